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


T200 = {"kind": "thruster_step", "chain": "t200", "t_end": 0.5, "dt": 0.001}


def test_sweep_thruster_step_default_signal_follows_the_chains_input():
    import warnings

    from uuvid.uncertainty.sweep import SweepStudy, run_sweep

    spec = sweep_from_dict({"target": T200, "metrics": ["steady_thrust"],
                            "parameters": [{"name": "blocks[1].time_constant", "values": [0.1]}]})
    study = SweepStudy(spec)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning for the chain's own step
        study.check()
    assert study.plan.signal_spec["baseline"] == 1500 and study.plan.signal_spec["amplitude"] == 1900
    res = run_sweep(spec, backend="inprocess")
    assert res.table["steady_thrust"].iloc[0] > 0  # full forward, not the ESC's full reverse
    mcl = SweepStudy(sweep_from_dict({"target": {"kind": "thruster_step"},
                                      "parameters": [{"name": "voltage", "values": [12]}]}))
    mcl.check()
    assert mcl.plan.signal_spec["amplitude"] == 24.0  # a voltage input: 0 → 24 V as before


def test_sweep_signal_outside_the_escs_range_warns_as_thruster_simulate():
    from uuvid.core.checks import InputWarning
    from uuvid.uncertainty.sweep import SweepStudy

    spec = sweep_from_dict({"target": {**T200, "signal": {"kind": "step", "amplitude": 24.0}},
                            "parameters": [{"name": "blocks[1].time_constant", "values": [0.1]}]})
    with pytest.warns(InputWarning, match=r"target\.signal: .*outside 800–2200 µs.*24 µs"):
        SweepStudy(spec).check()
    spec = sweep_from_dict({"target": T200, "parameters": [{"name": "command",
                                                             "values": [1600, 24]}]})
    with pytest.warns(InputWarning, match=r"e\.g\. 24 µs"):
        SweepStudy(spec).check()


def test_sweep_cli_shows_the_signal_warning(tmp_path):
    f = tmp_path / "t.yaml"
    f.write_text("target: {kind: thruster_step, chain: t200, t_end: 0.05, dt: 0.001,\n"
                 "         signal: {kind: step, amplitude: 24.0}}\n"
                 "parameters: [{name: 'blocks[1].time_constant', values: [0.1]}]\n")
    from uuvid.core.checks import InputWarning

    with pytest.warns(InputWarning):
        res = runner.invoke(app, ["sweep", str(f), "--out", str(tmp_path / "o"), "--backend",
                                  "inprocess", "--json"])
    assert res.exit_code == 0, res.output
    import json

    doc = json.loads(res.stdout)
    assert any("24 µs" in w for w in doc["warnings"])


def test_montecarlo_says_a_thruster_model_file_is_not_an_uncertain_model(tmp_path):
    from uuvid.thruster.modelfile import save_chain
    from uuvid.thruster.presets import PRESETS

    f = save_chain(PRESETS["t200"](), tmp_path / "o.yaml")
    res = runner.invoke(app, ["montecarlo", str(f), "--runs", "5"])
    assert res.exit_code == 2, res.output
    out = " ".join(res.output.split())
    assert "this is a thruster model file (uuvid thruster fit --out-model" in out
    assert "uuvid-uncertain-model/1" in out and "kind: thruster_chain" in out
    assert "unknown key" not in out and "kind: missing" not in out
    s = tmp_path / "s.yaml"
    s.write_text("format: uuvid-sweep/1\ntarget: {kind: thruster_step}\n"
                 "parameters: [{name: voltage, values: [1]}]\n")
    res = runner.invoke(app, ["montecarlo", str(s), "--runs", "5"])
    assert res.exit_code == 2 and "this is a sweep file" in " ".join(res.output.split())
