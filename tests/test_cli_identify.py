"""``uuvid vehicle identify steady|inertia``, ``uuvid vehicle design-input``, ``uuvid reproduce
caccia2000`` and the vehicle-file write-back, on small synthetic ROMEO-like logs made with the
library's 1-DOF model (constant-thrust segments in two mapping modes, per-segment thrust errors and
disturbances, compass noise, spikes and dropouts; a sine experiment; heave with ballast; the same
data as a ROS 2 bag and Parquet; an ArduSub telemetry log of a BlueROV2 whose thrust comes from the
servo outputs)."""

from __future__ import annotations

import csv
import json
import math
import struct

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from uuvid.cli.identify_cmds import register
from uuvid.cli.vehicle_cmds import simulate
from uuvid.identify.vehicle.fit import simulate_one_dof
from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.model import OneDofModel
from uuvid.vehicle.writeback import WritebackError, write_identified

runner = CliRunner()

# ROMEO yaw (Caccia et al. 2000, Table III): I = 84, k = 20.5, k_q = 49.5; FL-RR open water for a
# positive torque, η_hull 0.60 for a negative one; horizontal-all η_hull-prop 0.62 both ways
YAW = {"I": 84.0, "k": 20.5, "k_q": 49.5, "eta_hull": 0.60, "eta_hull_prop": 0.62}
HEAVE = {"m": 1050.0, "k": 44.7, "k_q": 430.3, "W": -13.5, "dW": 7.1, "eta": 0.56}
DT = 0.1


def _app() -> typer.Typer:
    app = typer.Typer()
    vehicle = typer.Typer()
    reproduce = typer.Typer()
    app.add_typer(vehicle, name="vehicle")
    app.add_typer(reproduce, name="reproduce")
    app.command("simulate")(simulate)
    register(vehicle, reproduce)

    @app.callback()
    def _root():
        pass

    return app


APP = _app()


def _run(*args):
    return runner.invoke(APP, [str(a) for a in args])


def _json(*args) -> dict:
    r = _run(*args, "--json")
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


def _write_csv(path, cols: dict):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        for row in zip(*cols.values()):
            w.writerow(["" if isinstance(v, float) and not math.isfinite(v) else
                        (v if isinstance(v, str) else repr(float(v))) for v in row])
    return path


def _integrate(v, x0=0.0):
    return np.concatenate([[x0], x0 + np.cumsum(0.5 * (v[1:] + v[:-1]) * DT)])


# ------------------------------------------------------------------------------------ data
def _yaw_steady_log():
    """20 constant-torque segments (32 s) in two modes, a 10 Hz compass in degrees wrapped to
    [0, 360) with 0.3° noise, ~0.3 % spikes of 5–20° and ~0.5 % dropouts (empty cells)."""
    rng = np.random.default_rng(0)
    eta = {("yaw_fl_rr", 1): 1.0, ("yaw_fl_rr", -1): YAW["eta_hull"],
           ("horizontal_all", 1): YAW["eta_hull_prop"], ("horizontal_all", -1): YAW["eta_hull_prop"]}
    levels = {"yaw_fl_rr": (1.5, 3.5, 6.0, 9.0, 12.5, -2.5, -6.0, -10.0, -15.0, -20.0),
              "horizontal_all": (2.5, 6.0, 10.0, 15.0, 20.0, -2.5, -6.0, -10.0, -15.0, -20.0)}
    force, modes, deliv = [0.0] * 50, ["yaw_fl_rr"] * 50, [0.0] * 50
    for m, lv in levels.items():
        for L in lv:
            n = int(32 / DT)
            d = rng.normal(0, 0.2)
            force += [L] * n
            modes += [m] * n
            deliv += [eta[(m, 1 if L > 0 else -1)] * L * (1 + rng.normal(0, 0.015)) + d] * n
    force, deliv = np.array(force), np.array(deliv)
    t = np.arange(force.size) * DT
    r = simulate_one_dof(OneDofModel(YAW["I"], YAW["k"], YAW["k_q"]), t, deliv)
    y = np.degrees(_integrate(r, 0.3)) + rng.normal(0, 0.3, t.size)
    spikes = np.flatnonzero(rng.random(t.size) < 0.003)
    y[spikes] += rng.uniform(5, 20, spikes.size) * rng.choice([-1, 1], spikes.size)
    y = np.mod(y, 360.0)
    y[rng.random(t.size) < 0.005] = np.nan
    return {"time": t, "torque": force, "heading_deg": y, "mode": modes}, spikes


def _yaw_sine_log(period=24.0, duration=130.0):
    """The paper's yaw sine: −5 + 4 sin(2πt/24) N·m in open water (FR-RL), 10 Hz compass."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, duration, DT)
    f = -5.0 + 4.0 * np.sin(2 * np.pi * t / period)
    # a small coloured disturbance so that σ is not degenerate
    ou = np.zeros(t.size)
    for i in range(1, t.size):
        ou[i] = 0.95 * ou[i - 1] + rng.normal(0, 0.05)
    r = simulate_one_dof(OneDofModel(YAW["I"], YAW["k"], YAW["k_q"]), t, f + ou)
    y = np.mod(np.degrees(_integrate(r)) + rng.normal(0, 0.3, t.size), 360.0)
    return {"time": t, "torque": f, "heading_deg": y}


def _heave_log():
    """Three ballasts × six down/up steps (eq. 20); depth at 10 Hz, 1 cm noise, dropouts."""
    rng = np.random.default_rng(2)
    force, ball, deliv = [], [], []
    for n in range(3):
        for L in (20.0, -40.0, 45.0, -75.0, 75.0, -110.0):
            k = int(70 / DT)
            e = 1.0 if L > 0 else HEAVE["eta"]
            force += [L] * k
            ball += [float(n)] * k
            deliv += [e * L * (1 + rng.normal(0, 0.02)) + HEAVE["W"] + n * HEAVE["dW"]
                      + rng.normal(0, 0.8)] * k
    t = np.arange(len(force)) * DT
    v = simulate_one_dof(OneDofModel(HEAVE["m"], HEAVE["k"], HEAVE["k_q"]), t, np.array(deliv))
    z = _integrate(v, 2.0) + rng.normal(0, 0.01, t.size)
    z[rng.random(t.size) < 0.005] = np.nan
    return {"time": t, "thrust": np.array(force), "depth": z, "ballast": np.array(ball)}


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    cols, spikes = _yaw_steady_log()
    return {"dir": d, "yaw": _write_csv(d / "yaw_steady.csv", cols), "yaw_cols": cols,
            "spikes": spikes, "sine": _write_csv(d / "yaw_sine.csv", _yaw_sine_log())}


STEADY_COLS = ("--dof", "yaw", "--command-col", "torque", "--position-col", "heading_deg",
               "--angle-unit", "deg", "--mode-col", "mode", "--settle", "12", "--min-duration",
               "15")
ETA_MAP = "yaw_fl_rr+=1,yaw_fl_rr-=eta_hull,horizontal_all=eta_hull_prop"


def _within(row, truth, n=3.0):
    return abs(row["estimate"] - truth) <= n * row["sigma"]


# ------------------------------------------------------------------------------------ steady
@pytest.fixture(scope="module")
def steady(logs):
    d = logs["dir"]
    doc = _json("vehicle", "identify", "steady", logs["yaw"], *STEADY_COLS, "--eta-map", ETA_MAP,
                "--report", d / "steady_report", "--write-vehicle", "romeo", "--out-vehicle",
                d / "romeo_identified.yaml")
    (d / "steady.json").write_text(json.dumps(doc))
    return doc


@pytest.mark.slow
def test_steady_recovers_drag_and_installation_coefficients(steady):
    p = steady["parameters"]
    assert set(p) == {"k", "k_q", "w", "eta_hull", "eta_hull_prop"}
    for name, truth in (("k", YAW["k"]), ("k_q", YAW["k_q"]), ("w", 0.0),
                        ("eta_hull", YAW["eta_hull"]), ("eta_hull_prop", YAW["eta_hull_prop"])):
        assert _within(p[name], truth), (name, p[name])
        assert set(p[name]) >= {"estimate", "sigma", "unit", "percentile_error", "significant"}
    assert p["k"]["unit"] == "N·m·s/rad" and steady["units"]["velocity"] == "rad/s"
    assert steady["quadratic_significant"] is True and steady["reduced_to"] is None
    assert steady["n_points"] == 20 and len(steady["segments"]) == 20
    assert steady["eta_map"] == {"yaw_fl_rr+": None, "yaw_fl_rr-": "eta_hull",
                                 "horizontal_all": "eta_hull_prop"}
    m = steady["model"]
    assert m["dof"] == "yaw" and np.shape(m["drag_covariance"]) == (2, 2)
    assert m["eta"]["yaw_fl_rr"]["pos"] == 1.0
    assert m["eta"]["yaw_fl_rr"]["neg"] == pytest.approx(p["eta_hull"]["estimate"])
    assert m["open_water"] == ["yaw_fl_rr+"]


@pytest.mark.slow
def test_steady_flags_compass_spikes_and_reports_them(steady, logs):
    rej = steady["rejected"]
    assert rej and all(r["reason"] == "outlier" for r in rej)
    assert steady["rejections"]["outliers"] == len(rej)
    # the flagged samples are injected spikes (rows of the CSV that carry a heading)
    t_spikes = set(np.round(logs["yaw_cols"]["time"][logs["spikes"]], 6))
    assert sum(round(r["time"], 6) in t_spikes for r in rej) >= 0.8 * len(rej)
    rep = logs["dir"] / "steady_report"
    for f in ("index.html", "steady_fit.png", "steady_log.png", "segments.csv", "rejected.csv",
              "fit_report.txt", "summary.json"):
        assert (rep / f).is_file(), f
    html = (rep / "index.html").read_text()
    assert "Rejected samples" in html and "eta_hull_prop" in html
    assert steady["report"].endswith("index.html")


@pytest.mark.slow
def test_steady_counts_dropped_headings_as_missing(steady, logs):
    """Empty heading cells inside the segments are samples lost, not silently absent: they count
    in "missing" and in the total (it said "4332/4347 used, 0 missing" with dropouts)."""
    r = steady["rejections"]
    y, t = logs["yaw_cols"]["heading_deg"], logs["yaw_cols"]["time"]
    in_seg = sum(np.count_nonzero(np.isnan(y) & (t >= s["t0"]) & (t <= s["t1"]))
                 for s in steady["segments"])
    assert in_seg > 0 and r["missing"] == in_seg
    assert r["used"] + r["missing"] + r["outliers"] == r["samples"]


def test_no_segment_message_says_what_was_excluded_and_the_remedy():
    from uuvid.cli.log_options import flags
    from uuvid.identify.vehicle.logs import LogData
    from uuvid.identify.vehicle.procedures import identify_steady

    t = np.arange(0.0, 100.0, 0.1)
    cmd = np.where(t < 50, 5.0, -5.0)
    pos = np.cumsum(cmd) * 0.01
    info = {"source": "dive.tlog", "closed_loop_why": "left out 100 s disarmed", "armed_s": 0.0}
    never = LogData(t, cmd, t, pos, info=info, closed_loop=np.ones(t.size, bool))
    with pytest.raises(ValueError) as e:
        identify_steady(never, "yaw")
    m = str(e.value)
    assert f"{t.size} of {t.size} command samples" in m and "disarmed" in m
    assert "never armed in MANUAL" in m and "`open_loop_only=False`" in m
    assert "--all-modes" in flags(m) and "rel_tol" not in m
    # open loop only for 8 s: too short for settle + min_duration, and it says which knobs
    short = LogData(t, cmd, t, pos, info={"source": "x.BIN"}, closed_loop=~((t > 40) & (t < 58)))
    with pytest.raises(ValueError) as e:
        identify_steady(short, "yaw")
    m = str(e.value)
    assert "excluded as not open loop" in m and "longest stretch" in m
    assert "`settle=`" in m and "`min_duration=`" in m
    assert "--settle" in flags(m) and "--min-duration" in flags(m)


@pytest.mark.slow
def test_open_water_mode_gives_the_same_fit_with_generated_names(logs, steady):
    doc = _json("vehicle", "identify", "steady", logs["yaw"], *STEADY_COLS,
                "--open-water-mode", "yaw_fl_rr+")
    assert doc["eta_map"] == {"yaw_fl_rr+": None, "yaw_fl_rr-": "eta_yaw_fl_rr_neg",
                              "horizontal_all+": "eta_horizontal_all",
                              "horizontal_all-": "eta_horizontal_all"}
    assert doc["parameters"]["eta_yaw_fl_rr_neg"]["estimate"] == pytest.approx(
        steady["parameters"]["eta_hull"]["estimate"], rel=1e-12)
    assert doc["parameters"]["k"]["estimate"] == pytest.approx(
        steady["parameters"]["k"]["estimate"], rel=1e-12)


@pytest.mark.slow
def test_robust_covariance_and_no_reduce_options(logs):
    doc = _json("vehicle", "identify", "steady", logs["yaw"], *STEADY_COLS, "--eta-map", ETA_MAP,
                "--cov-type", "HC3", "--no-quadratic")
    assert doc["cov_type"] == "HC3" and "k_q" not in doc["parameters"]


@pytest.mark.slow
def test_write_back_round_trip_and_the_new_vehicle_flies(steady, logs):
    path = logs["dir"] / "romeo_identified.yaml"
    assert steady["vehicle_out"] == str(path)
    v = load_vehicle(path)
    p = steady["parameters"]
    assert v.params.linear_damping[5, 5] == pytest.approx(p["k"]["estimate"], rel=1e-5)
    assert v.params.quadratic_damping[5, 5] == pytest.approx(p["k_q"]["estimate"], rel=1e-5)
    od = v.one_dof["yaw"]
    assert od.linear == pytest.approx(p["k"]["estimate"], rel=1e-5)
    assert od.eta_neg == pytest.approx(p["eta_hull"]["estimate"], rel=1e-5) and od.eta_pos == 1.0
    assert v.modes["yaw_fl_rr"].eta_dof["yaw-"] == pytest.approx(p["eta_hull"]["estimate"], rel=1e-5)
    assert v.modes["horizontal_all"].eta_dof["yaw"] == pytest.approx(
        p["eta_hull_prop"]["estimate"], rel=1e-5)
    assert v.modes["horizontal_all"].eta_dof["surge+"] == 0.73  # untouched
    assert v.params.linear_damping[0, 0] == load_vehicle("romeo").params.linear_damping[0, 0]
    assert "yaw_steady.csv" in json.dumps(v.source)
    r = _json("simulate", "mission", "square", "--vehicle", path)
    # the written vehicle is named after its file, not the base's name (it is not the preset)
    assert r["completed"] is True and r["vehicle"] == "romeo_identified"


def test_write_back_refuses_a_negative_added_mass(tmp_path):
    with pytest.raises(WritebackError, match="below the rigid-body inertia"):
        write_identified("romeo", {"yaw": {"mass": 50.0}}, tmp_path / "x.yaml")
    assert not (tmp_path / "x.yaml").exists()
    out = write_identified("romeo", {"surge": {"mass": 900.0, "linear": 50.0, "quadratic": 300.0}},
                           tmp_path / "s.yaml", log="pool.csv")
    v = load_vehicle(out)
    assert v.params.added_mass[0, 0] == pytest.approx(450.0)
    assert v.params.mass_matrix[0, 0] == pytest.approx(900.0)
    with pytest.raises(WritebackError, match="negative"):
        write_identified("romeo", {"yaw": {"linear": -1.0}}, tmp_path / "y.yaml")


# ------------------------------------------------------------------------------------ inertia
@pytest.mark.slow
def test_inertia_from_the_steady_json_and_from_the_written_vehicle(steady, logs):
    d = logs["dir"]
    cols = ("--dof", "yaw", "--command-col", "torque", "--position-col", "heading_deg",
            "--angle-unit", "deg")
    doc = _json("vehicle", "identify", "inertia", logs["sine"], *cols, "--drag", d / "steady.json",
                "--report", d / "inertia_report")
    m = doc["parameters"]["m"]
    assert set(doc["parameters"]) == {"m", "c", "b"}
    assert _within(m, YAW["I"]), m
    assert doc["mass"]["estimate"] == m["estimate"] and doc["drag"]["covariance_propagated"]
    assert m["sigma_from_drag"] > 0
    pl = doc["phase_lag"]
    assert pl["period"] == pytest.approx(24.0, rel=1e-3)
    assert pl["k_L"] > doc["drag"]["k"]  # k + 2 k_q |ξ̄|
    assert pl["predicted_deg"] == pytest.approx(
        math.degrees(math.atan(pl["omega"] * m["estimate"] / pl["k_L"])), rel=1e-9)
    assert abs(pl["measured_deg"] - pl["predicted_deg"]) < 3.0
    assert doc["fit_nrmse"] < 0.1
    assert (d / "inertia_report" / "inertia.png").is_file()
    # the vehicle written by `identify steady`: its one_dof yaw model is in FL-RR mode, whose
    # negative torque sees η_hull; the sine ran in open water → --eta 1
    doc2 = _json("vehicle", "identify", "inertia", logs["sine"], *cols, "--drag",
                 d / "romeo_identified.yaml", "--one-dof", "yaw", "--eta", "1",
                 "--write-vehicle", d / "romeo_identified.yaml", "--out-vehicle", d / "romeo2.yaml")
    assert doc2["drag"]["k"] == pytest.approx(steady["parameters"]["k"]["estimate"], rel=1e-5)
    assert _within(doc2["parameters"]["m"], YAW["I"])
    v = load_vehicle(d / "romeo2.yaml")
    assert v.params.mass_matrix[5, 5] == pytest.approx(doc2["mass"]["estimate"], rel=1e-5)
    assert v.one_dof["yaw"].mass == pytest.approx(doc2["mass"]["estimate"], rel=1e-5)


# ------------------------------------------------------------------------------------ heave
@pytest.mark.slow
def test_heave_with_ballast_and_the_buoyancy_figure(tmp_path):
    path = _write_csv(tmp_path / "heave.csv", _heave_log())
    doc = _json("vehicle", "identify", "steady", path, "--dof", "heave", "--command-col",
                "thrust", "--position-col", "depth", "--ballast-col", "ballast", "--settle", "40",
                "--min-duration", "20", "--open-water-mode", "+", "--report", tmp_path / "rep")
    p = doc["parameters"]
    assert set(p) == {"k", "k_q", "W", "dW", "eta_neg"}
    for name, truth in (("k", HEAVE["k"]), ("k_q", HEAVE["k_q"]), ("W", HEAVE["W"]),
                        ("dW", HEAVE["dW"]), ("eta_neg", HEAVE["eta"])):
        assert _within(p[name], truth), (name, p[name])
    b = doc["buoyancy"]
    assert [r["ballast"] for r in b["with_eta"]] == [0.0, 1.0, 2.0]
    assert len(b["eta_unitary"]) == 3
    for r, n in zip(b["with_eta"], range(3)):
        assert abs(r["estimate"] - (HEAVE["W"] + n * HEAVE["dW"])) < 3 * r["sigma"]
    assert (tmp_path / "rep" / "steady_fit.png").is_file()


# ------------------------------------------------------------------------------------ other logs
@pytest.mark.slow
def test_the_same_log_as_parquet_and_as_a_ros2_bag(logs, steady, tmp_path):
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    pytest.importorskip("rosbags")
    cols = logs["yaw_cols"]
    pq = tmp_path / "yaw.parquet"
    pd.DataFrame(cols).to_parquet(pq)
    doc = _json("vehicle", "identify", "steady", pq, *STEADY_COLS, "--eta-map", ETA_MAP)
    assert doc["parameters"]["k"]["estimate"] == pytest.approx(
        steady["parameters"]["k"]["estimate"], rel=1e-9)
    # ROS 2 bag: torque at 10 Hz, heading (rad) where present, the mode as a number on change
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    F64 = ts.types["std_msgs/msg/Float64"]
    bag = tmp_path / "yaw_bag"
    t0 = 1_700_000_000 * 10**9
    code = {"yaw_fl_rr": 0.0, "horizontal_all": 1.0}
    with Writer(bag, version=9) as w:
        cc = w.add_connection("/cmd/torque", F64.__msgtype__, typestore=ts)
        ch = w.add_connection("/compass", F64.__msgtype__, typestore=ts)
        cm = w.add_connection("/mapping_mode", F64.__msgtype__, typestore=ts)
        last = None
        for i, tt in enumerate(cols["time"]):
            ns = t0 + int(round(tt * 1e9))
            if cols["mode"][i] != last:
                w.write(cm, ns, ts.serialize_cdr(F64(data=code[cols["mode"][i]]), F64.__msgtype__))
                last = cols["mode"][i]
            w.write(cc, ns, ts.serialize_cdr(F64(data=float(cols["torque"][i])), F64.__msgtype__))
            if math.isfinite(cols["heading_deg"][i]):
                w.write(ch, ns + 1000, ts.serialize_cdr(
                    F64(data=math.radians(cols["heading_deg"][i])), F64.__msgtype__))
    doc = _json("vehicle", "identify", "steady", bag, "--dof", "yaw", "--topic",
                "command=/cmd/torque:data", "--topic", "position=/compass", "--topic",
                "mode=/mapping_mode", "--settle", "12", "--min-duration", "15", "--eta-map",
                "0+=1,0-=eta_hull,1=eta_hull_prop")
    assert doc["format"] == "rosbag"
    for name in ("k", "k_q", "eta_hull", "eta_hull_prop"):
        assert doc["parameters"][name]["estimate"] == pytest.approx(
            steady["parameters"][name]["estimate"], rel=2e-3), name


def _write_tlog(path, params: bool = False, reversed_motors=()):
    """A BlueROV2 turning on the spot: horizontal servos at 1500 ± δ (yaw pattern), ATTITUDE.yaw
    (wrapped to ±π) from the 1-DOF yaw model driven by B T(PWM) through the T200 model.

    ``params``: also the parameter download (FRAME_CONFIG 1, SERVOn_FUNCTION, MOT_n_DIRECTION)
    and MANUAL/armed heartbeats; ``reversed_motors``: MOT_n_DIRECTION = −1 for these motors, whose
    outputs ArduSub then mirrors about 1500 µs (the trap of real vehicles)."""
    from pymavlink import mavutil
    from pymavlink.dialects.v20 import ardupilotmega as mavlink2

    from uuvid.io.ardusub import default_t200

    v = load_vehicle("bluerov2")
    chains = [v.thruster_chain(j) for j in range(v.layout.n)]
    t200 = default_t200()
    s = np.sign(v.B[5, :4])
    pwm, tau = [], []
    for d in (80, 120, 180, 250, 330, 400, -80, -120, -180, -250, -330, -400):
        p = np.full(8, 1500.0)
        p[:4] = 1500 + s * d
        if params:  # what the log reader uses: the voltage-aware T200 at the logged 15.2 V
            T = t200.thrust(p[:6], np.full(6, 15.2))
        else:
            T = np.array([c.steady_thrust(np.array([p[j]]))[0] for j, c in enumerate(chains)])
        pwm += [p] * 100
        tau += [float(v.B[5] @ T)] * 100
    tau = np.array(tau)
    t = np.arange(tau.size) * DT
    P = v.params
    r = simulate_one_dof(OneDofModel(P.mass_matrix[5, 5], P.linear_damping[5, 5],
                                     P.quadratic_damping[5, 5]), t, tau)
    yaw = _integrate(r) + np.random.default_rng(3).normal(0, 0.003, t.size)
    yaw = (yaw + np.pi) % (2 * np.pi) - np.pi
    path.touch()
    log = mavutil.mavlink_connection(str(path), write=True)
    sub = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)

    def put(t_unix, msg):
        log.write(struct.pack(">Q", int(round(t_unix * 1e6))) + msg.pack(sub))

    put(1.7e9, sub.heartbeat_encode(mavlink2.MAV_TYPE_SUBMARINE,
                                    mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0))
    if params:
        plist = {"FRAME_CONFIG": 1.0, "BARO_PRIMARY": 0.0}
        for j in range(1, 9):
            plist[f"SERVO{j}_FUNCTION"] = float(32 + j if j <= 6 else 0)
        for j in range(1, 7):
            plist[f"MOT_{j}_DIRECTION"] = -1.0 if j in reversed_motors else 1.0
        for i, (name, val) in enumerate(plist.items()):
            put(1.7e9 + 0.001 * (i + 1), sub.param_value_encode(name.encode(), val, 9,
                                                                  len(plist), i))
    mirror = np.array([-1.0 if j + 1 in reversed_motors else 1.0 for j in range(8)])
    for k in range(t.size):
        boot = 5.0 + t[k]
        if params and k % 10 == 0:  # 1 Hz: MANUAL (19), armed
            put(1.7e9 + boot, sub.heartbeat_encode(
                mavlink2.MAV_TYPE_SUBMARINE, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
                mavlink2.MAV_MODE_FLAG_SAFETY_ARMED | mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                19, mavlink2.MAV_STATE_ACTIVE))
            put(1.7e9 + boot + 0.005, sub.sys_status_encode(0, 0, 0, 500, 15200, 300, 90,
                                                            0, 0, 0, 0, 0, 0))
        pwm[k] = 1500 + mirror * (pwm[k] - 1500)
        put(1.7e9 + boot + 0.01, sub.attitude_encode(int(round(boot * 1000)), 0.0, 0.0,
                                                     float(yaw[k]), 0, 0, 0))
        put(1.7e9 + boot + 0.02, sub.servo_output_raw_encode(int(round(boot * 1e6)), 0,
                                                             *[int(x) for x in pwm[k]]))
    log.close()
    return P


@pytest.mark.slow
def test_ardusub_tlog_thrust_from_the_servo_outputs(tmp_path):
    pytest.importorskip("pymavlink")
    P = _write_tlog(tmp_path / "dive.tlog")
    doc = _json("vehicle", "identify", "steady", tmp_path / "dive.tlog", "--dof", "yaw",
                "--vehicle", "bluerov2", "--settle", "2", "--min-duration", "5")
    assert doc["format"] == "tlog" and "servo" in doc["log_info"]["command_from"]
    assert _within(doc["parameters"]["k"], P.linear_damping[5, 5])
    assert _within(doc["parameters"]["k_q"], P.quadratic_damping[5, 5])
    assert any("holds no parameters" in w for w in doc["log_info"]["warnings"])
    r = _run("vehicle", "identify", "steady", tmp_path / "dive.tlog", "--dof", "yaw")
    assert r.exit_code == 2 and "--vehicle" in r.output


@pytest.mark.slow
def test_ardusub_tlog_read_as_its_parameters_describe_the_vehicle(tmp_path):
    """With the parameter download the log itself says the frame (FRAME_CONFIG 1 → the BlueROV2
    preset, said in the notes), which output drives which motor and which motors are reversed:
    reversed motors' mirrored PWM gives the same yaw drag (ignoring MOT_n_DIRECTION would flip
    their thrust and wreck it)."""
    pytest.importorskip("pymavlink")
    P = _write_tlog(tmp_path / "dive.tlog", params=True, reversed_motors=(1, 2, 4))
    doc = _json("vehicle", "identify", "steady", tmp_path / "dive.tlog", "--dof", "yaw",
                "--settle", "2", "--min-duration", "5")
    assert "N_Nm" in doc["log_info"]["command_from"]
    notes = " ".join(doc["log_info"]["notes"])
    assert "bluerov2 preset" in notes and "FRAME_CONFIG = 1" in notes and "open-loop" in notes
    assert _within(doc["parameters"]["k"], P.linear_damping[5, 5])
    assert _within(doc["parameters"]["k_q"], P.quadratic_damping[5, 5])


# ------------------------------------------------------------------------------------ design
@pytest.mark.slow
def test_design_input_paper_frequency_and_command_file(tmp_path):
    doc = _json("vehicle", "design-input", "--k", "28.6", "--mass-air", "93.75", "--speed",
                str(-5 / 28.6))
    assert doc["omega_opt"] == pytest.approx(0.176, rel=0.02)
    assert doc["omega_opt_numeric"] == pytest.approx(doc["omega_opt"], rel=1e-4)
    assert doc["omega_verification"]["verified"] is True
    assert doc["tau_c"] == pytest.approx(93.75 / 28.6)
    lo, hi = doc["tau_c_range"]
    assert lo == pytest.approx(1.1 * 93.75 / 28.6) and hi == pytest.approx(2 * 93.75 / 28.6)
    assert doc["offset"] < 0 and 0 < doc["amplitude"] < abs(doc["offset"])
    out = tmp_path / "cmd.csv"
    doc = _json("vehicle", "design-input", "--k", "46.9", "--kq", "306.2", "--mass", "675",
                "--mass-air", "450", "--speed", "0.27", "--speed-range", "0.1,0.35", "--vehicle",
                "romeo", "--mode", "surge_front", "--dof", "surge", "--voltage-cv", "1.02,1.09",
                "--out", out)
    assert doc["omega_opt"] == pytest.approx(0.18, rel=0.02)
    rows = list(csv.reader(out.open()))
    assert rows[0][:3] == ["time", "force_N", "thrust_HFL"] and "voltage_HRR" in rows[0]
    assert len(rows) - 1 == doc["command_samples"]
    f = np.array([float(r[1]) for r in rows[1:]])
    assert f.min() > 0  # no thrust reversal
    r = _run("vehicle", "design-input", "--k", "28.6", "--speed", "0.1")
    assert r.exit_code == 2 and "--mass-air" in r.output


# ------------------------------------------------------------------------------------ reproduce
@pytest.mark.slow
def test_reproduce_caccia2000_fast_json():
    doc = _json("reproduce", "caccia2000", "--fast")
    tables = ("heave", "yaw_linear_quadratic", "yaw_low_speed", "yaw_linear",
              "surge_forward_standard", "surge_backward_standard", "surge_forward_plankton",
              "surge_backward_plankton", "yaw_inertia", "surge_mass")
    for t in tables:
        for name, row in doc[t]["parameters"].items():
            assert {"estimate", "sigma", "truth", "paper_sigma"} <= set(row), (t, name)
    assert doc["yaw_low_speed"]["quadratic_significant"] is False
    assert doc["yaw_low_speed"]["reduced_to"] == "linear"
    d = doc["design"]
    assert d["omega_opt_yaw"] == pytest.approx(0.176, rel=0.02)
    assert d["omega_opt_surge"] == pytest.approx(0.18, rel=0.02)
    assert abs(d["phase_lag_yaw_deg"] - 37.6) < 0.5 and abs(d["phase_lag_surge_deg"] - 45.4) < 0.5
    assert doc["acceptance"]["passed"] is True


# ------------------------------------------------------------------------------------ errors
@pytest.mark.slow
def test_clear_errors_exit_2(logs, tmp_path):
    r = _run("vehicle", "identify", "steady", tmp_path / "nope.csv", "--dof", "yaw")
    assert r.exit_code == 2 and "no such log file" in r.output
    r = _run("vehicle", "identify", "steady", logs["yaw"], "--dof", "yaw", "--command-col", "tau")
    assert r.exit_code == 2 and "'tau'" in r.output and "available columns" in r.output
    bad = tmp_path / "bad.csv"
    bad.write_text("time,torque,heading_deg,mode\n0,1,0,a\n0.1,x,1,a\n")
    r = _run("vehicle", "identify", "steady", bad, "--dof", "yaw", "--command-col", "torque",
             "--position-col", "heading_deg")
    assert r.exit_code == 2
    assert "bad.csv" in r.output and "'torque'" in r.output and "row 2" in r.output
    r = _run("vehicle", "identify", "steady", logs["yaw"], *STEADY_COLS)
    assert r.exit_code == 2 and "--open-water-mode" in r.output
    r = _run("vehicle", "identify", "steady", logs["yaw"], *STEADY_COLS, "--open-water-mode", "fwd")
    assert r.exit_code == 2 and "'fwd'" in r.output
    r = _run("vehicle", "identify", "steady", logs["yaw"], *STEADY_COLS, "--eta-map", ETA_MAP,
             "--write-vehicle", "romeo")
    assert r.exit_code == 2 and "--out-vehicle" in r.output
    r = _run("vehicle", "identify", "inertia", logs["sine"], "--dof", "yaw")
    assert r.exit_code == 2 and "--drag" in r.output
    # an identified inertia below the rigid body's: refused, nothing written
    heavy = tmp_path / "heavy.yaml"
    import yaml

    raw = yaml.safe_load((load_vehicle("romeo").path).read_text())
    raw["rigid_body"]["inertia"] = [43.5, 64.6, 100.0]
    raw["hydrodynamics"]["added_mass"][5] = 0.0
    for t in raw["thrusters"]:
        t["model"] = str(load_vehicle("romeo").path.parent / t["model"])
    heavy.write_text(yaml.safe_dump(raw))
    r = _run("vehicle", "identify", "inertia", logs["sine"], "--dof", "yaw", "--k", "20.5",
             "--kq", "49.5", "--command-col", "torque", "--position-col", "heading_deg",
             "--angle-unit", "deg", "--write-vehicle", heavy, "--out-vehicle", tmp_path / "h2.yaml")
    assert r.exit_code == 2 and "below the rigid-body inertia" in r.output
    assert not (tmp_path / "h2.yaml").exists()


# ------------------------------------------------------------------------------------ design options
DESIGN_BASE = ("vehicle", "design-input", "--k", "2", "--mass-air", "0.16", "--speed", "0.5")


@pytest.mark.parametrize("dof", ["pitch", "roll"])
def test_design_input_refuses_a_dof_the_vehicle_cannot_drive(tmp_path, dof):
    """Wrote all-zero thruster columns beside a 1 … 1.6 N·m moment, exit 0, no word; and the
    error of a failed allocation said '--mode None' when no mode was given."""
    out = tmp_path / "p.csv"
    r = _run(*DESIGN_BASE, "--dof", dof, "--vehicle", "bluerov2", "--out-file", str(out))
    assert r.exit_code == 2, r.output
    assert dof in r.output and "bluerov2" in r.output and "None" not in r.output
    assert not out.exists()


def test_design_input_voltage_cv_needs_a_vehicle():
    for value in ("1.02,1.09", "garbage"):
        r = _run(*DESIGN_BASE, "--dof", "yaw", "--voltage-cv", value)
        assert r.exit_code == 2, r.output
        assert "--voltage-cv" in r.output and "--vehicle" in r.output


def test_design_input_vehicle_without_out_file_says_nothing_is_written():
    r = _run(*DESIGN_BASE, "--dof", "yaw", "--vehicle", "bluerov2")
    assert r.exit_code == 0, r.output
    assert "--out-file" in r.stderr and "not written" in r.stderr


def test_design_input_command_column_names_its_unit(tmp_path):
    cols = {}
    for dof in ("yaw", "surge"):
        out = tmp_path / f"{dof}.csv"
        doc = _json(*DESIGN_BASE, "--dof", dof, "--vehicle", "bluerov2", "--out-file", str(out))
        cols[dof] = out.read_text().splitlines()[0].split(",")
        assert doc["columns"] == cols[dof]
    assert cols["yaw"][:2] == ["time", "torque_Nm"] and cols["surge"][:2] == ["time", "force_N"]
    r = _run(*DESIGN_BASE, "--out-file", str(tmp_path / "x.csv"))
    assert r.exit_code == 2 and "--dof" in r.output and not (tmp_path / "x.csv").exists()
