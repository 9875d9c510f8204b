"""PWM → thrust per sample, at the battery voltage the log recorded.

Default: the voltage-aware Blue Robotics T200 model ``t200-physical`` (ESC duty × supply voltage
→ DC motor → ``K_T Ω|Ω|``; :class:`uuvid.identify.physical.PhysicalModel`), fitted to Blue
Robotics' T200 sheets at 12 V and 16 V by :func:`uuvid.uncertainty.identified.make_t200_physical`
and shipped as package data (``uuvid/uncertainty/data/t200-physical.yaml``), so it needs no
sheets at run time.  Override: a fitted thruster model file — a ``thruster_physical`` model
(voltage-aware) or any command-driven model file :func:`uuvid.io.modelfile.load_chain` reads
(its steady thrust, at the voltage it was fitted for).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from uuvid.io.logs import LogDataError

T200_MODEL_FILE = (Path(__file__).resolve().parents[2] / "uncertainty" / "data"
                   / "t200-physical.yaml")


@dataclass(frozen=True)
class ThrustModel:
    """``thrust(pwm, volts) → N``, vectorised; ``voltage_aware`` says whether volts matter."""

    name: str
    source: str
    voltage_aware: bool
    _fn: object

    def thrust(self, pwm, volts) -> np.ndarray:
        return np.asarray(self._fn(np.asarray(pwm, float), np.asarray(volts, float)), float)

    def to_dict(self) -> dict:
        return {"name": self.name, "source": self.source, "voltage_aware": self.voltage_aware}


def _physical_from_yaml(path: Path):
    import yaml

    from uuvid.identify.physical import PhysicalModel

    doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    if not isinstance(doc, dict) or doc.get("kind") != "thruster_physical":
        return None
    try:
        return PhysicalModel(**doc["base"]["physical_model"])
    except (KeyError, TypeError, ValueError) as e:
        raise LogDataError(f"{path.name}: base.physical_model: {e}") from None


def _physical(model, name: str, source: str) -> ThrustModel:
    def fn(pwm, volts):
        out = np.zeros(np.broadcast(pwm, volts).shape)
        ok = np.isfinite(pwm) & np.isfinite(volts) & (volts > 0)
        out[~ok] = np.nan
        out[ok] = model.thrust(pwm[ok], volts[ok])
        return out

    return ThrustModel(name, source, True, fn)


def default_t200() -> ThrustModel:
    """The shipped voltage-aware T200 model."""
    m = _physical_from_yaml(T200_MODEL_FILE)
    return _physical(m, "t200-physical", "Blue Robotics T200 sheets (12 V, 16 V, 2019), fitted by "
                     "uuvid.uncertainty.identified.make_t200_physical; uuvid/uncertainty/data/"
                     "t200-physical.yaml")


def load_thrust_model(path) -> ThrustModel:
    """A thruster model file as a :class:`ThrustModel` (see the module doc)."""
    from uuvid.io.modelfile import ModelFileError, load_chain

    p = Path(path)
    if not p.is_file():
        raise LogDataError(f"{p}: no such thruster model file")
    if p.suffix.lower() in (".yaml", ".yml"):
        pm = _physical_from_yaml(p)
        if pm is not None:
            return _physical(pm, p.stem, str(p))
    try:
        chain = load_chain(p)
    except (ModelFileError, ValueError) as e:
        raise LogDataError(f"{p.name}: not a thruster model file: {e}") from None
    if chain.signal_kinds[0] != "command":
        raise LogDataError(f"{p.name}: model {chain.name!r} is driven by {chain.signal_kinds[0]}, "
                           "not a PWM command, so it cannot turn servo outputs into thrust")
    cache: dict = {}

    def fn(pwm, volts):
        flat = np.asarray(pwm, float).ravel()
        out = np.full(flat.size, np.nan)
        ok = np.isfinite(flat)
        u, inv = np.unique(np.round(flat[ok]), return_inverse=True)  # whole µs
        todo = np.array([x for x in u.tolist() if x not in cache])
        if todo.size:
            cache.update(zip(todo.tolist(), np.atleast_1d(chain.steady_thrust(todo)).tolist()))
        out[ok] = np.array([cache[x] for x in u.tolist()])[inv]
        return out.reshape(np.shape(pwm))

    return ThrustModel(chain.name or p.stem, str(p), False, fn)
