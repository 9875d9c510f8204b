"""One DOF's command and position series from a vehicle log, for Caccia's identification.

:func:`read_vehicle_log` takes a :class:`LogSpec` (where the command, position, mode and ballast
are) and returns :class:`LogData` (SI series on one clock, plus ``info``: source, columns,
units, notes and warnings)::

    from uuvid.identify.vehicle.logs import LogSpec, read_vehicle_log
    data = read_vehicle_log(LogSpec("dive.csv", "heave", command_col="thrust",
                                    position_col="-altitude"))

Formats: CSV/Parquet (``*_col``), ROS 1/2 bags (``topics``: ``command=/topic:field``), ArduSub
``.tlog``/``.bin`` (``fields``: ``command=MESSAGE.field``).  Every column, topic or field may
carry a sign and a scale: ``-altitude``, ``0.01*depth_cm``, ``-GLOBAL_POSITION_INT.relative_alt``,
``-2.5*/thrust:data``.  Without a command channel and with a ``vehicle``, the recorded servo
outputs (ArduSub ``SERVO_OUTPUT_RAW``/``RCOU``, MAVROS ``/mavros/rc/out``) become thrust through
the vehicle's thruster models and the DOF's force through its B matrix
(:func:`uuvid.vehicle.servo_thrust.servo_generalized_force`).  A ROS ``…orientation`` quaternion
field gives yaw (``…orientation.yaw``, ``.roll``, ``.pitch``).

A channel whose magnitude cannot be what it claims — PWM-like values (1000–2000) as newtons, a
mostly negative depth (an altitude, up positive) — gives a warning naming the column
(``info["warnings"]``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from uuvid.io.logs import CHANNEL_UNITS

__all__ = ["LogSpec", "LogData", "read_vehicle_log", "parse_scaled", "load_msg_definitions",
           "quaternion_angles", "ANGULAR", "DUPLICATE_MODES"]

ANGULAR = ("roll", "pitch", "yaw")
#: ``on_duplicate`` choices; ``merge`` is the mean of the samples sharing a stamp
DUPLICATE_MODES = ("merge", "first", "last", "error")
_CHANNELS = ("command", "position", "mode", "ballast")


@dataclass
class LogSpec:
    """Where a DOF's command, position, mode and ballast are in a log, and how to read it.

    ``on_duplicate``: samples sharing a time stamp (ordinary in QGroundControl tlogs) are
    ``merge``-d (mean, counted in ``info["duplicates"]``), or ``first``/``last``, or an
    ``error``.  ``time``: ``boot`` (the vehicle's clock; ROS: header stamps) or ``log`` (the
    recorder's receive time — survives a reboot inside the log).  ``msg_definitions``: ROS
    message definitions the bag lacks (``{"pkg/msg/Type": text}`` or ``["pkg/msg/Type=FILE.msg",
    "path/pkg/msg/Type.msg"]``).  ``t_start``/``t_end``: the part of the log used [s]."""

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
    on_duplicate: str = "merge"
    time: str | None = None
    msg_definitions: dict | list | None = None
    t_start: float | None = None
    t_end: float | None = None
    #: ArduSub logs: steady segments only from open-loop (MANUAL, armed) stretches.
    open_loop_only: bool = True

    def __post_init__(self):
        self.path = Path(self.path)


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
    #: True where the vehicle was not in open loop (e.g. ArduSub ALT_HOLD): steady segments end
    #: there (``None``: every sample is usable).
    closed_loop: np.ndarray | None = None
    #: Times of samples dropped because the position (resp. command) was missing (NaN/empty):
    #: the fits count them as missing samples of the segments they fall in.
    t_position_missing: np.ndarray | None = None
    t_command_missing: np.ndarray | None = None

    @property
    def warnings(self) -> list[str]:
        return list(self.info.get("warnings") or [])

    @property
    def notes(self) -> list[str]:
        return list(self.info.get("notes") or [])

    def between(self, t_start: float | None = None, t_end: float | None = None) -> LogData:
        """The samples with ``t_start <= t <= t_end`` (``None``: open)."""
        from uuvid.core.checks import time_window

        if t_start is None and t_end is None:
            return self
        time_window(t_start, t_end)
        lo = -math.inf if t_start is None else float(t_start)
        hi = math.inf if t_end is None else float(t_end)
        if not lo < hi:
            raise ValueError(f"--t-start {t_start} must be before --t-end {t_end}")
        kc = (self.t_cmd >= lo) & (self.t_cmd <= hi)
        kp = (self.t_pos >= lo) & (self.t_pos <= hi)
        if kc.sum() < 2 or kp.sum() < 5:
            raise ValueError(f"{self.info.get('source')}: {int(kc.sum())} command and "
                             f"{int(kp.sum())} position samples between {lo:g} and {hi:g} s "
                             f"(the log spans {self.t_cmd[0]:.6g}…{self.t_cmd[-1]:.6g} s)")
        modes = None if self.modes is None else [m for m, k in zip(self.modes, kc) if k]
        info = {**self.info, "t_start": t_start, "t_end": t_end,
                "command_samples": int(kc.sum()), "position_samples": int(kp.sum())}
        def win(tt):
            return None if tt is None else tt[(tt >= lo) & (tt <= hi)]

        return LogData(self.t_cmd[kc], self.command[kc], self.t_pos[kp], self.position[kp],
                       modes, None if self.ballast is None else self.ballast[kc], info,
                       None if self.closed_loop is None else self.closed_loop[kc],
                       win(self.t_position_missing), win(self.t_command_missing))


# ------------------------------------------------------------------------------------------------
# small parsers
# ------------------------------------------------------------------------------------------------
_SCALE_RE = re.compile(r"^\s*(?P<sign>[-+])?\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
                       r"\s*\*)?\s*(?P<rest>\S.*?)\s*$")


def parse_scaled(text: str) -> tuple[float, str]:
    """``"-2.5*depth"`` → ``(-2.5, "depth")``, ``"-alt"`` → ``(-1.0, "alt")``, ``"x"`` →
    ``(1.0, "x")``: the sign/scale applied to a mapped column, topic or field."""
    m = _SCALE_RE.match(text or "")
    if not m:
        raise ValueError(f"expected [-][SCALE*]NAME, got {text!r}")
    f = float(m["num"]) if m["num"] else 1.0
    return (-f if m["sign"] == "-" else f), m["rest"]


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
    unknown = sorted(set(out) - set(_CHANNELS))
    if unknown:
        raise ValueError(f"{opt}: unknown channel(s) {unknown}; use command, position, mode, "
                         "ballast")
    return out


def load_msg_definitions(items) -> dict[str, str]:
    """ROS message definitions: ``{"pkg/msg/Type": text}`` kept; strings ``TYPE=FILE`` or a
    ``FILE`` whose path ends in ``pkg/msg/Type.msg`` (or is named ``Type.msg`` inside ``pkg/``)
    are read."""
    if not items:
        return {}
    if isinstance(items, dict):
        return dict(items)
    out: dict[str, str] = {}
    for it in items:
        name, sep, file = str(it).partition("=")
        if not sep:
            file, name = name, ""
        p = Path(file.strip())
        if not p.is_file():
            raise ValueError(f"--msg-definitions {it!r}: no such file {p}")
        if not name:
            parts = p.with_suffix("").parts
            if len(parts) >= 3 and parts[-2] == "msg":
                name = "/".join(parts[-3:])
            elif len(parts) >= 2:
                name = f"{parts[-2]}/msg/{parts[-1]}"
            else:
                raise ValueError(f"--msg-definitions {it!r}: say the type, e.g. "
                                 f"mavros_msgs/msg/RCOut={p}")
        try:
            out[name.strip()] = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise ValueError(f"--msg-definitions {p}: cannot read ({e})") from None
    return out


def quaternion_angles(qx, qy, qz, qw) -> dict[str, np.ndarray]:
    """Roll, pitch, yaw [rad] (ZYX Euler angles) of unit quaternions, in the quaternion's own
    frame (ROS: ENU/FLU by REP 103 — yaw counter-clockwise from east; negate it for a NED
    heading).  Fossen 2011, eq. 2.69."""
    qx, qy, qz, qw = (np.asarray(a, float) for a in (qx, qy, qz, qw))
    n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
    roll = np.arctan2(2 * (qw * qx + qy * qz), 1 - 2 * (qx * qx + qy * qy))
    pitch = np.arcsin(np.clip(2 * (qw * qy - qz * qx), -1.0, 1.0))
    yaw = np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    return {"roll": roll, "pitch": pitch, "yaw": yaw}


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


def _position_unit(spec: LogSpec) -> str | None:
    if spec.dof in ANGULAR:
        return spec.angle_unit or spec.position_unit or "rad"
    return spec.position_unit


def _reader_duplicates(spec: LogSpec) -> str:
    if spec.on_duplicate not in DUPLICATE_MODES:
        raise ValueError(f"--on-duplicate {spec.on_duplicate!r}: expected one of "
                         f"{', '.join(DUPLICATE_MODES)}")
    return "mean" if spec.on_duplicate == "merge" else spec.on_duplicate


def _units(spec: LogSpec, servo: bool = False) -> dict:
    units = {}
    if spec.command_unit and not servo:
        units["command"] = spec.command_unit
    pu = _position_unit(spec)
    if pu:
        units["position"] = pu
    return units


# ------------------------------------------------------------------------------------------------
# warnings: a channel whose magnitude cannot be what it claims
# ------------------------------------------------------------------------------------------------
def _magnitude_warnings(data: LogData, spec: LogSpec, names: dict, servo: bool) -> list[str]:
    out = []
    c = data.command[np.isfinite(data.command)]
    force_unit = spec.command_unit in (None, "N", "N·m", "N*m", "Nm", "N.m")
    if not servo and force_unit and c.size:
        inside = np.mean((c >= 900) & (c <= 2100))
        if inside >= 0.9 and 1100 <= np.median(c) <= 1900:
            out.append(f"command {names.get('command')!r} holds {c.min():.6g}…{c.max():.6g}, "
                       "servo-PWM-like values (µs), taken as "
                       f"{'N·m' if spec.dof in ANGULAR else 'N'}: give the force, or the PWM "
                       "outputs with a vehicle (--vehicle) to turn them into thrust")
    p = data.position[np.isfinite(data.position)]
    if p.size and np.ptp(p) == 0:
        out.append(f"position {names.get('position')!r} is constant ({p[0]:g}) over the log: not "
                   "a measurement of the motion (ArduSub's VFR_HUD.alt stays 0 without an EKF "
                   "origin: use -GLOBAL_POSITION_INT.relative_alt)")
    from uuvid.identify.plausibility import rate_warnings, time_step_warnings

    out += time_step_warnings(data.t_pos, spec.time_unit)
    out += rate_warnings(data.t_pos, data.position, spec.dof, _position_unit(spec) or "m",
                         defaulted=not (spec.angle_unit or spec.position_unit),
                         angular=spec.dof in ANGULAR)
    out += heading_unit_warnings(data.t_pos, data.position, _position_unit(spec),
                                 names.get("position"), spec.dof)
    if spec.dof == "heave" and p.size:
        if np.mean(p < 0) >= 0.8 and np.median(p) < -0.05:
            out.append(f"depth {names.get('position')!r} is mostly negative (median "
                       f"{np.median(p):.3g} m): depth is positive down — if this is an altitude "
                       f"(up positive) negate it (-{names.get('position')})")
    return out


#: the angle units a heading in radians can be mistaken for (the numbers as logged ÷ these = rad)
_DEGREE_UNITS = {u: f for u, (si, f) in CHANNEL_UNITS.items() if si == "rad" and u != "rad"}


def heading_unit_warnings(t, x, unit: str | None, name: str | None, dof: str) -> list[str]:
    """An angle read in degrees whose numbers stay within ±2π and jump by ≈ 2π where they wrap is
    a heading in radians (−π…π or 0…2π) read as degrees: 57× too small a motion, and each wrap a
    6.28° "jump" (outliers, a nonsense drag) — one sentence.  ``x`` is in rad, as read."""
    if dof not in ANGULAR or unit not in _DEGREE_UNITS:
        return []
    t, x = np.asarray(t, float), np.asarray(x, float)
    ok = np.isfinite(t) & np.isfinite(x)
    t, raw = t[ok], x[ok] / _DEGREE_UNITS[unit]  # the numbers as logged
    if raw.size < 10 or np.max(np.abs(raw)) > 2 * math.pi + 0.05 or np.ptp(raw) < math.pi:
        return []
    o = np.argsort(t, kind="stable")
    t, raw = t[o], raw[o]
    d = np.diff(raw)
    wrap = (np.abs(d) > math.pi) & (np.abs(np.abs(d) - 2 * math.pi) < 1.0)
    small = np.abs(d[~wrap])
    if not wrap.any() or not small.size or float(np.percentile(small, 90)) > 0.5:
        return []
    # a heading in radians moves between its wraps (a turning vehicle: more than half a turn in
    # all); a few degrees of steps that happen to span ≈ 6° (a small yaw step, a roll record) do not
    if float(np.sum(small)) < math.pi:
        return []
    k = int(np.flatnonzero(wrap)[0])
    return [f"{dof} angle {name or 'position'!r} (read in {unit}) spans {raw.min():.3g}…"
            f"{raw.max():.3g} and wraps at 2π ({int(wrap.sum())} jump(s) of ≈ ±6.28, first at t = "
            f"{t[k + 1]:.6g} s: {raw[k]:.4g} → {raw[k + 1]:.4g}): radians? give --angle-unit rad "
            "— read as degrees the motion is 57× too small and every wrap is a jump (outliers, "
            "nonsense drag and η)"]


def _finish(data: LogData, spec: LogSpec, names: dict, servo: bool = False) -> LogData:
    warn = list(data.info.get("warnings") or []) + _magnitude_warnings(data, spec, names, servo)
    data.info["warnings"] = warn
    if spec.t_start is not None or spec.t_end is not None:
        data = data.between(spec.t_start, spec.t_end)
    return data


# ------------------------------------------------------------------------------------------------
# CSV / Parquet
# ------------------------------------------------------------------------------------------------
def _table(spec: LogSpec):
    from uuvid.io.logs import _read_csv, _read_parquet

    p = spec.path
    if p.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(p)
    return _read_csv(p, spec.delimiter, "#")


_TIME_CANDIDATES = ("time", "timestamp", "t", "time_s", "stamp", "datetime", "date_time")


def _read_table_log(spec: LogSpec) -> LogData:
    from uuvid.io.logs import LogDataError, _find_column, read_log_csv

    scales = {}
    columns = {}
    for ch, text in (("command", spec.command_col), ("position", spec.position_col),
                     ("ballast", spec.ballast_col)):
        if text:
            scales[ch], columns[ch] = parse_scaled(text)
    units = _units(spec)
    kw = dict(columns=columns, units=units, time_unit=spec.time_unit, delimiter=spec.delimiter,
              allow_missing=True, on_duplicate=_reader_duplicates(spec))
    notes: list[str] = []
    try:
        r = read_log_csv(spec.path, time_col=spec.time_col, **kw)
    except LogDataError as e:
        if spec.time_col != "time" or "for the time" not in str(e):
            raise
        cols = _table(spec).columns
        from uuvid.io.bench import _norm

        hit = next((c for cand in _TIME_CANDIDATES for c in cols if _norm(c) == cand), None)
        if hit is None:
            raise
        notes.append(f"time column {hit!r} (no column 'time')")
        r = read_log_csv(spec.path, time_col=hit, **kw)
    t = np.asarray(r.t, float)
    name = r.meta.get("source", spec.path.name)
    orig = dict(r.meta["original_names"])
    if r.meta.get("time_unit") == "datetime":
        t0 = float(t[0])
        t = t - t0
        notes.append(f"time column {r.meta['time_column']!r} is ISO 8601 date-time text"
                     + (" (detected)" if r.meta.get("time_detected") else "")
                     + f": t = 0 at {np.datetime64(int(round(t0 * 1e3)), 'ms')}")
    if r.meta.get("duplicates"):
        notes.append(f"{r.meta['duplicates']} rows with a duplicated time stamp merged "
                     f"({spec.on_duplicate})")
    if r.meta.get("reordered"):
        notes.append(f"{r.meta['reordered']} rows out of time order sorted")
    for sec in r.meta.get("sections") or []:
        if sec.get("inserted_after"):
            notes.append(f"from data row {sec['first_row']} the rows carry "
                         f"{len(sec['columns_added'])} more cells than the header (a telemetry "
                         "group added mid-log, as QGroundControl does): placed after column "
                         f"{sec['inserted_after']!r} by matching the neighbouring rows, named "
                         f"{sec['columns_added']}")
        elif sec["columns_added"]:
            notes.append(f"header repeated at data row {sec['first_row']}: columns "
                         f"{sec['columns_added']} added there (earlier rows have them empty)")
    cmd = np.asarray(r["command"], float) * scales["command"]
    rows = np.flatnonzero(np.isfinite(cmd))
    if rows.size < 2:
        raise LogDataError(f"{name}: column {orig['command']!r} has "
                           f"{rows.size} command values; expected the nominal force of the DOF "
                           "on every command row")
    pos = np.asarray(r["position"], float) * scales["position"]
    prow = np.flatnonzero(np.isfinite(pos))
    if prow.size < 5:
        raise LogDataError(f"{name}: column {orig['position']!r} has "
                           f"{prow.size} position values (need at least 5)")
    tbl = None
    modes = None
    if spec.mode_col:
        if r.meta.get("duplicates") or r.meta.get("reordered"):
            at = r.meta.get("first_unordered") or name
            raise LogDataError(f"{at}: a mode column (--mode-col {spec.mode_col}) cannot be "
                               "matched to merged or sorted rows; give one row per time stamp, "
                               "in time order")
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
        b = np.asarray(r["ballast"], float)[rows] * scales["ballast"]
        bad = np.flatnonzero(~np.isfinite(b))
        if bad.size:
            tbl = tbl or _table(spec)
            col = orig["ballast"]
            raise LogDataError(f"{tbl.where(col, int(rows[bad[0]]))}: empty ballast count on a "
                               "row with a command; every command sample needs it")
        ballast = b
    names = {k: (f"{scales[k]:g}*{v}" if scales.get(k, 1.0) not in (1.0, -1.0) else
                 ("-" if scales.get(k) == -1.0 else "") + v) for k, v in orig.items()}
    info = {"source": name, "format": r.meta.get("format"), "rows": int(t.size),
            "command_samples": int(rows.size), "position_samples": int(prow.size),
            "columns": names, "units": r.meta.get("units"),
            "original_units": r.meta.get("original_units"),
            "duplicates": int(r.meta.get("duplicates") or 0), "notes": notes}
    if spec.mode_col:
        info["columns"] = {**info["columns"], "mode": spec.mode_col}
    data = LogData(t[rows], cmd[rows], t[prow], pos[prow], modes, ballast, info,
                   t_position_missing=t[~np.isfinite(pos) & np.isfinite(t)],
                   t_command_missing=t[~np.isfinite(cmd) & np.isfinite(t)])
    return _finish(data, spec, names)


# ------------------------------------------------------------------------------------------------
# shared by bags and ArduSub logs: channels on their own clocks → LogData
# ------------------------------------------------------------------------------------------------
def _zoh(t_src, t):
    """Index of the sample of ``t_src`` held at each ``t`` (−1 before the first)."""
    return np.searchsorted(t_src, t, side="right") - 1


def _scaled(out: dict, scales: dict) -> dict:
    from uuvid.core.response import TimeResponse

    res = dict(out)
    for ch, f in scales.items():
        if ch in res and f != 1.0:
            r = res[ch]
            res[ch] = TimeResponse(r.t, {ch: np.asarray(r[ch], float) * f}, r.meta)
    return res


def _duplicates(out: dict) -> dict[str, int]:
    d = {}
    for ch, r in out.items():
        n = (r.meta.get("duplicates") or {}).get(ch, 0)
        if n:
            d[ch] = int(n)
    return d


def _from_channels(out: dict, spec: LogSpec, info: dict, command=None) -> LogData:
    from uuvid.io.logs import LogDataError

    if command is None:
        c = out["command"]
        t_cmd, cmd = np.asarray(c.t, float), np.asarray(c["command"], float)
    else:
        t_cmd, cmd = command
    ok = np.isfinite(cmd)
    t_cmd_missing = t_cmd[~ok]
    t_cmd, cmd = t_cmd[ok], cmd[ok]
    p = out["position"]
    t_pos, pos = np.asarray(p.t, float), np.asarray(p["position"], float)
    okp = np.isfinite(pos)
    t_pos_missing = t_pos[~okp]
    t_pos, pos = t_pos[okp], pos[okp]
    if t_cmd.size < 2:
        raise LogDataError(f"{spec.path.name}: the command channel has {t_cmd.size} samples")
    if t_pos.size < 5:
        raise LogDataError(f"{spec.path.name}: the position channel has {t_pos.size} samples "
                           "(need at least 5)")
    notes = list(info.get("notes") or [])
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
    dup = _duplicates(out)
    if dup:
        notes.append("samples with a duplicated time stamp merged ("
                     f"{spec.on_duplicate}): " + ", ".join(f"{k} {v}" for k, v in dup.items()))
    info = {**info, "command_samples": int(t_cmd.size), "position_samples": int(t_pos.size),
            "duplicates": dup, "notes": notes}
    return LogData(t_cmd, cmd, t_pos, pos, modes, ballast, info,
                   t_position_missing=t_pos_missing, t_command_missing=t_cmd_missing)


def _servo_command(spec: LogSpec, out: dict, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """The DOF's generalized force from the servo channels ``names`` (output i → thruster i)."""
    from uuvid.io.logs import LogDataError, align
    from uuvid.vehicle.layout import dof_index
    from uuvid.vehicle.servo_thrust import servo_generalized_force

    v = _load_vehicle(spec.vehicle)
    al = align({n: out[n] for n in names}, "union", interp="previous")
    pwm = np.vstack([np.asarray(al[n], float) for n in names])
    try:
        T, tau = servo_generalized_force(v, pwm)
    except ValueError as e:
        raise ValueError(f"{e}; give the command channel instead") from None
    if not np.all(np.isfinite(T)):
        raise LogDataError(f"{spec.path.name}: servo outputs give non-finite thrust")
    return np.asarray(al.t, float), tau[dof_index(spec.dof)]


def _load_vehicle(name):
    from uuvid.vehicle.definition import load_vehicle

    try:
        return load_vehicle(name)
    except (ValueError, FileNotFoundError, KeyError) as e:
        msg = str(e.args[0]) if isinstance(e, KeyError) and e.args else str(e)
        raise ValueError(f"--vehicle: {msg}") from None


# ------------------------------------------------------------------------------------------------
# ROS bags
# ------------------------------------------------------------------------------------------------
_QUAT_RE = re.compile(r"^(?P<q>(?:.*\.)?orientation)(?:\.(?P<angle>roll|pitch|yaw))?$")


def _read_bag_log(spec: LogSpec) -> LogData:
    from uuvid.io.logs import read_rosbag

    raw = _parse_pairs(spec.topics, "--topic")
    scales, topics = {}, {}
    for ch, text in raw.items():
        scales[ch], topics[ch] = parse_scaled(text)
    servo = "command" not in topics
    if "position" not in topics:
        raise ValueError(f"{spec.path.name}: a ROS bag needs --topic position=/topic:field (e.g. "
                         "--topic position=-/mavros/global_position/rel_alt:data, or "
                         "position=/mavros/imu/data:orientation.yaw)")
    if servo and not spec.vehicle:
        raise ValueError(f"{spec.path.name}: a ROS bag needs --topic command=/topic:field (e.g. "
                         "--topic command=/thrust_cmd:data), or --vehicle to turn the recorded "
                         "PWM outputs (/mavros/rc/out) into the DOF's force")
    units = _units(spec, servo)
    req = dict(topics)
    quat = None
    topic, _, fld = topics["position"].partition(":")
    m = _QUAT_RE.match(fld)
    if m:
        angle = m["angle"] or (spec.dof if spec.dof in ANGULAR else None)
        if angle is None:
            raise ValueError(f"--topic position={topics['position']}: a quaternion gives roll, "
                             "pitch or yaw; name one (…orientation.yaw)")
        quat = (m["q"], angle)
        del req["position"]
        for c in "xyzw":
            req[f"_q{c}"] = f"{topic}:{m['q']}.{c}"
        units.pop("position", None)
    servo_names = []
    if servo:
        n = _load_vehicle(spec.vehicle).layout.n
        servo_names = [f"servo_{j}" for j in range(1, n + 1)]
        for j, nm in enumerate(servo_names):
            req[nm] = f"/mavros/rc/out:channels[{j}]"
    stamp = "receive" if spec.time == "log" else "header"
    from uuvid.io.logs import LogDataError

    try:
        out = read_rosbag(spec.path, req, units=units, allow_missing=True, stamp=stamp,
                          on_duplicate=_reader_duplicates(spec),
                          msg_definitions=load_msg_definitions(spec.msg_definitions) or None)
    except LogDataError as e:
        if "msg_definitions=" not in str(e):
            raise
        raise LogDataError(f"{e} (command line: --msg-definitions pkg/msg/Type=FILE.msg)") from None
    notes = []
    if quat is not None:
        from uuvid.core.response import TimeResponse

        q = [out.pop(f"_q{c}") for c in "xyzw"]
        ang = quaternion_angles(*(r[f"_q{c}"] for r, c in zip(q, "xyzw")))[quat[1]]
        out["position"] = TimeResponse(q[0].t, {"position": ang}, q[0].meta)
        notes.append(f"position = {quat[1]} of the quaternion {topic}:{quat[0]} (ZYX, in the "
                     "message's frame: ROS ENU, counter-clockwise from east)")
    out = _scaled(out, scales)
    info = {"source": spec.path.name, "format": "rosbag", "topics": raw, "units": units,
            "stamp": stamp, "notes": notes}
    cmd = None
    if servo:
        cmd = _servo_command(spec, out, servo_names)
        info["command_from"] = (f"/mavros/rc/out channels through {spec.vehicle}'s thruster models "
                                f"and B ({spec.dof} component)")
    data = _from_channels(out, spec, info, command=cmd)
    names = {"command": raw.get("command", "/mavros/rc/out"), "position": raw["position"]}
    return _finish(data, spec, names, servo)


# ------------------------------------------------------------------------------------------------
# ArduSub
# ------------------------------------------------------------------------------------------------
#: Vehicle presets ArduSub's frames stand for when no vehicle is given (said out loud).
FRAME_PRESETS = {1: "bluerov2", 2: "bluerov2-heavy"}
_DOF_COLUMN = {"surge": "X_N", "sway": "Y_N", "heave": "Z_N", "roll": "K_Nm", "pitch": "M_Nm",
               "yaw": "N_Nm"}


def _read_ardusub_log(spec: LogSpec) -> LogData:
    """Command/position from an ArduSub ``.tlog``/``.BIN`` as the log describes the vehicle.

    Without ``--field command=…`` the DOF's generalized force comes from
    :func:`uuvid.io.ardusub.load_dive`: the log's FRAME_CONFIG / SERVOn_FUNCTION /
    MOT_n_DIRECTION, thrust per motor from PWM at the logged battery voltage, and the physical
    wrench ``τ = B T`` of the vehicle (``--vehicle``, or the preset the frame stands for:
    FRAME_CONFIG 1 → BlueROV2, 2 → BlueROV2 Heavy, said in the notes).  Depth (heave) and yaw
    come from the sources ``load_dive`` chooses and reports.  Only open-loop (MANUAL, armed)
    stretches end steady segments unless ``spec.open_loop_only`` is off; what was left out is
    said in the notes."""
    raw = _parse_pairs(spec.fields, "--field")
    if "command" in raw or "position" in raw:
        return _read_ardusub_fields(spec)
    if spec.dof not in ("heave", "yaw"):
        raise ValueError(f"{spec.path.name}: ArduSub logs carry no {spec.dof} position; give "
                         "--field position=MESSAGE.field (e.g. a positioning system's message)")
    from uuvid.io.ardusub import load_dive
    from uuvid.io.ardusub.frames import MissingFrameError

    try:
        dive = load_dive(spec.path)
    except MissingFrameError as e:
        if not spec.vehicle:
            raise ValueError(f"{e}; or give --vehicle to map output j to thruster j") from None
        # no parameters: output j drives thruster j of --vehicle, unreversed — said loudly
        data = _read_ardusub_fields(spec)
        data.info.setdefault("warnings", []).append(
            f"{spec.path.name} holds no parameters (FRAME_CONFIG, SERVOn_FUNCTION, "
            f"MOT_n_DIRECTION): assumed output j drives thruster j of {spec.vehicle} with no "
            "reversal — give the log's parameter download to read them")
        return data
    notes, warnings = [], list(dive.warnings)
    vehicle = spec.vehicle
    if vehicle is None:
        vehicle = FRAME_PRESETS.get(dive.config.frame)
        if vehicle is None:
            raise ValueError(f"{spec.path.name}: FRAME_CONFIG = {dive.config.frame} "
                             f"({dive.config.frame_name}) has no uuvid preset: give --vehicle "
                             "(its geometry turns the thrusts into the generalized force)")
        notes.append(f"vehicle: the {vehicle} preset, which FRAME_CONFIG = {dive.config.frame} "
                     f"({dive.config.frame_name}) stands for (give --vehicle to use another)")
    from uuvid.io.ardusub import check_vehicle

    veh = _load_vehicle(vehicle)
    check_vehicle(dive.config, veh, name=spec.path.name)
    tb = dive.table
    motors = [m.number for m in dive.config.active]
    T = np.vstack([tb[f"thrust_{i}_N"].to_numpy(float) for i in motors])
    B = np.asarray(veh.B, float)
    from uuvid.vehicle.layout import dof_index

    tau = B[dof_index(spec.dof)] @ T
    t = tb["t_s"].to_numpy(float)
    if spec.dof == "heave":
        pos, pos_from = tb["depth_m"].to_numpy(float), dive.depth_source["source"]
        notes.append(f"depth: {dive.depth_source['source']} — {dive.depth_source['why']}")
    else:
        pos, pos_from = tb["yaw_rad"].to_numpy(float), "attitude yaw (unwrapped)"
    closed = None
    if spec.open_loop_only:
        mask, why = dive.open_loop()
        closed = ~mask
        notes.append(f"steady segments from open-loop data only (--all-modes to use every mode): "
                     f"{why}")
    armed = dive.table["armed"].fillna(False).to_numpy(bool)
    info = {"source": spec.path.name, "format": dive.format, "time_base": "autopilot boot",
            "command_from": (f"{_DOF_COLUMN[spec.dof]}: thrust per motor (PWM at the logged "
                             f"battery voltage) through {veh.name}'s B ({spec.dof} row)"),
            "position_from": pos_from, "frame": dive.config.frame,
            "notes": notes, "warnings": warnings,
            "closed_loop_why": why if spec.open_loop_only else None,
            "armed_s": float(np.count_nonzero(armed) * np.median(np.diff(t))) if t.size > 1
            else 0.0}
    keep, okp = np.isfinite(tau), np.isfinite(pos)
    if keep.sum() < 2 or okp.sum() < 5:
        raise ValueError(f"{spec.path.name}: too few samples for {spec.dof} "
                         f"({int(keep.sum())} command, {int(okp.sum())} position)")
    data = LogData(t[keep], tau[keep], t[okp], pos[okp], None, None, info,
                   None if closed is None else closed[keep], t[~okp], t[_missing_between(t, keep)])
    names = {"command": _DOF_COLUMN[spec.dof], "position": pos_from}
    return _finish(data, spec, names, True)


def _missing_between(t: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Rows without a sample (``~ok``) that are missing ones: in a hole of the channel (its
    samples further apart than the reader's gap, :data:`~uuvid.io.ardusub.sources.GAP_FACTOR`
    × its median interval and at least ``GAP_MIN_S``) or outside its first and last sample — not
    the empty rows between the samples of a channel logged slower than the table (2 Hz servo
    outputs on 20 Hz attitude rows)."""
    from uuvid.io.ardusub.sources import GAP_FACTOR, GAP_MIN_S

    ts = t[ok]
    if ts.size < 2:
        return ~ok
    gap = max(GAP_FACTOR * float(np.median(np.diff(ts))), GAP_MIN_S)
    j = np.searchsorted(ts, t)  # the first sample at or after each row
    inside = (j > 0) & (j < ts.size)
    span = np.where(inside, ts[np.clip(j, 0, ts.size - 1)] - ts[np.clip(j - 1, 0, ts.size - 1)],
                    np.inf)
    return ~ok & (span > gap)


def _read_ardusub_fields(spec: LogSpec) -> LogData:
    """Command/position from named ArduSub message fields (``--field command=…``); the servo
    outputs through ``--vehicle`` only when ``--field position=…`` names a position that the
    log's own configuration cannot give."""
    from uuvid.io.logs import ARDUSUB_DATAFLASH_FIELDS, ARDUSUB_TLOG_FIELDS, read_ardusub

    raw = _parse_pairs(spec.fields, "--field")
    scales, fields = {}, {}
    for ch, text in raw.items():
        f, rest = parse_scaled(text)
        # read_ardusub understands a leading '-'; a scale is ours
        scales[ch], fields[ch] = abs(f), ("-" if f < 0 else "") + rest
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
    servo_names = []
    if servo:
        if not spec.vehicle:
            raise ValueError(f"{spec.path.name}: ArduSub logs record the thrusters' PWM outputs, "
                             "not the generalized force: give --vehicle (its thruster models turn "
                             "servo_1…servo_n into thrust, its B matrix into the force) or "
                             "--field command=MESSAGE.field")
        n = _load_vehicle(spec.vehicle).layout.n
        for j in range(1, n + 1):
            servo_names.append(f"servo_{j}")
            req[f"servo_{j}"] = (f"SERVO_OUTPUT_RAW.servo{j}_raw" if tlog else f"RCOU.C{j}")
    units = {}
    if spec.command_unit and not servo:
        units["command"] = spec.command_unit
    if spec.angle_unit or spec.position_unit:
        units["position"] = _position_unit(spec)
    out = read_ardusub(spec.path, req, units=units, allow_missing=True,
                       time=spec.time or "boot", on_duplicate=_reader_duplicates(spec))
    out = _scaled(out, scales)
    info = {"source": spec.path.name, "format": "tlog" if tlog else "dataflash",
            "fields": {k: v for k, v in req.items()}, "time_base": spec.time or "boot"}
    cmd = _servo_command(spec, out, servo_names) if servo else None
    if servo:
        info["command_from"] = (f"servo outputs through {spec.vehicle}'s thruster models and B "
                                f"({spec.dof} component)")
    data = _from_channels(out, spec, info, command=cmd)
    used = out["position"].meta.get("original_names", {}).get("position", req["position"])
    names = {"command": raw.get("command", "servo outputs"), "position": used}
    if "position" not in raw and spec.dof == "heave":  # say which default depth was taken
        data.info.setdefault("notes", []).append(
            f"depth: {used}, the default of a --field read (an altitude the autopilot reports); "
            "without --field command=… the water-pressure sensor (BARO_PRIMARY) is used — give "
            "--field position=… to choose")
    return _finish(data, spec, names, servo)


# ------------------------------------------------------------------------------------------------
# entry point
# ------------------------------------------------------------------------------------------------
def read_vehicle_log(spec: LogSpec | str | Path, dof: str | None = None, **kw) -> LogData:
    """Read the command/position (mode, ballast) series of ``spec`` — a :class:`LogSpec`, or a
    path with ``dof`` and the :class:`LogSpec` fields as keywords.  Raises ``ValueError`` /
    :class:`~uuvid.io.logs.LogDataError` / ``ImportError`` with a message naming file, column,
    row."""
    if not isinstance(spec, LogSpec):
        if dof is None:
            raise ValueError("read_vehicle_log(path, dof=...): say which DOF the log excites")
        spec = LogSpec(Path(spec), dof, **kw)
    elif kw or dof is not None:
        spec = replace(spec, **({"dof": dof} if dof else {}), **kw)
    p = spec.path
    if not p.exists():
        raise ValueError(f"{p}: no such log file")
    if spec.time not in (None, "boot", "log"):
        raise ValueError(f"--time {spec.time!r}: expected boot or log")
    _reader_duplicates(spec)
    data = _read(spec, p)
    data.info["path"] = str(p)
    return data


def _read(spec: LogSpec, p: Path) -> LogData:
    fmt = _detect_format(p, spec.fmt)
    if fmt in ("csv", "parquet"):
        if spec.topics or spec.fields:
            raise ValueError("--topic/--field apply to ROS bags and ArduSub logs, not to "
                             f"{fmt.upper()} files (use the --*-col options)")
        if p.is_dir():
            raise ValueError(f"{p}: a directory, not a CSV/Parquet file")
        for given, opt, why in ((spec.time, "--time", "a table has one time column"),
                                (spec.msg_definitions, "--msg-definitions", "ROS bags only"),
                                (spec.vehicle, "--vehicle", "a table gives the force column; "
                                 "the servo outputs of ArduSub logs and ROS bags need it")):
            if given:
                raise ValueError(f"{opt} does not apply to {fmt.upper()} files ({why})")
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
    if spec.msg_definitions:
        raise ValueError("--msg-definitions applies to ROS bags, not to ArduSub logs")
    return _read_ardusub_log(spec)
