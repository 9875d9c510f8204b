"""McLean (1991): α_o − α_i and β_o − β_i from Table I's steady columns, and the model with
Coulomb friction fitted to the experiments of Tables II/III."""

import json
import math

import pytest

from uuvid.papers import mclean1991_identification as mi
from uuvid.thruster import presets


@pytest.fixture(scope="module")
def corrections():
    return mi.identify_corrections()


def test_corrections_from_table1_steady_columns(corrections):
    """Digest §A.3: α_o − α_i ≈ 3.0 and β_o − β_i ≈ 0.185, which the thesis never printed."""
    da, db = corrections["energy_correction"], corrections["momentum_correction"]
    assert da.value == pytest.approx(presets.AUV2_ENERGY_CORRECTION, abs=0.3)
    assert db.value == pytest.approx(presets.AUV2_MOMENTUM_CORRECTION, abs=0.02)
    assert da.percentile_error < 5 and db.percentile_error < 6
    assert abs(da.value - 3.0) < 3 * da.stderr + 0.1
    assert abs(db.value - 0.185) < 3 * db.stderr


def test_corrections_predict_each_steady_row_left_out():
    """Identified from the other rows, the corrections predict each row's printed steady speed
    within 5 % and its thrust within 20 % (8 V: 0.126 against a printed 0.15 lb)."""
    rows = mi.leave_one_out()
    assert [r["case"] for r in rows] == list(mi.STEADY_CASES)
    for row in rows:
        assert row["predicted_rpm"] == pytest.approx(row["steady_rpm"], rel=0.05), row
        assert row["predicted_lbf"] == pytest.approx(row["steady_lbf"], rel=0.2), row


def test_pe0_row_is_motor_and_friction_alone(corrections):
    pe0 = corrections.extra["pe0_check"]
    assert pe0["model_rpm"] == pytest.approx(3000, rel=0.01)  # not a row the fit used


@pytest.mark.parametrize("start", [mi.OUTPUT_START, (10.0, 0.05), (0.3, 0.02)])
def test_output_error_cross_check_agrees_from_away(corrections, start):
    """The nonlinear output-error fit, started far from the answer, moves to the linear
    equation-error solution (a frozen optimiser would stay at its start, many σ away)."""
    out = mi.identify_corrections(method="output", start=start)
    assert out.extra["start"] == list(start) and not out.warnings
    for name, s0 in zip(("energy_correction", "momentum_correction"), start):
        a, b = corrections[name], out[name]
        assert abs(a.value - b.value) < 2 * max(a.stderr, b.stderr)
        assert abs(b.value - s0) > 10 * b.stderr  # it moved


def test_corrections_reject_bad_cases():
    with pytest.raises(ValueError, match="unknown Table I case"):
        mi.identify_corrections(cases=("baseline", "L=30in"))
    with pytest.raises(ValueError, match="P_e = 0"):
        mi.identify_corrections(cases=("baseline", "Pe=0"))
    with pytest.raises(ValueError, match="method"):
        mi.identify_corrections(method="magic")


def test_thesis_simulation_against_its_experiments():
    """Table III: the thesis's own simulation misses its experiments by 31.7 % on average."""
    assert mi.thesis_mean_abs_rel_error() == pytest.approx(0.3174, abs=5e-4)


@pytest.fixture(scope="module")
def experiments():
    return mi.fit_experiments()


@pytest.mark.slow
def test_experiment_fit_beats_the_thesis(experiments):
    """With Coulomb friction the model matches the nine numbers of Table II within 15 % on average
    (the thesis's simulation: 31.7 %)."""
    assert experiments["mean_abs_rel_error"] < 0.15
    assert experiments["thesis_mean_abs_rel_error"] == pytest.approx(0.3174, abs=5e-4)
    json.dumps(experiments)


@pytest.mark.slow
def test_experiment_fit_parameters_are_physical(experiments):
    p = experiments["parameters"]
    assert set(p) == set(mi.DEFAULT_FREE)
    for name, e in p.items():
        assert e["bounds"][0] < e["estimate"] < e["bounds"][1], name
        assert math.isfinite(e["sigma"]) and e["sigma"] > 0, name
    # the motor starts at 8 V but needs a few volts to overcome friction (thesis: 4–5 V static)
    assert 1.0 < p["coulomb_volts"]["estimate"] < 5.0
    # the corrections stay near the values identified from Table I
    assert p["energy_correction"]["estimate"] == pytest.approx(3.0, rel=0.5)
    assert p["momentum_correction"]["estimate"] == pytest.approx(0.185, rel=0.5)


def test_experiment_rows(experiments):
    rows = {r["voltage_V"]: r for r in experiments["rows"]}
    assert list(rows) == [24.0, 16.0, 8.0]
    for v, r in rows.items():
        assert r["experiment"] == mi.EXPERIMENTS[v]
        assert set(r["rel_error"]) == set(mi.EXPERIMENT_FIELDS)
    # the thesis's worst row (8 V: 1.85 against 0.95 lb peak, 0.15 against 0.08 lb steady) is fixed
    r8 = rows[8.0]
    assert r8["rel_error"]["peak_output_lbf"] < 0.3 < r8["thesis_rel_error"]["peak_output_lbf"]
    assert r8["rel_error"]["steady_lbf"] < 0.15 < r8["thesis_rel_error"]["steady_lbf"]
    assert experiments["tachometer"]["ours_rpm"] == pytest.approx(900, rel=0.15)


def test_experiment_fit_rejects_unknown_parameters():
    with pytest.raises(ValueError, match="free must name"):
        mi.fit_experiments(free=("coulomb_volts", "warp_factor"))
    with pytest.raises(ValueError, match="unknown parameter"):
        mi.experiment_chain({"warp_factor": 9})
