"""Inflow coefficients from bench runs in a flow (issue 21, item 3).

The data are made by the project's own inflow models with known coefficients plus Gaussian
thrust noise: the linear Healey form (``uuvid.thruster.inflow.linear_healey_forces`` of a
``HealeyThruster``, with the carriage speed as the flow through the propeller) and a four-quadrant
map (``FourQuadrantMap.thrust_torque``).  Both fits are linear least squares (no optimiser start,
so none at the truth).  Recovery is judged over 20 consecutive seeds (no seed picking): at least
90 % of the estimates lie within 3σ of the truth for every coefficient.
"""

import json

import numpy as np
import pytest

from uuvid.identify.thruster.inflow import (
    BOLLARD_ONLY,
    MIN_FLOW_LEVELS,
    fit_four_quadrant,
    fit_inflow_linear,
    model_thrust,
)
from uuvid.identify.thruster.workflow import FitError, ReadOptions, run_fit
from uuvid.io.bench import BenchData, BenchDataError, read_bench
from uuvid.thruster.blocks import HealeyThruster
from uuvid.thruster.inflow import FourQuadrantMap, linear_healey_forces

SEEDS = range(20)
NOISE_N = 0.25  # thrust noise σ, N
#: T200-like truth: k_t of the preset, k_a = k_t / (0.7 R p) at D = 76 mm, P/D = 1 (inflow.py)
TRUE = HealeyThruster(thrust_coefficient=3.668e-4, thrust_coefficient_rev=2.9e-4,
                      inflow_coefficient=0.0323)
SPEEDS = np.array([120.0, 170.0, 220.0, 270.0, 320.0])  # |Ω|, rad/s
FLOWS = np.array([0.0, 0.2, 0.4, 0.6, 0.8])  # m/s


def _design(reverse=True, flows=FLOWS, repeats=3):
    w = np.concatenate([SPEEDS, -SPEEDS]) if reverse else SPEEDS
    W, U = np.meshgrid(w, flows, indexing="ij")
    W = np.repeat(W.ravel(), repeats)
    U = np.repeat(U.ravel(), repeats)
    cmd = 1500.0 + W / 0.8  # a monotone command per speed level (µs)
    return cmd, W, U


def _linear_bench(seed, block=TRUE, **kw):
    cmd, w, u = _design(**kw)
    thrust = linear_healey_forces(block, w, u)[0]
    thrust = thrust + np.random.default_rng(seed).normal(0.0, NOISE_N, thrust.size)
    return BenchData(command=cmd, thrust=thrust, speed=w, flow_speed=u, source=f"seed{seed}.csv")


def _inside(est, sig, truth, z=3.0):
    return abs(est - truth) <= z * sig


# ------------------------------------------------------------------ linear (Healey) form
def test_linear_form_recovers_kt_and_ka_within_3_sigma_over_seeds():
    truth = {"K_T_fwd": TRUE.thrust_coefficient, "K_T_rev": TRUE.thrust_coefficient_rev,
             "k_a": TRUE.inflow_coefficient}
    hits = {k: 0 for k in truth}
    for seed in SEEDS:
        f = fit_inflow_linear(_linear_bench(seed)).fits["inflow"]
        for k, v in truth.items():
            hits[k] += _inside(f[k].value, f[k].stderr, v)
            assert f[k].stderr < 0.05 * abs(v)  # well determined, not a vacuous 3σ
    for k in truth:
        assert hits[k] / len(SEEDS) >= 0.9, (k, hits[k])


def test_linear_form_residuals_are_the_noise_and_correlation_is_reported():
    """The model through the fitted coefficients leaves only the noise: the u_a term dropped (in
    the regressors or in the model thrust) leaves residuals of several newtons."""
    sf = fit_inflow_linear(_linear_bench(1))
    f = sf.fits["inflow"]
    d = _linear_bench(1)
    r = d.thrust - model_thrust(sf, d.speed, d.flow_speed)
    assert np.sqrt(np.mean(r ** 2)) == pytest.approx(NOISE_N, rel=0.2)
    np.testing.assert_allclose(r, f.residuals, atol=1e-9)
    c = f.correlation
    assert c.shape == (3, 3) and np.allclose(np.diag(c), 1.0)
    assert f.names == ["K_T_fwd", "K_T_rev", "k_a"]
    assert sf.block.k_pos == pytest.approx(f["K_T_fwd"].value)  # the bollard map: u_a = 0


def test_forward_only_bench_fits_one_kt():
    sf = fit_inflow_linear(_linear_bench(2, reverse=False))
    assert sf.fits["inflow"].names == ["K_T_fwd", "k_a"]


# ------------------------------------------------------------------ four-quadrant map
FQ_TRUE = FourQuadrantMap("truth", 0.076, (0.30, 0.12), (0.0, -0.55), (0.05, 0.0), (0.0, 0.0))


def _fq_bench(seed):
    cmd, w, u = _design(reverse=False, flows=np.array([0.0, 0.3, 0.6, 0.9, 1.2, 1.5]))
    thrust = FQ_TRUE.thrust_torque(w / (2 * np.pi), u)[0]
    thrust = thrust + np.random.default_rng(seed).normal(0.0, NOISE_N, thrust.size)
    return BenchData(command=cmd, thrust=thrust, speed=w, flow_speed=u, source=f"fq{seed}.csv")


def test_four_quadrant_recovers_ct_fourier_coefficients_within_3_sigma_over_seeds():
    truth = {"a_0": 0.30, "a_1": 0.12, "b_1": -0.55}
    hits = {k: 0 for k in truth}
    for seed in SEEDS:
        sf = fit_four_quadrant(_fq_bench(seed), 0.076, order=1)
        f = sf.fits["four-quadrant"]
        for k, v in truth.items():
            hits[k] += _inside(f[k].value, f[k].stderr, v)
    for k in truth:
        assert hits[k] / len(SEEDS) >= 0.9, (k, hits[k])
    lo, hi = sf.info["beta_range_deg"]
    assert lo == 0.0 and 5.0 < hi < 60.0
    # the map's bollard K_T is the chain's map: T = K_T ρ n² D⁴ = k Ω|Ω|
    k = sf.info["map"].bollard_kt(1) * 1000.0 * 0.076 ** 4 / (2 * np.pi) ** 2
    assert sf.block.k_pos == pytest.approx(k)


# ------------------------------------------------------------------ files, CLI, messages
def _write(path, d: BenchData, flow=True, thrust=None):
    cols = {"command": d.command, "speed": d.speed,
            "thrust": d.thrust if thrust is None else thrust}
    if flow:
        cols["flow_speed"] = d.flow_speed
    lines = [",".join(cols)] + [",".join(repr(float(v)) if not isinstance(v, str) else v
                                         for v in row) for row in zip(*cols.values())]
    path.write_text("\n".join(lines) + "\n")
    return path


OPTS = ReadOptions(thrust_col="thrust", speed_col="speed")


@pytest.mark.slow
def test_workflow_fits_inflow_with_plot_and_summary(tmp_path):
    f = _write(tmp_path / "flow.csv", _linear_bench(4))
    out = run_fit([f], "quadratic", OPTS)
    p = out.parameters()
    assert set(p) == {"K_T_fwd", "K_T_rev", "k_a"}
    assert p["k_a"]["estimate"] == pytest.approx(TRUE.inflow_coefficient, rel=0.1)
    doc = out.to_dict()
    assert doc["inflow"]["flow_levels_m_s"] == pytest.approx(list(FLOWS))
    assert len(doc["inflow"]["correlation"]["matrix"]) == 3
    assert out.rmse == pytest.approx(NOISE_N, rel=0.25)
    fig = out.plot()
    ax = fig.axes[0]
    assert "[N]" in ax.get_ylabel()
    assert all("water speed u_a [m/s]" == a.get_xlabel() for a in fig.axes[2:])  # residual row
    assert len(ax.lines) == 2 * len(SPEEDS)  # data and model per command (forward panel)
    out.report(tmp_path / "rep")
    assert (tmp_path / "rep" / "fit.png").exists()


@pytest.mark.parametrize("suffix", [".yaml", ".toml"])
def test_the_fitted_inflow_coefficients_are_written_to_the_model_file(tmp_path, suffix):
    """The model file's blocks are the bollard map; its ``inflow`` section keeps what the flow
    identified — k_a with its σ and unit, the flow levels — and reads back as the chain's
    ``inflow`` (YAML and TOML), which takes no part in the dynamics or the chain's equality."""
    from uuvid.thruster.modelfile import load_chain, save_chain

    out = run_fit([_write(tmp_path / "flow.csv", _linear_bench(4))], "quadratic", OPTS)
    sec = out.chain.inflow
    assert sec["form"] == "linear" and "flow.csv" in sec["source"]
    ka = out.parameters()["k_a"]
    assert sec["parameters"]["k_a"]["estimate"] == ka["estimate"]
    assert sec["parameters"]["k_a"]["sigma"] == ka["sigma"] > 0
    back = load_chain(save_chain(out.chain, tmp_path / f"m{suffix}"))
    assert back.inflow["parameters"]["k_a"]["estimate"] == pytest.approx(ka["estimate"],
                                                                        rel=1e-12)
    assert back.inflow["parameters"]["k_a"]["unit"] == sec["parameters"]["k_a"]["unit"]
    assert back.inflow["flow_levels_m_s"] == pytest.approx(list(FLOWS))
    assert back == out.chain  # metadata: equal chains with or without it
    assert any("'inflow' section" in n for n in out.notes)
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    shown = CliRunner().invoke(app, ["thruster", "show", str(tmp_path / f"m{suffix}")])
    assert shown.exit_code == 0 and "inflow (linear" in shown.output and "k_a = " in shown.output


def test_a_bad_inflow_section_names_the_key(tmp_path):
    import yaml

    from uuvid.thruster.modelfile import ModelFileError, chain_to_dict, load_chain

    out = run_fit([_write(tmp_path / "flow.csv", _linear_bench(4))], "quadratic", OPTS)
    doc = chain_to_dict(out.chain)
    doc["inflow"]["form"] = "momentum"
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ModelFileError, match=r"bad\.yaml: inflow\.form"):
        load_chain(tmp_path / "bad.yaml")
    doc["inflow"]["form"] = "linear"
    doc["inflow"]["parameters"]["k_a"]["estimate"] = "fast"
    (tmp_path / "bad2.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ModelFileError, match=r"inflow\.parameters\.k_a\.estimate"):
        load_chain(tmp_path / "bad2.yaml")


@pytest.mark.slow
def test_four_quadrant_model_through_the_workflow_and_cli(tmp_path):
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    f = _write(tmp_path / "fq.csv", _fq_bench(5))
    res = CliRunner().invoke(app, ["thruster", "fit", str(f), "--model", "four-quadrant",
                                   "--diameter", "0.076", "--speed-col", "speed", "--thrust-col",
                                   "thrust", "--out-model", str(tmp_path / "m.yaml"), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout[res.stdout.index("{"):])
    assert doc["parameters"]["b_1"]["estimate"] == pytest.approx(-0.55, abs=0.05)
    from uuvid.thruster.modelfile import load_chain

    sec = load_chain(tmp_path / "m.yaml").inflow  # the fitted C_T* terms are in the file
    assert sec["form"] == "four-quadrant" and sec["beta_range_deg"]
    assert sec["parameters"]["b_1"]["estimate"] == pytest.approx(
        doc["parameters"]["b_1"]["estimate"], rel=1e-12)
    with pytest.raises(FitError, match="--diameter"):
        run_fit([f], "four-quadrant", OPTS)


def test_without_a_flow_column_nothing_changes(tmp_path):
    d = _linear_bench(6)
    still = BenchData(command=d.command, thrust=linear_healey_forces(TRUE, d.speed, 0 * d.speed)[0],
                      speed=d.speed, source="still.csv")
    a = run_fit([_write(tmp_path / "a.csv", still, flow=False)], "quadratic", OPTS)
    assert set(a.parameters()) == {"K_T_fwd", "K_T_rev"}
    assert "inflow" not in a.to_dict() and not any("bollard" in w for w in a.warnings)


def test_bollard_bench_warns_that_ka_is_not_identifiable(tmp_path):
    d = _linear_bench(7)
    zero = BenchData(command=d.command, thrust=d.thrust, speed=d.speed, flow_speed=0 * d.speed)
    out = run_fit([_write(tmp_path / "bollard.csv", zero)], "quadratic", OPTS)
    assert BOLLARD_ONLY in out.warnings
    assert "k_a" not in out.parameters()  # no silent value


def test_too_few_flow_levels_is_an_error_naming_file_and_column(tmp_path):
    d = _linear_bench(8, flows=np.array([0.0, 0.5]))
    with pytest.raises(BenchDataError, match=r"two\.csv: column 'flow_speed': 2 distinct"):
        run_fit([_write(tmp_path / "two.csv", d)], "quadratic", OPTS)
    assert MIN_FLOW_LEVELS == 3


def test_nan_in_flow_speed_names_file_column_and_row(tmp_path):
    f = _write(tmp_path / "nan.csv", _linear_bench(9))
    lines = f.read_text().splitlines()
    cells = lines[5].split(",")
    cells[-1] = "nan"
    lines[5] = ",".join(cells)
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(BenchDataError,
                       match=r"nan\.csv: column 'flow_speed', data row 5 \(CSV line 6\): NaN"):
        read_bench(f, command_col="command", thrust_col="thrust", speed_col="speed")


def test_thrust_against_the_command_in_still_water_names_the_row(tmp_path):
    d = _linear_bench(10)
    t = d.thrust.copy()
    i = int(np.flatnonzero((d.speed > 0) & (d.flow_speed == 0))[2])
    t[i] = -5.0  # forward propeller, water at rest, pulling backwards
    f = _write(tmp_path / "neg.csv", d, thrust=t)
    with pytest.raises(BenchDataError, match=rf"neg\.csv: column 'thrust', data row {i + 1} "
                                             rf"\(CSV line {i + 2}\): thrust -5 N"):
        read_bench(f, command_col="command", thrust_col="thrust", speed_col="speed")


@pytest.mark.slow
def test_models_that_ignore_the_water_speed_refuse_runs_in_a_flow(tmp_path):
    f = _write(tmp_path / "flow.csv", _linear_bench(11))
    with pytest.raises(FitError, match=r"flow\.csv: column 'flow_speed'.*--model polynomial"):
        run_fit([f], "polynomial", OPTS)
    # the column can be left unread on purpose
    out = run_fit([f], "polynomial", ReadOptions(thrust_col="thrust", speed_col="speed",
                                                 flow_speed_col=None))
    assert out.model == "polynomial"


def test_four_quadrant_default_order_follows_the_directions_in_the_data():
    """Ahead and astern (β near 0 and near π) take order 2 by default and fit to the noise."""
    truth = FourQuadrantMap("both", 0.076, (0.05, 0.30, -0.05), (0.0, -0.55, 0.10), (0.05,) * 3,
                            (0.0,) * 3)
    cmd, w, u = _design(reverse=True, flows=np.array([0.0, 0.3, 0.6, 0.9]))
    t = truth.thrust_torque(w / (2 * np.pi), u)[0] + np.random.default_rng(3).normal(0, NOISE_N,
                                                                                     w.size)
    sf = fit_four_quadrant(BenchData(command=cmd, thrust=t, speed=w, flow_speed=u), 0.076)
    f = sf.fits["four-quadrant"]
    assert f.names == ["a_0", "a_1", "a_2", "b_1", "b_2"]
    assert f.rmse == pytest.approx(NOISE_N, rel=0.25)
    for k, v in zip(f.names, (0.05, 0.30, -0.05, -0.55, 0.10)):
        assert _inside(f[k].value, f[k].stderr, v, z=4.0)


def test_a_reversed_or_mis_scaled_flow_speed_is_said(tmp_path):
    """flow_speed with its sign reversed gave k_a < 0 (thrust rising with the water from ahead)
    and cm/s gave k_a 100× too small, both without a word."""
    d = _linear_bench(11)
    rev = BenchData(command=d.command, thrust=d.thrust, speed=d.speed, flow_speed=-d.flow_speed)
    out = run_fit([_write(tmp_path / "rev.csv", rev)], "quadratic", OPTS)
    assert out.parameters()["k_a"]["estimate"] < 0
    assert any("k_a = -0.03" in w and "sign reversed" in w for w in out.warnings), out.warnings
    ok = run_fit([_write(tmp_path / "ok.csv", d)], "quadratic", OPTS)
    assert not any("sign reversed" in w for w in ok.warnings)
    cms = BenchData(command=d.command, thrust=d.thrust, speed=d.speed, flow_speed=100 * d.flow_speed)
    with pytest.raises(BenchDataError, match=r"cms\.csv: column 'flow_speed' reaches 80 m/s, "
                                             r"beyond 10 m/s .* cm/s"):
        run_fit([_write(tmp_path / "cms.csv", cms)], "quadratic", OPTS)


def _both_ways_bench():
    truth = FourQuadrantMap("both", 0.076, (0.05, 0.30, -0.05), (0.0, -0.55, 0.10), (0.05,) * 3,
                            (0.0,) * 3)
    cmd, w, u = _design(reverse=True, flows=np.array([0.0, 0.3, 0.6, 0.9]))
    t = truth.thrust_torque(w / (2 * np.pi), u)[0] + np.random.default_rng(3).normal(0, NOISE_N,
                                                                                     w.size)
    return BenchData(command=cmd, thrust=t, speed=w, flow_speed=u, source="both.csv")


def test_four_quadrant_refuses_a_diameter_no_propeller_has():
    """--diameter 1e-9 gave a rank-deficient fit with NaN correlations (76 m was refused)."""
    with pytest.raises(BenchDataError, match=r"--diameter 1e-09 m: smaller than any thruster"):
        fit_four_quadrant(_both_ways_bench(), 1e-9)


def test_four_quadrant_order_0_refused_when_the_propeller_turns_both_ways():
    """Order 0 (one constant C_T*) wrote a model with k_pos 0.0 and only a 'not significant'."""
    with pytest.raises(BenchDataError, match=r"both.csv: Fourier order 0 .* turns both ways"):
        fit_four_quadrant(_both_ways_bench(), 0.076, order=0)
    # one way, a constant C_T* is a model
    sf = fit_four_quadrant(_fq_bench(0), 0.076, order=0)
    assert sf.block.k_pos > 0


def test_four_quadrant_without_thrust_the_way_the_propeller_turns_is_no_model():
    """A map whose bollard K_T opposes a direction the data turn was clipped to k = 0 and written."""
    d = _fq_bench(0)
    with pytest.raises(BenchDataError, match=r"gives no forward bollard thrust"):
        fit_four_quadrant(BenchData(command=d.command, thrust=-d.thrust, speed=d.speed,
                                    flow_speed=d.flow_speed, source="neg.csv"), 0.076, order=1)
