"""LIO-SAM ``params.yaml`` IMU noise (ROS 2 layout ``/**: ros__parameters:``; METHODS §E).

LIO-SAM hands these to GTSAM: ``imuGyrNoise``² is the gyroscope covariance and
``imuGyrBiasN`` the bias random walk scaled by √Δt between keyframes, so both are continuous
densities: imuGyrNoise = N (rad/s/√Hz), imuGyrBiasN = K (rad/s²/√Hz), the accelerometer's
likewise; one number per sensor (the largest axis). Merge the keys into your params.yaml
(extrinsics and gravity stay yours).
"""

from __future__ import annotations

from gyro_calib.export.common import (
    ExportOptions,
    check_stream,
    header,
    largest,
    need_accelerometers,
    number,
)
from gyro_calib.export.source import ExportSource

FORMAT = 'lio-sam'
KEYS = ('imuTopic', 'imuAccNoise', 'imuGyrNoise', 'imuAccBiasN', 'imuGyrBiasN')


def lio_sam_text(src: ExportSource, options: ExportOptions) -> str:
    """The LIO-SAM parameter text (see the module docstring)."""
    check_stream(src, FORMAT, options)
    need_accelerometers(src, FORMAT, options, 'imuAccNoise')
    slots = (('imuAccNoise', 'accel', 'N', 'm/s^2/sqrt(Hz)'),
             ('imuGyrNoise', 'gyro', 'N', 'rad/s/sqrt(Hz)'),
             ('imuAccBiasN', 'accel', 'K', 'm/s^3/sqrt(Hz)'),
             ('imuGyrBiasN', 'gyro', 'K', 'rad/s^2/sqrt(Hz)'))
    body = ['/**:', '  ros__parameters:', f'    imuTopic: "{options.topic}"']
    for key, sensor, sym, unit in slots:
        value, why = largest(src, FORMAT, sensor, sym, key)
        body.append(f'    {key}: {number(value)}  # {unit}; {why}; continuous density')
    return '\n'.join(header(src, FORMAT, options) + body) + '\n'
