"""Dead zone and saturation of a steady command → thrust map (Laidani et al., Fig. 5).

Laidani et al. report a dead zone of ≈50 µs around neutral and saturation above 1800 µs.  Here both
are read off a steady map: the dead zone is the contiguous run of commands around neutral whose
thrust magnitude stays below ``tol``; saturation starts where the thrust stops changing (within
``tol`` of its extreme) for every larger command magnitude.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Regions:
    """Operating regions of a thruster map (command units)."""

    dead_zone: tuple[float, float]
    saturation: tuple[float | None, float | None]  # (reverse onset, forward onset)

    def as_dict(self) -> dict:
        return {"dead_zone": list(self.dead_zone), "saturation": list(self.saturation)}


def detect_regions(command, thrust, neutral: float, tol: float | None = None) -> Regions:
    """Dead zone ``[low, high]`` and saturation onsets from a sampled steady map.

    ``command`` must be strictly increasing and contain ``neutral``'s neighbourhood; ``tol`` defaults
    to 1e-6 of the largest thrust magnitude.
    """
    c = np.asarray(command, dtype=float)
    f = np.asarray(thrust, dtype=float)
    if c.ndim != 1 or c.shape != f.shape or c.size < 3:
        raise ValueError("command and thrust must be 1-D arrays of the same length (>= 3)")
    if np.any(np.diff(c) <= 0):
        i = int(np.flatnonzero(np.diff(c) <= 0)[0]) + 1
        raise ValueError(f"command must be strictly increasing; sample {i} ({c[i]:g}) is not")
    if not np.all(np.isfinite(f)):
        raise ValueError(f"thrust sample {int(np.flatnonzero(~np.isfinite(f))[0])} is not finite")
    scale = float(np.max(np.abs(f)))
    tol = 1e-6 * scale if tol is None else tol
    k0 = int(np.argmin(np.abs(c - neutral)))
    if abs(f[k0]) > tol:
        dz = (float(c[k0]), float(c[k0]))
    else:
        lo = k0
        while lo > 0 and abs(f[lo - 1]) <= tol:
            lo -= 1
        hi = k0
        while hi < c.size - 1 and abs(f[hi + 1]) <= tol:
            hi += 1
        dz = (float(c[lo]), float(c[hi]))

    def onset(idx):
        # first index (walking outward) after which the thrust stays within tol of its end value
        seg = f[idx]
        end = seg[-1]
        flat = np.abs(seg - end) <= max(tol, 1e-9 * scale)
        if not flat[-1] or flat.all() and seg.size == 1:
            return None
        k = seg.size - 1
        while k > 0 and flat[k - 1]:
            k -= 1
        return float(c[idx[k]]) if k > 0 else None

    fwd = np.arange(k0, c.size)
    rev = np.arange(k0, -1, -1)
    sat_hi = onset(fwd) if fwd.size > 2 else None
    sat_lo = onset(rev) if rev.size > 2 else None
    return Regions(dead_zone=dz, saturation=(sat_lo, sat_hi))
