"""Logs as users have them (uuvid.io.logs): CSV/Parquet, ROS 1/2 bags, ArduSub .tlog and .bin.

The bag and MAVLink files are written here with the same libraries the readers use (rosbags'
writers, pymavlink's MAVLink encoder); the dataflash .bin is written by hand following the
format pymavlink's DFReader parses (see ``_write_dataflash``).  Tests that need an optional
package skip without it, so the default suite passes without the ``logs`` extra.
"""

from __future__ import annotations

import math
import sqlite3
import struct
import sys
from pathlib import Path

import numpy as np
import pytest

from uuvid.core import units as U
from uuvid.core.response import TimeResponse
from uuvid.io.logs import LogDataError, align, convert_units, read_ardusub, read_log_csv, read_rosbag


def write(tmp_path: Path, text: str, name: str = "log.csv") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


# ================================================================================== CSV / Parquet
LOG = """t_ms,depth_mm,hdg_deg,pwm1
0,100,90,1500
100,150,91,1550
200,210,92.5,1600
"""


def test_csv_units_meta(tmp_path):
    p = write(tmp_path, LOG)
    r = read_log_csv(p, time_col="t_ms", time_unit="ms",
                     columns={"depth": "depth_mm", "heading": "hdg_deg", "thrust_1": "pwm1"},
                     units={"depth": "mm", "heading": "deg", "thrust_1": "pwm_us"})
    assert isinstance(r, TimeResponse)
    np.testing.assert_allclose(r.t, [0.0, 0.1, 0.2])
    np.testing.assert_allclose(r["depth"], [0.1, 0.15, 0.21])
    np.testing.assert_allclose(r["heading"], np.radians([90, 91, 92.5]))
    np.testing.assert_allclose(r["thrust_1"], [1500, 1550, 1600])
    assert r.meta["source"] == "log.csv" and r.meta["format"] == "csv"
    assert r.meta["units"] == {"depth": "m", "heading": "rad", "thrust_1": "pwm_us"}
    assert r.meta["original_units"]["depth"] == "mm"
    assert r.meta["original_names"] == {"depth": "depth_mm", "heading": "hdg_deg",
                                        "thrust_1": "pwm1"}
    assert r.meta["time_column"] == "t_ms" and r.meta["time_unit"] == "ms"


def test_csv_semicolons_comments_and_name_matching(tmp_path):
    p = write(tmp_path, "# logger v2\n# vehicle rov1\nTime (us);Depth\n0;1.0\n500000;1.5\n")
    r = read_log_csv(p, time_col="time (µs)", columns=["depth"], time_unit="us")
    np.testing.assert_allclose(r.t, [0, 0.5])
    np.testing.assert_allclose(r["depth"], [1.0, 1.5])
    assert r.meta["original_names"] == {"depth": "Depth"}
    assert r.meta["units"] == {"depth": None}  # no unit given: taken as SI


@pytest.mark.parametrize("unit,factor", [("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)])
def test_csv_time_units(tmp_path, unit, factor):
    p = write(tmp_path, "t,x\n0,1\n10,2\n")
    r = read_log_csv(p, time_col="t", columns={"x": "x"}, time_unit=unit)
    np.testing.assert_allclose(r.t, [0, 10 * factor])


def test_csv_iso_datetime(tmp_path):
    p = write(tmp_path, "stamp,x\n2024-05-01T12:00:00Z,1\n2024-05-01T12:00:00.250Z,2\n")
    r = read_log_csv(p, time_col="stamp", columns={"x": "x"}, time_unit="datetime")
    assert r.t[1] - r.t[0] == pytest.approx(0.25)
    assert r.t[0] == pytest.approx(1714564800.0)


def test_csv_missing_column_lists_available(tmp_path):
    p = write(tmp_path, LOG)
    with pytest.raises(LogDataError) as e:
        read_log_csv(p, time_col="t_ms", columns={"depth": "depth_m"})
    msg = str(e.value)
    assert "log.csv" in msg and "'depth_m'" in msg and "channel 'depth'" in msg
    for c in ("'t_ms'", "'depth_mm'", "'hdg_deg'", "'pwm1'"):
        assert c in msg
    with pytest.raises(LogDataError, match="no column 'time'.*available columns"):
        read_log_csv(p, time_col="time", columns={"depth": "depth_mm"})


@pytest.mark.parametrize("cell,what", [("nan", "NaN"), ("", "empty cell"),
                                       ("1.2.3", "'1.2.3' is not numeric"), ("inf", "not finite")])
def test_csv_bad_cell_names_file_column_row(tmp_path, cell, what):
    p = write(tmp_path, f"t,depth\n0,1\n1,{cell}\n2,3\n")
    with pytest.raises(LogDataError) as e:
        read_log_csv(p, time_col="t", columns={"depth": "depth"})
    msg = str(e.value)
    assert "log.csv: column 'depth', data row 2 (CSV line 3)" in msg
    assert what in msg


def test_csv_allow_missing_keeps_nan(tmp_path):
    p = write(tmp_path, "t,depth\n0,1\n1,\n2,nan\n3,4\n")
    r = read_log_csv(p, time_col="t", columns={"depth": "depth"}, allow_missing=True)
    assert np.isnan(r["depth"][1]) and np.isnan(r["depth"][2]) and r["depth"][3] == 4
    with pytest.raises(LogDataError, match="not numeric"):  # text is still an error
        read_log_csv(write(tmp_path, "t,d\n0,1\n1,x\n", "b.csv"), time_col="t",
                     columns={"d": "d"}, allow_missing=True)


@pytest.mark.parametrize("times,kind", [("0,2,1", "not increasing"), ("0,1,1", "duplicated")])
def test_csv_time_must_increase(tmp_path, times, kind):
    t = times.split(",")
    p = write(tmp_path, "t,x\n" + "".join(f"{v},5\n" for v in t))
    with pytest.raises(LogDataError) as e:
        read_log_csv(p, time_col="t", columns={"x": "x"})
    msg = str(e.value)
    assert "column 't', data row 3 (CSV line 4)" in msg and kind in msg


def test_csv_option_errors(tmp_path):
    p = write(tmp_path, LOG)
    with pytest.raises(LogDataError, match="unknown unit 'furlong'.*known units"):
        read_log_csv(p, time_col="t_ms", columns={"d": "depth_mm"}, units={"d": "furlong"})
    with pytest.raises(LogDataError, match="unknown time_unit 'hours'"):
        read_log_csv(p, time_col="t_ms", columns={"d": "depth_mm"}, time_unit="hours")
    with pytest.raises(LogDataError, match="units given for 'x'"):
        read_log_csv(p, time_col="t_ms", columns={"d": "depth_mm"}, units={"x": "m"})
    with pytest.raises(LogDataError, match="'time' cannot be a channel name"):
        read_log_csv(p, time_col="t_ms", columns={"time": "t_ms"})
    with pytest.raises(LogDataError, match="no such log file"):
        read_log_csv(tmp_path / "nope.csv", time_col="t", columns={"d": "d"})
    with pytest.raises(LogDataError, match="CSV line 3 has 3 cells"):
        read_log_csv(write(tmp_path, "t,x\n0,1\n1,2,3\n", "c.csv"), time_col="t", columns=["x"])


def test_convert_units():
    v, si = convert_units([1.0, 2.0], "kgf")
    np.testing.assert_allclose(v, [U.KGF, 2 * U.KGF])
    assert si == "N"
    assert convert_units([1.0], "mA")[1] == "A" and convert_units([1.0], "mA")[0][0] == 1e-3
    assert convert_units([60.0], "rpm")[0][0] == pytest.approx(2 * math.pi)
    assert convert_units([3.0], None)[1] is None


def test_parquet_roundtrip(tmp_path):
    pytest.importorskip("pyarrow")
    import pandas as pd

    df = pd.DataFrame({"time": pd.to_datetime(["2024-01-01 00:00:00.0", "2024-01-01 00:00:00.5",
                                               "2024-01-01 00:00:01.0"]),
                       "rpm": [0.0, 600.0, 1200.0], "amps": [0.0, 1.0, 2.0]})
    p = tmp_path / "log.parquet"
    df.to_parquet(p)
    r = read_log_csv(p, time_col="time", columns={"speed": "rpm", "current": "amps"},
                     units={"speed": "rpm"})
    np.testing.assert_allclose(np.diff(r.t), [0.5, 0.5])
    np.testing.assert_allclose(r["speed"], np.array([0, 600, 1200]) * U.RPM)
    assert r.meta["format"] == "parquet" and r.meta["time_unit"] == "datetime"
    df2 = pd.DataFrame({"t": [0.0, 0.1, 0.2], "x": [1.0, None, 2.0]})
    df2.to_parquet(tmp_path / "bad.parquet")
    with pytest.raises(LogDataError, match=r"bad.parquet: column 'x', data row 2: empty cell"):
        read_log_csv(tmp_path / "bad.parquet", time_col="t", columns=["x"])


def test_parquet_without_pyarrow_names_the_extra(tmp_path, monkeypatch):
    p = tmp_path / "log.parquet"
    p.write_bytes(b"PAR1")
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(ImportError, match=r"pip install 'uuvid\[logs\]'"):
        read_log_csv(p, time_col="t", columns=["x"])


@pytest.mark.parametrize("module,call", [
    ("rosbags", lambda p: read_rosbag(p, {"d": "/d:data"})),
    ("pymavlink", lambda p: read_ardusub(p)),
])
def test_missing_optional_package_names_the_extra(tmp_path, monkeypatch, module, call):
    for name in list(sys.modules):
        if name == module or name.startswith(module + "."):
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, module, None)
    with pytest.raises(ImportError, match=r"pip install 'uuvid\[logs\]'"):
        call(tmp_path / "x.bag")


# ========================================================================================= align
def test_align_union_dt_and_hold():
    a = TimeResponse(np.array([0.0, 1.0, 2.0]), {"a": np.array([0.0, 10.0, 20.0])},
                     {"source": "x", "units": {"a": "m"}})
    b = TimeResponse(np.array([0.5, 1.5, 2.5]), {"b": np.array([1.0, 2.0, 3.0])},
                     {"source": "x", "units": {"b": "pwm_us"}})
    u = align({"a": a, "b": b})
    np.testing.assert_allclose(u.t, [0.5, 1.0, 1.5, 2.0])  # overlap only
    np.testing.assert_allclose(u["a"], [5, 10, 15, 20])
    np.testing.assert_allclose(u["b"], [1, 1.5, 2, 2.5])
    assert u.meta["units"] == {"a": "m", "b": "pwm_us"} and u.meta["source"] == "x"
    h = align([a, b], 0.25, interp={"b": "previous"})
    np.testing.assert_allclose(h.t, np.arange(0.5, 2.0001, 0.25))
    np.testing.assert_allclose(h["b"], [1, 1, 1, 1, 2, 2, 2])
    w = align([a, b], "union", span="union")
    np.testing.assert_allclose(w.t, [0, 0.5, 1, 1.5, 2, 2.5])
    assert np.isnan(w["b"][0]) and np.isnan(w["a"][-1])
    n = align([a, b], 0.25, interp="nearest")
    np.testing.assert_allclose(n["a"], [0, 10, 10, 10, 10, 20, 20])  # ties go to the earlier
    c = TimeResponse(np.array([5.0, 6.0]), {"c": np.array([0.0, 1.0])})
    with pytest.raises(LogDataError, match="do not overlap"):
        align([a, c])
    with pytest.raises(LogDataError, match="appears twice"):
        align([a, a])


# ===================================================================================== ROS bags
RCOUT_MSG = "std_msgs/Header header\nuint16[] channels\n"
T0_NS = 1_700_000_000 * 10**9
N_MSG = 10


def _stores(ros: int):
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC if ros == 1 else Stores.ROS2_HUMBLE)
    ts.register(get_types_from_msg(RCOUT_MSG, "mavros_msgs/msg/RCOut"))
    return ts


def _write_bag(path: Path, ros: int, storage: str = "sqlite3", zero_rc_stamps: bool = False,
               shift_ns: int = 0):
    """Topics as mavros records them: depth/heading (Float64), IMU (header), RC out (custom)."""
    ts = _stores(ros)
    if ros == 1:
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
        ser = ts.serialize_ros1
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=9, storage_plugin=plugin)
        ser = ts.serialize_cdr
    F64 = ts.types["std_msgs/msg/Float64"]
    Imu = ts.types["sensor_msgs/msg/Imu"]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    Quat = ts.types["geometry_msgs/msg/Quaternion"]
    Vec = ts.types["geometry_msgs/msg/Vector3"]
    RCOut = ts.types["mavros_msgs/msg/RCOut"]

    def header(ns):
        kw = {"seq": 0} if ros == 1 else {}
        return Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="base_link", **kw)

    with writer as w:
        c_depth = w.add_connection("/mavros/global_position/rel_alt", F64.__msgtype__, typestore=ts)
        c_hdg = w.add_connection("/mavros/global_position/compass_hdg", F64.__msgtype__,
                                 typestore=ts)
        c_imu = w.add_connection("/mavros/imu/data", Imu.__msgtype__, typestore=ts)
        c_rc = w.add_connection("/mavros/rc/out", RCOut.__msgtype__, typestore=ts)
        for k in range(N_MSG):
            t = T0_NS + shift_ns + k * 100_000_000
            w.write(c_depth, t, ser(F64(data=-0.5 * k), F64.__msgtype__))
            if k % 2 == 0:
                w.write(c_hdg, t + 1_000_000, ser(F64(data=10.0 * k), F64.__msgtype__))
            imu = Imu(header=header(t - 5_000_000),
                      orientation=Quat(x=0.0, y=0.0, z=0.01 * k, w=1.0),
                      orientation_covariance=np.zeros(9), angular_velocity=Vec(x=0.0, y=0.0, z=k),
                      angular_velocity_covariance=np.zeros(9),
                      linear_acceleration=Vec(x=0.0, y=0.0, z=9.8),
                      linear_acceleration_covariance=np.zeros(9))
            w.write(c_imu, t, ser(imu, Imu.__msgtype__))
            rc = RCOut(header=header(0 if zero_rc_stamps else t - 2_000_000),
                       channels=np.array([1500 + k, 1600 - k, 1700], dtype=np.uint16))
            w.write(c_rc, t, ser(rc, RCOut.__msgtype__))
    return path


TOPICS = {
    "depth": "/mavros/global_position/rel_alt:data",
    "heading": "/mavros/global_position/compass_hdg:data",
    "qz": "/mavros/imu/data:orientation.z",
    "r": "/mavros/imu/data:angular_velocity.z",
    "thrust_1": "/mavros/rc/out:channels[0]",
    "thrust_2": "/mavros/rc/out:channels[1]",
    "thrust_3": "/mavros/rc/out:channels[-1]",
}


def _check_bag_channels(out, ros):
    k = np.arange(N_MSG)
    # t = 0 is the first sample of any channel: the first IMU header stamp (5 ms before receive)
    assert out["qz"].meta["t0_ns"] == T0_NS - 5_000_000
    np.testing.assert_allclose(out["qz"].t, 0.1 * k)
    np.testing.assert_allclose(out["qz"]["qz"], 0.01 * k)
    np.testing.assert_allclose(out["r"]["r"], k)
    np.testing.assert_allclose(out["depth"].t, 0.1 * k + 0.005, atol=1e-12)  # receive time
    np.testing.assert_allclose(out["depth"]["depth"], -0.5 * k)
    np.testing.assert_allclose(out["heading"].t, 0.2 * np.arange(5) + 0.006, atol=1e-12)
    np.testing.assert_allclose(out["heading"]["heading"], np.radians(20.0 * np.arange(5)))
    np.testing.assert_allclose(out["thrust_1"].t, 0.1 * k + 0.003, atol=1e-12)
    np.testing.assert_allclose(out["thrust_1"]["thrust_1"], 1500 + k)
    np.testing.assert_allclose(out["thrust_2"]["thrust_2"], 1600 - k)
    np.testing.assert_allclose(out["thrust_3"]["thrust_3"], 1700)
    m = out["heading"].meta
    assert m["units"] == {"heading": "rad"} and m["original_units"] == {"heading": "deg"}
    assert m["original_names"] == {"heading": "/mavros/global_position/compass_hdg:data"}
    assert m["format"] == f"rosbag{ros}"
    assert m["stamp"] == {"heading": "receive"}
    assert out["qz"].meta["stamp"] == {"qz": "header"}
    assert out["thrust_1"].meta["msgtypes"] == {"thrust_1": "mavros_msgs/msg/RCOut"}


@pytest.mark.slow
@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_rosbag2_channels_and_time_axes(tmp_path, storage):
    pytest.importorskip("rosbags")
    bag = _write_bag(tmp_path / "dive", 2, storage)
    out = read_rosbag(bag, TOPICS, units={"heading": "deg"})
    assert set(out) == set(TOPICS)
    _check_bag_channels(out, 2)
    # a file inside the bag directory is accepted too
    inner = next(p for p in bag.iterdir() if p.suffix in (".db3", ".mcap"))
    assert read_rosbag(inner, {"depth": TOPICS["depth"]})["depth"].t.size == N_MSG


@pytest.mark.slow
def test_rosbag1_channels_and_time_axes(tmp_path):
    pytest.importorskip("rosbags")
    bag = _write_bag(tmp_path / "dive.bag", 1)
    out = read_rosbag(bag, TOPICS, units={"heading": "deg"})
    _check_bag_channels(out, 1)


def test_rosbag1_split_recording(tmp_path):
    pytest.importorskip("rosbags")
    a = _write_bag(tmp_path / "dive_0.bag", 1)
    b = _write_bag(tmp_path / "dive_1.bag", 1, shift_ns=N_MSG * 100_000_000)
    out = read_rosbag([a, b], {"depth": TOPICS["depth"]})
    np.testing.assert_allclose(out["depth"].t, 0.1 * np.arange(2 * N_MSG), atol=1e-9)
    assert out["depth"].meta["source"] == "dive_0.bag (+1 more)"


def test_rosbag_resample_union_and_dt(tmp_path):
    pytest.importorskip("rosbags")
    bag = _write_bag(tmp_path / "dive.bag", 1)
    sel = {k: TOPICS[k] for k in ("depth", "qz", "thrust_1")}
    u = read_rosbag(bag, sel, resample="union", interp={"thrust_1": "previous"})
    assert isinstance(u, TimeResponse) and set(u.names) == set(sel)
    assert u.t[0] == pytest.approx(0.005) and u.t[-1] == pytest.approx(0.9)  # overlap
    assert np.all(np.diff(u.t) > 0) and np.all(np.isfinite(u["depth"]))
    # depth is linear in time (-0.5 m per 0.1 s): interpolation onto any stamp is exact
    np.testing.assert_allclose(u["depth"], -5.0 * (u.t - 0.005), atol=1e-9)
    assert u.meta["original_names"]["qz"] == "/mavros/imu/data:orientation.z"
    g = read_rosbag(bag, sel, resample=0.05)
    np.testing.assert_allclose(np.diff(g.t), 0.05)
    np.testing.assert_allclose(g["qz"], 0.1 * g.t, atol=1e-12)


def test_rosbag_receive_stamps_and_zero_header_stamps(tmp_path):
    pytest.importorskip("rosbags")
    bag = _write_bag(tmp_path / "dive.bag", 1, zero_rc_stamps=True)
    out = read_rosbag(bag, {"qz": TOPICS["qz"], "thrust_1": TOPICS["thrust_1"]},
                      stamp="receive")
    np.testing.assert_allclose(out["qz"].t, 0.1 * np.arange(N_MSG), atol=1e-12)
    assert out["qz"].meta["stamp"] == {"qz": "receive"}
    out = read_rosbag(bag, {"thrust_1": TOPICS["thrust_1"]})
    assert out["thrust_1"].meta["stamp"] == {"thrust_1": "receive (header stamps are zero)"}


@pytest.mark.slow
def test_rosbag_missing_topic_and_field_errors(tmp_path):
    pytest.importorskip("rosbags")
    bag = _write_bag(tmp_path / "dive", 2)
    with pytest.raises(LogDataError) as e:
        read_rosbag(bag, {"depth": "/mavros/global_position/rel_altitude:data"})
    msg = str(e.value)
    assert "no topic '/mavros/global_position/rel_altitude'" in msg
    assert "/mavros/imu/data (sensor_msgs/msg/Imu, 10 msgs)" in msg
    assert "/mavros/rc/out (mavros_msgs/msg/RCOut, 10 msgs)" in msg
    with pytest.raises(LogDataError) as e:
        read_rosbag(bag, {"q": "/mavros/imu/data:orientation.zz"})
    msg = str(e.value)
    assert "no field 'zz'" in msg and "geometry_msgs/msg/Quaternion" in msg
    assert "x (float" in msg and "w (float" in msg
    with pytest.raises(LogDataError, match=r"no field 'orientatoin'.*header \(std_msgs/msg/Header\)"):
        read_rosbag(bag, {"q": "/mavros/imu/data:orientatoin.z"})
    with pytest.raises(LogDataError, match=r"is a geometry_msgs/msg/Quaternion message, not a number"):
        read_rosbag(bag, {"q": "/mavros/imu/data:orientation"})
    with pytest.raises(LogDataError, match=r"'channels' is an array of 3 value.*'channels\[0\]'"):
        read_rosbag(bag, {"t": "/mavros/rc/out:channels"})
    with pytest.raises(LogDataError, match=r"message 1: channels has 3 element\(s\); index \[5\]"):
        read_rosbag(bag, {"t": "/mavros/rc/out:channels[5]"})
    with pytest.raises(LogDataError, match="invalid field path"):
        read_rosbag(bag, {"t": "/mavros/rc/out:channels[x]"})
    with pytest.raises(LogDataError, match="not a bag"):
        read_rosbag(write(tmp_path, "x"), {"t": "/a:data"})


@pytest.mark.slow
def test_rosbag2_without_embedded_definitions_uses_msg_definitions(tmp_path):
    """ROS 2 bags recorded before Iron (sqlite3) carry no type definitions."""
    pytest.importorskip("rosbags")
    bag = _write_bag(tmp_path / "old", 2, "sqlite3")
    db = next(bag.glob("*.db3"))
    with sqlite3.connect(db) as con:
        con.execute("DELETE FROM message_definitions")
    # standard types come from the built-in ROS 2 Humble store
    out = read_rosbag(bag, {"depth": TOPICS["depth"], "qz": TOPICS["qz"]})
    np.testing.assert_allclose(out["depth"]["depth"], -0.5 * np.arange(N_MSG))
    with pytest.raises(LogDataError, match=r"'mavros_msgs/msg/RCOut'.*msg_definitions"):
        read_rosbag(bag, {"thrust_1": TOPICS["thrust_1"]})
    out = read_rosbag(bag, {"thrust_1": TOPICS["thrust_1"]},
                      msg_definitions={"mavros_msgs/RCOut": RCOUT_MSG})
    np.testing.assert_allclose(out["thrust_1"]["thrust_1"], 1500 + np.arange(N_MSG))


# ============================================================================== ArduSub .tlog
BOOT0 = 4294.5  # s since boot: SERVO_OUTPUT_RAW.time_usec (uint32 µs) wraps at 4294.967296 s
UNIX0 = 1_700_000_000.0


def _write_tlog(path: Path) -> Path:
    """A tlog as a ground station saves it: 8-byte big-endian µs receive time + MAVLink 2 frame.

    Vehicle (system 1) at 10 Hz: ATTITUDE (time_boot_ms), SERVO_OUTPUT_RAW (32-bit time_usec,
    which wraps during this log) and VFR_HUD (no on-board stamp).  The ground station (system
    255) sends a HEARTBEAT and a bogus ATTITUDE that must be ignored.  Receive latencies vary
    (10–30 ms); the smallest is 10 ms.
    """
    from pymavlink import mavutil
    from pymavlink.dialects.v20 import ardupilotmega as mavlink2

    path.touch()
    log = mavutil.mavlink_connection(str(path), write=True)
    sub = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    gcs = mavlink2.MAVLink(None, srcSystem=255, srcComponent=190)

    def put(mav, t_unix, msg):
        log.write(struct.pack(">Q", int(round(t_unix * 1e6))) + msg.pack(mav))

    put(gcs, UNIX0 + BOOT0 - 1.0, gcs.heartbeat_encode(mavlink2.MAV_TYPE_GCS,
                                                       mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, 0))
    put(sub, UNIX0 + BOOT0 - 0.9, sub.heartbeat_encode(mavlink2.MAV_TYPE_SUBMARINE,
                                                       mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                       0, 0, 0))
    for k in range(N_MSG):
        boot = BOOT0 + 0.1 * k
        lat = 0.01 if k % 2 == 0 else 0.03
        put(sub, UNIX0 + boot + lat,
            sub.attitude_encode(int(round(boot * 1000)), 0.1 * k, -0.05 * k, 0.2 + 0.01 * k,
                                0, 0, 0))
        put(gcs, UNIX0 + boot + 0.011, gcs.attitude_encode(0, 9.0, 9.0, 9.0, 0, 0, 0))
        usec = int(round((boot + 0.002) * 1e6)) % 2**32
        put(sub, UNIX0 + boot + 0.002 + 0.02,
            sub.servo_output_raw_encode(usec, 0, *[1500 + 10 * k + i for i in range(1, 9)]))
        put(sub, UNIX0 + boot + 0.05 + 0.01, sub.vfr_hud_encode(0, 0, 90, 50, -0.5 * k, 0.0))
    log.close()
    return path


def test_tlog_defaults_values_and_boot_times(tmp_path):
    pytest.importorskip("pymavlink")
    p = _write_tlog(tmp_path / "dive.tlog")
    out = read_ardusub(p)
    assert set(out) == {"depth", "roll", "pitch", "yaw", *(f"servo_{i}" for i in range(1, 9))}
    k = np.arange(N_MSG)
    boot = BOOT0 + 0.1 * k
    np.testing.assert_allclose(out["roll"].t, boot, atol=1e-9)
    np.testing.assert_allclose(out["roll"]["roll"], 0.1 * k, rtol=1e-6)  # the GCS's 9.0 is ignored
    np.testing.assert_allclose(out["pitch"]["pitch"], -0.05 * k, rtol=1e-6)
    np.testing.assert_allclose(out["yaw"]["yaw"], 0.2 + 0.01 * k, rtol=1e-6)
    # SERVO_OUTPUT_RAW.time_usec wrapped at 2^32 µs mid-log: unwrapped, still increasing
    np.testing.assert_allclose(out["servo_3"].t, boot + 0.002, atol=1e-6)
    for i in range(1, 9):
        np.testing.assert_allclose(out[f"servo_{i}"][f"servo_{i}"], 1500 + 10 * k + i)
    # VFR_HUD has no on-board stamp: receive time mapped onto the boot clock (min latency 10 ms)
    np.testing.assert_allclose(out["depth"].t, boot + 0.05, atol=1e-5)
    np.testing.assert_allclose(out["depth"]["depth"], 0.5 * k, rtol=1e-6)
    m = out["depth"].meta
    assert m["format"] == "tlog" and m["time_base"] == "boot"
    assert m["original_names"] == {"depth": "-VFR_HUD.alt"} and m["units"] == {"depth": "m"}
    assert m["time_mapped"] == {"depth": True} and out["roll"].meta["time_mapped"] == {"roll": False}
    assert m["source_system"] == [1, 1]
    assert out["servo_1"].meta["units"] == {"servo_1": "pwm_us"}
    assert out["servo_1"].meta["instances"] == {"servo_1": "port=0"}


def test_tlog_resample_log_time_and_fields(tmp_path):
    pytest.importorskip("pymavlink")
    p = _write_tlog(tmp_path / "dive.tlog")
    u = read_ardusub(p, {"depth": "-VFR_HUD.alt", "roll": "ATTITUDE.roll",
                         "thrust_1": "SERVO_OUTPUT_RAW.servo1_raw"},
                     resample=0.02, interp={"thrust_1": "previous"})
    assert isinstance(u, TimeResponse) and set(u.names) == {"depth", "roll", "thrust_1"}
    assert u.t[0] == pytest.approx(BOOT0 + 0.05, abs=1e-5)  # overlap starts at the first depth
    np.testing.assert_allclose(np.diff(u.t), 0.02)
    assert set(np.unique(u["thrust_1"])) <= {1501.0 + 10 * k for k in range(N_MSG)}
    lg = read_ardusub(p, {"roll": "ATTITUDE.roll", "d": "VFR_HUD.alt"}, time="log",
                      units={"d": "m"})
    assert lg["roll"].t[0] == 0.0 and lg["roll"].meta["t0_unix"] == pytest.approx(UNIX0 + BOOT0 + 0.01)
    np.testing.assert_allclose(lg["d"].t, 0.1 * np.arange(N_MSG) + 0.05, atol=1e-5)
    sel = read_ardusub(p, {"hdg": "VFR_HUD.heading"})
    np.testing.assert_allclose(sel["hdg"]["hdg"], math.radians(90))


def test_tlog_errors(tmp_path):
    pytest.importorskip("pymavlink")
    p = _write_tlog(tmp_path / "dive.tlog")
    with pytest.raises(LogDataError) as e:
        read_ardusub(p, {"p": "SCALED_PRESSURE2.press_abs"})
    msg = str(e.value)
    assert "dive.tlog: channel 'p': no SCALED_PRESSURE2 messages" in msg
    assert "ATTITUDE (20)" in msg and "VFR_HUD (10)" in msg
    with pytest.raises(LogDataError, match=r"ATTITUDE has no field 'rol'; its fields are: .*roll"):
        read_ardusub(p, {"r": "ATTITUDE.rol"})
    with pytest.raises(LogDataError, match="invalid field"):
        read_ardusub(p, {"r": "ATTITUDE"})
    with pytest.raises(LogDataError, match="unknown unit 'furlong' for channel 'r'"):
        read_ardusub(p, {"r": "ATTITUDE.roll"}, units={"r": "furlong"})
    with pytest.raises(LogDataError, match="several senders"):
        _no_heartbeat_tlog(tmp_path)
    with pytest.raises(LogDataError, match=r"ATTITUDE message 4 \(of that type\): time stamp "
                                            r"0.000000 s is duplicated .*on_duplicate="):
        read_ardusub(p, {"r": "ATTITUDE.roll"}, source_system=255)  # its time_boot_ms is 0
    out = read_ardusub(p, {"r": "ATTITUDE.roll"}, source_system=255, time="log")
    np.testing.assert_allclose(out["r"]["r"], 9.0)
    np.testing.assert_allclose(np.diff(out["r"].t), 0.1, atol=1e-6)


def _no_heartbeat_tlog(tmp_path):
    """Two senders of ATTITUDE and no autopilot HEARTBEAT: the reader cannot choose."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink2

    p = tmp_path / "two.tlog"
    a = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    b = mavlink2.MAVLink(None, srcSystem=2, srcComponent=1)
    with open(p, "wb") as f:
        for k in range(3):
            for mav in (a, b):
                f.write(struct.pack(">Q", 10**15 + k * 10**5)
                        + mav.attitude_encode(100 * k, 0, 0, 0, 0, 0, 0).pack(mav))
    return read_ardusub(p, {"r": "ATTITUDE.roll"})


# ========================================================================== ArduSub dataflash
_DF_STRUCT = {"Q": "Q", "q": "q", "c": "h", "C": "H", "e": "i", "E": "I", "f": "f", "d": "d",
              "b": "b", "B": "B", "h": "h", "H": "H", "i": "i", "I": "I", "n": "4s", "N": "16s",
              "Z": "64s"}


def _write_dataflash(path: Path) -> Path:
    """A minimal dataflash log, written by hand (pymavlink has no dataflash writer).

    Every message is ``0xA3 0x95 <type id> <payload>`` (little endian).  Type 128 ``FMT``
    (``BBnNZ``: Type, Length incl. the 3 header bytes, Name char[4], Format char[16], Columns
    char[64]) declares each message type, itself included.  ``UNIT`` (id char → unit label) and
    ``FMTU`` (type → one unit id per column, ``#`` marking the instance column) tell the units —
    as ArduPilot writes them.  Format chars: ``Q`` uint64, ``c`` int16 × 0.01, ``f`` float,
    ``B`` uint8, ``H`` uint16, ``b`` int8, ``N`` char[16], ``Z`` char[64].
    """
    types = {"FMT": 128}

    def fmt(type_id, name, form, cols):
        types[name] = type_id
        length = 3 + struct.calcsize("<" + "".join(_DF_STRUCT[c] for c in form))
        return bytes([0xA3, 0x95, 128]) + struct.pack("<BB4s16s64s", type_id, length, name.encode(),
                                                      form.encode(), cols.encode())

    def msg(name, form, *vals):
        return bytes([0xA3, 0x95, types[name]]) + struct.pack(
            "<" + "".join(_DF_STRUCT[c] for c in form),
            *[v.encode() if isinstance(v, str) else v for v in vals])

    out = [fmt(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"),
           fmt(64, "UNIT", "QbZ", "TimeUS,Id,Label"),
           fmt(65, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds"),
           fmt(10, "ATT", "QcccccC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw"),
           fmt(11, "BARO", "QBff", "TimeUS,I,Alt,Press"),
           fmt(12, "RCOU", "QHHH", "TimeUS,C1,C2,C3")]
    for uid, label in (("s", "s"), ("#", "instance"), ("m", "m"), ("d", "deg"), ("P", "Pa"),
                       ("Y", "us"), ("-", "")):
        out.append(msg("UNIT", "QbZ", 0, ord(uid), label))
    out += [msg("FMTU", "QBNN", 0, 10, "sdddddd", "F------"),
            msg("FMTU", "QBNN", 0, 11, "s#mP", "F---"),
            msg("FMTU", "QBNN", 0, 12, "sYYY", "F---")]
    for k in range(N_MSG):
        t = 2_000_000 + 100_000 * k  # TimeUS: 2 s after boot, 10 Hz
        out.append(msg("ATT", "QcccccC", t, 0, 100 * k, 0, -50 * k, 0, 1000 * k))
        out.append(msg("BARO", "QBff", t + 1_000, 0, -0.25 * k, 101325.0 + 2500 * k))
        out.append(msg("BARO", "QBff", t + 1_000, 1, -0.3 * k, 101325.0 + 3000 * k))
        out.append(msg("RCOU", "QHHH", t + 2_000, 1500 + k, 1600, 1400))
    path.write_bytes(b"".join(out))
    return path


def test_dataflash_defaults_instances_and_units(tmp_path):
    pytest.importorskip("pymavlink")
    p = _write_dataflash(tmp_path / "00000042.BIN")
    out = read_ardusub(p)
    k = np.arange(N_MSG)
    t = 2.0 + 0.1 * k
    assert set(out) == {"depth", "roll", "pitch", "yaw", "servo_1", "servo_2", "servo_3"}
    np.testing.assert_allclose(out["roll"].t, t)
    np.testing.assert_allclose(out["roll"]["roll"], np.radians(1.0 * k))
    np.testing.assert_allclose(out["pitch"]["pitch"], np.radians(-0.5 * k))
    np.testing.assert_allclose(out["yaw"]["yaw"], np.radians(10.0 * k))
    np.testing.assert_allclose(out["depth"].t, t + 0.001)
    np.testing.assert_allclose(out["depth"]["depth"], 0.25 * k)  # instance 0 (the primary)
    assert out["depth"].meta["instances"] == {"depth": "I=0"}
    np.testing.assert_allclose(out["servo_1"].t, t + 0.002)
    np.testing.assert_allclose(out["servo_1"]["servo_1"], 1500 + k)
    m = out["servo_1"].meta
    assert m["format"] == "dataflash" and m["units"] == {"servo_1": "pwm_us"}
    assert "RCOU has no field 'C4'" in m["skipped"]["servo_4"]
    assert "no CTUN messages" not in m["skipped"].get("depth", "")


def test_dataflash_named_fields(tmp_path):
    pytest.importorskip("pymavlink")
    p = _write_dataflash(tmp_path / "log.bin")
    out = read_ardusub(p, {"depth2": "-BARO[1].Alt", "p": "BARO[1].Press"},
                       resample="union")
    np.testing.assert_allclose(out["depth2"], 0.3 * np.arange(N_MSG), rtol=1e-6)
    np.testing.assert_allclose(out["p"], 101325.0 + 3000 * np.arange(N_MSG))
    assert out.meta["units"] == {"depth2": "m", "p": "Pa"}  # Press: from the log's FMTU
    with pytest.raises(LogDataError, match=r"BARO has no instance 7 \(I\); instances: 0, 1"):
        read_ardusub(p, {"d": "BARO[7].Alt"})
    with pytest.raises(LogDataError, match="no CTUN messages.*ATT \\(10\\), BARO \\(20\\)"):
        read_ardusub(p, {"d": "-CTUN.Alt"})
    with pytest.raises(LogDataError, match="time='log' needs a telemetry log"):
        read_ardusub(p, time="log")
