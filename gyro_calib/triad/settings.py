"""The triad's settings: windows, pairs and channels (METHODS §F.2), and the bench (§F.1, §F.5).

:class:`TriadSettings` extends the shared window and fit fields
(:class:`~gyro_calib.windows.WindowFields`) with the pairing and channel rules;
:class:`Bench` holds the bench settings the directions and the Earth rate rest on.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.config import check_ranges
from gyro_calib.errors import ConfigError
from gyro_calib.units import RAD_PER_ARCSEC
from gyro_calib.windows import WindowFields

if TYPE_CHECKING:
    import numpy.typing as npt

    Array = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class TriadSettings(WindowFields):
    """Window, pair and channel settings of the triad method (METHODS §F.2, §A.2's rules).

    The window and fit fields come first, from :class:`~gyro_calib.windows.WindowFields` (m:
    rate-table, inner-axis, revolutions per window; the bag's stored value wins); the pulse
    stream is /imu/pulses, a local fit's residual rejects the event for that channel alone.
    """

    window_angle_source: str = 'encoder'
    """'encoder' (swept angle measured between the events) or 'nominal' (whole turns)."""
    max_pair_gap_s: float = 120.0
    """Longest time from a window to the opposite-direction window it is paired with, s."""
    min_pulse_rate_hz: float = 0.0
    """A channel's window with a mean count rate below this is rejected for that channel
    (a rate-biased RLG locked in about that direction), pulses/s; 0 = no check."""
    station_still_deg_s: float = 0.05
    """The rate table counts as held at its station during a position-table window while its
    |rate| stays below this, °/s."""
    analysis_period_s: float = 60.0
    """Live: the windows are recut from the data held after this much more data, s."""
    angle_random_walk_deg_sqrt_h: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    """The gyros' angle random walk N_i, °/√h (datasheet or a noise run; one number for all
    three, or one per channel): each window's count carries N_i²·T/K_i² (METHODS §F eq. (6b)).
    NaN (not given): measured from each gyro's own pair residuals (eq. (6c))."""

    def __post_init__(self) -> None:
        """Range-check every field (ConfigError naming it)."""
        arw = self.angle_random_walk_deg_sqrt_h
        if isinstance(arw, (int, float)) and not isinstance(arw, bool):
            object.__setattr__(self, 'angle_random_walk_deg_sqrt_h', (float(arw),) * 3)
        elif isinstance(arw, (list, tuple)) and len(arw) == 3 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in arw):
            object.__setattr__(self, 'angle_random_walk_deg_sqrt_h',
                               tuple(float(v) for v in arw))
        arw = self.angle_random_walk_deg_sqrt_h
        arw_ok = isinstance(arw, tuple) and len(arw) == 3 and all(
            isinstance(v, float) and (math.isnan(v) or v >= 0) for v in arw) and (
            all(math.isnan(v) for v in arw) or not any(math.isnan(v) for v in arw))
        check_ranges(self, [
            *self.window_checks(angle_within_half_turn=False, jump_may_be_zero=True),
            ('window_angle_source', self.window_angle_source in ('encoder', 'nominal'),
             "'encoder' or 'nominal'"),
            ('max_pair_gap_s', self.max_pair_gap_s > 0, 'positive'),
            ('min_pulse_rate_hz', self.min_pulse_rate_hz >= 0, 'non-negative'),
            ('station_still_deg_s', self.station_still_deg_s > 0, 'positive'),
            ('analysis_period_s', self.analysis_period_s > 0, 'positive'),
            ('angle_random_walk_deg_sqrt_h', arw_ok,
             'a non-negative number, or three (one per channel); not given: measured'),
        ])

    def stated_arw_rad_sqrt_s(self) -> npt.NDArray[np.float64] | None:
        """The stated N_i (3,), rad/√s; None when not given (measured from the record)."""
        arw = np.array(self.angle_random_walk_deg_sqrt_h, dtype=np.float64)
        if np.any(np.isnan(arw)):
            return None
        return np.asarray(np.radians(arw) / 60.0, dtype=np.float64)


def triad_settings_from_mapping(values: dict[str, Any], *, source: str) -> TriadSettings:
    """The settings from a mapping (config file), refusing unknown fields by name."""
    names = {f.name for f in dataclasses.fields(TriadSettings)}
    unknown = sorted(set(values) - names)
    if unknown:
        raise ConfigError(f'{source}: unknown triad setting {unknown[0]!r}; the settings are '
                          f'{", ".join(sorted(names))}.')
    return TriadSettings(**values)


@dataclass(frozen=True, slots=True)
class Bench:
    """The bench settings the directions and the Earth rate rest on (METHODS §F.1, §F.5)."""

    tilt_rad: float = math.nan
    tilt_std_rad: float = 60.0 * RAD_PER_ARCSEC
    station_offset_rad: float = 0.0
    fixture: Array = field(default_factory=lambda: np.eye(3))
    latitude_deg: float = math.nan
    heading_deg: float = 0.0
