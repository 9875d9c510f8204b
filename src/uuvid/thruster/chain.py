"""Composition of thruster blocks, like a block diagram: command → driver → motor → map → rig.

``ThrusterChain`` checks that each block accepts the signal the previous one produces, flattens the
blocks into the arrays the compiled kernel needs, and simulates the chain under any input signal
(:func:`ThrusterChain.simulate`).  The same chain evaluates steady maps (:meth:`steady_thrust`)
and exposes its right-hand side for a reference ``scipy.integrate.solve_ivp`` run (:meth:`rhs`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from uuvid.core.checks import (
    MAX_SUBSTEPS,  # re-exported: most RK4 steps per sample/step
    count,
    finite_values,
    real,
)
from uuvid.core.response import CHANNEL_UNITS, TimeResponse
from uuvid.core.result import Result, jsonable
from uuvid.thruster.blocks import (
    _SIGNAL_CHANNEL,
    CH,
    CHANNELS,
    COMMAND,
    K_FIRST_ORDER,
    K_FIRST_ORDER_MOTOR,
    Block,
    ParameterError,
)

_STATIC_STATES = 0
_STEADY_CACHE = "steady_maps"  # sub-folder of the kernel cache for swept steady tables
_SWEEP_DT, _SWEEP_PASSES, _SWEEP_RTOL = 1e-3, 8, 1e-9  # sweep() defaults (part of the cache key)
MAX_SAMPLES = 2_000_000
"""Most output samples (× runs) one simulation holds in memory (≈ :data:`SAMPLE_BYTES` each)."""
SAMPLE_BYTES = 200
"""Memory one output sample of a simulation takes, roughly: its time, input, states and channels."""
MAX_RUN_STEPS = 50_000_000
"""Most RK4 steps one simulated run may take (≈ 100 s at the ≈ 0.5 M steps/s of a T200 chain)."""
MAX_SWEEP_STEPS = 20 * MAX_RUN_STEPS
"""Most integration steps a sweep may take (levels × pass length / dt, all passes, were no level
to settle early): minutes of compute, ≈ 20 at the very worst (it was 1e12: hours); 2,600 levels
at the defaults of a 3 s settling chain.  Each level's own passes are one run, held to
:data:`MAX_RUN_STEPS` like a simulation's."""


def _n_samples(t_end, dt, substeps, runs: int = 1, names: tuple[str, str, str] | None = None,
               max_samples: int = MAX_SAMPLES, sample_bytes: int = SAMPLE_BYTES) -> int:
    """Output samples of a simulation, checked before anything is allocated: at least 3 (what a
    response needs: a start, a middle and an end), at most :data:`MAX_SAMPLES` (× runs) in memory
    and :data:`MAX_RUN_STEPS` RK4 steps per run.  ``names``: what the messages call t_end, dt and
    substeps (e.g. a file's keys), instead of the simulate options (``--t-end``…);
    ``max_samples``/``sample_bytes``: the limit and the size of a sample for a caller that keeps
    less of each (a sweep keeps a run's input and metrics, not its channels)."""
    tn, dn, sn = names or ("t_end", "dt", "substeps")
    tf, df, sf = ("", "", "") if names else (" (--t-end)", " (--dt)", " (--substeps)")
    # text from a script ("1.3") failed in math.isfinite with "must be real number, not str",
    # naming no argument
    real(tn, t_end, "a finite simulated time > 0 in s")
    real(dn, dt, "a finite output step > 0 in s")
    real(sn, substeps, "a number of RK4 steps per output sample >= 1", integer=True)
    if not (math.isfinite(t_end) and t_end > 0):
        raise ValueError(f"{tn} = {t_end:g}: expected a finite simulated time > 0 s{tf}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"{dn} = {dt:g}: expected a finite output step > 0 s{df}")
    if int(substeps) < 1:
        raise ValueError(f"{sn} = {substeps}: expected RK4 steps per output sample >= 1{sf}")
    if int(substeps) > MAX_SUBSTEPS:
        raise ValueError(f"{sn} = {int(substeps):,} RK4 steps per output sample is more than "
                         f"{MAX_SUBSTEPS:,} (a step of dt/{MAX_SUBSTEPS:,} buys no accuracy, only "
                         f"time); lower {sn}{sf} or the output step {dn}{df}")
    n = t_end / dt + 1
    if n < 2.5:  # round(t_end/dt) + 1 < 3
        raise ValueError(f"{tn} = {t_end:g} s at {dn} = {dt:g} s gives {int(round(n))} output "
                         f"sample(s); a response needs at least 3: give {tn} >= 2 {dn}"
                         + (" (--t-end, --dt)" if not names else ""))
    if n * max(runs, 1) > max_samples:
        per = f" × {runs} runs" if runs > 1 else ""
        raise ValueError(f"{tn} = {t_end:g} s at {dn} = {dt:g} s is {n:.3g} samples{per} (≈ "
                         f"{n * max(runs, 1) * sample_bytes / 1e9:.3g} GB), more than the "
                         f"{max_samples:,} a simulation may hold in memory; shorten {tn}{tf} or "
                         f"raise {dn}{df}")
    if n * int(substeps) > MAX_RUN_STEPS:
        raise ValueError(f"{tn} = {t_end:g} s at {dn} = {dt:g} s with {sn} = {int(substeps)} is "
                         f"{n * int(substeps):.3g} RK4 steps, more than the {MAX_RUN_STEPS:.0e} "
                         f"one run may take (minutes of compute); lower {sn}{sf}, shorten {tn}{tf} "
                         f"or raise {dn}{df}")
    return int(round(t_end / dt)) + 1


def _pow2(log2: float) -> str:
    """``2**log2`` for a message, as ``3.84e+09`` — or ``10^301030`` beyond a float's range."""
    return f"{2.0 ** log2:.3g}" if log2 < 1000 else f"10^{log2 * math.log10(2):.0f}"


def _kernel_code_digest() -> str:
    """Digest of the code a swept steady table comes from: the blocks, kernels and this module,
    and the whole package's :func:`~uuvid.core.cache.code_version` (version + source hash)."""
    global _CODE_DIGEST
    if _CODE_DIGEST is None:
        from importlib.util import find_spec

        from uuvid.core.cache import code_version, file_digest
        from uuvid.thruster import blocks as _blocks

        kernels_py = find_spec("uuvid.thruster.kernels").origin  # located, not imported (numba)
        _CODE_DIGEST = file_digest(_blocks.__file__, kernels_py, __file__) + code_version()
    return _CODE_DIGEST


_CODE_DIGEST: str | None = None


def _kernels():
    """The compiled kernels, imported on first use (numba's import is most of a process start-up;
    closed-form steady maps and model inspection do not need it)."""
    from uuvid.thruster import kernels

    return kernels


@dataclass(frozen=True)
class Compiled:
    """Flat arrays describing a chain to the kernel."""

    kinds: np.ndarray
    poff: np.ndarray
    params: np.ndarray
    soff: np.ndarray
    outch: np.ndarray
    in_ch: int
    exact: np.ndarray


@dataclass(frozen=True)
class ThrusterChain:
    """An ordered, validated composition of blocks.

    Parameters
    ----------
    blocks
        The blocks in signal order.
    input_kind
        The signal the chain is driven by (``command``, ``voltage`` or ``speed``); by default the
        first signal the first block accepts.
    name
        A label for reports.
    inflow
        What a bench run in a flow identified about the thrust's loss with the water speed
        (``{form, parameters: {name: {estimate, sigma, unit}}, flow_levels_m_s, ...}``, see
        :func:`uuvid.identify.thruster.workflow`'s inflow fits); the blocks stay the bollard map.
        Metadata: it takes no part in the chain's dynamics, equality or hash.
    fit_supply_voltages
        The supply voltages [V] of the data the chain was fitted on (sorted), when known; a
        supply asked of the model is said to be inside or outside them.  Metadata, like ``inflow``.
    """

    blocks: tuple[Block, ...]
    input_kind: str | None = None
    name: str = "thruster"
    inflow: dict | None = field(default=None, compare=False, hash=False, repr=False)
    fit_supply_voltages: tuple[float, ...] | None = field(default=None, compare=False, hash=False,
                                                           repr=False)
    _kinds: tuple[str, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        blocks = tuple(self.blocks)
        if not blocks:
            raise ParameterError("a thruster chain needs at least one block")
        object.__setattr__(self, "blocks", blocks)
        kind = self.input_kind or blocks[0].INPUTS[0]
        object.__setattr__(self, "input_kind", kind)
        kinds = [kind]
        for i, b in enumerate(blocks):
            if not isinstance(b, Block):
                raise ParameterError(f"block {i} is not a uuvid block: {b!r}")
            if kinds[-1] not in b.INPUTS:
                prev = "the chain input" if i == 0 else f"block {i - 1} ({blocks[i - 1].TYPE})"
                raise ParameterError(
                    f"block {i} ({b.TYPE}) takes {' or '.join(b.INPUTS)}, but {prev} gives "
                    f"{kinds[-1]}")
            kinds.append(b.output_kind(kinds[-1]))
        object.__setattr__(self, "_kinds", tuple(kinds))

    # ---------------------------------------------------------------- structure
    @property
    def signal_kinds(self) -> tuple[str, ...]:
        """Signal kind at the chain input and after every block."""
        return self._kinds

    @property
    def output_kind(self) -> str:
        return self._kinds[-1]

    @property
    def n_states(self) -> int:
        return sum(b.n_states for b in self.blocks)

    def compile(self) -> Compiled:
        kinds = np.array([b.KIND for b in self.blocks], dtype=np.int64)
        parts = [b.params_array() for b in self.blocks]
        poff = np.zeros(len(parts) + 1, dtype=np.int64)
        poff[1:] = np.cumsum([len(p) for p in parts])
        params = np.concatenate(parts) if poff[-1] else np.zeros(0)
        soff = np.zeros(len(self.blocks) + 1, dtype=np.int64)
        soff[1:] = np.cumsum([b.n_states for b in self.blocks])
        outch = np.array([CH[_SIGNAL_CHANNEL[k]] for k in self._kinds[1:]], dtype=np.int64)
        in_ch = CH[_SIGNAL_CHANNEL[self._kinds[0]]] if self._kinds[0] != COMMAND else 0
        exact = np.zeros(len(self.blocks), dtype=np.bool_)
        upstream_static = True
        for i, b in enumerate(self.blocks):
            if b.KIND in (K_FIRST_ORDER, K_FIRST_ORDER_MOTOR) and upstream_static:
                exact[i] = True
            if b.n_states:
                upstream_static = False
        return Compiled(kinds, poff, params.astype(np.float64), soff, outch, in_ch, exact)

    # ---------------------------------------------------------------- evaluation
    def evaluate(self, x: np.ndarray, u: float) -> tuple[np.ndarray, dict[str, float]]:
        """State derivative and channels at one (state, input) point."""
        c = self.compile()
        dx = np.zeros(self.n_states)
        ch = np.empty(len(CHANNELS))
        blk = np.empty(max(len(self.blocks), 1))
        _kernels().eval_chain(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch,
                           np.asarray(x, dtype=float), float(u), dx, ch, blk)
        return dx, dict(zip(CHANNELS, ch))

    def rhs(self) -> Callable[[float, np.ndarray, float], np.ndarray]:
        """``f(t, x, u) → ẋ`` for reference integrators such as ``solve_ivp``."""
        c = self.compile()
        n = self.n_states
        ch = np.empty(len(CHANNELS))
        blk = np.empty(max(len(self.blocks), 1))
        eval_chain = _kernels().eval_chain

        def f(t, x, u):
            dx = np.zeros(n)
            eval_chain(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch,
                       np.asarray(x, dtype=float), float(u), dx, ch, blk)
            return dx

        return f

    @property
    def has_closed_form_steady(self) -> bool:
        """Every block knows its output at rest in closed form (static maps, first-order lags,
        ZeroOrder, Yoerger, Bessa, the load cell): :meth:`steady_thrust` composes them, no
        simulation."""
        probe = np.zeros(1)
        return all(b.steady_output(probe) is not None for b in self.blocks)

    def steady_thrust(self, u, *, cache: bool = True) -> np.ndarray:
        """Steady-state chain output for constant inputs ``u``.

        Chains whose blocks all have a closed-form output at rest (:attr:`has_closed_form_steady`:
        static maps and first-order lags, whose state at rest equals their input times their DC
        gain) compose those maps — exact, no simulation.  Other chains (a DC motor with Coulomb
        friction, McLean's tunnel thruster, a load cell behind them…) are simulated to rest
        (:meth:`sweep`); that table is cached on disk (:mod:`uuvid.core.cache`, ``steady_maps``)
        under a hash of the chain's parameters, the levels and the kernel code, unless
        ``cache=False``.  Levels the sweep could not bring to rest are never cached."""
        # a NaN level went through the closed-form maps as a thrust of 0 (a T200's dead band)
        u = np.atleast_1d(finite_values("u", u, what="finite input levels"))
        y = u
        for b in self.blocks:
            y = b.steady_output(y)
            if y is None:
                break
        else:
            return np.asarray(y, dtype=float).reshape(u.shape)
        if not cache:
            return self.sweep(u).final
        from uuvid.core import cache as disk

        key = self._steady_key(u)
        y = disk.load_array(_STEADY_CACHE, key, u.shape)
        if y is not None:
            return y
        res = self.sweep(u)
        if not res.not_converged and np.all(np.isfinite(res.final)):
            disk.store_array(_STEADY_CACHE, key, res.final)
        return res.final

    def _steady_key(self, u: np.ndarray) -> str:
        """Hash of everything a swept steady table depends on: the compiled chain, the output,
        the levels, the sweep's defaults and the uuvid version and code that computes it."""
        from uuvid import __version__
        from uuvid.core.cache import digest

        c = self.compile()
        settings = (_SWEEP_DT, _SWEEP_PASSES, _SWEEP_RTOL)
        return digest("steady-v1", __version__, _kernel_code_digest(), c.kinds, c.poff, c.params,
                      c.soff, c.outch, c.in_ch, c.exact, self.output_kind, self.settling_time_hint(),
                      settings, u)

    def sweep(self, u, settle_time: float | None = None, dt: float = _SWEEP_DT,
              max_passes: int = _SWEEP_PASSES, rtol: float = _SWEEP_RTOL) -> SweepResult:
        """Hold each input in ``u`` from rest until steady; returns the final channels per input.

        Runs are batched through the compiled kernel in parallel.  Each pass lasts ``settle_time``
        (default: :meth:`settling_time_hint`); levels whose output still moves by more than
        ``rtol`` of the output scale run another pass from where they stopped, up to
        ``max_passes``; levels still moving after that are reported in ``not_converged``.
        """
        u = np.atleast_1d(np.asarray(u, dtype=float))
        if u.ndim != 1 or not np.all(np.isfinite(u)):
            bad = np.flatnonzero(~np.isfinite(u.ravel()))
            raise ValueError("sweep: u must be finite input levels (a 1-D array)"
                             + (f"; u[{bad[0]}] = {float(u.ravel()[bad[0]])!r}" if bad.size else
                                f", got shape {u.shape}"))
        settle = settle_time if settle_time is not None else self.settling_time_hint()
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"sweep: dt must be a finite step > 0 s, got {dt!r}")
        if not (math.isfinite(settle) and settle > 0):
            raise ValueError(f"sweep: settle_time must be a finite time > 0 s, got {settle!r}")
        max_passes = count("sweep: max_passes", max_passes, minimum=1)
        if not rtol > 0:
            raise ValueError(f"sweep: rtol = {rtol!r}: expected a relative tolerance > 0")
        # pass lengths settle, settle, 2·settle, … : a level's passes last settle · 2^(P−1) in all
        # (taken in logarithms: 2.0 ** (10**6) overflowed, a bare OverflowError)
        # (a chain without states runs one pass whatever max_passes says)
        log2_run = math.log2(settle / dt) + (max_passes - 1 if self.n_states else 0)
        if log2_run > math.log2(MAX_RUN_STEPS):
            raise ValueError(
                f"sweep: settle_time {settle:g} s at dt = {dt:g} s over up to max_passes = "
                f"{max_passes} passes (each doubling the last) is up to "
                f"{_pow2(log2_run)} steps per level, more than the {MAX_RUN_STEPS:.0e} one run may "
                "take (minutes of compute); lower max_passes, raise dt or shorten settle_time")
        log2_all = log2_run + math.log2(max(u.size, 1))
        if log2_all > math.log2(MAX_SWEEP_STEPS):
            raise ValueError(
                f"sweep: {u.size} levels × {settle:g} s / dt {dt:g} s over up to max_passes = "
                f"{max_passes} passes is up to {_pow2(log2_all)} steps, more than the "
                f"{MAX_SWEEP_STEPS:.0e} a sweep may take (minutes of compute); raise dt, shorten "
                "settle_time or use fewer levels or passes")
        nsamp = int(math.ceil(settle / dt)) + 1
        c = self.compile()
        nx = self.n_states
        finals = np.empty((u.size, len(CHANNELS)))
        X = np.zeros((u.size, nx))
        out_ch = CH[_SIGNAL_CHANNEL[self.output_kind]]
        todo = np.arange(u.size)
        prev = None
        last_change = np.zeros(u.size)
        for k in range(max_passes if nx else 1):
            # pass lengths settle, settle, 2·settle, 4·settle, … so slow equilibria are reached
            nsamp = int(math.ceil(settle * max(1, 2 ** (k - 1)) / dt)) + 1
            f = np.empty((todo.size, len(CHANNELS)))
            xf = np.empty((todo.size, nx))
            kern = _kernels()
            sweep = (kern.sweep_chain if kern.parallel_pays(todo.size, nsamp)
                     else kern.sweep_chain_serial)
            sweep(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch, c.exact,
                  np.ascontiguousarray(X[todo]), np.ascontiguousarray(u[todo]), float(dt), nsamp, f, xf)
            finals[todo] = f
            X[todo] = xf
            y = f[:, out_ch]
            if prev is None:
                # levels whose state no longer moves (relative rate × pass length below rtol) are
                # at rest already; only the others need a second pass to confirm it
                rates = np.empty(todo.size)
                floor = 1e-12 * max(float(np.max(np.abs(xf))), 1e-300) if xf.size else 1.0
                _kernels().relative_rates(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch,
                                       np.ascontiguousarray(xf), np.ascontiguousarray(u[todo]),
                                       floor, rates)
                moving = rates * settle > rtol
                todo, prev = todo[moving], y[moving]
                if todo.size == 0:
                    break
                continue
            scale = max(float(np.nanmax(np.abs(finals[:, out_ch]))), 1e-300)
            change = np.abs(y - prev)
            last_change[todo] = change / scale
            moving = change > rtol * scale
            todo, prev = todo[moving], y[moving]
            if todo.size == 0:
                break
        # keep refining to rtol, but only call a level unsettled if its last pass still moved it
        # by more than 1e-6 of the output scale
        todo = todo[last_change[todo] > 1e-6]
        if nx and todo.size and prev is not None:
            import warnings

            warnings.warn(f"{self.name}: {todo.size} input level(s) still not at rest after "
                          f"{max_passes} passes (e.g. u = {u[todo[0]]:g}); their output is the "
                          "last value reached", RuntimeWarning, stacklevel=2)
        return SweepResult(u, {name: finals[:, i] for i, name in enumerate(CHANNELS)},
                           output=_SIGNAL_CHANNEL[self.output_kind],
                           not_converged=tuple(float(v) for v in u[todo]) if prev is not None and nx else (),
                           input_unit=self.input_unit())

    def input_unit(self) -> str:
        """Unit of the chain's input: an ESC's command unit (µs, V, duty), else V or rad/s."""
        from uuvid.thruster.blocks import ESC

        first = self.blocks[0] if self.blocks else None
        if isinstance(first, ESC):
            return {"pwm_us": "µs", "volts": "V"}.get(first.command_unit, first.command_unit)
        return {"voltage": "V", "speed": "rad/s"}.get(self.input_kind, "")

    def channel_units(self) -> dict:
        """Units of the simulated channels (SI, ``time`` in s) with the command's in the chain's
        own unit (:meth:`input_unit`: its ESC's µs, V or duty, else V or rad/s)."""
        from uuvid.core.response import CHANNEL_UNITS

        units = dict(CHANNEL_UNITS, time="s")
        u = self.input_unit()
        if u:
            units["command"] = "duty (−1..1)" if u == "duty" else u
        return units

    def fastest_time_constant(self) -> float | None:
        """The shortest time constant we know of in the chain (for step-size advice)."""
        taus = []
        for b in self.blocks:
            tau = getattr(b, "time_constant", None)
            if tau:
                taus.append(tau)
            motor = getattr(b, "motor", b)
            if getattr(motor, "inductance", 0) > 0:
                taus.append(motor.inductance / motor.resistance)
            if b.TYPE == "load_cell":
                taus.append(1.0 / b.natural_frequency)
        return min(taus) if taus else None

    def settling_time_hint(self) -> float:
        """A generous time to reach steady state (10× the slowest time constant we know of)."""
        hint = 0.5
        for b in self.blocks:
            tau = getattr(b, "time_constant", None)
            if tau:
                hint = max(hint, 10 * tau)
            if b.TYPE == "tunnel_thruster":
                hint = max(hint, 3.0)
            if b.TYPE in ("dc_motor", "yoerger", "bessa", "load_cell", "healey"):
                hint = max(hint, 3.0)
        return hint

    # ---------------------------------------------------------------- simulation
    def simulate(self, signal, t_end: float, dt: float = 1e-3, substeps: int = 4,
                 x0: Sequence[float] | None = None) -> TimeResponse:
        """Simulate the chain from rest (or ``x0``) under ``signal`` for ``t_end`` seconds.

        ``signal`` is a callable of a time array (see :mod:`uuvid.simulate.signals`), a constant, or
        an array of samples on the output grid ``t = 0, dt, 2dt, …``.  The input is held over each
        output interval; ``substeps`` RK4 steps advance the state inside it (fixed step
        ``dt/substeps``; convergence against ``solve_ivp`` is tested).
        """
        # x0 first: a NaN state was flown and reported as 'diverged … use a smaller dt'
        x0a = np.zeros(self.n_states) if x0 is None else finite_values(
            "x0", x0, (self.n_states,), "finite numbers, the chain's initial state")
        n = _n_samples(t_end, dt, substeps)
        t = np.arange(n) * dt
        u = _sample_signal(signal, t)
        c = self.compile()
        X = np.empty((n, self.n_states))
        C = np.empty((n, len(CHANNELS)))
        _kernels().rk4_chain(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch, c.exact, x0a, u,
                          float(dt), int(substeps), X, C)
        if self.n_states and not np.all(np.isfinite(X)):
            k = int(np.flatnonzero(~np.all(np.isfinite(X), axis=1))[0])
            fast = self.fastest_time_constant()
            hint = f"; the fastest time constant of this chain is about {fast:.3g} s" if fast else ""
            raise ValueError(
                f"{self.name}: the simulation diverged at t = {t[k]:.6g} s with step "
                f"dt/substeps = {dt / substeps:.3g} s{hint} — use a smaller dt or more substeps")
        chans = {name: C[:, i].copy() for i, name in enumerate(CHANNELS)}
        meta = {"chain": self.name, "dt": dt, "substeps": substeps,
                "blocks": [b.TYPE for b in self.blocks]}
        if hasattr(signal, "describe"):
            meta["signal"] = signal.describe()
        return TimeResponse(t, chans, meta).recorded()

    def simulate_batch(self, chains_params: np.ndarray, signal, t_end: float, dt: float = 1e-3,
                       substeps: int = 4, channel: str = "thrust") -> np.ndarray:
        """Simulate many parameter vectors (rows, same layout as ``compile().params``) in parallel;
        returns ``channel`` as an array ``(runs, samples)``."""
        if channel not in CH:
            raise ValueError(f"channel {channel!r}: expected one of {', '.join(CHANNELS)}")
        c = self.compile()
        P = np.ascontiguousarray(chains_params, dtype=np.float64)
        if P.ndim != 2 or P.shape[1] != c.params.size:
            raise ValueError(f"chains_params: expected shape (runs, {c.params.size}) (rows like "
                             f"compile().params), got {P.shape}")
        bad = np.isnan(P) | (np.isinf(P) & np.isfinite(c.params)[None])
        if bad.any():
            r, j = (int(i) for i in np.argwhere(bad)[0])
            raise ValueError(f"chains_params[{r}, {j}] = {float(P[r, j])!r}: expected finite values")
        n = _n_samples(t_end, dt, substeps, runs=P.shape[0])
        t = np.arange(n) * dt
        u = _sample_signal(signal, t)
        Y = np.empty((P.shape[0], n))
        _kernels().rk4_chain_batch(c.kinds, c.poff, P, c.soff, c.outch, c.in_ch, c.exact,
                                np.zeros(self.n_states), u, float(dt), int(substeps), CH[channel], Y)
        return Y

    def to_dict(self) -> dict:
        return {"name": self.name, "input": self.input_kind,
                "blocks": [b.to_dict() for b in self.blocks]}


#: Pulse widths a servo/ESC output can carry (µs): ArduPilot's SERVOn_MIN/MAX bounds.
PWM_PLAUSIBLE_US = (800.0, 2200.0)


def command_range_warnings(x, esc, unit: str = "") -> list[str]:
    """Commands ``x`` an ESC cannot be given: PWM outside :data:`PWM_PLAUSIBLE_US` (a wrong unit
    or a typo, not a wish for more thrust; the ESC clips it to the end of its full-command range
    ``[saturation_low, saturation_high]``).  Empty when every command is plausible."""
    x = np.asarray(x, float)
    if unit != "µs":
        return []
    lo, hi = PWM_PLAUSIBLE_US
    bad = x[(x < lo) | (x > hi)]
    if not bad.size:
        return []
    hint = ""
    if np.all(np.abs(bad) <= 1.0):
        hint = (" — these look like duties (−1…1), not pulse widths: give µs, e.g. "
                f"{esc.saturation_low:g}:{esc.saturation_high:g}:100")
    return [f"{bad.size} command(s) outside {lo:g}–{hi:g} µs, the pulse widths a servo output "
            f"carries (e.g. {bad[0]:g} µs) — check the unit; the ESC expects "
            f"{esc.saturation_low:g}–{esc.saturation_high:g} µs and would clip them to those "
            f"ends{hint}"]


#: Above this a motor voltage (V) is no small thruster's supply (a PWM width or a typo).
VOLTAGE_PLAUSIBLE_V = 100.0


def voltage_range_warnings(x, chain) -> list[str]:
    """Inputs of a chain driven by its motor voltage (``input_kind == 'voltage'``, no ESC) above
    :data:`VOLTAGE_PLAUSIBLE_V`: a pulse width in µs (800–2200) or a typo, simulated as volts —
    McLean's 24 V motor given 1500 pushed 825 N, and 1e9 "diverged" with advice to shorten dt."""
    if getattr(chain, "input_kind", None) != "voltage":
        return []
    x = np.asarray(x, float)
    bad = x[np.abs(x) > VOLTAGE_PLAUSIBLE_V]
    if not bad.size:
        return []
    lo, hi = PWM_PLAUSIBLE_US
    hint = (" — these look like PWM pulse widths (µs): this model has no ESC and takes volts; "
            "give volts, or a model with an ESC (e.g. t200)") if np.all((bad >= lo) & (bad <= hi)) \
        else ""
    return [f"{bad.size} input(s) above {VOLTAGE_PLAUSIBLE_V:g} V (e.g. {bad[0]:g} V) to "
            f"{chain.name or 'a model'}, driven by its motor voltage — unusual for a small "
            f"thruster: check the unit{hint}"]


def signal_range_warnings(chain, signal, t_end: float) -> list[str]:
    """:func:`voltage_range_warnings` of ``signal`` (a callable of time) sampled over
    ``[0, t_end]``, said before a simulation (a wrong unit may make it diverge); empty when the
    signal cannot be sampled (the simulation then says what is wrong with it)."""
    try:
        u = signal(np.linspace(0.0, float(t_end), 1001)) if callable(signal) else None
    except Exception:  # noqa: BLE001 - the simulation says what is wrong with the signal
        return []
    return voltage_range_warnings(u, chain) if u is not None else []


def zero_output_warnings(x, y, neutral: float = 0.0) -> list[str]:
    """One sentence when a steady map gives exactly zero at every input away from ``neutral``
    (e.g. a quadratic fit whose coefficients were clamped to 0): a model that cannot push."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    away = x != neutral
    if not away.any() or np.any(y[away] != 0) or np.any(~np.isfinite(y[away])):
        return []
    return [f"the model gives zero output at all {int(away.sum())} inputs away from neutral "
            f"({x[away].min():g}…{x[away].max():g}): it cannot push — check the model file (a fit "
            "of data with a reversed thrust sign, or inputs inside its dead band)"]


def monotonicity_warnings(x, y, neutral: float = 0.0, rel_tol: float = 1e-3) -> list[str]:
    """Where a steady map ``y(x)`` stops growing in magnitude away from ``neutral``.

    A real thruster gives more thrust for more command; a map whose output *falls* with more
    command (on either side of neutral) is being used outside the range it was identified on —
    e.g. a polynomial of propeller speed beyond the fastest speed of its bench data, reached at a
    higher supply voltage.  Returns one sentence per side where that happens (empty: monotone)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    out = []
    scale = float(np.nanmax(np.abs(y))) if y.size else 0.0
    for side, name in ((1.0, "forward"), (-1.0, "reverse")):
        m = side * (x - neutral) > 0
        if m.sum() < 2:
            continue
        order = np.argsort(side * (x[m] - neutral))
        xs, ys = x[m][order], side * y[m][order]
        peak = np.maximum.accumulate(ys)
        drop = np.flatnonzero(ys < peak - rel_tol * max(scale, 1e-12))
        if drop.size:
            k = int(drop[0])
            j = int(np.argmax(ys[:k + 1]))
            out.append(f"{name}: the steady output falls from {side * ys[j]:.4g} at {xs[j]:.6g} to "
                       f"{side * ys[k]:.4g} at {xs[k]:.6g} — the model is used beyond the range it "
                       "was identified on (e.g. a polynomial map past the fastest speed of its "
                       "bench data); do not trust it there")
    return out


def steady_map_agreement(chain: ThrusterChain, u) -> dict:
    """How :meth:`ThrusterChain.steady_thrust` (closed form when the chain has one) compares with
    simulating the chain to rest (:meth:`ThrusterChain.sweep`) at the inputs ``u``: the largest
    difference relative to the output scale and the time each took."""
    import time

    u = np.atleast_1d(np.asarray(u, dtype=float))
    t0 = time.perf_counter()
    fast = chain.steady_thrust(u, cache=False)
    t1 = time.perf_counter()
    swept = chain.sweep(u).final
    t2 = time.perf_counter()
    scale = max(float(np.max(np.abs(swept))), 1e-300)
    return {"chain": chain.name, "closed_form": chain.has_closed_form_steady, "levels": int(u.size),
            "max_relative_difference": float(np.max(np.abs(fast - swept)) / scale),
            "steady_thrust_s": t1 - t0, "sweep_s": t2 - t1}


@dataclass(frozen=True)
class SweepResult(Result):
    """Steady channels reached for each constant input of a sweep."""

    inputs: np.ndarray
    channels: dict[str, np.ndarray]
    output: str = "thrust"
    not_converged: tuple[float, ...] = ()
    input_unit: str = ""

    @property
    def final(self) -> np.ndarray:
        """The chain's output signal at rest, for each input."""
        return self.channels[self.output]

    report_title = "Steady sweep"

    def summary(self) -> str:
        x = np.asarray(self.inputs, dtype=float)
        lines = [f"steady sweep: {x.size} inputs in [{x.min():.4g}, {x.max():.4g}], output "
                 f"{self.output}"]
        for k, v in self.channels.items():
            a = np.asarray(v, dtype=float)
            ok = a[np.isfinite(a)]
            if ok.size:
                lines.append(f"  {k:<14} [{ok.min():.4g}, {ok.max():.4g}] "
                             f"{CHANNEL_UNITS.get(k, '')}")
        if self.not_converged:
            lines.append(f"  not settled at inputs: {', '.join(f'{u:g}' for u in self.not_converged)}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return jsonable({"inputs": self.inputs, "channels": dict(self.channels),
                         "output": self.output, "not_converged": list(self.not_converged)})

    def plot(self):
        """Each steady channel against the input."""
        from uuvid.core.plots import new_figure

        names = [k for k, v in self.channels.items() if np.any(np.isfinite(v))] or [self.output]
        fig, ax = new_figure(len(names), 1, squeeze=False, sharex=True,
                             figsize=(7, 1.2 + 2.2 * len(names)))
        for a, k in zip(ax[:, 0], names):
            a.plot(self.inputs, self.channels[k], ".-", ms=3)
            a.set_ylabel(f"{k} [{CHANNEL_UNITS.get(k, '')}]")
        ax[-1, 0].set_xlabel(f"input [{self.input_unit or 'the chain input unit'}]")
        ax[0, 0].set_title(f"Steady {self.output} against the input ({len(self.inputs)} levels)")
        return fig


def _sample_signal(signal, t: np.ndarray) -> np.ndarray:
    if callable(signal):
        u = np.asarray(signal(t), dtype=float)
    elif np.ndim(signal) == 0:
        u = np.full(t.shape, float(signal))
    else:
        u = np.asarray(signal, dtype=float)
    if u.shape != t.shape:
        raise ValueError(f"input has {u.size} samples, the time grid has {t.size}")
    bad = np.flatnonzero(~np.isfinite(u))
    if bad.size:
        raise ValueError(f"input sample {bad[0]} (t = {t[bad[0]]:g} s) is not finite")
    return np.ascontiguousarray(u)
