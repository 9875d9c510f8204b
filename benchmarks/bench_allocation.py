"""Allocation benchmark: the compiled bounded allocation per call against scipy's ``lsq_linear``.

Cases per vehicle (BlueROV2: 6 thrusters; BlueROV2 Heavy: 8): wrenches inside the limits (the
common case in a mission: one matrix product and a check), wrenches needing the active set
(achievable but not by the unconstrained solution, or not achievable at all: weighted least
error).  Our time is per call from a compiled loop over the wrenches; the reference solves the
same weighted bounded least squares with ``scipy.optimize.lsq_linear`` (BVLS), in-process.
"""

from __future__ import annotations

import json
import time

import numpy as np
from numba import njit
from scipy.optimize import lsq_linear

from uuvid.vehicle.allocation import allocate_compiled
from uuvid.vehicle.definition import load_vehicle


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


def _case(vehicle: str, kind: str, count: int = 20000, ref_count: int = 300) -> dict:
    al = load_vehicle(vehicle).allocator()
    rng = np.random.default_rng(0)
    PHI = (_wrenches(al, rng, count, 0.05, 0.5, True) if kind == "inside limits"
           else _wrenches(al, rng, count, 0.3, 2.5, False))
    a = al.to_array("priority")
    out = np.empty((count, al.n))
    _loop(a, PHI[:10], out)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        _loop(a, PHI, out)
        best = min(best, time.perf_counter() - t0)
    ours = best / count
    ctl = list(al.controlled)
    sq = np.sqrt(al.priority[ctl])
    A = sq[:, None] * al.B[ctl]
    lo, hi = al.limits[:, 0], al.limits[:, 1]
    t0 = time.perf_counter()
    for phi in PHI[:ref_count]:
        lsq_linear(A, sq * phi[ctl], bounds=(lo, hi), method="bvls")
    ref = (time.perf_counter() - t0) / ref_count
    return {"case": f"{vehicle}_{kind.replace(' ', '_')}", "thrusters": al.n, "calls": count,
            "time_per_call_us": ours * 1e6, "reference": "scipy.optimize.lsq_linear (bvls)",
            "reference_time_per_call_us": ref * 1e6, "ratio": ref / ours}


def run_all() -> dict:
    return {"allocation": [_case(v, k) for v in ("bluerov2", "bluerov2-heavy")
                           for k in ("inside limits", "active set")]}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2))
