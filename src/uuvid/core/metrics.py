"""Step-response metrics from sampled arrays (pure NumPy).

Definitions follow McLean (1991), who characterised thruster step responses two ways:

* **Speed time constant** — McLean 1991, Table I: time constant = time for the propeller speed
  to reach 63 % of its final value.  Here: the first time the speed reaches ``1 - e⁻¹``
  (63.2 %) of its final (steady) value, counted from zero speed, linearly interpolated between
  samples and measured from ``t[0]`` (:func:`time_constant_rise`).
* **Thrust decay time constant** — McLean 1991, Tables II/III (experimental): time for the initial
  thrust peak to decay to 37 % (``e⁻¹`` = 36.8 %) of its height above the steady state, measured
  from the peak, interpolated (:func:`time_constant_decay`).

The *steady* value of a record is the mean of the samples in the last ``steady_window`` fraction
of its time span (:func:`steady_value`).

Signed responses (a reverse/negative step) are handled by working on magnitudes along the
direction of the response: the direction is the sign of the steady value (or, if that is zero,
of the largest-magnitude sample).  A "peak" is the extreme in that direction and is reported
*signed* (a reverse step with a −30 N overshoot has ``peak_output_thrust == -30``); the time
constants are positive times either way.

All inputs are in SI (s, N, rad/s); the functions validate their arrays (same length, enough
samples, finite, strictly increasing time) and raise ValueError naming the offending index.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "DECAY_FRACTION",
    "RISE_FRACTION",
    "StepMetrics",
    "mean_abs_error",
    "nrmse",
    "peak",
    "response_direction",
    "rmse",
    "steady_value",
    "step_response_metrics",
    "time_constant_decay",
    "time_constant_rise",
    "time_to_fraction",
]

RISE_FRACTION = 1.0 - math.exp(-1.0)  # 0.632…, McLean Table I ("63 %")
DECAY_FRACTION = math.exp(-1.0)  # 0.368…, McLean Tables II/III ("37 %")


# --------------------------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------------------------


def _vector(name: str, a: Any, n: int | None = None, min_len: int = 1) -> np.ndarray:
    arr = np.asarray(a, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if n is not None and arr.size != n:
        raise ValueError(f"{name} has length {arr.size}, expected {n} (the length of t)")
    if arr.size < min_len:
        raise ValueError(f"{name} needs at least {min_len} samples, got {arr.size}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{name} has a non-finite value at index {i}: {float(arr[i])!r}")
    return arr


def _time(t: Any, min_len: int) -> np.ndarray:
    t = _vector("t", t, min_len=min_len)
    bad = np.flatnonzero(np.diff(t) <= 0.0)
    if bad.size:
        i = int(bad[0]) + 1
        raise ValueError(
            f"t must be strictly increasing, but t[{i}] = {float(t[i])!r} <= t[{i - 1}] = {float(t[i - 1])!r}"
        )
    return t


def _record(t: Any, y: Any, name: str = "y", min_len: int = 2) -> tuple[np.ndarray, np.ndarray]:
    tt = _time(t, min_len)
    return tt, _vector(name, y, tt.size, min_len)


def _check_window(steady_window: float) -> float:
    w = float(steady_window)
    if not 0.0 < w <= 1.0:
        raise ValueError(
            f"steady_window must satisfy 0 < steady_window <= 1, got {steady_window!r}"
        )
    return w


# --------------------------------------------------------------------------------------------
# pure building blocks
# --------------------------------------------------------------------------------------------


def steady_value(t: Any, y: Any, window: float = 0.1) -> float:
    """Mean of ``y`` over the samples with ``t >= t[-1] - window·(t[-1] - t[0])``.

    ``window`` is a fraction of the record's time span (0 < window <= 1); the last sample is
    always included.
    """
    t, y = _record(t, y, min_len=1)
    w = _check_window(window)
    start = t[-1] - w * (t[-1] - t[0])
    return float(np.mean(y[t >= start]))


def response_direction(y: Any, steady: float | None = None) -> float:
    """+1.0 or -1.0: sign of ``steady``, or if that is None/zero of the largest-|y| sample.

    An all-zero record counts as positive.
    """
    y = _vector("y", y)
    if steady is not None and steady != 0.0:
        return 1.0 if steady > 0.0 else -1.0
    extreme = y[int(np.argmax(np.abs(y)))]
    return -1.0 if extreme < 0.0 else 1.0


def peak(t: Any, y: Any, direction: float | None = None) -> tuple[float, float]:
    """``(value, time)`` of the extreme of ``y`` in ``direction`` (default: the sign of the
    record's largest-magnitude sample); ``time`` is measured from ``t[0]``, first occurrence on a
    plateau.  ``value`` is signed.
    """
    t, y = _record(t, y, min_len=1)
    s = response_direction(y) if direction is None else (-1.0 if direction < 0 else 1.0)
    i = int(np.argmax(s * y))
    return float(y[i]), float(t[i] - t[0])


def time_to_fraction(
    t: Any,
    y: Any,
    fraction: float,
    final: float,
    initial: float = 0.0,
) -> float:
    """First time (from ``t[0]``) at which ``y`` has covered ``fraction`` of the way from
    ``initial`` to ``final``, linearly interpolated between samples.

    Works on magnitudes along the direction of ``final - initial``.  Returns 0.0 if the first
    sample already qualifies and NaN if the level is never reached or ``final == initial``.
    """
    t, y = _record(t, y)
    span = float(final) - float(initial)
    if span == 0.0 or not math.isfinite(span):
        return math.nan
    s = 1.0 if span > 0.0 else -1.0
    v = s * (y - initial)
    target = fraction * abs(span)
    hit = np.flatnonzero(v >= target)
    if hit.size == 0:
        return math.nan
    i = int(hit[0])
    if i == 0:
        return 0.0
    t_cross = t[i - 1] + (target - v[i - 1]) / (v[i] - v[i - 1]) * (t[i] - t[i - 1])
    return float(t_cross - t[0])


def time_constant_rise(
    t: Any,
    y: Any,
    final: float | None = None,
    initial: float = 0.0,
    steady_window: float = 0.1,
) -> float:
    """McLean 1991 Table I time constant: first time ``y`` reaches 63.2 % (1 − e⁻¹) of its final
    value, counted from ``initial`` (0 by default, as in McLean's start-from-rest tests),
    interpolated, measured from ``t[0]``.  ``final`` defaults to :func:`steady_value`.
    NaN if never reached.
    """
    if final is None:
        final = steady_value(t, y, steady_window)
    return time_to_fraction(t, y, RISE_FRACTION, final, initial)


def time_constant_decay(
    t: Any,
    y: Any,
    steady: float | None = None,
    steady_window: float = 0.1,
) -> float:
    """McLean 1991 Tables II/III time constant: time from the output peak until the transient
    has decayed to 36.8 % (e⁻¹) of the peak's height above the steady state, interpolated.

    ``steady`` defaults to :func:`steady_value` over the last ``steady_window``.  The peak is
    the extreme in the direction of the response (signed responses work on magnitudes).
    Returns NaN when there is no decaying peak: the peak does not rise above the steady state,
    it lies inside the steady window, or the record ends before the decay.
    """
    t, y = _record(t, y)
    w = _check_window(steady_window)
    if steady is None:
        steady = steady_value(t, y, w)
    s = response_direction(y, steady)
    v = s * (y - steady)
    p = int(np.argmax(s * y))
    height = v[p]
    if not height > 0.0:
        return math.nan
    if t[p] >= t[-1] - w * (t[-1] - t[0]):  # the peak is part of the steady state
        return math.nan
    target = DECAY_FRACTION * height
    after = np.flatnonzero(v[p + 1 :] <= target)
    if after.size == 0:
        return math.nan
    i = p + 1 + int(after[0])
    t_cross = t[i - 1] + (v[i - 1] - target) / (v[i - 1] - v[i]) * (t[i] - t[i - 1])
    return float(t_cross - t[p])


# --------------------------------------------------------------------------------------------
# the step-response summary
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StepMetrics:
    """Step-response summary, all SI (N, rad/s, s); NaN where a metric does not apply.

    Attributes:
        peak_output_thrust: signed extreme of the output thrust (measured if given, else true)
            in the direction of the response.
        max_true_thrust: signed extreme of the true thrust in the direction of the response.
        steady_thrust: mean output thrust over the last ``steady_window`` of the record.
        steady_speed: mean speed over the same window (NaN without speed).
        time_to_peak: time of ``peak_output_thrust`` from ``t[0]``.
        time_constant_speed: McLean Table I, 63.2 % of the final speed, from ``t[0]``.
        time_constant_decay: McLean Tables II/III, output peak decays to 36.8 % of its height
            above steady, from the peak.
    """

    peak_output_thrust: float
    max_true_thrust: float
    steady_thrust: float
    steady_speed: float
    time_to_peak: float
    time_constant_speed: float
    time_constant_decay: float

    def as_dict(self, nan_as_none: bool = False) -> dict[str, float | None]:
        """Field name → value (SI).  ``nan_as_none=True`` maps NaN to None for strict JSON."""
        d: dict[str, float | None] = dataclasses.asdict(self)
        if nan_as_none:
            d = {k: (None if v is None or math.isnan(v) else v) for k, v in d.items()}
        return d


#: Unit of each :class:`StepMetrics` field (for tables that print them).
STEP_METRIC_UNITS = {"peak_output_thrust": "N", "max_true_thrust": "N", "steady_thrust": "N",
                     "steady_speed": "rad/s", "time_to_peak": "s", "time_constant_speed": "s",
                     "time_constant_decay": "s"}


def step_response_metrics(
    t: Any,
    thrust_true: Any,
    thrust_measured: Any | None = None,
    speed: Any | None = None,
    steady_window: float = 0.1,
) -> StepMetrics:
    """Summarise a thrust (and optionally speed) step response.

    ``t`` (s) must be strictly increasing; every given array must have the length of ``t``
    (≥ 3 samples) and be finite.  The *output* thrust is ``thrust_measured`` if given (what a
    load cell reads, as in McLean's experiments), else ``thrust_true``; ``peak_output_thrust``,
    ``steady_thrust``, ``time_to_peak`` and ``time_constant_decay`` refer to it.  See
    :class:`StepMetrics` and the module docstring for the definitions and signed responses.
    """
    t = _time(t, min_len=3)
    w = _check_window(steady_window)
    true = _vector("thrust_true", thrust_true, t.size, 3)
    meas = (
        None if thrust_measured is None else _vector("thrust_measured", thrust_measured, t.size, 3)
    )
    spd = None if speed is None else _vector("speed", speed, t.size, 3)

    out = true if meas is None else meas
    steady_out = steady_value(t, out, w)
    peak_out, t_peak = peak(t, out, response_direction(out, steady_out))
    peak_true, _ = peak(t, true, response_direction(true, steady_value(t, true, w)))
    tau_decay = time_constant_decay(t, out, steady_out, w)

    if spd is None:
        steady_spd = tau_speed = math.nan
    else:
        steady_spd = steady_value(t, spd, w)
        tau_speed = time_constant_rise(t, spd, final=steady_spd, initial=0.0)

    return StepMetrics(
        peak_output_thrust=peak_out,
        max_true_thrust=peak_true,
        steady_thrust=steady_out,
        steady_speed=steady_spd,
        time_to_peak=t_peak,
        time_constant_speed=tau_speed,
        time_constant_decay=tau_decay,
    )


# --------------------------------------------------------------------------------------------
# error measures
# --------------------------------------------------------------------------------------------


def _pair(a: Any, b: Any) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"a and b must have the same shape, got {a.shape} and {b.shape}")
    if a.size == 0:
        raise ValueError("a and b must not be empty")
    for name, arr in (("a", a), ("b", b)):
        bad = np.argwhere(~np.isfinite(arr))
        if bad.size:
            i = tuple(int(k) for k in bad[0])
            idx = i[0] if len(i) == 1 else i
            raise ValueError(f"{name} has a non-finite value at index {idx}: {float(arr[i])!r}")
    return a, b


def rmse(a: Any, b: Any) -> float:
    """Root-mean-square error ``sqrt(mean((a - b)²))``."""
    a, b = _pair(a, b)
    return float(np.sqrt(np.mean((a - b) ** 2)))


def mean_abs_error(a: Any, b: Any) -> float:
    """Mean absolute error ``mean(|a - b|)``."""
    a, b = _pair(a, b)
    return float(np.mean(np.abs(a - b)))


def nrmse(a: Any, b: Any, by: str = "range") -> float:
    """RMSE of ``a`` against the reference ``b``, normalised by a scale of ``b``.

    ``by="range"``: ``max(b) - min(b)`` (default); ``"rms"``: ``sqrt(mean(b²))``;
    ``"std"``: ``std(b)``.  Raises ValueError when that scale is zero.
    """
    a, b = _pair(a, b)
    if by == "range":
        scale = float(np.max(b) - np.min(b))
    elif by == "rms":
        scale = float(np.sqrt(np.mean(b**2)))
    elif by == "std":
        scale = float(np.std(b))
    else:
        raise ValueError(f"by must be 'range', 'rms' or 'std', got {by!r}")
    if scale == 0.0:
        raise ValueError(f"nrmse: the reference b has zero {by}; cannot normalise")
    return float(np.sqrt(np.mean((a - b) ** 2))) / scale
