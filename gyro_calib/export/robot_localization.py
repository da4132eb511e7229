"""robot_localization ``ekf_node`` IMU input (ROS 2 parameters).

robot_localization has no gyro-bias state: the bias, scale factor, axes and thermal model
must be removed upstream (imu_corrector), so only the compensated stream is exported. It
takes the rate noise from each message's ``angular_velocity_covariance`` (not from its
parameters): the per-message variance of white rate noise N at rate f is N²·f (rad/s)²,
which the file states in a comment for the publisher to fill. ``imu0_config`` fuses the
angular velocities (and the linear accelerations when the accelerometers were measured),
not the orientation (imu_corrector publishes none).
"""

from __future__ import annotations

from gyro_calib.export.common import (
    ExportOptions,
    accelerometers_on_stream,
    gyro_sample_variance,
    header,
    largest,
    need_rate,
    number,
    refuse,
)
from gyro_calib.export.source import AXES, ExportSource

FORMAT = 'robot-localization'
KEYS = ('imu0', 'imu0_config', 'imu0_differential', 'imu0_relative',
        'imu0_remove_gravitational_acceleration')
CONFIG_ORDER = ('x', 'y', 'z', 'roll', 'pitch', 'yaw', 'vx', 'vy', 'vz', 'vroll', 'vpitch',
                'vyaw', 'ax', 'ay', 'az')
"""robot_localization's 15 booleans of ``imu0_config``, in its order."""


def robot_localization_text(src: ExportSource, options: ExportOptions) -> str:
    """The robot_localization ekf parameter text (see the module docstring)."""
    if options.stream != 'compensated':
        raise refuse(FORMAT, 'robot_localization has no gyro-bias state: bias and thermal '
                     'compensation must be upstream; export for the compensated stream '
                     '(--stream compensated).')
    rate, rate_from = need_rate(src, FORMAT, options,
                                'the per-message angular_velocity_covariance')
    var, why = gyro_sample_variance(src, FORMAT, 'angular_velocity_covariance', rate)
    accel = any(src.accel[a] for a in AXES) and accelerometers_on_stream(src, options)
    fused = {'vroll', 'vpitch', 'vyaw'} | ({'ax', 'ay', 'az'} if accel else set())
    flags = ['true' if name in fused else 'false' for name in CONFIG_ORDER]
    notes = ['robot_localization has no gyro-bias state: bias, scale factor, axes and thermal '
             'model are removed upstream by imu_corrector.',
             f'angular_velocity_covariance of each message: diag {number(var)} '
             f'(rad/s)^2 = {why}, f = {rate:g} Hz ({rate_from}).']
    if accel:
        na, why_a = largest(src, FORMAT, 'accel', 'N', 'linear_acceleration_covariance')
        notes.append(f'linear_acceleration_covariance of each message: diag '
                     f'{number(na * na * rate)} (m/s^2)^2 = ({why_a}) squared × f.')
    body = ['ekf_filter_node:', '  ros__parameters:', f'    imu0: {options.topic}',
            '    imu0_config: [' + ', '.join(flags[:3]) + ',  # x y z',
            '                  ' + ', '.join(flags[3:6]) + ',  # roll pitch yaw: no '
            'orientation in the message',
            '                  ' + ', '.join(flags[6:9]) + ',  # vx vy vz',
            '                  ' + ', '.join(flags[9:12]) + ',  # vroll vpitch vyaw: the '
            'calibrated rates',
            '                  ' + ', '.join(flags[12:]) + ']  # ax ay az'
            + (': measured' if accel else ': not fused (no accelerometer on the stream, or '
               'no accelerometer term in the hand-off)'),
            '    imu0_differential: false',
            '    imu0_relative: false',
            f'    imu0_remove_gravitational_acceleration: {"true" if accel else "false"}']
    return '\n'.join(header(src, FORMAT, options, notes) + body) + '\n'
