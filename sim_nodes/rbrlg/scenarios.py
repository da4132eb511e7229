"""Named bench scenarios and their MCAP bags (the committed regression bags come from here).

A :class:`Scenario` is a bench set-up (table, gyro, mount, procedure configs), optional
data faults applied to what the bench publishes, and the bench settings a calibration
needs (site latitude, n). :func:`write_scenario_bag` runs the simulators and writes the
contract topics to a rosbag2 MCAP bag with the scenario — parameters, seeds and truth —
in its metadata. Everything is deterministic under the seeds, so the same scenario
always gives the same messages.

Faults model what goes wrong on a real bench, applied to the published data, never to
the truth: a zero-index event the detector missed, a stretch of gyro samples lost, a
burst of mis-timed index events, samples arriving out of order. Lock-in at reversal is
physics and lives in the gyro config.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from gyro_calib import topics
from gyro_calib.bagio import BagMessage, ContractMessages, topic_sort_key, write_bag
from gyro_calib.units import RAD_PER_ARCSEC
from sim_nodes import scenario_files
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import (
    TwoAxisRecording,
    simulate_full_procedure,
    simulate_rate_bias_bench,
    true_k_tilde_arcsec_per_pulse,
)
from sim_nodes.rbrlg.procedure import ThetaProcedureConfig
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig
from sim_nodes.rbrlg.two_axis_gyro import TiltedMountConfig
from sim_nodes.scenario_files import named

KINDS = ('rate_bias', 'full')


@dataclass(frozen=True, slots=True)
class Faults:
    """Data faults applied to the published streams (all off by default).

    Attributes:
        drop_zero_index: indices (0-based) of rate-table zero-index events not published.
        pulse_gap_s: (start, end) of a stretch of gyro samples lost, s from the start.
        index_burst_s: (start, end) in which every rate-table zero-index event is stamped
            ``index_burst_arcsec`` of table angle late (a disturbed mark detector).
        index_burst_arcsec: angle error of the events inside the burst, ″.
        out_of_order_pulses: how many pairs of neighbouring gyro samples arrive swapped.
    """

    drop_zero_index: tuple[int, ...] = ()
    pulse_gap_s: tuple[float, float] | None = None
    index_burst_s: tuple[float, float] | None = None
    index_burst_arcsec: float = 0.0
    out_of_order_pulses: int = 0


@dataclass(frozen=True, slots=True)
class Scenario:
    """One bench run: configs, faults, and what a calibration of it should find.

    Attributes:
        name: file-system friendly name (the bag is ``<name>/``).
        description: one sentence for humans.
        kind: ``rate_bias`` (rate table alone, K̃) or ``full`` (K̃ phase then θ stations).
        table, gyro, mount, procedure: simulator configs.
        k_tilde_pairs: forward/reverse pairs of the K̃ phase (kind ``full``).
        faults: data faults.
        expected: regression expectations beyond the truth — counts and rejection reasons.
    """

    name: str
    description: str
    kind: str
    table: RateTableConfig
    gyro: RingLaserGyroConfig = field(default_factory=RingLaserGyroConfig)
    mount: TiltedMountConfig = field(default_factory=TiltedMountConfig)
    procedure: ThetaProcedureConfig = field(default_factory=ThetaProcedureConfig)
    k_tilde_pairs: int = 2
    faults: Faults = field(default_factory=Faults)
    expected: dict[str, Any] = field(default_factory=dict)

    def bench_settings(self) -> dict[str, Any]:
        """What the operator knows about the bench (not the answer): calibration inputs."""
        return {'latitude_deg': self.gyro.latitude_deg,
                'heading_deg': self.gyro.table_heading_deg,
                'position_table_revolutions': self.procedure.position_table_revolutions,
                'revolutions_per_window': 5}

    def truth(self) -> dict[str, float]:
        """The simulator's true values (what the calibration should recover)."""
        k = self.gyro.scale_factor_arcsec_per_pulse
        truth = {'k_tilde_arcsec_per_pulse': true_k_tilde_arcsec_per_pulse(self.gyro),
                 'scale_factor_arcsec_per_pulse': k,
                 'fix_error_angle_arcsec': self.gyro.fix_error_angle_arcsec}
        if self.kind == 'full':
            truth['tilt_deg'] = self.mount.tilt_deg
        return truth

    def tolerances(self) -> dict[str, float]:
        """How far from the truth a correct calibration may land.

        How far from the truth a correct calibration of this run may land (≈ 5 σ of
        the noise the run carries: index jitter, ARW, and the θ-phase error sources).
        """
        tol = {'k_tilde_relative': 7e-8}
        if self.kind == 'full':
            tol.update({'scale_factor_relative': 7e-8, 'fix_error_angle_arcsec': 0.5,
                        'tilt_deg': 0.01, 'bias_deg_h': 0.03})
        return tol

    def expected_results(self) -> dict[str, Any]:
        """The expectations written beside the committed bag: truth, tolerances, counts."""
        return {'scenario': self.name, 'truth': self.truth(), 'tolerance': self.tolerances(),
                'bias_deg_h_truth': self.gyro.bias_deg_h, **self.expected}

    def description_dict(self) -> dict[str, Any]:
        """Everything stored in the bag's metadata: configs, seeds, faults, truth."""
        return {
            'name': self.name, 'description': self.description, 'kind': self.kind,
            'k_tilde_pairs': self.k_tilde_pairs,
            'table': dataclasses.asdict(self.table), 'gyro': dataclasses.asdict(self.gyro),
            'mount': dataclasses.asdict(self.mount),
            'procedure': {k: list(v) if isinstance(v, tuple) else v
                          for k, v in dataclasses.asdict(self.procedure).items()},
            'faults': {k: list(v) if isinstance(v, tuple) else v
                       for k, v in dataclasses.asdict(self.faults).items()},
            'bench': self.bench_settings(), 'truth': self.truth(),
        }


# The odd bench's reference mark: 5.7° back from the reversal point after the forward cruise,
# which lies at 2·ω²/(2a) + 6.4 revolutions = 174.375° (ω = 135 °/s, a = 600 °/s²).
ODD_BENCH_MARK_DEG = 2 * 135.0**2 / (2 * 600.0) + 0.4 * 360.0 - 5.7

# K̃ bench runs: the paper's rate table and gyro, 100 s (three forward/reverse pairs, so a
# fault that costs a pair still leaves K̃).
_K_TABLE = RateTableConfig(duration_s=100.0, seed=21)
_K_GYRO = RingLaserGyroConfig(seed=21)
# θ procedures: 250 Hz samples (25 each side of an index event within ±0.1 s: enough for
# the count fit) keep the bags small.
_THETA_TABLE = RateTableConfig(sample_rate_hz=250.0, seed=31)
_THETA_GYRO = RingLaserGyroConfig(seed=31, sense_axis_azimuth_deg=23.0)

SCENARIOS: dict[str, Scenario] = {s.name: s for s in (
    Scenario('k_tilde_bench', "The paper's rate-bias bench: three forward/reverse pairs, "
             'm = 5, 150 °/s, 1 kHz.', 'rate_bias', _K_TABLE, _K_GYRO,
             expected={'window_pairs': 3, 'windows_accepted': 6, 'rejections': 0}),
    Scenario('theta_four_position', 'Full procedure: K̃ phase (2 pairs) on the tilted '
             'mount, then the classic four stations β₀ + k·90°.', 'full', _THETA_TABLE,
             _THETA_GYRO, expected={'window_pairs': 2, 'windows_accepted': 4, 'stations': 4,
                                    'rejections': 0}),
    Scenario('theta_multi_station', 'Full procedure with ten stations at 36° steps and '
             "the paper's error sources (wobble, positioning error, mounting change).",
             'full', dataclasses.replace(_THETA_TABLE, seed=41),
             dataclasses.replace(_THETA_GYRO, seed=41),
             TiltedMountConfig(wobble_arcsec=1.0, fix_error_change_arcsec=0.1),
             ThetaProcedureConfig(stations_deg=tuple(float(b) for b in range(0, 360, 36)),
                                  position_table_rate_deg_s=45.0, station_error_arcsec=1.0,
                                  seed=41),
             expected={'window_pairs': 2, 'windows_accepted': 4, 'stations': 10,
                       'rejections': 0}),
    Scenario('fault_lock_in', 'K̃ bench whose gyro locks in below 5 °/s at every reversal.',
             'rate_bias', dataclasses.replace(_K_TABLE, seed=22),
             dataclasses.replace(_K_GYRO, seed=22, lock_in_rate_deg_s=5.0),
             expected={'window_pairs': 3, 'windows_accepted': 6, 'rejections': 0}),
    Scenario('fault_missing_zero_index', 'K̃ bench whose index detector misses the event '
             'that ends the second forward window.', 'rate_bias',
             dataclasses.replace(_K_TABLE, seed=23), dataclasses.replace(_K_GYRO, seed=23),
             faults=Faults(drop_zero_index=(17,)),
             expected={'window_pairs': 2, 'windows_accepted': 5, 'rejections': 1,
                       'rejection_reasons': ['missing zero-index event']}),
    Scenario('fault_pulse_gap', 'K̃ bench that loses 0.4 s of gyro samples around the end '
             'of a window.', 'rate_bias', dataclasses.replace(_K_TABLE, seed=24),
             dataclasses.replace(_K_GYRO, seed=24), faults=Faults(pulse_gap_s=(58.3, 58.7)),
             expected={'window_pairs': 2, 'windows_accepted': 5, 'rejections': 1,
                       'rejection_reasons': ['gap in the pulse stream']}),
    Scenario('fault_index_jitter_burst', 'K̃ bench whose index events are stamped 300″ late '
             'during a 12 s burst.', 'rate_bias', dataclasses.replace(_K_TABLE, seed=25),
             dataclasses.replace(_K_GYRO, seed=25),
             faults=Faults(index_burst_s=(31.0, 43.0), index_burst_arcsec=300.0),
             expected={'window_pairs': 2, 'windows_accepted': 5, 'rejections': 5,
                       'rejection_reasons': ['jitter burst']}),
    Scenario('k_tilde_mark_in_acceleration', "Someone else's rate-bias bench: 135 °/s, "
             '600 °/s², 0.5 s rest at each reversal, 6.4 revolutions of cruise, and the '
             'reference mark 5.7° past one reversal point, so the zero-index event after '
             'that reversal falls in the acceleration (issue 9).', 'rate_bias',
             RateTableConfig(duration_s=112.0, rate_deg_s=135.0, acceleration_deg_s2=600.0,
                             settle_s=0.5, revolutions_per_segment=6.4,
                             zero_index_angle_deg=ODD_BENCH_MARK_DEG, seed=27),
             dataclasses.replace(_K_GYRO, seed=27),
             expected={'window_pairs': 3, 'windows_accepted': 6, 'rejections': 6,
                       'rejection_reasons': ['table accelerating at the zero-index event']}),
    Scenario('fault_out_of_order', 'K̃ bench whose gyro samples arrive with 200 '
             'neighbouring pairs swapped.', 'rate_bias', dataclasses.replace(_K_TABLE, seed=26),
             dataclasses.replace(_K_GYRO, seed=26), faults=Faults(out_of_order_pulses=200),
             expected={'window_pairs': 3, 'windows_accepted': 6, 'rejections': 0}),
)}
"""The committed scenarios (``bags/<name>``)."""


@dataclass(frozen=True, slots=True)
class _Streams:
    """Published streams of a run: joint states per topic and event stamps per topic."""

    joint_states: dict[str, tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                                  npt.NDArray[np.float64] | None]]
    events: dict[str, npt.NDArray[np.int64]]


def simulate_streams(scenario: Scenario) -> _Streams:
    """Run the scenario's simulators; return what the bench publishes, faults applied."""
    if scenario.kind == 'rate_bias':
        rec = simulate_rate_bias_bench(scenario.table, scenario.gyro)
        js = {topics.GYRO_PULSES: (rec.pulse_t_ns, rec.pulse_counts, None),
              topics.RATE_TABLE_JOINT_STATES: (rec.table_t_ns, rec.table_angle_rad,
                                               rec.table_rate_rad_s)}
        events = {topics.RATE_TABLE_ZERO_INDEX: rec.zero_index_ns}
    elif scenario.kind == 'full':
        two: TwoAxisRecording = simulate_full_procedure(
            scenario.procedure, scenario.table, scenario.gyro, scenario.mount,
            k_tilde_pairs=scenario.k_tilde_pairs)
        js = {topics.GYRO_PULSES: (two.pulse_t_ns, two.pulse_counts, None),
              topics.RATE_TABLE_JOINT_STATES: two.rate_table,
              topics.POSITION_TABLE_JOINT_STATES: two.position_table}
        events = {topics.RATE_TABLE_ZERO_INDEX: two.rate_zero_index_ns,
                  topics.POSITION_TABLE_ZERO_INDEX: two.position_zero_index_ns}
    else:
        raise ValueError(f'scenario kind {scenario.kind!r} is not one of {KINDS}')
    return _apply_faults(scenario, _Streams(js, events))


def _apply_faults(scenario: Scenario, streams: _Streams) -> _Streams:
    f = scenario.faults
    js, events = dict(streams.joint_states), dict(streams.events)
    t0 = scenario.table.start_time_ns
    index = events[topics.RATE_TABLE_ZERO_INDEX].copy()
    if f.index_burst_s is not None:
        lo, hi = (t0 + int(s * 1e9) for s in f.index_burst_s)
        burst = (index >= lo) & (index < hi)
        rate_rad_s = math.radians(scenario.table.rate_deg_s)
        index[burst] += int(round(f.index_burst_arcsec * RAD_PER_ARCSEC / rate_rad_s * 1e9))
    if f.drop_zero_index:
        index = np.delete(index, [i for i in f.drop_zero_index if i < len(index)])
    events[topics.RATE_TABLE_ZERO_INDEX] = index
    t, n, _ = js[topics.GYRO_PULSES]
    if f.pulse_gap_s is not None:
        lo, hi = (t0 + int(s * 1e9) for s in f.pulse_gap_s)
        keep = (t < lo) | (t >= hi)
        t, n = t[keep], n[keep]
    if f.out_of_order_pulses:
        t, n = t.copy(), n.copy()
        rng = np.random.default_rng(scenario.table.seed + 7)
        first = np.sort(rng.choice(len(t) // 2 - 1, f.out_of_order_pulses, replace=False)) * 2
        t[first], t[first + 1] = t[first + 1], t[first].copy()
        n[first], n[first + 1] = n[first + 1], n[first].copy()
    js[topics.GYRO_PULSES] = (t, n, None)
    return _Streams(js, events)


_JOINTS = {topics.GYRO_PULSES: topics.GYRO_JOINT,
           topics.RATE_TABLE_JOINT_STATES: topics.RATE_TABLE_JOINT,
           topics.POSITION_TABLE_JOINT_STATES: topics.POSITION_TABLE_JOINT,
           topics.RATE_TABLE_ZERO_INDEX: topics.RATE_TABLE_JOINT,
           topics.POSITION_TABLE_ZERO_INDEX: topics.POSITION_TABLE_JOINT}


def stream_messages(streams: _Streams) -> Iterator[BagMessage]:
    """The streams as bag messages in publication order.

    Log time = the sample's stamp, except that a sample arriving out of order keeps the
    log time of its slot (it was received then); ties go in contract topic order.
    """
    names: list[str] = []
    slots, order, kinds, rows = [], [], [], []
    for topic, (t, *_rest) in streams.joint_states.items():
        names.append(topic)
        slots.append(np.sort(t))  # arrival slot: the stamps in order
        order.append(np.full(len(t), topic_sort_key(topic)))
        kinds.append(np.full(len(t), len(names) - 1))
        rows.append(np.arange(len(t)))
    for topic, t in streams.events.items():
        names.append(topic)
        slots.append(np.asarray(t))
        order.append(np.full(len(t), topic_sort_key(topic)))
        kinds.append(np.full(len(t), len(names) - 1))
        rows.append(np.arange(len(t)))
    slot, prio = np.concatenate(slots), np.concatenate(order)
    kind, row = np.concatenate(kinds), np.concatenate(rows)
    sequence = np.lexsort((row, prio, slot))
    cdr = ContractMessages()
    for i in sequence.tolist():
        topic, r = names[kind[i]], int(row[i])
        joint = _JOINTS[topic]
        if topic in streams.joint_states:
            t, pos, vel = streams.joint_states[topic]
            data = cdr.joint_state(int(t[r]), joint, float(pos[r]),
                                   None if vel is None else float(vel[r]))
        else:
            data = cdr.header(int(streams.events[topic][r]), joint)
        yield BagMessage(topic, int(slot[i]), data)


def write_scenario_bag(scenario: Scenario | str, path: str | Path) -> Path:
    """Simulate ``scenario`` and write its bag at ``path`` (which must not exist)."""
    scenario = named(scenario, SCENARIOS)
    streams = simulate_streams(scenario)
    write_bag(path, stream_messages(streams), scenario=scenario.description_dict())
    return Path(path)


write_scenario_files = scenario_files.files_writer(
    SCENARIOS, write_scenario_bag, source='sim_nodes/scenarios.py')
"""Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in a directory."""
