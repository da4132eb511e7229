"""Named triad bench scenarios and their MCAP bags (METHODS §F; issue 26).

- ``triad_two_axis_bench``: the paper's two-axis bench with a triad on the rate table.
- ``triad_remount_bench_<axis>`` (``px mx py my pz mz``): the single-axis table, one bag per
  mount of the IMU (body axis ``+x`` … ``-z`` up); ``triad_remount_bench`` names the six
  (``gyro-calib simulate triad_remount_bench --out DIR`` writes all of them into DIR).

Each bag holds ``/imu/pulses`` (JointState, ``name`` the three channels, ``position`` the
cumulative counts), the rate table's ``/rate_table/joint_states`` and ``/rate_table/zero_index``
and, on the two-axis bench, the position table's; its stored scenario has the ``bench:``
settings a calibration needs (issue 26 contract) and the truth (K_i, s_i, M, b).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib import topics
from gyro_calib.bagio import JOINT_STATE, BagMessage, ContractMessages, typestore, write_bag
from gyro_calib.units import NS_PER_S
from sim_nodes import scenario_files
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.scenario_files import named
from sim_nodes.triad.bench import TriadBench, TriadChunk
from sim_nodes.triad.gyros import MOUNT_AXES, TriadConfig, TriadMountConfig
from sim_nodes.two_axis_procedure import ThetaProcedureConfig

IMU_PULSES = topics.IMU_PULSES
"""The triad's pulse topic."""

REMOUNT_GROUP = 'triad_remount_bench'
"""Name of the six remount scenarios together."""


def _axis_suffix(axis: str) -> str:
    return ('p' if axis[0] == '+' else 'm') + axis[1]


@dataclass(frozen=True, slots=True)
class TriadScenario:
    """One triad bench run and what a calibration of it should find.

    Attributes:
        name: the bag's name.
        description: one sentence for humans.
        kind: ``two_axis`` or ``remount``.
        table: the rate table (rate, m + 1 revolutions per segment, encoder, sample rates;
            the position table shares its encoder and sample settings).
        gyros: the triad and the site.
        mount: how the IMU sits (true tilt, fixture, mount axis).
        procedure: stations and position-table motion (two-axis bench).
        inner_pairs: forward/reverse pairs of rate-table segments.
    """

    name: str
    description: str
    kind: str
    table: RateTableConfig
    gyros: TriadConfig = field(default_factory=TriadConfig)
    mount: TriadMountConfig = field(default_factory=TriadMountConfig)
    procedure: ThetaProcedureConfig = field(default_factory=ThetaProcedureConfig)
    inner_pairs: int = 2

    def bench(self) -> TriadBench:
        """The simulated bench of this scenario."""
        return TriadBench(self.kind, self.table, self.gyros, self.mount, self.procedure,
                          self.inner_pairs)

    def bench_settings(self) -> dict[str, Any]:
        """What the operator knows about the bench (issue 26 contract): calibration inputs."""
        out: dict[str, Any] = {'latitude_deg': self.gyros.latitude_deg,
                               'heading_deg': self.gyros.heading_deg}
        if self.kind == 'remount':
            out['mount_axis'] = self.mount.mount_axis
        else:
            out.update({
                'tilt_deg': self.mount.tilt_deg, 'tilt_std_arcsec': self.mount.tilt_std_arcsec,
                'station_offset_deg': self.mount.station_offset_deg,
                'fixture_rotation': [list(r) for r in self.mount.fixture_rotation],
                'position_table_revolutions': self.procedure.position_table_revolutions})
        out['revolutions_per_window'] = int(self.table.revolutions_per_segment) - 1
        return out

    def truth(self) -> dict[str, Any]:
        """The simulator's true triad (what the calibration should recover), SI and ″."""
        g = self.gyros
        s = g.unit_sense_axes()
        misalignment = s / np.diag(s)[:, None]
        np.fill_diagonal(misalignment, 0.0)
        out: dict[str, Any] = {
            'channels': list(g.channels),
            'scale_factor_arcsec_per_pulse': [float(k) for k in g.scale_factor_arcsec_per_pulse],
            'scale_factor_rad_per_pulse': g.scale_factor_rad_per_pulse().tolist(),
            'sense_axes': s.tolist(),
            'misalignment_rad': misalignment.tolist(),
            'pulses_to_body_rad': g.pulses_to_body_rad().tolist(),
            'bias_rad_s': g.bias_body_rad_s().tolist(),
            'bias_deg_h_along_sense_axes': [float(b) for b in g.bias_deg_h],
            'angle_random_walk_deg_sqrt_h': [float(a) for a in g.angle_random_walk_deg_sqrt_h]}
        if self.kind == 'two_axis':
            out['tilt_deg'] = math.degrees(self.mount.true_tilt_rad())
            out['station_offset_deg'] = self.mount.station_offset_deg
            out['fixture_rotation'] = [list(r) for r in self.mount.fixture_rotation]
        else:
            out['mount_axis'] = self.mount.mount_axis
        return out

    def tolerances(self) -> dict[str, Any]:
        """How far from the truth a correct calibration of this run may land (≈ 5 σ).

        Two-axis bench: benchmarks/triad_precision.py predicts u(K)/K 1.3·10⁻⁸ for the gyro
        along the rate-table axis with 10 inner pairs (≈ 3·10⁻⁸ with this run's two) and
        2.5·10⁻⁷ for the other two (the stations alone), directions 0.04–0.06″. Remount: each
        bag measures one direction with two pairs (as the K̃ bench, 7·10⁻⁸ at three pairs);
        the six together give the triad. (test/test_triad_bags_estimator.py, bags cut naively:
        two-axis u(K)/K 2.0, 2.3, 0.25·10⁻⁷, directions 0.03–0.05″, tilt ±0.025″; remount
        u(K)/K 1.6–2.0·10⁻⁸, directions 0.005″; bias along s_i ±0.015–0.020 °/h two-axis,
        ±0.005 °/h remount.)
        """
        if self.kind == 'remount':
            return {'scale_factor_relative': [1e-7, 1e-7, 1e-7], 'sense_axis_arcsec': 0.5,
                    'bias_deg_h': 0.03}
        return {'scale_factor_relative': [1.5e-6, 1.5e-6, 1.5e-7], 'sense_axis_arcsec': 0.5,
                'tilt_arcsec': 0.5, 'bias_deg_h': 0.1}

    def expected_results(self) -> dict[str, Any]:
        """The expectations written beside the committed bag: truth, tolerances, counts."""
        rate, position = self.bench().profiles()
        out: dict[str, Any] = {'scenario': self.name, 'truth': self.truth(),
                               'tolerance': self.tolerances(),
                               'inner_window_pairs': self.inner_pairs}
        if position is not None:
            out['stations'] = len(self.procedure.stations_deg)
        return out

    def description_dict(self) -> dict[str, Any]:
        """Everything stored in the bag's metadata: configs, seeds, bench settings, truth."""
        def plain(obj: Any) -> Any:
            if isinstance(obj, (tuple, list)):
                return [plain(v) for v in obj]
            if isinstance(obj, dict):
                return {k: plain(v) for k, v in obj.items()}
            return obj

        return {
            'name': self.name, 'description': self.description, 'kind': f'triad_{self.kind}',
            'inner_pairs': self.inner_pairs,
            'table': dataclasses.asdict(self.table),
            'gyros': plain(dataclasses.asdict(self.gyros)),
            'mount': plain(dataclasses.asdict(self.mount)),
            'procedure': plain(dataclasses.asdict(self.procedure)) if self.kind == 'two_axis'
            else None,
            'bench': self.bench_settings(), 'truth': self.truth()}


# The paper bench: 150 °/s, m = 5 (6 revolutions per segment), two inner pairs, four stations
# with n = 1. A /imu/pulses message costs ≈ 40 bytes in the bag, so 1 kHz pulses over the
# ≈ 150 s run would make 6.8 MB: the committed bag has 500 Hz pulses and 250 Hz joint states
# (4.6 MB; `gyro-calib simulate triad_two_axis_bench --sample-rate-hz 1000` gives 1 kHz), and
# the position table turns at 90 °/s (≈ 22 s a station), accelerating at 400 °/s² so that the
# reference mark (37°) is crossed at constant rate in each run's first turn.
_TABLE = RateTableConfig(sample_rate_hz=500.0, joint_state_decimation=2, seed=61)
_GYROS = TriadConfig(seed=61)
_MOUNT = TriadMountConfig(tilt_error_arcsec=12.0)
_PROCEDURE = ThetaProcedureConfig(position_table_rate_deg_s=90.0, acceleration_deg_s2=400.0,
                                  seed=61)
# The remount bench: a single-axis table at 150 °/s, two forward/reverse pairs of 6
# revolutions per mount, 500 Hz pulses and 250 Hz joint states.
_REMOUNT_TABLE = RateTableConfig(sample_rate_hz=500.0, joint_state_decimation=2, seed=71)

_remount = tuple(
    TriadScenario(
        f'{REMOUNT_GROUP}_{_axis_suffix(axis)}',
        f'Single-axis table, the IMU mounted with body {axis} up: two forward/reverse pairs '
        'of 6 revolutions at 150 °/s, 500 Hz pulses.', 'remount',
        dataclasses.replace(_REMOUNT_TABLE, seed=71 + k),
        dataclasses.replace(_GYROS, seed=71 + k), TriadMountConfig(mount_axis=axis))
    for k, axis in enumerate(MOUNT_AXES))

SCENARIOS: dict[str, TriadScenario] = {s.name: s for s in (
    TriadScenario('triad_two_axis_bench', "The paper's two-axis bench with a triad: two "
                  'inner pairs (m = 5, 150 °/s), then four stations 90° apart with one '
                  'position-table revolution each way at 90 °/s; tilt 45° (12″ off '
                  'nominal), 500 Hz pulses.', 'two_axis', _TABLE, _GYROS, _MOUNT, _PROCEDURE),
    *_remount)}
"""The committed triad scenarios (``bags/<name>``)."""

GROUPS: dict[str, tuple[str, ...]] = {REMOUNT_GROUP: tuple(s.name for s in _remount)}
"""Names that stand for several scenarios (one bag each)."""


class PulseMessages:
    """CDR of /imu/pulses: a JointState of the three channels (positions = counts)."""

    def __init__(self, channels: tuple[str, ...]) -> None:
        """Load the typestore; ``channels`` are the JointState names."""
        self.store = typestore()
        t = self.store.types
        self._js, self._header, self._time = (t[JOINT_STATE], t['std_msgs/msg/Header'],
                                              t['builtin_interfaces/msg/Time'])
        self.channels = list(channels)
        self._empty = np.zeros(0, dtype=np.float64)

    def message(self, t_ns: int, counts: np.ndarray) -> bytes:
        """One message: stamp, frame_id 'imu', the channels' cumulative counts."""
        sec, nsec = divmod(int(t_ns), NS_PER_S)
        msg = self._js(header=self._header(stamp=self._time(sec=sec, nanosec=nsec),
                                           frame_id='imu'),
                       name=self.channels, position=np.asarray(counts, dtype=np.float64),
                       velocity=self._empty, effort=self._empty)
        return bytes(self.store.serialize_cdr(msg, JOINT_STATE))


def stream_messages(rec: TriadChunk, channels: tuple[str, ...]) -> Iterator[BagMessage]:
    """The run's messages in publication order.

    Log time = stamp; ties in the order pulses, rate table, its index, position table, its
    index (fixed here, so the bags do not change when topics join the contract's table).
    """
    streams: list[tuple[str, np.ndarray]] = [
        (IMU_PULSES, rec.pulse_t_ns), (topics.RATE_TABLE_JOINT_STATES, rec.rate_table[0]),
        (topics.RATE_TABLE_ZERO_INDEX, rec.rate_zero_index_ns)]
    if rec.position_table is not None and rec.position_zero_index_ns is not None:
        streams += [(topics.POSITION_TABLE_JOINT_STATES, rec.position_table[0]),
                    (topics.POSITION_TABLE_ZERO_INDEX, rec.position_zero_index_ns)]
    stamps = np.concatenate([t for _, t in streams])
    kind = np.concatenate([np.full(len(t), k) for k, (_, t) in enumerate(streams)])
    row = np.concatenate([np.arange(len(t)) for _, t in streams])
    pulses, cdr = PulseMessages(channels), ContractMessages()
    for i in np.lexsort((row, kind, stamps)).tolist():
        k, r, t_ns = int(kind[i]), int(row[i]), int(stamps[i])
        topic = streams[k][0]
        if topic == IMU_PULSES:
            data = pulses.message(t_ns, rec.pulse_counts[r])
        elif topic == topics.RATE_TABLE_JOINT_STATES:
            data = cdr.joint_state(t_ns, topics.RATE_TABLE_JOINT, float(rec.rate_table[1][r]),
                                   float(rec.rate_table[2][r]))
        elif topic == topics.POSITION_TABLE_JOINT_STATES:
            assert rec.position_table is not None
            data = cdr.joint_state(t_ns, topics.POSITION_TABLE_JOINT,
                                   float(rec.position_table[1][r]),
                                   float(rec.position_table[2][r]))
        else:
            data = cdr.header(t_ns, topics.RATE_TABLE_JOINT
                              if topic == topics.RATE_TABLE_ZERO_INDEX
                              else topics.POSITION_TABLE_JOINT)
        yield BagMessage(topic, t_ns, data)


def write_scenario_bag(scenario: TriadScenario | str, path: str | Path) -> Path:
    """Simulate ``scenario`` and write its bag at ``path`` (which must not exist)."""
    scenario = named(scenario, SCENARIOS)
    rec = scenario.bench().record()
    write_bag(path, stream_messages(rec, scenario.gyros.channels),
              types={IMU_PULSES: JOINT_STATE}, scenario=scenario.description_dict())
    return Path(path)


write_scenario_files = scenario_files.files_writer(
    SCENARIOS, write_scenario_bag, source='sim_nodes/triad/scenarios.py', what='triad calibration')
"""Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in a directory."""


__all__ = ['GROUPS', 'IMU_PULSES', 'SCENARIOS', 'TriadScenario', 'write_scenario_bag',
           'write_scenario_files']
