"""Controllers and disturbances as blocks of the compiled mission loop (issue 12, item 3).

The user controller below is written here, outside the package, as a user would: a body-frame PD
on position and yaw, compiled by numba, plugged in through ``setup_mission(controller=...)``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from uuvid.simulate.control.blocks import Controller
from uuvid.simulate.control.pid import pid, pid_controller
from uuvid.simulate.disturbances import Disturbance, sinusoidal
from uuvid.simulate.reference import square_mission
from uuvid.simulate.vehicle_sim import fly_mission, run_batch, setup_mission
from uuvid.vehicle.definition import load_vehicle

REF = Path(__file__).parent / "data" / "square_mission_bluerov2.npz"


def _tracked(r):
    """Followed the path (the tracking half of ``completed``; the BlueROV2 at the square's
    nominal 0.5 m/s pitches past the 20° level limit, which ``completed`` also requires)."""
    m = r.metrics
    return m["max_tracking_error_m"] < 1.0 and m["final_position_error_m"] < 0.25


def body_pd(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    """PD on the body-frame position error (gains params[0], params[1]) and yaw (params[2],
    params[3]); counts its calls in state[0]."""
    q0, q1, q2, q3 = eta[3], eta[4], eta[5], eta[6]
    r00, r01, r02 = 1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)
    r10, r11, r12 = 2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)
    r20, r21, r22 = 2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)
    d0, d1, d2 = ref_pos[0] - eta[0], ref_pos[1] - eta[1], ref_pos[2] - eta[2]
    e = (r00 * d0 + r10 * d1 + r20 * d2, r01 * d0 + r11 * d1 + r21 * d2,
         r02 * d0 + r12 * d1 + r22 * d2)
    v = (r00 * ref_vel[0] + r10 * ref_vel[1] + r20 * ref_vel[2],
         r01 * ref_vel[0] + r11 * ref_vel[1] + r21 * ref_vel[2],
         r02 * ref_vel[0] + r12 * ref_vel[1] + r22 * ref_vel[2])
    for j in range(6):
        tau_out[j] = 0.0
    for i in range(3):
        tau_out[i] = params[0] * e[i] + params[1] * (v[i] - nu[i])
    yaw = math.atan2(2 * (q0 * q3 + q1 * q2), 1 - 2 * (q2 * q2 + q3 * q3))
    ey = (ref_yaw - yaw + math.pi) % (2 * math.pi) - math.pi
    tau_out[5] = params[2] * ey + params[3] * (ref_rate - nu[5])
    state[0] += 1.0


body_pd_compiled = njit(body_pd)
PD_GAINS = [60.0, 80.0, 10.0, 8.0]


@pytest.fixture(scope="module")
def bluerov2():
    return load_vehicle("bluerov2")


@pytest.fixture(scope="module")
def pd_setup(bluerov2):
    return setup_mission(bluerov2, square_mission(),
                         controller=Controller(body_pd_compiled, PD_GAINS, [0.0], "PD"))


def _pid_block_equals_built_in(bluerov2, **blocks):
    ref = np.load(REF)
    rows = ref["rows"]
    for current in ((0.0, 0.0, 0.0), (0.2, -0.1, 0.05)):
        base = fly_mission(setup_mission(bluerov2, square_mission(), current=current))
        r = fly_mission(setup_mission(bluerov2, square_mission(), current=current,
                                      controller=pid(base_gains(bluerov2)), **blocks))
        assert r.metrics["controller"] == "PID DP"
        for a, b in ((r.state, base.state), (r.thrust, base.thrust), (r.tau_cmd, base.tau_cmd)):
            assert np.max(np.abs(a - b)) <= 1e-12
        if current == (0.0, 0.0, 0.0):
            assert np.max(np.abs(r.state[rows, :13] - ref["state"])) <= 1e-12


def base_gains(vehicle):
    from uuvid.simulate.vehicle_sim import default_gains

    return default_gains(vehicle)


@pytest.mark.slow
def test_pid_as_a_controller_block_equals_the_built_in_loop(bluerov2):
    """The PID DP passed as a Controller (with a zero-amplitude disturbance block, which shares
    its compiled loop with test_disturbance_force) flies the loop compiled around it; states,
    thrusts and controller output equal the built-in loop's, and the recorded run
    (tests/data/make_square_mission_reference.py), to 1e-12 — with a current too."""
    _pid_block_equals_built_in(bluerov2, disturbance=sinusoidal(period=3.0))


@pytest.mark.slow
def test_pid_as_the_only_block_equals_the_built_in_loop(bluerov2):
    """As above, the PID alone (no disturbance block)."""
    _pid_block_equals_built_in(bluerov2)


@pytest.mark.slow  # compiles the loop around the test's PD (≈ 7 s); the default suite flies
# a user block through test_pid_as_a_controller_block_equals_the_built_in_loop
def test_user_compiled_controller_flies_the_square(pd_setup):
    """A PD written in this test file, compiled by numba, flies the square mission: it is called
    once per step (its persistent state counts the calls), its output is the loop's τ_cmd, and it
    tracks the square (a PD has no integrator: the tracking is good, not PID-exact)."""
    s = pd_setup
    r = fly_mission(s)
    assert r.metrics["controller"] == "PD"
    assert _tracked(r)
    assert r.metrics["max_tracking_error_m"] < 0.5
    # τ_cmd is the PD's output at the recorded state: recompute step k in plain Python
    for k in (0, 1234, s.t.size - 1):
        z = r.state[k]
        out = np.zeros(6)
        body_pd(s.t[k], z[0:7], z[7:13], s.ref[0][k], s.ref[1][k], s.ref[2][k], s.ref[3][k],
                np.array(PD_GAINS), np.zeros(1), s.dt, out)
        np.testing.assert_allclose(r.tau_cmd[k], out, rtol=1e-12, atol=1e-9)
    # the state array of the Controller is not modified: each flight starts from a copy
    assert s.controller.state0[0] == 0.0
    r2 = fly_mission(s)
    assert np.array_equal(r.state, r2.state)


@pytest.mark.slow
def test_user_controller_in_the_batch_loop(pd_setup, bluerov2):
    """run_batch with a user controller flies each vehicle through the loop compiled around it:
    the nominal row equals fly_mission's summary, a perturbed vehicle differs."""
    s = pd_setup
    r = fly_mission(s)
    from uuvid.simulate.batch import perturb_vehicle_params, run_batch_fast

    VP = np.tile(s.vp, (3, 1))
    VP[2] = perturb_vehicle_params(bluerov2, np.random.default_rng(1), 1, current_speed=0.0)[0]
    out = run_batch(s, VP)
    err = r.tracking_error
    np.testing.assert_allclose(out[0, :4], [err.max(), math.sqrt(np.mean(err**2)),
                                            np.abs(r.thrust).max(), err[-1]], rtol=1e-12)
    assert np.array_equal(out[0], out[1])
    assert not np.array_equal(out[0], out[2])
    fast = run_batch_fast(s, VP[:2])  # the SIMD kernel around the user's controller
    np.testing.assert_allclose(fast[:, :5], out[:2, :5], rtol=1e-12)


@pytest.mark.slow
def test_python_controller_equals_the_compiled_one(pd_setup, bluerov2):
    """The same PD as a plain Python callable (called through numba.objmode each step) flies the
    same trajectory as the compiled one."""
    r = fly_mission(pd_setup)
    s = setup_mission(bluerov2, square_mission(), controller=Controller(body_pd, PD_GAINS, [0.0]))
    assert not s.controller.compiled
    rp = fly_mission(s)
    assert np.max(np.abs(rp.state[:, :13] - r.state[:, :13])) <= 1e-9
    out = run_batch(s, s.vp[None])
    assert out[0, 0] == pytest.approx(rp.metrics["max_tracking_error_m"], rel=1e-12)


@pytest.mark.slow
def test_disturbance_force(bluerov2):
    """A sinusoidal disturbance of zero amplitude flies exactly the undisturbed mission; a
    constant surge force c is cancelled by the PID's integral action on the final hold
    (τ_cmd,X → −c) while the vehicle holds its waypoint."""
    base = fly_mission(setup_mission(bluerov2, square_mission()))
    r0 = fly_mission(setup_mission(bluerov2, square_mission(), disturbance=sinusoidal(period=3.0)))
    assert r0.metrics["disturbance"] == "sinusoidal"
    assert np.array_equal(r0.state, base.state)
    c = 15.0
    r = fly_mission(setup_mission(bluerov2, square_mission(),
                                  disturbance=sinusoidal(constant=(c, 0, 0, 0, 0, 0))))
    assert r.tau_cmd[-1, 0] == pytest.approx(-c, rel=0.02)
    assert abs(base.tau_cmd[-1, 0]) < 0.02 * c
    assert r.metrics["final_position_error_m"] < 0.05


def test_bad_blocks(bluerov2):
    with pytest.raises(TypeError, match="callable"):
        Controller(3.0, [], [])
    with pytest.raises(TypeError, match="numba"):
        Disturbance(lambda t, eta, nu, p, out: None, [])
    with pytest.raises(TypeError, match="Controller"):
        setup_mission(bluerov2, square_mission(), controller=body_pd)
    with pytest.raises(ValueError, match="6 values"):
        sinusoidal((1.0, 2.0))


# ---------------------------------------------------------------------------------------------
# Controllers that output per-thruster thrust or raw commands
# ---------------------------------------------------------------------------------------------
@njit
def pid_then_allocate(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    """The package's PID wrench (params[:24], state[:16]), allocated here by uniform scaling with
    the vehicle's allocation matrix T (params[24:24+6n]) and limits (then lo (n), hi (n))."""
    n = tau_out.size
    wrench = state[16:22]
    pid_controller(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params[:24], state[:16], dt,
                   wrench)
    o = 24 + 6 * n
    s = 1.0
    for i in range(n):
        f = 0.0
        for j in range(6):
            f += params[24 + 6 * i + j] * wrench[j]
        tau_out[i] = f
        if f > params[o + n + i]:
            s = min(s, params[o + n + i] / f)
        elif f < params[o + i]:
            s = min(s, params[o + i] / f)
    for i in range(n):
        tau_out[i] *= s


@pytest.mark.slow  # its own loop compile (≈ 7 s)
def test_thrust_output_controller_reproduces_the_built_in_run(bluerov2):
    """A controller written here computes the PID wrench and allocates it itself (T, limits,
    uniform scaling) with output='thrust': the loop skips its own allocation, and the flight
    equals the built-in run with the 'scale' allocation (the same arithmetic) to rounding."""
    from uuvid.simulate.vehicle_sim import default_gains

    g = default_gains(bluerov2)
    al = bluerov2.allocator()
    lim = bluerov2.layout.limits
    params = np.concatenate([g.to_array().ravel(), al.T.ravel(), lim[:, 0], lim[:, 1]])
    ctrl = Controller(pid_then_allocate, params, np.zeros(22), "PID + own allocation", "thrust")
    base = fly_mission(setup_mission(bluerov2, square_mission(), allocation="scale"))
    r = fly_mission(setup_mission(bluerov2, square_mission(), allocation="scale", controller=ctrl))
    assert r.metrics["controller_output"] == "thrust"
    assert base.metrics["controller_output"] == "wrench"
    assert np.max(np.abs(r.state - base.state)) <= 1e-9
    assert np.max(np.abs(r.thrust_cmd - base.thrust_cmd)) <= 1e-9
    # τ_cmd of a thrust output: B (η ∘ f) of the thrusts sent on; here (T a right inverse of B on
    # the controlled DOFs, no saturation on the square) the PID's wrench on those DOFs
    ep, en = al.eta
    f = r.thrust_cmd
    np.testing.assert_allclose(r.tau_cmd, (f * np.where(f >= 0, ep, en)) @ bluerov2.B.T,
                               rtol=1e-12, atol=1e-9)
    assert np.array_equal(r.scale, np.ones_like(r.scale))


@njit
def hold_command(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    for i in range(tau_out.size):
        tau_out[i] = params[i]


@njit
def echo_params(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    for i in range(params.size):
        tau_out[i] = params[i]


@pytest.mark.slow
def test_command_output_gives_the_chains_steady_thrust(bluerov2):
    """Constant PWM commands (output='command') reach the ESCs as they are: once the thruster
    lag has settled, the delivered thrust is the chain's steady map of the command (times η),
    and thrust_cmd reads the same thrust back from the inverse table."""
    n = len(bluerov2.layout)
    chain = bluerov2.thruster_chain(0)
    pwm = np.array([1620.0, 1380.0, 1550.0, 1500.0, 1700.0, 1300.0, 1530.0, 1470.0])[:n]
    s = setup_mission(bluerov2, square_mission(), t_end=3.0,
                      controller=Controller(hold_command, pwm, [], "PWM hold", "command"))
    r = fly_mission(s)
    steady = np.array([bluerov2.thruster_chain(i).steady_thrust(np.array([c]))[0]
                       for i, c in enumerate(pwm)])
    ep, en = bluerov2.allocator().eta
    want = steady * np.where(steady >= 0, ep, en)
    np.testing.assert_allclose(r.thrust[-1], want, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(r.thrust_cmd[-1], steady, rtol=1e-3, atol=0.02)
    assert r.thrust[-1, 3] == 0.0  # neutral PWM: no thrust
    assert chain.input_kind != "thrust"


@pytest.mark.slow
def test_per_thruster_output_errors():
    """A wrong output kind or length is named with what was expected (the Heavy: 8 thrusters)."""
    with pytest.raises(ValueError, match="wrench, thrust, command"):
        Controller(hold_command, [], [], output="pwm")
    heavy = load_vehicle("bluerov2-heavy")
    mission = square_mission()
    with pytest.raises(ValueError, match=r"must write 8 values.*wrote past"):  # Python: IndexError
        setup_mission(heavy, mission, controller=Controller(echo_params.py_func, np.zeros(10), [],
                                                            output="thrust"))
    with pytest.raises(ValueError, match=r"must write 8 values.*left entries \[6, 7\] unwritten"):
        setup_mission(heavy, mission, controller=Controller(body_pd_compiled, PD_GAINS, [0.0],
                                                            output="command"))
    with pytest.raises(ValueError, match=r"must write 6 values.*wrote 2 more.*output='thrust'"):
        setup_mission(heavy, mission, controller=Controller(echo_params, np.zeros(8), []))
    with pytest.raises(ValueError, match="failed on its first call.*ZeroDivisionError"):
        setup_mission(heavy, mission, controller=Controller(lambda *a: 1 / 0, [], []))


# ---------------------------------------------------------------------------------------------
# User controllers in the SIMD batch kernel
# ---------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_which_controllers_the_simd_kernel_takes(bluerov2, pd_setup):
    """Compiled wrench controllers fly the SIMD kernel; the others say why not."""
    from uuvid.simulate.batch import fast_path_reason

    assert fast_path_reason(pd_setup) is None
    n = len(bluerov2.layout)
    thrust = setup_mission(bluerov2, square_mission(),
                           controller=Controller(hold_command, np.zeros(n), [], output="thrust"))
    assert "output='thrust'" in fast_path_reason(thrust)
    py = setup_mission(bluerov2, square_mission(), controller=Controller(body_pd, PD_GAINS, [0.0]))
    assert "plain Python controller" in fast_path_reason(py)
    dist = setup_mission(bluerov2, square_mission(), disturbance=sinusoidal(period=3.0))
    assert "disturbance" in fast_path_reason(dist)


@pytest.mark.slow
def test_pid_as_a_user_controller_in_the_simd_kernel(bluerov2):
    """The PID passed as a Controller flies the SIMD kernel (called per lane) with the numbers
    of the built-in kernel (the PID inline) to 1e-12, perturbed vehicles and a current too."""
    from uuvid.simulate.batch import perturb_batch, run_batch_fast

    base = setup_mission(bluerov2, square_mission())
    user = setup_mission(bluerov2, square_mission(), controller=pid(base.gains))
    VP, TP, VC = perturb_batch(base, np.random.default_rng(3), 40)
    a = run_batch_fast(base, VP, TP, VC)
    b, tr = run_batch_fast(user, VP, TP, VC, trace_runs=[0, 39])
    assert np.all(np.isfinite(b[:, 6]))  # column 6 is NaN on the fallback: this is the kernel
    np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-14)
    _, tr0 = run_batch_fast(base, VP, TP, VC, trace_runs=[0, 39])
    np.testing.assert_allclose(tr, tr0, rtol=0, atol=1e-12)


def test_blocks_are_named_after_their_function_by_default():
    """A mission summary says which controller flew: an unnamed block takes its function's name."""
    from uuvid.simulate.disturbances import Disturbance, sinusoidal_force

    assert Controller(body_pd, PD_GAINS, [0.0]).name == "body_pd"
    assert Controller(body_pd, PD_GAINS, [0.0], name="PD").name == "PD"
    assert Disturbance(sinusoidal_force, np.zeros(12)).name == "sinusoidal_force"


@pytest.mark.slow
def test_a_controller_declared_with_its_own_signature_flies_and_its_first_flight_is_timed_apart():
    """A controller compiled with an explicit signature (``@njit(sig)``, "A"-layout arrays)
    cannot be compiled for the loop's C-contiguous arrays: the loop calls the overload those
    convert to (it crashed: "compilation disabled"). And a new controller on a loop already
    compiled in this process has its first flight timed apart (compile_time_s > 0), not counted
    as flying."""
    from numba import types as nt

    A = nt.Array(nt.float64, 1, "A")
    RO = nt.Array(nt.float64, 1, "A", readonly=True)

    def body(t, eta, nu, rp, rv, ryaw, rrate, params, state, dt, out):
        for j in range(6):
            out[j] = (params[0] * (rp[j] - eta[j]) if j < 3 else 0.0) - params[1] * nu[j]

    hold = njit(nt.void(nt.float64, A, A, A, A, nt.float64, nt.float64, RO, A, nt.float64, A))(body)
    hold_c = njit(body)  # the same, compiled for the arguments it is given

    v = load_vehicle("bluerov2")
    wave = sinusoidal(amplitude=(5.0, 0, 3.0, 0, 0, 0), period=4.0)
    runs = []
    for fn in (hold_c, hold):
        c = Controller(fn, np.array([60.0, 40.0]), np.zeros(0))
        runs.append(fly_mission(setup_mission(v, square_mission(), t_end=5.0, controller=c,
                                              disturbance=wave)))
    assert np.array_equal(runs[0].state, runs[1].state)  # the same arithmetic either way
    assert runs[1].metrics["compile_time_s"] > 0.0  # the declared one's first flight, apart
