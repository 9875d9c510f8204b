"""``uuvid sweep`` / ``uuvid montecarlo`` (registered on a local app, as app.py will) and the demo
pieces."""

import json

import pytest
import typer
from typer.testing import CliRunner

from uuvid.cli.uncertainty_cmds import register
from uuvid.uncertainty.showcase import demo_montecarlo, demo_sweep

app = typer.Typer()
register(app)
runner = CliRunner()

SWEEP_YAML = """
name: cli-sweep
target: {kind: thruster_step, chain: auv2-tunnel, t_end: 0.5, substeps: 1}
parameters:
  - {name: tunnel_length, unit: in, values: [5, 20]}
  - {name: voltage, values: [12, 24]}
metrics: [peak_output_thrust, steady_thrust]
"""


@pytest.mark.slow
def test_sweep_command_json(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text(SWEEP_YAML)
    out = tmp_path / "out"
    res = runner.invoke(app, ["sweep", str(f), "--out", str(out), "--backend", "inprocess",
                              "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["runs"] == 4 and doc["succeeded"] == 4 and doc["partial"] is False
    assert set(doc["metrics"]) == {"peak_output_thrust", "steady_thrust"}
    assert "spec" not in doc and doc["out"] == str(out)
    assert (out / "results.csv").exists() and (out / "index.html").exists()


def test_sweep_command_errors_exit_2(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text(SWEEP_YAML.replace("tunnel_length", "tunnel_lenght"))
    res = runner.invoke(app, ["sweep", str(f), "--out", str(tmp_path / "o"), "--backend", "inprocess"])
    assert res.exit_code == 2 and "tunnel_lenght" in res.output
    res = runner.invoke(app, ["sweep", "nope.yaml", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "not a built-in sweep" in res.output
    f.write_text(SWEEP_YAML)
    res = runner.invoke(app, ["sweep", str(f), "--out", str(tmp_path / "o"), "--backend", "threads"])
    assert res.exit_code == 2 and "backend must be one of" in res.output


@pytest.mark.slow
def test_montecarlo_command_json(tmp_path):
    res = runner.invoke(app, ["montecarlo", "t200-physical", "--runs", "40", "--seed", "1",
                              "--backend", "inprocess", "--out", str(tmp_path / "mc"), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["succeeded"] == 40 and doc["model"] == "t200-physical"
    end = doc["bands"]["thrust@16V"]["at_end"]
    assert end["lower"] <= end["median"] <= end["upper"]
    assert (tmp_path / "mc" / "band_thrust_at_16V.png").exists()


def test_montecarlo_command_errors_exit_2():
    res = runner.invoke(app, ["montecarlo", "no-such-model", "--runs", "3"])
    assert res.exit_code == 2 and "bluerov2-identified" in res.output
    res = runner.invoke(app, ["montecarlo", "t200-physical", "--runs", "3", "--requirement", "x=1"])
    assert res.exit_code == 2 and "METRIC<VALUE" in res.output
    res = runner.invoke(app, ["montecarlo", "t200-physical", "--runs", "0"])
    assert res.exit_code == 2
    res = runner.invoke(app, ["montecarlo", "t200-physical", "--runs", "3", "--backend", "inprocess",
                              "--requirement", "max_tracking_error_m<0.5"])
    assert res.exit_code == 2 and "unknown metric" in res.output


@pytest.mark.slow
def test_demo_pieces(tmp_path):
    d = demo_sweep(tmp_path / "sweep")
    assert d["summary"]["succeeded"] == 30 and d["summary"]["figures"]
    assert 20 < d["baseline_24V"]["peak_output_thrust"] < 30  # 5.4 lb in Table I
    m = demo_montecarlo(tmp_path / "mc", runs=100)
    b = m["full_forward_thrust_band_N"]["thrust@14V"]
    assert b["lower"] <= b["median"] <= b["upper"]
    assert (tmp_path / "mc" / "index.html").exists()
    json.dumps(d)
    json.dumps(m)
