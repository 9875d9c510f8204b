"""The practical limit of a mission step: a minimal numba RK4 kernel of the same closed loop.

What a competent user would write by hand for *one* configuration — the BlueROV2 (or any vehicle
whose thrusters are ESC → first-order motor → quadratic map) flying a mission with the built-in
PID DP, uniform-scaling allocation, no current, no disturbance, an ideal supply — and nothing
else: straight-line code, matrices as 6×6 arrays, no generality (no current terms, no block
dispatch, no battery, no controller interface).

Same model as :func:`uuvid.simulate.vehicle_sim.fly_mission`: the 6-DOF rigid body with added
mass, Kirchhoff Coriolis, linear + quadratic damping and restoring forces; the PID on surge, sway,
heave and yaw (body-frame errors, conditional-integration anti-windup); allocation ``f = T τ``
scaled uniformly into the thrust limits; each thruster's motor speed follows its target with a
first-order lag, evaluated in closed form at the RK4 stage times under the held target (the
target speed for a thrust comes from inverting the quadratic map in closed form, clamped to the
speeds the ESC can give); RK4 with ``dt`` steps, quaternion normalised after each.  It differs
from ``fly_mission`` only where uuvid inverts the steady map by a 401-point table (linear
interpolation) instead of the square root: the trajectories agree to ~1e-4 m (the benchmark
asserts it).  Its helpers are inlined (``inline="always"``): it is the fastest form of this
code we found, so the reference is at its best.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


def kernel_inputs(setup) -> dict:
    """The arrays of the minimal kernel from a :func:`~uuvid.simulate.vehicle_sim.setup_mission`
    setup (thrusters ESC → first-order motor → quadratic map; the allocation's T and limits)."""
    s = setup
    p = s.vehicle.params
    b = s.bank
    n = b.n
    gains = s.gains.to_array()
    T = s.alloc[3:3 + n * 6].reshape(n, 6)
    lo = s.alloc[3 + n * 6:3 + n * 7]
    hi = s.alloc[3 + n * 7:3 + n * 8]
    kq = np.empty((n, 2))  # quadratic map k+ / k−
    motor = np.empty((n, 2))  # gain, time constant
    wlim = np.empty((n, 2))  # motor speed range the ESC can give
    for i, ch in enumerate(b.chains):
        esc, mot, qmap = ch.blocks
        kq[i] = qmap.k_pos, qmap.k_neg
        motor[i] = mot.gain, mot.time_constant
        v = esc.voltage(np.array([esc.saturation_low, esc.saturation_high]))
        wlim[i] = mot.gain * v[0], mot.gain * v[1]
    return dict(Minv=np.linalg.inv(p.mass_matrix), MRB=np.ascontiguousarray(p.M_RB),
                MA=np.ascontiguousarray(p.added_mass), DL=np.ascontiguousarray(p.linear_damping),
                DQ=np.ascontiguousarray(p.quadratic_damping),
                grav=np.array([p.weight, p.buoyancy, *p.r_g, *p.r_b, p.quaternion_gain]),
                B=np.ascontiguousarray(s.B), T=np.ascontiguousarray(T), lo=lo.copy(), hi=hi.copy(),
                eta_p=s.eta_p.copy(), eta_n=s.eta_n.copy(), kq=kq, motor=motor, wlim=wlim,
                gains=gains, dt=float(s.dt))


@njit(inline="always")
def _kirchhoff(M, v, f):
    a0 = a1 = a2 = a3 = a4 = a5 = 0.0
    for j in range(6):
        a0 += M[0, j] * v[j]
        a1 += M[1, j] * v[j]
        a2 += M[2, j] * v[j]
        a3 += M[3, j] * v[j]
        a4 += M[4, j] * v[j]
        a5 += M[5, j] * v[j]
    f[0] -= v[4] * a2 - v[5] * a1
    f[1] -= v[5] * a0 - v[3] * a2
    f[2] -= v[3] * a1 - v[4] * a0
    f[3] -= (v[1] * a2 - v[2] * a1) + (v[4] * a5 - v[5] * a4)
    f[4] -= (v[2] * a0 - v[0] * a2) + (v[5] * a3 - v[3] * a5)
    f[5] -= (v[0] * a1 - v[1] * a0) + (v[3] * a4 - v[4] * a3)


@njit(inline="always")
def _rhs(x, tau, Minv, MRB, MA, DL, DQ, grav, f, dx):
    e, ex, ey, ez = x[3], x[4], x[5], x[6]
    r00 = 1.0 - 2.0 * (ey * ey + ez * ez)
    r01 = 2.0 * (ex * ey - ez * e)
    r02 = 2.0 * (ex * ez + ey * e)
    r10 = 2.0 * (ex * ey + ez * e)
    r11 = 1.0 - 2.0 * (ex * ex + ez * ez)
    r12 = 2.0 * (ey * ez - ex * e)
    r20 = 2.0 * (ex * ez - ey * e)
    r21 = 2.0 * (ey * ez + ex * e)
    r22 = 1.0 - 2.0 * (ex * ex + ey * ey)
    u, v, w, p, q, r = x[7], x[8], x[9], x[10], x[11], x[12]
    dx[0] = r00 * u + r01 * v + r02 * w
    dx[1] = r10 * u + r11 * v + r12 * w
    dx[2] = r20 * u + r21 * v + r22 * w
    k = 0.5 * grav[8] * (1.0 - (e * e + ex * ex + ey * ey + ez * ez))
    dx[3] = 0.5 * (-ex * p - ey * q - ez * r) + k * e
    dx[4] = 0.5 * (e * p - ez * q + ey * r) + k * ex
    dx[5] = 0.5 * (ez * p + e * q - ex * r) + k * ey
    dx[6] = 0.5 * (-ey * p + ex * q + e * r) + k * ez
    nu = x[7:13]
    for i in range(6):
        f[i] = tau[i]
    _kirchhoff(MRB, nu, f)
    _kirchhoff(MA, nu, f)
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += DL[i, j] * nu[j] + DQ[i, j] * abs(nu[j]) * nu[j]
        f[i] -= s
    W, Bu = grav[0], grav[1]
    f[0] += (W - Bu) * r20
    f[1] += (W - Bu) * r21
    f[2] += (W - Bu) * r22
    mx = W * grav[2] - Bu * grav[5]
    my = W * grav[3] - Bu * grav[6]
    mz = W * grav[4] - Bu * grav[7]
    f[3] += my * r22 - mz * r21
    f[4] += mz * r20 - mx * r22
    f[5] += mx * r21 - my * r20
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += Minv[i, j] * f[j]
        dx[7 + i] = s


@njit(inline="always")
def _pid_alloc(z, k, ref_pos, ref_vel, ref_yaw, ref_rate, gains, integ, e, ed, tau_des, T, lo, hi,
               fd, kq, wlim, wt, dt):
    """Step k's PID DP (body-frame errors, conditional-integration anti-windup), allocation
    ``f = T τ`` scaled uniformly into the limits, and each motor's target speed ``wt`` (the
    quadratic map inverted in closed form, clamped to the ESC's range)."""
    n = T.shape[0]
    # PID DP (body-frame errors)
    q0, q1, q2, q3 = z[3], z[4], z[5], z[6]
    r00 = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
    r01 = 2.0 * (q1 * q2 - q3 * q0)
    r02 = 2.0 * (q1 * q3 + q2 * q0)
    r10 = 2.0 * (q1 * q2 + q3 * q0)
    r11 = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
    r12 = 2.0 * (q2 * q3 - q1 * q0)
    r20 = 2.0 * (q1 * q3 - q2 * q0)
    r21 = 2.0 * (q2 * q3 + q1 * q0)
    r22 = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
    d0 = ref_pos[k, 0] - z[0]
    d1 = ref_pos[k, 1] - z[1]
    d2 = ref_pos[k, 2] - z[2]
    v0, v1, v2 = ref_vel[k, 0], ref_vel[k, 1], ref_vel[k, 2]
    e[0] = r00 * d0 + r10 * d1 + r20 * d2
    e[1] = r01 * d0 + r11 * d1 + r21 * d2
    e[2] = r02 * d0 + r12 * d1 + r22 * d2
    ed[0] = r00 * v0 + r10 * v1 + r20 * v2 - z[7]
    ed[1] = r01 * v0 + r11 * v1 + r21 * v2 - z[8]
    ed[2] = r02 * v0 + r12 * v1 + r22 * v2 - z[9]
    yaw = math.atan2(2 * (q0 * q3 + q1 * q2), 1 - 2 * (q2 * q2 + q3 * q3))
    e[3] = (ref_yaw[k] - yaw + math.pi) % (2 * math.pi) - math.pi
    ed[3] = ref_rate[k] - z[12]
    for j in range(4):
        kp, ki, kd, tmax, ilim = gains[0, j], gains[1, j], gains[2, j], gains[3, j], gains[4, j]
        uu = kp * e[j] + ki * integ[j] + kd * ed[j]
        if not (abs(uu) >= tmax and uu * e[j] > 0):
            integ[j] += e[j] * dt
        if ki > 0:
            integ[j] = min(max(integ[j], -ilim / ki), ilim / ki)
        uu = kp * e[j] + ki * integ[j] + kd * ed[j]
        tau_des[j if j < 3 else 5] = min(max(uu, -tmax), tmax)
    # allocation, uniform scaling into the limits
    s = 1.0
    for i in range(n):
        t = 0.0
        for j in range(6):
            t += T[i, j] * tau_des[j]
        fd[i] = t
        if t > hi[i]:
            s = min(s, hi[i] / t)
        elif t < lo[i]:
            s = min(s, lo[i] / t)
    # thrust → target motor speed (quadratic map inverted in closed form)
    for i in range(n):
        t = fd[i] * s
        w = math.sqrt(t / kq[i, 0]) if t >= 0.0 else -math.sqrt(-t / kq[i, 1])
        wt[i] = min(max(w, wlim[i, 0]), wlim[i, 1])


@njit(inline="always")
def _lags(motor, dt):
    """``exp(−h/τ_m)`` of each motor's first-order lag over half a step and a whole step."""
    n = motor.shape[0]
    ehalf = np.empty(n)
    efull = np.empty(n)
    for i in range(n):
        ehalf[i] = math.exp(-0.5 * dt / motor[i, 1])
        efull[i] = math.exp(-dt / motor[i, 1])
    return ehalf, efull


@njit(inline="always")
def _end_step(z, k1, k2, k3, k4, wt, efull, dt):
    """The RK4 update of the 13 vehicle states, the motors' exact lag to the step's end, and the
    quaternion renormalised (sign kept with a non-negative scalar part)."""
    for i in range(13):
        z[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    for i in range(wt.shape[0]):
        z[13 + i] = wt[i] + (z[13 + i] - wt[i]) * efull[i]
    qn = math.sqrt(z[3] * z[3] + z[4] * z[4] + z[5] * z[5] + z[6] * z[6])
    qs = 1.0 / qn if z[3] >= 0.0 else -1.0 / qn
    for i in range(3, 7):
        z[i] *= qs


@njit
def fly_minimal(z0, Minv, MRB, MA, DL, DQ, grav, B, T, lo, hi, eta_p, eta_n, kq, motor, wlim,
                gains, ref_pos, ref_vel, ref_yaw, ref_rate, dt, Z, F):
    """Fly ``ref_pos.shape[0]`` steps; ``Z[k]`` the state (13 + n motor speeds) at the start of
    step k, ``F[k]`` the delivered thrusts then."""
    n = T.shape[0]
    nz = z0.size
    z = z0.copy()
    zt = np.empty(13)
    k1 = np.empty(13)
    k2 = np.empty(13)
    k3 = np.empty(13)
    k4 = np.empty(13)
    f = np.empty(6)
    tau = np.empty(6)
    tau_des = np.zeros(6)
    fd = np.empty(n)
    wt = np.empty(n)
    th = np.empty((3, n))
    integ = np.zeros(4)
    e = np.empty(4)
    ed = np.empty(4)
    ehalf, efull = _lags(motor, dt)
    for k in range(ref_pos.shape[0]):
        _pid_alloc(z, k, ref_pos, ref_vel, ref_yaw, ref_rate, gains, integ, e, ed, tau_des, T, lo,
                   hi, fd, kq, wlim, wt, dt)
        # thrust at the RK4 stage times (exact first-order lag under the held target)
        for i in range(n):
            w0 = z[13 + i]
            for st in range(3):
                ws = w0 if st == 0 else wt[i] + (w0 - wt[i]) * (ehalf[i] if st == 1 else efull[i])
                tq = (kq[i, 0] if ws >= 0.0 else kq[i, 1]) * ws * abs(ws)
                th[st, i] = tq * (eta_p[i] if tq >= 0.0 else eta_n[i])
        for i in range(nz):
            Z[k, i] = z[i]
        for i in range(n):
            F[k, i] = th[0, i]
        # RK4 of the 13 vehicle states
        for j in range(6):
            a = 0.0
            for i in range(n):
                a += B[j, i] * th[0, i]
            tau[j] = a
        _rhs(z, tau, Minv, MRB, MA, DL, DQ, grav, f, k1)
        for j in range(6):
            a = 0.0
            for i in range(n):
                a += B[j, i] * th[1, i]
            tau[j] = a
        for i in range(13):
            zt[i] = z[i] + 0.5 * dt * k1[i]
        _rhs(zt, tau, Minv, MRB, MA, DL, DQ, grav, f, k2)
        for i in range(13):
            zt[i] = z[i] + 0.5 * dt * k2[i]
        _rhs(zt, tau, Minv, MRB, MA, DL, DQ, grav, f, k3)
        for j in range(6):
            a = 0.0
            for i in range(n):
                a += B[j, i] * th[2, i]
            tau[j] = a
        for i in range(13):
            zt[i] = z[i] + dt * k3[i]
        _rhs(zt, tau, Minv, MRB, MA, DL, DQ, grav, f, k4)
        _end_step(z, k1, k2, k3, k4, wt, efull, dt)


def fly(setup, Z=None, F=None):
    """Fly a setup with the minimal kernel; returns ``(Z, F)``."""
    args = kernel_args(setup, Z, F)
    fly_minimal(*args)
    return args[-2], args[-1]


# ------------------------------------------------------------------------------------------------
# The same closed loop with thrust at the advance speed (issue 21): the practical limit of the
# inflow mission loop
# ------------------------------------------------------------------------------------------------
def inflow_inputs(setup) -> dict:
    """The inflow arrays of :func:`fly_minimal_inflow` from a setup whose vehicle has inflow on:
    ``M`` (n, 6) with ``u_a = M ν`` (row ``(1 − w)[axis, r × axis]``: the advance speed is linear
    in the body velocity), ``vtc`` (n, 2) the propeller's ``0.7π n D`` per unit of motor speed
    ahead/astern (the shaft speed uuvid derives from the bollard thrust ``k w|w|``:
    ``0.7πD sqrt(k /(ρ K_T0 D⁴)) w``, no square root per stage) and the map's parameters."""
    prm, geo = setup.inflow_arrays
    a = kernel_inputs(setup)
    M = np.empty((geo.shape[0], 6))
    for i in range(geo.shape[0]):
        r, ax, w = geo[i, :3], geo[i, 3:6], geo[i, 6]
        M[i, :3] = (1.0 - w) * ax
        M[i, 3:] = (1.0 - w) * np.cross(r, ax)
    vtc = np.column_stack([prm[0] * np.sqrt(a["kq"][:, 0] * prm[2]),
                           prm[0] * np.sqrt(a["kq"][:, 1] * prm[3])])
    return dict(M=M, vtc=vtc, prm=np.ascontiguousarray(prm))


@njit(inline="always")
def _stage_tau_inflow(x, ws, st, kq, eta_p, eta_n, M, vtc, prm, B, tau, thr):
    """τ at one RK4 stage: each motor's bollard thrust ``k w|w|`` taken through the four-quadrant
    map to the advance speed of the stage state ``x`` (C_T* from its cubic table in the diamond
    angle, as :func:`uuvid.thruster.inflow.inflow_thrust_nb`)."""
    u, v, w, p, q, r = x[7], x[8], x[9], x[10], x[11], x[12]
    t0 = t1 = t2 = t3 = t4 = t5 = 0.0
    nint = int(prm[4])
    for i in range(M.shape[0]):
        ms = ws[st, i]
        f = (kq[i, 0] if ms >= 0.0 else kq[i, 1]) * ms * abs(ms)
        ua = M[i, 0] * u + M[i, 1] * v + M[i, 2] * w + M[i, 3] * p + M[i, 4] * q + M[i, 5] * r
        if ua != 0.0:
            vt = (vtc[i, 0] if ms >= 0.0 else vtc[i, 1]) * ms
            qd = ua / (abs(ua) + abs(vt))
            xg = ((qd if vt >= 0.0 else math.copysign(2.0, ua) - qd) + 2.0) * prm[5]
            j = min(int(xg), nint - 1)
            tt = xg - j
            o = 6 + 4 * j
            f = (prm[o] + tt * (prm[o + 1] + tt * (prm[o + 2] + tt * prm[o + 3]))) * prm[1] \
                * (ua * ua + vt * vt)
        f *= eta_p[i] if f >= 0.0 else eta_n[i]
        thr[i] = f
        t0 += B[0, i] * f
        t1 += B[1, i] * f
        t2 += B[2, i] * f
        t3 += B[3, i] * f
        t4 += B[4, i] * f
        t5 += B[5, i] * f
    tau[0], tau[1], tau[2], tau[3], tau[4], tau[5] = t0, t1, t2, t3, t4, t5


@njit
def fly_minimal_inflow(z0, Minv, MRB, MA, DL, DQ, grav, B, T, lo, hi, eta_p, eta_n, kq, motor,
                       wlim, gains, ref_pos, ref_vel, ref_yaw, ref_rate, dt, Z, F, M, vtc, prm):
    """:func:`fly_minimal` with each thruster's thrust at the advance speed of every RK4 stage's
    own state (:func:`_stage_tau_inflow`); still water."""
    n = T.shape[0]
    nz = z0.size
    z = z0.copy()
    zt = np.empty(13)
    k1 = np.empty(13)
    k2 = np.empty(13)
    k3 = np.empty(13)
    k4 = np.empty(13)
    f = np.empty(6)
    tau = np.empty(6)
    tau_des = np.zeros(6)
    fd = np.empty(n)
    wt = np.empty(n)
    ws = np.empty((3, n))
    thr = np.empty(n)
    integ = np.zeros(4)
    e = np.empty(4)
    ed = np.empty(4)
    ehalf, efull = _lags(motor, dt)
    for k in range(ref_pos.shape[0]):
        _pid_alloc(z, k, ref_pos, ref_vel, ref_yaw, ref_rate, gains, integ, e, ed, tau_des, T, lo,
                   hi, fd, kq, wlim, wt, dt)
        for i in range(n):  # motor speeds at the RK4 stage times (exact first-order lag)
            w0 = z[13 + i]
            ws[0, i] = w0
            ws[1, i] = wt[i] + (w0 - wt[i]) * ehalf[i]
            ws[2, i] = wt[i] + (w0 - wt[i]) * efull[i]
        for i in range(nz):
            Z[k, i] = z[i]
        _stage_tau_inflow(z, ws, 0, kq, eta_p, eta_n, M, vtc, prm, B, tau, thr)
        for i in range(n):
            F[k, i] = thr[i]
        _rhs(z, tau, Minv, MRB, MA, DL, DQ, grav, f, k1)
        for i in range(13):
            zt[i] = z[i] + 0.5 * dt * k1[i]
        _stage_tau_inflow(zt, ws, 1, kq, eta_p, eta_n, M, vtc, prm, B, tau, thr)
        _rhs(zt, tau, Minv, MRB, MA, DL, DQ, grav, f, k2)
        for i in range(13):
            zt[i] = z[i] + 0.5 * dt * k2[i]
        _stage_tau_inflow(zt, ws, 1, kq, eta_p, eta_n, M, vtc, prm, B, tau, thr)
        _rhs(zt, tau, Minv, MRB, MA, DL, DQ, grav, f, k3)
        for i in range(13):
            zt[i] = z[i] + dt * k3[i]
        _stage_tau_inflow(zt, ws, 2, kq, eta_p, eta_n, M, vtc, prm, B, tau, thr)
        _rhs(zt, tau, Minv, MRB, MA, DL, DQ, grav, f, k4)
        _end_step(z, k1, k2, k3, k4, wt, efull, dt)


def kernel_args(setup, Z=None, F=None) -> tuple:
    """The positional arguments of :func:`fly_minimal` (and, with the :func:`inflow_inputs`
    appended, of :func:`fly_minimal_inflow`) for a setup, with output arrays ``Z``, ``F``."""
    a = kernel_inputs(setup)
    ref_pos, ref_vel, ref_yaw, ref_rate = (np.ascontiguousarray(r) for r in setup.ref)
    N = ref_pos.shape[0]
    n = a["T"].shape[0]
    Z = np.empty((N, 13 + n)) if Z is None else Z
    F = np.empty((N, n)) if F is None else F
    return (setup.z0(), a["Minv"], a["MRB"], a["MA"], a["DL"], a["DQ"], a["grav"], a["B"],
            a["T"], a["lo"], a["hi"], a["eta_p"], a["eta_n"], a["kq"], a["motor"], a["wlim"],
            a["gains"], ref_pos, ref_vel, ref_yaw, ref_rate, a["dt"], Z, F)


def fly_inflow(setup, Z=None, F=None):
    """Fly a setup (vehicle with inflow on) with :func:`fly_minimal_inflow`; returns ``(Z, F)``."""
    args = kernel_args(setup, Z, F)
    b = inflow_inputs(setup)
    fly_minimal_inflow(*args, b["M"], b["vtc"], b["prm"])
    return args[-2], args[-1]
