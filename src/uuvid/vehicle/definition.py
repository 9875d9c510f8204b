"""Vehicle definition files (YAML or TOML), validated with pydantic, with exact error paths.

A vehicle file (SI units, NED/FRD body axes: x forward, y starboard, z down; positive damping
and added-mass magnitudes, see :mod:`uuvid.vehicle.hydrodynamics`)::

    name: bluerov2
    source:                      # required: where the numbers come from
      citation: Wu, C.-J. (2018) ...
      transcribed_from: ...      # optional
    assumptions:                 # key path → why the value is assumed (not from the source)
      thrusters: positions approximate, from the frame drawing
    environment: {current: [0, 0, 0]}        # vehicle_rhs only: a run takes its own (scenario, CLI)
    inflow: none                 # or four-quadrant: thrust falls with the advance speed (issue 21)
    rigid_body:
      mass: 11.5
      weight: 112.8              # optional, default m·g (more than 1 % from m·g warns)
      buoyancy: 114.8            # or displaced_volume + water_density (+ gravity)
      center_of_gravity: [0, 0, 0.02]
      center_of_buoyancy: [0, 0, 0]
      inertia: [0.16, 0.16, 0.16]            # 3 principal values or 9; about the CG by default
    hydrodynamics:               # 6 (diagonal) or 36 (row-major) values each
      added_mass: [...]
      linear_damping: [...]
      quadratic_damping: [...]
    thrusters:
      - name: T1
        position: [0.156, 0.111, 0.085]
        axis: [-0.7071, 0.7071, 0]           # or rpy_deg: [roll, pitch, yaw] of the thruster
                                             # (normalised; [1, 1, 0] is fine, see _axis_warnings)
        model: t200                          # thruster preset name or model-file path
        limits: [-39.91, 51.49]              # [min, max] thrust, N
        installation: {surge_front: [1.0, 0.89]}   # η per mode: value or [η₊, η₋]
        wake: 0.0                            # wake fraction in [0, 1) (with inflow only; > 0.5 warns)
        propeller: my-prop.yaml              # inflow map (default: the model's; with inflow only)
    allocation: {dofs: [surge, sway, heave, yaw], weights: [...], default_modes: [...]}
    modes:                       # thrust-mapping modes (Caccia et al. 2000, Table I)
      surge_front:
        constraints: [{RL: 1, RR: 1}]        # τ_RL + τ_RR = 0
        zero_dofs: [sway]
        open_water: forward surge
    one_dof:                     # Caccia et al. (2000) eq. 3 models identified per DOF; a key
                                 # that is, or starts with, a DOF name must match its dof
      yaw: {dof: yaw, mass: 84, linear: 20.5, quadratic: 49.5, eta_neg: 0.60}
    battery:                     # uuvid.vehicle.power.Battery
      capacity_ah: 18.0          # Ah (over 500 Wh per kg of vehicle warns: mAh?)
      ocv_soc: [0.0, 0.5, 1.0]   # state of charge, a fraction 0…1 (not %)
      ocv_voltage: [12.0, 14.9, 16.8]
      resistance: 0.03           # ohm

Errors name the file and the key path: ``bluerov2.yaml: thrusters[2].position: missing``.
:func:`load_vehicle` takes a path or a preset name (:func:`list_presets`).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from uuvid.thruster.blocks import ParameterError
from uuvid.thruster.modelfile import (
    ModelFileError,
    NotAModelFileError,
    format_loc,
    other_kind,
    read_model_text,
)
from uuvid.vehicle.allocation import Allocator, ThrustMode, dead_thrusters
from uuvid.vehicle.layout import Thruster, ThrusterLayout, axis_from_rpy, dof_index
from uuvid.vehicle.model import DOF_NAMES, OneDofModel, VehicleParams
from uuvid.vehicle.rigid_body import skew_ref

if TYPE_CHECKING:  # pydantic is imported only when a file is validated
    from pydantic import ValidationError

    from uuvid.vehicle.schema import BatterySchema

PRESET_DIR = Path(__file__).resolve().parent / "presets"
#: Presets of one vehicle family from different published parameter sets (told to the user).
PARAMETER_SET_SIBLINGS = {"bluerov2": "bluerov2-heavy", "bluerov2-heavy": "bluerov2"}


def _diag(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    return np.diag(a) if a.ndim == 2 else a


def _is_preset_path(path) -> bool:
    return Path(path).resolve().parent == PRESET_DIR


def command_line_name(vehicle) -> str:
    """How to name ``vehicle`` on the command line: its preset name, else its file."""
    path = getattr(vehicle, "path", None)
    if path is None or _is_preset_path(path):
        return getattr(vehicle, "name", "vehicle")
    return str(path)


class VehicleFileError(ModelFileError):
    """A vehicle file is unreadable or invalid; the message names the file and the key path."""


class VehicleFileWarning(UserWarning):
    """A vehicle file value that is valid but cannot be what it claims (most often a unit)."""


#: Buoyancy / weight beyond this factor either way cannot be a vehicle that holds depth: real
#: ROVs and AUVs are trimmed within a few per cent (the presets within 2 %); a mass in grams, a
#: buoyancy in kgf or a displaced volume in litres lands far outside.
NEUTRAL_FACTOR = 2.0


#: A thrust limit beyond this (N) either way is refused on load: no thruster of an underwater
#: vehicle gives it (a T200 51 N, work-class ROV thrusters a few kN, the largest tunnel thrusters
#: of ships ~ 100 kN at the surface); ``1e300`` or ``1e9`` standing for "no limit" would otherwise
#: give speeds of 1e149 m/s and force-times-thrust overflows in the envelope and stability.
MAX_THRUST_N = 1e5


#: A given weight beyond this factor either way of ``m g`` (g = 9.81 m/s²) is a unit slip.
WEIGHT_FACTOR = 1.5
#: A thruster, the centre of gravity or of buoyancy further than this from the body origin (m):
#: lengths in mm or cm (the largest AUVs are a few metres either side of their origin).
MAX_EXTENT_M = 12.0
#: A radius of gyration ``sqrt(I/m)`` below this (m) about any axis: the mass or the inertia is
#: in another unit (a BlueROV2's is 12 cm, a compact 5 kg AUV's several cm).
MIN_GYRATION_M = 0.01
#: A radius of gyration above both of these is more than the vehicle's size allows: this × the
#: largest distance of a thruster (or the centre of buoyancy) from the centre of gravity — the
#: thrusters sit on the hull, and little mass lies beyond it (a BlueROV2's 12 cm against its
#: thrusters' 19 cm; a REMUS 100's 0.31 m in pitch against its tail thruster's 0.8 m) …
MAX_GYRATION_EXTENT = 2.0
#: … and this × the side ``(m/ρ)^(1/3)`` of a cube of water of the vehicle's mass (m): a vehicle
#: about as dense as water, however slender (a rod 20× as long as it is wide has 2.3×), cannot
#: spread its mass further (BlueROV2: at most 0.68 m, REMUS 100: 1 m)
MAX_GYRATION_VOLUME = 3.0


def rigid_body_warnings(params: VehicleParams, layout=None) -> list[str]:
    """Sentences for valid numbers that cannot be what they claim (most often a unit slip): a
    weight beyond :data:`WEIGHT_FACTOR` of ``m g`` (a mass in grams, a weight in kgf), a buoyancy
    beyond :data:`NEUTRAL_FACTOR` of the weight, a radius of gyration below
    :data:`MIN_GYRATION_M` or beyond what the vehicle's size allows (:func:`max_gyration`: an
    inertia in g·m² or kg·cm²), principal moments of inertia no body has (the triangle
    inequality), a position beyond :data:`MAX_EXTENT_M` (lengths in mm or cm)."""
    out = []
    m, w, b = float(params.mass), float(params.weight), float(params.buoyancy)
    if (w > 0.0 and b > 0.0) and not 1.0 / NEUTRAL_FACTOR <= b / w <= NEUTRAL_FACTOR:
        out.append(f"rigid_body: the buoyancy {b:.4g} N is {b / w:.3g} × the weight m·g = "
                   f"{w:.4g} N (mass {m:.4g} kg): no vehicle that holds depth is that far from "
                   "neutral; expected the mass in kg, weight and buoyancy in N, displaced_volume "
                   "in m³ (a mass in grams weighs 1000× too much, a buoyancy in kgf floats 9.8× "
                   "too little)")
    mg = m * 9.81
    if w > 0.0 and mg > 0.0 and not 1.0 / WEIGHT_FACTOR <= w / mg <= WEIGHT_FACTOR:
        out.append(f"rigid_body: the weight {w:.4g} N is {w / mg:.3g} × m·g = {mg:.4g} N (mass "
                   f"{m:.4g} kg): expected the mass in kg and the weight in N (a mass in grams "
                   "is 1000× m·g, a weight in kgf 1/9.81 of it)")
    inertia = np.diag(np.asarray(params.inertia, float))
    if m > 0.0 and inertia.size == 3 and np.all(inertia > 0.0):
        gyr = np.sqrt(inertia / m)  # radius of gyration: a vehicle's is centimetres to metres
        if gyr.min() < MIN_GYRATION_M:
            k = int(np.argmin(gyr))
            out.append(f"rigid_body: inertia {inertia[k]:.4g} kg·m² about {'xyz'[k]} with mass "
                       f"{m:.4g} kg is a radius of gyration of {1000 * gyr[k]:.3g} mm — no vehicle "
                       "is that compact: expected the mass in kg and the inertia in kg·m² (a mass "
                       "in grams, or an inertia in kg·cm²?)")
        top, why = max_gyration(params, layout)
        if gyr.max() > top:
            k = int(np.argmax(gyr))
            out.append(f"rigid_body: inertia {inertia[k]:.4g} kg·m² about {'xyz'[k]} with mass "
                       f"{m:.4g} kg is a radius of gyration of {gyr[k]:.3g} m — more than a "
                       f"vehicle {why} can have (at most about {top:.2g} m): expected the "
                       "inertia in kg·m² about the centre of gravity and the mass in kg (an "
                       "inertia in g·m² or kg·cm², or a value from a larger vehicle?)")
    full = np.asarray(params.inertia, float)
    full = np.diag(full) if full.ndim == 1 else full
    if full.shape == (3, 3) and np.all(np.isfinite(full)):
        pm = np.sort(np.linalg.eigvalsh(0.5 * (full + full.T)))
        if pm[0] > 0.0 and pm[2] > (pm[0] + pm[1]) * (1.0 + 1e-3):  # (a plate to 3 digits passes)
            # I_xx + I_yy = ∫(x² + y² + 2z²) dm ≥ I_zz about any point, for any mass
            out.append(f"rigid_body.inertia: principal moments {pm[0]:.4g}, {pm[1]:.4g}, "
                       f"{pm[2]:.4g} kg·m² — the largest exceeds the sum of the other two, which "
                       "no body of positive mass has (I_xx + I_yy ≥ I_zz): a typo or a moment "
                       "from another vehicle?")
    where = [("rigid_body.center_of_gravity", params.r_g),
             ("rigid_body.center_of_buoyancy", params.r_b)]
    if layout is not None:
        where += [(f"thrusters[{i}] ({t.name}).position", t.position)
                  for i, t in enumerate(layout.thrusters)]
    far = [(k, float(np.linalg.norm(np.asarray(v, float)))) for k, v in where]
    far = [(k, d) for k, d in far if d > MAX_EXTENT_M]
    if far:
        k, d = max(far, key=lambda x: x[1])
        out.append(f"{k} is {d:.4g} m from the body origin"
                   + (f" ({len(far)} positions beyond {MAX_EXTENT_M:g} m)" if len(far) > 1 else "")
                   + ": are the lengths in mm or cm? expected metres")
    return out


def max_gyration(params: VehicleParams, layout=None) -> tuple[float, str]:
    """``(bound, why)``: the largest radius of gyration ``sqrt(I/m)`` (m) a vehicle of this mass
    and these thruster positions can have — the larger of :data:`MAX_GYRATION_EXTENT` × the
    furthest thruster (or the centre of buoyancy) from the centre of gravity and
    :data:`MAX_GYRATION_VOLUME` × ``(m / 1000 kg/m³)^(1/3)`` — and the words for it."""
    m = float(params.mass)
    r_g = np.asarray(params.r_g, float)
    pts = [np.asarray(params.r_b, float)]
    if layout is not None:
        pts += [np.asarray(t.position, float) for t in layout.thrusters]
    reach = max(float(np.linalg.norm(p - r_g)) for p in pts)
    by_size = MAX_GYRATION_EXTENT * reach
    by_mass = MAX_GYRATION_VOLUME * (max(m, 0.0) / 1000.0) ** (1.0 / 3.0)
    what = "thrusters sit" if layout is not None and layout.n else "centre of buoyancy sits"
    return max(by_size, by_mass), (f"of {m:.4g} kg whose {what} within {reach:.2g} m of its "
                                   "centre of gravity")


# ---------------------------------------------------------------------------------------------
# The loaded vehicle
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Vehicle:
    """A validated vehicle: parameters, thruster layout, modes, allocation defaults, provenance."""

    name: str
    params: VehicleParams
    layout: ThrusterLayout
    modes: Mapping[str, ThrustMode] = field(default_factory=dict)
    allocation_dofs: tuple[int, ...] = tuple(range(6))
    allocation_weights: np.ndarray | None = None
    default_modes: tuple[str, ...] = ()
    one_dof: Mapping[str, OneDofModel] = field(default_factory=dict)
    source: Mapping[str, Any] = field(default_factory=dict)
    assumptions: Mapping[str, str] = field(default_factory=dict)
    description: str = ""
    path: Path | None = None
    battery: Any = None  # uuvid.vehicle.power.Battery, from the file's ``battery`` block
    inflow: str = "none"  # thrust against advance speed: "none" (bollard) or "four-quadrant"
    wake: tuple[float, ...] = ()  # wake fraction per thruster (empty: all 0)
    #: per thruster, what its inflow map comes from (``propeller:``, else its ``model``; empty:
    #: the models)
    propellers: tuple[str, ...] = ()
    #: per thruster, its ``axis`` as the file wrote it, before normalising (``None``: given as
    #: ``rpy_deg``; empty: not from a file), for :func:`_axis_warnings` on every load
    file_axes: tuple[tuple[float, float, float] | None, ...] = ()
    #: the file's ``rigid_body.gravity`` when it gives ``weight`` beside ``mass`` (``None``: the
    #: weight is m·g), for :func:`_weight_mass_warnings` on every load
    weight_given_g: float | None = None

    def propeller(self, thruster: int) -> str:
        """The preset or model file a thruster's four-quadrant map comes from (with inflow)."""
        return self.propellers[thruster] if self.propellers else self.layout[thruster].model

    @property
    def B(self) -> np.ndarray:
        """Thrust configuration matrix (6 × n)."""
        return self.layout.B

    def mode(self, modes: str | Sequence[str] | None = None) -> ThrustMode | None:
        """One mode, or the combination of several (constraints stacked, η multiplied).

        ``None`` → the file's ``allocation.default_modes``; ``()`` or ``"none"`` → no mode.
        """
        if modes is None:
            modes = self.default_modes
        if isinstance(modes, str):
            modes = () if modes == "none" else (modes,)
        modes = tuple(modes)
        if not modes:
            return None
        for m in modes:
            if m not in self.modes:
                raise KeyError(f"{self.name}: no thrust-mapping mode {m!r}; "
                               f"have {sorted(self.modes)}")
        if len(modes) == 1:
            return self.modes[modes[0]]
        ms = [self.modes[m] for m in modes]
        eta_dof: dict[str, float] = {}
        for m in ms:
            eta_dof.update(m.eta_dof)
        return ThrustMode("+".join(modes), np.vstack([m.constraints for m in ms]),
                          tuple(sorted({d for m in ms for d in m.zero_dofs})),
                          np.prod([m.eta_pos for m in ms], axis=0),
                          np.prod([m.eta_neg for m in ms], axis=0),
                          "; ".join(m.open_water for m in ms if m.open_water),
                          "; ".join(m.description for m in ms if m.description), eta_dof)

    def allocator(self, modes: str | Sequence[str] | None = None, *, dofs=None, weights=None,
                  compensate_eta: bool = False, limits: bool = True) -> Allocator:
        """An :class:`Allocator` for this vehicle (file defaults unless overridden)."""
        return Allocator(self.B, self.allocation_dofs if dofs is None else dofs,
                         self.allocation_weights if weights is None else weights,
                         self.mode(modes), self.layout.limits if limits else None,
                         compensate_eta)

    def thruster_chain(self, thruster: int | str):
        """The thruster model a thruster refers to (thruster preset name or model-file path,
        relative to the vehicle file).  Raises ``KeyError`` for a placeholder name."""
        ref = self.layout[thruster].model
        from uuvid.thruster.resolve import preset_names, resolve_chain

        try:
            return resolve_chain(ref, self.path.parent if self.path is not None else Path.cwd())
        except FileNotFoundError:
            raise KeyError(f"{self.name}: thruster {self.layout[thruster].name} refers to model "
                           f"{ref!r}, which is neither a thruster preset ({', '.join(preset_names())}) "
                           "nor a model file next to the vehicle file (a placeholder)") from None
        except NotAModelFileError as e:  # say which vehicle and thruster point at it
            raise NotAModelFileError(f"{self.name}: thruster {self.layout[thruster].name} refers "
                                     f"to model {ref!r}: {e}") from None

    @property
    def citation(self) -> str:
        return str(self.source.get("citation", ""))

    def provenance_note(self) -> str | None:
        """For a preset with a sibling from another parameter set (``bluerov2`` ↔
        ``bluerov2-heavy``): how far apart the two sets are, so nobody reads the difference as
        the frame's.  ``None`` otherwise."""
        preset = self.path is not None and _is_preset_path(self.path)
        other = PARAMETER_SET_SIBLINGS.get(self.name) if preset else None
        if other is None:
            return None
        o = load_vehicle(other)
        a, b = float(_diag(self.params.quadratic_damping)[0]), float(_diag(o.params.quadratic_damping)[0])
        ratio = max(a, b) / min(a, b)
        return (f"{self.name} and {other} come from different published parameter sets "
                f"({self.description.split(', ')[-1]} vs {o.description.split(', ')[-1]}), "
                f"{ratio:.1f}× apart in quadratic surge drag ({a:g} vs {b:g} N·s²/m²; linear "
                f"{_diag(self.params.linear_damping)[0]:g} vs {_diag(o.params.linear_damping)[0]:g} "
                "N·s/m): their "
                "speeds and endurance differ mostly by the data set, not by the 6- vs 8-thruster "
                "frame (uuvid vehicle envelope shows it)")

    def to_dict(self) -> dict:
        """The vehicle as JSON-safe data, every quantity's unit in its key or in ``units``."""
        from uuvid.core.atomic import to_jsonable

        p = self.params
        d = {
            "name": self.name, "description": self.description, "source": dict(self.source),
            "provenance_note": self.provenance_note(),
            "mass_kg": p.mass, "weight_N": p.weight, "buoyancy_N": p.buoyancy,
            "center_of_gravity_m": p.r_g, "center_of_buoyancy_m": p.r_b,
            "inertia_kg_m2": p.inertia, "added_mass": p.added_mass,
            "linear_damping": p.linear_damping, "quadratic_damping": p.quadratic_damping,
            "dofs": ["surge", "sway", "heave", "roll", "pitch", "yaw"],
            "units": {"added_mass": ["kg"] * 3 + ["kg·m²"] * 3,
                      "linear_damping": ["N·s/m"] * 3 + ["N·m·s/rad"] * 3,
                      "quadratic_damping": ["N·s²/m²"] * 3 + ["N·m·s²/rad²"] * 3},
            "thrusters": [{"name": t.name, "model": t.model, "position_m": t.position,
                           "axis": t.axis, "limits_N": t.limits,
                           "wake": self.wake[i] if self.wake else 0.0,
                           "propeller": self.propeller(i)} for i, t in enumerate(self.layout)],
            "inflow": self.inflow,
            "modes": list(self.modes), "default_modes": list(self.default_modes),
            "assumptions": dict(self.assumptions),
            "battery": None if self.battery is None else {
                "name": self.battery.name, "capacity_Ah": self.battery.capacity_ah,
                "resistance_ohm": self.battery.resistance,
                "hotel_load_W": self.battery.hotel_load_w},
            "file": None if self.path is None else str(self.path),
            "one_dof": _one_dof_dicts(self.one_dof),
        }
        return to_jsonable(d)

    def summary(self) -> str:
        lines = [f"{self.name}: {self.description}".rstrip(": "), f"  source: {self.citation}",
                 *([f"  notes: {self.source['notes']}"] if self.source.get("notes") else []),
                 *([f"  note: {n}"] if (n := self.provenance_note()) else []),
                 self.params.summary(),
                 f"  {self.layout.n} thrusters: " + ", ".join(
                     f"{t.name} ({t.model}, [{t.limits[0]:.4g}, {t.limits[1]:.4g}] N)"
                     for t in self.layout)]
        if self.inflow != "none":
            props = sorted(set(self.propeller(i) for i in range(self.layout.n)))
            wakes = sorted(set(self.wake)) if self.wake else [0.0]
            lines.append(f"  inflow: {self.inflow} (propeller map: {', '.join(props)}; wake "
                         f"{', '.join(f'{w:g}' for w in wakes)})")
        else:
            lines.append("  inflow: none (bollard thrust at every speed)")
        if self.modes:
            lines.append(f"  modes: {', '.join(self.modes)}")
        if self.assumptions:
            lines.append(f"  assumed: {', '.join(self.assumptions)}")
        lines += _one_dof_lines(self.one_dof)
        return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------
_loc = format_loc


_TEXT = {"missing": "missing", "extra_forbidden": "unknown key"}
# VehicleParams field → file key path
_PARAM_PATH = {"mass": "rigid_body.mass", "inertia": "rigid_body.inertia",
               "weight": "rigid_body.weight", "buoyancy": "rigid_body.buoyancy",
               "r_g": "rigid_body.center_of_gravity", "r_b": "rigid_body.center_of_buoyancy",
               "added_mass": "hydrodynamics.added_mass",
               "linear_damping": "hydrodynamics.linear_damping",
               "quadratic_damping": "hydrodynamics.quadratic_damping",
               "current": "environment.current", "quaternion_gain": "quaternion_gain"}


def _by_propeller(refs) -> dict[str, list[int]]:
    """Thruster indices per propeller reference (one message per file, naming its thrusters)."""
    out: dict[str, list[int]] = {}
    for i, r in enumerate(refs):
        out.setdefault(r, []).append(i)
    return out


def _inflow_fix(spec, mode: str, given: bool) -> str:
    """How to fly a vehicle whose thrusters have no usable propeller map: the file's key and the
    commands' option that overrides it, or — when the override asked for inflow the file does
    not have — leaving that out."""
    if given:
        return (f"inflow {mode} was asked for on this run (--inflow {mode}, a scenario file's "
                f"inflow: {mode}, or inflow= in Python) over the vehicle file's inflow: "
                f"{spec.inflow}: leave it out, or name a propeller: with a map for these thrusters")
    return ("set inflow: none in the vehicle file, or switch it off for one run with --inflow "
            "none (uuvid simulate, vehicle envelope, stability, hold; load_vehicle(..., "
            "inflow='none') in Python)")


def _propeller_errors(spec, where: str, base_dir: Path | None,
                      mode: str | None = None) -> list[str]:
    """Why the thrusters' four-quadrant maps (``propeller:``, else ``model``) cannot be read, one
    message per reference with its own cause (no such file, a bad model file, no or a linear
    ``inflow`` section, an unknown preset).  ``mode``: the inflow in force (default: the file's
    key; another is the caller's override, and the messages say so)."""
    from uuvid.thruster.modelfile import ModelFileError
    from uuvid.vehicle.inflow import KNOWN_PROPELLERS, thruster_map

    given = mode is not None and mode != spec.inflow
    mode = spec.inflow if mode is None else mode
    out = []
    refs = [t.propeller or t.model for t in spec.thrusters]
    for ref, idx in _by_propeller(refs).items():
        key = "propeller" if spec.thrusters[idx[0]].propeller else "model"
        at = f"{where}: thrusters[{', '.join(map(str, idx))}].{key}"
        try:
            thruster_map(ref, base_dir)
        except KeyError:
            out.append(f"{at}: inflow {mode!r} needs the propeller map of {ref!r}, which "
                       f"holds none (known: {KNOWN_PROPELLERS}); {_inflow_fix(spec, mode, given)}")
        except FileNotFoundError:
            out.append(f"{at}: {ref!r}: no such thruster model file (relative to the vehicle "
                       "file's folder) and not a preset with a propeller map (t200, t200-physical)")
        except (ModelFileError, ValueError) as e:
            out.append(f"{at}: inflow {mode!r}: {e}")
    return out


def _model_warnings(vehicle: Vehicle, base_dir: Path | None = None) -> list[str]:
    """One sentence naming the thrusters whose ``model`` is neither a thruster preset nor a file
    beside the vehicle file (with the nearest preset name), and one per model file that is
    another kind of uuvid file (a vehicle, a scenario: :class:`~uuvid.thruster.modelfile.
    NotAModelFileError`): such a vehicle allocates and gives envelopes from its limits, but no
    simulation can fly it — said when it is loaded, not at the first mission."""
    import difflib

    from uuvid.thruster.resolve import preset_names, resolve_chain

    base = vehicle.path.parent if vehicle.path is not None else (base_dir or Path.cwd())
    bad, wrong = {}, {}
    for t in vehicle.layout.thrusters:
        if not t.model:
            continue
        try:
            resolve_chain(t.model, base)
        except FileNotFoundError:
            bad.setdefault(t.model, []).append(t.name)
        except NotAModelFileError as e:  # another kind of uuvid file (a vehicle, a scenario…)
            wrong.setdefault((t.model, str(e)), []).append(t.name)
        except Exception:  # noqa: BLE001 - a broken model file is reported where it is read
            continue
    out = [f"thrusters {', '.join(names)}: model {ref!r}: {why.split(': ', 1)[-1]} — allocation "
           "and envelopes use the file's limits, but no simulation can fly these thrusters"
           for (ref, why), names in wrong.items()]
    for ref, names in bad.items():
        near = difflib.get_close_matches(str(ref), preset_names(), n=1)
        out.append(f"thrusters {', '.join(names)}: model {ref!r} is neither a thruster preset "
                   f"({', '.join(preset_names())}) nor a model file beside the vehicle file"
                   + (f" — did you mean {near[0]!r}?" if near else "")
                   + "; allocation and envelopes use the file's limits, but no simulation can "
                     "fly these thrusters")
    return out


#: A wake fraction above this is warned of (:func:`_inflow_key_warnings`): ship wake fractions are
#: typically 0–0.4 (Carlton, *Marine Propellers and Propulsion*, ch. 5), the thrusters of an open-
#: frame ROV ≈ 0–0.3; at ``w`` the advance speed is ``(1 − w)`` times the water's speed, so a wake
#: near 1 switches the inflow off and an identified loss divided by ``(1 − w)`` grows without bound.
WAKE_PLAUSIBLE_MAX = 0.5


def _inflow_key_warnings(vehicle: Vehicle, base_dir: Path | None = None) -> list[str]:
    """The thrusters' inflow keys that load but cannot be what they claim: a wake fraction above
    :data:`WAKE_PLAUSIBLE_MAX`, and — with inflow off, when the maps are not read — a
    ``propeller:`` that names no preset or model file with a map (as a missing ``model`` is said
    by :func:`_model_warnings`; with inflow on it is an error)."""
    from uuvid.thruster.modelfile import ModelFileError
    from uuvid.vehicle.inflow import thruster_map

    out = []
    wakes: dict[float, list[str]] = {}
    for t, w in zip(vehicle.layout, vehicle.wake):
        if w > WAKE_PLAUSIBLE_MAX:
            wakes.setdefault(w, []).append(t.name)
    for w, names in wakes.items():
        out.append(f"thrusters {', '.join(names)}: wake {w:g} is above {WAKE_PLAUSIBLE_MAX:g} "
                   "(ship wake fractions are typically 0–0.4, ROV thrusters ≈ 0–0.3): the advance "
                   f"speed is (1 − w) = {1 - w:.3g} times the water's speed along the thruster, so "
                   "the propeller barely feels the vehicle's speed, and an inflow coefficient "
                   f"fitted on a dive (vehicle identify dive --inflow) comes out {1 / (1 - w):.3g}× "
                   "larger — a wake fraction this high is not a thruster in open water")
    if vehicle.inflow != "none" or not vehicle.propellers:
        return out
    base = vehicle.path.parent if vehicle.path is not None else base_dir
    explicit = [p if p != t.model else None for t, p in zip(vehicle.layout, vehicle.propellers)]
    for ref, idx in _by_propeller(explicit).items():
        if ref is None:
            continue
        try:
            thruster_map(ref, base)
            continue
        except KeyError:
            why = "holds no four-quadrant propeller map"
        except FileNotFoundError:
            why = ("is neither a preset with a propeller map (t200, t200-physical) nor a model file "
                   "beside the vehicle file")
        except (ModelFileError, ValueError) as e:
            why = f"cannot be read as a propeller map ({e})"
        names = ", ".join(vehicle.layout[i].name for i in idx)
        out.append(f"thrusters {names}: propeller {ref!r} {why}; inflow is none, so it is not used "
                   "now, but inflow: four-quadrant (or --inflow four-quadrant) cannot fly these "
                   "thrusters")
    return out


#: a thruster's limit may exceed its model's steady thrust at full command by this fraction
LIMIT_SLACK = 0.02


def _limit_warnings(vehicle: Vehicle, base_dir: Path | None = None) -> list[str]:
    """One sentence per thruster model whose steady thrust at full command (its ESC at its own
    supply voltage, :func:`uuvid.thruster.resolve.full_command_thrust`) falls short of the file's
    ``limits`` by more than :data:`LIMIT_SLACK`: the allocation, envelopes and hold take the
    limits while a simulation flies the model, which saturates below them (a 12 V fit kept the
    16 V limits, and the envelope "confirmed" a 16 V speed).  A chain without a closed-form steady
    state is simulated to rest at its two full commands (≈ 20 ms; cached on disk)."""
    from uuvid.thruster.resolve import full_command_thrust, resolve_chain, supply_voltage_of

    base = vehicle.path.parent if vehicle.path is not None else (base_dir or Path.cwd())
    lim = np.asarray(vehicle.layout.limits, float)
    reach: dict = {}
    short: dict = {}
    for i, t in enumerate(vehicle.layout.thrusters):
        if not t.model:
            continue
        if t.model not in reach:
            try:
                chain = resolve_chain(t.model, base)
                reach[t.model] = (full_command_thrust(chain), supply_voltage_of(chain))
            except Exception:  # noqa: BLE001 - a model that does not resolve is said elsewhere
                reach[t.model] = (None, None)
        (fr, volts) = reach[t.model]
        if fr is None:
            continue
        fmin, fmax = fr
        if lim[i, 1] > fmax * (1 + LIMIT_SLACK) + 0.05 or lim[i, 0] < fmin * (1 + LIMIT_SLACK) - 0.05:
            short.setdefault((str(t.model), tuple(lim[i])), (fmin, fmax, volts, []))[3].append(t.name)
    out = []
    for (ref, (lo, hi)), (fmin, fmax, volts, names) in short.items():
        at = f" (its ESC at {volts:g} V)" if volts else ""
        out.append(f"thrusters {', '.join(names)}: limits [{lo:g}, {hi:g}] N exceed what their "
                   f"model {ref!r} gives at full command{at}, [{fmin:.4g}, {fmax:.4g}] N: the "
                   f"allocation, envelopes and hold use the limits while a simulation flies the "
                   f"model, which saturates below them — set limits: [{fmin:.4g}, {fmax:.4g}] (or "
                   "a model for this supply voltage)")
    return out


#: Thrusters closer than this (m) with axes within ~2.6° of each other are one thruster twice.
COINCIDENT_TOL_M = 1e-3


def _coincident_warnings(vehicle: Vehicle) -> list[str]:
    """Two thrusters at the same position (within :data:`COINCIDENT_TOL_M`) pushing the same way
    (axes within ~2.6°): a line copied and not edited — they act as one thruster of twice the
    thrust, with no moment between them, and the vehicle file's allocation loses a DOF it may
    count on (a mission then tilts or drifts with nothing said)."""
    th = vehicle.layout.thrusters
    out = []
    for i in range(len(th)):
        for j in range(i + 1, len(th)):
            pi, pj = np.asarray(th[i].position, float), np.asarray(th[j].position, float)
            ai, aj = np.asarray(th[i].axis, float), np.asarray(th[j].axis, float)
            cos = float(ai @ aj) / max(float(np.linalg.norm(ai) * np.linalg.norm(aj)), 1e-300)
            if np.linalg.norm(pi - pj) <= COINCIDENT_TOL_M and cos > 0.999:
                out.append(f"thrusters {th[i].name} and {th[j].name} sit at the same position "
                           f"{[round(float(x), 6) for x in pi]} m pushing the same way "
                           f"{[round(float(x), 6) for x in ai]}: a copied line? they act as one "
                           "thruster (no moment between them) — check their position and axis")
    return out


#: A thruster ``axis`` whose length differs from 1 by more than this fraction is said on load
#: (unless it is a plain direction, see :func:`_axis_warnings`); rounding a unit vector to two
#: decimals stays within it.
AXIS_NORM_TOL = 0.01


def _axis_warnings(vehicle: Vehicle) -> list[str]:
    """A thruster ``axis`` of length beyond 1 ± :data:`AXIS_NORM_TOL` that is not a plain
    direction: ``[0.5, 0, 0.05]`` or ``[0.6, 0.7, 0]`` look like a unit vector with a typo,
    and are used normalised — said with the axis used.  A plain direction is used normalised in
    silence: every component an integer (``[1, 1, 0]``, ``[0, 0, 2]``) or every non-zero
    component of the same magnitude (``[0.5, -0.5, 0]``, whose direction normalising cannot
    change).  An axis given as ``rpy_deg`` is a unit vector and never said."""
    out = []
    for i, (a, t) in enumerate(zip(vehicle.file_axes, vehicle.layout)):
        if a is None:
            continue
        a = np.asarray(a, float)
        n = float(np.linalg.norm(a))
        mags = np.abs(a[a != 0.0])
        if (not np.isfinite(n) or n == 0.0 or abs(n - 1.0) <= AXIS_NORM_TOL
                or np.all(a == np.round(a)) or np.all(mags == mags[0])):
            continue
        used = [round(float(x), 4) + 0.0 for x in a / n]
        out.append(f"thrusters[{i}].axis ({t.name}): {[float(x) for x in a]} has "
                   f"length {n:.4g}, not 1 (beyond {AXIS_NORM_TOL:.0%}), and is used normalised "
                   f"as {used}: a unit vector with a typo or a rounding? give the unit vector, or "
                   "a plain direction (integers such as [1, 1, 0]), or rpy_deg")
    return out


def _one_way_warnings(vehicle: Vehicle) -> list[str]:
    """A controlled DOF the thrusters can push one way and not the other: with a thruster
    limited to one direction (``limits: [0, max]`` or ``[min, 0]``) no thrust within the limits
    may give the other (the allocation's default modes, the other controlled DOFs held at 0).
    A controller cannot push the vehicle that way: said, not left to stall a mission."""
    lim = np.asarray(vehicle.layout.limits, float)
    one = [i for i in range(vehicle.layout.n) if lim[i, 0] == 0.0 or lim[i, 1] == 0.0]
    if not one:  # two-sided limits: every direction of a controllable DOF is some thrust's
        return []
    from uuvid.vehicle.envelope import DIRECTIONS

    try:
        al = vehicle.allocator()
    except (KeyError, ValueError):  # a mode or weight problem is said where it is used
        return []
    out = []
    for d in al.controlled:
        e = np.zeros(6)
        e[d] = 1.0
        r = (al.reach(e), al.reach(-e))
        for k in (0, 1):
            if r[1 - k] > 0.0 and r[k] <= 1e-6 * r[1 - k]:  # (neither way: no authority at all)
                used = [i for i in one if vehicle.B[d, i] != 0.0]
                names = ", ".join(f"{vehicle.layout[i].name} [{lim[i, 0]:.4g}, {lim[i, 1]:.4g}] N"
                                  for i in used or one)
                out.append(f"allocation.dofs: {DOF_NAMES[d]} {DIRECTIONS[d][k]}: no thrust within "
                           f"the limits gives it (thrusters limited to one direction: {names}), "
                           f"only {DOF_NAMES[d]} {DIRECTIONS[d][1 - k]} (up to {r[1 - k]:.4g} "
                           f"{'N' if d < 3 else 'N·m'}): no controller can push the vehicle that "
                           "way (drag and the restoring forces alone bring it back), and a "
                           "mission that needs it will not follow its path — if those thrusters "
                           "can reverse, give their reverse thrust (a negative min, N)")
    return out


def no_drag_dofs(params: VehicleParams) -> list[int]:
    """DOFs with neither linear nor quadratic damping (their diagonal entries both 0)."""
    dl, dq = _diag(params.linear_damping), _diag(params.quadratic_damping)
    return [d for d in range(6) if dl[d] == 0.0 and dq[d] == 0.0]


def _no_drag_warnings(vehicle: Vehicle) -> list[str]:
    """A DOF with neither linear nor quadratic damping: nothing bounds its steady speed (surge,
    sway, heave, yaw) or damps its oscillation about level (roll, pitch) — a placeholder left at
    0, or damping not identified yet; the envelope says "unbounded (no drag)" there."""
    none = no_drag_dofs(vehicle.params)
    if not none:
        return []
    out = []
    moving = [DOF_NAMES[d] for d in none if d not in (3, 4)]
    if moving:
        out.append(f"hydrodynamics: no drag in {', '.join(moving)} (linear_damping and "
                   "quadratic_damping both 0 there): the steady speed is unbounded — any thrust "
                   "accelerates the vehicle for ever, and the envelope, stability and missions "
                   "have no top speed to give; expected positive damping (N·s/m and N·s²/m², "
                   "N·m·s/rad and N·m·s²/rad² for yaw)")
    tilting = [DOF_NAMES[d] for d in none if d in (3, 4)]
    if tilting:
        out.append(f"hydrodynamics: no drag in {', '.join(tilting)} (linear_damping and "
                   "quadratic_damping both 0 there): an oscillation about level never dies out; "
                   "expected positive damping (N·m·s/rad, N·m·s²/rad²)")
    return out


def _dead_thruster_warnings(vehicle: Vehicle) -> list[str]:
    """Thrusters with ``limits: [0, 0]`` (switched off, or a placeholder): they give no thrust,
    the allocation leaves them out (:class:`~uuvid.vehicle.allocation.Allocator`) and the other
    thrusters carry their share — said, with the DOFs that are then left without authority."""
    dead = [int(i) for i in dead_thrusters(vehicle.layout.limits)]
    if not dead:
        return []
    live = [i for i in range(vehicle.layout.n) if i not in dead]
    B = np.asarray(vehicle.B, float)
    lost = [] if not live else [DOF_NAMES[d] for j, d in
                                enumerate(vehicle.allocation_dofs)
                                if any(k == j for k, _ in
                                       _uncontrollable_dofs(B[:, live], vehicle.allocation_dofs))]
    names = ", ".join(f"thrusters[{i}] ({vehicle.layout[i].name})" for i in dead)
    one = len(dead) == 1
    return [f"{names}: limits [0, 0] N: {'gives' if one else 'give'} no thrust either way; the "
            f"allocation leaves {'it' if one else 'them'} out and the other thrusters carry "
            f"{'its' if one else 'their'} share"
            + (f" — but without it the thrusters cannot hold {', '.join(lost)} (the allocation "
               "meets those in the least-squares sense)" if lost else "")
            + "; if it does push, give its data-sheet limits [min, max] in N"]


#: A ``weight`` given beside ``mass`` further than this (relative) from ``m g`` (the file's
#: ``gravity``): one of the two was edited without the other (Earth's g varies by 0.5 %).
WEIGHT_MASS_RTOL = 0.01
#: Battery energy (capacity × the highest open-circuit voltage) per kg of the vehicle's mass
#: beyond this (Wh/kg) is no battery: cells in service store at most ~300 Wh/kg, and a battery
#: weighs less than the vehicle that carries it (a BlueROV2's 18 Ah pack is 26 Wh/kg of it).
MAX_BATTERY_WH_PER_KG = 500.0


def _one_dof_key_error(key: str, dof: str) -> str | None:
    """Why a ``one_dof`` entry's key disagrees with its ``dof`` (a key that is, or starts with, a
    DOF name — ``heave``, ``surge_forward`` — names that DOF), else ``None``."""
    head = key.replace("-", "_").split("_", 1)[0]
    if head in DOF_NAMES and head != dof:
        names = "" if head == key else f" (which names {head})"
        return (f"{dof!r} disagrees with its key {key!r}{names}: the model would "
                f"be used as the {dof} model under the name one_dof.{key}; set dof: {head}, or "
                f"rename the entry")
    return None


def _one_dof_dicts(one_dof: Mapping[str, OneDofModel]) -> dict:
    """``one_dof`` as JSON-safe data, the units in the keys (angular DOFs in rad)."""
    out = {}
    for key, m in one_dof.items():
        ang = m.dof in ("roll", "pitch", "yaw")
        out[key] = {"dof": m.dof, ("inertia_kg_m2" if ang else "mass_kg"): m.mass,
                    ("linear_N_m_s_per_rad" if ang else "linear_N_s_per_m"): m.linear,
                    ("quadratic_N_m_s2_per_rad2" if ang else "quadratic_N_s2_per_m2"): m.quadratic,
                    "eta_pos": m.eta_pos, "eta_neg": m.eta_neg,
                    ("disturbance_N_m" if ang else "disturbance_N"): m.disturbance,
                    "inflow_coefficient_N_s2_per_rad_m": m.inflow_coefficient}
    return out


def _one_dof_lines(one_dof: Mapping[str, OneDofModel]) -> list[str]:
    """The ``one_dof`` models for :meth:`Vehicle.summary`, one line each with units."""
    if not one_dof:
        return []
    lines = [f"  one_dof ({len(one_dof)} one-DOF models, Caccia et al. 2000 eq. 3):"]
    for key, m in one_dof.items():
        ang = m.dof in ("roll", "pitch", "yaw")
        u = ("kg·m²", "N·m·s/rad", "N·m·s²/rad²", "N·m") if ang else ("kg", "N·s/m", "N·s²/m²", "N")
        line = (f"    {key}: {m.dof}, {'inertia' if ang else 'mass'} {m.mass:.4g} {u[0]}, linear "
                f"{m.linear:.4g} {u[1]}, quadratic {m.quadratic:.4g} {u[2]}, disturbance "
                f"{m.disturbance:.4g} {u[3]}")
        if m.eta_pos != 1.0 or m.eta_neg != 1.0:
            line += f", η+ {m.eta_pos:.3g}, η− {m.eta_neg:.3g}"
        if m.inflow_coefficient:
            line += f", inflow coefficient {m.inflow_coefficient:.4g} N·s²/(rad·m)"
        lines.append(line)
    return lines


def _weight_mass_warnings(vehicle: Vehicle) -> list[str]:
    """A ``weight`` given beside ``mass`` more than :data:`WEIGHT_MASS_RTOL` from ``m g`` (a
    file that gives only the mass has ``W = m g``).  Far slips (a unit) are
    :func:`rigid_body_warnings`' :data:`WEIGHT_FACTOR` message, not repeated here."""
    g = vehicle.weight_given_g
    m, w = float(vehicle.params.mass), float(vehicle.params.weight)
    if g is None or not (m > 0.0 and w > 0.0):
        return []
    mg = m * g
    if abs(w - mg) <= WEIGHT_MASS_RTOL * mg or not 1.0 / WEIGHT_FACTOR <= w / (m * 9.81) <= WEIGHT_FACTOR:
        return []
    return [f"rigid_body.weight {w:.4g} N differs by {100 * (w / mg - 1):+.1f} % from "
            f"rigid_body.mass {m:.4g} kg × g {g:.5g} m/s² = {mg:.4g} N: was one edited without the "
            "other? Give the weight that matches the mass (or leave weight out: it is then m·g)"]


def _battery_warnings(vehicle: Vehicle) -> list[str]:
    """A battery storing more than :data:`MAX_BATTERY_WH_PER_KG` per kg of the vehicle: the
    capacity is in another unit (mAh typed as Ah)."""
    b, m = vehicle.battery, float(vehicle.params.mass)
    if b is None or not m > 0.0:
        return []
    wh = float(b.capacity_ah) * float(max(b.ocv_voltage))
    if wh / m <= MAX_BATTERY_WH_PER_KG:
        return []
    hint = (f"is it in mAh? ({b.capacity_ah / 1000:.4g} Ah)" if wh / 1000 / m <= MAX_BATTERY_WH_PER_KG
            else "expected amp-hours")
    return [f"battery.capacity_ah: {b.capacity_ah:.6g} Ah at up to {max(b.ocv_voltage):.4g} V stores "
            f"{wh / 1000:.4g} kWh, {wh / m:.4g} Wh per kg of the vehicle's {m:.4g} kg — no battery "
            f"stores more than ~300 Wh/kg, and it weighs less than the vehicle (bound "
            f"{MAX_BATTERY_WH_PER_KG:g} Wh/kg of vehicle): {hint}"]


def _warn_on_load(vehicle: Vehicle, where: str, base_dir: Path | None) -> None:
    """What a valid file may still hold wrong, as :class:`VehicleFileWarning` naming the file — on
    every load, a cached one too: :func:`rigid_body_warnings`, and with inflow on a thruster
    whose fitted propeller map does not reach a direction it pushes
    (:func:`uuvid.vehicle.inflow.map_range_warnings`)."""
    msgs = rigid_body_warnings(vehicle.params, vehicle.layout) + _model_warnings(vehicle,
                                                                                 base_dir)
    msgs += _no_drag_warnings(vehicle)
    msgs += _limit_warnings(vehicle, base_dir) + _dead_thruster_warnings(vehicle)
    msgs += _one_way_warnings(vehicle)
    msgs += _coincident_warnings(vehicle) + _axis_warnings(vehicle)
    msgs += _inflow_key_warnings(vehicle, base_dir)
    msgs += _weight_mass_warnings(vehicle) + _battery_warnings(vehicle)
    cur = np.asarray(vehicle.params.current, float)
    if np.any(cur != 0.0):
        # missions, hold, sweeps and the envelope take the current the run is given: a vehicle
        # "in 0.5 m/s" flew in still water, unsaid
        msgs.append(f"environment.current: {cur.tolist()} m/s is read only where the vehicle "
                    "model's right-hand side is used directly (vehicle_rhs, the envelope's "
                    "confirmation flights, synthetic dives); missions, hold, sweeps and the "
                    "envelope's own speeds take the current their run is given — a scenario's current: "
                    "[N, E, D] (uuvid simulate SCENARIO.yaml), uuvid simulate mission --current "
                    "N,E,D, uuvid vehicle hold --current SPEED,DIR, or current= of "
                    "uuvid.simulate.vehicle_sim.setup_mission; give it there, and leave "
                    "environment out of this file")
    if vehicle.inflow != "none":
        from uuvid.vehicle.inflow import map_range_warnings, thruster_map

        refs = [vehicle.propeller(i) for i in range(vehicle.layout.n)]
        for ref, idx in _by_propeller(refs).items():  # one message per file, naming its thrusters
            try:
                fq = thruster_map(ref, base_dir)
            except (KeyError, OSError, ValueError):  # an error at load; at use if it changed since
                continue
            lim = np.asarray(vehicle.layout.limits, float)[idx]
            msgs += map_range_warnings(fq, (lim[:, 0].min(), lim[:, 1].max()),
                                       f"thrusters[{', '.join(map(str, idx))}] propeller {ref!r}")
    for msg in msgs:
        warnings.warn(f"{where}: {msg}", VehicleFileWarning, stacklevel=3)


def _validation_messages(e: ValidationError, where: str) -> list[str]:
    msgs = []
    for err in e.errors():
        loc = list(err["loc"])
        # drop the union-member tags pydantic inserts (installation.x.float / tuple[...])
        loc = [p for p in loc if not (isinstance(p, str) and (p in ("float", "str", "list[str]")
                                                              or p.startswith("tuple[")))]
        text = _TEXT.get(err["type"], err["msg"])
        text = text.removeprefix("Value error, ")
        msgs.append(f"{where}: {_loc(loc)}: {text}")
    # the same path may come out once per union member; keep the first
    seen, out = set(), []
    for m in msgs:
        key = m.rsplit(": ", 1)[0]
        if key not in seen:
            seen.add(key)
            out.append(m)
    return out


#: What the top level of a vehicle file holds (said when a file is not one).
VEHICLE_FILE_KEYS = ("name, source, rigid_body, hydrodynamics and usually thrusters (optionally "
                     "description, assumptions, environment, inflow, allocation, modes, one_dof, "
                     "battery)")


def vehicle_from_dict(raw: Any, where: str = "<vehicle>", base_dir: Path | None = None,
                      path: Path | None = None, inflow: str | None = None) -> Vehicle:
    """Validate a vehicle description (as loaded from YAML/TOML) and build a :class:`Vehicle`.

    ``inflow`` (``None``: the file's ``inflow`` key) overrides that key — the commands'
    ``--inflow``: the vehicle is built with the inflow in force, and the thrusters' propeller maps
    are checked only when it is on (``'none'`` flies a file whose models hold no map)."""
    if inflow is not None:
        from uuvid.vehicle.inflow import resolve_inflow

        resolve_inflow(None, inflow)  # ValueError naming the models
    if not isinstance(raw, dict):
        raise VehicleFileError(f"{where}: expected a mapping at the top level, got "
                               f"{type(raw).__name__}")
    from pydantic import ValidationError

    from uuvid.vehicle.schema import VehicleSchema

    try:
        spec = VehicleSchema.model_validate(raw)
    except ValidationError as e:
        kind = other_kind(raw, "a vehicle file")
        if kind:
            raise VehicleFileError(f"{where}: not a vehicle file: it looks like {kind}; a vehicle "
                                   f"file has {VEHICLE_FILE_KEYS}") from None
        raise VehicleFileError("\n".join(_validation_messages(e, where))) from None
    errors: list[str] = []

    def err(p: str, text: str):
        errors.append(f"{where}: {p}: {text}")

    # ------------------------------------------------------------ rigid body
    rb = spec.rigid_body
    weight = rb.weight if rb.weight is not None else rb.mass * rb.gravity
    buoyancy = rb.buoyancy
    if rb.buoyancy is not None and rb.displaced_volume is not None:
        err("rigid_body.displaced_volume", "give buoyancy or displaced_volume, not both")
    elif rb.buoyancy is None:
        if rb.displaced_volume is None:
            err("rigid_body.buoyancy", "missing (or give displaced_volume and water_density)")
        elif rb.water_density is None:
            err("rigid_body.water_density", "missing (needed with displaced_volume)")
        else:
            buoyancy = rb.water_density * rb.gravity * rb.displaced_volume
    inertia = np.asarray(rb.inertia, dtype=float)
    inertia = np.diag(inertia) if inertia.size == 3 else inertia.reshape(3, 3)
    if rb.inertia_about == "origin":  # I_g = I_o + m S(r_g)²
        S = skew_ref(rb.center_of_gravity)
        inertia = inertia + rb.mass * S @ S

    # ------------------------------------------------------------ modes and thrusters
    names = [t.name for t in spec.thrusters]
    for i, t in enumerate(spec.thrusters):
        if names.index(t.name) != i:
            err(f"thrusters[{i}].name", f"duplicate thruster name {t.name!r}")
    mode_names = set(spec.modes)
    thrusters: list[Thruster] = []
    for i, t in enumerate(spec.thrusters):
        p = f"thrusters[{i}]"
        if t.axis is None and t.rpy_deg is None:
            err(f"{p}.axis", "missing (give axis or rpy_deg)")
            continue
        if t.axis is not None and t.rpy_deg is not None:
            err(f"{p}.rpy_deg", "give axis or rpy_deg, not both")
            continue
        axis = (np.asarray(t.axis, float) if t.axis is not None
                else axis_from_rpy(*np.radians(t.rpy_deg)))
        if np.linalg.norm(axis) < 1e-9:
            err(f"{p}.axis", "must be a non-zero vector")
            continue
        lo, hi = t.limits
        if not lo <= 0.0 <= hi:
            err(f"{p}.limits", f"must be [min, max] with min <= 0 <= max, got [{lo}, {hi}]")
            continue
        if (big := max(abs(lo), abs(hi))) > MAX_THRUST_N:
            err(f"{p}.limits", f"{t.name}: [{lo:g}, {hi:g}] N: {big:g} N is beyond what any "
                f"thruster gives (at most {MAX_THRUST_N:g} N, MAX_THRUST_N; a BlueROV2's T200 "
                "gives 51 N, work-class ROV thrusters a few kN): expected the thrust limits in "
                "newtons (a placeholder for 'no limit'? give the thruster's data-sheet thrust)")
            continue
        bad = False
        for m, eta in t.installation.items():
            if m not in mode_names:
                err(f"{p}.installation.{m}", f"unknown mode; modes: {sorted(mode_names)}")
                bad = True
            elif any(v <= 0 for v in np.atleast_1d(eta)):
                err(f"{p}.installation.{m}", "installation coefficients must be > 0")
                bad = True
        if bad:
            continue
        thrusters.append(Thruster(t.name, t.position, tuple(axis), t.model, (lo, hi),
                                  dict(t.installation)))
    mode = spec.inflow if inflow is None else inflow
    if mode != "none":  # the maps matter only with inflow on (--inflow none overrides the file)
        errors += _propeller_errors(spec, where, base_dir, mode)
    layout = None
    if not errors:
        layout = ThrusterLayout(tuple(thrusters))
        modes = {}
        for mname, ms in spec.modes.items():
            p = f"modes.{mname}"
            ok = True
            for j, c in enumerate(ms.constraints):
                for k in c:
                    if k not in names:
                        err(f"{p}.constraints[{j}].{k}", f"unknown thruster; have {names}")
                        ok = False
                if c and all(v == 0 for v in c.values()):
                    err(f"{p}.constraints[{j}]", "all coefficients are zero")
                    ok = False
            for j, k in enumerate(ms.off):
                if k not in names:
                    err(f"{p}.off[{j}]", f"unknown thruster; have {names}")
                    ok = False
            for key in ms.eta_dof:
                d = key.rstrip("+-")
                if d not in DOF_NAMES or len(key) - len(d) > 1:
                    err(f"{p}.eta_dof.{key}", "keys are a DOF name with an optional + or - "
                        "(e.g. surge+, yaw)")
                    ok = False
            if not ok:
                continue
            ep, en = layout.eta(mname)
            modes[mname] = ThrustMode.from_names(
                mname, names, ms.constraints, ms.zero_dofs, ms.off,
                {n_: (float(ep[i]), float(en[i])) for i, n_ in enumerate(names)},
                open_water=ms.open_water, description=ms.description, eta_dof=ms.eta_dof)
    al = spec.allocation
    if al.weights is not None and len(al.weights) != len(spec.thrusters):
        err("allocation.weights", f"expected {len(spec.thrusters)} values (one per thruster), got "
            f"{len(al.weights)}")
    elif al.weights is not None and any(w <= 0 for w in al.weights):
        err("allocation.weights", "weights must be > 0")
    dof_seen: dict[str, int] = {}
    for j, d in enumerate(al.dofs):
        if d in dof_seen:
            err(f"allocation.dofs[{j}]", f"{d} is named twice (also allocation.dofs"
                f"[{dof_seen[d]}]): each controlled DOF is one equation of the allocation; name it "
                "once")
        dof_seen.setdefault(d, j)
    # the DOFs the file names (the default, all six, is not checked: a file may leave out the
    # allocation block, e.g. for drag identification without thrusters)
    if layout is not None and layout.n and "dofs" in al.model_fields_set \
            and len(dof_seen) == len(al.dofs):
        for j, text in _uncontrollable_dofs(layout.B, [dof_index(d) for d in al.dofs]):
            err(f"allocation.dofs[{j}]", text)
    for j, m in enumerate(al.default_modes):
        if m not in mode_names:
            err(f"allocation.default_modes[{j}]", f"unknown mode; modes: {sorted(mode_names)}")
    one_dof = {}
    for key, od in spec.one_dof.items():
        if (text := _one_dof_key_error(key, od.dof)) is not None:
            err(f"one_dof.{key}.dof", text)
            continue
        if od.mode is not None and od.mode not in mode_names:
            err(f"one_dof.{key}.mode", f"unknown mode; modes: {sorted(mode_names)}")
            continue
        if od.linear == 0 and od.quadratic == 0:
            err(f"one_dof.{key}.linear", "linear or quadratic drag must be > 0")
            continue
        one_dof[key] = OneDofModel(od.mass, od.linear, od.quadratic, od.eta_pos, od.eta_neg,
                                   od.disturbance, od.dof, od.inflow_coefficient)
    if errors:
        raise VehicleFileError("\n".join(errors))

    # ------------------------------------------------------------ physics
    try:
        params = VehicleParams(rb.mass, inertia, np.array(rb.center_of_gravity),
                               np.array(rb.center_of_buoyancy), weight, buoyancy,
                               spec.hydrodynamics.added_mass, spec.hydrodynamics.linear_damping,
                               spec.hydrodynamics.quadratic_damping,
                               np.array(spec.environment.current), spec.quaternion_gain, spec.name)
    except ParameterError as e:
        raise VehicleFileError(f"{where}: {_PARAM_PATH.get(e.param, e.param or '')}: {e}") from None
    vehicle = Vehicle(spec.name, params, layout, modes,
                      tuple(dof_index(d) for d in al.dofs),
                      None if al.weights is None else np.asarray(al.weights, float),
                      tuple(al.default_modes), one_dof, spec.source.model_dump(exclude_none=True),
                      dict(spec.assumptions), spec.description, path,
                      _battery(spec.battery, where) if spec.battery is not None else None,
                      mode, tuple(float(t.wake) for t in spec.thrusters),
                      tuple(t.propeller or t.model for t in spec.thrusters),
                      tuple(None if t.axis is None else tuple(float(x) for x in t.axis)
                            for t in spec.thrusters),
                      None if rb.weight is None else float(rb.gravity))
    _warn_on_load(vehicle, where, base_dir)
    return vehicle


#: A row of ``B`` (or what is left of it beside the other controlled DOFs' rows) below this
#: fraction of the largest row norm is no authority (rounding of the axes and positions only).
AUTHORITY_RTOL = 1e-9


def _uncontrollable_dofs(B, dofs: Sequence[int]) -> list[tuple[int, str]]:
    """``(position in dofs, why)`` for each DOF of ``dofs`` the thrusters cannot hold: its row
    of ``B`` is zero (no thruster pushes or turns it), or a combination of the rows of the DOFs
    named before it (every thrust moves it in a fixed ratio to those: the allocation cannot set
    them independently, and would silently meet the request in the least-squares sense)."""
    B = np.asarray(B, float)
    tol = AUTHORITY_RTOL * max(float(np.linalg.norm(B, axis=1).max(initial=0.0)), 1e-300)
    out: list[tuple[int, str]] = []
    kept: list[int] = []
    for j, d in enumerate(dofs):
        row = B[d]
        name = DOF_NAMES[d]
        if np.linalg.norm(row) <= tol:
            out.append((j, f"{name}: no thruster gives any {'force' if d < 3 else 'moment'} in "
                        f"{name} (its row of the thrust configuration matrix B is zero): the "
                        f"thrusters cannot hold it; leave {name} out of allocation.dofs (it is then "
                        "left to drag and the restoring forces)"))
            continue
        if kept:
            A = B[kept]
            c = np.linalg.lstsq(A.T, row, rcond=None)[0]
            if np.linalg.norm(A.T @ c - row) <= tol:
                big = np.abs(c) > 1e-6 * np.abs(c).max()
                ratio = " + ".join(f"{c[k]:.4g} × {DOF_NAMES[kept[k]]}"
                                   for k in np.flatnonzero(big))
                out.append((j, f"{name}: the thrusters cannot hold it independently of "
                            f"{', '.join(DOF_NAMES[kept[k]] for k in np.flatnonzero(big))}: every "
                            f"thrust gives {name} = {ratio} (its row of the thrust configuration "
                            "matrix B is a combination of theirs), so the allocation cannot set "
                            f"them all; leave {name} (or one of those) out of allocation.dofs"))
                continue
        kept.append(d)
    return out


def _battery(b: BatterySchema, where: str):
    from uuvid.vehicle.power import POWER_MODELS, Battery

    if b.thruster_power_model not in POWER_MODELS:
        raise VehicleFileError(
            f"{where}: battery.thruster_power_model {b.thruster_power_model!r}: unknown; the "
            f"thruster power models are {', '.join(POWER_MODELS)} (the voltage-aware T200: "
            "thrust limits and current at a supply voltage); a thruster's own model goes in "
            "its thrusters[*].model")
    try:
        return Battery(b.name, b.capacity_ah, tuple(b.ocv_soc), tuple(b.ocv_voltage), b.resistance,
                       b.hotel_load_w, b.min_voltage, b.max_current, b.thruster_power_model,
                       b.source, b.assumptions)
    except ValueError as e:
        raise VehicleFileError(f"{where}: battery: {e}") from None


def list_presets() -> list[str]:
    """Names of the vehicle presets shipped with uuvid (``load_vehicle(name)``)."""
    return sorted(p.stem for p in PRESET_DIR.glob("*.yaml"))


def preset_path(name: str) -> Path:
    p = PRESET_DIR / f"{name}.yaml"
    if not p.is_file():
        raise KeyError(f"unknown vehicle preset {name!r}; known: {', '.join(list_presets())}")
    return p


def as_vehicle(vehicle, expected: str, func: str = "") -> Vehicle:
    """``vehicle`` as a :class:`Vehicle`: a preset name or a vehicle file (a ``str`` or any
    path-like) loaded, a vehicle as given, anything else a ``TypeError``
    ``"<func>: vehicle: <expected>, got …"`` (a string, ``None``, a thruster chain or layout
    failed later with an ``AttributeError`` naming no argument); ``func``: the function the
    vehicle was given to, named first (none: the message starts at ``vehicle:``)."""
    import os

    if isinstance(vehicle, (str, os.PathLike)):
        return load_vehicle(vehicle)
    if not all(hasattr(vehicle, a) for a in ("layout", "params", "allocator", "B")):
        raise TypeError(f"{func + ': ' if func else ''}vehicle: {expected}, got "
                        f"{type(vehicle).__name__} {vehicle!r:.80}")
    return vehicle


def load_vehicle(path_or_name: str | Path, inflow: str | None = None) -> Vehicle:
    """Load a vehicle from a YAML/TOML file or by preset name (``bluerov2``, ``romeo``, …).

    ``inflow`` (``None``: the file's ``inflow`` key; ``'none'``, ``'four-quadrant'``) overrides
    that key, as the commands' ``--inflow`` does (:func:`vehicle_from_dict`).

    A file validated once is kept in the disk cache (``vehicles`` beside the steady maps,
    :mod:`uuvid.core.cache`), keyed on its bytes, its path and a stamp of the code it depends
    on (layers 0–2: ``core``, ``thruster``, ``vehicle``): a warm start reads it back without
    parsing or validating again, and without importing pydantic.  An invalid file is never
    cached, so its errors are reported every time."""
    p = Path(path_or_name)
    if not p.is_file():
        if isinstance(path_or_name, str) and path_or_name in list_presets():
            p = preset_path(path_or_name)
        else:
            raise VehicleFileError(f"{path_or_name}: no such vehicle file and not a preset "
                                   f"(presets: {', '.join(list_presets())})")
    from uuvid.core.cache import digest, load_object, store_object, tree_stamp

    try:
        key = digest(tree_stamp("", "core", "thruster", "vehicle"), str(p.resolve()),
                     p.read_bytes(), *(() if inflow is None else (f"inflow={inflow}",)))
    except OSError:
        key = None
    where = p.name if p.parent == PRESET_DIR else str(p)
    cached = load_object("vehicles", key) if key else None
    if isinstance(cached, Vehicle):
        _warn_on_load(cached, where, p.parent)  # said on every load, not only the first
        return cached
    try:
        raw = read_model_text(p)
    except ModelFileError as e:
        raise VehicleFileError(str(e)) from None
    vehicle = vehicle_from_dict(raw, where=where, base_dir=p.parent, path=p.resolve(),
                                inflow=inflow)
    if key:
        store_object("vehicles", key, vehicle)
    return vehicle
