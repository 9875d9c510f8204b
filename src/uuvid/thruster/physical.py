"""A voltage-aware physical thruster model (its identification: :mod:`uuvid.identify.thruster.physical`).

Chain (steady state, per direction; forward = command above neutral):

1. **ESC** — command → duty: ``s = (c − e)/(f − e)`` between the dead-band edge ``e`` and the
   full-command point ``f`` (clipped to 0…1), optionally bent by a duty curvature β:
   ``d = s (1 + β (s − 1))`` (monotone for |β| < 1; β = 0 is the linear ESC of Laidani et al.
   eq. 1).  Motor voltage ``V = d · V_supply`` — the same duty gives more volts on a fuller
   battery, which is what lets one model answer for any supply voltage.
2. **DC motor** (averaged brushless motor; McLean 1991 eqs. 2.1–2.5 at rest), ``K_t = K_e``:
   ``K_e (V − K_e Ω)/R = K_Q Ω|Ω| + c_v Ω + T_c sgn Ω`` with the propeller torque
   ``K_Q Ω|Ω|`` per direction.  For ``Ω ≥ 0`` this is the quadratic
   ``K_Q Ω² + (K_e²/R + c_v) Ω + (T_c − K_e V/R) = 0``, solved in closed form (vectorised,
   cancellation-free root); the shaft stays still while ``K_e V/R ≤ T_c``.
3. **Propeller** — ``T = K_T Ω|Ω|`` per direction.

The supply current is ``I_s = d · I_m`` with ``I_m = (V − K_e Ω)/R`` the motor current (a PWM
ESC as a lossless DC/DC converter, ``V_s I_s = V_m I_m``).

:meth:`PhysicalModel.to_chain` builds the equivalent :class:`~uuvid.thruster.chain.ThrusterChain`
``ESC → DCMotor → QuadraticMap`` whose steady state equals :meth:`PhysicalModel.predict`.
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import asdict, dataclass, fields, replace
from importlib import resources

import numpy as np

from uuvid.thruster.blocks import ESC, DCMotor, ParameterError, QuadraticMap
from uuvid.thruster.chain import ThrusterChain

#: Default lower bound of K_e: back-EMF at the top measured speed ≥ this fraction of the supply.
#: Steady sheets barely constrain K_e (see the module notes); without a floor the fit may slide to
#: a motor with no back-EMF at all, which no real motor is.
KE_MIN_FRACTION = 0.1
#: Default linearised mechanical time constant of an exported chain when no inertia is known.
DEFAULT_TIME_CONSTANT = 0.05

_UNITS = {
    "K_e": "V·s/rad (= K_t, N·m/A)",
    "deadband_fwd": "command (edge − neutral)",
    "deadband_rev": "command (neutral − edge)",
    "R": "Ω",
    "K_Q_fwd": "N·m·s²/rad²",
    "K_Q_rev": "N·m·s²/rad²",
    "K_T_fwd": "N·s²/rad²",
    "K_T_rev": "N·s²/rad²",
    "curvature_fwd": "1",
    "curvature_rev": "1",
    "c_v": "N·m·s/rad",
    "T_c": "N·m",
}


@dataclass(frozen=True)
class Prediction:
    """Steady state at each (command, supply voltage)."""

    command: np.ndarray
    supply_voltage: np.ndarray
    duty: np.ndarray  # signed
    voltage: np.ndarray  # motor voltage, signed [V]
    speed: np.ndarray  # [rad/s], signed
    thrust: np.ndarray  # [N], signed
    motor_current: np.ndarray  # [A], signed
    current: np.ndarray  # supply current [A] = |d|·|I_m|
    torque: np.ndarray  # propeller torque [N·m], signed


@dataclass(frozen=True)
class PhysicalModel:
    """ESC duty × supply voltage → DC motor against ``K_Q Ω|Ω|`` → ``T = K_T Ω|Ω|``, per direction.

    Commands are in ``command_unit`` around ``neutral``; ``edge_*`` are the dead-band edges and
    ``full_*`` the commands of full duty.  ``motor_inertia`` only matters for simulation (it is
    not identifiable from steady data); when ``None`` an exported chain gets the inertia that gives
    a linearised time constant of :data:`DEFAULT_TIME_CONSTANT` at full forward command.
    """

    back_emf_constant: float
    resistance: float
    kq_fwd: float
    kq_rev: float
    kt_fwd: float
    kt_rev: float
    edge_fwd: float
    edge_rev: float
    full_fwd: float
    full_rev: float
    curvature_fwd: float = 0.0
    curvature_rev: float = 0.0
    viscous: float = 0.0
    coulomb: float = 0.0
    neutral: float = 1500.0
    command_unit: str = "pwm_us"
    motor_inertia: float | None = None

    def __post_init__(self):
        for name in ("back_emf_constant", "resistance"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(f"PhysicalModel.{name} must be positive, got {v!r}", name)
        if self.motor_inertia is not None and not (math.isfinite(self.motor_inertia)
                                                   and self.motor_inertia > 0):
            raise ParameterError(f"PhysicalModel.motor_inertia must be positive, got "
                                 f"{self.motor_inertia!r}", "motor_inertia")
        for name in ("kq_fwd", "kq_rev", "kt_fwd", "kt_rev", "viscous", "coulomb"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"PhysicalModel.{name} must be >= 0, got {v!r}", name)
        if not (self.full_rev < self.edge_rev <= self.neutral <= self.edge_fwd < self.full_fwd):
            raise ParameterError(
                "PhysicalModel needs full_rev < edge_rev <= neutral <= edge_fwd < full_fwd, got "
                f"{self.full_rev:g}, {self.edge_rev:g}, {self.neutral:g}, {self.edge_fwd:g}, "
                f"{self.full_fwd:g}")
        for name in ("curvature_fwd", "curvature_rev"):
            v = getattr(self, name)
            if not (math.isfinite(v) and -1 < v < 1):
                raise ParameterError(f"PhysicalModel.{name} must lie in (-1, 1) (monotone duty), "
                                     f"got {v!r}", name)

    # ------------------------------------------------------------------ the model
    def duty(self, command) -> np.ndarray:
        """Signed duty ``d(c)`` (−1…1)."""
        c = np.clip(np.asarray(command, dtype=float), self.full_rev, self.full_fwd)
        s_f = np.clip((c - self.edge_fwd) / (self.full_fwd - self.edge_fwd), 0.0, 1.0)
        s_r = np.clip((self.edge_rev - c) / (self.edge_rev - self.full_rev), 0.0, 1.0)
        d_f = s_f * (1.0 + self.curvature_fwd * (s_f - 1.0))
        d_r = s_r * (1.0 + self.curvature_rev * (s_r - 1.0))
        return np.where(c > self.edge_fwd, d_f, np.where(c < self.edge_rev, -d_r, 0.0))

    def predict(self, command, supply_voltage) -> Prediction:
        """Steady thrust, speed, currents at commands ``command`` and supply voltage(s)
        (compiled, :func:`uuvid.thruster.physical_kernel.steady_state_nb`: the arithmetic of
        :meth:`duty` and the steady motor/propeller balance, element by element)."""
        from uuvid.thruster.physical_kernel import steady_state_nb

        c = np.asarray(command, dtype=float)
        vs = np.asarray(supply_voltage, dtype=float)
        if vs.ndim == 0 and c.ndim > 0:  # one voltage for every command (a grid)
            vflat, vs = vs.reshape(1), np.broadcast_to(vs, c.shape)
        else:
            if c.shape != vs.shape:
                c, vs = np.broadcast_arrays(c, vs)
            vflat = np.ascontiguousarray(vs).ravel()
        out = np.empty((7, c.size))
        # writable C arrays always (a read-only input, e.g. from np.broadcast_to, would compile
        # the kernel a second time for its read-only signature)
        cflat = np.require(np.ascontiguousarray(c).ravel(), float, ["C", "W"])
        if steady_state_nb(cflat, np.require(vflat, float, ["C", "W"]), self._kernel_params(),
                           out) >= 0:
            raise ValueError("supply voltage must be positive and finite")
        d, v, speed, thrust, im, cur, torque = (o.reshape(c.shape) for o in out)
        return Prediction(command=c, supply_voltage=vs, duty=d, voltage=v, speed=speed,
                          thrust=thrust, motor_current=im, current=cur, torque=torque)

    def _kernel_params(self) -> np.ndarray:
        """The model's numbers in the order of :data:`uuvid.thruster.physical_kernel.PARAMS`
        (built once: the model is frozen)."""
        p = self.__dict__.get("_kp")
        if p is None:
            from uuvid.thruster.physical_kernel import PARAMS

            p = np.array([float(getattr(self, k)) for k in PARAMS])
            object.__setattr__(self, "_kp", p)
        return p

    def _predict_numpy(self, command, supply_voltage) -> Prediction:
        """The NumPy form of :meth:`predict` (the reference its compiled kernel is tested against)."""
        c, vs = np.broadcast_arrays(np.asarray(command, dtype=float),
                                    np.asarray(supply_voltage, dtype=float))
        d = self.duty(c)
        v = d * vs
        sgn = np.sign(v)
        av = np.abs(v)
        ke, r = self.back_emf_constant, self.resistance
        kq = np.where(sgn >= 0, self.kq_fwd, self.kq_rev)
        kt = np.where(sgn >= 0, self.kt_fwd, self.kt_rev)
        b = ke * ke / r + self.viscous
        cc = self.coulomb - ke * av / r
        disc = np.sqrt(np.maximum(b * b - 4.0 * kq * cc, 0.0))
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(cc < 0, -2.0 * cc / (b + disc), 0.0)
        im = (av - ke * w) / r
        return Prediction(command=c, supply_voltage=vs, duty=d, voltage=v, speed=sgn * w,
                          thrust=sgn * kt * w * w, motor_current=sgn * im,
                          current=np.abs(d) * im, torque=sgn * kq * w * w)

    def thrust(self, command, supply_voltage) -> np.ndarray:
        """Steady thrust [N] (shorthand for ``predict(...).thrust``)."""
        return self.predict(command, supply_voltage).thrust

    def speed(self, command, supply_voltage) -> np.ndarray:
        return self.predict(command, supply_voltage).speed

    # ------------------------------------------------------------------ export
    def esc(self, supply_voltage: float) -> ESC:
        """The ESC block at ``supply_voltage`` (duty curvature only if the block supports it)."""
        a_f = supply_voltage / (self.full_fwd - self.edge_fwd)
        a_r = supply_voltage / (self.edge_rev - self.full_rev)
        kw = dict(a_fwd=a_f, b_fwd=-a_f * self.edge_fwd, a_rev=a_r, b_rev=-a_r * self.edge_rev,
                  neutral=self.neutral, deadzone_low=self.edge_rev, deadzone_high=self.edge_fwd,
                  saturation_low=self.full_rev, saturation_high=self.full_fwd,
                  supply_voltage=float(supply_voltage), command_unit=self.command_unit)
        if self.curvature_fwd or self.curvature_rev:
            if esc_supports_curvature():
                kw.update(curvature_fwd=self.curvature_fwd, curvature_rev=self.curvature_rev)
        return ESC(**kw)

    def inertia_for(self, time_constant: float, supply_voltage: float) -> float:
        """Inertia giving the linearised time constant ``time_constant`` at full forward command:
        ``J = τ (K_e²/R + c_v + 2 K_Q Ω_full)``."""
        w = float(abs(self.predict(self.full_fwd, supply_voltage).speed))
        damping = (self.back_emf_constant**2 / self.resistance + self.viscous
                   + 2.0 * self.kq_fwd * w)
        return float(time_constant * damping)

    def to_chain(self, supply_voltage: float, *, motor_inertia: float | None = None,
                 time_constant: float = DEFAULT_TIME_CONSTANT, allow_approximation: bool = False,
                 name: str = "physical") -> ThrusterChain:
        """``ESC → DCMotor → QuadraticMap`` at ``supply_voltage``; its steady state is :meth:`predict`.

        The inertia is ``motor_inertia``, else the model's, else the one giving ``time_constant``
        (steady data say nothing about dynamics).

        A model with a duty curvature needs an ESC block with ``curvature_fwd``/``curvature_rev``;
        without one this raises, unless ``allow_approximation`` (then the curvature is dropped
        with a warning giving the largest steady thrust error it causes).
        """
        if not (math.isfinite(supply_voltage) and supply_voltage > 0):
            raise ParameterError(f"supply_voltage must be positive, got {supply_voltage!r}")
        curved = bool(self.curvature_fwd or self.curvature_rev)
        if curved and not esc_supports_curvature():
            lin = self.linear_duty()
            c = np.linspace(self.full_rev, self.full_fwd, 401)
            err = float(np.max(np.abs(lin.thrust(c, supply_voltage)
                                      - self.thrust(c, supply_voltage))))
            msg = (f"the ESC block has no duty curvature (curvature_fwd={self.curvature_fwd:.3g}, "
                   f"curvature_rev={self.curvature_rev:.3g}); a linear ESC changes the steady "
                   f"thrust by up to {err:.3g} N at {supply_voltage:g} V")
            if not allow_approximation:
                raise ParameterError(msg + ": fit with duty_curvature=False for an exact chain, or "
                                     "pass allow_approximation=True", "curvature_fwd")
            warnings.warn(msg, RuntimeWarning, stacklevel=2)
        j = motor_inertia if motor_inertia is not None else self.motor_inertia
        if j is None:
            j = self.inertia_for(time_constant, supply_voltage)
        motor = DCMotor(torque_constant=self.back_emf_constant,
                        back_emf_constant=self.back_emf_constant, resistance=self.resistance,
                        motor_inertia=j,
                        motor_viscous=self.viscous, coulomb_torque=self.coulomb,
                        torque_coefficient=self.kq_fwd, torque_coefficient_rev=self.kq_rev)
        prop = QuadraticMap(k_pos=self.kt_fwd, k_neg=self.kt_rev, torque_pos=self.kq_fwd,
                            torque_neg=self.kq_rev)
        return ThrusterChain((self.esc(supply_voltage), motor, prop),
                             name=f"{name}@{supply_voltage:g}V")

    def linear_duty(self) -> PhysicalModel:
        """The same model with the duty curvature removed."""

        return replace(self, curvature_fwd=0.0, curvature_rev=0.0)

    def as_dict(self) -> dict:
        return asdict(self)


def esc_supports_curvature() -> bool:
    """Whether :class:`~uuvid.thruster.blocks.ESC` has ``curvature_fwd``/``curvature_rev``."""
    names = {f.name for f in fields(ESC)}
    return {"curvature_fwd", "curvature_rev"} <= names


T200_PHYSICAL_SOURCE = (
    "uuvid/thruster/data/t200-physical.yaml: physical model fitted (uuvid.identify.thruster.physical."
    "fit_physical) to Blue Robotics' T200 bollard sheets at 12 V and 16 V (September 2019)")


@functools.lru_cache(maxsize=4)
def physical_model(name: str = "t200-physical") -> PhysicalModel:
    """The shipped voltage-aware thruster model (``t200-physical``, package data)."""
    import yaml

    if name != "t200-physical":
        raise KeyError(f"unknown thruster power model {name!r}; have t200-physical")
    text = resources.files("uuvid.thruster").joinpath("data/t200-physical.yaml").read_text()
    return PhysicalModel(**yaml.safe_load(text)["base"]["physical_model"])


__all__ = ["PhysicalModel", "Prediction", "esc_supports_curvature", "physical_model",
           "KE_MIN_FRACTION", "DEFAULT_TIME_CONSTANT", "T200_PHYSICAL_SOURCE"]
