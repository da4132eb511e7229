"""The units a gyro lab quotes (″/pulse, ″, °/h, °/√h, ppm …) for the SI hand-off keys.

Hand-off keys carry their SI unit in the name (``…_rad_per_pulse``, ``…_rad_s``); a
certificate shows each quantity in the unit a bench engineer reads, and a spec file gives its
limits in that unit. The unit follows from the key's suffix (longest match first); a key whose
suffix is not listed keeps its SI unit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gyro_calib.units import ARCSEC_PER_RAD

DEG_PER_RAD = 180.0 / math.pi
STANDARD_GRAVITY_M_S2 = 9.80665
_UG = 1e6 / STANDARD_GRAVITY_M_S2


@dataclass(frozen=True, slots=True)
class UserUnit:
    """The quoted unit of a quantity.

    Attributes:
        label: the unit as printed, e.g. '°/h'.
        factor: SI value × factor = value in this unit.
        si: the SI unit of the hand-off key.
    """

    label: str
    factor: float
    si: str


_SUFFIXES: tuple[tuple[str, UserUnit], ...] = (
    ('_rad_per_pulse', UserUnit('″/pulse', ARCSEC_PER_RAD, 'rad/pulse')),
    ('_rad_per_s_sqrt_s', UserUnit('°/h/√h', DEG_PER_RAD * 3600.0 * 60.0, 'rad/s/√s')),
    ('_rad_per_sqrt_s', UserUnit('°/√h', DEG_PER_RAD * 60.0, 'rad/√s')),
    ('_rad_per_s2', UserUnit('°/h²', DEG_PER_RAD * 3600.0**2, 'rad/s²')),
    ('_rad_s', UserUnit('°/h', DEG_PER_RAD * 3600.0, 'rad/s')),
    ('_counts_per_rad', UserUnit('counts/rad', 1.0, 'counts/rad')),
    ('_s2_per_rad2', UserUnit('s²/rad²', 1.0, 's²/rad²')),
    ('_s_per_rad', UserUnit('s/rad', 1.0, 's/rad')),
    ('_m_s2_per_sqrt_s', UserUnit('µg/√h', _UG * 60.0, 'm/s²/√s')),
    ('_m_s2_per_s', UserUnit('µg/h', _UG * 3600.0, 'm/s³')),
    ('_m_s_per_sqrt_s', UserUnit('m/s/√h', 60.0, 'm/s/√s')),
    ('_m_s2', UserUnit('µg', _UG, 'm/s²')),
    ('_m_s', UserUnit('mm/s', 1e3, 'm/s')),
    ('_ppm', UserUnit('ppm', 1.0, 'ppm')),
    ('_hz', UserUnit('Hz', 1.0, 'Hz')),
    ('_pulses', UserUnit('pulses', 1.0, 'pulses')),
    ('_rad', UserUnit('″', ARCSEC_PER_RAD, 'rad')),
)

_ARCMIN = UserUnit('′', ARCSEC_PER_RAD / 60.0, 'rad')
_OVERRIDES = {
    # the dither acceptance limit is stated in arcminutes (METHODS §C)
    'dither_axis_misalignment_rad': _ARCMIN,
    'dither_misalignment_z_rad': _ARCMIN,
    'dither_misalignment_y_rad': _ARCMIN,
    'dither_axis_misalignment_lower_rad': _ARCMIN,
    'dither_axis_misalignment_upper_rad': _ARCMIN,
    'dither_misalignment_limit_rad': _ARCMIN,
}


def user_unit(key: str) -> UserUnit:
    """The quoted unit of hand-off key ``key`` (SI unchanged when the suffix is unknown)."""
    if key in _OVERRIDES:
        return _OVERRIDES[key]
    for suffix, unit in _SUFFIXES:
        if key.endswith(suffix):
            return unit
    return UserUnit('', 1.0, '')
