"""The coupled horizontal-plane model (surge, sway, yaw) of a vehicle that holds depth, roll, pitch.

Fossen (2011, §6.5 and eq. 7.12–7.14: the 3-DOF manoeuvring model) with Caccia et al. (2000,
eq. 1) restricted to ``ν = [u, v, 0, 0, 0, r]``, diagonal ``M = M_RB + M_A`` (``m_u = m + X_u̇``,
``m_v = m + Y_v̇``, ``I_r = I_z + N_ṙ``, as positive magnitudes) and diagonal drag::

    m_u u̇ − m_v v r           = X − k_u u − k_qu u|u| + b_u
    m_v v̇ + m_u u r           = Y − k_v v − k_qv v|v| + b_v
    I_r ṙ − (m_u − m_v) u v   = N − k_r r − k_qr r|r| + b_r
    ψ̇ = r

The Coriolis/centripetal terms are ``C(ν)ν`` of the 6-DOF model (:mod:`uuvid.vehicle.model`,
Kirchhoff form ``C(ν)ν = [ω × M₁₁ν₁ ; ν₁ × M₁₁ν₁ + ω × M₂₂ω]``, Fossen 2011 Thm 3.2) with rigid
body and added mass together (no current, so ``ν_r = ν``): ``ω × M₁₁ν₁ = (−m_v v r, m_u u r, 0)``
and ``(ν₁ × M₁₁ν₁)_z = (m_v − m_u) u v`` — the Munk moment, which turns a vehicle with
``m_v > m_u`` broadside to its motion.  ``b_*`` are constant force/moment biases (a tether, a
DVL misalignment, an unmodelled offset).

This *is* the 6-DOF model when heave, roll and pitch stay zero and ``M``, ``D_L``, ``D_Q`` are
diagonal with the centre of gravity at the origin (``r_g = 0``: a vertical ``z_g`` couples
surge with pitch and sway with roll through ``M_RB``, which this model leaves out — the vehicle's
restoring moments are taken to hold roll and pitch level).  ``tests/test_dive_horizontal.py``
checks the right-hand side against :func:`uuvid.vehicle.model.vehicle_rhs` to 1e-12.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["HorizontalParams", "horizontal_rhs", "horizontal_params", "HORIZONTAL_NAMES"]

#: parameter order of :meth:`HorizontalParams.as_array`
HORIZONTAL_NAMES = ("m_u", "m_v", "I_r", "k_u", "kq_u", "k_v", "kq_v", "k_r", "kq_r",
                    "b_u", "b_v", "b_r")


@dataclass(frozen=True)
class HorizontalParams:
    """Masses with added mass ``m_u``, ``m_v`` [kg], inertia ``I_r`` [kg·m²], linear and
    quadratic drag per DOF (N·s/m, N·s²/m², N·m·s/rad, N·m·s²/rad²) and biases (N, N, N·m)."""

    m_u: float
    m_v: float
    I_r: float
    k_u: float
    kq_u: float
    k_v: float
    kq_v: float
    k_r: float
    kq_r: float
    b_u: float = 0.0
    b_v: float = 0.0
    b_r: float = 0.0

    def as_array(self) -> np.ndarray:
        return np.array([getattr(self, k) for k in HORIZONTAL_NAMES], float)

    def to_dict(self) -> dict:
        return {k: float(getattr(self, k)) for k in HORIZONTAL_NAMES}

    @classmethod
    def from_array(cls, a) -> HorizontalParams:
        return cls(*(float(x) for x in a))


def horizontal_params(params, biases=(0.0, 0.0, 0.0)) -> HorizontalParams:
    """The horizontal model of :class:`~uuvid.vehicle.model.VehicleParams`: the (u, v, r) diagonal
    of ``M_RB + M_A``, ``D_L``, ``D_Q`` (off-diagonal terms are left out)."""
    M = np.asarray(params.M_RB) + np.asarray(params.added_mass)
    DL, DQ = np.asarray(params.linear_damping), np.asarray(params.quadratic_damping)
    return HorizontalParams(float(M[0, 0]), float(M[1, 1]), float(M[5, 5]),
                            float(DL[0, 0]), float(DQ[0, 0]), float(DL[1, 1]), float(DQ[1, 1]),
                            float(DL[5, 5]), float(DQ[5, 5]), *map(float, biases))


def horizontal_rhs(u, v, r, X, Y, N, theta):
    """``(u̇, v̇, ṙ)`` of the module's equations (NumPy, vectorised; ``theta`` =
    :meth:`HorizontalParams.as_array` order)."""
    m_u, m_v, I_r, k_u, kq_u, k_v, kq_v, k_r, kq_r, b_u, b_v, b_r = theta
    du = (X + m_v * v * r - k_u * u - kq_u * u * np.abs(u) + b_u) / m_u
    dv = (Y - m_u * u * r - k_v * v - kq_v * v * np.abs(v) + b_v) / m_v
    dr = (N + (m_u - m_v) * u * v - k_r * r - kq_r * r * np.abs(r) + b_r) / I_r
    return du, dv, dr
