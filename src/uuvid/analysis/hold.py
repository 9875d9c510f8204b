"""Station keeping: can the vehicle hold station in this current, and for how long?

**Capability** (the "capability plot" of dynamic positioning, e.g. IMCA M 140): for each angle
β of the current relative to the vehicle's heading (0° = current from ahead, 90° = from
starboard), the largest current speed V the vehicle holds station against.  Analytic: holding
station means ν = 0, so ν_r = −ν_c and the thrusters must supply the steady wrench

    τ_req(V, β) = C_A(ν_r) ν_r + D(ν_r) ν_r + g(η)      (Fossen 2011, eq. 10.1, ν̇ = 0)

which is taken from the vehicle model itself (``τ_req = −M ν̇`` with τ = 0 at ν = 0, level, so
the Munk moment and the net buoyancy are included).  V_max(β) is the largest V for which the
bounded allocation (:class:`~uuvid.vehicle.allocation.Allocator`, method ``priority``) delivers
τ_req exactly within the thrust limits (at the supply voltage, when a thruster model and battery
set them), found by bisection; τ_req grows monotonically with V.

Roll and pitch that the allocation does not control (a 6-thruster BlueROV2) settle where their
moments balance (:func:`steady_hold`, followed by continuation in V from still water, as the
current builds up); holding station also requires that balance to be stable and within
:data:`MAX_TILT_DEG`.

**Confirmation by simulation** (:func:`simulate_boundary`): the vehicle holds a point at depth
in the mission loop while a current ramps up to V; it holds when the position error settles.
The simulated boundary is found by bisection on V and compared with the analytic one.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from uuvid.analysis.hold_linear import closed_loop_jacobian
from uuvid.core.checks import state_of_charge
from uuvid.core.result import Result
from uuvid.vehicle.allocation import Allocator
from uuvid.vehicle.model import vehicle_rhs_into

#: The fastest current :func:`max_current` searches to (its ``v_cap``), m/s.
MAX_V_CAP = 100.0


def current_ned(speed: float, relative_deg: float, heading: float = 0.0) -> np.ndarray:
    """NED current of ``speed`` coming from ``relative_deg`` off the bow of a vehicle heading
    ``heading`` (rad): it flows towards ``heading + relative + 180°``."""
    a = heading + math.radians(relative_deg)
    return -speed * np.array([math.cos(a), math.sin(a), 0.0])


def _accel(vehicle, current, depth, roll, pitch, tau) -> np.ndarray:
    from uuvid.vehicle.kinematics import euler_to_quat

    x = np.zeros(13)
    x[2] = depth
    x[3:7] = euler_to_quat(roll, pitch, 0.0)
    dx = np.zeros(13)
    vehicle_rhs_into(x, np.asarray(tau, float), vehicle.params.to_array(),
                     np.asarray(current, float), np.zeros(3), dx)
    return dx[7:13]


def required_wrench(vehicle, current, depth: float = 2.0, roll: float = 0.0,
                    pitch: float = 0.0) -> np.ndarray:
    """Steady wrench (6) the thrusters must give to hold the vehicle at rest (heading north, at
    the given attitude) in the NED ``current``: ``τ_req = −M ν̇(ν = 0, τ = 0)``.  ``current``:
    3 finite NED components (m/s); ``depth`` finite, >= 0 m (down positive); ``roll``, ``pitch``
    finite (rad)."""
    from uuvid.core.checks import finite

    current = _check_current(current)
    depth = _check_depth(depth)
    return _required_wrench(vehicle, current, depth, finite("roll", roll, "rad"),
                            finite("pitch", pitch, "rad"))


def _required_wrench(vehicle, current, depth: float = 2.0, roll: float = 0.0,
                     pitch: float = 0.0) -> np.ndarray:
    """:func:`required_wrench` of arguments already checked (the inner loops of a search)."""
    return -vehicle.params.mass_matrix @ _accel(vehicle, current, depth, roll, pitch, np.zeros(6))


def _check_current(current) -> np.ndarray:
    """A NED current as given by a caller: 3 finite components (m/s); a 2-component current was
    taken as is and failed (or not) far from the call, a NaN gave an all-NaN wrench."""
    from uuvid.core.checks import finite_values

    return finite_values("current", current, (3,), "a NED current of 3 finite components (m/s)")


def _check_depth(depth) -> float:
    """A holding depth (m, down positive): finite and >= 0, as a mission's (``square_mission``);
    a NaN depth raised a LinAlgError deep in the allocation."""
    from uuvid.core.checks import non_negative

    return non_negative("depth", depth, "m, down positive")


#: Largest roll or pitch (deg) counted as holding station: the same level limit as steady flight
#: (:data:`uuvid.vehicle.stability.MAX_TILT_DEG`); a vehicle tilted further by the current is not
#: doing useful work (camera, tools) even if its position is held.
from uuvid.vehicle.stability import MAX_TILT_DEG  # noqa: E402


def steady_hold(vehicle, current, al: Allocator, depth: float = 2.0, start=(0.0, 0.0),
                max_tilt_deg: float = MAX_TILT_DEG):
    """Station-keeping equilibrium: the thrusters deliver the controlled rows of τ_req; roll and
    pitch, when the allocation does not control them, settle where their moments (hydrodynamic,
    restoring, and the thrusters' side moments) balance — found by Newton iteration (finite
    differences) from ``start``.  Returns ``(achievable, roll, pitch, allocation)``; not
    achievable also when no attitude within ±``max_tilt_deg`` balances or the balance is statically unstable
    (an eigenvalue of ∂(ṗ, q̇)/∂(φ, θ) ≥ 0).  ``depth``: finite, >= 0 m."""
    depth = _check_depth(depth)
    free = [k for k in (3, 4) if k not in al.controlled]
    ang = np.array(start, dtype=float)
    drift = uncontrolled_push(vehicle, current, al, depth)
    if drift:
        r = al.allocate(_required_wrench(vehicle, current, depth), "priority")
        return False, 0.0, 0.0, r

    def resid(a):
        tau = _required_wrench(vehicle, current, depth, a[0], a[1])
        r = al.allocate(tau, "priority")
        acc = _accel(vehicle, current, depth, a[0], a[1], r.achieved)
        return np.array([acc[k] for k in free]), r

    f, r = resid(ang)
    for _ in range(40):
        if not free or np.max(np.abs(f)) < 1e-10:
            break
        J = np.zeros((len(free), len(free)))
        for j, k in enumerate(free):
            d = np.zeros(2)
            d[k - 3] = 1e-6
            J[:, j] = (resid(ang + d)[0] - f) / 1e-6
        step = np.clip(np.linalg.lstsq(J, -f, rcond=None)[0], -0.2, 0.2)
        for j, k in enumerate(free):
            ang[k - 3] += step[j]
        if np.max(np.abs(ang)) > math.radians(max_tilt_deg):
            return False, float(ang[0]), float(ang[1]), r
        f, r = resid(ang)
    ok = r.achievable and (not free or np.max(np.abs(f)) < 1e-6) and \
        np.max(np.abs(ang)) <= math.radians(max_tilt_deg)
    if ok and free:
        J = np.zeros((len(free), len(free)))
        for j, k in enumerate(free):
            d = np.zeros(2)
            d[k - 3] = 1e-6
            J[:, j] = (resid(ang + d)[0] - f) / 1e-6
        ok = bool(np.all(np.linalg.eigvals(J).real < 0))
    return bool(ok), float(ang[0]), float(ang[1]), r


def uncontrolled_push(vehicle, current, al: Allocator, depth: float = 2.0) -> list[str]:
    """DOFs among surge, sway, heave, yaw that the allocation does not control but the current
    pushes on (a steady force there means the vehicle drifts off station: no thruster opposes
    it).  Roll and pitch are not listed: they settle at a balance (:func:`steady_hold`)."""
    from uuvid.vehicle.layout import DOF_NAMES

    tau = _required_wrench(vehicle, current, depth)
    tol = 1e-9 + 1e-6 * float(np.max(np.abs(tau)))
    return [DOF_NAMES[k] for k in (0, 1, 2, 5) if k not in al.controlled and abs(tau[k]) > tol]


def hold_gains(vehicle, modes=None, attitude_bandwidth: float = 6.0):
    """The DP controller of the station-keeping check (analytic and simulated): the default PID
    gains with output and integral limits at each DOF's reach with the bounded allocation (the
    vehicle's limit is tested, not the controller's), and, where the thrusters control roll and
    pitch, a stiff level-attitude hold at ``attitude_bandwidth`` (rad/s)."""
    from uuvid.simulate.vehicle_sim import default_gains

    g = default_gains(vehicle)
    al = vehicle.allocator(modes)
    reach = []
    for k in (0, 1, 2, 5):
        u = np.zeros(6)
        u[k] = 1e6
        reach.append(float(al.allocate(u, "maxscale").fraction * 1e6) if k in al.controlled
                     else 0.0)
    gains = dataclasses.replace(g, tau_max=tuple(reach), i_limit=tuple(reach))
    if any(g.kp_attitude):
        M = vehicle.params.mass_matrix
        w = attitude_bandwidth
        gains = dataclasses.replace(gains, kp_attitude=tuple(float(M[i, i] * w * w) for i in (3, 4)),
                                    kd_attitude=tuple(float(2 * M[i, i] * w) for i in (3, 4)))
    return gains


def closed_loop_growth(vehicle, current, al: Allocator, gains, depth: float, roll: float,
                       pitch: float) -> float:
    """Largest real part of the closed loop's eigenvalues (see :func:`closed_loop_modes`)."""
    return closed_loop_modes(vehicle, current, al, gains, depth, roll, pitch)[0]


def _loop_point(vehicle, current, gains, depth, roll, pitch):
    """``(G, P, current, s0)``: gains and vehicle arrays, and the equilibrium state of the loop
    (at rest at depth, the integrators holding the steady wrench)."""
    from uuvid.simulate.control.pid import DP_DOFS

    G = gains.to_array()
    P = vehicle.params.to_array()
    cur = np.asarray(current, float)
    tau_req = _required_wrench(vehicle, cur, depth, roll, pitch)
    integ0 = np.array([tau_req[k] / G[1, j] if G[1, j] > 0 else 0.0
                       for j, k in enumerate(DP_DOFS)])
    s0 = np.zeros(16)
    s0[2] = depth
    s0[3], s0[4] = roll, pitch
    s0[12:16] = integ0
    return G, P, cur, s0


def closed_loop_modes(vehicle, current, al: Allocator, gains, depth: float, roll: float,
                      pitch: float) -> tuple[float, list[str]]:
    """Largest real part (1/s) of the eigenvalues of the station-keeping loop linearised at the
    equilibrium (rest at the origin, heading north, attitude ``roll``, ``pitch``): 16 states
    (position, Euler angles, ν, the 4 PID integrators), the PID of
    :func:`uuvid.simulate.control.pid.dp_control` (+ attitude PD), the bounded allocation and the
    full vehicle model (Munk moments, restoring, the thrusters' side moments).  ``< 0``: the hold
    is (locally) stable.

    Why it matters: a vehicle that cannot control roll and pitch, held against a *diagonal*
    current, is statically stable in roll/pitch up to the tilt limit, but the non-conservative
    coupling of the tilted attitude with the yaw and position loops (Munk moment
    ``N = (Y_v̇ − X_u̇) u v`` and the tilted thrust) makes the loop oscillate earlier
    (a Hopf bifurcation; the BlueROV2 at 45°/135°).

    Uncontrolled DOFs: the position (or heading) of a DP DOF the allocation does not control
    (AUV II has no surge thruster) and its PID integrator are pure integrators nothing else
    depends on — eigenvalues exactly 0, neutral drift, not an oscillation.  When their columns
    of the Jacobian vanish outside their own rows (block triangular, checked), they are taken
    out and returned by name as the second element (``growth`` is then that of the rest); any
    remaining eigenvalue with ``|Re λ| ≤ 1e-9 · max|λ|`` counts as 0 (marginal, not stable)."""
    from uuvid.simulate.control.pid import DP_DOFS

    G, P, cur, s0 = _loop_point(vehicle, current, gains, depth, roll, pitch)
    ep, en = al.eta
    A = closed_loop_jacobian(s0, np.ascontiguousarray(G), P, cur, float(depth),
                             al.to_array("priority"), np.ascontiguousarray(al.B, dtype=float),
                             np.ascontiguousarray(ep, dtype=float),
                             np.ascontiguousarray(en, dtype=float))
    from uuvid.vehicle.layout import DOF_NAMES

    drop, drifting = [], []
    for j, k in enumerate(DP_DOFS):
        if k in al.controlled:
            continue
        st = [k if k < 3 else 5, 12 + j]  # position (or heading) state, integrator
        keep = [i for i in range(16) if i not in st]
        scale = max(1.0, float(np.max(np.abs(A))))
        if np.all(np.abs(A[np.ix_(keep, st)]) <= 1e-9 * scale):
            drop += st
            drifting.append(DOF_NAMES[k])
    keep = [i for i in range(16) if i not in drop]
    ev = np.linalg.eigvals(A[np.ix_(keep, keep)])
    re = ev.real.copy()
    re[np.abs(re) <= 1e-9 * max(1.0, float(np.max(np.abs(ev))))] = 0.0
    return float(np.max(re)), drifting


def _closed_loop_jacobian_py(vehicle, current, al: Allocator, gains, depth: float, roll: float,
                             pitch: float) -> np.ndarray:
    """The loop's Jacobian through :meth:`Allocator.allocate` in Python: the reference
    :func:`uuvid.analysis.hold_linear.closed_loop_jacobian` is tested against."""
    from uuvid.simulate.control.pid import DP_DOFS
    from uuvid.vehicle.kinematics import euler_to_quat, quat_to_rotmat

    G, P, cur, s0 = _loop_point(vehicle, current, gains, depth, roll, pitch)

    def rhs(s):
        pos, eul, nu, integ = s[0:3], s[3:6], s[6:12], s[12:16]
        ph, th, ps = eul
        q = euler_to_quat(ph, th, ps)
        R = quat_to_rotmat(q)
        e = np.empty(4)
        ed = np.empty(4)
        e[:3] = R.T @ (np.array([0.0, 0.0, depth]) - pos)
        ed[:3] = -nu[:3]
        e[3] = -ps
        ed[3] = -nu[5]
        tau = np.zeros(6)
        for j, k in enumerate(DP_DOFS):
            tau[k] = G[0, j] * e[j] + G[1, j] * integ[j] + G[2, j] * ed[j]
        if G[5].any():
            tau[3] = -G[5, 0] * ph - G[5, 2] * nu[3]
            tau[4] = -G[5, 1] * th - G[5, 3] * nu[4]
        got = al.allocate(tau, "priority").achieved
        x = np.zeros(13)
        x[0:3] = pos
        x[3:7] = q
        x[7:13] = nu
        dx = np.zeros(13)
        vehicle_rhs_into(x, got, P, cur, np.zeros(3), dx)
        ct, st_, tt = math.cos(ph), math.sin(ph), math.tan(th)
        Tm = np.array([[1.0, st_ * tt, ct * tt], [0.0, ct, -st_],
                       [0.0, st_ / math.cos(th), ct / math.cos(th)]])
        return np.concatenate([R @ nu[:3], Tm @ nu[3:], dx[7:13], e])

    A = np.empty((16, 16))
    for j in range(16):
        h = 1e-6 * max(1.0, abs(s0[j]))
        d = np.zeros(16)
        d[j] = h
        A[:, j] = (rhs(s0 + d) - rhs(s0 - d)) / (2 * h)
    return A


def _allocator(vehicle, limits=None, modes=None) -> Allocator:
    """The allocation of the steady hold.  η compensated: in steady state the DP loop's integral
    action raises the command until the *delivered* wrench is τ_req, so holding needs commanded
    thrusts τ/η within the limits (the mission allocator does not compensate η; its integrator
    does).  Without it a mode with η < 1 (ROMEO's downward heave, η = 0.56) could never deliver
    even its net buoyancy."""
    al = vehicle.allocator(modes, compensate_eta=True)
    if limits is None:
        return al
    return dataclasses.replace(al, limits=np.asarray(limits, float))


def max_current(vehicle, relative_deg: float, *, limits=None, modes=None, depth: float = 2.0,
                v_cap: float = 10.0, tol: float = 1e-4, soc: float | None = None,
                battery=None, stability: bool = True, gains=None,
                inflow: str | None = None) -> tuple[float, dict]:
    """Largest current speed (m/s) held from ``relative_deg``; also the allocation at it.

    Held: the steady wrench is delivered within the limits (:func:`steady_hold`: thrust,
    attitude balance within :data:`MAX_TILT_DEG`) and, with ``stability``, the closed station-
    keeping loop with ``gains`` (default :func:`hold_gains`) is stable there
    (:func:`closed_loop_growth` < 0).  ``info["limit"]`` says which ran out first: ``thrust``,
    ``attitude``, ``stability`` or ``uncontrolled`` (the current pushes along a DOF no thruster
    controls), ``info["reason"]`` in words; ``info["drifting"]`` the DOFs left to drift
    neutrally (uncontrolled, taken out of the stability test).  With ``soc`` the limits follow
    the battery's loaded voltage (:func:`hold_on_battery`).

    ``inflow`` (``None``: the vehicle file's; ``'none'``: bollard limits): each thruster's limit
    at the advance speed the current gives it while the vehicle holds still, level, heading
    north (``ν_r = −ν_c``; :mod:`uuvid.vehicle.inflow`).  The hold gains keep the bollard reach."""
    from uuvid.core.checks import direction_deg

    return _max_current(vehicle, direction_deg("relative_deg", relative_deg), limits=limits,
                        modes=modes, depth=depth, v_cap=v_cap, tol=tol, soc=soc, battery=battery,
                        stability=stability, gains=gains, inflow=inflow)


def _max_current(vehicle, relative_deg: float, *, limits=None, modes=None, depth: float = 2.0,
                 v_cap: float = 10.0, tol: float = 1e-4, soc: float | None = None, battery=None,
                 stability: bool = True, gains=None, inflow: str | None = None):
    """:func:`max_current` at a ``relative_deg`` already checked (the command line's, a
    capability plot's grid): its warnings are not said again.  The other numbers are checked
    here (no warnings, cheap): ``tol`` and ``v_cap`` finite and > 0 (``tol=0`` bisected for
    ever, ``v_cap=0`` returned ∞), ``depth`` finite and >= 0."""
    from uuvid.core.checks import positive
    from uuvid.vehicle.inflow import inflow_limits

    tol = positive("tol", tol, "m/s, the bisection's resolution")
    v_cap = positive("v_cap", v_cap, "m/s, the fastest current searched")
    if v_cap > MAX_V_CAP:  # searched in 0.05 m/s steps: 1e9 m/s was 2·10¹⁰ station checks
        raise ValueError(f"v_cap = {v_cap:g} m/s: expected at most {MAX_V_CAP:g} m/s (the search "
                         "steps 0.05 m/s at a time; no current runs faster than ≈ 5 m/s)")
    depth = _check_depth(depth)

    al = _allocator(vehicle, limits, modes)
    il = inflow_limits(vehicle, inflow)
    if il is not None and soc is not None:
        raise ValueError("the held current with inflow at a battery's state of charge (`soc=`) "
                         "is not computed yet: switch inflow off (`inflow=`none) or give a supply "
                         "voltage instead (`supply_voltage=`)")
    if il is not None and limits is not None:
        il = il.with_limits(limits)

    def al_at(v):  # the allocation with the thrust limits at current speed v
        if il is None or v == 0.0:
            return al
        nu = np.zeros(6)
        nu[:3] = -current_ned(v, relative_deg)
        return _allocator(vehicle, il.limits_at(nu), modes)

    if stability and gains is None:
        gains = hold_gains(vehicle if limits is None else _with_limits(vehicle, limits), modes)

    # continuation in speed from still water: the attitude follows its stable branch, as it
    # does while a current builds up
    ang = (0.0, 0.0)
    why, detail, drifting = {}, {}, set()

    def ok(v, a0):
        cur = current_ned(v, relative_deg)
        if soc is not None:
            h = hold_on_battery(vehicle, cur, soc, battery=battery, modes=modes, depth=depth,
                                start=a0)
            good, roll, pitch, r, a_ = h.held, h.roll, h.pitch, h.allocation, \
                _allocator(vehicle, h.limits, modes)
            if h.battery_limit:  # the battery's own limit, not the thrust or the attitude
                why[v] = "battery"
                detail[v] = f"the battery at SOC {soc:.0%}: {h.battery_limit}"
                return False, (roll, pitch)
        else:
            a_ = al_at(v)
            good, roll, pitch, r = steady_hold(vehicle, cur, a_, depth, a0)
        if not good:
            push = uncontrolled_push(vehicle, cur, a_, depth)
            if push:
                why[v] = "uncontrolled"
                detail[v] = (f"the current pushes along {', '.join(push)}, which the allocation "
                             "does not control (no thruster opposes it: the vehicle drifts)")
            elif not r.achievable:
                why[v] = "thrust"
                lost = ", ".join(f"{k} {x:+.3g}" for k, x in r.shortfall.items())
                detail[v] = ("the thrusters cannot deliver the steady wrench within their limits"
                             + (f" (short by {lost})" if lost else ""))
            else:
                why[v] = "attitude"
                detail[v] = (f"no statically stable roll/pitch balance within {max_tilt:g}° tilt"
                             f" (reached roll {math.degrees(roll):.1f}°, pitch "
                             f"{math.degrees(pitch):.1f}°)")
            return False, (roll, pitch)
        if stability:
            g, drift = closed_loop_modes(vehicle, cur, a_, gains, depth, roll, pitch)
            drifting.update(drift)
            if g >= 0:
                why[v] = "stability"
                detail[v] = (f"the station-keeping loop is not stable (largest growth rate "
                             f"{g:.3g} 1/s)")
                return False, (roll, pitch)
        return True, (roll, pitch)

    max_tilt = MAX_TILT_DEG
    good, ang = ok(0.0, ang)
    if not good:
        return 0.0, {"limit": why[0.0], "reason": "cannot hold station in still water: "
                     + detail[0.0], "limiting_thrusters": [], "drifting": sorted(drifting)}
    lo, hi, step = 0.0, None, 0.05
    while hi is None:
        v = lo + step
        if v > v_cap:
            return math.inf, {"limit": "", "reason": f"holds beyond {v_cap} m/s",
                              "drifting": sorted(drifting)}
        good, a = ok(v, ang)
        if good:
            lo, ang = v, a
        else:
            hi = v
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if not lo < mid < hi:  # a tol below the float spacing at lo (1e-20): as fine as it gets
            break
        good, a = ok(mid, ang)
        if good:
            lo, ang = mid, a
        else:
            hi = mid
    names = [t.name for t in vehicle.layout]
    if soc is not None:
        h = hold_on_battery(vehicle, current_ned(lo, relative_deg), soc, battery=battery,
                            modes=modes, depth=depth, start=ang)
        hb = hold_on_battery(vehicle, current_ned(hi, relative_deg), soc, battery=battery,
                             modes=modes, depth=depth, start=ang).allocation
        return lo, {"limit": why.get(hi, ""), "reason": detail.get(hi, ""),
                    "drifting": sorted(drifting),
                    "limiting_thrusters": [names[i] for i in hb.limiting]
                    if not hb.achievable else [],
                    "roll_deg": math.degrees(h.roll), "pitch_deg": math.degrees(h.pitch),
                    "supply_voltage_V": h.voltage, "battery_current_A": h.current}
    _, roll, pitch, r = steady_hold(vehicle, current_ned(lo, relative_deg), al_at(lo), depth, ang)
    # just beyond the boundary: thrusters at their limits if thrust is what runs out
    rb = steady_hold(vehicle, current_ned(hi, relative_deg), al_at(hi), depth, ang)[3]
    lim = [names[i] for i in rb.limiting] if not rb.achievable else []
    info = {"limit": why.get(hi, ""), "reason": detail.get(hi, ""), "drifting": sorted(drifting),
            "limiting_thrusters": lim,
            "roll_deg": math.degrees(roll), "pitch_deg": math.degrees(pitch)}
    if il is not None and lo > 0.0:  # a bench-fitted map read beyond the advance angles it saw
        nu = np.zeros(6)
        nu[:3] = -current_ned(lo, relative_deg)
        beyond = [(names[i], b) for i, b in il.extrapolated(nu)]
        if beyond:
            info["extrapolated"] = beyond
            info["map_ranges"] = il.maps[0].ranges_text()
    return lo, info


@dataclass(frozen=True)
class CapabilityResult(Result):
    """Station-keeping capability: the largest current (m/s) held per relative angle."""

    vehicle: str
    relative_deg: np.ndarray
    max_current: np.ndarray
    limiting: tuple = ()
    supply_voltage: float | None = None
    limit: tuple = ()  # per angle: what ran out first (thrust, attitude, stability, uncontrolled)
    reasons: tuple = ()  # per angle: the limit in words
    drifting: tuple = ()  # DOFs not controlled, left to drift (neutral), at any angle
    simulated_deg: np.ndarray = field(default_factory=lambda: np.zeros(0))
    simulated: np.ndarray = field(default_factory=lambda: np.zeros(0))
    note: str = ""
    inflow: str = "none"  # thrust against advance speed (issue 21)
    max_current_bollard: np.ndarray = field(default_factory=lambda: np.zeros(0))  # inflow off
    # with a bench-fitted propeller map: where a held current reads it outside its advance angles
    extrapolated: tuple = ()
    #: with inflow: the propeller map and wake behind the numbers, and whether they are assumed
    #: (:func:`uuvid.vehicle.propeller_note.propeller_map_note`)
    propeller: str = ""
    map_ranges: str = ""

    def warnings(self) -> list[str]:
        """What the numbers rest on that no data backs: a fitted propeller map read outside the
        advance angles of its bench (as :meth:`uuvid.analysis.envelope_check.EnvelopeCheck.warnings`)."""
        if not self.extrapolated:
            return []
        return [f"extrapolated: the fitted propeller map ({self.map_ranges}) is read outside its "
                f"advance angles — {'; '.join(self.extrapolated)} — those currents rest on the "
                "series beyond the bench's data"]

    def analytic_at(self, deg: float) -> float:
        """The analytic boundary (m/s) at the computed direction nearest to ``deg`` (finite,
        degrees off the bow, modulo 360°)."""
        from uuvid.core.checks import finite

        deg = finite("deg", deg, "degrees off the bow")
        i = int(np.argmin(np.abs((self.relative_deg - deg + 180) % 360 - 180)))
        return float(self.max_current[i])

    @property
    def agreement(self) -> np.ndarray:
        """Simulated / analytic boundary at each simulated angle."""
        return np.array([s / self.analytic_at(d) for d, s in zip(self.simulated_deg, self.simulated)])

    def summary(self) -> str:
        v = f" at {self.supply_voltage:.2f} V" if self.supply_voltage else ""
        k = int(np.argmin(self.max_current))
        lines = [f"station-keeping capability of {self.vehicle}{v}: largest current held "
                 f"{np.min(self.max_current):.3f}–{np.max(self.max_current):.3f} m/s "
                 f"(weakest from {self.relative_deg[k]:.0f}° off the bow)"]
        if self.inflow != "none" and self.max_current_bollard.size:
            lines.append(f"  inflow {self.inflow}: thrust at each thruster's advance speed in the "
                         f"current; with bollard thrust {np.min(self.max_current_bollard):.3f}–"
                         f"{np.max(self.max_current_bollard):.3f} m/s")
            if self.propeller:
                lines.append(f"  {self.propeller}")
            lines.append("  from [deg]   held with inflow [m/s]   with bollard thrust [m/s]")
            for d, a, b in zip(self.relative_deg, self.max_current, self.max_current_bollard):
                lines.append(f"  {d:>10.0f}   {a:>22.3f}   {b:>25.3f}")
        if self.limit:
            c = {k: sum(1 for x in self.limit if x == k) for k in
                 ("thrust", "attitude", "stability", "uncontrolled", "battery")}
            lines.append(f"  limited by thrust at {c['thrust']} of {len(self.limit)} angles, by "
                         f"the attitude (tilt beyond {MAX_TILT_DEG:g}° or statically unstable) at "
                         f"{c['attitude']}, by closed-loop stability (the DP loop oscillates) at "
                         f"{c['stability']}"
                         + (f", by an uncontrolled DOF at {c['uncontrolled']}"
                            if c["uncontrolled"] else "")
                         + (f", by the battery (its minimum voltage or maximum current) at "
                            f"{c['battery']}" if c["battery"] else ""))
        zero = sorted({r for v, r in zip(self.max_current, self.reasons) if v == 0 and r})
        for r in zero:
            n0 = sum(1 for v, x in zip(self.max_current, self.reasons) if v == 0 and x == r)
            lines.append(f"  holds nothing at {n0} of {len(self.max_current)} angles: {r}")
        if self.drifting:
            lines.append(f"  not controlled (drifts, neutrally stable; left out of the stability "
                         f"test): {', '.join(self.drifting)}")
        for d, s, a in zip(self.simulated_deg, self.simulated, self.agreement):
            lines.append(f"  simulated at {d:.0f}°: {s:.3f} m/s (analytic {self.analytic_at(d):.3f},"
                         f" ratio {a:.3f})")
        if self.note:
            lines.append("  " + self.note)
        lines += [f"  warning: {w}" for w in self.warnings()]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        d = {"vehicle": self.vehicle, "relative_deg": self.relative_deg.tolist(),
             "max_current_m_s": self.max_current.tolist(),
             "limiting_thrusters": [list(x) for x in self.limiting],
             "limit": list(self.limit), "reasons": list(self.reasons),
             "drifting": list(self.drifting),
             "supply_voltage_V": self.supply_voltage,
             "simulated_deg": self.simulated_deg.tolist(),
             "simulated_max_current_m_s": self.simulated.tolist(),
             "simulated_over_analytic": self.agreement.tolist(), "note": self.note,
             "inflow": self.inflow}  # in force, on or off (a JSON without it said neither)
        if self.inflow != "none":
            d["max_current_bollard_m_s"] = self.max_current_bollard.tolist()
            if self.propeller:
                d["propeller_map"] = self.propeller
        d["warnings"] = self.warnings()
        return d

    def plot(self, path=None, mark=None):
        """Polar capability plot (0° = current from ahead, clockwise to starboard); ``mark``
        ``(speed m/s, from deg[, held])`` draws a requested current on it."""
        from uuvid.core.plots import new_figure, save_figure

        fig, ax = new_figure(1, 1, figsize=(5.5, 5.5), subplot_kw={"projection": "polar"})
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        th = np.radians(np.append(self.relative_deg, self.relative_deg[:1]))
        ax.plot(th, np.append(self.max_current, self.max_current[:1]), label="analytic")
        if self.simulated.size:
            ax.plot(np.radians(self.simulated_deg), self.simulated, "o", label="simulated")
        if mark is not None:
            sp, deg = float(mark[0]), float(mark[1])
            held = bool(mark[2]) if len(mark) > 2 else sp <= self.analytic_at(deg)
            ax.plot([np.radians(deg)], [sp], "*", ms=14, color="tab:green" if held else "tab:red",
                    label=f"requested {sp:g} m/s from {deg:g}° ({'held' if held else 'NOT held'})")
            ax.set_rmax(max(ax.get_rmax(), 1.1 * sp))
        v = f" at {self.supply_voltage:g} V" if self.supply_voltage else ""
        ax.set_title(f"{self.vehicle}{v}: largest current held (m/s)\nvs the direction it comes from")
        ax.legend(loc="lower right", fontsize=8)
        return save_figure(fig, path) if path is not None else fig


#: Most directions a capability plot takes (0.1° apart): each is a search of :func:`max_current`
#: (tens of ms), and a polar plot resolves no finer.
MAX_DIRECTIONS = 3600


def _check_step(step_deg) -> float:
    """The angle step of :func:`capability`: finite, in (0, 180]° (at least head-on and from
    astern) and at most :data:`MAX_DIRECTIONS` directions."""
    from uuvid.core.checks import positive

    step = positive("step_deg", step_deg, "degrees")
    if step > 180:
        raise ValueError(f"step_deg = {step:g}°: expected a step of at most 180° (a capability "
                         "plot needs at least two directions: head-on and from astern)")
    if 360.0 / step > MAX_DIRECTIONS:
        raise ValueError(f"step_deg = {step:g}° gives {360.0 / step:.3g} directions, more than the "
                         f"{MAX_DIRECTIONS:,} ({360 / MAX_DIRECTIONS:g}° apart) a capability plot "
                         f"resolves (each a search of tens of ms); give a step of at least "
                         f"{360 / MAX_DIRECTIONS:g}°")
    return step


def capability(vehicle, *, step_deg: float = 15.0, limits=None, modes=None, depth: float = 2.0,
               supply_voltage: float | None = None, soc: float | None = None, simulate_deg=(),
               progress: bool | None = None, inflow: str | None = None,
               **sim) -> CapabilityResult:
    """Capability plot data: :func:`max_current` every ``step_deg``; the angles in
    ``simulate_deg`` are also found by simulation (:func:`simulate_boundary`).

    Thrust limits: ``limits`` (n, 2); or the thruster model's at ``supply_voltage``; or, with
    ``soc``, at the battery's loaded voltage for each current (the vehicle file's battery);
    default the vehicle file's limits.  ``progress``: a bar (one stage per angle) on stderr
    (:mod:`uuvid.core.progress`; ``None``: automatic).  ``inflow`` (``None``: the vehicle file's,
    ``'none'``: bollard): with inflow the limits follow each thruster's advance speed in the
    current (:func:`max_current`) and the bollard-thrust capability is computed beside it."""
    from uuvid.core.checks import direction_deg

    return _capability(vehicle, step_deg=step_deg, limits=limits, modes=modes, depth=depth,
                       supply_voltage=supply_voltage, soc=soc,
                       simulate_deg=tuple(direction_deg("simulate_deg", d) for d in simulate_deg),
                       progress=progress, inflow=inflow, **sim)


def _capability(vehicle, *, step_deg: float = 15.0, limits=None, modes=None, depth: float = 2.0,
                supply_voltage: float | None = None, soc: float | None = None, simulate_deg=(),
                progress: bool | None = None, inflow: str | None = None,
                **sim) -> CapabilityResult:
    """:func:`capability` with its ``simulate_deg`` already checked (the command line's
    ``--simulate``): their warnings are not said again."""
    from uuvid.core.progress import progress_task
    from uuvid.vehicle.inflow import resolve_inflow
    from uuvid.vehicle.power import limits_at
    from uuvid.vehicle.propeller_note import vehicle_propeller_note

    step_deg = _check_step(step_deg)
    simulate_deg = tuple(float(d) for d in simulate_deg)
    inflow = resolve_inflow(vehicle, inflow)
    if inflow != "none" and simulate_deg:
        raise ValueError("the confirmation by simulation (`simulate_deg=`) flies bollard thrusters "
                         f"only, and inflow is on ({inflow}, from the vehicle file or the option): "
                         "switch it off (`inflow=`none) to confirm by simulation")

    if supply_voltage is not None and limits is None:
        limits = limits_at(vehicle, supply_voltage)
    if soc is not None and vehicle.battery is None:
        raise ValueError(f"{vehicle.name} has no battery block; give supply_voltage or limits")
    degs = np.arange(0.0, 360.0, float(step_deg))
    if simulate_deg and soc is not None:
        raise ValueError("simulated confirmation runs at fixed limits (give supply_voltage)")
    vals, lim, why, words, drift, bollard, beyond, ranges = [], [], [], [], set(), [], [], ""
    n = len(degs) + len(simulate_deg)
    task = progress_task(f"{vehicle.name} capability", total=n, eta=False, stages=n,
                         disable=None if progress is None else not progress)
    with task:
        for d in degs:
            task.stage(f"current from {d:g}°" + (f" on the battery at SOC {soc:.0%}"
                                                 if soc is not None else ""))
            # the grid's own angles, not the user's (5.5° is no π/4 radians slip): not checked
            v, info = _max_current(vehicle, float(d), limits=limits, modes=modes, depth=depth,
                                   soc=soc, inflow=inflow)
            if inflow != "none":
                bollard.append(_max_current(vehicle, float(d), limits=limits, modes=modes,
                                            depth=depth, soc=soc, inflow="none")[0])
            task.advance()
            vals.append(v)
            lim.append(tuple(info.get("limiting_thrusters", ())))
            why.append(info.get("limit", ""))
            words.append(info.get("reason", ""))
            drift.update(info.get("drifting", ()))
            beyond += [f"from {d:g}°: {t} at β = {b:.0f}°" for t, b in info.get("extrapolated", ())]
            ranges = info.get("map_ranges", ranges)
        sv = []
        for d in simulate_deg:
            task.stage(f"simulating the boundary at {d:g}°")
            guess = float(np.array(vals)[int(np.argmin(np.abs((degs - d + 180) % 360 - 180)))])
            sv.append(_simulate_boundary(vehicle, d, guess, limits=limits, modes=modes,
                                         depth=depth, **sim))
            task.advance()
    res = CapabilityResult(vehicle.name, degs, np.array(vals), tuple(lim), supply_voltage,
                           tuple(why), tuple(words), tuple(sorted(drift)),
                           note=(f"battery {vehicle.battery.name} at SOC {soc:.0%}: limits at the "
                                 "loaded voltage" if soc is not None else ""),
                           inflow=inflow, max_current_bollard=np.array(bollard),
                           extrapolated=tuple(beyond), map_ranges=ranges,
                           propeller=vehicle_propeller_note(vehicle, inflow))
    if simulate_deg:
        sd = np.asarray(simulate_deg, float)
        res = dataclasses.replace(res, simulated_deg=sd, simulated=np.array(sv), note=(
            "simulation: PID DP with output/integral limits at each DOF's reach, stiff level-attitude "
            "hold; the current ramps up over 60 s, then a 0.03 m/s gust; held = position error "
            f"settled below 0.5 m, heading within 5° and roll, pitch within {MAX_TILT_DEG:g}°"))
    return res


def holds_in_simulation(vehicle, relative_deg: float, speed: float, *, limits=None, modes=None,
                        depth: float = 2.0, duration: float = 150.0, dt: float = 0.02,
                        attitude_bandwidth: float = 6.0, ramp: float = 60.0,
                        max_tilt_deg: float = MAX_TILT_DEG, gust: float = 0.03,
                        max_yaw_error_deg: float = 5.0):
    """Fly a station-keeping hold in a current ramping to ``speed``; returns (held, result)."""
    from uuvid.core.checks import direction_deg

    return _holds_in_simulation(vehicle, direction_deg("relative_deg", relative_deg), speed,
                                limits=limits, modes=modes, depth=depth, duration=duration, dt=dt,
                                attitude_bandwidth=attitude_bandwidth, ramp=ramp,
                                max_tilt_deg=max_tilt_deg, gust=gust,
                                max_yaw_error_deg=max_yaw_error_deg)


def _holds_in_simulation(vehicle, relative_deg: float, speed: float, *, limits=None, modes=None,
                         depth: float = 2.0, duration: float = 150.0, dt: float = 0.02,
                         attitude_bandwidth: float = 6.0, ramp: float = 60.0,
                         max_tilt_deg: float = MAX_TILT_DEG, gust: float = 0.03,
                         max_yaw_error_deg: float = 5.0):
    """:func:`holds_in_simulation` at a ``relative_deg`` already checked (each step of
    :func:`simulate_boundary`'s bisection): its warnings are not said again.  The other numbers
    are checked here (cheap, no warnings): a negative ``speed`` flew the current from the
    other side and a NaN one a NaN mission, both reported as diverged (blamed on the step)."""
    from uuvid.core.checks import non_negative, positive
    from uuvid.simulate.currents import TimeSeriesCurrent
    from uuvid.simulate.reference import WaypointMission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    speed = non_negative("speed", speed, "m/s, the current held against")
    depth = _check_depth(depth)
    duration = positive("duration", duration, "s")
    dt = positive("dt", dt, "s")
    attitude_bandwidth = positive("attitude_bandwidth", attitude_bandwidth, "rad/s")
    ramp = positive("ramp", ramp, "s, the current's rise")
    gust = non_negative("gust", gust, "m/s")
    max_tilt_deg = positive("max_tilt_deg", max_tilt_deg, "deg")
    max_yaw_error_deg = positive("max_yaw_error_deg", max_yaw_error_deg, "deg")
    if duration <= ramp + 14.0:
        raise ValueError(f"duration = {duration:g} s: expected longer than ramp + 14 s = "
                         f"{ramp + 14.0:g} s (the current ramps up over ramp = {ramp:g} s, then a "
                         "gust blows 10 to 14 s after it, and the hold is judged after that)")
    if limits is not None:
        vehicle = _with_limits(vehicle, limits)
    c = current_ned(speed, relative_deg)
    # a gust (2 s up, 2 s down; ``gust`` m/s across the current and upwards) after the ramp:
    # without it a current exactly along a symmetry axis (0°, 90°, 180°) never excites the
    # antisymmetric modes, and an unstable hold would look held
    side = np.array([-c[1], c[0], 0.0]) / max(speed, 1e-12) * gust + np.array([0, 0, -gust])
    tg = ramp + 10.0
    cur = TimeSeriesCurrent(np.array([0.0, ramp, tg, tg + 2.0, tg + 4.0, duration + 1.0]),
                            np.vstack([0 * c, c, c, c + side, c, c]))
    wp = (0.0, 0.0, depth, 0.0)
    mission = WaypointMission((wp, wp), hold=duration, name="station keeping")
    gains = hold_gains(vehicle, modes, attitude_bandwidth)
    s = setup_mission(vehicle, mission, dt=dt, gains=gains, current=cur, modes=modes,
                      t_end=duration)
    r = fly_mission(s)
    err = r.tracking_error
    tail = err[r.t >= duration - 20.0]
    from uuvid.vehicle.kinematics import quat_to_euler

    eul = quat_to_euler(r.state[r.t >= duration - 20.0, 3:7])
    tilt = float(np.max(np.abs(eul[:, :2])))
    # heading is held too: a yaw limit cycle (±40° at the BlueROV2's 0° boundary, with the
    # position still within centimetres) is not station keeping
    yaw_err = float(np.max(np.abs((eul[:, 2] + math.pi) % (2 * math.pi) - math.pi)))
    held = bool(np.all(np.isfinite(err)) and tail.max() < 0.5 and
                abs(tail[-1] - tail[0]) < 0.05 and tilt <= math.radians(max_tilt_deg) and
                yaw_err <= math.radians(max_yaw_error_deg))
    return held, r


def _with_limits(vehicle, limits):
    """The vehicle with other thrust limits (e.g. at a supply voltage)."""
    lim = np.asarray(limits, float)
    layout = vehicle.layout
    new = dataclasses.replace(layout, thrusters=tuple(
        dataclasses.replace(t, limits=(float(lim[i, 0]), float(lim[i, 1])))
        for i, t in enumerate(layout.thrusters)))
    return dataclasses.replace(vehicle, layout=new)


def simulate_boundary(vehicle, relative_deg: float, guess: float, *, limits=None, modes=None,
                      depth: float = 2.0, span: float = 0.25, iterations: int = 7,
                      duration: float = 150.0) -> float:
    """Largest current held in simulation, by bisection in ``[(1−span), (1+span)]·guess``."""
    from uuvid.core.checks import direction_deg

    return _simulate_boundary(vehicle, direction_deg("relative_deg", relative_deg), guess,
                              limits=limits, modes=modes, depth=depth, span=span,
                              iterations=iterations, duration=duration)


def _simulate_boundary(vehicle, relative_deg: float, guess: float, *, limits=None, modes=None,
                       depth: float = 2.0, span: float = 0.25, iterations: int = 7,
                       duration: float = 150.0) -> float:
    """:func:`simulate_boundary` at a ``relative_deg`` already checked (a capability plot's
    ``simulate_deg``): checked once, not at each of its simulations."""
    lo, hi = (1 - span) * guess, (1 + span) * guess
    kw = dict(limits=limits, modes=modes, depth=depth, duration=duration)
    if not _holds_in_simulation(vehicle, relative_deg, lo, **kw)[0]:
        return lo  # (below the bracket: reported as its lower end)
    if _holds_in_simulation(vehicle, relative_deg, hi, **kw)[0]:
        return hi
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if _holds_in_simulation(vehicle, relative_deg, mid, **kw)[0]:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


# ---------------------------------------------------------------------------------------------
# Battery: holding station at a state of charge, endurance
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BatteryHold:
    held: bool
    soc: float
    voltage: float
    current: float
    limits: np.ndarray
    roll: float
    pitch: float
    allocation: object
    reason: str = ""
    command: np.ndarray | None = None  # command per thruster giving its thrust at the voltage
    battery_limit: str = ""  # the battery's own limit it broke (minimum voltage, maximum current)


def hold_on_battery(vehicle, current, soc: float, *, battery=None, modes=None,
                    depth: float = 2.0, start=(0.0, 0.0)) -> BatteryHold:
    """Station keeping on the battery at ``soc``: the supply voltage V, the thrust limits at V
    and the thrusts are solved together (fixed point: allocation → thruster currents →
    ``V = OCV − R I`` → limits(V) → allocation).  Held when the allocation delivers τ_req within
    the limits at V, V stays above the battery's minimum and I below its maximum current."""
    from uuvid.thruster.physical import physical_model
    from uuvid.vehicle.power import SupplyThruster, check_battery_models, limits_at

    bat = battery if battery is not None else vehicle.battery
    if bat is None:
        raise ValueError(f"{vehicle.name} has no battery block")
    soc = state_of_charge("soc", soc)
    depth = _check_depth(depth)
    check_battery_models(vehicle, bat)
    st = SupplyThruster(physical_model(bat.thruster_power_model))
    v = bat.ocv(soc)
    ok, roll, pitch, r, i = False, 0.0, 0.0, None, 0.0
    for _ in range(30):
        lim = limits_at(vehicle, v)
        ok, roll, pitch, r = steady_hold(vehicle, current, _allocator(vehicle, lim, modes), depth,
                                         start)
        vn, i = bat.supply(soc, r.thrust, st)
        if abs(vn - v) < 1e-6:
            v = vn
            break
        v = vn
    reason = "" if ok else "thrust limits at the loaded voltage (or attitude)"
    limit = ""
    if v < bat.min_voltage:
        ok = False
        reason = limit = f"loaded voltage {v:.2f} V below the minimum {bat.min_voltage:g} V"
    if bat.max_current is not None and i > bat.max_current:
        ok = False
        reason = limit = f"current {i:.1f} A above the battery's {bat.max_current:g} A"
    cmd = st.command_for(r.thrust, v)
    return BatteryHold(bool(ok), float(soc), float(v), float(i), limits_at(vehicle, v), roll,
                       pitch, r, reason, cmd, limit)


@dataclass(frozen=True)
class EnduranceResult(Result):
    """Holding station against a current from full charge until the battery cannot."""

    vehicle: str
    speed: float
    relative_deg: float
    time_s: np.ndarray
    soc: np.ndarray
    voltage: np.ndarray
    current: np.ndarray
    max_forward_thrust: np.ndarray
    endurance_s: float
    reason: str
    thrust: np.ndarray = None  # (k, n) held thrusts
    command: np.ndarray = None  # (k, n) commands giving them at the loaded voltage
    thruster_names: tuple = ()  # the legend of the held commands

    def summary(self) -> str:
        e = self.endurance_s
        return (f"{self.vehicle} holding station against {self.speed:.2f} m/s from "
                f"{self.relative_deg:.0f}°: {e / 60:.1f} min ({self.reason}); supply "
                f"{self.voltage[0]:.2f} → {self.voltage[-1]:.2f} V, current {self.current[0]:.1f} → "
                f"{self.current[-1]:.1f} A, forward thrust limit {self.max_forward_thrust[0]:.1f} → "
                f"{self.max_forward_thrust[-1]:.1f} N")

    def to_dict(self) -> dict:
        return {"vehicle": self.vehicle, "speed_m_s": self.speed, "relative_deg": self.relative_deg,
                "endurance_s": self.endurance_s, "reason": self.reason,
                "time_s": self.time_s.tolist(), "soc": self.soc.tolist(),
                "voltage_V": self.voltage.tolist(), "current_A": self.current.tolist(),
                "max_forward_thrust_N": self.max_forward_thrust.tolist(),
                "thrust_N": None if self.thrust is None else self.thrust.tolist(),
                "command": None if self.command is None else self.command.tolist()}

    def plot(self, path=None):
        """SOC, voltage, current, limit and the held commands over the discharge."""
        from uuvid.core.plots import new_figure, save_figure

        fig, ax = new_figure(2, 2, figsize=(10, 6))
        ax = ax.ravel()
        tm = self.time_s / 60
        ax[0].plot(tm, self.voltage)
        ax[0].set_ylabel("loaded supply voltage [V]")
        ax[1].plot(tm, self.current)
        ax[1].set_ylabel("battery current [A]")
        ax[2].plot(tm, self.max_forward_thrust)
        ax[2].set_ylabel("forward thrust limit [N]")
        if self.command is not None:
            names = list(self.thruster_names) or [f"T{i + 1}" for i in range(self.command.shape[1])]
            for j, name in enumerate(names[: self.command.shape[1]]):
                ax[3].plot(tm, self.command[:, j], label=name)
            ax[3].legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
        ax[3].set_ylabel("held commands [µs]")
        for a in ax:
            a.set_xlabel("time [min]")
        ax[2].set_title("thrust limit at the loaded voltage")
        ax[3].set_title("commands holding station, per thruster")
        fig.suptitle(self.title())
        return save_figure(fig, path) if path is not None else fig

    def title(self) -> str:
        """One whole line for a figure: vehicle, current, endurance (the summary is too long)."""
        return (f"{self.vehicle} holding station against {self.speed:.2f} m/s from "
                f"{self.relative_deg:.0f}°: {self.endurance_s / 60:.1f} min")


def endurance(vehicle, speed: float, relative_deg: float = 0.0, *, soc0: float = 1.0,
              battery=None, modes=None, depth: float = 2.0, dsoc: float = 0.01,
              progress: bool | None = None) -> EnduranceResult:
    """Time until the battery can no longer hold station against ``speed`` from
    ``relative_deg``: quasi-steady discharge ``dt = 3600 Q ΔSOC / I(SOC)`` (trapezoid in 1/I),
    stepping SOC down by ``dsoc`` from ``soc0`` and stopping where :func:`hold_on_battery`
    fails (interpolated between the last held and the first failed SOC by bisection).
    ``progress``: a bar on stderr, one stage per 10 % of charge (``None``: automatic)."""
    from uuvid.core.checks import direction_deg

    return _endurance(vehicle, speed, direction_deg("relative_deg", relative_deg), soc0=soc0,
                      battery=battery, modes=modes, depth=depth, dsoc=dsoc, progress=progress)


def _endurance(vehicle, speed: float, relative_deg: float, *, soc0: float = 1.0, battery=None,
               modes=None, depth: float = 2.0, dsoc: float = 0.01,
               progress: bool | None = None) -> EnduranceResult:
    """:func:`endurance` at a ``relative_deg`` already checked (the command line's ``--current``
    direction): its warnings are not said again."""
    from uuvid.core.checks import non_negative, positive
    from uuvid.core.progress import progress_task

    speed = non_negative("speed", speed, "m/s")
    soc0 = state_of_charge("soc0", soc0)
    depth = _check_depth(depth)
    dsoc = positive("dsoc", dsoc, "the step of state of charge")
    if dsoc > 1.0:
        raise ValueError(f"dsoc = {dsoc:g}: expected a step of state of charge of at most 1")
    task = progress_task(f"{vehicle.name} endurance", total=max(1, math.ceil(soc0 / dsoc)),
                         eta=False, stages=max(1, math.ceil(soc0 * 10)),
                         disable=None if progress is None else not progress)
    with task:
        return _discharge(vehicle, speed, relative_deg, soc0, battery, modes, depth, dsoc, task)


def _discharge(vehicle, speed, relative_deg, soc0, battery, modes, depth, dsoc, task):
    bat = battery if battery is not None else vehicle.battery
    if bat is None:
        raise ValueError(f"{vehicle.name} has no battery block")
    cur = current_ned(speed, relative_deg)
    rows, ang = [], (0.0, 0.0)
    soc, t = soc0, 0.0
    reason = "battery empty"
    h = hold_on_battery(vehicle, cur, soc, battery=bat, modes=modes, depth=depth, start=ang)
    if not h.held:
        return EnduranceResult(vehicle.name, speed, relative_deg, np.zeros(1), np.array([soc]),
                               np.array([h.voltage]), np.array([h.current]),
                               np.array([h.limits[0, 1]]), 0.0, h.reason,
                               thruster_names=tuple(t.name for t in vehicle.layout))
    rows.append((t, soc, h.voltage, h.current, h.limits[0, 1]))
    extra = [(h.allocation.thrust, h.command)]
    while soc > 0:
        s2 = max(soc - dsoc, 0.0)
        task.advance()
        if math.floor(soc * 10 + 1e-9) != math.floor(s2 * 10 + 1e-9) or not task.stages:
            task.stage(f"holding {speed:g} m/s at SOC {s2:.0%}")
        h2 = hold_on_battery(vehicle, cur, s2, battery=bat, modes=modes, depth=depth,
                             start=(h.roll, h.pitch))
        if not h2.held:
            lo, hi = s2, soc  # hi held, lo failed
            for _ in range(20):
                mid = 0.5 * (lo + hi)
                hm = hold_on_battery(vehicle, cur, mid, battery=bat, modes=modes, depth=depth,
                                     start=(h.roll, h.pitch))
                if hm.held:
                    hi, h_end = mid, hm
                else:
                    lo = mid
            if hi < soc:
                t += 3600 * bat.capacity_ah * (soc - hi) * 0.5 * (1 / h.current + 1 / h_end.current)
                rows.append((t, hi, h_end.voltage, h_end.current, h_end.limits[0, 1]))
                extra.append((h_end.allocation.thrust, h_end.command))
            reason = h2.reason
            break
        t += 3600 * bat.capacity_ah * (soc - s2) * 0.5 * (1 / h.current + 1 / h2.current)
        soc, h = s2, h2
        rows.append((t, soc, h.voltage, h.current, h.limits[0, 1]))
        extra.append((h.allocation.thrust, h.command))
    a = np.array(rows)
    return EnduranceResult(vehicle.name, speed, relative_deg, a[:, 0], a[:, 1], a[:, 2], a[:, 3],
                           a[:, 4], float(a[-1, 0]), reason, np.array([e[0] for e in extra]),
                           np.array([e[1] for e in extra]),
                           tuple(t.name for t in vehicle.layout))


def write_hold_report(folder, cap: CapabilityResult, doc: dict, current=None,
                      endur: EnduranceResult | None = None) -> Path:
    """``uuvid vehicle hold --out``: capability.png (the requested ``current`` = (speed, from
    deg) marked), endurance.png when there is an endurance, hold.json and an index.html linking
    them all, as a whole (:func:`uuvid.core.atomic.atomic_dir`: built beside ``folder`` and
    swapped in, so an interrupted run — Ctrl-C while the figure is drawn — leaves no empty or
    partial folder, and an old report intact).  Returns the index."""
    from uuvid.core.atomic import atomic_dir

    final = Path(folder)
    with atomic_dir(final) as work:
        index = _hold_report_into(work, cap, doc, current, endur)
    return final / Path(index).relative_to(work)


def _hold_report_into(folder: Path, cap: CapabilityResult, doc: dict, current,
                      endur: EnduranceResult | None) -> Path:
    """:func:`write_hold_report`'s content, written into ``folder``; returns the index."""
    from uuvid.core.atomic import atomic_write_json
    from uuvid.core.html import Report

    a = doc.get("at_current")
    mark = None if current is None else (*current[:2], a["holds"]) if a else current
    cap.plot(folder / "capability.png", mark=mark)
    rep = Report(f"Station keeping: {cap.vehicle}")
    rep.add_preformatted(cap.summary())
    rep.add_figure(folder / "capability.png", caption="Largest current held [m/s] against the "
                   "direction it comes from" + (" — the star is the requested current"
                                                if current is not None else ""))
    if a:
        rep.add_table([{"current_m_s": a["speed_m_s"], "from_deg": a["from_deg"],
                        "largest_held_m_s": a["max_current_m_s"], "holds": a["holds"]}],
                      caption="The requested current")
    if endur is not None:
        endur.plot(folder / "endurance.png")
        rep.add_preformatted(endur.summary())
        rep.add_figure(folder / "endurance.png", caption="Discharge while holding station")
    rep.add_links("Data:", ["hold.json"])
    atomic_write_json(folder / "hold.json", doc)
    return rep.write(folder)
