"""Specification of the noise method behind the front door.

Specification of the noise method behind the front door: NoiseSession's inputs, flattened
hand-off keys, snapshots (running results), JSON shape, summary, scale factors, input choice.

The records are written here from the physics (white rate noise, integrated to pulses for
an RLG), not by ``sim_nodes``.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gyro_calib.bagio import MissingTopicError, SampleBatch, WrongMessageTypeError
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.errors import ConfigError
from gyro_calib.handoff import Provenance, method_calibration, write_calibration
from gyro_calib.noise.keys import HANDOFF_KEYS, IMU_AXES, IMU_KEYS, SINGLE_GYRO_KEYS, imu_key
from gyro_calib.noise.session import (
    GYRO_PULSES,
    IMU,
    JOINT_STATE,
    NoiseSession,
    NoNoiseDataError,
    check_scale_factor,
    fog_scale_factor,
    pulse_scale_factor,
    select_input,
)
from gyro_calib.registry import METHODS, handoff_schema
from gyro_calib.session import CalibrationOptions

START_NS = 1_700_000_000_000_000_000
PERIOD_NS = 10_000_000  # 100 Hz
K_PULSE = 4.0e-6
N_GYRO = 3e-4  # rad/√s
N_ACCEL = 2e-3  # m/s/√s


def imu_columns(topic: str, t_ns: np.ndarray, gyro: np.ndarray,
                accel: np.ndarray) -> TopicColumns:
    return TopicColumns(topic, IMU, t_ns.copy(), t_ns,
                        FrameIds(np.zeros(len(t_ns), dtype=np.int32), ('imu',)),
                        {'angular_velocity_rad_s': gyro, 'linear_acceleration_m_s2': accel})


def joint_columns(topic: str, t_ns: np.ndarray, position: np.ndarray) -> TopicColumns:
    return TopicColumns(topic, JOINT_STATE, t_ns.copy(), t_ns,
                        FrameIds(np.zeros(len(t_ns), dtype=np.int32), ('gyro',)),
                        {'position': position, 'velocity': np.full(len(t_ns), np.nan)})


def batch(*columns: TopicColumns) -> SampleBatch:
    return SampleBatch({c.topic: c for c in columns}, sum(len(c) for c in columns),
                       max(int(c.log_time_ns.max()) for c in columns))


def imu_record(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A static IMU: white rate noise of density N on every axis (per sample N/√τ0)."""
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    tau0 = PERIOD_NS / 1e9
    t = START_NS + PERIOD_NS * np.arange(n, dtype=np.int64)
    gyro = rng.normal(0.0, N_GYRO / math.sqrt(tau0), (n, 3))
    accel = rng.normal(0.0, N_ACCEL / math.sqrt(tau0), (n, 3)) + (0.0, 0.0, 9.80665)
    return t, gyro, accel


def pulse_record(n: int, seed: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """An RLG turning slowly: angle = ∫(ω + white noise), counts = angle / K (not rounded)."""
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    tau0 = PERIOD_NS / 1e9
    t = START_NS + PERIOD_NS * np.arange(n, dtype=np.int64)
    rate = 1e-3 + rng.normal(0.0, N_GYRO / math.sqrt(tau0), n)
    return t, np.cumsum(rate * tau0) / K_PULSE


@pytest.fixture(scope='module')
def imu_session() -> NoiseSession:
    s = NoiseSession(CalibrationOptions(topic='/imu/data'))
    t, g, a = imu_record(20_000)
    for lo in range(0, len(t), 7000):
        s.feed(batch(imu_columns('/imu/data', t[lo:lo + 7000], g[lo:lo + 7000],
                                 a[lo:lo + 7000])))
        s.process()
    s.process(flush=True)
    return s


def test_imu_keys_name_every_axis_and_term_with_its_own_unit() -> None:
    assert len(IMU_KEYS) == 30 and len(SINGLE_GYRO_KEYS) == 5
    names = {k.name for k in IMU_KEYS}
    assert 'imu_gyro_x_angle_random_walk_rad_per_sqrt_s' in names
    assert 'imu_accel_z_velocity_random_walk_m_s_per_sqrt_s' in names
    assert 'imu_accel_y_bias_instability_m_s2' in names
    assert not any(n.startswith('imu_accel') and 'rad' in n for n in names)
    assert all(k.method == 'noise' and k.kind == 'nonnegative' for k in HANDOFF_KEYS)
    assert set(METHODS['noise'].handoff_keys()) == set(HANDOFF_KEYS)
    assert all(k.name in handoff_schema() for k in HANDOFF_KEYS)


def test_imu_session_flattens_terms_to_per_axis_handoff_keys(imu_session: NoiseSession) -> None:
    results = imu_session.results()
    assert imu_key('gyro_y', 'angle_random_walk_rad_per_sqrt_s') in results
    for axis in IMU_AXES:
        key = imu_key(axis, 'angle_random_walk_rad_per_sqrt_s' if axis.startswith('gyro')
                      else 'velocity_random_walk_m_s_per_sqrt_s')
        truth = N_GYRO if axis.startswith('gyro') else N_ACCEL
        est = results[key]
        assert abs(est.value - truth) < 4 * est.std_uncertainty, (key, est)
    schema = handoff_schema()
    assert set(results) | set(imu_session.missing()) == {k.name for k in IMU_KEYS}
    assert not set(results) & set(imu_session.missing())
    assert all(schema[k].method == 'noise' for k in results)
    record = imu_session.handoff('test.bag', gyro_id='imu-7')
    assert record is not None and record.gyro_id == 'imu-7'
    assert set(record.missing) == set(imu_session.missing())


def test_json_section_has_exactly_the_issue_shape(imu_session: NoiseSession) -> None:
    section = imu_session.json_section()
    assert {'axes', 'results', 'missing', 'rejections'} <= set(section)
    assert list(section['axes']) == list(IMU_AXES)
    for axis, a in section['axes'].items():
        assert {'tau_s', 'adev', 'adev_std', 'results'} <= set(a)
        assert {'mdev', 'hdev', 'totdev', 'mdev_std', 'hdev_std', 'totdev_std', 'fit'} <= set(a)
        assert len(a['tau_s']) == len(a['adev']) == len(a['adev_std']) > 10
        for key, r in a['results'].items():
            assert set(r) == {'value', 'std', 'n'}
            assert imu_session.results()[imu_key(axis, key)].value == r['value']


def test_summary_rows_give_si_and_the_quoted_units(imu_session: NoiseSession) -> None:
    rows = {q: (v, s, n) for q, v, s, n in imu_session.summary_rows()}
    value, std, n = rows['gyro_x: angle random walk N']
    assert 'rad/√s' in value and '°/√h' in value and '°/√h' in std and n == '20000'
    si, quoted = (float(p.split()[0]) for p in value.split(' = '))
    assert quoted == pytest.approx(si * 180 / math.pi * 60, rel=1e-3)
    assert any(q.startswith('accel_z: velocity random walk N') for q in rows)
    lines = imu_session.summary_lines()
    assert any('0 re-sorted (out of order), 0 duplicate stamps dropped' in ln for ln in lines)
    assert 'known to ±' in imu_session.limiting()


def test_pulse_session_uses_the_plain_keys_and_names_its_scale_factor() -> None:
    s = NoiseSession(CalibrationOptions(scale_factor_rad_per_pulse=K_PULSE))
    assert s.topics() == {GYRO_PULSES: JOINT_STATE, '/fog/output': JOINT_STATE,
                          '/rate_table/joint_states': JOINT_STATE,  # optional: motion gate
                          '/position_table/joint_states': JOINT_STATE}
    t, counts = pulse_record(20_000)
    s.feed(batch(joint_columns(GYRO_PULSES, t, counts)))
    s.process(flush=True)
    results = s.results()
    n = results['angle_random_walk_rad_per_sqrt_s']
    assert abs(n.value - N_GYRO) < 4 * n.std_uncertainty
    assert set(results) | set(s.missing()) == {k.name for k in SINGLE_GYRO_KEYS}
    assert 'K = 4e-06 rad/pulse from --scale-factor-rad-per-pulse' in s.summary_lines()[0]
    assert list(s.json_section()['axes']) == ['gyro']
    with pytest.raises(ConfigError, match='single-axis gyro'):
        s.kalibr_text()


def test_both_gyro_streams_without_a_topic_is_refused_naming_the_choice() -> None:
    s = NoiseSession(CalibrationOptions(scale_factor_rad_per_pulse=K_PULSE,
                                        scale_factor_counts_per_rad=1e6))
    t, counts = pulse_record(500)
    with pytest.raises(ConfigError, match='choose one with --topic'):
        s.feed(batch(joint_columns(GYRO_PULSES, t, counts),
                     joint_columns('/fog/output', t, counts)))


def test_running_results_before_the_end_equal_the_finished_result_of_the_same_samples(
        ) -> None:
    t, g, a = imu_record(12_000, seed=5)
    live = NoiseSession(CalibrationOptions(topic='/imu/data'))
    live.auto_refresh = False
    live.feed(batch(imu_columns('/imu/data', t[:9000], g[:9000], a[:9000])))
    live.process()
    assert live.results() == {} and 'no running result yet' in next(iter(
        live.missing().values()))
    assert live.refresh() and not live.refresh()  # nothing new: no second snapshot
    done = NoiseSession(CalibrationOptions(topic='/imu/data'))
    done.feed(batch(imu_columns('/imu/data', t[:9000], g[:9000], a[:9000])))
    done.process(flush=True)
    assert live.results() == done.results()
    assert live.json_section() == done.json_section()
    live.feed(batch(imu_columns('/imu/data', t[9000:], g[9000:], a[9000:])))
    live.process()
    assert live.refresh()
    assert live.results() != done.results()


@functools.cache
def _reference_session() -> NoiseSession:
    t, g, a = imu_record(6000, seed=9)
    ref = NoiseSession(CalibrationOptions(topic='/imu/data'))
    ref.feed(batch(imu_columns('/imu/data', t, g, a)))
    ref.process(flush=True)
    return ref


@settings(max_examples=25, deadline=None)
@given(cuts=st.lists(st.integers(1, 5999), max_size=6, unique=True),
       swaps=st.lists(st.integers(10, 5980), max_size=20, unique=True),
       dups=st.lists(st.integers(10, 5990), max_size=10, unique=True))
def test_any_batching_swaps_and_duplicates_give_the_same_terms_and_counts(
        cuts: list[int], swaps: list[int], dups: list[int]) -> None:
    t, g, a = imu_record(6000, seed=9)
    order = np.arange(len(t))
    for i in swaps:  # neighbours arriving in swapped order
        order[i], order[i + 1] = order[i + 1], order[i]
    order = np.insert(order, np.searchsorted(np.arange(len(order)), sorted(dups)),
                      order[sorted(dups)])  # a message delivered twice
    ref = _reference_session()
    s = NoiseSession(CalibrationOptions(topic='/imu/data'))
    bounds = [0, *sorted(c for c in cuts if c < len(order)), len(order)]
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        if hi > lo:
            idx = order[lo:hi]
            s.feed(batch(imu_columns('/imu/data', t[idx], g[idx], a[idx])))
            s.process()
    s.process(flush=True)
    for axis in IMU_AXES:  # the same curves, hence the same fit and terms
        mine, theirs = s.calibrator.curve(axis), ref.calibrator.curve(axis)
        assert mine is not None and theirs is not None
        assert np.array_equal(mine.avar, theirs.avar) and np.array_equal(mine.tau_s,
                                                                          theirs.tau_s)
    (counts,) = s.calibrator.stream_counts()
    assert counts.received == 6000 + len(dups)
    assert counts.duplicate == len(dups) and counts.late == 0


def test_a_constant_channel_is_named_and_stops_the_run() -> None:
    s = NoiseSession(CalibrationOptions(scale_factor_rad_per_pulse=K_PULSE))
    t = START_NS + PERIOD_NS * np.arange(3000, dtype=np.int64)
    s.feed(batch(joint_columns(GYRO_PULSES, t, np.full(3000, 17.0))))
    s.process(flush=True)
    with pytest.raises(NoNoiseDataError, match='is constant.*locked-in|lock-in band'):
        s.check_measurable()
    assert s.results() == {}


def test_scale_factor_comes_from_the_flag_then_the_handoff_file_then_the_bag(
        tmp_path: Path) -> None:
    rbrlg = tmp_path / 'rlg.yaml'
    write_calibration(rbrlg, method_calibration('rbrlg', {
        'k_tilde_rad_per_pulse': 4.1e-6, 'k_tilde_rad_per_pulse_std': 1e-13},
        Provenance('bench', 1, 2)))
    fog = tmp_path / 'fog.yaml'
    write_calibration(fog, method_calibration('fog', {
        'fog_scale_factor_counts_per_rad': 2.5e6, 'fog_scale_factor_counts_per_rad_std': 3.0},
        Provenance('bench', 1, 2)))
    stored = {'bench': {'scale_factor_rad_per_pulse': 3.9e-6}}
    assert pulse_scale_factor(CalibrationOptions(scale_factor_rad_per_pulse=4.0e-6,
                                                 calibration_file=rbrlg)).value == 4.0e-6
    k = pulse_scale_factor(CalibrationOptions(calibration_file=rbrlg, scenario=stored))
    assert k.value == 4.1e-6 and k.source == f'k_tilde_rad_per_pulse in {rbrlg}'
    assert pulse_scale_factor(CalibrationOptions(scenario=stored)).value == 3.9e-6
    assert math.isnan(pulse_scale_factor(CalibrationOptions()).value)
    assert fog_scale_factor(CalibrationOptions(calibration_file=fog)).value == 2.5e6
    with pytest.raises(ConfigError, match='--scale-factor-rad-per-pulse K, or --calibration'):
        check_scale_factor(CalibrationOptions(topic=GYRO_PULSES, calibration_file=fog))
    with pytest.raises(ConfigError, match='positive'):
        pulse_scale_factor(CalibrationOptions(scale_factor_rad_per_pulse=-1.0))


PRESENT = {'/imu/data': (IMU, 100), '/imu/raw': (IMU, 100),
           '/rate_table/joint_states': (JOINT_STATE, 50), '/gyro/pulses': (JOINT_STATE, 0)}


@pytest.mark.parametrize('topic, error, text', [
    ('/imu/dta', MissingTopicError, 'no topic /imu/dta in the bag(s); they hold LISTING'),
    ('/rate_table/joint_states', WrongMessageTypeError,
     'has type sensor_msgs/msg/JointState, but gyro-calib noise reads sensor_msgs/msg/Imu'),
    ('/gyro/pulses', MissingTopicError, 'holds no message'),
    (None, ConfigError, 'several inputs to characterise (/imu/data, /imu/raw)'),
])
def test_select_input_refuses_what_it_cannot_read_naming_what_is_there(
        topic: str | None, error: type[Exception], text: str) -> None:
    with pytest.raises(error) as exc:
        select_input(PRESENT, CalibrationOptions(topic=topic), where='b', listing='LISTING')
    assert text in str(exc.value)


def test_select_input_takes_the_only_candidate_or_the_one_the_bag_stores() -> None:
    one = {'/imu/data': (IMU, 10), '/temp': ('sensor_msgs/msg/Temperature', 3)}
    assert select_input(one, CalibrationOptions(), where='b', listing='') == '/imu/data'
    stored = CalibrationOptions(scenario={'bench': {'topic': '/imu/raw'}})
    assert select_input(PRESENT, stored, where='b', listing='') == '/imu/raw'


def test_terms_not_resolved_carry_their_2sigma_upper_bound_as_a_handoff_key(
        imu_session: NoiseSession, tmp_path: Path) -> None:
    """Issue 27 §1: an unresolved term's 2σ bound is machine-readable, never the term itself."""
    from gyro_calib.handoff import load_calibration

    values = imu_session.handoff_values()
    missing = imu_session.missing()
    bounds = {k: v for k, v in values.items() if k.endswith('_upper_bound_2sigma')}
    k_key = imu_key('gyro_z', 'rate_random_walk_rad_per_s_sqrt_s')
    assert k_key in missing and k_key not in values  # white noise only: K not resolved
    assert values[k_key + '_upper_bound_2sigma'] > 0
    for key, bound in bounds.items():
        term = key.removesuffix('_upper_bound_2sigma')
        assert term in missing and term not in values and bound >= 0
    assert not any(k.removesuffix('_upper_bound_2sigma') in values for k in bounds)
    record = imu_session.handoff('test.bag', gyro_id='imu-7')
    assert record is not None
    path = write_calibration(tmp_path / 'h.yaml', record)
    loaded = load_calibration(path)
    assert loaded.values[k_key + '_upper_bound_2sigma'] == pytest.approx(
        values[k_key + '_upper_bound_2sigma'])
    assert k_key in loaded.missing


def test_a_later_run_that_resolves_a_term_drops_its_upper_bound_in_the_file(
        tmp_path: Path) -> None:
    """The bound follows its term in a merge: a resolved K replaces the old bound."""
    from gyro_calib.handoff import load_calibration, update_calibration

    n_key, k_key = 'angle_random_walk_rad_per_sqrt_s', 'rate_random_walk_rad_per_s_sqrt_s'
    bound = k_key + '_upper_bound_2sigma'
    first = method_calibration('noise', {n_key: 1e-4, n_key + '_std': 1e-6, bound: 3e-6},
                               Provenance('a.bag', 0, 10**12, {k_key: 'not resolved.'}))
    path = tmp_path / 'h.yaml'
    write_calibration(path, first)
    assert load_calibration(path).values[bound] == 3e-6
    second = method_calibration('noise', {n_key: 1e-4, n_key + '_std': 1e-6,
                                          k_key: 1e-6, k_key + '_std': 1e-7},
                                Provenance('b.bag', 2 * 10**12, 3 * 10**12, {}))
    update_calibration(path, second)
    values = load_calibration(path).values
    assert values[k_key] == 1e-6 and bound not in values
    # a later run that only bounds K leaves the file's measured K, without a bound beside it
    third = method_calibration('noise', {n_key: 1e-4, n_key + '_std': 1e-6, bound: 5e-6},
                               Provenance('c.bag', 4 * 10**12, 5 * 10**12,
                                          {k_key: 'not resolved.'}))
    update_calibration(path, third)
    values = load_calibration(path).values
    assert values[k_key] == 1e-6 and bound not in values
