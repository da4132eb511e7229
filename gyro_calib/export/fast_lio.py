"""FAST-LIO ``mapping:`` covariances (ROS 2 branch layout; METHODS §E).

ROS 1 takes the same ``common:`` and ``mapping:`` blocks without ``/**: ros__parameters:``.

FAST-LIO's filter adds Q per IMU step as a discrete covariance of the rate (and of the bias
derivative, multiplied by Δt² in the step), so at sample rate f = 1/Δt:
``gyr_cov`` = N²·f ((rad/s)²), ``acc_cov`` = N_a²·f ((m/s²)²), ``b_gyr_cov`` = K²·f
((rad/s²)²: the bias step K·√Δt over Δt, squared), ``b_acc_cov`` = K_a²·f. One number per
sensor (the largest axis).
"""

from __future__ import annotations

from gyro_calib.export.common import (
    ExportOptions,
    check_stream,
    gyro_sample_variance,
    header,
    largest,
    need_accelerometers,
    need_rate,
    number,
)
from gyro_calib.export.source import ExportSource

FORMAT = 'fast-lio'
KEYS = ('acc_cov', 'gyr_cov', 'b_acc_cov', 'b_gyr_cov')


def fast_lio_text(src: ExportSource, options: ExportOptions) -> str:
    """The FAST-LIO parameter text (see the module docstring)."""
    check_stream(src, FORMAT, options)
    need_accelerometers(src, FORMAT, options, 'acc_cov')
    slots = (('acc_cov', 'accel', 'N', '(m/s^2)^2'), ('gyr_cov', 'gyro', 'N', '(rad/s)^2'),
             ('b_acc_cov', 'accel', 'K', '(m/s^3)^2'), ('b_gyr_cov', 'gyro', 'K', '(rad/s^2)^2'))
    got = [(key, unit, *largest(src, FORMAT, sensor, sym, key))
           for key, sensor, sym, unit in slots]
    rate, rate_from = need_rate(src, FORMAT, options, 'a discrete covariance')
    body = ['/**:', '  ros__parameters:', '    common:', f'      imu_topic: "{options.topic}"',
            '    mapping:']
    for key, unit, value, why in got:
        if key == 'gyr_cov':  # with the angle quantisation per sample
            var, text = gyro_sample_variance(src, FORMAT, key, rate)
            body.append(f'      {key}: {number(var)}  # {unit}; {text}, f = {rate:g} Hz '
                        f'({rate_from}; discrete, per sample)')
            continue
        body.append(f'      {key}: {number(value ** 2 * rate)}  # {unit}; {why}; squared × '
                    f'f = {rate:g} Hz ({rate_from}; discrete, per sample)')
    return '\n'.join(header(src, FORMAT, options) + body) + '\n'
