"""Published Wageningen B-series data (issue 21 item 2): the B4-70 P/D 1.0 four-quadrant table
checked in quadrant 1 against the independent Oosterveld & van Oossanen (1975) polynomial."""

import numpy as np
import pytest

from uuvid.thruster.inflow import FourQuadrantMap, wageningen_b4_70, wageningen_b4_70_approx
from uuvid.thruster.wageningen import polynomial_table, wageningen_open_water

J = np.linspace(0.0, 1.0, 41)
B4_70 = dict(ae_a0=0.70, z=4)
# Two regressions of the same NSMB tests (Fourier in β vs polynomial in J, P/D, A_E/A_0, Z):
# measured max |ΔK_T| = 3.5 % of K_T(0) and |ΔK_Q| = 1.4 % of K_Q(0) over 0 ≤ J ≤ 1.
TOL_KT, TOL_KQ = 0.05, 0.03


def _gap(fq: FourQuadrantMap, pd: float = 1.0):
    kt, kq = fq.kt_kq(J)
    pt, pq = wageningen_open_water(J, pd, **B4_70)
    return np.max(np.abs(kt - pt)) / pt[0], np.max(np.abs(kq - pq)) / pq[0]


def test_polynomial_has_the_published_term_counts():
    t = polynomial_table()
    assert t["KT"].shape == (39, 5) and t["KQ"].shape == (47, 5)
    # exponents as published: J ≤ 3, P/D ∈ {0, 1, 2, 3, 6}, A_E/A_0 ≤ 2, Z ≤ 2
    for a in t.values():
        assert set(a[:, 1]) <= {0, 1, 2, 3} and set(a[:, 2]) <= {0, 1, 2, 3, 6}
        assert set(a[:, 3]) <= {0, 1, 2} and set(a[:, 4]) <= {0, 1, 2}


def test_polynomial_range_is_enforced():
    with pytest.raises(ValueError, match="pd"):
        wageningen_open_water(0.5, 1.6, **B4_70)


def test_published_map_agrees_with_the_polynomial_in_quadrant_1():
    dkt, dkq = _gap(wageningen_b4_70())
    assert dkt < TOL_KT and dkq < TOL_KQ


def test_the_check_can_tell_the_pitch_ratio():
    # the same comparison against the polynomial at P/D 0.9 or 1.1 fails: the table is P/D 1.0
    for pd in (0.9, 1.1):
        dkt, dkq = _gap(wageningen_b4_70(), pd)
        assert dkt > 2 * TOL_KT or dkq > 2 * TOL_KQ


def test_published_map_is_diameter_free_and_thrust_vanishes_near_the_polynomial_zero():
    m = wageningen_b4_70()
    np.testing.assert_allclose(m.kt_kq(J)[0], wageningen_b4_70(0.076).kt_kq(J)[0], rtol=1e-14)
    # J at zero thrust: the polynomial's root vs the map's, both just above J = 1
    jj = np.linspace(0.9, 1.2, 3001)
    j_map = jj[np.argmax(m.kt_kq(jj)[0] < 0)]
    j_poly = jj[np.argmax(wageningen_open_water(jj, 1.0, **B4_70)[0] < 0)]
    assert abs(j_map - j_poly) < 0.05


def test_published_map_is_much_closer_to_the_polynomial_than_the_approximation():
    # the recalled-points approximation (kept for comparison) is off by 8 % (K_T) and 14 % (K_Q)
    pub, app = _gap(wageningen_b4_70()), _gap(wageningen_b4_70_approx())
    assert max(app) > 0.05 and max(pub) < max(app) / 2


def test_published_map_provenance_is_stated():
    m = wageningen_b4_70()
    assert "Lammeren" in m.source and "approx" not in m.name
    assert len(m.ct_a) == 21
