"""Where each quantity of a dive comes from in an ArduSub log, and why (used by
:mod:`.dive` and :mod:`.inspect`): depth, attitude, battery voltage, PWM per output, modes and
arming, each as a :class:`_Channel` on the time base of :mod:`.reader`, split by reboot part,
with duplicated stamps merged.

Depth: dataflash ``-BARO[BARO_PRIMARY].Alt`` (instance 0 is often the enclosure sensor), else
``-BAR{n+1}.Alt`` on firmware that logged barometers as separate messages, else ``CTUN``;
telemetry: the pressure of barometer n = BARO_PRIMARY (``SCALED_PRESSURE{n+1}``, the water-pressure
sensor, as in a .BIN) relative to ``BARO{n+1}_GND_PRESS`` when the log names BARO_PRIMARY, else the
EKF's ``-GLOBAL_POSITION_INT.relative_alt`` (on-board stamp; ``VFR_HUD.alt`` reads 0 without an
EKF origin), else a varying ``VFR_HUD.alt``, else that pressure relative to the lowest pressure in
the log.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uuvid.io.ardusub.frames import VehicleConfig
from uuvid.io.ardusub.reader import RawLog, Series
from uuvid.io.logs import LogDataError

G_WATER = 9.80665
# ------------------------------------------------------------------------------------ helpers
_HB_ARMED = "HEARTBEAT.base_mode & MAV_MODE_FLAG_SAFETY_ARMED"


def relevant_param(name: str) -> bool:
    """Parameters the configuration is built from (a change during the log is worth a warning)."""
    return (name in ("FRAME_CONFIG", "BARO_PRIMARY", "MOT_PWM_MIN", "MOT_PWM_MAX")
            or (name.startswith("SERVO") and name.endswith("_FUNCTION"))
            or (name.startswith("MOT_") and name.endswith("_DIRECTION")))


def _clean(t: np.ndarray, v: np.ndarray, last: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
    """Finite samples sorted by time; samples sharing a time stamp merged — their mean, or the
    last one for step signals (modes, PWM: a mean would be a value never commanded).  Returns
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
        if last:
            v = v[np.concatenate((start[1:], [True]))]
        else:
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
        tk, vk, nd = _clean(t[part == k], v[part == k], last=how == "previous")
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
    from uuvid.io.ardusub.frames import check_given_params, read_param_file

    if isinstance(given, dict):  # a file is checked line by line as it is read
        extra = dict(given)
        check_given_params(extra, "the given parameters")
    else:
        extra = read_param_file(given)
    diff = [k for k in extra if relevant_param(k) and k in from_log and from_log[k] != extra[k]]
    if diff:
        warnings.append("given parameters override the log's: " + ", ".join(
            f"{k} {from_log[k]:g} → {extra[k]:g}" for k in diff))
    return {**from_log, **extra}


def _constant(ch: _Channel) -> bool:
    return ch.v.size > 1 and float(np.ptp(ch.v)) == 0.0


# ------------------------------------------------------------------------------------ sources
def _depth(raw: RawLog, config: VehicleConfig | None, warnings: list) -> tuple[_Channel, dict]:
    """Depth [m, positive down] and why that source (see the module doc of :mod:`.dive`).  A
    logged BARO_PRIMARY that is no barometer instance (``config.baro_primary`` None) is treated
    as instance 2 on a vehicle with two barometers: no BARO instance is read (it would not be
    the water-pressure sensor the parameter was meant to name), the autopilot's own estimate
    stands in (CTUN.BAlt; telemetry: GLOBAL_POSITION_INT), with a warning."""
    bad_primary = config is not None and config.baro_primary is None
    if bad_primary:
        value = config.params_used.get("BARO_PRIMARY", float("nan"))
        warnings.append(f"the log's BARO_PRIMARY = {value:g} is no barometer instance (0, 1 or "
                        "2): no barometer is read as the water-pressure sensor; depth from the "
                        "autopilot's own altitude estimate instead, if logged (see the depth "
                        "source) — check the "
                        "parameter, or give --params with BARO_PRIMARY")
    if raw.format == "dataflash":
        primary = config.baro_primary if config else 0
        baro = raw.get("BARO")
        tried = []
        if bad_primary:
            tried.append(f"BARO_PRIMARY = {value:g} is no barometer instance (0, 1 or 2)")
            baro = None
        elif baro is not None and not ({"I", "Instance"} & set(baro.values)) and primary > 0:
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
                    named = config is not None and "BARO_PRIMARY" in config.params_used
                    why = (f"BARO instance {primary} = BARO_PRIMARY, the barometer ArduSub uses "
                           "for depth (the water-pressure sensor)" if named else
                           f"BARO instance {primary}: BARO_PRIMARY is not in the log, so ArduSub's "
                           f"default {primary} is assumed — on most vehicles the water-pressure "
                           "sensor, but check the depth against a known one (give --params)")
                    if len(insts) > 1:
                        others = [i for i in insts if i != primary]
                        why += f"; instance(s) {others} (e.g. the enclosure sensor) not used"
                        if not named:  # two barometers and no word on which measures the water
                            warnings.append(
                                f"depth: BARO_PRIMARY is not in the log and BARO has instances "
                                f"{insts}: instance {primary} (ArduSub's default) assumed to be "
                                "the water-pressure sensor — check the depth against a known one, "
                                "or give --params with BARO_PRIMARY")
                    return ch, {"message": "BARO", "field": "Alt", "instance": primary,
                                "sign": -1, "why": why, "instances": insts}
                tried.append(f"BARO[{primary}].Alt is constant" if ch.v.size else
                             f"BARO[{primary}] has no samples")
            else:
                tried.append(f"BARO has no instance {primary} (BARO_PRIMARY); instances {insts}")
        elif not bad_primary:
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
        raise LogDataError(f"{raw.name}: no usable depth: {'; '.join(tried)}"
                           + _other_barometer(raw, primary))
    # telemetry: the BARO_PRIMARY sensor's pressure first (as the dataflash branch), when the log
    # says which barometer that is
    pressure = _tlog_pressure_depth(raw, config, warnings)
    if pressure is not None:
        return pressure
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
    if primary is None:
        raise LogDataError(f"{raw.name}: no usable depth: {'; '.join(t for t in tried if t)}; "
                           f"BARO_PRIMARY = {value:g} names no barometer whose pressure to read "
                           "(give --params with BARO_PRIMARY)")
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
    raise LogDataError(f"{raw.name}: no usable depth: {'; '.join(t for t in tried if t)}"
                       + _other_barometer(raw, primary))


#: a barometer whose pressure spans this much (Pa) over the log measures water, not the
#: enclosure (0.5 m of water; an enclosure's varies by a few hundred Pa)
WATER_PRESSURE_SPAN_PA = 5000.0


def _other_barometer(raw: RawLog, primary: int | None) -> str:
    """A note naming each barometer other than BARO_PRIMARY whose pressure varies like a
    water-pressure sensor's (swapped or misconfigured barometers), with the parameter to give;
    empty when none does."""
    found = []  # (what, instance, span in Pa)
    if raw.format == "dataflash":
        baro = raw.get("BARO")
        inst_f = next((f for f in ("I", "Instance") if baro is not None and f in baro.values), None)
        if baro is not None and "Press" in baro.values and inst_f:
            inst, press = baro.array(inst_f), baro.array("Press")
            for i in sorted({int(x) for x in inst if np.isfinite(x)} - {primary}):
                found.append((f"BARO[{i}].Press", i, press[inst == i]))
        for i in (1, 2):
            b = raw.get(f"BAR{i + 1}")
            if b is not None and "Press" in b.values and i != primary:
                found.append((f"BAR{i + 1}.Press", i, b.array("Press")))
    else:
        for i in (0, 1, 2):
            sp = raw.get("SCALED_PRESSURE" + ("" if i == 0 else str(i + 1)))
            if sp is not None and "press_abs" in sp.values and i != primary:
                found.append((f"SCALED_PRESSURE{'' if i == 0 else i + 1}.press_abs", i,
                              100.0 * sp.array("press_abs")))  # hPa
    out = []
    for what, i, v in found:
        v = v[np.isfinite(v)]
        span = float(np.ptp(v)) if v.size > 1 else 0.0
        if span >= WATER_PRESSURE_SPAN_PA:
            out.append(f"{what} (barometer {i}) varies by {span / 1000.0:.3g} kPa over the log, as "
                       f"a water-pressure sensor does: if it is the one in the water, give "
                       f"--params with a file setting BARO_PRIMARY = {i}")
    return "".join("; " + o for o in out)


def _tlog_pressure_depth(raw: RawLog, config: VehicleConfig | None,
                         warnings: list) -> tuple[_Channel, dict] | None:
    """Depth from ``SCALED_PRESSURE{n+1}.press_abs`` of barometer n = BARO_PRIMARY (the
    water-pressure sensor ArduSub computes depth from), relative to its calibrated ground
    pressure ``BARO{n+1}_GND_PRESS`` (else the lowest pressure in the log, warned); ``None`` when
    the log does not name BARO_PRIMARY or has no varying pressure of that barometer."""
    if config is None or "BARO_PRIMARY" not in config.params_used or config.baro_primary is None:
        return None
    primary = config.baro_primary
    msg = "SCALED_PRESSURE" + ("" if primary == 0 else str(primary + 1))
    sp = raw.get(msg)
    if sp is None or "press_abs" not in sp.values:
        return None
    sg = config.params_used.get("BARO_SPEC_GRAV") or 1.0
    per_m = 1000.0 * sg * G_WATER  # Pa per metre of water
    ch = _channel(raw, sp, "press_abs", 100.0 / per_m, source=f"{msg}.press_abs")
    if not ch.v.size or _constant(ch):
        return None
    gnd_name = f"BARO{primary + 1}_GND_PRESS"
    gnd = config.params_used.get(gnd_name)
    density = f"water density {1000.0 * sg:g} kg/m³ (BARO_SPEC_GRAV)"
    if gnd is not None and math.isfinite(gnd) and gnd > 0:
        surface = gnd / per_m
        ref = f"relative to its calibrated ground pressure {gnd_name} = {gnd:g} Pa, {density}"
        src = f"{msg}.press_abs − {gnd_name}"
    else:
        surface = float(ch.v.min())
        ref = f"relative to the lowest pressure in the log ({gnd_name} not in the log), {density}"
        src = f"{msg}.press_abs − surface"
        warnings.append(f"depth from {msg}.press_abs: surface taken as the lowest pressure in the "
                        f"log ({gnd_name} not in the log), {density}; check against a known depth")
    ch = _Channel(ch.t, ch.v - surface, ch.part, src, ch.how)
    others = [m for m in ("GLOBAL_POSITION_INT", "VFR_HUD") if raw.get(m) is not None]
    why = (f"{msg} is barometer {primary} = BARO_PRIMARY, the water-pressure sensor ArduSub "
           f"computes depth from (as BARO[{primary}] in a .BIN); {ref}"
           + (f"; the EKF's {' and '.join(others)} altitude not used" if others else ""))
    return ch, {"message": msg, "field": "press_abs", "instance": primary,
                "ground_pressure_Pa": gnd, "scale": 100.0 / per_m, "why": why}


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
#: samples of a channel further apart than this many times its median interval (and at least
#: :data:`GAP_MIN_S`) leave a gap in it: never bridged by interpolation or hold
GAP_FACTOR = 10.0
GAP_MIN_S = 1.0


def _gaps(ch: _Channel) -> list[tuple[int, float, float, float]]:
    """``(part, last sample before, first sample after, median interval)`` of each gap in
    ``ch`` (see :data:`GAP_FACTOR`)."""
    out = []
    for k in np.unique(ch.part):
        t = ch.t[ch.part == k]
        if t.size < 3:
            continue
        d = np.diff(t)
        med = float(np.median(d))
        for i in np.flatnonzero(d > max(GAP_FACTOR * med, GAP_MIN_S)):
            out.append((int(k), float(t[i]), float(t[i + 1]), med))
    return out


def _in_gaps(gaps, grid: np.ndarray, gpart: np.ndarray) -> np.ndarray:
    """Rows of the grid strictly inside one of ``gaps`` (:func:`_gaps`)."""
    m = np.zeros(grid.size, bool)
    for k, a, b, _ in gaps:
        m |= (gpart == k) & (grid > a) & (grid < b)
    return m


def _on_grid(ch: _Channel, grid: np.ndarray, gpart: np.ndarray, *, hold_ends=False,
             initial=None, gaps: bool = False) -> np.ndarray:
    """``ch`` on the grid (per part); ``gaps``: NaN inside the channel's gaps (:func:`_gaps`)
    rather than a straight line or a held value across them."""
    out = _on_grid_all(ch, grid, gpart, hold_ends=hold_ends, initial=initial)
    if gaps:
        out[_in_gaps(_gaps(ch), grid, gpart)] = np.nan
    return out


def _on_grid_all(ch: _Channel, grid: np.ndarray, gpart: np.ndarray, *, hold_ends=False,
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


def _fresh_rows(ch: _Channel, grid: np.ndarray, gpart: np.ndarray, dt: float) -> np.ndarray:
    """Rows of the grid with a sample of ``ch`` since the row before (in ``(row − dt, row]``, in
    the row's part): where a channel logged slower than the rows has a new value.  A channel
    as fast as the rows or faster has one on (nearly) every row."""
    out = np.zeros(grid.size, bool)
    for k in np.unique(gpart):
        g = np.flatnonzero(gpart == k)
        t = ch.t[ch.part == k]
        if t.size == 0:
            continue
        n = np.searchsorted(t, grid[g], side="right") - np.searchsorted(t, grid[g] - dt,
                                                                         side="right")
        out[g] = n > 0
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
