"""Servo outputs logged slower than attitude in an ArduSub log (a BlueROV2 streams
SERVO_OUTPUT_RAW at 2 Hz beside ATTITUDE at 20 Hz): the table read from the log keeps each
column's own sampling — PWM, thrust and force filled only on the rows where a new servo-output
sample arrived, empty between — so identification says the force is logged slowly and the
motor-direction check sees the samples as logged, as it does for the same dive written as a
table.  Synthetic .tlog files from test_ardusub's writer."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pymavlink")

from test_ardusub import DIRECTIONS, params, scenario, write_tlog  # noqa: E402

from uuvid.io.ardusub import load_dive  # noqa: E402
from uuvid.io.dive_channels import read_dive_channels  # noqa: E402

MODES = {"MANUAL": 19, "STABILIZE": 0, "ALT_HOLD": 2}


@pytest.mark.slow
def test_servo_outputs_slower_than_the_rows_are_left_empty_between_their_samples(tmp_path):
    """ATTITUDE at 20 Hz, SERVO_OUTPUT_RAW at 2 Hz: the rows are 0.05 s apart; pwm_n, thrust and
    Z_N were held on every row (read back as a 20 Hz force) — now filled every 0.5 s only, said
    in a warning, and the force channel identification reads is sampled every 0.5 s."""
    sc = scenario(n=300, dt=0.05)
    path = write_tlog(tmp_path / "d.tlog", sc, companion=False, servo_every=10)
    dive = load_dive(path, vehicle="bluerov2")
    tb = dive.table
    assert float(np.median(np.diff(tb["t_s"]))) == pytest.approx(0.05)
    for c in ("pwm_1", "thrust_1_N", "Z_N", "N_Nm"):
        t = tb["t_s"][np.isfinite(tb[c])].to_numpy()
        assert float(np.median(np.diff(t))) == pytest.approx(0.5, abs=0.06), c
    assert any("SERVO_OUTPUT_RAW" in w and "every 0.5" in w and "empty (NaN)" in w
               for w in dive.warnings)
    assert "every 0.5" in dive.provenance["pwm_1"]["sampled"]
    dc = read_dive_channels(path, "bluerov2")
    tz = dc.channels["Z_N"][0]
    assert float(np.median(np.diff(tz))) == pytest.approx(0.5, abs=0.06)


def test_servo_outputs_as_fast_as_the_rows_fill_every_row(tmp_path):
    """Outputs logged with the attitude (a .BIN's RCOU): every row keeps its PWM, as before."""
    sc = scenario(n=120, dt=0.1)
    dive = load_dive(write_tlog(tmp_path / "d.tlog", sc, companion=False), vehicle="bluerov2")
    assert np.isfinite(dive.table["Z_N"]).all()
    assert not any("slower than the table" in w for w in dive.warnings)


def _synthetic_tlog_and_table(tmp_path, prm=None, surge=0.0):
    """A synthetic dive at 20 Hz written as a .tlog with SERVO_OUTPUT_RAW at 2 Hz and as the
    table a CSV user writes of it (PWM cells empty between the 2 Hz samples)."""
    from uuvid.simulate.dive_synth import synthetic_dive

    df, _ = synthetic_dive(120.0, seed=5, surge=surge, jitter=0.0,
                           rates={"depth": 20, "yaw": 20, "pwm": 20, "battery": 20})
    df = df.dropna(subset=["depth_m", "yaw_rad", "pwm_1", "battery_V"]).reset_index(drop=True)
    cols = [f"pwm_{j}" for j in range(1, 7)]
    d = np.asarray(DIRECTIONS, float)
    sc = {"t": df["t_s"].to_numpy(), "pwm": 1500 + d * (df[cols].to_numpy() - 1500),
          "volts": df["battery_V"].to_numpy(), "depth": df["depth_m"].to_numpy(),
          "psi": df["yaw_rad"].to_numpy(), "armed": df["armed"].to_numpy(bool),
          "mode": df["mode"].map(MODES).to_numpy()}
    tlog = write_tlog(tmp_path / "dive.tlog", sc, prm=prm, companion=False, servo_every=10)
    table = df.copy()
    table.loc[np.arange(len(table)) % 10 != 0, cols] = np.nan
    csv = tmp_path / "dive.csv"
    table.drop(columns=[c for c in table if c.endswith(("_N", "_Nm"))]).to_csv(csv, index=False)
    return tlog, csv


@pytest.mark.slow
def test_a_tlog_with_2_hz_servo_outputs_warns_that_the_force_is_logged_slowly_as_its_table_does(
        tmp_path):
    """identify dive on the .tlog said nothing (the force looked 20 Hz) while the same dive as a
    table warned "the force … is logged every 0.5 s but yaw responds in about …"."""
    from uuvid.identify.vehicle.dive import identify_dive

    tlog, csv = _synthetic_tlog_and_table(tmp_path)
    for log in (tlog, csv):
        res = identify_dive(log, "bluerov2", ("yaw",), t_end=90.0)
        said = [w for w in res.estimates["yaw"].warnings if "is logged every" in w]
        assert said and "the force (N_Nm, from the servo outputs) is logged every 0.5 s" in said[0], \
            (log.name, res.estimates["yaw"].warnings)


def test_a_wrong_motor_direction_in_a_tlog_with_2_hz_servo_outputs_is_named(tmp_path):
    """MOT_3_DIRECTION in the log opposite to the motor on the vehicle: the direction check named
    it for the table but not for the .tlog (it saw each 2 Hz sample held over ten rows)."""
    wrong = list(DIRECTIONS)
    wrong[2] = -wrong[2]
    tlog, _ = _synthetic_tlog_and_table(tmp_path, prm=params(directions=wrong), surge=0.1)
    dc = read_dive_channels(tlog, "bluerov2")
    assert any("pwm_3 is probably reversed" in w and "MOT_3_DIRECTION" in w for w in dc.warnings), \
        dc.warnings


@pytest.mark.slow
def test_rows_after_the_servo_outputs_stop_are_kept_with_the_pwm_empty_and_said(tmp_path):
    """SERVO_OUTPUT_RAW stops at 8 s of a 20 s log whose depth and attitude run on: the export
    ended at 8 s without a word (the span was cut to where every channel has data).  Now the rows
    run to the end with PWM and force empty after 8 s, and export and inspect name the message,
    where its stream ends and the span without it."""
    from uuvid.io.ardusub import inspect_log

    sc = scenario(n=200, dt=0.1)
    path = write_tlog(tmp_path / "d.tlog", sc, companion=False, servo_until=8.0)
    dive = load_dive(path, vehicle="bluerov2")
    tb = dive.table
    assert tb["t_s"].iloc[-1] > 19.0
    after = tb["t_s"] > 8.2
    assert tb.loc[after, ["pwm_1", "thrust_1_N", "Z_N"]].isna().all().all()
    assert np.isfinite(tb.loc[~after & (tb["t_s"] < 7.9), "Z_N"]).all()
    assert np.isfinite(tb.loc[after, "depth_m"]).all()
    said = [w for w in dive.warnings if "SERVO_OUTPUT_RAW" in w and "stops at t = 8" in w]
    assert said and "before depth and attitude end (t = 19.9" in said[0], dive.warnings
    assert any("SERVO_OUTPUT_RAW" in w and "stops at t = 8" in w
               for w in inspect_log(path).warnings)


@pytest.mark.slow
def test_a_bin_record_with_a_corrupt_time_stamp_is_left_out_and_said(tmp_path):
    """One BAT record's TimeUS corrupted to 1.8e13 s in the middle of an 8 s .BIN: inspect said
    the log was 1.8e13 s long and export warned of a BAT gap of that length.  Now the record is
    left out, named with its stamp, and the log keeps its length."""
    import struct

    from test_ardusub import write_bin

    from uuvid.io.ardusub import inspect_log

    path = write_bin(tmp_path / "d.BIN", scenario(n=80))
    b = bytearray(path.read_bytes())
    head = bytes([0xA3, 0x95, 23])  # the BAT records (write_bin's type 23)
    at = [i for i in range(len(b) - 3) if b[i:i + 3] == head]
    b[at[40] + 3:at[40] + 11] = struct.pack("<Q", 18374686479681 * 10**6)
    path.write_bytes(bytes(b))
    ins = inspect_log(path)
    assert ins.duration_s < 10.0
    assert any("BAT record(s) carry a TimeUS far from the records" in w and "1.83747e+13" in w
               for w in ins.warnings), ins.warnings
    dive = load_dive(path, vehicle="bluerov2")
    assert not any("gap of" in w for w in dive.warnings)
    assert dive.table["t_s"].iloc[-1] < 10.0


@pytest.mark.parametrize("changes", [(100.0, 130.0), (50.0, 70.0, 190.0)])
def test_mode_records_minutes_apart_are_no_corrupt_stamps(tmp_path, changes):
    """The corrupt-TimeUS filter judged each message type by its own records: MODE records
    logged minutes apart (a first one at 0 s, the next at 100 s; a last change 120 s after the
    one before) were called corrupt and left out — ALT_HOLD read as MANUAL, MANUAL as UNKNOWN.
    A record is judged by the attitude records logged around it."""
    from test_ardusub import write_bin

    from uuvid.io.ardusub import inspect_log

    sc = scenario(n=2000, dt=0.1)
    t = sc["t"]
    mode = np.full(t.size, 19)  # MANUAL, ALT_HOLD (2) between alternate changes
    for k, t0 in enumerate(changes):
        mode[t >= t0] = 2 if k % 2 == 0 else 19
    sc["mode"] = mode
    ins = inspect_log(write_bin(tmp_path / "m.BIN", sc))
    assert not any("corrupt" in w for w in ins.warnings), ins.warnings
    spans = [(s["start_s"], s["mode"]) for s in ins.modes]
    for k, t0 in enumerate((0.0, *changes)):
        m = "MANUAL" if k % 2 == 0 else "ALT_HOLD"
        assert any(abs(a - t0) <= 2.5 and name == m for a, name in spans), (t0, m, spans)
    assert {name for _, name in spans} == {"MANUAL", "ALT_HOLD"}, spans


def test_empty_rows_between_slow_servo_samples_are_not_missing_commands(tmp_path):
    """A steady/inertia fit of a .tlog counted every empty row between the 2 Hz servo samples as
    a missing command sample (9 of every 10 rows); only rows in a hole of the outputs, or past
    their last sample, are missing."""
    from pathlib import Path

    from uuvid.identify.vehicle.logs import LogSpec, _read_ardusub_log

    sc = scenario(n=200, dt=0.05)
    whole = write_tlog(tmp_path / "d.tlog", sc, companion=False, servo_every=10)
    d = _read_ardusub_log(LogSpec(path=Path(whole), dof="heave", vehicle="bluerov2"))
    assert d.t_command_missing.size <= 10, (d.t_cmd.size, d.t_command_missing.size)
    cut = write_tlog(tmp_path / "c.tlog", scenario(n=400, dt=0.05), companion=False,
                     servo_every=10, servo_until=5.0)
    d = _read_ardusub_log(LogSpec(path=Path(cut), dof="heave", vehicle="bluerov2"))
    assert d.t_command_missing.size >= 250  # the last 15 s of 20 Hz rows have no output
    assert d.t_command_missing.min() >= 5.0 - 0.5
