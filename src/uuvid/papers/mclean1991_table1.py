"""McLean (1991) Table I: the thesis's printed values and its eleven cases (thesis units converted
here).  Shared by the reproduction (:mod:`uuvid.papers.mclean1991`) and the identification of the
unprinted corrections (:mod:`uuvid.papers.mclean1991_identification`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from uuvid.core import units as U
from uuvid.thruster.presets import MCLEAN

#: Table I as printed: peak output thrust lb, max true thrust lb, steady thrust lb, time constant s,
#: steady propeller speed rpm.
TABLE1_THESIS = {
    "baseline": (5.40, 3.80, 0.50, 0.125, 925),
    "L=20in": (5.80, 3.80, 0.50, 0.230, 925),
    "L=5in": (4.40, 3.60, 0.50, 0.060, 925),
    "Ka=1.0": (5.80, 3.80, 0.50, 0.195, 925),
    "Ka=0.5": (5.60, 3.80, 0.50, 0.140, 925),
    "Pe=0.0270": (8.00, 7.00, 0.50, 0.075, 2000),
    "Pe=0.0721": (4.30, 2.90, 0.40, 0.145, 640),
    "Pe=0": (0.0, 0.0, 0.0, 0.025, 3000),
    "coulomb": (4.30, 3.00, 0.40, 0.130, 800),
    "baseline-16V": (3.60, 2.50, 0.33, 0.150, 725),
    "baseline-8V": (1.85, 1.25, 0.15, 0.200, 480),
}
TABLE1_FIELDS = ("peak_output_lbf", "max_true_lbf", "steady_lbf", "time_constant_s", "steady_rpm")

#: Simulation length of the thesis's runs (1.333 s at 24 V).
STEP_DURATION = 1.333


@dataclass(frozen=True)
class Case:
    """One Table I case: thruster overrides (SI) and the step voltage."""

    name: str
    overrides: dict = field(default_factory=dict)
    voltage: float = MCLEAN.supply_voltage


def table1_cases() -> list[Case]:
    """Table I's eleven cases in the thesis's order (thesis units converted here)."""
    return [
        Case("baseline"),
        Case("L=20in", {"tunnel_length": U.inch(20.0)}),
        Case("L=5in", {"tunnel_length": U.inch(5.0)}),
        Case("Ka=1.0", {"added_mass_coefficient": 1.0}),
        Case("Ka=0.5", {"added_mass_coefficient": 0.5}),
        Case("Pe=0.0270", {"effective_pitch": U.ft_per_rad(0.0270)}),
        Case("Pe=0.0721", {"effective_pitch": U.ft_per_rad(0.0721)}),
        Case("Pe=0", {"effective_pitch": 0.0}),
        Case("coulomb", {"coulomb": True}),
        Case("baseline-16V", voltage=16.0),
        Case("baseline-8V", voltage=8.0),
    ]
