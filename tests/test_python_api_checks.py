"""Arguments of the Python API a notebook user passes: a bad one is a ValueError naming it,
before any work (not a hang, an infinity, a NaN result or an error from deep inside)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uuvid.analysis import hold
from uuvid.vehicle.definition import load_vehicle

_ROV: list = []


def _rov():
    if not _ROV:
        _ROV.append(load_vehicle("bluerov2"))
    return _ROV[0]


# ------------------------------------------------------------------ hold (items 1, 9, 10)
@pytest.mark.parametrize("tol", [math.nan, 0.0, -1.0, math.inf])
def test_hold_max_current_refuses_a_bad_tol(tol):
    """tol = 0 or < 0 bisected for ever; NaN stopped after the first step (0.35 m/s, not 0.384)."""
    with pytest.raises(ValueError, match=r"^tol = .*expected a finite number > 0"):
        hold.max_current(_rov(), 0.0, tol=tol)


@pytest.mark.parametrize("v_cap", [0.0, -1.0, math.nan, math.inf])
def test_hold_max_current_refuses_a_bad_v_cap(v_cap):
    """v_cap = 0 or −1 returned ∞ (held 'beyond'), NaN was ignored."""
    with pytest.raises(ValueError, match=r"^v_cap = .*expected a finite number > 0"):
        hold.max_current(_rov(), 0.0, v_cap=v_cap)


def test_hold_max_current_refuses_a_v_cap_no_search_ends():
    """v_cap = 1e9 m/s stepped 0.05 m/s at a time: 2·10¹⁰ station checks on a vehicle that holds."""
    with pytest.raises(ValueError, match=r"^v_cap = 1e\+09 m/s: expected at most 100 m/s"):
        hold.max_current(_rov(), 0.0, v_cap=1e9)


@pytest.mark.parametrize("depth", [-5.0, math.nan, math.inf])
def test_hold_max_current_refuses_a_bad_depth(depth):
    """depth = −5 was accepted (a mission refuses it), NaN raised a LinAlgError 8 frames deep."""
    with pytest.raises(ValueError, match=r"^depth = .*expected a finite number >= 0"):
        hold.max_current(_rov(), 0.0, depth=depth)


def test_hold_max_current_valid_numbers_unchanged():
    v, info = hold.max_current(_rov(), 0.0)
    assert v == pytest.approx(0.38427734375, abs=1e-12)
    assert hold.max_current(_rov(), 0.0, tol=1e-3, depth=0.0)[0] > 0.37


def test_hold_max_current_tol_below_float_spacing_ends():
    """A tol below the spacing of floats at the boundary stops where bisection can go no finer."""
    v = hold.max_current(_rov(), 0.0, tol=1e-30)[0]
    assert v == pytest.approx(0.3843, abs=1e-3)


@pytest.mark.parametrize("current, match", [([0.1, 0.0], r"^current has shape \(2,\)"),
                                            ([math.nan, 0.0, 0.0], r"^current\[0\] = nan"),
                                            ([0.0, 0.0, math.inf], r"^current\[2\] = inf"),
                                            ("0.3", r"^current")])
def test_hold_required_wrench_refuses_a_bad_current(current, match):
    with pytest.raises(ValueError, match=match):
        hold.required_wrench(_rov(), current)


@pytest.mark.parametrize("kw", [{"depth": -5.0}, {"depth": math.nan}, {"roll": math.nan}])
def test_hold_required_wrench_refuses_a_bad_depth_or_attitude(kw):
    with pytest.raises(ValueError, match=f"^{next(iter(kw))} = "):
        hold.required_wrench(_rov(), [0.1, 0.0, 0.0], **kw)


def test_hold_required_wrench_valid_numbers_unchanged():
    v = _rov()
    c = hold.current_ned(0.3, 20.0)
    np.testing.assert_array_equal(hold.required_wrench(v, c, 3.0),
                                  -v.params.mass_matrix @ hold._accel(v, c, 3.0, 0.0, 0.0,
                                                                      np.zeros(6)))


def test_hold_capability_analytic_at_refuses_nan():
    cap = hold.CapabilityResult("x", np.array([0.0, 90.0, 180.0, 270.0]),
                                np.array([0.4, 0.3, 0.35, 0.3]))
    with pytest.raises(ValueError, match=r"^deg = nan"):
        cap.analytic_at(math.nan)
    assert cap.analytic_at(359.0) == 0.4 and cap.analytic_at(95) == 0.3


# ------------------------------------------------------------------ thruster chain (items 5, 11)
def test_chain_sweep_refuses_a_step_of_hours():
    """dt = 1e-7 was within the old 1e12-step limit: hours of compute."""
    from uuvid.thruster.chain import MAX_RUN_STEPS
    from uuvid.thruster.presets import auv2_tunnel_chain

    with pytest.raises(ValueError, match=rf"^sweep: .*dt = 1e-07.*{MAX_RUN_STEPS:.0e}".replace("+", r"\+")):
        auv2_tunnel_chain().sweep(np.linspace(1, 12, 100), dt=1e-7)


@pytest.mark.parametrize("max_passes", [10**6, 60])
def test_chain_sweep_refuses_too_many_passes_naming_max_passes(max_passes):
    """max_passes = 10**6 raised a bare OverflowError (2.0 ** 999999)."""
    from uuvid.thruster.presets import auv2_tunnel_chain

    with pytest.raises(ValueError, match=r"^sweep: .*max_passes = "):
        auv2_tunnel_chain().sweep([4.0, 8.0], max_passes=max_passes)


def test_chain_sweep_refuses_a_fractional_max_passes():
    from uuvid.thruster.presets import auv2_tunnel_chain

    with pytest.raises(ValueError, match=r"^sweep: max_passes = 2.5"):
        auv2_tunnel_chain().sweep([4.0, 8.0], max_passes=2.5)


@pytest.mark.parametrize("u, at", [([math.nan, 1600.0], r"u\[0\] = nan"),
                                   ([1600.0, math.inf], r"u\[1\] = inf"),
                                   (math.nan, r"u = nan")])
def test_chain_steady_thrust_refuses_non_finite_levels(u, at):
    """A closed-form chain (the T200) gave a thrust of 0 for NaN."""
    from uuvid.thruster.presets import t200_chain

    with pytest.raises(ValueError, match=f"^{at}: expected finite input levels"):
        t200_chain().steady_thrust(u)


def test_chain_steady_thrust_valid_numbers_unchanged():
    from uuvid.thruster.presets import t200_chain

    c = t200_chain()
    y = c.steady_thrust([1600.0, 1400.0])
    assert y[0] == pytest.approx(5.127, abs=1e-3) and y.shape == (2,)
    assert c.steady_thrust(1600.0).shape == (1,)


# ------------------------------------------------------------------ least squares (items 12, 13)
def _regression():
    rng = np.random.default_rng(0)
    H = np.column_stack([np.ones(20), np.linspace(0, 1, 20)])
    y = H @ [1.0, 2.0] + 0.01 * rng.standard_normal(20)
    return H, y


def test_nonlinear_lsq_refuses_names_not_matching_x0():
    from uuvid.identify.fit import nonlinear_lsq

    H, y = _regression()
    with pytest.raises(ValueError, match="1 names for 2 parameters"):
        nonlinear_lsq(lambda th: H @ th - y, [0.0, 0.0], ["a"])
    f = nonlinear_lsq(lambda th: H @ th - y, [0.0, 0.0], ["a", "b"])
    assert len(f.parameters) == 2 and f.covariance.shape == (2, 2)


@pytest.mark.parametrize("w, match", [(np.r_[1.0, -1.0, np.ones(18)], r"^weights\[1\] = -1"),
                                      (np.r_[np.ones(5), np.nan, np.ones(14)],
                                       r"^weights\[5\] = nan"),
                                      (np.ones(19), r"^weights has shape \(19,\).*20")])
def test_linear_lsq_refuses_bad_weights(w, match, capfd):
    """A negative or NaN weight made LAPACK print 'On entry to DLASCL …' and raise a
    LinAlgError; a wrong length, a bare broadcasting error."""
    from uuvid.identify.fit import linear_lsq

    H, y = _regression()
    with pytest.raises(ValueError, match=match):
        linear_lsq(H, y, ["a", "b"], weights=w)
    assert "DLASCL" not in capfd.readouterr().err


def test_linear_lsq_valid_weights_unchanged():
    from uuvid.identify.fit import linear_lsq

    H, y = _regression()
    w = np.linspace(0.0, 2.0, 20)
    f = linear_lsq(H, y, ["a", "b"], weights=w)
    sw = np.sqrt(w)
    theta = np.linalg.lstsq(H * sw[:, None], y * sw, rcond=None)[0]
    np.testing.assert_allclose([p.value for p in f.parameters], theta, rtol=1e-10)


# ------------------------------------------------------------------ bootstrap (item 6)
@pytest.mark.parametrize("n_boot, exc, match", [(10**9, ValueError, r"^n_boot = 1,000,000,000"),
                                                (-5, ValueError, r"^n_boot = -5"),
                                                (0, ValueError, r"^n_boot = 0"),
                                                (1, ValueError, r"^n_boot = 1"),
                                                (2.5, ValueError, r"^n_boot = 2.5"),
                                                ("10", TypeError, r"^n_boot = '10'")])
def test_bootstrap_linear_refuses_a_bad_n_boot(n_boot, exc, match):
    from uuvid.uncertainty.bootstrap import bootstrap_linear

    H, y = _regression()
    with pytest.raises(exc, match=match):
        bootstrap_linear(H, y, ["a", "b"], n_boot=n_boot)


@pytest.mark.parametrize("which", ["drag", "steady"])
def test_the_other_bootstraps_check_n_boot_and_seed_too(which):
    """bootstrap (behind bootstrap_drag/_physical) and bootstrap_steady took n_boot = 0 (σ = NaN)
    and 10⁹ (hours of refits) unchecked."""
    import numpy as np

    from uuvid.uncertainty import bootstrap as bs

    if which == "drag":
        def call(**kw):
            return bs.bootstrap(lambda d: None, np.zeros(3), lambda d, rng: d, **kw)
    else:
        def call(**kw):
            return bs.bootstrap_steady(None, **kw)
    for n_boot, match in ((0, r"^n_boot = 0"), (10**9, r"^n_boot = 1,000,000,000: expected")):
        with pytest.raises(ValueError, match=match):
            call(n_boot=n_boot)
    with pytest.raises(ValueError, match=r"^seed = -1"):
        call(n_boot=10, seed=-1)


def test_bootstrap_linear_refuses_replicates_beyond_memory(monkeypatch):
    from uuvid.core import checks
    from uuvid.uncertainty.bootstrap import bootstrap_linear

    monkeypatch.setattr(checks, "memory_budget_bytes", lambda: 1e5)
    H, y = _regression()
    with pytest.raises(ValueError, match=r"^n_boot = 1,000: .*GB"):
        bootstrap_linear(H, y, ["a", "b"], n_boot=1000)


@pytest.mark.parametrize("seed", [-1, 1.5, "a"])
def test_bootstrap_linear_refuses_a_bad_seed(seed):
    from uuvid.uncertainty.bootstrap import bootstrap_linear

    H, y = _regression()
    with pytest.raises((ValueError, TypeError), match=r"^seed = "):
        bootstrap_linear(H, y, ["a", "b"], n_boot=10, seed=seed)


def test_bootstrap_linear_seed_none_is_a_fresh_recorded_seed():
    from uuvid.uncertainty.bootstrap import bootstrap_linear

    H, y = _regression()
    r = bootstrap_linear(H, y, ["a", "b"], n_boot=20, seed=None)
    assert isinstance(r.seed, int) and r.seed >= 0
    again = bootstrap_linear(H, y, ["a", "b"], n_boot=20, seed=r.seed)
    np.testing.assert_array_equal(r.replicates, again.replicates)
    fixed = bootstrap_linear(H, y, ["a", "b"], n_boot=20, seed=3)
    assert fixed.seed == 3 and np.all(np.isfinite(fixed.boot_sigma))


@pytest.mark.parametrize("w, match", [(np.zeros(20), r"^weights: all 20 are 0"),
                                      (np.r_[1.0, np.zeros(19)], r"^weights: 1 of 20 .* > 0")])
def test_linear_lsq_refuses_weights_that_leave_too_few_rows(w, match):
    """All-zero weights gave a Fit of zeros with σ = ∞ (every parameter 'not identifiable'),
    as if the data were at fault; too few weighted rows, a fit of a rank-deficient problem."""
    from uuvid.identify.fit import linear_lsq

    H, y = _regression()
    with pytest.raises(ValueError, match=match):
        linear_lsq(H, y, ["a", "b"], weights=w)


@pytest.mark.parametrize("units", [["m"], ["m", "s", "kg"]])
@pytest.mark.parametrize("which", ["linear", "nonlinear"])
def test_lsq_refuses_units_not_matching_names(which, units):
    """A short ``units`` list raised a bare IndexError after the solve; a long one was cut
    silently (the extra unit belonged to nothing)."""
    from uuvid.identify.fit import linear_lsq, nonlinear_lsq

    H, y = _regression()
    with pytest.raises(ValueError, match=rf"^units has {len(units)} entries for 2 names"):
        if which == "linear":
            linear_lsq(H, y, ["a", "b"], units=units)
        else:
            nonlinear_lsq(lambda th: H @ th - y, [0.0, 0.0], ["a", "b"], units=units)


# ------------------------------------------------- hold in simulation, on the battery (fix-r1)
def _no_flight(monkeypatch):
    """A flight or a discharge that starts is a failure: the bad number is refused before."""
    from uuvid.simulate import vehicle_sim

    def flew(*a, **k):
        raise AssertionError("the bad argument was not refused: the work started")

    monkeypatch.setattr(vehicle_sim, "setup_mission", flew)
    monkeypatch.setattr(hold, "hold_on_battery", flew)


@pytest.mark.parametrize("args, kw, match", [
    ((0.0, -1.0), {}, r"^speed = -1: expected a finite number >= 0"),
    ((0.0, math.nan), {}, r"^speed = nan"),
    ((0.0, math.inf), {}, r"^speed = inf"),
    ((math.nan, 0.3), {}, r"^relative_deg = nan"),
    ((0.0, 0.3), {"depth": -2.0}, r"^depth = -2: expected a finite number >= 0"),
    ((0.0, 0.3), {"depth": math.nan}, r"^depth = nan"),
    ((0.0, 0.3), {"duration": 0.0}, r"^duration = 0: expected a finite number > 0"),
    ((0.0, 0.3), {"dt": -0.02}, r"^dt = -0.02: expected a finite number > 0"),
    ((0.0, 0.3), {"dt": math.inf}, r"^dt = inf"),
    ((0.0, 0.3), {"ramp": math.nan}, r"^ramp = nan"),
    ((0.0, 0.3), {"gust": -0.1}, r"^gust = -0.1: expected a finite number >= 0"),
    ((0.0, 0.3), {"attitude_bandwidth": 0.0}, r"^attitude_bandwidth = 0"),
    ((0.0, 0.3), {"max_tilt_deg": math.nan}, r"^max_tilt_deg = nan"),
    ((0.0, 0.3), {"max_yaw_error_deg": -5.0}, r"^max_yaw_error_deg = -5"),
    ((0.0, 0.3), {"duration": 50.0}, r"^duration = 50 s: expected longer than ramp \+ 14 s"),
])
def test_holds_in_simulation_refuses_bad_numbers(monkeypatch, args, kw, match):
    """speed = −1 flew a current from the opposite side scaled by −1 and said 'diverged' (or
    held); NaN/inf anywhere flew a NaN mission and blamed the step."""
    _no_flight(monkeypatch)
    with pytest.raises(ValueError, match=match):
        hold.holds_in_simulation(_rov(), *args, **kw)


@pytest.mark.parametrize("depth", [-5.0, math.nan, math.inf])
def test_steady_and_battery_holds_refuse_a_bad_depth(monkeypatch, depth):
    """hold_on_battery, steady_hold and endurance took any depth: −5 m (above the surface) was
    solved as given, NaN raised a LinAlgError deep in the allocation."""
    v = load_vehicle("bluerov2-heavy")
    with pytest.raises(ValueError, match=r"^depth = .*expected a finite number >= 0"):
        hold.steady_hold(v, [0.1, 0.0, 0.0], hold._allocator(v), depth)
    with pytest.raises(ValueError, match=r"^depth = .*expected a finite number >= 0"):
        hold.hold_on_battery(v, [0.1, 0.0, 0.0], 0.9, depth=depth)
    _no_flight(monkeypatch)
    with pytest.raises(ValueError, match=r"^depth = .*expected a finite number >= 0"):
        hold.endurance(v, 0.1, depth=depth, progress=False)


@pytest.mark.parametrize("kw, match", [
    ({"soc0": math.nan}, r"^soc0 = nan: expected a state of charge within 0..1"),
    ({"soc0": 1.5}, r"^soc0 = 1.5: expected a state of charge within 0..1"),
    ({"soc0": "full"}, r"^soc0 = 'full': expected a state of charge within 0..1 \(a number\)"),
    ({"dsoc": 0.0}, r"^dsoc = 0: expected a finite number > 0"),
    ({"dsoc": -0.01}, r"^dsoc = -0.01: expected a finite number > 0"),
    ({"dsoc": math.nan}, r"^dsoc = nan"),
    ({"dsoc": 2.0}, r"^dsoc = 2: expected a step of state of charge of at most 1"),
])
def test_endurance_refuses_a_bad_charge_or_step(monkeypatch, kw, match):
    """dsoc = 0 never stepped the charge down (an endless discharge), a negative one charged the
    battery past full; soc0 given as text raised a bare TypeError."""
    _no_flight(monkeypatch)
    with pytest.raises(ValueError, match=match):
        hold.endurance(load_vehicle("bluerov2-heavy"), 0.1, progress=False, **kw)


def test_hold_on_battery_names_soc():
    with pytest.raises(ValueError, match=r"^soc = 'x': expected a state of charge within 0..1 \(a number\)"):
        hold.hold_on_battery(load_vehicle("bluerov2-heavy"), [0.1, 0.0, 0.0], "x")
