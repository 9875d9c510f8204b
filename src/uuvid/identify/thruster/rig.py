"""Test-rig helpers: the load cell's dynamics, undoing them, and averaging repeated runs.

McLean (1991), Ch. III–IV.  The thrust of the AUV II tunnel thruster was read through a load cell
in a box whose compliance adds a lightly damped second-order filter (block 9,
``F_out/F = ω_n²/(s² + 2ζω_n s + ω_n²)``, ω_n ≈ 44 rad/s (7 Hz), ζ ≈ 0.16).  The thesis found
ω_n from the FFT of an impulse ("tap") record and settled ζ by trial simulations; it could not
separate the true thrust from the structure's ringing ("the inverse transform", Fig. 33); and
averaging its eight runs per voltage *without aligning them* cut the 24 V peak from ≈5.3 to 3.5 lb.

* :func:`load_cell_from_tap` — ω_n and ζ from a tap record three ways: FFT resonance peak
  (parabolic interpolation) with the half-power bandwidth; log decrement (regression of the
  log-amplitude of successive extrema, period from zero crossings); and a least-squares fit of a
  damped sinusoid to the free ring-down (the estimate returned, with σ).
* :func:`remove_load_cell` — the true thrust ``F = y + (2ζ/ω_n) ẏ + ÿ/ω_n²`` from the measured
  ``y``; differentiation amplifies noise by ``(ω/ω_n)²``, so it is regularised (Savitzky–Golay
  derivatives, or a zero-phase low-pass in the frequency domain).
* :func:`align_runs`, :func:`average_runs` — align repeated runs on their trigger (command step or
  output rising through a threshold, sub-sample by interpolation) before averaging.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from uuvid.identify.fit import Fit, nonlinear_lsq
from uuvid.thruster.blocks import LoadCell

__all__ = [
    "AlignedRuns",
    "RunAverage",
    "TapTest",
    "align_runs",
    "average_runs",
    "load_cell_from_tap",
    "remove_load_cell",
    "trigger_time",
]


# ------------------------------------------------------------------------------------------------
# validation
# ------------------------------------------------------------------------------------------------
def _record(
    t: Any, y: Any, name: str = "y", min_len: int = 8, uniform: bool = True
) -> tuple[np.ndarray, np.ndarray, float]:
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.ndim != 1 or y.ndim != 1:
        raise ValueError(f"t and {name} must be one-dimensional, got shapes {t.shape} and {y.shape}")
    if t.size != y.size:
        raise ValueError(f"t has {t.size} samples but {name} has {y.size}")
    if t.size < min_len:
        raise ValueError(f"need at least {min_len} samples, got {t.size}")
    for nm, a in (("t", t), (name, y)):
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise ValueError(f"{nm}[{bad[0]}] is not finite ({a[bad[0]]!r})")
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0]) + 1
        raise ValueError(f"t must be strictly increasing, but t[{i}] = {t[i]!r} <= t[{i - 1}] = {t[i - 1]!r}")
    dt = (t[-1] - t[0]) / (t.size - 1)
    if uniform and np.max(np.abs(d - dt)) > 1e-3 * dt:
        raise ValueError(
            f"t must be uniformly sampled (mean step {dt:.6g} s, steps range "
            f"{d.min():.6g}–{d.max():.6g} s); resample the record first"
        )
    return t, y, float(dt)


# ------------------------------------------------------------------------------------------------
# tap test
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TapTest:
    """Load-cell dynamics from a tap (impulse) record.

    ``natural_frequency`` (rad/s) and ``damping_ratio`` are the chosen estimate (``method``);
    ``estimates`` holds every method's numbers; ``fit`` the ring-down least-squares fit (σ).
    """

    natural_frequency: float
    damping_ratio: float
    method: str
    estimates: dict
    fit: Fit | None = field(default=None, repr=False)

    @property
    def load_cell(self) -> LoadCell:
        return LoadCell(natural_frequency=self.natural_frequency, damping_ratio=self.damping_ratio)

    @property
    def frequency_hz(self) -> float:
        return self.natural_frequency / (2 * math.pi)

    def as_dict(self) -> dict:
        return {
            "natural_frequency": self.natural_frequency,
            "frequency_hz": self.frequency_hz,
            "damping_ratio": self.damping_ratio,
            "method": self.method,
            "estimates": self.estimates,
            "fit": None if self.fit is None else self.fit.as_dict(),
        }


def _parabolic(y_m: float, y_0: float, y_p: float) -> tuple[float, float]:
    """Vertex ``(offset in samples, value)`` of the parabola through three equally spaced points."""
    den = y_m - 2 * y_0 + y_p
    if den == 0:
        return 0.0, y_0
    d = 0.5 * (y_m - y_p) / den
    d = float(np.clip(d, -0.5, 0.5))
    return d, y_0 - 0.25 * (y_m - y_p) * d


def _zeta_from_bandwidth(r: float) -> float:
    """Solve ``2ζ√(1−ζ²)/(1−2ζ²) = r`` for ζ in (0, 1/√2)."""
    from scipy.optimize import brentq

    def g(z):
        return 2 * z * math.sqrt(1 - z * z) / (1 - 2 * z * z) - r

    return float(brentq(g, 1e-9, 1 / math.sqrt(2) - 1e-9))


def _fft_estimate(x: np.ndarray, dt: float, pad: int = 16) -> dict:
    """Resonance of the response spectrum: ``|H|`` peaks at ``ω_r = ω_n√(1−2ζ²)``; the half-power
    points ``ω_{1,2}² = ω_n²(1 − 2ζ² ∓ 2ζ√(1−ζ²))`` give ζ through
    ``(ω₂² − ω_r²)/ω_r² = (ω_r² − ω₁²)/ω_r² = 2ζ√(1−ζ²)/(1−2ζ²)``."""
    n = x.size
    nfft = 1 << math.ceil(math.log2(max(n * pad, 256)))
    mag = np.abs(np.fft.rfft(x, nfft))
    f = np.fft.rfftfreq(nfft, dt)
    lo = np.searchsorted(f, 1.0 / (n * dt))  # below one cycle per record: offset/drift
    k = lo + int(np.argmax(mag[lo:-1]))
    if k <= 0 or k >= mag.size - 1 or not (mag[k - 1] < mag[k] > mag[k + 1]):
        return {"ok": False, "reason": "no spectral peak (the spectrum falls from DC)"}
    d, peak = _parabolic(mag[k - 1], mag[k], mag[k + 1])
    fr = (k + d) * (f[1] - f[0])
    half = peak / math.sqrt(2)
    out = {"ok": True, "resonant_frequency_hz": float(fr), "peak_magnitude": float(peak)}
    ratios = []
    below = np.flatnonzero(mag[:k] < half)
    if below.size:
        i = int(below[-1])
        f1 = f[i] + (half - mag[i]) / (mag[i + 1] - mag[i]) * (f[i + 1] - f[i])
        out["lower_half_power_hz"] = float(f1)
        ratios.append(1 - (f1 / fr) ** 2)
    above = np.flatnonzero(mag[k:] < half)
    if above.size:
        i = k + int(above[0])
        f2 = f[i - 1] + (mag[i - 1] - half) / (mag[i - 1] - mag[i]) * (f[i] - f[i - 1])
        out["upper_half_power_hz"] = float(f2)
        ratios.append((f2 / fr) ** 2 - 1)
    if not ratios:
        out.update(ok=False, reason="half-power points not found")
        return out
    zeta = _zeta_from_bandwidth(float(np.mean(ratios)))
    out["damping_ratio"] = zeta
    out["natural_frequency"] = float(2 * math.pi * fr / math.sqrt(1 - 2 * zeta * zeta))
    return out


def _half_cycles(x: np.ndarray, t: np.ndarray, threshold: float):
    """Half cycles of a ring-down ``x`` (offset removed), with hysteresis: a new half cycle starts
    only when ``x`` goes beyond ``±threshold`` on the other side, so noise near zero does not split
    one.  Returns the zero crossing that opens each half cycle after the first (interpolated; the
    mean when noise makes several) and every half cycle's extremum (time and |value|, parabolic
    refinement)."""
    dt = t[1] - t[0]
    side = 0
    seg_start = 0
    segs = []
    for i in range(x.size):
        s = 1 if x[i] > threshold else (-1 if x[i] < -threshold else 0)
        if s != 0 and s != side:
            if side != 0:
                segs.append((seg_start, i, side))
            side, seg_start = s, i
    if side != 0:
        segs.append((seg_start, x.size, side))
    te, ae, crossings = [], [], []
    # least-squares parabola over ±10 % of a period around each extremum (3 points at 75 Hz)
    period = 2 * float(np.median(np.diff([a for a, _, _ in segs]))) if len(segs) > 2 else 8.0
    m = max(1, round(0.1 * period))
    for k, (a, b, sgn) in enumerate(segs):
        j = a + int(np.argmax(sgn * x[a:b]))
        lo, hi = max(0, j - m), min(x.size, j + m + 1)
        if hi - lo >= 3:
            c2, c1, c0 = np.polyfit(np.arange(lo, hi) - j, x[lo:hi], 2)
            d = float(np.clip(-c1 / (2 * c2), -m, m)) if c2 != 0 else 0.0
            v = c0 + c1 * d + c2 * d * d
        else:
            d, v = 0.0, x[j]
        te.append(t[j] + d * dt)
        ae.append(abs(v))
        if k > 0:  # zero crossings between the previous extremum and this half cycle's entry
            j0 = round((te[-2] - t[0]) / dt)
            seg = x[j0 : a + 1]
            idx = np.flatnonzero(np.sign(seg[:-1]) * np.sign(seg[1:]) < 0)
            if idx.size:
                ii = j0 + idx
                zc = t[ii] - x[ii] * dt / (x[ii + 1] - x[ii])
                crossings.append(float(np.mean(zc)))
            else:
                crossings.append(math.nan)
    return np.array(crossings), np.array(te), np.array(ae)


def _log_decrement(x: np.ndarray, t: np.ndarray, noise: float) -> dict:
    first = abs(x[0])
    crossings, te, ae = _half_cycles(x, t, max(4 * noise, 0.02 * first))
    keep = ae > max(10 * noise, 0.02 * first)  # near the noise floor the extrema are biased up
    crossings = crossings[keep[1:]] if crossings.size else crossings
    te, ae = te[keep], ae[keep]
    if te.size < 2:
        return {"ok": False, "reason": "fewer than two extrema above the noise"}
    decay = float(-np.polyfit(te - te[0], np.log(ae), 1)[0])  # ζω_n, 1/s
    ok = np.isfinite(crossings)
    if ok.sum() >= 2:  # zero crossings of a damped sinusoid are exactly half a period apart
        half = float(np.polyfit(np.flatnonzero(ok), crossings[ok], 1)[0])
    else:
        half = float(np.mean(np.diff(te)))
    wd = math.pi / half
    if not decay > 0:
        return {"ok": False, "reason": "the extrema do not decay"}
    delta = 2 * math.pi * decay / wd
    wn = math.hypot(decay, wd)
    return {
        "ok": True,
        "natural_frequency": wn,
        "damping_ratio": decay / wn,
        "damped_frequency": wd,
        "log_decrement": delta,
        "n_extrema": int(te.size),
    }


def _ringdown_fit(x: np.ndarray, t: np.ndarray, wn0: float, z0: float) -> Fit:
    """``x(τ) = c + e^{−ζω_n τ}(a cos ω_d τ + b sin ω_d τ)``, ``ω_d = ω_n√(1−ζ²)``."""
    tau = t - t[0]

    def model(p):
        wn, z, a, b, c = p
        wd = wn * math.sqrt(max(1 - z * z, 1e-12))
        return c + np.exp(-z * wn * tau) * (a * np.cos(wd * tau) + b * np.sin(wd * tau))

    p0 = [wn0, min(max(z0, 1e-3), 0.95), x[0], 0.0, 0.0]
    amp = max(abs(x[0]), 1e-300)
    lo = [0.0, 0.0, -np.inf, -np.inf, -np.inf]
    hi = [np.inf, 0.999, np.inf, np.inf, np.inf]
    return nonlinear_lsq(
        lambda p: (model(p) - x) / amp,
        p0,
        ["natural_frequency", "damping_ratio", "a", "b", "offset"],
        model="load-cell ring-down (damped sinusoid)",
        units=["rad/s", "", "", "", ""],
        bounds=(lo, hi),
        emit_warnings=False,
    )


def load_cell_from_tap(t: Any, y: Any, *, onset: float | None = None, tail_fraction: float = 0.2) -> TapTest:
    """ω_n and ζ of a load cell from its response to a tap, and the :class:`LoadCell` block.

    ``t`` uniformly sampled (s); ``y`` the load-cell output (any unit).  The record must end after
    the ring-down has decayed: its offset is the mean of the last ``tail_fraction`` of the record.
    ``onset`` (s) marks the tap; by default the first sample exceeding 20 % of the largest
    deflection.  Three estimates (``TapTest.estimates``):

    * ``fft`` — spectrum of the response from the onset (zero-padded ×16), resonance peak refined
      by parabolic interpolation, ζ from the half-power bandwidth, ``ω_n = ω_r/√(1−2ζ²)``;
    * ``log_decrement`` — from the largest deflection on: extrema of every half cycle (parabolic
      refinement), ``ζω_n`` = slope of ``ln|A_k|`` against ``t_k``, damped period from the zero
      crossings; ``δ = 2πζω_n/ω_d``, ``ω_n = √((ζω_n)² + ω_d²)``;
    * ``ringdown_fit`` — least-squares damped sinusoid on the free ring-down (from the largest
      deflection, after the tap force has ended), started from the others; returned, with σ.
    """
    t, y, dt = _record(t, y, "y")
    if not 0 < tail_fraction < 1:
        raise ValueError(f"tail_fraction must be in (0, 1), got {tail_fraction}")
    ntail = max(3, int(tail_fraction * t.size))
    offset = float(np.mean(y[-ntail:]))
    noise = float(np.std(y[-ntail:]))
    x = y - offset
    peak = int(np.argmax(np.abs(x)))
    if onset is None:
        start = int(np.flatnonzero(np.abs(x) >= 0.2 * abs(x[peak]))[0])
        start = max(0, start - 1)
    else:
        start = int(np.searchsorted(t, onset))
    if t.size - peak < 8:
        raise ValueError("the record ends too soon after the tap to see the ring-down")
    est: dict = {"offset": offset, "noise_std": noise}
    est["fft"] = _fft_estimate(x[start:-ntail] if t.size - ntail - start > 16 else x[start:], dt)
    est["log_decrement"] = _log_decrement(x[peak:], t[peak:], noise)
    starts = [e for e in (est["log_decrement"], est["fft"]) if e.get("ok")]
    if not starts:
        raise ValueError(
            "no oscillation found in the tap record (no spectral peak and fewer than two decaying extrema)"
        )
    wn0, z0 = starts[0]["natural_frequency"], starts[0]["damping_ratio"]
    fit = None
    try:
        fit = _ringdown_fit(x[peak:], t[peak:], wn0, z0)
        wn, z = fit["natural_frequency"], fit["damping_ratio"]
        ok = fit.extra.get("status", 0) > 0 and 0 < z.value < 0.999 and wn.value > 0
        est["ringdown_fit"] = {
            "ok": bool(ok),
            "natural_frequency": wn.value,
            "natural_frequency_sigma": wn.stderr,
            "damping_ratio": z.value,
            "damping_ratio_sigma": z.stderr,
            "rmse": fit.rmse,
        }
    except (ValueError, np.linalg.LinAlgError) as e:  # pragma: no cover - defensive
        est["ringdown_fit"] = {"ok": False, "reason": str(e)}
    for method in ("ringdown_fit", "log_decrement", "fft"):
        e = est[method]
        if e.get("ok"):
            return TapTest(float(e["natural_frequency"]), float(e["damping_ratio"]), method, est, fit)
    raise ValueError("tap record: no method produced an estimate")  # pragma: no cover


# ------------------------------------------------------------------------------------------------
# undoing the load cell
# ------------------------------------------------------------------------------------------------
def _savgol_window(dt: float, cutoff_hz: float, polyorder: int) -> int:
    """Window (odd, samples) whose Savitzky–Golay response falls off near ``cutoff_hz``
    (Schafer 2011: ``f_c/f_Nyquist ≈ (N+1)/(3.2M − 4.6)`` for window ``2M+1``, order ``N``)."""
    frac = min(cutoff_hz * 2 * dt, 0.9)
    m = ((polyorder + 1) / frac + 4.6) / 3.2
    w = 2 * math.ceil(m) + 1
    return max(w, polyorder + 2 + (polyorder % 2 == 0))


def remove_load_cell(
    t: Any,
    y_measured: Any,
    load_cell: LoadCell,
    *,
    method: str = "fourier",
    cutoff_hz: float | None = None,
    window: int | None = None,
    polyorder: int = 4,
) -> np.ndarray:
    """Estimate the true thrust behind a load-cell record by inverting its 2nd-order filter.

    ``F = y + (2ζ/ω_n) ẏ + ÿ/ω_n²``.  Inverting amplifies noise by ``|1 − (ω/ω_n)² + 2jζω/ω_n|``
    (≈ ``(ω/ω_n)²`` above ω_n), so the inverse is regularised with a low-pass of cutoff
    ``cutoff_hz`` (default: twice the load cell's natural frequency) — the price is that a jump in
    the true thrust (McLean's step response) comes back smoothed over ≈ 1/cutoff_hz.

    ``method``:

    * ``"savgol"`` — ``y``, ``ẏ``, ``ÿ`` from one Savitzky–Golay fit (``polyorder`` ≥ 2, default 3;
      ``window`` samples, default matched to ``cutoff_hz``); works on any record length;
    * ``"fourier"`` — the line through the end samples is removed (so the periodic extension has
      no jump), the rest is multiplied in the frequency domain by the inverse filter times a
      zero-phase 4th-order Butterworth magnitude ``1/√(1 + (f/f_c)^8)``, and the line's own
      inverse ``a + bt + 2ζb/ω_n`` is added back.
    """
    from scipy.signal import savgol_filter

    t, y, dt = _record(t, y_measured, "y_measured")
    if not isinstance(load_cell, LoadCell):
        raise TypeError("load_cell must be a LoadCell block")
    wn, z = load_cell.natural_frequency, load_cell.damping_ratio
    fc = 2.0 * wn / (2 * math.pi) if cutoff_hz is None else float(cutoff_hz)
    if not fc > 0:
        raise ValueError(f"cutoff_hz must be positive, got {cutoff_hz}")
    if method == "savgol":
        if polyorder < 2:
            raise ValueError("polyorder must be >= 2 to estimate the second derivative")
        w = window if window is not None else _savgol_window(dt, fc, polyorder)
        if w % 2 == 0:
            w += 1
        if w > y.size:
            raise ValueError(f"Savitzky–Golay window {w} is longer than the record ({y.size})")
        if w <= polyorder:
            raise ValueError(f"window ({w}) must exceed polyorder ({polyorder})")
        y0 = savgol_filter(y, w, polyorder, deriv=0, delta=dt, mode="interp")
        y1 = savgol_filter(y, w, polyorder, deriv=1, delta=dt, mode="interp")
        y2 = savgol_filter(y, w, polyorder, deriv=2, delta=dt, mode="interp")
        return y0 + 2 * z / wn * y1 + y2 / wn**2
    if method == "fourier":
        b = (y[-1] - y[0]) / (t[-1] - t[0])
        line = y[0] + b * (t - t[0])
        r = y - line
        n = y.size
        f = np.fft.rfftfreq(n, dt)
        w_ = 2 * math.pi * f
        inv = (wn**2 - w_**2 + 2j * z * wn * w_) / wn**2
        lp = 1.0 / np.sqrt(1.0 + (f / fc) ** 8)
        rr = np.fft.irfft(np.fft.rfft(r) * inv * lp, n)
        return rr + line + 2 * z * b / wn
    raise ValueError(f"method must be 'savgol' or 'fourier', got {method!r}")


# ------------------------------------------------------------------------------------------------
# aligning and averaging runs
# ------------------------------------------------------------------------------------------------
def _crossing(t: np.ndarray, y: np.ndarray, level: float, rising: bool = True) -> float:
    v = y - level if rising else level - y
    hit = np.flatnonzero(v >= 0)
    if hit.size == 0:
        return math.nan
    i = int(hit[0])
    if i == 0:
        return float(t[0])
    return float(t[i - 1] + (0 - v[i - 1]) / (v[i] - v[i - 1]) * (t[i] - t[i - 1]))


def trigger_time(
    t: Any, y: Any, *, level: float = 0.5, absolute: float | None = None, baseline_samples: int = 3
) -> float:
    """First time ``y`` moves through a level, linearly interpolated between samples.

    The level is ``absolute`` if given, else ``baseline + level·(extreme − baseline)`` with the
    baseline the mean of the first ``baseline_samples`` samples and the extreme the sample
    farthest from it (so falling steps work too).  NaN if never crossed.
    """
    t, y, _ = _record(t, y, "y", min_len=2, uniform=False)
    base = float(np.mean(y[: max(1, baseline_samples)]))
    ext = float(y[int(np.argmax(np.abs(y - base)))])
    rising = ext >= base
    if absolute is not None:
        lev = float(absolute)
    else:
        if not 0 < level < 1:
            raise ValueError(f"level must be a fraction in (0, 1), got {level}")
        lev = base + level * (ext - base)
    return _crossing(t, y, lev, rising)


@dataclass(frozen=True)
class AlignedRuns:
    """Runs resampled so their triggers coincide at ``reference`` (NaN where a run has no data)."""

    t: np.ndarray
    runs: np.ndarray  # (n_runs, n_samples)
    triggers: np.ndarray  # trigger time of every run on its own record
    reference: float

    @property
    def shifts(self) -> np.ndarray:
        """How much each run was moved earlier (s): ``trigger − reference``."""
        return self.triggers - self.reference


def _as_runs(t: np.ndarray, runs, name: str = "runs") -> np.ndarray:
    R = np.asarray(runs, dtype=float)
    if R.ndim == 1:
        R = R[None, :]
    if R.ndim != 2 or R.shape[1] != t.size:
        raise ValueError(
            f"{name} must be a list of records as long as t ({t.size} samples), got shape {R.shape}"
        )
    bad = np.argwhere(~np.isfinite(R))
    if bad.size:
        raise ValueError(f"{name}[{bad[0][0]}][{bad[0][1]}] is not finite")
    return R


def align_runs(
    t: Any,
    runs,
    *,
    trigger: str = "threshold",
    commands=None,
    level: float = 0.5,
    absolute: float | None = None,
    reference: float | str = "median",
    kind: str = "cubic",
) -> AlignedRuns:
    """Shift repeated runs so that their triggers coincide, with sub-sample precision.

    ``t`` is the common sample time of the records (s); ``runs`` a list (or 2-D array) of records.
    ``trigger``:

    * ``"command"`` — the step of each run's recorded command (``commands``, same shape as
      ``runs``) through ``level`` of its height (or ``absolute``);
    * ``"threshold"`` — the run itself rising through ``level`` of its peak height above its first
      samples (or through ``absolute``).

    Each run is re-evaluated at ``t + (trigger − reference)`` by ``kind`` interpolation
    (``"cubic"`` spline — keeps a sharp peak — or ``"linear"``); samples outside the record are
    NaN.  ``reference``: ``"median"`` / ``"first"`` trigger, or a time.
    """
    t = np.asarray(t, dtype=float)
    _record(t, np.zeros_like(t), "t", min_len=2, uniform=False)
    R = _as_runs(t, runs)
    if trigger == "command":
        if commands is None:
            raise ValueError("trigger='command' needs the commands of the runs")
        C = _as_runs(t, commands, "commands")
        if C.shape != R.shape:
            raise ValueError(f"commands have shape {C.shape}, runs {R.shape}")
        trig = np.array([trigger_time(t, c, level=level, absolute=absolute) for c in C])
    elif trigger == "threshold":
        trig = np.array([trigger_time(t, r, level=level, absolute=absolute) for r in R])
    else:
        raise ValueError(f"trigger must be 'command' or 'threshold', got {trigger!r}")
    if np.any(~np.isfinite(trig)):
        raise ValueError(f"run {int(np.flatnonzero(~np.isfinite(trig))[0])} never crosses its trigger level")
    if reference == "median":
        ref = float(np.median(trig))
    elif reference == "first":
        ref = float(trig[0])
    elif isinstance(reference, (int, float)):
        ref = float(reference)
    else:
        raise ValueError(f"reference must be 'median', 'first' or a time, got {reference!r}")
    out = np.full(R.shape, np.nan)
    for i, r in enumerate(R):
        tq = t + (trig[i] - ref)
        inside = (tq >= t[0]) & (tq <= t[-1])
        if kind == "cubic":
            from scipy.interpolate import CubicSpline

            out[i, inside] = CubicSpline(t, r)(tq[inside])
        elif kind == "linear":
            out[i, inside] = np.interp(tq[inside], t, r)
        else:
            raise ValueError(f"kind must be 'cubic' or 'linear', got {kind!r}")
    return AlignedRuns(t, out, trig, ref)


@dataclass(frozen=True)
class RunAverage:
    """Sample-by-sample mean of runs (NaN-aware), its spread and how many runs cover each sample."""

    t: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    count: np.ndarray
    aligned: AlignedRuns | None = None

    @property
    def peak(self) -> float:
        """Largest value of the mean (over samples covered by at least one run)."""
        return float(np.nanmax(self.mean))


def average_runs(
    t: Any, runs, *, align: bool = True, min_count: int | None = None, **align_kwargs
) -> RunAverage:
    """Average repeated runs, aligned first (:func:`align_runs`, keyword arguments passed on)
    unless ``align=False`` — which reproduces McLean's averaging by sample index.

    Samples covered by fewer than ``min_count`` runs (default: all of them) are NaN in the mean.
    """
    t = np.asarray(t, dtype=float)
    R = _as_runs(t, runs)
    al = align_runs(t, R, **align_kwargs) if align else None
    X = al.runs if al is not None else R
    count = np.sum(np.isfinite(X), axis=0)
    need = X.shape[0] if min_count is None else int(min_count)
    with np.errstate(invalid="ignore"):
        covered = count >= max(need, 1)
        mean = np.full(t.size, np.nan)
        std = np.full(t.size, np.nan)
        if np.any(covered):
            mean[covered] = np.nanmean(X[:, covered], axis=0)
            std[covered] = np.nanstd(X[:, covered], axis=0)
    return RunAverage(t, mean, std, count, al)
