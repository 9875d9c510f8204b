"""Scenario files and `uuvid simulate` as a new user writes them: what was silently ignored or
answered with pydantic's union noise now ends in an error naming the key and what is expected."""

import re

import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()


def clean_error(res, *needles):
    assert res.exit_code in (1, 2), (res.exit_code, res.output, res.exception)
    assert isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output
    for n in needles:
        assert n in res.output, (n, res.output)


@pytest.mark.parametrize("args, said", [
    (["--current", "0.3,0,0"], "--current: only for `uuvid simulate mission`"),
    (["--speed", "0.2", "--vehicle", "romeo"], "--vehicle, --speed: only for"),
    (["--dt", "0.05", "--thruster-model", "t200"], "sets thruster_model, dt itself"),
    (["--depth", "5", "--side", "20"], "sets mission.depth, mission.side itself"),
])
def test_mission_options_beside_a_scenario_file_are_refused_not_ignored(tmp_path, args, said):
    """`uuvid simulate s.yaml --current 0.3,0,0` flew in still water and printed "completed":
    the mission options were dropped without a word when a scenario file was given."""
    p = tmp_path / "s.yaml"
    p.write_text("duration: 0.05\ndt: 0.01\n")
    clean_error(runner.invoke(app, ["simulate", str(p), *args]), said, "s.yaml")


def test_waypoints_under_the_default_square_are_refused():
    """`mission: {waypoints: [...]}` without `kind: waypoints` flew Laidani's square (kind's
    default) and said "completed"; a square's depth/side/yaw beside waypoints did nothing."""
    from uuvid.simulate.scenario import ScenarioError, scenario_from_dict

    wps = [[0, 0, 0, 0], [0, 0, 3, 0], [8, 0, 3, 0]]
    with pytest.raises(ScenarioError, match=r"s.yaml: mission: waypoints: given, but kind is "
                                            r"'square' \(the default\).*add kind: waypoints"):
        scenario_from_dict({"mission": {"waypoints": wps}}, where="s.yaml")
    with pytest.raises(ScenarioError, match=r"kind is 'square', which flies"):
        scenario_from_dict({"mission": {"kind": "square", "waypoints": wps}}, where="s.yaml")
    with pytest.raises(ScenarioError, match=r"mission: depth, side: only for kind square"):
        scenario_from_dict({"mission": {"kind": "waypoints", "depth": 5, "side": 20,
                                        "waypoints": wps}}, where="s.yaml")
    ok = scenario_from_dict({"mission": {"kind": "waypoints", "waypoints": wps, "speed": 0.3}})
    assert ok.mission.build().waypoints[-1] == (8.0, 0.0, 3.0, 0.0)
    assert scenario_from_dict({"mission": {"depth": 5}}).mission.build().name == "square 10 m at 5 m"


@pytest.mark.parametrize("current, said", [
    ("0.3,0,0", "current: expected N,E,D (m/s): a list of three numbers"),
    (0.3, "or a mapping such as {kind: constant"),
    ({"speed": 0.3}, "current: kind: missing; expected one of constant, timeseries, gauss_markov"),
    ({"kind": "steady", "speed": 0.3}, "current: kind: 'steady'; expected one of constant"),
    ({"kind": "constant", "speed": 0.3, "direction": 90},
     "current: direction: unknown key (a constant current's keys: kind, speed, direction_deg"),
])
def test_a_current_of_the_wrong_form_says_what_is_expected(current, said):
    """A string, a number or a mapping with a typo'd key was answered with one line per member of
    the union (`current.tuple[float, float, float]: Input should be a valid tuple`,
    `current.TimeSeriesCurrentSpec.file: missing` for a constant current)."""
    from uuvid.simulate.scenario import ScenarioError, scenario_from_dict

    with pytest.raises(ScenarioError) as e:
        scenario_from_dict({"current": current}, where="s.yaml")
    m = str(e.value)
    assert said in m and m.startswith("s.yaml: current: ") and "\n" not in m, m
    assert "Spec" not in m and "tuple[" not in m, m
    spec = scenario_from_dict({"current": {"kind": "constant", "speed": 0.3, "direction_deg": 90}})
    assert spec.current.speed == 0.3 and spec.current.direction_deg == 90


@pytest.mark.parametrize("waypoints, said", [
    ([0, 0, 2, 0, 5, 0, 2, 0], "waypoint 0: expected 4 numbers [north, east, down, yaw]"),
    ([[0, 0, 2], [5, 0, 2]], "got [0, 0, 2]; 1 more rows like it"),
    (3, "expected a list of waypoints [[north, east, down, yaw], ...]"),
])
def test_waypoints_of_the_wrong_shape_are_one_clear_line(waypoints, said):
    """A flat list gave eight lines of `mission.waypoints[k]: Input should be a valid tuple`."""
    from uuvid.simulate.scenario import ScenarioError, scenario_from_dict

    with pytest.raises(ScenarioError) as e:
        scenario_from_dict({"mission": {"kind": "waypoints", "waypoints": waypoints}},
                           where="s.yaml")
    m = str(e.value)
    assert said in m and "\n" not in m and "valid tuple" not in m, m


@pytest.mark.parametrize("value, warned", [(1.57, "π/2"), (-3.14, "−π"), (0.785, "π/4"),
                                           (90.0, None), (1.0, None), (0.5, None), (359.5, None)])
def test_a_direction_in_radians_is_warned_of(value, warned):
    """`vehicle hold --current 0.3,1.57` (π/2 meant) held a current from 2° off the bow without a
    word, as did a scenario's `direction_deg: 1.5708`."""
    import warnings

    from uuvid.core.checks import InputWarning, direction_deg
    from uuvid.simulate.scenario import scenario_from_dict

    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        assert direction_deg("x", value) == value % 360  # -3.14 is also outside [0, 360)
        scenario_from_dict({"current": {"kind": "constant", "speed": 0.1, "direction_deg": value}})
    said = [str(w.message) for w in got if issubclass(w.category, InputWarning)]
    if warned is None:
        assert not said, said
    else:
        assert len(said) == 2 and warned in said[0] and "is it in radians?" in said[0], said
        assert said[1].startswith(f"current.direction_deg = {value:g}°"), said


def test_hold_warns_of_a_current_direction_in_radians(monkeypatch):
    from uuvid.cli import hold_cmd

    with pytest.warns(UserWarning, match=r"--current direction = 1.57°: that is π/2 in radians"):
        assert hold_cmd._parse_current("0.3,1.57") == (0.3, 1.57)


@pytest.mark.parametrize("value, used", [(400.0, 40.0), (-90.0, 270.0), (360.0, 0.0),
                                         (720.5, 0.5)])
def test_a_direction_outside_one_turn_is_said_and_taken_within_it(value, used):
    """`vehicle hold --current 0.3,400` printed "from 400°" for a current flown from 40°, without
    a word; a scenario's direction_deg and GaussMarkovCurrent kept 400 too.  Each says the value
    given and the one used, and uses it."""
    import warnings

    from uuvid.core.checks import InputWarning, direction_deg
    from uuvid.simulate.currents import GaussMarkovCurrent
    from uuvid.simulate.scenario import scenario_from_dict

    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        assert direction_deg("x", value) == pytest.approx(used)
        spec = scenario_from_dict({"current": {"kind": "constant", "speed": 0.1,
                                               "direction_deg": value}})
        gm = GaussMarkovCurrent(direction_deg=value)
    assert spec.current.direction_deg == pytest.approx(used)
    assert gm.direction_deg == pytest.approx(used)
    said = [str(w.message) for w in got if issubclass(w.category, InputWarning)]
    assert said == [f"{n} = {value:g}°: outside [0, 360°), the same direction modulo 360°; taken "
                    f"as {used:g}°" for n in ("x", "current.direction_deg", "direction_deg")], said


def test_hold_takes_a_current_direction_past_a_turn_within_it():
    """`uuvid vehicle hold --current 0.3,400` printed "from 400°"; its --simulate angles and the
    library's max_current the same."""
    import json
    import warnings

    from uuvid.analysis import hold
    from uuvid.cli import hold_cmd
    from uuvid.core.checks import InputWarning
    from uuvid.vehicle.definition import load_vehicle

    with pytest.warns(InputWarning, match=r"^--current direction = 400°: outside \[0, 360°\), the "
                      r"same direction modulo 360°; taken as 40°$"):
        assert hold_cmd._parse_current("0.3,400") == (0.3, 40.0)
    with pytest.warns(InputWarning, match=r"^--current direction = 400°: .*taken as 40°$"):
        res = runner.invoke(app, ["vehicle", "hold", "bluerov2", "--current", "0.3,400", "--step",
                                  "90", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["at_current"]["from_deg"] == 40.0
    with pytest.warns(InputWarning, match=r"^--simulate = 400°: .*taken as 40°$"):
        res = runner.invoke(app, ["vehicle", "hold", "bluerov2", "--simulate", "0,400",
                                  "--battery", "0.5"])  # refused after the angles are read
    assert res.exit_code == 2, res.output
    v = load_vehicle("bluerov2")
    with pytest.warns(InputWarning, match=r"relative_deg = 400°: .*taken as 40°"):
        far = hold.max_current(v, 400.0, stability=False)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        assert far == hold.max_current(v, 40.0, stability=False)[0]


def _radians_said(record):
    """The InputWarnings of a π/2-in-radians slip among the recorded warnings."""
    from uuvid.core.checks import InputWarning

    return [str(w.message) for w in record
            if issubclass(w.category, InputWarning) and "π/2 in radians" in str(w.message)]


def _fly_held(monkeypatch):
    """holds_in_simulation's flight replaced by one held still and level (no 150 s simulation)."""
    import types

    import numpy as np

    from uuvid.simulate import vehicle_sim

    def fly(setup):
        t = np.arange(0.0, 151.0, 1.0)
        state = np.zeros((t.size, 13))
        state[:, 3] = 1.0
        return types.SimpleNamespace(t=t, state=state, tracking_error=np.zeros(t.size))

    monkeypatch.setattr(vehicle_sim, "setup_mission", lambda *a, **k: None)
    monkeypatch.setattr(vehicle_sim, "fly_mission", fly)


@pytest.mark.slow
def test_hold_says_a_direction_in_radians_once_where_it_is_given(monkeypatch):
    """`vehicle hold bluerov2 --current 0.3,1.57` printed the π/2 warning twice (`--current
    direction`, then `relative_deg` from max_current), three times with --battery (endurance);
    `--simulate 1.57` once per check: the option, capability(simulate_deg=) and each simulation
    of the bisection.  The option is the value given: said there, once."""
    import warnings

    _fly_held(monkeypatch)
    for args in (["--current", "0.3,1.57"], ["--current", "0.3,1.57", "--battery", "0.9"],
                 ["--simulate", "1.57", "--voltage", "16", "--inflow", "none"]):
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            res = runner.invoke(app, ["vehicle", "hold", "bluerov2", "--step", "180", "--json",
                                      *args])
        assert res.exit_code == 0, (args, res.output)
        said = _radians_said(got)
        flag = args[0] + (" direction" if args[0] == "--current" else "")
        assert len(said) == 1 and said[0].startswith(f"{flag} = 1.57°: that is π/2"), (args, said)


def test_the_library_says_a_direction_in_radians_once(monkeypatch):
    """Called directly, max_current(relative_deg=1.57) says it once; simulate_boundary and
    capability(simulate_deg=) said it again at each simulation of their bisection."""
    import warnings

    from uuvid.analysis import hold
    from uuvid.vehicle.definition import load_vehicle

    _fly_held(monkeypatch)
    v = load_vehicle("bluerov2")
    calls = {"max_current": lambda: hold.max_current(v, 1.57, stability=False),
             "simulate_boundary": lambda: hold.simulate_boundary(v, 1.57, 0.5, iterations=2),
             "capability": lambda: hold.capability(v, step_deg=180, simulate_deg=(1.57,),
                                                   supply_voltage=16, inflow="none",
                                                   progress=False, iterations=2)}
    for name, call in calls.items():
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            call()
        said = _radians_said(got)
        assert len(said) == 1, (name, said)


def test_a_gauss_markov_current_says_a_direction_in_radians_once():
    """A scenario's `current: {kind: gauss_markov, direction_deg: 1.57}` was warned of by the
    scenario's check and again by GaussMarkovCurrent; built directly it says it once."""
    import warnings

    from uuvid.simulate.currents import GaussMarkovCurrent
    from uuvid.simulate.scenario import build, scenario_from_dict

    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        spec = scenario_from_dict({"duration": 1.0, "dt": 0.05,
                                   "current": {"kind": "gauss_markov", "direction_deg": 1.57,
                                               "mu": 0.1, "seed": 3}})
        build(spec)
        cur = spec.current.build(None)  # (its one warning said above, by scenario_from_dict)
    assert isinstance(cur, GaussMarkovCurrent) and cur.direction_deg == 1.57
    assert (cur.mu, cur.seed) == (0.1, 3)
    said = _radians_said(got)
    assert len(said) == 1 and said[0].startswith("current.direction_deg = 1.57°"), said
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        assert GaussMarkovCurrent(direction_deg=1.57).direction_deg == 1.57
    said = _radians_said(got)
    assert len(said) == 1 and said[0].startswith("direction_deg = 1.57°"), said
    with pytest.raises(ValueError, match="need mu > 0"):  # the other parameters still checked
        GaussMarkovCurrent._checked(direction_deg=1.57, mu=-1.0)


@pytest.mark.slow
def test_a_scenario_flown_with_another_controller_says_its_direction_once(tmp_path):
    """`uuvid simulate scen.yaml --controller lqr` checked the scenario again to swap its
    controller: a radians-looking direction was said twice."""
    import warnings

    p = tmp_path / "scen.yaml"
    p.write_text("vehicle: bluerov2\nduration: 1.0\ncurrent: {kind: gauss_markov, direction_deg: 1.57, "
                 "mu: 0.1, seed: 3}\n")
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        r = runner.invoke(app, ["simulate", str(p), "--controller", "lqr", "--json"])
    assert r.exit_code == 0, r.output
    said = _radians_said(got) + [ln for ln in r.output.splitlines() if "in radians" in ln]
    assert len(said) == 1 and "current.direction_deg = 1.57°" in said[0], said


def test_a_direction_a_hair_below_zero_is_taken_as_zero_not_a_full_turn():
    """`direction_deg('x', -1e-9)` said "taken as 360°" (359.999999999 printed with :g) and
    returned it: a hair below 0 is 0."""
    import warnings

    from uuvid.core.checks import InputWarning, direction_deg

    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        assert direction_deg("x", -1e-9) == 0.0
        assert direction_deg("x", -1e-4) == pytest.approx(359.9999)
    said = [str(w.message) for w in got if issubclass(w.category, InputWarning)]
    assert said[0].endswith("taken as 0°") and said[1].endswith("taken as 359.9999°"), said


@pytest.mark.parametrize("kw, said", [
    ({"depth": -2}, "depth = -2 m: expected >= 0"),
    ({"waypoints": ((0, 0, 0, 0), (5, 0, -5, 0))}, "waypoint 1 is at down = -5 m, 5 m above the surface"),
    ({"waypoints": ((0, 0, 2, 0), (5, 0, 2, 90))}, "waypoint 1 has yaw 90: beyond ±2π rad"),
])
def test_a_library_mission_above_the_water_or_in_degrees_is_refused(kw, said):
    """The scenario file refused these, the library did not: square_mission(depth=-2) flew 2 m
    above the water and reported "completed" with no warning."""
    from uuvid.simulate.reference import WaypointMission, square_mission

    with pytest.raises(ValueError, match=said):
        WaypointMission(**kw) if "waypoints" in kw else square_mission(**kw)
    assert square_mission(depth=0.0).duration > 0
    assert WaypointMission(((0, 0, -0.5, 0), (5, 0, 2, -6.28))).duration > 0
    assert WaypointMission(((0, 0, 1, 0), (5, 0, 2, 6.2832))).duration > 0  # 2π to four decimals


def test_a_vehicle_file_given_as_the_scenario_says_it_is_not_one(tmp_path):
    """`uuvid simulate my-rov.yaml` listed 'rigid_body: unknown key', … for every key of the
    vehicle file; the scenario names a vehicle file with `vehicle:`."""
    from uuvid.vehicle.definition import preset_path

    p = tmp_path / "my-rov.yaml"
    p.write_text(preset_path("bluerov2").read_text())
    res = runner.invoke(app, ["simulate", str(p)])
    clean_error(res, "not a scenario file: it looks like a vehicle file (it has rigid_body, "
                     "hydrodynamics, thrusters); a scenario file has name, vehicle, mission")
    assert "unknown key" not in res.output


@pytest.mark.parametrize("field, value, said", [
    ("hold", float("nan"), "hold = nan: expected a finite number >= 0 (s)"),
    ("hold", -1.0, "hold = -1: expected a finite number >= 0 (s)"),
    ("ramp_time", float("inf"), "ramp_time = inf: expected a finite number >= 0 (s)"),
    ("speed", float("inf"), "speed = inf: expected a finite number > 0 (m/s)"),
    ("speed", float("nan"), "speed = nan: expected a finite number > 0 (m/s)"),
    ("vertical_speed", 0.0, "vertical_speed = 0: expected a finite number > 0 (m/s)"),
    ("yaw_rate", float("nan"), "yaw_rate = nan: expected a finite number > 0 (rad/s)"),
])
def test_a_waypoint_mission_refuses_a_non_finite_or_negative_number(field, value, said):
    """``WaypointMission(hold=nan)`` was built (duration NaN) and failed later in setup_mission as
    "the mission's duration = nan s"; ``speed=inf`` flew legs of zero length.  Each field is
    checked where it is given, naming it and its value."""
    from uuvid.simulate.reference import WaypointMission

    with pytest.raises(ValueError, match=re.escape(said)):
        WaypointMission(((0, 0, 1, 0), (5, 0, 1, 0)), **{field: value})
    assert WaypointMission(((0, 0, 1, 0), (5, 0, 1, 0)), hold=0.0, ramp_time=0.0).duration > 0


SPEED_MODEL = """name: four-quadrant
input: speed
blocks:
- type: quadratic
  k_pos: 0.00037
  k_neg: 0.00029
  torque_pos: 0.0
  torque_neg: 0.0
"""


def test_a_thruster_model_driven_by_propeller_speed_names_the_scenario_key_and_file(tmp_path):
    """`thruster_model: ../q_base.yaml` (a fit against propeller speed) was refused as "bluerov2:
    thrusters[0] (T1_front_right): model '--thruster-model' takes the propeller speed …
    (vehicle file)": neither the key nor the file, and the vehicle file blamed.  Now the
    scenario file, its thruster_model key and the model file; on the command line
    --thruster-model."""
    (tmp_path / "q_base.yaml").write_text(SPEED_MODEL)
    (tmp_path / "sub").mkdir()
    sc = tmp_path / "sub" / "s.yaml"
    sc.write_text("vehicle: bluerov2\nthruster_model: ../q_base.yaml\nduration: 1\n")
    res = runner.invoke(app, ["simulate", str(sc)])
    said = " ".join(res.output.split())
    clean_error(res)
    model = (tmp_path / "q_base.yaml").resolve()
    assert f"s.yaml: thruster_model: '../q_base.yaml' (model file {model}) takes the propeller " \
           "speed (rad/s) as its input, not a command" in said, said
    assert "vehicle file)" not in said.split("propeller: in the vehicle file")[0]
    assert "'--thruster-model'" not in said and "T1_front_right" not in said
    res = runner.invoke(app, ["simulate", "mission", "square", "--thruster-model",
                              str(tmp_path / "q_base.yaml")])
    said = " ".join(res.output.split())
    clean_error(res)
    assert f"error: --thruster-model '{tmp_path / 'q_base.yaml'}' (model file {model}) takes the " \
           "propeller speed" in said, said


def test_a_thruster_chain_driven_by_propeller_speed_is_named_as_the_callers():
    """The library's own message named '--thruster-model' and the vehicle file for a chain the
    caller passed."""
    import yaml

    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import setup_mission
    from uuvid.thruster.modelfile import chain_from_dict
    from uuvid.vehicle.definition import load_vehicle

    chain = chain_from_dict(yaml.safe_load(SPEED_MODEL))
    with pytest.raises(ValueError, match=r"^thruster_chain \(four-quadrant\) takes the propeller "
                                         r"speed") as got:
        setup_mission(load_vehicle("bluerov2"), square_mission(), thruster_chain=chain, t_end=1.0)
    assert "--thruster-model" not in str(got.value) and "vehicle file" not in str(got.value)


@pytest.mark.parametrize("text, said", [
    ("- vehicle: bluerov2\n", "got a list (1 item) — drop the leading '- '"),
    ("bluerov2\n", "got the text 'bluerov2'"),
    ("3\n", "got the number 3"),
    ("true\n", "got true (a yes/no value)"),
    ("- 1\n- 2\n", "got a list (2 items)"),
])
def test_a_scenario_file_that_is_no_mapping_says_so(tmp_path, text, said):
    """A top-level list gave "s9.yaml: : Input should be a valid dictionary or instance of
    ScenarioSpec": an empty key path and a class name."""
    p = tmp_path / "s9.yaml"
    p.write_text(text)
    res = runner.invoke(app, ["simulate", str(p)])
    clean_error(res, f"s9.yaml: a scenario file is a mapping of keys (vehicle:, mission:, "
                     f"duration:, …), {said}")
    assert "ScenarioSpec" not in res.output and ": :" not in res.output


@pytest.mark.parametrize("text, said", [
    ("mission: square\n", "mission: expected a mapping of keys (kind:, depth:, side:, speed: …), "
                          "got the text 'square'; for that mission, write mission: {kind: square}"),
    ("controller: 3\n", "controller: expected a mapping of keys (kind:, bandwidth:, kp:, ki: …), "
                        "got the number 3"),
    ("controller: {kind: lqr, weights: 5}\n", "controller.weights: expected a mapping of keys "
                                              "(position:, yaw:, tilt:, speed: …)"),
])
def test_a_section_given_as_a_word_says_what_it_takes(tmp_path, text, said):
    """`mission: square` gave "mission: Input should be a valid dictionary or instance of
    MissionSpec" (a class name the file never shows)."""
    from uuvid.simulate.scenario import ScenarioError, load_scenario

    p = tmp_path / "s.yaml"
    p.write_text(text)
    with pytest.raises(ScenarioError) as got:
        load_scenario(p)
    assert said in str(got.value) and "Spec" not in str(got.value), str(got.value)
