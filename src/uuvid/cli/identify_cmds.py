"""``uuvid vehicle identify steady`` and the registration of the identification commands.

::

    uuvid vehicle identify steady LOG --dof surge|sway|heave|yaw [--mode-col mode]
          [--open-water-mode MODE | --eta-map MODE=NAME,...] [--ballast-col n] [--json]
          [--report DIR] [--write-vehicle VEHICLE --out-vehicle NEW.yaml]
    uuvid vehicle identify inertia LOG --dof yaw --drag STEADY.json|VEHICLE [--resample auto]
    uuvid vehicle design-input --k K --mass-air M --speed V [--out-file cmd.csv] [--json]
    uuvid reproduce caccia2000 [--seed 0] [--fast] [--json] [--out DIR]

**Logs** (``LOG``): CSV/Parquet with a column mapping (``--time-col``, ``--command-col`` — the
nominal generalized force of the DOF, ``--position-col`` — position (m), depth or heading,
``--mode-col``, ``--ballast-col``); ROS 1/2 bags with ``--topic NAME=/topic:field``; ArduSub
``.tlog``/``.bin`` with ``--field NAME=MESSAGE.field`` (defaults for heave and yaw; the command
from the servo outputs through ``--vehicle``).  Any mapped column, topic or field takes a sign and
a scale (``-altitude``, ``0.01*depth_cm``, ``-GLOBAL_POSITION_INT.relative_alt``).  Reading:
``--on-duplicate`` (merge by default, reported), ``--time boot|log``, ``--msg-definitions``,
``--t-start/--t-end``.  The work is done by :mod:`uuvid.identify.vehicle.logs` and
:mod:`uuvid.identify.vehicle.procedures`; this module parses options and prints.

Errors in the input (file, column, row, option) exit with status 2 and one message naming what is
wrong; ``--json`` prints exactly one JSON document on stdout, messages go to stderr.
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path

import typer

from uuvid.cli import log_options as lo
from uuvid.cli.log_options import AngleUnit, CovType, Dof, LogFormat, OnDuplicate, TimeBase

__all__ = ["register", "identify_app", "identify_steady"]


class Direction(StrEnum):
    both = "both"
    positive = "positive"
    negative = "negative"


identify_app = typer.Typer(
    no_args_is_help=True,
    help="Identify drag, installation coefficients and inertia from logs (Caccia et al. 2000).")


@identify_app.command("steady")
def identify_steady(
    log: Path = typer.Argument(..., help="CSV/Parquet file, ROS 1 .bag or ROS 2 bag directory, or "
                                         "ArduSub .tlog/.bin."),
    dof: Dof = typer.Option(..., "--dof", help="The degree of freedom the log excites."),
    fmt: LogFormat = lo.FMT,
    time_col: str = lo.TIME_COL,
    command_col: str = lo.COMMAND_COL,
    position_col: str = lo.POSITION_COL,
    mode_col: str | None = typer.Option(None, "--mode-col",
                                        help="CSV/Parquet: thrust-mapping mode label per row."),
    ballast_col: str | None = typer.Option(None, "--ballast-col",
                                           help="CSV/Parquet: number of added weights (heave, "
                                                "eq. 20: W and ΔW become parameters)."),
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
    t_start: float | None = lo.T_START,
    t_end: float | None = lo.T_END,
    all_modes: bool = typer.Option(False, "--all-modes",
                                   help="ArduSub logs: also take steady segments from closed-loop "
                                        "modes (default: MANUAL and armed only)."),
    eta_map: str | None = typer.Option(None, "--eta-map",
                                       help="MODE[+|-]=NAME,...: the installation coefficient each "
                                            "mode (and sign of φ) sees; 1/open = open water."),
    open_water_mode: list[str] = typer.Option([], "--open-water-mode",
                                              help="Mode with η = 1 (MODE, or MODE+/MODE- for one "
                                                   "sign; without --mode-col: + or -); every other "
                                                   "mode gets its own η."),
    eta_per_sign: bool = typer.Option(False, "--eta-per-sign",
                                      help="With --open-water-mode: separate η for + and − force "
                                           "in every mode."),
    settle: float = typer.Option(10.0, "--settle", help="Settling time discarded at the start of "
                                                        "each constant-command interval (s)."),
    min_duration: float = typer.Option(10.0, "--min-duration",
                                       help="Shortest steady window kept (s)."),
    tol: float = typer.Option(0.0, "--tol", help="Absolute tolerance of a constant command "
                                                  "(N or N·m, the command's unit)."),
    rel_tol: float = typer.Option(0.02, "--rel-tol", help="Relative tolerance of a constant "
                                                          "command (fraction, 0.02 = 2 %)."),
    threshold: float = typer.Option(3.5, "--threshold",
                                    help="Outlier threshold in robust scales (× the MAD-based "
                                         "σ, dimensionless)."),
    direction: Direction = typer.Option(Direction.both, "--direction",
                                        help="Keep segments moving this way (the paper fits "
                                             "forward and backward surge separately)."),
    no_quadratic: bool = typer.Option(False, "--no-quadratic", help="Fit linear drag only."),
    cov_type: CovType = typer.Option(CovType.classical, "--cov-type",
                                     help="Covariance: classical σ²(HᵀH)⁻¹ (the paper) or "
                                          "heteroscedasticity(/autocorrelation)-robust."),
    hac_lags: int | None = typer.Option(None, "--hac-lags", help="HAC bandwidth (points)."),
    no_reduce: bool = typer.Option(False, "--no-reduce",
                                   help="Keep an insignificant quadratic term (no automatic model "
                                        "reduction)."),
    write_vehicle: str | None = typer.Option(None, "--write-vehicle",
                                             help="Vehicle file or preset to write the identified "
                                                  "parameters into (with --out-vehicle)."),
    out_vehicle: Path | None = typer.Option(None, "--out-vehicle",
                                            help="The new vehicle YAML to write."),
    one_dof_key: str | None = typer.Option(None, "--one-dof-key",
                                           help="one_dof entry to write (default: the DOF name)."),
    json_out: bool = typer.Option(False, "--json", help="Print the results as one JSON document."),
    report: Path | None = typer.Option(None, "--report",
                                       help="Folder for plots (velocity vs thrust per mode, "
                                            "heave buoyancy Figs. 5/6), tables and index.html."),
):
    """Drag and installation coefficients from constant-thrust segments (Caccia et al. 2000)."""
    from uuvid.cli.common import _print_json, out_console
    from uuvid.identify.vehicle.logs import read_vehicle_log
    from uuvid.identify.vehicle.procedures import identify_steady as run

    lo.check_write_back(write_vehicle, out_vehicle)
    spec = lo.log_spec(log, dof.value, fmt, time_col, command_col, position_col, mode_col,
                       ballast_col, time_unit, command_unit, position_unit, angle_unit,
                       delimiter, topic, fields, vehicle, on_duplicate, time_base,
                       msg_definitions, t_start, t_end)
    spec.open_loop_only = not all_modes
    data = lo.call(read_vehicle_log, spec)
    res = lo.call(run, data, dof.value, settle=settle, min_duration=min_duration, tol=tol,
                  rel_tol=rel_tol, threshold=threshold, eta_map=eta_map,
                  open_water=list(open_water_mode), per_sign=eta_per_sign,
                  direction=direction.value, quadratic=not no_quadratic,
                  cov_type=cov_type.value, hac_lags=hac_lags, reduce=not no_reduce,
                  prefix="identify steady: ")
    doc = lo.outputs(res, report=report, write_vehicle=write_vehicle, out_vehicle=out_vehicle,
                     key=one_dof_key)
    if json_out:
        _print_json(doc)
        return
    fit = res.fit
    out_console.print(lo.params_table(
        f"{res.dof} drag from {log.name}: {len(fit.points)} steady segments"
        + (f", reduced to {fit.reduced_to}" if fit.reduced_to else ""), doc["parameters"]))
    r = res.result["rejections"]
    out_console.print(f"samples: {r['used']}/{r['samples']} used, {r['missing']} missing, "
                      f"{r['outliers']} outliers rejected; {len(res.result['skipped'])} segments "
                      "left out", highlight=False, markup=False)
    lo.print_tail(doc, res.warnings, res.notes)


def register(vehicle_app: typer.Typer, reproduce_app: typer.Typer) -> None:
    """Add ``reproduce caccia2000``, ``vehicle identify steady|inertia`` and ``vehicle
    design-input``."""
    from uuvid.cli.design_cmds import design_input, reproduce_caccia2000
    from uuvid.cli.dive_cmds import register as register_dive

    reproduce_app.command("caccia2000")(reproduce_caccia2000)
    vehicle_app.add_typer(identify_app, name="identify")
    register_dive(vehicle_app, identify_app)
    vehicle_app.command("design-input")(design_input)


def _register_inertia() -> None:
    from uuvid.cli.inertia_cmd import identify_inertia

    identify_app.command("inertia")(identify_inertia)


_register_inertia()
