"""Thrusters from the papers, built from the numbers the papers print.

The thesis numbers (ft, lb, slug, oz·in) stay visible here as the papers print them and pass through
:mod:`uuvid.core.units` once; everything returned is SI.

* AUV II tunnel thruster — McLean (1991), Ch. II–III and App. B (Pittman 9514, 2.5:1 gear,
  3-in Kaplan propeller in a 0.2557-ft tunnel) with the test rig's load cell.
* Laidani et al. — PWM → ESC → A2212 first-order motor → degree-5 polynomial per direction.
"""

from __future__ import annotations

from dataclasses import dataclass

from uuvid.core import units as U
from uuvid.thruster.blocks import (
    ESC,
    DCMotor,
    FirstOrderMotor,
    LoadCell,
    PolynomialMap,
    QuadraticMap,
    TunnelThruster,
)
from uuvid.thruster.chain import ThrusterChain


@dataclass(frozen=True)
class McLeanThesisNumbers:
    """McLean (1991) as printed, in the thesis's units (App. B; Ch. II–III; digest §A.2)."""

    kt_oz_in_per_a: float = 4.13  # Pittman 9514 winding 3, torque constant
    kg_v_s_per_rad: float = 0.0292  # back-EMF constant
    resistance_ohm: float = 4.06
    inductance_h: float = 0.80e-3 * 4.06  # τ_e = 0.80 ms = L/R (neglected in the baseline)
    jm_oz_in_s2: float = 5.37e-4  # rotor inertia
    viscous_v_per_rad_s: float = 0.000862  # motor viscous friction written as a voltage (block 5)
    propeller_viscous_factor: float = 3.0  # propeller viscous = 3 × motor viscous, through N²
    coulomb_volts: float = 5.0  # the motor needs 4–5 V to start turning
    gear_ratio: float = 2.5  # 36/90 teeth
    rho_slug_ft3: float = 1.94  # fresh water
    tunnel_area_ft2: float = 0.05134  # ID 0.2557 ft
    tunnel_length_in: float = 10.5  # vertical tunnels (horizontal: 16.5 in)
    added_mass_coefficient: float = 0.25  # K_a
    efficiency: float = 0.75  # η
    pitch_ft_per_rad: float = 0.0721  # 30° Kaplan, pitch ratio 1.77
    profile_factor: float = 1.5  # β
    load_cell_a1: float = 14.1  # 1935/(s² + 14.1 s + 1935), block 9
    load_cell_a0: float = 1935.0
    supply_voltage: float = 24.0


MCLEAN = McLeanThesisNumbers()

#: α_o − α_i and β_o − β_i of the AUV II thruster.  The thesis tuned them by hand to its tests and
#: never printed them.  These are the values the seed digest (§A.3) worked out from Table I's steady
#: columns; ``uuvid.papers.mclean1991_identification.identify_corrections`` re-identifies them by
#: least squares over Table I's six steady operating points (2.92 ± 0.07 and 0.182 ± 0.008, so
#: 3.0 and 0.185 lie within ~1σ).  With them every Table I row is reproduced.
AUV2_ENERGY_CORRECTION = 3.0  # α_o − α_i
AUV2_MOMENTUM_CORRECTION = 0.185  # β_o − β_i


def pittman_9514(gear_ratio: float = MCLEAN.gear_ratio, coulomb: bool = False,
                 inductance: bool = False) -> DCMotor:
    """Pittman 9514 (winding 3) with McLean's viscous friction model; optional 5 V Coulomb offset."""
    m = MCLEAN
    kt = U.oz_in(m.kt_oz_in_per_a)
    # A voltage V_f per motor rad/s is a torque K_T V_f/R per rad/s (i = (V − V_f ω)/R).
    c_m = m.viscous_v_per_rad_s * kt / m.resistance_ohm
    c_p = m.propeller_viscous_factor * c_m  # at the propeller shaft; reflected as C_P/N²
    return DCMotor(
        torque_constant=kt,
        back_emf_constant=m.kg_v_s_per_rad,
        resistance=m.resistance_ohm,
        inductance=m.inductance_h if inductance else 0.0,
        motor_inertia=U.oz_in_s2(m.jm_oz_in_s2),
        motor_viscous=c_m,
        propeller_viscous=c_p,
        coulomb_torque=kt * m.coulomb_volts / m.resistance_ohm if coulomb else 0.0,
        gear_ratio=gear_ratio,
    )


def auv2_tunnel_thruster(
    tunnel_length: float | None = None,
    added_mass_coefficient: float = MCLEAN.added_mass_coefficient,
    effective_pitch: float | None = None,
    coulomb: bool = False,
    inductance: bool = False,
    energy_correction: float = AUV2_ENERGY_CORRECTION,
    momentum_correction: float = AUV2_MOMENTUM_CORRECTION,
) -> TunnelThruster:
    """McLean's AUV II tunnel thruster, baseline unless told otherwise (SI arguments).

    ``effective_pitch`` (m/rad) sets ``P_e = η p`` keeping η = 0.75 (``p = P_e/η``); 0 removes the
    water's effect entirely (Table I's "Pe = 0" row).
    """
    m = MCLEAN
    pitch = U.ft_per_rad(m.pitch_ft_per_rad)
    if effective_pitch is not None:
        pitch = effective_pitch / m.efficiency
    return TunnelThruster(
        motor=pittman_9514(coulomb=coulomb, inductance=inductance),
        water_density=U.slug_per_ft3(m.rho_slug_ft3),
        tunnel_area=U.ft2(m.tunnel_area_ft2),
        tunnel_length=U.inch(m.tunnel_length_in) if tunnel_length is None else tunnel_length,
        added_mass_coefficient=added_mass_coefficient,
        propeller_efficiency=m.efficiency,
        pitch=pitch,
        profile_factor=m.profile_factor,
        energy_correction=energy_correction,
        momentum_correction=momentum_correction,
    )


def mclean_load_cell() -> LoadCell:
    """The rig's load cell + box, ``1935/(s² + 14.1 s + 1935)`` (McLean block 9)."""
    return LoadCell.from_polynomial(MCLEAN.load_cell_a1, MCLEAN.load_cell_a0)


def auv2_rig_chain(**thruster_kwargs) -> ThrusterChain:
    """Voltage → AUV II tunnel thruster → load cell: the thesis's simulation (Fig. 3.1)."""
    return ThrusterChain((auv2_tunnel_thruster(**thruster_kwargs), mclean_load_cell()),
                         input_kind="voltage", name="auv2-tunnel-rig")


# ------------------------------------------------------------------------------------------------
# Laidani et al.
# ------------------------------------------------------------------------------------------------
#: Table 2, degree 5, highest power first; Ω in rad/s (magnitude), thrust magnitude in N.
LAIDANI_POLY_FORWARD = (1.3506e-15, -1.1879e-11, 2.4328e-8, -1.8243e-5, 0.0141, 0.0264)
LAIDANI_POLY_REVERSE = (-1.1504e-15, 5.4431e-12, -1.1928e-8, 1.0508e-5, 0.0057, 0.0020)
LAIDANI_KM = 131.3016  # A2212, rad/s per V (eq. 3)
LAIDANI_TAU = 0.01021  # s
LAIDANI_SUPPLY = 12.0  # V
LAIDANI_NEUTRAL_US = 1500.0
LAIDANI_DEADBAND_US = 50.0  # "a dead zone ... of about 50 µs"
LAIDANI_SATURATION_US = (1200.0, 1800.0)  # "from a PWM of 1,800 µs ... saturation"; mirrored


def laidani_esc(supply_voltage: float = LAIDANI_SUPPLY) -> ESC:
    """The ESC of Laidani et al.: linear PWM → voltage per direction (eq. 1), 50 µs dead band
    around 1500 µs, full supply voltage reached at the saturation onset (1800 µs forward,
    mirrored to 1200 µs in reverse; the paper prints only the forward one and the combined
    fit ``V = 0.012·PWM − 12``, which is ambiguous about direction)."""
    return ESC.from_range(LAIDANI_NEUTRAL_US, LAIDANI_DEADBAND_US, LAIDANI_SATURATION_US[0],
                          LAIDANI_SATURATION_US[1], supply_voltage, command_unit="pwm_us")


def laidani_chain(supply_voltage: float = LAIDANI_SUPPLY) -> ThrusterChain:
    """PWM → ESC → A2212 first-order motor → degree-5 polynomial per direction (Fig. 8–9)."""
    return ThrusterChain(
        (laidani_esc(supply_voltage), FirstOrderMotor(gain=LAIDANI_KM, time_constant=LAIDANI_TAU),
         PolynomialMap(forward=LAIDANI_POLY_FORWARD, reverse=LAIDANI_POLY_REVERSE)),
        input_kind="command", name="laidani-a2212")


# ------------------------------------------------------------------------------------------------
# Blue Robotics T200 (for vehicle simulations)
# ------------------------------------------------------------------------------------------------
#: Facts read off Blue Robotics' T200 performance sheet (Sept. 2019) at 16 V: full command 1100 /
#: 1900 µs, no thrust reading between 1472 and 1528 µs (speeds under 300 rpm were recorded as 0),
#: full-command speed ≈ 3500 rpm, thrust +5.25 / −4.07 kgf.
T200_SUPPLY = 16.0
T200_FULL_US = (1100.0, 1900.0)
T200_DEADBAND_US = 56.0
T200_FULL_SPEED = 3500.0 * 2.0 * 3.141592653589793 / 60.0  # rad/s
T200_MAX_THRUST_N = (U.kgf(5.25), U.kgf(4.07))
#: The two sheets' supply voltages (12 V and 16 V): the preset's steady constants are fitted there.
T200_SHEET_VOLTS = (12.0, 16.0)
#: Spin-up time constant: not on the sheet; assumed (typical of a 100 g propeller on an outrunner).
T200_TIME_CONSTANT = 0.1


@dataclass(frozen=True)
class T200Steady:
    """Steady constants of the ``t200`` preset (see :mod:`uuvid.identify.thruster.t200_preset`)."""

    curvature_fwd: float  # ESC duty curvature β, forward
    curvature_rev: float
    kt_fwd: float  # N·s²/rad², T = K_T Ω|Ω|
    kt_rev: float
    full_speed: float  # rad/s at full command and 16 V
    speed_exponent: float  # γ: full-command speed ∝ V^γ
    deadband_fwd: float = 0.0  # µs, forward dead-band edge − 1500
    deadband_rev: float = 0.0  # µs, 1500 − reverse dead-band edge


#: Fitted by :func:`uuvid.identify.thruster.t200_preset.fit_t200_preset` to the 12 V and 16 V sheets
#: (weighted least squares on thrust and speed; refit: ``python -m uuvid.identify.thruster.t200_preset``;
#: tests/test_t200_preset.py checks these equal a refit within its σ).  The steady thrust is then
#: within T200_SHEET_TOLERANCE of the sheet's max |thrust| at every row of both sheets (≤ 1.9 %).
T200_STEADY = T200Steady(
    curvature_fwd=-0.3456, curvature_rev=-0.3694, kt_fwd=3.668e-4, kt_rev=2.856e-4,
    full_speed=375.57, speed_exponent=0.6010)
T200_SHEET_TOLERANCE = 0.02


def t200_chain(supply_voltage: float = T200_SUPPLY, steady: T200Steady = T200_STEADY, *,
               warn: bool = True) -> ThrusterChain:
    """Blue Robotics T200: PWM → ESC → first-order motor → ``K_T Ω|Ω|`` per direction.

    The ESC has a per-direction dead-band edge ``e`` and duty curvature β,
    ``V = V_s s (1 + β (s − 1))`` with ``s = (c − e)/(f − e)`` (f = 1900 / 1100 µs); the motor's gain
    ``K_m = Ω_16 (V_s/16 V)^γ / V_s`` gives the full-command speed at the supply ``V_s``; its time
    constant is :data:`T200_TIME_CONSTANT` (assumed).  Steady thrust follows Blue Robotics' 12 V and
    16 V sheets (:data:`T200_STEADY`); away from 12–16 V the speed is the power law's extrapolation
    (warned).  Every block is static but the first-order motor, so the SIMD batch kernel's fast
    path takes it.
    """
    v = float(supply_voltage)
    if warn and not (T200_SHEET_VOLTS[0] - 1e-9 <= v <= T200_SHEET_VOLTS[1] + 1e-9):
        import warnings

        warnings.warn(f"t200_chain: {v:g} V is outside the sheets' {T200_SHEET_VOLTS[0]:g}–"
                      f"{T200_SHEET_VOLTS[1]:g} V; the full-command speed is extrapolated by "
                      f"Ω ∝ V^{steady.speed_exponent:.2f}", stacklevel=2)
    lo, hi = 1500.0 - steady.deadband_rev, 1500.0 + steady.deadband_fwd
    a_f = v / (T200_FULL_US[1] - hi)
    a_r = v / (lo - T200_FULL_US[0])
    esc = ESC(a_fwd=a_f, b_fwd=-a_f * hi, a_rev=a_r, b_rev=-a_r * lo, neutral=1500.0,
              deadzone_low=lo, deadzone_high=hi, saturation_low=T200_FULL_US[0],
              saturation_high=T200_FULL_US[1], supply_voltage=v, command_unit="pwm_us",
              curvature_fwd=steady.curvature_fwd, curvature_rev=steady.curvature_rev)
    gain = steady.full_speed * (v / T200_SUPPLY) ** steady.speed_exponent / v
    return ThrusterChain(
        (esc, FirstOrderMotor(gain=gain, time_constant=T200_TIME_CONSTANT),
         QuadraticMap(k_pos=steady.kt_fwd, k_neg=steady.kt_rev)),
        input_kind="command", name="t200")


def auv2_tunnel_chain(**thruster_kwargs) -> ThrusterChain:
    """Voltage → AUV II tunnel thruster (no test rig): the thruster as it sits in the vehicle."""
    return ThrusterChain((auv2_tunnel_thruster(**thruster_kwargs),), input_kind="voltage",
                         name="auv2-tunnel-thruster")


PRESETS = {
    "auv2-tunnel": auv2_rig_chain,
    "auv2-tunnel-thruster": auv2_tunnel_chain,
    "laidani-a2212": laidani_chain,
    "t200": t200_chain,
}


def preset_chain(name: str, supply_voltage: float | None = None) -> ThrusterChain:
    """A named preset chain (``auv2-tunnel``, ``laidani-a2212``, ``t200``…), at ``supply_voltage``
    when given (the preset's own voltage law, e.g. the T200's speed ∝ V^γ; presets without an
    ESC take no supply voltage)."""
    try:
        make = PRESETS[name]
    except KeyError:
        raise KeyError(f"unknown thruster preset {name!r}; known: {sorted(PRESETS)}") from None
    if supply_voltage is None:
        return make()
    if name not in ("laidani-a2212", "t200"):
        raise ValueError(f"thruster preset {name!r} has no ESC: a supply voltage does not apply")
    return make(supply_voltage=float(supply_voltage))
