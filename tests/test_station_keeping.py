"""LQR on the linearised BlueROV2 against the PID DP, in one compiled station-keeping loop."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from uuvid.simulate.control.lqr import augment_integral, default_weights, lqr_gain
from uuvid.simulate.station_keeping import compare_station_keeping, fly_station
from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.linearize import linearize
from uuvid.vehicle.model import vehicle_rhs_reference


@pytest.fixture(scope="module")
def rov():
    return load_vehicle("bluerov2")


@pytest.fixture(scope="module")
def comparison(rov):
    return compare_station_keeping(rov)


@pytest.mark.slow
def test_loop_integrates_the_vehicle_model(rov):
    # open loop (K = 0): constant thrusts f0 in a current; the compiled RK4 loop must follow an
    # adaptive solution of the NumPy reference model
    f0 = np.array([5.0, -3.0, 4.0, 2.0, -6.0, 1.0])
    cur = np.array([0.2, -0.1, 0.0])
    x0 = linearize(rov).x0
    run = fly_station(rov, "lqr", x_ref=x0, z0=x0, current=cur, K=np.zeros((6, 16)), f0=f0,
                      duration=5.0, dt=0.01)
    tau = rov.B @ f0
    sol = solve_ivp(lambda t, x: vehicle_rhs_reference(x, tau, rov.params, current_ned=cur),
                    (0, run.t[-1]), x0, t_eval=run.t, rtol=1e-10, atol=1e-12)
    ref = sol.y.T.copy()
    # q and −q are one attitude (the loop keeps η ≥ 0)
    ref[:, 3:7] *= np.sign(np.sum(ref[:, 3:7] * run.state[:, 3:7], axis=1))[:, None]
    assert np.abs(ref[:, 3:7] - sol.y.T[:, 3:7]).max() > 1  # the vehicle did turn past 180°
    np.testing.assert_allclose(run.state, ref, atol=1e-7)


def test_lqr_gain_equals_python_control(rov):
    control = pytest.importorskip("control")
    lin = linearize(rov)
    A, B = augment_integral(lin)
    Q, R = default_weights(lin)
    K_ctrl, _, E = control.lqr(A, B, Q, R)
    K = lqr_gain(A, B, Q, R)
    np.testing.assert_allclose(K, K_ctrl, rtol=1e-8, atol=1e-10 * np.abs(K).max())
    assert np.all(np.linalg.eigvals(A - B @ K).real < 0)


def test_small_offset_follows_the_linear_closed_loop(rov):
    # 2 mm / 2 mrad offset, no current: the nonlinear loop and the exact zero-order-hold
    # discretisation of the linear model under the same LQI law agree to second order
    lin = linearize(rov)
    A, B = augment_integral(lin)
    Q, R = default_weights(lin)
    K = lqr_gain(A, B, Q, 30 * R)
    dt, N = 0.01, 600
    eps = 2e-3
    z0 = lin.full_state(np.r_[eps, -eps, eps, 0, 0, eps, np.zeros(6)])
    run = fly_station(rov, "lqr", x_ref=lin.x0, z0=z0, K=K, f0=lin.thrust0, duration=N * dt,
                      dt=dt, substeps=4)
    M = expm(np.block([[lin.A, lin.B], [np.zeros((6, 18))]]) * dt)
    Phi, Gam = M[:12, :12], M[:12, 12:]
    xi = lin.deviation(z0)
    integ = np.zeros(4)
    traj = []
    for _ in range(N):
        traj.append(xi.copy())
        u = -K @ np.r_[xi, integ]
        integ = integ + xi[[0, 1, 2, 5]] * dt
        xi = Phi @ xi + Gam @ u
    lin_pos = np.array(traj)[:, :3]
    sim_pos = run.state[:, :3] - lin.x0[:3]
    assert np.abs(sim_pos).max() > 0.5 * eps
    assert np.abs(sim_pos - lin_pos).max() < 0.02 * eps  # O(eps²) nonlinearity, not O(eps)


def test_comparison_at_equal_peak_thrust(comparison):
    c = comparison
    assert abs(c.lqr.peak_thrust - c.pid.peak_thrust) <= 0.01 * c.pid.peak_thrust
    # both hold station in the unknown current (integral action); the verdict is the numbers'
    assert c.pid.final_error < 0.01 and c.lqr.final_error < 0.01
    assert c.lqr_better == (c.lqr.rms_error < c.pid.rms_error)
    text = c.summary()
    assert ("LQR holds station with the smaller" in text) == c.lqr_better
    d = c.to_dict()
    assert d["pid"]["rms_position_error_m"] == pytest.approx(c.pid.rms_error)
    assert c.plot() is not None


@pytest.mark.slow
def test_the_lqi_step_gets_one_signature_from_station_keeping_and_missions(rov, comparison):
    """The LQI step serves the station-keeping loop and the mission loop's LQR controller, whose
    parameters (gain, trim, limits) are frozen, read-only: the station loop passes them read-only
    too, so the step is compiled for one signature, not once per loop."""
    from uuvid.simulate.control.lqr import lqr
    from uuvid.simulate.station_keeping import station_loop

    assert not lqr(rov).params.flags.writeable
    (sig,) = station_loop.signatures
    for i, name in ((4, "lo"), (5, "hi"), (9, "K"), (11, "f0")):
        assert not sig[i].mutable, f"{name} reaches lqi_step writable: {sig[i]}"

