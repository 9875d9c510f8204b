"""A piloted dive from a ROS bag, as a BlueROV2 running ArduSub + mavros records it.

:func:`read_bag_dive` reads a ROS 1 ``.bag`` or a ROS 2 bag directory (sqlite3 or MCAP; the
``rosbags`` package, extra ``[logs]``) into the channels of
:class:`~uuvid.io.dive_channels.DiveChannels` (it is called by
:func:`~uuvid.io.dive_channels.read_dive_channels`).  Each *role* has a default topic (what mavros
publishes) that ``topics={role: "topic[:field.path]"}`` (CLI ``--topic role=topic[:field]``)
overrides:

============  =============================================  ====================================
role          default                                        becomes
============  =============================================  ====================================
``pwm``       ``/mavros/rc/out:channels`` (mavros_msgs/      servo outputs [µs], output n =
              RCOut)                                         element n − 1 → thrust → forces
``attitude``  ``/mavros/imu/data:orientation``               ``roll_rad``, ``pitch_rad``,
              (sensor_msgs/Imu)                              ``yaw_rad`` (NED/FRD, see below)
``yaw``       —                                              ``yaw_rad`` as given (rad, NED:
                                                             clockwise from north)
``depth``     —                                              ``depth_m`` as given (m, down)
``altitude``  ``/mavros/global_position/rel_alt:data``       ``depth_m = −altitude``
              (std_msgs/Float64, m, up)
``pressure``  ``/mavros/imu/static_pressure:fluid_pressure``  ``depth_m = (p − p_surface)/(ρ g)``
              (sensor_msgs/FluidPressure, Pa)
``battery``   ``/mavros/battery:voltage``                    ``battery_V``
              (sensor_msgs/BatteryState)
``armed``     ``/mavros/state:armed`` (mavros_msgs/State)    armed intervals
``mode``      ``/mavros/state:mode``                         flight-mode runs
``velocity``  — (geometry_msgs/TwistStamped,                 ``u_mps`` = linear.x,
              TwistWithCovarianceStamped, nav_msgs/Odometry)  ``v_mps`` = −linear.y (FLU body)
``u``, ``v``  —                                              ``u_mps``/``v_mps`` as given (m/s,
                                                             forward / starboard)
============  =============================================  ====================================

Depth: ``depth`` if given, else ``altitude`` (mavros' ``rel_alt`` is ArduSub's
``GLOBAL_POSITION_INT.relative_alt``, positive up), else ``pressure`` (mavros' ``static_pressure``
is ``SCALED_PRESSURE``, barometer 0, which on some BlueROV2s is the enclosure sensor — check) with
``p_surface`` = ``BARO1_GND_PRESS`` from ``params`` else the bag's 5th lowest pressure (samples
outside 30 kPa–20 MPa, no pressure of air or water, left out and said), ρ = 1000
kg/m³ (fresh water; × ``BARO_SPEC_GRAV`` from ``params``), g = 9.80665 m/s².

Heading: mavros publishes ``imu/data`` orientation as the rotation from the FLU ``base_link`` to
the ENU world (REP 103), not ArduSub's FRD-to-NED attitude: it computes ``q_ENU,FLU = Q_NED→ENU ⊗
q_NED,FRD ⊗ Q_FRD→FLU`` with ``Q_NED→ENU`` = roll π, yaw π/2 and ``Q_FRD→FLU`` = roll π (mavros
``ftf_frame_conversions.cpp``, ``plugins/imu.cpp``).  :func:`enu_flu_to_ned_frd` inverts it, so
``yaw_rad`` is the NED heading ArduSub logs (ψ_NED = π/2 − ψ_ENU; pitch up positive, roll right
positive).

Thrust: as for a table with ``pwm_<j>`` columns, the voltage-aware T200 at the logged battery
voltage and the vehicle's ``B``.  A bag holds no ArduSub parameters: output n drives motor n
(thruster n of the vehicle) with ``MOT_n_DIRECTION = +1`` unless ``params`` (``{NAME: value}`` or a
parameter file) gives ``SERVOn_FUNCTION``/``MOT_n_DIRECTION`` (with ``FRAME_CONFIG`` the vehicle is
also checked against ArduSub's frame; give every SERVOn_FUNCTION, as a parameter file does: a motor
no output drives is left out and the vehicle then has a thruster too many); outputs at 0 µs
throughout are disabled outputs, a 0 µs sample is no pulse (no thrust).  Every default used is a
warning.

Time: a topic whose messages carry a non-zero ``header.stamp`` is on that stamp, else on the bag's
receive time; topics on another clock than the servo outputs (receive time against header stamps,
or a header clock seconds away) are moved onto the servo outputs' clock by the median difference
of receive and stamp times, and a warning says by how much.  Samples are sorted; samples sharing
a stamp are merged (mean; the last one for servo outputs, attitude and state), as in the ArduSub
path.  Header stamps that go back in receive order by more than 20 typical steps (and 1 s) and stay
back — a sender restarted, a clock set back, two recordings joined — are not sorted but refused,
naming the message and where to cut the bag, as a table's restarting time column is.

Publishers: a topic that several publish on (a second IMU, a driver started twice) keeps the
messages of one — the node (ROS 1 records it) or header ``frame_id`` that ``topic@SOURCE`` names,
else the one with the most messages — and the warning gives each one's count
(:func:`_one_publisher`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uuvid.io.bag_path import is_bag  # noqa: F401  (re-exported)
from uuvid.io.logs import _RESTART_MIN_S, _RESTART_STEPS, LogDataError, pause_s

__all__ = ["DEFAULT_TOPICS", "ROLES", "BagDive", "read_bag_dive", "enu_flu_to_ned_frd",
           "parse_topic_options", "is_bag"]

G = 9.80665
RHO_FRESH = 1000.0

#: role → default ``topic:field`` (what ArduSub + mavros publish)
DEFAULT_TOPICS = {
    "pwm": "/mavros/rc/out:channels",
    "attitude": "/mavros/imu/data:orientation",
    "altitude": "/mavros/global_position/rel_alt:data",
    "pressure": "/mavros/imu/static_pressure:fluid_pressure",
    "battery": "/mavros/battery:voltage",
    "armed": "/mavros/state:armed",
    "mode": "/mavros/state:mode",
}
#: role → what it is (for messages and help)
ROLES = {
    "pwm": "servo outputs [µs], an array (output n = element n-1)",
    "attitude": "orientation quaternion, ENU world / FLU body (REP 103, as mavros publishes it)",
    "yaw": "heading [rad], NED (clockwise from north)",
    "depth": "depth [m], positive down",
    "altitude": "altitude [m], positive up (depth = -altitude)",
    "pressure": "absolute pressure [Pa]",
    "battery": "battery voltage [V]",
    "armed": "armed flag (bool)",
    "mode": "flight mode name (string)",
    "velocity": "body velocity (TwistStamped, TwistWithCovarianceStamped or Odometry; FLU body)",
    "u": "surge velocity [m/s], forward",
    "v": "sway velocity [m/s], starboard",
}
_DEFAULT_FIELD = {"pwm": "channels", "attitude": "orientation", "battery": "voltage",
                  "pressure": "fluid_pressure", "armed": "armed", "mode": "mode", "velocity": ""}
# definitions used when a bag does not embed them (ROS 2 sqlite3 bags before Iron); current mavros
MAVROS_MSGS = {
    "mavros_msgs/msg/RCOut": "std_msgs/Header header\nuint16[] channels\n",
    "mavros_msgs/msg/State": "std_msgs/Header header\nbool connected\nbool armed\nbool guided\n"
                             "bool manual_input\nstring mode\nuint8 system_status\n",
}
_STEP_ROLES = ("pwm", "attitude", "armed", "mode")  # duplicated stamps: keep the last sample


def parse_topic_options(items) -> dict:
    """``["depth=/my/depth:data", …]`` (the CLI's ``--topic``) or a mapping → ``{role: spec}``."""
    if not items:
        return {}
    if isinstance(items, dict):
        pairs = list(items.items())
    else:
        pairs = []
        for it in items:
            role, sep, spec = str(it).partition("=")
            if not sep or not spec.strip():
                raise LogDataError(f"--topic {it!r}: expected ROLE=TOPIC[:FIELD], e.g. "
                                    "depth=/my/depth:data; roles: " + ", ".join(ROLES))
            pairs.append((role.strip(), spec.strip()))
    out = {}
    for role, spec in pairs:
        if role not in ROLES:
            raise LogDataError(f"--topic {role}={spec}: unknown role {role!r}; roles: "
                                + "; ".join(f"{k} ({v})" for k, v in ROLES.items()))
        out[role] = spec
    return out


def enu_flu_to_ned_frd(qx, qy, qz, qw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch, yaw [rad] (ZYX, FRD body in NED) from quaternions of the FLU body in ENU
    (REP 103, mavros ``imu/data``): ``R_NED,FRD = P · R_ENU,FLU · D`` with ``P`` the ENU↔NED axis
    swap ``[[0,1,0],[1,0,0],[0,0,-1]]`` and ``D = diag(1, −1, −1)`` (FLU↔FRD)."""
    qx, qy, qz, qw = (np.asarray(a, float) for a in (qx, qy, qz, qw))
    n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
    # the elements of R_ENU,FLU needed: R_NED,FRD = P R D has rows (R₁, R₀, −R₂) with columns 1
    # and 2 negated, so N00 = R10, N10 = R00, N20 = −R20, N21 = R21, N22 = R22
    r00 = 1 - 2 * (qy * qy + qz * qz)
    r10 = 2 * (qx * qy + qz * qw)
    r20 = 2 * (qx * qz - qy * qw)
    r21 = 2 * (qy * qz + qx * qw)
    r22 = 1 - 2 * (qx * qx + qy * qy)
    yaw = np.arctan2(r00, r10)  # atan2(N10, N00)
    pitch = np.arcsin(np.clip(r20, -1.0, 1.0))  # −asin(N20)
    roll = np.arctan2(r21, r22)  # atan2(N21, N22)
    return roll, pitch, yaw


# ------------------------------------------------------------------------------------ reading
@dataclass
class _Topic:
    topic: str
    msgtype: str = ""
    recv: list = field(default_factory=list)
    hdr: list | None = field(default_factory=list)
    values: dict = field(default_factory=dict)  # role → list of extracted objects
    src: list = field(default_factory=list)  # per message: (publishing node, header frame)
    index: list = field(default_factory=list)  # per message: its number on the topic (1, 2, …)
    publishers: int = 1  # publishers the bag's metadata lists for the topic (ROS 2 QoS profiles)
    chosen: str | None = None  # the publisher kept where several published together


def _split(role: str, spec: str) -> tuple[str, str]:
    """``"topic[:field]"`` → (topic, field); without a field, the role's usual one (std_msgs
    scalars: ``data``; ``velocity``: found from the message type).  A ``@SOURCE`` suffix (the
    publisher to read, :func:`_one_publisher`) is not part of either."""
    topic, sep, fld = _publisher_pick(spec, role)[0].partition(":")
    return topic.strip(), (fld.strip() if sep else _DEFAULT_FIELD.get(role, "data"))


def _publisher_pick(spec: str, role: str = "ROLE") -> tuple[str, str | None]:
    """``"topic[:field][@SOURCE]"`` → (``"topic[:field]"``, SOURCE or None)."""
    head, sep, pick = spec.strip().rpartition("@")
    if not sep:
        return spec.strip(), None
    if not pick.strip() or not head.strip():
        raise LogDataError(f"--topic {role}={spec}: expected TOPIC[:FIELD]@SOURCE with SOURCE a "
                           "publishing node or a header frame_id, e.g. /mavros/imu/data@/mavros")
    if ":" in pick and ":" not in head:
        src, _, fld = pick.partition(":")
        raise LogDataError(f"--topic {role}={spec}: the field goes before the source: "
                           f"{role}={head.strip()}:{fld.strip()}@{src.strip()}")
    return head.strip(), pick.strip()


def _source_label(key) -> str:
    node, frame = key
    return ", ".join(([f"node {node}"] if node else []) + ([f"frame '{frame}'"] if frame else [])) \
        or "no node or frame named"


def _together(ra: np.ndarray, rb: np.ndarray) -> bool:
    """Two sources publish together (not one after the other, as a node restarted under a new
    name or a frame_id set once the driver is up, where a message or two may cross): five of
    either one's messages (all of them, when it sent fewer: a stray `rostopic pub`) arrive within
    the other's span (a 20 s overlap of two IMUs in a 4-minute bag is together: merged, it made a
    saw-tooth heading)."""
    def inside(x, y):
        return int(np.count_nonzero((x >= y.min()) & (x <= y.max()))) >= min(5, x.size)
    return inside(ra, rb) or inside(rb, ra)


def _one_publisher(tp: _Topic, pick, roles: str, name: str, warnings: list, fail) -> None:
    """Keep the messages of one publisher of a topic that several publish on at the same time.

    Two sensors or two nodes on one topic (a second IMU or depth sensor, a test publisher, a
    driver started twice) read as one series interleave their samples: headings or depths a few
    per cent apart become a saw-tooth the fit takes for motion.  Publishers are told apart by the
    node that published (ROS 1 records it per connection) and the header's ``frame_id``; sources
    that follow one another (:func:`_together` false: a node restarted under a new name, a frame
    set once the driver is up) are one series and all read.  Of sources publishing together, the
    one ``pick`` names (a node or a frame) is kept, else the one with the most messages; the
    choice, the counts and how to choose another are said.  A ROS 2 bag records no node per
    message: when its metadata lists several publishers and their messages carry one frame, that
    is said."""
    keys = tp.src
    uniq: dict = {}
    for k in keys:
        uniq[k] = uniq.get(k, 0) + 1
    recv = np.asarray(tp.recv, np.int64)
    times: dict = {}
    if len(uniq) > 1:
        code = {k: i for i, k in enumerate(uniq)}
        idx = np.array([code[k] for k in keys])
        times = {k: recv[idx == code[k]] for k in uniq}

    def listing():
        return "; ".join(f"{_source_label(k)}: {n} messages" for k, n in uniq.items())

    if pick is not None:
        hit = [k for k in uniq if pick in k]
        if not hit:
            fail(f"{name}: {tp.topic}@{pick}: no publisher {pick!r} on the topic; its publishers: "
                 + listing())
        if any(_together(times[a], times[b]) for i, a in enumerate(hit) for b in hit[i + 1:]):
            fail(f"{name}: {tp.topic}@{pick}: {pick!r} names {len(hit)} publishers that publish "
                 f"together ({listing()}): name one by its node")
        keep_keys = set(hit)
    elif len(uniq) > 1:
        major = max(uniq, key=lambda k: uniq[k])  # the first seen on a tie
        keep_keys = {major} | {k for k in uniq if k != major
                               and not _together(times[k], times[major])}
    else:
        if tp.publishers > 1 and keys:
            warnings.append(
                f"{name}: {tp.topic} had {tp.publishers} publishers when the bag was recorded "
                f"and its messages do not say which sent each ({_source_label(keys[0])} on all): "
                f"read as one series ({roles}) — if two sensors published, their samples are "
                "interleaved; record them on topics of their own")
        return
    if len(uniq) > 1 and len(keep_keys) == len(uniq):
        if pick is None:
            warnings.append(f"{name}: {tp.topic}'s messages come from {len(uniq)} sources one "
                            f"after the other ({listing()}), not together: all read ({roles})")
        return
    if len(uniq) > 1:
        k0 = next(iter(keep_keys)) if pick is not None else major
        others = {k: n for k, n in uniq.items() if k not in keep_keys}
        tie = pick is None and sum(n == uniq[k0] for n in uniq.values()) > 1
        by = (f"as --topic ...@{pick} asks" if pick is not None else
              "as many messages as another: the first to publish" if tie else
              "the one with the most messages")
        warnings.append(
            f"{name}: {tp.topic} has {len(uniq)} publishers ({listing()}); two sources "
            f"publishing together on one topic read as one series interleave their samples: "
            f"{roles} read from {_source_label(k0)} ({by}), the {sum(others.values())} messages "
            f"of the other{'s' if len(others) > 1 else ''} left out; choose with --topic "
            f"ROLE={tp.topic}@SOURCE (a node or a frame)")
    tp.chosen = ", ".join(_source_label(k) for k in uniq if k in keep_keys)
    mask = [k in keep_keys for k in keys]
    tp.recv = [x for x, m in zip(tp.recv, mask) if m]
    if tp.hdr is not None:
        tp.hdr = [x for x, m in zip(tp.hdr, mask) if m]
    tp.values = {r: [x for x, m in zip(v, mask) if m] for r, v in tp.values.items()}
    tp.src = [k for k, m in zip(keys, mask) if m]
    tp.index = [x for x, m in zip(tp.index, mask) if m]


def _walk(msg, fld: str, where: str):
    from uuvid.io.logs import _describe_fields, _msg_fields, _parse_field_path

    cur = msg
    if not fld:
        return cur
    for tok in _parse_field_path(fld):
        if isinstance(tok, int):
            if not isinstance(cur, (list, tuple, np.ndarray)) or not -len(cur) <= tok < len(cur):
                raise LogDataError(f"{where}: cannot take [{tok}] in {fld!r}")
            cur = cur[tok]
        else:
            if tok not in _msg_fields(cur):
                raise LogDataError(f"{where}: no field {tok!r} (in {fld!r}); the fields are: "
                                   f"{_describe_fields(cur)}")
            cur = getattr(cur, tok)
    return cur


def _value(role: str, obj, where: str):
    """The sample of ``role`` from the object at its field path."""
    if role == "pwm":
        if not isinstance(obj, (list, tuple, np.ndarray)):
            raise LogDataError(f"{where}: the servo outputs must be an array (e.g. "
                               f"mavros_msgs/RCOut channels), got {type(obj).__name__}")
        return np.asarray(obj, float)
    if role == "attitude":
        if not all(hasattr(obj, c) for c in ("x", "y", "z", "w")):
            raise LogDataError(f"{where}: attitude must be a quaternion (x, y, z, w), e.g. "
                               "sensor_msgs/Imu orientation; for a heading in radians use --topic "
                               "yaw=TOPIC:FIELD")
        return (float(obj.x), float(obj.y), float(obj.z), float(obj.w))
    if role == "mode":
        return str(obj)
    if role == "velocity":
        for path in ("twist.twist", "twist", ""):  # Odometry / TwistWith…Stamped, TwistStamped
            cur = obj
            for name in filter(None, path.split(".")):
                cur = getattr(cur, name, None)
            lin = getattr(cur, "linear", None) if cur is not None else None
            if lin is not None and hasattr(lin, "x"):
                return (float(lin.x), float(lin.y))
        if hasattr(obj, "x") and hasattr(obj, "y"):  # a Vector3 field path
            return (float(obj.x), float(obj.y))
        raise LogDataError(f"{where}: no body velocity (twist.linear) in "
                           f"{getattr(obj, '__msgtype__', type(obj).__name__)}; give a "
                           "geometry_msgs/TwistStamped or nav_msgs/Odometry topic, or --topic "
                           "u=TOPIC:FIELD and v=TOPIC:FIELD")
    if isinstance(obj, (bool, int, float, np.number, np.bool_)):
        return float(obj)
    raise LogDataError(f"{where}: expected a number for {role} ({ROLES[role]}), got "
                       f"{getattr(obj, '__msgtype__', type(obj).__name__)}")


def _read(bag_path, specs: dict, name: str, fail, picks=None, warnings=None):
    """``{topic: _Topic}`` of the topics that ``specs`` (role → (topic, field, given)) name and the
    bag has, and the bag's topic listing; a topic several publish on keeps one publisher's messages
    (``picks``: topic → the node or frame to keep, see :func:`_one_publisher`; what was done is
    appended to ``warnings``).  ``fail(msg)`` raises the dive error."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from uuvid.io.logs import _bag_locations

    bags, ros, _p = _bag_locations(bag_path)
    fallback = get_typestore(Stores.ROS1_NOETIC if ros == 1 else Stores.ROS2_HUMBLE)
    for mt, text in MAVROS_MSGS.items():
        fallback.register(get_types_from_msg(text, mt))
    try:
        reader = AnyReader(bags, default_typestore=fallback)
        reader.open()
    except Exception as e:  # rosbags' own error types
        fail(f"{name}: cannot read the bag: {type(e).__name__}: {e}")
    try:
        available = {t: (i.msgtype or "several types", i.msgcount)
                     for t, i in reader.topics.items()}
        listing = "; ".join(f"{t} ({mt}, {n} msgs)" for t, (mt, n) in sorted(available.items()))
        want: dict[str, _Topic] = {}
        roles_of: dict[str, list] = {}
        for role, (topic, fld, _given) in specs.items():
            hit = next((c for c in ([topic] if topic.startswith("/") else [topic, "/" + topic])
                        if c in available), None)
            if hit is None:
                continue
            want.setdefault(hit, _Topic(hit, available[hit][0]))
            roles_of.setdefault(hit, []).append((role, fld))
            specs[role] = (hit, fld, specs[role][2])
        conns = [c for c in reader.connections if c.topic in want]
        for conn, t_ns, raw in reader.messages(connections=conns):
            tp = want[conn.topic]
            k = len(tp.recv) + 1
            mt = conn.msgtype
            try:
                if mt in reader.typestore.types:
                    msg = reader.deserialize(raw, mt)
                elif mt in fallback.types:
                    msg = (fallback.deserialize_cdr(raw, mt) if reader.is2
                           else fallback.deserialize_ros1(raw, mt))
                else:
                    fail(f"{name}: topic {conn.topic} has type {mt}, whose definition is neither "
                         "in the bag nor in the built-in type store")
            except LogDataError:
                raise
            except Exception as e:
                fail(f"{name}: topic {conn.topic} message {k}: cannot decode {mt}: {e}")
            tp.recv.append(int(t_ns))
            tp.index.append(k)
            frame = getattr(getattr(msg, "header", None), "frame_id", None)
            tp.src.append((getattr(conn.ext, "callerid", None) or "",
                           frame if isinstance(frame, str) else ""))
            qos = getattr(conn.ext, "offered_qos_profiles", None)
            if isinstance(qos, (list, tuple)):
                tp.publishers = max(tp.publishers, len(qos))
            if tp.hdr is not None:
                st = getattr(getattr(msg, "header", None), "stamp", None)
                if st is None or not hasattr(st, "sec"):
                    tp.hdr = None
                else:
                    tp.hdr.append(int(st.sec) * 1_000_000_000 + int(st.nanosec))
            for role, fld in roles_of[conn.topic]:
                where = f"{name}: {role} topic {conn.topic} ({mt}) message {k}"
                tp.values.setdefault(role, []).append(_value(role, _walk(msg, fld, where), where))
    finally:
        reader.close()
    for topic, tp in want.items():
        roles = ", ".join(r for r, _f in roles_of[topic])
        _one_publisher(tp, (picks or {}).get(topic), roles, name,
                       warnings if warnings is not None else [], fail)
    return want, listing


def _stamps(tp: _Topic) -> tuple[np.ndarray, np.ndarray, str]:
    """(stamps ns, receive ns, which) of a topic's messages."""
    recv = np.asarray(tp.recv, np.int64)
    if tp.hdr is None:
        return recv, recv, "receive time (the message has no header)"
    h = np.asarray(tp.hdr, np.int64)
    if h.size and np.all(h > 0):
        return h, recv, "header.stamp"
    return recv, recv, (f"receive time (header.stamp is zero in {np.count_nonzero(h <= 0)} of "
                        f"{h.size} messages)")


#: messages either side of a jump back whose stamps must stay apart for it to be a restart (two
#: corrupt stamps ahead of the series, or behind it, are no restart)
_RESTART_WINDOW = 5


def _check_restart(st, rc, index, how: str, label: str, name: str, fail) -> None:
    """Refuse a topic whose header stamps, in receive order, jump back by more than
    max(``_RESTART_STEPS`` × the median forward step, ``_RESTART_MIN_S``) and stay back: the rule
    of a table's time column (:func:`uuvid.io.logs._check_restart`).  The sender restarted (an
    autopilot reboot stamps time since boot), a clock was set back, or two recordings were
    joined: sorted, the two parts interleaved into one nonsense series.  Stamps a few steps out of
    order (late arrivals) are sorted into place by :func:`_merge`; a jump back is a restart only
    when the stamps of the next messages stay back against those before it (the lower median of
    :data:`_RESTART_WINDOW` messages before, the upper median of as many after, two at least on
    either side), so a corrupt stamp or two ahead of the series or behind it is none, and stamps
    hours off the rest (:func:`_far_mask`) are left to :func:`_far_stamps`.  The jump is a second
    at least: a clock re-synced by less is :func:`_check_clock_step`'s.  Run on every topic before
    the clock checks, as its message names the message and the stamps where
    :func:`_check_clock_jump`'s says only that receive time − stamp changes."""
    if how != "header.stamp" or st.size < 4:
        return
    far, _lo, _hi = _far_mask((st - st[0]).astype(float) / 1e9)
    keep = np.flatnonzero(~far)
    t = st[keep]
    d = np.diff(t)
    ahead = d[d > 0]
    step = float(np.median(ahead)) / 1e9 if ahead.size else 0.0
    limit = max(_RESTART_STEPS * step, _RESTART_MIN_S) * 1e9
    w = _RESTART_WINDOW
    hits = []
    for j in np.flatnonzero(-d > limit) + 1:
        before, after = np.sort(t[max(0, j - w):j]), np.sort(t[j:j + w])
        if before.size >= 2 and after.size >= 2 and \
                before[(before.size - 1) // 2] - after[after.size // 2] > limit:
            hits.append(int(j))
    if not hits:
        return
    j = hits[0]
    i0, i1 = keep[j - 1], keep[j]
    cut = (int(rc[i0]) + int(rc[i1])) / 2e9
    more = f"; {len(hits) - 1} more such jump(s) later" if len(hits) > 1 else ""
    fail(f"{name}: {label}: header stamps go back at message {index[i1]} (received at bag time "
         f"{rc[i1] / 1e9:.6f} s, {(rc[i1] - rc[0]) / 1e9:.6g} s into the topic): stamped "
         f"{st[i1] / 1e9:.6f} s after {st[i0] / 1e9:.6f} s, {(st[i0] - st[i1]) / 1e9:.6g} s back "
         f"where the typical step is {step:.3g} s{more} — the sender restarted (an autopilot reboot "
         "stamps time since boot), a clock was set back, or two recordings were joined; sorted, "
         "the two parts would interleave into one series: cut the bag there and read each part on "
         f"its own (ROS 1: rosbag filter IN OUT \"t.to_sec() < {cut:.6f}\", or >= it; ROS 2: a copy "
         "of the part before or after, e.g. with the rosbags package) — --t-start/--t-end do not "
         "help: the whole bag is read first; only stamps a few steps out of order are sorted into "
         "place")


def _check_clock_jump(st, rc, how: str, topic: str, name: str, fail, warnings=None) -> None:
    """Refuse a topic whose receive time − header stamp changes by more than a second within the
    bag (2nd to 98th percentile: a few corrupt stamps are not a jump): one of the two clocks
    jumped mid-bag — an autopilot reboot restarting its stamps, or the recording computer's clock
    set back — and the two halves interleaved (heave mass ×17, blamed on the motors).  Stamps
    that go back (a restart) are refused before by :func:`_check_restart`, naming the message."""
    if how != "header.stamp" or st.size < 50:
        return
    d = (rc - st).astype(float) / 1e9
    lo, hi = np.percentile(d, [2, 98])
    if hi - lo <= 1.0:
        _check_clock_step(d, rc, topic, name, fail, warnings)
        return
    k = np.flatnonzero(np.abs(np.diff(d)) > 1.0)
    at = (f" (first after {(rc[k[0]] - rc[0]) / 1e9:.6g} s of the topic's recording)"
          if k.size else "")
    fail(f"{name}: {topic}: receive time − header stamp changes by {hi - lo:.4g} s within the bag"
         f"{at}: a clock jumped mid-bag — the sender's (an autopilot reboot restarts its stamps) "
         "or the recording computer's; the two sides cannot be put on one clock: cut the bag "
         "where it jumps")


#: absolute pressures [Pa] of air (a mountain lake's surface ≈ 55 kPa) or water (2000 m): a
#: sample outside is a glitch (0 Pa from a sensor off its bus) or another unit
PRESSURE_PA = (30e3, 20e6)
GAUGE_LOW_PA = -20e3  # a gauge pressure (median below PRESSURE_PA[0]): 2 m above the water at most
#: a topic's receive − stamp moving by more than this (s) and staying there is a clock step
CLOCK_STEP_S = 0.1
_STEP_BLOCK = 25  # messages per block median


def _check_clock_step(d, rc, topic: str, name: str, fail, warnings=None) -> None:
    """Refuse a topic whose receive time − header stamp ``d`` [s] steps by more than
    :data:`CLOCK_STEP_S` mid-bag and stays there: the medians of its first and last fifths
    (blocks of 25 messages) differ by more than that, most of it in one jump between two blocks.
    Under a second it is no reboot but a re-sync of the sender's clock (mavros and the
    autopilot): the topics on header stamps move together, the ones on receive times do not, and
    each topic's median shift lands on one side or the other — a 0.3 s step put the IMU 0.11 s
    early against the servo outputs (yaw inertia ×0.46).  A recorder stalling or lagging for a
    while and catching up comes back to its level and passes; a lag that grows steadily (the
    recording computer's clock running at another rate) is said in ``warnings``."""
    nb = d.size // _STEP_BLOCK
    if nb < 10:
        return
    b = np.median(d[:nb * _STEP_BLOCK].reshape(nb, _STEP_BLOCK), axis=1)
    fifth = max(2, nb // 5)
    first, last = float(np.median(b[:fifth])), float(np.median(b[-fifth:]))
    total = last - first
    if abs(total) <= CLOCK_STEP_S:
        return
    jumps = np.diff(b)
    j = int(np.argmax(np.abs(jumps)))
    if abs(jumps[j]) < 0.5 * abs(total):  # no one jump: a steady drift
        if warnings is not None:
            warnings.append(f"{name}: {topic}: receive time − header stamp drifts by {total:+.3g} s "
                            "over the bag (the recording computer's clock and the sender's run at "
                            "different rates): the topics on receive times are off by up to "
                            f"{abs(total) / 2:.2g} s against those on header stamps at the bag's ends")
        return
    at = rc[(j + 1) * _STEP_BLOCK] / 1e9
    fail(f"{name}: {topic}: receive time − header stamp steps from {first:+.3f} s to {last:+.3f} s "
         f"and stays (near receive time {at:.3f} s, {(rc[(j + 1) * _STEP_BLOCK] - rc[0]) / 1e9:.4g} "
         "s into the topic): the sender's clock was re-synced mid-bag, and the topics on header "
         "stamps and those on receive times cannot be put on one clock across it; cut the bag "
         f"there (ROS 1: rosbag filter IN OUT \"t.to_sec() < {at:.3f}\", or > it; ROS 2: a copy "
         "of the part before or after, e.g. with the rosbags package) — --t-start/--t-end do not "
         "help: the whole bag is put on one clock first")


def _merge(t: np.ndarray, v: np.ndarray, last: bool) -> tuple[np.ndarray, np.ndarray, int]:
    """Sorted by time; samples sharing a stamp merged (mean, or the last one)."""
    o = np.argsort(t, kind="stable")
    t, v = t[o], v[o]
    if t.size < 2:
        return t, v, 0
    start = np.concatenate(([True], np.diff(t) != 0))
    nd = int(t.size - np.count_nonzero(start))
    if nd:
        if last:
            v = v[np.concatenate((start[1:], [True]))]
        else:
            g = np.cumsum(start) - 1
            cnt = np.bincount(g)
            v = (np.stack([np.bincount(g, weights=c) for c in np.atleast_2d(v.T)]).T
                 / cnt[:, None]).reshape((-1,) + v.shape[1:])
        t = t[start]
    return t, v, nd


@dataclass
class BagDive:
    """What :func:`read_bag_dive` read; :func:`uuvid.io.dive_channels.read_dive_channels` turns
    the servo outputs into forces and the state into armed intervals and mode runs."""

    name: str
    format: str
    channels: dict  # name → (t, v), forces not yet computed
    pwm: dict  # motor → (t, pwm as logged; 0 = no pulse)
    directions: dict  # motor → MOT_n_DIRECTION
    pwm_label: str
    armed: tuple | None  # (t, armed 0/1) or None
    modes: tuple | None  # (t, names) or None
    warnings: list
    sources: dict
    t_end: float  # the last sample of any channel [s]


#: a topic whose median (receive − header stamp) differs from the servo outputs' by more than
#: this [ns] is stamped by another clock and moved onto theirs (a 0.3 s offset of the IMU's clock,
#: left in place under the former 1 s threshold, gave yaw inertia −60 %); below it the
#: difference is the recorder's latency, said in the time-stamp note
CLOCK_SHIFT_NS = 100_000_000
#: a topic whose stamps span more than this (s) holds a clock jump, not a dive: refused (an
#: autopilot rebooted mid-bag and stamped time since boot: 10⁹ s of "dive", cut into 10⁸ windows)
MAX_BAG_SPAN_S = 2 * 86400.0


#: share of a topic's samples that may hold another value at the same stamp before it is refused
MAX_CONFLICT_SHARE = 0.05


def _check_conflicts(t, v, topic: str, role: str, name: str, warnings: list, fail) -> None:
    """Samples of one topic sharing a stamp with different values (a second publisher, or a
    sender re-stamping): said with the count and the largest difference, refused beyond
    :data:`MAX_CONFLICT_SHARE` of the samples (a table refuses any: its rows have no second
    sender) — merged silently they biased heave mass by 7 σ."""
    o = np.argsort(t, kind="stable")
    ts = t[o]
    vs = np.asarray(v, float)[o].reshape(ts.size, -1)
    same = np.flatnonzero(np.diff(ts) == 0)
    if not same.size:
        return
    diff = np.abs(vs[same + 1] - vs[same])
    diff = np.where(np.isfinite(diff), diff, 0.0).max(axis=1)
    clash = same[diff > 0]
    if not clash.size:
        return
    k = int(clash[np.argmax(diff[diff > 0])])
    what = (f"{name}: {topic} ({role}): {clash.size} of {ts.size} samples share a time stamp with "
            f"another of different value (up to {float(np.max(diff)):.4g} apart, at t = "
            f"{ts[k]:.6g} s): two publishers on one topic, or a sender re-stamping")
    if clash.size > MAX_CONFLICT_SHARE * ts.size:
        fail(what + "; expected one value per stamp — record each sensor on a topic of its own")
    warnings.append(what + ": merged (mean; the last for servo outputs and state)")


#: two sources interleaved on one topic (same node and frame: not told apart by
#: :func:`_one_publisher`) are seen in stretches of this many samples in which the middle of every
#: three samples sits off its neighbours' mean, alternately above and below, in at least
#: :data:`INTERLEAVED_ALTERNATING` of the steps, by :data:`INTERLEAVED_RATIO` × what a sample moves
#: from the one two steps before (the same source's change).  One noisy sensor alternates in about
#: 73 % of the steps (white noise) with a ratio of about 0.9; a smooth motion has a ratio near 0
INTERLEAVED_BLOCK = 100
INTERLEAVED_ALTERNATING = 0.8
INTERLEAVED_RATIO = 4.0
#: share of a topic's stretches that may look interleaved before the topic is refused
INTERLEAVED_SHARE = 0.1


def _saw_tooth(x: np.ndarray) -> tuple[float, float, float] | None:
    """(share of alternating steps, the offset between the two levels, the same-parity change) of
    a stretch whose samples alternate between two levels, or ``None``."""
    x = x[np.isfinite(x)]
    if x.size < 20:
        return None
    c = x[1:-1] - 0.5 * (x[:-2] + x[2:])  # a sample off its neighbours' mean
    w = np.median(np.abs(x[2:] - x[:-2]))  # the change two samples apart: one source's
    off = float(np.median(np.abs(c)))
    alt = float(np.mean(c[:-1] * c[1:] < 0))
    if w > 0 and off > INTERLEAVED_RATIO * w and alt >= INTERLEAVED_ALTERNATING:
        return alt, off, float(w)
    return None


def _check_interleaved(t, cols: dict, topic: str, role: str, name: str, fail,
                       warnings: list) -> None:
    """A topic whose samples alternate between two levels (a saw-tooth the fit would take for
    motion): refused when its stamps also come in pairs — two sensors publishing on it under one
    node and frame, which nothing else tells apart; else a warning (two sources whose stamps do
    not pair, or real content at half the sampling rate: vibration, a load toggling every
    sample).  ``cols``: label → the samples (sorted by ``t``)."""
    n = t.size
    if n < 20:
        return
    starts = range(0, max(n - INTERLEAVED_BLOCK // 2, 1), INTERLEAVED_BLOCK)
    for label, x in cols.items():
        hits = [(i, r) for i in starts
                if (r := _saw_tooth(np.asarray(x[i:i + INTERLEAVED_BLOCK], float))) is not None]
        if not hits or len(hits) < INTERLEAVED_SHARE * len(starts):
            continue
        i, (alt, off, w) = hits[0]
        d = np.diff(t[i:i + INTERLEAVED_BLOCK])
        pairs = ""
        if d.size >= 4:
            a, b = sorted((float(np.median(d[0::2])), float(np.median(d[1::2]))))
            if b > 3 * a:
                pairs = f"; its stamps come in pairs {a * 1e3:.3g} ms apart, every {a + b:.3g} s"
        seen = (f"{name}: {topic} ({role}): {label} saw-tooths in {len(hits)} of {len(starts)} "
                f"stretches of {INTERLEAVED_BLOCK} samples (first from t = {t[i]:.6g} s): "
                f"successive samples alternate between two levels {off:.2g} apart ({alt:.0%} of "
                f"the steps change direction) while every other sample moves only {w:.2g}{pairs}")
        if pairs:
            fail(seen + " — two sources interleaved on one topic (a second sensor published with "
                 "the same node and frame), whose merged series the fit would take for motion; "
                 "expected one source per topic — record each sensor on a topic of its own (or a "
                 "frame_id of its own), or filter the bag to one of them")
        else:
            warnings.append(seen + " — two sources interleaved on one topic (a second sensor "
                            "with the same node and frame), or real content at half the "
                            "sampling rate (vibration, a load toggling every sample): a fit "
                            f"takes either for motion; check {topic} in the bag")


#: a sample stamped more than this (s) outside the 0.5–99.5 % range of its topic's stamps, with
#: at most 1 % of them so: a corrupt stamp, left out (not a clock jump, not a day-long "gap")
FAR_STAMP_S = 3600.0


def _far_mask(t) -> tuple[np.ndarray, float, float]:
    """(mask of the samples stamped hours outside the rest of their topic, the 0.5 and 99.5 %
    stamps): the samples more than :data:`FAR_STAMP_S` [s] outside that range, when they are at
    most 1 % of 50 or more; none else."""
    keep = np.isfinite(t)
    none = np.zeros(t.size, bool)
    if t.size < 50 or not keep.any():
        return none, math.nan, math.nan
    lo, hi = np.percentile(t[keep], [0.5, 99.5])
    far = keep & ((t < lo - FAR_STAMP_S) | (t > hi + FAR_STAMP_S))
    return (far if far.sum() <= 0.01 * t.size else none), float(lo), float(hi)


def _far_stamps(t, topic: str, role: str, name: str, warnings: list) -> np.ndarray:
    """Mask of the samples to keep: those not stamped hours outside the rest of their topic."""
    keep = np.isfinite(t)
    if role in ("armed", "mode"):
        return keep
    far, lo, hi = _far_mask(t)
    if far.any():
        k = int(np.flatnonzero(far)[0])
        warnings.append(f"{name}: {int(far.sum())} {topic} ({role}) sample(s) stamped far outside "
                        f"the rest (first: t = {t[k]:.6g} s, the others within {lo:.6g}…{hi:.6g} "
                        "s): corrupt stamps, left out")
        return keep & ~far
    return keep


def _check_gaps(t, topic: str, role: str, name: str, warnings: list, fail) -> None:
    """Say a pause in a topic (:func:`~uuvid.io.logs.pause_s`, as a dive table's: no sample spans
    it, fit each side on its own), refuse a span of
    days (:data:`MAX_BAG_SPAN_S`); state topics (armed, mode) publish on change and are exempt."""
    if t.size < 2 or role in ("armed", "mode"):
        return
    span = float(t[-1] - t[0])
    if span > MAX_BAG_SPAN_S:
        d = np.diff(t)
        i = int(np.argmax(d))
        fail(f"{name}: {topic} ({role}) time stamps span {span / 86400:.3g} days, with a jump of "
             f"{d[i]:.6g} s after t = {t[i]:.6g} s: a clock jump (an autopilot reboot stamping "
             "time since boot, or a sender's clock set mid-bag), not a dive; record the dive "
             "again or cut the bag at the jump")
    gap = pause_s(t)  # the one pause rule, a dive table's too
    if gap is None:
        return
    d = np.diff(t)
    big = np.flatnonzero(d > gap)
    if big.size:
        i = int(big[0])
        warnings.append(f"{name}: {topic} ({role}) stops for {d[i]:.4g} s (from t = {t[i]:.6g} s)"
                        + (f", and {big.size - 1} more gap(s) over {gap:.3g} s" if big.size > 1
                           else "")
                        + ": a recording pause or a dropped link; no sample spans it, so fit and "
                        "replay each side on its own (--t-start/--t-end)")


def _pressure_depth(td, p, prm: dict, topic: str, name: str, warnings: list, fail):
    """``(t, depth, how)`` from absolute pressures ``p`` [Pa] (:data:`PRESSURE_PA`; samples
    outside are glitches, left out and said; a median below it is a gauge pressure, read from
    0 Pa): ``depth = (p − p_surface)/(ρ g)`` with ``p_surface`` = ``BARO1_GND_PRESS`` of ``prm``
    (said when the bag's lowest pressure is 10 cm of water above it) else the bag's 5th lowest
    sample (the lowest of a short bag: one 0 Pa sample as the surface made every depth 10 m too
    deep), ρ = 1000 kg/m³ × ``BARO_SPEC_GRAV``."""
    from uuvid.io.ardusub.frames import check_spec_grav

    sg = check_spec_grav(float(prm.get("BARO_SPEC_GRAV", prm.get("GND_SPEC_GRAV", 1.0))), name)
    rho = RHO_FRESH * sg
    gauge = p.size > 0 and float(np.median(p)) < PRESSURE_PA[0]  # 0 at the surface
    lo_pa = GAUGE_LOW_PA if gauge else PRESSURE_PA[0]
    span = f"{lo_pa / 1e3:g} kPa–{PRESSURE_PA[1] / 1e6:g} MPa"
    if gauge:
        warnings.append(f"{name}: {topic} has median {float(np.median(p)):.0f} Pa, below any "
                        f"absolute pressure of air ({PRESSURE_PA[0] / 1e3:g} kPa): read as a gauge "
                        "pressure (0 at the surface; sensor_msgs/FluidPressure is absolute — check "
                        "the driver)")
    odd = ~((p >= lo_pa) & (p <= PRESSURE_PA[1]))
    if odd.any():  # 0 Pa from a sensor that lost its bus, a value of another unit
        k = np.flatnonzero(odd)
        warnings.append(f"{name}: {k.size} {topic} sample(s) outside {span}, no pressure of air "
                        f"or water (first at t = {td[k[0]]:.6g} s: {p[k[0]]:.6g} Pa): left out")
        td, p = td[~odd], p[~odd]
        if not p.size:
            fail(f"{name}: no {topic} sample is a pressure of air or water ({span}): is it in Pa?")
    kth = min(4, p.size // 20)  # the 5th lowest (a lower one in a short bag)
    low = float(np.partition(p, kth)[kth])
    gnd = prm.get("BARO1_GND_PRESS")
    if gauge:
        ps, ps_how = 0.0, "0 Pa (a gauge pressure)"
    elif gnd is not None and math.isfinite(float(gnd)) and float(gnd) > 0:
        ps, ps_how = float(gnd), f"BARO1_GND_PRESS = {float(gnd):g} Pa (--params)"
        if low - ps > rho * G * 0.1:
            warnings.append(
                f"{name}: BARO1_GND_PRESS = {ps:g} Pa is {(low - ps) / (rho * G):.2g} m of water "
                f"below the bag's lowest pressure ({low:.0f} Pa): the vehicle is never shallower "
                "than that — fine if the bag starts under water; if the vehicle was at the "
                "surface in it, BARO1_GND_PRESS is from another day, the depth reads that much "
                "too deep and the heave fit's surface cut-off admits surface windows (then leave "
                "BARO1_GND_PRESS out: the surface is taken from the bag)")
    else:
        nth = ("lowest", "2nd lowest", "3rd lowest", "4th lowest", "5th lowest")[kth]
        ps, ps_how = low, (f"the bag's lowest pressure ({low:.0f} Pa, its {nth} sample"
                           + (": a few glitches do not move it" if kth else "")
                           + "; default: no BARO1_GND_PRESS in --params)")
    if p.size > 1 and float(np.ptp(p)) < rho * G * 0.05:
        fail(f"{name}: pressure topic {topic} varies by only {float(np.ptp(p)):.0f} Pa (< 5 cm of "
             "water) over the bag: it is not the water pressure (mavros' static_pressure is "
             "SCALED_PRESSURE, barometer 0, on some BlueROV2s the enclosure sensor); pass --topic "
             "depth=TOPIC:FIELD or --topic altitude=TOPIC:FIELD")
    how = (f"depth = (p − p_surface)/(ρ g), p_surface = {ps_how}, ρ = {rho:g} kg/m³ "
           + ("(BARO_SPEC_GRAV from --params)" if sg != 1.0 else
              "(fresh water, default; sea water ≈ 1025: give BARO_SPEC_GRAV in --params)")
           + f", g = {G} m/s²")
    return td, (p - ps) / (rho * G), how


def read_bag_dive(path, veh, *, topics=None, params=None) -> BagDive:
    """Read a bag (see the module doc); raises :class:`~uuvid.io.logs.LogDataError` naming the bag,
    the topic looked for, the bag's topics and the option to pass."""
    from pathlib import Path

    from uuvid.io.ardusub.frames import check_vehicle, config_from_params
    from uuvid.io.ardusub.sources import merge_params
    from uuvid.io.logs import _require

    p = Path(path)
    name = p.name
    _require("rosbags", "reading ROS bags")

    def fail(msg):
        raise LogDataError(msg)

    if veh is None:
        fail(f"{name}: a ROS bag needs --vehicle (its thruster geometry turns the servo outputs "
             "into forces and moments)")
    given = parse_topic_options(topics)
    warnings: list = []
    specs = {}
    picked = {}  # role → the publisher asked for (topic@SOURCE)
    for role in ROLES:
        if role in given:
            specs[role] = (*_split(role, given[role]), True)
            pick = _publisher_pick(given[role], role)[1]
            if pick is not None:
                picked[role] = pick
        elif role in DEFAULT_TOPICS:
            specs[role] = (*_split(role, DEFAULT_TOPICS[role]), False)
    picks: dict = {}
    for role, pick in picked.items():
        topic = specs[role][0]
        alt = topic if topic.startswith("/") else "/" + topic
        for tpc in {topic, alt}:
            if picks.get(tpc, pick) != pick:
                fail(f"{name}: --topic asks for two publishers of {topic} ({picks[tpc]!r} and "
                     f"{pick!r}): one topic is read from one publisher")
            picks[tpc] = pick
    data, listing = _read(p, specs, name, fail, picks, warnings)

    def have(role):
        return role in specs and specs[role][0] in data and data[specs[role][0]].recv

    def missing(role, what, alt=""):
        topic, fld, _g = specs[role]
        return (f"{name}: no {what}: the bag has no topic {topic} ({role}: {ROLES[role]}); "
                f"the bag's topics are: {listing or '(none)'}; pass --topic {role}=TOPIC:FIELD"
                + alt)

    for role, (_topic, _fld, g) in specs.items():
        if g and not have(role):
            fail(missing(role, f"{role} topic given by --topic"))
    if not have("pwm"):
        fail(missing("pwm", "servo outputs"))
    if not (have("yaw") or have("attitude")):
        fail(missing("attitude", "heading", " (a quaternion) or --topic yaw=TOPIC:FIELD (NED "
                     "heading in rad)"))
    depth_role = next((r for r in ("depth", "altitude", "pressure") if have(r)), None)
    if depth_role is None:
        fail(missing("altitude", "depth", f" (altitude, up) or --topic depth=TOPIC:FIELD (down) "
                     f"or --topic pressure=TOPIC:FIELD (Pa; default {DEFAULT_TOPICS['pressure']})"))
    # ---- one clock: the servo outputs'
    # stamps that restart (every topic first: the most precise message), then the clocks
    stamped = {tp.topic: _stamps(tp) for tp in data.values() if tp.recv}
    for topic, (st, rc, how) in stamped.items():
        roles = ", ".join(r for r, (tpc, _f, _g) in specs.items() if tpc == topic)
        _check_restart(st, rc, np.asarray(data[topic].index), how, f"{topic} ({roles})", name, fail)
    clocks = {}
    for topic, (st, rc, how) in stamped.items():
        _check_clock_jump(st, rc, how, topic, name, fail, warnings)
        clocks[topic] = (st, float(np.median(rc - st)), how)
    ref_topic = specs["pwm"][0]
    ref_off = clocks[ref_topic][1]
    ref_hdr = clocks[ref_topic][2] == "header.stamp"
    t_ns, stamp_note = {}, {}
    for tp, (st, off, how) in clocks.items():
        shift = 0.0
        same_kind = (how == "header.stamp") == ref_hdr
        if not same_kind or abs(off - ref_off) > CLOCK_SHIFT_NS:
            shift = off - ref_off
        t_ns[tp] = st + int(round(shift))
        stamp_note[tp] = how + (f", moved by {shift / 1e9:+.3f} s onto the clock of {ref_topic} "
                                f"(median receive − stamp: {off / 1e9:.3f} s here, "
                                f"{ref_off / 1e9:.3f} s there)" if shift else
                                f" (its receive − stamp differs from {ref_topic}'s by "
                                f"{(off - ref_off) / 1e9:+.3f} s: left in place)"
                                if abs(off - ref_off) > 0.01e9 else "")
    t0 = min(int(t.min()) for t in t_ns.values())
    warnings.append(f"{name}: time stamps: " + "; ".join(f"{tp}: {stamp_note[tp]}"
                                                        for tp in sorted(stamp_note))
                    + f"; t = 0 is bag time {t0} ns")
    chans: dict = {}
    sources: dict = {}
    dups: dict = {}

    def series(role):
        tp = specs[role][0]
        t = (t_ns[tp] - t0).astype(float) / 1e9
        vals = data[tp].values[role]
        if role == "mode":
            # mode strings are merged by index (the last one of a stamp)
            o = np.argsort(t, kind="stable")
            ts = t[o]
            keep = np.concatenate((np.diff(ts) != 0, [True])) if ts.size else np.zeros(0, bool)
            return ts[keep], np.asarray(vals, object)[o][keep]
        if role == "pwm":
            width = max(len(v) for v in vals)
            arr = np.full((len(vals), width), np.nan)
            for i, v in enumerate(vals):
                arr[i, :len(v)] = v
        else:
            arr = np.asarray(vals, float)
        ok = np.isfinite(t) & (np.all(np.isfinite(arr.reshape(len(vals), -1)), axis=1)
                               if role != "pwm" else True)
        ok = ok & _far_stamps(t, tp, role, name, warnings)
        if role != "mode":
            _check_conflicts(t[ok], arr[ok], tp, role, name, warnings, fail)
        tt, vv, nd = _merge(t[ok], arr[ok], role in _STEP_ROLES)
        if nd:
            dups[f"{tp} ({role})"] = nd
        _check_gaps(tt, tp, role, name, warnings, fail)
        if role not in ("pwm", "armed", "mode"):
            tc = tt
            if role == "attitude":  # as angles; quaternions that are no rotation are left out below
                q = vv.reshape(tt.size, 4)
                good = np.abs(np.linalg.norm(q, axis=1) - 1.0) < 0.1
                tc, q = tt[good], q[good]
                r_, p_, y_ = enu_flu_to_ned_frd(q[:, 0], q[:, 1], q[:, 2], q[:, 3])
                cols = {"roll [rad]": r_, "pitch [rad]": p_, "the heading [rad]": np.unwrap(y_)}
            else:
                v2 = vv.reshape(tt.size, -1)
                cols = {"xyz"[k] if 1 < v2.shape[1] <= 3 else "the value": v2[:, k]
                        for k in range(v2.shape[1])}
            _check_interleaved(tc, cols, tp, role, name, fail, warnings)
        return tt, vv

    def src(role, how):
        topic, fld, g = specs[role]
        pub = f" [publisher {data[topic].chosen}]" if data[topic].chosen else ""
        return (f"{topic}:{fld}{pub} ({data[topic].msgtype}) {how}; "
                f"{stamp_note[topic].split(',')[0]}" + ("" if g else "; default topic"))

    # ---- heading
    if have("yaw"):
        ty, y = series("yaw")
        chans["yaw_rad"] = (ty, np.unwrap(y))
        sources["yaw_rad"] = src("yaw", "as given (rad, NED), unwrapped")
    else:
        tq, q = series("attitude")
        nq = np.linalg.norm(q, axis=1) if q.size else np.zeros(0)
        bad = ~(np.abs(nq - 1.0) < 0.1)  # all zeros: an IMU not yet initialised, not a rotation
        if bad.any():
            k = np.flatnonzero(bad)
            warnings.append(f"{name}: {k.size} {specs['attitude'][0]} quaternions are not "
                            f"rotations (norm {nq[k[0]]:.3g}, first at t = {tq[k[0]]:.6g} s; an "
                            "IMU not yet initialised publishes zeros): left out")
            tq, q = tq[~bad], q[~bad]
        roll, pitch, yaw = enu_flu_to_ned_frd(q[:, 0], q[:, 1], q[:, 2], q[:, 3])
        chans["roll_rad"], chans["pitch_rad"] = (tq, roll), (tq, pitch)
        chans["yaw_rad"] = (tq, np.unwrap(yaw))
        how = ("quaternion of the FLU body in ENU (REP 103, as mavros publishes it) → roll, pitch, "
               "yaw of the FRD body in NED (ψ_NED = π/2 − ψ_ENU), yaw unwrapped")
        for c in ("roll_rad", "pitch_rad", "yaw_rad"):
            sources[c] = src("attitude", how)
        if not specs["attitude"][2]:
            warnings.append(f"{name}: heading from {specs['attitude'][0]} (default): {how}")
    # ---- depth
    td, d = series(depth_role)
    if depth_role == "depth":
        how = "as given (m, positive down)"
    elif depth_role == "altitude":
        d = -d
        how = "depth = −altitude (m, positive up: mavros rel_alt is ArduSub's " \
              "GLOBAL_POSITION_INT.relative_alt)"
    else:
        prm = merge_params({}, params, []) if params is not None else {}
        td, d, how = _pressure_depth(td, d, prm, specs["pressure"][0], name, warnings, fail)
    chans["depth_m"] = (td, d)
    sources["depth_m"] = src(depth_role, how)
    if not specs[depth_role][2]:
        why = {"altitude": "", "pressure": f" (no {DEFAULT_TOPICS['altitude'].split(':')[0]} in "
                                           "the bag; mavros' static_pressure is SCALED_PRESSURE, "
                                           "barometer 0 — on some BlueROV2s the enclosure "
                                           "sensor: check)"}
        warnings.append(f"{name}: depth from {specs[depth_role][0]} (default){why[depth_role]}: "
                        f"{how}")
    # ---- battery, velocities
    if have("battery"):
        tb, vb = series("battery")
        good = vb > 0  # BatteryState: NaN or 0 when unknown
        chans["battery_V"] = (tb[good], vb[good])
        sources["battery_V"] = src("battery", "voltage [V]")
    else:
        warnings.append(f"{name}: no {specs['battery'][0]} topic (battery): thrust at the T200 "
                        "sheet's nominal 16 V (default); pass --topic battery=TOPIC:FIELD")
    if have("velocity"):
        tv, uv = series("velocity")
        chans["u_mps"], chans["v_mps"] = (tv, uv[:, 0]), (tv, -uv[:, 1])
        for c in ("u_mps", "v_mps"):
            sources[c] = src("velocity", "twist.linear of the FLU body: u = x, v = −y (starboard)")
        warnings.append(f"{name}: velocities from {specs['velocity'][0]}: taken as the body's "
                        "(FLU, REP 103: Odometry's child frame / the stamped frame) linear "
                        "velocity: u_mps = x, v_mps = −y")
    for role, c in (("u", "u_mps"), ("v", "v_mps")):
        if have(role):
            chans[c] = series(role)
            sources[c] = src(role, f"as given ({ROLES[role]})")
    # ---- servo outputs → motors → forces
    tp_, P = series("pwm")
    seen = {k + 1: bool(np.any(np.isfinite(P[:, k]) & (P[:, k] > 0))) for k in range(P.shape[1])}
    prm = merge_params({}, params, warnings)
    B = np.asarray(veh.B, float)
    frame_given = "FRAME_CONFIG" in prm
    cfg_params = prm if frame_given else {**prm, "FRAME_CONFIG": 7}
    try:
        config = config_from_params(cfg_params, name=name, outputs_seen=seen, custom_B=B)
        check_vehicle(config, veh, name=name)
    except LogDataError as e:
        raise LogDataError(str(e) + ("" if frame_given else
                                     "; a bag has no ArduSub parameters: output n drives thruster "
                                     "n of the vehicle unless --params gives SERVOn_FUNCTION")) from None
    for note in config.notes:
        if note.startswith(("BARO_PRIMARY", "FRAME_CONFIG = 7")):
            continue
        warnings.append(f"{name}: " + note.replace(" not in the log", " not given (a ROS bag "
                                                   "holds no ArduSub parameters; --params)")
                        .replace("no SERVOn_FUNCTION in the log", "no SERVOn_FUNCTION given")
                        .replace("give --params", "pass --params"))
    if not frame_given:
        warnings.append(f"{name}: no FRAME_CONFIG given: {veh.name}'s thruster j is motor j and "
                        "pushes along its B column (not checked against an ArduSub frame)")
    if config.disabled_outputs:
        warnings.append(f"{name}: outputs {', '.join(map(str, config.disabled_outputs))} are 0 µs "
                        "throughout (disabled) and drive no motor")
    used = {m.output for m in config.active}
    extra = [k for k, s in seen.items() if s and k not in used]
    if extra:
        warnings.append(f"{name}: outputs {', '.join(map(str, extra))} carry PWM but drive no "
                        f"thruster of {veh.name} (lights, gripper, camera tilt?): ignored")
    pwm, dirs = {}, {}
    # a message with fewer channels than an active output holds no sample of it (its NaN was read
    # as 0 µs, no thrust: heave mass −25 % with nothing said): such messages are left out
    short = np.zeros(tp_.size, bool)
    for m in config.active:
        short |= ~np.isfinite(P[:, m.output - 1])
    if short.any() and not short.all():
        k = int(np.flatnonzero(short)[0])
        need = max(m.output for m in config.active)
        warnings.append(f"{name}: {int(short.sum())} of {short.size} {specs['pwm'][0]} messages "
                        f"hold fewer than the {need} channels the motors use (first at t = "
                        f"{tp_[k]:.6g} s): those messages are left out, not read as 0 µs")
        tp_, P = tp_[~short], P[~short]
    for m in config.active:
        col = P[:, m.output - 1]
        pwm[str(m.number)] = (tp_, np.where(np.isfinite(col), col, 0.0))
        dirs[str(m.number)] = m.direction
    label = f"{specs['pwm'][0]} outputs " + ", ".join(f"{m.output}→motor {m.number}"
                                                       for m in config.active)
    for c in ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"):
        sources[c] = src("pwm", "servo outputs → thrust at "
                         + ("battery_V" if "battery_V" in chans else "the nominal 16 V") + " → B·T")
    t_end = max([float(c[0][-1]) for c in chans.values() if c[0].size] + [float(tp_[-1])])
    armed = modes = None
    if have("armed"):
        armed = series("armed")
        sources["armed"] = src("armed", "armed flag; a state holds until the next message")
    else:
        warnings.append(f"{name}: no {specs['armed'][0]} topic (armed): every sample is taken as "
                        "armed (default); pass --topic armed=TOPIC:FIELD")
    if have("mode"):
        modes = series("mode")
        sources["mode"] = src("mode", "flight mode name")
    if dups:
        warnings.append(f"{name}: merged samples with duplicated time stamps (mean; the last one "
                        "for servo outputs, attitude and state): "
                        + ", ".join(f"{k}: {v}" for k, v in dups.items()))
    fmt = "rosbag1" if p.suffix == ".bag" else "rosbag2"
    return BagDive(name, fmt, chans, pwm, dirs, label, armed, modes, warnings, sources, t_end)
