"""Compiled numerical core of a thruster chain: block evaluation and a fixed-step RK4.

A chain is flattened into arrays (``kinds``, parameter offsets ``poff`` into one ``params`` vector,
state offsets ``soff``, the output channel of every block ``outch``) so that one numba-compiled
function evaluates any composition of blocks, block after block, like the block diagram it
describes.  The integrator writes into preallocated arrays; nothing is allocated per step.

The input is held constant over each output interval (zero-order hold, as a digital driver
does); inside it, ``nsub`` RK4 steps advance the state.  First-order blocks driven only through
static blocks are advanced exactly (``x ← e^{−h/τ} x + (1 − e^{−h/τ}) u``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from uuvid.thruster.blocks import (
    CH,
    CHANNELS,
    K_BESSA,
    K_DC_MOTOR,
    K_DEADZONE,
    K_ESC,
    K_FIRST_ORDER,
    K_FIRST_ORDER_MOTOR,
    K_HEALEY,
    K_LOAD_CELL,
    K_POLYNOMIAL,
    K_QUADRATIC,
    K_TABLE,
    K_TUNNEL,
    K_YOERGER,
    K_ZERO_ORDER,
)

N_CHANNELS = len(CHANNELS)
_MOTOR_SPEED = CH["motor_speed"]
_PROP_SPEED = CH["prop_speed"]
_TORQUE = CH["torque"]
_CURRENT = CH["current"]
_VOLTAGE = CH["voltage"]
STICK_SPEED = 1e-3  # rad/s: below this a shaft with Coulomb friction may stick (Karnopp model)


@njit(cache=True, inline="always")
def esc_output(params, pb, cmd):
    """The ESC block's output for command ``cmd`` (its parameters at ``params[pb:]``)."""
    return _esc(params, pb, cmd)


@njit(cache=True, inline="always")
def _esc(params, pb, cmd):
    c = min(max(cmd, params[pb + 6]), params[pb + 7])
    if c > params[pb + 5]:
        v = params[pb + 0] * c + params[pb + 1]
        v = v * (1.0 + params[pb + 9] * (abs(v) / params[pb + 8] - 1.0))
    elif c < params[pb + 4]:
        v = params[pb + 2] * c + params[pb + 3]
        v = v * (1.0 + params[pb + 10] * (abs(v) / params[pb + 8] - 1.0))
    else:
        v = 0.0
    return min(max(v, -params[pb + 8]), params[pb + 8])


@njit(cache=True, inline="always")
def _motor(kind, params, pb, x, s, nst, volts, dx, ch):
    """DC motor + gear (+ tunnel water): writes dx, channels, returns the block output."""
    kt, kg, r, ind, jm, jp, cm, cp, tc, n = (
        params[pb + 0],
        params[pb + 1],
        params[pb + 2],
        params[pb + 3],
        params[pb + 4],
        params[pb + 5],
        params[pb + 6],
        params[pb + 7],
        params[pb + 8],
        params[pb + 9],
    )
    w = x[s]
    if nst == 2:
        i = x[s + 1]
        dx[s + 1] = (volts - r * i - kg * w) / ind
    else:
        i = (volts - kg * w) / r
    wp = w / n
    j = jm + jp / (n * n)
    cv = cm + cp / (n * n)
    mf = 0.0
    pe = 0.0
    if kind == K_TUNNEL:
        rho = params[pb + 10]
        area = params[pb + 11]
        pe = params[pb + 14]
        beta = params[pb + 15]
        dalpha = params[pb + 16]
        dbeta = params[pb + 17]
        mf = rho * area * params[pb + 12] * (1.0 + params[pb + 13])  # ρ A L (1 + K_a)
        j += beta * mf * pe * pe / (n * n)
        q_static = 0.5 * rho * area * dalpha * pe * pe * pe * wp * abs(wp)
    else:
        q_static = (params[pb + 10] if wp >= 0.0 else params[pb + 11]) * wp * abs(wp)
    drive = kt * i - cv * w - q_static / n
    if abs(w) < STICK_SPEED and tc > 0.0:
        if abs(drive) <= tc:
            fr = drive
        else:
            fr = tc if drive > 0 else -tc
    elif tc > 0.0:
        fr = tc if w > 0 else -tc
    else:
        fr = 0.0
    wdot = (drive - fr) / j
    dx[s] = wdot
    wpdot = wdot / n
    ch[_MOTOR_SPEED] = w
    ch[_PROP_SPEED] = wp
    ch[_CURRENT] = i
    if kind == K_TUNNEL:
        ch[_TORQUE] = beta * mf * pe * pe * wpdot + q_static
        return mf * pe * wpdot + rho * area * pe * pe * dbeta * wp * abs(wp)
    ch[_TORQUE] = q_static
    return wp


@njit(cache=True, inline="always")
def _healey(params, pb, x, s, volts, dx, ch):
    """Healey et al. 1995 two-state thruster (see ``HealeyThruster``): writes dx, channels,
    returns the thrust."""
    w = x[s]
    ua = x[s + 1]
    aw = abs(w)
    kt = params[pb + 5] if w >= 0.0 else params[pb + 6]
    thrust = kt * w * aw - params[pb + 7] * aw * ua
    torque = params[pb + 3] * w * aw - params[pb + 4] * aw * ua
    dx[s] = (params[pb + 1] * volts - params[pb + 2] * w - torque) / params[pb + 0]
    dx[s + 1] = (thrust - params[pb + 9] * ua * abs(ua)) / params[pb + 8]
    ch[_MOTOR_SPEED] = w
    ch[_PROP_SPEED] = w
    ch[_TORQUE] = torque
    return thrust


@njit(cache=True, inline="always")
def _polyval(p, start, count, x):
    y = 0.0
    for k in range(count):
        y = y * x + p[start + k]
    return y


@njit(cache=True, inline="always")
def _table(params, pb, x):
    n = int(params[pb + 0])
    if x <= params[pb + 1]:
        return params[pb + 1 + n]
    if x >= params[pb + n]:
        return params[pb + 2 * n]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if params[pb + 1 + mid] <= x:
            lo = mid
        else:
            hi = mid
    x0 = params[pb + 1 + lo]
    x1 = params[pb + 1 + hi]
    y0 = params[pb + 1 + n + lo]
    y1 = params[pb + 1 + n + hi]
    return y0 + (y1 - y0) * (x - x0) / (x1 - x0)


@njit(cache=True)
def eval_chain_at(kinds, poff, params, po, soff, outch, in_ch, x, xo, cmd, dx, ch, blk_in, bo, start=0):
    """Evaluate every block once: fills ``dx`` (state derivatives) and ``ch`` (channels).

    Offsets instead of slices (``params[po:]``, ``x[xo:]``/``dx[xo:]``, ``blk_in[bo:]``) so that a
    vehicle loop can evaluate many thrusters stored in flat arrays without creating views.  With
    ``start > 0`` evaluation begins at block ``start`` and ``cmd`` is that block's input (a loop
    that holds the command over a step evaluates the static blocks in front once)."""
    for k in range(ch.size):
        ch[k] = np.nan
    ch[0] = cmd
    if in_ch > 0:
        ch[in_ch] = cmd
    sig = cmd
    for b in range(start, kinds.size):
        kind = kinds[b]
        pb = po + poff[b]
        s = xo + soff[b]
        nst = soff[b + 1] - soff[b]
        blk_in[bo + b] = sig
        if kind == K_ESC:
            sig = _esc(params, pb, sig)
        elif kind == K_FIRST_ORDER_MOTOR:
            dx[s] = (params[pb + 0] * sig - x[s]) / params[pb + 1]
            sig = x[s]
            ch[_MOTOR_SPEED] = sig
        elif kind == K_DC_MOTOR or kind == K_TUNNEL:
            ch[_VOLTAGE] = sig
            sig = _motor(kind, params, pb, x, s, nst, sig, dx, ch)
        elif kind == K_QUADRATIC:
            a = sig * abs(sig)
            if sig >= 0.0:
                if params[pb + 2] > 0.0:
                    ch[_TORQUE] = params[pb + 2] * a
                sig = params[pb + 0] * a
            else:
                if params[pb + 3] > 0.0:
                    ch[_TORQUE] = params[pb + 3] * a
                sig = params[pb + 1] * a
        elif kind == K_POLYNOMIAL:
            nf = int(params[pb + 0])
            nr = int(params[pb + 1])
            if sig > 0.0:
                sig = _polyval(params, pb + 2, nf, sig)
            elif sig < 0.0:
                sig = -_polyval(params, pb + 2 + nf, nr, -sig)
            else:
                sig = 0.0
        elif kind == K_DEADZONE:
            a = sig * abs(sig)
            if a <= params[pb + 2]:
                sig = params[pb + 0] * (a - params[pb + 2])
            elif a >= params[pb + 3]:
                sig = params[pb + 1] * (a - params[pb + 3])
            else:
                sig = 0.0
        elif kind == K_TABLE:
            sig = _table(params, pb, sig)
        elif kind == K_ZERO_ORDER:
            pass
        elif kind == K_FIRST_ORDER:
            dx[s] = (sig - x[s]) / params[pb + 0]
            sig = x[s]
        elif kind == K_YOERGER:
            dx[s] = params[pb + 1] * sig - params[pb + 0] * x[s] * abs(x[s])
            sig = x[s]
        elif kind == K_BESSA:
            dx[s] = (
                sig * params[pb + 3] / params[pb + 4]
                - params[pb + 1] * x[s]
                - params[pb + 2] * x[s] * abs(x[s])
            ) / params[pb + 0]
            sig = x[s]
        elif kind == K_HEALEY:
            sig = _healey(params, pb, x, s, sig, dx, ch)
        elif kind == K_LOAD_CELL:
            wn = params[pb + 0]
            dx[s] = x[s + 1]
            dx[s + 1] = wn * wn * (sig - x[s]) - 2.0 * params[pb + 1] * wn * x[s + 1]
            sig = x[s]
        ch[outch[b]] = sig
    return sig


@njit(cache=True)
def interp_sorted(xs, ys, x):
    """Linear interpolation in a table with strictly increasing ``xs``, end values held."""
    n = xs.size
    if x <= xs[0]:
        return ys[0]
    if x >= xs[n - 1]:
        return ys[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    return ys[lo] + (ys[hi] - ys[lo]) * (x - xs[lo]) / (xs[hi] - xs[lo])


@njit(cache=True, inline="always")
def interp_sorted_from(xs, ys, x, j):
    """:func:`interp_sorted` starting its search at interval ``j`` (a loop that reads one table
    every step keeps the previous interval: the value moves little, so a few comparisons find
    it instead of a full binary search); returns ``(value, interval)``.  The same interval and
    formula as :func:`interp_sorted`, so the same value."""
    n = xs.size
    if x <= xs[0]:
        return ys[0], j
    if x >= xs[n - 1]:
        return ys[n - 1], j
    lo = min(max(j, 0), n - 2)
    for _ in range(4):  # walk from the guess: xs[lo] <= x < xs[lo + 1]
        if xs[lo] > x:
            lo -= 1
        elif xs[lo + 1] <= x:
            lo += 1
        else:
            return ys[lo] + (ys[lo + 1] - ys[lo]) * (x - xs[lo]) / (xs[lo + 1] - xs[lo]), lo
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    return ys[lo] + (ys[hi] - ys[lo]) * (x - xs[lo]) / (xs[hi] - xs[lo]), lo


@njit(cache=True, inline="always")
def eval_chain_prefix(kinds, poff, params, po, cmd, blk_in, bo, stop):
    """Output of the static blocks ``0 … stop−1`` (no states) for input ``cmd``."""
    sig = cmd
    for b in range(stop):
        blk_in[bo + b] = sig
        sig = _static_block(kinds[b], params, po + poff[b], sig)
    return sig


@njit(cache=True, inline="always")
def eval_static_range(kinds, poff, params, po, sig, b0, b1):
    """Output of the static blocks ``b0 … b1−1`` for input ``sig``."""
    for b in range(b0, b1):
        sig = _static_block(kinds[b], params, po + poff[b], sig)
    return sig


@njit(cache=True, inline="always")
def _static_block(kind, params, pb, sig):
    if kind == K_ESC:
        return _esc(params, pb, sig)
    if kind == K_QUADRATIC:
        a = sig * abs(sig)
        return (params[pb + 0] if sig >= 0.0 else params[pb + 1]) * a
    if kind == K_POLYNOMIAL:
        nf = int(params[pb + 0])
        nr = int(params[pb + 1])
        if sig > 0.0:
            return _polyval(params, pb + 2, nf, sig)
        if sig < 0.0:
            return -_polyval(params, pb + 2 + nf, nr, -sig)
        return 0.0
    if kind == K_DEADZONE:
        a = sig * abs(sig)
        if a <= params[pb + 2]:
            return params[pb + 0] * (a - params[pb + 2])
        if a >= params[pb + 3]:
            return params[pb + 1] * (a - params[pb + 3])
        return 0.0
    if kind == K_TABLE:
        return _table(params, pb, sig)
    return sig


@njit(cache=True)
def eval_chain(kinds, poff, params, soff, outch, in_ch, x, cmd, dx, ch, blk_in):
    """Evaluate every block once: fills ``dx`` (state derivatives) and ``ch`` (channels)."""
    o = np.int64(0)  # not the literal 0, and ``start`` given: eval_chain_at is compiled once, for
    # the signature the loops call it with (an omitted ``start`` is a type of its own: ≈ 2 s)
    return eval_chain_at(kinds, poff, params, o, soff, outch, in_ch, x, o, cmd, dx, ch, blk_in, o, o)


@njit(cache=True)
def _exact_first_order(kinds, poff, params, soff, exact, x_old, x_new, blk_in, h):
    for b in range(kinds.size):
        if exact[b]:
            s = soff[b]
            p = params[poff[b] : poff[b + 1]]
            if kinds[b] == K_FIRST_ORDER_MOTOR:
                target = p[0] * blk_in[b]
                tau = p[1]
            else:
                target = blk_in[b]
                tau = p[0]
            e = math.exp(-h / tau)
            x_new[s] = e * x_old[s] + (1.0 - e) * target


@njit(cache=True)
def _stick(kinds, poff, params, soff, x_old, x_new, blk_in, h):
    """Coulomb stick–slip at step level (Karnopp): a shaft whose speed crosses zero during a step,
    or ends it within the speed change Coulomb friction alone makes in one step (``h T_c/J``),
    stops there if the driving torque at rest cannot overcome the Coulomb torque."""
    for b in range(kinds.size):
        if kinds[b] == K_DC_MOTOR or kinds[b] == K_TUNNEL:
            p = params[poff[b] : poff[b + 1]]
            tc = p[8]
            if tc <= 0.0:
                continue
            s = soff[b]
            n = p[9]
            j = p[4] + p[5] / (n * n)
            if kinds[b] == K_TUNNEL:
                j += p[15] * p[10] * p[11] * p[12] * (1.0 + p[13]) * p[14] * p[14] / (n * n)
            band = h * tc / j
            w0 = x_old[s]
            w1 = x_new[s]
            if w0 * w1 < 0.0 or abs(w1) < band:
                if soff[b + 1] - s == 2:
                    drive0 = p[0] * x_new[s + 1]
                else:
                    drive0 = p[0] * blk_in[b] / p[2]
                if abs(drive0) <= tc:
                    x_new[s] = 0.0


@njit(cache=True, nogil=True)
def rk4_chain(kinds, poff, params, soff, outch, in_ch, exact, x0, u, dt, nsub, X, C):
    """Fixed-step RK4 over the chain; ``u[n]`` is held on ``[n dt, (n+1) dt)``.

    Writes the state ``X[n]`` and channels ``C[n]`` at every sample ``t = n dt`` (preallocated).
    Releases the GIL (a fit's finite-difference columns run in threads).
    """
    nx = x0.size
    nb = kinds.size
    x = x0.copy()
    xt = np.empty(nx)
    xn = np.empty(nx)
    k1 = np.zeros(nx)
    k2 = np.zeros(nx)
    k3 = np.zeros(nx)
    k4 = np.zeros(nx)
    ch = np.empty(C.shape[1])
    blk_in = np.empty(max(nb, 1))
    blk_tmp = np.empty(max(nb, 1))
    h = dt / nsub
    nsamp = u.size
    for n in range(nsamp):
        eval_chain(kinds, poff, params, soff, outch, in_ch, x, u[n], k1, ch, blk_in)
        for i in range(nx):
            X[n, i] = x[i]
        for i in range(ch.size):
            C[n, i] = ch[i]
        if n == nsamp - 1:
            break
        un = u[n]
        for _ in range(nsub):
            eval_chain(kinds, poff, params, soff, outch, in_ch, x, un, k1, ch, blk_in)
            for i in range(nx):
                xt[i] = x[i] + 0.5 * h * k1[i]
            eval_chain(kinds, poff, params, soff, outch, in_ch, xt, un, k2, ch, blk_tmp)
            for i in range(nx):
                xt[i] = x[i] + 0.5 * h * k2[i]
            eval_chain(kinds, poff, params, soff, outch, in_ch, xt, un, k3, ch, blk_tmp)
            for i in range(nx):
                xt[i] = x[i] + h * k3[i]
            eval_chain(kinds, poff, params, soff, outch, in_ch, xt, un, k4, ch, blk_tmp)
            for i in range(nx):
                xn[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            # blk_in (stage 1) holds each block's input at the step start
            _exact_first_order(kinds, poff, params, soff, exact, x, xn, blk_in, h)
            _stick(kinds, poff, params, soff, x, xn, blk_in, h)
            for i in range(nx):
                x[i] = xn[i]


@njit(cache=True, parallel=True)
def rk4_chain_batch(kinds, poff, params_batch, soff, outch, in_ch, exact, x0, u, dt, nsub, out_channel, Y):
    """Many chains with different parameters (rows of ``params_batch``) under one input.

    Writes one channel (``out_channel``) of every run into ``Y[run, sample]``.
    """
    nrun = params_batch.shape[0]
    nsamp = u.size
    for r in prange(nrun):
        X = np.empty((nsamp, x0.size))
        C = np.empty((nsamp, N_CHANNELS))
        rk4_chain(kinds, poff, params_batch[r], soff, outch, in_ch, exact, x0, u, dt, nsub, X, C)
        for n in range(nsamp):
            Y[r, n] = C[n, out_channel]


@njit(cache=True)
def _sweep_level(kinds, poff, params, soff, outch, in_ch, exact, X0, u_levels, dt, nsamp, finals, XF, r):
    """Level ``r`` of :func:`sweep_chain`."""
    nx = X0.shape[1]
    u = np.full(nsamp, u_levels[r])
    X = np.empty((nsamp, nx))
    C = np.empty((nsamp, N_CHANNELS))
    rk4_chain(kinds, poff, params, soff, outch, in_ch, exact, X0[r], u, dt, np.int64(1), X, C)
    for i in range(N_CHANNELS):
        finals[r, i] = C[nsamp - 1, i]
    for i in range(nx):
        XF[r, i] = X[nsamp - 1, i]


@njit(cache=True, parallel=True)
def sweep_chain(kinds, poff, params, soff, outch, in_ch, exact, X0, u_levels, dt, nsamp, finals, XF):
    """Hold each constant input of ``u_levels`` for ``nsamp`` samples from its initial state
    ``X0[level]``; store the final channels in ``finals[level]`` and the final state in
    ``XF[level]`` (a steady-state sweep, one parallel run per level; :func:`sweep_chain_serial`:
    the same, one level after another)."""
    for r in prange(u_levels.size):
        _sweep_level(kinds, poff, params, soff, outch, in_ch, exact, X0, u_levels, dt, nsamp, finals, XF,
                     r)


@njit(cache=True)
def sweep_chain_serial(kinds, poff, params, soff, outch, in_ch, exact, X0, u_levels, dt, nsamp, finals,
                       XF):
    """:func:`sweep_chain` on one thread: compiles in a fraction of the parallel loop's time
    (numba's parallel passes), for sweeps too short to pay for it (:func:`parallel_pays`)."""
    for r in range(u_levels.size):
        _sweep_level(kinds, poff, params, soff, outch, in_ch, exact, X0, u_levels, dt, nsamp, finals, XF,
                     r)


#: A prange kernel takes this many RK4 steps (all its runs together) or more before its threads pay
#: for what they cost: ≈ 1–3 s more compiling on a first run (numba's parallel passes) and a
#: thread pool's start; below it (≈ 0.1 s of work) one thread finishes first.
PARALLEL_MIN_STEPS = 1_000_000


def parallel_pays(runs: int, steps_per_run: int) -> bool:
    """Whether a batch of ``runs`` independent runs of ``steps_per_run`` steps each should use the
    parallel kernel: more than one run, more than one numba thread (a demo or Monte Carlo worker
    runs with one) and at least :data:`PARALLEL_MIN_STEPS` steps in all."""
    if runs < 2 or runs * steps_per_run < PARALLEL_MIN_STEPS:
        return False
    import numba

    return numba.get_num_threads() > 1


@njit(cache=True)
def relative_rates(kinds, poff, params, soff, outch, in_ch, X, u, floor, out):
    """``max_i |ẋ_i| / (|x_i| + floor)`` at each row of ``X`` under input ``u[row]`` (how fast a
    swept level is still moving, relative to where it is; one thread: a few microseconds a row)."""
    n = X.shape[0]
    nx = X.shape[1]
    for r in range(n):
        dx = np.zeros(nx)
        ch = np.empty(N_CHANNELS)
        blk = np.empty(max(kinds.size, 1))
        eval_chain(kinds, poff, params, soff, outch, in_ch, X[r], u[r], dx, ch, blk)
        m = 0.0
        for i in range(nx):
            v = abs(dx[i]) / (abs(X[r, i]) + floor)
            if v > m:
                m = v
        out[r] = m
