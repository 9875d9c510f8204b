"""One result type for every estimator: parameters with statistics, residuals, diagnostics.

Statistics follow Caccia, Indiveri & Veruggio (2000), §III: for ``y = Hθ + e`` solved by ordinary
least squares, ``σ² = |y − Hθ̂|²/(dim y − dim θ)``, ``cov θ̂ = σ² (HᵀH)⁻¹``, the *percentile error*
``100 σ_θ/|θ|``; a parameter whose percentile error exceeds 51.02 % (``|θ|/σ_θ < 1.96``) is not
significantly different from zero at 95 % confidence.  Nonlinear fits use the same formulas with the
Jacobian of the residuals in place of ``H``.

Functions:
    linear_lsq     ordinary (optionally weighted) linear LS with classical, HC0/HC3 or HAC covariance
    nonlinear_lsq  scipy ``least_squares`` wrapped to return a :class:`Fit` with Jacobian-based σ
    diagnose       the identifiability warnings every fit carries
"""

from __future__ import annotations

import math
import warnings as _warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from uuvid.core.result import Result, jsonable
from uuvid.core.threads import small_blas

#: Caccia et al. 2000: percentile error above this → insignificant at 95 % (1/1.96 = 51.02 %).
SIGNIFICANCE_PERCENT = 100.0 / 1.96
#: Condition number of the column-scaled regressor above which parameters are called unidentifiable.
CONDITION_LIMIT = 1e8
#: |correlation| above which two parameters are reported as nearly inseparable.
CORRELATION_LIMIT = 0.995
#: how a warning says that a parameter ended on a bound (``"<name>: at its bound <value>; …"``)
AT_BOUND = ": at its bound "


def _pct(pe: float) -> str:
    """A percentile error for text: one decimal up to 10 000 %, then three digits (1.2e+18 %, not
    eighteen digits of a σ that only says 'not determined')."""
    return f"{pe:.1f}" if abs(pe) < 1e4 else f"{pe:.3g}"


class IdentifiabilityWarning(UserWarning):
    """A parameter cannot be trusted from these data (rank, conditioning, significance)."""


@dataclass(frozen=True)
class Parameter:
    """An estimated (or fixed) parameter with its standard error."""

    name: str
    value: float
    stderr: float = math.nan
    unit: str = ""
    fixed: bool = False

    @property
    def percentile_error(self) -> float:
        """``100 σ/|θ|`` (Caccia et al. 2000); ``inf`` for a zero estimate."""
        if self.fixed:
            return 0.0
        if self.value == 0:
            return math.inf
        return 100.0 * self.stderr / abs(self.value)

    @property
    def significant(self) -> bool:
        """``True`` when ``|θ|/σ ≥ 1.96`` (percentile error ≤ 51.02 %)."""
        return self.fixed or self.percentile_error <= SIGNIFICANCE_PERCENT

    def interval(self, z: float = 1.96) -> tuple[float, float]:
        return (self.value - z * self.stderr, self.value + z * self.stderr)

    def as_dict(self) -> dict:
        return {"name": self.name, "estimate": self.value, "sigma": self.stderr, "unit": self.unit,
                "percentile_error": self.percentile_error, "significant": self.significant,
                "fixed": self.fixed}


@dataclass(frozen=True)
class Fit(Result):
    """Parameters by name with σ, covariance, residuals and diagnostics; ``summary()`` is the
    text report, ``report(folder)`` writes it with a residual plot."""

    model: str
    parameters: tuple[Parameter, ...]
    covariance: np.ndarray
    residuals: np.ndarray
    n_samples: int
    condition_number: float = math.nan
    warnings: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict)

    # ------------------------------------------------------------------ access
    def __getitem__(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(f"no parameter {name!r} in fit {self.model!r}; have {self.names}")

    def __contains__(self, name: str) -> bool:
        return any(p.name == name for p in self.parameters)

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parameters]

    @property
    def values(self) -> dict[str, float]:
        return {p.name: p.value for p in self.parameters}

    @property
    def stderrs(self) -> dict[str, float]:
        return {p.name: p.stderr for p in self.parameters}

    @property
    def at_bound(self) -> tuple[str, ...]:
        """Parameters the optimiser left on a bound (their σ is not meaningful)."""
        return tuple(w.split(AT_BOUND, 1)[0] for w in self.warnings if AT_BOUND in w)

    @property
    def n_free(self) -> int:
        return sum(not p.fixed for p in self.parameters)

    @property
    def dof(self) -> int:
        return self.n_samples - self.n_free

    @property
    def rmse(self) -> float:
        return float(np.sqrt(np.mean(self.residuals**2))) if self.residuals.size else math.nan

    @property
    def mean_abs_error(self) -> float:
        """ME as Laidani et al. define it: mean |e|."""
        return float(np.mean(np.abs(self.residuals))) if self.residuals.size else math.nan

    @property
    def bias(self) -> float:
        return float(np.mean(self.residuals)) if self.residuals.size else math.nan

    @property
    def sigma2(self) -> float:
        """Residual variance ``|e|²/(n − p)``."""
        return float(self.residuals @ self.residuals / max(self.dof, 1))

    @property
    def correlation(self) -> np.ndarray:
        c = np.asarray(self.covariance, dtype=float)
        d = np.sqrt(np.clip(np.diag(c), 0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            return c / np.outer(d, d)

    def aic(self) -> float:
        n = self.n_samples
        return n * math.log(max(self.residuals @ self.residuals / n, 1e-300)) + 2 * self.n_free

    def bic(self) -> float:
        n = self.n_samples
        return n * math.log(max(self.residuals @ self.residuals / n, 1e-300)) + self.n_free * math.log(n)

    # ------------------------------------------------------------------ output
    def as_dict(self) -> dict:
        return {
            "model": self.model,
            "parameters": {p.name: p.as_dict() for p in self.parameters},
            "covariance": np.asarray(self.covariance).tolist(),
            "n_samples": self.n_samples,
            "rmse": self.rmse,
            "mean_abs_error": self.mean_abs_error,
            "bias": self.bias,
            "condition_number": self.condition_number,
            "warnings": list(self.warnings),
            **({"extra": self.extra} if self.extra else {}),
        }

    report_title = "Fit"

    def to_dict(self) -> dict:
        """:meth:`as_dict`, JSON-safe (NaN → ``None``)."""
        return jsonable(self.as_dict())

    def plot(self):
        """Residuals against sample index and their histogram."""
        return residual_figure({self.model: self}, unit=self.extra.get("residual_unit"))

    def summary(self) -> str:
        """A readable fit report (lmfit-style)."""
        ru = self.extra.get("residual_unit") or ""
        ru = f" {ru}" if ru else ""
        lines = [f"[[Fit]] {self.model}",
                 f"    samples = {self.n_samples}, free parameters = {self.n_free}, "
                 f"RMSE = {self.rmse:.6g}{ru}, ME = {self.mean_abs_error:.6g}{ru}, "
                 f"cond = {self.condition_number:.3g}",
                 "[[Parameters]]"]
        w = max([len(p.name) for p in self.parameters] + [4])
        bound = self.at_bound
        for p in self.parameters:
            if p.fixed:
                lines.append(f"    {p.name:<{w}} = {p.value:.6g} (fixed) {p.unit}")
            elif p.name in bound:
                lines.append(f"    {p.name:<{w}} = {p.value:.6g} at bound (no σ) {p.unit}")
            elif p.stderr == math.inf:  # the data do not determine it
                lines.append(f"    {p.name:<{w}} = {p.value:.6g} not determined by these data "
                             f"(σ = ∞) {p.unit}")
            elif not math.isfinite(p.stderr):  # unknown, not "not significant"
                lines.append(f"    {p.name:<{w}} = {p.value:.6g} (σ unknown) {p.unit}")
            else:
                flag = "" if p.significant else "  <-- not significant (>51.02 %)"
                lines.append(f"    {p.name:<{w}} = {p.value:.6g} +/- {p.stderr:.3g} "
                             f"({_pct(p.percentile_error)} %) {p.unit}{flag}")
        corr = self.correlation
        free = [i for i, p in enumerate(self.parameters) if not p.fixed]
        pairs = []
        for a in range(len(free)):
            for b in range(a + 1, len(free)):
                i, j = free[a], free[b]
                if i < corr.shape[0] and j < corr.shape[1] and abs(corr[i, j]) > 0.5:
                    pairs.append(f"    C({self.parameters[i].name}, {self.parameters[j].name}) = "
                                 f"{corr[i, j]:+.3f}")
        if pairs:
            lines.append("[[Correlations]] (|C| > 0.5)")
            lines.extend(pairs)
        if self.warnings:
            lines.append("[[Warnings]]")
            lines.extend(f"    {w}" for w in self.warnings)
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


def residual_figure(fits: dict, title: str | None = None, unit: str | None = None):
    """One row per fit (label → :class:`Fit`): residuals against sample index and their
    histogram (a headless Figure).  ``unit``: the residuals' unit (that of the fitted output;
    unnamed when not known)."""
    from uuvid.core.plots import new_figure

    fig, ax = new_figure(max(len(fits), 1), 2, figsize=(10, 1.2 + 2.4 * max(len(fits), 1)),
                         width_ratios=[3, 1], squeeze=False)
    for row, (label, f) in zip(ax, fits.items()):
        r = np.asarray(f.residuals, dtype=float).ravel()
        r = r[np.isfinite(r)]
        row[0].plot(r, ".", ms=3)
        row[0].axhline(0.0, color="k", lw=0.6)
        u = unit or f.extra.get("residual_unit") or "fitted output's unit"
        row[0].set_ylabel(f"residual [{u}]")
        row[0].set_title(f"{label}: RMSE {f.rmse:.4g}, {f.n_samples} samples", fontsize=10)
        row[1].hist(r, bins=max(5, min(40, r.size // 4)), orientation="horizontal")
        row[1].set_ylabel(f"residual [{u}]")
        row[0].set_xlabel("sample [index]")
        row[1].set_xlabel("count [samples]")
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


def diagnose(names: Sequence[str], values: np.ndarray, cov: np.ndarray, jac: np.ndarray,
             emit: bool = True, at_bound: Sequence[str] = ()) -> tuple[float, list[str]]:
    """Condition number of the column-scaled regressor/Jacobian and identifiability warnings.

    Warns (``IdentifiabilityWarning``) on rank deficiency, a condition number above
    ``CONDITION_LIMIT``, a percentile error above 51.02 % and near-perfect correlations; not on
    the percentile error of a parameter left on a bound (``at_bound``: its σ means nothing, and
    at a bound of 0 it read "3.89e+20 %").
    """
    msgs: list[str] = []
    J = np.asarray(jac, dtype=float)
    if J.size == 0:
        return math.nan, msgs
    norms = np.linalg.norm(J, axis=0)
    zero = norms == 0
    for i in np.flatnonzero(zero):
        msgs.append(f"{names[i]}: not identifiable — the data do not excite it (zero column)")
    Js = J[:, ~zero] / norms[~zero] if np.any(~zero) else J
    with small_blas(Js.shape[1], entries=Js.size):
        s = np.linalg.svd(Js, compute_uv=False) if Js.size else np.array([0.0])
    cond = float(s[0] / s[-1]) if s.size and s[-1] > 0 else math.inf
    rank = int(np.sum(s > s[0] * max(J.shape) * np.finfo(float).eps)) if s.size else 0
    if rank < Js.shape[1]:
        msgs.append(f"rank deficient: {rank} independent directions for {J.shape[1]} parameters "
                    "— some parameters are not identifiable from these data")
    elif cond > CONDITION_LIMIT:
        msgs.append(f"condition number {cond:.3g} > {CONDITION_LIMIT:.0e}: parameters nearly "
                    "unidentifiable (collinear regressors)")
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    for i, n in enumerate(names):
        v = values[i]
        if sd[i] == np.inf and not zero[i]:
            msgs.append(f"{n}: not identifiable — it trades off exactly with another parameter "
                        "in these data (σ = ∞)")
        if not np.isfinite(sd[i]) or n in at_bound:
            continue
        pe = math.inf if v == 0 else 100 * sd[i] / abs(v)
        if pe > SIGNIFICANCE_PERCENT:
            msgs.append(f"{n}: percentile error {_pct(pe)} % > 51.02 % — not significantly "
                        "different from zero (95 %)")
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    k = len(names)
    for i in range(k):
        for j in range(i + 1, k):
            if np.isfinite(corr[i, j]) and abs(corr[i, j]) > CORRELATION_LIMIT:
                msgs.append(f"{names[i]} and {names[j]} are correlated {corr[i, j]:+.4f}: only a "
                            "combination of them is well determined")
    if emit:
        for m in msgs:
            _warnings.warn(m, IdentifiabilityWarning, stacklevel=3)
    return cond, msgs


def _sandwich(H: np.ndarray, r: np.ndarray, bread: np.ndarray, cov_type: str, lags: int | None):
    n, p = H.shape
    if cov_type == "HC0":
        meat = (H * r[:, None] ** 2).T @ H
    elif cov_type == "HC3":
        h = np.einsum("ij,jk,ik->i", H, bread, H)
        meat = (H * (r / np.clip(1 - h, 1e-12, None))[:, None] ** 2).T @ H
    elif cov_type == "HAC":  # Newey–West with Bartlett weights
        L = int(lags if lags is not None else math.floor(4 * (n / 100.0) ** (2.0 / 9.0)))
        if L < 0:
            raise ValueError(f"`hac_lags=` {L}: expected a bandwidth of >= 0 points")
        u = H * r[:, None]
        meat = u.T @ u
        for lag in range(1, min(L, n - 1) + 1):  # a lag of n or more pairs no residuals
            w = 1.0 - lag / (L + 1.0)
            g = u[lag:].T @ u[:-lag]
            meat += w * (g + g.T)
    else:
        raise ValueError(f"cov_type must be classical, HC0, HC3 or HAC, got {cov_type!r}")
    return bread @ meat @ bread * n / max(n - p, 1)


def normal_inverse(H: np.ndarray) -> np.ndarray:
    """``(HᵀH)⁻¹`` (pseudo-inverse) from the SVD of ``H`` with its columns scaled to unit norm,
    unscaled after: the covariance's shape does not depend on the columns' units.  Inverting
    ``HᵀH`` itself squares the condition number, and the pseudo-inverse's relative cut-off then
    dropped the directions of a column in small units — a torque column in µN·m gave σ = 0.0 %
    and correlations of 1.0019.  Singular values below ``max(n, p)·ε`` × the largest (the rank
    tolerance of :func:`diagnose`) count as zero."""
    norms = np.linalg.norm(H, axis=0)
    sc = np.where(norms > 0, norms, 1.0)
    with small_blas(H.shape[1], entries=H.size):
        Hs = H / sc
        # the SVD of R (Hs = QR, p × p) has Hs's singular values and V without an n × p U
        R = np.linalg.qr(Hs, mode="r") if Hs.shape[0] > Hs.shape[1] else Hs
        _, s, Vt = np.linalg.svd(R, full_matrices=False)
    keep = s > (s[0] if s.size else 0.0) * max(H.shape) * np.finfo(float).eps
    inv = (Vt[keep].T / s[keep] ** 2) @ Vt[keep]
    return inv / np.outer(sc, sc)


def lsq_solution(H: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``θ`` minimising ``|y − Hθ|`` (columns scaled to unit norm, ``lstsq``): the estimate of
    :func:`linear_lsq` alone, bit for bit, for loops that need no statistics (iterated
    re-weighting, outlier rejection)."""
    norms = np.linalg.norm(H, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    with small_blas(H.shape[1], entries=H.size):
        theta_s, *_ = np.linalg.lstsq(H / scale, y, rcond=None)
    return theta_s / scale


def lsq_classical(H: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``(θ, σ_θ, s²)`` of an unweighted classical :func:`linear_lsq` (the same arithmetic, the
    same numbers) without building a :class:`Fit` or its diagnostics: for inner loops over many
    small regressions (a segment's velocity)."""
    n, p = H.shape
    if n < p:
        raise ValueError(f"too few samples: {n} for {p} parameters")
    theta = lsq_solution(H, y)
    r = y - H @ theta
    sigma2 = float(r @ r / max(n - p, 1))
    cov = sigma2 * normal_inverse(H)
    return theta, np.sqrt(np.maximum(np.diag(cov), 0.0)), sigma2


def linear_lsq(H, y, names: Sequence[str], *, model: str = "linear", units: Sequence[str] | None = None,
               weights=None, cov_type: str = "classical", hac_lags: int | None = None,
               emit_warnings: bool = True, extra: dict | None = None) -> Fit:
    """Solve ``y ≈ H θ`` by (weighted) least squares and return a :class:`Fit`.

    ``cov_type``: ``classical`` (Caccia: ``σ²(HᵀH)⁻¹``), ``HC0``/``HC3`` (heteroscedasticity-robust)
    or ``HAC`` (Newey–West, heteroscedasticity and autocorrelation robust).
    """
    H = np.asarray(H, dtype=float)
    y = np.asarray(y, dtype=float)
    if H.ndim == 1:
        H = H[:, None]
    n, p = H.shape
    if y.shape != (n,):
        raise ValueError(f"y has shape {y.shape}; H has {n} rows")
    if len(names) != p:
        raise ValueError(f"{len(names)} names for {p} regressor columns")
    if n < p:
        raise ValueError(f"too few samples: {n} for {p} parameters")
    units = _check_units(units, names)
    if hac_lags is not None and cov_type != "HAC":
        raise ValueError(f"`hac_lags=` {hac_lags} is the bandwidth of the HAC (Newey–West) "
                         f"covariance; with `cov_type=` {cov_type} it would be ignored: expected "
                         "`cov_type=` HAC, or no bandwidth")
    bad = np.flatnonzero(~np.isfinite(y) | ~np.all(np.isfinite(H), axis=1))
    if bad.size:
        raise ValueError(f"row {bad[0]} of the regression has a non-finite value")
    if weights is not None:
        w = np.sqrt(_check_weights(weights, n, p))
        Hw, yw = H * w[:, None], y * w
    else:
        Hw, yw = H, y
    theta = lsq_solution(Hw, yw)
    r = yw - Hw @ theta
    dof = max(n - p, 1)
    sigma2 = float(r @ r / dof)
    bread = normal_inverse(Hw)
    if cov_type == "classical":
        cov = sigma2 * bread
    else:
        cov = _sandwich(Hw, r, bread, cov_type, hac_lags)
    norms = np.linalg.norm(Hw, axis=0)
    cov = _mark_undetermined(cov, undetermined(Hw / np.where(norms > 0, norms, 1.0),
                                               max(n, p) * np.finfo(float).eps))
    cond, msgs = diagnose(names, theta, cov, Hw, emit=emit_warnings)
    if n == p:
        msgs.append("as many samples as parameters: no residual degrees of freedom, σ undefined")
    params = tuple(Parameter(nm, float(v), float(math.sqrt(max(cov[i, i], 0.0))), units[i])
                   for i, (nm, v) in enumerate(zip(names, theta)))
    ex = {"cov_type": cov_type, "sigma2": sigma2}
    if extra:
        ex.update(extra)
    return Fit(model, params, cov, y - H @ theta, n, cond, tuple(msgs), ex)


def _check_units(units, names: Sequence[str]) -> list[str]:
    """``units``: one per name, or None (no units).  A short list raised a bare IndexError after
    the solve; a long one was cut silently."""
    if units is None:
        return [""] * len(names)
    units = list(units)
    if len(units) != len(names):
        raise ValueError(f"units has {len(units)} entries for {len(names)} names "
                         f"({', '.join(map(str, names))}): expected one unit per name, or none")
    return units


def _check_weights(weights, n: int, p: int) -> np.ndarray:
    """:func:`linear_lsq`'s ``weights``: one per row, finite and >= 0 (a negative or NaN weight
    reached LAPACK, which printed "On entry to DLASCL parameter number 4 had an illegal value"
    and raised a LinAlgError; a wrong length, a bare broadcasting error), and at least ``p`` of
    them > 0 (all zero gave a Fit of zeros with every parameter "not identifiable", blaming the
    data for what the weights had removed)."""
    from uuvid.core.checks import finite_values

    w = np.asarray(weights, dtype=float)
    if w.shape != (n,):
        raise ValueError(f"weights has shape {w.shape}: expected one weight per row of H ({n})")
    w = finite_values("weights", w, what="a finite weight >= 0 per row")
    neg = np.flatnonzero(w < 0)
    if neg.size:
        raise ValueError(f"weights[{neg[0]}] = {w[neg[0]]:g}: expected a finite weight >= 0 per "
                         "row")
    k = int(np.count_nonzero(w))
    if k == 0:
        raise ValueError(f"weights: all {n} are 0, which leaves no row to fit: expected at least "
                         f"{p} weights > 0 (one per parameter)")
    if k < p:
        raise ValueError(f"weights: {k} of {n} are > 0, too few rows for {p} parameters: "
                         f"expected at least {p} weights > 0")
    return w


#: a parameter whose squared share of the null directions exceeds this is undetermined
NULL_SHARE = 1e-6


def undetermined(Js: np.ndarray, rtol: float) -> np.ndarray:
    """Mask of the parameters a column-scaled Jacobian ``Js`` does not determine: a zero column,
    or a share of a direction whose singular value is below ``rtol`` × the largest (two columns
    that trade off exactly).  ``rtol``: the rank tolerance ``max(n, p)·ε`` of an exact
    regressor (:func:`linear_lsq`, the tolerance :func:`diagnose` reports rank with), or
    ``1/CONDITION_LIMIT`` for a finite-difference Jacobian, whose columns carry errors of
    ~1e-8 (:func:`nonlinear_lsq`: a null direction shows as a condition number of ~1e8)."""
    if Js.size == 0:
        return np.zeros(Js.shape[1], bool)
    try:
        with small_blas(Js.shape[1], entries=Js.size):
            _, sv, Vt = np.linalg.svd(Js, full_matrices=False)
    except np.linalg.LinAlgError:
        return np.ones(Js.shape[1], bool)
    null = sv <= max(float(sv[0]), 1e-300) * rtol
    share = np.sum(Vt[null] ** 2, axis=0)
    if Js.shape[0] < Js.shape[1]:  # fewer rows than columns: the missing directions are null
        share = share + 1.0 - np.sum(Vt ** 2, axis=0)
    return share > NULL_SHARE


def propagated_variance(G: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``diag(G cov Gᵀ)``: the variances of combinations ``g(θ)`` with Jacobian ``G``, where an
    undetermined parameter (σ = ∞, NaN covariances) gives ∞ to the combinations that involve it
    and leaves the others their variance from the determined block (NaN·0 would spoil them all)."""
    G = np.atleast_2d(np.asarray(G, dtype=float))
    cov = np.asarray(cov, dtype=float)
    bad = ~np.isfinite(np.diag(cov))
    good = ~bad
    Gd = G[:, good]
    v = np.einsum("ij,jk,ik->i", Gd, cov[np.ix_(good, good)], Gd)
    v[np.any(G[:, bad] != 0, axis=1)] = np.inf
    return v


def _mark_undetermined(cov: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``cov`` with an undetermined parameter's variance ∞ and its covariances NaN (the
    pseudo-inverse's numbers there are round-off: σ ≈ 1e-16 and correlations beyond ±1)."""
    if not mask.any():
        return cov
    cov = np.array(cov, dtype=float)
    cov[mask, :] = np.nan
    cov[:, mask] = np.nan
    cov[mask, mask] = np.inf
    return cov


def nonlinear_lsq(residual: Callable[[np.ndarray], np.ndarray], x0, names: Sequence[str], *,
                  model: str = "nonlinear", units: Sequence[str] | None = None, bounds=(-np.inf, np.inf),
                  x_scale="jac", jac="2-point", emit_warnings: bool = True, extra: dict | None = None,
                  **kwargs) -> Fit:
    """Minimise ``|residual(θ)|²`` (scipy ``least_squares``, trust-region reflective) → :class:`Fit`.

    Standard errors from the Jacobian at the optimum: ``cov = σ² (JᵀJ)⁻¹``.
    """
    from scipy.optimize import least_squares

    x0 = np.asarray(x0, dtype=float)
    if x0.ndim > 1 or len(names) != x0.size:
        # checked before the solve, as linear_lsq does: a Fit of 1 parameter with a 2×2
        # covariance came back
        raise ValueError(f"{len(names)} names for {x0.size} parameters (x0 has shape {x0.shape}): "
                         "expected one name per parameter, x0 a 1-D start")
    units = _check_units(units, names)
    # a few parameters: threaded SVDs and products of the tall Jacobian only cost (and OpenBLAS's
    # threads spin on after each call, taking the cores from the residual's own threads)
    with small_blas(x0.size):
        sol = least_squares(residual, x0, bounds=bounds, x_scale=x_scale, jac=jac, **kwargs)
        J = np.asarray(sol.jac, dtype=float)
        r = np.asarray(sol.fun, dtype=float)
        n, p = J.shape
        dof = max(n - p, 1)
        sigma2 = float(r @ r / dof)
        # scale the columns before inverting so parameters of very different size keep their σ
        norms = np.linalg.norm(J, axis=0)
        sc = np.where(norms > 0, norms, 1.0)
        Js = J / sc
        cov = _mark_undetermined(sigma2 * np.linalg.pinv(Js.T @ Js) / np.outer(sc, sc),
                                 undetermined(Js, 1.0 / CONDITION_LIMIT))
    lo, hi = np.broadcast_to(bounds[0], sol.x.shape), np.broadcast_to(bounds[1], sol.x.shape)
    x = np.array(sol.x, dtype=float)
    # a parameter's own scale (x_scale when given, else its start; 1 when both are 0): a value
    # within 1e-9 of it from a bound is on the bound — a parameter of 5e-10 is not "at 0"
    typ = np.abs(np.broadcast_to(np.asarray(x_scale, float), x.shape)) if not isinstance(
        x_scale, str) else np.abs(np.asarray(x0, float))
    typ = np.where(typ > 0, typ, 1.0)
    bound_msgs, on_bound = [], []
    for i, nm in enumerate(names):
        for b in (lo[i], hi[i]):
            if np.isfinite(b) and abs(x[i] - b) <= 1e-9 * max(typ[i], abs(b)):
                x[i] = b  # the bound itself (the optimiser stops a rounding away: -6.8e-16 for 0)
                on_bound.append(nm)
                bound_msgs.append(f"{nm}{AT_BOUND}{x[i]:.6g}; its σ is not meaningful")
                break
    cond, msgs = diagnose(names, x, cov, J, emit=emit_warnings, at_bound=on_bound)
    if not sol.success:
        msgs.append(f"optimiser did not converge: {sol.message}")
    msgs += bound_msgs
    params = tuple(Parameter(nm, float(v), float(math.sqrt(max(cov[i, i], 0.0))), units[i])
                   for i, (nm, v) in enumerate(zip(names, x)))
    ex = {"nfev": int(sol.nfev), "cost": float(sol.cost), "status": int(sol.status),
          "sigma2": sigma2}
    if extra:
        ex.update(extra)
    return Fit(model, params, cov, -r, n, cond, tuple(msgs), ex)
