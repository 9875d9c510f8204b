"""Real logs' traps, read right by `uuvid vehicle identify` and its library (issue 9, items 6–7).

Every file here is synthetic and reproduces one trap seen in real dive logs: duplicated stamps
(QGroundControl tlogs), a reboot inside a tlog, a ROS 2 Humble bag without type definitions whose
thrusters are recorded as /mavros/rc/out PWM and whose heading is an IMU quaternion, a 10 Hz
attitude whose stamps drift off any uniform grid, a QGroundControl CSV export whose columns grow
mid-log with ISO time stamps, and channels whose magnitude cannot be what they claim.
"""

from __future__ import annotations

import csv
import json
import math
import sqlite3
import struct

import numpy as np
import pytest
from test_cli_identify import _json, _run, _within

from uuvid.identify.vehicle.fit import simulate_one_dof
from uuvid.identify.vehicle.logs import (
    LogSpec,
    load_msg_definitions,
    parse_scaled,
    quaternion_angles,
    read_vehicle_log,
)
from uuvid.identify.vehicle.procedures import identify_inertia, identify_steady, uniform_position
from uuvid.io.logs import LogDataError, read_log_csv
from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.model import OneDofModel
from uuvid.vehicle.servo_thrust import servo_generalized_force

YAW = {"I": 84.0, "k": 20.5, "k_q": 49.5}
DT = 0.1


def _integrate(v, dt=DT, x0=0.0):
    return np.concatenate([[x0], x0 + np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])


def _write_csv(path, header, rows):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    return path


# ------------------------------------------------------------------------------------ yaw steps
def _yaw_steps(seed=0, levels=(2.0, 5.0, 9.0, 14.0, -3.0, -7.0, -12.0, -18.0), seg=30.0):
    """Constant-torque segments on ROMEO's yaw (Caccia et al. 2000, Table III), heading in rad."""
    rng = np.random.default_rng(seed)
    f = np.concatenate([np.full(int(seg / DT), L) for L in levels])
    t = np.arange(f.size) * DT
    r = simulate_one_dof(OneDofModel(YAW["I"], YAW["k"], YAW["k_q"]), t, f)
    return t, f, _integrate(r) + rng.normal(0, 0.004, t.size)


def test_parse_scaled_and_quaternion_yaw():
    assert parse_scaled("-GLOBAL_POSITION_INT.relative_alt") == (-1.0, "GLOBAL_POSITION_INT."
                                                                   "relative_alt")
    assert parse_scaled("2.5*thrust") == (2.5, "thrust")
    assert parse_scaled("-0.01 * depth_cm") == (-0.01, "depth_cm")
    assert parse_scaled("-/mavros/rc/out:channels[0]") == (-1.0, "/mavros/rc/out:channels[0]")
    assert parse_scaled("1st_col") == (1.0, "1st_col")
    yaw = np.array([-3.0, -1.0, 0.0, 0.7, 3.1])
    pitch = np.array([0.1, -0.2, 0.0, 0.3, -0.4])
    roll = np.array([0.05, 0.2, -0.1, 0.0, 0.3])
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    q = (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
         cr * cp * cy + sr * sp * sy)
    a = quaternion_angles(*q)
    np.testing.assert_allclose(a["yaw"], yaw, atol=1e-12)
    np.testing.assert_allclose(a["pitch"], pitch, atol=1e-12)
    np.testing.assert_allclose(a["roll"], roll, atol=1e-12)


# ------------------------------------------------------------------------------------ CSV traps
@pytest.mark.slow
def test_csv_duplicated_stamps_merged_by_default_and_refused_on_request(tmp_path):
    t, f, y = _yaw_steps()
    rows = []
    for k in range(t.size):
        rows.append([f"{t[k]:.3f}", f[k], y[k]])
        if k % 7 == 3:  # the same sample written twice (a second link, a re-sent message)
            rows.append([f"{t[k]:.3f}", f[k], y[k] + 0.002])
    p = _write_csv(tmp_path / "dup.csv", ["time", "torque", "heading"], rows)
    cols = ("--dof", "yaw", "--command-col", "torque", "--position-col", "heading", "--settle",
            "10", "--min-duration", "10")
    doc = _json("vehicle", "identify", "steady", p, *cols)
    n_dup = sum(1 for k in range(t.size) if k % 7 == 3)
    assert doc["log_info"]["duplicates"] == n_dup
    assert any(f"{n_dup} rows with a duplicated time stamp merged" in n for n in doc["notes"])
    assert _within(doc["parameters"]["k"], YAW["k"]) and _within(doc["parameters"]["k_q"],
                                                                 YAW["k_q"])
    r = _run("vehicle", "identify", "steady", p, *cols, "--on-duplicate", "error")
    assert r.exit_code == 2 and "dup.csv" in r.output and "duplicated" in r.output
    # merge = the mean of the finite cells of the rows sharing a stamp
    lg = read_log_csv(p, time_col="time", columns=["heading"], on_duplicate="mean")
    np.testing.assert_allclose(lg["heading"][3], y[3] + 0.001, rtol=0, atol=1e-12)
    assert lg.meta["duplicates"] == n_dup


@pytest.mark.slow
def test_sign_scale_and_window_of_mapped_columns(tmp_path):
    t, f, y = _yaw_steps()
    p = _write_csv(tmp_path / "s.csv", ["time", "torque_x2", "heading_neg"],
                   [[f"{a:.3f}", 2 * b, -c] for a, b, c in zip(t, f, y)])
    base = ("--dof", "yaw", "--settle", "10", "--min-duration", "10")
    doc = _json("vehicle", "identify", "steady", p, *base, "--command-col", "0.5*torque_x2",
                "--position-col", "-heading_neg")
    ref = identify_steady(_write_csv(tmp_path / "r.csv", ["time", "torque", "heading"],
                                     [[f"{a:.3f}", b, c] for a, b, c in zip(t, f, y)]),
                          dof="yaw", command_col="torque", position_col="heading", settle=10,
                          min_duration=10)
    for n in ("k", "k_q"):
        assert doc["parameters"][n]["estimate"] == pytest.approx(
            ref.to_dict()["parameters"][n]["estimate"], rel=1e-9)
    assert doc["log_info"]["columns"]["command"] == "0.5*torque_x2"
    # --t-start/--t-end: only the segments inside the window
    win = _json("vehicle", "identify", "steady", p, *base, "--command-col", "0.5*torque_x2",
                "--position-col", "-heading_neg", "--t-start", "0", "--t-end", "120")
    assert win["n_points"] == 4 and max(s["t1"] for s in win["segments"]) <= 120


@pytest.mark.slow
def test_qgc_csv_export_with_growing_columns_and_iso_times(tmp_path):
    """QGroundControl writes 'Timestamp' as local ISO text and re-declares its header when a
    telemetry group appears; rows are read by their own header."""
    t, f, y = _yaw_steps()
    t0 = np.datetime64("2024-05-01T12:00:00.000")
    half = t.size // 2

    def stamp(x):
        return str(t0 + np.timedelta64(int(round(x * 1000)), "ms")).replace("T", " ")

    p = tmp_path / "qgc.csv"
    with open(p, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["Timestamp", "torque", "heading"])
        for k in range(half):
            w.writerow([stamp(t[k]), f[k], y[k]])
        w.writerow(["Timestamp", "torque", "battery.voltage", "heading"])
        for k in range(half, t.size):
            w.writerow([stamp(t[k]), f[k], 15.9, y[k]])
    lg = read_log_csv(p, time_col="Timestamp", columns=["heading", "battery.voltage"],
                      allow_missing=True)
    assert lg.meta["time_unit"] == "datetime" and lg.meta["time_detected"]
    np.testing.assert_allclose(np.diff(lg.t), DT, atol=1e-6)
    np.testing.assert_allclose(lg["heading"], y)
    assert np.all(np.isnan(lg["battery.voltage"][:half]))
    np.testing.assert_allclose(lg["battery.voltage"][half:], 15.9)
    assert lg.meta["sections"][1] == {"first_row": half + 1, "columns_added": ["battery.voltage"],
                                      "n_columns": 4}
    doc = _json("vehicle", "identify", "steady", p, "--dof", "yaw", "--command-col", "torque",
                "--position-col", "heading", "--settle", "10", "--min-duration", "10")
    assert doc["log_info"]["columns"]["command"] == "torque"
    notes = " ".join(doc["notes"])
    assert "'Timestamp'" in notes and "ISO 8601" in notes and "battery.voltage" in notes
    assert doc["segments"][0]["t0"] == pytest.approx(10.0, abs=0.11)  # t = 0 at the first row
    assert _within(doc["parameters"]["k"], YAW["k"])


@pytest.mark.slow
def test_qgc_csv_whose_rows_grow_when_a_battery_is_found(tmp_path):
    """QGroundControl writes its header once; a battery found after the first rows adds its
    cells in the middle of every later row, shifting the rest (mavlink/qgroundcontrol#11763)."""
    t, f, y = _yaw_steps()
    rng = np.random.default_rng(5)
    t0 = np.datetime64("2024-05-01T12:00:00.000")
    header = ["Timestamp", "roll", "pitch", "flightMode", "armed", "gps.lat", "gps.lon", "torque",
              "heading", "temperature.temperature1"]
    p = tmp_path / "qgc_grow.csv"
    with open(p, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for k in range(t.size):
            row = [str(t0 + np.timedelta64(int(round(t[k] * 1000)), "ms")).replace("T", " "),
                   f"{rng.normal(0, 0.01):.4f}", f"{rng.normal(0, 0.01):.4f}", "Manual", "true",
                   "0.0000000", "0.0000000", f"{f[k]:.4f}", f"{y[k]:.6f}", "18.20"]
            if k >= 7:  # battery0 discovered: its cells go after 'armed'
                row[5:5] = [f"{15.9 - 1e-4 * k:.2f}", "1.50", "87"]
            w.writerow(row)
    lg = read_log_csv(p, time_col="Timestamp", columns=["heading", "torque", "gps.lat",
                                                         "unnamed_1"], allow_missing=True)
    np.testing.assert_allclose(lg["heading"], y, atol=1e-6)
    np.testing.assert_allclose(lg["torque"], f, atol=1e-4)
    np.testing.assert_allclose(lg["gps.lat"], 0.0)
    assert np.all(np.isnan(lg["unnamed_1"][:7]))
    np.testing.assert_allclose(lg["unnamed_1"][7:], 15.9 - 1e-4 * np.arange(7, t.size), atol=6e-3)
    assert lg.meta["sections"][1]["inserted_after"] == "armed"
    doc = _json("vehicle", "identify", "steady", p, "--dof", "yaw", "--command-col", "torque",
                "--position-col", "heading", "--settle", "10", "--min-duration", "10")
    assert any("after column 'armed'" in n for n in doc["notes"])
    # nothing in the neighbouring rows says where the new cells went: refused, naming the line
    amb = tmp_path / "amb.csv"
    amb.write_text("t,a,b\n0,1,2\n1,5,6,7\n2,8,9,10\n")
    with pytest.raises(LogDataError, match=r"amb.csv: CSV line 3 has 4 cells .* cannot be told"):
        read_log_csv(amb, time_col="t", columns=["a"])
    assert _within(doc["parameters"]["k"], YAW["k"])


@pytest.mark.slow
def test_pwm_as_newtons_and_altitude_as_depth_are_named(tmp_path):
    t, f, y = _yaw_steps()
    pwm = 1500 + 20 * f  # a raw servo command, not a torque
    p = _write_csv(tmp_path / "pwm.csv", ["time", "servo", "heading"],
                   [[f"{a:.3f}", b, c] for a, b, c in zip(t, pwm, y)])
    doc = _json("vehicle", "identify", "steady", p, "--dof", "yaw", "--command-col", "servo",
                "--position-col", "heading", "--settle", "10", "--min-duration", "10")
    assert any("'servo'" in w and "PWM" in w for w in doc["warnings"])
    # a constant "depth" (ArduSub's VFR_HUD.alt without an EKF origin) is named too
    data = read_vehicle_log(LogSpec(_write_csv(tmp_path / "flat.csv", ["time", "f", "z"],
                                               [[a, b, 0.0] for a, b in zip(t, f)]), "heave",
                                    command_col="f", position_col="-z"))
    assert any("'-z' is constant" in w for w in data.warnings)
    r = _run("vehicle", "identify", "steady", p, "--dof", "yaw", "--command-col", "servo",
             "--position-col", "heading", "--vehicle", "bluerov2")
    assert r.exit_code == 2 and "--vehicle does not apply to CSV" in r.output
    # heave: an altitude (up positive, mostly negative under water) given as depth
    rng = np.random.default_rng(4)
    lv = (30.0, -40.0, 60.0, -70.0, 90.0, -100.0)
    fz = np.concatenate([np.full(400, L) for L in lv])
    tz = np.arange(fz.size) * DT
    w = simulate_one_dof(OneDofModel(1050.0, 44.7, 430.3), tz, fz)
    depth = 3.0 + _integrate(w) + rng.normal(0, 0.005, tz.size)
    p = _write_csv(tmp_path / "alt.csv", ["time", "thrust", "alt"],
                   [[f"{a:.3f}", b, -c] for a, b, c in zip(tz, fz, depth)])
    cols = ("--dof", "heave", "--command-col", "thrust", "--settle", "25", "--min-duration", "10")
    bad = _json("vehicle", "identify", "steady", p, *cols, "--position-col", "alt")
    assert any("'alt'" in w and "mostly negative" in w for w in bad["warnings"])
    good = _json("vehicle", "identify", "steady", p, *cols, "--position-col", "-alt")
    assert not good["warnings"]
    ref = identify_steady(_write_csv(tmp_path / "depth.csv", ["time", "thrust", "depth"],
                                     [[f"{a:.3f}", b, c] for a, b, c in zip(tz, fz, depth)]),
                          dof="heave", command_col="thrust", position_col="depth", settle=25,
                          min_duration=10)
    assert not ref.warnings
    assert good["parameters"]["k_q"]["estimate"] == pytest.approx(
        ref.to_dict()["parameters"]["k_q"]["estimate"], rel=1e-9)
    assert good["parameters"]["k_q"]["estimate"] > 0 > bad["parameters"]["k_q"]["estimate"]


# ------------------------------------------------------------------------------------ inertia
def _jittery_sine(seed=1, duration=130.0, uniform=False):
    """The paper's yaw sine, −5 + 4 sin(2πt/24) N·m commanded at 10 Hz (held between updates),
    and a 10 Hz heading whose stamps wander as an autopilot's ATT does: steps 0.1 s ± 8 ms, so
    the offset from any grid random-walks.  CSV rows: command rows and heading rows, each with
    the other cell empty (``uniform``: also the same experiment with the heading on the
    command's grid)."""
    rng = np.random.default_rng(seed)
    tc = np.arange(0.0, duration, DT)
    cmd = -5.0 + 4.0 * np.sin(2 * np.pi * tc / 24.0)
    tf = np.arange(0.0, duration - DT, 0.01)
    held = cmd[np.floor(tf / DT + 1e-9).astype(int)]
    psi = _integrate(simulate_one_dof(OneDofModel(YAW["I"], YAW["k"], YAW["k_q"]), tf, held),
                     0.01)
    ts = np.cumsum(np.r_[0.0, 0.1 + rng.normal(0, 0.008, int(duration / 0.1) + 10)]) + 0.003
    ts = ts[ts < tf[-1]]
    head = np.interp(ts, tf, psi) + rng.normal(0, 0.003, ts.size)
    wrapped = (head + np.pi) % (2 * np.pi) - np.pi
    cmd_rows = [[f"{a:.4f}", b, ""] for a, b in zip(tc, cmd)]
    rows = sorted(cmd_rows + [[f"{a:.4f}", "", c] for a, c in zip(ts, wrapped)],
                  key=lambda r: float(r[0]))
    if not uniform:
        return rows, ts, wrapped
    tu = tc[tc < tf[-1]] + 0.003
    hu = np.interp(tu, tf, psi) + rng.normal(0, 0.003, tu.size)
    urows = sorted(cmd_rows + [[f"{a:.4f}", "", c] for a, c in zip(tu, hu)],
                   key=lambda r: float(r[0]))
    return rows, urows, ts, wrapped


@pytest.mark.slow
def test_inertia_resamples_a_jittery_attitude_and_refuses_when_asked(tmp_path):
    rows, urows, ts, head = _jittery_sine(uniform=True)
    p = _write_csv(tmp_path / "sine.csv", ["time", "torque", "yaw"], rows)
    cols = ("--dof", "yaw", "--command-col", "torque", "--position-col", "yaw", "--k",
            str(YAW["k"]), "--kq", str(YAW["k_q"]))
    r = _run("vehicle", "identify", "inertia", p, *cols, "--resample", "off")
    assert r.exit_code == 2 and "uniform grid" in r.output
    doc = _json("vehicle", "identify", "inertia", p, *cols)
    assert any("drift off a uniform grid" in n and "interpolated" in n for n in doc["notes"])
    assert _within(doc["parameters"]["m"], YAW["I"]), doc["parameters"]["m"]
    # the same experiment logged on a uniform grid: no resampling, the same inertia within σ
    ref = _json("vehicle", "identify", "inertia",
                _write_csv(tmp_path / "uniform.csv", ["time", "torque", "yaw"], urows), *cols)
    assert not any("uniform grid" in n for n in ref["notes"])
    m, m0 = doc["parameters"]["m"], ref["parameters"]["m"]
    assert abs(m["estimate"] - m0["estimate"]) <= 3 * math.hypot(m["sigma"], m0["sigma"])
    tu = np.arange(0, 10, 0.1)
    t2, _x2, note = uniform_position(tu, np.sin(tu))
    assert note is None and t2 is tu
    # heading unwrapped before interpolation (no ±π jumps smeared into the grid)
    tg, xg, note = uniform_position(ts, head, angle=True)
    assert note and np.max(np.abs(np.diff(xg))) < 0.2
    np.testing.assert_allclose(np.diff(tg), np.median(np.diff(ts)), rtol=1e-9)


# ------------------------------------------------------------------------------------ tlogs
def _bluerov_yaw_turns():
    """A BlueROV2 turning on the spot: horizontal outputs 1500 ± δ (yaw pattern), the yaw from
    the 1-DOF model driven by B T(PWM) through the vehicle's T200 models."""
    v = load_vehicle("bluerov2")
    s = np.sign(v.B[5, :4])
    pwm = []
    for d in (80, 150, 250, 400, -80, -150, -250, -400):
        p = np.full(8, 1500.0)
        p[:4] = 1500 + s * d
        pwm += [p] * 100
    pwm = np.array(pwm)
    _, tau = servo_generalized_force(v, pwm[:, :v.layout.n].T)
    t = np.arange(pwm.shape[0]) * DT
    P = v.params
    r = simulate_one_dof(OneDofModel(P.mass_matrix[5, 5], P.linear_damping[5, 5],
                                     P.quadratic_damping[5, 5]), t, tau[5])
    yaw = _integrate(r) + np.random.default_rng(3).normal(0, 0.003, t.size)
    return t, pwm, tau[5], yaw, P


def _tlog(path, t, pwm, yaw, *, reboot_at=None, duplicate_every=None):
    from pymavlink import mavutil
    from pymavlink.dialects.v20 import ardupilotmega as mavlink2

    path.touch()
    log = mavutil.mavlink_connection(str(path), write=True)
    sub = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)

    def put(t_unix, msg):
        log.write(struct.pack(">Q", int(round(t_unix * 1e6))) + msg.pack(sub))

    put(1.7e9, sub.heartbeat_encode(mavlink2.MAV_TYPE_SUBMARINE,
                                    mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0))
    wrapped = (yaw + np.pi) % (2 * np.pi) - np.pi
    for k in range(t.size):
        boot = 5.0 + t[k]
        if reboot_at is not None and t[k] >= reboot_at:
            boot = 1.0 + t[k] - reboot_at  # the autopilot restarted: its clock starts again
        att = sub.attitude_encode(int(round(boot * 1000)), 0.0, 0.0, float(wrapped[k]), 0, 0, 0)
        put(1.7e9 + 5.0 + t[k] + 0.01, att)
        if duplicate_every and k % duplicate_every == 0:
            put(1.7e9 + 5.0 + t[k] + 0.011, att)  # the same message received twice
        put(1.7e9 + 5.0 + t[k] + 0.02, sub.servo_output_raw_encode(
            int(round(boot * 1e6)), 0, *[int(x) for x in pwm[k]]))
    log.close()
    return path


@pytest.mark.slow
def test_tlog_duplicates_reboot_and_a_signed_field(tmp_path):
    pytest.importorskip("pymavlink")
    t, pwm, _tau, yaw, P = _bluerov_yaw_turns()
    cols = ("--dof", "yaw", "--vehicle", "bluerov2", "--settle", "2", "--min-duration", "5")
    dup = _tlog(tmp_path / "dup.tlog", t, pwm, yaw, duplicate_every=3)
    r = _run("vehicle", "identify", "steady", dup, *cols, "--on-duplicate", "error")
    assert r.exit_code == 2 and "duplicated" in r.output
    doc = _json("vehicle", "identify", "steady", dup, *cols)
    assert doc["log_info"]["duplicates"] == {"position": len(range(0, t.size, 3))}
    assert any("duplicated time stamp merged" in n for n in doc["notes"])
    assert _within(doc["parameters"]["k"], P.linear_damping[5, 5])
    # a reboot mid-log: the boot clock jumps back — refused with the way out, read with --time log
    rb = _tlog(tmp_path / "reboot.tlog", t, pwm, yaw, reboot_at=37.0)
    r = _run("vehicle", "identify", "steady", rb, *cols)
    assert r.exit_code == 2 and "rebooted" in r.output
    doc = _json("vehicle", "identify", "steady", rb, *cols, "--time", "log")
    assert doc["log_info"]["time_base"] == "log"
    assert _within(doc["parameters"]["k"], P.linear_damping[5, 5])
    assert _within(doc["parameters"]["k_q"], P.quadratic_damping[5, 5])
    # a sign on a field: the heading negated turns the drag negative (the sign is applied)
    neg = _json("vehicle", "identify", "steady", dup, *cols, "--field",
                "position=-ATTITUDE.yaw", "--no-quadratic")
    assert neg["parameters"]["k"]["estimate"] < 0
    assert any(w.startswith("implausible yaw linear drag") for w in neg["warnings"])


# ------------------------------------------------------------------------------------ ROS 2 bag
RCOUT_MSG = "std_msgs/Header header\nuint16[] channels\n"


@pytest.mark.slow
def test_humble_bag_rc_out_to_thrust_and_imu_quaternion_yaw(tmp_path):
    """A ROS 2 Humble bag (no embedded definitions): /mavros/rc/out PWM, /mavros/imu/data
    orientation; the force comes from the same PWM → thrust path as ArduSub logs."""
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    t, pwm, tau, yaw, P = _bluerov_yaw_turns()
    ts = get_typestore(Stores.ROS2_HUMBLE)
    ts.register(get_types_from_msg(RCOUT_MSG, "mavros_msgs/msg/RCOut"))
    Imu, Header = ts.types["sensor_msgs/msg/Imu"], ts.types["std_msgs/msg/Header"]
    Time, Quat = ts.types["builtin_interfaces/msg/Time"], ts.types["geometry_msgs/msg/Quaternion"]
    Vec, RCOut = ts.types["geometry_msgs/msg/Vector3"], ts.types["mavros_msgs/msg/RCOut"]
    bag = tmp_path / "humble"
    t0 = 1_700_000_000 * 10**9

    def hdr(ns):
        return Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="base_link")

    with Writer(bag, version=9) as w:
        ci = w.add_connection("/mavros/imu/data", Imu.__msgtype__, typestore=ts)
        cr = w.add_connection("/mavros/rc/out", RCOut.__msgtype__, typestore=ts)
        z = np.zeros(9)
        for k in range(t.size):
            ns = t0 + int(round(t[k] * 1e9))
            q = Quat(x=0.0, y=0.0, z=math.sin(yaw[k] / 2), w=math.cos(yaw[k] / 2))
            w.write(ci, ns + 10**7, ts.serialize_cdr(Imu(
                header=hdr(ns + 5 * 10**6), orientation=q, orientation_covariance=z,
                angular_velocity=Vec(x=0.0, y=0.0, z=0.0), angular_velocity_covariance=z,
                linear_acceleration=Vec(x=0.0, y=0.0, z=9.8), linear_acceleration_covariance=z),
                Imu.__msgtype__))
            w.write(cr, ns + 2 * 10**7, ts.serialize_cdr(RCOut(
                header=hdr(ns), channels=pwm[k].astype(np.uint16)), RCOut.__msgtype__))
    with sqlite3.connect(next(bag.glob("*.db3"))) as con:
        con.execute("DELETE FROM message_definitions")  # as a Humble recording has them
    cols = ("--dof", "yaw", "--vehicle", "bluerov2", "--topic",
            "position=/mavros/imu/data:orientation.yaw", "--settle", "2", "--min-duration", "5")
    r = _run("vehicle", "identify", "steady", bag, *cols)
    assert r.exit_code == 2 and "mavros_msgs/msg/RCOut" in r.output
    assert "--msg-definitions" in r.output
    msg = tmp_path / "mavros_msgs" / "msg"
    msg.mkdir(parents=True)
    (msg / "RCOut.msg").write_text(RCOUT_MSG)
    assert set(load_msg_definitions([str(msg / "RCOut.msg")])) == {"mavros_msgs/msg/RCOut"}
    doc = _json("vehicle", "identify", "steady", bag, *cols, "--msg-definitions",
                f"mavros_msgs/msg/RCOut={msg / 'RCOut.msg'}")
    assert "/mavros/rc/out" in doc["log_info"]["command_from"]
    assert _within(doc["parameters"]["k"], P.linear_damping[5, 5])
    assert _within(doc["parameters"]["k_q"], P.quadratic_damping[5, 5])
    # the command series is exactly B T(PWM) of the recorded outputs (the shared path)
    data = read_vehicle_log(LogSpec(bag, "yaw", topics=["position=/mavros/imu/data:orientation"],
                                    vehicle="bluerov2",
                                    msg_definitions=[str(msg / "RCOut.msg")]))
    np.testing.assert_allclose(data.command, tau, rtol=1e-12)
    np.testing.assert_allclose(data.position, (yaw + np.pi) % (2 * np.pi) - np.pi, atol=1e-9)


# ------------------------------------------------------------------------------------ Python API
@pytest.mark.slow
def test_python_api_in_a_few_lines(tmp_path):
    t, f, y = _yaw_steps()
    p = _write_csv(tmp_path / "pool.csv", ["time", "torque", "heading"],
                   [[f"{a:.3f}", b, c] for a, b, c in zip(t, f, y)])
    res = identify_steady(p, dof="yaw", command_col="torque", position_col="heading",
                          settle=10, min_duration=10)
    assert "k_q" in res.summary() and res.to_dict()["dof"] == "yaw"
    cli = _json("vehicle", "identify", "steady", p, "--dof", "yaw", "--command-col", "torque",
                "--position-col", "heading", "--settle", "10", "--min-duration", "10")
    assert res.to_dict()["parameters"] == cli["parameters"]
    assert (res.report(tmp_path / "rep")).name == "index.html"
    assert (tmp_path / "rep" / "steady_fit.png").is_file()
    assert res.plot() is not None
    ps = _write_csv(tmp_path / "sine.csv", ["time", "torque", "yaw"], _jittery_sine()[0])
    inr = identify_inertia(ps, dof="yaw", drag=res, command_col="torque", position_col="yaw")
    assert inr.document["drag"]["covariance_propagated"]
    (tmp_path / "steady.json").write_text(json.dumps(cli))
    cli_i = _json("vehicle", "identify", "inertia", ps, "--dof", "yaw", "--drag",
                  tmp_path / "steady.json", "--command-col", "torque", "--position-col", "yaw")
    assert inr.mass == pytest.approx(cli_i["mass"]["estimate"], rel=1e-9)
    assert inr.fit.mass_stderr == pytest.approx(cli_i["mass"]["sigma"], rel=1e-9)
    assert "inertia" in inr.summary()


# ------------------------------------------------------------------- clock restarts vs swapped rows
_STEADY = ("--dof", "yaw", "--command-col", "torque", "--position-col", "heading", "--settle",
           "10", "--min-duration", "10")


def test_csv_whose_time_restarts_is_refused_naming_the_row(tmp_path):
    """A time column reset to 0 halfway (a reboot, two recordings appended) must not be sorted
    and merged into one series: the reader stops at the row where the clock restarts."""
    t, f, y = _yaw_steps()
    k = t.size // 2 + 7
    tt = np.concatenate([t[:k], t[k:] - t[k]])  # the clock starts again at 0 on row k
    rows = [[f"{a:.3f}", b, c, "yaw"] for a, b, c in zip(tt, f, y)]
    p = _write_csv(tmp_path / "restart.csv", ["time", "torque", "heading", "mode"], rows)
    where = f"restart.csv: column 'time', data row {k + 1} (CSV line {k + 2})"
    jump = f"{t[k - 1]:.9g} s → 0 s"
    for extra in ((), ("--mode-col", "mode", "--open-water-mode", "yaw+"),
                  ("--on-duplicate", "error")):
        r = _run("vehicle", "identify", "steady", p, *_STEADY, *extra)
        assert r.exit_code == 2, r.output
        out = " ".join(r.output.split())
        assert where in out and "time restarts" in out and jump in out, out
        assert "--topic" not in out and "sorted" not in out.split("time restarts")[0]
    with pytest.raises(LogDataError, match="time restarts"):
        read_log_csv(p, time_col="time", columns=["heading"], on_duplicate="mean")
    # the same file in milliseconds: the threshold follows the time step, not the unit
    pm = _write_csv(tmp_path / "restart_ms.csv", ["time", "torque", "heading"],
                    [[f"{a * 1e3:.0f}", b, c] for a, b, c in zip(tt, f, y)])
    with pytest.raises(LogDataError, match=rf"data row {k + 1} .*time restarts"):
        read_log_csv(pm, time_col="time", columns=["heading"], time_unit="ms", on_duplicate="mean")


def test_csv_with_a_few_locally_swapped_rows_is_sorted_with_its_note(tmp_path):
    """Rows a step or two out of order (two senders interleaved in an export) stay legitimate:
    sorted into place and said in a note; a mode column cannot follow them and the error names
    the row (and no ROS-bag option)."""
    t, f, y = _yaw_steps()
    rows = [[f"{a:.3f}", b, c, "yaw"] for a, b, c in zip(t, f, y)]
    swapped = (100, 101, 905, 906, 1700, 1701)
    for i in swapped[::2]:
        rows[i], rows[i + 1] = rows[i + 1], rows[i]
    rows[1500], rows[1503] = rows[1503], rows[1500]  # three steps late: still local
    p = _write_csv(tmp_path / "swapped.csv", ["time", "torque", "heading", "mode"], rows)
    lg = read_log_csv(p, time_col="time", columns=["heading"], on_duplicate="mean")
    assert lg.meta["reordered"] > 0 and lg.meta["duplicates"] == 0
    np.testing.assert_allclose(lg.t, np.round(t, 3), atol=1e-9)
    np.testing.assert_allclose(lg["heading"], y, atol=1e-12)
    data = read_vehicle_log(LogSpec(p, "yaw", command_col="torque", position_col="heading"))
    assert any("rows out of time order sorted" in n for n in data.info["notes"])
    r = _run("vehicle", "identify", "steady", p, *_STEADY, "--mode-col", "mode",
             "--open-water-mode", "yaw+")
    out = " ".join(r.output.split())
    assert r.exit_code == 2 and "swapped.csv: column 'time', data row 102 (CSV line 103)" in out, out
    assert "mode" in out and "--topic" not in out and "--field" not in out


@pytest.mark.slow
def test_csv_with_locally_swapped_rows_identifies_like_the_sorted_log(tmp_path):
    t, f, y = _yaw_steps()
    rows = [[f"{a:.3f}", b, c] for a, b, c in zip(t, f, y)]
    for i in (100, 905, 1700):
        rows[i], rows[i + 1] = rows[i + 1], rows[i]
    p = _write_csv(tmp_path / "swapped.csv", ["time", "torque", "heading"], rows)
    doc = _json("vehicle", "identify", "steady", p, *_STEADY)
    assert any("rows out of time order sorted" in n for n in doc["notes"])
    assert _within(doc["parameters"]["k"], YAW["k"]) and _within(doc["parameters"]["k_q"],
                                                                 YAW["k_q"])


def test_decimal_commas_in_a_semicolon_table_are_named_as_such(tmp_path):
    """A European spreadsheet export (';' between cells, ',' as the decimal point) said only
    "'0,1' is not numeric"; `thruster fit` names the cause: so does the log reader now."""
    from uuvid.io.logs import LogDataError, read_log_csv

    p = tmp_path / "euro.csv"
    p.write_text("time;torque;heading_deg\n0;0;16,8\n0,1;0;17,6\n0,2;0;18,4\n")
    with pytest.raises(LogDataError, match=r"'0,1' is not numeric.* a decimal comma .*'\.' as the "
                                           "decimal point"):
        read_log_csv(p, time_col="time", columns=["torque", "heading_deg"])
    p.write_text("time,torque\n0,0\n0.1,x1\n")
    with pytest.raises(LogDataError, match="'x1' is not numeric") as e:
        read_log_csv(p, time_col="time", columns=["torque"])
    assert "decimal comma" not in str(e.value)


def test_the_first_unordered_row_is_named_with_the_stamps_as_read(tmp_path):
    """The note named the row from the file but read its stamps from the sorted, merged series:
    a repeated last stamp raised an IndexError (the merged series is shorter) and a swap was
    said backwards ("0.3 s is earlier than the previous row's 0.2 s")."""
    p = tmp_path / "dupend.csv"
    p.write_text("t,x\n0,1\n0.1,2\n0.2,3\n0.3,4\n0.3,5\n")
    lg = read_log_csv(p, time_col="t", columns=["x"], on_duplicate="first")
    np.testing.assert_array_equal(lg.t, [0.0, 0.1, 0.2, 0.3])
    assert lg.meta["first_unordered"].endswith("time stamp 0.3 s repeats the previous row's 0.3 s")
    p = tmp_path / "swap.csv"
    p.write_text("t,x\n0,1\n0.1,2\n0.3,3\n0.2,4\n0.4,5\n0.5,6\n")
    lg = read_log_csv(p, time_col="t", columns=["x"], on_duplicate="first")
    assert lg.meta["first_unordered"].endswith("data row 4 (CSV line 5): time stamp 0.2 s is "
                                               "earlier than the previous row's 0.3 s"), lg.meta
