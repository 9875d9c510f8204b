"""The ``uuvid thruster fit`` workflow as a library: read bench files, fit a model, write a report.

:func:`run_fit` returns a :class:`FitOutcome` (chain, fits, report text, figures, tables);
:func:`summary` and :func:`write_report` turn it into the JSON summary and the report folder.
The CLI (:mod:`uuvid.cli.fit_cmd`) only parses options and calls these.

Steady models (``quadratic``, ``cv``, ``polynomial``, ``deadzone``, ``table``, ``physical``) use
every row of every file (files are stacked; ``physical`` keeps each file as one sheet with its own
supply voltage).  Dynamic models (``first-order``, ``yoerger``, ``bessa``, ``mclean``) need a time
column; each file is one run (e.g. steps at several voltages) and the runs share the parameters.

What each model reads and writes (the model file loads with :func:`uuvid.thruster.modelfile.load_chain`):

===========  =====================================  ===========================================
model        data                                   chain written
===========  =====================================  ===========================================
quadratic    thrust, speed (and flow_speed: the     speed → ``T = K_T Ω|Ω|`` per direction
             inflow coefficient k_a of
             ``T = K_T Ω|Ω| − k_a|Ω|u_a``)
four-        thrust, speed, flow_speed, --diameter  speed → the bollard ``K_T Ω|Ω|`` of the fitted
quadrant                                            ``C_T*(β)`` Fourier series (order --degree)
cv           thrust, command in volts (or duty ×    voltage → ``T = c_V V|V|`` (Caccia 2000)
             supply)
polynomial   thrust, speed                          speed → ``|T| = P(|Ω|)`` per direction,
                                                    degree by 5-fold CV (or ``--degree``)
deadzone     thrust, speed (or the command)         speed (or command) → UUV Simulator Bessa
                                                    conversion ``T = c(x|x| − δ)``
table        thrust, command                        command → lookup table (LinearInterp)
physical     thrust, speed, supply voltage          command → ESC → DC motor → ``K_T Ω|Ω|`` at
             (current helps); one file per voltage  ``--supply-voltage`` (default: first file's)
first-order  time, speed, command                   (command − neutral) → ``K/(1 + τ s)``
yoerger      time, speed, command                   (command − neutral) → ``ẋ = βu − αx|x|``
bessa        time, speed, command                   (command − neutral) → Bessa dynamics
mclean       time, thrust, command in volts         voltage → McLean tunnel thruster (+ the
                                                    ``--start`` model's load cell); motor
                                                    constants fixed at the start model's
dc-motor     time, speed (and thrust), command      command → driver with dead band → DC motor
                                                    (→ ``K_T Ω|Ω|`` with thrust)
healey       time, speed and thrust, command        command → driver with dead band → Healey
                                                    two-state thruster (speed + axial inflow)
===========  =====================================  ===========================================

Structured dynamic fits (:mod:`uuvid.identify.thruster.dynamic_select`): ``dc-motor`` and ``healey``
always, and ``first-order``/``yoerger``/``bessa`` when the records hold thrust too or with
``dead_band=True``, put a :class:`~uuvid.thruster.blocks.Driver` (dead band per direction, offset
= the neutral command) in front and fit dead bands, dynamics and thrust map together, each
channel weighted by its estimated noise.  ``select=True`` compares every family by
leave-one-level-out prediction and writes the one that extrapolates best.

With a PWM command (neutral ≠ 0) the ``deadzone`` (command input) and dynamic models get a
unit-gain ESC in front that only subtracts the neutral command, so ``uuvid thruster predict --pwm``
works on the written file; its "voltage" is then ``command − neutral``.

Bench runs in a flow (a ``flow_speed`` column, m/s unless its header or ``flow_speed_unit`` says
another unit; :mod:`uuvid.identify.thruster.inflow`): ``quadratic`` and ``four-quadrant`` identify
how thrust falls with the water speed, with σ, correlations, residuals and a plot of thrust against
the water speed per command, and warn when the fit says it rises (the column's sign reversed?).  A
flow column that is zero throughout leaves the inflow coefficient unidentifiable: ``quadratic``
warns and fits the bollard map, ``four-quadrant`` refuses (its ``C_T*(β)`` needs water speeds to
span the advance angle β) and points to ``quadratic``; it changes nothing for the other models;
they refuse data with water
speeds they do not model.  Without a flow column nothing changes.

Errors in the data (unreadable files, missing columns, bad cells, missing channels) exit with
status 2 and the :class:`~uuvid.io.bench.BenchDataError` message, which names the file, the column
and the row.
"""

from __future__ import annotations

import csv
import io
import math
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from uuvid.core.result import Result, jsonable

__all__ = ["DYNAMIC", "MODELS", "STEADY", "FitError", "FitOutcome", "ReadOptions", "offset_esc",
           "read_files", "run_fit", "summary", "write_report"]

MODELS = ("quadratic", "cv", "polynomial", "deadzone", "table", "physical", "first-order",
          "yoerger", "bessa", "dc-motor", "healey", "mclean", "four-quadrant")
STEADY = ("quadratic", "cv", "polynomial", "deadzone", "table", "physical", "four-quadrant")
#: Models that take the water speed of a bench in a flow into account (``flow_speed``).
INFLOW = ("quadratic", "four-quadrant")
DYNAMIC = ("first-order", "yoerger", "bessa", "dc-motor", "healey", "mclean")
#: Families fitted with a dead-band driver, jointly on speed + thrust (see dynamic_select).
STRUCTURED = ("first-order", "yoerger", "bessa", "dc-motor", "healey")


class FitError(ValueError):
    """A user-input problem found by the command itself (exit 2)."""


# ------------------------------------------------------------------------------------------------
# result
# ------------------------------------------------------------------------------------------------
@dataclass
class FitOutcome(Result):
    """Everything the command writes: the chain, the fits, the numbers and the figures."""

    model: str
    chain: object  # ThrusterChain
    fits: dict  # label → Fit
    report_text: str
    rmse: float
    rmse_unit: str
    warnings: list[str]
    summary_extra: dict = field(default_factory=dict)
    figures: list = field(default_factory=list)  # (file stem, Figure, caption)
    tables: list = field(default_factory=list)  # (file stem, rows, columns, caption)
    #: what was done and why (not a problem with the result; ``warnings`` are the problems)
    notes: list[str] = field(default_factory=list)
    #: a short text for the terminal when ``report_text`` is long (a 201-knot table); the full
    #: text stays in the report's fit_report.txt, the model file and the JSON
    terminal_text: str | None = None

    def parameters(self) -> dict:
        """``{name: {estimate, sigma, percentile_error, unit, significant}}``; names are prefixed
        with the fit's label (``forward.c5``) where two fits share a name."""
        counts: dict[str, int] = {}
        for f in self.fits.values():
            for p in f.parameters:
                counts[p.name] = counts.get(p.name, 0) + 1
        out = {}
        for label, f in self.fits.items():
            for p in f.parameters:
                key = p.name if counts[p.name] == 1 else f"{label}.{p.name}"
                out[key] = {"estimate": p.value, "sigma": p.stderr,
                            "percentile_error": p.percentile_error, "unit": p.unit,
                            "significant": p.significant, "at_bound": p.name in f.at_bound}
        return out

    report_title = "Thruster fit"

    def summary(self) -> str:
        """What ``uuvid thruster fit`` prints: the fit report, or its short form when long."""
        return self.terminal_text or self.report_text

    def to_dict(self) -> dict:
        """The ``uuvid thruster fit --json`` document (without the output paths)."""
        return jsonable(summary(self, None, None))

    def plot(self):
        """The first figure of the fit (the residuals when the fit made none)."""
        if self.figures:
            return self.figures[0][1]
        from uuvid.identify.fit import residual_figure

        return residual_figure(self.fits, self.model, unit=self.rmse_unit or None)

    def report(self, folder, sources=()) -> Path:
        """Plots, tables, fit report, summary.json, result.json and index.html in ``folder``,
        written as a whole (:func:`uuvid.core.atomic.atomic_dir`); returns the index."""
        from uuvid.core.atomic import atomic_dir

        final = Path(folder)
        with atomic_dir(final) as work:
            index = write_report(self, summary(self, None, final), work, [str(s) for s in sources])
            self.write_basics(work)
        return final / Path(index).relative_to(work)

    def parameter_rows(self) -> list[dict]:
        rows = []
        for label, f in self.fits.items():
            for p in f.parameters:
                rows.append({"fit": label, "parameter": p.name, "estimate": p.value,
                             "sigma": p.stderr, "percentile_error_%": p.percentile_error,
                             "significant": p.significant, "unit": p.unit,
                             "at_bound": p.name in f.at_bound})
        return rows


# ------------------------------------------------------------------------------------------------
# reading
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ReadOptions:
    fmt: str = "csv"
    command_col: str = "command"
    thrust_col: str | None = None
    speed_col: str | None = None
    current_col: str | None = None
    voltage_col: str | None = None
    time_col: str | None = None
    command_unit: str = "pwm_us"
    thrust_unit: str | None = None  # None: the unit in the column's header, else N
    speed_unit: str | None = None  # None: the unit in the column's header, else rad/s
    supply_voltage: float | None = None
    neutral: float | None = None
    flow_speed_col: str | None = "auto"  # auto: the column 'flow_speed' when the file has one
    flow_speed_unit: str | None = None  # None: the unit in the column's header, else m/s


#: options a Blue Robotics T200 sheet does not take (its columns and units are fixed): defaults
_T200_IGNORES = {"thrust_unit": None, "speed_unit": None, "command_unit": "pwm_us",
                 "time_col": None, "command_col": "command", "thrust_col": None,
                 "speed_col": None, "current_col": None, "voltage_col": None, "neutral": None,
                 "flow_speed_unit": None, "flow_speed_col": "auto"}


def _t200_unit_clash(opts: ReadOptions) -> str:
    """What a unit option given with ``--format t200`` says against the sheet's headers: a unit
    option names the unit of the file's column (the result is SI whatever it is), so
    ``--thrust-unit N`` on the sheet's kgf column is a contradiction, not a request for N."""
    from uuvid.io.bench import T200_UNIT_COLUMNS

    out = []
    for k, (col, unit, si) in T200_UNIT_COLUMNS.items():
        v = getattr(opts, k)
        if v is None:
            continue
        flag = f"--{k.replace('_', '-')} {v}"
        if str(v).strip().lower() == unit.lower():
            out.append(f" {flag} is the sheet's own unit: leaving it out reads the same.")
        else:
            out.append(f" {flag} contradicts the sheet: its column {col!r} is in {unit} by its "
                       f"header (read in {unit} and converted to {si}; {flag.split()[0]} names the "
                       f"unit of the file's column, not of the result).")
    return "." + "".join(out) if out else ""


def read_files(paths, opts: ReadOptions) -> list:
    """Read every file into :class:`~uuvid.io.bench.BenchData` (raises ``BenchDataError``)."""
    from uuvid.io.bench import read_bench, read_t200

    if opts.fmt == "t200":
        given = [f"--{k.replace('_', '-')} {'none' if getattr(opts, k) is None else getattr(opts, k)}"
                 for k, d in _T200_IGNORES.items() if getattr(opts, k) != d]
        if given:
            raise FitError(f"--format t200 reads the sheet's own columns and units (µs, kgf → N, "
                           f"rpm → rad/s, A, V): {', '.join(given)} would be ignored; drop it, or "
                           "read the file as a plain table (--format csv with its columns)"
                           + _t200_unit_clash(opts))
    sets = []
    for p in paths:
        if opts.fmt == "t200":
            sets.append(read_t200(p))
        else:
            sets.append(read_bench(
                p, command_col=opts.command_col, thrust_col=opts.thrust_col,
                speed_col=opts.speed_col, current_col=opts.current_col,
                voltage_col=opts.voltage_col, time_col=opts.time_col,
                command_unit=opts.command_unit, thrust_unit=opts.thrust_unit,
                speed_unit=opts.speed_unit,
                supply_voltage=opts.supply_voltage if opts.voltage_col is None else None,
                neutral=opts.neutral, flow_speed_col=opts.flow_speed_col,
                flow_speed_unit=opts.flow_speed_unit))
    return sets


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------
def _chain(blocks, input_kind, name):
    from uuvid.thruster.chain import ThrusterChain

    return ThrusterChain(tuple(blocks), input_kind=input_kind, name=name)


def offset_esc(neutral: float, cmin: float, cmax: float, command_unit: str):
    """A unit-gain ESC whose only job is ``command → command − neutral`` (clipped to the data's
    command range), so a map or dynamics fitted on ``command − neutral`` takes raw commands.  It
    is no voltage source (``follows_supply`` False): the map was measured at the bench's supply
    and a supply voltage asked of the model does not rescale it."""
    from uuvid.thruster.blocks import ESC

    lo, hi = min(cmin, neutral - 1e-9), max(cmax, neutral + 1e-9)
    return ESC(a_fwd=1.0, b_fwd=-neutral, a_rev=1.0, b_rev=-neutral, neutral=neutral,
               deadzone_low=neutral, deadzone_high=neutral, saturation_low=lo,
               saturation_high=hi, supply_voltage=max(hi - neutral, neutral - lo),
               command_unit=command_unit, follows_supply=False)


def _rms(e) -> float:
    e = np.asarray(e, dtype=float)
    return float(np.sqrt(np.mean(e**2))) if e.size else math.nan


def _one_supply_voltage(sets, what: str, rel_tol: float = 0.02) -> None:
    """Refuse to merge sheets at different supply voltages into a map of the command (the
    thrust at a command depends on the voltage: merging would average the sheets silently)."""
    volts = []
    for s in sets:
        if s.supply_voltage is not None:
            volts.append((s.source or "data", s.nominal_voltage()))
            _one_voltage_per_command(s, what)
    if len(volts) < 2:
        return
    vs = [v for _, v in volts]
    if max(vs) - min(vs) <= rel_tol * max(vs):
        return
    listing = ", ".join(f"{src} at {v:g} V" for src, v in volts)
    raise FitError(f"{what}: the files are at different supply voltages ({listing}); a map of the "
                   "command would average them. Fix: fit one voltage at a time, or use --model "
                   "physical (it models the supply voltage), or a map of the propeller speed")


def _one_voltage_per_command(s, what: str, rel_tol: float = 0.2) -> None:
    """One file whose voltage column holds rows at one command more than ``rel_tol`` apart is
    several sheets in one (12 V and 16 V rows: a table map averaged them silently) or a battery
    drained far during the session; a battery's sag under load (one voltage per command) and a
    4S pack's drain within a session (16.4 → 14.8 V, 11 %) pass."""
    if s.supply_voltage is None or np.ndim(s.supply_voltage) != 1:
        return
    v = np.asarray(s.supply_voltage, float)
    cmd = np.round(np.asarray(s.command, float), 6)
    order = np.lexsort((v, cmd))
    c, vs = cmd[order], v[order]
    starts = np.flatnonzero(np.r_[True, c[1:] != c[:-1]])
    lo, hi = np.minimum.reduceat(vs, starts), np.maximum.reduceat(vs, starts)
    bad = np.flatnonzero(hi > (1 + rel_tol) * lo)
    if bad.size:
        k = starts[bad[0]]
        raise FitError(f"{what}: {s.source or 'the data'} holds rows at supply voltages "
                       f"{100 * (hi[bad[0]] / lo[bad[0]] - 1):.0f} % apart for one command "
                       f"({lo[bad[0]]:g} V and {hi[bad[0]]:g} V at {c[k]:g}): several sheets in "
                       "one file, or a battery drained far, which a map of the command would "
                       "average. Fix: fit one voltage at a time (split the file), or use --model "
                       "physical (it models the supply voltage)")


def _stack(sets):
    from uuvid.io.bench import concat

    return sets[0] if len(sets) == 1 else concat(sets)


def _residual_label(ylabel: str) -> str:
    """``residual [N]`` for a panel whose data are ``thrust [N]`` (the residual's unit is theirs)."""
    import re

    m = re.search(r"\[([^\]]+)\]", ylabel)
    return f"residual [{m.group(1)}]" if m else f"residual (as {ylabel})"


def _direction_figure(title: str, panels: list[dict], xlabel: str, ylabel: str):
    """Top row: data and fitted curve per panel (direction); bottom row: residuals."""
    from uuvid.core.plots import new_figure

    n = len(panels)
    fig, ax = new_figure(2, n, squeeze=False, sharex="col", height_ratios=[3, 1],
                         figsize=(5.2 * n, 6.0))
    for j, p in enumerate(panels):
        a, r = ax[0, j], ax[1, j]
        for k, s in enumerate(p["series"]):
            color = f"C{k}"
            a.plot(s["x"], s["y"], ".", ms=3, color=color, label=s.get("label", "data"))
            if s.get("xg") is not None:
                a.plot(s["xg"], s["yg"], "-", lw=1.4, color=color if len(p["series"]) > 1 else "C1",
                       label=s.get("fit_label", "fit"))
            r.plot(s["x"], s["y"] - s["yfit"], ".", ms=3, color=color)
            if s.get("xc") is not None and len(s["xc"]):
                a.plot(s["xc"], np.zeros(len(s["xc"])), "x", ms=4, color="0.6",
                       label="censored (not fitted)" if k == 0 else None)
        a.set_title(p["title"])
        a.set_ylabel(ylabel)
        a.grid(True, alpha=0.3)
        a.legend(loc="best", fontsize="small")
        r.axhline(0.0, color="k", lw=0.8)
        r.set_ylabel(_residual_label(ylabel))
        r.set_xlabel(xlabel)
        r.grid(True, alpha=0.3)
    fig.suptitle(title)
    return fig


def _split_panels(x, y, yfit, direction, grid_fn, xg_range=None, censored_x=None,
                  censored_dir=None):
    panels = []
    for name, sgn in (("forward", 1), ("reverse", -1)):
        m = direction == sgn
        if not np.any(m):
            continue
        xs = x[m]
        lo, hi = (float(xs.min()), float(xs.max())) if xg_range is None else xg_range[name]
        xg = np.linspace(lo, hi, 300)
        s = {"x": xs, "y": y[m], "yfit": yfit[m], "xg": xg, "yg": grid_fn(xg)}
        if censored_x is not None:
            s["xc"] = censored_x[censored_dir == sgn]
        panels.append({"title": name, "series": [s]})
    return panels


def _degree_rows(tables: dict) -> dict:
    return {d: [{k: r[k] for k in ("degree", "n_params", "me", "rmse", "cv_rmse", "cv_se",
                                   "aic", "bic")} for r in t.rows] for d, t in tables.items()}


def _degree_figure(tables: dict, chosen: dict):
    from uuvid.core.plots import new_figure

    n = len(tables)
    fig, ax = new_figure(1, n, squeeze=False, figsize=(5.2 * n, 3.8))
    for j, (d, t) in enumerate(tables.items()):
        a = ax[0, j]
        deg = t.column("degree")
        a.plot(deg, t.column("me"), "o-", label="ME (in-sample)")
        a.plot(deg, t.column("rmse"), "s-", label="RMSE (in-sample)")
        a.errorbar(deg, t.column("cv_rmse"), yerr=t.column("cv_se"), fmt="^-",
                   label=f"{t.k}-fold CV RMSE ± SE", capsize=3)
        if d in chosen:
            a.axvline(chosen[d], color="r", ls="--", lw=1, label=f"selected: {chosen[d]}")
        a.set_yscale("log")
        a.set_xlabel("polynomial degree [–]")
        a.set_ylabel("thrust error [N]")
        a.set_title(d)
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize="small")
    return fig


# ------------------------------------------------------------------------------------------------
# steady models
# ------------------------------------------------------------------------------------------------
def _steady_messages(sf) -> tuple[list[str], list[str]]:
    """(warnings, notes) of a steady fit: the fits' identifiability warnings and a direction
    without samples are warnings; the rest of its notes (rows left out, …) are notes."""
    warn = [f"{k}: {w}" for k, f in sf.fits.items() for w in f.warnings]
    notes = []
    for n in sf.info.get("notes", ()):
        (warn if "not identified" in n or n.startswith(("zero thrust", "the table's", "wrong-sign",
                                                                 "lack of fit"))
         else notes).append(n)
    return warn, notes


def _fit_quadratic(sets, name):
    from uuvid.identify.thruster.inflow import BOLLARD_ONLY, is_bollard
    from uuvid.identify.thruster.steady import fit_quadratic_speed

    data = _stack(sets)
    if data.flow_speed is not None and not is_bollard(data):
        return _fit_inflow(data, name, "quadratic")
    data.require("thrust", "speed", what="--model quadratic (thrust = k·Ω|Ω| against speed)")
    sf = fit_quadratic_speed(data)
    chain = _chain((sf.block,), "speed", name)
    m = data.measured & (data.speed != 0)
    x, y = data.speed[m], data.thrust[m]
    yfit = sf.block.thrust(x)
    cm = data.censored
    fig = _direction_figure(f"{name}: T = K_T Ω|Ω|", _split_panels(
        x, y, yfit, np.sign(x), sf.block.thrust,
        censored_x=data.speed[cm] if cm.any() else None,
        censored_dir=np.sign(data.command[cm] - data.neutral)), "Ω [rad/s]", "thrust [N]")
    warn, notes = _steady_messages(sf)
    if data.flow_speed is not None:  # a flow column, zero throughout: say what it cannot give
        warn.append(BOLLARD_ONLY)
    return FitOutcome("quadratic", chain, dict(sf.fits), sf.summary(), _rms(y - yfit), "N",
                      warn, figures=[("fit", fig, "Thrust vs propeller speed, fit "
                                                  "and residuals per direction")], notes=notes)


def _command_groups(data, m, max_groups: int = 8) -> list[tuple[str, np.ndarray]]:
    """Rows ``m`` grouped by command (one curve each in the inflow plot); more distinct commands
    than ``max_groups`` are binned by propeller speed."""
    cmd = data.command
    levels = np.unique(cmd[m])
    if levels.size <= max_groups:
        return [(f"{c:g} {data.command_unit}", m & (cmd == c)) for c in levels]
    edges = np.quantile(np.abs(data.speed[m]), np.linspace(0, 1, max_groups + 1))
    out = []
    for j in range(max_groups):
        a = np.abs(data.speed)
        g = m & (a >= edges[j]) & ((a <= edges[j + 1]) if j == max_groups - 1 else (a < edges[j + 1]))
        if g.any():
            out.append((f"|Ω| {edges[j]:.0f}–{edges[j + 1]:.0f} rad/s", g))
    return out


def _inflow_figure(data, sf, name, title):
    """Thrust against the water speed, data and model per command (curves at the group's median
    propeller speed), residuals below, one panel per direction."""
    from uuvid.identify.thruster.inflow import model_thrust

    m = data.measured & (data.speed != 0)
    panels = []
    fl = data.flow_speed
    ug = np.linspace(float(fl[m].min()), float(fl[m].max()), 200)
    for dname, sgn in (("forward", 1.0), ("reverse", -1.0)):
        series = []
        for label, g in _command_groups(data, m & (np.sign(data.speed) == sgn)):
            w = data.speed[g]
            series.append({"x": fl[g], "y": data.thrust[g], "yfit": model_thrust(sf, w, fl[g]),
                           "xg": ug, "yg": model_thrust(sf, np.full(ug.size, np.median(w)), ug),
                           "label": label, "fit_label": None})
        if series:
            panels.append({"title": dname, "series": series})
    return _direction_figure(f"{name}: {title}", panels, "water speed u_a [m/s]", "thrust [N]")


def _fit_inflow(data, name, model, diameter=None, order=None):
    """``quadratic`` or ``four-quadrant`` on a bench in a flow (:mod:`uuvid.identify.thruster.
    inflow`): the chain is the bollard map, the inflow coefficients are the fit's parameters."""
    from uuvid.identify.thruster.inflow import fit_four_quadrant, fit_inflow_linear, model_thrust

    if model == "four-quadrant":
        if diameter is None:
            raise FitError("--model four-quadrant needs the propeller diameter: --diameter D (m)")
        sf = fit_four_quadrant(data, diameter, order=order)
        k = (len(next(iter(sf.fits.values())).parameters) - 1) // 2
        title = f"C_T*(β) Fourier order {k}, D = {diameter:g} m"
    else:
        sf = fit_inflow_linear(data)
        title = "T = K_T Ω|Ω| − k_a |Ω| u_a"
    (label, fit), = sf.fits.items()
    m = data.measured & (data.speed != 0)
    resid = data.thrust[m] - model_thrust(sf, data.speed[m], data.flow_speed[m])
    corr = fit.correlation
    extra = {"inflow": {"form": fit.model, "flow_levels_m_s": fit.extra["flow_levels"],
                        "parameters": {p.name: {"estimate": p.value, "sigma": p.stderr,
                                                "unit": p.unit} for p in fit.parameters},
                        "correlation": {"names": fit.names, "matrix": np.asarray(corr).tolist()}}}
    for k in ("beta_range_deg", "beta_ranges_deg"):
        if k in sf.info:
            extra["inflow"][k] = sf.info[k]
    warn, notes = _steady_messages(sf)
    notes.append("the model file's blocks are the bollard map (u_a = 0) of the fit; its 'inflow' "
                 "section holds the fitted inflow coefficients with their σ (summary key "
                 "'inflow')")
    turned = [n for n, s in (("ahead", 1), ("astern", -1)) if np.any(np.sign(data.speed[m]) == s)]
    if len(turned) == 1:
        other = "reverse" if turned[0] == "ahead" else "forward"
        warn.append(f"the bench turned the propeller {turned[0]} only: the model file's {other} "
                    f"bollard coefficient is the {turned[0]} one (assumed, not measured)"
                    + (", and the map read the other way is an extrapolation"
                       if model == "four-quadrant" else ""))
    text = sf.summary() + "\n=== correlation ===\n" + "\n".join(
        f"{a:>10s} " + " ".join(f"{c:+.3f}" for c in row) for a, row in zip(fit.names, corr))
    section = jsonable({**extra["inflow"], "equation": fit.model,
                        "form": "four-quadrant" if model == "four-quadrant" else "linear",
                        **({"diameter_m": float(diameter)} if model == "four-quadrant" else {}),
                        "source": f"bench fit of {data.source or 'bench data'}"})
    chain = replace(_chain((sf.block,), "speed", name), inflow=section)
    return FitOutcome(model, chain, dict(sf.fits), text, _rms(resid),
                      "N", warn, extra,
                      [("fit", _inflow_figure(data, sf, name, title),
                        "Thrust against the water speed through the propeller: data and model "
                        "per command (curves at each command's median propeller speed), "
                        "residuals below")], notes=notes)


def _voltage_of(data):
    from uuvid.io.bench import BenchDataError

    if data.command_unit == "volts":
        return data.command - data.neutral
    if data.command_unit == "duty":
        return (data.command - data.neutral) * data.supply_voltage_array()
    raise BenchDataError(f"{data.source or 'bench data'}: this model needs the motor voltage as "
                         "the command: use --command-unit volts (or duty with the supply voltage)")


def _fit_cv(sets, name):
    from uuvid.identify.thruster.steady import fit_cv

    data = _stack(sets)
    data.require("thrust", what="--model cv")
    v = _voltage_of(data)
    m = data.measured
    sf = fit_cv(v[m], data.thrust[m])
    chain = _chain((sf.block,), "voltage", name)
    x, y = v[m], data.thrust[m]
    yfit = sf.block.thrust(x)
    fig = _direction_figure(f"{name}: T = c_V V|V|", _split_panels(
        x, y, yfit, np.sign(x), sf.block.thrust), "motor voltage [V]", "thrust [N]")
    warn, notes = _steady_messages(sf)
    if data.command_unit == "duty":
        notes.append("the chain's input is the motor voltage (duty × supply voltage)")
    return FitOutcome("cv", chain, dict(sf.fits), sf.summary(), _rms(y - yfit), "N", warn,
                      figures=[("fit", fig, "Thrust vs motor voltage, fit and residuals")],
                      notes=notes)


def _fit_polynomial(sets, name, degree, criterion):
    from uuvid.identify.thruster.steady import (
        DIRECTIONS,
        fit_polynomial,
        polynomial_degree_table,
        select_degree,
    )

    data = _stack(sets)
    data.require("thrust", "speed", what="--model polynomial (thrust against speed)")
    sf = fit_polynomial(data, degree, criterion=criterion)
    tables, choices = dict(sf.info.get("tables", {})), dict(sf.info.get("choices", {}))
    if degree is not None:  # still show the table and what the rule would have chosen
        for d in DIRECTIONS:
            if d not in sf.fits:
                continue
            sgn = 1.0 if d == "forward" else -1.0
            m = data.measured & (np.sign(data.speed) == sgn)
            try:
                tables[d] = polynomial_degree_table(np.abs(data.speed[m]), np.abs(data.thrust[m]))
                choices[d] = select_degree(tables[d], criterion)
            except ValueError:
                pass
    chain = _chain((sf.block,), "speed", name)
    m = data.measured & (data.speed != 0)
    x, y = data.speed[m], data.thrust[m]
    yfit = sf.block.thrust(x)
    selected = {d: len(f.parameters) - 1 for d, f in sf.fits.items()}
    if degree is None:
        reason = {d: c.reason for d, c in choices.items()}
    else:
        reason = {d: f"degree {degree} given with --degree" + (
            f" (the {criterion} rule would choose {choices[d].degree}: {choices[d].reason})"
            if d in choices else "") for d in sf.fits}
    cm = data.censored
    figs = [("fit", _direction_figure(
        f"{name}: |T| = P(|Ω|), degree " + "/".join(str(selected[d]) for d in selected),
        _split_panels(x, y, yfit, np.sign(x), sf.block.thrust,
                      censored_x=data.speed[cm] if cm.any() else None,
                      censored_dir=np.sign(data.command[cm] - data.neutral)),
        "Ω [rad/s]", "thrust [N]"), "Thrust vs propeller speed, fit and residuals per direction")]
    tabs = []
    if tables:
        figs.append(("degree_table", _degree_figure(tables, selected),
                     "ME, RMSE and k-fold CV RMSE per degree (Laidani Table 1, extended)"))
        for d, t in tables.items():
            tabs.append((f"degree_table_{d}", list(_degree_rows({d: t})[d]),
                         ["degree", "n_params", "me", "rmse", "cv_rmse", "cv_se", "aic", "bic"],
                         f"Degree table, {d} (selected {selected.get(d)}): {reason.get(d, '')}"))
    text = sf.summary()
    if tables:
        text += "\n" + "\n".join(f"=== degree table ({d}) ===\n{t.to_text()}\nselected: "
                                 f"{selected.get(d)} — {reason.get(d, '')}"
                                 for d, t in tables.items())
    extra = {"degree_table": _degree_rows(tables) if tables else None,
             "selected_degree": selected, "reason": reason,
             "criterion": criterion if degree is None else "given"}
    warn, notes = _steady_messages(sf)
    return FitOutcome("polynomial", chain, dict(sf.fits), text, _rms(y - yfit), "N",
                      warn, extra, figs, tabs, notes=notes)


def _fit_deadzone(sets, name, map_input):
    from uuvid.identify.thruster.steady import fit_deadzone_curve

    data = _stack(sets)
    inp = map_input
    if inp == "auto":
        inp = "speed" if data.speed is not None else "command"
    if inp == "command":
        _one_supply_voltage(sets, "--model deadzone on the command")
    sf = fit_deadzone_curve(data, input=inp)
    block = sf.block
    warn, notes = _steady_messages(sf)
    if inp == "speed":
        chain = _chain((block,), "speed", name)
        x_all = data.speed
        xlabel = "Ω [rad/s]"
    else:
        x_all = data.command - data.neutral
        xlabel = f"command − neutral [{data.command_unit}]"
        if data.neutral != 0:
            esc = offset_esc(data.neutral, float(data.command.min()), float(data.command.max()),
                             data.command_unit)
            chain = _chain((esc, block), "command", name)
            notes.append(f"block 0 is a unit-gain ESC that subtracts the neutral command "
                         f"{data.neutral:g} (its 'voltage' is command − neutral), so the file "
                         "takes raw commands")
        else:
            chain = _chain((block,), "command", name)
    m = data.measured
    x, y = x_all[m], data.thrust[m]
    yfit = block.thrust(x)
    fig = _direction_figure(f"{name}: T = c(x|x| − δ) (UUV Simulator Bessa conversion)",
                            _split_panels(x, y, yfit, np.sign(x), block.thrust), xlabel,
                            "thrust [N]")
    return FitOutcome("deadzone", chain, dict(sf.fits), sf.summary(), _rms(y - yfit), "N",
                      warn, {"map_input": inp},
                      figures=[("fit", fig, "Thrust, dead-zone conversion and residuals")],
                      notes=notes)


def _fit_table(sets, name, n_points):
    from uuvid.identify.thruster.steady import fit_table

    _one_supply_voltage(sets, "--model table")
    data = _stack(sets)
    sf = fit_table(data, n_points)
    chain = _chain((sf.block,), "command", name)
    c = data.command
    y = np.where(data.censored, 0.0, data.thrust) if data.thrust is not None else None
    yfit = sf.block.thrust(c)
    d = np.sign(c - data.neutral)
    rng = {"forward": (data.neutral, float(c.max())), "reverse": (float(c.min()), data.neutral)}
    fig = _direction_figure(f"{name}: lookup table ({len(sf.block.input_values)} knots)",
                            _split_panels(c, y, yfit, np.where(d == 0, 1, d), sf.block.thrust,
                                          xg_range=rng),
                            f"command [{data.command_unit}]", "thrust [N]")
    warn, notes = _steady_messages(sf)
    rms = _rms(y - yfit)
    return FitOutcome("table", chain, dict(sf.fits), sf.summary(), rms, "N",
                      warn, {"knots": len(sf.block.input_values)},
                      figures=[("fit", fig, "Thrust vs command, table and residuals")],
                      notes=notes, terminal_text=_table_short_text(sf, data.command_unit, rms))


#: A table with more knots than this is summarised on the terminal (the full one is in the files).
TABLE_KNOTS_SHOWN = 12


def _table_short_text(sf, command_unit: str, rms: float) -> str | None:
    """A few lines for a long lookup table: knots, ranges with units, residual, σ; ``None`` when
    the table is short enough to print whole."""
    x = np.asarray(sf.block.input_values, dtype=float)
    y = np.asarray(sf.block.output_values, dtype=float)
    if x.size <= TABLE_KNOTS_SHOWN:
        return None
    unit = {"pwm_us": "µs"}.get(command_unit, command_unit)
    se = np.array([p.stderr for p in sf.fits["all"].parameters], dtype=float)
    known = se[np.isfinite(se)]
    sig = (f"σ per entry: median {np.median(known):.3g} N, max {known.max():.3g} N"
           + (f" ({se.size - known.size} entries without repeats: σ unknown)"
              if known.size < se.size else "") if known.size else "σ unknown (no repeats)")
    ends = ", ".join(f"T({a:g})={b:.4g} N" for a, b in zip(x[:3], y[:3]))
    tail = ", ".join(f"T({a:g})={b:.4g} N" for a, b in zip(x[-3:], y[-3:]))
    return "\n".join([
        f"{sf.model}: {x.size} knots",
        f"  command {x.min():g} … {x.max():g} {unit}; thrust {y.min():.4g} … {y.max():.4g} N",
        f"  RMS residual {rms:.3g} N; {sig}",
        f"  knots: {ends}, …, {tail}",
        "  the whole table: the model file (--out-model), --json, and fit_report.txt in --report",
    ])


def _fit_physical(sets, name, supply_voltage, linear_duty):
    from uuvid.identify.thruster.physical import fit_physical

    pf = fit_physical(sets, duty_curvature=not linear_duty, emit_warnings=False)
    v = supply_voltage if supply_voltage is not None else sets[0].nominal_voltage()
    chain = pf.to_chain(v, name=name)
    model = pf.model
    e_all = []
    panels = []
    for dname, sgn in (("forward", 1), ("reverse", -1)):
        series = []
        for s in sets:
            m = s.measured & (s.direction == sgn)
            if not np.any(m):
                continue
            vs = s.supply_voltage_array()[m]
            yfit = model.thrust(s.command[m], vs)
            vn = s.nominal_voltage()
            lo, hi = ((model.neutral, float(s.command.max())) if sgn > 0 else
                      (float(s.command.min()), model.neutral))
            xg = np.linspace(lo, hi, 300)
            cm = s.censored & (s.direction == sgn)
            series.append({"x": s.command[m], "y": s.thrust[m], "yfit": yfit, "xg": xg,
                           "yg": model.thrust(xg, vn), "label": f"{s.source} ({vn:g} V)",
                           "fit_label": f"model at {vn:g} V", "xc": s.command[cm]})
        if series:
            panels.append({"title": dname, "series": series})
    for s in sets:
        m = s.measured
        e_all.append(s.thrust[m] - model.thrust(s.command[m], s.supply_voltage_array()[m]))
    fig = _direction_figure(f"{name}: physical model (ESC × supply → DC motor → K_T Ω|Ω|)",
                            panels, "command", "thrust [N]")
    extra = {"supply_voltage_V": v, "per_sheet": pf.per_sheet, "physical_model": model.as_dict()}
    warn = list(pf.fit.warnings)
    notes = [n for n in pf.notes if n not in pf.fit.warnings]
    if supply_voltage is None:
        notes.append(f"the written chain is at {v:g} V, the first file's supply voltage (the "
                     "default; --supply-voltage sets another)")
    volts = [s.nominal_voltage() for s in sets]
    if not min(volts) * 0.95 <= v <= max(volts) * 1.05:
        span = f"{min(volts):g} V" if min(volts) == max(volts) else f"{min(volts):g}–{max(volts):g} V"
        warn.append(f"supply voltage {v:g} V is outside the data's {span}: the written chain "
                    "extrapolates the motor model there, not backed by measurements")
    return FitOutcome("physical", chain, {"physical": pf.fit}, pf.summary(),
                      _rms(np.concatenate(e_all)), "N", warn, extra,
                      figures=[("fit", fig, "Thrust vs command per sheet: data, model and "
                                            "residuals per direction")],
                      notes=notes)


# ------------------------------------------------------------------------------------------------
# dynamic models
# ------------------------------------------------------------------------------------------------
def _step_start(t, u, y):
    """(final input, final output, initial slope per unit input) of a step-like record."""
    n = max(1, t.size // 10)
    u_end, y_end = float(np.mean(u[-n:])), float(np.mean(y[-n:]))
    moved = np.flatnonzero(np.abs(u - u[0]) > 1e-12 * max(1.0, abs(u_end)))
    k0 = int(moved[0]) if moved.size and u[0] != u_end else 0
    k1 = min(t.size, k0 + max(3, min(10, (t.size - k0) // 10)))
    slope = float(np.polyfit(t[k0:k1] - t[k0], y[k0:k1], 1)[0]) if k1 - k0 >= 2 else math.nan
    return u_end, y_end, slope


def _dynamic_runs(sets, model):
    from uuvid.identify.thruster.dynamic import Run

    runs = []
    for s in sets:
        s.require("time", "speed", what=f"--model {model} (give --time-col and --speed-col)")
        m = s.measured
        if not m.all():
            raise FitError(f"{s.source}: {int((~m).sum())} censored row(s) in a time series; "
                           f"--model {model} needs every sample")
        runs.append(Run(s.time, s.command - s.neutral, s.speed, "prop_speed", name=s.source))
    return runs


def _dyn_chain(sets, block_chain, name):
    """Prepend the neutral-shifting ESC when the command has a non-zero neutral."""
    s0 = sets[0]
    blocks = list(block_chain.blocks)
    notes = []
    if s0.neutral != 0:
        cmin = min(float(s.command.min()) for s in sets)
        cmax = max(float(s.command.max()) for s in sets)
        esc = offset_esc(s0.neutral, cmin, cmax, s0.command_unit)
        notes.append(f"block 0 is a unit-gain ESC that subtracts the neutral command "
                     f"{s0.neutral:g}; the dynamics were fitted on u = command − neutral")
        return _chain([esc] + blocks, "command", name), notes
    return _chain(blocks, block_chain.input_kind, name), notes


def _dynamic_figure(title, cf, ylabel):
    from uuvid.core.plots import new_figure

    n = len(cf.runs)
    fig, ax = new_figure(2, n, squeeze=False, sharex="col", height_ratios=[3, 1],
                         figsize=(max(6.0, 4.6 * n), 5.6))
    for j, r in enumerate(cf.runs):
        yhat = cf.predict(j)
        ax[0, j].plot(r.t, r.y, ".", ms=2, label="data")
        ax[0, j].plot(r.t, yhat, "-", lw=1.3, color="C1", label="fit")
        ax[0, j].set_title(r.name)
        ax[0, j].set_ylabel(ylabel)
        ax[0, j].grid(True, alpha=0.3)
        ax[0, j].legend(fontsize="small")
        ax[1, j].plot(r.t, r.y - yhat, ".", ms=2)
        ax[1, j].axhline(0.0, color="k", lw=0.8)
        ax[1, j].set_ylabel(_residual_label(ylabel))
        ax[1, j].set_xlabel("t [s]")
        ax[1, j].grid(True, alpha=0.3)
    fig.suptitle(title)
    return fig


def _dyn_outcome(model, cf, sets, name, unit, ylabel, notes=(), prepend=True):
    if prepend:
        chain, more = _dyn_chain(sets, cf.chain, name)
    else:
        chain, more = _chain(cf.chain.blocks, cf.chain.input_kind, name), []
    info = cf.fit.extra.get("runs", [])
    n = sum(r["samples"] for r in info)
    rmse = math.sqrt(sum(r["samples"] * r["rmse"] ** 2 for r in info) / n) if n else math.nan
    fig = _dynamic_figure(f"{name}: {cf.fit.model}", cf, ylabel)
    return FitOutcome(model, chain, {model: cf.fit}, cf.summary(), rmse, unit,
                      list(cf.warnings), {"runs": info},
                      figures=[("fit", fig, "Recorded and fitted response per run, with "
                                            "residuals")], notes=list(notes) + more)


def _fit_first_order(sets, name, resample):
    from uuvid.identify.thruster.dynamic import fit_first_order

    runs = _dynamic_runs(sets, "first-order")
    cf = fit_first_order(runs, resample=resample, emit_warnings=False)
    return _dyn_outcome("first-order", cf, sets, name, "rad/s", "speed [rad/s]")


def _fit_yoerger(sets, name, resample):
    from uuvid.identify.thruster.dynamic import fit_yoerger

    runs = _dynamic_runs(sets, "yoerger")
    cf = fit_yoerger(runs, resample=resample, emit_warnings=False)
    return _dyn_outcome("yoerger", cf, sets, name, "rad/s", "speed [rad/s]")


def _fit_bessa(sets, name, resample):
    from uuvid.identify.thruster.dynamic import fit_bessa

    runs = _dynamic_runs(sets, "bessa")
    u_end, y_end, slope = _step_start(np.asarray(runs[0].t), np.asarray(runs[0].u),
                                      np.asarray(runs[0].y))
    kw = {}
    if u_end and y_end and math.isfinite(slope) and slope != 0:
        jmsp = abs(u_end / slope)  # K_t = R_m = 1: ẋ(0⁺) = u/J_msp
        kw = {"jmsp": jmsp, "kv1": 0.5 * abs(u_end / y_end), "kv2": 0.5 * abs(u_end) / y_end**2}
    cf = fit_bessa(runs, resample=resample, emit_warnings=False, **kw)
    notes = ["K_t and R_m are fixed at 1 (only K_t/(R_m J_msp), K_v1/J_msp and K_v2/J_msp are "
             "identifiable from speed; see 'identifiable' in the report)"]
    out = _dyn_outcome("bessa", cf, sets, name, "rad/s", "speed [rad/s]", notes)
    out.summary_extra["identifiable"] = cf.fit.extra.get("identifiable")
    return out


def _fit_mclean(sets, name, start, resample):
    from uuvid.identify.thruster.dynamic import Run, fit_tunnel_thruster
    from uuvid.thruster.blocks import LoadCell, TunnelThruster

    tunnel = next((b for b in start.blocks if isinstance(b, TunnelThruster)), None)
    if tunnel is None:
        raise FitError(f"--start {start.name}: no tunnel_thruster block to start from")
    lc = next((b for b in start.blocks if isinstance(b, LoadCell)), None)
    channel = "measured_thrust" if lc is not None else "thrust"
    runs = []
    for s in sets:
        s.require("time", "thrust", what="--model mclean (give --time-col and --thrust-col)")
        runs.append(Run(s.time, _voltage_of(s), s.thrust, channel, name=s.source))
    cf = fit_tunnel_thruster(runs, tunnel, load_cell=lc, resample=resample, emit_warnings=False)
    notes = [f"motor constants fixed at the start model's ({start.name}); fitted α_o−α_i, "
             "β_o−β_i and K_a" + (" through its load cell (runs compared on measured_thrust)"
                                  if lc is not None else "")]
    return _dyn_outcome("mclean", cf, sets, name, "N", "thrust [N]", notes, prepend=False)


# ------------------------------------------------------------------------------------------------
# structured dynamic models: dead band, joint speed + thrust, selection by held-out level
# ------------------------------------------------------------------------------------------------
def experiments_from(sets, what: str, resample: bool = False) -> list:
    """Bench records → :class:`~uuvid.identify.thruster.dynamic_select.Experiment` (command − neutral).
    ``resample``: a record not sampled uniformly is put on a grid of its median step first
    (command held, speed and thrust linear: :func:`uuvid.identify.thruster.dynamic.validate_runs`'s
    rule), as the other dynamic fits do with ``--resample``."""
    from uuvid.identify.thruster.dynamic import UNIFORM_RTOL, _resample
    from uuvid.identify.thruster.dynamic_select import Experiment

    out = []
    for s in sets:
        s.require("time", what=f"{what} (give --time-col)")
        if s.speed is None and s.thrust is None:
            s.require("speed", what=f"{what} (give --speed-col and/or --thrust-col)")
        m = s.measured
        if not m.all():
            raise FitError(f"{s.source}: {int((~m).sum())} censored row(s) in a time series; "
                           f"{what} needs every sample")
        t, u, w, f = s.time, s.command - s.neutral, s.speed, s.thrust
        d = np.diff(t)
        if resample and d.size and np.max(np.abs(d - d.mean())) > UNIFORM_RTOL * d.mean():
            dt = float(np.median(d))
            tn, un, w = _resample(t, u, w, dt) if w is not None else (None, None, None)
            tn, un, f = _resample(t, u, f, dt) if f is not None else (tn, un, None)
            t, u = tn, un
        out.append(Experiment(t, u, w, f, name=s.source))
    return out


def _with_offset(chain, neutral: float, name: str):
    blocks = list(chain.blocks)
    blocks[0] = replace(blocks[0], offset=neutral)
    return _chain(blocks, "command", name)


def _structured_outcome(model, df, sets, name, figures, notes=(), extra=None, text_extra=""):
    s0 = sets[0]
    chain = _with_offset(df.chain, s0.neutral, name)
    main = "speed" if "speed" in df.noise else "thrust"
    info = [r for r in df.fit.extra["runs"] if r["channel"] == ("prop_speed" if main == "speed"
                                                                else "thrust")]
    n = sum(r["samples"] for r in info)
    rmse = math.sqrt(sum(r["samples"] * r["rmse"] ** 2 for r in info) / n) if n else math.nan
    more = [f"block 0 is the driver: dead band per direction around the neutral command "
            f"{s0.neutral:g} {s0.command_unit}, fitted with the dynamics"]
    if "thrust" in df.noise and "speed" in df.noise:
        more.append("speed and thrust fitted together, each weighted by its estimated noise "
                    f"(σ speed {df.noise['speed']:.3g} rad/s, thrust {df.noise['thrust']:.3g} N)")
    doc = {"runs": df.fit.extra["runs"], "noise": df.noise, "in_sample_nrmse": df.in_sample,
           "identifiable": df.identifiable or None}
    doc.update(extra or {})
    warns = list(df.fit.warnings)
    d = np.concatenate([np.sign(np.asarray(x.command, float) - x.neutral) for x in sets])
    for sgn, side, other in ((1, "forward", "reverse"), (-1, "reverse", "forward")):
        if np.any(d == sgn) and not np.any(d == -sgn):
            warns.append(f"only {side} runs (every command on one side of neutral {s0.neutral:g}): "
                         f"the {other} parameters written (dead band, thrust coefficient) are "
                         f"copies of the {side} ones or 0, not fitted — the model holds {side} "
                         f"only; record {other} runs to identify them")
    return FitOutcome(model, chain, {df.structure.name: df.fit}, df.summary() + text_extra, rmse,
                      "rad/s" if main == "speed" else "N", warns, doc, figures,
                      notes=list(notes) + more)


def _fit_structured(sets, model, name, dead_band, resample=False):
    from uuvid.identify.thruster.dynamic_select import Structure, fit_dynamics, plot_predictions

    exps = experiments_from(sets, f"--model {model}", resample)
    df = fit_dynamics(exps, Structure(model, dead_band))
    fig = plot_predictions([df.predict(e) for e in exps], f"{name}: {df.structure.name} (in sample)")
    return _structured_outcome(model, df, sets, name,
                               [("fit", fig, "Recorded and fitted speed and thrust per record, "
                                             "with the ±2σ band from the parameter covariance")])


def _fit_select(sets, name, dead_band, families=None, resample=False):
    from uuvid.identify.thruster.dynamic_select import (
        Structure,
        default_structures,
        plot_predictions,
        select_structure,
    )

    exps = experiments_from(sets, "--select", resample)
    strs = default_structures(dead_band) if not families else [Structure(f, dead_band) for f in families]
    sel = select_structure(exps, strs)
    df = sel.best
    figs = [("fit", plot_predictions([df.predict(e) for e in exps],
                                     f"{name}: {sel.chosen} (in sample, all levels)"),
             "Recorded and fitted speed and thrust per record (all levels)"),
            ("held_out", sel.plot(), "Held-out level: fitted without it, predicted at it, with "
                                     "the ±2σ band from the parameter covariance")]
    out = _structured_outcome(df.structure.family, df, sets, name, figs,
                              [f"selected {sel.chosen}: {sel.reason}"],
                              {"selection": sel.to_dict()}, "\n\n" + sel.to_text())
    out.tables.append(("selection", sel.rows, sel.columns(),
                       "Leave-one-level-out prediction NRMSE (%) per structure"))
    out.model = f"select → {df.structure.family}"
    return out


# ------------------------------------------------------------------------------------------------
# the whole job (usable without the CLI)
# ------------------------------------------------------------------------------------------------
def run_fit(paths, model: str, opts: ReadOptions, *, degree: int | None = None,
            criterion: str = "cv", map_input: str = "auto", table_points: int | None = None,
            linear_duty: bool = False, start=None, resample: bool = False,
            name: str | None = None, dead_band: bool = False, select: bool = False,
            families: list[str] | None = None, diameter: float | None = None) -> FitOutcome:
    """Read the files and fit ``model``; raises ``BenchDataError``/``FitError``/``ValueError``.

    ``select``: ignore ``model`` and pick the dynamic family by leave-one-level-out prediction;
    ``dead_band``: a dead-band driver in front of ``first-order``/``yoerger``/``bessa`` (always
    there for ``dc-motor``/``healey`` and for the joint speed + thrust fit); ``families``: the
    dynamic families ``select`` compares (default: all); ``diameter``: the propeller diameter (m)
    of ``four-quadrant``, whose Fourier order is ``degree`` (default 1)."""
    from uuvid.identify.fit import IdentifiabilityWarning
    from uuvid.identify.plausibility import bench_unit_warnings, check_bench_signs

    if select:
        if opts.fmt == "t200":
            raise FitError("--select needs time series; T200 sheets are steady sweeps")
        if not paths:
            raise FitError("no data files given")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IdentifiabilityWarning)
            sets = read_files(paths, opts)
            for s in sets:
                check_bench_signs(s)
            _check_flow_model(sets, "select")
            outcome = _fit_select(sets, name or "selected", True, families, resample)
    else:
        sets, outcome = _run_model(paths, model, opts, degree=degree, criterion=criterion,
                                   map_input=map_input, table_points=table_points,
                                   linear_duty=linear_duty, start=start, resample=resample,
                                   name=name, dead_band=dead_band, diameter=diameter)
    _require_residual_dof(outcome, model)
    # readings probably in a wrong unit (where big thrusters make an error wrong): said first
    unit_warnings = [w for s in sets for w in (*s.warnings, *bench_unit_warnings(s))]
    # thrust low for its power: a unit (kgf/lbf read as N) or a small, inefficient thruster (a
    # tunnel thruster gives as little) — a note to look at, not a warning of a wrong value
    weak = [w for s in sets for w in weak_thrust_warnings(s, opts.thrust_col)]
    if select or model in DYNAMIC:  # a steady sweep may well be logged every few seconds
        unit_warnings += _time_unit_warnings(sets)
        if any(s.current is not None for s in sets):
            unit_warnings.append(
                f"the current column (--current-col) is read but not used by "
                f"{'--select' if select else '--model ' + model}: its output error compares "
                "speed and thrust, so no electrical parameter comes from the current (a "
                "resistance written in the model is its start value); McLean's motor from speed "
                "and current: uuvid.identify.thruster.dynamic.fit_dc_motor")
    outcome.warnings = unit_warnings + list(outcome.warnings)
    # how the files were read (a unit taken from a column's header): said first
    outcome.notes = [n for s in sets for n in s.notes] + weak + list(outcome.notes)
    return outcome


#: below this median |thrust| / momentum bound of the electrical power (a 1 m² disk, see
#: :func:`uuvid.identify.plausibility.momentum_thrust_bound`) a thrust is low for its power.  The
#: ratio is about A^(1/3)·η^(2/3) (A the disk area, η electrical → jet efficiency), independent of
#: power: the Blue Robotics T200 sheets (10–20 V) give 0.06–0.08, their numbers in kgf read as N
#: 0.008 (lbf 0.017) — but McLean's AUV II tunnel thruster, small and inefficient, gives 0.009–0.012
#: in N.  No bound separates the two, so this is a note, not a warning.
MIN_THRUST_BOUND_RATIO = 0.02
#: the thrust units a low thrust may be in, with their N per unit (the likeliest first)
_SMALL_THRUST_UNITS = (("kgf", 9.80665), ("lbf", 4.4482216152605))


def weak_thrust_warnings(data, thrust_col: str | None = None) -> list[str]:
    """The lower side of :func:`uuvid.identify.plausibility.check_bench_units`: a still-water
    thrust low for its electrical power |V·I| (median |thrust| / bound under
    :data:`MIN_THRUST_BOUND_RATIO`, on the same rows) — one sentence naming the column, the ratio,
    and both explanations: a small or inefficient thruster, or kgf/lbf read as N (kgf passed
    silently).  ``run_fit`` gives it as a note."""
    from uuvid.identify.plausibility import _power_rows, momentum_thrust_bound

    pr = _power_rows(data)
    if pr is None:
        return []
    p, rows = pr
    t = np.abs(data.thrust[rows])
    ratio = float(np.median(t / momentum_thrust_bound(p[rows])))
    if not np.isfinite(ratio) or ratio >= MIN_THRUST_BOUND_RATIO or ratio <= 0:
        return []
    per_w = float(np.median(t / p[rows]))
    fits = [f"{u} (×{k:.3g}: ratio {ratio * k:.2g}, {per_w * k:.2g} N/W)"
            for u, k in _SMALL_THRUST_UNITS if MIN_THRUST_BOUND_RATIO <= ratio * k <= 1.0]
    unit = (("thrust in " + " or ".join(fits) + " read as N (then give --thrust-unit "
             + fits[0].split()[0] + ")") if fits else
            "a thrust column in another unit (--thrust-unit N | kgf | lbf | ozf | g), or current "
            "and voltage not in A and V")
    src = f"{data.source}: " if data.source else ""
    col = f"column {thrust_col!r}" if thrust_col else "the thrust column"
    return [f"{src}thrust low for its electrical power: {col}, read in N, gives a median "
            f"{per_w:.3g} N/W over the {int(rows.sum())} still-water rows above 25 % of the "
            f"largest power, {ratio:.2g} of the momentum-theory bound for a 1 m² disk (a T200 at "
            f"10–20 V gives 0.06–0.08, about 0.1–0.2 N/W) — a small or inefficient thruster (a "
            f"tunnel thruster gives ≈ 0.01), or {unit}?"]


#: a bench time series sampled coarser than this (s) cannot show a thruster's dynamics (tenths of
#: a second): the time column is probably in ms
MAX_BENCH_STEP_S = 0.5


def _time_unit_warnings(sets) -> list[str]:
    """One sentence per time series whose median step exceeds :data:`MAX_BENCH_STEP_S` (a time in
    ms read as s made a 62.5 s thruster time constant from 5 s samples, silently)."""
    out = []
    for s in sets:
        t = getattr(s, "time", None)
        if t is None or np.size(t) < 3:
            continue
        d = np.diff(np.asarray(t, float))
        d = d[np.isfinite(d) & (d > 0)]
        if d.size and float(np.median(d)) > MAX_BENCH_STEP_S:
            out.append(f"{s.source or 'bench data'}: samples {float(np.median(d)):.4g} s apart "
                       f"(median step, over {MAX_BENCH_STEP_S:g} s): a thruster responds within "
                       "tenths of a second, so its dynamics cannot show — is the time column in "
                       "ms? (expected seconds: divide it by 1000)")
    return out


def _require_residual_dof(outcome, model: str) -> None:
    """A fit with no more samples than free parameters is no identification: it passes through
    its points, its σ is undefined and nothing in the data checks it (a one-row file gave a
    model with RMSE 0).  A lookup table interpolates its points by design and is exempt."""
    if model == "table":
        return
    for label, f in (outcome.fits or {}).items():
        n, p = int(getattr(f, "n_samples", 0)), int(getattr(f, "n_free", 0))
        if p > 0 and n <= p:
            raise FitError(f"{label}: {n} usable sample(s) for {p} free parameter(s): the fit "
                           "passes through its points and nothing checks it (σ undefined); "
                           f"need at least {p + 1} — more rows, or a model with fewer parameters")


def _run_model(paths, model: str, opts: ReadOptions, *, degree, criterion, map_input,
               table_points, linear_duty, start, resample, name, dead_band, diameter):
    """:func:`run_fit` of one ``model`` (not ``--select``): ``(sets read, outcome)``."""
    from uuvid.identify.fit import IdentifiabilityWarning
    from uuvid.identify.plausibility import check_bench_signs

    if model not in MODELS:
        raise FitError(f"--model: expected one of {', '.join(MODELS)}, got {model!r}")
    if not paths:
        raise FitError("no data files given")
    if degree is not None and model not in ("polynomial", "four-quadrant"):
        raise FitError("--degree applies to --model polynomial (and four-quadrant: its Fourier "
                       "order) only")
    if diameter is not None and model != "four-quadrant":
        raise FitError("--diameter applies to --model four-quadrant only")
    if degree is not None and model == "four-quadrant" and not 0 <= degree <= 8:
        raise FitError(f"--degree (Fourier order) must be between 0 and 8, got {degree}")
    if degree is not None and model == "polynomial" and not 1 <= degree <= 12:
        raise FitError(f"--degree must be between 1 and 12, got {degree}")
    if model in DYNAMIC and opts.fmt == "t200":
        raise FitError(f"--model {model} needs time series; T200 sheets are steady sweeps")
    sets = read_files(paths, opts)
    for s in sets:
        check_bench_signs(s)
    _check_flow_model(sets, model)
    name = name or model
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)  # they are in the fit's warnings
        if model in STRUCTURED and (dead_band or model in ("dc-motor", "healey")
                                    or any(s.thrust is not None for s in sets)):
            return sets, _fit_structured(sets, model, name, True, resample)
        fitters = {
            "quadratic": lambda: _fit_quadratic(sets, name),
            "four-quadrant": lambda: _fit_inflow(_stack(sets), name, model, diameter, degree),
            "cv": lambda: _fit_cv(sets, name),
            "polynomial": lambda: _fit_polynomial(sets, name, degree, criterion),
            "deadzone": lambda: _fit_deadzone(sets, name, map_input),
            "table": lambda: _fit_table(sets, name, table_points),
            "physical": lambda: _fit_physical(sets, name, opts.supply_voltage, linear_duty),
            "first-order": lambda: _fit_first_order(sets, name, resample),
            "yoerger": lambda: _fit_yoerger(sets, name, resample),
            "bessa": lambda: _fit_bessa(sets, name, resample),
        }
        if model in fitters:
            return sets, _record_fit_voltages(sets, fitters[model]())
        if start is None:
            from uuvid.thruster.presets import auv2_rig_chain

            start = auv2_rig_chain()
        return sets, _fit_mclean(sets, name, start, resample)


def _record_fit_voltages(sets, outcome: FitOutcome) -> FitOutcome:
    """The supply voltages of the data (a voltage column, or --supply-voltage) recorded in the
    chain (``fit_supply_voltages`` of its model file), so predict and export can say whether a
    supply asked of the model is one it was fitted at; the written ESC's own voltage is one
    value, the first file's, whatever the sheets were."""
    import dataclasses

    volts = sorted({round(s.nominal_voltage(), 2) for s in sets if s.supply_voltage is not None})
    if volts and all(math.isfinite(v) and v > 0 for v in volts):
        outcome.chain = dataclasses.replace(outcome.chain, fit_supply_voltages=tuple(volts))
    return outcome


def _check_flow_model(sets, model: str) -> None:
    """A model that ignores the water speed must not average runs in a flow into a bollard map;
    ``four-quadrant`` needs the flow column."""
    if model in INFLOW:
        if model == "four-quadrant" and any(s.flow_speed is None for s in sets):
            src = next(s.source for s in sets if s.flow_speed is None)
            raise FitError(f"{src}: --model four-quadrant needs a flow_speed column (water speed "
                           "through the propeller, m/s; --flow-speed-col names another)")
        return
    for s in sets:
        if s.flow_speed is not None and np.any(s.flow_speed != 0):
            i = int(np.flatnonzero(s.flow_speed != 0)[0])
            raise FitError(f"{s.source}: column {s.flow_column!r}, data row {i + 1}: water speed "
                           f"{s.flow_speed[i]:g} m/s, but "
                           f"{'--select' if model == 'select' else '--model ' + model} does not "
                           "model the "
                           f"water speed. Use --model {' or '.join(INFLOW)}, or keep only the "
                           "still-water rows")


def summary(outcome: FitOutcome, out: Path | None, report: Path | None) -> dict:
    doc = {"model": outcome.model, "out": str(out) if out is not None else None,
           "parameters": outcome.parameters(),
           "rmse": outcome.rmse, "rmse_unit": outcome.rmse_unit,
           "warnings": list(outcome.warnings), "notes": list(outcome.notes),
           "chain": outcome.chain.name,
           "signals": list(outcome.chain.signal_kinds)}
    if len(outcome.fits) == 1:  # one estimator: its covariance, in the order of "parameters"
        (fit,) = outcome.fits.values()
        doc["covariance"] = np.asarray(fit.covariance, dtype=float).tolist()
    for k, v in outcome.summary_extra.items():
        if v is not None:
            doc[k] = v
    if report is not None:
        doc["report"] = str(report / "index.html")
    return doc


def _csv_text(rows: list[dict], columns: list[str]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: r.get(k) for k in columns})
    return buf.getvalue()


def _add_pre(rep, text: str) -> None:
    """Preformatted text (the fit report keeps its column alignment)."""
    add = getattr(rep, "add_preformatted", None)
    if add is not None:
        add(text)
    else:  # Report has no public <pre> block yet
        import html

        rep._blocks.append(f"<pre>{html.escape(text)}</pre>")


def write_report(outcome: FitOutcome, doc: dict, folder: Path, sources: list[str]) -> Path:
    """Plots (PNG), parameter and degree tables (CSV), the fit report text, summary.json and an
    ``index.html`` embedding all of it."""
    from uuvid.core.atomic import atomic_write_json, atomic_write_text
    from uuvid.core.html import Report
    from uuvid.core.plots import save_figure
    from uuvid.thruster.modelfile import chain_to_dict

    folder.mkdir(parents=True, exist_ok=True)
    rep = Report(f"uuvid thruster fit — {outcome.model} ({outcome.chain.name})")
    rep.add_paragraph((f"Data: {', '.join(sources)}.  " if sources else "")
                      + (f"Model file: {doc['out']}.  " if doc.get("out") else "")
                      + f"RMSE {outcome.rmse:.4g} {outcome.rmse_unit}.")
    pcols = ["fit", "parameter", "estimate", "sigma", "percentile_error_%", "significant", "unit",
             "at_bound"]
    prow = outcome.parameter_rows()
    atomic_write_text(folder / "parameters.csv", _csv_text(prow, pcols))
    rep.add_heading("Parameters")
    rep.add_table(prow, pcols, caption="Estimates with standard errors σ and percentile errors "
                                       "100σ/|θ| (Caccia et al. 2000: > 51.02 % is not "
                                       "significant at 95 %)", float_fmt="{:.5g}")
    if outcome.warnings:
        rep.add_heading("Warnings")
        rep.add_paragraph("\n".join(outcome.warnings))
    if outcome.notes:
        rep.add_heading("Notes")
        rep.add_paragraph("\n".join(outcome.notes))
    rep.add_heading("Fit")
    for stem, fig, caption in outcome.figures:
        png = save_figure(fig, folder / f"{stem}.png")
        rep.add_figure(png, caption=caption)
    for stem, rows, cols, caption in outcome.tables:
        atomic_write_text(folder / f"{stem}.csv", _csv_text(rows, cols))
        rep.add_table(rows, cols, caption=caption)
    atomic_write_text(folder / "fit_report.txt", outcome.report_text + "\n")
    rep.add_heading("Fit report")
    _add_pre(rep, outcome.report_text)
    rep.add_heading("Model file")
    rep.add_json(chain_to_dict(outcome.chain), caption=doc.get("out") or outcome.chain.name)
    atomic_write_json(folder / "summary.json", doc)
    return rep.write(folder)


# ------------------------------------------------------------------------------------------------
# replay of a logged command through a model
# ------------------------------------------------------------------------------------------------
@dataclass
class Replay(Result):
    """A model driven by logged commands: predicted vs measured speed and thrust per record."""

    chain_name: str
    predictions: list  # dynamic_select.Prediction per record
    notes: tuple = ()  # how the files were read (a unit taken from a column's header…)

    def rows(self) -> list[dict]:
        return [r for p in self.predictions for r in p.rows()]

    report_title = "Thruster replay"

    def to_dict(self) -> dict:
        return jsonable({"model": self.chain_name, "records": self.rows(),
                         "nrmse_definition": "RMSE / (max − min) of the measured channel",
                         **({"notes": list(self.notes)} if self.notes else {})})

    def summary(self) -> str:
        return self.to_text()

    def plot(self):
        """Measured and predicted speed and thrust per record."""
        from uuvid.identify.thruster.dynamic_select import plot_predictions

        return plot_predictions(self.predictions, f"{self.chain_name}: logged command replayed")

    def _report_into(self, folder) -> Path:
        """:meth:`write` plus ``summary.txt`` and ``result.json``; returns ``index.html``."""
        index = self.write(folder)
        self.write_basics(folder)
        return index

    def to_text(self) -> str:
        lines = [f"{self.chain_name}: replayed logged commands (NRMSE = RMSE / measured range)"]
        lines += [f"  {r['record']:<30} {r['channel']:<7} NRMSE {r['nrmse_%']:7.2f} %"
                  for r in self.rows()]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)

    def write(self, folder: Path) -> Path:
        """``<record>.csv`` (time, command, measured, predicted), ``replay.png``,
        ``summary.json`` and ``index.html``."""
        from uuvid.core.atomic import atomic_write_json, atomic_write_text
        from uuvid.core.html import Report
        from uuvid.core.plots import save_figure

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        rep = Report(f"uuvid thruster replay — {self.chain_name}")
        for k, p in enumerate(self.predictions):
            stem = Path(p.experiment.name).stem or f"record{k}"
            atomic_write_text(folder / f"{stem}.predicted.csv", p.to_csv_text())
        png = save_figure(self.plot(), folder / "replay.png")
        rep.add_table(self.rows(), ["record", "level", "channel", "nrmse_%"],
                      caption="NRMSE per record and channel (RMSE / measured range)")
        rep.add_figure(png, caption="Measured (dots) and predicted (line) speed and thrust")
        atomic_write_json(folder / "summary.json", self.to_dict())
        return rep.write(folder)


def replay_files(chain, paths, opts: ReadOptions) -> Replay:
    """Drive ``chain`` with the command logged in each file; compare with its speed/thrust.

    A chain whose input is the voltage gets the command as voltage (``--command-unit volts``, or
    duty × supply); a command chain gets the raw command (its driver holds the neutral)."""
    from uuvid.identify.thruster.dynamic_select import predict_chain

    if chain.input_kind == "speed":
        raise FitError(f"{chain.name}: the model's input is the propeller speed; replay needs a "
                       "model driven by the command or the voltage")
    sets = read_files(paths, opts)  # checks the options (a finite --neutral…) first
    if chain.input_kind == "command" and opts.neutral is not None:
        held = float(getattr(chain.blocks[0], "neutral", 0.0))
        if abs(float(opts.neutral) - held) > 1e-9 * max(1.0, abs(held)):
            raise FitError(f"--neutral {opts.neutral:g}: {chain.name} takes the raw command and "
                           f"its first block holds the neutral command {held:g}, so the option "
                           "would be ignored: expected no --neutral (or the model's own), or a "
                           "model file whose driver has the neutral you mean")
    preds = []
    for s, e in zip(sets, experiments_from(sets, "replay")):
        u = _voltage_of(s) if chain.input_kind == "voltage" else s.command
        preds.append(predict_chain(chain, replace(e, u=u)))
    notes = tuple(dict.fromkeys(n for s in sets for n in getattr(s, "notes", ())))
    return Replay(chain.name, preds, notes)
