"""Replay a dive through the coupled horizontal model (surge, sway, yaw together).

Where a dive logs body velocities (DVL: ``u_mps``, ``v_mps``) and a heading (``yaw_rad``), the
coupled model of :mod:`uuvid.vehicle.horizontal` (Fossen 2011's 3-DOF manoeuvring model: the
Coriolis/centripetal terms ``∓m v r``, ``(m_u − m_v) u v`` tie the three DOF together)::

    m_u u̇ − m_v v r = X − k_u u − k_qu u|u| + b_u
    m_v v̇ + m_u u r = Y − k_v v − k_qv v|v| + b_v
    I_r ṙ − (m_u − m_v) u v = N − k_r r − k_qr r|r| + b_r,      ψ̇ = r

is integrated (RK4, fixed step, vectorised over windows) with the *logged* X, Y, N (linear
between their own samples) in windows of ``horizon`` s, each from its own initial state
``(u, v, ψ, r)``; the yaw rate is never measured — it comes from the heading through the model.
Predictions are compared with u, v (linear between steps) and the heading (cubic Hermite with
``r`` as slope) on the measurements' own stamps.  The initial state is fitted to each window's
first ``span`` seconds with the model fixed (:func:`initial_state_horizontal`), as the 1-DOF
replay does (:mod:`uuvid.simulate.dive_replay`); the samples after it are scored.
"""

from __future__ import annotations

import numpy as np

from uuvid.core.checks import arg, arg_is
from uuvid.io.dive_channels import DiveDataError
from uuvid.vehicle.horizontal import HorizontalParams, horizontal_params, horizontal_rhs

__all__ = ["HorizontalProblem", "horizontal_windows", "horizontal_inflow_of", "initial_state_horizontal",
           "replay_horizontal", "require_horizontal", "horizontal_from_vehicle", "noise_sigma",
           "H_MEAS", "H_FORCES", "H_CHANNELS", "H_UNITS", "H_STATE_SPAN"]

H_MEAS = ("u_mps", "v_mps", "yaw_rad")
H_FORCES = ("X_N", "Y_N", "N_Nm")
H_CHANNELS = ("u", "v", "heading")
H_UNITS = ("m/s", "m/s", "rad")
H_STATE_SPAN = 1.0  # s of each window used to fit its initial state
_HINT = {"u_mps": "a surge velocity (DVL; table column u_mps)",
         "v_mps": "a sway velocity (DVL; table column v_mps)",
         "yaw_rad": "a heading (ArduSub: ATT/ATTITUDE; table column yaw_rad)"}


def _near(t, y, t0, half):
    """The samples within ±half of ``t0`` (widened until there are 4)."""
    sel = np.abs(t - t0) <= half
    while np.count_nonzero(sel) < 4 and half < 10:
        half *= 1.5
        sel = np.abs(t - t0) <= half
    return t[sel] - t0, y[sel]


def _start_state(dc, t0) -> tuple:
    """``(u, v, ψ, r)`` at ``t0``: u, v the mean of their samples within ±0.5 s; ψ and r the
    value and slope of a quadratic through the heading samples within ±0.25 s."""
    u = float(np.mean(_near(*dc.channels["u_mps"], t0, 0.5)[1]))
    v = float(np.mean(_near(*dc.channels["v_mps"], t0, 0.5)[1]))
    tt, yy = _near(*dc.channels["yaw_rad"], t0, 0.25)
    c = np.polyfit(tt, yy, 2 if tt.size >= 5 else 1)
    return u, v, float(np.polyval(c, 0.0)), float(np.polyval(np.polyder(c), 0.0))


def require_horizontal(dc) -> None:
    """Raise :class:`DiveDataError` naming what the coupled horizontal model lacks in ``dc``."""
    for c in H_MEAS:
        if c not in dc.channels or dc.channels[c][0].size < 4:
            have = [d for d, m in (("heave", "depth_m"), ("yaw", "yaw_rad"), ("surge", "u_mps"),
                                   ("sway", "v_mps")) if m in dc.channels
                    and dc.channels[m][0].size >= 4]
            raise DiveDataError(f"{dc.name}: no {c} samples: "
                                f"{arg_is('dofs', 'horizontal', '--dof')} (surge, sway and yaw "
                                f"coupled) needs u_mps, v_mps and yaw_rad, i.e. {_HINT[c]}; pass "
                                f"{arg_is('dofs', '|'.join(have) or 'heave', '--dof')} or a log that has it")
    for f in H_FORCES:
        if f not in dc.channels or dc.channels[f][0].size < 2:
            raise DiveDataError(f"{dc.name}: no {f} samples (thruster forces): "
                                f"{arg_is('dofs', 'horizontal', '--dof')} "
                                "needs X_N, Y_N and N_Nm; pass an ArduSub log with "
                                "SERVO_OUTPUT_RAW/RCOU or a table with force or pwm_ columns")


def noise_sigma(t, y) -> float:
    """Measurement noise σ of a channel from its own samples: each sample minus the straight
    line through its neighbours, ``e_i = y_i − (a y_{i−1} + b y_{i+1})`` (``a + b = 1`` from the
    stamps), has variance ``σ²(1 + a² + b²)`` for white noise on a signal that is smooth over
    two sample intervals; σ from the median absolute deviation of ``e`` (robust to
    manoeuvres)."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if t.size < 5:
        return float("nan")
    d0, d1 = t[1:-1] - t[:-2], t[2:] - t[1:-1]
    a = d1 / (d0 + d1)
    b = 1.0 - a
    e = (y[1:-1] - (a * y[:-2] + b * y[2:])) / np.sqrt(1 + a * a + b * b)
    return float(1.4826 * np.median(np.abs(e - np.median(e))))


def horizontal_from_vehicle(veh) -> tuple[HorizontalParams, str]:
    """The vehicle's coupled horizontal model: the (u, v, r) diagonal of ``M_RB + M_A``, ``D_L``,
    ``D_Q`` (what the 6-DOF simulator flies) and, as biases, the ``disturbance`` of its
    ``one_dof`` surge/sway/yaw entries where it has them (an identified file)."""
    bias, src = [0.0, 0.0, 0.0], []
    for key, m in (veh.one_dof or {}).items():
        if m.dof in ("surge", "sway", "yaw"):
            bias[("surge", "sway", "yaw").index(m.dof)] = float(m.disturbance)
            src.append(f"one_dof.{key}")
    text = f"{veh.name}: (u, v, r) diagonal of M_RB + M_A, D_L, D_Q"
    if src:
        text += f"; biases from {', '.join(src)}"
    return horizontal_params(veh.params, bias), text


def horizontal_inflow_of(veh) -> tuple[float, str]:
    """``(k_a, source)``: the inflow coefficient the coupled model flies — the
    ``inflow_coefficient`` of the vehicle's ``one_dof`` surge/sway/yaw entries (a coupled fit
    writes the same k_a to all three; where they differ, the largest, and the source says so);
    ``(0.0, "")`` when none has one."""
    vals = {key: float(getattr(m, "inflow_coefficient", 0.0) or 0.0)
            for key, m in (veh.one_dof or {}).items() if m.dof in ("surge", "sway", "yaw")}
    vals = {k: v for k, v in vals.items() if v}
    if not vals:
        return 0.0, ""
    key = max(vals, key=vals.get)
    src = f"one_dof.{key}.inflow_coefficient"
    if len(set(vals.values())) > 1:
        src += " (the largest of " + ", ".join(f"{k} {v:.4g}" for k, v in vals.items()) + ")"
    return vals[key], src


#: a window whose force (servo outputs) has a gap longer than this (s) is left out: what the
#: controllers did across it is unknown (an 8 s dropout inside a 10 s heave window was
#: interpolated and tripled the linear drag's σ)
MAX_FORCE_GAP_S = 3.0
#: most windows one fit takes: its Jacobian holds every sample × (parameters + 2 per window), so
#: memory grows with the square of the windows (a 1-hour yaw dive: ≈ 3 GB; 250: ≈ 0.5 GB); a longer dive is
#: fitted on this many windows spread evenly over it, and that is said
MAX_FIT_WINDOWS = 250


def spread_windows(windows: list, notes: list, what: str) -> list:
    """At most :data:`MAX_FIT_WINDOWS` of ``windows``, evenly spread (first and last kept)."""
    if len(windows) <= MAX_FIT_WINDOWS:
        return windows
    idx = np.unique(np.round(np.linspace(0, len(windows) - 1, MAX_FIT_WINDOWS)).astype(int))
    notes.append(f"{len(windows)} usable {what} windows: {idx.size} spread evenly over the dive "
                 "are fitted (the fit's memory grows with the square of the windows); "
                 f"{arg('t_start')}/{arg('t_end')} fit a part in full")
    return [windows[i] for i in idx]


#: samples of the measured channel a window needs (fewer cannot fix its initial state and rate)
WINDOW_SAMPLES = 4


#: a measured channel (depth, heading, DVL) logging slower than this (s) is no sensor of a dive
#: log: the time column is in another unit (ms read as s)
SLOWEST_SENSOR_STEP_S = 30.0


def check_horizon(dc, channels, horizon: float) -> None:
    """``DiveDataError`` when windows of ``horizon`` s cannot hold :data:`WINDOW_SAMPLES` samples
    of each measured channel at its median step — the windows would all be left out, and a tiny
    horizon (``--horizon 1e-9``) cut the dive into 10¹¹ of them, running without end."""
    from uuvid.io.dive_channels import DiveDataError

    for c in channels:
        t = dc.channels[c][0]
        d = np.diff(t)
        d = d[d > 0]
        if not d.size:
            continue
        floor = (WINDOW_SAMPLES - 1) * float(np.median(d))  # 4 samples span 3 steps
        if not horizon >= floor:
            slow = float(np.median(d)) > SLOWEST_SENSOR_STEP_S
            raise DiveDataError(
                f"{dc.name}: {arg_is('horizon', f'{horizon:g}')} s is shorter than "
                f"{WINDOW_SAMPLES} samples of "
                f"{c} (median step {np.median(d):.3g} s): no window could hold the samples it "
                + (f"needs; a sensor logging every {np.median(d):.3g} s is no dive log: is the "
                   "time in milliseconds? (divide t_s by 1000)" if slow else
                   f"needs; give at least {floor:.3g} s"))


def horizontal_windows(dc, horizon: float, t_start=None, t_end=None) -> tuple[list, list]:
    """Windows ``[(t0, t1)]`` of ``horizon`` s inside the armed intervals ∩ [t_start, t_end]
    where u, v and the heading have ≥ 4 samples each and X, Y, N no gap longer than
    :data:`MAX_FORCE_GAP_S`; notes on what was left out."""
    ms = [dc.channels[c][0] for c in H_MEAS]
    fs = [dc.channels[c][0] for c in H_FORCES]
    check_horizon(dc, H_MEAS, horizon)
    lo = max([t[0] for t in ms + fs] + [-np.inf if t_start is None else t_start])
    hi = min([t[-1] for t in ms + fs] + [np.inf if t_end is None else t_end])
    out, sparse = [], 0
    for a, b in dc.armed:
        a, b = max(a, lo), min(b, hi)
        s = a
        while s + horizon <= b + 1e-9:
            e = s + horizon
            ok = all(np.count_nonzero((t >= s) & (t <= e)) >= WINDOW_SAMPLES for t in ms)
            for tf in fs:
                fsel = (tf >= s - 1.0) & (tf <= e + 1.0)
                if np.count_nonzero(fsel) < 2 or np.max(np.diff(np.concatenate(
                        ([s], tf[fsel], [e])))) > MAX_FORCE_GAP_S:
                    ok = False
            if ok:
                out.append((s, e))
            else:
                sparse += 1
            s = e
    notes = []
    if sparse:
        notes.append(f"{sparse} horizontal window(s) with too few u/v/heading samples (or a gap "
                     "in the force) left out")
    return out, notes


class HorizontalProblem:
    """Windows prepared for the vectorised coupled simulation: X, Y, N at the RK4 half steps and,
    per measured sample (rows of u, then v, then heading), its channel ``c``, window ``w``, step
    ``k`` and fraction ``s``.  ``x0_meas`` (W × 4): ``(u, v, ψ, r)`` at each window's start from
    local fits of the samples (u, v: mean within ±0.5 s; ψ, r: a quadratic within ±0.25 s).

    ``gain``: ``(t, C (len(t) × 3 × 3))`` of the thrust lost to the advance speed
    (:func:`uuvid.io.dive_channels.horizontal_inflow_gain`), linear between its samples like the
    forces; the parameters then carry a 13th, the inflow coefficient ``k_a``, and the model's
    force is ``(X, Y, N) − k_a C(t) (u, v, r)`` at every RK4 stage."""

    def __init__(self, dc, windows, h: float | None = None, gain=None):
        self.windows = list(windows)
        W = len(self.windows)
        horizon = self.windows[0][1] - self.windows[0][0]
        h = h or min(0.05, horizon / 40)
        self.n = int(np.ceil(horizon / h - 1e-9))
        self.h = horizon / self.n
        ta = np.array([w[0] for w in self.windows])
        self.ta, self.W = ta, W
        th = ta[:, None] + 0.5 * self.h * np.arange(2 * self.n + 1)[None, :]
        self.Fh = np.stack([np.interp(th, *dc.channels[f]) for f in H_FORCES])
        self.Ch = None  # (3, 3, W, 2n+1): the inflow matrix at the half steps
        if gain is not None:
            tg, C = gain
            self.Ch = np.stack([np.stack([np.interp(th, tg, C[:, j, k]) for k in range(3)])
                                for j in range(3)])
        cs, ws, ts, ys = [], [], [], []
        for c, m in enumerate(H_MEAS):
            tm, ym = dc.channels[m]
            for k, (a, b) in enumerate(self.windows):
                sel = (tm >= a) & (tm <= b)
                n = int(np.count_nonzero(sel))
                cs.append(np.full(n, c))
                ws.append(np.full(n, k))
                ts.append(tm[sel])
                ys.append(ym[sel])
        self.c = np.concatenate(cs)
        self.w = np.concatenate(ws)
        self.t = np.concatenate(ts)
        self.y = np.concatenate(ys)
        u = (self.t - ta[self.w]) / self.h
        self.k = np.clip(np.floor(u).astype(int), 0, self.n - 1)
        self.s = u - self.k
        self.x0_meas = np.array([_start_state(dc, a) for a, _ in self.windows])

    def with_forces(self, extra) -> HorizontalProblem:
        """A copy whose X, Y, N are raised by ``extra`` (3 × (t, F), zero outside)."""
        import copy

        p = copy.copy(self)
        th = self.ta[:, None] + 0.5 * self.h * np.arange(2 * self.n + 1)[None, :]
        p.Fh = self.Fh + np.stack([np.interp(th, tt, ff, left=0.0, right=0.0)
                                   for tt, ff in extra])
        return p

    def simulate(self, thetas, x0s):
        """States ``(U, V, PSI, R)`` as a (4, C, W, n+1) array for ``C`` copies of the windows at
        once: ``thetas`` (C × 12, or C × 13 with the inflow coefficient last when the problem has
        a ``gain``) parameters and ``x0s`` (C × W × 4) initial states per copy (a Jacobian's
        perturbed copies in one vectorised integration).  RK4 with the forces at the half
        steps."""
        th = np.asarray(thetas, float)
        C = th.shape[0]
        W, h, n = self.W, self.h, self.n
        if th.shape[1] == 13 and self.Ch is None:
            raise ValueError("an inflow coefficient needs the problem's inflow gain (gain=)")
        theta = np.repeat(th[:, :12], W, axis=0).T  # (12, C·W): one column per simulated window
        ka = np.repeat(th[:, 12], W) if th.shape[1] == 13 else None
        Cm = None if ka is None else [[np.tile(self.Ch[j, k], (C, 1)) for k in range(3)]
                                      for j in range(3)]
        x0 = np.asarray(x0s, float).reshape(C * W, 4)
        u, v, psi, r = (x0[:, i].copy() for i in range(4))
        out = np.empty((4, C * W, n + 1))
        out[:, :, 0] = u, v, psi, r
        X, Y, N = (np.tile(f, (C, 1)) for f in self.Fh)

        def rhs(u, v, r, i):
            if ka is None:
                return horizontal_rhs(u, v, r, X[:, i], Y[:, i], N[:, i], theta)
            f = [F[:, i] - ka * (Cm[j][0][:, i] * u + Cm[j][1][:, i] * v + Cm[j][2][:, i] * r)
                 for j, F in enumerate((X, Y, N))]
            return horizontal_rhs(u, v, r, *f, theta)

        for s in range(n):
            i0, i1, i2 = 2 * s, 2 * s + 1, 2 * s + 2
            a1 = rhs(u, v, r, i0)
            u2, v2, r2 = u + 0.5 * h * a1[0], v + 0.5 * h * a1[1], r + 0.5 * h * a1[2]
            a2 = rhs(u2, v2, r2, i1)
            u3, v3, r3 = u + 0.5 * h * a2[0], v + 0.5 * h * a2[1], r + 0.5 * h * a2[2]
            a3 = rhs(u3, v3, r3, i1)
            u4, v4, r4 = u + h * a3[0], v + h * a3[1], r + h * a3[2]
            a4 = rhs(u4, v4, r4, i2)
            psi = psi + h / 6 * (r + 2 * r2 + 2 * r3 + r4)
            u = u + h / 6 * (a1[0] + 2 * a2[0] + 2 * a3[0] + a4[0])
            v = v + h / 6 * (a1[1] + 2 * a2[1] + 2 * a3[1] + a4[1])
            r = r + h / 6 * (a1[2] + 2 * a2[2] + 2 * a3[2] + a4[2])
            out[:, :, s + 1] = u, v, psi, r
        return out.reshape(4, C, W, n + 1)

    def predict_many(self, thetas, x0s):
        """(C × rows): each copy's u, v (linear between steps) and heading (cubic Hermite with
        ``r`` as slope) at every measured sample's own stamp (NaN/inf where a trial window
        blows up)."""
        with np.errstate(over="ignore", invalid="ignore"):
            S = self.simulate(thetas, x0s)
        w, k, s, h, c = self.w, self.k, self.s, self.h, self.c
        out = np.empty((S.shape[1], self.y.size))
        for ch in (0, 1):
            m = c == ch
            out[:, m] = S[ch][:, w[m], k[m]] * (1 - s[m]) + S[ch][:, w[m], k[m] + 1] * s[m]
        m = c == 2
        ww, kk, ss = w[m], k[m], s[m]
        x0_, x1 = S[2][:, ww, kk], S[2][:, ww, kk + 1]
        d0, d1 = S[3][:, ww, kk] * h, S[3][:, ww, kk + 1] * h
        s2, s3 = ss * ss, ss * ss * ss
        out[:, m] = ((2 * s3 - 3 * s2 + 1) * x0_ + (s3 - 2 * s2 + ss) * d0
                     + (-2 * s3 + 3 * s2) * x1 + (s3 - s2) * d1)
        return out

    def predict(self, theta, x0):
        """One copy of :meth:`predict_many`: ``theta`` (12 or 13), ``x0`` (W × 4)."""
        return self.predict_many(np.asarray(theta, float)[None], np.asarray(x0, float)[None])[0]


def initial_state_horizontal(prob: HorizontalProblem, theta, scale, span: float = H_STATE_SPAN):
    """``(x0, scored)``: each window's ``(u, v, ψ, r)`` fitted (Gauss–Newton, model fixed,
    residuals scaled by ``scale`` per row: 1/noise σ of the row's channel) to the samples of its
    first ``span`` seconds, and the mask of the samples after it."""
    x0 = prob.x0_meas.copy()
    early = prob.t <= prob.ta[prob.w] + span
    w = prob.w[early]
    sc = np.broadcast_to(np.asarray(scale, float), prob.y.shape)[early]
    steps = (1e-4, 1e-4, 1e-4, 1e-3)
    theta = np.asarray(theta, float)
    for _ in range(3):
        xs = np.repeat(x0[None], 5, axis=0)
        for i, d in enumerate(steps):
            xs[i + 1, :, i] += d
        P = (prob.predict_many(np.repeat(theta[None], 5, axis=0), xs) - prob.y)[:, early] * sc
        r = P[0]
        J = [(P[i + 1] - r) / d for i, d in enumerate(steps)]
        A = np.zeros((prob.W, 4, 4))
        g = np.zeros((prob.W, 4))
        for i in range(4):
            g[:, i] = np.bincount(w, J[i] * r, prob.W)
            for j in range(i, 4):
                A[:, i, j] = A[:, j, i] = np.bincount(w, J[i] * J[j], prob.W)
        if not np.all(np.isfinite(A)) or not np.all(np.isfinite(g)):
            break
        ridge = 1e-9 * np.maximum(np.trace(A, axis1=1, axis2=2), 1e-12)
        A = A + ridge[:, None, None] * np.eye(4)[None]
        try:
            dx = np.linalg.solve(A, -g[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break
        x0 = x0 + dx
    return x0, ~early


def _metrics(y, pred) -> dict:
    err = pred - y
    rms = float(np.sqrt(np.mean(err ** 2))) if err.size else float("nan")
    sd = float(np.std(y)) if y.size > 1 else float("nan")
    return {"rms": rms, "nrmse": rms / sd if sd > 0 else float("nan"), "n": int(err.size),
            "std_measured": sd}


def channel_scale(dc, prob: HorizontalProblem) -> tuple[np.ndarray, list]:
    """Per row ``1/σ`` of its channel (:func:`noise_sigma` of the whole channel) and the σ."""
    sig = []
    for m in H_MEAS:
        s = noise_sigma(*dc.channels[m])
        sig.append(s if np.isfinite(s) and s > 0 else 1.0)
    return 1.0 / np.asarray(sig)[prob.c], sig


def score_horizontal(prob: HorizontalProblem, params: HorizontalParams, scale,
                     inflow: float = 0.0):
    """``(metrics per channel name, traces per channel name, prediction, scored mask)`` of one
    replay of ``prob`` with ``params`` (initial states fitted, the rest scored); ``inflow``: the
    inflow coefficient k_a when ``prob`` has a gain."""
    th = params.as_array()
    if prob.Ch is not None:
        th = np.append(th, float(inflow))
    x0, sc = initial_state_horizontal(prob, th, scale)
    pred = prob.predict(th, x0)
    mets, traces = {}, {}
    for c, name in enumerate(H_CHANNELS):
        m = sc & (prob.c == c)
        mets[name] = {**_metrics(prob.y[m], pred[m]), "unit": H_UNITS[c]}
        traces[name] = (prob.t[m], prob.y[m], pred[m], prob.w[m])
    return mets, traces, pred, sc


def replay_horizontal(dc, params: HorizontalParams, horizon: float, t_start=None, t_end=None,
                      gain=None, inflow: float = 0.0):
    """``(metrics, traces, notes)`` of the coupled model over the dive (``None`` metrics when no
    window fits); metrics per channel u, v, heading: rms, nrmse, n.  ``gain``/``inflow``: the
    thrust lost to the advance speed (see :class:`HorizontalProblem`)."""
    require_horizontal(dc)
    windows, notes = horizontal_windows(dc, horizon, t_start, t_end)
    if not windows:
        return None, None, notes
    prob = HorizontalProblem(dc, windows, gain=gain)
    scale, _ = channel_scale(dc, prob)
    mets, traces, _, _ = score_horizontal(prob, params, scale, inflow)
    for m in mets.values():
        m["windows"] = len(windows)
        m["state_fit_s"] = H_STATE_SPAN
    return mets, traces, notes
