"""Recorded thruster commands (servo PWM outputs) → thrust per thruster → generalized force.

One path for every log that records the outputs rather than the force: ArduSub's
``SERVO_OUTPUT_RAW`` / ``RCOU``, MAVROS ``/mavros/rc/out``.  Output *i* drives the vehicle's
thruster *i*; each thruster's own model gives its steady thrust at the recorded command
(``ThrusterChain.steady_thrust``), the thrust configuration matrix the force,
``τ = B T`` (Fossen 2011, eq. 12.222; UUV Simulator's ``tam``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["servo_thrust", "servo_generalized_force", "thruster_chains"]


def thruster_chains(vehicle) -> list:
    """The thruster model of every thruster of ``vehicle``; each must take a command (PWM) as
    input, else ``ValueError`` naming the thruster."""
    chains = []
    for j, th in enumerate(vehicle.layout):
        try:
            c = vehicle.thruster_chain(j)
        except KeyError as e:
            raise ValueError(str(e.args[0]) if e.args else str(e)) from None
        if c.signal_kinds[0] != "command":
            raise ValueError(f"{vehicle.name}: thruster {th.name}'s model {c.name!r} is driven by "
                             f"{c.signal_kinds[0]}, not a PWM command: the servo outputs cannot be "
                             "turned into thrust")
        chains.append(c)
    return chains


def servo_thrust(vehicle, pwm, *, chains=None, max_table: int = 401) -> np.ndarray:
    """Steady thrust [N] of each thruster at recorded commands: ``pwm`` is (n_thrusters, n).

    Servo outputs are whole µs, so each thruster model is evaluated once per distinct value (a
    1 µs grid and linear interpolation when there are more than ``max_table`` distinct values);
    models shared by several thrusters are evaluated once."""
    pwm = np.asarray(pwm, dtype=float)
    n = vehicle.layout.n
    if pwm.ndim != 2 or pwm.shape[0] != n:
        raise ValueError(f"{vehicle.name} has {n} thrusters; got commands of shape {pwm.shape}")
    chains = thruster_chains(vehicle) if chains is None else chains
    cache: dict = {}
    T = np.empty(pwm.shape)
    for j in range(n):
        u, inv = np.unique(pwm[j], return_inverse=True)
        table = cache.setdefault(vehicle.layout[j].model, {})
        todo = np.array([x for x in u.tolist() if x not in table and math.isfinite(x)])
        if todo.size:
            if todo.size > max_table:
                grid = np.arange(math.floor(todo.min()), math.ceil(todo.max()) + 1.0)
                vals = np.interp(todo, grid, chains[j].steady_thrust(grid))
            else:
                vals = chains[j].steady_thrust(todo)
            table.update(zip(todo.tolist(), np.atleast_1d(vals).tolist()))
        T[j] = np.array([table.get(x, math.nan) for x in u.tolist()])[inv]
    return T


def servo_generalized_force(vehicle, pwm, *, chains=None) -> tuple[np.ndarray, np.ndarray]:
    """(thrust T (n_thrusters, n) [N], generalized force τ = B T (6, n) [N, N·m])."""
    T = servo_thrust(vehicle, pwm, chains=chains)
    return T, vehicle.B @ T
