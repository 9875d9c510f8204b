"""Vehicle models: 6-DOF dynamics, Caccia's 1-DOF model, thruster layout, allocation, presets.

Modules:
    kinematics     unit-quaternion attitude kinematics, NED/FRD (Fossen 2011, §2.2.2)
    rigid_body     M_RB and C_RB (Fossen 2011, §3.3)
    hydrodynamics  added mass, damping, restoring forces (Fossen 2011, §§4.1, 6.3–6.4)
    model          VehicleParams, compiled and NumPy right-hand sides, OneDofModel (Caccia eq. 3)
    layout         thrusters → thrust configuration matrix B (UUV Simulator's ``tam``)
    allocation     pseudo-inverse / minimum-energy allocation, thrust-mapping modes, saturation
    definition     vehicle files (YAML/TOML, pydantic), presets, load_vehicle
    envelope       maximum steady speeds per DOF and direction (Laidani et al. Table 4 kind)
    linearize      analytic linearisation about a trimmed operating point (A, B, python-control)
"""

from uuvid.vehicle.allocation import (
    AllocationResult,
    Allocator,
    ThrustMode,
    allocate_compiled,
    constrained_allocation_matrix,
    delivered_compiled,
    pseudo_inverse,
    weighted_pseudo_inverse,
)
from uuvid.vehicle.definition import (
    Vehicle,
    VehicleFileError,
    VehicleFileWarning,
    list_presets,
    load_vehicle,
    vehicle_from_dict,
)
from uuvid.vehicle.layout import Thruster, ThrusterLayout, thrust_configuration_matrix

# eager: the submodule's name is the function's (a lazy name would be shadowed by the module
# once anything imports uuvid.vehicle.linearize)
from uuvid.vehicle.linearize import LinearModel, OperatingPoint, TrimError, linearize, trim
from uuvid.vehicle.model import (
    DOF_NAMES,
    N_PARAMS,
    PARAM_LAYOUT,
    OneDofModel,
    VehicleParams,
    make_params,
    make_state,
    one_dof_rhs,
    one_dof_rhs_compiled,
    steady_speed,
    vehicle_rhs,
    vehicle_rhs_into,
    vehicle_rhs_reference,
)

#: Names served on first use (PEP 562): a plain mission imports ``uuvid.vehicle`` for its model,
#: layout and allocation, and need not load the envelope and stability modules.
_LAZY = {"Envelope": "envelope", "speed_envelope": "envelope", "StabilityResult": "stability",
         "static_stability": "stability"}


def __getattr__(name: str):
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f"{__name__}.{mod}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "DOF_NAMES",
    "N_PARAMS",
    "PARAM_LAYOUT",
    "AllocationResult",
    "Allocator",
    "Envelope",
    "LinearModel",
    "OneDofModel",
    "OperatingPoint",
    "ThrustMode",
    "Thruster",
    "ThrusterLayout",
    "TrimError",
    "Vehicle",
    "VehicleFileError",
    "VehicleFileWarning",
    "VehicleParams",
    "allocate_compiled",
    "constrained_allocation_matrix",
    "delivered_compiled",
    "list_presets",
    "linearize",
    "load_vehicle",
    "make_params",
    "make_state",
    "one_dof_rhs",
    "one_dof_rhs_compiled",
    "pseudo_inverse",
    "speed_envelope",
    "static_stability",
    "StabilityResult",
    "steady_speed",
    "thrust_configuration_matrix",
    "trim",
    "vehicle_from_dict",
    "vehicle_rhs",
    "vehicle_rhs_into",
    "vehicle_rhs_reference",
    "weighted_pseudo_inverse",
]
