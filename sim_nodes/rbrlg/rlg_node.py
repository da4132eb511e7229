"""rlg_sim: the simulated ring laser gyro, integrating the bench's true motion.

Subscribes /sim/rate_table/true_motion (rate-bias table alone: exact closed-form
model) and /sim/bench/true_motion (two-axis bench: composed rotations), publishes
/gyro/pulses (one message per sample, cumulative count in position[0]).
Parameters: every field of :class:`~sim_nodes.rbrlg.ring_laser_gyro.RingLaserGyroConfig`
and, as ``mount.*``, of :class:`~sim_nodes.rbrlg.two_axis_gyro.TiltedMountConfig`. If the
table's stamps jump back (the bench restarted) the gyro restarts too.
"""

from __future__ import annotations

import math
import time

import numpy as np
from sensor_msgs.msg import JointState

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    SENSOR_QOS,
    ProgressLog,
    declare_dataclass_parameters,
    described_parameter,
    ns_to_stamp,
    publish_paced,
    run_node,
    stamp_to_ns,
)
from gyro_calib.topics import relative
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig, RingLaserGyroSimulator
from sim_nodes.rbrlg.two_axis_gyro import TiltedMountConfig, TwoAxisGyroSimulator
from sim_nodes.simulator_node import SimulatorNode


def scenario_yaml(gyro: RingLaserGyroConfig, mount: TiltedMountConfig) -> str:
    """The gyro's part of /sim/scenario: its parameters and the truth they imply."""
    import dataclasses

    import yaml

    from sim_nodes.rbrlg.bench import true_k_tilde_arcsec_per_pulse

    return yaml.safe_dump({
        'gyro': dataclasses.asdict(gyro), 'mount': dataclasses.asdict(mount),
        'truth': {'k_tilde_arcsec_per_pulse': true_k_tilde_arcsec_per_pulse(gyro),
                  'scale_factor_arcsec_per_pulse': gyro.scale_factor_arcsec_per_pulse,
                  'fix_error_angle_arcsec': gyro.fix_error_angle_arcsec}}, sort_keys=True)


class RingLaserGyroNode(SimulatorNode):
    """Turns true-motion batches into pulse samples."""

    def __init__(self) -> None:
        """Declare parameters and wire the topics."""
        super().__init__('rlg_sim')
        self.config = RingLaserGyroConfig(
            **declare_dataclass_parameters(self, RingLaserGyroConfig))
        self.mount = TiltedMountConfig(
            **declare_dataclass_parameters(self, TiltedMountConfig, prefix='mount.'))
        self.subscriber_wait_s = float(described_parameter(
            self, 'subscriber_wait_s', 60.0, 'Before the first pulse, wait up to this long (s) '
            'for a reader of /gyro/pulses, so no pulse is published into the void; 0 = do not '
            'wait.'))
        self.min_subscribers = int(described_parameter(
            self, 'min_subscribers', 1, 'Readers of /gyro/pulses to wait for before the first '
            'pulse (2 when a bag recorder and a calibration node must both hear it).'))
        self.sim: RingLaserGyroSimulator | TwoAxisGyroSimulator | None = None
        self._last_ns: int | None = None
        self._waited_for_reader = False
        self.pub = self.create_publisher(JointState, relative(topics.GYRO_PULSES), SENSOR_QOS)
        self.create_subscription(
            JointState, relative(topics.RATE_TABLE_TRUE_MOTION), self._on_truth, SENSOR_QOS)
        self.create_subscription(
            JointState, relative(topics.BENCH_TRUE_MOTION), self._on_truth, SENSOR_QOS)
        self.publish_scenario(scenario_yaml(self.config, self.mount))
        self._first_ns: int | None = None
        self._published = 0
        self._progress = ProgressLog(self.get_logger(), 'rlg_sim: bench time', math.nan)
        self.get_logger().info(f'waiting for the true motion on {topics.RATE_TABLE_TRUE_MOTION} '
                               f'(rate table alone) or {topics.BENCH_TRUE_MOTION} (two-axis '
                               'bench)')

    def _on_truth(self, msg: JointState) -> None:
        t_ns = stamp_to_ns(msg.header.stamp) + np.asarray(msg.effort, dtype=np.int64)
        if self._last_ns is not None and t_ns[0] <= self._last_ns:
            self.get_logger().warning('table stamps jumped back: the bench restarted; '
                                      'the gyro restarts with it.')
            self.sim = None
        angles = np.asarray(msg.position, dtype=np.float64).reshape(len(msg.name), len(t_ns))
        if self.sim is None:
            self._first_ns = int(t_ns[0])
            self.get_logger().info(
                'true motion received ('
                + ('rate table alone' if len(msg.name) == 1 else 'two-axis bench')
                + f'); publishing {topics.GYRO_PULSES}')
        if len(msg.name) == 1:
            if not isinstance(self.sim, RingLaserGyroSimulator):
                self.sim = RingLaserGyroSimulator(self.config)
            counts = self.sim.step(t_ns, angles[0])
        else:
            if not isinstance(self.sim, TwoAxisGyroSimulator):
                self.sim = TwoAxisGyroSimulator(self.config, self.mount)
            rates = np.asarray(msg.velocity, dtype=np.float64).reshape(angles.shape)
            counts = self.sim.step(t_ns, angles[1], angles[0], np.abs(rates[0]) < 1e-9)
        self._last_ns = int(t_ns[-1])
        self._wait_for_a_reader()
        for t, n in zip(t_ns.tolist(), counts.tolist()):
            out = JointState(name=[topics.GYRO_JOINT], position=[n])
            ns_to_stamp(t, out.header.stamp)
            out.header.frame_id = topics.GYRO_JOINT
            publish_paced(self.pub, out, graph=self)
        self._published += len(t_ns)
        if self._first_ns is not None:
            self._progress.what = f'rlg_sim: {self._published} pulse samples, bench time'
            self._progress.update((int(t_ns[-1]) - self._first_ns) / 1e9)

    def _wait_for_a_reader(self) -> None:
        """Block until /gyro/pulses is matched (discovery may lag the table's start).

        The table waits for our truth subscription, not for our pulse publisher's match;
        on a slow machine the first pulses could otherwise go to no reader. Blocking here
        holds the table back through its reliable writer, so nothing is lost.
        """
        if self._waited_for_reader:
            return
        self._waited_for_reader = True
        deadline = time.monotonic() + self.subscriber_wait_s
        need = max(1, self.min_subscribers)
        what = 'a reader' if need == 1 else f'{need} readers'
        if self.pub.get_subscription_count() < need and self.subscriber_wait_s > 0:
            self.get_logger().info(f'waiting for {what} of {topics.GYRO_PULSES}')
        while self.pub.get_subscription_count() < need and time.monotonic() < deadline:
            time.sleep(0.01)
        if self.pub.get_subscription_count() < need and self.subscriber_wait_s > 0:
            self.get_logger().warning(f'not {what} of {topics.GYRO_PULSES} after '
                                      f'{self.subscriber_wait_s:g} s; publishing anyway.')


def main(args: list[str] | None = None) -> None:
    """Run the gyro simulator until SIGINT/SIGTERM."""
    run_node('rlg_sim', RingLaserGyroNode, args)


if __name__ == '__main__':
    main()
