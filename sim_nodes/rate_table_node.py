"""rate_table_sim: the simulated bench's time master (rate table, and position table).

``scenario`` = ``rate_bias`` (default): the rate-bias turntable alone, publishing
/rate_table/joint_states, /rate_table/zero_index and, for the gyro simulator only,
/sim/rate_table/true_motion. ``theta`` or ``full``: the two-axis bench of the fix-error
procedure (the RBRLG tilted on a position table); ``full`` runs the K̃ phase first. It
also publishes /position_table/joint_states and /position_table/zero_index, and the
true motion of both tables on /sim/bench/true_motion.

Parameters: every field of :class:`~sim_nodes.rate_table.RateTableConfig`, the
``procedure.*`` fields of :class:`~sim_nodes.two_axis_procedure.ThetaProcedureConfig`,
``k_tilde_pairs``, ``real_time_factor`` (simulated seconds per wall second; 0 = as
fast as the readers acknowledge), ``exit_when_done``, ``wait_for_subscribers`` and
``min_subscribers``.
"""

from __future__ import annotations

import functools
from typing import Any

from rclpy.publisher import Publisher
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    EVENT_QOS,
    SENSOR_QOS,
    declare_dataclass_parameters,
    described_parameter,
    ns_to_stamp,
    publish_paced,
)
from gyro_calib.topics import relative
from sim_nodes.rate_table import RateTableConfig, RateTableSimulator, TableChunk
from sim_nodes.rbrlg.bench import CHUNK_SAMPLES
from sim_nodes.simulator_node import BOTH_READERS, PacedSimulatorNode, run_simulator
from sim_nodes.two_axis_procedure import (
    ThetaProcedureConfig,
    full_procedure_profiles,
    theta_procedure_profiles,
    two_axis_simulators,
)

SCENARIOS = ('rate_bias', 'theta', 'full')


def scenario_yaml(kind: str, table: RateTableConfig, procedure: ThetaProcedureConfig,
                  k_tilde_pairs: int) -> str:
    """The table's part of /sim/scenario: scenario kind and the tables' parameters."""
    import dataclasses

    import yaml

    return yaml.safe_dump({
        'kind': kind, 'k_tilde_pairs': k_tilde_pairs, 'table': dataclasses.asdict(table),
        'procedure': {k: list(v) if isinstance(v, tuple) else v
                      for k, v in dataclasses.asdict(procedure).items()}}, sort_keys=True)


class RateTableNode(PacedSimulatorNode):
    """Streams the table simulators' chunks at a paced rate."""

    unpaced_chunks = 20
    progress_what = 'rate table'

    def __init__(self) -> None:
        """Declare parameters, build the scenario and start the pacing timer."""
        super().__init__('rate_table_sim')
        self.config = RateTableConfig(**declare_dataclass_parameters(self, RateTableConfig))
        procedure = ThetaProcedureConfig(**declare_dataclass_parameters(
            self, ThetaProcedureConfig, prefix='procedure.'))
        param = functools.partial(described_parameter, self)

        scenario = param('scenario', 'rate_bias', f'One of {", ".join(SCENARIOS)}.')
        k_pairs = param('k_tilde_pairs', 4, 'Forward/reverse rate-table pairs of the K̃ phase '
                        '(scenario full).')
        self.declare_run_parameters(
            paced='Simulated seconds per wall-clock second (0 = unpaced).',
            exit_when_done='Shut the node down once the run has been simulated.',
            wait='Start only once the gyro and a reader of every table topic are connected, '
            'so nothing is lost at the start.',
            readers='Readers each table topic needs before the run starts' + BOTH_READERS)
        if scenario not in SCENARIOS:
            raise SystemExit(f'rate_table_sim: scenario {scenario!r} is not one of {SCENARIOS}')
        self.tables: list[tuple[RateTableSimulator, Publisher[JointState],
                                Publisher[Header], str]] = []
        if scenario == 'rate_bias':
            sims = [RateTableSimulator(self.config)]
            truth_topic = topics.RATE_TABLE_TRUE_MOTION
        else:
            if scenario == 'full':
                profiles = full_procedure_profiles(
                    procedure, k_tilde_pairs=int(k_pairs), rate_deg_s=self.config.rate_deg_s,
                    acceleration_deg_s2=self.config.acceleration_deg_s2,
                    revolutions_per_segment=self.config.revolutions_per_segment)
            else:
                profiles = theta_procedure_profiles(procedure)
            sims = list(two_axis_simulators(profiles[0], profiles[1], self.config,
                                            procedure.position_table_index_jitter_arcsec))
            truth_topic = topics.BENCH_TRUE_MOTION
        names = [(topics.RATE_TABLE_JOINT, topics.RATE_TABLE_JOINT_STATES,
                  topics.RATE_TABLE_ZERO_INDEX),
                 (topics.POSITION_TABLE_JOINT, topics.POSITION_TABLE_JOINT_STATES,
                  topics.POSITION_TABLE_ZERO_INDEX)]
        for sim, (joint, js_topic, index_topic) in zip(sims, names):
            self.tables.append((
                sim, self.create_publisher(JointState, relative(js_topic), SENSOR_QOS),
                self.create_publisher(Header, relative(index_topic), EVENT_QOS), joint))
        self.truth_pub = self.create_publisher(JointState, relative(truth_topic), SENSOR_QOS)
        self.publish_scenario(scenario_yaml(scenario, self.config, procedure, int(k_pairs)))
        self.sample_rate_hz = self.config.sample_rate_hz

    @property
    def all_publishers(self) -> list[Publisher[Any]]:
        """Every publisher of the node (for the final acknowledgement wait)."""
        return [self.truth_pub, *self.sensor_publishers]

    @property
    def sensor_publishers(self) -> list[Publisher[Any]]:
        """The table topics a recorder and a calibrator read (each needs min_subscribers)."""
        return [p for _, js, ix, _ in self.tables for p in (js, ix)]

    def gate_publishers(self) -> list[Publisher[Any]]:
        """The table topics (each needs min_subscribers readers)."""
        return self.sensor_publishers

    def internal_publishers(self) -> list[Publisher[Any]]:
        """The true motion, read by the gyro simulator alone."""
        return [self.truth_pub]

    @property
    def total_s(self) -> float:
        """The run's simulated seconds."""
        return self.tables[0][0].n_samples_total / self.config.sample_rate_hz

    def start_line(self) -> str:
        """'simulating T s at F× real time'."""
        return f'simulating {self.total_s:g} s at {self.real_time_factor:g}× real time'

    def run_finished(self) -> bool:
        """Whether the master table's run is over."""
        return self.tables[0][0].finished

    def publish_next(self) -> None:
        """One chunk of every table."""
        self._publish([sim.step(CHUNK_SAMPLES) for sim, *_ in self.tables])

    def _publish(self, chunks: list[TableChunk]) -> None:
        first = chunks[0]
        truth = JointState(name=[joint for *_, joint in self.tables])
        ns_to_stamp(int(first.t_ns[0]), truth.header.stamp)
        truth.position = [a for c in chunks for a in c.true_angle_rad.tolist()]
        truth.velocity = [r for c in chunks for r in c.true_rate_rad_s.tolist()]
        truth.effort = (first.t_ns - first.t_ns[0]).astype(float).tolist()
        publish_paced(self.truth_pub, truth, graph=self)
        dec = self.config.joint_state_decimation
        start = (-self._n_published) % dec
        for chunk, (_, js_pub, index_pub, joint) in zip(chunks, self.tables):
            for i in range(start, len(chunk.t_ns), dec):
                msg = JointState(name=[joint], position=[float(chunk.encoder_angle_rad[i])],
                                 velocity=[float(chunk.encoder_rate_rad_s[i])])
                ns_to_stamp(int(chunk.t_ns[i]), msg.header.stamp)
                msg.header.frame_id = joint
                publish_paced(js_pub, msg, graph=self)
            for t_ns in chunk.zero_index_ns.tolist():
                header = Header(frame_id=joint)
                ns_to_stamp(t_ns, header.stamp)
                publish_paced(index_pub, header, graph=self)
        self._n_published += len(first.t_ns)


def main(args: list[str] | None = None) -> None:
    """Run the table simulator until its run is done (or it is shut down)."""
    run_simulator('rate_table_sim', RateTableNode, args)


if __name__ == '__main__':
    main()
