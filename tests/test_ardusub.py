"""ArduSub logs read right (uuvid.io.ardusub): synthetic .BIN/.tlog files that reproduce each trap
real BlueROV2 logs set, written with pymavlink's encoder (tlog) or by hand in the dataflash
format pymavlink parses (.BIN), and the three shared real logs (realdata).

The synthetic dive drives the thrusters the way ArduSub does (AP_Motors6DOF): per motor
``mix = Σ factor × demand``, ``pwm = 1500 + 400 · d · mix`` with the per-motor reversal ``d``
(MOT_n_DIRECTION), and the truth thrust of a motor along its mixing direction is the T200's at
``1500 + 400 · mix`` and the logged battery voltage.  A 1-DOF heave and yaw model is driven by it.
"""

from __future__ import annotations

import json
import math
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pymavlink")

from uuvid.io.ardusub import FRAME_NAMES, inspect_log, load_dive  # noqa: E402
from uuvid.io.ardusub.thrust import default_t200  # noqa: E402
from uuvid.io.logs import LogDataError  # noqa: E402

# ArduSub's Vectored frame (FRAME_CONFIG 1), AP_Motors6DOF::setup_motors, per motor:
# (roll, pitch, yaw, throttle, forward, lateral)
VECTORED = [(0, 0, 1, 0, -1, 1), (0, 0, -1, 0, -1, -1), (0, 0, -1, 0, 1, 1), (0, 0, 1, 0, 1, -1),
            (1, 0, 0, -1, 0, 0), (-1, 0, 0, -1, 0, 0)]
DIRECTIONS = [-1, -1, 1, -1, -1, 1]  # as on real BlueROV2s
UNIX0 = 1.7e9
BOOT0 = 120.0


# =========================================================================== the synthetic dive
def scenario(n=700, dt=0.1, seed=1):
    """Heave and yaw demands, PWM as ArduSub writes it, and the vehicle's response."""
    rng = np.random.default_rng(seed)
    t = dt * np.arange(n)
    heave = 0.45 * np.sin(2 * np.pi * t / 23.0) + 0.1 * np.sin(2 * np.pi * t / 7.0)  # + = up
    yaw = 0.35 * np.sign(np.sin(2 * np.pi * t / 17.0)) * (t > 5)
    volts = 16.4 - 0.003 * t + 0.02 * rng.standard_normal(n)
    f = np.array(VECTORED, float)
    mix = np.outer(heave, f[:, 3]) + np.outer(yaw, f[:, 2])  # n × motors
    d = np.array(DIRECTIONS, float)
    pwm = np.round(1500 + 400 * np.clip(d * mix, -1, 1))
    t200 = default_t200()
    T = np.column_stack([t200.thrust(1500 + d[i] * (pwm[:, i] - 1500), volts)
                         for i in range(6)])  # truth thrust along each mixing direction
    Z = T @ -f[:, 3]  # NED heave force (down +)
    N = T @ f[:, 2]
    w = np.zeros(n)
    r = np.zeros(n)
    depth = np.zeros(n)
    psi = np.zeros(n)
    depth[0] = 2.0
    for k in range(1, n):  # 1-DOF models, explicit Euler at dt (test generator only)
        w[k] = w[k - 1] + dt * (Z[k - 1] - 40 * w[k - 1] * abs(w[k - 1]) - 8 * w[k - 1]) / 35.0
        r[k] = r[k - 1] + dt * (0.18 * N[k - 1] - 1.5 * r[k - 1] * abs(r[k - 1]) - 0.3 * r[k - 1]) / 0.6
        depth[k] = depth[k - 1] + dt * w[k - 1]
        psi[k] = psi[k - 1] + dt * r[k - 1]
    psi += math.radians(170.0)
    armed = t >= 2.0
    mode = np.where((t >= 40) & (t < 46), 2, 19)  # ALT_HOLD stretch
    pwm[~armed] = 1500
    return dict(t=t, pwm=pwm, volts=volts, depth=depth, psi=psi, armed=armed, mode=mode, Z=Z, N=N,
                T=T)


def params(frame=1, disabled=(7, 8), directions=DIRECTIONS, baro_primary=1):
    p = {"FRAME_CONFIG": frame, "BARO_PRIMARY": baro_primary, "MOT_PWM_MIN": 1100,
         "MOT_PWM_MAX": 1900, "SYSID_THISMAV": 1}
    n = 8 if frame == 2 else 6
    for k in range(1, 17):
        p[f"SERVO{k}_FUNCTION"] = 33 + k - 1 if k <= n and k not in disabled else 0
    for k in range(1, 13):
        p[f"MOT_{k}_DIRECTION"] = directions[k - 1] if k <= len(directions) else 1
    return p


# ------------------------------------------------------------------------------ dataflash
_ST = {"Q": "Q", "c": "h", "C": "H", "f": "f", "B": "B", "H": "H", "N": "16s", "n": "4s",
       "Z": "64s"}


class _DF:
    def __init__(self, omit=()):
        self.omit = set(omit)
        self.types = {"FMT": 128}
        self.forms = {}
        self.out = [self._fmt(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns")]

    def _fmt(self, tid, name, form, cols):
        self.types[name] = tid
        self.forms[name] = form
        length = 3 + struct.calcsize("<" + "".join(_ST[c] for c in form))
        return bytes([0xA3, 0x95, 128]) + struct.pack("<BB4s16s64s", tid, length, name.encode(),
                                                      form.encode(), cols.encode())

    def fmt(self, tid, name, form, cols):
        self.out.append(self._fmt(tid, name, form, cols))

    def msg(self, name, *vals):
        if name in self.omit:
            return
        form = self.forms[name]
        self.out.append(bytes([0xA3, 0x95, self.types[name]]) + struct.pack(
            "<" + "".join(_ST[c] for c in form),
            *[v.encode() if isinstance(v, str) else v for v in vals]))

    def write(self, path):
        path.write_bytes(b"".join(self.out))
        return path


def write_bin(path: Path, sc, *, prm=None, reboot_at=None, omit=()) -> Path:
    """Dataflash log of the scenario: PARM, ATT (centi-deg, yaw 0…360), two BAROs (instance 0 in
    the enclosure, 1 the water-pressure sensor), BAT, RCOU (outputs 7/8 at 0 µs), MODE, ARM."""
    df = _DF(omit)
    df.fmt(20, "PARM", "QNf", "TimeUS,Name,Value")
    df.fmt(21, "ATT", "QccC", "TimeUS,Roll,Pitch,Yaw")
    df.fmt(22, "BARO", "QBff", "TimeUS,I,Alt,Press")
    df.fmt(23, "BAT", "QBf", "TimeUS,Instance,Volt")
    df.fmt(24, "RCOU", "QHHHHHHHH", "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8")
    df.fmt(25, "MODE", "QBBB", "TimeUS,Mode,ModeNum,Rsn")
    df.fmt(26, "ARM", "QB", "TimeUS,ArmState")
    for k, v in (prm or params()).items():
        df.msg("PARM", int(BOOT0 * 1e6) - 1000, k, float(v))
    t, boot_shift = sc["t"], 0.0
    last_mode, last_arm = None, None
    for k in range(t.size):
        if reboot_at is not None and k == reboot_at:
            boot_shift = -t[k] + 3.0 - BOOT0  # the clock restarts 3 s after boot
            last_mode, last_arm = None, None
            for name, v in (prm or params()).items():
                df.msg("PARM", int(2.5e6), name, float(v))
        us = int(round((BOOT0 + t[k] + boot_shift) * 1e6))
        if sc["mode"][k] != last_mode:
            df.msg("MODE", us, int(sc["mode"][k]), int(sc["mode"][k]), 1)
            last_mode = sc["mode"][k]
        if sc["armed"][k] != last_arm:
            if last_arm is not None:
                df.msg("ARM", us, int(sc["armed"][k]))
            elif not sc["armed"][k]:
                pass
            last_arm = sc["armed"][k]
        yaw_deg = math.degrees(sc["psi"][k]) % 360.0
        df.msg("ATT", us + 100, 0, 0, int(round(yaw_deg * 100)) % 36000)
        df.msg("BARO", us + 200, 0, -9.2 + 0.01 * t[k], 99000.0)
        df.msg("BARO", us + 200, 1, -sc["depth"][k], 101325.0 + 9806.65 * sc["depth"][k])
        df.msg("BAT", us + 300, 0, float(sc["volts"][k]))
        df.msg("RCOU", us + 400, *[int(x) for x in sc["pwm"][k]], 0, 0)
    return df.write(path)


# ------------------------------------------------------------------------------ telemetry
def write_tlog(path: Path, sc, *, prm=None, qgc_stamps=True, companion=True, reboot_at=None,
               vfr_alt=0.0, with_params=True, gpi=True, pressure=False, ekf_swing=0.0,
               servo_every=1, servo_until=math.inf) -> Path:
    """Telemetry log of the scenario as QGroundControl saves it: receive stamps quantised to
    50 ms batches (many exact duplicates) and one message saved twice; VFR_HUD.alt = 0 (no EKF
    origin); a BlueOS companion (component 194) with its own boot clock 1130 s ahead sending a
    bogus ATTITUDE and DISTANCE_SENSOR; optionally an autopilot reboot.  SERVO_OUTPUT_RAW on
    every ``servo_every``-th sample (a BlueROV2 streams it at 2 Hz) up to ``servo_until`` s."""
    from pymavlink import mavutil
    from pymavlink.dialects.v20 import ardupilotmega as mv

    path.touch()
    log = mavutil.mavlink_connection(str(path), write=True)
    ap = mv.MAVLink(None, srcSystem=1, srcComponent=1)
    blueos = mv.MAVLink(None, srcSystem=1, srcComponent=194)
    gcs = mv.MAVLink(None, srcSystem=255, srcComponent=190)

    def put(mav, t_unix, msg):
        if qgc_stamps:
            t_unix = math.floor(t_unix / 0.05) * 0.05
        log.write(struct.pack(">Q", int(round(t_unix * 1e6))) + msg.pack(mav))

    boot_base = BOOT0
    put(gcs, UNIX0 - 1.0, gcs.heartbeat_encode(6, 8, 192, 0, 4))
    prm = (prm or params()) if with_params else {}
    for i, (k, v) in enumerate(prm.items()):
        put(ap, UNIX0 - 0.5 + 0.001 * i, ap.param_value_encode(k.encode(), float(v), 9, len(prm), i))
    if companion:  # a companion's own parameter of the same name is not the vehicle's
        put(blueos, UNIX0 - 0.2, blueos.param_value_encode(b"FRAME_CONFIG", 0.0, 9, 1, 0))
    t = sc["t"]
    for k in range(t.size):
        if reboot_at is not None and k == reboot_at:
            boot_base = 3.0 - t[k]  # autopilot clock restarts: 3 s after boot at this sample
        boot = boot_base + t[k]
        tu = UNIX0 + t[k]
        ms = int(round(boot * 1000))
        lat = 0.012 + 0.008 * (k % 3)
        if k % 10 == 0:
            base = 81 | (128 if sc["armed"][k] else 0)
            put(ap, tu + lat, ap.heartbeat_encode(12, 3, base, int(sc["mode"][k]), 4))
            if companion:
                put(blueos, tu + 0.02, blueos.heartbeat_encode(18, 8, 128, 0, 3))
                put(blueos, tu + 0.021, blueos.distance_sensor_encode(
                    int((t[k] + 1130.0) * 1000), 20, 5000, 300, 0, 1, 25, 0))
        psi = (sc["psi"][k] + np.pi) % (2 * np.pi) - np.pi
        att = ap.attitude_encode(ms, 0.0, 0.0, float(psi), 0, 0, 0)
        put(ap, tu + lat, att)
        if k == 50:
            put(ap, tu + lat, att)  # the same message saved twice
        if gpi:  # the EKF's altitude, swinging by ekf_swing [m] as on deck
            ekf = sc["depth"][k] + ekf_swing * math.sin(2 * math.pi * t[k] / 9.0)
            put(ap, tu + lat + 0.001, ap.global_position_int_encode(
                ms, 0, 0, 0, int(round(-ekf * 1000)), 0, 0, 0, 0))
        if not gpi or pressure:  # the barometers: instance 0 in the enclosure, 1 in the water
            put(ap, tu + lat + 0.001, ap.scaled_pressure_encode(ms, 980.0, 0, 3000))
            put(ap, tu + lat + 0.001, ap.scaled_pressure2_encode(
                ms, 1000.0 + 98.0665 * sc["depth"][k], 0, 1500))
        put(ap, tu + lat + 0.002, ap.vfr_hud_encode(0, 0, 0, 0, vfr_alt, 0))
        put(ap, tu + lat + 0.003, ap.sys_status_encode(0, 0, 0, 0, int(round(sc["volts"][k] * 1000)),
                                                       0, -1, 0, 0, 0, 0, 0, 0))
        pw = [int(x) for x in sc["pwm"][k]] + [0, 0]
        if k % servo_every == 0 and t[k] <= servo_until:
            put(ap, tu + lat + 0.004, ap.servo_output_raw_encode(
                int(round(boot * 1e6)) % 2**32, 0, *pw))
        if companion:
            put(blueos, tu + 0.03, blueos.attitude_encode(int((t[k] + 1130.0) * 1000), 1.0, 1.0,
                                                          3.0, 0, 0, 0))
    log.close()
    return path


# ============================================================================= configuration
@pytest.mark.slow
def test_config_vectored_factors_directions_and_disabled_outputs(tmp_path):
    sc = scenario(n=80)
    ins = inspect_log(write_bin(tmp_path / "d.BIN", sc))
    c = ins.config
    assert c.frame == 1 and [m.number for m in c.active] == [1, 2, 3, 4, 5, 6]
    assert [m.direction for m in c.active] == DIRECTIONS
    assert [m.output for m in c.active] == [1, 2, 3, 4, 5, 6]
    # ArduSub factors restated: motor 1 forward -1, lateral +1, yaw +1; motor 5 throttle -1 (Z +1)
    assert c.motors[0].factors == (-1.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    assert c.motors[4].factors == (0.0, 0.0, 1.0, 1.0, 0.0, 0.0)
    s = ins.summary()
    assert "FRAME_CONFIG = 1" in s and "motor 1: SERVO1, reversed (-1)" in s
    assert "-BARO[1].Alt" in s


def test_servo_function_remaps_outputs_and_zero_outputs_are_ignored():
    prm = params(frame=2, disabled=())
    prm["SERVO8_FUNCTION"] = 0  # motor 8 has no output
    prm["SERVO9_FUNCTION"] = 39  # motor 7 moved to output 9
    prm["SERVO7_FUNCTION"] = 0
    from uuvid.io.ardusub.frames import config_from_params

    c = config_from_params(prm, outputs_seen={k: k <= 9 for k in range(1, 17)})
    assert {m.number: m.output for m in c.active} == {1: 1, 2: 2, 3: 3, 4: 4, 5: 5, 6: 6, 7: 9}
    assert "no SERVOn_FUNCTION" in c.motors[7].disabled
    c2 = config_from_params(params(frame=2, disabled=()),
                            outputs_seen={k: k <= 6 for k in range(1, 17)})
    assert [m.number for m in c2.active] == [1, 2, 3, 4, 5, 6]
    assert "0 µs" in c2.motors[6].disabled


def test_wrong_vehicle_is_an_error_naming_the_difference(tmp_path):
    p = write_bin(tmp_path / "d.BIN", scenario(n=60))
    with pytest.raises(LogDataError, match=r"8 thrusters.*drives 6 motors.*outputs SERVO7, SERVO8 drive no motor"):
        load_dive(p, vehicle="bluerov2-heavy")
    d = load_dive(p, vehicle="bluerov2")  # the 6-thruster BlueROV2 matches the Vectored frame
    assert d.vehicle == "bluerov2" and "physical wrench" in d.force_basis
    from uuvid.vehicle.definition import load_vehicle

    T = d.table[[f"thrust_{i}_N" for i in range(1, 7)]].to_numpy()
    W = T @ load_vehicle("bluerov2").B.T
    np.testing.assert_allclose(d.table[["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]], W)
    # the mixing-factor force stays available beside the physical wrench
    np.testing.assert_allclose(d.factor_forces["Z_N"], T @ -np.array(VECTORED, float)[:, 3])


def test_export_without_a_vehicle_says_the_forces_are_mixing_sums(tmp_path):
    p = write_bin(tmp_path / "d.BIN", scenario(n=60))
    d = load_dive(p)
    (w,) = [w for w in d.warnings if w.startswith("no vehicle given")]
    assert "mixing-frame sums" in w and "--vehicle" in w and "not N·m" in w
    assert f"warning: {w}" in d.summary()
    assert not any(w.startswith("no vehicle given") for w in load_dive(p, vehicle="bluerov2").warnings)


@pytest.mark.slow
def test_thruster_model_file_with_an_esc_follows_the_logged_voltage(tmp_path):
    # was: voltage_aware False, thrust at the file's fixed 12 V whatever the battery said
    from uuvid.thruster.modelfile import save_chain
    from uuvid.thruster.presets import laidani_chain
    from uuvid.thruster.resolve import at_supply

    model = save_chain(laidani_chain(), tmp_path / "mine.yaml")
    d = load_dive(write_bin(tmp_path / "d.BIN", scenario(n=120)), thruster_model=model)
    assert d.thrust_model["voltage_aware"] is True
    assert "logged battery voltage" in d.thrust_model["voltage"]
    pwm = 1500 + DIRECTIONS[0] * (d.table["pwm_1"].to_numpy() - 1500)
    volts = np.round(d.table["battery_V"].to_numpy() / 0.05) * 0.05
    want = [float(at_supply(laidani_chain(), v).steady_thrust(np.array([u]))[0])
            for u, v in zip(np.round(pwm), volts)]
    np.testing.assert_allclose(d.table["thrust_1_N"], want, rtol=1e-9)
    # the battery (~16.4 V) is not the chain's 12 V: a fixed-voltage chain would differ
    fixed = laidani_chain().steady_thrust(pwm)
    assert np.max(np.abs(d.table["thrust_1_N"] - fixed)) > 0.1 * np.max(np.abs(fixed))


@pytest.mark.slow
def test_physical_chain_file_matches_the_voltage_aware_default(tmp_path):
    """A chain of the shipped physical T200 fit written at 12 V gives, at the logged voltage,
    the thrust of the voltage-aware default (the same model)."""
    from uuvid.io.ardusub.thrust import load_thrust_model
    from uuvid.thruster.modelfile import save_chain
    from uuvid.thruster.physical import physical_model

    f = save_chain(physical_model().to_chain(12.0), tmp_path / "t200-12V.yaml")
    tm, ref = load_thrust_model(f), default_t200()
    pwm, volts = np.array([1300.0, 1723.0, 1723.0]), np.array([16.2, 16.2, 12.0])
    np.testing.assert_allclose(tm.thrust(pwm, volts), ref.thrust(pwm, volts), rtol=1e-6)


@pytest.mark.slow
def test_thruster_model_without_esc_cannot_follow_voltage_and_says_so(tmp_path):
    from uuvid.thruster.blocks import TableMap
    from uuvid.thruster.chain import ThrusterChain
    from uuvid.thruster.modelfile import save_chain

    chain = ThrusterChain((TableMap(input_values=(1100.0, 1500.0, 1900.0),
                                    output_values=(-30.0, 0.0, 40.0)),), "command", "table")
    model = save_chain(chain, tmp_path / "table.yaml")
    d = load_dive(write_bin(tmp_path / "d.BIN", scenario(n=120)), thruster_model=model)
    assert d.thrust_model["voltage_aware"] is False
    assert any("cannot follow the battery voltage" in w for w in d.warnings)


@pytest.mark.parametrize("name", ["t200", "laidani-a2212", "t200-physical"])
def test_thruster_model_accepts_preset_names(tmp_path, name):
    from uuvid.io.ardusub.thrust import load_thrust_model
    from uuvid.thruster.resolve import resolve_chain

    tm = load_thrust_model(name)
    assert tm.voltage_aware
    if name != "t200-physical":
        np.testing.assert_allclose(tm.thrust(np.array([1700.0]), np.array([16.0])),
                                   resolve_chain(name, supply_voltage=16.0).steady_thrust(
                                       np.array([1700.0])))
    with pytest.raises(LogDataError, match="not a preset"):
        load_thrust_model("no-such-thruster")


def test_a_vehicle_file_as_the_thruster_model_is_said_once_to_be_not_one():
    """``--thruster-model bluerov2.yaml`` said 'not a thruster model file' and then listed the
    model schema's errors for every vehicle key; now it says what the file looks like, once."""
    from uuvid.io.ardusub.thrust import load_thrust_model
    from uuvid.vehicle.definition import preset_path

    with pytest.raises(LogDataError) as e:
        load_thrust_model(preset_path("bluerov2"))
    said = str(e.value)
    assert said.count("not a thruster model file") == 1 and "unknown key" not in said
    assert "it looks like a vehicle file (it has rigid_body, hydrodynamics, thrusters)" in said


def test_custom_frame_needs_the_vehicle_geometry(tmp_path):
    prm = {**params(), "FRAME_CONFIG": 7}
    p = write_bin(tmp_path / "d.BIN", scenario(n=60), prm=prm)
    with pytest.raises(LogDataError, match="Custom.*give --vehicle"):
        load_dive(p)
    d = load_dive(p, vehicle="bluerov2")
    assert any("Custom" in n for n in d.config.notes)
    assert np.allclose(d.factor_forces.to_numpy(), d.table[list(d.factor_forces.columns)])


def test_layout_mismatch_names_thruster_and_dof(tmp_path):
    import yaml

    from uuvid.vehicle.definition import load_vehicle, preset_path, vehicle_from_dict

    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    raw["thrusters"][4]["axis"] = [0.0, 0.0, -1.0]  # T5 pushing up: not ArduSub's motor 5
    v = vehicle_from_dict(raw, "mine.yaml", preset_path("bluerov2").parent)
    assert load_vehicle("bluerov2").B.shape == v.B.shape
    with pytest.raises(LogDataError, match=r"thruster 5 .* as motor 5: Z -1"):
        load_dive(write_bin(tmp_path / "d.BIN", scenario(n=60)), vehicle=v)


# ============================================================================ dataflash traps
def test_bin_depth_from_baro_primary_not_the_enclosure_sensor(tmp_path):
    sc = scenario(n=200)
    d = load_dive(write_bin(tmp_path / "d.BIN", sc))
    assert d.depth_source["source"] == "-BARO[1].Alt"
    t = d.table["t_s"].to_numpy() + d.provenance["t_s"]["t0_boot_s"] - BOOT0
    truth = np.interp(t, sc["t"] + 200e-6, sc["depth"])
    np.testing.assert_allclose(d.table["depth_m"], truth, atol=1e-4)
    # instance 0 (the enclosure) would read 9 m off
    assert abs(d.table["depth_m"].mean() - (9.2 - 0.01 * t.mean())) > 1.0


@pytest.mark.slow
def test_bin_yaw_unwrapped_through_360(tmp_path):
    sc = scenario(n=500)
    d = load_dive(write_bin(tmp_path / "d.BIN", sc))
    yaw = d.table["yaw_rad"].to_numpy()
    assert np.max(np.abs(np.diff(yaw))) < 1.0  # no 2π jumps
    assert np.ptp(np.degrees(sc["psi"]) % 360) > 300  # the raw ATT.Yaw did wrap


def test_generalized_force_is_factors_times_direction_times_thrust(tmp_path):
    """Hand computation: Z = Σ −throttle_i · T200(1500 + d_i (pwm_i − 1500), V), N = Σ yaw_i T."""
    sc = scenario(n=300)
    d = load_dive(write_bin(tmp_path / "d.BIN", sc))
    tb = d.table
    t200 = default_t200()
    V = tb["battery_V"].to_numpy()
    T = np.column_stack([t200.thrust(1500 + DIRECTIONS[i] * (tb[f"pwm_{i + 1}"] - 1500), V)
                         for i in range(6)])
    f = np.array(VECTORED, float)
    np.testing.assert_allclose(tb[[f"thrust_{i}_N" for i in range(1, 7)]].to_numpy(), T)
    np.testing.assert_allclose(tb["Z_N"], T @ -f[:, 3], atol=1e-9)
    np.testing.assert_allclose(tb["N_Nm"], T @ f[:, 2], atol=1e-9)
    np.testing.assert_allclose(tb["X_N"], T @ f[:, 4], atol=1e-9)
    np.testing.assert_allclose(tb["K_Nm"], T @ f[:, 0], atol=1e-9)
    # ignoring MOT_n_DIRECTION would cancel the vertical pair: the heave force differs
    T_wrong = np.column_stack([t200.thrust(tb[f"pwm_{i + 1}"], V) for i in range(6)])
    assert np.max(np.abs(T_wrong @ -f[:, 3] - tb["Z_N"])) > 20.0


def _rate(t, x):
    from scipy.signal import savgol_filter

    return savgol_filter(x, 11, 2, deriv=1, delta=float(np.median(np.diff(t))))


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["BIN", "tlog"])
def test_physics_heave_force_and_depth_rate_correlate_yaw_signs_agree(tmp_path, fmt):
    sc = scenario()
    p = (write_bin(tmp_path / "d.BIN", sc) if fmt == "BIN" else
         write_tlog(tmp_path / "d.tlog", sc, qgc_stamps=False))
    tb = load_dive(p).table
    t = tb["t_s"].to_numpy()
    m = tb["armed"].fillna(False).to_numpy(bool)
    wz = _rate(t, tb["depth_m"].to_numpy())
    r = _rate(t, tb["yaw_rad"].to_numpy())
    assert np.corrcoef(tb["Z_N"][m], wz[m])[0, 1] >= 0.85
    driven = m & (np.abs(tb["N_Nm"].to_numpy()) > 0.5 * np.abs(tb["N_Nm"]).max())
    # a driven turn: the rate follows the torque after the yaw transient (~1 s)
    settled = driven & np.concatenate(([False] * 15, driven[:-15]))
    assert np.mean(np.sign(tb["N_Nm"][settled]) == np.sign(r[settled])) > 0.95


@pytest.mark.slow
def test_bin_modes_arming_and_open_loop(tmp_path):
    d = load_dive(write_bin(tmp_path / "d.BIN", scenario(n=600)))
    modes = [(s["mode"], s["armed"]) for s in d.modes]
    assert modes == [("MANUAL", False), ("MANUAL", True), ("ALT_HOLD", True), ("MANUAL", True)]
    mask, why = d.open_loop()
    assert not mask[d.table["mode"] == "ALT_HOLD"].any()
    assert mask.sum() == np.count_nonzero((d.table["mode"] == "MANUAL") & d.table["armed"])
    assert "ALT_HOLD" in why and "disarmed" in why


def test_bin_reboot_splits_into_parts(tmp_path):
    sc = scenario(n=300)
    sc["mode"][150:] = 2  # the second boot logs its MODE before its first ATT
    d = load_dive(write_bin(tmp_path / "d.BIN", sc, reboot_at=150))
    assert set(d.table["part"]) == {0, 1}
    assert np.all(np.diff(d.table["t_s"]) > 0)
    assert any("rebooted" in w for w in d.warnings)
    part = d.table["part"].to_numpy()
    assert set(d.table["mode"][part == 1]) == {"ALT_HOLD"}
    assert set(d.table["mode"][part == 0]) == {"MANUAL"}


def test_bin_missing_messages_and_repeated_parameters(tmp_path):
    sc = scenario(n=120)
    prm = params()
    p = write_bin(tmp_path / "d.BIN", sc, prm=prm, omit=("BAT", "MODE", "ARM"))
    d = load_dive(p)
    assert set(d.table["mode"]) == {"UNKNOWN"} and d.table["armed"].isna().all()
    assert any("no battery voltage" in w for w in d.warnings)
    assert any("16 V" in w for w in d.warnings)
    assert d.provenance["thrust_3_N"]["source"].endswith("at the nominal 16 V (no voltage logged)")
    np.testing.assert_allclose(
        d.table["thrust_3_N"], default_t200().thrust(d.table["pwm_3"], np.full(len(d.table), 16.0)))
    # a parameter written again with another value after the last sample (t = 50 s, the log
    # ends at 12 s): the value in force over the rows is used, and the change is said
    p2 = write_bin(tmp_path / "e.BIN", sc, prm={**prm, "MOT_3_DIRECTION": -1.0})
    raw = p2.read_bytes()
    extra = _DF()
    extra.fmt(20, "PARM", "QNf", "TimeUS,Name,Value")
    extra.msg("PARM", int((BOOT0 + 50) * 1e6), "MOT_3_DIRECTION", 1.0)
    p2.write_bytes(raw + b"".join(extra.out[2:]))
    d2 = load_dive(p2)
    assert d2.config.motors[2].direction == -1.0
    assert any("MOT_3_DIRECTION changed" in w and "outside this table" in w for w in d2.warnings)


# ============================================================================ telemetry traps
@pytest.mark.slow
def test_tlog_depth_from_relative_alt_when_vfr_hud_alt_is_zero(tmp_path):
    sc = scenario(n=300)
    d = load_dive(write_tlog(tmp_path / "d.tlog", sc))
    assert d.depth_source["source"] == "-GLOBAL_POSITION_INT.relative_alt"
    assert "VFR_HUD.alt is constant" in d.depth_source["why"]
    t = d.table["t_s"].to_numpy() + d.provenance["t_s"]["t0_boot_s"] - BOOT0
    np.testing.assert_allclose(d.table["depth_m"], np.interp(t, sc["t"], sc["depth"]), atol=1e-3)


@pytest.mark.slow
def test_tlog_depth_from_the_water_pressure_sensor_by_default(tmp_path):
    """As in a .BIN: BARO_PRIMARY's pressure relative to its ground pressure, not the EKF's
    relative_alt (which swings ±0.3 m here); the source is named in the provenance."""
    sc = scenario(n=300)
    prm = {**params(), "BARO2_GND_PRESS": 100000.0}  # 1000 hPa at the surface
    d = load_dive(write_tlog(tmp_path / "d.tlog", sc, prm=prm, pressure=True, ekf_swing=0.3))
    assert d.depth_source["message"] == "SCALED_PRESSURE2"
    assert "BARO_PRIMARY" in d.depth_source["why"] and "BARO2_GND_PRESS" in d.depth_source["why"]
    assert d.provenance["depth_m"]["source"] == "SCALED_PRESSURE2.press_abs − BARO2_GND_PRESS"
    assert not any("lowest pressure" in w for w in d.warnings)
    t = d.table["t_s"].to_numpy() + d.provenance["t_s"]["t0_boot_s"] - BOOT0
    np.testing.assert_allclose(d.table["depth_m"], np.interp(t, sc["t"], sc["depth"]), atol=2e-3)
    out = d.export(tmp_path / "o.csv")
    side = json.loads(out.with_name("o.csv.json").read_text())
    assert side["depth_source"]["message"] == "SCALED_PRESSURE2"
    assert "depth: SCALED_PRESSURE2.press_abs" in d.summary()
    # without BARO_PRIMARY the log does not say which sensor is in the water: the EKF's altitude
    prm.pop("BARO_PRIMARY")
    d2 = load_dive(write_tlog(tmp_path / "e.tlog", sc, prm=prm, pressure=True, ekf_swing=0.3))
    assert d2.depth_source["source"] == "-GLOBAL_POSITION_INT.relative_alt"


@pytest.mark.slow
def test_tlog_depth_from_primary_pressure_when_no_position_message(tmp_path):
    sc = scenario(n=300)
    d = load_dive(write_tlog(tmp_path / "d.tlog", sc, gpi=False))
    assert d.depth_source["message"] == "SCALED_PRESSURE2"
    assert any("lowest pressure" in w for w in d.warnings)
    t = d.table["t_s"].to_numpy() + d.provenance["t_s"]["t0_boot_s"] - BOOT0
    truth = np.interp(t, sc["t"], sc["depth"]) - sc["depth"].min()
    np.testing.assert_allclose(d.table["depth_m"], truth, atol=2e-3)


@pytest.mark.slow
def test_tlog_companion_clock_is_not_the_autopilot_clock(tmp_path):
    sc = scenario(n=300)
    p = write_tlog(tmp_path / "d.tlog", sc)
    ins = inspect_log(p)
    blueos = next(s for s in ins.senders if s["component"] == 194)
    assert blueos["clock_offset_s"] == pytest.approx(1130.0 - BOOT0, abs=0.1)
    assert any("component 194" in w and "own boot clock" in w for w in ins.warnings)
    d = load_dive(p)
    # the companion's bogus ATTITUDE (yaw 3.0, roll 1.0) is not read as the vehicle's
    assert np.all(np.abs(d.table["roll_rad"]) < 1e-6)
    assert d.provenance["t_s"]["t0_boot_s"] == pytest.approx(BOOT0, abs=0.2)


def test_tlog_qgc_duplicated_stamps_are_merged_and_reported(tmp_path):
    d = load_dive(write_tlog(tmp_path / "d.tlog", scenario(n=300), qgc_stamps=True))
    assert any("duplicated time stamps" in w and "ATTITUDE.yaw: 1" in w for w in d.warnings)
    assert d.table["t_s"].is_monotonic_increasing


@pytest.mark.slow
def test_tlog_reboot_splits_into_parts(tmp_path):
    sc = scenario(n=400)
    d = load_dive(write_tlog(tmp_path / "d.tlog", sc, reboot_at=200))
    assert set(d.table["part"]) == {0, 1}
    t = d.table["t_s"].to_numpy()
    assert np.all(np.diff(t) > 0)
    # parts joined by the receive clock: the second part starts where it was received
    first1 = t[d.table["part"].to_numpy() == 1][0]
    assert first1 == pytest.approx(sc["t"][200], abs=0.15)
    assert inspect_log(write_tlog(tmp_path / "e.tlog", sc, reboot_at=200)).parts == 2


@pytest.mark.slow
def test_tlog_without_parameters_needs_a_parameter_file(tmp_path):
    sc = scenario(n=100)
    p = write_tlog(tmp_path / "d.tlog", sc, with_params=False)
    with pytest.raises(LogDataError, match="no FRAME_CONFIG.*give --params"):
        load_dive(p)
    qgc = "# Onboard parameters for Vehicle 1\n" + "".join(
        f"1\t1\t{k}\t{v}\t9\n" for k, v in params().items())
    (tmp_path / "v.params").write_text(qgc)
    d = load_dive(p, params=tmp_path / "v.params")
    assert [m.direction for m in d.config.active] == DIRECTIONS
    assert inspect_log(p, params=tmp_path / "v.params").config.frame == 1


@pytest.mark.slow
def test_tlog_modes_from_autopilot_heartbeat(tmp_path):
    d = load_dive(write_tlog(tmp_path / "d.tlog", scenario(n=600)))
    seen = [(s["mode"], s["armed"]) for s in d.modes]
    assert ("ALT_HOLD", True) in seen and ("MANUAL", False) in seen


# ============================================================================ export and CLI
@pytest.mark.slow
def test_export_csv_sidecar_and_parquet_metadata(tmp_path):
    d = load_dive(write_tlog(tmp_path / "d.tlog", scenario(n=120)))
    cols = ["t_s", "depth_m", "roll_rad", "pitch_rad", "yaw_rad", "battery_V", "mode", "armed",
            *[f"pwm_{i}" for i in range(1, 7)], *[f"thrust_{i}_N" for i in range(1, 7)],
            "X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]
    assert list(d.table.columns) == cols
    out = d.export(tmp_path / "o.csv")
    import pandas as pd

    back = pd.read_csv(out)
    assert list(back.columns) == cols
    side = json.loads((tmp_path / "o.csv.json").read_text())
    assert side["provenance"]["depth_m"]["source"] == "-GLOBAL_POSITION_INT.relative_alt"
    assert side["provenance"]["pwm_3"]["source"] == "SERVO_OUTPUT_RAW.servo3_raw"
    pq = pytest.importorskip("pyarrow.parquet")
    d.export(tmp_path / "o.parquet")
    md = json.loads(pq.read_schema(tmp_path / "o.parquet").metadata[b"uuvid"])
    assert md["provenance"]["battery_V"]["source"] == "SYS_STATUS.voltage_battery"
    with pytest.raises(LogDataError, match="expected .csv or .parquet"):
        d.export(tmp_path / "o.xlsx")


@pytest.mark.slow
def test_cli_log_inspect_and_export(tmp_path):
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    p = write_bin(tmp_path / "d.BIN", scenario(n=100))
    r = CliRunner().invoke(app, ["log", "inspect", str(p), "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["config"]["frame_config"] == 1 and doc["depth_source"]["instance"] == 1
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "x.csv")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "x.csv").is_file() and (tmp_path / "x.csv.json").is_file()
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "y.csv"),
                                 "--vehicle", "bluerov2-heavy"])
    assert r.exit_code == 2 and "8 thrusters" in r.output
    # the sidecar is named by its full path
    r = CliRunner().invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "z.csv")])
    assert r.exit_code == 0 and str(tmp_path / "z.csv.json") in r.output.replace("\n", "")
    # the output type is checked before the log is read (here: a log that does not exist)
    r = CliRunner().invoke(app, ["log", "export", str(tmp_path / "none.BIN"), "--out-file",
                                 str(tmp_path / "x.xlsx")])
    assert r.exit_code == 2 and "expected .csv or .parquet" in r.output


@pytest.mark.slow
def test_plot_shades_each_mode_and_hatches_disarmed(tmp_path):
    """The legend names what the figure shows: one entry per mode (MANUAL unshaded), and the
    disarmed stretches drawn hatched without fill; without a vehicle the moment axis says its
    columns are not N·m."""
    from matplotlib.colors import to_rgba

    d = load_dive(write_bin(tmp_path / "d.BIN", scenario(n=600)))
    fig = d.plot(tmp_path / "p.png")
    assert (tmp_path / "p.png").stat().st_size > 0
    labels = [t.get_text() for lg in fig.legends for t in lg.get_texts()]
    assert labels == ["ALT_HOLD", "MANUAL (unshaded)", "disarmed"]
    ax = fig.axes[0]
    disarmed = [s for s in d.modes if s["armed"] is False]
    hatched = [p for p in ax.patches if p.get_hatch()]
    assert len(hatched) == len(disarmed) > 0
    assert all(p.get_facecolor()[3] == 0 and p.get_edgecolor()[3] > 0 for p in hatched)
    alt = [p for p in ax.patches if not p.get_hatch()
           and p.get_facecolor()[:3] == to_rgba("#a1d99b")[:3]]
    assert len(alt) == sum(s["mode"] == "ALT_HOLD" for s in d.modes)
    assert "not N·m" in fig.axes[-1].get_ylabel() and "--vehicle" in fig.axes[-1].get_ylabel()
    assert "not N·m" in d.provenance["K_Nm"]["unit"] and d.provenance["X_N"]["unit"] == "N"


def test_factor_tables_hold_no_negative_zero():
    from uuvid.io.ardusub import factor_matrix

    for frame in FRAME_NAMES:
        try:
            F = factor_matrix(frame)
        except KeyError:
            continue
        assert not np.any(np.signbit(F) & (F == 0)), frame


# ================================================================================== real logs
REAL = "ardusub-bluerov2"


@pytest.mark.slow
@pytest.mark.realdata
def test_real_small_bin_depth_is_baro_primary(shared_data):
    from pymavlink import mavutil

    p = shared_data / REAL / "small.BIN"
    c = mavutil.mavlink_connection(str(p))
    tb_, alt = [], []
    while (m := c.recv_match(type="BARO", blocking=False)) is not None:
        if m.I == 1:
            tb_.append(m.TimeUS * 1e-6)
            alt.append(m.Alt)
    d = load_dive(p)
    assert d.config.baro_primary == 1
    t = d.table["t_s"].to_numpy() + d.provenance["t_s"]["t0_boot_s"]
    np.testing.assert_allclose(d.table["depth_m"], -np.interp(t, tb_, alt), atol=1e-3)


@pytest.mark.slow
@pytest.mark.realdata
@pytest.mark.parametrize("name,frame,dirs", [
    ("small.BIN", 1, [-1, -1, 1, -1, -1, 1]),
    ("small.tlog", 2, [-1, -1, 1, 1, -1, 1, 1, -1]),
    ("2023-04-18_11-03-34.tlog", 2, [-1, -1, 1, 1, -1, 1, 1, -1])])
def test_real_logs_inspect_and_export_without_options(shared_data, tmp_path, name, frame, dirs):
    p = shared_data / REAL / name
    ins = inspect_log(p)
    s = ins.summary()
    assert f"FRAME_CONFIG = {frame}" in s and "depth source:" in s
    assert [m.direction for m in ins.config.active] == dirs
    d = load_dive(p)
    d.export(tmp_path / "o.csv")
    if name.endswith(".tlog"):  # on deck: the water-pressure sensor stays within 3 cm
        assert d.depth_source["source"] == "SCALED_PRESSURE2.press_abs − BARO2_GND_PRESS"
        assert np.nanmax(np.abs(d.table["depth_m"])) < 0.04
    # hand computation on the real PWM: factors × direction × T200 thrust
    from uuvid.io.ardusub.frames import factor_matrix

    tb = d.table
    t200 = default_t200()
    T = np.column_stack([t200.thrust(1500 + dirs[i] * (tb[f"pwm_{i + 1}"] - 1500),
                                     tb["battery_V"]) for i in range(len(dirs))])
    np.testing.assert_allclose(tb[["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]].to_numpy(),
                               (factor_matrix(frame) @ T.T).T, atol=1e-9)


def test_parquet_export_without_pyarrow_names_the_extra_before_reading(tmp_path, monkeypatch):
    """After a plain ``pip install -e .`` (no pyarrow) a .parquet export fails at once with the
    exact install command, printed literally (rich markup would eat ``[logs]``)."""
    import sys

    from typer.testing import CliRunner

    from uuvid.cli.app import app

    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow → ImportError
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    log = tmp_path / "never-read.BIN"
    log.write_bytes(b"not a log")
    res = CliRunner().invoke(app, ["log", "export", str(log), "--out-file", str(tmp_path / "d.parquet")])
    assert res.exit_code == 2
    assert "pip install 'uuvid[logs]'" in res.output
    assert "not a log" not in res.output and not (tmp_path / "d.parquet").exists()


@pytest.mark.realdata
def test_a_damaged_byte_in_a_bin_log_does_not_cut_the_rest_silently(shared_data, tmp_path, capfd):
    """One message of an unknown type halfway through small.BIN: pymavlink's index stops there,
    and the filtered read it serves ended the log at 9.7 s of 23.7 s without a word.  The reader
    now notices, reads past the damage and says so."""
    data = bytearray((shared_data / REAL / "small.BIN").read_bytes())
    i = data.index(b"\xa3\x95", 150000)
    data[i + 2] = 0xEE  # the message type byte: a type the file never defined
    (tmp_path / "damaged.BIN").write_bytes(bytes(data))
    whole = load_dive(shared_data / REAL / "small.BIN")
    d = load_dive(tmp_path / "damaged.BIN")
    assert abs(len(d.table) - len(whole.table)) <= 2
    assert any("damaged at byte" in w for w in d.warnings)
    assert not any("damaged at byte" in w for w in whole.warnings)
    # pymavlink's complaints (from Python and from C) are one warning, not lines on the terminal
    assert any("pymavlink reported" in w for w in d.warnings)
    out, err = capfd.readouterr()
    assert "unknown msg type" not in out + err and "Skipped" not in out + err


def test_a_telemetry_log_under_the_bin_suffix_is_one_error_not_a_flood(shared_data, tmp_path, capfd):
    (tmp_path / "renamed.BIN").write_bytes((shared_data / REAL / "small.tlog").read_bytes())
    with pytest.raises(LogDataError, match=r"renamed\.BIN: no messages.*complaints.*is it a \.tlog"):
        inspect_log(tmp_path / "renamed.BIN")
    out, err = capfd.readouterr()
    assert "bad header" not in out + err


@pytest.mark.realdata
def test_read_ardusub_reads_past_a_damaged_byte_too(shared_data, tmp_path):
    from uuvid.io.logs import LogWarning, read_ardusub

    data = bytearray((shared_data / REAL / "small.BIN").read_bytes())
    i = data.index(b"\xa3\x95", 150000)
    data[i + 2] = 0xEE
    (tmp_path / "damaged.BIN").write_bytes(bytes(data))
    whole = read_ardusub(shared_data / REAL / "small.BIN")
    with pytest.warns(LogWarning, match=r"damaged\.BIN: the log is damaged at byte"):
        cut = read_ardusub(tmp_path / "damaged.BIN")
    for ch in ("depth", "yaw"):
        a, b = cut[ch].t, whole[ch].t
        assert abs(a[-1] - b[-1]) < 0.5 and a.size >= 0.95 * b.size, ch


@pytest.mark.realdata
def test_read_ardusub_says_pymavlinks_complaints_once_not_on_the_terminal(shared_data, tmp_path,
                                                                           capfd):
    """The library reader, like the dive reader: pymavlink's prints about undecodable bytes (from
    Python and from C) become one LogWarning, or part of the error when nothing can be read."""
    from uuvid.io.logs import LogWarning, read_ardusub

    data = bytearray((shared_data / REAL / "small.BIN").read_bytes())
    i = data.index(b"\xa3\x95", 150000)
    data[i + 2] = 0xEE
    (tmp_path / "damaged.BIN").write_bytes(bytes(data))
    with pytest.warns(LogWarning) as rec:
        read_ardusub(tmp_path / "damaged.BIN")
    said = [str(w.message) for w in rec]
    assert any("pymavlink reported" in m and "decoding problem" in m for m in said), said
    (tmp_path / "renamed.BIN").write_bytes((shared_data / REAL / "small.tlog").read_bytes())
    with pytest.raises(LogDataError, match=r"pymavlink could not decode parts of the log.*is it a \.tlog"):
        read_ardusub(tmp_path / "renamed.BIN")
    out, err = capfd.readouterr()
    assert "unknown msg type" not in out + err and "bad header" not in out + err
    assert "Skipped" not in out + err


def _tlog_messages(path):
    from pymavlink import mavutil

    c = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    out = []
    while (m := c.recv_msg()) is not None:
        if m.get_type() != "BAD_DATA":
            out.append((m._timestamp, m.get_type(), bytes(m.get_msgbuf())))
    return out


def _write_tlog_messages(path, msgs):
    with open(path, "wb") as f:
        for t, _, buf in msgs:
            f.write(struct.pack(">Q", int(round(t * 1e6))))
            f.write(buf)
    return path


@pytest.mark.slow
@pytest.mark.realdata
@pytest.mark.parametrize("case", ["step back 100 s", "a day forward", "one corrupt stamp"])
def test_a_jump_of_the_ground_stations_clock_leaves_the_dive_as_it_was(shared_data, tmp_path, case):
    """The topside laptop's clock set back 100 s halfway (NTP): arming flickered, 2,258 rows were
    added and PWM moved by up to 197 µs, because the receive clock overrode the autopilot's good
    stamps.  The autopilot's clock runs on: the receive times after a jump are taken back."""
    src = _tlog_messages(shared_data / REAL / "small.tlog")
    base = _write_tlog_messages(tmp_path / "base.tlog", src)
    h = len(src) // 2
    if case == "one corrupt stamp":
        k = [i for i, (_, ty, _) in enumerate(src) if ty == "ATTITUDE"][100]
        msgs = src[:k] + [(0.0, src[k][1], src[k][2])] + src[k + 1:]
    else:
        d = -100.0 if case == "step back 100 s" else 86400.0
        msgs = src[:h] + [(t + d, ty, b) for t, ty, b in src[h:]]
    bad = _write_tlog_messages(tmp_path / "jump.tlog", msgs)
    a, b = load_dive(base, vehicle="bluerov2-heavy"), load_dive(bad, vehicle="bluerov2-heavy")
    assert len(a.table) == len(b.table)
    for col in ("t_s", "depth_m", "pwm_1", "armed"):
        np.testing.assert_allclose(b.table[col].to_numpy(float), a.table[col].to_numpy(float),
                                   atol=1e-6, err_msg=col)
    said = [w for w in b.warnings if "receive" in w and "autopilot's own clock runs on" in w]
    assert len(said) == 1 and ("corrupt stamp" in said[0]) == (case == "one corrupt stamp")
    assert not any("receive clock" in w for w in a.warnings)


@pytest.mark.slow
@pytest.mark.realdata
def test_one_heartbeat_with_a_corrupt_receive_time_does_not_stretch_the_modes(shared_data, tmp_path):
    """A HEARTBEAT (no on-board stamp) received '1e6 s later' made the last mode run to
    1,000,025 s; a receive time far outside the log's is left out, and said."""
    src = _tlog_messages(shared_data / REAL / "small.tlog")
    k = [i for i, (_, ty, _) in enumerate(src) if ty == "HEARTBEAT"][100]
    msgs = src[:k] + [(src[k][0] + 1e6, src[k][1], src[k][2])] + src[k + 1:]
    ins = inspect_log(_write_tlog_messages(tmp_path / "hb.tlog", msgs))
    assert max(m["end_s"] for m in ins.modes) < 300.0
    assert any("1 HEARTBEAT message(s)" in w and "left out" in w for w in ins.warnings)
    clean = inspect_log(shared_data / REAL / "small.tlog")
    assert not any("left out" in w for w in clean.warnings)


def _tlog_records(b: bytes):
    """(offset, message id) of each record (8-byte receive stamp + frame) of a telemetry log."""
    off, out = 0, []
    while off < len(b) - 10 and b[off + 8] in (0xFD, 0xFE):
        v2 = b[off + 8] == 0xFD
        n = 12 + b[off + 9] + (13 if b[off + 10] & 1 else 0) if v2 else 8 + b[off + 9]
        out.append((off, int.from_bytes(b[off + 15:off + 18], "little") if v2 else b[off + 13]))
        off += 8 + n
    return out


@pytest.mark.slow
@pytest.mark.realdata
@pytest.mark.parametrize("where", ["length", "payload"])
def test_two_corrupt_bytes_in_a_tlog_lose_only_the_damaged_message_and_are_said(shared_data,
                                                                                tmp_path, where):
    """Two bytes flipped in one AHRS2 frame in the middle of a real .tlog: a corrupt length byte
    made pymavlink swallow 265 bytes (the five valid messages after it, two ATTITUDEs among
    them) and a corrupt payload byte dropped the frame, both silently; the .BIN reader says
    what it skips.  Now the bytes are searched again for valid frames and the loss is said with
    where it is."""
    from uuvid.io.ardusub.reader import read_raw

    src = (shared_data / REAL / "small.tlog").read_bytes()
    recs = _tlog_records(src)
    off = next(o for o, mid in recs[len(recs) // 2:] if mid == 178)  # AHRS2: not read for a dive
    b = bytearray(src)
    k = off + (9 if where == "length" else 20)
    b[k] ^= 0xFF
    b[k + 1] ^= 0xFF
    whole = read_raw(shared_data / REAL / "small.tlog")
    cut = read_raw(_write(tmp_path / "flip.tlog", bytes(b)))
    n = [sum(sum(s.counts.values()) for s in r.senders.values()) for r in (whole, cut)]
    assert n[1] == n[0] - 1  # the damaged AHRS2 only
    for msg in ("ATTITUDE", "SERVO_OUTPUT_RAW", "SCALED_PRESSURE2", "HEARTBEAT"):
        assert len(cut.get(msg).t) == len(whole.get(msg).t), msg
    said = [w for w in cut.warnings if f"byte {off:,}" in w]
    assert len(said) == 1, cut.warnings
    assert ("damaged in 1 place" in said[0]) == (where == "length")
    assert ("1 AHRS2 from system 1 component 1" in said[0]) == (where == "payload")
    assert not any(f"byte {off:,}" in w for w in whole.warnings)


@pytest.mark.slow
@pytest.mark.realdata
@pytest.mark.parametrize("where", ["length", "payload"])
def test_read_ardusub_says_the_damaged_bytes_of_a_tlog_too(shared_data, tmp_path, where):
    """The library reader goes by pymavlink's index, which steps over damaged bytes and drops a
    frame failing its checksum silently: two flipped bytes in one ATTITUDE frame lost it (and
    with a corrupt length byte two more) with nothing said.  Now a gap in the index reads the
    log in turn (the damage searched again, as the dive reader does) and both are warned."""
    from uuvid.io.logs import LogWarning, read_ardusub

    src = (shared_data / REAL / "small.tlog").read_bytes()
    recs = _tlog_records(src)
    off = next(o for o, mid in recs[len(recs) // 2:] if mid == 30)  # ATTITUDE
    b = bytearray(src)
    k = off + (9 if where == "length" else 22)
    b[k] ^= 0xFF
    b[k + 1] ^= 0xFF
    whole = read_ardusub(shared_data / REAL / "small.tlog", on_duplicate="mean")
    with pytest.warns(LogWarning) as rec:
        cut = read_ardusub(_write(tmp_path / "flip.tlog", bytes(b)), on_duplicate="mean")
    said = [str(w.message) for w in rec if f"byte {off:,}" in str(w.message)]
    assert len(said) == 1 and "flip.tlog" in said[0], [str(w.message) for w in rec]
    assert cut["roll"].t.size == whole["roll"].t.size - 1  # the damaged ATTITUDE only
    assert cut["servo_1"].t.size == whole["servo_1"].t.size


def _bad_copy(src: bytes, mid: int, at: int = 30) -> bytes:
    """The last record of message ``mid`` in a telemetry log, one payload byte flipped (its
    checksum fails)."""
    off = [o for o, m in _tlog_records(src) if m == mid][-1]
    end = off + 8 + (12 + src[off + 9] if src[off + 8] == 0xFD else 8 + src[off + 9])
    rec = bytearray(src[off:end])
    rec[at] ^= 0xFF
    return bytes(rec)


@pytest.mark.slow
@pytest.mark.realdata
def test_a_dive_read_of_a_clean_tlog_says_nothing_of_camera_messages(shared_data):
    """small.tlog's camera (system 1 component 100) sends four messages pymavlink cannot check:
    every dive read said so, and identify repeated it under each 'window too short'.  A dive
    reads none of them: only checksum failures of the types it reads from the autopilot are its
    business; ``log inspect`` (the whole file) still lists them."""
    from uuvid.io.dive_channels import read_dive_channels

    dc = read_dive_channels(shared_data / REAL / "small.tlog", "bluerov2-heavy")
    assert not any("checksum" in w for w in dc.warnings), dc.warnings
    ins = inspect_log(shared_data / REAL / "small.tlog")
    assert any("CAMERA_INFORMATION from system 1 component 100" in w for w in ins.warnings)


@pytest.mark.slow
@pytest.mark.realdata
@pytest.mark.parametrize("extra", [5, 12, -7])
def test_a_tlog_cut_off_while_written_is_read_fast_and_said_as_such(shared_data, tmp_path, extra):
    """A log cut off mid-write (stray bytes after the last whole record, or its last record
    cut): taken for damage, read_ardusub read it message by message (twice as slow) and said the
    camera's checksums.  The partial record is the end of the log, said so."""
    from uuvid.io.ardusub.reader import read_raw
    from uuvid.io.logs import LogWarning, read_ardusub

    src = (shared_data / REAL / "small.tlog").read_bytes()
    p = _write(tmp_path / "cut.tlog", src + bytes(range(1, extra + 1)) if extra > 0 else src[:extra])
    n = extra if extra > 0 else len(src) + extra - _tlog_records(src)[-1][0]  # the last, cut
    said = f"cut.tlog: the log ends in a partial message ({n:,} bytes): cut off while written?"
    with pytest.warns(LogWarning) as rec:
        read_ardusub(p, on_duplicate="mean")
    # (LogWarnings only: a ResourceWarning of a file another test left to the collector may land
    # here, as it did once in CI)
    assert [str(w.message) for w in rec if issubclass(w.category, LogWarning)] == [said]
    assert said in read_raw(p, whole_file=False).warnings


@pytest.mark.slow
@pytest.mark.realdata
def test_frames_failing_their_checksum_at_the_end_of_a_tlog_are_said(shared_data, tmp_path):
    """Two ATTITUDE frames with a corrupt byte appended to small.tlog (after a damaged stretch,
    so the log is read message by message, and without it): failed frames were only said when a
    good message followed, so inspect counted 4 of the 6 BAD_DATA.  Now all six are said."""
    src = (shared_data / REAL / "small.tlog").read_bytes()
    bad = _bad_copy(src, 30)
    mid = next(o for o, m in _tlog_records(src)[len(_tlog_records(src)) // 2:] if m == 178)
    flipped = bytearray(src)
    flipped[mid + 9] ^= 0xFF  # a corrupt length byte: a damaged stretch
    for name, body in (("end.tlog", src), ("gap.tlog", bytes(flipped))):
        ins = inspect_log(_write(tmp_path / name, body + bad + bad))
        said = " | ".join(ins.warnings)
        assert f"2 ATTITUDE from system 1 component 1 at byte {len(src):,}" in said, said
        assert "4 message(s) fail their checksum in every copy" in said, said


@pytest.mark.realdata
def test_read_ardusub_counts_checksum_failures_of_the_types_read_only(shared_data, tmp_path):
    """Once pymavlink's index of the types read was used up, the rest of the log was read in
    turn: a frame of any type failing its checksum there (an AHRS2, not read) was counted as
    'of the types read', at the byte of the last indexed message."""
    from uuvid.io.logs import LogWarning, read_ardusub

    src = (shared_data / REAL / "small.tlog").read_bytes()
    p = _write(tmp_path / "ahrs2.tlog", src + _bad_copy(src, 178))
    with warnings.catch_warnings():
        warnings.simplefilter("error", LogWarning)
        read_ardusub(p, on_duplicate="mean")
    p = _write(tmp_path / "att.tlog", src + _bad_copy(src, 30))
    with pytest.warns(LogWarning, match=f"1 ATTITUDE from system 1 component 1 at byte {len(src):,}"):
        read_ardusub(p, on_duplicate="mean")


def _write(path, data: bytes):
    path.write_bytes(data)
    return path


# ---------------------------------------------------------------------------------------------
# Motor directions a log's parameters get wrong, and exports read back as tables
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def piloted(tmp_path_factory):
    """A 300 s piloted BlueROV2 dive (pure heave and yaw sticks) as the servo outputs ArduSub
    writes (the real BlueROV2 directions applied), for .BIN files with chosen parameters."""
    from uuvid.simulate.dive_synth import synthetic_dive

    df, _ = synthetic_dive(300.0, seed=7, vehicle="bluerov2", surge=0.0, jitter=0.0,
                           rates={"depth": 10, "yaw": 10, "pwm": 10, "battery": 10})
    df = df.dropna(subset=["depth_m", "yaw_rad", "pwm_1", "battery_V"])
    d = np.asarray(DIRECTIONS, float)
    pwm = 1500 + d * (df[[f"pwm_{j}" for j in range(1, 7)]].to_numpy() - 1500)
    sc = {"t": df["t_s"].to_numpy(), "pwm": pwm, "volts": df["battery_V"].to_numpy(),
          "depth": df["depth_m"].to_numpy(), "psi": df["yaw_rad"].to_numpy(),
          "armed": df["armed"].to_numpy(bool),
          "mode": df["mode"].map({"MANUAL": 19, "STABILIZE": 0, "ALT_HOLD": 2}).to_numpy()}
    return sc, tmp_path_factory.mktemp("piloted")


def _reversed_said(dc):
    return [w for w in dc.warnings if "probably reversed" in w]


@pytest.mark.slow
@pytest.mark.parametrize("motor", [None, 1, 5])
def test_a_direction_parameter_that_does_not_match_the_motor_is_named_in_a_bin_log(piloted, motor):
    """MOT_n_DIRECTION in the log flipped for one motor (the motor on the vehicle pushes the other
    way): the forces computed from the log oppose the measured motion, and the reader says which
    motor and which parameter — for a horizontal motor driven with three others (yaw) and for
    one of the vertical pair (heave).  The log as flown says nothing."""
    from uuvid.io.dive_channels import read_dive_channels

    sc, folder = piloted
    dirs = list(DIRECTIONS)
    if motor is not None:
        dirs[motor - 1] = -dirs[motor - 1]
    path = write_bin(folder / f"dir{motor}.BIN", sc, prm=params(directions=dirs))
    said = _reversed_said(read_dive_channels(path, "bluerov2"))
    if motor is None:
        assert not said
        return
    assert len(said) == 1 and said[0].startswith(f"dir{motor}.BIN: pwm_{motor} is probably "
                                                 "reversed"), said
    assert f"MOT_{motor}_DIRECTION = {-dirs[motor - 1]:d}" in said[0]


@pytest.mark.slow
def test_an_export_without_a_vehicle_is_read_back_with_the_vehicles_forces(piloted):
    """`uuvid log export` without --vehicle writes ArduSub's mixing sums (K/M/N in N per unit
    mixing factor, not N·m).  Read back as a dive table, those columns are not taken as the
    wrench: the forces are computed from the pwm_ columns with the export's motor directions —
    the same forces as reading the log itself; without a vehicle it is an error."""
    from uuvid.io.ardusub.export import export_dive
    from uuvid.io.dive_channels import DiveDataError, read_dive_channels

    sc, folder = piloted
    path = write_bin(folder / "flown.BIN", sc)
    out = export_dive(load_dive(path), folder / "flown.csv")
    direct = read_dive_channels(path, "bluerov2")
    back = read_dive_channels(out, "bluerov2")
    assert any("mixing sums" in w and "not used" in w for w in back.warnings)
    assert not _reversed_said(back)
    for c in ("Z_N", "N_Nm"):
        ta, a = direct.channels[c]
        tb, b = back.channels[c]
        assert np.allclose(np.interp(ta, tb, b), a, atol=1e-3 * np.abs(a).max()), c
    import pandas as pd

    raw = pd.read_csv(out)
    assert not np.allclose(raw["N_Nm"].to_numpy(), np.interp(raw["t_s"], *direct.channels["N_Nm"]),
                           atol=1e-3 * np.abs(direct.channels["N_Nm"][1]).max())
    with pytest.raises(DiveDataError, match="exported without a vehicle"):
        read_dive_channels(out)
    other = export_dive(load_dive(path, vehicle="bluerov2"), folder / "flown_b2.csv")
    again = read_dive_channels(other, "bluerov2")
    assert not any("mixing sums" in w or "exported with vehicle" in w for w in again.warnings)


def test_a_warning_raised_inside_the_capture_is_not_taken_for_a_pymavlink_print(capfd):
    """The capture of pymavlink's prints wraps the whole read; a warning raised meanwhile (the
    damaged-index note) was printed into the capture and reported as a 'decoding problem'. It is
    re-issued as a warning once the terminal is back."""
    import warnings

    from uuvid.io.logs import LogWarning, _captured_output

    lines: list = []
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        with _captured_output(lines):
            print("Skipped 3 bad bytes")
            warnings.warn("a note of the reader", LogWarning, stacklevel=1)
    assert lines == ["Skipped 3 bad bytes"]
    assert [str(w.message) for w in rec if issubclass(w.category, LogWarning)] == ["a note of the reader"]
