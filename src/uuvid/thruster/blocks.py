"""The blocks a thruster is built from, as small frozen parameter records.

Each block is a pure function of (state, input, parameters); its numerical core lives in
:mod:`uuvid.thruster.kernels` (compiled with numba) and is selected by the block's ``KIND`` code.
A block declares which signal it takes (``command``, ``voltage``, ``speed``, ``thrust``) and
which it produces, so :class:`uuvid.thruster.chain.ThrusterChain` can check a composition the way
one checks the wires of a block diagram (McLean 1991, Fig. 3.1; Laidani et al., Fig. 1b).

Sources:
    ESC          Laidani et al. eq. (1)–(2): ``V = a·PWM + b`` per direction, dead zone, saturation.
    FirstOrderMotor  Laidani et al. eq. (3): ``Ω/V = K_m/(1 + τ s)`` (A2212: 131.3016, 0.01021 s).
    DCMotor      McLean 1991 eqs. 2.1–2.5: armature ``L di/dt = V − R i − K_G ω_m``, torque ``K_T i``,
                 ``(J_M + J_P/N²) ω̇_m + (C_M + C_P/N²) ω_m + Q/N + T_c sgn ω_m = K_T i``.
    TunnelThruster   McLean 1991 eqs. 2.12–2.16 (digest §A.1): DC motor + gear + tunnel water.
    QuadraticMap ``T = K_T Ω|Ω|`` (also Caccia 2000 ``T = c_V V|V|``), per direction.
    PolynomialMap    Laidani et al. Table 2: ``|T| = Σ K_Ti |Ω|^(n−i)`` per direction.
    DeadZoneMap  UUV Simulator ``Bessa`` conversion: ``T = c_{L,R}(x|x| − δ_{L,R})`` outside [δ_L, δ_R].
    TableMap     UUV Simulator ``LinearInterp``: linear interpolation, end values held.
    ZeroOrder, FirstOrder, Yoerger, BessaDynamics   UUV Simulator dynamics (Yoerger et al. 1990;
                 Bessa et al. 2005), integrated as ODEs.
    LoadCell     McLean 1991 block 9: ``F_out/F = ω_n²/(s² + 2ζω_n s + ω_n²)``.
    Driver       dead band per direction, offset, gain and output limit of an ESC/driver (the ESC
                 law of Laidani eq. 1 written by its identifiable thresholds; runs on the ESC kernel).
    HealeyThruster   Healey et al. 1995 / Bachmayer et al. 2000: shaft speed + axial inflow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import ClassVar

import numpy as np

# Signal kinds that travel along a chain.
COMMAND, VOLTAGE, SPEED, THRUST, MEASURED = "command", "voltage", "speed", "thrust", "measured_thrust"

# Channels recorded by a simulation (index = position in the channel vector of the kernel).
CHANNELS = (
    "command",
    "voltage",
    "motor_speed",
    "prop_speed",
    "thrust",
    "measured_thrust",
    "torque",
    "current",
)
CH = {name: i for i, name in enumerate(CHANNELS)}

# Block kind codes understood by the compiled kernel.
K_ESC = 1
K_FIRST_ORDER_MOTOR = 2
K_DC_MOTOR = 3
K_TUNNEL = 4
K_QUADRATIC = 5
K_POLYNOMIAL = 6
K_DEADZONE = 7
K_TABLE = 8
K_ZERO_ORDER = 9
K_FIRST_ORDER = 10
K_YOERGER = 11
K_BESSA = 12
K_LOAD_CELL = 13
K_HEALEY = 14

_SIGNAL_CHANNEL = {
    COMMAND: "command",
    VOLTAGE: "voltage",
    SPEED: "prop_speed",
    THRUST: "thrust",
    MEASURED: "measured_thrust",
}


class ParameterError(ValueError):
    """A block parameter is outside its physical range; the message names the parameter.

    ``param`` holds the parameter's name (for key paths in model-file errors)."""

    def __init__(self, message: str, param: str | None = None):
        super().__init__(message)
        self.param = param


def _positive(block: str, **values: float) -> None:
    for name, v in values.items():
        if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v) and v > 0):
            raise ParameterError(f"{block}.{name} must be a positive finite number, got {v!r}", name)


def _non_negative(block: str, **values: float) -> None:
    for name, v in values.items():
        if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v) and v >= 0):
            raise ParameterError(f"{block}.{name} must be a finite number >= 0, got {v!r}", name)


def _finite(block: str, **values: float) -> None:
    for name, v in values.items():
        if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v)):
            raise ParameterError(f"{block}.{name} must be a finite number, got {v!r}", name)


@dataclass(frozen=True)
class Block:
    """Base of every block: a frozen parameter record with a kind code for the kernel."""

    KIND: ClassVar[int] = 0
    TYPE: ClassVar[str] = ""
    INPUTS: ClassVar[tuple[str, ...]] = ()
    N_STATES: ClassVar[int] = 0

    @property
    def n_states(self) -> int:
        return self.N_STATES

    def output_kind(self, input_kind: str) -> str:  # pragma: no cover - overridden
        raise NotImplementedError

    def params_array(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def extra_channels(self) -> tuple[str, ...]:
        """Channels the block writes besides its output signal."""
        return ()

    def steady_output(self, x: np.ndarray) -> np.ndarray | None:
        """The block's output at rest under each constant input in ``x`` (vectorised), in closed
        form; ``None`` when it has none (the chain then finds the equilibrium by simulation)."""
        return None

    def to_dict(self) -> dict:
        """Plain-data form used by model files (``type`` plus the parameters)."""
        out: dict = {"type": self.TYPE}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, tuple):
                v = [list(x) if isinstance(x, tuple) else x for x in v]
            out[f.name] = v
        return out

    def replace(self, **changes) -> Block:
        """A copy with some parameters changed (validated again)."""
        return replace(self, **changes)


# --------------------------------------------------------------------------------------------
# Driver
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ESC(Block):
    """Electronic speed controller: command → motor voltage (Laidani et al. eq. 1).

    ``V = a_fwd·cmd + b_fwd`` above the dead zone, ``V = a_rev·cmd + b_rev`` below it, 0 inside
    ``[deadzone_low, deadzone_high]``; the command is first clipped to
    ``[saturation_low, saturation_high]`` (saturation) and |V| never exceeds ``supply_voltage``.
    An optional duty curvature β per direction bends the linear duty ``s = |V_lin|/V_supply``:
    ``V = V_lin (1 + β (s − 1))`` (β = 0: linear; identified on T200 sheets, see
    :mod:`uuvid.identify.thruster.physical`).
    The command unit (``pwm_us``, ``duty`` or ``volts``) is recorded for reports.
    ``follows_supply`` False marks a command stage that is not a voltage source (the unit-gain
    ``command − neutral`` offset in front of a map fitted on the command): its output is the
    command, measured at the bench's supply, so :meth:`with_supply` leaves it as it is.
    """

    KIND: ClassVar[int] = K_ESC
    TYPE: ClassVar[str] = "esc"
    INPUTS: ClassVar[tuple[str, ...]] = (COMMAND,)

    a_fwd: float = 1.0
    b_fwd: float = 0.0
    a_rev: float = 1.0
    b_rev: float = 0.0
    neutral: float = 0.0
    deadzone_low: float = 0.0
    deadzone_high: float = 0.0
    saturation_low: float = -math.inf
    saturation_high: float = math.inf
    supply_voltage: float = 12.0
    command_unit: str = "volts"
    curvature_fwd: float = 0.0
    curvature_rev: float = 0.0
    follows_supply: bool = True

    def __post_init__(self):
        _finite(
            "ESC",
            a_fwd=self.a_fwd,
            b_fwd=self.b_fwd,
            a_rev=self.a_rev,
            b_rev=self.b_rev,
            neutral=self.neutral,
            deadzone_low=self.deadzone_low,
            deadzone_high=self.deadzone_high,
        )
        _positive("ESC", supply_voltage=self.supply_voltage)
        for name in ("curvature_fwd", "curvature_rev"):
            b = getattr(self, name)
            if not (math.isfinite(b) and -1.0 <= b <= 1.0):
                raise ParameterError(f"ESC.{name} must lie in [-1, 1] (monotone duty), got {b!r}", name)
        if not self.deadzone_low <= self.neutral <= self.deadzone_high:
            raise ParameterError(
                f"ESC dead zone [{self.deadzone_low}, {self.deadzone_high}] must contain the "
                f"neutral command {self.neutral}"
            )
        if not self.saturation_low < self.deadzone_low or not self.deadzone_high < self.saturation_high:
            if not (self.saturation_low <= self.deadzone_low and self.deadzone_high <= self.saturation_high):
                raise ParameterError("ESC saturation limits must lie outside the dead zone")
        if self.command_unit not in ("pwm_us", "duty", "volts"):
            raise ParameterError(f"ESC.command_unit must be pwm_us, duty or volts, got {self.command_unit!r}")

    @classmethod
    def from_range(
        cls,
        neutral: float,
        deadband: float,
        full_low: float,
        full_high: float,
        supply_voltage: float,
        command_unit: str = "pwm_us",
    ) -> ESC:
        """Linear ESC reaching ±``supply_voltage`` at ``full_high``/``full_low`` and saturating there.

        The dead zone is ``neutral ± deadband/2``; voltage rises linearly from 0 at its edge.
        """
        lo, hi = neutral - deadband / 2.0, neutral + deadband / 2.0
        if not (full_low < lo and hi < full_high):
            raise ParameterError("ESC.from_range: full-command points must lie outside the dead band")
        a_f = supply_voltage / (full_high - hi)
        a_r = supply_voltage / (lo - full_low)
        return cls(
            a_fwd=a_f,
            b_fwd=-a_f * hi,
            a_rev=a_r,
            b_rev=-a_r * lo,
            neutral=neutral,
            deadzone_low=lo,
            deadzone_high=hi,
            saturation_low=full_low,
            saturation_high=full_high,
            supply_voltage=supply_voltage,
            command_unit=command_unit,
        )

    def with_supply(self, supply_voltage: float) -> ESC:
        """Same duty-cycle map at another supply voltage (V = duty × supply); an ESC that does
        not follow the supply (``follows_supply`` False) is returned unchanged."""
        if not self.follows_supply:
            return self
        k = supply_voltage / self.supply_voltage
        return replace(
            self,
            a_fwd=self.a_fwd * k,
            b_fwd=self.b_fwd * k,
            a_rev=self.a_rev * k,
            b_rev=self.b_rev * k,
            supply_voltage=supply_voltage,
        )

    def output_kind(self, input_kind):
        return VOLTAGE

    def params_array(self):
        return np.array(
            [
                self.a_fwd,
                self.b_fwd,
                self.a_rev,
                self.b_rev,
                self.deadzone_low,
                self.deadzone_high,
                self.saturation_low,
                self.saturation_high,
                self.supply_voltage,
                self.curvature_fwd,
                self.curvature_rev,
            ],
            dtype=np.float64,
        )

    def steady_output(self, x):
        return self.voltage(x)

    def voltage(self, command):
        """Vectorised ``V(cmd)`` (same law as the kernel)."""
        c = np.clip(np.asarray(command, dtype=float), self.saturation_low, self.saturation_high)
        v = np.where(
            c > self.deadzone_high,
            self.a_fwd * c + self.b_fwd,
            np.where(c < self.deadzone_low, self.a_rev * c + self.b_rev, 0.0),
        )
        beta = np.where(c > self.deadzone_high, self.curvature_fwd, self.curvature_rev)
        v = v * (1.0 + beta * (np.abs(v) / self.supply_voltage - 1.0))
        return np.clip(v, -self.supply_voltage, self.supply_voltage)


# --------------------------------------------------------------------------------------------
# Motors
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FirstOrderMotor(Block):
    """First-order speed model ``Ω(s)/V(s) = K_m/(1 + τ s)`` (Laidani et al. eq. 3).

    Driven by a held (zero-order-hold) voltage it is advanced exactly:
    ``Ω_{k+1} = e^{−h/τ} Ω_k + (1 − e^{−h/τ}) K_m V_k``.
    """

    KIND: ClassVar[int] = K_FIRST_ORDER_MOTOR
    TYPE: ClassVar[str] = "first_order_motor"
    INPUTS: ClassVar[tuple[str, ...]] = (VOLTAGE,)
    N_STATES: ClassVar[int] = 1

    gain: float = 131.3016  # K_m, rad/s per V
    time_constant: float = 0.01021  # τ, s

    def __post_init__(self):
        _positive("FirstOrderMotor", gain=self.gain, time_constant=self.time_constant)

    def output_kind(self, input_kind):
        return SPEED

    def extra_channels(self):
        return ("motor_speed",)

    def steady_output(self, x):
        """At rest ``Ω = K_m V`` (the lag has unit DC gain)."""
        return self.gain * np.asarray(x, dtype=float)

    def params_array(self):
        return np.array([self.gain, self.time_constant], dtype=np.float64)


@dataclass(frozen=True)
class DCMotor(Block):
    """Permanent-magnet DC motor with a gear driving a propeller of torque ``K_Q Ω_p|Ω_p|``.

    McLean 1991 eqs. 2.1–2.5 (inductance optional):
        ``L di/dt = V − R i − K_G ω_m``  (``L = 0``: ``i = (V − K_G ω_m)/R``)
        ``(J_M + J_P/N²) ω̇_m = K_T i − (C_M + C_P/N²) ω_m − Q/N − T_c sgn(ω_m)``,  ``Ω_p = ω_m/N``.
    Coulomb friction ``T_c`` (at the motor shaft) opposes motion and holds the shaft still while the
    driving torque is below it (Karnopp stick–slip); McLean's "5 V offset" is ``T_c = K_T·5/R``.
    """

    KIND: ClassVar[int] = K_DC_MOTOR
    TYPE: ClassVar[str] = "dc_motor"
    INPUTS: ClassVar[tuple[str, ...]] = (VOLTAGE,)

    torque_constant: float = 0.0292  # K_T, N·m/A
    back_emf_constant: float = 0.0292  # K_G, V·s/rad
    resistance: float = 4.06  # R, Ω
    inductance: float = 0.0  # L, H (0: electrical dynamics neglected)
    motor_inertia: float = 3.79e-6  # J_M, kg·m²
    propeller_inertia: float = 0.0  # J_P, kg·m² (at the propeller shaft)
    motor_viscous: float = 0.0  # C_M, N·m·s/rad
    propeller_viscous: float = 0.0  # C_P, N·m·s/rad (at the propeller shaft)
    coulomb_torque: float = 0.0  # T_c, N·m at the motor shaft
    gear_ratio: float = 1.0  # N = ω_m/ω_p
    torque_coefficient: float = 0.0  # K_Q, N·m·s²/rad², propeller torque K_Q Ω_p|Ω_p|
    torque_coefficient_rev: float | None = None  # K_Q for Ω_p < 0 (None: same as forward)

    def __post_init__(self):
        _positive(
            "DCMotor",
            torque_constant=self.torque_constant,
            back_emf_constant=self.back_emf_constant,
            resistance=self.resistance,
            motor_inertia=self.motor_inertia,
            gear_ratio=self.gear_ratio,
        )
        _non_negative(
            "DCMotor",
            inductance=self.inductance,
            propeller_inertia=self.propeller_inertia,
            motor_viscous=self.motor_viscous,
            propeller_viscous=self.propeller_viscous,
            coulomb_torque=self.coulomb_torque,
            torque_coefficient=self.torque_coefficient,
        )
        if self.torque_coefficient_rev is not None:
            _non_negative("DCMotor", torque_coefficient_rev=self.torque_coefficient_rev)

    @property
    def n_states(self) -> int:
        return 2 if self.inductance > 0 else 1

    def output_kind(self, input_kind):
        return SPEED

    def extra_channels(self):
        return ("motor_speed", "torque", "current")

    def motor_params(self) -> list[float]:
        return [
            self.torque_constant,
            self.back_emf_constant,
            self.resistance,
            self.inductance,
            self.motor_inertia,
            self.propeller_inertia,
            self.motor_viscous,
            self.propeller_viscous,
            self.coulomb_torque,
            self.gear_ratio,
        ]

    def params_array(self):
        kq_rev = (
            self.torque_coefficient if self.torque_coefficient_rev is None else self.torque_coefficient_rev
        )
        return np.array(self.motor_params() + [self.torque_coefficient, kq_rev], dtype=np.float64)

    @property
    def electrical_time_constant(self) -> float:
        return self.inductance / self.resistance

    @property
    def mechanical_time_constant(self) -> float:
        """``τ_m = J_M R/(K_T K_G)`` (McLean: 0.01808 s for the Pittman 9514)."""
        return self.motor_inertia * self.resistance / (self.torque_constant * self.back_emf_constant)


def water_column_mass(density: float, area: float, length: float, added_mass: float = 0.0) -> float:
    """``ρ A L (1 + K_a)``, kg: the water a propeller accelerates (McLean 1991 eq. 2.12's fluid
    inertia; Healey et al. 1995's control-volume mass ``ρ A L γ`` with ``γ = 1 + K_a``)."""
    return density * area * length * (1.0 + added_mass)


@dataclass(frozen=True)
class TunnelThruster(Block):
    """McLean's tunnel thruster: DC motor + gear + the water column in the tunnel.

    Volumetric flow ``Q = η p A ω_p``; effective fluid length ``L(1 + K_a)``; ``P_e = η p``.
    Thrust (unsteady momentum, eq. 2.12):
        ``F = ρ A L(1+K_a) P_e ω̇_p + ρ A P_e² (β_o − β_i) ω_p|ω_p|``
    Propeller torque (unsteady energy, eqs. 2.14–2.16):
        ``Q_h = β ρ A L(1+K_a) P_e² ω̇_p + ½ ρ A (α_o − α_i) P_e³ ω_p|ω_p|``
    The unsteady torque term is water inertia reflected to the motor, so the motor sees
    ``J = J_M + (J_P + β ρ A L(1+K_a) P_e²)/N²``.  With ``P_e = 0`` the water does nothing.
    """

    KIND: ClassVar[int] = K_TUNNEL
    TYPE: ClassVar[str] = "tunnel_thruster"
    INPUTS: ClassVar[tuple[str, ...]] = (VOLTAGE,)

    motor: DCMotor = field(default_factory=DCMotor)
    water_density: float = 1000.0  # ρ, kg/m³
    tunnel_area: float = 0.00477  # A, m²
    tunnel_length: float = 0.2667  # L, m
    added_mass_coefficient: float = 0.25  # K_a
    propeller_efficiency: float = 0.75  # η
    pitch: float = 0.02198  # p, m/rad
    profile_factor: float = 1.5  # β (momentum / kinetic-energy profile factor)
    energy_correction: float = 3.0  # α_o − α_i
    momentum_correction: float = 0.185  # β_o − β_i

    def __post_init__(self):
        if not isinstance(self.motor, DCMotor):
            raise ParameterError("TunnelThruster.motor must be a DCMotor")
        if self.motor.torque_coefficient != 0.0 or self.motor.torque_coefficient_rev:
            raise ParameterError(
                "TunnelThruster.motor.torque_coefficient must be 0: the tunnel "
                "model supplies the propeller torque"
            )
        _positive(
            "TunnelThruster",
            water_density=self.water_density,
            tunnel_area=self.tunnel_area,
            tunnel_length=self.tunnel_length,
        )
        _non_negative(
            "TunnelThruster",
            added_mass_coefficient=self.added_mass_coefficient,
            propeller_efficiency=self.propeller_efficiency,
            pitch=self.pitch,
            profile_factor=self.profile_factor,
            energy_correction=self.energy_correction,
            momentum_correction=self.momentum_correction,
        )
        if self.propeller_efficiency > 1.0:
            raise ParameterError(
                f"TunnelThruster.propeller_efficiency must be <= 1, got {self.propeller_efficiency}",
                "propeller_efficiency",
            )

    @property
    def effective_pitch(self) -> float:
        """``P_e = η p`` (m/rad)."""
        return self.propeller_efficiency * self.pitch

    @property
    def fluid_mass(self) -> float:
        """``ρ A L (1 + K_a)``, kg — the water the propeller accelerates."""
        return water_column_mass(
            self.water_density, self.tunnel_area, self.tunnel_length, self.added_mass_coefficient
        )

    @property
    def n_states(self) -> int:
        return self.motor.n_states

    def output_kind(self, input_kind):
        return THRUST

    def extra_channels(self):
        return ("motor_speed", "prop_speed", "torque", "current")

    def params_array(self):
        return np.array(
            self.motor.motor_params()
            + [
                self.water_density,
                self.tunnel_area,
                self.tunnel_length,
                self.added_mass_coefficient,
                self.effective_pitch,
                self.profile_factor,
                self.energy_correction,
                self.momentum_correction,
            ],
            dtype=np.float64,
        )

    def steady_state(self, voltage: float) -> dict:
        """Steady speed and thrust at a constant voltage (algebraic solution of the ODE)."""
        m = self.motor
        pe = self.effective_pitch
        n = m.gear_ratio
        c_q = 0.5 * self.water_density * self.tunnel_area * self.energy_correction * pe**3
        c_v = m.motor_viscous + m.propeller_viscous / n**2
        # K_T (V − K_G w)/R − c_v w − c_q (w/N)² / N − T_c = 0 for w > 0 (motor speed)
        drive = m.torque_constant * abs(voltage) / m.resistance - m.coulomb_torque
        if drive <= 0:
            return {"motor_speed": 0.0, "prop_speed": 0.0, "thrust": 0.0}
        a = c_q / n**3
        b = m.torque_constant * m.back_emf_constant / m.resistance + c_v
        w = drive / b if a == 0 else (-b + math.sqrt(b * b + 4 * a * drive)) / (2 * a)
        w = math.copysign(w, voltage)
        wp = w / n
        f = self.water_density * self.tunnel_area * pe**2 * self.momentum_correction * wp * abs(wp)
        return {"motor_speed": w, "prop_speed": wp, "thrust": f}


# --------------------------------------------------------------------------------------------
# Steady maps (conversion functions)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class QuadraticMap(Block):
    """``T = k_pos x|x|`` for ``x ≥ 0`` and ``k_neg x|x|`` for ``x < 0``.

    With speed input this is ``T = K_T Ω|Ω|`` (and ``Q = K_Q Ω|Ω|`` is recorded as torque);
    with voltage input it is Caccia et al.'s ``T = c_V V|V|`` (ROMEO: 1.02 and 1.09 N/V²).
    UUV Simulator's ``Basic`` conversion is ``k_pos = k_neg = rotorConstant``.
    """

    KIND: ClassVar[int] = K_QUADRATIC
    TYPE: ClassVar[str] = "quadratic"
    INPUTS: ClassVar[tuple[str, ...]] = (SPEED, VOLTAGE, COMMAND)

    k_pos: float = 1.0
    k_neg: float | None = None  # None: same as k_pos (UUV Simulator's single rotorConstant)
    torque_pos: float = 0.0
    torque_neg: float | None = None  # None: same as torque_pos

    def __post_init__(self):
        if self.k_neg is None:
            object.__setattr__(self, "k_neg", self.k_pos)
        if self.torque_neg is None:
            object.__setattr__(self, "torque_neg", self.torque_pos)
        _non_negative(
            "QuadraticMap",
            k_pos=self.k_pos,
            k_neg=self.k_neg,
            torque_pos=self.torque_pos,
            torque_neg=self.torque_neg,
        )

    @classmethod
    def basic(cls, rotor_constant: float) -> QuadraticMap:
        """UUV Simulator ``Basic`` conversion: ``T = c·x|x|``."""
        return cls(k_pos=rotor_constant, k_neg=rotor_constant)

    def output_kind(self, input_kind):
        return THRUST

    def extra_channels(self):
        return ("torque",)

    def params_array(self):
        return np.array([self.k_pos, self.k_neg, self.torque_pos, self.torque_neg], dtype=np.float64)

    def thrust(self, x):
        x = np.asarray(x, dtype=float)
        return np.where(x >= 0, self.k_pos, self.k_neg) * (x * np.abs(x))

    def steady_output(self, x):
        return self.thrust(x)


@dataclass(frozen=True)
class PolynomialMap(Block):
    """Per-direction polynomial thrust map (Laidani et al. Table 2).

    ``T = +P_fwd(|x|)`` for ``x > 0``, ``T = −P_rev(|x|)`` for ``x < 0``, ``T = 0`` at ``x = 0``;
    coefficients highest power first (``numpy.polyval`` order), ``x`` = |Ω| in rad/s.
    """

    KIND: ClassVar[int] = K_POLYNOMIAL
    TYPE: ClassVar[str] = "polynomial"
    INPUTS: ClassVar[tuple[str, ...]] = (SPEED, VOLTAGE, COMMAND)

    forward: tuple[float, ...] = (0.0,)
    reverse: tuple[float, ...] = (0.0,)

    def __post_init__(self):
        for name in ("forward", "reverse"):
            c = tuple(float(v) for v in getattr(self, name))
            if len(c) == 0 or not all(math.isfinite(v) for v in c):
                raise ParameterError(f"PolynomialMap.{name} needs at least one finite coefficient", name)
            object.__setattr__(self, name, c)

    def output_kind(self, input_kind):
        return THRUST

    def params_array(self):
        return np.array(
            [len(self.forward), len(self.reverse), *self.forward, *self.reverse], dtype=np.float64
        )

    def thrust(self, x):
        x = np.asarray(x, dtype=float)
        ax = np.abs(x)
        return np.where(
            x > 0, np.polyval(self.forward, ax), np.where(x < 0, -np.polyval(self.reverse, ax), 0.0)
        )

    def steady_output(self, x):
        return self.thrust(x)


@dataclass(frozen=True)
class DeadZoneMap(Block):
    """UUV Simulator ``Bessa`` conversion (asymmetric dead zone), Bessa et al. 2005.

    With ``b = x|x|``: ``T = c_L (b − δ_L)`` for ``b ≤ δ_L``; ``T = c_R (b − δ_R)`` for ``b ≥ δ_R``;
    else 0 (continuous at the dead-zone edges, as in UUV Simulator's ThrusterConversionFcn.cc).
    """

    KIND: ClassVar[int] = K_DEADZONE
    TYPE: ClassVar[str] = "deadzone"
    INPUTS: ClassVar[tuple[str, ...]] = (SPEED, VOLTAGE, COMMAND)

    rotor_constant_l: float = 1.0
    rotor_constant_r: float = 1.0
    delta_l: float = 0.0
    delta_r: float = 0.0

    def __post_init__(self):
        _non_negative(
            "DeadZoneMap", rotor_constant_l=self.rotor_constant_l, rotor_constant_r=self.rotor_constant_r
        )
        _finite("DeadZoneMap", delta_l=self.delta_l, delta_r=self.delta_r)
        if self.delta_l > self.delta_r:
            raise ParameterError(
                f"DeadZoneMap.delta_l ({self.delta_l}) must be <= delta_r ({self.delta_r})", "delta_l"
            )

    def output_kind(self, input_kind):
        return THRUST

    def params_array(self):
        return np.array(
            [self.rotor_constant_l, self.rotor_constant_r, self.delta_l, self.delta_r], dtype=np.float64
        )

    def thrust(self, x):
        x = np.asarray(x, dtype=float)
        xx = x * np.abs(x)
        return np.where(
            xx <= self.delta_l,
            self.rotor_constant_l * (xx - self.delta_l),
            np.where(xx >= self.delta_r, self.rotor_constant_r * (xx - self.delta_r), 0.0),
        )

    def steady_output(self, x):
        return self.thrust(x)


@dataclass(frozen=True)
class TableMap(Block):
    """UUV Simulator ``LinearInterp``: piecewise-linear table, end values held outside it."""

    KIND: ClassVar[int] = K_TABLE
    TYPE: ClassVar[str] = "table"
    INPUTS: ClassVar[tuple[str, ...]] = (SPEED, VOLTAGE, COMMAND)

    input_values: tuple[float, ...] = (0.0, 1.0)
    output_values: tuple[float, ...] = (0.0, 0.0)

    def __post_init__(self):
        xi = tuple(float(v) for v in self.input_values)
        yi = tuple(float(v) for v in self.output_values)
        if len(xi) != len(yi):
            raise ParameterError(
                f"TableMap: input_values has {len(xi)} entries but output_values has {len(yi)}"
            )
        if len(xi) < 2:
            raise ParameterError("TableMap needs at least two points")
        if not all(math.isfinite(v) for v in xi + yi):
            raise ParameterError("TableMap values must be finite")
        for k in range(1, len(xi)):
            if not xi[k] > xi[k - 1]:
                raise ParameterError(
                    f"TableMap.input_values must be strictly increasing; entry {k} "
                    f"({xi[k]}) is not greater than entry {k - 1} ({xi[k - 1]})",
                    "input_values",
                )
        object.__setattr__(self, "input_values", xi)
        object.__setattr__(self, "output_values", yi)

    def output_kind(self, input_kind):
        return THRUST

    def params_array(self):
        return np.array([len(self.input_values), *self.input_values, *self.output_values], dtype=np.float64)

    def thrust(self, x):
        return np.interp(np.asarray(x, dtype=float), self.input_values, self.output_values)

    def steady_output(self, x):
        return self.thrust(x)


# --------------------------------------------------------------------------------------------
# UUV Simulator dynamics (command → rotor state), integrated as ODEs
# --------------------------------------------------------------------------------------------
def _dynamic_output(input_kind: str) -> str:
    return THRUST if input_kind in (THRUST, MEASURED) else SPEED


@dataclass(frozen=True)
class ZeroOrder(Block):
    """UUV Simulator ``ZeroOrder``: the state follows the command instantly."""

    KIND: ClassVar[int] = K_ZERO_ORDER
    TYPE: ClassVar[str] = "zero_order"
    INPUTS: ClassVar[tuple[str, ...]] = (COMMAND, VOLTAGE, SPEED, THRUST)

    def output_kind(self, input_kind):
        return _dynamic_output(input_kind)

    def steady_output(self, x):
        return np.asarray(x, dtype=float)

    def params_array(self):
        return np.zeros(0, dtype=np.float64)


@dataclass(frozen=True)
class FirstOrder(Block):
    """UUV Simulator ``FirstOrder(τ)``: ``ẋ = (u − x)/τ``, advanced exactly under a held input."""

    KIND: ClassVar[int] = K_FIRST_ORDER
    TYPE: ClassVar[str] = "first_order"
    INPUTS: ClassVar[tuple[str, ...]] = (COMMAND, VOLTAGE, SPEED, THRUST)
    N_STATES: ClassVar[int] = 1

    time_constant: float = 0.01

    def __post_init__(self):
        _positive("FirstOrder", time_constant=self.time_constant)

    def output_kind(self, input_kind):
        return _dynamic_output(input_kind)

    def steady_output(self, x):
        """At rest ``x = u`` (unit DC gain)."""
        return np.asarray(x, dtype=float)

    def params_array(self):
        return np.array([self.time_constant], dtype=np.float64)


@dataclass(frozen=True)
class Yoerger(Block):
    """UUV Simulator ``Yoerger(α, β)`` (Yoerger et al. 1990): ``ẋ = β u − α x|x|``."""

    KIND: ClassVar[int] = K_YOERGER
    TYPE: ClassVar[str] = "yoerger"
    INPUTS: ClassVar[tuple[str, ...]] = (COMMAND, VOLTAGE, SPEED, THRUST)
    N_STATES: ClassVar[int] = 1

    alpha: float = 1.0
    beta: float = 1.0

    def __post_init__(self):
        _positive("Yoerger", alpha=self.alpha, beta=self.beta)

    def output_kind(self, input_kind):
        return _dynamic_output(input_kind)

    def steady_output(self, x):
        """At rest ``α x|x| = β u``: ``x = sgn(u) √(β|u|/α)`` (the only equilibrium, reached from
        any start since the right-hand side decreases in ``x``)."""
        u = np.asarray(x, dtype=float)
        return np.sign(u) * np.sqrt(self.beta * np.abs(u) / self.alpha)

    def params_array(self):
        return np.array([self.alpha, self.beta], dtype=np.float64)


@dataclass(frozen=True)
class BessaDynamics(Block):
    """UUV Simulator ``Bessa(Jmsp, Kv1, Kv2, Kt, Rm)`` (Bessa et al. 2005):

    ``Jmsp ẋ = u K_t/R_m − K_v1 x − K_v2 x|x|``.
    """

    KIND: ClassVar[int] = K_BESSA
    TYPE: ClassVar[str] = "bessa"
    INPUTS: ClassVar[tuple[str, ...]] = (COMMAND, VOLTAGE, SPEED, THRUST)
    N_STATES: ClassVar[int] = 1

    jmsp: float = 1.0
    kv1: float = 0.0
    kv2: float = 0.0
    kt: float = 1.0
    rm: float = 1.0

    def __post_init__(self):
        _positive("BessaDynamics", jmsp=self.jmsp, kt=self.kt, rm=self.rm)
        _non_negative("BessaDynamics", kv1=self.kv1, kv2=self.kv2)
        if self.kv1 == 0 and self.kv2 == 0:
            raise ParameterError("BessaDynamics needs kv1 > 0 or kv2 > 0 (else the speed is unbounded)")

    def output_kind(self, input_kind):
        return _dynamic_output(input_kind)

    def steady_output(self, x):
        """At rest ``K_v2 x|x| + K_v1 x = g = u K_t/R_m``:
        ``x = sgn(g)·2|g|/(K_v1 + √(K_v1² + 4 K_v2 |g|))`` (the only equilibrium; the form has no
        cancellation and holds for ``K_v2 = 0``)."""
        g = np.asarray(x, dtype=float) * self.kt / self.rm
        a = np.abs(g)
        den = self.kv1 + np.sqrt(self.kv1 * self.kv1 + 4.0 * self.kv2 * a)
        mag = np.divide(2.0 * a, den, out=np.zeros_like(a), where=a > 0)
        return np.sign(g) * mag

    def params_array(self):
        return np.array([self.jmsp, self.kv1, self.kv2, self.kt, self.rm], dtype=np.float64)


# --------------------------------------------------------------------------------------------
# Test rig
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LoadCell(Block):
    """Load cell + box of the test rig: ``F_out/F = ω_n²/(s² + 2ζω_n s + ω_n²)`` (McLean block 9).

    McLean's rig: ``1935/(s² + 14.1 s + 1935)``, i.e. ω_n = 43.99 rad/s, ζ = 0.160.
    """

    KIND: ClassVar[int] = K_LOAD_CELL
    TYPE: ClassVar[str] = "load_cell"
    INPUTS: ClassVar[tuple[str, ...]] = (THRUST,)
    N_STATES: ClassVar[int] = 2

    natural_frequency: float = math.sqrt(1935.0)  # ω_n, rad/s
    damping_ratio: float = 14.1 / (2.0 * math.sqrt(1935.0))  # ζ

    def __post_init__(self):
        _positive("LoadCell", natural_frequency=self.natural_frequency, damping_ratio=self.damping_ratio)

    @classmethod
    def from_polynomial(cls, a1: float, a0: float) -> LoadCell:
        """From ``a0/(s² + a1 s + a0)``."""
        wn = math.sqrt(a0)
        return cls(natural_frequency=wn, damping_ratio=a1 / (2 * wn))

    def output_kind(self, input_kind):
        return MEASURED

    def steady_output(self, x):
        """At rest ``F_out = F`` (unit DC gain, stable for ω_n, ζ > 0)."""
        return np.asarray(x, dtype=float)

    def params_array(self):
        return np.array([self.natural_frequency, self.damping_ratio], dtype=np.float64)


# --------------------------------------------------------------------------------------------
# Driver with dead band, and Healey's two-state thruster
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Driver(Block):
    """ESC / analog driver in front of a motor model: offset, dead band per direction, gain, limit.

    With ``c = cmd − offset``:
        ``V = g_fwd (c − d_fwd)`` for ``c > d_fwd``; ``V = g_rev (c + d_rev)`` for ``c < −d_rev``;
        ``V = 0`` inside the dead band; ``|V| ≤ limit`` (output saturation).
    This is Laidani et al.'s ESC law (eq. 1, dead zone and saturation) written with the
    parameters a step or ramp record can separate: the two thresholds ``offset + d_fwd`` and
    ``offset − d_rev`` (the offset alone is not identifiable next to two dead bands — keep it
    fixed at the neutral command) and the gains (one of which is redundant with a motor gain).
    It runs on the ESC kernel (``KIND = K_ESC``), so chains with it compile as any other.
    """

    KIND: ClassVar[int] = K_ESC
    TYPE: ClassVar[str] = "driver"
    INPUTS: ClassVar[tuple[str, ...]] = (COMMAND, VOLTAGE)

    deadband_fwd: float = 0.0
    deadband_rev: float = 0.0
    offset: float = 0.0
    gain_fwd: float = 1.0
    gain_rev: float = 1.0
    limit: float = math.inf

    def __post_init__(self):
        _finite("Driver", offset=self.offset)
        _non_negative("Driver", deadband_fwd=self.deadband_fwd, deadband_rev=self.deadband_rev)
        _positive("Driver", gain_fwd=self.gain_fwd, gain_rev=self.gain_rev)
        if not (self.limit > 0):
            raise ParameterError(f"Driver.limit must be positive, got {self.limit!r}", "limit")

    def output_kind(self, input_kind):
        return VOLTAGE

    def params_array(self):
        hi = self.offset + self.deadband_fwd
        lo = self.offset - self.deadband_rev
        return np.array(
            [self.gain_fwd, -self.gain_fwd * hi, self.gain_rev, -self.gain_rev * lo, lo, hi,
             -math.inf, math.inf, self.limit, 0.0, 0.0],
            dtype=np.float64,
        )

    def steady_output(self, x):
        return self.voltage(x)

    def voltage(self, command):
        """Vectorised ``V(cmd)`` (same law as the kernel)."""
        c = np.asarray(command, dtype=float) - self.offset
        v = np.where(c > self.deadband_fwd, self.gain_fwd * (c - self.deadband_fwd),
                     np.where(c < -self.deadband_rev, self.gain_rev * (c + self.deadband_rev), 0.0))
        return np.clip(v, -self.limit, self.limit)


@dataclass(frozen=True)
class HealeyThruster(Block):
    """Two-state thruster: shaft speed ``Ω`` and axial inflow ``u_a`` of a control volume.

    Healey, Rock, Cody, Miles & Brown (1995), "Toward an improved understanding of thruster
    dynamics for underwater vehicles", IEEE JOE 20(4); Bachmayer, Whitcomb & Grosenbaugh (2000),
    IEEE JOE 25(1) (same two states, four quadrants):
        ``J Ω̇ = K_u V − K_n Ω − Q``                      (motor, driven by the voltage V)
        ``m_f u̇_a = T − d_f u_a|u_a|``                   (axial momentum of the control volume,
                                                           ``m_f = ρ A L γ``, ``d_f = ρ A Δβ``)
        ``T = k_t Ω|Ω| − k_a |Ω| u_a``,  ``Q = k_q Ω|Ω| − k_qa |Ω| u_a``
    — the blade-lift thrust and torque with the lift linear in the angle of attack (small-angle
    form of Healey's sinusoidal lift curve).  ``k_t`` may differ per direction.  At a step the
    flow lags the shaft, so thrust overshoots its steady value ``d_f u_a²``.  The water mass is
    :func:`water_column_mass`, the same term as McLean's tunnel water (``TunnelThruster``).

    Identifiable: dividing the motor equation by ``J`` leaves ``K_u/J, K_n/J, k_q/J, k_qa/J``;
    scaling the unmeasured ``u_a`` by ``c`` maps ``(k_a, k_qa, m_f, d_f)`` to
    ``(k_a/c, k_qa/c, m_f/c, d_f/c²)`` — so ``J`` and ``m_f`` are fixed (datasheet, geometry)
    and the combinations ``k_a/m_f`` and ``d_f/m_f²`` are what the data determine.
    """

    KIND: ClassVar[int] = K_HEALEY
    TYPE: ClassVar[str] = "healey"
    INPUTS: ClassVar[tuple[str, ...]] = (VOLTAGE, COMMAND)
    N_STATES: ClassVar[int] = 2

    inertia: float = 1e-4  # J, kg·m²
    drive_gain: float = 0.04  # K_u, N·m/V
    viscous: float = 5e-4  # K_n, N·m·s/rad
    torque_coefficient: float = 4.5e-6  # k_q, N·m·s²/rad²
    torque_inflow: float = 0.0  # k_qa, N·m·s²/(rad·m)
    thrust_coefficient: float = 6e-4  # k_t forward, N·s²/rad²
    thrust_coefficient_rev: float | None = None  # k_t for Ω < 0 (None: same)
    inflow_coefficient: float = 0.02  # k_a, N·s²/(rad·m)
    fluid_mass: float = 1.0  # m_f = ρ A L γ, kg
    flow_damping: float = 4.5  # d_f = ρ A Δβ, kg/m

    def __post_init__(self):
        _positive("HealeyThruster", inertia=self.inertia, drive_gain=self.drive_gain,
                  fluid_mass=self.fluid_mass, flow_damping=self.flow_damping,
                  thrust_coefficient=self.thrust_coefficient)
        _non_negative("HealeyThruster", viscous=self.viscous,
                      torque_coefficient=self.torque_coefficient, torque_inflow=self.torque_inflow,
                      inflow_coefficient=self.inflow_coefficient)
        if self.thrust_coefficient_rev is not None:
            _positive("HealeyThruster", thrust_coefficient_rev=self.thrust_coefficient_rev)
        if self.viscous == 0 and self.torque_coefficient == 0:
            raise ParameterError("HealeyThruster needs viscous > 0 or torque_coefficient > 0 "
                                 "(else the speed is unbounded)", "viscous")

    @classmethod
    def from_geometry(cls, area: float, length: float, *, density: float = 1000.0,
                      added_mass: float = 0.0, momentum_correction: float = 1.0, **kw):
        """Fluid mass and damping from the control volume: ``m_f = ρ A L (1 + K_a)``,
        ``d_f = ρ A Δβ``."""
        return cls(fluid_mass=water_column_mass(density, area, length, added_mass),
                   flow_damping=density * area * momentum_correction, **kw)

    def output_kind(self, input_kind):
        return THRUST

    def extra_channels(self):
        return ("motor_speed", "prop_speed", "torque")

    def params_array(self):
        kr = self.thrust_coefficient if self.thrust_coefficient_rev is None else self.thrust_coefficient_rev
        return np.array(
            [self.inertia, self.drive_gain, self.viscous, self.torque_coefficient,
             self.torque_inflow, self.thrust_coefficient, kr, self.inflow_coefficient,
             self.fluid_mass, self.flow_damping],
            dtype=np.float64,
        )


BLOCK_TYPES: dict[str, type[Block]] = {
    cls.TYPE: cls
    for cls in (
        ESC,
        FirstOrderMotor,
        DCMotor,
        TunnelThruster,
        QuadraticMap,
        PolynomialMap,
        DeadZoneMap,
        TableMap,
        ZeroOrder,
        FirstOrder,
        Yoerger,
        BessaDynamics,
        LoadCell,
        Driver,
        HealeyThruster,
    )
}
# Names users know from UUV Simulator, accepted in model files.
BLOCK_ALIASES = {
    "Basic": "quadratic",
    "LinearInterp": "table",
    "ZeroOrder": "zero_order",
    "FirstOrder": "first_order",
    "Yoerger": "yoerger",
    "Bessa": "bessa",
    "cv": "quadratic",
    "mclean": "tunnel_thruster",
    "Healey": "healey",
}
