"""Vehicle + thrusters + allocation + DP controller in one compiled loop (issue: vehicle simulation)."""

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.simulate.control.pid import attitude_hold, dp_control, dp_errors
from uuvid.simulate.reference import square_mission
from uuvid.simulate.scenario import ScenarioError, scenario_from_dict
from uuvid.simulate.vehicle_sim import _interp, _rhs, fly_mission, run_batch, setup_mission
from uuvid.thruster import kernels
from uuvid.thruster.blocks import FirstOrder, QuadraticMap, Yoerger
from uuvid.thruster.chain import ThrusterChain
from uuvid.vehicle.allocation import allocate_compiled
from uuvid.vehicle.definition import load_vehicle


@pytest.fixture(scope="module")
def bluerov2():
    return load_vehicle("bluerov2")


def _reference_solution(setup, t_end):
    """The same held-per-step controller/allocation, the ODE between steps by solve_ivp (rtol 1e-10)."""
    s, b = setup, setup.bank
    n, nb, P = b.n, b.kinds.size, b.params.shape[1]
    start = 0
    while start < nb and b.soff[start + 1] == b.soff[start]:
        start += 1
    tflat = np.ascontiguousarray(b.params.reshape(-1))
    z = s.z0()
    gains = s.gains.to_array()
    e, edot, integ, integ_new, tau_des = (np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4),
                                          np.zeros(6))
    fdes, sig0 = np.zeros(n), np.zeros(n)
    thrust, tau, ch = np.zeros(n), np.zeros(6), np.empty(8)
    blk = np.empty((n, max(nb, 1)))
    dvc = np.zeros(3)
    ref_pos, ref_vel, ref_yaw, ref_rate = s.ref
    steps = int(round(t_end / s.dt))
    for k in range(steps):
        dp_errors(z[0:3], z[3:7], z[7:13], ref_pos[k], ref_vel[k], ref_yaw[k], ref_rate[k], e, edot)
        dp_control(e, edot, integ, gains, s.dt, tau_des, integ_new)
        attitude_hold(z[3:7], z[7:13], gains, tau_des)
        integ[:] = integ_new
        allocate_compiled(s.alloc, tau_des, fdes)
        for i in range(n):
            cmd = _interp(b.inv_thrust[i], b.inv_command[i], fdes[i])
            sig0[i] = (kernels.eval_chain_prefix(b.kinds, b.poff, tflat, i * P, cmd, blk.reshape(-1),
                                                 i * max(nb, 1), start) if start else cmd)

        def f(t, zz):
            dz = np.zeros_like(zz)
            _rhs(zz, sig0, start, s.vp, s.B, s.eta_p, s.eta_n, b.kinds, b.poff, b.params, b.soff,
                 b.outch, b.in_ch, s.current, dvc, dz, thrust, tau, ch, blk)
            return dz

        sol = solve_ivp(f, (0.0, s.dt), z, method="DOP853", rtol=1e-10, atol=1e-12)
        z = sol.y[:, -1].copy()
        z[3:7] /= np.linalg.norm(z[3:7])
    return z


@pytest.mark.slow
@pytest.mark.parametrize("chain", [None, "yoerger"], ids=["t200-closed-form", "yoerger-rk4"])
def test_compiled_rk4_agrees_with_solve_ivp_over_60s(bluerov2, chain):
    """Fixed-step RK4 (dt = 0.01 s) against solve_ivp (rtol 1e-10) on 60 s of the square mission
    (the dive and the first leg): positions agree to 1e-6 m.

    The weak Yoerger thrusters saturate for most of the dive; there the allocation is uniform
    scaling, a smooth map of the controller's demand, so the comparison measures integration
    error.  (The bounded priority allocation's active set switches on differences far below
    the integrators' — it is checked against its oracles in test_allocation_bounded.py.)"""
    thr, alloc = None, "priority"
    if chain == "yoerger":
        thr = ThrusterChain((Yoerger(alpha=2.0, beta=4.0), QuadraticMap.basic(1.0)), input_kind="command")
        alloc = "scale"
    setup = setup_mission(bluerov2, square_mission(), thruster_chain=thr, t_end=60.0,
                          allocation=alloc)
    res = fly_mission(setup)
    ref = _reference_solution(setup, 60.0 - setup.dt)
    z_end = res.state[-1]
    assert np.max(np.abs(z_end[0:3] - ref[0:3])) < 1e-6
    assert np.max(np.abs(z_end[7:13] - ref[7:13])) < 1e-6


def test_square_mission_bluerov2_completes_within_half_a_metre(bluerov2):
    """At the cruising speed chosen for it (below its level-flight limit) the BlueROV2 flies the
    square level and on the path; at the nominal 0.5 m/s it follows the path but pitches past
    the 20° level limit, so the mission is not completed and the summary says why."""
    from uuvid.simulate.reference import cruise_speed

    speed, note = cruise_speed(bluerov2)
    assert speed < 0.5 and "level-flight limit" in note
    res = fly_mission(setup_mission(bluerov2, square_mission(speed=speed)))
    s = res.metrics
    assert s["completed"] and s["max_tilt_deg"] <= 20.0 and not s["warnings"]
    assert s["max_tracking_error_m"] < 0.5
    assert not s["thrust_over_limit"]
    assert s["max_thrust_N"] <= s["thrust_limit_N"]
    # Laidani et al.: cruising at 0.5 m/s takes about 2 N per horizontal thruster
    cruise = (res.t > 50) & (res.t < 60)
    assert 0.5 < np.median(np.abs(res.thrust[cruise, :4])) < 5.0
    fast = fly_mission(setup_mission(bluerov2, square_mission(speed=0.5))).metrics
    assert fast["max_tracking_error_m"] < 1.0 and fast["final_position_error_m"] < 0.25
    assert fast["max_pitch_deg"] > 20.0 and not fast["completed"]
    assert any("level-flight limit" in w for w in fast["warnings"])


def test_a_thruster_that_cannot_reverse_keeps_the_pid_output_limits_and_flies(bluerov2):
    """T1 limited to [0, 51.5] N: the uniform allocation's direction T φ for surge, sway and yaw
    needs T1 reversed, so its max_along was 0 and the PID's output limits for those DOFs were
    zeroed — the square mission stalled with only "did not follow the path".  Such a limit is
    what the thrusters can give (either way, every thrust combination), and the mission flies."""
    import warnings

    import yaml

    from uuvid.simulate.reference import cruise_speed
    from uuvid.simulate.vehicle_sim import default_gains
    from uuvid.vehicle.definition import VehicleFileWarning, vehicle_from_dict

    raw = yaml.safe_load(open(bluerov2.path))
    raw["thrusters"][0]["limits"] = [0.0, 51.485]
    with warnings.catch_warnings():
        warnings.simplefilter("error", VehicleFileWarning)  # every direction is still reachable
        v = vehicle_from_dict(raw, where="oneway.yaml", base_dir=bluerov2.path.parent)
    al = v.allocator()
    g = default_gains(v)
    stalled = 0
    for j, d in enumerate((0, 1, 2, 5)):
        e = np.eye(6)[d]
        if al.max_along(e) > 0:  # kept: the uniform allocation's limit, as for every preset
            assert g.tau_max[j] == al.max_along(e)
        else:
            stalled += 1
            assert g.tau_max[j] == pytest.approx(max(al.reach(e), al.reach(-e)), rel=1e-9)
        assert g.tau_max[j] > 30.0
    assert stalled >= 1  # surge's went to 0
    base = bluerov2.allocator()  # the preset's limits are the uniform allocation's, unchanged
    assert list(default_gains(bluerov2).tau_max) == [base.max_along(np.eye(6)[d]) for d in (0, 1, 2, 5)]
    assert min(al.reach(np.eye(6)[0]), al.reach(-np.eye(6)[0])) == pytest.approx(72.81, abs=0.01)
    s = fly_mission(setup_mission(v, square_mission(speed=cruise_speed(v)[0]))).metrics
    assert s["completed"] and s["max_tracking_error_m"] < 0.5 and not s["warnings"]


def test_batch_equals_single_runs(bluerov2):
    setup = setup_mission(bluerov2, square_mission(), t_end=30.0)
    single = fly_mission(setup)
    vp = np.tile(setup.vp, (3, 1))
    out = run_batch(setup, vp)
    assert out[0, 0] == pytest.approx(single.metrics["max_tracking_error_m"], rel=1e-12)
    assert np.allclose(out[0], out[1])


def test_general_thruster_chain_runs_and_thrust_lags(bluerov2):
    lag = ThrusterChain((FirstOrder(0.3),), input_kind="thrust", name="lag")
    res = fly_mission(setup_mission(bluerov2, square_mission(), thruster_chain=lag, t_end=40.0))
    assert np.all(np.isfinite(res.state))
    # delivered thrust lags the allocated one
    assert np.max(np.abs(res.thrust - res.thrust_cmd)) > 0.01


def test_scenario_errors_name_the_key():
    with pytest.raises(ScenarioError, match=r"mission\.speed"):
        scenario_from_dict({"mission": {"speed": -1}}, where="s.yaml")
    with pytest.raises(ScenarioError, match=r"s\.yaml: wobble: unknown key"):
        scenario_from_dict({"wobble": 1}, where="s.yaml")


@pytest.mark.slow
def test_cli_simulate_mission_square_json(tmp_path):
    runner = CliRunner()
    res = runner.invoke(app, ["simulate", "mission", "square", "--vehicle", "bluerov2", "--json",
                              "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    for k in ("completed", "max_tracking_error_m", "rms_tracking_error_m", "max_thrust_N",
              "thrust_limit_N", "sim_time_s", "wall_time_s"):
        assert k in doc
    assert doc["completed"] and doc["max_tracking_error_m"] < 0.5
    assert doc["max_thrust_N"] <= doc["thrust_limit_N"]
    for f in ("timeseries.csv", "path_3d.png", "path_top.png", "positions.png", "attitude.png",
              "velocities.png",
              "thrusters.png", "index.html"):
        assert (tmp_path / f).exists(), f


@pytest.mark.slow
def test_cli_simulate_scenario_file(tmp_path):
    sc = tmp_path / "sc.yaml"
    sc.write_text("vehicle: bluerov2\nmission: {kind: square, side: 4, depth: 1}\ncurrent: [0.1, 0, 0]\n")
    res = CliRunner().invoke(app, ["simulate", str(sc), "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["completed"]
    bad = tmp_path / "bad.yaml"
    bad.write_text("vehicle: bluerov2\nmission: {kind: circle}\n")
    res = CliRunner().invoke(app, ["simulate", str(bad)])
    assert res.exit_code == 2 and "mission.kind" in res.output


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["bluerov2", "bluerov2-heavy", "romeo", "auv2"])
def test_cli_envelope_prints_a_table_for_every_preset(preset):
    res = CliRunner().invoke(app, ["vehicle", "envelope", preset])
    assert res.exit_code == 0, res.output
    assert f"{preset}: speed envelope" in res.output and "nan" not in res.output.lower()
    # forces and speeds carry their units (rows mix N / N·m and m/s / rad/s)
    assert " m/s" in res.output and " rad/s" in res.output and " N·m" in res.output


@pytest.mark.parametrize("args", [["vehicle", "envelope", "nosuch"], ["vehicle", "info", "nosuch"],
                                  ["simulate", "mission", "square", "--vehicle", "nosuch"]])
def test_unknown_vehicle_names_the_presets_once(args):
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2
    text = " ".join(res.output.split())
    assert text.count("presets") == 1 and "bluerov2-heavy" in text and "['" not in text


@pytest.mark.slow
def test_cli_envelope_confirms_heave_and_yaw_and_the_heavy():
    """The Heavy controls roll and pitch: flown at full command with its attitude held, every
    translational direction reaches the analytic (allocator) speed; the BlueROV2 cannot hold
    roll/pitch, and its unconfirmed directions carry the static-stability limit, whose trim the
    simulation flies."""
    runner = CliRunner()
    res = runner.invoke(app, ["vehicle", "envelope", "bluerov2-heavy", "--json"])
    assert res.exit_code == 0, res.output
    rows = {r["direction"]: r for r in json.loads(res.stdout)["rows"]}
    for d in ("forward", "backward", "starboard", "port", "diving", "climbing", "yaw + (clockwise)"):
        r = rows[d]
        assert r["confirmed"] and r["relative_difference"] < 0.05, (d, r["note"])
        assert abs(r["final_roll_deg"]) < 1 and abs(r["final_pitch_deg"]) < 1, d  # attitude held
    assert set(rows["nose up"]) == set(rows["forward"])  # every row carries every column

    res = runner.invoke(app, ["vehicle", "envelope", "bluerov2", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    rows = {r["direction"]: r for r in doc["rows"]}
    cases = {c["direction"]: c for c in doc["stability"]["cases"]}
    for d in ("diving", "climbing", "yaw + (clockwise)"):
        assert rows[d]["confirmed"] and rows[d]["relative_difference"] < 0.05, d
    for d, ang in (("forward", "pitch"), ("backward", "pitch"), ("starboard", "roll"), ("port", "roll")):
        r, c = rows[d], cases[d]
        assert r["confirmed"] is False and r["limit"].startswith("stability") and ang in r["limit"]
        # no simulated speed for a vehicle that cannot stay level: the tumbling run is kept apart
        assert r["simulated_speed"] is None and r["relative_difference"] is None
        assert max(r["tumbling_full_command"]["max_abs_roll_deg"],
                   r["tumbling_full_command"]["max_abs_pitch_deg"]) > doc["stability"]["max_tilt_deg"], d
        assert c["limit_speed"] < abs(r["allocator_speed"]) and c["limit_dof"] == ang
        # the simulation flown at a speed below the limit settles on the static trim
        assert r["trim_check_speed"] < c["limit_speed"]
        assert abs(r["trim_static_deg"]) > 1.0
        assert r["trim_simulated_deg"] == pytest.approx(r["trim_static_deg"], rel=0.02, abs=0.05), d


@pytest.mark.slow
def test_thruster_loop_study_runs_and_answers():
    from uuvid.papers.thruster_loop_study import run_study

    r = run_study(bandwidths=(2.0,))
    assert len(r["rows"]) == 6
    assert set(r["max_stable_bandwidth"]["heading"]) == {"tunnel", "first-order", "yoerger"}
    assert "conjecture" in r["answer"]
    # the tunnel thruster's leading response: true thrust spikes far above its steady limit
    tunnel = [x for x in r["rows"] if x["model"] == "tunnel"]
    assert max(x["max_thrust_N"] for x in tunnel) > 2.3


@pytest.mark.slow
def test_level_speed_limit_is_cached_per_vehicle(tmp_path, monkeypatch, bluerov2):
    """The stability scan behind the default cruise speed runs once per vehicle and code version
    (≈ 0.5 s; a scenario build would pay it each time); a changed vehicle is scanned again."""
    import dataclasses

    from uuvid.simulate.reference import level_speed_limit
    from uuvid.vehicle import stability

    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path))
    first = level_speed_limit(bluerov2)
    calls = []
    real = stability.static_stability
    monkeypatch.setattr(stability, "static_stability", lambda v, **k: calls.append(v) or real(v, **k))
    assert level_speed_limit(bluerov2) == first and not calls
    heavier = dataclasses.replace(bluerov2, params=dataclasses.replace(
        bluerov2.params, mass=bluerov2.params.mass * 1.1))
    level_speed_limit(heavier)
    assert len(calls) == 1


@pytest.mark.slow
def test_level_speed_limit_cache_is_keyed_on_the_layers_it_runs(tmp_path, monkeypatch, bluerov2):
    """The scan depends on more than stability.py (allocation, model, hydrodynamics ...): a new
    stamp of the core, thruster and vehicle layers must scan again, not read the old entry — and
    an edit above them (the CLI, a report) must not (hashing every source file for the key cost
    each tilted mission ≈ 37 ms)."""
    from uuvid.core import cache as disk
    from uuvid.simulate.reference import level_speed_limit
    from uuvid.vehicle import stability

    monkeypatch.setenv("UUVID_KERNEL_CACHE", str(tmp_path))
    level_speed_limit(bluerov2)
    calls = []
    real = stability.static_stability
    monkeypatch.setattr(stability, "static_stability", lambda v, **k: calls.append(v) or real(v, **k))
    monkeypatch.setattr(disk, "code_version", lambda: "0.0.0+an-edit-in-the-cli")
    level_speed_limit(bluerov2)
    assert calls == []  # the layers the scan runs did not change
    stamp = disk.tree_stamp("", "core", "thruster", "vehicle")
    monkeypatch.setattr(disk, "tree_stamp", lambda *subs: stamp + "-an-edit-in-vehicle")
    level_speed_limit(bluerov2)
    assert len(calls) == 1


def _general_loop(setup):
    """The mission flown by the general compiled loop (``fly``: block dispatch, every option)."""
    from uuvid.simulate import vehicle_sim

    s, b = setup, setup.bank
    N, z0 = s.t.size, s.z0()
    out = (np.empty((N, z0.size)), np.empty((N, b.n)), np.empty((N, b.n)), np.empty((N, 6)),
           np.empty(N))
    ref = [np.ascontiguousarray(a) for a in s.ref]
    vehicle_sim.fly(z0, s.vp, s.B, s.alloc, s.eta_p, s.eta_n, s.dofs, b.kinds, b.poff, b.params,
                    b.soff, b.outch, b.in_ch, b.exact, b.inv_thrust, b.inv_command,
                    s.gains.to_array(), *ref, s.current, s.dt, s.substeps, *out, np.zeros((0, 3)),
                    np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3 + b.n)),
                    *vehicle_sim._inflow_or_empty(s.inflow_arrays))
    return out


@pytest.mark.parametrize("kw", [{}, {"current": (0.2, -0.1, 0.0), "substeps": 2,
                                      "allocation": "scale"},
                                 {"inflow": "four-quadrant"},
                                 {"inflow": "four-quadrant", "current": (0.3, 0.1, 0.0)}],
                         ids=["still", "current-substeps", "inflow", "inflow-current"])
def test_specialised_loop_is_the_general_loop_bit_for_bit(bluerov2, kw):
    """fly_mission flies ESC → first-order motor → quadratic map vehicles with the built-in PID
    through the specialised loop (fly_quad): the same numbers as the general loop, bit for bit —
    states, delivered and allocated thrusts, controller output and allocation scale — with the
    thrust taken to the advance speed (inflow) too."""
    from uuvid.simulate import vehicle_sim

    setup = setup_mission(bluerov2, square_mission(), t_end=30.0, **kw)
    assert vehicle_sim.quad_chain(setup.bank)
    assert (setup.inflow_arrays is not None) == ("inflow" in kw)
    run, _, out = vehicle_sim.mission_runner(setup)
    run(setup.t.size)
    for got, ref in zip(out, _general_loop(setup)):
        assert np.array_equal(got, ref)


def _general_loop_around(setup, direct: bool = False):
    """The mission flown by the general loop (every branch compiled) with the setup's controller
    and disturbance, battery and current series included: as function pointers
    (:func:`compiled_loop`), or with ``direct`` compiled into it (the loop as it was before the
    pointers: ``_CTRL``/``_DIST`` module globals, direct calls)."""
    from uuvid.simulate import vehicle_sim
    from uuvid.simulate.control.blocks import compiled_form
    from uuvid.simulate.control.pid import pid
    from uuvid.simulate.disturbances import no_disturbance

    s, b = setup, setup.bank
    N, z0 = s.t.size, s.z0()
    c = s.controller or pid(s.gains)
    cfn, cpar = compiled_form(c)
    d = s.disturbance
    dfn = d.fn if d is not None else no_disturbance
    loop = (vehicle_sim._in_memory(vehicle_sim._fly_loop, (), _CTRL=cfn, _DIST=dfn) if direct
            else vehicle_sim.compiled_loop(cfn, dfn)[0])
    VCT, DVCT = s.current_series if s.current_series is not None else (np.zeros((0, 3)),) * 2
    BAT = s.battery_array if s.battery_array is not None else np.zeros(0)
    out = (np.empty((N, z0.size)), np.empty((N, b.n)), np.empty((N, b.n)), np.empty((N, 6)),
           np.empty(N), np.zeros((N if BAT.size else 0, 3 + b.n)))
    loop(np.ascontiguousarray(cpar), c.state0.copy(), d.params if d is not None else np.zeros(0),
         d is not None, c.output_code, z0, s.vp, s.B, s.alloc, s.eta_p, s.eta_n, s.dofs, b.kinds,
         b.poff, b.params, b.soff, b.outch, b.in_ch, b.exact, b.inv_thrust, b.inv_command,
         *[np.ascontiguousarray(a) for a in s.ref], s.current, s.dt, s.substeps, *out[:5], VCT,
         DVCT, BAT, out[5], *vehicle_sim._inflow_or_empty(s.inflow_arrays))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("kw", [{"battery": True},
                                {"disturbance": "wave", "current": (0.2, -0.1, 0.0),
                                 "inflow": "four-quadrant"}], ids=["battery", "wave-current-inflow"])
def test_loop_specialised_to_its_configuration_is_the_general_loop_bit_for_bit(bluerov2, kw):
    """A mission outside fly_quad's configuration flies _fly_loop specialised to its own
    (battery or not, current, inflow, the closed-form path): the same numbers as the general loop
    with every branch compiled, bit for bit — states, thrusts, controller output, allocation scale
    and the battery's voltage, current and charge."""
    from uuvid.simulate import vehicle_sim
    from uuvid.simulate.disturbances import sinusoidal

    kw = dict(kw)
    if kw.get("disturbance") == "wave":
        kw["disturbance"] = sinusoidal(amplitude=(10.0, 0, 8.0, 0, 0, 0), period=5.0)
    setup = setup_mission(bluerov2, square_mission(), t_end=20.0, **kw)
    run, _, out = vehicle_sim.mission_runner(setup)
    assert run.loop is not vehicle_sim._fly_loop and run.loop is not vehicle_sim.fly_quad
    run(setup.t.size)
    ref = _general_loop_around(setup)
    assert len(out) == len(ref)
    for got, want in zip(out, ref):
        assert np.array_equal(got, want)
    if "battery" not in kw:  # and the loop with the blocks compiled in (no pointers): the same
        for got, want in zip(out, _general_loop_around(setup, direct=True)):
            assert np.array_equal(got, want)


def test_a_mission_moving_in_an_unallocated_dof_is_named():
    """A vehicle file whose allocation leaves out a DOF the mission moves in (a square turns in
    yaw and moves ahead in surge) says which and from when, not only that the path was missed."""
    import yaml

    from uuvid.simulate.vehicle_sim import unallocated_motion_warning
    from uuvid.vehicle.definition import preset_path, vehicle_from_dict

    raw = yaml.safe_load(preset_path("bluerov2").read_text())

    def warning(dofs):
        raw["allocation"] = {"dofs": dofs}
        return unallocated_motion_warning(setup_mission(vehicle_from_dict(raw, where="v.yaml"),
                                                        square_mission()))

    w = warning(["surge", "heave"])
    assert "yaw (up to 0.3 rad/s" in w and "surge," not in w.split("controls")[0], w
    w = warning(["sway", "heave", "yaw"])
    assert w.startswith("the mission moves in surge (up to 0.5 m/s") and "yaw (" not in w, w
    assert warning(["surge", "sway", "heave", "yaw"]) == ""
    r = fly_mission(setup_mission(load_vehicle("bluerov2"), square_mission()))
    assert not any("not allocated" in x for x in r.metrics["warnings"])
    raw["allocation"] = {"dofs": ["surge", "heave"]}
    r = fly_mission(setup_mission(vehicle_from_dict(raw, where="v.yaml"), square_mission()))
    assert not r.metrics["completed"] and "not allocated" in r.metrics["warnings"][0]
    # a controller that outputs each thruster's thrust bypasses the allocation: nothing to say
    from uuvid.simulate.control.lqr import lqr

    v = vehicle_from_dict(raw, where="v.yaml")
    assert unallocated_motion_warning(setup_mission(v, square_mission(), controller=lqr(v))) == ""


@pytest.mark.slow
def test_timeseries_csv_columns_carry_their_units(bluerov2, tmp_path):
    """``timeseries.csv`` said ``time, north, roll, u, thrust_T1…`` with no unit while the summary
    gives degrees: every column now names its unit as uuvid's other tables do (values stay SI)."""
    import pandas as pd

    from uuvid.simulate.mission_report import write_mission_outputs

    res = fly_mission(setup_mission(bluerov2, square_mission(), t_end=5.0))
    write_mission_outputs(res, bluerov2, tmp_path)
    df = pd.read_csv(tmp_path / "timeseries.csv")
    units = ("_s", "_m", "_rad", "_mps", "_rad_s", "_N")
    assert [c for c in df.columns if not c.endswith(units)] == ["allocation_scale"]
    for c in ("t_s", "north_m", "ref_down_m", "roll_rad", "pitch_rad", "yaw_rad", "ref_yaw_rad",
              "u_mps", "r_rad_s", "tracking_error_m", f"thrust_{res.thruster_names[0]}_N",
              f"thrust_cmd_{res.thruster_names[0]}_N"):
        assert c in df.columns, c
    np.testing.assert_allclose(df["t_s"], res.t)
    np.testing.assert_allclose(df["r_rad_s"], res.velocity[:, 5])
    np.testing.assert_allclose(df["tracking_error_m"], res.tracking_error)
    # radians, not the summary's degrees
    assert np.max(np.abs(df["pitch_rad"])) == pytest.approx(np.radians(res.metrics["max_pitch_deg"]),
                                                            rel=1e-6)


@pytest.mark.slow
def test_the_mission_page_shows_its_warnings(bluerov2, tmp_path):
    """`uuvid simulate --out`'s index.html listed completed and completed_reason in its table but
    not the warnings the command line prints (they are a list, left out of the table)."""
    import html

    from uuvid.simulate.mission_report import write_mission_outputs

    res = fly_mission(setup_mission(bluerov2, square_mission(), t_end=5.0))
    assert res.metrics["warnings"] and not res.metrics["completed"]
    page = write_mission_outputs(res, bluerov2, tmp_path).read_text()
    for w in res.metrics["warnings"]:
        assert html.escape(w, quote=False) in page or html.escape(w) in page, w
    from uuvid.simulate.reference import cruise_speed

    quiet = fly_mission(setup_mission(bluerov2, square_mission(speed=cruise_speed(bluerov2)[0])))
    assert not quiet.metrics["warnings"]
    assert "Warnings" not in write_mission_outputs(quiet, bluerov2, tmp_path / "q").read_text()
