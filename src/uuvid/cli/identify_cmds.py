"""Vehicle identification from on-board sensors (Caccia, Indiveri & Veruggio 2000) on the command line.

::

    uuvid reproduce caccia2000 [--seed 0] [--fast] [--json] [--out DIR]
    uuvid vehicle identify steady LOG --dof surge|sway|heave|yaw [--mode-col mode]
          [--open-water-mode MODE | --eta-map MODE=NAME,...] [--ballast-col n] [--json]
          [--report DIR] [--write-vehicle VEHICLE --out-vehicle NEW.yaml]
    uuvid vehicle identify inertia LOG --dof yaw --drag STEADY.json|VEHICLE [--json] [--report DIR]
    uuvid vehicle design-input --k K [--kq KQ] --mass-air M --speed V [--vehicle V --mode M
          --dof D] [--out-file cmd.csv] [--json]

**Logs** (``LOG``): CSV/Parquet with a column mapping (``--time-col``, ``--command-col`` — the
nominal generalized force of the DOF (N or N·m, e.g. the thrust-mapping layer's φ), ``--position-col``
— position (m), depth or heading, ``--mode-col`` — the thrust-mapping mode label per row,
``--ballast-col`` — known number of added weights (heave, eq. 20)); rows where the command cell is
empty are not command samples, rows where the position cell is empty are not position samples (so
one file can hold a 10 Hz command and a 3.33 Hz sonar).  ROS 1/2 bags: ``--topic
command=/topic:field --topic position=/topic:field [--topic mode=... --topic ballast=...]``.
ArduSub ``.tlog``/``.bin``: ``--field name=MESSAGE.field`` with defaults for heave (depth) and yaw
(attitude); the command comes from ``--field command=...`` or, with ``--vehicle``, from the servo
outputs (servo *i* drives the vehicle file's thruster *i*, PWM → thrust through the thruster's model,
generalized force ``B T``).  Angles are converted to rad (``--angle-unit``, default rad); results
are in SI (rad/s, N·m·s/rad …).

Errors in the input (file, column, row, option) exit with status 2 and one message naming what is
wrong; ``--json`` prints exactly one JSON document on stdout, messages go to stderr.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path

import numpy as np
import typer

from uuvid.cli.options import deprecated_out, renamed

__all__ = ["register", "identify_app", "reproduce_caccia2000", "identify_steady",
           "identify_inertia", "design_input", "read_vehicle_log", "LogSpec", "LogData"]

ANGULAR = ("roll", "pitch", "yaw")


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


class Direction(StrEnum):
    both = "both"
    positive = "positive"
    negative = "negative"


class Choice(StrEnum):
    nominal = "nominal"
    robust = "robust"


identify_app = typer.Typer(
    no_args_is_help=True,
    help="Identify drag, installation coefficients and inertia from logs (Caccia et al. 2000).")


def _h():
    from uuvid.cli.app import _fail, _print_json, err_console, out_console

    return _fail, _print_json, err_console, out_console


def _fail(msg: str):
    _h()[0](msg)


def _escape(text) -> str:
    from rich.markup import escape

    return escape(str(text))


def _msg(e: BaseException) -> str:
    if isinstance(e, KeyError) and e.args:
        return str(e.args[0])
    return str(e)


# =============================================================================================
# reading logs
# =============================================================================================
@dataclass
class LogSpec:
    """Where a DOF's command, position, mode and ballast are in a log."""

    path: Path
    dof: str
    fmt: str = "auto"
    time_col: str = "time"
    command_col: str = "command"
    position_col: str = "position"
    mode_col: str | None = None
    ballast_col: str | None = None
    time_unit: str = "s"
    command_unit: str | None = None
    position_unit: str | None = None
    angle_unit: str | None = None
    delimiter: str | None = None
    topics: list[str] = field(default_factory=list)
    fields: list[str] = field(default_factory=list)
    vehicle: str | None = None


@dataclass
class LogData:
    """The command (nominal generalized force) and position series of one DOF, SI units."""

    t_cmd: np.ndarray
    command: np.ndarray
    t_pos: np.ndarray
    position: np.ndarray
    modes: list[str] | None = None
    ballast: np.ndarray | None = None
    info: dict = field(default_factory=dict)


def _detect_format(path: Path, fmt: str) -> str:
    if fmt != "auto":
        return fmt
    s = path.suffix.lower()
    if path.is_dir() or s in (".bag", ".db3", ".mcap"):
        return "rosbag"
    if s in (".tlog", ".bin"):
        return "ardusub"
    if s in (".parquet", ".pq"):
        return "parquet"
    return "csv"


def _label(v) -> str:
    if v is None:
        return ""
    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            return ""
        return str(int(v)) if float(v).is_integer() else f"{float(v):g}"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return str(v).strip()


def _parse_pairs(items, opt: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for it in items or []:
        if "=" not in it:
            raise ValueError(f"{opt}: expected name=spec, got {it!r}")
        k, v = it.split("=", 1)
        k, v = k.strip(), v.strip()
        if not k or not v:
            raise ValueError(f"{opt}: expected name=spec, got {it!r}")
        if k in out:
            raise ValueError(f"{opt}: channel {k!r} given twice")
        out[k] = v
    return out


def _position_unit(spec: LogSpec) -> str | None:
    if spec.dof in ANGULAR:
        return spec.angle_unit or spec.position_unit or "rad"
    return spec.position_unit


def _table(spec: LogSpec):
    from uuvid.io.logs import _read_csv, _read_parquet

    p = spec.path
    if p.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(p)
    return _read_csv(p, spec.delimiter, "#")


def _read_table_log(spec: LogSpec) -> LogData:
    from uuvid.io.logs import LogDataError, _find_column, read_log_csv

    columns = {"command": spec.command_col, "position": spec.position_col}
    if spec.ballast_col:
        columns["ballast"] = spec.ballast_col
    units = {}
    if spec.command_unit:
        units["command"] = spec.command_unit
    pu = _position_unit(spec)
    if pu:
        units["position"] = pu
    r = read_log_csv(spec.path, time_col=spec.time_col, columns=columns, units=units,
                     time_unit=spec.time_unit, delimiter=spec.delimiter, allow_missing=True)
    t = np.asarray(r.t, float)
    cmd = np.asarray(r["command"], float)
    rows = np.flatnonzero(np.isfinite(cmd))
    name = r.meta.get("source", spec.path.name)
    if rows.size < 2:
        raise LogDataError(f"{name}: column {r.meta['original_names']['command']!r} has "
                           f"{rows.size} command values; expected the nominal force of the DOF "
                           "on every command row")
    pos = np.asarray(r["position"], float)
    prow = np.flatnonzero(np.isfinite(pos))
    if prow.size < 5:
        raise LogDataError(f"{name}: column {r.meta['original_names']['position']!r} has "
                           f"{prow.size} position values (need at least 5)")
    tbl = None
    modes = None
    if spec.mode_col:
        tbl = _table(spec)
        col = _find_column(tbl, spec.mode_col, "the thrust-mapping mode")
        cells = tbl.cells[col]
        modes = []
        for i in rows:
            lab = _label(cells[i])
            if not lab:
                raise LogDataError(f"{tbl.where(col, int(i))}: empty mode cell on a row with a "
                                   "command; every command sample needs its thrust-mapping mode")
            modes.append(lab)
    ballast = None
    if spec.ballast_col:
        b = np.asarray(r["ballast"], float)[rows]
        bad = np.flatnonzero(~np.isfinite(b))
        if bad.size:
            tbl = tbl or _table(spec)
            col = r.meta["original_names"]["ballast"]
            raise LogDataError(f"{tbl.where(col, int(rows[bad[0]]))}: empty ballast count on a "
                               "row with a command; every command sample needs it")
        ballast = b
    info = {"source": name, "format": r.meta.get("format"), "rows": int(t.size),
            "command_samples": int(rows.size), "position_samples": int(prow.size),
            "columns": r.meta.get("original_names"), "units": r.meta.get("units"),
            "original_units": r.meta.get("original_units")}
    if spec.mode_col:
        info["columns"] = {**info["columns"], "mode": spec.mode_col}
    return LogData(t[rows], cmd[rows], t[prow], pos[prow], modes, ballast, info)


def _zoh(t_src, t):
    """Index of the sample of ``t_src`` held at each ``t`` (−1 before the first)."""
    return np.searchsorted(t_src, t, side="right") - 1


def _from_channels(out: dict, spec: LogSpec, info: dict, command=None) -> LogData:
    from uuvid.io.logs import LogDataError

    if command is None:
        c = out["command"]
        t_cmd, cmd = np.asarray(c.t, float), np.asarray(c["command"], float)
    else:
        t_cmd, cmd = command
    ok = np.isfinite(cmd)
    t_cmd, cmd = t_cmd[ok], cmd[ok]
    p = out["position"]
    t_pos, pos = np.asarray(p.t, float), np.asarray(p["position"], float)
    okp = np.isfinite(pos)
    t_pos, pos = t_pos[okp], pos[okp]
    if t_cmd.size < 2:
        raise LogDataError(f"{spec.path.name}: the command channel has {t_cmd.size} samples")
    if t_pos.size < 5:
        raise LogDataError(f"{spec.path.name}: the position channel has {t_pos.size} samples "
                           "(need at least 5)")
    notes = []
    keep = np.ones(t_cmd.size, dtype=bool)
    modes = ballast = None
    for ch in ("mode", "ballast"):
        if ch not in out:
            continue
        r = out[ch]
        ts, vs = np.asarray(r.t, float), np.asarray(r[ch], float)
        good = np.isfinite(vs)
        ts, vs = ts[good], vs[good]
        if ts.size == 0:
            raise LogDataError(f"{spec.path.name}: the {ch} channel has no samples")
        idx = _zoh(ts, t_cmd)
        before = idx < 0
        if before.any():
            notes.append(f"{int(before.sum())} command samples before the first {ch} sample "
                         "were left out")
        keep &= ~before
        vals = vs[np.clip(idx, 0, None)]
        if ch == "mode":
            modes = vals
        else:
            ballast = vals
    t_cmd, cmd = t_cmd[keep], cmd[keep]
    if modes is not None:
        modes = [_label(v) for v in modes[keep]]
    if ballast is not None:
        ballast = ballast[keep]
    info = {**info, "command_samples": int(t_cmd.size), "position_samples": int(t_pos.size)}
    if notes:
        info["notes"] = notes
    return LogData(t_cmd, cmd, t_pos, pos, modes, ballast, info)


def _check_channels(ch: dict, opt: str):
    allowed = {"command", "position", "mode", "ballast"}
    unknown = sorted(set(ch) - allowed)
    if unknown:
        raise ValueError(f"{opt}: unknown channel(s) {unknown}; use command, position, mode, "
                         "ballast")


def _read_bag_log(spec: LogSpec) -> LogData:
    from uuvid.io.logs import read_rosbag

    topics = _parse_pairs(spec.topics, "--topic")
    _check_channels(topics, "--topic")
    missing = [c for c in ("command", "position") if c not in topics]
    if missing:
        raise ValueError(f"{spec.path.name}: a ROS bag needs --topic {missing[0]}=/topic:field "
                         "(e.g. --topic command=/thrust_cmd:data --topic "
                         "position=/mavros/global_position/rel_alt:data)")
    units = {}
    if spec.command_unit:
        units["command"] = spec.command_unit
    pu = _position_unit(spec)
    if pu:
        units["position"] = pu
    out = read_rosbag(spec.path, topics, units=units, allow_missing=True)
    info = {"source": spec.path.name, "format": "rosbag", "topics": topics, "units": units}
    return _from_channels(out, spec, info)


def _servo_force(spec: LogSpec, out: dict) -> tuple[np.ndarray, np.ndarray]:
    from uuvid.io.logs import LogDataError, align
    from uuvid.vehicle.definition import load_vehicle
    from uuvid.vehicle.layout import dof_index

    try:
        v = load_vehicle(spec.vehicle)
    except (ValueError, FileNotFoundError, KeyError) as e:
        raise ValueError(f"--vehicle: {_msg(e)}") from None
    chains = []
    for j, th in enumerate(v.layout):
        try:
            c = v.thruster_chain(j)
        except KeyError as e:
            raise ValueError(_msg(e)) from None
        if c.signal_kinds[0] != "command":
            raise ValueError(f"{v.name}: thruster {th.name}'s model {c.name!r} is driven by "
                             f"{c.signal_kinds[0]}, not a PWM command: the servo outputs cannot be "
                             "turned into thrust; give --field command=MESSAGE.field")
        chains.append(c)
    names = [f"servo_{j + 1}" for j in range(len(chains))]
    al = align({n: out[n] for n in names}, "union", interp="previous")
    # steady thrust per distinct PWM value (servo outputs are whole µs), once per thruster model
    pwm = {n: np.asarray(al[n], float) for n in names}
    cache: dict = {}
    T = np.empty((len(names), al.t.size))
    for j, n in enumerate(names):
        ref = v.layout[j].model
        u, inv = np.unique(pwm[n], return_inverse=True)
        table = cache.setdefault(ref, {})
        todo = np.array([x for x in u if x not in table])
        if todo.size:
            if todo.size > 401:  # many distinct values: a 1 µs grid over their range, then interp
                grid = np.arange(math.floor(todo.min()), math.ceil(todo.max()) + 1.0)
                tg = chains[j].steady_thrust(grid)
                vals = np.interp(todo, grid, tg)
            else:
                vals = chains[j].steady_thrust(todo)
            table.update(zip(todo.tolist(), np.atleast_1d(vals).tolist()))
        T[j] = np.array([table[x] for x in u.tolist()])[inv]
    if not np.all(np.isfinite(T)):
        raise LogDataError(f"{spec.path.name}: servo outputs give non-finite thrust")
    tau = v.B @ T
    return np.asarray(al.t, float), tau[dof_index(spec.dof)]


def _read_ardusub_log(spec: LogSpec) -> LogData:
    from uuvid.io.logs import ARDUSUB_DATAFLASH_FIELDS, ARDUSUB_TLOG_FIELDS, read_ardusub

    fields = _parse_pairs(spec.fields, "--field")
    _check_channels(fields, "--field")
    tlog = spec.path.suffix.lower() == ".tlog"
    defaults = ARDUSUB_TLOG_FIELDS if tlog else ARDUSUB_DATAFLASH_FIELDS
    req: dict = dict(fields)
    if "position" not in req:
        if spec.dof == "heave":
            req["position"] = defaults["depth"]
        elif spec.dof == "yaw":
            req["position"] = defaults["yaw"]
        else:
            raise ValueError(f"{spec.path.name}: ArduSub logs carry no {spec.dof} position; give "
                             "--field position=MESSAGE.field (e.g. a positioning system's message)")
    servo = "command" not in req
    if servo:
        if not spec.vehicle:
            raise ValueError(f"{spec.path.name}: ArduSub logs record the thrusters' PWM outputs, "
                             "not the generalized force: give --vehicle (its thruster models turn "
                             "servo_1…servo_n into thrust, its B matrix into the force) or "
                             "--field command=MESSAGE.field")
        from uuvid.vehicle.definition import load_vehicle

        try:
            n = load_vehicle(spec.vehicle).layout.n
        except (ValueError, FileNotFoundError, KeyError) as e:
            raise ValueError(f"--vehicle: {_msg(e)}") from None
        for j in range(1, n + 1):
            req[f"servo_{j}"] = (f"SERVO_OUTPUT_RAW.servo{j}_raw" if tlog else f"RCOU.C{j}")
    units = {}
    if spec.command_unit and not servo:
        units["command"] = spec.command_unit
    if spec.angle_unit or spec.position_unit:
        units["position"] = _position_unit(spec)
    out = read_ardusub(spec.path, req, units=units, allow_missing=True)
    info = {"source": spec.path.name, "format": "tlog" if tlog else "dataflash",
            "fields": {k: v for k, v in req.items()}}
    cmd = _servo_force(spec, out) if servo else None
    if servo:
        info["command_from"] = (f"servo outputs through {spec.vehicle}'s thruster models and B "
                                f"({spec.dof} component)")
    return _from_channels(out, spec, info, command=cmd)


def read_vehicle_log(spec: LogSpec) -> LogData:
    """Read the command/position (mode, ballast) series of ``spec`` (raises ``ValueError`` /
    :class:`~uuvid.io.logs.LogDataError` / ``ImportError`` with a message naming file, column,
    row)."""
    p = spec.path
    if not p.exists():
        raise ValueError(f"{p}: no such log file")
    fmt = _detect_format(p, spec.fmt)
    if fmt in ("csv", "parquet"):
        if spec.topics or spec.fields:
            raise ValueError("--topic/--field apply to ROS bags and ArduSub logs, not to "
                             f"{fmt.upper()} files (use the --*-col options)")
        if p.is_dir():
            raise ValueError(f"{p}: a directory, not a CSV/Parquet file")
        return _read_table_log(spec)
    if spec.mode_col or spec.ballast_col:
        raise ValueError(f"--mode-col/--ballast-col apply to CSV/Parquet; in a {fmt} log give "
                         "--topic/--field mode=... and ballast=...")
    if fmt == "rosbag":
        if spec.fields:
            raise ValueError("--field applies to ArduSub logs; use --topic for ROS bags")
        return _read_bag_log(spec)
    if spec.topics:
        raise ValueError("--topic applies to ROS bags; use --field for ArduSub logs")
    return _read_ardusub_log(spec)


def _read_or_fail(spec: LogSpec) -> LogData:
    try:
        return read_vehicle_log(spec)
    except (ValueError, ImportError, KeyError, OSError) as e:
        _fail(_msg(e))


# =============================================================================================
# installation-coefficient map
# =============================================================================================
def _eta_name(mode: str, sign: str | None = None) -> str:
    import re

    base = re.sub(r"\W+", "_", mode).strip("_")
    parts = ["eta"] + ([base] if base else []) + ([] if sign is None else
                                                  ["pos" if sign == "+" else "neg"])
    return "_".join(parts)


def parse_eta_map(text: str) -> dict[str, str | None]:
    """``"front+=1,front-=eta_hull,all=eta_hull_prop"`` → ``{"front+": None, ...}`` (1/open/none
    = open water, η fixed to 1)."""
    import re

    out: dict[str, str | None] = {}
    for part in text.split(","):
        if not part.strip():
            continue
        if "=" not in part:
            raise ValueError(f"--eta-map: expected MODE[+|-]=NAME, got {part.strip()!r}")
        k, v = (s.strip() for s in part.split("=", 1))
        if not k:
            raise ValueError(f"--eta-map: empty mode in {part.strip()!r}")
        if v.lower() in ("1", "1.0", "open", "none", "open_water", "open-water"):
            out[k] = None
        elif re.fullmatch(r"[A-Za-z_]\w*", v):
            out[k] = v
        else:
            raise ValueError(f"--eta-map: {v!r} is not a coefficient name (letters, digits, _) "
                             "nor 1/open (open water)")
    if not out:
        raise ValueError("--eta-map is empty")
    return out


def build_eta_map(seen: dict[str, set[str]], eta_map: str | None, open_water: list[str] | None,
                  per_sign: bool, has_mode_col: bool) -> tuple[dict[str, str | None], list[str]]:
    """η map for the (mode → signs of φ) seen in the segments; returns (map, notes)."""
    notes: list[str] = []
    if eta_map:
        m = parse_eta_map(eta_map)
        known = set(seen) | {f"{k}{s}" for k, ss in seen.items() for s in ss}
        extra = sorted(k for k in m if k not in known)
        if extra:
            notes.append(f"--eta-map entries {extra} match no segment of the log")
        return m, notes
    if open_water:
        opens = set()
        for o in open_water:
            for part in o.split(","):
                if part.strip():
                    opens.add(part.strip())
        for o in sorted(opens):
            base = o[:-1] if o[-1:] in "+-" and o[:-1] in seen else o
            if base not in seen:
                raise ValueError(f"--open-water-mode {o!r}: no steady segment in that mode; modes "
                                 f"in the log's segments: {sorted(seen) or '(none)'}")
        out: dict[str, str | None] = {}
        for mode, signs in seen.items():
            split = per_sign or any(f"{mode}{s}" in opens for s in "+-")
            for s in sorted(signs):
                if mode in opens or f"{mode}{s}" in opens:
                    out[f"{mode}{s}"] = None
                else:
                    out[f"{mode}{s}"] = _eta_name(mode, s if split else None)
        return out, notes
    if not has_mode_col or set(seen) == {""}:
        notes.append("no mode column: every segment taken as open water (η = 1); give --mode-col "
                     "and --open-water-mode to identify installation coefficients")
        return {"": None}, notes
    raise ValueError(f"the log has thrust-mapping modes {sorted(seen)}: say which works in open "
                     "water (η = 1) with --open-water-mode MODE (or MODE+ / MODE- for one sign of "
                     "the force), or give --eta-map MODE=NAME,...")


# =============================================================================================
# steady identification
# =============================================================================================
_SEP = "\x1f"


def run_steady(data: LogData, dof: str, *, settle: float, min_duration: float, tol: float,
               rel_tol: float, threshold: float, eta_map: str | None,
               open_water: list[str] | None, per_sign: bool, direction: str, quadratic: bool,
               cov_type: str, hac_lags: int | None, reduce: bool, has_mode_col: bool) -> dict:
    """Segments → robust velocities → η map → :func:`fit_drag`; everything for JSON/report."""
    from uuvid.identify.segments import find_segments, segment_velocity, summarise_rejections
    from uuvid.identify.vehicle_fit import SteadyPoint, eta_label, fit_drag

    angle = dof in ANGULAR
    n = data.t_cmd.size
    modes = data.modes if data.modes is not None else [""] * n
    if data.ballast is not None:
        labels = [f"{m}{_SEP}{b!r}" for m, b in zip(modes, data.ballast.tolist())]
    else:
        labels = list(modes)
    segs = find_segments(data.t_cmd, data.command, min_duration=min_duration, settle=settle,
                         tol=tol, rel_tol=rel_tol, mode=labels)
    if not segs:
        lv = np.unique(np.round(data.command, 6))
        raise ValueError(f"no constant-command segment of at least {min_duration:g} s after "
                         f"{settle:g} s of settling in {data.info.get('source')} "
                         f"({lv.size} distinct command values over {data.t_cmd[-1] - data.t_cmd[0]:.4g}"
                         " s); lower --min-duration/--settle or raise --rel-tol")
    sign_keep = {"both": 0, "positive": 1, "negative": -1}[direction]
    fitted, skipped = [], []
    for s in segs:
        mode, _, b = (s.mode or "").partition(_SEP)
        ballast = float(b) if b else 0.0
        try:
            sv = segment_velocity(data.t_pos, data.position, s.t0, s.t1, angle=angle,
                                  angle_unit="rad", threshold=threshold)
        except ValueError as e:
            skipped.append({"segment": s.index, "mode": mode, "level": s.level, "t0": s.t0,
                            "t1": s.t1, "reason": str(e)})
            continue
        if sign_keep and np.sign(sv.velocity) != sign_keep:
            skipped.append({"segment": s.index, "mode": mode, "level": s.level, "t0": s.t0,
                            "t1": s.t1, "reason": f"velocity {sv.velocity:.4g} is not {direction} "
                                                  "(--direction)"})
            continue
        fitted.append((s, mode, ballast, sv))
    if not fitted:
        raise ValueError("no steady segment left to fit: " + "; ".join(
            f"segment {k['segment']}: {k['reason']}" for k in skipped[:5]))
    seen: dict[str, set[str]] = {}
    for s, mode, _, _ in fitted:
        seen.setdefault(mode, set()).add("+" if s.level >= 0 else "-")
    emap, notes = build_eta_map(seen, eta_map, open_water, per_sign, has_mode_col)
    pts, vels, seg_rows, rejected = [], [], [], []
    for s, mode, ballast, sv in fitted:
        try:
            et = eta_label(emap, mode, s.level)
        except KeyError as e:
            raise ValueError(f"--eta-map: {_msg(e)}") from None
        pts.append(SteadyPoint(sv.velocity, s.level, et, sv.stderr, ballast, mode, 0, s.t0, s.t1))
        vels.append(sv)
        seg_rows.append({"segment": s.index, "mode": mode, "ballast": ballast, "level": s.level,
                         "t0": s.t0, "t1": s.t1, "eta": et, "velocity": sv.velocity,
                         "velocity_stderr": sv.stderr, "relative_error": sv.relative_error,
                         "n_total": sv.n_total, "n_used": sv.n_used, "n_missing": sv.n_missing,
                         "n_outliers": sv.n_outliers, "settled": sv.settled,
                         "messages": list(sv.messages)})
        for r in sv.rejected:
            rejected.append({"segment": s.index, **r.as_dict()})
    ballast = "dW" if data.ballast is not None else None
    disturbance = "W" if dof == "heave" else "w"
    fit = fit_drag(pts, quadratic=quadratic, disturbance=disturbance, ballast=ballast,
                   cov_type=cov_type, hac_lags=hac_lags, reduce=reduce, dof=dof,
                   model=f"{dof} steady drag ({data.info.get('source')})")
    naive = None
    if dof == "heave" and fit.eta_names:
        try:
            naive = fit_drag([replace(p, eta=None) for p in pts], quadratic=quadratic,
                             disturbance=disturbance, ballast=ballast, cov_type=cov_type,
                             hac_lags=hac_lags, reduce=reduce, dof=dof,
                             model="heave, η = 1 assumed")
        except ValueError:
            naive = None
    unsettled = [r["segment"] for r in seg_rows if not r["settled"]]
    if unsettled:
        notes.append(f"segments {unsettled} had not settled (significant acceleration): their "
                     "velocities are biased; lengthen --settle")
    return {"fit": fit, "naive": naive, "points": pts, "velocities": vels, "segments": seg_rows,
            "skipped": skipped, "rejected": rejected, "eta_map": emap, "notes": notes,
            "rejections": summarise_rejections(vels), "seen": seen}


def _mode_etas(fit, emap: dict, seen: dict[str, set[str]]) -> dict[str, dict]:
    from uuvid.identify.vehicle_fit import eta_label

    out = {}
    for mode, signs in seen.items():
        d = {}
        for s in sorted(signs):
            name = eta_label(emap, mode, 1.0 if s == "+" else -1.0)
            d["pos" if s == "+" else "neg"] = fit.eta(name)
            d[("pos" if s == "+" else "neg") + "_name"] = name
        out[mode] = d
    return out


def _param_table(f) -> dict:
    return {p.name: {"estimate": p.value, "sigma": p.stderr, "unit": p.unit,
                     "percentile_error": p.percentile_error, "significant": p.significant}
            for p in f.parameters}


def _buoyancy(fit, counts) -> list[dict]:
    f = fit.fit
    if "W" not in f.names:
        return []
    C = f.covariance
    iw = f.names.index("W")
    idw = f.names.index("dW") if "dW" in f.names else None
    rows = []
    for n in counts:
        est = f["W"].value + (n * f["dW"].value if idw is not None else 0.0)
        var = C[iw, iw]
        if idw is not None:
            var += n * n * C[idw, idw] + 2 * n * C[iw, idw]
        rows.append({"ballast": n, "estimate": est, "sigma": math.sqrt(max(var, 0.0))})
    return rows


def steady_document(res: dict, dof: str, log: Path, data: LogData) -> dict:
    fit = res["fit"]
    f = fit.fit
    etas = _mode_etas(fit, res["eta_map"], res["seen"])
    opens = sorted({m + k for m, d in etas.items() for k, s in (("+", "pos"), ("-", "neg"))
                    if d.get(f"{s}_name", "x") is None})
    doc = {
        "command": "vehicle identify steady", "log": str(log), "dof": dof,
        "format": data.info.get("format"),
        "units": {"velocity": "rad/s" if dof in ANGULAR else "m/s",
                  "force": "N·m" if dof in ANGULAR else "N"},
        "parameters": _param_table(f),
        "quadratic_significant": fit.quadratic_significant,
        "linear_significant": fit.linear_significant,
        "reduced_to": fit.reduced_to, "dropped": list(fit.dropped),
        "full_parameters": _param_table(fit.full),
        "cov_type": f.extra.get("cov_type"), "sigma2": f.sigma2, "n_points": len(fit.points),
        "messages": list(fit.messages), "notes": list(fit.notes) + res["notes"],
        "eta_map": {k: v for k, v in res["eta_map"].items()},
        "model": {"dof": dof, "k": fit.k, "k_q": fit.k_q, "disturbance": fit.w,
                  "disturbance_name": fit.disturbance, "ballast": fit.ballast,
                  "drag_covariance": fit.drag_covariance().tolist(),
                  "eta": {m: {"pos": d.get("pos"), "neg": d.get("neg")} for m, d in etas.items()},
                  "open_water": opens},
        "segments": res["segments"], "skipped_segments": res["skipped"],
        "rejected": res["rejected"], "rejections": res["rejections"],
        "log_info": data.info,
    }
    if dof == "heave":
        counts = sorted({p.ballast for p in fit.points})
        doc["buoyancy"] = {"with_eta": _buoyancy(fit, counts),
                           "eta_unitary": _buoyancy(res["naive"], counts) if res["naive"] else []}
    return doc


def _steady_identified(doc: dict, dof: str, log: Path, key: str | None, mode: str | None) -> dict:
    m = doc["model"]
    p = doc["parameters"]
    lin = m["k"] if "k" in p else 0.0
    quad = m["k_q"] if "k_q" in p else 0.0
    etas = {mo: {s: v for s, v in (("+", d["pos"]), ("-", d["neg"])) if v is not None}
            for mo, d in m["eta"].items() if mo}
    if mode is None:
        full = [mo for mo, d in m["eta"].items() if mo and all(
            (f"{mo}{s}" in m["open_water"]) for s, k in (("+", "pos"), ("-", "neg"))
            if d.get(k) is not None)]
        mode = full[0] if full else next((o[:-1] for o in m["open_water"] if o[:-1]), None)
    sigma = {"linear": p.get("k", {}).get("sigma"), "quadratic": p.get("k_q", {}).get("sigma")}
    d = {"linear": lin, "quadratic": quad, "eta": etas, "disturbance": m["disturbance"],
         "sigma": {k: v for k, v in sigma.items() if v is not None}, "log": str(log),
         "method": "steady segments, Caccia et al. 2000 §III-A"
                   + (f"; reduced to {doc['reduced_to']}" if doc["reduced_to"] else "")}
    if mode:
        d["mode"] = mode
    if key:
        d["key"] = key
    return {dof: d}


def _write_back(vehicle: str | None, out_vehicle: Path | None, identified: dict, log: Path,
                command: str) -> str | None:
    if vehicle is None and out_vehicle is None:
        return None
    if vehicle is None or out_vehicle is None:
        _fail("--write-vehicle and --out-vehicle go together (the vehicle to start from and the "
              "new file to write)")
    from uuvid.vehicle.writeback import WritebackError, write_identified

    try:
        return str(write_identified(vehicle, identified, out_vehicle, log=str(log),
                                    command=command))
    except WritebackError as e:
        _fail(f"--write-vehicle: {e}")


# ---------------------------------------------------------------------------------------------
# steady report
# ---------------------------------------------------------------------------------------------
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


def write_steady_report(res: dict, doc: dict, data: LogData, dof: str, folder: Path) -> Path:
    from uuvid.io.atomic import atomic_write_json, atomic_write_text
    from uuvid.report.html import Report
    from uuvid.report.plots import new_figure, save_figure

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
        rep.add_figure(save_figure(fig, folder / "steady_fit.png"),
                       caption="Steady velocities with the fitted curves (left); net weight per "
                               "experiment with identified vs unitary η (right)")
    else:
        fig, ax = new_figure(1, 1, figsize=(8, 5))
        _plot_steady(ax, fit, res["points"], angular, False,
                     f"{dof}: LS velocity vs nominal force per mapping mode")
        rep.add_figure(save_figure(fig, folder / "steady_fit.png"),
                       caption="Velocity vs nominal force per mapping mode (±2σ) with the "
                               "identified steady-state curves")
    # the log: command, position, segment windows, rejected samples
    sc = 180 / math.pi if angular else 1.0
    fig, ax = new_figure(2, 1, figsize=(12, 6), sharex=True)
    ax[0].step(data.t_cmd, data.command, where="post", lw=0.8)
    ax[0].set_ylabel("command φ")
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
    rep.add_preformatted(fit.report(), caption="Fit report")
    atomic_write_text(folder / "fit_report.txt", fit.report() + "\n")
    atomic_write_json(folder / "summary.json", doc)
    return rep.write(folder)


def _csv_text(rows: list[dict], cols: list[str]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow(["" if r.get(c) is None else r.get(c) for c in cols])
    return buf.getvalue()


def _show_params(title: str, params: dict):
    from rich.table import Table

    t = Table(title=title)
    for c in ("parameter", "estimate", "σ", "unit", "% error", "significant"):
        t.add_column(c)
    for n, r in params.items():
        t.add_row(n, f"{r['estimate']:.5g}", f"{r['sigma']:.3g}", r.get("unit") or "",
                  f"{r['percentile_error']:.1f}", "yes" if r["significant"] else "no")
    return t


# ---------------------------------------------------------------------------------------------
# the command
# ---------------------------------------------------------------------------------------------
@identify_app.command("steady")
def identify_steady(
    log: Path = typer.Argument(..., help="CSV/Parquet file, ROS 1 .bag or ROS 2 bag directory, or "
                                         "ArduSub .tlog/.bin."),
    dof: Dof = typer.Option(..., "--dof", help="The degree of freedom the log excites."),
    fmt: LogFormat = typer.Option(LogFormat.auto, "--format", help="Log format (auto: by suffix)."),
    time_col: str = typer.Option("time", "--time-col", help="CSV/Parquet: time column."),
    command_col: str = typer.Option("command", "--command-col",
                                    help="CSV/Parquet: nominal generalized force of the DOF "
                                         "(applied force/thrust in N, torque in N·m)."),
    position_col: str = typer.Option("position", "--position-col",
                                     help="CSV/Parquet: position (m), depth (m, down) or heading."),
    mode_col: str | None = typer.Option(None, "--mode-col",
                                        help="CSV/Parquet: thrust-mapping mode label per row."),
    ballast_col: str | None = typer.Option(None, "--ballast-col",
                                           help="CSV/Parquet: number of added weights (heave, "
                                                "eq. 20: W and ΔW become parameters)."),
    time_unit: str = typer.Option("s", "--time-unit", help="s | ms | us | ns | min | datetime."),
    command_unit: str | None = typer.Option(None, "--command-unit",
                                            help="Unit of the command (N, kgf, lbf, N·m; "
                                                 "default SI)."),
    position_unit: str | None = typer.Option(None, "--position-unit",
                                             help="Unit of a linear position (m, cm, mm, ft)."),
    angle_unit: AngleUnit | None = typer.Option(None, "--angle-unit",
                                                help="Unit of a heading (default rad)."),
    delimiter: str | None = typer.Option(None, "--delimiter", help="CSV delimiter (default: guess)."),
    topic: list[str] = typer.Option([], "--topic",
                                    help="ROS bag: NAME=/topic:field for command, position, mode, "
                                         "ballast (repeat)."),
    fields: list[str] = typer.Option([], "--field",
                                     help="ArduSub: NAME=MESSAGE.field for command, position, "
                                          "mode, ballast (repeat); position defaults to depth "
                                          "(heave) / ATTITUDE yaw."),
    vehicle: str | None = typer.Option(None, "--vehicle",
                                       help="ArduSub: vehicle whose thruster models and B turn the "
                                            "servo outputs into the DOF's force."),
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
    tol: float = typer.Option(0.0, "--tol", help="Absolute tolerance of a constant command."),
    rel_tol: float = typer.Option(0.02, "--rel-tol", help="Relative tolerance of a constant "
                                                          "command."),
    threshold: float = typer.Option(3.5, "--threshold",
                                    help="Outlier threshold in robust scales."),
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
    _, _print_json, err_console, out_console = _h()
    d = dof.value
    for name, v in (("--settle", settle), ("--min-duration", min_duration)):
        if not (math.isfinite(v) and v >= 0) or (name == "--min-duration" and v <= 0):
            _fail(f"{name} must be {'> 0' if name == '--min-duration' else '>= 0'} seconds, got {v}")
    if eta_map and open_water_mode:
        _fail("give --eta-map or --open-water-mode, not both")
    if (write_vehicle is None) != (out_vehicle is None):
        _fail("--write-vehicle and --out-vehicle go together")
    spec = LogSpec(log, d, fmt.value, time_col, command_col, position_col, mode_col, ballast_col,
                   time_unit, command_unit, position_unit, angle_unit.value if angle_unit else None,
                   delimiter, list(topic), list(fields), vehicle)
    data = _read_or_fail(spec)
    if data.ballast is not None and d != "heave":
        _fail("a ballast channel (added weights, eq. 20) applies to --dof heave")
    has_modes = data.modes is not None
    try:
        res = run_steady(data, d, settle=settle, min_duration=min_duration, tol=tol,
                         rel_tol=rel_tol, threshold=threshold, eta_map=eta_map,
                         open_water=list(open_water_mode), per_sign=eta_per_sign,
                         direction=direction.value, quadratic=not no_quadratic,
                         cov_type=cov_type.value, hac_lags=hac_lags, reduce=not no_reduce,
                         has_mode_col=has_modes)
    except (ValueError, KeyError) as e:
        _fail(f"identify steady: {_msg(e)}")
    doc = steady_document(res, d, log, data)
    if report is not None:
        try:
            write_steady_report(res, doc, data, d, report)
        except OSError as e:
            _fail(f"--report {report}: cannot write the report ({e.strerror or e})")
        doc["report"] = str(report / "index.html")
    if write_vehicle is not None:
        ident = _steady_identified(doc, d, log, one_dof_key, None)
        doc["identified"] = ident
        doc["vehicle_out"] = _write_back(write_vehicle, out_vehicle, ident, log,
                                         "uuvid vehicle identify steady")
    if json_out:
        _print_json(doc)
        return
    fit = res["fit"]
    out_console.print(_show_params(f"{d} drag from {log.name}: {len(fit.points)} steady segments"
                                   + (f", reduced to {fit.reduced_to}" if fit.reduced_to else ""),
                                   doc["parameters"]))
    r = res["rejections"]
    out_console.print(f"samples: {r['used']}/{r['samples']} used, {r['missing']} missing, "
                      f"{r['outliers']} outliers rejected; {len(res['skipped'])} segments left out",
                      highlight=False)
    for m in list(fit.messages) + res["notes"]:
        err_console.print(f"[yellow]note:[/] {_escape(m)}", highlight=False, soft_wrap=True)
    if doc.get("report"):
        err_console.print(f"report: {doc['report']}")
    if doc.get("vehicle_out"):
        err_console.print(f"wrote {doc['vehicle_out']}")


# =============================================================================================
# inertia
# =============================================================================================
def load_drag(source: str, dof: str, key: str | None = None, mode: str | None = None) -> dict:
    """Drag (k, k_q, covariance, disturbance, η) for the inertia regression from the JSON of
    ``identify steady --json`` or a vehicle file/preset (its ``one_dof`` model of the DOF)."""
    p = Path(source)
    if p.suffix.lower() == ".json":
        if not p.is_file():
            raise ValueError(f"--drag {p}: no such file")
        if p.stat().st_size == 0:  # e.g. `> steady.json` from a command that failed
            raise ValueError(f"--drag {p}: the file is empty — the command that should have "
                             "written it failed or wrote nothing (use its --report DIR: "
                             "DIR/summary.json)")
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise ValueError(f"--drag {p}: not a readable JSON file ({e})") from None
        m = doc.get("model", doc) if isinstance(doc, dict) else None
        if not isinstance(m, dict) or "k" not in m:
            raise ValueError(f"--drag {p}: expected the JSON of `uuvid vehicle identify steady "
                             "--json` (a 'model' with k, k_q) or {\"k\": ..., \"k_q\": ...}")
        if m.get("dof") not in (None, dof):
            raise ValueError(f"--drag {p}: a {m['dof']} model, but --dof is {dof}")
        try:
            k, kq = float(m["k"]), float(m.get("k_q", 0.0) or 0.0)
        except (TypeError, ValueError):
            raise ValueError(f"--drag {p}: k and k_q must be numbers") from None
        cov = m.get("drag_covariance")
        etas = m.get("eta") or {}
        ep = en = 1.0
        if mode is not None:
            if mode not in etas:
                raise ValueError(f"--mode {mode!r}: not a mode of {p.name} (modes: "
                                 f"{sorted(etas) or '(none)'})")
            ep = etas[mode].get("pos") or 1.0
            en = etas[mode].get("neg") or 1.0
        return {"k": k, "k_q": kq, "cov": cov, "w": float(m.get("disturbance", 0.0) or 0.0),
                "eta": (float(ep), float(en)), "source": str(p), "key": None}
    from uuvid.vehicle.definition import load_vehicle

    try:
        v = load_vehicle(source)
    except (ValueError, FileNotFoundError, KeyError) as e:
        raise ValueError(f"--drag: {_msg(e)} (give the JSON of `identify steady --json` or a "
                         "vehicle file)") from None
    cands = {n: od for n, od in v.one_dof.items() if od.dof == dof}
    notes = []
    if key is not None:
        if key not in v.one_dof:
            raise ValueError(f"--one-dof {key!r}: {v.name} has no such one_dof model (have "
                             f"{sorted(v.one_dof)})")
        od = v.one_dof[key]
        if od.dof != dof:
            raise ValueError(f"--one-dof {key!r} is a {od.dof} model, but --dof is {dof}")
    elif len(cands) == 1:
        key, od = next(iter(cands.items()))
    elif len(cands) > 1:
        raise ValueError(f"{v.name} has several {dof} models in one_dof ({', '.join(cands)}): "
                         "pick one with --one-dof")
    else:
        from uuvid.vehicle.layout import dof_index

        i = dof_index(dof)
        od = None
        k, kq = float(v.params.linear_damping[i, i]), float(v.params.quadratic_damping[i, i])
        notes.append(f"{v.name} has no one_dof {dof} model: drag from hydrodynamics "
                     f"(k = {k:.4g}, k_q = {kq:.4g}), η = 1")
    if od is not None:
        k, kq = od.linear, od.quadratic
        ep, en = od.eta_pos, od.eta_neg
    else:
        ep = en = 1.0
    if mode is not None:
        if mode not in v.modes:
            raise ValueError(f"--mode {mode!r}: {v.name} has no such mode ({sorted(v.modes)})")
        ed = v.modes[mode].eta_dof
        ep = float(ed.get(f"{dof}+", ed.get(dof, 1.0)))
        en = float(ed.get(f"{dof}-", ed.get(dof, 1.0)))
    return {"k": float(k), "k_q": float(kq), "cov": None,
            "w": float(od.disturbance) if od is not None else 0.0, "eta": (float(ep), float(en)),
            "source": str(source), "key": key, "notes": notes}


def detect_omega(t, u) -> tuple[float | None, float]:
    """Frequency [rad/s] and amplitude of the dominant sine in ``u(t)`` (FFT peak refined by a
    least-squares sine fit), or ``None`` for the frequency when one sine explains less than 3/4
    of the command's variance or fewer than two periods are recorded (not a sine experiment)."""
    from scipy.optimize import minimize_scalar

    t = np.asarray(t, float)
    u = np.asarray(u, float)
    if t.size < 16:
        return None, 0.0
    dt = float(np.median(np.diff(t)))
    grid = np.arange(t[0], t[-1], dt)
    idx = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, t.size - 1)
    ug = u[idx]
    ug = ug - np.polyval(np.polyfit(grid - grid[0], ug, 1), grid - grid[0])
    if np.ptp(ug) <= 1e-9 * max(1.0, float(np.max(np.abs(u)))):
        return None, 0.0
    F = np.abs(np.fft.rfft(ug * np.hanning(ug.size)))
    fr = np.fft.rfftfreq(ug.size, dt)
    i = int(np.argmax(F[1:])) + 1
    lo, hi = 2 * math.pi * fr[max(i - 1, 1)], 2 * math.pi * fr[min(i + 1, fr.size - 1)]
    tt = grid - grid[0]

    def sine_fit(w):
        H = np.column_stack([np.sin(w * tt), np.cos(w * tt), np.ones_like(tt), tt])
        c, *_ = np.linalg.lstsq(H, ug, rcond=None)
        return float(np.sum((ug - H @ c) ** 2)), math.hypot(c[0], c[1])

    r = minimize_scalar(lambda w: sine_fit(w)[0], bounds=(lo, hi), method="bounded",
                        options={"xatol": 1e-9})
    w = float(r.x)
    rss, a = sine_fit(w)
    tss = float(np.sum((ug - ug.mean()) ** 2))
    # not a sine experiment: one sine explains less than 3/4 of the command's variance, or fewer
    # than two periods were recorded
    if tss <= 0 or rss > 0.25 * tss or 2 * math.pi / w > 0.5 * (grid[-1] - grid[0]):
        return None, a
    return w, a


@dataclass
class InertiaOptions:
    window: int | None = None
    order: int = 4
    cov_type: str = "HAC"
    hac_lags: int | None = None
    omega: float | None = None
    t_start: float | None = None
    t_end: float | None = None
    clean: bool = True
    eiv: bool = False
    max_filled: int = 2


def run_inertia(data: LogData, dof: str, drag: dict, opt: InertiaOptions) -> dict:
    from uuvid.identify.vehicle_fit import (
        fit_inertia,
        phase_lag,
        predicted_phase_lag,
        validate_one_dof,
    )
    from uuvid.vehicle.model import OneDofModel

    angle = dof in ANGULAR
    window = opt.window if opt.window is not None else (41 if angle else 21)
    if window % 2 == 0 or window <= opt.order:
        raise ValueError(f"--window must be an odd number of points > --order ({opt.order}), got "
                         f"{window}")
    omega, amp = (opt.omega, math.nan) if opt.omega else detect_omega(data.t_cmd, data.command)
    dt_pos = float(np.median(np.diff(data.t_pos)))
    hac = opt.hac_lags
    notes = []
    if opt.cov_type == "HAC" and hac is None and omega:
        hac = max(1, int(round(0.25 * (2 * math.pi / omega) / dt_pos)))
        notes.append(f"HAC bandwidth {hac} points = a quarter of the {2 * math.pi / omega:.4g} s "
                     "sine period")
    cov = drag.get("cov")
    fit = fit_inertia(data.t_pos, data.position, data.command, t_phi=data.t_cmd, k=drag["k"],
                      k_q=drag["k_q"], eta=drag["eta"], order=opt.order, window=window,
                      t_start=opt.t_start, t_end=opt.t_end, clean=opt.clean, angle=angle,
                      angle_unit="rad", cov_type=opt.cov_type, hac_lags=hac,
                      drag_cov=cov, velocity_noise_correction=opt.eiv,
                      max_filled=opt.max_filled)
    m = fit.mass
    out = {"fit": fit, "window": window, "hac_lags": hac, "omega": omega, "notes": notes}
    # phase lag of the velocity behind the sine input vs atan(ω m / k_L)
    tr, vr = fit.t_raw, fit.velocity_raw
    j = np.clip(np.searchsorted(data.t_cmd, tr, side="right") - 1, 0, data.t_cmd.size - 1)
    u_r = data.command[j]
    lag = None
    if omega:
        try:
            pl = phase_lag(tr, u_r, vr, omega, t_start=float(fit.t[0]), t_end=float(fit.t[-1]))
            kL = drag["k"] + 2 * drag["k_q"] * float(np.mean(np.abs(fit.velocity)))
            dt_cmd = float(np.median(np.diff(data.t_cmd)))
            lag = {"omega": omega, "period": 2 * math.pi / omega, "input_amplitude": amp,
                   "measured_deg": pl["lag_deg"], "time_lag_s": pl["time_lag_s"], "k_L": kL,
                   "predicted_deg": predicted_phase_lag(omega, m, kL) if m > 0 and kL > 0
                   else None,
                   "zoh_delay_deg": math.degrees(omega * dt_cmd / 2),
                   "note": "measured from the Savitzky–Golay velocity; includes the half-sample "
                           "delay of a zero-order-hold command (zoh_delay_deg)"}
        except ValueError as e:
            notes.append(f"phase lag not measured: {e}")
    else:
        notes.append("the command is not a sine (no dominant frequency): no phase lag; give "
                     "--omega")
    out["phase_lag"] = lag
    model = None
    if m > 0 and (drag["k"] > 0 or drag["k_q"] > 0):
        model = OneDofModel(m, max(drag["k"], 0.0), max(drag["k_q"], 0.0), drag["eta"][0],
                            drag["eta"][1], drag.get("w", 0.0), dof)
        sel = (tr >= fit.t[0]) & (tr <= fit.t[-1])
        val = validate_one_dof(model, tr[sel], data.command, vr[sel], t_phi=data.t_cmd)
        out["fit_nrmse"] = val["nrmse"]
        out["predicted"] = (tr[sel], val["predicted"], vr[sel])
    else:
        notes.append("non-positive inertia or drag: the model cannot be simulated")
    out["model"] = model
    return out


def _validate_log(model, data: LogData, dof: str, window: int) -> dict:
    from uuvid.identify.segments import clean_series, savgol_velocity
    from uuvid.identify.vehicle_fit import validate_one_dof

    angle = dof in ANGULAR
    cs = clean_series(data.t_pos, data.position, angle=angle, angle_unit="rad", window=window)
    v = savgol_velocity(cs.t, cs.x, order=4, window=window)
    val = validate_one_dof(model, cs.t, data.command, v, t_phi=data.t_cmd)
    return {"nrmse": val["nrmse"], "rmse": val["rmse"], "cleaning": cs.report(),
            "series": (cs.t, val["predicted"], v)}


def inertia_document(res: dict, dof: str, log: Path, drag: dict, data: LogData) -> dict:
    fit = res["fit"]
    f = fit.fit
    pars = _param_table(f)
    for n, r in pars.items():
        if "sigma_ls" in f.extra:
            r["sigma_regression"] = f.extra["sigma_ls"].get(n)
            r["sigma_from_drag"] = f.extra["sigma_drag"].get(n)
    doc = {"command": "vehicle identify inertia", "log": str(log), "dof": dof,
           "parameters": pars,
           "mass": {"estimate": fit.mass, "sigma": fit.mass_stderr,
                    "unit": "kg·m²" if dof in ANGULAR else "kg",
                    "m_uncorrected": f.extra.get("m_uncorrected")},
           "drag": {"k": drag["k"], "k_q": drag["k_q"], "disturbance": drag.get("w", 0.0),
                    "eta_pos": drag["eta"][0], "eta_neg": drag["eta"][1],
                    "source": drag["source"], "one_dof_key": drag.get("key"),
                    "covariance_propagated": drag.get("cov") is not None},
           "window": res["window"], "order": fit.order, "cov_type": f.extra.get("cov_type"),
           "hac_lags": res["hac_lags"], "n_rows": int(fit.t.size),
           "rows_excluded": f.extra.get("rows_excluded"), "cleaning": fit.cleaning,
           "phase_lag": res["phase_lag"], "fit_nrmse": res.get("fit_nrmse"),
           "notes": [n.replace("(give drag_cov)", "(give --drag with the JSON of identify steady)")
                     for n in fit.notes] + res["notes"] + list(drag.get("notes") or []),
           "log_info": data.info}
    return doc


def write_inertia_report(res: dict, doc: dict, data: LogData, dof: str, folder: Path,
                         validation: dict | None) -> Path:
    from uuvid.io.atomic import atomic_write_json, atomic_write_text
    from uuvid.report.html import Report
    from uuvid.report.plots import new_figure, save_figure

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
    n_rows = 3 if "predicted" in res else 2
    fig, ax = new_figure(n_rows, 1, figsize=(12, 2.8 * n_rows), sharex=True)
    ax[0].step(data.t_cmd, data.command, where="post", lw=0.8)
    ax[0].set_ylabel("command φ")
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
    rep.add_preformatted(fit.fit.report(), caption="Fit report")
    atomic_write_text(folder / "fit_report.txt", fit.fit.report() + "\n")
    atomic_write_json(folder / "summary.json", doc)
    return rep.write(folder)


@identify_app.command("inertia")
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
    fmt: LogFormat = typer.Option(LogFormat.auto, "--format", help="Log format (auto: by suffix)."),
    time_col: str = typer.Option("time", "--time-col", help="CSV/Parquet: time column."),
    command_col: str = typer.Option("command", "--command-col",
                                    help="CSV/Parquet: nominal generalized force of the DOF."),
    position_col: str = typer.Option("position", "--position-col",
                                     help="CSV/Parquet: position, depth or heading."),
    time_unit: str = typer.Option("s", "--time-unit", help="s | ms | us | ns | min | datetime."),
    command_unit: str | None = typer.Option(None, "--command-unit", help="Unit of the command."),
    position_unit: str | None = typer.Option(None, "--position-unit",
                                             help="Unit of a linear position."),
    angle_unit: AngleUnit | None = typer.Option(None, "--angle-unit",
                                                help="Unit of a heading (default rad)."),
    delimiter: str | None = typer.Option(None, "--delimiter", help="CSV delimiter."),
    topic: list[str] = typer.Option([], "--topic", help="ROS bag: NAME=/topic:field (repeat)."),
    fields: list[str] = typer.Option([], "--field", help="ArduSub: NAME=MESSAGE.field (repeat)."),
    vehicle: str | None = typer.Option(None, "--vehicle",
                                       help="ArduSub: vehicle turning servo outputs into force."),
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
    t_start: float | None = typer.Option(None, "--t-start", help="Use the log from here (s)."),
    t_end: float | None = typer.Option(None, "--t-end", help="Use the log up to here (s)."),
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
    _, _print_json, err_console, out_console = _h()
    d = dof.value
    if drag is None and k is None:
        _fail("give the drag: --drag STEADY.json|VEHICLE, or --k (and --kq)")
    if drag is not None and (k is not None or kq is not None):
        _fail("give --drag or --k/--kq, not both")
    if (write_vehicle is None) != (out_vehicle is None):
        _fail("--write-vehicle and --out-vehicle go together")
    if omega is not None and not (math.isfinite(omega) and omega > 0):
        _fail(f"--omega must be > 0 rad/s, got {omega}")
    if drag is not None:
        try:
            dr = load_drag(drag, d, one_dof, mode)
        except ValueError as e:
            _fail(str(e))
    else:
        if not (math.isfinite(k) and k >= 0) or (kq is not None and not (math.isfinite(kq)
                                                                           and kq >= 0)):
            _fail("--k and --kq must be finite and >= 0")
        if mode is not None:
            _fail("--mode needs --drag (where the mode's η comes from); give --eta instead")
        dr = {"k": float(k), "k_q": float(kq or 0.0), "cov": None, "w": 0.0, "eta": (1.0, 1.0),
              "source": "command line", "key": None}
    if eta is not None:
        try:
            ev = [float(x) for x in eta.split(",")]
            if len(ev) == 1:
                ev = ev * 2
            if len(ev) != 2 or not all(math.isfinite(x) and x > 0 for x in ev):
                raise ValueError
        except ValueError:
            _fail(f"--eta: expected η or η₊,η₋ (positive), got {eta!r}")
        dr["eta"] = (ev[0], ev[1])
    if dr["k"] <= 0 and dr["k_q"] <= 0:
        _fail(f"the drag from {dr['source']} is zero (k = {dr['k']}, k_q = {dr['k_q']})")
    spec = LogSpec(log, d, fmt.value, time_col, command_col, position_col, None, None, time_unit,
                   command_unit, position_unit, angle_unit.value if angle_unit else None,
                   delimiter, list(topic), list(fields), vehicle)
    data = _read_or_fail(spec)
    opt = InertiaOptions(window, order, cov_type.value, hac_lags, omega, t_start, t_end,
                         not no_clean, eiv, max_filled)
    try:
        res = run_inertia(data, d, dr, opt)
    except (ValueError, np.linalg.LinAlgError) as e:
        _fail(f"identify inertia: {e}")
    doc = inertia_document(res, d, log, dr, data)
    validation = None
    if validation_log is not None:
        if res["model"] is None:
            _fail("--validation-log: the identified model cannot be simulated (non-positive "
                  "inertia or drag)")
        vdata = _read_or_fail(replace(spec, path=validation_log))
        try:
            validation = _validate_log(res["model"], vdata, d, res["window"])
        except ValueError as e:
            _fail(f"--validation-log {validation_log}: {e}")
        doc["validation"] = {"log": str(validation_log), "nrmse": validation["nrmse"],
                             "rmse": validation["rmse"], "cleaning": validation["cleaning"]}
    if report is not None:
        try:
            write_inertia_report(res, doc, data, d, report, validation)
        except OSError as e:
            _fail(f"--report {report}: cannot write the report ({e.strerror or e})")
        doc["report"] = str(report / "index.html")
    if write_vehicle is not None:
        ident = {d: {"mass": res["fit"].mass, "linear": dr["k"], "quadratic": dr["k_q"],
                     "sigma": {"mass": res["fit"].mass_stderr}, "log": str(log),
                     "method": "sine experiment, integrated regression, Caccia et al. 2000 "
                               "eqs. 15–19",
                     "key": one_dof_key or dr.get("key") or d}}
        if mode is not None:
            ident[d]["mode"] = mode
            ident[d]["eta"] = {mode: {"+": dr["eta"][0], "-": dr["eta"][1]}}
        doc["identified"] = ident
        doc["vehicle_out"] = _write_back(write_vehicle, out_vehicle, ident, log,
                                         "uuvid vehicle identify inertia")
    if json_out:
        _print_json(doc)
        return
    out_console.print(_show_params(f"{d} inertia from {log.name} ({doc['n_rows']} rows, "
                                   f"{doc['cov_type']} σ)", doc["parameters"]))
    pl = doc["phase_lag"]
    if pl:
        pred = f"{pl['predicted_deg']:.1f}°" if pl["predicted_deg"] is not None else "n/a"
        out_console.print(f"phase lag at ω = {pl['omega']:.4g} rad/s: measured "
                          f"{pl['measured_deg']:.1f}° (incl. {pl['zoh_delay_deg']:.1f}° ZOH), "
                          f"atan(ω m/k_L) = {pred}", highlight=False)
    if doc.get("fit_nrmse") is not None:
        out_console.print(f"NRMSE of the identified model on this log: {doc['fit_nrmse']:.3f}"
                          + (f"; on {validation_log.name}: {doc['validation']['nrmse']:.3f}"
                             if validation else ""), highlight=False)
    for m in doc["notes"]:
        err_console.print(f"[yellow]note:[/] {_escape(m)}", highlight=False, soft_wrap=True)
    if doc.get("report"):
        err_console.print(f"report: {doc['report']}")
    if doc.get("vehicle_out"):
        err_console.print(f"wrote {doc['vehicle_out']}")


# =============================================================================================
# input design
# =============================================================================================
def _pair(text: str | None, opt: str) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        _fail(f"{opt}: expected two comma-separated numbers, got {text!r}")
    if not (math.isfinite(a) and math.isfinite(b)):
        _fail(f"{opt}: values must be finite, got {text!r}")
    return a, b


def design_input(
    k: float = typer.Option(..., "--k", help="Prior linear drag k (N·s/m or N·m·s/rad)."),
    kq: float = typer.Option(0.0, "--kq", help="Prior quadratic drag k_q."),
    mass: float | None = typer.Option(None, "--mass",
                                      help="Nominal inertia for τ_c (default: --mass-air, the "
                                           "paper's yaw choice)."),
    mass_air: float | None = typer.Option(None, "--mass-air",
                                          help="In-air (rigid-body) inertia along the DOF."),
    added_mass_range: str = typer.Option("0.1,1.0", "--added-mass-range",
                                         help="Added mass as fractions of --mass-air: LOW,HIGH."),
    speed: float = typer.Option(..., "--speed",
                                help="Regime speed ξ* (m/s or rad/s); its sign sets the offset's."),
    speed_range: str | None = typer.Option(None, "--speed-range",
                                           help="Keep the speed within LOW,HIGH."),
    eta: float = typer.Option(1.0, "--eta", help="Installation coefficient of the mode."),
    w: float = typer.Option(0.0, "--w", help="Mean disturbance w."),
    choice: Choice = typer.Option(Choice.nominal, "--choice",
                                  help="nominal: 1/(√3 τ_c); robust: maximin D-efficiency over the "
                                       "inertia range."),
    n_periods: float = typer.Option(3.0, "--n-periods", help="Sine periods to record."),
    settle_tau: float = typer.Option(4.0, "--settle-tau", help="Settling time in τ_c (largest)."),
    lead_in: float = typer.Option(0.0, "--lead-in", help="Offset-only lead-in (s)."),
    max_distance: float | None = typer.Option(None, "--max-distance",
                                              help="Maneuvering space (m): raise ω so it fits."),
    force_limit: float | None = typer.Option(None, "--force-limit",
                                             help="Largest |φ| the thrusters give in the mode."),
    reversal_margin: float = typer.Option(0.1, "--reversal-margin",
                                          help="Keep Δφ ≤ (1 − margin)|φ₀| (no thrust reversal)."),
    amplitude: float | None = typer.Option(None, "--amplitude", help="Impose the amplitude Δφ."),
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
    from uuvid.identify.design import SQRT3, design_sine_experiment
    from uuvid.io.atomic import atomic_write_text

    _, _print_json, err_console, out_console = _h()
    out = renamed(out, "--out-file", old_out)
    for name, v in (("--k", k), ("--kq", kq)):
        if not (math.isfinite(v) and v >= 0):
            _fail(f"{name} must be finite and >= 0, got {v}")
    if mass is None and mass_air is None:
        _fail("give --mass-air (in-air inertia; the added mass range is relative to it) or --mass")
    frac = _pair(added_mass_range, "--added-mass-range")
    if frac[0] < 0 or frac[1] < frac[0]:
        _fail(f"--added-mass-range: expected 0 <= LOW <= HIGH, got {added_mass_range!r}")
    nominal = mass if mass is not None else mass_air
    if vehicle is not None and dof is None:
        _fail("--vehicle needs --dof (the DOF the command drives)")
    if dof is not None:
        from uuvid.vehicle.layout import dof_index
        from uuvid.vehicle.model import DOF_NAMES

        try:
            dof = DOF_NAMES[dof_index(dof)]
        except ValueError as e:
            _fail(f"--dof: {e}")
    if out is not None and out.suffix.lower() != ".csv":
        _fail(f"--out-file {out}: the command file must end in .csv")
    try:
        des = design_sine_experiment(
            k, kq, mass=nominal, speed=speed, mass_air=mass_air, added_fraction=frac,
            speed_range=_pair(speed_range, "--speed-range"), eta=eta, w=w, n_periods=n_periods,
            settle_tau=settle_tau, lead_in=lead_in, max_distance=max_distance,
            force_limit=force_limit, reversal_margin=reversal_margin, amplitude=amplitude,
            sample_time=sample_time, choice=choice.value, dof=dof or "")
    except ValueError as e:
        _fail(f"design-input: {e}")
    doc = {"command": "vehicle design-input", **des.as_dict()}
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
    cmd = des.command(sample_time)
    cols = {"time": cmd["t"], "force": cmd["force"]}
    if vehicle is not None:
        from uuvid.vehicle.definition import load_vehicle

        try:
            v = load_vehicle(vehicle)
        except (ValueError, FileNotFoundError, KeyError) as e:
            _fail(f"--vehicle: {_msg(e)}")
        try:
            tc = des.thruster_commands(v, mode, sample_time=sample_time,
                                       voltage=_pair(voltage_cv, "--voltage-cv"))
        except (ValueError, KeyError) as e:
            _fail(f"--vehicle {vehicle} --mode {mode}: {_msg(e)}")
        for j, nm in enumerate(tc["thrusters"]):
            cols[f"thrust_{nm}"] = tc["thrust"][j]
        if "voltage" in tc:
            for j, nm in enumerate(tc["thrusters"]):
                cols[f"voltage_{nm}"] = tc["voltage"][j]
        doc["thrusters"] = {"vehicle": v.name, "mode": tc["mode"], "names": tc["thrusters"],
                            "peak_thrust_N": float(np.max(np.abs(tc["thrust"]))),
                            "saturated": tc["saturated"]}
        if tc["saturated"]:
            err_console.print("[yellow]warning:[/] some thruster commands exceed the thrust limits "
                              "(lower the amplitude or give --force-limit)", highlight=False)
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
            _fail(f"--out-file {out}: cannot write ({e.strerror or e})")
        doc["out"] = str(out)
        doc["columns"] = list(cols)
    if json_out:
        _print_json(doc)
        return
    from rich.table import Table

    t = Table(title=f"Sine experiment for the {dof or 'DOF'} inertia")
    t.add_column("quantity")
    t.add_column("value")
    rows = [("k_L = k + 2 k_q |ξ*|", f"{des.k_L:.4g}"),
            (f"τ_c (nominal inertia {nominal:.4g}, {doc['nominal_inertia_from']})", f"{des.tau_c:.4g} s")]
    if "tau_c_range" in doc:
        rows.append((f"τ_c range (in-air + {frac[0]:.0%} … {frac[1]:.0%} added)",
                     f"{doc['tau_c_range'][0]:.4g} … {doc['tau_c_range'][1]:.4g} s"))
        rows.append(("ω_opt range", f"{doc['omega_opt_range'][0]:.4g} … "
                                    f"{doc['omega_opt_range'][1]:.4g} rad/s"))
    rows += [("ω_opt = 1/(√3 τ_c)", f"{des.omega_opt:.4g} rad/s"),
             ("ω_opt numeric (Fisher)", f"{des.omega_numeric:.4g} rad/s"),
             ("ω applied", f"{des.omega:.4g} rad/s (period {des.period:.4g} s, {des.choice})"),
             ("offset φ₀", f"{des.offset:.4g}"),
             ("amplitude Δφ", f"{des.amplitude:.4g} (limited by {des.levels['limited_by']})"),
             ("duration", f"{des.duration:.4g} s (settle {des.settle:.4g} s)"),
             ("distance", f"{des.distance:.4g}"),
             ("D-efficiency", f"{des.efficiency:.3f}")]
    for a, b in rows:
        t.add_row(a, b)
    out_console.print(t)
    for m in des.messages:
        err_console.print(f"[yellow]note:[/] {_escape(m)}", highlight=False, soft_wrap=True)
    if out is not None:
        err_console.print(f"wrote {out} ({doc['command_samples']} samples: {', '.join(cols)})")


# =============================================================================================
# reproduce caccia2000
# =============================================================================================
def reproduce_caccia2000(
    seed: int = typer.Option(0, "--seed", help="Random seed of the simulated experiments."),
    fast: bool = typer.Option(False, "--fast",
                              help="Skip the two validation logs (Figs. 13, 15); the "
                                   "identification is identical."),
    json_out: bool = typer.Option(False, "--json", help="Print the results as one JSON document."),
    out: Path | None = typer.Option(None, "--out", help="Write plots, caccia2000.json and "
                                                        "index.html here."),
):
    """Caccia, Indiveri & Veruggio (2000): ROMEO's identification, simulated and identified back."""
    from uuvid.papers import caccia2000
    from uuvid.report.progress import progress_task

    _, _print_json, err_console, out_console = _h()
    try:
        with progress_task("Caccia 2000: simulate ROMEO and identify", total=1) as task:
            result = caccia2000.reproduce(seed=seed, fast=fast, out_dir=out)
            task.advance()
    except OSError as e:
        _fail(f"--out {out}: cannot write the outputs ({e.strerror or e})")
    if json_out:
        _print_json(dict(result))
        return
    _show_caccia(result)
    if out:
        err_console.print(f"report: {Path(out) / 'index.html'}")


def _show_caccia(result: dict) -> None:
    from rich.table import Table

    from uuvid.papers.caccia2000 import TABLE_KEYS

    out_console = _h()[3]
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
                                        "[bold red]FAILED[/]: " + "; ".join(acc["failures"])))


# =============================================================================================
# registration
# =============================================================================================
def register(vehicle_app: typer.Typer, reproduce_app: typer.Typer) -> None:
    """Add ``reproduce caccia2000``, ``vehicle identify steady|inertia`` and ``vehicle
    design-input``."""
    reproduce_app.command("caccia2000")(reproduce_caccia2000)
    vehicle_app.add_typer(identify_app, name="identify")
    vehicle_app.command("design-input")(design_input)
