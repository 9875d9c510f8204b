"""``uuvid vehicle design-input`` (the D-optimal sine experiment for the inertia) and
``uuvid reproduce caccia2000`` (ROMEO's identification, simulated and identified back)."""

from __future__ import annotations

import csv
import io
import math
from enum import StrEnum
from pathlib import Path

import numpy as np
import typer
from rich.markup import escape

from uuvid.cli.log_options import fail, msg
from uuvid.cli.options import deprecated_out, renamed

__all__ = ["design_input", "reproduce_caccia2000"]


class Choice(StrEnum):
    nominal = "nominal"
    robust = "robust"


#: :func:`~uuvid.identify.vehicle.design.design_sine_experiment`'s parameters → options.
DESIGN_FLAGS = {"k": "--k", "k_q": "--kq", "speed": "--speed", "w": "--w", "eta": "--eta",
                "mass_air": "--mass-air", "n_periods": "--n-periods",
                "sample_time": "--sample-time", "settle_tau": "--settle-tau",
                "lead_in": "--lead-in", "max_distance": "--max-distance",
                "force_limit": "--force-limit", "reversal_margin": "--reversal-margin",
                "amplitude": "--amplitude", "speed_range": "--speed-range"}


def _pair(text: str | None, opt: str) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        fail(f"{opt}: expected two comma-separated numbers, got {text!r}")
    if not (math.isfinite(a) and math.isfinite(b)):
        fail(f"{opt}: values must be finite, got {text!r}")
    return a, b


def _units(dof: str | None) -> dict:
    """Units of the design's numbers for a linear or angular DOF (both when it is not given)."""
    lin = {"f": "N", "x": "m", "m": "kg", "k": "N·s/m"}
    ang = {"f": "N·m", "x": "rad", "m": "kg·m²", "k": "N·m·s/rad"}
    if dof is None:
        return {key: f"{lin[key]} | {ang[key]}" for key in lin}
    return ang if dof in ("roll", "pitch", "yaw") else lin


def design_input(
    k: float = typer.Option(..., "--k", help="Prior linear drag k (N·s/m or N·m·s/rad)."),
    kq: float = typer.Option(0.0, "--kq", help="Prior quadratic drag k_q (N·s²/m² or N·m·s²/rad²)."),
    mass: float | None = typer.Option(None, "--mass",
                                      help="Nominal inertia for τ_c, kg or kg·m² (default: "
                                           "--mass-air, the paper's yaw choice)."),
    mass_air: float | None = typer.Option(None, "--mass-air",
                                          help="In-air (rigid-body) inertia along the DOF (kg or kg·m²)."),
    added_mass_range: str = typer.Option("0.1,1.0", "--added-mass-range",
                                         help="Added mass as fractions of --mass-air: LOW,HIGH."),
    speed: float = typer.Option(..., "--speed",
                                help="Regime speed ξ* (m/s or rad/s); its sign sets the offset's."),
    speed_range: str | None = typer.Option(None, "--speed-range",
                                           help="Keep the speed within LOW,HIGH (m/s or rad/s)."),
    eta: float = typer.Option(1.0, "--eta", help="Installation coefficient of the mode (dimensionless)."),
    w: float = typer.Option(0.0, "--w", help="Mean disturbance w (N or N·m)."),
    choice: Choice = typer.Option(Choice.nominal, "--choice",
                                  help="nominal: 1/(√3 τ_c); robust: maximin D-efficiency over the "
                                       "inertia range."),
    n_periods: float = typer.Option(3.0, "--n-periods",
                                    help="Sine periods to record (count)."),
    settle_tau: float = typer.Option(4.0, "--settle-tau",
                                     help="Settling time in multiples of τ_c (the largest τ_c)."),
    lead_in: float = typer.Option(0.0, "--lead-in", help="Offset-only lead-in (s)."),
    max_distance: float | None = typer.Option(None, "--max-distance",
                                              help="Maneuvering space (m, or rad for a "
                                                   "rotation): raise ω so it fits."),
    force_limit: float | None = typer.Option(None, "--force-limit",
                                             help="Largest |φ| the thrusters give in the mode "
                                                  "(N or N·m)."),
    reversal_margin: float = typer.Option(0.1, "--reversal-margin",
                                          help="Keep Δφ ≤ (1 − margin)|φ₀| (no thrust reversal)."),
    amplitude: float | None = typer.Option(None, "--amplitude",
                                           help="Impose the amplitude Δφ (N or N·m)."),
    sample_time: float = typer.Option(0.1, "--sample-time", help="Command sample time (s)."),
    dof: str | None = typer.Option(None, "--dof",
                                   help="DOF name (surge, sway, heave, roll, pitch, yaw); needed "
                                        "with --vehicle."),
    vehicle: str | None = typer.Option(None, "--vehicle",
                                       help="Vehicle file/preset: also write per-thruster commands."),
    mode: str | None = typer.Option(None, "--mode", help="Thrust-mapping mode for the allocation."),
    voltage_cv: str | None = typer.Option(None, "--voltage-cv",
                                          help="c_V₊,c_V₋ of T = c_V V|V|: also write voltages."),
    out: Path | None = typer.Option(None, "--out-file", help="Command time series to write (.csv)."),
    old_out: Path | None = deprecated_out("--out-file"),
    json_out: bool = typer.Option(False, "--json", help="Print the design as one JSON document."),
):
    """Design the sine experiment for the inertia (D-optimal frequency, levels, length, command file).

    Reports the τ_c range, the D-optimal ω verified from the Fisher information, the offset and
    amplitude that avoid thrust reversal, and the experiment length."""
    from uuvid.cli.common import _print_json, err_console, out_console
    from uuvid.core.atomic import atomic_write_text
    from uuvid.identify.vehicle.design import SQRT3, design_sine_experiment

    out = renamed(out, "--out-file", old_out)
    for name, v in (("--k", k), ("--kq", kq)):
        if not (math.isfinite(v) and v >= 0):
            fail(f"{name} must be finite and >= 0, got {v}")
    if mass is None and mass_air is None:
        fail("give --mass-air (in-air inertia; the added mass range is relative to it) or --mass")
    frac = _pair(added_mass_range, "--added-mass-range")
    if frac[0] < 0 or frac[1] < frac[0]:
        fail(f"--added-mass-range: expected 0 <= LOW <= HIGH, got {added_mass_range!r}")
    nominal = mass if mass is not None else mass_air
    from uuvid.core.checks import as_options
    from uuvid.identify.vehicle.design import check_command_request, command_columns

    with as_options():
        try:  # the combination first: a --voltage-cv without --vehicle is refused, even malformed
            notes = check_command_request(dof=dof, vehicle=vehicle, voltage=voltage_cv, out=out)
        except ValueError as e:
            fail(str(e))
    cv = _pair(voltage_cv, "--voltage-cv")
    if dof is not None:
        from uuvid.vehicle.layout import dof_index
        from uuvid.vehicle.model import DOF_NAMES

        try:
            dof = DOF_NAMES[dof_index(dof)]
        except ValueError as e:
            fail(f"--dof: {e}")
    if out is not None and out.suffix.lower() != ".csv":
        fail(f"--out-file {out}: the command file must end in .csv")
    try:
        des = design_sine_experiment(
            k, kq, mass=nominal, speed=speed, mass_air=mass_air, added_fraction=frac,
            speed_range=_pair(speed_range, "--speed-range"), eta=eta, w=w, n_periods=n_periods,
            settle_tau=settle_tau, lead_in=lead_in, max_distance=max_distance,
            force_limit=force_limit, reversal_margin=reversal_margin, amplitude=amplitude,
            sample_time=sample_time, choice=choice.value, dof=dof or "")
    except ValueError as e:
        from uuvid.cli.common import _fail_flagged

        _fail_flagged(e, {**DESIGN_FLAGS, "mass": "--mass" if mass is not None else "--mass-air"},
                      prefix="design-input: ")
    doc = {"command": "vehicle design-input", **des.as_dict()}
    u = _units(dof)
    doc["units"] = {"k": u["k"], "mass": u["m"], "k_L": u["k"], "offset": u["f"],
                    "amplitude": u["f"], "distance": u["x"], "tau_c": "s", "duration": "s",
                    "settle": "s", "period": "s", "omega": "rad/s", "sample_time": "s"}
    doc["omega_opt_analytic"] = des.omega_opt
    doc["omega_opt_numeric"] = des.omega_numeric
    rel = abs(des.omega_numeric - des.omega_opt) / des.omega_opt
    doc["omega_verification"] = {
        "relative_difference": rel, "verified": bool(rel < 1e-3),
        "statement": ("the numeric maximum of det M (Fisher information of the first-order "
                      f"model from the sampled sine response) is {des.omega_numeric:.5g} rad/s; "
                      f"1/(√3 τ_c) = {des.omega_opt:.5g} rad/s"
                      + (" — they agree" if rel < 1e-3 else " — they differ"))}
    if mass_air is not None:
        m_lo, m_hi = mass_air * (1 + frac[0]), mass_air * (1 + frac[1])
        doc["inertia_range"] = [m_lo, m_hi]
        doc["tau_c_range"] = [m_lo / des.k_L, m_hi / des.k_L]
        doc["omega_opt_range"] = [des.k_L / (SQRT3 * m_hi), des.k_L / (SQRT3 * m_lo)]
    doc["nominal_inertia"] = nominal
    doc["nominal_inertia_from"] = "--mass" if mass is not None else "--mass-air (in-air)"
    tc = None
    if vehicle is not None:
        from uuvid.vehicle.definition import load_vehicle

        try:
            v = load_vehicle(vehicle)
        except (ValueError, FileNotFoundError, KeyError) as e:
            fail(f"--vehicle: {msg(e)}")
        try:
            tc = des.thruster_commands(v, mode, sample_time=sample_time, voltage=cv)
        except (ValueError, KeyError) as e:
            fail(f"--vehicle {vehicle}" + (f" --mode {mode}" if mode else "") + f": {msg(e)}")
        doc["thrusters"] = {"vehicle": v.name, "mode": tc["mode"], "names": tc["thrusters"],
                            "peak_thrust_N": float(np.max(np.abs(tc["thrust"]))),
                            "saturated": tc["saturated"], "messages": tc["messages"]}
        for m in tc["messages"]:
            err_console.print(f"[yellow]warning:[/] {escape(m)}", highlight=False, soft_wrap=True)
    cols = command_columns(des, sample_time, tc) if dof else {}
    cmd = des.command(sample_time)
    for m in notes:
        err_console.print(f"note: {escape(m)}", highlight=False, soft_wrap=True)
    doc["command_samples"] = int(cmd["t"].size)
    if out is not None:
        buf = io.StringIO()
        wr = csv.writer(buf, lineterminator="\n")
        wr.writerow(list(cols))
        for row in zip(*cols.values()):
            wr.writerow([f"{x:.10g}" for x in row])
        try:
            atomic_write_text(out, buf.getvalue())
        except OSError as e:
            fail(f"--out-file {out}: cannot write ({e.strerror or e})")
        doc["out"] = str(out)
        doc["columns"] = list(cols)
    if json_out:
        _print_json(doc)
        return
    from rich.table import Table

    t = Table(title=f"Sine experiment for the {dof or 'DOF'} inertia")
    t.add_column("quantity")
    t.add_column("value")
    rows = [("k_L = k + 2 k_q |ξ*|", f"{des.k_L:.4g} {u['k']}"),
            (f"τ_c (nominal inertia {nominal:.4g} {u['m']}, {doc['nominal_inertia_from']})",
             f"{des.tau_c:.4g} s")]
    if "tau_c_range" in doc:
        rows.append((f"τ_c range (in-air + {frac[0]:.0%} … {frac[1]:.0%} added)",
                     f"{doc['tau_c_range'][0]:.4g} … {doc['tau_c_range'][1]:.4g} s"))
        rows.append(("ω_opt range", f"{doc['omega_opt_range'][0]:.4g} … "
                                    f"{doc['omega_opt_range'][1]:.4g} rad/s"))
    rows += [("ω_opt = 1/(√3 τ_c)", f"{des.omega_opt:.4g} rad/s"),
             ("ω_opt numeric (Fisher)", f"{des.omega_numeric:.4g} rad/s"),
             ("ω applied", f"{des.omega:.4g} rad/s (period {des.period:.4g} s, {des.choice})"),
             ("offset φ₀", f"{des.offset:.4g} {u['f']}"),
             ("amplitude Δφ", f"{des.amplitude:.4g} {u['f']} (limited by "
                              f"{des.levels['limited_by']})"),
             ("duration", f"{des.duration:.4g} s (settle {des.settle:.4g} s)"),
             ("distance", f"{des.distance:.4g} {u['x']}"
              + (f" ({math.degrees(des.distance):.4g}°)" if u["x"] == "rad" else "")),
             ("D-efficiency", f"{des.efficiency:.3f}")]
    for a, b in rows:
        t.add_row(a, b)
    out_console.print(t)
    if dof is None:
        err_console.print("note: units shown as linear | angular DOF (give --dof to pick one)",
                          highlight=False, markup=False)
    for m in des.messages:
        err_console.print(f"[yellow]note:[/] {escape(m)}", highlight=False, soft_wrap=True)
    if out is not None:
        err_console.print(f"wrote {out} ({doc['command_samples']} samples: {', '.join(cols)})", markup=False)


# =============================================================================================
# reproduce caccia2000
# =============================================================================================
def reproduce_caccia2000(
    seed: int = typer.Option(0, "--seed", min=0, help="Random seed of the simulated experiments "
                             "(an integer >= 0)."),
    fast: bool = typer.Option(False, "--fast",
                              help="Skip the two validation logs (Figs. 13, 15); the "
                                   "identification is identical."),
    json_out: bool = typer.Option(False, "--json", help="Print the results as one JSON document."),
    out: Path | None = typer.Option(None, "--out", help="Write plots, caccia2000.json and "
                                                        "index.html here."),
):
    """Caccia, Indiveri & Veruggio (2000): ROMEO's identification, simulated and identified back.

    Exit status 1 when the acceptance fails (the results are still printed and written)."""
    from uuvid.cli.common import _print_json, err_console
    from uuvid.core.progress import progress_task
    from uuvid.papers import caccia2000

    try:
        with progress_task("Caccia 2000: simulate ROMEO and identify", total=1) as task:
            result = caccia2000.reproduce(seed=seed, fast=fast, out_dir=out)
            task.advance()
    except OSError as e:
        fail(f"--out {out}: cannot write the outputs ({e.strerror or e})")
    if json_out:
        _print_json(dict(result))
    else:
        _show_caccia(result)
        if out:
            err_console.print(f"report: {Path(out) / 'index.html'}", markup=False)
    if not result["acceptance"]["passed"]:  # exit 1: the run's own check failed (2: bad input)
        err_console.print(f"acceptance FAILED on seed {seed} (exit status 1)", markup=False)
        raise typer.Exit(code=1)


def _show_caccia(result: dict) -> None:
    from rich.table import Table

    from uuvid.cli.common import out_console
    from uuvid.papers.caccia2000 import TABLE_KEYS

    for table in TABLE_KEYS:
        r = result[table]
        title = table + (f" — reduced to {r['reduced_to']}" if r.get("reduced_to") else "")
        if r.get("quadratic_significant") is False:
            title += " (quadratic insignificant)"
        t = Table(title=title)
        for c in ("parameter", "estimate", "σ", "truth", "paper", "paper σ", "|est−truth|/σ"):
            t.add_column(c)
        for n, p in r["parameters"].items():
            t.add_row(n, f"{p['estimate']:.4g}", f"{p['sigma']:.3g}", f"{p['truth']:.4g}",
                      "" if p["paper"] is None else f"{p['paper']:.4g}",
                      "" if p["paper_sigma"] is None else f"{p['paper_sigma']:.3g}",
                      f"{p['z']:.2f}")
        out_console.print(t)
    d = result["design"]
    t = Table(title="Input design and phase lags")
    for c in ("quantity", "ours", "paper"):
        t.add_column(c)
    t.add_row("ω_opt yaw (I = 93.75, k = 28.6) [rad/s]", f"{d['omega_opt_yaw']:.4g}",
              f"{d['omega_opt_paper']['yaw']:g}")
    t.add_row("ω_opt surge (m = 675, k_L = 212.25) [rad/s]", f"{d['omega_opt_surge']:.4g}",
              f"{d['omega_opt_paper']['surge']:g}")
    t.add_row("phase lag yaw, 24 s, I = 84 [°]", f"{d['phase_lag_yaw_deg']:.1f} "
              f"(measured {d['phase_lag_yaw_measured_deg']:.1f})", "37.5 / 39 measured")
    t.add_row("phase lag surge, 26 s, m = 890 [°]", f"{d['phase_lag_surge_deg']:.1f} "
              f"(measured {d['phase_lag_surge_measured_deg']:.1f})", "45 / 37 measured")
    out_console.print(t)
    for key, v in (result.get("validation") or {}).items():
        out_console.print(f"validation {key}: NRMSE {v['nrmse']:.3f}", highlight=False)
    acc = result["acceptance"]
    out_console.print("acceptance: " + ("[bold green]PASSED[/]" if acc["passed"] else
                                        "[bold red]FAILED[/]: " + escape("; ".join(acc["failures"]))))
