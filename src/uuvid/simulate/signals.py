"""Input signals for thruster and vehicle simulations.

Every signal is a small frozen dataclass.  Calling it on a time array returns the input at those
times, vectorised (no Python loop per sample); ``describe()`` returns a plain dict
(``{"kind": ..., **params}``) fit for reports and JSON, and :func:`signal_from_spec` turns such a
dict back into a signal, so ``signal_from_spec(s.describe()) == s``.  Model files use the same
dicts, e.g. ``{"kind": "step", "amplitude": 24.0, "t0": 0.5}``.

Units are whatever the driven input uses (V for a voltage command, N for a thrust demand, rad/s
for a speed demand); times are in s, frequencies in Hz, phases in rad.

Kinds:

========  ==============================================  =====================================
kind      class                                           value
========  ==============================================  =====================================
constant  ``Constant(value)``                             ``value`` everywhere
step      ``Step(amplitude, t0=0, baseline=0)``           ``baseline`` for t < t0, ``amplitude``
                                                          for t >= t0 (absolute level, not an
                                                          increment)
square    ``Square(low, high, period, duty=0.5, t0=0)``   ``high`` for the first ``duty`` of
                                                          each period from t0, else ``low``;
                                                          ``low`` before t0
sawtooth  ``Sawtooth(low, high, period, t0=0)``           ramps low → high over each period
                                                          from t0, then resets; ``low`` before t0
sine      ``Sine(offset, amplitude, period, phase=0)``    offset + amplitude·sin(2πt/period + phase)
ramp      ``Ramp(start, end, t0, t1)``                    linear start → end on [t0, t1], held
                                                          outside
sweep     ``Sweep(offset, amplitude, f0, f1, t1,          offset + amplitude·sin(phase(t)) with
          method="linear")``                              the frequency going f0 → f1 over
                                                          [0, t1]; ``offset`` outside [0, t1]
sampled   ``Sampled(t_data, u_data, hold="zoh")``         tabulated data, zero-order hold or
                                                          linear; the first value before
                                                          t_data[0], the last after the end
========  ==============================================  =====================================

A NaN in the time array gives NaN at that position for every kind.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

__all__ = [
    "SIGNAL_KINDS",
    "default_step",
    "Constant",
    "Ramp",
    "Sampled",
    "Sawtooth",
    "Signal",
    "Sine",
    "Square",
    "Step",
    "Sweep",
    "signal_from_spec",
]


# --------------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------------


def _real(kind: str, name: str, value: Any) -> float:
    """Coerce a parameter to a finite float, or raise ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(  # noqa: TRY004 - spec files report bad values as ValueError
            f"{kind}: parameter '{name}' must be a real number, got {type(value).__name__} "
            f"{value!r}"
        )
    f = float(value)
    if not math.isfinite(f):
        raise ValueError(f"{kind}: parameter '{name}' must be finite, got {f!r}")
    return f


def _choice(kind: str, name: str, value: Any, allowed: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in allowed:
        raise ValueError(
            f"{kind}: parameter '{name}' must be one of {', '.join(map(repr, allowed))}, "
            f"got {value!r}"
        )
    return value


def _set(obj: object, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


def _snap_cycles(cycles: np.ndarray) -> np.ndarray:
    """Snap cycle counts within rounding error of an integer onto it.

    ``(t - t0) / period`` for a ``t`` that is an exact multiple of the period in decimal
    (``0.3 / 0.1``) can come out as ``2.9999999999999996``; without snapping the sawtooth would
    read ``high`` instead of ``low`` at its reset instants.
    """
    n = np.rint(cycles)
    close = np.abs(cycles - n) <= 1e-12 * np.maximum(1.0, np.abs(cycles))
    return np.where(close, n, cycles)


# --------------------------------------------------------------------------------------------
# base class
# --------------------------------------------------------------------------------------------


class Signal:
    """Base of all input signals.

    Subclasses are frozen dataclasses that set the class attribute ``kind`` and implement
    ``_evaluate(t)`` for a float ndarray ``t``; this base class does the array conversion,
    keeps the shape of ``t`` and propagates NaN times.
    """

    kind: ClassVar[str] = ""

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Value of the signal at times ``t`` (s); an array of the same shape as ``t``."""
        t = np.asarray(t, dtype=float)
        out = np.asarray(self._evaluate(t), dtype=float)
        if out.shape != t.shape:
            out = np.broadcast_to(out, t.shape).copy()
        nan = np.isnan(t)
        if nan.any():
            out = np.where(nan, np.nan, out)
        return out

    def _evaluate(self, t: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def describe(self) -> dict[str, Any]:
        """``{"kind": ..., **parameters}`` with plain Python values (JSON-ready)."""
        d: dict[str, Any] = {"kind": self.kind}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            if not f.init:
                continue
            v = getattr(self, f.name)
            d[f.name] = list(v) if isinstance(v, tuple) else v
        return d


# --------------------------------------------------------------------------------------------
# kinds
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Constant(Signal):
    """``value`` at all times."""

    value: float
    kind: ClassVar[str] = "constant"

    def __post_init__(self) -> None:
        _set(self, "value", _real(self.kind, "value", self.value))

    def _evaluate(self, t: np.ndarray) -> np.ndarray:
        return np.full(t.shape, self.value)


@dataclass(frozen=True)
class Step(Signal):
    """``baseline`` for t < t0, ``amplitude`` for t >= t0.

    ``amplitude`` is the level after the step (not the size of the jump).
    """

    amplitude: float
    t0: float = 0.0
    baseline: float = 0.0
    kind: ClassVar[str] = "step"

    def __post_init__(self) -> None:
        for name in ("amplitude", "t0", "baseline"):
            _set(self, name, _real(self.kind, name, getattr(self, name)))

    def _evaluate(self, t: np.ndarray) -> np.ndarray:
        return np.where(t >= self.t0, self.amplitude, self.baseline)


@dataclass(frozen=True)
class Square(Signal):
    """Square wave starting at ``t0``: ``high`` for the first ``duty`` fraction of every period,
    ``low`` for the rest; ``low`` before ``t0``.  The time average over whole periods is
    ``low + duty·(high - low)``.
    """

    low: float
    high: float
    period: float
    duty: float = 0.5
    t0: float = 0.0
    kind: ClassVar[str] = "square"

    def __post_init__(self) -> None:
        for name in ("low", "high", "period", "duty", "t0"):
            _set(self, name, _real(self.kind, name, getattr(self, name)))
        if self.period <= 0.0:
            raise ValueError(f"square: 'period' must be > 0, got {self.period!r}")
        if not 0.0 < self.duty < 1.0:
            raise ValueError(f"square: 'duty' must satisfy 0 < duty < 1, got {self.duty!r}")

    def _evaluate(self, t: np.ndarray) -> np.ndarray:
        cycles = _snap_cycles((t - self.t0) / self.period)
        phase = cycles - np.floor(cycles)
        # the same rounding tolerance as _snap_cycles, so that t = t0 + (k + duty)·period
        # computed in floating point switches to ``low`` exactly there
        tol = 1e-12 * np.maximum(1.0, np.abs(cycles))
        on = (t >= self.t0) & (phase < self.duty - tol)
        return np.where(on, self.high, self.low)


@dataclass(frozen=True)
class Sawtooth(Signal):
    """Rising ramp from ``low`` (at t0 + k·period) towards ``high``, then an instant reset to
    ``low``; ``low`` before ``t0``.  Values lie in ``[low, high)``.
    """

    low: float
    high: float
    period: float
    t0: float = 0.0
    kind: ClassVar[str] = "sawtooth"

    def __post_init__(self) -> None:
        for name in ("low", "high", "period", "t0"):
            _set(self, name, _real(self.kind, name, getattr(self, name)))
        if self.period <= 0.0:
            raise ValueError(f"sawtooth: 'period' must be > 0, got {self.period!r}")

    def _evaluate(self, t: np.ndarray) -> np.ndarray:
        cycles = _snap_cycles((t - self.t0) / self.period)
        phase = cycles - np.floor(cycles)
        return np.where(t >= self.t0, self.low + (self.high - self.low) * phase, self.low)


@dataclass(frozen=True)
class Sine(Signal):
    """``offset + amplitude·sin(2π·t/period + phase)``; ``phase`` in rad."""

    offset: float
    amplitude: float
    period: float
    phase: float = 0.0
    kind: ClassVar[str] = "sine"

    def __post_init__(self) -> None:
        for name in ("offset", "amplitude", "period", "phase"):
            _set(self, name, _real(self.kind, name, getattr(self, name)))
        if self.period <= 0.0:
            raise ValueError(f"sine: 'period' must be > 0, got {self.period!r}")

    @property
    def frequency_hz(self) -> float:
        return 1.0 / self.period

    @property
    def omega(self) -> float:
        """Angular frequency, rad/s."""
        return 2.0 * math.pi / self.period

    def _evaluate(self, t: np.ndarray) -> np.ndarray:
        return self.offset + self.amplitude * np.sin(self.omega * t + self.phase)


@dataclass(frozen=True)
class Ramp(Signal):
    """``start`` until ``t0``, linear to ``end`` at ``t1``, ``end`` afterwards."""

    start: float
    end: float
    t0: float
    t1: float
    kind: ClassVar[str] = "ramp"

    def __post_init__(self) -> None:
        for name in ("start", "end", "t0", "t1"):
            _set(self, name, _real(self.kind, name, getattr(self, name)))
        if not self.t1 > self.t0:
            raise ValueError(f"ramp: 't1' must be > 't0', got t0={self.t0!r}, t1={self.t1!r}")

    def _evaluate(self, t: np.ndarray) -> np.ndarray:
        frac = np.clip((t - self.t0) / (self.t1 - self.t0), 0.0, 1.0)
        return self.start + (self.end - self.start) * frac


@dataclass(frozen=True)
class Sweep(Signal):
    """Frequency sweep (chirp) ``offset + amplitude·sin(phase(t))`` on ``[0, t1]``.

    The instantaneous frequency goes from ``f0`` at t = 0 to ``f1`` at t = t1 (Hz), linearly
    (``method="linear"``) or geometrically (``method="logarithmic"``, needs f0, f1 > 0).  The
    phase starts at 0, so the signal starts at ``offset``; it is the same waveform as
    ``scipy.signal.chirp(t, f0, t1, f1, method, phi=-90)``.  Outside ``[0, t1]`` the output is
    ``offset`` (the excitation is off).
    """

    offset: float
    amplitude: float
    f0: float
    f1: float
    t1: float
    method: str = "linear"
    kind: ClassVar[str] = "sweep"

    _METHODS: ClassVar[tuple[str, ...]] = ("linear", "logarithmic")

    def __post_init__(self) -> None:
        for name in ("offset", "amplitude", "f0", "f1", "t1"):
            _set(self, name, _real(self.kind, name, getattr(self, name)))
        _choice(self.kind, "method", self.method, self._METHODS)
        if self.t1 <= 0.0:
            raise ValueError(f"sweep: 't1' must be > 0, got {self.t1!r}")
        if self.method == "linear":
            for name in ("f0", "f1"):
                if getattr(self, name) < 0.0:
                    raise ValueError(f"sweep: '{name}' must be >= 0, got {getattr(self, name)!r}")
        else:
            for name in ("f0", "f1"):
                if getattr(self, name) <= 0.0:
                    raise ValueError(
                        f"sweep: '{name}' must be > 0 for a logarithmic sweep, "
                        f"got {getattr(self, name)!r}"
                    )

    def instantaneous_frequency(self, t: np.ndarray | float) -> np.ndarray:
        """Instantaneous frequency (Hz) at ``t``, with ``t`` clamped to ``[0, t1]``."""
        tc = np.clip(np.asarray(t, dtype=float), 0.0, self.t1)
        if self.method == "linear":
            return self.f0 + (self.f1 - self.f0) * tc / self.t1
        return self.f0 * (self.f1 / self.f0) ** (tc / self.t1)

    def _phase(self, t: np.ndarray) -> np.ndarray:
        f0, f1, t1 = self.f0, self.f1, self.t1
        if self.method == "linear":
            return 2.0 * math.pi * (f0 * t + 0.5 * (f1 - f0) * t * t / t1)
        if f0 == f1:
            return 2.0 * math.pi * f0 * t
        beta = math.log(f1 / f0) / t1
        return 2.0 * math.pi * f0 * np.expm1(beta * t) / beta

    def _evaluate(self, t: np.ndarray) -> np.ndarray:
        inside = (t >= 0.0) & (t <= self.t1)
        tc = np.where(inside, t, 0.0)
        return np.where(inside, self.offset + self.amplitude * np.sin(self._phase(tc)), self.offset)


@dataclass(frozen=True)
class Sampled(Signal):
    """Tabulated input ``u_data`` at times ``t_data`` (strictly increasing, finite, ≥ 1 sample).

    ``hold="zoh"``: the last sample at or before t is held (zero-order hold);
    ``hold="linear"``: linear interpolation between samples.  Before ``t_data[0]`` the first
    value is held, after ``t_data[-1]`` the last one.  The data are stored as tuples so the
    signal stays hashable and comparable.
    """

    t_data: tuple[float, ...]
    u_data: tuple[float, ...]
    hold: str = "zoh"
    kind: ClassVar[str] = "sampled"

    _HOLDS: ClassVar[tuple[str, ...]] = ("zoh", "linear")
    _t: np.ndarray = field(init=False, repr=False, compare=False)
    _u: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = self._vector("t_data", self.t_data)
        u = self._vector("u_data", self.u_data)
        _choice(self.kind, "hold", self.hold, self._HOLDS)
        if t.size < 1:
            raise ValueError("sampled: 't_data' must hold at least 1 sample, got 0")
        if u.size != t.size:
            raise ValueError(
                f"sampled: 't_data' and 'u_data' must have the same length, "
                f"got {t.size} and {u.size}"
            )
        bad = np.flatnonzero(np.diff(t) <= 0.0)
        if bad.size:
            i = int(bad[0]) + 1
            raise ValueError(
                f"sampled: 't_data' must be strictly increasing, but t_data[{i}] = {float(t[i])!r} "
                f"<= t_data[{i - 1}] = {float(t[i - 1])!r}"
            )
        t.setflags(write=False)
        u.setflags(write=False)
        _set(self, "t_data", tuple(t.tolist()))
        _set(self, "u_data", tuple(u.tolist()))
        _set(self, "_t", t)
        _set(self, "_u", u)

    @classmethod
    def _vector(cls, name: str, value: Any) -> np.ndarray:
        if isinstance(value, (str, bytes)):
            raise ValueError(  # noqa: TRY004 - spec files report bad values as ValueError
                f"sampled: '{name}' must be a sequence of numbers, got {value!r}"
            )
        try:
            a = np.array(value, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"sampled: '{name}' must be a sequence of numbers ({exc})") from None
        if a.ndim != 1:
            raise ValueError(f"sampled: '{name}' must be one-dimensional, got shape {a.shape}")
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"sampled: '{name}' has a non-finite value at index {i}: {float(a[i])!r}"
            )
        return a

    def _evaluate(self, t: np.ndarray) -> np.ndarray:
        if self.hold == "linear":
            return np.interp(t, self._t, self._u)
        idx = np.searchsorted(self._t, t, side="right") - 1
        return self._u[np.clip(idx, 0, self._u.size - 1)]


# --------------------------------------------------------------------------------------------
# construction from dicts
# --------------------------------------------------------------------------------------------

SIGNAL_KINDS: dict[str, type[Signal]] = {
    cls.kind: cls for cls in (Constant, Step, Square, Sawtooth, Sine, Ramp, Sweep, Sampled)
}


def signal_from_spec(spec: Mapping[str, Any]) -> Signal:
    """Build a signal from ``{"kind": "step", "amplitude": 24.0, ...}``.

    Parameter names are the dataclass fields of the kind (see the module table).  Raises
    ValueError for a missing or unknown ``kind``, an unknown parameter, a missing required
    parameter, or an invalid value — the message names the offending key.
    """
    if not isinstance(spec, Mapping):
        raise TypeError(f"signal spec must be a mapping, got {type(spec).__name__}")
    if "kind" not in spec:
        raise ValueError("signal spec is missing the key 'kind'")
    kind = spec["kind"]
    cls = SIGNAL_KINDS.get(kind) if isinstance(kind, str) else None
    if cls is None:
        raise ValueError(
            f"unknown signal kind {kind!r} for key 'kind'; expected one of "
            f"{', '.join(map(repr, SIGNAL_KINDS))}"
        )
    init_fields = [f for f in dataclasses.fields(cls) if f.init]  # type: ignore[arg-type]
    names = {f.name for f in init_fields}
    params = {k: v for k, v in spec.items() if k != "kind"}
    unknown = [k for k in params if k not in names]
    if unknown:
        raise ValueError(
            f"{kind}: unknown key {unknown[0]!r}; allowed keys are "
            f"{', '.join(repr(f.name) for f in init_fields)}"
        )
    for f in init_fields:
        required = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if required and f.name not in params:
            raise ValueError(f"{kind}: missing required key {f.name!r}")
    return cls(**params)


def default_step(chain):
    """The input ``thruster simulate`` uses when none is given: a step to full forward command in
    the chain's own unit (a PWM ESC: neutral → saturation_high µs; otherwise 0 → 24, e.g. volts
    for McLean's 24 V motor)."""
    from uuvid.thruster.blocks import ESC

    first = chain.blocks[0]
    if isinstance(first, ESC) and first.command_unit == "pwm_us":
        return Step(amplitude=float(first.saturation_high), baseline=float(first.neutral))
    return Step(amplitude=24.0)
