"""Specification of the streaming NoiseCalibrator: inputs, outputs, bad input, chunking."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from gyro_calib.errors import ConfigError, StreamError
from gyro_calib.noise import (
    KalibrExportError,
    NoiseCalibrator,
    NoiseSettings,
    calibrate_noise,
    kalibr_imu_yaml,
    write_kalibr_imu_yaml,
)
from gyro_calib.noise.calibrator import IMU_AXES
from gyro_calib.noise.plots import plot_noise, plot_noise_figure
from sim_nodes.noise import FogOutputGenerator, ImuNoiseGenerator, NoiseTerms, RlgPulseGenerator

GYRO = NoiseTerms(random_walk=2e-4, rate_random_walk=2e-5)
ACCEL = NoiseTerms(random_walk=1e-3, rate_random_walk=1e-4)
K_PULSE = 4e-6


@pytest.fixture(scope='module')
def imu_record() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    gen = ImuNoiseGenerator((GYRO, GYRO.scaled(1.5), GYRO), ACCEL, sample_rate_hz=100.0, seed=4)
    return gen.chunk(60_000)


@pytest.fixture(scope='module')
def imu_cal(imu_record: tuple[np.ndarray, np.ndarray, np.ndarray]) -> NoiseCalibrator:
    return calibrate_noise(imu=imu_record)


def test_imu_results_are_keyed_by_axis_then_term(imu_cal: NoiseCalibrator) -> None:
    res = imu_cal.results()
    assert set(res) == set(IMU_AXES)
    n = res['gyro_y']['angle_random_walk_rad_per_sqrt_s']
    assert abs(n.value - 3e-4) < 3 * n.std_uncertainty
    assert n.n_used == 60_000  # rate samples: 60 000 drawn (not the 60 001 phase points)
    assert 'velocity_random_walk_m_s_per_sqrt_s' in res['accel_z']
    assert 'angle_random_walk_rad_per_sqrt_s' not in res['accel_z']


def test_missing_terms_carry_a_sentence_for_every_axis(imu_cal: NoiseCalibrator) -> None:
    missing = imu_cal.missing()
    assert set(missing) == set(IMU_AXES)
    for axis, reasons in missing.items():
        for key, reason in reasons.items():
            assert key not in imu_cal.results().get(axis, {})
            assert reason.endswith('.') and len(reason) > 40


def test_json_section_has_exactly_the_issue_shape(imu_cal: NoiseCalibrator) -> None:
    section = json.loads(json.dumps(imu_cal.json_section()))
    assert list(section) == ['axes']
    assert list(section['axes']) == list(IMU_AXES)
    for axis in section['axes'].values():
        assert list(axis)[:4] == ['tau_s', 'adev', 'adev_std', 'results']
        assert set(axis) == {'tau_s', 'adev', 'adev_std', 'results', 'm', 'clusters',
                             'noise_alpha', 'adev_edf', 'mdev', 'mdev_std', 'mdev_edf',
                             'hdev', 'hdev_std', 'hdev_edf', 'totdev', 'totdev_std',
                             'totdev_edf', 'fit', 'outliers'}
        n_tau = len(axis['tau_s'])
        assert n_tau > 10
        assert all(len(axis[k]) == n_tau for k in axis if k not in ('results', 'fit', 'outliers'))
        for entry in axis['results'].values():
            assert list(entry) == ['value', 'std', 'n']
    gx = section['axes']['gyro_x']
    assert gx['adev'][0] == pytest.approx(2e-4 / math.sqrt(gx['tau_s'][0]), rel=0.02)


def test_summary_table_quotes_si_and_practical_units(imu_cal: NoiseCalibrator) -> None:
    table = imu_cal.summary_table()
    assert '°/√h' in table and 'rad/√s' in table and 'm/s/√h' in table
    arw = imu_cal.results()['gyro_x']['angle_random_walk_rad_per_sqrt_s'].value
    assert f'{arw * 180 / math.pi * 60:.4g}' in table


def test_kalibr_yaml_takes_the_largest_axis_in_kalibr_units(imu_cal: NoiseCalibrator) -> None:
    data = yaml.safe_load(kalibr_imu_yaml(imu_cal, rostopic='/imu0'))
    assert set(data) == {'accelerometer_noise_density', 'accelerometer_random_walk',
                         'gyroscope_noise_density', 'gyroscope_random_walk', 'rostopic',
                         'update_rate'}
    res = imu_cal.results()
    arw = [res[a]['angle_random_walk_rad_per_sqrt_s'].value
           for a in ('gyro_x', 'gyro_y', 'gyro_z')]
    assert data['gyroscope_noise_density'] == pytest.approx(max(arw), rel=1e-6)
    assert data['gyroscope_noise_density'] == pytest.approx(3e-4, rel=0.05)  # gyro_y: 1.5×
    assert data['accelerometer_noise_density'] == pytest.approx(1e-3, rel=0.05)
    assert data['gyroscope_random_walk'] > 0 and data['accelerometer_random_walk'] > 0
    assert data['rostopic'] == '/imu0'
    assert data['update_rate'] == pytest.approx(100.0)


def test_kalibr_yaml_is_written_atomically_and_never_half(imu_cal: NoiseCalibrator,
                                                         tmp_path: Path) -> None:
    path = write_kalibr_imu_yaml(tmp_path / 'imu.yaml', imu_cal, rostopic='/imu0')
    assert path.is_absolute() and yaml.safe_load(path.read_text())['rostopic'] == '/imu0'
    single = calibrate_noise(pulses=RlgPulseGenerator(
        NoiseTerms(random_walk=1e-5), scale_factor_rad_per_pulse=K_PULSE,
        rotation_rate_rad_s=0.01).chunk(5000), settings=NoiseSettings(
            scale_factor_rad_per_pulse=K_PULSE))
    before = path.read_text()
    with pytest.raises(KalibrExportError, match='no gyro axes|Imu'):
        write_kalibr_imu_yaml(path, single, rostopic='/imu0')
    assert path.read_text() == before


def test_results_do_not_depend_on_chunking_or_on_add_versus_extend(
        imu_record: tuple[np.ndarray, np.ndarray, np.ndarray], imu_cal: NoiseCalibrator) -> None:
    t, g, a = imu_record
    chunked = NoiseCalibrator()
    cuts = np.sort(np.random.default_rng(1).integers(0, len(t), 30))
    for idx in np.split(np.arange(len(t)), cuts):
        chunked.extend_imu(t[idx], g[idx], a[idx])
        chunked.process()
    chunked.process(flush=True)
    assert chunked.json_section() == imu_cal.json_section()
    live = NoiseCalibrator()
    live.extend_imu(t[:-300], g[:-300], a[:-300])
    for i in range(len(t) - 300, len(t)):
        live.add_imu(int(t[i]), g[i], a[i])
    live.process(flush=True)
    assert live.json_section() == imu_cal.json_section()


def test_rlg_pulses_give_the_single_gyro_axis_in_rad() -> None:
    rlg = RlgPulseGenerator(NoiseTerms(random_walk=2e-5), scale_factor_rad_per_pulse=K_PULSE,
                            rotation_rate_rad_s=0.0123, sample_rate_hz=200.0, seed=6)
    cal = calibrate_noise(pulses=rlg.chunk(40_000),
                          settings=NoiseSettings(scale_factor_rad_per_pulse=K_PULSE))
    assert list(cal.json_section()['axes']) == ['gyro']
    n = cal.results()['gyro']['angle_random_walk_rad_per_sqrt_s']
    assert abs(n.value - 2e-5) < 3 * n.std_uncertainty
    entries = cal.handoff_entries()
    assert entries['angle_random_walk_rad_per_sqrt_s_std'] == n.std_uncertainty


def test_fog_output_counts_use_the_counts_per_rad_scale_factor() -> None:
    fog = FogOutputGenerator(NoiseTerms(random_walk=5e-6), scale_factor_counts_per_rad=1e7,
                             sample_rate_hz=200.0, seed=7)
    cal = calibrate_noise(fog_output=fog.chunk(40_000),
                          settings=NoiseSettings(fog_scale_factor_counts_per_rad=1e7))
    n = cal.results()['gyro']['angle_random_walk_rad_per_sqrt_s']
    assert abs(n.value - 5e-6) < 3 * n.std_uncertainty


def test_pulse_stream_without_scale_factor_gives_a_reason_and_no_number() -> None:
    rlg = RlgPulseGenerator(NoiseTerms(random_walk=2e-5), scale_factor_rad_per_pulse=K_PULSE,
                            rotation_rate_rad_s=0.01)
    cal = calibrate_noise(pulses=rlg.chunk(5000))
    assert cal.results() == {}
    assert cal.json_section() == {'axes': {}}
    reason = cal.missing()['gyro']['angle_random_walk_rad_per_sqrt_s']
    assert 'scale_factor_rad_per_pulse' in reason and '--scale-factor-rad-per-pulse' in reason


def test_locked_in_static_rlg_is_reported_as_constant_not_fitted() -> None:
    rlg = RlgPulseGenerator(NoiseTerms(random_walk=1e-6), scale_factor_rad_per_pulse=K_PULSE,
                            lock_in_rate_rad_s=1e-3)
    cal = calibrate_noise(pulses=rlg.chunk(5000),
                          settings=NoiseSettings(scale_factor_rad_per_pulse=K_PULSE))
    assert cal.results() == {}
    reason = cal.missing()['gyro']['quantization_noise_rad']
    assert 'constant' in reason and 'lock-in' in reason


def test_nan_filled_axis_is_reported_and_the_other_axes_are_kept(
        imu_record: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    t, g, a = imu_record
    g = g.copy()
    g[:, 1] = np.nan
    cal = calibrate_noise(imu=(t[:20_000], g[:20_000], a[:20_000]))
    assert 'gyro_y' not in cal.results() and 'gyro_x' in cal.results()
    assert 'non-finite' in cal.missing()['gyro_y']['angle_random_walk_rad_per_sqrt_s']
    assert 'gyro_y' not in cal.json_section()['axes']


def test_constant_axis_is_reported_as_constant() -> None:
    t = np.arange(2000, dtype=np.int64) * 10_000_000
    g = np.zeros((2000, 3))
    a = np.random.default_rng(0).standard_normal((2000, 3))
    cal = calibrate_noise(imu=(t, g, a))
    assert 'constant' in cal.missing()['gyro_z']['rate_random_walk_rad_per_s_sqrt_s']
    assert 'accel_z' in cal.results()


@pytest.mark.parametrize('n', [0, 5, 40])
def test_too_short_record_gives_a_reason_for_every_term(n: int) -> None:
    t = np.arange(n, dtype=np.int64) * 10_000_000
    rng = np.random.default_rng(1)
    cal = NoiseCalibrator()
    cal.extend_imu(t, rng.standard_normal((n, 3)), rng.standard_normal((n, 3)))
    cal.process(flush=True)
    assert cal.results() == {}
    if n:
        reasons = cal.missing()['gyro_x']
        assert len(reasons) == 5 and all('too short' in r for r in reasons.values())


def test_both_single_gyro_streams_in_one_calibrator_is_refused() -> None:
    cal = NoiseCalibrator()
    cal.extend_pulses(np.arange(3, dtype=np.int64), np.zeros(3))
    with pytest.raises(StreamError, match='one calibrator per gyro'):
        cal.extend_fog_output(np.arange(3, dtype=np.int64), np.zeros(3))


@pytest.mark.parametrize(('call', 'match'), [
    (lambda c: c.extend_imu(np.arange(3, dtype=np.int64), np.zeros((3, 2)), np.zeros((3, 3))),
     'shape'),
    (lambda c: c.extend_pulses(np.arange(3.0), np.zeros(3)), 'integer nanoseconds'),
    (lambda c: c.extend_pulses(np.arange(3, dtype=np.int64), np.zeros(4)), 'counts of shape'),
])
def test_malformed_arrays_are_refused_with_what_is_wrong(call: object, match: str) -> None:
    with pytest.raises(StreamError, match=match):
        call(NoiseCalibrator())  # type: ignore[operator]


@pytest.mark.parametrize(('field', 'value'), [
    ('scale_factor_rad_per_pulse', -1.0), ('gap_threshold_periods', 1.0),
    ('taus_per_octave', 0), ('overlap', 'some'), ('tree_min_averaging_factor', 100),
    ('max_tau_fraction', 0.9), ('restart_backstep_s', 0.5), ('min_segment_samples', 2),
    ('period_tolerance', 0.0), ('min_term_significance', 0.0), ('fit_max_tau_s', 0.0),
    ('total_deviation_points', 10), ('sample_rate_hz', -5.0), ('taus_per_octave', 2.0),
])
def test_invalid_settings_name_the_field(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=field):
        NoiseSettings(**{field: value})


def test_log_lines_report_gaps_reordering_and_terms(
        imu_record: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    t, g, a = (x[:20_000].copy() for x in imu_record)
    keep = np.ones(len(t), bool)
    keep[10_000:10_050] = False  # a 0.5 s gap
    order = np.arange(len(t))[keep]
    order[100:102] = order[101], order[100]  # one swapped pair
    order = np.insert(order, 200, order[199])  # one duplicate
    cal = NoiseCalibrator()
    cal.extend_imu(t[order], g[order], a[order])
    lines = cal.process(flush=True)
    text = '\n'.join(lines)
    assert 'gap of 0.51 s' in text
    assert '1 re-sorted out-of-order, 1 duplicate-stamp' in text
    assert any(line.startswith('gyro_x: angle random walk N = ') for line in cal.result_lines())
    assert len(cal.axis_result('gyro_x').curve.tau_s) > 5  # type: ignore[union-attr]


def test_partial_overlap_memory_is_bounded(imu_record: tuple[np.ndarray, ...]) -> None:
    from gyro_calib.noise.tree import TREE_BLOCK

    t, g, a = imu_record
    s = NoiseSettings(overlap='partial')
    for n in (len(t) // 8, len(t)):
        cal = NoiseCalibrator(s)
        cal.extend_imu(t[:n], g[:n], a[:n])
        # the tree grows one level per doubling
        levels = max(1, int(math.log2(n / TREE_BLOCK)) + 2)
        per_axis = (levels * (TREE_BLOCK + 4 * s.tree_min_averaging_factor)
                    + 2 * (2 * s.total_deviation_points + 1)
                    + 3 * s.outlier_block_samples) * 8  # the spike screen's block (§E.6)
        assert cal.sample_storage_bytes() <= 6 * per_axis


def test_plots_are_written_per_axis_and_as_one_figure(imu_cal: NoiseCalibrator,
                                                      tmp_path: Path) -> None:
    single = {'gyro_x': imu_cal.axis_result('gyro_x')}
    paths = plot_noise(single, tmp_path)
    assert [p.name for p in paths] == ['noise_adev_gyro_x.png']
    assert paths[0].stat().st_size > 10_000
    figure = plot_noise_figure(imu_cal, tmp_path / 'noise.png')
    assert figure.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_source_restart_splits_the_record_and_keeps_both_timelines() -> None:
    gen = ImuNoiseGenerator(GYRO, ACCEL, sample_rate_hz=100.0, seed=8)
    t, g, a = gen.chunk(6000)
    t2 = np.concatenate((t[:3000], t[3000:] - (t[3000] - t[0]) + 5_000_000))  # back to the start
    cal = NoiseCalibrator()
    cal.extend_imu(t2, g, a)
    lines = cal.process(flush=True)
    assert any('restarted' in line for line in lines)
    assert cal.ordering_stats()['imu'].restarts == 1
    curve = cal.curve('gyro_x')
    assert curve is not None and curve.n_segments == 2 and curve.n_samples == 6002


def test_samples_later_than_the_reorder_window_are_dropped_and_counted() -> None:
    gen = ImuNoiseGenerator(GYRO, ACCEL, sample_rate_hz=100.0, seed=9)
    t, g, a = gen.chunk(3000)
    order = np.arange(3000)
    order = np.concatenate((order[:1000], order[1010:1300], order[1000:1010], order[1300:]))
    cal = NoiseCalibrator(NoiseSettings(reorder_window_s=1.0, restart_backstep_s=5.0))
    cal.extend_imu(t[order], g[order], a[order])  # 10 samples 3 s late
    cal.process(flush=True)
    stats = cal.ordering_stats()['imu']
    assert stats.late == 10 and stats.restarts == 0


def test_total_deviation_comes_from_the_decimated_record_and_matches_allantools() -> None:
    import allantools

    gen = ImuNoiseGenerator(GYRO, ACCEL, sample_rate_hz=100.0, seed=10)
    t, g, a = gen.chunk(20_000)
    cal = calibrate_noise(imu=(t, g, a), settings=NoiseSettings(total_deviation_points=1024,
                                                                overlap='partial',
                                                                taus_per_octave=4))
    tau, dev, std = cal.axis_result('gyro_x').total_deviation  # type: ignore[misc]
    phase = np.concatenate(([0.0], np.cumsum(g[:, 0] - g[0, 0]) * 0.01))
    stride = 16  # 20 001 points kept at most 2·1024 + 1: 2^4
    ref_tau, ref, _, _ = allantools.totdev(phase[::stride], rate=100.0 / stride,
                                           data_type='phase', taus=tau)
    assert np.allclose(tau, ref_tau) and np.max(np.abs(dev / ref - 1)) < 1e-9
    assert np.all(std > 0) and tau[-1] > 90.0  # to T/2
