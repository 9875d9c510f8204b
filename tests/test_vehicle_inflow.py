"""Vehicle-file inflow switch and the steady analyses with thrust at the advance speed (issue 21)."""

import math
import re

import numpy as np
import pytest
import yaml
from numba import njit

from uuvid.vehicle import VehicleFileError, load_vehicle, vehicle_from_dict
from uuvid.vehicle.definition import preset_path
from uuvid.vehicle.envelope import speed_envelope
from uuvid.vehicle.inflow import inflow_limits


def _preset_raw(name):
    return yaml.safe_load(preset_path(name).read_text())


def _with(name, inflow="four-quadrant", wake=None):
    raw = _preset_raw(name)
    raw["inflow"] = inflow
    if wake is not None:
        for t in raw["thrusters"]:
            t["wake"] = wake
    return vehicle_from_dict(raw, where=f"{name}.yaml")


# ------------------------------------------------------------------ file
def test_file_switch_and_wake_are_read():
    v = _with("bluerov2", wake=0.2)
    assert v.inflow == "four-quadrant"
    assert v.wake == (0.2,) * 6
    assert load_vehicle("bluerov2").inflow == "none"


@pytest.mark.parametrize("mutate, expected", [
    (lambda r: r.update(inflow="momentum"), "inflow"),
    (lambda r: r["thrusters"][1].update(wake=1.0), r"thrusters\[1\]\.wake"),
    (lambda r: r["thrusters"][0].update(wake=-0.1), r"thrusters\[0\]\.wake"),
])
def test_bad_inflow_input_names_the_key(mutate, expected):
    raw = _preset_raw("bluerov2")
    mutate(raw)
    with pytest.raises(VehicleFileError, match=expected):
        vehicle_from_dict(raw, where="b.yaml")


def test_inflow_needs_a_known_propeller():
    raw = _preset_raw("bluerov2")
    raw["inflow"] = "four-quadrant"
    raw["thrusters"][2]["model"] = "my_thruster.yaml"
    with pytest.raises(VehicleFileError, match=r"thrusters\[2\]\.model: 'my_thruster\.yaml': no such"):
        vehicle_from_dict(raw, where="b.yaml")


# ------------------------------------------------------------------ limits
def test_limits_at_rest_are_the_files_exactly():
    v = _with("bluerov2")
    il = inflow_limits(v)
    np.testing.assert_array_equal(il.limits_at(np.zeros(6)), v.layout.limits)


def test_limits_fall_when_propelling_into_the_flow():
    v0, v3 = _with("bluerov2"), _with("bluerov2", wake=0.3)
    nu = np.array([1.0, 0, 0, 0, 0, 0])
    il = inflow_limits(v0)
    a, b = il.limits_at(nu), inflow_limits(v3).limits_at(nu)
    lim = v0.layout.limits
    ua = il.advance(nu)
    for i in range(4):  # horizontal thrusters, axes at ±45° to surge
        prop = 1 if ua[i] > 0 else 0  # the limit whose thrust pushes into the advance
        other = 1 - prop
        assert abs(a[i, prop]) < abs(b[i, prop]) < abs(lim[i, prop])  # wake gives some back
        # flow from behind the jet: momentum theory says it helps a little, but the published
        # B4-70 table (thruster/data) is flat there — at |J| ≈ 0.16 ahead and astern its thrust
        # is within a few % of bollard (ripple of the 21-term fit) — so only: no large loss,
        # and a smaller change than the ~10 % lost when propelling into the same flow
        d_other = abs(a[i, other]) / abs(lim[i, other]) - 1
        d_prop = 1 - abs(a[i, prop]) / abs(lim[i, prop])
        assert d_other > -0.05 and abs(d_other) < d_prop
    np.testing.assert_array_equal(a[4:], lim[4:])  # the vertical pair sees no surge advance


# ------------------------------------------------------------------ envelope
def test_envelope_inflow_none_restores_the_bollard_envelope():
    v = _with("bluerov2")
    off = speed_envelope(v, inflow="none")
    plain = speed_envelope(load_vehicle("bluerov2"))
    assert off.to_dict() == plain.to_dict()
    assert "speed_bollard" not in plain.to_dict()["rows"][0]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["bluerov2", "bluerov2-heavy"])
def test_envelope_with_inflow_balances_drag_against_the_thrust_at_that_speed(name):
    v = _with(name)
    env = speed_envelope(v, dofs=["surge", "heave"])
    p = v.params
    for r in env.rows:
        d = {"surge": 0, "heave": 2}[r.dof]
        assert abs(r.speed) < abs(r.speed_bollard)
        # the force behind the row is the LP maximum at the limits of its own steady state …
        nu = np.zeros(6)
        nu[d] = r.speed
        lim = inflow_limits(v).limits_at(nu)
        from uuvid.vehicle.envelope import _forces

        al = v.allocator(None, compensate_eta=True)
        ep, en = al.eta
        C = al.mode.constraint_rows(v.B) if al.mode is not None else None
        F, _ = _forces(al, v.B, lim, d, r.sign, al.controlled, ep, en, C)
        # … and it balances drag (plus W − B in heave)
        drag = p.linear_damping[d, d] * r.speed + p.quadratic_damping[d, d] * r.speed * abs(r.speed)
        bias = p.net_weight if d == 2 else 0.0
        assert drag == pytest.approx(r.sign * F + bias, rel=1e-8)


@njit
def _surge_full_level(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt,
                      tau_out):
    """Per-thruster thrust (output "thrust"): the horizontal thrusters held at ``params[:n]``;
    the vertical ones (``params[n:2n]`` ≠ 0) hold depth, roll and pitch by PD through the rows
    ``params[2n+1:]`` of the (Z, K, M) pseudo-inverse, ``params[2n]`` = W − B fed forward."""
    n = tau_out.size
    if state[1] == 0.0:
        state[0] = eta[2]
        state[1] = 1.0
    q0, q1, q2, q3 = eta[3], eta[4], eta[5], eta[6]
    roll = math.atan2(2 * (q0 * q1 + q2 * q3), 1 - 2 * (q1 * q1 + q2 * q2))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (q0 * q2 - q3 * q1))))
    Z = -(100.0 * (eta[2] - state[0]) + 60.0 * nu[2]) - params[2 * n]
    K = -(20.0 * roll + 5.0 * nu[3])
    M = -(20.0 * pitch + 5.0 * nu[4])
    o = 2 * n + 1
    for i in range(n):
        tau_out[i] = params[i]
        if params[n + i] != 0.0:
            tau_out[i] = params[o + 3 * i] * Z + params[o + 3 * i + 1] * K + params[o + 3 * i + 2] * M


@pytest.mark.slow
def test_envelope_with_inflow_is_the_speed_a_6dof_simulation_reaches():
    """Independent of the envelope's fixed point: the 6-DOF mission loop (thrust from the
    four-quadrant map at each thruster's advance speed, every RK4 stage) flies the Heavy with its
    horizontal thrusters held at the full commands of the envelope's surge pattern and its
    vertical ones holding depth, roll and pitch level.  The speed it settles at is the envelope's
    maximum surge speed with inflow to 1e-5, and the thrusts it ends with are the envelope's
    limits at that speed; bollard thrusters (``inflow='none'``) settle at the bollard envelope
    speed, 4 % faster.  (The BlueROV2 cannot hold pitch — two vertical thrusters — and pitches
    past 40° at full surge, so only the Heavy gives a level run.)"""
    from uuvid.simulate.control.blocks import Controller
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    v = _with("bluerov2-heavy")
    B = np.asarray(v.B)
    lim = v.layout.limits
    vert = np.abs(B[2]) > 1e-9
    inv = np.zeros((B.shape[1], 3))
    inv[vert] = np.linalg.pinv(B[[2, 3, 4]][:, vert])
    pattern = np.where(B[0] > 1e-9, lim[:, 1], np.where(B[0] < -1e-9, lim[:, 0], 0.0))
    params = np.concatenate([pattern, vert.astype(float), [v.params.net_weight], inv.ravel()])
    ctrl = Controller(_surge_full_level, params, [0.0, 0.0], "surge full, level", "thrust")
    speeds = {}
    for inflow in ("four-quadrant", "none"):
        row = speed_envelope(v, dofs=["surge"], inflow=inflow).rows[0]
        assert row.direction == "forward"
        # 20 s: steady after ~8 s; the bollard straight run is yaw-unstable (Munk moment) and
        # round-off turns it after ~35 s, the run with inflow is not
        res = fly_mission(setup_mission(v, square_mission(), controller=ctrl, t_end=20.0,
                                        inflow=inflow))
        u_end = res.state[-1, 7]
        assert u_end == pytest.approx(row.speed, rel=1e-5), (inflow, u_end, row.speed)
        assert np.max(np.abs(res.state[-1, 8:13])) < 1e-6
        nu = np.zeros(6)
        nu[0] = row.speed
        at = (inflow_limits(v).limits_at(nu) if inflow != "none" else lim)
        want = np.where(B[0] > 1e-9, at[:, 1], at[:, 0])[~vert]
        np.testing.assert_allclose(res.thrust[-1][~vert], want, rtol=1e-4)
        speeds[inflow] = u_end
    assert 1.03 < speeds["none"] / speeds["four-quadrant"] < 1.06


@pytest.mark.slow
def test_confirm_envelope_flies_the_limits_at_the_advance_speed():
    """``confirm_envelope`` with inflow flies every translational and yaw direction with the
    thrust limits at the advance speeds (the hold flight's kernel): the Heavy's rows are all
    confirmed to 1e-6 of the envelope's speeds with inflow, which lie 2–15 % below the bollard
    ones (a flight with bollard limits would miss them by that); the BlueROV2's heave and yaw
    rows likewise, its surge and sway rows say it cannot stay level."""
    from uuvid.analysis.envelope_check import confirm_envelope

    for name in ("bluerov2-heavy", "bluerov2"):
        check = confirm_envelope(load_vehicle(name), inflow="four-quadrant")
        for r in check.rows:
            if r["dof"] in ("roll", "pitch"):
                continue
            if name == "bluerov2" and r["dof"] in ("surge", "sway"):
                assert r["confirmed"] is False and "cannot stay level" in r["note"]
                continue
            assert r["confirmed"], (name, r["direction"], r["note"])
            assert r["simulated_speed"] == pytest.approx(r["allocator_speed"], rel=1e-6)
            assert 0.8 < r["allocator_speed"] / r["allocator_bollard_speed"] < 0.985, r
        # the JSON keys mean what the envelope's fields mean (EnvelopeCheck's docstring)
        env = speed_envelope(load_vehicle(name), inflow="four-quadrant")
        for r, e in zip(check.rows, env.rows):
            if e.dof in ("roll", "pitch"):
                continue
            assert (r["speed"], r["bollard_speed"]) == (e.speed, e.speed_bollard)
            assert (r["allocator_speed"], r["allocator_bollard_speed"]) == \
                (e.speed_allocator, e.speed_allocator_bollard)
        assert check.inflow == "four-quadrant" and check.to_dict()["inflow"] == "four-quadrant"


@pytest.mark.slow
def test_wake_raises_the_speed_towards_bollard():
    s0 = speed_envelope(_with("bluerov2"), dofs=["surge"])["forward"].speed
    s3 = speed_envelope(_with("bluerov2", wake=0.3), dofs=["surge"])["forward"].speed
    sb = speed_envelope(load_vehicle("bluerov2"), dofs=["surge"])["forward"].speed
    assert s0 < s3 < sb


# ------------------------------------------------------------------ stability and hold
@pytest.mark.slow
def test_stability_inflow_none_restores_today_and_inflow_only_changes_range_and_fractions():
    from uuvid.vehicle.stability import static_stability

    v = _with("bluerov2")
    plain = static_stability(load_vehicle("bluerov2"), n_speeds=9)
    off = static_stability(v, n_speeds=9, inflow="none")
    assert off.to_dict() == plain.to_dict()
    on = static_stability(v, n_speeds=9)
    fwd_on, fwd_off = on["forward"], off["forward"]
    assert fwd_on.max_speed < fwd_off.max_speed
    # the level limit is a property of trim, not of thrust: the same with and without inflow
    assert fwd_on.limit_speed == pytest.approx(fwd_off.limit_speed, rel=1e-3)
    # at the same speed the thrusters work harder when the advance speed eats their thrust
    u = fwd_on.speeds[3]
    from uuvid.vehicle.stability import trim_state

    assert u > 0
    i_off = int(np.argmin(np.abs(fwd_off.speeds - u)))
    if fwd_off.speeds[i_off] == pytest.approx(u):
        assert fwd_on.thrust_fraction[3] > fwd_off.thrust_fraction[i_off]
    assert trim_state(v, "surge", 1, u)["ok"]


def test_hold_with_inflow_none_is_today_and_inflow_lowers_the_held_current():
    from uuvid.analysis.hold import max_current

    v = _with("bluerov2-heavy")  # thrust-limited in a current (the BlueROV2 tilts first)
    base = max_current(load_vehicle("bluerov2-heavy"), 90.0, stability=False)
    off = max_current(v, 90.0, stability=False, inflow="none")
    assert off[0] == base[0] and off[1]["limit"] == "thrust"
    on = max_current(v, 90.0, stability=False)
    assert on[0] < off[0]


@pytest.mark.slow
def test_held_current_from_ahead_equals_the_envelope_speed_with_inflow():
    """Two code paths (allocation in a current; LP envelope in still water) meet: holding still in
    a head current V is flying at V through still water, advance speed included."""
    from uuvid.analysis.hold import max_current

    v = _with("bluerov2-heavy")
    held = max_current(v, 0.0, stability=False, tol=1e-5)[0]
    env = speed_envelope(v, dofs=["surge"])["forward"].speed
    assert held == pytest.approx(env, rel=2e-3)


# ------------------------------------------------------------------ CLI
@pytest.mark.slow
def test_cli_envelope_inflow_side_by_side_and_none_restores(tmp_path):
    import json

    from typer.testing import CliRunner

    from uuvid.cli.app import app

    run = CliRunner()
    plain = run.invoke(app, ["vehicle", "envelope", "bluerov2-heavy", "--no-confirm", "--json"])
    off = run.invoke(app, ["vehicle", "envelope", "bluerov2-heavy", "--no-confirm", "--json",
                           "--inflow", "none"])
    assert plain.exit_code == 0 and off.exit_code == 0
    assert json.loads(off.output) == json.loads(plain.output)
    on = run.invoke(app, ["vehicle", "envelope", "bluerov2-heavy", "--inflow", "four-quadrant"])
    assert on.exit_code == 0, on.output
    text = " ".join(on.output.split())
    assert "(bollard)" in text and "simulated" in text  # headers (wrapped at this width)
    # the legend says what the columns are and which JSON keys hold them
    assert "(bollard): the same speeds with bollard thrust" in text
    assert "keys force, speed, allocator_speed, bollard_speed, allocator_bollard_speed" in text
    assert "limit at its advance speed at every control step" in on.output
    doc = json.loads(run.invoke(app, ["vehicle", "envelope", "bluerov2-heavy", "--json",
                                      "--inflow", "four-quadrant"]).output)
    fwd = next(r for r in doc["rows"] if r["direction"] == "forward")
    assert doc["inflow"] == "four-quadrant" and json.loads(off.output)["inflow"] == "none"
    assert fwd["allocator_speed"] < fwd["allocator_bollard_speed"]
    assert fwd["speed"] < fwd["bollard_speed"]
    assert fwd["confirmed"] and fwd["simulated_speed"] == pytest.approx(fwd["allocator_speed"],
                                                                        rel=1e-6)
    bad = run.invoke(app, ["vehicle", "stability", "bluerov2", "--inflow", "bogus"])
    assert bad.exit_code == 2 and "'--inflow'" in bad.output and "bogus" in bad.output


@pytest.mark.slow
def test_demo_section_shows_both_vehicles_with_and_without_inflow(tmp_path):
    from uuvid.core.html import Report
    from uuvid.demo import _inflow_rows

    rep = Report("inflow")
    rows = _inflow_rows(rep, load_vehicle("bluerov2"))
    assert [r["vehicle"] for r in rows] == ["bluerov2", "bluerov2-heavy"]
    for r in rows:
        assert 0 < r["thrust at the advance speed [m/s]"] < r["bollard thrust [m/s]"]
    rep.write(tmp_path)
    assert "advance speed" in (tmp_path / "index.html").read_text()


def test_demo_flies_a_bluerov2_on_the_map_fitted_on_the_example_bench(tmp_path):
    from uuvid.core.html import Report
    from uuvid.demo import _fitted_map_vehicle
    from uuvid.examples import write_example

    bench = write_example("thruster-flow", tmp_path)[0]
    row = _fitted_map_vehicle(bench, tmp_path, Report("inflow"))
    own, pub = row["map fitted on the bench [m/s]"], row["published T200 map [m/s]"]
    assert 0 < own < row["bollard [m/s]"] and 0 < pub < row["bollard [m/s]"] and own != pub
    v = load_vehicle(tmp_path / "bluerov2-own-propeller.yaml")
    assert inflow_limits(v).maps[0].beta_ranges_deg is not None  # the file's map, not the T200's


# ------------------------------------------------------------------ the mission loop
REF = __import__("pathlib").Path(__file__).parent / "data" / "square_mission_bluerov2.npz"


def test_mission_inflow_none_is_the_stored_square_mission():
    """A vehicle file with inflow on, flown with inflow='none', is today's recorded mission."""
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    ref = np.load(REF)
    r = fly_mission(setup_mission(_with("bluerov2"), square_mission(), inflow="none"))
    rows = ref["rows"]
    assert np.max(np.abs(r.state[rows, :13] - ref["state"])) <= 1e-12
    assert np.max(np.abs(r.thrust[rows] - ref["thrust"])) <= 1e-12


def test_mission_thrust_is_the_map_at_each_thrusters_advance_speed():
    """The loop's delivered thrust at the start of a step equals the map taken to the advance
    speed computed here independently (numpy geometry, rotation matrix, with a current)."""
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
    from uuvid.thruster.inflow import advance_speeds, inflow_params, inflow_thrust_nb
    from uuvid.vehicle.kinematics import quat_to_rotmat

    v = _with("bluerov2", wake=0.1)
    cur = np.array([0.1, -0.05, 0.0])
    s = setup_mission(v, square_mission(speed=0.3), inflow="four-quadrant", current=cur)
    r = fly_mission(s)
    b = s.bank
    prm = inflow_params(inflow_limits(v).maps[0])
    P = np.array([t.position for t in v.layout])
    A = np.array([t.axis for t in v.layout])
    checked = 0
    for k in range(500, r.t.size, 997):
        z = r.state[k]
        nu_r = z[7:13].copy()
        nu_r[:3] -= quat_to_rotmat(z[3:7]).T @ cur
        ua = advance_speeds(nu_r, P, A, v.wake)
        for i in range(b.n):
            f = b.chains[i].blocks[-1].thrust(z[13 + i])  # the T200 map: K_T Ω|Ω| of the motor state
            want = inflow_thrust_nb(float(f), float(ua[i]), prm)
            want *= s.eta_p[i] if want >= 0 else s.eta_n[i]
            assert r.thrust[k, i] == pytest.approx(want, rel=1e-9, abs=1e-9)
            checked += abs(ua[i]) > 0.05
    assert checked > 20  # the vehicle was moving through the water at those samples


def test_mission_with_inflow_needs_more_allocated_thrust_to_cruise():
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    v = _with("bluerov2")
    m = square_mission(speed=0.4)
    on = fly_mission(setup_mission(v, m))
    off = fly_mission(setup_mission(v, m, inflow="none"))
    assert on.metrics["max_tracking_error_m"] < 1.0
    cruise = np.linalg.norm(off.state[:, 7:9], axis=1) > 0.3  # moving horizontally
    assert cruise.sum() > 1000
    work_on = np.abs(on.thrust_cmd[cruise, :4]).mean()
    work_off = np.abs(off.thrust_cmd[cruise, :4]).mean()
    assert work_on > 1.02 * work_off


def _inflow_batch_case(runs=3):
    """A short square mission with inflow on (a wake and a current, so every term of the advance
    speed is used) and ``runs`` perturbed vehicles (mass, damping, thrusters, current)."""
    from uuvid.simulate.batch import perturb_batch
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import setup_mission

    s = setup_mission(_with("bluerov2", wake=0.1), square_mission(speed=0.35), t_end=12.0,
                      current=np.array([0.1, -0.05, 0.0]))
    assert s.inflow_arrays is not None
    VP, TP, VC = perturb_batch(s, np.random.default_rng(3), runs)
    return s, VP, TP, VC


def _single_flights(s, VP, TP, VC):
    """Each vehicle flown alone by fly_mission, summarised as the batch summarises a run."""
    import dataclasses

    from uuvid.simulate.vehicle_sim import RUN_COLUMNS, _summarise_run, fly_mission

    rows = np.empty((len(VP), len(RUN_COLUMNS)))
    for r in range(len(VP)):
        one = dataclasses.replace(s, vp=VP[r], current=VC[r],
                                  bank=dataclasses.replace(s.bank, params=TP[r]))
        res = fly_mission(one)
        _summarise_run(res.state, res.thrust, res.scale, res.ref_pos, rows[r])
    return rows


def test_batch_flies_inflow_as_the_single_mission_loop():
    """run_batch with inflow on: every vehicle's summary equals its own fly_mission (to 1e-9),
    and differs from the bollard batch (inflow really flown, not dropped)."""
    import dataclasses

    from uuvid.simulate.vehicle_sim import run_batch

    s, VP, TP, VC = _inflow_batch_case()
    out = run_batch(s, VP, TP, VC)
    ref = _single_flights(s, VP, TP, VC)
    np.testing.assert_allclose(out, ref, rtol=1e-9, atol=1e-12)
    off = run_batch(dataclasses.replace(s, inflow_arrays=None), VP, TP, VC)
    assert np.all(np.abs(out[:, 1] - off[:, 1]) > 1e-6 * np.abs(off[:, 1]))


def test_simd_batch_flies_inflow_as_the_per_vehicle_loop():
    """The SIMD kernel with inflow on: its summaries and a traced trajectory equal run_batch's
    (the per-vehicle loop, itself fly_mission's arithmetic) to 1e-9."""
    import dataclasses

    from uuvid.simulate.batch import fast_path_reason, run_batch_fast
    from uuvid.simulate.vehicle_sim import fly_mission, run_batch

    s, VP, TP, VC = _inflow_batch_case()
    assert fast_path_reason(s, VP, TP, VC) is None
    out, tr = run_batch_fast(s, VP, TP, VC, trace_runs=[1], trace_every=50)
    ref = run_batch(s, VP, TP, VC)
    np.testing.assert_allclose(out[:, :5], ref[:, :5], rtol=1e-9, atol=0)
    np.testing.assert_allclose(out[:, 8], ref[:, 5], rtol=0, atol=1e-6)
    one = fly_mission(dataclasses.replace(s, vp=VP[1], current=VC[1],
                                          bank=dataclasses.replace(s.bank, params=TP[1])))
    Z = one.state[::50, :13]
    assert np.max(np.abs(tr[0] - Z)) <= 1e-9 * max(1.0, float(np.max(np.abs(Z))))
    off = run_batch_fast(dataclasses.replace(s, inflow_arrays=None), VP, TP, VC)
    assert np.all(np.abs(out[:, 1] - off[:, 1]) > 1e-6 * np.abs(off[:, 1]))


@pytest.mark.slow
def test_cli_simulate_inflow_none_is_today_and_four_quadrant_differs():
    import json

    from typer.testing import CliRunner

    from uuvid.cli.app import app

    run = CliRunner()
    args = ["simulate", "mission", "square", "--speed", "0.3", "--json"]

    def doc(*extra):
        res = run.invoke(app, args + list(extra))
        assert res.exit_code == 0, res.output
        d = json.loads(res.stdout[res.stdout.index("{"):])
        for k in [k for k in d if k.endswith("time_s") or "real_time" in k]:
            d.pop(k)
        return d

    plain, off, on = doc(), doc("--inflow", "none"), doc("--inflow", "four-quadrant")
    assert (plain["inflow_source"], off["inflow_source"]) == ("vehicle file", "option")
    assert {**off, "inflow_source": ""} == {**plain, "inflow_source": ""}
    assert on["rms_tracking_error_m"] != plain["rms_tracking_error_m"]


def test_gym_env_inflow_none_is_today_and_inflow_lowers_the_thrust_when_moving():
    pytest.importorskip("gymnasium")
    from uuvid.simulate.gym_env import StationKeepingEnv

    def one_step(vehicle, speed, **kw):
        """Surge at ``speed`` (level, at the target), full surge force for one step (0.1 s)."""
        env = StationKeepingEnv(vehicle, action="force", offset_range=0.0, **kw)
        env.reset(seed=1)
        env._z[7] = speed
        act = np.zeros(env.action_space.shape)
        act[0] = 1.0
        env.step(act)
        return env.state

    for u in (0.0, 1.0):
        plain = one_step("bluerov2", u)
        off = one_step(_with("bluerov2"), u, inflow="none")
        on = one_step(_with("bluerov2"), u)
        np.testing.assert_array_equal(off, plain)  # inflow none: today's environment
        if u == 0.0:  # from rest the advance speed only builds up within the step
            assert on[7] == pytest.approx(off[7], rel=0.05)
        else:  # moving: the propellers keep less of their bollard thrust
            assert on[7] - u < 0.95 * (off[7] - u)


def test_mission_on_a_battery_keeps_the_vehicle_files_inflow():
    """On a battery, setup_mission flies the voltage-aware T200 model in place of the 16 V preset
    (the same thruster): a vehicle file with inflow on keeps its propeller map there (it used to
    refuse the mission as if the user had swapped the thruster); inflow='none' is the bollard
    flight, and a thruster chain the user swaps in is still refused with inflow on."""
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
    from uuvid.thruster.presets import preset_chain

    v = _with("bluerov2")
    res = {}
    for inflow in ("four-quadrant", "none"):
        s = setup_mission(v, square_mission(), battery=True, t_end=20.0, inflow=inflow)
        assert (s.inflow_arrays is not None) == (inflow != "none")
        res[inflow] = fly_mission(s)
    on, off = res["four-quadrant"], res["none"]
    assert np.array_equal(on.thrust[0], off.thrust[0])  # at rest: the bollard thrust exactly
    assert np.max(np.abs(on.thrust - off.thrust)) > 0.05  # moving: the loss acts
    assert on.metrics["soc"][1] < off.metrics["soc"][1]  # more thrust asked for the same square
    with pytest.raises(ValueError, match=r"thruster_chain= replaces the vehicle's models with a "
                                         r"chain that names none: give propeller=.*or inflow='none'"):
        setup_mission(v, square_mission(), battery=True, thruster_chain=preset_chain("t200"),
                      t_end=5.0)


@pytest.mark.slow
def test_minimal_inflow_kernel_flies_the_same_model():
    """The benchmark's practical limit for the inflow loop (benchmarks/minimal_kernel.py's
    fly_minimal_inflow: advance speed as ``M ν``, tip speed from the motor speed, no square root)
    flies the same mission as fly_mission with inflow to ~1e-4 m, and differs from the bollard
    kernel by the inflow's own effect — a reference that is the same model, not another one."""
    import sys
    from pathlib import Path

    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import minimal_kernel

    on = setup_mission(_with("bluerov2"), square_mission(speed=0.4), t_end=40.0)
    off = setup_mission(load_vehicle("bluerov2"), square_mission(speed=0.4), t_end=40.0)
    Zi, Fi = minimal_kernel.fly_inflow(on)
    Zb, _ = minimal_kernel.fly(off)
    r = fly_mission(on)
    assert np.max(np.abs(Zi[:, :3] - r.state[:, :3])) < 3e-4
    assert np.max(np.abs(Zi[:, :3] - Zb[:, :3])) > 10 * np.max(np.abs(Zi[:, :3] - r.state[:, :3]))
    np.testing.assert_allclose(Fi[0], r.thrust[0], rtol=1e-12, atol=1e-12)  # at rest: bollard


# ------------------------------------------------------------------ the user's own propeller
def _bench_truth():
    """A propeller unlike the T200's published map (C_T* of Fourier order 2, ahead and astern),
    which a bench in a flow measures; D = 76 mm as the T200."""
    from uuvid.thruster.inflow import FourQuadrantMap

    return FourQuadrantMap("bench truth", 0.076, (0.05, 0.40, 0.02), (0.0, -1.0, 0.05),
                           (0.0,) * 3, (0.0,) * 3)


def _fitted_vehicle(tmp_path, *, reverse=True, form="four-quadrant", seed=0, section=True,
                    key="propeller", edit=None):
    """A bench in a flow made by :func:`_bench_truth` (thrust noise 0.25 N) → ``thruster fit``
    → model file ``fitted.yaml`` (``edit``: a change to its ``inflow`` section) → the BlueROV2
    with every thruster's ``key`` (``propeller``, the thruster staying a T200) naming it, inflow
    on."""
    from dataclasses import replace

    from uuvid.identify.thruster.workflow import ReadOptions, run_fit
    from uuvid.thruster.modelfile import chain_to_dict, save_chain

    w = np.array([120.0, 170.0, 220.0, 270.0, 320.0])
    w = np.concatenate([w, -w]) if reverse else w
    W, U = np.meshgrid(w, [0.0, 0.2, 0.4, 0.6, 0.8], indexing="ij")
    W, U = np.repeat(W.ravel(), 3), np.repeat(U.ravel(), 3)
    thrust = _bench_truth().thrust_torque(W / (2 * np.pi), U)[0]
    thrust = thrust + np.random.default_rng(seed).normal(0.0, 0.25, thrust.size)
    rows = ["command,speed,thrust,flow_speed"] + [
        f"{1500 + a / 0.8:.17g},{a:.17g},{b:.17g},{c:.17g}" for a, b, c in zip(W, thrust, U)]
    (tmp_path / "flow.csv").write_text("\n".join(rows) + "\n")
    opts = ReadOptions(thrust_col="thrust", speed_col="speed")
    out = (run_fit([tmp_path / "flow.csv"], "four-quadrant", opts, diameter=0.076)
           if form == "four-quadrant" else run_fit([tmp_path / "flow.csv"], "quadratic", opts))
    save_chain(out.chain if section else replace(out.chain, inflow=None), tmp_path / "fitted.yaml")
    if edit is not None:
        doc = chain_to_dict(out.chain)
        edit(doc["inflow"])
        (tmp_path / "fitted.yaml").write_text(yaml.safe_dump(doc))
    raw = _preset_raw("bluerov2")
    raw["inflow"] = "four-quadrant"
    for t in raw["thrusters"]:
        t[key] = "fitted.yaml"
    (tmp_path / "v.yaml").write_text(yaml.safe_dump(raw))
    return tmp_path / "v.yaml", out


def test_a_vehicle_flies_the_propeller_map_fitted_on_its_own_bench(tmp_path):
    """``inflow: four-quadrant`` with ``propeller:`` naming a model file from a bench in a flow
    uses that file's fitted C_T*(β) — not the T200's published map — in the limits, the envelope
    and the mission loop, while the thrusters stay T200s driven by command."""
    import warnings

    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
    from uuvid.thruster.inflow import inflow_params, propeller_map
    from uuvid.vehicle.inflow import loop_arrays

    path, out = _fitted_vehicle(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # ahead and astern both fitted: nothing to warn about
        v = load_vehicle(path)
    assert v.propeller(0) == "fitted.yaml" and v.layout[0].model == "t200"
    fq = inflow_limits(v).maps[0]
    p = out.parameters()
    assert fq.ct_a == tuple(p[f"a_{k}"]["estimate"] for k in range(3))  # the file's numbers
    assert fq.ct_b[1:] == tuple(p[f"b_{k}"]["estimate"] for k in (1, 2))
    assert fq.diameter == 0.076 and len(fq.beta_ranges_deg) == 2  # ahead and astern
    truth, t200 = _bench_truth(), propeller_map("t200")
    beta = np.radians(np.linspace(0.0, 14.0, 8))
    np.testing.assert_allclose(fq.ct(beta), truth.ct(beta), rtol=0.03)
    # the user's propeller loses thrust faster than the published T200 map says
    n = inflow_limits(v).n_fwd[0]
    assert fq.thrust_ratio(n, 1.0) < t200.thrust_ratio(t200.shaft_speed_for(51.485), 1.0) - 0.05
    bollard = speed_envelope(v, dofs=["surge"], inflow="none")["forward"].speed
    own = speed_envelope(v, dofs=["surge"])["forward"].speed
    published = speed_envelope(_with("bluerov2"), dofs=["surge"])["forward"].speed
    assert own < published < bollard
    prm, _ = loop_arrays(v)  # the mission loop reads the same map
    np.testing.assert_array_equal(prm, inflow_params(fq))
    r = fly_mission(setup_mission(v, square_mission(), t_end=3.0))
    pub = fly_mission(setup_mission(_with("bluerov2"), square_mission(), t_end=3.0))
    assert np.max(np.abs(r.thrust)) > 1.0  # T200s commanded through their ESC
    assert np.all(np.isfinite(r.state)) and np.max(np.abs(r.thrust - pub.thrust)) > 1e-3


def test_a_thruster_driven_by_propeller_speed_cannot_fly_a_mission(tmp_path):
    """The fit's own blocks (thrust against propeller speed) as a thruster's model: a mission
    has no command range for it — an error naming the thruster, never a vehicle that sits still
    (it flew ±1 rad/s: 0.03 N)."""
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import setup_mission

    path, _ = _fitted_vehicle(tmp_path, key="model")
    v = load_vehicle(path)  # envelope and stability read the file's limits and map
    assert inflow_limits(v).maps[0].beta_ranges_deg is not None
    with pytest.raises(ValueError, match=r"thrusters\[0\] \(T1_front_right\): model 'fitted\.yaml' "
                                         r"takes the propeller speed.*propeller:"):
        setup_mission(v, square_mission(), inflow="none")


def test_a_map_fitted_ahead_only_warns_that_astern_is_an_extrapolation(tmp_path):
    from uuvid.vehicle import VehicleFileWarning

    path, _ = _fitted_vehicle(tmp_path, reverse=False)
    with pytest.warns(VehicleFileWarning) as got:  # one message for the six thrusters on the file
        load_vehicle(path)
    assert len(got) == 1
    assert re.search(r"thrusters\[0, 1, 2, 3, 4, 5\] propeller 'fitted\.yaml'.*\[0°, 14°\].*astern",
                     str(got[0].message))
    with pytest.warns(VehicleFileWarning, match="astern"):  # a cached load says it again
        load_vehicle(path)


def test_the_envelope_says_where_it_reads_a_fitted_map_outside_the_bench(tmp_path):
    """The bench saw no flow from behind: thrusters that meet one in steady flight (the BlueROV2's
    vectored thrusters going sideways) read the series outside its advance angles — noted."""
    path, _ = _fitted_vehicle(tmp_path)
    env = speed_envelope(load_vehicle(path), dofs=["surge", "sway"])
    note = [n for n in env.notes if n.startswith("extrapolated")]
    assert note and "[0°, 14°] and [166°, 180°]" in note[0] and "β = " in note[0]
    assert not [n for n in speed_envelope(_with("bluerov2")).notes if n.startswith("extrapolated")]


@pytest.mark.parametrize("kw, expected", [
    ({"form": "linear"}, r"thrusters\[0, 1, 2, 3, 4, 5\]\.propeller: inflow 'four-quadrant': "
                         r"fitted\.yaml: inflow: form 'linear'.*--model four-quadrant"),
    ({"section": False}, r"thrusters\[0, 1, 2, 3, 4, 5\]\.propeller: inflow 'four-quadrant' needs "
                         r"the propeller map of 'fitted\.yaml', which holds none"),
    ({"edit": lambda s: s.update(diameter_m=76.0)}, r"diameter_m = 76 m.*in mm"),
    ({"edit": lambda s: s["parameters"].pop("a_1")}, r"missing a_1"),
])
def test_a_propeller_file_without_a_usable_map_is_an_error_with_its_own_cause(tmp_path, kw, expected):
    path, _ = _fitted_vehicle(tmp_path, **kw)
    with pytest.raises(VehicleFileError, match=expected) as e:
        load_vehicle(path)
    assert str(e.value).count("fitted.yaml") <= 2  # one message for the six thrusters


def test_a_propeller_file_that_is_not_there_is_named(tmp_path):
    raw = _preset_raw("bluerov2")
    raw["inflow"] = "four-quadrant"
    raw["thrusters"][3]["propeller"] = "nowhere.yaml"
    with pytest.raises(VehicleFileError, match=r"thrusters\[3\]\.propeller: 'nowhere\.yaml': no "
                                               r"such thruster model file"):
        vehicle_from_dict(raw, where="b.yaml", base_dir=tmp_path)


def test_identical_maps_under_two_names_fly_one_mission_loop(tmp_path):
    from uuvid.vehicle.inflow import loop_arrays

    path, _ = _fitted_vehicle(tmp_path)
    (tmp_path / "copy.yaml").write_text((tmp_path / "fitted.yaml").read_text())
    raw = yaml.safe_load(path.read_text())
    raw["thrusters"][5]["propeller"] = "copy.yaml"
    (tmp_path / "v2.yaml").write_text(yaml.safe_dump(raw))
    assert loop_arrays(load_vehicle(tmp_path / "v2.yaml")) is not None


@pytest.mark.parametrize("mutate, key", [
    (lambda s: s.pop("diameter_m"), r"inflow\.diameter_m"),
    (lambda s: s["parameters"].pop("b_1"), r"parameters: expected exactly a_0, a_1, b_1 .*; missing b_1"),
    (lambda s: s["parameters"].pop("a_1"), r"missing a_1$"),
    (lambda s: s["parameters"]["a_0"].update(estimate=float("nan")), r"parameters\.a_0"),
    (lambda s: s.update(beta_range_deg=[30.0, 10.0]), r"beta_range_deg"),
    (lambda s: s.update(beta_ranges_deg=[[0.0, 10.0], [170.0]]), r"beta_ranges_deg: expected \[\[lo"),
])
def test_a_bad_four_quadrant_section_names_its_key(mutate, key):
    from uuvid.thruster.inflow import map_from_section

    sec = {"form": "four-quadrant", "diameter_m": 0.076, "beta_range_deg": [0.0, 15.0],  # older file
           "parameters": {"a_0": {"estimate": 0.3}, "a_1": {"estimate": 0.1},
                          "b_1": {"estimate": -0.5}}}
    fq = map_from_section(sec, "m.yaml: inflow")
    assert fq.ct_a == (0.3, 0.1) and fq.ct_b == (0.0, -0.5) and fq.covers(10.0)
    assert not fq.covers(180.0) and not fq.covers(-40.0) and fq.covers(360.0)
    mutate(sec)
    with pytest.raises(ValueError, match=key):
        map_from_section(sec, "m.yaml: inflow")


def test_hold_refusals_with_inflow_name_the_options_to_change(tmp_path):
    """What hold cannot do with inflow yet is refused in the command's own words (the library's
    parameter names became --simulate, --inflow none, --battery, --voltage)."""
    from typer.testing import CliRunner

    from uuvid.analysis import hold
    from uuvid.cli.app import app

    raw = _preset_raw("bluerov2")
    raw["inflow"] = "four-quadrant"
    (tmp_path / "v.yaml").write_text(yaml.safe_dump(raw))
    r = CliRunner().invoke(app, ["vehicle", "hold", str(tmp_path / "v.yaml"), "--simulate", "0,90"])
    assert r.exit_code == 2
    text = " ".join(r.output.split())
    assert "(--simulate) flies bollard thrusters only" in text and "(--inflow none)" in text
    v = load_vehicle(tmp_path / "v.yaml")
    with pytest.raises(ValueError, match=r"\(`soc=`\) is not computed yet.*`inflow=`none"):
        hold.max_current(v, 0.0, soc=0.8)
