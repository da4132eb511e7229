"""imu_corrector: calibrated sensor_msgs/Imu from the gyro's cumulative pulse count.

Subscribes /gyro/pulses (sensor_msgs/JointState, name ['gyro'], position = count) and
publishes :data:`GYRO_IMU`: angular_velocity.z = K·Δcount/Δt − bias (rad/s) between
consecutive samples by their stamps, with its variance; the maths and the choice of
x/y covariance are in :mod:`gyro_calib.imu_conversion`. Orientation and linear
acceleration are marked unavailable (covariance[0] = −1, sensor_msgs/Imu, REP 145).

Parameters: ``calibration_file`` (hand-off YAML, :mod:`gyro_calib.handoff`; re-read at
every poll, so it may also be set at run time), ``use_k_tilde`` (take K̃ with θ = 0 when the
file has no K), ``frame_id``, ``reload_period_s``, ``gyro_id`` and ``thermal_max_age_s``.
A file without the scale factor it needs is refused, naming the missing key; one without the
bias is used with a warning (the rates are then not bias-corrected).
The file is polled (inode, mtime, size) and reloaded when it changes; a missing or bad
file is logged and the calibration in use is kept (none: nothing is published).

Thermal compensation (METHODS §D): when the file holds a ``thermal_model``, the node also
subscribes /gyro/temperature (sensor_msgs/Temperature, frame_id cavity_a, cavity_b, shell)
and subtracts the model's bias instead of a constant bias. Each pulse sample is held, by its
stamp, until the temperatures that decide its bias have arrived, and gets exactly the bias
``gyro-calib compensate --out`` gives it, whatever the arrival order of the two topics
(:class:`gyro_calib.thermal.live.OrderedThermalCompensator`). Latency, in stamp time: about
one averaging interval plus the reorder window plus the longest run of identical readings
(2–10 s with 1 Hz sensors; a sparse sensor's reading spacing), never more than
``thermal_max_age_s`` beyond the sample's interval plus one interval and the reorder window
(a temperature topic only behind is waited for; a stopped one: at most 200 000 samples are
held). While the model cannot give a
bias — no temperature, a stuck or silent cavity sensor, temperatures not decided within
``thermal_max_age_s``, or a temperature outside the calibrated range by more than the
model's margin — nothing is published, and the log says why once (and again when
compensation resumes). A model fitted on another gyro than ``gyro_id`` (or than the file
names) is refused like any bad file.
"""

from __future__ import annotations

import os
import re
from typing import TYPE_CHECKING, Any

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu, JointState, Temperature

from gyro_calib import topics
from gyro_calib.errors import GyroCalibError
from gyro_calib.estimate import Rejection
from gyro_calib.handoff import load_calibration
from gyro_calib.imu_conversion import (
    ImuAngularVelocity,
    PulseRateConverter,
    pulse_calibration,
    scale_factor_line,
)
from gyro_calib.nodes.ros_io import (
    SENSOR_QOS,
    declare_parameter_value,
    ns_to_stamp,
    run_node,
    stamp_to_ns,
)
from gyro_calib.registry import handoff_schema
from gyro_calib.thermal.site import RAD_S_PER_DEG_H
from gyro_calib.topics import relative

if TYPE_CHECKING:
    from rclpy.parameter import Parameter

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
        declare_parameter_value(self, 'calibration_file', '', ParameterDescriptor(description=(
            'Hand-off calibration YAML (gyro_calib.handoff); required. Polled and reloaded '
            'when it changes; nothing is published until a valid file is read.')))
        declare_parameter_value(self, 'use_k_tilde', False, ParameterDescriptor(description=(
            'Take K̃ (k_tilde_rad_per_pulse) as the scale factor, i.e. θ = 0, when θ was not '
            'measured; by default K (scale_factor_rad_per_pulse) is required.')))
        self.use_k_tilde = bool(self.get_parameter('use_k_tilde').value)
        declare_parameter_value(self, 'frame_id', 'gyro', ParameterDescriptor(
            description='header.frame_id of the Imu messages; its z axis is the sense axis.'))
        declare_parameter_value(self, 'reload_period_s', 1.0, ParameterDescriptor(
            description='How often the calibration file is checked for changes, s.',
            floating_point_range=[FloatingPointRange(from_value=0.01, to_value=3600.0)]))
        declare_parameter_value(self, 'gyro_id', '', ParameterDescriptor(description=(
            "The gyro's serial or name: a thermal model fitted on another gyro is refused "
            "('' = not checked).")))
        declare_parameter_value(self, 'thermal_max_age_s', 30.0, ParameterDescriptor(
            description='With a thermal model: pulse samples wait, by stamp, for the '
            'temperatures that decide their bias; those may lie at most this far (stamp time) '
            'beyond the sample\'s averaging interval, else the sample is not published, s.',
            floating_point_range=[FloatingPointRange(from_value=1.0, to_value=3600.0)]))
        self.frame_id = self.get_parameter('frame_id').value
        self.gyro_id = self.get_parameter('gyro_id').value
        self.thermal_max_age_s = float(self.get_parameter('thermal_max_age_s').value)
        self._thermal_state = ''
        self.add_on_set_parameters_callback(self._check_runtime_change)
        self.converter: PulseRateConverter | None = None
        self._file_key: tuple[int, int, int] | None = None
        self._last_problem = ''
        self._skipped = 0
        self.pub = self.create_publisher(Imu, relative(GYRO_IMU), IMU_QOS)
        self.create_subscription(JointState, relative(topics.GYRO_PULSES), self._on_pulses,
                                 SENSOR_QOS)
        self.create_subscription(Temperature, relative(topics.GYRO_TEMPERATURE),
                                 self._on_temperature, SENSOR_QOS)
        self._poll_file()
        self.create_timer(self.get_parameter('reload_period_s').value, self._poll_file)

    def _check_runtime_change(self, params: list[Parameter[Any]]) -> SetParametersResult:
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
            calibration = pulse_calibration(load_calibration(path, handoff_schema()),
                                            use_k_tilde=self.use_k_tilde, gyro_id=self.gyro_id)
        except GyroCalibError as exc:
            self._problem(str(exc))
            return
        if self.converter is None:
            self.converter = PulseRateConverter(calibration,
                                                thermal_max_age_s=self.thermal_max_age_s)
        else:
            self.converter.calibration = calibration
        self._last_problem = ''
        c = calibration
        self.get_logger().info(
            f'calibration loaded from {path}: {scale_factor_line(c)}, bias = '
            + (f'{c.bias_rad_s!r} ± {c.bias_std!r} rad/s' if c.thermal_model is None
               else 'from thermal_model') + f'; publishing {GYRO_IMU}')
        m = c.thermal_model
        if m is not None:
            self._thermal_state = ''
            self.get_logger().info(
                f'thermal model of gyro {m.gyro_id or "(unnamed)"}: bias = b0 + '
                f'{" + ".join(m.terms) or "(constant)"}, calibrated H {m.h_range_c[0]:.2f}…'
                f'{m.h_range_c[1]:.2f} °C ± {m.extrapolation_margin_c:g} °C; the bias is '
                f'taken live from {topics.GYRO_TEMPERATURE}'
                + ('' if c.scale_factor_key != 'thermal_model' else
                   '; K is the one the model was fitted with (its uncertainty is not in the '
                   'file, so the Imu variance leaves it out)'))
            if not self.gyro_id:
                self.get_logger().warning('parameter gyro_id is not set: the thermal model\'s '
                                          'gyro identity is not checked.')
        elif not c.bias_known:
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
            self._publish([Rejection(t_ns, f'no position for joint "{topics.GYRO_JOINT}" '
                                           f'(names {list(msg.name)}).')])
            return
        self._publish(self.converter.add_pulse(t_ns, count))

    def _on_temperature(self, msg: Temperature) -> None:
        if self.converter is not None:
            self._publish(self.converter.add_temperature(
                stamp_to_ns(msg.header.stamp), msg.temperature, msg.header.frame_id))

    def _publish(self, outs: list[ImuAngularVelocity | Rejection]) -> None:
        """Publish the released rates in stamp order; log why samples got none."""
        for out in outs:
            if isinstance(out, Rejection) and out.reason.startswith('no thermal compensation'):
                self._thermal_problem(out.reason)
                continue
            if isinstance(out, ImuAngularVelocity) and self._thermal_state:
                self._thermal_state = ''
                bias = self.converter.last_bias if self.converter is not None else None
                self.get_logger().info(
                    f'thermal compensation resumed at stamp {out.stamp_ns} ns'
                    + (f' (bias {bias[0] / RAD_S_PER_DEG_H:.4f} °/h)' if bias is not None
                       else '') + f'; publishing {GYRO_IMU} again.')
            if isinstance(out, Rejection):
                self._skipped += 1
                if self._skipped % 100 == 1:
                    self.get_logger().warning(
                        f'{self._skipped} pulse sample(s) skipped so far; latest: {out.reason}')
            else:
                self.pub.publish(self._imu(out))

    def _thermal_problem(self, reason: str) -> None:
        """Log why nothing is published, once per kind of reason (numbers aside)."""
        kind = re.sub(r'[-+0-9.:]+', '#', reason)
        if kind != self._thermal_state:
            self._thermal_state = kind
            self.get_logger().warning(f'{reason} Publishing nothing on {GYRO_IMU} until the '
                                    'thermal model can give the bias.')

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
    """Run the IMU corrector node until SIGINT/SIGTERM."""
    run_node('imu_corrector', ImuCorrectorNode, args)


if __name__ == '__main__':
    main()
