"""The scale factor that turns a stream into rad, and where it came from (METHODS §E).

K of ``/gyro/pulses`` (rad/pulse), the FOG's counts/rad of ``/fog/output``, and K_i of each
``/imu/pulses`` channel (a triad's hand-off, METHODS §F): the flag or node parameter, a
hand-off file, the settings, else the bench settings a simulated bag stores — in the order
the table of :mod:`gyro_calib.noise.session` gives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeGuard

from gyro_calib.errors import ConfigError

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.session import CalibrationOptions


@dataclass(frozen=True, slots=True)
class ScaleFactor:
    """A scale factor and where it came from.

    Attributes:
        value: the value (rad/pulse or counts/rad); NaN when none was found.
        source: where it came from, for the summary ('' when none).
    """

    value: float
    source: str = ''

    @property
    def known(self) -> bool:
        """A finite positive value was found."""
        return math.isfinite(self.value) and self.value > 0


def _positive(value: Any) -> TypeGuard[float]:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value) and value > 0)


_FLAGS = {'scale_factor_rad_per_pulse': '--scale-factor-rad-per-pulse K',
          'fog_scale_factor_counts_per_rad': '--scale-factor-counts-per-rad S'}
"""The flag that gives a stream's scale factor, by its hand-off key."""


def _from_handoff(path: Path, keys: tuple[str, ...]) -> tuple[float, str] | None:
    from gyro_calib.handoff import load_calibration

    record = load_calibration(path)
    for key in keys:
        got = record.measured(key)
        if got is not None:
            return got[0], f'{key} in {path}'
    return None


def refuse_a_triads_file(options: CalibrationOptions, key: str) -> None:
    """A triad's hand-off given (``--calibration``) for one gyro's stream: refused.

    Its ``imu:`` K_i are three other gyros', never this stream's; without the single gyro's
    ``key`` the file would be passed over silently (the bag's K taken instead).

    Raises:
        ConfigError: the file has an ``imu:`` section and no ``key``.
    """
    path = options.calibration_file
    if path is None:
        return
    from gyro_calib.handoff import load_calibration

    record = load_calibration(path)
    if record.imu is None or record.measured(key) is not None:
        return
    raise ConfigError(f'--calibration {path} is a triad\'s hand-off file (imu: section, '
                      f'channels {list(record.imu.channels)}) and holds no {key} of a single '
                      'gyro: its K_i are the triad\'s channels\' (noise --topic /imu/pulses '
                      'reads them). Give this gyro\'s own hand-off file, or '
                      f'{_FLAGS.get(key, "its scale factor")}.')


def _first_scale_factor(options: CalibrationOptions, given: float | None, *, flag: str,
                        unit: str, key: str, handoff_keys: tuple[str, ...],
                        settings_source: str, order: tuple[str, str]) -> ScaleFactor:
    """The first scale factor given: the flag, hand-off file and settings in ``order``, the bag.

    ``key`` names the setting, the flag's origin and the bag's bench-settings entry; ``flag``
    and ``unit`` word the refusal of a bad flag value.

    Raises:
        ConfigError: the flag's value is not positive and finite.
        HandoffError: the hand-off file cannot be read or is invalid.
    """
    if given is not None:
        if not _positive(given):
            raise ConfigError(f'{flag} = {given!r} is invalid: it must be a positive number of '
                              f'{unit}.')
        return ScaleFactor(float(given), options.origin_of_given(key))
    setting = options.settings.get(key)
    for source in order:
        if source == 'handoff' and options.calibration_file is not None:
            got = _from_handoff(options.calibration_file, handoff_keys)
            if got is not None:
                return ScaleFactor(*got)
        elif source == 'settings' and _positive(setting):
            return ScaleFactor(float(setting), settings_source)
    stored = options.bench(key, None)
    if _positive(stored):
        return ScaleFactor(float(stored), 'the bench settings stored in the bag')
    return ScaleFactor(math.nan)


def pulse_scale_factor(options: CalibrationOptions) -> ScaleFactor:
    """K of ``/gyro/pulses``, rad/pulse, from the first source given.

    The flag (node parameter), a hand-off file (``scale_factor_rad_per_pulse``, else
    ``k_tilde_rad_per_pulse``), the settings (config file), the bag's bench settings; raises
    as :func:`_first_scale_factor`.
    """
    return _first_scale_factor(
        options, options.scale_factor_rad_per_pulse, flag='scale_factor_rad_per_pulse',
        unit='rad/pulse', key='scale_factor_rad_per_pulse',
        handoff_keys=('scale_factor_rad_per_pulse', 'k_tilde_rad_per_pulse'),
        settings_source='the settings', order=('handoff', 'settings'))


def fog_scale_factor(options: CalibrationOptions) -> ScaleFactor:
    """Scale factor of ``/fog/output``, counts/rad, from the first source given.

    The flag, the setting ``fog_scale_factor_counts_per_rad`` (node parameter, config file),
    a hand-off file (``fog_scale_factor_counts_per_rad``), the bag's bench settings; raises
    as :func:`_first_scale_factor`.
    """
    return _first_scale_factor(
        options, options.scale_factor_counts_per_rad, flag='scale_factor_counts_per_rad',
        unit='counts/rad', key='fog_scale_factor_counts_per_rad',
        handoff_keys=('fog_scale_factor_counts_per_rad',),
        settings_source='fog_scale_factor_counts_per_rad (settings)',
        order=('settings', 'handoff'))


@dataclass(frozen=True, slots=True)
class TriadScales:
    """The channels of ``/imu/pulses`` and K_i of each (METHODS §F), and where they came from.

    Attributes:
        channels: the channel names, in the hand-off's ``imu.channels`` order.
        values: K_i, rad/pulse; NaN for a channel the file does not give.
        source: the file they came from ('' when none).
    """

    channels: tuple[str, ...] = ('x', 'y', 'z')
    values: tuple[float, ...] = (math.nan, math.nan, math.nan)
    source: str = ''

    @property
    def known(self) -> bool:
        """At least one channel has a finite positive K."""
        return any(_positive(v) for v in self.values)


def triad_scale_factors(options: CalibrationOptions) -> TriadScales:
    """K_i of each ``/imu/pulses`` channel from ``--calibration`` (the ``imu:`` section).

    Raises:
        HandoffError: the hand-off file cannot be read or is invalid.
    """
    from gyro_calib.handoff import load_calibration

    if options.calibration_file is None:
        return TriadScales()
    imu = load_calibration(options.calibration_file).imu
    if imu is None or imu.scale_factor_rad_per_pulse is None:
        return TriadScales(imu.channels) if imu is not None else TriadScales()
    k = tuple(float(v) for v in imu.scale_factor_rad_per_pulse)
    return TriadScales(imu.channels, k, f'imu.scale_factor_rad_per_pulse in '
                                        f'{options.calibration_file}')
