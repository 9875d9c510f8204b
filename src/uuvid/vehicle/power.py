"""Voltage-true thrusters and a battery: limits, inverse maps and currents at the supply voltage.

**Thrusters** (:class:`SupplyThruster`): the voltage-aware physical T200 model
(:class:`uuvid.thruster.physical.PhysicalModel`: ESC duty × supply → DC motor against
``K_Q Ω|Ω|`` → ``T = K_T Ω|Ω|``, fitted to Blue Robotics' 12 V and 16 V sheets; shipped as
``uuvid/thruster/data/t200-physical.yaml``, so nothing outside the package is needed).  At a
supply voltage V it gives the thrust limits ``[T(c_rev, V), T(c_fwd, V)]``, the command giving a
wanted thrust (inverse of the monotone steady map over a command grid), and the supply current
``|d|·I_m``.

**Battery** (:class:`Battery`): open-circuit voltage vs state of charge (table, linear; SOC a
fraction 0…1, an axis beyond 1 — in % — is refused), internal
resistance R, capacity Q (Ah): ``V = OCV(SOC) − R I``, ``dSOC/dt = −I / (3600 Q)``, with
``I = Σ I_thruster(V) + P_hotel / V`` solved as a fixed point (the thruster currents depend on V).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from uuvid.thruster.physical import physical_model


@dataclass(frozen=True)
class SupplyThruster:
    """A voltage-aware thruster: limits, inverse map and current at a supply voltage."""

    model: object
    points: int = 801

    def _commands(self) -> np.ndarray:
        """The command grid (full reverse … full forward; built once: the thruster is frozen)."""
        c = self.__dict__.get("_c")
        if c is None:
            m = self.model
            c = np.linspace(m.full_rev, m.full_fwd, self.points)
            c.flags.writeable = False
            self.__dict__["_c"] = c
        return c

    def _grid(self, voltage: float):
        c = self._commands()
        p = self.model.predict(c, float(voltage))
        return c, p.thrust, p.current

    def limits(self, voltage: float) -> tuple[float, float]:
        """(reverse, forward) thrust at full command, N."""
        m = self.model
        return (float(m.thrust(m.full_rev, voltage)), float(m.thrust(m.full_fwd, voltage)))

    def command_for(self, thrust, voltage: float) -> np.ndarray:
        """Command giving ``thrust`` at ``voltage`` (clipped to the limits)."""
        c, f, _ = self._grid(voltage)
        return _invert(c, f, thrust)

    def current(self, thrust, voltage: float) -> np.ndarray:
        """Supply current (A) drawn while giving ``thrust`` at ``voltage``."""
        c = self.command_for(thrust, voltage)
        return self.model.predict(c, float(voltage)).current

    def limits_and_current(self, thrust, voltage: float):
        """``(limits(V), current(clip(thrust, limits), V))`` from one grid evaluation (its end
        points are the full commands: the same numbers as the two calls)."""
        c, f, _ = self._grid(voltage)
        lo, hi = float(f[0]), float(f[-1])
        cmd = _invert(c, f, np.clip(thrust, lo, hi))
        return (lo, hi), self.model.predict(cmd, float(voltage)).current


def _invert(c, f, thrust):
    """The command of a monotone thrust grid ``f(c)`` giving ``thrust`` (flat parts dropped)."""
    order = np.argsort(f, kind="stable")
    f, c = f[order], c[order]
    keep = np.concatenate([[True], np.diff(f) > 0])
    return np.interp(thrust, f[keep], c[keep])


@dataclass(frozen=True)
class Battery:
    name: str
    capacity_ah: float
    ocv_soc: tuple[float, ...]
    ocv_voltage: tuple[float, ...]
    resistance: float
    hotel_load_w: float = 0.0
    min_voltage: float = 0.0
    max_current: float | None = None
    thruster_power_model: str = "t200-physical"
    source: str = ""
    assumptions: str = ""

    def __post_init__(self):
        s, v = np.asarray(self.ocv_soc, float), np.asarray(self.ocv_voltage, float)
        if s.size and s[-1] > 1.0:  # a % axis passes "from <= 0 to >= 1": 0.8 would be 0.8 %
            raise ValueError(f"ocv_soc ends at {s[-1]:g}: state of charge is a fraction 0…1; is it "
                             "in %? (divide the ocv_soc values by 100)")
        if s.shape != v.shape or np.any(np.diff(s) <= 0) or s[0] > 0 or s[-1] < 1:
            raise ValueError("ocv_soc must increase strictly from 0 (or below) to exactly 1, one "
                             "voltage each")
        if np.any(np.diff(v) < 0) or np.any(v <= 0):
            raise ValueError("ocv_voltage must be positive and non-decreasing with SOC")

    def ocv(self, soc: float) -> float:
        return float(np.interp(soc, self.ocv_soc, self.ocv_voltage))

    def terminal(self, soc: float, current: float) -> float:
        """``V = OCV(SOC) − R I``."""
        return self.ocv(soc) - self.resistance * current

    def supply(self, soc: float, thrusts, thruster: SupplyThruster) -> tuple[float, float]:
        """(voltage, current) while the thrusters give ``thrusts``: the fixed point of
        ``V = OCV − R (Σ I_i(T_i, V) + P_hotel/V)`` (thrusts clipped to the limits at V)."""
        v = self.ocv(soc)
        thrusts = np.asarray(thrusts, float)
        # any object with limits(V) and current(T, V) will do; a SupplyThruster gives both from
        # one evaluation of its model (the same numbers)
        both = getattr(thruster, "limits_and_current", None)
        i = 0.0
        for _ in range(50):
            if both is not None:
                _, cur = both(thrusts, v)
            else:
                lo, hi = thruster.limits(v)
                cur = thruster.current(np.clip(thrusts, lo, hi), v)
            i = float(np.sum(cur)) + self.hotel_load_w / v
            vn = self.terminal(soc, i)
            if vn <= 0:
                return 0.0, math.inf
            if abs(vn - v) < 1e-9:
                v = vn
                break
            v = 0.5 * (v + vn)
        return v, i


class SupplyVoltageWarning(UserWarning):
    """A supply voltage outside the data a thruster power model was fitted on."""


#: a supply voltage beyond this factor of the power model's data range is warned about
SUPPLY_RANGE_SLACK = 1.25
_WARNED: set = set()  # (power model, "above"/"below") already warned about in this process


def _warn_voltage(name: str, voltage: float) -> None:
    """Warn when ``voltage`` lies well outside the voltages the power model ``name`` rests on (the
    T200 sheets' 12–16 V): its limits are then the voltage law extrapolated (1 kV gave thrust
    limits as if the thrusters ran on it, silently)."""
    import warnings

    from uuvid.thruster.resolve import supply_data_range

    rng = supply_data_range(name)  # the voltages the preset's data were taken at
    if rng is None or rng[0] / SUPPLY_RANGE_SLACK <= voltage <= rng[1] * SUPPLY_RANGE_SLACK:
        return
    lo, hi = rng
    side = "above" if voltage > hi else "below"
    if (name, side) in _WARNED:  # once per model and side: a battery sweep calls this per step
        return
    _WARNED.add((name, side))
    warnings.warn(f"supply voltage {voltage:g} V is far outside the {lo:g}–{hi:g} V the thruster "
                  f"power model {name} was fitted on: its thrust limits are extrapolated — a 4S "
                  "battery is 12–16.8 V", SupplyVoltageWarning, stacklevel=3)


def limits_at(vehicle, voltage: float) -> np.ndarray:
    """(n, 2) thrust limits of the vehicle's thrusters at a supply voltage: a T200 thruster (or one
    without a model) from the power model of the vehicle's battery block, or the T200 model;
    another thruster from its own chain with its ESC at that supply (:func:`_chain_limits`).
    ``ValueError`` for a voltage that is not finite, > 0 and at most 1 kV
    (:func:`uuvid.core.checks.supply_voltage`), or a thruster whose model cannot follow it."""
    from uuvid.core.checks import supply_voltage

    voltage = supply_voltage("supply_voltage", voltage)
    name = vehicle.battery.thruster_power_model if vehicle.battery is not None else "t200-physical"
    out = np.empty((len(vehicle.layout), 2))
    own = _own_models(vehicle)
    if len(own) < len(vehicle.layout):
        _warn_voltage(name, voltage)
        out[:] = SupplyThruster(physical_model(name)).limits(voltage)
    fixed = []
    for i, (ref, chain) in own.items():
        lim = _chain_limits(ref, chain, voltage)
        if lim is None:  # no ESC: its thrust does not follow the supply; the file's limits hold
            out[i] = np.asarray(vehicle.layout.limits, float)[i]
            fixed.append(f"{vehicle.layout.thrusters[i].name} ({ref})")
        else:
            out[i] = lim
    if fixed:
        warnings.warn(f"{vehicle.name}: thrusters {', '.join(fixed)}: their models have no ESC "
                      f"that follows the supply (none, or a map fitted on the command at the "
                      f"bench's supply), so their thrust does not follow the supply voltage: the "
                      f"vehicle file's limits are used at {voltage:g} V", SupplyVoltageWarning,
                      stacklevel=2)
    return out


#: the battery block's thruster power models (:func:`uuvid.thruster.physical.physical_model`)
POWER_MODELS = ("t200-physical",)
#: thruster models the battery's T200 power model describes (the vehicle presets' thrusters)
T200_MODELS = ("t200", "t200-physical")


def _own_models(vehicle) -> dict:
    """``{index: (model, chain)}`` of the thrusters whose ``model`` is not the T200 preset the
    battery's power model describes (:data:`T200_MODELS`): the power model does not give their
    thrust at a supply voltage — their own chain does (a vehicle of eight 12 N thrusters was given
    the T200's 50 N limits)."""
    from uuvid.thruster.resolve import resolve_chain

    memo = getattr(vehicle, "__dict__", {}).get("_own_models")
    if memo is not None:  # limits_at runs inside the battery fixed point, per heading: once
        return memo
    base = vehicle.path.parent if getattr(vehicle, "path", None) is not None else None
    out, chains = {}, {}
    for i, t in enumerate(vehicle.layout.thrusters):
        if t.model and str(t.model) not in T200_MODELS:
            if t.model not in chains:
                chains[t.model] = resolve_chain(t.model, base)
            if not _is_t200(chains[t.model]):
                out[i] = (t.model, chains[t.model])
    if hasattr(vehicle, "__dict__"):
        vehicle.__dict__["_own_models"] = out  # the vehicle is frozen: its thrusters too
    return out


def _is_t200(chain) -> bool:
    """The T200 preset's chain at its ESC's supply (a file `thruster export t200` wrote)."""
    from uuvid.thruster.presets import preset_chain
    from uuvid.thruster.resolve import supply_voltage_of

    v = supply_voltage_of(chain)
    if v is None:
        return False
    try:
        return chain.blocks == preset_chain("t200", v).blocks
    except (KeyError, ValueError):
        return False


def check_battery_models(vehicle, battery=None) -> None:
    """``ValueError`` when the battery's currents cannot be computed for every thruster: the power
    model (a T200) gives a thruster's current draw, so a thruster whose model is not that preset
    is refused — said before any hold is flown, not after the first heading."""
    bat = battery if battery is not None else vehicle.battery
    own = _own_models(vehicle)
    if not own:
        return
    by: dict = {}
    for i, (ref, _) in own.items():
        by.setdefault(str(ref), []).append(vehicle.layout.thrusters[i].name)
    names = "; ".join(f"{', '.join(n)} ({ref})" for ref, n in by.items())
    raise ValueError(f"{vehicle.name}: the battery's currents come from its thruster power model "
                     f"{bat.thruster_power_model} (the T200 preset's), and thrusters {names} have "
                     "another model, whose current draw is not modelled; hold at a fixed supply "
                     "voltage instead (--voltage V), which takes each thruster's own model")


def _chain_limits(ref, chain, voltage: float) -> tuple[float, float] | None:
    """(reverse, forward) steady thrust of a thruster's own chain at ``voltage``: its ESC at that
    supply (:func:`uuvid.thruster.resolve.supply_law`) at full command
    (:func:`uuvid.thruster.resolve.full_command_thrust`); ``None`` without an ESC."""
    from uuvid.thruster.resolve import full_command_thrust, supply_law

    law = supply_law(ref, chain, quiet=True)
    return None if law is None else full_command_thrust(law[0](voltage))
