"""The vehicle file's schema (pydantic), apart from :mod:`uuvid.vehicle.definition` so that
pydantic is imported only when a file is validated — a vehicle read from the cache of validated
files (:func:`uuvid.vehicle.definition.load_vehicle`) and a plain mission never import it.
Every key is documented in :mod:`uuvid.vehicle.definition`."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from uuvid.core.units import G0
from uuvid.core.yamltypes import Num, boolean_message
from uuvid.vehicle.model import DOF_NAMES

_CFG = ConfigDict(extra="forbid", allow_inf_nan=False)
Vec3 = tuple[Num, Num, Num]
DofName = Literal["surge", "sway", "heave", "roll", "pitch", "yaw"]


def _six_or_36(v: list[float]) -> list[float]:
    if len(v) not in (6, 36):
        raise ValueError(f"expected 6 (diagonal) or 36 (6×6 row-major) values, got {len(v)}")
    return v


class SourceSchema(BaseModel):
    model_config = _CFG
    citation: str = Field(min_length=1)
    transcribed_from: str | list[str] | None = None
    notes: str | None = None


class EnvironmentSchema(BaseModel):
    model_config = _CFG
    current: Vec3 = (0.0, 0.0, 0.0)


class RigidBodySchema(BaseModel):
    model_config = _CFG
    mass: Num = Field(gt=0)
    weight: Num | None = Field(None, ge=0)
    buoyancy: Num | None = Field(None, ge=0)
    displaced_volume: Num | None = Field(None, gt=0)
    water_density: Num | None = Field(None, gt=0)
    gravity: Num = Field(G0, gt=0)
    center_of_gravity: Vec3
    center_of_buoyancy: Vec3
    inertia: list[Num]
    inertia_about: Literal["cg", "origin"] = "cg"

    @field_validator("inertia", mode="before")
    @classmethod
    def _inertia_matrix(cls, v):
        """A 3×3 matrix written as three rows is the 9 values row-major."""
        if isinstance(v, (list, tuple)) and len(v) == 3 and all(isinstance(r, (list, tuple))
                                                                 for r in v):
            if any(len(r) != 3 for r in v):
                raise ValueError("a 3×3 inertia matrix needs three rows of three values")
            return [x for r in v for x in r]
        return v

    @field_validator("inertia")
    @classmethod
    def _inertia_len(cls, v):
        if len(v) not in (3, 9):
            raise ValueError(f"expected 3 (principal) or 9 (3×3 row-major) values, got {len(v)}")
        return v


class HydrodynamicsSchema(BaseModel):
    model_config = _CFG
    added_mass: list[Num]
    linear_damping: list[Num]
    quadratic_damping: list[Num]

    @field_validator("added_mass", "linear_damping", "quadratic_damping")
    @classmethod
    def _len(cls, v):
        return _six_or_36(v)


class ThrusterSchema(BaseModel):
    model_config = _CFG
    name: str = Field(min_length=1)
    position: Vec3
    axis: Vec3 | None = None
    rpy_deg: Vec3 | None = None
    model: str = Field(min_length=1)
    limits: tuple[Num, Num]
    installation: dict[str, Num | tuple[Num, Num]] = {}
    wake: Num = Field(0.0, ge=0, lt=1)  # wake fraction w: u_a = (1 − w) axisᵀ(v_r + ω × r)
    # the propeller's four-quadrant map for inflow (default: the model's): a preset name or a
    # thruster model file with a four-quadrant 'inflow' section (a bench fit in a flow)
    propeller: str | None = Field(None, min_length=1)
    notes: str | None = None

    @field_validator("installation", mode="before")
    @classmethod
    def _installation_numbers(cls, v):
        """A boolean η said once, naming the mode: through the union, pydantic named each member
        (``installation.x.function-before[…]`` and ``Input should be a valid tuple``)."""
        for mode, eta in (v.items() if isinstance(v, dict) else ()):
            for x in (eta if isinstance(eta, (list, tuple)) else (eta,)):
                if isinstance(x, bool):
                    raise ValueError(f"{mode}: {boolean_message(x)}")
        return v

    @field_validator("wake", mode="before")
    @classmethod
    def _wake_fraction(cls, v):
        """A wake fraction outside [0, 1) said as one (pydantic's "Input should be less than 1"
        did not say what the number is)."""
        if isinstance(v, (int, float)) and not isinstance(v, bool) and not 0 <= v < 1:
            raise ValueError(f"a wake fraction w in [0, 1) (the advance speed is (1 − w) times the "
                             f"water's speed along the thruster; ROV thrusters ≈ 0–0.3), got {v:g}")
        return v


class ModeSchema(BaseModel):
    model_config = _CFG
    description: str = ""
    constraints: list[dict[str, Num]] = []
    zero_dofs: list[DofName] = []
    off: list[str] = []
    open_water: str = ""
    eta_dof: dict[str, Num] = {}


class AllocationSchema(BaseModel):
    model_config = _CFG
    dofs: list[DofName] = list(DOF_NAMES)
    weights: list[Num] | None = None
    default_modes: list[str] = []


class OneDofSchema(BaseModel):
    model_config = _CFG
    dof: DofName
    mass: Num = Field(gt=0)
    linear: Num = Field(ge=0)
    quadratic: Num = Field(0.0, ge=0)
    eta_pos: Num = Field(1.0, gt=0)
    eta_neg: Num = Field(1.0, gt=0)
    disturbance: Num = 0.0
    inflow_coefficient: Num = Field(0.0, ge=0)  # k_a [N·s²/(rad·m)], thrust lost to u_a
    mode: str | None = None
    notes: str | None = None


class BatterySchema(BaseModel):
    """Battery block (see :mod:`uuvid.vehicle.power`): OCV vs SOC, internal resistance, capacity."""
    model_config = _CFG
    name: str = "battery"
    capacity_ah: Num = Field(gt=0)
    ocv_soc: list[Num] = Field(min_length=2)
    ocv_voltage: list[Num] = Field(min_length=2)
    resistance: Num = Field(ge=0)
    hotel_load_w: Num = Field(0.0, ge=0)
    min_voltage: Num = Field(0.0, ge=0)
    max_current: Num | None = Field(None, gt=0)
    thruster_power_model: str = "t200-physical"
    source: str = ""
    assumptions: str = ""


class VehicleSchema(BaseModel):
    model_config = _CFG
    name: str = Field(min_length=1)
    description: str = ""
    source: SourceSchema
    assumptions: dict[str, str] = {}
    environment: EnvironmentSchema = EnvironmentSchema()
    inflow: Literal["none", "four-quadrant"] = "none"
    quaternion_gain: Num = Field(1.0, ge=0)
    rigid_body: RigidBodySchema
    hydrodynamics: HydrodynamicsSchema
    thrusters: list[ThrusterSchema] = []
    allocation: AllocationSchema = AllocationSchema()
    modes: dict[str, ModeSchema] = {}
    one_dof: dict[str, OneDofSchema] = {}
    battery: BatterySchema | None = None

    @field_validator("inflow", mode="before")
    @classmethod
    def _inflow_null_is_none(cls, v):
        """``inflow: null`` (or an empty ``inflow:``) is bollard thrust, as the key left out; a
        YAML boolean (``off``, ``no``) is said to be written ``none``."""
        if v is None:
            return "none"
        if isinstance(v, bool):
            raise ValueError(f"got {v!r} (YAML reads on/off/yes/no as a boolean): write none or "
                             "four-quadrant")
        return v
