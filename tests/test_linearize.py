"""Linearisation: analytic Jacobians against finite differences of the independent NumPy model."""

import math

import numpy as np
import pytest

from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.linearize import (
    LinearModel,
    OperatingPoint,
    TrimError,
    deviation_from_state,
    linearize,
    quat_multiply,
    state_from_deviation,
    trim,
)
from uuvid.vehicle.model import vehicle_rhs_reference


@pytest.fixture(scope="module")
def rov():
    return load_vehicle("bluerov2")


def _fd_reference(params, lin: LinearModel, h=1e-7):
    """4th-order central differences of the chart map built here from vehicle_rhs_reference
    (NumPy, matrices term by term) — independent of the analytic Jacobian and of the compiled
    right-hand side.  Columns: states, then generalized force."""
    x0 = lin.x0
    q0c = x0[3:7] * np.array([1, -1, -1, -1])
    cur = np.asarray(lin.op.current)

    def F(xi, tau):
        eps = 0.5 * xi[3:6]
        qe = np.concatenate([[np.sqrt(1 - eps @ eps)], eps])
        x = np.concatenate([x0[:3] + xi[:3], quat_multiply(x0[3:7], qe), x0[7:] + xi[6:]])
        dx = vehicle_rhs_reference(x, tau, params, current_ned=cur)
        return np.concatenate([dx[:3], 2 * quat_multiply(q0c, dx[3:7])[1:], dx[7:]])

    J = np.zeros((12, 18))
    for j in range(18):
        e = np.zeros(18)
        e[j] = h

        def G(s):
            return F(s[:12], lin.tau0 + s[12:])

        J[:, j] = (-G(2 * e) + 8 * G(e) - 8 * G(-e) + G(-2 * e)) / (12 * h)
    return J[:, :12], J[:, 12:]


OPS = {
    "hover": lambda v: OperatingPoint.hover(v),
    "forward 0.8 m/s": lambda v: OperatingPoint.forward(v, 0.8),
    "hover in a current": lambda v: OperatingPoint.hover(v, current=(0.3, -0.15, 0.05), heading=0.7),
    "arbitrary (not an equilibrium)": lambda v: OperatingPoint(
        position=(1, 2, 3), rpy=(0.3, -0.2, 2.0), nu=(0.4, -0.3, 0.2, 0.25, -0.35, 0.5),
        current=(0.2, -0.1, 0.05), tau=np.array([5.0, -3, 2, 0.1, -0.2, 0.3])),
}


@pytest.mark.parametrize("name", list(OPS))
@pytest.mark.parametrize("vehicle", ["bluerov2", "romeo"])
def test_jacobians_match_finite_differences(name, vehicle):
    v = load_vehicle(vehicle)
    lin = linearize(v, OPS[name](v))
    A_fd, Bt_fd = _fd_reference(v.params, lin)
    assert np.abs(lin.A - A_fd).max() <= 1e-6 * np.abs(lin.A).max()
    assert np.abs(lin.B_tau - Bt_fd).max() <= 1e-6 * np.abs(lin.B_tau).max()
    # thrust inputs enter through the layout matrix
    np.testing.assert_allclose(lin.B, Bt_fd @ v.B, rtol=0, atol=1e-6 * np.abs(lin.B).max())


def test_trim_is_an_equilibrium_of_the_nonlinear_model(rov):
    for op in (OperatingPoint.hover(rov), OperatingPoint.forward(rov, 0.6),
               OperatingPoint.hover(rov, current=(0.25, 0.1, 0.0))):
        tau = rov.B @ op.thrust  # the thrusts, not just the generalized force, make it
        dx = vehicle_rhs_reference(op.state, tau, rov.params, current_ned=np.array(op.current))
        assert np.abs(dx[7:]).max() < 1e-9
        assert linearize(rov, op).is_equilibrium


def test_bluerov2_forward_trim_needs_pitch_and_hover_does_not(rov):
    # (pure body surge) the BlueROV2's horizontal thrusters sit 2 cm below CO: surge thrust pitches, and the
    # thrusters have no independent pitch authority — the restoring moment must balance it
    hover = OperatingPoint.hover(rov)
    assert np.allclose(hover.rpy, 0) and np.allclose(rov.B @ hover.thrust, [0, 0, 2.0, 0, 0, 0])
    fwd = OperatingPoint.forward(rov, 0.6, level=False)  # body surge: no heave, no Munk moment
    X = rov.B[0] @ fwd.thrust
    W = rov.params.weight
    assert X > 0 and fwd.rpy[1] > 0
    np.testing.assert_allclose(W * 0.02 * np.sin(fwd.rpy[1]) * np.cos(fwd.rpy[0]), 0.02 * X,
                               rtol=1e-6)


def test_trim_without_attitude_freedom_fails_clearly(rov):
    with pytest.raises(TrimError, match="pitch"):
        trim(rov, 0.6, free_attitude=False)


def test_chart_roundtrip_and_small_angle_meaning():
    x0 = np.concatenate([[1, 2, 3], [np.cos(0.3), 0, 0, np.sin(0.3)], np.zeros(6)])
    xi = np.array([0.1, -0.2, 0.3, 0.01, -0.02, 0.03, 1, 2, 3, 4, 5, 6])
    np.testing.assert_allclose(deviation_from_state(x0, state_from_deviation(x0, xi)), xi,
                               atol=1e-14)
    # a pure yaw deviation δψ at a level point has α = [0, 0, 2 sin(δψ/2)]
    x = x0.copy()
    x[3:7] = quat_multiply(x0[3:7], [np.cos(0.05), 0, 0, np.sin(0.05)])
    np.testing.assert_allclose(deviation_from_state(x0, x)[3:6], [0, 0, 2 * np.sin(0.05)],
                               atol=1e-15)


def test_hover_structure(rov):
    lin = linearize(rov)
    # position and yaw are neutrally stable (no restoring): four zero eigenvalues;
    # everything else decays (damping, righting moment)
    ev = lin.eigenvalues()
    assert np.sum(np.abs(ev) < 1e-9) == 4
    assert np.all(ev.real[np.abs(ev) >= 1e-9] < 0)
    assert lin.controllability_rank("thrust") == 12
    d = lin.to_dict()
    assert np.array(d["A"]).shape == (12, 12) and len(d["input_names"]) == rov.layout.n


def test_to_control(rov):
    control = pytest.importorskip("control")
    lin = linearize(rov)
    sys = lin.to_control()
    assert isinstance(sys, control.StateSpace)
    np.testing.assert_array_equal(sys.A, lin.A)
    np.testing.assert_array_equal(sys.B, lin.B)
    assert sys.input_labels == list(rov.layout.names)
    assert lin.to_control("force").B.shape == (12, 6)


def test_params_without_thrusters_linearise_in_generalized_force(rov):
    lin = linearize(rov.params, OperatingPoint.hover(rov.params))
    np.testing.assert_array_equal(lin.B, lin.B_tau)
    assert lin.thrust0 is None and lin.input_names[0] == "tau_surge"
    np.testing.assert_allclose(lin.A, linearize(rov).A, atol=1e-12)


@pytest.mark.slow
def test_forward_trim_is_level_flight_and_agrees_with_static_stability():
    """``OperatingPoint.forward`` trims the vehicle flying level (constant depth): its pitch is
    the trim of :func:`static_stability` at the same speed, and the velocity over ground is
    horizontal; ``level=False`` (pure body surge) is a different, climbing equilibrium."""
    from uuvid.vehicle.kinematics import euler_to_rotmat
    from uuvid.vehicle.stability import static_stability

    rov = load_vehicle("bluerov2")
    case = static_stability(rov)["forward"]
    k = int(np.flatnonzero(np.isfinite(case.tilt_deg["pitch"]))[-3])  # a speed below the limit
    speed = float(case.speeds[k])
    op = OperatingPoint.forward(rov, speed)
    assert math.degrees(op.rpy[1]) == pytest.approx(case.tilt_deg["pitch"][k], abs=1e-3)
    v_ned = euler_to_rotmat(*op.rpy) @ np.asarray(op.nu[:3])
    np.testing.assert_allclose(v_ned, [speed, 0.0, 0.0], atol=1e-12)
    surge = OperatingPoint.forward(rov, speed, level=False)
    assert surge.nu[2] == 0.0 and abs(surge.rpy[1] - op.rpy[1]) > 1e-3
