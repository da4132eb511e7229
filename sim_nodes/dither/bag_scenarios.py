"""Named dither-misalignment bench runs and their MCAP bags (the committed ``bags/dither_*``).

A :class:`DitherScenario` is one orientation's run of the vibration table with the dithered
RLG on it (exact kinematics, :mod:`sim_nodes.dither.bench`), optional faults applied to what
the bench publishes, and what a calibration of it should find. :func:`write_scenario_bag`
writes ``/gyro/pulses`` and ``/vibration_table/joint_states`` (frame_id = the orientation)
into a rosbag2 MCAP bag with the scenario — parameters, seeds and truth — in its metadata.
Deterministic under the seeds: the same scenario always gives the same messages.

``dither_z`` and ``dither_y`` are the two orientations of one gyro (the Y run: gyro seed + 1,
starting one second after the Z run ended, as :func:`simulate_dither_pair`); together they
give a. The records are short (40 s at 2 kHz, 200 Hz joint_states: 2.6 MB each, and a DDS
replay of both within a minute); a table rate amplitude of 20 rad/s keeps the floor at 2.5′
per component (half the 5′ limit at k = 2), and the vibration frequency 27.6 Hz does not
divide the 2 kHz sample rate. Their expected files give
tolerances from the predicted floor σ_c and the in-phase rocking bound (k/θ_d·a), not from a
calibration of the bag.

Fault bags: ``dither_stripped`` (the output with the dither subtracted by the electronics'
pick-off, a 1 % residual left: no usable dither line) and ``dither_small_table`` (a table
rate amplitude of 1 rad/s, too small for the floor to resolve the misalignment).
"""

from __future__ import annotations

import dataclasses
import math
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib import topics
from gyro_calib.bagio import BagMessage, ContractMessages, topic_sort_key, write_bag
from gyro_calib.dither.coning import coning_drift
from gyro_calib.dither.floor import detection_floor
from gyro_calib.units import NS_PER_S
from sim_nodes import scenario_files
from sim_nodes.dither.bench import DitherBenchConfig
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.scenarios import DitherRecording, dither_truth, simulate_dither_run
from sim_nodes.dither.vibration_table import VibrationTableConfig
from sim_nodes.scenario_files import named

JOINT_STATE = 'sensor_msgs/msg/JointState'


@dataclass(frozen=True, slots=True)
class DitherFaults:
    """Faults applied to the published streams (all off by default).

    Attributes:
        strip_dither_residual: None = raw output; a number = the output is dither-stripped
            (the electronics subtract θ_d·cos a·sin(Ω_d·t + φ₀)/K, read from the dither
            pick-off, rounded to whole pulses), leaving this fraction of the dither line.
    """

    strip_dither_residual: float | None = None


@dataclass(frozen=True, slots=True)
class DitherScenario:
    """One orientation's bench run: configs, faults, and what a calibration should find.

    Attributes:
        name: file-system friendly name (the bag is ``<name>/``).
        description: one sentence for humans.
        gyro, table, bench: simulator configs (``table.axis`` is the orientation).
        faults: data faults.
        pair: the scenario of the other orientation of the same gyro ('' if none).
        expected: regression expectations beyond the truth: counts and reasons.
    """

    name: str
    description: str
    gyro: DitheredGyroConfig
    table: VibrationTableConfig
    bench: DitherBenchConfig
    faults: DitherFaults = field(default_factory=DitherFaults)
    pair: str = ''
    expected: dict[str, Any] = field(default_factory=dict)

    @property
    def orientation(self) -> str:
        """``'z'`` or ``'y'``: the case axis the table axis is along (the frame_id)."""
        return self.table.axis

    def truth(self) -> dict[str, Any]:
        """The simulator's truth and the coning the estimator reports.

        The simulator's truth (:func:`sim_nodes.dither.scenarios.dither_truth`) and the
        worst-case eq. (24) the estimator reports at the true components.
        """
        truth = dither_truth(self.gyro, self.table)
        truth['coning_eq24_worst_case_rad_s'] = self._coning(truth['misalignment_rad'])
        return truth

    def _coning(self, misalignment_rad: float) -> float:
        """Eq. (24) at this a, worst case.

        Eq. (24), worst case sin φ = 1, proportional rocking, at this a (what the estimator
        reports when the rocking phase is not given).
        """
        scale = misalignment_rad / self.gyro.geometry.misalignment_rad
        truth = dither_truth(self.gyro, self.table)
        return coning_drift(truth['misalignment_z_rad'] * scale,
                            truth['misalignment_y_rad'] * scale,
                            dither_frequency_hz=self.gyro.dither_frequency_hz,
                            dither_amplitude_rad=self.gyro.dither_amplitude_rad,
                            rocking_per_misalignment=self.gyro.rocking_per_misalignment,
                            model=self.gyro.rocking_model).eq24_rad_s

    def predicted_floor_rad(self) -> float:
        """σ_c of this record (METHODS §C), rad."""
        return detection_floor(
            table_rate_amplitude_rad_s=self.table.rate_amplitude_rad_s,
            dither_amplitude_rad=self.gyro.dither_amplitude_rad,
            record_s=self.bench.duration_s, sample_rate_hz=self.bench.sample_rate_hz,
            scale_factor_rad_per_pulse=self.gyro.scale_factor_rad_per_pulse,
            angle_random_walk_rad_sqrt_s=math.radians(
                self.gyro.angle_random_walk_deg_sqrt_h) / 60.0,
            dither_frequency_hz=self.gyro.dither_frequency_hz,
            table_frequency_hz=self.table.frequency_hz).component_std_rad

    def rocking_shift_rad(self) -> float:
        """Largest shift of one component the rocking causes, rad.

        Largest shift of one component the in-phase rocking causes: θ_rock,max/θ_d with
        θ_rock,max = k·a (METHODS §C), rad.
        """
        a = self.gyro.geometry.misalignment_rad
        return self.gyro.rocking_per_misalignment * a / self.gyro.dither_amplitude_rad

    def tolerances(self) -> dict[str, float]:
        """How far from the truth a correct calibration may land.

        How far from the truth a correct calibration may land: 4 σ_c of the record for the
        rocking-shifted (effective) components the output carries; plus the rocking shift
        for the true components and a (the estimator bounds, not removes, it); the coning at
        a ± that tolerance; θ_d and f_d to 1e-3.
        """
        floor, shift = self.predicted_floor_rad(), self.rocking_shift_rad()
        a = self.gyro.geometry.misalignment_rad
        tol_a = 4.0 * floor + math.sqrt(2.0) * shift
        return {
            'effective_component_rad': 4.0 * floor,
            'component_rad': 4.0 * floor + shift,
            'misalignment_rad': tol_a,
            'coning_eq24_rad_s': self._coning(a + tol_a) - self._coning(a),
            'dither_amplitude_relative': 1e-3,
            'dither_frequency_hz': 1e-3,
        }

    def bench_settings(self) -> dict[str, Any]:
        """What the operator knows about the bench (not the answer)."""
        return {'orientation': self.orientation,
                'table_rate_amplitude_rad_s': self.table.rate_amplitude_rad_s,
                'table_frequency_hz': self.table.frequency_hz,
                'sample_rate_hz': self.bench.sample_rate_hz}

    def expected_results(self) -> dict[str, Any]:
        """The expectations written beside the committed bag."""
        return {'scenario': self.name, 'orientation': self.orientation, 'pair': self.pair,
                'truth': self.truth(),
                'predicted': {'floor_rad': self.predicted_floor_rad(),
                              'rocking_shift_rad': self.rocking_shift_rad()},
                'tolerance': self.tolerances(), **self.expected}

    def description_dict(self) -> dict[str, Any]:
        """Everything stored in the bag's metadata: configs, seeds, faults, truth."""
        return {'name': self.name, 'description': self.description, 'method': 'dither',
                'orientation': self.orientation, 'pair': self.pair,
                'gyro': dataclasses.asdict(self.gyro), 'table': dataclasses.asdict(self.table),
                'bench_config': dataclasses.asdict(self.bench),
                'faults': dataclasses.asdict(self.faults),
                'bench': self.bench_settings(), 'truth': self.truth()}


# One gyro with a 60′ dither-axis misalignment (a badly bonded gyro, the top of the paper's
# sweep, where eq. (24) gives its 0.02 °/h) at ψ₀ = 120°, the paper's 1″-at-35′ rocking
# (proportional, φ = 1 rad), K = 1″. With the rocking bounded (the default), a lies within
# â·[1/(1 + ρ), 1/(1 − ρ)], ρ = √2·k/θ_d ≈ 0.39: the reject verdict against the 5′ limit is
# decided from â ≈ 7′ on.
_GYRO = DitheredGyroConfig(misalignment_arcmin=60.0, ia_azimuth_deg=120.0, seed=61)
_TABLE = VibrationTableConfig(rate_amplitude_rad_s=20.0, frequency_hz=27.6)
_BENCH = DitherBenchConfig(sample_rate_hz=2000.0, table_decimation=10, duration_s=40.0)
_Y_START_NS = int(round(_BENCH.duration_s * NS_PER_S)) + 1_000_000_000
_SHORT = dataclasses.replace(_BENCH, duration_s=20.0)

# Issue 16's bench (odd but legal): a = 53′ (ten times the 5′ limit), no transverse rocking
# (k = 0), a small slow table (6.2 rad/s at 8.7 Hz: 229.9 table periods per 2000 samples, near
# enough a divisor that the estimator widens σ as clock-locked), 2 kHz. The records
# were 5 min; 30 s keep each bag under 2 MB, with a floor of 9.3′ per component: the Z
# component (a·|sin ψ₀| = 45.9′) alone proves a ≫ 5′ (a ≥ |z|), so the verdict is reject
# from the interval, even with the paper's rocking allowance the estimator assumes by default.
_GYRO_53 = DitheredGyroConfig(misalignment_arcmin=53.0, ia_azimuth_deg=120.0,
                              rocking_arcsec_per_arcmin=0.0, seed=71)
_TABLE_53 = VibrationTableConfig(rate_amplitude_rad_s=6.2, frequency_hz=8.7)
_BENCH_53 = DitherBenchConfig(sample_rate_hz=2000.0, table_decimation=10, duration_s=30.0)
_Y_START_53_NS = int(round(_BENCH_53.duration_s * NS_PER_S)) + 1_000_000_000

SCENARIOS: dict[str, DitherScenario] = {s.name: s for s in (
    DitherScenario(
        'dither_z', 'Dithered RLG (a = 60′, ψ₀ = 120°, θ_d = 6′, 407.3 Hz, paper rocking) on a '
        'vibration table along case Z: 20 rad/s at 27.6 Hz, 40 s at 2 kHz.',
        _GYRO, dataclasses.replace(_TABLE, axis='z'), _BENCH, pair='dither_y',
        expected={'blocks_accepted': 20, 'rejections': 0,
                  'with_pair': {'verdict': 'reject'}}),
    DitherScenario(
        'dither_y', 'The same gyro with the table along case Y (the second orientation; '
        'starts 1 s after dither_z ended).',
        dataclasses.replace(_GYRO, seed=_GYRO.seed + 1), dataclasses.replace(_TABLE, axis='y'),
        dataclasses.replace(_BENCH, start_time_ns=_Y_START_NS), pair='dither_z',
        expected={'blocks_accepted': 20, 'rejections': 0,
                  'with_pair': {'verdict': 'reject'}}),
    DitherScenario(
        'dither_53arcmin_z', 'Issue 16\'s bench: another gyro (a = 53′, ψ₀ = 120°, no transverse '
        'rocking) on a vibration table along case Z: 6.2 rad/s at 8.7 Hz, 30 s at 2 kHz.',
        _GYRO_53, dataclasses.replace(_TABLE_53, axis='z'), _BENCH_53, pair='dither_53arcmin_y',
        expected={'blocks_accepted': 15, 'rejections': 0,
                  'with_pair': {'verdict': 'reject'}}),
    DitherScenario(
        'dither_53arcmin_y', 'The same 53′ gyro with the table along case Y (starts 1 s after '
        'dither_53arcmin_z ended).',
        dataclasses.replace(_GYRO_53, seed=_GYRO_53.seed + 1),
        dataclasses.replace(_TABLE_53, axis='y'),
        dataclasses.replace(_BENCH_53, start_time_ns=_Y_START_53_NS), pair='dither_53arcmin_z',
        expected={'blocks_accepted': 15, 'rejections': 0,
                  'with_pair': {'verdict': 'reject'}}),
    DitherScenario(
        'dither_stripped', 'The Z run of a dither-stripped output: the electronics subtract '
        'the dither read from the pick-off (1 % residual left), 20 s.',
        dataclasses.replace(_GYRO, seed=63), dataclasses.replace(_TABLE, axis='z'), _SHORT,
        DitherFaults(strip_dither_residual=0.01),
        expected={'blocks_accepted': 0, 'rejections': 10,
                  'rejection_reasons': ['no dither line in the output', 'dither-stripped']}),
    DitherScenario(
        'dither_small_table', 'The Z run with a table rate amplitude of 1 rad/s (0.33° at '
        '27.6 Hz), 20 s: the floor (71′ per component) is far above the 5′ limit.',
        dataclasses.replace(_GYRO, seed=64),
        dataclasses.replace(_TABLE, axis='z', rate_amplitude_rad_s=1.0), _SHORT,
        expected={'blocks_accepted': 10, 'rejections': 0,
                  'unresolved_reasons': ['cannot be told from zero', 'use A ≥']}),
)}
"""The committed dither scenarios (``bags/<name>``)."""


def simulate_scenario(scenario: DitherScenario) -> DitherRecording:
    """Run the scenario's bench; return what it publishes, faults applied."""
    rec = simulate_dither_run(scenario.gyro, scenario.table, scenario.bench)
    residual = scenario.faults.strip_dither_residual
    if residual is None:
        return rec
    gyro = scenario.gyro
    t_s = (rec.pulse_t_ns - scenario.bench.start_time_ns) / NS_PER_S
    pickoff_pulses = (gyro.dither_amplitude_rad * math.cos(gyro.geometry.misalignment_rad)
                      / gyro.scale_factor_rad_per_pulse
                      * np.sin(gyro.dither_angular_frequency_rad_s * t_s
                               + gyro.dither_phase_rad))
    stripped = rec.pulse_counts - np.round((1.0 - residual) * pickoff_pulses)
    return dataclasses.replace(rec, pulse_counts=stripped)


class JointStateTemplate:
    """CDR of a one-joint sensor_msgs/JointState with fixed name and frame_id, fast.

    The bytes rosbags serialises once are reused with the stamp and the position (and
    velocity) written in place: the layout of such a message never changes, so the result is
    byte for byte rosbags' own (``test/test_dither_bags.py`` checks it).
    """

    _SENTINELS = (1.2345678901234567e-300, -7.654321098765432e-299)

    def __init__(self, joint: str, frame_id: str, *, velocity: bool) -> None:
        """Serialise the template with sentinel values and find where they lie."""
        contract = ContractMessages()
        types = contract.store.types
        js, header, time_ = (types[JOINT_STATE], types['std_msgs/msg/Header'],
                             types['builtin_interfaces/msg/Time'])
        pos, vel = self._SENTINELS

        def serialise(sec: int, nsec: int, position: float, rate: float) -> bytes:
            msg = js(header=header(stamp=time_(sec=sec, nanosec=nsec), frame_id=frame_id),
                     name=[joint], position=np.array([position]),
                     velocity=np.array([rate]) if velocity else np.zeros(0),
                     effort=np.zeros(0))
            return bytes(contract.store.serialize_cdr(msg, JOINT_STATE))

        self.serialise = serialise
        raw = serialise(0x01020304, 0x05060708, pos, vel)
        self._template = bytearray(raw)
        self._stamp_at = raw.index(struct.pack('<iI', 0x01020304, 0x05060708))
        self._position_at = raw.index(struct.pack('<d', pos))
        self._velocity_at = raw.index(struct.pack('<d', vel)) if velocity else -1

    def cdr(self, t_ns: int, position: float, velocity: float = 0.0) -> bytes:
        """The message's CDR bytes at stamp ``t_ns`` (non-negative)."""
        sec, nsec = divmod(int(t_ns), 1_000_000_000)
        out = self._template
        struct.pack_into('<iI', out, self._stamp_at, sec, nsec)
        struct.pack_into('<d', out, self._position_at, position)
        if self._velocity_at >= 0:
            struct.pack_into('<d', out, self._velocity_at, velocity)
        return bytes(out)


def stream_messages(rec: DitherRecording) -> Iterator[BagMessage]:
    """The recording as bag messages in publication order.

    The recording as bag messages in publication order (log time = stamp; ties in contract
    topic order).
    """
    stamps = np.concatenate((rec.pulse_t_ns, rec.table_t_ns))
    prio = np.concatenate((np.full(len(rec.pulse_t_ns), topic_sort_key(topics.GYRO_PULSES)),
                           np.full(len(rec.table_t_ns),
                                   topic_sort_key(topics.VIBRATION_TABLE_JOINT_STATES))))
    rows = np.concatenate((np.arange(len(rec.pulse_t_ns)), np.arange(len(rec.table_t_ns))))
    is_table = np.concatenate((np.zeros(len(rec.pulse_t_ns), bool),
                               np.ones(len(rec.table_t_ns), bool)))
    order = np.lexsort((rows, prio, stamps))
    pulse_msg = JointStateTemplate(topics.GYRO_JOINT, topics.GYRO_JOINT, velocity=False)
    table_msg = JointStateTemplate(topics.VIBRATION_TABLE_JOINT, rec.frame_id, velocity=True)
    pulse_t, counts = rec.pulse_t_ns.tolist(), rec.pulse_counts.tolist()
    table_t = rec.table_t_ns.tolist()
    angle, rate = rec.table_angle_rad.tolist(), rec.table_rate_rad_s.tolist()
    for i in order.tolist():
        r = int(rows[i])
        if is_table[i]:
            yield BagMessage(topics.VIBRATION_TABLE_JOINT_STATES, table_t[r],
                             table_msg.cdr(table_t[r], angle[r], rate[r]))
        else:
            yield BagMessage(topics.GYRO_PULSES, pulse_t[r], pulse_msg.cdr(pulse_t[r], counts[r]))


def write_scenario_bag(scenario: DitherScenario | str, path: str | Path) -> Path:
    """Simulate ``scenario`` and write its bag at ``path`` (which must not exist)."""
    scenario = named(scenario, SCENARIOS)
    write_bag(path, stream_messages(simulate_scenario(scenario)),
              scenario=scenario.description_dict())
    return Path(path)


write_scenario_files = scenario_files.files_writer(
    SCENARIOS, write_scenario_bag, source='sim_nodes/dither/bag_scenarios.py')
"""Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in a directory."""

