"""Inflow coefficients from bench runs recorded in a flow (issue 21, item 3).

A bench file with a ``flow_speed`` column (m/s: the carriage or tunnel speed, i.e. the water speed
through the propeller along its axis — the advance speed ``u_a`` of :mod:`uuvid.thruster.inflow`
with no wake on an open bench) beside thrust and propeller speed determines how the thrust falls
with the water speed.  Two forms, both linear in their coefficients (ordinary least squares with
σ and correlations, :func:`uuvid.identify.fit.linear_lsq`; no optimiser start to choose):

* **linear inflow form** (Healey et al. 1995, IEEE JOE 20(4), eq. 6 in its small-angle form with
  the flow through the propeller taken as the advance speed; equivalently the open-water line
  ``K_T(J) = α₁ + α₂ J`` of Fossen 2011, *Handbook of Marine Craft Hydrodynamics*, §6.7)::

      T = K_T Ω|Ω| − k_a |Ω| u_a            (K_T per direction, Ω in rad/s, u_a in m/s)

  ``k_a`` [N·s²/(rad·m)] is the inflow coefficient of :class:`~uuvid.thruster.blocks.HealeyThruster`
  and of :meth:`uuvid.thruster.inflow.BladeElement.linear_coefficients`; at ``u_a = 0`` the form is
  the bollard map ``T = K_T Ω|Ω|`` written to the model file.

* **four-quadrant map** (van Lammeren et al. 1969; Carlton, *Marine Propellers and Propulsion*,
  ch. 6.5; :class:`uuvid.thruster.inflow.FourQuadrantMap`): with ``n = Ω/2π`` rev/s,
  ``β = atan2(u_a, 0.7πnD)`` and ``V_r² = u_a² + (0.7πnD)²``::

      T = C_T*(β) · ½ρ V_r² (π/4) D²,   C_T*(β) = Σ_k a_k cos kβ + b_k sin kβ  (k ≤ order)

  the Fourier coefficients of ``C_T*`` over the advance angles the data span (the propeller
  diameter ``D`` given, fresh water unless ``rho`` says otherwise).

Identifiability: the inflow term needs water speeds that differ.  All ``flow_speed = 0`` (a
bollard bench) leaves the coefficient undetermined — the linear fit's caller (``thruster fit
--model quadratic``) then says so as a warning and fits the bollard map only, never a silent value;
:func:`fit_four_quadrant` refuses such data (``C_T*`` along β, and still water pins β to 0°/180°)
naming ``--model quadratic`` for the bollard map; fewer than :data:`MIN_FLOW_LEVELS` distinct water
speeds raise (two levels always fit a line in ``u_a``; a third tests the form).
"""

from __future__ import annotations

import math

import numpy as np

from uuvid.identify.fit import Fit, linear_lsq
from uuvid.identify.thruster.steady import SteadyFit
from uuvid.io.bench import BenchData, BenchDataError
from uuvid.thruster.blocks import QuadraticMap
from uuvid.thruster.inflow import RHO_FRESH, FourQuadrantMap

#: Distinct water speeds (rounded to :data:`FLOW_RESOLUTION`) an inflow fit needs.
MIN_FLOW_LEVELS = 3
#: Water speeds closer than this (m/s) count as one level.
FLOW_RESOLUTION = 1e-3
#: The warning of a bench in still water (every ``flow_speed`` zero).
BOLLARD_ONLY = ("the inflow coefficient is not identifiable from bollard data: flow_speed is 0 in "
                "every row, so the thrust never meets a water speed; only the bollard map was "
                "fitted (record runs at three or more carriage/tunnel speeds to identify it)")
LINEAR_FORM = "T = K_T Ω|Ω| − k_a |Ω| u_a"
FOUR_QUADRANT_FORM = "T = C_T*(β) ½ρ V_r² (π/4) D²"


def flow_levels(flow) -> np.ndarray:
    """The distinct water speeds (m/s) of a flow column, to :data:`FLOW_RESOLUTION`."""
    return np.unique(np.round(np.asarray(flow, float) / FLOW_RESOLUTION) * FLOW_RESOLUTION)


def is_bollard(data: BenchData) -> bool:
    """``True`` when the data have a flow column that is zero in every row (a still-water bench)."""
    return data.flow_speed is not None and not np.any(data.flow_speed != 0)


def _rows(data: BenchData, what: str) -> np.ndarray:
    """Measured rows with thrust, speed ≠ 0 and a water speed; checks the number of levels."""
    data.require("thrust", "speed", "flow_speed", what=what)
    m = data.measured & (data.speed != 0)
    src = f"{data.source}: " if data.source else ""
    col = data.flow_column
    lv = flow_levels(data.flow_speed[m])
    if lv.size < MIN_FLOW_LEVELS:
        shown = ", ".join(f"{v:g}" for v in lv)
        raise BenchDataError(
            f"{src}column {col!r}: {lv.size} distinct water speed(s) ({shown} m/s) in the "
            f"{int(m.sum())} measured rows with the propeller turning; {what} needs at least "
            f"{MIN_FLOW_LEVELS} (two always fit a line in u_a, a third tests the form). Fix: "
            "record the runs at more carriage/tunnel speeds")
    top = float(np.max(np.abs(data.flow_speed[m])))
    if top > MAX_FLOW_SPEED:
        raise BenchDataError(
            f"{src}column {col!r} reaches {top:.4g} m/s, beyond {MAX_FLOW_SPEED:g} m/s for a "
            "thruster's tow tank or water tunnel: is it in cm/s or km/h? expected m/s, or the "
            "unit in the column's header ('flow_speed [cm/s]') or --flow-speed-unit")
    return m


#: a water speed through a thruster on a bench beyond this (m/s) is no tunnel's or carriage's
MAX_FLOW_SPEED = 10.0


def _directions(speed) -> list[tuple[str, float]]:
    return [(d, s) for d, s in (("forward", 1.0), ("reverse", -1.0)) if np.any(np.sign(speed) == s)]


def linear_regressors(speed, flow, directions) -> np.ndarray:
    """Columns of :data:`LINEAR_FORM`: ``Ω|Ω|`` per direction (zero in the other), ``−|Ω| u_a``."""
    w = np.asarray(speed, float)
    cols = [np.where(np.sign(w) == s, w * np.abs(w), 0.0) for _, s in directions]
    cols.append(-np.abs(w) * np.asarray(flow, float))
    return np.column_stack(cols)


def linear_inflow_thrust(speed, flow, k_fwd: float, k_rev: float, k_a: float) -> np.ndarray:
    """:data:`LINEAR_FORM` at propeller speed ``Ω`` (rad/s) and water speed ``u_a`` (m/s)."""
    w = np.asarray(speed, float)
    kt = np.where(w >= 0, k_fwd, k_rev)
    return kt * w * np.abs(w) - k_a * np.abs(w) * np.asarray(flow, float)


def fit_inflow_linear(data: BenchData, *, cov_type: str = "classical") -> SteadyFit:
    """:data:`LINEAR_FORM` by linear least squares over every measured row (one joint fit: the
    directions share ``k_a``) → a :class:`SteadyFit` with one fit ``"inflow"`` (``K_T_fwd``,
    ``K_T_rev`` where the data turn that way, ``k_a``; σ, covariance, correlation, residuals) and
    the bollard :class:`~uuvid.thruster.blocks.QuadraticMap` (``u_a = 0``) as its block."""
    what = f"the inflow fit ({LINEAR_FORM})"
    m = _rows(data, what)
    w, u, y = data.speed[m], data.flow_speed[m], data.thrust[m]
    dirs = _directions(w)
    names = [f"K_T_{'fwd' if d == 'forward' else 'rev'}" for d, _ in dirs] + ["k_a"]
    units = ["N·s²/rad²"] * len(dirs) + ["N·s²/(rad·m)"]
    fit = linear_lsq(linear_regressors(w, u, dirs), y, names, model=LINEAR_FORM, units=units,
                     cov_type=cov_type, emit_warnings=False,
                     extra={"flow_levels": flow_levels(u).tolist()})
    src = f"{data.source}: " if data.source else ""
    for nm in names[:-1]:
        p = fit[nm]
        if p.value < 0 and not -p.value <= 2.0 * p.stderr:
            raise BenchDataError(f"{src}{nm} = {p.value:.4g} < 0: the thrust opposes the propeller "
                                 "speed. Fix: check the sign of the thrust column against the "
                                 "speed column")
    ka = fit["k_a"]
    fit = _warn_reversed_flow(fit, "k_a", ka.value, ka.stderr, data.flow_column)
    v = fit.values
    kf = max(v.get("K_T_fwd", v.get("K_T_rev", 0.0)), 0.0)
    kr = max(v.get("K_T_rev", kf), 0.0)
    notes = [f"{int((~data.measured).sum())} censored row(s) left out"] if (~data.measured).any() \
        else []
    return SteadyFit(f"{LINEAR_FORM} (Healey et al. 1995, small-angle form)", {"inflow": fit},
                     QuadraticMap(k_pos=kf, k_neg=kr), {"notes": tuple(notes), "form": "linear"})


# ------------------------------------------------------------------------------------------------
# four-quadrant map
# ------------------------------------------------------------------------------------------------
def _warn_reversed_flow(fit: Fit, what: str, ka: float, sigma: float, col: str) -> Fit:
    """``fit`` with a warning when the inflow coefficient ``ka`` (``what``: ``k_a`` of the linear
    form, or the map's equivalent, :func:`map_inflow_coefficient`) is negative beyond 2σ: the
    thrust rises with the water from ahead, physically backwards — the water speed's sign is
    probably reversed.  One sentence for both forms."""
    if not (ka < 0 and -ka > 2.0 * sigma):
        return fit
    import dataclasses

    return dataclasses.replace(fit, warnings=fit.warnings + (
        f"{what} = {ka:.4g} ± {sigma:.2g} < 0: the thrust rises with {col}, while water meeting "
        f"the propeller from ahead ({col} > 0 in forward thrust) takes thrust away: is {col}'s "
        "sign reversed (positive for water from behind)?",))


def advance_angle(speed, flow, diameter: float) -> np.ndarray:
    """``β = atan2(u_a, 0.7 π n D)`` (rad) with ``n = Ω/2π``."""
    return np.arctan2(np.asarray(flow, float), 0.7 * np.asarray(speed, float) / 2.0 * diameter)


def four_quadrant_regressors(speed, flow, diameter: float, order: int, rho: float) -> np.ndarray:
    """Columns of :data:`FOUR_QUADRANT_FORM` for the coefficients ``a_0 … a_order, b_1 … b_order``."""
    vt = 0.7 * np.asarray(speed, float) / 2.0 * diameter  # 0.7 π n D with n = Ω / 2π
    u = np.asarray(flow, float)
    q = 0.5 * rho * (u * u + vt * vt) * 0.25 * math.pi * diameter * diameter
    beta = np.arctan2(u, vt)
    k = np.arange(order + 1)
    return np.hstack([np.cos(np.outer(beta, k)), np.sin(np.outer(beta, k[1:]))]) * q[:, None]


def four_quadrant_flow_slopes(speed, flow, diameter: float, order: int, rho: float) -> np.ndarray:
    """``∂/∂u_a`` of the columns of :func:`four_quadrant_regressors` (per N of thrust per m/s):
    with ``q = c (u² + v_t²)``, ``c = ½ρ(π/4)D²``, ``v_t = 0.7πnD`` and ``∂β/∂u = v_t/(u² + v_t²)``,
    ``∂(q cos kβ)/∂u = c (2u cos kβ − k v_t sin kβ)`` and
    ``∂(q sin kβ)/∂u = c (2u sin kβ + k v_t cos kβ)``."""
    vt = 0.7 * np.asarray(speed, float) / 2.0 * diameter
    u = np.asarray(flow, float)
    c = 0.5 * rho * 0.25 * math.pi * diameter * diameter
    beta = np.arctan2(u, vt)
    k = np.arange(order + 1)
    kb = np.outer(beta, k)
    cos_cols = 2.0 * u[:, None] * np.cos(kb) - vt[:, None] * k * np.sin(kb)
    sin_cols = (2.0 * u[:, None] * np.sin(kb) + vt[:, None] * k * np.cos(kb))[:, 1:]
    return c * np.hstack([cos_cols, sin_cols])


def map_inflow_coefficient(fit: Fit, speed, flow) -> tuple[float, float]:
    """The inflow coefficient a fitted four-quadrant map implies over the bench's rows, with its
    σ: ``−mean(∂T/∂u_a / |Ω|)`` — for the linear form ``T = K_T Ω|Ω| − k_a |Ω| u_a`` exactly
    ``k_a``, so positive when water from ahead takes thrust away (either shaft direction).  A
    linear function of the coefficients, so its σ is exact from their covariance."""
    ex = fit.extra
    order = (len(fit.parameters) - 1) // 2
    w = np.asarray(speed, float)
    g = -np.mean(four_quadrant_flow_slopes(w, flow, ex["diameter"], order, ex["rho"])
                 / np.abs(w)[:, None], axis=0)
    theta = np.array([p.value for p in fit.parameters])
    cov = np.asarray(fit.covariance, float)
    var = float(g @ cov @ g) if np.all(np.isfinite(cov)) else math.inf
    return float(g @ theta), math.sqrt(max(var, 0.0))


#: Smallest propeller diameter [m] the four-quadrant fit takes: 5 mm, below any thruster's
#: propeller (micro-ROV propellers are ≈ 20 mm); a smaller one is a unit slip (km?) or a typo.
MIN_PROPELLER_DIAMETER = 0.005


def fit_four_quadrant(data: BenchData, diameter: float, *, order: int | None = None,
                      rho: float = RHO_FRESH, cov_type: str = "classical") -> SteadyFit:
    """The Fourier coefficients of ``C_T*(β)`` (:data:`FOUR_QUADRANT_FORM`) by linear least
    squares → :class:`SteadyFit` with one fit ``"four-quadrant"`` (``a_0 … a_order``,
    ``b_1 … b_order``), ``info["map"]`` the :class:`~uuvid.thruster.inflow.FourQuadrantMap`
    (thrust only: its ``C_Q*`` is zero, the bench gives no torque here) and the bollard
    :class:`~uuvid.thruster.blocks.QuadraticMap` of that map as the block.  The coefficients hold
    over the advance angles in the data (``info["beta_ranges_deg"]``, one interval per shaft
    direction: :func:`beta_ranges`); outside them the series is an extrapolation.  ``order``
    (default): 1 for data turning one way (β near 0 or near ±π), 2 when they turn both ways
    (ahead and astern need their own level and slope)."""
    if not (math.isfinite(diameter) and diameter > 0):
        raise BenchDataError(f"the four-quadrant fit needs the propeller diameter in m "
                             f"(--diameter), got {diameter!r}")
    if diameter < MIN_PROPELLER_DIAMETER:
        raise BenchDataError(f"--diameter {diameter:g} m: smaller than any thruster's propeller "
                             f"(at least {MIN_PROPELLER_DIAMETER:g} m); expected the propeller "
                             "diameter in m (the T200's is 0.076 m)")
    both = data.speed is not None and np.any(data.speed > 0) and np.any(data.speed < 0)
    if order is None:
        order = 2 if both else 1
    if not (isinstance(order, int) and 0 <= order <= 8):
        raise BenchDataError(f"the four-quadrant Fourier order must be an integer in [0, 8], got "
                             f"{order!r}")
    if order == 0 and both:
        raise BenchDataError(f"{data.source or 'the data'}: Fourier order 0 (--degree 0: one "
                             "constant C_T*) gives thrust of one sign ahead and astern, but the "
                             "propeller turns both ways here: give order ≥ 1 (default 2 for such "
                             "data)")
    what = f"the four-quadrant fit ({FOUR_QUADRANT_FORM})"
    if is_bollard(data):  # unlike quadratic's K_T, the map has nothing to fit without water
        raise BenchDataError(
            f"{data.source or 'the data'}: column {data.flow_column!r}: flow_speed is 0 in every "
            f"row, so the advance angle β = atan2(u_a, 0.7πnD) is 0° (or 180° astern) throughout: "
            f"{what} is C_T* along β and needs water speeds to span it (record runs at three or "
            "more carriage/tunnel speeds). The bollard map alone: --model quadratic (it fits "
            "K_T Ω|Ω| from such a file, with a warning)")
    m = _rows(data, what)
    w, u, y = data.speed[m], data.flow_speed[m], data.thrust[m]
    names = [f"a_{k}" for k in range(order + 1)] + [f"b_{k}" for k in range(1, order + 1)]
    beta = advance_angle(w, u, diameter)
    fit = linear_lsq(four_quadrant_regressors(w, u, diameter, order, rho), y, names,
                     model=FOUR_QUADRANT_FORM, units=[""] * len(names), cov_type=cov_type,
                     emit_warnings=False,
                     extra={"flow_levels": flow_levels(u).tolist(), "diameter": diameter,
                            "rho": rho, "beta_range_deg": [float(np.degrees(beta.min())),
                                                           float(np.degrees(beta.max()))],
                            "beta_ranges_deg": beta_ranges(w, beta)})
    ka, ka_sigma = map_inflow_coefficient(fit, w, u)
    fit = _warn_reversed_flow(fit, "k_a of the fitted map (−∂T/∂u_a / |Ω|, mean over the rows)",
                              ka, ka_sigma, data.flow_column)
    v = fit.values
    a = tuple(v[f"a_{k}"] for k in range(order + 1))
    b = (0.0,) + tuple(v[f"b_{k}"] for k in range(1, order + 1))
    fq = FourQuadrantMap(f"fitted {data.source}".strip(), diameter, a, b, (0.0,) * len(a),
                         (0.0,) * len(a), source=f"bench in a flow: {data.source}",
                         assumption="C_Q* not identified (no torque fitted)",
                         beta_ranges_deg=tuple(map(tuple, fit.extra["beta_ranges_deg"])))
    # bollard map T = K_T ρ n² D⁴ as K_T Ω|Ω| (n = Ω/2π) per direction the data turn
    c = rho * diameter ** 4 / (2.0 * math.pi) ** 2
    dirs = dict(_directions(w))
    for sgn, way in ((1, "forward"), (-1, "reverse")):
        if way in dirs and sgn * fq.bollard_kt(sgn) <= 0:  # the map would be written as 0 thrust
            raise BenchDataError(
                f"{data.source or 'the data'}: the fitted C_T*(β) (order {order}, D = "
                f"{diameter:g} m) gives no {way} bollard thrust (K_T = {fq.bollard_kt(sgn):+.3g}) "
                f"though the propeller turns {way} in the data: not a model of this thruster. "
                "Check --diameter and the signs of the columns, or give another --degree")
    fit = _warn_bollard_scale(fit, fq, [s for way, s in (("forward", 1), ("reverse", -1)) if way in dirs])
    kf = max(fq.bollard_kt(1) * c, 0.0) if "forward" in dirs else None
    kr = max(-fq.bollard_kt(-1) * c, 0.0) if "reverse" in dirs else None
    kf = kr if kf is None else kf
    return SteadyFit(f"{FOUR_QUADRANT_FORM}, C_T* Fourier order {order}", {"four-quadrant": fit},
                     QuadraticMap(k_pos=kf, k_neg=kr),
                     {"form": "four-quadrant", "map": fq, "notes": (),
                      "beta_range_deg": fit.extra["beta_range_deg"],
                      "beta_ranges_deg": fit.extra["beta_ranges_deg"]})


#: Bollard ``K_T = T/(ρn²D⁴)`` a propeller can have, generously: real screws give 0.1–0.8 (the
#: published Wageningen B4-70, P/D = 1.0 map 0.445; ducted and high-pitch ones up to ≈ 0.8, astern
#: ≈ 0.5–0.8 of ahead).  Outside it the diameter is the likely culprit: ``K_T ∝ D⁻⁴`` for the same
#: thrust, so a diameter off by 10× moves it by 10⁴ — far outside — and one radius given for the
#: diameter by 16×.
BOLLARD_KT_RANGE = (0.02, 2.0)
#: A typical bollard ``K_T``, for the diameter a message suggests.
TYPICAL_BOLLARD_KT = 0.4


def _warn_bollard_scale(fit: Fit, fq: FourQuadrantMap, signs) -> Fit:
    """``fit`` with one warning naming each shaft direction (``signs``: +1 ahead, −1 astern) whose
    fitted bollard ``K_T`` lies outside :data:`BOLLARD_KT_RANGE` — the fit itself cannot tell:
    any diameter fits the same thrusts equally well, only the coefficients' scale moves (``K_T``
    and ``C_T*`` as ``D⁻⁴``, the β axis as ``D⁻¹``).  Names the implied ``K_T`` and the
    diameter that would give a typical one."""
    import dataclasses

    lo, hi = BOLLARD_KT_RANGE
    bad = [(sgn, sgn * fq.bollard_kt(sgn)) for sgn in signs]
    bad = [(sgn, kt) for sgn, kt in bad if kt > 0 and not lo <= kt <= hi]
    if not bad:
        return fit
    said = " and ".join(f"{'ahead' if sgn > 0 else 'astern'} {kt:.3g}" for sgn, kt in bad)
    d_typ = fq.diameter * (bad[0][1] / TYPICAL_BOLLARD_KT) ** 0.25
    msg = (f"the fitted map's bollard K_T = T/(ρn²D⁴) at D = {fq.diameter:g} m is {said} (C_T*(0°) "
           f"= {float(fq.ct(0.0)):.3g}), outside {lo:g}–{hi:g} where propellers lie (about "
           "0.1–0.8): is the diameter in m? (a diameter off by 10× scales K_T by 10⁴); "
           f"K_T ≈ {TYPICAL_BOLLARD_KT:g} would mean D ≈ {d_typ:.3g} m. Any diameter fits the "
           "thrusts equally well, but the map's coefficients and advance angles are then wrong")
    return dataclasses.replace(fit, warnings=fit.warnings + (msg,))


def beta_ranges(speed, beta) -> list[list[float]]:
    """The advance angles (deg) a bench spans, one ``[lo, hi]`` per shaft direction it turned:
    ahead (``Ω > 0``, β in (−90°, 90°)) and astern (``Ω < 0``, β taken in [90°, 270°) so that
    flows from ahead and behind make one interval) — the min and max over both would claim the
    whole half-circle between them."""
    speed = np.asarray(speed, float)
    deg = np.degrees(np.asarray(beta, float))
    out = []
    for m, b in ((speed > 0, deg), (speed < 0, np.mod(deg, 360.0))):
        if np.any(m):
            out.append([float(b[m].min()), float(b[m].max())])
    return out


def model_thrust(sf: SteadyFit, speed, flow) -> np.ndarray:
    """The fitted thrust of :func:`fit_inflow_linear` or :func:`fit_four_quadrant` (N)."""
    if sf.info.get("form") == "four-quadrant":
        fit: Fit = sf.fits["four-quadrant"]
        ex = fit.extra
        order = (len(fit.parameters) - 1) // 2
        H = four_quadrant_regressors(speed, flow, ex["diameter"], order, ex["rho"])
        return H @ np.array([p.value for p in fit.parameters])
    v = sf.fits["inflow"].values
    kf = v.get("K_T_fwd", v.get("K_T_rev"))
    return linear_inflow_thrust(speed, flow, kf, v.get("K_T_rev", kf), v["k_a"])
