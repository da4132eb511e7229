"""How the dither method writes its numbers in sentences: arcminutes, ± parts, durations, stamps.

One format for the summary, the log lines, the figures and the verdict (METHODS §C quotes
angles in arcminutes).
"""

from __future__ import annotations

import math

from gyro_calib.units import NS_PER_S

RAD_PER_ARCMIN = math.pi / 180.0 / 60.0


def arcmin(value_rad: float) -> str:
    """An angle in arcminutes, two decimals: '1.23′'."""
    return f'{value_rad / RAD_PER_ARCMIN:.2f}′'


def plus_minus(std_rad: float) -> str:
    """'± x′', or '± unbounded' when the uncertainty cannot be stated."""
    return f'± {arcmin(std_rad)}' if math.isfinite(std_rad) else '± unbounded'


def duration(seconds: float) -> str:
    """A duration in the unit that reads best: '90 s', '12 min', '3.5 h'."""
    if seconds < 120:
        return f'{seconds:.0f} s'
    if seconds < 7200:
        return f'{seconds / 60:.0f} min'
    return f'{seconds / 3600:.1f} h'


def stamp(t_ns: int) -> str:
    """A stamp in seconds, ms resolution: '12.345 s'."""
    return f'{t_ns / NS_PER_S:.3f} s'
