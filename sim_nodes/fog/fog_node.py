"""fog_sim: a simulated FOG bench in one process — rate table and closed-loop FOG (METHODS §B).

Runs a :class:`~sim_nodes.fog.bag_scenarios.FogScenario` — ``turntable`` (IEEE Std 952
multi-rate) or ``mapping_self_cal`` (the equivalence mapping rates, then the injected ladder
on the stopped table) — streaming the shared :class:`~sim_nodes.rate_table.RateTableSimulator`
and the :class:`~sim_nodes.fog.gyro.FogSimulator` chunk by chunk (the same
:class:`~sim_nodes.fog.scenarios.FogBench` the offline scenarios and the committed bags use,
so the samples are bit-identical to theirs), and publishes

- ``/fog/output`` (cumulative count), ``/fog/injection`` (injected rate as counts/s, at the
  plateau's first stamp), ``/rate_table/joint_states``, ``/rate_table/zero_index``;
- ``/sim/scenario``: YAML of the parameters, seeds and truth (transient-local).

Parameters: ``scenario`` (turntable | mapping_self_cal), ``model`` (equivalent | loop),
every field of :class:`~sim_nodes.fog.config.FogConfig` (the gyro), ``table.*`` of
:class:`~sim_nodes.fog.scenarios.TableSettings`, ``turntable.rates_deg_s`` /
``turntable.hold_s``, ``mapping.rates_deg_s`` ([] = no mapping phase) / ``mapping.hold_s``,
``ladder.*`` of :class:`~sim_nodes.fog.scenarios.SelfCalLadder`, ``real_time_factor``
(simulated seconds per wall second; 0 = as fast as the readers acknowledge),
``exit_when_done``, ``wait_for_subscribers`` and ``min_subscribers``.

    fog_sim --ros-args -p scenario:=mapping_self_cal -p real_time_factor:=10.0
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from typing import Any

from rclpy.publisher import Publisher
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from gyro_calib.fog import topics
from gyro_calib.nodes.ros_io import (
    EVENT_QOS,
    SENSOR_QOS,
    declare_dataclass_parameters,
    described_parameter,
    ns_to_stamp,
    number_list_parameter,
    publish_paced,
)
from gyro_calib.topics import RATE_TABLE_JOINT, relative
from sim_nodes.fog.bag_scenarios import KINDS, FogScenario, scenario_from_parameters
from sim_nodes.fog.config import FogConfig
from sim_nodes.fog.scenarios import (
    IEEE_RATES_DEG_S,
    MAPPING_RATES_DEG_S,
    BenchChunk,
    SelfCalLadder,
    TableSettings,
)
from sim_nodes.simulator_node import PacedSimulatorNode, run_simulator

CHUNK_S = 0.1
"""Simulated time per published chunk, s (does not change a sample)."""


class FogBenchNode(PacedSimulatorNode):
    """Streams a FOG scenario's bench at a paced rate."""

    samples_what = 'output samples'

    def __init__(self) -> None:
        """Declare parameters, build the scenario and start the pacing timer."""
        super().__init__('fog_sim')
        param = functools.partial(described_parameter, self)
        kind = param('scenario', 'turntable', f'One of {", ".join(KINDS)}.')
        model = param('model', 'equivalent', "FOG loop model: 'equivalent' (long runs) or "
                      "'loop' (every transit time τ).")
        # tuple fields as number lists: [] and integer lists taken
        fields = functools.partial(declare_dataclass_parameters, self, number_lists=True)
        gyro = FogConfig(**fields(FogConfig))
        table = TableSettings(**fields(TableSettings, 'table.'))
        ladder = SelfCalLadder(**fields(SelfCalLadder, 'ladder.'))
        lists = {name: number_list_parameter(self, name, default, text)
                 for name, default, text in (
                     ('turntable.rates_deg_s', IEEE_RATES_DEG_S, 'Turntable rates in order, '
                      '°/s.'),
                     ('mapping.rates_deg_s', MAPPING_RATES_DEG_S, 'Equivalence-mapping rates, '
                      '°/s ([] = no mapping phase).'))}
        hold = param('turntable.hold_s', 60.0, 'Time at each turntable rate, s.')
        mapping_hold = param('mapping.hold_s', 60.0, 'Time at each mapping rate, s.')
        self.declare_run_parameters()
        if kind not in KINDS:
            raise SystemExit(f'fog_sim: scenario {kind!r} is not one of {KINDS}')
        self.scenario: FogScenario = scenario_from_parameters(
            kind, gyro, table, rates_deg_s=[float(r) for r in lists['turntable.rates_deg_s']],
            hold_s=float(hold), mapping_rates_deg_s=[float(r) for r in
                                                     lists['mapping.rates_deg_s']],
            mapping_hold_s=float(mapping_hold), ladder=ladder, model=str(model))
        self.bench = self.scenario.bench()
        chunk = max(1, round(CHUNK_S * table.output_rate_hz))
        self._chunks: Iterator[BenchChunk] = self.bench.chunks(chunk)
        self._injection = list(zip(*(a.tolist() for a in self.bench.injection_messages)))
        self._next_injection = 0
        pub = self.create_publisher
        self.output_pub = pub(JointState, relative(topics.FOG_OUTPUT), SENSOR_QOS)
        self.injection_pub = pub(JointState, relative(topics.FOG_INJECTION), SENSOR_QOS)
        self.table_pub = pub(JointState, relative(topics.RATE_TABLE_JOINT_STATES), SENSOR_QOS)
        self.index_pub = pub(Header, relative(topics.RATE_TABLE_ZERO_INDEX), EVENT_QOS)
        self.publish_scenario(self.scenario.description_dict())
        self.sample_rate_hz = table.output_rate_hz

    @property
    def all_publishers(self) -> list[Publisher[Any]]:
        """The stream publishers (for the start and the final acknowledgement waits)."""
        return [self.output_pub, self.injection_pub, self.table_pub, self.index_pub]

    @property
    def total_s(self) -> float:
        """The scenario's simulated seconds."""
        return self.bench.n_samples / self.sample_rate_hz

    @property
    def progress_what(self) -> str:
        """The scenario kind."""
        return str(self.scenario.kind)

    def run_ended(self) -> None:
        """The injections that remain after the last chunk."""
        self._publish_injections(None)

    def _publish_injections(self, until_ns: int | None) -> None:
        """Injection messages stamped up to ``until_ns`` (None: all that remain)."""
        while self._next_injection < len(self._injection):
            t_ns, value = self._injection[self._next_injection]
            if until_ns is not None and t_ns > until_ns:
                return
            msg = JointState(name=[topics.FOG_INJECTION_JOINT], position=[float(value)])
            ns_to_stamp(int(t_ns), msg.header.stamp)
            msg.header.frame_id = topics.FOG_INJECTION_JOINT
            publish_paced(self.injection_pub, msg, graph=self)
            self._next_injection += 1

    def _publish(self, chunk: BenchChunk) -> None:
        self._publish_injections(int(chunk.output_t_ns[-1]))
        for t_ns, count in zip(chunk.output_t_ns.tolist(), chunk.output_counts.tolist()):
            msg = JointState(name=[topics.FOG_JOINT], position=[count])
            ns_to_stamp(t_ns, msg.header.stamp)
            msg.header.frame_id = topics.FOG_JOINT
            publish_paced(self.output_pub, msg, graph=self)
        for t_ns, angle, rate in zip(chunk.table_t_ns.tolist(), chunk.table_angle_rad.tolist(),
                                     chunk.table_rate_rad_s.tolist()):
            js = JointState(name=[RATE_TABLE_JOINT], position=[angle], velocity=[rate])
            ns_to_stamp(t_ns, js.header.stamp)
            js.header.frame_id = RATE_TABLE_JOINT
            publish_paced(self.table_pub, js, graph=self)
        for t_ns in chunk.zero_index_ns.tolist():
            header = Header(frame_id=RATE_TABLE_JOINT)
            ns_to_stamp(t_ns, header.stamp)
            publish_paced(self.index_pub, header, graph=self)
        self._n_published += len(chunk.output_t_ns)


def main(args: list[str] | None = None) -> None:
    """Run the FOG bench until its run is done (or it is shut down)."""
    run_simulator('fog_sim', FogBenchNode, args)


if __name__ == '__main__':
    main()
