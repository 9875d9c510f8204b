"""Output error over windows, shared by the per-DOF and the coupled horizontal dive fits.

* :func:`levenberg_marquardt` — the minimiser (small dense problems, normal equations);
* :func:`covariance` — σ and correlations: the larger of ``s²(JᵀJ)⁻¹`` and a window-cluster
  sandwich, nuisance initial states included;
* :func:`correlation_warnings` — parameters a dive cannot separate (|ρ| > 0.95);
* :func:`not_identifiable` — parameters the dive gives no information on (σ = ∞);
* :func:`noise_sigma` — a channel's measurement noise from its own samples
  (:func:`uuvid.simulate.dive_horizontal.noise_sigma`);
* :func:`dead_band_weights` — the weight rule for residuals whose force comes from thrusters
  at the dead band's edge (see its docstring).
"""

from __future__ import annotations

import math

import numpy as np

from uuvid.simulate.dive_horizontal import noise_sigma

__all__ = ["levenberg_marquardt", "covariance", "not_identifiable", "correlation_warnings",
           "noise_sigma", "dead_band_weights", "weighting_summary", "weighting_text", "DOWN_WEIGHTED"]

#: a residual sample counts as down-weighted below this weight
DOWN_WEIGHTED = 0.9


#: converged when the Gauss–Newton step still to go would lower the cost by less than this times
#: the residual variance s²: the estimates are then within √1e-8 = 1e-4 σ of the minimum (the
#: step's length in the metric of their covariance), whatever their units
CONVERGED = 1e-8


def levenberg_marquardt(resid, jac, z0, free, max_iter: int = 100, positive=(0,),
                        nonneg=(), tol: float = CONVERGED) -> dict:
    """Minimise ``|resid(z)|²`` over the ``free`` entries: Levenberg–Marquardt (Marquardt-scaled
    damping, normal equations: few parameters, no SVD of the tall Jacobian; ``jac(z)`` dense, or
    SciPy sparse when each row touches few of them) on the Gauss–Newton matrix ``JᵀJ`` plus a
    secant estimate ``S`` of the residuals' curvature ``Σ rᵢ ∇²rᵢ`` (Dennis, Gay & Welsch 1981,
    ACM TOMS 7(3), NL2SOL's update and sizing; used when it predicted the last step's decrease
    better than ``JᵀJ`` alone).  A dive's output error has large residuals (windows the model
    cannot follow, a force logged at 2 Hz): there plain Gauss–Newton converges only linearly,
    zig-zagging along the mass and the drags.

    Converged when the Gauss–Newton step still to go would lower the cost by less than ``tol``
    times the residual variance ``s² = cost/(N − free)`` (the estimates then sit within
    ``√tol`` of their σ of the minimum: a test on the gradient, in the units of the estimates'
    own uncertainty — not on how little one damped step happened to gain).  A trial step that
    makes an entry of ``positive`` (indices: masses, inertias) ≤ 0, or whose residuals are not
    finite, is refused; entries of ``nonneg`` (drag coefficients) are projected onto ≥ 0 (a
    negative drag feeds energy in: a model that blows up on replay, or that a vehicle file, which
    clips it to 0, would turn into another model), and one at 0 whose gradient points below it is
    held there for the step (the active set: a projected step in its direction would only
    shorten the others')."""
    z = np.array(z0, float)
    free = np.asarray(free, bool)
    nn = np.zeros(z.size, bool)
    nn[list(nonneg)] = True
    pos = list(positive)
    n_free = int(np.count_nonzero(free))

    def cost_of(r):
        c = float(r @ r)
        return c if math.isfinite(c) else math.inf

    with np.errstate(over="ignore", invalid="ignore"):
        r = resid(z)
        cost = cost_of(r)
        J = jac(z)
        g_all = J.T @ np.where(np.isfinite(r), r, 0.0)
        JtJ = None
        S = np.zeros((z.size, z.size))
        use_s = False
        lam, msg, ok, it = 1e-3, "maximum iterations", False, 0
        for it in range(1, max_iter + 1):  # noqa: B007  (returned as nit)
            act = free & ~(nn & (z <= 0) & (g_all > 0))
            if JtJ is None:
                JtJ = _gram(J)
            A = JtJ[np.ix_(act, act)]
            g = g_all[act]
            D = np.maximum(np.diag(A), 1e-12 * max(float(np.max(np.diag(A), initial=0.0)), 1e-300))
            s2 = cost / max(r.size - n_free, 1)
            try:
                gn = np.linalg.solve(A + 1e-12 * np.diag(D), -g)
                to_go = float(-g @ gn)
            except np.linalg.LinAlgError:
                to_go = math.inf
            if math.isfinite(cost) and to_go <= tol * s2:
                msg, ok = "converged", True
                break
            B = A + S[np.ix_(act, act)] if use_s else A
            improved = False
            while lam < 1e12:
                try:
                    L = np.linalg.cholesky(B + lam * np.diag(D))
                    step = -np.linalg.solve(L.T, np.linalg.solve(L, g))
                except np.linalg.LinAlgError:  # (B + λD not positive definite: more damping)
                    lam = max(lam, 1e-6) * 4
                    continue
                zn = z.copy()
                zn[act] += step
                zn[nn] = np.maximum(zn[nn], 0.0)
                if np.any(zn[pos] <= 0):
                    lam = max(lam, 1e-6) * 4
                    continue
                rn = resid(zn)
                cn = cost_of(rn)
                if cn < cost:
                    improved = True
                    break
                lam = max(lam, 1e-6) * 4
            if not improved:
                # (an infinite cost — a replay refused at the start — is never "converged")
                msg, ok = "no step lowers the cost", math.isfinite(cost) and to_go <= 1e4 * tol * s2
                if ok:
                    msg = "no further decrease (at the optimiser's resolution)"
                break
            Jn = jac(zn)
            gn_all = Jn.T @ rn
            # the structured secant update of S (NL2SOL: y# = (J₊ − J)ᵀ r₊, sized, rank two), and
            # which model — JᵀJ or JᵀJ + S — predicted this step's actual decrease better
            sv = zn - z
            Js = J @ sv
            drop = cost - cn
            pred_gn = -(2 * float(g_all @ sv) + float(Js @ Js))
            pred_s = pred_gn - float(sv @ S @ sv)
            use_s = abs(pred_s - drop) < abs(pred_gn - drop)
            y = gn_all - g_all
            ys = float(y @ sv)
            if ys > 0:
                yh = (Jn - J).T @ rn
                sSs = float(sv @ S @ sv)
                if sSs != 0:
                    S *= min(1.0, abs(float(sv @ yh)) / abs(sSs))
                w = yh - S @ sv
                S += (np.outer(w, y) + np.outer(y, w)) / ys - float(w @ sv) * np.outer(y, y) / ys ** 2
            z, r, cost, J, g_all, JtJ = zn, rn, cn, Jn, gn_all, None
            lam = max(lam / 3, 1e-9)
    return {"x": z, "fun": r, "jac": J, "success": ok, "message": msg, "nit": it}


def _gram(J) -> np.ndarray:
    """``JᵀJ`` as a dense array; ``J`` dense or a SciPy sparse matrix (a dive's Jacobian: each
    row touches the few global parameters and its own window's start — the product is then a
    small fraction of the dense one's cost)."""
    A = J.T @ J
    return A.toarray() if hasattr(A, "toarray") else np.asarray(A)


def share_of_value(sigma: float, value: float) -> str:
    """``"53 % of the value"``; a σ beyond 100× the value as ``"2.3e+17× the value"`` (an
    18-digit percentage was printed)."""
    r = abs(sigma / value)
    return f"{100 * r:.0f} % of the value" if r < 100 else f"{r:.2g}× the value"


def best_starts(cost, candidates, keep: int = 2) -> list:
    """``[(cost, candidate)]`` to refine, cheapest first: the first candidate — the data's own
    start value — and, when they cost less than it, up to ``keep − 1`` of the others (all of
    them ranked by ``cost(candidate)``; a start whose simulation blows up costs ∞).  When the
    data's own start is the cheapest, it alone is refined."""
    scored = []
    with np.errstate(over="ignore", invalid="ignore"):
        for c in candidates:
            v = float(cost(c))
            scored.append((v if math.isfinite(v) else math.inf, c))
    first = scored[0]
    better = sorted((x for x in scored[1:] if x[0] < first[0]), key=lambda x: x[0])
    out = better[:keep - 1] + ([first] if math.isfinite(first[0]) else better[keep - 1:keep])
    return sorted(out, key=lambda x: x[0]) or [first]


BLOWN_UP = 1e6  # a residual change this large from a 1e-6 relative perturbation: the replay blew up


def blown_windows(delta, groups, n_windows: int):
    """``(delta, blown)``: residual changes ``delta`` (rows, or rows × perturbations) of a
    forward-difference Jacobian with every window in which a perturbed replay blew up set to 0
    for that perturbation, and the boolean mask of those windows.

    A window blows up when a change is not finite or beyond :data:`BLOWN_UP` (outputs are metres,
    radians, m/s): an explicit RK4 step near its stability limit (stiff drag at speed) turns a
    1e-6 nudge into an overflow, and the finite entries before the overflow (1e270 was seen) are
    as meaningless as the inf after it, and would overflow ``JᵀJ``.  Such a window gives no
    information in that direction."""
    d = np.asarray(delta, float)
    d2 = d.reshape(d.shape[0], -1)
    with np.errstate(invalid="ignore"):
        bad = ~(np.abs(d2) <= BLOWN_UP)
    if not bad.any():
        return d, np.zeros(n_windows, bool)
    per = np.stack([np.bincount(groups, weights=bad[:, k], minlength=n_windows) > 0
                    for k in range(d2.shape[1])], axis=1)
    out = np.where(per[groups], 0.0, d2).reshape(d.shape)
    return out, per.any(axis=1)


def _left_out_residuals(Jg, Ainv, rg, floor: float):
    """A window's residuals as if the fit had left it out, ``(I − H_gg)⁺ r_g`` with
    ``H_gg = J_g (JᵀJ)⁺ J_gᵀ`` its block of the hat matrix (MacKinnon & White 1985, J. Econometrics
    29, the jackknife "CR3" form; Bell & McCaffrey 2002).  A window's own start (position and
    speed, nuisance parameters) fits part of its error away: the plain residuals under-state it,
    most where a window's error looks like a start that is off (a force sampled between its
    logged values).  The start's own directions (eigenvalue 0 of ``I − H_gg``: the residuals are
    orthogonal to them) carry nothing: eigenvalues below ``floor`` (which grows with the
    condition of ``JᵀJ``, whose round-off leaves a start's zero at ~ε·cond) are cut."""
    M = np.eye(Jg.shape[0]) - Jg @ Ainv @ Jg.T
    w, V = np.linalg.eigh(0.5 * (M + M.T))
    keep = w > floor
    return V[:, keep] @ ((V[:, keep].T @ rg) / w[keep])


#: a held-out rms this much above the base vehicle's (ratio base/identified below it) makes an
#: estimate not a model to use: the base predicts the rest of the dive better (more than 11 %
#: worse; a base about as good may come out a little ahead by chance)
HELD_OUT_WORSE = 0.9


#: an inertia (mass, moment of inertia) whose σ exceeds this × its value is not determined: it
#: lies within half a σ of 0, and a model built on it is a guess (a depth spike gave σ ×10⁴).
#: Above 0.5 it is a warning ("poorly determined"); the built-in example's yaw from 220 s of a
#: dive whose force is logged at 2 Hz comes out at 1.2 and still predicts the rest better than
#: the preset
INERTIA_SIGMA_MAX = 2.0
#: an in-sample replay whose error is this large a part of the channel's own spread (nrmse, rms
#: error / std of the measured channel) explains nothing of it — under 10 % of its variance
#: (1 − 0.95²); the replays restart every window from the measured state, so a usable model is
#: far below (0.05–0.3 on the project's dives)
NRMSE_USELESS = 0.95


def not_finite_reasons(names, values: dict, sigma: dict, labels: dict | None = None) -> list:
    """The reasons an estimate is no model to use that its numbers show: values that are not
    finite, σ that are not (a parameter this log does not determine); ``labels`` name the
    parameters (``{"mass": "inertia"}`` in yaw)."""
    lab = labels or {}
    why = []
    bad = [k for k in names if not math.isfinite(float(values.get(k, math.nan)))]
    if bad:
        why.append(f"{', '.join(lab.get(k, k) for k in bad)} not finite")
    loose = [k for k in names if k not in bad and not math.isfinite(float(sigma.get(k, math.nan)))]
    if loose:
        why.append(f"σ of {', '.join(lab.get(k, k) for k in loose)} not finite (not determined by "
                   "this log)")
    return why


def unusable_reasons(names, values: dict, sigma: dict, *, inertias=(), nrmse=None,
                     labels: dict | None = None) -> list:
    """Why an estimate is no model to use, from its numbers: :func:`not_finite_reasons`; an
    inertia among ``inertias`` whose σ exceeds :data:`INERTIA_SIGMA_MAX` × its value (not
    determined); an in-sample replay (``nrmse``: ``{channel: nrmse}``) that does not stay
    finite or whose nrmse reaches :data:`NRMSE_USELESS` (the model explains nothing of the
    channel).  Drag terms and biases may be loose on their own (their σ is warned of): the
    inertia and the replay say whether the model as a whole is one."""
    lab = labels or {}
    why = not_finite_reasons(names, values, sigma, labels)
    for k in inertias:
        v, s = float(values.get(k, math.nan)), float(sigma.get(k, math.nan))
        if math.isfinite(v) and math.isfinite(s) and s > INERTIA_SIGMA_MAX * abs(v):
            why.append(f"σ of {lab.get(k, k)} {s:.2g} is more than {INERTIA_SIGMA_MAX:g}× its "
                       f"value {v:.3g}: not determined by this log")
    for ch, n in (nrmse or {}).items():
        if n is None or (isinstance(n, float) and math.isnan(n)):
            continue  # a channel without spread: no nrmse (the rms is reported)
        if not math.isfinite(n):
            why.append(f"its in-sample replay of {ch} does not stay finite")
        elif n >= NRMSE_USELESS:
            why.append(f"its in-sample replay explains nothing of the {ch} (nrmse {n:.3g} ≥ "
                       f"{NRMSE_USELESS:g}: the error is as large as the {ch}'s own spread)")
    return why


def held_out_verdict(improvement: float) -> str:
    """``"2.52× better"`` or ``"3.1× worse"``: the held-out rms ratio base/identified in words."""
    return (f"{improvement:.2f}× better" if improvement >= 1 else
            f"{1 / improvement:.3g}× worse")


def covariance(J, r, groups, n_glob):
    """``(σ, correlation)`` of the first ``n_glob`` parameters (the nuisance initial states are in
    the fit, so their uncertainty is accounted for): per parameter the larger of the classical
    ``s²(JᵀJ)⁻¹`` and the window-cluster-robust sandwich, each window's residuals taken as if it
    had been left out (:func:`_left_out_residuals`, factor ``(G − 1)/G``: the leave-one-window-out
    jackknife); correlations from the sandwich (the classical matrix where the sandwich is
    degenerate).  On synthetic dives the plain sandwich under-covered yaw 1.5–2× (the windows'
    own starts fitted away the error of a force sampled at 10 Hz); the jackknife form covers.

    A parameter the data cannot move the residuals with — its Jacobian column all zero (every
    window left out in its direction), or a direction of ``JᵀJ``'s null space it takes part in —
    gets σ = ∞ (not identifiable; :func:`not_identifiable` names it), never the 0 a
    pseudo-inverse would report for it."""
    N, P = J.shape
    nan = np.full(n_glob, np.nan), np.full((n_glob, n_glob), np.nan)
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(r))):
        return nan
    # columns scaled to unit largest entry before JᵀJ (a column of 1e200 would overflow it; the
    # scaling is undone exactly on the inverse: (JᵀJ)⁺ = D⁻¹ (JₛᵀJₛ)⁺ D⁻¹ for full rank)
    scale = np.max(np.abs(J), axis=0)
    scale[scale == 0] = 1.0
    Js = J / scale
    A = Js.T @ Js
    try:
        Ainv = np.linalg.pinv(A)
        w, V = np.linalg.eigh(A)
    except np.linalg.LinAlgError:
        return nan
    null = w <= max(float(w[-1]), 1e-300) * NULL_RCOND
    # a parameter with a share of a null direction is not determined (the zero column is one)
    unidentified = np.sum(V[:n_glob][:, null] ** 2, axis=1) > NULL_SHARE
    s2 = float(r @ r) / max(N - (P - int(null.sum())), 1)  # degrees of freedom: N − rank
    c = (s2 * Ainv)[:n_glob, :n_glob]  # in the scaled parameters: σ_i = σ_s,i / scale_i
    meat = np.zeros((P, P))
    live = w[~null]
    cond = float(live[-1] / live[0]) if live.size else 1.0
    floor = max(LEVERAGE_FLOOR, 100.0 * np.finfo(float).eps * cond)
    for g in np.unique(groups):
        sel = groups == g
        gw = Js[sel].T @ _left_out_residuals(Js[sel], Ainv, r[sel], floor)
        meat += np.outer(gw, gw)
    G = np.unique(groups).size
    rb = (Ainv @ meat @ Ainv * ((G - 1) / max(G, 1)))[:n_glob, :n_glob]
    # (a null direction's round-off can leave a diagonal entry at −1e-17: σ = ∞ there below)
    sd = np.sqrt(np.maximum(np.maximum(np.diag(c), np.diag(rb)), 0.0)) / scale[:n_glob]
    sd[unidentified] = np.inf
    use = rb if np.all(np.diag(rb) > 0) else c
    d = np.sqrt(np.maximum(np.diag(use), 1e-300))
    corr = use / np.outer(d, d)
    corr[unidentified, :] = corr[:, unidentified] = np.nan
    corr[unidentified, unidentified] = 1.0
    return sd, corr


NULL_RCOND = 1e-12  # eigenvalue of the column-scaled JᵀJ below this × the largest: a null direction
LEVERAGE_FLOOR = 1e-9  # eigenvalue of a window's I − H_gg below which it is the window's own start
#                       (raised to 100·ε·cond(JᵀJ) for an ill-conditioned fit)
NULL_SHARE = 1e-6   # a parameter's squared share of the null directions above which it is undetermined


def not_identifiable(names, sigma: dict) -> list:
    """One warning per parameter whose σ is ∞ (see :func:`covariance`)."""
    return [f"{k} is not identifiable from this dive: no window's residuals move with it "
            "(every window was left out in its direction, or it trades off exactly against "
            "another parameter); σ = ∞: its value is not determined by the data" for k in names
            if math.isinf(sigma[k])]


def correlation_warnings(names, corr, limit: float = 0.95) -> list:
    """One warning per pair of parameters correlated beyond ``limit``."""
    out = []
    n = len(names)
    for i in range(n):
        for j in range(i + 1, n):
            if abs(corr[i][j]) > limit:
                out.append(f"{names[i]} and {names[j]} are hard to separate in this dive "
                           f"(correlation {corr[i][j]:+.2f}): more varied forces and speeds help")
    return out


def dead_band_weights(delta_y, sigma_y) -> np.ndarray:
    """Weights ``w_i = 1/sqrt(1 + (δy_i/σ_y)²)`` of the output-error residuals.

    ``δy_i`` is how far sample i's prediction moves when every thruster at the dead band's edge
    pushes its uncertain thrust ``σ_T`` (:func:`uuvid.io.dive_channels.pwm_flags`) from the
    window's start on (the same model, the same initial state: the input uncertainty propagated
    through the model); ``σ_y`` the channel's measurement noise (:func:`noise_sigma`).  The
    residual's variance is then ``σ_y² + δy_i²`` and ``w_i ∝ 1/sqrt`` of it — weighted least
    squares with the input error treated as an output error (errors in variables to first
    order).  Samples whose force is certain keep ``w = 1``; a window whose thrusters sat at the
    edge early counts little for the whole of it, since its error accumulates.  Saturated
    samples are not down-weighted: their thrust is known.
    """
    d = np.asarray(delta_y, float)
    s = max(float(sigma_y), 1e-12) if math.isfinite(float(sigma_y)) else 1.0
    with np.errstate(over="ignore"):  # a δy beyond 1e154 σ (a start that blew up): weight 0
        w = 1.0 / np.hypot(1.0, np.where(np.isfinite(d), d, 0.0) / s)
    return w


def weighting_summary(flags, weights, windows_of_rows, t0, t1, n_windows: int,
                      forces=()) -> dict:
    """Counts for summary()/to_dict(): force samples within ``[t0, t1]`` whose ``forces``
    (channel names, e.g. ``("Z_N",)``) depend on thrusters at the dead band's edge, samples
    with a saturated thruster, residual samples and windows down-weighted."""
    out = {"enabled": weights is not None, "rule": "w = 1/sqrt(1 + (δy/σ_y)²), δy: the "
           "prediction's change under the edge thrusters' uncertain thrust",
           "force_samples": 0, "force_samples_dead_band_edge": 0, "force_samples_saturated": 0,
           "residual_samples": 0, "residual_samples_down_weighted": 0, "windows": n_windows,
           "windows_down_weighted": 0, "mean_weight": 1.0, "regions": None}
    if flags is not None:
        sel = (flags.t >= t0) & (flags.t <= t1)
        edge = (np.any([flags.sigma_of(f)[1] > 0 for f in forces], axis=0) if forces
                else flags.n_edge > 0)
        out.update(force_samples=int(np.count_nonzero(sel)),
                   force_samples_dead_band_edge=int(np.count_nonzero(edge[sel])),
                   force_samples_saturated=int(np.count_nonzero(flags.n_sat[sel] > 0)),
                   regions=flags.regions.to_dict())
    if weights is not None:
        w = np.asarray(weights, float)
        low = w < DOWN_WEIGHTED
        out.update(residual_samples=int(w.size), residual_samples_down_weighted=int(
            np.count_nonzero(low)), mean_weight=float(np.mean(w)) if w.size else 1.0,
            windows_down_weighted=int(np.unique(np.asarray(windows_of_rows)[low]).size))
    return out


def weighting_text(d: dict) -> str:
    """One line for a summary."""
    if d["force_samples"] == 0 and not d["enabled"]:
        return "dead-band weighting: no servo outputs logged (forces used as logged)"
    r = d["regions"] or {}
    band = r.get("dead_band_us")
    head = (f"dead band {band[0]:.0f}–{band[1]:.0f} µs ({r.get('model')}): " if band else "")
    txt = (f"{head}{d['force_samples_dead_band_edge']} of {d['force_samples']} force samples of "
           f"this model depend on thrusters at its edge, {d['force_samples_saturated']} have one "
           "saturated")
    if d["enabled"]:
        txt += (f"; {d['residual_samples_down_weighted']} of {d['residual_samples']} residual "
                f"samples in {d['windows_down_weighted']} of {d['windows']} windows down-weighted "
                f"(w < {DOWN_WEIGHTED:g}; mean weight {d['mean_weight']:.2f})")
    else:
        txt += "; not down-weighted (weighting off)"
    return txt


def loss_as_drag(gain, speed, ka: float, sigma_ka: float, linear: float, gain_unit: str,
                 drag_unit: str = "") -> dict:
    """How much of an apparent linear drag is thrust lost to the advance speed (issue 21).

    Over the fitted windows the loss ``k_a c(t) ν`` acts as the drag ``k_a c(t)``; its mean
    ``k_a c̄`` (``c̄`` weighted by ``|ν|``, where the term acts) beside the hull's linear drag
    ``k``: a bollard-thrust model books ``k + k_a c̄`` as its linear drag.  ``gain`` and
    ``speed``: ``c(t)`` and ``ν(t)`` on the same samples (``gain_unit`` the unit of ``c``,
    ``drag_unit`` that of the drags, kept in the result as ``unit``)."""
    gain = np.asarray(gain, float)
    w = np.abs(np.asarray(speed, float))
    w = np.where(np.isfinite(w), w, 0.0)
    c_bar = float(np.sum(gain * w) / np.sum(w)) if np.sum(w) > 0 else float(np.mean(gain))
    loss = ka * c_bar
    apparent = linear + loss
    return {"unit": drag_unit, "c_mean": c_bar, "c_unit": gain_unit,
            "c_range": [float(np.min(gain)), float(np.max(gain))],
            "loss_as_drag": loss, "loss_as_drag_sigma": sigma_ka * c_bar,
            "apparent_linear": apparent,
            "loss_fraction": loss / apparent if apparent > 0 else float("nan")}


def loss_as_drag_text(s: dict, unit: str) -> str:
    """One line of :func:`loss_as_drag` (``unit``: the drag's)."""
    cu = s.get("c_unit", "")
    return (f"thrust loss as drag k_a·c̄ = {s['loss_as_drag']:.3g} ± "
            f"{s['loss_as_drag_sigma']:.2g} {unit} (c̄, the |speed|-weighted mean of the inflow "
            f"gain c(t), = {s['c_mean']:.3g} {cu}; c(t) "
            f"{s['c_range'][0]:.3g}–{s['c_range'][1]:.3g} {cu}): "
            f"{100 * s['loss_fraction']:.0f} % of the apparent linear drag "
            f"{s['apparent_linear']:.3g} {unit} a bollard-thrust model would report")
