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


LATE_CONTROLLER = '''
import numpy as np

from uuvid.simulate.control.blocks import Controller


def make_controller(vehicle, context):
    g = context.gains
    params = np.array([*g.kp[:3], *g.kd[:3], g.kp[3], g.kd[3]], dtype=float)

    def late(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
        if t > 3.0:
            raise ValueError("fails at t>3")
        for j in range(6):
            tau_out[j] = 0.0
        for i in range(3):
            tau_out[i] = params[i] * (ref_pos[i] - eta[i]) - params[3 + i] * nu[i]

    return Controller(late, params, np.zeros(0))
'''

#: The line of LATE_CONTROLLER that raises.
LATE_LINE = LATE_CONTROLLER.splitlines().index('            raise ValueError("fails at t>3")') + 1

RAISED = ("make_controller(vehicle, context) returned the controller 'late', which raised ValueError "
          f"at t = 3.01 s of the flight: fails at t>3 (c_late.py line {LATE_LINE}, in late)")


@pytest.mark.slow
def test_a_controller_raising_mid_flight_names_its_file_function_error_and_time(tmp_path, monkeypatch):
    """A plain Python controller raising at t > 3 s ended `uuvid simulate` with "error: command
    line: fails at t>3": no file, no function, no exception type, no time.  Now as the factory
    raising is said: the file, the factory and the controller, the exception and the simulated
    time (and the line that raised); the library raises a ControllerRaised carrying them."""
    from uuvid.simulate.control.blocks import ControllerRaised
    from uuvid.simulate.vehicle_sim import fly_mission

    monkeypatch.chdir(tmp_path)
    (tmp_path / "c_late.py").write_text(LATE_CONTROLLER)
    r = CliRunner().invoke(app, ["simulate", "mission", "square", "--controller",
                                 "c_late.py:make_controller"])
    said = " ".join(r.output.split())
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert f"error: command line: controller file c_late.py: {RAISED}" in said, said
    (tmp_path / "late.yaml").write_text("controller: {kind: python, file: c_late.py}\nduration: 5\n")
    r = CliRunner().invoke(app, ["simulate", "late.yaml"])
    said = " ".join(r.output.split())
    assert r.exit_code == 2 and f"error: late.yaml: controller file c_late.py: {RAISED}" in said, said
    _, setup = build(_spec({"kind": "python", "file": "c_late.py"}, duration=5), base=tmp_path)
    with pytest.raises(ControllerRaised) as got:
        fly_mission(setup)
    assert got.value.t == pytest.approx(3.01) and isinstance(got.value.error, ValueError)
    assert got.value.__cause__ is got.value.error and isinstance(got.value, ValueError)


NAN_OUTPUT = '''
from uuvid.simulate.control.blocks import Controller


def _f(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    for j in range(tau_out.shape[0]):
        tau_out[j] = float("nan") if t > 1.0 else params[0]


def make_controller(vehicle, context):
    return Controller(_f, [0.0 if context.options["output"] == "thrust" else 1500.0], [],
                      output=context.options["output"])
'''


@pytest.mark.slow
@pytest.mark.parametrize("output", ["thrust", "command"])
def test_nan_from_a_thrust_or_command_controller_is_said_as_such(tmp_path, output):
    """NaN thrusts or commands were reported as "a non-finite wrench" (the wrench the loop
    derives from them): the author looked for a wrench their controller never writes."""
    from uuvid.simulate.vehicle_sim import fly_mission

    (tmp_path / "nanc.py").write_text(NAN_OUTPUT)
    _, setup = build(_spec({"kind": "python", "file": "nanc.py", "options": {"output": output}},
                           duration=3), base=tmp_path)
    with pytest.raises(ValueError, match=rf"the controller \(_f\) gave a non-finite {output} "
                                         rf"\(output='{output}', one per thruster\) from t = 1.01 s"):
        fly_mission(setup)


@pytest.mark.slow
def test_a_compiled_controller_raising_mid_flight_is_said_with_its_time(tmp_path):
    """The same for a numba controller (its exception came out bare, "fails at t>3"): the loop
    writes each step's state once its control is computed, so the step that raised is known."""
    from uuvid.simulate.control.blocks import ControllerRaised
    from uuvid.simulate.vehicle_sim import fly_mission

    (tmp_path / "c_jit.py").write_text(LATE_CONTROLLER.replace(
        "    def late(", "    @njit\n    def late(").replace(
        "import numpy as np\n", "import numpy as np\nfrom numba import njit\n"))
    _, setup = build(_spec({"kind": "python", "file": "c_jit.py"}, duration=5), base=tmp_path)
    assert setup.controller.compiled
    with pytest.raises(ControllerRaised, match=r"^controller file .*c_jit\.py: make_controller\("
                                               r"vehicle, context\) returned the controller 'late', "
                                               r"which raised ValueError at t = 3\.01 s of the "
                                               r"flight: fails at t>3"):
        fly_mission(setup)
