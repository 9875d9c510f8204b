"""``uuvid log inspect`` / ``uuvid log export``: ArduSub logs read right (thin shell over
:mod:`uuvid.io.ardusub`)."""

from __future__ import annotations

from pathlib import Path

import typer

from uuvid.cli.options import deprecated_out, renamed

log_app = typer.Typer(no_args_is_help=True,
                      help="ArduSub logs (.BIN dataflash, .tlog telemetry): inspect and export.")


def _fail(msg: str):
    from uuvid.cli.common import _fail as fail

    fail(msg)


@log_app.command("inspect")
def inspect_cmd(
    log: Path = typer.Argument(..., help="ArduSub .BIN/.log (dataflash) or .tlog (telemetry)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON document."),
    params: Path | None = typer.Option(None, "--params", help="Parameter file (QGroundControl/"
                                       "BlueOS) completing or overriding the log's parameters."),
):
    """Format, senders and clocks, messages, vehicle configuration, depth source, modes."""
    from uuvid.cli.common import _print_json, out_console
    from uuvid.io.ardusub import inspect_log

    try:
        res = inspect_log(log, params=params)
    except (ValueError, ImportError) as e:
        _fail(str(e))
    if json_out:
        _print_json(res.to_dict())
    else:
        out_console.print(res.summary(), highlight=False, markup=False, soft_wrap=True)


@log_app.command("export")
def export_cmd(
    log: Path = typer.Argument(..., help="ArduSub .BIN/.log (dataflash) or .tlog (telemetry)."),
    out: Path | None = typer.Option(None, "--out-file", help="FILE.csv (with FILE.csv.json "
                                    "provenance) or FILE.parquet (provenance in its metadata)."),
    old_out: Path | None = deprecated_out("--out-file"),
    vehicle: str | None = typer.Option(None, "--vehicle", help="uuvid vehicle preset or file: "
                                       "checked against the log; its geometry gives the "
                                       "physical wrench."),
    thruster_model: str | None = typer.Option(None, "--thruster-model", help="Thruster model "
                                              "file or preset (t200, laidani-a2212, t200-physical) "
                                              "overriding the voltage-aware T200 model; a chain "
                                              "with an ESC follows the logged voltage."),
    dt: float | None = typer.Option(None, "--dt", help="Time step of the table [s] (default: "
                                    "the attitude interval)."),
    plot: Path | None = typer.Option(None, "--plot", help="Also save the overview figure here."),
    params: Path | None = typer.Option(None, "--params", help="Parameter file (QGroundControl/"
                                       "BlueOS) completing or overriding the log's parameters."),
    t_start: float | None = typer.Option(None, "--t-start", help="Rows from here [s, t_s of the "
                                         "whole log] (e.g. after a parameter change)."),
    t_end: float | None = typer.Option(None, "--t-end", help="Rows up to here [s, t_s of the "
                                       "whole log]."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document."),
):
    """One tidy table on one time base: depth, attitude, battery, mode, PWM, thrust, forces."""
    from uuvid.cli.common import _print_json, check_outputs, err_console, out_console
    from uuvid.io.ardusub import check_export_path, load_dive, sidecar_path

    out = renamed(out, "--out-file", old_out)
    if out is None:
        _fail("give --out-file FILE.csv or FILE.parquet: the table to write")
    if plot is not None:  # before anything is written: a bad suffix left the table behind
        from matplotlib.figure import Figure

        kinds = Figure().canvas.get_supported_filetypes()
        if plot.suffix.lstrip(".").lower() not in kinds:
            _fail(f"--plot {plot}: {plot.suffix or 'no suffix'} is no figure format; expected one "
                  f"of {', '.join('.' + k for k in sorted(kinds))}")
    try:
        check_export_path(out)  # before reading the log
    except (ValueError, ImportError) as e:
        _fail(str(e))
    side = sidecar_path(out)  # every output checked before the log is read: all or none
    check_outputs(("--out-file", out, "file"),
                  (f"--out-file {out}: its provenance file", side, "file"), ("--plot", plot, "file"))
    try:
        dive = load_dive(log, vehicle=vehicle, thruster_model=thruster_model, dt=dt,
                         params=params, t_start=t_start, t_end=t_end)
        path = _write(dive.export, out, plot)  # the figure with the table: all or none
    except (ValueError, ImportError, FileNotFoundError, KeyError) as e:
        from uuvid.cli.common import _flagged

        _fail(_flagged(str(e), {"dt": "--dt", "t_start": "--t-start", "t_end": "--t-end"})
              .replace(": dt = ", ": --dt "))
    if json_out:
        _print_json({**dive.to_dict(), "out": str(path)})
        return
    out_console.print(dive.summary(), highlight=False, markup=False, soft_wrap=True)
    side = sidecar_path(path)
    err_console.print(f"wrote {path}" + (f" and {side}" if side else "")
                      + (f"; figure {plot}" if plot is not None else ""), highlight=False,
                      soft_wrap=True, markup=False)


def _write(export, out: Path, plot: Path | None):
    """``export(out, plot=plot)``; a write the file system refuses ends the command naming the
    option and the path given (not the temporary file the write went through)."""
    try:
        return export(out, plot=plot)
    except OSError as e:
        mine = plot is not None and str(e.filename or "").endswith(plot.name)  # or its temp file
        option, path = ("--plot", plot) if mine else ("--out-file", out)
        _fail(f"{option} {path}: cannot write it ({e.strerror or e}); nothing was written")


def register(app: typer.Typer) -> None:
    app.add_typer(log_app, name="log")
