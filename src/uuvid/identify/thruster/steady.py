"""Steady-state identification of a thruster from bench sweeps, per direction.

Forward means a command above neutral, reverse below it; every map is identified separately per
direction (propellers are not symmetric: the T200 gives 3.71 kgf forward and 2.92 kgf reverse at
12 V).  Rows marked ``censored`` in :class:`~uuvid.io.bench.BenchData` (readings the logger zeroed
under its detection limit) are *unknown*, never zeros: fits leave them out and region detection
reports the censored band as an outer bound.

Functions (each fit returns a :class:`SteadyFit` holding :class:`~uuvid.identify.fit.Fit` results
and, where one exists, the block it identifies as ``.block``):

    detect_regions_bench     dead zone and saturation onset per direction, from the data
    fit_quadratic_speed      ``T = K_T Ω|Ω|`` per direction (linear LS through the origin) → QuadraticMap
    fit_cv                   Caccia et al. 2000: ``T = c_V V|V|`` per direction → QuadraticMap
    polynomial_degree_table  ME, RMSE, k-fold CV RMSE, AIC, BIC for degrees 1…8 (Laidani Table 1)
    select_degree            one-standard-error (CV) or ΔBIC < 2 choice with a stated reason
    fit_polynomial           Laidani's ``|T| = Σ c_j |Ω|^j`` per direction → PolynomialMap
    fit_deadzone_curve       UUV Simulator's Bessa conversion (dead zone) by nonlinear LS → DeadZoneMap
    fit_table                averaged, monotone lookup table → TableMap (UUV Simulator LinearInterp)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from uuvid.core.result import Result, jsonable
from uuvid.identify.fit import Fit, Parameter, linear_lsq, nonlinear_lsq, residual_figure
from uuvid.identify.plausibility import check_bench_signs
from uuvid.identify.thruster.regions import Regions
from uuvid.io.bench import BenchData, BenchDataError, require_samples
from uuvid.thruster.blocks import Block, DeadZoneMap, PolynomialMap, QuadraticMap, TableMap

DIRECTIONS = ("forward", "reverse")
_SIGN = {"forward": 1.0, "reverse": -1.0}


# ------------------------------------------------------------------------------------------------
# Result type
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SteadyFit(Result):
    """Result of a steady identification: one :class:`Fit` per direction (or ``"all"``) + block."""

    model: str
    fits: dict[str, Fit]
    block: Block | None = None
    info: dict = field(default_factory=dict)

    def __getitem__(self, key: str) -> Fit:
        try:
            return self.fits[key]
        except KeyError:
            raise KeyError(f"{self.model}: no fit {key!r}; have {list(self.fits)}") from None

    @property
    def forward(self) -> Fit | None:
        return self.fits.get("forward")

    @property
    def reverse(self) -> Fit | None:
        return self.fits.get("reverse")

    @property
    def fit(self) -> Fit:
        """The single fit when there is one (``"all"``), else the forward one."""
        if "all" in self.fits:
            return self.fits["all"]
        if len(self.fits) == 1:
            return next(iter(self.fits.values()))
        return self.fits["forward"]

    @property
    def warnings(self) -> tuple[str, ...]:
        out = []
        for k, f in self.fits.items():
            out.extend(f"{k}: {w}" for w in f.warnings)
        out.extend(self.info.get("notes", ()))
        return tuple(out)

    report_title = "Steady thruster fit"

    def to_dict(self) -> dict:
        return jsonable({"model": self.model, "fits": {k: f.as_dict() for k, f in self.fits.items()},
                         "block": self.block.to_dict() if self.block is not None else None,
                         "info": self.info, "warnings": list(self.warnings)})

    def plot(self):
        """Residuals of each fit (forward / reverse / all)."""
        return residual_figure(self.fits, self.model, unit="N")  # every steady map gives thrust

    def summary(self) -> str:
        parts = [f"=== {self.model} ==="]
        for k, f in self.fits.items():
            parts.append(f"--- {k} ---")
            parts.append(f.summary())
        for n in self.info.get("notes", ()):
            parts.append(f"note: {n}")
        if self.block is not None:
            parts.append(f"block: {self.block!r}")
        return "\n".join(parts)

    def __str__(self) -> str:
        return self.summary()


def _direction_rows(data: BenchData, direction: str, need: Sequence[str]) -> np.ndarray:
    """Measured (uncensored) rows of one direction."""
    m = data.measured & (data.direction == _SIGN[direction])
    for name in need:
        a = getattr(data, name)
        m &= np.isfinite(a)
    return m


# ------------------------------------------------------------------------------------------------
# Regions
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BenchRegions:
    """Dead zone and saturation of a bench sweep (command units).

    ``dead_zone`` is the band around neutral where the signal is zero *or censored*; when an edge
    row is censored, ``dead_zone_censored`` says so and the band is only an outer bound (upper
    bound on the width) of the true dead zone, whose edge lies somewhere inside the censored rows.
    ``saturation`` is ``(reverse onset, forward onset)``, ``None`` where the data do not saturate.
    """

    dead_zone: tuple[float, float]
    saturation: tuple[float | None, float | None]
    dead_zone_censored: tuple[bool, bool] = (False, False)
    first_measured: tuple[float | None, float | None] = (None, None)
    signal: str = "thrust"
    notes: tuple[str, ...] = ()

    def as_regions(self) -> Regions:
        return Regions(dead_zone=self.dead_zone, saturation=self.saturation)

    def as_dict(self) -> dict:
        return {"dead_zone": list(self.dead_zone), "saturation": list(self.saturation),
                "dead_zone_censored": list(self.dead_zone_censored),
                "first_measured": list(self.first_measured), "signal": self.signal,
                "notes": list(self.notes)}


def _average_duplicates(c: np.ndarray, *ys: np.ndarray):
    uc, inv, counts = np.unique(c, return_inverse=True, return_counts=True)
    outs = []
    for y in ys:
        s = np.zeros(uc.size)
        np.add.at(s, inv, y)
        outs.append(s / counts)
    return uc, counts, outs


def detect_regions_bench(data: BenchData, neutral: float | None = None, *,
                         signal: str | None = None, tol: float | None = None,
                         saturation_tol: float = 0.02, slope_ratio: float = 0.25,
                         min_plateau: int = 3) -> BenchRegions:
    """Dead zone ``[low, high]`` and saturation onset per direction, read off the data.

    Parameters
    ----------
    signal
        ``thrust`` (default when present) or ``speed``.
    tol
        |signal| at or below which a measured row counts as zero (default 1e-6 of the largest).
    saturation_tol, slope_ratio, min_plateau
        Saturation starts at the command after which |signal| stays within ``saturation_tol`` of
        its extreme for at least ``min_plateau`` distinct commands *and* the plateau's slope is
        below ``slope_ratio`` times the median slope of the rest of that direction.
    """
    neutral = data.neutral if neutral is None else float(neutral)
    if signal is None:
        signal = "thrust" if data.thrust is not None else "speed"
    y_all = getattr(data, signal)
    if y_all is None:
        raise BenchDataError(f"{data.source or 'bench data'}: no {signal} data to detect regions")
    c_u, _, (y_u, cens_frac) = _average_duplicates(data.command, y_all,
                                                    data.censored.astype(float))
    cens_u = cens_frac > 0.5
    scale = float(np.max(np.abs(y_u[~cens_u]))) if np.any(~cens_u) else 0.0
    if scale == 0:
        raise BenchDataError(f"{data.source or 'bench data'}: the {signal} is zero or censored "
                             "everywhere; no regions to detect")
    tol = 1e-6 * scale if tol is None else float(tol)
    quiet = cens_u | (np.abs(y_u) <= tol)
    notes = []
    k0 = int(np.argmin(np.abs(c_u - neutral)))
    if not quiet[k0]:
        dz = (float(c_u[k0]), float(c_u[k0]))
        dz_cens = (False, False)
        lo = hi = k0
    else:
        lo = k0
        while lo > 0 and quiet[lo - 1]:
            lo -= 1
        hi = k0
        while hi < c_u.size - 1 and quiet[hi + 1]:
            hi += 1
        dz = (float(c_u[lo]), float(c_u[hi]))
        dz_cens = (bool(cens_u[lo]), bool(cens_u[hi]))
    first = (float(c_u[lo - 1]) if lo > 0 else None, float(c_u[hi + 1]) if hi < c_u.size - 1
             else None)
    for side, flag, edge, nxt in (("low", dz_cens[0], dz[0], first[0]),
                                  ("high", dz_cens[1], dz[1], first[1])):
        if flag:
            bound = "the end of the data" if nxt is None else f"{nxt:g} (first measured command)"
            notes.append(
                f"dead-zone {side} edge {edge:g} is censored: readings below the detection limit "
                f"were zeroed, so the motor may already turn inside the band; the true edge lies "
                f"between neutral ({neutral:g}) and {bound}, and [{dz[0]:g}, {dz[1]:g}] is an "
                f"upper bound on the true dead zone")

    def onset(idx: np.ndarray) -> float | None:
        idx = idx[~cens_u[idx]]
        if idx.size < min_plateau + 2:
            return None
        mag = np.abs(y_u[idx])
        peak = float(mag.max())
        if peak <= tol:
            return None
        ok = mag >= (1.0 - saturation_tol) * peak
        if not ok[-1]:
            return None
        k = idx.size - 1
        while k > 0 and ok[k - 1]:
            k -= 1
        plateau = idx[k:]
        if plateau.size < min_plateau or k < 2:
            return None
        cp, yp = c_u[plateau], np.abs(y_u[plateau])
        slope_p = abs(np.polyfit(cp, yp, 1)[0])
        rest = idx[:k + 1]
        slopes = np.abs(np.diff(np.abs(y_u[rest])) / np.diff(c_u[rest]))
        slopes = slopes[np.abs(y_u[rest][1:]) > tol]
        if slopes.size == 0:
            return None
        if slope_p > slope_ratio * float(np.median(slopes)):
            return None
        return float(c_u[plateau[0]])

    fwd = np.arange(hi + 1, c_u.size)
    rev = np.arange(lo - 1, -1, -1)
    sat = (onset(rev), onset(fwd))
    return BenchRegions(dead_zone=dz, saturation=sat, dead_zone_censored=dz_cens,
                        first_measured=first, signal=signal, notes=tuple(notes))


def _one_direction_note(direction: str, what: str) -> str:
    """What a fit without samples in ``direction`` writes: the other direction's map, mirrored —
    said as a warning (a forward-only sheet gave reverse thrust 27 % above a real T200's)."""
    other = "reverse" if direction == "forward" else "forward"
    return (f"no {direction} samples: the {direction} {what} is not identified — the model file "
            f"copies the {other} one, so {direction} thrust mirrors {other} (a propeller gives "
            f"less astern than ahead); measure {direction} runs too, or command this thruster "
            f"{other} only")


# ------------------------------------------------------------------------------------------------
# Quadratic maps
# ------------------------------------------------------------------------------------------------
def _quadratic_per_direction(x, y, d, *, names: dict, unit: str, model: str, source: str,
                             input_name: str, cov_type: str) -> tuple[dict, list]:
    fits, notes = {}, []
    for direction in DIRECTIONS:
        m = d == _SIGN[direction]
        n = int(m.sum())
        if n == 0:
            notes.append(_one_direction_note(direction, "coefficient"))
            continue
        require_samples(n, 1, f"{source}{model} ({direction})")
        H = (x[m] * np.abs(x[m]))[:, None]
        fits[direction] = linear_lsq(H, y[m], [names[direction]], units=[unit],
                                     model=f"{model} ({direction}, {n} samples)",
                                     cov_type=cov_type,
                                     extra={"direction": direction, "input": input_name,
                                            "residual_unit": "N"})
    if not fits:
        raise BenchDataError(f"{source}{model}: no usable samples in either direction")
    return fits, notes


def _quadratic_block(fits: dict, names: dict, notes: list, source: str = "") -> QuadraticMap:
    """The map of the per-direction fits.  A coefficient significantly below zero (thrust
    opposing the input: a reversed sign) raises; one within 2σ of zero is set to 0 with a note
    that the model gives no thrust in that direction (a warning in the fit's messages)."""
    k = {}
    for direction in DIRECTIONS:
        if direction not in fits:
            continue
        p = fits[direction][names[direction]]
        v = p.value
        if v < 0:
            if not (math.isfinite(p.stderr) and -v <= 2.0 * p.stderr):
                raise BenchDataError(
                    f"{source}{names[direction]} = {v:.4g} < 0: the {direction} thrust opposes the "
                    "input, so the fitted map would give no thrust. Expected: positive thrust "
                    "for a positive input. Fix: check the sign of the thrust column against the "
                    "speed/command columns (negate the reversed one)")
            notes.append(f"zero thrust {direction}: {names[direction]} = {v:.3g} is not "
                         "significantly above zero; set to 0, so the model gives no "
                         f"{direction} thrust (not identified from these data)")
            v = 0.0
        k[direction] = v
    kp, kn = k.get("forward"), k.get("reverse")
    kp = kn if kp is None else kp
    kn = kp if kn is None else kn
    return QuadraticMap(k_pos=kp, k_neg=kn)


def fit_quadratic_speed(data: BenchData, *, cov_type: str = "classical") -> SteadyFit:
    """``T = K_T Ω|Ω|`` per direction by linear LS through the origin → :class:`QuadraticMap`.

    The direction of a row is the sign of its speed (forward = positive).  Censored rows are
    left out.  ``cov_type`` as in :func:`linear_lsq` (``HC3`` when the noise grows with thrust).
    """
    data.require("thrust", "speed", what="fit_quadratic_speed")
    check_bench_signs(data)
    m = data.measured & (data.speed != 0)
    src = f"{data.source}: " if data.source else ""
    names = {"forward": "K_T_fwd", "reverse": "K_T_rev"}
    fits, notes = _quadratic_per_direction(data.speed[m], data.thrust[m], np.sign(data.speed[m]),
                                           names=names, unit="N·s²/rad²", model="T = K_T Ω|Ω|",
                                           source=src, input_name="speed", cov_type=cov_type)
    n_cens = int(data.censored.sum())
    if n_cens:
        notes.append(f"{n_cens} censored row(s) left out (readings below the detection limit)")
    block = _quadratic_block(fits, names, notes, src)
    return SteadyFit("T = K_T Ω|Ω| per direction", fits, block, {"notes": tuple(notes)})


def fit_cv(voltage, thrust, *, cov_type: str = "classical") -> SteadyFit:
    """Caccia et al. (2000): ``T = c_V V|V|`` per direction (positive/negative voltage).

    ROMEO: c_V = 1.02 N/V² (positive) and 1.09 N/V² (negative), percentile errors 3.0 %/3.7 %.
    Returns the fits (``c_V_fwd``, ``c_V_rev`` with σ and percentile errors) and a
    :class:`QuadraticMap` for a voltage-driven chain.
    """
    v = np.asarray(voltage, dtype=float).ravel()
    t = np.asarray(thrust, dtype=float).ravel()
    if v.shape != t.shape:
        raise BenchDataError(f"fit_cv: voltage has {v.size} samples, thrust has {t.size}")
    bad = np.flatnonzero(~np.isfinite(v) | ~np.isfinite(t))
    if bad.size:
        raise BenchDataError(f"fit_cv: sample {bad[0] + 1} (1-based) is not finite")
    m = v != 0
    names = {"forward": "c_V_fwd", "reverse": "c_V_rev"}
    fits, notes = _quadratic_per_direction(v[m], t[m], np.sign(v[m]), names=names, unit="N/V²",
                                           model="T = c_V V|V|", source="",
                                           input_name="voltage", cov_type=cov_type)
    block = _quadratic_block(fits, names, notes, "fit_cv: ")
    return SteadyFit("T = c_V V|V| per direction (Caccia et al. 2000)", fits, block,
                     {"notes": tuple(notes)})


# ------------------------------------------------------------------------------------------------
# Polynomials (Laidani et al. Table 1 and 2)
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DegreeTable(Result):
    """Laidani's Table 1, extended: one row per degree with in-sample and held-out errors."""

    rows: tuple[dict, ...]
    k: int
    n_samples: int
    x_scale: float
    notes: tuple[str, ...] = ()

    COLUMNS = ("degree", "n_params", "me", "rmse", "cv_rmse", "cv_se", "aic", "bic",
               "condition_number")

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self):
        return iter(self.rows)

    def __getitem__(self, i):
        return self.rows[i]

    def column(self, name: str) -> np.ndarray:
        return np.array([r[name] for r in self.rows], dtype=float)

    def row(self, degree: int) -> dict:
        for r in self.rows:
            if r["degree"] == degree:
                return r
        raise KeyError(f"degree {degree} is not in the table")

    def to_text(self) -> str:
        head = (f"{'degree':>6} {'ME':>10} {'RMSE':>10} {f'CV{self.k} RMSE':>11} {'±SE':>9} "
                f"{'AIC':>10} {'BIC':>10}")
        lines = [head]
        for r in self.rows:
            lines.append(f"{r['degree']:>6d} {r['me']:>10.4g} {r['rmse']:>10.4g} "
                         f"{r['cv_rmse']:>11.4g} {r['cv_se']:>9.2g} {r['aic']:>10.2f} "
                         f"{r['bic']:>10.2f}")
        return "\n".join(lines)

    report_title = "Polynomial degree selection"

    def summary(self) -> str:
        return "\n".join([self.to_text(), *(f"note: {n}" for n in self.notes)])

    def to_dict(self) -> dict:
        return jsonable({"rows": list(self.rows), "k": self.k, "n_samples": self.n_samples,
                         "x_scale": self.x_scale, "notes": list(self.notes)})

    def plot(self):
        """In-sample RMSE and k-fold CV RMSE (± SE) against the degree."""
        from uuvid.core.plots import new_figure

        fig, ax = new_figure(figsize=(6.4, 3.6))
        d = self.column("degree")
        ax.plot(d, self.column("rmse"), "o-", label="RMSE (in sample)")
        ax.errorbar(d, self.column("cv_rmse"), yerr=self.column("cv_se"), fmt="s--", capsize=3,
                    label=f"CV{self.k} RMSE")
        ax.set_xlabel("polynomial degree [–]")
        ax.set_ylabel("thrust RMSE [N]")
        ax.set_title(f"Degree selection: in-sample and {self.k}-fold CV error, "
                     f"{self.n_samples} samples", fontsize=10)
        ax.legend(fontsize=8)
        return fig


def _folds(x: np.ndarray, k: int) -> np.ndarray:
    """Deterministic folds: sort by x, deal the samples out in turn (each fold spans the range)."""
    order = np.argsort(x, kind="stable")
    f = np.empty(x.size, dtype=int)
    f[order] = np.arange(x.size) % k
    return f


def _vander(z: np.ndarray, degree: int, through_origin: bool) -> np.ndarray:
    V = np.vander(z, degree + 1)
    return V[:, :-1] if through_origin else V


def polynomial_degree_table(x, y, degrees: Iterable[int] = range(1, 9), *, k: int = 5,
                            through_origin: bool = False) -> DegreeTable:
    """ME (mean |e|), RMSE, k-fold CV RMSE (±SE over folds), AIC and BIC per polynomial degree.

    Laidani et al. choose a degree from ME and RMSE alone (their Table 1), which always favours
    the highest degree; the held-out RMSE and BIC do not.  Polynomials are fitted in the scaled
    variable ``x/max|x|`` (conditioning); folds are deterministic (sorted by x, dealt in turn).
    """
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise BenchDataError(f"x has {x.size} samples, y has {y.size}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise BenchDataError("polynomial_degree_table: x and y must be finite")
    degrees = sorted({int(d) for d in degrees})
    if not degrees or degrees[0] < 0:
        raise BenchDataError(f"degrees must be non-negative integers, got {degrees}")
    if k < 2:
        raise BenchDataError(f"k-fold cross-validation needs k >= 2, got {k}")
    n = x.size
    s = float(np.max(np.abs(x))) if n else 0.0
    if s == 0:
        raise BenchDataError("polynomial_degree_table: x is zero everywhere")
    z = x / s
    folds = _folds(x, k)
    rows, notes = [], []
    for d in degrees:
        p = d + (0 if through_origin else 1)
        n_train = int(min(np.sum(folds != j) for j in range(k)))
        if n_train < p + 1:
            if not rows and d == degrees[0]:
                raise BenchDataError(f"degree {d} polynomial ({p} parameters) with {k}-fold "
                                     f"cross-validation: {n_train} training sample(s) per fold "
                                     f"(of {n}); need at least {p + 1}")
            notes.append(f"degree {d} left out: {n_train} training samples per fold for {p} "
                         "parameters")
            continue
        V = _vander(z, d, through_origin)
        f = linear_lsq(V, y, [f"a{j}" for j in range(p)], emit_warnings=False,
                       model=f"degree {d}")
        e_cv = np.empty(n)
        fold_rmse = []
        for j in range(k):
            tr, te = folds != j, folds == j
            coef, *_ = np.linalg.lstsq(V[tr], y[tr], rcond=None)
            e = y[te] - V[te] @ coef
            e_cv[te] = e
            fold_rmse.append(float(np.sqrt(np.mean(e**2))))
        rows.append({"degree": d, "n_params": p, "me": f.mean_abs_error, "rmse": f.rmse,
                     "cv_rmse": float(np.sqrt(np.mean(e_cv**2))),
                     "cv_se": float(np.std(fold_rmse, ddof=1) / math.sqrt(k)),
                     "aic": f.aic(), "bic": f.bic(), "condition_number": f.condition_number})
    return DegreeTable(tuple(rows), k, n, s, tuple(notes))


@dataclass(frozen=True)
class DegreeChoice:
    degree: int
    criterion: str
    reason: str


def select_degree(table: DegreeTable, criterion: str = "cv") -> DegreeChoice:
    """Pick a degree with a parsimony rule and say why.

    ``cv``: the one-standard-error rule — the lowest degree whose k-fold CV RMSE is within one
    standard error (over folds) of the lowest CV RMSE.  ``bic``: the lowest degree whose BIC is
    within 2 of the minimum (ΔBIC < 2: no real evidence for the bigger model).
    """
    if criterion not in ("cv", "bic"):
        raise ValueError(f"criterion must be 'cv' or 'bic', got {criterion!r}")
    if not len(table):
        raise BenchDataError("empty degree table")
    deg = [r["degree"] for r in table.rows]
    if criterion == "cv":
        cv = table.column("cv_rmse")
        b = int(np.argmin(cv))
        thr = cv[b] + table.rows[b]["cv_se"]
        i = next(j for j in range(len(deg)) if cv[j] <= thr)
        if i == b:
            reason = f"degree {deg[i]}: lowest {table.k}-fold CV RMSE ({cv[i]:.4g})"
        else:
            reason = (f"degree {deg[i]}: {table.k}-fold CV RMSE {cv[i]:.4g} is within one "
                      f"standard error of the lowest ({cv[b]:.4g} ± {table.rows[b]['cv_se']:.2g} "
                      f"at degree {deg[b]}) — one-standard-error rule")
    else:
        bic = table.column("bic")
        b = int(np.argmin(bic))
        i = next(j for j in range(len(deg)) if bic[j] <= bic[b] + 2.0)
        if i == b:
            reason = f"degree {deg[i]}: lowest BIC ({bic[i]:.2f})"
        else:
            reason = (f"degree {deg[i]}: BIC {bic[i]:.2f} within 2 of the lowest ({bic[b]:.2f} at "
                      f"degree {deg[b]}) — no real evidence for the larger model")
    if i + 1 < len(deg):
        r0, r1 = table.rows[i], table.rows[i + 1]
        imp = 100.0 * (1.0 - r1["rmse"] / r0["rmse"]) if r0["rmse"] > 0 else 0.0
        cimp = 100.0 * (1.0 - r1["cv_rmse"] / r0["cv_rmse"]) if r0["cv_rmse"] > 0 else 0.0
        reason += (f"; degree {deg[i + 1]} improves in-sample RMSE by only {imp:.1f} % and "
                   f"CV RMSE by {cimp:.1f} %" if imp < 5 else
                   f"; degree {deg[i + 1]} improves in-sample RMSE by {imp:.1f} % (CV RMSE by "
                   f"{cimp:.1f} %), not enough out of sample")
    return DegreeChoice(deg[i], criterion, reason)


def _poly_fit_original(x: np.ndarray, y: np.ndarray, degree: int, direction: str,
                       input_name: str, unit_x: str) -> Fit:
    s = float(np.max(np.abs(x)))
    z = x / s
    powers = list(range(degree, -1, -1))
    names = [f"c{j}" for j in powers]
    fs = linear_lsq(np.vander(z, degree + 1), y, names, emit_warnings=True,
                    model=f"degree {degree} in x/{s:.6g}")
    D = np.array([s ** (-j) for j in powers])
    vals = np.array([p.value for p in fs.parameters]) * D
    cov = fs.covariance * np.outer(D, D)
    units = [f"N/({unit_x})^{j}" if j > 1 else (f"N/({unit_x})" if j == 1 else "N")
             for j in powers]
    params = tuple(Parameter(nm, float(v), float(math.sqrt(max(cov[i, i], 0.0))), units[i])
                   for i, (nm, v) in enumerate(zip(names, vals)))
    extra = dict(fs.extra)
    extra.update({"direction": direction, "input": input_name, "x_scale": s, "residual_unit": "N",
                  "scaled_coefficients": [p.value for p in fs.parameters],
                  "note": "fitted in x/x_scale; condition number is that of the scaled design"})
    return Fit(f"|T| = Σ c_j |{input_name}|^j, degree {degree} ({direction}, {x.size} samples)",
               params, cov, fs.residuals, fs.n_samples, fs.condition_number, fs.warnings, extra)


def _below_data_sign(coef, x_min: float, y_max: float, direction: str) -> list[str]:
    """A sentence (a warning) when ``|T| = P(|Ω|)`` (highest power first) turns negative between
    0 and the slowest measured speed: every thruster passes through there, and the fitted
    polynomial pushed the wrong way below the data (−0.13 N at 1 rad/s forward, silently)."""
    w = np.linspace(0.0, x_min, 64)
    p = np.polyval(np.asarray(coef, float), w)
    j = int(np.argmin(p))
    if p[j] >= -1e-3 * max(y_max, 1e-12):
        return []
    wrong = w[p < 0]
    return [f"wrong-sign thrust below the data: the {direction} polynomial gives {p[j]:.3g} N at "
            f"{w[j]:.3g} rad/s (negative from {wrong.min():.3g} to {wrong.max():.3g} rad/s, "
            f"below the slowest measured {x_min:.3g} rad/s): a lower --degree or --model "
            "quadratic holds the sign through zero"]


def fit_polynomial(data: BenchData, degree: int | None = None, *, criterion: str = "cv",
                   degrees: Iterable[int] = range(1, 9), k: int = 5) -> SteadyFit:
    """Laidani's per-direction polynomial ``|T| = Σ c_j |Ω|^j`` → :class:`PolynomialMap`.

    With ``degree=None`` each direction's degree is chosen by :func:`select_degree` on its
    :func:`polynomial_degree_table` (tables and reasons in ``info``).  Coefficients are returned
    in the original units (N per (rad/s)^j), highest power first.
    """
    data.require("thrust", "speed", what="fit_polynomial")
    check_bench_signs(data)
    fits, info, coefs = {}, {"tables": {}, "choices": {}, "notes": []}, {}
    for direction in DIRECTIONS:
        m = data.measured & (np.sign(data.speed) == _SIGN[direction])
        x, y = np.abs(data.speed[m]), np.abs(data.thrust[m])
        if x.size == 0:
            info["notes"].append(_one_direction_note(direction, "polynomial"))
            continue
        d = degree
        if d is None:
            try:
                tab = polynomial_degree_table(x, y, degrees, k=k)
            except BenchDataError as e:  # too few levels to choose a degree: say where, and how
                raise BenchDataError(f"{data.source or 'bench data'}: {direction} ({x.size} "
                                     f"sample(s) at non-zero speed): choosing the degree: {e} — "
                                     "record more levels in this direction, or give the degree "
                                     "(degree=, --degree)") from None
            ch = select_degree(tab, criterion)
            info["tables"][direction] = tab
            info["choices"][direction] = ch
            d = ch.degree
        require_samples(x.size, d + 1, f"{data.source or 'bench data'}: degree {d} polynomial "
                                       f"({direction})")
        f = _poly_fit_original(x, y, d, direction, "Ω", "rad/s")
        fits[direction] = f
        coefs[direction] = tuple(p.value for p in f.parameters)
        info["notes"] += _below_data_sign(coefs[direction], float(x.min()), float(y.max()),
                                          direction)
    if not fits:
        raise BenchDataError(f"{data.source or 'bench data'}: no usable samples for a polynomial")
    fwd = coefs.get("forward", coefs.get("reverse"))
    rev = coefs.get("reverse", coefs.get("forward"))
    info["notes"] = tuple(info["notes"])
    return SteadyFit("|T| = P(|Ω|) per direction (Laidani et al.)", fits,
                     PolynomialMap(forward=fwd, reverse=rev), info)


# ------------------------------------------------------------------------------------------------
# Dead-zone conversion (UUV Simulator "Bessa") and lookup table ("LinearInterp")
# ------------------------------------------------------------------------------------------------
def _deadzone_eval(theta, b):
    cl, cr, dl, dr = theta
    return np.where(b <= dl, cl * (b - dl), np.where(b >= dr, cr * (b - dr), 0.0))


def fit_deadzone_curve(data: BenchData, *, input: str = "command") -> SteadyFit:
    """UUV Simulator's Bessa conversion ``T = c_{L,R}(x|x| − δ_{L,R})`` by nonlinear LS.

    ``input="command"``: ``x = command − neutral`` (so the block expects the command relative to
    neutral; for duty or volts with neutral 0 that is the command itself).  ``input="speed"``:
    ``x`` = propeller speed [rad/s].  Censored rows are left out.
    """
    data.require("thrust", what="fit_deadzone_curve")
    check_bench_signs(data)
    if input == "command":
        x = data.command - data.neutral
        unit = data.command_unit
    elif input == "speed":
        data.require("speed", what="fit_deadzone_curve(input='speed')")
        x = data.speed
        unit = "rad/s"
    else:
        raise ValueError(f"input must be 'command' or 'speed', got {input!r}")
    m = data.measured
    x, t = x[m], data.thrust[m]
    require_samples(x.size, 4, f"{data.source or 'bench data'}: dead-zone conversion")
    b = x * np.abs(x)
    if not (np.any(b > 0) and np.any(b < 0)):
        raise BenchDataError(f"{data.source or 'bench data'}: the dead-zone conversion needs "
                             "samples on both sides of neutral")
    # start: dead zone from the quiet rows, gains by LS on each side
    scale_t = float(np.max(np.abs(t)))
    quiet = np.abs(t) <= 1e-3 * scale_t
    dl0 = float(np.min(b[quiet & (b <= 0)])) if np.any(quiet & (b <= 0)) else 0.0
    dr0 = float(np.max(b[quiet & (b >= 0)])) if np.any(quiet & (b >= 0)) else 0.0
    # with censored rows removed the quiet band is empty: start halfway into the gap
    if dl0 == 0.0 and np.any(b < 0):
        dl0 = 0.5 * float(np.max(b[b < 0]))
    if dr0 == 0.0 and np.any(b > 0):
        dr0 = 0.5 * float(np.min(b[b > 0]))
    sel_r, sel_l = b > dr0, b < dl0
    cr0 = float(np.sum(t[sel_r] * (b[sel_r] - dr0)) / max(np.sum((b[sel_r] - dr0) ** 2), 1e-300))
    cl0 = float(np.sum(t[sel_l] * (b[sel_l] - dl0)) / max(np.sum((b[sel_l] - dl0) ** 2), 1e-300))
    bs = float(np.max(np.abs(b)))

    def resid(th):
        return _deadzone_eval(th, b) - t

    lo = [0.0, 0.0, float(b.min()), 0.0]
    hi = [np.inf, np.inf, 0.0, float(b.max())]
    x0 = np.clip([max(cl0, 1e-12), max(cr0, 1e-12), dl0, dr0], lo, hi)
    xu = f"({unit})²"
    f = nonlinear_lsq(resid, x0, ["rotor_constant_l", "rotor_constant_r", "delta_l", "delta_r"],
                      units=[f"N/{xu}", f"N/{xu}", xu, xu], bounds=(lo, hi),
                      x_scale=np.array([max(abs(cl0), 1e-12), max(abs(cr0), 1e-12), bs, bs]),
                      model="T = c(x|x| − δ) outside [δ_L, δ_R], x = "
                            + ("command − neutral" if input == "command" else "Ω"),
                      extra={"input": input, "neutral": data.neutral if input == "command" else 0.0,
                             "residual_unit": "N"})
    v = f.values
    block = DeadZoneMap(rotor_constant_l=v["rotor_constant_l"], rotor_constant_r=v["rotor_constant_r"],
                        delta_l=min(v["delta_l"], v["delta_r"]), delta_r=v["delta_r"])
    notes = []
    if data.censored.any():
        notes.append(f"{int(data.censored.sum())} censored row(s) left out: the dead-zone widths "
                     "are extrapolated from the measured rows")
    if input == "command" and data.neutral != 0:
        notes.append(f"the block's input is the command relative to neutral "
                     f"(command − {data.neutral:g})")
    miss = _deadzone_misses(x, t, block, data.neutral if input == "command" else 0.0,
                            "command" if input == "command" else "speed", unit)
    if miss:
        notes.append(miss)
    return SteadyFit("UUV Simulator Bessa conversion (dead zone)", {"all": f}, block,
                     {"notes": tuple(notes)})


#: Relative error of the fitted thrust at a side's largest input above which the dead-zone family
#: is said to miss the data (the T200 sheet: +13 % at full forward and reverse).
DEADZONE_END_TOLERANCE = 0.05


def _deadzone_misses(x, t, block, offset: float, what: str, unit: str) -> str | None:
    """``lack of fit: …`` when ``T = c(x|x| − δ)`` misses the data materially: its thrust at a
    side's largest input is more than :data:`DEADZONE_END_TOLERANCE` off the measured mean there,
    or the data have a measured zero-thrust band that the fit does not reproduce (both δ at 0)."""
    parts = []
    unit = {"pwm_us": "µs"}.get(unit, unit)
    for sel, end in ((x > 0, np.max), (x < 0, np.min)):
        if not np.any(sel):
            continue
        xe = float(end(x[sel]))
        meas = float(np.mean(t[x == xe]))
        fit = float(block.thrust(np.array([xe]))[0])
        if abs(meas) > 0 and abs(fit - meas) > DEADZONE_END_TOLERANCE * abs(meas):
            parts.append(f"at {what} {xe + offset:g} {unit} it gives {fit:.4g} N against "
                         f"{meas:.4g} N measured ({100 * (abs(fit) - abs(meas)) / abs(meas):+.0f} % in "
                         "magnitude)")
    floor = 1e-3 * float(np.max(np.abs(t)))
    quiet = (np.abs(t) <= floor) & (x != 0)
    # a band the fit misses: its thrust there well above what the data call zero (a δ = 0 map
    # also gives next to nothing close to neutral, where exact data are quiet too)
    missed = np.any(quiet) and float(np.max(np.abs(block.thrust(x[quiet])))) > 3.0 * floor
    if missed and block.delta_l == 0 and block.delta_r == 0:
        lo, hi = float(np.min(x[quiet])) + offset, float(np.max(x[quiet])) + offset
        parts.append(f"the data's zero-thrust band ({what} {lo:g}…{hi:g} {unit}) is not "
                     "reproduced (δ_L = δ_R = 0, at their bound: the map gives thrust there)")
    if not parts:
        return None
    return ("lack of fit: T = c(x|x| − δ) does not follow this data — " + "; ".join(parts)
            + ". The family is wrong for it: use --model table (the measured curve) or --model "
            "physical (speed, current and voltage columns)")


def _isotonic(y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Pool-adjacent-violators: the weighted least-squares non-decreasing fit."""
    vals, wts, lens = [], [], []
    for yi, wi in zip(y, w):
        vals.append(float(yi))
        wts.append(float(wi))
        lens.append(1)
        while len(vals) > 1 and vals[-2] > vals[-1]:
            v2, w2, l2 = vals.pop(), wts.pop(), lens.pop()
            v1, w1, l1 = vals.pop(), wts.pop(), lens.pop()
            vals.append((v1 * w1 + v2 * w2) / (w1 + w2))
            wts.append(w1 + w2)
            lens.append(l1 + l2)
    return np.repeat(vals, lens)


def _greedy_knots(x: np.ndarray, y: np.ndarray, n: int) -> np.ndarray:
    """Indices of ``n`` knots (ends included) chosen by repeatedly adding the worst-fit point."""
    keep = {0, x.size - 1}
    while len(keep) < n:
        ks = np.array(sorted(keep))
        err = np.abs(np.interp(x, x[ks], y[ks]) - y)
        err[ks] = -1.0
        j = int(np.argmax(err))
        if err[j] <= 0:
            break
        keep.add(j)
    return np.array(sorted(keep))


#: a lookup table whose knots miss the data by more than this fraction of the largest |thrust|
TABLE_MISS = 0.05


def _table_warnings(xi, yi, c, t, resid, unit: str) -> list[str]:
    """Sentences (warnings) for a table that cannot be what the data say: it reaches only one
    direction (beyond its commands it holds its end values: every reverse command gave 0 N), or
    its knots (fewer than the commands) miss the mean thrust ``t`` at a command ``c`` by more than
    :data:`TABLE_MISS` of the largest thrust (2 knots gave 5.8 N at neutral, where the sheet has
    its dead band); ``resid``: those misses (empty when every command is a knot)."""
    out = []
    unit = {"pwm_us": "µs", "": ""}.get(unit, unit)
    unit = f" {unit}" if unit else ""
    tiny = 0.02 * float(np.max(np.abs(yi)))  # a sheet's noise about zero is no reverse thrust
    if yi[0] >= -tiny or yi[-1] <= tiny:
        side, end = ("reverse", yi[0]) if yi[0] >= -tiny else ("forward", yi[-1])
        out.append(f"the table's commands span {xi[0]:g}…{xi[-1]:g}{unit} with thrust of one sign "
                   f"only: the {side} thrust is not identified, and beyond its ends the table "
                   f"holds its end values (every {side} command gives {end:.3g} N)")
    scale = float(np.max(np.abs(t))) if t.size else 0.0
    if scale > 0 and resid.size:
        j = int(np.argmax(np.abs(resid)))
        if abs(resid[j]) > TABLE_MISS * scale:
            out.append(f"the table's {xi.size} knots miss the data by up to {abs(resid[j]):.3g} N "
                       f"(at {c[j]:g}{unit}), {100 * abs(resid[j]) / scale:.0f} % of the largest "
                       "thrust: give more --table-points (or all: leave it out)")
    return out


def fit_table(data: BenchData, n_points: int | None = None, *, monotone: bool = True,
              censored: str = "zero") -> SteadyFit:
    """Lookup table command → thrust (UUV Simulator ``LinearInterp``) → :class:`TableMap`.

    Duplicate commands are averaged (σ of each entry = spread/√count where repeated).  With
    ``monotone`` the thrust is made non-decreasing in the command (weighted isotonic regression),
    so the table can be inverted by an allocator.  ``n_points`` keeps that many knots, chosen
    greedily where linear interpolation errs most (ends always kept).  ``censored="zero"`` keeps
    censored rows at the sheet's zero (the table then shows the logger's dead band);
    ``"drop"`` leaves them out.
    """
    data.require("thrust", what="fit_table")
    check_bench_signs(data)
    if censored not in ("zero", "drop"):
        raise ValueError(f"censored must be 'zero' or 'drop', got {censored!r}")
    m = np.ones(len(data), dtype=bool) if censored == "zero" else data.measured
    c, t = data.command[m], data.thrust[m]
    if censored == "zero":
        t = np.where(data.censored[m], 0.0, t)
    require_samples(np.unique(c).size, 2, f"{data.source or 'bench data'}: lookup table "
                                          "(distinct commands)")
    uc, counts, (mean_t, mean_t2) = _average_duplicates(c, t, t * t)
    var = np.where(counts > 1, (mean_t2 - mean_t**2) * counts / np.maximum(counts - 1, 1), np.nan)
    se = np.sqrt(np.clip(var, 0, None) / counts)
    notes = []
    vals = mean_t
    if monotone:
        iso = _isotonic(mean_t, counts.astype(float))
        moved = np.abs(iso - mean_t)
        if moved.max() > 0:
            notes.append(f"isotonic adjustment moved {int(np.sum(moved > 0))} entr(y/ies) by up to "
                         f"{moved.max():.4g} N to make thrust non-decreasing in the command")
        vals = iso
    idx = np.arange(uc.size)
    if n_points is not None:
        if int(n_points) < 2:
            raise BenchDataError(f"n_points = {n_points} (--table-points): expected at least 2 "
                                 "knots")
        if n_points < uc.size:
            idx = _greedy_knots(uc, vals, int(n_points))
        elif n_points > uc.size:
            notes.append(f"{int(n_points):,} knots asked for, but the data have {uc.size} distinct "
                         f"commands: the table keeps all {uc.size}")
    xi, yi, si = uc[idx], vals[idx], se[idx]
    # the knots against the table of every command (its means): the scatter of repeats is no miss
    miss = vals - np.interp(uc, xi, yi) if idx.size < uc.size else np.zeros(0)
    nu = float(data.neutral)
    added = not xi[0] <= nu <= xi[-1]
    if added:  # one-sided data: the table held its first row's thrust down to neutral and beyond
        at = 0 if nu < xi[0] else xi.size
        # a load cell's offset in the dead band (−0.05 N next to the knot) would break the
        # monotone table: the data side keeps its sign
        yi = np.maximum(yi, 0.0) if at == 0 else np.minimum(yi, 0.0)
        xi, yi, si = np.insert(xi, at, nu), np.insert(yi, at, 0.0), np.insert(si, at, 0.0)
        unit = {"pwm_us": " µs"}.get(data.command_unit or "", f" {data.command_unit or ''}".rstrip())
        notes.append(f"the data hold no command at or across the neutral {nu:g}{unit}: the knot "
                     f"T({nu:g}) = 0 is added (no thrust at neutral), so commands between it and "
                     "the data interpolate from zero instead of holding the nearest row's thrust")
    notes += _table_warnings(xi, yi, uc, vals, miss, data.command_unit or "")
    block = TableMap(input_values=tuple(xi), output_values=tuple(yi))
    resid = t - np.interp(c, xi, yi)
    params = tuple(Parameter(f"T({x:g})", float(y), float(s), "N", fixed=added and x == nu)
                   for x, y, s in zip(xi, yi, si))
    cov = np.diag(si ** 2)
    n_cens = int(data.censored.sum())
    if n_cens and censored == "zero":
        notes.append(f"{n_cens} censored row(s) kept at zero thrust (below the detection limit)")
    once = int(np.sum(counts[idx] < 2))
    counts_kept = (np.insert(counts[idx], at, 0) if added else counts[idx]).tolist()
    if once:
        notes.append(f"σ unknown (no repeats) for {once} of {idx.size} table entries: an entry's σ "
                     "comes from repeated measurements at its command")
    f = Fit(f"lookup table command → thrust ({xi.size} knots)", params, cov, resid, int(c.size),
            math.nan, (), {"command_unit": data.command_unit, "counts": counts_kept})
    return SteadyFit("lookup table (UUV Simulator LinearInterp)", {"all": f}, block,
                     {"notes": tuple(notes)})


__all__ = ["SteadyFit", "BenchRegions", "DegreeTable", "DegreeChoice", "detect_regions_bench",
           "fit_quadratic_speed", "fit_cv", "polynomial_degree_table", "select_degree",
           "fit_polynomial", "fit_deadzone_curve", "fit_table"]
