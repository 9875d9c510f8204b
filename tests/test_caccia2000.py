"""Caccia, Indiveri & Veruggio (2000): ROMEO's published estimates as the truth of a simulated
vehicle, the whole identification procedure run on its simulated logs."""

import json

import pytest

from uuvid.core.atomic import to_jsonable
from uuvid.papers import caccia2000

TABLES = ("heave", "yaw_linear_quadratic", "yaw_low_speed", "yaw_linear",
          "surge_forward_standard", "surge_backward_standard", "surge_forward_plankton",
          "surge_backward_plankton", "yaw_inertia", "surge_mass")


@pytest.fixture(scope="module")
def result():
    return caccia2000.reproduce(seed=0, fast=True)


def test_every_table_and_parameter(result):
    assert caccia2000.TABLE_KEYS == TABLES
    for table in TABLES:
        params = result[table]["parameters"]
        assert set(caccia2000.PAPER[table]) <= set(params), table
        for name, row in params.items():
            assert {"estimate", "sigma", "truth", "paper_sigma"} <= set(row)
            assert row["sigma"] > 0, (table, name)


def test_truth_within_three_sigma(result):
    for table in TABLES:
        for name, row in result[table]["parameters"].items():
            assert abs(row["estimate"] - row["truth"]) <= 3 * row["sigma"], (table, name, row)


def test_sigma_of_the_papers_order(result):
    for table in TABLES:
        for name, row in result[table]["parameters"].items():
            if row["paper_sigma"]:
                assert 1 / 3 <= row["sigma"] / row["paper_sigma"] <= 3, (table, name, row)


def test_low_speed_yaw_reduced_to_linear(result):
    low = result["yaw_low_speed"]
    assert low["quadratic_significant"] is False
    assert low["reduced_to"] == "linear"
    assert low["parameters"]["k_q"]["percentile_error"] > 51.02
    assert "k_q" not in result["yaw_linear"]["parameters"]
    assert result["yaw_linear_quadratic"]["quadratic_significant"] is True
    assert result["acceptance"]["passed"], result["acceptance"]["failures"]


def test_design_and_phase_lags(result):
    d = result["design"]
    assert d["omega_opt_yaw"] == pytest.approx(0.176, rel=0.02)
    assert d["omega_opt_surge"] == pytest.approx(0.18, rel=0.02)
    assert d["fisher_check"]["yaw_numeric_over_analytic"] == pytest.approx(1.0, abs=1e-4)
    assert d["phase_lag_yaw_deg"] == pytest.approx(37.6, abs=0.5)
    assert d["phase_lag_surge_deg"] == pytest.approx(45.4, abs=0.5)
    # measured in the simulated sine experiments (the paper measured 39° and 37°)
    assert d["phase_lag_yaw_measured_deg"] == pytest.approx(d["phase_lag_yaw_deg"], abs=3.0)
    assert d["phase_lag_surge_measured_deg"] == pytest.approx(d["phase_lag_surge_deg"], abs=3.0)
    assert d["surge_experiment"]["command_samples"] > 100
    assert d["surge_experiment"]["omega"] > d["surge_experiment"]["omega_opt"]  # 20 m pool


def test_sensors_had_outliers_and_gaps(result):
    rej = result["surge_forward_standard"]["rejections"]
    assert rej["outliers"] > 0 and rej["missing"] > 0
    assert result["surge_mass"]["cleaning"].count("outliers") == 1
    assert result["surge_forward_standard"]["velocity_relative_error_max"] < 0.03
    # the 6-DOF couplings stay small in these manoeuvres (the paper's case for 1-DOF models)
    assert result["coupling"]["surge_standard"]["max_abs_pitch_deg"] < 1.0


def test_inertia_reports_both_sigmas(result):
    for key in ("yaw_inertia", "surge_mass"):
        r = result[key]
        assert r["cov_type"] == "HAC"
        assert r["sigma_classical"] < r["sigma_regression"]
        assert "6-DOF" in r["simulation"]


def test_json_and_determinism(result):
    text = json.dumps(to_jsonable(dict(result)), allow_nan=False)
    assert "surge_mass" in text
    again = caccia2000.reproduce(seed=0, fast=True)
    for table in ("heave", "surge_mass", "yaw_inertia"):
        for name, row in result[table]["parameters"].items():
            assert again[table]["parameters"][name]["estimate"] == row["estimate"]


def test_write_outputs(result, tmp_path):
    page = caccia2000.write_outputs(result, tmp_path)
    assert page.name == "index.html" and "Caccia" in page.read_text()
    for f in ("caccia2000_fig5_fig6_heave.png", "caccia2000_drag_fits.png",
              "caccia2000_inertia.png"):
        assert (tmp_path / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((tmp_path / "caccia2000.json").read_text())["seed"] == 0
    with pytest.raises(ValueError, match="artifacts"):
        caccia2000.write_outputs(dict(result), tmp_path)
