"""Thrust that knows the water speed: advance speed, four-quadrant maps, Healey's full form.

Three pieces, each a pure function of (state, input, parameters) with a compiled core:

* **Advance speed** at a thruster (Fossen 2011, *Handbook of Marine Craft Hydrodynamics*, §6.7;
  the wake fraction of ship propulsion, Carlton, *Marine Propellers and Propulsion*, ch. 5)::

      u_a = (1 − w) · axisᵀ (v_r + ω × r)

  with ``v_r`` the linear part of the body-frame velocity relative to the water, ``ω`` the angular
  rate, ``r`` the thruster position and ``w`` the wake fraction.

* **Four-quadrant map** (van Lammeren, van Manen & Oosterveld 1969, "The Wageningen B-screw
  series", SNAME Trans. 77; Carlton ch. 6.5): with the advance angle
  ``β = atan2(u_a, 0.7·π·n·D)`` (``n`` rev/s) and ``V_r² = u_a² + (0.7·π·n·D)²``::

      T = C_T*(β) · ½ρ V_r² · (π/4) D²,     Q = C_Q*(β) · ½ρ V_r² · (π/4) D³

  ``C_T*``, ``C_Q*`` a Fourier series in β (the published form of the Wageningen four-quadrant
  data), or a periodic table.  β covers both shaft directions, so one map holds "per direction".
  At ``u_a = 0`` the map is ``T = K_T(0) ρ n² D⁴`` — today's bollard ``T = k_t Ω|Ω|``.

* **Healey's full blade-element form** (Healey, Rock, Cody, Miles & Brown 1995, IEEE JOE 20(4),
  eqs. 6–11) with the vehicle's advance speed in the axial-flow state (Blanke, Lindegaard &
  Fossen 2000, "Dynamic model for thrust generation of marine propellers", IFAC MCMC, eq. for the
  axial flow; Fossen 2011 §6.7)::

      β = atan2(u_p, 0.7 R Ω),  α = p − β,  V² = u_p² + (0.7 R Ω)²
      L = ½ρ A V² C_Lmax sin 2α,   D = ½ρ A V² C_Dmax (1 − cos 2α)
      T = L cos β − D sin β,       Q = 0.7 R (L sin β + D cos β)
      m_f u̇_p = T − d_f |u_p| (u_p − u_a)

  ``u_p`` is the flow through the propeller, ``u_a`` the ambient advance speed.  At ``u_a = 0``
  the flow equation is exactly Healey's ``m_f u̇_p = T − d_f u_p|u_p|`` (today's
  :class:`~uuvid.thruster.blocks.HealeyThruster`).  For small ``α`` and ``β`` the thrust is the
  linear form ``T = k_t Ω|Ω| − k_a |Ω| u_p`` with ``k_t = ρ A C_Lmax (0.7R)² p`` and
  ``k_a = ρ A C_Lmax 0.7R`` (:meth:`BladeElement.linear_coefficients`), so the existing block is
  the small-angle special case.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from uuvid.thruster.blocks import HealeyThruster, ParameterError

#: Fresh water, kg/m³ (the density :meth:`HealeyThruster.from_geometry` also assumes).
RHO_FRESH = 1000.0


# ------------------------------------------------------------------------------------------------
# Advance speed
# ------------------------------------------------------------------------------------------------
@njit(cache=True)
def advance_speeds_nb(nu_r, positions, axes, wake, out):
    """Compiled ``u_a,i = (1 − w_i) axis_iᵀ(v_r + ω × r_i)`` for every thruster (in place)."""
    u, v, w = nu_r[0], nu_r[1], nu_r[2]
    p, q, r = nu_r[3], nu_r[4], nu_r[5]
    for i in range(positions.shape[0]):
        x, y, z = positions[i, 0], positions[i, 1], positions[i, 2]
        vx = u + q * z - r * y
        vy = v + r * x - p * z
        vz = w + p * y - q * x
        out[i] = (1.0 - wake[i]) * (axes[i, 0] * vx + axes[i, 1] * vy + axes[i, 2] * vz)
    return out


def advance_speeds(nu_r, positions, axes, wake=None) -> np.ndarray:
    """Advance speed at each thruster, m/s: ``u_a = (1 − w) axisᵀ(v_r + ω × r)``.

    ``nu_r`` (6,) body velocity relative to the water ``[u, v, w, p, q, r]``; ``positions`` and
    ``axes`` (n, 3) (axes are normalised here); ``wake`` (n,) wake fractions in [0, 1), or one for
    every thruster (default 0).
    """
    nu_r = np.asarray(nu_r, dtype=np.float64).reshape(-1)
    if nu_r.shape != (6,):
        raise ValueError(f"advance_speeds: nu_r must have 6 values [u, v, w, p, q, r], got "
                         f"{nu_r.size}")
    P = np.ascontiguousarray(np.asarray(positions, dtype=np.float64).reshape(-1, 3))
    A = np.asarray(axes, dtype=np.float64).reshape(-1, 3)
    if A.shape != P.shape:
        raise ValueError(f"advance_speeds: axes {A.shape} and positions {P.shape} differ")
    norm = np.linalg.norm(A, axis=1)
    if np.any(norm < 1e-12):
        raise ValueError("advance_speeds: every thruster axis must be a non-zero vector")
    A = np.ascontiguousarray(A / norm[:, None])
    w = np.zeros(len(P)) if wake is None else np.asarray(wake, dtype=np.float64).reshape(-1)
    if w.size == 1:
        w = np.full(len(P), w[0])
    elif w.size != len(P):  # the kernel reads wake[i] for every thruster: a short array read past
        raise ValueError(f"advance_speeds: {w.size} wake fractions for {len(P)} thrusters: "
                         "expected one per thruster, or one for all")
    check_wake(w)
    return advance_speeds_nb(nu_r, P, A, np.ascontiguousarray(w), np.empty(len(P)))


def check_wake(wake) -> None:
    """Wake fractions must lie in [0, 1) (``w = 1`` would hide the vehicle's speed entirely)."""
    w = np.atleast_1d(np.asarray(wake, dtype=float))
    bad = ~((w >= 0.0) & (w < 1.0))
    if np.any(bad):
        raise ParameterError(f"wake fraction must be in [0, 1), got {w[bad][0]!r}", "wake")


# ------------------------------------------------------------------------------------------------
# Four-quadrant map
# ------------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def fourier_nb(a, b, beta):
    """``Σ_k a_k cos kβ + b_k sin kβ`` (k = 0 … len(a) − 1)."""
    s = 0.0
    for k in range(a.shape[0]):
        s += a[k] * math.cos(k * beta) + b[k] * math.sin(k * beta)
    return s


@njit(cache=True)
def map_thrust_torque_nb(ct_a, ct_b, cq_a, cq_b, diameter, rho, n, ua):
    """Compiled four-quadrant ``(T, Q)`` at shaft speed ``n`` (rev/s) and advance ``u_a`` (m/s)."""
    vt = 0.7 * math.pi * n * diameter
    beta = math.atan2(ua, vt)
    q = 0.5 * rho * (ua * ua + vt * vt) * 0.25 * math.pi * diameter * diameter
    return (fourier_nb(ct_a, ct_b, beta) * q, fourier_nb(cq_a, cq_b, beta) * q * diameter)


#: :meth:`FourQuadrantMap.covers`' tolerance: this fraction of a fitted interval's width …
COVER_TOL_FRACTION = 0.1
#: … at most this (deg; the fixed tolerance it had before, for the usual intervals ≥ 10° wide) …
COVER_TOL_MAX_DEG = 1.0
#: … and at least this (deg): rounding of the interval's ends, e.g. in a model file.
COVER_TOL_MIN_DEG = 1e-6


def cover_tolerance(lo: float, hi: float) -> float:
    """Degrees beyond a fitted advance-angle interval ``[lo, hi]`` still counted as inside it:
    ``COVER_TOL_FRACTION × (hi − lo)`` clipped to [``COVER_TOL_MIN_DEG``, ``COVER_TOL_MAX_DEG``]."""
    return min(COVER_TOL_MAX_DEG, max(COVER_TOL_MIN_DEG, COVER_TOL_FRACTION * (hi - lo)))


@dataclass(frozen=True)
class FourQuadrantMap:
    """``C_T*(β)``, ``C_Q*(β)`` as Fourier series (see the module docstring for the equations).

    ``ct_a``/``ct_b`` (cos/sin coefficients, k = 0 … N) and likewise ``cq_*``; ``diameter`` in m.
    ``source`` and ``assumption`` say where the numbers come from.
    """

    name: str
    diameter: float
    ct_a: tuple[float, ...]
    ct_b: tuple[float, ...]
    cq_a: tuple[float, ...]
    cq_b: tuple[float, ...]
    source: str = ""
    assumption: str = ""
    #: advance-angle intervals (deg, ``(lo, hi)`` each, one per shaft direction the data turned)
    #: a fitted map's coefficients hold over; ``None``: the whole circle (a published series)
    beta_ranges_deg: tuple[tuple[float, float], ...] | None = None

    def __post_init__(self):
        if not (math.isfinite(self.diameter) and self.diameter > 0):
            raise ParameterError(f"FourQuadrantMap.diameter must be a positive length in m, got "
                                 f"{self.diameter!r}", "diameter")
        n = len(self.ct_a)
        for f in ("ct_b", "cq_a", "cq_b"):
            if len(getattr(self, f)) != n:
                raise ParameterError(f"FourQuadrantMap.{f} must have {n} coefficients (as ct_a), "
                                     f"got {len(getattr(self, f))}", f)
        if n == 0 or not np.all(np.isfinite(np.r_[self.ct_a, self.ct_b, self.cq_a, self.cq_b])):
            raise ParameterError("FourQuadrantMap coefficients must be finite and non-empty",
                                 "ct_a")

    @classmethod
    def fit(cls, name: str, diameter: float, beta, ct, cq, order: int = 16, **kw):
        """Least-squares Fourier series of order ``order`` through samples ``(β [rad], C_T*, C_Q*)``
        (e.g. a published table); the samples must cover the whole circle."""
        beta = np.asarray(beta, float)
        k = np.arange(order + 1)
        X = np.hstack([np.cos(np.outer(beta, k)), np.sin(np.outer(beta, k[1:]))])
        ca = np.linalg.lstsq(X, np.asarray(ct, float), rcond=None)[0]
        qa = np.linalg.lstsq(X, np.asarray(cq, float), rcond=None)[0]

        def split(c):
            c = [float(v) for v in c]
            return tuple(c[:order + 1]), (0.0,) + tuple(c[order + 1:])

        (cta, ctb), (cqa, cqb) = split(ca), split(qa)
        return cls(name, diameter, cta, ctb, cqa, cqb, **kw)

    def with_diameter(self, diameter: float) -> FourQuadrantMap:
        """The same non-dimensional map for a geometrically similar propeller of another size."""
        return FourQuadrantMap(self.name, diameter, self.ct_a, self.ct_b, self.cq_a, self.cq_b,
                               self.source, self.assumption, self.beta_ranges_deg)

    def covers(self, beta_deg: float, tol: float | None = None) -> bool:
        """Does the map hold at advance angle ``beta_deg`` (within a tolerance of a fitted
        interval, angles taken modulo 360°)?  Always for a map of the whole circle.

        The tolerance (deg) is ``tol`` if given, else :func:`cover_tolerance` of each interval:
        a tenth of its width, at most 1°, so that an interval as narrow as a wrong diameter
        makes it (10 m instead of 0.076 m squeezes the bench's 0–14° into 0–0.11°) is not
        widened past everything a vehicle reaches."""
        if self.beta_ranges_deg is None:
            return True
        for lo, hi in self.beta_ranges_deg:
            t = cover_tolerance(lo, hi) if tol is None else tol
            if any(lo - t <= b <= hi + t for b in (beta_deg - 360.0, beta_deg, beta_deg + 360.0)):
                return True
        return False

    def ranges_text(self) -> str:
        """The fitted advance-angle intervals, for messages (``"the whole circle"`` if none)."""
        if self.beta_ranges_deg is None:
            return "the whole circle"
        def text(lo, hi):  # whole degrees, more decimals for an interval under 10° wide
            w = hi - lo
            d = min(6, max(0, math.ceil(-math.log10(w)) + 1)) if w > 0 else 0
            return f"[{lo:.{d}f}°, {hi:.{d}f}°]"

        return " and ".join(text(lo, hi) for lo, hi in self.beta_ranges_deg)

    def _arrays(self):
        return (np.asarray(self.ct_a), np.asarray(self.ct_b), np.asarray(self.cq_a),
                np.asarray(self.cq_b))

    def ct(self, beta) -> np.ndarray:
        """``C_T*(β)``, β in rad."""
        b = np.asarray(beta, float)[..., None]
        k = np.arange(len(self.ct_a))
        return (np.asarray(self.ct_a) * np.cos(k * b) + np.asarray(self.ct_b) * np.sin(k * b)).sum(-1)

    def cq(self, beta) -> np.ndarray:
        """``C_Q*(β)``, β in rad."""
        b = np.asarray(beta, float)[..., None]
        k = np.arange(len(self.cq_a))
        return (np.asarray(self.cq_a) * np.cos(k * b) + np.asarray(self.cq_b) * np.sin(k * b)).sum(-1)

    def thrust_torque(self, n, ua, rho: float = RHO_FRESH):
        """``(T [N], Q [N·m])`` at shaft speed ``n`` (rev/s) and advance speed ``u_a`` (m/s)."""
        n, ua = np.broadcast_arrays(np.asarray(n, float), np.asarray(ua, float))
        vt = 0.7 * np.pi * n * self.diameter
        beta = np.arctan2(ua, vt)
        q = 0.5 * rho * (ua ** 2 + vt ** 2) * 0.25 * np.pi * self.diameter ** 2
        return self.ct(beta) * q, self.cq(beta) * q * self.diameter

    def kt_kq(self, J):
        """Open-water ``K_T(J)``, ``K_Q(J)`` for ``n > 0``: ``K = C* · (π/8)(J² + (0.7π)²)``."""
        J = np.asarray(J, float)
        beta = np.arctan2(J, 0.7 * np.pi)
        s = np.pi / 8.0 * (J ** 2 + (0.7 * np.pi) ** 2)
        return self.ct(beta) * s, self.cq(beta) * s

    def bollard_kt(self, direction: int = 1) -> float:
        """``K_T`` at ``u_a = 0``: ``T = K_T ρ n² D⁴`` (sign of thrust with ``direction``)."""
        return float(self.ct(0.0 if direction > 0 else math.pi)) * math.pi / 8.0 * (0.7 * math.pi) ** 2

    def shaft_speed_for(self, thrust: float, rho: float = RHO_FRESH) -> float:
        """Shaft speed (rev/s, signed) that gives bollard ``thrust`` (N, signed)."""
        if thrust == 0:
            return 0.0
        d = 1 if thrust > 0 else -1
        kt = self.bollard_kt(d)
        if kt * d <= 0:
            raise ValueError(f"{self.name}: bollard K_T has the wrong sign for direction {d}")
        return d * math.sqrt(abs(thrust) / (rho * abs(kt) * self.diameter ** 4))

    def thrust_ratio(self, n, ua) -> np.ndarray:
        """``T(n, u_a) / T(n, 0)`` — the fraction of bollard thrust left at advance ``u_a`` with the
        shaft speed held (equals 1 exactly at ``u_a = 0``)."""
        n = np.asarray(n, float)
        vt = 0.7 * np.pi * n * self.diameter
        beta = np.arctan2(ua, vt)
        b0 = np.where(n >= 0, 0.0, np.pi)
        return self.ct(beta) / self.ct(b0) * (1.0 + (np.asarray(ua, float) / vt) ** 2)


#: Intervals of the C_T* table a mission loop reads (:func:`inflow_params`): cubic Hermite
#: pieces on a uniform grid of the diamond angle (:func:`diamond_angle`) over [−2, 2) — a
#: quarter of them per quadrant of β — with the series' exact values and slopes at the nodes,
#: within 1e-11 of the series (of C_T*, whose peak is ~1) for the 21-term published map
#: (tests/test_inflow.py), and as cheap for a 21-term series as for a 5-term one.
INFLOW_TABLE_INTERVALS = 8192
#: Header length of :func:`inflow_params` before the table.
INFLOW_TABLE_OFFSET = 6


def diamond_angle(ua, vt) -> np.ndarray:
    """The diamond angle ``p ∈ [−2, 2]`` of the point ``(vt, ua)``: ``q = u_a/(|u_a| + |v_t|)``,
    ``p = q`` ahead (``v_t ≥ 0``, β ∈ [−π/2, π/2]) and ``p = ±2 − q`` astern (sign of ``u_a``).
    It is monotone in the advance angle ``β = atan2(u_a, v_t)`` and equal to it at 0, ±π/2 (as
    ±1) and ±π (as ±2), and it costs a division instead of an ``atan2``: the loops' table of
    ``C_T*`` is uniform in ``p`` (:func:`ct_table`)."""
    ua, vt = np.asarray(ua, float), np.asarray(vt, float)
    q = ua / (np.abs(ua) + np.abs(vt))
    return np.where(vt >= 0.0, q, np.copysign(2.0, ua) - q)


def diamond_to_beta(p) -> tuple[np.ndarray, np.ndarray]:
    """``(β, dβ/dp)`` at diamond angles ``p`` (:func:`diamond_angle`): on the diamond
    ``|s| + |c| = 1`` with ``s = sin``-side, ``c = cos``-side coordinates linear in ``p``,
    ``β = atan2(s, c)`` and ``dβ/dp = 1/(s² + c²)``."""
    p = np.asarray(p, float)
    s = np.where(np.abs(p) <= 1.0, p, np.copysign(2.0, p) - p)
    c = 1.0 - np.abs(p)
    return np.arctan2(s, c), 1.0 / (s * s + c * c)


def ct_table(fq: FourQuadrantMap, intervals: int = INFLOW_TABLE_INTERVALS) -> np.ndarray:
    """``(intervals, 4)`` cubic coefficients ``c0 + c1 t + c2 t² + c3 t³`` (``t`` ∈ [0, 1] across
    an interval) of ``C_T*`` on the uniform grid of diamond angles ``p_j = −2 + 4j/intervals``
    (:func:`diamond_angle`): Hermite pieces through the series' values (:meth:`FourQuadrantMap.ct`)
    at ``β(p_j)`` and slopes ``dC_T*/dp = dβ/dp · Σ k (b_k cos kβ − a_k sin kβ)``.  ``β(p)`` is
    smooth inside each quadrant and the quadrants' edges are nodes (``intervals`` a multiple of
    4), so each piece interpolates a smooth function."""
    N = int(intervals)
    if N % 4:
        raise ValueError(f"the C_T* table needs a multiple of 4 intervals, got {N}")
    h = 4.0 / N
    b, dbdp = diamond_to_beta(-2.0 + h * np.arange(N + 1))
    k = np.arange(len(fq.ct_a))
    kb = k * b[:, None]
    f = fq.ct(b)
    d = h * dbdp * (k * (np.asarray(fq.ct_b) * np.cos(kb)
                         - np.asarray(fq.ct_a) * np.sin(kb))).sum(-1)
    f0, f1, d0, d1 = f[:-1], f[1:], d[:-1], d[1:]
    return np.column_stack([f0, d0, 3.0 * (f1 - f0) - 2.0 * d0 - d1, 2.0 * (f0 - f1) + d0 + d1])


def inflow_params(fq: FourQuadrantMap, rho: float = RHO_FRESH,
                  intervals: int = INFLOW_TABLE_INTERVALS) -> np.ndarray:
    """Flat parameters of :func:`inflow_thrust_nb`: ``[0.7πD, ⅛πρD², 1/(ρ|K_T0|D⁴) ahead, the same
    astern, N, N/4, the C_T* table (N × 4, :func:`ct_table`), K, the series' K cos and K sin
    coefficients]`` (the constants precomputed: the loop calls it per thruster and RK4 stage; the
    series itself is for the SIMD batch kernel, :func:`inflow_series`).  Built once per map (the
    map is frozen); each call returns a fresh copy."""
    return _inflow_params(fq, float(rho), int(intervals)).copy()


@functools.lru_cache(maxsize=16)
def _inflow_params(fq: FourQuadrantMap, rho: float, intervals: int) -> np.ndarray:
    D = fq.diameter
    head = [0.7 * math.pi * D, 0.125 * math.pi * rho * D * D,
            1.0 / (rho * abs(fq.bollard_kt(1)) * D ** 4),
            1.0 / (rho * abs(fq.bollard_kt(-1)) * D ** 4),
            float(intervals), intervals / 4.0]
    assert len(head) == INFLOW_TABLE_OFFSET
    return np.concatenate([head, ct_table(fq, intervals).ravel(), [len(fq.ct_a)], fq.ct_a,
                           fq.ct_b]).astype(np.float64)


def inflow_series(prm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ``C_T*`` Fourier coefficients ``(a, b)`` held at the end of :func:`inflow_params`."""
    o = INFLOW_TABLE_OFFSET + 4 * int(prm[4])
    k = int(prm[o])
    return prm[o + 1:o + 1 + k], prm[o + 1 + k:o + 1 + 2 * k]


@njit(cache=True, inline="always")
def inflow_thrust_nb(f, ua, prm):
    """Thrust at advance speed ``u_a`` of a thruster whose bollard model gives ``f`` (N).

    The shaft speed is the one the map needs for ``f`` at bollard, ``n = sgn f ·
    sqrt(|f| / (ρ |K_T0| D⁴))``; the thrust is then the map's ``T(n, u_a)``.  For ``f ≠ 0`` this is
    ``f · T(n, u_a)/T(n, 0)``, so the chain's own bollard calibration is kept; ``u_a = 0`` returns
    ``f`` itself (bit for bit: the bollard model is the zero-advance case).  ``prm``:
    :func:`inflow_params` (``C_T*`` read from its cubic table in the diamond angle: one division
    and one table step, no ``atan2``, whatever the series' order).  This is the evaluation a
    mission loop calls per thruster and stage."""
    if ua == 0.0:
        return f
    return inflow_thrust_at_nb(f, tip_speed_nb(f, prm), ua, prm)


@njit(cache=True, inline="always")
def tip_speed_nb(f, prm):
    """``v_t = 0.7π n D`` (m/s, signed) of the shaft speed the map needs for the bollard thrust
    ``f`` (:func:`inflow_thrust_nb`): a loop whose bollard thrust is held over several RK4 stages
    computes it once for them."""
    c = prm[2] if f >= 0.0 else prm[3]
    return prm[0] * math.copysign(math.sqrt(abs(f) * c), f)


@njit(cache=True, inline="always")
def inflow_thrust_at_nb(f, vt, ua, prm):
    """:func:`inflow_thrust_nb` with the tip speed ``vt`` (:func:`tip_speed_nb` of ``f``) given:
    the same arithmetic, so the same numbers."""
    if ua == 0.0:
        return f
    q = ua / (abs(ua) + abs(vt))  # the diamond angle of (vt, ua), monotone in β (diamond_angle)
    x = ((q if vt >= 0.0 else math.copysign(2.0, ua) - q) + 2.0) * prm[5]  # on the grid, [0, N]
    j = min(max(int(x), 0), int(prm[4]) - 1)  # clamped: a NaN state reads inside the table
    t = x - j
    o = 6 + 4 * j
    ct = prm[o] + t * (prm[o + 1] + t * (prm[o + 2] + t * prm[o + 3]))
    return ct * prm[1] * (ua * ua + vt * vt)


# ------------------------------------------------------------------------------------------------
# Healey's full blade-element form with the advance speed in the axial flow
# ------------------------------------------------------------------------------------------------
@njit(cache=True)
def blade_element_nb(omega, up, pitch, lift_gain, drag_gain, r07):
    """Compiled Healey 1995 blade forces ``(T, Q)``.

    ``lift_gain = ½ρ A C_Lmax``, ``drag_gain = ½ρ A C_Dmax``, ``r07 = 0.7 R``; see
    :class:`BladeElement`."""
    vt = r07 * omega
    beta = math.atan2(up, vt)
    v2 = up * up + vt * vt
    alpha = pitch - beta
    lift = lift_gain * v2 * math.sin(2.0 * alpha)
    drag = drag_gain * v2 * (1.0 - math.cos(2.0 * alpha))
    cb, sb = math.cos(beta), math.sin(beta)
    return lift * cb - drag * sb, r07 * (lift * sb + drag * cb)


@njit(cache=True, inline="always")
def axial_flow_rate_nb(thrust, up, ua, fluid_mass, flow_damping):
    """``u̇_p = (T − d_f |u_p| (u_p − u_a)) / m_f`` (Blanke et al. 2000); ``u_a = 0`` is Healey's
    ``(T − d_f u_p|u_p|)/m_f``."""
    return (thrust - flow_damping * abs(up) * (up - ua)) / fluid_mass


def axial_flow_rate(thrust, up, ua, fluid_mass: float, flow_damping: float):
    """NumPy form of :func:`axial_flow_rate_nb`."""
    up = np.asarray(up, float)
    return (np.asarray(thrust, float) - flow_damping * np.abs(up) * (up - np.asarray(ua, float))) \
        / fluid_mass


def linear_healey_forces(block: HealeyThruster, omega, up):
    """Today's linear Healey thrust and torque (``HealeyThruster``): ``T = k_t Ω|Ω| − k_a|Ω|u_p``."""
    p = block.params_array()
    omega, up = np.asarray(omega, float), np.asarray(up, float)
    aw = np.abs(omega)
    kt = np.where(omega >= 0, p[5], p[6])
    return kt * omega * aw - p[7] * aw * up, p[3] * omega * aw - p[4] * aw * up


def steady_flow(thrust_of, omega: float, ua: float, flow_damping: float) -> float:
    """The steady axial flow ``u_p`` where ``T(Ω, u_p) = d_f |u_p|(u_p − u_a)`` (bracketed root).

    ``thrust_of(omega, up)`` returns the thrust.  Between ``u_a`` and the bollard-like bound the
    residual changes sign once for a propeller whose thrust falls with the flow."""
    from scipy.optimize import brentq

    def g(up):
        return float(thrust_of(omega, up)) - flow_damping * abs(up) * (up - ua)

    lo, hi = ua, ua
    g0 = g(ua)
    if g0 == 0.0:
        return ua
    step = max(1e-3, abs(ua) * 0.1, math.sqrt(abs(g0) / flow_damping))
    for _ in range(200):
        if g0 > 0:
            hi = hi + step
            if g(hi) <= 0:
                break
        else:
            lo = lo - step
            if g(lo) >= 0:
                break
        step *= 1.6
    else:  # pragma: no cover - a thrust law that never balances the flow
        raise ValueError("steady_flow: no steady axial flow found")
    return brentq(g, lo, hi, xtol=1e-14, rtol=1e-13) if g0 > 0 else brentq(g, lo, ua, xtol=1e-14,
                                                                            rtol=1e-13)


@dataclass(frozen=True)
class BladeElement:
    """Healey et al. 1995 full thruster: blade lift and drag at 0.7 R with the flow state ``u_p``.

    ``pitch`` p (rad, geometric pitch angle at 0.7 R: ``tan p = (P/D)/(0.7π)``), ``radius`` R (m),
    ``blade_area`` A (m², effective), ``cl_max``, ``cd_max``, ``fluid_mass`` m_f (kg) and
    ``flow_damping`` d_f (kg/m) of the axial-flow control volume, ``rho`` (kg/m³).
    """

    pitch: float
    radius: float
    blade_area: float
    cl_max: float
    cd_max: float
    fluid_mass: float
    flow_damping: float
    rho: float = RHO_FRESH

    def __post_init__(self):
        for f in ("radius", "blade_area", "cl_max", "fluid_mass", "flow_damping", "rho"):
            v = getattr(self, f)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(f"BladeElement.{f} must be positive, got {v!r}", f)
        if not (math.isfinite(self.cd_max) and self.cd_max >= 0):
            raise ParameterError(f"BladeElement.cd_max must be >= 0, got {self.cd_max!r}", "cd_max")
        if not (0 < self.pitch < math.pi / 2):
            raise ParameterError(f"BladeElement.pitch must be an angle in (0, π/2) rad, got "
                                 f"{self.pitch!r}", "pitch")

    @property
    def r07(self) -> float:
        return 0.7 * self.radius

    def forces(self, omega, up):
        """``(T, Q)`` at shaft speed ``Ω`` (rad/s) and axial flow ``u_p`` (m/s) (vectorised)."""
        f = np.vectorize(lambda w, u: blade_element_nb(
            w, u, self.pitch, 0.5 * self.rho * self.blade_area * self.cl_max,
            0.5 * self.rho * self.blade_area * self.cd_max, self.r07), otypes=[float, float])
        return f(np.asarray(omega, float), np.asarray(up, float))

    def flow_rate(self, omega, up, ua):
        """``u̇_p`` with the ambient advance speed ``u_a`` in the axial flow (Blanke et al. 2000)."""
        return axial_flow_rate(self.forces(omega, up)[0], up, ua, self.fluid_mass,
                               self.flow_damping)

    def linear_coefficients(self) -> tuple[float, float]:
        """``(k_t, k_a)`` of the small-angle form ``T = k_t Ω|Ω| − k_a |Ω| u_p``:
        ``k_t = ρ A C_Lmax (0.7R)² p``, ``k_a = ρ A C_Lmax 0.7R`` (``sin 2α ≈ 2α``, ``β ≈ u_p/0.7RΩ``)."""
        g = self.rho * self.blade_area * self.cl_max
        return g * self.r07 ** 2 * self.pitch, g * self.r07

    def steady(self, omega: float, ua: float) -> dict:
        """Steady flow, thrust and torque at shaft speed ``Ω`` and advance speed ``u_a``."""
        up = steady_flow(lambda w, u: self.forces(w, u)[0], omega, ua, self.flow_damping)
        T, Q = self.forces(omega, up)
        return {"up": up, "thrust": float(T), "torque": float(Q)}


def linear_healey_steady(block: HealeyThruster, omega: float, ua: float) -> dict:
    """Steady flow and thrust of the linear Healey block at ``Ω`` with the advance speed ``u_a`` in
    the axial flow (at ``u_a = 0``: today's steady state ``k_tΩ|Ω| − k_a|Ω|u_p = d_f u_p|u_p|``)."""
    up = steady_flow(lambda w, u: linear_healey_forces(block, w, u)[0], omega, ua,
                     block.flow_damping)
    T, Q = linear_healey_forces(block, omega, up)
    return {"up": up, "thrust": float(T), "torque": float(Q)}


# ------------------------------------------------------------------------------------------------
# Presets
# ------------------------------------------------------------------------------------------------
#: Approximate open-water points of the Wageningen B4-70, P/D = 1.0 (J, K_T, 10 K_Q).
#: ASSUMPTION: recalled readings of the B-series open-water chart (van Lammeren et al. 1969;
#: Oosterveld & van Oossanen 1975 polynomials), good to about ±10 %, NOT a digitisation of the
#: published table: K_T(0) ≈ 0.45, K_T = 0 near J ≈ 1.08, best η₀ ≈ 0.7 near J ≈ 0.85.
B4_70_PD10_OPEN_WATER = ((0.0, 0.45, 0.63), (0.2, 0.40, 0.58), (0.5, 0.31, 0.48),
                         (0.8, 0.18, 0.33), (1.08, 0.0, 0.12))
#: ASSUMPTION: reverse (n < 0) lift relative to forward; B-series propellers give about 0.7–0.8 of
#: their ahead bollard thrust astern (Carlton ch. 6.5, quoted from memory).
B4_70_REVERSE_LIFT = 0.75


def _blade_map_coefficients(beta, pitch, cl, cd, cl_rev, cd0=0.0):
    """The blade-element shape of a four-quadrant map in the geometric advance angle β:
    ``C_T* = c_l(β) sin 2(p−β) cos β − c_D sin β``, ``C_Q* = 0.35 (c_l(β) sin 2(p−β) sin β +
    c_D cos β)`` with ``c_D = c_d0 + c_d (1 − cos 2(p−β))`` (Healey's drag plus a profile drag
    ``c_d0``, so that the torque stays positive where the thrust vanishes), and the lift weight
    ``c_l(β)`` blending smoothly from ahead (cos β = 1) to astern (cos β = −1)."""
    a = pitch - beta
    clb = cl * (1 + np.cos(beta)) / 2 + cl_rev * (1 - np.cos(beta)) / 2
    lift, drag = clb * np.sin(2 * a), cd0 + cd * (1 - np.cos(2 * a))
    return lift * np.cos(beta) - drag * np.sin(beta), 0.35 * (lift * np.sin(beta) + drag * np.cos(beta))


@functools.cache
def wageningen_b4_70_approx(diameter: float = 1.0) -> FourQuadrantMap:
    """Four-quadrant map shaped like a Wageningen B4-70, P/D = 1.0 propeller.

    ASSUMPTION (labelled): the published four-quadrant Fourier coefficients (van Lammeren et al.
    1969; MARIN) were not available here.  The map is Healey's blade-element shape (C_L ∝ sin 2α,
    C_D ∝ 1 − cos 2α, in the geometric advance angle) with pitch angle, lift and drag gains fitted
    by least squares to the recalled open-water points :data:`B4_70_PD10_OPEN_WATER`, the astern
    lift scaled by :data:`B4_70_REVERSE_LIFT`, then expanded to a 4th-order Fourier
    series (exact: the shape is a trigonometric polynomial of degree 4).
    Kept for comparison: the published table is :func:`wageningen_b4_70`.
    """
    from scipy.optimize import least_squares

    pts = np.asarray(B4_70_PD10_OPEN_WATER, float)
    J, kt, kq = pts[:, 0], pts[:, 1], pts[:, 2] / 10.0
    beta = np.arctan2(J, 0.7 * np.pi)
    s = np.pi / 8 * (J ** 2 + (0.7 * np.pi) ** 2)

    def res(x):
        ct, cq = _blade_map_coefficients(beta, x[0], x[1], x[2], x[1], x[3])
        return np.r_[(ct * s - kt) / 0.45, (cq * s - kq) / 0.063]

    x = least_squares(res, [math.atan(1.0 / (0.7 * math.pi)), 0.3, 0.3, 0.0],
                      bounds=([0.05, 0.0, 0.0, 0.0], [1.4, 5.0, 5.0, 1.0])).x
    grid = np.linspace(-np.pi, np.pi, 721)[:-1]
    ct, cq = _blade_map_coefficients(grid, x[0], x[1], x[2], B4_70_REVERSE_LIFT * x[1], x[3])
    return FourQuadrantMap.fit(
        "wageningen-b4-70-pd1.0-approx", diameter, grid, ct, cq, order=4,
        source="shape: Healey et al. 1995 blade element; level: Wageningen B4-70 P/D=1.0 open-water "
               "chart (van Lammeren et al. 1969), recalled points",
        assumption="not the published four-quadrant table; open-water points recalled to ~±10 %; "
                   f"astern lift {B4_70_REVERSE_LIFT:g} × ahead (assumed)")


@functools.cache
def wageningen_b4_70(diameter: float = 1.0) -> FourQuadrantMap:
    """Four-quadrant map of the Wageningen B4-70, P/D = 1.0 screw from its published Fourier table
    (21 terms; van Lammeren, van Manen & Oosterveld 1969 form, the B4-70 table of Smogeli 2006),
    ``data/wageningen_b4_70_pd10_4q.csv`` — provenance and the cross-checks in that file's header;
    quadrant 1 checked against the Oosterveld & van Oossanen (1975) polynomial
    (:func:`uuvid.thruster.wageningen.wageningen_open_water`, tests/test_wageningen.py)."""
    from uuvid.thruster.wageningen import four_quadrant_table

    at, bt, aq, bq = four_quadrant_table("wageningen_b4_70_pd10_4q.csv")
    return FourQuadrantMap(
        "wageningen-b4-70-pd1.0", diameter, at, bt, aq, bq,
        source="Wageningen B4-70, P/D = 1.0 four-quadrant Fourier table (MARIN B-series; van "
               "Lammeren, van Manen & Oosterveld 1969, Trans. SNAME 77), as tabulated by Smogeli "
               "2006 (PhD thesis, NTNU); uuvid/thruster/data/wageningen_b4_70_pd10_4q.csv",
        assumption="transcribed from public copies of the table (two agree digit for digit), not "
                   "from the printed page; P/D = 1.0 confirmed by the open-water polynomial")


#: ASSUMPTION: T200 propeller diameter 76 mm (Blue Robotics' 3-inch propeller), pitch ratio 1.0.
#: The pitch ratio is derived, not measured: the preset's fitted bollard coefficient
#: ``k_t = 3.668e-4 N·s²/rad²`` is ``K_T = k_t (2π)² / (ρ D⁴) = 0.434`` at D = 76 mm, within 3 % of
#: the bollard K_T = 0.445 of the published B4-70, P/D = 1.0 table (:func:`wageningen_b4_70`; the
#: Oosterveld–van Oossanen polynomial gives 0.455, and P/D = 0.9 / 1.1 would give 0.41 / 0.50 there),
#: and the full-command speed that map gives for the sheet's 51.5 N is within 1 % of the sheet's
#: 3500 rpm (tests/test_inflow.py checks both).
T200_DIAMETER = 0.076
T200_PITCH_RATIO = 1.0


@dataclass(frozen=True)
class T200Inflow:
    """The T200 preset's inflow coefficients (all derived from diameter and pitch ratio, see
    :data:`T200_DIAMETER`)."""

    diameter: float
    pitch_ratio: float
    pitch_angle: float  # rad at 0.7 R: tan p = (P/D) / (0.7 π)
    inflow_coefficient: float  # k_a of the linear Healey form, N·s²/(rad·m): k_t / (0.7 R p)
    map: FourQuadrantMap


def t200_inflow(kt_fwd: float | None = None) -> T200Inflow:
    """T200 inflow coefficients from its pitch and diameter (assumptions at :data:`T200_DIAMETER`)."""
    if kt_fwd is None:
        from uuvid.thruster.presets import T200_STEADY

        kt_fwd = T200_STEADY.kt_fwd
    p = math.atan(T200_PITCH_RATIO / (0.7 * math.pi))
    r07 = 0.35 * T200_DIAMETER
    return T200Inflow(T200_DIAMETER, T200_PITCH_RATIO, p, kt_fwd / (r07 * p),
                      wageningen_b4_70(T200_DIAMETER))


def map_from_section(section, where: str = "inflow") -> FourQuadrantMap:
    """The :class:`FourQuadrantMap` a thruster model file's ``inflow`` section holds — the
    ``C_T*(β)`` Fourier terms ``a_0 … a_K``, ``b_1 … b_K`` and ``diameter_m`` a bench fit in a
    flow writes (``uuvid thruster fit --model four-quadrant --diameter D``,
    :func:`uuvid.identify.thruster.inflow.fit_four_quadrant`), valid over its ``beta_ranges_deg``
    (one interval per shaft direction; an older file's single ``beta_range_deg``).
    ``C_Q*`` is zero (the fit has no torque).  ``ValueError`` naming ``where`` and the key for
    anything else — the linear form ``T = K_T Ω|Ω| − k_a |Ω| u_a`` included: a line in one
    quadrant per direction with no propeller diameter is no four-quadrant map."""
    if not isinstance(section, dict):
        raise ValueError(f"{where}: expected a mapping, got {type(section).__name__}")
    form = section.get("form")
    if form != "four-quadrant":
        raise ValueError(
            f"{where}: form {form!r}: a vehicle's four-quadrant inflow needs the C_T*(β) series of a "
            "four-quadrant fit (thruster fit --model four-quadrant --diameter D on the same bench "
            "file); the linear form T = K_T Ω|Ω| − k_a |Ω| u_a holds one quadrant per direction "
            "and has no propeller diameter")
    d = section.get("diameter_m")
    if not isinstance(d, (int, float)) or isinstance(d, bool) or not (math.isfinite(d) and d > 0):
        raise ValueError(f"{where}.diameter_m: expected the propeller diameter in m (> 0), got {d!r}")
    prm = section.get("parameters")
    if not isinstance(prm, dict) or "a_0" not in prm:
        raise ValueError(f"{where}.parameters: expected the Fourier terms a_0 … a_K, b_1 … b_K "
                         f"of C_T*(β), got {sorted(prm) if isinstance(prm, dict) else prm!r}")

    def est(name):
        v = prm[name]
        v = v.get("estimate") if isinstance(v, dict) else v
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            raise ValueError(f"{where}.parameters.{name}: expected a finite estimate, got {v!r}")
        return float(v)

    idx = [int(k[2:]) for k in prm if k[:2] in ("a_", "b_") and k[2:].isdigit()]
    order = max(idx, default=0)
    want = [f"a_{k}" for k in range(order + 1)] + [f"b_{k}" for k in range(1, order + 1)]
    if sorted(prm) != sorted(want):
        missing = [k for k in want if k not in prm]
        extra = sorted(k for k in prm if k not in want)
        raise ValueError(f"{where}.parameters: expected exactly {', '.join(want)} (C_T*(β) of "
                         f"Fourier order {order})"
                         + (f"; missing {', '.join(missing)}" if missing else "")
                         + (f"; not a term: {', '.join(extra)}" if extra else ""))
    key = "beta_ranges_deg" if "beta_ranges_deg" in section else "beta_range_deg"
    rng = section.get(key)
    if rng is not None:  # one interval per direction (older files: one overall [lo, hi])
        ivs = [rng] if key == "beta_range_deg" else rng
        ok = isinstance(ivs, (list, tuple)) and len(ivs) > 0 and all(
            isinstance(r, (list, tuple)) and len(r) == 2
            and all(isinstance(x, (int, float)) and math.isfinite(x) for x in r) and r[0] <= r[1]
            for r in ivs)
        if not ok:
            raise ValueError(f"{where}.{key}: expected "
                             + ("[lo, hi]" if key == "beta_range_deg" else "[[lo, hi], …]")
                             + f" in degrees, got {rng!r}")
        rng = tuple((float(a), float(b)) for a, b in ivs)
    a = tuple(est(f"a_{k}") for k in range(order + 1))
    b = (0.0,) + tuple(est(f"b_{k}") for k in range(1, order + 1))
    zeros = (0.0,) * len(a)
    return FourQuadrantMap(f"fitted ({where})", float(d), a, b, zeros, zeros,
                           source=str(section.get("source") or where),
                           assumption="C_Q* not identified (no torque fitted)", beta_ranges_deg=rng)


#: Thruster model names with known propeller data → their four-quadrant map.
def propeller_map(model: str) -> FourQuadrantMap:
    """The four-quadrant map of a thruster model (preset name); ``KeyError`` when none is known."""
    if model in ("t200", "t200-physical"):
        return t200_inflow().map
    raise KeyError(model)


INFLOW_MODELS = ("none", "four-quadrant")
