"""What a user reads (issue 22): every number with its unit, every default said aloud, reports
that show all they hold."""

import json

from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()


def test_predict_says_the_default_supply_voltage_it_used():
    res = runner.invoke(app, ["thruster", "predict", "t200", "--pwm", "1500,1900"])
    assert res.exit_code == 0, res.output
    assert "default 16 V" in res.stderr and "16 V supply" in res.stdout
    doc = json.loads(runner.invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm",
                                         "1500,1900", "--json"]).stdout)
    assert doc["supply_voltage_V"] == 12.0 and "default" in doc["supply_voltage_source"]
    assert doc["warnings"] == []


def test_predict_warns_outside_the_presets_data_voltages():
    res = runner.invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm", "1700:1900:100",
                              "--supply-voltage", "14", "--json"])
    doc = json.loads(res.stdout)
    assert any("outside the 12 V" in w for w in doc["warnings"]), doc["warnings"]
    res = runner.invoke(app, ["thruster", "predict", "t200", "--pwm", "1900",
                              "--supply-voltage", "14", "--json"])
    assert json.loads(res.stdout)["warnings"] == []  # inside the 12–16 V sheets
    res = runner.invoke(app, ["thruster", "predict", "t200", "--pwm", "1900",
                              "--supply-voltage", "20"])
    assert "outside the 12–16 V" in res.stderr


def test_readme_predict_example_is_inside_its_data_or_explained():
    from pathlib import Path

    readme = (Path(__file__).parents[1] / "README.md").read_text()
    for line in readme.splitlines():
        if line.startswith("uuvid thruster predict laidani-a2212") and "--supply-voltage" in line:
            assert "--supply-voltage 12 " in line, line
    assert "identified at 12 V only" in readme
