"""A voltage-aware physical thruster model identified from bench sheets at several supply voltages.

Chain (steady state, per direction; forward = command above neutral):

1. **ESC** — command → duty: ``s = (c − e)/(f − e)`` between the dead-band edge ``e`` and the
   full-command point ``f`` (clipped to 0…1), optionally bent by a duty curvature β:
   ``d = s (1 + β (s − 1))`` (monotone for |β| < 1; β = 0 is the linear ESC of Laidani et al.
   eq. 1).  Motor voltage ``V = d · V_supply`` — the same duty gives more volts on a fuller
   battery, which is what lets one model answer for any supply voltage.
2. **DC motor** (averaged brushless motor; McLean 1991 eqs. 2.1–2.5 at rest), ``K_t = K_e``:
   ``K_e (V − K_e Ω)/R = K_Q Ω|Ω| + c_v Ω + T_c sgn Ω`` with the propeller torque
   ``K_Q Ω|Ω|`` per direction.  For ``Ω ≥ 0`` this is the quadratic
   ``K_Q Ω² + (K_e²/R + c_v) Ω + (T_c − K_e V/R) = 0``, solved in closed form (vectorised,
   cancellation-free root); the shaft stays still while ``K_e V/R ≤ T_c``.
3. **Propeller** — ``T = K_T Ω|Ω|`` per direction.

Current.  The sheets log the *supply* current.  A PWM ESC is (to first order) a lossless DC/DC
converter: ``V_s I_s = V_m I_m`` so ``I_s = d · I_m`` with ``I_m = (V − K_e Ω)/R`` the motor
current.  The current is the only signal that separates ``K_e`` from ``R`` (thrust and speed
alone only fix ``K_e`` and ``R K_Q / K_e``), so it is fitted — but with a reduced weight
(``current_weight``, default 0.3), because the lossless-ESC relation ignores switching losses and
the ESC's own supply, and the sheets round small currents to 0.05 A.

Censored rows (readings the logger zeroed below its detection limit, e.g. T200 < 300 rpm) are not
zeros: they contribute only a one-sided residual when the model predicts a speed above the limit.

All parameters are fitted jointly by nonlinear least squares
(:func:`uuvid.identify.fit.nonlinear_lsq`) on thrust, speed and current of all sheets, each
channel of each sheet scaled by its largest magnitude (the fit's residuals are therefore
dimensionless; per-sheet errors in physical units are in ``fit.extra["per_sheet"]``).

On the Blue Robotics T200 sheets (12 V and 16 V) a linear ESC duty cannot carry one sheet to the
other (fit on 16 V → 12 V thrust RMSE 3.5 % of max thrust); a duty curvature β ≈ 0.2 plus viscous
friction brings that to ≈0.6 % (12 V → 16 V: 3.0 % → 1.1 %).  Then ``K_e`` sits on its floor
(``min_back_emf_fraction``): the sheets' voltage scaling looks "resistive", so read the fitted
``K_e``, ``R``, ``K_Q`` as effective values, not as datasheet motor constants.

:meth:`PhysicalModel.to_chain` builds the equivalent :class:`~uuvid.thruster.chain.ThrusterChain`
``ESC → DCMotor → QuadraticMap`` whose steady state equals :meth:`PhysicalModel.predict`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from uuvid.identify.fit import Fit, IdentifiabilityWarning, Parameter, nonlinear_lsq, residual_figure
from uuvid.io.bench import BenchData, BenchDataError, require_samples
from uuvid.report.result import Result, jsonable
from uuvid.thruster.blocks import ESC, DCMotor, ParameterError, QuadraticMap
from uuvid.thruster.chain import ThrusterChain

#: Default lower bound of K_e: back-EMF at the top measured speed ≥ this fraction of the supply.
#: Steady sheets barely constrain K_e (see the module notes); without a floor the fit may slide to
#: a motor with no back-EMF at all, which no real motor is.
KE_MIN_FRACTION = 0.1
#: Default linearised mechanical time constant of an exported chain when no inertia is known.
DEFAULT_TIME_CONSTANT = 0.05

_UNITS = {
    "K_e": "V·s/rad (= K_t, N·m/A)",
    "deadband_fwd": "command (edge − neutral)",
    "deadband_rev": "command (neutral − edge)",
    "R": "Ω",
    "K_Q_fwd": "N·m·s²/rad²",
    "K_Q_rev": "N·m·s²/rad²",
    "K_T_fwd": "N·s²/rad²",
    "K_T_rev": "N·s²/rad²",
    "curvature_fwd": "1",
    "curvature_rev": "1",
    "c_v": "N·m·s/rad",
    "T_c": "N·m",
}


@dataclass(frozen=True)
class Prediction:
    """Steady state at each (command, supply voltage)."""

    command: np.ndarray
    supply_voltage: np.ndarray
    duty: np.ndarray  # signed
    voltage: np.ndarray  # motor voltage, signed [V]
    speed: np.ndarray  # [rad/s], signed
    thrust: np.ndarray  # [N], signed
    motor_current: np.ndarray  # [A], signed
    current: np.ndarray  # supply current [A] = |d|·|I_m|
    torque: np.ndarray  # propeller torque [N·m], signed


@dataclass(frozen=True)
class PhysicalModel:
    """ESC duty × supply voltage → DC motor against ``K_Q Ω|Ω|`` → ``T = K_T Ω|Ω|``, per direction.

    Commands are in ``command_unit`` around ``neutral``; ``edge_*`` are the dead-band edges and
    ``full_*`` the commands of full duty.  ``motor_inertia`` only matters for simulation (it is
    not identifiable from steady data); when ``None`` an exported chain gets the inertia that gives
    a linearised time constant of :data:`DEFAULT_TIME_CONSTANT` at full forward command.
    """

    back_emf_constant: float
    resistance: float
    kq_fwd: float
    kq_rev: float
    kt_fwd: float
    kt_rev: float
    edge_fwd: float
    edge_rev: float
    full_fwd: float
    full_rev: float
    curvature_fwd: float = 0.0
    curvature_rev: float = 0.0
    viscous: float = 0.0
    coulomb: float = 0.0
    neutral: float = 1500.0
    command_unit: str = "pwm_us"
    motor_inertia: float | None = None

    def __post_init__(self):
        for name in ("back_emf_constant", "resistance"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(f"PhysicalModel.{name} must be positive, got {v!r}", name)
        if self.motor_inertia is not None and not (math.isfinite(self.motor_inertia)
                                                   and self.motor_inertia > 0):
            raise ParameterError(f"PhysicalModel.motor_inertia must be positive, got "
                                 f"{self.motor_inertia!r}", "motor_inertia")
        for name in ("kq_fwd", "kq_rev", "kt_fwd", "kt_rev", "viscous", "coulomb"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"PhysicalModel.{name} must be >= 0, got {v!r}", name)
        if not (self.full_rev < self.edge_rev <= self.neutral <= self.edge_fwd < self.full_fwd):
            raise ParameterError(
                "PhysicalModel needs full_rev < edge_rev <= neutral <= edge_fwd < full_fwd, got "
                f"{self.full_rev:g}, {self.edge_rev:g}, {self.neutral:g}, {self.edge_fwd:g}, "
                f"{self.full_fwd:g}")
        for name in ("curvature_fwd", "curvature_rev"):
            v = getattr(self, name)
            if not (math.isfinite(v) and -1 < v < 1):
                raise ParameterError(f"PhysicalModel.{name} must lie in (-1, 1) (monotone duty), "
                                     f"got {v!r}", name)

    # ------------------------------------------------------------------ the model
    def duty(self, command) -> np.ndarray:
        """Signed duty ``d(c)`` (−1…1)."""
        c = np.clip(np.asarray(command, dtype=float), self.full_rev, self.full_fwd)
        s_f = np.clip((c - self.edge_fwd) / (self.full_fwd - self.edge_fwd), 0.0, 1.0)
        s_r = np.clip((self.edge_rev - c) / (self.edge_rev - self.full_rev), 0.0, 1.0)
        d_f = s_f * (1.0 + self.curvature_fwd * (s_f - 1.0))
        d_r = s_r * (1.0 + self.curvature_rev * (s_r - 1.0))
        return np.where(c > self.edge_fwd, d_f, np.where(c < self.edge_rev, -d_r, 0.0))

    def predict(self, command, supply_voltage) -> Prediction:
        """Steady thrust, speed, currents at commands ``command`` and supply voltage(s)."""
        c, vs = np.broadcast_arrays(np.asarray(command, dtype=float),
                                    np.asarray(supply_voltage, dtype=float))
        if np.any(~np.isfinite(vs) | (vs <= 0)):
            raise ValueError("supply voltage must be positive and finite")
        d = self.duty(c)
        v = d * vs
        sgn = np.sign(v)
        av = np.abs(v)
        ke, r = self.back_emf_constant, self.resistance
        kq = np.where(sgn >= 0, self.kq_fwd, self.kq_rev)
        kt = np.where(sgn >= 0, self.kt_fwd, self.kt_rev)
        b = ke * ke / r + self.viscous
        cc = self.coulomb - ke * av / r
        disc = np.sqrt(np.maximum(b * b - 4.0 * kq * cc, 0.0))
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(cc < 0, -2.0 * cc / (b + disc), 0.0)
        im = (av - ke * w) / r
        return Prediction(command=c, supply_voltage=vs, duty=d, voltage=v, speed=sgn * w,
                          thrust=sgn * kt * w * w, motor_current=sgn * im,
                          current=np.abs(d) * im, torque=sgn * kq * w * w)

    def thrust(self, command, supply_voltage) -> np.ndarray:
        """Steady thrust [N] (shorthand for ``predict(...).thrust``)."""
        return self.predict(command, supply_voltage).thrust

    def speed(self, command, supply_voltage) -> np.ndarray:
        return self.predict(command, supply_voltage).speed

    # ------------------------------------------------------------------ export
    def esc(self, supply_voltage: float) -> ESC:
        """The ESC block at ``supply_voltage`` (duty curvature only if the block supports it)."""
        a_f = supply_voltage / (self.full_fwd - self.edge_fwd)
        a_r = supply_voltage / (self.edge_rev - self.full_rev)
        kw = dict(a_fwd=a_f, b_fwd=-a_f * self.edge_fwd, a_rev=a_r, b_rev=-a_r * self.edge_rev,
                  neutral=self.neutral, deadzone_low=self.edge_rev, deadzone_high=self.edge_fwd,
                  saturation_low=self.full_rev, saturation_high=self.full_fwd,
                  supply_voltage=float(supply_voltage), command_unit=self.command_unit)
        if self.curvature_fwd or self.curvature_rev:
            if esc_supports_curvature():
                kw.update(curvature_fwd=self.curvature_fwd, curvature_rev=self.curvature_rev)
        return ESC(**kw)

    def inertia_for(self, time_constant: float, supply_voltage: float) -> float:
        """Inertia giving the linearised time constant ``time_constant`` at full forward command:
        ``J = τ (K_e²/R + c_v + 2 K_Q Ω_full)``."""
        w = float(abs(self.predict(self.full_fwd, supply_voltage).speed))
        damping = (self.back_emf_constant**2 / self.resistance + self.viscous
                   + 2.0 * self.kq_fwd * w)
        return float(time_constant * damping)

    def to_chain(self, supply_voltage: float, *, motor_inertia: float | None = None,
                 time_constant: float = DEFAULT_TIME_CONSTANT, allow_approximation: bool = False,
                 name: str = "physical") -> ThrusterChain:
        """``ESC → DCMotor → QuadraticMap`` at ``supply_voltage``; its steady state is :meth:`predict`.

        The inertia is ``motor_inertia``, else the model's, else the one giving ``time_constant``
        (steady data say nothing about dynamics).

        A model with a duty curvature needs an ESC block with ``curvature_fwd``/``curvature_rev``;
        without one this raises, unless ``allow_approximation`` (then the curvature is dropped
        with a warning giving the largest steady thrust error it causes).
        """
        if not (math.isfinite(supply_voltage) and supply_voltage > 0):
            raise ParameterError(f"supply_voltage must be positive, got {supply_voltage!r}")
        curved = bool(self.curvature_fwd or self.curvature_rev)
        if curved and not esc_supports_curvature():
            lin = self.linear_duty()
            c = np.linspace(self.full_rev, self.full_fwd, 401)
            err = float(np.max(np.abs(lin.thrust(c, supply_voltage)
                                      - self.thrust(c, supply_voltage))))
            msg = (f"the ESC block has no duty curvature (curvature_fwd={self.curvature_fwd:.3g}, "
                   f"curvature_rev={self.curvature_rev:.3g}); a linear ESC changes the steady "
                   f"thrust by up to {err:.3g} N at {supply_voltage:g} V")
            if not allow_approximation:
                raise ParameterError(msg + ": fit with duty_curvature=False for an exact chain, or "
                                     "pass allow_approximation=True", "curvature_fwd")
            warnings.warn(msg, RuntimeWarning, stacklevel=2)
        j = motor_inertia if motor_inertia is not None else self.motor_inertia
        if j is None:
            j = self.inertia_for(time_constant, supply_voltage)
        motor = DCMotor(torque_constant=self.back_emf_constant,
                        back_emf_constant=self.back_emf_constant, resistance=self.resistance,
                        motor_inertia=j,
                        motor_viscous=self.viscous, coulomb_torque=self.coulomb,
                        torque_coefficient=self.kq_fwd, torque_coefficient_rev=self.kq_rev)
        prop = QuadraticMap(k_pos=self.kt_fwd, k_neg=self.kt_rev, torque_pos=self.kq_fwd,
                            torque_neg=self.kq_rev)
        return ThrusterChain((self.esc(supply_voltage), motor, prop),
                             name=f"{name}@{supply_voltage:g}V")

    def linear_duty(self) -> PhysicalModel:
        """The same model with the duty curvature removed."""
        from dataclasses import replace

        return replace(self, curvature_fwd=0.0, curvature_rev=0.0)

    def as_dict(self) -> dict:
        return asdict(self)


def esc_supports_curvature() -> bool:
    """Whether :class:`~uuvid.thruster.blocks.ESC` has ``curvature_fwd``/``curvature_rev``."""
    names = {f.name for f in fields(ESC)}
    return {"curvature_fwd", "curvature_rev"} <= names


# ------------------------------------------------------------------------------------------------
# Identification
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PhysicalFit(Result):
    """The fitted :class:`PhysicalModel`, its :class:`Fit` and per-sheet errors."""

    model: PhysicalModel
    fit: Fit
    per_sheet: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    @property
    def chain(self) -> ThrusterChain:
        """The chain at the first sheet's supply voltage (see :meth:`to_chain`)."""
        v = next(iter(self.per_sheet.values()))["supply_voltage"] if self.per_sheet else 12.0
        return self.model.to_chain(v)

    def to_chain(self, supply_voltage: float, **kw) -> ThrusterChain:
        return self.model.to_chain(supply_voltage, **kw)

    def predict(self, command, supply_voltage) -> Prediction:
        return self.model.predict(command, supply_voltage)

    report_title = "Physical thruster model fit"

    def to_dict(self) -> dict:
        return jsonable({"model": asdict(self.model), "fit": self.fit.as_dict(),
                         "per_sheet": self.per_sheet, "notes": list(self.notes)})

    def plot(self):
        """Residuals of the joint fit over all sheets."""
        return residual_figure({"physical": self.fit}, "physical model",
                               unit="fraction of each channel's largest value")

    def summary(self) -> str:
        lines = [self.fit.summary(), "[[Per sheet]]"]
        for k, s in self.per_sheet.items():
            lines.append(f"    {k}: thrust RMSE {s['thrust_rmse']:.4g} N "
                         f"({s['thrust_rmse_pct']:.2f} % of max {s['max_thrust']:.4g} N), "
                         f"speed RMSE {s.get('speed_rmse', math.nan):.4g} rad/s, "
                         f"current RMSE {s.get('current_rmse', math.nan):.4g} A")
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


def evaluate(model: PhysicalModel, data: BenchData, *, include_censored: bool = False) -> dict:
    """Errors of ``model`` on one sheet: thrust RMSE [N] and % of the sheet's max |thrust|, etc.

    Censored rows are left out unless ``include_censored`` (then compared with the sheet's 0).
    """
    data.require("thrust", what="evaluate")
    p = model.predict(data.command, data.supply_voltage_array())
    m = np.ones(len(data), dtype=bool) if include_censored else data.measured
    e = p.thrust[m] - data.thrust[m]
    tmax = float(np.max(np.abs(data.thrust[m])))
    out = {"supply_voltage": data.nominal_voltage(), "n": int(m.sum()),
           "thrust_rmse": float(np.sqrt(np.mean(e**2))), "thrust_me": float(np.mean(np.abs(e))),
           "thrust_bias": float(np.mean(e)), "max_thrust": tmax,
           "thrust_max_error": float(np.max(np.abs(e)))}
    out["thrust_rmse_pct"] = 100.0 * out["thrust_rmse"] / tmax
    if data.speed is not None:
        out["speed_rmse"] = float(np.sqrt(np.mean((p.speed[m] - data.speed[m]) ** 2)))
    if data.current is not None:
        out["current_rmse"] = float(np.sqrt(np.mean((p.current[m] - data.current[m]) ** 2)))
    return out


def _names(duty_curvature: bool, viscous: bool, coulomb: bool, fit_full: bool) -> list[str]:
    n = ["K_e", "R", "K_Q_fwd", "K_Q_rev", "K_T_fwd", "K_T_rev", "deadband_fwd", "deadband_rev"]
    if duty_curvature:
        n += ["curvature_fwd", "curvature_rev"]
    if viscous:
        n.append("c_v")
    if coulomb:
        n.append("T_c")
    if fit_full:
        n += ["full_fwd", "full_rev"]
    return n


_FIELD = {"K_e": "back_emf_constant", "R": "resistance", "K_Q_fwd": "kq_fwd", "K_Q_rev": "kq_rev",
          "K_T_fwd": "kt_fwd", "K_T_rev": "kt_rev", "curvature_fwd": "curvature_fwd",
          "curvature_rev": "curvature_rev", "c_v": "viscous", "T_c": "coulomb",
          "full_fwd": "full_fwd", "full_rev": "full_rev"}


def _unscale(fq: Fit, scale: np.ndarray, names, units, model: str, emit: bool,
             extra: dict) -> Fit:
    """Map a fit in scaled parameters ``q = θ/scale`` back to θ (values, σ, covariance)."""
    params = tuple(Parameter(nm, p.value * s, p.stderr * s, u)
                   for nm, p, s, u in zip(names, fq.parameters, scale, units))
    cov = fq.covariance * np.outer(scale, scale)
    msgs = []
    for m in fq.warnings:
        if "at its bound" in m:  # restate the bound in θ units
            nm = m.split(":")[0]
            m = f"{nm}: at its bound {params[names.index(nm)].value:.6g}; its σ is not meaningful"
        msgs.append(m)
    if emit:
        for m in msgs:
            warnings.warn(m, IdentifiabilityWarning, stacklevel=3)
    ex = dict(fq.extra)
    ex.update(extra)
    return Fit(model, params, cov, fq.residuals, fq.n_samples, fq.condition_number, tuple(msgs),
               ex)


def fit_physical(sheets: BenchData | Sequence[BenchData], *, duty_curvature: bool = True,
                 viscous: bool = True, coulomb: bool = False, current_weight: float = 0.3,
                 speed_weight: float = 1.0, full_command: tuple[float, float] | None = None,
                 fit_full_command: bool = False, min_back_emf_fraction: float = KE_MIN_FRACTION,
                 motor_inertia: float | None = None, emit_warnings: bool = True) -> PhysicalFit:
    """Fit every parameter of :class:`PhysicalModel` jointly on one or more bench sheets.

    Parameters
    ----------
    sheets
        :class:`BenchData` with command, thrust, speed and supply voltage (current optional).
        Several sheets at different supply voltages make the voltage dependence identifiable.
    duty_curvature, viscous, coulomb
        Which optional physics to fit: ESC duty curvature β per direction, motor viscous
        friction ``c_v``, Coulomb friction ``T_c`` (otherwise fixed at 0).
    current_weight, speed_weight
        Weights of the (max-scaled) current and speed residuals relative to thrust.
    full_command
        ``(reverse, forward)`` commands of full duty; default: the extreme commands of the data.
    fit_full_command
        Fit the full-command points too (an ESC reaching full duty before the end of its range).
    min_back_emf_fraction
        Floor on ``K_e``: back-EMF at the top measured speed of the highest-voltage sheet is at
        least this fraction of its supply.  The sheets hardly constrain ``K_e`` (thrust and speed
        fix only ``K_e`` and ``R K_Q/K_e``; the supply current helps only through the idealised
        ``I_s = d I_m``); on the T200 sheets the optimum sits on this floor, and the fit says so.
    motor_inertia
        Rotor + propeller inertia [kg·m²] for exported chains (not identifiable from steady data).
    """
    sets = [sheets] if isinstance(sheets, BenchData) else list(sheets)
    if not sets:
        raise BenchDataError("fit_physical needs at least one bench sheet")
    for s in sets:
        s.require("thrust", "speed", "supply_voltage", what="fit_physical")
    unit, neutral = sets[0].command_unit, sets[0].neutral
    for s in sets[1:]:
        if s.command_unit != unit or s.neutral != neutral:
            raise BenchDataError(f"{s.source}: command unit/neutral differ from {sets[0].source}")
    for direction, sgn in (("forward", 1), ("reverse", -1)):
        if not any(np.any(s.measured & (s.direction == sgn) & (s.speed != 0)) for s in sets):
            raise BenchDataError(f"fit_physical: no measured {direction} samples; both "
                                 "directions are needed")
    use_current = current_weight > 0 and all(s.current is not None for s in sets)
    cmin = min(float(s.command.min()) for s in sets)
    cmax = max(float(s.command.max()) for s in sets)
    f_rev, f_fwd = (cmin, cmax) if full_command is None else map(float, full_command)
    if not (f_rev < neutral < f_fwd):
        raise BenchDataError(f"full commands ({f_rev:g}, {f_fwd:g}) must bracket neutral "
                             f"{neutral:g}")
    names = _names(duty_curvature, viscous, coulomb, fit_full_command)
    n_meas = sum(int(s.measured.sum()) for s in sets)
    require_samples(n_meas, len(names), "physical thruster model (measured rows)")

    # ---------------------------------------------------------------- stacked data
    C = np.concatenate([s.command for s in sets])
    VS = np.concatenate([s.supply_voltage_array() for s in sets])
    T = np.concatenate([s.thrust for s in sets])
    W = np.concatenate([s.speed for s in sets])
    CUR = np.concatenate([s.current for s in sets]) if use_current else None
    M = np.concatenate([s.measured for s in sets])
    sheet_id = np.concatenate([np.full(len(s), k) for k, s in enumerate(sets)])
    cens_lim = np.concatenate([np.full(len(s), s.censor_speed if s.censor_speed is not None
                                       else np.nan) for s in sets])
    sT = np.array([np.max(np.abs(s.thrust[s.measured])) for s in sets])[sheet_id]
    sW = np.array([np.max(np.abs(s.speed[s.measured])) for s in sets])[sheet_id]
    sI = (np.array([max(np.max(np.abs(s.current[s.measured])), 1e-9) for s in sets])[sheet_id]
          if use_current else None)
    hinge = ~M & np.isfinite(cens_lim)

    fixed = {"curvature_fwd": 0.0, "curvature_rev": 0.0, "c_v": 0.0, "T_c": 0.0,
             "full_fwd": f_fwd, "full_rev": f_rev}

    def build(theta) -> PhysicalModel:
        vals = dict(fixed)
        vals.update(zip(names, theta))
        kw = {_FIELD[k]: float(v) for k, v in vals.items() if k in _FIELD}
        kw["edge_fwd"] = neutral + float(vals["deadband_fwd"])
        kw["edge_rev"] = neutral - float(vals["deadband_rev"])
        return PhysicalModel(neutral=neutral, command_unit=unit, motor_inertia=motor_inertia, **kw)

    def residual(theta):
        try:
            mdl = build(theta)
        except ParameterError:
            return np.full(n_res, 1e3)
        p = mdl.predict(C, VS)
        parts = [((p.thrust - T) / sT)[M], speed_weight * ((p.speed - W) / sW)[M]]
        if use_current:
            parts.append(current_weight * ((p.current - CUR) / sI)[M])
        if hinge.any():
            parts.append(speed_weight * np.maximum(np.abs(p.speed[hinge]) - cens_lim[hinge], 0.0)
                         / sW[hinge])
        return np.concatenate(parts)

    n_res = int(M.sum()) * (3 if use_current else 2) + int(hinge.sum())

    # ---------------------------------------------------------------- start values
    kt0 = {}
    for key, sgn in (("fwd", 1), ("rev", -1)):
        m = M & (np.sign(W) == sgn)
        kt0[key] = float(np.sum(np.abs(T[m]) * W[m] ** 2) / np.sum(W[m] ** 4))
    big = int(np.argmax([s.nominal_voltage() for s in sets]))
    sb = sets[big]
    vmax = sb.nominal_voltage()
    wmax = float(np.max(np.abs(sb.speed[sb.measured])))
    imax = (float(np.max(sb.current[sb.measured])) if sb.current is not None else None)
    edge0 = {}
    for key, sgn in (("fwd", 1), ("rev", -1)):
        # the edge lies between neutral and the first measured moving command
        firsts = []
        for s in sets:
            m = s.measured & (s.direction == sgn) & (np.abs(s.speed) > 0)
            if np.any(m):
                firsts.append(float(np.min(np.abs(s.command[m] - neutral))))
        edge0[key] = 0.5 * min(firsts)
    lo = {"K_e": min_back_emf_fraction * vmax / wmax, "R": 1e-5, "K_Q_fwd": 0.0, "K_Q_rev": 0.0,
          "K_T_fwd": 0.0, "K_T_rev": 0.0, "deadband_fwd": 0.0, "deadband_rev": 0.0,
          "curvature_fwd": -0.95, "curvature_rev": -0.95, "c_v": 0.0, "T_c": 0.0,
          "full_fwd": neutral + 0.5 * (f_fwd - neutral), "full_rev": f_rev}
    hi = {"K_e": 100.0, "R": 1e3, "K_Q_fwd": np.inf, "K_Q_rev": np.inf, "K_T_fwd": np.inf,
          "K_T_rev": np.inf, "deadband_fwd": 0.5 * (f_fwd - neutral),
          "deadband_rev": 0.5 * (neutral - f_rev),
          "curvature_fwd": 0.95, "curvature_rev": 0.95, "c_v": np.inf, "T_c": np.inf,
          "full_fwd": f_fwd, "full_rev": neutral - 0.5 * (neutral - f_rev)}
    starts = []
    curvatures = (0.05, 0.25) if duty_curvature else (0.0,)
    for frac in (0.3, 0.6):
        for beta in curvatures:
            ke = frac * vmax / wmax
            i_full = imax if imax and imax > 0 else 0.5 * vmax  # guess: a few amps
            r = max((vmax - ke * wmax) / i_full, 1e-3)
            kq = ke * i_full / wmax**2
            x = {"K_e": ke, "R": r, "K_Q_fwd": kq, "K_Q_rev": kq, "K_T_fwd": kt0["fwd"],
                 "K_T_rev": kt0["rev"], "deadband_fwd": edge0["fwd"],
                 "deadband_rev": edge0["rev"], "curvature_fwd": beta, "curvature_rev": beta,
                 "c_v": 0.02 * kq * wmax, "T_c": 0.01 * kq * wmax**2,
                 "full_fwd": f_fwd - 1e-6 * (f_fwd - neutral),
                 "full_rev": f_rev + 1e-6 * (neutral - f_rev)}
            starts.append(np.array([np.clip(x[k], lo[k], hi[k]) for k in names]))
    lob = np.array([lo[k] for k in names])
    hib = np.array([hi[k] for k in names])
    units = [_UNITS.get(k, unit) for k in names]
    # Fit in scaled parameters q = θ/scale (scale = the first start's magnitudes) so that the
    # Jacobian's columns are comparable; the covariance is mapped back to θ afterwards.
    scale = np.where(np.abs(starts[0]) > 0, np.abs(starts[0]), 1.0)

    def residual_q(q):
        return residual(q * scale)

    best = None
    for x0 in starts:
        f = nonlinear_lsq(residual_q, x0 / scale, names, bounds=(lob / scale, hib / scale),
                          emit_warnings=False, model="physical thruster model", max_nfev=4000)
        if best is None or f.extra["cost"] < best.extra["cost"]:
            best = f
    desc = (f"physical: ESC duty{' (curved)' if duty_curvature else ''} × V_supply → DC motor "
            f"vs K_Q Ω|Ω|{' + c_v Ω' if viscous else ''}{' + T_c' if coulomb else ''} → "
            f"K_T Ω|Ω|; sheets {', '.join(f'{s.nominal_voltage():g} V' for s in sets)}")
    fit = _unscale(best, scale, names, units, desc, emit_warnings,
                   {"residuals": "dimensionless: each channel of each sheet divided by its largest "
                                 "magnitude, times its weight",
                    "current_weight": current_weight if use_current else 0.0,
                    "speed_weight": speed_weight,
                    "fixed": {k: v for k, v in fixed.items() if k not in names},
                    "starts": len(starts)})
    model = build([fit[k].value for k in names])
    per = {}
    for s in sets:
        key = f"{s.source or 'sheet'} ({s.nominal_voltage():g} V)"
        per[key] = evaluate(model, s)
    fit.extra["per_sheet"] = per
    notes = []
    if not use_current:
        # Structural, not numerical: without current the model depends on K_e and R only through
        # K_e and R·K_Q/K_e, so say so whatever the Jacobian's rank test happens to conclude.
        msg = ("no current data (or current_weight 0): K_e and R are not separately "
               "identifiable — only K_e and R·K_Q/K_e are")
        notes.append(msg)
        if not any("K_e" in w and "R" in w for w in fit.warnings):
            fit = replace(fit, warnings=fit.warnings + (msg,))
            if emit_warnings:
                warnings.warn(msg, IdentifiabilityWarning, stacklevel=2)
    if any(s.censored.any() for s in sets):
        notes.append("censored rows enter only as one-sided constraints (|Ω| below the detection "
                     "limit)")
    return PhysicalFit(model, fit, per, tuple(notes))


__all__ = ["PhysicalModel", "PhysicalFit", "Prediction", "fit_physical", "evaluate",
           "esc_supports_curvature"]
