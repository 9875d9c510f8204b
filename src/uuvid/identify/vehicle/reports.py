"""Report folders of the log identifications (Caccia, Indiveri & Veruggio 2000): plots (velocity
vs force per mode, heave buoyancy cf. Figs. 5/6, measured vs predicted velocity), tables (segments,
rejected samples), the fit report and ``summary.json``, written atomically, plus ``index.html``."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from uuvid.identify.vehicle.logs import ANGULAR, LogData

__all__ = ["write_steady_report", "write_inertia_report", "steady_figure", "inertia_figure"]


def _plot_steady(ax, fit, pts, angular: bool, by_ballast: bool, title: str):
    sc = 180 / math.pi if angular else 1.0
    groups: dict = {}
    for p in pts:
        groups.setdefault(p.ballast if by_ballast else p.mode, []).append(p)
    for j, (key, g) in enumerate(groups.items()):
        f = np.array([q.force for q in g])
        v = np.array([q.velocity for q in g]) * sc
        e = np.array([q.velocity_stderr for q in g]) * sc
        if by_ballast:
            lab = f"ballast {key:g}"
        else:
            et = sorted({q.eta or "η = 1" for q in g})
            lab = f"{key or 'log'} ({', '.join(et)})"
        ax.errorbar(f, v, yerr=2 * e, fmt="o", ms=4, color=f"C{j % 10}", capsize=2, label=lab)
        for sgn in (1, -1):
            gs = [q for q in g if np.sign(q.force) == sgn]
            if not gs:
                continue
            fs = np.array([q.force for q in gs])
            ff = np.linspace(0, fs.max() if sgn > 0 else fs.min(), 100)
            for et in {q.eta for q in gs}:
                try:
                    vv = fit.steady_speed(ff, et, ballast=gs[0].ballast)
                except ValueError:
                    continue
                ax.plot(ff, np.asarray(vv) * sc, color=f"C{j % 10}", lw=1)
    ax.axhline(0, color="0.7", lw=0.5)
    ax.axvline(0, color="0.7", lw=0.5)
    ax.set_xlabel("nominal applied " + ("torque φ [N·m]" if angular else "force φ [N]"))
    ax.set_ylabel(f"LS steady velocity [{'°/s' if angular else 'm/s'}] (±2σ)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7)


def steady_figure(res: dict, doc: dict, data: LogData, dof: str):
    """The steady fit: LS velocity vs nominal force per mode with the fitted curves (heave: and
    the buoyancy per ballast, identified vs unitary η).  Returns (figure, caption)."""
    from uuvid.core.plots import new_figure

    fit = res["fit"]
    angular = dof in ANGULAR
    by_ballast = dof == "heave" and data.ballast is not None
    if dof == "heave":
        fig, ax = new_figure(1, 2, figsize=(12, 4.5))
        _plot_steady(ax[0], fit, res["points"], False, by_ballast,
                     "Heave (cf. Fig. 5): LS velocity vs nominal thrust"
                     + (" per ballast" if by_ballast else " per mode"))
        b, b0 = doc["buoyancy"]["with_eta"], doc["buoyancy"]["eta_unitary"]
        x = np.array([r["ballast"] for r in b], float)
        ax[1].errorbar(x - 0.06, [r["estimate"] for r in b], yerr=[2 * r["sigma"] for r in b],
                       fmt="o", capsize=3, label="identified η")
        if b0:
            ax[1].errorbar(x + 0.06, [r["estimate"] for r in b0],
                           yerr=[2 * r["sigma"] for r in b0], fmt="s", capsize=3,
                           label="η = 1 (unitary)")
        ax[1].set_xticks(x)
        ax[1].set_xlabel("experiment (added weights)")
        ax[1].set_ylabel("W + n ΔW [N] (+ = sinks), ±2σ")
        ax[1].set_title("Buoyancy estimate with and without installation coefficients "
                        "(cf. Fig. 6)", fontsize=10)
        ax[1].legend(fontsize=8)
        caption = ("Steady velocities with the fitted curves (left); net weight per "
                   "experiment with identified vs unitary η (right)")
    else:
        fig, ax = new_figure(1, 1, figsize=(8, 5))
        _plot_steady(ax, fit, res["points"], angular, False,
                     f"{dof}: LS velocity vs nominal force per mapping mode")
        caption = ("Velocity vs nominal force per mapping mode (±2σ) with the identified "
                   "steady-state curves")
    return fig, caption


def write_steady_report(res: dict, doc: dict, data: LogData, dof: str, folder: Path) -> Path:
    from uuvid.core.atomic import atomic_write_json, atomic_write_text
    from uuvid.core.html import Report
    from uuvid.core.plots import new_figure, save_figure

    folder.mkdir(parents=True, exist_ok=True)
    fit = res["fit"]
    angular = dof in ANGULAR
    rep = Report(f"uuvid vehicle identify steady — {dof} from {Path(doc['log']).name}")
    rep.add_paragraph(
        "Constant-command segments, robust LS velocity of each (outliers and missing samples "
        "flagged, listed below), then 0 = −kξ − k_qξ|ξ| + η_μφ + w stacked over segments and "
        "mapping modes and solved by LS (Caccia, Indiveri & Veruggio 2000, §III-A).")
    rep.add_table([{"parameter": n, **{k: v for k, v in r.items()}}
                   for n, r in doc["parameters"].items()], caption="Identified parameters"
                  + (f" (reduced to {doc['reduced_to']})" if doc["reduced_to"] else ""))
    fig, caption = steady_figure(res, doc, data, dof)
    rep.add_figure(save_figure(fig, folder / "steady_fit.png"), caption=caption)
    # the log: command, position, segment windows, rejected samples
    sc = 180 / math.pi if angular else 1.0
    fig, ax = new_figure(2, 1, figsize=(12, 6), sharex=True)
    ax[0].step(data.t_cmd, data.command, where="post", lw=0.8)
    ax[0].set_ylabel("command φ [N·m]" if angular else "command φ [N]")
    ax[1].plot(data.t_pos, data.position * sc, ".", ms=1.5, color="C0", label="position")
    for r in res["segments"]:
        for a in ax:
            a.axvspan(r["t0"], r["t1"], color="C2", alpha=0.12, lw=0)
    rej = [r for r in res["rejected"] if r["reason"] == "outlier"]
    if rej:
        ax[1].plot([r["time"] for r in rej], np.array([r["value"] for r in rej]) * sc, "x",
                   color="C3", ms=5, label=f"rejected outliers ({len(rej)})")
    ax[1].set_ylabel("heading [°]" if angular else "position [m]")
    ax[1].set_xlabel("t [s]")
    ax[1].legend(fontsize=8)
    ax[0].set_title("Log: steady windows shaded", fontsize=10)
    rep.add_figure(save_figure(fig, folder / "steady_log.png"),
                   caption="Command and position; the steady windows used (shaded) and the "
                           "rejected outliers (×)")
    seg_cols = ["segment", "mode", "ballast", "level", "t0", "t1", "eta", "velocity",
                "velocity_stderr", "n_total", "n_used", "n_missing", "n_outliers", "settled"]
    rep.add_table(res["segments"], seg_cols, caption="Steady segments")
    atomic_write_text(folder / "segments.csv", _csv_text(res["segments"], seg_cols))
    rej_cols = ["segment", "index", "time", "value", "residual", "reason"]
    rep.add_table(res["rejected"], rej_cols,
                  caption=f"Rejected samples ({len(res['rejected'])}): missing (non-finite) and "
                          "outliers (residual spike > threshold × robust scale)")
    atomic_write_text(folder / "rejected.csv", _csv_text(res["rejected"], rej_cols))
    if res["skipped"]:
        rep.add_table(res["skipped"], caption="Segments left out")
    rep.add_preformatted(fit.summary(), caption="Fit report")
    atomic_write_text(folder / "fit_report.txt", fit.summary() + "\n")
    atomic_write_json(folder / "summary.json", doc)
    return rep.write(folder)


def _csv_text(rows: list[dict], cols: list[str]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow(["" if r.get(c) is None else r.get(c) for c in cols])
    return buf.getvalue()



def inertia_figure(res: dict, doc: dict, data: LogData, dof: str):
    """Input, Savitzky–Golay velocity and measured vs predicted velocity against time."""
    from uuvid.core.plots import new_figure

    fit = res["fit"]
    angular = dof in ANGULAR
    sc = 180 / math.pi if angular else 1.0
    unit = "°/s" if angular else "m/s"
    n_rows = 3 if "predicted" in res else 2
    fig, ax = new_figure(n_rows, 1, figsize=(12, 2.8 * n_rows), sharex=True)
    ax[0].step(data.t_cmd, data.command, where="post", lw=0.8)
    ax[0].set_ylabel("command φ [N·m]" if angular else "command φ [N]")
    ax[1].plot(fit.t_raw, fit.velocity_raw * sc, "--", color="0.6", lw=0.8,
               label="Savitzky–Golay, whole record")
    ax[1].plot(fit.t, fit.velocity * sc, ".", ms=2, label="rows used by the regression")
    ax[1].set_ylabel(f"velocity [{unit}]")
    ax[1].legend(fontsize=8)
    if "predicted" in res:
        tp, vp, vm = res["predicted"]
        ax[2].plot(tp, vm * sc, label="measured (S–G)")
        ax[2].plot(tp, vp * sc, label="predicted (identified 1-DOF model)")
        ax[2].set_ylabel(f"velocity [{unit}]")
        ax[2].legend(fontsize=8)
        ax[2].set_title(f"NRMSE {doc['fit_nrmse']:.3f}", fontsize=10)
    ax[-1].set_xlabel("t [s]")
    return fig


def write_inertia_report(res: dict, doc: dict, data: LogData, dof: str, folder: Path,
                         validation: dict | None) -> Path:
    from uuvid.core.atomic import atomic_write_json, atomic_write_text
    from uuvid.core.html import Report
    from uuvid.core.plots import new_figure, save_figure

    folder.mkdir(parents=True, exist_ok=True)
    fit = res["fit"]
    angular = dof in ANGULAR
    sc = 180 / math.pi if angular else 1.0
    unit = "°/s" if angular else "m/s"
    rep = Report(f"uuvid vehicle identify inertia — {dof} from {Path(doc['log']).name}")
    rep.add_paragraph("Integrated regression (Caccia et al. 2000, eqs. 15–19): "
                      "m ξ(t) − m ξ₀ − b t = Φ(t) − k x(t) − k_q ∫ξ|ξ|dt on the Savitzky–Golay "
                      "velocity; θ = [m, m ξ₀ + k x₀, b].")
    rep.add_table([{"parameter": n, **r} for n, r in doc["parameters"].items()],
                  caption="Identified parameters")
    fig = inertia_figure(res, doc, data, dof)
    rep.add_figure(save_figure(fig, folder / "inertia.png"),
                   caption="Input, Savitzky–Golay velocity and measured vs predicted velocity")
    pl = doc["phase_lag"]
    if pl:
        rep.add_table([{"quantity": "ω [rad/s]", "value": pl["omega"]},
                       {"quantity": "period [s]", "value": pl["period"]},
                       {"quantity": "measured lag [°]", "value": pl["measured_deg"]},
                       {"quantity": "atan(ω m/k_L) [°]", "value": pl["predicted_deg"]},
                       {"quantity": "k_L", "value": pl["k_L"]},
                       {"quantity": "ZOH delay in the measured lag [°]",
                        "value": pl["zoh_delay_deg"]}],
                      caption="Phase lag of the velocity behind the sine input")
    if validation is not None:
        tv, pv, mv = validation["series"]
        fig, ax = new_figure(1, 1, figsize=(12, 3.5))
        ax.plot(tv, mv * sc, label="measured (S–G)")
        ax.plot(tv, pv * sc, label="predicted")
        ax.set_xlabel("t [s]")
        ax.set_ylabel(f"velocity [{unit}]")
        ax.set_title(f"validation log, NRMSE {validation['nrmse']:.3f}", fontsize=10)
        ax.legend(fontsize=8)
        rep.add_figure(save_figure(fig, folder / "validation.png"),
                       caption="Validation log: measured vs predicted velocity")
    rep.add_preformatted(fit.fit.summary(), caption="Fit report")
    atomic_write_text(folder / "fit_report.txt", fit.fit.summary() + "\n")
    atomic_write_json(folder / "summary.json", doc)
    return rep.write(folder)


