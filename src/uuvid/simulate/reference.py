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


@dataclass(frozen=True)
class Leg:
    start: np.ndarray  # (4,) n, e, d, yaw
    end: np.ndarray
    t0: float
    duration: float


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

    def __post_init__(self):
        if len(self.waypoints) < 2:
            raise ValueError("a mission needs at least two waypoints")
        for i, w in enumerate(self.waypoints):
            if len(w) != 4 or not all(math.isfinite(float(v)) for v in w):
                raise ValueError(f"waypoint {i} must be 4 finite numbers (north, east, down, yaw), got {w!r}")
        for name in ("speed", "vertical_speed", "yaw_rate"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive")
        if self.ramp_time < 0 or self.hold < 0:
            raise ValueError("ramp_time and hold must be >= 0")

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
