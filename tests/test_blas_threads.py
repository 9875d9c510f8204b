"""A fit of a few parameters runs its dense algebra on one BLAS thread.

OpenBLAS's threads spin after each call: on two shared cores the post-fit SVDs and products of a
tall Jacobian (``diagnose``, ``undetermined``, the covariance) took the cores from the residual's
own threads — the demo's thruster-dynamics selection spent 6.9 CPU s where 4.4 do.
"""

import numpy as np
import pytest


def _blas_threads() -> int:
    from threadpoolctl import threadpool_info

    return max((d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"), default=0)


@pytest.fixture
def svd_threads(monkeypatch):
    """The BLAS threads in force at every ``np.linalg.svd`` / ``pinv`` call of the block."""
    seen: list[int] = []
    for name in ("svd", "pinv"):
        real = getattr(np.linalg, name)

        def spy(*a, _real=real, **k):
            seen.append(_blas_threads())
            return _real(*a, **k)

        monkeypatch.setattr(np.linalg, name, spy)
    return seen


def test_nonlinear_fit_statistics_run_on_one_blas_thread(svd_threads):
    import scipy.linalg  # noqa: F401  (its OpenBLAS too)

    if _blas_threads() < 2:
        pytest.skip("BLAS runs one thread here: nothing to limit")
    from uuvid.identify.fit import diagnose, nonlinear_lsq

    t = np.linspace(0.0, 5.0, 4000)
    y = 2.0 * np.exp(-0.7 * t) + 0.01 * np.random.default_rng(1).standard_normal(t.size)
    fit = nonlinear_lsq(lambda th: th[0] * np.exp(-th[1] * t) - y, [1.0, 1.0], ["a", "k"])
    diagnose(["a", "k"], np.array(list(fit.values.values())), fit.covariance, np.column_stack([np.exp(-t), t * np.exp(-t)]),
             emit=False)
    assert svd_threads, "no SVD seen: the test no longer watches the fit's algebra"
    assert max(svd_threads) == 1, svd_threads
    assert _blas_threads() >= 2  # and the limit ends with the block

