"""Published Wageningen B-series data: the open-water polynomials and a four-quadrant table.

* :func:`wageningen_open_water` — ``K_T``, ``K_Q`` of a B-series screw from the regression
  polynomials of Oosterveld & van Oossanen (1975, Int. Shipbuilding Progress 22(251), Table 1;
  reprinted in Bernitsas, Ray & Kinley 1981, UMich NAME report 237)::

      K_T = Σ C_T,i J^s_i (P/D)^t_i (A_E/A_0)^u_i Z^v_i     (39 terms)
      K_Q = Σ C_Q,i J^s_i (P/D)^t_i (A_E/A_0)^u_i Z^v_i     (47 terms)

  at Reynolds number 2·10⁶; coefficients in ``data/wageningen_b_polynomial.csv``.

* :func:`four_quadrant_table` — the Fourier coefficients ``A_T, B_T, A_Q, B_Q`` (k = 0 … N) of a
  published four-quadrant table (``data/wageningen_b4_70_pd10_4q.csv``, with its provenance in the
  file header); :func:`uuvid.thruster.inflow.wageningen_b4_70` makes the map from it.
"""

from __future__ import annotations

import functools
from importlib import resources

import numpy as np

#: Range of the polynomials (Bernitsas et al. 1981): blades, blade-area ratio, pitch ratio.
POLYNOMIAL_RANGE = {"z": (2, 7), "ae_a0": (0.30, 1.05), "pd": (0.5, 1.4)}


def _data_lines(name: str) -> list[list[str]]:
    text = resources.files("uuvid.thruster").joinpath(f"data/{name}").read_text()
    rows = [ln.split(",") for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    return rows[1:]  # drop the header row


@functools.cache
def polynomial_table() -> dict[str, np.ndarray]:
    """``{"KT": (39, 5), "KQ": (47, 5)}`` arrays of ``(C, s, t, u, v)``."""
    out: dict[str, list] = {"KT": [], "KQ": []}
    for kind, *vals in _data_lines("wageningen_b_polynomial.csv"):
        out[kind].append([float(v) for v in vals])
    return {k: np.asarray(v, float) for k, v in out.items()}


def wageningen_open_water(J, pd: float, ae_a0: float, z: int):
    """Open-water ``(K_T, K_Q)`` of a Wageningen B-series screw at advance ratio ``J = u_a/(nD)``
    (Oosterveld & van Oossanen 1975, Table 1).  ``pd`` pitch ratio P/D, ``ae_a0`` expanded
    blade-area ratio, ``z`` number of blades; valid over :data:`POLYNOMIAL_RANGE` and
    ``0 ≤ J`` up to zero thrust."""
    for key, val in (("pd", pd), ("ae_a0", ae_a0), ("z", z)):
        lo, hi = POLYNOMIAL_RANGE[key]
        if not lo <= val <= hi:
            raise ValueError(f"Wageningen B-series polynomial: {key} = {val!r} outside [{lo}, {hi}]")
    J = np.asarray(J, float)
    res = []
    for kind in ("KT", "KQ"):
        c, s, t, u, v = polynomial_table()[kind].T
        res.append((c * J[..., None] ** s * pd ** t * ae_a0 ** u * float(z) ** v).sum(-1))
    return res[0], res[1]


@functools.cache
def four_quadrant_table(name: str = "wageningen_b4_70_pd10_4q.csv") -> tuple[tuple[float, ...], ...]:
    """``(A_T, B_T, A_Q, B_Q)`` (k = 0 … N) of a four-quadrant table in ``data/`` (plain
    ``C_T*``, ``C_Q*``; convention in the file header)."""
    rows = np.asarray([[float(v) for v in r] for r in _data_lines(name)], float)
    if not np.array_equal(rows[:, 0], np.arange(len(rows))):
        raise ValueError(f"{name}: the k column must be 0, 1, …, N in order")
    return tuple(tuple(float(x) for x in rows[:, i]) for i in range(1, 5))
