"""Numerical guards of the dive output-error fit: a replay beyond RK4's stability limit, a window
that blows up under a finite-difference nudge, a Jacobian column too large for ``JᵀJ``, and an
optimiser that ends at the minimum (large residuals, a drag at its bound)."""

import warnings

import numpy as np
import pytest

from uuvid.identify.vehicle.output_error import (
    BLOWN_UP,
    CONVERGED,
    blown_windows,
    covariance,
    levenberg_marquardt,
    not_identifiable,
)
from uuvid.simulate.dive_replay import RK4_LIMIT, WindowProblem


class _Channels:
    """The least a :class:`WindowProblem` reads: named channels ``(t, values)``."""

    def __init__(self, t, u, force):
        self.name = "synthetic"
        self.channels = {"u_mps": (t, u), "X_N": (t, force)}


def _surge_problem(n_windows=3, horizon=5.0):
    t = np.arange(0.0, n_windows * horizon + 1.0, 0.1)
    u = 0.5 + 0.1 * np.sin(t)
    wins = [(k * horizon, (k + 1) * horizon) for k in range(n_windows)]
    return WindowProblem(_Channels(t, u, np.zeros_like(t)), "surge", wins)


def test_rk4_limit_is_where_the_amplification_reaches_one():
    z = -RK4_LIMIT
    amp = 1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24
    assert abs(amp - 1.0) < 1e-3
    for zz in (-RK4_LIMIT + 0.05, -1.0, -0.1):
        assert abs(1 + zz + zz ** 2 / 2 + zz ** 3 / 6 + zz ** 4 / 24) < 1.0


@pytest.mark.parametrize("margin, grows", [(0.9, False), (1.1, True)])
def test_stiffness_says_when_the_replay_amplifies(margin, grows):
    """Linear drag only: the stiffness is ``h k / m`` exactly, and a replay from a nonzero
    velocity with no force decays below the limit and grows beyond it."""
    prob = _surge_problem()
    m = 10.0
    k = margin * RK4_LIMIT * m / prob.h
    theta = np.array([m, k, 0.0, 0.0])
    v0 = np.full(prob.W, 1.0)
    st = prob.stiffness(theta, v0, v0)
    assert np.allclose(st, prob.h * k / m, rtol=1e-12)
    _, V = prob.simulate(theta, v0, v0)
    assert (np.abs(V[:, -1]).max() > 1.0) == grows


def test_stiffness_counts_quadratic_drag_at_twice_its_rate():
    prob = _surge_problem()
    theta = np.array([10.0, 0.0, 4.0, 0.0])  # d(k_q v|v|)/dv = 2 k_q |v|
    v0 = np.full(prob.W, 2.0)
    st = prob.stiffness(theta, v0, v0)
    assert np.allclose(st, prob.h * 2 * 4.0 * 2.0 / 10.0, rtol=1e-12)  # largest |v| is the start


def test_blown_windows_zero_the_whole_window_only_in_that_direction():
    groups = np.repeat(np.arange(3), 4)
    delta = np.tile(np.linspace(0.1, 0.4, 4), 3)[:, None].repeat(2, axis=1)
    delta[4:6, 0] = [1e270, np.inf]      # window 1 overflows under perturbation 0: huge, then inf
    delta[9, 1] = 10 * BLOWN_UP          # window 2 grows past the bound under perturbation 1
    out, blown = blown_windows(delta, groups, 3)
    assert blown.tolist() == [False, True, True]
    assert np.all(out[4:8, 0] == 0) and np.all(out[4:8, 1] == delta[4:8, 1])
    assert np.all(out[8:12, 1] == 0) and np.all(out[8:12, 0] == delta[8:12, 0])
    assert np.all(out[0:4] == delta[0:4])
    same, none = blown_windows(delta[:4], groups[:4], 3)  # nothing blown: unchanged
    assert not none.any() and np.array_equal(same, delta[:4])


def test_covariance_is_scale_free_and_does_not_overflow():
    """Scaling a parameter by s scales its σ by 1/s: a column of 1e250 (σ 1e-250) gives finite
    numbers, no overflow warning, and the same correlations."""
    rng = np.random.default_rng(0)
    J = rng.normal(size=(200, 3))
    r = rng.normal(size=200) * 0.1
    groups = np.repeat(np.arange(20), 10)
    sd, corr = covariance(J, r, groups, 3)
    Js = J.copy()
    Js[:, 1] *= 1e250
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sd2, corr2 = covariance(Js, r, groups, 3)
    assert np.allclose(sd2 * [1, 1e250, 1], sd, rtol=1e-10)
    assert np.allclose(corr2, corr, atol=1e-12)
    # the classical part is s²(JᵀJ)⁻¹ with s² from the residuals
    s2 = r @ r / (200 - 3)
    assert np.all(sd >= np.sqrt(np.diag(s2 * np.linalg.inv(J.T @ J))) * (1 - 1e-12))


def test_covariance_of_a_non_finite_jacobian_is_nan_not_garbage():
    J = np.ones((10, 2))
    J[3, 1] = np.inf
    sd, corr = covariance(J, np.ones(10), np.zeros(10, int), 2)
    assert np.all(np.isnan(sd)) and np.all(np.isnan(corr))


@pytest.mark.parametrize("seed", range(8))
def test_covariance_of_an_undetermined_parameter_is_infinite_not_zero(seed):
    """A parameter whose Jacobian column is all zero (every window left out in its direction) or
    that trades off exactly against another gets σ = ∞ and a warning naming it; the determined
    parameters keep the σ they have without it (a pseudo-inverse reported σ = 0 for the zero
    column: a certainty the data do not give)."""
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(120, 4))
    r = rng.normal(size=120) * 0.1
    groups = np.repeat(np.arange(12), 10)
    sd_ref, _ = covariance(J[:, [0, 2, 3]], r, groups, 3)
    Jz = J.copy()
    Jz[:, 1] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sd, corr = covariance(Jz, r, groups, 4)
    assert np.isinf(sd[1]) and np.all(np.isfinite(sd[[0, 2, 3]]))
    assert np.allclose(sd[[0, 2, 3]], sd_ref, rtol=1e-9)
    assert np.all(np.isnan(np.delete(corr[1], 1))) and corr[1, 1] == 1.0
    names = ["mass", "linear", "quadratic", "bias"]
    warns = not_identifiable(names, dict(zip(names, sd)))
    assert len(warns) == 1 and warns[0].startswith("linear is not identifiable")
    # two columns that only act through their sum: both undetermined, the others not
    Jd = J.copy()
    Jd[:, 2] = 2.0 * Jd[:, 1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sd, _ = covariance(Jd, r, groups, 4)
    assert np.isinf(sd[1]) and np.isinf(sd[2]) and np.all(np.isfinite(sd[[0, 3]]))
    # a nuisance column (beyond n_glob) that is zero does not make the globals undetermined
    Jn = np.hstack([J, np.zeros((120, 1))])
    sd, _ = covariance(Jn, r, groups, 4)
    assert np.all(np.isfinite(sd))


def _numpy_replay(prob, theta, y0, v0):
    """The vectorised NumPy RK4 the compiled window replay replaced (over all windows at once)."""
    m, k, kq, b = theta[:4]
    ka = theta[4] if len(theta) > 4 else 0.0
    h, n = prob.h, prob.n
    X = np.empty((prob.W, n + 1))
    V = np.empty((prob.W, n + 1))
    x, v = np.array(y0, float), np.array(v0, float)
    if not prob.position:
        v = x.copy()
    X[:, 0], V[:, 0] = x, v
    inv = 1.0 / m
    Fh = prob.Fh
    K = k + ka * prob.Ch if ka != 0.0 else np.full(Fh.shape, float(k))
    for s in range(n):
        f0, f1, f2 = Fh[:, 2 * s], Fh[:, 2 * s + 1], Fh[:, 2 * s + 2]
        k0, k1, k2 = K[:, 2 * s], K[:, 2 * s + 1], K[:, 2 * s + 2]
        a1 = (f0 - k0 * v - kq * v * np.abs(v) + b) * inv
        v2 = v + 0.5 * h * a1
        a2 = (f1 - k1 * v2 - kq * v2 * np.abs(v2) + b) * inv
        v3 = v + 0.5 * h * a2
        a3 = (f1 - k1 * v3 - kq * v3 * np.abs(v3) + b) * inv
        v4 = v + h * a3
        a4 = (f2 - k2 * v4 - kq * v4 * np.abs(v4) + b) * inv
        x = x + h / 6 * (v + 2 * v2 + 2 * v3 + v4)
        v = v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        X[:, s + 1], V[:, s + 1] = x, v
    return (V if not prob.position else X), V


@pytest.mark.parametrize("seed", range(4))
def test_compiled_window_replay_is_the_numpy_form_bit_for_bit(seed):
    """Position (heave) and velocity (surge) windows, with and without the inflow term, a force
    that varies within each window: the compiled replay equals the NumPy form exactly."""
    from uuvid.simulate.dive_replay import WindowProblem

    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 41.0, 0.1)
    force = 20 * np.sin(0.7 * t) + rng.normal(0, 3, t.size)
    for dof, meas, fname in (("heave", "depth_m", "Z_N"), ("surge", "u_mps", "X_N")):
        dc = _Channels(t, 2 + 0.3 * np.sin(0.5 * t), force)
        dc.channels = {meas: (t, 2 + 0.3 * np.sin(0.5 * t)), fname: (t, force)}
        wins = [(a, a + 10.0) for a in (0.0, 10.0, 20.0, 30.0)]
        gain = (t, 100 + 50 * np.cos(t))
        prob = WindowProblem(dc, dof, wins, gain=gain)
        y0 = rng.normal(2, 0.2, prob.W)
        v0 = rng.normal(0, 0.3, prob.W)
        for theta in (np.array([30.0, 5.0, 40.0, -2.0]), np.array([30.0, 5.0, 40.0, -2.0, 0.01])):
            X, V = prob.simulate(theta, y0, v0)
            Xr, Vr = _numpy_replay(prob, theta, y0, v0)
            assert np.array_equal(X, Xr) and np.array_equal(V, Vr)


def test_loss_as_drag_weights_the_gain_by_the_speed():
    """c̄ is the |ν|-weighted mean of c(t): where the vehicle does not move the loss does not act
    as drag; k_a c̄ is the loss, k + k_a c̄ the drag a bollard model would report."""
    from uuvid.identify.vehicle.output_error import loss_as_drag, loss_as_drag_text

    c = np.array([100.0, 300.0, 200.0, 50.0])
    v = np.array([0.5, 0.0, -0.5, np.nan])  # a blown-up sample carries no weight
    s = loss_as_drag(c, v, 0.05, 0.001, 5.0, "rad/s")
    assert s["c_mean"] == pytest.approx(150.0, rel=1e-15)
    assert s["c_range"] == [50.0, 300.0]
    assert s["loss_as_drag"] == pytest.approx(7.5) and s["loss_as_drag_sigma"] == pytest.approx(0.15)
    assert s["apparent_linear"] == pytest.approx(12.5) and s["loss_fraction"] == pytest.approx(0.6)
    still = loss_as_drag(c, np.zeros(4), 0.05, 0.001, 5.0, "rad/s")  # no motion: the plain mean
    assert still["c_mean"] == pytest.approx(162.5)
    assert "= 150 rad/s" in loss_as_drag_text(s, "N·s/m") and "weighted mean" in \
        loss_as_drag_text(s, "N·s/m")
    assert loss_as_drag(c, v, 0.05, 0.001, 5.0, "rad/s", "N·s/m")["unit"] == "N·s/m"


def test_cluster_sandwich_is_the_leave_one_window_out_jackknife():
    """With per-window nuisance parameters (each window's own start) the plain cluster sandwich
    under-states a window's error (its start fits part of it away).  The σ is the jackknife's:
    refit with each window left out (its nuisance columns with it), σ² = (G − 1)/G Σ (θ₍g₎ − θ)²
    — exact for a linear problem (Sherman–Morrison–Woodbury); here built so the sandwich exceeds
    the classical σ (errors shared within a window), which the test asserts too."""
    rng = np.random.default_rng(7)
    G, n, K = 12, 15, 3
    groups = np.repeat(np.arange(G), n)
    X = rng.normal(size=(G * n, K)) + np.repeat(rng.normal(size=(G, K)), n, axis=0)
    t = np.tile(np.linspace(0, 1, n), G)
    nuis = np.zeros((G * n, 2 * G))  # each window's own offset and slope
    nuis[np.arange(G * n), 2 * groups] = 1.0
    nuis[np.arange(G * n), 2 * groups + 1] = t
    J = np.hstack([X, nuis])
    # a window's error: a shared part along its regressors (the sandwich's case) plus noise
    err = (X * np.repeat(rng.normal(size=(G, K)), n, axis=0)).sum(1) + 0.1 * rng.normal(size=G * n)
    theta, *_ = np.linalg.lstsq(J, err, rcond=None)
    r = err - J @ theta
    sd, _ = covariance(J, r, groups, K)
    loo = []
    for g in range(G):
        keep = groups != g
        cols = np.r_[np.arange(K), K + np.flatnonzero(np.arange(2 * G) // 2 != g)]
        th_g, *_ = np.linalg.lstsq(J[np.ix_(keep, cols)], err[keep], rcond=None)
        loo.append(th_g[:K])
    jack = np.sqrt((G - 1) / G * np.sum((np.array(loo) - theta[:K]) ** 2, axis=0))
    classical = np.sqrt(np.diag(r @ r / (G * n - J.shape[1]) * np.linalg.inv(J.T @ J))[:K])
    assert np.all(jack > 1.5 * classical)
    np.testing.assert_allclose(sd, jack, rtol=1e-8)


def _scipy_minimum(fun, x0, lower):
    from scipy.optimize import least_squares

    return least_squares(fun, x0, bounds=(lower, np.inf), xtol=1e-15, ftol=1e-15, gtol=1e-15,
                         max_nfev=10000, method="trf").x


def _fd_jac(fun):
    def jac(z):
        r0 = fun(z)
        J = np.empty((r0.size, z.size))
        for i in range(z.size):
            dz = 1e-7 * max(abs(z[i]), 1e-3)
            zz = z.copy()
            zz[i] += dz
            J[:, i] = (fun(zz) - r0) / dz
        return J
    return jac


@pytest.mark.parametrize("sparse", [False, True])
@pytest.mark.parametrize("seed", range(5))
def test_optimiser_reaches_a_large_residual_minimum(seed, sparse):
    """A decay ``a exp(−t/τ) + c`` fitted to data it does not describe (a second, slower decay
    and outliers): large residuals, where Gauss–Newton converges only linearly.  The optimiser
    ends converged, at the minimum scipy's trust-region solver finds with tolerances of 1e-15,
    within its own tolerance (√CONVERGED of σ; a test on one damped step's gain stopped up to
    1.5e-3 σ short here, and 0.1 σ short on a dive).  A sparse Jacobian (a dive's) is taken as
    the dense one."""
    from scipy.sparse import csr_matrix

    rng = np.random.default_rng(seed)
    t = np.linspace(0, 10, 400)
    y = 2 * np.exp(-t / 1.5) + 1.5 * np.exp(-t / 6.0) + rng.normal(0, 0.05, t.size)
    y[rng.choice(t.size, 20, replace=False)] += rng.normal(0, 1.0, 20)

    def fun(z):
        return z[0] * np.exp(-t / z[1]) + z[2] - y

    z0 = np.array([1.0, 0.5, 0.0])
    jac = _fd_jac(fun)
    sol = levenberg_marquardt(fun, (lambda z: csr_matrix(jac(z))) if sparse else jac, z0,
                              np.ones(3, bool), positive=(1,))
    assert sol["success"] and sol["message"] == "converged", sol["message"]
    best = _scipy_minimum(fun, z0, [-np.inf, 1e-9, -np.inf])
    J = _fd_jac(fun)(best)
    r = fun(best)
    sigma = np.sqrt(np.diag(r @ r / (t.size - 3) * np.linalg.inv(J.T @ J)))
    assert np.all(np.abs(sol["x"] - best) <= 2 * np.sqrt(CONVERGED) * sigma), (sol["x"], best, sigma)


@pytest.mark.parametrize("seed", range(5))
def test_optimiser_converges_with_a_drag_at_its_bound(seed):
    """Linear and quadratic drag of a steady speed that the data's quadratic law makes negative for
    the linear term: the minimum has the linear drag at its bound 0.  A projected step there only
    shortened the others' (the fit crawled to its iteration cap); the linear drag is held at 0 and
    the rest converges to the bounded minimum."""
    rng = np.random.default_rng(seed)
    v = np.linspace(0.05, 1.5, 200)
    force = 3.0 * v ** 2 - 0.4 * v + rng.normal(0, 0.05, v.size)

    def fun(z):
        return z[0] * v + z[1] * v * np.abs(v) - force

    z0 = np.array([1.0, 1.0])
    sol = levenberg_marquardt(fun, _fd_jac(fun), z0, np.ones(2, bool), positive=(), nonneg=(0, 1))
    assert sol["success"] and sol["message"] == "converged", (sol["message"], sol["nit"])
    assert sol["x"][0] == 0.0
    best = _scipy_minimum(fun, z0, [0.0, 0.0])
    assert abs(sol["x"][1] - best[1]) < 1e-6 * best[1], (sol["x"], best)


def test_a_start_whose_replay_is_refused_is_not_reported_converged():
    """A residual that is not finite at the start (a window's replay refused) and that no step
    changes: the cost is ∞, and "no step lowers the cost" must not be called converged (it was:
    ∞ ≤ 1e4·tol·∞), so the caller's "optimiser stopped" warning is given."""
    import numpy as np

    from uuvid.identify.vehicle.output_error import levenberg_marquardt

    def resid(z):
        return np.array([z[0] - 1.0, np.nan])  # the second window: refused whatever z is

    def jac(z):
        return np.array([[1.0], [0.0]])

    sol = levenberg_marquardt(resid, jac, np.array([3.0]), np.array([True]))
    assert not sol["success"]
