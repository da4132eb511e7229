"""Earth rate along a ground-fixed sense axis (static base; METHODS §E)."""

from __future__ import annotations

import math

from gyro_calib.errors import ConfigError
from gyro_calib.units import EARTH_RATE_DEG_H

RAD_S_PER_DEG_H = math.pi / 180.0 / 3600.0
"""1 °/h in rad/s."""


def earth_rate_along_axis_rad_s(latitude_deg: float, elevation_deg: float = 90.0,
                                azimuth_deg: float = 0.0,
                                earth_rate_deg_h: float = EARTH_RATE_DEG_H) -> float:
    """Earth-rate component along the sense axis, rad/s.

    The axis points ``elevation_deg`` above the horizon (90 = vertical, the default)
    towards ``azimuth_deg`` (from North towards East). With the Earth rate
    Ω·(0, cos φ, sin φ) in East-North-Up, the component is
    Ω·(cos e·cos a·cos φ + sin e·sin φ); vertical: Ω·sin φ (METHODS §E).

    Raises:
        ConfigError: if the latitude is not set (NaN) or out of range.
    """
    if not (math.isfinite(latitude_deg) and -90.0 <= latitude_deg <= 90.0):
        raise ConfigError(f'latitude_deg = {latitude_deg!r} is invalid: the Earth rate along '
                          'the sense axis needs the site latitude in degrees (−90…90).')
    lat, el, az = (math.radians(v) for v in (latitude_deg, elevation_deg, azimuth_deg))
    return earth_rate_deg_h * RAD_S_PER_DEG_H * (
        math.cos(el) * math.cos(az) * math.cos(lat) + math.sin(el) * math.sin(lat))
