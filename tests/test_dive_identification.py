"""Identification from a whole piloted dive and its replay (issue 19).

Evidence: synthetic piloted dives flown by the project's 6-DOF model (MANUAL / STABILIZE /
ALT_HOLD with depth and heading controllers acting, battery sag, unmodelled tether drag, channels
at their own jittered rates) written as tables with force columns and as real .BIN/.tlog files
(ROS bags: tests/test_dive_rosbag.py).
The truth of a 1-DOF model is the vehicle's diagonal plus the tether drag; the dives used for the
truth checks fly no surge (surge couples into yaw through the Munk moment, which a 1-DOF model
does not have)."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.identify.vehicle.dive import identify_dive
from uuvid.io.dive_channels import DiveDataError
from uuvid.simulate.dive_replay import replay_dive
from uuvid.simulate.dive_synth import synthetic_dive
from uuvid.vehicle.definition import load_vehicle

runner = CliRunner()
PARAMS = ("mass", "linear", "quadratic", "bias")


@pytest.fixture(scope="module")
def dive():
    # .BIN-like force rate (RCOU 10 Hz); depth 3 Hz, yaw 20 Hz
    return synthetic_dive(360.0, seed=11, pwm_rate=10.0, surge=0.0)


@pytest.fixture(scope="module")
def result(dive):
    df, _ = dive
    return identify_dive(df, "bluerov2", t_end=270.0)


@pytest.mark.slow
def test_truth_within_3_sigma_and_the_preset_is_not(dive, result):
    _, truth = dive
    for dof in ("heave", "yaw"):
        e = result.estimates[dof]
        for k in PARAMS:
            assert abs(e.values[k] - truth[dof][k]) <= 3 * e.sigma[k], (dof, k, e.values[k],
                                                                        e.sigma[k], truth[dof][k])
        # the check can fail: the preset (no tether) is far outside the estimate's 3σ
        assert abs(e.values["quadratic"] - e.base["quadratic"]) > 3 * e.sigma["quadratic"]


@pytest.mark.slow
def test_held_out_part_is_predicted_near_the_noise_floor_and_better_than_the_preset(result):
    h = result.estimates["heave"].held_out
    assert h is not None and h["identified"]["rms"] < 0.03  # depth noise σ 1 cm
    assert h["improvement"] > 2
    y = result.estimates["yaw"].held_out
    assert y["identified"]["rms"] < 0.05 and y["improvement"] > 2  # heading noise σ 0.005 rad
    # the fit's residual is at the measurement noise
    assert result.estimates["heave"].train["rms_fit"] < 2 * 0.01


@pytest.mark.slow
def test_a_model_that_predicts_the_held_out_part_worse_than_the_base_is_not_written(result,
                                                                                  tmp_path):
    """The summary called a model 3× worse than the preset on the held-out part "0.32× better"
    and wrote it.  Worse by more than 10 %: "N× worse", not a model to use, the file refused;
    within 10 % (chance): said "worse", still written."""
    import dataclasses

    from uuvid.vehicle.writeback import WritebackError

    e = result.estimates["yaw"]
    h = dict(e.held_out)
    bad = dataclasses.replace(e, held_out={**h, "improvement": 1 / 3.1})
    assert any("3.1× worse than the base vehicle" in w for w in bad.unusable)
    res = dataclasses.replace(result, estimates={**result.estimates, "yaw": bad})
    assert "(3.1× worse than the base: not a model to use)" in res.summary()
    assert res.to_dict()["dofs"]["yaw"]["unusable"]
    with pytest.raises(WritebackError, match="yaw is not a model to use .*3.1× worse"):
        res.write_vehicle(tmp_path / "v.yaml")
    near = dataclasses.replace(e, held_out={**h, "improvement": 0.95})
    assert not near.unusable
    res = dataclasses.replace(result, estimates={**result.estimates, "yaw": near})
    assert "(1.05× worse)" in res.summary()
    res.write_vehicle(tmp_path / "w.yaml")


@pytest.mark.slow
def test_result_surface_and_report(result, tmp_path):
    d = result.to_dict()
    json.dumps(d)
    e = d["dofs"]["heave"]
    assert set(e["values"]) == set(PARAMS) and set(e["sigma"]) == set(PARAMS)
    assert e["ratio_to_base"]["mass"] == pytest.approx(e["values"]["mass"] / e["base"]["mass"])
    assert len(e["correlation"]["matrix"]) == 4
    text = result.summary()
    assert "held-out" in text and "of base" in text
    idx = result.report(tmp_path / "rep")
    assert idx.is_file() and (tmp_path / "rep" / "replay.png").is_file()


@pytest.mark.slow
def test_written_vehicle_replays_as_identified(result, dive, tmp_path):
    df, _ = dive
    out = result.write_vehicle(tmp_path / "mine.yaml")
    v = load_vehicle(out)
    assert v.one_dof["heave"].mass == pytest.approx(result.estimates["heave"].values["mass"],
                                                    rel=1e-5)
    ident = replay_dive(df, v, ["heave", "yaw"], t_start=270.0)
    base = replay_dive(df, "bluerov2", ["heave", "yaw"], t_start=270.0)
    for ch in ("depth", "heading"):
        assert ident.channels[ch]["rms"] < base.channels[ch]["rms"] / 2
        assert "one_dof" in ident.channels[ch]["params_source"]
    assert "W − B" in base.channels["depth"]["params_source"]
    # the 6-DOF model takes the identified net weight: W − B of the written rigid body equals the
    # heave bias (the weight kept), so an unpowered vehicle sinks or floats as the dive did
    bias = result.estimates["heave"].values["bias"]
    assert v.params.weight == pytest.approx(load_vehicle("bluerov2").params.weight)
    assert v.params.weight - v.params.buoyancy == pytest.approx(bias, abs=1e-3)


@pytest.mark.slow
def test_forces_from_pwm_columns_at_the_logged_voltage(dive, result):
    """A table with pwm_<j> and battery_V but no force columns: thrust from the T200 model at the
    logged voltage through the vehicle's B gives the same identification."""
    df, _ = dive
    res = identify_dive(df.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]),
                        "bluerov2", ["heave"], t_end=270.0)
    assert res.estimates["heave"].values["mass"] == pytest.approx(
        result.estimates["heave"].values["mass"], rel=1e-3)
    assert any("forces computed from pwm_1" in w and "at battery_V" in w for w in res.warnings)
    # no battery_V column: the warnings name the voltage used, not a column that is not there
    nov = identify_dive(df.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm", "battery_V"]),
                        "bluerov2", ["heave"], t_end=270.0)
    fw = [w for w in nov.warnings if "forces computed from pwm_1" in w]
    assert fw and "at the nominal 16 V" in fw[0] and "battery_V" not in fw[0]


@pytest.mark.slow
def test_bad_input_gives_clear_errors(dive):
    df, _ = dive
    with pytest.raises(DiveDataError, match="Z_N.*servo outputs"):
        identify_dive(df.drop(columns=["Z_N"] + [f"pwm_{j}" for j in range(1, 7)]), "bluerov2",
                      ["heave"])
    with pytest.raises(DiveDataError, match="depth source"):
        identify_dive(df.drop(columns=["depth_m"]), "bluerov2", ["heave"])
    unarmed = df.assign(armed=False)
    with pytest.raises(DiveDataError, match="unarmed log"):
        identify_dive(unarmed, "bluerov2")
    with pytest.raises(DiveDataError, match="window too short.*widen t_start/t_end"):
        identify_dive(df, "bluerov2", ["heave"], t_end=30.0)
    # every DOF failing: each one's reason (only heave's was said)
    with pytest.raises(DiveDataError, match=r"no DOF could be identified: heave: window too short"
                                            r".*; yaw: window too short"):
        identify_dive(df, "bluerov2", "all", t_end=30.0)
    with pytest.raises(DiveDataError, match="6 pwm_ columns.*8 thrusters"):
        identify_dive(df, "bluerov2-heavy")
    with pytest.raises(DiveDataError, match="surge velocity \\(DVL"):
        identify_dive(df, "bluerov2", ["surge"])
    with pytest.raises(DiveDataError, match="unknown DOF"):
        identify_dive(df, "bluerov2", ["pitch"])


@pytest.mark.slow
def test_cli_identify_dive_then_replay(dive, tmp_path):
    df, _ = dive
    log = tmp_path / "dive.csv"
    df.to_csv(log, index=False)
    out = tmp_path / "mine.yaml"
    res = runner.invoke(app, ["vehicle", "identify", "dive", str(log), "--vehicle", "bluerov2",
                              "--dof", "heave", "--t-end", "270", "--out-vehicle", str(out),
                              "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["dofs"]["heave"]["held_out"]["improvement"] > 2 and out.is_file()
    res = runner.invoke(app, ["vehicle", "replay", str(log), "--vehicle", str(out), "--dof",
                              "heave", "--t-start", "270", "--out", str(tmp_path / "rp"),
                              "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["channels"]["depth"]["rms"] < 0.03 and "nrmse" in doc["channels"]["depth"]
    assert (tmp_path / "rp" / "replay.png").is_file()
    res = runner.invoke(app, ["vehicle", "identify", "dive", str(log), "--vehicle", "bluerov2",
                              "--t-end", "20"])
    assert res.exit_code == 2 and "window too short" in res.output


@pytest.mark.slow
def test_surge_from_a_logged_velocity():
    """Surge is identified where a velocity is logged (DVL, 5 Hz); the 6-DOF vehicle pitches as it
    surges, so only the path and the plausibility of the numbers are checked here."""
    df, _ = synthetic_dive(200.0, seed=3, surge=0.3, pwm_rate=10.0, dvl=True)
    res = identify_dive(df, "bluerov2", ["surge"], t_end=160.0)
    e = res.estimates["surge"]
    assert 0.5 < e.values["mass"] / e.base["mass"] < 2 and e.held_out is not None
    assert "mass [kg]" in res.summary()


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["bin", "tlog"])
def test_identify_dive_from_ardusub_logs_with_reversed_and_disabled_outputs(fmt, tmp_path):
    """The synthetic dive written as a real .BIN / .tlog (10 Hz, per-motor reversal
    MOT_n_DIRECTION, SERVO7/8 disabled at 0 µs; .BIN: BARO[1] the water sensor; .tlog: receive
    stamps in 50 ms batches, a companion computer on its own clock) and read back through
    uuvid.io.ardusub: the truth within 3σ, the held-out part predicted 2× better than the preset."""
    pytest.importorskip("pymavlink")
    from test_ardusub import DIRECTIONS, write_bin, write_tlog

    df, truth = synthetic_dive(300.0, seed=7, surge=0.0, jitter=0.0,
                               rates={"depth": 10, "yaw": 10, "pwm": 10, "battery": 10})
    df = df.dropna(subset=["depth_m", "yaw_rad", "pwm_1", "battery_V"])
    d = np.asarray(DIRECTIONS, float)
    pwm = 1500 + d * (df[[f"pwm_{j}" for j in range(1, 7)]].to_numpy() - 1500)  # as logged
    modes = {"MANUAL": 19, "STABILIZE": 0, "ALT_HOLD": 2}
    sc = {"t": df["t_s"].to_numpy(), "pwm": pwm, "volts": df["battery_V"].to_numpy(),
          "depth": df["depth_m"].to_numpy(), "psi": df["yaw_rad"].to_numpy(),
          "armed": df["armed"].to_numpy(bool), "mode": df["mode"].map(modes).to_numpy()}
    path = (write_bin(tmp_path / "dive.BIN", sc) if fmt == "bin"
            else write_tlog(tmp_path / "dive.tlog", sc))
    res = identify_dive(path, "bluerov2", t_end=230.0)
    for dof in ("heave", "yaw"):
        e = res.estimates[dof]
        for k in PARAMS:
            assert abs(e.values[k] - truth[dof][k]) <= 3 * e.sigma[k], (dof, k, e.values[k],
                                                                        e.sigma[k])
        assert e.held_out["improvement"] > 2
    # the summary names where depth and heading came from (the water-pressure barometer)
    assert "BARO[1]" in res.sources["depth_m"] if fmt == "bin" else res.sources["depth_m"]
    assert "measured: depth_m from " in res.summary() and res.to_dict()["sources"]


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_truth_within_3_sigma_at_telemetry_rates_over_seeds(seed):
    """The issue's telemetry rates (servo outputs 2 Hz): heave's truth within 3σ on every seed; the
    force is then sampled slower than yaw responds, which identify dive must say."""
    df, truth = synthetic_dive(600.0, seed=seed, pwm_rate=2.0, surge=0.0)
    res = identify_dive(df, "bluerov2", t_end=450.0)
    e = res.estimates["heave"]
    for k in PARAMS:
        assert abs(e.values[k] - truth["heave"][k]) <= 3 * e.sigma[k], (seed, k)
    assert e.held_out["improvement"] > 2
    assert any("logged every" in w for w in res.estimates["yaw"].warnings)


@pytest.mark.slow
def test_yaw_sigma_covers_the_truth_over_forty_dives():
    """σ is judged over many dives, not one: 40 seeds (every one of 0–39), servo outputs logged
    at 50 Hz (fast enough that no sampling warning applies), the usual noise.  Of the 120 yaw
    estimates (mass, linear, quadratic drag) about 95 % should lie within 2σ and the median
    |error|/σ be near 0.67 (a normal's).  The plain window-cluster sandwich gave 82 % and a
    median 1.05 (the windows' own starts fitted part of each window's error away); the jackknife
    form is what covers.  Bounds left for 40 correlated dives: ≥ 85 %, median 0.45–0.95 (a σ
    inflated 1.5× would fall below 0.45)."""
    z = []
    for seed in range(40):
        df, truth = synthetic_dive(300.0, seed=seed, pwm_rate=50.0, surge=0.0)
        e = identify_dive(df, "bluerov2", ["yaw"], t_end=220.0).estimates["yaw"]
        z += [(e.values[k] - truth["yaw"][k]) / e.sigma[k] for k in ("mass", "linear", "quadratic")]
    z = np.abs(np.array(z))
    assert np.mean(z <= 2.0) >= 0.85, np.sort(z)[-20:]
    assert 0.45 <= np.median(z) <= 0.95, np.median(z)


def test_a_horizon_of_three_steps_holds_four_samples_and_is_not_refused():
    """The floor is 3 median steps (4 samples span 3 steps): a heading thinned to ≈ 1 Hz with
    jitter fitted with the default 4 s yaw horizon before the floor was added, and still does."""
    from uuvid.simulate.dive_synth import synthetic_dive

    df, _ = synthetic_dive(300.0, seed=3, rates={"yaw": 0.95})
    identify_dive(df, "bluerov2", ["yaw"])  # median step ≈ 1.05 s: 4 s ≥ 3.2 s


@pytest.mark.parametrize("h", [0.001, 0.1])
def test_a_horizon_shorter_than_four_samples_is_refused_before_any_window(h):
    """``--horizon 1e-9`` cut a 5-minute dive into 3·10¹¹ windows and ran without end (0.001 s:
    3·10⁵ windows, every one left out, then "window too short"): a window must hold four samples
    of the measured channel, and the refusal says the floor (yaw at 20 Hz: 3 steps, 0.15 s)."""
    from uuvid.simulate.dive_replay import replay_dive
    from uuvid.simulate.dive_synth import synthetic_dive

    df, _ = synthetic_dive(120.0, seed=3)
    for call in (lambda: identify_dive(df, "bluerov2", ["yaw"], horizon=h),
                 lambda: identify_dive(df, "bluerov2", ["heave"], horizon=h),
                 lambda: replay_dive(df, "bluerov2", horizon=h)):
        with pytest.raises(DiveDataError, match=rf"horizon={h:g} s is shorter than 4 samples of "
                                                r"(yaw_rad|depth_m) \(median step .* s\): .*give at "
                                                r"least"):
            call()


@pytest.mark.slow
@pytest.mark.realdata
def test_real_logs_without_a_dive_give_clear_errors(shared_data):
    """The shared real logs are deck/bench logs: one never armed, the others armed for seconds at
    the surface.  identify dive must say so rather than return a model."""
    d = shared_data / "ardusub-bluerov2"
    with pytest.raises(DiveDataError, match="unarmed log"):
        identify_dive(d / "2023-04-18_11-03-34.tlog", "bluerov2-heavy")
    with pytest.raises(DiveDataError, match="unarmed log"):
        replay_dive(d / "2023-04-18_11-03-34.tlog", "bluerov2-heavy")
    with pytest.raises(DiveDataError, match="window too short"):
        identify_dive(d / "small.tlog", "bluerov2-heavy", ["heave"])
    with pytest.raises(DiveDataError, match="window too short"):
        identify_dive(d / "small.BIN", "bluerov2", ["yaw"])
    # 16 s armed fill five 2 s yaw windows: that once returned four parameters correlated ±1
    with pytest.raises(DiveDataError, match="window too short.*30 s"):
        identify_dive(d / "small.tlog", "bluerov2-heavy", ["yaw"], horizon=2.0, t_end=218.0)


@pytest.mark.slow
def test_all_returns_what_the_log_can_inform_and_says_what_it_cannot(dive):
    """``--dof all`` on a log whose heading stops after 40 s: heave is identified and yaw is named
    in the warnings (too few windows); naming yaw explicitly is an error."""
    df, _ = dive
    cut = df.copy()
    cut.loc[cut["t_s"] > 40.0, "yaw_rad"] = np.nan
    res = identify_dive(cut, "bluerov2", "all")
    assert "heave" in res.estimates and "yaw" not in res.estimates
    assert any(w.startswith("yaw not identified") and "too short" in w for w in res.warnings)
    with pytest.raises(DiveDataError, match="too short to identify yaw"):
        identify_dive(cut, "bluerov2", ["heave", "yaw"])


@pytest.mark.slow
def test_too_short_a_dive_error_says_the_readers_warning_behind_it(dive, tmp_path):
    """A depth sensor stuck from t = 50 s: the reader warned that those samples are left out,
    then heave failed with 'window too short' — and the command printed only the error.  The
    error now carries the reader's warnings about the DOF's channel and samples left out."""
    df, _ = dive
    stuck = df.copy()
    stuck.loc[(stuck["t_s"] > 50.0) & stuck["depth_m"].notna(), "depth_m"] = 2.5
    p = tmp_path / "stuck.csv"
    stuck.to_csv(p, index=False)
    why = r"too short to identify heave.*the reader warned of this log: depth_m repeats 2\.5"
    with pytest.raises(DiveDataError, match=why):
        identify_dive(p, "bluerov2", ["heave"])
    with pytest.raises(DiveDataError, match=why):  # "all": the only DOF it could have had
        identify_dive(stuck.drop(columns=["yaw_rad"]), "bluerov2", "all")
    res = runner.invoke(app, ["vehicle", "identify", "dive", str(p), "--vehicle", "bluerov2",
                              "--dof", "heave"])
    out = " ".join(res.output.split())
    assert res.exit_code == 2 and "too short" in out and "a stuck sensor" in out, out
    # a reader warning about another matter (the force columns used) is not added to heave's
    assert "force columns" not in out


def test_a_dofs_error_carries_only_the_reader_warnings_naming_its_channels():
    """The error matched the reader's warnings by generic words: a camera's checksum failures
    ('skipped') and a 'disarmed' were added to every heave and yaw 'window too short' as if they
    explained it.  Only the warnings naming the DOF's channels are added now."""
    from types import SimpleNamespace

    from uuvid.identify.vehicle.dive import _with_reader_warnings

    dc = SimpleNamespace(name="d.tlog", warnings=[
        "d.tlog: 4 message(s) fail their checksum in every copy; skipped: 1 CAMERA_INFORMATION",
        "d.tlog: the vehicle disarmed at t = 12 s; samples dropped, data lost",
        "d.tlog: depth_m repeats 2.5 exactly from t = 50 to 90 s — those samples are left out",
        "d.tlog: yaw_rad repeats 0.1 exactly from t = 5 to 9 s — those samples are left out",
        "d.tlog: the table has all six force columns (X_N … N_Nm) and pwm_ columns"])
    e = DiveDataError("d.tlog: window too short to identify heave")
    assert str(_with_reader_warnings(e, ["heave"], dc)) == (
        "d.tlog: window too short to identify heave — the reader warned of this log: depth_m "
        "repeats 2.5 exactly from t = 50 to 90 s — those samples are left out")
    yaw = str(_with_reader_warnings(e, ["yaw"], dc))
    assert "yaw_rad repeats" in yaw and "depth_m" not in yaw and "N_Nm" not in yaw
    assert _with_reader_warnings(e, ["surge"], dc) is e
    # an ArduSub log's own words: the depth source, a part left out (every DOF's)
    dc.warnings = ["d.tlog: depth from VFR_HUD.alt: it has no on-board stamp",
                   "d.tlog: part 2: depth, attitude and PWM do not overlap; part left out"]
    heave = str(_with_reader_warnings(e, ["heave"], dc))
    assert "depth from VFR_HUD.alt" in heave and "part 2:" in heave
    assert "VFR_HUD" not in str(_with_reader_warnings(e, ["surge"], dc))


@pytest.mark.slow
def test_an_inertia_ten_times_the_base_is_a_warning_with_what_to_check(tmp_path):
    """The example dive with one horizontal motor's PWM mirrored (driven with the others, so the
    direction check names it too): yaw inertia ×11.5 of the base, said with what to check; the
    intact dive's is near the base and says nothing of the kind."""
    import pandas as pd

    from uuvid.examples import write_example

    df = pd.read_csv(write_example("dive", tmp_path)[0])
    df = df.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"])
    intact = identify_dive(df, "bluerov2", ["yaw"]).estimates["yaw"]
    df["pwm_1"] = 3000.0 - df["pwm_1"]
    res = identify_dive(df, "bluerov2", ["yaw"])
    mirrored = res.estimates["yaw"]
    # and it is not written into a vehicle file (the summary calls it no model to use)
    from uuvid.vehicle.writeback import WritebackError

    with pytest.raises(WritebackError, match="not written — yaw is not a model to use"):
        res.write_vehicle(tmp_path / "mine.yaml")
    assert not (tmp_path / "mine.yaml").exists()
    far = [w for w in mirrored.warnings if "beyond the ×8" in w]
    assert far and far[0].startswith("yaw inertia ×") and "motor directions" in far[0]
    # the summary does not call it "better" without saying it is no model to use
    assert any("inertia beyond ×8 of the base's" in w for w in mirrored.unusable), mirrored.unusable
    assert not intact.unusable
    text = "\n".join(mirrored.summary_lines(None))
    assert "not a model to use" in text and "× better" not in text
    assert not any("beyond the ×8" in w for w in intact.warnings)


@pytest.mark.slow
@pytest.mark.parametrize("forces", [True, False])
def test_a_depth_positive_up_is_said_as_such_with_or_without_force_columns(tmp_path, forces):
    """The example dive with depth_m = 15 − depth_m (a height above the bottom): with the force
    columns kept the mass came out ×1.17e6 with only "check the motor directions … the thruster
    model and the log's units"; with pwm_ columns only, the reader asked "is depth_m positive
    up?".  Both paths now ask it, and the far-from-base warning points at it too."""
    import pandas as pd

    from uuvid.examples import write_example

    df = pd.read_csv(write_example("dive", tmp_path)[0])
    df["depth_m"] = 15.0 - df["depth_m"]
    if not forces:
        df = df.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"])
    res = identify_dive(df, "bluerov2", ["heave"], t_end=220.0)
    said = [w for w in res.warnings if "opposes the heave force" in w]
    assert len(said) == 1 and "is depth_m positive up" in said[0], res.warnings
    assert ("logged in Z_N" in said[0]) == forces
    far = [w for w in res.estimates["heave"].warnings if "beyond the ×8" in w]
    assert far and "is depth_m positive up" in far[0] and "motor directions" not in far[0], far


def test_the_command_fails_when_a_dof_came_out_not_finite():
    """Printed for the record, but the exit status says no model was identified (it was 0 with
    every parameter NaN)."""
    from types import SimpleNamespace

    from uuvid.cli.dive_cmds import _not_finite

    ok = SimpleNamespace(values={"mass": 26.0, "linear": 1.0, "quadratic": 30.0, "bias": -2.0})
    nan = SimpleNamespace(values={"mass": float("nan"), "linear": 1.0, "quadratic": 30.0,
                                  "bias": -2.0})
    assert _not_finite(SimpleNamespace(estimates={"heave": ok, "yaw": nan})) == ["yaw"]
    assert _not_finite(SimpleNamespace(estimates={"heave": ok})) == []


@pytest.mark.slow
def test_armed_time_on_deck_does_not_enter_the_yaw_fit(tmp_path):
    """40 s armed on deck before the dive (depth 0, heading still, the horizontal motors pulsed as
    in a motor test) made the yaw inertia tens of times the base's.  Yaw windows wholly shallower
    than the surface limit are left out and said; the estimate is the dive's."""
    import pandas as pd

    from uuvid.examples import write_example

    df = pd.read_csv(write_example("dive", tmp_path)[0])
    df = df.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"])
    dive_only = identify_dive(df, "bluerov2", ["yaw"]).estimates["yaw"]
    t = np.arange(0.0, 40.0, 0.1)
    pulse = np.where((t % 8.0) < 2.0, 150.0, 0.0)
    rng = np.random.default_rng(0)  # a sensor on deck still reads its noise
    deck = pd.DataFrame({"t_s": t, "depth_m": 0.01 * rng.standard_normal(t.size),
                         "yaw_rad": float(df["yaw_rad"].iloc[0]) + 1e-3 * rng.standard_normal(t.size),
                         "roll_rad": 0.0, "pitch_rad": 0.0, "battery_V": 16.0,
                         "pwm_1": 1500 + pulse, "pwm_2": 1500 - pulse, "pwm_3": 1500 - pulse,
                         "pwm_4": 1500 + pulse, "pwm_5": 1500.0, "pwm_6": 1500.0,
                         "mode": "MANUAL", "armed": True})
    both = pd.concat([deck, df.assign(t_s=df["t_s"] + 40.05)], ignore_index=True)
    est = identify_dive(both, "bluerov2", ["yaw"]).estimates["yaw"]
    assert any("out of the water, armed on deck" in n and "left out" in n for n in est.notes)
    assert est.values["mass"] == pytest.approx(dive_only.values["mass"], rel=0.15)


@pytest.mark.slow
def test_surging_while_turning_is_said_in_the_yaw_estimate():
    """A piloted dive with surge stick (no DVL): the uncoupled yaw model absorbs the sway
    coupling (inertia several times the truth), so the yaw estimate says the pilot surged in
    many of its windows; the dive without surge says nothing of the kind."""
    said = {}
    for surge in (0.0, 0.3):
        df, _ = synthetic_dive(300.0, seed=31, pwm_rate=10.0, surge=surge)
        est = identify_dive(df, "bluerov2", ["yaw"], t_end=220.0).estimates["yaw"]
        said[surge] = [w for w in est.warnings if w.startswith("the pilot surged in ")]
    assert not said[0.0]
    assert len(said[0.3]) == 1 and "dofs=horizontal" in said[0.3][0]  # the API names its argument


@pytest.mark.slow
def test_a_long_dive_is_fitted_on_windows_spread_evenly_and_says_so(monkeypatch):
    """The fit's Jacobian is samples × (4 + 2 per window): a 1-hour yaw dive took ≈ 3 GB.  Beyond
    MAX_FIT_WINDOWS, that many windows spread over the dive are fitted, first and last kept."""
    from uuvid.simulate import dive_horizontal
    from uuvid.simulate.dive_synth import synthetic_dive

    notes = []
    w = [(float(i), float(i + 1)) for i in range(1000)]
    kept = dive_horizontal.spread_windows(w, notes, "yaw")
    assert len(kept) == dive_horizontal.MAX_FIT_WINDOWS and kept[0] == w[0] and kept[-1] == w[-1]
    assert notes and notes[0].startswith("1000 usable yaw windows: 250 spread evenly")
    assert dive_horizontal.spread_windows(w[:10], [], "yaw") == w[:10]
    monkeypatch.setattr(dive_horizontal, "MAX_FIT_WINDOWS", 40)
    df, _ = synthetic_dive(300.0, seed=2)
    e = identify_dive(df, "bluerov2", ["yaw"]).estimates["yaw"]
    assert e.windows == 40
