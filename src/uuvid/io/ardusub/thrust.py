"""PWM → thrust per sample, at the battery voltage the log recorded.

Default: the voltage-aware Blue Robotics T200 model ``t200-physical`` (ESC duty × supply voltage
→ DC motor → ``K_T Ω|Ω|``; :class:`uuvid.thruster.physical.PhysicalModel`), fitted to Blue
Robotics' T200 sheets at 12 V and 16 V by :func:`uuvid.uncertainty.identified.make_t200_physical`
and shipped as package data (``uuvid/thruster/data/t200-physical.yaml``), so it needs no
sheets at run time.  Override: a preset name or a fitted thruster model file — a
``thruster_physical`` model (voltage-aware) or any command-driven model
:func:`uuvid.thruster.resolve.resolve_chain` reads (its steady thrust; with an ESC block at the
logged voltage, else at the voltage it was fitted for, with a warning).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from uuvid.io.logs import LogDataError

T200_MODEL_FILE = (Path(__file__).resolve().parents[2] / "thruster" / "data"
                   / "t200-physical.yaml")


@dataclass(frozen=True)
class ThrustModel:
    """``thrust(pwm, volts) → N``, vectorised; ``voltage_aware`` says whether volts matter."""

    name: str
    source: str
    voltage_aware: bool
    _fn: object
    voltage: str = "logged battery voltage (the model takes the supply voltage directly)"
    _speed_fn: object = None
    # volts → [sentence] when the model's data do not cover that supply voltage (None: unknown)
    _volt_check: object = None

    def thrust(self, pwm, volts) -> np.ndarray:
        return np.asarray(self._fn(np.asarray(pwm, float), np.asarray(volts, float)), float)

    @property
    def has_speed(self) -> bool:
        """Whether the model gives the rotor speed itself (a physical, voltage-aware model)."""
        return self._speed_fn is not None

    def speed(self, pwm, volts) -> np.ndarray | None:
        """Steady rotor speed Ω [rad/s, signed] at ``pwm`` and ``volts`` (the physical model's
        DC-motor balance, :meth:`uuvid.thruster.physical.PhysicalModel.predict`), or ``None``
        when the model gives thrust only."""
        if self._speed_fn is None:
            return None
        return np.asarray(self._speed_fn(np.asarray(pwm, float), np.asarray(volts, float)), float)

    def to_dict(self) -> dict:
        return {"name": self.name, "source": self.source, "voltage_aware": self.voltage_aware,
                "voltage": self.voltage}


def _physical_from_yaml(path: Path):
    from uuvid.thruster.modelfile import ModelFileError, read_model_text
    from uuvid.thruster.physical import PhysicalModel

    try:
        doc = read_model_text(path)
    except ModelFileError as e:
        raise LogDataError(str(e)) from None
    if not isinstance(doc, dict) or doc.get("kind") != "thruster_physical":
        return None
    try:
        return PhysicalModel(**doc["base"]["physical_model"])
    except (KeyError, TypeError, ValueError) as e:
        raise LogDataError(f"{path.name}: base.physical_model: {e}") from None


def _preset_voltage_check(ref: str, chain=None):
    """``volts → [sentence]``: :func:`uuvid.thruster.resolve.supply_voltage_warnings` of the
    preset or chain ``ref`` (the check `uuvid thruster predict` says)."""
    from uuvid.thruster.resolve import resolve_chain, supply_voltage_warnings

    held = {}

    def check(volts: float) -> list[str]:
        if "chain" not in held:
            held["chain"] = chain if chain is not None else resolve_chain(ref)
        return supply_voltage_warnings(ref, held["chain"], float(volts))

    return check


def thrust_warnings(tm: ThrustModel, volts, t=None, pwm_min: float = 1100.0,
                    pwm_max: float = 1900.0, neutral: float = 1500.0, what: str = "battery_V",
                    ) -> list[str]:
    """What the thrust ``tm`` gives at the logged voltages ``volts`` (one per row, at times ``t``
    [s]) rests on: the rows whose voltage lies outside the model's data (its preset's check,
    :func:`uuvid.thruster.resolve.supply_voltage_warnings`, naming those rows, their time span
    and the voltages seen) and a map whose thrust falls with a growing command at the lowest or
    highest logged voltage (:func:`uuvid.thruster.chain.monotonicity_warnings`)."""
    from uuvid.thruster.chain import monotonicity_warnings

    v = np.asarray(volts, float)
    ok = np.isfinite(v) & (v > 0)
    if not tm.voltage_aware or not ok.any():
        return []
    out = []
    t = np.arange(v.size, dtype=float) if t is None else np.asarray(t, float)
    if tm._volt_check is not None:
        keys = np.round(v, 2)
        bad = [x for x in np.unique(keys[ok]).tolist() if tm._volt_check(x)]
        sel = ok & np.isin(keys, bad)
        if sel.any():
            lo, hi = float(v[sel].min()), float(v[sel].max())
            said = tm._volt_check(round(hi, 2)) or tm._volt_check(round(lo, 2))
            out.append(f"thrust from pwm ({tm.name}): {what} {lo:.2f}–{hi:.2f} V on "
                       f"{np.count_nonzero(sel)} of {v.size} rows (t = {t[sel].min():.1f}–"
                       f"{t[sel].max():.1f} s): " + said[0])
    x = np.linspace(pwm_min, pwm_max, 81)
    for volt in sorted({float(v[ok].min()), float(v[ok].max())}, reverse=True):  # falls first
        falls = monotonicity_warnings(x, tm.thrust(x, np.full(x.size, volt)), neutral=neutral)
        if falls:
            out.append(f"thrust from pwm ({tm.name}) at {volt:.2f} V (the log's "
                       f"{'lowest' if volt == float(v[ok].min()) else 'highest'} {what}): "
                       + "; ".join(falls))
            break
    return out


def _physical(model, name: str, source: str, volt_check=None) -> ThrustModel:
    def of(what):
        def fn(pwm, volts):
            pwm, volts = np.broadcast_arrays(pwm, volts)
            out = np.zeros(pwm.shape)
            ok = np.isfinite(pwm) & np.isfinite(volts) & (volts > 0)
            out[~ok] = np.nan
            out[ok] = getattr(model.predict(pwm[ok], volts[ok]), what)
            return out

        return fn

    return ThrustModel(name, source, True, of("thrust"), _speed_fn=of("speed"),
                       _volt_check=volt_check)


def default_t200() -> ThrustModel:
    """The shipped voltage-aware T200 model."""
    m = _physical_from_yaml(T200_MODEL_FILE)
    return _physical(m, "t200-physical", "Blue Robotics T200 sheets (12 V, 16 V, 2019), fitted by "
                     "uuvid.uncertainty.identified.make_t200_physical; uuvid/thruster/data/"
                     "t200-physical.yaml", _preset_voltage_check("t200-physical"))


def load_thrust_model(path) -> ThrustModel:
    """A thruster model (file or preset name, :func:`uuvid.thruster.resolve.resolve_chain`) as a
    :class:`ThrustModel` (see the module doc).

    Voltage: a ``thruster_physical`` file and ``t200-physical`` take the logged voltage directly;
    a chain with an ESC block (``V = duty × supply``) is re-evaluated at the logged voltage
    (rounded to 0.05 V) through :func:`uuvid.thruster.resolve.supply_law` (a preset by its own
    voltage law, a file's ESC at the voltage); a chain without one
    cannot follow it and keeps its own (``voltage_aware`` False: the loader warns).
    """
    from uuvid.thruster.modelfile import ModelFileError, NotAModelFileError
    from uuvid.thruster.resolve import (
        PHYSICAL_PRESETS,
        is_preset,
        preset_names,
        resolve_chain,
        supply_law,
    )

    if str(path) in PHYSICAL_PRESETS:
        return default_t200()
    p = Path(path)
    if not is_preset(path) and not p.is_file():
        raise LogDataError(f"{p}: no such thruster model file, and not a preset "
                           f"({', '.join(preset_names())})")
    if p.is_file() and p.suffix.lower() in (".yaml", ".yml"):
        pm = _physical_from_yaml(p)
        if pm is not None:
            return _physical(pm, p.stem, str(p))
    try:
        chain = resolve_chain(path)
    except NotAModelFileError as e:  # already says so, and what the file looks like
        raise LogDataError(str(e)) from None
    except (ModelFileError, ValueError) as e:
        raise LogDataError(f"{p.name}: not a thruster model file: {e}") from None
    if chain.signal_kinds[0] != "command":
        raise LogDataError(f"{p.name}: model {chain.name!r} is driven by {chain.signal_kinds[0]}, "
                           "not a PWM command, so it cannot turn servo outputs into thrust")
    source = f"thruster preset {path}" if is_preset(path) else str(p)
    law = supply_law(path, chain, quiet=True)
    at_v = None if law is None else law[0]
    cache: dict = {}

    def steady(key, c, todo):
        cache.update(zip(((key, x) for x in todo.tolist()),
                         np.atleast_1d(c.steady_thrust(todo)).tolist()))

    def fn(pwm, volts):
        flat = np.asarray(pwm, float).ravel()
        vb = np.broadcast_to(np.asarray(volts, float), np.shape(pwm)).ravel()
        out = np.full(flat.size, np.nan)
        ok = np.isfinite(flat)
        if at_v is not None:
            ok &= np.isfinite(vb) & (vb > 0)
            keys = np.round(vb / 0.05) * 0.05
        else:
            keys = np.zeros(flat.size)
        cmd = np.round(flat)  # whole µs
        for key in np.unique(keys[ok]).tolist():
            sel = ok & (keys == key)
            u = np.unique(cmd[sel])
            todo = np.array([x for x in u.tolist() if (key, x) not in cache])
            if todo.size:
                steady(key, chain if at_v is None else at_v(key), todo)
            out[sel] = [cache[(key, x)] for x in cmd[sel].tolist()]
        return out.reshape(np.shape(pwm))

    if at_v is None:
        from uuvid.thruster.resolve import command_map_supply, is_command_map

        why = (command_map_supply(chain)[0] if is_command_map(chain) else
               "the chain has no ESC block (its thrust does not depend on the supply voltage in "
               "the model)")
        return ThrustModel(chain.name or p.stem, source, False, fn,
                           f"none: {why}, so thrust ignores the logged voltage")
    return ThrustModel(chain.name or p.stem, source, True, fn,
                       f"logged battery voltage (0.05 V steps): {law[1]}",
                       _volt_check=_preset_voltage_check(str(path), chain))
