"""Specification of ``gyro-calib export`` (issue 27 §1): each consumer's keys, units, rules.

Each output is parsed with its consumer's own reading rules: GTSAM's parameter objects are
built from the file with the PyPI ``gtsam`` wheel; OpenCV ``%YAML:1.0`` files are read by our
reader (PyYAML rejects that header); the others against the key sets and value constraints
their readers enforce (Kalibr: every density > 0; FAST-LIO: discrete N²·f; Autoware: the
three stddevs equal; robot_localization: 15 booleans in its order).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from gyro_calib.cli import main
from gyro_calib.export import FORMATS, ExportError, ExportOptions, export_text
from gyro_calib.export.gtsam import gtsam_matrices
from gyro_calib.export.opencv_yaml import OpenCvYamlError, read_opencv_yaml
from gyro_calib.export.robot_localization import CONFIG_ORDER
from gyro_calib.handoff import Provenance, method_calibration, write_calibration
from gyro_calib.imu_calibration import ImuCalibration

N_G = {'x': 1.0e-4, 'y': 1.2e-4, 'z': 1.1e-4}  # rad/√s
K_G = {'x': 2.0e-6, 'y': 3.0e-6}  # rad/s/√s; z not resolved: its 2σ bound below
K_G_BOUND_Z = 4.0e-6
B_G = 5.0e-6  # rad/s: must never appear where a random walk belongs
N_A = {'x': 1.0e-3, 'y': 1.5e-3, 'z': 1.2e-3}  # m/s/√s
K_A = {'x': 4.0e-5, 'y': 5.0e-5, 'z': 6.0e-5}  # m/s²/√s
RATE = 200.0


def imu_values() -> dict[str, Any]:
    v: dict[str, Any] = {}
    for a in 'xyz':
        v[f'imu_gyro_{a}_angle_random_walk_rad_per_sqrt_s'] = N_G[a]
        v[f'imu_gyro_{a}_bias_instability_rad_s'] = B_G
        if a in K_G:
            v[f'imu_gyro_{a}_rate_random_walk_rad_per_s_sqrt_s'] = K_G[a]
        v[f'imu_accel_{a}_velocity_random_walk_m_s_per_sqrt_s'] = N_A[a]
        v[f'imu_accel_{a}_acceleration_random_walk_m_s2_per_sqrt_s'] = K_A[a]
    out = {}
    for k, val in v.items():
        out[k] = val
        out[k + '_std'] = val * 0.05
    out['imu_gyro_z_rate_random_walk_rad_per_s_sqrt_s_upper_bound_2sigma'] = K_G_BOUND_Z
    return out


@pytest.fixture
def imu_handoff(tmp_path: Path) -> Path:
    """A format-3 hand-off of an IMU's noise run, written by the hand-off writer itself."""
    missing = {'imu_gyro_z_rate_random_walk_rad_per_s_sqrt_s': 'not resolved: 2σ bound given.'}
    cal = method_calibration('noise', imu_values(), Provenance('imu.bag', 0, 10**12, missing),
                             gyro_id='IMU-1')
    return write_calibration(tmp_path / 'imu.yaml', cal)


@pytest.fixture
def gyro_only_handoff(tmp_path: Path) -> Path:
    values = {'scale_factor_rad_per_pulse': 4.0e-6, 'scale_factor_rad_per_pulse_std': 1e-12,
              'angle_random_walk_rad_per_sqrt_s': 1.0e-4,
              'angle_random_walk_rad_per_sqrt_s_std': 1e-6,
              'rate_random_walk_rad_per_s_sqrt_s_upper_bound_2sigma': 3.0e-6}
    data = {'format_version': 3, 'gyro_id': 'G-1', 'gyro': values,
            'missing': {'rate_random_walk_rad_per_s_sqrt_s': 'not resolved.'}}
    path = tmp_path / 'gyro.yaml'
    path.write_text(yaml.safe_dump(data), encoding='utf-8')
    return path


M_TRIAD = np.array([[4.0e-6, 2.0e-9, -1.0e-9], [-3.0e-9, 4.1e-6, 1.5e-9],
                    [2.5e-9, 1.0e-9, 3.9e-6]])


@pytest.fixture
def triad_handoff(tmp_path: Path) -> Path:
    noise = {c: {'angle_random_walk_rad_per_sqrt_s': N_G[a],
                 'angle_random_walk_rad_per_sqrt_s_std': 1e-6,
                 'rate_random_walk_rad_per_s_sqrt_s': 2e-6,
                 'rate_random_walk_rad_per_s_sqrt_s_std': 1e-7}
             for c, a in zip(('x', 'y', 'z'), 'xyz')}
    imu = ImuCalibration(('x', 'y', 'z'), pulses_to_body_rad=M_TRIAD,
                         pulses_to_body_rad_covariance=np.eye(9) * 1e-30,
                         bias_rad_s=np.array([1e-6, -2e-6, 3e-6]),
                         bias_rad_s_std=np.full(3, 1e-8), noise=noise)
    values = {k: v for k, v in imu_values().items() if k.startswith('imu_accel')}
    data = {'format_version': 4, 'gyro_id': 'TRIAD-1', 'imu': imu.to_section(), 'gyro': values}
    path = tmp_path / 'triad.yaml'
    path.write_text(yaml.safe_dump(data), encoding='utf-8')
    return path


def export(path: Path, fmt: str, **kw: Any) -> str:
    return export_text(path, fmt, ExportOptions(rate_hz=kw.pop('rate_hz', RATE), **kw))


def values_of(text: str) -> dict[str, Any]:
    data = read_opencv_yaml(text) if text.startswith('%YAML:1.0') else yaml.safe_load(text)
    assert isinstance(data, dict)
    return data


# -- every format -----------------------------------------------------------------------

@pytest.mark.parametrize('fmt', sorted(FORMATS))
def test_every_number_has_a_comment_naming_its_source_key(imu_handoff: Path, fmt: str) -> None:
    text = export(imu_handoff, fmt)
    for line in text.splitlines():
        code = line.split('#')[0]
        if any(ch.isdigit() for ch in code.split(':')[-1]) and 'e-' in code:
            assert '#' in line and ('imu_gyro_' in line or 'imu_accel_' in line
                                    or 'not a sensor term' in line), line


@pytest.mark.parametrize('fmt', sorted(FORMATS))
def test_bias_instability_is_never_a_written_value(imu_handoff: Path, fmt: str) -> None:
    text = export(imu_handoff, fmt)
    for line in text.splitlines():
        code = line.split('#')[0]
        assert f'{B_G:.6e}' not in code and f'{B_G ** 2:.6e}' not in code, line


# -- Kalibr -----------------------------------------------------------------------------

def test_kalibr_has_its_six_keys_continuous_largest_axis_and_the_bound_said(
        imu_handoff: Path) -> None:
    text = export(imu_handoff, 'kalibr')
    data = values_of(text)
    assert set(data) == {'accelerometer_noise_density', 'accelerometer_random_walk',
                         'gyroscope_noise_density', 'gyroscope_random_walk', 'rostopic',
                         'update_rate'}
    assert all(data[k] > 0 for k in data if k != 'rostopic')  # Kalibr's reader rule
    assert data['gyroscope_noise_density'] == pytest.approx(max(N_G.values()))
    assert data['gyroscope_random_walk'] == pytest.approx(K_G_BOUND_Z)  # the z bound is largest
    line = next(x for x in text.splitlines() if x.startswith('gyroscope_random_walk'))
    assert '2σ upper bound' in line and '_upper_bound_2sigma' in line
    assert data['accelerometer_random_walk'] == pytest.approx(max(K_A.values()))
    assert data['update_rate'] == RATE


def test_kalibr_from_a_gyro_only_handoff_says_what_is_missing_instead_of_zeros(
        gyro_only_handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'imu.yaml'
    old = '# an earlier export; gyro-calib export --format kalibr.\nold: 1\n'  # replaceable
    out.write_text(old)
    code = main(['export', str(gyro_only_handoff), '--format', 'kalibr', '--out', str(out),
                 '--rate-hz', '200'])
    err = capsys.readouterr()
    assert code == 2 and err.out == ''
    assert len(err.err.strip().splitlines()) == 1
    assert 'accelerometer_noise_density' in err.err and 'no accelerometer term' in err.err
    assert out.read_text() == old


# -- GTSAM: built with the gtsam wheel ----------------------------------------------------

def test_gtsam_combined_params_hold_the_per_axis_continuous_covariances(
        imu_handoff: Path) -> None:
    import gtsam

    m = gtsam_matrices(export(imu_handoff, 'gtsam'))
    p = gtsam.PreintegrationCombinedParams.MakeSharedU(9.81)
    p.setGyroscopeCovariance(m['gyroscope_covariance'])
    p.setBiasOmegaCovariance(m['bias_omega_covariance'])
    p.setAccelerometerCovariance(m['accelerometer_covariance'])
    p.setBiasAccCovariance(m['bias_acc_covariance'])
    p.setIntegrationCovariance(m['integration_covariance'])
    np.testing.assert_allclose(np.diag(p.getGyroscopeCovariance()),
                               [N_G[a] ** 2 for a in 'xyz'], rtol=1e-6)
    np.testing.assert_allclose(np.diag(p.getBiasOmegaCovariance()),
                               [K_G['x'] ** 2, K_G['y'] ** 2, K_G_BOUND_Z ** 2], rtol=1e-6)
    np.testing.assert_allclose(np.diag(p.getAccelerometerCovariance()),
                               [N_A[a] ** 2 for a in 'xyz'], rtol=1e-6)
    np.testing.assert_allclose(np.diag(p.getBiasAccCovariance()),
                               [K_A[a] ** 2 for a in 'xyz'], rtol=1e-6)
    pim = gtsam.PreintegratedCombinedMeasurements(p, gtsam.imuBias.ConstantBias())
    pim.integrateMeasurement(np.zeros(3), np.array([0.0, 0.0, 9.81]), 1.0 / RATE)
    assert np.all(np.isfinite(pim.preintMeasCov()))


def test_gtsam_from_a_gyro_only_handoff_gives_ahrs_params_and_no_invented_accelerometer(
        gyro_only_handoff: Path) -> None:
    import gtsam

    text = export(gyro_only_handoff, 'gtsam')
    m = gtsam_matrices(text)
    assert set(m) == {'gyroscope_covariance', 'bias_omega_covariance'}
    p = gtsam.PreintegratedRotationParams()
    p.setGyroscopeCovariance(m['gyroscope_covariance'])
    np.testing.assert_allclose(p.getGyroscopeCovariance(), np.eye(3) * 1e-8, rtol=1e-6)
    ahrs = gtsam.PreintegratedAhrsMeasurements(p, np.zeros(3))
    ahrs.integrateMeasurement(np.array([0.0, 0.0, 0.1]), 0.01)
    assert ahrs.preintMeasCov()[2, 2] == pytest.approx(1e-8 * 0.01, rel=1e-6)
    assert 'one gyro was measured' in text and 'upper bound' in text


# -- OpenVINS and VINS-Fusion: OpenCV YAML --------------------------------------------------

def test_openvins_writes_the_opencv_header_pyyaml_rejects_and_reads_back(
        triad_handoff: Path) -> None:
    text = export(triad_handoff, 'openvins', accel_topic='/imu/driver')
    assert text.startswith('%YAML:1.0\n')
    with pytest.raises(yaml.YAMLError):
        yaml.safe_load(text)
    imu0 = read_opencv_yaml(text)['imu0']
    assert set(imu0) == {'T_i_b', 'accelerometer_noise_density', 'accelerometer_random_walk',
                         'gyroscope_noise_density', 'gyroscope_random_walk', 'rostopic',
                         'time_offset', 'update_rate', 'model', 'Tw', 'R_IMUtoGYRO', 'Ta',
                         'R_IMUtoACC', 'Tg'}
    np.testing.assert_array_equal(imu0['Tw'], np.eye(3))  # compensated upstream
    with pytest.raises(OpenCvYamlError):
        read_opencv_yaml(text.split('\n', 1)[1])


def test_openvins_raw_triad_stream_has_tw_times_rotation_equal_k0_m_inverse(
        triad_handoff: Path) -> None:
    k0 = 4.0e-6
    text = export(triad_handoff, 'openvins', stream='raw', raw_scale_rad_per_pulse=k0)
    imu0 = read_opencv_yaml(text)['imu0']
    tw, r = np.asarray(imu0['Tw']), np.asarray(imu0['R_IMUtoGYRO'])
    assert np.allclose(np.triu(tw, 1), 0.0) and np.all(np.diag(tw) > 0)  # kalibr model
    dw = np.linalg.inv(tw)  # OpenVINS keeps Dw's lower triangle (its kalibr model)
    assert np.allclose(np.triu(dw, 1), 0.0, atol=1e-9 * np.abs(dw).max())
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-6)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(tw @ r, k0 * np.linalg.inv(M_TRIAD), rtol=1e-5, atol=1e-6)


def test_vins_fusion_keys_are_per_sample_with_the_opencv_header(imu_handoff: Path) -> None:
    """gyr_n = N·√(2f), gyr_w = K·√f (METHODS §E.5 eq. (18); its midpoint propagation)."""
    text = export(imu_handoff, 'vins-fusion')
    data = read_opencv_yaml(text)
    assert {'acc_n', 'gyr_n', 'acc_w', 'gyr_w', 'imu_topic'} <= set(data)
    assert data['gyr_n'] == pytest.approx(max(N_G.values()) * math.sqrt(2 * RATE))
    assert data['gyr_w'] == pytest.approx(K_G_BOUND_Z * math.sqrt(RATE))
    assert 'scale it up' in text


# -- LIO-SAM, FAST-LIO, Autoware, robot_localization ---------------------------------------

def test_lio_sam_is_continuous_under_ros2_parameters(imu_handoff: Path) -> None:
    p = values_of(export(imu_handoff, 'lio-sam'))['/**']['ros__parameters']
    assert p['imuGyrNoise'] == pytest.approx(max(N_G.values()))
    assert p['imuGyrBiasN'] == pytest.approx(K_G_BOUND_Z)
    assert p['imuAccNoise'] == pytest.approx(max(N_A.values()))
    assert p['imuAccBiasN'] == pytest.approx(max(K_A.values()))


def test_fast_lio_covariances_are_discrete_n_squared_times_rate(imu_handoff: Path) -> None:
    p = values_of(export(imu_handoff, 'fast-lio'))['/**']['ros__parameters']['mapping']
    assert p['gyr_cov'] == pytest.approx(max(N_G.values()) ** 2 * RATE, rel=1e-6)
    assert p['acc_cov'] == pytest.approx(max(N_A.values()) ** 2 * RATE, rel=1e-6)
    assert p['b_gyr_cov'] == pytest.approx(K_G_BOUND_Z ** 2 * RATE, rel=1e-6)
    assert p['b_acc_cov'] == pytest.approx(max(K_A.values()) ** 2 * RATE, rel=1e-6)


def test_fast_lio_without_a_rate_is_refused_naming_the_flag(imu_handoff: Path) -> None:
    with pytest.raises(ExportError, match='--rate-hz'):
        export(imu_handoff, 'fast-lio', rate_hz=None)


def test_autoware_stddevs_are_equal_per_message_and_offsets_zero_upstream(
        gyro_only_handoff: Path) -> None:
    p = values_of(export(gyro_only_handoff, 'autoware'))['/**']['ros__parameters']
    sd = [p[f'angular_velocity_stddev_{a}{a}'] for a in 'xyz']
    # N²·f and the count quantisation imu_corrector publishes, K²·f²/6 (issue 36 §4)
    assert sd[0] == sd[1] == sd[2] == pytest.approx(
        math.sqrt(1.0e-4 ** 2 * RATE + 4.0e-6 ** 2 * RATE ** 2 / 6), rel=1e-6)
    assert [p[f'angular_velocity_offset_{a}'] for a in 'xyz'] == [0.0, 0.0, 0.0]
    assert p['acceleration_stddev'] == 10000.0  # Autoware's own default: required (issue 36)


def test_robot_localization_fuses_rates_only_and_says_it_has_no_bias_state(
        gyro_only_handoff: Path, imu_handoff: Path) -> None:
    text = export(gyro_only_handoff, 'robot-localization')
    p = values_of(text)['ekf_filter_node']['ros__parameters']
    config = p['imu0_config']
    assert len(config) == 15 and all(isinstance(b, bool) for b in config)
    fused = {name for name, b in zip(CONFIG_ORDER, config) if b}
    assert fused == {'vroll', 'vpitch', 'vyaw'}
    assert 'no gyro-bias state' in text
    p2 = values_of(export(imu_handoff, 'robot-localization'))['ekf_filter_node']['ros__parameters']
    assert {n for n, b in zip(CONFIG_ORDER, p2['imu0_config']) if b} == {
        'vroll', 'vpitch', 'vyaw', 'ax', 'ay', 'az'}


# -- refusals -------------------------------------------------------------------------------

@pytest.mark.parametrize('fmt', ['kalibr', 'gtsam', 'lio-sam', 'fast-lio', 'vins-fusion',
                                 'autoware', 'robot-localization'])
def test_a_raw_stream_needing_a_scale_factor_is_refused_in_one_line(
        gyro_only_handoff: Path, fmt: str) -> None:
    with pytest.raises(ExportError) as info:
        export(gyro_only_handoff, fmt, stream='raw')
    assert '\n' not in str(info.value) and '--stream compensated' in str(info.value)


def test_a_raw_triad_stream_is_refused_where_intrinsics_cannot_be_taken(
        triad_handoff: Path) -> None:
    with pytest.raises(ExportError, match=r'imu\.pulses_to_body_rad'):
        export(triad_handoff, 'kalibr', stream='raw')


def test_cli_bad_input_is_one_line_exit_2_and_nothing_written(
        tmp_path: Path, imu_handoff: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'out.yaml'
    for argv in (['export', str(tmp_path / 'nope.yaml'), '--format', 'gtsam', '--out', str(out)],
                 ['export', str(imu_handoff), '--format', 'fast-lio', '--out', str(out)],
                 ['export', str(imu_handoff), '--format', 'kalibr', '--out',
                  str(tmp_path / 'no' / 'x.yaml'), '--rate-hz', '200'],
                 ['export', str(imu_handoff), '--format', 'klibr', '--out', str(out)],
                 ['export', str(imu_handoff), '--format', 'gtsam', '--out', str(out),
                  '--rate-hz', '-1']):
        with pytest.raises(SystemExit) if 'klibr' in argv or '-1' in argv else _nothing():
            code = main(argv)
            assert code == 2
        err = capsys.readouterr()
        assert err.out == '' and len(err.err.strip().splitlines()) == 1, (argv, err.err)
        assert not out.exists()


def test_cli_writes_the_file(tmp_path: Path, imu_handoff: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'kalibr.yaml'
    assert main(['export', str(imu_handoff), '--format', 'kalibr', '--out', str(out),
                 '--rate-hz', '200', '--topic', '/imu0']) == 0
    assert capsys.readouterr().out == ''
    assert yaml.safe_load(out.read_text())['rostopic'] == '/imu0'


class _nothing:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


def test_a_committed_imu_bag_exports_the_numbers_the_noise_methods_own_kalibr_file_has(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """End to end: noise run → hand-off → export; the same four densities as ``--kalibr``.

    The bag's random walks are not resolved in 500 s: both files carry the 2σ bound, the
    export reading it from the hand-off's ``_upper_bound_2sigma`` keys.
    """
    import gtsam

    bag = Path(__file__).resolve().parents[1] / 'bags' / 'noise_imu_static'
    handoff, own = tmp_path / 'h.yaml', tmp_path / 'k.yaml'
    assert main(['noise', str(bag), '--kalibr', str(own), '--out', str(handoff)]) == 0
    out = tmp_path / 'e.yaml'
    assert main(['export', str(handoff), '--format', 'kalibr', '--out', str(out),
                 '--rate-hz', '200']) == 0
    capsys.readouterr()
    mine, theirs = yaml.safe_load(out.read_text()), yaml.safe_load(own.read_text())
    for key in ('accelerometer_noise_density', 'accelerometer_random_walk',
                'gyroscope_noise_density', 'gyroscope_random_walk'):
        assert mine[key] == theirs[key], key
    assert '_upper_bound_2sigma' in out.read_text()
    # without --rate-hz: the noise run's own sample rate, as its Kalibr file has it
    plain = yaml.safe_load(export_text(handoff, 'kalibr', ExportOptions()))
    assert plain['update_rate'] == pytest.approx(theirs['update_rate'], abs=1e-6)
    m = gtsam_matrices(export(handoff, 'gtsam'))
    p = gtsam.PreintegrationCombinedParams.MakeSharedU(9.81)
    p.setGyroscopeCovariance(m['gyroscope_covariance'])
    p.setBiasOmegaCovariance(m['bias_omega_covariance'])
    assert np.max(np.diag(p.getGyroscopeCovariance())) == pytest.approx(
        theirs['gyroscope_noise_density'] ** 2, rel=1e-5)
    # every format, read back by its consumer's own reader (issue 36)
    from consumer_readers import gyro_white_noise_as_read

    n, f = theirs['gyroscope_noise_density'], theirs['update_rate']
    got = {fmt: gyro_white_noise_as_read(fmt, export(handoff, fmt, rate_hz=f))
           for fmt in FORMATS}
    for fmt in ('kalibr', 'openvins'):
        assert got[fmt]['gyroscope_noise_density'] == pytest.approx(n, rel=1e-6)
    assert got['lio-sam']['imuGyrNoise'] == pytest.approx(n, rel=1e-6)
    assert got['gtsam']['gyroscope_covariance'] == pytest.approx(n * n, rel=1e-5)
    assert got['vins-fusion']['gyr_n'] == pytest.approx(n * math.sqrt(2 * f), rel=1e-6)
    per_sample = got['fast-lio']['mapping.gyr_cov']
    assert per_sample >= n * n * f * (1 - 1e-6)  # N²·f and the angle quantisation
    assert got['autoware']['angular_velocity_stddev_zz'] ** 2 == pytest.approx(per_sample,
                                                                              rel=1e-5)
    assert got['robot-localization']['imu0'] == '/imu/data'


def test_triad_noise_follows_each_channel_to_the_body_axis_its_sense_axis_is_along(
        tmp_path: Path) -> None:
    """Channels in any order: channel 'a' senses body z, 'b' x, 'c' y."""
    from gyro_calib.export.source import read_source

    axes = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    noise = {c: {'angle_random_walk_rad_per_sqrt_s': n,
                 'angle_random_walk_rad_per_sqrt_s_std': 1e-7}
             for c, n in (('a', 3e-4), ('b', 1e-4), ('c', 2e-4))}
    imu = ImuCalibration(('a', 'b', 'c'), sense_axes=axes, sense_axes_std_rad=np.zeros(3),
                         noise=noise)
    section = imu.to_section()
    assert 'misalignment_rad' not in section  # s_ij/s_ii: undefined for a permuted triad
    path = tmp_path / 't.yaml'
    path.write_text(yaml.safe_dump({'format_version': 4, 'imu': section}))
    src = read_source(path)
    assert {a: src.gyro[a]['N'].value for a in 'xyz'} == {'x': 1e-4, 'y': 2e-4, 'z': 3e-4}
    assert src.gyro['z']['N'].key == 'imu.noise.a.angle_random_walk_rad_per_sqrt_s'


@pytest.mark.parametrize('victim', ['bag.mcap', 'bagdir/metadata.yaml', 'other_gyro.yaml'])
def test_an_export_never_replaces_a_bag_or_a_hand_off_file(
        victim: str, tmp_path: Path, imu_handoff: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """It replaced a 4 MB recording, a bag's metadata and another gyro's hand-off (exit 0)."""
    out = tmp_path / victim
    out.parent.mkdir(exist_ok=True)
    if victim.endswith('metadata.yaml'):
        (out.parent / 'bag.mcap').write_bytes(b'\x89MCAP0\r\n')
        out.write_text('rosbag2_bagfile_information: {}\n', encoding='utf-8')
    elif victim.endswith('.mcap'):
        out.write_bytes(b'\x89MCAP0\r\n' + b'\0' * 64)
    else:
        out.write_bytes(imu_handoff.read_bytes())
    before = out.read_bytes()
    assert main(['export', str(imu_handoff), '--format', 'gtsam', '--out', str(out),
                 '--rate-hz', '200']) == 2
    run = capsys.readouterr()
    assert run.out == '' and len(run.err.strip().splitlines()) == 1 and 'never replaces' in run.err
    assert out.read_bytes() == before


def test_a_per_sample_covariance_holds_the_angle_quantisation_of_a_pulse_gyro(
        tmp_path: Path) -> None:
    """Discrete consumers get N²·f + 2·Q²·f²; a dithered RLG's Q dominates (walk: 50× low).

    The noise_rlg_spikes figures: N = 8.84e-7 rad/√s, Q = 1.18e-6 rad at 500 Hz give a
    per-message σ of 8.3e-4 rad/s, not N·√f = 2.0e-5 rad/s.
    """
    n, q, f = 8.84e-7, 1.18e-6, 500.0
    cal = method_calibration('noise', {
        'angle_random_walk_rad_per_sqrt_s': n, 'angle_random_walk_rad_per_sqrt_s_std': 3.5e-8,
        'quantization_noise_rad': q, 'quantization_noise_rad_std': 3.7e-9,
        'rate_random_walk_rad_per_s_sqrt_s_upper_bound_2sigma': 1e-7},
        Provenance('rlg.bag', 0, 10**12), gyro_id='RLG-1')
    handoff = write_calibration(tmp_path / 'rlg.yaml', cal)
    want = n * n * f + 2.0 * q * q * f * f
    options = ExportOptions(rate_hz=f)
    aw = yaml.safe_load(export_text(handoff, 'autoware', options))['/**']['ros__parameters']
    assert aw['angular_velocity_stddev_zz'] == pytest.approx(math.sqrt(want), rel=1e-6)
    assert aw['angular_velocity_stddev_zz'] > 30 * n * math.sqrt(f)
    text = export_text(handoff, 'gtsam', options)
    assert 'angle quantisation' in text and 'cannot hold it' in text  # continuous: said
