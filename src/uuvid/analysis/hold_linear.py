"""The station-keeping loop's Jacobian, compiled: the linearisation behind
:func:`uuvid.analysis.hold.closed_loop_modes`.

State ``s`` (16): position (NED), zyx Euler angles, ν (body), the four PID integrators of
:func:`uuvid.simulate.control.pid.dp_control` (surge, sway, heave, yaw).  Right-hand side::

    ṗ = R(Θ) ν₁,  Θ̇ = T(Θ) ν₂,  ν̇ = f(x, B η(τ_alloc(τ_PID)), v_c),  i̇ = e

with ``e`` the body-frame error to rest at ``(0, 0, depth)``, heading 0, ``τ_PID = K_p e + K_i i
+ K_d ė`` (+ attitude PD when the gains have it), ``τ_alloc`` the bounded allocation
(:func:`uuvid.vehicle.allocation.allocate_compiled`, ``priority``), η the per-direction thrust
efficiency and ``f`` the 6-DOF model (:func:`uuvid.vehicle.model.vehicle_rhs_into`; Fossen 2011
eqs. 2.40, 7.190).  :func:`closed_loop_jacobian` takes central differences of it in every state
(32 evaluations, step ``1e-6 · max(1, |s_j|)``): ~100× faster than the same arithmetic through
:meth:`Allocator.allocate` in Python, which :mod:`uuvid.analysis.hold` keeps as the reference
(``_closed_loop_jacobian_py``, tested equal).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from uuvid.vehicle.allocation import allocate_compiled
from uuvid.vehicle.kinematics import quat_to_rotmat
from uuvid.vehicle.model import vehicle_rhs_into

__all__ = ["closed_loop_jacobian"]

_DP = (0, 1, 2, 5)  # uuvid.simulate.control.pid.DP_DOFS


@njit(cache=True)
def _rhs(s, G, P, cur, depth, AL, B, ep, en, out, x, dx, tau, thr, got, zero3, e, ed):
    ph, th, ps = s[3], s[4], s[5]
    cr, sr = math.cos(ph / 2), math.sin(ph / 2)
    cp, sp = math.cos(th / 2), math.sin(th / 2)
    cy, sy = math.cos(ps / 2), math.sin(ps / 2)
    q = np.empty(4)
    q[0] = cr * cp * cy + sr * sp * sy
    q[1] = sr * cp * cy - cr * sp * sy
    q[2] = cr * sp * cy + sr * cp * sy
    q[3] = cr * cp * sy - sr * sp * cy
    if q[0] < 0:
        for i in range(4):
            q[i] = -q[i]
    R = quat_to_rotmat(q)
    d0, d1, d2 = -s[0], -s[1], depth - s[2]
    for i in range(3):
        e[i] = R[0, i] * d0 + R[1, i] * d1 + R[2, i] * d2
        ed[i] = -s[6 + i]
    e[3] = -ps
    ed[3] = -s[11]
    tau[:] = 0.0
    for j in range(4):
        k = _DP[j]
        tau[k] = G[0, j] * e[j] + G[1, j] * s[12 + j] + G[2, j] * ed[j]
    if G[5, 0] != 0 or G[5, 1] != 0 or G[5, 2] != 0 or G[5, 3] != 0:
        tau[3] = -G[5, 0] * ph - G[5, 2] * s[9]
        tau[4] = -G[5, 1] * th - G[5, 3] * s[10]
    allocate_compiled(AL, tau, thr)
    m, n = B.shape
    for r in range(m):
        acc = 0.0
        for i in range(n):
            acc += B[r, i] * (thr[i] * (ep[i] if thr[i] >= 0 else en[i]))
        got[r] = acc
    for i in range(3):
        x[i] = s[i]
    for i in range(4):
        x[3 + i] = q[i]
    for i in range(6):
        x[7 + i] = s[6 + i]
    vehicle_rhs_into(x, got, P, cur, zero3, dx)
    ct, st, tt = math.cos(ph), math.sin(ph), math.tan(th)
    cth = math.cos(th)
    p_, q_, r_ = s[9], s[10], s[11]
    for i in range(3):
        out[i] = R[i, 0] * s[6] + R[i, 1] * s[7] + R[i, 2] * s[8]
    out[3] = p_ + st * tt * q_ + ct * tt * r_
    out[4] = ct * q_ - st * r_
    out[5] = st / cth * q_ + ct / cth * r_
    for i in range(6):
        out[6 + i] = dx[7 + i]
    for i in range(4):
        out[12 + i] = e[i]


@njit(cache=True)
def closed_loop_jacobian(s0, G, P, cur, depth, AL, B, ep, en):
    """``∂ṡ/∂s`` (16 × 16) at ``s0`` by central differences (see the module docstring)."""
    N = 16
    A = np.empty((N, N))
    fp = np.empty(N)
    fm = np.empty(N)
    s = s0.copy()
    x = np.zeros(13)
    dx = np.zeros(13)
    tau = np.zeros(6)
    thr = np.zeros(B.shape[1])
    got = np.zeros(B.shape[0])
    zero3 = np.zeros(3)
    e = np.empty(4)
    ed = np.empty(4)
    for j in range(N):
        h = 1e-6 * max(1.0, abs(s0[j]))
        s[j] = s0[j] + h
        _rhs(s, G, P, cur, depth, AL, B, ep, en, fp, x, dx, tau, thr, got, zero3, e, ed)
        s[j] = s0[j] - h
        _rhs(s, G, P, cur, depth, AL, B, ep, en, fm, x, dx, tau, thr, got, zero3, e, ed)
        s[j] = s0[j]
        for i in range(N):
            A[i, j] = (fp[i] - fm[i]) / (2 * h)
    return A
