"""A node that dies makes its DDS test fail at once, never a wait to the test's timeout.

On Jazzy every node once died at start-up (issue 34) and each DDS test then waited its
whole timeout (600 s) for results that could not come.
"""

from __future__ import annotations

import time

import pytest

from .dds_harness import NodeDied, NodeProcess, ResultListener, bench_node, launch, wait_discovered


def test_a_node_that_dies_fails_the_wait_at_once_with_its_log(
        listener: ResultListener, nodes: list[NodeProcess]) -> None:
    nodes.append(launch('calibration_node', {'latitude_deg': 400.0}))  # exits 2: bad input
    start = time.monotonic()
    with pytest.raises(NodeDied, match=r'calibration_node exited with status 2(.|\n)*'
                                       r'latitude_deg'):
        listener.spin_until(lambda: False, timeout_s=120.0)
    assert time.monotonic() - start < 60.0


def test_a_node_the_test_stops_or_expects_to_end_is_no_failure(
        listener: ResultListener, nodes: list[NodeProcess]) -> None:
    bad = launch('calibration_node', {'latitude_deg': 400.0}, expect_exit=(2,))
    stopped = launch('calibration_node', {})
    nodes += [bad, stopped]
    bad.proc.wait(timeout=60)
    stopped.stop(timeout_s=30.0)
    assert not listener.spin_until(lambda: False, timeout_s=1.0)


def test_a_bench_node_is_gone_after_its_test_failed_on_both_distributions() -> None:
    """A failed assertion inside ``bench_node`` leaves no reader behind for the next test.

    Jazzy's rclpy does not destroy a context's nodes when it shuts down (Kilted's does): a
    bench left alive kept a reliable reader of /imu/data that never read, and the next
    test's bag_player stalled on it ("2 connected", CI of stop 44).
    """
    from std_msgs.msg import String

    from gyro_calib.nodes.ros_io import SENSOR_QOS

    with bench_node('test_harness_probe_writer') as (writer_node, executor):
        writer = writer_node.create_publisher(String, '/harness/probe', SENSOR_QOS)
        with pytest.raises(AssertionError, match='the test failed'):
            with bench_node('test_harness_probe_reader') as (reader_node, _):
                reader_node.create_subscription(String, '/harness/probe', lambda _: None,
                                                SENSOR_QOS)
                assert wait_discovered(executor, lambda: writer.get_subscription_count() == 1,
                                       timeout_s=30.0, settle_s=0.0)
                raise AssertionError('the test failed')
        assert wait_discovered(executor, lambda: writer.get_subscription_count() == 0,
                               timeout_s=10.0, settle_s=0.0)
