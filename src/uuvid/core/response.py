"""One result type for every simulation and every loaded log: time plus named channels."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from uuvid.core.result import Result, jsonable

#: SI unit of each channel a thruster simulation records.
CHANNEL_UNITS = {
    "time": "s",
    "command": "cmd",
    "voltage": "V",
    "motor_speed": "rad/s",
    "prop_speed": "rad/s",
    "thrust": "N",
    "measured_thrust": "N",
    "torque": "N·m",
    "current": "A",
}


@dataclass(frozen=True)
class TimeResponse(Result):
    """Samples of named channels on a common, strictly increasing time axis (SI units)."""

    t: np.ndarray
    channels: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        t = np.asarray(self.t, dtype=float)
        for name, v in self.channels.items():
            if np.shape(v) != t.shape:
                raise ValueError(f"channel {name!r} has shape {np.shape(v)}, time has {t.shape}")

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "time":
            return self.t
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(f"no channel {name!r}; channels are {sorted(self.channels)}") from None

    def __contains__(self, name: str) -> bool:
        return name == "time" or name in self.channels

    @property
    def names(self) -> list[str]:
        return list(self.channels)

    def recorded(self) -> TimeResponse:
        """Only the channels that carry data (drop all-NaN ones)."""
        keep = {k: v for k, v in self.channels.items() if not np.all(np.isnan(v))}
        return TimeResponse(self.t, keep, dict(self.meta))

    def to_frame(self):
        import pandas as pd

        return pd.DataFrame({"time": self.t, **self.channels})

    def to_csv(self, path: str | Path) -> Path:
        from uuvid.core.atomic import atomic_path

        path = Path(path)
        with atomic_path(path) as tmp:
            self.to_frame().to_csv(tmp, index=False)
        return path

    def csv_bytes_estimate(self) -> int:
        """About how many bytes :meth:`to_csv` writes (formats up to 1000 rows and scales up), so
        a caller can say how big a file will be before writing it."""
        n = len(self.t)
        if n == 0:
            return 0
        head = self.to_frame().iloc[: min(n, 1000)].to_csv(index=False)
        return int(len(head.encode()) * n / min(n, 1000))

    report_title = "Time response"

    def summary(self) -> str:
        """Samples, duration and the range and final value of each channel."""
        t = np.asarray(self.t, dtype=float)
        span = f"{t[0]:.4g}–{t[-1]:.4g} s" if t.size else "empty"
        lines = [f"{t.size} samples, {span}"
                 + "".join(f", {k} {v}" for k, v in self.meta.items()
                           if isinstance(v, (str, int, float)))]
        for k, v in self.channels.items():
            a = np.asarray(v, dtype=float)
            ok = a[np.isfinite(a)]
            unit = CHANNEL_UNITS.get(k, "")
            lines.append(f"  {k:<16} " + (f"[{ok.min():.4g}, {ok.max():.4g}] final {a[-1]:.4g} {unit}"
                                          if ok.size else "no data"))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """Time, channels (lists; NaN → ``None``) and meta."""
        return jsonable({"t": self.t, "channels": dict(self.channels), "meta": self.meta,
                         "units": {k: CHANNEL_UNITS.get(k, "") for k in self.channels}})

    def metrics(self, steady_window: float = 0.1):
        """McLean's step-response metrics (see :mod:`uuvid.core.metrics`)."""
        from uuvid.core.metrics import step_response_metrics

        measured = self.channels.get("measured_thrust")
        if measured is not None and np.all(np.isnan(measured)):
            measured = None
        speed = self.channels.get("prop_speed")
        if speed is not None and np.all(np.isnan(speed)):
            speed = None
        return step_response_metrics(self.t, self.channels["thrust"], thrust_measured=measured,
                                     speed=speed, steady_window=steady_window)

    def plot(self, groups=None, title=None):
        """Stacked plots of the recorded channels; returns the matplotlib Figure."""
        from uuvid.core.plots import plot_time_series

        rec = self.recorded()
        if groups is None:
            groups = [g for g in (["command"], ["voltage"], ["motor_speed", "prop_speed"],
                                  ["thrust", "measured_thrust"], ["torque"], ["current"])
                      if any(c in rec.channels for c in g)]
            groups = [[c for c in g if c in rec.channels] for g in groups]
        labels = {k: f"{k} [{CHANNEL_UNITS.get(k, '')}]" for k in rec.channels}
        title = title or str(self.meta.get("name") or self.meta.get("model") or "Time response")
        return plot_time_series(rec.t, rec.channels, title=title, ylabel_by_channel=labels,
                                axes_groups=groups)
