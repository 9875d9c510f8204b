"""Dynamic-positioning controller: PID on surge, sway, heave and yaw with anti-windup.

Laidani et al. §5 fly their ROV with PI loops on surge, sway, heave and yaw; Caccia et al. use the
same decoupled structure.  Errors are formed in NED and rotated into the body frame,
``e_b = R(q)ᵀ (p_ref − p)``, the yaw error is wrapped to (−π, π]; the reference velocity is fed
forward through the derivative term (``ė = R(q)ᵀ v_ref − ν``).  Anti-windup by conditional
integration: the integrator stops while the output is saturated in the direction of the error,
and is clamped to ``i_limit``.

Gains can be chosen from the vehicle (:func:`gains_from_bandwidth`): for ``m ë + d ė = τ`` with
bandwidth ω and damping ζ, ``K_p = m ω²``, ``K_d = 2 ζ ω m − d``, ``K_i = K_p ω/10``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from uuvid.simulate.control.blocks import Controller
from uuvid.vehicle.kinematics import quat_to_rotmat

#: Controlled DOFs and their index in the generalized-force vector [X Y Z K M N].
DP_DOFS = (0, 1, 2, 5)


@dataclass(frozen=True)
class DPGains:
    """PID gains per controlled DOF (surge, sway, heave, yaw) and the output limits."""

    kp: tuple[float, float, float, float]
    ki: tuple[float, float, float, float]
    kd: tuple[float, float, float, float]
    tau_max: tuple[float, float, float, float]  # |generalized force| limit per DOF (N, N, N, N·m)
    i_limit: tuple[float, float, float, float] = (math.inf,) * 4  # |integral term| limit
    #: roll/pitch attitude hold (PD to level) for vehicles whose thrusters control them; 0 = off
    kp_attitude: tuple[float, float] = (0.0, 0.0)
    kd_attitude: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        for name in ("kp_attitude", "kd_attitude"):
            v = getattr(self, name)
            if len(v) != 2 or any(not (x >= 0) for x in v):
                raise ValueError(f"DPGains.{name} needs 2 values >= 0 (roll, pitch), got {v}")
        for name in ("kp", "ki", "kd", "tau_max", "i_limit"):
            v = getattr(self, name)
            if len(v) != 4:
                raise ValueError(f"DPGains.{name} needs 4 values (surge, sway, heave, yaw), got {len(v)}")
            if any(not (x >= 0) for x in v):
                raise ValueError(f"DPGains.{name} values must be >= 0, got {v}")

    def to_array(self) -> np.ndarray:
        """Rows kp, ki, kd, tau_max, i_limit and [kp_roll, kp_pitch, kd_roll, kd_pitch] (6 × 4)."""
        return np.array([self.kp, self.ki, self.kd, self.tau_max, self.i_limit,
                         self.kp_attitude + self.kd_attitude], dtype=np.float64)


def gains_from_bandwidth(mass: np.ndarray, damping: np.ndarray, tau_max, omega=(0.6, 0.6, 0.6, 0.8),
                         zeta: float = 1.0, integral_ratio: float = 0.1) -> DPGains:
    """PID gains placing each DOF's closed loop at bandwidth ω with damping ζ.

    ``mass`` and ``damping`` are the effective (rigid-body + added) mass/inertia and linear(ised)
    damping of surge, sway, heave, yaw.
    """
    m = np.asarray(mass, dtype=float)
    d = np.asarray(damping, dtype=float)
    w = np.asarray(omega, dtype=float)
    kp = m * w**2
    kd = np.maximum(2 * zeta * w * m - d, 0.0)
    ki = kp * w * integral_ratio
    tau_max = tuple(float(x) for x in tau_max)
    f = lambda a: tuple(float(x) for x in a)  # noqa: E731
    return DPGains(f(kp), f(ki), f(kd), tau_max, tuple(0.5 * t for t in tau_max))


quat_to_rot = quat_to_rotmat  # body → NED (Fossen 2011, §2.2.2)


@njit(cache=True, inline="always")
def quat_yaw(q):
    """Yaw angle ψ of a unit quaternion (ZYX convention)."""
    n, e1, e2, e3 = q[0], q[1], q[2], q[3]
    return math.atan2(2 * (n * e3 + e1 * e2), 1 - 2 * (e2 * e2 + e3 * e3))


@njit(cache=True, inline="always")
def wrap_angle(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True, inline="always")
def dp_errors(pos, q, nu, ref_pos, ref_vel, ref_yaw, ref_rate, e, edot):
    """Body-frame errors ``e`` and their rates ``edot`` for (surge, sway, heave, yaw)."""
    # R(q) (quat_to_rot) as scalars: no array per step; e = Rᵀ (p_ref − p), ė = Rᵀ v_ref − ν
    qe, qx, qy, qz = q[0], q[1], q[2], q[3]
    r00 = 1.0 - 2.0 * (qy * qy + qz * qz)
    r01 = 2.0 * (qx * qy - qz * qe)
    r02 = 2.0 * (qx * qz + qy * qe)
    r10 = 2.0 * (qx * qy + qz * qe)
    r11 = 1.0 - 2.0 * (qx * qx + qz * qz)
    r12 = 2.0 * (qy * qz - qx * qe)
    r20 = 2.0 * (qx * qz - qy * qe)
    r21 = 2.0 * (qy * qz + qx * qe)
    r22 = 1.0 - 2.0 * (qx * qx + qy * qy)
    d0 = ref_pos[0] - pos[0]
    d1 = ref_pos[1] - pos[1]
    d2 = ref_pos[2] - pos[2]
    e[0] = r00 * d0 + r10 * d1 + r20 * d2
    e[1] = r01 * d0 + r11 * d1 + r21 * d2
    e[2] = r02 * d0 + r12 * d1 + r22 * d2
    edot[0] = (r00 * ref_vel[0] + r10 * ref_vel[1] + r20 * ref_vel[2]) - nu[0]
    edot[1] = (r01 * ref_vel[0] + r11 * ref_vel[1] + r21 * ref_vel[2]) - nu[1]
    edot[2] = (r02 * ref_vel[0] + r12 * ref_vel[1] + r22 * ref_vel[2]) - nu[2]
    e[3] = wrap_angle(ref_yaw - quat_yaw(q))
    edot[3] = ref_rate - nu[5]


@njit(cache=True, inline="always")
def _attitude_hold_row(q, nu, g, tau_out):
    """:func:`attitude_hold` with its gains row ``g`` = [kp_roll, kp_pitch, kd_roll, kd_pitch]."""
    if g[0] == 0.0 and g[1] == 0.0 and g[2] == 0.0 and g[3] == 0.0:
        return
    n, e1, e2, e3 = q[0], q[1], q[2], q[3]
    roll = math.atan2(2 * (n * e1 + e2 * e3), 1 - 2 * (e1 * e1 + e2 * e2))
    s = 2 * (n * e2 - e3 * e1)
    pitch = math.asin(min(1.0, max(-1.0, s)))
    tau_out[3] = -g[0] * roll - g[2] * nu[3]
    tau_out[4] = -g[1] * pitch - g[3] * nu[4]


@njit(cache=True, inline="always")
def attitude_hold(q, nu, gains, tau_out):
    """PD to level roll and pitch (only for vehicles that can produce roll/pitch moments)."""
    _attitude_hold_row(q, nu, gains[5], tau_out)


@njit(cache=True, inline="always")
def _dp_control_rows(e, edot, integ, kpr, kir, kdr, tmr, ilr, dt, tau_out, integ_out):
    """:func:`dp_control` with the gains as five rows (kp, ki, kd, tau_max, i_limit)."""
    for k in range(6):
        tau_out[k] = 0.0
    for j in range(4):
        kp, ki, kd, tmax, ilim = kpr[j], kir[j], kdr[j], tmr[j], ilr[j]
        u_unsat = kp * e[j] + ki * integ[j] + kd * edot[j]
        saturated = abs(u_unsat) >= tmax and u_unsat * e[j] > 0
        new_i = integ[j] if saturated else integ[j] + e[j] * dt
        if ki > 0:
            lim = ilim / ki
            new_i = min(max(new_i, -lim), lim)
        integ_out[j] = new_i
        u = kp * e[j] + ki * new_i + kd * edot[j]
        u = min(max(u, -tmax), tmax)
        tau_out[DP_DOFS[j]] = u


@njit(cache=True, inline="always")
def dp_control(e, edot, integ, gains, dt, tau_out, integ_out):
    """PID with conditional-integration anti-windup; writes the 6-vector ``tau_out`` and the new
    integrator state.  ``gains`` is :meth:`DPGains.to_array` (rows kp, ki, kd, tau_max, i_limit)."""
    _dp_control_rows(e, edot, integ, gains[0], gains[1], gains[2], gains[3], gains[4], dt, tau_out,
                     integ_out)


# ---------------------------------------------------------------------------------------------
# Controllers as blocks
# ---------------------------------------------------------------------------------------------
#: Length of :func:`pid_controller`'s state: the integrator (4) and scratch for e, ė, new integrator.
PID_STATE_SIZE = 16


@njit(cache=True, inline="always")
def pid_controller(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    """The built-in DP controller in the :class:`Controller` interface: body-frame PID on surge,
    sway, heave and yaw (:func:`dp_errors`, :func:`dp_control`) plus roll/pitch hold
    (:func:`attitude_hold`).  ``params`` = ``DPGains.to_array().ravel()`` (24);
    ``state[0:4]`` the integrator, ``state[4:16]`` scratch (:data:`PID_STATE_SIZE`)."""
    # the gains read as rows of params (views), not params.reshape(6, 4): numba's reshape calls
    # out to a C helper on every step, which cost ~10 % of the whole mission step
    e = state[4:8]
    edot = state[8:12]
    integ_new = state[12:16]
    dp_errors(eta[0:3], eta[3:7], nu, ref_pos, ref_vel, ref_yaw, ref_rate, e, edot)
    _dp_control_rows(e, edot, state[0:4], params[0:4], params[4:8], params[8:12], params[12:16],
                     params[16:20], dt, tau_out, integ_new)
    _attitude_hold_row(eta[3:7], nu, params[20:24], tau_out)
    for j in range(4):
        state[j] = integ_new[j]


def pid(gains: DPGains) -> Controller:
    """The built-in PID DP controller (:func:`pid_controller`) with these gains."""
    return Controller(pid_controller, gains.to_array().ravel(), np.zeros(PID_STATE_SIZE), "PID DP")
