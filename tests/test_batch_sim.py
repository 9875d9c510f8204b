"""SIMD batch kernel (uuvid.simulate.batch): the same numbers as the scalar fly() loop.

The fast tests compile one kernel structure (BlueROV2, t200 thrusters, a current); the other
structures (attitude hold, static chains, thrust lag, full matrices, substeps) are slow tests.
Speed is measured by ``batch_throughput`` in the benchmarks, never here.
"""

import dataclasses

import numpy as np
import pytest

from uuvid.simulate import batch
from uuvid.simulate.reference import square_mission
from uuvid.simulate.vehicle_sim import fly_mission, path_cut, run_batch, setup_mission
from uuvid.thruster.blocks import FirstOrder
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.presets import laidani_chain
from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.model import N_PARAMS, P_DL, P_DQ, P_MA, P_MINV, P_MRB, P_VC

RTOL = 1e-9


@pytest.fixture(scope="module")
def bluerov2():
    return load_vehicle("bluerov2")


@pytest.fixture(scope="module")
def square(bluerov2):
    return setup_mission(bluerov2, square_mission(speed=0.35), t_end=40.0)


def setup_allocation(setup):
    from uuvid.simulate.vehicle_sim import allocation_method

    return allocation_method(setup.alloc)


def _fly_one(setup, vp, tp, vc):
    s = dataclasses.replace(setup, vp=vp, current=vc)
    if tp is not None:
        s = dataclasses.replace(s, bank=dataclasses.replace(setup.bank, params=tp))
    return fly_mission(s)


def _check_against_fly(setup, VP, TP, VC, trace_run=None):
    assert batch.fast_path_reason(setup, VP, TP, VC) is None
    out = batch.run_batch_fast(setup, VP, TP, VC)
    assert out.shape == (len(VP), len(batch.SUMMARY_COLUMNS))
    ref = run_batch(setup, VP, TP, VC)
    np.testing.assert_allclose(out[:, :5], ref[:, :5], rtol=RTOL, atol=0)
    # the tilt: the same running max (a cosine near 1 loses digits in acos: absolute in degrees)
    np.testing.assert_allclose(out[:, 8], ref[:, 5], rtol=0, atol=1e-6)
    assert np.all(out[:, 7] == 1.0)
    if trace_run is not None:
        out2, tr = batch.run_batch_fast(setup, VP, TP, VC, trace_runs=[trace_run], trace_every=7)
        np.testing.assert_array_equal(out2, out)  # tracing changes nothing
        res = _fly_one(setup, VP[trace_run], None if TP is None else TP[trace_run], VC[trace_run])
        Z = res.state[::7, :13]
        assert tr.shape == (1, Z.shape[0], 13)
        scale = np.max(np.abs(Z[:, :3]))
        assert np.max(np.abs(tr[0, :, :3] - Z[:, :3])) <= RTOL * scale
        assert np.max(np.abs(tr[0, :, 3:] - Z[:, 3:])) <= 1e-9
        s = res.metrics
        r = out[trace_run]
        assert r[5] == float(s["completed"])
        if np.isnan(r[6]):  # flown again by fly_batch (bounded allocation after saturating)
            assert setup_allocation(setup) != "scale"
        else:
            assert r[6] == pytest.approx(s["saturated_fraction"], abs=1e-12)
    return out


@pytest.mark.slow
def test_perturbed_bluerov2_matches_fly(square):
    """Mass, added mass, damping, current and thruster perturbations: summaries and the
    trajectory of a run equal fly()'s (to rounding; asserted at 1e-9)."""
    VP, TP, VC = batch.perturb_batch(square, np.random.default_rng(7), 5)
    assert np.any(VC != 0)
    out = _check_against_fly(square, VP, TP, VC, trace_run=3)
    # every perturbed vehicle follows the (shortened) path; 'completed' also asks for a level
    # flight, which a vehicle with half the damping in a current need not keep (column 8), and
    # for the path's end, which t_end = 40 s stops before: no run is completed (as fly_mission)
    assert np.all((out[:, 0] < 1.0) & (out[:, 3] < 0.25))
    assert path_cut(square) is not None
    np.testing.assert_array_equal(out[:, 5], 0.0)
    # lanes are independent: a permutation of the runs permutes the rows exactly
    p = np.array([4, 2, 0, 3, 1])
    np.testing.assert_array_equal(batch.run_batch_fast(square, VP[p], TP[p], VC[p]), out[p])


@pytest.mark.slow
def test_default_arguments_are_run_batch_defaults(bluerov2):
    """Default thruster parameters and the setup's current (as run_batch)."""
    setup = setup_mission(bluerov2, square_mission(), t_end=20.0, current=(0.1, -0.05, 0.0))
    VP = np.tile(setup.vp, (3, 1))
    out = batch.run_batch_fast(setup, VP)
    np.testing.assert_allclose(out[:, :5], run_batch(setup, VP)[:, :5], rtol=RTOL, atol=0)
    np.testing.assert_array_equal(out[0], out[2])


def test_perturb_vehicle_params_are_vehicleparams_rows(bluerov2):
    rng = np.random.default_rng(3)
    VP = batch.perturb_vehicle_params(bluerov2, rng, 4)
    assert VP.shape == (4, N_PARAMS)
    # the same draws, through VehicleParams
    rng = np.random.default_rng(3)
    ms = rng.uniform(0.95, 1.05, 4)
    sa, sl, sq = (rng.uniform(0.5, 1.5, (4, 6)) for _ in range(3))
    speed = rng.uniform(0.0, 0.2, 4)
    head = rng.uniform(0.0, 2 * np.pi, 4)
    p = bluerov2.params
    for r in range(4):
        def cong(M, s):
            d = np.sqrt(s)
            return M * np.outer(d, d)

        q = dataclasses.replace(
            p, mass=p.mass * ms[r], inertia=p.inertia * ms[r], weight=p.weight * ms[r],
            added_mass=cong(p.added_mass, sa[r]), linear_damping=cong(p.linear_damping, sl[r]),
            quadratic_damping=cong(p.quadratic_damping, sq[r]),
            current=[speed[r] * np.cos(head[r]), speed[r] * np.sin(head[r]), 0.0])
        np.testing.assert_allclose(VP[r], q.to_array(), rtol=1e-13, atol=1e-15)
    # the diagonal presets stay diagonal; M⁻¹ is full where the CG offset couples
    MA = VP[:, P_MA:P_MA + 36].reshape(-1, 6, 6)
    assert np.all(MA[:, ~np.eye(6, dtype=bool)] == 0)
    big = batch.perturb_vehicle_params(bluerov2, np.random.default_rng(0), 10_000)
    assert big.shape == (10_000, N_PARAMS) and np.all(np.isfinite(big))
    assert np.all(np.hypot(big[:, P_VC], big[:, P_VC + 1]) <= 0.2 + 1e-12)


def test_perturb_thruster_params(square):
    TP = batch.perturb_thruster_params(square, np.random.default_rng(1), 6,
                                       time_constant_scale=(0.5, 2.0), thrust_scale=1.0)
    b = square.bank
    assert TP.shape == (6,) + b.params.shape
    tc = TP[:, :, b.poff[1] + 1] / b.params[None, :, b.poff[1] + 1]  # FirstOrderMotor τ
    assert np.all((tc >= 0.5) & (tc <= 2.0)) and np.ptp(tc) > 0
    np.testing.assert_array_equal(TP[:, :, b.poff[2]:b.poff[3]],  # thrust map untouched
                                  np.broadcast_to(b.params[:, b.poff[2]:b.poff[3]], (6, 6, 4)))


@pytest.mark.slow
def test_unsupported_chain_falls_back_to_fly_batch():
    setup = setup_mission(load_vehicle("auv2"), square_mission(), t_end=5.0)
    VP = np.tile(setup.vp, (2, 1))
    assert "first-order" in batch.fast_path_reason(setup, VP)
    out = batch.run_batch_fast(setup, VP)
    np.testing.assert_array_equal(out[:, :5], run_batch(setup, VP)[:, :5])
    assert np.all(np.isnan(out[:, 6]))
    with pytest.raises(ValueError, match="not applicable"):
        batch.run_batch_fast(setup, VP, fallback=False)


@pytest.mark.slow
def test_batch_throughput_reports(square):
    short = setup_mission(square.vehicle, square_mission(), t_end=2.0)
    r = batch.batch_throughput(short, runs=10, reference_runs=2)
    for k in ("vehicle_steps_per_s", "runs", "steps", "wall_s", "reference", "first_call_s"):
        assert k in r
    assert r["runs"] == 10 and r["steps"] == short.t.size and r["kernel"] == "simd"
    assert r["reference"]["max_rel_diff_summary"] < RTOL


def test_bad_arguments(square):
    VP = np.tile(square.vp, (2, 1))
    with pytest.raises(ValueError, match="chunk"):
        batch.run_batch_fast(square, VP, chunk=12)
    with pytest.raises(ValueError, match="currents"):
        batch.run_batch_fast(square, VP, currents=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="trace_runs"):
        batch.run_batch_fast(square, VP, trace_runs=[5])


# ------------------------------------------------------------------ other kernel structures
@pytest.mark.slow
@pytest.mark.parametrize("name", ["bluerov2-heavy", "romeo"])
def test_attitude_hold_and_static_chains_match_fly(name):
    """BlueROV2 Heavy (8 thrusters, roll/pitch attitude hold) and ROMEO (static c_V V|V| map,
    installation coefficients η ≠ 1)."""
    setup = setup_mission(load_vehicle(name), square_mission(), t_end=30.0)
    VP, TP, VC = batch.perturb_batch(setup, np.random.default_rng(2), 3)
    _check_against_fly(setup, VP, TP, VC, trace_run=1)


@pytest.mark.slow
def test_thrust_lag_polynomial_map_and_substeps_match_fly(bluerov2):
    """A plain first-order thrust lag (thrust-input table), Laidani's ESC → motor → degree-5
    polynomial chain, and two RK4 substeps per control step."""
    lag = ThrusterChain((FirstOrder(0.3),), input_kind="thrust", name="lag")
    for kw in ({"thruster_chain": lag}, {"thruster_chain": laidani_chain()}, {"substeps": 2}):
        setup = setup_mission(bluerov2, square_mission(), t_end=20.0, **kw)
        VP, TP, VC = batch.perturb_batch(setup, np.random.default_rng(5), 3)
        _check_against_fly(setup, VP, TP, VC, trace_run=2)


@pytest.mark.slow
def test_full_matrices_take_the_general_path(bluerov2):
    """Non-diagonal added mass and damping (36 values) use the general right-hand side."""
    setup = setup_mission(bluerov2, square_mission(), t_end=20.0)
    R = 3
    VP, TP, VC = batch.perturb_batch(setup, np.random.default_rng(4), R)
    rng = np.random.default_rng(6)
    off_diag = ~np.eye(6, dtype=bool)
    for off in (P_MA, P_DL, P_DQ):
        M = VP[:, off:off + 36].reshape(R, 6, 6)
        d = np.sqrt(np.abs(np.diagonal(M, axis1=1, axis2=2)))
        C = 0.05 * rng.uniform(-1, 1, (R, 6, 6))
        M += 0.5 * (C + C.transpose(0, 2, 1)) * d[:, :, None] * d[:, None, :] * off_diag
        VP[:, off:off + 36] = M.reshape(R, 36)
    M = VP[:, P_MRB:P_MRB + 36].reshape(R, 6, 6) + VP[:, P_MA:P_MA + 36].reshape(R, 6, 6)
    VP[:, P_MINV:P_MINV + 36] = np.linalg.inv(M).reshape(R, 36)
    _check_against_fly(setup, VP, TP, VC, trace_run=0)


def test_saturated_runs_follow_the_bounded_allocation(bluerov2):
    """The kernel allocates by uniform scaling; under the bounded allocation (the mission default)
    the runs that saturate are flown again by fly(), so every row equals fly_batch's."""
    from uuvid.simulate.reference import square_mission as sq

    s = setup_mission(bluerov2, sq(speed=1.5), t_end=30.0)
    assert s.allocation == "priority"
    VP = np.tile(s.vp, (3, 1))
    VC = np.array([[0.0, 0.0, 0.0], [1.5, 1.5, 0.0], [2.0, -2.0, 0.0]])
    out = batch.run_batch_fast(s, VP, None, VC)
    ref = run_batch(s, VP, None, VC)
    assert np.any(np.isnan(out[:, 6]))  # some run left the limits under uniform scaling: reflown
    np.testing.assert_allclose(out[:, :5], ref[:, :5], rtol=RTOL, atol=0)
    np.testing.assert_allclose(out[:, 8], ref[:, 5], rtol=0, atol=1e-6)


def test_controller_saturation_and_anti_windup_match_fly(bluerov2):
    """A surge/yaw force limit far below what the square asks for keeps the PID saturated for long
    stretches (the allocation itself never saturates, so no run is flown again by fly()): the
    kernel's conditional integration must hold the integrators exactly as fly()'s does."""
    s = setup_mission(bluerov2, square_mission(speed=0.35), t_end=40.0)
    g = s.gains
    tmax = (3.0, g.tau_max[1], g.tau_max[2], 0.5)
    s = setup_mission(bluerov2, square_mission(speed=0.35), t_end=40.0,
                      gains=dataclasses.replace(g, tau_max=tmax))
    VP, TP, VC = batch.perturb_batch(s, np.random.default_rng(3), 3)
    out = _check_against_fly(s, VP, TP, VC)
    assert np.all(out[:, 6] == 0.0)  # never an allocation saturation: the kernel's own numbers


@pytest.mark.slow
def test_completed_column_is_one_for_a_mission_flown_to_its_end(bluerov2):
    """A short leg with no hold and no t_end: the flight stops within half a step of the path's
    end (the step count is rounded), which is the path flown, not a cut — fly_mission and the
    batch's column 5 both say completed (every other batch test flies a path cut by t_end)."""
    from uuvid.simulate.reference import WaypointMission

    setup = setup_mission(bluerov2, WaypointMission(((0, 0, 1, 0), (3, 0, 1, 0)), speed=0.33, hold=0.0))
    assert path_cut(setup) is None
    r = fly_mission(setup).metrics
    assert r["completed"] and r["path_finished"] and r["completed_reason"] == "", r
    out = batch.run_batch_fast(setup, np.tile(setup.vp, (2, 1)))
    np.testing.assert_array_equal(out[:, 5], 1.0)
    short = setup_mission(bluerov2, setup.mission, t_end=float(setup.t[-1]) - 1.0)
    assert path_cut(short) is not None
    np.testing.assert_array_equal(batch.run_batch_fast(short, np.tile(short.vp, (2, 1)))[:, 5], 0.0)
