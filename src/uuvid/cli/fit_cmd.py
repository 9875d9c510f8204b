"""``uuvid thruster fit``: identify a thruster model from bench files, write the model and a report.

::

    uuvid thruster fit DATA... --model KIND --out-model MODEL.yaml [--report DIR] [--json]
    uuvid thruster fit RUNS... --select [--families first-order,healey] --out-model MODEL.yaml

Steady models (``quadratic``, ``cv``, ``polynomial``, ``deadzone``, ``table``, ``physical``) use
every row of every file; dynamic models (``first-order``, ``yoerger``, ``bessa``, ``dc-motor``,
``healey``, ``mclean``) need a time column, one run per file.  ``--select`` picks the dynamic
family by leave-one-level-out prediction.  A bench run in a flow (a ``flow_speed`` column, m/s
unless its header or ``--flow-speed-unit`` says another unit) gives ``quadratic`` the inflow
coefficient ``k_a`` of ``T = K_T Ω|Ω| − k_a|Ω|u_a`` and ``four-quadrant`` (with ``--diameter``)
the Fourier series of ``C_T*(β)``.  What each model
reads and writes is tabulated in :mod:`uuvid.identify.thruster.workflow`, which does the work;
this module only parses options.

Errors in the data (unreadable files, missing columns, bad cells, missing channels) exit with
status 2 and the :class:`~uuvid.io.bench.BenchDataError` message, which names the file, the column
and the row.
"""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path

import typer

from uuvid.cli.options import deprecated_out, renamed
from uuvid.identify.thruster.workflow import (  # noqa: F401 - re-exported for callers of the CLI module
    DYNAMIC,
    MODELS,
    STEADY,
    FitError,
    FitOutcome,
    ReadOptions,
    offset_esc,
    run_fit,
    summary,
    write_report,
)

__all__ = ["thruster_fit", "register", "run_fit", "FitOutcome", "MODELS"]


#: Largest ``--diameter`` [m]: the biggest ship propellers are about 10 m across.
MAX_PROPELLER_DIAMETER = 20.0


class ModelKind(StrEnum):
    quadratic = "quadratic"
    cv = "cv"
    polynomial = "polynomial"
    deadzone = "deadzone"
    table = "table"
    physical = "physical"
    first_order = "first-order"
    yoerger = "yoerger"
    bessa = "bessa"
    dc_motor = "dc-motor"
    healey = "healey"
    mclean = "mclean"
    four_quadrant = "four-quadrant"


class DataFormat(StrEnum):
    csv = "csv"
    t200 = "t200"


class Criterion(StrEnum):
    cv = "cv"
    bic = "bic"


class MapInput(StrEnum):
    auto = "auto"
    speed = "speed"
    command = "command"


# ------------------------------------------------------------------------------------------------
# the command
# ------------------------------------------------------------------------------------------------
def thruster_fit(
    data: list[Path] = typer.Argument(..., help="Bench files (CSV, Parquet, or T200 sheets); "
                                                "several files = several sheets/runs."),
    fmt: DataFormat = typer.Option(DataFormat.csv, "--format",
                                   help="csv: columns by name (below) | t200: Blue Robotics sheet."),
    command_col: str = typer.Option("command", "--command-col", help="Command column."),
    thrust_col: str | None = typer.Option(None, "--thrust-col", help="Thrust column."),
    thrust_unit: str | None = typer.Option(
        None, "--thrust-unit",
        help="N | kgf | lbf | ozf | g | mN | kN (default: the unit in the column's header, as in "
             "'Thrust [kgf]', else N; a unit that disagrees with the header's is an error)."),
    speed_col: str | None = typer.Option(None, "--speed-col", help="Propeller speed column."),
    speed_unit: str | None = typer.Option(
        None, "--speed-unit",
        help="rad/s | rpm | rev/s (default: the unit in the column's header, as in 'RPM [rpm]', else "
             "rad/s; a unit that disagrees with the header's is an error)."),
    current_col: str | None = typer.Option(None, "--current-col", help="Supply current column [A]."),
    voltage_col: str | None = typer.Option(None, "--voltage-col", help="Supply voltage column [V]."),
    time_col: str | None = typer.Option(None, "--time-col", help="Time column, in seconds (dynamic models)."),
    flow_speed_col: str = typer.Option(
        "auto", "--flow-speed-col",
        help="Water speed through the propeller (bench in a flow; quadratic and "
             "four-quadrant fit the inflow coefficients): auto = the column 'flow_speed' (or "
             "'flow_speed [kn]', …) if the file has one | a column name | none."),
    flow_speed_unit: str | None = typer.Option(
        None, "--flow-speed-unit",
        help="m/s | cm/s | mm/s | km/h | kn | ft/s (default: the unit in the column's header, as "
             "in 'flow [kn]', else m/s; a unit that disagrees with the header's is an error)."),
    diameter: float | None = typer.Option(None, "--diameter",
                                          help="four-quadrant: propeller diameter [m]."),
    command_unit: str = typer.Option("pwm_us", "--command-unit", help="pwm_us (or us) | duty | volts."),
    neutral: float | None = typer.Option(None, "--neutral",
                                         help="Neutral command (default 1500 µs, or 0)."),
    supply_voltage: float | None = typer.Option(
        None, "--supply-voltage",
        help="Supply voltage [V]: of the data when a file has no voltage column, and of the "
             "written chain for --model physical (default: the first file's)."),
    model: ModelKind | None = typer.Option(None, "--model", help="Model to identify."),
    select: bool = typer.Option(False, "--select",
                                help="Dynamic models: compare every family (with a dead band) by "
                                     "leave-one-level-out prediction over the files, print the "
                                     "table and write the one that extrapolates best."),
    families: str | None = typer.Option(None, "--families",
                                        help="--select: comma-separated families to compare "
                                             "(first-order,yoerger,bessa,dc-motor,healey; "
                                             "default all)."),
    dead_band: bool = typer.Option(False, "--dead-band",
                                   help="first-order/yoerger/bessa: a driver with a dead band per "
                                        "direction in front, fitted with the dynamics (always on "
                                        "with thrust records, dc-motor, healey, --select)."),
    degree: int | None = typer.Option(None, "--degree",
                                      help="polynomial: fixed degree (default: chosen by CV); "
                                           "four-quadrant: Fourier order of C_T*(β) (default 1, 2 for "
                                           "data turning both ways)."),
    criterion: Criterion = typer.Option(Criterion.cv, "--criterion",
                                        help="polynomial: degree rule, cv (one-SE) or bic."),
    map_input: MapInput = typer.Option(MapInput.auto, "--map-input",
                                       help="deadzone: fit on speed or command (auto: speed if "
                                            "there is a speed column)."),
    table_points: int | None = typer.Option(None, "--table-points",
                                            help="table: keep this many knots."),
    linear_duty: bool = typer.Option(False, "--linear-duty",
                                     help="physical: no ESC duty curvature."),
    start: str | None = typer.Option(None, "--start",
                                     help="mclean: model file or preset with the tunnel thruster "
                                          "(and load cell) to start from (default auv2-tunnel)."),
    resample: bool = typer.Option(False, "--resample",
                                  help="Dynamic models: put non-uniform time stamps on a uniform "
                                       "grid instead of refusing them."),
    name: str | None = typer.Option(None, "--name", help="Name of the written chain."),
    out: Path | None = typer.Option(None, "--out-model", help="Model file to write (.yaml or .toml)."),
    old_out: Path | None = deprecated_out("--out-model"),
    report: Path | None = typer.Option(None, "--report",
                                       help="Folder for plots, tables, the fit report and "
                                            "index.html."),
    json_out: bool = typer.Option(False, "--json", help="Print a summary as one JSON document."),
):
    """Identify a thruster model from bench data; write the model file and a report."""
    from uuvid.cli.common import (
        _fail,
        _load_model,
        _print_json,
        check_outputs,
        err_console,
        out_console,
    )
    from uuvid.io.bench import BenchDataError
    from uuvid.thruster.blocks import ParameterError
    from uuvid.thruster.modelfile import ModelFileError, save_chain

    out = renamed(out, "--out-model", old_out, folder_option="--report")
    # the input first, then every missing option at once (not one per run)
    gone = [str(p) for p in data if not p.exists()]
    if gone:
        _fail(f"no such bench file: {', '.join(gone)}")
    missing = []
    if out is None:
        missing.append("--out-model FILE (.yaml or .toml): the model file to write")
    if model is None and not select:
        missing.append("--model KIND (or --select to choose the dynamic model by held-out level)")
    if missing:
        _fail("give " + "; and ".join(missing))
    if out.suffix.lower() not in (".yaml", ".yml", ".toml"):
        _fail(f"--out-model {out}: the model file must end in .yaml, .yml or .toml")
    if select and model is not None:
        _fail("--select chooses the dynamic model itself: leave out --model")
    kind = "select" if select else model.value
    fams = [f.strip() for f in families.split(",") if f.strip()] if families else None
    if fams and not select:
        _fail("--families applies to --select only")
    if start is not None and kind != "mclean":
        _fail("--start applies to --model mclean only")
    start_chain = _load_model(start) if start is not None else None
    opts = ReadOptions(fmt=fmt.value, command_col=command_col, thrust_col=thrust_col,
                       speed_col=speed_col, current_col=current_col, voltage_col=voltage_col,
                       time_col=time_col, command_unit=command_unit, thrust_unit=thrust_unit,
                       speed_unit=speed_unit, supply_voltage=supply_voltage, neutral=neutral,
                       flow_speed_col=None if flow_speed_col.lower() == "none" else flow_speed_col,
                       flow_speed_unit=flow_speed_unit)
    if diameter is not None and not (math.isfinite(diameter) and diameter > 0):
        _fail(f"--diameter must be a positive length in m, got {diameter}")
    if diameter is not None and diameter > MAX_PROPELLER_DIAMETER:
        _fail(f"--diameter {diameter:g} m: larger than any ship's propeller (at most "
              f"{MAX_PROPELLER_DIAMETER:g} m); expected the propeller diameter in m (in mm?)")
    if neutral is not None and not math.isfinite(neutral):
        _fail(f"--neutral {neutral:g}: expected a finite command (default 1500 µs, or 0)")
    if supply_voltage is not None and not (math.isfinite(supply_voltage) and supply_voltage > 0):
        _fail(f"--supply-voltage must be positive, got {supply_voltage}")
    # every destination before the fit and before any is written: a failed run leaves the old files
    check_outputs(("--out-model", out, "file"), ("--report", report, "folder"))
    try:
        outcome = run_fit(data, kind, opts, degree=degree, criterion=criterion.value,
                          map_input=map_input.value, table_points=table_points,
                          linear_duty=linear_duty, start=start_chain, resample=resample,
                          name=name, dead_band=dead_band, select=select,
                          families=fams, diameter=diameter)
    except (BenchDataError, FitError, ParameterError, ModelFileError) as e:
        _fail(str(e))
    except ValueError as e:  # run validation in the dynamic fits (time grid, lengths, channels)
        _fail(f"{'--select' if select else '--model ' + kind}: {e}")
    try:
        save_chain(outcome.chain, out)
    except OSError as e:
        _fail(f"--out-model {out}: cannot write the model file ({e.strerror or e})")
    doc = summary(outcome, out, report)
    if report is not None:
        try:
            write_report(outcome, doc, report, [str(p) for p in data])
        except OSError as e:
            _fail(f"--report {report}: cannot write the report ({e.strerror or e})")
    from rich.markup import escape

    shown = "" if json_out else outcome.report_text  # said once: not again what stdout says
    for w in outcome.warnings:  # a warning the report text shows only as a note is said again
        if (w not in shown and w.split(": ", 1)[-1] not in shown) or f"note: {w}" in shown:
            err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False, soft_wrap=True)
    for n in outcome.notes:
        if n not in shown:
            err_console.print(f"note: {escape(n)}", highlight=False, soft_wrap=True)
    if json_out:
        _print_json(doc)
        return
    out_console.print(outcome.summary(), highlight=False, markup=False, soft_wrap=True)
    err_console.print(f"wrote {out}" + (f" and {report / 'index.html'}" if report else ""), markup=False)


def register(thruster_app: typer.Typer) -> None:
    """Register the command as ``<thruster_app> fit``."""
    thruster_app.command("fit")(thruster_fit)
