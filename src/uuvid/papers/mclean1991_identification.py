"""McLean (1991) — the identification problems the thesis leaves open, solved.

Client of the public API: the AUV II preset, the chain simulator, McLean's step metrics and
:mod:`uuvid.identify`.

* :func:`identify_corrections` — the energy and momentum correction differences α_o − α_i and
  β_o − β_i, which the thesis tuned by hand and never printed, identified by linear least squares
  from Table I's *steady* columns (steady propeller speed, steady thrust).
* :func:`fit_experiments` — the tunnel-thruster model with Coulomb friction (which the thesis
  blamed for its misfit but did not model) fitted to the thesis's experiments (Tables II/III:
  peak output thrust, steady thrust and decay time constant at 24, 16 and 8 V), compared with
  the thesis's own simulation.

Steady-state equations (digest §A.1, ``ω̇ = 0``; motor speed ``ω_m = N ω_p``):

    thrust:  F = ρ A P_e² (β_o − β_i) ω_p²
    torque:  K_T (V − K_G ω_m)/R − (C_M + C_P/N²) ω_m − T_c = Q_h/N = ½ ρ A (α_o − α_i) P_e³ ω_p² / N

Both are linear in the unknown given the printed speed and thrust, with the motor constants from
the Pittman 9514 datasheet (App. B) and McLean's friction model (presets).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from uuvid.core import units as U
from uuvid.core.metrics import time_constant_decay
from uuvid.identify.fit import Fit, linear_lsq, nonlinear_lsq
from uuvid.papers.mclean1991_table1 import TABLE1_THESIS, Case, table1_cases
from uuvid.papers.reproduction import PaperReproduction
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.presets import auv2_tunnel_thruster, mclean_load_cell

# ------------------------------------------------------------------------------------------------
# the thesis's numbers
# ------------------------------------------------------------------------------------------------
#: Table II (experiments, 8 runs per voltage, 75 Hz): peak output thrust lb (largest of the runs),
#: peak of the averaged runs lb, steady thrust lb (static test, Fig. 35), decay time constant s.
EXPERIMENTS = {
    24.0: {"peak_output_lbf": 5.30, "peak_average_lbf": 3.50, "steady_lbf": 0.44, "time_constant_s": 0.150},
    16.0: {"peak_output_lbf": 3.40, "peak_average_lbf": 3.20, "steady_lbf": 0.25, "time_constant_s": 0.150},
    8.0: {"peak_output_lbf": 0.95, "peak_average_lbf": 0.80, "steady_lbf": 0.08, "time_constant_s": 0.300},
}
#: Table III, the thesis's simulation beside each experiment (= Table I baseline, 16 V, 8 V rows).
#: Its time constant is the *speed* 63 % time, compared in the thesis with the experiments'
#: *decay* time constant.
THESIS_SIMULATION = {
    24.0: {"peak_output_lbf": 5.40, "steady_lbf": 0.50, "time_constant_s": 0.125},
    16.0: {"peak_output_lbf": 3.60, "steady_lbf": 0.33, "time_constant_s": 0.150},
    8.0: {"peak_output_lbf": 1.85, "steady_lbf": 0.15, "time_constant_s": 0.200},
}
#: The nine numbers fitted: three per voltage.
EXPERIMENT_FIELDS = ("peak_output_lbf", "steady_lbf", "time_constant_s")
#: Ch. III: "A hand-held tachometer recorded the actual propeller speed at 900 RPM" (24 V).
TACHOMETER_RPM_24V = 900.0
#: Ch. IV: each run recorded two seconds after the power switch was thrown.
RECORD_LENGTH = 2.0

#: Table I rows with distinct steady operating points.  The L and K_a rows repeat the baseline's
#: steady state (the model's steady state does not depend on L or K_a, and the thesis prints
#: identical values), so they add no information; the Pe = 0 row has no water and says nothing
#: about α or β.
STEADY_CASES = ("baseline", "Pe=0.0270", "Pe=0.0721", "coulomb", "baseline-16V", "baseline-8V")


# ------------------------------------------------------------------------------------------------
# α_o − α_i and β_o − β_i from Table I's steady columns
# ------------------------------------------------------------------------------------------------
def _cases(names: Sequence[str]) -> list[Case]:
    by_name = {c.name: c for c in table1_cases()}
    unknown = [n for n in names if n not in by_name]
    if unknown:
        raise ValueError(f"unknown Table I case(s) {unknown}; cases: {sorted(by_name)}")
    return [by_name[n] for n in names]


def _steady_rows(cases: Sequence[Case]) -> list[dict]:
    """Per case: printed speed and thrust (SI), the two regressors and the net motor torque."""
    rows = []
    for c in cases:
        th = auv2_tunnel_thruster(**c.overrides)
        if th.effective_pitch == 0:
            raise ValueError(f"case {c.name}: P_e = 0, the water does nothing — no information on α or β")
        m = th.motor
        n = m.gear_ratio
        pe = th.effective_pitch
        rho_a = th.water_density * th.tunnel_area
        _, _, f_lbf, _, rpm = TABLE1_THESIS[c.name]
        wp = U.rpm(rpm)
        wm = n * wp
        cv = m.motor_viscous + m.propeller_viscous / n**2
        net = (
            m.torque_constant * (c.voltage - m.back_emf_constant * wm) / m.resistance
            - cv * wm
            - m.coulomb_torque
        )
        rows.append(
            {
                "case": c.name,
                "voltage_V": c.voltage,
                "steady_rpm": rpm,
                "steady_lbf": f_lbf,
                "thrust_N": U.lbf(f_lbf),
                "h_beta": rho_a * pe**2 * wp**2,
                "net_torque": net,
                "h_alpha": 0.5 * rho_a * pe**3 * wp**2 / n,
                # ∂(net − Δα h_α)/∂ω_m without the Δα term: back-EMF and viscous slopes
                "dnet_dw": m.torque_constant * m.back_emf_constant / m.resistance + cv,
                "motor_speed": wm,
            }
        )
    return rows


#: Where the output-error cross-check starts: away from the answer (α ≈ 3, β ≈ 0.185), so that
#: agreeing with the equation-error solution means the optimiser found it.
OUTPUT_START = (1.0, 1.0)


def identify_corrections(
    cases: Sequence[str] = STEADY_CASES, method: str = "equation", emit_warnings: bool = False,
    start: Sequence[float] = OUTPUT_START,
) -> Fit:
    """α_o − α_i (``energy_correction``) and β_o − β_i (``momentum_correction``) with σ.

    ``method="equation"`` (default) — two linear least-squares problems:

    * ``F_k = Δβ · ρ A P_e² ω_p²`` — each row divided by its printed thrust, so the residuals
      are relative thrust errors;
    * ``K_T(V − K_G ω_m)/R − C ω_m − T_c = Δα · ½ρA P_e³ ω_p²/N`` — each row divided by
      ``ω_m · ∂(torque balance)/∂ω_m``, which turns the torque residual into the relative error of
      the printed speed it corresponds to (the slope contains Δα, so the weights are iterated
      three times from Δα = 3).

    ``method="output"`` — nonlinear cross-check: both corrections at once, minimising the
    relative errors of the steady speed and thrust the model predicts
    (:meth:`TunnelThruster.steady_state`) for every row, started at ``start`` = (α_o − α_i,
    β_o − β_i) (default :data:`OUTPUT_START`, away from the answer); ``extra`` records the start
    and the number of model evaluations.

    Returns a :class:`Fit` (covariance block-diagonal for ``equation``); ``extra["rows"]`` has each
    row's data, the correction it implies alone, and the model's steady speed/thrust with the
    identified values; ``extra["pe0_check"]`` the Pe = 0 row's steady speed (motor + friction
    only) against the printed 3000 rpm.
    """
    cs = _cases(cases)
    rows = _steady_rows(cs)
    k = len(rows)
    if k < 2:
        raise ValueError("need at least two Table I rows")
    F = np.array([r["thrust_N"] for r in rows])
    hb = np.array([r["h_beta"] for r in rows])
    net = np.array([r["net_torque"] for r in rows])
    ha = np.array([r["h_alpha"] for r in rows])
    names = ["energy_correction", "momentum_correction"]
    if method == "equation":
        fb = linear_lsq(
            (hb / F)[:, None],
            np.ones(k),
            ["momentum_correction"],
            model="steady thrust",
            emit_warnings=emit_warnings,
        )
        da = 3.0
        for _ in range(3):
            w = 1.0 / (
                np.array([r["motor_speed"] for r in rows])
                * (
                    np.array([r["dnet_dw"] for r in rows])
                    + 2 * da * ha / np.array([r["motor_speed"] for r in rows])
                )
            )
            fa = linear_lsq(
                (ha * w)[:, None],
                net * w,
                ["energy_correction"],
                model="steady torque balance",
                emit_warnings=emit_warnings,
            )
            da = fa["energy_correction"].value
        cov = np.diag([fa.covariance[0, 0], fb.covariance[0, 0]])
        params = (fa["energy_correction"], fb["momentum_correction"])
        resid = np.concatenate([fa.residuals, fb.residuals])
        fit = Fit(
            "McLean 1991 Table I steady columns: linear LS (equation error)",
            params,
            cov,
            resid,
            2 * k,
            max(fa.condition_number, fb.condition_number),
            tuple(fa.warnings) + tuple(fb.warnings),
            {
                "method": "equation",
                "residuals_meaning": "relative speed error (torque rows), relative thrust "
                "error (thrust rows)",
                "sigma2_torque": fa.sigma2,
                "sigma2_thrust": fb.sigma2,
            },
        )
    elif method == "output":

        def residual(x):
            out = []
            for c in cs:
                s = auv2_tunnel_thruster(
                    energy_correction=x[0], momentum_correction=x[1], **c.overrides
                ).steady_state(c.voltage)
                _, _, f_lbf, _, rpm = TABLE1_THESIS[c.name]
                out += [U.to_rpm(s["prop_speed"]) / rpm - 1, U.to_lbf(s["thrust"]) / f_lbf - 1]
            return np.array(out)

        fit = nonlinear_lsq(
            residual,
            [float(v) for v in start],
            names,
            bounds=([0.01, 0.001], [100.0, 10.0]),
            emit_warnings=emit_warnings,
            model="McLean 1991 Table I steady columns: output error",
            extra={"method": "output", "residuals_meaning": "relative speed and thrust errors",
                   "start": [float(v) for v in start]},
        )
    else:
        raise ValueError(f"method must be 'equation' or 'output', got {method!r}")
    da, db = fit["energy_correction"].value, fit["momentum_correction"].value
    out_rows = []
    for c, r in zip(cs, rows):
        s = auv2_tunnel_thruster(energy_correction=da, momentum_correction=db, **c.overrides).steady_state(
            c.voltage
        )
        out_rows.append(
            {
                "case": c.name,
                "voltage_V": c.voltage,
                "steady_rpm": r["steady_rpm"],
                "steady_lbf": r["steady_lbf"],
                "implied_energy_correction": r["net_torque"] / r["h_alpha"],
                "implied_momentum_correction": r["thrust_N"] / r["h_beta"],
                "model_rpm": U.to_rpm(s["prop_speed"]),
                "model_lbf": U.to_lbf(s["thrust"]),
            }
        )
    pe0 = auv2_tunnel_thruster(effective_pitch=0.0).steady_state(24.0)
    extra = dict(fit.extra)
    extra.update(
        {
            "rows": out_rows,
            "cases": list(cases),
            "pe0_check": {"printed_rpm": TABLE1_THESIS["Pe=0"][4], "model_rpm": U.to_rpm(pe0["prop_speed"])},
        }
    )
    return dataclasses.replace(fit, extra=extra)


def leave_one_out(cases: Sequence[str] = STEADY_CASES) -> list[dict]:
    """Each steady row predicted by the corrections identified from the *other* rows: the model's
    steady speed and thrust against the printed ones (numbers the fit did not see)."""
    rows = []
    by_name = {c.name: c for c in _cases(cases)}
    for held in cases:
        fit = identify_corrections(cases=[c for c in cases if c != held])
        c = by_name[held]
        s = auv2_tunnel_thruster(energy_correction=fit["energy_correction"].value,
                                 momentum_correction=fit["momentum_correction"].value,
                                 **c.overrides).steady_state(c.voltage)
        _, _, f_lbf, _, rpm = TABLE1_THESIS[held]
        rows.append({"case": held, "steady_rpm": rpm, "steady_lbf": f_lbf,
                     "predicted_rpm": U.to_rpm(s["prop_speed"]),
                     "predicted_lbf": U.to_lbf(s["thrust"]),
                     "energy_correction": fit["energy_correction"].value,
                     "momentum_correction": fit["momentum_correction"].value})
    return rows


# ------------------------------------------------------------------------------------------------
# the experiments (Tables II/III)
# ------------------------------------------------------------------------------------------------
#: Parameters ``fit_experiments`` can free: start value, bounds, unit, meaning.
EXPERIMENT_PARAMETERS = {
    "coulomb_volts": (3.0, (0.0, 7.5), "V", "Coulomb friction as a voltage offset, T_c = K_T·V_c/R"),
    "momentum_correction": (0.185, (0.02, 1.0), "", "β_o − β_i"),
    "energy_correction": (3.0, (0.3, 20.0), "", "α_o − α_i"),
    "added_mass_coefficient": (0.25, (0.0, 4.0), "", "K_a"),
    "damping_ratio": (0.16, (0.05, 0.9), "", "load-cell ζ"),
    "natural_frequency": (math.sqrt(1935.0), (20.0, 90.0), "rad/s", "load-cell ω_n"),
    "profile_factor": (1.5, (0.5, 4.0), "", "β on the unsteady torque term"),
    "viscous_factor": (1.0, (0.0, 20.0), "", "multiplier of McLean's motor and propeller viscous friction"),
}
#: Default free set: the friction the thesis did not model, the two corrections it tuned by hand,
#: the added-mass coefficient it guessed and the load-cell damping it settled by trial.
DEFAULT_FREE = (
    "coulomb_volts",
    "momentum_correction",
    "energy_correction",
    "added_mass_coefficient",
    "damping_ratio",
)


def experiment_chain(values: Mapping[str, float] | None = None) -> ThrusterChain:
    """The rig chain (AUV II tunnel thruster → load cell) with named parameters changed
    (names of :data:`EXPERIMENT_PARAMETERS`; the rest at the thesis's baseline)."""
    v = {k: spec[0] for k, spec in EXPERIMENT_PARAMETERS.items()}
    v.update(values or {})
    unknown = set(v) - set(EXPERIMENT_PARAMETERS)
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; known: {sorted(EXPERIMENT_PARAMETERS)}")
    th = auv2_tunnel_thruster(
        energy_correction=v["energy_correction"],
        momentum_correction=v["momentum_correction"],
        added_mass_coefficient=v["added_mass_coefficient"],
    )
    m = th.motor
    m = m.replace(
        coulomb_torque=m.torque_constant * v["coulomb_volts"] / m.resistance,
        motor_viscous=m.motor_viscous * v["viscous_factor"],
        propeller_viscous=m.propeller_viscous * v["viscous_factor"],
    )
    th = th.replace(motor=m, profile_factor=v["profile_factor"])
    lc = mclean_load_cell().replace(
        natural_frequency=v["natural_frequency"], damping_ratio=v["damping_ratio"]
    )
    return ThrusterChain((th, lc), input_kind="voltage", name="auv2-rig-identified")


def experiment_metrics(
    chain: ThrusterChain, voltage: float, duration: float = RECORD_LENGTH, dt: float = 1e-3
) -> dict:
    """Table II's numbers for one voltage step on a rig chain, defined as the thesis did.

    Peak output = largest measured (load-cell) thrust; steady = the model's steady thrust (the
    thesis's came from a separate static test); time constant = from the measured peak until the
    transient has decayed to 37 % of the peak's height above the steady level
    (:func:`uuvid.core.metrics.time_constant_decay`).
    """
    r = chain.simulate(voltage, duration, dt=dt, substeps=2)
    th = chain.blocks[0]
    ss = th.steady_state(voltage)
    y = r["measured_thrust"]
    tau = time_constant_decay(r.t, y, steady=ss["thrust"])
    m = r.metrics()
    out = {
        "peak_output_lbf": U.to_lbf(np.max(y)),
        "steady_lbf": U.to_lbf(ss["thrust"]),
        "time_constant_s": tau,
        "max_true_lbf": U.to_lbf(m.max_true_thrust),
        "steady_rpm": U.to_rpm(ss["prop_speed"]),
        "time_to_peak_s": m.time_to_peak,
        "time_constant_speed_s": m.time_constant_speed,
    }
    return {k: float(v) for k, v in out.items()}


def _rel(a: float, b: float) -> float:
    return abs(a - b) / abs(b)


def thesis_mean_abs_rel_error() -> float:
    """Table III: mean |relative error| of the thesis's simulation against its experiments over
    the nine numbers (≈ 31.7 %)."""
    errs = [_rel(THESIS_SIMULATION[v][f], EXPERIMENTS[v][f]) for v in EXPERIMENTS for f in EXPERIMENT_FIELDS]
    return float(np.mean(errs))


def fit_experiments(
    free: Sequence[str] = DEFAULT_FREE,
    x0: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    fixed: Mapping[str, float] | None = None,
    tachometer: bool = True,
    dt: float = 1e-3,
    emit_warnings: bool = False,
) -> dict:
    """Fit the tunnel-thruster model, Coulomb friction included, to Tables II/III.

    The rig chain (tunnel thruster → load cell) is stepped to 24, 16 and 8 V for the thesis's 2 s
    record, and the nine numbers of :data:`EXPERIMENTS` (peak output thrust, steady thrust,
    decay time constant — :func:`experiment_metrics`) are matched in relative terms by nonlinear
    least squares over ``free`` (names of :data:`EXPERIMENT_PARAMETERS`).  With ``tachometer``
    the thesis's only speed reading (900 rpm at 24 V, hand-held tachometer) is a tenth residual;
    it is not part of the reported error.  The decay time constant jumps where the load cell's
    first trough crosses the 37 % level, so the Jacobian uses 1 % steps and σ is indicative.

    Returns a JSON-able dict: ``mean_abs_rel_error`` (ours, nine numbers),
    ``thesis_mean_abs_rel_error`` (Table III's simulation, ≈ 0.317), ``parameters``
    (estimate, σ, unit, bounds), ``fixed``, ``rows`` (per voltage: experiment, ours, the thesis's
    simulation, relative errors), ``tachometer``, ``fit`` (the full :class:`Fit`) and warnings.
    """
    free = list(free)
    unknown = [f for f in free if f not in EXPERIMENT_PARAMETERS]
    if unknown or not free:
        raise ValueError(f"free must name parameters of {sorted(EXPERIMENT_PARAMETERS)}, got {free}")
    fixed = dict(fixed or {})
    start = np.array([(x0 or {}).get(f, EXPERIMENT_PARAMETERS[f][0]) for f in free], dtype=float)
    lo = np.array([(bounds or {}).get(f, EXPERIMENT_PARAMETERS[f][1])[0] for f in free])
    hi = np.array([(bounds or {}).get(f, EXPERIMENT_PARAMETERS[f][1])[1] for f in free])
    volts = list(EXPERIMENTS)

    def predict(x) -> dict:
        chain = experiment_chain({**fixed, **dict(zip(free, x))})
        return {v: experiment_metrics(chain, v, dt=dt) for v in volts}

    def residual(x):
        p = predict(x)
        r = []
        for v in volts:
            for f in EXPERIMENT_FIELDS:
                a, b = p[v][f], EXPERIMENTS[v][f]
                r.append((a - b) / b if math.isfinite(a) else 1.0)
        if tachometer:
            r.append(p[24.0]["steady_rpm"] / TACHOMETER_RPM_24V - 1.0)
        return np.array(r)

    units = [EXPERIMENT_PARAMETERS[f][2] for f in free]
    fit = nonlinear_lsq(
        residual,
        start,
        free,
        units=units,
        bounds=(lo, hi),
        diff_step=1e-2,
        emit_warnings=emit_warnings,
        model="McLean 1991 experiments (Tables II/III): tunnel thruster + Coulomb friction + load cell",
        extra={
            "residuals_meaning": "relative errors of the nine Table II "
            "numbers" + (" and the 900 rpm tachometer reading" if tachometer else "")
        },
    )
    est = fit.values
    pred = predict(np.array([est[f] for f in free]))
    rows, errs, t_errs = [], [], []
    for v in volts:
        exp, ours, ths = EXPERIMENTS[v], pred[v], THESIS_SIMULATION[v]
        rel = {f: _rel(ours[f], exp[f]) if math.isfinite(ours[f]) else math.inf for f in EXPERIMENT_FIELDS}
        trel = {f: _rel(ths[f], exp[f]) for f in EXPERIMENT_FIELDS}
        errs += list(rel.values())
        t_errs += list(trel.values())
        rows.append(
            {
                "voltage_V": v,
                "experiment": dict(exp),
                "ours": {
                    k: (None if isinstance(x, float) and not math.isfinite(x) else x) for k, x in ours.items()
                },
                "thesis_simulation": dict(ths),
                "rel_error": rel,
                "thesis_rel_error": trel,
            }
        )
    params = {}
    for p in fit.parameters:
        params[p.name] = {
            "estimate": p.value,
            "sigma": p.stderr,
            "unit": p.unit,
            "percentile_error": p.percentile_error,
            "bounds": list(
                EXPERIMENT_PARAMETERS[p.name][1] if not bounds or p.name not in bounds else bounds[p.name]
            ),
            "meaning": EXPERIMENT_PARAMETERS[p.name][3],
        }
    fixed_all = {k: fixed.get(k, spec[0]) for k, spec in EXPERIMENT_PARAMETERS.items() if k not in free}
    rpm24 = pred[24.0]["steady_rpm"]
    return {
        "mean_abs_rel_error": float(np.mean(errs)),
        "thesis_mean_abs_rel_error": float(np.mean(t_errs)),
        "parameters": params,
        "fixed": fixed_all,
        "rows": rows,
        "tachometer": {
            "measured_rpm": TACHOMETER_RPM_24V,
            "ours_rpm": rpm24,
            "rel_error": _rel(rpm24, TACHOMETER_RPM_24V),
            "used_in_fit": tachometer,
        },
        "coulomb_torque_N_m": (experiment_chain({**fixed, **est}).blocks[0].motor.coulomb_torque),
        "warnings": list(fit.warnings),
        "fit": fit.as_dict(),
    }


class McLeanIdentification(PaperReproduction):
    """:func:`reproduce`'s document (a ``dict``, indexed as before) with the result surface: the
    identified correction factors with σ, the experiments' parameters and their relative errors
    against Table II beside the thesis's own simulation."""

    def summary(self) -> str:
        c = self["corrections"]
        lines = [self["paper"], "corrections (equation error; output error as a cross-check):"]
        oe = c.get("output_error_check") or {}
        for key in ("energy_correction", "momentum_correction"):
            p = c[key]
            cross = f", output error {oe[key]:.4g}" if key in oe else ""
            lines.append(f"  {key:<22} {p['estimate']:.4g} ± {p['sigma']:.2g} [1]{cross}")
        e = self["experiments"]
        lines.append(f"experiments (Table II): mean |relative error| {e['mean_abs_rel_error']:.1%} "
                     f"(thesis simulation {e['thesis_mean_abs_rel_error']:.1%})")
        for name, p in e["parameters"].items():
            sig = "σ unknown" if p["sigma"] is None else f"± {p['sigma']:.2g}"
            lines.append(f"  {name:<22} {p['estimate']:.4g} {sig} [{p['unit']}]")
        return "\n".join(lines)

    def plot(self):
        """Relative error of each Table II number per supply voltage, ours against the thesis's."""
        from uuvid.core.plots import new_figure

        rows = self["experiments"]["rows"]
        fields = list(rows[0]["rel_error"]) if rows else []
        fig, ax = new_figure(figsize=(7.5, 3.6))
        x = np.arange(len(fields))
        width = 0.8 / max(1, 2 * len(rows))
        for j, r in enumerate(rows):
            ours = [abs(r["rel_error"][f]) * 100 for f in fields]
            ths = [abs(r["thesis_rel_error"][f]) * 100 for f in fields]
            ax.bar(x + (2 * j) * width, ours, width, label=f"uuvid, {r['voltage_V']:g} V")
            ax.bar(x + (2 * j + 1) * width, ths, width, alpha=0.5, label=f"thesis, {r['voltage_V']:g} V")
        ax.set_xticks(x + width * (len(rows) - 0.5), fields, rotation=20, fontsize=7)
        ax.set_ylabel("|relative error| vs Table II [%]")
        ax.set_title("McLean 1991 experiments: identified model vs the thesis simulation")
        ax.legend(fontsize=7)
        return fig


def reproduce() -> McLeanIdentification:
    """Both identifications as one JSON-able document (a :class:`McLeanIdentification`)."""
    corr = identify_corrections()
    return McLeanIdentification({
        "paper": "McLean 1991 — identification of the unprinted corrections and of the experiments",
        "corrections": {
            "energy_correction": corr["energy_correction"].as_dict(),
            "momentum_correction": corr["momentum_correction"].as_dict(),
            "fit": corr.as_dict(),
            "output_error_check": identify_corrections(method="output").values,
            "output_error_start": list(OUTPUT_START),
            "leave_one_out": leave_one_out(),
        },
        "experiments": fit_experiments(),
    })


__all__ = [
    "DEFAULT_FREE",
    "EXPERIMENTS",
    "EXPERIMENT_FIELDS",
    "EXPERIMENT_PARAMETERS",
    "McLeanIdentification",
    "STEADY_CASES",
    "TACHOMETER_RPM_24V",
    "THESIS_SIMULATION",
    "experiment_chain",
    "experiment_metrics",
    "fit_experiments",
    "identify_corrections",
    "leave_one_out",
    "reproduce",
    "thesis_mean_abs_rel_error",
]
