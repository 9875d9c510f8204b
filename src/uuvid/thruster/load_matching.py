"""Load matching of a thruster propeller to a DC motor and gear (McLean 1991, NPS thesis, App. A).

Implements Appendix A, "Load matching for thruster propellers", of McLean (1991):

* eq. (A.1), the continuous-load torque capability of a Pittman DC servomotor (Pittman
  application notes, the thesis's Ref. 16)::

      T_cont(S) = sqrt((155 − T_amb)/TPR − T_f·S/C) · K · PKO − T_f        [oz·in, S in rpm]

* the AUV II load points of Table A-I (static thruster tests, the thesis's Ref. 15) and the
  extrapolation of that load curve that the thesis's FORTRAN code "Load Matching #3" uses;
* the linear thrust law of the FORTRAN listings, ``thrust = 0.0015625·rpm`` lb (propeller rpm);
* the operating point for a gear ratio N: the intersection, in propeller coordinates, of the motor's
  continuous-torque curve with the load curve, ``T_cont(N·n_p) = Q_p(n_p)/N``;
* the Pittman 9514 and 14202 motors (App. B; no-load speeds and stall torques from Ch. I and App. A).

Everything inside is SI (N·m, rad/s, N, W).  In SI eq. (A.1) reads
``T_cont(ω) = sqrt((155 − T_amb)/TPR − T_f·ω) · K · PKO − T_f``: the thesis's ``C = 1352`` is
only the factor that turns oz·in × rpm into watts (exactly 1/(OZ_IN·RPM) = 1352.28), so the term
under the root is thermal power minus friction power.  The thesis's own units appear only in the
constants below (original numbers visible) and in :meth:`OperatingPoint.thesis_units`,
:func:`load_matching_table` and :func:`plot_load_matching`.

Table A-I, column 4 ("prop torque", oz·in) was computed with the motor law ``K_T·i``
(4.13 × 3.20 = 13.2), so it is the torque at the *motor* of the test rig, which had a 2.5:1 gear;
the torque at the propeller is 2.5 × that.  The FORTRAN listings use exactly those propeller
torques (4.65 … 33.0 oz·in at 100 … 775 rpm), and so does this module.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import brentq

from uuvid.core import units

__all__ = [
    "PITTMAN_9514",
    "PITTMAN_14202",
    "TABLE_A1",
    "THESIS_CASES",
    "THESIS_EXTRAPOLATION",
    "LoadCurve",
    "OperatingPoint",
    "PittmanMotor",
    "continuous_torque",
    "load_matching_table",
    "max_continuous_speed",
    "operating_point",
    "plot_load_matching",
    "propeller_thrust",
]

# ---------------------------------------------------------------------------------------------
# Constants of eq. (A.1)
# ---------------------------------------------------------------------------------------------
T_WINDING_MAX = 155.0  # °C, maximum winding temperature (eq. A.1)
T_AMBIENT = 25.0  # °C, ambient temperature used in App. A
K_BRUSH_FERRITE = 0.71  # –, K of eq. (A.1) for brush-commutated, ferrite-magnet motors
C_THESIS = 1352.0  # oz·in·rpm per W, C of eq. (A.1); in SI the term is exactly T_f·ω (W)
TEST_GEAR_RATIO = 2.5  # gear ratio of the static tests behind Table A-I

# Linear thrust law of the FORTRAN listings (App. A, "Load Matching #2/#3"): 0.0015625 lb per prop rpm.
THRUST_PER_RPM_LB = 0.0015625  # lb/rpm, McLean 1991 App. A (FORTRAN "THRUST=.0015625*SS")
THRUST_GAIN = units.lbf(THRUST_PER_RPM_LB) / units.rpm(1.0)  # N per rad/s

# Table A-I, McLean 1991 App. A (starboard thrust direction, from Saunders' static tests, Ref. 15):
# (thrust lb, current A, prop rpm, "prop torque" oz·in [really motor torque K_T·i, 2.5:1 gear], motor rpm)
TABLE_A1: tuple[tuple[float, float, float, float, float], ...] = (
    (1.125, 3.20, 775.0, 13.2, 1940.0),
    (1.000, 2.80, 700.0, 11.6, 1750.0),
    (0.750, 2.00, 550.0, 8.26, 1380.0),
    (0.500, 1.20, 360.0, 4.96, 900.0),
    (0.375, 0.80, 245.0, 3.30, 613.0),
    (0.250, 0.45, 100.0, 1.86, 250.0),
)

# Extrapolation of the load curve in the FORTRAN code "Load Matching #3" (McLean 1991 App. A,
# arrays SLA/TLA): (prop rpm, prop torque oz·in); 775 rpm / 33.0 oz·in is the last measured point.
THESIS_EXTRAPOLATION: tuple[tuple[float, float], ...] = (
    (850.0, 39.0),
    (925.0, 47.0),
    (975.0, 55.0),
)


# ---------------------------------------------------------------------------------------------
# Motors
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PittmanMotor:
    """A Pittman brush DC servomotor, catalog values in SI (McLean 1991, App. B).

    Fields: ``torque_constant`` K_T [N·m/A], ``resistance`` R [Ω], ``back_emf_constant`` K_G
    [V·s/rad], ``friction_torque`` T_f [N·m], ``no_load_current`` [A], ``stall_current`` [A],
    ``no_load_speed`` [rad/s], ``stall_torque`` [N·m], ``motor_constant`` PKO [N·m/√W],
    ``thermal_impedance`` TPR [K/W = °C/W], ``voltage`` [V].
    """

    name: str
    torque_constant: float
    resistance: float
    back_emf_constant: float
    friction_torque: float
    no_load_current: float
    stall_current: float
    no_load_speed: float
    stall_torque: float
    motor_constant: float
    thermal_impedance: float
    voltage: float = 24.0

    def __post_init__(self) -> None:
        for f in (
            "torque_constant",
            "resistance",
            "back_emf_constant",
            "friction_torque",
            "no_load_current",
            "stall_current",
            "no_load_speed",
            "stall_torque",
            "motor_constant",
            "thermal_impedance",
            "voltage",
        ):
            v = getattr(self, f)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(
                    f"PittmanMotor {self.name!r}: {f} must be a finite number > 0, got {v!r}"
                )

    @classmethod
    def from_catalog(
        cls,
        name: str,
        *,
        kt_oz_in_per_a: float,
        resistance_ohm: float,
        kg_v_s_per_rad: float,
        friction_oz_in: float,
        no_load_current_a: float,
        stall_current_a: float,
        no_load_speed_rpm: float,
        stall_torque_oz_in: float,
        pko_oz_in_per_sqrt_w: float,
        tpr_c_per_w: float,
        voltage_v: float = 24.0,
    ) -> PittmanMotor:
        """Build from catalog numbers in the thesis's units (oz·in, rpm), converting to SI."""
        return cls(
            name=name,
            torque_constant=units.oz_in(kt_oz_in_per_a),
            resistance=resistance_ohm,
            back_emf_constant=kg_v_s_per_rad,
            friction_torque=units.oz_in(friction_oz_in),
            no_load_current=no_load_current_a,
            stall_current=stall_current_a,
            no_load_speed=units.rpm(no_load_speed_rpm),
            stall_torque=units.oz_in(stall_torque_oz_in),
            motor_constant=units.oz_in(pko_oz_in_per_sqrt_w),
            thermal_impedance=tpr_c_per_w,
            voltage=voltage_v,
        )


# McLean 1991, App. B (Tables B-I, B-II, winding 3, 24 V); no-load speed and stall torque: Ch. I.
PITTMAN_9514 = PittmanMotor.from_catalog(
    "Pittman 9514",
    kt_oz_in_per_a=4.13,
    resistance_ohm=4.06,
    kg_v_s_per_rad=0.0292,
    friction_oz_in=0.677,
    no_load_current_a=0.164,
    stall_current_a=5.91,
    no_load_speed_rpm=7370.0,
    stall_torque_oz_in=24.0,
    pko_oz_in_per_sqrt_w=2.05,
    tpr_c_per_w=17.1,
)

# McLean 1991, App. B (Tables B-I, B-II, winding 3, 24 V); no-load speed and stall torque: App. A.
# (The FORTRAN "Load Matching #3" uses T_f = 1.794 oz·in; App. B prints 1.79, used here.)
PITTMAN_14202 = PittmanMotor.from_catalog(
    "Pittman 14202",
    kt_oz_in_per_a=8.67,
    resistance_ohm=1.01,
    kg_v_s_per_rad=0.061,
    friction_oz_in=1.79,
    no_load_current_a=0.210,
    stall_current_a=23.8,
    no_load_speed_rpm=3820.0,
    stall_torque_oz_in=106.0,
    pko_oz_in_per_sqrt_w=5.81,
    tpr_c_per_w=9.0,
)

# The seven motor/gear combinations of App. A (Figs. A.4 and A.5).
THESIS_CASES: tuple[tuple[PittmanMotor, tuple[float, ...]], ...] = (
    (PITTMAN_9514, (2.5, 3.67, 5.0, 10.0)),
    (PITTMAN_14202, (2.5, 3.67, 5.0)),
)


# ---------------------------------------------------------------------------------------------
# Validation helpers
# ---------------------------------------------------------------------------------------------
def _check_motor(motor: object) -> PittmanMotor:
    if not isinstance(motor, PittmanMotor):
        raise ValueError(f"motor must be a PittmanMotor, got {type(motor).__name__}")  # noqa: TRY004
    return motor


def _check_gear_ratio(gear_ratio: object) -> float:
    try:
        n = float(gear_ratio)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"gear ratio must be a number > 0, got {gear_ratio!r}") from None
    if not (math.isfinite(n) and n > 0):
        raise ValueError(f"gear ratio must be finite and > 0, got {gear_ratio!r}")
    return n


def _check_ambient(ambient_temp: float) -> float:
    t = float(ambient_temp)
    if not (math.isfinite(t) and t < T_WINDING_MAX):
        raise ValueError(
            f"ambient temperature must be finite and below the {T_WINDING_MAX:g} °C winding limit, "
            f"got {ambient_temp!r}"
        )
    return t


def _check_speed(speed: object, what: str) -> np.ndarray:
    s = np.asarray(speed, dtype=float)
    if np.any(~np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"{what} must be finite and >= 0 rad/s, got {speed!r}")
    return s


def _out(x: np.ndarray, like: object):
    return float(x) if np.ndim(like) == 0 else x


# ---------------------------------------------------------------------------------------------
# Eq. (A.1)
# ---------------------------------------------------------------------------------------------
def max_continuous_speed(motor: PittmanMotor, *, ambient_temp: float = T_AMBIENT) -> float:
    """Motor speed [rad/s] where the root of eq. (A.1) vanishes: ``ω = (155 − T_amb)/(TPR·T_f)``."""
    _check_motor(motor)
    t_amb = _check_ambient(ambient_temp)
    return (T_WINDING_MAX - t_amb) / motor.thermal_impedance / motor.friction_torque


def continuous_torque(motor: PittmanMotor, motor_speed, *, ambient_temp: float = T_AMBIENT):
    """Continuous-load torque capability [N·m] at motor speed ω [rad/s], McLean 1991 eq. (A.1).

    ``T_cont(ω) = sqrt((155 − T_amb)/TPR − T_f·ω) · K · PKO − T_f`` (SI form; the thesis writes
    ``T_f·S/C`` with S in rpm and C = 1352 for the friction power ``T_f·ω`` in W).

    Returns **NaN** where the root's argument is negative (ω above :func:`max_continuous_speed`:
    the friction loss alone exceeds the thermal budget).  Values can be negative just below that
    speed (the motor cannot continuously overcome its own friction); they are returned as computed.
    Accepts a scalar (returns float) or an array.
    """
    _check_motor(motor)
    t_amb = _check_ambient(ambient_temp)
    w = _check_speed(motor_speed, "motor speed")
    arg = (T_WINDING_MAX - t_amb) / motor.thermal_impedance - motor.friction_torque * w
    with np.errstate(invalid="ignore"):
        root = np.where(arg >= 0.0, np.sqrt(np.maximum(arg, 0.0)), np.nan)
    t = root * K_BRUSH_FERRITE * motor.motor_constant - motor.friction_torque
    return _out(t, motor_speed)


# ---------------------------------------------------------------------------------------------
# Load curve and thrust
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LoadCurve:
    """Propeller torque Q_p [N·m] against propeller speed n_p [rad/s].

    ``kind="piecewise"``: linear interpolation through ``speeds``/``torques`` (strictly increasing
    speeds), continued beyond the last point with the slope of the last segment.
    ``kind="quadratic"``: ``Q_p = c0·n² + c1·n + c2`` with ``coeffs = (c0, c1, c2)`` (SI).
    ``measured_max_speed`` is the fastest *measured* point (775 rpm in Table A-I); speeds above it
    are extrapolation and flagged as such on an :class:`OperatingPoint`.
    """

    kind: Literal["piecewise", "quadratic"]
    speeds: tuple[float, ...] = ()
    torques: tuple[float, ...] = ()
    coeffs: tuple[float, float, float] = (0.0, 0.0, 0.0)
    measured_max_speed: float = math.inf
    label: str = ""

    def __post_init__(self) -> None:
        if self.kind == "piecewise":
            s = np.asarray(self.speeds, dtype=float)
            q = np.asarray(self.torques, dtype=float)
            if s.ndim != 1 or s.size < 2 or s.shape != q.shape:
                raise ValueError(
                    "piecewise load curve needs >= 2 (speed, torque) points of equal length"
                )
            if not (np.all(np.isfinite(s)) and np.all(np.isfinite(q))):
                raise ValueError("load curve points must be finite")
            if np.any(s < 0) or np.any(np.diff(s) <= 0):
                raise ValueError("load curve speeds must be >= 0 and strictly increasing")
        elif self.kind == "quadratic":
            if len(self.coeffs) != 3 or not all(math.isfinite(c) for c in self.coeffs):
                raise ValueError(
                    f"quadratic load curve needs 3 finite coefficients, got {self.coeffs!r}"
                )
        else:
            raise ValueError(
                f"load curve kind must be 'piecewise' or 'quadratic', got {self.kind!r}"
            )
        if not (self.measured_max_speed > 0):
            raise ValueError("measured_max_speed must be > 0")

    # -- constructors ------------------------------------------------------------------------
    @staticmethod
    def _table_points() -> tuple[np.ndarray, np.ndarray]:
        """Table A-I as propeller speed [rad/s] and propeller torque [N·m] (2.5 × column 4)."""
        rows = sorted(TABLE_A1, key=lambda r: r[2])
        n = units.rpm(np.array([r[2] for r in rows]))
        q = units.oz_in(TEST_GEAR_RATIO * np.array([r[3] for r in rows]))
        return n, q

    @classmethod
    def thesis(cls) -> LoadCurve:
        """The thesis's load curve (default): Table A-I at the propeller + FORTRAN extrapolation.

        Points: (0, 0) [assumed, not in the thesis: no torque at rest], the six Table A-I points
        with torque 2.5 × column 4 (4.65 … 33.0 oz·in at 100 … 775 rpm), and the FORTRAN
        "Load Matching #3" extrapolation (850, 39.0), (925, 47.0), (975, 55.0) rpm/oz·in.
        Linear between points, last slope beyond 975 rpm.
        """
        n, q = cls._table_points()
        ne = units.rpm(np.array([p[0] for p in THESIS_EXTRAPOLATION]))
        qe = units.oz_in(np.array([p[1] for p in THESIS_EXTRAPOLATION]))
        speeds = np.concatenate(([0.0], n, ne))
        torques = np.concatenate(([0.0], q, qe))
        return cls(
            kind="piecewise",
            speeds=tuple(float(x) for x in speeds),
            torques=tuple(float(x) for x in torques),
            measured_max_speed=float(n.max()),
            label="Table A-I + FORTRAN extrapolation",
        )

    @classmethod
    def quadratic_fit(cls) -> LoadCurve:
        """Least-squares ``Q_p = a·n² + b·n + c`` through the six Table A-I points (propeller side).

        In thesis units a ≈ 2.97e-5 oz·in/rpm², b ≈ 0.0165 oz·in/rpm, c ≈ 2.60 oz·in (residuals
        ≤ 0.3 oz·in).  Extrapolates less steeply than the thesis's hand extrapolation.
        """
        n, q = cls._table_points()
        a, b, c = np.polyfit(n, q, 2)
        return cls(
            kind="quadratic",
            coeffs=(float(a), float(b), float(c)),
            measured_max_speed=float(n.max()),
            label="quadratic least-squares fit to Table A-I",
        )

    # -- evaluation --------------------------------------------------------------------------
    def torque(self, prop_speed):
        """Propeller torque Q_p(n_p) [N·m] at propeller speed n_p [rad/s] (scalar or array)."""
        n = _check_speed(prop_speed, "propeller speed")
        if self.kind == "quadratic":
            c0, c1, c2 = self.coeffs
            q = (c0 * n + c1) * n + c2
        else:
            s = np.asarray(self.speeds)
            t = np.asarray(self.torques)
            slope = (t[-1] - t[-2]) / (s[-1] - s[-2])
            q = np.where(n > s[-1], t[-1] + (n - s[-1]) * slope, np.interp(n, s, t))
        return _out(q, prop_speed)

    def is_extrapolated(self, prop_speed) -> bool:
        """True where n_p is beyond the fastest measured load point."""
        return bool(
            np.any(np.asarray(prop_speed, dtype=float) > self.measured_max_speed * (1 + 1e-12))
        )


def propeller_thrust(prop_speed, law: Literal["linear", "table"] = "linear"):
    """Steady thrust [N] at propeller speed n_p [rad/s].

    ``law="linear"`` (default, the FORTRAN listings): ``F = 0.0015625 lb/rpm · n_p``.
    ``law="table"``: linear interpolation of Table A-I's thrust column against prop rpm, through
    (0, 0) [assumed] and continued beyond 775 rpm with the last segment's slope.
    """
    n = _check_speed(prop_speed, "propeller speed")
    if law == "linear":
        f = THRUST_GAIN * n
    elif law == "table":
        rows = sorted(TABLE_A1, key=lambda r: r[2])
        s = np.concatenate(([0.0], units.rpm(np.array([r[2] for r in rows]))))
        t = np.concatenate(([0.0], units.lbf(np.array([r[0] for r in rows]))))
        slope = (t[-1] - t[-2]) / (s[-1] - s[-2])
        f = np.where(n > s[-1], t[-1] + (n - s[-1]) * slope, np.interp(n, s, t))
    else:
        raise ValueError(f"thrust law must be 'linear' or 'table', got {law!r}")
    return _out(f, prop_speed)


# ---------------------------------------------------------------------------------------------
# Operating point
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class OperatingPoint:
    """Continuous operating point of a motor + gear + propeller (McLean 1991, App. A), SI.

    ``prop_speed`` n_p and ``motor_speed`` N·n_p [rad/s]; ``motor_torque`` = T_cont = Q_p/N and
    ``prop_torque`` Q_p [N·m]; ``thrust`` [N].  ``exceeds_no_load_speed``: the motor speed is above
    the catalog no-load speed, which the thesis's method ignores (the point is then not reachable
    at the rated voltage).  ``load_extrapolated``: n_p lies beyond the measured load points.
    """

    motor: str
    gear_ratio: float
    prop_speed: float
    motor_speed: float
    motor_torque: float
    prop_torque: float
    thrust: float
    exceeds_no_load_speed: bool
    load_extrapolated: bool

    def thesis_units(self) -> dict[str, float | str | bool]:
        """The point in the thesis's units: rpm, oz·in, lb."""
        return {
            "motor": self.motor,
            "gear_ratio": self.gear_ratio,
            "prop_rpm": units.to_rpm(self.prop_speed),
            "motor_rpm": units.to_rpm(self.motor_speed),
            "motor_torque_oz_in": units.to_oz_in(self.motor_torque),
            "prop_torque_oz_in": units.to_oz_in(self.prop_torque),
            "thrust_lbf": units.to_lbf(self.thrust),
            "exceeds_no_load_speed": self.exceeds_no_load_speed,
            "load_extrapolated": self.load_extrapolated,
        }


def operating_point(
    motor: PittmanMotor,
    gear_ratio: float,
    *,
    load: LoadCurve | None = None,
    thrust: Literal["linear", "table"] = "linear",
    ambient_temp: float = T_AMBIENT,
) -> OperatingPoint:
    """Solve ``T_cont(N·n_p) = Q_p(n_p)/N`` for the propeller speed n_p (McLean 1991, App. A).

    ``load`` defaults to :meth:`LoadCurve.thesis`.  The residual is scanned on
    ``0 ≤ n_p < ω_max/N`` (ω_max from :func:`max_continuous_speed`) and the first sign change is
    refined with :func:`scipy.optimize.brentq`.  Raises ValueError if the curves do not intersect.
    """
    _check_motor(motor)
    n_ratio = _check_gear_ratio(gear_ratio)
    t_amb = _check_ambient(ambient_temp)
    if load is None:
        load = LoadCurve.thesis()
    elif not isinstance(load, LoadCurve):
        raise ValueError(f"load must be a LoadCurve, got {type(load).__name__}")
    if thrust not in ("linear", "table"):
        raise ValueError(f"thrust law must be 'linear' or 'table', got {thrust!r}")

    n_hi = max_continuous_speed(motor, ambient_temp=t_amb) / n_ratio * (1.0 - 1e-9)

    def residual(n_p):
        return (
            continuous_torque(motor, n_ratio * n_p, ambient_temp=t_amb) - load.torque(n_p) / n_ratio
        )

    grid = np.linspace(0.0, n_hi, 2001)
    r = residual(grid)
    sign_change = np.nonzero(np.sign(r[:-1]) * np.sign(r[1:]) <= 0)[0]
    if sign_change.size == 0:
        where = "above" if r[0] < 0 else "below"
        raise ValueError(
            f"no operating point for {motor.name} at gear ratio {n_ratio:g}: the load curve stays "
            f"{where} the continuous-torque curve for all propeller speeds up to "
            f"{units.to_rpm(n_hi):.0f} rpm"
        )
    i = int(sign_change[0])
    if r[i] == 0.0:
        n_p = float(grid[i])
    else:
        n_p = float(brentq(residual, grid[i], grid[i + 1], xtol=1e-12, rtol=1e-12))

    q_p = float(load.torque(n_p))
    w_m = n_ratio * n_p
    return OperatingPoint(
        motor=motor.name,
        gear_ratio=n_ratio,
        prop_speed=n_p,
        motor_speed=w_m,
        motor_torque=q_p / n_ratio,
        prop_torque=q_p,
        thrust=float(propeller_thrust(n_p, thrust)),
        exceeds_no_load_speed=bool(w_m > motor.no_load_speed),
        load_extrapolated=load.is_extrapolated(n_p),
    )


def _iter_cases(motors_and_ratios) -> Iterable[tuple[PittmanMotor, float]]:
    items = (
        motors_and_ratios.items() if isinstance(motors_and_ratios, Mapping) else motors_and_ratios
    )
    try:
        items = list(items)
    except TypeError:
        raise ValueError("motors_and_ratios must be a sequence of (motor, ratios) pairs") from None
    for item in items:
        if not (isinstance(item, Sequence) and len(item) == 2):
            raise ValueError(f"each entry must be a (motor, ratios) pair, got {item!r}")
        motor, ratios = item
        _check_motor(motor)
        ratios = (ratios,) if np.ndim(ratios) == 0 else tuple(ratios)
        if not ratios:
            raise ValueError(f"no gear ratios given for {motor.name}")
        for n in ratios:
            yield motor, _check_gear_ratio(n)


def load_matching_table(
    motors_and_ratios=THESIS_CASES,
    *,
    load: LoadCurve | None = None,
    thrust: Literal["linear", "table"] = "linear",
) -> list[dict[str, float | str]]:
    """Rows ``{motor, gear_ratio, prop_rpm, thrust_lbf}`` (thesis units) for each motor and ratio.

    ``motors_and_ratios``: pairs ``(PittmanMotor, ratio or ratios)`` or a mapping of the same;
    the default is the thesis's seven cases (9514 at 2.5, 3.67, 5, 10; 14202 at 2.5, 3.67, 5).
    """
    rows = []
    for motor, n in _iter_cases(motors_and_ratios):
        p = operating_point(motor, n, load=load, thrust=thrust).thesis_units()
        rows.append(
            {
                "motor": motor.name,
                "gear_ratio": n,
                "prop_rpm": p["prop_rpm"],
                "thrust_lbf": p["thrust_lbf"],
            }
        )
    return rows


# ---------------------------------------------------------------------------------------------
# Figure (thesis Figs. A.4, A.5: propeller coordinates)
# ---------------------------------------------------------------------------------------------
def plot_load_matching(
    motor: PittmanMotor,
    ratios: float | Sequence[float] = (2.5, 3.67, 5.0),
    ax=None,
    *,
    load: LoadCurve | None = None,
    thrust: Literal["linear", "table"] = "linear",
    max_prop_rpm: float | None = None,
):
    """Draw Figs. A.4/A.5: N·T_cont(N·n_p) per gear ratio and the load curve Q_p(n_p), in
    propeller coordinates (rpm, oz·in), operating points marked, thrust on a right axis (lb).

    Returns the matplotlib Figure.  Does not select a backend (works under ``Agg``).
    """
    import matplotlib.pyplot as plt

    _check_motor(motor)
    ratios = (ratios,) if np.ndim(ratios) == 0 else tuple(ratios)
    if not ratios:
        raise ValueError("ratios must contain at least one gear ratio")
    ratios = tuple(_check_gear_ratio(n) for n in ratios)
    if load is None:
        load = LoadCurve.thesis()
    points = [operating_point(motor, n, load=load, thrust=thrust) for n in ratios]

    if max_prop_rpm is None:
        max_prop_rpm = 1.3 * max(units.to_rpm(p.prop_speed) for p in points)
    elif not (math.isfinite(max_prop_rpm) and max_prop_rpm > 0):
        raise ValueError(f"max_prop_rpm must be finite and > 0, got {max_prop_rpm!r}")

    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 5))
    else:
        fig = ax.figure

    n_rpm = np.linspace(0.0, max_prop_rpm, 400)
    n_si = units.rpm(n_rpm)
    for n_ratio, p in zip(ratios, points):
        t_prop = n_ratio * continuous_torque(motor, n_ratio * n_si)
        (line,) = ax.plot(n_rpm, units.to_oz_in(t_prop), label=f"T_cont, {n_ratio:g}:1")
        u = p.thesis_units()
        ax.plot(u["prop_rpm"], u["prop_torque_oz_in"], "o", color=line.get_color())
        ax.annotate(
            f"{u['prop_rpm']:.0f} rpm, {u['thrust_lbf']:.2f} lb",
            (u["prop_rpm"], u["prop_torque_oz_in"]),
            textcoords="offset points",
            xytext=(6, -12),
            fontsize=8,
        )
    measured = n_rpm <= units.to_rpm(load.measured_max_speed)
    q = units.to_oz_in(load.torque(n_si))
    ax.plot(n_rpm[measured], q[measured], "k-", label=f"load ({load.label or load.kind})")
    if np.any(~measured):
        ax.plot(n_rpm[~measured], q[~measured], "k:", label="load, extrapolated")
    ax.set_xlabel("propeller speed (rpm)")
    ax.set_ylabel("propeller torque (oz·in)")
    ax.set_xlim(0.0, max_prop_rpm)
    ax.set_ylim(bottom=0.0)
    ax.set_title(f"Load matching, {motor.name} (McLean 1991, App. A)")
    ax.grid(True, alpha=0.3)

    ax2 = ax.twinx()
    ax2.plot(n_rpm, units.to_lbf(propeller_thrust(n_si, thrust)), color="0.5", ls="--", lw=0.8)
    ax2.set_ylabel("thrust (lb)", color="0.4")
    ax2.set_ylim(bottom=0.0)
    ax.legend(loc="upper left", fontsize=8)
    return fig
