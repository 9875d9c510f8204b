"""A dive as an ArduSub log records it: one tidy table on one time base, read the right way.

:func:`load_dive` reads a ``.BIN``/``.tlog`` once (:mod:`.reader`), derives the thruster
configuration from the log's parameters (:mod:`.frames`), picks depth, attitude and battery
voltage from the right messages — and says which and why — turns every motor's PWM into thrust
at the logged voltage (:mod:`.thrust`) and sums the generalized force

    τ = Σ_i f_i · T(1500 + d_i (pwm_i − 1500))          (ArduSub mixing factors f_i, direction d_i)

or, when a uuvid vehicle is given, the physical wrench ``τ = B T`` (Fossen 2011, eq. 11.2).
:func:`inspect_log` describes a log without computing thrust.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from uuvid.core.result import Result
from uuvid.io.ardusub.frames import (
    DOF_COLUMNS,
    MODE_NAMES,
    MOMENT_FACTOR_UNIT,
    OPEN_LOOP_MODES,
    VehicleConfig,
    check_vehicle,
    config_from_params,
    effective_pwm,
    read_param_file,
)
from uuvid.io.ardusub.reader import read_raw
from uuvid.io.ardusub.sources import (
    _HB_ARMED,
    GAP_FACTOR,
    GAP_MIN_S,
    _attitude,
    _battery,
    _constant,
    _depth,
    _initial_armed,
    _mode_events,
    _on_grid,
    _outputs_seen,
    _pwm,
    _unwrap,
    merge_params,
    relevant_param,
)
from uuvid.io.logs import LogDataError

BASE_COLUMNS = ("t_s", "depth_m", "roll_rad", "pitch_rad", "yaw_rad", "battery_V", "mode",
                "armed")


# ------------------------------------------------------------------------------------ results
@dataclass
class DiveLog(Result):
    """A dive read from an ArduSub log (see :func:`load_dive`)."""

    path: Path
    format: str
    table: object  # pandas.DataFrame with the export columns
    config: VehicleConfig
    depth_source: dict
    warnings: list
    modes: list  # segments: {start_s, end_s, mode, armed, part}
    provenance: dict  # column → {message, field, ...}
    thrust_model: dict
    force_basis: str
    factor_forces: object  # DataFrame of Σ f·T (always), even when a vehicle gives the wrench
    vehicle: str | None = None

    @property
    def motors(self) -> list[int]:
        return [m.number for m in self.config.active]

    def open_loop(self, min_duration: float = 0.0) -> tuple[np.ndarray, str]:
        """Mask of the table rows in open-loop (MANUAL) *armed* stretches at least
        ``min_duration`` s long, and a sentence saying what was left out and why."""
        from uuvid.core.checks import non_negative, real

        min_duration = non_negative("min_duration", real("min_duration", min_duration,
                                                          "a finite number of seconds >= 0"), "s")
        tb = self.table
        mask = (tb["mode"].isin(OPEN_LOOP_MODES) & tb["armed"].fillna(False)).to_numpy(bool)
        t = tb["t_s"].to_numpy(float)
        dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        if min_duration > 0 and mask.any():
            edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(int), [0]))))
            for a, b in zip(edges[::2], edges[1::2]):
                if (b - a) * dt < min_duration:
                    mask[a:b] = False
        left: dict = {}
        modes = tb["mode"].astype(str).to_numpy()
        armed = tb["armed"].fillna(False).to_numpy(bool)
        reasons = np.where(~np.isin(modes, OPEN_LOOP_MODES), modes,
                           np.where(armed, "short MANUAL stretch", "disarmed or arming unknown"))
        for r in np.unique(reasons[~mask]):
            left[str(r)] = float(np.count_nonzero(reasons[~mask] == r) * dt)
        kept = float(np.count_nonzero(mask) * dt)
        text = (f"kept {kept:.1f} s of open-loop (MANUAL, armed) data; left out "
                + (", ".join(f"{v:.1f} s {k}" for k, v in sorted(left.items())) or "nothing"))
        return mask, text

    def summary(self) -> str:
        tb = self.table
        lines = [f"{self.path.name} ({self.format}): {len(tb)} rows on one time base, "
                 f"{tb['t_s'].iloc[-1] - tb['t_s'].iloc[0]:.1f} s" if len(tb) else
                 f"{self.path.name}: no rows",
                 self.config.summary(),
                 f"depth: {self.depth_source['source']} — {self.depth_source['why']}",
                 f"thrust: {self.thrust_model['name']} ({self.thrust_model['source']}); voltage: "
                 + self.thrust_model.get("voltage", "logged battery voltage"
                                         if self.thrust_model["voltage_aware"] else "fixed"),
                 f"forces: {self.force_basis}"]
        if self.modes:
            lines.append("modes: " + "; ".join(
                f"{s['mode']}{_ARMED_TEXT[s['armed']]} {s['start_s']:.1f}–{s['end_s']:.1f} s"
                for s in self.modes[:12]) + (" …" if len(self.modes) > 12 else ""))
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"path": str(self.path), "format": self.format, "rows": len(self.table),
                "columns": list(self.table.columns), "config": self.config.to_dict(),
                "depth_source": self.depth_source, "thrust_model": self.thrust_model,
                "force_basis": self.force_basis, "vehicle": self.vehicle, "modes": self.modes,
                "provenance": self.provenance, "warnings": list(self.warnings)}

    def export(self, out, plot=None) -> Path:
        """Write the table atomically: ``.parquet`` (provenance in the file metadata) or
        ``.csv`` (provenance in the sidecar ``<out>.json``); with ``plot``, the overview figure
        too, all or none (an interrupted write leaves neither)."""
        from uuvid.io.ardusub.export import export_dive

        return export_dive(self, out, plot=plot)

    report_title = "ArduSub dive"

    def _report_into(self, folder) -> Path:
        """``dive.csv`` (+ ``dive.csv.json``), ``dive.png``, ``summary.txt``, ``result.json`` and
        ``index.html`` in ``folder`` (:meth:`report` writes it as a whole); returns the index."""
        from uuvid.core.html import Report

        folder = self.write_basics(folder)
        table = self.export(folder / "dive.csv")
        figure = folder / "dive.png"
        self.plot(figure)
        rep = Report(f"{self.report_title} — {self.path.name}")
        rep.add_preformatted(self.summary(), caption="Summary")
        rep.add_figure(figure, caption="Depth, attitude, thrust per motor and generalized forces; "
                                       "modes shaded")
        rep.add_links("Files", [table.name, "summary.txt", "result.json", figure.name])
        return rep.write(folder)

    def plot(self, path=None):
        """Depth, attitude, thrusts and forces against time, modes shaded (a Figure; saved
        atomically when ``path`` is given)."""
        from uuvid.io.ardusub.export import plot_dive

        return plot_dive(self, path)


#: a table may hold at most this many rows per sample of the log's densest channel (a step
#: far below every sample interval only repeats interpolated values)
MAX_ROWS_PER_SAMPLE = 100


def _fmt_bound(v, default: float) -> str:
    return f"{float(default if v is None else v):g}"


def _check_grid(name: str, dt: float, spans, motors: int, *, dt_given: bool = True,
                densest: tuple[int, str] | None = None) -> None:
    """``LogDataError`` before the grid is allocated: a step longer than every stretch of the
    log (one row per stretch), more than :data:`MAX_ROWS_PER_SAMPLE` rows per sample of the
    densest channel (``densest``: its sample count and name), or a table (rows × columns ×
    8 bytes) past :func:`uuvid.core.checks.memory_budget_bytes`."""
    from uuvid.core.checks import memory_budget_bytes, physical_memory_bytes

    longest = max(hi - lo for _, lo, hi in spans)
    if dt > longest:
        if not dt_given:  # the range asked for is shorter than one attitude interval
            raise LogDataError(f"{name}: the range read (--t-start/--t-end) holds {longest:.4g} s "
                               f"of the log, less than one step of the table (the attitude "
                               f"interval, {dt:g} s): give a longer range")
        raise LogDataError(f"{name}: dt = {dt:g} s is longer than the log's longest stretch "
                           f"({longest:.4g} s): the table would hold one row per stretch; give a "
                           "shorter step")
    rows = sum((hi - lo) / dt + 1 for _, lo, hi in spans)
    columns = 16 + 3 * motors  # time, depth, attitude, battery, mode, wrench + per motor
    need = rows * columns * 8
    if need > memory_budget_bytes():
        raise LogDataError(f"{name}: dt = {dt:g} s makes {rows:.3g} rows × {columns} columns ≈ "
                           f"{need / 1e9:.3g} GB of table, more than half this machine's "
                           f"{physical_memory_bytes() / 1e9:.3g} GB; give a larger step")
    if densest is not None and rows > MAX_ROWS_PER_SAMPLE * max(densest[0], 1):
        raise LogDataError(f"{name}: dt = {dt:g} s makes {rows:.4g} rows, more than "
                           f"{MAX_ROWS_PER_SAMPLE}× the {densest[0]} samples of the log's densest "
                           f"channel ({densest[1]}): the rows would only repeat interpolated "
                           "values; give a larger step")


def load_dive(path, vehicle=None, thruster_model=None, *, dt: float | None = None,
              params=None, t_start: float | None = None, t_end: float | None = None) -> DiveLog:
    """Read an ArduSub ``.BIN``/``.tlog`` into a :class:`DiveLog` (see the module doc).

    Parameters
    ----------
    vehicle
        A uuvid vehicle (preset name, file, or :class:`~uuvid.vehicle.definition.Vehicle`):
        checked against the log (thruster ``j`` must be motor ``j`` of the frame, pushing the way
        ArduSub's factors say; a mismatch raises naming what differs); its ``B`` then gives the
        physical wrench ``X_N … N_Nm``.  Without one, those columns are ArduSub's mixing-frame
        force ``Σ f_i T_i`` (linear: N along the mixer's axes; moments: N per unit factor —
        proportional to, not equal to, N·m).
    thruster_model
        A thruster model file or preset name overriding the default voltage-aware T200 model
        (:func:`uuvid.io.ardusub.thrust.load_thrust_model`: a chain with an ESC block follows the
        logged voltage; one without cannot, and a warning says so).
    dt
        Time step of the table [s]; default the median attitude interval (to 1 ms).
    params
        Parameters the log lacks or that should override it: ``{NAME: value}`` or a parameter
        file (QGroundControl / Mission Planner / BlueOS format); used when a telemetry log was
        recorded without the parameter download.  A parameter given here holds for the whole
        log, also where the log changes it.
    t_start, t_end
        Only the rows from/up to these times [s, on ``t_s`` of the whole log].  A parameter the
        configuration depends on (frame, outputs, motor directions, primary barometer, PWM
        range) that changes inside the rows read is an error naming it, its values and when
        (one table holds one configuration): read each side of the change with these.
    """
    import pandas as pd

    from uuvid.core.checks import seconds_or_none, time_window
    from uuvid.io.ardusub.thrust import default_t200, load_thrust_model

    seconds_or_none(t_start=t_start, t_end=t_end)
    time_window(t_start, t_end, error=LogDataError)  # NaN/inf, an empty range: before reading
    if dt is not None and not (math.isfinite(float(dt)) and float(dt) > 0):
        raise LogDataError(f"dt = {float(dt):g}: expected a time step > 0 s (leave it out for the "
                           "attitude interval)")
    raw = read_raw(path, whole_file=False)  # checksum failures of the messages a dive reads
    name = raw.name
    warnings = list(raw.warnings)
    params_log, _ = raw.param_values()
    given = set(read_param_file(params) if isinstance(params, (str, Path)) else params or {})
    history = {n: h for n, h in raw.param_history().items()
               if relevant_param(n) and len(h) > 1 and n not in given}
    params = merge_params(params_log, params, warnings)
    veh = None
    if vehicle is not None:
        from uuvid.vehicle.definition import load_vehicle

        veh = vehicle if hasattr(vehicle, "B") else load_vehicle(vehicle)
    att, att_src = _attitude(raw)
    att[2] = _unwrap(att[2])
    bat = _battery(raw)
    mode_ch, arm_ch = _mode_events(raw, warnings)
    # the configuration in force at the start of the table (a parameter changed during the log
    # is taken at the value it had there; a change inside the table is an error, below)
    setup = _setup(raw, {**params, **_in_force(history, -math.inf)}, veh, att)
    config, depth, dsrc, pwms, spans, g0, mine = setup
    dt_given = dt is not None
    if dt is None:
        d = np.diff(att[0].t)
        d = d[(d > 0) & (np.diff(att[0].part) == 0)]
        dt = max(round(float(np.median(d)), 3), 0.001) if d.size else 0.1
    lo_w = g0 + (t_start if t_start is not None else 0.0)
    hi_w = g0 + t_end if t_end is not None else math.inf
    # the configuration is the one in force at the first row read, or — when every change in the
    # rows was made while disarmed (motor directions set on deck, then the dive) — the one in
    # force while armed: a disarmed row's thrust is zero either way
    t_ref, on_deck = lo_w, _changes_on_deck(history, spans, lo_w, hi_w, dt, arm_ch)
    if on_deck is not None:
        t_ref = on_deck[0]
    if _in_force(history, t_ref) != _in_force(history, -math.inf):  # changed before the rows
        config, depth, dsrc, pwms, spans, _, mine = _setup(
            raw, {**params, **_in_force(history, t_ref)}, veh, att)
    warnings.extend(mine)
    # cut on the whole log's rows (a part's first row + whole steps)
    spans = [(k, lo + max(math.ceil((lo_w - lo) / dt - 1e-9), 0) * dt, min(hi, hi_w))
             for k, lo, hi in spans]
    spans = [(k, lo, hi) for k, lo, hi in spans if hi >= lo]
    if not spans:
        asked = (f"[{_fmt_bound(t_start, 0.0)}, {_fmt_bound(t_end, math.inf)}] s")
        raise LogDataError(f"{name}: the range {asked} (--t-start/--t-end) is outside the log "
                           f"(0–{max(h for _, _, h in setup[4]) - g0:.4g} s): no row to export")
    if on_deck is None:
        _check_changes(name, history, spans, g0)
    for n, h in history.items():
        where = ("while disarmed (armed rows from t = "
                 f"{on_deck[0] - g0:.6g} to {on_deck[1] - g0:.6g} s, all in one configuration)"
                 if on_deck is not None else "outside this table")
        warnings.append(f"parameter {n} changed during the log ("
                        + ", ".join(f"{v:g} from t = {t - g0:.6g} s" for t, v in h[1:])
                        + f"); {where}: its value here is {_in_force(history, t_ref)[n]:g}")
    for m in config.motors:
        if m.disabled:
            warnings.append(f"motor {m.number} ignored: {m.disabled}")
    for ch, label in ((depth, "depth"), *((a, a.source) for a in att)):
        if ch is not None and _constant(ch):
            warnings.append(f"{label} ({ch.source}) is constant over the whole log")
    _check_grid(name, dt, spans, len(pwms), dt_given=dt_given,
                densest=max([(c.t.size, c.source) for c in (depth, *att, *pwms.values())
                             if c is not None]))
    grids, gparts = [], []
    for k, lo, hi in spans:
        n = int(math.floor((hi - lo) / dt + 1e-9)) + 1
        grids.append(lo + dt * np.arange(n))
        gparts.append(np.full(n, k))
    grid, gpart = np.concatenate(grids), np.concatenate(gparts)
    cols: dict = {"t_s": grid - g0}
    stamp = "TimeUS" if raw.format == "dataflash" else "time_boot_ms"
    prov: dict = {"t_s": {"source": f"autopilot clock ({stamp}), continued across reboots, "
                                    "from the first row of the whole log (--t-start/--t-end "
                                    "keep it)",
                          "unit": "s", "t0_boot_s": float(g0), "dt_s": dt}}
    cols["depth_m"] = (_on_grid(depth, grid, gpart, gaps=True) if depth is not None
                       else np.full(grid.size, np.nan))
    prov["depth_m"] = {"source": None if depth is None else depth.source, "unit": "m",
                       "why": dsrc["why"]}
    for c, ch in zip(("roll_rad", "pitch_rad", "yaw_rad"), att):
        cols[c] = _on_grid(ch, grid, gpart, gaps=True)
        prov[c] = {"source": ch.source, "unit": "rad"}
    prov["yaw_rad"]["note"] = "unwrapped (continuous) before resampling"
    for c in ("roll_rad", "pitch_rad", "yaw_rad"):
        prov[c]["as_logged"] = att_src
    if bat is not None:
        cols["battery_V"] = _on_grid(bat, grid, gpart, hold_ends=True, gaps=True)
        prov["battery_V"] = {"source": bat.source, "unit": "V"}
    else:
        cols["battery_V"] = np.full(grid.size, np.nan)
        prov["battery_V"] = {"source": None, "unit": "V"}
        warnings.append("no battery voltage in the log (BAT/CURR or SYS_STATUS)")
    _modes_on_grid(cols, prov, warnings, mode_ch, arm_ch, grid, gpart)
    tm = load_thrust_model(thruster_model) if thruster_model is not None else default_t200()
    T = _thrusts(cols, prov, warnings, config, pwms, tm, grid, gpart, dt, g0)
    Ff = config.F @ T
    factor_df = pd.DataFrame({c: Ff[k] for k, c in enumerate(DOF_COLUMNS)})
    if veh is not None:
        W = np.asarray(veh.B, float) @ T
        basis = (f"physical wrench B·T of vehicle {veh.name!r} (thruster j = motor j); N and N·m")
    else:
        W = Ff
        basis = ("ArduSub mixing factors Σ f_i·T_i (no vehicle geometry given): X/Y/Z in N along "
                 f"the mixer's axes, K/M/N in {MOMENT_FACTOR_UNIT} — proportional to the moments")
        warnings.append("no vehicle given: X_N … N_Nm are ArduSub's mixing-frame sums Σ f_i·T_i "
                        "(the default without geometry), not the physical wrench — K_Nm, M_Nm, "
                        f"N_Nm are in {MOMENT_FACTOR_UNIT}; give --vehicle (e.g. bluerov2) for "
                        "B·T in N and N·m")
    for k, c in enumerate(DOF_COLUMNS):
        cols[c] = W[k]
        unit = ("N" if k < 3 else "N·m" if veh is not None else MOMENT_FACTOR_UNIT)
        prov[c] = {"source": "Σ over motors " + ("B[dof, j]" if veh is not None else "f[dof, i]")
                             + " × thrust_i_N", "basis": basis, "unit": unit}
    df = pd.DataFrame(cols)
    gap_rows = _say_gaps(name, warnings, grid, gpart, g0, depth, att, bat, pwms)
    used = {v.get("source") for v in prov.values()}
    dups = {k: v for k, v in raw.duplicates.items() if k in used}
    if dups:
        warnings.append("merged samples with duplicated time stamps (mean; last for PWM and "
                        "modes): "
                        + ", ".join(f"{k}: {v}" for k, v in dups.items()))
    if raw.parts > 1:
        df.insert(1, "part", gpart)
        prov["part"] = {"source": "boot (reboot) number within the log"}
    if gap_rows.any():  # rows where no essential channel has a sample: left out
        df = df[~gap_rows].reset_index(drop=True)
        factor_df = factor_df[~gap_rows].reset_index(drop=True)
    segs = _segments(df)
    dsrc = {**dsrc, "source": None if depth is None else depth.source}
    return DiveLog(raw.path, raw.format, df, config, dsrc, warnings, segs, prov, tm.to_dict(),
                   basis, factor_df, None if veh is None else veh.name)


def _say_gaps(name, warnings, grid, gpart, g0, depth, att, bat, pwms) -> np.ndarray:
    """A warning per gap of each message read (its start, end and length on ``t_s``; the columns
    left NaN there); returns the rows inside a gap of depth, attitude and every PWM channel at
    once (a hole in the log: left out of the table)."""
    from uuvid.io.ardusub.sources import _gaps, _in_gaps

    said: dict = {}
    for ch in (depth, *att, bat, *pwms.values()):
        if ch is None:
            continue
        for k, a, b, med in _gaps(ch):
            key = (ch.source.split(".")[0], k, round(a, 1), round(b, 1))
            said.setdefault(key, [a, b, med, []])[3].append(ch.source)
    for (msg, k, _, _), (a, b, med, srcs) in said.items():
        warnings.append(f"{name}: {msg} has no sample from t = {a - g0:.6g} to {b - g0:.6g} s (a gap "
                        f"of {b - a:.4g} s; its samples are normally {med:.3g} s apart"
                        + (f", part {k}" if k else "") + f"): {', '.join(srcs)} left NaN there, "
                        "not interpolated or held across the gap")
    every = [c for c in (depth, *att, *pwms.values()) if c is not None]
    rows = np.ones(grid.size, bool)
    for c in every:
        rows &= _in_gaps(_gaps(c), grid, gpart)
    if rows.any():
        warnings.append(f"{name}: {int(rows.sum())} rows inside a gap of depth, attitude and "
                        "every PWM channel at once (a hole in the log) are left out of the table")
    return rows


def _in_force(history: dict, t: float) -> dict:
    """``{name: value}`` in force at ``t`` (the first value before its first message)."""
    out = {}
    for n, h in history.items():
        v = h[0][1]
        for tt, vv in h[1:]:
            if tt <= t:
                v = vv
        out[n] = v
    return out


class ConfigurationChanged(LogDataError):
    """A parameter the table's configuration depends on changed inside the rows read
    (:func:`load_dive`): read each side of the change apart (``t_start``/``t_end``)."""


def _changes_on_deck(history: dict, spans, lo_w: float, hi_w: float, dt: float, arm_ch):
    """``(first, last)`` armed row times (log clock) when parameters change between the table's
    first and last rows but only while disarmed — every change before the first armed row or
    after the last (the usual set-up on deck, then the dive); ``None`` when no change falls in
    the rows, arming is unknown, nothing is armed, or a change falls while armed."""
    from uuvid.io.ardusub.sources import _initial_armed, _on_grid

    first = max(spans[0][1], lo_w) if spans else math.inf
    last = min(spans[-1][2], hi_w) if spans else -math.inf
    changes = [t for h in history.values() for t, _ in h[1:] if first < t <= last]
    if not changes or arm_ch is None:
        return None
    grids, parts = [], []
    for k, lo, hi in spans:
        lo, hi = max(lo, lo_w), min(hi, hi_w)
        if hi >= lo:
            g = lo + dt * np.arange(int(math.floor((hi - lo) / dt + 1e-9)) + 1)
            grids.append(g)
            parts.append(np.full(g.size, k))
    if not grids:
        return None
    grid, gpart = np.concatenate(grids), np.concatenate(parts)
    events = arm_ch.source != _HB_ARMED
    arm = _on_grid(arm_ch, grid, gpart, initial=_initial_armed(arm_ch) if events else None)
    on = grid[np.nan_to_num(arm) > 0.5]
    if on.size == 0 or not np.all(np.isfinite(arm)):
        return None
    a, b = float(on[0]), float(on[-1])
    if any(a - dt < t <= b for t in changes):  # a change while armed (or at its first row)
        return None
    return a, b


def _check_changes(name: str, history: dict, spans, g0: float) -> None:
    """A parameter change between the first and the last row of the table (inside a part, or
    between two parts: a reboot after a configuration change): an error naming the parameter,
    its values, when it changed and how to read each side (never a value applied where it was
    not in force)."""
    bad = []
    first, last = spans[0][1], spans[-1][2]
    for n, h in history.items():
        inside = [(t, v) for t, v in h[1:] if first < t <= last]
        if inside:
            bad.append((n, h, inside))
    if not bad:
        return
    lo, hi = spans[0][1] - g0, spans[-1][2] - g0
    texts = []
    for n, h, inside in bad:
        steps = [f"{_in_force({n: h}, inside[0][0] - 1e-9)[n]:g}"]
        steps += [f"{v:g} from t = {t - g0:.6g} s" for t, v in inside]
        texts.append(f"{n}: " + ", then ".join(steps))
    first = min(t for _, _, inside in bad for t, _ in inside) - g0
    end, start = math.floor(first * 1000) / 1000 - 0.001, math.ceil(first * 1000 + 1e-6) / 1000
    raise ConfigurationChanged(
        f"{name}: parameters the thrust/depth configuration depends on changed during the rows "
        f"read ({lo:.6g}–{hi:.6g} s): " + "; ".join(texts) + ". One table holds one "
        f"configuration: read each side apart (--t-end {end:.3f}, then --t-start {start:.3f}), "
        "or give --params with the value that held throughout if the log's is wrong")


def export_origin(raw, params: dict, ends: list | None = None) -> float:
    """The autopilot time [s] that ``log export``'s ``t_s`` counts from (its ``t0_boot_s``): the
    first time depth, attitude and the thruster outputs all cover, with the configuration of
    ``params``; a :class:`LogDataError` when the log has no such time (nothing to export).
    ``ends``: gets export's warning for servo outputs that stop long before the log's end."""
    return _setup(raw, params, None, _attitude(raw)[0], ends)[5]


def _setup(raw, params: dict, veh, att, ends: list | None = None):
    """Configuration, depth, PWM channels and the spans (part, first, last time) that depth,
    attitude and PWM all cover — or, where the servo outputs stop long before depth and
    attitude do, up to the end of those (said in a warning, also added to ``ends``), for
    ``params``; the first time of those spans and the messages (warnings) of this choice."""
    name = raw.name
    config = config_from_params(params, name=name, outputs_seen=_outputs_seen(raw),
                                custom_B=None if veh is None else np.asarray(veh.B, float))
    if veh is not None:
        check_vehicle(config, veh, name=name)
    mine: list = []
    try:
        depth, dsrc = _depth(raw, config, mine)
    except LogDataError as e:  # a surface or bench log: everything else is still worth reading
        depth, dsrc = None, {"source": None, "why": str(e)}
        mine.append(f"depth_m is empty (NaN): {e}")
    pwms = {}
    for m in config.active:
        ch = _pwm(raw, m.output)
        if ch is None or ch.v.size == 0:
            raise LogDataError(f"{name}: motor {m.number} is driven by SERVO{m.output}, but the log "
                               f"has no {'RCOU.C' if raw.format == 'dataflash' else 'SERVO_OUTPUT_RAW.servo'}"
                               f"{m.output}{'' if raw.format == 'dataflash' else '_raw'} samples")
        pwms[m.number] = ch
    spans, ended = [], []
    essentials = [c for c in (depth, *att, *pwms.values()) if c is not None]
    motion = [c for c in (depth, *att) if c is not None]
    for k in sorted(set(np.unique(att[0].part).tolist())):
        lo = max((c.t[c.part == k].min() for c in essentials if np.any(c.part == k)),
                 default=np.nan)
        hi = min((c.t[c.part == k].max() for c in essentials if np.any(c.part == k)),
                 default=np.nan)
        if not all(np.any(c.part == k) for c in essentials) or not hi > lo:
            mine.append(f"part {k}: depth, attitude and PWM do not overlap; part left out")
            continue
        # servo outputs that stop long before depth and attitude do (a stream stopped): the
        # rows after them are kept, their PWM empty — not the end of the table
        out_end = min(c.t[c.part == k].max() for c in pwms.values()) if pwms else hi
        motion_end = min(c.t[c.part == k].max() for c in motion)
        every = max((_interval(c) for c in pwms.values()), default=0.0)
        if motion_end - out_end > max(GAP_FACTOR * every, GAP_MIN_S):
            hi = motion_end
            ended.append((k, out_end, motion_end))
        spans.append((k, lo, hi))
    if not spans:
        raise LogDataError(f"{name}: depth, attitude and thruster outputs never overlap in time")
    g0 = spans[0][1]
    msg = next(iter(pwms.values())).source.split(".")[0] if pwms else ""
    for k, a, b in ended:
        mine.append(f"{name}: {msg} (the servo outputs) stops at t = {a - g0:.6g} s"
                    + (f" (part {k})" if raw.parts > 1 else "") + f", {b - a:.4g} s before depth "
                    f"and attitude end (t = {b - g0:.6g} s): the rows from there are kept with "
                    "pwm_<n>, thrust_<n>_N and X_N … N_Nm empty (NaN) — no force is known there")
        if ends is not None:
            ends.append(mine[-1])
    return config, depth, dsrc, pwms, spans, g0, mine


_ARMED_TEXT = {True: " armed", False: " disarmed", None: ""}


def _modes_on_grid(cols, prov, warnings, mode_ch, arm_ch, grid, gpart) -> None:
    """``mode`` (ArduSub mode name) and ``armed`` (nullable boolean) columns."""
    import pandas as pd

    if mode_ch is not None:
        mnum = _on_grid(mode_ch, grid, gpart, gaps=mode_ch.source.startswith("HEARTBEAT"))
        names = {x: MODE_NAMES.get(int(x), f"MODE{int(x)}") for x in np.unique(mnum[np.isfinite(mnum)])}
        mode = pd.Series(mnum).map(names).fillna("UNKNOWN").to_numpy(object)
        prov["mode"] = {"source": mode_ch.source, "names": "ArduSub Mode::Number"}
    else:
        mode = np.full(grid.size, "UNKNOWN", dtype=object)
        prov["mode"] = {"source": None}
        warnings.append("no flight-mode messages (MODE / HEARTBEAT): mode UNKNOWN")
    cols["mode"] = mode
    if arm_ch is not None:
        events = arm_ch.source != _HB_ARMED  # dataflash: events; telemetry: a state per HEARTBEAT
        arm = _on_grid(arm_ch, grid, gpart, initial=_initial_armed(arm_ch) if events else None,
                       gaps=not events)  # telemetry: a state per HEARTBEAT, not held across gaps
        prov["armed"] = {"source": arm_ch.source}
        if events:
            prov["armed"]["note"] = "before the first event of a part: the opposite of that event"
    else:
        arm = np.full(grid.size, np.nan)
        prov["armed"] = {"source": None}
        warnings.append("no arming messages (ARM/EV or HEARTBEAT): armed unknown")
    cols["armed"] = pd.arrays.BooleanArray(np.nan_to_num(arm) > 0.5, ~np.isfinite(arm))


#: servo outputs logged more than this many row steps apart fill only the rows where a new
#: sample arrived (:func:`_thrusts`)
SLOW_OUTPUT_STEPS = 1.5


def _thrusts(cols, prov, warnings, config, pwms, tm, grid, gpart, dt, g0) -> np.ndarray:
    """``pwm_<i>`` and ``thrust_<i>_N`` columns; returns the thrusts (motors × rows).  Servo
    outputs logged slower than the rows (a BlueROV2's SERVO_OUTPUT_RAW at 2 Hz beside ATTITUDE
    at 20 Hz) are filled only on the rows where a new sample arrived and left empty (NaN)
    between, as in a table written at the logger's own rows: each column's stamps keep the
    interval of the message it came from, so the identification sees how often the force is
    logged, and a held value is not taken for a new sample.  Warned: that, rows whose voltage
    the thruster model's data do not cover, a map that falls with a growing command at the
    logged voltage (:func:`.thrust.thrust_warnings`)."""
    from uuvid.io.ardusub.sources import _fresh_rows
    from uuvid.io.ardusub.thrust import thrust_warnings

    volts = cols["battery_V"]
    if not tm.voltage_aware:
        span = (f" (the log's battery spans {np.nanmin(volts):.2f}–{np.nanmax(volts):.2f} V)"
                if np.isfinite(volts).any() else "")
        warnings.append(f"thruster model {tm.name!r} cannot follow the battery voltage{span}: "
                        f"{tm.voltage}")
    at_v = "at battery_V" if np.isfinite(volts).any() else "at the nominal 16 V (no voltage logged)"
    if tm.voltage_aware and not np.all(np.isfinite(volts)):
        fill = float(np.nanmedian(volts)) if np.isfinite(volts).any() else 16.0
        warnings.append(f"battery voltage missing on {np.count_nonzero(~np.isfinite(volts))} rows: "
                        f"thrust there computed at {fill:.2f} V "
                        + ("(the log's median)" if np.isfinite(volts).any()
                           else "(the T200 sheet's nominal 16 V: no voltage in the log)"))
        volts = np.where(np.isfinite(volts), volts, fill)
    T = np.empty((len(config.active), grid.size))
    slow: dict = {}  # message → its sample interval, for outputs logged slower than the rows
    for j, m in enumerate(config.active):
        ch = pwms[m.number]
        pwm = _on_grid(ch, grid, gpart, gaps=True)
        prov[f"pwm_{m.number}"] = {"source": ch.source, "unit": "µs", "output": m.output}
        every = _interval(ch)
        for k in np.unique(gpart):  # after the stream's last sample (it stopped): no value
            tk = ch.t[ch.part == k]
            pwm[(gpart == k) & (grid > (tk.max() + min(every, GAP_MIN_S) if tk.size
                                         else -math.inf))] = np.nan
        if every > SLOW_OUTPUT_STEPS * dt:
            pwm[~_fresh_rows(ch, grid, gpart, dt)] = np.nan
            prov[f"pwm_{m.number}"]["sampled"] = (
                f"every {every:.3g} s: only on the rows where a new sample arrived, empty between")
            slow[ch.source.split(".")[0]] = every
        cols[f"pwm_{m.number}"] = pwm
        out = np.count_nonzero((pwm < config.pwm_min - 1) | (pwm > config.pwm_max + 1))
        if out:
            warnings.append(f"pwm_{m.number}: {out} rows outside MOT_PWM_MIN/MAX "
                            f"({config.pwm_min:g}–{config.pwm_max:g} µs)")
        # 0 µs is "no pulse" (output off), not full reverse
        T[j] = np.where(pwm > 0, tm.thrust(effective_pwm(pwm, m.direction), volts),
                        np.where(np.isfinite(pwm), 0.0, np.nan))  # NaN: a gap in the PWM
    for msg, every in slow.items():
        warnings.append(f"{msg} (the servo outputs) is logged every {every:.3g} s, slower than "
                        f"the table's {dt:g} s rows: pwm_<n>, thrust_<n>_N and X_N … N_Nm are "
                        f"filled only on the rows where a new {msg} sample arrived and left empty "
                        "(NaN) between — not held, so the force's own sampling stays visible")
    if config.active:
        warnings.extend(thrust_warnings(tm, volts, cols["t_s"], config.pwm_min, config.pwm_max))
    for j, m in enumerate(config.active):
        cols[f"thrust_{m.number}_N"] = T[j]
        prov[f"thrust_{m.number}_N"] = {
            "source": f"{pwms[m.number].source} → {tm.name} {at_v}",
            "unit": "N", "direction": m.direction,
            "note": "thrust along ArduSub's mixing direction of the motor: T(1500 + d (pwm − 1500))"}
    return T


def _interval(ch) -> float:
    """Median interval [s] between a channel's samples within a part (inf with fewer than 2)."""
    d = np.diff(ch.t)[np.diff(ch.part) == 0]
    d = d[d > 0]
    return float(np.median(d)) if d.size else math.inf


def _segments(df) -> list[dict]:
    """Runs of equal (mode, armed, part) as ``{start_s, end_s, mode, armed, part, last_row_s}``:
    a run spans from its first row to the next run's first row (the first time the new state is
    seen; the change happened in between; across a hole in the rows, to its last row + the row
    step) and the last one to its last row + the row step — the
    intervals tile the rows, as :func:`~uuvid.io.ardusub.inspect.inspect_log`'s tile the log's
    events (``log inspect`` and ``log export`` then say the same spans); ``last_row_s`` is the
    run's last row."""
    import pandas as pd

    t = df["t_s"].to_numpy(float)
    if t.size == 0:
        return []
    part = df["part"].to_numpy() if "part" in df else np.zeros(t.size, int)
    codes = pd.factorize(pd.Series(list(zip(df["mode"].astype(str), df["armed"].astype(str),
                                            part.tolist()))))[0]
    starts = np.flatnonzero(np.concatenate(([True], np.diff(codes) != 0)))
    ends = np.concatenate((starts[1:] - 1, [t.size - 1]))
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    out = []
    for a, b in zip(starts, ends):
        arm = df["armed"].iloc[a]
        # across a hole in the rows (a logger paused: more than 3 row steps) the change is not
        # seen: the span ends a row step after its last row, as the log's last one does
        end = (float(t[b + 1]) if b + 1 < t.size and t[b + 1] - t[b] <= 3 * step
               else float(t[b]) + step)
        out.append({"start_s": float(t[a]), "end_s": end, "mode": str(df["mode"].iloc[a]),
                    "armed": None if arm is pd.NA else bool(arm), "part": int(part[a]),
                    "last_row_s": float(t[b])})
    return out
