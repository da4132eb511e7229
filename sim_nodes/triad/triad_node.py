"""triad_sim: a simulated gyro-triad bench in one process — tables and three gyros (METHODS §F).

Runs one of the committed triad scenarios (:data:`~sim_nodes.triad.scenarios.SCENARIOS`:
``triad_two_axis_bench`` or ``triad_remount_bench_<axis>``), streaming the same
:class:`~sim_nodes.triad.bench.TriadBench` chunks the offline bags are written from (so the
samples are bit-identical to ``gyro-calib simulate`` with the same seed and rate), and
publishes

- ``/imu/pulses`` (JointState, ``name`` the three channels, ``position`` cumulative counts),
  ``/rate_table/joint_states``, ``/rate_table/zero_index`` and, on the two-axis bench,
  ``/position_table/joint_states``, ``/position_table/zero_index``;
- ``/sim/scenario``: YAML of the parameters, seeds, bench settings and truth
  (transient-local).

Parameters: ``scenario``, ``seed`` (−1 = the scenario's; else each of its seeds is SEED + k),
``sample_rate_hz`` (0 = the scenario's), ``real_time_factor`` (simulated seconds per wall
second; 0 = as fast as the readers acknowledge), ``exit_when_done``,
``wait_for_subscribers`` and ``min_subscribers``.

    triad_sim --ros-args -p scenario:=triad_remount_bench_py -p real_time_factor:=0.0
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from rclpy.publisher import Publisher
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    EVENT_QOS,
    SENSOR_QOS,
    ns_to_stamp,
    publish_paced,
)
from gyro_calib.topics import relative
from sim_nodes.simulator_node import PacedSimulatorNode, run_simulator
from sim_nodes.triad.bench import CHUNK_SAMPLES, TriadChunk
from sim_nodes.triad.scenarios import IMU_PULSES, SCENARIOS, TriadScenario

IMU_FRAME = 'imu'
"""frame_id of /imu/pulses (as in the bags)."""


def scenario_with(name: str, seed: int, sample_rate_hz: float) -> TriadScenario:
    """Scenario ``name`` with its seeds (SEED + k; −1 keeps them) and sample rate (0 keeps)."""
    from sim_nodes.scenarios import with_node_parameters

    scenario = with_node_parameters(name, seed, sample_rate_hz)
    assert isinstance(scenario, TriadScenario)
    return scenario


class TriadBenchNode(PacedSimulatorNode):
    """Streams a triad scenario's bench at a paced rate."""

    samples_what = 'pulse samples'

    def __init__(self) -> None:
        """Declare parameters, build the scenario and start the pacing timer."""
        super().__init__('triad_sim')
        self.scenario: TriadScenario = self.declare_scenario(
            SCENARIOS, 'triad_two_axis_bench',
            seed="Seed of the run (−1 = the scenario's; else each of the scenario's seeds "
                 'becomes seed + k).',
            rate="Pulse sample rate, Hz (0 = the scenario's).")
        bench = self.scenario.bench()
        self.duration_s = bench.profiles()[0].duration_s
        self.sample_rate_hz = self.scenario.table.sample_rate_hz
        self._chunks: Iterator[TriadChunk] = bench.chunks(CHUNK_SAMPLES)
        self.channels = list(self.scenario.gyros.channels)
        pub = self.create_publisher
        self.pulse_pub = pub(JointState, relative(IMU_PULSES), SENSOR_QOS)
        self.rate_pub = pub(JointState, relative(topics.RATE_TABLE_JOINT_STATES), SENSOR_QOS)
        self.rate_index_pub = pub(Header, relative(topics.RATE_TABLE_ZERO_INDEX), EVENT_QOS)
        self.two_axis = self.scenario.kind == 'two_axis'
        self.position_pub = self.position_index_pub = None
        if self.two_axis:
            self.position_pub = pub(JointState, relative(topics.POSITION_TABLE_JOINT_STATES),
                                    SENSOR_QOS)
            self.position_index_pub = pub(Header, relative(topics.POSITION_TABLE_ZERO_INDEX),
                                          EVENT_QOS)
        self.publish_scenario(self.scenario.description_dict())

    @property
    def all_publishers(self) -> list[Publisher[Any]]:
        """The stream publishers (for the start and the final acknowledgement waits)."""
        return [p for p in (self.pulse_pub, self.rate_pub, self.rate_index_pub,
                            self.position_pub, self.position_index_pub) if p is not None]

    @property
    def total_s(self) -> float:
        """The scenario's simulated seconds."""
        return float(self.duration_s)

    def _publish(self, chunk: TriadChunk) -> None:
        for t_ns, counts in zip(chunk.pulse_t_ns.tolist(), chunk.pulse_counts.tolist()):
            msg = JointState(name=self.channels, position=counts)
            ns_to_stamp(t_ns, msg.header.stamp)
            msg.header.frame_id = IMU_FRAME
            publish_paced(self.pulse_pub, msg, graph=self)
        self._publish_table(self.rate_pub, self.rate_index_pub, topics.RATE_TABLE_JOINT,
                            chunk.rate_table, chunk.rate_zero_index_ns.tolist())
        if self.position_pub is not None and self.position_index_pub is not None \
                and chunk.position_table is not None and chunk.position_zero_index_ns is not None:
            self._publish_table(self.position_pub, self.position_index_pub,
                                topics.POSITION_TABLE_JOINT, chunk.position_table,
                                chunk.position_zero_index_ns.tolist())
        self._n_published += len(chunk.pulse_t_ns)

    def _publish_table(self, js_pub: Any, index_pub: Any, joint: str, states: Any,
                       index_ns: list[int]) -> None:
        for t_ns, angle, rate in zip(*(a.tolist() for a in states)):
            js = JointState(name=[joint], position=[angle], velocity=[rate])
            ns_to_stamp(t_ns, js.header.stamp)
            js.header.frame_id = joint
            publish_paced(js_pub, js, graph=self)
        for t_ns in index_ns:
            header = Header(frame_id=joint)
            ns_to_stamp(t_ns, header.stamp)
            publish_paced(index_pub, header, graph=self)


def main(args: list[str] | None = None) -> None:
    """Run the triad bench until its run is done (or it is shut down)."""
    run_simulator('triad_sim', TriadBenchNode, args)


if __name__ == '__main__':
    main()
