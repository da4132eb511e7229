"""A noise run's settings read from the calibration options, and the scale factor checked.

The settings come from the node's parameters or the config file (a plain mapping or a ROS 2
parameter file of ``noise_node``), the scale factors from :mod:`gyro_calib.noise.
scale_factors`; :func:`check_scale_factor` refuses a pulse or FOG stream without one before
any sample is read (METHODS §E).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from gyro_calib.errors import ConfigError
from gyro_calib.noise.inputs import FOG_OUTPUT, GYRO_PULSES, IMU_PULSES, input_kind, input_topic
from gyro_calib.noise.scale_factors import (
    ScaleFactor,
    _positive,
    fog_scale_factor,
    pulse_scale_factor,
    refuse_a_triads_file,
    triad_scale_factors,
)
from gyro_calib.noise.settings import NoiseSettings

if TYPE_CHECKING:
    from gyro_calib.session import CalibrationOptions

NODE_NAME = 'noise_node'
"""The node's name (ROS 2 parameter files for ``--config`` use it, or ``/**``)."""


def settings_values(options: CalibrationOptions) -> tuple[dict[str, Any], str]:
    """The settings given, and where they came from.

    The settings given: the node's parameters, then the config file's values (plain
    mapping or ROS 2 parameter file of ``noise_node``); and where they came from.

    Raises:
        ConfigError: the config file is unreadable, or names an unknown setting.
    """
    values, source = options.method_settings(NoiseSettings, NODE_NAME,
                                             parameters='the node parameters')
    names = {f.name for f in dataclasses.fields(NoiseSettings)}
    unknown = sorted(set(values) - names)
    if unknown:
        raise ConfigError(f'unknown noise setting(s) {", ".join(unknown)} in {source}; the '
                          f'settings are: {", ".join(sorted(names))}.')
    return values, source


def noise_settings(options: CalibrationOptions) -> NoiseSettings:
    """The analysis settings with the scale factors resolved.

    The analysis settings (:func:`settings_values`) with the scale factors resolved by
    :func:`pulse_scale_factor` and :func:`fog_scale_factor`.

    Raises:
        ConfigError: an unknown or invalid setting, naming it and its source.
        HandoffError: the hand-off file given for a scale factor is unreadable.
    """
    values, source = settings_values(options)
    merged = dataclasses.replace(options, settings=values)
    defaults = NoiseSettings()
    for name, value in list(values.items()):
        if (isinstance(getattr(defaults, name), float) and isinstance(value, int)
                and not isinstance(value, bool)):
            values[name] = float(value)
    values['scale_factor_rad_per_pulse'] = pulse_scale_factor(merged).value
    values['fog_scale_factor_counts_per_rad'] = fog_scale_factor(merged).value
    try:
        return NoiseSettings(**values)
    except ConfigError as exc:
        raise ConfigError(f'{exc} (in {source})') from None


def check_scale_factor(options: CalibrationOptions) -> ScaleFactor | None:
    """The scale factor the chosen input needs (None for an Imu).

    Raises:
        ConfigError: a pulse or FOG stream without a scale factor, naming the ways to give one.
    """
    kind = input_kind(input_topic(options))
    merged = dataclasses.replace(options, settings=settings_values(options)[0])
    if kind in ('pulses', 'fog', 'gyro'):  # a triad's file names no single gyro's K
        refuse_a_triads_file(merged, 'fog_scale_factor_counts_per_rad' if kind == 'fog' else
                             'scale_factor_rad_per_pulse')
    if kind == 'pulses':
        k = pulse_scale_factor(merged)
        if not k.known:
            raise ConfigError(
                f'{GYRO_PULSES} needs the scale factor K to turn pulses into rad, and none was '
                'given: pass --scale-factor-rad-per-pulse K, or --calibration FILE (a hand-off '
                'file with scale_factor_rad_per_pulse or k_tilde_rad_per_pulse). No number in '
                'rad is possible without it; nothing was written.')
        return k
    if kind == 'triad':
        ks = triad_scale_factors(merged)
        if not ks.known:
            raise ConfigError(
                f'{IMU_PULSES} needs each channel\'s scale factor K_i to turn pulses into rad, '
                'and none was given: pass --calibration FILE (a format-4 hand-off file whose '
                'imu: section holds scale_factor_rad_per_pulse, from gyro-calib calibrate '
                '--method triad). Nothing was written.')
        return ScaleFactor(min(v for v in ks.values if _positive(v)), ks.source)
    if kind == 'fog':
        sf = fog_scale_factor(merged)
        if not sf.known:
            raise ConfigError(
                f'{FOG_OUTPUT} needs the scale factor (counts/rad) to turn counts into rad, and '
                'none was given: pass --scale-factor-counts-per-rad S, or --calibration FILE (a '
                'hand-off file with fog_scale_factor_counts_per_rad). Nothing was written.')
        return sf
    return None
