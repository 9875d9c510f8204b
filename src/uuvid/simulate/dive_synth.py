"""A synthetic piloted dive flown by the project's 6-DOF model, logged as ArduSub would log it.

:func:`synthetic_dive` flies a vehicle (default ``bluerov2``) with
:func:`uuvid.vehicle.model.vehicle_rhs` (RK4, 50 Hz) under a pilot who switches between MANUAL,
STABILIZE (heading hold) and ALT_HOLD (depth + heading hold, PID like ArduSub's), with:

* thrusters driven by PWM computed for a nominal 16 V, delivering the voltage-aware T200 thrust
  at the *sagging* battery voltage (``uuvid.io.ardusub.thrust.default_t200``);
* an unmodelled tether-like drag in heave and yaw (linear + quadratic, added to the vehicle's);
* optionally (``inflow_coefficient`` k_a > 0) thrust that falls with the advance speed, the linear
  inflow form ``T_i = T_i,bollard − k_a |Ω_i| u_a,i`` (Healey et al. 1995, small-angle form;
  Fossen 2011 §6.7) with ``u_a`` from :func:`uuvid.thruster.inflow.advance_speeds` at each RK4
  stage and ``|Ω_i|`` the T200 model's rotor speed at the PWM and battery voltage — the log still
  records the bollard force (as ArduSub's servo outputs would give it);
* channels logged at their own jittered rates: depth ≈ 3 Hz (σ 1 cm), yaw ≈ 20 Hz (σ 0.3°),
  PWM ≈ 2 Hz, battery ≈ 1 Hz (σ 0.02 V); a disarmed stretch at the start.

The table has one row per stamp of any channel (NaN where a channel has no sample) with the
force columns ``X_N … N_Nm`` computed from the logged PWM at the logged voltage (as
``uuvid log export`` does).  The tests also write it as real ``.BIN``/``.tlog`` files
(pymavlink) and as ROS 1/2 bags (rosbags), and read those back through the same readers users'
logs go through.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from uuvid.io.ardusub.frames import DOF_COLUMNS
from uuvid.thruster.inflow import advance_speeds_nb
from uuvid.vehicle.kinematics import normalise_state
from uuvid.vehicle.model import vehicle_rhs

__all__ = ["synthetic_dive", "dive_truth", "synthetic_horizontal_dive", "horizontal_truth_vehicle"]

TETHER = {"heave": (3.0, 12.0), "yaw": (0.05, 0.6)}  # (linear, quadratic) extra drag
DT = 0.02
MODES = ("MANUAL", "STABILIZE", "ALT_HOLD")  # the pilot's modes, coded 0, 1, 2 in the kernel


@njit(cache=True, inline="always")
def _table_at(table, pwm, volts):
    """``table[V, pwm]`` (rows every 0.05 V from 13 V, columns every µs from 1100 µs), linear in V."""
    i = min(max(int(np.rint(pwm - 1100.0)), 0), table.shape[1] - 1)
    u = min(max((volts - 13.0) / 0.05, 0.0), table.shape[0] - 1.000001)
    k = int(u)
    f = u - k
    return table[k, i] * (1 - f) + table[k + 1, i] * f


@njit(cache=True, inline="always")
def _stage_point(x, ks, s, h, z):
    """RK4 stage ``s``'s state into ``z``: ``x``, ``x + h/2 k1``, ``x + h/2 k2``, ``x + h k3``
    (``ks[s - 1]`` the previous stage's derivative)."""
    if s == 0:
        for m in range(13):
            z[m] = x[m]
    else:
        a = 0.5 * h if s < 3 else h
        for m in range(13):
            z[m] = x[m] + a * ks[s - 1, m]


@njit(cache=True)
def _pilot_steps(i0, i1, x, t, mode, disarmed, duration, stick, depth_tgt, yaw_tgt, integ,
                 A, lim, thr_pos, pwm_pos, thr_neg, pwm_neg, TT, OO, ka, pos, axes, wake, B,
                 tether, p, X, PWM, V):
    """Steps ``i0 … i1 − 1`` of :func:`synthetic_dive` between two of the pilot's decisions (stick
    and mode held): the mode's control (heading hold ``4 e − 1.2 r``, depth PID
    ``60 e_z − 50 w + 3 ∫e_z``), thrust wanted → PWM at the nominal 16 V (no compensation), the
    battery's sag, the T200's thrust at the logged PWM and the sagging voltage, less
    ``k_a |Ω| u_a`` with inflow, the tether's drag, and one RK4 step of
    :func:`uuvid.vehicle.model.vehicle_rhs`; ``x`` is advanced in place, ``X``/``PWM``/``V``
    record each step.  Returns the depth integrator."""
    n_thr = A.shape[0]
    n = t.size - 1
    tau = np.zeros(4)
    T_cmd = np.zeros(n_thr)
    pwm = np.zeros(n_thr)
    T = np.zeros(n_thr)
    Om = np.zeros(n_thr)
    ua = np.zeros(n_thr)
    Te = np.zeros(n_thr)
    tau6 = np.zeros(6)
    z = np.zeros(13)
    ks = np.zeros((4, 13))
    h = DT
    for i in range(i0, i1):
        ti = t[i]
        qw, qx, qy, qz = x[3], x[4], x[5], x[6]
        yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        w, r = x[9], x[12]
        tau[:] = 0.0
        tau[0] = 25.0 * stick[0]
        if mode == 0:
            tau[2] = 40.0 * stick[1]
            tau[3] = 2.0 * stick[2]
        else:
            e = (yaw_tgt - yaw + np.pi) % (2 * np.pi) - np.pi
            tau[3] = min(max(4.0 * e - 1.2 * r, -4.0), 4.0)
            if mode == 2:
                ez = depth_tgt - x[2]
                integ = min(max(integ + ez * h, -20.0), 20.0)
                tau[2] = min(max(60.0 * ez - 50.0 * w + 3.0 * integ, -60.0), 60.0)
            else:
                tau[2] = 40.0 * stick[1]
        armed = ti >= disarmed
        load = 0.0
        for j in range(n_thr):
            if armed:
                c = A[j, 0] * tau[0] + A[j, 1] * tau[1] + A[j, 2] * tau[2] + A[j, 3] * tau[3]
                c = min(max(c, lim[j, 0]), lim[j, 1])
                T_cmd[j] = c
                if c > 1e-3:
                    pwm[j] = np.rint(np.interp(c, thr_pos, pwm_pos))
                elif c < -1e-3:
                    pwm[j] = np.rint(np.interp(c, thr_neg, pwm_neg))
                else:
                    pwm[j] = 1500.0
            else:
                T_cmd[j] = 0.0
                pwm[j] = 1500.0
            load += abs(T_cmd[j])
        v_batt = 16.4 - 1.2 * ti / max(duration, 1.0) - 0.01 * load
        for j in range(n_thr):
            T[j] = _table_at(TT, pwm[j], v_batt)
            if ka != 0.0:
                Om[j] = _table_at(OO, pwm[j], v_batt)
        for m in range(13):  # rows element by element: a row assignment compiles numba's
            X[i, m] = x[m]  # shape-mismatch message (≈ 2 s per process)
        for j in range(n_thr):
            PWM[i, j] = pwm[j]
        V[i] = v_batt
        if i == n:
            break
        for s in range(4):  # RK4: stages at x, x + h/2 k1, x + h/2 k2, x + h k3
            _stage_point(x, ks, s, h, z)
            if ka != 0.0:
                advance_speeds_nb(z[7:13], pos, axes, wake, ua)
                for j in range(n_thr):
                    Te[j] = T[j] - ka * Om[j] * ua[j]
            else:
                for j in range(n_thr):
                    Te[j] = T[j]
            for m in range(6):
                acc = 0.0
                for j in range(n_thr):
                    acc += B[m, j] * Te[j]
                tau6[m] = acc
            tau6[2] -= tether[0] * z[9] + tether[1] * z[9] * abs(z[9])
            tau6[5] -= tether[2] * z[12] + tether[3] * z[12] * abs(z[12])
            d = vehicle_rhs(z, tau6, p)
            for m in range(13):
                ks[s, m] = d[m]
        for m in range(13):
            x[m] = x[m] + h / 6 * (ks[0, m] + 2 * ks[1, m] + 2 * ks[2, m] + ks[3, m])
        normalise_state(x)
        if x[2] < 0:  # the surface: no flying out of the water
            x[2], x[9] = 0.0, max(x[9], 0.0)
    return integ


def _stamps(rng, t0, t1, rate, jitter=0.3):
    dt = 1.0 / rate
    n = int((t1 - t0) / dt) + 2
    steps = dt * (1 + jitter * rng.uniform(-1, 1, n))
    t = t0 + np.cumsum(steps)
    return t[t < t1]


def dive_truth(vehicle="bluerov2", tether=None, inflow_coefficient: float = 0.0) -> dict:
    """The 1-DOF parameters the synthetic dive obeys (vehicle + tether drag), per DOF; with an
    inflow coefficient, also ``inflow`` (k_a, the same for every DOF: one thruster type)."""
    from uuvid.vehicle.definition import load_vehicle

    v = load_vehicle(vehicle) if isinstance(vehicle, str) else vehicle
    tether = TETHER if tether is None else tether
    p = v.params
    M = np.asarray(p.M_RB) + np.asarray(p.added_mass)
    out = {}
    for dof, i in (("heave", 2), ("yaw", 5)):
        kt, kqt = tether.get(dof, (0.0, 0.0))
        out[dof] = {"mass": float(M[i, i]), "linear": float(p.linear_damping[i, i] + kt),
                    "quadratic": float(p.quadratic_damping[i, i] + kqt),
                    "bias": float(p.weight - p.buoyancy) if dof == "heave" else 0.0}
        if inflow_coefficient:
            out[dof]["inflow"] = float(inflow_coefficient)
    return out


def synthetic_dive(duration: float = 600.0, seed: int = 0, vehicle="bluerov2", *,
                   tether=None, depth_noise: float = 0.01, yaw_noise: float = 0.005,
                   disarmed: float = 8.0, pwm_rate: float = 2.0, surge: float = 0.1,
                   rates: dict | None = None, jitter: float = 0.3, dvl: bool = False,
                   inflow_coefficient: float = 0.0):
    """``(table, truth)``: a piloted dive as a pandas DataFrame (see the module doc) and
    :func:`dive_truth`.  ``rates`` overrides the logging rates ``{"depth": 3, "yaw": 20,
    "pwm": pwm_rate, "battery": 1}`` [Hz]; ``jitter`` is the relative spread of the intervals
    (0: every channel at the same rate shares its stamps, as in a dataflash log).  ``dvl``: add
    body velocities ``u_mps``/``v_mps`` at 5 Hz (σ 0.01 m/s), as a DVL would log them.
    ``inflow_coefficient`` k_a [N·s²/(rad·m)] > 0: the thrusters lose ``k_a |Ω_i| u_a,i`` to the
    advance speed (see the module doc; default 0: bollard thrust, the dive as before)."""
    import pandas as pd

    from uuvid.io.ardusub.thrust import default_t200
    from uuvid.vehicle.definition import load_vehicle
    from uuvid.vehicle.kinematics import quat_to_euler
    from uuvid.vehicle.model import make_state

    rng = np.random.default_rng(seed)
    veh = load_vehicle(vehicle) if isinstance(vehicle, str) else vehicle
    tether = TETHER if tether is None else tether
    p = veh.params.to_array()
    B = np.array(veh.B, float, order="C")  # writable copies (the vehicle's are read-only), the
    n_thr = B.shape[1]  # types the compiled kernels were built for
    lim = np.array(veh.layout.limits, float, order="C")
    ctrl_rows = [0, 1, 2, 5]
    A = np.ascontiguousarray(np.linalg.pinv(B[ctrl_rows]))
    t200 = default_t200()
    pwm_tab = np.arange(1100.0, 1901.0, 1.0)
    thr_tab = t200.thrust(pwm_tab, np.full(pwm_tab.size, 16.0))
    ka = float(inflow_coefficient)
    if not (math.isfinite(ka) and ka >= 0):
        raise ValueError(f"inflow_coefficient must be a finite number >= 0, got {ka!r}")

    pos, neg = pwm_tab > 1500, pwm_tab < 1500
    # thrust(pwm, V) tabulated once: whole µs × 0.05 V (linear in V between rows)
    v_tab = np.arange(13.0, 17.0001, 0.05)
    TT = np.stack([t200.thrust(pwm_tab, np.full(pwm_tab.size, v)) for v in v_tab])
    P_thr = np.array([t_.position for t_ in veh.layout], float).reshape(-1, 3)
    A_thr = np.array([t_.axis for t_ in veh.layout], float).reshape(-1, 3)
    wake = np.asarray(veh.wake if len(veh.wake) else np.zeros(n_thr), float)
    # rotor speed |Ω|(pwm, V) on the same grid, for the inflow loss k_a |Ω| u_a
    OO = (np.stack([np.abs(t200.speed(pwm_tab, np.full(pwm_tab.size, v))) for v in v_tab])
          if ka else np.zeros((2, 1)))
    teth = np.array([*tether.get("heave", (0.0, 0.0)), *tether.get("yaw", (0.0, 0.0))], float)

    n = int(round(duration / DT))
    t = np.arange(n + 1) * DT
    x = make_state(position=(0, 0, 0.3), rpy=(0, 0, rng.uniform(-np.pi, np.pi)))
    # pilot schedule: segments of 15–40 s cycling the modes
    segs, s = [], disarmed
    k = 0
    while s < duration:
        d = rng.uniform(15, 40)
        segs.append((s, min(s + d, duration), k % 3))
        s += d
        k += 1
    mode = np.zeros(n + 1, np.int64)  # MANUAL outside the segments
    for a, b, m in reversed(segs):
        mode[(t >= a) & (t < b)] = m
    mode_changes = np.flatnonzero(np.diff(mode)) + 1  # the steps whose mode differs from the last
    X = np.empty((n + 1, 13))
    PWM = np.empty((n + 1, n_thr))
    V = np.empty(n + 1)
    stick = np.zeros(3)  # surge, heave, yaw
    next_stick = disarmed
    depth_tgt, yaw_tgt, integ = 1.0, 0.0, 0.0
    prev_mode = -1
    i = 0
    # the pilot decides (new sticks and targets, a mode's first step) in Python; between two
    # decisions the compiled _pilot_steps flies the vehicle
    while i <= n:
        ti = t[i]
        qw, qx, qy, qz = x[3:7]
        yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        if ti >= next_stick:
            stick = np.array([rng.uniform(-surge, surge) * (rng.random() < 0.4),
                              rng.uniform(-0.8, 0.8) * (rng.random() < 0.7),
                              rng.uniform(-0.6, 0.6) * (rng.random() < 0.6)])
            if x[2] < 1.5:  # the pilot keeps the vehicle down (it floats: W < B)
                stick[1] = rng.uniform(0.2, 0.8)
            elif x[2] > 12.0:
                stick[1] = rng.uniform(-0.8, -0.2)
            next_stick = ti + rng.uniform(2, 8)
            if mode[i] == 2:
                depth_tgt = float(np.clip(x[2] + rng.uniform(-2, 2), 0.5, 15.0))
            yaw_tgt = yaw + rng.uniform(-1.5, 1.5)
        if mode[i] != prev_mode:
            depth_tgt, yaw_tgt, integ = float(x[2]), float(yaw), 0.0
            prev_mode = mode[i]
        after = mode_changes[mode_changes > i]
        j = min(int(np.searchsorted(t, next_stick, side="left")),
                int(after[0]) if after.size else n + 1, n + 1)
        integ = _pilot_steps(i, max(j, i + 1), x, t, int(mode[i]), float(disarmed),
                             float(duration), stick, depth_tgt, yaw_tgt, integ, A, lim,
                             thr_tab[pos], pwm_tab[pos], thr_tab[neg], pwm_tab[neg], TT, OO, ka,
                             P_thr, A_thr, wake, B, teth, p, X, PWM, V)
        i = max(j, i + 1)
    MODE = np.array(MODES, object)[mode]
    ARM = t >= disarmed
    euler = quat_to_euler(X[:, 3:7])
    yaw_true = np.unwrap(euler[:, 2])
    roll_pitch = euler[:, :2]
    # ---- logging at each channel's own rate
    hz = {"depth": 3.0, "yaw": 20.0, "pwm": pwm_rate, "battery": 1.0, **(rates or {})}
    t_d = _stamps(rng, 0.0, duration, hz["depth"], jitter)
    t_y = _stamps(rng, 0.0, duration, hz["yaw"], jitter)
    t_p = _stamps(rng, 0.0, duration, hz["pwm"], jitter)
    t_b = _stamps(rng, 0.0, duration, hz["battery"], jitter)
    depth = np.interp(t_d, t, X[:, 2]) + depth_noise * rng.standard_normal(t_d.size)
    yaw = np.interp(t_y, t, yaw_true) + yaw_noise * rng.standard_normal(t_y.size)
    yaw = (yaw + np.pi) % (2 * np.pi) - np.pi  # logged wrapped, like ATTITUDE.yaw
    idx_p = np.clip(np.searchsorted(t, t_p, side="right") - 1, 0, n)
    pwm_l = PWM[idx_p]
    batt = np.interp(t_b, t, V) + 0.02 * rng.standard_normal(t_b.size)
    v_at_p = np.interp(t_p, t_b, batt)
    T_l = np.stack([t200.thrust(pwm_l[:, j], v_at_p) for j in range(n_thr)], axis=1)
    W_l = T_l @ B.T
    t_v = _stamps(rng, 0.0, duration, 5.0, jitter) if dvl else np.zeros(0)
    stamps = np.unique(np.concatenate([t_d, t_y, t_p, t_b, t_v]))
    df = pd.DataFrame({"t_s": stamps})
    idx = {nm: np.searchsorted(stamps, ts) for nm, ts in (("d", t_d), ("y", t_y), ("p", t_p),
                                                        ("b", t_b))}

    def col(key, vals):
        c = np.full(stamps.size, np.nan)
        c[idx[key]] = vals
        return c

    df["depth_m"] = col("d", depth)
    df["yaw_rad"] = col("y", yaw)
    df["roll_rad"] = col("y", np.interp(t_y, t, roll_pitch[:, 0]))
    df["pitch_rad"] = col("y", np.interp(t_y, t, roll_pitch[:, 1]))
    df["battery_V"] = col("b", batt)
    if dvl:
        idx["v"] = np.searchsorted(stamps, t_v)
        for c, j in (("u_mps", 7), ("v_mps", 8)):
            df[c] = col("v", np.interp(t_v, t, X[:, j]) + 0.01 * rng.standard_normal(t_v.size))
    for j in range(n_thr):
        df[f"pwm_{j + 1}"] = col("p", pwm_l[:, j])
    for k, c in enumerate(DOF_COLUMNS):
        df[c] = col("p", W_l[:, k])
    ii = np.clip(np.searchsorted(t, stamps, side="right") - 1, 0, n)
    df["mode"] = MODE[ii]
    df["armed"] = ARM[ii]
    return df, dive_truth(veh, tether, ka)


@njit(cache=True)
def _horizontal_inflow_steps(x, TAU, OM, ka, pos, axes, wake, B, p, h, X):
    """RK4 steps of :func:`uuvid.vehicle.model.vehicle_rhs` for :func:`synthetic_horizontal_dive`
    with inflow: the bollard wrench ``TAU[i]`` held over step i, less ``B (k_a |Ω_i| u_a,i)`` with
    the advance speeds ``u_a`` (:func:`uuvid.thruster.inflow.advance_speeds_nb`) at each stage's
    velocity; heave, roll and pitch forces zero (only X, Y, N act).  ``x`` is advanced in place,
    ``X[i + 1]`` records it."""
    n_thr = B.shape[1]
    ua = np.zeros(n_thr)
    tau6 = np.zeros(6)
    z = np.zeros(13)
    ks = np.zeros((4, 13))
    for i in range(TAU.shape[0] - 1):
        for s in range(4):
            _stage_point(x, ks, s, h, z)
            advance_speeds_nb(z[7:13], pos, axes, wake, ua)
            for m in range(6):
                acc = TAU[i, m]
                for j in range(n_thr):
                    acc -= B[m, j] * ka * OM[i, j] * ua[j]
                tau6[m] = acc
            tau6[2] = tau6[3] = tau6[4] = 0.0
            d = vehicle_rhs(z, tau6, p)
            for m in range(13):
                ks[s, m] = d[m]
        for m in range(13):
            x[m] = x[m] + h / 6 * (ks[0, m] + 2 * ks[1, m] + 2 * ks[2, m] + ks[3, m])
        normalise_state(x)
        for m in range(13):
            X[i + 1, m] = x[m]


def _edge_shifted(model, edges):
    """``thrust(pwm, volts)`` of ``model`` with its dead band moved to ``edges`` = (rev, fwd) µs
    *only* inside the model's edge region (:meth:`uuvid.io.dive_channels.ThrustRegions.
    edge_region`): commands there are mapped linearly so that the truth starts to push at the
    new edge and meets the model at the region's outer end; outside it truth = model."""
    from uuvid.io.dive_channels import thrust_regions

    reg = thrust_regions(model)
    lo, hi = reg.edge_region()
    e_rev, e_fwd = edges

    def thrust(pwm, volts):
        c = np.asarray(pwm, float).copy()
        f = (c > e_fwd) & (c < hi)
        c[f] = reg.edge_fwd + (c[f] - e_fwd) * (hi - reg.edge_fwd) / (hi - e_fwd)
        r = (c < e_rev) & (c > lo)
        c[r] = reg.edge_rev - (e_rev - c[r]) * (reg.edge_rev - lo) / (e_rev - lo)
        mid = (np.asarray(pwm, float) >= e_rev) & (np.asarray(pwm, float) <= e_fwd)
        return np.where(mid, 0.0, model.thrust(c, volts))

    return thrust


def horizontal_truth_vehicle(vehicle="bluerov2", added=(1.4, 1.2, 1.5),
                             extra_linear=(3.0, 2.0, 0.1), extra_quadratic=(0.0, 6.0, 0.5)):
    """The vehicle a synthetic horizontal dive flies: ``vehicle`` with its centre of gravity at
    the origin and ``W = B`` (so the 6-DOF model stays in the horizontal plane), its surge/sway/yaw
    added mass scaled by ``added`` and extra drag (a tether) — so the base vehicle is not the
    truth.  Returns ``(Vehicle, VehicleParams)``."""
    from dataclasses import replace

    from uuvid.vehicle.definition import load_vehicle

    veh = load_vehicle(vehicle) if isinstance(vehicle, str) else vehicle
    p = veh.params
    MA = np.array(p.added_mass)
    DL = np.array(p.linear_damping)
    DQ = np.array(p.quadratic_damping)
    for j, i in enumerate((0, 1, 5)):
        MA[i, i] *= added[j]
        DL[i, i] += extra_linear[j]
        DQ[i, i] += extra_quadratic[j]
    pt = replace(p, r_g=np.zeros(3), r_b=np.zeros(3), weight=p.buoyancy, added_mass=MA,
                 linear_damping=DL, quadratic_damping=DQ)
    return veh, pt


def synthetic_horizontal_dive(duration: float = 120.0, seed: int = 0, vehicle="bluerov2", *,
                              dvl_rate: float = 6.0, yaw_rate: float = 20.0,
                              pwm_rate: float = 10.0, dvl_noise: float = 0.01,
                              yaw_noise: float = 0.005, truth_dead_band=None,
                              jitter: float = 0.2, turning: float = 1.0,
                              inflow_coefficient: float = 0.0):
    """``(table, truth)``: a dive in the horizontal plane flown by the project's 6-DOF model
    (:func:`uuvid.vehicle.model.vehicle_rhs`, RK4 at 50 Hz) with the vehicle of
    :func:`horizontal_truth_vehicle`; ``truth`` is its :class:`~uuvid.vehicle.horizontal.
    HorizontalParams` as a dict (biases 0).

    A pilot holds surge, sway and yaw sticks for 2–6 s at a time (often surging while turning,
    ``turning`` scales the yaw stick); ArduSub-like, each thruster's command is linear in its
    share of the wanted wrench, ``pwm = 1500 + 400 T/T_max`` (no dead-band compensation, so
    small commands sit in the dead band), reaching the thrusters through a 0.15 s lag.  The
    thrust is the shipped T200 model at the sagging battery voltage — or, with
    ``truth_dead_band=(rev, fwd)`` µs, that model with its dead band moved
    (:func:`_edge_shifted`): the log's forces, computed from the PWM with the shipped model,
    are then wrong at the dead band's edge.  Only X, Y, N act (heave, roll, pitch held).
    Logged: u/v (DVL, ``dvl_rate`` Hz, σ ``dvl_noise``), heading (``yaw_rate`` Hz, wrapped),
    ``pwm_<j>`` (``pwm_rate`` Hz), battery (1 Hz); no force columns (the reader computes them
    from the PWM).

    ``inflow_coefficient`` k_a [N·s²/(rad·m)] > 0: every thruster loses ``k_a |Ω_i| u_a,i`` to
    its advance speed at each RK4 stage (``|Ω_i|`` the T200 model's rotor speed at the PWM and
    battery voltage), as :func:`synthetic_dive` does; ``truth`` then has ``inflow``.  0 (the
    default): bollard thrust, the dive as before."""
    import pandas as pd

    from uuvid.io.ardusub.thrust import default_t200
    from uuvid.simulate.station_keeping import rk4_held
    from uuvid.vehicle.horizontal import horizontal_params
    from uuvid.vehicle.model import P_VC, make_state

    ka = float(inflow_coefficient)
    if not (math.isfinite(ka) and ka >= 0):
        raise ValueError(f"inflow_coefficient must be a finite number >= 0, got {ka!r}")
    rng = np.random.default_rng(seed)
    veh, pt = horizontal_truth_vehicle(vehicle)
    p = pt.to_array()
    B = np.asarray(veh.B, float)
    n_thr = B.shape[1]
    rows = [0, 1, 5]
    A = np.linalg.pinv(B[rows])
    t_max = 40.0
    t200 = default_t200()
    thrust_fn = t200.thrust if truth_dead_band is None else _edge_shifted(t200,
                                                                          truth_dead_band)
    # thrust(pwm, V) tabulated once: whole µs × 0.05 V (linear in V between rows)
    pwm_tab = np.arange(1100.0, 1901.0, 1.0)
    v_tab = np.arange(13.0, 17.0001, 0.05)
    TT = np.stack([thrust_fn(pwm_tab, np.full(pwm_tab.size, v)) for v in v_tab])

    n = int(round(duration / DT))
    t = np.arange(n + 1) * DT
    # the pilot's wrench, held 2–6 s at a time
    want = np.zeros((n + 1, 3))
    s0 = 0.0
    while s0 < duration:
        s1 = s0 + rng.uniform(2, 6)
        stick = np.array([25.0 * rng.uniform(-1, 1) * (rng.random() < 0.75),
                          20.0 * rng.uniform(-1, 1) * (rng.random() < 0.5),
                          3.0 * turning * rng.uniform(-1, 1) * (rng.random() < 0.7)])
        if rng.random() < 0.25:  # fine corrections: commands near the dead band
            stick = stick * 0.08
        want[(t >= s0) & (t < s1)] = stick
        s0 = s1
    from scipy.signal import lfilter

    cmd_want = np.clip(want @ A.T / t_max, -1, 1)
    a_lag = DT / 0.15  # first-order lag, forward Euler at the simulation step
    cmd = lfilter([a_lag], [1.0, -(1.0 - a_lag)], cmd_want, axis=0)
    cmd = np.vstack([np.zeros((1, n_thr)), cmd[:-1]])
    PWM = np.round(1500.0 + 400.0 * cmd)
    V = 16.2 - 1.0 * t / max(duration, 1.0) - 0.005 * np.sum(np.abs(cmd), axis=1) * t_max
    iv = np.clip((V - v_tab[0]) / 0.05, 0.0, v_tab.size - 1.000001)
    kv = iv.astype(int)
    fv = (iv - kv)[:, None]
    ip = np.clip(np.round(PWM - 1100.0).astype(int), 0, pwm_tab.size - 1)
    T = TT[kv[:, None], ip] * (1 - fv) + TT[kv[:, None] + 1, ip] * fv
    TAU = T @ B.T
    TAU[:, 2:5] = 0.0
    x = make_state(rpy=(0, 0, rng.uniform(-np.pi, np.pi)))
    X = np.empty((n + 1, 13))
    X[0] = x
    TAU = np.ascontiguousarray(TAU)
    vc, dvc = np.ascontiguousarray(p[P_VC:P_VC + 3]), np.zeros(3)  # vehicle_rhs's current
    if ka:
        OO = np.stack([np.abs(t200.speed(pwm_tab, np.full(pwm_tab.size, v))) for v in v_tab])
        OM = np.ascontiguousarray(OO[kv[:, None], ip] * (1 - fv) + OO[kv[:, None] + 1, ip] * fv)
        P_thr = np.ascontiguousarray(np.array([t_.position for t_ in veh.layout], float))
        A_thr = np.array([t_.axis for t_ in veh.layout], float)
        A_thr = np.ascontiguousarray(A_thr / np.linalg.norm(A_thr, axis=1)[:, None])
        wake = np.ascontiguousarray(veh.wake if len(veh.wake) else np.zeros(n_thr), float)
        _horizontal_inflow_steps(x, TAU, OM, ka, P_thr, A_thr, wake, np.ascontiguousarray(B),
                                 p, DT, X)
    k1, k2, k3, k4, zt = (np.empty(13) for _ in range(5))
    for i in range(n if not ka else 0):  # one compiled RK4 step of vehicle_rhs per call
        rk4_held(x, TAU[i], p, vc, DT, 1, dvc, k1, k2, k3, k4, zt)
        X[i + 1] = x
    qw, qx, qy, qz = X[:, 3], X[:, 4], X[:, 5], X[:, 6]
    yaw_true = np.unwrap(np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz)))
    t_y = _stamps(rng, 0.0, duration, yaw_rate, jitter)
    t_v = _stamps(rng, 0.0, duration, dvl_rate, jitter)
    t_p = _stamps(rng, 0.0, duration, pwm_rate, jitter)
    t_b = _stamps(rng, 0.0, duration, 1.0, jitter)
    stamps = np.unique(np.concatenate([t_y, t_v, t_p, t_b]))
    df = pd.DataFrame({"t_s": stamps})

    def col(ts, vals):
        c = np.full(stamps.size, np.nan)
        c[np.searchsorted(stamps, ts)] = vals
        return c

    yaw = np.interp(t_y, t, yaw_true) + yaw_noise * rng.standard_normal(t_y.size)
    df["yaw_rad"] = col(t_y, (yaw + np.pi) % (2 * np.pi) - np.pi)
    for c, j in (("u_mps", 7), ("v_mps", 8)):
        df[c] = col(t_v, np.interp(t_v, t, X[:, j]) + dvl_noise * rng.standard_normal(t_v.size))
    df["battery_V"] = col(t_b, np.interp(t_b, t, V) + 0.02 * rng.standard_normal(t_b.size))
    idx_p = np.clip(np.searchsorted(t, t_p, side="right") - 1, 0, n)
    for j in range(n_thr):
        df[f"pwm_{j + 1}"] = col(t_p, PWM[idx_p, j])
    df["armed"] = True
    truth = horizontal_params(pt).to_dict()
    if ka:
        truth["inflow"] = ka
    return df, truth
