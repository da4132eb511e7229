"""rate_table_sim: the simulated rate-bias turntable, time master of the bench.

Publishes /rate_table/joint_states, /rate_table/zero_index and, for the gyro
simulator only, /sim/rate_table/true_motion (true angle batches). Parameters:
every field of :class:`~sim_nodes.rate_table.RateTableConfig`, plus
``real_time_factor`` (simulated seconds per wall second; 0 = as fast as the
process can go) and ``exit_when_done``.
"""

from __future__ import annotations

import time

import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    EVENT_QOS,
    SENSOR_QOS,
    declare_dataclass_parameters,
    make_executor,
    ns_to_stamp,
    publish_paced,
)
from sim_nodes.bench import CHUNK_SAMPLES
from sim_nodes.rate_table import RateTableConfig, RateTableSimulator, TableChunk


class RateTableNode(Node):
    """Streams the table simulator's chunks at a paced rate."""

    def __init__(self) -> None:
        """Declare parameters and start the pacing timer."""
        super().__init__('rate_table_sim')
        self.config = RateTableConfig(**declare_dataclass_parameters(self, RateTableConfig))
        self.real_time_factor = self.declare_parameter('real_time_factor', 1.0, ParameterDescriptor(
            description='Simulated seconds per wall-clock second (0 = unpaced).')).value
        self.exit_when_done = self.declare_parameter('exit_when_done', True, ParameterDescriptor(
            description='Shut the node down once duration_s has been simulated.')).value
        self.wait_for_subscribers = self.declare_parameter(
            'wait_for_subscribers', True, ParameterDescriptor(
                description='Start only once the gyro (true motion) and a reader of joint_states '
                            'and zero_index are connected, so nothing is lost at the start.')).value
        self.sim = RateTableSimulator(self.config)
        self.js_pub = self.create_publisher(JointState, topics.RATE_TABLE_JOINT_STATES, SENSOR_QOS)
        self.index_pub = self.create_publisher(Header, topics.RATE_TABLE_ZERO_INDEX, EVENT_QOS)
        self.truth_pub = self.create_publisher(
            JointState, topics.RATE_TABLE_TRUE_MOTION, SENSOR_QOS)
        self._n_published = 0
        self._wall_start: float | None = None
        self._ready_since: float | None = None
        self.done = False
        self.create_timer(0.005, self._tick)

    def _tick(self) -> None:
        if self._wall_start is None:
            pubs = (self.truth_pub, self.js_pub, self.index_pub)
            if self.wait_for_subscribers and not all(p.get_subscription_count() for p in pubs):
                return  # the gyro must integrate from our first sample, the calibrator see it
            if self._ready_since is None:
                self._ready_since = time.monotonic()
            if self.wait_for_subscribers and time.monotonic() - self._ready_since < 1.0:
                return  # let the gyro's pulse publisher finish discovery too
            self._wall_start = time.monotonic()
            self.get_logger().info(f'simulating {self.config.duration_s:g} s at '
                                   f'{self.real_time_factor:g}× real time')
        rate = self.config.sample_rate_hz
        budget = 20 if self.real_time_factor <= 0 else None
        while not self.sim.finished and (budget is None or budget > 0):
            if budget is None:
                sim_due = (time.monotonic() - self._wall_start) * self.real_time_factor
                if self._n_published / rate > sim_due:
                    break
            else:
                budget -= 1
            self._publish(self.sim.step(CHUNK_SAMPLES))
        if self.sim.finished and not self.done:
            self.done = True
            self.get_logger().info('run finished')

    def _publish(self, chunk: TableChunk) -> None:
        truth = JointState(name=[topics.RATE_TABLE_JOINT])
        ns_to_stamp(int(chunk.t_ns[0]), truth.header.stamp)
        truth.header.frame_id = topics.RATE_TABLE_JOINT
        truth.position = chunk.true_angle_rad.tolist()
        truth.velocity = chunk.true_rate_rad_s.tolist()
        truth.effort = (chunk.t_ns - chunk.t_ns[0]).astype(float).tolist()
        publish_paced(self.truth_pub, truth)
        dec = self.config.joint_state_decimation
        first = (-self._n_published) % dec
        for i in range(first, len(chunk.t_ns), dec):
            msg = JointState(name=[topics.RATE_TABLE_JOINT],
                             position=[float(chunk.encoder_angle_rad[i])],
                             velocity=[float(chunk.encoder_rate_rad_s[i])])
            ns_to_stamp(int(chunk.t_ns[i]), msg.header.stamp)
            msg.header.frame_id = topics.RATE_TABLE_JOINT
            publish_paced(self.js_pub, msg)
        for t_ns in chunk.zero_index_ns.tolist():
            header = Header(frame_id=topics.RATE_TABLE_JOINT)
            ns_to_stamp(t_ns, header.stamp)
            publish_paced(self.index_pub, header)
        self._n_published += len(chunk.t_ns)


def main(args: list[str] | None = None) -> None:
    """Run the table simulator until its run is done (or it is shut down)."""
    try:
        with rclpy.init(args=args):
            node = RateTableNode()
            executor = make_executor()
            executor.add_node(node)
            while rclpy.ok() and not (node.done and node.exit_when_done):
                executor.spin_once(timeout_sec=0.05)
            if node.done:
                for pub in (node.js_pub, node.index_pub, node.truth_pub):
                    pub.wait_for_all_acked(rclpy.duration.Duration(seconds=5.0))
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
