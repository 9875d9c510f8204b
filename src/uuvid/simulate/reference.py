"""Reference generation for dynamic positioning: waypoints flown along straight lines.

A mission is a list of waypoints ``(north, east, down, yaw)`` flown in order at a cruising speed
(horizontal) and a vertical speed, each leg a straight line at constant speed (trapezoid-free,
with the speed ramped over ``ramp_time`` at each leg's start and end so the reference velocity has no
jumps the vehicle cannot follow).  Heading either follows the path (``yaw="path"``) or is held per
waypoint.  Everything is evaluated on a whole time grid at once (pure NumPy): the compiled
simulator reads the arrays.

Laidani et al. §5 mission: dive 2 m, fly a 10 × 10 m square, return to the surface, cruising at
0.5 m/s — :func:`square_mission`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uuvid.core.checks import finite, non_negative, positive, real


@dataclass(frozen=True)
class Leg:
    start: np.ndarray  # (4,) n, e, d, yaw
    end: np.ndarray
    t0: float
    duration: float


#: a waypoint may sit this far (m) above the surface (a vehicle floating high); higher is a sign slip
MAX_ABOVE_SURFACE_M = 0.5
#: a waypoint's yaw may pass ±2π by this much (rad: 2π written to a few decimals, 6.2832)
YAW_SLACK_RAD = 1e-3


def waypoint_problem(k: int, down: float, yaw: float) -> str | None:
    """Why waypoint ``k`` cannot be what a mission means, or None: above the surface (down <
    −:data:`MAX_ABOVE_SURFACE_M`; NED, down positive) or a yaw beyond ±2π (degrees given).  One
    rule for :class:`WaypointMission` and the scenario file."""
    if down < -MAX_ABOVE_SURFACE_M:
        return (f"waypoint {k} is at down = {down:g} m, {-down:g} m above the surface: down is "
                "positive (NED; depth 5 m is down = 5)")
    if abs(yaw) > 2 * math.pi + YAW_SLACK_RAD:
        return f"waypoint {k} has yaw {yaw:g}: beyond ±2π rad — is it in degrees? expected radians"
    return None


@dataclass(frozen=True)
class WaypointMission:
    """Straight legs between waypoints; ``duration`` includes a final hold."""

    waypoints: tuple[tuple[float, float, float, float], ...]
    speed: float = 0.5  # m/s, horizontal cruising speed
    vertical_speed: float = 0.25  # m/s
    yaw_rate: float = 0.3  # rad/s, for pure turns
    ramp_time: float = 2.0  # s, speed ramp at each leg's start and end
    hold: float = 10.0  # s, final station keeping
    name: str = "mission"
    note: str = ""  # where a default came from (e.g. the cruising speed chosen for the vehicle)

    def __post_init__(self):
        if len(self.waypoints) < 2:
            raise ValueError("a mission needs at least two waypoints")
        for i, w in enumerate(self.waypoints):
            for j, v in enumerate(w):  # text ("2") passed float() and was flown as given
                real(f"waypoints[{i}][{j}]", v, "a finite number: north, east, down [m], yaw [rad]")
            if len(w) != 4 or not all(math.isfinite(float(v)) for v in w):
                raise ValueError(f"waypoint {i} must be 4 finite numbers (north, east, down, yaw), got {w!r}")
            # a mission above the water flew to "completed" (square_mission(depth=-2), a waypoint
            # at down = -5 meant as 5 m deep)
            why = waypoint_problem(i, float(w[2]), float(w[3]))
            if why:
                raise ValueError(why)
        # a NaN passed these as comparisons and failed deep in the reference or the flight; text
        # ("0.3") passed float() and was stored as given, failing when the mission was set up
        for name, unit in (("speed", "m/s"), ("vertical_speed", "m/s"), ("yaw_rate", "rad/s")):
            positive(name, real(name, getattr(self, name), f"a finite number > 0 in {unit}"), unit)
        for name in ("ramp_time", "hold"):
            non_negative(name, real(name, getattr(self, name), "a finite number of seconds >= 0"), "s")

    def legs(self) -> list[Leg]:
        legs, t = [], 0.0
        wps = [np.asarray(w, dtype=float) for w in self.waypoints]
        for a, b in zip(wps[:-1], wps[1:]):
            dh = math.hypot(b[0] - a[0], b[1] - a[1])
            dv = abs(b[2] - a[2])
            dyaw = abs(_wrap(b[3] - a[3]))
            dur = max(dh / self.speed, dv / self.vertical_speed, dyaw / self.yaw_rate, 1e-9)
            dur += self.ramp_time  # ramps add half a ramp at each end
            legs.append(Leg(a, b, t, dur))
            t += dur
        return legs

    @property
    def duration(self) -> float:
        legs = self.legs()
        return legs[-1].t0 + legs[-1].duration + self.hold

    def __call__(self, t: np.ndarray):
        """Reference position (N,3), velocity (N,3) in NED, yaw (N,) and yaw rate (N,) at times t."""
        t = np.asarray(t, dtype=float)
        pos = np.empty((t.size, 3))
        vel = np.zeros((t.size, 3))
        yaw = np.empty(t.size)
        rate = np.zeros(t.size)
        legs = self.legs()
        last = legs[-1]
        pos[:] = last.end[:3]
        yaw[:] = last.end[3]
        for leg in legs:
            m = (t >= leg.t0) & (t < leg.t0 + leg.duration)
            if not np.any(m):
                continue
            s, ds = _progress(t[m] - leg.t0, leg.duration, self.ramp_time)
            d = leg.end - leg.start
            dyaw = _wrap(d[3])
            pos[m] = leg.start[:3] + s[:, None] * d[:3]
            vel[m] = ds[:, None] * d[:3]
            yaw[m] = leg.start[3] + s * dyaw
            rate[m] = ds * dyaw
        before = t < legs[0].t0
        pos[before] = legs[0].start[:3]
        yaw[before] = legs[0].start[3]
        return pos, vel, _wrap(yaw), rate


def _progress(tau: np.ndarray, duration: float, ramp: float):
    """Fraction s(τ) ∈ [0, 1] of a leg with a linear speed ramp of length ``ramp`` at both ends."""
    r = min(ramp, duration / 2.0)
    cruise = duration - r  # area under the speed profile in units of peak speed × time
    v = 1.0 / cruise  # peak ds/dt
    s = np.empty_like(tau)
    ds = np.empty_like(tau)
    a = tau < r
    if r > 0:
        s[a] = 0.5 * v * tau[a] ** 2 / r
        ds[a] = v * tau[a] / r
    b = (tau >= r) & (tau <= duration - r)
    s[b] = 0.5 * v * r + v * (tau[b] - r)
    ds[b] = v
    c = tau > duration - r
    if r > 0:
        rem = duration - tau[c]
        s[c] = 1.0 - 0.5 * v * rem**2 / r
        ds[c] = v * rem / r
    return np.clip(s, 0.0, 1.0), ds


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def square_mission(depth: float = 2.0, side: float = 10.0, speed: float = 0.5,
                   vertical_speed: float = 0.25, yaw: str = "path", hold: float = 10.0) -> WaypointMission:
    """Laidani et al.'s mission: dive ``depth``, fly a ``side`` × ``side`` square, surface.

    ``yaw="path"`` turns the vehicle to face each side before flying it (turns in place, as an ROV
    does); ``yaw="fixed"`` keeps heading north and flies sideways/backwards.
    """
    if yaw not in ("path", "fixed"):
        raise ValueError(f"yaw must be 'path' or 'fixed', got {yaw!r}")
    # every number checked here, at the call (text "2" failed in a comparison, "0.3" when the
    # mission was set up; WaypointMission checks speed, vertical_speed and hold again, the same way)
    real("depth", depth, "a finite depth >= 0 in m")
    finite("side", real("side", side, "a finite side length in m"), "m")
    real("speed", speed, "a finite number > 0 in m/s")
    real("vertical_speed", vertical_speed, "a finite number > 0 in m/s")
    real("hold", hold, "a finite number of seconds >= 0")
    if not (depth >= 0 and math.isfinite(depth)):  # NaN too
        raise ValueError(f"depth = {depth:g} m: expected >= 0 and finite (down positive; depth 2 m "
                         "is 2)")
    corners = [(0.0, 0.0), (side, 0.0), (side, side), (0.0, side), (0.0, 0.0)]
    heads = [0.0, math.pi / 2, math.pi, -math.pi / 2]
    wps = [(0.0, 0.0, 0.0, 0.0), (0.0, 0.0, depth, 0.0)]
    for k in range(4):
        h = heads[k] if yaw == "path" else 0.0
        n0, e0 = corners[k]
        n1, e1 = corners[k + 1]
        if wps[-1][3] != h:
            wps.append((n0, e0, depth, h))  # turn in place
        wps.append((n1, e1, depth, h))
    wps.append((0.0, 0.0, depth, 0.0))
    wps.append((0.0, 0.0, 0.0, 0.0))
    return WaypointMission(tuple(wps), speed=speed, vertical_speed=vertical_speed, hold=hold,
                           name=f"square {side:g} m at {depth:g} m")


#: Cruising speed of a mission that does not set one (m/s): Laidani et al.'s square.
NOMINAL_SPEED = 0.5
#: Fraction of the level-flight limit a default cruising speed keeps to.
LEVEL_MARGIN = 0.8


#: Slowest default cruising speed (m/s): below it the mission is not worth flying by default.
MIN_SPEED = 0.1


def cruise_speed(vehicle, facing_path: bool = True, current_speed: float = 0.0) -> tuple[float, str]:
    """Default cruising speed for ``vehicle`` and why: :data:`NOMINAL_SPEED`, or lower when the
    speed through the water (cruise + ``current_speed``, the worst leg) would pass
    :data:`LEVEL_MARGIN` × the speed at which the vehicle can no longer stay level
    (:func:`uuvid.vehicle.stability.static_stability`) in the directions the mission flies
    (forward/backward when the vehicle faces its path, every horizontal one if not).
    The BlueROV2 pitches past 20° above 0.48 m/s: its default is 0.38 m/s in still water."""
    if vehicle is None:
        return NOMINAL_SPEED, ""
    dirs = ("forward", "backward") if facing_path else ("forward", "backward", "starboard", "port")
    lim = level_speed_limit(vehicle, dirs)
    cur = float(current_speed)
    if lim is None and hasattr(vehicle, "params"):
        from uuvid.vehicle.definition import no_drag_dofs

        free = [("surge", "sway")[d] for d in no_drag_dofs(vehicle.params) if d < (1 if facing_path
                                                                                    else 2)]
        if free:  # no drag: stability has no speed range to scan, "stays level" is not known
            return NOMINAL_SPEED, (f"speed {NOMINAL_SPEED:g} m/s (nominal; whether the vehicle "
                                   f"stays level is not known: the vehicle file gives no drag in "
                                   f"{', '.join(free)}, so it has no steady speed and no level-"
                                   "flight limit — give its damping)")
    if lim is None or LEVEL_MARGIN * lim - cur >= NOMINAL_SPEED:
        return NOMINAL_SPEED, f"speed {NOMINAL_SPEED:g} m/s (nominal; the vehicle stays level there)"
    name = getattr(vehicle, "name", "vehicle")
    if cur >= lim:  # no cruising speed keeps it level: say so (CANNOT_FLY), no formula for the floor
        top = top_speed(vehicle, dirs) if cur > 0 else None
        over = f" and its top speed {top:.2f} m/s" if top is not None and cur > top else ""
        return MIN_SPEED, (
            f"speed {MIN_SPEED:g} m/s, the floor: the current (up to {cur:.2f} m/s) exceeds the "
            f"{name}'s level-flight limit {lim:.2f} m/s{over}: the mission {CANNOT_FLY} "
            f"(expect it to tilt past 20° and be carried off the path; see `uuvid vehicle "
            f"hold {name}` for the current it holds); flying at the floor speed {MIN_SPEED:g} m/s; "
            "set a speed to override")
    v = round(LEVEL_MARGIN * lim - cur, 2)
    in_cur = f" less the {cur:.2f} m/s current" if cur > 0 else ""
    if v < MIN_SPEED:  # clamped: the formula gives less than the speed flown, say both
        return MIN_SPEED, (
            f"speed {MIN_SPEED:g} m/s, the floor: {LEVEL_MARGIN:.0%} of the {name}'s level-flight "
            f"limit {lim:.2f} m/s{in_cur} leaves " + (f"only {v:.2f} m/s" if v > 0 else "nothing")
            + " — the current alone "
            "nearly reaches the limit: expect it to tilt; set a speed to override")
    return v, (f"speed {v:g} m/s: {LEVEL_MARGIN:.0%} of the {name}'s "
               f"level-flight limit {lim:.2f} m/s{in_cur} (the nominal {NOMINAL_SPEED:g} m/s would "
               "tilt it past 20°; see `uuvid vehicle stability`); set a speed to override")


#: What a cruising-speed note says when no speed keeps the vehicle level in the current.
CANNOT_FLY = "cannot be flown as planned"


def top_speed(vehicle, directions=("forward", "backward"), inflow: str = "none") -> float | None:
    """The fastest steady speed (m/s) over the horizontal ``directions`` (the largest force any
    thrust combination gives, :func:`uuvid.vehicle.envelope.speed_envelope`): a current faster
    than it cannot be held whichever of them the vehicle faces.  ``inflow``: ``"none"`` (default)
    bollard thrust (≈ 0.02 s); ``"four-quadrant"`` each thruster's limit at the advance speed of
    the steady state, which falls with the water speed (≈ 0.5 s).  None when it cannot be
    computed."""
    try:
        from uuvid.vehicle.envelope import speed_envelope

        env = speed_envelope(vehicle, inflow=inflow)
    except Exception:  # noqa: BLE001 - a message's bound, not a result: left out if unknown
        return None
    sp = [abs(r.speed) for r in env.rows if r.direction in directions and np.isfinite(r.speed)]
    return max(sp) if sp else None


def current_speed_bound(current, horizon: float = 600.0) -> float:
    """Largest speed (m/s) of a current (a 3-vector or a current model) over ``horizon`` s."""
    if hasattr(current, "sample"):
        t = np.linspace(0.0, horizon, 601)
        v, _ = current.sample(t, float(t[1] - t[0]))
        return float(np.max(np.linalg.norm(np.asarray(v), axis=1)))
    return float(np.linalg.norm(np.asarray(current, dtype=float)))


def level_speed_limit(vehicle, directions=("forward", "backward")) -> float | None:
    """Smallest speed (m/s) over ``directions`` at which ``vehicle`` can no longer stay level
    (:func:`uuvid.vehicle.stability.static_stability`); None when it stays level throughout.

    The scan takes ≈ 0.5 s, so its result (all six directions) is cached on disk
    (:mod:`uuvid.core.cache`) under a digest of everything it depends on: the vehicle's parameters,
    thruster layout and limits, modes, allocation defaults and a stamp of the layers the scan's
    code lives in (:func:`uuvid.core.cache.tree_stamp` of ``core``, ``thruster`` and ``vehicle``:
    stability, allocation, model and hydrodynamics, and what they import — imports run downhill —
    so a change to any of it is a new key, without reading every source file as
    :func:`~uuvid.core.cache.code_version` does)."""
    from uuvid.core import cache as disk

    names = ("forward", "backward", "starboard", "port", "diving", "climbing")
    key = None
    if hasattr(vehicle, "layout"):
        key = disk.digest("level-speed-limit-v2", disk.tree_stamp("", "core", "thruster", "vehicle"),
                          vehicle.params.to_array(), np.asarray(vehicle.B, float),
                          np.asarray(vehicle.layout.limits, float), repr(sorted(vehicle.modes)),
                          repr([(m.name, m.constraints.tolist(), m.eta_pos.tolist(),
                                 m.eta_neg.tolist()) for m in vehicle.modes.values()]),
                          vehicle.allocation_dofs, vehicle.default_modes,
                          None if vehicle.allocation_weights is None
                          else np.asarray(vehicle.allocation_weights, float))
        got = disk.load_array("stability", key, (len(names),))
    else:
        got = None
    if got is None:  # −1: no limit in that direction (the cache stores finite values only)
        from uuvid.vehicle import stability  # (only on a cache miss: a warm mission skips it)

        st = stability.static_stability(vehicle, inflow="none")  # trim only: the cache key holds
        got = np.full(len(names), -1.0)
        for c in st.cases:
            if c.direction in names and c.limit_speed is not None and np.isfinite(c.limit_speed):
                got[names.index(c.direction)] = float(c.limit_speed)
        if key is not None:
            disk.store_array("stability", key, got)
    lims = [float(got[names.index(d)]) for d in directions if got[names.index(d)] >= 0]
    return min(lims) if lims else None


#: The horizontal directions a current can come from, relative to the vehicle.
HORIZONTAL = ("forward", "backward", "starboard", "port")


def vehicle_ref(vehicle) -> str:
    """How to name ``vehicle`` on the command line (its preset name, else its file)."""
    from uuvid.vehicle.definition import command_line_name

    return command_line_name(vehicle)


def current_limit_warning(vehicle, current_max: float, inflow: str | None = "none") -> str:
    """A warning when a current of up to ``current_max`` m/s is more than ``vehicle`` can hold
    level whichever way it faces: past its top speed in every horizontal direction
    (:func:`top_speed`) it cannot hold its path at all; past its level-flight limit in every
    horizontal direction (:func:`level_speed_limit`) holding against it tilts the vehicle beyond
    20°.  ``""`` otherwise.  The top speed is that of the flight's ``inflow``: bollard thrust for
    ``"none"``; with ``"four-quadrant"`` each thruster's thrust falls with the water speed, so the
    current held is below the bollard top speed — the warning says which one it used.
    Cheap: the level-flight limits come from the disk cache the cruising speed fills, and without
    inflow the envelope (≈ 0.02 s) is computed only when a limit is missing or passed — a current
    the vehicle flies level in costs nothing more; with inflow its envelope (≈ 0.5 s) whenever
    there is a current, since its top speed may lie below a level-flight limit."""
    cur = float(current_max)
    if vehicle is None or not (cur > 0 and math.isfinite(cur)):
        return ""
    try:
        levels = [level_speed_limit(vehicle, (d,)) for d in HORIZONTAL]
    except Exception:  # noqa: BLE001 - a message's bound: no warning when it is unknown
        return ""
    wet = inflow not in (None, "none")
    level = all(x is not None for x in levels) and cur <= max(levels)
    if level and not wet:
        return ""
    name, hold = getattr(vehicle, "name", "vehicle"), f"`uuvid vehicle hold {vehicle_ref(vehicle)}`"
    top = top_speed(vehicle, HORIZONTAL, inflow=inflow if wet else "none")
    if top is not None and cur > top:
        which = f"top speed {top:.2f} m/s, bollard thrust"
        if wet:
            dry = top_speed(vehicle, HORIZONTAL)
            which = (f"top speed {top:.2f} m/s with {inflow} inflow, the thrust falling with the "
                     "water speed" + (f"; {dry:.2f} m/s at bollard thrust" if dry is not None else ""))
        return (f"the current reaches {cur:.2f} m/s, faster than the {name} can fly in any "
                f"horizontal direction ({which}): it cannot hold "
                f"its path against it — {hold} gives the current it holds from each direction")
    if level:
        return ""
    if all(x is not None for x in levels):
        return (f"the current reaches {cur:.2f} m/s, above the {name}'s level-flight limit in "
                f"every horizontal direction (at most {max(levels):.2f} m/s): holding against it "
                f"tilts the vehicle past 20° — {hold} gives the current it holds level")
    return ""
