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

# the vertical current's bound lives with the horizontal one (core.checks); re-exported here
from uuvid.core.checks import MAX_VERTICAL_CURRENT_MPS, vertical_current  # noqa: F401


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


CSV_COLUMNS = ("time", "north", "east", "down")  # a current time series file's columns


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
        """CSV with columns ``time, north, east, down`` (s, m/s; header required, names in any
        case and order, ``down`` optional: zero).  Refused, naming the file: a column that is
        none of these (a typo such as ``dwn`` flew with no vertical current) or one given twice,
        a row with too few or too many cells, and a cell that is empty, not a number, NaN or
        infinite (naming its row — data rows from 1 — its line and its column)."""
        import csv

        where = str(path)
        with open(path, newline="", encoding="utf-8-sig") as f:
            reader = csv.reader(f)
            header = next(reader, None)
            rows = [(reader.line_num, r) for r in reader if any(c.strip() for c in r)]
        # a spreadsheet's trailing comma: an unnamed empty last column, left out with its cells
        while header and len(header) > 1 and not header[-1].strip():
            header = header[:-1]
        if header:
            w = len(header)
            rows = [(ln, r[:w] if len(r) > w and not any(c.strip() for c in r[w:]) else r)
                    for ln, r in rows]
        if not header or not any(c.strip() for c in header):
            raise ValueError(f"{where}: no header; expected the columns time, north, east and "
                             "optionally down (s, m/s)")
        shown = [c.strip() for c in header]
        names = [c.lower() for c in shown]
        twice = list(dict.fromkeys(n for n in names if names.count(n) > 1))
        if twice:
            raise ValueError(f"{where}: column{'s' if len(twice) > 1 else ''} "
                             f"{', '.join(repr(n) for n in twice)} given twice (header: "
                             f"{', '.join(shown)}); expected each of time, north, east and "
                             "optionally down once")
        unknown = [c for c, n in zip(shown, names) if n not in CSV_COLUMNS]
        if unknown:
            raise ValueError(f"{where}: unknown column{'s' if len(unknown) > 1 else ''} "
                             f"{', '.join(repr(c) for c in unknown)}; expected time, north, east "
                             f"and optionally down (s, m/s; header: {', '.join(shown)})")
        for c in ("time", "north", "east"):
            if c not in names:
                raise ValueError(f"{where}: missing column {c!r} (need time, north, east[, down]); "
                                 f"have {shown}")
        data = np.zeros((len(rows), len(names)))
        for k, (line, r) in enumerate(rows, 1):
            at = f"{where}: row {k} (line {line})"
            if len(r) != len(names):
                raise ValueError(f"{at}: {len(r)} cells; expected {len(names)} ({', '.join(shown)})")
            for j, cell in enumerate(r):
                text = cell.strip()
                col = f"{at}, column {shown[j]!r}"
                unit = "s" if names[j] == "time" else "m/s"
                if not text:
                    raise ValueError(f"{col}: empty; expected a number ({unit})")
                try:
                    x = float(text)
                except ValueError:
                    raise ValueError(f"{col}: {text!r} is not a number; expected one ({unit})") \
                        from None
                if math.isnan(x):
                    raise ValueError(f"{col}: NaN; expected a number ({unit})")
                if math.isinf(x):
                    raise ValueError(f"{col}: {text} is not finite; expected a number ({unit})")
                if names[j] == "down":
                    vertical_current(col, x)
                data[k - 1, j] = x
        col = {n: data[:, j] for j, n in enumerate(names)}
        v = np.column_stack([col["north"], col["east"], col.get("down", np.zeros(len(rows)))])
        return cls(col["time"], v, where)

    def coverage_note(self, t_end: float) -> str | None:
        """What a flight of ``t_end`` seconds (from 0) flies outside the series' times (held at
        its first or last values), or ``None`` when the series covers it."""
        t0, t1 = float(self.time[0]), float(self.time[-1])
        if t0 <= 0.0 and t1 >= t_end:
            return None
        held = ([f"at its first values before {t0:g} s"] if t0 > 0.0 else []) + \
            ([f"at its last values from {t1:g} s"] if t1 < t_end else [])
        return (f"{self.source or 'current time series'} covers {t0:g}–{t1:g} s of a {t_end:g} s "
                f"flight: the current is held {' and '.join(held)}; extend the series to the "
                "flight's span (or shorten duration)")

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
