"""Autoware ``imu_corrector.param.yaml`` (ROS 2 parameters; METHODS §E).

Autoware's imu_corrector subtracts ``angular_velocity_offset_<x|y|z>`` (rad/s) and writes
``angular_velocity_stddev_<xx|yy|zz>``² (rad/s, per message) into the message covariance.
The per-sample standard deviation of white rate noise of density N at rate f is N·√f; the
three are written equal, the largest axis's (one conservative number, as the issue asks
where Autoware's code takes the maximum).
On the compensated stream the offsets are 0.0: the bias — and the thermal bias, published
live by ``thermal_bias_node`` for Autoware's ``gyro_bias_input`` — is removed upstream.
``acceleration_stddev`` (m/s²), which Autoware's parameter schema requires
(schema/imu_corrector.schema.json), is N_a·√f when the accelerometers were measured, else
Autoware's own declared default for an accelerometer it knows nothing of, 10000.0 m/s²
(imu_corrector_core.cpp, ``declare_parameter<double>("acceleration_stddev", 10000.0)``),
written out with a comment saying so (no number is invented).
"""

from __future__ import annotations

from gyro_calib.export.common import (
    ExportOptions,
    check_stream,
    gyro_sample_variance,
    header,
    largest,
    need_rate,
    number,
)
from gyro_calib.export.source import AXES, ExportSource

FORMAT = 'autoware'
KEYS = tuple(f'angular_velocity_offset_{a}' for a in AXES) + tuple(
    f'angular_velocity_stddev_{a}{a}' for a in AXES) + ('acceleration_stddev',)
"""Every key Autoware's imu_corrector schema requires."""
UNKNOWN_ACCELERATION_STDDEV = 10000.0
"""m/s²: Autoware imu_corrector's declared default, its value for an unmeasured accelerometer."""


def autoware_text(src: ExportSource, options: ExportOptions) -> str:
    """The Autoware imu_corrector parameter text (see the module docstring)."""
    check_stream(src, FORMAT, options)
    rate, rate_from = need_rate(src, FORMAT, options, 'angular_velocity_stddev (per message)')
    var, why = gyro_sample_variance(src, FORMAT, 'angular_velocity_stddev_xx', rate)
    offset_why = ('0.0: the bias is removed upstream by gyro_calib imu_corrector'
                  if options.stream == 'compensated'
                  else '0.0: no bias in the hand-off (the noise method measures none)')
    body = ['/**:', '  ros__parameters:']
    body += [f'    angular_velocity_offset_{a}: 0.0  # rad/s; {offset_why}' for a in AXES]
    body += [f'    angular_velocity_stddev_{a}{a}: {number(var ** 0.5)}  # rad/s; √[{why}] '
             f'(f = {rate:g} Hz, {rate_from}): per-message std, equal on the three '
             'axes' for a in AXES]
    if any(src.accel[a] for a in AXES):
        na, why_a = largest(src, FORMAT, 'accel', 'N', 'acceleration_stddev')
        body.append(f'    acceleration_stddev: {number(na * rate ** 0.5)}  # m/s^2; {why_a}; '
                    f'× √f (f = {rate:g} Hz, {rate_from})')
    else:
        body.append(f'    acceleration_stddev: {number(UNKNOWN_ACCELERATION_STDDEV)}  # m/s^2; '
                    'no accelerometer term in the hand-off: Autoware\'s own default for an '
                    'accelerometer it knows nothing of (its schema requires the key)')
    notes = ['Autoware takes no scale factor, axis misalignment, thermal model or bias '
             'random walk: they are applied upstream (imu_corrector, thermal_bias_node).']
    return '\n'.join(header(src, FORMAT, options, notes) + body) + '\n'
