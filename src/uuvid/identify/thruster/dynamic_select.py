"""Thruster dynamics that extrapolate: dead band, joint speed + thrust, selection by held-out level.

A *structure* is a driver with a dead band per direction (:class:`~uuvid.thruster.blocks.Driver`:
offset, thresholds, output limit) in front of one dynamic family, and — when the records hold
thrust — a thrust map behind it::

    command → Driver(d_fwd, d_rev) → first-order | Yoerger | Bessa | DC motor → K_T Ω|Ω| per direction
    command → Driver(d_fwd, d_rev) → Healey two-state (speed + axial inflow → thrust)

:func:`fit_dynamics` identifies the dead bands together with the dynamics and the map by output
error (:func:`uuvid.identify.thruster.dynamic.fit_chain`) from every channel of every record at once.
Each channel's residuals are divided by its noise σ, *estimated* and not assumed: first from the
data (the scatter of second differences, which a smooth response does not have), then
iteratively from the residual variance of that channel (iteratively reweighted least squares,
until the σ settle), so one covariance ``(JᵀJ)⁻¹`` of the whitened residuals covers all the
parameters.

:func:`select_structure` compares structures by how they *extrapolate*: leave one command level
out (fit on the records of all other levels, predict the left-out level), and picks the lowest
mean held-out NRMSE (ties within 2 % go to the structure with fewer parameters).  Predictions
at a new level carry a ±2σ band from the parameter covariance (linearised:
``var ŷ_k = J_k C J_kᵀ``, ``J_k = ∂ŷ_k/∂θ``).

NRMSE here is ``RMSE / (max y − min y)`` of the measured channel of the record.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from uuvid.core.result import Result, jsonable
from uuvid.identify.fit import propagated_variance
from uuvid.identify.thruster.dynamic import (
    ChainFit,
    Run,
    _simulate_run,
    fit_chain,
    set_parameter,
    validate_runs,
)
from uuvid.thruster.blocks import (
    CH,
    BessaDynamics,
    DCMotor,
    Driver,
    FirstOrderMotor,
    HealeyThruster,
    QuadraticMap,
    Yoerger,
)
from uuvid.thruster.chain import ThrusterChain

__all__ = [
    "FAMILIES",
    "DynamicsFit",
    "Experiment",
    "Prediction",
    "Selection",
    "Structure",
    "default_structures",
    "fit_dynamics",
    "nrmse",
    "plot_predictions",
    "predict_chain",
    "reference_two_state_thruster",
    "select_structure",
    "selection_demo",
    "synthetic_experiments",
]

FAMILIES = ("first-order", "yoerger", "bessa", "dc-motor", "healey")
CHANNELS = ("speed", "thrust")
_CH = {"speed": "prop_speed", "thrust": "thrust"}
#: Relative score difference under which the structure with fewer parameters is preferred.
TIE = 0.02


def nrmse(y, yhat) -> float:
    """``RMSE / (max y − min y)`` (NaN for a flat record)."""
    y = np.asarray(y, dtype=float)
    span = float(np.max(y) - np.min(y))
    return float(np.sqrt(np.mean((np.asarray(yhat) - y) ** 2)) / span) if span > 0 else math.nan


# ------------------------------------------------------------------------------------------------
# records and structures
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Experiment:
    """One logged record: time ``t`` (s), the command ``u`` and shaft ``speed`` (rad/s) and/or
    ``thrust`` (N) on the same samples."""

    t: np.ndarray
    u: np.ndarray
    speed: np.ndarray | None = None
    thrust: np.ndarray | None = None
    name: str = ""

    def __post_init__(self):
        t = np.ascontiguousarray(self.t, dtype=float)
        u = np.ascontiguousarray(self.u, dtype=float)
        label = self.name or "experiment"
        if self.speed is None and self.thrust is None:
            raise ValueError(f"{label}: needs a speed or a thrust record")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "u", u)
        for nm in CHANNELS:
            v = getattr(self, nm)
            if v is not None:
                v = np.ascontiguousarray(v, dtype=float)
                if v.shape != t.shape:
                    raise ValueError(f"{label}: {nm} has {v.size} samples, t has {t.size}")
                object.__setattr__(self, nm, v)

    @property
    def level(self) -> float:
        """The command level of the record: ``max |u|`` to 3 significant digits."""
        return float(f"{float(np.max(np.abs(self.u))):.3g}")

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(c for c in CHANNELS if getattr(self, c) is not None)

    def runs(self, sigma: dict[str, float] | None = None) -> list[Run]:
        """One :class:`Run` per channel, sharing ``t`` and ``u`` (simulated once per record)."""
        sigma = sigma or {}
        return [Run(self.t, self.u, getattr(self, c), _CH[c], name=f"{self.name}:{c}",
                    sigma=sigma.get(c)) for c in self.channels]


@dataclass(frozen=True)
class Structure:
    """A dynamic family with (or without) a dead-band driver in front (and a ``K_T Ω|Ω|`` map
    behind when thrust is fitted and the family gives speed)."""

    family: str
    dead_band: bool = True

    def __post_init__(self):
        if self.family not in FAMILIES:
            raise ValueError(f"unknown dynamic family {self.family!r}; families: {', '.join(FAMILIES)}")

    @property
    def name(self) -> str:
        return self.family + ("+deadband" if self.dead_band else "")


def default_structures(dead_band: bool = True) -> list[Structure]:
    return [Structure(f, dead_band) for f in FAMILIES]


# ------------------------------------------------------------------------------------------------
# start values from the records
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Guess:
    db: dict  # direction (+1/−1) → dead band start
    v: dict  # direction → driver output at the top level (|u| − d)
    w: dict  # direction → steady |speed| at the top level
    thrust: dict  # direction → steady |thrust| at the top level
    tau: float


def _noise_guess(y: np.ndarray) -> float:
    """Noise σ from second differences (a smooth response has almost none): MAD/0.6745/√6."""
    d2 = np.diff(y, 2)
    s = float(np.median(np.abs(d2 - np.median(d2))) / 0.6745 / math.sqrt(6.0)) if d2.size else 0.0
    span = float(np.ptp(y)) if y.size else 1.0
    return max(s, 1e-3 * span, 1e-12)


def _guess(exps: Sequence[Experiment], offset: float) -> _Guess:
    db, v, w, thr = {}, {}, {}, {}
    taus = []
    for sgn in (1.0, -1.0):
        best = None
        for e in exps:
            c = (e.u - offset) * sgn
            top = float(np.max(c))
            if top <= 0:
                continue
            y = e.speed if e.speed is not None else e.thrust
            on = np.flatnonzero(c >= 0.98 * top)
            tail = on[int(0.7 * on.size):] if on.size > 3 else on
            ys = abs(float(np.mean(y[tail])))
            ts = abs(float(np.mean(e.thrust[tail]))) if e.thrust is not None else math.nan
            moving = np.flatnonzero((np.abs(y) > 0.1 * ys) & (c > 0))
            start = float(np.min(c[moving])) if moving.size else 0.0
            if best is None or top > best[0]:
                best = (top, ys, ts, start)
            taus.append(_tau_guess(e.t, c, np.abs(y)))
        if best is not None:
            top, ys, ts, start = best
            d = min(max(0.7 * start, 0.0), 0.5 * top)
            db[sgn], v[sgn], w[sgn], thr[sgn] = d, top - d, max(ys, 1e-9), ts
    if not db:
        raise ValueError("the records never leave the offset command: nothing to identify")
    taus = [x for x in taus if math.isfinite(x)]
    return _Guess(db, v, w, thr, float(np.median(taus)) if taus else 0.1)


def _tau_guess(t, c, y) -> float:
    """63 % time after the largest upward command jump."""
    du = np.diff(c)
    k = int(np.argmax(du))
    if du[k] <= 0:
        return math.nan
    nxt = np.flatnonzero(np.abs(du[k + 1:]) > 1e-9 * max(1.0, abs(du[k])))
    end = k + 1 + (int(nxt[0]) if nxt.size else y.size - k - 1)
    seg = y[k + 1:end + 1]
    if seg.size < 5:
        return math.nan
    y0, y1 = float(y[k]), float(np.mean(seg[-max(1, seg.size // 5):]))
    if y1 <= y0:
        return math.nan
    hit = np.flatnonzero(seg >= y0 + 0.632 * (y1 - y0))
    return float(t[k + 1 + hit[0]] - t[k]) if hit.size else math.nan


def _template(s: Structure, g: _Guess, with_thrust: bool, offset: float, limit: float):
    """(start chain, free parameters, bounds, units, identifiable combinations)."""
    dirs = sorted(g.db)
    sg = 1.0 if 1.0 in g.db else -1.0
    V, W, tau = g.v[sg], g.w[sg], max(g.tau, 1e-4)
    drv = Driver(deadband_fwd=g.db.get(1.0, 0.0) if s.dead_band else 0.0,
                 deadband_rev=g.db.get(-1.0, 0.0) if s.dead_band else 0.0, offset=offset,
                 limit=limit)
    free: list = []
    bounds: dict = {}
    umax = max(g.v[d] + g.db[d] for d in dirs)
    if s.dead_band:
        for d, nm in ((1.0, "deadband_fwd"), (-1.0, "deadband_rev")):
            if d in g.db:
                free.append(f"blocks[0].{nm}")
                bounds[f"blocks[0].{nm}"] = (0.0, umax)
    units = {"deadband_fwd": "cmd", "deadband_rev": "cmd"}
    combos: dict[str, Callable] = {}
    if s.family == "first-order":
        dyn = FirstOrderMotor(gain=W / V, time_constant=tau)
        free += ["blocks[1].gain", "blocks[1].time_constant"]
        units.update({"gain": "(rad/s)/cmd", "time_constant": "s"})  # Ω_ss = gain · u
    elif s.family == "yoerger":
        a = 1.0 / (2 * tau * W)
        dyn = Yoerger(alpha=a, beta=a * W * W / V)
        free += ["blocks[1].alpha", "blocks[1].beta"]
        units.update({"alpha": "1/rad", "beta": "(rad/s²)/cmd"})  # Ω̇ = β u − α Ω|Ω|
    elif s.family == "bessa":
        dyn = BessaDynamics(jmsp=1.5 * V * tau / W, kv1=V / (2 * W), kv2=V / (2 * W * W))
        free += ["blocks[1].jmsp", "blocks[1].kv1", "blocks[1].kv2"]
        combos = {"Kt/(Rm Jmsp)": lambda c: c.blocks[1].kt / (c.blocks[1].rm * c.blocks[1].jmsp),
                  "Kv1/Jmsp": lambda c: c.blocks[1].kv1 / c.blocks[1].jmsp,
                  "Kv2/Jmsp": lambda c: c.blocks[1].kv2 / c.blocks[1].jmsp}
    elif s.family == "dc-motor":
        k = V / (2 * W)
        dyn = DCMotor(torque_constant=k, back_emf_constant=k, resistance=1.0,
                      motor_inertia=3 * k * k * tau, torque_coefficient=k * k / W)
        free += [("blocks[1].torque_constant", "blocks[1].back_emf_constant"),
                 "blocks[1].motor_inertia", "blocks[1].torque_coefficient"]
        units.update({"torque_constant": "N·m/A", "motor_inertia": "kg·m²",
                      "torque_coefficient": "N·m·s²/rad²"})
        def rj(c):
            return c.blocks[1].resistance * c.blocks[1].motor_inertia

        combos = {"K/(R J)": lambda c: c.blocks[1].torque_constant / rj(c),
                  "K²/(R J)": lambda c: c.blocks[1].torque_constant ** 2 / rj(c),
                  "K_Q/J": lambda c: c.blocks[1].torque_coefficient / c.blocks[1].motor_inertia}
    else:  # healey
        if not with_thrust:
            raise ValueError("healey: the axial-flow state is seen only through thrust; give "
                             "records with thrust")
        J, mf = 1e-4, 1.0
        ku = J * W / (1.5 * V * tau)
        T = g.thrust[sg] if math.isfinite(g.thrust[sg]) and g.thrust[sg] > 0 else 1.0
        ua = 2.43 * T * tau / mf
        with np.errstate(all="ignore"):
            kt = {d: (g.thrust[d] if math.isfinite(g.thrust[d]) and g.thrust[d] > 0 else T)
                  / (0.7 * g.w[d] ** 2) for d in dirs}
            starts = np.array([ku, ku * V / (2 * W), ku * V / (2 * W * W), *kt.values(),
                               0.43 * T / (W * ua) if W * ua else np.inf,
                               T / ua ** 2 if ua ** 2 else np.inf])
        if not np.all(np.isfinite(starts) & (starts > 0)):
            raise ValueError(
                f"healey: a steady thrust of {T:.3g} N at {W:.3g} rad/s and {V:.3g} command "
                "units gives no finite start values for the axial-flow state (thrust far too "
                "small or large); check the thrust column's unit (N) and the speed's (rad/s), or "
                "choose a model without the flow state (first-order, yoerger)")
        dyn = HealeyThruster(inertia=J, drive_gain=ku, viscous=ku * V / (2 * W),
                             torque_coefficient=ku * V / (2 * W * W),
                             thrust_coefficient=kt.get(1.0, kt[sg]),
                             thrust_coefficient_rev=kt.get(-1.0, kt[sg]),
                             inflow_coefficient=0.43 * T / (W * ua), fluid_mass=mf,
                             flow_damping=T / ua ** 2)
        free += ["blocks[1].drive_gain", "blocks[1].viscous", "blocks[1].torque_coefficient"]
        free += [f"blocks[1].{nm}" for d, nm in ((1.0, "thrust_coefficient"),
                                                 (-1.0, "thrust_coefficient_rev")) if d in g.db]
        free += ["blocks[1].inflow_coefficient", "blocks[1].flow_damping"]
        units.update({"drive_gain": "N·m/V", "viscous": "N·m·s", "torque_coefficient": "N·m·s²",
                      "thrust_coefficient": "N·s²", "thrust_coefficient_rev": "N·s²",
                      "inflow_coefficient": "N·s/m", "flow_damping": "kg/m"})
        combos = {"K_u/J": lambda c: c.blocks[1].drive_gain / c.blocks[1].inertia,
                  "K_n/J": lambda c: c.blocks[1].viscous / c.blocks[1].inertia,
                  "k_q/J": lambda c: c.blocks[1].torque_coefficient / c.blocks[1].inertia,
                  "k_a/m_f": lambda c: c.blocks[1].inflow_coefficient / c.blocks[1].fluid_mass,
                  "d_f/m_f²": lambda c: c.blocks[1].flow_damping / c.blocks[1].fluid_mass ** 2}
    blocks = [drv, dyn]
    if with_thrust and s.family != "healey":
        kq = {d: (g.thrust[d] if math.isfinite(g.thrust[d]) else 1.0) / g.w[d] ** 2 for d in dirs}
        blocks.append(QuadraticMap(k_pos=kq.get(1.0, kq[sg]), k_neg=kq.get(-1.0, kq[sg])))
        free += [f"blocks[2].{nm}" for d, nm in ((1.0, "k_pos"), (-1.0, "k_neg")) if d in g.db]
        units.update({"k_pos": "N·s²", "k_neg": "N·s²"})
    chain = ThrusterChain(tuple(blocks), input_kind="command", name=s.name)
    return chain, free, bounds, units, combos


# ------------------------------------------------------------------------------------------------
# predictions
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Prediction:
    """Predicted vs measured channels of one record, with a ±2σ band from the parameter
    covariance (``band[channel] = (lo, hi)``) and the NRMSE per channel."""

    experiment: Experiment
    predicted: dict  # channel → array
    band: dict  # channel → (lo, hi) or absent
    nrmse: dict  # channel → float

    def rows(self) -> list[dict]:
        return [{"record": self.experiment.name, "level": self.experiment.level, "channel": c,
                 "nrmse_%": 100 * v} for c, v in self.nrmse.items()]

    def to_csv_text(self) -> str:
        e = self.experiment
        cols = {"t": e.t, "command": e.u}
        for c in e.channels:
            cols[f"{c}_measured"] = getattr(e, c)
        for c, y in self.predicted.items():
            cols[f"{c}_predicted"] = y
            if c in self.band:
                cols[f"{c}_lo"], cols[f"{c}_hi"] = self.band[c]
        head = ",".join(cols)
        data = np.column_stack(list(cols.values()))
        return head + "\n" + "\n".join(",".join(f"{v:.9g}" for v in row) for row in data) + "\n"


def predict_chain(chain: ThrusterChain, exp: Experiment, max_step: float | None = None) -> Prediction:
    """Replay a record's command through ``chain``; NRMSE of every channel the record holds."""
    p = validate_runs([Run(exp.t, exp.u, exp.u, "command")], resample=True)[0]
    C = _simulate_run(chain, p, max_step or p.dt)
    pred, score = {}, {}
    for c in CHANNELS:
        y = C[:, CH[_CH[c]]]
        if np.all(np.isnan(y)):
            continue
        pred[c] = y.copy()
        if getattr(exp, c) is not None:
            score[c] = nrmse(getattr(exp, c), y)
    return Prediction(exp, pred, {}, score)


# ------------------------------------------------------------------------------------------------
# the joint fit
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class DynamicsFit(Result):
    """A structure fitted to records: ``chain_fit`` (the :class:`ChainFit`, whose ``fit`` is the
    :class:`~uuvid.identify.fit.Fit`), the estimated noise σ per channel, the in-sample NRMSE per
    record and channel, and the identifiable combinations (with σ by the delta method)."""

    structure: Structure
    chain_fit: ChainFit
    noise: dict
    in_sample: list  # rows {record, level, channel, nrmse_%}
    identifiable: dict
    iterations: int

    @property
    def chain(self) -> ThrusterChain:
        return self.chain_fit.chain

    @property
    def fit(self):
        return self.chain_fit.fit

    @property
    def n_params(self) -> int:
        return len(self.chain_fit.free)

    def in_sample_nrmse(self, channel: str) -> float:
        """Mean in-sample NRMSE of ``channel`` over the records (fraction)."""
        v = [r["nrmse_%"] / 100 for r in self.in_sample if r["channel"] == channel]
        return float(np.mean(v)) if v else math.nan

    def predict(self, exp: Experiment, band: bool = True, z: float = 2.0) -> Prediction:
        """Replay ``exp``'s command; with ``band`` a ±zσ band from the parameter covariance."""
        cf = self.chain_fit
        base = predict_chain(self.chain, exp, cf.max_step)
        if not band:
            return base
        cov = np.asarray(cf.fit.covariance, dtype=float)
        if not np.all(np.isfinite(cov)):
            return base
        theta = np.array([f.value_in(self.chain) for f in cf.free])
        sens = {c: np.empty((exp.t.size, theta.size)) for c in base.predicted}
        for i in range(theta.size):
            h = 1e-4 * max(abs(theta[i]), 1e-12)
            th = theta.copy()
            th[i] += h
            pi = predict_chain(set_parameter(self.chain, list(zip(cf.free, th))), exp, cf.max_step)
            for c in sens:
                sens[c][:, i] = (pi.predicted[c] - base.predicted[c]) / h
        bands = {}
        for c, S in sens.items():
            sd = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", S, cov, S), 0.0))
            bands[c] = (base.predicted[c] - z * sd, base.predicted[c] + z * sd)
        return dataclasses.replace(base, band=bands)

    def brief(self) -> str:
        """Structure, noise σ, in-sample NRMSE and identifiable combinations (no parameter
        table; :meth:`summary` adds it)."""
        from uuvid.core.response import CHANNEL_UNITS

        units = {**CHANNEL_UNITS, "speed": "rad/s"}
        lines = [f"{self.structure.name}: {self.n_params} parameters, noise σ "
                 + ", ".join(f"{c} {v:.3g} {units.get(c, '')}".rstrip() for c, v in self.noise.items())
                 + f" (estimated, {self.iterations} reweighting passes)"]
        lines += [f"  in-sample NRMSE {r['record']} {r['channel']}: {r['nrmse_%']:.2f} %"
                  for r in self.in_sample]
        for k, v in self.identifiable.items():
            lines.append(f"  identifiable {k} = {v['estimate']:.5g} ± {v['sigma']:.2g}")
        return "\n".join(lines)

    report_title = "Dynamic thruster model"

    def summary(self) -> str:
        return self.fit.summary() + "\n" + self.brief()

    def to_dict(self) -> dict:
        return jsonable({"structure": self.structure.name, "n_params": self.n_params,
                         "noise": self.noise, "in_sample": self.in_sample,
                         "identifiable": self.identifiable, "parameters": self.fit.as_dict()})

    def plot(self, run: int = 0):
        """Measured channel of record ``run`` and the fitted chain's prediction."""
        return self.chain_fit.plot(run)


def _delta(cf: ChainFit, combos: dict) -> dict:
    if not combos:
        return {}
    chain = cf.chain
    theta = np.array([f.value_in(chain) for f in cf.free])
    g0 = np.array([f(chain) for f in combos.values()])
    G = np.empty((g0.size, theta.size))
    for i in range(theta.size):
        h = 1e-6 * max(abs(theta[i]), 1e-12)
        th = theta.copy()
        th[i] += h
        ci = set_parameter(chain, list(zip(cf.free, th)))
        G[:, i] = (np.array([f(ci) for f in combos.values()]) - g0) / h
    var = propagated_variance(G, cf.fit.covariance)
    return {k: {"estimate": float(g0[i]), "sigma": float(math.sqrt(max(var[i], 0.0)))}
            for i, k in enumerate(combos)}


def fit_dynamics(
    experiments: Iterable[Experiment] | Experiment,
    structure: Structure | str = "healey",
    *,
    offset: float = 0.0,
    limit: float = math.inf,
    channels: Sequence[str] | None = None,
    start: ThrusterChain | None = None,
    iterations: int = 4,
    max_step: float | None = None,
    free_limit: bool = False,
    **lsq_kwargs,
) -> DynamicsFit:
    """Fit ``structure`` (dead bands, dynamics and thrust map together) to every channel of
    ``experiments``, each channel weighted by its estimated noise (see the module docstring).

    ``offset``: the driver's neutral command (fixed: next to two dead bands it is not
    identifiable); ``limit``: its output limit (fixed; with ``free_limit`` fitted, starting
    at most at 90 % of the largest driver output the records imply — only records that reach
    the limit can tell it);
    ``channels``: restrict to ``("speed",)`` or ``("thrust",)``; ``start``: a chain of the same
    structure to start from (e.g. the all-levels fit when refitting a subset).
    """
    exps = [experiments] if isinstance(experiments, Experiment) else list(experiments)
    if not exps:
        raise ValueError("no records given")
    s = Structure(structure) if isinstance(structure, str) else structure
    use = tuple(channels or CHANNELS)
    with_thrust = "thrust" in use and any(e.thrust is not None for e in exps)
    if channels:
        exps = [dataclasses.replace(e, **{c: None for c in CHANNELS if c not in use})
                for e in exps if any(getattr(e, c) is not None for c in use)]
    g = _guess(exps, offset)
    if free_limit:  # start inside the range the records reach, or the limit has no gradient
        limit = min(limit, 0.9 * max(g.v.values()))
    chain, free, bounds, units, combos = _template(s, g, with_thrust, offset, limit)
    if start is not None:
        chain = ThrusterChain(start.blocks, input_kind=start.input_kind, name=s.name)
    if free_limit:
        free = [*free, "blocks[0].limit"]
        bounds = {**bounds, "blocks[0].limit": (1e-9, math.inf)}
    # a speed-only family seen through thrust alone cannot separate map and gain: drop the speed
    # family's output from the fit only when no record has speed (the map then carries the gain)
    sigma = {}
    for c in CHANNELS:
        ys = [getattr(e, c) for e in exps if getattr(e, c) is not None]
        if ys and (c == "speed" or with_thrust):
            sigma[c] = float(np.median([_noise_guess(y) for y in ys]))
    dt = float(np.median([np.median(np.diff(e.t)) for e in exps]))
    step = max_step or dt
    cf = None
    x0 = None
    n_iter = 0
    for k in range(1, iterations + 1):
        n_iter = k
        runs = [r for e in exps for r in e.runs(sigma) if r.channel in {_CH[c] for c in sigma}]
        cf = fit_chain(chain, free, runs, bounds=bounds, x0=x0, max_step=step, model=s.name,
                       units=units, emit_warnings=False, normalize=False, **lsq_kwargs)
        x0 = [cf.values[f.name] for f in cf.free]
        chain = cf.chain
        new = {}
        for c in sigma:
            e2 = [r["rmse"] ** 2 * r["samples"] for r in cf.fit.extra["runs"]
                  if r["channel"] == _CH[c]]
            n = sum(r["samples"] for r in cf.fit.extra["runs"] if r["channel"] == _CH[c])
            new[c] = max(math.sqrt(sum(e2) / n), 1e-12)
        settled = all(abs(new[c] / sigma[c] - 1) < 0.05 for c in sigma)
        sigma = new
        if settled:
            break
    rows = []
    for e in exps:
        pr = predict_chain(cf.chain, e, step)
        rows += [r for r in pr.rows() if r["channel"] in sigma]
    return DynamicsFit(s, cf, sigma, rows, _delta(cf, combos), n_iter)


# ------------------------------------------------------------------------------------------------
# selection by leave-one-level-out prediction
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Selection(Result):
    """Leave-one-level-out table, the chosen structure and why, the all-levels fits, and the
    held-out predictions of the chosen structure (``held_out``: level → predictions)."""

    rows: list
    chosen: str
    reason: str
    fits: dict  # structure name → DynamicsFit (all levels)
    held_out: dict  # level → list[Prediction] (chosen structure, fitted without that level)
    levels: tuple

    @property
    def best(self) -> DynamicsFit:
        return self.fits[self.chosen]

    def columns(self) -> list[str]:
        cols = ["structure", "n_params"]
        for c in CHANNELS:
            if any(f"in_{c}_%" in r for r in self.rows):
                cols.append(f"in_{c}_%")
        for lv in self.levels:
            for c in CHANNELS:
                k = f"out_{lv:g}_{c}_%"
                if any(k in r for r in self.rows):
                    cols.append(k)
        return cols + ["score_%", "note"]

    def to_text(self) -> str:
        cols = self.columns()
        cells = [[_fmt(r.get(c)) for c in cols] for r in self.rows]
        wid = [max(len(c), *(len(x[i]) for x in cells)) for i, c in enumerate(cols)]
        out = ["leave-one-level-out prediction (NRMSE %; out_L_*: fitted without level L, "
               "predicted at it; score: mean of the out_ columns)",
               "  ".join(c.ljust(w) for c, w in zip(cols, wid))]
        for x in cells:
            out.append("  ".join(v.ljust(w) for v, w in zip(x, wid)))
        out.append(f"chosen: {self.chosen} — {self.reason}")
        return "\n".join(out)

    report_title = "Dynamic model structure selection"

    def summary(self) -> str:
        return self.to_text()

    def to_dict(self) -> dict:
        return jsonable({"levels": list(self.levels), "table": self.rows, "chosen": self.chosen,
                         "reason": self.reason})

    def plot(self, level: float | None = None):
        """Held-out prediction of the chosen structure at ``level`` (default: the highest) with
        its ±2σ band, measured data and command."""
        lv = max(self.held_out) if level is None else level
        return plot_predictions(self.held_out[lv],
                                f"{self.chosen}: fitted without level {lv:g}, predicted at it",
                                suffix=" (held out)")


def plot_predictions(preds: Sequence[Prediction], title: str, suffix: str = ""):
    """Measured vs predicted speed and thrust (rows) per record (columns), with bands."""
    from uuvid.core.plots import new_figure

    chans = [c for c in CHANNELS if any(c in p.nrmse for p in preds)]
    fig, ax = new_figure(len(chans), len(preds), squeeze=False, sharex="col",
                         figsize=(5.5 * len(preds), 3.2 * len(chans)))
    for j, p in enumerate(preds):
        e = p.experiment
        for i, c in enumerate(chans):
            a = ax[i, j]
            if c not in p.nrmse:
                continue
            a.plot(e.t, getattr(e, c), ".", ms=1.5, color="0.55", label="measured", rasterized=True)
            a.plot(e.t, p.predicted[c], "-", lw=1.2, color="C1",
                   label=f"predicted (NRMSE {100 * p.nrmse[c]:.1f} %)")
            if c in p.band:
                a.fill_between(e.t, *p.band[c], color="C1", alpha=0.25, lw=0,
                               label="±2σ (parameters)")
            a.set_ylabel("speed [rad/s]" if c == "speed" else "thrust [N]")
            a.grid(True, alpha=0.3)
            a.legend(fontsize="small", loc="upper left")
        ax[0, j].set_title(f"{e.name} (level {e.level:g}{suffix})")
        ax[-1, j].set_xlabel("t [s]")
    fig.suptitle(title)
    return fig


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.3g}"
    return str(v)


def _by_level(exps: Sequence[Experiment]) -> dict[float, list[Experiment]]:
    out: dict[float, list[Experiment]] = {}
    for e in exps:
        out.setdefault(e.level, []).append(e)
    return dict(sorted(out.items()))


def select_structure(
    experiments: Iterable[Experiment],
    structures: Sequence[Structure | str] | None = None,
    *,
    offset: float = 0.0,
    limit: float = math.inf,
    progress: bool | None = None,
    **kwargs,
) -> Selection:
    """Compare ``structures`` (default: every family with a dead band) by leave-one-level-out
    prediction over ``experiments`` and pick the lowest mean held-out NRMSE over levels and
    channels; ties within :data:`TIE` go to fewer parameters.  Refits start from the all-levels
    estimate.  Needs records at two command levels at least."""
    from uuvid.core.progress import progress_task

    exps = list(experiments)
    groups = _by_level(exps)
    if len(groups) < 2:
        raise ValueError(f"selection by held-out level needs records at 2 command levels at "
                         f"least; all records are at level {next(iter(groups), 0):g}")
    strs = [Structure(x) if isinstance(x, str) else x for x in (structures or default_structures())]
    if not any(e.thrust is not None for e in exps):
        strs = [s for s in strs if s.family != "healey"]
    rows, fits, held = [], {}, {}
    with progress_task("selecting structure", total=len(strs) * (len(groups) + 1),
                       disable=progress if progress is None else not progress) as task:
        for s in strs:
            row: dict = {"structure": s.name}
            try:
                full = fit_dynamics(exps, s, offset=offset, limit=limit, **kwargs)
                task.advance()
                fits[s.name] = full
                row["n_params"] = full.n_params
                for c in full.noise:
                    row[f"in_{c}_%"] = 100 * full.in_sample_nrmse(c)
                scores, preds = [], {}
                for lv, test in groups.items():
                    train = [e for e in exps if e.level != lv]
                    f = fit_dynamics(train, s, offset=offset, limit=limit, start=full.chain,
                                     **kwargs)
                    task.advance()
                    preds[lv] = [f.predict(e, band=False) for e in test]
                    for c in full.noise:
                        v = [p.nrmse[c] for p in preds[lv] if c in p.nrmse]
                        if v:
                            row[f"out_{lv:g}_{c}_%"] = 100 * float(np.mean(v))
                            scores.append(float(np.mean(v)))
                row["score_%"] = 100 * float(np.mean(scores))
                row["note"] = (f"{len(full.fit.warnings)} identifiability warning(s)"
                               if full.fit.warnings else "")
                held[s.name] = (f, preds)
            except (ValueError, ArithmeticError) as err:
                row.update({"n_params": None, "score_%": math.inf, "note": f"failed: {err}"})
            rows.append(row)
    ok = [r for r in rows if math.isfinite(r["score_%"])]
    if not ok:
        raise ValueError("no structure could be fitted: " + "; ".join(r["note"] for r in rows))
    ok.sort(key=lambda r: r["score_%"])
    best = ok[0]
    near = [r for r in ok if r["score_%"] <= best["score_%"] * (1 + TIE)]
    pick = min(near, key=lambda r: (r["n_params"], r["score_%"]))
    runner = next((r for r in ok if r is not pick), None)
    reason = (f"lowest mean held-out NRMSE {pick['score_%']:.2f} % over {len(groups)} levels"
              if pick is best else
              f"fewest parameters ({pick['n_params']}) among structures within {100 * TIE:g} % "
              f"of the best held-out NRMSE ({best['structure']}, {best['score_%']:.2f} %)")
    if runner is not None:
        reason += f"; next: {runner['structure']} at {runner['score_%']:.2f} %"
    # held-out predictions of the chosen structure, with bands from its reduced-data covariance
    lv_max = max(groups)
    train = [e for e in exps if e.level != lv_max]
    f_top = fit_dynamics(train, Structure(*_parse_name(pick["structure"])), offset=offset,
                         limit=limit, start=fits[pick["structure"]].chain, **kwargs)
    held_out = {lv: p for lv, p in held[pick["structure"]][1].items()}
    held_out[lv_max] = [f_top.predict(e) for e in groups[lv_max]]
    return Selection(rows, pick["structure"], reason, fits, held_out, tuple(groups))


def _parse_name(name: str) -> tuple[str, bool]:
    return (name.removesuffix("+deadband"), name.endswith("+deadband"))


# ------------------------------------------------------------------------------------------------
# a known thruster for tests and the demo
# ------------------------------------------------------------------------------------------------
def reference_two_state_thruster(dead_band: tuple[float, float] = (0.4, 0.5)) -> ThrusterChain:
    """A ROV-sized two-state (Healey) thruster behind a ±5 V analog driver with a dead band:
    about 115 rad/s and 5 N at 3 V, about 40 % thrust overshoot on steps (the synthetic truth)."""
    return ThrusterChain(
        (Driver(deadband_fwd=dead_band[0], deadband_rev=dead_band[1], limit=5.0),
         HealeyThruster(inertia=1e-4, drive_gain=0.09, viscous=5e-4, torque_coefficient=1.3e-5,
                        thrust_coefficient=8e-4, thrust_coefficient_rev=6.4e-4,
                        inflow_coefficient=0.05, fluid_mass=1.0, flow_damping=4.5)),
        input_kind="command", name="two-state truth")


def synthetic_experiments(
    chain: ThrusterChain,
    levels: Sequence[float] = (2.0, 3.0),
    *,
    rate: float = 1000.0,
    duration: float = 6.0,
    noise: tuple[float, float] = (1.0, 0.15),
    seed: int = 0,
    both_directions: bool = True,
) -> list[Experiment]:
    """Bench-shaped records of ``chain`` at each command level (and its negative): rest, a slow
    ramp to the level (the shaft starts at the dead band), a hold, a release, a step back up and
    a release; sampled at ``rate`` Hz with white noise ``(speed σ rad/s, thrust σ N)`` (no
    thrust record when the chain has no thrust)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    t = np.arange(int(round(duration * rate)) + 1) * dt
    shape = np.interp(t / duration, [0, 0.08, 0.33, 0.5, 0.5001, 0.65, 0.6501, 0.85, 0.8501, 1],
                      [0, 0, 1, 1, 0, 0, 1, 1, 0, 0])
    out = []
    for lv in levels:
        for sgn in ((1.0, -1.0) if both_directions else (1.0,)):
            u = sgn * lv * shape
            r = chain.simulate(u, t[-1], dt=dt, substeps=1)
            sp = r["prop_speed"] + noise[0] * rng.standard_normal(t.size)
            th = (r["thrust"] + noise[1] * rng.standard_normal(t.size)
                  if "thrust" in r.channels else None)
            out.append(Experiment(t, u, sp, th, name=f"{'+' if sgn > 0 else '-'}{lv:g}V"))
    return out


def selection_demo(folder, *, rate: float = 200.0, families: Sequence[str] | None = None,
                   seed: int = 0) -> dict:
    """The whole story on the synthetic truth: records at ±2 V and ±3 V from
    :func:`reference_two_state_thruster`, selection by held-out level, the chosen chain fitted
    at ±2 V predicting ±3 V.  Writes ``selection.csv``, ``held_out.png`` and ``summary.json`` to
    ``folder``; returns the summary (table, chosen, reason, paths)."""
    from pathlib import Path

    from uuvid.core.atomic import atomic_write_json, atomic_write_text
    from uuvid.core.plots import save_figure

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    recs = synthetic_experiments(reference_two_state_thruster(), (2.0, 3.0), rate=rate, seed=seed)
    sel = select_structure(recs, families)
    png = save_figure(sel.plot(3.0), folder / "held_out.png")
    cols = sel.columns()
    atomic_write_text(folder / "selection.csv", ",".join(cols) + "\n" + "\n".join(
        ",".join(_fmt(r.get(c)).replace(",", ";") for c in cols) for r in sel.rows) + "\n")
    doc = {"truth": "Driver(dead band 0.4/0.5 V) → Healey two-state thruster", "rate_Hz": rate,
           **sel.to_dict(), "text": sel.to_text(), "figure": str(png),
           "held_out_3V": [r for p in sel.held_out[3.0] for r in p.rows()]}
    atomic_write_json(folder / "summary.json", doc)
    return doc
