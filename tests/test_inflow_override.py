"""The inflow switch as a user meets it: ``--inflow`` (and a scenario's ``inflow:``) over the
vehicle file's key, what a run says was in force, and the messages of the inflow keys."""

import json
import warnings

import pytest
import yaml
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.vehicle import VehicleFileError, VehicleFileWarning, load_vehicle
from uuvid.vehicle.definition import preset_path


def _raw(**top):
    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    raw.update(top)
    return raw


def _write(path, raw):
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


@pytest.fixture
def no_map_vehicle(tmp_path):
    """``inflow: four-quadrant`` on thrusters whose model file (the voltage-aware T200 fit, as
    ``uuvid thruster fit --model physical`` writes it) holds no propeller map."""
    from uuvid.thruster.modelfile import save_chain
    from uuvid.thruster.physical import physical_model

    save_chain(physical_model().to_chain(16.0), tmp_path / "t200phys.yaml")
    raw = _raw(inflow="four-quadrant")
    for t in raw["thrusters"]:
        t["model"] = "t200phys.yaml"
    return _write(tmp_path / "v.yaml", raw)


def _run(*args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return CliRunner().invoke(app, [str(a) for a in args])


def _json(res):
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout[res.stdout.index("{"):])


# ------------------------------------------------------------------ 1: --inflow none overrides
@pytest.mark.slow
def test_inflow_none_flies_a_file_whose_models_hold_no_propeller_map(no_map_vehicle):
    v = no_map_vehicle
    for args in (["vehicle", "envelope", v, "--no-confirm", "--json"],
                 ["vehicle", "stability", v, "--json"],
                 ["vehicle", "hold", v, "--step", "90", "--json"],
                 ["simulate", "mission", "square", "--vehicle", v, "--side", "1", "--json"]):
        doc = _json(_run(*args, "--inflow", "none"))
        assert doc.get("inflow", doc.get("capability", {}).get("inflow")) == "none", args
    assert load_vehicle(v, inflow="none").inflow == "none"


def test_without_the_option_the_missing_map_is_an_error_naming_key_and_option(no_map_vehicle):
    res = _run("vehicle", "envelope", no_map_vehicle, "--no-confirm")
    assert res.exit_code == 2
    text = " ".join(res.output.split())
    assert "holds none" in text and "set inflow: none in the vehicle file" in text
    assert "--inflow none" in text and "(presets:" not in text
    load_vehicle(no_map_vehicle, inflow="none")  # an override's load is not the file's (cache)
    with pytest.raises(VehicleFileError, match="--inflow none"):
        load_vehicle(no_map_vehicle)


def test_inflow_four_quadrant_over_a_file_without_it_says_to_leave_the_option_out(no_map_vehicle):
    raw = yaml.safe_load(no_map_vehicle.read_text())
    raw["inflow"] = "none"
    path = _write(no_map_vehicle.parent / "off.yaml", raw)
    with pytest.raises(VehicleFileError, match=r"inflow four-quadrant was asked for on this run "
                                               r"\(--inflow four-quadrant.*inflow: none: leave it out"):
        load_vehicle(path, inflow="four-quadrant")


# ------------------------------------------------------------------ 2: a run says which inflow
@pytest.mark.slow
def test_simulate_says_the_inflow_in_force_and_where_it_came_from(tmp_path):
    path = _write(tmp_path / "v4q.yaml", _raw(inflow="four-quadrant"))
    base = ["simulate", "mission", "square", "--vehicle", path, "--side", "1", "--json"]
    on, off = _json(_run(*base)), _json(_run(*base, "--inflow", "none"))
    assert (on["inflow"], on["inflow_source"]) == ("four-quadrant", "vehicle file")
    assert (off["inflow"], off["inflow_source"]) == ("none", "option")
    assert on["rms_tracking_error_m"] != off["rms_tracking_error_m"]
    res = _run(*base[:-1], "--out", tmp_path / "rep")
    assert res.exit_code == 0, res.output
    assert "inflow_source" in " ".join(res.output.split())  # the summary table
    summary = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert (summary["inflow"], summary["inflow_source"]) == ("four-quadrant", "vehicle file")
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "inflow</td><td>four-quadrant" in page and "inflow_source</td><td>vehicle file" in page


@pytest.mark.slow
def test_hold_and_stability_json_say_the_inflow_in_force(tmp_path):
    path = _write(tmp_path / "v4q.yaml", _raw(inflow="four-quadrant"))
    hold = _json(_run("vehicle", "hold", "bluerov2", "--step", "90", "--json"))
    assert (hold["inflow"], hold["inflow_source"], hold["capability"]["inflow"]) == (
        "none", "vehicle file", "none")
    hold = _json(_run("vehicle", "hold", path, "--step", "90", "--json"))
    assert (hold["inflow"], hold["inflow_source"]) == ("four-quadrant", "vehicle file")
    st = _json(_run("vehicle", "stability", path, "--json", "--inflow", "none"))
    assert (st["inflow"], st["inflow_source"]) == ("none", "option")
    st = _json(_run("vehicle", "stability", path, "--json"))
    assert (st["inflow"], st["inflow_source"]) == ("four-quadrant", "vehicle file")


# ------------------------------------------------------------------ 3: scenarios, thruster models
def test_a_scenario_takes_an_inflow_key_and_a_thruster_model_with_a_map(tmp_path):
    from uuvid.simulate.scenario import ScenarioError, build, scenario_from_dict

    _write(tmp_path / "v4q.yaml", _raw(inflow="four-quadrant"))
    own = build(scenario_from_dict({"vehicle": "v4q.yaml", "duration": 1.0}), tmp_path)[1]
    # the vehicle's own model named as thruster_model: the same propeller map, not a refusal
    t200 = build(scenario_from_dict({"vehicle": "v4q.yaml", "thruster_model": "t200",
                                     "duration": 1.0}), tmp_path)[1]
    assert t200.inflow_arrays is not None and (t200.inflow, t200.inflow_source) == (
        "four-quadrant", "vehicle file")
    for a, b in zip(own.inflow_arrays, t200.inflow_arrays):
        assert (a == b).all()
    off = build(scenario_from_dict({"vehicle": "v4q.yaml", "thruster_model": "laidani-a2212",
                                    "inflow": "none", "duration": 1.0}), tmp_path)[1]
    assert off.inflow_arrays is None and (off.inflow, off.inflow_source) == ("none", "scenario file")
    spec = scenario_from_dict({"vehicle": "v4q.yaml", "thruster_model": "laidani-a2212",
                               "duration": 1.0})
    with pytest.raises(ScenarioError, match=r"'laidani-a2212' holds none.*set inflow: none in the "
                                            r"scenario \(--inflow none on the command line\)") as e:
        build(spec, tmp_path)
    assert "inflow='none'" not in str(e.value)
    assert build(spec, tmp_path, inflow="none")[1].inflow_source == "option"


def test_cli_thruster_model_t200_flies_with_inflow_on():
    doc = _json(_run("simulate", "mission", "square", "--vehicle", "bluerov2", "--thruster-model",
                     "t200", "--inflow", "four-quadrant", "--side", "1", "--json"))
    assert (doc["inflow"], doc["inflow_source"]) == ("four-quadrant", "option")


# ------------------------------------------------------------------ 4: the keys' own messages
def test_a_propeller_that_is_not_there_warns_with_inflow_off(tmp_path):
    raw = _raw()
    raw["thrusters"][1]["propeller"] = "nosuch.yaml"
    path = _write(tmp_path / "p.yaml", raw)
    with pytest.warns(VehicleFileWarning, match=r"T2_front_left: propeller 'nosuch\.yaml' is "
                                                r"neither a preset.*inflow is none"):
        load_vehicle(path)


def test_a_wake_error_says_what_a_wake_fraction_is_without_the_presets(tmp_path):
    raw = _raw()
    raw["thrusters"][0]["wake"] = 1.5
    res = _run("vehicle", "info", _write(tmp_path / "w.yaml", raw))
    text = " ".join(res.output.split())
    assert res.exit_code == 2 and "thrusters[0].wake: a wake fraction w in [0, 1)" in text
    assert "got 1.5" in text and "presets" not in text


def test_inflow_null_is_none(tmp_path):
    assert load_vehicle(_write(tmp_path / "n.yaml", _raw(inflow=None))).inflow == "none"
    with pytest.raises(VehicleFileError, match="write none or four-quadrant"):
        load_vehicle(_write(tmp_path / "b.yaml", _raw(inflow=False)))


def test_an_implausible_wake_fraction_warns_naming_the_thruster(tmp_path):
    from uuvid.vehicle.definition import WAKE_PLAUSIBLE_MAX

    raw = _raw(inflow="four-quadrant")
    raw["thrusters"][4]["wake"] = 0.999
    raw["thrusters"][0]["wake"] = WAKE_PLAUSIBLE_MAX  # the bound itself is plausible
    with pytest.warns(VehicleFileWarning) as got:
        load_vehicle(_write(tmp_path / "w.yaml", raw))
    msgs = [str(w.message) for w in got if "wake" in str(w.message)]
    assert len(msgs) == 1 and "T5_vertical_right: wake 0.999 is above 0.5" in msgs[0]
    assert "T1_front_right" not in msgs[0]
