"""Rigid-body kinetics in the body frame about the body origin CO (NumPy reference forms).

Fossen (2011), *Handbook of Marine Craft Hydrodynamics and Motion Control*, §3.3:

* ``M_RB = [[m I₃, −m S(r_g)], [m S(r_g), I_o]]`` with ``I_o = I_g − m S(r_g)²`` (parallel-axis
  theorem; ``I_g`` is the inertia tensor about the CG, ``r_g`` the CG in body axes);
* the Coriolis–centripetal matrix from any symmetric positive-definite inertia matrix ``M``
  (Fossen 2011, Theorem 3.2, Kirchhoff's equations)::

      C(ν) = [[0₃,               −S(M₁₁ν₁ + M₁₂ν₂)],
              [−S(M₁₁ν₁ + M₁₂ν₂), −S(M₂₁ν₁ + M₂₂ν₂)]]

  which is skew-symmetric for every ν, so ``νᵀC(ν)ν = 0`` (the rigid body does no work on
  itself).  The same formula with ``M_A`` gives ``C_A`` (:mod:`uuvid.vehicle.hydrodynamics`).
"""

from __future__ import annotations

import numpy as np


def skew_ref(a) -> np.ndarray:
    """``S(a)`` with ``S(a) b = a × b`` (Fossen 2011, eq. 2.10)."""
    a = np.asarray(a, dtype=float)
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def inertia_about_origin(mass: float, inertia_cg, r_g) -> np.ndarray:
    """``I_o = I_g − m S(r_g)²`` (parallel-axis theorem, Fossen 2011, §3.3)."""
    S = skew_ref(r_g)
    return np.asarray(inertia_cg, dtype=float) - mass * S @ S


def rigid_body_mass_matrix(mass: float, inertia_cg, r_g) -> np.ndarray:
    """``M_RB`` about CO (Fossen 2011, §3.3): ``[[m I, −m S(r_g)], [m S(r_g), I_o]]``."""
    S = skew_ref(r_g)
    M = np.zeros((6, 6))
    M[:3, :3] = mass * np.eye(3)
    M[:3, 3:] = -mass * S
    M[3:, :3] = mass * S
    M[3:, 3:] = inertia_about_origin(mass, inertia_cg, r_g)
    return M


def coriolis_from_mass(M, nu) -> np.ndarray:
    """``C(ν)`` from a symmetric inertia matrix (Fossen 2011, Theorem 3.2); skew-symmetric."""
    M = 0.5 * (np.asarray(M, dtype=float) + np.asarray(M, dtype=float).T)
    nu = np.asarray(nu, dtype=float)
    a1 = M[:3, :3] @ nu[:3] + M[:3, 3:] @ nu[3:]
    a2 = M[3:, :3] @ nu[:3] + M[3:, 3:] @ nu[3:]
    C = np.zeros((6, 6))
    C[:3, 3:] = -skew_ref(a1)
    C[3:, :3] = -skew_ref(a1)
    C[3:, 3:] = -skew_ref(a2)
    return C


def rigid_body_coriolis(M_RB, nu) -> np.ndarray:
    """``C_RB(ν)`` (Fossen 2011, Theorem 3.2 applied to ``M_RB``)."""
    return coriolis_from_mass(M_RB, nu)
