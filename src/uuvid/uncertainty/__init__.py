"""Uncertainty and scale: sweeps, Monte Carlo propagation and bootstrap, run in-process, over local
processes or on a Dask cluster.

* :mod:`~uuvid.uncertainty.sweep` — sweep files (grid / list / random over named parameters of a
  thruster chain or a vehicle) → tidy table + heat maps / line plots (:func:`run_sweep`).
* :mod:`~uuvid.uncertainty.montecarlo` — draws from an identified model's covariance with bounds
  (reject / truncate / ignore, reported) → prediction bands and requirement probabilities
  (:func:`run_montecarlo`); built-in models ``bluerov2-identified`` and ``t200-physical``.
* :mod:`~uuvid.uncertainty.bootstrap` — residual / wild / pairs (segment) / block bootstrap of the
  identification procedures against their LS standard errors.
* :mod:`~uuvid.uncertainty.execute` — chunked execution (``inprocess``, ``processes``, ``dask``),
  retries, failure reports, atomic partial results (:func:`run_study`, :func:`read_result`).
* :mod:`~uuvid.uncertainty.targets` / :mod:`~uuvid.uncertainty.params` — what a run simulates and
  how parameter names map onto chains and vehicles.
* :mod:`~uuvid.uncertainty.identified` — how the built-in identified models were made.
"""

from __future__ import annotations

_EXPORTS = {
    "run_sweep": "sweep", "load_sweep": "sweep", "SweepSpec": "sweep", "SweepStudy": "sweep",
    "run_montecarlo": "montecarlo", "load_model": "montecarlo", "UncertainModel": "montecarlo",
    "MonteCarloSpec": "montecarlo", "MonteCarloStudy": "montecarlo",
    "run_study": "execute", "read_result": "execute", "StudyResult": "execute",
    "bootstrap_linear": "bootstrap", "bootstrap_drag": "bootstrap",
    "bootstrap_inertia": "bootstrap", "bootstrap_steady": "bootstrap",
    "bootstrap_physical": "bootstrap", "comparison_table": "bootstrap",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    mod = _EXPORTS.get(name)
    if mod is None:
        raise AttributeError(f"module 'uuvid.uncertainty' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(f"uuvid.uncertainty.{mod}"), name)
