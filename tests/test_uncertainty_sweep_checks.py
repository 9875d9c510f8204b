"""A new user's sweep files: units of the wrong kind, values that are not numbers, currents no sea
has, runs that all fail, a PWM thruster stepped with a voltage."""

import pytest
import typer
from typer.testing import CliRunner

from uuvid.cli.uncertainty_cmds import register
from uuvid.uncertainty.sweep import SweepError, load_sweep, sweep_from_dict

app = typer.Typer()
register(app)
runner = CliRunner()

VEHICLE = {"kind": "vehicle_mission"}


def _axis(**kw):
    return {"target": VEHICLE, "parameters": [{"name": "current_speed", **kw}]}


def test_sweep_unit_must_be_of_the_parameters_dimension():
    with pytest.raises(SweepError, match=r"f\.yaml.*'current_speed'.*unit 'rpm'.*takes m/s.*kn"):
        sweep_from_dict(_axis(unit="rpm", values=[0.1, 0.5]), where="f.yaml")
    with pytest.raises(SweepError, match=r"'tunnel_length'.*unit 'lbf'.*takes m, in"):
        sweep_from_dict({"target": {"kind": "thruster_step"},
                         "parameters": [{"name": "tunnel_length", "unit": "lbf", "values": [1]}]})


def test_sweep_accepts_speed_units():
    g = sweep_from_dict(_axis(unit="kn", values=[1, 2])).parameters[0].grid()
    assert g == pytest.approx([1852 / 3600, 2 * 1852 / 3600])
    g = sweep_from_dict(_axis(unit="cm/s", values=[10])).parameters[0].grid()
    assert g == pytest.approx([0.1])


def test_sweep_current_direction_unit_deg_is_not_converted_twice():
    spec = sweep_from_dict({"target": VEHICLE, "parameters": [
        {"name": "current_direction", "unit": "deg", "values": [90]}]})
    assert spec.parameters[0].grid() == pytest.approx([90.0])  # taken in degrees by the model


def test_sweep_value_not_a_number_refused_when_read(tmp_path):
    f = tmp_path / "sw.yaml"
    f.write_text("target: {kind: vehicle_mission}\n"
                 "parameters: [{name: current_speed, values: [0.1, fast]}]\n")
    with pytest.raises(SweepError, match=r"sw\.yaml: parameters\[0\] \(current_speed\): value "
                                         r"'fast' is not a number"):
        load_sweep(f)
    with pytest.raises(SweepError, match=r"runs\[1\]\.mass: value 'heavy' is not a number"):
        sweep_from_dict({"target": VEHICLE, "mode": "list",
                         "runs": [{"mass": 10}, {"mass": "heavy"}]})


def test_sweep_current_faster_than_any_sea_refused_when_read():
    with pytest.raises(SweepError, match=r"f\.yaml: parameters\[0\] \(current_speed\): value "
                                         r"1000000\.0.*at most 6 m/s"):
        sweep_from_dict(_axis(values=[0.1, 1e6]), where="f.yaml")
    with pytest.raises(SweepError, match=r"value 20 kn.*10\.2889 m/s"):
        sweep_from_dict(_axis(unit="kn", values=[20]))


def test_sweep_exit_1_when_every_run_fails_and_says_why(tmp_path):
    f = tmp_path / "t.yaml"
    f.write_text("target: {kind: thruster_step, chain: auv2-tunnel, t_end: 0.05, substeps: 1}\n"
                 "parameters: [{name: 'blocks[0].motor.resistance', values: [-0.1]}]\n")
    res = runner.invoke(app, ["sweep", str(f), "--out", str(tmp_path / "o"), "--backend",
                              "inprocess"])
    assert res.exit_code == 1, res.output
    assert "none of the runs succeeded" in res.output and "invalid" in res.output
    assert "-0.1" in res.output and str(f) in res.output
