"""triad_sim over DDS: the live streams are the offline scenario's samples, bit for bit.

The node runs a remount scenario at a reduced sample rate as fast as its reader acknowledges;
this process reads /imu/pulses (three channels), the rate table's joint states and zero-index
events, and /sim/scenario, and compares them with the offline bench of the same scenario.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import yaml

from gyro_calib import topics
from sim_nodes.triad.scenarios import IMU_PULSES
from sim_nodes.triad.triad_node import scenario_with

from .dds_harness import NodeProcess, launch, spin_watched

SCENARIO, SEED, RATE_HZ = 'triad_remount_bench_my', 7, 100.0


class _Reader:
    """Collects the triad bench's topics in this process."""

    def __init__(self) -> None:
        import rclpy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Header, String

        from gyro_calib.nodes.ros_io import EVENT_QOS, SCENARIO_QOS, SENSOR_QOS, make_executor

        self._rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('triad_reader', context=self.context)
        self.pulses: list[tuple[int, list[str], list[float]]] = []
        self.table: list[tuple[int, float, float]] = []
        self.index: list[int] = []
        self.scenario: dict[str, Any] = {}

        def ns(stamp: Any) -> int:
            return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)

        sub = self.node.create_subscription
        sub(JointState, IMU_PULSES, lambda m: self.pulses.append(
            (ns(m.header.stamp), list(m.name), list(m.position))), SENSOR_QOS)
        sub(JointState, topics.RATE_TABLE_JOINT_STATES, lambda m: self.table.append(
            (ns(m.header.stamp), m.position[0], m.velocity[0])), SENSOR_QOS)
        sub(Header, topics.RATE_TABLE_ZERO_INDEX, lambda m: self.index.append(ns(m.stamp)),
            EVENT_QOS)
        sub(String, topics.SIM_SCENARIO, lambda m: self.scenario.update(yaml.safe_load(m.data)),
            SCENARIO_QOS)
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)

    def spin_until_exit(self, proc: NodeProcess, timeout_s: float) -> bool:
        import time

        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            spin_watched(self.executor, timeout_sec=0.1)
            if proc.proc.poll() is not None:
                for _ in range(20):  # what was delivered before the exit
                    spin_watched(self.executor, timeout_sec=0.05)
                return True
        return False

    def close(self) -> None:
        self.node.destroy_node()
        self._rclpy.shutdown(context=self.context)


def test_triad_sim_publishes_the_offline_scenario_samples(nodes: list[NodeProcess]) -> None:
    reader = _Reader()
    try:
        sim = launch('triad_sim', {'scenario': SCENARIO, 'seed': SEED,
                                   'sample_rate_hz': RATE_HZ, 'real_time_factor': 0.0})
        nodes.append(sim)
        assert reader.spin_until_exit(sim, 120.0), sim.log()
        assert sim.proc.returncode == 0, sim.log()
    finally:
        reader.close()
    rec = scenario_with(SCENARIO, SEED, RATE_HZ).bench().record()
    assert len(reader.pulses) == len(rec.pulse_t_ns), sim.log()
    assert all(names == ['x', 'y', 'z'] for _, names, _ in reader.pulses)
    np.testing.assert_array_equal([t for t, _, _ in reader.pulses], rec.pulse_t_ns)
    np.testing.assert_array_equal(np.array([p for _, _, p in reader.pulses]), rec.pulse_counts)
    np.testing.assert_array_equal(np.array(reader.table), np.column_stack(
        (rec.rate_table[0].astype(np.float64), rec.rate_table[1], rec.rate_table[2])))
    np.testing.assert_array_equal(reader.index, rec.rate_zero_index_ns)
    assert reader.scenario['bench']['mount_axis'] == '-y'
    assert reader.scenario['gyros']['seed'] == SEED + 1  # table.seed = SEED, gyros SEED + 1
