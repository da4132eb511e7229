"""imu_corrector's modes, as the node runs them, without DDS (test/fake_node.py).

- a format-4 file with ``imu:`` puts the corrector in triad mode: /imu/pulses → /imu/data,
  the body rate against a known M and b within the published covariance;
- a sample whose channel names are not the file's is refused with one throttled line;
- ``equal_variances`` publishes the largest variance on every axis;
- a FOG's file reads /fog/output and says which scale factor applies and why;
- a pulse gyro's file behaves as before (/gyro/pulses → /gyro/imu, z only).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from fake_node import FakeNode

from gyro_calib.handoff import Provenance, method_calibration, write_calibration
from gyro_calib.imu_calibration import ImuCalibration
from gyro_calib.nodes.imu_corrector_core import (
    GYRO_IMU,
    IMU_DATA,
    REFUSED_EVERY,
    ImuCorrector,
)
from gyro_calib.units import RAD_PER_ARCSEC

T0_NS = 1_795_426_200_000_000_000
K = np.array([0.84, 1.1, 2.3]) * RAD_PER_ARCSEC
AXES = np.array([[1.0, 2e-3, -1e-3], [-3e-3, 1.0, 4e-3], [1e-3, -2e-3, 1.0]])
AXES /= np.linalg.norm(AXES, axis=1)[:, None]
M = np.linalg.inv(AXES / K[:, None])
B = np.array([2e-6, -1e-6, 4e-6])


def _write_triad(path: Path, channels: tuple[str, str, str] = ('gx', 'gy', 'gz')) -> Path:
    cal = ImuCalibration(channels, np.eye(3), K, K * 1e-7, None, AXES, np.full(3, 1e-7),
                         np.asarray(M, dtype=np.float64), np.eye(9) * (1e-7 * K.min()) ** 2,
                         B, np.full(3, 1e-8),
                         {c: {'angle_random_walk_rad_per_sqrt_s': 4e-7} for c in channels})
    path.write_text(yaml.safe_dump({'format_version': 4, 'gyro_id': 'IMU-7',
                                    'imu': cal.to_section()}), encoding='utf-8')
    return path


def _corrector(path: Path, **options: bool) -> tuple[ImuCorrector, FakeNode]:
    node = FakeNode()
    corrector = ImuCorrector(node, **options)  # type: ignore[arg-type]
    corrector.poll_file(str(path))
    return corrector, node


def test_triad_file_gives_body_rates_on_imu_data_within_the_published_covariance(
        tmp_path: Path) -> None:
    corrector, node = _corrector(_write_triad(tmp_path / 'imu.yaml'))
    assert corrector.output == IMU_DATA
    assert 'reading /imu/pulses, publishing /imu/data' in node.logger.lines[0]
    rng = np.random.default_rng(3)
    dt_ns, n = 1_000_000, 3000
    omega = np.array([0.4, -0.25, 0.9])
    r = np.linalg.inv(M)
    t_s = np.arange(n) * dt_ns / 1e9
    angle = np.outer(t_s, r @ (omega + B))  # the physics: ṅ = R·(ω + b), R = M⁻¹
    angle += np.cumsum(rng.normal(size=(n, 3)) * 4e-7 / K * np.sqrt(dt_ns / 1e9), axis=0)
    counts = np.floor(angle + rng.uniform(0, 1, 3))
    chi2 = []
    for i in range(n):
        outs = corrector.on_imu_pulses(T0_NS + i * dt_ns, ['gz', 'gx', 'gy'],
                                       [counts[i, 2], counts[i, 0], counts[i, 1]])
        for topic, out in outs:
            assert topic == IMU_DATA and out.stamp_ns == T0_NS + i * dt_ns
            err = np.array(out.angular_velocity_rad_s) - omega
            cov = np.array(out.covariance_rad2_s2).reshape(3, 3)
            chi2.append(float(err @ np.linalg.solve(cov, err)))
    assert len(chi2) == n - 1
    assert 2.7 < np.mean(chi2) < 3.3
    # the single-gyro topics are not read in triad mode
    assert corrector.on_gyro_pulses(T0_NS, ['gyro'], [1.0]) == []


def test_samples_with_other_channel_names_are_refused_with_one_throttled_line(
        tmp_path: Path) -> None:
    corrector, node = _corrector(_write_triad(tmp_path / 'imu.yaml'))
    before = len(node.logger.lines)
    for i in range(2 * REFUSED_EVERY + 5):
        assert corrector.on_imu_pulses(T0_NS + i * 10**6, ['x', 'y', 'z'], [1.0, 2.0, 3.0]) \
            == []
    lines = node.logger.lines[before:]
    assert len(lines) == 3
    assert lines[0] == ("/imu/pulses: channel names ['x', 'y', 'z'] (with 3 positions) do not "
                        "match the calibration's channels ['gx', 'gy', 'gz']: sample not used.")
    assert lines[1].endswith(f'({REFUSED_EVERY + 1} such samples refused so far)')


def test_equal_variances_option_publishes_the_largest_variance_on_every_axis(
        tmp_path: Path) -> None:
    path = _write_triad(tmp_path / 'imu.yaml')
    outs = {}
    for equal in (False, True):
        corrector, node = _corrector(path, equal_variances=equal)
        corrector.on_imu_pulses(T0_NS, ['gx', 'gy', 'gz'], [0.0, 0.0, 0.0])
        ((_, outs[equal]),) = corrector.on_imu_pulses(T0_NS + 10**6, ['gx', 'gy', 'gz'],
                                                      [500.0, -200.0, 90.0])
    assert 'equal variances (the largest) on every axis' in node.logger.lines[0]
    full = np.array(outs[False].covariance_rad2_s2).reshape(3, 3)
    np.testing.assert_array_equal(np.array(outs[True].covariance_rad2_s2).reshape(3, 3),
                                  np.eye(3) * np.diag(full).max())


def test_a_fog_file_reads_fog_output_and_says_which_scale_factor_applies(tmp_path: Path
                                                                         ) -> None:
    prov = Provenance('bags/fog_turntable_bench', T0_NS - 10**12, T0_NS - 10**9)
    sf, bias = 823_190.0, 4.8e-6
    path = tmp_path / 'fog.yaml'
    write_calibration(path, method_calibration('fog', {
        'fog_scale_factor_counts_per_rad': sf, 'fog_scale_factor_counts_per_rad_std': 4.0,
        'fog_bias_rad_s': bias, 'fog_bias_rad_s_std': 2e-8,
        'fog_angle_random_walk_rad_per_sqrt_s': 1.2e-6,
        'fog_angle_random_walk_rad_per_sqrt_s_std': 1e-7}, prov, gyro_id='F-3'))
    corrector, node = _corrector(path)
    log = '\n'.join(node.logger.lines)
    assert 'reading /fog/output, publishing /gyro/imu' in log
    assert 'FOG: the turntable scale factor applies (from run bags/fog_turntable_bench' in log
    assert "measured against the table's rates" in log
    assert 'K̃' not in log and 'θ' not in log
    assert corrector.on_gyro_pulses(T0_NS, ['gyro'], [0.0]) == []  # not the FOG's topic
    corrector.on_fog_output(T0_NS, ['fog'], [0.0])
    ((topic, out),) = corrector.on_fog_output(T0_NS + 10**7, ['fog'], [8232.0])
    assert topic == GYRO_IMU
    assert out.angular_velocity_rad_s[2] == pytest.approx(8232.0 / (sf * 0.01) - bias, rel=1e-12)


def test_a_pulse_gyro_file_keeps_the_single_gyro_behaviour(tmp_path: Path) -> None:
    prov = Provenance('test', T0_NS - 10**12, T0_NS - 10**9)
    path = tmp_path / 'gyro.yaml'
    k = 0.84279066 * RAD_PER_ARCSEC
    write_calibration(path, method_calibration('rbrlg', {
        'k_tilde_rad_per_pulse': k, 'k_tilde_rad_per_pulse_std': 5e-14, 'window_pairs': 3,
        'scale_factor_rad_per_pulse': k, 'scale_factor_rad_per_pulse_std': 6e-14,
        'bias_rad_s': 7.3e-6, 'bias_rad_s_std': 3e-9}, prov))
    corrector, node = _corrector(path)
    assert corrector.output == GYRO_IMU
    assert corrector.on_fog_output(T0_NS, ['fog'], [0.0]) == []
    assert corrector.on_imu_pulses(T0_NS, ['x', 'y', 'z'], [0.0] * 3) == []
    corrector.on_gyro_pulses(T0_NS, ['gyro'], [1e8])
    ((topic, out),) = corrector.on_gyro_pulses(T0_NS + 10**6, ['gyro'], [1e8 + 412.0])
    assert topic == GYRO_IMU and out.angular_velocity_rad_s[:2] == (0.0, 0.0)
    assert out.angular_velocity_rad_s[2] == k * 412e3 - 7.3e-6
    # the triad file later: the mode follows the file
    _write_triad(path)
    corrector.poll_file(str(path))
    assert corrector.output == IMU_DATA and corrector.converter is None


def test_triad_with_an_accelerometer_input_passes_each_stamps_sample_through(
        tmp_path: Path) -> None:
    """/imu/data carries the IMU's accelerometers, matched by stamp (issue 36 §3).

    A rate whose accelerometer sample never comes is not published (no zero acceleration).
    """
    node = FakeNode()
    corrector = ImuCorrector(node, accel_input='/imu/driver')  # type: ignore[arg-type]
    corrector.poll_file(str(_write_triad(tmp_path / 'imu.yaml')))
    dt_ns = 5_000_000
    cov = (1e-4, 0.0, 0.0, 0.0, 2e-4, 0.0, 0.0, 0.0, 3e-4)
    out = []
    for i in range(6):
        t = T0_NS + i * dt_ns
        out += corrector.on_imu_pulses(t, ['gx', 'gy', 'gz'], [10.0 * i, 20.0 * i, 30.0 * i])
        if i != 3:  # the driver's sample of stamp 3 is lost
            out += corrector.on_accel(t + 20_000, (0.1 * i, -0.2, 9.81), cov)  # 20 µs later
    assert [o.stamp_ns for _, o in out] == [T0_NS + i * dt_ns for i in (1, 2, 4, 5)]
    for topic, o in out:
        i = (o.stamp_ns - T0_NS) // dt_ns
        assert topic == IMU_DATA
        assert o.linear_acceleration_m_s2 == (0.1 * i, -0.2, 9.81)
        assert o.linear_acceleration_covariance == cov
    assert any('no accelerometer sample on /imu/driver' in ln for ln in node.logger.lines)
    # without an accelerometer input the output says it carries none
    plain, _ = _corrector(tmp_path / 'imu.yaml')
    outs = [o for i in range(3) for o in plain.on_imu_pulses(
        T0_NS + i * dt_ns, ['gx', 'gy', 'gz'], [1.0 * i, 2.0 * i, 3.0 * i])]
    assert outs and all(o.linear_acceleration_m_s2 is None for _, o in outs)


def _imu_noise_handoff(path: Path) -> Path:
    """An IMU's noise run (gyro-calib noise on its sensor_msgs/Imu): no imu: section."""
    values = {}
    for a, n in zip('xyz', (1.0e-4, 1.2e-4, 1.1e-4), strict=True):
        values[f'imu_gyro_{a}_angle_random_walk_rad_per_sqrt_s'] = n
        values[f'imu_gyro_{a}_angle_random_walk_rad_per_sqrt_s_std'] = n * 0.05
        values[f'imu_accel_{a}_velocity_random_walk_m_s_per_sqrt_s'] = 1e-3
        values[f'imu_accel_{a}_velocity_random_walk_m_s_per_sqrt_s_std'] = 5e-5
    cal = method_calibration('noise', values, Provenance('imu.bag', 0, 10**12, {}),
                             gyro_id='MEMS-1')
    return write_calibration(path, cal)


def test_imu_mode_takes_a_mems_driver_imu_and_publishes_the_exported_covariance(
        tmp_path: Path) -> None:
    """A driver's Imu in, /imu/data out (issue 36 §5).

    With the per-sample covariance the robot_localization export states, and the message's
    own accelerometers.
    """
    import re

    from gyro_calib.export import ExportOptions, export_text

    path = _imu_noise_handoff(tmp_path / 'mems.yaml')
    node = FakeNode()
    corrector = ImuCorrector(node, imu_input='/mems/imu')  # type: ignore[arg-type]
    corrector.poll_file(str(path))
    assert corrector.output == IMU_DATA
    assert 'reading /mems/imu, publishing /imu/data' in node.logger.lines[0]
    dt_ns, out = 5_000_000, []
    for i in range(5):
        out += corrector.on_imu(T0_NS + i * dt_ns, (0.1, -0.2, 0.3 + i), (0.0, 0.1, 9.8 + i),
                                (1.0,) + (0.0,) * 8)
    assert [o.stamp_ns for _, o in out] == [T0_NS + i * dt_ns for i in range(1, 5)]
    text = export_text(path, 'robot-localization', ExportOptions(rate_hz=200.0))
    stated = float(re.search(r'angular_velocity_covariance of each message: diag (\S+)',
                             text).group(1))  # type: ignore[union-attr]
    for topic, o in out:
        i = (o.stamp_ns - T0_NS) // dt_ns
        assert topic == IMU_DATA and o.angular_velocity_rad_s == (0.1, -0.2, 0.3 + i)
        assert max(o.covariance_rad2_s2) == pytest.approx(stated, rel=1e-6)
        assert o.linear_acceleration_m_s2 == (0.0, 0.1, 9.8 + i)
        assert o.linear_acceleration_covariance[0] == pytest.approx(1e-6 * 200.0)


def test_imu_mode_with_a_triad_file_applies_m_and_b_to_the_drivers_rates(
        tmp_path: Path) -> None:
    """The driver publishes ω_m = K0·ṅ per channel; /imu/data is M·ṅ − b, the true rate."""
    k0 = float(K.mean())
    path = _write_triad(tmp_path / 'imu.yaml', channels=('x', 'y', 'z'))
    node = FakeNode()
    unset = ImuCorrector(node, imu_input='/imu/raw')  # type: ignore[arg-type]
    unset.poll_file(str(path))
    assert any('needs raw_scale_rad_per_pulse' in ln for ln in node.logger.lines)
    assert unset.on_imu(T0_NS, (0.1, 0.2, 0.3), (0.0, 0.0, 9.8), (0.0,) * 9) == []
    corrector = ImuCorrector(FakeNode(), imu_input='/imu/raw',  # type: ignore[arg-type]
                             raw_scale_rad_per_pulse=k0)
    corrector.poll_file(str(path))
    omega = np.array([0.4, -0.25, 0.9])
    n_dot = np.linalg.inv(M) @ (omega + B)  # the physics: ṅ = M⁻¹·(ω + b)
    out = []
    for i in range(4):
        out += corrector.on_imu(T0_NS + i * 5_000_000, tuple(k0 * n_dot), (0.0, 0.0, 9.8),
                                (0.0,) * 9)
    assert len(out) == 3
    for _, o in out:
        np.testing.assert_allclose(o.angular_velocity_rad_s, omega, rtol=1e-9)
        assert o.linear_acceleration_m_s2 == (0.0, 0.0, 9.8)
