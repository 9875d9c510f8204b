"""Thrust limits at the vehicle's own speed: the steady analyses' view of inflow (issue 21).

The vehicle file's thrust limits ``[min, max]`` are bollard values (zero advance).  With
``inflow: four-quadrant`` each thruster's limit at a steady body velocity ``ν_r`` (relative to
the water) is its bollard limit times the fraction of bollard thrust its propeller keeps at the
advance speed ``u_a = (1 − w) axisᵀ(v_r + ω × r)`` (:func:`uuvid.thruster.inflow.advance_speeds`)::

    T_max(u_a) = T_max · T(n₊, u_a) / T(n₊, 0),    T_min(u_a) = T_min · T(n₋, u_a) / T(n₋, 0)

with ``T(n, u_a)`` the four-quadrant map of the thruster's propeller and ``n±`` the shaft speed
giving the bollard limit.  ASSUMPTION (labelled): the shaft speed at full command does not
change with the advance speed (in a real ESC/motor the unloaded propeller speeds up a little, so
this errs on the side of less thrust).  A limit that would change sign is held at zero (the
thruster then cannot push that way at all).  At ``ν_r = 0`` the limits are exactly the file's.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from uuvid.thruster.inflow import (
    INFLOW_MODELS,
    FourQuadrantMap,
    advance_speeds,
    map_from_section,
    propeller_map,
)

#: The propellers :func:`thruster_map` knows, for messages.
KNOWN_PROPELLERS = ("t200, t200-physical, or a thruster model file with a four-quadrant 'inflow' "
                    "section (uuvid thruster fit --model four-quadrant --diameter D on a bench in "
                    "a flow)")


def thruster_map(model: str, base=None) -> FourQuadrantMap:
    """The four-quadrant map of a vehicle thruster's ``model``: a preset's published propeller
    (:func:`uuvid.thruster.inflow.propeller_map`), else the ``inflow`` section of the model file
    it names (relative to ``base``, the vehicle file's folder; :func:`uuvid.thruster.inflow.
    map_from_section`) — the map fitted on the user's own bench in a flow.  ``KeyError`` when
    the preset or file has no propeller data, ``FileNotFoundError`` / ``ModelFileError`` for a
    missing or bad file, ``ValueError`` (naming the file's key) when its section is not a
    four-quadrant map."""
    try:
        return propeller_map(model)
    except KeyError:
        pass
    from pathlib import Path

    from uuvid.thruster.resolve import is_preset

    if is_preset(model):  # a preset without propeller data
        raise KeyError(model)
    p = Path(model) if base is None or Path(model).is_absolute() else Path(base) / model
    try:
        st = p.stat()
        stamp = (st.st_size, st.st_mtime_ns)
    except OSError:
        stamp = None
    return _file_map(model, None if base is None else str(base), stamp)


@functools.lru_cache(maxsize=64)
def _file_map(model: str, base: str | None, stamp) -> FourQuadrantMap:
    """:func:`thruster_map` of a model file, memoised on its size and modification time (the
    analyses ask for it per heading and speed)."""
    from uuvid.thruster.resolve import resolve_chain

    chain = resolve_chain(model, base)  # FileNotFoundError, ModelFileError: the file's own cause
    if chain.inflow is None:
        raise KeyError(model)
    fq = map_from_section(chain.inflow, where=f"{model}: inflow")
    _check_against_bollard(fq, chain, model)
    return fq


def _check_against_bollard(fq: FourQuadrantMap, chain, model: str) -> None:
    """A fit writes the map's bollard point as the file's block (``T = K_T Ω|Ω|``): a map that
    disagrees with it by more than 2× has a wrong diameter (mm for m: 10¹² in ``D⁴``) or an
    edited coefficient — an error, not a silently weaker or stronger thruster."""
    from uuvid.thruster.blocks import QuadraticMap
    from uuvid.thruster.inflow import RHO_FRESH

    blk = chain.blocks[0] if len(chain.blocks) == 1 else None
    if not (isinstance(blk, QuadraticMap) and chain.input_kind == "speed" and blk.k_pos > 0):
        return
    k_map = fq.bollard_kt(1) * RHO_FRESH * fq.diameter ** 4 / (2.0 * math.pi) ** 2
    r = k_map / blk.k_pos
    if not 0.5 < r < 2.0:
        raise ValueError(f"{model}: inflow.diameter_m = {fq.diameter:g} m: the map's bollard thrust "
                         f"coefficient is {r:.3g}× the file's own bollard map (its block, K_T = "
                         f"{blk.k_pos:.4g} N·s²/rad²) — a diameter in mm, or an edited coefficient?")


def map_range_warnings(fq: FourQuadrantMap, limits, where: str) -> list[str]:
    """Why a fitted map (its ``beta_ranges_deg``) cannot hold where a thruster with bollard
    ``limits`` ``[min, max]`` works: the bollard point of a direction it pushes (β = 0° ahead,
    ±180° astern) outside the fitted advance angles means that direction's thrust — and the shaft
    speed the loop infers from it — is an extrapolation of the series."""
    out = []
    lo, hi = float(limits[0]), float(limits[1])
    for need, beta, what in ((hi > 0, 0.0, "ahead (β = 0°)"), (lo < 0, 180.0, "astern (β = ±180°)")):
        if need and not fq.covers(beta):
            out.append(f"{where}: the propeller map was fitted over β ∈ {fq.ranges_text()}, "
                       f"but the thruster also pushes {what}: its thrust there is an "
                       "extrapolation of the series (record bench runs that turn that way, or set "
                       "inflow: none)")
    return out


def resolve_inflow(vehicle, inflow: str | None = None) -> str:
    """The inflow model in force: ``inflow`` if given (``'none'`` switches it off), else the
    vehicle file's ``inflow`` key."""
    mode = getattr(vehicle, "inflow", "none") if inflow is None else inflow
    if mode not in INFLOW_MODELS:
        raise ValueError(f"inflow must be one of {', '.join(INFLOW_MODELS)}, got {mode!r}")
    return mode


@dataclass(frozen=True, eq=False)
class InflowLimits:
    """Per-thruster data to turn bollard limits into limits at a body velocity."""

    model: str
    maps: tuple[FourQuadrantMap, ...]
    positions: np.ndarray  # (n, 3)
    axes: np.ndarray  # (n, 3)
    wake: np.ndarray  # (n,)
    limits: np.ndarray  # (n, 2) bollard
    n_fwd: np.ndarray  # rev/s at the upper limit
    n_rev: np.ndarray  # rev/s at the lower limit (negative)

    def with_limits(self, limits) -> InflowLimits:
        """The same thrusters with other bollard limits (e.g. at a supply voltage)."""
        lim = np.asarray(limits, float).reshape(self.limits.shape)
        return InflowLimits(self.model, self.maps, self.positions, self.axes, self.wake, lim,
                            np.array([m.shaft_speed_for(lim[i, 1]) for i, m in enumerate(self.maps)]),
                            np.array([m.shaft_speed_for(lim[i, 0]) for i, m in enumerate(self.maps)]))

    def advance(self, nu_r) -> np.ndarray:
        """Advance speed at each thruster (m/s) for body velocity ``ν_r`` relative to the water."""
        return advance_speeds(nu_r, self.positions, self.axes, self.wake)

    def extrapolated(self, nu_r) -> list[tuple[int, float]]:
        """``(thruster, β in deg)`` of each limit :meth:`limits_at` takes outside its map's fitted
        advance angles at body velocity ``ν_r`` (empty for maps of the whole circle)."""
        ua = self.advance(nu_r)
        out = []
        for i, m in enumerate(self.maps):
            for n in (self.n_fwd[i], self.n_rev[i]):
                if n != 0.0 and m.beta_ranges_deg is not None:
                    b = math.degrees(math.atan2(ua[i], 0.7 * math.pi * n * m.diameter))
                    if not m.covers(b):
                        out.append((i, b))
        return out

    def limits_at(self, nu_r) -> np.ndarray:
        """``(n, 2)`` thrust limits at steady body velocity ``ν_r`` (see the module text)."""
        ua = self.advance(nu_r)
        out = self.limits.copy()
        for i, m in enumerate(self.maps):
            if ua[i] == 0.0:
                continue
            if self.n_fwd[i] != 0.0:
                out[i, 1] = max(0.0, self.limits[i, 1] * float(m.thrust_ratio(self.n_fwd[i], ua[i])))
            if self.n_rev[i] != 0.0:
                out[i, 0] = min(0.0, self.limits[i, 0] * float(m.thrust_ratio(self.n_rev[i], ua[i])))
        return out


def inflow_limits(vehicle, inflow: str | None = None) -> InflowLimits | None:
    """The vehicle's :class:`InflowLimits`, or ``None`` when inflow is off (``'none'``)."""
    mode = resolve_inflow(vehicle, inflow)
    if mode == "none":
        return None
    lay = vehicle.layout
    path = getattr(vehicle, "path", None)
    base = path.parent if path is not None else None
    maps = []
    for i, t in enumerate(lay):
        ref = vehicle.propeller(i) if hasattr(vehicle, "propeller") else t.model
        try:
            maps.append(thruster_map(ref, base))
        except (KeyError, OSError) as e:
            why = ("holds no propeller map" if isinstance(e, KeyError)
                   else f"cannot be read ({e})")
            raise ValueError(f"{vehicle.name}: thrusters[{t.name}]: inflow {mode!r} needs a "
                             f"propeller map, and {ref!r} {why} (known: {KNOWN_PROPELLERS}); use "
                             "inflow none") from None
    lim = np.array(lay.limits, float)  # its own (the layout's are read-only)
    for i, t in enumerate(lay):
        if not np.all(np.isfinite(lim[i])):
            raise ValueError(f"{vehicle.name}: thrusters[{t.name}].limits must be finite for inflow "
                             f"(bollard thrust at full command), got {tuple(lim[i])}")
    P = np.array([t.position for t in lay], float)
    A = np.array([t.axis for t in lay], float)
    wake = np.asarray(vehicle.wake if len(getattr(vehicle, "wake", ())) else np.zeros(lay.n), float)
    n_fwd = np.array([m.shaft_speed_for(lim[i, 1]) for i, m in enumerate(maps)])
    n_rev = np.array([m.shaft_speed_for(lim[i, 0]) for i, m in enumerate(maps)])
    return InflowLimits(mode, tuple(maps), P, A / np.linalg.norm(A, axis=1)[:, None], wake, lim,
                        n_fwd, n_rev)


@njit(cache=True, inline="always")
def state_advance_speeds_nb(x, vc_ned, G, out):
    """Advance speeds (in place) from the 13-state ``x = [η (3), q (4), ν (6)]`` of
    :func:`uuvid.vehicle.model.vehicle_rhs_into` and the NED current: ``ν_r = ν − [Rᵀ v_c; 0]``,
    then ``u_a = (1 − w) axisᵀ(v_r + ω × r) = (1 − w)(axisᵀ v_r + (r × axis)ᵀ ω)`` (for a mission
    loop, per RK4 stage: six products, the row ``G[i, 7:13]``).  ``G`` (n, 13):
    :func:`inflow_geometry`."""
    e, ex, ey, ez = x[3], x[4], x[5], x[6]
    r00 = 1.0 - 2.0 * (ey * ey + ez * ez)
    r01 = 2.0 * (ex * ey - ez * e)
    r02 = 2.0 * (ex * ez + ey * e)
    r10 = 2.0 * (ex * ey + ez * e)
    r11 = 1.0 - 2.0 * (ex * ex + ez * ez)
    r12 = 2.0 * (ey * ez - ex * e)
    r20 = 2.0 * (ex * ez - ey * e)
    r21 = 2.0 * (ey * ez + ex * e)
    r22 = 1.0 - 2.0 * (ex * ex + ey * ey)
    u = x[7] - (r00 * vc_ned[0] + r10 * vc_ned[1] + r20 * vc_ned[2])
    v = x[8] - (r01 * vc_ned[0] + r11 * vc_ned[1] + r21 * vc_ned[2])
    w = x[9] - (r02 * vc_ned[0] + r12 * vc_ned[1] + r22 * vc_ned[2])
    p, q, r = x[10], x[11], x[12]
    for i in range(G.shape[0]):  # (1 − w)(aᵀv_r + (r × a)ᵀω): the row G[i, 7:13]; G checked
        # once where a loop takes it (check_geometry), not per RK4 stage
        out[i] = (G[i, 7] * u + G[i, 8] * v + G[i, 9] * w + G[i, 10] * p + G[i, 11] * q
                  + G[i, 12] * r)
    return out


def inflow_geometry(vehicle) -> np.ndarray:
    """``(n, 13)`` rows ``[r (3), unit axis (3), wake, (1 − w)[axis, r × axis] (6)]`` of a
    vehicle's thrusters: the last six give the advance speed ``u_a = M_i ν_r`` (linear in the body
    velocity, six products per thruster: :func:`state_advance_speeds_nb`)."""
    lay = vehicle.layout
    P = np.array([t.position for t in lay], float)
    A = np.array([t.axis for t in lay], float)
    A = A / np.linalg.norm(A, axis=1)[:, None]
    w = np.asarray(vehicle.wake if len(getattr(vehicle, "wake", ())) else np.zeros(lay.n), float)
    return geometry_rows(P, A, w)


GEOMETRY_COLUMNS = 13


def check_geometry(G) -> np.ndarray:
    """``G`` as the compiled loops take it (float64, C order), or a ``ValueError`` saying what a
    geometry is: :func:`inflow_geometry`'s 13 columns (an older 7-column one, without the advance
    speed's row, would be read past its end)."""
    G = np.ascontiguousarray(G, dtype=np.float64)
    if G.ndim != 2 or (G.shape[0] and G.shape[1] != GEOMETRY_COLUMNS):
        raise ValueError(f"inflow geometry of shape {G.shape}: expected (thrusters, "
                         f"{GEOMETRY_COLUMNS}) rows [r (3), unit axis (3), wake, (1 − w)[axis, "
                         "r × axis] (6)] — build it with uuvid.vehicle.inflow.inflow_geometry "
                         "(or loop_arrays)")
    return G


def geometry_rows(P, A, w) -> np.ndarray:
    """The rows of :func:`inflow_geometry` from positions ``P`` (n, 3), unit axes ``A`` (n, 3)
    and wake fractions ``w`` (n)."""
    P, A, w = (np.asarray(a, float) for a in (P, A, w))
    M = (1.0 - w)[:, None] * np.column_stack([A, np.cross(P, A)])
    return np.ascontiguousarray(np.column_stack([P, A, w, M]))


def loop_arrays(vehicle, inflow: str | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """``(map parameters, geometry)`` for a mission loop (:func:`uuvid.thruster.inflow.
    inflow_params`, :func:`inflow_geometry`), or ``None`` when inflow is off.  One map for all
    thrusters (a vehicle's thrusters share one chain structure in the loop)."""
    from uuvid.thruster.inflow import inflow_params

    il = inflow_limits(vehicle, inflow)
    if il is None:
        return None
    distinct = {(m.diameter, m.ct_a, m.ct_b): m.name for m in il.maps}  # by content, not name
    if len(distinct) > 1:
        raise ValueError(f"{vehicle.name}: the mission loops take one propeller map for all "
                         f"thrusters, got {len(distinct)} different ones ({', '.join(distinct.values())}); "
                         "vehicle envelope, stability and hold take one per thruster")
    return inflow_params(il.maps[0]), inflow_geometry(vehicle)


def steady_speed_with_inflow(speed_of_force, force_at_speed, s0: float) -> float:
    """Fixed point ``s = speed_of_force(force_at_speed(s))`` by bracketing (``s0``: the bollard
    speed, where the thrust is largest).  ``φ(s) = s − speed_of_force(force_at_speed(s))`` rises
    through zero once between 0 and ``s0`` for a thrust that falls with speed."""
    from scipy.optimize import brentq

    if not math.isfinite(s0) or s0 == 0.0:
        return s0

    def phi(s):
        return s - speed_of_force(force_at_speed(s))

    a, b = 0.0, s0
    fa, fb = phi(a), phi(b)
    k = 0
    while fa * fb > 0 and k < 40:  # thrust rising with speed: widen the bracket
        b *= 1.5
        fb = phi(b)
        k += 1
    if fa * fb > 0:
        raise ValueError("steady speed with inflow: no balance of drag and thrust found")
    return float(brentq(phi, min(a, b), max(a, b), xtol=1e-12, rtol=1e-12))


def one_dof_inflow_matrix(vehicle) -> np.ndarray:
    """``(6, n)`` matrix ``G`` of the thrust lost to the advance speed in a 1-DOF motion.

    With the linear inflow form of each thruster (Healey et al. 1995, IEEE JOE 20(4), eq. 6 in
    its small-angle form; Fossen 2011, *Handbook of Marine Craft Hydrodynamics*, §6.7)::

        T_i = T_i,bollard − k_a |Ω_i| u_a,i,     u_a,i = (1 − w_i) axis_iᵀ(v + ω × r_i)

    (:func:`uuvid.thruster.inflow.advance_speeds`), a motion along DOF ``j`` alone at speed
    ``ν_j`` (m/s, or rad/s for roll, pitch, yaw: then ``ω × r_i`` gives the lever arm) has
    ``u_a,i = (1 − w_i) a_ij ν_j`` with ``a_ij`` the advance speed at thruster i per unit ``ν_j``
    (the axis' component along j; for yaw ``(e_z × r_i)·axis_i = (r_i × axis_i)_z``).  The DOF's
    generalised force ``τ_j = Σ_i B_ji T_i`` is then::

        τ_j = F_j,bollard − k_a c_j(t) ν_j,     c_j(t) = Σ_i G_ji |Ω_i(t)|,
        G_ji = B_ji (1 − w_i) a_ij

    Since ``B``'s column i is ``[axis_i; r_i × axis_i]``, ``a_ij = B_ji`` and ``G_ji =
    (1 − w_i) B_ji² ≥ 0``: the loss always opposes the motion, a drag proportional to the rotor
    speeds.  ``G`` is computed from :func:`advance_speeds` with unit velocities (not from that
    identity), so a change to the advance-speed convention carries over.
    """
    lay = vehicle.layout
    P = np.array([t.position for t in lay], float).reshape(-1, 3)
    A = np.array([t.axis for t in lay], float).reshape(-1, 3)
    w = np.asarray(vehicle.wake if len(getattr(vehicle, "wake", ())) else np.zeros(lay.n), float)
    B = np.asarray(vehicle.B, float)
    G = np.zeros((6, P.shape[0]))
    for j in range(6):
        e = np.zeros(6)
        e[j] = 1.0
        G[j] = B[j] * advance_speeds(e, P, A, w)
    return G


#: the rows of ``B`` (X, Y, N) and the velocity components (u, v, r) of the horizontal model
HORIZONTAL_DOFS = (0, 1, 5)


def horizontal_inflow_matrix(vehicle) -> np.ndarray:
    """``(3, 3, n)`` array ``H`` of the thrust lost to the advance speed in the coupled horizontal
    model (:mod:`uuvid.vehicle.horizontal`): with the linear inflow form of
    :func:`one_dof_inflow_matrix` and a motion ``ν_h = (u, v, r)`` in the plane, the force and
    moment ``(X, Y, N)`` are::

        τ_h = τ_h,bollard − k_a C(t) ν_h,      C_jk(t) = Σ_i H_jki |Ω_i(t)|,
        H_jki = B_ji (1 − w_i) a_ik

    ``a_ik`` the advance speed at thruster i per unit ``ν_k`` (:func:`advance_speeds` with unit
    velocities), ``j`` over the X, Y, N rows of ``B``.  ``C``'s diagonal is the 1-DOF gains
    (:func:`one_dof_inflow_matrix`); its off-diagonal terms are the loss in one DOF from a motion
    in another (a thruster at a lever arm sees the yaw rate as a surge/sway advance speed).
    ``C`` is symmetric and positive semi-definite (``Σ_i (1 − w_i)|Ω_i| b_i b_iᵀ``, ``b_i`` the
    thruster's (X, Y, N) column): the loss never feeds energy in."""
    lay = vehicle.layout
    P = np.array([t.position for t in lay], float).reshape(-1, 3)
    A = np.array([t.axis for t in lay], float).reshape(-1, 3)
    w = np.asarray(vehicle.wake if len(getattr(vehicle, "wake", ())) else np.zeros(lay.n), float)
    B = np.asarray(vehicle.B, float)[list(HORIZONTAL_DOFS)]
    H = np.zeros((3, 3, P.shape[0]))
    for k, dof in enumerate(HORIZONTAL_DOFS):
        e = np.zeros(6)
        e[dof] = 1.0
        H[:, k, :] = B * advance_speeds(e, P, A, w)[None, :]
    return H
