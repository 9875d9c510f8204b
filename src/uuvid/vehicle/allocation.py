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

Saturation: by default (``priority``, as missions fly) the **bounded** solution: every wrench the
limits allow is delivered exactly (an active-set method; see :class:`Allocator`), and one they do
not gets the weighted least error; ``maxscale`` scales the request until it is achievable.
Named alternatives: **uniform scaling** ``τ ← s τ``, ``s = min(1, min_i lim_i/τ_i)`` of ``T φ``
(keeps the direction but shrinks wrenches other thrust combinations could deliver) and
per-thruster **clipping** (UUV Simulator's behaviour; bends the direction).

:func:`allocate_compiled` is the numba version for simulation loops, on the flat array of
:meth:`Allocator.to_array` (every method).
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


def dead_thrusters(limits) -> np.ndarray:
    """Indices of the thrusters whose ``limits`` (n, 2) are ``[0, 0]``: they give no thrust either
    way (switched off, or a placeholder) and the allocation leaves them out (:class:`Allocator`).
    The one rule for the allocation, the vehicle file's warnings
    (:func:`uuvid.vehicle.definition.load_vehicle`) and the envelope's one-way thrusters."""
    lim = np.asarray(limits, dtype=float).reshape(-1, 2)
    return np.flatnonzero((lim[:, 0] == 0.0) & (lim[:, 1] == 0.0))


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

    @property
    def shortfall(self) -> dict[str, float]:
        """What each controlled DOF lost: requested − achieved (N or N·m), non-zero entries only."""
        from uuvid.vehicle.layout import DOF_NAMES

        d = self.requested - self.achieved
        tol = 1e-9 * max(1.0, float(np.abs(self.requested).max(initial=0.0)))
        return {DOF_NAMES[k]: float(d[k]) for k in range(min(len(d), 6))
                if k not in self.ignored and abs(d[k]) > tol}

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
        if self.saturated and self.shortfall:
            lines.append("  lost: " + ", ".join(f"{k} {v:+.4g}" for k, v in self.shortfall.items()))
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class Allocator:
    """Precomputed allocation ``τ = T φ`` for ``B`` (m × n), DOF subset, weights, mode, limits.

    ``dofs``: controlled rows (names like ``"surge"`` or indices; default all); ``weights``: P
    (n positive numbers or an SPD matrix; default I); ``limits``: (n, 2) ``[min, max]`` thrust;
    ``priority``: weights ``q`` (m) of the DOFs' errors when a request is not achievable
    (default :data:`DEFAULT_PRIORITY`: heave, roll, pitch, yaw 1000× surge and sway).

    Bounded methods (``priority`` and ``maxscale``) work on the planned forces ``x`` (delivered
    forces with ``compensate_eta``, commanded ones otherwise) within ``[lo, hi]`` (η-scaled when
    compensating) and the mode's equalities ``C x = 0``:

    * achievable φ (some x delivers ``B_c x = φ_c``): ``min ½ Σ P_ii x_i²`` s.t. ``B_c x = φ_c``;
    * otherwise ``priority``: ``min Σ q_k (B_k x − φ_k)²`` (the achieved wrench is unique), then
      the least effort among the x giving it; ``maxscale``: the largest ``s ≤ 1`` with ``s φ``
      achievable (bisection to 1e-10 on exact feasibility), then the least effort for ``s φ``.

    Both are solved by a primal active-set method (:func:`_qp_box`), compiled, at every call.
    """

    B: np.ndarray
    dofs: tuple[int, ...] | None = None
    weights: np.ndarray | None = None
    mode: ThrustMode | None = None
    limits: np.ndarray | None = None
    compensate_eta: bool = False
    priority: np.ndarray | None = None
    T: np.ndarray = field(init=False)
    controlled: tuple[int, ...] = field(init=False)

    def __post_init__(self):
        B = np.atleast_2d(np.array(self.B, dtype=float))  # its own (a vehicle's B is read-only)
        m, n = B.shape
        object.__setattr__(self, "B", B)
        dofs = tuple(range(m)) if self.dofs is None else tuple(
            (dof_index(d) if not isinstance(d, (int, np.integer)) else int(d)) for d in self.dofs)
        if any(not 0 <= d < m for d in dofs):
            raise ValueError(f"dofs {dofs} out of range for B with {m} rows")
        if len(set(dofs)) != len(dofs):  # T[:, rows] would keep one column of a repeated row
            raise ValueError(f"dofs {dofs}: a DOF is named twice; name each controlled DOF once")
        object.__setattr__(self, "dofs", dofs)
        if self.mode is not None and self.mode.n != n:
            raise ValueError(f"mode {self.mode.name} is for {self.mode.n} thrusters, B has {n}")
        zero = set(self.mode.zero_dofs) if self.mode is not None else set()
        controlled = tuple(d for d in dofs if d not in zero)
        object.__setattr__(self, "controlled", controlled)
        if self.weights is not None:
            object.__setattr__(self, "weights", _weight_matrix(self.weights, n))
        lim = np.tile([-np.inf, np.inf], (n, 1)) if self.limits is None else np.array(
            self.limits, dtype=float).reshape(n, 2)
        if np.any(lim[:, 0] > 0) or np.any(lim[:, 1] < 0):
            raise ValueError("thrust limits must satisfy min <= 0 <= max for every thruster")
        object.__setattr__(self, "limits", lim)
        C = self.mode.constraint_rows(B) if self.mode is not None else np.zeros((0, n))
        dead = dead_thrusters(lim)
        if dead.size:  # a thruster that gives no thrust either way (limits [0, 0]) is left out
            # of T: T φ would ask it for thrust it cannot give, and uniform scaling would then
            # scale every request to 0 (normal vehicles: no such thruster, T as before)
            C = np.vstack([C, np.eye(n)[dead]])
        object.__setattr__(self, "T", constrained_allocation_matrix(B, controlled, self.weights, C))
        q = np.asarray(DEFAULT_PRIORITY if self.priority is None and m == 6 else
                       (np.ones(m) if self.priority is None else self.priority), dtype=float)
        if q.shape != (m,) or np.any(~np.isfinite(q)) or np.any(q <= 0):
            raise ValueError(f"priority must be {m} positive numbers, got {q}")
        object.__setattr__(self, "priority", q)
        object.__setattr__(self, "_arrays", {})  # to_array per method, built once (frozen)

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

    def _check_wrench(self, phi) -> np.ndarray:
        """``phi`` as floats, refused unless it has one finite component per row of ``B``."""
        phi = np.asarray(phi, dtype=float)
        m = self.B.shape[0]
        if phi.shape != (m,):
            raise ValueError(f"phi: expected {m} components (surge, sway, heave, roll, pitch, "
                             f"yaw: N and N·m), got shape {phi.shape}")
        bad = np.flatnonzero(~np.isfinite(phi))
        if bad.size:
            raise ValueError(f"phi[{bad[0]}] = {float(phi[bad[0]])!r}: expected finite forces and "
                             "moments (a NaN wrench would give NaN thrusts)")
        return phi

    def allocate(self, phi, saturation: str = "priority", tol: float = 1e-9) -> AllocationResult:
        """Allocate ``φ`` (m); ``saturation``: ``"priority"`` (default, as missions fly: exact
        whenever achievable, else weighted least error), ``"maxscale"``, ``"scale"`` (uniform
        scaling of ``T φ``), ``"clip"`` or ``"none"``."""
        phi = self._check_wrench(phi)
        if saturation in ("priority", "maxscale"):
            return self._allocate_bounded(np.asarray(phi, dtype=float), saturation, tol)
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

    def _allocate_bounded(self, phi, method: str, tol: float) -> AllocationResult:
        if phi.shape != (self.B.shape[0],):
            raise ValueError(f"requested force must have {self.B.shape[0]} components")
        ep, en = self.eta
        tau = np.empty(self.n)
        frac = float(allocate_compiled(self._array(method), phi, tau))
        tau0 = self.nominal(phi)
        lo, hi = self.limits[:, 0], self.limits[:, 1]
        delivered = apply_eta(tau, ep, en)
        planned = delivered if self.compensate_eta else tau
        achieved = self.B @ delivered
        ctl = list(self.controlled)
        scale_ref = max(1.0, float(np.abs(phi).max(initial=0.0)))
        exact = frac == 1.0
        representable = bool(np.all(np.abs(self.B[ctl] @ delivered - self.B[ctl] @ planned)
                                    <= tol * scale_ref * 10 + 1e-12)) if exact else bool(
            np.all(np.abs(self.B[ctl] @ apply_eta(tau0, ep, en) - phi[ctl])
                   <= tol * scale_ref * 10 + 1e-12))
        ignored = tuple(d for d in range(len(phi)) if d not in self.controlled
                        and abs(phi[d]) > tol * scale_ref)
        a, r = achieved[ctl], phi[ctl]
        nr, na = float(np.linalg.norm(r)), float(np.linalg.norm(a))
        ang = math.acos(max(-1.0, min(1.0, float(a @ r) / (na * nr)))) if nr > 0 and na > 0 else 0.0
        span = np.maximum(hi - lo, 1e-300)
        limiting = tuple(int(i) for i in np.flatnonzero(
            (np.abs(tau - hi) <= 1e-9 * span) | (np.abs(tau - lo) <= 1e-9 * span)))
        return AllocationResult(tau, delivered, phi, achieved, frac, not exact, representable,
                                ignored, ang, method,
                                self.mode.name if self.mode is not None else None, limiting)

    def max_along(self, phi) -> float:
        """Largest ``s`` such that ``s φ`` is allocated within the limits (uniform scaling)."""
        tau = self.nominal(phi)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(tau > 0, self.limits[:, 1] / tau,
                         np.where(tau < 0, self.limits[:, 0] / tau, np.inf))
        return float(np.min(r)) if r.size else math.inf

    def reach(self, phi) -> float:
        """Largest ``s`` such that ``s φ`` is delivered exactly within the limits by the bounded
        allocation (``maxscale``, the missions' default ``priority`` gives the same wrenches): what
        the thrusters can give along φ, every thrust combination allowed (≥ :meth:`max_along`,
        which keeps the least-effort direction ``T φ``: zero along a direction whose ``T φ``
        needs a thruster the way it cannot push, although others can).  0 when no thrust
        within the limits gives φ (and the mode's equalities); ``inf`` with unbounded limits."""
        phi = self._check_wrench(phi)
        ctl = list(self.controlled)
        if not np.any(phi[ctl]):
            return math.inf
        ep, en = self.eta
        amp = np.maximum(ep, en) if self.compensate_eta else np.ones(self.n)
        most = np.abs(self.B[ctl]) @ (np.maximum(-self.limits[:, 0], self.limits[:, 1]) * amp)
        nz = phi[ctl] != 0
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = float(np.min(most[nz] / np.abs(phi[ctl][nz])))
        if not math.isfinite(bound):
            return math.inf
        if bound == 0.0:
            return 0.0
        big = 2.0 * bound  # beyond every thrust's reach: the bisection brackets the answer
        return float(self.allocate(big * phi, "maxscale").fraction) * big

    def _array(self, method: str) -> np.ndarray:
        """:meth:`to_array`, built once per method (the allocator is frozen), not to be written."""
        a = self._arrays.get(method)
        if a is None:
            a = self._arrays[method] = self._build_array(method)
        return a

    def to_array(self, method: str = "priority") -> np.ndarray:
        """Flat parameters of :func:`allocate_compiled` for a saturation ``method`` (a copy)."""
        return self._array(method).copy()

    def _build_array(self, method: str) -> np.ndarray:
        """Flat parameters of :func:`allocate_compiled` for a saturation ``method``.

        Layout: ``[n, m, compensate, T (n·m, row-major), lower (n), upper (n), η₊ (n), η₋ (n),
        method, k, exact, q (m), P_ii (n), planned lower (n), planned upper (n), B (m·n),
        C (k·n), W (n·n), H (n·n)]`` — ``exact`` = 1 when ``T φ`` delivers every controlled request (no mode
        rank loss); ``C`` the mode's equalities including forced-zero DOFs.
        """
        if method not in _METHOD_CODE:
            raise ValueError(f"saturation must be one of {', '.join(SATURATION_METHODS)}, "
                             f"got {method!r}")
        n, m = self.T.shape
        ep, en = self.eta
        lo, hi = self.limits[:, 0], self.limits[:, 1]
        if self.compensate_eta:
            lo, hi = lo * en, hi * ep
        P = np.eye(n) if self.weights is None else self.weights
        if method in ("priority", "maxscale") and np.any(P != np.diag(np.diag(P))):
            raise ValueError("the bounded allocation methods take diagonal effort weights")
        q = np.array([self.priority[k] if k in self.controlled else 0.0 for k in range(m)])
        C = self.mode.constraint_rows(self.B) if self.mode is not None else np.zeros((0, n))
        ctl = list(self.controlled)
        exact = bool(np.allclose(self.B[ctl] @ self.T[:, ctl], np.eye(len(ctl)), atol=1e-10))
        W = np.zeros((n, n))
        H = np.zeros((n, n))
        _hessians(np.ascontiguousarray(self.B, dtype=np.float64), q,
                  np.ascontiguousarray(np.diag(P), dtype=np.float64), W, H)
        return np.concatenate([[n, m, 1.0 if self.compensate_eta else 0.0], self.T.ravel(),
                               self.limits[:, 0], self.limits[:, 1], ep, en,
                               [_METHOD_CODE[method], C.shape[0], 1.0 if exact else 0.0], q,
                               np.diag(P), lo, hi, self.B.ravel(), C.ravel(), W.ravel(),
                               H.ravel()]).astype(np.float64)


# ---------------------------------------------------------------------------------------------
# Bounded allocation (active set): every achievable wrench exactly, the best one otherwise
# ---------------------------------------------------------------------------------------------
SATURATION_METHODS = ("scale", "clip", "none", "priority", "maxscale")
_METHOD_CODE = {"scale": 0.0, "clip": 1.0, "none": 2.0, "priority": 3.0, "maxscale": 4.0}

#: Default DOF priorities of the weighted least error when a wrench is not achievable: depth and
#: heading (and attitude) before surge and sway (a station-keeping vehicle keeps its depth and
#: heading and gives up position first).
DEFAULT_PRIORITY = (1.0, 1.0, 1e3, 1e3, 1e3, 1e3)


@njit(cache=True)
def _solve_psd(S, k, r, lam, A, b, d0, used, piv):
    """Solve the k×k symmetric PSD system ``S λ = r`` by symmetric Gauss–Jordan with diagonal
    pivoting; a pivot below ``1e-11`` of its row's original diagonal is a dependent row and is
    dropped (its λ set to 0), so a consistent singular system is solved exactly.  The test is
    per row because S's rows can differ in scale by many orders of magnitude."""
    for i in range(k):
        for j in range(k):
            A[i, j] = S[i, j]
        b[i] = r[i]
        d0[i] = A[i, i]
        used[i] = 0.0
    rank = 0
    for _c in range(k):
        bi = -1
        bv = 0.0
        for i in range(k):  # the largest remaining diagonal, relative to its original value
            if used[i] == 0.0 and d0[i] > 0.0:
                v = A[i, i] / d0[i]
                if v > bv:
                    bv, bi = v, i
        if bi < 0 or bv <= 1e-11:
            break
        used[bi] = 1.0
        piv[rank] = bi
        rank += 1
        p = A[bi, bi]
        for i in range(k):
            if i != bi and A[i, bi] != 0.0:
                f = A[i, bi] / p
                for j in range(k):
                    A[i, j] -= f * A[bi, j]
                b[i] -= f * b[bi]
    for i in range(k):
        lam[i] = 0.0
    for c in range(rank):
        i = piv[c]
        lam[i] = b[i] / A[i, i]


@njit(cache=True)
def _chol(H, idx, nf, L):
    """Cholesky ``H[idx, idx] = L Lᵀ`` (nf × nf, H positive definite)."""
    for i in range(nf):
        for j in range(i + 1):
            s = H[idx[i], idx[j]]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = math.sqrt(max(s, 1e-300))
            else:
                L[i, j] = s / L[j, j]


@njit(cache=True)
def _chol_solve(L, nf, b, x):
    for i in range(nf):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(nf - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, nf):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(cache=True)
def _y_from(Y, lam, z, nf, nE, y, accumulate):
    """``y = Y λ − z`` on the free variables (added to ``y`` when ``accumulate``)."""
    for a in range(nf):
        t = -z[a]
        for q in range(nE):
            t += Y[a, q] * lam[q]
        y[a] = y[a] + t if accumulate else t


@njit(cache=True)
def _qp_box(H, g, E, e, nE, lo, hi, x, fixed, maxit, wf, wi):
    """Primal active-set method for ``min ½xᵀHx + gᵀx`` s.t. ``E x = e``, ``lo ≤ x ≤ hi``
    (H positive definite; Nocedal & Wright 2006, Alg. 16.3, with bounds as the inequalities).

    ``x`` must start inside the box and satisfy ``E x = e`` (up to rounding); ``fixed[i]`` is
    −1/+1 for a variable held at its lower/upper bound, 0 when free.  Each iteration solves the
    equality-constrained subproblem on the free variables through its KKT system (Schur
    complement ``E_F H_FF⁻¹ E_Fᵀ``), steps towards it with a ratio test, and frees the bound
    with the most negative multiplier at a subproblem optimum.  Returns the iterations used
    (``maxit`` when it did not converge)."""
    n = x.size
    K = max(nE, 1)
    o = 0
    L = wf[o:o + n * n].reshape(n, n)
    o += n * n
    Y = wf[o:o + n * K].reshape(n, K)
    o += n * K
    S = wf[o:o + K * K].reshape(K, K)
    o += K * K
    A2 = wf[o:o + K * K].reshape(K, K)
    o += K * K
    gt, z0, col, dz, y = wf[o:o + n], wf[o + n:o + 2 * n], wf[o + 2 * n:o + 3 * n], \
        wf[o + 3 * n:o + 4 * n], wf[o + 4 * n:o + 5 * n]
    o += 5 * n
    r, lam, dlam, rr, b2, d0, used = wf[o:o + K], wf[o + K:o + 2 * K], wf[o + 2 * K:o + 3 * K], \
        wf[o + 3 * K:o + 4 * K], wf[o + 4 * K:o + 5 * K], wf[o + 5 * K:o + 6 * K], \
        wf[o + 6 * K:o + 7 * K]
    for q in range(K):
        lam[q] = 0.0
    idx = wi[0:n]
    piv = wi[n:n + K]
    gscale = 0.0
    for i in range(n):
        gscale = max(gscale, abs(g[i]))
        for j in range(n):
            gscale = max(gscale, abs(H[i, j]) * max(abs(lo[j]), abs(hi[j]), 1.0))
    tolmu = 1e-12 * max(gscale, 1e-300)
    for it in range(maxit):
        nf = np.int64(0)  # not the literal 0: callees are typed for it once, not twice
        for i in range(n):
            if fixed[i] == 0:
                idx[nf] = i
                nf += 1
        if nf > 0:
            _chol(H, idx, nf, L)
            for a in range(nf):
                i = idx[a]
                s = g[i]
                for j in range(n):
                    if fixed[j] != 0:
                        s += H[i, j] * x[j]
                gt[a] = s
            _chol_solve(L, nf, gt, z0)
            for q in range(nE):
                for a in range(nf):
                    col[a] = E[q, idx[a]]
                _chol_solve(L, nf, col, y)
                for a in range(nf):
                    Y[a, q] = y[a]
            for q in range(nE):
                s = e[q]
                for j in range(n):
                    if fixed[j] != 0:
                        s -= E[q, j] * x[j]
                for a in range(nf):
                    s += E[q, idx[a]] * z0[a]
                r[q] = s
                for p in range(nE):
                    t = 0.0
                    for a in range(nf):
                        t += E[q, idx[a]] * Y[a, p]
                    S[q, p] = t
            if nE > 0:
                _solve_psd(S, nE, r, lam, A2, b2, d0, used, piv)
            _y_from(Y, lam, z0, nf, nE, y, False)
            # iterative refinement of the KKT solution (H_FF can be ill-conditioned: εW tie-break)
            for _ref in range(2 if nE > 0 else 0):
                for a in range(nf):  # σ = H_FF y + g̃ − E_Fᵀλ
                    i = idx[a]
                    t = gt[a]
                    for a2 in range(nf):
                        t += H[i, idx[a2]] * y[a2]
                    for q in range(nE):
                        t -= E[q, i] * lam[q]
                    col[a] = t
                _chol_solve(L, nf, col, dz)
                for q in range(nE):  # ρ = r' − E_F y, with r' = r − E_F z0
                    t = r[q]
                    for a in range(nf):
                        t -= E[q, idx[a]] * (y[a] + z0[a])
                    for a in range(nf):
                        t += E[q, idx[a]] * dz[a]
                    rr[q] = t
                _solve_psd(S, nE, rr, dlam, A2, b2, d0, used, piv)
                _y_from(Y, dlam, dz, nf, nE, y, True)
                for q in range(nE):
                    lam[q] += dlam[q]
            # ratio test from x towards the subproblem optimum y
            alpha = 1.0
            block = -1
            for a in range(nf):
                i = idx[a]
                p = y[a] - x[i]
                if p < 0.0 and y[a] < lo[i]:
                    t = (lo[i] - x[i]) / p
                    if t < alpha:
                        alpha, block = t, a
                elif p > 0.0 and y[a] > hi[i]:
                    t = (hi[i] - x[i]) / p
                    if t < alpha:
                        alpha, block = t, a
            if block >= 0:
                alpha = max(alpha, 0.0)
                for a in range(nf):
                    i = idx[a]
                    x[i] = x[i] + alpha * (y[a] - x[i])
                i = idx[block]
                if y[block] < lo[i]:
                    x[i] = lo[i]
                    fixed[i] = -1
                else:
                    x[i] = hi[i]
                    fixed[i] = 1
                continue
            for a in range(nf):
                x[idx[a]] = y[a]
        # subproblem optimum: multipliers of the held bounds, μ = Hx + g − Eᵀλ
        worst = -1
        wv = tolmu
        for i in range(n):
            if fixed[i] == 0:
                continue
            mu = g[i]
            for j in range(n):
                mu += H[i, j] * x[j]
            for q in range(nE):
                mu -= E[q, i] * lam[q]
            v = -mu if fixed[i] < 0 else mu  # > 0: leaving the bound lowers the objective
            if v > wv:
                wv, worst = v, i
        if worst < 0:
            return it + 1
        fixed[worst] = 0
    return maxit


@njit(cache=True, inline="always")  # (call overhead: ~8 % of a call)
def _phase1(H, g, C, nC, zero, lo, hi, x, fixed, wf, wi, a, phi, sc):
    """Weighted least error, warm-started from the unconstrained least-effort thrusts
    ``x₀ = T (sc·φ)``: clipped into the box (no equalities: every box point is feasible) or,
    with the mode's equalities, scaled uniformly into it (``C x₀ = 0`` holds for ``T``)."""
    n = x.size
    m = int(a[1])
    s = 1.0
    for i in range(n):
        t = 0.0
        for j in range(m):
            t += a[3 + i * m + j] * phi[j]
        t *= sc
        x[i] = t
        fixed[i] = 0
        if t > hi[i]:
            s = min(s, hi[i] / t)
        elif t < lo[i]:
            s = min(s, lo[i] / t)
    for i in range(n):
        if nC == 0:
            if x[i] >= hi[i]:
                x[i] = hi[i]
                fixed[i] = 1
            elif x[i] <= lo[i]:
                x[i] = lo[i]
                fixed[i] = -1
        else:
            x[i] = min(max(x[i] * s, lo[i]), hi[i])
    return _qp_box(H, g, C, zero, nC, lo, hi, x, fixed, 8 * x.size + 20, wf, wi)


@njit(cache=True)
def _residual(Bp, q, m, n, x, target):
    """max |B_k x − target_k| over the controlled rows (q_k > 0)."""
    r = 0.0
    for k in range(m):
        if q[k] > 0.0:
            s = -target[k]
            for i in range(n):
                s += Bp[k, i] * x[i]
            r = max(r, abs(s))
    return r


@njit(cache=True, inline="always")  # (call overhead: ~8 % of a call)
def _exact(Bp, q, C, nC, m, n, W, lo, hi, target, x, fixed, E, e, g0, wf, wi):
    """Least weighted effort ``min ½ Σ w_i x_i²`` with ``B_c x = target``, ``C x = 0`` and the
    bounds, from a start ``x`` that (nearly) delivers ``target``; returns the residual."""
    nE = np.int64(0)  # not the literal 0: _qp_box is compiled for it once, not twice
    for k in range(m):
        if q[k] > 0.0:
            for i in range(n):
                E[nE, i] = Bp[k, i]
            e[nE] = target[k]
            nE += 1
    for c in range(nC):
        for i in range(n):
            E[nE, i] = C[c, i]
        e[nE] = 0.0
        nE += 1
    for i in range(n):
        g0[i] = 0.0
    _qp_box(W, g0, E, e, nE, lo, hi, x, fixed, 8 * n + 20, wf, wi)
    r = _residual(Bp, q, m, n, x, target)
    for c in range(nC):
        t = 0.0
        for i in range(n):
            t += C[c, i] * x[i]
        r = max(r, abs(t))
    return r


@njit(cache=True, inline="always")  # (call overhead: ~8 % of a call)
def _try_scaled(sc, a, phi, target, g, Bp, q, C, nC, m, n, H, W, lo, hi, x, x1, fixed, zero, E,
                e, g0, wf, wi, scale):
    """Is ``sc·φ`` achievable?  Phase 1 (weighted least error, kept in ``x1``), then, when its
    error is small, the least-effort exact solution (``x``); True when that one delivers
    ``sc·φ`` (and the mode's equalities) to 1e-11 of the request's size."""
    for k in range(m):
        target[k] = sc * phi[k]
    for i in range(n):
        t = 0.0
        for k in range(m):
            t += Bp[k, i] * q[k] * target[k]
        g[i] = -t
    _phase1(H, g, C, nC, zero, lo, hi, x, fixed, wf, wi, a, phi, sc)
    for i in range(n):
        x1[i] = x[i]
    if _residual(Bp, q, m, n, x, target) > 1e-6 * scale:
        return False
    return _exact(Bp, q, C, nC, m, n, W, lo, hi, target, x, fixed, E, e, g0, wf, wi) \
        <= 1e-11 * scale


@njit(cache=True)
def _hessians(Bp, q, w, W, H):
    """Effort weights ``W = diag(w)`` and the phase-1 Hessian ``BᵀQB + εW`` (ε: 1e-13 of the
    scale of BᵀQB: a tie-break towards least effort), constant for an allocator."""
    m, n = Bp.shape
    for i in range(n):
        for j in range(n):
            W[i, j] = 0.0
        W[i, i] = w[i]
    trb = 0.0
    trw = 0.0
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(m):
                s += Bp[k, i] * q[k] * Bp[k, j]
            H[i, j] = s
        trb += H[i, i]
        trw += W[i, i]
    eps = 1e-13 * trb / max(trw, 1e-300)
    for i in range(n):
        H[i, i] += eps * W[i, i]


@njit(cache=True)
def _bounded(a, phi, tau, n, m, method, s0):
    """Active-set allocation (methods ``priority`` and ``maxscale``); see :class:`Allocator`."""
    comp = a[2] != 0.0
    oep = 3 + n * m + 2 * n
    oen = oep + n
    o = oen + n
    nC = int(a[o + 1])
    oq = o + 3
    ow = oq + m
    olo = ow + n
    ohi = olo + n
    oB = ohi + n
    oC = oB + m * n
    q = a[oq:oq + m]
    lo = a[olo:olo + n]
    hi = a[ohi:ohi + n]
    Bp = a[oB:oB + m * n].reshape(m, n)
    C = a[oC:oC + nC * n].reshape(max(nC, 0), n)
    K = m + nC
    oW = oC + nC * n  # W and the phase-1 Hessian, precomputed by Allocator.to_array
    W = a[oW:oW + n * n].reshape(n, n)
    H = a[oW + n * n:oW + 2 * n * n].reshape(n, n)
    nfl = 5 * n + K * n + 2 * K + m + 1 + (n * n + n * K + 2 * K * K + 5 * n + 7 * K)
    # one block for every work array (no allocation in the iterations); every entry is written
    # before it is read, except ``zero`` and ``best`` (zeroed here)
    blk = np.empty(nfl)
    o = 0
    g, x, x1, g0, best = blk[o:o + n], blk[o + n:o + 2 * n], blk[o + 2 * n:o + 3 * n], \
        blk[o + 3 * n:o + 4 * n], blk[o + 4 * n:o + 5 * n]
    for i in range(n):
        best[i] = 0.0
    o += 5 * n
    E = blk[o:o + K * n].reshape(K, n)
    o += K * n
    e = blk[o:o + K]
    zero = blk[o + K:o + 2 * K]
    target = blk[o + 2 * K:o + 2 * K + m]
    o += 2 * K + m + 1
    wf = blk[o:]
    for k in range(K):
        zero[k] = 0.0
    iblk = np.empty(3 * n + K, np.int64)
    fixed = iblk[0:n]
    wi = iblk[n:]
    scale = 1.0
    for k in range(m):
        if q[k] > 0.0:
            scale = max(scale, abs(phi[k]))
    frac = 1.0
    # method 3 (priority): one try at s = 1 — weighted least error with DOF priorities; the other
    # methods: the largest s ≤ 1 with s·φ achievable (bisection on exact feasibility), then, if no
    # try succeeded, the bracket's start s0 (uniform scaling).  One call site of _try_scaled
    # (inlined: compiled once, not three times); phase 0: the priority try, 1: bisection,
    # 2: the bracket's start, 3: done (priority), 4: done (bisection).
    slo = max(s0, 0.0)
    shi = 1.0
    have = False
    it = 0
    phase = 0 if method == 3 else 1
    while phase < 3:
        if phase == 0:
            s_try = 1.0
        elif phase == 2:
            s_try = slo
        else:
            s_try = shi if it == 0 else 0.5 * (slo + shi)
        ok = _try_scaled(s_try, a, phi, target, g, Bp, q, C, nC, m, n, H, W, lo, hi, x, x1,
                         fixed, zero, E, e, g0, wf, wi, scale)
        if phase == 0:
            if not ok:
                for i in range(n):  # not achievable: the phase-1 optimum (its εW term picks the
                    x[i] = x1[i]  # least effort among the thrusts giving the best wrench, to O(ε))
                frac = -1.0  # computed below
            phase = 3
        elif phase == 2:
            for i in range(n):
                best[i] = x[i]
            phase = 4
        else:
            done = False
            if ok:
                slo = s_try
                have = True
                for i in range(n):
                    best[i] = x[i]
                done = it == 0
            else:
                shi = s_try
            it += 1
            if done or shi - slo <= 1e-10 or it == 40:
                # the bracket's start (uniform scaling) is solved when no try succeeded
                phase = 2 if not have and slo > 0.0 else 4
    if phase == 4:
        for i in range(n):
            x[i] = best[i]
        frac = slo
    for i in range(n):  # clamp rounding and convert the planned force to the command
        t = min(max(x[i], lo[i]), hi[i])
        if comp:
            t = t / (a[oep + i] if t >= 0.0 else a[oen + i])
        tau[i] = t
    if frac < 0.0:  # achieved fraction along the request
        num = 0.0
        den = 0.0
        for k in range(m):
            if q[k] > 0.0:
                s = 0.0
                for i in range(n):
                    s += Bp[k, i] * x[i]
                num += s * phi[k]
                den += phi[k] * phi[k]
        frac = num / den if den > 0.0 else 1.0
        frac = min(frac, 1.0 - 1e-16)  # < 1: not achieved
    return frac


# ---------------------------------------------------------------------------------------------
# Compiled allocation for simulation loops
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def _fraction(a, phi, tau, n, m):
    """Achieved fraction ``(a·r)/|r|²`` of the controlled request ``r`` for commands ``tau``."""
    comp = a[2] != 0.0
    oep = 3 + n * m + 2 * n
    oen = oep + n
    o = oen + n
    oq = o + 3
    oB = oq + m + 3 * n
    num = 0.0
    den = 0.0
    for k in range(m):
        if a[oq + k] > 0.0:
            d = 0.0
            for i in range(n):
                t = tau[i]
                if comp:
                    t = t * (a[oep + i] if t >= 0.0 else a[oen + i])
                d += a[oB + k * n + i] * t
            num += d * phi[k]
            den += phi[k] * phi[k]
    return min(num / den, 1.0) if den > 0.0 else 1.0


@njit(cache=True, inline="always")
def allocate_compiled(a, phi, tau):
    """Allocate ``φ`` into ``tau`` (n) by the method stored in ``a``; returns the achieved fraction.

    ``a`` is :meth:`Allocator.to_array`.  The unsaturated thrusts ``τ₀ = T φ`` (η-compensated if
    the flag is set) are computed first; when they are inside the limits (and deliver φ) they are
    the answer for every method (the least-effort solution is then the unconstrained one).
    Otherwise: ``scale`` → ``s τ₀`` with ``s`` the uniform factor (returned); ``clip`` → τ₀
    clipped; ``none`` → τ₀; ``priority``/``maxscale`` → the active-set solution of
    :class:`Allocator` (returned value: the achieved fraction along φ, < 1 when not achieved).
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
    o = oen + n
    method = 0 if a.size <= o else int(a[o])
    if method == 0:
        for i in range(n):
            tau[i] *= s
        return s
    if method == 2:
        return 1.0
    if method == 1:
        if s < 1.0:
            for i in range(n):
                tau[i] = min(max(tau[i], a[olo + i]), a[ohi + i])
            return _fraction(a, phi, tau, n, m)
        return 1.0
    if s == 1.0 and a[o + 2] == 1.0:  # τ₀ delivers every φ exactly when inside the limits
        return 1.0
    return _bounded(a, phi, tau, n, m, method, s)


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
