"""What a sweep or Monte Carlo of vehicle missions says on stderr while building its runs — the
vehicle file's warnings, a duration that is not a whole number of steps — is in its ``--json``
document (and ``summary.json``) too, under ``warnings`` as other commands' JSON has it, once each.
They reached stderr only, and the document said nothing."""

from __future__ import annotations

import json
import warnings

import pytest
import typer
import yaml
from typer.testing import CliRunner

from uuvid.cli.uncertainty_cmds import register

app = typer.Typer()
register(app)
runner = CliRunner()

ROUNDED = ("duration = 2.005 s is not a whole number of steps (dt = 0.01 s): the flight takes "
           "200 steps and flies 2 s")
SCENARIO = {"duration": 2.005, "dt": 0.01, "mission": {"kind": "square", "side": 2}}


@pytest.fixture()
def big(tmp_path):
    """The BlueROV2 with an inertia of 160 kg·m²: a valid file its loader warns of."""
    from uuvid.vehicle.definition import preset_path

    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    raw["rigid_body"]["inertia"] = [160.0, 160.0, 160.0]
    p = tmp_path / "bluerov2-big.yaml"
    p.write_text(yaml.safe_dump(raw))
    return p


def _invoke(args):
    """The command's JSON document and the texts of the warnings it raised (stderr's lines)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout), [str(w.message) for w in caught]


def _check(doc, said, big):
    file_warning = next(w for w in said if w.startswith(f"{big}: rigid_body: inertia 160"))
    assert ROUNDED in said  # on stderr, as before
    assert doc["warnings"].count(file_warning) == 1, doc.get("warnings")
    assert doc["warnings"].count(ROUNDED) == 1, doc.get("warnings")


def test_sweep_json_lists_the_vehicle_files_and_the_durations_warnings(tmp_path, big):
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump({"name": "warned", "target": {
        "kind": "vehicle_mission", "scenario": {"vehicle": str(big), **SCENARIO}},
        "parameters": [{"name": "damping_scale", "values": [0.5, 1.0]}]}))
    for k in range(2):  # the second in the same process: the plan (and its build) is cached
        out = tmp_path / f"o{k}"
        doc, said = _invoke(["sweep", str(f), "--out", str(out), "--backend", "inprocess", "--json"])
        _check(doc, said, big)
        assert json.loads((out / "summary.json").read_text())["warnings"] == doc["warnings"]


def test_montecarlo_json_lists_the_vehicle_files_and_the_durations_warnings(tmp_path, big):
    f = tmp_path / "m.yaml"
    f.write_text(yaml.safe_dump({
        "format": "uuvid-uncertain-model/1", "name": "warned", "kind": "vehicle",
        "base": {"vehicle": str(big), "scenario": SCENARIO},
        "parameters": [{"name": "damping_scale", "estimate": 1.0, "sigma": 0.1, "lower": 0}]}))
    doc, said = _invoke(["montecarlo", str(f), "--runs", "3", "--backend", "inprocess", "--json"])
    _check(doc, said, big)


def test_a_sweep_without_warnings_has_none_in_its_json(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump({"target": {"kind": "vehicle_mission", "scenario": {
        "vehicle": "bluerov2", "duration": 2.0, "dt": 0.01, "mission": {"kind": "square", "side": 2}}},
        "parameters": [{"name": "damping_scale", "values": [1.0]}]}))
    doc, said = _invoke(["sweep", str(f), "--out", str(tmp_path / "o"), "--backend", "inprocess",
                         "--json"])
    assert not doc.get("warnings") and not [w for w in said if "duration" in w]
