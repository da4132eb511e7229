"""Local gravity from latitude and height (docs/methods.md §G eq. (1)).

Somigliana's closed form of the WGS 84 normal gravity on the ellipsoid and the free-air
gradient of the normal field to second order in the height (NIMA TR8350.2 §4.2, eqs. 4-1
and 4-3). Normal gravity differs from the true local gravity by the gravity anomaly, at most
a few 10⁻⁴ m/s² away from mountains: :data:`ANOMALY_STD_M_S2` is its standard uncertainty.
"""

from __future__ import annotations

import math

A_M = 6378137.0
"""WGS 84 semi-major axis, m."""
F = 1.0 / 298.257223563
"""WGS 84 flattening."""
GAMMA_E = 9.7803253359
"""Normal gravity at the equator, m/s²."""
K_SOMIGLIANA = 0.00193185265241
"""Somigliana's constant k = bγ_p/(aγ_e) − 1."""
E2 = 0.00669437999013
"""First eccentricity squared."""
M_RATIO = 0.00344978650684
"""m = ω²a²b/GM."""
ANOMALY_STD_M_S2 = 3e-4
"""Standard uncertainty of normal against true gravity (the anomaly), m/s² (30 mGal)."""


def normal_gravity_m_s2(latitude_deg: float, height_m: float = 0.0) -> float:
    """Normal gravity at geodetic latitude (°) and ellipsoidal height (m), m/s² (§G eq. (1))."""
    s2 = math.sin(math.radians(latitude_deg)) ** 2
    g0 = GAMMA_E * (1 + K_SOMIGLIANA * s2) / math.sqrt(1 - E2 * s2)
    return g0 * (1 - 2 / A_M * (1 + F + M_RATIO - 2 * F * s2) * height_m
                 + 3 / A_M ** 2 * height_m ** 2)
