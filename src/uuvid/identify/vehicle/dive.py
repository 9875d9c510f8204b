"""Identify a vehicle from a whole piloted dive: every armed sample, closed loop or not.

In every armed sample the thrust is known from the servo outputs (at the logged battery voltage,
:mod:`uuvid.io.ardusub`), so a piloted dive informs the model whether a pilot or ArduSub's
depth/heading controllers moved the sticks.  Per DOF (heave from depth, yaw from heading; surge
and sway where a velocity is logged) the 1-DOF model of :mod:`uuvid.simulate.dive_replay`
``m v̇ = F − k v − k_q v|v| + b`` (``m`` with added mass; ``b`` the net weight in heave) is
identified in two steps:

1. **start value** — equation error through a state-variable filter (``ω²/(s² + 2ζωs + ω²)``
   applied to the measured output and to the force alike, so derivatives are never raw
   differences; the channels are interpolated onto a 20 Hz grid for this step only);
2. **output error over short horizons** (the estimate): the dive is cut into windows of
   ``horizon`` s; each window is simulated with the logged force (linear between its own samples)
   from its own initial position and velocity (nuisance parameters) and compared with the
   measurements on *their own* stamps;
   :func:`~uuvid.identify.vehicle.output_error.levenberg_marquardt` minimises the error to
   within 1e-4 σ of the minimum.  Each window works on time and position relative to its own
   start (a heading wrapped, unwrapped or 2πk off and Unix-time stamps give the same fit); its
   measured start rate counts as one more sample (a window the model cannot follow otherwise
   sends its start rate to ±∞); a model whose replay of a window is beyond RK4's stability
   limit is not taken (its replay is not the model's solution, and can cost less than any
   solution does).

σ: the larger of the classical ``s²(JᵀJ)⁻¹`` and a cluster-robust sandwich with one cluster per
window (residuals within a window are correlated when the model is not exact), the nuisance
parameters included, each window's residuals as if it were left out (the jackknife form,
:func:`uuvid.identify.vehicle.output_error.covariance`).  Warnings name parameters the dive
cannot separate (|ρ| > 0.95), terms whose σ exceeds half their value, estimates at a bound.
With ``t_end`` before the end of the log, the rest is a held-out part: both the identified and
the base vehicle's model replay it (:func:`uuvid.simulate.dive_replay.replay_windows`).

Inflow (issue 21): the logged force is the *bollard* thrust; a moving propeller gives less.  With
the linear inflow form per thruster ``T_i = T_i,bollard − k_a |Ω_i| u_a,i`` (Healey et al. 1995,
IEEE JOE 20(4), eq. 6, small-angle form; Fossen 2011, *Handbook of Marine Craft Hydrodynamics*,
§6.7) and the advance speed of a 1-DOF motion ``u_a,i = (1 − w_i) a_ij v``, the DOF's force is
``F(t) − k_a c(t) v`` with ``c(t) = Σ_i B_ji (1 − w_i) a_ij |Ω_i(t)|``
(:func:`uuvid.vehicle.inflow.one_dof_inflow_matrix`; ``|Ω_i|`` the thruster model's rotor speed
at the logged PWM and voltage, :func:`uuvid.io.dive_channels.rotor_speeds`).  With ``inflow``
on, ``k_a`` is a fifth parameter fitted jointly (same windows, same output error); without it a
model identified from a moving vehicle books that loss as linear drag.  ``k_a`` and the linear
drag both multiply ``v``; only the variation of ``c(t)`` with the thrust separates them.

Dead band: where servo outputs are logged, each force sample whose thrusters sit at the edge of
the dead band (read off the thruster model, :func:`uuvid.io.dive_channels.pwm_flags`) carries an
uncertain force σ_F; it is propagated through the model from each window's start and the
residuals weighted by ``1/sqrt(1 + (δy/σ_y)²)``
(:func:`uuvid.identify.vehicle.output_error.dead_band_weights`); saturated samples are counted,
not down-weighted (their thrust is known).  ``dofs="horizontal"`` identifies surge, sway and yaw
jointly with the coupled model (:mod:`uuvid.identify.vehicle.dive_horizontal`).

A DOF whose force takes one value over the armed part fitted (every thruster that gives it in
the dead band: the thrusters sat at neutral) is refused, naming those outputs
(:meth:`~uuvid.io.dive_channels.DiveChannels.require_thrust`): with no force to scale them by,
mass, drag and the bias trade off exactly.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field

import numpy as np

from uuvid.core.checks import arg, arg_is
from uuvid.core.result import Result
from uuvid.identify.vehicle.output_error import (
    HELD_OUT_WORSE,
    best_starts,
    blown_windows,
    correlation_warnings,
    covariance,
    dead_band_weights,
    held_out_verdict,
    levenberg_marquardt,
    loss_as_drag,
    loss_as_drag_text,
    noise_sigma,
    not_identifiable,
    share_of_value,
    unusable_reasons,
    weighting_summary,
    weighting_text,
)
from uuvid.io.dive_channels import DIVE_DOFS, DiveDataError, pwm_flags, read_dive_channels
from uuvid.io.motor_direction import SIGN_HINT
from uuvid.simulate.dive_horizontal import spread_windows
from uuvid.simulate.dive_replay import (
    _STATE_SPAN,
    CHANNEL_NAMES,
    DEFAULT_HORIZON,
    RK4_LIMIT,
    SURFACE_M,
    UNITS,
    OneDofParams,
    WindowProblem,
    _dof_list,
    _is_all,
    all_left_out,
    check_state_span,
    dive_windows,
    initial_state,
    params_from_vehicle,
    plot_windows,
    replay_windows,
)

__all__ = ["identify_dive", "DiveIdentification", "MIN_WINDOWS", "MIN_SECONDS"]

#: identified inertia this many times the base vehicle's (or 1/this) is worth a warning: real
#: vehicles differ from published sets by several times, a reversed motor by ten and more
FAR_FROM_BASE = 8.0
MIN_WINDOWS = 4
MIN_SECONDS = 30.0  # of armed, submerged windows: fewer cannot separate four parameters
PARAMS = ("mass", "linear", "quadratic", "bias")
PARAMS_INFLOW = PARAMS + ("inflow",)
_SVF_OMEGA = {"heave": 1.5, "yaw": 4.0, "surge": 2.0, "sway": 2.0}
_LABEL = {"heave": {"mass": "mass [kg]", "linear": "linear drag [N·s/m]",
                    "quadratic": "quadratic drag [N·s²/m²]", "bias": "net weight W−B [N]"},
          "surge": {"mass": "mass [kg]", "linear": "linear drag [N·s/m]",
                    "quadratic": "quadratic drag [N·s²/m²]", "bias": "force bias [N]"},
          "sway": {"mass": "mass [kg]", "linear": "linear drag [N·s/m]",
                   "quadratic": "quadratic drag [N·s²/m²]", "bias": "force bias [N]"},
          "yaw": {"mass": "inertia [kg·m²]", "linear": "linear drag [N·m·s/rad]",
                  "quadratic": "quadratic drag [N·m·s²/rad²]", "bias": "moment bias [N·m]"}}
for _lab in _LABEL.values():
    _lab["inflow"] = "inflow coefficient k_a [N·s²/(rad·m)]"
#: the parameters' names without their units (``mass`` is the yaw inertia's key)
_NAMES = {d: {k: v.split(" [")[0] for k, v in lab.items()} for d, lab in _LABEL.items()}
#: |ρ| beyond which k_a and the linear drag are reported as not separated
RHO_LIMIT = 0.95


def _svf_start(dc, dof, windows, omega):
    """Equation-error LS through a state-variable filter over the windows' span (start value)."""
    from scipy.signal import lsim

    meas, force, position = DIVE_DOFS[dof]
    tm, ym = dc.channels[meas]
    tf, F = dc.channels[force]
    rows, rhs = [], []
    # contiguous runs of windows
    runs, cur = [], [windows[0][0], windows[0][1]]
    for a, b in windows[1:]:
        if a <= cur[1] + 1e-9:
            cur[1] = b
        else:
            runs.append(tuple(cur))
            cur = [a, b]
    runs.append(tuple(cur))
    z = 0.9
    A = np.array([[0.0, 1.0], [-omega ** 2, -2 * z * omega]])
    Bm = np.array([[0.0], [omega ** 2]])
    C = np.eye(2)
    D = np.zeros((2, 1))
    for a, b in runs:
        # time from the run's start and the measured channel from its value there: neither an
        # absolute stamp (1.7e9 s) nor a heading's 2πk enters the filter's arithmetic
        g = np.arange(0.0, b - a, 0.05)
        if g.size < 40:
            continue
        y = np.interp(g, tm - a, ym)
        if position:
            y = y - y[0]
        f = np.interp(g, tf - a, F)
        _, yf, _ = lsim((A, Bm, C, D), y, g, X0=[y[0], 0.0])
        _, ff, _ = lsim((A, Bm, C, D), f, g, X0=[f[0], 0.0])
        skip = g > 3.0 / omega
        if position:
            p, d1 = yf[:, 0], yf[:, 1]
            d2 = omega ** 2 * (y - p) - 2 * z * omega * d1
            vel, acc = d1, d2
        else:
            vel, acc = yf[:, 0], yf[:, 1]
        rows.append(np.column_stack([acc, vel, vel * np.abs(vel), -np.ones_like(vel)])[skip])
        rhs.append(ff[:, 0][skip])
    if not rows:
        return None
    H, r = np.vstack(rows), np.concatenate(rhs)
    th, *_ = np.linalg.lstsq(H, r, rcond=None)
    return th


@dataclass
class DofEstimate:
    """One DOF's estimate (plain object inside :class:`DiveIdentification`)."""

    dof: str
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
    inflow: dict | None = None  # the thrust-loss split (see _inflow_split), None when off
    #: servo outputs the reader found at fault that drive this DOF (a reversed motor, one off
    #: throughout: :attr:`uuvid.io.dive_channels.DiveChannels.faulty`)
    faults: list = field(default_factory=list)

    @property
    def names(self) -> tuple:
        return PARAMS_INFLOW if "inflow" in self.values else PARAMS

    @property
    def unusable(self) -> list:
        """Why this estimate is not a model to use (empty when nothing says so): parameters or σ
        that are not finite, a mass or inertia not determined (σ beyond twice its value,
        :data:`~uuvid.identify.vehicle.output_error.INERTIA_SIGMA_MAX`) or beyond
        :data:`FAR_FROM_BASE` of the base's, an in-sample replay that explains nothing of the
        channel (:func:`~uuvid.identify.vehicle.output_error.unusable_reasons`), a held-out part
        the base predicts better, a servo output at fault that drives the DOF (:attr:`faults`)."""
        rms, nrmse = self.train.get("rms", math.nan), self.train.get("nrmse", math.nan)
        why = unusable_reasons(self.names, self.values, self.sigma, inertias=("mass",),
                               nrmse={CHANNEL_NAMES.get(self.dof, self.dof):
                                      nrmse if math.isfinite(rms) else math.inf},
                               labels=_NAMES.get(self.dof))
        if any(f"beyond the ×{FAR_FROM_BASE:g}" in w for w in self.warnings):
            why.append(f"{'inertia' if self.dof in ('roll', 'pitch', 'yaw') else 'mass'} beyond "
                       f"×{FAR_FROM_BASE:g} of the base's")
        why += self.faults  # (before the held-out verdict: the summary says that one last)
        h = self.held_out or {}
        if h.get("improvement") is not None and h["improvement"] < HELD_OUT_WORSE:
            why.append(f"it predicts the held-out part {1 / h['improvement']:.3g}× worse than the "
                       f"base vehicle (rms {h['identified']['rms']:.3g} vs {h['base']['rms']:.3g})")
        return why

    def params(self) -> OneDofParams:
        v = self.values
        return OneDofParams(v["mass"], v["linear"], v["quadratic"], v["bias"],
                            v.get("inflow", 0.0))

    def to_dict(self) -> dict:
        ratio = {k: (self.values[k] / self.base[k] if self.base.get(k) else None)
                 for k in self.names}
        return {"dof": self.dof, "values": self.values, "sigma": self.sigma,
                "correlation": {"params": list(self.names), "matrix": self.correlation},
                "start_value_svf": self.start, "base": self.base, "base_source": self.base_source,
                "ratio_to_base": ratio, "windows": self.windows, "horizon_s": self.horizon,
                "train": self.train, "held_out": self.held_out, "warnings": self.warnings,
                "notes": self.notes, "dead_band": self.weighting, "inflow": self.inflow,
                "unusable": self.unusable}

    def identified(self, log: str, measured: str = "") -> dict:
        """``{dof: entry}`` for :func:`uuvid.vehicle.writeback.write_identified`; ``measured``:
        where the DOF's channels came from (a bag's topics and publisher), kept in its notes."""
        v, s = self.values, self.sigma
        e = {"mass": v["mass"], "linear": max(v["linear"], 0.0),
             "quadratic": max(v["quadratic"], 0.0), "disturbance": v["bias"],
             "sigma": {"mass": s["mass"], "linear": s["linear"],
                       "quadratic": s["quadratic"], "disturbance": s["bias"]},
             "log": log, "method": "dive output-error" + (" with inflow" if "inflow" in v else ""),
             "notes": f"{self.windows} windows of {self.horizon:g} s"
                      + (f"; measured: {measured}" if measured else "")}
        if "inflow" in v:
            e["inflow_coefficient"] = max(v["inflow"], 0.0)
            e["sigma"]["inflow_coefficient"] = s["inflow"]
            e["notes"] += ("; linear drag without the thrust lost to the advance speed (k_a: "
                           "one_dof inflow_coefficient, read by the dive replay)")
        return {self.dof: e}

    def summary_lines(self, t_end) -> list:
        dof, e = self.dof, self
        lab = _LABEL.get(dof, {k: k for k in PARAMS_INFLOW})
        lines = [f"{dof}: {e.windows} windows of {e.horizon:g} s (output error"
                 + (", inflow coefficient jointly)" if e.inflow else ")")]
        for k in e.names:
            b = e.base.get(k)
            ratio = (f"  ×{e.values[k] / b:.2f} of base {b:.4g}" if b else
                     f"  (base {b:.4g})" if b is not None else "")
            lines.append(f"  {lab[k]:30s} {e.values[k]:10.4g} ± {e.sigma[k]:.2g}{ratio}")
        if e.inflow:
            lines.append(f"  {loss_as_drag_text(e.inflow, UNITS_DRAG[dof])}")
        ch = CHANNEL_NAMES[dof]
        lines.append(f"  in-sample replay: {ch} rms {e.train['rms']:.3g} {UNITS[dof]}, "
                     f"nrmse {e.train['nrmse']:.3f}")
        if e.held_out and e.held_out["improvement"] is not None:
            h = e.held_out
            imp = h["improvement"]
            verdict = held_out_verdict(imp)
            if e.unusable and imp < HELD_OUT_WORSE:
                verdict = (f"{verdict} than the base: not a model to use"
                           + (f"; also {'; '.join(e.unusable[:-1])} — see the warnings"
                              if len(e.unusable) > 1 else ""))
            elif e.unusable:
                verdict = (f"{h['improvement']:.3g}× lower rms than the base's, but not a model "
                           f"to use: "
                           f"{'; '.join(e.unusable)} — see the warnings")
            lines.append(f"  held-out (t > {t_end:.10g} s): {ch} rms identified "
                         f"{h['identified']['rms']:.3g} vs base {h['base']['rms']:.3g} "
                         f"{UNITS[dof]} ({verdict})")
        elif e.unusable:
            lines.append(f"  not a model to use: {'; '.join(e.unusable)} — see the warnings")
        if e.weighting:
            lines.append(f"  {weighting_text(e.weighting)}")
        lines += [f"  warning: {w}" for w in e.warnings]
        lines += [f"  note: {n}" for n in e.notes]
        return lines

    def panels(self) -> list:
        """``[(trace, y label, title)]`` for the report's figure; a trace is ``(t, measured,
        identified, base, window)``."""
        key = "held_out" if "held_out" in self.traces else "train"
        return [(self.traces[key], f"{CHANNEL_NAMES[self.dof]} [{UNITS[self.dof]}]",
                 f"{self.dof}: {'held-out' if key == 'held_out' else 'in-sample'} replay")]


@dataclass
class DiveIdentification(Result):
    """Per-DOF 1-DOF models identified from a dive (see :func:`identify_dive`)."""

    log: str
    vehicle: str
    vehicle_ref: object
    estimates: dict  # dof → DofEstimate
    t_start: float | None
    t_end: float | None
    seconds: float
    warnings: list = field(default_factory=list)
    #: where each measured channel came from (``depth_m`` → ``-BARO[1].Alt``, a table column)
    sources: dict = field(default_factory=dict)

    report_title = "Dive identification"

    def identified(self) -> dict:
        """The estimates in :func:`uuvid.vehicle.writeback.write_identified`'s form.  Where the
        coupled horizontal model was identified too, its surge, sway and yaw values are written
        (it is the model the 6-DOF simulator flies; the 1-DOF ones stay in the result)."""
        out = {}
        for e in self.estimates.values():
            if e.dof != "horizontal":
                chans = DIVE_DOFS[e.dof][:2] if e.dof in DIVE_DOFS else ()
                measured = "; ".join(f"{c} from {self.sources[c].split(' (')[0]}" for c in chans
                                     if (self.sources or {}).get(c))
                out.update(e.identified(self.log, measured))
        if "horizontal" in self.estimates:
            out.update(self.estimates["horizontal"].identified(self.log))
        return out

    def write_vehicle(self, out, base=None) -> object:
        """Write the base vehicle with the identified values and their provenance
        (:func:`uuvid.vehicle.writeback.write_identified`); returns the path.  Mass, added mass
        and drag go into ``hydrodynamics`` (the 6-DOF model every command flies); the bias into
        ``one_dof.<dof>.disturbance``, and in heave (the net weight ``W − B``) also into
        ``rigid_body.buoyancy`` (the weight kept) so that the 6-DOF model sinks as the dive did.
        An estimate that is not a model to use (:attr:`DofEstimate.unusable`) is refused
        (:class:`~uuvid.vehicle.writeback.WritebackError`): nothing is written."""
        from uuvid.vehicle.writeback import WritebackError, write_identified

        bad = {d: e.unusable for d, e in self.estimates.items() if getattr(e, "unusable", None)}
        if bad:
            raise WritebackError(
                f"{out}: not written — " + "; ".join(f"{d} is not a model to use ({'; '.join(w)})"
                                                     for d, w in bad.items())
                + f": resolve the warnings, or identify only the DOFs that are ({arg('dofs', '--dof')})")
        base = base or self.vehicle_ref
        return write_identified(base, self.identified(), out, log=self.log,
                                command="uuvid vehicle identify dive")

    def summary(self) -> str:
        span = ""
        if self.t_start is not None or self.t_end is not None:
            span = f" over [{self.t_start if self.t_start is not None else 'start'}, " \
                   f"{self.t_end if self.t_end is not None else 'end'}] s"
        lines = [f"dive identification of {self.log}{span}, base vehicle {self.vehicle} "
                 f"({self.seconds:.1f} s)"]
        if self.sources:
            lines.append("measured: " + ", ".join(f"{c} from {s}" for c, s in self.sources.items()))
        for e in self.estimates.values():
            lines += e.summary_lines(self.t_end)
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"log": self.log, "vehicle": self.vehicle, "t_start": self.t_start,
                "t_end": self.t_end, "seconds": self.seconds,
                "dofs": {d: e.to_dict() for d, e in self.estimates.items()},
                "warnings": self.warnings, "sources": self.sources}

    def plot(self, path=None):
        from uuvid.core.plots import new_figure, save_figure

        panels = [p for e in self.estimates.values() for p in e.panels()]
        fig, ax = new_figure(len(panels), 1, figsize=(10, 3.2 * len(panels)))
        ax = np.atleast_1d(ax)
        for a, ((t, y, p_id, p_base, w), ylabel, title) in zip(ax, panels):
            plot_windows(a, t, y, w, [(p_id, "identified", {"color": "C1", "lw": 1}),
                                      (p_base, f"base {self.vehicle}",
                                       {"color": "C0", "lw": 0.8, "ls": "--"})])
            a.set_ylabel(ylabel)
            a.set_title(title)
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
        rep.add_preformatted(self.summary(), caption="Summary: identified vs base vehicle")
        rep.add_figure(fig, caption="Replay (each window restarted from the measured state): "
                                    "identified vs base model vs measured")
        return rep.write(folder)


UNITS_DRAG = {"heave": "N·s/m", "surge": "N·s/m", "sway": "N·s/m", "yaw": "N·m·s/rad"}


#: unit of the inflow gain c(t) = Σ (1 − w_i)|Ω_i| b_i² per DOF (rad/s; yaw: lever arm² too)
UNITS_GAIN = {"heave": "rad/s", "surge": "rad/s", "sway": "rad/s", "yaw": "rad·m²/s"}


def _inflow_split(prob, values: dict, sigma: dict, dof: str) -> dict:
    """:func:`~uuvid.identify.vehicle.output_error.loss_as_drag` over the fitted windows (the
    identified model's own speeds)."""
    with np.errstate(over="ignore", invalid="ignore"):
        _, V = prob.simulate(np.array([values[k] for k in PARAMS_INFLOW]), prob.y0_meas,
                             prob.v0_meas if prob.position else np.zeros(prob.W))
    return loss_as_drag(prob.Ch[:, ::2], V, values["inflow"], sigma["inflow"], values["linear"],
                        UNITS_GAIN[dof], UNITS_DRAG[dof])


def inflow_warnings(values: dict, sigma: dict, corr) -> list:
    """Warnings on the inflow coefficient of a 5-parameter fit (:data:`PARAMS_INFLOW` order):
    ``k_a`` and the linear drag both multiply the speed — only the variation of ``c(t)`` with the
    thrust tells them apart — so |ρ(k, k_a)| > :data:`RHO_LIMIT` is named as that confusion; a
    negative or poorly determined ``k_a`` is named too."""
    out = []
    rho = float(np.asarray(corr)[1, 4])
    if abs(rho) > RHO_LIMIT:
        out.append(f"the inflow coefficient k_a and the linear drag are not separated in this "
                   f"dive (correlation {rho:+.2f}): both multiply the speed, and the rotor speeds "
                   "varied too little between the moving stretches; their split is uncertain "
                   "(their sum, the apparent drag, is not) — fly at one speed with different "
                   "thrusts (e.g. against a current or with a payload)")
    ka, s = values["inflow"], sigma["inflow"]
    if ka < 0:
        out.append(f"inflow coefficient negative ({ka:.3g} ± {s:.2g}): thrust that grows with the "
                   "advance speed is not physical; "
                   + ("not significant" if ka > -3 * s else "the model does not fit")
                   + "; a vehicle file gets 0")
    elif math.isfinite(s) and s > 0.5 * abs(ka):
        out.append(f"inflow coefficient poorly determined: σ {s:.2g} is "
                   + (share_of_value(s, ka) if ka else
                      "above a zero estimate"))
    return out


def _dead_band_delta(prob, force_sigma, theta, y0, v0):
    """``δy`` of :func:`~uuvid.identify.vehicle.output_error.dead_band_weights`: the prediction
    with the force raised by its dead-band uncertainty σ_F (linear between the servo-output
    samples, like the force) minus the prediction with the logged force."""
    import copy

    tF, sF = force_sigma
    pert = copy.copy(prob)
    pert.Fh = prob.Fh + np.interp(prob.half_steps(), np.asarray(tF) - prob.t_ref, sF, left=0.0,
                                  right=0.0)
    return pert.predict(theta, y0, v0) - prob.predict(theta, y0, v0)


#: Log-spaced start values around the base vehicle: published parameter sets differ from a real
#: vehicle by several times (and from each other by up to 8× on one coefficient).
_GRID_MASS = (0.6, 1.5, 3.0)
_GRID_DRAG = (0.3, 1.0, 3.0, 10.0)


def _start_candidates(th_svf, base: OneDofParams, inflow_starts=None) -> list:
    """``[(label, θ)]``: the state-variable-filter estimate first, the base vehicle, and a grid
    around the base (mass × :data:`_GRID_MASS`, each drag × :data:`_GRID_DRAG`, bias the SVF's or
    the base's).  From a start far from the truth the output-error fit can settle where some
    windows diverge (a vehicle 4× draggier than its preset: heading rms 2.8 rad); the candidates
    are ranked by the output error from the measured initial states and the best refined.
    ``inflow_starts`` (k_a values, e.g. 0 and the T200 preset's): each candidate once per value,
    θ then has ``k_a`` as a fifth entry (the SVF start first with the first value)."""
    if inflow_starts:
        four = _start_candidates(th_svf[:4], OneDofParams(*base.as_array()[:4]))
        return [(lab if ka == inflow_starts[0] else f"{lab}, k_a {ka:.3g}",
                 np.append(th[:4], ka)) for ka in inflow_starts for lab, th in four]
    b = base.as_array()[:4]
    out = [("SVF", np.asarray(th_svf, float)), ("base", b.copy())]
    lin = max(b[1], 1e-3 * b[0])
    quad = max(b[2], 1e-3 * b[0])
    for bias in sorted({float(th_svf[3]), float(b[3])}):
        for ms in _GRID_MASS:
            for kl in _GRID_DRAG:
                for kq in _GRID_DRAG:
                    out.append(("grid", np.array([b[0] * ms, lin * kl, quad * kq, bias])))
    return out


def _rms_kept(r, left_out) -> float:
    """RMS of the residuals ``r`` outside the windows ``left_out`` (a replay refused there is NaN)."""
    keep = ~np.asarray(left_out, bool)
    return float(np.sqrt(np.mean(r[keep] ** 2))) if keep.any() else math.nan


def _cost(resid, z0, th) -> float:
    z = z0.copy()
    z[:len(th)] = th
    r = resid(z)
    c = float(r @ r)
    return c if math.isfinite(c) else math.inf


def _fmt_theta(th) -> str:
    return "(" + ", ".join(f"{v:.3g}" for v in th) + ")"


#: yaw windows whose surge force would drive the vehicle faster than this (m/s, steady, at the
#: base vehicle's surge drag) couple sway into yaw, which the 1-DOF yaw model cannot hold
SURGE_COUPLING_MPS = 0.2
#: ... in more than this fraction of the yaw windows: a warning
SURGE_COUPLING_SHARE = 0.1


def _surge_in_yaw_windows(dc, veh, windows) -> str | None:
    """A sentence when the pilot surged in many yaw windows: the steady surge speed the logged
    surge force gives at the base vehicle's drag (``X = X_u u + X_uu u²``) above
    :data:`SURGE_COUPLING_MPS` in more than :data:`SURGE_COUPLING_SHARE` of them.  Turning
    while moving couples sway into yaw (Munk moment, Coriolis), which the uncoupled yaw model
    absorbs into its inertia and drag (3–8× on synthetic dives); without a DVL nothing measures
    it."""
    if "X_N" not in dc.channels:
        return None
    try:  # ``windows``: the yaw fit's own [(t0, t1)]
        xl = float(veh.params.linear_damping[0, 0])
        xq = float(veh.params.quadratic_damping[0, 0])
    except (KeyError, IndexError, AttributeError, TypeError, ValueError):
        return None
    if not windows or not (xl > 0 or xq > 0):
        return None
    tx, fx = dc.channels["X_N"]
    fast, top = 0, 0.0
    for a, b in windows:
        sel = (tx >= a) & (tx <= b)
        if not sel.any():
            continue
        f = float(np.median(np.abs(fx[sel])))
        u = (f / xl if xq <= 0 else
             (-xl + math.sqrt(xl * xl + 4.0 * xq * f)) / (2.0 * xq))
        top = max(top, u)
        fast += u > SURGE_COUPLING_MPS
    if fast <= SURGE_COUPLING_SHARE * len(windows):
        return None
    return (f"the pilot surged in {fast} of {len(windows)} yaw windows (a surge force that drives "
            f"{veh.name} at {SURGE_COUPLING_MPS:g}–{top:.2g} m/s): turning while moving couples "
            "sway into yaw, which the 1-DOF yaw model absorbs into its inertia and drag — "
            f"identify yaw from turns without surge ({arg('t_start')}/{arg('t_end')}), or with "
            f"a DVL (u_mps, v_mps) the coupled model ({arg_is('dofs', 'horizontal', '--dof')})")


#: the measured channels of a DOF, by which a reader's warning is known to bear on it (a stuck
#: depth sensor whose samples were left out, then 'window too short')
_DOF_CHANNELS = {"heave": ("depth_m", "depth"), "yaw": ("yaw_rad", "yaw", "heading", "attitude"),
                 "surge": ("u_mps",), "sway": ("v_mps",)}
_DOF_CHANNELS["horizontal"] = ("u_mps", "v_mps") + _DOF_CHANNELS["yaw"]
assert set(DIVE_DOFS) <= set(_DOF_CHANNELS)
#: warnings that bear on every DOF: a part of the log left out (its channels do not overlap)
_EVERY_DOF = re.compile(r"part \d+: .*left out|do not overlap")


def below_rigid_body(veh, dof: str, mass: float, sigma: float) -> str | None:
    """The warning when an identified ``dof`` mass (inertia in yaw) is below the base vehicle's
    rigid-body one — an added mass < 0, physically impossible (the write-back refuses it); the
    usual cause, when below by more than 2σ, is a force column in another unit (lbf, kgf), which
    scales mass and drag alike; within 2σ it is said as possibly the record's noise."""
    i = {"surge": 0, "sway": 1, "heave": 2, "yaw": 5}.get(dof)
    try:
        rigid = float(np.asarray(veh.params.M_RB)[i, i])
    except (AttributeError, TypeError, IndexError):
        return None
    if i is None or not (rigid > 0) or not (mass < rigid):
        return None
    what, unit = ("inertia", "kg·m²") if i >= 3 else ("mass", "kg")
    # below by less than 2σ: a small added mass (yaw, a streamlined surge) estimated from a short
    # record lands under the rigid-body value half the time by noise alone — said all the same,
    # as the write-back refuses any added mass < 0
    if not (mass + 2.0 * (sigma if sigma >= 0 else math.inf) < rigid):
        within = ("within 2σ, so possibly noise of the record" if math.isfinite(sigma)
                  else "its σ not determined, so possibly noise of the record")
        return (f"the identified {dof} {what} {mass:.4g} ± {sigma:.2g} {unit} is below the "
                f"rigid-body {what} {rigid:.4g} {unit} of {veh.name} ({within}; a longer record or "
                f"more {dof} manoeuvres narrow it): the added {what} would be {mass - rigid:.3g} "
                "< 0, so writing it (--out-vehicle, write_vehicle) is refused")
    force = DIVE_DOFS[dof][1]
    units = ("lbf·ft: ×1.356 → N·m; lbf·in: ×0.113 → N·m; kgf·m: ×9.807 → N·m" if i >= 3 else
             "lbf: ×4.448 → N; kgf: ×9.807 → N")
    kind = "torque" if i >= 3 else "force"
    return (f"the identified {dof} {what} {mass:.4g} ± {sigma:.2g} {unit} is below the rigid-body "
            f"{what} {rigid:.4g} {unit} of {veh.name} by more than 2σ: the added {what} would be "
            f"{mass - rigid:.3g} < 0, which is physically impossible — is the {kind} column "
            f"({force}) in another unit ({units})? A {kind} scaled by c "
            f"scales {what} and drag by c; else check the rigid-body numbers. Writing it "
            "(--out-vehicle, write_vehicle) is refused")


def output_faults(dc, dofs) -> list:
    """What the reader found at fault in the servo outputs that drive one of ``dofs`` (a motor
    named as probably reversed, an output off throughout: its force wrong or missing there),
    :attr:`uuvid.io.dive_channels.DiveChannels.faulty`."""
    return [why for why, driven in getattr(dc, "faulty", {}).values() if set(driven) & set(dofs)]


def _with_reader_warnings(e: DiveDataError, dofs, dc) -> DiveDataError:
    """``e`` (a DOF not identified) with the reader's warnings that name its channels appended
    (the samples of them left out, a source missing): a CLI user sees the error alone, not the
    warnings that explain it.  Warnings about other messages or channels are not added, even if
    they speak of samples skipped or of the vehicle disarmed."""
    names = sorted({c for d in dofs for c in _DOF_CHANNELS.get(d, ())})
    if not names:
        return e
    pat = re.compile(r"(?<![A-Za-z0-9_])(" + "|".join(map(re.escape, names)) + r")(?![A-Za-z0-9_])",
                     re.IGNORECASE)
    pre = f"{dc.name}: " if dc.name else ""
    said = [w.removeprefix(pre) for w in dc.warnings if pat.search(w) or _EVERY_DOF.search(w)]
    if not said:
        return e
    more = f" (and {len(said) - 3} more)" if len(said) > 3 else ""
    return DiveDataError(f"{e} — the reader warned of this log: " + " | ".join(said[:3]) + more)


def _fit_dof(dc, dof, horizon, t_start, t_end, base: OneDofParams, flags=None,
             weighting: bool = True, gain=None, inflow_starts=None, B=None):
    windows, notes = dive_windows(dc, dof, horizon, t_start, t_end)
    windows = spread_windows(windows, notes, dof)
    need = max(MIN_WINDOWS, math.ceil(MIN_SECONDS / horizon - 1e-9))
    if len(windows) < need:
        span = dc.span_text(t_start, t_end)
        raise DiveDataError(
            f"{dc.name}: window too short to identify {dof}: {len(windows)} usable armed window(s) "
            f"of {horizon:g} s in {span} (need at least {need}, i.e. {need * horizon:g} s of "
            f"armed, submerged data); widen {arg('t_start')}/{arg('t_end')} or pass a longer dive"
            + (f" ({'; '.join(notes)})" if notes else ""))
    dc.require_thrust(dof, [DIVE_DOFS[dof][1]], B, flags, t_start, t_end)
    prob = WindowProblem(dc, dof, windows, gain=gain)
    W = prob.W
    names = PARAMS_INFLOW if gain is not None else PARAMS
    NP = len(names)
    th0 = _svf_start(dc, dof, windows, _SVF_OMEGA[dof])
    start = {k: float(v) for k, v in zip(PARAMS, th0)} if th0 is not None else {}
    th0 = np.array(th0 if th0 is not None else base.as_array()[:4], float)
    if not (th0[0] > 0):
        notes.append(f"state-variable-filter start value had mass {th0[0]:.3g} ≤ 0; started from "
                     "the base vehicle's mass instead")
        th0[0] = base.mass
    th0[1] = max(th0[1], 0.0)
    th0[2] = max(th0[2], 0.0)
    pos = prob.position
    n_nuis = 2 if pos else 1

    def unpack(z):
        th = z[:NP]
        if pos:
            return th, z[NP:NP + W], z[NP + W:]
        return th, z[NP:NP + W], None

    weights = None
    if flags is not None and weighting:
        fs = flags.sigma_of(DIVE_DOFS[dof][1])
        if np.any(fs[1] > 0):
            with np.errstate(over="ignore", invalid="ignore"):
                delta = _dead_band_delta(prob, fs, th0, prob.y0_meas,
                                         prob.v0_meas if pos else np.zeros(W))
            weights = dead_band_weights(delta, noise_sigma(*dc.channels[DIVE_DOFS[dof][0]]))
    wts = weights if weights is not None else 1.0

    # A position DOF's windows start at the measured position plus an offset (the nuisance y0 is
    # that offset, the samples are taken relative to it: prob.y_rel), so where the heading's
    # zero lies (wrapped, unwrapped, 2πk) changes none of the fit's numbers.  The measured start
    # rate counts as one more sample (wv (v0 − v0_meas), wv the local fit's slope weight):
    # without it a window the model cannot follow (a force that changed between its samples)
    # sends its v0 towards ±∞ — a strong drag turns any start rate into a step of the position
    # within a time step — and the fit ends where RK4's fixed step gives out, in round-off.  A
    # replay beyond RK4's stability limit is refused (NaN): it is not the model's solution, and
    # can cost less than any solution does.
    def resid(z):
        th, y0, v0 = unpack(z)
        r = (prob.predict(th, y0, v0 if v0 is not None else np.zeros(W), stiff_limit=RK4_LIMIT)
             - prob.y_rel) * wts
        return np.concatenate([r, prob.v0_weight * (v0 - prob.v0_meas)]) if pos else r

    th0_full = np.append(th0, inflow_starts[0] if gain is not None else [])
    z0 = np.concatenate([th0_full, prob.y0_meas - prob.y_ref] + ([prob.v0_meas] if pos else []))
    N = prob.y.size
    P = z0.size
    # each residual's window: the samples', then (position DOFs) each window's start-rate row
    groups = np.concatenate([prob.w, np.arange(W)]) if pos else prob.w
    n_rows = groups.size

    def jac(z):
        # globals by forward differences; each window's nuisance touches only its own rows, so
        # all windows' y0 (then v0) are perturbed at once; sparse: a row has the globals and its
        # window's start, and the optimiser's JᵀJ then costs a few entries per row
        # (a window whose perturbed replay blew up gives no information in that direction:
        # blown_windows zeroes it and the windows are reported with the fit)
        from scipy.sparse import csr_matrix

        r0 = resid(z)
        cols = [np.empty((n_rows, NP))]
        blown = np.zeros(W, bool)
        for i in range(NP):
            dz = 1e-6 * max(abs(z[i]), 1e-3)
            zz = z.copy()
            zz[i] += dz
            dr, b = blown_windows(resid(zz) - r0, groups, W)
            cols[0][:, i] = dr / dz
            blown |= b
        for j in range(n_nuis):
            sl = slice(NP + j * W, NP + (j + 1) * W)
            d = 1e-6 * np.maximum(np.abs(z[sl]), 1e-2)
            zz = z.copy()
            zz[sl] += d
            dr, b = blown_windows(resid(zz) - r0, groups, W)
            cols.append((dr / d[groups])[:, None])
            blown |= b
        vals = np.hstack(cols)
        vals[~np.isfinite(vals)] = 0.0
        idx = np.hstack([np.broadcast_to(np.arange(NP), (n_rows, NP))]
                        + [(NP + j * W + groups)[:, None] for j in range(n_nuis)])
        J = csr_matrix((vals.ravel(), idx.ravel(), np.arange(0, vals.size + 1, vals.shape[1])),
                       shape=(n_rows, P))
        blown_at.clear()
        blown_at[z.tobytes()] = blown
        return J

    blown_at: dict = {}

    free = np.ones(P, bool)
    sol, sol_cost = None, math.inf
    starts = best_starts(lambda c: _cost(resid, z0, c[1]),
                         _start_candidates(th0, base, inflow_starts if gain is not None else None))
    finals = []
    for _, (label, th_start) in starts:
        z = z0.copy()
        z[:NP] = th_start
        s_ = levenberg_marquardt(resid, jac, z, free, nonneg=(1, 2))
        c1 = _cost(resid, s_["x"], s_["x"][:NP])
        finals.append(c1)
        if sol is None or c1 < sol_cost:
            sol, sol_cost, kept = s_, c1, label
    if len(starts) > 1 or kept != "SVF":  # (the start's cost and the refined fit's: "lowest"
        # is the final one — the start costs alone read as the other start kept)
        notes.append("output error refined from " + "; ".join(
            f"the {label} start {_fmt_theta(th)} (start cost {c:.3g} → final cost {f:.3g})"
            for (c, (label, th)), f in zip(starts, finals))
            + f": kept the fit from the {kept} start (lowest final cost)")
    th = sol["x"][:NP]
    J = sol["jac"]
    if sol["x"].tobytes() not in blown_at:  # the last Jacobian was another start's
        J = jac(sol["x"])
    # the optimiser's Jacobian is the derivative of the cost it minimises (a window's rows are
    # not zeroed while its residuals stay in the cost: that stalled the fit); resid refuses a
    # replay beyond RK4's stability limit, so a window is so here only when no step left it: for
    # σ its rows are left out (its replay is not the model's solution)
    _, y0_s, v0_s = unpack(sol["x"])
    stiff = prob.stiffness(th, y0_s, v0_s if v0_s is not None else np.zeros(W))
    unstable = stiff > RK4_LIMIT
    blown = blown_at[sol["x"].tobytes()] | unstable
    J = np.where(unstable[groups][:, None], 0.0, J.toarray())[:, free]
    warns_pre = []
    if blown.any():
        ts = ", ".join(f"{windows[k][0]:.1f}" for k in np.flatnonzero(blown)[:6])
        more = f" (and {int(blown.sum()) - 6} more)" if blown.sum() > 6 else ""
        warns_pre.append(
            f"{int(blown.sum())} window(s) (starting at t = {ts} s{more}) are too stiff for the "
            f"replay's fixed RK4 step of {prob.h:.3g} s at the fitted model (step × drag rate "
            f"h·(k + 2k_q|v|)/m up to {float(np.max(stiff[blown])):.3g}; RK4 is stable below "
            f"{RK4_LIMIT}) or blew up when a parameter moved by 1e-6 of its value: they are "
            "left out of the standard errors; replays there are not the model's solution")
    # the left-out windows' residuals too (NaN where a replay is refused): σ from the others
    fun = np.where(unstable[groups], 0.0, sol["fun"])
    sd_f, corr_f = covariance(J, fun, groups, int(np.count_nonzero(free[:NP])))
    sd, corr = np.zeros(NP), np.eye(NP)
    fi = np.flatnonzero(free[:NP])
    sd[fi] = sd_f
    corr[np.ix_(fi, fi)] = corr_f
    values = {k: float(v) for k, v in zip(names, th)}
    sigma = {k: float(v) for k, v in zip(names, sd)}
    warns = warns_pre + not_identifiable(names, sigma) + correlation_warnings(names, corr, RHO_LIMIT)
    if gain is not None:
        warns += inflow_warnings(values, sigma, corr)
    for k in ("linear", "quadratic"):
        if values[k] == 0:
            warns.append(f"{k} drag estimate is at its bound 0 (± {sigma[k]:.2g}): the dive "
                         f"prefers {'less' if k == 'linear' else 'no'} {k} drag than physics "
                         "allows; the other terms carry the drag")
        elif values[k] < 0:
            warns.append(f"{k} drag estimate is negative ({values[k]:.3g} ± {sigma[k]:.2g}): "
                         f"{'not significant' if values[k] > -3 * sigma[k] else 'the model does not fit'}"
                         "; a vehicle file gets 0")
        elif math.isfinite(sigma[k]) and sigma[k] > 0.5 * abs(values[k]):
            warns.append(f"{k} drag poorly determined: σ {sigma[k]:.2g} is "
                         + share_of_value(sigma[k], values[k]))
    tf = dc.channels[DIVE_DOFS[dof][1]][0]
    tf = tf[(tf >= windows[0][0]) & (tf <= windows[-1][1])]
    dt_f = float(np.median(np.diff(tf))) if tf.size > 2 else math.inf
    v_rms = float(np.sqrt(np.mean(np.asarray(prob.v0_meas) ** 2))) if pos else \
        float(np.sqrt(np.mean(prob.y ** 2)))
    tau = values["mass"] / max(values["linear"] + 2 * max(values["quadratic"], 0.0) * v_rms,
                               1e-12)
    if dt_f > 0.5 * tau:
        fcol = DIVE_DOFS[dof][1]
        src_f = str(dc.sources.get(fcol, ""))
        via = ", from the servo outputs" if "computed from" in src_f or "thrust_" in src_f else ""
        warns.append(f"the force ({fcol}{via}) is logged every {dt_f:.2g} s but {dof} "
                     f"responds in about {tau:.2g} s: what the controllers did between samples is "
                     "unknown, so mass and drag may be biased beyond σ; log the servo outputs "
                     "faster (telemetry SERVO_OUTPUT_RAW stream rate, or the .BIN's RCOU)")
    if math.isfinite(sigma["mass"]) and sigma["mass"] > 0.5 * values["mass"]:
        warns.append(f"{_NAMES[dof]['mass']} poorly determined (σ {sigma['mass']:.2g}): the dive "
                     "has little acceleration")
    r = values["mass"] / base.mass if base.mass > 0 else math.nan
    if math.isfinite(r) and not 1.0 / FAR_FROM_BASE <= r <= FAR_FROM_BASE:
        what = "inertia" if dof in ("roll", "pitch", "yaw") else "mass"
        meas = DIVE_DOFS[dof][0]
        why = ((f"{meas} opposes the {dof} force throughout the log (the reader's warning): "
                f"{SIGN_HINT[dof]} — fix its sign before using it")
               if dof in getattr(dc, "opposed", ()) and dof in SIGN_HINT else
               "check the motor directions (reversed motors driven together can escape the "
               "direction check), the thruster model and the log's units before using it")
        warns.append(f"{dof} {what} ×{r:.3g} of the base vehicle's {base.mass:.4g}: beyond the "
                     f"×{FAR_FROM_BASE:g} a real vehicle differs from a published set by — {why}")
    if not sol["success"]:
        warns.append(f"optimiser stopped: {sol['message']}")
    # in-sample replay from the measured state, identified and base
    p_id = OneDofParams(*values.values())
    split = _inflow_split(prob, values, sigma, dof) if gain is not None else None
    span = _STATE_SPAN[dof]
    y0, v0, sc = initial_state(prob, p_id.as_array(), span)
    pr_id = prob.predict(p_id.as_array(), y0, v0)
    b_arr = base.as_array() if prob.Ch is not None else base.as_array()[:4]
    y0b, v0b, _ = initial_state(prob, b_arr, span)
    pr_b = prob.predict(b_arr, y0b, v0b)
    err = (pr_id - prob.y)[sc]
    sd_y = float(np.std(prob.y[sc]))
    train = {"rms": float(np.sqrt(np.mean(err ** 2))),
             "nrmse": float(np.sqrt(np.mean(err ** 2)) / sd_y) if sd_y > 0 else float("nan"),
             "rms_fit": _rms_kept(sol["fun"][:N] / wts, unstable[groups][:N]),  # unweighted
             "iterations": sol["nit"],
             "rms_base": float(np.sqrt(np.mean(((pr_b - prob.y)[sc]) ** 2))),
             "n": int(np.count_nonzero(sc))}
    traces = {"train": (prob.t[sc], prob.y[sc], pr_id[sc], pr_b[sc], prob.w[sc])}
    if not math.isfinite(train["rms"]):
        warns.append("the identified model does not stay finite when replayed from the measured "
                     "states (too stiff for the replay's step, or unstable): do not use it")
    weighting_d = weighting_summary(flags, weights if weights is not None else
                                    (np.ones(prob.y.size) if flags is not None and weighting
                                     else None), prob.w, windows[0][0], windows[-1][1], W,
                                    (DIVE_DOFS[dof][1],))
    weighting_d["enabled"] = bool(weighting and flags is not None)
    return values, sigma, corr, start, windows, notes, warns, train, traces, weighting_d, split


def _pwm_notes(dc, t_start, t_end, flags=None) -> list:
    """Per motor: how many PWM samples sit at the thruster model's saturation (within 5 µs of
    where its thrust stops growing; 1100/1900 µs without a model)."""
    out = []
    lo, hi = ((flags.regions.full_rev, flags.regions.full_fwd) if flags is not None
              else (1100.0, 1900.0))
    for m, (t, p) in dc.pwm.items():
        sel = (t >= (t_start if t_start is not None else -np.inf)) & \
              (t <= (t_end if t_end is not None else np.inf)) & (p > 0)
        if not sel.any():
            continue
        sat = np.count_nonzero((p[sel] >= hi - 5.0) | (p[sel] <= lo + 5.0))
        if sat:
            out.append(f"motor {m}: {sat} of {np.count_nonzero(sel)} PWM samples at the "
                       f"{lo:.0f}/{hi:.0f} µs limits (saturated: thrust there is still known, "
                       "used as logged)")
    return out


def _flags(dc, veh, thruster_model):
    """Dead-band/saturation flags of the servo outputs with the thruster model that turned them
    into forces: a table's pwm_ columns always through the shipped T200 model
    (:func:`uuvid.io.dive_channels.read_dive_channels`), an ArduSub log's through
    ``thruster_model`` when given."""
    from uuvid.io.ardusub.thrust import default_t200, load_thrust_model

    if not dc.pwm:
        return None
    tm = (load_thrust_model(thruster_model) if thruster_model is not None
          and dc.format not in ("table", "csv", "parquet") else default_t200())
    return pwm_flags(dc, veh.B, tm)


def _inflow_setup(dc, veh, dofs, inflow, thruster_model, warnings):
    """``(rotor speeds | None, k_a starts)``: whether the inflow coefficient is fitted (see
    :func:`identify_dive`) and the rotor speeds it needs."""
    from uuvid.io.dive_channels import rotor_speeds
    from uuvid.simulate.dive_replay import _thrust_model
    from uuvid.thruster.inflow import t200_inflow

    carried = sorted({float(getattr(m, "inflow_coefficient", 0.0)) for m in
                      (veh.one_dof or {}).values() if getattr(m, "inflow_coefficient", 0.0)})
    on = inflow if inflow is not None else (getattr(veh, "inflow", "none") != "none"
                                            or bool(carried))
    starts = [0.0, t200_inflow().inflow_coefficient] + carried
    if not on:
        return None, starts
    speeds = rotor_speeds(dc, _thrust_model(dc, thruster_model))
    if speeds is None:
        msg = (f"{dc.name}: the inflow coefficient needs the servo outputs (the rotor speeds "
               "come from the PWM at the logged voltage) and the log has none")
        if inflow:
            raise DiveDataError(msg + "; pass --no-inflow or a log with SERVO_OUTPUT_RAW/RCOU or "
                                      "pwm_<j> columns")
        warnings.append(msg + ": identified with bollard thrust (inflow off)")
    elif getattr(veh, "inflow", "none") == "none":
        warnings.append("inflow: the drag identified is the hull's, without the thrust loss "
                        "(k_a goes to one_dof.<dof>.inflow_coefficient, which the dive replay "
                        f"flies); {veh.name} has inflow: none, so a 6-DOF simulation of a written "
                        "file loses no thrust to the advance speed until you add 'inflow: "
                        "four-quadrant' to it")
    return speeds, starts


def identify_dive(log, vehicle, dofs=("heave", "yaw"), *, t_start=None, t_end=None,
                  horizon=None, params=None, thruster_model=None, dive=None,
                  held_out_horizon=None, topics=None,
                  dead_band_weighting: bool = True, inflow: bool | None = None
                  ) -> DiveIdentification:
    """Identify per-DOF 1-DOF models from every armed sample of a dive (see the module doc).

    ``log``: ArduSub ``.tlog``/``.BIN``, CSV/Parquet with force columns, a DataFrame, or a ROS 1/2
    bag (``topics``: ``{role: "topic:field"}`` overriding mavros' topics,
    :mod:`uuvid.io.dive_rosbag`; ``params``: ArduSub parameters the log lacks);
    ``vehicle``: the base vehicle (preset, file or :class:`~uuvid.vehicle.definition.Vehicle`);
    ``dofs``: names among heave, yaw, surge, sway, ``horizontal`` (surge, sway and yaw jointly
    with the coupled model, :mod:`uuvid.identify.vehicle.dive_horizontal`; needs ``u_mps``,
    ``v_mps`` and ``yaw_rad``) or ``"all"`` (every one the log has channels for);
    ``t_start``/``t_end`` [s]: the part to identify from (the rest after ``t_end`` is scored as
    held out); ``horizon`` [s]: output-error window (default per DOF,
    :data:`uuvid.simulate.dive_replay.DEFAULT_HORIZON`).  ``dead_band_weighting``: down-weight
    residuals whose force comes from thrusters at the dead band's edge
    (:func:`~uuvid.identify.vehicle.output_error.dead_band_weights`; needs logged PWM).
    ``inflow``: fit the inflow coefficient ``k_a`` jointly (the thrust lost to the advance speed,
    ``F − k_a c(t) v``, see the module doc; needs logged PWM); ``None`` (default): on when the
    base vehicle has ``inflow`` other than ``none`` or a ``one_dof`` entry with an
    ``inflow_coefficient`` (off for the presets).  Starts: ``k_a`` = 0 and the T200 preset's
    (:func:`uuvid.thruster.inflow.t200_inflow`) with every start of the 4-parameter screen.
    The coupled horizontal model fits one ``k_a`` for its three DOF, with the loss
    ``k_a C(t) (u, v, r)`` coupling them (:func:`uuvid.vehicle.inflow.horizontal_inflow_matrix`).
    """
    from uuvid.core.checks import seconds_or_none, time_window
    from uuvid.simulate.dive_replay import base_vehicle

    t0 = time.perf_counter()
    seconds_or_none(t_start=t_start, t_end=t_end, horizon=horizon,
                    held_out_horizon=held_out_horizon)
    time_window(t_start, t_end, horizon, error=DiveDataError, named=True)
    time_window(horizon=held_out_horizon, error=DiveDataError)
    if dive is None:
        from uuvid.io.dive_channels import check_log_arg

        check_log_arg(log)
    veh = base_vehicle(vehicle, "identify_dive")
    dc = dive or read_dive_channels(log, veh, params=params, thruster_model=thruster_model,
                                    topics=topics, t_start=t_start, t_end=t_end)
    if not dc.armed:
        raise DiveDataError(f"{dc.name}: unarmed log: no armed sample, so the thrusters never "
                            "pushed and nothing can be identified; pass the log of a dive (armed "
                            "in the water)")
    if t_start is not None and t_end is not None and t_end <= t_start:
        raise DiveDataError(f"{arg_is('t_end', f'{t_end:g}')} s must be after "
                            f"{arg_is('t_start', f'{t_start:g}')} s")
    dc.check_span(t_start, t_end)
    inside = dc.pause_around(t_start, t_end)
    if inside is not None:  # no DOF has a sample there: one message, not one per DOF
        a, b = dc.t_range
        raise DiveDataError(f"{dc.name}: nothing to identify from: {inside}; choose "
                            f"{arg('t_start')}/{arg('t_end')} on one side of it or across it "
                            f"(the log runs from {a:.6g} to {b:.6g} s)")
    # "all": every DOF the log can inform; one that cannot be identified (too few windows, …)
    # is said in the warnings and the others are returned
    every = _is_all(dofs)
    dofs = _dof_list(dofs, dc)
    for dof in dofs:  # a horizon within the initial-state span scores nothing: an error
        if horizon is not None:
            check_state_span(dc, dof, float(horizon))
        if held_out_horizon is not None and t_end is not None:
            check_state_span(dc, dof, float(held_out_horizon), "held_out_horizon")
    ests = {}
    flags = _flags(dc, veh, thruster_model)
    warnings = list(dc.warnings) + _pwm_notes(dc, t_start, t_end, flags)
    if every and all_left_out(dc):
        warnings.append(all_left_out(dc))
    speeds, ka_starts = _inflow_setup(dc, veh, dofs, inflow, thruster_model, warnings)
    if "horizontal" in dofs and {"surge", "sway", "yaw"} & set(dofs):
        warnings.append("both the coupled horizontal model and 1-DOF "
                        + "/".join(d for d in ("surge", "sway", "yaw") if d in dofs)
                        + " were identified: a written vehicle gets the coupled model's values "
                          "(the 6-DOF simulator flies the coupled model)")
    def one(dof):
        if dof == "horizontal":
            from uuvid.identify.vehicle.dive_horizontal import fit_horizontal

            hgain = None
            if speeds is not None:
                from uuvid.io.dive_channels import horizontal_inflow_gain

                hgain = horizontal_inflow_gain(dc, veh, speeds=speeds)[:2]
            est = fit_horizontal(dc, veh, float(horizon or DEFAULT_HORIZON[dof]), t_start,
                                 t_end, flags=flags, weighting=dead_band_weighting,
                                 held_out_horizon=held_out_horizon, gain=hgain,
                                 inflow_start=ka_starts[0])
            if speeds is not None:
                est.notes.append(f"inflow: rotor speeds from {speeds[2]}")
            from uuvid.identify.vehicle.dive_horizontal import _DOF_KEYS

            for d, keys in _DOF_KEYS.items():
                low = below_rigid_body(veh, d, est.values[keys[0]], est.sigma[keys[0]])
                if low is not None:
                    est.warnings.insert(0, low)
            est.faults = output_faults(dc, _DOF_KEYS)
            return est
        dc.require(dof)
        H = float(horizon or DEFAULT_HORIZON[dof])
        base, base_src = params_from_vehicle(veh, dof)
        gain = None
        if speeds is not None:
            from uuvid.io.dive_channels import inflow_gain

            gain = inflow_gain(dc, veh, dof, speeds=speeds)[:2]
        elif base.inflow:
            base = OneDofParams(*base.as_array()[:4])
            base_src += " (its inflow coefficient not used: inflow off)"
        values, sigma, corr, start, windows, notes, warns, train, traces, wd, split = _fit_dof(
            dc, dof, H, t_start, t_end, base, flags, dead_band_weighting, gain, ka_starts,
            B=veh.B)
        if speeds is not None:
            notes.append(f"inflow: rotor speeds from {speeds[2]}; k_a started at "
                         + " and ".join(f"{k:.3g}" for k in ka_starts) + " N·s²/(rad·m)")
        held = None
        if t_end is not None:
            Hh = float(held_out_horizon or H)
            m_id, tr_id, nt = replay_windows(dc, dof, OneDofParams(*values.values()), Hh, t_end,
                                             gain=gain)
            m_b, tr_b, _ = replay_windows(dc, dof, base, Hh, t_end, gain=gain)
            if m_id is None:
                notes.append(f"no armed {Hh:g} s window after {arg_is('t_end', f'{t_end:g}')} s: no held-out "
                             "score" + (f" ({'; '.join(nt)})" if nt else ""))
            else:
                ratio = m_b["rms"] / m_id["rms"] if m_id["rms"] > 0 else math.nan
                held = {"identified": m_id, "base": m_b, "horizon_s": Hh,
                        "improvement": ratio if math.isfinite(ratio) else None}
                if not math.isfinite(m_id["rms"]):
                    warns.append("the identified model does not stay finite on the held-out part "
                                 "(too stiff for the replay's step, or unstable): do not use it")
                if tr_b[0].size == tr_id[0].size:
                    traces["held_out"] = (tr_id[0], tr_id[1], tr_id[2], tr_b[2], tr_id[3])
        low = below_rigid_body(veh, dof, values["mass"], sigma["mass"])
        if low is not None:
            warns.insert(0, low)
        if dof == "heave" and not any("at the surface" in n for n in notes):
            notes.append(f"heave windows touching the surface (depth < {SURFACE_M:g} m) are not "
                         "used")
        if dof == "yaw" and "u_mps" not in dc.channels:
            surged = _surge_in_yaw_windows(dc, veh, windows)
            if surged is not None:
                warns.append(surged)
        return DofEstimate(dof, values, sigma, corr.tolist(), start, base.to_dict(),
                           base_src, len(windows), H, train, held, warns, notes, traces, wd,
                           split, output_faults(dc, [dof]))
    failed = []
    for dof in dofs:
        try:
            ests[dof] = one(dof)
        except DiveDataError as e:
            if not every:  # DOFs the user named: each must be identified
                raise _with_reader_warnings(e, [dof], dc) from None
            failed.append((dof, e))
            warnings.append(f"{dof} not identified: {e}")
    if not ests:  # (the reader's warnings are not printed with an error: said in it)
        if len(failed) == 1:
            raise _with_reader_warnings(failed[0][1], [failed[0][0]], dc) from None
        raise _with_reader_warnings(DiveDataError(
            (f"{dc.name}: " if dc.name else "") + "no DOF could be identified: " + "; ".join(
                f"{dof}: {str(e).removeprefix(dc.name + ': ')}" for dof, e in failed)),
            [d for d, _ in failed], dc) from None
    measured = ("depth_m", "yaw_rad", "u_mps", "v_mps", "roll_rad", "pitch_rad")
    used = {c: str(dc.sources.get(c)) for c in measured
            if c in dc.channels and dc.sources.get(c)}
    return DiveIdentification(dc.name, veh.name, vehicle if not hasattr(vehicle, "B") else
                              (veh.path or veh.name), ests, t_start, t_end,
                              time.perf_counter() - t0, warnings, used)
