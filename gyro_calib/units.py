"""Unit constants and conversions used across gyro_calib.

Angles in the methods are in arcseconds (″); ROS messages carry SI units (rad, rad/s).
"""

from __future__ import annotations

import math

ARCSEC_PER_REV = 1_296_000.0
"""One revolution, in arcseconds (″)."""

ARCSEC_PER_RAD = ARCSEC_PER_REV / (2.0 * math.pi)
"""Arcseconds per radian."""

RAD_PER_ARCSEC = 1.0 / ARCSEC_PER_RAD
"""Radians per arcsecond."""

NS_PER_S = 1_000_000_000
"""Nanoseconds per second (stamps are int64 nanoseconds)."""

EARTH_RATE_DEG_H = 15.041
"""Earth rotation rate, in °/h (METHODS §E)."""

ARCSEC_PER_S_PER_DEG_H = 1.0
"""1 °/h equals 1 ″/s exactly (3600″ per 3600 s)."""

ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H = 60.0
"""1 °/√h equals 60 ″/√s (3600″ / √3600 s)."""


def arcsec_to_rad(value_arcsec: float) -> float:
    """Convert an angle from arcseconds to radians."""
    return value_arcsec * RAD_PER_ARCSEC


def rad_to_arcsec(value_rad: float) -> float:
    """Convert an angle from radians to arcseconds."""
    return value_rad * ARCSEC_PER_RAD


def format_stamp(t_ns: int) -> str:
    """A header stamp (int ns) in seconds for log lines and reasons, e.g. ``t=123.456789 s``."""
    return f't={t_ns / NS_PER_S:.6f} s'
