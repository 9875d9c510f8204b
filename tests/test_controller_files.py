"""Controllers from scenario files and the command line: pid, lqr, or the user's FILE.py:FACTORY."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.simulate.control.blocks import Controller
from uuvid.simulate.control.files import (
    ControllerFileError,
    parse_controller_arg,
    write_example,
)
from uuvid.simulate.scenario import ScenarioError, build, scenario_from_dict

NOT_A_CONTROLLER = '''
def make_controller(vehicle, context):
    return "pid"


def helper():
    pass
'''


def _spec(controller: dict, **kw):
    return scenario_from_dict({"vehicle": "bluerov2", "controller": controller, **kw})


def test_parse_controller_arg():
    assert parse_controller_arg("pid") == {"kind": "pid"}
    assert parse_controller_arg("lqr") == {"kind": "lqr"}
    assert parse_controller_arg("dir/my_ctrl.py:build") == {
        "kind": "python", "file": "dir/my_ctrl.py", "factory": "build"}
    assert parse_controller_arg("my_ctrl.py")["factory"] == "make_controller"
    with pytest.raises(ControllerFileError, match="pid, lqr or FILE.py:FACTORY"):
        parse_controller_arg("sliding-mode")


@pytest.mark.slow
def test_scenario_controller_kinds(tmp_path):
    """pid flies the built-in loop (no Controller block), lqr the hover LQI (per-thruster
    thrust), python the factory's Controller; the file is found relative to the scenario."""
    _, s = build(_spec({"kind": "pid"}))
    assert s.controller is None
    _, s = build(_spec({"kind": "lqr", "weights": {"position": 0.2}}))
    assert s.controller.output == "thrust" and s.controller.name.startswith("LQI")
    _, s2 = build(_spec({"kind": "lqr"}))
    assert not np.array_equal(s.controller.params, s2.controller.params)  # the weight was used
    write_example(tmp_path / "ctrl" / "my_pd.py")
    _, s = build(_spec({"kind": "python", "file": "ctrl/my_pd.py", "options": {"kp_scale": 2.0}}),
                 base=tmp_path)
    assert isinstance(s.controller, Controller) and s.controller.compiled
    assert s.controller.name == "body-frame PD (example)"
    assert s.controller.params[0] == pytest.approx(2 * s.gains.kp[0])  # options reached it


def test_scenario_controller_errors(tmp_path):
    """Missing file, missing factory, a factory not returning a Controller, keys of another
    kind: each named."""
    with pytest.raises(ScenarioError, match="controller.*needs its file"):
        _spec({"kind": "python"})
    with pytest.raises(ScenarioError, match="weights: only for kind lqr"):
        _spec({"kind": "pid", "weights": {"position": 0.1}})
    with pytest.raises(ScenarioError, match=r"controller file .*nosuch\.py: no such file"):
        build(_spec({"kind": "python", "file": "nosuch.py"}), base=tmp_path)
    (tmp_path / "bad.py").write_text(NOT_A_CONTROLLER)
    with pytest.raises(ScenarioError, match=r"no function 'build_it' \(functions defined there: "
                                            r"helper, make_controller\)"):
        build(_spec({"kind": "python", "file": "bad.py", "factory": "build_it"}), base=tmp_path)
    with pytest.raises(ScenarioError, match=r"make_controller\(vehicle, context\) returned str, "
                                            "not a uuvid.simulate.control.blocks.Controller"):
        build(_spec({"kind": "python", "file": "bad.py"}), base=tmp_path)
    (tmp_path / "broken.py").write_text("import nosuchmodule_xyz\n")
    with pytest.raises(ScenarioError, match="importing it failed: ModuleNotFoundError"):
        build(_spec({"kind": "python", "file": "broken.py"}), base=tmp_path)


def test_cli_controller_errors(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(app, ["simulate", "mission", "square", "--controller", "nosuch.py:f"])
    assert r.exit_code == 2 and "nosuch.py: no such file" in r.output
    r = CliRunner().invoke(app, ["simulate", "mission", "square", "--controller", "mpc"])
    assert r.exit_code == 2 and "expected pid, lqr or FILE.py:FACTORY" in r.output


@pytest.mark.slow
@pytest.mark.parametrize("which", ["lqr", "file"])
def test_cli_flies_the_chosen_controller(tmp_path, monkeypatch, which):
    """`uuvid simulate mission square --controller ...` flies it and says so (summary, report)."""
    monkeypatch.chdir(tmp_path)
    arg = "lqr"
    if which == "file":
        write_example(tmp_path / "my_pd.py")
        arg = "my_pd.py:make_controller"
    r = CliRunner().invoke(app, ["simulate", "mission", "square", "--controller", arg, "--json",
                                 "--out", str(tmp_path / "out")])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout[r.stdout.index("{"):])
    want = "LQI (hover design)" if which == "lqr" else "body-frame PD (example)"
    assert doc["controller"] == want
    assert doc["controller_output"] == ("thrust" if which == "lqr" else "wrench")
    assert doc["completed"]
    assert want in (tmp_path / "out" / "index.html").read_text(encoding="utf-8")


@pytest.mark.slow
def test_demo_flies_the_example_file_on_the_pid_blocks_loop(tmp_path):
    """The demo's controller section writes the example controller file and flies it under the
    PID block's disturbance: the same compiled loop (one per configuration, the controller a
    function pointer), not one compiled around the file's controller."""
    from uuvid.core.html import Report
    from uuvid.demo import _blocks_section
    from uuvid.simulate.disturbances import sinusoidal
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.scenario import build, scenario_from_dict
    from uuvid.simulate.vehicle_sim import mission_runner, setup_mission
    from uuvid.vehicle.definition import load_vehicle

    rows = _blocks_section(tmp_path, Report("demo"), quick=False)["rows"]
    assert (tmp_path / "my_controller.py").is_file()
    own = [r for r in rows if "my_controller.py" in r["controller"]]
    assert len(own) == 1 and own[0]["max_tracking_error_m"] < 1.0
    v = load_vehicle("bluerov2")
    wave = sinusoidal(amplitude=(10.0, 0, 8.0, 0, 0, 0), period=5.0)
    _, s = build(scenario_from_dict({"vehicle": "bluerov2", "controller": {
        "kind": "python", "file": str(tmp_path / "my_controller.py"), "factory": "make_controller"}}))
    mine = mission_runner(setup_mission(v, square_mission(), controller=s.controller,
                                        disturbance=wave))[0].loop
    pid_block = mission_runner(setup_mission(v, square_mission(), disturbance=wave))[0].loop
    assert mine.dispatcher is pid_block.dispatcher and mine.ctrl_fn is not pid_block.ctrl_fn
