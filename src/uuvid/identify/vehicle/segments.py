"""Constant-thrust segments of a vehicle log and their steady velocities (Caccia et al. 2000, §III-A).

Caccia, Indiveri & Veruggio identify drag and installation coefficients from *steady* runs: a
constant nominal force is applied, the vehicle settles to a constant velocity, and that velocity
is estimated by a least-squares line fit to the position (3.33 Hz echo-sounder ranges for surge and
sway, 10 Hz compass for yaw, 10 Hz depth for heave).  Real logs contain sonar multipath echoes
(range jumps) and missing samples (their Fig. 14), so this module fits **robustly and says what
it rejected**:

* :func:`find_segments` — intervals where the command (one DOF's generalised force) is constant
  within a tolerance, in one thrust-mapping mode, for at least ``min_duration`` after discarding a
  ``settle`` time from the start of each interval (the vehicle's transient).
* :func:`segment_velocity` — robust line fit to the position (or unwrapped heading) in a window:

  1. non-finite samples are rejected as ``"missing"``;
  2. a robust start: the median of the slopes between sample ``i`` and sample ``i + m/2`` (``m``
     finite samples; a Theil–Sen estimator on half-window baselines, O(m), tolerant of up to ~25 %
     outliers) and the median intercept;
  3. residuals ``r`` from the line; each residual minus the median residual of its inlying
     neighbours (±5 samples) is its *spike* ``d`` (a Hampel statistic, so a real vehicle's slow
     wander about the line is not mistaken for outliers); robust scale ``s = 1.4826·MAD(d)``;
     samples with ``|d| > threshold·s`` are rejected as ``"outlier"`` (default threshold 3.5);
  4. ordinary LS refit on the inliers (:func:`uuvid.identify.fit.lsq_classical`), spikes of *all*
     samples against it, new robust scale, new inlier set (earlier rejections may come back) —
     repeated until the set no longer changes.

  The velocity is the LS slope of the inliers with its classical standard error
  ``σ_v = sqrt(σ²/Σ(t − t̄)²)``; every rejected sample comes back with its index, time, value,
  residual and reason (:class:`Rejection`), and ``summary()`` prints them.  A quadratic term is
  also fitted to the inliers: a significant acceleration (|a|/σ_a > 3) means the segment had not
  settled (``settled = False``) — the slope is then biased and the segment should be shortened
  or its ``settle`` time lengthened.
* Heading wrap-around (``angle=True``): the heading is unwrapped with the *robust rate*: each
  wrapped increment ``d_i ∈ (−π, π]`` between consecutive finite samples gets the multiple of
  2π that brings it closest to ``ṙ̂·Δt_i`` (``ṙ̂`` = median of ``d_i/Δt_i``), so gaps of missing
  samples and isolated spikes do not break the unwrapping as :func:`numpy.unwrap` would.
* :func:`savgol_velocity` — the non-causal 4th-order Savitzky–Golay derivative the paper uses
  for the inertia experiments (windows of 41 points in yaw, 21 in surge), with the edge handling
  stated (``edge``): ``"interp"`` (default, scipy ``savgol_filter(mode="interp")``: within
  ``window//2`` samples of an end the derivative of the polynomial fitted to the first/last full
  window — asymmetric, same order), ``"shrink"`` (symmetric windows that shrink towards the ends,
  order reduced to fit, a one-sided difference at the very end) or ``"nan"`` (NaN where the
  symmetric window does not fit).
* :func:`clean_series` — outliers and gaps of a whole record for :func:`savgol_velocity`: the
  record is put on a uniform grid, a local polynomial (Savitzky–Golay) smooth of the current
  inliers is computed, samples whose residual sticks out of their neighbours' residuals by more
  than ``threshold`` robust scales (a Hampel test on the residual) are flagged ``"outlier"``
  (the worst of each neighbourhood per pass, since one outlier contaminates the smooth around
  it) and re-filled, until nothing changes; missing samples are flagged; both are filled by a
  shape-preserving cubic (PCHIP) through the good samples.

Angles are in the unit of the data (``angle_unit="rad"`` or ``"deg"``); velocities come back in
that unit per second.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from uuvid.identify.fit import lsq_classical, lsq_solution

__all__ = [
    "CleanSeries",
    "Rejection",
    "Segment",
    "SegmentVelocity",
    "clean_series",
    "find_segments",
    "robust_unwrap",
    "savgol_velocity",
    "segment_velocity",
]

MAD_TO_SIGMA = 1.482602218505602  # 1/Φ⁻¹(3/4)


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------
def _as_1d(name: str, a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    return a


def _check_time(t: np.ndarray, name: str = "t") -> None:
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{name} has non-finite values")
    if t.size > 1 and np.any(np.diff(t) <= 0):
        raise ValueError(f"{name} must be strictly increasing")


def _period(angle_unit: str) -> float:
    if angle_unit == "rad":
        return 2.0 * math.pi
    if angle_unit == "deg":
        return 360.0
    raise ValueError(f"angle_unit must be 'rad' or 'deg', got {angle_unit!r}")


def _robust_scale(r: np.ndarray) -> float:
    r = r[np.isfinite(r)]
    if r.size == 0:
        return math.nan
    return float(MAD_TO_SIGMA * np.median(np.abs(r - np.median(r))))


def robust_unwrap(t, angle, angle_unit: str = "rad") -> np.ndarray:
    """Unwrap a heading with gaps: each step gets the 2π multiple closest to the robust rate.

    Non-finite samples stay NaN and are skipped (the increment across a gap is taken between the
    finite samples on both sides).  Needs the true change between consecutive finite samples to
    differ from ``median rate × Δt`` by less than half a turn.
    """
    t = _as_1d("t", t)
    a = _as_1d("angle", angle)
    if t.shape != a.shape:
        raise ValueError(f"t {t.shape} and angle {a.shape} must have the same shape")
    P = _period(angle_unit)
    out = np.full_like(a, np.nan)
    ok = np.flatnonzero(np.isfinite(a))
    if ok.size == 0:
        return out
    tf, af = t[ok], a[ok]
    if ok.size == 1:
        out[ok] = af
        return out
    dt = np.diff(tf)
    d = (np.diff(af) + P / 2) % P - P / 2  # wrapped increments in [−P/2, P/2)
    rate = float(np.median(d / dt))
    inc = d + P * np.round((rate * dt - d) / P)
    out[ok] = af[0] + np.concatenate([[0.0], np.cumsum(inc)])
    return out


# ---------------------------------------------------------------------------------------------
# constant-command segments
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Segment:
    """A constant-command interval: the command held ``level`` (median) from ``start`` to
    ``end`` in ``mode``; the steady window used for the velocity is ``[t0, t1]`` =
    ``[start + settle, end]``."""

    index: int
    start: float
    end: float
    t0: float
    t1: float
    level: float
    mode: str | None = None

    @property
    def duration(self) -> float:
        return self.t1 - self.t0

    def as_dict(self) -> dict:
        return {"index": self.index, "start": self.start, "end": self.end, "t0": self.t0,
                "t1": self.t1, "level": self.level, "mode": self.mode}


def find_segments(t, command, *, min_duration: float, settle: float = 0.0, tol: float = 0.0,
                  rel_tol: float = 0.02, mode=None, include_zero: bool = False,
                  zero_tol: float | None = None) -> list[Segment]:
    """Intervals where ``command`` is constant (and the mode unchanged) long enough to be steady.

    ``t``, ``command``: the command log (one DOF's nominal generalised force, any rate).  Two
    samples belong to the same interval when they differ from the interval's first sample by at
    most ``max(tol, rel_tol·|level|)`` and have the same ``mode`` label (``mode``: ``None``, one
    label, or one label per sample).  An interval from ``start`` to ``end`` (the last sample's
    time) becomes a :class:`Segment` with steady window ``[start + settle, end]`` if that window
    is at least ``min_duration`` long.  Intervals whose level is zero (``|level| ≤ zero_tol``,
    default ``max(tol, 1e-12)``) are skipped unless ``include_zero``.  Non-finite commands end an
    interval.
    """
    t = _as_1d("t", t)
    u = _as_1d("command", command)
    if t.shape != u.shape:
        raise ValueError(f"t {t.shape} and command {u.shape} must have the same shape")
    _check_time(t)
    if not (math.isfinite(min_duration) and min_duration > 0):
        raise ValueError(f"min_duration must be > 0, got {min_duration!r}")
    if not (math.isfinite(settle) and settle >= 0):
        raise ValueError(f"settle must be >= 0, got {settle!r}")
    for name, v in (("tol", tol), ("rel_tol", rel_tol)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"`{name}=` {v!r}: expected a finite tolerance >= 0")
    n = t.size
    if mode is None or isinstance(mode, str):
        modes = [mode] * n
    else:
        modes = list(mode)
        if len(modes) != n:
            raise ValueError(f"mode has {len(modes)} labels for {n} samples")
    zt = max(tol, 1e-12) if zero_tol is None else zero_tol
    segs: list[Segment] = []
    i = 0
    while i < n:
        if not math.isfinite(u[i]):
            i += 1
            continue
        ref, m = u[i], modes[i]
        tl = max(tol, rel_tol * abs(ref))
        j = i + 1
        while j < n and math.isfinite(u[j]) and abs(u[j] - ref) <= tl and modes[j] == m:
            j += 1
        start, end = float(t[i]), float(t[j - 1])
        level = float(np.median(u[i:j]))
        if end - (start + settle) >= min_duration and (include_zero or abs(level) > zt):
            segs.append(Segment(len(segs), start, end, start + settle, end, level, m))
        i = j
    return segs


# ---------------------------------------------------------------------------------------------
# robust velocity of one segment
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Rejection:
    """A sample left out of a fit: its index in the arrays given, time, value, residual, reason
    (``"missing"`` — non-finite; ``"outlier"`` — ``|residual| > threshold × robust scale``)."""

    index: int
    time: float
    value: float
    residual: float
    reason: str

    def as_dict(self) -> dict:
        return {"index": self.index, "time": self.time, "value": self.value,
                "residual": self.residual, "reason": self.reason}


@dataclass(frozen=True)
class SegmentVelocity:
    """Velocity of one steady segment (LS slope of the inliers) with what was rejected and why."""

    velocity: float
    stderr: float
    intercept: float
    t0: float
    t1: float
    n_total: int
    n_used: int
    residual_std: float
    robust_scale: float
    acceleration: float
    acceleration_stderr: float
    settled: bool
    rejected: tuple[Rejection, ...] = ()
    angle: bool = False
    iterations: int = 0
    used: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool), repr=False)
    messages: tuple[str, ...] = ()

    @property
    def relative_error(self) -> float:
        """``σ_v/|v|`` (Caccia: below 3 % for ROMEO's sonar)."""
        return self.stderr / abs(self.velocity) if self.velocity != 0 else math.inf

    def count(self, reason: str) -> int:
        return sum(r.reason == reason for r in self.rejected)

    @property
    def n_missing(self) -> int:
        return self.count("missing")

    @property
    def n_outliers(self) -> int:
        return self.count("outlier")

    def summary(self) -> str:
        lines = [f"segment [{self.t0:.6g}, {self.t1:.6g}] s: v = {self.velocity:.6g} ± "
                 f"{self.stderr:.3g} ({100 * self.relative_error:.2f} %), {self.n_used}/"
                 f"{self.n_total} samples used, residual σ {self.residual_std:.3g}"]
        if not self.settled:
            lines.append(f"  NOT SETTLED: acceleration {self.acceleration:.3g} ± "
                         f"{self.acceleration_stderr:.2g} (|a|/σ > 3); lengthen the settle time")
        if self.rejected:
            lines.append(f"  rejected {len(self.rejected)}: {self.n_missing} missing, "
                         f"{self.n_outliers} outliers (spike > threshold × {self.robust_scale:.3g})")
            for r in self.rejected:
                if r.reason != "missing":
                    lines.append(f"    #{r.index} t={r.time:.6g} value={r.value:.6g} "
                                 f"residual={r.residual:+.4g} ({r.reason})")
        lines.extend(f"  {m}" for m in self.messages)
        return "\n".join(lines)

    def as_dict(self) -> dict:
        return {"velocity": self.velocity, "stderr": self.stderr, "intercept": self.intercept,
                "t0": self.t0, "t1": self.t1, "n_total": self.n_total, "n_used": self.n_used,
                "n_missing": self.n_missing, "n_outliers": self.n_outliers,
                "residual_std": self.residual_std, "robust_scale": self.robust_scale,
                "acceleration": self.acceleration,
                "acceleration_stderr": self.acceleration_stderr, "settled": self.settled,
                "rejected": [r.as_dict() for r in self.rejected], "messages": list(self.messages)}


def _half_baseline_slope(t: np.ndarray, x: np.ndarray) -> float:
    m = t.size
    h = max(m // 2, 1)
    dt = t[h:] - t[:-h]
    return float(np.median((x[h:] - x[:-h]) / dt))


def segment_velocity(t, x, t0: float | None = None, t1: float | None = None, *,
                     angle: bool = False, angle_unit: str = "rad", threshold: float = 3.5,
                     max_iter: int = 20, min_samples: int = 5, neighbours: int = 5,
                     max_outlier_fraction: float = 0.25, min_scale: float = 0.0,
                     settled_z: float = 3.0) -> SegmentVelocity:
    """Robust LS velocity of ``x(t)`` on ``[t0, t1]`` (see the module docstring).

    ``x`` may contain NaN (missing samples) and outliers; ``angle=True`` unwraps a heading first.
    A sample is an outlier when its residual from the line sticks out of the residuals of its
    ``neighbours`` inlying neighbours on each side by more than ``threshold`` robust scales (a
    Hampel test: slow wander of a real vehicle about the straight line is not called an outlier;
    bursts of up to about ``neighbours`` samples are caught).  ``min_scale`` floors the robust
    scale (e.g. the sensor resolution); if more than ``max_outlier_fraction`` of the samples would
    be rejected the noise is too small to tell outliers from the trajectory's own curvature
    (noise-free data), so rejection stops there and ``messages`` says so.  Raises ``ValueError``
    when fewer than ``min_samples`` usable samples remain.
    """
    t = _as_1d("t", t)
    x = _as_1d("x", x)
    if t.shape != x.shape:
        raise ValueError(f"t {t.shape} and x {x.shape} must have the same shape")
    _check_time(t)
    if not (math.isfinite(threshold) and threshold > 0):
        raise ValueError(f"`threshold=` {threshold!r}: expected a finite threshold > 0")
    lo = -math.inf if t0 is None else t0
    hi = math.inf if t1 is None else t1
    if hi <= lo:
        raise ValueError(f"empty window [{t0}, {t1}]")
    idx = np.flatnonzero((t >= lo) & (t <= hi))
    if idx.size == 0:
        raise ValueError(f"no samples in [{t0}, {t1}]")
    tw, xw = t[idx], x[idx].copy()
    if angle:
        xw = robust_unwrap(tw, xw, angle_unit)
    finite = np.isfinite(xw)
    rejected: list[Rejection] = [Rejection(int(idx[i]), float(tw[i]), float(x[idx[i]]), math.nan,
                                           "missing") for i in np.flatnonzero(~finite)]
    if finite.sum() < min_samples:
        raise ValueError(f"only {int(finite.sum())} finite samples in [{tw[0]:.6g}, "
                         f"{tw[-1]:.6g}] (need {min_samples})")
    tc = float(np.mean(tw[finite]))
    s = tw - tc
    # robust start
    slope = _half_baseline_slope(s[finite], xw[finite])
    icpt = float(np.median(xw[finite] - slope * s[finite]))
    inl = finite.copy()
    scale = math.nan
    it = 0
    floor = max(min_scale, 1e-12 * max(1.0, float(np.nanmax(np.abs(xw[finite])))))
    msgs: list[str] = []
    for it in range(1, max_iter + 1):
        r = xw - (icpt + slope * s)
        d = _spikes(np.where(inl, r, np.nan), np.where(finite, r, np.nan), neighbours)
        scale = _robust_scale(d[inl])
        with np.errstate(invalid="ignore"):
            new = finite & (np.abs(d) <= threshold * max(scale, floor))
        if (finite & ~new).sum() > max_outlier_fraction * finite.sum() or new.sum() < min_samples:
            msgs.append(f"more than {100 * max_outlier_fraction:.0f} % of the samples would be "
                        "rejected: the noise is too small to tell outliers from the trajectory's "
                        "curvature; outlier rejection stopped (give min_scale)")
            break
        H = np.column_stack([np.ones(int(new.sum())), s[new]])
        icpt, slope = (float(v) for v in lsq_solution(H, xw[new]))
        if np.array_equal(new, inl) and it > 1:
            break
        inl = new
    H = np.column_stack([np.ones(int(inl.sum())), s[inl]])
    (x0, v), (_, v_se), s2 = lsq_classical(H, xw[inl])
    r = xw - (x0 + v * s)
    for i in np.flatnonzero(finite & ~inl):
        rejected.append(Rejection(int(idx[i]), float(tw[i]), float(x[idx[i]]), float(r[i]),
                                  "outlier"))
    rejected.sort(key=lambda q: q.index)
    # settling check: a significant quadratic term means the velocity still changes
    acc, acc_se = 0.0, math.nan
    if inl.sum() > 3:
        H2 = np.column_stack([np.ones(int(inl.sum())), s[inl], 0.5 * s[inl] ** 2])
        th2, se2, _ = lsq_classical(H2, xw[inl])
        acc, acc_se = float(th2[2]), float(se2[2])
    settled = not (math.isfinite(acc_se) and acc_se > 0 and abs(acc) / acc_se > settled_z)
    used = np.zeros(t.size, dtype=bool)
    used[idx[inl]] = True
    return SegmentVelocity(float(v), float(v_se),
                           float(x0 - v * tc), float(tw[0]), float(tw[-1]),
                           int(idx.size), int(inl.sum()), float(math.sqrt(s2)), float(scale),
                           float(acc), float(acc_se), bool(settled), tuple(rejected), angle, it,
                           used, tuple(msgs))


# ---------------------------------------------------------------------------------------------
# whole-record cleaning and Savitzky–Golay differentiation
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CleanSeries:
    """A record on a uniform grid with outliers and gaps filled (PCHIP through the good
    samples).

    ``t``, ``x``: the uniform grid and the cleaned values; ``flags``: per grid point ``"ok"``,
    ``"missing"`` (no sample there, interpolated) or ``"outlier"`` (rejected, interpolated);
    ``rejected``: the rejected samples of the *input* arrays with reasons.
    """

    t: np.ndarray
    x: np.ndarray
    flags: np.ndarray
    rejected: tuple[Rejection, ...]
    dt: float
    robust_scale: float
    messages: tuple[str, ...] = ()

    @property
    def n_outliers(self) -> int:
        return int(np.sum(self.flags == "outlier"))

    @property
    def n_missing(self) -> int:
        return int(np.sum(self.flags == "missing"))

    @property
    def good(self) -> np.ndarray:
        return self.flags == "ok"

    def summary(self) -> str:
        return (f"{self.t.size} samples at dt = {self.dt:.4g} s: {self.n_missing} missing and "
                f"{self.n_outliers} outliers (> threshold × {self.robust_scale:.3g}) interpolated"
                + "".join(f"; {m}" for m in self.messages))


def _uniform_grid(t: np.ndarray, dt: float | None) -> tuple[np.ndarray, float]:
    d = np.diff(t)
    step = float(np.median(d)) if dt is None else float(dt)
    if not step > 0:
        raise ValueError("cannot find a positive sample time")
    n = int(round((t[-1] - t[0]) / step)) + 1
    return t[0] + step * np.arange(n), step


def _fill(grid: np.ndarray, good: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Values at every grid point: the good samples, gaps filled by a shape-preserving cubic
    (PCHIP: no overshoot across long gaps; linear when there are too few), constant beyond the
    ends."""
    from scipy.interpolate import PchipInterpolator

    g = np.flatnonzero(good)
    out = x.copy()
    if g.size >= 4:
        out[~good] = PchipInterpolator(grid[g], x[g], extrapolate=False)(grid[~good])
    else:
        out[~good] = np.interp(grid[~good], grid[g], x[g])
    bad = ~np.isfinite(out)
    out[bad] = np.interp(grid[bad], grid[g], x[g])
    return out


def _running_max(a: np.ndarray, h: int) -> np.ndarray:
    from numpy.lib.stride_tricks import sliding_window_view

    pad = np.concatenate([np.zeros(h), a, np.zeros(h)])
    return sliding_window_view(pad, 2 * h + 1).max(axis=1)


def _spikes(r_inliers: np.ndarray, r_all: np.ndarray, neighbours: int) -> np.ndarray:
    """``r_i − median(r_j, 0 < |j − i| ≤ neighbours, j an inlier)``: how much a residual sticks
    out of its neighbours (a Hampel statistic; smooth, systematic residuals give ≈ 0)."""
    from numpy.lib.stride_tricks import sliding_window_view

    h = int(neighbours)
    pad = np.concatenate([np.full(h, np.nan), r_inliers, np.full(h, np.nan)])
    win = sliding_window_view(pad, 2 * h + 1).copy()
    win[:, h] = np.nan  # leave the sample itself out
    # the median of each row's non-NaN entries (np.nanmedian's value: the middle one, or the mean
    # of the two middle ones), from one sort of the rows — NaN sort last
    win.sort(axis=1)
    k = np.count_nonzero(~np.isnan(win), axis=1)
    rows = np.arange(win.shape[0])
    lo = win[rows, np.maximum(k - 1, 0) // 2]
    hi = win[rows, k // 2]
    ref = np.where(k > 0, (lo + hi) / 2, 0.0)
    return r_all - ref


def clean_series(t, x, *, dt: float | None = None, window: int = 21, order: int = 3,
                 threshold: float = 4.0, max_iter: int = 200, angle: bool = False,
                 angle_unit: str = "rad", neighbours: int = 5, min_scale: float = 0.0,
                 max_outlier_fraction: float = 0.25) -> CleanSeries:
    """Flag outliers and gaps of a record and fill them (see the module docstring).

    The outlier test is a Hampel test on the residual ``r`` from the local polynomial smooth:
    ``d_i = r_i − median(r of the ``neighbours`` inliers on each side)``, robust scale
    ``1.4826·MAD(d)``, flagged when ``|d_i| > threshold × scale`` — so the smoother's own smooth
    (systematic) error is never mistaken for outliers, and bursts of up to ``neighbours`` samples
    are caught.

    ``t`` need not be uniform: samples are placed on the grid ``t[0] + k·dt`` (``dt`` = median
    spacing unless given) at the nearest grid point; grid points without a sample are
    ``"missing"``.  Returns a :class:`CleanSeries`.
    """
    from scipy.signal import savgol_filter

    t = _as_1d("t", t)
    x = _as_1d("x", x)
    if t.shape != x.shape:
        raise ValueError(f"t {t.shape} and x {x.shape} must have the same shape")
    _check_time(t)
    if t.size < 3:
        raise ValueError("need at least 3 samples")
    if window % 2 == 0 or window <= order:
        raise ValueError(f"window must be odd and > order, got window={window}, order={order}")
    xa = robust_unwrap(t, x, angle_unit) if angle else x.copy()
    grid, step = _uniform_grid(t, dt)
    k = np.rint((t - grid[0]) / step).astype(int)
    if np.any(np.abs(t - (grid[0] + k * step)) > 0.25 * step):
        raise ValueError("sample times are not on a (near-)uniform grid; give dt or resample")
    if np.unique(k).size != k.size:
        raise ValueError("two samples fall on the same grid point; give a smaller dt")
    xg = np.full(grid.size, np.nan)
    src = np.full(grid.size, -1)
    xg[k] = xa
    src[k] = np.arange(t.size)
    present = np.isfinite(xg)
    if present.sum() < max(order + 2, 3):
        raise ValueError("too few finite samples to clean")
    if window > grid.size:
        raise ValueError(f"window {window} is longer than the record ({grid.size} samples)")
    inl = present.copy()
    scale = math.nan
    msgs: list[str] = []
    h = window // 2
    floor = max(min_scale, 1e-9 * max(1.0, float(np.nanmax(np.abs(xg[present])))))
    for _ in range(max_iter):
        filled = _fill(grid, inl, xg)
        r = xg - savgol_filter(filled, window, order, mode="interp")
        d = _spikes(np.where(inl, r, np.nan), r, neighbours)
        scale = _robust_scale(d[inl])
        thr = threshold * max(scale, floor)
        cand = inl & (np.abs(d) > thr)
        # one outlier contaminates the smooth over ±window/2: flag only the worst point of each
        # neighbourhood per pass, re-smooth, and let earlier rejections come back if they fit
        a = np.where(cand, np.abs(d), 0.0)
        runmax = _running_max(a, h)
        worst = cand & (a >= runmax)
        back = present & ~inl & (np.abs(d) <= thr)
        new = (inl & ~worst) | back
        if np.array_equal(new, inl):
            break
        if (present & ~new).sum() > max_outlier_fraction * present.sum():
            msgs.append(f"more than {100 * max_outlier_fraction:.0f} % of the samples would be "
                        "flagged: the smoother does not follow the signal at this noise level; "
                        "outlier rejection stopped (give min_scale, e.g. the sensor resolution)")
            break
        inl = new
    xc = _fill(grid, inl, xg)
    flags = np.where(inl, "ok", np.where(present, "outlier", "missing")).astype(object)
    r = xg - savgol_filter(xc, window, order, mode="interp")
    r = _spikes(np.where(inl, r, np.nan), r, neighbours)
    rej = []
    for g in np.flatnonzero(present & ~inl):
        i = int(src[g])
        if i >= 0:
            rej.append(Rejection(i, float(t[i]), float(x[i]), float(r[g]), "outlier"))
    for i in np.flatnonzero(~np.isfinite(xa)):
        rej.append(Rejection(int(i), float(t[i]), float(x[i]), math.nan, "missing"))
    rej.sort(key=lambda q: q.index)
    return CleanSeries(grid, xc, flags.astype(str), tuple(rej), step, float(scale), tuple(msgs))


EDGE_MODES = ("interp", "shrink", "nan")


def savgol_velocity(t, x, order: int = 4, window: int = 41, edge: str = "interp", *,
                    angle: bool = False, angle_unit: str = "rad", rtol: float = 1e-3) -> np.ndarray:
    """Non-causal Savitzky–Golay derivative ``dx/dt`` (Caccia et al. 2000: order 4; 41 points yaw,
    21 points surge).

    ``t`` must be uniform (relative spread of the steps below ``rtol``) and ``x`` finite — run
    :func:`clean_series` first on records with gaps or outliers.  ``edge`` says what happens
    within ``window//2`` samples of each end:

    * ``"interp"`` — scipy ``savgol_filter(mode="interp")``: the derivative of the order-``order``
      polynomial fitted to the first (last) full window, evaluated at those samples;
    * ``"shrink"`` — symmetric windows ``2h+1`` shrinking with the distance ``h`` to the end,
      polynomial order ``min(order, 2h)``; a one-sided first difference at the end samples;
    * ``"nan"`` — NaN there (only full symmetric windows).

    ``angle=True`` unwraps a heading first.
    """
    from scipy.signal import savgol_coeffs, savgol_filter

    t = _as_1d("t", t)
    x = _as_1d("x", x)
    if t.shape != x.shape:
        raise ValueError(f"t {t.shape} and x {x.shape} must have the same shape")
    _check_time(t)
    if edge not in EDGE_MODES:
        raise ValueError(f"edge must be one of {EDGE_MODES}, got {edge!r}")
    if not isinstance(order, (int, np.integer)) or order < 1:
        raise ValueError(f"order must be an integer >= 1, got {order!r}")
    if not isinstance(window, (int, np.integer)) or window % 2 == 0 or window <= order:
        raise ValueError(f"window must be an odd integer > order ({order}), got {window!r}")
    if window > t.size:
        raise ValueError(f"window {window} is longer than the record ({t.size} samples)")
    if not np.all(np.isfinite(x)):
        raise ValueError("x has non-finite values; fill them first (clean_series)")
    d = np.diff(t)
    dt = float(np.mean(d))
    if np.max(np.abs(d - dt)) > rtol * dt:
        raise ValueError("t is not uniformly sampled; resample first (clean_series)")
    if angle:
        x = robust_unwrap(t, x, angle_unit)
    if edge == "interp":
        return savgol_filter(x, window, order, deriv=1, delta=dt, mode="interp")
    h = window // 2
    v = np.full(x.size, np.nan)
    c = savgol_coeffs(window, order, deriv=1, delta=dt, use="dot")
    v[h:x.size - h] = np.correlate(x, c, mode="valid")
    if edge == "nan":
        return v
    n = x.size
    for i in list(range(h)) + list(range(n - h, n)):
        hh = min(i, n - 1 - i)
        if hh == 0:
            v[i] = (x[1] - x[0]) / dt if i == 0 else (x[-1] - x[-2]) / dt
            continue
        w = 2 * hh + 1
        cc = savgol_coeffs(w, min(order, 2 * hh), deriv=1, delta=dt, use="dot")
        v[i] = float(cc @ x[i - hh:i + hh + 1])
    return v


def window_samples(duration: float, dt: float) -> int:
    """The odd number of samples spanning about ``duration`` at sample time ``dt``."""
    n = int(round(duration / dt))
    return n + 1 if n % 2 == 0 else n


def summarise_rejections(velocities: Sequence[SegmentVelocity]) -> dict:
    """Counts over many segments: samples, used, missing, outliers, unsettled segments."""
    return {"segments": len(velocities),
            "samples": int(sum(v.n_total for v in velocities)),
            "used": int(sum(v.n_used for v in velocities)),
            "missing": int(sum(v.n_missing for v in velocities)),
            "outliers": int(sum(v.n_outliers for v in velocities)),
            "unsettled_segments": [i for i, v in enumerate(velocities) if not v.settled]}
