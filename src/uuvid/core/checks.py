"""Checks of single numbers a caller passes (an option's value, a keyword argument), before any
work: ``ValueError`` whose message starts with the parameter's name (``name = value: expected
…``), so a command line can name its option instead (:func:`uuvid.cli.common._flagged`)."""

from __future__ import annotations

import math
from contextlib import contextmanager
from contextvars import ContextVar


def _num(name: str, value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r}: expected a number") from None


def finite(name: str, value, unit: str = "") -> float:
    """``value`` as a float; ``ValueError`` for NaN or ±inf."""
    v = _num(name, value)
    if not math.isfinite(v):
        raise ValueError(f"{name} = {v:g}: expected a finite number{f' ({unit})' if unit else ''}")
    return v


def positive(name: str, value, unit: str = "") -> float:
    """``value`` as a finite float > 0."""
    v = _num(name, value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} = {v:g}: expected a finite number > 0"
                         + (f" ({unit})" if unit else ""))
    return v


def non_negative(name: str, value, unit: str = "") -> float:
    """``value`` as a finite float >= 0."""
    v = _num(name, value)
    if not (math.isfinite(v) and v >= 0):
        raise ValueError(f"{name} = {v:g}: expected a finite number >= 0"
                         + (f" ({unit})" if unit else ""))
    return v


#: a supply voltage above this [V] is in millivolts (no thruster runs on a kilovolt supply); the
#: bound ``thruster fit`` applies to a bench file's voltage too (``uuvid.identify.plausibility``)
MAX_PLAUSIBLE_VOLTAGE = 1000.0
#: a water current faster than this (m/s) is a unit slip (cm/s, knots ×2): the strongest tidal
#: races run at about 5 m/s
MAX_CURRENT_MPS = 6.0
#: most RK4 steps per output sample or control step (a thruster chain's, a mission's, the Gym
#: env's, a dynamic fit's): finer than ``dt / 10⁴`` buys RK4 no accuracy, only time
MAX_SUBSTEPS = 10_000


def state_of_charge(name: str, value) -> float:
    """A battery's state of charge as given (``soc``, ``soc0``, ``--battery``): a number within
    0..1 (text raised a bare ``TypeError`` from ``math.isfinite``; 1.5 ran a battery over full)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r}: expected a state of charge within 0..1 "
                         "(a number)") from None
    if not (math.isfinite(v) and 0.0 <= v <= 1.0):
        raise ValueError(f"{name} = {v:g}: expected a state of charge within 0..1")
    return v


#: a vertical water velocity beyond this (m/s) is no ocean current: up- and downwelling run at
#: mm/s to cm/s, convective plumes, breaking internal waves and flows over sills at a few tenths of
#: a m/s; more is a horizontal speed in the down slot, or cm/s
MAX_VERTICAL_CURRENT_MPS = 1.0


def vertical_current(name: str, down: float) -> float:
    """``down`` (m/s, NED: positive flowing down) of a water current, or ``ValueError`` naming
    ``name`` (``""``: where the caller's message already names it) when it is beyond
    :data:`MAX_VERTICAL_CURRENT_MPS` either way."""
    w = float(down)
    if abs(w) > MAX_VERTICAL_CURRENT_MPS:
        raise ValueError(f"{name + ': ' if name else ''}{w:g} m/s: a vertical current beyond "
                         f"{MAX_VERTICAL_CURRENT_MPS:g} m/s is not an ocean current (up- and "
                         "downwelling run at mm/s to cm/s, the strongest plumes and flows over "
                         "sills at a few tenths of a m/s): is it a horizontal speed, or cm/s? "
                         "expected the vertical velocity in m/s, positive down")
    return w


def current_speed(name: str, speed: float) -> float:
    """``speed`` (m/s) of a water current, or ``ValueError`` naming ``name`` when it is faster than
    :data:`MAX_CURRENT_MPS` (a simulation then only 'diverges', blamed on its step)."""
    v = float(speed)
    if v > MAX_CURRENT_MPS:
        raise ValueError(f"{name}: a current of {v:g} m/s is faster than any sea or river current "
                         f"(the strongest tidal races run at about 5 m/s; at most "
                         f"{MAX_CURRENT_MPS:g} m/s): is it in cm/s? expected m/s")
    return v


class InputWarning(UserWarning):
    """A value that is valid but most likely not what was meant (a unit slip)."""


def direction_deg(name: str, value) -> float:
    """A direction in degrees, finite, returned within [0, 360): one outside (400, −90) is the
    same direction modulo 360° and is taken so, with an :class:`InputWarning` saying the value
    given and the value used (400 was printed as 400° and flown as 40°); warns too when it is a
    quarter, half, … turn written in radians (1.57, 3.14, 0.785: degrees that small are nearly
    head-on, and a direction in radians was flown as that).

    Check a value once, where the user gives it: a function that receives one already checked
    (from a command line option, a scenario file, a public function passing it on) takes a
    private path that does not check it again (``hold._max_current`` beside ``hold.max_current``),
    or the user reads the same warning two or three times."""
    import warnings

    v = finite(name, value, "deg")
    used = v % 360.0
    if used >= 360.0 - 1e-9:  # a tiny negative value (−1e-9) is a full turn short of 0: it is 0
        used = 0.0
    said = []
    k = round(abs(v) / (math.pi / 4))
    if v != round(v) and 1 <= k <= 8 and abs(abs(v) - k * math.pi / 4) < 0.01:
        frac = {1: "π/4", 2: "π/2", 3: "3π/4", 4: "π", 5: "5π/4", 6: "3π/2", 7: "7π/4", 8: "2π"}[k]
        said.append(f"that is {'−' if v < 0 else ''}{frac} in radians ({math.copysign(45 * k, v):g}°)"
                    " — is it in radians? degrees are expected")
    if not 0.0 <= v < 360.0:  # (within 1e-9 below 360 it is taken as 0, the same direction)
        said.append("outside [0, 360°), the same direction modulo 360°")
    if said:
        shown = f"{used:g}"
        if shown == "360":  # 359.9999 (from −1e-4) is not a full turn: said with its digits
            shown = f"{used:.12g}"
        warnings.warn(f"{name} = {v:g}°: {'; '.join(said)}; taken as {shown}°", InputWarning,
                      stacklevel=2)
    return used


def supply_voltage(name: str, value) -> float:
    """A supply voltage [V]: finite, > 0 and at most :data:`MAX_PLAUSIBLE_VOLTAGE` (above it
    the number is in millivolts)."""
    v = positive(name, value, "V")
    if v > MAX_PLAUSIBLE_VOLTAGE:
        raise ValueError(f"{name} = {v:g} V: above {MAX_PLAUSIBLE_VOLTAGE:g} V, beyond any "
                         "thruster's supply (millivolts?); expected a battery voltage in V")
    return v


def seconds_or_none(**values) -> None:
    """``TypeError`` naming the keyword argument when one of ``values`` is neither ``None`` nor a
    real number (``t_start="10"`` from a script raised a bare comparison error deep in the
    reader): ``t_start = '10': expected a number of seconds (int or float) or None, got str``."""
    import numbers

    for name, v in values.items():
        if v is not None and (isinstance(v, bool) or not isinstance(v, numbers.Real)):
            raise TypeError(f"{name} = {v!r}: expected a number of seconds (int or float) or "
                            f"None, got {type(v).__name__}")


def real(name: str, value, what: str = "a number", *, integer: bool = False):
    """``value`` unchanged, or ``TypeError`` naming ``name`` when it is not a real number (a string
    ``"0.3"``, ``None``, a bool): a keyword argument of the Python API given as text was stored
    as given and failed far from the call (``square_mission(speed="0.3")`` raised ``unsupported
    operand type(s) for /: 'float' and 'str'`` when the mission was set up).  ``what`` says what is
    expected (``"a finite number of seconds"``); ``integer``: an integral number is expected
    (a float with a fractional part is a ``ValueError``)."""
    import numbers

    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} = {value!r}: expected {what} (an int or float), got "
                        f"{type(value).__name__}")
    if integer and not isinstance(value, numbers.Integral) and not (
            math.isfinite(value) and value == int(value)):
        raise ValueError(f"{name} = {value!r}: expected {what}, a whole number")
    return value


_AS_OPTIONS: ContextVar[bool] = ContextVar("uuvid_messages_name_options", default=False)


@contextmanager
def as_options():
    """Inside a command: the messages of :func:`arg`/:func:`arg_is` name its options
    (``--t-end``), as the user typed them; outside, a Python caller's keyword arguments
    (``t_end``) — ``identify_dive(t_end=30)`` was told to "widen --t-start/--t-end"."""
    token = _AS_OPTIONS.set(True)
    try:
        yield
    finally:
        _AS_OPTIONS.reset(token)


def arg(name: str, option: str | None = None) -> str:
    """``--t-end`` inside :func:`as_options` (a command; ``option`` where it is not the name's
    spelling: ``dofs`` → ``--dof``), ``t_end`` for a Python caller."""
    return (option or "--" + name.replace("_", "-")) if _AS_OPTIONS.get() else name


def arg_is(name: str, value: str, option: str | None = None) -> str:
    """``--t-end 30`` inside :func:`as_options` (a command), ``t_end=30`` for a Python caller."""
    return f"{arg(name, option)} {value}" if _AS_OPTIONS.get() else f"{name}={value}"


def time_window(t_start=None, t_end=None, horizon=None, *, error=ValueError,
                named: bool = False) -> None:
    """A log's time bounds and window length as given (``None``: not given): finite times, an
    end after the start, a window > 0 s; ``error`` (a ``ValueError`` type) naming the options
    ``--t-start``, ``--t-end``, ``--horizon`` as the dive commands spell them, or with
    ``named`` as the caller gave them (:func:`arg_is`: ``t_end=`` from Python)."""
    def say(name: str, v) -> str:
        return arg_is(name, f"{float(v):g}") if named else f"--{name.replace('_', '-')} {float(v):g}"

    for name, v in (("t_start", t_start), ("t_end", t_end)):
        if v is not None and not math.isfinite(_num("--" + name.replace("_", "-"), v)):
            raise error(f"{say(name, v)}: expected a finite time in s (leave it out for "
                        "the log's " + ("start" if name == "t_start" else "end") + ")")
    if t_start is not None and t_end is not None and float(t_end) <= float(t_start):
        raise error(f"{say('t_end', t_end)} s must be after {say('t_start', t_start)} s")
    if horizon is not None and not (math.isfinite(_num("--horizon", horizon))
                                    and float(horizon) > 0):
        raise error(f"{say('horizon', horizon)}: expected a window length > 0 s (leave it "
                    "out for the default of each DOF)")


def physical_memory_bytes() -> float:
    """This machine's physical memory (4 GB when the system does not say)."""
    import os

    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return 4e9


def memory_budget_bytes() -> float:
    """Most memory one result (a study's table, an exported log) may take: half of
    :func:`physical_memory_bytes`, the rest left to the process and the machine."""
    return 0.5 * physical_memory_bytes()


def count(name: str, value, what: str = "a whole number", *, minimum: int = 1,
          maximum: int | None = None, hint: str = "") -> int:
    """``value`` as an int: ``TypeError`` naming ``name`` when it is not a real number (``"2"``,
    ``None``), ``ValueError`` for a fractional one (``2.5`` was truncated to 2 without a word) or
    one outside ``[minimum, maximum]`` (``hint``: what to do about a too large one)."""
    real(name, value, what, integer=True)
    n = int(value)
    if n < minimum:
        raise ValueError(f"{name} = {value!r}: expected {what} >= {minimum}")
    if maximum is not None and n > maximum:
        raise ValueError(f"{name} = {n:,}: expected {what} of at most {maximum:,}"
                         + (f"; {hint}" if hint else ""))
    return n


def of_type(name: str, value, types, expected: str):
    """``value`` unchanged, or ``TypeError`` naming ``name`` and ``expected`` when it is not an
    instance of ``types`` (an object of another type failed later with an ``AttributeError``
    that named neither)."""
    if not isinstance(value, types):
        raise TypeError(f"{name}: expected {expected}, got {type(value).__name__} {value!r:.80}")
    return value


def finite_values(name: str, value, shape: tuple | None = None, what: str = "finite numbers"):
    """``value`` as a float array of ``shape`` (``None``: any) whose entries are all finite, or
    ``ValueError`` naming the first that is not (``current[0] = nan: expected finite numbers``)
    or the shape it should have."""
    import numpy as np

    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r}: expected {what}") from None
    if shape is not None and a.shape != tuple(shape):
        want = " × ".join(str(k) for k in shape) if len(shape) != 1 else f"{shape[0]} component(s)"
        raise ValueError(f"{name} has shape {a.shape}: expected {want} ({what})")
    if a.ndim == 0:
        if not np.isfinite(a):
            raise ValueError(f"{name} = {float(a):g}: expected {what}")
        return a
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i = tuple(int(k) for k in bad[0])
        raise ValueError(f"{name}[{', '.join(map(str, i))}] = {float(a[i]):g}: expected {what}")
    return a
