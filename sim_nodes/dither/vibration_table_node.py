"""vibration_table_sim: the angular vibration table with the dithered RLG on it (METHODS §C).

One orientation per run: the table axis along case Z or case Y (``orientation``), published
as the header.frame_id of /vibration_table/joint_states (name ``["vibration_table"]``,
position = encoder angle in rad, velocity in rad/s, every ``table_decimation``-th pulse
stamp); the gyro's cumulative pulse count on /gyro/pulses (name ``["gyro"]``); parameters,
seed and truth on /sim/scenario. The samples come from the same chunked exact-kinematics
simulator as the offline runs (:class:`~sim_nodes.dither.bench.DitherBenchSimulator`), so a
live run and :func:`~sim_nodes.dither.scenarios.simulate_dither_run` give bit-identical
samples. For the second orientation, start a second run with ``orientation:=y``, another
``seed`` and a ``start_time_ns`` after the first run's end.

Parameters: ``orientation`` ("z" or "y"); every field of
:class:`~sim_nodes.dither.vibration_table.VibrationTableConfig` but ``axis`` as ``table.*``;
every field of :class:`~sim_nodes.dither.gyro.DitheredGyroConfig` and of
:class:`~sim_nodes.dither.bench.DitherBenchConfig`; ``real_time_factor`` (simulated seconds per
wall second; 0 = as fast as the readers acknowledge), ``exit_when_done``,
``wait_for_subscribers`` and ``min_subscribers``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.publisher import Publisher
from sensor_msgs.msg import JointState

from gyro_calib.dither import topics
from gyro_calib.nodes.ros_io import (
    SENSOR_QOS,
    declare_dataclass_parameters,
    ns_to_stamp,
    publish_paced,
)
from gyro_calib.topics import relative
from sim_nodes.dither.bench import DitherBenchConfig, DitherBenchSimulator, DitherChunk
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.scenarios import dither_truth
from sim_nodes.dither.vibration_table import VibrationTableConfig
from sim_nodes.simulator_node import BOTH_READERS, PacedSimulatorNode, run_simulator

CHUNK_S = 0.05
"""Simulated time per chunk (the pacing granularity), s; chunking never changes a sample."""


def scenario_yaml(gyro: DitheredGyroConfig, table: VibrationTableConfig,
                  bench: DitherBenchConfig) -> str:
    """This run's part of /sim/scenario: orientation, configs, seed and truth."""
    import yaml

    return yaml.safe_dump({
        'method': 'dither', 'orientation': table.axis, 'gyro': dataclasses.asdict(gyro),
        'table': dataclasses.asdict(table), 'bench_config': dataclasses.asdict(bench),
        'truth': dither_truth(gyro, table)}, sort_keys=True)


class VibrationTableNode(PacedSimulatorNode):
    """Streams the bench simulator's chunks at a paced rate."""

    unpaced_chunks = 20
    progress_what = 'vibration table'

    def __init__(self) -> None:
        """Declare parameters, build the bench and start the pacing timer."""
        super().__init__('vibration_table_sim')
        orientation: Any = self.declare_parameter('orientation', 'z', ParameterDescriptor(
            description='Case axis the table axis is along: "z" or "y" (the joint_states '
            'frame_id). rcl reads an unquoted y as the YAML boolean true; it is taken as "y".',
            dynamic_typing=True)).value
        orientation = 'y' if orientation is True else str(orientation).strip().lower()
        try:
            table = declare_dataclass_parameters(self, VibrationTableConfig, 'table.',
                                                 skip=('axis',))
            self.table_config = VibrationTableConfig(axis=orientation, **table)
            self.gyro_config = DitheredGyroConfig(
                **declare_dataclass_parameters(self, DitheredGyroConfig))
            self.bench = DitherBenchConfig(**declare_dataclass_parameters(self, DitherBenchConfig))
        except ValueError as exc:
            raise SystemExit(f'vibration_table_sim: {exc}') from None
        self.declare_run_parameters(
            exit_when_done='Shut the node down once the run has been simulated.',
            wait='Start only once /gyro/pulses and /vibration_table/joint_states have a '
            'reader, so nothing is lost at the start.',
            readers='Readers each topic needs before the run starts' + BOTH_READERS)
        self.sim = DitherBenchSimulator(self.gyro_config, self.table_config, self.bench)
        self.chunk_samples = max(1, int(round(CHUNK_S * self.bench.sample_rate_hz)))
        self.pulse_pub = self.create_publisher(JointState, relative(topics.GYRO_PULSES),
                                               SENSOR_QOS)
        self.table_pub = self.create_publisher(
            JointState, relative(topics.VIBRATION_TABLE_JOINT_STATES), SENSOR_QOS)
        self.publish_scenario(scenario_yaml(self.gyro_config, self.table_config, self.bench))
        self.sample_rate_hz = self.bench.sample_rate_hz

    @property
    def all_publishers(self) -> list[Publisher[Any]]:
        """The sensor publishers (for the final acknowledgement wait)."""
        return [self.pulse_pub, self.table_pub]

    @property
    def total_s(self) -> float:
        """The run's simulated seconds."""
        return float(self.bench.duration_s)

    def start_line(self) -> str:
        """'simulating T s with the table along Z at F× real time'."""
        return (f'simulating {self.bench.duration_s:g} s with the table along '
                f'{self.table_config.axis.upper()} at {self.real_time_factor:g}× real time')

    def run_finished(self) -> bool:
        """Whether the bench's run is over."""
        return bool(self.sim.finished)

    def publish_next(self) -> None:
        """The next chunk of the bench."""
        self._publish(self.sim.step(self.chunk_samples))

    def _publish(self, chunk: DitherChunk) -> None:
        frame = self.table_config.axis
        table_t = chunk.table_t_ns.tolist()
        angle, rate = chunk.table_angle_rad.tolist(), chunk.table_rate_rad_s.tolist()
        j = 0
        for t_ns, count in zip(chunk.pulse_t_ns.tolist(), chunk.counts.tolist()):
            while j < len(table_t) and table_t[j] <= t_ns:
                msg = JointState(name=[topics.VIBRATION_TABLE_JOINT], position=[angle[j]],
                                 velocity=[rate[j]])
                ns_to_stamp(table_t[j], msg.header.stamp)
                msg.header.frame_id = frame
                publish_paced(self.table_pub, msg, graph=self)
                j += 1
            out = JointState(name=[topics.GYRO_JOINT], position=[count])
            ns_to_stamp(t_ns, out.header.stamp)
            out.header.frame_id = topics.GYRO_JOINT
            publish_paced(self.pulse_pub, out, graph=self)
        self._n_published += len(chunk.pulse_t_ns)


def main(args: list[str] | None = None) -> None:
    """Run the vibration table simulator until its run is done (or it is shut down)."""
    run_simulator('vibration_table_sim', VibrationTableNode, args)


if __name__ == '__main__':
    main()
