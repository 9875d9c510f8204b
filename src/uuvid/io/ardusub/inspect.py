"""What an ArduSub log holds, before any number is computed from it (``uuvid log inspect``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from uuvid.core.result import Result
from uuvid.io.ardusub.frames import MODE_NAMES, VehicleConfig, config_from_params, read_param_file
from uuvid.io.ardusub.reader import read_raw
from uuvid.io.ardusub.sources import (
    _HB_ARMED,
    _depth,
    _initial_armed,
    _mode_events,
    _outputs_seen,
    merge_params,
    relevant_param,
)
from uuvid.io.logs import LogDataError


@dataclass
class LogInspection(Result):
    path: Path
    format: str
    duration_s: float
    senders: list  # {system, component, kind, messages, clock_offset_s, reboots, autopilot}
    messages: list  # {type, system, component, count, rate_hz}
    config: VehicleConfig | None
    config_error: str | None
    depth_source: dict | None
    modes: list  # {start_s, end_s, mode, armed}
    warnings: list
    parts: int = 1
    #: the autopilot time [s] every time shown counts from (``log export``'s ``t_s`` = 0 when
    #: the log can be exported), and what it is
    t0_boot_s: float = 0.0
    time_origin: str = "the autopilot's first message"
    #: how long [s] the log's messages run before export's first row (its modes start at 0 then)
    before_first_row_s: float = 0.0

    def summary(self) -> str:
        L = [f"{self.path.name}: {self.format}, {self.duration_s:.1f} s"
             + (f", {self.parts} parts (reboots or sessions)" if self.parts > 1 else "")]
        L.append("senders:")
        for s in self.senders:
            off = ("" if s["clock_offset_s"] is None else
                   f", boot clock {s['clock_offset_s']:+.3f} s vs the autopilot's")
            L.append(f"  system {s['system']} component {s['component']} {s['kind']}"
                     f"{' [autopilot]' if s['autopilot'] else ''}: {s['messages']} messages{off}")
        L.append("messages (count, rate):")
        for m in self.messages:
            who = "" if self.format == "dataflash" else f" [{m['system']}/{m['component']}]"
            L.append(f"  {m['type']}{who}: {m['count']} ({m['rate_hz']:.2f} Hz)")
        L.append("vehicle configuration:")
        L.append("  " + (self.config.summary().replace("\n", "\n  ") if self.config
                         else f"unknown: {self.config_error}"))
        if self.depth_source:
            L.append(f"depth source: {self.depth_source['source']} — {self.depth_source['why']}")
        L.append(f"modes and arming (t [s] from {self.time_origin}; t = 0 at autopilot clock "
                 f"{self.t0_boot_s:.3f} s):")
        if self.before_first_row_s > 0:
            L.append(f"  (the log's messages begin {self.before_first_row_s:.3f} s before export's "
                     "first row; the spans start at its t = 0, as export's)")
        for m in self.modes:
            arm = {True: "armed", False: "disarmed", None: "arming unknown"}[m["armed"]]
            L.append(f"  {m['start_s']:8.1f} – {m['end_s']:8.1f} s  {m['mode']}, {arm}"
                     + (f" (part {m['part']})" if self.parts > 1 else ""))
        L += [f"warning: {w}" for w in self.warnings]
        return "\n".join(L)

    report_title = "ArduSub log inspection"

    def plot(self):
        """Message rate per type (up to 20 types) and the mode segments over time."""
        from uuvid.core.plots import new_figure

        fig, ax = new_figure(1, 2, figsize=(12, 4.5), width_ratios=[1, 2])
        top = sorted(self.messages, key=lambda m: -m["rate_hz"])[:20]
        ax[0].barh([m["type"] for m in top][::-1], [m["rate_hz"] for m in top][::-1])
        ax[0].set_xlabel("rate [Hz]")
        ax[0].tick_params(axis="y", labelsize=7)
        names = sorted({m["mode"] for m in self.modes})
        for m in self.modes:
            ax[1].barh(names.index(m["mode"]), m["end_s"] - m["start_s"], left=m["start_s"],
                       color="C0" if m["armed"] else "0.7")
        ax[1].set_yticks(range(len(names)))
        ax[1].set_yticklabels(names, fontsize=8)
        ax[1].set_xlabel("t [s] (blue: armed)")
        ax[1].set_title(f"{self.path.name}: {self.format}, {self.duration_s:.1f} s", fontsize=10)
        return fig

    def to_dict(self) -> dict:
        return {"path": str(self.path), "format": self.format, "duration_s": self.duration_s,
                "parts": self.parts, "senders": self.senders, "messages": self.messages,
                "config": None if self.config is None else self.config.to_dict(),
                "config_error": self.config_error, "depth_source": self.depth_source,
                "modes": self.modes, "t0_boot_s": self.t0_boot_s,
                "time_origin": self.time_origin, "warnings": self.warnings}


def inspect_log(path, params=None) -> LogInspection:
    """Format, duration, senders and their clocks, message counts and rates, the vehicle
    configuration from the parameters (``params``: a mapping or parameter file overriding or
    completing the log's), the depth source and why, modes and arming, warnings."""
    params_given = params
    raw = read_raw(path)
    warnings = list(raw.warnings)
    ap = raw.autopilot
    ts = [sr.t for sr in raw.series.values() if sr.src == ap and sr.t is not None and sr.t.size]
    tt = np.concatenate(ts) if ts else np.zeros(0)
    tt = tt[np.isfinite(tt)]
    t0 = float(tt.min()) if tt.size else 0.0
    if raw.format == "tlog" and not raw.sessions:
        r = [s.first_recv for s in raw.senders.values()] + [s.last_recv for s in raw.senders.values()]
        duration = float(np.nanmax(r) - np.nanmin(r))
    else:
        duration = float(tt.max() - t0) if tt.size else 0.0
    senders, msgs = [], []
    for src, s in sorted(raw.senders.items()):
        n = sum(s.counts.values())
        span = (s.last_recv - s.first_recv) if raw.format == "tlog" else duration
        kind = s.kind or ("dataflash" if raw.format == "dataflash" else "(no HEARTBEAT)")
        senders.append({"system": src[0], "component": src[1], "kind": kind,
                        "messages": n, "autopilot": src == ap,
                        "clock_offset_s": s.clock_offset, "reboots": len(s.parts)})
        for mt, c in sorted(s.counts.items()):
            rate = c / span if span and span > 0 and math.isfinite(span) else 0.0
            msgs.append({"type": mt, "system": src[0], "component": src[1], "count": c,
                         "rate_hz": rate})
        if src != ap and s.clock_offset is not None and abs(s.clock_offset) > 1.0:
            warnings.append(f"system {src[0]} component {src[1]} stamps its messages on its own "
                            f"boot clock ({s.clock_offset:+.1f} s from the autopilot's); they are "
                            "mapped through the receive clock, never taken as autopilot time")
    if raw.same_recv:
        warnings.append(f"{raw.same_recv} messages share the receive stamp of the message before "
                        "them (the ground station stamps in batches): receive times only place "
                        "messages without an on-board stamp, through the sender's clock")
    if raw.bad_data and raw.format != "tlog":  # the telemetry reader says how many and where
        warnings.append(f"{raw.bad_data} undecodable (BAD_DATA) messages skipped")
    params, _ = raw.param_values()
    given = set(read_param_file(params_given) if isinstance(params_given, (str, Path))
                else params_given or {})
    history = {n: h for n, h in raw.param_history().items()
               if relevant_param(n) and len(h) > 1 and n not in given}
    # a parameter changed during the log: the configuration at its start (never a later value
    # applied to the messages before it); the change is said with its time
    params = {**params, **{n: h[0][1] for n, h in history.items()}}
    params = merge_params(params, params_given, warnings)
    config, err, dsrc = None, None, None
    used: set = set()  # the channels this inspection reads: only their merged stamps matter
    try:
        config = config_from_params(params, name=raw.name, outputs_seen=_outputs_seen(raw))
    except LogDataError as e:
        err = str(e)
        warnings.append(err)
    t0, origin = _origin(raw, params, t0, warnings)
    for n, h in history.items():
        warnings.append(f"parameter {n} changed during the log: {h[0][1]:g} at the start, then "
                        + ", ".join(f"{v:g} from t = {t - t0:.4g} s" for t, v in h[1:])
                        + "; the configuration and depth source shown are the start's, valid "
                        f"up to t = {h[1][0] - t0:.4g} s only — `log export` refuses rows on both "
                        "sides of the change: read each side with --t-start/--t-end")
    try:
        ch, dsrc = _depth(raw, config, warnings)
        dsrc = {**dsrc, "source": ch.source}
        used.add(ch.source)
        if ch.v.size > 1 and float(np.ptp(ch.v)) == 0.0:
            warnings.append(f"depth channel {ch.source} is constant over the log")
    except LogDataError as e:
        warnings.append(str(e))
    mode_ch, arm_ch = _mode_events(raw, warnings)
    starts = {}  # the first time of each part (a reboot): modes and arming start afresh there
    for sr in raw.series.values():
        if sr.src == ap and sr.t is not None and sr.part is not None:
            for k in np.unique(sr.part):
                tk = sr.t[(sr.part == k) & np.isfinite(sr.t)]
                if tk.size:
                    starts[int(k)] = min(starts.get(int(k), math.inf), float(tk.min()) - t0)
    modes = _intervals(mode_ch, arm_ch, t0, float(tt.max() - t0) if tt.size else 0.0, starts,
                       start=(float(tt.min()) - t0) if tt.size else 0.0)
    before = 0.0
    if origin.startswith("`log export`") and modes and modes[0]["start_s"] < 0:
        # export has no rows before its t = 0: its spans (and these) start there
        before = -modes[0]["start_s"]
        modes = [{**m, "start_s": max(m["start_s"], 0.0)} for m in modes if m["end_s"] > 0]
    used |= {c.source for c in (mode_ch, arm_ch) if c is not None}
    dups = {k: v for k, v in raw.duplicates.items() if k in used}
    if dups:
        warnings.append("duplicated time stamps merged: "
                        + ", ".join(f"{k}: {v}" for k, v in dups.items()))
    return LogInspection(raw.path, raw.format, duration, senders, msgs, config, err, dsrc, modes,
                         warnings, raw.parts, t0, origin, before)


def _origin(raw, params: dict, first: float, warnings: list) -> tuple[float, str]:
    """(the autopilot time the times shown count from, what it is): ``log export``'s ``t_s`` =
    0 (:func:`~uuvid.io.ardusub.dive.export_origin`) — inspect counted from the autopilot's
    first message, up to a stream's start-up off the table's times — else, for a log export
    cannot read, the autopilot's first message ``first``, said so.  Export's warning for servo
    outputs that stop long before the log's end goes to ``warnings``."""
    from uuvid.io.ardusub.dive import export_origin

    try:
        return float(export_origin(raw, params, warnings)), "`log export`'s first row, as its t_s"
    except LogDataError:
        return first, "the autopilot's first message (`log export` cannot read this log)"


def _intervals(mode_ch, arm_ch, t0: float, t_end: float, starts: dict | None = None,
               start: float = 0.0) -> list[dict]:
    """Segments ``{start_s, end_s, mode, armed, part}`` on times from ``t0``, the first from
    ``start``; each part after a reboot (``starts``:
    part → its first time) starts with the mode unknown and the arming before its first event,
    as ``log export`` reads them (the state before the reboot does not carry over)."""
    ev = [(t, "part", k) for k, t in sorted((starts or {}).items()) if k > 0]
    if mode_ch is not None:
        ev += [(float(t) - t0, "mode", MODE_NAMES.get(int(v), f"MODE{int(v)}"))
               for t, v in zip(mode_ch.t, mode_ch.v)]
    init_arm = _initial_armed(arm_ch) if arm_ch is not None and arm_ch.source != _HB_ARMED else {}
    if arm_ch is not None:
        ev += [(float(t) - t0, "armed", bool(v)) for t, v in zip(arm_ch.t, arm_ch.v)]
    ev.sort(key=lambda e: e[0])
    def first_armed(k):
        a0 = init_arm.get(k)
        return None if a0 is None or not np.isfinite(a0) else bool(a0)

    mode, armed, part = "UNKNOWN", first_armed(0), 0
    out: list[dict] = []
    for t, kind, v in ev + [(t_end, "end", None)]:
        new_mode = v if kind == "mode" else "UNKNOWN" if kind == "part" else mode
        new_armed = (v if kind == "armed" else first_armed(v) if kind == "part" else armed)
        if kind in ("end", "part") or (new_mode, new_armed) != (mode, armed):
            if t > start or kind == "end":
                if out and (out[-1]["mode"], out[-1]["armed"], out[-1]["part"]) == (mode, armed,
                                                                                  part):
                    out[-1]["end_s"] = t
                else:
                    out.append({"start_s": start, "end_s": t, "mode": mode, "armed": armed,
                                "part": part})
            start = t
        mode, armed = new_mode, new_armed
        part = v if kind == "part" else part
    return out
