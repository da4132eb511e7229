"""imu_multiposition_sim: a MEMS IMU turned by hand between static poses (issue 38).

Runs one of the committed multiposition scenarios
(:data:`~sim_nodes.multiposition.scenarios.SCENARIOS`, ``multiposition_hand_turned``),
publishing the same samples and stamps its bag holds (``gyro-calib simulate`` with the same
seed and rate gives them bit for bit):

- ``/imu/data`` (sensor_msgs/Imu: angular_velocity rad/s and linear_acceleration m/s² as the
  IMU reads them, raw = (T·diag(s))⁻¹·true + b + noise; orientation unknown,
  orientation_covariance[0] = −1);
- ``/sim/scenario``: YAML of the IMU's errors, the procedure, the seed, the bench settings
  (latitude) and the truth (transient-local).

Parameters: ``scenario``, ``seed`` (−1 = the scenario's), ``sample_rate_hz`` (0 = the
scenario's), ``real_time_factor`` (simulated seconds per wall second; 0 = as fast as the
readers acknowledge), ``exit_when_done``, ``wait_for_subscribers`` and ``min_subscribers``.

    imu_multiposition_sim --ros-args -p real_time_factor:=0.0
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
from rclpy.publisher import Publisher
from sensor_msgs.msg import Imu

from gyro_calib.nodes.ros_io import SENSOR_QOS, ns_to_stamp, publish_paced
from gyro_calib.topics import relative
from sim_nodes.multiposition.scenarios import (
    IMU_FRAME,
    IMU_TOPIC,
    SCENARIOS,
    MultipositionScenario,
)
from sim_nodes.simulator_node import PacedSimulatorNode, run_simulator

CHUNK_SAMPLES = 50
"""Samples per published chunk."""


def scenario_with(name: str, seed: int, sample_rate_hz: float) -> MultipositionScenario:
    """Scenario ``name`` with its seed (−1 keeps it) and sample rate (0 keeps it)."""
    from sim_nodes.scenarios import with_node_parameters

    scenario = with_node_parameters(name, seed, sample_rate_hz)
    assert isinstance(scenario, MultipositionScenario)
    return scenario


class ImuMultipositionNode(PacedSimulatorNode):
    """Streams a hand-turned IMU run at a paced rate."""

    samples_what = 'Imu samples'

    def __init__(self) -> None:
        """Declare parameters, simulate the run and start the pacing timer."""
        super().__init__('imu_multiposition_sim')
        self.scenario: MultipositionScenario = self.declare_scenario(
            SCENARIOS, 'multiposition_hand_turned', seed="Seed of the run (−1 = the scenario's).",
            rate="IMU output rate, Hz (0 = the scenario's).")
        run = self.scenario.run()
        self.sample_rate_hz = self.scenario.procedure.sample_rate_hz
        self.duration_s = float(run.t_s[-1] + 1 / self.sample_rate_hz)
        stamps = self.scenario.stamps_ns(run)
        self._chunks: Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]] = (
            (stamps[i:i + CHUNK_SAMPLES], run.acc[i:i + CHUNK_SAMPLES],
             run.gyro[i:i + CHUNK_SAMPLES]) for i in range(0, len(stamps), CHUNK_SAMPLES))
        self.imu_pub = self.create_publisher(Imu, relative(IMU_TOPIC), SENSOR_QOS)
        self.publish_scenario(self.scenario.description_dict())

    @property
    def all_publishers(self) -> list[Publisher[Any]]:
        """The Imu publisher."""
        return [self.imu_pub]

    @property
    def total_s(self) -> float:
        """The run's simulated seconds."""
        return self.duration_s

    def _publish(self, chunk: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        stamps, acc, gyro = chunk
        for t_ns, a, w in zip(stamps.tolist(), acc.tolist(), gyro.tolist(), strict=True):
            msg = Imu()
            ns_to_stamp(t_ns, msg.header.stamp)
            msg.header.frame_id = IMU_FRAME
            msg.orientation_covariance[0] = -1.0  # no orientation estimate (REP 145)
            msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = w
            (msg.linear_acceleration.x, msg.linear_acceleration.y,
             msg.linear_acceleration.z) = a
            publish_paced(self.imu_pub, msg, graph=self)
        self._n_published += len(stamps)


def main(args: list[str] | None = None) -> None:
    """Run the hand-turned IMU until its run is done (or it is shut down)."""
    run_simulator('imu_multiposition_sim', ImuMultipositionNode, args)


if __name__ == '__main__':
    main()
