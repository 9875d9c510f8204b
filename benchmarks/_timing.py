"""Fair timing for the benchmarks: interleaved pairs, medians with min–max.

Ours and the reference run alternately in one process (the order flips every pair, so drift in
the machine's load — two shared cores — hits both alike); each pair gives one ratio.  The
report is the median of the times and of the per-pair ratios, with their min–max: never
best-of-N of ours against one reference run, never a reference timed on a subset and scaled.
"""

from __future__ import annotations

import time

import numpy as np


def _stats(x) -> dict:
    x = np.asarray(x, dtype=float)
    return {"median": float(np.median(x)), "min": float(np.min(x)), "max": float(np.max(x))}


def interleaved(ours, reference, repeats: int = 15, budget_s: float = 30.0, warmup: int = 1) -> dict:
    """Time ``ours()`` and ``reference()`` in alternating pairs; stops after ``repeats`` pairs or
    when ``budget_s`` is spent (at least 3 pairs).  Returns medians and min–max of both times and
    of the per-pair ratio ``reference / ours`` (> 1: ours faster) and ``ours / reference``.  A
    function that returns a float has timed itself (e.g. the loop inside a larger call)."""
    for _ in range(warmup):
        ours()
        reference()
    t_ours, t_ref = [], []
    start = time.perf_counter()
    for k in range(repeats):
        pair = (ours, reference) if k % 2 == 0 else (reference, ours)
        got = {}
        for fn in pair:
            t0 = time.perf_counter()
            own = fn()
            got[fn] = own if isinstance(own, float) else time.perf_counter() - t0
        t_ours.append(got[ours])
        t_ref.append(got[reference])
        if k >= 2 and time.perf_counter() - start > budget_s:
            break
    t_ours = np.array(t_ours)
    t_ref = np.array(t_ref)
    r = _stats(t_ref / t_ours)
    s = _stats(t_ours / t_ref)
    return {"pairs": int(t_ours.size), "time_s": float(np.median(t_ours)),
            "time_s_min_max": [float(t_ours.min()), float(t_ours.max())],
            "reference_time_s": float(np.median(t_ref)),
            "reference_time_s_min_max": [float(t_ref.min()), float(t_ref.max())],
            "ratio": r["median"], "ratio_min_max": [r["min"], r["max"]],
            "ours_over_reference": s["median"], "ours_over_reference_min_max": [s["min"], s["max"]]}
