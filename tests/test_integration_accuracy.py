"""The compiled fixed-step RK4 chain simulation against ``scipy.integrate.solve_ivp``.

The reference integrates ``chain.rhs()`` with a tight stiff solver, the input held constant over
each output interval ``[n dt, (n+1) dt)`` exactly as the kernel holds it (zero-order hold), one
``solve_ivp`` call per run of equal input samples.  Channels are then evaluated with
``chain.evaluate`` at the reference states, so thrust (which for McLean's tunnel thruster depends
on the acceleration, eq. 2.12) is compared like for like.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from uuvid.simulate.signals import Sine, Step
from uuvid.thruster import presets

RTOL, ATOL = 1e-10, 1e-12


def reference_response(chain, signal, t_end, dt, method="Radau"):
    """Time grid and channels of ``chain`` on ``t = 0, dt, …, t_end`` from ``solve_ivp``."""
    n = round(t_end / dt) + 1
    t = np.arange(n) * dt
    u = np.asarray(signal(t), dtype=float)
    f = chain.rhs()
    x = np.zeros(chain.n_states)
    X = np.empty((n, chain.n_states))
    X[0] = x
    k = 0
    while k < n - 1:
        j = k + 1  # u[k] is held on [t_k, t_j): extend over equal samples
        while j < n - 1 and u[j] == u[k]:
            j += 1
        sol = solve_ivp(lambda tt, xx, uk=u[k]: f(tt, xx, uk), (t[k], t[j]), x, method=method,
                        rtol=RTOL, atol=ATOL, t_eval=t[k + 1:j + 1])
        assert sol.success, sol.message
        X[k + 1:j + 1] = sol.y.T
        x = sol.y[:, -1].copy()
        k = j
    chans: dict[str, list[float]] = {}
    for i in range(n):
        _, ch = chain.evaluate(X[i], u[i])
        for name, v in ch.items():
            chans.setdefault(name, []).append(v)
    return t, {name: np.asarray(v) for name, v in chans.items()}


def peak_relative_error(sim, ref):
    return float(np.max(np.abs(sim - ref)) / np.max(np.abs(ref)))


MCLEAN_STEP = Step(24.0)
MCLEAN_T_END = 1.333  # McLean's simulation length (Table I)


@pytest.fixture(scope="module")
def mclean_reference():
    chain = presets.auv2_rig_chain()
    return chain, reference_response(chain, MCLEAN_STEP, MCLEAN_T_END, 1e-3, method="Radau")


@pytest.mark.slow
def test_mclean_rig_24V_step_rk4_agrees_with_radau(mclean_reference):
    chain, (t, ref) = mclean_reference
    r = chain.simulate(MCLEAN_STEP, MCLEAN_T_END)  # default dt = 1e-3, substeps = 4
    np.testing.assert_array_equal(r.t, t)
    for name in ("thrust", "measured_thrust"):
        assert peak_relative_error(r[name], ref[name]) < 1e-4, name
    for name in ("motor_speed", "prop_speed", "current", "torque"):
        assert peak_relative_error(r[name], ref[name]) < 1e-4, name
    # the reference itself reproduces McLean's leading response: spike, then decay
    assert np.argmax(ref["thrust"]) == 0
    assert ref["measured_thrust"].max() > ref["thrust"].max()  # load-cell overshoot (ζ = 0.16)


@pytest.mark.slow
def test_mclean_rig_rk4_converges_at_fourth_order(mclean_reference):
    chain, (_, ref) = mclean_reference
    errs = []
    for substeps in (1, 2, 4):  # h = 1e-3, 5e-4, 2.5e-4 on the same output grid
        r = chain.simulate(MCLEAN_STEP, MCLEAN_T_END, dt=1e-3, substeps=substeps)
        errs.append(peak_relative_error(r["measured_thrust"], ref["measured_thrust"]))
    # RK4: halving the step divides the error by 2^4 = 16 (accept >= 8)
    assert errs[0] / errs[1] >= 8.0, errs
    assert errs[1] / errs[2] >= 8.0, errs
    assert errs[0] / errs[1] <= 32.0, errs


@pytest.mark.slow
def test_mclean_rig_halving_output_dt_also_converges(mclean_reference):
    chain, (_, ref) = mclean_reference
    coarse = chain.simulate(MCLEAN_STEP, MCLEAN_T_END, dt=2e-3, substeps=1)
    fine = chain.simulate(MCLEAN_STEP, MCLEAN_T_END, dt=1e-3, substeps=1)
    # compare on the common grid (every 2nd sample of the fine/reference run; the step input is
    # the same constant on both grids, so the held inputs agree)
    e_coarse = peak_relative_error(coarse["measured_thrust"], ref["measured_thrust"][::2])
    e_fine = peak_relative_error(fine["measured_thrust"][::2], ref["measured_thrust"][::2])
    assert e_coarse / e_fine >= 8.0


LAIDANI_SINE = Sine(offset=1500.0, amplitude=400.0, period=2.0)


@pytest.mark.slow
def test_laidani_chain_sinusoidal_pwm_agrees_with_lsoda():
    chain = presets.laidani_chain()
    dt = 2e-3
    _, ref = reference_response(chain, LAIDANI_SINE, 2.0, dt, method="LSODA")
    r = chain.simulate(LAIDANI_SINE, 2.0, dt=dt)
    # the PWM visits the dead zone, both linear zones and both saturations
    cmd = r["command"]
    assert cmd.max() > 1800.0 and cmd.min() < 1200.0
    assert np.any(r["voltage"] == 0.0)
    assert peak_relative_error(r["motor_speed"], ref["motor_speed"]) < 1e-6
    assert peak_relative_error(r["thrust"], ref["thrust"]) < 1e-6
    np.testing.assert_array_equal(r["voltage"], ref["voltage"])


@pytest.mark.slow
def test_laidani_chain_sinusoidal_pwm_agrees_with_radau_at_default_dt():
    chain = presets.laidani_chain()
    _, ref = reference_response(chain, LAIDANI_SINE, 1.0, 1e-3, method="Radau")
    r = chain.simulate(LAIDANI_SINE, 1.0)
    assert peak_relative_error(r["thrust"], ref["thrust"]) < 1e-6


def test_rhs_is_the_kernel_right_hand_side():
    chain = presets.auv2_rig_chain()
    f = chain.rhs()
    x = np.array([120.0, 3.0, -10.0])
    dx, _ = chain.evaluate(x, 24.0)
    np.testing.assert_array_equal(f(0.0, x, 24.0), dx)
    assert chain.n_states == 3 and dx.shape == (3,)
