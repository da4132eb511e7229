"""rlg_sim: the simulated ring laser gyro, integrating the table's true motion.

Subscribes /sim/rate_table/true_motion, publishes /gyro/pulses (one message per
sample, cumulative count in position[0]). Parameters: every field of
:class:`~sim_nodes.ring_laser_gyro.RingLaserGyroConfig`. If the table's stamps
jump back (the table restarted) the gyro restarts too.
"""

from __future__ import annotations

import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from sensor_msgs.msg import JointState

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    SENSOR_QOS,
    declare_dataclass_parameters,
    spin,
    ns_to_stamp,
    publish_paced,
    stamp_to_ns,
)
from sim_nodes.ring_laser_gyro import RingLaserGyroConfig, RingLaserGyroSimulator


class RingLaserGyroNode(Node):
    """Turns true-motion batches into pulse samples."""

    def __init__(self) -> None:
        """Declare parameters and wire the topics."""
        super().__init__('rlg_sim')
        self.config = RingLaserGyroConfig(
            **declare_dataclass_parameters(self, RingLaserGyroConfig))
        self.sim = RingLaserGyroSimulator(self.config)
        self.pub = self.create_publisher(JointState, topics.GYRO_PULSES, SENSOR_QOS)
        self.create_subscription(
            JointState, topics.RATE_TABLE_TRUE_MOTION, self._on_truth, SENSOR_QOS)

    def _on_truth(self, msg: JointState) -> None:
        t_ns = stamp_to_ns(msg.header.stamp) + np.asarray(msg.effort, dtype=np.int64)
        last = self.sim.last_stamp_ns
        if last is not None and t_ns[0] <= last:
            self.get_logger().warning('table stamps jumped back: the table restarted; '
                                      'the gyro restarts with it.')
            self.sim = RingLaserGyroSimulator(self.config)
        counts = self.sim.step(t_ns, np.asarray(msg.position, dtype=np.float64))
        for t, n in zip(t_ns.tolist(), counts.tolist()):
            out = JointState(name=[topics.GYRO_JOINT], position=[n])
            ns_to_stamp(t, out.header.stamp)
            out.header.frame_id = topics.GYRO_JOINT
            publish_paced(self.pub, out)


def main(args: list[str] | None = None) -> None:
    """Run the gyro simulator until shut down."""
    try:
        with rclpy.init(args=args):
            spin(RingLaserGyroNode())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
