"""LQR with integral action (LQI) on the linearised vehicle, as a controller block.

``f = clip(f₀ − K [ξ; ∫e])`` on the 12-state deviation ``ξ`` of :mod:`uuvid.vehicle.linearize`
(``f₀`` the trim thrust) and the integral of the position and yaw deviations
``e = [δn, δe, δd, α_z]``; ``K`` minimises ``∫ ξᵀQξ + δfᵀRδf`` for the augmented linear model
(continuous algebraic Riccati equation; python-control's ``lqr`` gives the same ``K``).  The
integrators stop while a thruster is clipped (anti-windup).  :func:`lqr` builds the mission-loop
block; :mod:`uuvid.simulate.station_keeping` flies it against the PID DP.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from uuvid.simulate.control.blocks import Controller
from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.linearize import LinearModel, OperatingPoint, linearize

#: Deviations integrated by the LQI: indices into the 12-state ξ (δn, δe, δd, α_z).
INTEGRATED = (0, 1, 2, 5)


@njit(cache=True)
def deviation_into(x0, z, xi):
    """12-state deviation of ``z`` from ``x0`` (compiled :func:`uuvid.vehicle.linearize.
    deviation_from_state`): ``α = 2 vec(q₀* ⊗ q)`` with ``η_e ≥ 0``."""
    a0, a1, a2, a3 = x0[3], -x0[4], -x0[5], -x0[6]
    b0, b1, b2, b3 = z[3], z[4], z[5], z[6]
    e0 = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    e1 = a0 * b1 + b0 * a1 + a2 * b3 - a3 * b2
    e2 = a0 * b2 + b0 * a2 + a3 * b1 - a1 * b3
    e3 = a0 * b3 + b0 * a3 + a1 * b2 - a2 * b1
    s = 2.0 if e0 >= 0.0 else -2.0
    for i in range(3):
        xi[i] = z[i] - x0[i]
    xi[3] = s * e1
    xi[4] = s * e2
    xi[5] = s * e3
    for i in range(6):
        xi[6 + i] = z[7 + i] - x0[7 + i]


@njit(cache=True)
def lqi_step(K, f0, lo, hi, xi, integ, dt, f):
    """``f = clip(f₀ − K [ξ; ∫e], lower, upper)`` with the integrators ``integ`` (4) put in
    ``xi[12:16]``; they then advance by ``e dt`` unless a thruster was clipped (anti-windup)."""
    n = f.size
    for j in range(4):
        xi[12 + j] = integ[j]
    clipped = False
    for i in range(n):
        s = f0[i]
        for j in range(16):
            s -= K[i, j] * xi[j]
        if s > hi[i]:
            s = hi[i]
            clipped = True
        elif s < lo[i]:
            s = lo[i]
            clipped = True
        f[i] = s
    if not clipped:
        for j in range(4):
            integ[j] += xi[INTEGRATED[j]] * dt


# ---------------------------------------------------------------------------------------------
# LQR design
# ---------------------------------------------------------------------------------------------
def augment_integral(lin: LinearModel) -> tuple[np.ndarray, np.ndarray]:
    """``(A_aug, B_aug)`` with the integrals of ``[δn, δe, δd, α_z]`` appended (16 states)."""
    A = np.zeros((16, 16))
    A[:12, :12] = lin.A
    for j, i in enumerate(INTEGRATED):
        A[12 + j, i] = 1.0
    B = np.zeros((16, lin.B.shape[1]))
    B[:12] = lin.B
    return A, B


def default_weights(lin: LinearModel, *, position: float = 0.1, yaw: float = 0.1,
                    tilt: float = 0.5, speed: float = 0.5, rate: float = 1.0,
                    integral: float = 0.5, thrust: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """Bryson's rule ``Q = diag(1/x_max²)``, ``R = diag(1/f_max²)`` for the augmented model
    (``x_max``: acceptable position error m, yaw/tilt rad, speed m/s, rate rad/s, integral m·s;
    ``f_max = thrust`` N per thruster)."""
    xmax = np.array([position] * 3 + [tilt, tilt, yaw] + [speed] * 3 + [rate] * 3
                    + [integral] * 4, dtype=float)
    return np.diag(1.0 / xmax**2), np.eye(lin.B.shape[1]) / thrust**2


def lqr_gain(A, B, Q, R) -> np.ndarray:
    """``K = R⁻¹ Bᵀ S`` with ``S`` from the continuous algebraic Riccati equation
    ``AᵀS + SA − SBR⁻¹BᵀS + Q = 0`` (scipy; equals ``control.lqr(A, B, Q, R)[0]``)."""
    from scipy.linalg import solve_continuous_are

    S = solve_continuous_are(A, B, Q, R)
    return np.linalg.solve(R, B.T @ S)


# ---------------------------------------------------------------------------------------------
# The LQI as a controller block of the mission loop
# ---------------------------------------------------------------------------------------------
#: Length of :func:`lqr_controller`'s state: the 4 integrators, then scratch (reference state 13,
#: vehicle state 13, augmented deviation 16).
LQR_STATE_SIZE = 4 + 13 + 13 + 16


@njit(cache=True)
def lqr_controller(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    """The LQI of :func:`compare_station_keeping` tracking a mission, as a
    :class:`~uuvid.simulate.control.blocks.Controller` with ``output="thrust"``:
    ``f = clip(f₀ − K [ξ; ∫e])``, ``ξ`` the 12-state deviation from the reference state
    ``x_r`` = (``ref_pos``, level at ``ref_yaw``, body velocity ``R_z(ψ_r)ᵀ v_ref``, yaw rate
    ``ref_rate``) with the position deviation turned into the reference heading's frame (the
    model linearised at heading 0 is the same at any heading); the integrators stop while a
    thruster is clipped.  ``params`` = [K (n × 16), f₀ (n), lower (n), upper (n)]."""
    n = tau_out.size
    K = params[0:16 * n].reshape(n, 16)
    f0 = params[16 * n:17 * n]
    lo = params[17 * n:18 * n]
    hi = params[18 * n:19 * n]
    xr = state[4:17]
    z = state[17:30]
    xi = state[30:46]
    cy = math.cos(ref_yaw)
    sy = math.sin(ref_yaw)
    for i in range(3):
        xr[i] = ref_pos[i]
    xr[3] = math.cos(0.5 * ref_yaw)
    xr[4] = 0.0
    xr[5] = 0.0
    xr[6] = math.sin(0.5 * ref_yaw)
    xr[7] = cy * ref_vel[0] + sy * ref_vel[1]
    xr[8] = -sy * ref_vel[0] + cy * ref_vel[1]
    xr[9] = ref_vel[2]
    xr[10] = 0.0
    xr[11] = 0.0
    xr[12] = ref_rate
    for i in range(7):
        z[i] = eta[i]
    for i in range(6):
        z[7 + i] = nu[i]
    deviation_into(xr, z, xi)
    dn = xi[0]
    de = xi[1]
    xi[0] = cy * dn + sy * de
    xi[1] = -sy * dn + cy * de
    lqi_step(K, f0, lo, hi, xi, state[0:4], dt, tau_out)


def lqr(vehicle, *, weights=None, **bryson):
    """The LQI designed on ``vehicle`` linearised at hover (:func:`uuvid.vehicle.linearize.
    linearize`, :func:`augment_integral`, :func:`lqr_gain`) as a mission-loop controller
    (:func:`lqr_controller`, per-thruster thrust).  ``weights`` = ``(Q, R)`` for the 16-state
    augmented model, else Bryson's rule :func:`default_weights` with the keywords ``bryson``
    (``position``, ``yaw``, ``tilt``, ``speed``, ``rate``, ``integral``, ``thrust``)."""
    v = load_vehicle(vehicle) if isinstance(vehicle, str) else vehicle
    lin = linearize(v, OperatingPoint.hover(v))
    Aa, Ba = augment_integral(lin)
    Q, R = weights if weights is not None else default_weights(lin, **bryson)
    K = lqr_gain(Aa, Ba, Q, R)
    lim = v.layout.limits
    f0 = np.zeros(K.shape[0]) if lin.thrust0 is None else lin.thrust0
    return Controller(lqr_controller, np.concatenate([K.ravel(), f0, lim[:, 0], lim[:, 1]]),
                      np.zeros(LQR_STATE_SIZE), "LQI (hover design)", "thrust")
