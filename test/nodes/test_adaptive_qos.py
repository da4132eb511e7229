"""Any sensor driver's QoS (issue 19 part 3).

Any sensor driver's QoS (issue 19 part 3): a calibration node hears best-effort and reliable
publishers, as ``ros2 bag record`` does, and adapts again when publishers come and go.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import JointState

from gyro_calib.nodes.adaptive_qos import BEST_EFFORT, RELIABLE, reliability_for
from gyro_calib.nodes.ros_io import SENSOR_QOS, make_executor


class Graph:
    """rclpy's default context with an executor, for this process's nodes.

    rclpy's default context (the nodes under test make their nodes in it) with an
    executor, for nodes made in this process; shut down afterwards (``rclpy.shutdown()``
    without a context also gives the next test a fresh default context).
    """

    def __init__(self) -> None:
        import rclpy

        self.rclpy = rclpy
        rclpy.init()
        self.context = rclpy.get_default_context()
        self.executor = make_executor(self.context)
        self.nodes: list[Any] = []

    def node(self, name: str) -> Any:
        node = self.rclpy.create_node(name, context=self.context)
        self.add(node)
        return node

    def add(self, node: Any) -> Any:
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def spin_until(self, done: Callable[[], bool], timeout_s: float = 30.0) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
            if done():
                return True
        return False

    def close(self) -> None:
        for node in self.nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()
        self.rclpy.shutdown()


@pytest.fixture
def graph() -> Iterator[Graph]:
    g = Graph()
    yield g
    g.close()


def _pulses(n: int) -> JointState:
    msg = JointState(name=['gyro'], position=[float(n)])
    msg.header.stamp.sec, msg.header.frame_id = n, 'gyro'
    return msg


def test_reliability_follows_the_publishers_as_ros2_bag_record() -> None:
    assert reliability_for([]) is None  # nobody publishes: keep what we have
    assert reliability_for([RELIABLE, RELIABLE]) == RELIABLE
    assert reliability_for([RELIABLE, BEST_EFFORT]) == BEST_EFFORT
    assert reliability_for([BEST_EFFORT]) == BEST_EFFORT


def test_a_best_effort_driver_and_a_reliable_one_are_both_heard(graph: Graph) -> None:
    """Both a best-effort driver and a reliable one are heard.

    The dither node's two inputs: pulses from a best-effort driver (sensor-data QoS),
    the vibration table reliable; both reach the node's buffers, the choice is logged, and
    the pulses go back to reliable when the best-effort driver leaves.
    """
    from gyro_calib.dither import topics
    from gyro_calib.dither.settings import DitherSettings
    from gyro_calib.nodes.method_node import MethodNode

    node = graph.add(MethodNode('dither', 'dither_calibration_node',
                                {}, DitherSettings))
    node._process = lambda: None  # keep the samples in the buffers, to count them
    drivers = graph.node('drivers')
    best_effort_driver = drivers.create_publisher(JointState, topics.GYRO_PULSES,
                                                  qos_profile_sensor_data)
    table = drivers.create_publisher(JointState, topics.VIBRATION_TABLE_JOINT_STATES,
                                     SENSOR_QOS)
    inputs = {s.topic: s for s in node._inputs}
    pulses = inputs[topics.GYRO_PULSES]
    assert graph.spin_until(lambda: pulses.reliability == BEST_EFFORT)
    assert inputs[topics.VIBRATION_TABLE_JOINT_STATES].reliability == RELIABLE
    assert graph.spin_until(lambda: pulses.subscription.get_publisher_count() == 1
                            and table.get_subscription_count() == 1)
    sent = 0
    arrived = dict.fromkeys(node._live_inputs.buffers, 0)  # messages each reader delivered
    deliver = node._live_inputs.add

    def counted(topic: str, stamp: int, payload: Any) -> None:
        arrived[topic] += 1
        deliver(topic, stamp, payload)

    node._live_inputs.add = counted

    def heard() -> bool:
        nonlocal sent
        sent += 1
        best_effort_driver.publish(_pulses(sent))
        table.publish(_pulses(sent))
        return all(n >= 5 for n in arrived.values())

    assert graph.spin_until(heard)  # both heard
    drivers.destroy_publisher(best_effort_driver)
    reliable_driver = drivers.create_publisher(JointState, topics.GYRO_PULSES,
                                               QoSProfile(depth=10,
                                                          reliability=ReliabilityPolicy.RELIABLE))
    assert graph.spin_until(lambda: pulses.reliability == RELIABLE)
    assert pulses.switches == 2
    before = arrived[topics.GYRO_PULSES]
    assert graph.spin_until(lambda: pulses.subscription.get_publisher_count() == 1)
    reliable_driver.publish(_pulses(10_000))
    assert graph.spin_until(lambda: arrived[topics.GYRO_PULSES] > before)
