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
    of the per-pair ratio ``reference / ours`` (> 1: ours faster) and ``ours / reference``, in
    wall time and in the process's CPU time (``cpu_*``, all its threads: what the wall time is
    on an idle machine for single-threaded code; on shared, busy cores the steadier figure)."""
    for _ in range(warmup):
        ours()
        reference()
    wall = {ours: [], reference: []}
    cpu = {ours: [], reference: []}
    start = time.perf_counter()
    for k in range(repeats):
        for fn in ((ours, reference) if k % 2 == 0 else (reference, ours)):
            c0 = time.process_time()
            t0 = time.perf_counter()
            fn()
            wall[fn].append(time.perf_counter() - t0)
            cpu[fn].append(time.process_time() - c0)
        if k >= 2 and time.perf_counter() - start > budget_s:
            break
    t_ours, t_ref = np.array(wall[ours]), np.array(wall[reference])
    c_ours, c_ref = np.array(cpu[ours]), np.array(cpu[reference])
    r = _stats(t_ref / t_ours)
    s = _stats(t_ours / t_ref)
    cs = _stats(c_ours / c_ref)
    return {"pairs": int(t_ours.size), "time_s": float(np.median(t_ours)),
            "time_s_min_max": [float(t_ours.min()), float(t_ours.max())],
            "reference_time_s": float(np.median(t_ref)),
            "reference_time_s_min_max": [float(t_ref.min()), float(t_ref.max())],
            "ratio": r["median"], "ratio_min_max": [r["min"], r["max"]],
            "ours_over_reference": s["median"], "ours_over_reference_min_max": [s["min"], s["max"]],
            "cpu_time_s": float(np.median(c_ours)), "reference_cpu_time_s": float(np.median(c_ref)),
            "cpu_ours_over_reference": cs["median"],
            "cpu_ours_over_reference_min_max": [cs["min"], cs["max"]]}
