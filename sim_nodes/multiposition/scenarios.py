"""The committed multiposition scenario and its MCAP bag (issue 38).

- ``multiposition_hand_turned``: a MEMS IMU (percent-level scale errors, misalignments of
  0.2–0.7°, biases of 0.1–0.35 m/s² and 4–11 mrad/s, white noise) turned by hand through 18
  poses — gravity along each body axis both ways, then along the 12 edges between them, each
  pose at its own heading — at 50 Hz, ``sensor_msgs/Imu`` on ``/imu/data``.
- ``multiposition_few_poses_low_rate``: the odd-but-legal end of the same procedure — 13
  poses (the six faces and seven edges: one more than the accelerometer needs), 20 Hz,
  rests of 2.5–3 s, outputs rounded to 16-bit LSBs (±4 g: 2.4·10⁻³ m/s², ±500 °/s:
  2.66·10⁻⁴ rad/s).

The stored scenario has the ``bench:`` settings the calibration reads (the site's latitude)
and the truth in the method's parameter order; the expected file says how close a correct
calibration lands: within k = 3 standard uncertainties of each parameter.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sim_nodes import scenario_files
from sim_nodes.multiposition.imu import (
    EDGES,
    FACES,
    HandTurnedRun,
    MemsImuConfig,
    PoseProcedureConfig,
    simulate,
)
from sim_nodes.noise.bag_scenarios import imu_template
from sim_nodes.scenario_files import named

IMU_TOPIC = '/imu/data'
"""Where the IMU publishes (the method's default topic)."""
IMU_FRAME = 'imu'
"""frame_id of its messages."""
IMU = 'sensor_msgs/msg/Imu'
START_NS = 1_750_000_000_000_000_000
"""Stamp of the first sample, ns."""

ACC_NAMES = ('misalignment_yz_rad', 'misalignment_zy_rad', 'misalignment_zx_rad',
             'scale_x', 'scale_y', 'scale_z', 'bias_x_raw', 'bias_y_raw', 'bias_z_raw')
GYRO_NAMES = ('misalignment_yz_rad', 'misalignment_zy_rad', 'misalignment_zx_rad',
              'misalignment_xz_rad', 'misalignment_xy_rad', 'misalignment_yx_rad',
              'scale_x', 'scale_y', 'scale_z', 'bias_x_raw', 'bias_y_raw', 'bias_z_raw')
"""The method's parameter names, repeated: a simulator imports no method."""


@dataclass(frozen=True, slots=True)
class MultipositionScenario:
    """One hand-turned run and what a calibration of it should find.

    Attributes:
        name: the bag's name.
        description: one sentence for humans.
        imu: the IMU's true errors and noise.
        procedure: the poses and turns.
    """

    name: str
    description: str
    imu: MemsImuConfig = field(default_factory=MemsImuConfig)
    procedure: PoseProcedureConfig = field(default_factory=PoseProcedureConfig)

    def run(self) -> HandTurnedRun:
        """The simulated run."""
        return simulate(self.imu, self.procedure)

    def stamps_ns(self, run: HandTurnedRun) -> np.ndarray:
        """Each sample's header stamp, ns."""
        return START_NS + np.round(run.t_s * 1e9).astype(np.int64)

    def bench_settings(self) -> dict[str, Any]:
        """What the operator knows: the site."""
        return {'latitude_deg': self.procedure.latitude_deg}

    def truth(self) -> dict[str, Any]:
        """The IMU's true parameters by the method's result keys (``imu.<sensor>.<name>``)."""
        out: dict[str, Any] = {}
        for sensor, names, values in (('accelerometer', ACC_NAMES, self.imu.acc_truth()),
                                      ('gyro', GYRO_NAMES, self.imu.gyro_truth())):
            out.update({f'imu.{sensor}.{n}': float(v)
                        for n, v in zip(names, values, strict=True)})
        out['gravity_m_s2'] = self.run().gravity_m_s2
        return out

    def expected_results(self) -> dict[str, Any]:
        """Truth, how close a calibration lands, the poses."""
        return {'scenario': self.name, 'truth': self.truth(),
                'tolerance': {'k_standard_uncertainties': 3.0},
                'static_poses': len(self.procedure.up_axes),
                'well_conditioned': True,
                'note': 'the gyro bias estimate holds the Earth rate averaged over the poses '
                        '(docs/methods.md §G.3), inside its u'}

    def description_dict(self) -> dict[str, Any]:
        """Everything stored in the bag's metadata: configs, seed, bench settings, truth."""
        def plain(obj: Any) -> Any:
            if isinstance(obj, (tuple, list)):
                return [plain(v) for v in obj]
            if isinstance(obj, dict):
                return {k: plain(v) for k, v in obj.items()}
            return obj

        return {'name': self.name, 'description': self.description,
                'kind': 'multiposition_hand_turned', 'topic': IMU_TOPIC,
                'imu': plain(dataclasses.asdict(self.imu)),
                'procedure': plain(dataclasses.asdict(self.procedure)),
                'bench': self.bench_settings(), 'truth': self.truth()}


SCENARIOS: dict[str, MultipositionScenario] = {s.name: s for s in (
    MultipositionScenario(
        'multiposition_hand_turned',
        'A MEMS IMU turned by hand through 18 poses (gravity along ±x, ±y, ±z, then the 12 '
        'edges), 3–4.5 s rests, 1.5–2.5 s turns, 50 Hz sensor_msgs/Imu on /imu/data.'),
    MultipositionScenario(
        'multiposition_few_poses_low_rate',
        'The same IMU with 16-bit outputs turned through 13 poses (the six faces, seven '
        'edges), 2.5–3 s rests, 20 Hz sensor_msgs/Imu on /imu/data.',
        MemsImuConfig(acc_lsb=2.4e-3, gyro_lsb=2.66e-4),
        PoseProcedureConfig(up_axes=FACES + EDGES[:7], first_rest_s=4.0, rest_s=(2.5, 3.0),
                            sample_rate_hz=20.0, seed=7)))}
"""The committed multiposition scenarios (``bags/<name>``)."""


def imu_rows(run: HandTurnedRun, stamps_ns: np.ndarray) -> np.ndarray:
    """The run's sensor_msgs/Imu messages as rows of CDR bytes."""
    template, accel_offset = imu_template(IMU_FRAME)
    rows = template.rows(stamps_ns, run.gyro)
    at = template.value_at + accel_offset
    rows[:, at:at + 24] = np.ascontiguousarray(run.acc.astype('<f8')).view(np.uint8).reshape(
        len(stamps_ns), 24)
    return rows


def write_scenario_bag(scenario: MultipositionScenario | str, path: str | Path) -> Path:
    """Simulate ``scenario`` and write its bag at ``path`` (which must not exist)."""
    from gyro_calib.bagio import BagMessage, write_bag

    scenario = named(scenario, SCENARIOS)
    run = scenario.run()
    stamps = scenario.stamps_ns(run)
    rows = imu_rows(run, stamps)
    write_bag(path, (BagMessage(IMU_TOPIC, int(s), r.tobytes()) for s, r in zip(stamps, rows)),
              types={IMU_TOPIC: IMU}, scenario=scenario.description_dict())
    return Path(path)


write_scenario_files = scenario_files.files_writer(
    SCENARIOS, write_scenario_bag, source='sim_nodes/multiposition/scenarios.py',
    what='multiposition calibration')
"""Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in a directory."""


__all__ = ['IMU_TOPIC', 'SCENARIOS', 'MultipositionScenario', 'write_scenario_bag',
           'write_scenario_files']
