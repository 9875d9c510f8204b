"""Allocation benchmark: the compiled bounded allocation per call against the best plain alternative.

Cases per vehicle (BlueROV2: 6 thrusters; BlueROV2 Heavy: 8): wrenches inside the limits (the
common case in a mission: one matrix product and a check), wrenches needing the active set
(achievable but not by the unconstrained solution, or not achievable at all: weighted least
error).  Our time is per call from a compiled loop over the wrenches.  The reference inside the
limits is what suffices there — a compiled mat-vec ``T φ`` with the limit check; for the active
set it solves the same weighted bounded least squares with ``scipy.optimize.lsq_linear`` (BVLS).
Both over the same wrenches (no subset scaled up), interleaved pairs, medians with min–max.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from numba import njit
from scipy.optimize import lsq_linear

from uuvid.vehicle.allocation import allocate_compiled
from uuvid.vehicle.definition import load_vehicle

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:  # the sibling module, also when loaded by file (uuvid bench)
    sys.path.insert(0, _HERE)
from _timing import interleaved  # noqa: E402


@njit(cache=True)
def _loop(a, PHI, out):
    tau = np.empty(out.shape[1])
    acc = 0.0
    for k in range(PHI.shape[0]):
        acc += allocate_compiled(a, PHI[k], tau)
        for i in range(tau.size):
            out[k, i] = tau[i]
    return acc


def _wrenches(al, rng, count, lo_gain, hi_gain, inside):
    ctl = list(al.controlled)
    a = al.to_array("scale")
    lim = float(np.abs(al.limits).max())
    out = []
    tau = np.empty(al.n)
    while len(out) < count:
        phi = np.zeros(6)
        phi[ctl] = rng.normal(size=len(ctl)) * lim * rng.uniform(lo_gain, hi_gain)
        s = allocate_compiled(a, phi, tau)
        if (s == 1.0) == inside:
            out.append(phi)
    return np.array(out)


@njit
def _matvec_loop(T, lo, hi, PHI, out):
    """The reference inside the limits: ``f = T φ`` and the check that it is within them (what
    a hand-written allocator does when nothing saturates), compiled, over the same wrenches."""
    n, m = T.shape
    ok = 0
    for k in range(PHI.shape[0]):
        inside = True
        for i in range(n):
            t = 0.0
            for j in range(m):
                t += T[i, j] * PHI[k, j]
            out[k, i] = t
            inside = inside and lo[i] <= t <= hi[i]
        ok += inside
    return ok


def _case(vehicle: str, kind: str) -> dict:
    al = load_vehicle(vehicle).allocator()
    rng = np.random.default_rng(0)
    inside = kind == "inside limits"
    count = 100000 if inside else 500  # the same wrenches for ours and the reference
    PHI = (_wrenches(al, rng, count, 0.05, 0.5, True) if inside
           else _wrenches(al, rng, count, 0.3, 2.5, False))
    a = al.to_array("priority")
    out = np.empty((count, al.n))
    ref_out = np.empty((count, al.n))
    lo, hi = al.limits[:, 0].copy(), al.limits[:, 1].copy()
    ctl = list(al.controlled)
    if inside:
        T = np.ascontiguousarray(a[3:3 + al.n * 6].reshape(al.n, 6))

        def reference():
            _matvec_loop(T, lo, hi, PHI, ref_out)
        label = "compiled mat-vec f = T φ with the limit check (numba loop, same wrenches)"
    else:
        sq = np.sqrt(al.priority[ctl])
        A = sq[:, None] * al.B[ctl]

        def reference():
            for k, phi in enumerate(PHI):
                ref_out[k] = lsq_linear(A, sq * phi[ctl], bounds=(lo, hi), method="bvls").x
        label = "scipy.optimize.lsq_linear (bvls) per wrench, same wrenches"

    def ours():
        _loop(a, PHI, out)

    t = interleaved(ours, reference, repeats=9, budget_s=20.0)
    if inside:
        assert np.allclose(out, ref_out, rtol=1e-12, atol=1e-12)
    return {"case": f"{vehicle}_{kind.replace(' ', '_')}", "thrusters": al.n, "calls": count,
            "time_per_call_us": t["time_s"] / count * 1e6, "reference": label,
            "reference_time_per_call_us": t["reference_time_s"] / count * 1e6, **t}


def run_all() -> dict:
    return {"allocation": [_case(v, k) for v in ("bluerov2", "bluerov2-heavy")
                           for k in ("inside limits", "active set")]}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2))
