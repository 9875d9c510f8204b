"""Bad input that was accepted silently, ran unbounded or failed with a traceback (a new user's
trial, stop 36): each is now a clear error or said — a mission cut short by its duration, a
controller giving NaN, an empty scenario file, a water density read as a specific gravity, a
vehicle without thrusters, a figure suffix no backend writes, a σ whose variance overflows."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.io.logs import LogDataError

runner = CliRunner()

NAN_CONTROLLER = '''
from uuvid.simulate.control.blocks import Controller


def _f(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    for j in range(6):
        tau_out[j] = float("nan") if t > 1.0 else 0.0


def make_controller(vehicle, context):
    return Controller(_f, [0.0], [])
'''


def _said(res) -> str:
    return " ".join(res.output.split())


@pytest.mark.slow
def test_a_mission_cut_short_by_its_duration_says_so(tmp_path):
    """A 10 km-deep square with ``duration: 5`` reported "completed True" after 5 s and nothing
    else: the vehicle had tracked the first seconds of the reference.  Then ``completed: true``
    beside ``path_finished: false``: a mission stopped before its path's end is not completed,
    and ``completed_reason`` says why (as the summary text and the batch's column)."""
    from uuvid.simulate import batch
    from uuvid.simulate.scenario import build, scenario_from_dict
    from uuvid.simulate.vehicle_sim import fly_mission

    _, setup = build(scenario_from_dict({"mission": {"depth": 50, "speed": 0.5}, "duration": 5}))
    res = fly_mission(setup)
    s = res.metrics
    assert s["path_finished"] is False and s["completed"] is False
    from uuvid.simulate.vehicle_sim import path_cut

    end = path_cut(setup)
    assert end is not None and end > 5
    assert s["max_tracking_error_m"] < 1.0 and s["max_tilt_deg"] <= 20.0  # tracked, level
    assert s["completed_reason"] == (f"the duration ends before the path (flight stops at 5 s, "
                                     f"path ends at {end:.4g} s)")
    assert any("before the path ends" in w and "cuts the mission short" in w for w in s["warnings"])
    assert "NOT completed (the duration ends before the path" in res.summary()
    out = batch.run_batch_fast(setup, setup.vp[None, :])
    assert out[0, 0] < 1.0 and out[0, 5] == 0.0  # the batch's column: the same meaning
    _, full = build(scenario_from_dict({"mission": {"depth": 2, "speed": 0.5}}))
    assert path_cut(full) is None
    m = fly_mission(full).metrics  # 0.5 m/s tilts the BlueROV2: not completed, for that alone
    assert m["path_finished"] is True and m["completed_reason"].startswith("tilted ")
    assert "duration" not in m["completed_reason"]


@pytest.mark.slow
def test_simulate_cut_by_duration_prints_not_completed(tmp_path):
    """``uuvid simulate s.yaml --json`` and its table said completed for a duration stopping
    the flight at 5 s of a 13 km path."""
    sc = tmp_path / "sc.yaml"
    sc.write_text("mission: {depth: 50, speed: 0.5}\nduration: 5\n")
    res = runner.invoke(app, ["simulate", str(sc), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["completed"] is False and doc["path_finished"] is False
    assert doc["completed_reason"].startswith("the duration ends before the path")
    res = runner.invoke(app, ["simulate", str(sc)])
    assert res.exit_code == 0, res.output
    assert "completed_reason" in res.output and "the duration ends before the path" in _said(res)


@pytest.mark.slow
def test_a_controller_giving_nan_is_an_error_naming_it_and_the_time(tmp_path):
    """NaN from a user controller reached the allocator as no thrust: "max thrust 0 N", exit 0."""
    (tmp_path / "nanc.py").write_text(NAN_CONTROLLER)
    sc = tmp_path / "sc.yaml"
    sc.write_text("controller: {kind: python, file: nanc.py}\nduration: 3\n")
    res = runner.invoke(app, ["simulate", str(sc)])
    assert res.exit_code == 2
    assert "the controller (_f) gave a non-finite wrench from t = 1.01 s" in _said(res), res.output


def test_an_empty_scenario_file_is_refused_not_flown_as_the_defaults(tmp_path):
    sc = tmp_path / "e.yaml"
    sc.write_text("")
    res = runner.invoke(app, ["simulate", str(sc)])
    assert res.exit_code == 2 and "the file is empty; expected a mapping" in _said(res)


@pytest.mark.parametrize("sg, hint", [(1000.0, "a density in kg/m³"), (-1.0, ""), (0.0, "")])
def test_a_specific_gravity_no_water_has_is_refused(sg, hint):
    """BARO_SPEC_GRAV 1000 made depth 1000× too small, −1 flipped its sign, 0 was taken as 1."""
    from uuvid.io.ardusub.frames import check_spec_grav

    with pytest.raises(LogDataError, match=rf"log\.tlog: BARO_SPEC_GRAV = {sg:g} is no water's "
                                           rf"specific gravity.*{hint}"):
        check_spec_grav(sg, "log.tlog")
    assert check_spec_grav(1.025, "log.tlog") == 1.025


@pytest.mark.parametrize("command", ["envelope", "stability", "hold"])
def test_a_vehicle_without_thrusters_is_refused_saying_so(tmp_path, command):
    """"cannot reshape array of size 0 into shape (0)" for envelope, stability and hold."""
    import yaml

    from uuvid.vehicle.definition import preset_path

    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    raw["thrusters"] = []
    f = tmp_path / "none.yaml"
    f.write_text(yaml.safe_dump(raw, sort_keys=False))
    res = runner.invoke(app, ["vehicle", command, str(f)])
    assert res.exit_code == 2 and "has no thrusters" in _said(res), res.output


def test_a_figure_suffix_no_backend_writes_is_refused_before_the_table(tmp_path, shared_data):
    """``--plot p.xyz`` wrote the table and its sidecar, then failed in Matplotlib."""
    out = tmp_path / "t.csv"
    res = runner.invoke(app, ["log", "export", str(shared_data / "ardusub-bluerov2" / "small.BIN"),
                              "--out-file", str(out), "--plot", str(tmp_path / "p.xyz")])
    assert res.exit_code == 2 and "--plot" in _said(res) and "no figure format" in _said(res)
    assert not out.exists() and not list(tmp_path.glob("t.csv*"))


def test_a_monte_carlo_sigma_or_estimate_that_cannot_be_drawn_is_refused():
    from uuvid.uncertainty.montecarlo import ModelError, model_from_dict

    base = {"name": "m", "kind": "thruster_chain", "base": {"chain": "auv2-tunnel"}}
    with pytest.raises(ModelError, match=r"tunnel_length: sigma 1e\+300 is beyond"):
        model_from_dict({**base, "parameters": [{"name": "tunnel_length", "estimate": 0.27,
                                                 "sigma": 1e300}]}, "m.yaml")

    # an estimate outside its own bounds: refused when the model is read, before any draw (it
    # was drawn max_draws times a run, every draw rejected, and only the table said why)
    with pytest.raises(ModelError, match=r"m.yaml: parameters\[0\] \(tunnel_length\): estimate -5 "
                                         r"is outside its bounds \[0, inf\]"):
        model_from_dict({**base, "parameters": [{"name": "tunnel_length", "estimate": -5,
                                                 "sigma": 0.1, "lower": 0}]}, "m.yaml")


# ------------------------------------------------------------------ files that are no dive log
#: internal names a user should never read in an error about a file
INTERNAL = ("Traceback", "UnicodeDecodeError", "codec can't decode", "mmap", "NoneType",
            "AnyReaderError", "EmptyDataError", "senders (0/0)", "no such log file")


def _bad_file(tmp_path, name: str, what: str):
    import numpy as np

    p = tmp_path / name
    if what == "folder":
        p.mkdir()
    elif name == "ros2":  # a ROS 2 bag folder whose metadata.yaml is no bag description
        p.mkdir()
        (p / "metadata.yaml").write_bytes(np.random.default_rng(0).bytes(3000) if what == "random"
                                          else b"")
    else:
        p.write_bytes(np.random.default_rng(0).bytes(5000) if what == "random" else b"")
    return p


@pytest.mark.parametrize("name", ["dive.tlog", "dive.BIN", "dive.log"])
@pytest.mark.parametrize("what", ["random", "empty", "folder"])
def test_an_ardusub_log_that_is_none_is_a_clear_error_in_every_reader(tmp_path, name, what):
    """Random bytes, an empty file or a folder under a log's name gave "'utf-8' codec can't
    decode byte 0xfe" (a traceback in `identify dive`), "cannot mmap an empty file", "no
    autopilot HEARTBEAT ... senders (0/0)" or "no such log file" of a folder.  Each reader and
    command now names the file and what it expected."""
    from uuvid.io.ardusub import inspect_log, load_dive
    from uuvid.io.dive_channels import read_dive_channels
    from uuvid.io.logs import read_ardusub

    p = _bad_file(tmp_path, name, what)
    readers = [inspect_log, load_dive, read_ardusub, lambda q: read_dive_channels(q, "bluerov2")]
    for read in readers:
        with pytest.raises(LogDataError) as e:
            read(p)
        msg = str(e.value)
        assert name in msg and not any(s in msg for s in INTERNAL), msg
        if what != "random" or name != "dive.BIN":  # (a random .BIN: pymavlink's complaint)
            assert ".tlog" in msg and ".bin" in msg.lower(), msg
    for cmd in (["log", "inspect"], ["vehicle", "identify", "dive", "--vehicle", "bluerov2-heavy"]):
        res = runner.invoke(app, [*cmd, str(p)])
        out = _said(res)
        assert res.exit_code == 2 and name in out and not any(s in out for s in INTERNAL), out


@pytest.mark.parametrize("name", ["dive.csv", "dive.parquet", "dive.bag", "ros2"])
@pytest.mark.parametrize("what", ["random", "empty"])
def test_a_table_or_bag_that_is_none_is_a_clear_error(tmp_path, name, what):
    """A random or empty .bag said "cannot read the bag: UnicodeDecodeError" / "AnyReaderError",
    a ROS 2 folder with an empty metadata.yaml "'NoneType' object is not subscriptable", an empty
    CSV "EmptyDataError": each now says what the file is not and what was expected."""
    pytest.importorskip("rosbags")
    from uuvid.io.dive_channels import read_dive_channels

    p = _bad_file(tmp_path, name, what)
    with pytest.raises(LogDataError) as e:
        read_dive_channels(p, "bluerov2")
    msg = str(e.value)
    assert name in msg and "expected" in msg and not any(s in msg for s in INTERNAL), msg
    res = runner.invoke(app, ["vehicle", "identify", "dive", "--vehicle", "bluerov2-heavy", str(p)])
    out = _said(res)
    assert res.exit_code == 2 and name in out and not any(s in out for s in INTERNAL), out
    if name in ("dive.bag", "ros2"):
        from uuvid.io.logs import read_rosbag

        with pytest.raises(LogDataError, match="not a ROS|empty"):
            read_rosbag(p, {"depth": "/depth:data"})


def test_a_latin1_csv_names_the_true_byte_and_how_to_resave_it(tmp_path):
    """A CSV saved by Excel in Latin-1 (an 'é' after 2 MB): the error said "byte 0xe9 at position
    0 ... a binary file?" (the position within pandas' decode buffer).  It now names the byte
    and line in the file and says to re-save it as UTF-8."""
    from uuvid.io.dive_channels import DiveDataError, read_dive_channels

    head = ("t_s,depth_m,yaw_rad\n" + "".join(f"{i * 0.1:.1f},1.0,0.0\n" for i in range(150_000)))
    body = head.encode() + "1.0,1.0,0.0 # café\n".encode("latin-1")
    p = tmp_path / "excel.csv"
    p.write_bytes(body)
    with pytest.raises(DiveDataError) as e:
        read_dive_channels(p, "bluerov2")
    at = body.index(b"\xe9")
    msg = str(e.value)
    assert f"byte 0xe9 at byte {at:,} (line 150,002)" in msg and "re-save it as UTF-8" in msg, msg
    assert at > 2_000_000 and "binary file" not in msg
    from uuvid.io.dive_channels import _not_utf8  # a sequence cut by the end or by a 1 MiB read

    p.write_bytes(b"t_s\n" * 5 + b"x\xc3")
    assert "at byte 21 (line 6)" in _not_utf8(p)
    p.write_bytes(b"a" * ((1 << 20) - 1) + b"\xc3\x28")
    assert "byte 0xc3 at byte 1,048,575 (line 1)" in _not_utf8(p)
