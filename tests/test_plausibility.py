"""Plausibility checks: a unit or sign mistake that gives a "valid" result is warned or refused."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()


def _predict(*args):
    res = runner.invoke(app, ["thruster", "predict", *map(str, args), "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


# ------------------------------------------------------------------ thruster predict
def test_duty_given_as_pwm_is_warned_with_the_expected_range():
    doc = _predict("t200", "--pwm", "0:1:0.25")
    (w,) = doc["warnings"]
    assert "1100–1900 µs" in w and "look like duties" in w


def test_pwm_in_range_has_no_warning():
    assert _predict("t200", "--pwm", "1100:1900:100")["warnings"] == []


@pytest.mark.parametrize("volts, warned", [(48, True), (6, True), (12, False), (16, False),
                                           (16.8, False)])
def test_supply_voltage_outside_the_sheets_is_warned(volts, warned):
    doc = _predict("t200", "--pwm", "1900", "--supply-voltage", volts)
    hit = [w for w in doc["warnings"] if "outside the data's 12–16 V" in w]
    assert bool(hit) == warned, doc["warnings"]


def test_supply_voltage_of_a_model_file_is_checked_against_its_esc(tmp_path):
    from uuvid.io.modelfile import save_chain
    from uuvid.thruster.presets import preset_chain

    p = save_chain(preset_chain("laidani-a2212"), tmp_path / "m.yaml")
    v0 = preset_chain("laidani-a2212").blocks[0].supply_voltage
    assert not [w for w in _predict(p, "--pwm", "1600", "--supply-voltage", v0)["warnings"]
                if "supply voltage" in w]
    doc = _predict(p, "--pwm", "1600", "--supply-voltage", 4 * v0)
    assert any(f"outside the data's {v0:g} V" in w for w in doc["warnings"])
