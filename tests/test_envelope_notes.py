"""The envelope's notes reach the command line (fix-f2, item 1).

A vehicle flying a four-quadrant map fitted on a bench over β 0–14° and 166–180° (the inflow
tutorial's ``propeller: my-propeller.yaml``) reads the map outside its advance angles in steady
sideways flight: ``speed_envelope(v).notes`` says so ("extrapolated: …"), but ``uuvid vehicle
envelope`` printed nothing about it and its ``--json`` had ``"warnings": []`` — nor the notes
"not controlled (left free): roll, pitch" and "inflow …"."""

import json
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from uuvid.analysis.envelope_check import confirm_envelope
from uuvid.cli.app import app
from uuvid.vehicle.definition import load_vehicle

sys.path.insert(0, str(Path(__file__).parent))
from test_vehicle_inflow import _fitted_vehicle  # noqa: E402

runner = CliRunner()


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    return _fitted_vehicle(tmp_path_factory.mktemp("fitted"))[0]


def _flat(text):
    return " ".join(text.split())


@pytest.mark.slow
def test_the_check_carries_the_envelope_notes_and_warns_of_the_extrapolation(fitted):
    check = confirm_envelope(load_vehicle(fitted), simulate=False)
    assert any(n.startswith("not controlled (left free): roll, pitch") for n in check.notes)
    assert any(n.startswith("inflow four-quadrant") for n in check.notes)
    warned = [w for w in check.warnings() if w.startswith("extrapolated: the fitted propeller map")]
    assert warned and "[0°, 14°] and [166°, 180°]" in warned[0]
    doc = check.to_dict()
    assert doc["notes"] == list(check.notes) and warned[0] in doc["warnings"]
    assert "note: not controlled (left free): roll, pitch" in check.summary()


@pytest.mark.slow
def test_vehicle_envelope_prints_the_notes_and_the_extrapolation(fitted):
    res = runner.invoke(app, ["vehicle", "envelope", str(fitted), "--no-confirm"])
    assert res.exit_code == 0, res.output
    assert "warning: extrapolated: the fitted propeller map ([0°, 14°] and [166°, 180°]) is read " \
           "outside its advance angles" in _flat(res.stderr)
    out = _flat(res.stdout)
    assert "note: not controlled (left free): roll, pitch" in out
    assert "note: inflow four-quadrant" in out
    assert "note: extrapolated" not in out  # said once, as the warning on stderr


@pytest.mark.slow
def test_vehicle_envelope_json_has_the_notes_and_the_warning(fitted):
    res = runner.invoke(app, ["vehicle", "envelope", str(fitted), "--no-confirm", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert any(w.startswith("extrapolated: the fitted propeller map") for w in doc["warnings"])
    assert any(n.startswith("not controlled (left free): roll, pitch") for n in doc["notes"])


@pytest.mark.slow
def test_vehicle_stability_warns_that_its_envelope_speeds_are_extrapolated(fitted):
    """The stability scan runs up to the envelope's speeds: the same caveat applies to them."""
    res = runner.invoke(app, ["vehicle", "stability", str(fitted), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert any(w.startswith("extrapolated: the fitted propeller map") for w in doc["warnings"])
    assert "warning: extrapolated: the fitted propeller map" in _flat(res.stderr)


def test_a_bench_covering_every_angle_warns_of_nothing(tmp_path):
    from uuvid.vehicle.definition import preset_path

    check = confirm_envelope(load_vehicle(preset_path("bluerov2")), simulate=False)
    assert not [w for w in check.warnings() if w.startswith("extrapolated")]
    assert check.notes  # the notes are there all the same


def test_hold_warns_where_a_held_current_reads_the_map_beyond_its_bench(fitted):
    """``vehicle hold`` computed its currents through the fitted map outside its advance angles
    and said nothing (the envelope says it since this stop's fix); the capability now warns, in
    its summary, its dict and the command's stderr/--json."""
    from uuvid.analysis.hold import capability

    cap = capability(load_vehicle(fitted), step_deg=90.0)
    w = cap.warnings()
    assert w and "extrapolated" in w[0] and "β =" in w[0], w
    assert cap.to_dict()["warnings"] == w and "warning: extrapolated" in cap.summary()
    r = runner.invoke(app, ["vehicle", "hold", str(fitted), "--step", "90", "--json"])
    assert r.exit_code == 0, r.output
    assert any("extrapolated" in x for x in json.loads(r.stdout)["warnings"])


def test_hold_with_a_map_of_the_whole_circle_warns_of_nothing():
    from uuvid.analysis.hold import capability
    from uuvid.vehicle.definition import load_vehicle as load

    assert capability(load("bluerov2"), step_deg=90.0, inflow="four-quadrant").warnings() == []
