"""Caccia, Indiveri & Veruggio (2000): ROMEO's published estimates as the truth of a simulated
vehicle, the whole identification procedure run on its simulated logs."""

import json
import math

import pytest

from uuvid.core.atomic import to_jsonable
from uuvid.papers import caccia2000

TABLES = ("heave", "yaw_linear_quadratic", "yaw_low_speed", "yaw_linear",
          "surge_forward_standard", "surge_backward_standard", "surge_forward_plankton",
          "surge_backward_plankton", "yaw_inertia", "surge_mass")


@pytest.fixture(scope="module")
def result():
    return caccia2000.reproduce(seed=0, fast=True)


@pytest.mark.slow
def test_every_table_and_parameter(result):
    assert caccia2000.TABLE_KEYS == TABLES
    for table in TABLES:
        params = result[table]["parameters"]
        assert set(caccia2000.PAPER[table]) <= set(params), table
        for name, row in params.items():
            assert {"estimate", "sigma", "truth", "paper_sigma"} <= set(row)
            assert row["sigma"] > 0, (table, name)


@pytest.mark.slow
def test_sigma_of_the_papers_order(result):
    """The criterion the 16-seed study applies (≥ 90 % of σ within a factor 3 of the paper's),
    not "every σ on this seed", which seed 0 meets and 3 of seeds 0–15 do not."""
    ratios = [row["sigma"] / row["paper_sigma"] for table in TABLES
              for row in result[table]["parameters"].values() if row["paper_sigma"]]
    assert len(ratios) >= 30
    assert sum(1 / 3 <= q <= 3 for q in ratios) >= 0.9 * len(ratios)


@pytest.mark.slow
def test_low_speed_yaw_reduced_to_linear(result):
    low = result["yaw_low_speed"]
    assert low["quadratic_significant"] is False
    assert low["reduced_to"] == "linear"
    assert low["parameters"]["k_q"]["percentile_error"] > 51.02
    assert "k_q" not in result["yaw_linear"]["parameters"]
    assert result["yaw_linear_quadratic"]["quadratic_significant"] is True


def test_design(result):
    d = result["design"]
    assert d["omega_opt_yaw"] == pytest.approx(0.176, rel=0.02)  # the paper's printed optima
    assert d["omega_opt_surge"] == pytest.approx(0.18, rel=0.02)
    assert d["fisher_check"]["yaw_numeric_over_analytic"] == pytest.approx(1.0, abs=1e-4)
    assert d["surge_experiment"]["command_samples"] > 100
    assert d["surge_experiment"]["omega"] > d["surge_experiment"]["omega_opt"]  # 20 m pool


def test_measured_phase_lags_match_the_identified_models(result):
    """The lag measured in the simulated sine logs (less the 10 Hz command's half-sample delay)
    against atan(ω m̂/k̂_L) of the *identified* inertia and drag (computed here from the
    estimates, not from the paper's numbers); over 16 seeds the mean difference is judged in
    test_procedure_over_sixteen_seeds."""
    d = result["design"]
    wy, ws = 2 * math.pi / 24.0, 2 * math.pi / 26.0
    yaw_i = result["yaw_inertia"]["parameters"]["I"]["estimate"]
    yaw_k = result["yaw_linear"]["parameters"]["k"]["estimate"]
    m = result["surge_mass"]["parameters"]["m"]["estimate"]
    drag = result["surge_mass"]["drag_used"]
    k_l = drag["k"] + 2 * drag["k_q"] * 0.27  # linearised at the paper's ξ* = 0.27 m/s
    pred = {"yaw": math.degrees(math.atan(wy * yaw_i / yaw_k)),
            "surge": math.degrees(math.atan(ws * m / k_l))}
    for dof in ("yaw", "surge"):
        assert d["phase_lag_identified_deg"][dof] == pytest.approx(pred[dof], abs=1e-9)
        lag = d[f"phase_lag_{dof}_measured_deg"] - d["zoh_delay_deg"][dof]
        assert lag == pytest.approx(pred[dof], abs=5.0), dof


@pytest.mark.slow
def test_procedure_over_sixteen_seeds():
    """The procedure judged over seeds 0–15 rather than one chosen seed: σ honest (3σ coverage
    of the truth ≥ 97 % of all estimates, each parameter ≥ 14 of 16), σ of the paper's order
    (≥ 90 % within a factor 3), the low-speed quadratic dropped in ≥ 12 of 16, measured phase
    lags unbiased against the identified models (mean within 1.5°); the pass rate of the
    whole acceptance is reported as it comes out."""
    s = caccia2000.seed_study(range(16))
    assert s["n_seeds"] == 16 and s["estimates"] >= 16 * 38
    assert s["coverage_3sigma"] >= 0.97, s["coverage_3sigma"]
    assert min(s["coverage_by_parameter"].values()) >= 14 / 16, s["coverage_by_parameter"]
    assert s["sigma_within_factor3_of_paper"] >= 0.9
    assert len(s["low_speed_quadratic_kept_seeds"]) <= 4
    for dof, v in s["phase_lag_minus_identified_deg"].items():
        assert abs(v["mean"]) < 1.5, (dof, v)
    assert s["pass_rate"] == len(s["passed_seeds"]) / 16
    assert set(s["failures"]) == {str(k) for k in range(16)} - {str(k) for k in s["passed_seeds"]}


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


@pytest.mark.slow
def test_json_and_determinism(result):
    text = json.dumps(to_jsonable(dict(result)), allow_nan=False)
    assert "surge_mass" in text
    again = caccia2000.reproduce(seed=0, fast=True)
    for table in ("heave", "surge_mass", "yaw_inertia"):
        for name, row in result[table]["parameters"].items():
            assert again[table]["parameters"][name]["estimate"] == row["estimate"]


@pytest.mark.slow
def test_write_outputs(result, tmp_path):
    page = caccia2000.write_outputs(result, tmp_path)
    assert page.name == "index.html" and "Caccia" in page.read_text()
    for f in ("caccia2000_fig5_fig6_heave.png", "caccia2000_drag_fits.png",
              "caccia2000_inertia.png"):
        assert (tmp_path / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((tmp_path / "caccia2000.json").read_text())["seed"] == 0
    with pytest.raises(ValueError, match="artifacts"):
        caccia2000.write_outputs(dict(result), tmp_path)


def test_demo_reports_the_pass_rate_over_seeds_not_one_seed(result, tmp_path, monkeypatch):
    """The demo's Caccia section and its terminal line give the multi-seed pass rate and
    coverage as computed (a stubbed study here: 5 of 16 pass), and in --quick say that one
    seed is not the verdict."""
    from uuvid import demo
    from uuvid.core.html import Report

    study = {"seeds": list(range(16)), "n_seeds": 16, "within_3sigma": 640, "estimates": 656,
             "coverage_3sigma": 640 / 656, "passed_seeds": [0, 3, 6, 9, 12], "pass_rate": 5 / 16,
             "failures": {str(k): ["x.y: 3.5 σ"] for k in range(16) if k % 3},
             "phase_lag_minus_identified_deg": {"yaw": {"mean": 0.3}, "surge": {"mean": -0.3}}}
    monkeypatch.setattr(caccia2000, "reproduce", lambda seed=0, fast=False: result)
    monkeypatch.setattr(caccia2000, "seed_study", lambda *a, **k: study)
    monkeypatch.setattr(type(result), "report", lambda self, out: None)
    rep = Report("t")
    doc = demo._caccia_section(tmp_path, rep)
    html = rep.to_html()
    assert "passes on 5 of 16 seeds (31 %)" in html and "640 of 656" in html
    line = demo.caccia_headline(doc)
    assert "passes on 5 (31 %)" in line and "97.6 % of 656" in line
    quick = demo._caccia_section(tmp_path, Report("q"), quick=True)
    assert "one seed only" in demo.caccia_headline(quick)


@pytest.mark.parametrize("json_out", [False, True])
def test_cli_exits_non_zero_when_the_acceptance_fails(result, monkeypatch, json_out):
    """`uuvid reproduce caccia2000` printed FAILED and exited 0: a script or CI could not tell."""
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    for passed in (True, False):
        doc = caccia2000.Reproduction(dict(result))
        doc["acceptance"] = {**result["acceptance"], "passed": passed,
                             "failures": [] if passed else ["heave.k: |estimate − truth| = 9.00 σ"]}
        monkeypatch.setattr(caccia2000, "reproduce", lambda seed=0, fast=False, out_dir=None, d=doc: d)
        res = CliRunner().invoke(app, ["reproduce", "caccia2000", "--fast"]
                                 + (["--json"] if json_out else []))
        assert res.exit_code == (0 if passed else 1), res.output
        if not passed and not json_out:
            assert "FAILED" in res.stdout and "heave.k" in res.stdout


@pytest.mark.slow  # ≈ 23 fast reproductions (≈ 9 s each on a free machine)
def test_acceptance_fails_a_correct_procedure_at_its_design_rate_and_a_wrong_model_always(monkeypatch):
    """The acceptance is a joint bound at family-wise level ACCEPTANCE_ALPHA (1 %): a correct
    implementation fails it on a seed with probability ≤ 1 %, so over 20 consecutive seeds
    (not chosen) three or more failures would happen with probability ≈ 0.1 % — the old rule
    (every one of ~38 parameters within 3σ, every σ within a factor 3, the 5 % quadratic test)
    failed 9 of 20.  A simulation whose drag is 1.5× the truth the estimates are judged against
    must fail on every seed."""
    assert caccia2000.ACCEPTANCE_ALPHA <= 0.01
    study = caccia2000.seed_study(range(20))
    assert len(study["passed_seeds"]) >= 18, study["failures"]

    real = caccia2000._params_for

    def heavier_drag(base, dof, k, k_q, **kw):
        return real(base, dof, 1.5 * k, 1.5 * k_q, **kw)

    monkeypatch.setattr(caccia2000, "_params_for", heavier_drag)
    for seed in range(3):
        acc = caccia2000.reproduce(seed=seed, fast=True)["acceptance"]
        assert not acc["passed"], seed
        assert any("k_q" in f for f in acc["failures"]), acc["failures"]
