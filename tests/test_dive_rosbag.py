"""Dive identification and replay from ROS bags as ArduSub + mavros record them (issue 19).

Evidence: the project's synthetic piloted dive (6-DOF model, MANUAL/STABILIZE/ALT_HOLD, tether
drag, battery sag) written with ``rosbags`` as ROS 1 and ROS 2 bags on mavros' topics and types,
with the traps of a real recording: motors reversed by ``MOT_n_DIRECTION`` (the outputs carry the
reflected PWM, as ArduSub writes them), outputs 7 and 8 disabled at 0 µs, messages written twice,
header stamps a constant 0.25 s before the receive times (``rel_alt`` has no header, so only its
receive time) and header stamps out of order in the bag.  The attitude is written as mavros does
(ENU world, FLU body) from the NED heading the dive flew.  The same dive as a CSV table is the
reference: the bag must give the same estimates (it is the same data) and the truth within 3σ.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("rosbags")

from uuvid.cli.app import app  # noqa: E402
from uuvid.identify.vehicle.dive import identify_dive  # noqa: E402
from uuvid.io.dive_channels import DiveDataError, read_dive_channels  # noqa: E402
from uuvid.io.dive_rosbag import _check_interleaved, enu_flu_to_ned_frd  # noqa: E402
from uuvid.simulate.dive_replay import replay_dive  # noqa: E402
from uuvid.simulate.dive_synth import synthetic_dive  # noqa: E402

runner = CliRunner()
PARAMS = ("mass", "linear", "quadratic", "bias")
DIRECTIONS = [-1, -1, 1, -1, -1, 1]  # MOT_n_DIRECTION as on real BlueROV2s
PARAM_TEXT = "".join(f"MOT_{j}_DIRECTION,{d}\n" for j, d in enumerate(DIRECTIONS, 1))
T0 = 1_700_000_000 * 10**9
OFFSET = 250_000_000  # receive time − header stamp [ns]
RCOUT = "std_msgs/Header header\nuint16[] channels\n"
STATE = ("std_msgs/Header header\nbool connected\nbool armed\nbool guided\nbool manual_input\n"
         "string mode\nuint8 system_status\n")
ALL = ("rc", "imu", "rel_alt", "battery", "state")


# ----------------------------------------------------------------------- quaternions (w, x, y, z)
def _qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


def _axis(angle, k):
    q = [math.cos(angle / 2), 0.0, 0.0, 0.0]
    q[1 + k] = math.sin(angle / 2)
    return tuple(q)


def _rpy(roll, pitch, yaw):  # ZYX: q = qz(yaw) qy(pitch) qx(roll)
    return _qmul(_qmul(_axis(yaw, 2), _axis(pitch, 1)), _axis(roll, 0))


def mavros_orientation(roll, pitch, yaw):
    """What mavros publishes on imu/data for ArduSub's NED/FRD attitude (plugins/imu.cpp:
    transform_orientation_aircraft_baselink(transform_orientation_ned_enu(q)) = Q_NE q Q_AB with
    Q_NE = rpy(π, 0, π/2), Q_AB = rpy(π, 0, 0), ftf_frame_conversions.cpp)."""
    return _qmul(_qmul(_rpy(math.pi, 0.0, math.pi / 2), _rpy(roll, pitch, yaw)),
                 _rpy(math.pi, 0.0, 0.0))


def test_heading_from_a_mavros_quaternion():
    """ENU/FLU → NED/FRD: the identity (body x along ENU x = east) is heading east, ψ = +π/2;
    mixing the frames up gives 0 or −π/2 and fails here."""
    r, p, y = enu_flu_to_ned_frd(0.0, 0.0, 0.0, 1.0)
    assert (float(r), float(p), float(y)) == pytest.approx((0.0, 0.0, math.pi / 2), abs=1e-12)
    # ENU yaw +0.3 (counter-clockwise from east, seen from above) is NED heading π/2 − 0.3
    _, _, y = enu_flu_to_ned_frd(0.0, 0.0, math.sin(0.15), math.cos(0.15))
    assert float(y) == pytest.approx(math.pi / 2 - 0.3, abs=1e-12)
    # nose up: a rotation about FLU y (left) by −0.2 is pitch +0.2 in FRD/NED
    _, p, _ = enu_flu_to_ned_frd(0.0, math.sin(-0.1), 0.0, math.cos(-0.1))
    assert float(p) == pytest.approx(0.2, abs=1e-12)
    # and the round trip through mavros' own composition of static rotations
    rng = np.random.default_rng(1)
    for _ in range(20):
        rpy = (rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-math.pi, math.pi))
        w, x, yq, z = mavros_orientation(*rpy)
        got = [float(a) for a in enu_flu_to_ned_frd(x, yq, z, w)]
        assert got == pytest.approx(list(rpy), abs=1e-9)


# ------------------------------------------------------------------------------ writing bags
def _qos():
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    zero = QosTime(0, 0)
    return Qos(QosHistory.KEEP_LAST, 10, QosReliability.RELIABLE, QosDurability.VOLATILE, zero, zero,
               QosLiveliness.AUTOMATIC, zero, False)


_QOS = _qos()


def _store(ros):
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC if ros == 1 else Stores.ROS2_HUMBLE)
    ts.register({**get_types_from_msg(RCOUT, "mavros_msgs/msg/RCOut"),
                 **get_types_from_msg(STATE, "mavros_msgs/msg/State")})
    return ts


def _default(ts, typ: str):
    if typ == "float":
        return 0.0
    if typ == "int":
        return 0
    if typ == "bool":
        return False
    if typ == "str":
        return ""
    if typ.startswith("np.ndarray"):
        return np.zeros(0, np.float32)
    raise AssertionError(typ)


def _msg(ts, name, **given):
    cls = ts.types[name]
    kw = {f.name: given[f.name] if f.name in given else _default(ts, f.type)
          for f in dataclasses.fields(cls) if not f.type.startswith("ClassVar")}
    return cls(**kw)


def write_bag(path, ros, df, *, omit=(), depth_topic=None, storage="sqlite3", pressure=None,
              twist=None, mutate=None):
    """The dive ``df`` (a synthetic_dive table) as mavros would record it (see the module doc).
    ``pressure``: also ``/mavros/imu/static_pressure`` (sensor_msgs/FluidPressure), this surface
    pressure [Pa] + 1000 kg/m³ · g · depth; ``twist``: ``(topic, type)`` of a DVL velocity
    (TwistStamped or Odometry) with linear = (0.1 t, 0.2, 0) and header stamps left at zero;
    ``mutate(out, ts, hdr)``: a trap, applied to the ``[receive ns, topic, message]`` list."""
    ts = _store(ros)
    if ros == 1:
        from rosbags.rosbag1 import Writer

        writer, ser = Writer(path), ts.serialize_ros1
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer, ser = Writer(path, version=9, storage_plugin=plugin), ts.serialize_cdr
    Time, Header = ts.types["builtin_interfaces/msg/Time"], ts.types["std_msgs/msg/Header"]
    Quat, Vec = ts.types["geometry_msgs/msg/Quaternion"], ts.types["geometry_msgs/msg/Vector3"]

    def hdr(ns):
        return Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="base_link",
                      **({"seq": 0} if ros == 1 else {}))

    def ns(t):
        return T0 + int(round(float(t) * 1e9))

    t = df["t_s"].to_numpy(float)
    out = []  # (receive ns, topic, message)
    rows = df["pwm_1"].notna().to_numpy()
    pwm = df.loc[rows, [f"pwm_{j}" for j in range(1, 7)]].to_numpy(float)
    logged = np.round(1500 + np.asarray(DIRECTIONS, float) * (pwm - 1500))  # ArduSub reflects
    rc = []
    for k, (ti, row) in enumerate(zip(t[rows], logged)):
        ch = np.zeros(8, np.uint16)  # outputs 7 and 8: disabled, 0 µs
        ch[:6] = row
        m = _msg(ts, "mavros_msgs/msg/RCOut", header=hdr(ns(ti)), channels=ch)
        rc.append([ns(ti) + OFFSET, "/mavros/rc/out", m])
        if k % 50 == 7:  # the same message twice
            rc.append([ns(ti) + OFFSET + 1_000_000, "/mavros/rc/out", m])
    for k in range(10, len(rc) - 1, 97):  # arrivals swapped: header stamps out of bag order
        rc[k][0], rc[k + 1][0] = rc[k + 1][0], rc[k][0]
    out += rc
    rows = df["yaw_rad"].notna().to_numpy()
    for ti, r, p, y in zip(t[rows], *(df.loc[rows, c].to_numpy(float)
                                      for c in ("roll_rad", "pitch_rad", "yaw_rad"))):
        w, x, yq, z = mavros_orientation(r, p, y)
        imu = _msg(ts, "sensor_msgs/msg/Imu", header=hdr(ns(ti)),
                   orientation=Quat(x=x, y=yq, z=z, w=w), orientation_covariance=np.zeros(9),
                   angular_velocity=Vec(x=0.0, y=0.0, z=0.0), angular_velocity_covariance=np.zeros(9),
                   linear_acceleration=Vec(x=0.0, y=0.0, z=9.8),
                   linear_acceleration_covariance=np.zeros(9))
        out.append([ns(ti) + OFFSET, "/mavros/imu/data", imu])
    rows = df["depth_m"].notna().to_numpy()
    F64 = ts.types["std_msgs/msg/Float64"]
    for k, (ti, d) in enumerate(zip(t[rows], df.loc[rows, "depth_m"].to_numpy(float))):
        if depth_topic:
            out.append([ns(ti) + OFFSET, depth_topic, F64(data=float(d))])
        else:  # rel_alt: altitude, up, no header: only the receive time
            out.append([ns(ti) + OFFSET, "/mavros/global_position/rel_alt", F64(data=-float(d))])
            if k % 40 == 3:
                out.append(out[-1])
    if pressure is not None:
        for ti, d in zip(t[rows], df.loc[rows, "depth_m"].to_numpy(float)):
            fp = _msg(ts, "sensor_msgs/msg/FluidPressure", header=hdr(ns(ti)),
                      fluid_pressure=pressure + 1000.0 * 9.80665 * d)
            out.append([ns(ti) + OFFSET, "/mavros/imu/static_pressure", fp])
    if twist is not None:
        Tw = ts.types["geometry_msgs/msg/Twist"]
        for ti in np.arange(1.0, t.max(), 0.2):
            tw = Tw(linear=Vec(x=0.1 * ti, y=0.2, z=0.0), angular=Vec(x=0.0, y=0.0, z=0.0))
            if twist[1] == "geometry_msgs/msg/TwistStamped":
                m = _msg(ts, twist[1], header=hdr(0), twist=tw)
            else:
                TwC = ts.types["geometry_msgs/msg/TwistWithCovariance"]
                PoC = ts.types["geometry_msgs/msg/PoseWithCovariance"]
                Pose, Pt = ts.types["geometry_msgs/msg/Pose"], ts.types["geometry_msgs/msg/Point"]
                pose = PoC(pose=Pose(position=Pt(x=0.0, y=0.0, z=0.0),
                                     orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0)),
                           covariance=np.zeros(36))
                m = _msg(ts, twist[1], header=hdr(0), child_frame_id="base_link", pose=pose,
                         twist=TwC(twist=tw, covariance=np.zeros(36)))
            out.append([ns(ti) + OFFSET, twist[0], m])
    rows = df["battery_V"].notna().to_numpy()
    for ti, v in zip(t[rows], df.loc[rows, "battery_V"].to_numpy(float)):
        out.append([ns(ti) + OFFSET, "/mavros/battery",
                    _msg(ts, "sensor_msgs/msg/BatteryState", header=hdr(ns(ti)), voltage=v)])
    # state: on every change of armed or mode, and about once a second (mavros: each HEARTBEAT)
    armed, mode = df["armed"].to_numpy(bool), df["mode"].astype(str).to_numpy()
    change = np.concatenate(([True], (armed[1:] != armed[:-1]) | (mode[1:] != mode[:-1])))
    beat = np.concatenate(([True], np.floor(t[1:]) != np.floor(t[:-1])))
    for i in np.flatnonzero(change | beat):
        st = _msg(ts, "mavros_msgs/msg/State", header=hdr(ns(t[i])), connected=True,
                  armed=bool(armed[i]), mode=str(mode[i]))
        out.append([ns(t[i]) + OFFSET, "/mavros/state", st])
    types = {"/mavros/rc/out": "mavros_msgs/msg/RCOut", "/mavros/imu/data": "sensor_msgs/msg/Imu",
             "/mavros/global_position/rel_alt": "std_msgs/msg/Float64",
             "/mavros/battery": "sensor_msgs/msg/BatteryState",
             "/mavros/state": "mavros_msgs/msg/State"}
    if depth_topic:
        types[depth_topic] = "std_msgs/msg/Float64"
    if pressure is not None:
        types["/mavros/imu/static_pressure"] = "sensor_msgs/msg/FluidPressure"
    if twist is not None:
        types[twist[0]] = twist[1]
    short = {"/mavros/rc/out": "rc", "/mavros/imu/data": "imu",
             "/mavros/global_position/rel_alt": "rel_alt", "/mavros/battery": "battery",
             "/mavros/state": "state"}
    out = [m for m in out if short.get(m[1]) not in omit]
    if mutate is not None:
        mutate(out, ts, hdr)
    out.sort(key=lambda m: m[0])
    # a "topic#node" entry is a second publisher on the topic: its own connection (callerid) in
    # ROS 1; in ROS 2 the same connection, whose metadata then lists two publishers
    second = {m[1].partition("#")[0]: m[1].partition("#")[2] for m in out if "#" in m[1]}
    with writer as w:
        if ros == 1:
            conns = {tp: w.add_connection(tp, mt, typestore=ts, callerid="/mavros")
                     for tp, mt in types.items() if short.get(tp) not in omit}
            conns.update({f"{tp}#{node}": w.add_connection(tp, types[tp], typestore=ts, callerid=node)
                          for tp, node in second.items()})
        else:
            conns = {tp: w.add_connection(tp, mt, typestore=ts,
                                          offered_qos_profiles=[_QOS] * (2 if tp in second else 1))
                     for tp, mt in types.items() if short.get(tp) not in omit}
            conns.update({f"{tp}#{node}": conns[tp] for tp, node in second.items()})
        for recv, tp, m in out:
            w.write(conns[tp], recv, ser(m, types[tp.partition("#")[0]]))
    return path


# --------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def dive():
    df, truth = synthetic_dive(240.0, seed=7, pwm_rate=10.0, surge=0.0)
    return df, truth


@pytest.fixture(scope="module")
def bag1(dive, tmp_path_factory):
    return write_bag(tmp_path_factory.mktemp("ros1") / "dive.bag", 1, dive[0])


@pytest.fixture(scope="module")
def params_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("prm") / "bluerov2.params"
    p.write_text(PARAM_TEXT)
    return p


@pytest.fixture(scope="module")
def from_bag(bag1, params_file):
    return identify_dive(bag1, "bluerov2", params=params_file)


@pytest.fixture(scope="module")
def from_csv(dive):
    df, _ = dive
    # the same table with t = 0 at its first sample, as the bag's t = 0 is its first message
    return identify_dive(df.assign(t_s=df["t_s"] - df["t_s"].min()), "bluerov2")


@pytest.mark.slow
def test_bag_gives_the_csv_estimates_and_the_truth_within_3_sigma(dive, from_bag, from_csv):
    _, truth = dive
    for dof in ("heave", "yaw"):
        b, c = from_bag.estimates[dof], from_csv.estimates[dof]
        for k in PARAMS:
            # the same data: the same estimate, far inside σ
            assert abs(b.values[k] - c.values[k]) <= 0.05 * c.sigma[k], (dof, k, b.values[k],
                                                                         c.values[k], c.sigma[k])
            assert abs(b.values[k] - truth[dof][k]) <= 3 * b.sigma[k], (dof, k, b.values[k],
                                                                        b.sigma[k], truth[dof][k])
    w = " ".join(from_bag.warnings)
    assert "reversed (MOT_n_DIRECTION = -1): motor(s) 1, 2, 4, 5" in w
    assert "outputs 7, 8 are 0 µs throughout (disabled)" in w
    assert "/mavros/global_position/rel_alt: receive time (the message has no header), moved by " \
           "-0.250 s" in w
    assert "/mavros/rc/out: header.stamp" in w
    assert "merged samples with duplicated time stamps" in w
    assert "/mavros/rc/out (pwm): 48" in w  # every 50th of 2400 messages written twice


@pytest.mark.slow
def test_the_traps_matter(bag1, dive, from_csv):
    """Without the reversal the forces are wrong (and the reader says it assumed +1); the
    disarmed start is not armed; the heading is the NED one the dive flew."""
    df, _ = dive
    dc = read_dive_channels(bag1, "bluerov2")
    w = " ".join(dc.warnings)
    assert "MOT_n_DIRECTION not given" in w and "+1 (normal) assumed" in w
    assert "no FRAME_CONFIG given" in w
    ok = read_dive_channels(bag1, "bluerov2", params={f"MOT_{j}_DIRECTION": d
                                                      for j, d in enumerate(DIRECTIONS, 1)})
    z_wrong, z_ok = dc.channels["Z_N"][1], ok.channels["Z_N"][1]
    assert np.max(np.abs(z_wrong - z_ok)) > 10.0
    rows = df["Z_N"].notna().to_numpy()
    np.testing.assert_allclose(z_ok, df.loc[rows, "Z_N"].to_numpy(), atol=1e-9)
    t0 = df["t_s"].min()
    first_armed = df.loc[df["armed"], "t_s"].min() - t0
    assert ok.armed[0][0] == pytest.approx(first_armed, abs=1e-6)
    assert ok.armed[-1][1] == pytest.approx(df["t_s"].max() - t0, abs=1e-6)
    ty, yaw = ok.channels["yaw_rad"]
    rows = df["yaw_rad"].notna().to_numpy()
    np.testing.assert_allclose(ty, df.loc[rows, "t_s"].to_numpy() - t0, atol=1e-9)
    np.testing.assert_allclose(yaw, np.unwrap(df.loc[rows, "yaw_rad"].to_numpy()), atol=1e-9)
    assert "ENU" in ok.sources["yaw_rad"] and "rel_alt" in ok.sources["depth_m"]
    assert {m for _a, _b, m in ok.modes} == {"MANUAL", "STABILIZE", "ALT_HOLD"}
    # with FRAME_CONFIG the vehicle is checked against ArduSub's frame: bluerov2 is frame 1 …
    frame = read_dive_channels(bag1, "bluerov2", params={"FRAME_CONFIG": 1, **{
        f"MOT_{j}_DIRECTION": d for j, d in enumerate(DIRECTIONS, 1)}})
    np.testing.assert_allclose(frame.channels["Z_N"][1], z_ok)
    assert not any("no FRAME_CONFIG given" in x for x in frame.warnings)
    # … and not the Heavy's frame 2 (8 motors)
    with pytest.raises(DiveDataError, match="FRAME_CONFIG = 2"):
        read_dive_channels(bag1, "bluerov2", params={"FRAME_CONFIG": 2})


@pytest.mark.slow
@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_ros2_bag_reads_as_the_ros1_bag(dive, bag1, tmp_path, storage, params_file):
    df, _ = dive
    bag2 = write_bag(tmp_path / "dive2", 2, df, storage=storage)
    a = read_dive_channels(bag1, "bluerov2", params=params_file)
    b = read_dive_channels(bag2, "bluerov2", params=params_file)
    assert b.format == "rosbag2" and a.format == "rosbag1"
    assert set(a.channels) == set(b.channels)
    for c in a.channels:
        np.testing.assert_array_equal(a.channels[c][0], b.channels[c][0])
        np.testing.assert_allclose(a.channels[c][1], b.channels[c][1], rtol=1e-6)
    assert a.armed == b.armed


def _short(dive):
    df, _ = dive
    return df[df["t_s"] < 20.0]


@pytest.mark.slow
@pytest.mark.parametrize("omit,topic,option", [
    (("rc",), "/mavros/rc/out", "--topic pwm=TOPIC:FIELD"),
    (("rel_alt",), "/mavros/global_position/rel_alt", "--topic depth=TOPIC:FIELD"),
    (("imu",), "/mavros/imu/data", "--topic yaw=TOPIC:FIELD"),
])
def test_a_bag_without_a_needed_topic_says_what_is_missing(dive, tmp_path, omit, topic, option):
    bag = write_bag(tmp_path / "short.bag", 1, _short(dive), omit=omit)
    with pytest.raises(DiveDataError) as e:
        read_dive_channels(bag, "bluerov2")
    msg = str(e.value)
    assert msg.startswith("short.bag: no ") and f"no topic {topic}" in msg
    assert option in msg
    present = [t for t in ("/mavros/rc/out (mavros_msgs/msg/RCOut",
                           "/mavros/imu/data (sensor_msgs/msg/Imu",
                           "/mavros/battery (sensor_msgs/msg/BatteryState") if t.split()[0] != topic]
    for t in present:
        assert t in msg


@pytest.mark.slow
def test_depth_from_the_pressure_topic(dive, tmp_path):
    """No rel_alt: depth from mavros' static_pressure, surface = the bag's 5th lowest pressure (a
    warning) or BARO1_GND_PRESS from the parameters; a pressure that does not vary is refused."""
    df = _short(dive)
    bag = write_bag(tmp_path / "p.bag", 1, df, omit=("rel_alt",), pressure=101325.0)
    rows = df["depth_m"].notna().to_numpy()
    depth = df.loc[rows, "depth_m"].to_numpy()
    dc = read_dive_channels(bag, "bluerov2")
    k = min(4, depth.size // 20)  # the 5th lowest sample; in this short bag (59) the 3rd
    np.testing.assert_allclose(dc.channels["depth_m"][1], depth - np.partition(depth, k)[k],
                               atol=1e-9)
    w = " ".join(dc.warnings)
    assert "depth from /mavros/imu/static_pressure (default)" in w
    assert "the bag's lowest pressure" in w and "ρ = 1000 kg/m³" in w
    dc = read_dive_channels(bag, "bluerov2", params={"BARO1_GND_PRESS": 101325.0})
    np.testing.assert_allclose(dc.channels["depth_m"][1], depth, atol=1e-9)
    sea = read_dive_channels(bag, "bluerov2", params={"BARO1_GND_PRESS": 101325.0,
                                                      "BARO_SPEC_GRAV": 1.025})
    np.testing.assert_allclose(sea.channels["depth_m"][1], depth / 1.025, atol=1e-9)
    flat = write_bag(tmp_path / "enclosure.bag", 1, df.assign(depth_m=1.0), omit=("rel_alt",),
                     pressure=101325.0)
    with pytest.raises(DiveDataError, match="not the water pressure.*--topic depth="):
        read_dive_channels(flat, "bluerov2")


@pytest.mark.slow
@pytest.mark.parametrize("msgtype", ["geometry_msgs/msg/TwistStamped", "nav_msgs/msg/Odometry"])
def test_dvl_velocity_topic_and_zero_header_stamps(dive, tmp_path, msgtype):
    """A body velocity topic (FLU, REP 103) gives u = x, v = −y; its header stamps are zero, so
    the receive times are used, moved onto the servo outputs' header clock."""
    bag = write_bag(tmp_path / "dvl.bag", 1, _short(dive), twist=("/dvl/twist", msgtype))
    dc = read_dive_channels(bag, "bluerov2", topics=["velocity=/dvl/twist"])
    tu, u = dc.channels["u_mps"]
    t0 = _short(dive)["t_s"].min()
    np.testing.assert_allclose(u, 0.1 * (tu + t0), atol=1e-9)  # back on the header clock
    np.testing.assert_allclose(dc.channels["v_mps"][1], -0.2)
    w = " ".join(dc.warnings)
    assert "/dvl/twist: receive time (header.stamp is zero in" in w and "moved by -0.250 s" in w


@pytest.mark.slow
def test_bad_options_and_wrong_vehicle(dive, tmp_path):
    bag = write_bag(tmp_path / "short.bag", 1, _short(dive))
    with pytest.raises(DiveDataError, match="unknown role 'dpeth'"):
        read_dive_channels(bag, "bluerov2", topics=["dpeth=/x:data"])
    with pytest.raises(DiveDataError, match="no topic /my/depth.*--topic depth="):
        read_dive_channels(bag, "bluerov2", topics={"depth": "/my/depth:data"})
    with pytest.raises(DiveDataError, match="has 8 thrusters.*drives 6 motors"):
        read_dive_channels(bag, "bluerov2-heavy")
    with pytest.raises(DiveDataError, match="no field 'chanels'"):
        read_dive_channels(bag, "bluerov2", topics=["pwm=/mavros/rc/out:chanels"])
    with pytest.raises(DiveDataError, match="--topic applies to ROS bags only"):
        read_dive_channels(dive[0], "bluerov2", topics=["depth=/x"])


@pytest.mark.slow
def test_cli_identify_dive_and_replay_from_a_bag(dive, tmp_path, params_file):
    """A depth sensor on its own topic (positive down) given with --topic; ArduSub's reversal with
    --params; then replay the bag with the identified vehicle."""
    df, _ = dive
    bag = write_bag(tmp_path / "bar30.bag", 1, df, omit=("rel_alt",), depth_topic="/bar30/depth")
    out = tmp_path / "mine.yaml"
    res = runner.invoke(app, ["vehicle", "identify", "dive", str(bag), "--vehicle", "bluerov2",
                              "--dof", "heave", "--t-end", "190", "--params", str(params_file),
                              "--topic", "depth=/bar30/depth:data", "--out-vehicle", str(out),
                              "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["dofs"]["heave"]["held_out"]["improvement"] > 2 and out.is_file()
    assert any("/bar30/depth" in w for w in doc["warnings"])
    res = runner.invoke(app, ["vehicle", "replay", str(bag), "--vehicle", str(out), "--dof",
                              "heave", "--t-start", "190", "--params", str(params_file),
                              "--topic", "depth=/bar30/depth", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["channels"]["depth"]["rms"] < 0.03
    res = runner.invoke(app, ["vehicle", "replay", str(bag), "--vehicle", "bluerov2"])
    assert res.exit_code == 2 and "no topic /mavros/global_position/rel_alt" in res.output
    assert "--topic depth=" in res.output


@pytest.mark.slow
def test_replay_reads_the_bag_like_the_table(bag1, dive, params_file):
    df, _ = dive
    a = replay_dive(bag1, "bluerov2", ["heave"], params=params_file, t_start=150.0)
    b = replay_dive(df.assign(t_s=df["t_s"] - df["t_s"].min()), "bluerov2", ["heave"],
                    t_start=150.0)
    assert a.channels["depth"]["rms"] == pytest.approx(b.channels["depth"]["rms"], rel=1e-6)


# ------------------------------------------------------------------ traps a real bag holds
def _every(topic, k):
    def pick(out):
        return [m for m in out if m[1] == topic][::k]
    return pick


def _short_rc(out, ts, hdr):
    """Every 4th servo-output message with 4 channels (a publisher's short frame)."""
    for m in _every("/mavros/rc/out", 4)(out):
        m[2] = _msg(ts, "mavros_msgs/msg/RCOut", header=m[2].header,
                    channels=np.asarray(m[2].channels[:4], np.uint16))


def _cell_voltage(out, ts, hdr):
    for m in _every("/mavros/battery", 1)(out):
        m[2] = _msg(ts, "sensor_msgs/msg/BatteryState", header=m[2].header,
                    voltage=m[2].voltage / 4.0)


def _uninitialised_imu(out, ts, hdr):
    Quat = ts.types["geometry_msgs/msg/Quaternion"]
    for m in [m for m in out if m[1] == "/mavros/imu/data"][:30]:
        m[2] = dataclasses.replace(m[2], orientation=Quat(x=0.0, y=0.0, z=0.0, w=0.0))


def _reboot(out, ts, hdr):
    """From 100 s on the IMU stamps time since its boot (the autopilot rebooted)."""
    for m in out:
        if m[1] == "/mavros/imu/data" and m[0] - OFFSET >= T0 + 100 * 10**9:
            m[2] = dataclasses.replace(m[2], header=hdr(m[0] - OFFSET - T0 - 90 * 10**9))


@pytest.mark.slow
def test_short_servo_frames_are_left_out_not_read_as_no_thrust(dive, tmp_path, params_file):
    """Every 4th /mavros/rc/out message with 4 channels: the missing outputs were NaN, then 0 µs
    ("no thrust"), and heave mass came out −25 % with nothing said."""
    _, truth = dive
    bag = write_bag(tmp_path / "short.bag", 1, dive[0], mutate=_short_rc)
    res = identify_dive(bag, "bluerov2", ["heave"], params=params_file)
    assert any("/mavros/rc/out messages hold fewer than the 6 channels the motors use" in w
               and "left out, not read as 0 µs" in w for w in res.warnings), res.warnings
    e = res.estimates["heave"]
    assert abs(e.values["mass"] / truth["heave"]["mass"] - 1) < 0.1, e.values


@pytest.mark.slow
def test_a_bag_gets_the_tables_unit_checks_naming_its_topic(dive, tmp_path):
    bag = write_bag(tmp_path / "cells.bag", 1, _short(dive), mutate=_cell_voltage)
    with pytest.raises(DiveDataError, match=r"battery_V has median [34]\.\d+, outside 6–60 V .*one "
                                            r"cell's voltage.*\(read from /mavros/battery"):
        read_dive_channels(bag, "bluerov2")


@pytest.mark.slow
def test_quaternions_of_an_uninitialised_imu_are_left_out(dive, tmp_path):
    """Zeros from an IMU not yet initialised became NaN headings and a LinAlgError traceback."""
    bag = write_bag(tmp_path / "q0.bag", 1, dive[0], mutate=_uninitialised_imu)
    dc = read_dive_channels(bag, "bluerov2")
    assert any("30 /mavros/imu/data quaternions are not rotations" in w for w in dc.warnings)
    assert np.all(np.isfinite(dc.channels["yaw_rad"][1]))
    identify_dive(bag, "bluerov2", ["yaw"])


@pytest.mark.slow
def test_a_sender_stamping_time_since_boot_is_refused_as_a_restart_and_a_clock_set_forward_as_a_jump(
        dive, tmp_path):
    """An autopilot rebooted mid-bag and stamped time since boot: 10⁹ s of "dive" ran out of
    memory in the direction check and would have cut 10⁸ windows.  Its stamps go back: refused
    naming the IMU's first message since the reboot (the clock check said only that receive time
    − stamp changes).  Stamps that jump forward go back nowhere: the clock check says it."""
    df = dive[0]
    bag = write_bag(tmp_path / "boot.bag", 1, df, mutate=_reboot)
    k = int((df.loc[df["yaw_rad"].notna(), "t_s"] < 100.0).sum()) + 1
    with pytest.raises(DiveDataError, match=rf"/mavros/imu/data \(attitude\): header stamps go back "
                                            rf"at message {k} \(.* stamped 10\.0\d+ s after "
                                            r"1700000099\.9\d+ s, 1\.7e\+09 s back"):
        read_dive_channels(bag, "bluerov2")
    ahead = write_bag(tmp_path / "ahead.bag", 1, _short(dive), mutate=_stamps_step(60.0, 10.0))
    with pytest.raises(DiveDataError, match=r"/mavros/rc/out: receive time − header stamp "
                                            r"changes by 60 s within the bag .*a clock jumped mid-bag"):
        read_dive_channels(ahead, "bluerov2")


def _restart(topic, at_s, back_s, seen):
    """From receive time ``at_s`` [s] on, ``topic``'s header stamps are ``back_s`` s earlier (its
    sender restarted, or a second recording was joined on); ``seen`` gets the topic's number of the
    first such message and the receive times [ns] of it and of the message before it."""
    def restart(out, ts, hdr):
        mine = sorted((m for m in out if m[1] == topic), key=lambda m: m[0])
        for k, m in enumerate(mine, 1):
            if m[0] >= T0 + OFFSET + int(at_s * 1e9):
                if not seen:
                    seen.update(index=k, recv=m[0], recv_before=mine[k - 2][0])
                st = m[2].header.stamp
                m[2] = dataclasses.replace(m[2], header=hdr(st.sec * 10**9 + st.nanosec
                                                            - int(back_s * 1e9)))
    return restart


@pytest.mark.slow
@pytest.mark.parametrize("topic,role,at_s,back_s", [
    ("/mavros/imu/data", "attitude", 19.8, 5.0),  # its last 1 %: the clock check let it through
    ("/mavros/rc/out", "pwm", 10.0, 60.0),  # mid-bag: the clock check said no more than "changes"
    ("/mavros/battery", "battery", 10.0, 30.0),  # 20 messages, too few for the clock check
])
def test_header_stamps_that_restart_are_refused_naming_the_message_and_where_to_cut(
        dive, tmp_path, topic, role, at_s, back_s):
    """Header stamps going back by much more than their step and staying back, as a table's time
    column that restarts is refused: sorted, the two parts interleaved into one series (the last
    1 % of the IMU's messages were sorted in silently, 5 s early)."""
    seen: dict = {}
    bag = write_bag(tmp_path / "restart.bag", 1, _short(dive), mutate=_restart(topic, at_s, back_s, seen))
    with pytest.raises(DiveDataError) as e:
        read_dive_channels(bag, "bluerov2")
    msg = str(e.value)
    assert msg.startswith(f"restart.bag: {topic} ({role}): header stamps go back at message "
                          f"{seen['index']} (received at bag time {seen['recv'] / 1e9:.6f} s"), msg
    m = re.search(r"stamped (\d+\.\d+) s after (\d+\.\d+) s, ([\d.]+) s back where the typical step "
                  r"is ([\d.]+) s — the sender restarted", msg)
    assert m, msg
    back, step = float(m[3]), float(m[4])
    assert float(m[2]) - float(m[1]) == pytest.approx(back, rel=1e-5)
    assert back_s - 3 * step < back <= back_s and 20 * step < back
    cut = re.search(r'rosbag filter IN OUT "t\.to_sec\(\) < (\d+\.\d+)", or >= it', msg)
    assert cut and seen["recv_before"] / 1e9 < float(cut[1]) < seen["recv"] / 1e9, msg


def _late_arrivals(out, ts, hdr):
    """Every 40th IMU message received 0.7 s late (14 messages later; its stamp intact)."""
    for m in [m for m in out if m[1] == "/mavros/imu/data"][5::40]:
        m[0] += 700_000_000


@pytest.mark.slow
def test_stamps_a_few_steps_out_of_order_are_sorted_not_refused(dive, tmp_path):
    """Late arrivals put the IMU's stamps up to 0.7 s (14 steps) back in receive order: under the
    restart limit (20 steps and 1 s), sorted into place — the heading is the in-order bag's."""
    one = read_dive_channels(write_bag(tmp_path / "one.bag", 1, _short(dive)), "bluerov2")
    late = read_dive_channels(write_bag(tmp_path / "late.bag", 1, _short(dive),
                                        mutate=_late_arrivals), "bluerov2")
    for c in ("yaw_rad", "roll_rad", "pitch_rad"):
        np.testing.assert_array_equal(late.channels[c][0], one.channels[c][0])
        np.testing.assert_array_equal(late.channels[c][1], one.channels[c][1])


def _one_stamp(days):
    def far(out, ts, hdr):
        m = [m for m in out if m[1] == "/mavros/imu/data"][-5]
        m[2] = dataclasses.replace(m[2], header=hdr(m[0] - OFFSET - T0 + int(days * 86400e9)))
    return far


@pytest.mark.slow
@pytest.mark.parametrize("days", [1, 30, 3650])
def test_one_corrupt_stamp_is_left_out_not_taken_for_a_clock_jump(dive, tmp_path, days):
    clean = read_dive_channels(write_bag(tmp_path / "c.bag", 1, _short(dive)), "bluerov2")
    dc = read_dive_channels(write_bag(tmp_path / "o.bag", 1, _short(dive), mutate=_one_stamp(days)),
                            "bluerov2")
    assert any("1 /mavros/imu/data (attitude) sample(s) stamped far outside the rest" in w
               for w in dc.warnings), dc.warnings
    assert dc.channels["yaw_rad"][0].size == clean.channels["yaw_rad"][0].size - 1


def _pause(a, b, topics=None):
    def drop(out, ts, hdr):
        lo, hi = T0 + a * 10**9 + OFFSET, T0 + b * 10**9 + OFFSET
        out[:] = [m for m in out if not (lo <= m[0] < hi and (topics is None or m[1] in topics))]
    return drop


@pytest.mark.slow
def test_a_pause_in_a_bag_is_said_and_a_force_dropout_leaves_its_windows_out(dive, tmp_path):
    """A 60 s recording pause was said for tables, not bags; an 8 s dropout of the servo outputs
    inside a 10 s heave window was interpolated across (the linear drag's σ ×3)."""
    bag = write_bag(tmp_path / "pause.bag", 1, dive[0], mutate=_pause(100, 160))
    dc = read_dive_channels(bag, "bluerov2")
    assert any(re.search(r"/mavros/rc/out \(pwm\) stops for 60\.\d+ s \(from t = 99\.\d+ s\)", w)
               for w in dc.warnings), dc.warnings
    bag = write_bag(tmp_path / "rc8.bag", 1, dive[0], mutate=_pause(100, 108, {"/mavros/rc/out"}))
    from uuvid.simulate.dive_replay import dive_windows

    windows, _ = dive_windows(read_dive_channels(bag, "bluerov2"), "heave", 10.0)
    assert windows and not any(s < 108.0 and e > 100.0 for s, e in windows), windows


def _conflicting_rc(every):
    def dup(out, ts, hdr):
        for m in _every("/mavros/rc/out", every)(out):
            ch = np.asarray(m[2].channels, np.uint16).copy()
            ch[4] = 1500 + (int(ch[4]) - 1500) // 2  # another value at the same header stamp
            out.append([m[0] + 2_000_000, m[1], _msg(ts, "mavros_msgs/msg/RCOut",
                                                      header=m[2].header, channels=ch)])
    return dup


@pytest.mark.slow
def test_conflicting_samples_at_one_stamp_are_said_and_refused_when_many(dive, tmp_path):
    """A second publisher re-stamping servo outputs: merged silently, heave mass −7 σ."""
    bag = write_bag(tmp_path / "few.bag", 1, _short(dive), mutate=_conflicting_rc(50))
    dc = read_dive_channels(bag, "bluerov2")
    assert any(re.search(r"/mavros/rc/out \(pwm\): \d+ of \d+ samples share a time stamp with "
                         r"another of different value .*: merged", w) for w in dc.warnings)
    bag = write_bag(tmp_path / "many.bag", 1, _short(dive), mutate=_conflicting_rc(5))
    with pytest.raises(DiveDataError, match=r"share a time stamp .* expected one value per stamp"):
        read_dive_channels(bag, "bluerov2")


@pytest.mark.slow
def test_log_commands_point_a_bag_to_the_commands_that_read_it(bag1, dive, tmp_path):
    """`uuvid log inspect` said "unknown log type '.bag'" of a bag and "no such log file" of a ROS 2
    bag folder; both name the commands that read a dive's bag."""
    r2 = write_bag(tmp_path / "r2", 2, _short(dive))
    for bag in (bag1, r2):
        res = CliRunner().invoke(app, ["log", "inspect", str(bag)])
        assert res.exit_code != 0 and "a ROS bag; `uuvid log` reads ArduSub logs" in res.output
        assert "uuvid vehicle identify dive" in res.output


def _imu_clock(offset_s):
    def shift(out, ts, hdr):
        for m in out:
            if m[1] == "/mavros/imu/data":
                m[2] = dataclasses.replace(m[2], header=hdr(m[0] - OFFSET + int(offset_s * 1e9)))
    return shift


@pytest.mark.slow
@pytest.mark.parametrize("offset", [0.3, -0.5])
def test_a_sender_clock_off_by_a_fraction_of_a_second_is_moved_onto_the_servo_clock(
        dive, tmp_path, offset):
    """The IMU's clock 0.3 s off the autopilot's: left in place under a 1 s threshold, it gave yaw
    inertia −60 % with nothing said.  Moved by its median receive − stamp, the heading's times
    equal those of the same bag with one clock."""
    clean = read_dive_channels(write_bag(tmp_path / "c.bag", 1, _short(dive)), "bluerov2")
    off = read_dive_channels(write_bag(tmp_path / "o.bag", 1, _short(dive),
                                       mutate=_imu_clock(offset)), "bluerov2")
    np.testing.assert_allclose(off.channels["yaw_rad"][0], clean.channels["yaw_rad"][0], atol=2e-3)
    moved = re.escape(f"/mavros/imu/data: header.stamp, moved by {-offset:+.3f} s onto the clock of "
                      "/mavros/rc/out")
    assert any(re.search(moved, w) for w in off.warnings), off.warnings


def _second_imu(frame, yaw_offset=0.3, lag_ns=5_000_000, node="/imu2"):
    """A second IMU on /mavros/imu/data (node ``node``, ``None``: the first's own connection, its
    frame ``frame``), its heading ``yaw_offset`` rad off and its stamps ``lag_ns`` later (no stamp
    shared with the first: not a conflict), every tenth of its messages missing (fewer messages
    than the first)."""
    topic = "/mavros/imu/data" + (f"#{node}" if node else "")

    def add(out, ts, hdr):
        Quat = ts.types["geometry_msgs/msg/Quaternion"]
        for i, m in enumerate([m for m in out if m[1] == "/mavros/imu/data"]):
            if i % 10 == 9:
                continue
            q = m[2].orientation
            c, s = math.cos(yaw_offset / 2), math.sin(yaw_offset / 2)  # about ENU up: NED +offset
            w, x, y, z = _qmul((c, 0.0, 0.0, -s), (q.w, q.x, q.y, q.z))
            st = m[2].header.stamp
            ns = st.sec * 10**9 + st.nanosec + lag_ns
            h = hdr(ns)
            h = dataclasses.replace(h, frame_id=frame)
            out.append([m[0] + lag_ns, topic,
                        dataclasses.replace(m[2], header=h, orientation=Quat(x=x, y=y, z=z, w=w))])
    return add


@pytest.mark.slow
@pytest.mark.parametrize("ros", [1, 2])
def test_a_second_imu_on_the_topic_is_left_out_and_said(dive, tmp_path, ros):
    """Two IMUs on /mavros/imu/data, headings 0.3 rad apart, stamps 5 ms apart: merged they made a
    saw-tooth heading (yaw rate ±0.3 rad per 5 ms).  The one with the most messages is read — the
    heading equals the one-IMU bag's — and the other is said; ``@SOURCE`` reads the other."""
    ext = ".bag" if ros == 1 else ""  # a ROS 2 bag is a folder
    one = read_dive_channels(write_bag(tmp_path / f"one{ext}", ros, _short(dive)), "bluerov2")
    bag = write_bag(tmp_path / f"two{ext}", ros, _short(dive), mutate=_second_imu("imu2_link"))
    dc = read_dive_channels(bag, "bluerov2")
    said = [w for w in dc.warnings if "2 publishers" in w]
    assert said and "imu2_link" in said[0] and "left out" in said[0], dc.warnings
    assert ("node /mavros" in said[0]) == (ros == 1)
    t1, y1 = one.channels["yaw_rad"]
    t2, y2 = dc.channels["yaw_rad"]
    np.testing.assert_array_equal(t2, t1)
    np.testing.assert_array_equal(y2, y1)
    assert "(the one with the most messages)" in said[0]
    for pick in (["imu2_link"] + (["/imu2"] if ros == 1 else [])):
        other = read_dive_channels(bag, "bluerov2",
                                   topics={"attitude": f"/mavros/imu/data@{pick}"})
        t3, y3 = other.channels["yaw_rad"]
        j = np.searchsorted(t1, t3 - 0.005 - 1e-6)  # the second IMU's samples: 9 in 10 of them
        assert t3.size == t1.size - t1.size // 10
        np.testing.assert_allclose(t1[j], t3 - 0.005, atol=1e-9)
        assert f"[publisher {'node /imu2, ' if ros == 1 else ''}frame 'imu2_link']" in \
            other.sources["yaw_rad"]  # said in the source, kept in a written vehicle's notes
        np.testing.assert_allclose(np.angle(np.exp(1j * (y3 - y1[j] - 0.3))), 0.0, atol=1e-9)
    with pytest.raises(DiveDataError, match=r"--topic attitude=/mavros/imu/data@/imu2:orientation: "
                                            r"the field goes before the source: attitude="
                                            r"/mavros/imu/data:orientation@/imu2"):
        read_dive_channels(bag, "bluerov2", topics={"attitude": "/mavros/imu/data@/imu2:orientation"})
    with pytest.raises(DiveDataError, match=r"--topic attitude=/mavros/imu/data@: expected"):
        read_dive_channels(bag, "bluerov2", topics={"attitude": "/mavros/imu/data@"})
    with pytest.raises(DiveDataError, match=r"no publisher 'imu3'.*imu2_link': 359 messages"):
        read_dive_channels(bag, "bluerov2", topics={"attitude": "/mavros/imu/data@imu3"})


@pytest.mark.slow
def test_a_ros2_topic_with_two_publishers_of_one_frame_is_said(dive, tmp_path):
    """ROS 2 records no node per message: two IMUs of one frame cannot be told apart, and the
    metadata's two publishers are said instead of read silently as one series; when their headings
    differ, the saw-tooth they make is refused."""
    bag = write_bag(tmp_path / "same", 2, _short(dive), mutate=_second_imu("base_link", 0.0))
    dc = read_dive_channels(bag, "bluerov2")
    assert any(re.search(r"/mavros/imu/data had 2 publishers .* do not say which sent each", w)
               for w in dc.warnings), dc.warnings
    bag = write_bag(tmp_path / "apart", 2, _short(dive), mutate=_second_imu("base_link"))
    with pytest.raises(DiveDataError, match=r"/mavros/imu/data \(attitude\): the heading \[rad\] "
                                            r"saw-tooths"):
        read_dive_channels(bag, "bluerov2")


def _interleaved(t, x, warnings=None):
    def fail(msg):
        raise DiveDataError(msg)
    said = [] if warnings is None else warnings
    _check_interleaved(t, {"the heading [rad]": x}, "/imu", "attitude", "b", fail, said)
    if warnings is None:
        assert not said, said


def test_a_saw_tooth_of_two_sources_is_refused_and_one_noisy_sensor_is_not():
    """Two headings 0.2 rad apart, stamps 3 ms apart, merged: refused with the offset and the pairs;
    one IMU of the same motion with white noise (also noise far above the motion per sample, and a
    noise as large as that offset), or quantised to 0.01 rad, passes."""
    rng = np.random.default_rng(3)
    ts = np.arange(0.0, 60.0, 0.05)
    yaw = 0.8 * np.sin(0.3 * ts) + 0.2 * np.sin(1.7 * ts)
    t2 = np.sort(np.r_[ts, ts + 0.003])
    y2 = np.where(np.isin(t2, ts), np.interp(t2, ts, yaw), np.interp(t2, ts, yaw) + 0.2)
    with pytest.raises(DiveDataError, match=r"^b: /imu \(attitude\): the heading \[rad\] "
                                            r"saw-tooths in 24 of 24 stretches .*two levels 0\.2 "
                                            r"apart.*pairs 3 ms apart"):
        _interleaved(t2, y2)
    for sigma in (0.0, 0.002, 0.05, 0.2):
        _interleaved(ts, yaw + sigma * rng.standard_normal(ts.size))
        _interleaved(t2, np.interp(t2, ts, yaw) + sigma * rng.standard_normal(t2.size))
    _interleaved(ts, np.round(yaw / 0.01) * 0.01)
    _interleaved(ts, np.zeros(ts.size))  # at rest


def test_content_at_half_the_sampling_rate_is_a_warning_not_a_refusal():
    """One sensor whose value alternates every sample (a 98 Hz vibration on a 200 Hz topic, a load
    toggling each sample) was refused as 'a second sensor': without stamps in pairs it is said,
    naming both explanations, and the bag is read."""
    ts = np.arange(0.0, 10.0, 0.005)
    x = 0.3 * np.sin(0.5 * ts) + 0.05 * np.sin(2 * np.pi * 98.0 * ts)
    said: list = []
    _interleaved(ts, x, said)
    assert len(said) == 1 and "half the sampling rate" in said[0], said


@pytest.mark.slow
@pytest.mark.parametrize("ros", [1, 2])
def test_two_imus_of_one_node_and_frame_interleaved_on_a_topic_are_refused(dive, tmp_path, ros):
    """A second IMU on the first's own connection (ROS 1: same callerid; same frame), heading
    +0.2 rad, 3 ms after it: nothing tells the two apart but the saw-tooth of their merged heading,
    which the yaw fit took for motion (heading rms ×5, model accepted), silently."""
    ext = ".bag" if ros == 1 else ""
    bag = write_bag(tmp_path / f"same{ext}", ros, _short(dive),
                    mutate=_second_imu("base_link", 0.2, 3_000_000, node=None))
    with pytest.raises(DiveDataError) as exc:
        read_dive_channels(bag, "bluerov2")
    msg = str(exc.value)
    assert re.search(r"/mavros/imu/data \(attitude\): the heading \[rad\] saw-tooths in \d+ of "
                     r"\d+ stretches", msg), msg
    assert re.search(r"two levels 0\.2 apart", msg) and "pairs 3 ms apart" in msg, msg
    assert "two sources interleaved on one topic" in msg


def _frame_set_late(out, ts, hdr):
    """mavros' IMU with an empty frame_id for the first 8 s, then base_link: one publisher."""
    for m in out:
        if m[1] == "/mavros/imu/data" and m[0] < T0 + OFFSET + 8 * 10**9:
            m[2] = dataclasses.replace(m[2], header=dataclasses.replace(m[2].header, frame_id=""))


def _stray_imu_messages(out, ts, hdr):
    """Three messages of a second IMU node mid-bag (a `rostopic pub` test)."""
    _second_imu("imu2_link")(out, ts, hdr)
    extra = [i for i, m in enumerate(out) if m[1].endswith("#/imu2")]
    drop = set(extra[:100] + extra[103:])
    out[:] = [m for i, m in enumerate(out) if i not in drop]


def _imus_overlapping(out, ts, hdr):
    """mavros' IMU until 11 s, a second IMU (node /imu2, heading +0.3 rad) from 9 s."""
    _second_imu("imu2_link")(out, ts, hdr)
    out[:] = [m for m in out if not (m[1] == "/mavros/imu/data" and m[0] > T0 + OFFSET + 11 * 10**9)
              and not (m[1].endswith("#/imu2") and m[0] < T0 + OFFSET + 9 * 10**9)]


@pytest.mark.slow
def test_sources_one_after_the_other_are_one_series_and_a_shared_frame_is_no_choice(dive, tmp_path):
    """A frame_id set once the driver is up (two sources, never together) is read whole; a frame
    that two IMUs publishing together share cannot pick one of them: refused, asking for a node."""
    one = read_dive_channels(write_bag(tmp_path / "one.bag", 1, _short(dive)), "bluerov2")
    late = read_dive_channels(write_bag(tmp_path / "late.bag", 1, _short(dive),
                                        mutate=_frame_set_late), "bluerov2")
    np.testing.assert_array_equal(late.channels["yaw_rad"][1], one.channels["yaw_rad"][1])
    assert any("one after the other" in w and "all read" in w for w in late.warnings)
    assert not any("left out" in w and "publishers" in w for w in late.warnings)
    bag = write_bag(tmp_path / "shared.bag", 1, _short(dive), mutate=_second_imu("base_link"))
    stray = write_bag(tmp_path / "stray.bag", 1, _short(dive), mutate=_stray_imu_messages)
    dc = read_dive_channels(stray, "bluerov2")  # three messages of a test publisher: left out
    assert any("2 publishers" in w and "the 3 messages of the other left out" in w
               for w in dc.warnings), dc.warnings
    np.testing.assert_array_equal(dc.channels["yaw_rad"][1], one.channels["yaw_rad"][1])
    overlap = write_bag(tmp_path / "overlap.bag", 1, _short(dive), mutate=_imus_overlapping)
    dc = read_dive_channels(overlap, "bluerov2")  # 2 s together in 20: not one after the other
    assert any("2 publishers" in w and "left out" in w for w in dc.warnings), dc.warnings
    with pytest.raises(DiveDataError, match=r"'base_link' names 2 publishers that publish together"
                                            r".*name one by its node"):
        read_dive_channels(bag, "bluerov2", topics={"attitude": "/mavros/imu/data@base_link"})
    dc = read_dive_channels(bag, "bluerov2", topics={"attitude": "/mavros/imu/data@/mavros"})
    np.testing.assert_array_equal(dc.channels["yaw_rad"][1], one.channels["yaw_rad"][1])


def _dead_output_3(out, ts, hdr):
    for m in out:
        if m[1] == "/mavros/rc/out" and T0 + OFFSET + 5 * 10**9 <= m[0] <= T0 + OFFSET + 15 * 10**9:
            ch = np.array(m[2].channels, np.uint16)
            ch[2] = 0
            m[2] = dataclasses.replace(m[2], channels=ch)


@pytest.mark.slow
def test_a_dead_output_in_a_bag_is_named_as_in_a_table(dive, tmp_path):
    """Output 3 at 0 µs (no pulse) from 5 to 15 s while the others are driven (armed from ≈ 8 s):
    said for a bag too."""
    dc = read_dive_channels(write_bag(tmp_path / "dead.bag", 1, _short(dive), mutate=_dead_output_3),
                            "bluerov2")
    assert any(re.search(r"pwm_3 is 0 µs \(no pulse\) from 7\.98\d* to 15\.04\d* s while armed", w)
               for w in dc.warnings), dc.warnings
    clean = read_dive_channels(write_bag(tmp_path / "clean.bag", 1, _short(dive)), "bluerov2")
    assert not any("no pulse" in w or "(neutral)" in w for w in clean.warnings)


def _stamps_step(seconds, after_s):
    """Every header stamp moved by ``seconds`` from ``after_s`` on (the sender's clock re-synced)."""
    def step(out, ts, hdr):
        for m in out:
            h = getattr(m[2], "header", None)
            if h is not None and m[0] - OFFSET >= T0 + int(after_s * 1e9):
                m[2] = dataclasses.replace(m[2], header=hdr(h.stamp.sec * 10**9 + h.stamp.nanosec
                                                            + int(seconds * 1e9)))
    return step


def _recorder_stall(out, ts, hdr):
    """The recorder stalls for a second: messages received 0.5 s late for 1 s (stamps intact)."""
    for m in out:
        if T0 + OFFSET + 12 * 10**9 <= m[0] < T0 + OFFSET + 13 * 10**9:
            m[0] += 500_000_000


@pytest.mark.slow
def test_a_clock_step_under_a_second_is_refused_and_a_recorder_stall_is_not(dive, tmp_path):
    """Header stamps stepping by 0.3 s mid-bag (a clock re-sync, no reboot) left the topics on
    receive times 0.3 s off for half the bag, and each topic's median shift fell on either side
    (yaw inertia ×0.46): refused with where to cut.  A one-second recorder stall is not a step."""
    bag = write_bag(tmp_path / "step.bag", 1, _short(dive), mutate=_stamps_step(0.3, 10.0))
    with pytest.raises(DiveDataError, match=r"steps from \+0\.250 s to -0\.050 s and stays .* "
                                            r"rosbag filter"):
        read_dive_channels(bag, "bluerov2")
    stall = write_bag(tmp_path / "stall.bag", 1, _short(dive), mutate=_recorder_stall)
    assert read_dive_channels(stall, "bluerov2").channels["yaw_rad"][0].size > 300
    lag = write_bag(tmp_path / "lag.bag", 1, _short(dive), mutate=_recorder_lagging(4.0, 8.0))
    assert read_dive_channels(lag, "bluerov2").channels["yaw_rad"][0].size > 300  # it came back
    drift = write_bag(tmp_path / "drift.bag", 1, _short(dive), mutate=_recorder_drifting(0.25))
    dc = read_dive_channels(drift, "bluerov2")
    assert any(re.search(r"/mavros/imu/data: receive time − header stamp drifts by \+0\.[12]\d* s", w)
               for w in dc.warnings), dc.warnings


@pytest.mark.slow
def test_a_clock_set_back_under_a_second_is_a_re_sync_and_over_it_a_restart(dive, tmp_path):
    """Header stamps set back 0.9 s mid-bag (under the IMU's restart limit, 1 s) keep the clock
    re-sync's message; set back 1.5 s they go back by more than it: a restart, naming the IMU's
    message (the clock check said only that receive time − stamp changes by 1.5 s)."""
    bag = write_bag(tmp_path / "back.bag", 1, _short(dive), mutate=_stamps_step(-0.9, 10.0))
    with pytest.raises(DiveDataError, match=r"/mavros/imu/data: receive time − header stamp steps "
                                            r"from \+0\.250 s to \+1\.150 s and stays .* rosbag filter"):
        read_dive_channels(bag, "bluerov2")
    bag = write_bag(tmp_path / "back15.bag", 1, _short(dive), mutate=_stamps_step(-1.5, 10.0))
    with pytest.raises(DiveDataError, match=r"/mavros/imu/data \(attitude\): header stamps go back at "
                                            r"message \d+ .* 1\.4\d* s back where the typical step is "
                                            r"0\.04\d* s .* rosbag filter"):
        read_dive_channels(bag, "bluerov2")


def _recorder_lagging(t_from, t_to, lag_s=0.15):
    """Messages received ``lag_s`` late from ``t_from`` to ``t_to`` s, then on time again."""
    def late(out, ts, hdr):
        for m in out:
            if T0 + OFFSET + int(t_from * 1e9) <= m[0] < T0 + OFFSET + int(t_to * 1e9):
                m[0] += int(lag_s * 1e9)
    return late


def _recorder_drifting(total_s, span_s=20.0):
    """The recording computer's clock running fast: receive times late by up to ``total_s``."""
    def drift(out, ts, hdr):
        for m in out:
            m[0] += int(total_s * 1e9 * min(max((m[0] - T0 - OFFSET) / (span_s * 1e9), 0.0), 1.0))
    return drift


def _pressure_glitches(out, ts, hdr):
    """One static_pressure sample at 0 Pa (a sensor off its bus), one 3 kPa low (a spike)."""
    ps = [m for m in out if m[1] == "/mavros/imu/static_pressure"]
    for m, value in ((ps[40], 0.0), (ps[41], 98300.0)):
        m[2] = dataclasses.replace(m[2], fluid_pressure=value)


@pytest.mark.slow
def test_pressure_glitches_do_not_move_the_surface_and_a_stale_ground_pressure_is_said(dive, tmp_path):
    """The surface was the lowest pressure in the bag: one 0 Pa sample made every depth +10 m
    (the surface cut-off never acted; heave mass 15.5 instead of 26.5), one 3 kPa spike +0.3 m.
    0 Pa is no pressure of air or water (left out, said); the 5th lowest sample ignores a spike.
    A BARO1_GND_PRESS 3 kPa below the bag's surface is said."""
    df = _short(dive)
    clean = read_dive_channels(write_bag(tmp_path / "p.bag", 1, df, omit=("rel_alt",),
                                         pressure=101325.0), "bluerov2")
    bag = write_bag(tmp_path / "glitch.bag", 1, df, omit=("rel_alt",), pressure=101325.0,
                    mutate=_pressure_glitches)
    dc = read_dive_channels(bag, "bluerov2")
    assert any(re.search(r"1 /mavros/imu/static_pressure sample\(s\) outside 30 kPa–20 MPa.*: 0 Pa\)"
                         r": left out", w) for w in dc.warnings), dc.warnings
    t0, d0 = clean.channels["depth_m"]
    t1, d1 = dc.channels["depth_m"]
    keep = np.isin(t0, t1)
    # the 0 Pa sample, and the spike: a jump of 0.3 m and back between neighbours, faster than
    # any vehicle moves, is left out by the depth-spike check (said with its value)
    assert keep.sum() == t0.size - 2
    assert any(re.search(r"1 depth_m sample\(s\) jump .*: -0\.[23]\d* m at t = ", w)
               for w in dc.warnings), dc.warnings
    # the others within 5 mm of the clean bag's (the spike is one of the five lowest pressure
    # samples: the 5th lowest is then the clean bag's 4th)
    np.testing.assert_allclose(d1, d0[keep], atol=5e-3)
    stale = read_dive_channels(bag, "bluerov2", params={"BARO1_GND_PRESS": 98325.0})
    assert any(re.search(r"BARO1_GND_PRESS = 98325 Pa is 0\.[23]\d* m of water below .*another day", w)
               for w in stale.warnings), stale.warnings


@pytest.mark.slow
def test_a_gauge_pressure_is_read_from_zero_and_said(dive, tmp_path):
    """A driver publishing gauge pressure (0 at the surface) on FluidPressure: every sample fell
    below 30 kPa and was left out as no pressure of air or water; read from 0 Pa, said."""
    df = _short(dive)
    bag = write_bag(tmp_path / "gauge.bag", 1, df, omit=("rel_alt",), pressure=0.0)
    dc = read_dive_channels(bag, "bluerov2")
    assert any("read as a gauge pressure" in w for w in dc.warnings), dc.warnings
    rows = df["depth_m"].notna().to_numpy()
    np.testing.assert_allclose(dc.channels["depth_m"][1], df.loc[rows, "depth_m"].to_numpy(),
                               atol=1e-9)


def test_a_bag_topic_and_a_dive_table_pause_by_one_rule(monkeypatch):
    """The bag reader kept its own BAG_GAP_S = 10 s beside the tables' pause rule: changing one
    left the other behind.  Now both ask uuvid.io.logs.pause_s."""
    from uuvid.io import dive_channels, dive_rosbag, logs

    assert not hasattr(dive_rosbag, "BAG_GAP_S")
    t = np.r_[np.arange(0.0, 20.0, 0.1), 29.0 + np.arange(0.0, 20.0, 0.1)]  # a 9 s pause
    seen = []
    dive_rosbag._check_gaps(t, "/x", "pwm", "b.bag", seen, None)
    assert not seen and dive_channels.pause_s(t) == logs.pause_s(t) == logs.GAP_S == 10.0
    monkeypatch.setattr(logs, "GAP_S", 8.0)
    dive_rosbag._check_gaps(t, "/x", "pwm", "b.bag", seen, None)
    assert len(seen) == 1 and "stops for 9.1 s" in seen[0], seen
    assert dive_channels.pause_s(t) == 8.0
