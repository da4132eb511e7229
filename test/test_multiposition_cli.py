"""``gyro-calib calibrate --method multiposition``: bags of sensor_msgs/Imu and plain files.

A bag written here from the physics (test/multiposition_physics.py), the real MPU-9150 and
Xsens recordings through ``--format``; the hand-off read back by the loader (format 4,
``imu:`` with the accelerometer); bad input refused in one line, exit 2, nothing written.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from multiposition_physics import random_unit, record

from gyro_calib.bagio import BagMessage, write_bag
from gyro_calib.cli import main
from gyro_calib.handoff import load_calibration
from sim_nodes.noise.bag_scenarios import imu_template

REAL = Path(__file__).resolve().parent / 'data' / 'real'
IMU = 'sensor_msgs/msg/Imu'
START_NS = 1_700_000_000_000_000_000


def imu_bag(path: Path, t_s: np.ndarray, gyro: np.ndarray, acc: np.ndarray,
            topic: str = '/imu/data') -> Path:
    """A rosbag2 MCAP bag of sensor_msgs/Imu at the given stamps (s from START_NS)."""
    template, accel_offset = imu_template('imu')
    stamps = START_NS + np.round(t_s * 1e9).astype(np.int64)
    rows = template.rows(stamps, gyro)
    at = template.value_at + accel_offset
    rows[:, at:at + 24] = np.ascontiguousarray(acc.astype('<f8')).view(np.uint8).reshape(
        len(stamps), 24)
    write_bag(path, [BagMessage(topic, int(s), r.tobytes()) for s, r in zip(stamps, rows)],
              types={topic: IMU})
    return path


@pytest.fixture(scope='module')
def hand_turned(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any, np.ndarray]:
    """A bag of a hand-turned IMU at 100 Hz, its unit's truth and mean gyro bias."""
    rng = np.random.default_rng(7)
    unit = random_unit(rng)
    t, acc, gyro, mean_bias = record(unit, rng, rate_hz=100.0)
    return imu_bag(tmp_path_factory.mktemp('mp') / 'turned', t, gyro, acc), unit, mean_bias


def run(capsys: pytest.CaptureFixture[str], *argv: Any) -> tuple[int, str, str]:
    status = main(['calibrate', *map(str, argv), '--no-progress'])
    out = capsys.readouterr()
    return status, out.out, out.err


def test_a_bag_of_imu_messages_gives_the_imu_section(
        hand_turned: tuple[Path, Any, np.ndarray], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Summary with the conditioning; the hand-off's imu: holds M, b and the accelerometer."""
    bag, unit, mean_bias = hand_turned
    out = tmp_path / 'handoff.yaml'
    status, text, _ = run(capsys, bag, '--method', 'multiposition', '--latitude-deg', '45',
                          '--out', out)
    assert status == 0
    assert 'conditioning: accelerometer: 18 poses' in text
    assert 'conditioning: gyro: 17 motions' in text
    cal = load_calibration(out)
    imu = cal.imu
    assert imu is not None and imu.pulses_to_body_rad is not None
    assert imu.bias_rad_s is not None and imu.bias_rad_s_std is not None
    m_true = np.array([[1.0, -unit.gyro_angles[0], unit.gyro_angles[1]],
                       [unit.gyro_angles[3], 1.0, -unit.gyro_angles[2]],
                       [-unit.gyro_angles[4], unit.gyro_angles[5], 1.0]]) @ np.diag(
        unit.gyro_scale)
    m_std = np.sqrt(np.diag(imu.pulses_to_body_rad_covariance)).reshape(3, 3)
    assert np.all(np.abs(imu.pulses_to_body_rad - m_true) < 5 * m_std)
    acc = imu.accelerometer
    assert acc['raw_unit'] == 'm/s²' and acc['poses'] == 18
    np.testing.assert_allclose(np.array(acc['raw_to_body']), np.array(
        [[1.0, -unit.acc_angles[0], unit.acc_angles[1]], [0.0, 1.0, -unit.acc_angles[2]],
         [0.0, 0.0, 1.0]]) @ np.diag(unit.acc_scale), atol=5e-3)
    assert abs(acc['gravity_m_s2'] - 9.80619) < 1e-4


def test_a_second_run_into_the_same_handoff_replaces_the_section(
        hand_turned: tuple[Path, Any, np.ndarray], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Run twice with the same --out: the second run's section, said in a line."""
    bag, _, _ = hand_turned
    out = tmp_path / 'handoff.yaml'
    assert run(capsys, bag, '--method', 'multiposition', '--out', out)[0] == 0
    status, text, _ = run(capsys, bag, '--method', 'multiposition', '--out', out)
    assert status == 0
    assert 'imu:' in text and load_calibration(out).imu is not None


def test_json_carries_the_covariances_and_the_conditioning(
        hand_turned: tuple[Path, Any, np.ndarray], capsys: pytest.CaptureFixture[str]) -> None:
    """--json (valid by the shipped schema): each covariance with names and ν, conditioning."""
    bag, _, _ = hand_turned
    status, text, _ = run(capsys, bag, '--method', 'multiposition', '--json')
    assert status == 0
    whole = json.loads(text)
    jsonschema = pytest.importorskip('jsonschema')
    schema = json.loads((Path(__file__).resolve().parents[1] / 'gyro_calib' / 'schema'
                         / 'result.schema.json').read_text(encoding='utf-8'))
    jsonschema.validate(whole, schema)
    doc = whole['methods']['multiposition']
    assert len(doc['conditioning']) == 2
    assert len(doc['gyro_covariance']['names']) == 12
    assert np.array(doc['accelerometer_covariance']['matrix']).shape == (9, 9)
    assert 'accelerometer' in doc['imu']


def test_the_mpu9150_log_through_format_xyz6(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """A plain log (no stamps) with its rate: calibrated, written."""
    out = tmp_path / 'mpu.yaml'
    status, text, _ = run(capsys, REAL / 'mikoff_mpu9150' / 'imu1.log.xz', '--format', 'xyz6',
                          '--rate-hz', '100', '--out', out)
    assert status == 0, text
    assert 'gyro scale_x (rad/s per rad/s)' in text
    assert load_calibration(out).imu is not None


@pytest.mark.parametrize(('argv', 'says'), [
    (['--format', 'xyz6'], '--rate-hz'),
    (['--rate-hz', '100'], '--format'),
    (['--format', 'xyz6', '--rate-hz', '100', '--method', 'triad'], 'multiposition'),
    (['--format', 'imu_tk'], 'two files'),
])
def test_bad_plain_input_is_refused_before_work(argv: list[str], says: str, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """One line naming what to do, exit 2, nothing on stdout, no file written."""
    out = tmp_path / 'h.yaml'
    status, text, err = run(capsys, REAL / 'mikoff_mpu9150' / 'imu0.log.xz', *argv,
                            '--out', out)
    assert status == 2 and text == '' and says in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_an_empty_or_wrong_file_is_refused(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    """An empty file and a file of another shape: one line each, exit 2."""
    empty = tmp_path / 'empty.log'
    empty.write_text('')
    five = tmp_path / 'five.log'
    five.write_text('1 2 3 4 5\n' * 10)
    for path in (empty, five):
        status, text, err = run(capsys, path, '--format', 'xyz6', '--rate-hz', '100')
        assert status == 2 and text == '' and str(path) in err


def test_a_bag_without_imu_messages_is_refused_before_work(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """--method multiposition on a pulse-gyro bag: one line naming what the bag holds, exit 2."""
    bag = Path(__file__).resolve().parents[1] / 'bags' / 'k_tilde_bench'
    out = tmp_path / 'h.yaml'
    status, text, err = run(capsys, bag, '--method', 'multiposition', '--out', out)
    assert status == 2 and text == '' and 'hold none' in err and '/gyro/pulses' in err
    assert not out.exists()


def test_the_ferraris_session_through_format_imucal_and_sections(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--format imucal --sections: the Ferraris variant; the hand-off holds imucal's matrices.

    With imucal's g (9.81, given in the config file) the section's A is (K_a·R_a)⁻¹ and M is
    (K_g·R_g)⁻¹ in rad/s per deg/s, from imucal 2.6.0 run here.
    """
    pd = pytest.importorskip('pandas')
    imucal = pytest.importorskip('imucal')
    import lzma

    session = REAL / 'imucal' / 'example_ferraris_session.csv.xz'
    sections = REAL / 'imucal' / 'example_ferraris_session_list.json'
    config = tmp_path / 'mp.yaml'
    config.write_text('gravity_m_s2: 9.81\n')
    out = tmp_path / 'ferraris.yaml'
    status, text, err = run(capsys, session, '--format', 'imucal', '--rate-hz', '102.4',
                            '--sections', sections, '--config', config, '--out', out)
    assert status == 0, err
    assert 'Ferraris K_g_0' in text and 'not in the uncertainty' in text
    with lzma.open(session, 'rt') as f:
        data = pd.read_csv(f, header=0, index_col=0)
    info = imucal.FerrarisCalibration().compute(
        imucal.ferraris_regions_from_section_list(data, pd.read_json(sections).T), 102.4,
        from_acc_unit='m/s^2', from_gyr_unit='deg/s')
    imu = load_calibration(out).imu
    assert imu is not None and imu.pulses_to_body_rad is not None
    np.testing.assert_allclose(np.array(imu.accelerometer['raw_to_body']),
                               np.linalg.inv(info.K_a @ info.R_a), rtol=1e-9)
    np.testing.assert_allclose(imu.pulses_to_body_rad,
                               np.linalg.inv(info.K_g @ info.R_g) * np.pi / 180, rtol=1e-9)
    assert 'gyro_g_sensitivity' in imu.missing
    status, text, err = run(capsys, REAL / 'mikoff_mpu9150' / 'imu0.log.xz', '--format', 'xyz6',
                            '--rate-hz', '100', '--sections', sections)
    assert status == 2 and text == '' and '--format imucal' in err


def test_the_advice_info_prints_runs_on_an_imu_on_another_topic(
        hand_turned: tuple[Path, Any, np.ndarray], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """``info`` advises a command that runs; ``--topic`` chooses the Imu topic read."""
    rng = np.random.default_rng(7)
    t, acc, gyro, _ = record(random_unit(rng), rng, rate_hz=100.0)
    bag = imu_bag(tmp_path / 'imu0', t, gyro, acc, topic='/sensors/imu0')
    assert main(['info', str(bag)]) == 0
    out = capsys.readouterr().out
    advice = next(line.split(maxsplit=2)[2] for line in out.splitlines()
                  if line.startswith('  multiposition '))
    assert advice == ('gyro-calib calibrate BAG --method multiposition --topic T, T one of '
                      '/sensors/imu0')
    argv = advice.split(',')[0].replace('BAG', str(bag)).replace(' T', ' /sensors/imu0')
    status, out, err = run(capsys, *argv.split()[2:], '--out', tmp_path / 'imu.yaml')
    assert status == 0, err
    assert 'gyro misalignment_yz' in out
    assert load_calibration(tmp_path / 'imu.yaml').imu is not None


def test_info_says_what_a_method_without_its_input_needs(
        hand_turned: tuple[Path, Any, np.ndarray], capsys: pytest.CaptureFixture[str]) -> None:
    """Not the garbled 'needs one of a sensor_msgs/msg/Imu topic'."""
    assert main(['info', str(Path(__file__).resolve().parents[1] / 'bags' / 'k_tilde_bench')]
                ) == 0
    out = capsys.readouterr().out
    assert 'needs one of a ' not in out
    assert '  multiposition no   needs a sensor_msgs/msg/Imu topic\n' in out


def test_a_ferraris_session_without_its_sections_is_not_reported_as_measured(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Gravity never near ±z: cond(JᵀJ) 2e11 > 1e6 (§G.5) — exit 1, one line why, no file.

    Before: exit 0 and a hand-off with `complete: true` holding gyro misalignments of 9088°.
    """
    out = tmp_path / 'imu.yaml'
    status, text, err = run(capsys, REAL / 'imucal' / 'example_ferraris_session.csv.xz',
                            '--format', 'imucal', '--rate-hz', '102.4', '--out', out)
    assert status == 1, text
    assert not out.exists() and 'nothing written' in err
    assert not re.search(r'^(accelerometer|gyro) (misalignment|scale|bias)', text,
                         re.MULTILINE)  # no parameter row
    why = next(line for line in text.splitlines()
               if line.startswith('imu.accelerometer: not measured — '))
    assert 'the poses do not determine the accelerometer' in why
    assert '> 1e+06' in why and 'gravity never came near +z, −z' in why
    assert 'Record poses with gravity near +z, −z' in why
    assert 'imu.gyro: not measured' in text
    assert 'give its section list with --sections' in text


def test_a_weak_but_determined_pose_set_still_gives_its_numbers(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """cond(JᵀJ) between max_condition (20) and the hard limit: numbers, u, conditioning line."""
    rng = np.random.default_rng(3)
    t, acc, gyro, _ = record(random_unit(rng), rng, poses=12, rate_hz=50.0)
    bag = imu_bag(tmp_path / 'weak', t, gyro, acc)
    status, text, err = run(capsys, bag, '--method', 'multiposition', '--out',
                            tmp_path / 'imu.yaml')
    assert status == 0, err
    assert 'pose set: not well-conditioned' in text and 'not measured' not in text
    conds = [float(c) for c in re.findall(r'cond\(JᵀJ\) = ([0-9.e+]+) \(columns', text)]
    assert len(conds) == 2 and max(conds) > 20 and max(conds) < 1e6, conds
    assert 'gyro misalignment_yz' in text and 'accelerometer scale_z' in text
