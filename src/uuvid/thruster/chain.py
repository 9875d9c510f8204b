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

from uuvid.simulate import kernels
from uuvid.simulate.response import TimeResponse
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
    """

    blocks: tuple[Block, ...]
    input_kind: str | None = None
    name: str = "thruster"
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
        kernels.eval_chain(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch,
                           np.asarray(x, dtype=float), float(u), dx, ch, blk)
        return dx, dict(zip(CHANNELS, ch))

    def rhs(self) -> Callable[[float, np.ndarray, float], np.ndarray]:
        """``f(t, x, u) → ẋ`` for reference integrators such as ``solve_ivp``."""
        c = self.compile()
        n = self.n_states
        ch = np.empty(len(CHANNELS))
        blk = np.empty(max(len(self.blocks), 1))

        def f(t, x, u):
            dx = np.zeros(n)
            kernels.eval_chain(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch,
                               np.asarray(x, dtype=float), float(u), dx, ch, blk)
            return dx

        return f

    def steady_thrust(self, u) -> np.ndarray:
        """Steady-state chain output for constant inputs ``u`` (static chains: exact; dynamic
        chains: the equilibrium reached by simulating each input to rest)."""
        u = np.atleast_1d(np.asarray(u, dtype=float))
        if self.n_states == 0:
            c = self.compile()
            out = np.empty(u.size)
            ch = np.empty(len(CHANNELS))
            blk = np.empty(max(len(self.blocks), 1))
            dx = np.zeros(0)
            for k, uk in enumerate(u):  # static map: one compiled call per point, no ODE
                out[k] = kernels.eval_chain(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch,
                                            dx, uk, dx, ch, blk)
            return out
        return self.sweep(u).final

    def sweep(self, u, settle_time: float | None = None, dt: float = 1e-3,
              max_passes: int = 8, rtol: float = 1e-9) -> SweepResult:
        """Hold each input in ``u`` from rest until steady; returns the final channels per input.

        Runs are batched through the compiled kernel in parallel.  Each pass lasts ``settle_time``
        (default: :meth:`settling_time_hint`); levels whose output still moves by more than
        ``rtol`` of the output scale run another pass from where they stopped, up to
        ``max_passes``; levels still moving after that are reported in ``not_converged``.
        """
        u = np.atleast_1d(np.asarray(u, dtype=float))
        settle = settle_time if settle_time is not None else self.settling_time_hint()
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
            kernels.sweep_chain(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch, c.exact,
                                np.ascontiguousarray(X[todo]), np.ascontiguousarray(u[todo]),
                                float(dt), nsamp, f, xf)
            finals[todo] = f
            X[todo] = xf
            y = f[:, out_ch]
            if prev is None:
                # levels whose state no longer moves (relative rate × pass length below rtol) are
                # at rest already; only the others need a second pass to confirm it
                rates = np.empty(todo.size)
                floor = 1e-12 * max(float(np.max(np.abs(xf))), 1e-300) if xf.size else 1.0
                kernels.relative_rates(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch,
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
                           not_converged=tuple(float(v) for v in u[todo]) if prev is not None and nx else ())

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
        if not (t_end > 0 and dt > 0):
            raise ValueError(f"t_end and dt must be positive, got t_end={t_end}, dt={dt}")
        if int(substeps) < 1:
            raise ValueError(f"substeps must be >= 1, got {substeps}")
        n = int(round(t_end / dt)) + 1
        t = np.arange(n) * dt
        u = _sample_signal(signal, t)
        c = self.compile()
        x0a = np.zeros(self.n_states) if x0 is None else np.asarray(x0, dtype=float)
        if x0a.shape != (self.n_states,):
            raise ValueError(f"x0 must have {self.n_states} entries, got {x0a.shape}")
        X = np.empty((n, self.n_states))
        C = np.empty((n, len(CHANNELS)))
        kernels.rk4_chain(c.kinds, c.poff, c.params, c.soff, c.outch, c.in_ch, c.exact, x0a, u,
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
        n = int(round(t_end / dt)) + 1
        t = np.arange(n) * dt
        u = _sample_signal(signal, t)
        c = self.compile()
        P = np.ascontiguousarray(chains_params, dtype=np.float64)
        if P.ndim != 2 or P.shape[1] != c.params.size:
            raise ValueError(f"parameter batch must have shape (runs, {c.params.size})")
        Y = np.empty((P.shape[0], n))
        kernels.rk4_chain_batch(c.kinds, c.poff, P, c.soff, c.outch, c.in_ch, c.exact,
                                np.zeros(self.n_states), u, float(dt), int(substeps), CH[channel], Y)
        return Y

    def to_dict(self) -> dict:
        return {"name": self.name, "input": self.input_kind,
                "blocks": [b.to_dict() for b in self.blocks]}


@dataclass(frozen=True)
class SweepResult:
    """Steady channels reached for each constant input of a sweep."""

    inputs: np.ndarray
    channels: dict[str, np.ndarray]
    output: str = "thrust"
    not_converged: tuple[float, ...] = ()

    @property
    def final(self) -> np.ndarray:
        """The chain's output signal at rest, for each input."""
        return self.channels[self.output]


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
