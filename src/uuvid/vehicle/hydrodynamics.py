"""Hydrodynamic and hydrostatic terms of the 6-DOF model (NumPy reference forms).

Sign convention of our files and parameter records: **positive magnitudes**.

* Added mass ``M_A`` is positive (semi-)definite: ``M_A = −diag(X_u̇, Y_v̇, Z_ẇ, K_ṗ, M_q̇, N_ṙ)``
  in Fossen's derivative notation, so a BlueROV2 with ``X_u̇ = −5.5 kg`` is written ``5.5``.
  It enters the mass matrix, ``M = M_RB + M_A`` (Fossen 2011, §6.3), never as a force computed
  from a differentiated acceleration.
* Damping magnitudes ``D_L = −diag(X_u, Y_v, Z_w, K_p, M_q, N_r)`` and
  ``D_Q = −diag(X_{u|u|}, …, N_{r|r|})`` (Fossen 2011, §6.4): the damping force is
  ``−D_L ν_r − D_Q (|ν_r| ∘ ν_r)``.  With 36 values, ``D_Q`` multiplies the vector
  ``|ν_r| ∘ ν_r`` (element-wise), i.e. the off-diagonal entry ``D_Q[i, j]`` is ``−X_{i, |j|j}``.
  :func:`from_fossen_derivatives` converts derivative sets (negative numbers) to magnitudes.
* Restoring forces for weight ``W`` at ``r_g`` and buoyancy ``B`` at ``r_b`` (Fossen 2011,
  eqs. 4.5–4.6 written with ``R(q)``; NED, z down)::

      g(η) = −[ Rᵀ(f_g + f_b) ; r_g × Rᵀf_g + r_b × Rᵀf_b ],  f_g = [0, 0, W]ᵀ, f_b = [0, 0, −B]ᵀ

  so with ``k = Rᵀ e_z`` (the down direction in body axes)
  ``−g(η) = [(W − B) k ; (W r_g − B r_b) × k]``.  A vehicle whose CB is above its CG rights itself.
"""

from __future__ import annotations

import numpy as np

from uuvid.vehicle.rigid_body import coriolis_from_mass


def six_by_six(values, what: str = "matrix") -> np.ndarray:
    """6 values → diagonal matrix; 36 values (row-major) or a 6×6 array → that matrix."""
    a = np.asarray(values, dtype=float)
    if a.shape == (6,):
        return np.diag(a)
    if a.shape == (36,):
        return a.reshape(6, 6).copy()
    if a.shape == (6, 6):
        return a.copy()
    raise ValueError(f"{what}: expected 6 (diagonal) or 36 (6×6, row-major) values, got shape "
                     f"{a.shape}")


def from_fossen_derivatives(values) -> np.ndarray:
    """Fossen derivatives (``X_u̇``, ``X_u``, ``X_{u|u|}`` …, negative) → our positive magnitudes.

    ``D_L = −[X_u …]``, ``D_Q = −[X_{u|u|} …]``, ``M_A = −[X_u̇ …]`` (6 or 36 values, same shape).
    """
    return -np.asarray(values, dtype=float)


def added_mass_coriolis(M_A, nu_r) -> np.ndarray:
    """``C_A(ν_r)`` from ``M_A`` (Fossen 2011, §6.3, Theorem 3.2 form); skew-symmetric."""
    return coriolis_from_mass(M_A, nu_r)


def damping_force(D_L, D_Q, nu_r) -> np.ndarray:
    """``D(ν_r) ν_r = D_L ν_r + D_Q (|ν_r| ∘ ν_r)`` (magnitudes; the force is minus this)."""
    nu_r = np.asarray(nu_r, dtype=float)
    return np.asarray(D_L) @ nu_r + np.asarray(D_Q) @ (np.abs(nu_r) * nu_r)


def restoring_forces(weight: float, buoyancy: float, r_g, r_b, R) -> np.ndarray:
    """``g(η)`` (Fossen 2011, eq. 4.6 with the rotation matrix ``R`` body → NED); enters as −g."""
    R = np.asarray(R, dtype=float)
    f_g = R.T @ np.array([0.0, 0.0, weight])
    f_b = R.T @ np.array([0.0, 0.0, -buoyancy])
    return -np.concatenate([f_g + f_b,
                            np.cross(np.asarray(r_g, float), f_g)
                            + np.cross(np.asarray(r_b, float), f_b)])
