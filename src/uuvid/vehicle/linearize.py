"""Linearisation of the 6-DOF vehicle model about an operating point (analytic Jacobians).

The nonlinear model is :mod:`uuvid.vehicle.model` (13 states, unit quaternion).  A quaternion has
one constraint, so the linear model uses a **minimal 12-state** deviation

    ξ = [δn, δe, δd, α₁, α₂, α₃, δu, δv, δw, δp, δq, δr]

where ``α = 2 ε_e`` is twice the vector part of the attitude error ``q_e = q₀* ⊗ q`` (scalar part
kept ≥ 0): a small rotation vector **in the body axes of the operating point**
(``R(q) ≈ R(q₀)(I + S(α))``).  At a level operating point ``α ≈ [δφ, δθ, δψ]`` to first order.
On this chart the model is exactly ``ξ̇ = F(ξ, τ)`` with

    δṗ = R(q)ν₁ − ṗ₀,     α̇ = η_e ω + ½ α × ω,     ν̇ = M⁻¹(τ − C_RB(ν)ν − C_A(ν_r)ν_r
                                                            − D(ν_r)ν_r − g(q) + M_A ν̇_c)

(the quaternion-norm stabilising term vanishes on ``qᵀq = 1``).  Its Jacobian at ``ξ = 0``
(Fossen 2011, §§2.2.2, 3.3, 6.3–6.4; Kirchhoff form of Theorem 3.2)::

    A = [[0, −R₀S(υ₀),        R₀,  0 ],        B_τ = [[0 ], [0 ], [M⁻¹]]
         [0, −½S(ω₀),         0,   I ],        B_f = B_τ · B_thr      (B_thr: layout, 6 × n)
         [0, M⁻¹ J_α,     M⁻¹ J_ν      ]]

with ``ν_r = ν − [c; 0]``, ``c = R₀ᵀv_c`` the current in body axes, ``k = R₀ᵀe_z``,
``m = W r_g − B r_b``::

    J_ν = −∂(C_RB(ν)ν)/∂ν − ∂(C_A(ν_r)ν_r)/∂ν_r − (D_L + 2 D_Q diag|ν_r|) + M_A [[0, S(c)], [0, 0]]
    J_α = (∂(C_A ν_r)/∂ν_r + D_L + 2 D_Q diag|ν_r|) [S(c); 0] + [(W−B) S(k); S(m) S(k)]
          − M_A [S(ω)S(c); 0]

and ``∂(C(v)v)/∂v = [[S(ω)M₁], [S(υ)M₁ + S(ω)M₂]] + [[0, −S(a₁)], [−S(a₁), −S(a₂)]]`` for
``a = M v = [a₁; a₂]`` (``M₁, M₂`` the upper/lower 3 rows of ``M``).  The thrusts ``f`` are the
*delivered* thrusts (open water, installation coefficients η = 1) and enter as ``τ = B_thr f``;
thruster dynamics are not part of the linear model.  Quadratic damping ``|ν_r|ν_r`` is
differentiable (slope ``2|ν_r|``, 0 at rest), so at hover only the linear damping acts.

:func:`trim` finds the operating point: the thrusts (minimum norm) and the roll/pitch angles that
make ``ν̇ = 0`` at a given body velocity (hover: ν = 0), with or without a constant current.
:func:`linearize` returns a :class:`LinearModel`; :meth:`LinearModel.to_control` hands it to
python-control (``pip install uuvid[control]``).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from uuvid.core.result import Result
from uuvid.vehicle.kinematics import euler_to_quat, quat_to_euler, quat_to_rotmat
from uuvid.vehicle.model import DOF_NAMES, VehicleParams, rotation_reference, vehicle_rhs
from uuvid.vehicle.rigid_body import skew_ref

#: Names of the 12 states of the linear model (see the module docstring).
LINEAR_STATE_NAMES = ("n", "e", "d", "alpha_x", "alpha_y", "alpha_z", "u", "v", "w", "p", "q", "r")
_EZ = np.array([0.0, 0.0, 1.0])


class TrimError(ValueError):
    """No operating point (equilibrium) exists for the requested velocity and attitude freedom."""


# ---------------------------------------------------------------------------------------------
# Quaternion chart: full 13-state ↔ 12-state deviation
# ---------------------------------------------------------------------------------------------
def quat_multiply(a, b) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` of quaternions ``[η, ε]`` (Fossen 2011, §2.2.2)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.concatenate([[a[0] * b[0] - a[1:] @ b[1:]],
                           a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])])


def _conj(q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    return np.concatenate([[q[0]], -q[1:]])


def deviation_from_state(x0, x) -> np.ndarray:
    """12-state deviation ``ξ`` of a 13-state ``x`` from the operating state ``x0``.

    ``α = 2 ε_e`` of ``q_e = q₀* ⊗ q/|q|`` (sign chosen so that ``η_e ≥ 0``).
    """
    x0 = np.asarray(x0, dtype=float)
    x = np.asarray(x, dtype=float)
    qe = quat_multiply(_conj(x0[3:7]), x[3:7] / np.linalg.norm(x[3:7]))
    if qe[0] < 0:
        qe = -qe
    return np.concatenate([x[0:3] - x0[0:3], 2.0 * qe[1:], x[7:13] - x0[7:13]])


def state_from_deviation(x0, xi) -> np.ndarray:
    """Inverse of :func:`deviation_from_state` (needs ``|α| ≤ 2``)."""
    x0 = np.asarray(x0, dtype=float)
    xi = np.asarray(xi, dtype=float)
    eps = 0.5 * xi[3:6]
    s = float(eps @ eps)
    if s > 1.0:
        raise ValueError(f"attitude deviation |α| = {2 * math.sqrt(s):.3g} > 2 has no quaternion")
    qe = np.concatenate([[math.sqrt(1.0 - s)], eps])
    return np.concatenate([x0[0:3] + xi[0:3], quat_multiply(x0[3:7], qe), x0[7:13] + xi[6:12]])


# ---------------------------------------------------------------------------------------------
# Operating point and trim
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class OperatingPoint:
    """Where to linearise: pose, body velocity ``ν``, constant NED current and the input there.

    ``rpy`` are zyx Euler angles (rad).  ``tau`` (generalized force, 6) and ``thrust`` (one per
    thruster) are the inputs at the point; the Jacobians do not depend on them (the model is
    affine in τ), but the derivative at the point — zero at an equilibrium — does.  Build an
    equilibrium with :func:`trim` or :meth:`hover` / :meth:`forward`.
    """

    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    nu: tuple[float, ...] = (0.0,) * 6
    current: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tau: np.ndarray | None = None
    thrust: np.ndarray | None = None
    name: str = "operating point"
    trim_residual: float | None = None  # |M ν̇| left by trim (N), None when not trimmed

    def __post_init__(self):
        for nm, k in (("position", 3), ("rpy", 3), ("nu", 6), ("current", 3)):
            v = np.asarray(getattr(self, nm), dtype=float)
            if v.shape != (k,) or not np.all(np.isfinite(v)):
                raise ValueError(f"OperatingPoint.{nm} must be {k} finite numbers, got {v}")
            object.__setattr__(self, nm, tuple(float(a) for a in v))
        if self.tau is not None:
            t = np.asarray(self.tau, dtype=float)
            if t.shape != (6,):
                raise ValueError(f"OperatingPoint.tau must have 6 components, got {t.shape}")
            object.__setattr__(self, "tau", t)
        if self.thrust is not None:
            object.__setattr__(self, "thrust", np.asarray(self.thrust, dtype=float))

    @property
    def quaternion(self) -> np.ndarray:
        return euler_to_quat(*self.rpy)

    @property
    def state(self) -> np.ndarray:
        """The 13-state ``[p, q, ν]`` of :mod:`uuvid.vehicle.model`."""
        return np.concatenate([self.position, self.quaternion, self.nu])

    @classmethod
    def hover(cls, vehicle, *, depth: float = 0.0, heading: float = 0.0,
              current=(0.0, 0.0, 0.0)) -> OperatingPoint:
        """Station keeping at rest (ν = 0), trimmed: ``trim(vehicle, 0.0, ...)``."""
        return trim(vehicle, 0.0, depth=depth, heading=heading, current=current, name="hover")

    @classmethod
    def forward(cls, vehicle, speed: float, *, depth: float = 0.0, heading: float = 0.0,
                current=(0.0, 0.0, 0.0), level: bool = True) -> OperatingPoint:
        """Steady flight ahead at ``speed``, trimmed.  ``level`` (default): the vehicle moves
        horizontally along its heading at constant depth (NED velocity ``speed·[cos ψ, sin ψ, 0]``,
        so a pitched vehicle has a body heave ``w`` — and the Munk moment that comes with it; this
        is the trim of :func:`uuvid.vehicle.stability.static_stability`); ``level=False``: body
        surge ``ν = [speed, 0, 0, 0, 0, 0]``, which for a pitched vehicle is a slow climb/dive."""
        if level:
            v = (speed * math.cos(heading), speed * math.sin(heading), 0.0)
            return trim(vehicle, ground_velocity=v, depth=depth, heading=heading, current=current,
                        name=f"forward {speed:g} m/s (level)")
        return trim(vehicle, speed, depth=depth, heading=heading, current=current,
                    name=f"forward {speed:g} m/s")

    def to_dict(self) -> dict:
        return {"name": self.name, "position": list(self.position), "rpy": list(self.rpy),
                "nu": list(self.nu), "current": list(self.current),
                "tau": None if self.tau is None else self.tau.tolist(),
                "thrust": None if self.thrust is None else self.thrust.tolist(),
                "trim_residual": self.trim_residual}


def _resolve(vehicle):
    """``(params, B_thr or None, limits or None, thruster names)`` from a vehicle-like object."""
    if isinstance(vehicle, (str, Path)):
        from uuvid.vehicle.definition import load_vehicle

        vehicle = load_vehicle(vehicle)
    if isinstance(vehicle, VehicleParams):
        return vehicle, None, None, (), vehicle.name
    return (vehicle.params, np.asarray(vehicle.B, dtype=float), vehicle.layout.limits,
            tuple(vehicle.layout.names), vehicle.name)


def _tau_required(params: VehicleParams, x, current) -> np.ndarray:
    """Generalized force that makes ``ν̇ = 0`` at ``x``: ``τ = −M ν̇(x, τ = 0)``."""
    p = params.with_current(current).to_array()
    return -params.mass_matrix @ vehicle_rhs(x, np.zeros(6), p)[7:13]


def trim(vehicle, speed: float = 0.0, *, velocity=None, ground_velocity=None, depth: float = 0.0,
         heading: float = 0.0, current=(0.0, 0.0, 0.0), free_attitude: bool = True,
         tol: float = 1e-9, name: str | None = None) -> OperatingPoint:
    """Equilibrium at body velocity ``ν`` (``[speed, 0, 0, 0, 0, 0]`` unless ``velocity``; with
    ``ground_velocity`` (NED, m/s) the linear part follows the attitude, ``R(φ, θ, ψ)ᵀ v``, so the
    vehicle keeps that velocity over ground whatever trim it settles at).

    Solves ``ν̇ = 0`` for the thrusts ``f`` (minimum norm, ``B_thr f = τ_req``) and — when the
    thrusters cannot produce the required force (e.g. a BlueROV2 has no pitch authority of its
    own) and ``free_attitude`` — for roll and pitch, so that the restoring moments close the gap:
    ``(I − B_thr B_thr⁺) τ_req(φ, θ) = 0`` by least squares.  Heading and depth are free
    parameters of an equilibrium.  Raises :class:`TrimError` if the residual stays above
    ``tol · max(1, |τ_req|)``; warns when a thrust is outside its limits.
    """
    params, Bt, limits, names, vname = _resolve(vehicle)
    nu = (np.array([speed, 0, 0, 0, 0, 0], dtype=float) if velocity is None
          else np.asarray(velocity, dtype=float))
    if nu.shape != (6,) or not np.all(np.isfinite(nu)):
        raise ValueError(f"trim: velocity must be 6 finite numbers, got {nu}")
    current = np.asarray(current, dtype=float)
    if current.shape != (3,):
        raise ValueError("trim: current must be 3 numbers (NED, m/s)")
    Bm = np.eye(6) if Bt is None else Bt
    Bp = np.linalg.pinv(Bm)
    proj = np.eye(6) - Bm @ Bp

    vg = None if ground_velocity is None else np.asarray(ground_velocity, dtype=float)
    if vg is not None and (vg.shape != (3,) or not np.all(np.isfinite(vg))):
        raise ValueError(f"trim: ground_velocity must be 3 finite numbers (NED), got {vg}")

    def state(rp):
        q = euler_to_quat(rp[0], rp[1], heading)
        v = nu if vg is None else np.concatenate([quat_to_rotmat(q).T @ vg, np.zeros(3)])
        return np.concatenate([[0.0, 0.0, depth], q, v])

    def resid(rp):
        return proj @ _tau_required(params, state(rp), current)

    rp = np.zeros(2)
    scale = max(1.0, float(np.linalg.norm(_tau_required(params, state(rp), current))))
    r = resid(rp)
    if free_attitude:
        # Gauss–Newton with minimum-norm steps from level: the smallest roll/pitch that closes
        # the gap (a direction the thrusters can balance is left at zero)
        for _ in range(60):
            if np.linalg.norm(r) <= 0.01 * tol * scale:
                break
            J = np.empty((6, 2))
            for j in range(2):
                d = np.zeros(2)
                d[j] = 1e-6
                J[:, j] = (resid(rp + d) - resid(rp - d)) / 2e-6
            step = np.linalg.lstsq(J, r, rcond=1e-10)[0]
            rp = np.clip(rp - step, -1.4, 1.4)
            r = resid(rp)
    res = float(np.linalg.norm(r))
    if res > tol * scale:
        bad = [DOF_NAMES[i] for i in np.flatnonzero(np.abs(r) > tol * scale)]
        where = (f"ν = {nu.tolist()}" if vg is None else f"ground velocity {vg.tolist()} (NED)")
        raise TrimError(f"{vname}: no equilibrium at {where} with current "
                        f"{current.tolist()}: the thrusters cannot produce the required "
                        f"{', '.join(bad)} force/moment (residual {res:.3g})"
                        + ("" if free_attitude else "; try free_attitude=True"))
    x = state(rp)
    tau = _tau_required(params, x, current)
    f = None if Bt is None else Bp @ tau
    if f is not None and limits is not None:
        over = [names[i] for i in range(len(f))
                if f[i] > limits[i, 1] * (1 + 1e-9) or f[i] < limits[i, 0] * (1 + 1e-9)]
        if over:
            warnings.warn(f"{vname}: trim thrust outside the limits for {', '.join(over)} "
                          f"(thrusts {np.round(f, 3).tolist()} N): not a reachable equilibrium",
                          stacklevel=2)
    return OperatingPoint((0.0, 0.0, depth), (float(rp[0]), float(rp[1]), heading),
                          tuple(float(v) for v in x[7:13]),
                          tuple(current), tau, f, name or f"trim u = {speed:g} m/s",
                          trim_residual=res)


# ---------------------------------------------------------------------------------------------
# Analytic Jacobians
# ---------------------------------------------------------------------------------------------
def _d_kirchhoff(M, v) -> np.ndarray:
    """``∂(C(v) v)/∂v`` for the Kirchhoff form ``C(v)v = [ω×a₁; υ×a₁ + ω×a₂]``, ``a = M v``."""
    a = M @ v
    S = skew_ref
    J = np.zeros((6, 6))
    J[0:3] = S(v[3:6]) @ M[0:3]
    J[3:6] = S(v[0:3]) @ M[0:3] + S(v[3:6]) @ M[3:6]
    J[0:3, 3:6] -= S(a[0:3])
    J[3:6, 0:3] -= S(a[0:3])
    J[3:6, 3:6] -= S(a[3:6])
    return J


def jacobians(params: VehicleParams, x0, current=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B_τ)`` of the 12-state deviation model at the 13-state ``x0`` (module docstring)."""
    S = skew_ref
    x0 = np.asarray(x0, dtype=float)
    q0 = x0[3:7] / np.linalg.norm(x0[3:7])
    R0 = rotation_reference(q0)
    nu = x0[7:13]
    ups, om = nu[0:3], nu[3:6]
    c = R0.T @ np.asarray(current, dtype=float)
    k = R0.T @ _EZ
    nu_r = nu - np.concatenate([c, np.zeros(3)])
    M_A = params.M_A
    Minv = np.linalg.inv(params.mass_matrix)
    D = params.linear_damping + params.quadratic_damping * (2.0 * np.abs(nu_r))[None, :]
    dCA = _d_kirchhoff(M_A, nu_r)
    dnuc_dot_dnu = np.zeros((6, 6))
    dnuc_dot_dnu[0:3, 3:6] = S(c)  # ν̇_c = [−ω × c; 0] = [S(c) ω; 0]
    J_nu = -_d_kirchhoff(params.M_RB, nu) - dCA - D + M_A @ dnuc_dot_dnu
    dnur_da = -np.vstack([S(c), np.zeros((3, 3))])
    m = params.weight * params.r_g - params.buoyancy * params.r_b
    dg_da = np.vstack([params.net_weight * S(k), S(m) @ S(k)])
    dnucdot_da = np.vstack([-S(om) @ S(c), np.zeros((3, 3))])
    J_a = -(dCA + D) @ dnur_da + dg_da + M_A @ dnucdot_da
    A = np.zeros((12, 12))
    A[0:3, 3:6] = -R0 @ S(ups)
    A[0:3, 6:9] = R0
    A[3:6, 3:6] = -0.5 * S(om)
    A[3:6, 9:12] = np.eye(3)
    A[6:12, 3:6] = Minv @ J_a
    A[6:12, 6:12] = Minv @ J_nu
    Bt = np.zeros((12, 6))
    Bt[6:12] = Minv
    return A + 0.0, Bt  # + 0.0: no negative zeros in printed matrices


def reduced_rhs(params: VehicleParams, x0, xi, tau, current=(0.0, 0.0, 0.0)) -> np.ndarray:
    """``ξ̇ = F(ξ, τ)``: the nonlinear model on the 12-state chart about ``x0`` (compiled RHS).

    ``δṗ`` is reported as ``ṗ`` (the operating point's own ``ṗ₀`` is not subtracted, so at a
    moving operating point ``F(0, τ₀) = [ṗ₀, 0, 0]``).  Used to check :func:`jacobians`.
    """
    x0 = np.asarray(x0, dtype=float)
    x = state_from_deviation(x0, xi)
    dx = vehicle_rhs(x, np.asarray(tau, dtype=float), params.with_current(current).to_array())
    qe = quat_multiply(_conj(x0[3:7] / np.linalg.norm(x0[3:7])), x[3:7])
    sgn = 1.0 if qe[0] >= 0 else -1.0
    da = 2.0 * sgn * quat_multiply(_conj(x0[3:7] / np.linalg.norm(x0[3:7])), dx[3:7])[1:]
    return np.concatenate([dx[0:3], da, dx[7:13]])


# ---------------------------------------------------------------------------------------------
# The linear model
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LinearModel(Result):
    """``ξ̇ = A ξ + B δf``, ``y = C ξ + D δf`` about an :class:`OperatingPoint`.

    ``B`` is with respect to the (delivered) thruster forces ``f`` (``B = B_tau · B_thr``),
    ``B_tau`` with respect to the generalized force ``τ``.  States: :data:`LINEAR_STATE_NAMES`;
    ``C = I``, ``D = 0`` (the outputs are the states).  ``xdot0`` is ``F(0, τ₀)`` without the
    position rate: zero at an equilibrium.
    """

    A: np.ndarray
    B: np.ndarray
    B_tau: np.ndarray
    C: np.ndarray
    D: np.ndarray
    op: OperatingPoint
    x0: np.ndarray
    tau0: np.ndarray
    thrust0: np.ndarray | None
    xdot0: np.ndarray
    thrust_matrix: np.ndarray | None
    thruster_names: tuple[str, ...] = ()
    vehicle_name: str = "vehicle"
    state_names: tuple[str, ...] = field(default=LINEAR_STATE_NAMES)

    @property
    def input_names(self) -> tuple[str, ...]:
        return self.thruster_names if self.thrust_matrix is not None else tuple(
            f"tau_{d}" for d in DOF_NAMES)

    @property
    def is_equilibrium(self) -> bool:
        return bool(np.linalg.norm(self.xdot0[3:]) <= 1e-8 * max(1.0, np.abs(self.A).max()))

    def eigenvalues(self) -> np.ndarray:
        return np.linalg.eigvals(self.A)

    def controllability_rank(self, inputs: str = "thrust", tol: float = 1e-9) -> int:
        """Dimension of the controllable subspace (12 = fully controllable), grown by
        orthonormal Krylov blocks ``span{B, AB, …}`` (better conditioned than ``[B, AB, …]``)."""
        B = self._input_matrix(inputs)
        scale = max(1.0, float(np.abs(self.A).max()))

        def orth(M):
            if M.size == 0:
                return M
            U, s, _ = np.linalg.svd(M, full_matrices=False)
            return U[:, s > tol * max(s[0], 1e-300)]

        V = orth(B)
        for _ in range(12):
            W = orth(np.hstack([V, self.A @ V / scale]))
            if W.shape[1] == V.shape[1]:
                break
            V = W
        return int(V.shape[1])

    def _input_matrix(self, inputs: str) -> np.ndarray:
        if inputs == "thrust":
            return self.B
        if inputs in ("force", "tau"):
            return self.B_tau
        raise ValueError(f"inputs must be 'thrust' or 'force', got {inputs!r}")

    def deviation(self, x) -> np.ndarray:
        """12-state deviation of a 13-state ``x`` from the operating point."""
        return deviation_from_state(self.x0, x)

    def full_state(self, xi) -> np.ndarray:
        """13-state of the deviation ``ξ``."""
        return state_from_deviation(self.x0, xi)

    def to_control(self, inputs: str = "thrust"):
        """A ``control.StateSpace`` with named states, inputs and outputs (``pip install
        uuvid[control]``); ``inputs="force"`` for the generalized force τ."""
        try:
            import control
        except ImportError:  # pragma: no cover - depends on the environment
            raise ImportError("LinearModel.to_control needs python-control: pip install "
                              "'uuvid[control]' (or pip install control)") from None
        B = self._input_matrix(inputs)
        names = self.input_names if inputs == "thrust" else tuple(f"tau_{d}" for d in DOF_NAMES)
        D = np.zeros((12, B.shape[1]))
        return control.ss(self.A, B, self.C, D, states=list(self.state_names),
                          inputs=list(names), outputs=[f"y_{s}" for s in self.state_names],
                          name=f"{self.vehicle_name} @ {self.op.name}")

    report_title = "Linearised vehicle"

    def plot(self):
        """Eigenvalues of A in the complex plane (the open-loop modes)."""
        from uuvid.core.plots import new_figure

        fig, ax = new_figure(1, 1, figsize=(6, 4.5))
        ev = self.eigenvalues()
        ax.plot(ev.real, ev.imag, "x", ms=8)
        ax.axvline(0.0, color="k", lw=0.6)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel("Re λ [1/s]")
        ax.set_ylabel("Im λ [rad/s]")
        ax.set_title(f"{self.vehicle_name} at {self.op.name}: eigenvalues of A", fontsize=10)
        return fig

    def summary(self) -> str:
        ev = self.eigenvalues()
        ev = ev[np.argsort(ev.real)]
        euler = np.degrees(self.op.rpy)
        lines = [f"{self.vehicle_name} linearised at {self.op.name}: ν = {list(self.op.nu)}, "
                 f"roll/pitch/yaw = {np.round(euler, 3).tolist()} deg, current = "
                 f"{list(self.op.current)} m/s",
                 f"  states: {', '.join(self.state_names)} (α: small rotation, body axes)",
                 f"  inputs: {', '.join(self.input_names)}",
                 f"  equilibrium: {self.is_equilibrium} (|ν̇₀| = "
                 f"{np.linalg.norm(self.xdot0[6:]):.3g})",
                 f"  controllable rank (thrust): {self.controllability_rank('thrust')}/12",
                 "  eigenvalues: " + ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" for z in ev)]
        if self.thrust0 is not None:
            lines.append("  trim thrust (N): " + ", ".join(
                f"{n}={f:.3f}" for n, f in zip(self.thruster_names, self.thrust0)))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"vehicle": self.vehicle_name, "operating_point": self.op.to_dict(),
                "state_names": list(self.state_names), "input_names": list(self.input_names),
                "A": self.A.tolist(), "B": self.B.tolist(), "B_tau": self.B_tau.tolist(),
                "C": self.C.tolist(), "D": self.D.tolist(), "x0": self.x0.tolist(),
                "tau0": self.tau0.tolist(),
                "thrust0": None if self.thrust0 is None else self.thrust0.tolist(),
                "is_equilibrium": self.is_equilibrium}


def linearize(vehicle, at: OperatingPoint | None = None) -> LinearModel:
    """Linearise a vehicle (``Vehicle``, preset name, file path, or ``VehicleParams``) at ``at``.

    ``at`` defaults to :meth:`OperatingPoint.hover` (trimmed).  Returns a :class:`LinearModel`
    with analytic ``A``, ``B`` (thrusts), ``B_tau`` (generalized force), ``C = I``, ``D = 0``.
    A ``VehicleParams`` has no thrusters: then ``B`` is ``B_tau``.
    """
    if isinstance(vehicle, (str, Path)):
        from uuvid.vehicle.definition import load_vehicle

        vehicle = load_vehicle(vehicle)
    params, Bthr, _, names, vname = _resolve(vehicle)
    op = OperatingPoint.hover(vehicle) if at is None else at
    x0 = op.state
    A, B_tau = jacobians(params, x0, op.current)
    if op.tau is not None:
        tau0 = op.tau
    elif op.thrust is not None and Bthr is not None:
        tau0 = Bthr @ op.thrust
    else:
        tau0 = np.zeros(6)
    xdot0 = reduced_rhs(params, x0, np.zeros(12), tau0, op.current)
    xdot0[0:3] = 0.0
    if Bthr is not None:
        B = B_tau @ Bthr
        f0 = op.thrust if op.thrust is not None else np.linalg.pinv(Bthr) @ tau0
    else:
        B, f0 = B_tau, None
    nin = B.shape[1]
    return LinearModel(A, B, B_tau, np.eye(12), np.zeros((12, nin)), op, x0, tau0, f0, xdot0,
                       Bthr, names, vname)


def euler_deviation(lin: LinearModel, x) -> np.ndarray:
    """Roll, pitch, yaw of a 13-state minus those of the operating point (wrapped), rad."""
    d = quat_to_euler(np.asarray(x, float)[3:7]) - np.asarray(lin.op.rpy)
    return (d + math.pi) % (2 * math.pi) - math.pi
