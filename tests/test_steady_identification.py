"""Steady identification (uuvid.identify.thruster.steady) on synthetic data with known truth + T200 sheets."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from uuvid.identify.fit import IdentifiabilityWarning
from uuvid.identify.thruster.steady import (
    detect_regions_bench,
    fit_cv,
    fit_deadzone_curve,
    fit_polynomial,
    fit_quadratic_speed,
    fit_table,
    polynomial_degree_table,
    select_degree,
)
from uuvid.io.bench import BenchData, BenchDataError, read_t200
from uuvid.thruster.blocks import DeadZoneMap, PolynomialMap, QuadraticMap, TableMap
from uuvid.thruster.presets import LAIDANI_POLY_FORWARD, LAIDANI_POLY_REVERSE

T200 = "t200-bluerobotics-2019"


def within(fit, name, truth, k=3.0):
    p = fit[name]
    assert math.isfinite(p.stderr) and p.stderr > 0, f"{name} has no σ"
    assert abs(p.value - truth) <= k * p.stderr, f"{name} = {p.value} ± {p.stderr}, truth {truth}"


def bench_from_speed(kt_f=3.6e-4, kt_r=2.9e-4, noise=0.05, seed=0, censor=None):
    """Synthetic sheet: PWM 1100…1900, speed ∝ command offset, T = K_T Ω|Ω| + noise."""
    rng = np.random.default_rng(seed)
    pwm = np.arange(1100.0, 1901.0, 8.0)
    w = 0.8 * (pwm - 1500.0)
    t = np.where(w >= 0, kt_f, kt_r) * w * np.abs(w) + rng.normal(0, noise, w.size)
    cens = np.zeros(w.size, dtype=bool) if censor is None else np.abs(w) < censor
    return BenchData(command=pwm, thrust=t, speed=w, supply_voltage=12.0, censored=cens,
                     source="synthetic")


# ------------------------------------------------------------------------------ quadratic maps
def test_quadratic_speed_recovers_truth_within_3_sigma():
    d = bench_from_speed()
    r = fit_quadratic_speed(d)
    within(r.forward, "K_T_fwd", 3.6e-4)
    within(r.reverse, "K_T_rev", 2.9e-4)
    assert isinstance(r.block, QuadraticMap)
    assert r.block.k_pos == pytest.approx(r.forward["K_T_fwd"].value)
    assert r.block.k_neg == pytest.approx(r.reverse["K_T_rev"].value)
    assert r.forward.rmse == pytest.approx(0.05, rel=0.3)
    assert "K_T_fwd" in r.summary()


def test_quadratic_speed_ignores_censored_rows():
    d = bench_from_speed(censor=40.0)
    bad = d.thrust.copy()
    bad[d.censored] = 99.0  # garbage where the logger did not measure
    d2 = BenchData(command=d.command, thrust=bad, speed=d.speed, censored=d.censored)
    a, b = fit_quadratic_speed(d), fit_quadratic_speed(d2)
    assert a.forward["K_T_fwd"].value == b.forward["K_T_fwd"].value
    assert any("censored" in n for n in a.info["notes"])


def test_quadratic_speed_one_direction_only():
    d = bench_from_speed().forward()
    r = fit_quadratic_speed(d)
    assert r.reverse is None and r.block.k_neg == r.block.k_pos
    assert any("no reverse samples" in n for n in r.warnings)


def test_quadratic_speed_with_thrust_reversed_is_an_error_not_a_zero_model():
    d = bench_from_speed()
    rev = BenchData(command=d.command, thrust=-d.thrust, speed=d.speed, source="rev.csv")
    with pytest.raises(BenchDataError, match=r"rev.csv: thrust has the opposite sign of the "
                                             r"command .*Fix: negate the thrust column"):
        fit_quadratic_speed(rev)
    for fit in (fit_polynomial, fit_table, fit_deadzone_curve):  # every steady fit checks
        with pytest.raises(BenchDataError, match="opposite sign"):
            fit(rev)


def test_quadratic_speed_insignificant_negative_direction_is_a_zero_thrust_warning():
    d = bench_from_speed(noise=0.0)
    rev = d.speed < 0
    t = d.thrust.copy()
    # reverse: a slope of -1e-6 (0.3 % of the forward one) under ±0.5 N scatter: not significant
    h = -d.speed[rev] ** 2  # the regressor Ω|Ω|
    e = 0.5 * (-1.0) ** np.arange(h.size)
    e -= h * (h @ e) / (h @ h)  # scatter orthogonal to the regressor: the LS slope stays -1e-6
    t[rev] = -1e-6 * h + e
    r = fit_quadratic_speed(BenchData(command=d.command, thrust=t, speed=d.speed))
    kn = r.reverse["K_T_rev"]
    assert kn.value < 0 and -kn.value < 2 * kn.stderr
    assert r.block.k_neg == 0.0 and r.block.k_pos == pytest.approx(3.6e-4)
    assert any(n.startswith("zero thrust reverse") for n in r.info["notes"])


def test_cv_with_thrust_reversed_is_an_error():
    v = np.linspace(-20, 20, 41)
    with pytest.raises(BenchDataError, match="c_V_fwd = -"):
        fit_cv(v, -1.02 * v * np.abs(v))


def test_quadratic_speed_needs_speed():
    with pytest.raises(BenchDataError, match="needs a propeller speed column"):
        fit_quadratic_speed(BenchData(command=[1500, 1600], thrust=[0, 1]))


def test_cv_caccia_synthetic():
    """Caccia et al. 2000 (ROMEO): c_V = 1.02 / 1.09 N/V², percentile errors 3.0 % / 3.7 %.

    The paper's data are not available, so synthetic data drawn from those coefficients with
    ~12 % multiplicative noise (a pool test) must give back c_V within 3σ and percentile errors
    of the same order (a few per cent).
    """
    rng = np.random.default_rng(7)
    v = np.concatenate([np.linspace(2, 10, 12), -np.linspace(2, 10, 12)])
    c = np.where(v > 0, 1.02, 1.09)
    t = c * v * np.abs(v) * (1 + rng.normal(0, 0.12, v.size))
    r = fit_cv(v, t)
    within(r.forward, "c_V_fwd", 1.02)
    within(r.reverse, "c_V_rev", 1.09)
    for f, name in ((r.forward, "c_V_fwd"), (r.reverse, "c_V_rev")):
        pe = f[name].percentile_error
        assert 1.0 < pe < 8.0, pe
        assert f[name].significant
    assert isinstance(r.block, QuadraticMap)
    assert r.block.thrust(np.array([-5.0]))[0] == pytest.approx(-r.reverse["c_V_rev"].value * 25)


def test_cv_input_checks():
    with pytest.raises(BenchDataError, match="voltage has 2 samples, thrust has 3"):
        fit_cv([1, 2], [1, 2, 3])
    with pytest.raises(BenchDataError, match="sample 2"):
        fit_cv([1, np.nan], [1, 2])


# ------------------------------------------------------------------------------ polynomials
def test_degree_table_shape_and_monotone_in_sample_error():
    rng = np.random.default_rng(1)
    x = np.linspace(0, 100, 80)
    y = 0.002 * x**2 + 0.1 * x + rng.normal(0, 0.2, x.size)
    tab = polynomial_degree_table(x, y)
    assert len(tab) == 8 and [r["degree"] for r in tab] == list(range(1, 9))
    for r in tab:
        assert set(tab.COLUMNS) <= set(r)
    rmse = tab.column("rmse")
    assert np.all(np.diff(rmse) <= 1e-12)  # nested least squares
    assert np.all(tab.column("cv_rmse") >= rmse - 1e-12)
    assert tab.k == 5 and tab.n_samples == 80
    assert "CV5 RMSE" in tab.to_text()
    # deterministic folds: same table twice
    assert polynomial_degree_table(x, y).column("cv_rmse").tolist() == tab.column("cv_rmse").tolist()
    ch = select_degree(tab, "cv")
    assert ch.degree == 2 and "degree 2" in ch.reason
    assert select_degree(tab, "bic").degree == 2


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("coef", [LAIDANI_POLY_FORWARD, LAIDANI_POLY_REVERSE])
def test_selection_is_parsimonious_on_laidani_like_data(seed, coef):
    """Data from Laidani's degree-5 polynomials (Table 2) + 0.1 N noise (their RMSE ≈ 0.1 N):
    ME/RMSE alone always favour degree 8; the CV one-SE rule and ΔBIC < 2 must not."""
    rng = np.random.default_rng(seed)
    w = np.linspace(50, 1575.6, 120)
    y = np.polyval(coef, w) + rng.normal(0, 0.1, w.size)
    tab = polynomial_degree_table(w, y)
    assert int(np.argmin(tab.column("rmse"))) == 7  # in-sample error picks the top degree
    for crit in ("cv", "bic"):
        ch = select_degree(tab, crit)
        assert ch.degree != 8 and 3 <= ch.degree <= 6, (crit, ch)
        assert ch.reason.startswith(f"degree {ch.degree}:")
    assert "improves in-sample RMSE" in select_degree(tab, "cv").reason


def test_select_degree_rejects_unknown_criterion():
    tab = polynomial_degree_table(np.arange(20.0), np.arange(20.0) ** 2, degrees=[1, 2])
    with pytest.raises(ValueError, match="criterion"):
        select_degree(tab, "aic")


@pytest.mark.filterwarnings("ignore::uuvid.identify.fit.IdentifiabilityWarning")
def test_fit_polynomial_recovers_coefficients_in_original_units():
    rng = np.random.default_rng(3)
    w = np.linspace(-300, 300, 151)
    fwd = (2e-9, 3e-4, 1e-3, 0.05)
    rev = (1e-9, 2.5e-4, 2e-3, 0.02)
    t = np.where(w > 0, np.polyval(fwd, np.abs(w)), -np.polyval(rev, np.abs(w)))
    t = t + rng.normal(0, 0.05, w.size)
    d = BenchData(command=1500 + w, thrust=t, speed=w)
    r = fit_polynomial(d, degree=3)
    for f, truth in ((r.forward, fwd), (r.reverse, rev)):
        assert f.names == ["c3", "c2", "c1", "c0"]
        for name, v in zip(f.names, truth):
            within(f, name, v)
        assert f["c2"].unit == "N/(rad/s)^2"
    assert isinstance(r.block, PolynomialMap)
    est = r.block.thrust(w)
    assert np.sqrt(np.mean((est - t) ** 2)) < 0.07
    # automatic degree: a small one, with the table and the reason kept
    ra = fit_polynomial(d)
    for direction in ("forward", "reverse"):
        assert ra.info["choices"][direction].degree <= 5
        assert len(ra.info["tables"][direction]) == 8


def test_rank_deficient_polynomial_warns():
    """Four distinct speeds cannot determine a degree-5 polynomial: the fit must say so."""
    w = np.repeat([50.0, 100.0, 150.0, 200.0], 3)
    w = np.concatenate([w, -w])
    t = 3e-4 * w * np.abs(w)
    d = BenchData(command=1500 + w, thrust=t + 0.01 * np.sin(np.arange(w.size)), speed=w)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = fit_polynomial(d, degree=5)
    assert any(issubclass(w.category, IdentifiabilityWarning) and "rank deficient" in str(w.message)
               for w in caught)
    assert any("rank deficient" in m for m in r.forward.warnings)


def test_polynomial_needs_enough_samples():
    w = np.array([10.0, 20.0, -10.0, -20.0])
    d = BenchData(command=1500 + w, thrust=w, speed=w)
    with pytest.raises(BenchDataError, match="degree 3 polynomial"):
        fit_polynomial(d, degree=3)


# ------------------------------------------------------------------------------ dead zone, table
def test_deadzone_curve_recovers_bessa_parameters():
    truth = DeadZoneMap(rotor_constant_l=40.0, rotor_constant_r=50.0, delta_l=-0.02, delta_r=0.03)
    rng = np.random.default_rng(5)
    x = np.linspace(-1, 1, 161)
    t = truth.thrust(x) + rng.normal(0, 0.2, x.size)
    d = BenchData(command=x, command_unit="duty", thrust=t)
    r = fit_deadzone_curve(d)
    f = r.fit
    within(f, "rotor_constant_l", 40.0)
    within(f, "rotor_constant_r", 50.0)
    within(f, "delta_l", -0.02)
    within(f, "delta_r", 0.03)
    assert isinstance(r.block, DeadZoneMap)
    np.testing.assert_allclose(r.block.thrust(x), truth.thrust(x), atol=0.3)


def test_table_averages_duplicates_and_is_monotone():
    c = np.array([1100, 1100, 1300, 1500, 1700, 1700, 1800, 1900], dtype=float)
    t = np.array([-10, -12, -5, 0, 5, 7, 5.5, 9], dtype=float)  # 1800 dips below 1700's mean
    d = BenchData(command=c, thrust=t)
    r = fit_table(d)
    assert isinstance(r.block, TableMap)
    assert r.block.input_values == (1100, 1300, 1500, 1700, 1800, 1900)
    y = np.array(r.block.output_values)
    assert np.all(np.diff(y) >= 0)
    assert y[0] == pytest.approx(-11.0) and y[-1] == 9.0
    assert y[3] == pytest.approx(y[4]) == pytest.approx((6 * 2 + 5.5) / 3)  # pooled violators
    assert r.fit["T(1100)"].stderr == pytest.approx(1.0)  # spread of the two repeats / √2
    assert math.isnan(r.fit["T(1300)"].stderr)
    assert any("isotonic" in n for n in r.info["notes"])
    raw = fit_table(d, monotone=False)
    assert raw.block.output_values[3] == pytest.approx(6.0)


def test_table_knot_reduction_keeps_ends_and_shape():
    d = bench_from_speed(noise=0.0)
    full = fit_table(d)
    small = fit_table(d, n_points=12)
    xi = small.block.input_values
    assert len(xi) == 12 and xi[0] == 1100 and xi[-1] == 1900
    err = np.abs(small.block.thrust(d.command) - full.block.thrust(d.command))
    assert err.max() < 0.03 * np.abs(d.thrust).max()
    with pytest.raises(BenchDataError, match="n_points"):
        fit_table(d, n_points=1)


# ------------------------------------------------------------------------------ regions
def laidani_like_sheet():
    """Dead zone 1475–1525 µs, linear between, flat (saturated) beyond 1200 / 1800 µs."""
    pwm = np.arange(1000.0, 2001.0, 10.0)
    c = np.clip(pwm, 1200, 1800)
    t = np.where(c > 1525, 12.7 * (c - 1525) / 275, np.where(c < 1475, -10.8 * (1475 - c) / 275, 0))
    return BenchData(command=pwm, thrust=t)


def test_regions_dead_zone_and_saturation():
    r = detect_regions_bench(laidani_like_sheet())
    assert r.dead_zone == (1480.0, 1520.0)
    assert r.saturation == (1200.0, 1800.0)
    assert r.dead_zone_censored == (False, False) and not r.notes
    assert r.as_regions().dead_zone == (1480.0, 1520.0)


def test_regions_no_saturation_on_a_quadratic_map():
    r = detect_regions_bench(bench_from_speed(noise=0.0))
    assert r.saturation == (None, None)
    assert r.dead_zone == (1500.0, 1500.0)


def test_regions_censored_band_is_an_upper_bound():
    d = laidani_like_sheet()
    small = np.abs(d.thrust) < 1.0
    d2 = BenchData(command=d.command, thrust=np.where(small, 0.0, d.thrust), censored=small)
    r = detect_regions_bench(d2)
    assert r.dead_zone[0] < 1480 and r.dead_zone[1] > 1520  # wider than the true dead zone
    assert r.dead_zone_censored == (True, True)
    assert all("upper bound" in n for n in r.notes) and len(r.notes) == 2


@pytest.mark.realdata
def test_t200_regions_are_censored(shared_data):
    d12 = read_t200(shared_data / T200 / "T200_12V.csv")
    d16 = read_t200(shared_data / T200 / "T200_16V.csv")
    r12, r16 = detect_regions_bench(d12), detect_regions_bench(d16)
    assert r12.dead_zone == (1464.0, 1536.0) and r16.dead_zone == (1472.0, 1528.0)
    assert r12.dead_zone_censored == (True, True) == r16.dead_zone_censored
    assert r12.first_measured == (1460.0, 1540.0)
    assert any("upper bound on the true dead zone" in n for n in r12.notes)
    # at 12 V the sheet flattens in the last few commands of each direction; at 16 V it does not
    lo, hi = r12.saturation
    assert 1100 <= lo <= 1112 and 1888 <= hi <= 1900
    assert r16.saturation[1] is None


@pytest.mark.realdata
def test_t200_fits_carry_sigma_and_warnings(shared_data):
    d = read_t200(shared_data / T200 / "T200_16V.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        q = fit_quadratic_speed(d)
        p = fit_polynomial(d)
        z = fit_deadzone_curve(d)
        t = fit_table(d)
    assert q.forward["K_T_fwd"].value == pytest.approx(3.71e-4, rel=0.02)
    assert q.reverse["K_T_rev"].value == pytest.approx(2.96e-4, rel=0.02)
    for f in (q.forward, q.reverse, p.forward, p.reverse, z.fit):
        for par in f.parameters:
            assert math.isfinite(par.stderr)
        assert math.isfinite(f.rmse) and math.isfinite(f.condition_number)
        assert f.covariance.shape == (len(f.parameters),) * 2
    # the T200 thrust is not quadratic in the PWM offset: the Bessa dead zone collapses onto its
    # bounds, and the fit says its σ is meaningless there
    assert any("at its bound" in w for w in z.fit.warnings)
    assert t.fit.n_samples == 201 and len(t.block.input_values) == 201


def test_a_parameter_at_its_bound_reports_no_sigma():
    """A parameter the optimiser leaves on a bound has no meaningful σ: the report says "at
    bound" instead of printing one, and the fit lists it in ``at_bound``."""
    from uuvid.identify.fit import nonlinear_lsq

    x = np.linspace(0.0, 1.0, 50)
    y = 2.0 * x + 0.01 * np.sin(17 * x)  # the best slope is 2, the bound holds it at 1.5
    fit = nonlinear_lsq(lambda th: th[0] * x + th[1] - y, [1.0, 0.0], ["a", "b"],
                        bounds=([-np.inf, -np.inf], [1.5, np.inf]), emit_warnings=False)
    assert fit.at_bound == ("a",)
    line_a = next(ln for ln in fit.summary().splitlines() if ln.strip().startswith("a "))
    line_b = next(ln for ln in fit.summary().splitlines() if ln.strip().startswith("b "))
    assert "at bound" in line_a and "+/-" not in line_a
    assert "+/-" in line_b


def test_a_parameter_the_data_do_not_determine_gets_infinite_sigma_not_round_off():
    """A parameter with no effect on the residuals, or two that trade off exactly, got σ ≈ 1e-16
    from the pseudo-inverse — "significant" in the JSON — and correlations beyond ±1.  Now σ = ∞,
    its covariances NaN, the summary says it, the determined parameter keeps its σ."""
    import warnings as _w

    from uuvid.identify.fit import linear_lsq, nonlinear_lsq

    rng = np.random.default_rng(2)
    x = np.linspace(0.0, 1.0, 50)
    y = 2.0 * x + 0.01 * rng.standard_normal(50)
    with _w.catch_warnings():
        _w.simplefilter("ignore")
        idle = nonlinear_lsq(lambda th: th[0] * x - y + 0.0 * th[1], [1.0, 0.5], ["a", "idle"])
        pair = nonlinear_lsq(lambda th: (th[0] + th[1]) * x - y, [1.0, 0.5], ["a", "b"])
        lin = linear_lsq(np.column_stack([x, x, np.ones(50)]), y, ["a", "b", "c"])
    assert idle["idle"].stderr == np.inf and not idle["idle"].significant
    assert 0 < idle["a"].stderr < 0.01
    assert "idle" in idle.summary() and "not determined by these data (σ = ∞)" in idle.summary()
    assert np.isnan(idle.correlation[0, 1])
    assert pair["a"].stderr == np.inf and pair["b"].stderr == np.inf
    assert any("trades off exactly" in w for w in pair.warnings)
    assert np.isnan(pair.correlation[0, 1])  # the pseudo-inverse's said +1.0002
    assert not any("correlated" in w for w in pair.warnings)
    assert lin["a"].stderr == lin["b"].stderr == np.inf and np.isfinite(lin["c"].stderr)


def test_a_one_sided_table_gets_zero_thrust_at_neutral():
    """Three forward rows (1700–1900 µs): the table held 17.9 N from 1700 µs down through
    neutral and over the whole reverse range — a thruster pushing at rest.  The knot T(1500) = 0
    is added (fixed, said); a table whose data cross neutral is unchanged."""
    from uuvid.identify.thruster.steady import fit_table

    fwd = BenchData(command=np.array([1700.0, 1800.0, 1900.0]),
                    thrust=np.array([17.9, 33.5, 51.4]), source="three.csv")
    sf = fit_table(fwd)
    assert sf.block.input_values[0] == 1500.0 and sf.block.output_values[0] == 0.0
    assert sf.fits["all"]["T(1500)"].fixed
    assert float(sf.block.thrust(np.array([1500.0]))[0]) == 0.0
    assert float(sf.block.thrust(np.array([1600.0]))[0]) == pytest.approx(17.9 / 2)
    assert any("knot T(1500) = 0 is added" in n for n in sf.info["notes"])
    assert sf.fits["all"].extra["counts"] == [0, 1, 1, 1]
    rev = BenchData(command=np.array([1100.0, 1200.0, 1200.0, 1300.0]),
                    thrust=np.array([-40.0, -25.0, -25.2, 0.04]), source="rev.csv")  # +0.04: offset
    sr = fit_table(rev)
    assert sr.block.input_values == (1100.0, 1200.0, 1300.0, 1500.0)
    assert sr.block.output_values[-2:] == (0.0, 0.0)  # the offset kept on the data's side
    assert np.all(np.diff(sr.block.output_values) >= 0)  # still monotone
    assert sr.fits["all"].extra["counts"] == [1, 2, 1, 0]
    both = BenchData(command=np.array([1300.0, 1500.0, 1700.0]),
                     thrust=np.array([-15.0, 0.0, 17.9]), source="both.csv")
    assert fit_table(both).block.input_values == (1300.0, 1500.0, 1700.0)


def test_combinations_of_an_undetermined_parameter_get_infinite_variance_and_others_keep_theirs():
    """G cov Gᵀ with a NaN covariance row gave NaN to every combination (0·NaN = NaN)."""
    from uuvid.identify.fit import propagated_variance

    cov = np.array([[4.0, 1.0, np.nan], [1.0, 9.0, np.nan], [np.nan, np.nan, np.inf]])
    G = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 2.0], [1.0, 0.0, 0.0]])
    np.testing.assert_array_equal(propagated_variance(G, cov), [4 + 9 + 2, np.inf, 4.0])


def test_a_monte_carlo_model_refuses_a_fit_with_an_undetermined_parameter():
    from uuvid.uncertainty.montecarlo import ModelError, model_from_dict

    raw = {"physical_model": {}, "parameters": {"K_e": {"estimate": 0.02, "sigma": None},
                                                "K_T_fwd": {"estimate": 3e-4, "sigma": 1e-7}}}
    with pytest.raises(ModelError, match=r"x\.json: the fit does not determine K_e \(σ = ∞"):
        model_from_dict(raw, "x.json")


def test_a_parameter_left_on_its_bound_is_the_bound_and_has_no_percentile_warning():
    """A dead band pushed to its bound of 0 printed 'delta_l = -6.78e-16 at bound' and warned
    'percentile error 3.89e+20 % > 51.02 %' for a σ the fit itself calls meaningless."""
    import warnings

    from uuvid.identify.fit import nonlinear_lsq

    x = np.linspace(1.0, 2.0, 20)
    y = -0.5 * x + 0.01 * np.sin(7 * x)  # wants a < 0; a ≥ 0 stops it at 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = nonlinear_lsq(lambda p: p[0] * x + p[1] - y, [1.0, 0.0], ["a", "b"],
                          bounds=([0.0, -np.inf], [np.inf, np.inf]), extra={"residual_unit": "N"})
    assert f.parameters[0].value == 0.0 and f.at_bound == ("a",)
    assert not any(w.startswith("a: percentile error") for w in f.warnings), f.warnings
    assert "RMSE = " in f.summary() and " N, ME = " in f.summary()
    # "on the bound" is judged on the parameter's own scale: 5e-10 of a 1e-9 scale is not 0
    y = 5e-10 * x * (1 + 0.01 * np.sin(7 * x))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = nonlinear_lsq(lambda p: (p[0] * x - y) / 1e-10, [1e-9], ["k"], bounds=([0.0], [np.inf]),
                          x_scale=np.array([1e-9]))
    assert f.at_bound == () and f.parameters[0].value == pytest.approx(5e-10, rel=0.05)


def test_steady_fit_summaries_give_the_residuals_unit():
    """'RMSE = 1.65509, ME = 1.38731' had no unit: a steady map's residuals are thrust, in N."""
    rng = np.random.default_rng(0)
    w = np.linspace(-300, 300, 41)
    data = BenchData(command=1500 + w, speed=w, thrust=np.where(w >= 0, 4e-4, 3e-4) * w * np.abs(w)
                     + rng.normal(0, 0.1, w.size))
    fits = [*fit_quadratic_speed(data).fits.values(), *fit_polynomial(data, 2).fits.values()]
    for fit in fits:
        assert " N, ME = " in fit.summary(), fit.summary()
