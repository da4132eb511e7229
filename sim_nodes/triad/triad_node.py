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

import functools
import time
from collections.abc import Iterator
from typing import Any

from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Header, String

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    EVENT_QOS,
    SCENARIO_QOS,
    SENSOR_QOS,
    ProgressLog,
    StartGate,
    acknowledge_tail,
    described_parameter,
    ns_to_stamp,
    publish_paced,
    run_node,
    simulation_done,
    stops_on_stalled_readers,
)
from gyro_calib.topics import relative
from sim_nodes.triad.bench import CHUNK_SAMPLES, TriadChunk
from sim_nodes.triad.scenarios import IMU_PULSES, SCENARIOS, TriadScenario

IMU_FRAME = 'imu'
"""frame_id of /imu/pulses (as in the bags)."""


def scenario_with(name: str, seed: int, sample_rate_hz: float) -> TriadScenario:
    """Scenario ``name`` with its seeds (SEED + k; −1 keeps them) and sample rate (0 keeps)."""
    from sim_nodes.scenarios import with_overrides

    overrides: dict[str, Any] = {}
    if seed >= 0:
        overrides['seed'] = seed
    if sample_rate_hz > 0:
        overrides['sample_rate_hz'] = sample_rate_hz
    scenario = with_overrides(name, overrides) if overrides else SCENARIOS[name]
    assert isinstance(scenario, TriadScenario)
    return scenario


class TriadBenchNode(Node):
    """Streams a triad scenario's bench at a paced rate."""

    def __init__(self) -> None:
        """Declare parameters, build the scenario and start the pacing timer."""
        super().__init__('triad_sim')
        param = functools.partial(described_parameter, self)
        name = str(param('scenario', 'triad_two_axis_bench', f'One of {", ".join(SCENARIOS)}.'))
        seed = int(param('seed', -1, "Seed of the run (−1 = the scenario's; else each of the "
                                     "scenario's seeds becomes seed + k)."))
        rate = float(param('sample_rate_hz', 0.0, "Pulse sample rate, Hz (0 = the scenario's)."))
        self.real_time_factor = float(param('real_time_factor', 1.0, 'Simulated seconds per '
                                            'wall-clock second (0 = as fast as the readers '
                                            'acknowledge).'))
        self.exit_when_done = bool(param('exit_when_done', True, 'Shut the node down once the '
                                         'run has been simulated and acknowledged.'))
        self.wait_for_subscribers = bool(param(
            'wait_for_subscribers', True, 'Start only once every topic has min_subscribers '
            'readers, so nothing is lost at the start.'))
        self.min_subscribers = int(param('min_subscribers', 1, 'Readers each topic needs '
                                         'before the run starts.'))
        if name not in SCENARIOS:
            raise SystemExit(f'triad_sim: scenario {name!r} is not one of '
                             f'{", ".join(SCENARIOS)}')
        self.scenario = scenario_with(name, seed, rate)
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
        import yaml

        self.create_publisher(String, relative(topics.SIM_SCENARIO), SCENARIO_QOS).publish(
            String(data=yaml.safe_dump(self.scenario.description_dict(), sort_keys=True)))
        self._n_published = 0
        self._wall_start: float | None = None
        self._start_gate = StartGate(self.wait_for_subscribers, min_readers=self.min_subscribers,
                                     logger=self.get_logger())
        self._progress: ProgressLog | None = None
        self.done = False
        self.stalled = ''  # why publishing stopped before the end ('' = it did not)
        self.create_timer(0.005, self._tick)

    @property
    def all_publishers(self) -> list[Any]:
        """The stream publishers (for the start and the final acknowledgement waits)."""
        return [p for p in (self.pulse_pub, self.rate_pub, self.rate_index_pub,
                            self.position_pub, self.position_index_pub) if p is not None]

    @stops_on_stalled_readers
    def _tick(self) -> None:
        if self.done:
            return
        if self._wall_start is None:
            if not self._start_gate.open(self.all_publishers):
                return  # readers first (see StartGate)
            self._wall_start = self._start_gate.opened_at
            self.get_logger().info(
                f'{self.scenario.name}: simulating {self.duration_s:g} s at '
                + (f'{self.real_time_factor:g}× real time' if self.real_time_factor > 0
                   else "the readers' pace"))
            self._progress = ProgressLog(self.get_logger(), self.scenario.name, self.duration_s)
        budget = 5 if self.real_time_factor <= 0 else None
        while budget is None or budget > 0:
            if budget is None:
                assert self._wall_start is not None
                due = (time.monotonic() - self._wall_start) * self.real_time_factor
                if self._n_published / self.sample_rate_hz > due:
                    return
            else:
                budget -= 1
            chunk = next(self._chunks, None)
            if chunk is None:
                self.done = True
                self.get_logger().info(f'run finished: {self._n_published} pulse samples')
                return
            self._publish(chunk)
            if self._progress is not None:
                self._progress.update(self._n_published / self.sample_rate_hz)

    def _publish(self, chunk: TriadChunk) -> None:
        for t_ns, counts in zip(chunk.pulse_t_ns.tolist(), chunk.pulse_counts.tolist()):
            msg = JointState(name=self.channels, position=counts)
            ns_to_stamp(t_ns, msg.header.stamp)
            msg.header.frame_id = IMU_FRAME
            publish_paced(self.pulse_pub, msg)
        self._publish_table(self.rate_pub, self.rate_index_pub, topics.RATE_TABLE_JOINT,
                            chunk.rate_table, chunk.rate_zero_index_ns.tolist())
        if self.position_pub is not None and self.position_index_pub is not None \
                and chunk.position_table is not None and chunk.position_zero_index_ns is not None:
            self._publish_table(self.position_pub, self.position_index_pub,
                                topics.POSITION_TABLE_JOINT, chunk.position_table,
                                chunk.position_zero_index_ns.tolist())
        self._n_published += len(chunk.pulse_t_ns)

    @staticmethod
    def _publish_table(js_pub: Any, index_pub: Any, joint: str, states: Any,
                       index_ns: list[int]) -> None:
        for t_ns, angle, rate in zip(*(a.tolist() for a in states)):
            js = JointState(name=[joint], position=[angle], velocity=[rate])
            ns_to_stamp(t_ns, js.header.stamp)
            js.header.frame_id = joint
            publish_paced(js_pub, js)
        for t_ns in index_ns:
            header = Header(frame_id=joint)
            ns_to_stamp(t_ns, header.stamp)
            publish_paced(index_pub, header)


def main(args: list[str] | None = None) -> None:
    """Run the triad bench until its run is done (or it is shut down)."""
    run_node('triad_sim', TriadBenchNode, args, done=simulation_done,
             on_stop=acknowledge_tail)


if __name__ == '__main__':
    main()
