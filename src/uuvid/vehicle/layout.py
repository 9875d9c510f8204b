"""Thruster geometry → thrust configuration matrix ``B`` (6 × n).

A thruster at position ``r`` (body axes, from CO, NED/FRD: x forward, y starboard, z down) whose
positive thrust pushes along the unit vector ``a`` contributes the column ``[a ; r × a]`` to
``B``, so the generalised force is ``τ = B f`` for thrusts ``f`` (Fossen 2011, "Control
allocation"; UUV Simulator's ``tam`` from the thruster poses).  An axis may be given as
roll-pitch-yaw of the thruster frame instead (the thrust acts along the thruster's own x axis,
``a = R(φ, θ, ψ) e_x``).

Each thruster also carries its model reference (a thruster preset name or a model-file path),
its thrust limits ``[min, max]`` (N, ``min ≤ 0 ≤ max``) and its installation coefficients per
thrust-mapping mode (Caccia et al. 2000): ``η₊`` for positive and ``η₋`` for negative commanded
thrust; delivered thrust = η · commanded.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from uuvid.thruster.blocks import ParameterError
from uuvid.vehicle.kinematics import euler_to_rotmat
from uuvid.vehicle.model import DOF_NAMES

DOF_INDEX = {name: i for i, name in enumerate(DOF_NAMES)}
DOF_INDEX.update({"x": 0, "y": 1, "z": 2, "k": 3, "m": 4, "n": 5,
                  "X": 0, "Y": 1, "Z": 2, "K": 3, "M": 4, "N": 5})


def dof_index(d) -> int:
    """``'surge'``/``'X'``/``0`` → 0, …, ``'yaw'``/``'N'``/``5`` → 5."""
    if isinstance(d, (int, np.integer)):
        if not 0 <= int(d) < 6:
            raise ValueError(f"DOF index must be 0…5, got {d}")
        return int(d)
    try:
        return DOF_INDEX[d]
    except KeyError:
        raise ValueError(f"unknown DOF {d!r}; use one of {list(DOF_NAMES)}") from None


def axis_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Thrust direction of a thruster frame rotated by zyx Euler angles (rad): ``R e_x``."""
    return euler_to_rotmat(roll, pitch, yaw)[:, 0]


def thrust_configuration_matrix(positions, axes) -> np.ndarray:
    """``B`` (6 × n) with columns ``[a_i ; r_i × a_i]`` (UUV Simulator's ``tam``)."""
    P = np.atleast_2d(np.asarray(positions, dtype=float))
    A = np.atleast_2d(np.asarray(axes, dtype=float))
    if P.shape != A.shape or P.shape[1] != 3:
        raise ValueError(f"positions {P.shape} and axes {A.shape} must both be (n, 3)")
    return np.vstack([A.T, np.cross(P, A).T])


@dataclass(frozen=True, eq=False)
class Thruster:
    """One thruster of a vehicle (see the module docstring)."""

    name: str
    position: tuple[float, float, float]
    axis: tuple[float, float, float]
    model: str = ""
    limits: tuple[float, float] = (-math.inf, math.inf)
    installation: Mapping[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self):
        pos = tuple(float(v) for v in self.position)
        if len(pos) != 3 or not all(math.isfinite(v) for v in pos):
            raise ParameterError(f"thruster {self.name}: position must be 3 finite numbers",
                                 "position")
        ax = np.asarray(self.axis, dtype=float)
        n = float(np.linalg.norm(ax)) if ax.shape == (3,) else 0.0
        if ax.shape != (3,) or not np.all(np.isfinite(ax)) or n < 1e-9:
            raise ParameterError(f"thruster {self.name}: axis must be a non-zero 3-vector", "axis")
        lo, hi = (float(v) for v in self.limits)
        if math.isnan(lo) or math.isnan(hi) or not lo <= 0.0 <= hi:
            raise ParameterError(f"thruster {self.name}: limits must satisfy min <= 0 <= max, got "
                                 f"[{lo}, {hi}]", "limits")
        inst = {}
        for mode, eta in dict(self.installation).items():
            e = (float(eta), float(eta)) if np.ndim(eta) == 0 else tuple(float(v) for v in eta)
            if len(e) != 2 or not all(math.isfinite(v) and v > 0 for v in e):
                raise ParameterError(f"thruster {self.name}: installation[{mode}] must be a "
                                     "positive number or [positive, negative-thrust] pair",
                                     "installation")
            inst[str(mode)] = e
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "axis", tuple(float(v) for v in ax / n))
        object.__setattr__(self, "limits", (lo, hi))
        object.__setattr__(self, "installation", inst)

    @classmethod
    def from_rpy(cls, name: str, position, rpy, **kw) -> Thruster:
        """Axis from the thruster frame's zyx Euler angles (rad)."""
        return cls(name, tuple(position), tuple(axis_from_rpy(*rpy)), **kw)

    @property
    def column(self) -> np.ndarray:
        """``[a ; r × a]``."""
        a = np.array(self.axis)
        return np.concatenate([a, np.cross(np.array(self.position), a)])

    def eta(self, mode: str | None) -> tuple[float, float]:
        """Installation coefficients ``(η₊, η₋)`` in ``mode`` (1, 1 when not listed)."""
        if mode is None:
            return (1.0, 1.0)
        return self.installation.get(mode, (1.0, 1.0))


@dataclass(frozen=True, eq=False)
class ThrusterLayout:
    """The thrusters of a vehicle, in column order of ``B``."""

    thrusters: tuple[Thruster, ...]

    def __post_init__(self):
        th = tuple(self.thrusters)
        names = [t.name for t in th]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ParameterError(f"duplicate thruster names {sorted(dup)}", "name")
        object.__setattr__(self, "thrusters", th)

    def __len__(self) -> int:
        return len(self.thrusters)

    def __iter__(self):
        return iter(self.thrusters)

    def __getitem__(self, i) -> Thruster:
        return self.thrusters[self.index(i)] if isinstance(i, str) else self.thrusters[i]

    @property
    def n(self) -> int:
        return len(self.thrusters)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(t.name for t in self.thrusters)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no thruster {name!r}; have {list(self.names)}") from None

    @property
    def B(self) -> np.ndarray:
        """Thrust configuration matrix (6 × n), read-only: it is computed from the thrusters at
        every access, so a write into it (``veh.B[0, 0] = 5``) would be lost without a word."""
        if not self.thrusters:
            return _read_only(np.zeros((6, 0)))
        return _read_only(thrust_configuration_matrix([t.position for t in self.thrusters],
                                                      [t.axis for t in self.thrusters]))

    @property
    def limits(self) -> np.ndarray:
        """``(n, 2)`` array of ``[min, max]`` thrust, N; read-only, as :attr:`B` (a new array
        at every access: change a thruster's ``limits`` instead)."""
        return _read_only(np.array([t.limits for t in self.thrusters], dtype=float).reshape(-1, 2))

    def eta(self, mode: str | None) -> tuple[np.ndarray, np.ndarray]:
        """Per-thruster ``(η₊, η₋)`` arrays in ``mode``."""
        e = np.array([t.eta(mode) for t in self.thrusters], dtype=float).reshape(-1, 2)
        return e[:, 0].copy(), e[:, 1].copy()

    def models(self) -> tuple[str, ...]:
        return tuple(t.model for t in self.thrusters)


def _read_only(a: np.ndarray) -> np.ndarray:
    """``a``, which cannot be written any more (assignment raises "assignment destination is
    read-only")."""
    a.flags.writeable = False
    return a


def layout_from_arrays(positions, axes, limits=None, names: Sequence[str] | None = None,
                       model: str = "") -> ThrusterLayout:
    """A layout from plain arrays (tests, scripts)."""
    P = np.asarray(positions, dtype=float)
    A = np.asarray(axes, dtype=float)
    n = len(P)
    lim = np.tile([-math.inf, math.inf], (n, 1)) if limits is None else np.asarray(limits, float)
    names = list(names) if names is not None else [f"T{i + 1}" for i in range(n)]
    return ThrusterLayout(tuple(Thruster(names[i], tuple(P[i]), tuple(A[i]), model,
                                         tuple(np.broadcast_to(lim, (n, 2))[i]))
                                for i in range(n)))
