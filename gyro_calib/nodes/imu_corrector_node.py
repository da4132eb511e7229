"""imu_corrector: calibrated sensor_msgs/Imu from a gyro's, or a triad's, cumulative counts.

The hand-off file chooses the mode (behaviour without ROS:
:class:`gyro_calib.nodes.imu_corrector_core.ImuCorrector`):

**Single gyro** (a file without ``imu:``). Subscribes /gyro/pulses (sensor_msgs/JointState,
name ['gyro'], position = count) — or, with a FOG's file (``fog_scale_factor_counts_per_rad``
or ``fog_self_cal_scale_factor_counts_per_rad``), /fog/output (name ['fog']) — and publishes
:data:`GYRO_IMU`: angular_velocity.z = K·Δcount/Δt − bias (rad/s; a FOG: K = 1/SF and its
asymmetry) between consecutive samples by their stamps, with its variance; the maths and the
choice of x/y covariance are in :mod:`gyro_calib.imu_conversion`. A FOG's log line says which
scale factor applies (turntable or self-calibrated) and why.

**Triad** (a format-4 file with an ``imu:`` section). Subscribes /imu/pulses (JointState, the
three channel names of ``imu.channels`` in any order; a sample with other names is refused,
logged once and then every 1000th) and publishes :data:`IMU_DATA`: ω = M·ṅ − b with the full
3×3 covariance (METHODS §F.6 eq. (17)); with ``equal_variances`` the largest variance on every
axis and no correlation (eq. (18), for consumers such as Autoware's imu_corrector that use one
variance). Channels with a thermal model read /imu/<channel>/temperature (eq. (19)).

Orientation is marked unavailable (covariance[0] = −1, sensor_msgs/Imu, REP 145). So is the
linear acceleration, unless ``accel_input`` names the IMU driver's own sensor_msgs/Imu topic
(issue 36 §3): then each rate waits for the accelerometer sample of its stamp (within
``accel_tolerance_s``) and is published with that sample's linear_acceleration and
linear_acceleration_covariance passed through; a rate without one is not published.

Parameters: ``calibration_file`` (hand-off YAML, :mod:`gyro_calib.handoff`; re-read at
every poll, so it may also be set at run time), ``use_k_tilde`` (take K̃ with θ = 0 when the
file has no K), ``frame_id`` (single gyro), ``imu_frame_id`` (triad), ``equal_variances``,
``reload_period_s``, ``gyro_id``, ``thermal_max_age_s``, ``accel_input`` and
``accel_tolerance_s``, ``imu_input`` and ``raw_scale_rad_per_pulse``.

**Imu mode** (``imu_input``, issue 36 §5): a MEMS or FOG IMU driver's sensor_msgs/Imu in,
/imu/data out with the message's own accelerometers (see
:mod:`gyro_calib.nodes.imu_corrector_core`). With a multiposition hand-off (an ``imu:``
section with ``accelerometer``) the gyro is ω = M·ω_raw − b (K₀ = 1: the section's pulse is
one raw unit·s) and the accelerometers are corrected too, a = A·r − b_a, with covariance.
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

from typing import TYPE_CHECKING, Any

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu, JointState, Temperature

from gyro_calib import topics
from gyro_calib.nodes.imu_corrector_core import (
    GYRO_IMU,
    IMU_DATA,
    IMU_PULSES,
    ImuCorrector,
    Output,
    channel_temperature_topic,
)
from gyro_calib.nodes.ros_io import (
    SENSOR_QOS,
    declare_parameter_value,
    ns_to_stamp,
    run_node,
    stamp_to_ns,
)
from gyro_calib.topics import relative

if TYPE_CHECKING:
    from rclpy.parameter import Parameter
    from rclpy.publisher import Publisher

__all__ = ['GYRO_IMU', 'IMU_DATA', 'IMU_QOS', 'ImuCorrectorNode', 'main']

IMU_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
"""Output: reliable (so reliable and best-effort subscribers both match) but KEEP_LAST, so
a slow consumer loses old samples instead of stalling the correction of new ones."""


class ImuCorrectorNode(Node):
    """Translates messages to :class:`ImuCorrector` calls and its rates to Imu messages."""

    def __init__(self) -> None:
        """Declare parameters, wire topics, load the calibration and start polling it."""
        super().__init__('imu_corrector')
        declare_parameter_value(self, 'calibration_file', '', ParameterDescriptor(description=(
            'Hand-off calibration YAML (gyro_calib.handoff; a triad\'s: format 4 with imu:); '
            'required. Polled and reloaded when it changes; nothing is published until a '
            'valid file is read.')))
        declare_parameter_value(self, 'use_k_tilde', False, ParameterDescriptor(description=(
            'Take K̃ (k_tilde_rad_per_pulse) as the scale factor, i.e. θ = 0, when θ was not '
            'measured; by default K (scale_factor_rad_per_pulse) is required.')))
        declare_parameter_value(self, 'frame_id', 'gyro', ParameterDescriptor(
            description='header.frame_id of the single-gyro Imu messages; its z axis is the '
                        'sense axis.'))
        declare_parameter_value(self, 'imu_frame_id', 'imu_link', ParameterDescriptor(
            description='header.frame_id of the triad\'s Imu messages (/imu/data): the IMU '
                        'body frame of M.'))
        declare_parameter_value(self, 'equal_variances', False, ParameterDescriptor(
            description='Triad mode: publish the largest of the three angular-velocity '
                        'variances on every axis and zero covariances (for consumers that '
                        'use one variance for all axes, e.g. Autoware\'s imu_corrector).'))
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
        declare_parameter_value(self, 'accel_input', '', ParameterDescriptor(description=(
            'The IMU driver\'s sensor_msgs/Imu topic whose linear_acceleration (and its '
            'covariance) is passed through on the output, matched by stamp; \'\' = none '
            '(the output then marks the acceleration unavailable).')))
        declare_parameter_value(self, 'accel_tolerance_s', 1e-4, ParameterDescriptor(
            description='With accel_input: an accelerometer sample pairs with the rate of '
                        'the same stamp within this many seconds.',
            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=1.0)]))
        declare_parameter_value(self, 'imu_input', '', ParameterDescriptor(description=(
            'Imu mode: a MEMS or FOG IMU driver\'s sensor_msgs/Imu topic, corrected with the '
            'hand-off\'s gyro model (a triad file: M, b, thermal model, full covariance, with '
            'raw_scale_rad_per_pulse; an IMU noise run\'s file: per-sample covariance) and '
            'published on /imu/data with its accelerometers; \'\' = off.')))
        declare_parameter_value(self, 'raw_scale_rad_per_pulse', 0.0, ParameterDescriptor(
            description='Imu mode with a triad file: the common scale factor K0 the driver '
                        'publishes each channel\'s rate with (ω = K0·Δn/Δt), rad/pulse.'))
        self.frame_ids = {GYRO_IMU: self.get_parameter('frame_id').value,
                          IMU_DATA: self.get_parameter('imu_frame_id').value}
        self.core = ImuCorrector(
            self, use_k_tilde=bool(self.get_parameter('use_k_tilde').value),
            gyro_id=self.get_parameter('gyro_id').value,
            thermal_max_age_s=float(self.get_parameter('thermal_max_age_s').value),
            equal_variances=bool(self.get_parameter('equal_variances').value),
            accel_input=str(self.get_parameter('accel_input').value),
            accel_tolerance_ns=int(round(
                float(self.get_parameter('accel_tolerance_s').value) * 1e9)),
            imu_input=str(self.get_parameter('imu_input').value),
            raw_scale_rad_per_pulse=float(self.get_parameter('raw_scale_rad_per_pulse').value))
        self.add_on_set_parameters_callback(self._check_runtime_change)
        self.pubs: dict[str, Publisher[Imu]] = {
            GYRO_IMU: self.create_publisher(Imu, relative(GYRO_IMU), IMU_QOS),
            IMU_DATA: self.create_publisher(Imu, relative(IMU_DATA), IMU_QOS)}
        self._channel_subs: dict[str, Any] = {}
        self.create_subscription(JointState, relative(topics.GYRO_PULSES), self._on_pulses,
                                 SENSOR_QOS)
        self.create_subscription(JointState, relative(topics.FOG_OUTPUT), self._on_fog,
                                 SENSOR_QOS)
        self.create_subscription(JointState, relative(IMU_PULSES), self._on_imu_pulses,
                                 SENSOR_QOS)
        self.create_subscription(Temperature, relative(topics.GYRO_TEMPERATURE),
                                 self._on_temperature, SENSOR_QOS)
        if self.core.imu_input:
            self.create_subscription(Imu, self.core.imu_input, self._on_imu, SENSOR_QOS)
        elif self.core.accel_input:
            self.create_subscription(Imu, self.core.accel_input, self._on_accel, SENSOR_QOS)
        self._poll_file()
        self.create_timer(self.get_parameter('reload_period_s').value, self._poll_file)

    def _check_runtime_change(self, params: list[Parameter[Any]]) -> SetParametersResult:
        fixed = [p.name for p in params if p.name != 'calibration_file']
        return SetParametersResult(successful=not fixed, reason=(
            f'{", ".join(fixed)} is read at start-up; restart the node to change it.'
            if fixed else ''))

    def _poll_file(self) -> None:
        self.core.poll_file(self.get_parameter('calibration_file').value)
        for channel in self.core.thermal_channels:
            if channel not in self._channel_subs:
                topic = channel_temperature_topic(channel)
                try:
                    self._channel_subs[channel] = self.create_subscription(
                        Temperature, relative(topic),
                        lambda msg, c=channel: self._on_channel_temperature(c, msg),
                        SENSOR_QOS)
                except Exception as exc:  # an invalid topic name (rclpy's own exception)
                    self.get_logger().error(
                        f'channel {channel!r}: cannot subscribe {topic} ({exc}); its thermal '
                        'bias cannot be had, so nothing is published. Name the channels '
                        'with letters, digits and underscores.')
                    self._channel_subs[channel] = None

    def _on_pulses(self, msg: JointState) -> None:
        self._publish(self.core.on_gyro_pulses(stamp_to_ns(msg.header.stamp), list(msg.name),
                                               list(msg.position)))

    def _on_fog(self, msg: JointState) -> None:
        self._publish(self.core.on_fog_output(stamp_to_ns(msg.header.stamp), list(msg.name),
                                              list(msg.position)))

    def _on_imu_pulses(self, msg: JointState) -> None:
        self._publish(self.core.on_imu_pulses(stamp_to_ns(msg.header.stamp), list(msg.name),
                                              list(msg.position)))

    def _on_imu(self, msg: Imu) -> None:
        w, a = msg.angular_velocity, msg.linear_acceleration
        self._publish(self.core.on_imu(stamp_to_ns(msg.header.stamp), (w.x, w.y, w.z),
                                       (a.x, a.y, a.z),
                                       tuple(msg.linear_acceleration_covariance)))

    def _on_accel(self, msg: Imu) -> None:
        a = msg.linear_acceleration
        self._publish(self.core.on_accel(stamp_to_ns(msg.header.stamp), (a.x, a.y, a.z),
                                         tuple(msg.linear_acceleration_covariance)))

    def _on_temperature(self, msg: Temperature) -> None:
        self._publish(self.core.on_temperature(stamp_to_ns(msg.header.stamp), msg.temperature,
                                               msg.header.frame_id))

    def _on_channel_temperature(self, channel: str, msg: Temperature) -> None:
        self._publish(self.core.on_channel_temperature(
            channel, stamp_to_ns(msg.header.stamp), msg.temperature, msg.header.frame_id))

    def _publish(self, outs: list[Output]) -> None:
        """Publish the released rates in stamp order."""
        for topic, out in outs:
            imu = Imu()
            ns_to_stamp(out.stamp_ns, imu.header.stamp)
            imu.header.frame_id = self.frame_ids[topic]
            v = imu.angular_velocity
            v.x, v.y, v.z = out.angular_velocity_rad_s
            imu.angular_velocity_covariance = list(out.covariance_rad2_s2)
            imu.orientation_covariance[0] = -1.0  # no orientation estimate
            if out.linear_acceleration_m_s2 is None:
                imu.linear_acceleration_covariance[0] = -1.0  # no accelerometer
            else:
                a = imu.linear_acceleration
                a.x, a.y, a.z = out.linear_acceleration_m_s2
                imu.linear_acceleration_covariance = list(
                    out.linear_acceleration_covariance or [0.0] * 9)
            self.pubs[topic].publish(imu)


def main(args: list[str] | None = None) -> None:
    """Run the IMU corrector node until SIGINT/SIGTERM."""
    run_node('imu_corrector', ImuCorrectorNode, args)


if __name__ == '__main__':
    main()
