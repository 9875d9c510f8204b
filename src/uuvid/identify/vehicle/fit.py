"""Vehicle drag, installation coefficients and inertia from on-board sensors (Caccia et al. 2000).

The uncoupled 1-DOF model (eq. 3) ``m ξ̇ = −k ξ − k_q ξ|ξ| + η(μ) φ + ν`` is identified in two steps.

**Drag and thruster installation coefficients** (§III-A, eqs. 7–12).  At steady state under a
constant nominal force φ applied in thrust-mapping mode μ::

    0 = −k ξ − k_q ξ|ξ| + η_μ φ + w

(``w`` is the mean of the disturbance ν, estimated).  The model is homogeneous in η, so at least
one mode must be known to work in open water (``η = 1`` fixed); its φ goes to the left side::

    open water:  φ   = k ξ + k_q ξ|ξ| − w
    mode μ:      0   = k ξ + k_q ξ|ξ| − w − η_μ φ

which is ``y = H θ`` with ``θ = [k, k_q, w, η_1 … η_M]`` solved by ordinary LS
(:func:`uuvid.identify.fit.linear_lsq`): ``σ_θ = sqrt(diag((HᵀH)⁻¹) σ²)``,
``σ² = |y − Hθ̂|²/(dim y − dim θ)``; ``cov_type`` ``"HC0"``/``"HC3"``/``"HAC"`` gives a
heteroscedasticity(/autocorrelation)-robust covariance instead.  Percentile error ``100 σ/|θ|``;
a drag term above **51.02 %** is insignificant at 95 % and is dropped by the **automatic model
reduction** (quadratic term first, as the paper's low-speed yaw model), and the model refitted —
the result says so (``reduced_to``, ``messages``) and keeps the full fit.

*Heave with ballast* (eq. 20): experiment i carries ``n_i`` known added weights, so
``m ẇ = −k w − k_q w|w| + η φ + W + n_i ΔW``: pass ``disturbance="W"`` and ``ballast="dW"``
with each point's ``ballast = n_i`` — W (net weight of experiment 0) and ΔW (per added weight)
become parameters.

*Errors in variables*: the steady velocities are estimated (σ_v < 3 % with ROMEO's sonar) and
enter ``H``; like the paper we **ignore that uncertainty** (ordinary LS, no total-LS or
errors-in-variables correction) — it biases the drag slightly towards zero when σ_v is not small
compared with the spread of the velocities.  The result carries this note.

**Inertia** (§III-B, eqs. 15–19).  With drag known, integrate eq. 3 (no acceleration needed)::

    m ξ(t) − m ξ₀ − b t = Φ(t) − k x(t) − k_q I(t),   Φ = ∫ η φ dt,  I = ∫ ξ|ξ| dt

(``x`` the position, ``ξ`` the Savitzky–Golay velocity, ``b`` the bias of the disturbance mean and
the numerical integrations) and regress ``y = Φ − k x − k_q I`` on ``H = [ξ, −1, −t]``,
``θ = [m, m ξ₀ + k x₀, b]`` (:func:`fit_inertia`).

**Validation**: :func:`simulate_one_dof` integrates the identified model under a logged force,
:func:`validate_one_dof` reports the NRMSE of the velocity; :func:`phase_lag` measures the lag of
the response behind a sine input and :func:`predicted_phase_lag` gives the first-order
``atan(ω m/k_L)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from uuvid.core.result import Result, jsonable
from uuvid.identify.fit import SIGNIFICANCE_PERCENT, Fit, Parameter, linear_lsq
from uuvid.identify.vehicle.segments import (
    SegmentVelocity,
    clean_series,
    find_segments,
    savgol_velocity,
    segment_velocity,
)
from uuvid.vehicle.model import OneDofModel

__all__ = [
    "DragFit",
    "InertiaFit",
    "SteadyPoint",
    "eta_label",
    "fit_drag",
    "fit_inertia",
    "phase_lag",
    "predicted_phase_lag",
    "simulate_one_dof",
    "steady_points_from_log",
    "validate_one_dof",
]

EIV_NOTE = ("velocity uncertainty (errors in variables) ignored, as in Caccia et al. (2000): the "
            "estimated steady velocities enter H as if exact")


# ---------------------------------------------------------------------------------------------
# steady points
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SteadyPoint:
    """One steady segment: velocity ξ, nominal force φ and the installation coefficient it sees.

    ``eta``: ``None`` for an open-water mode (η = 1 fixed) or the name of the coefficient to
    estimate (e.g. ``"eta_hull"``); ``ballast``: known number of added weights (heave, eq. 20).
    """

    velocity: float
    force: float
    eta: str | None = None
    velocity_stderr: float = math.nan
    ballast: float = 0.0
    mode: str = ""
    run: int | str = 0
    t0: float = math.nan
    t1: float = math.nan

    def as_dict(self) -> dict:
        return {"velocity": self.velocity, "velocity_stderr": self.velocity_stderr,
                "force": self.force, "eta": self.eta, "ballast": self.ballast, "mode": self.mode,
                "run": self.run, "t0": self.t0, "t1": self.t1}


def eta_label(eta_map: Mapping[str, str | None], mode: str | None, force: float) -> str | None:
    """The installation coefficient a segment sees: ``eta_map`` keys are ``"mode"`` (both signs
    of φ), ``"mode+"`` or ``"mode-"``; values a coefficient name or ``None`` (open water, η = 1).

    Raises ``KeyError`` for a mode/sign the map does not cover.
    """
    m = "" if mode is None else str(mode)
    key = m + ("+" if force >= 0 else "-")
    if key in eta_map:
        return eta_map[key]
    if m in eta_map:
        return eta_map[m]
    raise KeyError(f"eta_map has no entry for mode {m!r} with {'positive' if force >= 0 else 'negative'}"
                   f" force (keys: {sorted(eta_map)})")


def steady_points_from_log(t_cmd, command, t_pos, position, *, eta_map: Mapping[str, str | None],
                           min_duration: float, settle: float, mode=None, tol: float = 0.0,
                           rel_tol: float = 0.02, angle: bool = False, angle_unit: str = "rad",
                           threshold: float = 3.5, ballast: float = 0.0, run: int | str = 0,
                           velocity_sign: int = 0) -> tuple[list[SteadyPoint], list[SegmentVelocity]]:
    """Segments of one log → :class:`SteadyPoint` list (and the per-segment velocity fits).

    ``velocity_sign`` = +1/−1 keeps only segments whose estimated velocity has that sign (the
    paper fits forward and backward surge separately); 0 keeps all.
    """
    segs = find_segments(t_cmd, command, min_duration=min_duration, settle=settle, tol=tol,
                         rel_tol=rel_tol, mode=mode)
    pts, vels = [], []
    for s in segs:
        sv = segment_velocity(t_pos, position, s.t0, s.t1, angle=angle, angle_unit=angle_unit,
                              threshold=threshold)
        if velocity_sign and np.sign(sv.velocity) != velocity_sign:
            continue
        pts.append(SteadyPoint(sv.velocity, s.level, eta_label(eta_map, s.mode, s.level),
                               sv.stderr, ballast, s.mode or "", run, s.t0, s.t1))
        vels.append(sv)
    return pts, vels


# ---------------------------------------------------------------------------------------------
# drag + installation coefficients
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DragFit(Result):
    """Drag/installation-coefficient fit with its model reduction history.

    ``fit`` is the final :class:`~uuvid.identify.fit.Fit` (after reduction), ``full`` the fit with
    every term; ``reduced_to`` ``"linear"`` (quadratic dropped), ``"quadratic"`` (linear dropped)
    or ``None``; ``quadratic_significant``/``linear_significant`` refer to the full fit.
    """

    fit: Fit
    full: Fit
    points: tuple[SteadyPoint, ...]
    eta_names: tuple[str, ...]
    reduced_to: str | None = None
    dropped: tuple[str, ...] = ()
    quadratic_significant: bool | None = None
    linear_significant: bool | None = None
    messages: tuple[str, ...] = ()
    notes: tuple[str, ...] = (EIV_NOTE,)
    dof: str = ""
    disturbance: str | None = "w"
    ballast: str | None = None

    def _value(self, name: str) -> float:
        return self.fit[name].value if name in self.fit else 0.0

    @property
    def k(self) -> float:
        return self._value("k")

    @property
    def k_q(self) -> float:
        return self._value("k_q")

    @property
    def w(self) -> float:
        return self._value(self.disturbance) if self.disturbance else 0.0

    def eta(self, name: str | None) -> float:
        return 1.0 if name is None else self.fit[name].value

    def drag_covariance(self) -> np.ndarray:
        """2×2 covariance of (k, k_q) (zeros for a dropped term) — for ``fit_inertia(drag_cov=)``."""
        names = self.fit.names
        idx = [names.index(n) if n in names else None for n in ("k", "k_q")]
        C = np.zeros((2, 2))
        for a, i in enumerate(idx):
            for b, j in enumerate(idx):
                if i is not None and j is not None:
                    C[a, b] = self.fit.covariance[i, j]
        return C

    def drag(self, xi):
        """``k ξ + k_q ξ|ξ|``."""
        xi = np.asarray(xi, dtype=float)
        return self.k * xi + self.k_q * xi * np.abs(xi)

    def steady_force(self, xi, eta: str | None = None, ballast: float = 0.0):
        """Nominal φ that holds ξ steady: ``(k ξ + k_q ξ|ξ| − w − n ΔW)/η``."""
        dW = self._value(self.ballast) if self.ballast else 0.0
        return (self.drag(xi) - self.w - ballast * dW) / self.eta(eta)

    def steady_speed(self, force, eta: str | None = None, ballast: float = 0.0):
        """ξ at steady state under nominal ``force`` in a mode with coefficient ``eta``."""
        from uuvid.vehicle.model import steady_speed

        dW = self._value(self.ballast) if self.ballast else 0.0
        F = self.eta(eta) * np.asarray(force, dtype=float) + self.w + ballast * dW
        if self.k < 0 or self.k_q < 0:
            raise ValueError("negative drag estimate: no steady speed")
        return steady_speed(self.k, self.k_q, F)

    def one_dof_model(self, mass: float, eta_pos: str | None = None, eta_neg: str | None = None,
                      ballast: float = 0.0) -> OneDofModel:
        """The identified :class:`~uuvid.vehicle.model.OneDofModel` for a mode whose positive and
        negative forces see ``eta_pos``/``eta_neg`` (names; ``None`` = open water)."""
        dW = self._value(self.ballast) if self.ballast else 0.0
        return OneDofModel(mass, max(self.k, 0.0), max(self.k_q, 0.0), self.eta(eta_pos),
                           self.eta(eta_neg), self.w + ballast * dW, self.dof)

    def table(self) -> list[dict]:
        """One row per parameter: estimate, σ, percentile error, significant (paper's tables)."""
        return [p.as_dict() for p in self.fit.parameters]

    def as_dict(self) -> dict:
        return {"dof": self.dof, "parameters": {p.name: p.as_dict() for p in self.fit.parameters},
                "full_parameters": {p.name: p.as_dict() for p in self.full.parameters},
                "reduced_to": self.reduced_to, "dropped": list(self.dropped),
                "quadratic_significant": self.quadratic_significant,
                "linear_significant": self.linear_significant, "messages": list(self.messages),
                "notes": list(self.notes), "n_points": len(self.points),
                "sigma2": self.fit.sigma2, "cov_type": self.fit.extra.get("cov_type"),
                "points": [p.as_dict() for p in self.points]}

    report_title = "Steady drag fit"

    def to_dict(self) -> dict:
        return jsonable(self.as_dict())

    def plot(self):
        """LS steady velocity against nominal force per mode, with the fitted curves."""
        from uuvid.core.plots import new_figure
        from uuvid.identify.vehicle.logs import ANGULAR
        from uuvid.identify.vehicle.reports import _plot_steady

        fig, ax = new_figure(1, 1, figsize=(8, 5))
        _plot_steady(ax, self, self.points, self.dof in ANGULAR, False,
                     f"{self.dof or 'steady'} drag: velocity vs nominal force")
        return fig

    def summary(self) -> str:
        lines = [self.fit.summary()]
        if self.dropped:
            lines.append("[[Model reduction]]")
            lines.extend(f"    {m}" for m in self.messages)
        lines.append("[[Notes]]")
        lines.extend(f"    {n}" for n in self.notes)
        return "\n".join(lines)


_UNITS = {"surge": ("N·s/m", "N·s²/m²", "N"), "sway": ("N·s/m", "N·s²/m²", "N"),
          "heave": ("N·s/m", "N·s²/m²", "N"), "roll": ("N·m·s/rad", "N·m·s²/rad²", "N·m"),
          "pitch": ("N·m·s/rad", "N·m·s²/rad²", "N·m"), "yaw": ("N·m·s/rad", "N·m·s²/rad²", "N·m")}


def _build(points: Sequence[SteadyPoint], eta_names: Sequence[str], terms: Sequence[str],
           disturbance: str | None, ballast: str | None):
    n = len(points)
    xi = np.array([p.velocity for p in points], dtype=float)
    phi = np.array([p.force for p in points], dtype=float)
    cols, names = [], []
    if "k" in terms:
        cols.append(xi)
        names.append("k")
    if "k_q" in terms:
        cols.append(xi * np.abs(xi))
        names.append("k_q")
    if disturbance:
        cols.append(-np.ones(n))
        names.append(disturbance)
    if ballast:
        cols.append(-np.array([p.ballast for p in points], dtype=float))
        names.append(ballast)
    for e in eta_names:
        cols.append(np.where([p.eta == e for p in points], -phi, 0.0))
        names.append(e)
    y = np.where([p.eta is None for p in points], phi, 0.0)
    return np.column_stack(cols), y, names


def fit_drag(points: Sequence[SteadyPoint], *, linear: bool = True, quadratic: bool = True,
             disturbance: str | None = "w", ballast: str | None = None,
             cov_type: str = "classical", hac_lags: int | None = None, reduce: bool = True,
             reduce_linear: bool = False, dof: str = "", model: str | None = None) -> DragFit:
    """Stack the steady points into ``y = Hθ`` and solve by LS (see the module docstring).

    ``disturbance``: name of the mean-disturbance parameter (``None`` to leave it out; heave:
    ``"W"``); ``ballast``: name of the per-added-weight parameter (eq. 20) or ``None``;
    ``reduce``: drop an insignificant quadratic term (percentile error > 51.02 %) and refit;
    ``reduce_linear``: likewise drop an insignificant linear term when the quadratic stays.
    """
    pts = tuple(points)
    if not pts:
        raise ValueError("no steady points")
    if not (linear or quadratic):
        raise ValueError("need the linear or the quadratic drag term")
    for i, p in enumerate(pts):
        if not (math.isfinite(p.velocity) and math.isfinite(p.force)):
            raise ValueError(f"steady point {i} has a non-finite velocity or force")
        if ballast and not math.isfinite(p.ballast):
            raise ValueError(f"steady point {i} has a non-finite ballast count")
    if not any(p.eta is None for p in pts):
        raise ValueError("no open-water point (eta=None): the model is homogeneous in η, so at "
                         "least one mapping mode must have η = 1 fixed (Caccia et al. 2000, §II-A)")
    eta_names = tuple(dict.fromkeys(p.eta for p in pts if p.eta is not None))
    for e in eta_names:
        if all(p.force == 0 for p in pts if p.eta == e):
            raise ValueError(f"installation coefficient {e!r} only has zero-force points")
    if ballast and len({p.ballast for p in pts}) < 2:
        raise ValueError("ballast parameter needs points with at least two ballast counts")
    u = _UNITS.get(dof, ("", "", ""))
    unit_of = {"k": u[0], "k_q": u[1], disturbance: u[2], ballast: u[2]}

    def solve(terms):
        H, y, names = _build(pts, eta_names, terms, disturbance, ballast)
        if len(pts) <= H.shape[1]:
            raise ValueError(f"{len(pts)} steady points for {H.shape[1]} parameters: need more "
                             "points than parameters for σ")
        return linear_lsq(H, y, names, model=model or f"steady drag {dof}".strip(),
                          units=[unit_of.get(n, "") for n in names], cov_type=cov_type,
                          hac_lags=hac_lags, emit_warnings=False)

    terms = [t for t, on in (("k", linear), ("k_q", quadratic)) if on]
    full = solve(terms)
    final = full
    dropped: list[str] = []
    msgs: list[str] = []
    q_sig = full["k_q"].significant if "k_q" in full else None
    l_sig = full["k"].significant if "k" in full else None
    if reduce and len(terms) == 2:
        if not q_sig:
            p = full["k_q"]
            msgs.append(f"quadratic drag k_q = {p.value:.4g} ± {p.stderr:.3g} has percentile error "
                        f"{p.percentile_error:.1f} % > {SIGNIFICANCE_PERCENT:.2f} %: not significant "
                        "at 95 % → dropped, linear model refitted")
            dropped.append("k_q")
            final = solve(["k"])
        elif reduce_linear and not l_sig:
            p = full["k"]
            msgs.append(f"linear drag k = {p.value:.4g} ± {p.stderr:.3g} has percentile error "
                        f"{p.percentile_error:.1f} % > {SIGNIFICANCE_PERCENT:.2f} %: not significant "
                        "at 95 % → dropped, quadratic model refitted")
            dropped.append("k")
            final = solve(["k_q"])
    reduced = None
    if "k_q" in dropped:
        reduced = "linear"
    elif "k" in dropped:
        reduced = "quadratic"
    for p in final.parameters:
        if not p.significant and p.name not in ("k", "k_q"):
            msgs.append(f"{p.name} = {p.value:.4g} ± {p.stderr:.3g} is not significant "
                        f"({p.percentile_error:.1f} % > {SIGNIFICANCE_PERCENT:.2f} %); kept")
    msgs.extend(w for w in final.warnings if "not significantly" not in w)
    return DragFit(final, full, pts, eta_names, reduced, tuple(dropped), q_sig, l_sig,
                   tuple(msgs), (EIV_NOTE,), dof, disturbance, ballast)


# ---------------------------------------------------------------------------------------------
# inertia: the integrated regression (eqs. 15–19)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class InertiaFit(Result):
    """``θ = [m, m ξ₀ + k x₀, b]`` of the integrated regression, and the rows it used:
    ``Phi`` = ∫ηφ dt, ``Iq`` = ∫ξ|ξ| dt, ``y`` = Φ − k x − k_q I; ``velocity_raw``/``t_raw`` the
    Savitzky–Golay velocity of the whole (cleaned) record."""

    fit: Fit
    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    Phi: np.ndarray
    Iq: np.ndarray
    y: np.ndarray
    k: float
    k_q: float
    window: int
    order: int
    cleaning: str = ""
    notes: tuple[str, ...] = ()
    velocity_raw: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    t_raw: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def mass(self) -> float:
        return self.fit["m"].value

    @property
    def mass_stderr(self) -> float:
        return self.fit["m"].stderr

    def as_dict(self) -> dict:
        return {"parameters": {p.name: p.as_dict() for p in self.fit.parameters},
                "k": self.k, "k_q": self.k_q, "window": self.window, "order": self.order,
                "n_samples": int(self.t.size), "cleaning": self.cleaning,
                "cov_type": self.fit.extra.get("cov_type"), "notes": list(self.notes)}

    report_title = "Inertia fit (integrated regression)"

    def summary(self) -> str:
        return "\n".join([self.fit.summary(), f"k = {self.k:.5g}, k_q = {self.k_q:.5g} (given), "
                          f"Savitzky–Golay window {self.window}, order {self.order}"]
                         + ([f"cleaning: {self.cleaning}"] if self.cleaning else [])
                         + [f"note: {n}" for n in self.notes])

    def to_dict(self) -> dict:
        return jsonable(self.as_dict())

    def plot(self):
        """The regression target y = Φ − k x − k_q I and its fit, and the velocity used."""
        from uuvid.core.plots import new_figure

        fig, ax = new_figure(2, 1, figsize=(10, 5.5), sharex=True)
        ax[0].plot(self.t, self.y, ".", ms=2, color="0.5", label="y = Φ − k x − k_q I")
        if np.size(self.fit.residuals) == self.y.size:
            ax[0].plot(self.t, self.y - self.fit.residuals, "-", color="C1", label="fitted")
        ax[0].legend(fontsize=8)
        angular = self.fit["m"].unit == "kg·m²"
        ax[0].set_ylabel("y [N·m·s]" if angular else "y [N·s]")
        ax[0].set_title(f"m = {self.mass:.4g} ± {self.mass_stderr:.2g} {self.fit['m'].unit}",
                        fontsize=10)
        if self.t_raw.size:
            ax[1].plot(self.t_raw, self.velocity_raw, "--", color="0.6", lw=0.8,
                       label="Savitzky–Golay, whole record")
        ax[1].plot(self.t, self.velocity, ".", ms=2, label="rows used")
        ax[1].set_ylabel("velocity [rad/s]" if angular else "velocity [m/s]")
        ax[1].set_xlabel("t [s]")
        ax[1].legend(fontsize=8)
        return fig


def _eta_of(eta) -> tuple[float, float]:
    if np.ndim(eta) == 0:
        return float(eta), float(eta)
    e = tuple(float(v) for v in eta)
    if len(e) != 2:
        raise ValueError("eta must be a number or (eta_pos, eta_neg)")
    return e


def _integrate_force(t_phi: np.ndarray, phi: np.ndarray, eta, t: np.ndarray, hold: str):
    ep, en = _eta_of(eta)
    f = np.where(phi >= 0, ep, en) * phi
    if hold == "zoh":
        cum = np.concatenate([[0.0], np.cumsum(f[:-1] * np.diff(t_phi))])
        # ∫ up to t: cum at the last command sample ≤ t plus its value × the remainder
        j = np.clip(np.searchsorted(t_phi, t, side="right") - 1, 0, t_phi.size - 1)
        return cum[j] + f[j] * (t - t_phi[j])
    if hold == "linear":
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t_phi))])
        return np.interp(t, t_phi, cum)
    raise ValueError(f"hold must be 'zoh' or 'linear', got {hold!r}")


def fit_inertia(t, x, phi, *, k: float, k_q: float = 0.0, eta=1.0, t_phi=None,
                hold: str = "zoh", order: int = 4, window: int = 21, edge: str = "interp",
                trim: int | None = None, t_start: float | None = None, t_end: float | None = None,
                clean: bool = True, clean_threshold: float = 4.0, angle: bool = False,
                angle_unit: str = "rad", velocity=None, cov_type: str = "classical",
                hac_lags: int | None = None, drag_cov=None,
                velocity_noise_correction: bool = False,
                position_noise: float | None = None, max_filled: int = 2) -> InertiaFit:
    """Inertia from a (sine) experiment by the integrated regression of eqs. 15–19.

    ``t``, ``x``: position (or heading) samples — may hold NaN (missing) and outliers when
    ``clean`` (then :func:`~uuvid.identify.vehicle.segments.clean_series` puts them on a uniform grid and
    fills them, reporting what it rejected); ``phi``: the nominal force, on ``t`` or on its own
    time base ``t_phi`` (``hold``: ``"zoh"`` for a sampled command, ``"linear"``); ``eta``: the
    mode's installation coefficient (number or ``(η₊, η₋)``; the paper uses an open-water mode,
    η = 1); ``k``, ``k_q``: the drag identified before.  The velocity is the Savitzky–Golay
    derivative (``order``, ``window``, ``edge``) unless ``velocity`` is given; ``trim`` samples
    (default ``window//2``) are dropped at both ends of ``[t_start, t_end]`` where the filter is
    one-sided.  Rows whose filter window holds more than ``max_filled`` filled samples (missing or
    outliers, interpolated by the cleaning) are left out of the regression; the integrals still run
    through them (the paper's Fig. 14 likewise uses a subset).  ``cov_type`` as in
    :func:`~uuvid.identify.fit.linear_lsq` — the residuals of an integrated regression are
    autocorrelated, so ``"HAC"`` (with a bandwidth of about a quarter of the sine period) gives an
    honest σ where the classical one is several times too small.

    ``drag_cov``: the 2×2 covariance of (k, k_q) from the drag fit (or a scalar variance of k
    alone).  θ̂ is linear in the drag, ``∂θ̂/∂(k, k_q) = −(HᵀH)⁻¹Hᵀ[x, I]``, so the drag
    uncertainty is propagated exactly: ``cov θ̂ = cov_LS + J cov_drag Jᵀ`` (the paper's remark
    ``δτ_c/τ_c = δk_L/k_L``: an error in the drag moves the inertia).  The returned fit carries the
    total covariance; ``extra`` holds ``sigma_ls`` and ``sigma_drag`` of each parameter.

    ``velocity_noise_correction``: the Savitzky–Golay velocity in ``H`` carries the position noise
    (variance ``σ_x² Σ c_j²`` for the derivative coefficients ``c``), which biases m towards zero
    (errors in variables; −4 % for ROMEO's 2 cm, 3.33 Hz sonar and the 21-point filter).  With
    the correction that known variance is removed from ``HᵀH``:
    ``θ̂ = (HᵀH − N σ_ξ² e₁e₁ᵀ)⁻¹ Hᵀy``; ``σ_x`` is ``position_noise`` or estimated robustly from
    the second differences of the cleaned record (``1.4826·MAD(Δ²x)/√6``).  The paper does not
    correct; the default is off.  ``extra["m_uncorrected"]`` keeps the plain LS value.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if t.ndim != 1 or t.shape != x.shape:
        raise ValueError("t and x must be 1-D arrays of the same length")
    if not (math.isfinite(k) and math.isfinite(k_q)):
        raise ValueError("k and k_q must be finite")
    phi = np.asarray(phi, dtype=float)
    tp = t if t_phi is None else np.asarray(t_phi, dtype=float)
    if phi.shape != tp.shape:
        raise ValueError(f"phi has shape {phi.shape}; its time base has {tp.shape}")
    if not np.all(np.isfinite(phi)):
        raise ValueError("phi has non-finite values")
    note = ""
    if clean:
        cs = clean_series(t, x, threshold=clean_threshold, angle=angle, angle_unit=angle_unit,
                          window=max(window, 7) if window % 2 else window + 1)
        tg, xg = cs.t, cs.x
        note = cs.summary()
    else:
        if not np.all(np.isfinite(x)):
            raise ValueError("x has non-finite values; use clean=True")
        tg, xg = t, x.copy()
        if angle:
            from uuvid.identify.vehicle.segments import robust_unwrap

            xg = robust_unwrap(tg, xg, angle_unit)
    if velocity is None:
        v = savgol_velocity(tg, xg, order=order, window=window, edge=edge)
    else:
        v = np.asarray(velocity, dtype=float)
        if v.shape != tg.shape:
            raise ValueError("velocity must be given on the (cleaned) position grid")
    lo = tg[0] if t_start is None else t_start
    hi = tg[-1] if t_end is None else t_end
    sel = np.flatnonzero((tg >= lo) & (tg <= hi))
    tr = window // 2 if trim is None else int(trim)
    if tr:
        sel = sel[tr:-tr] if sel.size > 2 * tr else sel[:0]
    if sel.size < 10:
        raise ValueError(f"only {sel.size} samples left for the inertia regression")
    ts, xs, vs = tg[sel], xg[sel], v[sel]
    # rows whose filter window holds more than max_filled filled (missing/outlier) samples are
    # left out of the regression; the integrals run through them (over a filled stretch the
    # Savitzky–Golay velocity of the filled position still integrates to its displacement)
    keep = np.ones(sel.size, dtype=bool)
    if clean and velocity is None:
        from numpy.lib.stride_tricks import sliding_window_view

        h = window // 2
        bad = np.concatenate([np.zeros(h), (~cs.good).astype(float), np.zeros(h)])
        nfill = sliding_window_view(bad, 2 * h + 1).sum(axis=1)[sel]
        keep = nfill <= max_filled
        if keep.sum() < 10:
            raise ValueError("fewer than 10 regression rows have a filter window free of filled "
                             "samples; raise `max_filled=`")
    n_excluded = int((~keep).sum())
    Phi = _integrate_force(tp, phi, eta, ts, hold)
    Phi = Phi - Phi[0]
    q = vs * np.abs(vs)
    Iq = np.concatenate([[0.0], np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(ts))])
    tt = ts - ts[0]
    xr = xs - xs[0]
    y = Phi - k * xr - k_q * Iq
    ts_r, vs_r, y_r, tt_r, xr_r, Iq_r = ts[keep], vs[keep], y[keep], tt[keep], xr[keep], Iq[keep]
    H = np.column_stack([vs_r, -np.ones(ts_r.size), -tt_r])
    # y = m·v − c − b·t in N·s (N·m·s about an axis): m in kg (kg·m²), c in N·s, b in N
    units = ["kg·m²", "N·m·s", "N·m"] if angle else ["kg", "N·s", "N"]
    f = linear_lsq(H, y_r, ["m", "c", "b"], model="inertia (integrated regression, eqs. 15–19)",
                   units=units, cov_type=cov_type, hac_lags=hac_lags, emit_warnings=False,
                   extra={"k": k, "k_q": k_q, "rows_excluded": n_excluded})
    notes = ["classical σ assumes white residuals; the integrated regression's residuals are "
             "autocorrelated — compare cov_type='HAC'"] if cov_type == "classical" else []
    if velocity_noise_correction:
        if velocity is not None:
            raise ValueError("velocity_noise_correction applies to the Savitzky–Golay velocity "
                             "computed here, not to a given velocity")
        from scipy.signal import savgol_coeffs

        dtg = float(np.mean(np.diff(tg)))
        if position_noise is None:
            d2 = np.diff(xg, 2)
            if clean:
                ok = cs.good
                d2 = d2[ok[:-2] & ok[1:-1] & ok[2:]]
            sx = float(1.482602218505602 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6))
        else:
            sx = float(position_noise)
        c = savgol_coeffs(window, order, deriv=1, delta=dtg, use="dot")
        var_v = sx * sx * float(c @ c)
        A = H.T @ H
        A[0, 0] -= ts_r.size * var_v
        theta = np.linalg.solve(A, H.T @ y_r)
        params = tuple(Parameter(p.name, float(theta[i]), p.stderr, p.unit)
                       for i, p in enumerate(f.parameters))
        f = replace(f, parameters=params, residuals=y_r - H @ theta,
                    extra={**f.extra, "m_uncorrected": f["m"].value, "position_noise": sx,
                           "velocity_noise_sigma": math.sqrt(var_v)})
        notes.append(f"errors-in-variables correction: S–G velocity noise σ = {math.sqrt(var_v):.3g} "
                     f"(position noise {sx:.3g}) removed from HᵀH; m uncorrected = "
                     f"{f.extra['m_uncorrected']:.5g}; σ from the uncorrected LS")
    if drag_cov is not None:
        D = np.atleast_2d(np.asarray(drag_cov, dtype=float))
        if D.shape == (1, 1):
            D = np.array([[D[0, 0], 0.0], [0.0, 0.0]])
        if D.shape == (2, 2) and np.any(np.isinf(np.diag(D))):
            raise ValueError("drag_cov: the drag fit does not determine "
                             + " and ".join(n for n, v in zip(("k", "k_q"), np.diag(D))
                                            if np.isinf(v))
                             + " (σ = ∞: its speeds do not separate linear and quadratic drag); "
                             "fit the drag from runs at several speeds, or fix one term")
        if D.shape != (2, 2) or not np.all(np.isfinite(D)):
            raise ValueError("drag_cov must be the 2×2 covariance of (k, k_q) or a variance of k")
        J = -np.linalg.pinv(H) @ np.column_stack([xr_r, Iq_r])
        Cd = J @ D @ J.T
        C = f.covariance + Cd
        sd_ls = {p.name: p.stderr for p in f.parameters}
        params = tuple(Parameter(p.name, p.value, float(math.sqrt(max(C[i, i], 0.0))), p.unit)
                       for i, p in enumerate(f.parameters))
        f = replace(f, parameters=params, covariance=C,
                    extra={**f.extra, "sigma_ls": sd_ls,
                           "sigma_drag": {p.name: float(math.sqrt(max(Cd[i, i], 0.0)))
                                          for i, p in enumerate(f.parameters)},
                           "dtheta_dk": J[:, 0].tolist(), "dtheta_dkq": J[:, 1].tolist()})
        notes.append("drag uncertainty propagated exactly into σ (θ̂ is linear in k, k_q)")
    else:
        notes.append("drag taken as known: its uncertainty is not in σ (give drag_cov)")
    notes = tuple(notes)
    if n_excluded:
        notes = notes + (f"{n_excluded} rows whose {window}-point window holds more than "
                         f"{max_filled} filled samples left out of the regression",)
    return InertiaFit(f, ts_r, xs[keep], vs_r, Phi[keep], Iq_r, y_r, float(k), float(k_q),
                      int(window), int(order), note, notes, v, tg)


# ---------------------------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------------------------
def simulate_one_dof(model: OneDofModel, t, phi, xi0: float = 0.0, *, t_phi=None,
                     hold: str = "zoh", substeps: int = 4) -> np.ndarray:
    """Integrate eq. 3 (RK4, ``substeps`` per sample interval) under the force ``phi``.

    ``phi`` is given on ``t`` (or on ``t_phi``): zero-order hold (``"zoh"``) or linear
    interpolation between its samples.  Returns ξ at the times ``t``.
    """
    t = np.asarray(t, dtype=float)
    phi = np.asarray(phi, dtype=float)
    tp = t if t_phi is None else np.asarray(t_phi, dtype=float)
    if phi.shape != tp.shape:
        raise ValueError("phi and its time base must have the same length")
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise ValueError("t must be strictly increasing with at least 2 samples")
    if hold not in ("zoh", "linear"):
        raise ValueError(f"hold must be 'zoh' or 'linear', got {hold!r}")

    def force(tq):
        if hold == "zoh":
            j = np.clip(np.searchsorted(tp, tq, side="right") - 1, 0, tp.size - 1)
            return phi[j]
        return np.interp(tq, tp, phi)

    substeps = max(int(substeps), 1)
    # force at every sub-step start, mid-point and end, evaluated at once
    frac = np.arange(2 * substeps + 1) / (2.0 * substeps)
    tq = t[:-1, None] + frac[None, :] * np.diff(t)[:, None]
    if hold == "zoh":  # hold the value at each sub-step's start through that sub-step
        F = force(tq[:, 0::2][:, :-1])
        F = np.repeat(F, 2, axis=1)
        F = np.concatenate([F, F[:, -1:]], axis=1)
    else:
        F = force(tq)
    m, k, kq, ep, en, nu = (float(v) for v in model.to_array())

    def f(xi, u):
        eta = ep if u >= 0 else en
        return (-k * xi - kq * xi * abs(xi) + eta * u + nu) / m

    out = np.empty(t.size)
    xi = float(xi0)
    out[0] = xi
    Fl = F.tolist()
    tl = t.tolist()
    for i in range(t.size - 1):
        h = (tl[i + 1] - tl[i]) / substeps
        Fi = Fl[i]
        for s in range(substeps):
            u0, um, u1 = Fi[2 * s], Fi[2 * s + 1], Fi[2 * s + 2]
            if hold == "zoh":
                um = u1 = u0
            k1 = f(xi, u0)
            k2 = f(xi + 0.5 * h * k1, um)
            k3 = f(xi + 0.5 * h * k2, um)
            k4 = f(xi + h * k3, u1)
            xi += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[i + 1] = xi
    return out


def validate_one_dof(model: OneDofModel, t, phi, measured, *, t_phi=None, hold: str = "zoh",
                     xi0: float | None = None, by: str = "range") -> dict:
    """Predicted vs measured velocity on a validation log: NRMSE (``by`` as
    :func:`uuvid.core.metrics.nrmse`), RMSE and the predicted series."""
    from uuvid.core.metrics import nrmse

    t = np.asarray(t, dtype=float)
    meas = np.asarray(measured, dtype=float)
    if meas.shape != t.shape:
        raise ValueError("measured must be given on t")
    ok = np.isfinite(meas)
    x0 = float(meas[ok][0]) if xi0 is None else float(xi0)
    pred = simulate_one_dof(model, t, phi, x0, t_phi=t_phi, hold=hold)
    return {"nrmse": nrmse(pred[ok], meas[ok], by=by),
            "rmse": float(np.sqrt(np.mean((pred[ok] - meas[ok]) ** 2))),
            "predicted": pred, "t": t, "measured": meas}


def _sine_fit(t: np.ndarray, y: np.ndarray, omega: float) -> tuple[float, float]:
    """Amplitude and phase of ``y ≈ c + A sin(ωt + ϕ)`` by LS (with a linear trend)."""
    H = np.column_stack([np.sin(omega * t), np.cos(omega * t), np.ones_like(t), t - t.mean()])
    c, *_ = np.linalg.lstsq(H, y, rcond=None)
    return float(math.hypot(c[0], c[1])), float(math.atan2(c[1], c[0]))


def phase_lag(t, u, y, omega: float, *, t_start: float | None = None,
              t_end: float | None = None) -> dict:
    """Lag of the response ``y`` behind the sine input ``u`` at ``omega`` (rad/s).

    Both signals are fitted with ``c + A sin(ωt + ϕ)`` (plus a linear trend) over
    ``[t_start, t_end]`` (choose it after the transient); returns the lag in degrees
    (``ϕ_u − ϕ_y`` wrapped to (−180, 180]), the time lag and both amplitudes.
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if not (t.shape == u.shape == y.shape):
        raise ValueError("t, u and y must have the same shape")
    if not (math.isfinite(omega) and omega > 0):
        raise ValueError(f"omega must be > 0, got {omega!r}")
    sel = np.isfinite(u) & np.isfinite(y)
    if t_start is not None:
        sel &= t >= t_start
    if t_end is not None:
        sel &= t <= t_end
    if sel.sum() < 8:
        raise ValueError("too few samples for the phase fit")
    au, pu = _sine_fit(t[sel], u[sel], omega)
    ay, py = _sine_fit(t[sel], y[sel], omega)
    lag = math.degrees(pu - py)
    lag = (lag + 180.0) % 360.0 - 180.0
    if lag == -180.0:
        lag = 180.0
    return {"lag_deg": lag, "time_lag_s": math.radians(lag) / omega, "input_amplitude": au,
            "output_amplitude": ay}


def predicted_phase_lag(omega: float, mass: float, k_L: float) -> float:
    """First-order lag ``atan(ω m/k_L)`` in degrees (Caccia et al. 2000, §IV)."""
    if not (omega > 0 and mass > 0 and k_L > 0):
        raise ValueError("omega, mass and k_L must be > 0")
    return math.degrees(math.atan(omega * mass / k_L))


def points_table(points: Sequence[SteadyPoint], key: Callable[[SteadyPoint], str] | None = None):
    """Group points by ``key`` (default: their η label) → ``{label: (velocities, forces)}``."""
    key = key or (lambda p: "open water" if p.eta is None else p.eta)
    out: dict[str, tuple[list[float], list[float]]] = {}
    for p in points:
        v, f = out.setdefault(key(p), ([], []))
        v.append(p.velocity)
        f.append(p.force)
    return {k_: (np.array(v), np.array(f)) for k_, (v, f) in out.items()}
