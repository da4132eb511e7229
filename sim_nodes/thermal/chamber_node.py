"""thermal_chamber_sim: a prism laser gyro in a temperature chamber, live (METHODS §D).

Publishes /gyro/pulses (sensor_msgs/JointState, name ['gyro'], position[0] = cumulative
count), /gyro/temperature (sensor_msgs/Temperature, one message per sensor and instant,
header.frame_id = cavity_a, cavity_b, shell; variance = the sensor's noise and rounding) and
its scenario on /sim/scenario (YAML: configs, seed, bench settings, truth). The samples are
those of :meth:`~sim_nodes.thermal.scenarios.ChamberRunConfig.recording` (the same chunked
simulator, bit for bit), in stamp order, pulses before temperatures at equal stamps.

Parameters: every field of :class:`~sim_nodes.thermal.scenarios.ChamberRunConfig`
(programme, gyro_id, seed, soak and ramp settings, rates, faults), ``real_time_factor``
(simulated seconds per wall second; 0 = as fast as the readers acknowledge — hours of
chamber time then take seconds), ``chunk_s`` (simulated seconds per published chunk),
``exit_when_done``, ``wait_for_subscribers`` and
``min_subscribers``.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from rclpy.publisher import Publisher
from sensor_msgs.msg import JointState, Temperature

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    SENSOR_QOS,
    declare_dataclass_parameters,
    described_parameter,
    ns_to_stamp,
    publish_paced,
)
from gyro_calib.topics import relative
from sim_nodes.simulator_node import BOTH_READERS, PacedSimulatorNode, run_simulator
from sim_nodes.thermal.gyro import ThermalChunk
from sim_nodes.thermal.scenarios import ChamberRunConfig


class ThermalChamberNode(PacedSimulatorNode):
    """Streams a chamber run's chunks at a paced rate."""

    unpaced_chunks = 1
    progress_what = 'chamber'

    def __init__(self) -> None:
        """Declare parameters, set up the run and start the pacing timer."""
        super().__init__('thermal_chamber_sim')
        param = functools.partial(described_parameter, self)
        self.config = ChamberRunConfig(**declare_dataclass_parameters(self, ChamberRunConfig))
        self.chunk_s = float(param('chunk_s', 10.0, 'Simulated seconds per published chunk.'))
        self.declare_run_parameters(
            exit_when_done='Shut the node down once the run has been published.',
            wait='Start only once /gyro/pulses and /gyro/temperature each have a reader, so '
            'nothing is lost at the start.',
            readers='Readers each topic needs before the run starts' + BOTH_READERS)
        if not self.chunk_s > 0:
            raise ValueError(f'chunk_s = {self.chunk_s!r} must be positive')
        self.run = self.config.run()
        self.pulse_pub = self.create_publisher(JointState, relative(topics.GYRO_PULSES),
                                               SENSOR_QOS)
        self.temp_pub = self.create_publisher(Temperature, relative(topics.GYRO_TEMPERATURE),
                                              SENSOR_QOS)
        self.publish_scenario(self.run.scenario)
        self._step_ns = int(round(self.chunk_s * 1e9))
        self._until_ns = self.run.simulator.start_time_ns - 1
        self.published = 0

    @property
    def all_publishers(self) -> list[Publisher[Any]]:
        """The sensor publishers (for the final acknowledgement wait)."""
        return [self.pulse_pub, self.temp_pub]

    @property
    def total_s(self) -> float:
        """The programme's simulated seconds."""
        sim = self.run.simulator
        return (sim.end_time_ns - sim.start_time_ns) / 1e9

    def start_line(self) -> str:
        """'<scenario>: simulating H h of chamber time at <pace>'."""
        sim = self.run.simulator
        return (f'{self.run.scenario["name"]}: simulating '
                f'{(sim.end_time_ns - sim.start_time_ns) / 3.6e12:.2f} h of chamber time at '
                + (f'{self.real_time_factor:g}× real time'
                                         if self.real_time_factor > 0
                                         else 'the pace of the readers'))

    def finished_line(self) -> str:
        """'run finished: N messages published'."""
        return f'run finished: {self.published} messages published'

    def simulated_s(self) -> float:
        """Simulated seconds published (through the last chunk's end)."""
        return (self._until_ns + 1 - self.run.simulator.start_time_ns) / 1e9

    def run_finished(self) -> bool:
        """Whether the programme is over."""
        return bool(self.run.finished)

    def publish_next(self) -> None:
        """The next ``chunk_s`` of the run, in stamp order."""
        self._until_ns += self._step_ns
        self._publish(self.run.advance(self._until_ns))

    def _publish(self, chunk: ThermalChunk) -> None:
        n_p = len(chunk.pulse_t_ns)
        t = np.concatenate((chunk.pulse_t_ns, chunk.temperature_t_ns))
        kind = np.concatenate((np.zeros(n_p, np.int64),
                               np.ones(len(chunk.temperature_t_ns), np.int64)))
        row = np.concatenate((np.arange(n_p), np.arange(len(chunk.temperature_t_ns))))
        for i in np.lexsort((row, kind, t)).tolist():
            r = int(row[i])
            if kind[i] == 0:
                msg = JointState(name=[topics.GYRO_JOINT],
                                 position=[float(chunk.pulse_counts[r])])
                ns_to_stamp(int(chunk.pulse_t_ns[r]), msg.header.stamp)
                msg.header.frame_id = topics.GYRO_JOINT
                publish_paced(self.pulse_pub, msg, graph=self)
            else:
                temp = Temperature(temperature=float(chunk.temperature_c[r]),
                                   variance=float(chunk.temperature_variance_c2[r]))
                ns_to_stamp(int(chunk.temperature_t_ns[r]), temp.header.stamp)
                temp.header.frame_id = str(chunk.temperature_frame_id[r])
                publish_paced(self.temp_pub, temp, graph=self)
            self.published += 1


def main(args: list[str] | None = None) -> None:
    """Run the chamber simulator until its run is done (or it is shut down)."""
    run_simulator('thermal_chamber_sim', ThermalChamberNode, args)


if __name__ == '__main__':
    main()
