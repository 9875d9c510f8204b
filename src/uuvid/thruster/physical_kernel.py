"""Compiled steady state of the voltage-aware physical thruster model (:mod:`uuvid.thruster.physical`).

:meth:`~uuvid.thruster.physical.PhysicalModel.predict` is called tens of thousands of times by
the battery and station-keeping analyses (a supply fixed point per held wrench, an 801-point
command grid per voltage); this is its arithmetic, element by element, in the same order (so the
same numbers, bit for bit), without NumPy's per-call overhead::

    d(c): dead band, then s (1 + κ (s − 1)) per direction;   v = d V_s
    ω = −2 c_c / (b + sqrt(b² − 4 k_q c_c))   (c_c = Q_c − k_e |v|/R < 0, else 0),  b = k_e²/R + B_v
    T = sgn(v) k_t ω²,  I_m = (|v| − k_e ω)/R,  I_s = |d| I_m,  Q = sgn(v) k_q ω²
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Order of the parameters of :func:`steady_state_nb`.
PARAMS = ("full_rev", "edge_rev", "edge_fwd", "full_fwd", "curvature_fwd", "curvature_rev",
          "back_emf_constant", "resistance", "viscous", "coulomb", "kq_fwd", "kq_rev", "kt_fwd",
          "kt_rev")


@njit(cache=True)
def steady_state_nb(c, vs, p, out):
    """Rows of ``out`` (7 × n): duty, motor voltage, speed, thrust, motor current, supply current,
    torque at commands ``c`` and supply voltages ``vs`` (1-D, n; ``vs`` of size 1 is used for
    every command); ``p``: :data:`PARAMS`.  A NaN command reads as the dead band, as the NumPy
    form's ``where`` does.  Returns ``-1``, or the index of the first supply voltage that is not
    positive and finite (nothing computed)."""
    fr, er, ef, ff, cf, cr, ke, r, visc, coul, kqf, kqr, ktf, ktr = (
        p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12], p[13])
    b = ke * ke / r + visc
    for k in range(vs.size):
        if not (vs[k] > 0.0 and vs[k] < np.inf):
            return k
    one = vs.size == 1
    for k in range(c.size):
        x = c[k]
        if x < fr:
            x = fr
        if x > ff:
            x = ff
        s_f = (x - ef) / (ff - ef)
        if s_f < 0.0:
            s_f = 0.0
        if s_f > 1.0:
            s_f = 1.0
        s_r = (er - x) / (er - fr)
        if s_r < 0.0:
            s_r = 0.0
        if s_r > 1.0:
            s_r = 1.0
        if x > ef:
            d = s_f * (1.0 + cf * (s_f - 1.0))
        elif x < er:
            d = -(s_r * (1.0 + cr * (s_r - 1.0)))
        else:  # the dead band (and a NaN command, as NumPy's where reads it)
            d = 0.0
        v = d * (vs[0] if one else vs[k])
        sgn = np.sign(v)
        av = abs(v)
        kq = kqf if sgn >= 0 else kqr
        kt = ktf if sgn >= 0 else ktr
        cc = coul - ke * av / r
        q = b * b - 4.0 * kq * cc
        if q < 0.0:
            q = 0.0
        disc = np.sqrt(q)
        w = -2.0 * cc / (b + disc) if cc < 0 else 0.0
        im = (av - ke * w) / r
        out[0, k] = d
        out[1, k] = v
        out[2, k] = sgn * w
        out[3, k] = sgn * kt * w * w
        out[4, k] = sgn * im
        out[5, k] = abs(d) * im
        out[6, k] = sgn * kq * w * w
    return -1
