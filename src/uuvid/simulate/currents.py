"""Water currents for missions: constant, a measured time series, or a first-order Gauss–Markov
process (as UUV Simulator's ``GaussMarkovProcess``), sampled on the mission's control steps.

Every model returns the current ``v_c`` (NED, m/s) at the step times and its rate ``v̇_c``; the
mission loop applies ``v_c(t_k + s) = v_c[k] + v̇_c[k]·s`` within step k (piecewise linear and
continuous) and passes ``v̇_c`` to the vehicle model, whose hydrodynamics use the relative
velocity ``ν_r = ν − ν_c`` (Fossen 2011, §10.3: ``ν̇_c = [−ω×Rᵀv_c + Rᵀv̇_c; 0]``).

Gauss–Markov (first order, Fossen 2011 eq. 8.4): ``V̇ + μ V = w``, w white with intensity σ²;
sampled exactly: ``V_{k+1} = V̄ + (V_k − V̄) e^{−μΔt} + σ √((1 − e^{−2μΔt})/(2μ)) ξ_k``, clamped to
``[min, max]``; the direction (horizontal, from north towards east) can follow its own process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np


def _rates(v: np.ndarray, dt: float) -> np.ndarray:
    d = np.zeros_like(v)
    d[:-1] = np.diff(v, axis=0) / dt
    return d


def ned(speed: float, direction_deg: float = 0.0, down: float = 0.0) -> np.ndarray:
    """Current vector towards ``direction_deg`` (0 = flowing north, 90 = east)."""
    a = math.radians(direction_deg)
    return np.array([speed * math.cos(a), speed * math.sin(a), down])


@dataclass(frozen=True)
class ConstantCurrent:
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    kind: str = "constant"

    def sample(self, t: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        v = np.tile(np.asarray(self.velocity, float), (t.size, 1))
        return v, np.zeros_like(v)

    @property
    def is_constant(self) -> bool:
        return True


@dataclass(frozen=True)
class TimeSeriesCurrent:
    """A measured current: times (s) and NED velocities (m/s), linearly interpolated (held at the
    ends)."""

    time: np.ndarray
    velocity: np.ndarray  # (N, 3)
    source: str = ""
    kind: str = "timeseries"

    def __post_init__(self):
        t = np.asarray(self.time, float)
        v = np.asarray(self.velocity, float).reshape(-1, 3)
        where = self.source or "current time series"
        if t.size < 2 or t.size != v.shape[0]:
            raise ValueError(f"{where}: need at least two rows of time, north, east, down")
        if np.any(np.diff(t) <= 0) or not np.all(np.isfinite(v)):
            bad = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 2 if np.any(np.diff(t) <= 0) else -1
            raise ValueError(f"{where}: time must increase strictly and values be finite"
                             + (f" (row {bad})" if bad > 0 else ""))
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "velocity", v)

    @classmethod
    def from_csv(cls, path: str | Path) -> TimeSeriesCurrent:
        """CSV with columns ``time, north, east, down`` (header required; down optional)."""
        import pandas as pd

        df = pd.read_csv(path)
        cols = {c.strip().lower(): c for c in df.columns}
        for c in ("time", "north", "east"):
            if c not in cols:
                raise ValueError(f"{path}: missing column {c!r} (need time, north, east[, down]); "
                                 f"have {list(df.columns)}")
        down = df[cols["down"]].to_numpy(float) if "down" in cols else np.zeros(len(df))
        v = np.column_stack([df[cols["north"]].to_numpy(float), df[cols["east"]].to_numpy(float),
                             down])
        return cls(df[cols["time"]].to_numpy(float), v, str(path))

    def sample(self, t, dt):
        v = np.column_stack([np.interp(t, self.time, self.velocity[:, j]) for j in range(3)])
        return v, _rates(v, dt)

    @property
    def is_constant(self) -> bool:
        return False


@dataclass(frozen=True)
class GaussMarkovCurrent:
    """First-order Gauss–Markov speed (and optionally direction) of a horizontal current."""

    mean: float = 0.3
    mu: float = 0.05
    sigma: float = 0.02
    min: float = 0.0
    max: float = 1.0
    direction_deg: float = 0.0
    direction_sigma_deg: float = 0.0
    direction_mu: float = 0.05
    seed: int = 0
    kind: str = "gauss_markov"

    def __post_init__(self):
        from uuvid.core.checks import direction_deg

        if not (self.mu > 0 and self.sigma >= 0 and self.min <= self.mean <= self.max):
            raise ValueError("Gauss-Markov current: need mu > 0, sigma >= 0, min <= mean <= max")
        # within [0, 360) as every current direction (400 is said and taken as 40)
        object.__setattr__(self, "direction_deg", direction_deg("direction_deg", self.direction_deg))

    @classmethod
    def _checked(cls, *, direction_deg: float = 0.0, **kw) -> GaussMarkovCurrent:
        """Built with a ``direction_deg`` already checked (a scenario's, warned of where the
        file gives it): its warning is not said a second time."""
        c = cls(**kw)  # the other parameters checked as ever; direction 0 warns of nothing
        object.__setattr__(c, "direction_deg", float(direction_deg))
        return c

    @staticmethod
    def _process(n, x0, mean, mu, sigma, dt, rng, lo=-math.inf, hi=math.inf):
        a = math.exp(-mu * dt)
        sd = sigma * math.sqrt((1 - a * a) / (2 * mu))
        xi = rng.standard_normal(n)
        x = np.empty(n)
        x[0] = x0
        for k in range(1, n):  # n ≤ mission steps; a scalar recursion, done once per mission
            x[k] = min(max(mean + (x[k - 1] - mean) * a + sd * xi[k], lo), hi)
        return x

    def sample(self, t, dt):
        rng = np.random.default_rng(self.seed)
        sp = self._process(t.size, self.mean, self.mean, self.mu, self.sigma, dt, rng, self.min,
                           self.max)
        d = np.radians(self._process(t.size, self.direction_deg, self.direction_deg,
                                     self.direction_mu, self.direction_sigma_deg, dt, rng))
        v = np.column_stack([sp * np.cos(d), sp * np.sin(d), np.zeros(t.size)])
        return v, _rates(v, dt)

    @property
    def is_constant(self) -> bool:
        return self.sigma == 0 and self.direction_sigma_deg == 0


def as_current(c):
    """A current model from a 3-vector (constant NED) or a model."""
    if hasattr(c, "sample"):
        return c
    v = np.asarray(c, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"current must be three finite NED components (m/s), got {c!r}")
    return ConstantCurrent(tuple(float(x) for x in v))
