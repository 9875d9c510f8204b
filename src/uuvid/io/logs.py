"""Logs as users have them: CSV/Parquet tables, ROS 1 / ROS 2 bags, ArduSub telemetry and dataflash.

Every reader returns :class:`~uuvid.core.response.TimeResponse` — time [s] plus named channels
in SI units — so a recorded dive goes wherever a simulated one goes.

* :func:`read_log_csv` — one row per sample (CSV, or Parquet with ``pyarrow``), channels picked by
  column name and converted from the units you name.
* :func:`read_rosbag` — any message type of a ROS 1 ``.bag`` or a ROS 2 bag directory (sqlite3 or
  MCAP) through the ``rosbags`` package; channels are ``"topic:field.path"`` (nested fields,
  array indices).
* :func:`read_ardusub` — ArduSub ``.tlog`` (MAVLink telemetry as saved by QGroundControl or
  MAVProxy) and ``.bin`` dataflash logs through ``pymavlink``, with defaults for depth, attitude
  and the servo (thruster) outputs.
* :func:`align` — put channels recorded at their own rates on one time axis.

Bags and telemetry carry every topic at its own rate.  With ``resample=None`` (the default) the
readers therefore return ``{channel: TimeResponse}``, each with the channel's own samples;
``resample="union"`` (every time stamp of every channel) or ``resample=dt`` (a uniform grid)
returns one :class:`TimeResponse` instead, the same as ``align(readers_output, ...)``.

Every problem raises :class:`LogDataError` (a ``ValueError``) naming the file and the column /
topic / message and the row, in the style of :class:`uuvid.io.bench.BenchDataError`.  The
optional packages (``pyarrow``, ``rosbags``, ``pymavlink``) are imported only when needed; a
missing one raises :class:`ImportError` naming ``pip install 'uuvid[logs]'``.

``meta`` of every result holds ``source`` (file name), ``path``, ``format``, ``units`` (SI unit per
channel), ``original_units`` (the unit the log used) and ``original_names`` (the column, the
``topic:field`` or the ``MESSAGE.field`` each channel came from), plus reader-specific entries
documented with each reader.
"""

from __future__ import annotations

import contextlib
import csv
import math
import os
import re
import sys
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from uuvid.core import units as U
from uuvid.core.response import TimeResponse
from uuvid.io.bench import _norm, _table_from_rows
from uuvid.io.bench import _Table as _BenchTable

__all__ = [
    "LogDataError",
    "read_log_csv",
    "read_rosbag",
    "read_ardusub",
    "align",
    "convert_units",
    "CHANNEL_UNITS",
    "TIME_UNITS",
    "ARDUSUB_TLOG_FIELDS",
    "ARDUSUB_DATAFLASH_FIELDS",
]

_EXTRA_HINT = "install it with `pip install 'uuvid[logs]'`"


class LogDataError(ValueError):
    """A log is unreadable or invalid; the message names file, column/topic/message and row."""


class LogWarning(UserWarning):
    """A log was read, but not the way it should have been (damaged past a point, …)."""


#: bytes after the last message pymavlink's index holds beyond which the index stopped early
INDEX_SLACK_BYTES = 1024


def _damaged_index_note(name: str, stop: tuple[int, int]) -> str:
    """What :func:`_index_stops_early` found, for a log's warnings."""
    return (f"{name}: the log is damaged at byte {stop[0]:,} of {stop[1]:,}: pymavlink's index "
            "stops there, so every message was read in turn past the damage (slower)")


@contextlib.contextmanager
def _captured_output(lines: list):
    """Collect what is written to stdout and stderr — pymavlink prints from Python and from C —
    into ``lines`` instead of the terminal: Python's ``sys.stdout``/``sys.stderr`` into a buffer,
    and file descriptors 1 and 2 into a temporary file meanwhile (where they exist)."""
    import io
    import warnings

    py = io.StringIO()  # Python's prints: sys.stdout/stderr may not write to fd 1/2 (Jupyter)
    caught: list = []
    try:
        with warnings.catch_warnings(record=True) as caught:  # warnings are not prints
            warnings.simplefilter("always")
            with _redirected(py, lines):
                yield
    finally:
        for w in caught:  # re-issued once the terminal and the filters are back
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)


@contextlib.contextmanager
def _redirected(py, lines: list):
    """The redirection of :func:`_captured_output` (stdout/stderr into ``py``, file descriptors
    1 and 2 into a temporary file), collected into ``lines``."""
    import tempfile

    try:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = [os.dup(1), os.dup(2)]
    except (OSError, ValueError, AttributeError):  # no real descriptors (an embedded interpreter)
        with contextlib.redirect_stdout(py), contextlib.redirect_stderr(py):
            yield
        lines.extend(py.getvalue().splitlines())
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            with contextlib.redirect_stdout(py), contextlib.redirect_stderr(py):
                yield
        finally:
            lines.extend(py.getvalue().splitlines())
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            finally:
                os.dup2(saved[0], 1)
                os.dup2(saved[1], 2)
                os.close(saved[0])
                os.close(saved[1])
            tmp.seek(0)
            lines.extend(tmp.read().decode("utf-8", "replace").splitlines())


def _index_stops_early(conn) -> tuple[int, int] | None:
    """``(offset, size)`` when a dataflash log's message index (built by pymavlink when it opens
    the file; a filtered read uses it) ends well before the file does — it stops at the first
    message of an unknown type, so one damaged byte would cut the rest of the log silently."""
    try:
        size = int(conn.data_len)
        last = max((max(o) for o in conn.offsets if o), default=0)
    except (AttributeError, TypeError, ValueError):
        return None
    return (int(last), size) if size - last > INDEX_SLACK_BYTES else None


def _dataflash_cut(conn) -> tuple[str, int, int] | None:
    """``(type, bytes present, record length)`` when a dataflash file ends inside its last
    record (pymavlink indexes it but cannot decode it, and says nothing)."""
    try:
        size = int(conn.data_len)
        last, i = max((max(o), i) for i, o in enumerate(conn.offsets) if o)
        fmt = conn.formats[i]
        need = int(fmt.len)
    except (AttributeError, TypeError, ValueError, KeyError, IndexError):
        return None
    return (str(fmt.name), size - int(last), need) if last + need > size else None


#: what the ArduSub log readers read, for their errors
ARDUSUB_KINDS = ("expected an ArduSub log file: .tlog (MAVLink telemetry, as QGroundControl or "
                 "BlueOS save it), .bin or .log (dataflash, from the autopilot)")


def _ardusub_kind(p: Path) -> str:
    """``"tlog"`` or ``"dataflash"`` for an ArduSub log file, by its suffix; a clear
    :class:`LogDataError` naming the file for anything else (no file, a folder, a ROS bag, an
    empty file, another suffix, a ``.log`` that is no dataflash text log)."""
    from uuvid.io.bag_path import bag_instead

    if bag_instead(p):
        raise LogDataError(bag_instead(p))
    if p.is_dir():
        raise LogDataError(f"{p}: a folder, not a log file; {ARDUSUB_KINDS}")
    if not p.is_file():
        raise LogDataError(f"{p}: no such log file")
    suffix = p.suffix.lower()
    if suffix not in (".tlog", ".bin", ".log"):
        raise LogDataError(f"{p.name}: unknown log type {p.suffix!r}; expected .tlog (MAVLink "
                           "telemetry), .bin or .log (ArduSub dataflash)")
    try:
        size = p.stat().st_size
    except OSError as e:
        raise LogDataError(f"{p}: cannot read the log ({e.strerror or e})") from None
    if size == 0:
        raise LogDataError(f"{p.name}: the file is empty (0 bytes); {ARDUSUB_KINDS}")
    if suffix == ".tlog":
        return "tlog"
    if suffix == ".bin":
        return "dataflash"
    from pymavlink import DFReader

    try:
        text = DFReader.DFReader_is_text_log(str(p))
    except (UnicodeDecodeError, ValueError):  # binary bytes: pymavlink reads the head as text
        text = False
    if not text:
        raise LogDataError(f"{p.name}: a .log file that is not a dataflash text log (its first "
                           "line is not an 'FMT, ...' record); a binary dataflash log ends in .bin, "
                           "a MAVLink telemetry log in .tlog")
    return "dataflash"


def _not_a_tlog(p: Path, bad: int) -> str:
    """The error for a ``.tlog`` in which no MAVLink message decodes (random bytes decode as a
    stray UNKNOWN_n or nothing)."""
    with open(p, "rb") as f:
        head = f.read(2)
    hint = ("; it starts like a dataflash log: is it a .BIN under another suffix?"
            if head == b"\xa3\x95" else "")
    return (f"{p.name}: no MAVLink message could be decoded ({bad:,} undecodable frame(s) in "
            f"{p.stat().st_size:,} bytes): not a telemetry log{hint}; {ARDUSUB_KINDS}")


#: undecodable frames at the head of a .tlog after which it is read anyway (a damaged start)
TLOG_PROBE_FRAMES = 2000


def _tlog_decodes(conn) -> tuple[bool, int]:
    """Whether a known MAVLink message decodes near the head of a telemetry log, and how many
    frames did not before it; the log is rewound.  (pymavlink's index of a telemetry log does not
    check checksums: random bytes list nine message types.)"""
    bad = 0
    try:
        for _ in range(TLOG_PROBE_FRAMES):
            m = conn.recv_msg()
            if m is None:
                return False, bad
            if m.get_type() != "BAD_DATA" and not m.get_type().startswith("UNKNOWN_"):
                return True, bad
            bad += 1
        return True, bad  # a long damaged head: read what follows
    finally:
        conn.rewind()


def _check_tlog(conn, p: Path) -> None:
    """The one test of both ArduSub readers that a ``.tlog`` is a telemetry log (a known MAVLink
    message decodes near its head, :func:`_tlog_decodes`): else a clear error naming it, the
    connection closed."""
    ok, bad = _tlog_decodes(conn)
    if not ok:
        conn.close()
        raise LogDataError(_not_a_tlog(p, bad))


#: a receive stamp this close (s) to the last good one can start a frame (pymavlink's own scan)
RESYNC_WINDOW_S = 3 * 24 * 3600.0
#: a message type failing its checksum in at least this share of its frames from one sender is
#: the sender's doing (another message definition), not damage to the file
SENDER_CRC_SHARE = 0.1


class _Skipped:
    """The bytes a telemetry log's reader skips, said instead of lost silently.  pymavlink gives
    a frame it cannot decode as a BAD_DATA message and resumes where its receive-stamp scan
    finds a plausible stamp, which can be several frames on (a corrupt length byte swallowed
    265 bytes, six good messages with it).  :meth:`stream` yields the decoded messages; between
    two of them the bytes skipped are either one *whole frame* failing its checksum (a corrupt
    payload byte, or a sender whose message definition differs from pymavlink's) or a *damaged
    stretch*, which is searched again frame by frame so only the damaged messages are lost.
    A log whose index has no gap (:func:`_tlog_index_check`) is read without :meth:`stream`: its
    BAD_DATA can only be whole frames, each given to :meth:`bad` with where it starts.
    ``partial``: the bytes of a last record cut off while the log was written (not damage)."""

    def __init__(self, conn, partial: int = 0):
        self.conn = conn
        self.end = 0  # file position after the last decoded message
        self.bads: list = []  # BAD_DATA messages since then
        self.last_recv = math.nan
        self.t0 = math.nan
        self.n = 0  # messages yielded
        self.frames: dict = {}  # (message id, system, component) → [count, first byte]
        self.good: Counter = Counter()  # (message id, system, component) → decoded
        self.stretches: list = []  # (first byte, bytes lost, message before, recv before)
        self.recovered = 0
        self.partial = partial
        data = getattr(conn, "data_map", None)
        self.size = len(data) if data is not None else 0

    def stream(self):
        conn = self.conn
        while True:
            m = conn.recv_msg()
            if m is None:  # failed frames or bytes at the end: said as those between messages
                yield from self._tail()
                return
            if m.get_type() == "BAD_DATA":
                self.bads.append(m)
                yield m
                continue
            try:
                pos = int(conn.f.tell())
            except (AttributeError, OSError, ValueError):
                pos = None
            if self.bads and pos is not None:
                yield from self._between(pos - 8 - len(m.get_msgbuf()))
            self.bads = []
            if pos is not None:
                self.end = pos
            self._seen(m)
            yield m

    def bad(self, m, at: int) -> None:
        """A BAD_DATA message read from the record at byte ``at`` of a log whose index has no gap
        (a whole frame failing its checksum; a record cut off at the end is the partial one)."""
        if self.partial and at >= self.size - self.partial:
            return
        data = bytes(getattr(m, "data", b""))
        if len(data) > 9 and "CRC" in str(getattr(m, "reason", "")):
            self._frame(data, at)
        else:
            self.stretches.append((at, len(data) + 8, None, math.nan, math.nan))

    def _frame(self, data: bytes, at: int) -> None:
        v2 = data[0] == 0xFD
        mid = int.from_bytes(data[7:10], "little") if v2 else data[5]
        key = (mid, *((data[5], data[6]) if v2 else (data[3], data[4])))
        self.frames.setdefault(key, [0, at])[0] += 1

    def _seen(self, m) -> None:
        self.n += 1
        self.good[(m.get_msgId(), m.get_srcSystem(), m.get_srcComponent())] += 1
        recv = float(getattr(m, "_timestamp", math.nan))
        if recv == recv:
            self.last_recv = recv
            if self.t0 != self.t0:
                self.t0 = recv

    def _tail(self):
        """The bytes after the last decoded message: whole records (failing their checksum) or a
        damaged stretch, then perhaps one record cut off while the log was written."""
        data = getattr(self.conn, "data_map", None)
        if data is None or self.end >= self.size:
            return
        o = self.end
        while o < self.size and not _tlog_partial(data, o):
            q = _tlog_frame_end(data, o)
            if q is None:
                break
            o = q
        hi = self.size
        if o < self.size and _tlog_partial(data, o):
            self.partial, hi = self.size - o, o
        if hi > self.end:
            yield from self._between(hi)
        self.bads = []

    def _between(self, start: int):
        """The bytes from the last decoded message to ``start`` (the next one's receive stamp)."""
        size = start - self.end
        datas = [bytes(getattr(b, "data", b"")) for b in self.bads]
        if (datas and sum(len(d) + 8 for d in datas) == size and all(len(d) > 9 for d in datas)
                and all("CRC" in str(getattr(b, "reason", "")) for b in self.bads)):
            at = self.end  # whole frames, each behind its receive stamp: their checksums failed
            for data in datas:
                self._frame(data, at)
                at += len(data) + 8
            return
        before, lo, got, prev = self.n, self.end, 0, self.last_recv
        for m, nbytes in self._search(self.end, start):
            got += nbytes
            self.recovered += 1
            self._seen(m)
            yield m
        data = getattr(self.conn, "data_map", None)
        after = (int.from_bytes(bytes(data[start:start + 8]), "big") * 1e-6
                 if data is not None and start + 8 <= self.size else math.nan)
        self.stretches.append((lo, size - got, before, prev if before else math.nan, after))

    def _search(self, lo: int, hi: int):
        """Valid frames (each behind a plausible receive stamp) in the file's bytes ``lo:hi``."""
        buf = getattr(self.conn, "data_map", None)
        ref = self.last_recv
        if buf is None or hi <= lo or ref != ref:
            return
        buf = bytes(buf[lo:hi])
        i = 0
        while i + 8 + 12 <= len(buf):
            t = int.from_bytes(buf[i:i + 8], "big") * 1e-6
            q = _tlog_frame_end(buf, i) if abs(t - ref) <= RESYNC_WINDOW_S else None
            if q is not None:
                n = q - i - 8
                if q <= len(buf):
                    try:
                        m = self.conn.mav.decode(bytearray(buf[i + 8:q]))
                    except Exception:  # noqa: BLE001 - any undecodable frame: search on
                        m = None
                    if m is not None:
                        m._timestamp = t
                        yield m, 8 + n
                        i += 8 + n
                        continue
            i += 1

    def notes(self, name: str, mavutil, *, types=None, sender=None, good=None) -> list:
        """What was skipped, said.  Frames failing their checksum are said only of the message
        ``types`` (names) read and of the ``sender`` (system, component; component ``None``:
        any) chosen, when given (``None``: the whole file).  ``good``: ``{(type name, system,
        component): decoded}`` when the log was not read through :meth:`stream`."""
        out = []
        if self.stretches:
            lost = sum(s[1] for s in self.stretches)
            # the receive clock across a stretch: a long jump is time lost, not a few bytes
            gaps = [a - r for _, _, _, r, a in self.stretches if a - r > TLOG_GAP_S]
            where = "; ".join(f"byte {b:,} ({k:,} bytes"
                              + (f", after message {n:,}" if n is not None else "")
                              + (f", {r - self.t0:.1f} s into the log" if r == r else "")
                              + (f"; the receive clock jumps {a - r:.1f} s across them, to "
                                 f"{a - self.t0:.1f} s" if a - r > TLOG_GAP_S else "") + ")"
                              for b, k, n, r, a in self.stretches[:3])
            more = f"; {len(self.stretches) - 3} more" if len(self.stretches) > 3 else ""
            back = (f"; {self.recovered:,} valid message(s) found again inside them"
                    if self.recovered else "")
            out.append(f"{name}: the log is damaged in {len(self.stretches)} place(s), {lost:,} "
                       f"bytes skipped: {where}{more}{back}; the reader resumed at the next valid "
                       "message, "
                       + (f"but {sum(gaps):.1f} s of the log are lost there (the messages "
                          "received in that time are missing, not just those in the damaged "
                          "bytes)" if gaps else "so only the messages in the damaged bytes are "
                          "lost"))
        names = getattr(getattr(mavutil, "mavlink", None), "mavlink_map", None) or {}
        damage, senders = [], []
        for key, (c, first) in sorted(self.frames.items(), key=lambda kv: kv[1][1]):
            nm = getattr(names.get(key[0]), "msgname", None) or f"message id {key[0]}"
            if types is not None and nm not in types:
                continue
            if sender is not None and (key[1] != sender[0]
                                       or sender[1] is not None and key[2] != sender[1]):
                continue
            who = f"{nm} from system {key[1]} component {key[2]}"
            ok = good.get((nm, key[1], key[2]), 0) if good is not None else self.good.get(key, 0)
            if c >= SENDER_CRC_SHARE * (c + ok):
                senders.append((c, who))
            else:
                damage.append((c, f"{who} at byte {first:,}"))
        if damage:
            out.append(f"{name}: {sum(c for c, _ in damage):,} message(s) fail their checksum (a "
                       "corrupt byte) and are skipped: "
                       + "; ".join(f"{c:,} {w}" for c, w in damage[:4])
                       + (f"; {len(damage) - 4} more" if len(damage) > 4 else ""))
        if senders:
            senders.sort(key=lambda cw: -cw[0])
            out.append(f"{name}: {sum(c for c, _ in senders):,} message(s) fail their checksum in "
                       f"every copy or in over {SENDER_CRC_SHARE:.0%} of them — a sender whose "
                       "message definition differs from pymavlink's, not damage; skipped: "
                       + "; ".join(f"{c:,} {w}" for c, w in senders[:4])
                       + (f"; {len(senders) - 4} more type(s)" if len(senders) > 4 else ""))
        if self.partial:
            out.append(f"{name}: the log ends in a partial message ({self.partial:,} bytes): cut "
                       "off while written?")
        return out


#: damaged bytes across which the receive clock jumps more than this (s) lost that much time
TLOG_GAP_S = 2.0
#: the shortest whole record of a telemetry log: receive stamp + a MAVLink 1 frame, no payload
TLOG_MIN_RECORD = 8 + 8


def _tlog_frame_end(data, o: int) -> int | None:
    """The end of the telemetry-log record (receive stamp + frame) at byte ``o``, or ``None``."""
    if o + 11 > len(data) or data[o + 8] not in (0xFD, 0xFE):
        return None
    if data[o + 8] == 0xFD:
        return o + 8 + 12 + data[o + 9] + (13 if data[o + 10] & 1 else 0)
    return o + 8 + 8 + data[o + 9]


def tlog_clock_back(p: Path) -> tuple[int, float, float] | None:
    """The first place a telemetry log's receive clock goes back by more than a second —
    ``(byte offset, stamp before, stamp after)`` in UNIX s — as when several logs are joined
    with ``cat``; ``None`` when it never does (read along the chain of whole records)."""
    import struct

    data = p.read_bytes()
    o, last = 0, None
    while True:
        q = _tlog_frame_end(data, o)
        if q is None or q > len(data):
            return None
        t = struct.unpack(">Q", data[o:o + 8])[0] * 1e-6
        if last is not None and t < last - 1.0:
            return o, last, t
        last = t if last is None else max(last, t)
        o = q


def _tlog_partial(data, o: int) -> bool:
    """Whether the bytes from ``o`` to the end of a telemetry log are one record cut off while it
    was written: too few for any whole record, or a frame header asking for more than remain."""
    rest = len(data) - o
    if rest <= 0:
        return False
    if rest < TLOG_MIN_RECORD:
        return True
    q = _tlog_frame_end(data, o)
    return q is not None and q > len(data)


def _tlog_index_check(conn) -> tuple[bool, int]:
    """Whether pymavlink's index of a telemetry log has a gap (a record that does not end where
    the next indexed one starts, with no chain of frames of types it does not know between),
    and the bytes of a last record cut off while the log was written (the end of the log, not
    a gap)."""
    data = getattr(conn, "data_map", None)
    offsets = getattr(conn, "offsets", None)
    if data is None or not offsets:
        return False, 0
    starts = sorted(o for lst in offsets.values() for o in lst)
    for o, nxt in zip(starts, starts[1:]):
        q = _tlog_frame_end(data, o)
        while q is not None and q < nxt:
            q = _tlog_frame_end(data, q)
        if q != nxt:
            return True, 0
    o = starts[-1]
    while o < len(data):
        if _tlog_partial(data, o):
            return False, len(data) - o
        q = _tlog_frame_end(data, o)
        if q is None:
            return True, 0
        o = q
    return False, 0


def _require(module: str, what: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as e:
        top = module.split(".")[0]
        raise ImportError(f"{what} needs the optional package {top!r}, which is not installed; "
                          f"{_EXTRA_HINT} (or `pip install {top}`)") from e


# ------------------------------------------------------------------------------------------------
# Units
# ------------------------------------------------------------------------------------------------
#: time unit → seconds per unit (``datetime``: ISO 8601 text, see :func:`read_log_csv`)
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ns": 1e-9, "min": 60.0}

_KNOT = U.KNOT
#: channel unit → (SI unit, SI per unit).  Units whose SI unit is themselves are kept as they are
#: (``pwm_us`` is a command, not a duration).
CHANNEL_UNITS: dict[str, tuple[str, float]] = {
    # length
    "m": ("m", 1.0), "cm": ("m", 0.01), "mm": ("m", 1e-3), "km": ("m", 1e3), "ft": ("m", U.FT),
    "in": ("m", U.INCH),
    # angle
    "rad": ("rad", 1.0), "deg": ("rad", U.DEG), "degrees": ("rad", U.DEG), "°": ("rad", U.DEG),
    "cdeg": ("rad", 0.01 * U.DEG), "cdeg/s": ("rad/s", 0.01 * U.DEG),
    # angular speed
    "rad/s": ("rad/s", 1.0), "deg/s": ("rad/s", U.DEG), "°/s": ("rad/s", U.DEG),
    "rpm": ("rad/s", U.RPM), "rev/s": ("rad/s", 2.0 * math.pi),
    # speed, acceleration
    "m/s": ("m/s", 1.0), "cm/s": ("m/s", 0.01), "mm/s": ("m/s", 1e-3), "km/h": ("m/s", U.KMH),
    "kn": ("m/s", _KNOT), "knot": ("m/s", _KNOT), "knots": ("m/s", _KNOT), "ft/s": ("m/s", U.FT),
    "m/s^2": ("m/s^2", 1.0), "m/s/s": ("m/s^2", 1.0), "m/s²": ("m/s^2", 1.0),
    # force, torque
    "N": ("N", 1.0), "kN": ("N", 1e3), "kgf": ("N", U.KGF), "lbf": ("N", U.LBF),
    "gf": ("N", U.G0 / 1000.0),
    "N·m": ("N·m", 1.0), "N*m": ("N·m", 1.0), "Nm": ("N·m", 1.0), "N.m": ("N·m", 1.0),
    # electrical, power, pressure
    "A": ("A", 1.0), "mA": ("A", 1e-3), "cA": ("A", 0.01), "V": ("V", 1.0), "mV": ("V", 1e-3),
    "W": ("W", 1.0), "Pa": ("Pa", 1.0), "hPa": ("Pa", 100.0), "kPa": ("Pa", 1e3),
    "mbar": ("Pa", 100.0), "bar": ("Pa", 1e5), "psi": ("Pa", U.LBF / U.INCH**2),
    # commands and dimensionless: kept as recorded
    "pwm_us": ("pwm_us", 1.0), "cmd": ("cmd", 1.0), "duty": ("duty", 1.0), "1": ("1", 1.0),
    "%": ("%", 1.0), "degC": ("degC", 1.0),
}


def _unit_key(unit: str, table) -> str | None:
    if unit in table:
        return unit
    u = unit.strip().replace("μ", "µ")
    if u in table:
        return u
    low = {k.casefold(): k for k in table}
    # case-insensitive only where it cannot confuse milli with mega
    k = low.get(u.casefold())
    if k is not None and u.casefold() not in ("ma", "mv", "mm"):
        return k
    return None


def convert_units(values, unit: str | None, *, what: str = "") -> tuple[np.ndarray, str | None]:
    """``values`` in ``unit`` → (values in SI, SI unit).  ``unit=None`` means already SI (kept)."""
    v = np.asarray(values, dtype=float)
    if unit is None:
        return v, None
    k = _unit_key(unit, CHANNEL_UNITS)
    if k is None:
        raise LogDataError(f"{what + ': ' if what else ''}unknown unit {unit!r}; known units: "
                           f"{', '.join(CHANNEL_UNITS)}")
    si, factor = CHANNEL_UNITS[k]
    return (v * factor if factor != 1.0 else v), si


# ------------------------------------------------------------------------------------------------
# Shared: series clean-up and alignment
# ------------------------------------------------------------------------------------------------
_DUPLICATES = ("error", "first", "last", "mean")


def _finish_series(t: np.ndarray, v: np.ndarray, *, on_duplicate: str, allow_missing: bool,
                   where: Callable[[int], str], fmt_t: Callable[[float], str]):
    """Check values, sort by time (stable), resolve duplicated stamps.

    ``where(i)`` describes original sample ``i`` for messages.  Returns (t, v, n_reordered).
    """
    bad = np.flatnonzero(~np.isfinite(v))
    if bad.size and not allow_missing:
        i = int(bad[0])
        raise LogDataError(f"{where(i)}: value {v[i]!r} is not a finite number (give "
                           "allow_missing=True to keep missing samples as NaN)")
    inf = np.flatnonzero(np.isinf(v))
    if inf.size:
        i = int(inf[0])
        raise LogDataError(f"{where(i)}: value {v[i]!r} is not finite")
    order = np.argsort(t, kind="stable")
    n_reordered = int(np.count_nonzero(order != np.arange(order.size)))
    t, v = t[order], v[order]
    if t.size > 1:
        dup = np.flatnonzero(np.diff(t) == 0)
        if dup.size:
            if on_duplicate == "error":
                j = int(dup[0])
                a, b = sorted((int(order[j]), int(order[j + 1])))
                raise LogDataError(f"{where(b)}: time stamp {fmt_t(t[j + 1])} is duplicated "
                                   f"(sample {a + 1} has the same); pass on_duplicate='first', "
                                   "'last' or 'mean' to merge duplicates")
            starts = np.concatenate(([True], np.diff(t) != 0))
            groups = np.cumsum(starts) - 1
            tu = t[starts]
            if on_duplicate == "first":
                v = v[starts]
            elif on_duplicate == "last":
                ends = np.concatenate((np.diff(t) != 0, [True]))
                v = v[ends]
            else:  # mean
                v = np.bincount(groups, weights=v) / np.bincount(groups)
            t = tu
    return t, v, n_reordered


def _check_duplicate_option(on_duplicate: str) -> None:
    if on_duplicate not in _DUPLICATES:
        raise LogDataError(f"unknown on_duplicate {on_duplicate!r}; expected one of "
                           f"{', '.join(_DUPLICATES)}")


def _interp(t_src, v_src, grid, how: str):
    if how == "linear":
        return np.interp(grid, t_src, v_src, left=np.nan, right=np.nan)
    if how == "previous":
        idx = np.searchsorted(t_src, grid, side="right") - 1
        out = v_src[np.clip(idx, 0, None)].astype(float)
        out[idx < 0] = np.nan
        out[grid > t_src[-1]] = np.nan
        return out
    if how == "nearest":
        if t_src.size == 1:
            pick = np.zeros(grid.size, dtype=int)
        else:
            idx = np.clip(np.searchsorted(t_src, grid), 1, t_src.size - 1)
            pick = np.where(grid - t_src[idx - 1] <= t_src[idx] - grid, idx - 1, idx)
        out = v_src[pick].astype(float)
        out[(grid < t_src[0]) | (grid > t_src[-1])] = np.nan
        return out
    raise LogDataError(f"unknown interpolation {how!r}; expected linear, previous or nearest")


_PER_CHANNEL_META = ("units", "original_units", "original_names")


MAX_GRID_POINTS = 10_000_000
"""Most points of a uniform resampling grid (checked before it is allocated)."""


def align(responses: Mapping[str, TimeResponse] | Iterable[TimeResponse],
          resample: str | float = "union", *, interp: str | Mapping[str, str] = "linear",
          span: str = "overlap") -> TimeResponse:
    """Put channels recorded at their own rates on one time axis.

    Parameters
    ----------
    responses
        ``{name: TimeResponse}`` as returned by the readers with ``resample=None``, or any
        iterable of :class:`TimeResponse`; every channel of every response is taken (channel
        names must be unique).
    resample
        ``"union"``: every time stamp of every channel; a number: a uniform grid with that step [s].
    interp
        ``"linear"``, ``"previous"`` (zero-order hold — right for commands such as PWM outputs,
        which are held between updates) or ``"nearest"``; or a ``{channel: method}`` mapping
        (channels not named are linear).
    span
        ``"overlap"``: only the interval every channel covers (no NaN); ``"union"``: from the
        first to the last sample of any channel, NaN where a channel has no data.
    """
    items = list(responses.values()) if isinstance(responses, Mapping) else list(responses)
    if not items:
        raise LogDataError("align: no channels to align")
    series: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for r in items:
        t = np.asarray(r.t, dtype=float)
        for name, v in r.channels.items():
            if name in series:
                raise LogDataError(f"align: channel {name!r} appears twice")
            v = np.asarray(v, dtype=float)
            ok = np.isfinite(v)
            if not ok.any():
                raise LogDataError(f"align: channel {name!r} has no finite samples")
            series[name] = (t[ok], v[ok])
    if span not in ("overlap", "union"):
        raise LogDataError(f"align: unknown span {span!r}; expected 'overlap' or 'union'")
    starts = {n: s[0][0] for n, s in series.items()}
    ends = {n: s[0][-1] for n, s in series.items()}
    if span == "overlap":
        lo, hi = max(starts.values()), min(ends.values())
        if lo > hi:
            spans = "; ".join(f"{n}: {starts[n]:g}…{ends[n]:g} s" for n in series)
            raise LogDataError(f"align: the channels do not overlap in time ({spans}); use "
                               "span='union'")
    else:
        lo, hi = min(starts.values()), max(ends.values())
    if isinstance(resample, str):
        if resample != "union":
            raise LogDataError(f"align: unknown resample {resample!r}; expected 'union' or a "
                               "time step in seconds")
        grid = np.unique(np.concatenate([s[0] for s in series.values()]))
        grid = grid[(grid >= lo) & (grid <= hi)]
    else:
        dt = float(resample)
        if not (math.isfinite(dt) and dt > 0):
            raise LogDataError(f"align: the resampling step must be a positive number of seconds, "
                               f"got {resample!r}")
        n = math.floor((hi - lo) / dt + 1e-9) + 1
        if n > MAX_GRID_POINTS:
            raise LogDataError(f"align: a uniform {dt:g} s grid over {hi - lo:.6g} s ({lo:.6g}…"
                               f"{hi:.6g} s) is {n:.3g} points, more than {MAX_GRID_POINTS:,}; "
                               "give a larger resampling step or cut the log (a time stamp far "
                               "from the others stretches the span: check the log's clock)")
        grid = lo + dt * np.arange(n)
    how = ({n: interp.get(n, "linear") for n in series} if isinstance(interp, Mapping)
           else dict.fromkeys(series, interp))
    channels = {n: _interp(t, v, grid, how[n]) for n, (t, v) in series.items()}
    meta: dict = {}
    for r in items:
        for k, val in r.meta.items():
            if k in _PER_CHANNEL_META or isinstance(val, dict):
                meta.setdefault(k, {}).update(val)
            elif k not in meta:
                meta[k] = val
            elif meta[k] != val and not isinstance(meta[k], list):
                meta[k] = [meta[k], val]
            elif isinstance(meta[k], list) and val not in meta[k]:
                meta[k].append(val)
    meta["resample"] = resample if isinstance(resample, str) else float(resample)
    meta["interp"] = how
    meta["span"] = span
    return TimeResponse(grid, channels, meta)


def _maybe_align(out: dict[str, TimeResponse], resample, interp, span):
    if resample is None:
        return out
    return align(out, resample, interp=interp, span=span)


# ------------------------------------------------------------------------------------------------
# CSV / Parquet
# ------------------------------------------------------------------------------------------------
# the table reader shared with bench files: rows with file/column/row locations
_Table = _BenchTable


def _sniff_delimiter(line: str) -> str:
    counts = {d: line.count(d) for d in (",", ";", "\t", "|")}
    best = max(counts, key=counts.get)
    return best if counts[best] else ","


def _read_csv(path: Path, delimiter: str | None, comment: str | None) -> _Table:
    try:
        fh = open(path, newline="", encoding="utf-8-sig")
    except OSError as e:
        raise LogDataError(f"{path.name}: cannot open log file: {e.strerror or e}") from e
    with fh:
        try:
            text = fh.read()
        except UnicodeDecodeError as e:
            raise LogDataError(f"{path.name}: not a readable CSV file (not UTF-8 text): {e}") from e
    lines = text.splitlines(keepends=True)
    first = 0
    while first < len(lines) and (not lines[first].strip()
                                  or (comment and lines[first].lstrip().startswith(comment))):
        first += 1
    if first == len(lines):
        raise LogDataError(f"{path.name}: the file is empty (no header line)")
    delim = delimiter or _sniff_delimiter(lines[first])
    # sections: a line repeating the first header's first column name starts a new header (a
    # QGroundControl CSV export re-declares its columns when telemetry groups appear mid-log);
    # every row is read by its own section's header
    sections: list[tuple[list[str], list, list]] = []
    try:
        reader = csv.reader(lines[first:], delimiter=delim)
        for row in reader:
            lineno = first + reader.line_num
            if not row or all(not c.strip() for c in row):
                continue
            if comment and row[0].lstrip().startswith(comment):
                continue
            if not sections or _norm(row[0]) == _norm(sections[0][0][0]):
                sections.append(([c.strip() for c in row], [], []))
                continue
            sections[-1][1].append(row)
            sections[-1][2].append(lineno)
    except csv.Error as e:
        raise LogDataError(f"{path.name}: not a readable CSV file: {e}") from e
    hint = f" (delimiter {delim!r})"
    grown = []
    for h, r, ln in sections:
        grown += _grown_rows(path.name, h, r, ln)
    if len(grown) == 1:
        return _table_from_rows(path.name, *grown[0][:3], LogDataError, hint)
    out = _merge_sections(path.name, [_table_from_rows(path.name, h, r, ln, LogDataError, hint)
                                      for h, r, ln, _ in grown])
    for sec, (_h, _r, _l, ins) in zip(out.sections, grown):
        if ins is not None:
            sec["inserted_after"] = ins
    return out


def _cell_sim(a: str, b: str) -> float:
    a, b = a.strip(), b.strip()
    if a == b:
        return 1.0
    try:
        x, y = float(a), float(b)
    except ValueError:
        return 0.0
    if not (math.isfinite(x) and math.isfinite(y)):
        return 0.0
    return 0.5 if abs(x - y) <= 0.05 * max(abs(x), abs(y), 1e-9) else 0.25


def _grown_rows(name: str, header: list[str], rows: list, lines: list):
    """Split a section where its rows grow: QGroundControl writes its CSV header once and adds a
    telemetry group's cells when the group appears (a battery found after the first rows,
    mavlink/qgroundcontrol#11763), shifting every later cell to the right.  Where the cells
    were inserted is found by matching the last shorter row with the next longer rows cell by
    cell (the same text, or numbers within 5 %); the new cells are named ``unnamed_<n>``.
    Returns ``[(header, rows, lines, inserted_after or None), ...]``."""
    out = []
    cur, start = list(header), 0
    inserted = None
    i = 0
    while i < len(rows):
        n = len(rows[i])
        if n <= len(cur) or i == start:
            i += 1
            continue
        prev = [r for r in rows[start:i] if len(r) == len(cur)]
        if not prev:
            i += 1
            continue
        m = n - len(cur)
        nxt = [r for r in rows[i:i + 5] if len(r) == n]
        base = prev[-1]
        scores = []
        for j in range(len(cur) + 1):
            idx = [c if c < j else c + m for c in range(len(cur))]
            scores.append(sum(_cell_sim(base[c], r[idx[c]]) for r in nxt
                              for c in range(len(cur))) / len(nxt))
        best = max(scores)
        tied = [j for j, sc in enumerate(scores) if sc == best]
        j = tied[-1]
        # tied insertion points are alike when the cells they would read differently agree
        if any(r[c] != r[c + m] for t in tied for c in range(t, j) for r in nxt):
            raise LogDataError(f"{name}: CSV line {lines[i]} has {n} cells but the header has "
                               f"{len(cur)} columns, and where the {m} new cells were inserted "
                               "cannot be told from the neighbouring rows; write the file with "
                               "one header per column layout")
        out.append((cur, rows[start:i], lines[start:i], inserted))
        k0 = sum(c.startswith("unnamed_") for c in cur)
        new = [f"unnamed_{k0 + q + 1}" for q in range(m)]
        inserted = cur[j - 1] if j else "(the start)"
        cur = cur[:j] + new + cur[j:]
        start = i
        i += 1
    out.append((cur, rows[start:], lines[start:], inserted))
    return out


def _merge_sections(name: str, parts: list[_Table]) -> _Table:
    """One table over the union of the sections' columns (in order of appearance); a column a
    section lacks is empty there.  ``meta``-like ``sections``: (first data row, columns added)."""
    cols: list[str] = []
    for t in parts:
        cols += [c for c in t.columns if c not in cols]
    cells: dict[str, list] = {c: [] for c in cols}
    lines: list[int] = []
    for t in parts:
        n = t.n_rows
        for c in cols:
            cells[c] += t.cells[c] if c in t.cells else [""] * n
        lines += list(t.lines or [])
    out = _Table(name, cols, cells, lines, "CSV")
    out.sections = []  # type: ignore[attr-defined]
    seen: set[str] = set()
    row = 0
    for t in parts:
        added = [c for c in t.columns if c not in seen]
        seen |= set(t.columns)
        out.sections.append({"first_row": row + 1, "columns_added": added if row else [],
                             "n_columns": len(t.columns)})
        row += t.n_rows
    return out


def _read_parquet(path: Path) -> _Table:
    pq = _require("pyarrow.parquet", f"{path.name}: reading Parquet logs")
    import pyarrow as pa

    try:
        tbl = pq.read_table(path)
    except Exception as e:  # pyarrow raises its own error types
        raise LogDataError(f"{path.name}: not a readable Parquet file: {e}") from e
    cols = list(tbl.column_names)
    cells, dtypes = {}, {}
    for c in cols:
        col = tbl.column(c)
        if pa.types.is_timestamp(col.type):
            dtypes[c] = "timestamp"
            # epoch nanoseconds (UTC for zone-aware columns)
            cells[c] = col.cast(pa.timestamp("ns", tz=col.type.tz)).cast(pa.int64()).to_pylist()
        else:
            cells[c] = col.to_pylist()
    return _Table(path.name, cols, cells, None, "Parquet", dtypes)


def _find_column(t: _Table, name: str, role: str) -> str:
    if name in t.cells:
        return name
    matches = [c for c in t.columns if _norm(c) == _norm(name)]
    if len(matches) == 1:
        return matches[0]
    raise LogDataError(f"{t.name}: no column {name!r} for {role}; available columns: "
                       f"{', '.join(repr(c) for c in t.columns)}")


def _numeric(t: _Table, col: str, role: str, allow_missing: bool) -> np.ndarray:
    vals = t.cells[col]
    try:
        out = np.array(vals, dtype=float)
    except (TypeError, ValueError):
        out = None
    if out is not None and np.all(np.isfinite(out)):
        return out
    # slow path: find and name the first bad cell
    res = np.empty(len(vals))
    for i, v in enumerate(vals):
        empty = v is None or (isinstance(v, str) and not v.strip())
        if empty:
            if allow_missing:
                res[i] = np.nan
                continue
            raise LogDataError(f"{t.where(col, i)}: empty cell; expected a number ({role})")
        try:
            x = float(v.strip() if isinstance(v, str) else v)
        except (TypeError, ValueError):
            shown = v.strip() if isinstance(v, str) else v
            comma = isinstance(shown, str) and re.fullmatch(r"[-+]?\d*,\d+([eE][-+]?\d+)?", shown)
            raise LogDataError(f"{t.where(col, i)}: {shown!r} is not numeric; expected a number "
                               f"({role})" + (" — a decimal comma (a European spreadsheet export) or a "
                                             "thousands separator? re-save the file with '.' as the "
                                             "decimal point and no separators"
                                             if comma else "")) from None
        if math.isnan(x) and not allow_missing:
            raise LogDataError(f"{t.where(col, i)}: NaN; expected a number ({role}); give "
                               "allow_missing=True to keep missing samples as NaN")
        if math.isinf(x):
            raise LogDataError(f"{t.where(col, i)}: {x} is not finite; expected a number ({role})")
        res[i] = x
    return res


def _datetime_seconds(t: _Table, col: str) -> np.ndarray:
    import pandas as pd

    vals = t.cells[col]
    out = np.empty(len(vals))
    for i, v in enumerate(vals):
        try:
            ts = pd.Timestamp(v.strip() if isinstance(v, str) else v)
        except (TypeError, ValueError):
            raise LogDataError(f"{t.where(col, i)}: {v!r} is not an ISO 8601 date-time "
                               "(time_unit='datetime')") from None
        if pd.isna(ts):
            raise LogDataError(f"{t.where(col, i)}: empty time stamp")
        if ts.tzinfo is not None:
            ts = ts.tz_convert("UTC").tz_localize(None)
        out[i] = ts.value / 1e9
    return out


def read_log_csv(path, *, time_col: str, columns: Mapping[str, str] | Sequence[str],
                 units: Mapping[str, str] | None = None, time_unit: str = "s",
                 delimiter: str | None = None, comment: str | None = "#",
                 allow_missing: bool = False, on_duplicate: str = "error") -> TimeResponse:
    """Read a table with one row per sample (CSV, or Parquet with ``pyarrow``) into SI channels.

    Parameters
    ----------
    path
        ``.csv``/``.txt``/``.tsv`` text (any other suffix is read as CSV) or ``.parquet``/``.pq``.
    time_col
        The time column (matched exactly, then ignoring case, spacing and µ/u).  Time stamps must
        be strictly increasing; the time axis keeps the file's origin (converted to seconds).
    columns
        ``{channel name: source column}``; a list of column names keeps the names.
    units
        ``{channel name: unit}`` of the source columns, converted to SI (see
        :data:`CHANNEL_UNITS`: ``mm``, ``deg``, ``rpm``, ``kgf``, ``mA``, ...).  Channels not named
        are taken as already SI.
    time_unit
        ``s``, ``ms``, ``us`` (``µs``), ``ns`` or ``min``; ``datetime`` for ISO 8601 text (then
        seconds since 1970-01-01 UTC).  Parquet timestamp columns are recognised by type.
    delimiter
        CSV delimiter; ``None`` guesses from the header line (``,`` ``;`` tab ``|``).
    comment
        Lines starting with this are skipped (``None``: none).
    allow_missing
        Keep empty/NaN cells as NaN instead of raising (the time column must be complete).
    on_duplicate
        Rows with the same time stamp: ``"error"`` (default), ``"first"``, ``"last"`` or
        ``"mean"`` (per channel, over the finite cells of the group); rows out of order are
        then sorted by time (``meta["reordered"]``, ``meta["duplicates"]`` count them;
        ``meta["first_unordered"]`` names the first such row).  Only rows a few steps out of
        order are sorted: a time that jumps back by more than 20 typical steps (and 1 s) is a
        clock restart (a reboot, two recordings in one file) and raises, whatever
        ``on_duplicate``.

    A time column of ISO 8601 text (``2024-05-01 12:00:00.250``, as QGroundControl's CSV export
    writes) is recognised with the default ``time_unit="s"`` (``meta["time_detected"]``).  A CSV
    whose header is repeated mid-file with more columns is read section by section, each row by
    its own header; a column a section lacks is empty there (``meta["sections"]``).  Rows that
    grow without a new header (QGroundControl adds a telemetry group's cells mid-row once the
    group appears) are placed by matching the neighbouring rows; the new cells are named
    ``unnamed_<n>`` (``meta["sections"][i]["inserted_after"]``).

    ``meta``: ``source``, ``path``, ``format`` (``csv``/``parquet``), ``units``,
    ``original_units``, ``original_names`` (source column per channel), ``time_column`` and
    ``time_unit``.
    """
    p = Path(path)
    if not p.exists():
        raise LogDataError(f"{p}: no such log file")
    if not isinstance(columns, Mapping):
        columns = {c: c for c in columns}
    if not columns:
        raise LogDataError(f"{p.name}: no channels requested (columns is empty)")
    if "time" in columns:
        raise LogDataError(f"{p.name}: 'time' cannot be a channel name (it is the time axis); "
                           "give the time column as time_col")
    units = dict(units or {})
    unknown = sorted(set(units) - set(columns))
    if unknown:
        raise LogDataError(f"units given for {', '.join(map(repr, unknown))}, which "
                           f"{'is not a channel' if len(unknown) == 1 else 'are not channels'}; "
                           f"channels: {', '.join(map(repr, columns))}")
    tu = time_unit
    if tu != "datetime":
        key = _unit_key(tu, TIME_UNITS)
        if key is None:
            raise LogDataError(f"unknown time_unit {tu!r}; expected one of "
                               f"{', '.join(TIME_UNITS)} or datetime")
        tu = key
    for name, unit in units.items():
        if unit is not None and _unit_key(unit, CHANNEL_UNITS) is None:
            raise LogDataError(f"{p.name}: unknown unit {unit!r} for channel {name!r}; known units: "
                               f"{', '.join(CHANNEL_UNITS)}")
    if p.suffix.lower() in (".parquet", ".pq"):
        t = _read_parquet(p)
    else:
        t = _read_csv(p, delimiter, comment)
    if t.n_rows == 0:
        raise LogDataError(f"{t.name}: no data rows under the header")
    _check_duplicate_option(on_duplicate)
    tcol = _find_column(t, time_col, "the time")
    detected = False
    if t.dtypes.get(tcol) == "timestamp":
        time = _numeric(t, tcol, "time", False) * 1e-9
        tu = "datetime"
    elif tu == "datetime" or (tu == "s" and _looks_iso(t.cells[tcol])):
        detected = tu != "datetime"
        time = _datetime_seconds(t, tcol)
        tu = "datetime"
    else:
        time = _numeric(t, tcol, f"time, {tu}", False) * TIME_UNITS[tu]
    d = np.diff(time)
    _check_restart(t, tcol, time, d, tu == "datetime")
    bad = np.flatnonzero(d <= 0)
    if bad.size and on_duplicate == "error":
        i = int(bad[0]) + 1
        kind = "duplicated" if d[i - 1] == 0 else "not increasing (unsorted)"
        raise LogDataError(f"{t.where(tcol, i)}: time stamp {time[i]:.9g} s is {kind}: the "
                           f"previous row has {time[i - 1]:.9g} s; expected strictly increasing "
                           "time stamps (or on_duplicate='first'|'last'|'mean')")
    channels, si_units, orig_units, orig_names = {}, {}, {}, {}
    for name, src in columns.items():
        col = _find_column(t, src, f"channel {name!r}")
        raw = _numeric(t, col, f"channel {name!r}{', ' + units[name] if units.get(name) else ''}",
                       allow_missing)
        v, si = convert_units(raw, units.get(name), what=f"{t.name}: channel {name!r}")
        channels[name] = v
        si_units[name] = si
        orig_units[name] = units.get(name)
        orig_names[name] = col
    n_reordered = n_dup = 0
    time_read = time  # the rows as read: the first unordered row is named from these
    if bad.size:
        time, channels, n_reordered, n_dup = _merge_rows(time, channels, on_duplicate)
    meta = {"source": t.name, "path": str(p), "format": t.kind.lower(), "units": si_units,
            "original_units": orig_units, "original_names": orig_names, "time_column": tcol,
            "time_unit": tu, "time_detected": detected, "reordered": n_reordered,
            "duplicates": n_dup}
    if bad.size:
        i = int(bad[0]) + 1
        meta["first_unordered"] = (f"{t.where(tcol, i)}: time stamp "
                                   f"{_fmt_time(t, tcol, time_read, i, tu)} "
                                   + ("repeats the previous row's" if d[i - 1] == 0 else
                                      "is earlier than the previous row's")
                                   + f" {_fmt_time(t, tcol, time_read, i - 1, tu)}")
    if getattr(t, "sections", None):
        meta["sections"] = t.sections
    return TimeResponse(time, channels, meta)


#: a time column that jumps back by more than this many typical steps (and at least
#: ``_RESTART_MIN_S``) restarts — a reboot, or a second recording appended — and is refused
_RESTART_STEPS = 20
_RESTART_MIN_S = 1.0
#: a pause in a dive log worth naming (s; or 50 median steps, the larger): one rule for the dive
#: tables (:mod:`uuvid.io.dive_channels`) and the bags' topics (:mod:`uuvid.io.dive_rosbag`)
GAP_S = 10.0


def pause_s(t) -> float | None:
    """The step between samples (s) that is a pause in a dive log: over :data:`GAP_S` and 50
    median steps (samples with the same stamp left out of the median); ``None`` under ten
    steps.  No sample spans a pause: a fit window ends at it, and it is said to the user."""
    step = np.diff(np.asarray(t, float))
    step = step[step > 0]
    return max(GAP_S, 50.0 * float(np.median(step))) if step.size >= 10 else None


def _fmt_time(t: _Table, col: str, time: np.ndarray, i: int, tu: str) -> str:
    if tu == "datetime":
        c = t.cells[col][i]
        return repr(c.strip()) if isinstance(c, str) else f"{np.datetime64(int(round(time[i] * 1e3)), 'ms')}"
    return f"{time[i]:.9g} s"


def _check_restart(t: _Table, col: str, time: np.ndarray, d: np.ndarray, iso: bool) -> None:
    """Refuse a time column that jumps back by much more than its typical step.

    Rows a few steps out of order are ordinary (messages of several senders interleaved in an
    export, a sample re-sent) and are sorted into place by ``on_duplicate``; a jump back by
    tens of steps is a clock that restarted (a reboot, two recordings in one file): sorting
    would interleave the two recordings into one nonsense series, so it stops here.
    """
    back = np.flatnonzero(d < 0)
    if not back.size:
        return
    ahead = d[d > 0]
    step = float(np.median(ahead)) if ahead.size else 0.0
    limit = max(_RESTART_STEPS * step, _RESTART_MIN_S)
    big = back[-d[back] > limit]
    if not big.size:
        return
    i = int(big[0]) + 1
    tu = "datetime" if iso else "s"
    raise LogDataError(f"{t.where(col, i)}: time restarts, {_fmt_time(t, col, time, i - 1, tu)} → "
                       f"{_fmt_time(t, col, time, i, tu)} (back {-d[i - 1]:.6g} s; the typical step "
                       f"is {step:.3g} s) — a reboot, or two recordings in one file? split the file "
                       f"before data row {i + 1} and read each part on its own (only rows a few "
                       "steps out of order are sorted into place)")


_ISO_RE = re.compile(r"^\s*\d{4}-\d{2}-\d{2}[T ]\d{1,2}:\d{2}")


def _looks_iso(cells: list) -> bool:
    """The first non-empty cell of a time column is ISO 8601 date-time text."""
    for c in cells:
        if isinstance(c, str) and c.strip():
            return bool(_ISO_RE.match(c))
        if c is not None and not isinstance(c, str):
            return False
    return False


def _merge_rows(time: np.ndarray, channels: dict, on_duplicate: str):
    """Sort rows by time (stable) and merge rows with the same stamp, per channel over its
    finite cells (``first``/``last``/``mean``).  Returns (t, channels, n_reordered, n_merged)."""
    order = np.argsort(time, kind="stable")
    n_reordered = int(np.count_nonzero(order != np.arange(order.size)))
    time = time[order]
    starts = np.concatenate(([True], np.diff(time) != 0))
    groups = np.cumsum(starts) - 1
    ng = int(groups[-1]) + 1
    out = {}
    for name, v in channels.items():
        v = v[order]
        ok = np.isfinite(v)
        if on_duplicate == "mean":
            cnt = np.bincount(groups[ok], minlength=ng)
            s = np.bincount(groups[ok], weights=v[ok], minlength=ng)
            with np.errstate(invalid="ignore", divide="ignore"):
                r = np.where(cnt > 0, s / np.maximum(cnt, 1), np.nan)
        else:
            r = np.full(ng, np.nan)
            idx = np.flatnonzero(ok)
            if on_duplicate == "first":
                idx = idx[::-1]  # later writes win: reversed, the first finite cell wins
            r[groups[idx]] = v[idx]
        out[name] = r
    return time[starts], out, n_reordered, int(time.size - ng)


# ------------------------------------------------------------------------------------------------
# ROS bags
# ------------------------------------------------------------------------------------------------
_IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
_PATH_RE = re.compile(rf"^{_IDENT}(\[-?\d+\])*(\.{_IDENT}(\[-?\d+\])*)*$")
_TOKEN_RE = re.compile(rf"({_IDENT})|\[(-?\d+)\]")


def _parse_field_path(path: str) -> list[str | int]:
    """``"pose.pose.position.z"`` / ``"channels[2]"`` → ``['pose', 'pose', ...]`` / ``['channels', 2]``."""
    if not _PATH_RE.match(path):
        raise LogDataError(f"invalid field path {path!r}; expected names separated by '.', each "
                           "optionally followed by [index], e.g. 'pose.position.z' or 'channels[2]'")
    return [m.group(1) if m.group(1) else int(m.group(2)) for m in _TOKEN_RE.finditer(path)]


def _parse_topic_spec(channel: str, spec: str) -> tuple[str, str, list[str | int]]:
    if not isinstance(spec, str) or not spec.strip():
        raise LogDataError(f"channel {channel!r}: expected 'topic:field.path', got {spec!r}")
    topic, sep, field = spec.strip().partition(":")
    field = field.strip() if sep else "data"
    if not topic:
        raise LogDataError(f"channel {channel!r}: no topic in {spec!r}; expected 'topic:field.path'")
    try:
        return topic.strip(), field, _parse_field_path(field)
    except LogDataError as e:
        raise LogDataError(f"channel {channel!r}: {e}") from None


def _msg_fields(obj) -> list[str]:
    fields = getattr(obj, "__dataclass_fields__", None)
    if fields is None:
        return []
    return [f for f in fields if not f.startswith("__")]


def _describe_value(v) -> str:
    if hasattr(v, "__msgtype__"):
        return v.__msgtype__
    if isinstance(v, np.ndarray):
        return f"{v.dtype}[{v.size}]"
    if isinstance(v, (list, tuple)):
        inner = _describe_value(v[0]) if v else "?"
        return f"{inner}[{len(v)}]"
    return type(v).__name__


def _describe_fields(obj) -> str:
    return ", ".join(f"{f} ({_describe_value(getattr(obj, f))})" for f in _msg_fields(obj))


def _extract(msg, tokens: list[str | int], field: str, where: str) -> float:
    cur = msg
    walked = ""
    for tok in tokens:
        if isinstance(tok, int):
            if not isinstance(cur, (list, tuple, np.ndarray)):
                raise LogDataError(f"{where}: {walked or 'the message'} is not an array "
                                   f"({_describe_value(cur)}); cannot take [{tok}] in {field!r}")
            n = len(cur)
            if not -n <= tok < n:
                raise LogDataError(f"{where}: {walked} has {n} element(s); index [{tok}] in "
                                   f"{field!r} is out of range")
            cur = cur[tok]
            walked += f"[{tok}]"
        else:
            names = _msg_fields(cur)
            if tok not in names:
                what = walked or f"the message ({getattr(msg, '__msgtype__', '?')})"
                if not names:
                    raise LogDataError(f"{where}: {what} is a {_describe_value(cur)}, which has no "
                                       f"field {tok!r} (in {field!r})")
                kind = getattr(cur, "__msgtype__", "")
                raise LogDataError(f"{where}: {what}{' (' + kind + ')' if walked and kind else ''} "
                                   f"has no field {tok!r} (in {field!r}); its fields are: "
                                   f"{_describe_fields(cur)}")
            cur = getattr(cur, tok)
            walked = f"{walked}.{tok}" if walked else tok
    if isinstance(cur, (bool, int, float, np.number, np.bool_)):
        return float(cur)
    if isinstance(cur, (list, tuple, np.ndarray)):
        raise LogDataError(f"{where}: {field!r} is an array of {len(cur)} value(s) "
                           f"({_describe_value(cur)}); pick one element, e.g. '{field}[0]'")
    if hasattr(cur, "__msgtype__"):
        raise LogDataError(f"{where}: {field!r} is a {cur.__msgtype__} message, not a number; "
                           f"its fields are: {_describe_fields(cur)}")
    raise LogDataError(f"{where}: {field!r} is a {type(cur).__name__} ({cur!r}), not a number")


def _normalize_msgtype(name: str) -> str:
    parts = name.strip().split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name.strip()


def _custom_types(defs: Mapping[str, str]) -> dict:
    from rosbags.typesys import get_types_from_idl, get_types_from_msg

    typs: dict = {}
    for name, text in defs.items():
        try:
            if re.search(r"^\s*module\s+\w+", text, re.M):
                typs.update(get_types_from_idl(text))
            else:
                typs.update(get_types_from_msg(text, _normalize_msgtype(name)))
        except Exception as e:  # rosbags' parser errors
            raise LogDataError(f"msg_definitions[{name!r}]: cannot parse the definition: {e}") from e
    return typs


def _bag_locations(path) -> tuple[list[Path], int, Path]:
    """Paths for AnyReader, the ROS version, and the path named in messages."""
    if isinstance(path, (str, os.PathLike)) or not isinstance(path, Iterable):
        p = Path(path)
        loc, ros = _bag_location(p)
        return [loc], ros, p
    paths = [Path(x) for x in path]
    if not paths:
        raise LogDataError("no bag given")
    locs = [_bag_location(x) for x in paths]
    if len(locs) > 1 and any(ros != 1 for _l, ros in locs):
        raise LogDataError("several bags can be read together only as ROS 1 .bag files (a split "
                           "recording); read ROS 2 bags one directory at a time")
    return [loc for loc, _r in locs], locs[0][1], paths[0]


def _bag_location(p: Path) -> tuple[Path, int]:
    """The path AnyReader wants and the ROS version (1 or 2)."""
    if not p.exists():
        raise LogDataError(f"{p}: no such bag (a ROS 1 .bag file or a ROS 2 bag directory)")
    if p.is_file() and p.suffix == ".bag":
        try:
            with open(p, "rb") as f:
                head = f.read(13)
        except OSError as e:
            raise LogDataError(f"{p}: cannot read the bag ({e.strerror or e})") from None
        if not head:
            raise LogDataError(f"{p.name}: the file is empty (0 bytes); expected a ROS 1 bag "
                               "(as `rosbag record` writes it) or a ROS 2 bag directory")
        if head != b"#ROSBAG V2.0\n":
            raise LogDataError(f"{p.name}: not a ROS 1 bag: it does not start with '#ROSBAG V2.0'; "
                               "expected a bag as `rosbag record` writes it (a ROS 2 bag is a "
                               "directory holding metadata.yaml)")
        return p, 1
    if p.is_dir():
        if (p / "metadata.yaml").exists():
            _check_bag_metadata(p / "metadata.yaml")
            return p, 2
        raise LogDataError(f"{p}: a directory without metadata.yaml is not a ROS 2 bag")
    if p.is_file() and (p.parent / "metadata.yaml").exists():
        _check_bag_metadata(p.parent / "metadata.yaml")
        return p.parent, 2
    raise LogDataError(f"{p}: not a bag: expected a ROS 1 '.bag' file or a ROS 2 bag directory "
                       "(with metadata.yaml)")


def _check_bag_metadata(meta: Path) -> None:
    """A ROS 2 bag's metadata.yaml that is no bag description is said as such (rosbags said
    "'NoneType' object is not subscriptable" of an empty one, a UnicodeDecodeError of bytes)."""
    import yaml

    what = ("expected the YAML mapping with rosbag2_bagfile_information that `ros2 bag record` "
            "writes")
    try:
        doc = yaml.safe_load(meta.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, yaml.YAMLError) as e:
        why = "not text" if isinstance(e, UnicodeDecodeError) else "not YAML"
        raise LogDataError(f"{meta}: {why}, not a ROS 2 bag's metadata; {what}") from None
    except OSError as e:
        raise LogDataError(f"{meta}: cannot read it ({e.strerror or e})") from None
    if not (isinstance(doc, dict) and isinstance(doc.get("rosbag2_bagfile_information"), dict)):
        got = "empty" if doc is None else f"a YAML {type(doc).__name__}" + (
            f" with keys {', '.join(map(str, list(doc)[:5]))}" if isinstance(doc, dict) else "")
        raise LogDataError(f"{meta}: {got}, not a ROS 2 bag's metadata; {what}")


def read_rosbag(path, topics: Mapping[str, str], *, resample: str | float | None = None,
                interp: str | Mapping[str, str] = "linear", span: str = "overlap",
                stamp: str = "header", units: Mapping[str, str] | None = None,
                msg_definitions: Mapping[str, str] | None = None, typestore: str | None = None,
                on_duplicate: str = "error", allow_missing: bool = False,
                ) -> dict[str, TimeResponse] | TimeResponse:
    """Read channels from a ROS 1 ``.bag`` or a ROS 2 bag (sqlite3 or MCAP) with ``rosbags``.

    Parameters
    ----------
    path
        A ROS 1 ``.bag`` file (or a list of them: a split recording), a ROS 2 bag directory
        (with ``metadata.yaml``) or a file inside it.
    topics
        ``{channel: "topic:field.path"}``, e.g. ``{"depth": "/mavros/global_position/rel_alt:data",
        "roll": "/imu/data:orientation.x", "thrust_1": "/mavros/rc/out:channels[0]"}``.  The field
        path is dotted with optional array indices (negative counts from the end); without
        ``:field`` it is ``data``.  Any message type whose definition is known can be read.
    resample
        ``None``: ``{channel: TimeResponse}`` with each channel's own samples (time axes share one
        origin); ``"union"`` or a step [s]: one :class:`TimeResponse`, see :func:`align`
        (``interp``, ``span`` are passed on; NaN samples kept by ``allow_missing`` are skipped).
    stamp
        ``"header"``: the message's ``header.stamp`` where the type has a header (and the stamps
        are set, i.e. not zero), else the bag's receive time; ``"receive"``: always the receive
        time.  ``meta["stamp"]`` says which was used per channel.
    units
        ``{channel: unit}`` to convert to SI (ROS data are SI by convention (REP 103), but e.g.
        ``compass_hdg`` is in degrees: ``{"heading": "deg"}``).
    msg_definitions
        Custom message definitions for bags that do not embed them (ROS 2 bags recorded before
        Iron with the sqlite3 storage): ``{"mavros_msgs/msg/RCOut": "std_msgs/Header header\\n
        uint16[] channels"}`` (``.msg`` text; ``pkg/Type`` is accepted; IDL text also works).
        Definitions embedded in the bag take precedence.
    typestore
        The built-in type store used for types the bag does not define: a name of
        ``rosbags.typesys.Stores`` such as ``"ros1_noetic"`` or ``"ros2_humble"``; default
        ``ros1_noetic`` for ROS 1 bags and ``ros2_humble`` for ROS 2 bags.
    on_duplicate
        Samples of one channel with the same time stamp: ``"error"`` (default), ``"first"``,
        ``"last"`` or ``"mean"``.  Samples out of order are sorted by time.
    allow_missing
        Keep NaN values instead of raising.

    ``meta`` (per channel, merged by :func:`align`): ``source``, ``path``, ``format``
    (``rosbag1``/``rosbag2``), ``units``, ``original_units``, ``original_names``
    (``topic:field``), ``msgtypes``, ``stamp``, ``reordered`` (samples sorted into time order),
    ``t0_ns`` (the bag time, ns, of t = 0: the first sample of any requested channel).
    """
    _require("rosbags", "reading ROS bags")
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    bags, ros, p = _bag_locations(path)
    if not topics:
        raise LogDataError(f"{p.name}: no channels requested (topics is empty)")
    if stamp not in ("header", "receive"):
        raise LogDataError(f"unknown stamp {stamp!r}; expected 'header' or 'receive'")
    _check_duplicate_option(on_duplicate)
    units = dict(units or {})
    unknown = sorted(set(units) - set(topics))
    if unknown:
        raise LogDataError(f"units given for {', '.join(map(repr, unknown))}, not in topics; "
                           f"channels: {', '.join(map(repr, topics))}")
    specs = {ch: _parse_topic_spec(ch, s) for ch, s in topics.items()}

    store_name = typestore or ("ros1_noetic" if ros == 1 else "ros2_humble")
    try:
        store_enum = Stores(store_name.lower())
    except ValueError:
        raise LogDataError(f"unknown typestore {typestore!r}; expected one of "
                           f"{', '.join(s.value for s in Stores)}") from None
    fallback = get_typestore(store_enum)
    if msg_definitions:
        fallback.register(_custom_types(msg_definitions))

    name = p.name if len(bags) == 1 else f"{p.name} (+{len(bags) - 1} more)"
    try:
        reader = AnyReader(bags, default_typestore=fallback)
        reader.open()
    except (AnyReaderError, FileNotFoundError) as e:
        raise LogDataError(f"{name}: cannot read the bag: {e}") from e
    except Exception as e:  # rosbags surfaces storage/parse errors of its own types
        raise LogDataError(f"{name}: cannot read the bag: {type(e).__name__}: {e}") from e
    try:
        available = reader.topics

        def listing() -> str:
            return "; ".join(f"{tn} ({ti.msgtype or 'several types'}, {ti.msgcount} msgs)"
                             for tn, ti in sorted(available.items())) or "(none)"

        resolved: dict[str, str] = {}
        for ch, (topic, _f, _t) in specs.items():
            cand = [topic] if topic.startswith("/") else [topic, "/" + topic]
            hit = next((c for c in cand if c in available), None)
            if hit is None:
                raise LogDataError(f"{name}: channel {ch!r}: no topic {topic!r} in the bag; "
                                   f"available topics: {listing()}")
            resolved[ch] = hit
        by_topic: dict[str, list[str]] = {}
        for ch, tp in resolved.items():
            by_topic.setdefault(tp, []).append(ch)
        conns = [c for c in reader.connections if c.topic in by_topic]

        def deserialize(conn, raw):
            mt = conn.msgtype
            if mt in reader.typestore.types:
                return reader.deserialize(raw, mt)
            if mt in fallback.types:
                return (fallback.deserialize_cdr(raw, mt) if reader.is2
                        else fallback.deserialize_ros1(raw, mt))
            raise LogDataError(f"{name}: topic {conn.topic!r} has type {mt!r}, whose definition "
                               f"is neither in the bag nor in the {store_enum.value} type store; "
                               f"pass msg_definitions={{{mt!r}: '<.msg text>'}}")

        recv: dict[str, list[int]] = {tp: [] for tp in by_topic}
        hdr: dict[str, list[int] | None] = {tp: [] for tp in by_topic}
        vals: dict[str, list[float]] = {ch: [] for ch in resolved}
        msgtypes: dict[str, str] = {}
        for conn, t_ns, raw in reader.messages(connections=conns):
            tp = conn.topic
            k = len(recv[tp])
            try:
                msg = deserialize(conn, raw)
            except LogDataError:
                raise
            except Exception as e:
                raise LogDataError(f"{name}: topic {tp!r} message {k + 1}: cannot decode "
                                   f"{conn.msgtype}: {e}") from e
            recv[tp].append(int(t_ns))
            if hdr[tp] is not None:
                h = getattr(msg, "header", None)
                st = getattr(h, "stamp", None)
                if st is None or not hasattr(st, "sec"):
                    hdr[tp] = None
                else:
                    hdr[tp].append(int(st.sec) * 1_000_000_000 + int(st.nanosec))
            for ch in by_topic[tp]:
                _topic, field, tokens = specs[ch]
                where = f"{name}: channel {ch!r}, topic {tp!r} ({conn.msgtype}) message {k + 1}"
                vals[ch].append(_extract(msg, tokens, field, where))
                msgtypes[ch] = conn.msgtype
    finally:
        reader.close()

    times: dict[str, np.ndarray] = {}
    stamp_used: dict[str, str] = {}
    for tp, chans in by_topic.items():
        if not recv[tp]:
            raise LogDataError(f"{name}: topic {tp!r} (channel(s) {', '.join(map(repr, chans))}) "
                               "has no messages")
        h = hdr[tp]
        if stamp == "header" and h is not None and min(h) > 0:
            tt, used = np.asarray(h, dtype=np.int64), "header"
        else:
            tt = np.asarray(recv[tp], dtype=np.int64)
            used = ("receive" if stamp == "receive" or h is None
                    else "receive (header stamps are zero)")
        for ch in chans:
            times[ch], stamp_used[ch] = tt, used
    t0 = min(int(t.min()) for t in times.values())
    fmt = "rosbag1" if ros == 1 else "rosbag2"
    out: dict[str, TimeResponse] = {}
    for ch in topics:
        tp = resolved[ch]
        tt, vv = times[ch], np.asarray(vals[ch], dtype=float)

        def where(i, ch=ch, tp=tp):
            return f"{name}: channel {ch!r}, topic {tp!r} message {i + 1}"

        n_raw = vv.size
        tt, vv, nre = _finish_series(tt, vv, on_duplicate=on_duplicate, allow_missing=allow_missing,
                                     where=where, fmt_t=lambda x: f"{(x - t0) / 1e9:.9f} s")
        vv, si = convert_units(vv, units.get(ch), what=f"{name}: channel {ch!r}")
        meta = {"source": name, "path": str(p) if len(bags) == 1 else [str(b) for b in bags],
                "format": fmt, "units": {ch: si},
                "original_units": {ch: units.get(ch)},
                "original_names": {ch: f"{tp}:{specs[ch][1]}"}, "msgtypes": {ch: msgtypes[ch]},
                "stamp": {ch: stamp_used[ch]}, "reordered": {ch: nre},
                "duplicates": {ch: int(n_raw - vv.size)}, "t0_ns": t0}
        out[ch] = TimeResponse((tt - t0) / 1e9, {ch: vv}, meta)
    return _maybe_align(out, resample, interp, span)


# ------------------------------------------------------------------------------------------------
# ArduSub: MAVLink telemetry (.tlog) and dataflash (.bin)
# ------------------------------------------------------------------------------------------------
#: Default channels of a telemetry log: ``{channel: spec or [alternatives]}``; a leading ``-``
#: negates (ArduSub reports altitude, negative below the surface; depth is positive down).
#: ArduSub's ``VFR_HUD.alt`` is its altitude above mean sea level (``get_alt_msl``), which is
#: minus the depth when the EKF origin is at the surface (the usual case without GPS); if yours is
#: not, use ``"-GLOBAL_POSITION_INT.relative_alt"`` (relative to home).
ARDUSUB_TLOG_FIELDS: dict[str, str | list[str]] = {
    "depth": ["-VFR_HUD.alt", "-GLOBAL_POSITION_INT.relative_alt"],
    "roll": "ATTITUDE.roll",
    "pitch": "ATTITUDE.pitch",
    "yaw": "ATTITUDE.yaw",
    **{f"servo_{i}": f"SERVO_OUTPUT_RAW.servo{i}_raw" for i in range(1, 9)},
}
#: Default channels of a dataflash log.
ARDUSUB_DATAFLASH_FIELDS: dict[str, str | list[str]] = {
    "depth": ["-BARO.Alt", "-CTUN.Alt"],
    "roll": "ATT.Roll",
    "pitch": "ATT.Pitch",
    "yaw": "ATT.Yaw",
    **{f"servo_{i}": f"RCOU.C{i}" for i in range(1, 9)},
}

#: units of well-known fields (MESSAGE.field → unit); others come from the log's FMTU/UNIT
#: messages (dataflash) or are taken as recorded
_FIELD_UNITS: dict[str, str] = {
    "VFR_HUD.alt": "m", "VFR_HUD.climb": "m/s", "VFR_HUD.heading": "deg",
    "VFR_HUD.groundspeed": "m/s", "VFR_HUD.airspeed": "m/s", "VFR_HUD.throttle": "%",
    "GLOBAL_POSITION_INT.relative_alt": "mm", "GLOBAL_POSITION_INT.alt": "mm",
    "GLOBAL_POSITION_INT.vx": "cm/s", "GLOBAL_POSITION_INT.vy": "cm/s",
    "GLOBAL_POSITION_INT.vz": "cm/s", "GLOBAL_POSITION_INT.hdg": "cdeg",
    "ATTITUDE.roll": "rad", "ATTITUDE.pitch": "rad", "ATTITUDE.yaw": "rad",
    "ATTITUDE.rollspeed": "rad/s", "ATTITUDE.pitchspeed": "rad/s", "ATTITUDE.yawspeed": "rad/s",
    "SCALED_PRESSURE.press_abs": "hPa", "SCALED_PRESSURE2.press_abs": "hPa",
    "SCALED_PRESSURE3.press_abs": "hPa", "SYS_STATUS.voltage_battery": "mV",
    "SYS_STATUS.current_battery": "cA",
    "ATT.Roll": "deg", "ATT.Pitch": "deg", "ATT.Yaw": "deg", "ATT.DesRoll": "deg",
    "ATT.DesPitch": "deg", "ATT.DesYaw": "deg", "BARO.Alt": "m", "BARO.Press": "Pa",
    "CTUN.Alt": "m", "CTUN.DAlt": "m", "CTUN.BAlt": "m", "CTUN.CRt": "m/s", "BAT.Volt": "V",
    "BAT.Curr": "A",
}
_FIELD_UNIT_PATTERNS = [
    (re.compile(r"^SERVO_OUTPUT_RAW\.servo\d+_raw$"), "pwm_us"),
    (re.compile(r"^RC_CHANNELS(_RAW)?\.chan\d+_raw$"), "pwm_us"),
    (re.compile(r"^RC_CHANNELS_OVERRIDE\.chan\d+_raw$"), "pwm_us"),
    (re.compile(r"^(RCOU|RCIN|RCI2|RCO2|RCO3)\.C\d+$"), "pwm_us"),
]
#: unit strings of dataflash UNIT messages that differ from ours
_DF_UNIT_ALIASES = {"degheading": "deg", "m/s/s": "m/s^2", "cdegheading": "cdeg"}

#: telemetry messages with ``time_boot_ms`` that ArduSub streams by default: read alongside the
#: requested ones to map the receive time of unstamped messages (VFR_HUD) onto the boot clock
_TLOG_CLOCK_TYPES = {"SYSTEM_TIME", "ATTITUDE", "GLOBAL_POSITION_INT", "SCALED_PRESSURE"}

_SPEC_RE = re.compile(r"^(?P<neg>-)?(?P<msg>[A-Za-z0-9_]+)(\[(?P<inst>[^\]]+)\])?"
                      r"\.(?P<field>[A-Za-z_][A-Za-z0-9_]*)(\[(?P<idx>-?\d+)\])?$")


class _Spec:
    def __init__(self, text: str):
        m = _SPEC_RE.match(text.strip()) if isinstance(text, str) else None
        if not m:
            raise LogDataError(f"invalid field {text!r}; expected 'MESSAGE.field', optionally "
                               "'-MESSAGE.field' (negated), 'MESSAGE[instance].field' or "
                               "'MESSAGE.field[index]'")
        self.text = text.strip()
        self.sign = -1.0 if m["neg"] else 1.0
        self.msg = m["msg"]
        self.inst = m["inst"]
        self.field = m["field"]
        self.idx = None if m["idx"] is None else int(m["idx"])

    @property
    def key(self) -> str:
        return f"{self.msg}.{self.field}"


def _known_unit(spec: _Spec) -> str | None:
    if spec.key in _FIELD_UNITS:
        return _FIELD_UNITS[spec.key]
    for rx, unit in _FIELD_UNIT_PATTERNS:
        if rx.match(spec.key):
            return unit
    return None


class _MsgStore:
    """Samples of one message type, as lists."""

    def __init__(self):
        self.log_t: list[float] = []
        self.boot: list[float] = []
        self.src: list[tuple[int, int]] = []
        self.inst: list[str | None] = []
        self.values: dict[tuple[str, int | None], list[float]] = {}
        self.fieldnames: list[str] = []
        self.instance_field: str | None = None
        self.fmt = None


def _get_number(msg, field: str, idx: int | None):
    v = getattr(msg, field)
    if idx is not None:
        try:
            v = v[idx]
        except (TypeError, IndexError):
            return math.nan
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _boot_from_log(log_t: np.ndarray, ref_log: np.ndarray, ref_boot: np.ndarray,
                   window: float = 5.0) -> np.ndarray:
    """Map ground-station receive times to the vehicle's boot clock.

    ``ref_*`` are messages carrying both.  Their offset ``log − boot`` is the clock offset plus
    the link latency; the lower envelope over ±``window`` s is the best estimate of the offset
    (latency only adds), and follows a slow drift of either clock.
    """
    d = ref_log - ref_boot
    origin = ref_log.min()
    # 1 s bins, only those holding a message (a corrupt receive stamp years away must not
    # allocate every second in between: memory follows the message count, not the time span)
    occ, inv = np.unique(np.floor(ref_log - origin).astype(np.int64), return_inverse=True)
    env = np.full(occ.size, np.inf)
    np.minimum.at(env, inv.ravel(), d)
    w = int(window)
    # the nodes: every bin within ±w of an occupied one, each the lowest offset within ±w
    nodes = np.unique((occ[:, None] + np.arange(-w, w + 1)).ravel())
    nodes = nodes[(nodes >= occ[0]) & (nodes <= occ[-1])]
    low = np.full(nodes.size, np.inf)
    for k in range(-w, w + 1):
        j = np.minimum(np.searchsorted(occ, nodes + k), occ.size - 1)
        hit = occ[j] == nodes + k
        low[hit] = np.minimum(low[hit], env[j[hit]])
    off = np.interp(log_t, origin + nodes + 0.5, low)
    return log_t - off


def read_ardusub(path, fields: Mapping[str, str | Sequence[str]] | None = None, *,
                 units: Mapping[str, str] | None = None, resample: str | float | None = None,
                 interp: str | Mapping[str, str] = "linear", span: str = "overlap",
                 time: str = "boot", source_system: int | None = None,
                 source_component: int | None = None, on_duplicate: str = "error",
                 allow_missing: bool = False) -> dict[str, TimeResponse] | TimeResponse:
    """Read an ArduSub log: MAVLink telemetry (``.tlog``) or dataflash (``.bin``, text ``.log``).

    Parameters
    ----------
    fields
        ``{channel: spec}``; a spec is ``"MESSAGE.field"`` (``"ATTITUDE.roll"``, ``"RCOU.C3"``),
        optionally negated (``"-VFR_HUD.alt"``), with an instance (``"BARO[1].Alt"``,
        ``"SERVO_OUTPUT_RAW[0].servo1_raw"``: ``port`` for that message) or an array index
        (``"ESC_TELEMETRY_1_TO_4.rpm[2]"``), or a list of alternatives tried in order.  Default
        :data:`ARDUSUB_TLOG_FIELDS` / :data:`ARDUSUB_DATAFLASH_FIELDS`: ``depth`` [m, positive
        down], ``roll``, ``pitch``, ``yaw`` [rad, yaw wrapped to ±π — ``np.unwrap`` it for
        dynamics], ``servo_1`` … ``servo_8`` [PWM µs: the thruster commands when
        ``SERVOn_FUNCTION`` = motor n, the ArduSub default].  Default channels the log lacks are
        skipped (``meta["skipped"]`` says why); channels you name must be there.  A message with
        several instances (two barometers) is read from the lowest instance unless one is named
        (``meta["instances"]``).
    units
        ``{channel: unit}`` of the raw field, converted to SI; by default the units of well-known
        fields (``ATT.Roll`` deg, ``GLOBAL_POSITION_INT.relative_alt`` mm, ...) and, in dataflash
        logs, those the log declares (FMTU) are used; other fields are kept as recorded.
    time
        ``"boot"``: the autopilot's clock, seconds since boot (``time_boot_ms`` / ``time_usec``
        in telemetry, ``TimeUS`` in dataflash).  Telemetry messages without an on-board stamp
        (``VFR_HUD``) get one from their receive time, mapped onto the boot clock by the
        other messages (``meta["time_mapped"]``).  ``"log"`` (telemetry only): the ground
        station's receive time, relative to the first requested sample (``meta["t0_unix"]``).
    source_system, source_component
        Telemetry only: the sender to read.  Default: the first autopilot that sends a HEARTBEAT
        (a tlog also holds the ground station's and companion computers' messages).
    resample, interp, span
        As for :func:`read_rosbag` / :func:`align`.
    on_duplicate, allow_missing
        As for :func:`read_rosbag`.

    ``meta``: ``source``, ``path``, ``format`` (``tlog``/``dataflash``), ``units``,
    ``original_units``, ``original_names`` (the spec used), ``time_base`` (``boot``/``log``),
    ``time_mapped``, ``instances``, ``skipped`` (default channels not in the log),
    ``source_system``.

    pymavlink's own prints about bytes it cannot decode (one line per bad byte, from Python and
    from C) are collected and said once, as a :class:`LogWarning` (or in the error when nothing
    could be read).
    """
    chatter: list = []
    try:
        with _captured_output(chatter):
            out = _read_ardusub(path, fields, units=units, resample=resample, interp=interp,
                                span=span, time=time, source_system=source_system,
                                source_component=source_component, on_duplicate=on_duplicate,
                                allow_missing=allow_missing)
    except LogDataError as e:
        if chatter:
            hint = ""
            if "present: (none)" in str(e):  # nothing decoded: the other format under this name
                other = ".tlog" if Path(path).suffix.lower() in (".bin", ".log") else ".BIN"
                hint = f"; is it a {other} under another suffix?"
            raise LogDataError(f"{e} — pymavlink could not decode parts of the log "
                               f"({len(chatter):,} complaint(s), first: {chatter[0][:80]!r}){hint}"
                               ) from None
        raise
    if chatter:
        import warnings

        warnings.warn(f"{Path(path).name}: pymavlink reported {len(chatter):,} decoding "
                      f"problem(s) (first: {chatter[0][:100]!r}); the messages it could decode "
                      "are read", LogWarning, stacklevel=2)
    return out


def _read_ardusub(path, fields, *, units, resample, interp, span, time, source_system,
                  source_component, on_duplicate, allow_missing):
    """The body of :func:`read_ardusub` (pymavlink's prints captured by the caller)."""
    mavutil = _require("pymavlink.mavutil", "reading ArduSub logs")
    p = Path(path)
    kind = _ardusub_kind(p)
    if time not in ("boot", "log"):
        raise LogDataError(f"unknown time {time!r}; expected 'boot' or 'log'")
    if time == "log" and kind == "dataflash":
        raise LogDataError(f"{p.name}: time='log' needs a telemetry log (.tlog); dataflash logs "
                           "only have the autopilot's clock (time='boot')")
    _check_duplicate_option(on_duplicate)
    name = p.name
    defaults = fields is None
    if defaults:
        fields = ARDUSUB_TLOG_FIELDS if kind == "tlog" else ARDUSUB_DATAFLASH_FIELDS
    if not fields:
        raise LogDataError(f"{name}: no channels requested (fields is empty)")
    units = dict(units or {})
    unknown = sorted(set(units) - set(fields))
    if unknown:
        raise LogDataError(f"units given for {', '.join(map(repr, unknown))}, not in fields; "
                           f"channels: {', '.join(map(repr, fields))}")
    for ch, unit in units.items():
        if unit is not None and _unit_key(unit, CHANNEL_UNITS) is None:
            raise LogDataError(f"{name}: unknown unit {unit!r} for channel {ch!r}; known units: "
                               f"{', '.join(CHANNEL_UNITS)}")
    alts: dict[str, list[_Spec]] = {}
    for ch, spec in fields.items():
        lst = [spec] if isinstance(spec, str) else list(spec)
        if not lst:
            raise LogDataError(f"channel {ch!r}: no field given")
        try:
            alts[ch] = [_Spec(s) for s in lst]
        except LogDataError as e:
            raise LogDataError(f"channel {ch!r}: {e}") from None
    wanted_types = {s.msg for lst in alts.values() for s in lst}
    need: dict[str, set[tuple[str, int | None]]] = {}
    for lst in alts.values():
        for s in lst:
            need.setdefault(s.msg, set()).add((s.field, s.idx))

    try:
        conn = mavutil.mavlink_connection(str(p))
    except Exception as e:
        raise LogDataError(f"{name}: cannot open the log: {type(e).__name__}: {e}") from e
    stores: dict[str, _MsgStore] = {}
    ref_log: list[float] = []
    ref_boot: list[float] = []
    ref_src: list[tuple[int, int]] = []
    autopilot: tuple[int, int] | None = None
    wraps: dict = {}
    read_types = set(wanted_types)
    if kind == "tlog":
        read_types |= {"HEARTBEAT"}
        if time == "boot":  # messages that map receive times onto the boot clock
            read_types |= _TLOG_CLOCK_TYPES
    if kind == "tlog":
        _check_tlog(conn, p)
    damaged = _index_stops_early(conn) if kind == "dataflash" else None
    cut = _dataflash_cut(conn) if kind == "dataflash" else None
    if cut is not None:
        import warnings

        warnings.warn(f"{name}: the log is cut off — its last record ({cut[0]}, {cut[1]} of "
                      f"{cut[2]} bytes) is incomplete (copied while being written, or the card was "
                      "full); the records before it are read", LogWarning, stacklevel=3)
    if damaged is not None and damaged[0] > 0:  # the filtered read would end at the damage
        import warnings

        warnings.warn(_damaged_index_note(name, damaged), LogWarning, stacklevel=3)
    # telemetry: pymavlink's index skips damaged bytes silently; where it has gaps every message
    # is read in turn (slower) so the damage is searched again and said (:class:`_Skipped`);
    # else the index's records of the types read, in file order (recv_match drops BAD_DATA)
    gaps, partial = _tlog_index_check(conn) if kind == "tlog" else (False, 0)
    skips = _Skipped(conn, partial) if kind == "tlog" else None
    stream = skips.stream() if gaps else None
    order = None
    if kind == "tlog" and not gaps:
        ids = getattr(conn, "name_to_id", {})
        order = iter(sorted(o for t in read_types if t in ids for o in conn.offsets[ids[t]]))
    good: Counter = Counter()  # (type, system, component) → decoded (the indexed read)
    try:
        present = _present_types(conn, kind)
        while True:
            try:
                if stream is not None:
                    m = next(stream, None)
                elif order is not None:
                    at = next(order, None)
                    m = None
                    if at is not None:
                        conn.f.seek(at)
                        conn.offset = at
                        m = conn.recv_msg()
                        if m is not None and m.get_type() == "BAD_DATA":
                            skips.bad(m, at)
                            continue
                else:
                    m = conn.recv_match(type=None if damaged else read_types, blocking=False)
            except Exception as e:
                raise LogDataError(f"{name}: cannot decode the log: {type(e).__name__}: {e}") from e
            if m is None:
                break
            mt = m.get_type()
            if kind == "tlog" and mt not in read_types:
                continue
            if kind == "tlog":
                src = (m.get_srcSystem(), m.get_srcComponent())
                if order is not None:
                    good[(mt, *src)] += 1
                if mt == "HEARTBEAT":
                    if autopilot is None and getattr(m, "autopilot", 8) != 8:
                        autopilot = src
                    if mt not in wanted_types:
                        continue
                log_t = float(m._timestamp)
                boot = _tlog_boot(m, wraps)
                if boot is not None:
                    ref_log.append(log_t)
                    ref_boot.append(boot)
                    ref_src.append(src)
                if mt not in wanted_types:
                    continue
            else:
                if damaged and mt not in read_types:
                    continue
                src = (0, 0)
                log_t = math.nan
                boot = _df_boot(m)
                if boot is None:
                    raise LogDataError(f"{name}: {mt} messages have no TimeUS/TimeMS field; "
                                       f"their fields are: {', '.join(m.get_fieldnames())}")
            st = stores.get(mt)
            if st is None:
                st = stores[mt] = _MsgStore()
                st.fieldnames = list(m.get_fieldnames())
                if kind == "tlog":
                    st.instance_field = getattr(m, "_instance_field", None)
                else:
                    st.instance_field = getattr(m.fmt, "instance_field", None)
                    if st.instance_field is None and "I" in st.fieldnames:
                        st.instance_field = "I"  # multi-instance message in a log without FMTU
                for fld, idx in need[mt]:
                    if fld in st.fieldnames:
                        st.values[(fld, idx)] = []
                st.fmt = getattr(m, "fmt", None)
            st.log_t.append(log_t)
            st.boot.append(math.nan if boot is None else boot)
            st.src.append(src)
            st.inst.append(None if st.instance_field is None
                           else str(getattr(m, st.instance_field)))
            for key, lst in st.values.items():
                lst.append(_get_number(m, *key))
    finally:
        try:
            conn.close()
        except Exception:
            pass

    # --- the sender (telemetry) --------------------------------------------------------------
    chosen_src: tuple[int, int] | None = None
    if kind == "tlog":
        if source_system is not None:
            comp = source_component
            if comp is None and autopilot is not None and autopilot[0] == source_system:
                comp = autopilot[1]
            chosen_src = (source_system, comp)
        elif autopilot is not None:
            chosen_src = (autopilot[0], source_component if source_component is not None
                          else autopilot[1])

    import warnings

    # frames failing their checksum: only those of the types read from the sender chosen
    for note in (skips.notes(name, mavutil, types=read_types, sender=chosen_src,
                             good=None if gaps else good) if skips is not None else []):
        warnings.warn(note, LogWarning, stacklevel=3)

    def src_mask(st: _MsgStore, mt: str) -> np.ndarray:
        src = st.src
        if kind != "tlog":
            return np.ones(len(src), dtype=bool)
        if chosen_src is None:
            senders = sorted(set(src))
            if len(senders) > 1:
                raise LogDataError(f"{name}: {mt} comes from several senders "
                                   f"({', '.join(f'system {a} component {b}' for a, b in senders)}) "
                                   "and no autopilot HEARTBEAT says which is the vehicle; pass "
                                   "source_system= (and source_component=)")
            return np.ones(len(src), dtype=bool)
        sysid, comp = chosen_src
        return np.array([s[0] == sysid and (comp is None or s[1] == comp) for s in src],
                        dtype=bool)

    def types_listing() -> str:
        return ", ".join(f"{t} ({n})" for t, n in sorted(present.items())) or "(none)"

    # --- boot-clock mapping for telemetry messages without an on-board stamp ---------------------
    ref_l, ref_b = np.asarray(ref_log, dtype=float), np.asarray(ref_boot, dtype=float)
    ref_sys = np.asarray([s[0] for s in ref_src], dtype=int)

    out: dict[str, TimeResponse] = {}
    skipped: dict[str, str] = {}
    raw_times: dict[str, np.ndarray] = {}
    raw_vals: dict[str, np.ndarray] = {}
    info: dict[str, dict] = {}
    for ch, lst in alts.items():
        reasons = []
        picked = None
        for s in lst:
            st = stores.get(s.msg)
            if st is None:
                reasons.append(f"no {s.msg} messages")
                continue
            if (s.field, s.idx) not in st.values:
                if defaults:
                    reasons.append(f"{s.msg} has no field {s.field!r}")
                    continue
                raise LogDataError(f"{name}: channel {ch!r}: {s.msg} has no field {s.field!r}; its "
                                   f"fields are: {', '.join(st.fieldnames)}")
            mask = src_mask(st, s.msg)
            if not mask.any():
                reasons.append(f"no {s.msg} messages from system {chosen_src[0]}")
                continue
            inst = np.array(st.inst, dtype=object)
            chosen_inst = None
            if st.instance_field is not None:
                have = sorted({i for i in inst[mask]}, key=_inst_key)
                if s.inst is not None:
                    if s.inst not in have:
                        raise LogDataError(f"{name}: channel {ch!r}: {s.msg} has no instance "
                                           f"{s.inst} ({st.instance_field}); instances: "
                                           f"{', '.join(have)}")
                    chosen_inst = s.inst
                else:
                    chosen_inst = have[0]
                mask &= inst == chosen_inst
            elif s.inst is not None:
                raise LogDataError(f"{name}: channel {ch!r}: {s.msg} has no instance field, so "
                                   f"{s.text!r} cannot select instance {s.inst}")
            picked = (s, st, mask, chosen_inst)
            break
        if picked is None:
            if defaults:
                skipped[ch] = "; ".join(reasons)
                continue
            raise LogDataError(f"{name}: channel {ch!r}: {'; '.join(reasons)} in the log; message "
                               f"types present: {types_listing()}")
        s, st, mask, chosen_inst = picked
        v = np.asarray(st.values[(s.field, s.idx)], dtype=float)[mask]
        idx_orig = np.flatnonzero(mask)
        boot = np.asarray(st.boot, dtype=float)[mask]
        logt = np.asarray(st.log_t, dtype=float)[mask]
        mapped = False
        if time == "log":
            tt = logt
        else:
            if np.all(np.isfinite(boot)):
                tt = boot
            elif kind == "tlog":
                systems = {st.src[i][0] for i in idx_orig}
                keep = np.isin(ref_sys, sorted(systems))
                if not keep.any():
                    raise LogDataError(f"{name}: channel {ch!r}: {s.msg} has no on-board time "
                                       "stamp and no other message maps the receive time onto the "
                                       "autopilot's clock; use time='log'")
                rl, rb = ref_l[keep], ref_b[keep]
                _check_reboot(name, "the time-stamped messages", rb)
                tt = _boot_from_log(logt, rl, rb)
                mapped = True
            else:  # pragma: no cover - dataflash messages always have a stamp (checked above)
                raise LogDataError(f"{name}: {s.msg} has no time stamp")
            _check_reboot(name, f"{s.msg} (channel {ch!r})", tt)
        raw_times[ch], raw_vals[ch] = tt, v
        unit = units.get(ch) or _known_unit(s)
        if unit is None and kind == "dataflash" and st.fmt is not None:
            u = st.fmt.get_unit(s.field) if hasattr(st.fmt, "get_unit") else ""
            unit = _DF_UNIT_ALIASES.get(u, u) or None
        info[ch] = {"spec": s, "unit": unit, "mapped": mapped, "inst": chosen_inst,
                    "instance_field": st.instance_field, "idx": idx_orig}
    if not raw_times:
        why = "; ".join(f"{c}: {r}" for c, r in skipped.items())
        raise LogDataError(f"{name}: none of the default channels is in the log ({why}); message "
                           f"types present: {types_listing()}")
    t0 = 0.0
    if time == "log":
        t0 = min(float(t.min()) for t in raw_times.values())
    fmt = kind
    for ch in raw_times:
        inf = info[ch]
        s: _Spec = inf["spec"]

        def where(i, ch=ch, s=s, idx=inf["idx"]):
            return f"{name}: channel {ch!r}, {s.msg} message {int(idx[i]) + 1} (of that type)"

        tt, vv, nre = _finish_series(raw_times[ch] - t0, raw_vals[ch], on_duplicate=on_duplicate,
                                     allow_missing=allow_missing, where=where,
                                     fmt_t=lambda x: f"{x:.6f} s")
        unit = inf["unit"]
        if unit is not None and _unit_key(unit, CHANNEL_UNITS) is not None:
            vv, si = convert_units(vv, unit, what=f"{name}: channel {ch!r}")
        else:
            si = unit
        vv = s.sign * vv
        meta = {"source": name, "path": str(p), "format": fmt, "units": {ch: si},
                "original_units": {ch: unit}, "original_names": {ch: s.text},
                "time_base": time, "time_mapped": {ch: inf["mapped"]},
                "reordered": {ch: nre}, "skipped": dict(skipped),
                "duplicates": {ch: int(raw_vals[ch].size - vv.size)}}
        if inf["inst"] is not None:
            meta["instances"] = {ch: f"{inf['instance_field']}={inf['inst']}"}
        if kind == "tlog":
            meta["source_system"] = None if chosen_src is None else list(chosen_src)
        if time == "log":
            meta["t0_unix"] = t0
        out[ch] = TimeResponse(tt, {ch: vv}, meta)
    return _maybe_align(out, resample, interp, span)


def _inst_key(x):
    try:
        return (0, float(x), "")
    except (TypeError, ValueError):
        return (1, 0.0, str(x))


def _check_reboot(name: str, what: str, boot: np.ndarray) -> None:
    """Raise if the autopilot clock jumps back by more than a second (a reboot in the log)."""
    if boot.size < 2:
        return
    d = np.diff(boot)
    j = np.flatnonzero(d < -1.0)
    if j.size:
        k = int(j[0]) + 1
        raise LogDataError(f"{name}: the autopilot clock of {what} jumps back from "
                           f"{boot[k - 1]:.3f} s to {boot[k]:.3f} s (sample {k + 1}): the vehicle "
                           "rebooted during the log; read it with time='log' (telemetry) or split "
                           "the log")


def _tlog_boot(m, wraps: dict) -> float | None:
    """Seconds since boot of a telemetry message, if it carries an on-board stamp.

    ``time_usec`` of several messages (SERVO_OUTPUT_RAW) is a 32-bit counter that wraps every
    71.6 min; ``wraps`` keeps, per message type, the last value and the number of wraps so far.
    """
    names = m.get_fieldnames()
    if "time_boot_ms" in names:
        return float(m.time_boot_ms) * 1e-3
    if "time_usec" in names:
        us = int(m.time_usec)
        if not 0 < us < 10**15:  # larger values are UNIX time, not time since boot
            return None
        if us < 2**32:
            mt = (m.get_type(), m.get_srcSystem(), m.get_srcComponent())
            last, n = wraps.get(mt, (us, 0))
            if us < last - 2**31:
                n += 1
            elif us > last + 2**31 and n > 0:
                n -= 1  # a late message from before the wrap
            wraps[mt] = (us, n)
            us += n * 2**32
        return us * 1e-6
    return None


def _df_boot(m) -> float | None:
    names = m.get_fieldnames()
    if "TimeUS" in names:
        return float(m.TimeUS) * 1e-6
    if "TimeMS" in names:
        return float(m.TimeMS) * 1e-3
    return None


def _present_types(conn, kind: str) -> dict[str, int]:
    """Message types in the log with their counts (for error messages)."""
    out: dict[str, int] = {}
    counts = getattr(conn, "counts", None)
    id_to_name = getattr(conn, "id_to_name", None)
    if counts is None or id_to_name is None:
        return out
    items = counts.items() if isinstance(counts, dict) else enumerate(counts)
    for mid, n in items:
        if n and mid in id_to_name:
            nm = id_to_name[mid]
            if kind == "dataflash" and nm in ("FMT", "FMTU", "UNIT", "MULT"):
                continue
            out[nm] = int(n)
    return out
