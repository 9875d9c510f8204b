"""Disturbances as blocks: a generalized force added to the thrusters' in the mission loop.

A :class:`Disturbance` ``fn(t, eta, nu, params, tau_out)`` writes a body-frame generalized force
[X Y Z K M N] (N, N·m) that the vehicle feels on top of the thrust ``B η f`` (waves, a tether, a
towed load): ``M ν̇ + C(ν_r) ν_r + D(ν_r) ν_r + g(η) = B η f + τ_d(t, η, ν)`` (Fossen 2011,
eq. 8.1, the environmental term).  ``eta`` = [north, east, down, q0..q3], ``nu`` = [u v w p q r].
The loop evaluates it at the start of every integration substep (``dt / substeps``) and holds
it over the substep.  Currents stay the kinematic models of :mod:`uuvid.simulate.currents`
(they enter through the relative velocity, not as a force).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit


@njit(cache=True)
def no_disturbance(t, eta, nu, params, tau_out):
    """τ_d = 0."""
    for j in range(6):
        tau_out[j] = 0.0


@njit(cache=True)
def sinusoidal_force(t, eta, nu, params, tau_out):
    """``τ_d,j = A_j sin(ω t + φ) + c_j`` with ``params`` = [A (6), c (6), ω, φ] — a first-order
    wave force at one frequency (Fossen 2011, §8.2) on top of a constant force ``c`` (e.g. a
    tether's mean pull), body frame."""
    s = math.sin(params[12] * t + params[13])
    for j in range(6):
        tau_out[j] = params[j] * s + params[6 + j]


@dataclass(frozen=True)
class Disturbance:
    """A disturbance block: numba-compiled ``fn(t, eta, nu, params, tau_out)`` and its params."""

    fn: object
    params: np.ndarray
    name: str = ""  # default: the function's name

    def __post_init__(self):
        from numba.core.registry import CPUDispatcher

        if not isinstance(self.fn, CPUDispatcher):
            raise TypeError("Disturbance.fn must be a numba @njit function "
                            f"(fn(t, eta, nu, params, tau_out)), got {type(self.fn).__name__}")
        p = np.ascontiguousarray(np.ravel(np.asarray(self.params, dtype=np.float64)))
        p.flags.writeable = False
        object.__setattr__(self, "params", p)
        if not self.name:
            object.__setattr__(self, "name", getattr(self.fn, "__name__", "") or "user")


def sinusoidal(amplitude=(0.0,) * 6, period: float = math.inf, phase: float = 0.0,
               constant=(0.0,) * 6) -> Disturbance:
    """:func:`sinusoidal_force` with amplitude ``A`` (6, N and N·m), period (s; ``inf`` = none),
    phase (rad) and a constant part ``c`` (6)."""
    a = np.asarray(amplitude, dtype=float)
    c = np.asarray(constant, dtype=float)
    if a.shape != (6,) or c.shape != (6,):
        raise ValueError(f"amplitude and constant need 6 values [X Y Z K M N], got {a.shape}, {c.shape}")
    if not period > 0:
        raise ValueError(f"period must be > 0 s, got {period}")
    w = 0.0 if math.isinf(period) else 2 * math.pi / period
    return Disturbance(sinusoidal_force, np.concatenate([a, c, [w, phase]]), "sinusoidal")
