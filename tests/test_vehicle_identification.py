"""Vehicle identification from on-board sensors (Caccia et al. 2000): segments, robust velocities,
drag + installation coefficients with model reduction, heave ballast, inertia, validation."""

import math

import numpy as np
import pytest

from uuvid.identify.vehicle.fit import (
    EIV_NOTE,
    SteadyPoint,
    eta_label,
    fit_drag,
    fit_inertia,
    phase_lag,
    predicted_phase_lag,
    simulate_one_dof,
    steady_points_from_log,
    validate_one_dof,
)
from uuvid.identify.vehicle.segments import (
    clean_series,
    find_segments,
    robust_unwrap,
    savgol_velocity,
    segment_velocity,
    summarise_rejections,
)
from uuvid.vehicle.model import OneDofModel, steady_speed


# ------------------------------------------------------------------------------- segments
def test_robust_velocity_flags_injected_outliers_and_missing():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 30.0, 0.3)  # 3.33 Hz echo-sounder
    x = 2.0 + 0.25 * t + rng.normal(0, 0.02, t.size)
    outliers = [5, 17, 40, 41]
    x[outliers] += [1.5, 2.0, -0.8, 2.5]  # multipath echoes
    missing = [60, 61, 62, 80]
    x[missing] = np.nan
    sv = segment_velocity(t, x)
    got = {r.index: r.reason for r in sv.rejected}
    assert {i for i, r in got.items() if r == "outlier"} == set(outliers)
    assert {i for i, r in got.items() if r == "missing"} == set(missing)
    assert sv.n_used == t.size - len(outliers) - len(missing)
    assert abs(sv.velocity - 0.25) < 3 * sv.stderr
    assert sv.relative_error < 0.03  # Caccia: σ_v < 3 % of v
    assert sv.settled
    rep = sv.summary()
    assert "4 outliers" in rep and "#17" in rep
    assert not sv.used[5] and sv.used[6]
    s = summarise_rejections([sv, sv])
    assert s["outliers"] == 8 and s["missing"] == 8


def test_plain_ls_would_be_biased_by_the_outliers():
    t = np.arange(0.0, 20.0, 0.3)
    x = 0.2 * t
    x[30:36] += 3.0  # a burst of multipath
    sv = segment_velocity(t, x)
    assert sv.velocity == pytest.approx(0.2, abs=1e-9)
    assert sv.n_outliers == 6
    assert abs(np.polyfit(t, x, 1)[0] - 0.2) > 1e-3


def test_unsettled_segment_is_reported():
    t = np.arange(0.0, 20.0, 0.1)
    x = 0.3 * t - 1.5 * np.exp(-t / 5.0)  # still accelerating
    x = x + np.random.default_rng(0).normal(0, 0.002, t.size)
    sv = segment_velocity(t, x)
    assert not sv.settled
    assert "NOT SETTLED" in sv.summary()


def test_heading_wraparound_with_gap_and_spike():
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 40.0, 0.1)  # 10 Hz compass
    rate = math.radians(15.0)
    psi = math.radians(350.0) + rate * t + rng.normal(0, 0.005, t.size)
    wrapped = np.mod(psi, 2 * np.pi)
    wrapped[100:130] = np.nan  # 3 s gap
    wrapped[200] = 0.3  # magnetic spike
    un = robust_unwrap(t, wrapped)
    ok = np.isfinite(un)
    assert np.all(np.abs(np.diff(un[ok])) < np.pi)  # no 2π jumps (the spike stays a spike)
    sv = segment_velocity(t, wrapped, angle=True)
    assert sv.velocity == pytest.approx(rate, rel=1e-3)
    outl = {r.index for r in sv.rejected if r.reason == "outlier"}
    assert sv.n_missing == 30 and 200 in outl and len(outl) <= 2  # ≤ 1 false alarm at 3.5 MAD
    svd = segment_velocity(t, np.degrees(wrapped), angle=True, angle_unit="deg")
    assert svd.velocity == pytest.approx(15.0, rel=1e-3)


def test_find_segments_levels_modes_settle():
    t = np.arange(0.0, 100.0, 0.1)
    u = np.where(t < 30, 10.0, np.where(t < 60, -5.0, np.where(t < 61, 0.0, 3.0)))
    modes = ["a" if ti < 80 else "b" for ti in t]
    segs = find_segments(t, u, min_duration=5.0, settle=10.0, mode=modes)
    assert [s.level for s in segs] == [10.0, -5.0, 3.0, 3.0]
    assert [s.mode for s in segs] == ["a", "a", "a", "b"]
    assert segs[0].t0 == pytest.approx(10.0) and segs[1].t0 == pytest.approx(40.0)
    # the zero segment only with include_zero, and only if long enough
    assert len(find_segments(t, u, min_duration=0.5, include_zero=True)) == 4
    # small command noise within the tolerance does not split a segment
    un = u + np.random.default_rng(0).normal(0, 0.01, u.size)
    assert len(find_segments(t, un, min_duration=5.0, settle=10.0, tol=0.1)) == 3


@pytest.mark.parametrize("kw, msg", [({"min_duration": 0.0}, "min_duration"),
                                     ({"min_duration": 1.0, "settle": -1.0}, "settle")])
def test_find_segments_bad_input(kw, msg):
    with pytest.raises(ValueError, match=msg):
        find_segments(np.arange(5.0), np.ones(5), **kw)
    with pytest.raises(ValueError, match="same shape"):
        find_segments(np.arange(5.0), np.ones(4), min_duration=1.0)
    with pytest.raises(ValueError, match="increasing"):
        find_segments(np.array([0.0, 2.0, 1.0]), np.ones(3), min_duration=1.0)


def test_segment_velocity_bad_input():
    t = np.arange(10.0)
    with pytest.raises(ValueError, match="finite samples"):
        segment_velocity(t, np.full(10, np.nan))
    with pytest.raises(ValueError, match="empty window"):
        segment_velocity(t, t, 5.0, 2.0)
    with pytest.raises(ValueError, match="angle_unit"):
        segment_velocity(t, t, angle=True, angle_unit="grad")


# ------------------------------------------------------------------------------- Savitzky–Golay
@pytest.mark.parametrize("window", [21, 41])
def test_savgol_velocity_exact_for_quartic_with_interp_edges(window):
    t = np.arange(0.0, 12.0, 0.1)
    x = 0.3 * t**4 - t**3 + 2 * t + 1
    v = savgol_velocity(t, x, order=4, window=window, edge="interp")
    assert np.allclose(v, 1.2 * t**3 - 3 * t**2 + 2, atol=1e-6 * np.abs(v).max())


def test_savgol_velocity_edge_modes():
    t = np.arange(0.0, 10.0, 0.1)
    x = np.sin(t)
    vn = savgol_velocity(t, x, window=21, edge="nan")
    assert np.isnan(vn[:10]).all() and np.isnan(vn[-10:]).all() and np.isfinite(vn[10:-10]).all()
    vs = savgol_velocity(t, x, window=21, edge="shrink")
    vi = savgol_velocity(t, x, window=21, edge="interp")
    assert np.allclose(vs[10:-10], vi[10:-10]) and np.allclose(vs[10:-10], np.cos(t[10:-10]), atol=5e-3)
    assert np.isfinite(vs).all()
    assert np.max(np.abs(vs - np.cos(t))) < 0.06


@pytest.mark.parametrize("kw, msg", [({"window": 20}, "odd"), ({"window": 3, "order": 4}, "odd"),
                                     ({"edge": "mirror"}, "edge"), ({"window": 301}, "longer")])
def test_savgol_velocity_bad_input(kw, msg):
    t = np.arange(0.0, 10.0, 0.1)
    with pytest.raises(ValueError, match=msg):
        savgol_velocity(t, np.sin(t), **kw)


def test_savgol_velocity_needs_uniform_finite_data():
    t = np.arange(0.0, 10.0, 0.1)
    x = np.sin(t)
    x[5] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        savgol_velocity(t, x, window=21)
    t2 = t.copy()
    t2[50] += 0.03
    with pytest.raises(ValueError, match="uniform"):
        savgol_velocity(t2, np.sin(t2), window=21)


def test_clean_series_flags_and_fills():
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 60.0, 0.3)
    truth = 0.27 * t + 0.3 * np.sin(2 * np.pi * t / 26)
    x = truth + rng.normal(0, 0.02, t.size)
    x[[40, 90]] += [1.8, -0.9]
    x[150:160] = np.nan
    cs = clean_series(t, x, window=21)
    assert {r.index for r in cs.rejected if r.reason == "outlier"} == {40, 90}
    assert cs.n_missing == 10 and cs.n_outliers == 2
    assert np.all(np.isfinite(cs.x))
    assert np.max(np.abs(cs.x - truth)) < 0.1
    # samples absent (not NaN) are put back on the grid as missing
    keep = np.ones(t.size, bool)
    keep[150:160] = False
    cs2 = clean_series(t[keep], x[keep], window=21)
    assert cs2.t.size == t.size and cs2.n_missing == 10


# ------------------------------------------------------------------------------- drag fit
def _points(truth, rng=None, noise=0.0, modes=(("open", None), ("hull", "eta_hull"), ("all", "eta_prop")),
            levels=(5, 10, 20, 30, 45, 60), relative=False):
    """Steady points; ``noise``: force noise, additive (N) or relative to the force."""
    pts = []
    for mode, e in modes:
        eta = 1.0 if e is None else truth[e]
        for lv in levels:
            for sgn in (1, -1):
                f = sgn * lv
                dn = noise * rng.normal() if noise else 0.0
                F = eta * f * (1 + dn if relative else 1) + (0 if relative else dn) + truth["w"]
                v = steady_speed(truth["k"], truth["k_q"], F)
                pts.append(SteadyPoint(float(v), float(f), e, mode=mode))
    return pts


def test_fit_drag_recovers_exact_parameters():
    truth = {"k": 46.9, "k_q": 306.2, "eta_hull": 0.73, "eta_prop": 0.6, "w": 0.4}
    fit = fit_drag(_points(truth), dof="surge")
    for n, v in truth.items():
        assert fit.fit[n].value == pytest.approx(v, rel=1e-8, abs=1e-9)
    assert fit.reduced_to is None and fit.quadratic_significant
    assert EIV_NOTE in fit.notes
    assert fit.fit["k"].unit == "N·s/m"
    assert fit.steady_speed(20.0, "eta_hull") == pytest.approx(
        steady_speed(46.9, 306.2, 0.73 * 20 + 0.4))
    m = fit.one_dof_model(890.0, None, "eta_hull")
    assert m.eta_neg == pytest.approx(0.73) and m.disturbance == pytest.approx(0.4)
    C = fit.drag_covariance()
    assert C.shape == (2, 2)


def test_fit_drag_sigma_covers_truth_with_noise():
    truth = {"k": 20.5, "k_q": 49.5, "eta_hull": 0.6, "eta_prop": 0.6, "w": 0.0}
    rng = np.random.default_rng(7)
    fit = fit_drag(_points(truth, rng, noise=0.3, levels=(1, 2, 4, 7, 10, 14, 20)), dof="yaw")
    for n in ("k", "k_q", "eta_hull", "eta_prop"):
        p = fit.fit[n]
        assert abs(p.value - truth[n]) < 3 * p.stderr
        assert p.percentile_error < 51.02
    d = fit.as_dict()
    assert d["parameters"]["k"]["sigma"] == fit.fit["k"].stderr
    assert "Fit" in fit.summary()


def test_automatic_model_reduction_drops_insignificant_quadratic():
    truth = {"k": 28.6, "k_q": 0.0, "eta_hull": 0.68, "eta_prop": 0.62, "w": 0.0}
    rng = np.random.default_rng(11)
    pts = _points(truth, rng, noise=0.15, levels=(1, 2, 3, 4, 5))
    fit = fit_drag(pts, dof="yaw")
    assert fit.quadratic_significant is False
    assert fit.reduced_to == "linear" and fit.dropped == ("k_q",)
    assert "k_q" in fit.full and "k_q" not in fit.fit
    assert fit.full["k_q"].percentile_error > 51.02
    assert any("51.02" in m and "dropped" in m for m in fit.messages)
    assert abs(fit.k - 28.6) < 3 * fit.fit["k"].stderr
    assert fit.k_q == 0.0
    assert fit_drag(pts, reduce=False).reduced_to is None


@pytest.mark.parametrize("cov_type", ["HC0", "HC3", "HAC"])
def test_robust_covariance_options_run(cov_type):
    truth = {"k": 46.9, "k_q": 306.2, "eta_hull": 0.73, "eta_prop": 0.73, "w": 0.0}
    pts = _points(truth, np.random.default_rng(5), noise=0.03, relative=True)  # heteroscedastic
    classical = fit_drag(pts)
    robust = fit_drag(pts, cov_type=cov_type, hac_lags=2 if cov_type == "HAC" else None)
    assert robust.fit.extra["cov_type"] == cov_type
    assert robust.fit["k"].value == pytest.approx(classical.fit["k"].value)
    assert all(np.isfinite(p.stderr) and p.stderr > 0 for p in robust.fit.parameters)
    assert robust.fit["eta_hull"].stderr != pytest.approx(classical.fit["eta_hull"].stderr)


def test_heave_with_ballast_eq20():
    k, kq, W0, dW, eta = 44.7, 430.3, -13.5, 7.1, 0.56
    pts = []
    for n in range(5):
        for f in (20.0, 45.0, 75.0, -40.0, -75.0, -110.0):
            F = (1.0 if f > 0 else eta) * f + W0 + n * dW
            pts.append(SteadyPoint(float(steady_speed(k, kq, F)), f, None if f > 0 else "eta",
                                   ballast=float(n)))
    fit = fit_drag(pts, disturbance="W", ballast="dW", dof="heave")
    for n_, v in (("k", k), ("k_q", kq), ("W", W0), ("dW", dW), ("eta", eta)):
        assert fit.fit[n_].value == pytest.approx(v, rel=1e-7)
    assert fit.steady_speed(30.0, None, ballast=2) == pytest.approx(
        steady_speed(k, kq, 30 + W0 + 2 * dW))
    # η = 1 assumed everywhere: the weight estimates absorb the lost upward thrust (Fig. 6)
    naive = fit_drag([SteadyPoint(p.velocity, p.force, None, ballast=p.ballast) for p in pts],
                     disturbance="W", ballast="dW")
    assert naive.fit["W"].value > W0 + 5


def test_fit_drag_bad_input():
    pts = [SteadyPoint(0.1 * i, 5.0 * i, "eta") for i in range(1, 8)]
    with pytest.raises(ValueError, match="open-water"):
        fit_drag(pts)
    with pytest.raises(ValueError, match="no steady points"):
        fit_drag([])
    with pytest.raises(ValueError, match="non-finite"):
        fit_drag([SteadyPoint(math.nan, 1.0)] * 5)
    with pytest.raises(ValueError, match="need more points"):
        fit_drag([SteadyPoint(0.1, 5.0), SteadyPoint(0.2, 12.0), SteadyPoint(0.3, 20.0)])
    with pytest.raises(ValueError, match="linear or the quadratic"):
        fit_drag([SteadyPoint(0.1, 5.0)] * 5, linear=False, quadratic=False)
    with pytest.raises(ValueError, match="two ballast"):
        fit_drag([SteadyPoint(0.1 * i, 5.0 * i) for i in range(1, 8)], ballast="dW")


def test_eta_label():
    m = {"yaw_fl_rr+": None, "yaw_fl_rr-": "eta_hull", "horizontal_all": "eta_hull_prop"}
    assert eta_label(m, "yaw_fl_rr", 3.0) is None
    assert eta_label(m, "yaw_fl_rr", -3.0) == "eta_hull"
    assert eta_label(m, "horizontal_all", -1.0) == "eta_hull_prop"
    with pytest.raises(KeyError, match="surge_front"):
        eta_label(m, "surge_front", 1.0)


def test_steady_points_from_log_end_to_end():
    model = OneDofModel(84.0, 28.6, 0.0, 1.0, 0.68)
    dt = 0.1
    levels = [2.0, 4.0, -3.0, -6.0]
    u = np.concatenate([np.full(300, lv) for lv in levels])
    t = np.arange(u.size) * dt
    v = simulate_one_dof(model, t, u)
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    heading = np.mod(psi + 1.0, 2 * np.pi)
    pts, vels = steady_points_from_log(t, u, t, heading, eta_map={"+": None, "-": "eta_hull"},
                                       min_duration=8.0, settle=20.0, angle=True)
    assert [p.eta for p in pts] == [None, None, "eta_hull", "eta_hull"]
    for p in pts:
        assert p.velocity == pytest.approx(model.steady_speed(p.force), rel=2e-3)


# ------------------------------------------------------------------------------- inertia
def _sine_log(model, period=24.0, offset=-5.0, amp=4.0, T=130.0, dt=0.1, noise=0.0, seed=0,
              hold="zoh"):
    t = np.arange(0.0, T, dt)
    u = offset + amp * np.sin(2 * np.pi * t / period)
    v = simulate_one_dof(model, t, u, substeps=8, hold=hold)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    x = x + np.random.default_rng(seed).normal(0, noise, t.size) if noise else x
    return t, u, v, x


@pytest.mark.slow
def test_fit_inertia_recovers_mass_noise_free():
    m = OneDofModel(84.0, 28.6)
    t, u, v, x = _sine_log(m)
    f = fit_inertia(t, x, u, k=28.6, window=41)
    assert f.mass == pytest.approx(84.0, rel=2e-3)
    # quadratic drag, surge-like numbers
    ms = OneDofModel(890.0, 46.9, 306.2)
    t, u, v, x = _sine_log(ms, period=26.0, offset=35.0, amp=25.0, T=90.0)
    f = fit_inertia(t, x, u, k=46.9, k_q=306.2, window=41)
    assert f.mass == pytest.approx(890.0, rel=3e-3)


def test_fit_inertia_with_noise_hac_drag_cov_and_eiv():
    m = OneDofModel(84.0, 28.6)
    t, u, v, x = _sine_log(m, noise=0.005)
    f = fit_inertia(t, x, u, k=28.6, window=41, cov_type="HAC", hac_lags=60)
    assert abs(f.mass - 84.0) < 3 * f.mass_stderr
    g = fit_inertia(t, x, u, k=28.6, window=41, cov_type="HAC", hac_lags=60,
                    drag_cov=[[1.3**2, 0.0], [0.0, 0.0]])
    assert g.mass == pytest.approx(f.mass)
    assert g.mass_stderr >= f.mass_stderr
    assert g.fit.extra["sigma_drag"]["m"] > 0
    h = fit_inertia(t, x, u, k=28.6, window=41, velocity_noise_correction=True)
    assert h.fit.extra["position_noise"] == pytest.approx(0.005, rel=0.2)
    assert h.mass >= h.fit.extra["m_uncorrected"]


def test_fit_inertia_cleans_outliers_and_gaps():
    m = OneDofModel(890.0, 46.9, 306.2)
    t, u, v, x = _sine_log(m, period=26.0, offset=35.0, amp=25.0, T=90.0, dt=0.3, noise=0.01)
    x[[100, 150]] += [1.5, -0.7]
    x[230:245] = np.nan
    f = fit_inertia(t, x, u, k=46.9, k_q=306.2, window=21, cov_type="HAC", hac_lags=22)
    assert "2 outliers" in f.cleaning and "15 missing" in f.cleaning
    assert f.fit.extra["rows_excluded"] > 0
    assert abs(f.mass - 890.0) < 3 * f.mass_stderr


def test_fit_inertia_bad_input():
    t = np.arange(0.0, 10.0, 0.1)
    with pytest.raises(ValueError, match="same length"):
        fit_inertia(t, t[:-1], t, k=1.0)
    with pytest.raises(ValueError, match="time base"):
        fit_inertia(t, t, t[:-1], k=1.0)
    with pytest.raises(ValueError, match="finite"):
        fit_inertia(t, t, t, k=math.nan)


# ------------------------------------------------------------------------------- validation
def test_simulate_one_dof_matches_first_order_step():
    m = OneDofModel(84.0, 28.6)
    t = np.linspace(0, 20, 201)
    v = simulate_one_dof(m, t, np.full(t.size, 5.0))
    assert np.allclose(v, 5 / 28.6 * (1 - np.exp(-t * 28.6 / 84)), atol=1e-7)


def test_phase_lag_of_first_order_response():
    m = OneDofModel(84.0, 28.6)
    w = 2 * np.pi / 24
    t, u, v, _ = _sine_log(m, T=200.0, hold="linear")  # continuous input
    lag = phase_lag(t, u, v, w, t_start=50.0)
    assert lag["lag_deg"] == pytest.approx(predicted_phase_lag(w, 84.0, 28.6), abs=0.05)
    # a 10 Hz zero-order-hold command adds half a sample of delay (0.75° here)
    t, u, v, _ = _sine_log(m, T=200.0)
    lag_zoh = phase_lag(t, u, v, w, t_start=50.0)
    assert lag_zoh["lag_deg"] - lag["lag_deg"] == pytest.approx(np.degrees(w * 0.05), abs=0.05)
    assert predicted_phase_lag(w, 84.0, 28.6) == pytest.approx(37.6, abs=0.05)
    assert lag["time_lag_s"] == pytest.approx(math.radians(lag["lag_deg"]) / w)
    with pytest.raises(ValueError):
        predicted_phase_lag(0.0, 1.0, 1.0)


def test_validate_one_dof():
    m = OneDofModel(890.0, 46.9, 306.2)
    t = np.arange(0.0, 100.0, 0.3)
    u = np.where(t < 30, 20.0, 45.0)
    truth = simulate_one_dof(m, t, u)
    val = validate_one_dof(m, t, u, truth + np.random.default_rng(0).normal(0, 0.003, t.size),
                           xi0=0.0)
    assert val["nrmse"] < 0.02
    worse = validate_one_dof(OneDofModel(600.0, 46.9, 250.0), t, u, truth, xi0=0.0)
    assert worse["nrmse"] > 3 * val["nrmse"]


def test_spike_statistic_is_the_nan_median_of_the_neighbours():
    """``_spikes`` takes each window's median from one sort of the rows: the value of
    ``np.nanmedian`` (the middle non-NaN neighbour, or the mean of the two), for every count of
    missing neighbours, bit for bit."""
    import warnings

    from numpy.lib.stride_tricks import sliding_window_view

    from uuvid.identify.vehicle.segments import _spikes

    rng = np.random.default_rng(7)
    for _ in range(300):
        n = int(rng.integers(1, 50))
        h = int(rng.integers(1, 7))
        r = rng.normal(size=n)
        inl = np.where(rng.random(n) < rng.random(), np.nan, r)
        all_ = np.where(rng.random(n) < 0.1, np.nan, r)
        pad = np.concatenate([np.full(h, np.nan), inl, np.full(h, np.nan)])
        win = sliding_window_view(pad, 2 * h + 1).copy()
        win[:, h] = np.nan
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            ref = np.nanmedian(win, axis=1)
        want = all_ - np.where(np.isfinite(ref), ref, 0.0)
        assert np.array_equal(_spikes(inl, all_, h), want, equal_nan=True)


def test_lean_least_squares_are_linear_lsq_number_for_number():
    """segment_velocity's inner regressions (fit.lsq_solution, fit.lsq_classical) skip the Fit
    and its diagnostics, not the arithmetic: estimates, σ and s² equal linear_lsq's exactly."""
    from uuvid.identify.fit import linear_lsq, lsq_classical, lsq_solution

    rng = np.random.default_rng(3)
    for n, p in ((5, 2), (40, 2), (63, 3), (200, 3)):
        s = np.sort(rng.uniform(-5, 5, n))
        H = np.column_stack([np.ones(n), s, 0.5 * s ** 2][:p])
        y = H @ rng.normal(size=p) + rng.normal(0, 0.1, n)
        f = linear_lsq(H, y, [f"c{i}" for i in range(p)], emit_warnings=False)
        th, se, s2 = lsq_classical(H, y)
        assert th.tolist() == [q.value for q in f.parameters]
        assert se.tolist() == [q.stderr for q in f.parameters]
        assert s2 == f.sigma2
        assert lsq_solution(H, y).tolist() == th.tolist()
    with pytest.raises(ValueError, match="too few samples"):
        lsq_classical(np.ones((1, 2)), np.ones(1))
