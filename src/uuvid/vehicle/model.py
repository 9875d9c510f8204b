"""6-DOF vehicle dynamics (body frame, velocity relative to the water) and Caccia's 1-DOF model.

6-DOF model (Fossen 2011, §§3.3, 4.1, 6.3–6.4, 10.3; Caccia et al. 2000, eq. 1)::

    ṗ  = R(q) ν₁                                   NED position, z down
    q̇  = ½ T(q) ν₂ + ½ γ (1 − qᵀq) q                unit quaternion [η, ε₁, ε₂, ε₃]
    (M_RB + M_A) ν̇ = −C_RB(ν)ν − C_A(ν_r)ν_r − D_L ν_r − D_Q (|ν_r| ∘ ν_r) − g(q) + τ + M_A ν̇_c

with ``ν_r = ν − ν_c``, ``ν_c = [R(q)ᵀ v_c ; 0]`` the current in body axes (``v_c`` in NED) and
``ν̇_c = [−ν₂ × R(q)ᵀ v_c + R(q)ᵀ v̇_c ; 0]``.  The last term is what ``M_A ν̇_r`` leaves over when
the added mass sits in the mass matrix; it is computed from ``ω`` and ``v_c`` analytically — never
from a differentiated acceleration — and vanishes without a current.

State (13): ``x = [n, e, d, η, ε₁, ε₂, ε₃, u, v, w, p, q, r]``; input ``τ = [X, Y, Z, K, M, N]``.
The attitude is singularity-free; its unit norm is kept by the stabilising term (gain γ,
default 1 s⁻¹: ``d(qᵀq)/dt = γ(1 − qᵀq)qᵀq`` pulls the norm back to 1) and, preferably, by
:func:`uuvid.vehicle.kinematics.normalise_state` after every integration step.

Two implementations of the right-hand side: :func:`vehicle_rhs` (numba, flattened parameters,
see :data:`PARAM_LAYOUT`) for the compiled integrators, and :func:`vehicle_rhs_reference`
(NumPy, matrices built term by term, ``np.linalg.solve``) to check it.

The uncoupled 1-DOF model of Caccia et al. (2000, eq. 3) is :class:`OneDofModel`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit

from uuvid.core.units import G0
from uuvid.thruster.blocks import ParameterError
from uuvid.vehicle.hydrodynamics import (
    added_mass_coriolis,
    damping_force,
    restoring_forces,
    six_by_six,
)
from uuvid.vehicle.kinematics import euler_to_quat
from uuvid.vehicle.rigid_body import rigid_body_coriolis, rigid_body_mass_matrix, skew_ref

DOF_NAMES = ("surge", "sway", "heave", "roll", "pitch", "yaw")
STATE_NAMES = ("n", "e", "d", "qw", "qx", "qy", "qz", "u", "v", "w", "p", "q", "r")
N_STATES = 13

#: Largest trim tilt (deg, roll or pitch) counted as level: beyond it the vehicle no longer does
#: useful work (camera, tools, a level DVL).  One limit for steady flight (:func:`static_stability`,
#: the envelope check) and station keeping (:mod:`uuvid.analysis.hold`).
MAX_TILT_DEG = 20.0

# ---------------------------------------------------------------------------------------------
# Flattened parameter array of the compiled right-hand side (layout version 1)
# ---------------------------------------------------------------------------------------------
LAYOUT_VERSION = 1.0
P_VERSION = 0  # 1 value: LAYOUT_VERSION (checked by VehicleParams.from_array)
P_MINV = 1  # 36: (M_RB + M_A)⁻¹, row-major
P_MRB = 37  # 36: M_RB about CO, row-major
P_MA = 73  # 36: M_A (positive), row-major
P_DL = 109  # 36: D_L (positive), row-major
P_DQ = 145  # 36: D_Q (positive), row-major, multiplies |ν_r|∘ν_r
P_W = 181  # 1: weight W, N
P_B = 182  # 1: buoyancy B, N
P_RG = 183  # 3: r_g, m (body axes)
P_RB = 186  # 3: r_b, m (body axes)
P_VC = 189  # 3: constant current in NED, m/s (vehicle_rhs only)
P_GAMMA = 192  # 1: quaternion stabilising gain γ, 1/s
N_PARAMS = 193

PARAM_LAYOUT = {
    "version": (P_VERSION, 1), "Minv": (P_MINV, 36), "M_RB": (P_MRB, 36), "M_A": (P_MA, 36),
    "D_L": (P_DL, 36), "D_Q": (P_DQ, 36), "W": (P_W, 1), "B": (P_B, 1), "r_g": (P_RG, 3),
    "r_b": (P_RB, 3), "current_ned": (P_VC, 3), "quaternion_gain": (P_GAMMA, 1),
}


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _inertia3(values) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    if a.shape == (3,):
        return np.diag(a)
    if a.shape in ((9,), (3, 3)):
        return a.reshape(3, 3).copy()
    raise ParameterError(f"VehicleParams.inertia: expected 3 (principal) or 9 values, got shape "
                         f"{a.shape}", "inertia")


MAX_MAGNITUDE = 1e12
"""Largest parameter magnitude accepted in SI units (a 10¹² kg vehicle is a unit mistake; beyond
this the mass matrix overflows or loses every digit of its smaller terms)."""


def _bounded(name: str, v) -> None:
    a = np.abs(np.asarray(v, dtype=float))
    if a.size and a.max() > MAX_MAGNITUDE:
        i = int(np.argmax(a))
        idx = np.unravel_index(i, a.shape)
        where = f"[{', '.join(str(int(k)) for k in idx)}]" if a.size > 1 else ""
        raise ParameterError(f"VehicleParams.{name}{where} = {np.ravel(v)[i]:g}: larger than "
                             f"{MAX_MAGNITUDE:g} in SI units; check the value and its unit", name)


@dataclass(frozen=True, eq=False)
class VehicleParams:
    """Rigid-body, hydrostatic and hydrodynamic parameters of a vehicle (SI, positive magnitudes).

    ``inertia`` is about the CG (3 principal values or 3×3); ``added_mass``, ``linear_damping``,
    ``quadratic_damping`` take 6 (diagonal) or 36 values; ``current`` is a constant current in
    NED (m/s).  Validated on construction; :meth:`to_array` flattens for :func:`vehicle_rhs`.
    """

    mass: float
    inertia: np.ndarray
    r_g: np.ndarray
    r_b: np.ndarray
    weight: float
    buoyancy: float
    added_mass: np.ndarray
    linear_damping: np.ndarray
    quadratic_damping: np.ndarray
    current: np.ndarray = field(default_factory=lambda: np.zeros(3))
    quaternion_gain: float = 1.0
    name: str = "vehicle"

    def __post_init__(self):
        m = self.mass
        if not (isinstance(m, (int, float, np.floating)) and math.isfinite(m) and m > 0):
            raise ParameterError(f"VehicleParams.mass must be a positive finite number, got {m!r}",
                                 "mass")
        for nm in ("weight", "buoyancy", "quaternion_gain"):
            v = getattr(self, nm)
            if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v >= 0):
                raise ParameterError(f"VehicleParams.{nm} must be a finite number >= 0, got {v!r}",
                                     nm)
        object.__setattr__(self, "mass", float(m))
        object.__setattr__(self, "weight", float(self.weight))
        object.__setattr__(self, "buoyancy", float(self.buoyancy))
        object.__setattr__(self, "quaternion_gain", float(self.quaternion_gain))
        Ig = _inertia3(self.inertia)
        for nm in ("r_g", "r_b", "current"):
            v = np.asarray(getattr(self, nm), dtype=float)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise ParameterError(f"VehicleParams.{nm} must be 3 finite numbers", nm)
            object.__setattr__(self, nm, _frozen(v))
        mats = {}
        for nm in ("added_mass", "linear_damping", "quadratic_damping"):
            try:
                mats[nm] = six_by_six(getattr(self, nm), f"VehicleParams.{nm}")
            except ValueError as e:
                raise ParameterError(str(e), nm) from None
            if not np.all(np.isfinite(mats[nm])):
                raise ParameterError(f"VehicleParams.{nm} must be finite", nm)
        _bounded("mass", m)
        for nm in ("weight", "buoyancy", "quaternion_gain", "r_g", "r_b", "current"):
            _bounded(nm, getattr(self, nm))
        if np.all(np.isfinite(Ig)):
            _bounded("inertia", Ig)
        for nm, v in mats.items():
            _bounded(nm, v)
        if not np.all(np.isfinite(Ig)) or not np.allclose(Ig, Ig.T, rtol=0, atol=1e-12 * max(
                1.0, np.abs(Ig).max())):
            raise ParameterError("VehicleParams.inertia must be a finite symmetric 3×3 tensor",
                                 "inertia")
        if np.linalg.eigvalsh(Ig).min() <= 0:
            raise ParameterError("VehicleParams.inertia must be positive definite", "inertia")
        MA = mats["added_mass"]
        tol = 1e-9 * max(1.0, np.abs(MA).max())
        if not np.allclose(MA, MA.T, rtol=0, atol=tol):
            raise ParameterError("VehicleParams.added_mass must be symmetric (largest asymmetry "
                                 f"{np.abs(MA - MA.T).max():.3g})", "added_mass")
        if np.linalg.eigvalsh(MA).min() < -tol:
            raise ParameterError("VehicleParams.added_mass must be positive semi-definite: files "
                                 "store magnitudes (X_u̇ = −5.5 kg is written 5.5)", "added_mass")
        for nm in ("linear_damping", "quadratic_damping"):
            D = mats[nm]
            if np.any(np.diag(D) < 0):
                i = int(np.flatnonzero(np.diag(D) < 0)[0])
                raise ParameterError(f"VehicleParams.{nm}[{DOF_NAMES[i]}] = {D[i, i]:g} < 0: files "
                                     "store positive magnitudes (Fossen X_u = −4.03 is written "
                                     "4.03)", nm)
            Ds = 0.5 * (D + D.T)
            if np.linalg.eigvalsh(Ds).min() < -1e-9 * max(1.0, np.abs(D).max()):
                raise ParameterError(f"VehicleParams.{nm}: the symmetric part must be positive "
                                     "semi-definite (damping must dissipate energy)", nm)
        object.__setattr__(self, "inertia", _frozen(Ig))
        for nm, v in mats.items():
            object.__setattr__(self, nm, _frozen(v))
        M = self.mass_matrix
        if np.linalg.eigvalsh(0.5 * (M + M.T)).min() <= 0:
            raise ParameterError("VehicleParams: M_RB + M_A is not positive definite", "inertia")

    # ---------------------------------------------------------------- derived matrices
    @property
    def M_RB(self) -> np.ndarray:
        """Rigid-body inertia matrix about CO (Fossen 2011, §3.3)."""
        return rigid_body_mass_matrix(self.mass, self.inertia, self.r_g)

    @property
    def M_A(self) -> np.ndarray:
        return np.array(self.added_mass)

    @property
    def mass_matrix(self) -> np.ndarray:
        """``M = M_RB + M_A``."""
        return self.M_RB + self.added_mass

    @property
    def net_weight(self) -> float:
        """``W − B`` (N): positive sinks (z down)."""
        return self.weight - self.buoyancy

    def with_current(self, current_ned) -> VehicleParams:
        return replace(self, current=np.asarray(current_ned, dtype=float))

    def to_array(self) -> np.ndarray:
        """The flattened parameter vector of :func:`vehicle_rhs` (layout :data:`PARAM_LAYOUT`):
        a fresh copy of the vector built once per (frozen) parameter set."""
        p = self.__dict__.get("_array")
        if p is None:
            p = self._build_array()
            p.flags.writeable = False
            self.__dict__["_array"] = p
        return p.copy()

    def _build_array(self) -> np.ndarray:
        p = np.zeros(N_PARAMS)
        p[P_VERSION] = LAYOUT_VERSION
        p[P_MINV:P_MINV + 36] = np.linalg.inv(self.mass_matrix).ravel()
        p[P_MRB:P_MRB + 36] = self.M_RB.ravel()
        p[P_MA:P_MA + 36] = self.added_mass.ravel()
        p[P_DL:P_DL + 36] = self.linear_damping.ravel()
        p[P_DQ:P_DQ + 36] = self.quadratic_damping.ravel()
        p[P_W] = self.weight
        p[P_B] = self.buoyancy
        p[P_RG:P_RG + 3] = self.r_g
        p[P_RB:P_RB + 3] = self.r_b
        p[P_VC:P_VC + 3] = self.current
        p[P_GAMMA] = self.quaternion_gain
        return p

    def kinetic_energy(self, nu) -> float:
        """``½ νᵀ (M_RB + M_A) ν`` (conserved without damping, restoring and thrust)."""
        nu = np.asarray(nu, dtype=float)
        return 0.5 * float(nu @ self.mass_matrix @ nu)

    def summary(self) -> str:
        def d(a):
            return np.array2string(np.diag(a), precision=4, separator=", ")

        return (f"{self.name}: m = {self.mass:g} kg, W = {self.weight:.4g} N, "
                f"B = {self.buoyancy:.4g} N, r_g = {self.r_g.tolist()} m, r_b = {self.r_b.tolist()} m\n"
                f"  inertia diag {d(self.inertia)} kg·m²\n"
                f"  M_A diag {d(self.added_mass)} (kg ×3, kg·m² ×3)\n"
                f"  D_L diag {d(self.linear_damping)} (N·s/m ×3, N·m·s/rad ×3)\n"
                f"  D_Q diag {d(self.quadratic_damping)} (N·s²/m² ×3, N·m·s²/rad² ×3)\n"
                f"  [surge, sway, heave, roll, pitch, yaw]")


def make_params(mass: float, inertia, *, r_g=(0, 0, 0), r_b=(0, 0, 0), weight: float | None = None,
                buoyancy: float | None = None, displaced_volume: float | None = None,
                water_density: float = 1025.0, gravity: float = G0, added_mass=(0,) * 6,
                linear_damping=(0,) * 6, quadratic_damping=(0,) * 6, current=(0, 0, 0),
                quaternion_gain: float = 1.0, name: str = "vehicle") -> VehicleParams:
    """Build :class:`VehicleParams`; ``W = m g`` by default and ``B = ρ g ∇`` from a volume."""
    if weight is None:
        weight = mass * gravity
    if buoyancy is None:
        if displaced_volume is None:
            raise ParameterError("give buoyancy or displaced_volume", "buoyancy")
        buoyancy = water_density * gravity * displaced_volume
    return VehicleParams(mass, inertia, np.asarray(r_g, float), np.asarray(r_b, float), weight,
                         buoyancy, added_mass, linear_damping, quadratic_damping,
                         np.asarray(current, float), quaternion_gain, name)


def make_state(position=(0, 0, 0), rpy=(0, 0, 0), nu=(0, 0, 0, 0, 0, 0), quaternion=None):
    """State vector ``[p(3), q(4), ν(6)]`` from position, zyx Euler angles (rad) or a quaternion."""
    q = euler_to_quat(*rpy) if quaternion is None else np.asarray(quaternion, float)
    return np.concatenate([np.asarray(position, float), q / np.linalg.norm(q),
                           np.asarray(nu, float)])


# ---------------------------------------------------------------------------------------------
# Compiled right-hand side
# ---------------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _sub_kirchhoff(p, off, v, f):
    """``f −= C(v) v`` with ``C`` from the 6×6 matrix stored at ``p[off:off+36]`` (Thm 3.2)."""
    a0 = a1 = a2 = a3 = a4 = a5 = 0.0
    for j in range(6):
        vj = v[j]
        a0 += p[off + j] * vj
        a1 += p[off + 6 + j] * vj
        a2 += p[off + 12 + j] * vj
        a3 += p[off + 18 + j] * vj
        a4 += p[off + 24 + j] * vj
        a5 += p[off + 30 + j] * vj
    # C v = [ν₂ × a₁ ; ν₁ × a₁ + ν₂ × a₂]
    f[0] -= v[4] * a2 - v[5] * a1
    f[1] -= v[5] * a0 - v[3] * a2
    f[2] -= v[3] * a1 - v[4] * a0
    f[3] -= (v[1] * a2 - v[2] * a1) + (v[4] * a5 - v[5] * a4)
    f[4] -= (v[2] * a0 - v[0] * a2) + (v[5] * a3 - v[3] * a5)
    f[5] -= (v[0] * a1 - v[1] * a0) + (v[3] * a4 - v[4] * a3)


@njit(cache=True, inline="always")
def _kinematics_into(x, p, dx):
    """``ṗ = R(q) v`` and ``q̇`` (with the unit-norm correction γ) into ``dx[0:7]``; returns the
    rotation matrix R(q) (body → NED, Fossen 2011, §2.2.2) by its nine elements."""
    e = x[3]
    ex = x[4]
    ey = x[5]
    ez = x[6]
    r00 = 1.0 - 2.0 * (ey * ey + ez * ez)
    r01 = 2.0 * (ex * ey - ez * e)
    r02 = 2.0 * (ex * ez + ey * e)
    r10 = 2.0 * (ex * ey + ez * e)
    r11 = 1.0 - 2.0 * (ex * ex + ez * ez)
    r12 = 2.0 * (ey * ez - ex * e)
    r20 = 2.0 * (ex * ez - ey * e)
    r21 = 2.0 * (ey * ez + ex * e)
    r22 = 1.0 - 2.0 * (ex * ex + ey * ey)
    u = x[7]
    v = x[8]
    w = x[9]
    pp = x[10]
    qq = x[11]
    rr = x[12]
    dx[0] = r00 * u + r01 * v + r02 * w
    dx[1] = r10 * u + r11 * v + r12 * w
    dx[2] = r20 * u + r21 * v + r22 * w
    k = 0.5 * p[P_GAMMA] * (1.0 - (e * e + ex * ex + ey * ey + ez * ez))
    dx[3] = 0.5 * (-ex * pp - ey * qq - ez * rr) + k * e
    dx[4] = 0.5 * (e * pp - ez * qq + ey * rr) + k * ex
    dx[5] = 0.5 * (ez * pp + e * qq - ex * rr) + k * ey
    dx[6] = 0.5 * (-ey * pp + ex * qq + e * rr) + k * ez
    return r00, r01, r02, r10, r11, r12, r20, r21, r22


@njit(cache=True, inline="always")
def _restoring_accel_into(p, r20, r21, r22, f, dx):
    """Add ``−g(q) = [(W − B) k ; (W r_g − B r_b) × k]`` (``k = Rᵀ e_z``, the last row of R) to
    the generalized force ``f`` and write ``ν̇ = M⁻¹ f`` into ``dx[7:13]``."""
    W = p[P_W]
    B = p[P_B]
    kx, ky, kz = r20, r21, r22
    f[0] += (W - B) * kx
    f[1] += (W - B) * ky
    f[2] += (W - B) * kz
    mx = W * p[P_RG] - B * p[P_RB]
    my = W * p[P_RG + 1] - B * p[P_RB + 1]
    mz = W * p[P_RG + 2] - B * p[P_RB + 2]
    f[3] += my * kz - mz * ky
    f[4] += mz * kx - mx * kz
    f[5] += mx * ky - my * kx
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += p[P_MINV + 6 * i + j] * f[j]
        dx[7 + i] = s


@njit(cache=True)
def vehicle_rhs_into(x, tau, p, vc_ned, dvc_ned, dx):
    """``ẋ = f(x, τ, p)`` written into ``dx`` (13), with a current ``v_c`` and its rate in NED.

    No allocation except two 6-vectors; ``p`` is :meth:`VehicleParams.to_array` (its own current
    slots are ignored here).  See the module docstring for the equations.
    """
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = _kinematics_into(x, p, dx)
    u = x[7]
    v = x[8]
    w = x[9]
    pp = x[10]
    qq = x[11]
    rr = x[12]
    # current in body axes and its rate: ν_c = [Rᵀ v_c; 0], ν̇_c = [−ω × Rᵀv_c + Rᵀ v̇_c; 0]
    cu = r00 * vc_ned[0] + r10 * vc_ned[1] + r20 * vc_ned[2]
    cv = r01 * vc_ned[0] + r11 * vc_ned[1] + r21 * vc_ned[2]
    cw = r02 * vc_ned[0] + r12 * vc_ned[1] + r22 * vc_ned[2]
    au = -(qq * cw - rr * cv) + r00 * dvc_ned[0] + r10 * dvc_ned[1] + r20 * dvc_ned[2]
    av = -(rr * cu - pp * cw) + r01 * dvc_ned[0] + r11 * dvc_ned[1] + r21 * dvc_ned[2]
    aw = -(pp * cv - qq * cu) + r02 * dvc_ned[0] + r12 * dvc_ned[1] + r22 * dvc_ned[2]
    nu = x[7:13]
    nr = np.empty(6)
    nr[0] = u - cu
    nr[1] = v - cv
    nr[2] = w - cw
    nr[3] = pp
    nr[4] = qq
    nr[5] = rr
    f = np.empty(6)
    for i in range(6):
        f[i] = tau[i]
    _sub_kirchhoff(p, P_MRB, nu, f)  # −C_RB(ν) ν
    _sub_kirchhoff(p, P_MA, nr, f)  # −C_A(ν_r) ν_r
    for i in range(6):
        s = 0.0
        for j in range(6):
            nj = nr[j]
            s += p[P_DL + 6 * i + j] * nj + p[P_DQ + 6 * i + j] * abs(nj) * nj
        # + M_A ν̇_c (only its translational part is non-zero)
        s -= p[P_MA + 6 * i] * au + p[P_MA + 6 * i + 1] * av + p[P_MA + 6 * i + 2] * aw
        f[i] -= s
    _restoring_accel_into(p, r20, r21, r22, f, dx)


@njit(cache=True, inline="always")
def vehicle_rhs_still_into(x, tau, p, f, dx):
    """:func:`vehicle_rhs_into` in still water (``v_c = v̇_c = 0``, so ``ν_r = ν``), for loops
    that step it many times: no current terms, and no allocation (``f`` is a 6-vector of
    scratch).  The same arithmetic on the remaining terms, so the same numbers."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = _kinematics_into(x, p, dx)
    nu = x[7:13]
    for i in range(6):
        f[i] = tau[i]
    _sub_kirchhoff(p, P_MRB, nu, f)  # −C_RB(ν) ν
    _sub_kirchhoff(p, P_MA, nu, f)  # −C_A(ν) ν
    for i in range(6):
        s = 0.0
        for j in range(6):
            nj = nu[j]
            s += p[P_DL + 6 * i + j] * nj + p[P_DQ + 6 * i + j] * abs(nj) * nj
        f[i] -= s
    _restoring_accel_into(p, r20, r21, r22, f, dx)


@njit(cache=True)
def vehicle_rhs(x, tau, p):
    """Compiled ``ẋ = f(x, τ, p)`` with the constant NED current stored in ``p`` (returns a new
    13-vector).  ``x`` (13), ``τ`` (6), ``p`` = :meth:`VehicleParams.to_array` (193)."""
    dx = np.empty(13)
    vehicle_rhs_into(x, tau, p, p[P_VC:P_VC + 3], np.zeros(3), dx)
    return dx


# ---------------------------------------------------------------------------------------------
# NumPy reference
# ---------------------------------------------------------------------------------------------
def rotation_reference(q) -> np.ndarray:
    """``R(q) = I + 2η S(ε) + 2 S(ε)²`` (Fossen 2011, §2.2.2) — written differently on purpose."""
    q = np.asarray(q, dtype=float)
    S = skew_ref(q[1:])
    return np.eye(3) + 2 * q[0] * S + 2 * S @ S


def vehicle_rhs_reference(x, tau, params: VehicleParams, current_ned=None,
                          current_rate_ned=None) -> np.ndarray:
    """NumPy reference of :func:`vehicle_rhs`: every term as a matrix, ``M ν̇`` solved directly."""
    x = np.asarray(x, dtype=float)
    tau = np.asarray(tau, dtype=float)
    vc = params.current if current_ned is None else np.asarray(current_ned, float)
    dvc = np.zeros(3) if current_rate_ned is None else np.asarray(current_rate_ned, float)
    q = x[3:7]
    nu = x[7:13]
    R = rotation_reference(q)
    eta_, eps = q[0], q[1:]
    Tq = 0.5 * np.vstack([-eps, eta_ * np.eye(3) + skew_ref(eps)])
    gamma = params.quaternion_gain
    vcb = R.T @ vc
    nu_c = np.concatenate([vcb, np.zeros(3)])
    nu_c_dot = np.concatenate([-np.cross(nu[3:], vcb) + R.T @ dvc, np.zeros(3)])
    nu_r = nu - nu_c
    M_RB = params.M_RB
    M_A = params.M_A
    rhs = (tau - rigid_body_coriolis(M_RB, nu) @ nu - added_mass_coriolis(M_A, nu_r) @ nu_r
           - damping_force(params.linear_damping, params.quadratic_damping, nu_r)
           - restoring_forces(params.weight, params.buoyancy, params.r_g, params.r_b, R)
           + M_A @ nu_c_dot)
    nu_dot = np.linalg.solve(M_RB + M_A, rhs)
    q_dot = Tq @ nu[3:] + 0.5 * gamma * (1 - q @ q) * q
    return np.concatenate([R @ nu[:3], q_dot, nu_dot])


# ---------------------------------------------------------------------------------------------
# Caccia et al. (2000), eq. 3: uncoupled 1-DOF model
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class OneDofModel:
    """``m ξ̇ = −k ξ − k_q ξ|ξ| + η(μ) φ + ν`` (Caccia, Indiveri & Veruggio 2000, eq. 3).

    ``mass`` is the total (rigid + added) inertia along the DOF, ``linear``/``quadratic`` the
    positive drag coefficients, ``eta_pos``/``eta_neg`` the thruster installation coefficient of
    the active mapping mode for positive/negative nominal force φ (1 = open water; e.g. ROMEO's
    vertical thrusters pulling up: ``eta_neg = 0.56``), ``disturbance`` the constant ν (in heave,
    ``W − B``).
    """

    mass: float
    linear: float
    quadratic: float = 0.0
    eta_pos: float = 1.0
    eta_neg: float = 1.0
    disturbance: float = 0.0
    dof: str = ""
    #: ``k_a`` [N·s²/(rad·m)] of the linear inflow form ``T_i = T_i,bollard − k_a |Ω_i| u_a,i``
    #: (Healey et al. 1995): the dive replay's thrust loss ``k_a c(t) v``
    #: (:mod:`uuvid.simulate.dive_replay`); 0 is bollard thrust
    inflow_coefficient: float = 0.0

    def __post_init__(self):
        if not (math.isfinite(self.inflow_coefficient) and self.inflow_coefficient >= 0):
            raise ParameterError(f"OneDofModel.inflow_coefficient must be a finite number >= 0, "
                                 f"got {self.inflow_coefficient!r}", "inflow_coefficient")
        if not (math.isfinite(self.mass) and self.mass > 0):
            raise ParameterError(f"OneDofModel.mass must be positive, got {self.mass!r}", "mass")
        for nm in ("linear", "quadratic", "eta_pos", "eta_neg"):
            v = getattr(self, nm)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"OneDofModel.{nm} must be a finite number >= 0, got {v!r}",
                                     nm)
        if self.linear == 0 and self.quadratic == 0:
            raise ParameterError("OneDofModel needs linear > 0 or quadratic > 0", "linear")
        if not math.isfinite(self.disturbance):
            raise ParameterError("OneDofModel.disturbance must be finite", "disturbance")

    def to_array(self) -> np.ndarray:
        """``[m, k, k_q, η₊, η₋, ν]`` for :func:`one_dof_rhs_compiled`."""
        return np.array([self.mass, self.linear, self.quadratic, self.eta_pos, self.eta_neg,
                         self.disturbance])

    def rhs(self, xi, phi):
        return one_dof_rhs(xi, phi, self)

    def applied(self, phi):
        """``η(μ) φ`` — the force the thrusters actually deliver."""
        phi = np.asarray(phi, dtype=float)
        return np.where(phi >= 0, self.eta_pos, self.eta_neg) * phi

    def steady_speed(self, phi):
        """ξ where ``k ξ + k_q ξ|ξ| = η φ + ν`` (the steady state of eq. 3)."""
        return steady_speed(self.linear, self.quadratic, self.applied(phi) + self.disturbance)

    def time_constant(self, xi_star: float = 0.0) -> float:
        """``τ_c = m/k_L``, ``k_L = k + 2 k_q |ξ*|`` (Caccia 2000, linearisation at ξ*)."""
        return self.mass / (self.linear + 2 * self.quadratic * abs(xi_star))


def steady_speed(linear: float, quadratic: float, force):
    """Solve ``k_L v + k_Q v|v| = F`` for v (sign of F; ``k_L, k_Q ≥ 0``, not both 0)."""
    F = np.asarray(force, dtype=float)
    aF = np.abs(F)
    if quadratic > 0:
        mag = 2 * aF / (linear + np.sqrt(linear * linear + 4 * quadratic * aF))
    else:
        mag = aF / linear
    out = np.sign(F) * mag
    return float(out) if out.ndim == 0 else out


def one_dof_rhs(xi, phi, model: OneDofModel):
    """``ξ̇`` of Caccia's eq. 3 (NumPy, vectorised over ξ and φ)."""
    xi = np.asarray(xi, dtype=float)
    return (-model.linear * xi - model.quadratic * xi * np.abs(xi) + model.applied(phi)
            + model.disturbance) / model.mass


@njit(cache=True)
def one_dof_rhs_compiled(xi, phi, p):
    """Compiled eq. 3: ``p = [m, k, k_q, η₊, η₋, ν]`` (:meth:`OneDofModel.to_array`)."""
    eta = p[3] if phi >= 0.0 else p[4]
    return (-p[1] * xi - p[2] * xi * abs(xi) + eta * phi + p[5]) / p[0]
