"""The thermal method's committed scenario bags.

The thermal method's committed scenario bags (``bags/thermal_*``) and how any chamber run
becomes a bag.

A :class:`ThermalScenario` is a chamber run (:class:`~sim_nodes.thermal.scenarios.
ChamberRunConfig`: programme, named gyro, seed, rates, faults) and what a calibration of it
should find. :func:`write_scenario_bag` streams the run chunk by chunk into a rosbag2 MCAP
bag — /gyro/pulses (sensor_msgs/JointState, name ['gyro'], position[0] = cumulative count)
and /gyro/temperature (sensor_msgs/Temperature, one message per sensor and instant,
header.frame_id = cavity_a, cavity_b or shell, variance = the sensor's noise and rounding)
— with the scenario (configs, seed, the bench settings an operator knows, truth) in its
metadata. Pulses at 2 Hz and temperatures at 1 Hz keep hours of data under 5 MB: the model
is fitted on 1 s interval means, which need no more (the paper's 8 h run: 3.7 MB).
"""

from __future__ import annotations

import dataclasses
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib.bagio import TEMPERATURE, BagMessage, ContractMessages, write_bag
from gyro_calib.topics import GYRO_JOINT, GYRO_PULSES, GYRO_TEMPERATURE
from sim_nodes.scenario_files import files_writer, named
from sim_nodes.thermal.scenarios import ChamberRunConfig, ThermalRun

CHUNK_S = 600.0
"""Simulated seconds per chunk while writing (the output does not depend on it)."""


class _CdrTemplate:
    """CDR bytes of one message layout with the stamp and some float64 fields left open.

    Made once from rosbags' serialisation of the message with sentinel values; each message
    is then the template with its stamp and values packed in — the same bytes rosbags
    writes (checked in test/test_thermal_bags.py), ten times faster.
    """

    _SENTINELS = (1234.56789012345, 9876.54321098765)

    def __init__(self, serialise: Any, n_values: int) -> None:
        ref = serialise(*self._SENTINELS[:n_values])
        self.template = bytes(ref)
        self.offsets = [self.template.index(struct.pack('<d', v))
                        for v in self._SENTINELS[:n_values]]

    def pack(self, t_ns: int, *values: float) -> bytes:
        out = bytearray(self.template)
        sec, nsec = divmod(int(t_ns), 1_000_000_000)
        struct.pack_into('<iI', out, 4, sec, nsec)  # header.stamp opens the CDR body
        for off, v in zip(self.offsets, values):
            struct.pack_into('<d', out, off, v)
        return bytes(out)


class TemperatureMessages:
    """CDR serialisation of sensor_msgs/Temperature and the /gyro/pulses JointState."""

    def __init__(self) -> None:
        """Load the typestore the bags are written with."""
        self.contract = ContractMessages()
        types = self.contract.store.types
        self._temperature = types[TEMPERATURE]
        self._header = types['std_msgs/msg/Header']
        self._time = types['builtin_interfaces/msg/Time']
        self._templates: dict[str, _CdrTemplate] = {}
        self._pulse = _CdrTemplate(lambda v: self.contract.joint_state(0, GYRO_JOINT, v), 1)

    def temperature_rosbags(self, t_ns: int, frame_id: str, celsius: float,
                            variance_c2: float) -> bytes:
        """One /gyro/temperature message, serialised by rosbags."""
        sec, nsec = divmod(int(t_ns), 1_000_000_000)
        msg = self._temperature(
            header=self._header(stamp=self._time(sec=sec, nanosec=nsec), frame_id=frame_id),
            temperature=float(celsius), variance=float(variance_c2))
        return bytes(self.contract.store.serialize_cdr(msg, TEMPERATURE))

    def temperature(self, t_ns: int, frame_id: str, celsius: float, variance_c2: float) -> bytes:
        """One /gyro/temperature message (header.frame_id = the sensor)."""
        tpl = self._templates.get(frame_id)
        if tpl is None:
            tpl = self._templates[frame_id] = _CdrTemplate(
                lambda c, v: self.temperature_rosbags(0, frame_id, c, v), 2)
        return tpl.pack(t_ns, celsius, variance_c2)

    def pulses(self, t_ns: int, count: float) -> bytes:
        """One /gyro/pulses message (name ['gyro'], position[0] = count)."""
        return self._pulse.pack(t_ns, count)


def run_messages(run: ThermalRun, *, chunk_s: float = CHUNK_S) -> Iterator[BagMessage]:
    """The run's messages in publication order.

    The run's messages in publication order: by stamp (= log time); at equal stamps the
    pulse sample first, then the sensors in the order the simulator emits them.
    """
    cdr = TemperatureMessages()
    for chunk in run.chunks(chunk_s):
        t = np.concatenate((chunk.pulse_t_ns, chunk.temperature_t_ns))
        kind = np.concatenate((np.zeros(len(chunk.pulse_t_ns), np.int64),
                               np.ones(len(chunk.temperature_t_ns), np.int64)))
        row = np.concatenate((np.arange(len(chunk.pulse_t_ns)),
                              np.arange(len(chunk.temperature_t_ns))))
        for i in np.lexsort((row, kind, t)).tolist():
            r = int(row[i])
            if kind[i] == 0:
                stamp = int(chunk.pulse_t_ns[r])
                yield BagMessage(GYRO_PULSES, stamp,
                                 cdr.pulses(stamp, float(chunk.pulse_counts[r])))
            else:
                stamp = int(chunk.temperature_t_ns[r])
                yield BagMessage(GYRO_TEMPERATURE, stamp, cdr.temperature(
                    stamp, str(chunk.temperature_frame_id[r]), float(chunk.temperature_c[r]),
                    float(chunk.temperature_variance_c2[r])))


@dataclass(frozen=True, slots=True)
class ThermalScenario:
    """One committed chamber run and what its calibration should find.

    Attributes:
        name: the bag's directory name.
        description: one sentence for humans.
        config: the chamber run.
        expected: regression expectations (rejection reasons, the improvement required on
            validation, which scenario calibrates a validation run).
    """

    name: str
    description: str
    config: ChamberRunConfig
    expected: dict[str, Any] = field(default_factory=dict)

    def description_dict(self) -> dict[str, Any]:
        """Everything stored in the bag's metadata: run config, gyro, chamber, bench, truth."""
        scenario = dict(self.config.run().scenario)
        scenario.update(name=self.name, description=self.description,
                        run=dataclasses.asdict(self.config))
        return scenario

    def expected_results(self) -> dict[str, Any]:
        """The expectations written beside the committed bag."""
        gyro = self.config.gyro()
        return {'scenario': self.name, 'gyro_id': gyro.gyro_id,
                'truth': {'scale_factor_rad_per_pulse': gyro.scale_factor_rad_per_pulse,
                          'earth_rate_along_axis_rad_s': gyro.earth_rate_along_axis_rad_s(),
                          'latitude_deg': gyro.latitude_deg},
                **self.expected}


_CAL = ChamberRunConfig(programme='paper_soak', gyro_id='A-1', seed=1)

SCENARIOS: dict[str, ThermalScenario] = {s.name: s for s in (
    ThermalScenario(
        'thermal_calibration', "The paper's chamber run (METHODS §D.4): gyro A-1 (the paper's "
        'strongly non-monotonic gyro), −35…35 °C at 7 set points, 1 h soaks, 1 °C/min ramps, '
        '8.2 h; 2 Hz pulses, 1 Hz temperatures of cavity_a, cavity_b, shell.', _CAL,
        expected={'rejections': 0, 'model_rms_error_deg_h': 0.02}),
    ThermalScenario(
        'thermal_validation', 'The same gyro A-1 on another day (seed 101): set points the '
        'calibration never visited (−30, −20, −5, 10, 20, 30 °C), 40 min soaks; the model of '
        'thermal_calibration must cut its bias stability by at least 77 %.',
        ChamberRunConfig(programme='validation', gyro_id='A-1', seed=101),
        expected={'calibrated_by': 'thermal_calibration', 'min_improvement': 0.77}),
    ThermalScenario(
        'thermal_fault_stuck_sensor', 'Gyro A-2 on a continuous ramp −20…20 °C at 0.5 °C/min: '
        'cavity_b freezes from 2.5 h on, the shell sensor drops out for 5 min; the model is '
        'fitted on the rest, each fault named.',
        ChamberRunConfig(programme='continuous_ramp', gyro_id='A-2', seed=7, low_c=-20.0,
                         high_c=20.0, rate_c_per_min=0.5, dwell_s=900.0,
                         stuck_sensor='cavity_b', stuck_from_s=9000.0, dropout_sensor='shell',
                         dropout_start_s=3000.0, dropout_end_s=3300.0),
        expected={'rejections': 2, 'model_rms_error_deg_h': 0.02,
                  'rejection_reasons': ['temperature sensor cavity_b reads exactly',
                                        'it is stuck',
                                        'temperature sensor shell gave no finite reading']}),
    ThermalScenario(
        'thermal_ramp_only_sparse', 'An odd but legal bench (issue 16): gyro B-1 '
        '(rate-sensitive) on ramps only, never soaking, −20…35 °C at 0.47–0.83 °C/min for '
        '5.8 h, starting hot; each temperature sensor read about every 2 s on its own clock '
        '(offsets 0.37, 1.21, 0.83 s; periods 2 s, 2.0004 s, 1.9997 s) with a 1/64 °C LSB; '
        '2 Hz pulses. The sensors are interpolated onto the 1 s intervals.',
        ChamberRunConfig(programme='ramp_only', gyro_id='B-1', seed=16, low_c=-20.0,
                         high_c=35.0, ramp_rates_c_per_min=(0.47, 0.83, 0.62, 0.71, 0.55),
                         start_hot=True, duration_s=5.8 * 3600.0, pulse_rate_hz=2.0,
                         sensor_read_intervals_s=(2.0, 2.0004, 1.9997),
                         sensor_clock_offsets_s=(0.37, 1.21, 0.83),
                         temperature_resolution_c=1.0 / 64.0),
        expected={'rejections': 0, 'model_rms_error_deg_h': 0.02}),
)}
"""The committed thermal scenarios (``bags/<name>``)."""


def write_scenario_bag(scenario: ThermalScenario | str, path: str | Path) -> Path:
    """Simulate ``scenario`` and write its bag at ``path`` (which must not exist)."""
    scenario = named(scenario, SCENARIOS)
    write_bag(path, run_messages(scenario.config.run()), scenario=scenario.description_dict())
    return Path(path)


write_scenario_files = files_writer(
    SCENARIOS, write_scenario_bag, source='sim_nodes/thermal/bag_scenarios.py')
"""Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in a directory."""
