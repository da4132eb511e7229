"""One sensor per file, and still a complete export: ``export --accel-from IMU_HANDOFF``.

A triad's hand-off holds its gyros (``imu:`` with each channel's noise); the IMU driver's
accelerometers are characterised by a noise run on its sensor_msgs/Imu topic into a file of
its own (a run of another sensor is refused in the triad's file: issue 35 item 2). The export
takes the gyro terms from the first and the accelerometer terms from the second, each
comment naming its file, as OpenCV reads them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from test_export import K_A, M_TRIAD, N_A, N_G, export, imu_values

from gyro_calib.cli import main
from gyro_calib.export.opencv_yaml import read_opencv_yaml
from gyro_calib.handoff import Provenance, method_calibration, write_calibration
from gyro_calib.imu_calibration import ImuCalibration


@pytest.fixture
def triad_gyros_only(tmp_path: Path) -> Path:
    """A triad's hand-off with its own gyro noise and no accelerometer term."""
    noise = {c: {'angle_random_walk_rad_per_sqrt_s': N_G[c],
                 'angle_random_walk_rad_per_sqrt_s_std': 1e-6,
                 'rate_random_walk_rad_per_s_sqrt_s': 2e-6,
                 'rate_random_walk_rad_per_s_sqrt_s_std': 1e-7} for c in 'xyz'}
    imu = ImuCalibration(('x', 'y', 'z'), pulses_to_body_rad=M_TRIAD,
                         pulses_to_body_rad_covariance=np.eye(9) * 1e-30,
                         bias_rad_s=np.array([1e-6, -2e-6, 3e-6]),
                         bias_rad_s_std=np.full(3, 1e-8), noise=noise)
    path = tmp_path / 'triad.yaml'
    path.write_text(yaml.safe_dump({'format_version': 4, 'gyro_id': 'TRIAD-9',
                                    'imu': imu.to_section()}), encoding='utf-8')
    return path


@pytest.fixture
def driver_noise(tmp_path: Path) -> Path:
    """The IMU driver's noise run (sensor_msgs/Imu): its accelerometer terms, in its own file."""
    cal = method_calibration('noise', imu_values(), Provenance('driver.bag', 0, 10**12, {}),
                             gyro_id='IMU-DRIVER')
    return write_calibration(tmp_path / 'driver.yaml', cal)


def test_the_triad_alone_is_refused_naming_accel_from(
        triad_gyros_only: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'ov.yaml'
    assert main(['export', str(triad_gyros_only), '--format', 'openvins', '--out', str(out),
                 '--accel-topic', '/imu/driver']) == 2
    err = capsys.readouterr().err.strip()
    assert '\n' not in err and '--accel-from IMU.yaml' in err and 'one sensor per file' in err
    assert not out.exists()


def test_openvins_takes_the_gyros_of_the_triad_and_the_accelerometers_of_the_driver(
        triad_gyros_only: Path, driver_noise: Path, tmp_path: Path) -> None:
    out = tmp_path / 'ov.yaml'
    assert main(['export', str(triad_gyros_only), '--format', 'openvins', '--out', str(out),
                 '--accel-topic', '/imu/driver', '--accel-from', str(driver_noise),
                 '--rate-hz', '500']) == 0
    imu0 = read_opencv_yaml(out.read_text(encoding='utf-8'))['imu0']
    assert imu0['gyroscope_noise_density'] == pytest.approx(max(N_G.values()), rel=1e-6)
    assert imu0['accelerometer_noise_density'] == pytest.approx(max(N_A.values()), rel=1e-6)
    assert imu0['accelerometer_random_walk'] == pytest.approx(max(K_A.values()), rel=1e-6)
    text = out.read_text(encoding='utf-8')
    assert f'{driver_noise}: gyro.imu_accel_' in text  # the comment names the other file
    assert 'imu.noise.' in text


def test_a_file_without_accelerometer_terms_or_a_second_source_is_refused(
        triad_gyros_only: Path, driver_noise: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'ov.yaml'
    assert main(['export', str(triad_gyros_only), '--format', 'openvins', '--out', str(out),
                 '--accel-from', str(triad_gyros_only)]) == 2
    assert 'holds no accelerometer term' in capsys.readouterr().err
    assert main(['export', str(driver_noise), '--format', 'openvins', '--out', str(out),
                 '--accel-from', str(driver_noise)]) == 2
    assert 'holds accelerometer terms of its own' in capsys.readouterr().err
    assert not out.exists()
    assert export  # the shared writer of test_export stays the one the other tests use


def test_noise_kalibr_never_replaces_a_hand_off_file(
        triad_gyros_only: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """README's ``--kalibr imu.yaml`` and the tutorial's ``--out imu.yaml`` share a name."""
    before = triad_gyros_only.read_bytes()
    bag = Path(__file__).resolve().parents[1] / 'bags' / 'noise_imu_static'
    assert main(['noise', str(bag), '--topic', '/imu/data', '--kalibr',
                 str(triad_gyros_only)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ''
    (line,) = captured.err.strip().splitlines()
    assert 'noise: --kalibr' in line and 'a gyro_calib hand-off file' in line
    assert triad_gyros_only.read_bytes() == before
