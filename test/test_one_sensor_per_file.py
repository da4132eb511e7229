"""One sensor per hand-off file (issue 35 item 2).

A hand-off file is one sensor's: a single-axis gyro, a gyro triad or an IMU read from
``sensor_msgs/Imu``. A run of another sensor — a MEMS IMU's noise run into a triad's file
(the Kalibr/OpenVINS export's own advice leads there), an RBRLG run into a triad's file, a
triad run into a single gyro's, a FOG run into an RLG's — is refused in one line naming what
differs (sensor kind, gyro technology, channels, sample rate), exit 2, the file untouched.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from gyro_calib.cli import main as gyro_calib_main

BAGS = Path(__file__).resolve().parent.parent / 'bags'


def _cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = gyro_calib_main([*args, '--no-progress'])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope='module')
def triad_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp('triad') / 'triad.yaml'
    assert gyro_calib_main(['calibrate', str(BAGS / 'triad_two_axis_bench'), '--out', str(path),
                            '--no-progress']) == 0
    return path


@pytest.fixture(scope='module')
def gyro_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp('gyro') / 'gyro.yaml'
    assert gyro_calib_main(['calibrate', str(BAGS / 'k_tilde_bench'), '--out', str(path),
                            '--no-progress']) == 0
    return path


@pytest.mark.parametrize(('command', 'bag', 'into', 'says'), [
    ('noise', 'noise_imu_static', 'triad', 'the file holds a gyro triad (channels x, y, z), this '
     'run is of an IMU (sensor_msgs/Imu) sampled at 200 Hz'),
    ('calibrate', 'k_tilde_bench', 'triad', 'the file holds a gyro triad (channels x, y, z), '
     'this run is of a single-axis gyro'),
    ('calibrate', 'triad_two_axis_bench', 'gyro', 'the file holds a single-axis gyro (RLG, '
     'pulse output), this run is of a gyro triad (channels x, y, z)'),
])
def test_a_run_of_another_sensor_is_refused_and_the_file_kept(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], triad_file: Path, gyro_file: Path,
        command: str, bag: str, into: str, says: str) -> None:
    target = tmp_path / 'handoff.yaml'
    shutil.copy(triad_file if into == 'triad' else gyro_file, target)
    before = target.read_bytes()
    code, out, err = _cli(capsys, command, str(BAGS / bag), '--out', str(target))
    assert code == 2 and out == '', (code, out, err)
    (line,) = err.strip().splitlines()
    assert 'another sensor (sensor kind differs)' in line and says in line, line
    assert 'one sensor per file' in line
    assert target.read_bytes() == before


def test_an_imu_sampled_at_another_rate_is_another_sensor(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / 'imu.yaml'
    assert _cli(capsys, 'noise', str(BAGS / 'noise_imu_static'), '--out', str(target))[0] == 0
    before = target.read_bytes()
    code, out, err = _cli(capsys, 'noise', str(BAGS / 'noise_imu_band_limited'), '--out',
                          str(target))
    assert code == 2 and out == ''
    assert ('another sensor (sample rate differs): the file holds an IMU (sensor_msgs/Imu) '
            'sampled at 200 Hz, this run is of an IMU (sensor_msgs/Imu) sampled at 100 Hz'
            ) in err
    assert target.read_bytes() == before


def test_the_triads_own_noise_run_still_goes_into_its_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], triad_file: Path) -> None:
    target = tmp_path / 'triad.yaml'
    shutil.copy(triad_file, target)
    code, out, err = _cli(capsys, 'noise', str(BAGS / 'triad_two_axis_bench'), '--topic',
                          '/imu/pulses', '--calibration', str(triad_file), '--out', str(target))
    assert code in (0, 1) and 'another sensor' not in err, err
    assert f'hand-off written: {target}' in out


@pytest.fixture(scope='module')
def fog_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp('fog') / 'fog.yaml'
    assert gyro_calib_main(['calibrate', str(BAGS / 'fog_turntable'), '--out', str(path),
                            '--no-progress']) == 0
    return path


RLG_WORDS = 'a single-axis gyro (RLG, pulse output)'
FOG_WORDS = 'a single-axis gyro (FOG, closed-loop counts)'


@pytest.mark.parametrize(('argv', 'into', 'says'), [
    (['calibrate', 'fog_turntable'], 'gyro', f'the file holds {RLG_WORDS}, this run is of '
     f'{FOG_WORDS}'),
    (['calibrate', 'k_tilde_bench'], 'fog', f'the file holds {FOG_WORDS}, this run is of '
     f'{RLG_WORDS}'),
    (['calibrate', 'dither_y'], 'fog', f'this run is of {RLG_WORDS}'),
    (['noise', 'noise_rlg_static'], 'fog', f'this run is of {RLG_WORDS} sampled at 500 Hz'),
])
def test_a_fog_run_never_goes_into_an_rlgs_file_nor_the_other_way(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], gyro_file: Path, fog_file: Path,
        argv: list[str], into: str, says: str) -> None:
    """Issue 35 round 2: ``calibrate --method fog … --out`` merged into an RBRLG file, exit 0."""
    target = tmp_path / 'handoff.yaml'
    shutil.copy(gyro_file if into == 'gyro' else fog_file, target)
    before = target.read_bytes()
    code, out, err = _cli(capsys, argv[0], str(BAGS / argv[1]), '--out', str(target))
    assert code == 2 and out == '', (code, out, err)
    (line,) = err.strip().splitlines()
    assert 'another sensor (gyro technology differs)' in line and says in line, line
    assert target.read_bytes() == before


def test_the_runs_of_one_rlg_share_its_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], gyro_file: Path) -> None:
    """Rbrlg + noise + dither + thermal of one RLG: one file (thermal refitted with its K)."""
    target = tmp_path / 'rlg.yaml'
    shutil.copy(gyro_file, target)
    for argv in (['noise', str(BAGS / 'noise_rlg_static')],
                 ['calibrate', str(BAGS / 'dither_y')],
                 ['calibrate', str(BAGS / 'thermal_calibration'), '--calibration', str(target)]):
        code, out, err = _cli(capsys, *argv, '--out', str(target))
        assert code == 0 and 'another sensor' not in err, (argv, err)
    from gyro_calib.handoff import load_calibration
    from gyro_calib.registry import handoff_schema

    held = load_calibration(target, handoff_schema())
    assert set(held.methods) == {'rbrlg', 'noise', 'dither', 'thermal'}
