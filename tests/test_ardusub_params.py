"""A new user's report on ``uuvid log``: parameter values ArduSub does not accept
(BARO_PRIMARY that names no barometer, MOT_n_DIRECTION other than ±1) taken silently; thrust from
PWM at a voltage outside the thruster data without a warning; inspect and export disagreeing on
the mode spans.  Synthetic logs from test_ardusub's writers; the real small.BIN/.tlog checks skip
when ../shared/data is absent."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pymavlink")

from test_ardusub import params, scenario, write_bin  # noqa: E402
from typer.testing import CliRunner  # noqa: E402

from uuvid.cli.app import app  # noqa: E402
from uuvid.io.ardusub import load_dive  # noqa: E402
from uuvid.io.ardusub.frames import config_from_params, read_param_file  # noqa: E402
from uuvid.io.logs import LogDataError  # noqa: E402

REAL = "ardusub-bluerov2"


# ============================================================ 1, 2: given parameters are checked
@pytest.mark.parametrize("value", ["3", "-1", "1.5"])
def test_given_baro_primary_not_an_instance_is_an_error(tmp_path, value):
    f = tmp_path / "baro.param"
    f.write_text(f"FRAME_CONFIG 1\nBARO_PRIMARY {value}\n")
    with pytest.raises(LogDataError, match=rf"baro\.param: line 2: BARO_PRIMARY = {value} .*0, 1 or 2"):
        read_param_file(f)
    for ok in ("0", "1", "2"):
        f.write_text(f"BARO_PRIMARY {ok}\n")
        assert read_param_file(f) == {"BARO_PRIMARY": float(ok)}


@pytest.mark.parametrize("text, line, name, value", [
    ("MOT_1_DIRECTION 0\nMOT_2_DIRECTION -5\n", 1, "MOT_1_DIRECTION", "0"),
    ("MOT_1_DIRECTION 1\nMOT_2_DIRECTION,-5\n", 2, "MOT_2_DIRECTION", "-5"),
    ("1\t1\tMOT_4_DIRECTION\t-1\t9\n1\t1\tMOT_5_DIRECTION\t0.5\t9\n", 2, "MOT_5_DIRECTION", "0.5"),
])
def test_given_motor_direction_not_plus_minus_one_is_an_error(tmp_path, text, line, name, value):
    f = tmp_path / "dir.param"
    f.write_text(text)
    with pytest.raises(LogDataError, match=rf"dir\.param: line {line}: {name} = {value} .*1 .*-1"):
        read_param_file(f)


def test_given_dict_parameters_are_checked_too(tmp_path):
    sc = scenario(n=60)
    p = write_bin(tmp_path / "d.BIN", sc)
    with pytest.raises(LogDataError, match=r"BARO_PRIMARY = 3 .*0, 1 or 2"):
        load_dive(p, params={"BARO_PRIMARY": 3})
    with pytest.raises(LogDataError, match=r"MOT_2_DIRECTION = -5 .*-1"):
        load_dive(p, params={"MOT_2_DIRECTION": -5})


def test_export_and_identify_dive_refuse_a_bad_params_file(tmp_path):
    sc = scenario(n=60)
    p = write_bin(tmp_path / "d.BIN", sc)
    bad = tmp_path / "dir.param"
    bad.write_text("MOT_1_DIRECTION 0\n")
    r = CliRunner().invoke(app, ["log", "export", str(p), "--params", str(bad),
                                 "--out-file", str(tmp_path / "x.csv")])
    assert r.exit_code != 0 and "dir.param: line 1: MOT_1_DIRECTION = 0" in r.output
    assert not (tmp_path / "x.csv").exists()
    # identify dive reads a table's --params through the same parser
    from uuvid.io.dive_channels import read_dive_channels

    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "ok.csv")])
    assert r.exit_code == 0, r.output
    with pytest.raises(LogDataError, match=r"dir\.param: line 1: MOT_1_DIRECTION = 0"):
        read_dive_channels(tmp_path / "ok.csv", params=bad)


# ============================================== 1: a logged BARO_PRIMARY that names no barometer
def test_logged_baro_primary_not_an_instance_is_not_read_as_instance_0(tmp_path):
    sc = scenario(n=60)
    cfg = config_from_params(params(baro_primary=3))
    assert cfg.baro_primary is None
    assert "BARO_PRIMARY = 3 (no barometer instance)" in cfg.summary()
    # the synthetic log has no CTUN: as with BARO_PRIMARY = 2, no depth rather than the enclosure's
    d = load_dive(write_bin(tmp_path / "d.BIN", sc, prm=params(baro_primary=3)))
    assert d.table["depth_m"].isna().all()
    assert "BARO_PRIMARY = 3 is no barometer instance" in d.depth_source["why"]
    assert any(w.startswith("the log's BARO_PRIMARY = 3 is no barometer instance") for w in d.warnings)


@pytest.mark.realdata
def test_real_small_bin_logged_bad_baro_primary_falls_back_to_ctun(shared_data):
    from uuvid.io.ardusub.reader import read_raw
    from uuvid.io.ardusub.sources import _depth

    raw = read_raw(shared_data / REAL / "small.BIN")
    prm = dict(raw.param_values()[0])
    for bad in (3, -1, 1.5):
        prm["BARO_PRIMARY"] = bad
        warnings: list = []
        ch, src = _depth(raw, config_from_params(prm), warnings)
        assert src["message"] == "CTUN", src
        assert "water-pressure sensor" not in src["why"]
        assert any("BARO_PRIMARY" in w and "no barometer instance" in w for w in warnings)
        assert abs(float(np.mean(ch.v))) < 0.5  # on deck; instance 0 (the enclosure) reads 9.7 m


@pytest.mark.realdata
def test_real_small_bin_given_bad_baro_primary_is_an_error(shared_data, tmp_path):
    f = tmp_path / "baro3.param"
    f.write_text("BARO_PRIMARY 3\n")
    r = CliRunner().invoke(app, ["log", "export", str(shared_data / REAL / "small.BIN"), "--params",
                                 str(f), "--out-file", str(tmp_path / "b.csv")])
    assert r.exit_code != 0
    assert "baro3.param: line 1: BARO_PRIMARY = 3" in r.output and "0, 1 or 2" in r.output


# ======================================== 3: thrust from PWM outside the thruster data's voltage
def test_thrust_warnings_voltage_outside_the_t200_sheets():
    from uuvid.io.ardusub.thrust import default_t200, thrust_warnings

    tm = default_t200()
    t = np.arange(10.0)
    assert thrust_warnings(tm, np.full(10, 15.0), t) == []  # inside 12–16 V (and its 5 %)
    v = np.where(t >= 6, 17.4, 15.0)
    w = thrust_warnings(tm, v, t)
    assert len(w) == 1
    assert "17.40–17.40 V on 4 of 10 rows (t = 6.0–9.0 s)" in w[0]
    assert "outside the data's 12–16 V (Blue Robotics' T200 sheets)" in w[0]  # predict's sentence


def test_thrust_warnings_laidani_above_its_bench_voltage_and_falling():
    from uuvid.io.ardusub.thrust import load_thrust_model, thrust_warnings

    w = thrust_warnings(load_thrust_model("laidani-a2212"), np.full(5, 16.2))
    assert any("outside the data's 12 V" in s for s in w)
    assert any("at 16.20 V" in s and "forward: the steady output falls" in s for s in w)
    # at its bench's 12 V: no voltage warning (its map past 1780 µs falls there too, as predict says)
    w12 = thrust_warnings(load_thrust_model("laidani-a2212"), np.full(5, 12.0))
    assert not any("outside the data" in s for s in w12)


def test_load_dive_warns_thrust_at_a_voltage_outside_the_data(tmp_path):
    sc = scenario(n=60)
    assert not any("thrust from pwm" in w for w in load_dive(write_bin(tmp_path / "a.BIN", sc)).warnings)
    sc["volts"] = sc["volts"] + 1.0  # 17.4 V: above the T200 sheets and a 4S pack's 16.8 V
    d = load_dive(write_bin(tmp_path / "b.BIN", sc))
    w = [s for s in d.warnings if s.startswith("thrust from pwm (t200-physical): battery_V")]
    assert len(w) == 1 and "outside the data's 12–16 V" in w[0] and f"of {len(d.table)} rows" in w[0]


@pytest.mark.realdata
def test_real_small_bin_export_warns_the_voltage_in_the_sidecar(shared_data, tmp_path):
    import json

    out = tmp_path / "a.csv"
    r = CliRunner().invoke(app, ["log", "export", str(shared_data / REAL / "small.BIN"),
                                 "--out-file", str(out)])
    assert r.exit_code == 0, r.output
    assert "battery_V 17.35–17.40 V on 236 of 236 rows" in r.output
    side = json.loads((tmp_path / "a.csv.json").read_text())
    assert any("outside the data's 12–16 V" in w for w in side["warnings"])


# ========================================== 4: inspect and export say the same mode/arming spans
def _spans(modes):
    return [(m["mode"], m["armed"], f"{m['start_s']:.1f}", f"{m['end_s']:.1f}") for m in modes]


def test_inspect_and_export_mode_spans_agree_synthetic(tmp_path):
    """Export's spans ended at a run's last row (armed 0.0–1.9 s, disarmed from 2.0 s), inspect's at
    the event (2.0 s): both now tile the time axis, export's from row to row."""
    from uuvid.io.ardusub import inspect_log

    p = write_bin(tmp_path / "d.BIN", scenario(n=500))
    ins, d = inspect_log(p), load_dive(p)
    assert _spans(ins.modes) == _spans(d.modes)
    assert [s[:2] for s in _spans(d.modes)] == [("MANUAL", False), ("MANUAL", True),
                                                 ("ALT_HOLD", True), ("MANUAL", True)]
    assert d.modes[0]["last_row_s"] == pytest.approx(1.9)  # the run's last row is still said
    for a, b in zip(d.modes, d.modes[1:]):
        assert a["end_s"] == b["start_s"]


@pytest.mark.realdata
def test_real_small_bin_inspect_and_export_mode_spans_agree(shared_data, tmp_path):
    """small.BIN: inspect said "-0.1 – 8.7 s MANUAL, armed" (its first message, 0.085 s before
    export's first row, and the disarm event at 8.696 s), export "MANUAL armed 0.0–8.6 s" (its
    last armed row)."""
    from uuvid.io.ardusub import inspect_log

    p = shared_data / REAL / "small.BIN"
    ins, d = inspect_log(p), load_dive(p)
    assert _spans(ins.modes) == _spans(d.modes) == [("MANUAL", True, "0.0", "8.7"),
                                                     ("MANUAL", False, "8.7", "23.6")]
    assert "0.085 s before export's first row" in ins.summary()
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "m.csv")])
    assert "modes: MANUAL armed 0.0–8.7 s; MANUAL disarmed 8.7–23.6 s" in r.output


@pytest.mark.realdata
def test_real_small_bin_without_baro_primary_says_instance_0_is_assumed(shared_data):
    """Two barometers and no BARO_PRIMARY in the log: instance 0 is ArduSub's default, not a
    fact of this vehicle — the depth source says it is assumed, and a warning asks to check."""
    from uuvid.io.ardusub.reader import read_raw
    from uuvid.io.ardusub.sources import _depth

    raw = read_raw(shared_data / REAL / "small.BIN")
    prm = {k: v for k, v in dict(raw.param_values()[0]).items() if k != "BARO_PRIMARY"}
    warnings: list = []
    _, src = _depth(raw, config_from_params(prm), warnings)
    assert src.get("instance") == 0 and "not in the log" in src["why"], src
    assert "= BARO_PRIMARY" not in src["why"]
    assert any("BARO_PRIMARY is not in the log" in w for w in warnings), warnings
    warnings.clear()
    _, src = _depth(raw, config_from_params(dict(raw.param_values()[0])), warnings)
    assert "= BARO_PRIMARY" in src["why"] and not any("not in the log" in w for w in warnings)


def test_export_mode_spans_do_not_stretch_across_a_hole_in_the_rows():
    import pandas as pd

    from uuvid.io.ardusub.dive import _segments

    t = np.concatenate([np.arange(0.0, 10.0, 0.1), np.arange(60.0, 70.0, 0.1)])
    armed = t < 30.0
    df = pd.DataFrame({"t_s": t, "mode": "MANUAL", "armed": pd.array(armed, dtype="boolean"),
                       "part": 0})
    segs = _segments(df)
    assert [s["armed"] for s in segs] == [True, False]
    assert segs[0]["end_s"] == pytest.approx(10.0, abs=1e-9)  # last row 9.9 + a step, not 60
    assert segs[1]["start_s"] == pytest.approx(60.0)
    # no hole: the span runs to the next run's first row (the first time the change is seen)
    df2 = df[df["t_s"] < 10.0].assign(armed=pd.array(t[t < 10.0] < 5.0, dtype="boolean"))
    s2 = _segments(df2)
    assert s2[0]["end_s"] == pytest.approx(5.0) and s2[0]["last_row_s"] == pytest.approx(4.9)
