"""Named model parameters: how a sweep or a Monte Carlo run changes a thruster chain or a vehicle.

Thruster chains (targets ``thruster_step``)::

    blocks[0].tunnel_length          a block field (validated again: a bad value → run "invalid")
    blocks[0].motor.coulomb_torque   a field of a nested block (the tunnel thruster's motor)
    preset.tunnel_length             a keyword of the preset's factory (``auv2_rig_chain(...)``);
    tunnel_length                    ... also without the prefix when the name is unambiguous
    signal.amplitude                 a field of the input signal (``voltage``/``command``: aliases
                                     of ``signal.amplitude`` for a step)

Vehicles (targets ``vehicle_mission``); ``[i]`` is 0–5 or a DOF name (``surge`` … ``yaw``)::

    mass                             rigid-body mass (M_RB; the weight stays unless given)
    weight, buoyancy                 N
    inertia[i]                       principal inertia about the CG, i = 0…2 (roll, pitch, yaw)
    added_mass[i]                    diagonal of M_A (positive magnitude)
    linear_damping[i], quadratic_damping[i]
    added_mass_scale, damping_scale, linear_damping_scale, quadratic_damping_scale
                                     multiply the whole matrix (after element overrides)
    current[i] (i = 0…2, NED), current_speed, current_direction (deg clockwise from north)
    thruster.blocks[k].field         a thruster-chain field, applied to every thruster (the
                                     controller's inverse thrust map stays the nominal one)

Values are SI.  A parameter file may give values in another unit (``unit: in``); :data:`UNITS`
lists the conversions.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping, Sequence

import numpy as np

from uuvid.core import units as U
from uuvid.thruster.blocks import Block, ParameterError

#: unit name → factor to SI (value_SI = value × factor)
UNITS = {
    "": 1.0, "si": 1.0, "m": 1.0, "in": U.INCH, "inch": U.INCH, "ft": U.FT, "ft/rad": U.FT,
    "m/rad": 1.0, "deg": U.DEG, "rad": 1.0, "rpm": U.RPM, "lbf": U.LBF, "N": 1.0, "kgf": U.KGF,
    "V": 1.0, "kg": 1.0, "g": 1e-3, "%": 0.01, "cm": 0.01, "mm": 1e-3, "us": 1.0, "s": 1.0, "ms": 1e-3,
    "m/s": 1.0, "cm/s": 0.01, "mm/s": 1e-3, "kn": U.KNOT, "knot": U.KNOT, "knots": U.KNOT,
    "km/h": U.KMH, "ft/s": U.FT, "rad/s": 1.0, "rev/s": U.REV_S,
}

#: the units of each dimension (keys of :data:`UNITS`), by the SI unit a parameter is in
#: (:func:`si_unit`); a parameter whose SI unit is unknown takes any unit
UNITS_OF = {
    "m": ("m", "in", "inch", "ft", "cm", "mm"), "m/s": ("m/s", "cm/s", "mm/s", "kn", "knot", "knots",
                                                        "km/h", "ft/s"),
    "°": ("deg", "rad"), "rad/s": ("rad/s", "rpm", "rev/s"), "N": ("N", "lbf", "kgf"),
    "V": ("V",), "kg": ("kg", "g"), "s": ("s", "ms"),
}

DOFS = ("surge", "sway", "heave", "roll", "pitch", "yaw")
_INDEXED = re.compile(r"^(?P<field>[a-z_]+)\[(?P<idx>[A-Za-z0-9_]+)\]$")
_BLOCK = re.compile(r"^blocks\[(?P<i>\d+)\]\.(?P<path>[A-Za-z_][A-Za-z0-9_.]*)$")

VEHICLE_SCALARS = ("mass", "weight", "buoyancy", "added_mass_scale", "damping_scale",
                   "linear_damping_scale", "quadratic_damping_scale", "current_speed",
                   "current_direction")
VEHICLE_INDEXED = {"added_mass": 6, "linear_damping": 6, "quadratic_damping": 6, "inertia": 3,
                   "current": 3}


class ParameterNameError(ValueError):
    """A parameter name the target does not know; the message lists what it accepts."""


_LINEAR_DOF = {"surge", "sway", "heave", "0", "1", "2"}
#: SI unit of a vehicle parameter per DOF kind (linear, angular)
_VEHICLE_UNITS = {"added_mass": ("kg", "kg·m²"), "linear_damping": ("N·s/m", "N·m·s/rad"),
                  "quadratic_damping": ("N·s²/m²", "N·m·s²/rad²"), "inertia": ("kg·m²", "kg·m²"),
                  "current": ("m/s", "m/s")}
#: SI unit of scalar parameters and of chain-block fields, by (last) name
_NAME_UNITS = {"mass": "kg", "weight": "N", "buoyancy": "N", "current_speed": "m/s",
               "current_direction": "°", "voltage": "V", "supply_voltage": "V",
               "time_constant": "s", "tunnel_length": "m", "diameter": "m", "resistance": "Ω",
               "inductance": "H", "thrust": "N", "force": "N", "torque": "N·m"}


def si_unit(name: str) -> str:
    """The SI unit a parameter's values are in (``""`` when unknown or dimensionless): the
    label of sweep axes whose file gives no ``unit``."""
    m = _INDEXED.match(name)
    if m and m.group("field") in _VEHICLE_UNITS:
        lin, ang = _VEHICLE_UNITS[m.group("field")]
        return lin if m.group("idx") in _LINEAR_DOF else ang
    return _NAME_UNITS.get(name.rsplit(".", 1)[-1], "")


def units_for(name: str) -> tuple[str, ...] | None:
    """The units a parameter's values may be given in (``None``: any of :data:`UNITS`, its
    dimension being unknown)."""
    return UNITS_OF.get(si_unit(name))


def unit_factor(name: str, unit: str | None) -> float:
    """value in ``unit`` × factor = the value ``name`` takes (SI, or degrees for an angle the
    model takes in degrees); ``ValueError`` naming the parameter and the units it accepts when
    ``unit`` is unknown or of another dimension (rpm for a current speed)."""
    if unit is None or unit in ("", "si"):
        return 1.0
    if unit not in UNITS:
        ok = units_for(name)
        raise ValueError(f"parameter {name!r}: unknown unit {unit!r}; "
                         + (f"{name} takes {', '.join(ok)}" if ok else
                            f"known: {', '.join(sorted(k for k in UNITS if k))}"))
    ok = units_for(name)
    if ok is not None and unit not in ok:
        raise ValueError(f"parameter {name!r}: unit {unit!r} is not a unit of {name} "
                         f"({si_unit(name)}); {name} takes {', '.join(ok)}")
    f = UNITS[unit]
    return f / U.DEG if si_unit(name) == "°" else f  # current_direction is taken in degrees


def to_si(value, unit: str | None, name: str = ""):
    """``value`` in ``unit`` as the value parameter ``name`` takes (:func:`unit_factor`)."""
    if unit is None:
        return value
    f = unit_factor(name, unit)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        return value
    return float(value) * f


# ---------------------------------------------------------------------------------------------
# thruster chains
# ---------------------------------------------------------------------------------------------
def set_block_field(block: Block, path: str, value) -> Block:
    """``block`` with ``path`` (``tunnel_length`` or ``motor.coulomb_torque``) set — validated."""
    head, _, rest = path.partition(".")
    names = {f.name for f in dataclasses.fields(block)}
    if head not in names:
        raise ParameterNameError(f"{block.TYPE} has no parameter {head!r}; it has "
                                 f"{', '.join(sorted(names))}")
    if rest:
        inner = getattr(block, head)
        if not isinstance(inner, Block):
            raise ParameterNameError(f"{block.TYPE}.{head} is not a block; {path!r} goes too deep")
        return dataclasses.replace(block, **{head: set_block_field(inner, rest, value)})
    cur = getattr(block, head)
    if isinstance(cur, bool):
        value = bool(value)
    elif isinstance(cur, (int, float)) and not isinstance(value, bool):
        value = float(value)
    return dataclasses.replace(block, **{head: value})


def parse_block_name(name: str) -> tuple[int, str] | None:
    m = _BLOCK.match(name)
    if not m:
        return None
    return int(m.group("i")), m.group("path")


def apply_block_values(chain, values: Mapping[str, object]):
    """A new :class:`~uuvid.thruster.chain.ThrusterChain` with ``blocks[i].path`` values set."""
    from uuvid.thruster.chain import ThrusterChain

    if not values:
        return chain
    blocks = list(chain.blocks)
    for name, v in values.items():
        i, path = parse_block_name(name)
        if i >= len(blocks):
            raise ParameterNameError(f"{name}: the chain {chain.name} has {len(blocks)} blocks")
        blocks[i] = set_block_field(blocks[i], path, v)
    return ThrusterChain(tuple(blocks), input_kind=chain.input_kind, name=chain.name)


# ---------------------------------------------------------------------------------------------
# vehicles
# ---------------------------------------------------------------------------------------------
def parse_vehicle_name(name: str) -> tuple[str, int | None]:
    """``added_mass[surge]`` → ``("added_mass", 0)``; ``mass`` → ``("mass", None)``;
    ``thruster.blocks[2].k_pos`` → ``("thruster", None)``."""
    if name in VEHICLE_SCALARS:
        return name, None
    if name.startswith("thruster.") and parse_block_name(name[len("thruster."):]):
        return "thruster", None
    m = _INDEXED.match(name)
    if m and m.group("field") in VEHICLE_INDEXED:
        f, idx = m.group("field"), m.group("idx")
        n = VEHICLE_INDEXED[f]
        if idx.isdigit():
            i = int(idx)
        elif f == "current":
            i = {"north": 0, "east": 1, "down": 2}.get(idx, -1)
        elif f == "inertia":
            i = {"roll": 0, "pitch": 1, "yaw": 2, "x": 0, "y": 1, "z": 2}.get(idx, -1)
        else:
            i = DOFS.index(idx) if idx in DOFS else -1
        if not 0 <= i < n:
            raise ParameterNameError(f"{name}: index must be 0…{n - 1}"
                                     + (" or a DOF name (surge … yaw)" if n == 6 else ""))
        return f, i
    raise ParameterNameError(
        f"unknown vehicle parameter {name!r}; use {', '.join(VEHICLE_SCALARS)}, "
        f"{', '.join(f + '[i]' for f in VEHICLE_INDEXED)} or thruster.blocks[k].field")


def vehicle_rows(base, values: Mapping[str, np.ndarray], nrun: int, current0=None):
    """Flattened vehicle parameter rows ``(nrun, 193)`` (layout of
    :meth:`uuvid.vehicle.model.VehicleParams.to_array`), currents ``(nrun, 3)`` or ``None``, and a
    per-run message (``""`` when valid).

    Vectorised; runs whose values break a physical bound (mass ≤ 0, negative added mass or
    damping, ``M_RB + M_A`` not positive definite, non-finite) get a message naming the parameter
    and are left at the nominal row (the caller marks them invalid and does not simulate them).
    """
    from uuvid.vehicle import model as VM
    from uuvid.vehicle.rigid_body import rigid_body_mass_matrix

    p0 = base.to_array()
    P = np.tile(p0, (nrun, 1))
    msg = np.full(nrun, "", dtype=object)

    def bad(mask, text):
        for r in np.flatnonzero(mask & (msg == "")):
            msg[r] = text

    mass = np.full(nrun, base.mass)
    inertia = np.tile(np.diag(base.inertia), (nrun, 1))
    MA = np.tile(base.added_mass, (nrun, 1, 1))
    DL = np.tile(base.linear_damping, (nrun, 1, 1))
    DQ = np.tile(base.quadratic_damping, (nrun, 1, 1))
    W = np.full(nrun, base.weight)
    B = np.full(nrun, base.buoyancy)
    cur = np.tile(np.asarray(base.current if current0 is None else current0, float), (nrun, 1))
    cur_changed = False
    scales = {}
    speed = direction = None
    for name, v in values.items():
        f, i = parse_vehicle_name(name)
        v = np.asarray(v, dtype=float)
        bad(~np.isfinite(v), f"{name} is not finite")
        if f == "mass":
            mass = v.copy()
        elif f == "weight":
            W = v.copy()
        elif f == "buoyancy":
            B = v.copy()
        elif f == "inertia":
            inertia[:, i] = v
        elif f == "added_mass":
            MA[:, i, i] = v
        elif f == "linear_damping":
            DL[:, i, i] = v
        elif f == "quadratic_damping":
            DQ[:, i, i] = v
        elif f == "current":
            cur[:, i] = v
            cur_changed = True
        elif f == "current_speed":
            speed = v
        elif f == "current_direction":
            direction = v
        elif f.endswith("_scale"):
            scales[f] = v
        # "thruster" names are handled by the caller
    if speed is not None or direction is not None:
        sp = speed if speed is not None else np.linalg.norm(cur[:, :2], axis=1)
        di = (np.radians(direction) if direction is not None
              else np.arctan2(cur[:, 1], cur[:, 0]))
        cur[:, 0] = sp * np.cos(di)
        cur[:, 1] = sp * np.sin(di)
        cur_changed = True
    if "added_mass_scale" in scales:
        MA *= scales["added_mass_scale"][:, None, None]
    for key, mats in (("damping_scale", (DL, DQ)), ("linear_damping_scale", (DL,)),
                      ("quadratic_damping_scale", (DQ,))):
        if key in scales:
            for M in mats:
                M *= scales[key][:, None, None]
    for key in scales:
        bad(scales[key] < 0, f"{key} = negative")
    bad(~(mass > 0), "mass must be > 0")
    bad(~np.all(inertia > 0, axis=1), "inertia must be > 0")
    bad(~(W >= 0), "weight must be >= 0")
    bad(~(B >= 0), "buoyancy must be >= 0")
    for nm, M in (("added_mass", MA), ("linear_damping", DL), ("quadratic_damping", DQ)):
        d = np.diagonal(M, axis1=1, axis2=2)
        neg = d < 0
        for r in np.flatnonzero(np.any(neg, axis=1) & (msg == "")):
            j = int(np.flatnonzero(neg[r])[0])
            msg[r] = f"{nm}[{DOFS[j]}] = {d[r, j]:.4g} < 0 (magnitudes must be >= 0)"
    # M_RB per distinct (mass, inertia): cheap and exact (the function the model uses)
    MRB = np.empty((nrun, 6, 6))
    cache: dict = {}
    for r in range(nrun):
        key = (mass[r], *inertia[r])
        M = cache.get(key)
        if M is None:
            if msg[r] == "":
                M = rigid_body_mass_matrix(float(mass[r]), np.diag(inertia[r]), base.r_g)
            else:
                M = base.M_RB
            cache[key] = M
        MRB[r] = M
    Mtot = MRB + MA
    ok = msg == ""
    if np.any(ok):
        ev = np.full((nrun, 6), np.inf)
        ev[ok] = np.linalg.eigvalsh(0.5 * (Mtot[ok] + np.swapaxes(Mtot[ok], 1, 2)))
        bad(np.min(ev, axis=1) <= 0, "M_RB + M_A is not positive definite")
        evA = np.full((nrun, 6), np.inf)
        ok = msg == ""
        evA[ok] = np.linalg.eigvalsh(MA[ok])
        bad(np.min(evA, axis=1) < -1e-9 * np.maximum(1.0, np.abs(MA).max(axis=(1, 2))),
            "added_mass must be positive semi-definite")
    ok = msg == ""
    if np.any(ok):
        P[ok, VM.P_MINV:VM.P_MINV + 36] = np.linalg.inv(Mtot[ok]).reshape(-1, 36)
        P[ok, VM.P_MRB:VM.P_MRB + 36] = MRB[ok].reshape(-1, 36)
        P[ok, VM.P_MA:VM.P_MA + 36] = MA[ok].reshape(-1, 36)
        P[ok, VM.P_DL:VM.P_DL + 36] = DL[ok].reshape(-1, 36)
        P[ok, VM.P_DQ:VM.P_DQ + 36] = DQ[ok].reshape(-1, 36)
        P[ok, VM.P_W] = W[ok]
        P[ok, VM.P_B] = B[ok]
        P[ok, VM.P_VC:VM.P_VC + 3] = cur[ok]
    return P, (cur if cur_changed else None), msg


def one_dof_of_rows(P: np.ndarray, dof: int):
    """(total inertia, linear damping, quadratic damping) along one DOF from parameter rows."""
    from uuvid.vehicle import model as VM

    j = dof * 6 + dof
    return (P[:, VM.P_MRB + j] + P[:, VM.P_MA + j], P[:, VM.P_DL + j].copy(),
            P[:, VM.P_DQ + j].copy())


def check_names(names: Sequence[str], known: Sequence[str], what: str) -> None:
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ParameterNameError(f"{what}: unknown parameter {unknown[0]!r}; known: "
                                 f"{', '.join(known)}")


def finite_float(v) -> float:
    f = float(v)
    if not math.isfinite(f):
        raise ParameterError(f"value {v!r} is not finite")
    return f
