"""Many perturbed vehicles flying one mission: a SIMD batch kernel (structure of arrays).

:func:`uuvid.simulate.vehicle_sim.fly_batch` runs one vehicle per thread through the scalar loop
:func:`~uuvid.simulate.vehicle_sim.fly`.  Here the vehicles of a *chunk* (``chunk`` lanes, 32 by
default) advance together, step by step.  Every state, parameter and intermediate is a row
``W[row·chunk + lane]``; each time step is three loops over the lanes, which LLVM compiles to
AVX-512/AVX2 code (one vehicle per vector element):

1. DP controller (errors, PID with anti-windup, attitude hold), allocation with uniform scaling,
   the running summaries, and a check that each thruster's allocated thrust is still inside the
   table interval the lane used last step;
2. (scalar) the lanes that left their interval — a few per cent — find the new one: a grid over
   the thrust axis (or over ``sign(f)√|f|`` for quadratic maps) gives the first candidate, one or
   two binary-lifting steps the interval; vector gathers, which cost about an element per cycle,
   are never used;
3. the inverse thrust maps from the cached intervals, the static prefix (ESC) → first-order target;

then one loop for the RK4 step: thrust of every thruster at the stage times in closed form (the
first-order block under a held command), static suffix, ``τ = B η f``, four 6-DOF right-hand
sides, the exact thruster-state update and the quaternion normalisation.  Chunks are handed to
``numba.get_num_threads()`` threads (the kernel releases the GIL; dynamic scheduling).  Nothing is
stored per time step: only the running summaries (and, on request, a decimated trajectory of a
few runs).

**Same numbers as** :func:`~uuvid.simulate.vehicle_sim.fly`: the kernel evaluates the same
expressions in the same order, so every vehicle agrees with ``fly()`` to rounding (≈1e-15
relative on the summaries, ≈1e-16 on the trajectory).  The differences: structural zeros are
skipped (they only ever added ±0), ``atan2``/``asin`` are branch-free (Cephes' rational ``atan``,
≤ 2 ulp from libm) and ``(a + π) mod 2π`` is done by selects (exact on the range the controller
produces).  ``fastmath={"contract"}`` (FMA) is available; it moves results by ~1e-14 and is not
faster here, so the default is plain IEEE arithmetic — deterministic, independent of the lane or
chunk a vehicle sits in.  The lane loops read and write rows of flat arrays at
literal offsets, so LLVM proves the rows independent and vectorises them (one run-time overlap
check between the workspace and the parameter array per loop).

**Specialisation.**  The kernel source is generated for the *structure* of a batch and compiled
once per structure (≈7 s; the generated module lives in a cache directory so that numba's disk
cache works — later processes load it in ≈0.1 s): the number of thrusters, the blocks of the
thruster chain, the sparsity pattern (union over the batch) of ``M_RB``, ``M_A``, ``D_L``,
``D_Q``, ``(M_RB + M_A)⁻¹``, the thrust configuration and allocation matrices, whether there is a
current and whether attitude hold is on.  Diagonal added mass and damping (the presets) thus give
a short right-hand side; full 36-value matrices take the general form of the same generator.
Values (parameters, gains, limits, tables) are run-time data: perturbing them needs no
recompilation.  Cache directory: ``$UUVID_KERNEL_CACHE``, else ``~/.cache/uuvid/batch_kernels``.

**Thruster chains handled:** a static prefix, one exact first-order block (``FirstOrder`` thrust
lag or ``FirstOrderMotor``), a static suffix — e.g. the ``t200`` preset ESC → first-order motor →
quadratic map — and purely static chains (thrust = map(command), e.g. ROMEO's ``c_V V|V|``).
Static blocks: ESC, quadratic, polynomial, dead zone, zero-order.  Anything else (DC motors,
tunnel thrusters, load cells, tables) falls back to :func:`~uuvid.simulate.vehicle_sim.fly_batch`.

**Inflow** (issue 21, a setup with ``inflow='four-quadrant'``): at every RK4 stage each lane
takes the bollard thrust of the first-order chain to the advance speed of that stage's own state,
``u_a = (1 − w) axisᵀ(v_r + ω × r)``, through the four-quadrant map — the expressions of
:func:`uuvid.vehicle.inflow.state_advance_speeds_nb` and
:func:`uuvid.thruster.inflow.inflow_thrust_nb` (the mission loop's
:func:`~uuvid.simulate.vehicle_sim._vehicle_rk4_inflow`), with the thruster geometry as shared
values and ``C_T*(β)`` summed by Clenshaw's recurrence in fused multiply-adds
(:func:`uuvid.core.fused.fma`, exactly where written: no ``fastmath``; ``fly()`` reads the same
series from a cubic table, within 1e-11 of it: a table gather would stop the lanes'
vectorisation), so every lane agrees with ``fly()`` to ~1e-11.  A static chain with inflow flies
:func:`~uuvid.simulate.vehicle_sim.fly_batch`.

**User controllers.**  A numba-compiled :class:`~uuvid.simulate.control.blocks.Controller` with
``output="wrench"`` takes the place of the inline PID: each step a scalar loop gathers a lane's
state into small arrays, calls the controller (a module global of the generated kernel, so numba
compiles it in as a direct call) with that lane's own controller state, and stores the wrench
in the workspace; allocation, inverse maps and RK4 stay vectorised.  Numba's disk cache cannot
tell which function the global names, so these kernels are compiled in memory, once per process
and controller (≈ 10-20 s).  Measured (BlueROV2 square, 64 perturbed vehicles, 2 shared
threads, two runs): the built-in kernel 0.04-0.16 s, the PID as a user controller here 0.13-0.50 s
(≈ 3× the built-in: the scalar call per lane), the same through the per-vehicle loop
(:func:`~uuvid.simulate.vehicle_sim.run_batch`) 1.4-2.2 s — 4-11× slower than here (``uuvid
bench``, case ``controllers_batch``, measures it on your machine).  Thrust/command outputs,
plain Python controllers and disturbance blocks fly the per-vehicle loop
(:func:`fast_path_reason` says which).

Public API: :func:`run_batch_fast`, :func:`batch_throughput`, :func:`perturb_vehicle_params`,
:func:`perturb_thruster_params`, :func:`perturb_batch`, :func:`fast_path_reason`.
"""

from __future__ import annotations

import hashlib
import importlib.util
import math
import os
import re
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from uuvid.simulate import vehicle_sim
from uuvid.simulate.control.pid import DP_DOFS
from uuvid.thruster.blocks import (
    K_DEADZONE,
    K_ESC,
    K_FIRST_ORDER,
    K_FIRST_ORDER_MOTOR,
    K_POLYNOMIAL,
    K_QUADRATIC,
    K_ZERO_ORDER,
)
from uuvid.thruster.inflow import inflow_series as _inflow_series
from uuvid.vehicle.inflow import check_geometry as _check_geometry
from uuvid.vehicle.model import (
    LAYOUT_VERSION,
    N_PARAMS,
    P_B,
    P_DL,
    P_DQ,
    P_GAMMA,
    P_MA,
    P_MINV,
    P_MRB,
    P_RB,
    P_RG,
    P_VC,
    P_VERSION,
    P_W,
)

__all__ = [
    "SUMMARY_COLUMNS",
    "run_batch_fast",
    "batch_throughput",
    "perturb_vehicle_params",
    "perturb_thruster_params",
    "perturb_batch",
    "fast_path_reason",
]

KERNEL_VERSION = 4  # bump when the generated source changes meaning
DEFAULT_CHUNK = 32

#: Columns of :func:`run_batch_fast`'s output.  The first five are those of
#: :func:`uuvid.simulate.vehicle_sim.run_batch`.
SUMMARY_COLUMNS = (
    "max_tracking_error_m",  # 0  max over steps of |p − p_ref| (state at the start of each step)
    "rms_tracking_error_m",  # 1
    "max_thrust_N",  # 2  max |delivered thrust| at the start of each step
    "final_position_error_m",  # 3  |p − p_ref| at the start of the last step
    "min_allocation_scale",  # 4  smallest uniform-scaling factor (1 = never saturated)
    "completed",  # 5  1.0 if tracked and level to the path's end (as fly_mission's: 0 when cut)
    "saturated_fraction",  # 6  fraction of steps with allocation scale < 1 (NaN on the fallback)
    "finite",  # 7  1.0 if the final state is finite (the run did not diverge)
    "max_tilt_deg",  # 8  largest tilt of the body z axis from the vertical (state at step starts)
)
N_SUMMARY = len(SUMMARY_COLUMNS)

_STATIC_KINDS = (K_ESC, K_QUADRATIC, K_POLYNOMIAL, K_DEADZONE, K_ZERO_ORDER)

# Cephes atan (S. Moshier): rational approximation on |w| ≤ 0.66 with two range reductions.
_ATAN_P = (-8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
           -1.228866684490136173410e2, -6.485021904942025371773e1)
_ATAN_Q = (2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
           4.853903996359136964868e2, 1.945506571482613964425e2)
_T3P8 = 2.41421356237309504880
_MOREBITS = 6.123233995736765886130e-17


# ---------------------------------------------------------------------------------------------
# Structure of a batch (what the generated kernel is specialised on)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Structure:
    n: int  # thrusters
    nsub: int
    chunk: int  # lanes per chunk
    tables: tuple  # per distinct inverse table: (points K, grid cells G, lifting steps, sqrt axis)
    tmap: tuple  # table of each thruster
    prefix: tuple  # static blocks before the dynamic one (all blocks for a static chain)
    dyn: int  # 0: none (static chain), K_FIRST_ORDER or K_FIRST_ORDER_MOTOR
    suffix: tuple  # static blocks after the dynamic one
    mrb: tuple  # 36 booleans: nonzero somewhere in the batch
    ma: tuple
    dl: tuple
    dq: tuple
    minv: tuple
    restoring: tuple  # (W − B, m_x, m_y, m_z) nonzero somewhere
    current: bool
    tpat: tuple  # n×6 allocation matrix pattern (columns of τ_des the controller sets)
    bpat: tuple  # 6×n thrust configuration pattern
    compensate: bool
    eta_one: tuple  # per thruster: η₊ = η₋ = 1
    ki_pos: tuple  # per DP DOF: k_i > 0
    attitude: bool  # roll/pitch attitude hold on (control.attitude_hold)
    fastmath: tuple
    user: bool = False  # a user's compiled wrench controller instead of the inline PID
    inflow: int = 0  # Fourier terms of the four-quadrant map's C_T* (0: bollard thrusters)

    def key(self) -> str:
        return hashlib.sha1(repr((KERNEL_VERSION, self)).encode()).hexdigest()[:16]


def _block_desc(kind: int, params: np.ndarray, pb: int) -> tuple:
    """Structural description of a static block from its parameters (all thrusters, all runs:
    ``params`` is (R·n, P))."""
    if kind == K_ESC:
        return (K_ESC, bool(np.any(params[:, pb + 9] != 0)), bool(np.any(params[:, pb + 10] != 0)))
    if kind == K_POLYNOMIAL:
        nf = np.unique(params[:, pb + 0])
        nr = np.unique(params[:, pb + 1])
        if nf.size != 1 or nr.size != 1:
            raise _NoFastPath("polynomial blocks with different degrees")
        return (K_POLYNOMIAL, int(nf[0]), int(nr[0]))
    return (int(kind),)


class _NoFastPath(Exception):
    pass


@dataclass
class _Prepared:
    struct: _Structure
    pv_names: list
    pv: dict  # name -> (R,) values
    shared_names: list
    shared: dict  # name -> float
    tbx: np.ndarray
    tby: np.ndarray
    grid: np.ndarray
    ref: np.ndarray  # (nsteps, 8)


def _analyse(setup, VP, TP, VC, chunk, fastmath) -> _Prepared:
    """Check the fast path applies; collect structure and per-lane/shared values."""
    s = setup
    b = s.bank
    R = VP.shape[0]
    n = b.n
    kinds = [int(k) for k in b.kinds]
    soff = np.asarray(b.soff)
    nb = len(kinds)
    ctrl = getattr(s, "controller", None)
    if getattr(s, "disturbance", None) is not None:
        raise _NoFastPath("a disturbance block flies the compiled loop per vehicle "
                          "(vehicle_sim.run_batch)")
    if ctrl is not None and ctrl.output != "wrench":
        raise _NoFastPath(f"a controller with output={ctrl.output!r} flies the compiled loop per "
                          "vehicle (vehicle_sim.run_batch); the kernel takes wrench controllers")
    if ctrl is not None and not ctrl.compiled:
        raise _NoFastPath("a plain Python controller flies the compiled loop per vehicle, one "
                          "vehicle after another (vehicle_sim.run_batch)")
    user = ctrl is not None
    if VP.shape[1] != N_PARAMS or np.any(VP[:, P_VERSION] != LAYOUT_VERSION):
        raise _NoFastPath("vehicle parameters do not have layout version 1")
    dynb = [i for i in range(nb) if soff[i + 1] > soff[i]]
    if len(dynb) == 0:
        prefix_idx, dyn, suffix_idx = list(range(nb)), 0, []
    elif len(dynb) == 1 and b.exact[dynb[0]] and soff[nb] == 1 and kinds[dynb[0]] in (
            K_FIRST_ORDER, K_FIRST_ORDER_MOTOR):
        d = dynb[0]
        prefix_idx, dyn, suffix_idx = list(range(d)), kinds[d], list(range(d + 1, nb))
    else:
        raise _NoFastPath("the thruster chain is not static + one exact first-order block + static")
    for i in prefix_idx + suffix_idx:
        if kinds[i] not in _STATIC_KINDS:
            raise _NoFastPath(f"static block kind {kinds[i]} is not handled by the batch kernel")
    if s.substeps > 8:
        raise _NoFastPath("more than 8 substeps")
    if not (chunk >= 8 and chunk % 8 == 0 and chunk <= 1024):
        raise ValueError(f"chunk must be a multiple of 8 in [8, 1024], got {chunk}")
    ref_pos, ref_vel, ref_yaw, ref_rate = (np.asarray(a, dtype=float) for a in s.ref)
    if ref_yaw.size and np.max(np.abs(ref_yaw)) > 5.5:
        raise _NoFastPath("reference yaw outside [-5.5, 5.5] rad (the kernel's angle wrap needs it)")
    K = b.inv_thrust.shape[1]
    if K < 2:
        raise _NoFastPath("inverse tables need 2 points or more")
    if np.any(np.diff(b.inv_thrust, axis=1) <= 0) or not np.all(np.isfinite(b.inv_thrust)):
        raise _NoFastPath("inverse tables are not strictly increasing")
    utab, tmap = [], []
    for i in range(n):
        for t, (xs_, ys_) in enumerate(utab):
            if np.array_equal(xs_, b.inv_thrust[i]) and np.array_equal(ys_, b.inv_command[i]):
                tmap.append(t)
                break
        else:
            tmap.append(len(utab))
            utab.append((np.asarray(b.inv_thrust[i], float), np.asarray(b.inv_command[i], float)))
    grids = [_table_grid(xs_) for xs_, _ in utab]
    poff = np.asarray(b.poff)
    flatTP = TP.reshape(R * n, -1)
    prefix = tuple(_block_desc(kinds[i], flatTP, poff[i]) for i in prefix_idx)
    suffix = tuple(_block_desc(kinds[i], flatTP, poff[i]) for i in suffix_idx)

    def pat(off):
        return tuple(bool(x) for x in np.any(VP[:, off:off + 36] != 0, axis=0))

    W, B = VP[:, P_W], VP[:, P_B]
    wb = W - B
    mx = W * VP[:, P_RG] - B * VP[:, P_RB]
    my = W * VP[:, P_RG + 1] - B * VP[:, P_RB + 1]
    mz = W * VP[:, P_RG + 2] - B * VP[:, P_RB + 2]
    restoring = tuple(bool(np.any(a != 0)) for a in (wb, mx, my, mz))
    current = bool(np.any(VC != 0))

    a = s.alloc
    na, ma = int(a[0]), int(a[1])
    if na != n or ma != 6:
        raise _NoFastPath("allocation array does not match the thrusters")
    T = a[3:3 + n * 6].reshape(n, 6)
    olo = 3 + n * 6
    lo, hi, aep, aen = a[olo:olo + n], a[olo + n:olo + 2 * n], a[olo + 2 * n:olo + 3 * n], \
        a[olo + 3 * n:olo + 4 * n]
    compensate = a[2] != 0.0
    G = s.gains.to_array()
    attitude = not user and G.shape[0] > 5 and bool(np.any(G[5] != 0.0))
    used = set(range(6)) if user else set(DP_DOFS) | ({3, 4} if attitude else set())  # τ_des ≠ 0
    tpat = tuple(bool(T[i, j] != 0 and j in used) for i in range(n) for j in range(6))
    Bm = np.asarray(s.B, dtype=float)
    bpat = tuple(bool(Bm[k, i] != 0) for k in range(6) for i in range(n))
    eta_one = tuple(bool(s.eta_p[i] == 1.0 and s.eta_n[i] == 1.0) for i in range(n))
    ki_pos = tuple(not user and bool(G[1, j] > 0) for j in range(4))
    inflow = getattr(s, "inflow_arrays", None)
    if inflow is not None and not dyn:
        raise _NoFastPath("inflow with a static thruster chain flies the per-vehicle loop "
                          "(vehicle_sim.fly_batch)")
    IPRM, IGEO = inflow if inflow is not None else (None, None)
    if IGEO is not None:
        IGEO = _check_geometry(IGEO)
    inflow_series = _inflow_series(IPRM) if inflow is not None else ((), ())

    struct = _Structure(n, int(s.substeps), int(chunk),
                        tuple((xs_.size, g[0], g[1], g[2]) for (xs_, _), g in zip(utab, grids)),
                        tuple(tmap), prefix, int(dyn), suffix,
                        pat(P_MRB), pat(P_MA), pat(P_DL), pat(P_DQ), pat(P_MINV), restoring,
                        current, tpat, bpat, bool(compensate), eta_one, ki_pos, attitude,
                        tuple(sorted(fastmath)), user, len(inflow_series[0]))

    # ---- per-lane values
    pv = {}
    for name, off, p in (("mrb", P_MRB, struct.mrb), ("ma", P_MA, struct.ma), ("dl", P_DL, struct.dl),
                         ("dq", P_DQ, struct.dq), ("minv", P_MINV, struct.minv)):
        for k in range(36):
            if p[k]:
                pv[f"{name}{k}"] = VP[:, off + k]
    for name, val, on in zip(("wb", "mx", "my", "mz"), (wb, mx, my, mz), restoring):
        if on:
            pv[name] = val
    pv["hg"] = 0.5 * VP[:, P_GAMMA]
    if current:
        for j in range(3):
            pv[f"vc{j}"] = VC[:, j]
    h = s.dt / s.substeps
    for i in range(n):
        for bi, desc in zip(prefix_idx + suffix_idx, prefix + suffix):
            pb = poff[bi]
            for j in _static_param_slots(desc):
                pv[f"t{i}b{bi}p{j}"] = TP[:, i, pb + j]
        if dyn:
            pb = poff[dynb[0]]
            if dyn == K_FIRST_ORDER_MOTOR:
                pv[f"t{i}gain"] = TP[:, i, pb]
                tc = TP[:, i, pb + 1]
            else:
                tc = TP[:, i, pb]
            # the same expressions as fly(): exp(−0.5·st·h/τ) for st = 1, 2
            pv[f"t{i}e1"] = np.array([math.exp(-0.5 * 1 * h / t) for t in tc.tolist()])
            pv[f"t{i}e2"] = np.array([math.exp(-0.5 * 2 * h / t) for t in tc.tolist()])

    # ---- shared scalars
    sh = {}
    for j in range(0 if user else 4):
        kp, ki, kd, tmax, ilim = (float(G[r, j]) for r in range(5))
        sh[f"kp{j}"], sh[f"ki{j}"], sh[f"kd{j}"], sh[f"tmax{j}"] = kp, ki, kd, tmax
        if ki > 0:
            sh[f"ilim{j}"] = ilim / ki
    if attitude:
        for j, nm in enumerate(("kpa0", "kpa1", "kda0", "kda1")):
            sh[nm] = float(G[5, j])
    for i in range(n):
        for j in range(6):
            if tpat[i * 6 + j]:
                sh[f"T{i}_{j}"] = float(T[i, j])
        sh[f"lo{i}"], sh[f"hi{i}"] = float(lo[i]), float(hi[i])
        if compensate:
            sh[f"aep{i}"], sh[f"aen{i}"] = float(aep[i]), float(aen[i])
        if not eta_one[i]:
            sh[f"ep{i}"], sh[f"en{i}"] = float(s.eta_p[i]), float(s.eta_n[i])
    for k in range(6):
        for i in range(n):
            if bpat[k * n + i]:
                sh[f"B{k}_{i}"] = float(Bm[k, i])
    if inflow is not None:  # map (inflow_params) and geometry (inflow_geometry) of the setup
        for j in range(4):
            sh[f"inf_p{j}"] = float(IPRM[j])
        for k, (a, b) in enumerate(zip(inflow_series[0], inflow_series[1])):
            sh[f"inf_a{k}"], sh[f"inf_b{k}"] = float(a), float(b)
        for i in range(n):
            for j in range(7, 13):  # the advance speed's row (1 − w)[axis, r × axis]
                sh[f"inf_g{i}_{j}"] = float(IGEO[i, j])
    for t, ((xs_, ys_), g) in enumerate(zip(utab, grids)):
        sh[f"x0_{t}"], sh[f"y0_{t}"] = float(xs_[0]), float(ys_[0])
        sh[f"xm_{t}"], sh[f"ym_{t}"] = float(xs_[-1]), float(ys_[-1])
        sh[f"u0_{t}"], sh[f"gi_{t}"] = g[3], g[4]
    ref = np.ascontiguousarray(np.column_stack([ref_pos, ref_vel, ref_yaw, ref_rate]), dtype=float)
    tbx = np.ascontiguousarray(np.concatenate([xs_ for xs_, _ in utab]), dtype=float)
    tby = np.ascontiguousarray(np.concatenate([ys_ for _, ys_ in utab]), dtype=float)
    grid = np.ascontiguousarray(np.concatenate([g[5] for g in grids]), dtype=np.int64)
    return _Prepared(struct, list(pv), pv, list(sh), sh, tbx, tby, grid, ref)


def _ssqrt(x):
    return np.copysign(np.sqrt(np.abs(x)), x)


def _table_grid(xs: np.ndarray):
    """Search accelerator for one inverse table: a uniform grid over the thrust axis (or over
    ``sign(f)·√|f|``, where a quadratic map's knots are evenly spread) whose cell ``c`` stores
    the first interval any query landing in the cell can be in.  A query then needs one look-up
    and ``steps`` binary-lifting steps instead of a full bisection; the interval found is the
    same (cells are widened by 1e-6 of their width, far more than the rounding of the cell index).

    Returns ``(G, steps, sqrt_axis, u0, G/(u_max − u0), start (G,))``."""
    K = xs.size
    mlast = max(K - 2, 0)
    best = None
    for use_sqrt in (False, True):
        f = _ssqrt if use_sqrt else (lambda x: x)
        finv = (lambda u: np.copysign(u * u, u)) if use_sqrt else (lambda u: u)
        u0, um = float(f(xs[0])), float(f(xs[-1]))
        if not um > u0:
            continue
        for G in (64, 128, 256, 512, 1024, 2048, 4096):
            d = (um - u0) / G
            c = np.arange(G)
            la = np.clip(np.searchsorted(xs, finv(u0 + (c - 1e-6) * d), side="right") - 1, 0, mlast)
            lb = np.clip(np.searchsorted(xs, finv(u0 + (c + 1 + 1e-6) * d), side="right") - 1, 0,
                         mlast)
            steps = int(np.max(lb - la)).bit_length()
            cost = 8 * steps + (6 if use_sqrt else 0) + G / 1024
            if best is None or cost < best[0]:
                best = (cost, G, steps, use_sqrt, u0, G / (um - u0), la.astype(np.int64))
    return best[1:]


def _static_param_slots(desc) -> tuple:
    kind = desc[0]
    if kind == K_ESC:
        return tuple(range(11))
    if kind == K_QUADRATIC:
        return (0, 1)
    if kind == K_DEADZONE:
        return (0, 1, 2, 3)
    if kind == K_POLYNOMIAL:
        return tuple(range(2, 2 + desc[1] + desc[2]))
    return ()


# ---------------------------------------------------------------------------------------------
# Code generation
# ---------------------------------------------------------------------------------------------
_IDENT = re.compile(r"(?<![.\w])([A-Za-z_]\w*)")
_ASSIGN = re.compile(r"^(\s*)([A-Za-z_]\w*) = (.*)$")


class _Emitter:
    def __init__(self):
        self.lines = []
        self.ind = 0
        self.count = 0

    def __call__(self, line: str):
        self.lines.append("    " * self.ind + line)

    def tmp(self, stem: str) -> str:
        self.count += 1
        return f"{stem}_{self.count}"

    def begin_ssa(self, prefix: str) -> None:
        self._mark = (len(self.lines), prefix)

    def end_ssa(self) -> None:
        """Rewrite the straight-line lines since :meth:`begin_ssa` in single-assignment form with
        names private to this loop body (numba's SSA reconstruction and type inference then have
        nothing to merge — a several-fold shorter compilation)."""
        start, prefix = self._mark
        cur: dict = {}
        count: dict = {}
        out = []

        def sub(text):
            return _IDENT.sub(lambda m: cur.get(m.group(1), m.group(1)), text)

        for line in self.lines[start:]:
            m = _ASSIGN.match(line)
            if m:
                ind, name, expr = m.groups()
                expr = sub(expr)
                count[name] = count.get(name, 0) + 1
                new = f"{prefix}{name}" + (f"_v{count[name]}" if count[name] > 1 else "")
                cur[name] = new
                out.append(f"{ind}{new} = {expr}")
            else:
                out.append(sub(line))
        self.lines[start:] = out


def _sum(terms) -> str:
    """Left-to-right sum of term strings (the order of the scalar loops); '0.0' if empty."""
    terms = list(terms)
    if not terms:
        return "0.0"
    out = terms[0]
    for t in terms[1:]:
        out = f"({out} + {t})"
    return out


def _emit_static(e: _Emitter, desc, pref: str, sig: str) -> str:
    """Lines evaluating one static block on lane variable ``sig``; returns the output variable."""
    kind = desc[0]
    out = e.tmp("sg")
    p = [f"{pref}p{j}" for j in range(11)]
    if kind == K_ESC:
        c, vf, vr = e.tmp("c"), e.tmp("vf"), e.tmp("vr")
        e(f"{c} = min(max({sig}, {p[6]}), {p[7]})")
        e(f"{vf} = {p[0]} * {c} + {p[1]}")
        if desc[1]:
            e(f"{vf} = {vf} * (1.0 + {p[9]} * (abs({vf}) / {p[8]} - 1.0))")
        e(f"{vr} = {p[2]} * {c} + {p[3]}")
        if desc[2]:
            e(f"{vr} = {vr} * (1.0 + {p[10]} * (abs({vr}) / {p[8]} - 1.0))")
        vv = e.tmp("vv")
        e(f"{vv} = {vf} if {c} > {p[5]} else ({vr} if {c} < {p[4]} else 0.0)")
        e(f"{out} = min(max({vv}, -{p[8]}), {p[8]})")
    elif kind == K_QUADRATIC:
        e(f"{out} = ({p[0]} if {sig} >= 0.0 else {p[1]}) * ({sig} * abs({sig}))")
    elif kind == K_DEADZONE:
        a = e.tmp("a")
        e(f"{a} = {sig} * abs({sig})")
        e(f"{out} = {p[0]} * ({a} - {p[2]}) if {a} <= {p[2]} else "
          f"({p[1]} * ({a} - {p[3]}) if {a} >= {p[3]} else 0.0)")
    elif kind == K_POLYNOMIAL:
        nf, nr = desc[1], desc[2]
        yf, yr, xr = e.tmp("yf"), e.tmp("yr"), e.tmp("xr")
        e(f"{yf} = 0.0")
        for k in range(nf):
            e(f"{yf} = {yf} * {sig} + {pref}p{2 + k}")
        e(f"{xr} = -{sig}")
        e(f"{yr} = 0.0")
        for k in range(nr):
            e(f"{yr} = {yr} * {xr} + {pref}p{2 + nf + k}")
        e(f"{out} = {yf} if {sig} > 0.0 else (-{yr} if {sig} < 0.0 else 0.0)")
    else:  # zero-order: identity
        e(f"{out} = {sig}")
    return out


def _emit_rhs(e: _Emitter, st: _Structure, x: list, tau: list, tag: str) -> list:
    """vehicle_rhs_into, unrolled on the structure; returns the 13 derivative variables."""
    n_ = lambda s: f"{s}{tag}"  # noqa: E731
    d = [n_(f"d{i}_") for i in range(13)]
    e_, ex, ey, ez = x[3], x[4], x[5], x[6]
    r = {k: n_(f"r{k}_") for k in ("00", "01", "02", "10", "11", "12", "20", "21", "22")}
    e(f"{r['00']} = 1.0 - 2.0 * ({ey} * {ey} + {ez} * {ez})")
    e(f"{r['01']} = 2.0 * ({ex} * {ey} - {ez} * {e_})")
    e(f"{r['02']} = 2.0 * ({ex} * {ez} + {ey} * {e_})")
    e(f"{r['10']} = 2.0 * ({ex} * {ey} + {ez} * {e_})")
    e(f"{r['11']} = 1.0 - 2.0 * ({ex} * {ex} + {ez} * {ez})")
    e(f"{r['12']} = 2.0 * ({ey} * {ez} - {ex} * {e_})")
    e(f"{r['20']} = 2.0 * ({ex} * {ez} - {ey} * {e_})")
    e(f"{r['21']} = 2.0 * ({ey} * {ez} + {ex} * {e_})")
    e(f"{r['22']} = 1.0 - 2.0 * ({ex} * {ex} + {ey} * {ey})")
    u, v, w, pp, qq, rr = x[7:13]
    e(f"{d[0]} = {r['00']} * {u} + {r['01']} * {v} + {r['02']} * {w}")
    e(f"{d[1]} = {r['10']} * {u} + {r['11']} * {v} + {r['12']} * {w}")
    e(f"{d[2]} = {r['20']} * {u} + {r['21']} * {v} + {r['22']} * {w}")
    kq = n_("kq_")
    e(f"{kq} = hg * (1.0 - ({e_} * {e_} + {ex} * {ex} + {ey} * {ey} + {ez} * {ez}))")
    e(f"{d[3]} = 0.5 * (-{ex} * {pp} - {ey} * {qq} - {ez} * {rr}) + {kq} * {e_}")
    e(f"{d[4]} = 0.5 * ({e_} * {pp} - {ez} * {qq} + {ey} * {rr}) + {kq} * {ex}")
    e(f"{d[5]} = 0.5 * ({ez} * {pp} + {e_} * {qq} - {ex} * {rr}) + {kq} * {ey}")
    e(f"{d[6]} = 0.5 * (-{ey} * {pp} + {ex} * {qq} + {e_} * {rr}) + {kq} * {ez}")
    nu = [u, v, w, pp, qq, rr]
    if st.current:
        cu, cv, cw = n_("cu_"), n_("cv_"), n_("cw_")
        au, av, aw = n_("au_"), n_("av_"), n_("aw_")
        e(f"{cu} = {r['00']} * vc0 + {r['10']} * vc1 + {r['20']} * vc2")
        e(f"{cv} = {r['01']} * vc0 + {r['11']} * vc1 + {r['21']} * vc2")
        e(f"{cw} = {r['02']} * vc0 + {r['12']} * vc1 + {r['22']} * vc2")
        e(f"{au} = -({qq} * {cw} - {rr} * {cv})")
        e(f"{av} = -({rr} * {cu} - {pp} * {cw})")
        e(f"{aw} = -({pp} * {cv} - {qq} * {cu})")
        nr = [n_("nr0_"), n_("nr1_"), n_("nr2_"), pp, qq, rr]
        e(f"{nr[0]} = {u} - {cu}")
        e(f"{nr[1]} = {v} - {cv}")
        e(f"{nr[2]} = {w} - {cw}")
        acc = (au, av, aw)
    else:
        nr = nu
        acc = None
    f = [n_(f"f{i}_") for i in range(6)]
    for i in range(6):
        e(f"{f[i]} = {tau[i]}")

    def kirchhoff(name, pat, vec):
        a = [n_(f"a{name}{i}_") for i in range(6)]
        for i in range(6):
            e(f"{a[i]} = " + _sum(f"{name}{6 * i + j} * {vec[j]}" for j in range(6) if pat[6 * i + j]))
        v_ = vec
        e(f"{f[0]} = {f[0]} - ({v_[4]} * {a[2]} - {v_[5]} * {a[1]})")
        e(f"{f[1]} = {f[1]} - ({v_[5]} * {a[0]} - {v_[3]} * {a[2]})")
        e(f"{f[2]} = {f[2]} - ({v_[3]} * {a[1]} - {v_[4]} * {a[0]})")
        e(f"{f[3]} = {f[3]} - (({v_[1]} * {a[2]} - {v_[2]} * {a[1]})"
          f" + ({v_[4]} * {a[5]} - {v_[5]} * {a[4]}))")
        e(f"{f[4]} = {f[4]} - (({v_[2]} * {a[0]} - {v_[0]} * {a[2]})"
          f" + ({v_[5]} * {a[3]} - {v_[3]} * {a[5]}))")
        e(f"{f[5]} = {f[5]} - (({v_[0]} * {a[1]} - {v_[1]} * {a[0]})"
          f" + ({v_[3]} * {a[4]} - {v_[4]} * {a[3]}))")

    if any(st.mrb):
        kirchhoff("mrb", st.mrb, nu)
    if any(st.ma):
        kirchhoff("ma", st.ma, nr)
    anr = [n_(f"anr{j}_") for j in range(6)]
    for j in range(6):
        if any(st.dq[6 * i + j] for i in range(6)):
            e(f"{anr[j]} = abs({nr[j]})")
    for i in range(6):
        terms = []
        for j in range(6):
            lin = f"dl{6 * i + j} * {nr[j]}" if st.dl[6 * i + j] else None
            quad = f"dq{6 * i + j} * {anr[j]} * {nr[j]}" if st.dq[6 * i + j] else None
            if lin and quad:
                terms.append(f"({lin} + {quad})")
            elif lin or quad:
                terms.append(lin or quad)
        if acc is not None:
            mterms = [f"ma{6 * i + j} * {acc[j]}" for j in range(3) if st.ma[6 * i + j]]
        else:
            mterms = []
        if not terms and not mterms:
            continue
        sv = n_(f"s{i}_")
        e(f"{sv} = " + _sum(terms))
        if mterms:
            e(f"{sv} = {sv} - " + _sum(mterms))
        e(f"{f[i]} = {f[i]} - {sv}")
    wb, mx, my, mz = st.restoring
    kx, ky, kz = r["20"], r["21"], r["22"]
    if wb:
        e(f"{f[0]} = {f[0]} + wb * {kx}")
        e(f"{f[1]} = {f[1]} + wb * {ky}")
        e(f"{f[2]} = {f[2]} + wb * {kz}")

    def cross_term(a_on, a, kb, b_on, b, ka):
        # a·kb − b·ka with structurally zero products dropped
        if a_on and b_on:
            return f"({a} * {kb} - {b} * {ka})"
        if a_on:
            return f"({a} * {kb})"
        if b_on:
            return f"(-({b} * {ka}))"
        return None

    for fi, t in ((3, cross_term(my, "my", kz, mz, "mz", ky)), (4, cross_term(mz, "mz", kx, mx, "mx", kz)),
                  (5, cross_term(mx, "mx", ky, my, "my", kx))):
        if t is not None:
            e(f"{f[fi]} = {f[fi]} + {t}")
    for i in range(6):
        e(f"{d[7 + i]} = " + _sum(f"minv{6 * i + j} * {f[j]}" for j in range(6) if st.minv[6 * i + j]))
    return d


def _emit_inflow_thrusts(e: _Emitter, st: _Structure, x: list, bollard: list) -> list:
    """Delivered thrusts (η applied) of the bollard thrusts ``bollard`` at the advance speeds of
    state ``x``: :func:`uuvid.vehicle.inflow.state_advance_speeds_nb` then
    :func:`uuvid.thruster.inflow.inflow_thrust_nb`, the same expressions in the same order
    (``C_T*`` by Clenshaw's recurrence on the map's ``st.inflow`` Fourier terms, where the loop
    reads the same series from its cubic table: within 1e-11 of each other; ``u_a = 0`` returns
    the bollard thrust itself, by a select)."""
    e_, ex, ey, ez = x[3], x[4], x[5], x[6]
    R = {}
    for k, expr in (("00", f"1.0 - 2.0 * ({ey} * {ey} + {ez} * {ez})"),
                    ("01", f"2.0 * ({ex} * {ey} - {ez} * {e_})"),
                    ("02", f"2.0 * ({ex} * {ez} + {ey} * {e_})"),
                    ("10", f"2.0 * ({ex} * {ey} + {ez} * {e_})"),
                    ("11", f"1.0 - 2.0 * ({ex} * {ex} + {ez} * {ez})"),
                    ("12", f"2.0 * ({ey} * {ez} - {ex} * {e_})"),
                    ("20", f"2.0 * ({ex} * {ez} - {ey} * {e_})"),
                    ("21", f"2.0 * ({ey} * {ez} + {ex} * {e_})"),
                    ("22", f"1.0 - 2.0 * ({ex} * {ex} + {ey} * {ey})")):
        R[k] = e.tmp("ir")
        e(f"{R[k]} = {expr}")
    uvw = []
    for j, a in enumerate(("0", "1", "2")):
        t = e.tmp("iu")
        if st.current:  # ν_r = ν − Rᵀ v_c
            e(f"{t} = {x[7 + j]} - ({R['0' + a]} * vc0 + {R['1' + a]} * vc1 + {R['2' + a]} * vc2)")
        else:  # no current: the loop subtracts zeros
            e(f"{t} = {x[7 + j]}")
        uvw.append(t)
    u, v, w = uvw
    p, q, r = x[10], x[11], x[12]
    out = []
    for i in range(st.n):
        g = [f"inf_g{i}_{j}" for j in range(13)]
        ua, f = e.tmp("ua"), bollard[i]
        e(f"{ua} = {g[7]} * {u} + {g[8]} * {v} + {g[9]} * {w} + {g[10]} * {p} + {g[11]} * {q} + "
          f"{g[12]} * {r}")
        vt, v2, ir, c1, s1 = (e.tmp(nm) for nm in ("vt", "v2", "iv", "c1", "s1"))
        e(f"{vt} = inf_p0 * math.copysign(math.sqrt(abs({f}) * (inf_p2 if {f} >= 0.0 else "
          f"inf_p3)), {f})")
        e(f"{v2} = {ua} * {ua} + {vt} * {vt}")
        e(f"{ir} = 1.0 / math.sqrt({v2})")
        e(f"{c1} = {vt} * {ir}")  # cos β
        e(f"{s1} = {ua} * {ir}")  # sin β
        ct = _emit_clenshaw(e, st.inflow, c1, s1)
        fi = e.tmp("fi")
        e(f"{fi} = {f} if {ua} == 0.0 else {ct} * inf_p1 * {v2}")
        if not st.eta_one[i]:
            fe = e.tmp("fe")
            e(f"{fe} = {fi} * (ep{i} if {fi} >= 0.0 else en{i})")
            fi = fe
        out.append(fi)
    return out


def _emit_clenshaw(e: _Emitter, nk: int, c: str, s: str) -> str:
    """``Σ_k a_k cos kβ + b_k sin kβ`` (``inf_a{k}``, ``inf_b{k}``, k < ``nk``) from ``cos β``,
    ``sin β``, split into even and odd k: with ``θ = 2β``, ``cos (2j+1)β = cos β cos jθ −
    sin β sin jθ`` and ``sin (2j+1)β = sin β cos jθ + cos β sin jθ``, the series is four series
    in ``jθ`` over half the terms, each summed by Clenshaw's recurrence ``u_j = x_j + 2 cos θ
    u_{j+1} − u_{j+2}`` (``Σ x_j cos jθ = x_0 + u_1 cos θ − u_2``, ``Σ x_j sin jθ = u_1 sin θ``;
    no gathers, so the lane loop stays vectorised), each term one subtraction and one fused
    multiply-add (:func:`uuvid.core.fused.fma`).  The same sum (within rounding) and the same
    count of operations as one recurrence in β per series, but four dependency chains of ~10
    multiply-adds instead of two of ~20: the recurrences were latency-bound (a chain's next
    multiply-add waits for the last; the compiled kernel evaluates one series after the other),
    and the inflow batch's cost over the bollard batch falls from ≈ 2.5× to ≈ 2.2× with them
    halved (splitting in four, ``θ = 4β``, was no better)."""
    ct, st_, t2 = e.tmp("cth"), e.tmp("sth"), e.tmp("c2")
    e(f"{ct} = fma({c} + {c}, {c}, -1.0)")  # cos 2β = 2cos²β − 1
    e(f"{st_} = ({s} + {s}) * {c}")  # sin 2β
    e(f"{t2} = {ct} + {ct}")

    def rec(xs):  # (u_1, u_2) of the recurrence on the coefficients xs (x_0 … x_m)
        u1 = u2 = None
        for k in range(len(xs) - 1, 0, -1):
            nu = e.tmp("cu")
            if u1 is None:
                e(f"{nu} = {xs[k]}")
            elif u2 is None:
                e(f"{nu} = fma({t2}, {u1}, {xs[k]})")
            else:
                e(f"{nu} = fma({t2}, {u1}, {xs[k]} - {u2})")
            u1, u2 = nu, u1
        return u1, u2

    def cos_sum(xs, u1, u2):  # Σ x_j cos jθ
        if u1 is None:
            return xs[0]
        if u2 is None:
            return f"fma({ct}, {u1}, {xs[0]})"
        return f"(fma({ct}, {u1}, {xs[0]}) - {u2})"

    def sin_sum(u1):  # Σ x_j sin jθ
        return "0.0" if u1 is None else f"({st_} * {u1})"

    ae = [f"inf_a{k}" for k in range(0, nk, 2)]
    ao = [f"inf_a{k}" for k in range(1, nk, 2)]
    be = [f"inf_b{k}" for k in range(0, nk, 2)]
    bo = [f"inf_b{k}" for k in range(1, nk, 2)]
    rae, rbe = rec(ae), rec(be)
    terms = [cos_sum(ae, *rae)]
    if rbe[0] is not None:
        terms.append(sin_sum(rbe[0]))
    if ao:  # the odd terms: cos β (C_a + S_b) + sin β (C_b − S_a)
        rao, rbo = rec(ao), rec(bo)
        cc, ss = e.tmp("cc"), e.tmp("cs")
        e(f"{cc} = {cos_sum(ao, *rao)} + {sin_sum(rbo[0])}")
        e(f"{ss} = {cos_sum(bo, *rbo)} - {sin_sum(rao[0])}")
        terms.append(f"fma({c}, {cc}, {s} * {ss})")
    out = e.tmp("ct")
    e(f"{out} = " + " + ".join(terms))
    return out


def _table_offsets(st: _Structure):
    toff, goff = [], []
    a = g = 0
    for K, G, _, _ in st.tables:
        toff.append(a)
        goff.append(g)
        a += K
        g += G
    return toff, goff


def _emit_search(e: _Emitter, st: _Structure, i: int, xv: str, Wr) -> None:
    """Scalar: find the table interval of thruster i containing ``xv`` (the ``lo`` of
    vehicle_sim._interp's bisection) and store it in the lane's cache rows.  Grid cell → first
    candidate interval → binary lifting (same interval as the bisection, fewer loads)."""
    t = st.tmap[i]
    K, G, steps, use_sqrt = st.tables[t]
    toff, goff = _table_offsets(st)
    o = toff[t]
    mlast = K - 2
    cf, li, xl = e.tmp("cf"), e.tmp("lo"), e.tmp("xl")
    u = f"math.copysign(math.sqrt(abs({xv})), {xv})" if use_sqrt else xv
    e(f"{cf} = ({u} - u0_{t}) * gi_{t}")
    e(f"{cf} = {cf} if {cf} > 0.0 else 0.0")  # NaN → 0 too
    e(f"{cf} = {cf} if {cf} < {float(G - 1)!r} else {float(G - 1)!r}")
    e(f"{li} = GRID[{goff[t]} + int({cf})]")
    e(f"{xl} = TBX[{o} + {li}]")
    for k in range(steps, 0, -1):
        c, xc = e.tmp("c"), e.tmp("xc")
        e(f"{c} = {li} + {1 << (k - 1)}")
        e(f"if {c} <= {mlast}:")
        e(f"    {xc} = TBX[{o} + {c}]")
        e(f"    if {xc} <= {xv}:")
        e(f"        {li} = {c}")
        e(f"        {xl} = {xc}")
    e(f"{Wr(f'cxl{i}')} = {xl}")
    e(f"{Wr(f'cxh{i}')} = TBX[{o + 1} + {li}]")
    e(f"{Wr(f'cyl{i}')} = TBY[{o} + {li}]")
    e(f"{Wr(f'cyh{i}')} = TBY[{o + 1} + {li}]")


def _emit_hit(st: _Structure, i: int, xv: str) -> str:
    """Lane-wise: the cached interval still contains ``xv`` (or the table clamps it anyway)."""
    t = st.tmap[i]
    return (f"((cxl{i} <= {xv}) & ({xv} < cxh{i})) | ({xv} <= x0_{t}) | ({xv} >= xm_{t})")


def _emit_interp_cached(e: _Emitter, st: _Structure, i: int, xv: str) -> str:
    """vehicle_sim._interp from the lane's cached interval (same expression, same numbers)."""
    t = st.tmap[i]
    out = e.tmp("cmd")
    e(f"{out} = y0_{t} if {xv} <= x0_{t} else (ym_{t} if {xv} >= xm_{t} else "
      f"cyl{i} + (cyh{i} - cyl{i}) * ({xv} - cxl{i}) / (cxh{i} - cxl{i}))")
    return out


def _emit_atan2(e: _Emitter, y: str, x: str) -> str:
    """Branch-free atan2 (Cephes' atan with its two range reductions; ≤ 2 ulp from libm)."""
    P, Q = _ATAN_P, _ATAN_Q
    ay, ax, big, mid, num, den, w, zz, pz, qz, r = (e.tmp(s) for s in (
        "ay", "ax", "big", "mid", "num", "den", "w", "zz", "pz", "qz", "r"))
    e(f"{ay} = abs({y})")
    e(f"{ax} = abs({x})")
    e(f"{big} = {ay} > {_T3P8!r} * {ax}")
    e(f"{mid} = {ay} > 0.66 * {ax}")
    e(f"{num} = -{ax} if {big} else ({ay} - {ax} if {mid} else {ay})")
    e(f"{den} = {ay} if {big} else ({ay} + {ax} if {mid} else {ax})")
    e(f"{w} = 0.0 if {ay} == 0.0 else {num} / {den}")
    e(f"{zz} = {w} * {w}")
    e(f"{pz} = (((({P[0]!r} * {zz} + {P[1]!r}) * {zz} + {P[2]!r}) * {zz} + {P[3]!r}) * {zz} + {P[4]!r})")
    e(f"{qz} = ((((({zz} + {Q[0]!r}) * {zz} + {Q[1]!r}) * {zz} + {Q[2]!r}) * {zz} + {Q[3]!r}) * {zz}"
      f" + {Q[4]!r})")
    e(f"{r} = {w} * ({zz} * {pz} / {qz}) + {w}")
    e(f"{r} = ({math.pi / 2!r} + ({r} + {_MOREBITS!r})) if {big} else "
      f"(({math.pi / 4!r} + ({r} + {0.5 * _MOREBITS!r})) if {mid} else {r})")
    e(f"{r} = {math.pi!r} - {r} if math.copysign(1.0, {x}) < 0.0 else {r}")
    out = e.tmp("atan2")
    e(f"{out} = math.copysign({r}, {y})")
    return out


def _rows(st: _Structure) -> dict:
    """Rows of the workspace ``W[row, lane]`` (lane state kept from step to step)."""
    n = st.n
    names = ([f"z{j}" for j in range(13)]  # vehicle state
             + ([f"x{i}" for i in range(n)] if st.dyn else [])  # thruster states
             + ([f"uq{j}" for j in range(6)] if st.user else [f"ig{j}" for j in range(4)])  # user
             # controller's wrench of the step, or the PID integrators
             + [f"tg{i}" for i in range(n)]  # first-order target (static chain: thrust) of the step
             + [f"{nm}{i}" for i in range(n) for nm in ("cxl", "cxh", "cyl", "cyh")]  # table interval
             + [f"fd{i}" for i in range(n)] + ["miss"]  # allocated thrust, lane needs a search
             + ["emax", "esum", "fmax", "smin", "nsat", "dfin", "cmin"])  # running summaries
    return {name: k for k, name in enumerate(names)}


def _generate(st: _Structure, pv_names: list, sh_names: list) -> str:
    CW = st.chunk
    rows = _rows(st)
    nrow = len(rows)
    pvi = {name: k for k, name in enumerate(pv_names)}

    def Wr(name):  # lane v of a workspace row (flat array, literal offset: no alias checks)
        return f"W[{rows[name] * CW} + v]"

    def Pr(name):
        return f"PV[{pvi[name] * CW} + v]"

    e = _Emitter()
    e("# generated by uuvid.simulate.batch — do not edit")
    e("import math")
    e("import numpy as np")
    if st.inflow:
        e("from uuvid.core.fused import fma")
    e("")
    e(f"NROW = {nrow}")
    e(f"NPV = {len(pv_names)}")
    e(f"CW = {CW}")
    e("")
    e("")
    if st.user:  # the user's controller (_UCTRL, set in the module) gets its params CP and a
        # state per lane (rows of CS, each a copy of CS0)
        e("def run_chunk(W, PV, TBX, TBY, GRID, REF, SH, TR, do_trace, trace_every, nsteps, dt, h, "
          "CP, CS0):")
    else:
        e("def run_chunk(W, PV, TBX, TBY, GRID, REF, SH, TR, do_trace, trace_every, nsteps, dt, h):")
    e.ind = 1
    if st.user:
        e(f"CS = np.empty(({CW}, CS0.size))")
        e(f"for v in range({CW}):")
        e("    CS[v, :] = CS0")
        for nm, m in (("ETA", 7), ("NU", 6), ("RP", 3), ("RV", 3), ("TQ", 6)):
            e(f"{nm} = np.zeros({m})")
    for k, name in enumerate(sh_names):
        e(f"{name} = SH[{k}]")
    e("hh = 0.5 * h")
    e("h6 = h / 6.0")
    e("ntr = 0")
    e(f"LST = np.empty({CW}, dtype=np.int64)")
    e("for k in range(nsteps):")
    e.ind = 2
    for j, nm in enumerate(("rp0", "rp1", "rp2", "rv0", "rv1", "rv2", "ryaw", "rrate")):
        e(f"{nm} = REF[k, {j}]")
    if st.user:  # ---------------------------------------------- loop A0: the user's controller
        for j in range(3):
            e(f"RP[{j}] = rp{j}")
            e(f"RV[{j}] = rv{j}")
        e(f"for v in range({CW}):")
        e.ind = 3
        for j in range(13):
            e(f"{'ETA' if j < 7 else 'NU'}[{j if j < 7 else j - 7}] = {Wr(f'z{j}')}")
        e("_UCTRL(k * dt, ETA, NU, RP, RV, ryaw, rrate, CP, CS[v], dt, TQ)")
        for j in range(6):
            e(f"{Wr(f'uq{j}')} = TQ[{j}]")
        e.ind = 2
    # ------------------------------------------------------------------ loop A: controller etc.
    e(f"for v in range({CW}):")
    e.ind = 3
    e.begin_ssa("a_")
    z = [f"z{j}" for j in range(13)]
    for j in range(13):
        e(f"{z[j]} = {Wr(z[j])}")
    e("t0 = z0 - rp0")
    e("t1 = z1 - rp1")
    e("t2 = z2 - rp2")
    e("dd = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)")
    e(f"{Wr('emax')} = max({Wr('emax')}, dd)")
    e(f"{Wr('esum')} = {Wr('esum')} + dd * dd")
    e(f"{Wr('dfin')} = dd")
    e(f"{Wr('cmin')} = min({Wr('cmin')}, 1.0 - 2.0 * (z4 * z4 + z5 * z5))")
    if st.user:
        for j in range(6):
            e(f"tq{j} = {Wr(f'uq{j}')}")
    else:
        _emit_pid(e, st, Wr)
    _emit_allocation(e, st, Wr)
    e.end_ssa()
    _emit_rest(e, st, Wr, Pr, z, pv_names)
    return "\n".join(e.lines) + "\n"


def _emit_pid(e: _Emitter, st: _Structure, Wr) -> None:
    """Loop A's built-in controller: control.dp_errors, dp_control, attitude_hold inline."""
    # dp_errors
    e("R00 = 1 - 2 * (z5 * z5 + z6 * z6)")
    e("R01 = 2 * (z4 * z5 - z6 * z3)")
    e("R02 = 2 * (z4 * z6 + z5 * z3)")
    e("R10 = 2 * (z4 * z5 + z6 * z3)")
    e("R11 = 1 - 2 * (z4 * z4 + z6 * z6)")
    e("R12 = 2 * (z5 * z6 - z4 * z3)")
    e("R20 = 2 * (z4 * z6 - z5 * z3)")
    e("R21 = 2 * (z5 * z6 + z4 * z3)")
    e("R22 = 1 - 2 * (z4 * z4 + z5 * z5)")
    e("p0 = rp0 - z0")
    e("p1 = rp1 - z1")
    e("p2 = rp2 - z2")
    for i in range(3):
        e(f"e{i} = R0{i} * p0 + R1{i} * p1 + R2{i} * p2")
        e(f"ed{i} = (R0{i} * rv0 + R1{i} * rv1 + R2{i} * rv2) - z{7 + i}")
    yaw = _emit_atan2(e, "2 * (z3 * z6 + z4 * z5)", "1 - 2 * (z5 * z5 + z6 * z6)")
    e(f"xw = (ryaw - {yaw}) + math.pi")
    e("xw = xw + 2.0 * math.pi if xw < 0.0 else (xw - 2.0 * math.pi if xw >= 2.0 * math.pi else xw)")
    e("e3 = xw - math.pi")
    e("ed3 = rrate - z12")
    # dp_control
    for j in range(4):
        ig = Wr(f"ig{j}")
        e(f"ii = {ig}")
        e(f"uu = kp{j} * e{j} + ki{j} * ii + kd{j} * ed{j}")
        e(f"sat = (abs(uu) >= tmax{j}) & (uu * e{j} > 0)")
        e(f"ni = ii if sat else ii + e{j} * dt")
        if st.ki_pos[j]:
            e(f"ni = min(max(ni, -ilim{j}), ilim{j})")
        e(f"{ig} = ni")
        e(f"u = kp{j} * e{j} + ki{j} * ni + kd{j} * ed{j}")
        e(f"tq{DP_DOFS[j]} = min(max(u, -tmax{j}), tmax{j})")
    if st.attitude:  # control.attitude_hold
        roll = _emit_atan2(e, "2 * (z3 * z4 + z5 * z6)", "1 - 2 * (z4 * z4 + z5 * z5)")
        e("sp = 2 * (z3 * z5 - z6 * z4)")
        e("sp = min(1.0, max(-1.0, sp))")
        # asin(s) = atan2(s, √((1 − s)(1 + s))): ≤ 2 ulp from libm's asin over [−1, 1]
        pitch = _emit_atan2(e, "sp", "math.sqrt((1.0 - sp) * (1.0 + sp))")
        e(f"tq3 = -kpa0 * {roll} - kda0 * z10")
        e(f"tq4 = -kpa1 * {pitch} - kda1 * z11")


def _emit_allocation(e: _Emitter, st: _Structure, Wr) -> None:
    """Loop A: allocate_compiled with uniform scaling, summaries, cached-interval check."""
    n = st.n
    # allocate_compiled
    e("sc = 1.0")
    for i in range(n):
        e(f"ta{i} = " + _sum(f"T{i}_{j} * tq{j}" for j in range(6) if st.tpat[i * 6 + j]))
        if st.compensate:
            e(f"ta{i} = ta{i} / (aep{i} if ta{i} >= 0.0 else aen{i})")
        # one division: the limit that is crossed (the same quotient allocate_compiled takes)
        e(f"lim = hi{i} if ta{i} > hi{i} else lo{i}")
        e(f"ra = lim / ta{i}")
        e(f"sc = min(sc, ra if (ta{i} > hi{i}) | (ta{i} < lo{i}) else 1.0)")
    e(f"{Wr('smin')} = min({Wr('smin')}, sc)")
    e(f"{Wr('nsat')} = {Wr('nsat')} + (1.0 if sc < 1.0 else 0.0)")
    e("miss = 0.0")
    for i in range(n):
        e(f"fd{i} = ta{i} * sc")
        e(f"{Wr(f'fd{i}')} = fd{i}")
        e(f"cxl{i} = {Wr(f'cxl{i}')}")
        e(f"cxh{i} = {Wr(f'cxh{i}')}")
        e(f"miss = miss + (0.0 if {_emit_hit(st, i, f'fd{i}')} else 1.0)")
    e(f"{Wr('miss')} = miss")


def _emit_rest(e: _Emitter, st: _Structure, Wr, Pr, z, pv_names) -> None:
    """The scalar interval search, loop A2 (inverse maps → first-order targets) and loop B
    (RK4 over the substeps)."""
    n = st.n
    CW = st.chunk
    # ---- scalar fix-up of the lanes whose thrust left its cached table interval (a few %)
    e.ind = 2
    e("nmiss = 0")
    e(f"for v in range({CW}):")
    e(f"    if {Wr('miss')} != 0.0:")
    e("        LST[nmiss] = v")
    e("        nmiss += 1")
    e("for jm in range(nmiss):")
    e.ind = 3
    e("v = LST[jm]")
    for i in range(n):
        e(f"fd{i} = {Wr(f'fd{i}')}")
        e(f"cxl{i} = {Wr(f'cxl{i}')}")
        e(f"cxh{i} = {Wr(f'cxh{i}')}")
        e(f"if not ({_emit_hit(st, i, f'fd{i}')}):")
        e.ind += 1
        _emit_search(e, st, i, f"fd{i}", Wr)
        e.ind -= 1
    # ---- loop A2: inverse maps from the cached intervals, static prefix → first-order target
    e.ind = 2
    e(f"for v in range({CW}):")
    e.ind = 3
    e.begin_ssa("c_")
    for i in range(n):
        e(f"fd{i} = {Wr(f'fd{i}')}")
        for nm in ("cxl", "cxh", "cyl", "cyh"):
            e(f"{nm}{i} = {Wr(f'{nm}{i}')}")
        sig = _emit_interp_cached(e, st, i, f"fd{i}")
        for bi, bdesc in enumerate(st.prefix):
            for j in _static_param_slots(bdesc):
                e(f"t{i}b{bi}p{j} = {Pr(f't{i}b{bi}p{j}')}")
            sig = _emit_static(e, bdesc, f"t{i}b{bi}", sig)
        if st.dyn == K_FIRST_ORDER_MOTOR:
            e(f"{Wr(f'tg{i}')} = {Pr(f't{i}gain')} * {sig}")
        elif st.dyn == K_FIRST_ORDER:
            e(f"{Wr(f'tg{i}')} = {sig}")
        else:  # static chain: the thrust itself, held over the step
            th = sig if st.eta_one[i] else f"{sig} * (ep{i} if {sig} >= 0.0 else en{i})"
            e(f"{Wr(f'tg{i}')} = {th}")
    e.end_ssa()
    e.ind = 2
    e("if do_trace and k % trace_every == 0:")
    e("    for j in range(13):")
    e(f"        for v in range({CW}):")
    e(f"            TR[ntr, j, v] = W[j * {CW} + v]")
    e("    ntr += 1")
    # ------------------------------------------------------------------ loop B: RK4
    e(f"for sub in range({st.nsub}):")
    e.ind = 3
    e(f"for v in range({CW}):")
    e.ind = 4
    e.begin_ssa("b_")
    for j in range(13):
        e(f"{z[j]} = {Wr(z[j])}")
    # per-lane vehicle parameters used by the RHS
    for name in pv_names:
        if not name.startswith("t"):
            e(f"{name} = {Pr(name)}")
    nb_pre = len(st.prefix)
    th = [[None] * n for _ in range(3)]
    for i in range(n):
        if st.dyn:
            e(f"xi = {Wr(f'x{i}')}")
            e(f"tg = {Wr(f'tg{i}')}")
            e("dx = xi - tg")
            for bi, bdesc in zip(range(nb_pre + 1, nb_pre + 1 + len(st.suffix)), st.suffix):
                for j in _static_param_slots(bdesc):
                    e(f"t{i}b{bi}p{j} = {Pr(f't{i}b{bi}p{j}')}")
            for stg, ex in ((0, None), (1, f"t{i}e1"), (2, f"t{i}e2")):
                xs = e.tmp("xs")
                if ex is None:
                    e(f"{xs} = tg + dx")
                else:
                    e(f"{xs} = tg + dx * {Pr(ex)}")
                sig = xs
                for bdesc, bi in zip(st.suffix, range(nb_pre + 1, nb_pre + 1 + len(st.suffix))):
                    sig = _emit_static(e, bdesc, f"t{i}b{bi}", sig)
                thv = f"th{stg}_{i}"
                if st.eta_one[i] or st.inflow:  # inflow: η after the map, per RK4 stage
                    e(f"{thv} = {sig}")
                else:
                    e(f"{thv} = {sig} * (ep{i} if {sig} >= 0.0 else en{i})")
                th[stg][i] = thv
                if stg == 2:
                    e(f"{Wr(f'x{i}')} = {xs}")
        else:
            e(f"th0_{i} = {Wr(f'tg{i}')}")
            th[0][i] = th[1][i] = th[2][i] = f"th0_{i}"
    fm = Wr("fmax")

    def emit_fmax(thrusts):
        e(f"fm = {fm}")
        for i in range(n):
            e(f"fm = max(fm, abs({thrusts[i]}))")
        if st.nsub > 1:
            e(f"{fm} = fm if sub == 0 else {fm}")
        else:
            e(f"{fm} = fm")

    def emit_tau(thrusts, tag):
        tv = []
        for k in range(6):
            terms = [f"B{k}_{i} * {thrusts[i]}" for i in range(n) if st.bpat[k * n + i]]
            if terms:
                nm = f"tau{tag}_{k}"
                e(f"{nm} = " + _sum(terms))
                tv.append(nm)
            else:
                tv.append("0.0")
        return tv

    zt = [f"zt{j}" for j in range(13)]
    zu = [f"zu{j}" for j in range(13)]
    zw = [f"zw{j}" for j in range(13)]
    if st.inflow:  # thrust at the advance speed of each stage's own state (_vehicle_rk4_inflow)
        f0 = _emit_inflow_thrusts(e, st, z, th[0])
        emit_fmax(f0)
        k1 = _emit_rhs(e, st, z, emit_tau(f0, "0"), "a")
        for j in range(13):
            e(f"{zt[j]} = {z[j]} + hh * {k1[j]}")
        k2 = _emit_rhs(e, st, zt, emit_tau(_emit_inflow_thrusts(e, st, zt, th[1]), "1"), "b")
        for j in range(13):
            e(f"{zu[j]} = {z[j]} + hh * {k2[j]}")
        k3 = _emit_rhs(e, st, zu, emit_tau(_emit_inflow_thrusts(e, st, zu, th[1]), "2"), "c")
        for j in range(13):
            e(f"{zw[j]} = {z[j]} + h * {k3[j]}")
        k4 = _emit_rhs(e, st, zw, emit_tau(_emit_inflow_thrusts(e, st, zw, th[2]), "3"), "d")
    else:
        emit_fmax(th[0])
        stages = (0, 1, 2) if st.dyn else (0,)
        taus = {stg: emit_tau(th[stg], str(stg)) for stg in stages}
        if not st.dyn:
            taus[1] = taus[2] = taus[0]
        k1 = _emit_rhs(e, st, z, taus[0], "a")
        for j in range(13):
            e(f"{zt[j]} = {z[j]} + hh * {k1[j]}")
        k2 = _emit_rhs(e, st, zt, taus[1], "b")
        for j in range(13):
            e(f"{zu[j]} = {z[j]} + hh * {k2[j]}")
        k3 = _emit_rhs(e, st, zu, taus[1], "c")
        for j in range(13):
            e(f"{zw[j]} = {z[j]} + h * {k3[j]}")
        k4 = _emit_rhs(e, st, zw, taus[2], "d")
    for j in range(13):
        # 2.0·k = k + k exactly (an addition instead of a multiplication)
        e(f"n{j} = {z[j]} + h6 * ({k1[j]} + ({k2[j]} + {k2[j]}) + ({k3[j]} + {k3[j]}) + {k4[j]})")
    e("nq = math.sqrt(n3 * n3 + n4 * n4 + n5 * n5 + n6 * n6)")
    e("sq = 1.0 / nq")  # −1/n = −(1/n) exactly
    e("sq = sq if n3 >= 0.0 else -sq")
    for j in range(13):
        val = f"n{j} * sq" if 3 <= j <= 6 else f"n{j}"
        e(f"{Wr(z[j])} = {val}")
    e.end_ssa()


# ---------------------------------------------------------------------------------------------
# Compilation (generated module on disk so that numba's cache works)
# ---------------------------------------------------------------------------------------------
_KERNELS: dict = {}
_LOCK = threading.Lock()


def _cache_dir() -> str:
    d = os.environ.get("UUVID_KERNEL_CACHE")
    if not d:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        d = os.path.join(base, "uuvid", "batch_kernels")
    try:
        os.makedirs(d, exist_ok=True)
        if os.access(d, os.W_OK):
            return d
    except OSError:
        pass
    uid = os.getuid() if hasattr(os, "getuid") else 0
    d = os.path.join(tempfile.gettempdir(), f"uuvid-batch-kernels-{uid}")
    os.makedirs(d, exist_ok=True)
    return d


def _kernel(st: _Structure, pv_names, sh_names, ctrl_fn=None):
    """``(run_chunk, module, source)`` of a structure, memoised; with a user's controller
    ``ctrl_fn`` (``st.user``) compiled around it in memory, not cached on disk (numba's cache
    would not see which function the module's ``_UCTRL`` is): one compile per process."""
    key = st.key()
    mkey = (key, ctrl_fn) if st.user else key
    with _LOCK:
        if mkey in _KERNELS:
            return _KERNELS[mkey]
        from numba import njit

        src = _generate(st, pv_names, sh_names)
        # the generated module calls the package's compiled kernels, which numba's cache does not
        # track: the compiled code's version (version + digest of the numba modules) is in its name
        from uuvid.core.cache import compiled_code_version, digest

        modname = f"_uuvid_batch_{key}_{digest(compiled_code_version())[:12]}"
        path = os.path.join(_cache_dir(), modname + ".py")
        try:
            if st.user:
                raise OSError("user controller: compiled in memory")
            old = open(path).read() if os.path.exists(path) else None
            if old != src:
                tmp = f"{path}.{os.getpid()}.tmp"
                with open(tmp, "w") as fh:
                    fh.write(src)
                os.replace(tmp, path)
            spec = importlib.util.spec_from_file_location(modname, path)
            mod = importlib.util.module_from_spec(spec)
            sys.modules[modname] = mod
            spec.loader.exec_module(mod)
            cache = True
        except OSError:  # read-only everything: compile from memory, no disk cache
            import types

            mod = types.ModuleType(modname)
            mod._UCTRL = ctrl_fn
            exec(compile(src, modname, "exec"), mod.__dict__)
            cache = False
        fm = set(st.fastmath) if st.fastmath else False
        run_chunk = njit(cache=cache, error_model="numpy", fastmath=fm, nogil=True)(mod.run_chunk)
        mod.run_chunk = run_chunk
        _KERNELS[mkey] = (run_chunk, mod, src)
        return _KERNELS[mkey]


# ---------------------------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------------------------
def _inputs(setup, vehicle_params, thruster_params, currents):
    return vehicle_sim.batch_inputs(setup, vehicle_params, thruster_params, currents)


def fast_path_reason(setup, vehicle_params=None, thruster_params=None, currents=None) -> str | None:
    """``None`` if :func:`run_batch_fast` uses the SIMD kernel for these inputs, else why not."""
    VP, TP, VC = _inputs(setup, setup.vp[None] if vehicle_params is None else vehicle_params,
                         thruster_params, currents)
    try:
        _analyse(setup, VP, TP, VC, DEFAULT_CHUNK, ())
    except _NoFastPath as exc:
        return str(exc)
    return None


def run_batch_fast(setup, vehicle_params, thruster_params=None, currents=None, *,
                   chunk: int = DEFAULT_CHUNK, fastmath=(), trace_runs=(), trace_every: int = 100,
                   threads: int | None = None, fallback: bool = True):
    """Fly ``len(vehicle_params)`` vehicles with the SIMD batch kernel.

    ``setup`` from :func:`uuvid.simulate.vehicle_sim.setup_mission`; ``vehicle_params`` (R, 193)
    rows of :meth:`~uuvid.vehicle.model.VehicleParams.to_array`; ``thruster_params`` (R, n, P)
    (default: the setup's) — the inverse thrust tables stay the setup's, as in ``run_batch``;
    ``currents`` (R, 3) NED (default: the setup's current; the current slots of
    ``vehicle_params`` are ignored, as in ``run_batch``).

    Returns (R, 9) rows, columns :data:`SUMMARY_COLUMNS` (the first five are ``run_batch``'s; its
    sixth, the tilt, is column 8).
    ``chunk``: lanes per chunk (multiple of 8); ``fastmath``: numba fast-math flags for the kernel
    (default none: IEEE, identical to ``fly()`` up to rounding; ``{"contract"}`` allows FMA).
    With ``trace_runs`` (run indices) it returns ``(summary, trace)``, ``trace`` being
    (len(trace_runs), ceil(steps/trace_every), 13) vehicle states at every ``trace_every``-th step.
    A compiled wrench controller of the setup flies inside the kernel (per lane).  Chains the
    kernel does not handle go to ``vehicle_sim.fly_batch``, setups with a disturbance, a
    per-thruster or a plain Python controller to ``vehicle_sim.run_batch`` (one compiled loop
    per vehicle); ``fallback=False`` raises instead; there column 6 is NaN and traces are not
    available.
    """
    s = setup
    vehicle_sim.require_constant_current(s)
    VP, TP, VC = _inputs(s, vehicle_params, thruster_params, currents)
    R = VP.shape[0]
    trace_runs = [int(r) for r in trace_runs]
    if any(not 0 <= r < R for r in trace_runs):
        raise ValueError(f"trace_runs: expected run indices in [0, {R}), got {trace_runs}")
    if R == 0:
        return np.empty((0, N_SUMMARY))
    try:
        prep = _analyse(s, VP, TP, VC, int(chunk), tuple(fastmath))
    except _NoFastPath as exc:
        if not fallback or trace_runs:
            raise ValueError(f"batch kernel not applicable: {exc}") from None
        return _fallback(s, VP, TP, VC)
    st = prep.struct
    ctrl = s.controller if st.user else None
    run_chunk, _, _ = _kernel(st, prep.pv_names, prep.shared_names,
                              ctrl.fn if ctrl is not None else None)
    extra = (ctrl.params, ctrl.state0) if ctrl is not None else ()
    CW = st.chunk
    nch = -(-R // CW)
    Rp = nch * CW
    pad = np.minimum(np.arange(Rp), R - 1)  # padding lanes repeat the last run

    def lanes(a):
        return np.ascontiguousarray(np.asarray(a, dtype=float)[pad].reshape(nch, CW))

    PV = np.empty((nch, max(len(prep.pv_names), 1), CW))
    for k, name in enumerate(prep.pv_names):
        PV[:, k, :] = lanes(prep.pv[name])
    rows = _rows(st)
    nrow = len(rows)
    W = np.zeros((nch, nrow, CW))
    z0 = s.z0()
    for j in range(13):
        W[:, rows[f"z{j}"], :] = z0[j]
    if st.dyn:
        for i in range(st.n):
            W[:, rows[f"x{i}"], :] = z0[13 + i]
    W[:, rows["smin"], :] = 1.0
    W[:, rows["cmin"], :] = 1.0
    SH = np.array([prep.shared[k] for k in prep.shared_names] or [0.0])
    nsteps = prep.ref.shape[0]
    every = max(int(trace_every), 1)
    TRMAP = -np.ones(nch, dtype=np.int64)
    tchunks = sorted({r // CW for r in trace_runs})
    for t, c in enumerate(tchunks):
        TRMAP[c] = t
    ntr = -(-nsteps // every) if trace_runs else 0
    TR = np.zeros((max(len(tchunks), 1), ntr, 13, CW))
    Wc = W.reshape(nch, -1)  # chunk c: one contiguous row per chunk
    PVc = PV.reshape(nch, -1)
    h = s.dt / s.substeps

    def work(c):
        t = int(TRMAP[c])
        run_chunk(Wc[c], PVc[c], prep.tbx, prep.tby, prep.grid, prep.ref, SH, TR[max(t, 0)], t >= 0,
                  every, nsteps, s.dt, h, *extra)

    nthr = _threads(threads)
    if nthr <= 1 or nch == 1:
        for c in range(nch):
            work(c)
    else:  # the kernel releases the GIL; chunks are handed out dynamically
        with ThreadPoolExecutor(min(nthr, nch)) as pool:
            list(pool.map(work, range(nch)))
    Wf = W.transpose(0, 2, 1).reshape(Rp, nrow)[:R]
    out = np.empty((R, N_SUMMARY))
    out[:, 0] = Wf[:, rows["emax"]]
    out[:, 1] = np.sqrt(Wf[:, rows["esum"]] / nsteps)
    out[:, 2] = Wf[:, rows["fmax"]]
    out[:, 3] = Wf[:, rows["dfin"]]
    out[:, 4] = Wf[:, rows["smin"]]
    out[:, 8] = np.degrees(np.arccos(np.clip(Wf[:, rows["cmin"]], -1.0, 1.0)))
    out[:, 5] = (vehicle_sim.mission_completed(out[:, 0], out[:, 3], out[:, 8])
                 & (vehicle_sim.path_cut(s) is None)).astype(float)
    out[:, 6] = Wf[:, rows["nsat"]] / nsteps
    out[:, 7] = np.all(np.isfinite(Wf[:, :13]), axis=1).astype(float)
    if vehicle_sim.allocation_method(s.alloc) != "scale":
        # the kernel allocates by uniform scaling, which a bounded method matches exactly while
        # the thrusters stay inside their limits: runs that saturated are flown again by fly()
        sat = np.flatnonzero(out[:, 6] > 0)
        if sat.size:
            out[sat] = _fallback(s, VP[sat], TP[sat], VC[sat])
    else:
        sat = np.zeros(0, dtype=int)
    if not trace_runs:
        return out
    trace = np.stack([TR[TRMAP[r // CW], :, :, r % CW] for r in trace_runs])
    for j, r in enumerate(trace_runs):
        if r in sat:  # flown again under the bounded method: its trace from that flight too
            trace[j] = _fly_trace(s, VP[r], TP[r], VC[r], every, trace.shape[1])
    return out, trace


def _threads(threads) -> int:
    if threads is not None:
        return max(int(threads), 1)
    import numba

    return int(numba.get_num_threads())


def _fly_trace(s, vp, tp, vc, every: int, rows: int) -> np.ndarray:
    """Vehicle states (13) of one perturbed run at every ``every``-th step, from fly()."""
    import dataclasses

    one = dataclasses.replace(s, vp=np.ascontiguousarray(vp), current=np.ascontiguousarray(vc),
                              bank=dataclasses.replace(s.bank, params=np.ascontiguousarray(tp)))
    return vehicle_sim.fly_mission(one).state[::every, :13][:rows]


def _fallback(s, VP, TP, VC) -> np.ndarray:
    b = s.bank
    R = VP.shape[0]
    o5 = np.empty((R, len(vehicle_sim.RUN_COLUMNS)))
    if s.controller is not None or s.disturbance is not None:
        o5 = vehicle_sim.run_batch(s, VP, TP, VC)
    else:
        ref_pos, ref_vel, ref_yaw, ref_rate = (np.ascontiguousarray(a) for a in s.ref)
        vehicle_sim.fly_batch(s.z0(), VP, s.B, s.alloc, s.eta_p, s.eta_n, s.dofs, b.kinds, b.poff,
                              TP, b.soff, b.outch, b.in_ch, b.exact, b.inv_thrust, b.inv_command,
                              s.gains.to_array(), ref_pos, ref_vel, ref_yaw, ref_rate, VC, s.dt,
                              s.substeps, o5, s.inflow_arrays)
    out = np.full((R, N_SUMMARY), np.nan)
    out[:, :5] = o5[:, :5]
    out[:, 8] = o5[:, 5]
    out[:, 5] = (vehicle_sim.mission_completed(o5[:, 0], o5[:, 3], o5[:, 5])
                 & (vehicle_sim.path_cut(s) is None)).astype(float)
    out[:, 7] = np.all(np.isfinite(o5), axis=1).astype(float)
    return out


# ---------------------------------------------------------------------------------------------
# Perturbed parameter sets
# ---------------------------------------------------------------------------------------------
def _uniform(rng, bounds, size):
    lo, hi = (float(bounds), float(bounds)) if np.ndim(bounds) == 0 else (float(bounds[0]),
                                                                            float(bounds[1]))
    if hi < lo:
        raise ValueError(f"bad range {bounds!r}")
    return rng.uniform(lo, hi, size) if hi > lo else np.full(size, lo)


def perturb_vehicle_params(vehicle, rng, runs: int, *, mass_scale=(0.95, 1.05),
                           added_mass_scale=(0.5, 1.5), damping_scale=(0.5, 1.5),
                           current_speed=(0.0, 0.2)) -> np.ndarray:
    """``runs`` perturbed copies of a vehicle's parameters as (runs, 193) rows of
    :meth:`VehicleParams.to_array <uuvid.vehicle.model.VehicleParams.to_array>`.

    ``vehicle`` is a loaded vehicle (or a :class:`~uuvid.vehicle.model.VehicleParams`); ``rng`` a
    :class:`numpy.random.Generator`.  Every range is ``(low, high)`` of a uniform draw (a single
    number: no perturbation):

    * ``mass_scale`` multiplies mass, inertia and weight together (buoyancy stays: the net
      buoyancy changes, as with a payload);
    * ``added_mass_scale`` draws a factor ``s_i`` per DOF, ``M_A ← D^½ M_A D^½`` (``D = diag s``:
      symmetric and positive semi-definite like the original, the diagonal scaled by ``s_i``);
    * ``damping_scale`` the same, independently, for ``D_L`` and ``D_Q``;
    * ``current_speed`` a horizontal current of that speed in a uniformly random direction, stored
      in the current slots (pass ``VP[:, P_VC:P_VC + 3]`` as ``currents`` — or use
      :func:`perturb_batch`, which does).

    The rows equal ``dataclasses.replace(params, mass=…, …).to_array()`` (same formulas,
    vectorised: 10 000 draws take a few milliseconds).
    """
    p = getattr(vehicle, "params", vehicle)
    R = int(runs)
    ms = _uniform(rng, mass_scale, R)
    sa = _uniform(rng, added_mass_scale, (R, 6))
    sl = _uniform(rng, damping_scale, (R, 6))
    sq = _uniform(rng, damping_scale, (R, 6))
    speed = _uniform(rng, current_speed, R)
    heading = rng.uniform(0.0, 2.0 * np.pi, R)
    mass = p.mass * ms
    Ig = np.asarray(p.inertia)[None] * ms[:, None, None]
    rg = np.asarray(p.r_g, dtype=float)
    S = np.array([[0.0, -rg[2], rg[1]], [rg[2], 0.0, -rg[0]], [-rg[1], rg[0], 0.0]])
    MRB = np.zeros((R, 6, 6))
    MRB[:, :3, :3] = mass[:, None, None] * np.eye(3)
    MRB[:, :3, 3:] = -mass[:, None, None] * S
    MRB[:, 3:, :3] = mass[:, None, None] * S
    MRB[:, 3:, 3:] = Ig - (mass[:, None, None] * S) @ S  # inertia_about_origin
    ra, rl, rq = np.sqrt(sa), np.sqrt(sl), np.sqrt(sq)
    MA = np.asarray(p.added_mass)[None] * (ra[:, :, None] * ra[:, None, :])
    DL = np.asarray(p.linear_damping)[None] * (rl[:, :, None] * rl[:, None, :])
    DQ = np.asarray(p.quadratic_damping)[None] * (rq[:, :, None] * rq[:, None, :])
    VP = np.zeros((R, N_PARAMS))
    VP[:, P_VERSION] = LAYOUT_VERSION
    VP[:, P_MINV:P_MINV + 36] = np.linalg.inv(MRB + MA).reshape(R, 36)
    VP[:, P_MRB:P_MRB + 36] = MRB.reshape(R, 36)
    VP[:, P_MA:P_MA + 36] = MA.reshape(R, 36)
    VP[:, P_DL:P_DL + 36] = DL.reshape(R, 36)
    VP[:, P_DQ:P_DQ + 36] = DQ.reshape(R, 36)
    VP[:, P_W] = p.weight * ms
    VP[:, P_B] = p.buoyancy
    VP[:, P_RG:P_RG + 3] = rg
    VP[:, P_RB:P_RB + 3] = np.asarray(p.r_b, dtype=float)
    VP[:, P_VC] = speed * np.cos(heading)
    VP[:, P_VC + 1] = speed * np.sin(heading)
    VP[:, P_VC + 2] = 0.0
    VP[:, P_GAMMA] = p.quaternion_gain
    return VP


def perturb_thruster_params(setup, rng, runs: int, *, time_constant_scale=(0.7, 1.3),
                            thrust_scale=(0.9, 1.1)) -> np.ndarray:
    """(runs, n, P) thruster parameters around the setup's: per run and thruster, the time
    constant of every first-order block is scaled by a draw from ``time_constant_scale`` and the
    thrust map (quadratic coefficients, polynomial coefficients) by one from ``thrust_scale``.
    The controller keeps inverting the *nominal* maps (as ``run_batch`` does), so a thrust scale
    is a model error the loop has to absorb."""
    b = setup.bank
    R = int(runs)
    n = b.n
    TP = np.repeat(np.asarray(b.params, dtype=float)[None], R, axis=0)
    ts = _uniform(rng, time_constant_scale, (R, n))
    ks = _uniform(rng, thrust_scale, (R, n))
    for blk, kind in enumerate(int(k) for k in b.kinds):
        pb = int(b.poff[blk])
        if kind == K_FIRST_ORDER_MOTOR:
            TP[:, :, pb + 1] *= ts
        elif kind == K_FIRST_ORDER:
            TP[:, :, pb] *= ts
        elif kind == K_QUADRATIC:
            TP[:, :, pb] *= ks
            TP[:, :, pb + 1] *= ks
        elif kind == K_POLYNOMIAL:
            nf, nr = int(b.params[0, pb]), int(b.params[0, pb + 1])
            TP[:, :, pb + 2:pb + 2 + nf + nr] *= ks[:, :, None]
    return TP


def perturb_batch(setup, rng, runs: int, *, thrusters: bool = True, **kw):
    """``(vehicle_params, thruster_params, currents)`` for :func:`run_batch_fast` (or
    ``run_batch``): :func:`perturb_vehicle_params` of the setup's vehicle (keywords
    ``mass_scale``, ``added_mass_scale``, ``damping_scale``, ``current_speed``) and, with
    ``thrusters``, :func:`perturb_thruster_params` (``time_constant_scale``, ``thrust_scale``)."""
    tkw = {k: kw.pop(k) for k in ("time_constant_scale", "thrust_scale") if k in kw}
    VP = perturb_vehicle_params(setup.vehicle, rng, runs, **kw)
    TP = perturb_thruster_params(setup, rng, runs, **tkw) if thrusters else None
    return VP, TP, np.ascontiguousarray(VP[:, P_VC:P_VC + 3])


# ---------------------------------------------------------------------------------------------
# Throughput measurement (called by the benchmarks; not a unit test)
# ---------------------------------------------------------------------------------------------
def batch_throughput(setup, runs: int = 1000, *, seed: int = 0, chunk: int = DEFAULT_CHUNK,
                     fastmath=(), repeat: int = 1, reference_runs: int = 8,
                     perturb: dict | None = None) -> dict:
    """Time :func:`run_batch_fast` on ``runs`` perturbed vehicles (:func:`perturb_batch` with
    ``perturb`` keywords, seed ``seed``).  The first call (compilation, or loading numba's cache)
    is timed separately; the best of ``repeat`` timed calls gives the throughput.  With
    ``reference_runs`` > 0 the first runs are also flown by ``vehicle_sim.fly_batch`` (the scalar
    loop) for its throughput and the largest relative difference of the summaries."""
    import numba

    rng = np.random.default_rng(seed)
    VP, TP, VC = perturb_batch(setup, rng, runs, **(perturb or {}))
    steps = int(setup.t.size)
    t0 = time.perf_counter()
    run_batch_fast(setup, VP[:1], TP[:1] if TP is not None else None, VC[:1], chunk=chunk,
                   fastmath=fastmath)
    first = time.perf_counter() - t0
    walls, cpus = [], []
    out = None
    for _ in range(max(int(repeat), 1)):
        t0, c0 = time.perf_counter(), time.process_time()
        out = run_batch_fast(setup, VP, TP, VC, chunk=chunk, fastmath=fastmath)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    k = int(np.argmin(walls))
    res = {
        "runs": int(runs),
        "steps": steps,
        "dt": float(setup.dt),
        "wall_s": walls[k],
        "cpu_s": cpus[k],
        "vehicle_steps_per_s": runs * steps / walls[k],
        "vehicle_steps_per_cpu_s": runs * steps / cpus[k] if cpus[k] > 0 else math.inf,
        "threads": int(numba.get_num_threads()),
        "first_call_s": first,
        "kernel": "simd" if fast_path_reason(setup, VP[:1], TP[:1] if TP is not None else None,
                                             VC[:1]) is None else "fallback fly_batch",
        "chunk": int(chunk),
        "fastmath": sorted(fastmath),
        "completed_fraction": float(np.mean(out[:, 5])),
        "finite_fraction": float(np.mean(out[:, 7])),
    }
    m = min(int(reference_runs), int(runs))
    if m > 0:
        ref_out = np.empty((m, 5))
        _fallback(setup, VP[:2], TP[:2] if TP is not None else _tp(setup, 2), VC[:2])  # compile
        t0 = time.perf_counter()
        ref_out = _fallback(setup, VP[:m], TP[:m] if TP is not None else _tp(setup, m), VC[:m])
        w = time.perf_counter() - t0
        diff = np.abs(out[:m, :5] - ref_out[:, :5]) / np.maximum(np.abs(ref_out[:, :5]), 1e-300)
        res["reference"] = {
            "what": "vehicle_sim.fly_batch (scalar fly() per vehicle, prange)",
            "runs": m,
            "wall_s": w,
            "vehicle_steps_per_s": m * steps / w,
            "speedup": (runs * steps / walls[k]) / (m * steps / w),
            "max_rel_diff_summary": float(np.max(diff)),
        }
    return res


def _tp(setup, R):
    return np.ascontiguousarray(np.broadcast_to(setup.bank.params, (R,) + setup.bank.params.shape))
