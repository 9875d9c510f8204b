"""Bootstrap of the identification procedures against their LS standard errors."""

import math

import numpy as np
import pytest

from uuvid.identify.fit import linear_lsq
from uuvid.identify.vehicle.fit import SteadyPoint, fit_inertia, simulate_one_dof
from uuvid.uncertainty import bootstrap as B
from uuvid.vehicle.model import OneDofModel, steady_speed


def quad_data(n=300, hetero=False, seed=1):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, n)
    H = np.column_stack([np.ones(n), x, x**2])
    sd = 0.02 + 0.3 * np.abs(x) ** 2 if hetero else 0.1
    y = H @ [1.0, 2.0, -0.5] + sd * rng.standard_normal(n)
    return H, y


def test_residual_bootstrap_confirms_classical_sigma():
    H, y = quad_data()
    r = B.bootstrap_linear(H, y, ["a", "b", "c"], n_boot=800, kind="residual", seed=2)
    assert r.n_boot == 800 and r.n_failed == 0
    assert np.all(np.abs(r.ratio - 1) < 0.12), r.ratio
    t = r.table()
    assert list(t.columns[:5]) == ["parameter", "estimate", "ls_sigma", "bootstrap_sigma",
                                   "ratio_boot_to_ls"]
    assert np.allclose(t["estimate"], [1.0, 2.0, -0.5], atol=0.05)
    fit = linear_lsq(H, y, ["a", "b", "c"], emit_warnings=False)
    assert np.allclose(t["ls_sigma"], [p.stderr for p in fit.parameters])


def test_heteroscedastic_errors_wild_and_pairs_disagree_with_classical_agree_with_hc3():
    H, y = quad_data(hetero=True, n=400)
    classical = B.bootstrap_linear(H, y, ["a", "b", "c"], n_boot=600, kind="pairs", seed=3)
    assert classical.ratio[2] > 1.3  # the classical σ of the x² term is too small
    hc3 = B.bootstrap_linear(H, y, ["a", "b", "c"], n_boot=600, kind="wild", seed=3,
                             cov_type="HC3")
    assert np.all(np.abs(hc3.ratio - 1) < 0.2), hc3.ratio
    assert hc3.ls_label == "LS σ (HC3)"


def test_block_bootstrap_of_autocorrelated_errors():
    rng = np.random.default_rng(4)
    n = 600
    t = np.linspace(0, 1, n)
    e = np.zeros(n)
    for i in range(1, n):  # AR(1), ρ = 0.95
        e[i] = 0.95 * e[i - 1] + 0.05 * rng.standard_normal()
    H = np.column_stack([np.ones(n), t])
    y = H @ [0.5, 1.0] + e
    white = B.bootstrap_linear(H, y, ["c", "s"], n_boot=400, kind="residual", seed=1)
    block = B.bootstrap_linear(H, y, ["c", "s"], n_boot=400, kind="block", block=60, seed=1)
    assert np.all(np.abs(white.ratio - 1) < 0.15)  # white resampling cannot see the correlation
    assert np.all(block.ratio > 2.0)  # blocks do: the classical σ is far too small


def drag_points(seed=0, n_levels=10):
    rng = np.random.default_rng(seed)
    pts = []
    for f in np.linspace(8, 100, n_levels):
        for s in (1, -1):
            delivered = s * f * (1 + 0.03 * rng.standard_normal()) + 0.5 * rng.standard_normal()
            xi = steady_speed(4.03, 18.18, delivered) + 0.01 * rng.standard_normal()
            pts.append(SteadyPoint(float(xi), float(s * f), None))
    return pts


@pytest.mark.slow
def test_drag_fit_segment_and_residual_bootstrap():
    pts = drag_points()
    seg = B.bootstrap_drag(pts, n_boot=300, kind="segment", seed=1, dof="surge")
    res = B.bootstrap_drag(pts, n_boot=300, kind="residual", seed=1, dof="surge")
    assert seg.names == ["k", "k_q", "w"] == res.names
    assert np.all((seg.ratio > 0.6) & (seg.ratio < 1.5)), seg.ratio
    assert np.all(np.abs(res.ratio - 1) < 0.2), res.ratio
    assert "fit_drag surge" in seg.summary()


def test_drag_segment_bootstrap_keeps_every_coefficient_in_each_resample():
    pts = drag_points(n_levels=5)
    pts += [SteadyPoint(p.velocity * 0.8, p.force, "eta_hull") for p in drag_points(seed=3, n_levels=5)]
    r = B.bootstrap_drag(pts, n_boot=100, kind="segment", seed=0)
    assert "eta_hull" in r.names and r.n_boot + r.n_failed == 100
    with pytest.raises(ValueError, match="open-water points only"):
        B.bootstrap_drag(pts, n_boot=5, kind="residual")


def test_inertia_block_bootstrap_smoke():
    rng = np.random.default_rng(0)
    model = OneDofModel(17.0, 4.03, 18.18)
    t = np.arange(0, 80, 0.01)
    phi = 20 + 10 * np.sin(2 * math.pi * t / 10)
    xi = simulate_one_dof(model, t, phi, xi0=float(model.steady_speed(20.0)), hold="linear")
    x = np.concatenate([[0.0], np.cumsum(0.5 * (xi[1:] + xi[:-1]) * np.diff(t))])
    ts, xs = t[::10], x[::10] + 0.01 * rng.standard_normal(t[::10].size)
    f = fit_inertia(ts, xs, phi, t_phi=t, k=4.03, k_q=18.18, hold="linear", clean=False)
    r = B.bootstrap_inertia(f, n_boot=200, seed=0)
    assert r.names == ["m", "c", "b"] and r.kind == "block"
    assert r.estimate[0] == pytest.approx(f.mass)
    assert np.isfinite(r.boot_sigma).all() and r.boot_sigma[0] > 0


@pytest.mark.slow
@pytest.mark.realdata
def test_t200_quadratic_fit_bootstrap(shared_data):
    from uuvid.io.bench import read_t200

    d = read_t200(shared_data / "t200-bluerobotics-2019" / "T200_16V.csv")
    res = B.bootstrap_steady(d, n_boot=300, kind="residual", seed=0)
    pairs = B.bootstrap_steady(d, n_boot=300, kind="pairs", seed=0)
    assert res.names == ["forward.K_T_fwd", "reverse.K_T_rev"]
    assert np.all(np.abs(res.ratio - 1) < 0.2)
    assert np.all(pairs.ratio > 0.8)  # the misfit of the quadratic law shows up in pairs
    tab = B.comparison_table([res, pairs])
    assert len(tab) == 4 and set(tab["kind"]) == {"residual", "pairs"}


@pytest.mark.slow
@pytest.mark.realdata
def test_physical_fit_bootstrap_runs(shared_data):
    from uuvid.io.bench import read_t200

    d = shared_data / "t200-bluerobotics-2019"
    sheets = [read_t200(d / "T200_12V.csv"), read_t200(d / "T200_16V.csv")]
    r = B.bootstrap_physical(sheets, n_boot=3, seed=0, progress=False)
    assert r.n_boot + r.n_failed == 3 and "K_T_fwd" in r.names
