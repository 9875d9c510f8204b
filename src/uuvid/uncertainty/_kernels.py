"""Compiled batch of thruster step responses that returns McLean's step metrics per run.

:meth:`uuvid.thruster.chain.ThrusterChain.simulate_batch` returns one channel per call; a step
metric row needs three (true thrust, measured thrust, propeller speed).  This kernel integrates
each run once with the chain's own RK4 (:func:`uuvid.thruster.kernels.rk4_chain`, so the numbers
are those of :meth:`ThrusterChain.simulate`) and reduces the channels to the metrics of
:func:`uuvid.core.metrics.step_response_metrics` inside the parallel loop, so a 10,000-run
sweep never holds 10,000 time series.  The reductions repeat the definitions of
:mod:`uuvid.core.metrics` line for line (steady window mean, signed peak, 63.2 % rise with
linear interpolation, 36.8 % decay from the peak); a test checks them against that module.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from uuvid.core.metrics import DECAY_FRACTION, RISE_FRACTION
from uuvid.thruster import kernels
from uuvid.thruster.blocks import CH, CHANNELS

N_CH = len(CHANNELS)
_THRUST = CH["thrust"]
_MEASURED = CH["measured_thrust"]
_SPEED = CH["prop_speed"]

#: Columns of the kernel's output, SI (N, rad/s, s).
STEP_METRICS = ("peak_output_thrust", "max_true_thrust", "steady_thrust", "steady_speed",
                "time_to_peak", "time_constant_speed", "time_constant_decay", "final_thrust")
N_METRICS = len(STEP_METRICS)


@njit(cache=True, inline="always")
def _steady(y, k0):
    s = 0.0
    for i in range(k0, y.size):
        s += y[i]
    return s / (y.size - k0)


@njit(cache=True, inline="always")
def _direction(y, steady):
    if steady != 0.0:
        return 1.0 if steady > 0.0 else -1.0
    best = 0
    for i in range(y.size):
        if abs(y[i]) > abs(y[best]):
            best = i
    return -1.0 if y[best] < 0.0 else 1.0


@njit(cache=True, inline="always")
def _argpeak(y, s):
    best = 0
    for i in range(y.size):
        if s * y[i] > s * y[best]:
            best = i
    return best


@njit(cache=True)
def _rise(t, y, final):
    """time_to_fraction(t, y, RISE_FRACTION, final, 0)."""
    span = final
    if span == 0.0 or not math.isfinite(span):
        return math.nan
    s = 1.0 if span > 0.0 else -1.0
    target = RISE_FRACTION * abs(span)
    for i in range(y.size):
        if s * y[i] >= target:
            if i == 0:
                return 0.0
            v0 = s * y[i - 1]
            v1 = s * y[i]
            return t[i - 1] + (target - v0) / (v1 - v0) * (t[i] - t[i - 1]) - t[0]
    return math.nan


@njit(cache=True)
def _decay(t, y, steady, t_window):
    """time_constant_decay(t, y, steady) with the steady window starting at ``t_window``."""
    s = _direction(y, steady)
    p = _argpeak(y, s)
    height = s * (y[p] - steady)
    if not height > 0.0:
        return math.nan
    if t[p] >= t_window:
        return math.nan
    target = DECAY_FRACTION * height
    for i in range(p + 1, y.size):
        vi = s * (y[i] - steady)
        if vi <= target:
            v0 = s * (y[i - 1] - steady)
            return t[i - 1] + (v0 - target) / (v0 - vi) * (t[i] - t[i - 1]) - t[p]
    return math.nan


@njit(cache=True)
def step_metrics_row(t, true, meas, spd, use_meas, use_speed, k0, t_window, out):
    """The metrics of one recorded step response into ``out`` (see :data:`STEP_METRICS`)."""
    y = meas if use_meas else true
    steady_out = _steady(y, k0)
    s = _direction(y, steady_out)
    p = _argpeak(y, s)
    out[0] = y[p]
    steady_true = _steady(true, k0)
    st = _direction(true, steady_true)
    out[1] = true[_argpeak(true, st)]
    out[2] = steady_out
    out[4] = t[p] - t[0]
    out[6] = _decay(t, y, steady_out, t_window)
    if use_speed:
        ss = _steady(spd, k0)
        out[3] = ss
        out[5] = _rise(t, spd, ss)
    else:
        out[3] = math.nan
        out[5] = math.nan
    out[7] = y[y.size - 1]


@njit(cache=True)
def _step_metrics_run(kinds, poff, P, soff, outch, in_ch, exact, x0, U, uidx, dt, nsub, t, k0,
                      t_window, use_meas, use_speed, OUT, FINITE, r):
    """Run ``r`` of :func:`step_metrics_batch`."""
    n = U.shape[1]
    nx = x0.size
    X = np.empty((n, nx))
    C = np.empty((n, N_CH))
    kernels.rk4_chain(kinds, poff, P[r], soff, outch, in_ch, exact, x0, U[uidx[r]], dt, nsub, X, C)
    ok = True
    for i in range(n):
        for j in range(nx):
            if not math.isfinite(X[i, j]):
                ok = False
                break
        if not ok:
            break
    FINITE[r] = ok
    if not ok:
        for j in range(OUT.shape[1]):
            OUT[r, j] = math.nan
        return
    true = np.ascontiguousarray(C[:, _THRUST])
    meas = np.ascontiguousarray(C[:, _MEASURED]) if use_meas else true
    spd = np.ascontiguousarray(C[:, _SPEED]) if use_speed else true
    step_metrics_row(t, true, meas, spd, use_meas, use_speed, k0, t_window, OUT[r])


@njit(cache=True, parallel=True)
def step_metrics_batch(kinds, poff, P, soff, outch, in_ch, exact, x0, U, uidx, dt, nsub, t, k0,
                       t_window, use_meas, use_speed, OUT, FINITE):
    """Simulate run ``r`` (parameters ``P[r]``, input ``U[uidx[r]]``) from ``x0`` and write its
    step metrics to ``OUT[r]``; ``FINITE[r]`` is False when the state left the finite numbers.
    One run per thread; :func:`step_metrics_serial`: the same on one thread."""
    for r in prange(P.shape[0]):
        _step_metrics_run(kinds, poff, P, soff, outch, in_ch, exact, x0, U, uidx, dt, nsub, t, k0,
                          t_window, use_meas, use_speed, OUT, FINITE, r)


@njit(cache=True)
def step_metrics_serial(kinds, poff, P, soff, outch, in_ch, exact, x0, U, uidx, dt, nsub, t, k0,
                        t_window, use_meas, use_speed, OUT, FINITE):
    """:func:`step_metrics_batch` one run after another: compiles in a fraction of its time, for
    batches too small to pay for threads (:func:`uuvid.thruster.kernels.parallel_pays`)."""
    for r in range(P.shape[0]):
        _step_metrics_run(kinds, poff, P, soff, outch, in_ch, exact, x0, U, uidx, dt, nsub, t, k0,
                          t_window, use_meas, use_speed, OUT, FINITE, r)


@njit(cache=True, parallel=True)
def one_dof_step_batch(m, k, kq, force, dt, nsub, V):
    """Velocity of Caccia's 1-DOF model ``m ξ̇ = −k ξ − k_q ξ|ξ| + F`` from rest under a constant
    force, RK4 with ``nsub`` steps per sample; ``V[r, i]`` at ``t = i·dt``."""
    nrun, n = V.shape
    h = dt / nsub
    for r in prange(nrun):
        x = 0.0
        V[r, 0] = 0.0
        for i in range(1, n):
            for _ in range(nsub):
                k1 = (force[r] - k[r] * x - kq[r] * x * abs(x)) / m[r]
                xa = x + 0.5 * h * k1
                k2 = (force[r] - k[r] * xa - kq[r] * xa * abs(xa)) / m[r]
                xb = x + 0.5 * h * k2
                k3 = (force[r] - k[r] * xb - kq[r] * xb * abs(xb)) / m[r]
                xc = x + h * k3
                k4 = (force[r] - k[r] * xc - kq[r] * xc * abs(xc)) / m[r]
                x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            V[r, i] = x
