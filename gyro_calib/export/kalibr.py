"""Kalibr ``imu.yaml`` (ethz-asl/kalibr wiki "IMU Noise Model"; METHODS §E).

Kalibr's densities are continuous-time: ``gyroscope_noise_density`` = N (rad/√s =
rad/s/√Hz), ``gyroscope_random_walk`` = K (rad/s/√s = rad/s²/√Hz), the accelerometer's
likewise (m/s/√s = m/s²/√Hz; m/s²/√s = m/s³/√Hz); one number per sensor (the largest axis).
Kalibr's reader refuses a density ≤ 0, so a term absent from the hand-off is refused here,
naming it, instead of written as zero.
"""

from __future__ import annotations

from gyro_calib.export.common import (
    KALIBR_DENSITIES,
    ExportOptions,
    check_stream,
    header,
    largest,
    need_accelerometers,
    need_rate,
    number,
    refuse,
)
from gyro_calib.export.source import ExportSource

FORMAT = 'kalibr'
KEYS = ('accelerometer_noise_density', 'accelerometer_random_walk', 'gyroscope_noise_density',
        'gyroscope_random_walk', 'rostopic', 'update_rate')
"""Every key Kalibr's IMU configuration reader takes (all required)."""


def kalibr_text(src: ExportSource, options: ExportOptions) -> str:
    """The Kalibr ``imu.yaml`` text (see the module docstring)."""
    check_stream(src, FORMAT, options)
    need_accelerometers(src, FORMAT, options, 'accelerometer_noise_density')
    values = []
    for key, sensor, sym, unit in KALIBR_DENSITIES:
        value, why = largest(src, FORMAT, sensor, sym, key)
        if not value > 0:
            raise refuse(FORMAT, f'Kalibr refuses {key} = 0 (its reader takes only positive '
                         f'densities); {why}.')
        values.append(f'{key}: {number(value)}  # {unit}; {why}; continuous density, same '
                      'number')
    rate, rate_from = need_rate(src, FORMAT, options, 'update_rate')
    lines = header(src, FORMAT, options, ['Kalibr takes one density per sensor: the largest '
                                          'axis (under-stating noise biases its fit).'])
    lines += values
    lines += [f'rostopic: {options.topic}',
              f'update_rate: {rate:.6f}  # Hz; {rate_from}']
    return '\n'.join(lines) + '\n'
