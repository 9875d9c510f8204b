"""ArduSub's vehicle configuration, read back from the parameters a log records.

ArduSub mixes pilot and controller demands into per-motor outputs with a fixed factor table per
frame (``FRAME_CONFIG``), then applies the per-motor reversal ``MOT_n_DIRECTION`` and writes
PWM to the output whose ``SERVOn_FUNCTION`` is that motor:

    out_i  = d_i · (Σ_dof f_{i,dof} · demand_dof)          (AP_Motors6DOF, output_armed_stabilizing)
    pwm_i  = 1500 + out_i · (MOT_PWM_MAX − 1500)   if out_i > 0
           = 1500 + out_i · (1500 − MOT_PWM_MIN)   otherwise  (calc_thrust_to_pwm)

(the logged RCOU / SERVO_OUTPUT_RAW value is what the ESC receives), so the thrust a motor gives
*along its mixing direction* is the thruster's thrust at the PWM
reflected about the 1500 µs trim: ``T_i = T(1500 + d_i (pwm_i − 1500))`` (a reversed motor runs
a reversed propeller; reflecting keeps its forward/reverse asymmetry on the right side).  The
generalized force in ArduSub's mixing frame is then ``τ = F · T`` with ``F`` the factor table
below, its rows in FRD/NED order ``[X, Y, Z, K, M, N] = [forward, lateral, −throttle, roll,
pitch, yaw]`` (ArduSub's throttle is positive up; its roll, pitch and yaw follow FRD).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from uuvid.io.logs import LogDataError

# Motor factor tables restated from ArduPilot's libraries/AP_Motors/AP_Motors6DOF.cpp,
# AP_Motors6DOF::setup_motors (github.com/ArduPilot/ardupilot, read at commits
# 0fd5fbf258e877389665051b1f7c7531ac1db76a and the current master): per motor
# (roll, pitch, yaw, throttle, forward, lateral).  FRAME_CONFIG numbers are the order of
# AP_Motors6DOF::sub_frame_t.  The SimpleROV rows follow the current source; older firmware
# (before SimpleROV-3 got its own case) gave SimpleROV-4/5 motors 3 and 4 no roll factor.
_R = tuple[float, float, float, float, float, float]
FRAME_NAMES = {0: "BlueROV1", 1: "Vectored (BlueROV2)", 2: "Vectored-6DOF (BlueROV2 Heavy)",
               3: "Vectored-6DOF-90deg", 4: "SimpleROV-3", 5: "SimpleROV-4", 6: "SimpleROV-5",
               7: "Custom"}
_SIMPLE = ((0, 0, -1.0, 0, 1.0, 0), (0, 0, 1.0, 0, 1.0, 0), (1.0, 0, 0, -1.0, 0, 0),
           (-1.0, 0, 0, -1.0, 0, 0), (0, 0, 0, 0, 0, 1.0))
_VECTORED_H = ((0, 0, 1.0, 0, -1.0, 1.0), (0, 0, -1.0, 0, -1.0, -1.0), (0, 0, -1.0, 0, 1.0, 1.0),
               (0, 0, 1.0, 0, 1.0, -1.0))
FRAME_FACTORS: dict[int, tuple[_R, ...]] = {
    0: ((0, 0, -1.0, 0, 1.0, 0), (0, 0, 1.0, 0, 1.0, 0), (-0.5, 0.5, 0, 0.45, 0, 0),
        (0.5, 0.5, 0, 0.45, 0, 0), (0, -1.0, 0, 1.0, 0, 0), (-0.25, 0, 0, 0, 0, 1.0)),
    1: _VECTORED_H + ((1.0, 0, 0, -1.0, 0, 0), (-1.0, 0, 0, -1.0, 0, 0)),
    2: _VECTORED_H + ((1.0, -1.0, 0, -1.0, 0, 0), (-1.0, -1.0, 0, -1.0, 0, 0),
                      (1.0, 1.0, 0, -1.0, 0, 0), (-1.0, 1.0, 0, -1.0, 0, 0)),
    3: ((1.0, 1.0, 0, 1.0, 0, 0), (0, 0, 1.0, 0, 1.0, 0), (1.0, -1.0, 0, 1.0, 0, 0),
        (0, 0, 0, 0, 0, 1.0), (0, 0, 0, 0, 0, 1.0), (-1.0, 1.0, 0, 1.0, 0, 0),
        (0, 0, -1.0, 0, 1.0, 0), (-1.0, -1.0, 0, 1.0, 0, 0)),
    4: _SIMPLE[:2] + ((0, 0, 0, -1.0, 0, 0),),
    5: _SIMPLE,
    6: _SIMPLE,
}
#: SERVOn_FUNCTION values of motors 1…12 (SRV_Channel::k_motor1…k_motor8 = 33…40,
#: k_motor9…k_motor12 = 82…85)
MOTOR_FUNCTIONS = {**{33 + k: k + 1 for k in range(8)}, **{82 + k: 9 + k for k in range(4)}}
#: ArduSub flight modes (ArduSub/mode.h, Mode::Number; pymavlink mode_mapping_sub)
MODE_NAMES = {0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 7: "CIRCLE",
              9: "SURFACE", 16: "POSHOLD", 19: "MANUAL", 20: "MOTOR_DETECT", 21: "SURFTRAK"}
#: modes in which the autopilot does not close any loop on attitude or depth
OPEN_LOOP_MODES = ("MANUAL",)
DOF_COLUMNS = ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm")
# what K_Nm/M_Nm/N_Nm hold when no vehicle geometry is given (the names are the export schema)
MOMENT_FACTOR_UNIT = "N per unit mixing factor (not N·m; give --vehicle)"
TRIM_PWM = 1500.0


#: specific gravities of water a vehicle dives in: fresh 1.0, sea 1.025, the saltiest lakes 1.24
SPEC_GRAV_RANGE = (0.9, 1.3)


def check_spec_grav(sg: float, name: str, key: str = "BARO_SPEC_GRAV") -> float:
    """``sg`` when it is a specific gravity of water (:data:`SPEC_GRAV_RANGE`); else a
    :class:`LogDataError` naming it (1000: a density in kg/m³; 0 or −1: every depth 0 or of the
    wrong sign)."""
    lo, hi = SPEC_GRAV_RANGE
    if not (math.isfinite(sg) and lo <= sg <= hi):
        hint = " (a density in kg/m³? the parameter is relative to fresh water: 1.0 or 1.025)" \
            if math.isfinite(sg) and 900 <= sg <= 1300 else ""
        raise LogDataError(f"{name}: {key} = {sg:g} is no water's specific gravity ({lo:g}–{hi:g}: "
                           f"fresh 1.0, sea 1.025){hint}; depth = pressure/(1000·{key}·g) would "
                           "be wrong — fix the parameter (--params)")
    return sg


class MissingFrameError(LogDataError):
    """The log holds no FRAME_CONFIG (e.g. a telemetry log recorded without the parameter
    download): the thruster layout and motor directions are unknown."""


def factor_matrix(frame: int) -> np.ndarray:
    """6 × n ArduSub mixing matrix of ``frame`` in ``[X, Y, Z, K, M, N]`` rows (see module doc)."""
    if frame not in FRAME_FACTORS:
        raise KeyError(frame)
    f = np.array(FRAME_FACTORS[frame], dtype=float)  # n × (roll, pitch, yaw, thr, fwd, lat)
    return np.vstack([f[:, 4], f[:, 5], -f[:, 3], f[:, 0], f[:, 1], f[:, 2]]) + 0.0  # no -0


@dataclass(frozen=True)
class Motor:
    """One motor as the parameters describe it."""

    number: int  # ArduSub motor number (1-based)
    output: int | None  # servo output (1-based) driving it, None if no output is assigned
    direction: float  # MOT_n_DIRECTION (+1 normal, −1 reversed)
    factors: tuple[float, ...]  # [X, Y, Z, K, M, N] mixing factors
    disabled: str = ""  # why it is ignored ("" = in use)

    def to_dict(self) -> dict:
        return {"motor": self.number, "output": self.output, "direction": self.direction,
                "factors": dict(zip(DOF_COLUMNS, self.factors)), "disabled": self.disabled or None}


@dataclass(frozen=True)
class VehicleConfig:
    """The thruster configuration derived from a log's parameters."""

    frame: int | None
    frame_name: str
    motors: tuple[Motor, ...]
    pwm_min: float
    pwm_max: float
    baro_primary: int | None  # None: the log's BARO_PRIMARY is no barometer instance
    notes: tuple[str, ...] = ()
    params_used: Mapping[str, float] = field(default_factory=dict)
    disabled_outputs: tuple[int, ...] = ()  # outputs 1…8 with no function / only 0 µs

    @property
    def active(self) -> tuple[Motor, ...]:
        return tuple(m for m in self.motors if not m.disabled)

    @property
    def F(self) -> np.ndarray:
        """6 × n mixing factors of the motors in use (columns in :attr:`active` order)."""
        return np.array([m.factors for m in self.active], dtype=float).reshape(-1, 6).T

    def summary(self) -> str:
        lines = [f"FRAME_CONFIG = {self.frame} ({self.frame_name}); MOT_PWM_MIN/MAX = "
                 f"{self.pwm_min:g}/{self.pwm_max:g} µs; BARO_PRIMARY = "
                 + (f"{self.baro_primary}" if self.baro_primary is not None else
                    f"{self.params_used.get('BARO_PRIMARY', float('nan')):g} (no barometer "
                    "instance)")]
        for m in self.motors:
            out = f"SERVO{m.output}" if m.output else "no output"
            sgn = "reversed (-1)" if m.direction < 0 else "normal (+1)"
            f = ", ".join(f"{c.split('_')[0]}{v:+g}" for c, v in zip(DOF_COLUMNS, m.factors) if v)
            lines.append(f"  motor {m.number}: {out}, {sgn}, factors {f}"
                         + (f"  [ignored: {m.disabled}]" if m.disabled else ""))
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"frame_config": self.frame, "frame": self.frame_name,
                "motors": [m.to_dict() for m in self.motors], "mot_pwm_min": self.pwm_min,
                "mot_pwm_max": self.pwm_max, "baro_primary": self.baro_primary,
                "disabled_outputs": list(self.disabled_outputs), "notes": list(self.notes),
                "params": dict(self.params_used)}


def config_from_params(params: Mapping[str, float], *, name: str = "log",
                       outputs_seen: Mapping[int, bool] | None = None,
                       custom_B: np.ndarray | None = None) -> VehicleConfig:
    """Build the :class:`VehicleConfig` from ``{PARAM: value}`` (the last value of each).

    ``custom_B``: for FRAME_CONFIG = 7 (Custom), whose factors are not in the log, the 6 × n
    thrust configuration matrix of the user's vehicle stands in for them (motor j = column j).

    ``outputs_seen``: ``{output: True if it ever carried a non-zero PWM}``; outputs that only
    ever read 0 µs are disabled (ignored, with a note) even if a motor function is assigned.
    """
    notes: list[str] = []
    used: dict[str, float] = {}

    def get(key, default=None):
        if key in params:
            used[key] = float(params[key])
            return float(params[key])
        return default

    frame = get("FRAME_CONFIG")
    if frame is None:
        raise MissingFrameError(f"{name}: the log holds no FRAME_CONFIG parameter (no PARM / "
                           "PARAM_VALUE messages with it), so its thruster layout and motor "
                           "directions are unknown; give --params (the vehicle's parameter file, "
                           "as QGroundControl or BlueOS save it)")
    frame = int(round(frame))
    frame_name = FRAME_NAMES.get(frame, f"unknown frame {frame}")
    if frame == 7 and custom_B is None:
        raise LogDataError(f"{name}: FRAME_CONFIG = 7 (Custom): the motor factors live in the "
                           "firmware build or a Lua script, not in the log; give --vehicle with "
                           "the thruster geometry (thrusters in motor order)")
    if frame not in FRAME_FACTORS and frame != 7:
        raise LogDataError(f"{name}: FRAME_CONFIG = {frame} is not an ArduSub frame this reader "
                           f"knows ({', '.join(f'{k} {v}' for k, v in FRAME_NAMES.items())})")
    pmin, pmax = get("MOT_PWM_MIN", 1100.0), get("MOT_PWM_MAX", 1900.0)
    if "MOT_PWM_MIN" not in params or "MOT_PWM_MAX" not in params:
        notes.append("MOT_PWM_MIN/MAX not in the log: ArduSub's defaults 1100/1900 µs assumed")
    for k in ("BARO_SPEC_GRAV", "GND_SPEC_GRAV"):
        if k in params:
            used["BARO_SPEC_GRAV"] = check_spec_grav(float(params[k]), name, k)
            break
    for k in (1, 2, 3):  # ground (surface) pressure each barometer was calibrated to [Pa]
        get(f"BARO{k}_GND_PRESS")
    baro = get("BARO_PRIMARY")
    if baro is None:
        notes.append("BARO_PRIMARY not in the log: barometer instance 0 assumed primary")
        baro = 0.0
    elif baro not in (0.0, 1.0, 2.0):
        # as BARO_PRIMARY = 2 on a vehicle without a third barometer: no BARO instance is read as
        # the depth sensor (ArduPilot then picks a healthy barometer itself — often instance 0,
        # the enclosure); the depth source (sources._depth) says which stands in, with a warning
        notes.append(f"BARO_PRIMARY = {baro:g} is no barometer instance (0, 1 or 2): no "
                     "barometer is taken as the depth sensor — check the parameter")
        baro = None
    # output → motor from SERVOn_FUNCTION
    motor_out: dict[int, list[int]] = {}
    for key, val in params.items():
        if key.startswith("SERVO") and key.endswith("_FUNCTION"):
            num = key[5:-9]
            if num.isdigit():
                used[key] = float(val)
                mot = MOTOR_FUNCTIONS.get(int(round(val)))
                if mot is not None:
                    motor_out.setdefault(mot, []).append(int(num))
    have_servo = any(k.startswith("SERVO") and k.endswith("_FUNCTION") for k in params)
    if not have_servo:
        notes.append("no SERVOn_FUNCTION in the log: ArduSub's default (output n = motor n) "
                     "assumed")
    if frame == 7:
        F = np.asarray(custom_B, dtype=float)
        notes.append("FRAME_CONFIG = 7 (Custom): the vehicle's thrust configuration matrix B "
                      "stands in for ArduSub's factors (motor j = thruster j)")
    else:
        F = factor_matrix(frame)
    missing_dir = [k for k in range(1, F.shape[1] + 1) if f"MOT_{k}_DIRECTION" not in params]
    if missing_dir:
        notes.append(f"MOT_n_DIRECTION not in the log for motor(s) {missing_dir}: +1 (normal) "
                     "assumed — a reversed motor would flip its thrust; give --params")
    motors = []
    for j in range(F.shape[1]):
        num = j + 1
        d = get(f"MOT_{num}_DIRECTION", 1.0)
        if d not in (1.0, -1.0):
            notes.append(f"MOT_{num}_DIRECTION = {d:g} is neither 1 nor -1; its sign is used")
            d = -1.0 if d < 0 else 1.0
        outs = sorted(motor_out.get(num, [])) if have_servo else [num]
        disabled = ""
        out = outs[0] if outs else None
        if len(outs) > 1:
            notes.append(f"motor {num} is assigned to outputs {outs}; SERVO{out} is read")
        if out is None:
            disabled = "no SERVOn_FUNCTION drives this motor"
        elif outputs_seen is not None and not outputs_seen.get(out, False):
            disabled = f"SERVO{out} output is 0 µs (disabled) throughout the log"
        motors.append(Motor(num, out, d, tuple(float(x) for x in F[:, j]), disabled))
    for mot, outs in sorted(motor_out.items()):
        if mot > F.shape[1]:
            notes.append(f"SERVO{outs[0]}_FUNCTION assigns motor {mot}, which frame "
                         f"{frame_name} does not mix (ignored)")
    assigned = {m.output for m in motors if not m.disabled}
    off = tuple(k for k in range(1, 9) if k not in assigned and (
        params.get(f"SERVO{k}_FUNCTION", 1) == 0
        or (outputs_seen is not None and not outputs_seen.get(k, False))))
    return VehicleConfig(frame, frame_name, tuple(motors), pmin, pmax,
                         None if baro is None else int(baro),
                         tuple(notes), used, off)


_MOT_DIRECTION = re.compile(r"MOT_\d+_DIRECTION")


def invalid_param(name: str, value: float, text: str | None = None) -> str:
    """Why a parameter value the user gave cannot be ArduSub's (``""`` if it can): BARO_PRIMARY
    names a barometer instance (an integer 0, 1 or 2), MOT_n_DIRECTION is -1 or 1.  A value a
    log holds is not checked here (the reader falls back and warns instead)."""
    shown = text if text is not None else f"{value:g}"
    if name == "BARO_PRIMARY" and value not in (0.0, 1.0, 2.0):
        return (f"BARO_PRIMARY = {shown} is not a barometer instance; ArduSub allows 0, 1 or 2 "
                "(the barometer depth is read from)")
    if _MOT_DIRECTION.fullmatch(name) and value not in (1.0, -1.0):
        return (f"{name} = {shown} is not a motor direction; ArduSub allows 1 (normal) or -1 "
                "(reversed)")
    return ""


def check_given_params(params: Mapping[str, float], where: str) -> None:
    """Raise :class:`LogDataError` for a given (not logged) parameter ArduSub would not accept
    (see :func:`invalid_param`)."""
    for k, v in params.items():
        bad = invalid_param(k, float(v))
        if bad:
            raise LogDataError(f"{where}: {bad}")


def read_param_file(path) -> dict[str, float]:
    """A parameter file as QGroundControl (``sys comp NAME value type``, tab separated),
    Mission Planner / MAVProxy (``NAME,value`` or ``NAME value``) or BlueOS save it."""
    from pathlib import Path

    p = Path(path)
    try:
        lines = p.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as e:
        raise LogDataError(f"{p}: cannot read the parameter file: {e.strerror or e}") from None
    out: dict[str, float] = {}
    for i, line in enumerate(lines, 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        f = line.replace(",", " ").split()
        if len(f) >= 4 and f[0].isdigit() and f[1].isdigit():
            f = f[2:]
        try:
            out[f[0]] = float(f[1])
        except (IndexError, ValueError):
            raise LogDataError(f"{p.name}: line {i}: expected 'NAME value' (or QGroundControl's "
                               f"'sys comp NAME value type'), got {line!r}") from None
        bad = invalid_param(f[0], out[f[0]], f[1])
        if bad:
            raise LogDataError(f"{p.name}: line {i}: {bad}")
    if not out:
        raise LogDataError(f"{p.name}: no parameters in the file")
    return out


def effective_pwm(pwm: np.ndarray, direction: float) -> np.ndarray:
    """PWM as the thruster sees it along its mixing direction: reflected about the trim when
    ``MOT_n_DIRECTION = −1`` (``1500 + d (pwm − 1500)``, AP_Motors6DOF)."""
    return TRIM_PWM + direction * (np.asarray(pwm, dtype=float) - TRIM_PWM)


def check_vehicle(config: VehicleConfig, vehicle, *, name: str = "log") -> None:
    """Raise if a uuvid vehicle cannot be the log's vehicle: its thrusters (in order) must be the
    motors in use, and each thruster's B column must push the way ArduSub's factors say."""
    act = config.active
    B = np.asarray(vehicle.B, dtype=float)
    if B.shape[1] != len(act):
        names = ", ".join(f"motor {m.number} (SERVO{m.output})" for m in act)
        raise LogDataError(f"{name}: vehicle {vehicle.name!r} has {B.shape[1]} thrusters but the "
                           f"log's FRAME_CONFIG = {config.frame} ({config.frame_name}) drives "
                           f"{len(act)} motors: {names}"
                           + ("; ignored: " + "; ".join(f"motor {m.number}: {m.disabled}"
                                                        for m in config.motors if m.disabled)
                              if any(m.disabled for m in config.motors) else "")
                           + (f"; outputs {', '.join(f'SERVO{k}' for k in config.disabled_outputs)}"
                              " drive no motor (SERVOn_FUNCTION = 0 or 0 µs): their 0 µs is no "
                              "command, not full reverse" if config.disabled_outputs else ""))
    bad = []
    for j, m in enumerate(act):
        col = B[:, j]
        scale = np.max(np.abs(col)) or 1.0
        for k, dof in enumerate(DOF_COLUMNS):
            f = m.factors[k]
            if f and (abs(col[k]) < 1e-6 * scale or np.sign(col[k]) != np.sign(f)):
                th = vehicle.layout[j].name
                bad.append(f"thruster {j + 1} ({th}) as motor {m.number}: "
                           f"{dof.split('_')[0]} {col[k]:+.3g} where ArduSub's factor is {f:+g}")
    if bad:
        raise LogDataError(f"{name}: vehicle {vehicle.name!r} does not match the log's "
                           f"FRAME_CONFIG = {config.frame} ({config.frame_name}) layout (thruster "
                           "j must be motor j, pushing along ArduSub's mixing direction): "
                           + "; ".join(bad[:6]) + (f"; … {len(bad) - 6} more" if len(bad) > 6
                                                   else ""))
