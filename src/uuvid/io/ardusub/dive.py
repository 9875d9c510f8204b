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

from uuvid.io.ardusub.frames import (
    BLUE_ROBOTICS_FRAMES,
    DOF_COLUMNS,
    MODE_NAMES,
    OPEN_LOOP_MODES,
    VehicleConfig,
    check_vehicle,
    config_from_params,
    effective_pwm,
)
from uuvid.io.ardusub.reader import RawLog, Series, read_raw
from uuvid.io.logs import LogDataError

G_WATER = 9.80665
BASE_COLUMNS = ("t_s", "depth_m", "roll_rad", "pitch_rad", "yaw_rad", "battery_V", "mode",
                "armed")


# ------------------------------------------------------------------------------------ helpers
_HB_ARMED = "HEARTBEAT.base_mode & MAV_MODE_FLAG_SAFETY_ARMED"


def relevant_param(name: str) -> bool:
    """Parameters the configuration is built from (a change during the log is worth a warning)."""
    return (name in ("FRAME_CONFIG", "BARO_PRIMARY", "MOT_PWM_MIN", "MOT_PWM_MAX")
            or (name.startswith("SERVO") and name.endswith("_FUNCTION"))
            or (name.startswith("MOT_") and name.endswith("_DIRECTION")))


def _clean(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Finite samples sorted by time; samples sharing a time stamp merged (mean).  Returns
    ``(t, v, number of merged samples)``."""
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    o = np.argsort(t, kind="stable")
    t, v = t[o], v[o]
    if t.size < 2:
        return t, v, 0
    start = np.concatenate(([True], np.diff(t) != 0))
    n_dup = int(t.size - np.count_nonzero(start))
    if n_dup:
        g = np.cumsum(start) - 1
        v = np.bincount(g, weights=v) / np.bincount(g)
        t = t[start]
    return t, v, n_dup


@dataclass
class _Channel:
    t: np.ndarray
    v: np.ndarray
    part: np.ndarray
    source: str  # "MESSAGE.field" (with instance)
    how: str = "linear"  # interpolation onto the grid: linear | previous


def _channel(raw: RawLog, sr: Series, fld: str, scale: float = 1.0, mask=None,
             source: str | None = None, how: str = "linear", invalid=None) -> _Channel:
    v = sr.array(fld) * scale
    t, part = np.asarray(sr.t, float), np.asarray(sr.part)
    if invalid is not None:
        v = np.where(invalid(sr.array(fld)), np.nan, v)
    if mask is not None:
        t, v, part = t[mask], v[mask], part[mask]
    src = source or f"{sr.msg}.{fld}"
    chans_t, chans_v, chans_p = [], [], []
    for k in np.unique(part):
        tk, vk, nd = _clean(t[part == k], v[part == k])
        if nd:
            raw.duplicates[src] = raw.duplicates.get(src, 0) + nd
        chans_t.append(tk)
        chans_v.append(vk)
        chans_p.append(np.full(tk.size, k))
    if not chans_t:
        return _Channel(np.zeros(0), np.zeros(0), np.zeros(0, int), src, how)
    return _Channel(np.concatenate(chans_t), np.concatenate(chans_v), np.concatenate(chans_p),
                    src, how)


def merge_params(from_log: dict, given, warnings: list) -> dict:
    """The log's parameters, overridden by ``given`` (mapping or parameter file)."""
    if given is None:
        return dict(from_log)
    from uuvid.io.ardusub.frames import read_param_file

    extra = dict(given) if isinstance(given, dict) else read_param_file(given)
    diff = [k for k in extra if relevant_param(k) and k in from_log and from_log[k] != extra[k]]
    if diff:
        warnings.append("given parameters override the log's: " + ", ".join(
            f"{k} {from_log[k]:g} → {extra[k]:g}" for k in diff))
    return {**from_log, **extra}


def _constant(ch: _Channel) -> bool:
    return ch.v.size > 1 and float(np.ptp(ch.v)) == 0.0


# ------------------------------------------------------------------------------------ sources
def _depth(raw: RawLog, config: VehicleConfig | None, warnings: list) -> tuple[_Channel, dict]:
    """Depth [m, positive down] and why that source (see the module doc of :mod:`.dive`)."""
    if raw.format == "dataflash":
        primary = config.baro_primary if config else 0
        baro = raw.get("BARO")
        tried = []
        if baro is not None and not ({"I", "Instance"} & set(baro.values)) and primary > 0:
            # firmware before multi-instance BARO logged the 2nd/3rd barometer as BAR2/BAR3
            alt = raw.get(f"BAR{primary + 1}")
            if alt is not None and "Alt" in alt.values:
                ch = _channel(raw, alt, "Alt", -1.0, source=f"-BAR{primary + 1}.Alt")
                if ch.v.size and not _constant(ch):
                    return ch, {"message": f"BAR{primary + 1}", "field": "Alt",
                                "instance": primary, "sign": -1,
                                "why": f"BAR{primary + 1} is barometer {primary} = BARO_PRIMARY "
                                       "(the water-pressure sensor); BARO (the enclosure) not used"}
            tried.append(f"no usable BAR{primary + 1} for BARO_PRIMARY = {primary}")
            baro = None
        if baro is not None:
            inst_f = "I" if "I" in baro.values else ("Instance" if "Instance" in baro.values
                                                     else None)
            insts = (sorted({int(x) for x in baro.array(inst_f) if np.isfinite(x)})
                     if inst_f else [0])
            if primary in insts:
                mask = baro.array(inst_f) == primary if inst_f else None
                ch = _channel(raw, baro, "Alt", -1.0, mask, f"-BARO[{primary}].Alt")
                if ch.v.size and not _constant(ch):
                    why = (f"BARO instance {primary} = BARO_PRIMARY, the barometer ArduSub uses "
                           "for depth (the water-pressure sensor)")
                    if len(insts) > 1:
                        others = [i for i in insts if i != primary]
                        why += f"; instance(s) {others} (e.g. the enclosure sensor) not used"
                    return ch, {"message": "BARO", "field": "Alt", "instance": primary,
                                "sign": -1, "why": why, "instances": insts}
                tried.append(f"BARO[{primary}].Alt is constant" if ch.v.size else
                             f"BARO[{primary}] has no samples")
            else:
                tried.append(f"BARO has no instance {primary} (BARO_PRIMARY); instances {insts}")
        else:
            tried.append("no BARO messages")
        ctun = raw.get("CTUN")
        for fld in ("BAlt", "Alt"):
            if ctun is not None and fld in ctun.values:
                ch = _channel(raw, ctun, fld, -1.0, source=f"-CTUN.{fld}")
                if ch.v.size and not _constant(ch):
                    return ch, {"message": "CTUN", "field": fld, "sign": -1,
                                "why": "; ".join(tried) + f"; CTUN.{fld} (the autopilot's own "
                                "altitude estimate from the primary barometer) used instead"}
                tried.append(f"CTUN.{fld} is constant or empty")
        raise LogDataError(f"{raw.name}: no usable depth: {'; '.join(tried)}")
    # telemetry
    gpi, vfr = raw.get("GLOBAL_POSITION_INT"), raw.get("VFR_HUD")
    origin = bool(raw.get("GPS_GLOBAL_ORIGIN") or raw.get("HOME_POSITION"))
    if gpi is not None and not origin:
        lat = gpi.array("lat") if "lat" in gpi.values else np.zeros(1)
        origin = bool(np.any(lat != 0))
    vfr_const = None
    if vfr is not None:
        vch = _channel(raw, vfr, "alt", -1.0, source="-VFR_HUD.alt")
        vfr_const = _constant(vch) or vch.v.size == 0
    tried = []
    if gpi is not None:
        ch = _channel(raw, gpi, "relative_alt", -1e-3, source="-GLOBAL_POSITION_INT.relative_alt")
        if ch.v.size and not _constant(ch):
            why = ("GLOBAL_POSITION_INT.relative_alt (mm, up) carries the autopilot's on-board "
                   "stamp and tracks depth with or without an EKF origin")
            if vfr is None:
                why += "; no VFR_HUD in the log"
            elif vfr_const:
                why += "; VFR_HUD.alt is constant over the log (no EKF origin: it reads 0)"
            else:
                why += ("; VFR_HUD.alt (not stamped on board, altitude above the origin"
                        + ("" if origin else ", 0 without an EKF origin") + ") not used")
            return ch, {"message": "GLOBAL_POSITION_INT", "field": "relative_alt", "scale": -1e-3,
                        "why": why, "ekf_origin": origin, "vfr_hud_alt_constant": vfr_const}
        tried.append("GLOBAL_POSITION_INT.relative_alt is constant or empty")
    else:
        tried.append("no GLOBAL_POSITION_INT from the autopilot")
    if vfr is not None and not vfr_const:
        warnings.append("depth from VFR_HUD.alt: it has no on-board stamp (mapped from the receive "
                        "time) and is relative to the EKF origin")
        return vch, {"message": "VFR_HUD", "field": "alt", "sign": -1,
                     "why": "; ".join(tried) + "; VFR_HUD.alt varies, used instead",
                     "ekf_origin": origin, "vfr_hud_alt_constant": False}
    tried.append("VFR_HUD.alt is absent or constant" if vfr is None or vfr_const else "")
    primary = config.baro_primary if config else 0
    msg = "SCALED_PRESSURE" + ("" if primary == 0 else str(primary + 1))
    sp = raw.get(msg)
    if sp is not None and "press_abs" in sp.values:
        sg = (config.params_used.get("BARO_SPEC_GRAV") if config else None) or 1.0
        ch = _channel(raw, sp, "press_abs", 100.0 / (1000.0 * sg * G_WATER),
                      source=f"{msg}.press_abs")
        if ch.v.size and not _constant(ch):
            surface = float(ch.v.min())
            ch = _Channel(ch.t, ch.v - surface, ch.part, ch.source + " − surface", ch.how)
            warnings.append(f"depth from {msg}.press_abs (the BARO_PRIMARY sensor's pressure): "
                            f"surface taken as the lowest pressure in the log, water density "
                            f"{1000.0 * sg:g} kg/m³ (BARO_SPEC_GRAV); check against a known depth")
            return ch, {"message": msg, "field": "press_abs", "why": "; ".join(
                t for t in tried if t) + f"; depth from the pressure of barometer {primary} "
                "(BARO_PRIMARY), relative to the lowest pressure in the log",
                "ekf_origin": origin, "vfr_hud_alt_constant": vfr_const}
    tried.append(f"no usable {msg}")
    raise LogDataError(f"{raw.name}: no usable depth: {'; '.join(t for t in tried if t)}")


def _attitude(raw: RawLog) -> tuple[list[_Channel], str]:
    if raw.format == "dataflash":
        att = raw.get("ATT")
        if att is None:
            raise LogDataError(f"{raw.name}: no ATT messages (attitude)")
        d = math.pi / 180.0
        return [_channel(raw, att, "Roll", d, source="ATT.Roll"),
                _channel(raw, att, "Pitch", d, source="ATT.Pitch"),
                _channel(raw, att, "Yaw", d, source="ATT.Yaw")], "ATT (deg; yaw 0…360)"
    att = raw.get("ATTITUDE")
    if att is None:
        raise LogDataError(f"{raw.name}: no ATTITUDE messages from the autopilot")
    return [_channel(raw, att, f, source=f"ATTITUDE.{f}") for f in ("roll", "pitch", "yaw")], \
        "ATTITUDE (rad; yaw ±π)"


def _unwrap(ch: _Channel) -> _Channel:
    v = ch.v.copy()
    for k in np.unique(ch.part):
        s = ch.part == k
        v[s] = np.unwrap(v[s])
    return _Channel(ch.t, v, ch.part, ch.source, ch.how)


def _battery(raw: RawLog) -> _Channel | None:
    if raw.format == "dataflash":
        for msg in ("BAT", "CURR"):
            sr = raw.get(msg)
            if sr is not None and "Volt" in sr.values:
                inst_f = next((f for f in ("Instance", "Inst", "I") if f in sr.values), None)
                mask = None
                src = f"{msg}.Volt"
                if inst_f:
                    inst = sr.array(inst_f)
                    lo = np.nanmin(inst)
                    mask = inst == lo
                    src = f"{msg}[{int(lo)}].Volt"
                ch = _channel(raw, sr, "Volt", 1.0, mask, src, invalid=lambda x: x <= 0)
                if ch.v.size:
                    return ch
        return None
    for msg, fld, src in (("SYS_STATUS", "voltage_battery", "SYS_STATUS.voltage_battery"),
                          ("BATTERY_STATUS", "voltages", "BATTERY_STATUS.voltages[0]")):
        sr = raw.get(msg)
        if sr is not None and fld in sr.values:  # mV; 0 and UINT16_MAX mean "unknown"
            ch = _channel(raw, sr, fld, 1e-3, source=src,
                          invalid=lambda x: (x <= 0) | (x >= 65535))
            if ch.v.size:
                return ch
    return None


def _pwm(raw: RawLog, output: int) -> _Channel | None:
    if raw.format == "dataflash":
        sr, fld = raw.get("RCOU"), f"C{output}"
    else:
        sr, fld = raw.get("SERVO_OUTPUT_RAW"), f"servo{output}_raw"
        if sr is not None and "port" in sr.values and output <= 16:
            mask = sr.array("port") == 0
            if fld in sr.values:
                return _channel(raw, sr, fld, mask=mask, how="previous")
    if sr is None or fld not in sr.values:
        return None
    return _channel(raw, sr, fld, how="previous")


def _outputs_seen(raw: RawLog) -> dict[int, bool]:
    sr = raw.get("RCOU" if raw.format == "dataflash" else "SERVO_OUTPUT_RAW")
    out = {}
    if sr is None:
        return out
    for k in range(1, 33):
        f = f"C{k}" if raw.format == "dataflash" else f"servo{k}_raw"
        if f in sr.values:
            v = sr.array(f)
            out[k] = bool(np.any(np.isfinite(v) & (v > 0)))
    return out


def _mode_events(raw: RawLog, warnings: list) -> tuple[_Channel | None, _Channel | None]:
    """(mode number, armed 0/1) as step channels on the time base."""
    if raw.format == "dataflash":
        mode = None
        sr = raw.get("MODE")
        if sr is not None:
            fld = "ModeNum" if "ModeNum" in sr.values else "Mode"
            mode = _channel(raw, sr, fld, source=f"MODE.{fld}", how="previous")
        armed = None
        arm, ev = raw.get("ARM"), raw.get("EV")
        ts, vs, ps = [], [], []
        if arm is not None and "ArmState" in arm.values:
            ts.append(arm.t)
            vs.append(arm.array("ArmState") > 0)
            ps.append(arm.part)
        if ev is not None and "Id" in ev.values:
            ids = ev.array("Id")
            sel = (ids == 10) | (ids == 11)  # LogEvent ARMED / DISARMED
            ts.append(ev.t[sel])
            vs.append(ids[sel] == 10)
            ps.append(ev.part[sel])
        if ts:
            t = np.concatenate(ts)
            v = np.concatenate(vs).astype(float)
            p = np.concatenate(ps)
            o = np.argsort(t, kind="stable")
            src = "+".join(n for n, s in (("ARM.ArmState", arm), ("EV.Id 10/11", ev))
                           if s is not None)
            armed = _Channel(t[o], v[o], p[o], src, "previous")
        return mode, armed
    hb = raw.get("HEARTBEAT")
    if hb is None:
        warnings.append("no autopilot HEARTBEAT: flight modes and arming are unknown")
        return None, None
    mode = _channel(raw, hb, "custom_mode", source="HEARTBEAT.custom_mode", how="previous")
    bm = hb.array("base_mode")
    sr = Series(hb.msg, hb.src, values={"armed": list(((bm.astype(np.int64) & 128) > 0)
                                                      .astype(float))})
    sr.t, sr.part = hb.t, hb.part
    armed = _channel(raw, sr, "armed", source=_HB_ARMED, how="previous")
    return mode, armed


# ------------------------------------------------------------------------------------ gridding
def _on_grid(ch: _Channel, grid: np.ndarray, gpart: np.ndarray, *, hold_ends=False,
             initial=None) -> np.ndarray:
    out = np.full(grid.size, np.nan)
    for k in np.unique(gpart):
        g = gpart == k
        s = ch.part == k
        t, v = ch.t[s], ch.v[s]
        if t.size == 0:
            continue
        if ch.how == "previous":
            idx = np.searchsorted(t, grid[g], side="right") - 1
            val = v[np.clip(idx, 0, None)].astype(float)
            if initial is not None:
                val[idx < 0] = initial[k] if isinstance(initial, dict) else initial
            else:
                val[idx < 0] = np.nan
            out[g] = val
        elif hold_ends:
            out[g] = np.interp(grid[g], t, v)
        else:
            out[g] = np.interp(grid[g], t, v, left=np.nan, right=np.nan)
    return out


def _initial_armed(ch: _Channel | None) -> dict:
    """State before the first arming event of each part: the opposite of that event."""
    if ch is None:
        return {}
    out = {}
    for k in np.unique(ch.part):
        v = ch.v[ch.part == k]
        out[int(k)] = 1.0 - v[0] if v.size else np.nan
    return out


# ------------------------------------------------------------------------------------ results
@dataclass
class DiveLog:
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
                 f"thrust: {self.thrust_model['name']} ({self.thrust_model['source']})"
                 + (", at the logged battery voltage" if self.thrust_model["voltage_aware"]
                    else ""),
                 f"forces: {self.force_basis}"]
        if self.modes:
            lines.append("modes: " + "; ".join(
                f"{s['mode']}{' armed' if s['armed'] else ''} {s['start_s']:.1f}–{s['end_s']:.1f} s"
                for s in self.modes[:12]) + (" …" if len(self.modes) > 12 else ""))
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"path": str(self.path), "format": self.format, "rows": len(self.table),
                "columns": list(self.table.columns), "config": self.config.to_dict(),
                "depth_source": self.depth_source, "thrust_model": self.thrust_model,
                "force_basis": self.force_basis, "vehicle": self.vehicle, "modes": self.modes,
                "provenance": self.provenance, "warnings": list(self.warnings)}

    def export(self, out) -> Path:
        """Write the table atomically: ``.parquet`` (provenance in the file metadata) or
        ``.csv`` (provenance in the sidecar ``<out>.json``)."""
        from uuvid.io.ardusub.export import export_dive

        return export_dive(self, out)

    def report(self, folder) -> dict:
        """``dive.csv`` (+ ``dive.csv.json``), ``dive.png`` and ``summary.txt`` in ``folder``;
        returns the file paths."""
        from uuvid.io.atomic import atomic_write_text

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        out = {"table": self.export(folder / "dive.csv"), "figure": folder / "dive.png",
               "summary": atomic_write_text(folder / "summary.txt", self.summary() + "\n")}
        self.plot(out["figure"])
        return out

    def plot(self, path=None):
        """Depth, attitude, thrusts and forces against time, modes shaded (a Figure; saved
        atomically when ``path`` is given)."""
        from uuvid.io.ardusub.export import plot_dive

        return plot_dive(self, path)


def load_dive(path, vehicle=None, thruster_model=None, *, dt: float | None = None,
              params=None) -> DiveLog:
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
        A thruster model file overriding the default voltage-aware T200 model.
    dt
        Time step of the table [s]; default the median attitude interval (to 1 ms).
    params
        Parameters the log lacks or that should override it: ``{NAME: value}`` or a parameter
        file (QGroundControl / Mission Planner / BlueOS format); used when a telemetry log was
        recorded without the parameter download.
    """
    import pandas as pd

    from uuvid.io.ardusub.thrust import default_t200, load_thrust_model

    raw = read_raw(path)
    name = raw.name
    warnings = list(raw.warnings)
    params_log, changed = raw.param_values()
    params = merge_params(params_log, params, warnings)
    for n, h in changed.items():
        if relevant_param(n):
            warnings.append(f"parameter {n} changed during the log ({' → '.join(map(str, h))}); "
                            "the last value is used")
    veh = None
    if vehicle is not None:
        from uuvid.vehicle.definition import load_vehicle

        veh = vehicle if hasattr(vehicle, "B") else load_vehicle(vehicle)
    config = config_from_params(params, name=name, outputs_seen=_outputs_seen(raw))
    if veh is not None:
        check_vehicle(config, veh, name=name)
    for m in config.motors:
        if m.disabled:
            warnings.append(f"motor {m.number} ignored: {m.disabled}")
    depth, dsrc = _depth(raw, config, warnings)
    att, att_src = _attitude(raw)
    att[2] = _unwrap(att[2])
    bat = _battery(raw)
    mode_ch, arm_ch = _mode_events(raw, warnings)
    pwms = {}
    for m in config.active:
        ch = _pwm(raw, m.output)
        if ch is None or ch.v.size == 0:
            raise LogDataError(f"{name}: motor {m.number} is driven by SERVO{m.output}, but the log "
                               f"has no {'RCOU.C' if raw.format == 'dataflash' else 'SERVO_OUTPUT_RAW.servo'}"
                               f"{m.output}{'' if raw.format == 'dataflash' else '_raw'} samples")
        pwms[m.number] = ch
    for ch, label in ((depth, "depth"), *((a, a.source) for a in att)):
        if _constant(ch):
            warnings.append(f"{label} ({ch.source}) is constant over the whole log")
    # ---- the grid: per part, over the interval depth, attitude and PWM all cover
    if dt is None:
        d = np.diff(att[0].t)
        d = d[(d > 0) & (np.diff(att[0].part) == 0)]
        dt = max(round(float(np.median(d)), 3), 0.001) if d.size else 0.1
    grids, gparts = [], []
    essentials = [depth, *att, *pwms.values()]
    for k in sorted(set(np.unique(att[0].part).tolist())):
        lo = max((c.t[c.part == k].min() for c in essentials if np.any(c.part == k)),
                 default=np.nan)
        hi = min((c.t[c.part == k].max() for c in essentials if np.any(c.part == k)),
                 default=np.nan)
        if not all(np.any(c.part == k) for c in essentials) or not hi > lo:
            warnings.append(f"part {k}: depth, attitude and PWM do not overlap; part left out")
            continue
        n = int(math.floor((hi - lo) / dt + 1e-9)) + 1
        grids.append(lo + dt * np.arange(n))
        gparts.append(np.full(n, k))
    if not grids:
        raise LogDataError(f"{name}: depth, attitude and thruster outputs never overlap in time")
    grid, gpart = np.concatenate(grids), np.concatenate(gparts)
    cols: dict = {"t_s": grid - grid[0]}
    stamp = "TimeUS" if raw.format == "dataflash" else "time_boot_ms"
    prov: dict = {"t_s": {"source": f"autopilot clock ({stamp}), continued across reboots, "
                                    "from the first row",
                          "unit": "s", "t0_boot_s": float(grid[0]), "dt_s": dt}}
    cols["depth_m"] = _on_grid(depth, grid, gpart)
    prov["depth_m"] = {"source": depth.source, "unit": "m", "why": dsrc["why"]}
    for c, ch in zip(("roll_rad", "pitch_rad", "yaw_rad"), att):
        cols[c] = _on_grid(ch, grid, gpart)
        prov[c] = {"source": ch.source, "unit": "rad"}
    prov["yaw_rad"]["note"] = "unwrapped (continuous) before resampling"
    if bat is not None:
        cols["battery_V"] = _on_grid(bat, grid, gpart, hold_ends=True)
        prov["battery_V"] = {"source": bat.source, "unit": "V"}
    else:
        cols["battery_V"] = np.full(grid.size, np.nan)
        prov["battery_V"] = {"source": None, "unit": "V"}
        warnings.append("no battery voltage in the log (BAT/CURR or SYS_STATUS)")
    # modes / arming
    if mode_ch is not None:
        mnum = _on_grid(mode_ch, grid, gpart)
        mode = np.array([MODE_NAMES.get(int(x), f"MODE{int(x)}") if np.isfinite(x) else "UNKNOWN"
                         for x in mnum], dtype=object)
        prov["mode"] = {"source": mode_ch.source, "names": "ArduSub Mode::Number"}
    else:
        mode = np.full(grid.size, "UNKNOWN", dtype=object)
        prov["mode"] = {"source": None}
        warnings.append("no flight-mode messages (MODE / HEARTBEAT): mode UNKNOWN")
    cols["mode"] = mode
    if arm_ch is not None:
        events = arm_ch.source != _HB_ARMED  # dataflash: events; telemetry: a state per HEARTBEAT
        arm = _on_grid(arm_ch, grid, gpart, initial=_initial_armed(arm_ch) if events else None)
        prov["armed"] = {"source": arm_ch.source}
        if events:
            prov["armed"]["note"] = "before the first event of a part: the opposite of that event"
    else:
        arm = np.full(grid.size, np.nan)
        prov["armed"] = {"source": None}
        warnings.append("no arming messages (ARM/EV or HEARTBEAT): armed unknown")
    cols["armed"] = pd.array([None if not np.isfinite(a) else bool(a) for a in arm],
                             dtype="boolean")
    # ---- thrust
    if thruster_model is not None:
        tm = load_thrust_model(thruster_model)
    else:
        tm = default_t200()
        if config.frame not in BLUE_ROBOTICS_FRAMES:
            warnings.append("thrusters assumed to be Blue Robotics T200s (give thruster_model=)")
    volts = cols["battery_V"]
    if tm.voltage_aware and not np.all(np.isfinite(volts)):
        fill = float(np.nanmedian(volts)) if np.isfinite(volts).any() else 16.0
        warnings.append(f"battery voltage missing on {np.count_nonzero(~np.isfinite(volts))} rows: "
                        f"thrust there computed at {fill:.2f} V "
                        + ("(the log's median)" if np.isfinite(volts).any()
                           else "(the T200 sheet's nominal 16 V: no voltage in the log)"))
        volts = np.where(np.isfinite(volts), volts, fill)
    T = np.empty((len(config.active), grid.size))
    for j, m in enumerate(config.active):
        pwm = _on_grid(pwms[m.number], grid, gpart)
        cols[f"pwm_{m.number}"] = pwm
        prov[f"pwm_{m.number}"] = {"source": pwms[m.number].source, "unit": "µs",
                                   "output": m.output}
        lo_bad = np.count_nonzero((pwm < config.pwm_min - 1) | (pwm > config.pwm_max + 1))
        if lo_bad:
            warnings.append(f"pwm_{m.number}: {lo_bad} rows outside MOT_PWM_MIN/MAX "
                            f"({config.pwm_min:g}–{config.pwm_max:g} µs)")
        eff = effective_pwm(pwm, m.direction)
        T[j] = np.where(pwm > 0, tm.thrust(eff, volts), 0.0)
    for j, m in enumerate(config.active):
        cols[f"thrust_{m.number}_N"] = T[j]
        prov[f"thrust_{m.number}_N"] = {
            "source": f"{pwms[m.number].source} → {tm.name} at battery_V",
            "unit": "N", "direction": m.direction,
            "note": "thrust along ArduSub's mixing direction of the motor: T(1500 + d (pwm − 1500))"}
    Ff = config.F @ T
    factor_df = pd.DataFrame({c: Ff[k] for k, c in enumerate(DOF_COLUMNS)})
    if veh is not None:
        W = np.asarray(veh.B, float) @ T
        basis = (f"physical wrench B·T of vehicle {veh.name!r} (thruster j = motor j); N and N·m")
    else:
        W = Ff
        basis = ("ArduSub mixing factors Σ f_i·T_i (no vehicle geometry given): X/Y/Z in N along "
                 "the mixer's axes, K/M/N in N per unit factor — proportional to the moments, not "
                 "N·m; give vehicle= for the physical wrench")
    for k, c in enumerate(DOF_COLUMNS):
        cols[c] = W[k]
        prov[c] = {"source": "Σ over motors " + ("B[dof, j]" if veh is not None else "f[dof, i]")
                             + " × thrust_i_N", "basis": basis}
    df = pd.DataFrame(cols)
    used = {v.get("source") for v in prov.values()}
    dups = {k: v for k, v in raw.duplicates.items() if k in used}
    if dups:
        warnings.append("merged samples with duplicated time stamps (mean): "
                        + ", ".join(f"{k}: {v}" for k, v in dups.items()))
    if raw.parts > 1:
        df.insert(1, "part", gpart)
        prov["part"] = {"source": "boot (reboot) number within the log"}
    segs = _segments(df)
    dsrc = {**dsrc, "source": depth.source}
    return DiveLog(raw.path, raw.format, df, config, dsrc, warnings, segs, prov, tm.to_dict(),
                   basis, factor_df, None if veh is None else veh.name)


def _segments(df) -> list[dict]:
    """Runs of equal (mode, armed, part) as ``{start_s, end_s, mode, armed, part}``."""
    import pandas as pd

    t = df["t_s"].to_numpy(float)
    if t.size == 0:
        return []
    part = df["part"].to_numpy() if "part" in df else np.zeros(t.size, int)
    codes = pd.factorize(pd.Series(list(zip(df["mode"].astype(str), df["armed"].astype(str),
                                            part.tolist()))))[0]
    starts = np.flatnonzero(np.concatenate(([True], np.diff(codes) != 0)))
    ends = np.concatenate((starts[1:] - 1, [t.size - 1]))
    out = []
    for a, b in zip(starts, ends):
        arm = df["armed"].iloc[a]
        out.append({"start_s": float(t[a]), "end_s": float(t[b]), "mode": str(df["mode"].iloc[a]),
                    "armed": None if arm is pd.NA else bool(arm), "part": int(part[a])})
    return out
