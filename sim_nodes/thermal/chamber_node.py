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
import time

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import String

from gyro_calib import topics
from gyro_calib.nodes.ros_io import (
    SCENARIO_QOS,
    SENSOR_QOS,
    ProgressLog,
    StartGate,
    acknowledge_tail,
    declare_dataclass_parameters,
    described_parameter,
    ns_to_stamp,
    publish_paced,
    run_node,
    simulation_done,
    stops_on_stalled_readers,
)
from gyro_calib.topics import relative
from sim_nodes.thermal.gyro import ThermalChunk
from sim_nodes.thermal.scenarios import ChamberRunConfig


class ThermalChamberNode(Node):
    """Streams a chamber run's chunks at a paced rate."""

    def __init__(self) -> None:
        """Declare parameters, set up the run and start the pacing timer."""
        super().__init__('thermal_chamber_sim')
        param = functools.partial(described_parameter, self)
        self.config = ChamberRunConfig(**declare_dataclass_parameters(self, ChamberRunConfig))
        self.real_time_factor = float(param(
            'real_time_factor', 1.0, 'Simulated seconds per wall-clock second (0 = as fast as '
            'the readers acknowledge).'))
        self.chunk_s = float(param('chunk_s', 10.0, 'Simulated seconds per published chunk.'))
        self.exit_when_done = bool(param('exit_when_done', True,
                                         'Shut the node down once the run has been published.'))
        self.wait_for_subscribers = bool(param(
            'wait_for_subscribers', True, 'Start only once /gyro/pulses and /gyro/temperature '
            'each have a reader, so nothing is lost at the start.'))
        self.min_subscribers = int(param(
            'min_subscribers', 1, 'Readers each topic needs before the run starts (2 when a '
            'bag recorder and a calibration node must both hear it from the start).'))
        if not self.chunk_s > 0:
            raise ValueError(f'chunk_s = {self.chunk_s!r} must be positive')
        self.run = self.config.run()
        self.pulse_pub = self.create_publisher(JointState, relative(topics.GYRO_PULSES),
                                               SENSOR_QOS)
        self.temp_pub = self.create_publisher(Temperature, relative(topics.GYRO_TEMPERATURE),
                                              SENSOR_QOS)
        import yaml

        self.create_publisher(String, relative(topics.SIM_SCENARIO), SCENARIO_QOS).publish(
            String(data=yaml.safe_dump(self.run.scenario, sort_keys=True)))
        self._step_ns = int(round(self.chunk_s * 1e9))
        self._until_ns = self.run.simulator.start_time_ns - 1
        self._wall_start: float | None = None
        self._start_gate = StartGate(self.wait_for_subscribers,
                                     min_readers=self.min_subscribers,
                                     logger=self.get_logger())
        self._progress: ProgressLog | None = None
        self.published = 0
        self.done = False
        self.stalled = ''
        """Why publishing stopped before the end of the run ('' = it did not)."""
        self.create_timer(0.005, self._tick)

    @property
    def all_publishers(self) -> list:
        """The sensor publishers (for the final acknowledgement wait)."""
        return [self.pulse_pub, self.temp_pub]

    @stops_on_stalled_readers
    def _tick(self) -> None:
        if self._wall_start is None:
            if not self._start_gate.open(self.all_publishers):
                return  # readers first (see StartGate)
            self._wall_start = self._start_gate.opened_at
            sim = self.run.simulator
            self.get_logger().info(
                f'{self.run.scenario["name"]}: simulating '
                f'{(sim.end_time_ns - sim.start_time_ns) / 3.6e12:.2f} h of chamber time at '
                + (f'{self.real_time_factor:g}× real time' if self.real_time_factor > 0
                   else 'the pace of the readers'))
            self._progress = ProgressLog(self.get_logger(), 'chamber',
                                         (sim.end_time_ns - sim.start_time_ns) / 1e9)
        budget = 1 if self.real_time_factor <= 0 else None
        start_ns = self.run.simulator.start_time_ns
        while not self.run.finished and (budget is None or budget > 0):
            if budget is None:
                sim_due_ns = (time.monotonic() - self._wall_start) * self.real_time_factor * 1e9
                if self._until_ns + 1 - start_ns > sim_due_ns:
                    break
            else:
                budget -= 1
            self._until_ns += self._step_ns
            self._publish(self.run.advance(self._until_ns))
        if self._progress is not None:
            self._progress.update((self._until_ns - start_ns) / 1e9)
        if self.run.finished and not self.done:
            self.done = True
            self.get_logger().info(f'run finished: {self.published} messages published')

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
                publish_paced(self.pulse_pub, msg)
            else:
                temp = Temperature(temperature=float(chunk.temperature_c[r]),
                                   variance=float(chunk.temperature_variance_c2[r]))
                ns_to_stamp(int(chunk.temperature_t_ns[r]), temp.header.stamp)
                temp.header.frame_id = str(chunk.temperature_frame_id[r])
                publish_paced(self.temp_pub, temp)
            self.published += 1


def main(args: list[str] | None = None) -> None:
    """Run the chamber simulator until its run is done (or it is shut down)."""
    run_node('thermal_chamber_sim', ThermalChamberNode, args, done=simulation_done,
             on_stop=acknowledge_tail)


if __name__ == '__main__':
    main()
