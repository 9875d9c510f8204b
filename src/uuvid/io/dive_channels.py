"""A whole piloted dive as channels on their own stamps, for dive identification and replay.

:func:`read_dive_channels` reads an ArduSub ``.tlog``/``.BIN`` (through
:func:`uuvid.io.ardusub.load_dive`: forces from the servo outputs at the logged battery voltage,
physical wrench ``B·T`` of the given vehicle) or a CSV/Parquet table with force columns
(``t_s``, ``depth_m``, ``yaw_rad``, ``Z_N``, ``N_Nm``, … optional ``armed``, ``mode``,
``u_mps``/``v_mps``), or a ROS 1 ``.bag`` / ROS 2 bag directory as ArduSub + mavros record it
(:mod:`uuvid.io.dive_rosbag`: servo outputs ``/mavros/rc/out``, attitude ``/mavros/imu/data``
turned from ENU/FLU into NED heading, depth from ``/mavros/global_position/rel_alt`` or a pressure,
battery, ``/mavros/state``; ``topics={role: "topic:field"}`` overrides a topic; forces as for a
table's ``pwm_<j>`` columns, reversal from ``params``).  In a table each column keeps its *own*
samples: a row where a column is empty is not a sample of it, so channels at different, irregular
rates stay as logged (no resampling); a bag's topics keep theirs.

Where forces come from servo outputs (a table's ``pwm_<j>``, a bag's ``/mavros/rc/out``) they are
checked against the motion (:func:`uuvid.io.motor_direction.direction_check`): an output whose
heave or yaw force pushes against the measured acceleration — a motor whose direction the table
lacks — is named in a warning with the evidence and the fix; a table's own ``Z_N``/``N_Nm`` go
through the same fit (:func:`~uuvid.io.motor_direction.force_sign_check`), so a depth logged
positive up is asked about on either path.  A path that is no dive log (a
folder that is not a ROS 2 bag, a missing path, a file of unknown kind) is a
:class:`DiveDataError` naming it, what it holds or looks like, and the kinds accepted.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from uuvid.core.checks import arg, arg_is
from uuvid.io.idle_outputs import _inside, _motor_order  # shared with the idle-output check
from uuvid.io.logs import LogDataError, pause_s
from uuvid.io.motor_direction import bag_fix, direction_check, force_sign_check, table_fix

__all__ = ["DiveDataError", "DiveChannels", "read_dive_channels", "DIVE_DOFS", "ThrustRegions",
           "thrust_regions", "PwmFlags", "pwm_flags", "rotor_speeds", "inflow_gain",
           "horizontal_inflow_gain"]

#: DOF → (measured channel, force channel, measured is a position (True) or a velocity)
DIVE_DOFS = {"heave": ("depth_m", "Z_N", True), "yaw": ("yaw_rad", "N_Nm", True),
             "surge": ("u_mps", "X_N", False), "sway": ("v_mps", "Y_N", False)}
_SOURCE_HINT = {"depth_m": "a depth source (ArduSub: BARO/GLOBAL_POSITION_INT; table: depth_m; "
                           "ROS bag: --topic depth=TOPIC:FIELD)",
                "yaw_rad": "a heading source (ArduSub: ATT/ATTITUDE; table: yaw_rad; ROS bag: "
                           "--topic attitude=TOPIC:FIELD)",
                "u_mps": "a surge velocity (DVL; table column u_mps; ROS bag: --topic "
                         "velocity=TOPIC)",
                "v_mps": "a sway velocity (DVL; table column v_mps; ROS bag: --topic "
                         "velocity=TOPIC)"}


#: ``--t-start`` this far (s) before a log's first stamp, ``--t-end`` after its last, is still
#: taken (``--t-start 0`` on a log whose first sample is at 0.04 s); beyond it, an error
SPAN_SLACK_S = 1.0


class DiveDataError(LogDataError):
    """A dive log cannot be used for identification or replay (the message says what to pass)."""


@dataclass
class DiveChannels:
    """Channels ``name → (t, v)`` (finite samples, sorted), armed intervals and provenance."""

    name: str
    format: str
    channels: dict
    armed: list  # [(t0, t1)] armed intervals
    modes: list = field(default_factory=list)  # [(t0, t1, mode)]
    warnings: list = field(default_factory=list)
    sources: dict = field(default_factory=dict)
    pwm: dict = field(default_factory=dict)  # motor → (t, pwm) where logged
    unread: list = field(default_factory=list)  # a table's columns that look like data, not read
    #: channel → ``[(samples left out, why)]`` by the reader's checks (a stuck sensor, spikes)
    left_out: dict = field(default_factory=dict)
    #: DOFs whose measured channel opposes every force in them (the direction check asked about
    #: its sign: a depth logged positive up), :mod:`uuvid.io.motor_direction`
    opposed: list = field(default_factory=list)
    #: logging pauses ``[(t0, t1, where)]``: the last stamp before, the first after and where the
    #: reader found it (a table's column and row; empty: from the channels' stamps)
    pauses: list = field(default_factory=list)
    #: servo outputs found at fault ``{motor: (why, DOFs it drives)}`` — probably reversed, or off
    #: throughout while the others are driven: a model of those DOFs is not one to use
    faulty: dict = field(default_factory=dict)

    def pause_around(self, t_start=None, t_end=None) -> str | None:
        """``"[a, b] s lies inside the logging pause …"`` when the time window asked for has no
        stamp of the log because a logger pause spans it, else ``None`` (the pauses the reader
        found, or the gaps of :func:`~uuvid.io.logs.pause_s` in the channels' stamps)."""
        if t_start is None or t_end is None:
            return None  # an end of the log itself is a sample
        pauses = self.pauses
        if not pauses:
            ts = [c[0] for c in self.channels.values() if c[0].size]
            t = np.unique(np.concatenate(ts)) if ts else np.zeros(0)
            gap = pause_s(t)
            big = np.flatnonzero(np.diff(t) > gap) if gap is not None else []
            pauses = [(float(t[i]), float(t[i + 1]), "") for i in big]
        for p0, p1, where in pauses:
            if p0 <= t_start and t_end <= p1:
                return (f"{self.span_text(t_start, t_end)} lies inside the logging pause "
                        f"{p0:.6g}–{p1:.6g} s" + (f" ({where})" if where else "")
                        + ": no samples there")
        return None

    @property
    def t_range(self) -> tuple[float, float]:
        ts = [c[0] for c in self.channels.values() if c[0].size]
        return float(min(t[0] for t in ts)), float(max(t[-1] for t in ts))

    def span_text(self, t_start=None, t_end=None) -> str:
        """``"[a, b] s"``: the time window asked for, the log's own ends where none is given."""
        try:
            a, b = self.t_range
        except ValueError:  # no samples at all
            a = b = math.nan
        a = a if t_start is None else t_start
        b = b if t_end is None else t_end
        return f"[{a:.6g}, {b:.6g}] s"

    def check_span(self, t_start=None, t_end=None) -> None:
        """Raise :class:`DiveDataError` when ``--t-start``/``--t-end`` miss the log: an end
        before its first stamp or a start after its last, an end after its last stamp or a start
        before its first (by more than :data:`SPAN_SLACK_S`), or a time before the start of a log
        stamped in epoch seconds (its first stamp beyond a day: ``--t-end 180`` meant from the
        start replayed or fitted nothing, or everything)."""
        try:
            a, b = self.t_range
        except ValueError:
            return
        for opt, v in (("t_start", t_start), ("t_end", t_end)):
            if v is None:
                continue
            epoch = a > 86400.0 and v < a
            # an end after the last stamp or a start before the first is an error too (it was
            # accepted: the held-out check skipped with a note), beyond SPAN_SLACK_S
            past = (opt == "t_end" and v > b + SPAN_SLACK_S) or (opt == "t_start"
                                                                 and v < a - SPAN_SLACK_S)
            if epoch or past or (opt == "t_end" and v <= a) or (opt == "t_start" and v >= b):
                raise DiveDataError(
                    f"{self.name}: {arg_is(opt, f'{v:g}')} s is outside the log, whose times run from "
                    f"{a:.10g} to {b:.10g} s" + (" (seconds since 1970?)" if a > 1e8 else "")
                    + ": give the log's own times" + (f" (e.g. {a + v:.10g} for {v:g} s after "
                                                      "its start)" if epoch else ""))

    def require(self, dof: str) -> None:
        """Raise :class:`DiveDataError` when the log lacks what ``dof`` needs."""
        meas, force, _ = DIVE_DOFS[dof]
        if meas not in self.channels or self.channels[meas][0].size < 4:
            n = self.channels[meas][0].size if meas in self.channels else 0
            have = [d for d in DIVE_DOFS if DIVE_DOFS[d][0] in self.channels
                    and self.channels[DIVE_DOFS[d][0]][0].size >= 4]
            gone = self.left_out.get(meas, [])
            if gone:  # the log had them: the reader's checks left them out (said in a warning)
                what = (f"{'only ' + str(n) if n else 'no'} {meas} samples left: "
                        f"{sum(k for k, _ in gone)} were left out as "
                        f"{' and '.join(w for _, w in gone)}; {dof} needs at least 4 that "
                        "follow the vehicle")
            else:
                what = ((f"only {n} {meas} samples (need at least 4)" if n else
                         f"no {meas} samples") + f": {dof} needs {_SOURCE_HINT[meas]}")
            raise DiveDataError(f"{self.name}: {what}; pass "
                                + (f"{arg_is('dofs', '|'.join(have), '--dof')} or " if have else "")
                                + "a log that has it" + self._unread_text())
        if force not in self.channels or self.channels[force][0].size < 2:
            raise DiveDataError(f"{self.name}: no {force} samples (thruster forces): the log has no "
                                "servo outputs / force column; pass an ArduSub log with "
                                "SERVO_OUTPUT_RAW/RCOU or a table with a " + force + " column or "
                                "servo-output columns pwm_1 … pwm_n [µs] (n the vehicle's "
                                "thrusters)" + self._unread_text())

    def require_thrust(self, dof: str, forces, B=None, flags=None, t_start=None,
                       t_end=None) -> None:
        """Raise :class:`DiveDataError` when the log gives ``dof`` no thrust to identify from:
        each of ``forces`` takes one value over the armed samples in ``[t_start, t_end]``
        (:func:`uuvid.io.idle_outputs.idle_force`; the outputs of ``B`` that give it are named
        when they sat in the dead band of the thruster model of ``flags``, :class:`PwmFlags`).
        A model of a vehicle its thrusters never pushed is not determined — mass, drag and bias
        trade off exactly — so none is reported."""
        from uuvid.io.idle_outputs import idle_force

        idle = idle_force(self, forces, B, flags.regions if flags is not None else None,
                          t_start, t_end)
        if idle is not None:
            raise DiveDataError(f"{self.name}: no {dof} thrust to identify from: {idle}")

    def _unread_text(self) -> str:
        return (f" (the table's columns {', '.join(self.unread[:8])} are not read: "
                f"{UNREAD_HINT})" if self.unread else "")


def _finite(t, v):
    t = np.asarray(t, float)
    v = np.asarray(v, float)
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    if t.size == 0:  # a column with no value at all: an empty channel (its users say what lacks)
        return t, v
    o = np.argsort(t, kind="stable")
    t, v = t[o], v[o]
    keep = np.concatenate(([True], np.diff(t) > 0))
    return t[keep], v[keep]


def _intervals(t, flag, holes: bool = True) -> list:
    """``[(t0, t1)]`` runs where ``flag`` is true (a run ends at the next false stamp, or, with
    ``holes``, at the last stamp before a pause in the rows, :func:`~uuvid.io.logs.pause_s` — the
    pauses the reader names: no run, so no fit window, spans one; ``holes=False`` for the stamps
    of a state topic, which may be sparse)."""
    out = []
    t = np.asarray(t, float)
    flag = np.asarray(flag, bool)
    if not flag.any():
        return out
    edges = np.flatnonzero(np.diff(np.concatenate(([0], flag.astype(int), [0]))))
    hole = np.zeros(t.size, bool)  # hole[i]: rows i and i + 1 straddle a pause
    gap = pause_s(t) if holes else None
    if gap is not None:
        hole[:-1] = np.diff(t) > gap
    for a, b in zip(edges[::2], edges[1::2]):
        cuts = np.flatnonzero(hole[a:b - 1]) + a  # last row before each hole inside the run
        start = a
        for c in cuts:
            out.append((float(t[start]), float(t[c])))
            start = c + 1
        end = b - 1 if hole[b - 1] else min(b, t.size - 1)  # the next stamp is past a hole
        out.append((float(t[start]), float(t[end])))
    return out


def _not_utf8(p: Path) -> str:
    """Where the first byte of ``p`` that is not UTF-8 is (pandas' error counts within its own
    decode buffer, not the file), and what to do."""
    import codecs

    dec = codecs.getincrementaldecoder("utf-8")()
    at, line = 0, 1
    with open(p, "rb") as f:
        while True:
            chunk = f.read(1 << 20)
            try:
                dec.decode(chunk, final=not chunk)
            except UnicodeDecodeError as e:
                # e.object: the bytes the decoder held back from the chunk before, then this one
                k = e.start - len(e.object) + len(chunk)  # (< 0: inside the held-back bytes)
                bad = (e.object[e.start:e.start + 1] or b"?")[0]
                line += chunk[:max(k, 0)].count(b"\n")
                return (f"byte 0x{bad:02x} at byte {at + k:,} (line {line:,}) is not UTF-8: a "
                        "file saved in another encoding (Excel's 'CSV' is Latin-1/Windows-1252) — "
                        "re-save it as UTF-8 ('CSV UTF-8'); or not a text file")
            if not chunk:
                return "not UTF-8 text: re-save it as UTF-8 ('CSV UTF-8')"
            at += len(chunk)
            line += chunk.count(b"\n")


def _mode_runs(t, modes) -> list:
    out = []
    modes = np.asarray(modes).astype(str)
    if modes.size == 0:
        return out
    starts = np.flatnonzero(np.concatenate(([True], modes[1:] != modes[:-1])))
    ends = np.concatenate((starts[1:], [modes.size - 1]))
    for a, b in zip(starts, ends):
        out.append((float(t[a]), float(t[b]), str(modes[a])))
    return out


def _vehicle(vehicle):
    from uuvid.vehicle.definition import load_vehicle

    if vehicle is None or hasattr(vehicle, "B"):
        return vehicle
    return load_vehicle(vehicle)


#: beyond these an underwater vehicle's channel is in another unit (checked per dive table)
MAX_DEPTH_RATE = 5.0  # m/s, the 90th percentile over 1 s
MAX_YAW_RATE = 2 * np.pi  # rad/s (a turn per second), likewise
MAX_SPEED = 5.0  # m/s, the 90th percentile of |u|, |v|
BATTERY_RANGE_V = (6.0, 60.0)  # median
MAX_ROW_STEP_S = 5.0  # median step between rows
#: no servo output holds a pulse this long (µs): a whole period at 50 Hz — 65535 (a uint16's
#: overflow) and the like are logger faults, not commands
PWM_SPIKE_US = 20000.0
#: an output at 0 µs this long (s) while armed and the others are driven is worth naming
DEAD_OUTPUT_S = 5.0


#: the units a time column logged as seconds may really be in, and their factor to seconds
_TIME_DIVISORS = ((1e3, "milliseconds"), (1e6, "microseconds"), (1e9, "nanoseconds"))
_TIME_MULTIPLIERS = ((60.0, "minutes"), (3600.0, "hours"))
#: no dive channel is logged faster than this (s; 1 kHz): a shorter median step is a time column
#: in another unit (minutes: a 20 Hz heading read at 1.2 kHz)
MIN_SENSOR_STEP_S = 1e-3


def _check_time_rate(chans: dict, pwm: dict, name: str, tcol: str) -> None:
    """A channel logged every < :data:`MIN_SENSOR_STEP_S` (beyond 1 kHz) is an error naming the
    multiplier that brings it to a sensor's rate — said before the unit checks, which took a time
    in minutes for a depth in cm ("changes by 7 m/s")."""
    steps = {}
    for c, (t, _) in list(chans.items()) + [(f"pwm_{k}", v) for k, v in pwm.items()]:
        d = np.diff(t)
        d = d[d > 0]
        if d.size >= 10:
            steps[c] = float(np.median(d))
    if not steps:
        return
    c = min(steps, key=steps.get)
    fast = steps[c]
    if fast >= MIN_SENSOR_STEP_S:
        return
    mul, unit = next(((m, u) for m, u in _TIME_MULTIPLIERS if fast * m >= MIN_SENSOR_STEP_S),
                     _TIME_MULTIPLIERS[-1])
    raise DiveDataError(
        f"{name}: column {tcol}: {c} is logged every {fast:.3g} s ({1 / fast:,.0f} Hz), faster "
        f"than a vehicle's sensors ({1 / MIN_SENSOR_STEP_S:,.0f} Hz at most): is the time in {unit}? "
        f"multiply it by {mul:g} ({c} every {fast * mul:.3g} s); expected seconds")


def _table_time(df, tcol: str, name: str, warnings: list | None = None) -> np.ndarray:
    """The time column in seconds: every cell a number, never decreasing (rows with the same
    stamp are merged by :func:`_finite`, conflicts refused by :func:`_check_same_stamps`)."""
    import pandas as pd

    raw = df[tcol]
    if pd.api.types.is_timedelta64_dtype(raw):  # a Parquet duration: its integers are ns
        raw = raw.dt.total_seconds()
        if warnings is not None:
            warnings.append(f"{name}: column {tcol} holds durations: read in seconds")
    elif pd.api.types.is_datetime64_any_dtype(raw):
        first = raw.dropna().iloc[0] if raw.notna().any() else None
        raw = (raw - first).dt.total_seconds() if first is not None else raw.astype("float64")
        if warnings is not None:
            warnings.append(f"{name}: column {tcol} holds dates and times: read as seconds from "
                            f"its first stamp ({first})")
    t = pd.to_numeric(raw, errors="coerce").to_numpy(float)
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        cell = raw.iloc[int(bad[0])]
        hint = ("; it looks like a date and time: give seconds (e.g. since the log's start)"
                if isinstance(cell, str) and len(cell) >= 10 and cell[4:5] == "-" else "")
        what = "an empty cell" if pd.isna(cell) else repr(cell)
        raise DiveDataError(f"{name}: column {tcol}, row {bad[0] + 2}: {what} is not a number; "
                            f"every row needs a time stamp in seconds{hint}")
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise DiveDataError(
            f"{name}: column {tcol}, row {i + 2}: {t[i]:.6g} s is before the previous row's "
            f"{t[i - 1]:.6g} s; expected time stamps that never decrease (a logger restart, or two "
            "logs joined? split the file at that row, or shift the later part's time)")
    step = np.diff(t)
    step = step[step > 0]
    if step.size >= 10 and float(np.median(step)) > MAX_ROW_STEP_S:
        med = float(np.median(step))
        # the divisor that brings the step to a sensor's rate ("divide by 1000" left a time in
        # µs at 41.5 s steps)
        div, unit = next(((d, u) for d, u in _TIME_DIVISORS if med / d <= MAX_ROW_STEP_S),
                         _TIME_DIVISORS[-1])
        raise DiveDataError(f"{name}: column {tcol}: the median step between rows is "
                            f"{med:.4g} s; expected seconds at the rate of the sensors (is the "
                            f"time in {unit}? divide it by {div:g}: a step of {med / div:.3g} s)")
    gap = pause_s(t)
    if warnings is not None and gap is not None:
        big = np.flatnonzero(np.diff(t) > gap)
        if big.size:
            i = int(big[0]) + 1
            warnings.append(f"{name}: column {tcol}, row {i + 2}: the log stops for "
                            f"{t[i] - t[i - 1]:.4g} s (from {t[i - 1]:.6g} s)"
                            + (f", and {big.size - 1} more gap(s) over {gap:.3g} s" if big.size > 1
                               else "")
                            + ": a logger pause or two logs joined; no sample spans it, so fit "
                            f"and replay each side on its own ({arg('t_start')}/{arg('t_end')})")
    return t


def _check_same_stamps(t, df, cols, name: str, warnings: list) -> None:
    """Rows with the same time stamp are one sample if their values agree (a repeated row, or
    two senders filling different columns); different values of one column at one stamp are an
    error naming the column and the rows."""
    same = np.flatnonzero(np.diff(t) == 0)
    if not same.size:
        return
    for c in cols:
        v = np.asarray(df[c], float)
        ok = np.flatnonzero(np.isfinite(v))
        if ok.size < 2:
            continue
        tv, vv = t[ok], v[ok]
        clash = np.flatnonzero((np.diff(tv) == 0) & (np.diff(vv) != 0))
        if clash.size:
            a, b = int(ok[clash[0]]), int(ok[clash[0] + 1])
            raise DiveDataError(
                f"{name}: column {c}, rows {a + 2} and {b + 2}: two different values ({v[a]:.6g}, "
                f"{v[b]:.6g}) at the same time stamp {t[a]:.6g} s; expected one value per time "
                "(a second sensor writing into this column? give it a column of its own)")
    warnings.append(f"{name}: {same.size} rows share the previous row's time stamp with no "
                    "conflicting value: merged into one sample each")


def _rate90(t, x, window: float = 1.0) -> float:
    """90th percentile of ``|x(t + window) − x(t)| / window`` over a channel's samples."""
    if t.size < 4:
        return 0.0
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(window / dt))) if dt > 0 else 1
    if t.size <= k:
        return 0.0
    span = t[k:] - t[:-k]
    good = span > 0
    if not good.any():
        return 0.0
    return float(np.percentile(np.abs(x[k:] - x[:-k])[good] / span[good], 90))


def _armed_part(tx: tuple, armed) -> tuple:
    """A channel's samples inside the armed intervals (all of it when those hold under 20): the
    rate checks look where the vehicle moves, not at 20 minutes on deck."""
    if not armed:
        return tx
    t, x = tx
    on = _inside(t, armed)
    return (t[on], x[on]) if on.sum() >= 20 else tx


def _check_units(chans: dict, pwm: dict, name: str, warnings: list, armed=None) -> None:
    """A channel that cannot be in its column's unit for an underwater vehicle is an error saying
    which unit it looks like (depth in cm, heading in degrees, speeds in cm/s, battery in mV, PWM
    normalised).  ``armed``: the rates
    are taken over the armed samples (a long quiet stretch let a heading in degrees through)."""
    if "depth_m" in chans and chans["depth_m"][0].size:
        r = _rate90(*_armed_part(chans["depth_m"], armed))
        if r > MAX_DEPTH_RATE:
            raise DiveDataError(f"{name}: column depth_m changes by {r:.3g} m/s or faster 10 % of "
                                f"the time, beyond {MAX_DEPTH_RATE:g} m/s for an underwater "
                                "vehicle: is it in cm or mm? expected metres (positive down)")
        td, d = chans["depth_m"]
        above = d < -ABOVE_WATER_M
        if above.sum() >= 10 and np.mean(above) >= 0.01:
            k = np.flatnonzero(above)[0]
            warnings.append(
                f"{name}: depth_m reads below −{ABOVE_WATER_M:g} m (above the water) on "
                f"{above.sum()} samples, {100 * np.mean(above):.3g} % (down to {d.min():.3g} m, first at t = "
                f"{td[k]:.6g} s): an offset (the surface pressure taken at depth, or for other "
                "water) or an altitude (positive up)? The heave fit's surface cut-off (depth < "
                f"{SURFACE_CUT_M:g} m) and the on-deck check act on the depth as logged: remove the "
                "offset first (and give a depth positive down)")
    if "yaw_rad" in chans and chans["yaw_rad"][0].size:
        r = _rate90(*_armed_part(chans["yaw_rad"], armed))
        if r > MAX_YAW_RATE:
            raise DiveDataError(f"{name}: column yaw_rad turns at {r:.3g} rad/s or faster 10 % of "
                                f"the time, beyond {MAX_YAW_RATE:.3g} rad/s (a turn per second): "
                                "is it in degrees? expected radians")
    for c in ("u_mps", "v_mps"):
        if c in chans and chans[c][1].size:
            r = float(np.percentile(np.abs(chans[c][1]), 90))
            if r > MAX_SPEED:
                raise DiveDataError(f"{name}: column {c} is {r:.3g} m/s or faster 10 % of the "
                                    f"time, beyond {MAX_SPEED:g} m/s for an underwater vehicle: "
                                    "is it in cm/s or mm/s? expected m/s")
    if "battery_V" in chans and chans["battery_V"][1].size:
        med = float(np.median(chans["battery_V"][1]))
        lo, hi = BATTERY_RANGE_V
        if not lo <= med <= hi:
            raise DiveDataError(f"{name}: column battery_V has median {med:.4g}, outside "
                                f"{lo:g}–{hi:g} V for a vehicle battery: is it in mV, or one cell's "
                                "voltage? expected the pack's volts")
        tb, vb = chans["battery_V"]
        odd = (vb < lo) | (vb > hi)
        if odd.any():  # single glitches (a 0 V sample): thrust at 0 V is no number
            k = np.flatnonzero(odd)
            chans["battery_V"] = (tb[~odd], vb[~odd])
            warnings.append(f"{name}: battery_V is outside {lo:g}–{hi:g} V on {k.size} sample(s) "
                            f"(first at t = {tb[k[0]]:.6g} s: {vb[k[0]]:.4g} V), not a battery "
                            "voltage: those samples are left out and the voltage is interpolated "
                            "across them")
    from uuvid.thruster.chain import PWM_PLAUSIBLE_US

    lo, hi = PWM_PLAUSIBLE_US
    for k, (_, v) in pwm.items():  # (one off throughout: _off_outputs)
        on = v[v != 0]
        if on.size and np.mean((on >= lo) & (on <= hi)) < 0.5:
            raise DiveDataError(f"{name}: column pwm_{k} holds {on.min():.4g}…{on.max():.4g}, not "
                                f"pulse widths: expected µs ({lo:g}–{hi:g}; 0 = output off)")


#: a thruster drives a DOF materially when its entry in the vehicle's allocation ``B`` is at least
#: this share of the DOF's largest (BlueROV2's four horizontal thrusters give yaw a quarter each,
#: its vertical ones nothing)
MATERIAL_SHARE = 0.1
_FORCE_ROW = {"X_N": 0, "Y_N": 1, "Z_N": 2, "K_Nm": 3, "M_Nm": 4, "N_Nm": 5}


def thruster_dofs(B, j: int) -> list:
    """The DOFs of :data:`DIVE_DOFS` that thruster ``j`` (a column of ``B``) drives materially
    (:data:`MATERIAL_SHARE`)."""
    A = np.abs(np.asarray(B, float))
    return [dof for dof, (_, force, _) in DIVE_DOFS.items()
            if A[_FORCE_ROW[force]].max() > 0
            and A[_FORCE_ROW[force], j] >= MATERIAL_SHARE * A[_FORCE_ROW[force]].max()]


def _fault(pwm: dict, veh, k: str, why: str, forces=None) -> tuple:
    """``(why, DOFs)`` of :attr:`DiveChannels.faulty` for output ``k``; ``why`` names the forces
    of the DOFs it drives where it says ``{forces}``.  ``forces``: the force columns computed
    from the outputs (``None``: all) — a DOF whose force the table gives itself is not touched."""
    dofs = [d for d in thruster_dofs(veh.B, _motor_order(pwm).index(k))
            if forces is None or DIVE_DOFS[d][1] in forces]
    return why.format(forces="/".join(DIVE_DOFS[d][1] for d in dofs) or "no force"), dofs


def _off_outputs(pwm: dict, veh, name: str, warnings: list, computed: bool,
                 forces=None) -> dict:
    """A ``pwm_`` output at 0 µs throughout is said (off: no pulse, no thrust).  One of the
    vehicle's own thrusters (the spare outputs are left out before) off while the others are
    driven, with the forces computed from the outputs (``computed``), is said strongly: its force
    is missing from the DOFs it drives (:func:`thruster_dofs`), whose models are not to be used —
    returned as :attr:`DiveChannels.faulty` (``forces``: the force columns computed, ``None``: all;
    a DOF whose force column the table gives is not touched)."""
    keys = _motor_order(pwm)
    off = [k for k in keys if pwm[k][1].size and not np.any(pwm[k][1] != 0)]
    own = (computed and veh is not None and len(keys) == np.shape(veh.B)[1]
           and len(off) < len(keys))
    faulty = {}
    for k in off:
        if not own:
            warnings.append(f"{name}: pwm_{k} is 0 µs throughout: that output is off (no pulse) "
                            "and its thruster gives no thrust")
            continue
        j = keys.index(k) + 1  # the vehicle's thruster (a column of B), not the output's number
        why, dofs = _fault(pwm, veh, k, f"pwm_{k} is 0 µs throughout: thruster {j}'s force is "
                                        "missing from the computed {forces} (check "
                                        f"SERVO{k}_FUNCTION or the logger)", forces)
        if not dofs:  # the DOFs it drives take the table's own force columns
            warnings.append(f"{name}: pwm_{k} is 0 µs throughout: that output is off (no pulse); "
                            "the DOFs its thruster drives take the table's own force columns")
            continue
        names = "/".join(DIVE_DOFS[d][1] for d in dofs)
        warnings.append(
            f"{name}: pwm_{k} is 0 µs throughout while the other outputs are driven: thruster {j} "
            f"of {veh.name} never had a pulse, so its force is missing from the computed "
            + (f"{names} ({', '.join(dofs)}): a model of {' or '.join(dofs)} from this log is "
               "not one to use" if dofs else "forces")
            + f". If the motor ran in the dive, output {k} is not the one that drives it (check "
            f"SERVO{k}_FUNCTION: the motor on another output) or the logger did not record it")
        if dofs:
            faulty[k] = (why, dofs)
    return faulty


def _reversed_faults(named: list, pwm: dict, veh, fix, forces=None) -> dict:
    """:attr:`DiveChannels.faulty` of the outputs the direction check named as probably
    reversed: their force enters the DOFs they drive with the wrong sign (``forces``: the force
    columns computed from the outputs, ``None``: all)."""
    out = {k: _fault(pwm, veh, k, f"pwm_{k} is probably reversed (the motor-direction check's "
                                  "warning): its force enters {forces} with the wrong sign — "
                                  + fix([k]), forces) for k in dict.fromkeys(named)}
    return {k: v for k, v in out.items() if v[1]}


#: a depth this far above zero (m) cannot be a depth: waves and sensor noise at the surface stay
#: within a few cm (10 samples beyond it, 1 % of the log or more, are said: a dive spends little
#: of its time at the surface)
ABOVE_WATER_M = 0.15
#: heave windows shallower than this (m) touch the surface and are left out of the fit
#: (:data:`uuvid.simulate.dive_replay.SURFACE_M`); defined here, where the depth checks name it
SURFACE_CUT_M = 0.2


#: a depth offset worth saying (m): a surface that reads deeper than the surface cut-off hides
#: the surface from the checks that act on it; readings up to this deep while disarmed can be one
SURFACE_OFFSET_MAX_M = 2.0


def _check_surface_reading(chans: dict, armed: list, name: str, warnings: list) -> None:
    """A depth reading steady at ``d₀`` > :data:`SURFACE_CUT_M` while disarmed (≥ 10 s, 20
    samples, 10–90 % spread < 5 cm) that the armed dive never reads shallower than is a surface
    (on deck, floating before the dive) read ``d₀`` too deep — a surface pressure taken for the
    wrong place, a sensor offset.  The surface cut-off and the on-deck check act on the depth as
    logged and then take the surface for water (a +0.3 m offset gave yaw inertia ×7.7 from
    windows on deck): said, with the offset to subtract."""
    if "depth_m" not in chans or chans["depth_m"][0].size < 20 or not armed:
        return
    td, d = chans["depth_m"]
    on = _inside(td, armed)
    off = ~on
    if off.sum() < 20 or not on.any():
        return
    t_off = td[off]
    if float(np.sum(np.diff(t_off)[np.diff(t_off) < 5.0])) < 10.0:
        return
    p10, d0, p90 = np.percentile(d[off], [10, 50, 90])
    if not (SURFACE_CUT_M < d0 <= SURFACE_OFFSET_MAX_M and p90 - p10 < 0.05):
        return
    if float(np.percentile(d[on], 1)) < d0 - 0.05:
        return  # the armed vehicle went above the disarmed reading: that was no surface
    warnings.append(f"{name}: depth_m reads {d0:.3g} m (steady within {p90 - p10:.2g} m) while "
                    f"disarmed and never shallower while armed: if the vehicle sat on deck or at "
                    f"the surface then, every depth reads {d0:.3g} m too deep, and the surface "
                    f"cut-off (depth < {SURFACE_CUT_M:g} m) and the on-deck check take the surface "
                    f"for water; subtract the offset (depth_m − {d0:.3g}) if so (not if the sensor "
                    f"sits {d0:.3g} m below the waterline of a vehicle floating disarmed)")


#: a depth step between consecutive samples faster than this (m/s) is no motion: an ROV climbs or
#: dives at 1–1.5 m/s at most (BlueROV2: about 1), so 5 m/s leaves room for any vehicle uuvid flies
DEPTH_RATE_MAX_MPS = MAX_DEPTH_RATE
#: ... beyond this many times the depth's own noise σ (a high-rate noisy sensor) and at least
#: :data:`DEPTH_JUMP_MIN_M`
DEPTH_JUMP_NOISE = 10.0
DEPTH_JUMP_MIN_M = 0.05
#: a departure that lasts longer than this many samples *and* seconds is a level change (a sensor
#: re-zeroed), not a glitch: not left out by the spike test
SPIKE_MAX_SAMPLES = 5
SPIKE_MAX_S = 2.0
#: ... unless it comes back: a departure that both leaves and returns faster than
#: :data:`DEPTH_RATE_MAX_MPS` between neighbouring samples, back in line with the depth before it,
#: within this many seconds is a glitch of any length (10 samples at 50 m over 3 s in a dive at
#: 5 m were kept as a level change and fitted: heave mass 2.2e7 ± inf)
SPIKE_RETURN_S = 60.0


def _comes_back(t, d, g: int, start: int, tol) -> int | None:
    """The first sample after ``start`` (within :data:`SPIKE_RETURN_S`) that steps from its
    neighbour back towards the good sample ``g`` faster than :data:`DEPTH_RATE_MAX_MPS` (plus
    ``tol``) and lands in line with it: the end of a departure no vehicle makes; ``None``."""
    away = np.sign(d[start] - d[g])
    for j in range(start + 1, t.size):
        if abs(t[j] - t[start]) > SPIKE_RETURN_S:
            break
        step = d[j] - d[j - 1]
        if abs(step) > DEPTH_RATE_MAX_MPS * abs(t[j] - t[j - 1]) + tol and np.sign(step) == -away \
                and abs(d[j] - d[g]) <= DEPTH_RATE_MAX_MPS * abs(t[j] - t[g]) + tol:
            return j
    return None


def _jump_pass(t, d, tol) -> np.ndarray:
    """Samples that jump from the last good one by more than ``DEPTH_RATE_MAX_MPS·Δt + tol`` and
    back again (the next good sample's step from them beyond the bound too) within
    :data:`SPIKE_MAX_SAMPLES` samples or :data:`SPIKE_MAX_S` s (one pass, in the order given).
    A departure that stays (no jump back) is a new level: its first sample becomes the good one."""
    def jump(i, j) -> bool:
        return abs(d[i] - d[j]) > DEPTH_RATE_MAX_MPS * abs(t[i] - t[j]) + tol

    bad = np.zeros(t.size, bool)
    g, run, i = 0, [], 1
    while i < t.size:
        if jump(i, g):
            run.append(i)
            if len(run) <= SPIKE_MAX_SAMPLES or abs(t[run[-1]] - t[run[0]]) <= SPIKE_MAX_S:
                i += 1
                continue
        elif not run or jump(i, run[-1]):  # in line with the last good sample: back from a spike
            bad[run] = True
            g, run, i = i, [], i + 1
            continue
        back = _comes_back(t, d, g, run[0], tol) if run else None
        if back is not None:  # a long departure that returns at an impossible rate: a glitch
            bad[run[0]:back] = True
            g, run, i = back, [], back + 1
            continue
        g, i, run = run[0], run[0] + 1, []  # a departure that stays: a new level from its start
    if run and (len(run) <= SPIKE_MAX_SAMPLES or abs(t[run[-1]] - t[run[0]]) <= SPIKE_MAX_S):
        bad[run] = True  # a glitch at the end of the log
    return bad


def _drop_depth_spikes(chans: dict, name: str, warnings: list, left_out: dict,
                       rows=None) -> None:
    """Leave out (and say, with time, value and — for a table, ``rows`` its per-row stamps — row)
    the depth samples no vehicle can produce: a step from the last good sample beyond
    :data:`DEPTH_RATE_MAX_MPS` × the time between them plus the larger of
    :data:`DEPTH_JUMP_NOISE` × the depth's noise σ (median absolute deviation of each sample from
    the line through its neighbours) and :data:`DEPTH_JUMP_MIN_M`, that comes back within
    :data:`SPIKE_MAX_SAMPLES` samples or :data:`SPIKE_MAX_S` s.  Tested forward and backward (a
    glitch on the first samples is found from the end).  One bad sample (1e6 m, or 20 m) fitted
    as motion gave a heave model with mass σ ×10⁵ its value, written as if usable; the samples
    are left out (the windows then see the neighbours), the rest of the dive kept.  A level
    change that does not come back (a re-zeroed sensor) is not a spike and is kept."""
    if "depth_m" not in chans or chans["depth_m"][0].size < 5:
        return
    t, d = chans["depth_m"]
    a = (t[2:] - t[1:-1]) / (t[2:] - t[:-2])
    e = (d[1:-1] - (a * d[:-2] + (1 - a) * d[2:])) / np.sqrt(1 + a * a + (1 - a) ** 2)
    sigma = float(1.4826 * np.nanmedian(np.abs(e - np.nanmedian(e))))  # (NaN: repeated stamps)
    sigma = sigma if math.isfinite(sigma) else 0.0
    tol = max(DEPTH_JUMP_NOISE * sigma, DEPTH_JUMP_MIN_M)
    step = np.abs(np.diff(d)) - DEPTH_RATE_MAX_MPS * np.diff(t)
    if not np.any(step > tol):  # the usual log: no step beyond the bound, nothing to search
        return
    bad = _jump_pass(t, d, tol) | _jump_pass(t[::-1], d[::-1], tol)[::-1]
    if not bad.any():
        return
    chans["depth_m"] = (t[~bad], d[~bad])
    left_out.setdefault("depth_m", []).append((int(bad.sum()), "depth spikes"))
    k = np.flatnonzero(bad)

    def at(i) -> str:
        row = (f" (row {int(np.searchsorted(rows, t[i])) + 2})" if rows is not None else "")
        return f"{d[i]:.6g} m at t = {t[i]:.6g} s{row}"

    more = f" and {k.size - 3} more, the last {at(k[-1])}" if k.size > 3 else ""
    warnings.append(f"{name}: {k.size} depth_m sample(s) jump away from their neighbours faster "
                    f"than {DEPTH_RATE_MAX_MPS:g} m/s (beyond {tol:.3g} m of noise) and come "
                    f"back: {', '.join(at(i) for i in k[:3])}{more} — a sensor or logging "
                    "glitch, not motion: those samples are left out")


#: a measured channel repeating one value exactly for this long (s, ≥ 20 samples) while armed is
#: a stuck sensor or a logger repeating its last reading, not a vehicle holding still (a real
#: heading or depth moves by its noise)
STUCK_S = 10.0


def _drop_stuck(chans: dict, armed: list, name: str, warnings: list,
                left_out: dict | None = None) -> None:
    """Leave out (and say) the stretches where ``depth_m`` or ``yaw_rad`` repeats one value
    exactly for :data:`STUCK_S` or longer while armed and its DOF's force is driven (a vehicle at
    rest on the bottom may repeat a quantised heading): fitted as a vehicle that did not move
    under its thrust they bias drag and inertia (a heading stuck at 0 for 100 s gave yaw linear
    drag ×10)."""
    for c, force in (("depth_m", "Z_N"), ("yaw_rad", "N_Nm")):
        if c not in chans or chans[c][0].size < 20:
            continue
        t, v = chans[c]
        tf, f = chans.get(force, (np.empty(0), np.empty(0)))
        span = float(np.ptp(f)) if f.size else 0.0
        change = np.flatnonzero(np.diff(v) != 0)
        starts = np.concatenate(([0], change + 1))
        ends = np.concatenate((change, [v.size - 1]))
        drop = np.zeros(v.size, bool)
        spans = []
        for a, b in zip(starts, ends):
            if b - a + 1 < 20 or t[b] - t[a] < STUCK_S:
                continue
            mid = 0.5 * (t[a] + t[b])
            if not any(lo <= mid <= hi for lo, hi in armed):
                continue
            if span > 0:  # only while its thrust was driven: a vehicle at rest may repeat a value
                fr = f[(tf >= t[a]) & (tf <= t[b])]
                if fr.size < 2 or float(np.ptp(fr)) < 0.1 * span:
                    continue
            drop[a:b + 1] = True
            spans.append((t[a], t[b], v[a]))
        if spans:
            chans[c] = (t[~drop], v[~drop])
            if left_out is not None:
                left_out.setdefault(c, []).append((int(drop.sum()), "a stuck sensor"))
            a, b, val = spans[0]
            if c == "yaw_rad":  # said as logged: wrapped (the reader unwraps headings)
                val = (val + math.pi) % (2 * math.pi) - math.pi
            more = f" and {len(spans) - 1} more stretch(es)" if len(spans) > 1 else ""
            warnings.append(f"{name}: {c} repeats {val:.6g} exactly from t = {a:.6g} to {b:.6g} s"
                            f"{more} while armed: a stuck sensor (or a logger repeating its last "
                            f"value), not a vehicle holding still — those samples are left out")


def _check_neutral_outputs(pwm: dict, armed: list, veh, name: str, warnings: list,
                           min_s: float = DEAD_OUTPUT_S) -> list:
    """An output that sits within ±2 µs of one value near neutral (1450–1550 µs) for 95 % of the
    armed time in which a thruster the mixer drives alike is driven beyond ±25 µs (0 µs, no
    pulse, is not driven), for more than ``min_s`` s, is said: its motor is on another output
    (a SERVOn_FUNCTION or a column that is not its output) or disabled — the fit reads it as
    giving no thrust (one vertical thruster of two read as idle doubles the heave force
    attributed to the other).
    Driven alike: the columns of ``B`` in the DOFs a pilot commands (surge, sway, heave, yaw; roll
    and pitch are held), each DOF scaled by its largest entry, parallel within 18° — BlueROV2's
    vertical pair, not its diagonal horizontal thrusters, which a turn with surge drives apart.
    Returns the outputs said."""
    keys = _motor_order(pwm)
    if veh is None or len(keys) != veh.B.shape[1] or len(keys) < 2:
        return []
    F = np.asarray(veh.B, float)[[0, 1, 2, 5]]
    scale = np.abs(F).max(axis=1, keepdims=True)
    F = F / np.where(scale > 0, scale, 1.0)
    nrm = np.linalg.norm(F, axis=0)
    said = []
    for i, k in enumerate(keys):
        t, v = pwm[k]
        if nrm[i] == 0 or not t.size:
            continue
        on = _inside(t, armed)
        partners = [j for j, kj in enumerate(keys) if j != i and nrm[j] > 0
                    and abs(F[:, i] @ F[:, j]) / (nrm[i] * nrm[j]) > 0.95]
        driven = np.zeros(t.size, bool)
        who = []
        for j in partners:
            tj, vj = pwm[keys[j]]
            if not tj.size:
                continue
            idx = np.clip(np.searchsorted(tj, t), 0, tj.size - 1)
            d = (np.abs(vj[idx] - 1500.0) > 25.0) & (vj[idx] != 0)  # 0 µs: no pulse, not driven
            if d.any():
                who.append(keys[j])
            driven |= d
        sel = on & driven & (v != 0)
        if sel.sum() < 20:
            continue
        dt = np.diff(t, append=t[-1])
        if float(dt[sel].sum()) <= min_s:
            continue
        v0 = float(np.median(v[sel]))  # within ±2 µs: PWM captured or resampled off the vehicle
        if 1450.0 <= v0 <= 1550.0 and np.mean(np.abs(v[sel] - v0) <= 2.0) >= 0.95:
            said.append((k, v0, float(dt[sel].sum()), who))
    for k, v0, dur, who in said:
        warnings.append(f"{name}: pwm_{k} sits at {v0:.6g} µs (neutral) for {dur:.3g} s while "
                        f"armed and pwm_{', pwm_'.join(who)} — which the mixer drives alike — is "
                        "driven: its motor is on another output (check "
                        "SERVOn_FUNCTION, or which column is its output) or disabled; it is taken "
                        "as giving no thrust there")
    return [k for k, *_ in said]


def _check_idle(pwm: dict, armed: list, veh, name: str, warnings: list, thrust_model=None, *,
                idle: bool = True) -> None:
    """The outputs said at neutral beside a driven partner (:func:`_check_neutral_outputs`), then
    (``idle``: the forces come from them) those that never leave the dead band of the thrust
    model (a file or preset; default the T200's) while armed
    (:func:`uuvid.io.idle_outputs.idle_output_check`: every output, or some while others push)."""
    said = _check_neutral_outputs(pwm, armed, veh, name, warnings)
    if not (pwm and idle):
        return
    from uuvid.io.ardusub.thrust import default_t200, load_thrust_model
    from uuvid.io.idle_outputs import idle_output_check

    tm = thrust_model
    if isinstance(tm, (str, Path)):
        import warnings as _w

        with _w.catch_warnings():  # loaded (and said) by the reader already
            _w.simplefilter("ignore")
            try:
                tm = load_thrust_model(tm)
            except (LogDataError, OSError, ValueError):
                return
    regions = thrust_regions(tm if tm is not None else default_t200())
    idle_output_check(pwm, armed, veh, name, warnings, regions, skip=said)


def _check_dead_outputs(pwm: dict, armed: list, name: str, warnings: list,
                        min_s: float = DEAD_OUTPUT_S) -> None:
    """An output at 0 µs (no pulse) for more than ``min_s`` while armed and the other outputs are
    driven — a dead ESC, a loose connector — is said with its time span: its thruster is taken as
    giving no thrust there, which the fit reads as the vehicle's own dynamics."""
    for k, (t, v) in pwm.items():
        if not v.size or not np.any(v != 0):
            continue  # off throughout: said by the unit check
        on = _inside(t, armed)
        others = np.zeros(t.size, bool)
        for j, (tj, vj) in pwm.items():
            if j != k and tj.size:
                i = np.clip(np.searchsorted(tj, t), 0, tj.size - 1)
                others |= vj[i] != 0
        runs = [(a, b) for a, b in _intervals(t, on & (v == 0) & others) if b - a > min_s]
        if runs:
            a, b = max(runs, key=lambda r: r[1] - r[0])
            warnings.append(f"{name}: pwm_{k} is 0 µs (no pulse) from {a:.6g} to {b:.6g} s while "
                            "armed and the other outputs are driven"
                            + (f" (and {len(runs) - 1} more stretch(es))" if len(runs) > 1 else "")
                            + ": a dead ESC or a loose connector? its thruster is taken as giving "
                            f"no thrust there; leave that time out ({arg('t_start')}/"
                            f"{arg('t_end')}) if it did")


def _check_pwm_cells(v, c: str, name: str) -> None:
    """A column of pulse widths with a few cells no servo output can hold — longer than
    :data:`PWM_SPIKE_US` (65535: a logger's overflow) — is an error naming the first; a
    column mostly outside the ESC's range is a unit question (:func:`_check_units`), and values
    just past it are clipped by the ESC (said by the thrust model)."""
    from uuvid.thruster.chain import PWM_PLAUSIBLE_US

    lo, hi = PWM_PLAUSIBLE_US
    on = np.isfinite(v) & (v != 0)
    out = on & (np.abs(v) > PWM_SPIKE_US)
    if out.any() and np.sum(on & (v >= lo) & (v <= hi)) >= 0.5 * on.sum():
        i = int(np.flatnonzero(out)[0])
        raise DiveDataError(f"{name}: column {c}, row {i + 2}: {v[i]:.6g} is not a pulse width "
                            f"({out.sum()} such cell(s)); expected µs (ESCs take about "
                            f"{lo:g}–{hi:g}; 0 or an empty cell for an output that is off)")


_ARMED_WORDS = ("true", "false", "1", "0", "1.0", "0.0", "yes", "no", "nan", "")

#: the measured and force columns a dive table may have (SI units)
TABLE_CHANNELS = ("depth_m", "yaw_rad", "roll_rad", "pitch_rad", "u_mps", "v_mps", "battery_V",
                  "X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm")


#: column names that mean a channel uuvid reads under another name: (pattern, the channel)
_SYNONYMS = ((r"(heading|hdg|yaw)(_?(deg|degrees|rad|radians))?", "yaw_rad"),
             (r"depth(_?(cm|mm|ft|m))?|rel_?depth", "depth_m"),
             (r"roll(_?(deg|rad))?", "roll_rad"), (r"pitch(_?(deg|rad))?", "pitch_rad"),
             (r"(servo|rcou|pwm|motor|output|ch)_?(\d+)(_?(raw|us|pwm))?", "pwm_"),
             (r"(batt(ery)?_?(volt(age)?s?|v)|volt(age)?s?|vbat(t)?)(_?v)?", "battery_V"),
             (r"(surge|dvl_?u|vel_?x|vx)(_?(mps|m_s|ms))?", "u_mps"),
             (r"(sway|dvl_?v|vel_?y|vy)(_?(mps|m_s|ms))?", "v_mps"),
             (r"arm(ed)?(_?(state|flag))?|is_?armed", "armed"))
UNREAD_HINT = ("uuvid reads t_s [s], depth_m [m, down], yaw_rad [rad, clockwise from north], "
               "roll_rad, pitch_rad, u_mps, v_mps, battery_V, pwm_1 … pwm_n [µs], X_N … N_Nm, "
               "armed, mode: rename them, in those units, to have them used")


#: the unit each channel is read in, for a column whose name gives another (``depth [cm]``)
_CHANNEL_UNIT = {"depth_m": "m", "yaw_rad": "rad", "roll_rad": "rad", "pitch_rad": "rad",
                 "u_mps": "m/s", "v_mps": "m/s", "battery_V": "V", "pwm_": "µs"}


def _unread_columns(cols, read) -> list:
    """``["heading_deg (yaw_rad?)", "depth [cm] (depth_m? in m, not cm)", …]``: a table's
    columns whose name means a channel uuvid reads under another name (a heading in degrees,
    ``servo1``, ``depth``, a unit in brackets) and that nothing reads; the others (a temperature,
    a second clock) are :func:`_other_columns`."""
    import re

    out = []
    for c in map(str, cols):
        if c in read:
            continue
        k = c.strip().lower()
        unit = re.fullmatch(r"(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]", k)  # "depth [cm]", "depth (m)"
        if unit:
            k = f"{unit.group(1)}_{unit.group(2)}" if unit.group(2) else unit.group(1)
        k = re.sub(r"\s+", "_", k)
        for pat, target in _SYNONYMS:
            m = re.fullmatch(pat, k)
            if m:
                want = _CHANNEL_UNIT.get(target)
                if target == "pwm_":
                    target = f"pwm_{int(m.group(2))}"
                if target not in read:
                    given = unit.group(2).strip() if unit else ""
                    hint = (f" in {want}, not {given}" if want and given and given != want.lower()
                            else "")
                    out.append(f"{c} ({target}?{hint})")
                break
    return out


def _other_columns(cols, read, unread) -> list:
    """A table's columns nothing reads and that do not look like a channel (``temp [C]``)."""
    named = {u.rsplit(" (", 1)[0] for u in unread}
    return [c for c in map(str, cols) if c not in read and c not in named]


def _numeric_column(df, c, name: str) -> np.ndarray:
    """A column as floats (empty cells NaN); a cell that is not a number is an error naming it."""
    import pandas as pd

    try:
        v = np.asarray(df[c], float)
    except (TypeError, ValueError):
        num = pd.to_numeric(df[c], errors="coerce")
        bad = np.flatnonzero(num.isna().to_numpy() & df[c].notna().to_numpy())
        i = int(bad[0]) if bad.size else 0
        raise DiveDataError(f"{name}: column {c}, row {i + 2}: {df[c].iloc[i]!r} is not a number; "
                            "expected numbers (SI units) or empty cells") from None
    inf = np.flatnonzero(np.isinf(v))
    if inf.size:  # a logger's overflow, never a measurement: not dropped like an empty cell
        raise DiveDataError(f"{name}: column {c}, row {inf[0] + 2}: {v[inf[0]]} is not a "
                            "measurement; expected a finite number or an empty cell")
    return v


def _semicolon_message(name: str, decimal_comma: str | None = None) -> str:
    """A semicolon CSV refused; ``decimal_comma``: where its numbers have decimal commas."""
    return (f"{name}: the columns are separated by ';' (a semicolon CSV, often with decimal "
            "commas" + (f"; this one has them: {decimal_comma}" if decimal_comma else "") + "); expected "
            "',' between columns and '.' as the decimal point: re-save the file as such")


def _refuse_semicolons(p: Path) -> None:
    """A CSV pandas cannot split whose header holds ';' (a semicolon CSV with decimal commas:
    its header one column, its rows "0,03;…;-2,6" several): the semicolon message, with the first
    decimal comma's row and column, instead of pandas' "Expected 5 fields in line 14, saw 14"."""
    import re

    with open(p, encoding="utf-8", errors="replace") as f:
        lines = [f.readline() for _ in range(200)]
    head = lines[0].rstrip("\r\n").split(";")
    if len(head) < 2:
        return
    where = None
    for r, line in enumerate(lines[1:], start=2):
        for c, cell in enumerate(line.rstrip("\r\n").split(";")):
            if re.fullmatch(r"\s*[-+]?\d*,\d+\s*", cell):
                col = head[c] if c < len(head) else f"field {c + 1}"
                where = f"row {r}, column {col.strip()} ({cell.strip()!r})"
                break
        if where:
            break
    raise DiveDataError(_semicolon_message(p.name, where))


def _canonical_names(df, name: str, warnings: list):
    """Columns that are a known one but for case or surrounding spaces ('Depth_m ') are read as
    it, and said; a file of one column whose header holds ';' is refused (a semicolon CSV)."""
    cols = [str(c) for c in df.columns]
    if len(cols) == 1 and ";" in cols[0]:
        raise DiveDataError(_semicolon_message(name))

    known = {k.lower(): k for k in (*TABLE_CHANNELS, "t_s", "armed", "mode")}
    ren = {}
    for c in cols:
        k = c.strip().lower()
        target = known.get(k) or (f"pwm_{k[4:]}" if k.startswith("pwm_") else None)
        if target and target != c and target not in cols:
            ren[c] = target
    if ren:
        warnings.append(f"{name}: column(s) " + ", ".join(f"{a!r} read as {b}" for a, b in
                                                          ren.items())
                        + " (matched ignoring case and surrounding spaces, and used; rename "
                          "the column(s) to that spelling to silence this warning)")
        df = df.rename(columns=ren)
    return df


def _check_duplicate_columns(df, name: str) -> None:
    """Two columns of one name (pandas reads the second 'depth_m' as 'depth_m.1'; a DataFrame
    may hold both) would leave one sensor silently unread: an error naming them."""
    import re

    cols = [str(c) for c in df.columns]
    known = {*TABLE_CHANNELS, "t_s", "t", "armed", "mode"}
    for i, c in enumerate(cols):
        m = re.fullmatch(r"(.+)\.(\d+)", c)
        base = m.group(1) if m else None
        if c in cols[:i] or (base is not None and base in cols[:i]
                             and (base in known or base.startswith("pwm_"))):
            first = base if (base is not None and c not in cols[:i]) else c
            raise DiveDataError(f"{name}: column {first!r} appears twice (columns "
                                f"{cols.index(first) + 1} and {i + 1}): which sensor is it? give "
                                "each column its own name (e.g. depth2_m), and keep the one "
                                "uuvid should read as depth_m")


def _export_meta(p: Path, df) -> dict | None:
    """The provenance ``uuvid log export`` wrote with a table (the sidecar ``<file>.csv.json``, or
    a Parquet file's ``uuvid`` metadata), or ``None`` (another table, or unreadable provenance)."""
    import json

    try:
        if df is None:
            side = p.with_name(p.name + ".json")
            if not side.is_file():
                return None
            meta = json.loads(side.read_text())
        else:
            raw = (df.attrs or {}).get("uuvid")
            if raw is None:
                import pyarrow.parquet as pq

                raw = (pq.read_schema(p).metadata or {}).get(b"uuvid")
            if raw is None:
                return None
            meta = json.loads(raw)
    except (OSError, ValueError, ImportError):
        return None
    if not isinstance(meta, dict) or "force_basis" not in meta or "config" not in meta:
        return None
    return meta


def _export_directions(meta: dict, pwm: dict) -> dict | None:
    """``{motor: MOT_n_DIRECTION}`` an export recorded for its ``pwm_<motor>`` columns."""
    try:
        d = {str(int(m["motor"])): float(m["direction"]) for m in meta["config"]["motors"]
             if not m.get("disabled")}
    except (KeyError, TypeError, ValueError):
        return None
    return d if set(pwm) <= set(d) else None


def _from_table(df, name: str, fmt: str, veh, warnings: list, *,
                export: dict | None = None, params: tuple | None = None) -> DiveChannels:
    """A table's channels; ``params``: ``({NAME: value}, where)`` of ``--params``, whose
    ``MOT_n_DIRECTION`` the forces computed from the ``pwm_`` columns take
    (:func:`_param_directions`)."""
    _check_duplicate_columns(df, name)
    df = _canonical_names(df, name, warnings)
    cols = list(df.columns)
    tcol = "t_s" if "t_s" in cols else ("t" if "t" in cols else None)
    if tcol is None:
        raise DiveDataError(f"{name}: no time column: expected t_s (seconds); columns are "
                            f"{', '.join(map(str, cols[:12]))}")
    if len(df) == 0:
        raise DiveDataError(f"{name}: no data rows under the header")
    t = _table_time(df, tcol, name, warnings)
    gap = pause_s(t)
    pauses = [(float(t[i]), float(t[i + 1]), f"column {tcol}, row {i + 3}")
              for i in (np.flatnonzero(np.diff(t) > gap) if gap is not None else [])]
    chans = {}
    for c in TABLE_CHANNELS:
        if c in cols:
            chans[c] = _finite(t, _numeric_column(df, c, name))
    if "yaw_rad" in chans:  # headings may be logged wrapped to ±π
        ty, y = chans["yaw_rad"]
        chans["yaw_rad"] = (ty, np.unwrap(y))
    pwm = {}
    for c in cols:
        if str(c).startswith("pwm_"):
            v = _numeric_column(df, c, name)
            _check_pwm_cells(v, str(c), name)
            pwm[str(c)[4:]] = _finite(t, v)
    _check_same_stamps(t, df, [c for c in cols if c in chans or str(c).startswith("pwm_")], name,
                       warnings)
    if veh is not None and pwm and len(pwm) != veh.B.shape[1]:
        _drop_spare_outputs(pwm, veh, name, warnings)
    if "armed" in cols:
        a = df["armed"]
        word = a.map(lambda x: str(x).strip().lower())
        odd = np.flatnonzero(~word.isin(_ARMED_WORDS).to_numpy() & a.notna().to_numpy())
        if odd.size:
            raise DiveDataError(f"{name}: column armed, row {odd[0] + 2}: {a.iloc[odd[0]]!r}; "
                                "expected true/false, 1/0 or yes/no (empty: not armed, unless "
                                "the column is a state on its own rows)")
        am = _armed_flags(word, a, name, warnings)
        armed = _intervals(t, am)
    else:
        armed = _intervals(t, np.ones(t.size, bool))  # all of it, a run each side of a pause
        warnings.append(f"{name}: no 'armed' column: every row is taken as armed (default)")
    left_out: dict = {}
    _check_time_rate(chans, pwm, name, tcol)  # (a time in minutes: no depth in cm)
    _check_units(chans, pwm, name, warnings, armed)  # (a depth in cm is no run of spikes)
    _drop_depth_spikes(chans, name, warnings, left_out, rows=t)
    forces = ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm")
    directions = None
    if export is not None:  # written by `uuvid log export`: its forces' basis and motor directions
        directions = _export_directions(export, pwm) if pwm else None
        made_for = export.get("vehicle")
        have = [c for c in forces if c in chans]
        if have and made_for is None:
            if not (pwm and veh is not None and directions is not None):
                raise DiveDataError(
                    f"{name}: exported without a vehicle (`uuvid log export` with no --vehicle): "
                    "its X_N … N_Nm are ArduSub's mixing sums Σ f_i·T_i and K/M/N_Nm are N per "
                    "unit mixing factor, not N·m; give --vehicle (its geometry turns the pwm_ "
                    "columns into forces), or export again with --vehicle")
            for c in have:
                del chans[c]
            warnings.append(f"{name}: the export's X_N … N_Nm are ArduSub's mixing sums (exported "
                            "without --vehicle; K/M/N_Nm are not N·m), so they are not used: the "
                            f"forces are computed from the pwm_ columns with {veh.name}'s geometry")
        elif have and veh is not None and made_for not in (None, veh.name):
            if pwm and directions is not None:
                for c in have:
                    del chans[c]
                warnings.append(f"{name}: exported with vehicle {made_for!r}, read as "
                                f"{veh.name!r}: the export's forces are not used, they are "
                                f"computed from the pwm_ columns with {veh.name}'s geometry")
            else:
                warnings.append(f"{name}: exported with vehicle {made_for!r}, read as "
                                f"{veh.name!r}: the export's forces are {made_for}'s")
    missing = [c for c in forces if c not in chans]
    label = None if directions is None else \
        "the pwm_ columns (the log's motor directions, from the export)"
    if params is not None:
        directions = _param_directions(params, pwm, directions, name, warnings,
                                       used=bool(missing and pwm and veh is not None))
        label = f"the pwm_ columns (MOT_n_DIRECTION from {params[1]})"
    thrust = None
    if missing and pwm and veh is not None:
        thrust = _forces_from_pwm(chans, pwm, veh, name, warnings, directions=directions,
                                  label=label)
    if not missing and pwm and export is None:
        warnings.append(f"{name}: the table has all six force columns (X_N … N_Nm) and pwm_ "
                        "columns: the forces are used and the pwm_ columns are not (remove the "
                        "force columns to have the thrust computed from the PWM)")
        if veh is not None:
            _check_force_scale(chans, pwm, veh, armed, name, warnings, directions, label)
    computed = thrust.computed if thrust is not None else ()
    faulty = _off_outputs(pwm, veh, name, warnings, computed=thrust is not None, forces=computed)
    _check_dead_outputs(pwm, armed, name, warnings)
    _check_idle(pwm, armed, veh, name, warnings, idle=thrust is not None)  # (forces from pwm)
    _check_surface_reading(chans, armed, name, warnings)
    _drop_stuck(chans, armed, name, warnings, left_out)
    opposed = []
    if thrust is not None:
        fix, named = table_fix if directions is None else bag_fix(directions), []
        opposed += direction_check(chans, thrust, veh, armed, name, warnings, fix, named=named)
        faulty.update(_reversed_faults(named, pwm, veh, fix, computed))
    own = [c for c in ("Z_N", "N_Nm") if c in chans and c not in (thrust.computed if thrust
                                                                   is not None else ())]
    if own:  # the table's own force columns: the same check of the measured channels' sign
        opposed += force_sign_check(chans, veh, armed, name, warnings, own)
    modes = _mode_runs(t, df["mode"].to_numpy()) if "mode" in cols else []
    src = {c: f"{name}:{c}" for c in chans}
    for c in (thrust.computed if thrust is not None else ()):
        src[c] = f"{name}: computed from pwm_{thrust.keys[0]}…pwm_{thrust.keys[-1]}"
    read = {c for c in map(str, cols) if c in TABLE_CHANNELS or c in (tcol, "armed", "mode")
            or c.startswith("pwm_")}
    unread = _unread_columns(cols, read)
    if unread:
        warnings.append(f"{name}: column(s) {', '.join(unread[:8])} not read ({UNREAD_HINT})")
    other = _other_columns(cols, read, unread)
    if other:  # said too: a channel under a name uuvid does not know is not read either
        more = f" and {len(other) - 8} more" if len(other) > 8 else ""
        warnings.append(f"{name}: column(s) {', '.join(other[:8])}{more} not read: not a channel "
                        f"uuvid uses ({UNREAD_HINT})")
    return DiveChannels(name, fmt, chans, armed, modes, warnings, src, pwm, unread, left_out,
                        opposed, pauses, faulty)


def _param_directions(params: tuple, pwm: dict, export_dirs: dict | None, name: str,
                      warnings: list, used: bool) -> dict | None:
    """``{motor: ±1}`` for a table's ``pwm_<n>`` columns (column n is motor n, as `uuvid log
    export` writes them) from ``--params``' ``MOT_n_DIRECTION`` (a motor it does not name keeps
    the export's direction, or +1), as the ArduSub and bag readers apply it
    (:func:`~uuvid.io.ardusub.frames.effective_pwm`).  ``SERVOn_FUNCTION`` maps outputs to
    motors; a table's columns are motors already, so a mapping other than n → n is said as not
    applied.  Said too: a file that gives no direction, a table whose forces are its own columns
    (``used`` false: nothing to apply the directions to)."""
    from uuvid.io.ardusub.frames import MOTOR_FUNCTIONS

    prm, where = params
    if not used:
        warnings.append(f"{name}: {where}: "
                        + ("the table's force columns X_N … N_Nm are used as they are"
                           if pwm else "the table has no pwm_ columns") +
                        ", so its MOT_n_DIRECTION is not applied to anything")
        return export_dirs
    d = {k: float((export_dirs or {}).get(k, 1.0)) for k in pwm}
    given = [k for k in _motor_order(pwm) if f"MOT_{k}_DIRECTION" in prm]
    for k in given:
        v = float(prm[f"MOT_{k}_DIRECTION"])
        if v not in (1.0, -1.0):
            warnings.append(f"{name}: MOT_{k}_DIRECTION = {v:g} in {where} is neither 1 nor -1; "
                            "its sign is used")
        d[k] = -1.0 if v < 0 else 1.0
    if not given:
        warnings.append(f"{name}: {where} gives no MOT_n_DIRECTION for motors "
                        f"{', '.join(_motor_order(pwm))}: " + ("the export's directions kept"
                                                               if export_dirs else
                                                               "+1 (normal) assumed"))
    moved = []
    for key, v in prm.items():
        out = key[5:-9] if key.startswith("SERVO") and key.endswith("_FUNCTION") else ""
        mot = MOTOR_FUNCTIONS.get(int(round(float(v)))) if out.isdigit() else None
        if out in pwm and mot is not None and str(mot) != out:
            moved.append(f"SERVO{out}_FUNCTION → motor {mot}")
    if moved:
        warnings.append(f"{name}: {where}: {', '.join(moved[:4])} not applied — a table's pwm_<n> "
                        "column is read as motor n (as `uuvid log export` writes it); put each "
                        "motor's output in its pwm_<motor> column")
    return d


def _armed_flags(word, a, name: str, warnings: list) -> np.ndarray:
    """Each row's armed flag.  A column filled on a minority of rows, nearly each filled row among
    empty ones, is a state logged on its own rows (a 1 Hz HEARTBEAT among other messages; all
    true in a log kept only while armed): each value holds until the next, rows before the first
    not armed — said.  Otherwise an empty cell means not armed (a column filled in blocks)."""
    true = word.isin(("true", "1", "1.0", "yes")).to_numpy(bool)
    empty = (a.isna() | word.isin(("", "nan"))).to_numpy(bool)
    filled = ~empty
    if not (empty.any() and filled.any()):
        return true
    k = np.flatnonzero(filled)
    prev_empty = np.r_[True, empty[:-1]][k]
    next_empty = np.r_[empty[1:], True][k]
    isolated = float(np.mean(prev_empty & next_empty))
    if not (filled.mean() < 0.5 and isolated >= 0.9):
        return true
    last = np.maximum.accumulate(np.where(filled, np.arange(true.size), -1))
    held = np.where(last >= 0, true[np.maximum(last, 0)], False)
    warnings.append(f"{name}: column armed is filled on {k.size} of {true.size} rows, each among "
                    "empty ones: read as a state logged on its own rows (each value holds until "
                    "the next; rows before the first: not armed)")
    return held


def _drop_spare_outputs(pwm: dict, veh, name: str, warnings: list) -> None:
    """More ``pwm_`` columns than the vehicle has thrusters: the highest-numbered beyond the
    count left out when each is off throughout (0 µs or empty: an export of a 6-thruster frame
    carrying outputs 7–8), said; otherwise an error naming the outputs that are off."""
    n = veh.B.shape[1]
    keys = _motor_order(pwm)
    off = [k for k in keys if not np.any(pwm[k][1] != 0)]
    spare = keys[n:]
    if len(keys) > n and all(k in off for k in spare):
        for k in spare:
            del pwm[k]
        warnings.append(f"{name}: pwm_{', pwm_'.join(spare)} are off throughout (0 µs or empty) and "
                        f"{veh.name!r} has {n} thrusters: left out, pwm_1 … pwm_{keys[n - 1]} "
                        "read as its thrusters 1 … " + str(n))
        return
    why = (f"; pwm_{', pwm_'.join(off)} are off throughout (0 µs or empty): if the frame has "
           "fewer motors, drop those columns" if off else "")
    raise DiveDataError(f"{name}: {len(pwm)} pwm_ columns (motors {', '.join(keys)}) but vehicle "
                        f"{veh.name!r} has {n} thrusters{why}; {'otherwise ' if off else ''}"
                        "pass the vehicle the log was flown with (e.g. bluerov2 for 6, "
                        "bluerov2-heavy for 8)")


@dataclass
class _PwmThrust:
    """The per-thruster thrust :func:`_forces_from_pwm` computed (``T``, n × len(t), N) and the
    thrust each would give with its output mirrored about 1500 µs (``mirrored``); ``computed``:
    the force columns it filled (the others came from the table)."""

    keys: list
    t: np.ndarray
    T: np.ndarray
    mirrored: np.ndarray
    computed: list
    directions: dict


def _forces_from_pwm(chans: dict, pwm: dict, veh, name: str, warnings: list, *,
                     directions: dict | None = None, thrust_model=None,
                     label: str = "") -> _PwmThrust:
    """``X_N … N_Nm`` from ``pwm_<j>`` columns: the voltage-aware T200 model (or
    ``thrust_model``) at ``battery_V`` (linear between its own samples) and the vehicle's ``B``
    (thruster j = column j).  ``directions`` ``{j: ±1}``: ArduSub's ``MOT_j_DIRECTION`` (thrust
    at ``1500 + d (pwm − 1500)``); ``label`` names where the PWM came from (default the columns)."""
    from uuvid.io.ardusub.frames import DOF_COLUMNS, effective_pwm
    from uuvid.io.ardusub.thrust import default_t200, thrust_warnings

    keys = _motor_order(pwm)
    t = pwm[keys[0]][0]
    odd = [k for k in keys if pwm[k][0].size != t.size or not np.array_equal(pwm[k][0], t)]
    if odd:
        tk = pwm[odd[0]][0]
        gone = np.setdiff1d(t, tk)
        where = (f" (pwm_{odd[0]} has no value at t = {gone[0]:.6g} s, where pwm_{keys[0]} has one)"
                 if gone.size else f" (pwm_{odd[0]} has values where pwm_{keys[0]} has none)")
        raise DiveDataError(f"{name}: the pwm_ columns do not share their rows{where}; every "
                            "pwm_<j> needs "
                            "a value on each servo-output row")
    at_v = "battery_V"
    if "battery_V" not in chans or chans["battery_V"][0].size == 0:
        volts = np.full(t.size, 16.0)
        at_v = "the nominal 16 V"
        warnings.append(f"{name}: no battery_V column: thrust from pwm_ at the T200 sheet's nominal "
                        "16 V (default); log the battery voltage")
    else:
        tb, vb = chans["battery_V"]
        volts = np.interp(t, tb, vb)
    tm = default_t200() if thrust_model is None else thrust_model
    if at_v == "battery_V":  # the thrust model's own voltage range, as log export says it
        warnings.extend(f"{name}: {w}" for w in thrust_warnings(tm, volts, t))
    d = {k: 1.0 for k in keys} if directions is None else {k: float(directions[k]) for k in keys}
    # 0 µs is "no pulse" (output off), not full reverse
    T = np.stack([np.where(pwm[k][1] > 0, tm.thrust(effective_pwm(pwm[k][1], d[k]), volts), 0.0)
                  for k in keys])
    W = np.asarray(veh.B, float) @ T
    computed = [c for c in DOF_COLUMNS if c not in chans]
    for i, c in enumerate(DOF_COLUMNS):
        chans.setdefault(c, (t, W[i]))
    if directions is None:
        warnings.append(f"{name}: forces computed from pwm_{keys[0]}…pwm_{keys[-1]} with {tm.name} "
                        f"at {at_v} and {veh.name}'s thruster geometry (pwm_j drives thruster j "
                        "along its axis: no reversal applied)")
    else:
        rev = [k for k in keys if d[k] < 0]
        warnings.append(f"{name}: forces computed from {label or 'pwm_'} with {tm.name} at "
                        f"{at_v} and {veh.name}'s thruster geometry (motor j = thruster j; "
                        + (f"reversed (MOT_n_DIRECTION = -1): motor(s) {', '.join(rev)}"
                           if rev else "no motor reversed") + ")")
    # what the direction check needs: the thrust with each output mirrored about 1500 µs
    mirrored = np.stack([np.where(pwm[k][1] > 0, tm.thrust(effective_pwm(pwm[k][1], -d[k]), volts),
                                  0.0) for k in keys])
    return _PwmThrust(keys, t, T, mirrored, computed, d)


#: logged force ÷ the pwm_ columns' thrust (RMS over the armed samples) outside 1/this…this:
#: the force columns' unit or scale is suspect.  Generous: a thrust curve other than the T200
#: preset's, or another battery voltage, moves the ratio by tens of % at most; the package's
#: examples agree to 1e-9 and a unit mix-up (lbf 0.22×, kgf 0.10×, ×1000) is far outside
FORCE_SCALE_FACTOR = 2.0
#: a column is compared only where the pwm_ columns' thrust has an RMS of at least this (N or
#: N·m): a DOF the thrusters barely push (roll) gives a ratio of noise
_FORCE_SCALE_MIN = {"Z_N": 1.0, "N_Nm": 0.2, "X_N": 1.0, "Y_N": 1.0, "K_Nm": 0.2, "M_Nm": 0.2}
_UNIT_GUESS = ((1 / 4.44822, "lbf (× 4.448 → N)"), (1 / 9.80665, "kgf (× 9.807 → N)"),
               (1 / 0.278014, "ozf"), (1e3, "mN (÷ 1000 → N)"), (1 / 1e3, "kN"))
#: the same for a torque column (N·m)
_TORQUE_UNIT_GUESS = ((1 / 1.355818, "lbf·ft (× 1.356 → N·m)"), (1 / 0.1129848, "lbf·in (× 0.113 → N·m)"),
                      (1 / 9.80665, "kgf·m (× 9.807 → N·m)"), (1e3, "mN·m (÷ 1000 → N·m)"),
                      (1 / 0.00706155, "ozf·in"))


def unit_guess(column: str, ratio: float) -> str | None:
    """The unit a force (``*_N``) or torque (``*_Nm``) column logged in it would read ``ratio`` ×
    its value in SI (within 15 %), or None."""
    table = _TORQUE_UNIT_GUESS if column.endswith("_Nm") else _UNIT_GUESS
    return next((u for r, u in table if abs(math.log(ratio / r)) < 0.15), None)


def _check_force_scale(chans, pwm, veh, armed, name, warnings, directions=None,
                       label=None) -> None:
    """With both the force columns and pwm_ columns: the forces the pwm_ columns give (the path
    used when the force columns are absent) against the logged ones; a warning naming the ratio
    when they disagree by more than :data:`FORCE_SCALE_FACTOR` (a force column in lbf gave a
    heave mass below the rigid-body mass, said as a better model)."""
    trial = {k: v for k, v in chans.items() if k not in _FORCE_SCALE_MIN}
    try:
        with np.errstate(all="ignore"):
            _forces_from_pwm(trial, pwm, veh, name, [], directions=directions, label=label or "")
    except (DiveDataError, ValueError, KeyError, IndexError):
        return
    off = []
    for c, floor in _FORCE_SCALE_MIN.items():
        if c not in chans or c not in trial:
            continue
        tl, fl = chans[c]
        tp, fp = trial[c]
        if tl.size < 2 or tp.size < 2:
            continue
        on = _inside(tl, armed) & (tl >= tp[0]) & (tl <= tp[-1]) & np.isfinite(fl)
        if np.count_nonzero(on) < 10:
            continue
        x = np.interp(tl[on], tp, fp)
        rx = float(np.sqrt(np.mean(x * x)))
        if not (rx >= floor):
            continue
        ratio = float(np.sqrt(np.mean(fl[on] ** 2))) / rx
        if ratio > 0 and not (1 / FORCE_SCALE_FACTOR <= ratio <= FORCE_SCALE_FACTOR):
            off.append((c, ratio))
    if not off:
        return
    c, ratio = off[0]
    unit = unit_guess(c, ratio)
    more = "; ".join(f"{k} {r:.2g}×" for k, r in off[1:])
    warnings.append(f"{name}: {c} is {ratio:.2g}× the thrust the pwm_ columns give"
                    + (f" ({more})" if more else "") + ": "
                    + (f"are the force columns in {unit}? " if unit else
                       "are the force columns in N and N·m? ")
                    + "The forces are used as logged (in N, N·m): convert them, or remove them to "
                    "have the thrust computed from the PWM; a wrong scale scales the identified "
                    "mass and drag with it")


#: what :func:`read_dive_channels` reads from a path, for the errors of one it cannot
_DIVE_KINDS = ("expected a dive table (.csv or .parquet), an ArduSub log (.bin, .tlog or .log), a "
               "ROS 1 .bag file or a ROS 2 bag folder (holding metadata.yaml)")
_DIVE_SUFFIXES = (".csv", ".parquet", ".bin", ".BIN", ".tlog", ".log", ".bag")


def _folder_message(p: Path) -> str:
    """Why the folder ``p`` (not a ROS 2 bag) is no dive log, and what in it might be one."""
    from itertools import islice

    from uuvid.io.dive_rosbag import is_bag

    kind = f"{p.suffix[1:]} file" if p.suffix.lower() in (".csv", ".parquet", ".bin", ".tlog",
                                                          ".log", ".bag") else "dive log"
    try:
        entries = sorted(islice(p.iterdir(), 2000))
    except OSError as e:
        return f"{p}: a folder, not a {kind}, and it cannot be listed ({e.strerror}); {_DIVE_KINDS}"
    if not entries:
        return f"{p}: a folder, not a {kind}, and an empty one; {_DIVE_KINDS}"
    storage = [q.name for q in entries if q.suffix in (".db3", ".mcap") and q.is_file()]
    if storage:
        return (f"{p}: a folder, not a {kind}: it holds ROS 2 bag storage "
                f"({', '.join(storage[:3])}) but no metadata.yaml, so it is no readable ROS 2 bag: "
                f"restore its metadata.yaml (`ros2 bag reindex {p}` rebuilds it) or pass the bag "
                "folder that has it")
    logs = [q for q in entries if (q.is_file() and q.suffix.lower() in
                                   (".csv", ".parquet", ".bin", ".tlog", ".log", ".bag"))
            or (q.is_dir() and is_bag(q))]
    if logs:
        shown = ", ".join(q.name for q in logs[:4]) + (", …" if len(logs) > 4 else "")
        return (f"{p}: a folder, not a {kind}: it holds {len(logs)} possible dive log"
                f"{'s' if len(logs) > 1 else ''} ({shown}); pass one of them, e.g. {logs[0]} "
                "(one dive at a time)")
    shown = ", ".join(q.name for q in entries[:3]) + (", …" if len(entries) > 3 else "")
    return (f"{p}: a folder, not a {kind}, and nothing in it is one ({len(entries)} entr"
            f"{'ies' if len(entries) > 1 else 'y'}: {shown}); {_DIVE_KINDS}")


def _looks_like(p: Path) -> str:
    """What the first bytes of a file without a known suffix say it is ('' when unsure)."""
    if not p.is_file():
        return ""
    try:
        with open(p, "rb") as f:
            head = f.read(4096)
    except OSError:
        return ""
    if not head:
        return "nothing: the file is empty"
    magic = [(b"\xa3\x95", "an ArduSub dataflash log: name it .bin"),
             (b"PAR1", "a Parquet table: name it .parquet"),
             (b"#ROSBAG", "a ROS 1 bag: name it .bag"),
             (b"\x89MCAP", "a ROS 2 bag's MCAP storage: pass the bag folder (with metadata.yaml)"),
             (b"SQLite format 3\x00", "a ROS 2 bag's sqlite3 storage: pass the bag folder (with "
                                     "metadata.yaml)")]
    for m, what in magic:
        if head.startswith(m):
            return what
    if len(head) > 9 and head[8] in (0xFE, 0xFD) and \
            9.4e17 < int.from_bytes(head[:8], "big") < 4.2e18:  # µs stamp (2000–2100), MAVLink
        return "a MAVLink telemetry log: name it .tlog"
    try:
        first = head.decode("utf-8").splitlines()[0]
    except (UnicodeDecodeError, IndexError):
        return ""
    if "," in first or ";" in first:
        return f"a CSV table (first line {first[:60]!r}): name it .csv"
    return ""


def check_log_arg(log) -> None:
    """``TypeError`` naming what ``log`` may be when it is none of them (an array, a list,
    ``None`` gave pathlib's "expected str, bytes or os.PathLike object")."""
    import os

    import pandas as pd

    if not isinstance(log, (str, os.PathLike, pd.DataFrame)):
        raise TypeError("log: expected a path (a dive table, an ArduSub log or a ROS bag file or "
                        f"folder) or a pandas DataFrame, got {type(log).__name__}")


def read_dive_channels(log, vehicle=None, *, params=None, thruster_model=None,
                       topics=None, t_start: float | None = None,
                       t_end: float | None = None) -> DiveChannels:
    """Read a dive (path or pandas DataFrame; see the module doc).  ``topics``: ROS bags only,
    ``{role: "topic:field"}`` or ``["role=topic:field", …]`` overriding the default topics
    (:data:`uuvid.io.dive_rosbag.DEFAULT_TOPICS`).  ``params``: ArduSub parameters (a file or
    ``{NAME: value}``) the log lacks; a table's ``pwm_<n>`` columns take their
    ``MOT_n_DIRECTION`` (a file that cannot be read is an error).  ``t_start``/``t_end``: the
    part of the dive the caller uses — an ArduSub log whose configuration (motor directions,
    outputs, primary barometer) changes mid-log is read on that part alone when the change lies
    outside it (the whole log otherwise: an error naming the change and these options).  Raises
    :class:`DiveDataError` / :class:`~uuvid.io.logs.LogDataError` naming what is missing."""
    import pandas as pd

    from uuvid.io.dive_rosbag import is_bag, read_bag_dive

    check_log_arg(log)
    warnings: list = []
    veh = _vehicle(vehicle)
    p = None if isinstance(log, pd.DataFrame) else Path(log)
    if p is not None and not p.exists():
        near = [q.name for q in (p.with_name(p.name + s) for s in _DIVE_SUFFIXES) if q.exists()]
        raise DiveDataError(f"{p}: no such file or folder"
                            + (f" (there is {near[0]} beside it)" if near else "")
                            + f"; {_DIVE_KINDS}")
    if p is not None and is_bag(p):
        try:
            return _from_bag(read_bag_dive(p, veh, topics=topics, params=params), veh,
                             thruster_model)
        except DiveDataError:
            raise
        except LogDataError as e:
            raise DiveDataError(str(e)) from None
    if topics:
        raise DiveDataError(f"{'<table>' if p is None else p.name}: --topic applies to ROS bags "
                            "only (a .bag file or a ROS 2 bag directory)")
    table_params = None
    if params is not None and (p is None or p.suffix.lower() in (".csv", ".parquet")):
        from uuvid.io.ardusub.sources import merge_params  # a missing file: an error, first

        table_params = (merge_params({}, params, []), "--params " + (
            Path(params).name if isinstance(params, (str, Path)) else "(the given parameters)"))
    if p is None:
        return _from_table(log, "<table>", "table", veh, warnings, params=table_params)
    suf = p.suffix.lower()
    if p.is_dir():
        raise DiveDataError(_folder_message(p))
    if suf in (".csv", ".parquet") and p.is_file() and p.stat().st_size == 0:
        raise DiveDataError(f"{p.name}: the file is empty (0 bytes); expected a dive table with a "
                            "header row (t_s, depth_m, …)")
    if suf == ".csv":
        try:
            df = pd.read_csv(p)
        except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as e:
            if isinstance(e, pd.errors.ParserError):
                _refuse_semicolons(p)
            why = (_not_utf8(p) if isinstance(e, UnicodeDecodeError)
                   else f"{type(e).__name__}: {str(e).splitlines()[0][:160]}")
            raise DiveDataError(f"{p.name}: not a readable CSV table ({why}); expected "
                                "comma-separated columns with a header row (t_s, depth_m, …) and "
                                "'.' as the decimal point") from None
        return _from_table(df, p.name, "csv", veh, warnings, export=_export_meta(p, None),
                           params=table_params)
    if suf == ".parquet":
        try:
            df = pd.read_parquet(p)
        except Exception as e:  # pyarrow raises several kinds for a file that is not Parquet
            raise DiveDataError(f"{p.name}: not a readable Parquet file ({type(e).__name__}: "
                                f"{str(e).splitlines()[0][:160] if str(e) else ''}); expected a "
                                "table with t_s and the dive's columns, as `uuvid log export` "
                                "writes it") from None
        return _from_table(df, p.name, "parquet", veh, warnings, export=_export_meta(p, df),
                           params=table_params)
    if suf in (".tlog", ".bin", ".log"):
        from uuvid.io.ardusub import load_dive

        if veh is None:
            raise DiveDataError(f"{p.name}: an ArduSub log needs --vehicle (its thruster geometry "
                                "turns the servo outputs into forces and moments)")
        from uuvid.io.ardusub.dive import ConfigurationChanged

        try:
            dive = load_dive(p, vehicle=veh, params=params, thruster_model=thruster_model)
        except ConfigurationChanged:
            if t_start is None and t_end is None:
                raise
            # the part asked for, in one configuration (still an error if the change is in it):
            # from t_start on first — identify's rows after --t-end are its held-out part
            dive = None
            if t_start is not None:
                try:
                    dive = load_dive(p, vehicle=veh, params=params,
                                     thruster_model=thruster_model, t_start=t_start)
                except ConfigurationChanged:
                    if t_end is None:
                        raise
            if dive is None:
                dive = load_dive(p, vehicle=veh, params=params, thruster_model=thruster_model,
                                 t_start=t_start, t_end=t_end)
                warnings.append(f"{p.name}: read up to t = {t_end:g} s only (the configuration "
                                f"changes after it): no rows after {arg('t_end')}, so no held-out part")
        tb = dive.table
        t = tb["t_s"].to_numpy(float)
        chans = {}
        for c in ("depth_m", "yaw_rad", "roll_rad", "pitch_rad", "battery_V", "X_N", "Y_N",
                  "Z_N", "K_Nm", "M_Nm", "N_Nm"):
            if c in tb:
                chans[c] = _finite(t, tb[c].to_numpy(float))
        armed_flag = tb["armed"].fillna(False).to_numpy(bool)
        armed = _intervals(t, armed_flag)
        pwm = {str(m): _finite(t, tb[f"pwm_{m}"].to_numpy(float)) for m in dive.motors}
        src = {c: (dive.provenance.get(c) or {}).get("source") for c in chans}
        warnings += list(dive.warnings)
        left_out: dict = {}
        _drop_depth_spikes(chans, p.name, warnings, left_out)
        _check_idle(pwm, armed, veh, p.name, warnings, thruster_model)
        _check_surface_reading(chans, armed, p.name, warnings)
        _drop_stuck(chans, armed, p.name, warnings, left_out)
        faulty = _off_outputs(pwm, veh, p.name, warnings, computed=True)
        opposed = _log_direction_check(chans, pwm, dive, veh, armed, p.name, warnings,
                                       thruster_model, faulty)
        return DiveChannels(p.name, dive.format, chans, armed,
                            _mode_runs(t, tb["mode"].astype(str).to_numpy()), warnings, src, pwm,
                            left_out=left_out, opposed=opposed, faulty=faulty)
    what = f"unknown dive log type {p.suffix!r}" if p.suffix else "no file suffix"
    if suf in (".db3", ".mcap"):
        what = f"a ROS 2 bag's {suf} storage file without the bag's metadata.yaml beside it"
    look = _looks_like(p)
    raise DiveDataError(f"{p}: {what}" + (f"; it looks like {look}" if look else "")
                        + f"; the reader goes by the suffix: {_DIVE_KINDS}")


def _log_direction_check(chans: dict, pwm: dict, dive, veh, armed: list, name: str,
                         warnings: list, thruster_model, faulty: dict | None = None) -> list:
    """The motion-based direction check (:func:`~uuvid.io.motor_direction.direction_check`) on an
    ArduSub log: the log's ``MOT_n_DIRECTION`` applied, the forces of the log's thrust model
    recomputed on a scratch copy (the dive's own columns are kept), so that a parameter that does
    not match the motor on the vehicle is said, as for tables and bags (and the outputs named
    go into ``faulty``, :attr:`DiveChannels.faulty`)."""
    directions = {str(m.number): float(m.direction) for m in dive.config.active}
    if not pwm or set(directions) != set(pwm):
        return []
    tm = None
    if thruster_model is not None:
        from uuvid.io.ardusub.thrust import load_thrust_model

        tm = load_thrust_model(thruster_model)
    from uuvid.io.ardusub.frames import DOF_COLUMNS

    scratch = {c: v for c, v in chans.items() if c not in DOF_COLUMNS}
    try:
        thrust = _forces_from_pwm(scratch, pwm, veh, name, [], directions=directions,
                                  thrust_model=tm)
    except (DiveDataError, LogDataError, ValueError):
        return []
    named: list = []
    opposed = direction_check(scratch, thrust, veh, armed, name, warnings, bag_fix(directions),
                              named=named)
    if faulty is not None:
        faulty.update(_reversed_faults(named, pwm, veh, bag_fix(directions)))
    return opposed


def _from_bag(bd, veh, thruster_model) -> DiveChannels:
    """Forces, armed intervals and mode runs of a :class:`uuvid.io.dive_rosbag.BagDive` (a state
    holds until the next message, so the last run lasts to the bag's last sample)."""
    tm = None
    if thruster_model is not None:
        from uuvid.io.ardusub.thrust import load_thrust_model

        tm = load_thrust_model(thruster_model)
    chans, warnings = dict(bd.channels), list(bd.warnings)
    left_out: dict = {}
    try:  # the table's unit checks, on the bag's channels (named with their topics)
        _check_units(chans, bd.pwm, bd.name, warnings)
    except DiveDataError as e:
        m = re.search(r"column (\w+)", str(e))
        src = bd.sources.get(m.group(1)) if m else None
        raise DiveDataError(f"{e} (read from {src.split(' ')[0]})" if src else str(e)) from None
    _drop_depth_spikes(chans, bd.name, warnings, left_out)
    thrust = _forces_from_pwm(chans, bd.pwm, veh, bd.name, warnings, directions=bd.directions,
                              thrust_model=tm, label=bd.pwm_label)
    if bd.armed is not None:
        ta, a = bd.armed
        armed = _intervals(ta, a > 0.5, holes=False)
        if armed and a[-1] > 0.5:
            armed[-1] = (armed[-1][0], max(armed[-1][1], bd.t_end))
    else:
        armed = [(min(float(c[0][0]) for c in chans.values() if c[0].size), bd.t_end)]
    _check_dead_outputs(bd.pwm, armed, bd.name, warnings)
    _check_idle(bd.pwm, armed, veh, bd.name, warnings, tm)
    _check_surface_reading(chans, armed, bd.name, warnings)
    faulty = _off_outputs(bd.pwm, veh, bd.name, warnings, computed=True)
    named: list = []
    opposed = direction_check(chans, thrust, veh, armed, bd.name, warnings,
                              bag_fix(thrust.directions), named=named)
    faulty.update(_reversed_faults(named, bd.pwm, veh, bag_fix(thrust.directions)))
    modes = []
    if bd.modes is not None:
        modes = _mode_runs(*bd.modes)
        if modes:
            modes[-1] = (modes[-1][0], max(modes[-1][1], bd.t_end), modes[-1][2])
    return DiveChannels(bd.name, bd.format, chans, armed, modes, warnings, dict(bd.sources),
                        dict(bd.pwm), left_out=left_out, opposed=opposed, faulty=faulty)


# ---------------------------------------------------------------------------------------------
# Dead band and saturation of the thrusters, per force sample
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ThrustRegions:
    """Where a thruster model's steady thrust is zero (dead band ``[edge_rev, edge_fwd]`` around
    ``neutral``) and where it stops growing (``full_rev``/``full_fwd``), in µs, read off the
    model (:func:`thrust_regions`)."""

    model: str
    neutral: float
    edge_rev: float
    edge_fwd: float
    full_rev: float
    full_fwd: float

    def edge_region(self) -> tuple[float, float]:
        """``[edge_rev − (neutral − edge_rev), edge_fwd + (edge_fwd − neutral)]``: the dead band
        and as much again beyond each edge — where the ESC may or may not spin (published T200
        dead bands run from ±18 µs, the shipped model's, to ±25–36 µs: the edge is uncertain by
        about its own width)."""
        return (2 * self.edge_rev - self.neutral, 2 * self.edge_fwd - self.neutral)

    def to_dict(self) -> dict:
        lo, hi = self.edge_region()
        return {"model": self.model, "neutral_us": self.neutral, "dead_band_us": [self.edge_rev,
                self.edge_fwd], "edge_region_us": [lo, hi],
                "saturation_us": [self.full_rev, self.full_fwd]}


def thrust_regions(thrust_model, volts: float = 16.0, neutral: float = 1500.0,
                   lo: float = 1100.0, hi: float = 1900.0) -> ThrustRegions:
    """Dead band and saturation onsets of ``thrust_model`` (``.thrust(pwm, volts)``, e.g.
    :func:`uuvid.io.ardusub.thrust.default_t200`) on a 0.5 µs grid at ``volts``: the dead band is
    the run of commands around ``neutral`` with zero thrust (|T| ≤ 10⁻⁶ of the largest), the
    saturation onset where the thrust comes within 0.1 % of its extreme."""
    c = np.arange(lo, hi + 0.25, 0.5)
    T = np.asarray(thrust_model.thrust(c, np.full(c.size, volts)), float)
    T = np.where(np.isfinite(T), T, 0.0)
    zero = np.abs(T) <= 1e-6 * max(float(np.max(np.abs(T))), 1e-12)
    i0 = int(np.argmin(np.abs(c - neutral)))
    a = b = i0
    while a > 0 and zero[a - 1]:
        a -= 1
    while b < c.size - 1 and zero[b + 1]:
        b += 1
    tmax, tmin = float(np.max(T)), float(np.min(T))
    full_fwd = float(c[np.flatnonzero(T >= tmax - 1e-3 * abs(tmax))[0]])
    full_rev = float(c[np.flatnonzero(T <= tmin + 1e-3 * abs(tmin))[-1]])
    return ThrustRegions(getattr(thrust_model, "name", "thruster model"), float(neutral),
                         float(c[a]), float(c[b]), full_rev, full_fwd)


@dataclass
class PwmFlags:
    """Per servo-output sample (stamps ``t``): thrusters in the dead band's edge region
    (``n_edge``) and at saturation (``n_sat``), and the force/moment uncertainty ``sigma``
    (6 × n, N and N·m) the edge-region thrusters leave (:func:`pwm_flags`)."""

    t: np.ndarray
    n_edge: np.ndarray
    n_sat: np.ndarray
    sigma: np.ndarray
    regions: ThrustRegions
    motors: int

    def sigma_of(self, force: str) -> tuple[np.ndarray, np.ndarray]:
        """``(t, σ)`` of one force channel (``X_N`` … ``N_Nm``)."""
        from uuvid.io.ardusub.frames import DOF_COLUMNS

        return self.t, self.sigma[list(DOF_COLUMNS).index(force)]


def pwm_flags(dc: DiveChannels, B, thrust_model, t_start=None, t_end=None) -> PwmFlags | None:
    """Flag each servo-output sample of ``dc.pwm`` (``None`` when no PWM is logged).

    A thruster is in the *edge region* when its command lies in
    :meth:`ThrustRegions.edge_region` but not at neutral (|c − neutral| < 1 µs: the output is
    off, its zero thrust is certain); its thrust then lies anywhere between 0 and the model's
    thrust at the outer end of the region, ``T_o`` (at the logged battery voltage, 16 V when
    none), so its uncertainty is taken as ``σ_T = |T_o|/2``.  The wrench uncertainty is
    ``σ_i = sqrt(Σ_j (B_ij σ_Tj)²)`` (thrusters' errors independent).  It is *saturated* within
    5 µs of the model's saturation onset: there the thrust is known (used as logged) but not
    what the controller asked for.  Disabled outputs (PWM ≤ 0) are neither.
    """
    if not dc.pwm:
        return None
    keys = _motor_order(dc.pwm)
    t = dc.pwm[keys[0]][0]
    P = np.full((len(keys), t.size), np.nan)
    for j, k in enumerate(keys):
        tk, pk = dc.pwm[k]
        P[j] = np.interp(t, tk, pk) if tk.size else np.nan
    sel = np.ones(t.size, bool)
    if t_start is not None:
        sel &= t >= t_start
    if t_end is not None:
        sel &= t <= t_end
    t, P = t[sel], P[:, sel]
    reg = thrust_regions(thrust_model)
    lo, hi = reg.edge_region()
    on = np.isfinite(P) & (P > 0)
    edge = on & (P >= lo) & (P <= hi) & (np.abs(P - reg.neutral) >= 1.0)
    sat = on & ((P >= reg.full_fwd - 5.0) | (P <= reg.full_rev + 5.0))
    if "battery_V" in dc.channels and dc.channels["battery_V"][0].size:
        volts = np.interp(t, *dc.channels["battery_V"])
    else:
        volts = np.full(t.size, 16.0)
    t_hi = np.abs(np.asarray(thrust_model.thrust(np.full(t.size, hi), volts), float))
    t_lo = np.abs(np.asarray(thrust_model.thrust(np.full(t.size, lo), volts), float))
    sT = 0.5 * np.where(edge, np.where(P >= reg.neutral, t_hi, t_lo), 0.0)
    Bm = np.asarray(B, float)
    if Bm.shape[1] != len(keys):
        sigma = np.zeros((6, t.size))
    else:
        sigma = np.sqrt((Bm ** 2) @ (sT ** 2))
    return PwmFlags(t, edge.sum(axis=0), sat.sum(axis=0), sigma, reg, len(keys))


# ---------------------------------------------------------------------------------------------
# Rotor speeds and the thrust lost to the advance speed (issue 21)
# ---------------------------------------------------------------------------------------------
def rotor_speeds(dc: DiveChannels, thrust_model=None) -> tuple[np.ndarray, np.ndarray, str] | None:
    """``(t, |Ω| (n × len(t)) [rad/s], how)``: each thruster's rotor speed on the servo-output
    stamps, or ``None`` when no PWM is logged.

    ``|Ω|`` is the steady speed the thruster model gives for the logged PWM at the logged battery
    voltage (16 V without one): the voltage-aware T200 model's DC-motor balance
    (:meth:`uuvid.io.ardusub.thrust.ThrustModel.speed`).  A model that gives thrust only (a
    command-driven chain) gives ``|Ω| = sqrt(|T| / K_T)`` with the shipped T200 model's ``K_T``
    per direction (``how`` says which).  MOT_n_DIRECTION reversal is not applied: forward and
    astern speeds at the same offset from neutral differ by a few per cent."""
    from uuvid.io.ardusub.thrust import T200_MODEL_FILE, _physical_from_yaml, default_t200

    if not dc.pwm:
        return None
    tm = default_t200() if thrust_model is None else thrust_model
    keys = _motor_order(dc.pwm)
    t = dc.pwm[keys[0]][0]
    P = np.stack([np.interp(t, *dc.pwm[k]) if dc.pwm[k][0].size else np.full(t.size, 1500.0)
                  for k in keys])
    if "battery_V" in dc.channels and dc.channels["battery_V"][0].size:
        volts = np.interp(t, *dc.channels["battery_V"])
        at_v = "the logged battery voltage"
    else:
        volts = np.full(t.size, 16.0)
        at_v = ("the nominal 16 V (no battery voltage logged: thrust and rotor speeds of a "
                "full battery, which biases k_a beyond its σ; log battery_V)")
    on = np.isfinite(P) & (P > 0)
    P = np.where(on, P, 1500.0)
    if tm.has_speed:
        W = np.abs(np.stack([tm.speed(p, volts) for p in P]))
        how = f"{tm.name}: steady rotor speed at the logged PWM and {at_v}"
    else:
        T = np.stack([tm.thrust(p, volts) for p in P])
        pm = _physical_from_yaml(T200_MODEL_FILE)
        kt = np.where(T >= 0, pm.kt_fwd, pm.kt_rev)
        W = np.sqrt(np.abs(T) / kt)
        how = (f"{tm.name} gives thrust only: |Ω| = sqrt(|T|/K_T) with the T200 model's K_T "
               f"({pm.kt_fwd:.4g} ahead, {pm.kt_rev:.4g} astern N·s²/rad²)")
    W = np.where(on & np.isfinite(W), W, 0.0)
    return t, W, how


def inflow_gain(dc: DiveChannels, vehicle, dof: str, speeds=None,
                thrust_model=None) -> tuple[np.ndarray, np.ndarray, str] | None:
    """``(t, c, how)``: the gain ``c(t) = Σ_i G_ji |Ω_i(t)|`` of the thrust lost to the advance
    speed in DOF ``dof`` (:func:`uuvid.vehicle.inflow.one_dof_inflow_matrix`): with the linear
    inflow form (Healey et al. 1995; Fossen 2011 §6.7) the DOF's force is ``F(t) − k_a c(t) v``.
    ``speeds``: :func:`rotor_speeds` already computed; ``None`` when no PWM is logged."""
    from uuvid.vehicle.inflow import one_dof_inflow_matrix

    rs = speeds if speeds is not None else rotor_speeds(dc, thrust_model)
    if rs is None:
        return None
    t, W, how = rs
    G = one_dof_inflow_matrix(vehicle)
    j = {"surge": 0, "sway": 1, "heave": 2, "yaw": 5}[dof]
    if G.shape[1] != W.shape[0]:
        raise DiveDataError(f"{dc.name}: {W.shape[0]} servo outputs but vehicle {vehicle.name!r} "
                            f"has {G.shape[1]} thrusters: the inflow term needs one per thruster")
    return t, G[j] @ W, how


def horizontal_inflow_gain(dc: DiveChannels, vehicle, speeds=None,
                           thrust_model=None) -> tuple[np.ndarray, np.ndarray, str] | None:
    """``(t, C (len(t) × 3 × 3), how)``: the matrix ``C(t) = Σ_i H_i |Ω_i(t)|`` of the thrust lost
    to the advance speed in the coupled horizontal model, ``(X, Y, N) − k_a C(t) (u, v, r)``
    (:func:`uuvid.vehicle.inflow.horizontal_inflow_matrix`); ``None`` when no PWM is logged."""
    from uuvid.vehicle.inflow import horizontal_inflow_matrix

    rs = speeds if speeds is not None else rotor_speeds(dc, thrust_model)
    if rs is None:
        return None
    t, W, how = rs
    H = horizontal_inflow_matrix(vehicle)
    if H.shape[2] != W.shape[0]:
        raise DiveDataError(f"{dc.name}: {W.shape[0]} servo outputs but vehicle {vehicle.name!r} "
                            f"has {H.shape[2]} thrusters: the inflow term needs one per thruster")
    return t, np.einsum("jki,it->tjk", H, W), how
