"""calibration_node: K̃ of a rate-biased RLG, live from the topic contract.

Subscribes /rate_table/joint_states, /rate_table/zero_index and /gyro/pulses,
feeds the core :class:`~gyro_calib.calibrator.RateBiasCalibrator` by stamp, and
publishes /gyro_calib/k_tilde (rad/pulse, transient-local) and /diagnostics.
Parameters: every field of :class:`~gyro_calib.config.KTildeConfig`, plus
``config_file`` (YAML; plain mapping or ROS 2 parameter file) whose values win
over the defaults.
"""

from __future__ import annotations

import math

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Header

from gyro_calib import topics
from gyro_calib.calibrator import CalibrationUpdate, RateBiasCalibrator
from gyro_calib.config import KTildeConfig, k_tilde_config_from_mapping, load_k_tilde_config
from gyro_calib.errors import GyroCalibError, InsufficientDataError
from gyro_calib.nodes.ros_io import (
    EVENT_QOS,
    RESULT_QOS,
    SENSOR_QOS,
    declare_dataclass_parameters,
    spin,
    stamp_to_ns,
)
from gyro_calib.units import RAD_PER_ARCSEC


class CalibrationNode(Node):
    """Translates the topic contract to core calls and results to topics and logs."""

    def __init__(self) -> None:
        """Declare parameters, build the calibrator, wire topics."""
        super().__init__('calibration_node')
        values = declare_dataclass_parameters(self, KTildeConfig)
        self.declare_parameter('config_file', '', ParameterDescriptor(
            description='YAML file with calibration settings; its values override parameters.'))
        path = self.get_parameter('config_file').value
        self.config = (load_k_tilde_config(path) if path
                       else k_tilde_config_from_mapping(values, source='ROS parameters'))
        self.add_on_set_parameters_callback(self._refuse_runtime_change)
        self.calibrator = RateBiasCalibrator(self.config)
        self._last_rejection = ''
        self._bad_messages = 0
        self.create_subscription(JointState, topics.GYRO_PULSES, self._on_pulses, SENSOR_QOS)
        self.create_subscription(
            JointState, topics.RATE_TABLE_JOINT_STATES, self._on_table, SENSOR_QOS)
        self.create_subscription(Header, topics.RATE_TABLE_ZERO_INDEX, self._on_index, EVENT_QOS)
        self.k_tilde_pub = self.create_publisher(Float64, topics.K_TILDE, RESULT_QOS)
        self.diag_pub = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, 10)
        self.create_timer(0.2, self._process)
        self.create_timer(1.0, self._publish_diagnostics)
        self.get_logger().info(
            f'calibrating K̃ over m = {self.config.revolutions_per_window} revolution windows; '
            f'waiting for {topics.GYRO_PULSES}, {topics.RATE_TABLE_JOINT_STATES}, '
            f'{topics.RATE_TABLE_ZERO_INDEX}')

    def _refuse_runtime_change(self, params: list) -> SetParametersResult:
        return SetParametersResult(successful=False, reason=(
            'calibration parameters are read at start-up; restart the node to change them.'))

    def _joint_sample(self, msg: JointState, joint: str) -> tuple[int, float, float] | None:
        try:
            i = msg.name.index(joint) if msg.name else 0
            velocity = msg.velocity[i] if len(msg.velocity) > i else math.nan
            return stamp_to_ns(msg.header.stamp), msg.position[i], velocity
        except (ValueError, IndexError):
            self._bad_messages += 1
            if self._bad_messages == 1:
                self.get_logger().error(
                    f'JointState without a position for joint "{joint}" (names {list(msg.name)}); '
                    'such messages are skipped.')
            return None

    def _on_pulses(self, msg: JointState) -> None:
        sample = self._joint_sample(msg, topics.GYRO_JOINT)
        if sample is not None:
            self.calibrator.add_pulses(sample[0], sample[1])

    def _on_table(self, msg: JointState) -> None:
        sample = self._joint_sample(msg, topics.RATE_TABLE_JOINT)
        if sample is not None:
            self.calibrator.add_table_state(*sample)

    def _on_index(self, msg: Header) -> None:
        self.calibrator.add_zero_index(stamp_to_ns(msg.stamp))

    def _process(self) -> None:
        self._report(self.calibrator.process())

    def _report(self, update: CalibrationUpdate) -> None:
        log = self.get_logger()
        for notice in update.notices:
            log.warning(notice)
        for rejection in update.rejections:
            self._last_rejection = rejection.reason
            log.warning(f'skipped: {rejection.reason}')
        for w in update.windows:
            log.info(f'window accepted: {"+" if w.direction > 0 else "-"}{w.revolutions} rev, '
                     f'N = {w.pulses:.3f} ± {w.pulses_std:.3f} pulses over {w.duration_s:.3f} s')
        if not update.pairs:
            return
        try:
            k = self.calibrator.k_tilde()
        except InsufficientDataError:
            return
        self.k_tilde_pub.publish(Float64(data=k.value * RAD_PER_ARCSEC))
        log.info(f'K̃ = {k.value:.10f} ″/pulse ± {k.relative_uncertainty * 1e6:.4f} ppm '
                 f'({k.n_used} pairs)')
        self._publish_diagnostics()

    def _publish_diagnostics(self) -> None:
        cal = self.calibrator
        status = DiagnosticStatus(name='gyro_calib: k_tilde', hardware_id='gyro')
        values = {
            'window_pairs': str(len(cal.pairs)),
            'windows_accepted': str(len(cal.windows)),
            'windows_rejected': str(len(cal.rejections)),
            'pulse_samples_missing': str(sum(w.pulse_samples_missing for w in cal.windows)),
            'last_rejection': self._last_rejection,
            'pulse_stream_dropped': cal.pulses.stats.summary(),
            'table_stream_dropped': cal.table.stats.summary(),
        }
        try:
            k = cal.k_tilde()
            eb = cal.earth_plus_bias_deg_h()
        except InsufficientDataError as exc:
            status.level, status.message = DiagnosticStatus.WARN, str(exc)
        else:
            status.level = DiagnosticStatus.OK
            status.message = f'K̃ from {k.n_used} window pairs'
            values.update({
                'k_tilde_rad_per_pulse': repr(k.value * RAD_PER_ARCSEC),
                'k_tilde_std_uncertainty_rad_per_pulse': repr(k.std_uncertainty * RAD_PER_ARCSEC),
                'k_tilde_arcsec_per_pulse': repr(k.value),
                'k_tilde_std_uncertainty_arcsec_per_pulse': repr(k.std_uncertainty),
                'earth_plus_bias_deg_h': repr(eb.value),
                'earth_plus_bias_std_uncertainty_deg_h': repr(eb.std_uncertainty),
            })
        status.values = [KeyValue(key=k_, value=v) for k_, v in values.items()]
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        self.diag_pub.publish(array)


def main(args: list[str] | None = None) -> None:
    """Run the calibration node until shut down."""
    try:
        with rclpy.init(args=args):
            try:
                node = CalibrationNode()
            except GyroCalibError as exc:
                rclpy.logging.get_logger('calibration_node').fatal(str(exc))
                raise SystemExit(1) from None
            spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
