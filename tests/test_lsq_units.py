"""A regression's statistics do not depend on the units of its columns.

``linear_lsq`` inverted ``HᵀH`` unscaled: a column in µN·m squared the condition number past the
pseudo-inverse's cut-off, and ``identify steady`` printed σ = 0.0 % and correlations of 1.0019 for
a torque column ×1e6 (its estimates scaled right, their errors did not).
"""

import numpy as np
import pytest

from uuvid.identify.fit import linear_lsq, lsq_classical


def _problem(seed: int, n: int = 200):
    rng = np.random.default_rng(seed)
    H = np.column_stack([rng.normal(size=n), rng.normal(size=n), np.ones(n)])
    y = H @ np.array([2.0, 3.0, -1.0]) + rng.normal(scale=0.1, size=n) * (1 + np.abs(H[:, 0]))
    return H, y


@pytest.mark.parametrize("cov_type", ["classical", "HC0", "HC3", "HAC"])
@pytest.mark.parametrize("seed", range(5))
def test_relative_errors_and_correlations_do_not_depend_on_column_units(seed, cov_type):
    H, y = _problem(seed)
    ref = linear_lsq(H, y, ["a", "b", "c"], cov_type=cov_type, emit_warnings=False)
    rel0 = np.array([p.stderr / abs(p.value) for p in ref.parameters])
    d0 = np.sqrt(np.diag(ref.covariance))
    corr0 = ref.covariance / np.outer(d0, d0)
    for scale in (1e-8, 1e-4, 1e4, 1e8):
        S = np.array([1.0, scale, 1.0])
        f = linear_lsq(H * S, y, ["a", "b", "c"], cov_type=cov_type, emit_warnings=False)
        rel = np.array([p.stderr / abs(p.value) for p in f.parameters])
        np.testing.assert_allclose(rel, rel0, rtol=1e-7, err_msg=f"column b ×{scale:g}")
        d = np.sqrt(np.diag(f.covariance))
        corr = f.covariance / np.outer(d, d)
        np.testing.assert_allclose(corr, corr0, rtol=1e-7, atol=1e-9)
        assert np.all(np.abs(corr) <= 1.0 + 1e-12)
        assert f.parameters[1].value == pytest.approx(ref.parameters[1].value / scale, rel=1e-9)


def test_classical_sigma_matches_the_textbook_formula_and_lsq_classical():
    """On a well-conditioned problem the SVD form equals σ²(HᵀH)⁻¹ and lsq_classical's numbers."""
    H, y = _problem(7)
    f = linear_lsq(H, y, ["a", "b", "c"], emit_warnings=False)
    theta = np.linalg.lstsq(H, y, rcond=None)[0]
    r = y - H @ theta
    cov = (r @ r / (H.shape[0] - 3)) * np.linalg.inv(H.T @ H)
    np.testing.assert_allclose(f.covariance, cov, rtol=1e-10)
    th, sig, _ = lsq_classical(H * [1.0, 1e7, 1.0], y)
    np.testing.assert_allclose(sig * [1.0, 1e7, 1.0], np.sqrt(np.diag(cov)), rtol=1e-7)
