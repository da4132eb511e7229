"""imu_corrector: calibrated sensor_msgs/Imu from the gyro's cumulative pulse count.

Subscribes /gyro/pulses (sensor_msgs/JointState, name ['gyro'], position = count) and
publishes :data:`GYRO_IMU`: angular_velocity.z = K·Δcount/Δt − bias (rad/s) between
consecutive samples by their stamps, with its variance; the maths and the choice of
x/y covariance are in :mod:`gyro_calib.imu_conversion`. Orientation and linear
acceleration are marked unavailable (covariance[0] = −1, sensor_msgs/Imu, REP 145).

Parameters: ``calibration_file`` (hand-off YAML, :mod:`gyro_calib.handoff`; re-read at
every poll, so it may also be set at run time), ``use_k_tilde`` (take K̃ with θ = 0 when the
file has no K), ``frame_id`` and ``reload_period_s``. A file without the scale factor it
needs is refused, naming the missing key; one without the bias is used with a warning (the
rates are then not bias-corrected).
The file is polled (inode, mtime, size) and reloaded when it changes; a missing or bad
file is logged and the calibration in use is kept (none: nothing is published).
"""

from __future__ import annotations

import os

import rclpy
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu, JointState

from gyro_calib import topics
from gyro_calib.errors import GyroCalibError
from gyro_calib.estimate import Rejection
from gyro_calib.handoff import load_calibration
from gyro_calib.imu_conversion import ImuAngularVelocity, PulseRateConverter, pulse_calibration
from gyro_calib.nodes.ros_io import SENSOR_QOS, ns_to_stamp, spin, stamp_to_ns

GYRO_IMU = '/gyro/imu'
"""sensor_msgs/Imu: calibrated rate about the gyro's sense axis (z), rad/s, with covariance."""

IMU_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
"""Output: reliable (so reliable and best-effort subscribers both match) but KEEP_LAST, so
a slow consumer loses old samples instead of stalling the correction of new ones."""


class ImuCorrectorNode(Node):
    """Translates pulse samples to core calls and calibrated rates to Imu messages."""

    def __init__(self) -> None:
        """Declare parameters, wire topics, load the calibration and start polling it."""
        super().__init__('imu_corrector')
        self.declare_parameter('calibration_file', '', ParameterDescriptor(description=(
            'Hand-off calibration YAML (gyro_calib.handoff); required. Polled and reloaded '
            'when it changes; nothing is published until a valid file is read.')))
        self.declare_parameter('use_k_tilde', False, ParameterDescriptor(description=(
            'Take K̃ (k_tilde_rad_per_pulse) as the scale factor, i.e. θ = 0, when θ was not '
            'measured; by default K (scale_factor_rad_per_pulse) is required.')))
        self.use_k_tilde = bool(self.get_parameter('use_k_tilde').value)
        self.declare_parameter('frame_id', 'gyro', ParameterDescriptor(
            description='header.frame_id of the Imu messages; its z axis is the sense axis.'))
        self.declare_parameter('reload_period_s', 1.0, ParameterDescriptor(
            description='How often the calibration file is checked for changes, s.',
            floating_point_range=[FloatingPointRange(from_value=0.01, to_value=3600.0)]))
        self.frame_id = self.get_parameter('frame_id').value
        self.add_on_set_parameters_callback(self._check_runtime_change)
        self.converter: PulseRateConverter | None = None
        self._file_key: tuple[int, int, int] | None = None
        self._last_problem = ''
        self._skipped = 0
        self.pub = self.create_publisher(Imu, GYRO_IMU, IMU_QOS)
        self.create_subscription(JointState, topics.GYRO_PULSES, self._on_pulses, SENSOR_QOS)
        self._poll_file()
        self.create_timer(self.get_parameter('reload_period_s').value, self._poll_file)

    def _check_runtime_change(self, params: list) -> SetParametersResult:
        fixed = [p.name for p in params if p.name != 'calibration_file']
        return SetParametersResult(successful=not fixed, reason=(
            f'{", ".join(fixed)} is read at start-up; restart the node to change it.'
            if fixed else ''))

    def _poll_file(self) -> None:
        path = self.get_parameter('calibration_file').value
        if not path:
            self._problem('parameter calibration_file is not set: give the hand-off YAML '
                          '(-p calibration_file:=/path/gyro.yaml).')
            return
        try:
            st = os.stat(path)
            key: tuple[int, int, int] | None = (st.st_ino, st.st_mtime_ns, st.st_size)
        except OSError:
            key = None
        if key is not None and key == self._file_key:
            return
        self._file_key = key
        try:
            calibration = pulse_calibration(load_calibration(path), use_k_tilde=self.use_k_tilde)
        except GyroCalibError as exc:
            self._problem(str(exc))
            return
        if self.converter is None:
            self.converter = PulseRateConverter(calibration)
        else:
            self.converter.calibration = calibration
        self._last_problem = ''
        c = calibration
        self.get_logger().info(
            f'calibration loaded from {path}: {c.scale_factor_key} = '
            f'{c.scale_factor_rad_per_pulse!r} ± {c.scale_factor_std!r} rad/pulse, bias = '
            f'{c.bias_rad_s!r} ± {c.bias_std!r} rad/s; publishing {GYRO_IMU}')
        if not c.bias_known:
            self.get_logger().warning('the calibration has no bias_rad_s: the rates are NOT '
                                      'bias-corrected (calibrate with the site latitude).')
        if c.angle_random_walk_rad_per_sqrt_s == 0.0:
            self.get_logger().warning('the calibration has no angle_random_walk_rad_per_sqrt_s: '
                                      'the Imu variance holds quantisation, K and bias only.')

    def _problem(self, message: str) -> None:
        if message != self._last_problem:  # once per distinct problem, not every poll
            self._last_problem = message
            self.get_logger().error(message + (
                ' Keeping the calibration in use.' if self.converter is not None
                else f' Nothing is published on {GYRO_IMU} until a valid file appears.'))

    def _on_pulses(self, msg: JointState) -> None:
        if self.converter is None:
            return
        t_ns = stamp_to_ns(msg.header.stamp)
        try:
            count = msg.position[msg.name.index(topics.GYRO_JOINT) if msg.name else 0]
        except (ValueError, IndexError):
            out: ImuAngularVelocity | Rejection | None = Rejection(
                t_ns, f'no position for joint "{topics.GYRO_JOINT}" (names {list(msg.name)}).')
        else:
            out = self.converter.add(t_ns, count)
        if isinstance(out, Rejection):
            self._skipped += 1
            if self._skipped % 100 == 1:
                self.get_logger().warning(
                    f'{self._skipped} pulse sample(s) skipped so far; latest: {out.reason}')
        elif out is not None:
            self.pub.publish(self._imu(out))

    def _imu(self, out: ImuAngularVelocity) -> Imu:
        imu = Imu()
        ns_to_stamp(out.stamp_ns, imu.header.stamp)
        imu.header.frame_id = self.frame_id
        v = imu.angular_velocity
        v.x, v.y, v.z = out.angular_velocity_rad_s
        imu.angular_velocity_covariance = list(out.covariance_rad2_s2)
        imu.orientation_covariance[0] = -1.0  # no orientation estimate
        imu.linear_acceleration_covariance[0] = -1.0  # no accelerometer
        return imu


def main(args: list[str] | None = None) -> None:
    """Run the IMU corrector node until shut down."""
    try:
        with rclpy.init(args=args):
            spin(ImuCorrectorNode())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
