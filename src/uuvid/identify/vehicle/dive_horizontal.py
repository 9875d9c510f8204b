"""Identify surge, sway and yaw *jointly* from a dive with logged body velocities (DVL).

The coupled horizontal model (:mod:`uuvid.vehicle.horizontal`; Fossen 2011's 3-DOF manoeuvring
model, the horizontal part of the project's 6-DOF model, also used by Caccia et al. 2000)::

    m_u u̇ − m_v v r = X − k_u u − k_qu u|u| + b_u
    m_v v̇ + m_u u r = Y − k_v v − k_qv v|v| + b_v
    I_r ṙ − (m_u − m_v) u v = N − k_r r − k_qr r|r| + b_r,      ψ̇ = r

has twelve parameters; they are identified like the 1-DOF models of
:mod:`uuvid.identify.vehicle.dive`:

1. **start value** — equation error through a state-variable filter
   ``ω²/(s² + 2ζωs + ω²)`` applied to u, v, the heading and X, Y, N alike (the products
   ``v r``, ``u r``, ``u v`` are formed from the filtered signals: an approximation good enough
   to start from); the three equations share ``m_u`` and ``m_v`` and are solved together, each
   scaled by its force's spread;
2. **output error over windows** of ``horizon`` s: each window is simulated with the logged X, Y,
   N from its own initial ``(u, v, ψ, r)`` (four nuisance parameters per window; the yaw rate is
   never measured) and compared with u, v and the heading on their own stamps, each residual
   divided by its channel's noise σ (estimated from the samples,
   :func:`uuvid.simulate.dive_horizontal.noise_sigma`) so metres per second and radians add up
   as likelihoods do; residuals whose force depends on thrusters at the dead band's edge are
   down-weighted (:func:`uuvid.identify.vehicle.output_error.dead_band_weights`).

σ, correlations and warnings as for the 1-DOF fits (:mod:`uuvid.identify.vehicle.output_error`);
the held-out part after ``t_end`` is replayed by the identified and the base vehicle's coupled
model.  Write-back: ``m_u``, ``m_v``, ``I_r`` (added mass = identified − rigid body) and the drags
into the vehicle's ``hydrodynamics`` diagonal, the biases into ``one_dof.<dof>.disturbance``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uuvid.core.threads import small_blas
from uuvid.identify.vehicle.output_error import (
    blown_windows,
    correlation_warnings,
    covariance,
    dead_band_weights,
    levenberg_marquardt,
    weighting_summary,
    weighting_text,
)
from uuvid.io.dive_channels import DiveDataError
from uuvid.simulate.dive_horizontal import (
    H_CHANNELS,
    H_FORCES,
    H_UNITS,
    HorizontalProblem,
    channel_scale,
    horizontal_from_vehicle,
    horizontal_windows,
    replay_horizontal,
    require_horizontal,
    score_horizontal,
)
from uuvid.vehicle.horizontal import HORIZONTAL_NAMES, HorizontalParams

__all__ = ["fit_horizontal", "HorizontalEstimate", "MIN_SECONDS_HORIZONTAL"]

MIN_SECONDS_HORIZONTAL = 40.0  # of armed windows: twelve parameters need more than four do
MIN_WINDOWS = 6
_SVF_OMEGA = 2.5
_NP = len(HORIZONTAL_NAMES)
_LABEL = {"m_u": "surge mass m_u [kg]", "m_v": "sway mass m_v [kg]",
          "I_r": "yaw inertia I_r [kg·m²]", "k_u": "surge linear drag [N·s/m]",
          "kq_u": "surge quadratic drag [N·s²/m²]", "k_v": "sway linear drag [N·s/m]",
          "kq_v": "sway quadratic drag [N·s²/m²]", "k_r": "yaw linear drag [N·m·s/rad]",
          "kq_r": "yaw quadratic drag [N·m·s²/rad²]", "b_u": "surge force bias [N]",
          "b_v": "sway force bias [N]", "b_r": "yaw moment bias [N·m]"}
_DOF_KEYS = {"surge": ("m_u", "k_u", "kq_u", "b_u"), "sway": ("m_v", "k_v", "kq_v", "b_v"),
             "yaw": ("I_r", "k_r", "kq_r", "b_r")}
_DRAGS = ("k_u", "kq_u", "k_v", "kq_v", "k_r", "kq_r")
_MASSES = ("m_u", "m_v", "I_r")


def _svf(g, y, omega, position: bool):
    """``(value, slope, curvature)`` of ``y`` on the grid ``g`` through the state-variable filter
    ``ω²/(s² + 2ζωs + ω²)`` (ζ = 0.9); for a velocity the curvature is unused."""
    from scipy.signal import lsim

    z = 0.9
    A = np.array([[0.0, 1.0], [-omega ** 2, -2 * z * omega]])
    Bm = np.array([[0.0], [omega ** 2]])
    _, yf, _ = lsim((A, Bm, np.eye(2), np.zeros((2, 1))), y, g - g[0], X0=[y[0], 0.0])
    p, d1 = yf[:, 0], yf[:, 1]
    d2 = omega ** 2 * (y - p) - 2 * z * omega * d1
    return p, d1, d2


def svf_start(dc, windows, omega: float = _SVF_OMEGA):
    """Equation-error least squares of the three coupled equations through the state-variable
    filter over the windows' contiguous runs (20 Hz grid), or ``None`` with too little data."""
    runs, cur = [], [windows[0][0], windows[0][1]]
    for a, b in windows[1:]:
        if a <= cur[1] + 1e-9:
            cur[1] = b
        else:
            runs.append(tuple(cur))
            cur = [a, b]
    runs.append(tuple(cur))
    eq = [[], [], []]
    rhs = [[], [], []]
    for a, b in runs:
        g = np.arange(a, b, 0.05)
        if g.size < 40:
            continue
        u, du, _ = _svf(g, np.interp(g, *dc.channels["u_mps"]), omega, False)
        v, dv, _ = _svf(g, np.interp(g, *dc.channels["v_mps"]), omega, False)
        _, r, dr = _svf(g, np.interp(g, *dc.channels["yaw_rad"]), omega, True)
        F = [_svf(g, np.interp(g, *dc.channels[f]), omega, False)[0] for f in H_FORCES]
        keep = g - g[0] > 3.0 / omega
        one, zero = np.ones(g.size), np.zeros(g.size)
        # columns: m_u m_v I_r k_u kq_u k_v kq_v k_r kq_r b_u b_v b_r
        cols = [
            [du, -v * r, zero, u, u * np.abs(u), zero, zero, zero, zero, -one, zero, zero],
            [u * r, dv, zero, zero, zero, v, v * np.abs(v), zero, zero, zero, -one, zero],
            [-u * v, u * v, dr, zero, zero, zero, zero, r, r * np.abs(r), zero, zero, -one],
        ]
        for i in range(3):
            eq[i].append(np.column_stack(cols[i])[keep])
            rhs[i].append(F[i][keep])
    if not eq[0]:
        return None
    H, y = [], []
    for i in range(3):
        Hi, yi = np.vstack(eq[i]), np.concatenate(rhs[i])
        s = float(np.std(yi)) or 1.0
        H.append(Hi / s)
        y.append(yi / s)
    th, *_ = np.linalg.lstsq(np.vstack(H), np.concatenate(y), rcond=None)
    return th


@dataclass
class HorizontalEstimate:
    """The coupled horizontal model identified from a dive (inside
    :class:`~uuvid.identify.vehicle.dive.DiveIdentification` as ``estimates["horizontal"]``)."""

    values: dict
    sigma: dict
    correlation: list
    start: dict
    base: dict
    base_source: str
    windows: int
    horizon: float
    train: dict
    held_out: dict | None
    warnings: list
    notes: list
    traces: dict = field(default_factory=dict, repr=False)
    weighting: dict = field(default_factory=dict)
    noise: dict = field(default_factory=dict)
    dof: str = "horizontal"

    def params(self) -> HorizontalParams:
        return HorizontalParams(**self.values)

    def to_dict(self) -> dict:
        ratio = {k: (self.values[k] / self.base[k] if self.base.get(k) else None)
                 for k in HORIZONTAL_NAMES}
        return {"dof": "horizontal", "model": "coupled surge–sway–yaw (Fossen 2011 3-DOF)",
                "values": self.values, "sigma": self.sigma,
                "correlation": {"params": list(HORIZONTAL_NAMES), "matrix": self.correlation},
                "start_value_svf": self.start, "base": self.base, "base_source": self.base_source,
                "ratio_to_base": ratio, "windows": self.windows, "horizon_s": self.horizon,
                "noise_sigma": self.noise, "train": self.train, "held_out": self.held_out,
                "warnings": self.warnings, "notes": self.notes, "dead_band": self.weighting}

    def identified(self, log: str) -> dict:
        """``{surge, sway, yaw: entry}`` for :func:`uuvid.vehicle.writeback.write_identified`."""
        out = {}
        v, s = self.values, self.sigma
        for dof, (m, k, kq, b) in _DOF_KEYS.items():
            out[dof] = {"mass": v[m], "linear": max(v[k], 0.0), "quadratic": max(v[kq], 0.0),
                        "disturbance": v[b],
                        "sigma": {"mass": s[m], "linear": s[k], "quadratic": s[kq],
                                  "disturbance": s[b]},
                        "log": log, "method": "dive output-error, coupled horizontal model",
                        "notes": f"surge, sway and yaw jointly (Coriolis and Munk terms); "
                                 f"{self.windows} windows of {self.horizon:g} s"}
        return out

    def summary_lines(self, t_end) -> list:
        lines = [f"horizontal (surge, sway, yaw coupled): {self.windows} windows of "
                 f"{self.horizon:g} s (output error)"]
        for k in HORIZONTAL_NAMES:
            b = self.base.get(k)
            ratio = (f"  ×{self.values[k] / b:.2f} of base {b:.4g}" if b else
                     f"  (base {b:.4g})" if b is not None else "")
            lines.append(f"  {_LABEL[k]:34s} {self.values[k]:10.4g} ± {self.sigma[k]:.2g}{ratio}")
        lines.append("  in-sample replay: " + ", ".join(
            f"{c} rms {self.train[c]['rms']:.3g} {self.train[c]['unit']} (nrmse "
            f"{self.train[c]['nrmse']:.3f})" for c in H_CHANNELS))
        if self.held_out:
            h = self.held_out
            lines.append(f"  held-out (t > {t_end:g} s): " + "; ".join(
                f"{c} rms identified {h['identified'][c]['rms']:.3g} vs base "
                f"{h['base'][c]['rms']:.3g} {h['identified'][c]['unit']}"
                + (f" ({h['improvement'][c]:.2f}× better)" if h["improvement"].get(c) else "")
                for c in H_CHANNELS))
        if self.weighting:
            lines.append(f"  {weighting_text(self.weighting)}")
        lines += [f"  warning: {w}" for w in self.warnings]
        lines += [f"  note: {n}" for n in self.notes]
        return lines

    def panels(self) -> list:
        key = "held_out" if "held_out" in self.traces else "train"
        return [(self.traces[key][c], f"{c} [{u}]",
                 f"horizontal (coupled) {c}: {'held-out' if key == 'held_out' else 'in-sample'} "
                 "replay") for c, u in zip(H_CHANNELS, H_UNITS)]


def _dead_band_rows(prob, flags, th0, scale):
    """Per row weight (:func:`~uuvid.identify.vehicle.output_error.dead_band_weights`) with the
    edge thrusters' X, Y, N uncertainty propagated through the model from each window's start;
    ``None`` when no force sample has a thruster at the edge."""
    extra = [flags.sigma_of(f) for f in H_FORCES]
    if not any(np.any(s > 0) for _, s in extra):
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        delta = (prob.with_forces(extra).predict(th0, prob.x0_meas)
                 - prob.predict(th0, prob.x0_meas))
    return dead_band_weights(delta * scale, 1.0)


def fit_horizontal(dc, veh, horizon: float, t_start=None, t_end=None, *, flags=None,
                   weighting: bool = True, held_out_horizon=None) -> HorizontalEstimate:
    """Identify the coupled model (see the module doc) from the armed windows of ``dc`` within
    ``[t_start, t_end]``; the part after ``t_end`` is replayed as held out.  Raises
    :class:`~uuvid.io.dive_channels.DiveDataError` naming a missing channel or too short a
    range."""
    require_horizontal(dc)
    windows, notes = horizontal_windows(dc, horizon, t_start, t_end)
    need = max(MIN_WINDOWS, math.ceil(MIN_SECONDS_HORIZONTAL / horizon - 1e-9))
    if len(windows) < need:
        span = f"[{t_start if t_start is not None else 'start'}, {t_end if t_end is not None else 'end'}]"
        raise DiveDataError(
            f"{dc.name}: window too short to identify horizontal (surge, sway, yaw coupled): "
            f"{len(windows)} usable armed window(s) of {horizon:g} s in {span} s (need at least "
            f"{need}, i.e. {need * horizon:g} s with u, v and heading samples); widen "
            "--t-start/--t-end or pass a longer dive" + (f" ({'; '.join(notes)})" if notes else ""))
    base, base_src = horizontal_from_vehicle(veh)
    prob = HorizontalProblem(dc, windows)
    scale, sig = channel_scale(dc, prob)
    W = prob.W
    th_svf = svf_start(dc, windows)
    start = {k: float(v) for k, v in zip(HORIZONTAL_NAMES, th_svf)} if th_svf is not None else {}
    th0 = np.array(th_svf if th_svf is not None else base.as_array(), float)
    b0 = base.as_array()
    for i, k in enumerate(HORIZONTAL_NAMES):
        if k in _MASSES and not th0[i] > 0:
            notes.append(f"state-variable-filter start value had {k} {th0[i]:.3g} ≤ 0; started "
                         "from the base vehicle's instead")
            th0[i] = b0[i]
        if k in _DRAGS:
            th0[i] = max(th0[i], 0.0)
    weights = _dead_band_rows(prob, flags, th0, scale) if (flags is not None and weighting) \
        else None
    rw = scale * (weights if weights is not None else 1.0)

    def resid(z):
        return (prob.predict(z[:_NP], z[_NP:].reshape(4, W).T) - prob.y) * rw

    z0 = np.concatenate([th0, prob.x0_meas.T.ravel()])
    N, P = prob.y.size, z0.size
    rows = np.arange(N)

    def jac(z):
        # every perturbed copy in one vectorised simulation: 12 parameters, then each of the
        # four initial-state components of all windows at once (a window's state touches only
        # its own rows)
        th, x0 = z[:_NP], z[_NP:].reshape(4, W).T
        ths = np.repeat(th[None], 1 + _NP + 4, axis=0)
        xs = np.repeat(x0[None], 1 + _NP + 4, axis=0)
        dth = 1e-6 * np.maximum(np.abs(th), 1e-3)
        ths[1 + np.arange(_NP), np.arange(_NP)] += dth
        dx = 1e-6 * np.maximum(np.abs(x0), 1e-2)
        for j in range(4):
            xs[1 + _NP + j, :, j] += dx[:, j]
        R = (prob.predict_many(ths, xs) - prob.y) * rw
        dR, _ = blown_windows((R[1:] - R[0]).T, prob.w, W)  # a blown-up window: no information
        J = np.zeros((N, P))
        J[:, :_NP] = dR[:, :_NP] / dth
        for j in range(4):
            J[rows, _NP + j * W + prob.w] = dR[:, _NP + j] / dx[prob.w, j]
        J[~np.isfinite(J)] = 0.0
        return J

    free = np.ones(P, bool)
    with small_blas():  # a few hundred unknowns, dense and small: one BLAS thread is fastest
        sol = levenberg_marquardt(resid, jac, z0, free, positive=(0, 1, 2))
        sd, corr = covariance(sol["jac"], sol["fun"], prob.w, _NP)
    th = sol["x"][:_NP]
    values = {k: float(v) for k, v in zip(HORIZONTAL_NAMES, th)}
    sigma = {k: float(v) for k, v in zip(HORIZONTAL_NAMES, sd)}
    warns = correlation_warnings(HORIZONTAL_NAMES, corr)
    for k in _DRAGS:
        if values[k] < 0:
            warns.append(f"{k} drag estimate is negative ({values[k]:.3g} ± {sigma[k]:.2g}): "
                         f"{'not significant' if values[k] > -3 * sigma[k] else 'the model does not fit'}"
                         "; a vehicle file gets 0")
        elif sigma[k] > 0.5 * abs(values[k]):
            warns.append(f"{k} drag poorly determined: σ {sigma[k]:.2g} is "
                         f"{100 * sigma[k] / abs(values[k]):.0f} % of the value")
    for k in _MASSES:
        if sigma[k] > 0.5 * values[k]:
            warns.append(f"{k} poorly determined (σ {sigma[k]:.2g}): the dive has little "
                         "acceleration or turning at speed")
    if not sol["success"]:
        warns.append(f"optimiser stopped: {sol['message']}")
    p_id = HorizontalParams(**values)
    m_id, tr_id, pr_id, sc = score_horizontal(prob, p_id, scale)
    m_b, tr_b, _, _ = score_horizontal(prob, base, scale)
    train = {c: {**m_id[c], "rms_base": m_b[c]["rms"]} for c in H_CHANNELS}
    train["rms_fit_scaled"] = float(np.sqrt(np.mean(sol["fun"] ** 2)))
    train["iterations"] = sol["nit"]
    traces = {"train": {c: (*tr_id[c][:3], tr_b[c][2], tr_id[c][3]) for c in H_CHANNELS}}
    if not all(math.isfinite(m_id[c]["rms"]) for c in H_CHANNELS):
        warns.append("the identified model does not stay finite when replayed from the measured "
                     "states (too stiff for the replay's step, or unstable): do not use it")
    held = None
    if t_end is not None:
        Hh = float(held_out_horizon or horizon)
        h_id, ht_id, nt = replay_horizontal(dc, p_id, Hh, t_end)
        h_b, ht_b, _ = replay_horizontal(dc, base, Hh, t_end)
        if h_id is None:
            notes.append(f"no armed {Hh:g} s window after --t-end {t_end:g} s: no held-out score"
                         + (f" ({'; '.join(nt)})" if nt else ""))
        else:
            imp = {c: (h_b[c]["rms"] / h_id[c]["rms"] if h_id[c]["rms"] > 0 and
                       math.isfinite(h_b[c]["rms"] / h_id[c]["rms"]) else None)
                   for c in H_CHANNELS}
            held = {"identified": h_id, "base": h_b, "horizon_s": Hh, "improvement": imp}
            traces["held_out"] = {c: (*ht_id[c][:3], ht_b[c][2], ht_id[c][3])
                                  for c in H_CHANNELS}
    wd = weighting_summary(flags, weights if weights is not None else
                           (np.ones(N) if flags is not None and weighting else None), prob.w,
                           windows[0][0], windows[-1][1], W, H_FORCES)
    wd["enabled"] = bool(weighting and flags is not None)
    notes.append("yaw rate from the heading through the model (not measured); residuals divided "
                 "by each channel's noise σ (" + ", ".join(
                     f"{c} {s:.2g} {u}" for c, s, u in zip(H_CHANNELS, sig, H_UNITS)) + ")")
    return HorizontalEstimate(values, sigma, corr.tolist(), start, base.to_dict(), base_src, W,
                              float(horizon), train, held, warns, notes, traces, wd,
                              {c: float(s) for c, s in zip(H_CHANNELS, sig)})
