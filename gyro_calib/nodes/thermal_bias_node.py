"""thermal_bias_node: the thermal model's current bias as geometry_msgs/Vector3Stamped.

For Autoware's imu_corrector ``gyro_bias_input`` (its ``correct_for_dynamic_bias`` path):
remap :data:`THERMAL_BIAS` to it. Subscribes /gyro/pulses and /gyro/temperature as
imu_corrector does and publishes, once per averaging interval of the model, ``vector.z`` =
the bias along the gyro's sense axis (the frame's z, as imu_corrector's Imu), rad/s;
``vector.x`` = ``vector.y`` = 0; the header stamp is that of the pulse sample it was decided
for. Same refusal rules as imu_corrector's rates (:mod:`gyro_calib.thermal.live_bias`):
nothing is published while the model cannot give the bias, one log line says why.

Parameters (read at start-up): ``calibration_file`` (a hand-off with a ``thermal_model``;
without one the node stops with one line, exit 2), ``gyro_id``, ``frame_id`` (default
``gyro``), ``thermal_max_age_s`` (default 30).
"""

from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, Temperature

from gyro_calib import topics
from gyro_calib.errors import ConfigError
from gyro_calib.handoff import load_calibration
from gyro_calib.imu_conversion import pulse_calibration
from gyro_calib.nodes.ros_io import (
    SENSOR_QOS,
    declare_parameter_value,
    ns_to_stamp,
    run_node,
    stamp_to_ns,
)
from gyro_calib.registry import handoff_schema
from gyro_calib.thermal.live_bias import LiveBias, ThermalBiasPublisher
from gyro_calib.topics import relative

THERMAL_BIAS = '/gyro/thermal_bias'
"""geometry_msgs/Vector3Stamped: the thermal model's bias, z along the sense axis, rad/s."""


BIAS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                      reliability=ReliabilityPolicy.RELIABLE)
"""Reliable (reliable and best-effort subscribers both match), KEEP_LAST."""


class ThermalBiasNode(Node):
    """Translates pulses and temperatures to core calls and biases to Vector3Stamped."""

    def __init__(self) -> None:
        """Read the parameters and the thermal model; subscribe; publish THERMAL_BIAS."""
        super().__init__('thermal_bias_node')
        declare_parameter_value(self, 'calibration_file', '', ParameterDescriptor(
            description='hand-off YAML holding a thermal_model'))
        declare_parameter_value(self, 'gyro_id', '', ParameterDescriptor(
            description="the gyro's serial: a model fitted on another gyro is refused"))
        declare_parameter_value(self, 'frame_id', 'gyro', ParameterDescriptor(
            description='header.frame_id of the bias'))
        declare_parameter_value(self, 'thermal_max_age_s', 30.0, ParameterDescriptor(
            description='how far, in stamp time, a bias may wait for its temperatures'))
        path = str(self.get_parameter('calibration_file').value)
        if not path:
            raise ConfigError('parameter calibration_file is not set: give the hand-off YAML '
                              'with a thermal_model (-p calibration_file:=/path/gyro.yaml).')
        loaded = load_calibration(path, handoff_schema())
        if 'thermal_model' not in loaded.values:
            raise ConfigError(f'{path} holds no thermal_model: there is no live bias to '
                              'publish (a constant bias goes in angular_velocity_offset_*; '
                              'gyro-calib export --format autoware).')
        model = pulse_calibration(loaded, gyro_id=str(self.get_parameter('gyro_id').value)
                                  ).thermal_model
        assert model is not None
        self.frame_id = str(self.get_parameter('frame_id').value)
        self.pub = self.create_publisher(Vector3Stamped, relative(THERMAL_BIAS), BIAS_QOS)
        self.core = ThermalBiasPublisher(
            model, self, self._send, topic=THERMAL_BIAS,
            max_wait_s=float(self.get_parameter('thermal_max_age_s').value))
        self.create_subscription(JointState, relative(topics.GYRO_PULSES), self._on_pulses,
                                 SENSOR_QOS)
        self.create_subscription(Temperature, relative(topics.GYRO_TEMPERATURE),
                                 self._on_temperature, SENSOR_QOS)
        self.get_logger().info(f'thermal model of gyro {model.gyro_id or "(unnamed)"} loaded '
                               f'from {path}; publishing {THERMAL_BIAS}')

    def _on_pulses(self, msg: JointState) -> None:
        try:
            count = msg.position[msg.name.index(topics.GYRO_JOINT) if msg.name else 0]
        except (ValueError, IndexError):
            return
        self.core.add_pulse(stamp_to_ns(msg.header.stamp), count)

    def _on_temperature(self, msg: Temperature) -> None:
        self.core.add_temperature(stamp_to_ns(msg.header.stamp), msg.temperature,
                                  msg.header.frame_id)

    def _send(self, bias: LiveBias) -> None:
        self.pub.publish(vector3_stamped(bias, self.frame_id))


def vector3_stamped(bias: LiveBias, frame_id: str) -> Vector3Stamped:
    """The message of one bias: z along the sense axis, x = y = 0, rad/s."""
    msg = Vector3Stamped()
    ns_to_stamp(bias.stamp_ns, msg.header.stamp)
    msg.header.frame_id = frame_id
    msg.vector.z = float(bias.bias_rad_s)
    return msg


def main(args: list[str] | None = None) -> None:
    """Run the thermal bias node until SIGINT/SIGTERM."""
    run_node('thermal_bias_node', ThermalBiasNode, args)


if __name__ == '__main__':
    main()
