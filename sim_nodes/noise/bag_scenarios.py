"""Committed noise-characterisation bags: static MEMS IMUs, dithered RLGs at rest, a turning RLG.

The scenarios (``bags/<name>/`` and ``bags/<name>.expected.yaml``, written by
``python bags/generate.py NAME``):

``noise_imu_static``
    A consumer-grade MEMS IMU lying still: ``sensor_msgs/Imu`` on ``/imu/data`` at 200 Hz
    for 500 s. Per axis angle (velocity) random walk, bias instability (flicker) and rate
    (acceleration) random walk, each axis its own values; gravity on +z; the output rounded
    to a 16-bit ADC's step (±250 °/s, ±4 g) as the driver scales it; host stamps with
    ±0.1 ms jitter; 60 neighbouring messages swapped (out of order) and 25 published twice
    (duplicate stamps). Long enough to resolve N and B of every gyro axis (the bias
    instability crosses the random walk near 5 s, the record reaches τ = 125 s); K is in
    the data but below what 500 s resolve, so it is absent with a reason and a bound.
``noise_rlg_static``
    A mechanically dithered ring laser gyro at rest on a level base, sense axis vertical
    (Earth rate 15.041·sin 45° °/h plus 0.005 °/h bias, both invisible to the Allan
    variance): cumulative pulses on ``/gyro/pulses`` at 500 Hz for 280 s, K = 4.0860157e-6
    rad/pulse (stored as the bench setting), dither 120″ at 413.7 Hz stripped by the dither
    pick-off; 2 s of samples lost at 240 s (a gap: two segments). The dither moves the
    sub-pulse phase, so quantisation shows as a −1 slope with Q = K/√12. **Without dither a
    static RLG is locked in**: no pulse, a constant count, no −1 slope and nothing else to
    measure (``gyro-calib noise`` says so and stops) — quantisation is absent then, not
    fitted. The bias instability of a navigation RLG (0.003 °/h) needs hours; 280 s leave
    it absent, with its bound.
``noise_rlg_spikes``
    The dithered RLG of ``noise_rlg_static`` (another seed, 120 s, no gap) whose count
    read-out has 40 one-sample bit errors: the count of that sample is off by ±2^b pulses
    (5 ≤ b < 10), the next one right again (``spikes``, ``spike_bits``). Each gives two
    increments beyond 8 robust σ (METHODS §E.6): 80 found; kept they make Q 20× too large;
    the expected file asks for ``outliers: remove``, which gives Q and N of the gyro.
``noise_rlg_turning``
    A rate-biased RLG (no dither) on a rate table turning about its sense axis at a constant
    37.9 °/s, 100 s one way, a reversal at 100 °/s² (0.758 s), 100 s the other way: pulses
    on ``/gyro/pulses`` at 250 Hz, the table's joint states on ``/rate_table/joint_states``
    at 50 Hz (2²³-count encoder angle, the controller's rate). A constant rate is a constant
    the Allan variance removes: the table gate leaves out the reversal only, and the two
    steady segments give Q = K/√12 (the rotation moves the sub-pulse phase) and N
    (0.01 °/√h). The count is ⌊φ0 + (table angle + Earth rate·t + noise angle)/K⌋.

The sinusoidal dither leaves structure in the rounding error a few samples long, so the
model fits the RLG's Allan variance worse than its scatter allows (χ² ratio about 4.5):
the summary says so, and the uncertainties are scaled up by √ratio. (Real RLGs add random
noise to the dither for the same reason.)

Expected files: the truth per axis and term, the terms that must resolve, the ordering and
gap counts; every reported term must lie within ``coverage_factor`` = 3.5 standard
uncertainties of the truth. With up to 14 terms checked per bag, 3.5 keeps the chance that
any honest one falls outside near 1 % (a Monte Carlo of the IMU's configuration — 120 axis
records, 500 s each — gave 93 % of |z| < 2, largest |z| 3.0; the committed record's accel_x
B lies at −3.3σ).

Messages are built from one template serialised by rosbags' typestore, with the stamp and
values written at their byte offsets (bit-identical to serialising each message; checked
in ``test/test_noise_bags.py``); the truth stored in the bag and the expected file is the
generators' own (:mod:`sim_nodes.noise.sensors`), rounding included.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sim_nodes import scenario_files
from sim_nodes.noise.sensors import (
    NS_PER_S,
    STANDARD_GRAVITY_M_S2,
    ImuNoiseGenerator,
    NoiseTerms,
    RlgPulseGenerator,
)
from sim_nodes.scenario_files import named

IMU = 'sensor_msgs/msg/Imu'
JOINT_STATE = 'sensor_msgs/msg/JointState'
GYRO_PULSES = '/gyro/pulses'
GYRO_JOINT = 'gyro'
TABLE_TOPIC = '/rate_table/joint_states'
START_NS = 1_767_225_600 * NS_PER_S
"""First stamp of the simulated records (2026-01-01T00:00:00Z)."""
EARTH_RATE_RAD_S = 7.292115e-5
DEG = math.pi / 180.0
MICRO_G = STANDARD_GRAVITY_M_S2 * 1e-6
COVERAGE_NOTE = ('every reported term lies within coverage_factor standard uncertainties of the '
                 'truth; terms not in must_resolve may be absent (with a reason)')
CHUNK = 20_000
"""Samples generated per chunk (the output does not depend on it)."""

GYRO_KEYS = ('quantization_noise_rad', 'angle_random_walk_rad_per_sqrt_s',
             'bias_instability_rad_s', 'rate_random_walk_rad_per_s_sqrt_s',
             'rate_ramp_rad_per_s2')
ACCEL_KEYS = ('quantization_noise_m_s', 'velocity_random_walk_m_s_per_sqrt_s',
              'bias_instability_m_s2', 'acceleration_random_walk_m_s2_per_sqrt_s',
              'acceleration_ramp_m_s2_per_s')
"""The core's term keys (gyro_calib.noise.terms), repeated: a simulator imports no method."""


def _terms_dict(t: NoiseTerms) -> dict[str, Any]:
    d = dataclasses.asdict(t)
    d['flicker_band_hz'] = list(t.flicker_band_hz)
    return d


class _Template:
    """One serialised message and the byte offsets of its stamp and values."""

    def __init__(self, cdr: bytes, sec_at: int, value_at: int, n_values: int) -> None:
        self.row = np.frombuffer(cdr, dtype=np.uint8)
        self.sec_at, self.value_at, self.n_values = sec_at, value_at, n_values

    def rows(self, t_ns: npt.NDArray[np.int64], values: npt.NDArray[np.float64]) -> np.ndarray:
        """Messages of the stamps and values (n × n_values) as rows of bytes."""
        n = len(t_ns)
        out = np.tile(self.row, (n, 1))
        sec, nsec = np.divmod(t_ns, NS_PER_S)
        out[:, self.sec_at:self.sec_at + 4] = sec.astype('<i4').view(np.uint8).reshape(n, 4)
        out[:, self.sec_at + 4:self.sec_at + 8] = nsec.astype('<u4').view(np.uint8).reshape(n, 4)
        v = np.ascontiguousarray(values.reshape(n, self.n_values).astype('<f8'))
        out[:, self.value_at:self.value_at + 8 * self.n_values] = v.view(np.uint8).reshape(
            n, 8 * self.n_values)
        return out


def _store() -> Any:
    from gyro_calib.bagio import typestore as _typestore

    return _typestore()


def imu_template(frame_id: str) -> tuple[_Template, int]:
    """Template of a sensor_msgs/Imu and its acceleration offset.

    Template of a sensor_msgs/Imu (orientation unknown: covariance[0] = −1, REP 145) and
    the offset of linear_acceleration relative to angular_velocity.
    """
    store = _store()
    t = store.types
    header = t['std_msgs/msg/Header'](stamp=t['builtin_interfaces/msg/Time'](sec=0, nanosec=0),
                                      frame_id=frame_id)
    vec = t['geometry_msgs/msg/Vector3']
    orientation_cov = np.zeros(9)
    orientation_cov[0] = -1.0
    marker_w, marker_a = vec(x=1.25, y=2.25, z=3.25), vec(x=4.25, y=5.25, z=6.25)
    msg = t[IMU](header=header, orientation=t['geometry_msgs/msg/Quaternion'](
        x=0.0, y=0.0, z=0.0, w=1.0), orientation_covariance=orientation_cov,
        angular_velocity=marker_w, angular_velocity_covariance=np.zeros(9),
        linear_acceleration=marker_a, linear_acceleration_covariance=np.zeros(9))
    cdr = bytes(store.serialize_cdr(msg, IMU))
    w_at = cdr.index(np.array([1.25, 2.25, 3.25], '<f8').tobytes())
    a_at = cdr.index(np.array([4.25, 5.25, 6.25], '<f8').tobytes())
    return _Template(cdr, 4, w_at, 3), a_at - w_at


def imu_message(t_ns: int, frame_id: str, gyro: Any, accel: Any) -> bytes:
    """One sensor_msgs/Imu serialised by rosbags (the reference the template must equal)."""
    store = _store()
    t = store.types
    sec, nsec = divmod(int(t_ns), NS_PER_S)
    vec = t['geometry_msgs/msg/Vector3']
    orientation_cov = np.zeros(9)
    orientation_cov[0] = -1.0
    msg = t[IMU](header=t['std_msgs/msg/Header'](
        stamp=t['builtin_interfaces/msg/Time'](sec=sec, nanosec=nsec), frame_id=frame_id),
        orientation=t['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=orientation_cov,
        angular_velocity=vec(x=float(gyro[0]), y=float(gyro[1]), z=float(gyro[2])),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=vec(x=float(accel[0]), y=float(accel[1]), z=float(accel[2])),
        linear_acceleration_covariance=np.zeros(9))
    return bytes(store.serialize_cdr(msg, IMU))


def pulse_template() -> _Template:
    """Template of the contract's /gyro/pulses JointState (one joint, position only)."""
    from gyro_calib.bagio import ContractMessages

    cdr = ContractMessages().joint_state(0, GYRO_JOINT, 1234.5)
    return _Template(cdr, 4, cdr.index(np.array([1234.5], '<f8').tobytes()), 1)


@dataclass(frozen=True, slots=True)
class ImuBagScenario:
    """A static IMU recorded to a bag (see the module docstring).

    Attributes:
        name: bag name.
        description: one sentence.
        gyro_terms, accel_terms: x, y, z noise of each triad (rad/s, m/s² units).
        sample_rate_hz: output rate, Hz.
        duration_s: record length, s.
        gyro_lsb_rad_s, accel_lsb_m_s2: output step (16-bit ADC as the driver scales it).
        stamp_jitter_s: host-stamp jitter, ± s.
        swapped_pairs: neighbouring messages published in swapped order.
        duplicates: messages published twice (same stamp and values).
        topic, frame_id: where and as what the IMU publishes.
        seed: generator seed.
        decimation, lowpass_cutoff_hz: the IMU's own decimation filter (D× internal rate,
            2nd-order Butterworth at f_c; 1 and 0 = none, as :class:`ImuNoiseGenerator`).
        must_resolve_gyro: the gyro terms every axis must resolve.
    """

    name: str
    description: str
    gyro_terms: tuple[NoiseTerms, NoiseTerms, NoiseTerms]
    accel_terms: tuple[NoiseTerms, NoiseTerms, NoiseTerms]
    sample_rate_hz: float = 200.0
    duration_s: float = 500.0
    gyro_lsb_rad_s: float = 250.0 * DEG / 32768.0
    accel_lsb_m_s2: float = 4.0 * STANDARD_GRAVITY_M_S2 / 32768.0
    stamp_jitter_s: float = 1e-4
    swapped_pairs: int = 60
    duplicates: int = 25
    topic: str = '/imu/data'
    frame_id: str = 'imu_link'
    seed: int = 11
    coverage_factor: float = 3.5
    decimation: int = 1
    lowpass_cutoff_hz: float = 0.0
    must_resolve_gyro: tuple[str, ...] = (GYRO_KEYS[1], GYRO_KEYS[2])

    @property
    def n_samples(self) -> int:
        """Samples generated."""
        return int(round(self.duration_s * self.sample_rate_hz))

    def generator(self) -> ImuNoiseGenerator:
        """A fresh generator of this IMU."""
        return ImuNoiseGenerator(self.gyro_terms, self.accel_terms,
                                 sample_rate_hz=self.sample_rate_hz, seed=self.seed,
                                 start_ns=START_NS, stamp_jitter_s=self.stamp_jitter_s,
                                 gyro_lsb_rad_s=self.gyro_lsb_rad_s,
                                 accel_lsb_m_s2=self.accel_lsb_m_s2,
                                 decimation=self.decimation,
                                 lowpass_cutoff_hz=self.lowpass_cutoff_hz)

    def truth(self) -> dict[str, dict[str, float]]:
        """The noise terms the recorded samples carry, per axis.

        The noise terms the recorded samples carry, per axis (term key → SI value):
        the generator's terms, the random walk times the decimation filter's alias factor
        (1 without a filter) with the ADC rounding added.
        """
        gen = self.generator()
        alias = gen.filtered_random_walk_factor()
        out: dict[str, dict[str, float]] = {}
        for prefix, terms, keys, lsb in (('gyro', self.gyro_terms, GYRO_KEYS,
                                          self.gyro_lsb_rad_s),
                                         ('accel', self.accel_terms, ACCEL_KEYS,
                                          self.accel_lsb_m_s2)):
            for axis, t in zip('xyz', terms):
                n_adc = gen.quantisation_random_walk(lsb)
                out[f'{prefix}_{axis}'] = dict(zip(keys, (
                    t.quantization, math.hypot(t.random_walk * alias, n_adc),
                    t.bias_instability,
                    t.rate_random_walk, t.rate_ramp)))
        return out

    def _faults(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """(first index of each swapped pair, indices published twice), disjoint, seeded."""
        rng = np.random.default_rng(np.random.SeedSequence([self.seed, 7]))
        n = self.n_samples
        picks = np.sort(rng.choice(np.arange(100, n - 100, 4), self.swapped_pairs
                                   + self.duplicates, replace=False))
        order = rng.permutation(len(picks))
        swapped = np.sort(picks[order[:self.swapped_pairs]])
        duplicated = np.sort(picks[order[self.swapped_pairs:]]) + 2
        return swapped.astype(np.int64), duplicated.astype(np.int64)

    def messages(self) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log time ns, CDR) in publication order.

        (topic, log time ns, CDR) in publication order; log time = the stamp of the slot
        a message went out in (a swapped message keeps its slot's).
        """
        template, accel_offset = imu_template(self.frame_id)
        accel_at = template.value_at + accel_offset
        gen = self.generator()
        swapped, duplicated = (set(a.tolist()) for a in self._faults())
        n, done = self.n_samples, 0
        held: tuple[int, bytes] | None = None  # the first of a swapped pair (log time, CDR)
        while done < n:
            k = min(CHUNK, n - done)
            t, gyro, accel = gen.chunk(k)
            rows = template.rows(t, gyro)
            rows[:, accel_at:accel_at + 24] = np.ascontiguousarray(
                accel.astype('<f8')).view(np.uint8).reshape(k, 24)
            for i in range(k):
                t_ns, data = int(t[i]), rows[i].tobytes()
                if held is not None:  # second of the pair goes out first, in the first's slot
                    yield self.topic, held[0], data
                    yield self.topic, t_ns, held[1]
                    held = None
                elif done + i in swapped:
                    held = (t_ns, data)
                else:
                    yield self.topic, t_ns, data
                    if done + i in duplicated:
                        yield self.topic, t_ns, data
            done += k

    def expected_counts(self) -> dict[str, int]:
        """What the ordering stage must count."""
        return {'received': self.n_samples + self.duplicates,
                'out_of_order': self.swapped_pairs, 'duplicate': self.duplicates, 'late': 0,
                'restarts': 0, 'gaps': 0, 'segments': 1}

    def bench_settings(self) -> dict[str, Any]:
        """What the operator knows: the topic (no scale factor needed for an Imu)."""
        return {'topic': self.topic}

    def expected_results(self) -> dict[str, Any]:
        """Truth, coverage factor, terms that must resolve, counts, Kalibr keys."""
        return {
            'scenario': self.name, 'topic': self.topic, 'kind': 'imu',
            'messages': self.n_samples + self.duplicates,
            'truth': self.truth(), 'coverage_factor': self.coverage_factor,
            'coverage_note': COVERAGE_NOTE,
            'must_resolve': {
                **{f'gyro_{a}': list(self.must_resolve_gyro) for a in 'xyz'},
                **{f'accel_{a}': [ACCEL_KEYS[1]] for a in 'xyz'}},
            'counts': self.expected_counts(),
            'kalibr': {'rostopic': self.topic, 'update_rate_hz': self.sample_rate_hz},
        }

    def description_dict(self) -> dict[str, Any]:
        """Stored in the bag: parameters, seed, faults, settings, truth.

        Stored in the bag: generator parameters, seed, faults, bench settings, truth (the
        decimation filter only where there is one).
        """
        band = ({'decimation': self.decimation, 'lowpass_cutoff_hz': self.lowpass_cutoff_hz,
                 'lowpass': 'Butterworth, order 2, at decimation × sample_rate_hz'}
                if self.decimation > 1 or self.lowpass_cutoff_hz else {})
        return {
            **band,
            'name': self.name, 'description': self.description, 'kind': 'imu',
            'sample_rate_hz': self.sample_rate_hz, 'duration_s': self.duration_s,
            'gyro_terms': [_terms_dict(t) for t in self.gyro_terms],
            'accel_terms': [_terms_dict(t) for t in self.accel_terms],
            'gyro_lsb_rad_s': self.gyro_lsb_rad_s, 'accel_lsb_m_s2': self.accel_lsb_m_s2,
            'stamp_jitter_s': self.stamp_jitter_s, 'swapped_pairs': self.swapped_pairs,
            'duplicates': self.duplicates, 'frame_id': self.frame_id, 'seed': self.seed,
            'bench': self.bench_settings(), 'truth': self.truth(),
        }


@dataclass(frozen=True, slots=True)
class RlgBagScenario:
    """A dithered RLG at rest recorded to a bag (see the module docstring).

    Attributes:
        name, description: bag name and one sentence.
        terms: the gyro's rate noise (rad/s units) and bias.
        scale_factor_rad_per_pulse: K, rad/pulse (stored as the bench setting).
        sample_rate_hz, duration_s: pulse sampling, Hz; record length, s.
        latitude_deg: the site (vertical sense axis: Earth rate · sin latitude).
        dither_amplitude_rad, dither_frequency_hz: the mechanical dither (stripped).
        gap_s: (start, end) of samples lost, s from the start ((0, 0): none).
        seed: generator seed.
    """

    name: str
    description: str
    terms: NoiseTerms
    scale_factor_rad_per_pulse: float = 4.0860157e-6
    sample_rate_hz: float = 500.0
    duration_s: float = 280.0
    latitude_deg: float = 45.0
    dither_amplitude_rad: float = 120.0 * DEG / 3600.0
    dither_frequency_hz: float = 413.7
    gap_s: tuple[float, float] = (240.0, 242.0)
    seed: int = 12
    coverage_factor: float = 3.5
    topic: str = GYRO_PULSES
    spikes: int = 0
    """One-sample bit errors in the count read-out: the count of that sample is off by
    ±2^b pulses (b from ``spike_bits``), the next one right again (METHODS §E.6)."""
    spike_bits: tuple[int, int] = (5, 10)
    """The flipped bit b is drawn from b_lo ≤ b < b_hi."""

    @property
    def n_samples(self) -> int:
        """Samples generated (before the gap is cut out)."""
        return int(round(self.duration_s * self.sample_rate_hz))

    def spike_errors(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """Sample indices (sorted, none at the ends or next to another) and count errors."""
        if not self.spikes:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        rng = np.random.default_rng(self.seed + 7919)
        pool = np.arange(2, self.n_samples - 2, 3, dtype=np.int64)  # never adjacent
        at = np.sort(rng.choice(pool, self.spikes, replace=False))
        bits = rng.integers(self.spike_bits[0], self.spike_bits[1], self.spikes)
        sign = rng.choice(np.array([-1.0, 1.0]), self.spikes)
        return at, sign * 2.0 ** bits

    def generator(self) -> RlgPulseGenerator:
        """A fresh generator of this gyro."""
        return RlgPulseGenerator(
            self.terms, scale_factor_rad_per_pulse=self.scale_factor_rad_per_pulse,
            sample_rate_hz=self.sample_rate_hz, seed=self.seed, start_ns=START_NS,
            rotation_rate_rad_s=EARTH_RATE_RAD_S * math.sin(self.latitude_deg * DEG),
            dither_amplitude_rad=self.dither_amplitude_rad,
            dither_frequency_hz=self.dither_frequency_hz, dither_stripped=True)

    def truth(self) -> dict[str, dict[str, float]]:
        """The noise terms of the pulse record.

        The noise terms of the pulse record: Q = K/√12 (dither-randomised rounding to
        whole pulses), the rate noise's N, B, K, R.
        """
        t = self.terms
        return {'gyro': dict(zip(GYRO_KEYS, (
            self.generator().quantization_noise_rad(), t.random_walk, t.bias_instability,
            t.rate_random_walk, t.rate_ramp)))}

    def _kept(self, t: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
        lo, hi = (START_NS + int(round(s * NS_PER_S)) for s in self.gap_s)
        return (t < lo) | (t >= hi)

    def messages(self) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log time ns, CDR) in publication order."""
        template = pulse_template()
        gen = self.generator()
        at, error = self.spike_errors()
        n, done = self.n_samples, 0
        while done < n:
            k = min(CHUNK, n - done)
            t, counts = gen.chunk(k)
            here = (at >= done) & (at < done + k)
            counts[at[here] - done] += error[here]
            keep = self._kept(t)
            t, counts = t[keep], counts[keep]
            rows = template.rows(t, counts)
            for i in range(len(t)):
                yield self.topic, int(t[i]), rows[i].tobytes()
            done += k

    def messages_count(self) -> int:
        """Messages in the bag (the gap's samples are lost)."""
        t = START_NS + np.arange(self.n_samples, dtype=np.int64) * int(
            round(NS_PER_S / self.sample_rate_hz))
        return int(np.count_nonzero(self._kept(t)))

    def bench_settings(self) -> dict[str, Any]:
        """What the operator knows: the topic, K, the site."""
        return {'topic': self.topic, 'scale_factor_rad_per_pulse': self.scale_factor_rad_per_pulse,
                'latitude_deg': self.latitude_deg}

    def expected_results(self) -> dict[str, Any]:
        """Truth, coverage factor, terms that must resolve, counts."""
        return {
            'scenario': self.name, 'topic': self.topic, 'kind': 'pulses',
            'messages': self.messages_count(), 'truth': self.truth(),
            'coverage_factor': self.coverage_factor, 'coverage_note': COVERAGE_NOTE,
            'must_resolve': {'gyro': [GYRO_KEYS[0], GYRO_KEYS[1]]},
            'counts': {'received': self.messages_count(), 'out_of_order': 0, 'duplicate': 0,
                       'late': 0, 'restarts': 0, **self._gap_counts()},
            **self._spike_record(),
        }

    def _gap_counts(self) -> dict[str, int]:
        inside = self.gap_s[0] < min(self.gap_s[1], self.duration_s)
        return {'gaps': 1 if inside else 0, 'segments': 2 if inside else 1}

    def _spike_record(self) -> dict[str, Any]:
        """The bit errors injected: each gives two increments beyond k (up, then back)."""
        if not self.spikes:
            return {}
        at, error = self.spike_errors()
        period = int(round(NS_PER_S / self.sample_rate_hz))
        stamps = [(START_NS + int(i) * period) / NS_PER_S for i in at]
        return {'settings': {'outliers': 'remove'},
                'spikes': {'bit_errors': int(len(at)), 'increments': 2 * int(len(at)),
                           'pulses': [float(e) for e in error], 'stamps_s': stamps}}

    def description_dict(self) -> dict[str, Any]:
        """Stored in the bag: generator parameters, seed, gap, bench settings, truth."""
        description = self.description
        if self.gap_s[1] > self.gap_s[0] >= self.duration_s:  # a shortened run: no gap
            description += (f' The {self.gap_s[0]:g}–{self.gap_s[1]:g} s gap lies beyond this '
                            f'{self.duration_s:g} s record: it has none.')
        return {
            'name': self.name, 'description': description, 'kind': 'pulses',
            'terms': _terms_dict(self.terms), 'sample_rate_hz': self.sample_rate_hz,
            'duration_s': self.duration_s,
            'dither_amplitude_rad': self.dither_amplitude_rad,
            'dither_frequency_hz': self.dither_frequency_hz, 'dither_stripped': True,
            'gap_s': list(self.gap_s), 'seed': self.seed,
            **({'spikes': self.spikes, 'spike_bits': list(self.spike_bits)}
               if self.spikes else {}),
            'bench': self.bench_settings(), 'truth': self.truth(),
        }


@dataclass(frozen=True, slots=True)
class RlgTurningBagScenario:
    """A rate-biased RLG on a rate table turning at a constant rate (see the module docstring).

    Attributes:
        name, description: bag name and one sentence.
        terms: the gyro's rate noise (rad/s units) and bias.
        scale_factor_rad_per_pulse: K, rad/pulse (stored as the bench setting).
        sample_rate_hz, table_rate_hz: pulse sampling and table joint states, Hz.
        rate_deg_s: the table's constant rate, °/s (+ then −: one reversal).
        cruise_s: time at each constant rate, s.
        acceleration_deg_s2: the reversal's angular acceleration, °/s².
        encoder_counts_per_rev: the table encoder's counts per revolution.
        latitude_deg: the site (sense axis along the vertical table axis).
        seed: generator seed.
    """

    name: str
    description: str
    terms: NoiseTerms
    scale_factor_rad_per_pulse: float = 4.0860157e-6
    sample_rate_hz: float = 250.0
    table_rate_hz: float = 50.0
    rate_deg_s: float = 37.9
    cruise_s: float = 100.0
    acceleration_deg_s2: float = 100.0
    encoder_counts_per_rev: int = 2**23
    latitude_deg: float = 45.0
    seed: int = 14
    coverage_factor: float = 3.5
    topic: str = GYRO_PULSES

    @property
    def reversal_s(self) -> tuple[float, float]:
        """(start, end) of the reversal, s from the start."""
        return self.cruise_s, self.cruise_s + 2.0 * self.rate_deg_s / self.acceleration_deg_s2

    @property
    def duration_s(self) -> float:
        """Record length, s."""
        return self.reversal_s[1] + self.cruise_s

    def profile(self) -> Any:
        """The table's motion: +rate, a reversal at constant deceleration, −rate."""
        from sim_nodes.motion import MotionProfile

        a = self.acceleration_deg_s2 * DEG
        lo, hi = self.reversal_s
        return MotionProfile([lo, hi - lo, self.cruise_s], [0.0, -a, 0.0],
                             initial_rate_rad_s=self.rate_deg_s * DEG)

    def generator(self) -> RlgPulseGenerator:
        """A fresh generator of this gyro, turned by the table."""
        profile = self.profile()
        return RlgPulseGenerator(
            self.terms, scale_factor_rad_per_pulse=self.scale_factor_rad_per_pulse,
            sample_rate_hz=self.sample_rate_hz, seed=self.seed, start_ns=START_NS,
            rotation_rate_rad_s=EARTH_RATE_RAD_S * math.sin(self.latitude_deg * DEG),
            table_angle=profile.angle_rad)

    @property
    def n_samples(self) -> int:
        """Pulse samples."""
        return int(round(self.duration_s * self.sample_rate_hz)) + 1

    @property
    def n_table_states(self) -> int:
        """Table joint states."""
        return int(round(self.duration_s * self.table_rate_hz)) + 1

    def truth(self) -> dict[str, dict[str, float]]:
        """The noise terms of the pulse record.

        Q = K/√12 (the rotation moves the sub-pulse phase), the rate noise's N, B, K, R.
        """
        t = self.terms
        return {'gyro': dict(zip(GYRO_KEYS, (
            self.generator().quantization_noise_rad(), t.random_walk, t.bias_instability,
            t.rate_random_walk, t.rate_ramp)))}

    def table_states(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                                    npt.NDArray[np.float64]]:
        """Stamps, encoder angle (quantised, rad) and the controller's rate (rad/s)."""
        profile = self.profile()
        period = int(round(NS_PER_S / self.table_rate_hz))
        t = START_NS + period * np.arange(self.n_table_states, dtype=np.int64)
        ts = (t - START_NS) / NS_PER_S
        res = 2.0 * math.pi / self.encoder_counts_per_rev
        return t, np.round(profile.angle_rad(ts) / res) * res, profile.rate_rad_s(ts)

    def messages(self) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log time ns, CDR) in stamp order (the table's state first at a tie)."""
        from gyro_calib.bagio import ContractMessages

        cdr = ContractMessages()
        template = pulse_template()
        gen = self.generator()
        t_table, angle, rate = self.table_states()
        table = [(int(t), 0, TABLE_TOPIC, cdr.joint_state(int(t), 'rate_table', float(a),
                                                          float(r)))
                 for t, a, r in zip(t_table, angle, rate)]
        k = 0
        n, done = self.n_samples, 0
        while done < n:
            m = min(CHUNK, n - done)
            t, counts = gen.chunk(m)
            rows = template.rows(t, counts)
            for i in range(m):
                while k < len(table) and table[k][0] <= int(t[i]):
                    yield table[k][2], table[k][0], table[k][3]
                    k += 1
                yield self.topic, int(t[i]), rows[i].tobytes()
            done += m
        for entry in table[k:]:
            yield entry[2], entry[0], entry[3]

    def messages_count(self) -> int:
        """Messages in the bag (pulses and table states)."""
        return self.n_samples + self.n_table_states

    def bench_settings(self) -> dict[str, Any]:
        """What the operator knows: the topic, K, the site."""
        return {'topic': self.topic, 'scale_factor_rad_per_pulse': self.scale_factor_rad_per_pulse,
                'latitude_deg': self.latitude_deg}

    def expected_results(self) -> dict[str, Any]:
        """Truth, coverage factor, terms that must resolve, counts, the table's motion."""
        lo, hi = self.reversal_s
        return {
            'scenario': self.name, 'topic': self.topic, 'kind': 'pulses',
            'messages': self.messages_count(), 'truth': self.truth(),
            'coverage_factor': self.coverage_factor, 'coverage_note': COVERAGE_NOTE,
            'must_resolve': {'gyro': [GYRO_KEYS[0], GYRO_KEYS[1]]},
            'counts': {'received': self.n_samples, 'out_of_order': 0, 'duplicate': 0,
                       'late': 0, 'restarts': 0, 'gaps': 0, 'segments': 2},
            'table': {'steady_rates_deg_s': [self.rate_deg_s, -self.rate_deg_s],
                      'reversal_s': [lo, hi], 'state_interval_s': 1.0 / self.table_rate_hz,
                      'note': 'the gyro samples strictly inside the reversal are left out, and '
                              'at most two table-state intervals more on each side'},
        }

    def description_dict(self) -> dict[str, Any]:
        """Stored in the bag: generator and table parameters, seed, bench settings, truth."""
        lo, hi = self.reversal_s
        return {
            'name': self.name, 'description': self.description, 'kind': 'pulses',
            'terms': _terms_dict(self.terms), 'sample_rate_hz': self.sample_rate_hz,
            'duration_s': self.duration_s, 'table_rate_hz': self.table_rate_hz,
            'rate_deg_s': self.rate_deg_s, 'cruise_s': self.cruise_s,
            'acceleration_deg_s2': self.acceleration_deg_s2, 'reversal_s': [lo, hi],
            'encoder_counts_per_rev': self.encoder_counts_per_rev, 'seed': self.seed,
            'bench': self.bench_settings(), 'truth': self.truth(),
        }


def _mems_gyro(n_deg_rt_h: float, b_deg_h: float, k_rad_s_rt_s: float,
               bias_rad_s: float) -> NoiseTerms:
    return NoiseTerms(random_walk=n_deg_rt_h * DEG / 60.0, bias_instability=b_deg_h * DEG / 3600,
                      rate_random_walk=k_rad_s_rt_s, bias=bias_rad_s)


def _mems_accel(n_ug_rt_hz: float, b_ug: float, k_m_s2_rt_s: float,
                bias_m_s2: float) -> NoiseTerms:
    return NoiseTerms(random_walk=n_ug_rt_hz * MICRO_G, bias_instability=b_ug * MICRO_G,
                      rate_random_walk=k_m_s2_rt_s, bias=bias_m_s2)


Scenario = ImuBagScenario | RlgBagScenario | RlgTurningBagScenario
SCENARIOS: dict[str, Scenario] = {s.name: s for s in (
    ImuBagScenario(
        'noise_imu_static', 'A consumer MEMS IMU lying still (sensor_msgs/Imu, 200 Hz, '
        '500 s, 16-bit output, jittered host stamps, 60 swapped and 25 repeated messages): '
        'N and B of every gyro axis resolve.',
        gyro_terms=(_mems_gyro(0.30, 12.0, 2.0e-6, 0.002), _mems_gyro(0.33, 13.0, 2.2e-6, -0.003),
                    _mems_gyro(0.27, 11.0, 1.8e-6, 0.001)),
        accel_terms=(_mems_accel(80.0, 60.0, 1.0e-5, 0.05),
                     _mems_accel(85.0, 55.0, 1.1e-5, -0.08),
                     _mems_accel(100.0, 70.0, 1.2e-5, 0.12))),
    ImuBagScenario(
        'noise_imu_band_limited', 'A MEMS IMU lying still whose own decimation filter bends '
        'the short-τ curve (100 Hz output of a 400 Hz core through a 2nd-order Butterworth '
        'at 20 Hz; ±250 °/s 16-bit LSB; 600 s): B of every gyro axis resolves, with its τ range.',
        gyro_terms=(_mems_gyro(0.17, 11.0, 0.0, 0.004), _mems_gyro(0.18, 12.0, 0.0, -0.002),
                    _mems_gyro(0.16, 10.0, 0.0, 0.001)),
        accel_terms=(_mems_accel(70.0, 40.0, 0.0, 0.05), _mems_accel(75.0, 45.0, 0.0, -0.08),
                     _mems_accel(90.0, 50.0, 0.0, 0.12)),
        sample_rate_hz=100.0, duration_s=600.0, swapped_pairs=0, duplicates=0, seed=13,
        decimation=4, lowpass_cutoff_hz=20.0, must_resolve_gyro=(GYRO_KEYS[2],)),
    RlgBagScenario(
        'noise_rlg_static', 'A dithered RLG at rest (/gyro/pulses, 500 Hz, 280 s, dither '
        'stripped, a 2 s gap): Q = K/√12 and N resolve; a locked-in RLG would show neither.',
        NoiseTerms(random_walk=0.003 * DEG / 60.0, bias_instability=0.003 * DEG / 3600.0,
                   bias=0.005 * DEG / 3600.0)),
    RlgBagScenario(
        'noise_rlg_spikes', 'A dithered RLG at rest whose count read-out has 40 one-sample '
        'bit errors (±2^5 … 2^9 pulses; /gyro/pulses, 500 Hz, 120 s, no gap): gyro-calib '
        'noise finds the 80 increments beyond 8 robust σ, says what they do to the terms, and '
        'with outliers = remove gives Q and N of the gyro.',
        NoiseTerms(random_walk=0.003 * DEG / 60.0, bias_instability=0.003 * DEG / 3600.0,
                   bias=0.005 * DEG / 3600.0), duration_s=120.0, gap_s=(0.0, 0.0),
        seed=30, spikes=40),
    RlgTurningBagScenario(
        'noise_rlg_turning', 'A rate-biased RLG on a rate table turning at 37.9 °/s (no '
        'dither: the rotation keeps it out of lock-in; /gyro/pulses 250 Hz, '
        '/rate_table/joint_states 50 Hz), 100 s each way with one reversal: the reversal is '
        'left out, Q = K/√12 and N resolve from the two steady segments.',
        NoiseTerms(random_walk=0.01 * DEG / 60.0, bias=0.005 * DEG / 3600.0)),
)}
"""The committed noise scenarios (``bags/<name>``)."""


def write_scenario_bag(scenario: Scenario | str,
                       path: str | Path) -> Path:
    """Simulate ``scenario`` and write its bag at ``path`` (which must not exist)."""
    from gyro_calib.bagio import BagMessage, write_bag

    scenario = named(scenario, SCENARIOS)
    msgtype = IMU if isinstance(scenario, ImuBagScenario) else JOINT_STATE
    types = {scenario.topic: msgtype}
    if isinstance(scenario, RlgTurningBagScenario):
        types[TABLE_TOPIC] = JOINT_STATE
    write_bag(path, (BagMessage(topic, log_ns, cdr) for topic, log_ns, cdr
                     in scenario.messages()),
              types=types, scenario=scenario.description_dict())
    return Path(path)


write_scenario_files = scenario_files.files_writer(
    SCENARIOS, write_scenario_bag, source='sim_nodes/noise/bag_scenarios.py',
    what='noise characterisation')
"""Write ``<name>/`` (the bag) and ``<name>.expected.yaml`` in a directory."""


__all__ = ['ImuBagScenario', 'RlgBagScenario', 'RlgTurningBagScenario', 'SCENARIOS',
           'write_scenario_bag',
           'write_scenario_files']
