"""Thrust allocation: generalised force → thruster forces, with thrust-mapping modes and limits.

For ``φ = B τ`` (``B`` m × n, thrusts ``τ``) the allocation solves (Caccia et al. 2000, §IV-B;
Fossen 2011, "Control allocation")::

    min ½ τᵀ P τ   subject to   B_s τ = φ_s   and   C_μ τ = 0

* ``B_s`` are the rows of the controlled DOFs (a subset is allowed: e.g. surge, sway, heave, yaw
  of a 6-thruster BlueROV2, whose roll and pitch are left to the restoring moments);
* ``P = I`` gives the minimum-norm pseudo-inverse ``Bᵀ(BBᵀ)⁻¹``; a diagonal or full SPD ``P``
  gives Caccia's minimum-energy ``B# = P⁻¹Bᵀ(BP⁻¹Bᵀ)⁻¹``;
* ``C_μ τ = 0`` are the linear constraints of a **thrust-mapping mode** μ (Caccia et al. 2000,
  Table I): relations between thruster forces (*surge front*: ``τ_RL + τ_RR = 0``), thrusters
  switched off, and DOFs forced to zero (*surge front*: ``Y = 0``; *vertical all, heave only*:
  ``L = M = 0``).

The solution is linear in φ, ``τ = T φ``, and is computed once by the null-space method: with
``N`` an orthonormal basis of ``ker C_μ`` and ``τ = N z``,
``T = N Q^{-1/2} (B_s N Q^{-1/2})⁺``, ``Q = NᵀPN``.  The constraints then hold exactly for every
φ; a φ the mode cannot produce is met in the least-squares sense and reported.

Installation coefficients η (Caccia et al. 2000, eq. 3): in mode μ thruster i delivers
``η_i τ_i`` (``η₊`` for positive, ``η₋`` for negative commanded thrust; η = 1 in open water).
By default the allocator commands the nominal thrusts (as Caccia's experiments do: the
constraints hold on the commanded forces and the vehicle feels ``B(η ∘ τ)``); with
``compensate_eta=True`` it commands ``τ_i/η_i`` so the delivered wrench is the requested one
(the constraints then hold on the delivered forces).

Saturation: **uniform scaling** ``τ ← s τ``, ``s = min(1, min_i lim_i/τ_i)`` keeps the direction
of the generalised force and reports the achieved fraction ``s``; per-thruster **clipping**
(UUV Simulator's behaviour) is offered for comparison and bends the direction.

:func:`allocate_compiled` is the numba version for simulation loops: the precomputed matrix
``T`` plus η compensation and uniform scaling, on the flat array of :meth:`Allocator.to_array`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from uuvid.vehicle.layout import dof_index


# ---------------------------------------------------------------------------------------------
# Plain matrices
# ---------------------------------------------------------------------------------------------
def pseudo_inverse(B) -> np.ndarray:
    """Minimum-norm right inverse ``Bᵀ(BBᵀ)⁻¹`` (Moore–Penrose for full row rank)."""
    return np.linalg.pinv(np.asarray(B, dtype=float))


def weighted_pseudo_inverse(B, P) -> np.ndarray:
    """``B# = P⁻¹Bᵀ(BP⁻¹Bᵀ)⁻¹`` minimising ½τᵀPτ (Caccia et al. 2000, §IV-B); ``B`` full row rank.

    ``P`` is a vector (diagonal weights) or an SPD matrix.
    """
    B = np.asarray(B, dtype=float)
    P = _weight_matrix(P, B.shape[1])
    Pi = np.linalg.inv(P)
    return Pi @ B.T @ np.linalg.inv(B @ Pi @ B.T)


def _weight_matrix(P, n: int) -> np.ndarray:
    if P is None:
        return np.eye(n)
    P = np.asarray(P, dtype=float)
    if P.ndim == 1:
        if P.shape != (n,) or np.any(~np.isfinite(P)) or np.any(P <= 0):
            raise ValueError(f"weights must be {n} positive numbers")
        return np.diag(P)
    if P.shape != (n, n) or not np.allclose(P, P.T) or np.linalg.eigvalsh(P).min() <= 0:
        raise ValueError(f"weight matrix must be symmetric positive definite {n}×{n}")
    return P


def null_space(C, n: int, rtol: float = 1e-10) -> np.ndarray:
    """Orthonormal basis (n × r) of ``ker C`` (``I`` when there are no constraints)."""
    C = np.asarray(C, dtype=float).reshape(-1, n)
    if C.shape[0] == 0:
        return np.eye(n)
    _, s, Vt = np.linalg.svd(C)
    rank = int(np.sum(s > rtol * max(s[0] if s.size else 0.0, 1e-300)))
    return Vt[rank:].T.copy()


def constrained_allocation_matrix(B, rows: Sequence[int] | None = None, weights=None,
                                  constraints=None) -> np.ndarray:
    """``T`` (n × m) with ``τ = T φ`` minimising ½τᵀPτ s.t. ``B[rows] τ = φ[rows]``, ``C τ = 0``.

    Columns of ``T`` for rows not controlled are zero (those components of φ are ignored).
    """
    B = np.asarray(B, dtype=float)
    m, n = B.shape
    rows = list(range(m)) if rows is None else [int(r) for r in rows]
    P = _weight_matrix(weights, n)
    N = null_space(np.zeros((0, n)) if constraints is None else constraints, n)
    T = np.zeros((n, m))
    if N.shape[1] == 0 or not rows:
        return T
    Q = N.T @ P @ N
    ev, V = np.linalg.eigh(0.5 * (Q + Q.T))
    Qmh = V @ np.diag(1.0 / np.sqrt(ev)) @ V.T
    G = N @ Qmh
    T[:, rows] = G @ np.linalg.pinv(B[rows] @ G, rcond=1e-10)
    return T


def scale_to_limits(tau, lower, upper) -> tuple[np.ndarray, float]:
    """Uniform scaling ``s τ`` into ``[lower, upper]`` (``lower ≤ 0 ≤ upper``); returns (τ, s)."""
    tau = np.asarray(tau, dtype=float)
    s = _scale_factor(tau, np.asarray(lower, float), np.asarray(upper, float))
    return tau * s, s


def clip_to_limits(tau, lower, upper) -> np.ndarray:
    """Per-thruster clipping (changes the direction of the generalised force)."""
    return np.clip(np.asarray(tau, dtype=float), lower, upper)


def _scale_factor(tau, lo, hi) -> float:
    s = 1.0
    for t, a, b in zip(tau, np.broadcast_to(lo, tau.shape), np.broadcast_to(hi, tau.shape)):
        if t > b:
            s = min(s, b / t)
        elif t < a:
            s = min(s, a / t)
    return float(s)


def apply_eta(tau, eta_pos, eta_neg) -> np.ndarray:
    """Delivered thrust ``η(sign τ) τ``."""
    tau = np.asarray(tau, dtype=float)
    return np.where(tau >= 0, eta_pos, eta_neg) * tau


# ---------------------------------------------------------------------------------------------
# Thrust-mapping modes
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ThrustMode:
    """A thrust-mapping mode (Caccia et al. 2000, Table I): constraints + installation coefficients.

    ``constraints`` (k × n) are rows of ``C_μ τ = 0`` on the thruster forces; ``zero_dofs`` are
    rows of ``B`` forced to zero (not controlled in this mode); ``eta_pos``/``eta_neg`` (n) the
    installation coefficients (1 = open water); ``open_water`` names the motion for which the
    mode's working thrusters see open water; ``eta_dof`` holds DOF-level installation
    coefficients as identified by Caccia (e.g. ``{"yaw-": 0.60}``) for the 1-DOF models.
    """

    name: str
    constraints: np.ndarray
    zero_dofs: tuple[int, ...] = ()
    eta_pos: np.ndarray | None = None
    eta_neg: np.ndarray | None = None
    open_water: str = ""
    description: str = ""
    eta_dof: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        C = np.atleast_2d(np.asarray(self.constraints, dtype=float))
        n = C.shape[1]
        if C.size == 0:
            C = C.reshape(0, n)
        object.__setattr__(self, "constraints", C)
        object.__setattr__(self, "zero_dofs", tuple(dof_index(d) for d in self.zero_dofs))
        for nm in ("eta_pos", "eta_neg"):
            e = getattr(self, nm)
            e = np.ones(n) if e is None else np.asarray(e, dtype=float)
            if e.shape != (n,) or np.any(~np.isfinite(e)) or np.any(e <= 0):
                raise ValueError(f"mode {self.name}: {nm} must be {n} positive numbers")
            object.__setattr__(self, nm, e)
        object.__setattr__(self, "eta_dof", dict(self.eta_dof))

    @property
    def n(self) -> int:
        return self.constraints.shape[1]

    @classmethod
    def from_names(cls, name: str, thrusters: Sequence[str], constraints=(), zero_dofs=(),
                   off: Sequence[str] = (),
                   eta: Mapping[str, float | tuple[float, float]] | None = None,
                   **kw) -> ThrustMode:
        """Constraints written with thruster names, e.g. ``[{"RL": 1, "RR": 1}]``; ``off``
        thrusters are forced to zero; ``eta = {"FL": 0.6}`` or ``{"FL": (1.0, 0.6)}``."""
        names = list(thrusters)
        rows = []
        for c in constraints:
            r = np.zeros(len(names))
            for k, v in dict(c).items():
                r[names.index(k)] = float(v)
            rows.append(r)
        for k in off:
            r = np.zeros(len(names))
            r[names.index(k)] = 1.0
            rows.append(r)
        ep, en = np.ones(len(names)), np.ones(len(names))
        for k, v in (eta or {}).items():
            i = names.index(k)
            ep[i], en[i] = (v, v) if np.ndim(v) == 0 else v
        C = np.array(rows).reshape(len(rows), len(names))
        return cls(name, C, tuple(zero_dofs), ep, en, **kw)

    def constraint_rows(self, B) -> np.ndarray:
        """All equality rows on τ: ``[C_μ ; B[zero_dofs]]``."""
        B = np.asarray(B, dtype=float)
        return np.vstack([self.constraints, B[list(self.zero_dofs)]]) if self.zero_dofs else \
            self.constraints

    def residual(self, tau) -> np.ndarray:
        """``C_μ τ`` (zero when the thrusts respect the mode's thruster relations)."""
        return self.constraints @ np.asarray(tau, dtype=float)

    def delivered(self, tau) -> np.ndarray:
        return apply_eta(tau, self.eta_pos, self.eta_neg)


# ---------------------------------------------------------------------------------------------
# Allocator
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class AllocationResult:
    """Commanded and delivered thrusts, requested vs achieved generalised force, saturation.

    ``fraction`` is the achieved fraction of the request along its own direction (uniform
    scaling: the scale factor); ``achievable`` is ``representable and not saturated``;
    ``representable`` says whether the unsaturated allocation delivers the controlled components
    (False when the mode cannot produce them, or when installation coefficients η < 1 reduce the
    delivered force and ``compensate_eta`` is off); ``ignored`` lists requested components the
    allocation does not control (outside ``dofs`` or forced to zero by the mode);
    ``direction_error`` is the angle (rad) between requested and achieved controlled components.
    """

    thrust: np.ndarray
    delivered: np.ndarray
    requested: np.ndarray
    achieved: np.ndarray
    fraction: float
    saturated: bool
    representable: bool
    ignored: tuple[int, ...]
    direction_error: float
    saturation: str
    mode: str | None = None
    limiting: tuple[int, ...] = ()

    @property
    def achievable(self) -> bool:
        return self.representable and not self.saturated

    def report(self) -> str:
        def f(a):
            return np.array2string(np.asarray(a), precision=4, suppress_small=True)

        ang = math.degrees(self.direction_error)
        lines = [f"allocation ({self.saturation}{', mode ' + self.mode if self.mode else ''}):",
                 f"  requested {f(self.requested)}", f"  achieved  {f(self.achieved)}",
                 f"  thrust    {f(self.thrust)}",
                 (f"  fraction {self.fraction:.4g}, saturated {self.saturated}, representable "
                  f"{self.representable}, direction error {ang:.3g}°")]
        if self.ignored:
            lines.append(f"  not controlled (ignored): rows {list(self.ignored)}")
        if self.limiting:
            lines.append(f"  limiting thrusters: {list(self.limiting)}")
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class Allocator:
    """Precomputed allocation ``τ = T φ`` for ``B`` (m × n), DOF subset, weights, mode, limits.

    ``dofs``: controlled rows (names like ``"surge"`` or indices; default all); ``weights``: P
    (n positive numbers or an SPD matrix; default I); ``limits``: (n, 2) ``[min, max]`` thrust.
    """

    B: np.ndarray
    dofs: tuple[int, ...] | None = None
    weights: np.ndarray | None = None
    mode: ThrustMode | None = None
    limits: np.ndarray | None = None
    compensate_eta: bool = False
    T: np.ndarray = field(init=False)
    controlled: tuple[int, ...] = field(init=False)

    def __post_init__(self):
        B = np.atleast_2d(np.asarray(self.B, dtype=float))
        m, n = B.shape
        object.__setattr__(self, "B", B)
        dofs = tuple(range(m)) if self.dofs is None else tuple(
            (dof_index(d) if not isinstance(d, (int, np.integer)) else int(d)) for d in self.dofs)
        if any(not 0 <= d < m for d in dofs):
            raise ValueError(f"dofs {dofs} out of range for B with {m} rows")
        object.__setattr__(self, "dofs", dofs)
        if self.mode is not None and self.mode.n != n:
            raise ValueError(f"mode {self.mode.name} is for {self.mode.n} thrusters, B has {n}")
        zero = set(self.mode.zero_dofs) if self.mode is not None else set()
        controlled = tuple(d for d in dofs if d not in zero)
        object.__setattr__(self, "controlled", controlled)
        if self.weights is not None:
            object.__setattr__(self, "weights", _weight_matrix(self.weights, n))
        lim = np.tile([-np.inf, np.inf], (n, 1)) if self.limits is None else np.asarray(
            self.limits, dtype=float).reshape(n, 2)
        if np.any(lim[:, 0] > 0) or np.any(lim[:, 1] < 0):
            raise ValueError("thrust limits must satisfy min <= 0 <= max for every thruster")
        object.__setattr__(self, "limits", lim)
        C = self.mode.constraint_rows(B) if self.mode is not None else np.zeros((0, n))
        object.__setattr__(self, "T", constrained_allocation_matrix(B, controlled, self.weights, C))

    @property
    def n(self) -> int:
        return self.B.shape[1]

    @property
    def eta(self) -> tuple[np.ndarray, np.ndarray]:
        if self.mode is None:
            return np.ones(self.n), np.ones(self.n)
        return self.mode.eta_pos, self.mode.eta_neg

    def nominal(self, phi) -> np.ndarray:
        """Unsaturated thrusts ``T φ`` (divided by η when ``compensate_eta``)."""
        tau = self.T @ np.asarray(phi, dtype=float)
        if self.compensate_eta:
            ep, en = self.eta
            tau = tau / np.where(tau >= 0, ep, en)
        return tau

    def allocate(self, phi, saturation: str = "scale", tol: float = 1e-9) -> AllocationResult:
        """Allocate ``φ`` (m); ``saturation``: ``"scale"`` (uniform), ``"clip"`` or ``"none"``."""
        phi = np.asarray(phi, dtype=float)
        if phi.shape != (self.B.shape[0],):
            raise ValueError(f"requested force must have {self.B.shape[0]} components")
        ep, en = self.eta
        tau0 = self.nominal(phi)
        ctl = list(self.controlled)
        scale_ref = max(1.0, float(np.abs(phi).max(initial=0.0)))
        res0 = self.B[ctl] @ apply_eta(tau0, ep, en) - phi[ctl]
        representable = bool(np.all(np.abs(res0) <= tol * scale_ref * 10 + 1e-12))
        ignored = tuple(d for d in range(len(phi)) if d not in self.controlled
                        and abs(phi[d]) > tol * scale_ref)
        lo, hi = self.limits[:, 0], self.limits[:, 1]
        limiting: tuple[int, ...] = ()
        if saturation == "scale":
            tau, s = scale_to_limits(tau0, lo, hi)
            if s < 1.0:
                with np.errstate(divide="ignore", invalid="ignore"):
                    r = np.where(tau0 > hi, hi / tau0, np.where(tau0 < lo, lo / tau0, np.inf))
                limiting = tuple(int(i) for i in np.flatnonzero(np.isclose(r, s)))
        elif saturation == "clip":
            tau = clip_to_limits(tau0, lo, hi)
            limiting = tuple(int(i) for i in np.flatnonzero((tau0 > hi) | (tau0 < lo)))
        elif saturation == "none":
            tau = tau0
        else:
            raise ValueError(f"saturation must be scale, clip or none, got {saturation!r}")
        delivered = apply_eta(tau, ep, en)
        achieved = self.B @ delivered
        a, r = achieved[ctl], phi[ctl]
        nr = float(np.linalg.norm(r))
        if nr > 0:
            frac = float(a @ r) / nr**2
            na = float(np.linalg.norm(a))
            cosang = float(a @ r) / (na * nr) if na > 0 else 1.0
            ang = math.acos(max(-1.0, min(1.0, cosang)))
        else:
            frac, ang = 1.0, 0.0
        saturated = bool(np.any(tau0 > hi * (1 + 1e-12)) or np.any(tau0 < lo * (1 + 1e-12)))
        return AllocationResult(tau, delivered, phi, achieved, frac, saturated, representable,
                                ignored, ang, saturation,
                                self.mode.name if self.mode is not None else None, limiting)

    def max_along(self, phi) -> float:
        """Largest ``s`` such that ``s φ`` is allocated within the limits (uniform scaling)."""
        tau = self.nominal(phi)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(tau > 0, self.limits[:, 1] / tau,
                         np.where(tau < 0, self.limits[:, 0] / tau, np.inf))
        return float(np.min(r)) if r.size else math.inf

    def to_array(self) -> np.ndarray:
        """Flat parameters of :func:`allocate_compiled`.

        Layout: ``[n, m, compensate, T (n·m, row-major), lower (n), upper (n), η₊ (n), η₋ (n)]``.
        """
        n, m = self.T.shape
        ep, en = self.eta
        return np.concatenate([[n, m, 1.0 if self.compensate_eta else 0.0], self.T.ravel(),
                               self.limits[:, 0], self.limits[:, 1], ep, en]).astype(np.float64)


# ---------------------------------------------------------------------------------------------
# Compiled allocation for simulation loops
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def allocate_compiled(a, phi, tau):
    """``τ = s · T φ`` (η-compensated if the flag is set) into ``tau`` (n); returns ``s`` ∈ [0, 1].

    ``a`` is :meth:`Allocator.to_array`; ``s < 1`` means the request was scaled down uniformly
    (the direction of the generalised force is kept; ``s`` is the achieved fraction).
    """
    n = int(a[0])
    m = int(a[1])
    comp = a[2] != 0.0
    oT = 3
    olo = oT + n * m
    ohi = olo + n
    oep = ohi + n
    oen = oep + n
    s = 1.0
    for i in range(n):
        t = 0.0
        for j in range(m):
            t += a[oT + i * m + j] * phi[j]
        if comp:
            t = t / (a[oep + i] if t >= 0.0 else a[oen + i])
        tau[i] = t
        if t > a[ohi + i]:
            s = min(s, a[ohi + i] / t)
        elif t < a[olo + i]:
            s = min(s, a[olo + i] / t)
    for i in range(n):
        tau[i] *= s
    return s


@njit(cache=True)
def delivered_compiled(a, tau, out):
    """Delivered thrust ``η(sign τ) τ`` into ``out`` (``a`` from :meth:`Allocator.to_array`)."""
    n = int(a[0])
    m = int(a[1])
    oep = 3 + n * m + 2 * n
    oen = oep + n
    for i in range(n):
        t = tau[i]
        out[i] = t * (a[oep + i] if t >= 0.0 else a[oen + i])
