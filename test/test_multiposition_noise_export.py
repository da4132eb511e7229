"""A multiposition calibration and its IMU's noise run share one hand-off, and export (F6).

Specification: ``gyro-calib calibrate BAG --method multiposition --out imu.yaml`` writes an
``imu:`` section in the triad's layout with ``imu.accelerometer`` beside it; that section is
an IMU read from sensor_msgs/Imu, not a pulse-output gyro triad. So ``gyro-calib noise`` on a
static sensor_msgs/Imu record of the same IMU goes into the same file (either order), even
when the noise is recorded at 200 Hz and the poses at 50 Hz (a calibration's parameters are
the sensor's, not its output rate's), and ``gyro-calib export`` then writes every consumer's
file, read back by the consumer's reader. A pulse triad's file still refuses the Imu noise
run and the multiposition run, and a multiposition file refuses a pulse triad's run.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from consumer_readers import openvins_imu0

from gyro_calib.cli import main as gyro_calib_main
from gyro_calib.handoff import load_calibration
from gyro_calib.registry import handoff_schema

BAGS = Path(__file__).resolve().parent.parent / 'bags'
MULTIPOSITION = BAGS / 'multiposition_hand_turned'  # 50 Hz
STATIC_IMU = BAGS / 'noise_imu_static'  # 200 Hz, the same kind of MEMS IMU lying still


def _cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = gyro_calib_main([*args] if args[0] == 'export' else [*args, '--no-progress'])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope='module')
def multiposition_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp('mp') / 'imu.yaml'
    assert gyro_calib_main(['calibrate', str(MULTIPOSITION), '--method', 'multiposition',
                            '--latitude-deg', '45.0', '--out', str(path),
                            '--no-progress']) == 0
    return path


@pytest.fixture(scope='module')
def triad_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp('triad') / 'triad.yaml'
    assert gyro_calib_main(['calibrate', str(BAGS / 'triad_two_axis_bench'), '--out', str(path),
                            '--no-progress']) == 0
    return path


@pytest.fixture(scope='module')
def calibrated_with_noise(tmp_path_factory: pytest.TempPathFactory,
                          multiposition_file: Path) -> Path:
    path = tmp_path_factory.mktemp('mpn') / 'imu.yaml'
    shutil.copy(multiposition_file, path)
    assert gyro_calib_main(['noise', str(STATIC_IMU), '--out', str(path),
                            '--no-progress']) == 0
    return path


def test_the_imus_noise_run_goes_into_its_multiposition_file(
        calibrated_with_noise: Path, multiposition_file: Path) -> None:
    held = load_calibration(calibrated_with_noise, handoff_schema())
    assert set(held.methods) == {'multiposition', 'noise'}
    before = load_calibration(multiposition_file, handoff_schema())
    assert held.imu is not None and before.imu is not None
    assert held.imu.accelerometer == before.imu.accelerometer
    assert (held.imu.pulses_to_body_rad == before.imu.pulses_to_body_rad).all()
    for axis in 'xyz':
        assert f'imu_gyro_{axis}_angle_random_walk_rad_per_sqrt_s' in held.values
        assert f'imu_accel_{axis}_velocity_random_walk_m_s_per_sqrt_s' in held.values


def test_the_calibration_goes_into_the_imus_noise_file_the_other_way_round(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / 'imu.yaml'
    assert _cli(capsys, 'noise', str(STATIC_IMU), '--out', str(path))[0] == 0
    code, out, err = _cli(capsys, 'calibrate', str(MULTIPOSITION), '--method', 'multiposition',
                          '--latitude-deg', '45.0', '--out', str(path))
    assert code == 0 and 'another sensor' not in err, err
    held = load_calibration(path, handoff_schema())
    assert set(held.methods) == {'multiposition', 'noise'} and held.imu is not None
    assert held.imu.accelerometer


@pytest.mark.parametrize('fmt', ['kalibr', 'openvins'])
def test_the_file_exports_and_the_consumers_reader_reads_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], calibrated_with_noise: Path,
        fmt: str) -> None:
    out_file = tmp_path / f'{fmt}.yaml'
    code, out, err = _cli(capsys, 'export', str(calibrated_with_noise), '--format', fmt,
                          '--rate-hz', '50', '--out', str(out_file))
    assert code == 0, err
    text = out_file.read_text(encoding='utf-8')
    held = load_calibration(calibrated_with_noise, handoff_schema()).values
    n_gyro = max(held[f'imu_gyro_{a}_angle_random_walk_rad_per_sqrt_s'] for a in 'xyz')
    n_acc = max(held[f'imu_accel_{a}_velocity_random_walk_m_s_per_sqrt_s'] for a in 'xyz')
    read = yaml.safe_load(text) if fmt == 'kalibr' else openvins_imu0(text)
    assert read['gyroscope_noise_density'] == pytest.approx(n_gyro, rel=1e-6)
    assert read['accelerometer_noise_density'] == pytest.approx(n_acc, rel=1e-6)
    assert read['rostopic'] == '/imu/data'
    if fmt == 'kalibr':  # Kalibr's update_rate: the stream's rate (--rate-hz), not the noise run's
        assert read['update_rate'] == pytest.approx(50.0)
    else:  # the stream is corrected upstream (imu_corrector): OpenVINS's intrinsics identity
        assert read['model'] == 'kalibr' and (read['Tw'] == np.eye(3)).all()
    assert 'a = A·r − b_a' in text  # the accelerations on /imu/data are imu_corrector's


def test_without_the_noise_run_export_names_the_noise_run_to_make(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], multiposition_file: Path) -> None:
    code, out, err = _cli(capsys, 'export', str(multiposition_file), '--format', 'kalibr',
                          '--rate-hz', '50', '--out', str(tmp_path / 'k.yaml'))
    assert code == 2 and out == ''
    assert 'carries none' not in err  # imu_corrector corrects this IMU's accelerations
    assert not (tmp_path / 'k.yaml').exists()


@pytest.mark.parametrize(('argv', 'into', 'says'), [
    (['noise', str(STATIC_IMU)], 'triad', 'the file holds a gyro triad (channels x, y, z), '
     'this run is of an IMU (sensor_msgs/Imu) sampled at 200 Hz'),
    (['calibrate', str(MULTIPOSITION), '--method', 'multiposition'], 'triad',
     'the file holds a gyro triad (channels x, y, z), this run is of an IMU (sensor_msgs/Imu)'),
    (['calibrate', str(BAGS / 'triad_two_axis_bench')], 'multiposition',
     'the file holds an IMU (sensor_msgs/Imu), this run is of a gyro triad (channels x, y, z)'),
])
def test_a_pulse_triad_and_an_imu_never_share_a_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], triad_file: Path,
        multiposition_file: Path, argv: list[str], into: str, says: str) -> None:
    target = tmp_path / 'handoff.yaml'
    shutil.copy(triad_file if into == 'triad' else multiposition_file, target)
    before = target.read_bytes()
    code, out, err = _cli(capsys, *argv, '--out', str(target))
    assert code == 2 and out == '', (code, out, err)
    (line,) = err.strip().splitlines()
    assert 'another sensor (sensor kind differs)' in line and says in line, line
    assert target.read_bytes() == before


def test_the_published_and_exported_rate_sigma_is_the_noise_runs_not_a_count_rounding(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], calibrated_with_noise: Path) -> None:
    """An IMU's rates are not integer counts: no 1/6 pulse² (1 "pulse" = 1 rad here) per sample.

    imu_corrector (Imu mode) publishes ≈ N·√f per axis at rest (was ≈ 80 rad/s at 200 Hz:
    the pulse triad's count rounding, 1/(6·Δt²) rad²/s²), and the Autoware export writes the
    largest of them.
    """
    from fake_node import FakeNode

    from gyro_calib.nodes.imu_corrector_core import ImuCorrector

    held = load_calibration(calibrated_with_noise, handoff_schema()).values
    n = np.array([held[f'imu_gyro_{a}_angle_random_walk_rad_per_sqrt_s'] for a in 'xyz'])
    corrector = ImuCorrector(FakeNode(), imu_input='/imu/raw')  # type: ignore[arg-type]
    corrector.poll_file(str(calibrated_with_noise))
    out = []
    for i in range(3):  # 200 Hz, at rest
        out += corrector.on_imu(1_000_000_000 + i * 5_000_000, (0.0, 0.0, 0.0),
                                (0.0, 0.0, 9.8), (4e-4, 0, 0, 0, 4e-4, 0, 0, 0, 4e-4))
    sigma = np.sqrt(np.diag(np.reshape(out[-1][1].covariance_rad2_s2, (3, 3))))
    assert sigma == pytest.approx(n * np.sqrt(200.0), rel=0.05)
    out_file = tmp_path / 'autoware.yaml'
    assert _cli(capsys, 'export', str(calibrated_with_noise), '--format', 'autoware',
                '--rate-hz', '200', '--out', str(out_file))[0] == 0
    params = yaml.safe_load(out_file.read_text(encoding='utf-8'))['/**']['ros__parameters']
    assert params['angular_velocity_stddev_xx'] == pytest.approx(max(sigma), rel=0.01)
