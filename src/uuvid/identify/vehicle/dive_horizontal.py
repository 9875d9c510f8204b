"""Identify surge, sway and yaw *jointly* from a dive with logged body velocities (DVL).

The coupled horizontal model (:mod:`uuvid.vehicle.horizontal`; Fossen 2011's 3-DOF manoeuvring
model, the horizontal part of the project's 6-DOF model, also used by Caccia et al. 2000)::

    m_u u̇ − m_v v r = X − k_u u − k_qu u|u| + b_u
    m_v v̇ + m_u u r = Y − k_v v − k_qv v|v| + b_v
    I_r ṙ − (m_u − m_v) u v = N − k_r r − k_qr r|r| + b_r,      ψ̇ = r

has twelve parameters — thirteen with the thrust lost to the advance speed, ``(X, Y, N) −
k_a C(t) (u, v, r)`` (:func:`uuvid.vehicle.inflow.horizontal_inflow_matrix`; ``identify_dive``'s
``inflow``) — identified like the 1-DOF models of :mod:`uuvid.identify.vehicle.dive`:

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

from uuvid.core.checks import arg, arg_is
from uuvid.core.threads import small_blas
from uuvid.identify.vehicle.output_error import (
    HELD_OUT_WORSE,
    blown_windows,
    correlation_warnings,
    covariance,
    dead_band_weights,
    held_out_verdict,
    levenberg_marquardt,
    loss_as_drag,
    loss_as_drag_text,
    not_identifiable,
    share_of_value,
    unusable_reasons,
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
    horizontal_inflow_of,
    horizontal_windows,
    replay_horizontal,
    require_horizontal,
    score_horizontal,
    spread_windows,
)
from uuvid.vehicle.horizontal import HORIZONTAL_NAMES, HorizontalParams

__all__ = ["fit_horizontal", "HorizontalEstimate", "MIN_SECONDS_HORIZONTAL"]

MIN_SECONDS_HORIZONTAL = 40.0  # of armed windows: twelve parameters need more than four do
MIN_WINDOWS = 6
_SVF_OMEGA = 2.5
_LABEL = {"m_u": "surge mass m_u [kg]", "m_v": "sway mass m_v [kg]",
          "I_r": "yaw inertia I_r [kg·m²]", "k_u": "surge linear drag k_u [N·s/m]",
          "kq_u": "surge quadratic drag kq_u [N·s²/m²]", "k_v": "sway linear drag k_v [N·s/m]",
          "kq_v": "sway quadratic drag kq_v [N·s²/m²]", "k_r": "yaw linear drag k_r [N·m·s/rad]",
          "kq_r": "yaw quadratic drag kq_r [N·m·s²/rad²]", "b_u": "surge force bias b_u [N]",
          "b_v": "sway force bias b_v [N]", "b_r": "yaw moment bias b_r [N·m]"}
_DOF_KEYS = {"surge": ("m_u", "k_u", "kq_u", "b_u"), "sway": ("m_v", "k_v", "kq_v", "b_v"),
             "yaw": ("I_r", "k_r", "kq_r", "b_r")}
_DRAGS = ("k_u", "kq_u", "k_v", "kq_v", "k_r", "kq_r")
_MASSES = ("m_u", "m_v", "I_r")
_LABEL["inflow"] = "inflow coefficient k_a [N·s²/(rad·m)]"


def _inflow_warnings(ka: float, s: float) -> list:
    """A negative or poorly determined joint inflow coefficient, said."""
    if ka < 0:
        return [f"inflow coefficient negative ({ka:.3g} ± {s:.2g}): thrust that grows with the "
                "advance speed is not physical; "
                + ("not significant" if ka > -3 * s else "the model does not fit")
                + "; a vehicle file gets 0"]
    if math.isfinite(s) and s > 0.5 * abs(ka):
        return [f"inflow coefficient poorly determined: σ {s:.2g} is "
                + (share_of_value(s, ka) if ka else "above a zero estimate")
                + " (the dive's speeds and rotor speeds vary too little together)"]
    return []


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


def svf_start(dc, windows, omega: float = _SVF_OMEGA, gain=None):
    """Equation-error least squares of the three coupled equations through the state-variable
    filter over the windows' contiguous runs (20 Hz grid), or ``None`` with too little data.
    With ``gain`` (``(t, C)``, :class:`~uuvid.simulate.dive_horizontal.HorizontalProblem`) a
    13th column ``(C(t) ν)_j`` (C linear between its samples, ν filtered) gives k_a's start."""
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
        # columns: m_u m_v I_r k_u kq_u k_v kq_v k_r kq_r b_u b_v b_r [k_a]
        cols = [
            [du, -v * r, zero, u, u * np.abs(u), zero, zero, zero, zero, -one, zero, zero],
            [u * r, dv, zero, zero, zero, v, v * np.abs(v), zero, zero, zero, -one, zero],
            [-u * v, u * v, dr, zero, zero, zero, zero, r, r * np.abs(r), zero, zero, -one],
        ]
        if gain is not None:
            Cg = [[np.interp(g, gain[0], gain[1][:, j, k]) for k in range(3)] for j in range(3)]
            for j in range(3):
                cols[j].append(Cg[j][0] * u + Cg[j][1] * v + Cg[j][2] * r)
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
    #: per DOF (surge, sway, yaw) the thrust-loss split (:func:`_horizontal_inflow_split`),
    #: ``None`` when inflow was off
    inflow_split: dict | None = None
    #: servo outputs the reader found at fault that drive surge, sway or yaw (a reversed motor,
    #: one off throughout: :attr:`uuvid.io.dive_channels.DiveChannels.faulty`)
    faults: list = field(default_factory=list)

    @property
    def inflow(self) -> float | None:
        """The inflow coefficient k_a when it was fitted jointly (else ``None``)."""
        return self.values.get("inflow")

    @property
    def unusable(self) -> list:
        """Why this estimate is not a model to use (empty when nothing says so): a value or σ
        that is not finite, an inertia not determined (σ beyond twice its value), a channel the
        in-sample replay explains nothing of
        (:func:`~uuvid.identify.vehicle.output_error.unusable_reasons`), a held-out channel the
        base vehicle predicts better than it by more than 11 %
        (:data:`~uuvid.identify.vehicle.output_error.HELD_OUT_WORSE`), a servo output at fault
        that drives it (:attr:`faults`)."""
        tr = self.train or {}
        nrmse = {c: (tr[c].get("nrmse") if math.isfinite(tr[c].get("rms", math.nan))
                     else math.inf) for c in H_CHANNELS if isinstance(tr.get(c), dict)}
        why = unusable_reasons(list(self.values), self.values, self.sigma, inertias=_MASSES,
                               nrmse=nrmse, labels={k: v.split(" [")[0]
                                                    for k, v in _LABEL.items()})
        h = self.held_out or {}
        worse = [c for c in H_CHANNELS if (h.get("improvement") or {}).get(c) is not None
                 and h["improvement"][c] < HELD_OUT_WORSE]
        if worse:
            why.append("it predicts the held-out " + ", ".join(
                f"{c} {1 / h['improvement'][c]:.3g}× worse" for c in worse)
                + " than the base vehicle")
        return why + list(self.faults)

    def params(self) -> HorizontalParams:
        return HorizontalParams(**{k: self.values[k] for k in HORIZONTAL_NAMES})

    def to_dict(self) -> dict:
        ratio = {k: (self.values[k] / self.base[k] if self.base.get(k) else None)
                 for k in HORIZONTAL_NAMES}
        model = "coupled surge–sway–yaw (Fossen 2011 3-DOF)" + (
            "; thrust less k_a C(t) (u, v, r) (inflow)" if self.inflow is not None else "")
        return {"dof": "horizontal", "model": model,
                "values": self.values, "sigma": self.sigma,
                "correlation": {"params": list(self.values), "matrix": self.correlation},
                "start_value_svf": self.start, "base": self.base, "base_source": self.base_source,
                "ratio_to_base": ratio, "windows": self.windows, "horizon_s": self.horizon,
                "noise_sigma": self.noise, "train": self.train, "held_out": self.held_out,
                "inflow_split": self.inflow_split,
                "warnings": self.warnings, "notes": self.notes, "dead_band": self.weighting,
                "unusable": self.unusable}

    def identified(self, log: str) -> dict:
        """``{surge, sway, yaw: entry}`` for :func:`uuvid.vehicle.writeback.write_identified`."""
        out = {}
        v, s = self.values, self.sigma
        for dof, (m, k, kq, b) in _DOF_KEYS.items():
            out[dof] = {"mass": v[m], "linear": max(v[k], 0.0), "quadratic": max(v[kq], 0.0),
                        "disturbance": v[b],
                        "sigma": {"mass": s[m], "linear": s[k], "quadratic": s[kq],
                                  "disturbance": s[b]},
                        "log": log, "method": "dive output-error, coupled horizontal model"
                                              + (" with inflow" if self.inflow is not None else ""),
                        "notes": f"surge, sway and yaw jointly (Coriolis and Munk terms); "
                                 f"{self.windows} windows of {self.horizon:g} s"}
            if self.inflow is not None:
                out[dof]["inflow_coefficient"] = max(self.inflow, 0.0)
                out[dof]["sigma"]["inflow_coefficient"] = s["inflow"]
                out[dof]["notes"] += ("; drag without the thrust lost to the advance speed (k_a "
                                      "of the coupled fit, the same for the three DOF)")
        return out

    def summary_lines(self, t_end) -> list:
        lines = [f"horizontal (surge, sway, yaw coupled): {self.windows} windows of "
                 f"{self.horizon:g} s (output error, "
                 + ("inflow coefficient jointly)" if self.inflow is not None else
                    "bollard thrust: inflow off)")]
        for k in self.values:
            b = self.base.get(k)
            ratio = (f"  ×{self.values[k] / b:.2f} of base {b:.4g}" if b else
                     f"  (base {b:.4g})" if b is not None else "")
            lines.append(f"  {_LABEL[k]:38s} {self.values[k]:10.4g} ± {self.sigma[k]:.2g}{ratio}")
        for dof, sp in (self.inflow_split or {}).items():
            lines.append(f"  {dof} (c(t): the {dof} diagonal of C(t)): "
                         f"{loss_as_drag_text(sp, UNITS_DRAG[dof])}")
        lines.append("  in-sample replay: " + ", ".join(
            f"{c} rms {self.train[c]['rms']:.3g} {self.train[c]['unit']} (nrmse "
            f"{self.train[c]['nrmse']:.3f})" for c in H_CHANNELS))
        if self.held_out:
            h = self.held_out
            lines.append(f"  held-out (t > {t_end:.10g} s): " + "; ".join(
                f"{c} rms identified {h['identified'][c]['rms']:.3g} vs base "
                f"{h['base'][c]['rms']:.3g} {h['identified'][c]['unit']}"
                + (f" ({held_out_verdict(h['improvement'][c])})" if h["improvement"].get(c)
                   else "")
                for c in H_CHANNELS))
        if self.unusable:
            lines.append(f"  not a model to use: {'; '.join(self.unusable)}")
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


#: drag units of the horizontal DOFs (the loss-as-drag lines)
UNITS_DRAG = {"surge": "N·s/m", "sway": "N·s/m", "yaw": "N·m·s/rad"}
_UNITS_GAIN = {"surge": "rad/s", "sway": "rad/s", "yaw": "rad·m²/s"}


def _horizontal_inflow_split(prob, th, x0, sigma_ka: float) -> dict:
    """Per DOF the thrust loss booked as linear drag by a bollard model
    (:func:`~uuvid.identify.vehicle.output_error.loss_as_drag`) from the diagonal of ``C(t)``
    and the identified model's own ``u``, ``v``, ``r`` over the fitted windows (the off-diagonal
    terms couple the DOFs and are not a drag of any one of them)."""
    with np.errstate(over="ignore", invalid="ignore"):
        S = prob.simulate(np.asarray(th, float)[None], np.asarray(x0, float)[None])[:, 0]
    nu = {"surge": S[0], "sway": S[1], "yaw": S[3]}
    out = {}
    for j, (dof, (_, k, _, _)) in enumerate(_DOF_KEYS.items()):
        out[dof] = loss_as_drag(prob.Ch[j, j][:, ::2], nu[dof], float(th[-1]), sigma_ka,
                                float(th[HORIZONTAL_NAMES.index(k)]), _UNITS_GAIN[dof],
                                UNITS_DRAG[dof])
    return out


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
                   weighting: bool = True, held_out_horizon=None, gain=None,
                   inflow_start: float | None = None) -> HorizontalEstimate:
    """Identify the coupled model (see the module doc) from the armed windows of ``dc`` within
    ``[t_start, t_end]``; the part after ``t_end`` is replayed as held out.  Raises
    :class:`~uuvid.io.dive_channels.DiveDataError` naming a missing channel, too short a range,
    or forces that never move (no thrust to identify from, ``DiveChannels.require_thrust``).

    ``gain``: ``(t, C)`` of :func:`uuvid.io.dive_channels.horizontal_inflow_gain` — the inflow
    coefficient ``k_a`` is then a 13th parameter (thrust less ``k_a C(t) (u, v, r)``), started
    from the state-variable-filter regression (``inflow_start`` where it has none)."""
    require_horizontal(dc)
    windows, notes = horizontal_windows(dc, horizon, t_start, t_end)
    windows = spread_windows(windows, notes, "horizontal")
    need = max(MIN_WINDOWS, math.ceil(MIN_SECONDS_HORIZONTAL / horizon - 1e-9))
    if len(windows) < need:
        span = dc.span_text(t_start, t_end)
        raise DiveDataError(
            f"{dc.name}: window too short to identify horizontal (surge, sway, yaw coupled): "
            f"{len(windows)} usable armed window(s) of {horizon:g} s in {span} (need at least "
            f"{need}, i.e. {need * horizon:g} s with u, v and heading samples); widen "
            f"{arg('t_start')}/{arg('t_end')} or pass a longer dive"
            + (f" ({'; '.join(notes)})" if notes else ""))
    dc.require_thrust("horizontal", H_FORCES, veh.B, flags, t_start, t_end)
    base, base_src = horizontal_from_vehicle(veh)
    names = HORIZONTAL_NAMES + (("inflow",) if gain is not None else ())
    npar = len(names)
    prob = HorizontalProblem(dc, windows, gain=gain)
    scale, sig = channel_scale(dc, prob)
    W = prob.W
    th_svf = svf_start(dc, windows, gain=gain)
    start = {k: float(v) for k, v in zip(names, th_svf)} if th_svf is not None else {}
    b0 = base.as_array()
    if gain is not None:
        b0 = np.append(b0, 0.0 if inflow_start is None else float(inflow_start))
    th0 = np.array(th_svf if th_svf is not None else b0, float)
    if gain is not None and not th0[-1] >= 0:
        notes.append(f"state-variable-filter start value had k_a {th0[-1]:.3g} < 0; started "
                     "k_a at 0")
        th0[-1] = 0.0
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
        return (prob.predict(z[:npar], z[npar:].reshape(4, W).T) - prob.y) * rw

    z0 = np.concatenate([th0, prob.x0_meas.T.ravel()])
    N, P = prob.y.size, z0.size
    rows = np.arange(N)

    def jac(z):
        # every perturbed copy in one vectorised simulation: 12 parameters, then each of the
        # four initial-state components of all windows at once (a window's state touches only
        # its own rows)
        th, x0 = z[:npar], z[npar:].reshape(4, W).T
        ths = np.repeat(th[None], 1 + npar + 4, axis=0)
        xs = np.repeat(x0[None], 1 + npar + 4, axis=0)
        dth = 1e-6 * np.maximum(np.abs(th), 1e-3)
        ths[1 + np.arange(npar), np.arange(npar)] += dth
        dx = 1e-6 * np.maximum(np.abs(x0), 1e-2)
        for j in range(4):
            xs[1 + npar + j, :, j] += dx[:, j]
        R = (prob.predict_many(ths, xs) - prob.y) * rw
        dR, _ = blown_windows((R[1:] - R[0]).T, prob.w, W)  # a blown-up window: no information
        J = np.zeros((N, P))
        J[:, :npar] = dR[:, :npar] / dth
        for j in range(4):
            J[rows, npar + j * W + prob.w] = dR[:, npar + j] / dx[prob.w, j]
        J[~np.isfinite(J)] = 0.0
        return J

    free = np.ones(P, bool)
    with small_blas():  # a few hundred unknowns, dense and small: one BLAS thread is fastest
        sol = levenberg_marquardt(resid, jac, z0, free, positive=(0, 1, 2))
        sd, corr = covariance(sol["jac"], sol["fun"], prob.w, npar)
    th = sol["x"][:npar]
    values = {k: float(v) for k, v in zip(names, th)}
    sigma = {k: float(v) for k, v in zip(names, sd)}
    warns = not_identifiable(names, sigma) + correlation_warnings(names, corr)
    if gain is not None:
        warns += _inflow_warnings(values["inflow"], sigma["inflow"])
    for k in _DRAGS:
        if values[k] < 0:
            warns.append(f"{k} drag estimate is negative ({values[k]:.3g} ± {sigma[k]:.2g}): "
                         f"{'not significant' if values[k] > -3 * sigma[k] else 'the model does not fit'}"
                         "; a vehicle file gets 0")
        elif math.isfinite(sigma[k]) and sigma[k] > 0.5 * abs(values[k]):
            warns.append(f"{k} drag poorly determined: σ {sigma[k]:.2g} is "
                         + share_of_value(sigma[k], values[k]))
    for k in _MASSES:
        if math.isfinite(sigma[k]) and sigma[k] > 0.5 * values[k]:
            warns.append(f"{k} poorly determined (σ {sigma[k]:.2g}): the dive has little "
                         "acceleration or turning at speed")
    if not sol["success"]:
        warns.append(f"optimiser stopped: {sol['message']}")
    p_id = HorizontalParams(**{k: values[k] for k in HORIZONTAL_NAMES})
    ka = values.get("inflow", 0.0)
    split = _horizontal_inflow_split(prob, th, sol["x"][npar:].reshape(4, W).T,
                                     sigma["inflow"]) if gain is not None else None
    m_id, tr_id, pr_id, sc = score_horizontal(prob, p_id, scale, ka)
    ka_base = horizontal_inflow_of(veh)[0] if gain is not None else 0.0
    m_b, tr_b, _, _ = score_horizontal(prob, base, scale, ka_base)
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
        h_id, ht_id, nt = replay_horizontal(dc, p_id, Hh, t_end, gain=gain, inflow=ka)
        h_b, ht_b, _ = replay_horizontal(dc, base, Hh, t_end, gain=gain if ka_base else None,
                                         inflow=ka_base)
        if h_id is None:
            notes.append(f"no armed {Hh:g} s window after {arg_is('t_end', f'{t_end:g}')} s: "
                         "no held-out score"
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
    if gain is not None:
        notes.append("inflow: the thrust lost to the advance speed, k_a C(t) (u, v, r) with C(t) "
                     "= Σ_i |Ω_i(t)| (1 − w_i) b_i b_iᵀ (Ω_i the rotor speed, w_i the wake "
                     "fraction, b_i the (X, Y, N) column of thruster i; "
                     "uuvid.vehicle.inflow.horizontal_inflow_matrix), is fitted with the "
                     "drags; the base-vehicle comparison uses "
                     + (f"the vehicle file's own k_a {ka_base:.4g}" if ka_base else
                        "bollard thrust (the vehicle file has no k_a)"))
    notes.append("yaw rate from the heading through the model (not measured); residuals divided "
                 "by each channel's noise σ (" + ", ".join(
                     f"{c} {s:.2g} {u}" for c, s, u in zip(H_CHANNELS, sig, H_UNITS)) + ")")
    return HorizontalEstimate(values, sigma, corr.tolist(), start, base.to_dict(), base_src, W,
                              float(horizon), train, held, warns, notes, traces, wd,
                              {c: float(s) for c, s in zip(H_CHANNELS, sig)},
                              inflow_split=split)
