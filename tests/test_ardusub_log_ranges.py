"""Second round of new-user traps in ``uuvid log`` on the real small ArduSub logs (skip when
../shared/data is absent): an absurd --dt, NaN and empty --t-start/--t-end, logs joined by
``cat``, cut-off files, and gaps in the log bridged by interpolation."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pymavlink")

from typer.testing import CliRunner  # noqa: E402

from uuvid.cli.app import app  # noqa: E402
from uuvid.io.ardusub import inspect_log, load_dive  # noqa: E402
from uuvid.io.logs import LogDataError  # noqa: E402


@pytest.fixture
def logs(shared_data):
    return shared_data / "ardusub-bluerov2"


def _export(log, tmp_path, *args):
    return CliRunner().invoke(app, ["log", "export", str(log), "--out-file",
                                    str(tmp_path / "x.csv"), *args])


def test_a_tiny_dt_is_refused_before_the_grid_is_built(logs, tmp_path):
    """--dt 1e-6 on the 23.6 s small.BIN headed for 23.6 M rows; now refused naming --dt and the
    row count (more than 100× the densest channel's samples)."""
    r = _export(logs / "small.BIN", tmp_path, "--dt", "1e-6")
    assert r.exit_code != 0
    assert "--dt 1e-06" in r.output and "rows" in r.output  # the memory check may come first
    assert "densest" in r.output or "GB of table" in r.output
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("opt", ["--t-start", "--t-end"])
def test_a_nan_time_bound_is_refused(logs, tmp_path, opt):
    """--t-start nan failed with "cannot convert float NaN to integer"; --t-end nan exported the
    whole log."""
    r = _export(logs / "small.BIN", tmp_path, opt, "nan")
    assert r.exit_code != 0 and f"{opt} nan: expected a finite time in s" in r.output
    with pytest.raises(LogDataError, match="expected a finite time in s"):
        load_dive(logs / "small.BIN", **{opt[2:].replace("-", "_"): math.nan})


def test_an_empty_or_outside_range_is_said_without_dt_or_none(logs, tmp_path):
    """[5, 5] s blamed a --dt nobody gave; --t-end -5 printed "t_start = None"."""
    r = _export(logs / "small.BIN", tmp_path, "--t-start", "5", "--t-end", "5")
    assert r.exit_code != 0 and "--dt" not in r.output and "after --t-start 5" in r.output
    r = _export(logs / "small.BIN", tmp_path, "--t-end", "-5")
    assert r.exit_code != 0 and "None" not in r.output
    assert "outside the log (0–23.6 s)" in r.output
    r = _export(logs / "small.BIN", tmp_path, "--t-start", "5", "--t-end", "5.01")
    assert r.exit_code != 0 and "--dt" not in r.output and "longer range" in r.output


def test_two_telemetry_logs_joined_with_cat_are_said_not_a_pymavlink_error(logs, tmp_path):
    """``cat small.tlog 2023-….tlog``: "cannot open the log: AttributeError: 'NoneType' object
    has no attribute '_instance_field'" from inside pymavlink."""
    a = (logs / "small.tlog").read_bytes()
    p = tmp_path / "two.tlog"
    p.write_bytes(a + (logs / "2023-04-18_11-03-34.tlog").read_bytes())
    r = CliRunner().invoke(app, ["log", "inspect", str(p)])
    assert r.exit_code != 0
    assert "AttributeError" not in r.output and "_instance_field" not in r.output
    assert "two.tlog" in r.output and "goes back" in r.output and f"byte {len(a):,}" in r.output


@pytest.mark.parametrize("name,cut,says", [
    ("small.BIN", 33086, "ends after 33,086 bytes holding only format and parameter records"),
    ("small.BIN", 5000, "ends after 5,000 bytes holding only its format (FMT) records"),
    ("small.tlog", 1000, "ends after 1,000 bytes (25 messages over 0.352 s) without an "
                         "autopilot HEARTBEAT: cut off"),
])
def test_a_cut_off_log_is_said_to_end_early(logs, tmp_path, name, cut, says):
    """A log cut after its format/parameter records said "none of ARM, ATT, … is in the log",
    "no messages in the log" or "no autopilot HEARTBEAT … senders (1/1)"."""
    p = tmp_path / f"cut_{name}"
    p.write_bytes((logs / name).read_bytes()[:cut])
    with pytest.raises(LogDataError, match="cut off") as e:
        inspect_log(p)
    assert says in str(e.value) and p.name in str(e.value)


def test_a_text_file_named_tlog_is_not_a_telemetry_log(tmp_path):
    """A CSV renamed .tlog: "no autopilot HEARTBEAT, so the vehicle among the senders () is
    unknown"."""
    p = tmp_path / "table.tlog"
    p.write_text("t,depth,roll\n" + "".join(f"{i * 0.1:.1f},{i * 0.01:.3f},0.0\n"
                                              for i in range(20000)))
    with pytest.raises(LogDataError, match="not a telemetry log"):
        inspect_log(p)


@pytest.mark.slow
def test_inspect_reads_modes_and_arming_per_part_as_export_does(logs, tmp_path):
    """``cat small.BIN small.BIN``: inspect said "8.8–48.3 s MANUAL, disarmed" across the reboot
    while export (right) has the vehicle armed again in part 1."""
    p = tmp_path / "twice.BIN"
    p.write_bytes((logs / "small.BIN").read_bytes() * 2)
    ins = inspect_log(p)
    assert ins.parts == 2
    exp = [(s["mode"], s["armed"], s["part"]) for s in load_dive(p).modes]
    got = [(s["mode"], s["armed"], s["part"]) for s in ins.modes]
    assert got == exp == [("MANUAL", True, 0), ("MANUAL", False, 0), ("MANUAL", True, 1),
                          ("MANUAL", False, 1)]
    armed1 = next(s for s in ins.modes if s["part"] == 1 and s["armed"])
    seg = next(s for s in load_dive(p).modes if s["part"] == 1 and s["armed"])
    assert abs(armed1["start_s"] - seg["start_s"]) < 0.2 and abs(armed1["end_s"] - seg["end_s"]) < 0.3
    r = CliRunner().invoke(app, ["log", "inspect", str(p)])
    assert "MANUAL, armed (part 1)" in r.output


def test_a_hole_in_a_telemetry_log_is_not_bridged_and_its_time_is_said(logs, tmp_path):
    """500 kB cut out of small.tlog: export drew straight lines over 94 s (PWM held) and the only
    warning said "44 bytes skipped … only the messages in the damaged bytes are lost"."""
    d = (logs / "small.tlog").read_bytes()
    p = tmp_path / "gap.tlog"
    p.write_bytes(d[:400000] + d[900000:])
    dive = load_dive(p)
    t = dive.table["t_s"].to_numpy()
    step = np.diff(t)
    assert step.max() > 90  # the hole is left out, not filled with rows
    k = int(np.argmax(step))
    assert 60 < t[k] < 66 and 155 < t[k + 1] < 160
    said = [w for w in dive.warnings if "ATTITUDE has no sample from t = 63" in w]
    assert said and "a gap of 94" in said[0] and "not interpolated" in said[0]
    damaged = [w for w in dive.warnings if "damaged" in w]
    assert damaged and "94.0 s of the log are lost" in damaged[0]
    assert "only the messages in the damaged bytes are lost" not in damaged[0]


def test_a_hole_in_a_dataflash_log_is_left_nan_or_out(logs, tmp_path):
    """A .BIN with 10 s of its records cut out: depth, attitude, battery linear across it."""
    d = (logs / "small.BIN").read_bytes()
    p = tmp_path / "gap.BIN"
    p.write_bytes(d[:100000] + d[200000:])
    dive = load_dive(p)
    tb = dive.table
    t = tb["t_s"].to_numpy()
    assert np.diff(t).max() > 5
    assert any("ATT has no sample from t = " in w and "not interpolated" in w
               for w in dive.warnings)
    # no row inside the hole (4.7–14.6 s) carries a value drawn across it
    inside = (t > 5.0) & (t < 14.0)
    assert not tb.loc[inside, ["roll_rad", "depth_m", "battery_V", "pwm_1"]].notna().to_numpy().any()


@pytest.mark.slow
def test_two_telemetry_sessions_joined_are_parts_not_a_16_day_dive(logs, tmp_path):
    """``cat 2023-….tlog small.tlog``: inspect said 1380106.8 s, export interpolated ~160 s
    between the sessions."""
    p = tmp_path / "two_rev.tlog"
    p.write_bytes((logs / "2023-04-18_11-03-34.tlog").read_bytes()
                  + (logs / "small.tlog").read_bytes())
    ins = inspect_log(p)
    assert ins.parts == 2 and ins.duration_s < 1000
    assert any("another recording session" in w for w in ins.warnings)
    dive = load_dive(p)
    assert "part" in dive.table and set(dive.table["part"]) == {0, 1}
    assert np.diff(dive.table["t_s"]).max() < 5


@pytest.mark.slow
@pytest.mark.parametrize("name", ["small.BIN", "small.tlog"])
def test_inspect_times_count_from_the_exports_t_s_and_say_so(logs, name):
    """inspect counted its mode/arming times from the autopilot's first message, export's t_s
    from the first row where depth, attitude and PWM all start (0.085 s later in small.BIN):
    inspect said 'armed until 8.8 s' where the table's row 8.7 s is already disarmed, and
    neither said its origin."""
    p = logs / name
    ins, dive = inspect_log(p), load_dive(p)
    assert ins.t0_boot_s == dive.provenance["t_s"]["t0_boot_s"]
    t, armed = dive.table["t_s"].to_numpy(), dive.table["armed"].to_numpy()
    changes = [s["start_s"] for a, s in zip(ins.modes, ins.modes[1:]) if a["armed"] is not None
               and s["armed"] is not None and a["armed"] != s["armed"]]
    assert changes
    for tc in changes:  # the first row at or after the change has the new state, the row before not
        k = int(np.searchsorted(t, tc - 1e-9))
        assert armed[k] != armed[k - 1], (tc, t[k - 1:k + 1], armed[k - 1:k + 1])
    s = ins.summary()
    assert f"`log export`'s first row, as its t_s; t = 0 at autopilot clock {ins.t0_boot_s:.3f} s" in s
    r = CliRunner().invoke(app, ["log", "inspect", str(p), "--json"])
    assert '"time_origin"' in r.output or "`log export`'s first row" in r.output


@pytest.mark.slow
def test_a_long_log_read_shows_its_progress_on_stderr_only(logs, monkeypatch, capfd):
    """Reading a large log (log inspect/export, load_dive) was silent however long it took;
    now its share read shows on stderr (a bar after PROGRESS_AFTER_S on a terminal, lines off
    one) — never in what is returned, never on stdout, never taken for pymavlink's chatter."""
    import json

    from uuvid.core import progress
    from uuvid.io.ardusub import reader

    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    monkeypatch.setattr(reader, "PROGRESS_AFTER_S", 0.0)  # as if every read were long
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.0)
    ins = inspect_log(logs / "small.tlog")
    out, err = capfd.readouterr()
    assert out == "" and "reading small.tlog: " in err and "%)" in err, err
    assert "reading small.tlog: done in" in err
    assert not any("reading small.tlog" in w or "pymavlink reported" in w for w in ins.warnings)
    r = CliRunner().invoke(app, ["log", "inspect", str(logs / "small.tlog"), "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["format"] == "tlog"
    assert "reading small.tlog: " in r.stderr
    monkeypatch.setenv("UUVID_NO_PROGRESS", "1")
    inspect_log(logs / "small.BIN")
    assert "reading" not in capfd.readouterr().err
