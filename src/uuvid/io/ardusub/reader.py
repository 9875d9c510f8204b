"""One pass over an ArduSub log (dataflash ``.BIN``/``.log`` or telemetry ``.tlog``) with
pymavlink: every message counted per sender, the messages a dive needs kept as arrays, each on
its own sender's clock, and those clocks mapped onto one time base.

Time base ``t`` [s]: the autopilot's boot clock, continued across reboots.  Within one boot
(a *part*) ``t = boot + C_k``; ``C_0 = 0`` and a later part is placed by the ground station's
receive clock (telemetry: ``C_k`` = the part's lower-envelope offset ``receive − boot`` minus
part 0's) or, for dataflash, right after the previous part (the gap is unknown; warned).
Telemetry messages without an on-board stamp (VFR_HUD, SYS_STATUS, HEARTBEAT) get one from
their receive time through the lower envelope of ``receive − boot`` of their sender's stamped
messages (:func:`uuvid.io.logs._boot_from_log`); another component (a companion computer such as
BlueOS, component 194) has its own ``time_boot_ms`` and is mapped through its own envelope.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import sys
from collections import Counter
from dataclasses import dataclass, field
from datetime import UTC
from pathlib import Path

import numpy as np

from uuvid.core.progress import progress_task
from uuvid.io.logs import (
    LogDataError,
    _ardusub_kind,
    _boot_from_log,
    _captured_output,
    _check_tlog,
    _damaged_index_note,
    _dataflash_cut,
    _index_stops_early,
    _not_a_tlog,
    _require,
    _Skipped,
    _tlog_boot,
    _tlog_index_check,
    tlog_clock_back,
)

#: messages kept (all numeric fields); everything else is only counted
TLOG_KEEP = {"HEARTBEAT", "ATTITUDE", "GLOBAL_POSITION_INT", "VFR_HUD", "SYS_STATUS",
             "BATTERY_STATUS", "SERVO_OUTPUT_RAW", "SCALED_PRESSURE", "SCALED_PRESSURE2",
             "SCALED_PRESSURE3", "GPS_GLOBAL_ORIGIN", "HOME_POSITION", "SYSTEM_TIME"}
DF_KEEP = {"ATT", "BARO", "BAR2", "BAR3", "CTUN", "BAT", "CURR", "RCOU", "MODE", "ARM", "EV"}
_NO_STAMP = object()


@dataclass
class Series:
    """All messages of one type from one sender, in log order."""

    msg: str
    src: tuple[int, int]
    recv: list = field(default_factory=list)  # receive time (UNIX s, telemetry) or nan
    boot: list = field(default_factory=list)  # on-board stamp [s since boot] or nan
    values: dict = field(default_factory=dict)  # field → list
    seq: list = field(default_factory=list)  # position in the log (message number)
    t: np.ndarray | None = None  # on the time base (filled by RawLog.finish)
    part: np.ndarray | None = None
    log: str = ""  # the log's file name (for errors)

    def array(self, name: str) -> np.ndarray:
        v = self.values.get(name)
        if v is None:  # a field the log's own format description (FMT) does not give
            raise LogDataError(
                f"{self.log or 'log'}: {self.msg} has no field {name!r} (its fields: "
                f"{', '.join(sorted(self.values)) or 'none'}); the log's format description "
                "(FMT) of that message is corrupt or from an unsupported firmware: re-download "
                "the log from the vehicle")
        return np.asarray(v, dtype=float)


@dataclass
class Sender:
    src: tuple[int, int]
    kind: str = ""  # HEARTBEAT type / autopilot, e.g. "SUBMARINE / ARDUPILOTMEGA"
    counts: Counter = field(default_factory=Counter)
    first_recv: float = math.nan
    last_recv: float = math.nan
    stamped_recv: list = field(default_factory=list)  # (receive, time_boot_ms) pairs
    stamped_boot: list = field(default_factory=list)
    parts: list = field(default_factory=list)  # receive times where a new boot starts
    clock_offset: float | None = None  # median of its boot clock minus the autopilot's [s]
    hb: tuple | None = None  # (MAV_TYPE, MAV_AUTOPILOT) of its first HEARTBEAT


@dataclass
class RawLog:
    path: Path
    format: str  # "tlog" | "dataflash"
    senders: dict
    series: dict  # (msg, src) → Series
    params: list  # (name, value, t, sender, message number)
    autopilot: tuple[int, int] | None
    warnings: list
    parts: int = 1
    duplicates: dict = field(default_factory=dict)
    bad_data: int = 0
    same_recv: int = 0  # telemetry messages sharing the previous one's receive stamp
    sessions: list = field(default_factory=list)  # parts of the autopilot starting a new session

    @property
    def name(self) -> str:
        return self.path.name

    def get(self, msg: str) -> Series | None:
        """The autopilot's ``msg`` series (dataflash: the only sender)."""
        return self.series.get((msg, self.autopilot))

    def param_values(self) -> tuple[dict, dict]:
        """``{name: last value}`` and ``{name: [distinct values in order]}`` of the autopilot's
        parameters (other components' PARAM_VALUEs are not the vehicle's)."""
        last: dict = {}
        hist: dict = {}
        for n, v, _, src, _ in self.params:
            if src != self.autopilot:
                continue
            last[n] = v
            h = hist.setdefault(n, [])
            if not h or h[-1] != v:
                h.append(v)
        return last, {n: h for n, h in hist.items() if len(h) > 1}

    def param_times(self) -> list[tuple[str, float, float]]:
        """The autopilot's parameters as ``(name, value, t)``, ``t`` on the time base: where
        the message sits among the attitude messages (dataflash: its own stamp on the clock of
        the part the next attitude message is in; telemetry: between its neighbours' times)."""
        ref = self.get("ATT") or self.get("ATTITUDE")
        rows = [(n, v, b, q) for n, v, b, src, q in self.params if src == self.autopilot]
        if ref is None or ref.t is None or not len(ref.seq):
            return [(n, v, -math.inf) for n, v, _, _ in rows]
        rs = np.asarray(ref.seq, dtype=float)
        rt = np.asarray(ref.t, dtype=float)
        q = np.asarray([r[3] for r in rows], dtype=float)
        if self.format == "dataflash":
            i = np.clip(np.searchsorted(rs, q), 0, rs.size - 1)  # the next attitude message
            off = rt - np.asarray(ref.boot, dtype=float)
            b = np.asarray([r[2] if r[2] is not None else math.nan for r in rows], dtype=float)
            t = np.where(np.isfinite(b), b + off[i], rt[i])
        else:
            ok = np.isfinite(rt)
            t = np.interp(q, rs[ok], rt[ok]) if ok.any() else np.full(q.size, -math.inf)
        return [(n, v, float(tt)) for (n, v, _, _), tt in zip(rows, t)]

    def param_history(self) -> dict[str, list[tuple[float, float]]]:
        """``{name: [(t, value), ...]}``: the first value of each parameter and every change
        after it, on the time base (:meth:`param_times`); a value is in force from its time to
        the next change, the first one from the start of the log."""
        hist: dict = {}
        for n, v, t in sorted(self.param_times(), key=lambda r: r[2]):
            h = hist.setdefault(n, [])
            if not h or h[-1][1] != v:
                h.append((t, v))
        return hist


def _numeric_fields(m) -> dict:
    out = {}
    for f in m.get_fieldnames():
        v = getattr(m, f, None)
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out[f] = float(v)
        elif isinstance(v, (list, tuple)) and v and isinstance(v[0], (int, float)):
            out[f] = float(v[0])  # first element (BATTERY_STATUS.voltages[0])
    return out


def read_raw(path, *, whole_file: bool = True) -> RawLog:
    """Read ``path`` once (see the module doc).  Raises :class:`LogDataError` naming the file.
    pymavlink's own prints about bad bytes (one line per byte of a damaged stretch: 290,000 for
    a telemetry log named .BIN) are collected and said once, as a warning of the log.
    ``whole_file``: telemetry frames failing their checksum are said of every type and sender
    (``log inspect``); else only of the types kept (:data:`TLOG_KEEP`) from the autopilot, as
    the others play no part in a dive."""
    mavutil = _require("pymavlink.mavutil", "reading ArduSub logs")
    p = Path(path)
    kind = _ardusub_kind(p)
    chatter: list = []
    try:
        # the bar writes to the terminal's stderr: the capture below takes pymavlink's prints
        with _terminal_stderr() as err, progress_task(f"reading {p.name}", total=100.0,
                                                      after_s=PROGRESS_AFTER_S, stream=err) as bar:
            with _captured_output(chatter):
                raw = _read_messages(p, kind, mavutil, whole_file, bar)
            _advance(bar, None)
    except LogDataError as e:
        if chatter and "no messages" in str(e):
            other = ".tlog" if kind == "dataflash" else ".BIN"
            raise LogDataError(f"{e} — pymavlink could not decode it ({len(chatter):,} complaints, "
                               f"first: {chatter[0][:80]!r}); is it a {other} under another "
                               "suffix?") from None
        raise
    if chatter:
        raw.warnings.append(f"{p.name}: pymavlink reported {len(chatter):,} decoding problem(s) "
                            f"(first: {chatter[0][:100]!r}); the messages it could decode are read")
    return raw


#: a sender's receive clock running on this much (s) more than its own clock between two of its
#: messages starts a new part: another recording session (telemetry logs joined with cat)
SESSION_JUMP_S = 600.0
#: receive times this far (s) outside a log part's stamped messages are corrupt, not late
RECV_MARGIN_S = 60.0
#: a receive-clock step (s): the receive time of a sender's stamped message advanced by more than
#: this apart from its own clock's advance ...
CLOCK_STEP_S = 5.0
#: ... over an advance of its own clock shorter than this (s; longer silences are link losses,
#: reboots reset the sender's clock: neither is a step)
CLOCK_STEP_WINDOW_S = 10.0
#: a receive (or a sender's own) time this much (s) before the latest one is that clock going
#: back, not messages reordered in the ground station or interleaved by the sender
RECV_BACK_S = 1.0


#: a log read taking longer than this (s) shows a progress bar on stderr (a terminal; off one,
#: a line every :data:`uuvid.core.progress.LINE_EVERY_S`)
PROGRESS_AFTER_S = 2.0


def _advance(bar, conn) -> None:
    """Move ``bar`` to the share of the file pymavlink has read (``conn.percent``, 0–100; the
    whole file when ``conn`` is None: the read is over)."""
    pct = 100.0 if conn is None else getattr(conn, "percent", None)
    if isinstance(pct, (int, float)) and math.isfinite(pct) and pct > bar.completed:
        bar.advance(min(float(pct), 100.0) - bar.completed)


@contextlib.contextmanager
def _terminal_stderr():
    """The stream stderr writes to before the read's capture (:func:`_captured_output`, which
    sends file descriptor 2 into a temporary file meanwhile): a duplicate of descriptor 2, or
    ``sys.stderr`` itself where it has none (Jupyter)."""
    try:
        fd = os.dup(sys.stderr.fileno())
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        yield sys.stderr
        return
    f = os.fdopen(fd, "w", buffering=1, encoding=getattr(sys.stderr, "encoding", None) or "utf-8",
                  errors="replace")
    try:
        yield f
    finally:
        f.close()


def _read_messages(p: Path, kind: str, mavutil, whole_file: bool = True, bar=None) -> RawLog:
    """The body of :func:`read_raw` (pymavlink's prints captured by the caller)."""
    try:
        conn = mavutil.mavlink_connection(str(p))
    except Exception as e:  # pymavlink's own error text says nothing about the log
        raise LogDataError(_cannot_read(p, kind, "open")) from e
    if kind == "tlog":  # random bytes decode as a stray UNKNOWN_n, or as nothing
        _check_tlog(conn, p)
    senders: dict = {}
    series: dict = {}
    params: list = []
    wraps: dict = {}
    keep = TLOG_KEEP if kind == "tlog" else DF_KEEP
    bad = 0
    n = 0
    same_recv, last_recv = 0, math.nan
    shift, steps, last_stamp = 0.0, [], {}  # receive-clock steps (tlog), see CLOCK_STEP_S
    recv_max, back = -math.inf, None  # the receive clock gone back: (byte, before, after)
    # dataflash: pymavlink indexes the file, so reading only the kept types skips the rest
    # (IMU, EKF, ...) and the counts of every type come from its index
    want = sorted(keep | {"PARM"}) if kind == "dataflash" else None
    notes: list = []
    # telemetry: a log whose index has a gap is read through :class:`_Skipped` (every message's
    # position, the damaged bytes searched again); else message by message as it comes, its
    # BAD_DATA whole frames failing their checksum (where each starts read only for them)
    gaps, partial = _tlog_index_check(conn) if kind == "tlog" else (False, 0)
    skipped = _Skipped(conn, partial) if kind == "tlog" else None
    tlog = skipped.stream() if gaps else None
    stop = _index_stops_early(conn) if kind == "dataflash" else None
    cut = _dataflash_cut(conn) if kind == "dataflash" else None
    if stop is not None:  # pymavlink's index ends at a damaged message: read them one by one
        want = None
        notes.append(_damaged_index_note(p.name, stop) + " (the bytes it could not decode are "
                     "skipped — see BAD_DATA)")
    try:
        while True:
            try:
                m = (next(tlog, None) if tlog is not None else conn.recv_msg() if want is None
                     else conn.recv_match(type=want, blocking=False))
            except Exception as e:
                raise LogDataError(_cannot_read(p, kind, f"decode after message {n:,} of")) from e
            if m is None:
                break
            n += 1
            if bar is not None and not n & 1023:  # the share of the file read, on stderr
                _advance(bar, conn)
            mt = m.get_type()
            if mt == "BAD_DATA":
                bad += 1
                if skipped is not None and tlog is None:
                    skipped.bad(m, int(conn.f.tell()) - 8 - len(getattr(m, "data", b"")))
                continue
            if kind == "tlog":
                src = (m.get_srcSystem(), m.get_srcComponent())
                recv = float(getattr(m, "_timestamp", math.nan))
                same_recv += recv == last_recv
                last_recv = recv
                recv += shift  # the receive clock's steps so far, taken out
                boot = None
                if mt in keep or "time_boot_ms" in m.get_fieldnames():
                    boot = _tlog_boot(m, wraps)
                # the receive clock gone back, found before this message's own clock is compared:
                # the first message of an appended log may itself carry time_boot_ms
                if back is None and recv < recv_max - RECV_BACK_S:
                    at = (int(conn.f.tell()) - 8 - len(m.get_msgbuf()) if tlog is None
                          else (tlog_clock_back(p) or (-1,))[0])
                    back = (at, recv_max, recv)
                if boot is not None and "time_boot_ms" in m.get_fieldnames():
                    prev = last_stamp.get(src)
                    if prev is not None:
                        dr, db = recv - prev[0], boot - prev[1]
                        # db > 0: a clock that runs (a ground station stamps 0 throughout)
                        if 0.0 < db < CLOCK_STEP_WINDOW_S and abs(dr - db) > CLOCK_STEP_S:
                            # the sender's own clock ran on; the ground station's jumped (an NTP
                            # correction, a laptop's clock set by hand)
                            shift += db - dr
                            recv += db - dr
                            steps.append((n, dr - db))
                        if back is not None and db < -RECV_BACK_S:
                            # both clocks went back: not a reboot (the receive clock runs on
                            # through one) but another log appended, however far back it goes
                            # (a sender's message types interleave by less than the tolerance)
                            raise LogDataError(_joined_out_of_order(p, *back))
                        if back is not None:  # the sender's clock ran on: a step, taken out
                            back, recv_max = None, recv
                    last_stamp[src] = (recv, boot)
                recv_max = max(recv_max, recv)
            else:
                if mt in ("FMT", "FMTU", "UNIT", "MULT"):
                    continue
                src = (0, 0)
                recv = math.nan
                fn = m.get_fieldnames()
                boot = (m.TimeUS * 1e-6 if "TimeUS" in fn else
                        m.TimeMS * 1e-3 if "TimeMS" in fn else None)
            s = senders.get(src)
            if s is None:
                s = senders[src] = Sender(src, first_recv=recv)
            s.counts[mt] += 1
            s.last_recv = recv
            if mt == "HEARTBEAT" and not s.kind:
                s.kind = f"{_enum('MAV_TYPE', m.type)} / {_enum('MAV_AUTOPILOT', m.autopilot)}"
                s.hb = (int(m.type), int(m.autopilot))
            if kind == "tlog" and boot is not None and "time_boot_ms" in m.get_fieldnames():
                s.stamped_recv.append(recv)
                s.stamped_boot.append(boot)
            if mt == "PARM":
                params.append((str(m.Name), float(m.Value), boot, src, n))
                continue
            if mt == "PARAM_VALUE":
                params.append((str(m.param_id).rstrip("\x00"), float(m.param_value), recv, src, n))
                continue
            if mt not in keep:
                continue
            key = (mt, src)
            sr = series.get(key)
            if sr is None:
                sr = series[key] = Series(mt, src, log=p.name)
            vals = _numeric_fields(m)
            for f, v in vals.items():
                lst = sr.values.get(f)
                if lst is None:
                    lst = sr.values[f] = [math.nan] * len(sr.recv)
                lst.append(v)
            for f, lst in sr.values.items():
                if f not in vals:
                    lst.append(math.nan)
            sr.recv.append(recv)
            sr.boot.append(math.nan if boot is None else boot)
            sr.seq.append(n)
    finally:
        try:
            conn.close()
        except Exception:
            pass
    if kind == "dataflash" and stop is None:  # (a damaged log's index counts too few)
        counts = getattr(conn, "counts", None)
        names = getattr(conn, "id_to_name", {})
        s0 = senders.setdefault((0, 0), Sender((0, 0)))
        items = enumerate(counts) if isinstance(counts, list) else (counts or {}).items()
        for i, c in items:
            nm = names.get(i)
            if c and nm and nm not in ("FMT", "FMTU", "UNIT", "MULT"):
                s0.counts[nm] = int(c)
    size = p.stat().st_size
    if n == 0 and kind == "dataflash" and size and p.read_bytes()[:2] == b"\xa3\x95":
        raise LogDataError(f"{p.name}: the log ends after {size:,} bytes holding only its format "
                           "(FMT) records, no message: cut off (copied while being written, or "
                           "the card was full)?")
    if n == 0:
        raise LogDataError(f"{p.name}: no messages in the log (empty or not an ArduSub log)")
    if kind == "tlog" and not senders:  # every frame failed: text or other bytes
        raise LogDataError(_not_a_tlog(p, bad))
    at = len(notes)  # the checksum notes go here once the autopilot is known
    if len(steps) == 2 and abs(steps[0][1] + steps[1][1]) < CLOCK_STEP_S:  # out and back
        (k, d), (k2, _) = steps
        notes.append(f"{p.name}: the receive times of messages {k:,} to {k2 - 1:,} are off by "
                     f"{d:+.4g} s (a corrupt stamp) while the autopilot's own clock runs on: "
                     "taken back onto the clock around them")
    elif steps:
        k, d = steps[0]
        notes.append(f"{p.name}: the ground station's receive clock jumps by {d:+.4g} s at message "
                     f"{k:,} while the autopilot's own clock runs on"
                     + (f" ({len(steps) - 1} more jump(s))" if len(steps) > 1 else "")
                     + ": an NTP correction or a clock set by hand; the receive times after it are "
                     "taken back onto the clock before (the autopilot's stamps are kept)")
    raw = RawLog(p, kind, senders, series, params, None, notes, bad_data=bad,
                 same_recv=int(same_recv))
    _finish(raw)
    if cut is not None:
        ts = [sr.t[np.isfinite(sr.t)] for sr in raw.series.values() if sr.t is not None]
        ts = np.concatenate(ts) if ts else np.zeros(0)
        when = (f"t = {float(ts.max() - ts.min()):.6g} s from the log's start (autopilot clock "
                f"{float(ts.max()):.6g} s)" if ts.size else "an unknown time")
        raw.warnings.append(f"{p.name}: the log is cut off — its last record ({cut[0]}, {cut[1]} "
                            f"of {cut[2]} bytes) is incomplete (copied while being written, or "
                            f"the card was full); the last complete record is at {when}")
    if skipped is not None:
        good = None if gaps else {(mt, *src): c for src, s in senders.items()
                                  for mt, c in s.counts.items()}
        keep = {} if whole_file else {"types": TLOG_KEEP | {"PARAM_VALUE"}, "sender": raw.autopilot}
        raw.warnings[at:at] = skipped.notes(p.name, mavutil, good=good, **keep)
    return raw


def _joined_out_of_order(p: Path, at: int, before: float, after: float) -> str:
    """Why a telemetry log whose receive clock and autopilot clock both go back is refused."""
    where = f"byte {at:,}" if at >= 0 else "the place it does"
    return (f"{p.name}: its receive clock goes back by {before - after:,.1f} s at {where} while the "
            "autopilot's clock restarts (a reboot keeps the receive clock running on): several "
            "telemetry logs joined into one out of order, or a log appended to itself? split it "
            f"at {where} and read each log apart")


def _cannot_read(p: Path, kind: str, what: str) -> str:
    """Why pymavlink failed on ``p`` in words about the log (never its internal error text):
    a telemetry log whose receive clock goes back holds several sessions (``cat a.tlog b.tlog``),
    which pymavlink cannot index."""
    if kind == "tlog":
        back = tlog_clock_back(p)
        if back is not None:
            at, t0, t1 = back
            return (f"{p.name}: its receive clock goes back by {t0 - t1:,.1f} s at byte {at:,} "
                    "(several telemetry logs joined into one, e.g. with cat?): pymavlink cannot "
                    f"read such a file; split it at byte {at:,} and read each log apart")
    return (f"{p.name}: pymavlink cannot {what} the log (an error inside its reader): the file is "
            f"damaged or not an ArduSub {'telemetry' if kind == 'tlog' else 'dataflash'} log")


def _utc(t: float) -> str:
    """A receive time (UNIX s) as UTC date and time."""
    from datetime import datetime

    return datetime.fromtimestamp(t, UTC).strftime("%Y-%m-%d %H:%M:%S UTC")


def _enum(name: str, value) -> str:
    try:
        from pymavlink.dialects.v20 import ardupilotmega as d

        e = d.enums[name][int(value)].name
        return e.split("_", 2)[-1] if name == "MAV_TYPE" else e.replace("MAV_AUTOPILOT_", "")
    except Exception:
        return str(value)


def _pick_autopilot(raw: RawLog) -> tuple[int, int] | None:
    if raw.format == "dataflash":
        return (0, 0)
    aps = [s for s in raw.senders.values() if s.hb is not None and s.hb[1] != 8]
    if aps:
        subs = [s for s in aps if s.hb[0] == 12] or aps
        best = max(subs, key=lambda s: sum(s.counts.values()))
        if len(subs) > 1:
            raw.warnings.append("several autopilots send HEARTBEATs ("
                                + ", ".join(f"system {s.src[0]} component {s.src[1]}"
                                            for s in subs)
                                + f"); reading system {best.src[0]} component {best.src[1]}, "
                                  "which sent the most messages")
        return best.src
    cands = [s for s in raw.senders.values() if s.src[1] == 1 and s.counts.get("ATTITUDE")]
    if len(cands) == 1:
        raw.warnings.append(f"no autopilot HEARTBEAT in the log; system {cands[0].src[0]} "
                            "component 1 (the only one sending ATTITUDE) taken as the autopilot")
        return cands[0].src
    n = sum(sum(s.counts.values()) for s in raw.senders.values())
    recv = [t for s in raw.senders.values() for t in (s.first_recv, s.last_recv) if t == t]
    span = max(recv) - min(recv) if recv else 0.0
    if n < 1000 or span < 10.0:  # a log cut off before the vehicle said what it is
        raise LogDataError(f"{raw.name}: the log ends after {raw.path.stat().st_size:,} bytes "
                           f"({n:,} messages over {span:.3g} s) without an autopilot HEARTBEAT: "
                           "cut off (copied while being written)? The vehicle among the senders "
                           f"({', '.join(f'{a}/{b}' for a, b in raw.senders)}) is unknown")
    raise LogDataError(f"{raw.name}: no autopilot HEARTBEAT, so the vehicle among the senders "
                       f"({', '.join(f'{a}/{b}' for a, b in raw.senders)}) is unknown")


def _part_index(boot: np.ndarray) -> np.ndarray:
    """Part number of each sample: a new part starts where the clock falls more than 1 s below
    the running maximum of the current part (a reboot; late messages do not start one)."""
    part = np.zeros(boot.size, dtype=int)
    k, runmax = 0, -np.inf
    for i, v in enumerate(boot.tolist()):  # one comparison per message, as read
        if v == v:  # not NaN
            if v < runmax - 1.0:
                k += 1
                runmax = -np.inf
            runmax = max(runmax, v)
        part[i] = k
    return part


def _finish(raw: RawLog) -> None:
    """Choose the autopilot, find reboots, put every kept series on the time base."""
    raw.autopilot = _pick_autopilot(raw)
    if raw.format == "dataflash":
        _finish_dataflash(raw)
    else:
        _finish_tlog(raw)


def _isolated_stamps(b: np.ndarray) -> np.ndarray:
    """Stamps of a densely logged series (the reference, ATT) more than :data:`RECV_MARGIN_S`
    from both neighbours (from the one neighbour at its ends) while the neighbours agree: a
    corrupt time field, not a reboot."""
    n = b.size
    if n < 3:
        return np.zeros(n, bool)
    far_prev = np.concatenate(([True], np.abs(np.diff(b)) > RECV_MARGIN_S))
    far_next = np.concatenate((np.abs(np.diff(b)) > RECV_MARGIN_S, [True]))
    around = np.concatenate(([0.0], np.abs(b[2:] - b[:-2]), [0.0])) <= RECV_MARGIN_S
    out = far_prev & far_next & around
    out[0] = far_next[0] and abs(b[2] - b[1]) <= RECV_MARGIN_S
    out[-1] = far_prev[-1] and abs(b[-2] - b[-3]) <= RECV_MARGIN_S
    return out


#: a record before the reference's first or after its last in the log is judged against one
#: reference record only: corrupt when this far (s) from it — no dive lasts a day, while an
#: event record (MODE, ARM) may legitimately come minutes before or after
EDGE_CORRUPT_S = 86400.0


def _stamps_off_reference(b: np.ndarray, seq: np.ndarray, rb: np.ndarray,
                          rseq: np.ndarray) -> np.ndarray:
    """Stamps ``b`` (records at log positions ``seq``) more than :data:`RECV_MARGIN_S` from both
    reference records written just before and just after them (``rb`` at ``rseq``), those two
    agreeing with each other: a corrupt time field.  Judged against the densely logged reference,
    not the record's own type: an event type (MODE, ARM, EV) is logged minutes apart, and its
    records straddle reboots and logging pauses (where the reference records around them
    disagree, and nothing is judged)."""
    if b.size == 0 or rb.size == 0:
        return np.zeros(b.size, bool)
    j = np.searchsorted(rseq, seq)
    has_p, has_n = j > 0, j < rb.size
    pb = np.where(has_p, rb[np.clip(j - 1, 0, rb.size - 1)], np.nan)
    nb = np.where(has_n, rb[np.clip(j, 0, rb.size - 1)], np.nan)
    with np.errstate(invalid="ignore"):
        both = has_p & has_n
        inner = both & (np.abs(pb - nb) <= RECV_MARGIN_S) & (np.abs(b - pb) > RECV_MARGIN_S) \
            & (np.abs(b - nb) > RECV_MARGIN_S)
        edge = ~both & (np.abs(b - np.where(has_p, pb, nb)) > EDGE_CORRUPT_S)
    return inner | edge


def _finish_dataflash(raw: RawLog) -> None:
    # a TimeUS far from the records logged around it (a corrupt record) would stretch the log to
    # its time (and split it as a reboot): left out, said.  The reference series (ATT, else the
    # longest) is judged by its own neighbours, every other record by the reference records
    # written around it
    ref0 = raw.get("ATT") or max(raw.series.values(), key=lambda s: len(s.boot), default=None)
    if ref0 is not None:
        rb0 = np.asarray(ref0.boot, dtype=float)
        bad0 = _isolated_stamps(rb0)
        rb_ok, rseq_ok = rb0[~bad0], np.asarray(ref0.seq)[~bad0]
        for (mt, _), sr in raw.series.items():
            b = np.asarray(sr.boot, dtype=float)
            bad = bad0 if sr is ref0 else _stamps_off_reference(b, np.asarray(sr.seq), rb_ok,
                                                                rseq_ok)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                k = int(np.searchsorted(rseq_ok, np.asarray(sr.seq)[i])) if sr is not ref0 else i
                near = rb_ok[min(max(k - 1, 0), rb_ok.size - 1)] if rb_ok.size else math.nan
                raw.warnings.append(
                    f"{raw.name}: {int(bad.sum())} {mt} record(s) carry a TimeUS far from the "
                    f"records logged around them (first: {b[i]:.6g} s where the log is near "
                    f"{near:.6g} s; a corrupt record): left out")
                b[bad] = np.nan
                sr.boot = b
    # one clock for all messages, but log order across types is lost: the parts are found on
    # the ATT series (or the longest one) and each series is split the same way
    ref = raw.get("ATT") or max(raw.series.values(), key=lambda s: len(s.boot), default=None)
    if ref is None:
        np_ = sum(1 for q in raw.params if q[3] == (0, 0))
        raise LogDataError(f"{raw.name}: the log ends after {raw.path.stat().st_size:,} bytes "
                           f"holding only format and parameter records ({np_:,} PARM), none of "
                           f"{', '.join(sorted(DF_KEEP))}: cut off (copied while being written, "
                           "or the card was full)?")
    rb = np.asarray(ref.boot, dtype=float)
    rp = _part_index(rb)
    raw.parts = int(rp.max()) + 1 if rp.size else 1
    offsets = [0.0]
    for k in range(1, raw.parts):
        prev_end = float(np.nanmax(rb[rp == k - 1])) + offsets[-1]
        offsets.append(prev_end + 1.0 - float(np.nanmin(rb[rp == k])))
    if raw.parts > 1:
        raw.warnings.append(f"the autopilot rebooted {raw.parts - 1} time(s) in this dataflash "
                            "log: the log is split into parts; dataflash keeps no clock across "
                            "a reboot, so each part is placed 1 s after the previous one (the "
                            "real gap is unknown)")
    # every series is split where the reference series is, by position in the log; a message
    # between the last reference message of one part and the first of the next belongs to the
    # part whose clock its stamp is nearer to
    rs = np.asarray(ref.seq)
    first = np.asarray([rs[rp == k][0] for k in range(1, raw.parts)], dtype=float)
    last = np.asarray([rs[rp == k - 1][-1] for k in range(1, raw.parts)], dtype=float)
    b_first = np.asarray([rb[rp == k][0] for k in range(1, raw.parts)], dtype=float)
    b_last = np.asarray([rb[rp == k - 1][-1] for k in range(1, raw.parts)], dtype=float)
    for sr in raw.series.values():
        b = np.asarray(sr.boot, dtype=float)
        q = np.asarray(sr.seq, dtype=float)
        part = np.searchsorted(first, q, side="right")
        j = np.searchsorted(last, q, side="right") - 1  # gap after the last of part j
        gap = (j >= 0) & (part == np.maximum(j, 0))  # past part j's last, before part j+1's first
        jj = np.clip(j, 0, max(raw.parts - 2, 0))
        newer = gap & (np.abs(b - b_first[jj]) < np.abs(b - b_last[jj])) if first.size else gap
        part = np.where(newer, j + 1, part)
        sr.part = part
        sr.t = b + np.asarray(offsets)[part]


def _finish_tlog(raw: RawLog) -> None:
    ap = raw.autopilot
    env: dict = {}  # sender → list of (part start receive time, recv array, boot array)
    for src, s in raw.senders.items():
        r = np.asarray(s.stamped_recv, dtype=float)
        b = np.asarray(s.stamped_boot, dtype=float)
        if r.size == 0:
            continue
        cuts = np.flatnonzero(np.diff(_part_index(b))) + 1
        # another session (logs joined with cat): the receive clock runs on far more than the
        # sender's own clock between two of its messages (a link loss advances both)
        sess = np.flatnonzero(np.diff(r) - np.diff(b) > SESSION_JUMP_S) + 1
        cuts = np.union1d(cuts, sess).astype(int)
        if src == raw.autopilot:
            raw.sessions = [int(np.searchsorted(cuts, i)) + 1 for i in sess]
        bounds = [0, *cuts.tolist(), r.size]
        parts = []
        for a, z in zip(bounds[:-1], bounds[1:]):
            parts.append((r[a], r[a:z], b[a:z]))
        s.parts = [pp[0] for pp in parts[1:]]
        env[src] = parts
    if ap not in env:
        raise LogDataError(f"{raw.name}: the autopilot (system {ap[0]} component {ap[1]}) sent no "
                           "message with an on-board time stamp (time_boot_ms), so its messages "
                           "cannot be put on its clock")
    ap_parts = env[ap]
    raw.parts = len(ap_parts)
    off0 = [float(np.min(rr - bb)) for _, rr, bb in ap_parts]
    C = [o - off0[0] for o in off0]
    for k in range(1, raw.parts):  # a new session: 1 s after the previous part (as dataflash)
        if k in raw.sessions:
            C[k] = float(np.max(ap_parts[k - 1][2])) + C[k - 1] + 1.0 - float(np.min(ap_parts[k][2]))
    if raw.sessions:
        raw.warnings.append(
            "the ground station's receive clock jumps ahead of the autopilot's by more than "
            f"{SESSION_JUMP_S:g} s at "
            + ", ".join(f"{_utc(ap_parts[k][0])} (after a gap of "
                        f"{ap_parts[k][0] - float(np.max(ap_parts[k - 1][1])):.6g} s)"
                        for k in raw.sessions)
            + ": another recording session (logs joined with cat?); each session is a part of "
              "its own, placed 1 s after the previous one on the time base")
    if raw.parts - len(raw.sessions) > 1:
        raw.warnings.append(f"the autopilot rebooted {raw.parts - 1 - len(raw.sessions)} time(s) "
                            "during the log: it is "
                            "split into parts, each on the autopilot's clock, joined by the "
                            "ground station's receive clock")
    # other senders: offset of their boot clock to the autopilot's
    for src, parts in env.items():
        if src == ap:
            continue
        o = float(np.median(np.concatenate([rr - bb for _, rr, bb in parts])))
        raw.senders[src].clock_offset = float(np.median(
            np.concatenate([rr - bb for _, rr, bb in ap_parts]))) - o
    raw.senders[ap].clock_offset = 0.0

    def part_of(src, recv):
        starts = np.asarray([pp[0] for pp in env[src]], dtype=float)
        return np.clip(np.searchsorted(starts, recv, side="right") - 1, 0, len(starts) - 1)

    # the receive times of every sender's stamped messages (a corrupt stamp lies far outside)
    span = (min(float(np.min(rr)) for ps in env.values() for _, rr, _ in ps),
            max(float(np.max(rr)) for ps in env.values() for _, rr, _ in ps))
    for (mt, src), sr in raw.series.items():
        recv = np.asarray(sr.recv, dtype=float)
        boot = np.asarray(sr.boot, dtype=float)
        if src not in env:
            sr.t = np.full(recv.size, np.nan)
            sr.part = np.zeros(recv.size, dtype=int)
            continue
        part = part_of(src, recv)
        b = boot.copy()
        miss = ~np.isfinite(b)
        n_bad = 0
        for k, (_, rr, bb) in enumerate(env[src]):
            sel = part == k
            if sel.any():
                mapped = _boot_from_log(recv[sel], rr, bb)
                # a receive time outside the log's stamped messages by more than a minute is
                # the suspect (a corrupt stamp): it maps nothing; an own stamp stays
                off = (recv[sel] < span[0] - RECV_MARGIN_S) | (recv[sel] > span[1] + RECV_MARGIN_S)
                # a stamp far from what its receive time says (a 32-bit time_usec whose wrap
                # was mistaken for a reboot, a corrupt field) is replaced by the mapped value
                far = (~np.isfinite(b[sel]) | (np.abs(b[sel] - mapped) > 60.0)) & ~off
                n_bad += int(np.count_nonzero(far & ~miss[sel]))
                b[np.flatnonzero(sel)[far]] = mapped[far]
                lost = off & miss[sel]
                if lost.any():
                    b[np.flatnonzero(sel)[lost]] = math.nan
                    raw.warnings.append(
                        f"{int(lost.sum())} {mt} message(s) from system {src[0]} component "
                        f"{src[1]} carry receive times more than {RECV_MARGIN_S:g} s outside the "
                        "log's (a corrupt stamp) and no time of their own: left out")
        if n_bad:
            raw.warnings.append(f"{n_bad} {mt} time stamps from system {src[0]} component "
                                f"{src[1]} disagree with that sender's clock by more than 60 s; "
                                "their receive time (mapped onto the clock) is used instead")
        if src == ap:
            t = b + np.asarray(C)[part]
        else:  # their clock → receive clock → the autopilot's
            t = np.full(b.size, np.nan)
            for k, (_, rr, bb) in enumerate(env[src]):
                sel = part == k
                if sel.any():
                    recv_est = b[sel] + np.interp(b[sel], bb, rr - bb)
                    ap_k = part_of(ap, recv_est)
                    tt = np.empty(recv_est.size)
                    for q, (_, ar, ab) in enumerate(ap_parts):
                        s2 = ap_k == q
                        if s2.any():
                            tt[s2] = recv_est[s2] - float(np.min(ar - ab)) + C[q]
                    t[sel] = tt
        sr.t, sr.part = t, part
