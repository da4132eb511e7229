"""VINS-Fusion config (OpenCV ``%YAML:1.0``): ``acc_n``, ``gyr_n``, ``acc_w``, ``gyr_w``.

VINS-Fusion's four numbers are per-sample standard deviations, not densities (METHODS §E.5
eq. (18)): its midpoint pre-integration (vins_estimator/src/factor/integration_base.h) draws
the gyro noise twice per step, each weighted ½·Δt (V blocks (3,3), (3,9): lines 122–123), so
a step adds ½·gyr_n²·Δt² of rotation variance, and the bias step adds gyr_w²·Δt² (V block
(12,15), line 129). Matching N²·T and K²·T after T at rest: gyr_n = N·√(2f), gyr_w = K·√f at
the sample rate f (acc_n, acc_w likewise, lines 124, 126, 128). One number per sensor (the
largest axis). VINS-Fusion users commonly inflate them (×10 or more) to absorb unmodelled
errors — that choice is yours, and the comment in the file says so.
"""

from __future__ import annotations

from gyro_calib.export.common import (
    ExportOptions,
    check_stream,
    header,
    largest,
    need_accelerometers,
    need_rate,
    number,
)
from gyro_calib.export.opencv_yaml import with_header
from gyro_calib.export.openvins import topic_string
from gyro_calib.export.source import ExportSource

FORMAT = 'vins-fusion'
KEYS = ('imu', 'imu_topic', 'acc_n', 'gyr_n', 'acc_w', 'gyr_w')
SLOTS = (('acc_n', 'accel', 'N', 'm/s^2', 2.0), ('gyr_n', 'gyro', 'N', 'rad/s', 2.0),
         ('acc_w', 'accel', 'K', 'm/s^3', 1.0), ('gyr_w', 'gyro', 'K', 'rad/s^2', 1.0))
"""(key, sensor, term, unit of the per-sample value, c): value = term·√(c·f)."""


def vins_fusion_text(src: ExportSource, options: ExportOptions) -> str:
    """The VINS-Fusion config text with its ``%YAML:1.0`` header."""
    check_stream(src, FORMAT, options)
    need_accelerometers(src, FORMAT, options, 'acc_n')
    got = [(key, unit, c, *largest(src, FORMAT, sensor, sym, key))
           for key, sensor, sym, unit, c in SLOTS]
    rate, rate_from = need_rate(src, FORMAT, options, 'acc_n, gyr_n, acc_w, gyr_w (per sample)')
    body = ['imu: 1', f'imu_topic: {topic_string(FORMAT, options.topic)}']
    for key, unit, c, value, why in got:
        factor = '√(2f)' if c == 2.0 else '√f'
        body.append(f'{key}: {number(value * (c * rate) ** 0.5)}  # {unit} per sample; {why}; '
                    f'× {factor}, f = {rate:g} Hz ({rate_from}); as measured (users often '
                    'scale it up; not done here)')
    return with_header('\n'.join(header(src, FORMAT, options) + body) + '\n')
