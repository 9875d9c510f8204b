"""YAML 1.1 reads yes/no/on/off/true/false as booleans, and pydantic's lax mode took a boolean
where a number was expected as 1.0/0.0: ``speed: yes`` flew 1 m/s, ``mass: on`` a 1 kg vehicle,
and a sweep value ``true`` ran and was recorded as "True". A boolean where a number is expected
is an error naming the key and the value; real flags (a sweep axis's ``log``) still take one."""

import copy
import re

import pytest
import yaml

from uuvid.simulate.scenario import ScenarioError, scenario_from_dict
from uuvid.uncertainty.montecarlo import ModelError, model_from_dict
from uuvid.uncertainty.sweep import SweepError, sweep_from_dict
from uuvid.vehicle.definition import VehicleFileError, preset_path, vehicle_from_dict

WHY = r"`true` is a boolean \(YAML reads yes/no/on/off/true/false as booleans\), not a number"


def test_scenario_booleans_are_not_numbers():
    raw = yaml.safe_load("vehicle: bluerov2\nbattery_soc: yes\nduration: 5\n"
                         "mission: {kind: square, side: on, speed: yes}\ncurrent: [yes, 0, 0]\n")
    with pytest.raises(ScenarioError) as e:
        scenario_from_dict(raw, "s.yaml")
    msg = str(e.value)
    for key in ("battery_soc", "mission.side", "mission.speed"):
        assert re.search(f"s.yaml: {key}: {WHY}", msg), msg
    assert "current: item 0 (north, m/s): `true` is a boolean" in msg
    assert "tuple[" not in msg and "ConstantCurrentSpec" not in msg  # not every union member
    with pytest.raises(ScenarioError, match=r"substeps: `false` is a boolean"):
        scenario_from_dict({"substeps": False}, "s.yaml")
    # numbers, and numbers YAML 1.1 reads as text, still pass
    sc = scenario_from_dict({"mission": {"side": "1e1"}, "battery_soc": 1, "duration": 5})
    assert sc.mission.side == 10.0 and sc.battery_soc == 1.0


def _sweep(params: list) -> dict:
    return {"target": {"kind": "vehicle_mission", "scenario": {"vehicle": "bluerov2", "duration": 10}},
            "parameters": params}


def test_sweep_booleans_are_not_numbers():
    with pytest.raises(SweepError, match=r"b.yaml: parameters\[0\] \(added_mass_scale\): " + WHY):
        sweep_from_dict(_sweep([{"name": "added_mass_scale", "values": [True, 1.5]}]), "b.yaml")
    with pytest.raises(SweepError, match=r"parameters\[0\].include\[0\]: `true` is a boolean"):
        sweep_from_dict(_sweep([{"name": "mass", "values": [12.0], "include": [True]}]), "b.yaml")
    with pytest.raises(SweepError, match=r"runs\[0\]\.mass: `true` is a boolean"):
        sweep_from_dict({"target": _sweep([])["target"], "mode": "list", "runs": [{"mass": True}]},
                        "b.yaml")
    with pytest.raises(SweepError, match=r"target.vehicle_mission.scenario.duration: `true` is a boolean"):
        sweep_from_dict({**_sweep([{"name": "mass", "values": [12.0]}]),
                         "target": {"kind": "vehicle_mission", "scenario": {"duration": True}}})
    # a real flag still takes a boolean
    s = sweep_from_dict(_sweep([{"name": "mass", "start": 10, "stop": 20, "num": 3, "log": True}]))
    assert s.parameters[0].log is True


def test_vehicle_file_booleans_are_not_numbers():
    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    bad = copy.deepcopy(raw)
    bad["rigid_body"]["mass"] = True
    bad["thrusters"][0]["limits"] = [-1.0, True]
    with pytest.raises(VehicleFileError) as e:
        vehicle_from_dict(bad, "v.yaml", preset_path("bluerov2").parent)
    msg = str(e.value)
    assert re.search(f"v.yaml: rigid_body.mass: {WHY}", msg), msg
    assert "thrusters[0].limits[1]: `true` is a boolean" in msg, msg
    bad = copy.deepcopy(raw)
    bad["thrusters"][0]["installation"] = {"surge": [1.0, False]}  # said once, not per union member
    with pytest.raises(VehicleFileError) as e:
        vehicle_from_dict(bad, "v.yaml", preset_path("bluerov2").parent)
    assert str(e.value).endswith("v.yaml: thrusters[0].installation: surge: `false` is a boolean "
                                 "(YAML reads yes/no/on/off/true/false as booleans), not a number")


def test_montecarlo_model_booleans_are_not_numbers():
    doc = {"format": "uuvid-uncertain-model/1", "name": "x", "kind": "vehicle",
           "base": {"vehicle": "bluerov2"},
           "parameters": [{"name": "mass", "estimate": True, "sigma": 0.1}]}
    with pytest.raises(ModelError, match=r"m.yaml: parameters\[0\].estimate: `true` is a boolean"):
        model_from_dict(doc, "m.yaml")


def _wake_file(tmp_path):
    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    for t in raw["thrusters"]:
        t["wake"] = 0.6
    p = tmp_path / "wake.yaml"
    p.write_text(yaml.safe_dump(raw))
    return p


@pytest.mark.slow
def test_wake_warning_reaches_json_warnings(tmp_path):
    """The wake > 0.5 warning of a vehicle file went to stderr only: ``--json``'s ``warnings``
    said nothing (envelope, stability, simulate)."""
    import json

    from typer.testing import CliRunner

    from uuvid.cli.app import app

    run = CliRunner()
    p = _wake_file(tmp_path)
    for args in (["vehicle", "envelope", str(p), "--inflow", "four-quadrant", "--no-confirm"],
                 ["vehicle", "stability", str(p), "--inflow", "four-quadrant"]):
        r = run.invoke(app, [*args, "--json"])
        assert r.exit_code == 0, r.output
        ws = json.loads(r.stdout)["warnings"]
        assert any("wake 0.6 is above 0.5" in w for w in ws), (args, ws)
    sc = tmp_path / "s.yaml"
    sc.write_text(f"vehicle: {p.name}\ninflow: four-quadrant\nduration: 0.2\n")
    r = run.invoke(app, ["simulate", str(sc), "--json"])
    assert r.exit_code == 0, r.output
    assert any("wake 0.6 is above 0.5" in w for w in json.loads(r.stdout)["warnings"])


def test_duration_below_one_step_refused_and_a_non_multiple_said():
    """0.005 s at dt 0.01 flew one step (0.01 s) while 1e-300 s was refused: any duration below
    one step is refused when read; 0.015 s silently flew 0.02 s: it still flies whole steps, with
    a note saying the duration flown."""
    import warnings

    from uuvid.core.checks import InputWarning
    from uuvid.simulate.scenario import build, duration_note

    for d in (0.005, 1e-300, 0.0099):
        with pytest.raises(ScenarioError, match=rf"s.yaml: duration: {d:g} s is shorter than one "
                                                r"step \(dt = 0.01 s\)"):
            scenario_from_dict({"duration": d}, "s.yaml")
    assert scenario_from_dict({"duration": 0.01}).duration == 0.01  # one step is a flight
    assert scenario_from_dict({"duration": 0.03, "dt": 0.03}).duration == 0.03  # 0.03/0.03 = 1
    assert duration_note(0.3, 0.1, 3) is None  # 0.3 / 0.1 = 2.9999999999999996 is three steps
    with pytest.warns(InputWarning, match=r"duration = 0.015 s is not a whole number of steps "
                                          r"\(dt = 0.01 s\): the flight takes 2 steps and flies 0.02 s"):
        _, setup = build(scenario_from_dict({"duration": 0.015}), None, time_series=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        build(scenario_from_dict({"duration": 0.02}), None, time_series=False)


@pytest.mark.slow
def test_wake_warning_reaches_hold_json(tmp_path):
    import json

    from typer.testing import CliRunner

    from uuvid.cli.app import app

    r = CliRunner().invoke(app, ["vehicle", "hold", str(_wake_file(tmp_path)), "--inflow",
                                 "four-quadrant", "--json"])
    assert r.exit_code == 0, r.output
    assert any("wake 0.6 is above 0.5" in w for w in json.loads(r.stdout)["warnings"])


def test_simulate_json_lists_the_duration_flown_as_whole_steps(tmp_path):
    """``uuvid simulate SCENARIO --json`` said the duration-rounding note on stderr only: the
    document's ``warnings`` carried the vehicle file's warnings but not the scenario's notes."""
    import json

    from typer.testing import CliRunner

    from uuvid.cli.app import app

    sc = tmp_path / "s.yaml"
    sc.write_text("vehicle: bluerov2\nduration: 0.205\n")
    r = CliRunner().invoke(app, ["simulate", str(sc), "--json"])
    assert r.exit_code == 0, r.output
    ws = json.loads(r.stdout)["warnings"]
    assert sum("not a whole number of steps" in w and "flies 0.2 s" in w for w in ws) == 1, ws
