"""Inflow-dependent thrust (issue 21): advance speed, four-quadrant map, Healey's full form."""

import math

import numpy as np
import pytest

from uuvid.thruster.blocks import HealeyThruster, ParameterError
from uuvid.thruster.inflow import (
    RHO_FRESH,
    BladeElement,
    advance_speeds,
    axial_flow_rate,
    linear_healey_steady,
    map_thrust_torque_nb,
    t200_inflow,
    wageningen_b4_70,
    wageningen_b4_70_approx,
)

D = 0.076
MAP = wageningen_b4_70_approx(D)
# the quadrant and energy checks run on the published table and on the approximation alike
MAPS = pytest.mark.parametrize("fq", [wageningen_b4_70(D), MAP], ids=["published", "approx"])


# ------------------------------------------------------------------ advance speed
def test_advance_speed_against_cross_product():
    rng = np.random.default_rng(3)
    P = rng.normal(size=(5, 3)) * 0.2
    A = rng.normal(size=(5, 3))
    w = rng.uniform(0, 0.4, 5)
    nu = rng.normal(size=6)
    got = advance_speeds(nu, P, A, w)
    a = A / np.linalg.norm(A, axis=1)[:, None]
    want = [(1 - w[i]) * a[i] @ (nu[:3] + np.cross(nu[3:], P[i])) for i in range(5)]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)


def test_advance_speed_yaw_rate_sign():
    # yaw rate r > 0 (clockwise seen from above, z down): a point at y = +0.1 moves backwards
    ua = advance_speeds([0, 0, 0, 0, 0, 1.0], [[0.0, 0.1, 0.0]], [[1.0, 0, 0]])
    assert ua[0] == pytest.approx(-0.1)


def test_advance_speed_bad_input_names_field():
    with pytest.raises(ParameterError, match="wake"):
        advance_speeds(np.zeros(6), [[0, 0, 0]], [[1, 0, 0]], [1.0])
    with pytest.raises(ValueError, match="nu_r"):
        advance_speeds(np.zeros(3), [[0, 0, 0]], [[1, 0, 0]])
    with pytest.raises(ValueError, match="axis"):
        advance_speeds(np.zeros(6), [[0, 0, 0]], [[0, 0, 0]])


# ------------------------------------------------------------------ zero advance = bollard
@pytest.mark.parametrize("n", [-60.0, -3.0, 2.5, 58.0])
def test_map_at_zero_advance_is_the_bollard_square_law(n):
    T, _ = MAP.thrust_torque(n, 0.0)
    kt = abs(MAP.bollard_kt(1 if n > 0 else -1))  # today: T = k_t Ω|Ω|, k_t > 0 per direction
    assert float(T) == pytest.approx(kt * RHO_FRESH * n * abs(n) * D ** 4, rel=1e-12, abs=0)
    assert float(MAP.thrust_ratio(n, 0.0)) == pytest.approx(1.0, rel=1e-12, abs=0)


@pytest.mark.slow
def test_healey_axial_flow_at_zero_advance_equals_todays_kernel():
    from uuvid.thruster.kernels import _healey

    blk = HealeyThruster()
    p = blk.params_array()
    for w, up, V in [(300.0, 1.2, 10.0), (-250.0, -0.7, -8.0), (120.0, -0.3, 3.0)]:
        dx, ch = np.zeros(2), np.zeros(8)
        thrust = _healey(p, 0, np.array([w, up]), 0, V, dx, ch)
        new = axial_flow_rate(thrust, up, 0.0, blk.fluid_mass, blk.flow_damping)
        assert float(new) == pytest.approx(dx[1], rel=1e-12, abs=1e-15)


def test_linear_healey_steady_at_zero_advance_is_todays_closed_form():
    blk = HealeyThruster()
    kt, ka, df = blk.thrust_coefficient, blk.inflow_coefficient, blk.flow_damping
    for w in (50.0, 300.0):
        # today's steady state: k_t Ω² − k_a Ω u = d_f u²
        up = (-ka * w + math.sqrt((ka * w) ** 2 + 4 * df * kt * w * w)) / (2 * df)
        s = linear_healey_steady(blk, w, 0.0)
        assert s["up"] == pytest.approx(up, rel=1e-12)
        assert s["thrust"] == pytest.approx(df * up * up, rel=1e-11)


# ------------------------------------------------------------------ momentum theory
def _actuator_disc(area):
    """A blade-element thruster whose flow damping is the actuator disc's 2ρA."""
    return BladeElement(pitch=0.43, radius=math.sqrt(area / math.pi), blade_area=0.3 * area,
                        cl_max=1.0, cd_max=0.8, fluid_mass=1.0, flow_damping=2 * RHO_FRESH * area)


def test_axial_flow_steady_state_obeys_froude_momentum_theory():
    A = math.pi * 0.038 ** 2
    be = _actuator_disc(A)
    for ua in (0.0, 0.5, 1.5):
        s = be.steady(300.0, ua)
        T, up = s["thrust"], s["up"]
        assert T > 0
        # actuator disc: induced speed from T = 2ρA u_p (u_p − u_a)
        want = (ua + math.sqrt(ua * ua + 2 * T / (RHO_FRESH * A))) / 2
        assert up == pytest.approx(want, rel=1e-9)
        if ua > 0:  # ideal (Froude) efficiency
            cth = T / (0.5 * RHO_FRESH * A * ua * ua)
            assert ua / up == pytest.approx(2 / (1 + math.sqrt(1 + cth)), rel=1e-9)


def test_thrust_falls_with_advance_and_vanishes_near_pitch_speed():
    be = _actuator_disc(math.pi * 0.038 ** 2)
    w = 300.0
    T = [be.steady(w, ua)["thrust"] for ua in (0.0, 0.5, 1.0, 2.0)]
    assert all(a > b for a, b in zip(T, T[1:]))
    # blade at zero lift: the flow at 0.7R meets the blade along its pitch → u ≈ 0.7RΩ tan p
    u_pitch = 0.7 * be.radius * w * math.tan(be.pitch)
    assert be.steady(w, 1.05 * u_pitch)["thrust"] < 0 < be.steady(w, 0.8 * u_pitch)["thrust"]


@MAPS
def test_map_efficiency_within_froude_ideal_efficiency(fq):
    J = np.linspace(0.05, 1.0, 40)
    kt, kq = fq.kt_kq(J)
    keep = kt > 0
    eta = J[keep] * kt[keep] / (2 * np.pi * kq[keep])
    cth = 8 * kt[keep] / (np.pi * J[keep] ** 2)
    assert np.all(eta <= 2 / (1 + np.sqrt(1 + cth)))


def test_full_healey_reduces_to_the_linear_form_at_small_angles():
    be = BladeElement(pitch=0.01, radius=0.04, blade_area=1e-3, cl_max=1.2, cd_max=0.0,
                      fluid_mass=1.0, flow_damping=4.5)
    kt, ka = be.linear_coefficients()
    w = 300.0
    up = 0.002 * 0.7 * be.radius * w
    T, _ = be.forces(w, up)
    lin = kt * w * w - ka * w * up
    assert float(T) == pytest.approx(lin, rel=1e-3)
    # and the error grows with the angle (the linear form is only the small-angle limit)
    be2 = BladeElement(pitch=0.4, radius=0.04, blade_area=1e-3, cl_max=1.2, cd_max=0.0,
                       fluid_mass=1.0, flow_damping=4.5)
    kt2, ka2 = be2.linear_coefficients()
    assert abs(float(be2.forces(w, 0.0)[0]) / (kt2 * w * w) - 1) > 1e-2


# ------------------------------------------------------------------ quadrants
@MAPS
def test_map_continuous_across_quadrant_boundaries(fq):
    eps = 1e-7
    for u in (-2.0, -0.3, 0.4, 1.5):  # n crosses zero at fixed advance
        a = np.array(fq.thrust_torque(-eps, u))
        b = np.array(fq.thrust_torque(eps, u))
        assert np.all(np.abs(a - b) < 1e-5)
    for n in (-40.0, -5.0, 7.0, 55.0):  # advance crosses zero at fixed shaft speed
        a = np.array(fq.thrust_torque(n, -eps))
        b = np.array(fq.thrust_torque(n, eps))
        assert np.all(np.abs(a - b) < 1e-5)
    # β = ±π is the same point of the circle
    assert float(fq.ct(np.pi)) == pytest.approx(float(fq.ct(-np.pi)), abs=1e-12)


@MAPS
def test_map_signs_per_quadrant(fq):
    n = 50.0
    assert fq.thrust_torque(n, 0.0)[0] > 0 > fq.thrust_torque(-n, 0.0)[0]
    # locked shaft in a flow from ahead: drag, thrust negative; from astern: positive
    assert fq.thrust_torque(0.0, 1.0)[0] < 0 < fq.thrust_torque(0.0, -1.0)[0]
    # astern weaker than ahead at the same |n| (published table: K_T0 0.347 vs 0.445;
    # a labelled assumption of the approximation)
    assert abs(fq.thrust_torque(-n, 0.0)[0]) < fq.thrust_torque(n, 0.0)[0]


@pytest.mark.slow
@MAPS
def test_compiled_map_equals_numpy(fq):
    a = [np.asarray(c) for c in (fq.ct_a, fq.ct_b, fq.cq_a, fq.cq_b)]
    for n, u in [(40.0, 0.7), (-30.0, 1.2), (0.0, -0.5), (12.0, -2.0)]:
        T, Q = fq.thrust_torque(n, u)
        Tn, Qn = map_thrust_torque_nb(*a, D, RHO_FRESH, n, u)
        assert Tn == pytest.approx(float(T), rel=1e-12, abs=1e-12)
        assert Qn == pytest.approx(float(Q), rel=1e-12, abs=1e-12)


# ------------------------------------------------------------------ energy
@MAPS
def test_shaft_power_exceeds_thrust_power_in_propelling_quadrants(fq):
    n = np.linspace(5, 60, 12)[:, None]
    ua = np.linspace(0, 3, 31)[None, :]
    for s in (1, -1):  # ahead (n > 0, u_a ≥ 0) and astern (n < 0, u_a ≤ 0)
        T, Q = fq.thrust_torque(s * n, s * ua)
        prop = T * s > 0
        assert prop.sum() > 50
        assert np.all((2 * np.pi * s * n * Q)[prop] >= (T * s * ua)[prop])
    be = _actuator_disc(math.pi * 0.038 ** 2)
    for ua_ in (0.0, 0.5, 1.0, 2.0):
        st = be.steady(300.0, ua_)
        if st["thrust"] > 0:
            assert st["torque"] * 300.0 >= st["thrust"] * ua_


# ------------------------------------------------------------------ T200 coefficients
def test_t200_pitch_and_diameter_are_consistent_with_its_sheet():
    from uuvid.thruster.presets import T200_FULL_SPEED, T200_MAX_THRUST_N, T200_STEADY

    t = t200_inflow()
    kt_nd = T200_STEADY.kt_fwd * (2 * np.pi) ** 2 / (RHO_FRESH * t.diameter ** 4)
    assert kt_nd == pytest.approx(t.map.bollard_kt(1), rel=0.03)  # published B4-70 P/D 1.0
    n = t.map.shaft_speed_for(T200_MAX_THRUST_N[0]) * 2 * np.pi
    assert n == pytest.approx(T200_FULL_SPEED, rel=0.02)
    # pitch angle at 0.7 R from P/D
    assert math.tan(t.pitch_angle) == pytest.approx(t.pitch_ratio / (0.7 * math.pi))
    assert t.inflow_coefficient > 0


# ------------------------------------------------------------------ compiled pieces for a loop
@pytest.mark.slow
@MAPS
def test_inflow_thrust_kernel_is_bollard_at_zero_advance_and_the_map_elsewhere(fq):
    from uuvid.thruster.inflow import inflow_params, inflow_thrust_nb

    prm = inflow_params(fq)
    for f in (51.485, 12.0, -39.913, -3.0, 0.0):
        assert inflow_thrust_nb(f, 0.0, prm) == f  # bit for bit: the bollard model
        n = fq.shaft_speed_for(f) if f else 0.0
        for ua in (-1.2, -0.3, 0.4, 1.5):
            want = float(fq.thrust_torque(n, ua)[0])
            # the series read from its cubic table (ct_table: < 1e-11 of C_T*, checked below)
            assert inflow_thrust_nb(f, ua, prm) == pytest.approx(want, rel=1e-9, abs=1e-12)
        # continuous as the advance speed goes to zero
        assert inflow_thrust_nb(f, 1e-9, prm) == pytest.approx(f, rel=1e-6, abs=1e-9)
        # a diverged state (NaN or infinite advance speed) gives NaN, not a number from
        # somewhere else (the table index is clamped: int(NaN) is undefined)
        for bad in (math.nan, math.inf, -math.inf):
            assert math.isnan(inflow_thrust_nb(f, bad, prm))
    assert math.isnan(inflow_thrust_nb(math.nan, 0.5, prm))


@MAPS
def test_the_loops_ct_table_is_the_series(fq):
    """The cubic table the loops read (values and slopes of the series at its nodes) against the
    Fourier series itself, everywhere on the circle, nodes and midpoints included."""
    from uuvid.thruster.inflow import INFLOW_TABLE_INTERVALS, ct_table, diamond_angle

    N = INFLOW_TABLE_INTERVALS
    T = ct_table(fq)
    assert T.shape == (N, 4)
    b = np.linspace(-np.pi, np.pi, 8 * N + 1)
    x = (diamond_angle(np.sin(b), np.cos(b)) + 2.0) * N / 4
    j = np.minimum(x.astype(int), N - 1)
    t = x - j
    c = T[j]
    got = c[:, 0] + t * (c[:, 1] + t * (c[:, 2] + t * c[:, 3]))
    assert np.max(np.abs(got - fq.ct(b))) < 1e-11 * np.max(np.abs(fq.ct(b)))
    # continuous across every node (value and slope): the pieces join
    end = T.sum(axis=1)
    assert np.max(np.abs(end[:-1] - T[1:, 0])) < 1e-14
    slope_end = T[:, 1] + 2 * T[:, 2] + 3 * T[:, 3]
    assert np.max(np.abs(slope_end[:-1] - T[1:, 1])) < 1e-14


def test_the_diamond_angle_is_monotone_in_beta_and_inverts():
    """The loops' table coordinate: p(β) rises with β over the circle, hits ±1 at ±π/2 and ±2 at
    ±π, and diamond_to_beta inverts it with the right slope (finite differences)."""
    from uuvid.thruster.inflow import diamond_angle, diamond_to_beta

    b = np.linspace(-np.pi + 1e-9, np.pi - 1e-9, 20001)
    p = diamond_angle(3.0 * np.sin(b), 3.0 * np.cos(b))  # any radius
    assert np.all(np.diff(p) > 0) and p[0] == pytest.approx(-2) and p[-1] == pytest.approx(2)
    assert diamond_angle(1.0, 0.0) == 1.0 and diamond_angle(-2.0, 0.0) == -1.0
    assert diamond_angle(0.5, 0.5) == 0.5 and diamond_angle(0.5, -0.5) == 1.5
    beta, slope = diamond_to_beta(p)
    assert np.allclose(beta, b, atol=1e-12)
    h = 1e-6
    for q in (-1.7, -0.6, 0.0, 0.3, 1.2):
        fd = (diamond_to_beta(q + h)[0] - diamond_to_beta(q - h)[0]) / (2 * h)
        assert float(diamond_to_beta(q)[1]) == pytest.approx(float(fd), rel=1e-5)


@pytest.mark.slow
def test_state_advance_speeds_match_the_geometric_form():
    from uuvid.vehicle.inflow import geometry_rows, state_advance_speeds_nb
    from uuvid.vehicle.kinematics import quat_to_rotmat

    rng = np.random.default_rng(7)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    x = np.r_[rng.normal(size=3), q, rng.normal(size=6)]
    vc = rng.normal(size=3) * 0.3
    P = rng.normal(size=(4, 3)) * 0.2
    A = rng.normal(size=(4, 3))
    A /= np.linalg.norm(A, axis=1)[:, None]
    w = rng.uniform(0, 0.3, 4)
    got = state_advance_speeds_nb(x, vc, geometry_rows(P, A, w), np.empty(4))
    nu_r = x[7:13].copy()
    nu_r[:3] -= quat_to_rotmat(q).T @ vc
    np.testing.assert_allclose(got, advance_speeds(nu_r, P, A, w), rtol=0, atol=1e-13)


def test_a_geometry_without_the_advance_speed_row_is_refused_not_read_past_its_end():
    """A hand-built 7-column geometry (before the advance speed's row was added) was read past
    its end in still water (a wrong trajectory, no error) and gave tracebacks elsewhere."""
    import dataclasses

    import yaml

    from uuvid.simulate.batch import perturb_batch, run_batch_fast
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
    from uuvid.vehicle.definition import preset_path, vehicle_from_dict

    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    raw["inflow"] = "four-quadrant"
    s = setup_mission(vehicle_from_dict(raw, where="bluerov2.yaml"), square_mission(), t_end=2.0)
    prm, geo = s.inflow_arrays
    assert geo.shape[1] == 13
    old = dataclasses.replace(s, inflow_arrays=(prm, geo[:, :7]))
    with pytest.raises(ValueError, match=r"shape \(6, 7\): expected \(thrusters, 13\)"):
        fly_mission(old)
    VP, TP, VC = perturb_batch(s, np.random.default_rng(0), 8)
    with pytest.raises(ValueError, match=r"expected \(thrusters, 13\)"):
        run_batch_fast(old, VP, TP, VC)


def test_advance_speeds_wake_is_one_per_thruster_or_one_for_all():
    """The compiled kernel reads wake[i] for every thruster: one wake for 40 thrusters read past
    the array (advance speeds of −3e299); three for two dropped one silently."""
    import numpy as np
    import pytest

    from uuvid.thruster.inflow import advance_speeds

    P = np.zeros((40, 3))
    A = np.tile([1.0, 0.0, 0.0], (40, 1))
    ua = advance_speeds([1.0, 0, 0, 0, 0, 0], P, A, wake=[0.5])
    assert np.array_equal(ua, np.full(40, 0.5))
    with pytest.raises(ValueError, match="2 wake fractions for 40 thrusters"):
        advance_speeds([1.0, 0, 0, 0, 0, 0], P, A, wake=[0.5, 0.1])
    with pytest.raises(ValueError, match="3 wake fractions for 2 thrusters"):
        advance_speeds([1.0, 0, 0, 0, 0, 0], P[:2], A[:2], wake=[0.1, 0.2, 0.3])
