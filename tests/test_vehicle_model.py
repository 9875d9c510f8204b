"""6-DOF vehicle model: compiled RHS vs NumPy reference, energy, restoring, buoyancy, current,
and Caccia et al. (2000) eq. 3."""

import math

import numpy as np
import pytest

from uuvid.thruster.blocks import ParameterError
from uuvid.vehicle import load_vehicle
from uuvid.vehicle.hydrodynamics import from_fossen_derivatives, restoring_forces
from uuvid.vehicle.kinematics import (
    euler_to_quat,
    euler_to_rotmat,
    normalise_state,
    quat_to_euler,
    quat_to_rotmat,
)
from uuvid.vehicle.model import (
    N_PARAMS,
    P_VC,
    PARAM_LAYOUT,
    OneDofModel,
    make_params,
    make_state,
    one_dof_rhs,
    one_dof_rhs_compiled,
    steady_speed,
    vehicle_rhs,
    vehicle_rhs_into,
    vehicle_rhs_reference,
)
from uuvid.vehicle.rigid_body import coriolis_from_mass, rigid_body_mass_matrix


def rk4(x, tau, p, dt, n, normalise=False):
    """The simple fixed-step RK4 the tests integrate the compiled RHS with."""
    x = np.array(x, dtype=float)
    for _ in range(n):
        k1 = vehicle_rhs(x, tau, p)
        k2 = vehicle_rhs(x + 0.5 * dt * k1, tau, p)
        k3 = vehicle_rhs(x + 0.5 * dt * k2, tau, p)
        k4 = vehicle_rhs(x + dt * k3, tau, p)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if normalise:
            normalise_state(x)
    return x


def coupled_params(**kw):
    """A deliberately coupled body: off-diagonal inertia, CG off the origin, full 6×6 M_A."""
    rng = np.random.default_rng(7)
    A = rng.normal(size=(6, 6)) * 0.5
    MA = A @ A.T + np.diag([5.0, 8.0, 10.0, 0.3, 0.4, 0.2])
    base = {"mass": 12.0, "inertia": [[0.3, 0.02, -0.01], [0.02, 0.4, 0.03], [-0.01, 0.03, 0.5]],
            "r_g": (0.01, -0.02, 0.03), "r_b": (0.0, 0.01, -0.02), "weight": 117.0,
            "buoyancy": 119.0, "added_mass": MA.ravel(),
            "linear_damping": [4, 6, 5, 0.1, 0.1, 0.1],
            "quadratic_damping": [18, 21, 37, 1.5, 1.5, 1.5]}
    base.update(kw)
    return make_params(**base)


# --------------------------------------------------------------------------- parameter array
def test_param_layout_is_contiguous_and_versioned():
    offs = sorted(PARAM_LAYOUT.values())
    pos = 0
    for off, size in offs:
        assert off == pos
        pos += size
    assert pos == N_PARAMS
    p = load_vehicle("bluerov2").params.to_array()
    assert p.shape == (N_PARAMS,) and p[0] == 1.0
    M = load_vehicle("bluerov2").params.mass_matrix
    off, _ = PARAM_LAYOUT["Minv"]
    assert np.allclose(p[off:off + 36].reshape(6, 6) @ M, np.eye(6))


# --------------------------------------------------------------------------- compiled == NumPy
@pytest.mark.parametrize("name", ["bluerov2", "bluerov2-heavy", "romeo", "auv2", "coupled"])
def test_compiled_rhs_matches_numpy_reference(name):
    params = coupled_params() if name == "coupled" else load_vehicle(name).params
    params = params.with_current([0.3, -0.2, 0.05])
    p = params.to_array()
    rng = np.random.default_rng(1)
    for _ in range(20):
        x = make_state(rng.normal(size=3), rng.uniform(-1.2, 1.2, 3), rng.normal(size=6))
        x[3:7] *= 1.0 + 0.01 * rng.normal()  # off the unit sphere: exercises the γ term
        tau = rng.normal(size=6) * 20
        ref = vehicle_rhs_reference(x, tau, params)
        assert np.allclose(vehicle_rhs(x, tau, p), ref, rtol=1e-12, atol=1e-10)
        vc, dvc = rng.normal(size=3), rng.normal(size=3)
        dx = np.empty(13)
        vehicle_rhs_into(x, tau, p, vc, dvc, dx)
        assert np.allclose(dx, vehicle_rhs_reference(x, tau, params, vc, dvc), rtol=1e-12,
                           atol=1e-10)


# --------------------------------------------------------------------------- kinematics
def test_quaternion_rotation_matches_euler_and_round_trips():
    rng = np.random.default_rng(2)
    for _ in range(20):
        rpy = rng.uniform([-3, -1.5, -3], [3, 1.5, 3])
        q = euler_to_quat(*rpy)
        R = quat_to_rotmat(q)
        assert np.allclose(R, euler_to_rotmat(*rpy))
        assert np.allclose(R.T @ R, np.eye(3)) and np.isclose(np.linalg.det(R), 1.0)
        assert np.allclose(quat_to_euler(q), rpy)


def test_euler_of_a_stack_of_quaternions_is_each_ones_euler():
    """The vectorised path (a trajectory's ``state[:, 3:7]``) reads the same angles as one at a time,
    unnormalised quaternions and the gimbal-lock clip included."""
    rng = np.random.default_rng(5)
    Q = rng.standard_normal((200, 4)) * [1.0, 0.4, 0.4, 1.0]
    Q[0] = [1.0, 0.0, 1.0, 0.0]  # θ = −90°: R₃₁ at the clip
    each = np.array([quat_to_euler(q) for q in Q])
    assert np.allclose(quat_to_euler(Q), each, rtol=0, atol=1e-12)
    rpy = rng.uniform([-3, -1.4, -3], [3, 1.4, 3], (50, 3))
    assert np.allclose(quat_to_euler(np.array([euler_to_quat(*a) for a in rpy])), rpy, atol=1e-12)


# --------------------------------------------------------------------------- energy
def test_kinetic_energy_conserved_without_damping_restoring_and_thrust():
    """Kirchhoff form: νᵀ(C_RB + C_A)ν = 0, so ½νᵀMν is a constant of the motion."""
    params = coupled_params(linear_damping=[0] * 6, quadratic_damping=[0] * 6, weight=0.0,
                            buoyancy=0.0)
    p = params.to_array()
    x0 = make_state((0, 0, 0), (0.2, -0.1, 0.5), (0.8, -0.3, 0.2, 1.5, -2.0, 2.5))
    E0 = params.kinetic_energy(x0[7:])
    x = rk4(x0, np.zeros(6), p, 0.002, 5000)  # 10 s, tumbling
    E = params.kinetic_energy(x[7:])
    assert abs(E - E0) / E0 < 1e-8
    assert abs(np.linalg.norm(x[3:7]) - 1.0) < 1e-9  # γ = 1 keeps the norm without help
    assert np.max(np.abs(x[7:] - x0[7:])) > 0.1  # it did move


def test_quaternion_norm_with_explicit_normalisation_and_without_gain():
    params = coupled_params(quaternion_gain=0.0)
    p = params.to_array()
    x0 = make_state((0, 0, 0), (0, 0, 0), (0, 0, 0, 3.0, -2.0, 4.0))
    x = rk4(x0, np.zeros(6), p, 0.05, 200, normalise=True)
    assert np.linalg.norm(x[3:7]) == pytest.approx(1.0, abs=1e-15)
    assert x[3] >= 0


def test_coriolis_matrices_are_skew_symmetric():
    rng = np.random.default_rng(3)
    params = coupled_params()
    for M in (params.M_RB, params.M_A):
        for _ in range(5):
            C = coriolis_from_mass(M, rng.normal(size=6))
            assert np.allclose(C, -C.T)
    # the compiled RHS does no work: νᵀ M ν̇ = 0 without damping, restoring and thrust
    free = coupled_params(linear_damping=[0] * 6, quadratic_damping=[0] * 6, weight=0.0,
                          buoyancy=0.0)
    p = free.to_array()
    for _ in range(5):
        x = make_state(rng.normal(size=3), rng.normal(size=3), rng.normal(size=6))
        dnu = vehicle_rhs(x, np.zeros(6), p)[7:]
        assert abs(x[7:] @ free.mass_matrix @ dnu) < 1e-10


def test_rigid_body_mass_matrix_parallel_axis():
    M = rigid_body_mass_matrix(10.0, np.diag([1.0, 2.0, 3.0]), [0.0, 0.0, 0.1])
    assert np.allclose(M, M.T)
    assert M[3, 3] == pytest.approx(1.0 + 10 * 0.01) and M[5, 5] == pytest.approx(3.0)
    assert M[0, 4] == pytest.approx(10 * 0.1)  # −m S(r_g): surge ↔ pitch coupling


# --------------------------------------------------------------------------- restoring
@pytest.mark.parametrize("axis", [3, 4])
def test_cb_above_cg_rights_the_vehicle(axis):
    params = make_params(20.0, [0.5, 0.5, 0.5], r_g=(0, 0, 0.05), r_b=(0, 0, -0.05),
                         weight=196.0, buoyancy=196.0, linear_damping=[5] * 6)
    p = params.to_array()
    rpy = [0.0, 0.0, 0.0]
    rpy[axis - 3] = 0.3
    acc = vehicle_rhs(make_state(rpy=rpy), np.zeros(6), p)[7:]
    f = np.zeros(6)
    f[axis] = -196.0 * 0.1 * math.sin(0.3)  # −W·BG·sin(tilt)
    assert np.allclose(acc, np.linalg.solve(params.mass_matrix, f), rtol=1e-12, atol=1e-14)
    assert acc[axis] < 0
    upright = vehicle_rhs(make_state(), np.zeros(6), p)
    assert np.allclose(upright[7:], 0.0)
    # CB below CG: the same tilt grows
    flipped = make_params(20.0, [0.5, 0.5, 0.5], r_g=(0, 0, -0.05), r_b=(0, 0, 0.05),
                          weight=196.0, buoyancy=196.0).to_array()
    assert vehicle_rhs(make_state(rpy=rpy), np.zeros(6), flipped)[7 + axis] > 0
    # and a damped roll settles back upright
    x = rk4(make_state(rpy=rpy), np.zeros(6), p, 0.01, 3000)
    assert np.allclose(quat_to_euler(x[3:7]), 0.0, atol=1e-3)


def test_restoring_forces_match_fossen_eq_4_6():
    W, B, zg, zb = 100.0, 110.0, 0.05, -0.02
    phi, theta = 0.2, -0.3
    g = restoring_forces(W, B, [0, 0, zg], [0, 0, zb], euler_to_rotmat(phi, theta, 0.7))
    c, s = math.cos, math.sin
    expected = [(W - B) * s(theta), -(W - B) * c(theta) * s(phi), -(W - B) * c(theta) * c(phi),
                (zg * W - zb * B) * c(theta) * s(phi), (zg * W - zb * B) * s(theta), 0.0]
    assert np.allclose(g, expected)


# --------------------------------------------------------------------------- buoyancy, current
def test_positive_buoyancy_gives_the_steady_rise_speed():
    kL, kQ, dB = 5.18, 36.99, 2.0
    params = make_params(11.5, [0.16] * 3, weight=112.8, buoyancy=112.8 + dB,
                         added_mass=[5.5, 12.7, 14.57, 0.12, 0.12, 0.12],
                         linear_damping=[4.03, 6.22, kL, 0.07, 0.07, 0.07],
                         quadratic_damping=[18.18, 21.66, kQ, 1.55, 1.55, 1.55])
    x = rk4(make_state(position=(0, 0, 10)), np.zeros(6), params.to_array(), 0.02, 2000)
    w_ss = steady_speed(kL, kQ, -dB)
    assert w_ss < 0  # rises (z down)
    assert x[9] == pytest.approx(w_ss, rel=1e-6)
    assert x[2] < 10 and np.allclose(x[[7, 8, 10, 11, 12]], 0, atol=1e-12)


def test_current_enters_as_relative_velocity():
    vc = np.array([0.4, -0.3, 0.0])
    params = make_params(11.5, [0.16] * 3, weight=112.8, buoyancy=112.8,
                         added_mass=[5.5, 12.7, 14.57, 0.12, 0.12, 0.12],
                         linear_damping=[4.03, 6.22, 5.18, 0.07, 0.07, 0.07],
                         quadratic_damping=[18.18, 21.66, 36.99, 1.55, 1.55, 1.55], current=vc)
    p = params.to_array()
    assert np.allclose(p[P_VC:P_VC + 3], vc)
    yaw = 1.0
    x0 = make_state(rpy=(0, 0, yaw))
    R = euler_to_rotmat(0, 0, yaw)
    # at rest the water drags the vehicle along the current, ν_r = −[Rᵀv_c; 0]; with unequal
    # surge and sway added mass C_A(ν_r)ν_r adds the Munk yaw moment (A_u − A_v) u_r v_r
    nu_r = -np.concatenate([R.T @ vc, np.zeros(3)])
    f = -(params.linear_damping @ nu_r + params.quadratic_damping @ (np.abs(nu_r) * nu_r))
    f[5] += (5.5 - 12.7) * nu_r[0] * nu_r[1]
    assert np.allclose(vehicle_rhs(x0, np.zeros(6), p)[7:], np.linalg.solve(params.mass_matrix, f))
    # moving with the water: no force
    x1 = make_state(rpy=(0, 0, yaw), nu=np.concatenate([R.T @ vc, np.zeros(3)]))
    assert np.allclose(vehicle_rhs(x1, np.zeros(6), p)[7:], 0.0, atol=1e-14)
    # it ends up drifting with the current (ground velocity = v_c, relative velocity 0)
    x = rk4(x0, np.zeros(6), p, 0.02, 3000)
    assert np.allclose(quat_to_rotmat(x[3:7]) @ x[7:10], vc, atol=1e-6)


def test_spinning_body_drifts_with_the_current():
    """A neutrally buoyant body carried by a uniform current keeps the current's ground velocity
    while it spins; this needs the M_A ν̇_c term of the added mass in the mass matrix."""
    vc = np.array([0.5, 0.2, 0.0])
    params = make_params(11.5, [0.16] * 3, weight=112.8, buoyancy=112.8,
                         added_mass=[5.5, 12.7, 14.57, 0.12, 0.12, 0.12],
                         linear_damping=[4.03, 6.22, 5.18, 0.07, 0.07, 0.07], current=vc)
    p = params.to_array()
    yaw, r = 0.4, 1.3
    R = euler_to_rotmat(0, 0, yaw)
    x = make_state(rpy=(0, 0, yaw), nu=np.concatenate([R.T @ vc, [0, 0, r]]))
    dx = vehicle_rhs(x, np.zeros(6), p)
    # d/dt (R ν₁) = R (ω × ν₁ + ν̇₁) = 0
    assert np.allclose(R @ (np.cross([0, 0, r], x[7:10]) + dx[7:10]), 0.0, atol=1e-12)
    x = rk4(x, np.zeros(6), p, 0.01, 500)
    assert np.allclose(quat_to_rotmat(x[3:7]) @ x[7:10], vc, atol=1e-9)


# --------------------------------------------------------------------------- validation
def test_params_reject_negative_damping_and_asymmetric_added_mass():
    with pytest.raises(ParameterError, match="positive magnitudes"):
        make_params(10.0, [1, 1, 1], buoyancy=98.0, linear_damping=[-4.03, 6, 5, 0, 0, 0])
    A = np.eye(6)
    A[0, 4] = 1.0
    with pytest.raises(ParameterError, match="symmetric"):
        make_params(10.0, [1, 1, 1], buoyancy=98.0, added_mass=A)
    assert np.allclose(from_fossen_derivatives([-4.03, -6.22]), [4.03, 6.22])


# --------------------------------------------------------------------------- Caccia eq. 3
def test_one_dof_model_steady_state_and_compiled_form():
    m = OneDofModel(mass=890.0, linear=46.9, quadratic=306.2, eta_pos=1.0, eta_neg=0.89)
    for phi in (35.0, -35.0, 80.0):
        u = m.steady_speed(phi)
        assert one_dof_rhs(u, phi, m) == pytest.approx(0.0, abs=1e-12)
        assert one_dof_rhs_compiled(0.1, phi, m.to_array()) == pytest.approx(
            float(one_dof_rhs(0.1, phi, m)))
    assert m.steady_speed(-35.0) == pytest.approx(-m.steady_speed(0.89 * 35.0))


def test_caccia_inertia_experiment_phase_lags():
    """§IV-D: yaw I = 84, k_L = 28.6, period 24 s → 37.6°; surge m = 890, k_L = 212.25 (at
    0.27 m/s), period 26 s → 45.4° (the paper prints ≈37.5° and ≈45°)."""
    yaw = OneDofModel(mass=84.0, linear=28.6)
    assert math.degrees(math.atan(2 * math.pi / 24 * yaw.time_constant())) == pytest.approx(
        37.6, abs=0.05)
    surge = OneDofModel(mass=890.0, linear=46.9, quadratic=306.2)
    assert 46.9 + 2 * 306.2 * 0.27 == pytest.approx(212.25, abs=0.1)
    tc = surge.time_constant(0.27)
    assert math.degrees(math.atan(2 * math.pi / 26 * tc)) == pytest.approx(45.4, abs=0.1)
