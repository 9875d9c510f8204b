"""``uuvid vehicle identify inertia``: inertia from a sine experiment (Caccia et al. 2000,
eqs. 15–19) — options in, :func:`uuvid.identify.vehicle.procedures.identify_inertia`, results out."""

from __future__ import annotations

from pathlib import Path

import typer

from uuvid.cli import log_options as lo
from uuvid.cli.log_options import AngleUnit, CovType, Dof, LogFormat, OnDuplicate, TimeBase

__all__ = ["identify_inertia"]


def _resample(text: str) -> str | float:
    if text in ("auto", "off"):
        return text
    try:
        v = float(text)
    except ValueError:
        lo.fail(f"--resample: expected auto, off or a step in seconds, got {text!r}")
    if not v > 0:
        lo.fail(f"--resample: the step must be > 0 s, got {text!r}")
    return v


def identify_inertia(
    log: Path = typer.Argument(..., help="Log of a sine experiment (CSV/Parquet, ROS bag, ArduSub)."),
    dof: Dof = typer.Option(..., "--dof", help="The degree of freedom."),
    drag: str | None = typer.Option(None, "--drag",
                                    help="Drag: the JSON of `identify steady --json`, or a vehicle "
                                         "file/preset (its one_dof model of the DOF)."),
    k: float | None = typer.Option(None, "--k", help="Linear drag (instead of --drag)."),
    kq: float | None = typer.Option(None, "--kq", help="Quadratic drag (with --k; default 0)."),
    one_dof: str | None = typer.Option(None, "--one-dof",
                                       help="With a vehicle --drag: which one_dof model."),
    mode: str | None = typer.Option(None, "--mode",
                                    help="Thrust-mapping mode of the experiment (its η from "
                                         "--drag)."),
    eta: str | None = typer.Option(None, "--eta",
                                   help="Installation coefficient: η or η₊,η₋ (default: from "
                                        "--drag/--mode, else 1 = open water)."),
    fmt: LogFormat = lo.FMT,
    time_col: str = lo.TIME_COL,
    command_col: str = lo.COMMAND_COL,
    position_col: str = lo.POSITION_COL,
    time_unit: str = lo.TIME_UNIT,
    command_unit: str | None = lo.COMMAND_UNIT,
    position_unit: str | None = lo.POSITION_UNIT,
    angle_unit: AngleUnit | None = lo.ANGLE_UNIT,
    delimiter: str | None = lo.DELIMITER,
    topic: list[str] = lo.TOPIC,
    fields: list[str] = lo.FIELD,
    vehicle: str | None = lo.VEHICLE,
    on_duplicate: OnDuplicate = lo.ON_DUPLICATE,
    time_base: TimeBase | None = lo.TIME_BASE,
    msg_definitions: list[str] = lo.MSG_DEFS,
    window: int | None = typer.Option(None, "--window",
                                      help="Savitzky–Golay window (points) (default 41 yaw, 21 "
                                           "linear: the paper's)."),
    order: int = typer.Option(4, "--order", help="Savitzky–Golay order (the paper's 4)."),
    cov_type: CovType = typer.Option(CovType.HAC, "--cov-type",
                                     help="HAC (default: the integrated regression's residuals are "
                                          "autocorrelated) or classical/HC0/HC3."),
    hac_lags: int | None = typer.Option(None, "--hac-lags",
                                        help="HAC bandwidth (points) (default a quarter period)."),
    omega: float | None = typer.Option(None, "--omega",
                                       help="Sine frequency (rad/s) (default: detected)."),
    t_start: float | None = lo.T_START,
    t_end: float | None = lo.T_END,
    resample: str = typer.Option("auto", "--resample",
                                 help="Position grid: auto (a near-uniform but jittery record — "
                                      "an autopilot's 10 Hz attitude — is interpolated onto a "
                                      "uniform grid, with a note), off (refuse), or a step (s)."),
    no_clean: bool = typer.Option(False, "--no-clean",
                                  help="Do not flag/fill outliers and gaps of the position."),
    eiv: bool = typer.Option(False, "--eiv-correction",
                             help="Remove the S–G velocity noise from HᵀH (errors in variables)."),
    max_filled: int = typer.Option(2, "--max-filled",
                                   help="Leave out rows whose filter window holds more filled "
                                        "samples."),
    validation_log: Path | None = typer.Option(None, "--validation-log",
                                               help="Another log (same columns) to validate the "
                                                    "identified model on (NRMSE)."),
    write_vehicle: str | None = typer.Option(None, "--write-vehicle",
                                             help="Vehicle file or preset to write the inertia "
                                                  "into (added mass; with --out-vehicle)."),
    out_vehicle: Path | None = typer.Option(None, "--out-vehicle", help="The new vehicle YAML."),
    one_dof_key: str | None = typer.Option(None, "--one-dof-key",
                                           help="one_dof entry to write (default: --one-dof or "
                                                "the DOF name)."),
    json_out: bool = typer.Option(False, "--json", help="Print the results as one JSON document."),
    report: Path | None = typer.Option(None, "--report",
                                       help="Folder for plots (measured vs predicted velocity, "
                                            "phase lag) and index.html."),
):
    """Inertia from a sine experiment by the integrated regression (Caccia et al. 2000, eqs. 15–19)."""
    from uuvid.cli.common import _print_json, out_console
    from uuvid.identify.vehicle.procedures import identify_inertia as run

    lo.check_write_back(write_vehicle, out_vehicle)
    spec = lo.log_spec(log, dof.value, fmt, time_col, command_col, position_col, None, None,
                       time_unit, command_unit, position_unit, angle_unit, delimiter, topic,
                       fields, vehicle, on_duplicate, time_base, msg_definitions, t_start, t_end)
    res = lo.call(run, spec, drag=drag, k=k, k_q=kq, eta=eta, mode=mode, one_dof=one_dof,
                  window=window, order=order, cov_type=cov_type.value, hac_lags=hac_lags,
                  omega=omega, clean=not no_clean, eiv=eiv, max_filled=max_filled,
                  resample=_resample(resample), validation_log=validation_log)
    doc = lo.outputs(res, report=report, write_vehicle=write_vehicle, out_vehicle=out_vehicle,
                     key=one_dof_key, mode=mode)
    if json_out:
        _print_json(doc)
        return
    out_console.print(lo.params_table(f"{res.dof} inertia from {log.name} ({doc['n_rows']} "
                                      f"rows, {doc['cov_type']} σ)", doc["parameters"]))
    for line in res.summary().splitlines():
        if line.startswith(("phase lag", "NRMSE")):
            out_console.print(line, highlight=False, markup=False)
    lo.print_tail(doc, doc.get("warnings"), doc["notes"])
