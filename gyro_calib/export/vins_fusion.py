"""VINS-Fusion config (OpenCV ``%YAML:1.0``): ``acc_n``, ``gyr_n``, ``acc_w``, ``gyr_w``.

VINS-Fusion takes continuous densities (METHODS §E): gyr_n = N (rad/s/√Hz), gyr_w = K
(rad/s²/√Hz), acc_n, acc_w likewise; one number per sensor (the largest axis). These are the
measured values: VINS-Fusion users commonly inflate them (×10 or more) to absorb unmodelled
errors — that choice is yours, and the comment in the file says so. Merge the keys into your
config (g_norm, extrinsics and cameras stay yours).
"""

from __future__ import annotations

from gyro_calib.export.common import ExportOptions, check_stream, header, largest, number
from gyro_calib.export.opencv_yaml import with_header
from gyro_calib.export.openvins import topic_string
from gyro_calib.export.source import ExportSource

FORMAT = 'vins-fusion'
KEYS = ('imu', 'imu_topic', 'acc_n', 'gyr_n', 'acc_w', 'gyr_w')


def vins_fusion_text(src: ExportSource, options: ExportOptions) -> str:
    """The VINS-Fusion config text with its ``%YAML:1.0`` header."""
    check_stream(src, FORMAT, options)
    slots = (('acc_n', 'accel', 'N', 'm/s^2/sqrt(Hz)'), ('gyr_n', 'gyro', 'N', 'rad/s/sqrt(Hz)'),
             ('acc_w', 'accel', 'K', 'm/s^3/sqrt(Hz)'), ('gyr_w', 'gyro', 'K', 'rad/s^2/sqrt(Hz)'))
    body = ['imu: 1', f'imu_topic: {topic_string(FORMAT, options.topic)}']
    for key, sensor, sym, unit in slots:
        value, why = largest(src, FORMAT, sensor, sym, key)
        body.append(f'{key}: {number(value)}  # {unit}; {why}; continuous density as '
                    'measured (users often scale it up; not done here)')
    return with_header('\n'.join(header(src, FORMAT, options) + body) + '\n')
