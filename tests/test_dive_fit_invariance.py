"""The dive output-error fit gives one answer for one piece of information, and it is the minimum.

A reviewer identified yaw from the example dive (forces from the pwm_ columns) with the heading
written as (−π, π], as [0, 2π), unwrapped + 20π and with the time column + 1.7e9 s (Unix time):
four different inertias (0.308–0.318, σ 0.097–0.18), "optimiser stopped: maximum iterations"
on three, a "too stiff window" warning on one.  The causes:

* the optimiser stopped on its iteration cap, short of the minimum, or "converged" when a damped
  step gained little (:func:`~uuvid.identify.vehicle.output_error.levenberg_marquardt`, whose
  own tests are in test_output_error_numerics.py);
* windows whose replay is beyond RK4's stability limit stayed in the cost with their Jacobian rows
  zeroed (a cost the optimiser could not see the slope of), and in windows the model cannot follow
  the start rate ran off towards ±∞ (a fit that ended in round-off);
* the heading and the time entered the fit's arithmetic as absolute numbers (the RK4 half steps
  were rounded to the 2.4e-7 s grid of a stamp of 1.7e9 s): checked below on a WindowProblem.

Here the end-to-end checks: the reviewer's inputs, synthetic dives of several seeds, and that the
example dive's fit converges."""

import math

import numpy as np
import pandas as pd
import pytest

from uuvid.examples import write_example
from uuvid.identify.vehicle.dive import identify_dive
from uuvid.identify.vehicle.output_error import CONVERGED
from uuvid.simulate.dive_replay import WindowProblem
from uuvid.simulate.dive_synth import synthetic_dive

FORCES = ["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]
#: two fits each within √CONVERGED of their σ of the minimum
AGREE = 2 * math.sqrt(CONVERGED)


def _representations(df) -> dict:
    """The same dive with the heading as (−π, π], as [0, 2π), unwrapped + 20π, and (wrapped) with
    the time as Unix time."""
    y = df["yaw_rad"].to_numpy(float)
    ok = np.isfinite(y)
    unwrapped = y.copy()
    unwrapped[ok] = np.unwrap(y[ok])
    wrapped = y.copy()
    wrapped[ok] = np.angle(np.exp(1j * unwrapped[ok]))
    out = {}
    for name, heading in (("(−π, π]", wrapped), ("[0, 2π)", np.mod(wrapped, 2 * np.pi)),
                          ("unwrapped + 20π", unwrapped + 20 * np.pi)):
        out[name] = df.assign(yaw_rad=heading)
    out["t + 1.7e9 s"] = df.assign(yaw_rad=wrapped, t_s=df["t_s"] + 1.7e9)
    return out


def _assert_same_fit(estimates: dict):
    ref_name, ref = next(iter(estimates.items()))
    for name, e in estimates.items():
        assert not any("optimiser stopped" in w for w in e.warnings), (name, e.warnings)
        for k in ref.values:
            assert abs(e.values[k] - ref.values[k]) <= AGREE * ref.sigma[k], \
                (name, ref_name, k, e.values[k], ref.values[k], ref.sigma[k])
            assert e.sigma[k] == pytest.approx(ref.sigma[k], rel=1e-3), (name, k)
    # the same warnings where the time is the same (with it offset, they name other stamps)
    same_t = [e.warnings for n, e in estimates.items() if not n.startswith("t +")]
    assert all(w == same_t[0] for w in same_t), same_t


@pytest.mark.slow
def test_example_dive_yaw_from_pwm_is_one_fit_however_heading_and_time_are_written(tmp_path):
    """The reviewer's inputs: `uuvid examples dive` without the force columns (forces from the
    servo outputs), yaw against the bluerov2 preset."""
    (path,) = write_example("dive", tmp_path)
    df = pd.read_csv(path).drop(columns=FORCES)
    ests = {name: identify_dive(d, "bluerov2", ["yaw"]).estimates["yaw"]
            for name, d in _representations(df).items()}
    _assert_same_fit(ests)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_heave_and_yaw_do_not_depend_on_the_heading_zero_or_the_clock_over_seeds(seed):
    """Synthetic dives of every seed 0–2 (none picked), forces from their columns, telemetry
    rates, surge flown: heave and yaw each give one fit for the four representations."""
    df, _ = synthetic_dive(240.0, seed=seed)
    fits = {name: identify_dive(d, "bluerov2", ["heave", "yaw"])
            for name, d in _representations(df).items()}
    for dof in ("heave", "yaw"):
        _assert_same_fit({name: r.estimates[dof] for name, r in fits.items()})


@pytest.mark.slow
def test_the_example_dive_fit_converges(tmp_path):
    """`uuvid examples dive` as written, heave and yaw: the optimiser ends converged (it stopped on
    its cap of 40 iterations, short of the minimum by 0.03–0.1 σ of the inertia, before)."""
    (path,) = write_example("dive", tmp_path)
    for force in ("columns", "pwm"):
        df = pd.read_csv(path)
        if force == "pwm":
            df = df.drop(columns=FORCES)
        res = identify_dive(df, "bluerov2", ["heave", "yaw"])
        for dof, e in res.estimates.items():
            assert not any("optimiser stopped" in w for w in e.warnings), (force, dof, e.warnings)
            assert e.train["iterations"] < 100, (force, dof, e.train)
            assert all(math.isfinite(e.sigma[k]) for k in e.values), (force, dof, e.sigma)


class _Channels:
    name = "synthetic"

    def __init__(self, channels):
        self.channels = channels


def _yaw_problem(t0: float, heading_offset: float):
    # stamps on a 1/64 s grid: t0 + t is exact for t0 = 1.7e9, so any difference is the fit's
    t = np.arange(0.0, 40.0, 1 / 64) + t0
    rng = np.random.default_rng(0)
    s = t - t0
    psi = 0.8 * np.sin(0.3 * s) + 0.2 * np.sin(1.1 * s) + rng.normal(0, 0.005, s.size)
    torque = 2.0 * np.cos(0.3 * s) + np.sign(np.sin(0.7 * s))
    ch = {"yaw_rad": (t, psi + heading_offset), "N_Nm": (t[::32], torque[::32])}
    wins = [(t0 + a, t0 + a + 4.0) for a in np.arange(1.0, 37.0, 4.0)]
    return WindowProblem(_Channels(ch), "yaw", wins)


def test_window_problem_works_on_time_and_heading_relative_to_each_window():
    """The RK4 half steps' force, each window's samples and its measured start rate are the same
    numbers with the time offset by 1.7e9 s and the heading by 20π (built on absolute stamps,
    the half steps of a Unix-time log were rounded to its 2.4e-7 s grid)."""
    ref = _yaw_problem(0.0, 0.0)
    for t0, off in ((1.7e9, 0.0), (0.0, 20 * np.pi), (1.7e9, -6 * np.pi)):
        p = _yaw_problem(t0, off)
        assert np.array_equal(p.Fh, ref.Fh), (t0, off, np.max(np.abs(p.Fh - ref.Fh)))
        np.testing.assert_allclose(p.y_rel, ref.y_rel, rtol=0, atol=1e-12)
        np.testing.assert_allclose(p.v0_meas, ref.v0_meas, rtol=0, atol=1e-10)
        np.testing.assert_allclose(p.v0_weight, ref.v0_weight, rtol=1e-12)
        theta = np.array([0.3, 0.5, 2.0, 0.01])
        np.testing.assert_allclose(p.predict(theta, np.zeros(p.W), p.v0_meas) - p.y_rel,
                                   ref.predict(theta, np.zeros(p.W), ref.v0_meas) - ref.y_rel,
                                   rtol=0, atol=1e-12)
