"""Traps a new user found in ``uuvid log`` (ArduSub logs): a parameter changed mid-log applied
to the whole log, outputs written by an export that then fails, a truncated .BIN read as whole,
and replay's reason for a log with no usable window.  Synthetic logs from test_ardusub's writers
reproduce each trap; the real small.BIN/.tlog checks skip when ../shared/data is absent."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pymavlink")

from test_ardusub import (  # noqa: E402
    _DF,
    BOOT0,
    UNIX0,
    _tlog_messages,
    _write_tlog_messages,
    params,
    scenario,
    write_bin,
    write_tlog,
)
from typer.testing import CliRunner  # noqa: E402

from uuvid.cli.app import app  # noqa: E402
from uuvid.io.ardusub import inspect_log, load_dive  # noqa: E402
from uuvid.io.logs import LogDataError  # noqa: E402


def _bin_with_change(path: Path, sc, name: str, value: float, at_s: float) -> Path:
    """The scenario's .BIN with ``name`` set to ``value`` at ``at_s`` s of the dive (a PARM
    record stamped then, as ArduSub writes one when a parameter is set)."""
    write_bin(path, sc)
    extra = _DF()
    extra.fmt(20, "PARM", "QNf", "TimeUS,Name,Value")
    extra.msg("PARM", int((BOOT0 + at_s) * 1e6), name, float(value))
    path.write_bytes(path.read_bytes() + b"".join(extra.out[2:]))
    return path


def _tlog_with_change(path: Path, sc, name: str, value: float, at_s: float) -> Path:
    """The scenario's .tlog with a PARAM_VALUE of ``name`` received at ``at_s`` s."""
    from pymavlink.dialects.v20 import ardupilotmega as mv

    write_tlog(path, sc, companion=False)
    msgs = _tlog_messages(path)
    ap = mv.MAVLink(None, srcSystem=1, srcComponent=1)
    buf = bytes(ap.param_value_encode(name.encode(), float(value), 9, 1, 0).pack(ap))
    t = UNIX0 + at_s
    k = next(i for i, m in enumerate(msgs) if m[0] > t)
    return _write_tlog_messages(path, msgs[:k] + [(t, "PARAM_VALUE", buf)] + msgs[k:])


@pytest.mark.parametrize("fmt", ["bin", "tlog"])
def test_a_direction_changed_mid_log_is_not_applied_to_the_rows_before_it(tmp_path, fmt):
    """MOT_1_DIRECTION −1 → +1 at 6 s: the export flipped the sign of thrust_1_N over the whole
    log ("the last value is used").  Now an error names the parameter, its values and when; each
    side read with --t-end/--t-start gets the value in force there."""
    sc = scenario(n=120)
    make = _bin_with_change if fmt == "bin" else _tlog_with_change
    p = make(tmp_path / f"d.{'BIN' if fmt == 'bin' else 'tlog'}", sc, "MOT_1_DIRECTION", 1.0, 6.0)
    with pytest.raises(LogDataError, match=r"MOT_1_DIRECTION: -1, then 1 from t = ") as e:
        load_dive(p)
    assert "--t-end" in str(e.value) and "--t-start" in str(e.value)
    before = load_dive(p, t_end=5.0)
    after = load_dive(p, t_start=7.0)
    assert before.config.motors[0].direction == -1.0 and after.config.motors[0].direction == 1.0
    assert before.table["t_s"].iloc[-1] <= 5.0 + 1e-9 and after.table["t_s"].iloc[0] >= 7.0 - 1e-9
    whole = load_dive(write_bin(tmp_path / "w.BIN", sc) if fmt == "bin"
                      else write_tlog(tmp_path / "w.tlog", sc, companion=False))
    # the rows before the change are the unchanged log's, on the same time
    w = whole.table.set_index("t_s")
    b = before.table.set_index("t_s")
    common = b.index.intersection(w.index)
    assert len(common) > 20
    np.testing.assert_allclose(b.loc[common, "thrust_1_N"], w.loc[common, "thrust_1_N"])
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "x.csv")])
    assert r.exit_code == 2 and "MOT_1_DIRECTION" in r.output, r.output
    assert not (tmp_path / "x.csv").exists()
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "y.csv"),
                                 "--t-start", "7"])
    assert r.exit_code == 0, r.output


def test_a_primary_barometer_changed_mid_log_is_an_error_and_inspect_says_when(tmp_path):
    """BARO_PRIMARY 1 → 0 at 5 s: depth came from the enclosure sensor (≈ 9 m) for the whole
    log and inspect called BARO[0] the water-pressure sensor.  Now export refuses the mixed
    table, and inspect shows the start's configuration and says when it changed."""
    sc = scenario(n=120)
    p = _bin_with_change(tmp_path / "d.BIN", sc, "BARO_PRIMARY", 0.0, 5.0)
    with pytest.raises(LogDataError, match=r"BARO_PRIMARY: 1, then 0 from t = "):
        load_dive(p)
    d = load_dive(p, t_end=4.0)
    np.testing.assert_allclose(d.table["depth_m"].iloc[0], sc["depth"][0], atol=0.05)
    ins = inspect_log(p)
    assert ins.depth_source["instance"] == 1, ins.depth_source
    assert any("BARO_PRIMARY" in w and "t = 5" in w for w in ins.warnings), ins.warnings


def test_a_parameter_given_with_params_holds_for_the_whole_log(tmp_path):
    sc = scenario(n=120)
    p = _bin_with_change(tmp_path / "d.BIN", sc, "MOT_1_DIRECTION", 1.0, 6.0)
    d = load_dive(p, params={"MOT_1_DIRECTION": -1.0})
    assert d.config.motors[0].direction == -1.0


def test_unchanged_parameters_repeated_after_the_dump_are_no_change(tmp_path):
    sc = scenario(n=80)
    p = _bin_with_change(tmp_path / "d.BIN", sc, "MOT_1_DIRECTION", params()["MOT_1_DIRECTION"], 3.0)
    d = load_dive(p)
    assert not any("MOT_1_DIRECTION" in w for w in d.warnings)


@pytest.mark.parametrize("back_s, first", [(None, None), (2.0, None), (None, "ATTITUDE")])
def test_a_tlog_joined_to_a_copy_of_itself_is_refused_with_the_byte_to_split_at(tmp_path, back_s,
                                                                                first):
    """A .tlog followed by itself (receive clock back by the whole log) or by a copy received
    only half a log later (back by half) was read as an autopilot reboot and the two copies
    interleaved or averaged; only a jump of days was refused.  Both clocks going back is two
    logs, whatever the size; a reboot keeps the receive clock running on.  ``first``: the
    appended copy starts at a message that carries the autopilot's clock itself (time_boot_ms),
    as a log cut at a random message does one time in three."""
    msgs = _tlog_messages(write_tlog(tmp_path / "a.tlog", scenario(n=80), companion=False))
    one = _write_tlog_messages(tmp_path / "one.tlog", msgs)
    span = msgs[-1][0] - msgs[0][0]
    shift = 0.0 if back_s is None else span / back_s
    tail = [(t + shift, ty, b) for t, ty, b in msgs]
    if first is not None:
        tail = tail[next(i for i, m in enumerate(tail) if m[1] == first):]
    joined = _write_tlog_messages(tmp_path / "joined.tlog", msgs + tail)
    size = one.stat().st_size
    for read in (inspect_log, load_dive):
        with pytest.raises(LogDataError, match=f"goes back by .* at byte {size:,} while the "
                                               f"autopilot's clock restarts.*split it at byte "
                                               f"{size:,}"):
            read(joined)


def test_a_reboot_with_the_receive_clock_running_on_is_still_a_reboot(tmp_path):
    d = load_dive(write_tlog(tmp_path / "r.tlog", scenario(n=80), reboot_at=40))
    assert any("rebooted 1 time(s)" in w for w in d.warnings)


@pytest.mark.slow
def test_no_usable_depth_names_the_other_barometer_that_varies_like_water_pressure(tmp_path):
    """BARO_PRIMARY naming the enclosure barometer (constant) while the other one swings by tens
    of kPa gave "no usable depth" without a word about the sensor that measured the water."""
    prm = {**params(), "BARO_PRIMARY": 0}
    d = load_dive(write_tlog(tmp_path / "s.tlog", scenario(n=80), prm=prm, gpi=False))
    said = [w for w in d.warnings if "no usable depth" in w]
    assert said and "SCALED_PRESSURE2.press_abs (barometer 1) varies by" in said[0], d.warnings
    assert "BARO_PRIMARY = 1" in said[0] and "--params" in said[0]
    ok = load_dive(write_tlog(tmp_path / "ok.tlog", scenario(n=80), gpi=False))
    assert not any("varies by" in w for w in ok.warnings)


# ------------------------------------------------------------------- outputs: all or none
def test_export_with_a_figure_that_cannot_be_written_writes_nothing(tmp_path, monkeypatch):
    """--plot /proc/x.png: the table and its provenance were written, then the command failed
    naming the temporary file (/proc/.tmp-…-x.png).  Now every output is checked before the log
    is read, and the message names the option and the path given."""
    monkeypatch.chdir(tmp_path)
    p = write_bin(tmp_path / "d.BIN", scenario(n=60))
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", "g1.csv", "--plot",
                                 "/proc/x.png"])
    assert r.exit_code == 2
    out = " ".join(r.output.split())
    assert "--plot /proc/x.png" in out and ".tmp-" not in out, out
    assert not (tmp_path / "g1.csv").exists() and not (tmp_path / "g1.csv.json").exists()


def test_export_with_a_folder_where_the_provenance_goes_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    p = write_bin(tmp_path / "d.BIN", scenario(n=60))
    (tmp_path / "g5.csv.json").mkdir()
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", "g5.csv"])
    assert r.exit_code == 2
    out = " ".join(r.output.split())
    assert "--out-file g5.csv" in out and "g5.csv.json" in out and "folder" in out, out
    assert not (tmp_path / "g5.csv").exists()


def test_export_whose_table_fails_after_the_figure_leaves_no_figure(tmp_path, monkeypatch):
    """A write that fails after the checks (disk full): the figure already written is removed
    and the option is named, not the temporary file."""
    from uuvid.io.ardusub import dive as dive_mod

    def full(self, out, plot=None):
        raise OSError(28, "No space left on device", str(Path(out).parent / ".tmp-1-abcdef12-x.csv"))

    monkeypatch.setattr(dive_mod.DiveLog, "export", full)
    p = write_bin(tmp_path / "d.BIN", scenario(n=60))
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "x.csv"),
                                 "--plot", str(tmp_path / "x.png")])
    assert r.exit_code == 2 and "--out-file" in r.output and ".tmp-" not in r.output, r.output
    assert not (tmp_path / "x.png").exists()


def test_export_interrupted_while_writing_the_table_leaves_no_figure(tmp_path, monkeypatch):
    """Ctrl-C while the table was written left the figure (saved first) without the table and
    its provenance; the figure now takes its name only after the table did."""
    from uuvid.core import progress
    from uuvid.io.ardusub import export as export_mod

    monkeypatch.setattr(progress, "_INTERRUPT_SAID", [False])

    def interrupted(path, obj, *a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(export_mod, "atomic_write_json", interrupted)
    p = write_bin(tmp_path / "d.BIN", scenario(n=60))
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "x.csv"),
                                 "--plot", str(tmp_path / "x.png")])
    assert r.exit_code == 130 and "interrupted" in r.output, r.output
    assert sorted(f.name for f in tmp_path.iterdir()) == ["d.BIN"]  # no temporary file either


def test_export_figure_that_fails_to_save_names_the_plot_option(tmp_path, monkeypatch):
    from uuvid.io.ardusub import export as export_mod

    def full(dive, path=None):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(export_mod, "plot_dive", full)
    p = write_bin(tmp_path / "d.BIN", scenario(n=60))
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "x.csv"),
                                 "--plot", str(tmp_path / "x.png")])
    out = " ".join(r.output.split())
    assert r.exit_code == 2 and "--plot" in out and ".tmp-" not in out, out
    assert sorted(f.name for f in tmp_path.iterdir()) == ["d.BIN"]


def test_thruster_export_to_an_unwritable_place_names_the_option(tmp_path):
    (tmp_path / "d.xml").mkdir()
    for target, said in (("/proc/x.xml", "cannot write in /proc"), (str(tmp_path / "d.xml"), "folder")):
        r = CliRunner().invoke(app, ["thruster", "export", "t200", "--to", "uuv-simulator",
                                     "--out-file", target])
        out = " ".join(r.output.split())
        assert r.exit_code == 2 and f"--out-file {target}" in out and said in out, out
        assert ".tmp-" not in out


def test_the_entry_point_names_an_atomic_writes_target_not_its_temporary_file(monkeypatch, capsys):
    import sys

    from uuvid.cli import app as app_mod

    def boom():
        raise FileNotFoundError(2, "No such file or directory", "/proc/.tmp-1012-0a1b2c3d-x.png")

    monkeypatch.setattr(app_mod, "_app", boom)
    monkeypatch.setattr(app_mod, "_register_subcommands", lambda c: None)
    monkeypatch.setattr(sys, "argv", ["uuvid", "log"])
    with pytest.raises(SystemExit):
        app_mod.main()
    err = capsys.readouterr().err
    assert "/proc/x.png" in err and ".tmp-" not in err, err


# ---------------------------------------------------------------------------- a cut-off .BIN
def _cut_off_said(warnings_) -> list[str]:
    return [w for w in warnings_ if "cut off" in w]


@pytest.mark.parametrize("keep", [17, 5])
def test_a_bin_cut_off_mid_record_is_said_with_the_last_complete_time(tmp_path, keep):
    """A .BIN cut inside its last record was read without a word (a cut .tlog is said)."""
    from uuvid.io.ardusub.reader import read_raw
    from uuvid.io.logs import LogWarning, read_ardusub

    whole = write_bin(tmp_path / "w.BIN", scenario(n=60)).read_bytes()
    rcou = 3 + 8 + 8 * 2  # the last record written: RCOU (header, TimeUS, C1…C8)
    p = tmp_path / "cut.BIN"
    p.write_bytes(whole[:len(whole) - rcou + keep])  # `keep` bytes of the last record
    said = _cut_off_said(read_raw(p).warnings)
    assert len(said) == 1 and "last complete record is at t = " in said[0], said
    assert _cut_off_said(inspect_log(p).warnings) == said
    assert _cut_off_said(load_dive(p).warnings) == said
    with pytest.warns(LogWarning, match="cut off"):
        read_ardusub(p, on_duplicate="mean")
    assert not _cut_off_said(read_raw(tmp_path / "w.BIN").warnings)


@pytest.mark.realdata
def test_real_small_bin_cut_at_half_is_said(shared_data, tmp_path):
    src = (shared_data / "ardusub-bluerov2" / "small.BIN").read_bytes()
    p = tmp_path / "cut.BIN"
    p.write_bytes(src[:len(src) // 2 + 17])
    said = _cut_off_said(inspect_log(p).warnings)
    assert len(said) == 1 and "t = 9.3" in said[0], said
    assert not _cut_off_said(inspect_log(shared_data / "ardusub-bluerov2" / "small.BIN").warnings)


# ------------------------------------------------------------- replay of a log armed on deck
def _deck_table(seconds: float = 16.0):
    """Armed on deck: depth ≈ 0 (the sensor in air), heading still, yaw motors pulsed."""
    import pandas as pd

    t = np.arange(0.0, seconds, 0.1)
    pulse = np.where((t % 8.0) < 2.0, 150.0, 0.0)
    rng = np.random.default_rng(0)
    return pd.DataFrame({"t_s": t, "depth_m": 0.01 * rng.standard_normal(t.size),
                         "yaw_rad": 1.0 + 1e-3 * rng.standard_normal(t.size),
                         "roll_rad": 0.0, "pitch_rad": 0.0, "battery_V": 16.0,
                         "pwm_1": 1500 + pulse, "pwm_2": 1500 - pulse, "pwm_3": 1500 - pulse,
                         "pwm_4": 1500 + pulse, "pwm_5": 1500.0, "pwm_6": 1500.0,
                         "mode": "MANUAL", "armed": True})


def test_replay_of_a_log_armed_only_on_deck_says_so(tmp_path):
    """16 s armed on deck: replay said "no armed window of the horizon", hiding the reason
    identify gives (the windows were out of the water, armed on deck)."""
    from uuvid.io.dive_channels import DiveDataError
    from uuvid.simulate.dive_replay import replay_dive

    with pytest.raises(DiveDataError, match=r"out of the water, armed on deck .* left out") as e:
        replay_dive(_deck_table(), "bluerov2", ["yaw"], horizon=3.0)
    assert "in the water" in str(e.value)


@pytest.mark.realdata
def test_replay_of_the_real_small_tlog_says_it_was_on_deck(shared_data):
    r = CliRunner().invoke(app, ["vehicle", "replay", str(shared_data / "ardusub-bluerov2" /
                                                          "small.tlog"),
                                 "--vehicle", "bluerov2-heavy", "--dof", "yaw", "--horizon", "3"])
    out = " ".join(r.output.split())
    assert r.exit_code == 2 and "armed on deck" in out, out


def test_identify_and_replay_read_a_log_changed_mid_way_on_the_part_they_use(tmp_path):
    """identify dive / vehicle replay read a whole ArduSub log before cutting it to --t-start /
    --t-end, so a motor direction changed mid-log stopped them even when the part asked for lies
    on one side of the change: that part is now read in the configuration in force there; with
    no window, or one across the change, the error names the change and the options."""
    from uuvid.io.dive_channels import read_dive_channels

    sc = scenario(n=120)
    p = _bin_with_change(tmp_path / "d.BIN", sc, "MOT_1_DIRECTION", 1.0, 6.0)
    with pytest.raises(LogDataError, match=r"MOT_1_DIRECTION: -1, then 1 from t = .*--t-end"):
        read_dive_channels(p, "bluerov2")
    with pytest.raises(LogDataError, match="MOT_1_DIRECTION"):
        read_dive_channels(p, "bluerov2", t_start=2.0, t_end=9.0)
    before = read_dive_channels(p, "bluerov2", t_end=5.0)
    after = read_dive_channels(p, "bluerov2", t_start=7.0)
    whole = read_dive_channels(write_bin(tmp_path / "w.BIN", sc), "bluerov2")
    t_b, z_b = before.channels["Z_N"] if "Z_N" in before.channels else before.channels["X_N"]
    t_w, z_w = whole.channels["Z_N"] if "Z_N" in whole.channels else whole.channels["X_N"]
    common = np.intersect1d(t_b, t_w)
    assert common.size > 20
    np.testing.assert_allclose(z_b[np.isin(t_b, common)], z_w[np.isin(t_w, common)])
    assert after.channels["depth_m"][0][0] >= 7.0 - 1e-9
    # identify's --t-end ends its training part: the rows after it (held out) are kept when the
    # change lies before --t-start, and said to be lost when only --t-end avoids it
    held = read_dive_channels(p, "bluerov2", t_start=7.0, t_end=9.0)
    assert held.channels["depth_m"][0][-1] > 10.0
    assert any("no held-out part" in w for w in before.warnings)
    assert not any("no held-out part" in w for w in held.warnings)


def test_a_direction_set_on_deck_before_the_dive_is_the_dives_configuration(tmp_path):
    """The usual set-up: MOT_1_DIRECTION changed while disarmed (the scenario arms at 2 s), then
    the dive. Every armed row is in one configuration, so the table is read in it (a disarmed
    row's thrust is zero either way), with a warning saying so — not refused."""
    sc = scenario(n=120)
    p = _bin_with_change(tmp_path / "d.BIN", sc, "MOT_1_DIRECTION", 1.0, 1.0)
    d = load_dive(p)
    assert d.config.motors[0].direction == 1.0
    said = [w for w in d.warnings if "MOT_1_DIRECTION" in w]
    assert said and "while disarmed" in said[0] and "its value here is 1" in said[0], d.warnings
    # the armed rows equal a log that had +1 throughout
    prm = params()
    prm["MOT_1_DIRECTION"] = 1.0
    w = load_dive(write_bin(tmp_path / "w.BIN", sc, prm=prm)).table.set_index("t_s")
    b = d.table.set_index("t_s")
    armed = b.index[b["armed"].fillna(False).to_numpy(bool)]
    assert len(armed) > 50
    np.testing.assert_allclose(b.loc[armed, "thrust_1_N"], w.loc[armed, "thrust_1_N"])


def test_a_direction_changed_across_a_reboot_is_an_error(tmp_path):
    """A changed MOT_1_DIRECTION in the parameter dump after a reboot (a change, then a
    restart) fell between the log's two parts and was applied nowhere: every row read with the
    first value, with a warning saying the change was outside the table.  Now the change is
    found between the first and the last row: an error, unless every armed row is on one side."""
    import test_ardusub as ta

    sc = scenario(n=120)
    p1 = params()
    p2 = dict(p1, MOT_1_DIRECTION=-p1["MOT_1_DIRECTION"])
    calls = {"n": 0}

    class Dump(dict):  # write_bin writes the dump at the start and after the reboot
        def items(self):
            calls["n"] += 1
            return (p1 if calls["n"] == 1 else p2).items()

    path = ta.write_bin(tmp_path / "r.BIN", sc, prm=Dump(p1), reboot_at=60)
    with pytest.raises(LogDataError, match=r"MOT_1_DIRECTION: "):
        load_dive(path)


def test_a_re_export_whose_provenance_cannot_be_written_keeps_the_earlier_export(tmp_path,
                                                                                monkeypatch):
    """The table replaced an earlier export of the same name, then the provenance failed and
    the new table was deleted: the earlier good CSV was lost and its stale .json stayed.  The
    provenance is now written before the table replaces anything."""
    from uuvid.io.ardusub import export as export_mod

    d = load_dive(write_bin(tmp_path / "d.BIN", scenario(n=60)))
    out = tmp_path / "x.csv"
    d.export(out)
    before = (out.read_bytes(), (tmp_path / "x.csv.json").read_bytes())

    def full(path, obj, *a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(export_mod, "atomic_write_json", full)
    d2 = load_dive(write_bin(tmp_path / "e.BIN", scenario(n=80)))
    with pytest.raises(OSError):
        d2.export(out)
    assert (out.read_bytes(), (tmp_path / "x.csv.json").read_bytes()) == before
