"""Bootstrap of the identification procedures: do the LS standard errors hold?

Every LS fit in uuvid reports ``σ = sqrt(diag(cov θ̂))`` (Caccia et al. 2000, §III: ``σ²(HᵀH)⁻¹``,
or a robust sandwich).  Those formulas assume a correct model with independent, equal-variance
errors.  The bootstrap re-runs the *whole procedure* on resampled data and takes the spread of the
re-estimates as the standard error — a check that needs none of those assumptions (or, for the
residual bootstrap, only some):

``residual``
    ``y* = ŷ + e*``, residuals resampled with replacement (centred, inflated by ``sqrt(n/(n−p))``).
    Keeps the design fixed; assumes exchangeable (equal-variance, independent) errors — agrees with
    the classical σ when the model is right.
``wild``
    ``y* = ŷ + e_i v_i`` with Rademacher ``v_i`` (and leverage-corrected residuals): robust to
    heteroscedasticity, like HC3.
``pairs`` / ``segment``
    rows (bench points, steady segments) resampled with replacement: robust to
    heteroscedasticity and to model error; the "segment bootstrap" of a steady-segment drag fit.
``block``
    moving-block resampling of the residuals (block length ``block``): for autocorrelated
    residuals (the integrated inertia regression) — compare with the classical and Newey–West σ.

Replicate ``b`` uses ``numpy.random.default_rng([seed, b])``; replicates whose refit fails (a
resample without an open-water point, a degenerate design) are counted in ``n_failed``, not hidden.

Procedures covered: :func:`bootstrap_linear` (any ``y = Hθ``, :func:`uuvid.identify.fit.linear_lsq`),
:func:`bootstrap_drag` (:func:`uuvid.identify.vehicle.fit.fit_drag`, segment or residual),
:func:`bootstrap_inertia` (:func:`~uuvid.identify.vehicle.fit.fit_inertia`, block bootstrap of the
integrated regression), :func:`bootstrap_steady` (the bench-sheet fits of
:mod:`uuvid.identify.thruster.steady`: ``fit_quadratic_speed``, ``fit_polynomial`` with a fixed degree),
:func:`bootstrap_physical` (:func:`uuvid.identify.thruster.physical.fit_physical`, residual bootstrap of all
sheets' channels — slow: each replicate is a full nonlinear fit), and the generic
:func:`bootstrap` for any ``fit(data) → Fit`` with a resampler.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from uuvid.core.result import Result, jsonable

KINDS = ("residual", "wild", "pairs", "segment", "block")
#: most replicates a bootstrap draws: a standard error is known to ~0.1 % after 10⁶ (1/√(2n)),
#: and each replicate costs at least a random draw and a solve
MAX_REPLICATES = 1_000_000


def _IdentifiabilityWarning():
    from uuvid.identify.fit import IdentifiabilityWarning

    return IdentifiabilityWarning


def _quiet(fn):
    """Replicate refits warn about every insignificant coefficient: silence those warnings (the
    full fit's own warnings belong to the user's call of the fit, not to the bootstrap)."""
    import functools

    @functools.wraps(fn)
    def wrapper(*a, **kw):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", _IdentifiabilityWarning())
            return fn(*a, **kw)

    return wrapper


@dataclass
class BootstrapResult(Result):
    """Estimates with LS σ and bootstrap σ; ``replicates`` holds every refit (rows)."""

    procedure: str
    kind: str
    names: list[str]
    estimate: np.ndarray
    ls_sigma: np.ndarray
    replicates: np.ndarray
    n_failed: int = 0
    seed: int = 0
    wall_time: float = 0.0
    notes: list[str] = field(default_factory=list)
    ls_label: str = "LS σ"

    @property
    def n_boot(self) -> int:
        return int(self.replicates.shape[0])

    @property
    def boot_sigma(self) -> np.ndarray:
        return (np.std(self.replicates, axis=0, ddof=1) if self.n_boot > 1
                else np.full(len(self.names), np.nan))

    @property
    def ratio(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.boot_sigma / self.ls_sigma

    def table(self) -> pd.DataFrame:
        """The comparison: bootstrap σ against the LS σ, per parameter."""
        R = self.replicates
        lo = np.quantile(R, 0.025, axis=0) if self.n_boot else np.full(len(self.names), np.nan)
        hi = np.quantile(R, 0.975, axis=0) if self.n_boot else np.full(len(self.names), np.nan)
        mean = R.mean(axis=0) if self.n_boot else np.full(len(self.names), np.nan)
        return pd.DataFrame({
            "parameter": self.names, "estimate": self.estimate, "ls_sigma": self.ls_sigma,
            "bootstrap_sigma": self.boot_sigma, "ratio_boot_to_ls": self.ratio,
            "bootstrap_bias": mean - self.estimate, "boot_q2.5": lo, "boot_q97.5": hi,
            "ls_ci_low": self.estimate - 1.959963984540054 * self.ls_sigma,
            "ls_ci_high": self.estimate + 1.959963984540054 * self.ls_sigma})

    def as_dict(self) -> dict:
        return {"procedure": self.procedure, "kind": self.kind, "n_boot": self.n_boot,
                "n_failed": self.n_failed, "seed": self.seed, "wall_time_s": self.wall_time,
                "ls_sigma_label": self.ls_label, "notes": self.notes,
                "table": self.table().to_dict(orient="records")}

    report_title = "Bootstrap σ against LS σ"

    def to_dict(self) -> dict:
        return jsonable(self.as_dict())

    def summary(self) -> str:
        t = self.table()
        w = max(len(n) for n in self.names) + 2
        lines = [f"[[Bootstrap]] {self.procedure}: {self.kind}, {self.n_boot} replicates"
                 f"{f' ({self.n_failed} failed)' if self.n_failed else ''}",
                 f"    {'parameter':<{w}}{'estimate':>13}{self.ls_label:>13}{'boot σ':>13}{'ratio':>8}"]
        for _, r in t.iterrows():
            lines.append(f"    {r['parameter']:<{w}}{r['estimate']:>13.5g}{r['ls_sigma']:>13.4g}"
                         f"{r['bootstrap_sigma']:>13.4g}{r['ratio_boot_to_ls']:>8.2f}")
        lines.extend(f"    note: {n}" for n in self.notes)
        return "\n".join(lines)

    def plot(self, ax=None):
        """Bootstrap σ / LS σ per parameter (1 = the LS σ is right)."""
        from uuvid.core.plots import new_figure

        fig = None
        if ax is None:
            fig, ax = new_figure(1, 1, figsize=(max(5, 0.6 * len(self.names) + 2), 3.5))
        ax.bar(range(len(self.names)), self.ratio, color="C0")
        ax.axhline(1.0, color="k", lw=1, ls="--")
        ax.set_xticks(range(len(self.names)))
        ax.set_xticklabels(self.names, rotation=45, ha="right", fontsize=8)
        ax.set_xlabel("parameter [name]")
        ax.set_ylabel("bootstrap σ / LS σ [–]")
        ax.set_title(f"{self.procedure} ({self.kind}, {self.n_boot} replicates)")
        return fig if fig is not None else ax.figure


# ---------------------------------------------------------------------------------------------
# the generic loop
# ---------------------------------------------------------------------------------------------
def _values(fit, names: Sequence[str] | None = None) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Names, values and σ of a :class:`~uuvid.identify.fit.Fit` (or ``{name: value}``)."""
    if isinstance(fit, dict):
        ns = list(names or fit)
        return ns, np.array([fit[n] for n in ns], float), np.full(len(ns), np.nan)
    ps = [p for p in fit.parameters if not p.fixed]
    if names is not None:
        d = {p.name: p for p in ps}
        ps = [d[n] for n in names]
    return [p.name for p in ps], np.array([p.value for p in ps]), np.array([p.stderr for p in ps])


@_quiet
def bootstrap(fit_fn: Callable, data, resample: Callable, *, n_boot: int = 200, seed: int = 0,
              kind: str = "custom", procedure: str = "fit", names: Sequence[str] | None = None,
              progress: bool | None = None) -> BootstrapResult:
    """Generic bootstrap: ``fit_fn(data) → Fit``; ``resample(data, rng) → data*`` per replicate
    (``n_boot``, ``seed``: as :func:`bootstrap_linear` checks them)."""
    from uuvid.core.progress import progress_task

    n_boot, seed = _check_replicates(n_boot, seed, 8.0 * 64)  # a replicate keeps its estimates
    t0 = time.perf_counter()
    full = fit_fn(data)
    nm, est, sd = _values(full, names)
    reps, failed = [], 0
    with progress_task(f"bootstrap {procedure}", total=n_boot,
                       disable=None if progress is None else not progress) as bar, \
            warnings.catch_warnings():
        warnings.simplefilter("ignore", _IdentifiabilityWarning())
        for b in range(n_boot):
            rng = np.random.default_rng([int(seed), b])
            try:
                f = fit_fn(resample(data, rng))
                _, v, _ = _values(f, nm)
                if not np.all(np.isfinite(v)):
                    raise ValueError("non-finite estimate")
                reps.append(v)
            except (ValueError, KeyError, np.linalg.LinAlgError, ZeroDivisionError):
                failed += 1
            bar.advance()
    R = np.array(reps) if reps else np.zeros((0, len(nm)))
    return BootstrapResult(procedure, kind, nm, est, sd, R, failed, seed,
                           time.perf_counter() - t0)


# ---------------------------------------------------------------------------------------------
# linear LS (identify.fit.linear_lsq)
# ---------------------------------------------------------------------------------------------
def _check_replicates(n_boot, seed, sample_bytes: float) -> tuple[int, int]:
    """``(n_boot, seed)`` of a bootstrap, checked before any work: ``n_boot`` a whole number from
    2 (a spread needs two replicates; 0 gave σ = NaN silently) to :data:`MAX_REPLICATES`, whose
    replicates (``sample_bytes`` each) fit in :func:`~uuvid.core.checks.memory_budget_bytes`
    (n_boot = 10⁹ tried to allocate 373 GiB); ``seed`` a whole number >= 0, or ``None`` for a
    fresh random one (returned, and kept in the result's ``seed`` to repeat the run)."""
    from uuvid.core.checks import count, memory_budget_bytes

    n = count("n_boot", n_boot, minimum=2, maximum=MAX_REPLICATES,
              hint="a standard error is known to 0.1 % after 10⁶ replicates")
    budget = memory_budget_bytes()
    if n * sample_bytes > budget:
        raise ValueError(f"n_boot = {n:,}: the replicates would take ≈ {n * sample_bytes / 1e9:.3g}"
                         f" GB, more than the {budget / 1e9:.3g} GB (half this machine's memory) "
                         f"one result may take; expected at most {int(budget // sample_bytes):,}")
    if seed is None:
        import secrets

        return n, secrets.randbits(63)
    return n, count("seed", seed, minimum=0)


@_quiet
def bootstrap_linear(H, y, names: Sequence[str], *, n_boot: int = 1000, seed: int = 0,
                     kind: str = "residual", cov_type: str = "classical", block: int = 10,
                     procedure: str = "linear LS") -> BootstrapResult:
    """Bootstrap ``y ≈ Hθ`` solved by :func:`~uuvid.identify.fit.linear_lsq` (``kind``: residual,
    wild, pairs, block).  Residual/wild/block replicates keep ``H`` and are solved together.

    ``n_boot``: 2 … :data:`MAX_REPLICATES` replicates, within the memory one result may take;
    ``seed``: a whole number >= 0 (replicate ``b`` draws from ``default_rng([seed, b])``), or
    ``None`` for a fresh random seed, kept in the result's ``seed``."""
    from uuvid.identify.fit import linear_lsq

    if kind not in ("residual", "wild", "pairs", "block"):
        raise ValueError(f"kind must be residual, wild, pairs or block, got {kind!r}")
    t0 = time.perf_counter()
    H = np.asarray(H, dtype=float)
    if H.ndim == 1:
        H = H[:, None]
    y = np.asarray(y, dtype=float)
    # a replicate holds a resampled y (n) and its estimate (p), 8 bytes each
    n_boot, seed = _check_replicates(n_boot, seed, 8.0 * (H.shape[0] + H.shape[1]))
    fit = linear_lsq(H, y, names, cov_type=cov_type, emit_warnings=False)
    nm, est, sd = _values(fit)
    n, p = H.shape
    yhat = H @ est
    e = y - yhat
    norms = np.linalg.norm(H, axis=0)
    sc = np.where(norms > 0, norms, 1.0)
    pinv = np.linalg.pinv(H / sc) / sc[:, None]  # θ = pinv @ y, column scaling as linear_lsq
    failed = 0
    if kind == "pairs":
        reps = []
        for b in range(n_boot):
            rng = np.random.default_rng([int(seed), b])
            idx = rng.integers(0, n, n)
            Hb = H[idx]
            if np.linalg.matrix_rank(Hb) < p:
                failed += 1
                continue
            nb = np.linalg.norm(Hb, axis=0)
            sb = np.where(nb > 0, nb, 1.0)
            th, *_ = np.linalg.lstsq(Hb / sb, y[idx], rcond=None)
            reps.append(th / sb)
        R = np.array(reps) if reps else np.zeros((0, p))
    else:
        Y = np.empty((n_boot, n))
        if kind == "residual":
            ec = (e - e.mean()) * math.sqrt(n / max(n - p, 1))
            for b in range(n_boot):
                rng = np.random.default_rng([int(seed), b])
                Y[b] = yhat + ec[rng.integers(0, n, n)]
        elif kind == "wild":
            h = np.einsum("ij,ji->i", H, pinv)
            ew = e / np.sqrt(np.clip(1 - h, 1e-12, None))
            for b in range(n_boot):
                rng = np.random.default_rng([int(seed), b])
                Y[b] = yhat + ew * rng.choice([-1.0, 1.0], n)
        else:  # moving blocks of residuals
            L = max(1, min(int(block), n))
            ec = (e - e.mean()) * math.sqrt(n / max(n - p, 1))
            nblk = math.ceil(n / L)
            for b in range(n_boot):
                rng = np.random.default_rng([int(seed), b])
                starts = rng.integers(0, n - L + 1, nblk)
                Y[b] = yhat + np.concatenate([ec[s:s + L] for s in starts])[:n]
        R = Y @ pinv.T
    label = "LS σ" if cov_type == "classical" else f"LS σ ({cov_type})"
    res = BootstrapResult(procedure, kind, nm, est, sd, R, failed, seed, time.perf_counter() - t0,
                          ls_label=label)
    if kind == "residual":
        res.notes.append("residual bootstrap assumes exchangeable errors: it reproduces the "
                         "classical σ when the model is right — compare wild/pairs")
    return res


# ---------------------------------------------------------------------------------------------
# vehicle identification (identify.vehicle.fit)
# ---------------------------------------------------------------------------------------------
def bootstrap_drag(points, *, n_boot: int = 500, seed: int = 0, kind: str = "segment",
                   **fit_kwargs) -> BootstrapResult:
    """Bootstrap :func:`~uuvid.identify.vehicle.fit.fit_drag` (no model reduction inside the
    replicates, so every replicate estimates the same parameters).

    ``segment``: steady segments resampled with replacement (a resample without an open-water
    segment, or without a segment for some installation coefficient, is redrawn up to 100 times,
    then counted as failed).  ``residual``: open-water points only — the force residuals of the
    fit resampled onto the fitted forces."""
    from uuvid.identify.vehicle.fit import fit_drag

    pts = list(points)
    kw = {**fit_kwargs, "reduce": False}
    full = fit_drag(pts, **kw)
    etas = set(full.eta_names)
    if kind == "segment":
        def resample(data, rng):
            n = len(data)
            for _ in range(100):
                idx = rng.integers(0, n, n)
                sample = [data[i] for i in idx]
                have = {p.eta for p in sample}
                if None in have and etas <= have:
                    return sample
            raise ValueError("no admissible resample")
    elif kind == "residual":
        if any(p.eta is not None for p in pts):
            raise ValueError("residual drag bootstrap needs open-water points only (eta=None); "
                             "use kind='segment'")
        fitted = np.array([full.steady_force(p.velocity, None, p.ballast) for p in pts])
        r = np.array([p.force for p in pts]) - fitted
        n = len(pts)
        p_ = len(full.fit.parameters)
        rc = (r - r.mean()) * math.sqrt(n / max(n - p_, 1))

        def resample(data, rng):
            e = rc[rng.integers(0, n, n)]
            return [replace(q, force=float(f + ei)) for q, f, ei in zip(data, fitted, e)]
    else:
        raise ValueError("kind must be segment or residual")
    res = bootstrap(lambda d: fit_drag(d, **kw).fit, pts, resample, n_boot=n_boot, seed=seed,
                    kind=kind, procedure=f"fit_drag {full.dof}".strip(), progress=False)
    res.notes.append("errors in variables (velocity noise in H) are not resampled separately: "
                     "the segment bootstrap carries them with the segments")
    return res


def bootstrap_inertia(inertia_fit, *, n_boot: int = 500, seed: int = 0, block: int | None = None,
                      kind: str = "block") -> BootstrapResult:
    """Bootstrap the integrated inertia regression of an
    :class:`~uuvid.identify.vehicle.fit.InertiaFit` (``H = [ξ, −1, −t]``, fixed drag).

    The regression's residuals are strongly autocorrelated (integrals of noise), so the moving-
    block bootstrap (default block: 1/10 of the record) is the fair check of its classical σ and
    of the Newey–West σ; ``kind="residual"`` shows what ignoring the autocorrelation gives."""
    f = inertia_fit
    H = np.column_stack([f.velocity, -np.ones(f.t.size), -(f.t - f.t[0])])
    y = np.asarray(f.y, dtype=float)
    if y.size != H.shape[0]:
        raise ValueError("the InertiaFit's regression rows and signals do not line up")
    L = block or max(2, H.shape[0] // 10)
    res = bootstrap_linear(H, y, ["m", "c", "b"], n_boot=n_boot, seed=seed, kind=kind, block=L,
                           cov_type=f.fit.extra.get("cov_type", "classical"),
                           procedure="fit_inertia (integrated regression)")
    if kind == "block":
        res.notes.append(f"moving-block bootstrap, block length {L} samples")
    return res


# ---------------------------------------------------------------------------------------------
# thruster identification (identify.thruster.steady, identify.thruster.physical)
# ---------------------------------------------------------------------------------------------
def _steady_fit_fn(model: str, degree: int | None):
    from uuvid.identify.thruster.steady import fit_polynomial, fit_quadratic_speed

    if model == "quadratic":
        fn = fit_quadratic_speed
    elif model == "polynomial":
        if degree is None:
            raise ValueError("bootstrap of a polynomial needs a fixed degree (the degree choice "
                             "itself is not bootstrapped)")

        def fn(data):
            return fit_polynomial(data, degree)
    else:
        raise ValueError("model must be quadratic or polynomial")

    def flat(data):
        sf = fn(data)
        out = {}
        for k, f in sf.fits.items():
            for p in f.parameters:
                out[f"{k}.{p.name}"] = (p.value, p.stderr)
        return out

    return flat


@_quiet
def bootstrap_steady(data, *, model: str = "quadratic", degree: int | None = None,
                     n_boot: int = 500, seed: int = 0, kind: str = "residual") -> BootstrapResult:
    """Bootstrap a per-direction steady bench fit (``quadratic``: ``T = K_T Ω|Ω|``;
    ``polynomial`` of a fixed ``degree``): ``residual`` (thrust residuals resampled within each
    direction) or ``pairs`` (measured rows resampled within each direction)."""
    from uuvid.identify.thruster.steady import fit_polynomial, fit_quadratic_speed

    flat = _steady_fit_fn(model, degree)
    n_boot, seed = _check_replicates(n_boot, seed, 8.0 * 64)  # a replicate keeps its estimates
    t0 = time.perf_counter()
    full = flat(data)
    names = list(full)
    est = np.array([full[n][0] for n in names])
    sd = np.array([full[n][1] for n in names])
    m = data.measured & (data.speed != 0)
    sf = fit_quadratic_speed(data) if model == "quadratic" else fit_polynomial(data, degree)
    pred = np.full(len(data), np.nan)
    sgn = np.sign(data.speed)
    for direction, s in (("forward", 1.0), ("reverse", -1.0)):
        rows = m & (sgn == s)
        if direction not in sf.fits or not rows.any():
            continue
        f = sf.fits[direction]
        w = np.abs(data.speed[rows])
        if model == "quadratic":
            pred[rows] = f.parameters[0].value * data.speed[rows] * w
        else:
            c = [p.value for p in f.parameters]  # highest power first
            pred[rows] = s * np.polyval(c, w)
    groups = [np.flatnonzero(m & (sgn == s)) for s in (1.0, -1.0)]
    groups = [g for g in groups if g.size]
    reps, failed = [], 0
    for b in range(n_boot):
        rng = np.random.default_rng([int(seed), b])
        try:
            if kind == "residual":
                thrust = data.thrust.copy()
                for g in groups:
                    r = data.thrust[g] - pred[g]
                    p_ = len(sf.fits["forward" if data.speed[g[0]] > 0 else "reverse"].parameters)
                    rc = (r - r.mean()) * math.sqrt(g.size / max(g.size - p_, 1))
                    thrust[g] = pred[g] + rc[rng.integers(0, g.size, g.size)]
                db = replace(data, thrust=thrust)
            elif kind == "pairs":
                idx = np.concatenate([g[rng.integers(0, g.size, g.size)] for g in groups])
                db = data.subset(idx)
            else:
                raise ValueError("kind must be residual or pairs")
            v = flat(db)
            reps.append([v[n][0] for n in names])
        except (ValueError, KeyError, np.linalg.LinAlgError):
            failed += 1
    R = np.array(reps) if reps else np.zeros((0, len(names)))
    res = BootstrapResult(f"steady {model}" + (f" degree {degree}" if degree else ""), kind, names,
                          est, sd, R, failed, seed, time.perf_counter() - t0)
    return res


def bootstrap_physical(sheets, *, n_boot: int = 30, seed: int = 0, progress: bool | None = None,
                       **fit_kwargs) -> BootstrapResult:
    """Residual bootstrap of :func:`~uuvid.identify.thruster.physical.fit_physical` over bench sheets:
    thrust, speed and current residuals (per sheet and channel, measured rows) resampled onto the
    fitted model's predictions, every replicate refitted from scratch.  Slow (a full multi-start
    nonlinear fit per replicate, ~1–3 s)."""
    from uuvid.identify.thruster.physical import fit_physical

    sets = list(sheets)
    kw = {**fit_kwargs, "emit_warnings": False}
    full = fit_physical(sets, **kw)
    model = full.model
    preds = [model.predict(s.command, s.supply_voltage_array()) for s in sets]

    def resample(data, rng):
        out = []
        for s, p in zip(data, preds):
            m = s.measured
            new = {}
            for ch, pv in (("thrust", p.thrust), ("speed", p.speed), ("current", p.current)):
                v = getattr(s, ch)
                if v is None:
                    continue
                r = (v - pv)[m]
                r = r - r.mean()
                nv = v.copy()
                nv[m] = pv[m] + r[rng.integers(0, r.size, r.size)]
                new[ch] = nv
            out.append(replace(s, **new))
        return out

    res = bootstrap(lambda d: fit_physical(d, **kw).fit, sets, resample, n_boot=n_boot, seed=seed,
                    kind="residual", procedure="fit_physical", progress=progress)
    res.notes.append("parameters at a bound (K_e on its floor) have no meaningful LS σ; their "
                     "bootstrap spread shows how far the data let them move")
    return res


def comparison_table(results: Sequence[BootstrapResult]) -> pd.DataFrame:
    """One table for several bootstraps (``procedure`` and ``kind`` columns added)."""
    frames = []
    for r in results:
        t = r.table()
        t.insert(0, "kind", r.kind)
        t.insert(0, "procedure", r.procedure)
        t["n_boot"] = r.n_boot
        t["n_failed"] = r.n_failed
        frames.append(t)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


__all__ = ["BootstrapResult", "KINDS", "bootstrap", "bootstrap_drag", "bootstrap_inertia",
           "bootstrap_linear", "bootstrap_physical", "bootstrap_steady", "comparison_table"]
