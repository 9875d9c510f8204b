"""Dynamic identification of thruster chains from time series (step or arbitrary input).

Output-error identification: the chain is rebuilt from the parameter vector, simulated under each
run's recorded input with the compiled kernel (:func:`uuvid.thruster.kernels.rk4_chain`, the same
integrator as :meth:`ThrusterChain.simulate`) and compared with the recorded output; the
parameters minimise ``Σ_runs Σ_k (w_r (ŷ_k − y_k)/s_r)²`` (:func:`uuvid.identify.fit.nonlinear_lsq`,
trust-region reflective with bounds).  Standard errors come from the Jacobian of the residuals at
the optimum, ``cov = σ² (JᵀJ)⁻¹`` with ``σ² = |r|²/(n − p)`` (Caccia et al. 2000, §III), so they
assume white measurement noise; coloured noise or model error makes them optimistic.

Generic core: :func:`fit_chain` — any :class:`~uuvid.thruster.chain.ThrusterChain`, any block
field by name (``"blocks[0].time_constant"``, nested ``"blocks[0].motor.coulomb_torque"``, tied
parameters), several runs sharing the parameters (different voltages, different channels).

Model wrappers (which parameters each model's data can and cannot separate):

===================  =========================================  ====================================
model                free parameters                            identifiability
===================  =========================================  ====================================
FirstOrderMotor      gain ``K_m``, ``τ`` (Laidani eq. 3)        both, from any non-constant input
Yoerger              ``α``, ``β``: ``ẋ = βu − αx|x|``           both, from speed (``x``)
BessaDynamics        ``J_msp``, ``K_v1``, ``K_v2``              only ``K_t/(R_m J_msp)``,
                     (``K_t``, ``R_m`` fixed)                   ``K_v1/J_msp``, ``K_v2/J_msp``: the
                                                                ODE divided by ``J_msp``.  ``K_t``
                                                                and ``R_m`` are fixed (datasheet);
                                                                the three combinations are reported
DCMotor              ``K = K_T = K_G`` (tied, SI), ``J_M``,     speed alone gives 4 combinations
                     ``K_Q``, ``T_c``; with a current record     (``K/RJ``, ``(K²/R + C)/J``,
                     also ``R`` and viscous ``C_M``             ``K_Q/J``, ``T_c/J``): ``R`` and
                                                                ``C_M`` must be fixed.  Current
                                                                ``i = (V − Kω)/R`` separates ``K``
                                                                and ``R``, then all are free
TunnelThruster       ``α_o−α_i``, ``β_o−β_i``, ``K_a``          from thrust: steady level (Δβ, Δα
(McLean 1991)        (+ Coulomb, load-cell ζ)                   through the speed), spike height and
                                                                decay (``K_a``); motor constants
                                                                fixed (datasheet)
===================  =========================================  ====================================

Runs are validated once (same lengths, finite values, strictly increasing and uniformly sampled
time — or resampled on request — and more samples than free parameters).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from uuvid.core.checks import MAX_SUBSTEPS  # re-exported: most RK4 steps per sample/step
from uuvid.core.response import TimeResponse
from uuvid.core.result import Result, jsonable
from uuvid.core.threads import usable_cpus
from uuvid.identify.fit import (
    Fit,
    IdentifiabilityWarning,
    Parameter,
    nonlinear_lsq,
    propagated_variance,
)
from uuvid.thruster import kernels
from uuvid.thruster.blocks import (
    CH,
    CHANNELS,
    BessaDynamics,
    Block,
    DCMotor,
    FirstOrderMotor,
    LoadCell,
    ParameterError,
    TunnelThruster,
    Yoerger,
)
from uuvid.thruster.chain import ThrusterChain

__all__ = [
    "ChainFit",
    "FreeParameter",
    "Run",
    "fit_bessa",
    "fit_chain",
    "fit_dc_motor",
    "fit_first_order",
    "fit_tunnel_thruster",
    "fit_yoerger",
    "parse_free",
    "set_parameter",
    "validate_runs",
]

#: Channel names accepted for a run besides the chain's own (``speed`` = propeller speed).
CHANNEL_ALIASES = {"speed": "prop_speed", "measured": "measured_thrust", "force": "thrust"}

#: Relative tolerance on the sampling interval for a record to count as uniformly sampled.
UNIFORM_RTOL = 1e-3


# ------------------------------------------------------------------------------------------------
# runs
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Run:
    """One record: time ``t`` (s), the chain input ``u`` and one measured channel ``y``.

    ``channel`` names the simulated signal ``y`` is compared with: ``thrust`` (true thrust),
    ``measured_thrust`` (after a load cell), ``prop_speed`` (alias ``speed``), ``motor_speed``,
    ``current``, ``torque``.  ``weight`` multiplies the run's residuals; ``x0`` is the initial
    state (default: rest).  The input is held over each sample interval, as the simulator does.
    To fit thrust and speed of one experiment together, give two runs with the same ``t, u``
    (the same arrays: the chain is then simulated once for both).  ``sigma`` (the channel's
    noise, in its unit) divides the residuals instead of the ``normalize`` scale.
    """

    t: Any
    u: Any
    y: Any
    channel: str = "thrust"
    weight: float = 1.0
    x0: Sequence[float] | None = None
    name: str = ""
    sigma: float | None = None


@dataclass(frozen=True, eq=False)
class _Prepared:
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    dt: float
    channel: str
    ch: int
    weight: float
    scale: float
    x0: np.ndarray | None
    name: str
    resampled: bool


def _as_vector(name: str, a: Any) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} must be a numeric array: {e}") from None
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    return arr


def _resample(t: np.ndarray, u: np.ndarray, y: np.ndarray, dt: float):
    """Uniform grid from ``t[0]`` with step ``dt``: ``u`` zero-order held, ``y`` linear."""
    n = math.floor((t[-1] - t[0]) / dt + 1e-9) + 1
    tn = t[0] + dt * np.arange(n)
    idx = np.clip(np.searchsorted(t, tn, side="right") - 1, 0, t.size - 1)
    return tn, u[idx], np.interp(tn, t, y)


def validate_runs(
    runs: Iterable[Run] | Run,
    n_params: int = 0,
    *,
    resample: bool = False,
    uniform_rtol: float = UNIFORM_RTOL,
    normalize: bool | None = None,
) -> list[_Prepared]:
    """Check runs and turn them into arrays; raise ``ValueError`` naming the run and the index.

    * ``t``, ``u``, ``y`` one-dimensional, equally long, at least 3 samples, all finite;
    * ``t`` strictly increasing and uniformly sampled (every step within ``uniform_rtol`` of the
      mean step) — with ``resample=True`` a non-uniform record is put on a uniform grid of its
      median step (``u`` zero-order held, ``y`` linearly interpolated) instead of rejected;
    * more samples in total than ``n_params``.

    ``normalize``: divide each run's residuals by the RMS of its ``y`` (so runs of different
    channels or magnitudes weigh alike).  ``None`` → only when the runs mix channels.
    """
    if isinstance(runs, Run):
        runs = [runs]
    runs = list(runs)
    if not runs:
        raise ValueError("no runs given")
    prepared = []
    for k, r in enumerate(runs):
        if not isinstance(r, Run):
            raise TypeError(f"run {k} is not a Run(t, u, y, channel=...): {type(r).__name__}")
        label = f"run {k}" + (f" ({r.name})" if r.name else "")
        t = _as_vector(f"{label}: t", r.t)
        u = _as_vector(f"{label}: u", r.u)
        y = _as_vector(f"{label}: y", r.y)
        if not (t.size == u.size == y.size):
            raise ValueError(
                f"{label}: t, u and y must have the same length, got {t.size}, {u.size} and {y.size}"
            )
        if t.size < 3:
            raise ValueError(f"{label}: needs at least 3 samples, got {t.size}")
        for nm, a in (("t", t), ("u", u), ("y", y)):
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                raise ValueError(f"{label}: {nm}[{bad[0]}] is not finite ({a[bad[0]]!r})")
        d = np.diff(t)
        bad = np.flatnonzero(d <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            raise ValueError(
                f"{label}: t must be strictly increasing, but t[{i}] = {t[i]!r} <= t[{i - 1}] = {t[i - 1]!r}"
            )
        dt = (t[-1] - t[0]) / (t.size - 1)
        dev = np.max(np.abs(d - dt))
        resampled = False
        if dev > uniform_rtol * dt:
            if not resample:
                i = int(np.argmax(np.abs(d - dt)))
                raise ValueError(
                    f"{label}: t is not uniformly sampled (mean step {dt:.6g} s, but "
                    f"t[{i + 1}] − t[{i}] = {d[i]:.6g} s); resample it first or pass "
                    "resample=True (command line: --resample) to interpolate onto a uniform grid"
                )
            dt = float(np.median(d))
            t, u, y = _resample(t, u, y, dt)
            resampled = True
        channel = CHANNEL_ALIASES.get(r.channel, r.channel)
        if channel not in CH:
            raise ValueError(
                f"{label}: unknown channel {r.channel!r}; channels are {', '.join(CHANNELS[1:])} (or speed)"
            )
        if not (math.isfinite(r.weight) and r.weight > 0):
            raise ValueError(f"{label}: weight must be positive and finite, got {r.weight!r}")
        if r.sigma is not None and not (math.isfinite(r.sigma) and r.sigma > 0):
            raise ValueError(f"{label}: sigma must be positive and finite, got {r.sigma!r}")
        x0 = None if r.x0 is None else np.asarray(r.x0, dtype=float)
        prepared.append(
            _Prepared(
                t,
                u,
                y,
                float(dt),
                channel,
                CH[channel],
                float(r.weight),
                1.0 if r.sigma is None else float(r.sigma),
                x0,
                r.name or f"run{k}",
                resampled,
            )
        )
    n = sum(p.t.size for p in prepared)
    if n <= n_params:
        raise ValueError(
            f"too few samples: {n} in all runs for {n_params} free parameters "
            "(need more samples than parameters)"
        )
    if normalize is None:
        normalize = len({p.channel for p in prepared}) > 1
    if normalize:
        out = []
        for p, r in zip(prepared, runs):
            if r.sigma is not None:
                out.append(p)
                continue
            rms = float(np.sqrt(np.mean(p.y**2)))
            out.append(dataclasses.replace(p, scale=rms if rms > 0 else 1.0))
        prepared = out
    return prepared


# ------------------------------------------------------------------------------------------------
# parameters by name
# ------------------------------------------------------------------------------------------------
_PATH = re.compile(r"^blocks\[(\d+)\]\.([A-Za-z_][\w.]*)$")


@dataclass(frozen=True)
class FreeParameter:
    """A free parameter: its report name and the block fields it sets (several when tied)."""

    name: str
    targets: tuple[tuple[int, tuple[str, ...]], ...]

    def value_in(self, chain: ThrusterChain) -> float:
        b, attrs = self.targets[0]
        return float(_get(chain.blocks[b], attrs))


def _get(obj, attrs: Sequence[str]):
    for a in attrs:
        if not dataclasses.is_dataclass(obj) or a not in {f.name for f in dataclasses.fields(obj)}:
            have = [f.name for f in dataclasses.fields(obj)] if dataclasses.is_dataclass(obj) else []
            raise ValueError(f"{type(obj).__name__} has no parameter {a!r}; parameters: {', '.join(have)}")
        obj = getattr(obj, a)
    return obj


def _set(obj, attrs: Sequence[str], value):
    if len(attrs) == 1:
        return dataclasses.replace(obj, **{attrs[0]: value})
    return dataclasses.replace(obj, **{attrs[0]: _set(getattr(obj, attrs[0]), attrs[1:], value)})


def parse_free(chain: ThrusterChain, free) -> list[FreeParameter]:
    """Normalise a free-parameter specification.

    Accepted forms (may be mixed in a list):

    * ``{block_index: ["time_constant", "motor.coulomb_torque", ("torque_constant",
      "back_emf_constant")]}`` — a tuple ties several fields of the block to one value;
    * ``["blocks[0].time_constant", ("blocks[0].motor.torque_constant",
      "blocks[0].motor.back_emf_constant")]``.

    Every target must be a numeric field of the block (nested dataclasses by dots).
    """
    items: list = []
    if isinstance(free, Mapping):
        for b, names in free.items():
            if isinstance(names, str):
                names = [names]
            for nm in names:
                if isinstance(nm, (tuple, list)):
                    items.append(tuple(f"blocks[{b}].{x}" for x in nm))
                else:
                    items.append(f"blocks[{b}].{nm}")
    elif isinstance(free, str):
        items = [free]
    else:
        items = list(free)
    out, seen = [], set()
    for it in items:
        paths = (it,) if isinstance(it, str) else tuple(it)
        if not paths:
            raise ValueError("empty tied-parameter group")
        targets = []
        for p in paths:
            m = _PATH.match(p)
            if not m:
                raise ValueError(f"parameter {p!r} must look like 'blocks[0].time_constant'")
            b = int(m.group(1))
            if b >= len(chain.blocks):
                raise ValueError(f"parameter {p!r}: the chain has {len(chain.blocks)} block(s)")
            attrs = tuple(m.group(2).split("."))
            v = _get(chain.blocks[b], attrs)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
                raise ValueError(f"parameter {p!r} is not a number ({v!r})")  # noqa: TRY004
            if p in seen:
                raise ValueError(f"parameter {p!r} is listed twice")
            seen.add(p)
            targets.append((b, attrs))
        name = (
            paths[0] if len(paths) == 1 else paths[0] + "=" + "=".join(p.split(".", 1)[1] for p in paths[1:])
        )
        out.append(FreeParameter(name, tuple(targets)))
    if not out:
        raise ValueError("no free parameters")
    return out


def set_parameter(
    chain: ThrusterChain, changes: Mapping[str, float] | Sequence[tuple[FreeParameter, float]]
) -> ThrusterChain:
    """A copy of ``chain`` with parameters changed (blocks re-validated).

    ``changes``: ``{"blocks[0].time_constant": 0.2, ...}`` or ``[(FreeParameter, value), ...]``.
    """
    if isinstance(changes, Mapping):
        pairs = [(fp, v) for fp, v in zip(parse_free(chain, list(changes)), changes.values())]
    else:
        pairs = list(changes)
    blocks = list(chain.blocks)
    for fp, v in pairs:
        for b, attrs in fp.targets:
            blocks[b] = _set(blocks[b], attrs, float(v))
    return ThrusterChain(tuple(blocks), input_kind=chain.input_kind, name=chain.name)


# ------------------------------------------------------------------------------------------------
# simulation of a run with the compiled kernel
# ------------------------------------------------------------------------------------------------
MAX_RUN_STEPS = 50_000_000
"""Most RK4 steps one simulation of a run may take (the fit simulates it many times)."""


def check_step_budget(runs, max_step: float) -> None:
    """Refuse runs whose simulation would take unbounded time (``ValueError`` naming the run):
    samples seconds apart at a millisecond step — typically time in ms or µs read as s."""
    for r in runs:
        nsub = math.ceil(r.dt / max_step - 1e-9)
        total = nsub * r.t.size
        if nsub > MAX_SUBSTEPS or total > MAX_RUN_STEPS:
            raise ValueError(
                f"{r.name}: samples {r.dt:.6g} s apart ({r.t.size} samples over {r.t[-1] - r.t[0]:.6g} "
                f"s) need {nsub:,} RK4 steps of max_step = {max_step:g} s each, {total:.3g} in all "
                f"(limits {MAX_SUBSTEPS:,} per sample, {MAX_RUN_STEPS:.0e} per run): is the time "
                "column in ms or µs but read as seconds? Convert it to seconds (check the time "
                "unit), or cut the record")


def _simulate_run(chain: ThrusterChain, run: _Prepared, max_step: float) -> np.ndarray:
    """All channels of ``chain`` under ``run.u`` on ``run.t`` (samples × channels)."""
    c = chain.compile()
    nsub = max(1, math.ceil(run.dt / max_step - 1e-9))
    x0 = np.zeros(chain.n_states) if run.x0 is None else run.x0
    if x0.shape != (chain.n_states,):
        raise ValueError(f"{run.name}: x0 must have {chain.n_states} entries, got {x0.shape}")
    X = np.empty((run.t.size, chain.n_states))
    C = np.empty((run.t.size, len(CHANNELS)))
    kernels.rk4_chain(
        c.kinds,
        c.poff,
        c.params,
        c.soff,
        c.outch,
        c.in_ch,
        c.exact,
        np.ascontiguousarray(x0, dtype=float),
        np.ascontiguousarray(run.u),
        float(run.dt),
        nsub,
        X,
        C,
    )
    return C


def _jsonable(v):
    if isinstance(v, Block):
        return _jsonable(v.to_dict())
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


# ------------------------------------------------------------------------------------------------
# result
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ChainFit(Result):
    """A :class:`~uuvid.identify.fit.Fit` together with the fitted chain and the runs.

    ``fit.residuals`` are the weighted, scaled residuals the optimiser saw; per-run RMSE in the
    channel's own unit is in ``fit.extra["runs"]``.  Indexing (``result["blocks[0].alpha"]``),
    ``values``, ``stderrs``, ``summary()`` and ``as_dict()`` delegate to the fit.
    """

    fit: Fit
    chain: ThrusterChain
    runs: tuple[_Prepared, ...] = field(repr=False)
    free: tuple[FreeParameter, ...] = ()
    max_step: float = 1e-3

    def __getitem__(self, name: str) -> Parameter:
        return self.fit[name]

    def __contains__(self, name: str) -> bool:
        return name in self.fit

    @property
    def values(self) -> dict[str, float]:
        return self.fit.values

    @property
    def stderrs(self) -> dict[str, float]:
        return self.fit.stderrs

    @property
    def warnings(self) -> tuple[str, ...]:
        return self.fit.warnings

    def predict(self, run: int | Run = 0, channel: str | None = None) -> np.ndarray:
        """The fitted chain's ``channel`` (default: the run's) on a run's time grid."""
        if isinstance(run, Run):
            p = validate_runs([run], resample=True)[0]
        else:
            p = self.runs[run]
        ch = CH[CHANNEL_ALIASES.get(channel, channel)] if channel else p.ch
        return _simulate_run(self.chain, p, self.max_step)[:, ch]

    def response(self, run: int = 0) -> TimeResponse:
        """Every channel of the fitted chain on run ``run``'s grid, as a :class:`TimeResponse`."""
        p = self.runs[run]
        C = _simulate_run(self.chain, p, self.max_step)
        return TimeResponse(
            p.t,
            {n: C[:, i].copy() for i, n in enumerate(CHANNELS)},
            {"chain": self.chain.name, "run": p.name},
        ).recorded()

    report_title = "Dynamic thruster-chain fit"

    def summary(self) -> str:
        return self.fit.summary()

    def as_dict(self) -> dict:
        return self.fit.as_dict()

    def to_dict(self) -> dict:
        return jsonable({"chain": self.chain.name, **self.fit.as_dict()})

    def plot(self, run: int = 0):
        """Measured channel of run ``run`` and the fitted chain's prediction."""
        from uuvid.core.plots import new_figure

        p = self.runs[run]
        fig, ax = new_figure(figsize=(8, 3.6))
        ax.plot(p.t, p.y, ".", ms=2, color="0.5", label="measured")
        ax.plot(p.t, self.predict(run), "-", color="C1", label="fitted chain")
        ax.set_xlabel("t [s]")
        from uuvid.core.response import CHANNEL_UNITS

        ax.set_ylabel(f"{p.channel} [{CHANNEL_UNITS.get(p.channel) or 'SI'}]")
        ax.set_title(f"{self.chain.name}: {p.name}", fontsize=10)
        ax.legend(fontsize=8)
        return fig

    def __str__(self) -> str:
        return self.summary()


# ------------------------------------------------------------------------------------------------
# the generic fit
# ------------------------------------------------------------------------------------------------
def _check_channel(chain: ThrusterChain, runs: list[_Prepared], max_step: float) -> None:
    for r in runs:
        short = dataclasses.replace(r, t=r.t[:3], u=r.u[:3], y=r.y[:3])
        C = _simulate_run(chain, short, max_step)
        if np.all(np.isnan(C[:, r.ch])):
            made = [n for i, n in enumerate(CHANNELS) if not np.all(np.isnan(C[:, i]))]
            raise ValueError(
                f"{r.name}: the chain does not produce channel {r.channel!r}; it records {', '.join(made)}"
            )


def _bounds(
    template: ThrusterChain, free: list[FreeParameter], x0: np.ndarray, bounds
) -> tuple[np.ndarray, np.ndarray]:
    """Default: each parameter keeps the sign of its start; one starting at 0 is kept >= 0 when
    its block rejects negative values (friction, K_Q, …)."""
    p = len(free)
    lo = np.full(p, -np.inf)
    hi = np.full(p, np.inf)
    for i in range(p):
        if x0[i] > 0:
            lo[i] = 0.0
        elif x0[i] < 0:
            hi[i] = 0.0
        else:
            try:
                set_parameter(template, [(free[i], -1e-6)])
            except ParameterError:
                lo[i] = 0.0
    if bounds is None:
        return lo, hi
    if isinstance(bounds, Mapping):
        names = [f.name for f in free]
        for k, (a, b) in bounds.items():
            key = k if k in names else next((n for n in names if n.endswith("." + k)), None)
            if key is None:
                raise ValueError(
                    f"bounds given for {k!r}, which is not a free parameter ({', '.join(names)})"
                )
            i = names.index(key)
            lo[i] = -np.inf if a is None else float(a)
            hi[i] = np.inf if b is None else float(b)
    else:
        a, b = bounds
        lo = np.broadcast_to(np.asarray(a, dtype=float), (p,)).copy()
        hi = np.broadcast_to(np.asarray(b, dtype=float), (p,)).copy()
    bad = np.flatnonzero(~(lo < hi))
    if bad.size:
        raise ValueError(
            f"{free[bad[0]].name}: lower bound {lo[bad[0]]} is not below the upper bound {hi[bad[0]]}"
        )
    return lo, hi


def _fd_jacobian(fun, x, f0, steps, lo, hi, workers: int = 1):
    """Forward differences with per-parameter steps, stepping backwards at an upper bound.

    ``workers`` > 1 evaluates the columns in threads (each column is independent: the same
    numbers in any order; the compiled simulation releases the GIL)."""
    J = np.empty((f0.size, x.size))
    hs = []
    for i in range(x.size):
        h = steps[i]
        if x[i] + h > hi[i]:
            h = -h
        hs.append(h)

    def column(i):
        xp = x.copy()
        xp[i] += hs[i]
        J[:, i] = (fun(xp) - f0) / hs[i]

    if workers > 1 and x.size > 1:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(max_workers=min(workers, x.size)) as ex:
            list(ex.map(column, range(x.size)))
    else:
        for i in range(x.size):
            column(i)
    return J


def fit_chain(
    template: ThrusterChain,
    free,
    runs: Iterable[Run] | Run,
    *,
    bounds=None,
    x0=None,
    scale=None,
    normalize: bool | None = None,
    resample: bool = False,
    max_step: float = 1e-3,
    diff_step: float = 1e-6,
    model: str | None = None,
    units: Mapping[str, str] | None = None,
    emit_warnings: bool = True,
    **lsq_kwargs,
) -> ChainFit:
    """Fit free parameters of ``template`` to time series by output-error least squares.

    Parameters
    ----------
    template
        The chain whose structure and fixed parameters are used; free parameters start from its
        values unless ``x0`` is given.
    free
        Which parameters to estimate, see :func:`parse_free` (e.g. ``{0: ["alpha", "beta"]}``).
    runs
        :class:`Run` records sharing the parameters (e.g. steps at several voltages; a thrust run
        and a speed run of the same test).
    bounds
        ``{name: (lo, hi)}`` (name as reported, or its last part such as ``"time_constant"``) or
        ``(lo, hi)`` arrays.  Default: each parameter keeps the sign of its start value.
    x0
        Start values, a sequence in the order of ``free`` or ``{name: value}``.
    scale
        Typical magnitude of each parameter (finite-difference steps ``diff_step·max(|θ|, scale)``
        and trust-region scaling); default ``|x0|`` — give it for parameters starting at 0
        (where the default is 1).
    normalize, resample
        See :func:`validate_runs`.
    max_step
        Largest RK4 step (s); each sample interval is split into ``ceil(dt/max_step)`` steps.
    model, units
        Label and parameter units for the report.

    Returns a :class:`ChainFit` (``.fit`` is the :class:`Fit`, ``.chain`` the fitted chain).
    """
    if not isinstance(template, ThrusterChain):
        raise TypeError("template must be a ThrusterChain")
    fps = parse_free(template, free)
    names = [f.name for f in fps]
    prepared = validate_runs(runs, len(fps), resample=resample, normalize=normalize)
    if not (max_step > 0):
        raise ValueError(f"max_step must be positive, got {max_step}")
    check_step_budget(prepared, max_step)
    start = np.array([f.value_in(template) for f in fps], dtype=float)
    if x0 is not None:
        if isinstance(x0, Mapping):
            for k, v in x0.items():
                key = k if k in names else next((n for n in names if n.endswith("." + k)), None)
                if key is None:
                    raise ValueError(f"x0 given for {k!r}, which is not a free parameter")
                start[names.index(key)] = float(v)
        else:
            s = np.asarray(x0, dtype=float)
            if s.shape != start.shape:
                raise ValueError(f"x0 has {s.size} values for {start.size} free parameters")
            start = s.copy()
    lo, hi = _bounds(template, fps, start, bounds)
    if np.any(start < lo) or np.any(start > hi):
        i = int(np.flatnonzero((start < lo) | (start > hi))[0])
        raise ValueError(f"start value of {names[i]} ({start[i]}) is outside its bounds [{lo[i]}, {hi[i]}]")
    typ = (
        np.where(np.abs(start) > 0, np.abs(start), 1.0)
        if scale is None
        else np.broadcast_to(np.asarray(scale, dtype=float), start.shape).copy()
    )
    _check_channel(set_parameter(template, list(zip(fps, start))), prepared, max_step)
    n_total = sum(r.t.size for r in prepared)

    def build(theta):
        try:
            return set_parameter(template, list(zip(fps, theta)))
        except ParameterError as e:
            raise ValueError(
                f"parameters {dict(zip(names, theta))} are outside the model's valid range ({e}); give bounds"
            ) from None

    last: dict = {}  # the residual at the last point least_squares asked for (the Jacobian's f0)

    def residual_at(theta):
        out = residual(theta)
        last.clear()
        last[theta.tobytes()] = out.copy()
        return out

    def residual(theta):
        chain = build(theta)
        out = np.empty(n_total)
        k = 0
        sims: dict = {}  # runs sharing t and u (speed + thrust of one record) are simulated once
        for r in prepared:
            key = (id(r.t), id(r.u), None if r.x0 is None else r.x0.tobytes())
            if key not in sims:
                sims[key] = _simulate_run(chain, r, max_step)
            yhat = sims[key][:, r.ch]
            e = r.weight * (yhat - r.y) / r.scale
            out[k : k + e.size] = np.where(np.isfinite(e), e, 1e10)
            k += e.size
        return out

    workers = min(usable_cpus(), 4)

    def jac(theta):
        f0 = last.get(theta.tobytes())
        if f0 is None:
            f0 = residual(theta)
        steps = diff_step * np.maximum(np.abs(theta), typ)
        return _fd_jacobian(residual, theta, f0, steps, lo, hi, workers)

    label = model or f"{template.name}: " + "+".join(b.TYPE for b in template.blocks)
    units = dict(units or {})
    unit_list = [units.get(n, units.get(n.rsplit(".", 1)[-1].split("=")[0], "")) for n in names]
    fit = nonlinear_lsq(
        residual_at,
        start,
        names,
        model=label,
        units=unit_list,
        bounds=(lo, hi),
        x_scale=typ,
        jac=jac,
        emit_warnings=emit_warnings,
        **lsq_kwargs,
    )
    chain = build(np.array([fit.values[n] for n in names]))
    run_info = []
    for r in prepared:
        yhat = _simulate_run(chain, r, max_step)[:, r.ch]
        e = yhat - r.y
        run_info.append(
            {
                "name": r.name,
                "channel": r.channel,
                "samples": int(r.t.size),
                "dt": r.dt,
                "resampled": r.resampled,
                "weight": r.weight,
                "scale": r.scale,
                "rmse": float(np.sqrt(np.mean(e**2))),
                "bias": float(np.mean(e)),
            }
        )
    extra = dict(fit.extra)
    extra.update(
        {
            "chain": _jsonable(chain.to_dict()),
            "runs": run_info,
            "max_step": max_step,
            "normalized": any(r.scale != 1.0 for r in prepared),
        }
    )
    fit = dataclasses.replace(fit, extra=extra,
                              warnings=fit.warnings + _sampling_warnings(fit, prepared, emit_warnings))
    return ChainFit(fit, chain, tuple(prepared), tuple(fps), max_step)


#: samples per time constant below which a fitted τ is said to depend on the logging rate
SAMPLES_PER_TAU = 10


def _sampling_warnings(fit, prepared, emit: bool) -> tuple:
    """A fitted time constant the log samples coarsely: the command is held between samples
    (zero-order hold), so a step that fell between two samples is placed at one of them and τ is
    biased by up to half a sample step, beyond σ (exact first-order data with steps between
    samples: τ 0.050 s fitted as 0.047 at 100 Hz, 0.042 at 20 Hz, 0.025 at 10 Hz)."""
    import warnings as _w

    dt = float(np.median([r.dt for r in prepared])) if prepared else math.nan
    out = []
    for p in fit.parameters:
        if not p.name.endswith("time_constant") or p.fixed or not dt > 0:
            continue
        if p.value < dt:
            out.append(f"{p.name} = {p.value:.3g} s is shorter than the sample step {dt:.3g} s: "
                       "the log cannot resolve it (log faster, or fit a zero-order model)")
        elif p.value < SAMPLES_PER_TAU * dt:
            out.append(f"{p.name} = {p.value:.3g} s spans only {p.value / dt:.3g} sample steps "
                       f"of {dt:.3g} s: the command is held between samples, so a change between "
                       f"two of them is placed at one, biasing τ by up to {dt / 2:.2g} s beyond σ; "
                       f"log at least {SAMPLES_PER_TAU} samples per time constant")
    if emit:
        for m in out:
            _w.warn(m, IdentifiabilityWarning, stacklevel=3)
    return tuple(out)


# ------------------------------------------------------------------------------------------------
# start values from a step record
# ------------------------------------------------------------------------------------------------
def _step_guess(r: _Prepared) -> tuple[float, float, float, float]:
    """(input level, final output, initial slope, 63 % time) of a step-like record."""
    u_end = float(np.mean(r.u[-max(1, r.u.size // 10) :]))
    y_end = float(np.mean(r.y[-max(1, r.y.size // 10) :]))
    moved = np.flatnonzero(np.abs(r.u - r.u[0]) > 1e-12 * max(1.0, abs(u_end)))
    k0 = int(moved[0]) if moved.size and r.u[0] != u_end else 0
    y0 = float(r.y[k0])
    span = y_end - y0
    t63 = math.nan
    if span != 0:
        v = (r.y[k0:] - y0) / span
        hit = np.flatnonzero(v >= 1 - math.exp(-1))
        if hit.size:
            t63 = max(float(r.t[k0 + hit[0]] - r.t[k0]), r.dt)
    n = max(2, min(5, (r.y.size - k0) // 10))
    slope = (
        float(np.polyfit(r.t[k0 : k0 + n] - r.t[k0], r.y[k0 : k0 + n], 1)[0])
        if r.y.size - k0 >= n
        else math.nan
    )
    return u_end, y_end, slope, t63


def _remap(runs, channel: str) -> list[Run]:
    if isinstance(runs, Run):
        runs = [runs]
    return [dataclasses.replace(r, channel=channel) for r in runs]


# ------------------------------------------------------------------------------------------------
# model wrappers
# ------------------------------------------------------------------------------------------------
def fit_first_order(
    runs, gain: float | None = None, time_constant: float | None = None, *, bounds=None, **kwargs
) -> ChainFit:
    """Gain × first-order lag, ``y/u = K/(1 + τs)`` (:class:`FirstOrderMotor`, Laidani eq. 3).

    A UUV-Simulator ``FirstOrder`` block has unit gain; this fits the gain with it.  Whatever the
    runs' channel says (speed, thrust), ``y`` is compared with the first-order output.  Start
    values default to the final ratio ``y/u`` and the 63 % time of the first run.
    """
    runs = _remap(runs, "prop_speed")
    p = validate_runs(runs, 2, resample=kwargs.get("resample", False))[0]
    u_end, y_end, _, t63 = _step_guess(p)
    k0 = gain if gain is not None else (y_end / u_end if u_end else 1.0)
    tau0 = (
        time_constant
        if time_constant is not None
        else (t63 if math.isfinite(t63) else (p.t[-1] - p.t[0]) / 10)
    )
    if not k0 > 0:
        k0 = abs(k0) or 1.0
    chain = ThrusterChain(
        (FirstOrderMotor(gain=k0, time_constant=tau0),), input_kind="voltage", name="first-order"
    )
    return fit_chain(
        chain,
        {0: ["gain", "time_constant"]},
        runs,
        bounds=bounds,
        model="gain x FirstOrder: K/(1 + tau s)",
        units={"time_constant": "s"},
        **kwargs,
    )


def fit_yoerger(
    runs, alpha: float | None = None, beta: float | None = None, *, bounds=None, **kwargs
) -> ChainFit:
    """Yoerger et al. (1990), ``ẋ = βu − αx|x|`` (UUV Simulator ``Yoerger``), from speed ``x``.

    Both α and β are identifiable from the rotor state.  Start values: β from the initial slope
    (``ẋ(0⁺) = βu``), α from the steady state (``αx² = βu``) of the first run.
    """
    runs = _remap(runs, "prop_speed")
    p = validate_runs(runs, 2, resample=kwargs.get("resample", False))[0]
    u_end, y_end, slope, _ = _step_guess(p)
    b0 = (
        beta
        if beta is not None
        else (abs(slope / u_end) if u_end and math.isfinite(slope) and slope != 0 else 1.0)
    )
    a0 = alpha if alpha is not None else (abs(b0 * u_end) / y_end**2 if y_end else 1.0)
    chain = ThrusterChain((Yoerger(alpha=a0, beta=b0),), input_kind="command", name="yoerger")
    return fit_chain(
        chain,
        {0: ["alpha", "beta"]},
        runs,
        bounds=bounds,
        model="Yoerger: dx/dt = beta u - alpha x|x|",
        **kwargs,
    )


def fit_bessa(
    runs,
    *,
    kt: float = 1.0,
    rm: float = 1.0,
    jmsp: float = 1.0,
    kv1: float = 0.1,
    kv2: float = 0.01,
    free: Sequence[str] = ("jmsp", "kv1", "kv2"),
    bounds=None,
    **kwargs,
) -> ChainFit:
    """Bessa et al. (2005), ``J_msp ẋ = u K_t/R_m − K_v1 x − K_v2 x|x|``, from speed ``x``.

    Only three combinations are identifiable from ``x`` (divide the ODE by ``J_msp``):
    ``b_u = K_t/(R_m J_msp)``, ``b_1 = K_v1/J_msp``, ``b_2 = K_v2/J_msp``.  ``K_t`` and ``R_m`` are
    therefore fixed (motor datasheet) and ``J_msp, K_v1, K_v2`` fitted; the three combinations,
    with σ by the delta method, are in ``fit.extra["identifiable"]``.
    """
    runs = _remap(runs, "prop_speed")
    chain = ThrusterChain(
        (BessaDynamics(jmsp=jmsp, kv1=kv1, kv2=kv2, kt=kt, rm=rm),), input_kind="command", name="bessa"
    )
    bad = [f for f in free if f in ("kt", "rm")]
    if bad and {"jmsp"} <= set(free):
        raise ValueError(
            f"{', '.join(bad)} and jmsp are not separately identifiable from speed "
            "(only K_t/(R_m J_msp) is): fix one of them"
        )
    res = fit_chain(
        chain,
        {0: list(free)},
        runs,
        bounds=bounds,
        model="Bessa: Jmsp dx/dt = u Kt/Rm - Kv1 x - Kv2 x|x|",
        **kwargs,
    )
    b = res.chain.blocks[0]
    names = [f"blocks[0].{f}" for f in free]
    cov = res.fit.covariance
    theta = {"jmsp": b.jmsp, "kv1": b.kv1, "kv2": b.kv2, "kt": b.kt, "rm": b.rm}

    def combos(th):
        return np.array([th["kt"] / (th["rm"] * th["jmsp"]), th["kv1"] / th["jmsp"], th["kv2"] / th["jmsp"]])

    g0 = combos(theta)
    G = np.zeros((3, len(free)))
    for j, f in enumerate(free):
        h = 1e-7 * max(abs(theta[f]), 1e-300)
        th = dict(theta)
        th[f] += h
        G[:, j] = (combos(th) - g0) / h
    var = propagated_variance(G, cov)
    ident = {
        nm: {"estimate": float(v), "sigma": float(math.sqrt(max(var[i], 0.0)))}
        for i, (nm, v) in enumerate(zip(("Kt/(Rm Jmsp)", "Kv1/Jmsp", "Kv2/Jmsp"), g0))
    }
    extra = dict(res.fit.extra)
    extra["identifiable"] = ident
    extra["fixed"] = {k: theta[k] for k in theta if f"blocks[0].{k}" not in names}
    return dataclasses.replace(res, fit=dataclasses.replace(res.fit, extra=extra))


def fit_dc_motor(runs, motor: DCMotor, free: Sequence | None = None, *, bounds=None, **kwargs) -> ChainFit:
    """McLean's DC motor (:class:`DCMotor`, eqs. 2.1–2.5) from speed and optionally current.

    ``K_T`` and ``K_G`` are one constant in SI units and are fitted tied (``K``).  From the
    propeller (or motor) speed alone four combinations are identifiable — ``K/(RJ)``,
    ``(K²/R + C)/J``, ``K_Q/J`` and ``T_c/J`` — so by default ``R`` and the motor viscous
    friction ``C_M`` stay fixed and ``K, J_M, K_Q, T_c`` are fitted.  When a run records
    ``current`` (``i = (V − Kω)/R``), ``R`` and ``C_M`` are fitted too.  ``K_Q`` and ``T_c`` are
    free only if the start motor has them non-zero.  Give ``free`` (field names) to override.
    """
    runs = list(runs) if not isinstance(runs, Run) else [runs]
    has_current = any(CHANNEL_ALIASES.get(r.channel, r.channel) == "current" for r in runs)
    if free is None:
        free = [("torque_constant", "back_emf_constant"), "motor_inertia"]
        if has_current:
            free += ["resistance"]
            if motor.motor_viscous > 0:
                free += ["motor_viscous"]
        if motor.torque_coefficient > 0:
            free.append("torque_coefficient")
        if motor.coulomb_torque > 0:
            free.append("coulomb_torque")
    chain = ThrusterChain((motor,), input_kind="voltage", name="dc-motor")
    units = {
        "torque_constant": "N·m/A",
        "resistance": "Ω",
        "motor_inertia": "kg·m²",
        "motor_viscous": "N·m·s/rad",
        "torque_coefficient": "N·m·s²/rad²",
        "coulomb_torque": "N·m",
    }
    res = fit_chain(
        chain, {0: list(free)}, runs, bounds=bounds, model="DC motor (McLean 2.1-2.5)", units=units, **kwargs
    )
    return res


def fit_tunnel_thruster(
    runs,
    thruster: TunnelThruster,
    *,
    load_cell: LoadCell | None = None,
    free: Sequence | None = None,
    bounds=None,
    **kwargs,
) -> ChainFit:
    """McLean's tunnel thruster (:class:`TunnelThruster`, eqs. 2.12–2.16), optionally seen
    through the rig's load cell (runs on ``measured_thrust``).

    Default free parameters: ``energy_correction`` (α_o − α_i), ``momentum_correction``
    (β_o − β_i) and ``added_mass_coefficient`` (K_a); the motor constants stay at the datasheet.
    Field names may be nested (``"motor.coulomb_torque"``); load-cell fields are given as
    ``"load_cell.damping_ratio"``.
    """
    blocks = (thruster,) if load_cell is None else (thruster, load_cell)
    chain = ThrusterChain(blocks, input_kind="voltage", name="tunnel-thruster")
    if free is None:
        free = ["energy_correction", "momentum_correction", "added_mass_coefficient"]
    spec = []
    for f in free:
        if isinstance(f, str) and f.startswith("load_cell."):
            if load_cell is None:
                raise ValueError(f"{f!r}: no load cell in the chain")
            spec.append(f"blocks[1].{f.split('.', 1)[1]}")
        elif isinstance(f, str):
            spec.append(f"blocks[0].{f}")
        else:
            spec.append(tuple(f"blocks[0].{x}" for x in f))
    return fit_chain(chain, spec, runs, bounds=bounds, model="McLean tunnel thruster", **kwargs)
