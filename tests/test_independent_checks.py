"""Core formulas checked against independent implementations (hand OLS, a hand battery solution,
finite differences) and behaviours (anti-windup, η₋): each test here killed a mutant of the core
that the rest of the suite let live (σ² with n instead of n − p, σ × 1.1, the battery's IR drop
sign, halved internal resistance, a dropped hotel load, anti-windup removed, η₋ ignored, the
errors-in-variables correction halved, the drag covariance propagated without k_q)."""

import dataclasses
import math

import numpy as np
import pytest

from uuvid.identify.fit import linear_lsq, nonlinear_lsq


# ---------------------------------------------------------------------------------- σ formulas
def _data(seed=3, n=9):
    rng = np.random.default_rng(seed)
    X = np.column_stack([np.ones(n), rng.uniform(-2, 2, n), rng.uniform(0, 5, n)])
    y = X @ [1.0, -0.7, 0.3] + rng.normal(0, 0.4, n)
    return X, y


def _hand_ols(X, y):
    """Textbook OLS, no uuvid code: β = (XᵀX)⁻¹Xᵀy, s² = RSS/(n − p), cov = s²(XᵀX)⁻¹."""
    n, p = X.shape
    beta = np.linalg.solve(X.T @ X, X.T @ y)
    r = y - X @ beta
    s2 = float(r @ r) / (n - p)
    return beta, s2, s2 * np.linalg.inv(X.T @ X), r


def test_linear_lsq_classical_sigma_is_textbook_ols():
    X, y = _data()
    beta, s2, cov, _ = _hand_ols(X, y)
    f = linear_lsq(X, y, ["a", "b", "c"], emit_warnings=False)
    np.testing.assert_allclose([p.value for p in f.parameters], beta, rtol=1e-10)
    np.testing.assert_allclose([p.stderr for p in f.parameters], np.sqrt(np.diag(cov)), rtol=1e-9)
    np.testing.assert_allclose(f.covariance, cov, rtol=1e-9, atol=1e-15)
    assert f.sigma2 == pytest.approx(s2, rel=1e-10)  # the Fit property: |e|²/(n − p)
    assert f.extra["sigma2"] == pytest.approx(s2, rel=1e-10)
    assert f.dof == X.shape[0] - X.shape[1]


def test_linear_lsq_weighted_sigma_is_textbook_wls():
    X, y = _data(seed=5, n=11)
    w = np.linspace(0.5, 3.0, X.shape[0])
    sw = np.sqrt(w)
    beta, _, cov, _ = _hand_ols(X * sw[:, None], y * sw)
    f = linear_lsq(X, y, ["a", "b", "c"], weights=w, emit_warnings=False)
    np.testing.assert_allclose([p.value for p in f.parameters], beta, rtol=1e-10)
    np.testing.assert_allclose([p.stderr for p in f.parameters], np.sqrt(np.diag(cov)), rtol=1e-9)


@pytest.mark.parametrize("cov_type", ["HC0", "HC3", "HAC"])
def test_linear_lsq_robust_covariances_by_hand(cov_type):
    X, y = _data(seed=7, n=14)
    n, p = X.shape
    beta, _, _, r = _hand_ols(X, y)
    bread = np.linalg.inv(X.T @ X)
    if cov_type == "HC0":
        meat = sum(r[i] ** 2 * np.outer(X[i], X[i]) for i in range(n))
    elif cov_type == "HC3":
        h = [X[i] @ bread @ X[i] for i in range(n)]
        meat = sum((r[i] / (1 - h[i])) ** 2 * np.outer(X[i], X[i]) for i in range(n))
    else:
        L = 2
        meat = sum(r[i] ** 2 * np.outer(X[i], X[i]) for i in range(n))
        for lag in range(1, L + 1):
            w = 1 - lag / (L + 1)
            g = sum(r[i] * r[i - lag] * np.outer(X[i], X[i - lag]) for i in range(lag, n))
            meat = meat + w * (g + g.T)
    cov = bread @ meat @ bread * n / (n - p)
    f = linear_lsq(X, y, ["a", "b", "c"], cov_type=cov_type,
                   hac_lags=2 if cov_type == "HAC" else None, emit_warnings=False)
    np.testing.assert_allclose([q.stderr for q in f.parameters], np.sqrt(np.diag(cov)), rtol=1e-9)


def test_nonlinear_lsq_sigma_on_a_linear_model_is_textbook_ols():
    """A model linear in θ, started away from the answer: the optimum and σ are OLS's."""
    X, y = _data(seed=11, n=10)
    beta, s2, cov, _ = _hand_ols(X, y)
    f = nonlinear_lsq(lambda th: X @ th - y, [5.0, 5.0, -5.0], ["a", "b", "c"], jac=lambda th: X,
                      emit_warnings=False)
    np.testing.assert_allclose([p.value for p in f.parameters], beta, rtol=1e-7)
    np.testing.assert_allclose([p.stderr for p in f.parameters], np.sqrt(np.diag(cov)), rtol=1e-6)
    assert f.extra["sigma2"] == pytest.approx(s2, rel=1e-8)


# ------------------------------------------------------------------------------------ battery
class _OhmicThrusters:
    """A stand-in thruster: each draws ``a·|T|`` amps whatever the voltage, limits ±100 N."""

    a = 0.8

    def limits(self, voltage):
        return (-100.0, 100.0)

    def current(self, thrust, voltage):
        return self.a * np.abs(np.asarray(thrust, float))


def _battery(**kw):
    from uuvid.vehicle.power import Battery

    base = dict(name="test", capacity_ah=10.0, ocv_soc=(0.0, 1.0), ocv_voltage=(12.0, 16.8),
                resistance=0.05, hotel_load_w=40.0)
    base.update(kw)
    return Battery(**base)


@pytest.mark.parametrize("soc,thrusts", [(0.5, [10.0, -20.0, 5.0]), (0.9, [0.0, 0.0, 0.0]),
                                         (0.2, [60.0, 60.0, -60.0, -60.0])])
def test_battery_supply_by_hand(soc, thrusts):
    """``V = OCV − R(I_T + P/V)`` is the quadratic ``V² − (OCV − R I_T)V + R P = 0``: its larger
    root, solved here by hand, is what ``Battery.supply`` must give."""
    b = _battery()
    ocv = 12.0 + 4.8 * soc
    i_t = _OhmicThrusters.a * sum(abs(t) for t in thrusts)
    e = ocv - b.resistance * i_t
    v = (e + math.sqrt(e * e - 4 * b.resistance * b.hotel_load_w)) / 2
    got_v, got_i = b.supply(soc, thrusts, _OhmicThrusters())
    assert got_v == pytest.approx(v, abs=1e-7)
    assert got_i == pytest.approx(i_t + b.hotel_load_w / v, rel=1e-7)
    assert b.terminal(soc, 10.0) == pytest.approx(ocv - 0.5, abs=1e-12)  # 10 A × 0.05 Ω below


def test_flown_battery_obeys_its_equations():
    """On a flight with a battery, every step: V = OCV(SOC) − R·I(previous step) (inside the
    table's grid), I − P_hotel/V is the thrusters' draw (which the hotel load does not change),
    and SOC falls by I·dt/(3600 Q)."""
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
    from uuvid.vehicle.definition import load_vehicle

    v = load_vehicle("bluerov2")
    runs = {}
    for hotel in (0.0, 150.0):
        bat = dataclasses.replace(v.battery, resistance=0.06, hotel_load_w=hotel)
        s = setup_mission(v, square_mission(speed=0.3), t_end=3.0, battery=bat, soc0=0.5)
        runs[hotel] = (bat, s, fly_mission(s))
    for hotel, (bat, s, r) in runs.items():
        V, amps, soc = r.supply[:, 0], r.supply[:, 1], r.supply[:, 2]
        ocv = np.interp(soc, bat.ocv_soc, bat.ocv_voltage)
        np.testing.assert_allclose(V[1:], ocv[1:] - bat.resistance * amps[:-1], rtol=1e-9)
        assert V[0] == pytest.approx(ocv[0])
        assert np.min(V) > s.battery_array[8 + 2 * len(bat.ocv_soc)] + 0.5  # inside the grid
        np.testing.assert_allclose(np.diff(soc), -amps[:-1] * s.dt / (3600 * bat.capacity_ah),
                                   rtol=1e-9, atol=1e-15)
        assert np.all(amps >= hotel / V - 1e-12)
    (_, _, r0), (_, _, r1) = runs[0.0], runs[150.0]
    # the first step flies the same commands in both: the currents differ by the hotel load
    assert r1.supply[0, 1] - r0.supply[0, 1] == pytest.approx(150.0 / r1.supply[0, 0], rel=1e-9)
    assert r1.supply[-1, 0] < r0.supply[-1, 0] - 0.5 * 0.06 * 150.0 / 16.8


# ----------------------------------------------------------------------- inertia regression
def _sine_record(seed=0, k=46.9, k_q=306.2, m=890.0, noise=0.02):
    from uuvid.identify.vehicle.fit import simulate_one_dof
    from uuvid.vehicle.model import OneDofModel

    dt = 0.3
    t = np.arange(0.0, 90.0, dt)
    phi = 35.0 + 25.0 * np.sin(2 * np.pi * t / 26.0)
    xi = simulate_one_dof(OneDofModel(m, k, k_q), t, phi, 0.0)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (xi[1:] + xi[:-1]) * dt)])
    x = x + np.random.default_rng(seed).normal(0, noise, t.size)
    return t, x, phi


def test_errors_in_variables_correction_by_hand():
    """θ̂ = (HᵀH − N σ_v² e₁e₁ᵀ)⁻¹Hᵀy with σ_v² = σ_x² Σc² of the Savitzky–Golay derivative
    coefficients (computed here with scipy, from the given position noise)."""
    from scipy.signal import savgol_coeffs

    from uuvid.identify.vehicle.fit import fit_inertia

    t, x, phi = _sine_record()
    sx = 0.02
    r = fit_inertia(t, x, phi, k=46.9, k_q=306.2, window=21, clean=False,
                    velocity_noise_correction=True, position_noise=sx)
    c = savgol_coeffs(21, 4, deriv=1, delta=0.3, use="dot")
    var_v = sx**2 * float(c @ c)
    H = np.column_stack([r.velocity, -np.ones(r.t.size), -(r.t - r.t[0])])
    A = H.T @ H
    A[0, 0] -= r.t.size * var_v
    theta = np.linalg.solve(A, H.T @ r.y)
    assert r.fit["m"].value == pytest.approx(theta[0], rel=1e-9)
    plain = np.linalg.lstsq(H, r.y, rcond=None)[0]
    assert r.fit.extra["m_uncorrected"] == pytest.approx(plain[0], rel=1e-9)
    assert r.fit["m"].value > plain[0]  # the correction undoes the attenuation towards zero


def test_drag_covariance_propagated_through_k_and_k_q_by_finite_differences():
    """θ̂ is linear in (k, k_q): refitting at shifted drag gives ∂θ̂/∂(k, k_q) by differences,
    and σ_drag² = diag(J D Jᵀ) for a covariance D with a k_q variance and a k–k_q correlation."""
    from uuvid.identify.vehicle.fit import fit_inertia

    t, x, phi = _sine_record(seed=1)
    kw = dict(window=21, clean=False)
    k, kq = 46.9, 306.2
    D = np.array([[9.0, -60.0], [-60.0, 2500.0]])
    r = fit_inertia(t, x, phi, k=k, k_q=kq, drag_cov=D, **kw)

    def theta(kk, qq):
        f = fit_inertia(t, x, phi, k=kk, k_q=qq, **kw).fit
        return np.array([f[n].value for n in ("m", "c", "b")])

    base = theta(k, kq)
    J = np.column_stack([(theta(k + 1.0, kq) - base) / 1.0, (theta(k, kq + 10.0) - base) / 10.0])
    want = np.sqrt(np.diag(J @ D @ J.T))
    got = [r.fit.extra["sigma_drag"][n] for n in ("m", "c", "b")]
    np.testing.assert_allclose(got, want, rtol=1e-6)
    ls = r.fit.extra["sigma_ls"]
    np.testing.assert_allclose([r.fit[n].stderr for n in ("m", "c", "b")],
                               np.sqrt(np.array([ls[n] for n in ("m", "c", "b")]) ** 2 + want**2),
                               rtol=1e-6)


# -------------------------------------------------------------------------------- anti-windup
@pytest.mark.slow
def test_dp_control_stops_integrating_while_saturated_towards_the_error():
    """Conditional integration: saturated in the error's direction → the integrator holds;
    saturated against the error, or unsaturated → it integrates e·dt."""
    from uuvid.simulate.control.pid import dp_control

    gains = np.zeros((6, 4))
    gains[0], gains[1], gains[2] = 100.0, 10.0, 0.0  # kp, ki, kd
    gains[3], gains[4] = 50.0, np.inf  # tau_max, i_limit
    dt = 0.1
    e = np.array([2.0, 0.1, -2.0, 0.3])  # kp·e: 200 (sat, +), 10, −200 (sat, −), 30
    integ = np.array([0.5, 0.5, -0.5, -4.0])  # the yaw term: 30 − 40 → unsaturated
    tau, new = np.zeros(6), np.zeros(4)
    dp_control(e, np.zeros(4), integ, gains, dt, tau, new)
    np.testing.assert_allclose(new, [0.5, 0.5 + 0.01, -0.5, -4.0 + 0.03])
    assert tau[0] == 50.0 and tau[2] == -50.0  # clipped to tau_max
    # saturated, but the error now points back: integrating helps unwind, so it integrates
    e2 = np.array([-0.1, 0.0, 0.1, 0.0])
    integ2 = np.array([10.0, 0.0, -10.0, 0.0])  # ki·integ = ±100 ≥ tau_max
    dp_control(e2, np.zeros(4), integ2, gains, dt, tau, new)
    np.testing.assert_allclose(new[[0, 2]], [10.0 - 0.01, -10.0 + 0.01])


# ------------------------------------------------------------------------------------- η₋
@pytest.mark.parametrize("chain", [None, "yoerger"], ids=["first-order-exact", "rk4-chain"])
def test_negative_thrust_is_scaled_by_eta_neg_in_the_flight_loop(chain):
    """Two flights that differ only in the dynamics' η₋ (the allocation is the same): the
    controller's first commands are identical, so two steps in each thruster gives the same raw
    thrust and the delivered thrust is η₋ times it where negative, unchanged where positive."""
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
    from uuvid.thruster.blocks import QuadraticMap, Yoerger
    from uuvid.thruster.chain import ThrusterChain
    from uuvid.vehicle.definition import load_vehicle

    v = load_vehicle("bluerov2")
    thr = None
    if chain == "yoerger":
        thr = ThrusterChain((Yoerger(alpha=2.0, beta=4.0), QuadraticMap.basic(1.0)),
                            input_kind="command")
    s = setup_mission(v, square_mission(speed=0.3), t_end=0.05, thruster_chain=thr)
    pos = s.ref[0].copy()
    pos[1:] += np.array([1.0, -1.0, 0.5])  # the reference jumps after the first step
    s = dataclasses.replace(s, ref=(pos,) + tuple(s.ref[1:]))
    a = fly_mission(s).thrust[2]
    b = fly_mission(dataclasses.replace(s, eta_n=0.5 * s.eta_n)).thrust[2]
    assert np.any(a < -1e-3) and np.any(a > 1e-3), a
    np.testing.assert_allclose(b, np.where(a < 0, 0.5 * a, a), rtol=1e-12, atol=1e-15)
