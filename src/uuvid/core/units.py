"""Unit conversions at the edge: the only place where non-SI numbers are turned into SI.

McLean (1991) works in ft, lb, slug and oz·in; Laidani et al. print kgf; Caccia et al. use degrees.
Constants are exact definitions (international foot and pound, standard gravity).
"""

from __future__ import annotations

import math

FT = 0.3048  # m per ft
INCH = 0.0254  # m per in
G0 = 9.80665  # m/s^2, standard gravity
LBF = 4.4482216152605  # N per lbf
OZF = LBF / 16.0  # N per ozf
OZ_IN = OZF * INCH  # N·m per oz·in  (= 7.0615518e-3)
SLUG = LBF / FT  # kg per slug (= 14.5939 kg)
SLUG_PER_FT3 = SLUG / FT**3  # kg/m^3 per slug/ft^3
FT2 = FT**2
KGF = G0  # N per kgf
REV_S = 2.0 * math.pi  # rad/s per rev/s (= 60 rpm)
RPM = REV_S / 60.0  # rad/s per rev/min
DEG = math.pi / 180.0
KNOT = 1852.0 / 3600.0  # m/s per knot (international nautical mile per hour)
KMH = 1.0 / 3.6  # m/s per km/h


def ft(x):
    """ft → m."""
    return x * FT


def inch(x):
    """in → m."""
    return x * INCH


def lbf(x):
    """lbf → N."""
    return x * LBF


def to_lbf(x):
    """N → lbf."""
    return x / LBF


def oz_in(x):
    """oz·in (torque) → N·m."""
    return x * OZ_IN


def to_oz_in(x):
    """N·m → oz·in."""
    return x / OZ_IN


def oz_in_s2(x):
    """oz·in·s² (rotational inertia) → kg·m²."""
    return x * OZ_IN


def slug_per_ft3(x):
    """slug/ft³ → kg/m³."""
    return x * SLUG_PER_FT3


def ft2(x):
    """ft² → m²."""
    return x * FT2


def ft_per_rad(x):
    """pitch ft/rad → m/rad."""
    return x * FT


def to_ft_per_rad(x):
    """pitch m/rad → ft/rad."""
    return x / FT


def rpm(x):
    """rev/min → rad/s."""
    return x * RPM


def to_rpm(x):
    """rad/s → rev/min."""
    return x / RPM


def kgf(x):
    """kgf → N."""
    return x * KGF


def to_kgf(x):
    """N → kgf."""
    return x / KGF


def deg(x):
    """degrees → rad."""
    return x * DEG


def to_deg(x):
    """rad → degrees."""
    return x / DEG
