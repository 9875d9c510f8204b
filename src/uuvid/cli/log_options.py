"""Options shared by ``uuvid vehicle identify steady|inertia``: where the log's channels are and
how to read it (the fields of :class:`uuvid.identify.vehicle.logs.LogSpec`), plus the helpers that
turn library errors and messages into CLI output."""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path

import typer

from uuvid.identify.vehicle.logs import LogSpec


class Dof(StrEnum):
    surge = "surge"
    sway = "sway"
    heave = "heave"
    yaw = "yaw"


class LogFormat(StrEnum):
    auto = "auto"
    csv = "csv"
    parquet = "parquet"
    rosbag = "rosbag"
    ardusub = "ardusub"


class CovType(StrEnum):
    classical = "classical"
    HC0 = "HC0"
    HC3 = "HC3"
    HAC = "HAC"


class AngleUnit(StrEnum):
    deg = "deg"
    rad = "rad"


class OnDuplicate(StrEnum):
    merge = "merge"
    first = "first"
    last = "last"
    error = "error"


class TimeBase(StrEnum):
    boot = "boot"
    log = "log"


_SCALE = " A sign/scale may lead: -NAME, 2.5*NAME."

FMT = typer.Option(LogFormat.auto, "--format", help="Log format (auto: by suffix).")
TIME_COL = typer.Option("time", "--time-col",
                        help="CSV/Parquet: time column (numbers, or ISO 8601 text — detected; "
                             "without a 'time' column, 'Timestamp' (QGroundControl) is taken).")
COMMAND_COL = typer.Option("command", "--command-col",
                           help="CSV/Parquet: nominal generalized force of the DOF (applied "
                                "force/thrust in N, torque in N·m)." + _SCALE)
POSITION_COL = typer.Option("position", "--position-col",
                            help="CSV/Parquet: position (m), depth (m, down) or heading." + _SCALE)
TIME_UNIT = typer.Option("s", "--time-unit", help="s | ms | us | ns | min | datetime.")
COMMAND_UNIT = typer.Option(None, "--command-unit",
                            help="Unit of the command (N, kgf, lbf, N·m; default SI).")
POSITION_UNIT = typer.Option(None, "--position-unit",
                             help="Unit of a linear position (m, cm, mm, ft).")
ANGLE_UNIT = typer.Option(None, "--angle-unit", help="Unit of a heading (default rad).")
DELIMITER = typer.Option(None, "--delimiter", help="CSV delimiter (default: guess).")
TOPIC = typer.Option([], "--topic",
                     help="ROS bag: NAME=/topic:field for command, position, mode, ballast "
                          "(repeat); position=/imu/data:orientation.yaw takes yaw from a "
                          "quaternion." + _SCALE)
FIELD = typer.Option([], "--field",
                     help="ArduSub: NAME=MESSAGE.field for command, position, mode, ballast "
                          "(repeat); position defaults to depth (heave) / ATTITUDE yaw."
                          + _SCALE)
VEHICLE = typer.Option(None, "--vehicle",
                       help="ArduSub/ROS bag without a command channel: vehicle whose thruster "
                            "models and B turn the servo outputs (SERVO_OUTPUT_RAW, RCOU, "
                            "/mavros/rc/out) into the DOF's force.")
ON_DUPLICATE = typer.Option(OnDuplicate.merge, "--on-duplicate",
                            help="Samples sharing a time stamp (QGroundControl tlogs): merge "
                                 "(mean, reported), first, last or error.")
TIME_BASE = typer.Option(None, "--time",
                         help="boot: the vehicle's clock (ROS: header stamps; default); log: the "
                              "recorder's receive time (reads through a reboot).")
MSG_DEFS = typer.Option([], "--msg-definitions",
                        help="ROS 2 bags without embedded definitions (Humble): TYPE=FILE.msg or "
                             "…/pkg/msg/Type.msg (repeat).")
T_START = typer.Option(None, "--t-start", help="Use the log from here (s).")
T_END = typer.Option(None, "--t-end", help="Use the log up to here (s).")


def log_spec(log: Path, dof: str, fmt, time_col, command_col, position_col, mode_col,
             ballast_col, time_unit, command_unit, position_unit, angle_unit, delimiter, topic,
             fields, vehicle, on_duplicate, time_base, msg_definitions, t_start=None,
             t_end=None) -> LogSpec:
    return LogSpec(log, dof, fmt.value, time_col, command_col, position_col, mode_col,
                   ballast_col, time_unit, command_unit, position_unit,
                   angle_unit.value if angle_unit else None, delimiter, list(topic), list(fields),
                   vehicle, on_duplicate.value, time_base.value if time_base else None,
                   list(msg_definitions) or None, t_start, t_end)


def fail(msg: str):
    from uuvid.cli.common import _fail

    _fail(msg)


#: Library parameter names in messages (written in backticks) → this command line's flags.
PARAM_FLAGS = {"`settle=`": "--settle", "`min_duration=`": "--min-duration",
               "`rel_tol=`": "--rel-tol", "`tol=`": "--tol", "`threshold=`": "--threshold",
               "`open_loop_only=False`": "--all-modes", "`hac_lags=`": "--hac-lags",
               "`max_filled=`": "--max-filled", "`cov_type=`": "--cov-type"}


def flags(text: str) -> str:
    """A library message with its parameter names as this CLI's flags."""
    for k, v in PARAM_FLAGS.items():
        text = text.replace(k, v)
    return text


def msg(e: BaseException) -> str:
    if isinstance(e, KeyError) and e.args:
        return flags(str(e.args[0]))
    return flags(str(e))


def call(fn, *args, prefix: str = "", **kw):
    """``fn(*args, **kw)``, a library error becoming one CLI error line (exit status 2)."""
    import numpy as np

    try:
        return fn(*args, **kw)
    except (ValueError, KeyError, ImportError, OSError, np.linalg.LinAlgError) as e:
        fail(f"{prefix}{msg(e)}")


def print_messages(warnings, notes) -> None:
    from rich.markup import escape

    from uuvid.cli.common import err_console

    for w in warnings or []:
        err_console.print(f"[yellow]warning:[/] {escape(flags(str(w)))}", highlight=False,
                          soft_wrap=True)
    for m in notes or []:
        err_console.print(f"[yellow]note:[/] {escape(flags(str(m)))}", highlight=False,
                          soft_wrap=True)


def params_table(title: str, params: dict):
    from rich.markup import escape
    from rich.table import Table

    t = Table(title=escape(title))
    for c in ("parameter", "estimate", "σ", "unit", "% error", "significant"):
        t.add_column(c)
    for n, r in params.items():
        t.add_row(escape(n), _num(r.get("estimate"), ".5g"), _num(r.get("sigma"), ".3g"),
                  escape(r.get("unit") or ""), _num(r.get("percentile_error"), ".1f"),
                  "yes" if r.get("significant") else "no")
    return t


def _num(x, fmt: str) -> str:
    """A table cell: "—" for a value the fit could not give (None in JSON, NaN/inf)."""
    try:
        return "—" if x is None or not math.isfinite(x) else format(x, fmt)
    except TypeError:
        return str(x)


def check_write_back(write_vehicle, out_vehicle) -> None:
    if (write_vehicle is None) != (out_vehicle is None):
        fail("--write-vehicle and --out-vehicle go together (the vehicle to start from and the "
             "new file to write)")


def outputs(res, *, report, write_vehicle, out_vehicle, key, mode=None) -> dict:
    """The result's JSON document, after writing the report folder and the vehicle file asked
    for (their paths added to the document)."""
    doc = res.to_dict()
    if report is not None:
        try:
            res.report(report)
        except OSError as e:
            fail(f"--report {report}: cannot write the report ({e.strerror or e})")
        doc["report"] = str(report / "index.html")
    if write_vehicle is not None:
        doc["identified"] = res.identified(key, mode)
        doc["vehicle_out"] = call(res.write_vehicle, write_vehicle, out_vehicle, key, mode)
    return doc


def print_tail(doc: dict, warnings, notes) -> None:
    from uuvid.cli.common import err_console

    print_messages(warnings, notes)
    if doc.get("report"):
        err_console.print(f"report: {doc['report']}", markup=False)
    if doc.get("vehicle_out"):
        err_console.print(f"wrote {doc['vehicle_out']}", markup=False)
