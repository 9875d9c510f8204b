"""A dive whose samples or fit are junk: a depth spike is found before the fit, named and left
out; a fit that determines nothing (inertia σ beyond its value, a replay that explains nothing of
the channel) is not a model to use and is not written; no numpy warning reaches the user."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.examples import generate_example
from uuvid.identify.vehicle.dive import identify_dive
from uuvid.identify.vehicle.output_error import dead_band_weights
from uuvid.io.dive_channels import read_dive_channels
from uuvid.vehicle.writeback import WritebackError

runner = CliRunner()
FORCES = ["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]


@pytest.fixture(scope="module")
def pwm6() -> pd.DataFrame:
    """``uuvid examples dive`` without its force columns (thrust from the servo outputs)."""
    return pd.DataFrame(generate_example("dive")).drop(columns=FORCES)


@pytest.fixture(scope="module")
def clean(pwm6):
    return identify_dive(pwm6, "bluerov2", ["heave", "yaw"])


def _spiked(df: pd.DataFrame, value) -> tuple[pd.DataFrame, int]:
    """``df`` with one depth cell, a quarter into the dive, set to ``value(old)``."""
    idx = df.index[df["depth_m"].notna()]
    i = int(idx[len(idx) // 4])
    out = df.copy()
    out.loc[i, "depth_m"] = value(df.loc[i, "depth_m"])
    return out, i


@pytest.mark.parametrize("value, shown", [(lambda d: 1e6, "1e+06 m"),
                                          (lambda d: d + 20.0, " m at t = ")])
@pytest.mark.slow
def test_a_depth_spike_is_named_left_out_and_the_fit_kept(pwm6, clean, tmp_path, value, shown):
    """One depth cell of 1e6 m gave mass 29 ± 1.5 with depth rms 3.9e4 m, nrmse 1.00, called
    usable and written; a 20 m spike was taken silently."""
    df, i = _spiked(pwm6, value)
    p = tmp_path / "spike.csv"
    df.to_csv(p, index=False)
    dc = read_dive_channels(p, "bluerov2")
    said = [w for w in dc.warnings if "depth_m sample(s) jump" in w]
    assert len(said) == 1 and shown in said[0] and f"(row {i + 2})" in said[0], dc.warnings
    assert f"t = {df.loc[i, 't_s']:.6g} s" in said[0] and "left out" in said[0]
    assert dc.channels["depth_m"][0].size == pwm6["depth_m"].notna().sum() - 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # no numpy overflow reaches the user
        res = identify_dive(p, "bluerov2", ["heave"])
    e, c = res.estimates["heave"], clean.estimates["heave"]
    assert not e.unusable
    assert e.values["mass"] == pytest.approx(c.values["mass"], rel=0.05)
    assert e.train["rms"] < 2 * c.train["rms"]
    assert any("depth_m sample(s) jump" in w for w in res.warnings)


def test_a_run_of_impossible_depths_that_comes_back_is_left_out(pwm6, clean, tmp_path):
    """10 neighbouring depth samples set to 50 m (3 s of a dive at a few metres) left and came
    back faster than any ROV moves, but were more than SPIKE_MAX_SAMPLES: taken as a level change
    and fitted (heave mass 2.2e7 ± inf, the diagnosis blaming motor directions)."""
    df = pwm6.copy()
    idx = df.index[df["depth_m"].notna()]
    run = idx[len(idx) // 3:len(idx) // 3 + 10]
    df.loc[run, "depth_m"] = 50.0
    p = tmp_path / "spikes.csv"
    df.to_csv(p, index=False)
    dc = read_dive_channels(p, "bluerov2")
    said = [w for w in dc.warnings if "10 depth_m sample(s) jump" in w]
    assert len(said) == 1, dc.warnings
    first, last = run[0], run[-1]
    assert f"50 m at t = {df.loc[first, 't_s']:.6g} s (row {first + 2})" in said[0]
    assert f"the last 50 m at t = {df.loc[last, 't_s']:.6g} s (row {last + 2})" in said[0]
    assert "spikes.csv" in said[0] and "left out" in said[0]
    assert dc.channels["depth_m"][0].size == idx.size - 10
    assert dc.channels["depth_m"][1].max() < 40.0
    res = identify_dive(p, "bluerov2", ["heave"])
    e, c = res.estimates["heave"], clean.estimates["heave"]
    assert not e.unusable
    assert e.values["mass"] == pytest.approx(c.values["mass"], rel=0.05)


def test_the_clean_dive_has_no_spike_said(pwm6):
    dc = read_dive_channels(pwm6, "bluerov2")
    assert not any("jump" in w for w in dc.warnings)


def test_a_level_change_that_stays_is_not_a_spike(pwm6):
    df = pwm6.copy()
    idx = df.index[df["depth_m"].notna()]
    df.loc[idx[len(idx) // 2]:, "depth_m"] += 3.0  # a re-zeroed sensor: not a glitch
    dc = read_dive_channels(df, "bluerov2")
    assert not any("jump" in w for w in dc.warnings)
    assert dc.channels["depth_m"][0].size == idx.size


def test_a_fit_that_determines_nothing_is_not_a_model_to_use(clean, tmp_path):
    """σ of the inertia beyond its value, or a replay whose error is the channel's own spread
    (nrmse ≈ 1), made no reason: the estimate was written."""
    h = clean.estimates["heave"]
    loose = dataclasses.replace(h, sigma={**h.sigma, "mass": 2.1 * h.values["mass"]})
    assert any("σ of mass" in w and "more than 2× its value" in w for w in loose.unusable)
    near = dataclasses.replace(h, sigma={**h.sigma, "mass": 1.5 * h.values["mass"]})
    assert not near.unusable  # poorly determined (a warning), not undetermined
    flat = dataclasses.replace(h, train={**h.train, "nrmse": 1.001})
    assert any("explains nothing of the depth" in w for w in flat.unusable)
    blown = dataclasses.replace(h, train={**h.train, "rms": math.inf, "nrmse": math.nan})
    assert any("does not stay finite" in w for w in blown.unusable)
    res = dataclasses.replace(clean, estimates={**clean.estimates, "heave": flat})
    assert res.to_dict()["dofs"]["heave"]["unusable"]
    with pytest.raises(WritebackError, match="heave is not a model to use .*explains nothing"):
        res.write_vehicle(tmp_path / "v.yaml")
    assert not (tmp_path / "v.yaml").exists()
    assert not clean.estimates["heave"].unusable and not clean.estimates["yaw"].unusable


def test_an_unusable_yaw_fit_names_the_inertia_not_a_mass(clean):
    y = clean.estimates["yaw"]
    loose = dataclasses.replace(y, sigma={**y.sigma, "mass": math.inf})
    assert any("σ of inertia not finite" in w for w in loose.unusable), loose.unusable
    wide = dataclasses.replace(y, sigma={**y.sigma, "mass": 3 * y.values["mass"]})
    assert any(w.startswith("σ of inertia") for w in wide.unusable)
    assert not any("mass" in w for w in wide.unusable)


@pytest.mark.slow
def test_a_depth_that_does_not_follow_the_thrust_is_refused_by_the_command(pwm6, tmp_path):
    """Depth noise around 5 m, unrelated to the thrust: the model explains nothing of it."""
    df = pwm6.copy()
    m = df["depth_m"].notna()
    df.loc[m, "depth_m"] = 5.0 + 0.02 * np.random.default_rng(0).standard_normal(int(m.sum()))
    p = tmp_path / "noise.csv"
    df.to_csv(p, index=False)
    out = tmp_path / "n.yaml"
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(p), "--vehicle", "bluerov2",
                            "--dof", "heave", "--out-vehicle", str(out)])
    assert r.exit_code != 0 and not out.exists()
    assert "explains nothing of the depth" in r.output


def test_dead_band_weights_of_a_blown_up_replay_are_zero_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        w = dead_band_weights(np.array([0.0, 1e-3, 1e200]), 1e-3)
    assert w[0] == 1.0 and w[1] == pytest.approx(2 ** -0.5) and w[2] < 1e-100
