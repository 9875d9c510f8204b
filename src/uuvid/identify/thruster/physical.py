"""Identification of the voltage-aware physical thruster model (:mod:`uuvid.thruster.physical`)
from bench sheets at several supply voltages.

The model (ESC duty × supply voltage → DC motor against ``K_Q Ω|Ω|`` → ``T = K_T Ω|Ω|``, per
direction) and its equations are in :mod:`uuvid.thruster.physical`.

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
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from uuvid.core.result import Result, jsonable
from uuvid.identify.fit import Fit, IdentifiabilityWarning, Parameter, nonlinear_lsq, residual_figure
from uuvid.io.bench import BenchData, BenchDataError, require_samples
from uuvid.thruster.blocks import ParameterError
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.physical import _UNITS, KE_MIN_FRACTION, PhysicalModel, Prediction


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
            names = ", ".join(s.source or "data" for s in sets)
            raise BenchDataError(f"{names}: no measured {direction} samples (command "
                                 f"{'above' if sgn > 0 else 'below'} neutral {neutral:g} with the "
                                 "propeller turning): the physical model fits both directions "
                                 "(one motor, two propeller coefficients). Fix: add the "
                                 f"{direction} half of the sweep, or fit the one direction with "
                                 "--model quadratic/polynomial/table (the other mirrored, said)")
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
        said = any(("K_e" in w and "R" in w) or (w.startswith(("K_e:", "R:"))
                                                   and "not identifiable" in w)
                   for w in fit.warnings)
        if not said:
            fit = replace(fit, warnings=fit.warnings + (msg,))
            if emit_warnings:
                warnings.warn(msg, IdentifiabilityWarning, stacklevel=2)
    if any(s.censored.any() for s in sets):
        notes.append("censored rows enter only as one-sided constraints (|Ω| below the detection "
                     "limit)")
    return PhysicalFit(model, fit, per, tuple(notes))


__all__ = ["PhysicalFit", "fit_physical", "evaluate"]
