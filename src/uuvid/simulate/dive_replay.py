"""Replay a logged dive through per-DOF 1-DOF models, restarting from the measured state.

Per DOF the model (Caccia et al. 2000, eq. 3, with a constant bias ``b``: in heave the net
weight ``W − B``)::

    ẋ = v,   m v̇ = F(t) − k v − k_q v|v| + b − k_a c(t) v

``F`` is the bollard force from the servo outputs; the last term is the thrust the propellers lose
to the advance speed with the linear inflow form ``T_i = T_i,bollard − k_a |Ω_i| u_a,i`` (Healey
et al. 1995, IEEE JOE 20(4), eq. 6, small-angle form; Fossen 2011 §6.7), ``c(t) = Σ_i G_ji |Ω_i|``
(:func:`uuvid.vehicle.inflow.one_dof_inflow_matrix`, :func:`uuvid.io.dive_channels.inflow_gain`);
``k_a = 0`` (the default, and every model without ``one_dof.<dof>.inflow_coefficient``) is the
bollard model.

is integrated (RK4, fixed step) with the *logged* force ``F`` — linear between its own samples,
never resampled — in windows of ``horizon`` seconds; each window starts from the measured state
(position from a local quadratic fit of the measured samples around the start, velocity its
slope, refined through the model on the window's first seconds, :func:`initial_state`) and is
compared with the measurements after those seconds on their own stamps (cubic Hermite between
steps).
Heave windows that touch the surface (depth < ``SURFACE_M``) are left out: there the buoyancy
changes and the model does not hold; windows of the other DOFs whose depth stays at zero (the
sensor in air: armed on deck) are left out too.  :func:`replay_dive` returns :class:`DiveReplay`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from uuvid.core.checks import arg, arg_is
from uuvid.core.result import Result
from uuvid.io.dive_channels import DIVE_DOFS, SURFACE_CUT_M, DiveDataError, read_dive_channels
from uuvid.simulate.dive_horizontal import (
    H_FORCES,
    H_MEAS,
    MAX_FORCE_GAP_S,
    WINDOW_SAMPLES,
    check_horizon,
    horizontal_from_vehicle,
    horizontal_inflow_of,
    replay_horizontal,
)

__all__ = ["OneDofParams", "DiveReplay", "replay_dive", "dive_windows", "WindowProblem",
           "params_from_vehicle", "CHANNEL_NAMES", "DEFAULT_HORIZON", "RK4_LIMIT",
           "check_state_span"]

CHANNEL_NAMES = {"heave": "depth", "yaw": "heading", "surge": "u", "sway": "v"}
UNITS = {"heave": "m", "yaw": "rad", "surge": "m/s", "sway": "m/s"}
DEFAULT_HORIZON = {"heave": 10.0, "yaw": 4.0, "surge": 5.0, "sway": 5.0, "horizontal": 5.0}
_FIT_HALF = {"heave": 1.0, "yaw": 0.25, "surge": 0.5, "sway": 0.5}  # local fit half-width [s]
SURFACE_M = SURFACE_CUT_M  # (defined beside the reader's depth checks, which name it)
_INDEX = {"surge": 0, "sway": 1, "heave": 2, "yaw": 5}


@dataclass(frozen=True)
class OneDofParams:
    """``m`` (incl. added mass), ``k``, ``k_q`` (≥ 0), the bias ``b`` and the inflow coefficient
    ``k_a`` [N·s²/(rad·m)] (0: bollard thrust) of one DOF, SI units."""

    mass: float
    linear: float
    quadratic: float
    bias: float = 0.0
    inflow: float = 0.0

    def as_array(self) -> np.ndarray:
        """``[m, k, k_q, b]``, plus ``k_a`` when it is not 0."""
        a = [self.mass, self.linear, self.quadratic, self.bias]
        return np.array(a + [self.inflow] if self.inflow else a)

    def to_dict(self) -> dict:
        d = {"mass": self.mass, "linear": self.linear, "quadratic": self.quadratic,
             "bias": self.bias}
        if self.inflow:
            d["inflow"] = self.inflow
        return d


def params_from_vehicle(veh, dof: str) -> tuple[OneDofParams, str]:
    """The vehicle's 1-DOF parameters for ``dof`` and where they came from: its ``one_dof``
    entry for the DOF when it has one (an identified file), else the diagonal of
    ``M_RB + M_A``, ``D_L``, ``D_Q`` and, in heave, ``W − B``."""
    for key, m in (veh.one_dof or {}).items():
        if m.dof == dof:
            ka = float(getattr(m, "inflow_coefficient", 0.0) or 0.0)
            return (OneDofParams(m.mass, m.linear, m.quadratic, m.disturbance, ka),
                    f"one_dof.{key} of {veh.name}" + (" (with its inflow coefficient)"
                                                      if ka else ""))
    i = _INDEX[dof]
    p = veh.params
    M = np.asarray(p.M_RB) + np.asarray(p.added_mass)
    bias = float(p.weight - p.buoyancy) if dof == "heave" else 0.0
    return (OneDofParams(float(M[i, i]), float(p.linear_damping[i, i]),
                         float(p.quadratic_damping[i, i]), bias),
            f"{veh.name}: diagonal of M_RB + M_A, D_L, D_Q" + (", W − B" if dof == "heave" else ""))


def dive_windows(dc, dof: str, horizon: float, t_start=None, t_end=None) -> tuple[list, list]:
    """Windows ``[(t0, t1)]`` of length ``horizon`` inside the armed intervals ∩ [t_start, t_end]
    where the measured and force channels have samples, and notes on what was left out."""
    meas, force, _ = DIVE_DOFS[dof]
    tm, ym = dc.channels[meas]
    tf = dc.channels[force][0]
    check_horizon(dc, [meas], horizon)
    lo = max(tm[0], tf[0], -np.inf if t_start is None else t_start)
    hi = min(tm[-1], tf[-1], np.inf if t_end is None else t_end)
    out, surface, sparse = [], 0, 0
    depth = dc.channels.get("depth_m") if dof != "heave" else None
    if depth is not None and depth[0].size == 0:
        depth = None
    for a, b in dc.armed:
        a, b = max(a, lo), min(b, hi)
        s = a
        while s + horizon <= b + 1e-9:
            e = s + horizon
            sel = (tm >= s) & (tm <= e)
            fsel = (tf >= s - 1.0) & (tf <= e + 1.0)
            if np.count_nonzero(sel) < WINDOW_SAMPLES or np.count_nonzero(fsel) < 2 \
                    or np.max(np.diff(np.concatenate(([s], tf[fsel], [e])))) > MAX_FORCE_GAP_S:
                sparse += 1
            elif dof == "heave" and np.min(ym[sel]) < SURFACE_M:
                surface += 1
            elif depth is not None and _on_top(depth, s, e):
                surface += 1
            else:
                out.append((s, e))
            s = e
    notes = []
    if surface:
        where = (f"at the surface (depth < {SURFACE_M:g} m)" if dof == "heave" else
                 f"out of the water, armed on deck (depth within {DECK_MIN_M:g}…{DECK_M:g} m "
                 "throughout)")
        notes.append(f"{surface} {dof} window(s) of {horizon:g} s {where} left out")
    if sparse:
        notes.append(f"{sparse} {dof} window(s) with too few samples (or a gap in the force) left out")
    return out, notes


#: a logged depth within ±this (m) of zero over a whole window: the pressure sensor is in air (the
#: vehicle on deck); a vehicle floating at the surface reads its sensor's draught (≈ 0.1–0.2 m)
DECK_M = 0.05
#: ... and not below this (m): a depth logged positive up reads metres below zero, not air
DECK_MIN_M = -0.2


def _on_top(depth, s: float, e: float) -> bool:
    """The logged depth stays within :data:`DECK_MIN_M`…:data:`DECK_M` over ``[s, e]`` (its
    samples there, or the nearest ones): the sensor is in air, the vehicle on deck, where thrust
    turns nothing.  A vehicle floating at the surface (its sensor a hand's breadth down) keeps its
    yaw turns."""
    td, yd = depth
    sel = (td >= s) & (td <= e)
    if not sel.any():
        sel = np.zeros(td.size, bool)
        sel[np.clip(np.searchsorted(td, [s, e]), 0, td.size - 1)] = True
    return bool(np.max(yd[sel]) < DECK_M and np.min(yd[sel]) > DECK_MIN_M)


def _local_state(t, y, t0, half, position: bool):
    """``(value, slope, slope weight)`` at ``t0`` from a quadratic (position) fit of the samples
    within ±half, on time and value relative to ``t0`` and the nearest sample (no absolute
    stamp or heading enters the fit's arithmetic).  The slope weight is ``1/sqrt([(XᵀX)⁻¹]₁₁)``
    [s]: the slope measured as a sample is, in the samples' units (σ_slope = σ_y / weight)."""
    sel = np.abs(t - t0) <= half
    while np.count_nonzero(sel) < 4 and half < 10:
        half *= 1.5
        sel = np.abs(t - t0) <= half
    tt, yy = t[sel] - t0, y[sel]
    if not position:
        return float(np.mean(yy)), 0.0, 0.0
    ref = yy[np.argmin(np.abs(tt))]
    deg = 2 if tt.size >= 5 else 1
    c = np.polyfit(tt, yy - ref, deg)
    X = np.vander(tt, deg + 1)
    try:
        var = float(np.linalg.inv(X.T @ X)[deg - 1, deg - 1])
    except np.linalg.LinAlgError:
        var = np.inf
    weight = 1.0 / np.sqrt(var) if var > 0 and np.isfinite(var) else 0.0
    return float(ref + np.polyval(c, 0.0)), float(np.polyval(np.polyder(c), 0.0)), weight


@njit(cache=True)
def _rk4_windows(Fh, K, m, kq, b, h, n, X, V):
    """RK4 of ``ẋ = v, m v̇ = F − K v − k_q v|v| + b`` in every window (rows), force and linear
    drag at the half steps (columns of ``Fh``, ``K``); ``X[:, 0]``, ``V[:, 0]`` hold the start.
    The arithmetic of the vectorised NumPy form, element by element (same order: equal bits)."""
    inv = 1.0 / m
    hh = 0.5 * h
    h6 = h / 6
    for w in range(X.shape[0]):
        x = X[w, 0]
        v = V[w, 0]
        for s in range(n):
            f0, f1, f2 = Fh[w, 2 * s], Fh[w, 2 * s + 1], Fh[w, 2 * s + 2]
            k0, k1, k2 = K[w, 2 * s], K[w, 2 * s + 1], K[w, 2 * s + 2]
            a1 = (f0 - k0 * v - kq * v * abs(v) + b) * inv
            v2 = v + hh * a1
            a2 = (f1 - k1 * v2 - kq * v2 * abs(v2) + b) * inv
            v3 = v + hh * a2
            a3 = (f1 - k1 * v3 - kq * v3 * abs(v3) + b) * inv
            v4 = v + h * a3
            a4 = (f2 - k2 * v4 - kq * v4 * abs(v4) + b) * inv
            x = x + h6 * (v + 2 * v2 + 2 * v3 + v4)
            v = v + h6 * (a1 + 2 * a2 + 2 * a3 + a4)
            X[w, s + 1] = x
            V[w, s + 1] = v


class WindowProblem:
    """Windows of one DOF prepared for vectorised simulation: force at the RK4 half steps and
    where each measured sample falls (window, step, fraction).  ``gain``: ``(t, c)`` of
    :func:`uuvid.io.dive_channels.inflow_gain` (linear between its samples, like the force),
    needed by a θ with ``k_a`` (a fifth entry)."""

    def __init__(self, dc, dof: str, windows, h: float | None = None, gain=None):
        meas, force, position = DIVE_DOFS[dof]
        self.dof, self.position = dof, position
        tm, ym = dc.channels[meas]
        tf, F = dc.channels[force]
        self.windows = list(windows)
        W = len(self.windows)
        horizon = self.windows[0][1] - self.windows[0][0]
        h = h or min(0.05, horizon / 40)
        self.n = int(np.ceil(horizon / h - 1e-9))
        self.h = horizon / self.n
        ta = np.array([w[0] for w in self.windows])
        self.ta = ta
        # times relative to the first window's start: a stamp of 1.7e9 s (Unix time) has a
        # resolution of 2.4e-7 s, and half steps built on it would be rounded to that grid
        self.t_ref = float(ta[0])
        th = self.half_steps()
        self.Fh = np.interp(th, tf - self.t_ref, F)
        self.Ch = None if gain is None else np.interp(th, gain[0] - self.t_ref, gain[1])
        wi, ti, yi = [], [], []
        for k, (a, b) in enumerate(self.windows):
            sel = (tm >= a) & (tm <= b)
            wi.append(np.full(np.count_nonzero(sel), k))
            ti.append(tm[sel])
            yi.append(ym[sel])
        self.w = np.concatenate(wi)
        self.t = np.concatenate(ti)
        self.y = np.concatenate(yi)
        u = (self.t - ta[self.w]) / self.h
        self.k = np.clip(np.floor(u).astype(int), 0, self.n - 1)
        self.s = u - self.k
        half = _FIT_HALF[dof]
        st = np.array([_local_state(tm, ym, a, half, position) for a, _ in self.windows])
        self.y0_meas, self.v0_meas, self.v0_weight = st[:, 0], st[:, 1], st[:, 2]
        # a position (depth, heading) enters the model only through its change: each window's
        # samples relative to its own measured start (a heading wrapped, unwrapped or offset by
        # 2πk gives the same numbers), for fits that take the start as y0_meas + an offset
        self.y_ref = self.y0_meas if position else np.zeros(W)
        self.y_rel = self.y - self.y_ref[self.w]
        self.W = W

    def half_steps(self) -> np.ndarray:
        """The RK4 half-step times of every window (W × 2n+1), relative to :attr:`t_ref`."""
        return (self.ta - self.t_ref)[:, None] + 0.5 * self.h * np.arange(2 * self.n + 1)[None, :]

    def simulate(self, theta, y0, v0):
        """``(X, V)`` (W × n+1): position (or velocity-only: V) over each window.  ``theta``:
        ``[m, k, k_q, b]`` or ``[m, k, k_q, b, k_a]``; the inflow loss ``k_a c(t) v`` enters as a
        time-varying linear drag ``k + k_a c(t)``."""
        m, k, kq, b = theta[:4]
        ka = theta[4] if len(theta) > 4 else 0.0
        h, n = self.h, self.n
        X = np.empty((self.W, n + 1))
        V = np.empty((self.W, n + 1))
        x, v = np.array(y0, float), np.array(v0, float)
        if not self.position:
            v = x.copy()
        X[:, 0], V[:, 0] = x, v
        Fh = self.Fh
        if ka != 0.0:
            if self.Ch is None:
                raise ValueError("an inflow coefficient k_a needs the inflow gain c(t) (logged "
                                 "servo outputs): WindowProblem(..., gain=inflow_gain(...))")
            K = k + ka * self.Ch
        else:
            K = np.full(Fh.shape, float(k))
        _rk4_windows(Fh, K, float(m), float(kq), float(b), float(h), n, X, V)
        if not self.position:
            X = V
        return X, V

    def stiffness(self, theta, y0, v0) -> np.ndarray:
        """Per window the largest ``h·(k + k_a c + 2 k_q |v|)/m`` along its replay: the step times
        the local rate ``−∂v̇/∂v``.  Beyond :data:`RK4_LIMIT` the fixed RK4 step amplifies instead
        of damping (the replay is then not the model's solution: its sensitivity to the
        parameters grows without bound, and ``predict`` may overflow)."""
        with np.errstate(over="ignore", invalid="ignore"):
            _, V = self.simulate(theta, y0, v0)
        return self._stiffness_of(theta, V)

    def _stiffness_of(self, theta, V) -> np.ndarray:
        m, k, kq = theta[0], theta[1], theta[2]
        ka = theta[4] if len(theta) > 4 else 0.0
        with np.errstate(over="ignore", invalid="ignore"):
            K = k + (ka * self.Ch[:, ::2] if ka != 0.0 and self.Ch is not None else 0.0)
            lam = self.h * (K + 2 * max(kq, 0.0) * np.abs(V)) / m
            lam = np.where(np.isfinite(lam), lam, np.inf)
        return lam.max(axis=1)

    def predict(self, theta, y0, v0, stiff_limit: float | None = None):
        """The model's output at every measured sample's own stamp (NaN/inf where a window's
        simulation blows up, e.g. under a trial step of the optimiser).  With ``stiff_limit``
        (e.g. :data:`RK4_LIMIT`): NaN too in every window whose replay is stiffer than that
        (:meth:`stiffness`) — there the fixed step's replay is not the model's solution, and a
        fit must not take its numbers (it could find a cost there lower than any the model's
        true solution gives)."""
        with np.errstate(over="ignore", invalid="ignore"):
            X, V = self.simulate(theta, y0, v0)
        w, k, s, h = self.w, self.k, self.s, self.h
        if not self.position:
            out = X[w, k] * (1 - s) + X[w, k + 1] * s
        else:
            x0, x1, d0, d1 = X[w, k], X[w, k + 1], V[w, k] * h, V[w, k + 1] * h
            s2, s3 = s * s, s * s * s
            out = ((2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * d0 + (-2 * s3 + 3 * s2) * x1
                   + (s3 - s2) * d1)
        if stiff_limit is not None:
            out = np.where((self._stiffness_of(theta, V) > stiff_limit)[w], np.nan, out)
        return out


RK4_LIMIT = 2.785  # −z where RK4's amplification 1 + z + z²/2 + z³/6 + z⁴/24 reaches 1 (real axis)
_STATE_SPAN = {"heave": 2.0, "yaw": 0.5, "surge": 1.0, "sway": 1.0}  # initial-state fit [s]


def check_state_span(dc, dof: str, horizon: float, name: str = "horizon") -> None:
    """``DiveDataError`` when ``horizon`` s is no longer than the span that fits each window's
    initial state (:data:`_STATE_SPAN`; the coupled horizontal model's ``H_STATE_SPAN``): no
    sample after it would be left to score (the replay printed ``rms nan`` over 0 samples, and
    identify called every model "not finite").  Says the horizon that leaves
    :data:`WINDOW_SAMPLES` samples of the slowest measured channel to score."""
    from uuvid.simulate.dive_horizontal import H_STATE_SPAN

    span = H_STATE_SPAN if dof == "horizontal" else _STATE_SPAN.get(dof)
    if span is None or horizon > span + 1e-9:
        return
    meas = list(H_MEAS) if dof == "horizontal" else [DIVE_DOFS[dof][0]]
    check_horizon(dc, [c for c in meas if c in dc.channels], horizon)  # (its error first)
    steps = []
    for c in meas:
        t = dc.channels[c][0] if c in dc.channels else np.empty(0)
        d = np.diff(t)
        d = d[d > 0]
        if d.size:
            steps.append(float(np.median(d)))
    need = span + WINDOW_SAMPLES * max(steps) if steps else None
    raise DiveDataError(
        f"{dof}: {arg_is(name, f'{horizon:g}')} s must exceed the {span:g} s used to fit each "
        "window's initial state: no sample after it is left to score"
        + (f"; give at least {need:.2g} s ({WINDOW_SAMPLES} samples of "
           f"{meas[int(np.argmax(steps))]} after the {span:g} s) — the default is "
           f"{DEFAULT_HORIZON[dof]:g} s" if need is not None else ""))


def initial_state(prob, theta, span: float):
    """``(y0, v0, scored)``: each window's initial state fitted (Gauss–Newton, model fixed) to the
    samples of its first ``span`` seconds — the measured state, read through the model as a
    Kalman filter would — and the mask of the samples after it, which are scored.

    Each window's step is accepted only where it lowers that window's error (else halved, up to
    four times, else the window keeps its state): with strong quadratic drag the initial velocity
    is barely observable from the positions a moment later, and undamped Gauss–Newton steps can
    run to tens of m/s, after which the replay overflows."""
    y0, v0 = prob.y0_meas.copy(), prob.v0_meas.copy()
    early = prob.t - prob.ta[prob.w] <= span
    w = prob.w[early]
    if not prob.position:
        return y0, v0, ~early

    def window_cost(y, v):
        r = (prob.predict(theta, y, v) - prob.y)[early]
        c = np.bincount(w, np.where(np.isfinite(r), r * r, np.inf), prob.W)
        return r, np.where(np.isfinite(c), c, np.inf)

    with np.errstate(over="ignore", invalid="ignore"):
        r, cost = window_cost(y0, v0)
        for _ in range(4):
            if not np.all(np.isfinite(r)):
                break
            dy = 1e-4
            ry = (prob.predict(theta, y0 + dy, v0) - prob.y)[early]
            rv = (prob.predict(theta, y0, v0 + dy) - prob.y)[early]
            jy, jv = (ry - r) / dy, (rv - r) / dy
            a = np.bincount(w, jy * jy, prob.W)
            b = np.bincount(w, jy * jv, prob.W)
            c = np.bincount(w, jv * jv, prob.W)
            gy = np.bincount(w, jy * r, prob.W)
            gv = np.bincount(w, jv * r, prob.W)
            det = a * c - b * b
            ok = np.isfinite(det) & (det > 1e-12 * np.maximum(a * c, 1e-300))
            sy = -np.where(ok, (c * gy - b * gv) / np.where(ok, det, 1), 0.0)
            sv = -np.where(ok, (a * gv - b * gy) / np.where(ok, det, 1), 0.0)
            frac = np.ones(prob.W)
            pending = ok.copy()
            for _ in range(5):  # per-window backtracking
                if not pending.any():
                    break
                yt = np.where(pending, y0 + frac * sy, y0)
                vt = np.where(pending, v0 + frac * sv, v0)
                rt, ct = window_cost(yt, vt)
                better = pending & (ct < cost)
                y0, v0 = np.where(better, yt, y0), np.where(better, vt, v0)
                cost = np.where(better, ct, cost)
                pending &= ~better
                frac = np.where(pending, 0.5 * frac, frac)
            r, cost = window_cost(y0, v0)
    return y0, v0, ~early


def _metrics(y, pred) -> dict:
    err = pred - y
    rms = float(np.sqrt(np.mean(err ** 2))) if err.size else float("nan")
    sd = float(np.std(y)) if y.size > 1 else float("nan")
    return {"rms": rms, "nrmse": rms / sd if sd > 0 else float("nan"), "n": int(err.size),
            "std_measured": sd}


def plot_windows(ax, t, measured, window, predictions) -> None:
    """Measured samples as dots and each prediction as one line per replay window (``window``:
    the window index of each sample, so no line joins two restarts); ``predictions`` is a list
    of ``(values, label, line style)``, each labelled once."""
    ax.plot(t, measured, ".", ms=2, color="0.4", label="measured")
    for k in np.unique(window):
        s = window == k
        for values, label, style in predictions:
            ax.plot(t[s], values[s], label=label if k == window[0] else None, **style)


@dataclass
class DiveReplay(Result):
    """Predicted vs measured per channel (see :func:`replay_dive`)."""

    log: str
    vehicle: str
    horizon: dict
    channels: dict  # name → {rms, nrmse, n, unit, dof, params, params_source}
    traces: dict = field(default_factory=dict, repr=False)  # name → (t, measured, predicted, w)
    notes: list = field(default_factory=list)
    t_start: float | None = None
    t_end: float | None = None
    warnings: list = field(default_factory=list)  # the log reader's (what it assumed)

    report_title = "Dive replay"

    def summary(self) -> str:
        span = ("" if self.t_start is None and self.t_end is None else
                f" over [{self.t_start if self.t_start is not None else '…'}, "
                f"{self.t_end if self.t_end is not None else '…'}] s")
        lines = [f"replay of {self.log} with {self.vehicle}{span} (restart every horizon from "
                 "the measured state)"]
        for name, c in self.channels.items():
            lines.append(f"  {name:8s} rms {c['rms']:.4g} {c['unit']}, nrmse {c['nrmse']:.3f} "
                         f"({c['n']} samples, {c['windows']} windows of {c['horizon']:g} s; "
                         f"model: {c['params_source']})")
        lines += [f"  note: {n}" for n in self.notes]
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"log": self.log, "vehicle": self.vehicle, "t_start": self.t_start,
                "t_end": self.t_end, "channels": self.channels, "notes": self.notes,
                "warnings": self.warnings}

    def plot(self, path=None):
        from uuvid.core.plots import new_figure, save_figure

        names = list(self.traces) or ["(none)"]
        fig, ax = new_figure(len(names), 1, figsize=(10, 3 * len(names)))
        ax = np.atleast_1d(ax)
        for a, name in zip(ax, names):
            if name not in self.traces:
                continue
            t, y, p, w = self.traces[name]
            plot_windows(a, t, y, w, [(p, "predicted", {"color": "C1", "lw": 1})])
            a.set_ylabel(f"{name} [{self.channels[name]['unit']}]")
            a.set_title(f"{name}: rms {self.channels[name]['rms']:.3g} "
                        f"{self.channels[name]['unit']}, nrmse {self.channels[name]['nrmse']:.3f}")
            a.legend(loc="upper right", fontsize="small")
        for a in ax:  # every panel names its time axis (they do not share one)
            a.set_xlabel("t [s]")
        if path is not None:
            save_figure(fig, path)
        return fig

    def _report_into(self, folder):
        """The report's files in ``folder``: :meth:`~uuvid.core.result.Result.report` builds
        it in a temporary sibling and renames it whole, so an interrupted report leaves none."""
        from pathlib import Path

        from uuvid.core.html import Report

        folder = self.write_basics(folder)
        fig = Path(folder) / "replay.png"
        self.plot(fig)
        rep = Report(f"{self.report_title} — {self.log}")
        rep.add_preformatted(self.summary(), caption="Summary")
        rep.add_figure(fig, caption="Predicted (each window restarted from the measured state) vs "
                                    "measured")
        return rep.write(folder)


def replay_windows(dc, dof: str, params: OneDofParams, horizon: float, t_start=None,
                   t_end=None, gain=None):
    """``(metrics, trace, notes)`` of one DOF (``None`` metrics when no window fits); ``gain``:
    the inflow gain ``(t, c)`` a model with ``k_a`` needs."""
    windows, notes = dive_windows(dc, dof, horizon, t_start, t_end)
    if not windows:
        return None, None, notes
    prob = WindowProblem(dc, dof, windows, gain=gain)
    span = _STATE_SPAN[dof]
    y0, v0, sc = initial_state(prob, params.as_array(), span)
    pred = prob.predict(params.as_array(), y0, v0)
    met = _metrics(prob.y[sc], pred[sc])
    met["windows"] = len(windows)
    met["state_fit_s"] = span
    return met, (prob.t[sc], prob.y[sc], pred[sc], prob.w[sc]), notes


def replay_dive(log, vehicle, dofs=("heave", "yaw"), *, t_start=None, t_end=None, horizon=None,
                params=None, thruster_model=None, dive=None, topics=None) -> DiveReplay:
    """Drive each DOF's 1-DOF model (the vehicle's, :func:`params_from_vehicle`) with the logged
    forces; restart every ``horizon`` s from the measured state; compare (see the module doc).

    ``dofs``: ``"all"`` or names among heave, yaw, surge, sway and ``horizontal`` (the coupled
    surge–sway–yaw model of :mod:`uuvid.simulate.dive_horizontal`: channels ``u (horizontal)``,
    ``v (horizontal)``, ``heading (horizontal)``); with ``"all"`` those without measured
    channels are left out.  ``dive``: an already read
    :class:`~uuvid.io.dive_channels.DiveChannels`; ``params``, ``topics``: as for
    :func:`~uuvid.io.dive_channels.read_dive_channels` (ArduSub parameters; a ROS bag's topics).
    """
    from uuvid.core.checks import seconds_or_none, time_window

    seconds_or_none(t_start=t_start, t_end=t_end, horizon=horizon)
    time_window(t_start, t_end, horizon, error=DiveDataError, named=True)
    if dive is None:
        from uuvid.io.dive_channels import check_log_arg

        check_log_arg(log)
    veh = base_vehicle(vehicle, "replay_dive")
    dc = dive or read_dive_channels(log, veh, params=params, thruster_model=thruster_model,
                                    topics=topics, t_start=t_start, t_end=t_end)
    if not dc.armed:
        raise DiveDataError(f"{dc.name}: unarmed log: no armed sample, so the thrusters never "
                            "pushed and there is nothing to replay; pass the log of a dive")
    dc.check_span(t_start, t_end)
    every = _is_all(dofs)
    dofs = _dof_list(dofs, dc)
    notes, chans, traces, hz = [], {}, {}, {}
    warnings, failed = list(dc.warnings), []
    if every and all_left_out(dc):
        notes.append(all_left_out(dc))
    if horizon is not None:
        for dof in dofs:
            check_state_span(dc, dof, float(horizon))
    for dof in dofs:
        H = float(horizon or DEFAULT_HORIZON[dof])
        hz[dof] = H
        if dof == "horizontal":
            idle = _idle_thrust(dc, dof, veh, thruster_model, t_start, t_end)
            if idle is not None:
                warnings.append(f"{dc.name}: no horizontal thrust in the replay: {idle}")
            ph, src = horizontal_from_vehicle(veh)
            ka, ka_src = horizontal_inflow_of(veh)
            hgain = None
            if ka:
                from uuvid.io.dive_channels import horizontal_inflow_gain

                g = horizontal_inflow_gain(dc, veh, thrust_model=_thrust_model(dc, thruster_model))
                if g is None:
                    notes.append(f"horizontal: the vehicle's inflow coefficient k_a = {ka:.4g} "
                                 f"({ka_src}) needs the servo outputs (rotor speeds) and the log "
                                 "has none: replayed with bollard thrust (k_a = 0)")
                    ka = 0.0
                else:
                    hgain = g[:2]
                    notes.append(f"horizontal: thrust lost to the advance speed with k_a = "
                                 f"{ka:.4g} N·s²/(rad·m) ({ka_src}; rotor speeds: {g[2]})")
            mets, trs, nt = replay_horizontal(dc, ph, H, t_start, t_end, gain=hgain, inflow=ka)
            notes += nt
            if mets is None:
                notes.append(f"horizontal: no armed {H:g} s window in the range: nothing replayed")
                continue
            for name, met in mets.items():
                key = f"{name} (horizontal)"
                chans[key] = {**met, "dof": "horizontal", "horizon": H,
                              "params": ph.to_dict(), "params_source": src}
                traces[key] = trs[name]
            continue
        try:
            dc.require(dof)
        except DiveDataError as e:
            if not every:  # a DOF named: it must be replayed
                raise
            failed.append(e)  # "all": left out, said, the others replayed (as identify does)
            warnings.append(f"{dof} not replayed: {e}")
            continue
        idle = _idle_thrust(dc, dof, veh, thruster_model, t_start, t_end)
        if idle is not None:  # as identify refuses it (a model coasting, said, still replayed)
            warnings.append(f"{dc.name}: no {dof} thrust in the replay: {idle}")
        p, src = params_from_vehicle(veh, dof)
        gain = None
        if p.inflow:
            from uuvid.io.dive_channels import inflow_gain

            g = inflow_gain(dc, veh, dof, thrust_model=_thrust_model(dc, thruster_model))
            if g is None:
                notes.append(f"{dof}: the vehicle's inflow coefficient k_a = {p.inflow:.4g} "
                             "needs the servo outputs (rotor speeds) and the log has none: "
                             "replayed with bollard thrust (k_a = 0)")
                p = OneDofParams(p.mass, p.linear, p.quadratic, p.bias)
            else:
                gain = g[:2]
                notes.append(f"{dof}: thrust lost to the advance speed with k_a = {p.inflow:.4g} "
                             f"N·s²/(rad·m) (rotor speeds: {g[2]})")
        met, trace, nt = replay_windows(dc, dof, p, H, t_start, t_end, gain=gain)
        notes += nt
        if met is None:
            notes.append(f"{dof}: no armed {H:g} s window in the range: nothing replayed")
            continue
        name = CHANNEL_NAMES[dof]
        chans[name] = {**met, "unit": UNITS[dof], "dof": dof, "horizon": H,
                       "params": p.to_dict(), "params_source": src}
        traces[name] = trace
    if not chans and failed and len(failed) == len(dofs):
        raise failed[0]
    if not chans:  # why the armed windows were left out (on deck, at the surface, sparse), as
        # identify says it: "no armed window" alone hid a log armed for 16 s on deck
        why = [n for n in notes if "left out" in n]
        raise DiveDataError(f"{dc.name}: no usable armed window of the horizon to replay in the "
                            "range given" + (f" ({'; '.join(why)})" if why else "")
                            + f"; widen {arg('t_start')}/{arg('t_end')} or shorten {arg('horizon')}"
                            + (", or pass a dive in the water" if any("deck" in n or "surface" in n
                                                                       for n in why) else ""))
    return DiveReplay(dc.name, _vehicle_label(veh), hz, chans, traces, notes, t_start, t_end,
                      warnings)


def _idle_thrust(dc, dof, veh, thruster_model, t_start, t_end) -> str | None:
    """Why ``dof``'s force gives the replay nothing to answer (it stays at one value over the
    armed samples; :func:`uuvid.io.idle_outputs.idle_force`, identify's check), or ``None``."""
    from uuvid.io.dive_channels import thrust_regions
    from uuvid.io.idle_outputs import idle_force

    forces = list(H_FORCES) if dof == "horizontal" else [DIVE_DOFS[dof][1]]
    regions = thrust_regions(_thrust_model(dc, thruster_model)) if dc.pwm else None
    return idle_force(dc, forces, veh.B, regions, t_start, t_end, replay=True)


def all_left_out(dc) -> str | None:
    """What ``--dof all`` (``dofs="all"``) leaves out for want of a channel in the log — a DOF
    without its measured or force channel was skipped without a word (a depth logged as
    ``depth [cm]`` left heave out silently) — with the table's columns not read that look like
    one; ``None`` when it leaves none out."""
    gone = []
    for d, (meas, force, _) in DIVE_DOFS.items():
        miss = [c for c in (meas, force) if c not in dc.channels]
        if miss:
            gone.append(f"{d} (no {' or '.join(miss)})")
    if not gone:
        return None
    return (f"{dc.name}: of all the DOFs ({arg_is('dofs', 'all', '--dof')}, the default) "
            f"{', '.join(gone)} left out: the log has no such channel"
            + (f"; its columns {', '.join(dc.unread[:8])} are not read (renamed they would be)"
               if dc.unread else ""))


def _is_all(dofs) -> bool:
    """``dofs`` asks for every DOF the log has channels for (``"all"``, ``None``, ``["all"]``; a
    generator is not read here: :func:`_dof_list` reads it)."""
    return dofs is None or (isinstance(dofs, str) and dofs == "all") or \
        (isinstance(dofs, (list, tuple)) and list(dofs) == ["all"])


#: what :func:`replay_dive` and ``identify_dive`` take as their ``vehicle`` (the message of
#: :func:`uuvid.vehicle.definition.as_vehicle` for anything else)
BASE_VEHICLE_EXPECTED = ("expected the base vehicle, a preset name (e.g. 'bluerov2'), a vehicle "
                         "file's path or a Vehicle")


def base_vehicle(vehicle, func: str):
    """The base vehicle of :func:`replay_dive`/``identify_dive`` (``func``):
    :func:`uuvid.vehicle.definition.as_vehicle` (a preset name or a vehicle file loaded, a
    Vehicle as given, anything else a ``TypeError`` naming ``func`` and the argument)."""
    from uuvid.vehicle.definition import as_vehicle

    return as_vehicle(vehicle, BASE_VEHICLE_EXPECTED, func)


def _vehicle_label(veh) -> str:
    """The vehicle's name, with its file when it is not a preset (a written ``--out-vehicle`` file
    keeps the base vehicle's name: the file says which one was replayed)."""
    from uuvid.vehicle.definition import command_line_name

    ref = command_line_name(veh)
    return veh.name if ref == veh.name else f"{veh.name} ({ref})"


def _thrust_model(dc, thruster_model):
    """The thruster model that turned the servo outputs into forces: a table's pwm_ columns
    always the shipped T200 model, an ArduSub log's or a bag's ``thruster_model`` when given."""
    from uuvid.io.ardusub.thrust import default_t200, load_thrust_model

    return (load_thrust_model(thruster_model) if thruster_model is not None
            and dc.format not in ("table", "csv", "parquet") else default_t200())


def _dof_list(dofs, dc) -> list:
    """The DOF names to work on: ``"all"`` is every DOF with its measured and force channels,
    plus ``horizontal`` (the coupled surge–sway–yaw model) when u, v and the heading are all
    logged with X, Y, N."""
    if dofs in (None, "all") or dofs == ("all",) or dofs == ["all"]:
        out = [d for d in DIVE_DOFS if DIVE_DOFS[d][0] in dc.channels
               and DIVE_DOFS[d][1] in dc.channels]
        if not out:
            dc.require("heave")
        if all(c in dc.channels and dc.channels[c][0].size >= 4 for c in H_MEAS) and \
                all(f in dc.channels for f in H_FORCES):
            out.append("horizontal")
        return out
    dofs = [dofs] if isinstance(dofs, str) else list(dofs)  # (a generator read once)
    if not dofs:  # `--dof ''` or `--dof ,`: not "all" and not a name
        have = [d for d in DIVE_DOFS if DIVE_DOFS[d][0] in dc.channels
                and DIVE_DOFS[d][1] in dc.channels]
        raise DiveDataError("the DOF list is empty: name one or more of heave, yaw, surge, sway, "
                            "horizontal (a comma list), or all"
                            + (f"; {dc.name} has the channels for {', '.join(have)}" if have
                               else f"; {dc.name} has the channels of none"))
    bad = [d for d in dofs if d not in DIVE_DOFS and d != "horizontal"]
    if bad:
        raise DiveDataError(f"unknown DOF {bad[0]!r}; expected heave, yaw, surge, sway, "
                            "horizontal or all")
    return list(dofs)
