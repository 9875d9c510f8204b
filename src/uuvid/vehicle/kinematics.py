"""Attitude kinematics with a unit quaternion, NED world frame and FRD body frame (z down).

Fossen (2011), *Handbook of Marine Craft Hydrodynamics and Motion Control*, §2.2.2:

* ``q = [η, ε₁, ε₂, ε₃]`` (scalar first), ``qᵀq = 1``;
* ``R(q) = I₃ + 2η S(ε) + 2 S(ε)²`` rotates body vectors into NED: ``ṗⁿ = R(q) v_bⁿ``;
* ``q̇ = ½ T(q) ω``, ``T(q) = [−εᵀ; η I₃ + S(ε)]``;
* the normalisation drift of a numerical integration is removed by the stabilising term
  ``q̇ = ½ T(q) ω + ½ γ (1 − qᵀq) q`` (Fossen 2011, §2.2.2, "normalization"), ``γ ≥ 0``,
  and/or by :func:`normalise_quaternion` after each step.

The Euler angles used at the edges (files, reports) are the zyx (roll φ, pitch θ, yaw ψ)
convention, ``R = R_z(ψ) R_y(θ) R_x(φ)`` (Fossen 2011, eq. 2.18).

The quaternion functions are compiled with numba and usable from Python; the NumPy reference
forms the tests compare against are :func:`uuvid.vehicle.model.rotation_reference` and
:func:`uuvid.vehicle.model.vehicle_rhs_reference`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def skew(a):
    """``S(a)`` with ``S(a) b = a × b`` (Fossen 2011, eq. 2.10)."""
    S = np.zeros((3, 3))
    S[0, 1] = -a[2]
    S[0, 2] = a[1]
    S[1, 0] = a[2]
    S[1, 2] = -a[0]
    S[2, 0] = -a[1]
    S[2, 1] = a[0]
    return S


@njit(cache=True)
def cross(a, b):
    """``a × b`` for 3-vectors (no allocation of temporaries beyond the result)."""
    out = np.empty(3)
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


@njit(cache=True)
def quat_to_rotmat(q):
    """``R(q)`` body → NED for ``q = [η, ε₁, ε₂, ε₃]`` (Fossen 2011, §2.2.2)."""
    e, x, y, z = q[0], q[1], q[2], q[3]
    R = np.empty((3, 3))
    R[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[0, 1] = 2.0 * (x * y - z * e)
    R[0, 2] = 2.0 * (x * z + y * e)
    R[1, 0] = 2.0 * (x * y + z * e)
    R[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[1, 2] = 2.0 * (y * z - x * e)
    R[2, 0] = 2.0 * (x * z - y * e)
    R[2, 1] = 2.0 * (y * z + x * e)
    R[2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return R


@njit(cache=True)
def quat_derivative(q, w, gain):
    """``q̇ = ½ T(q) ω + ½ γ (1 − qᵀq) q`` (Fossen 2011, §2.2.2), ``ω = [p, q, r]`` in body axes."""
    e, x, y, z = q[0], q[1], q[2], q[3]
    p, qq, r = w[0], w[1], w[2]
    k = 0.5 * gain * (1.0 - (e * e + x * x + y * y + z * z))
    out = np.empty(4)
    out[0] = 0.5 * (-x * p - y * qq - z * r) + k * e
    out[1] = 0.5 * (e * p - z * qq + y * r) + k * x
    out[2] = 0.5 * (z * p + e * qq - x * r) + k * y
    out[3] = 0.5 * (-y * p + x * qq + e * r) + k * z
    return out


@njit(cache=True, inline="always")
def normalise_quaternion(q):
    """``q/|q|`` (in place) with a non-negative scalar part; returns ``|q|`` before normalising."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    s = 1.0 / n if q[0] >= 0.0 else -1.0 / n
    for i in range(4):
        q[i] *= s
    return n


@njit(cache=True, inline="always")
def normalise_state(x):
    """Normalise the quaternion ``x[3:7]`` of a vehicle state in place (call after each step)."""
    return normalise_quaternion(x[3:7])


def euler_to_quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """zyx Euler angles (rad) → unit quaternion ``[η, ε₁, ε₂, ε₃]`` (Fossen 2011, §2.2.3)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    q = np.array([cr * cp * cy + sr * sp * sy,
                  sr * cp * cy - cr * sp * sy,
                  cr * sp * cy + sr * cp * sy,
                  cr * cp * sy - sr * sp * cy])
    return q if q[0] >= 0 else -q


def quat_to_euler(q) -> np.ndarray:
    """Unit quaternion → zyx Euler angles ``[φ, θ, ψ]`` (rad), read off ``R(q)`` (§2.2.3):
    ``φ = atan2(R₃₂, R₃₃)``, ``θ = −asin R₃₁``, ``ψ = atan2(R₂₁, R₁₁)``.  A stack of quaternions
    ``(n, 4)`` gives ``(n, 3)`` (vectorised, e.g. a whole trajectory's ``state[:, 3:7]``)."""
    q = np.asarray(q, dtype=float)
    if q.ndim > 1:
        e, x, y, z = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
        return np.stack([np.arctan2(2.0 * (y * z + x * e), 1.0 - 2.0 * (x * x + y * y)),
                         -np.arcsin(np.clip(2.0 * (x * z - y * e), -1.0, 1.0)),
                         np.arctan2(2.0 * (x * y + z * e), 1.0 - 2.0 * (y * y + z * z))], axis=-1)
    R = quat_to_rotmat(q / np.linalg.norm(q))
    roll = math.atan2(R[2, 1], R[2, 2])
    pitch = -math.asin(max(-1.0, min(1.0, R[2, 0])))
    yaw = math.atan2(R[1, 0], R[0, 0])
    return np.array([roll, pitch, yaw])


def euler_to_rotmat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``R = R_z(ψ) R_y(θ) R_x(φ)`` body → NED (Fossen 2011, eq. 2.18)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cy * cp, -sy * cr + cy * sp * sr, sy * sr + cy * cr * sp],
                     [sy * cp, cy * cr + sr * sp * sy, -cy * sr + sp * sy * cr],
                     [-sp, cp * sr, cp * cr]])
