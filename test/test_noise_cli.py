"""``gyro-calib noise`` bad input through main().

``gyro-calib noise`` through main(): the bad-input list of issue 11, each a one-line error
with exit status 2 and nothing written or overwritten; and what a good run writes.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from gyro_calib.bagio import BagMessage, ContractMessages, write_bag
from gyro_calib.cli import main
from gyro_calib.handoff import Calibration, write_calibration
from gyro_calib.noise.kalibr import KALIBR_MARK
from gyro_calib.registry import handoff_schema
from sim_nodes.noise.bag_scenarios import imu_template

START_NS = 1_700_000_000_000_000_000
PERIOD_NS = 10_000_000  # 100 Hz
IMU = 'sensor_msgs/msg/Imu'
JOINT_STATE = 'sensor_msgs/msg/JointState'
K = 4.0e-6


def imu_messages(topic: str, t: np.ndarray, gyro: np.ndarray,
                 accel: np.ndarray) -> list[BagMessage]:
    template, accel_offset = imu_template('imu')
    rows = template.rows(t, gyro)
    at = template.value_at + accel_offset
    rows[:, at:at + 24] = np.ascontiguousarray(accel.astype('<f8')).view(np.uint8).reshape(
        len(t), 24)
    return [BagMessage(topic, int(ti), r.tobytes()) for ti, r in zip(t, rows)]


def white_imu(n: int, seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    t = START_NS + PERIOD_NS * np.arange(n, dtype=np.int64)
    return t, rng.normal(0, 3e-3, (n, 3)), rng.normal(0, 2e-2, (n, 3)) + (0, 0, 9.81)


def pulse_messages(t: np.ndarray, counts: np.ndarray,
                   topic: str = '/gyro/pulses') -> list[BagMessage]:
    cdr = ContractMessages()
    return [BagMessage(topic, int(ti), cdr.joint_state(int(ti), 'gyro', float(c)))
            for ti, c in zip(t, counts)]


def merged(*streams: list[BagMessage]) -> list[BagMessage]:
    return sorted((m for s in streams for m in s), key=lambda m: m.log_time_ns)


@pytest.fixture(scope='module')
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp('noise_bags')
    t, g, a = white_imu(4000)
    rng = np.random.default_rng(8)
    pulses = np.cumsum(1e-3 * 0.01 / K + rng.normal(0, 30.0, 4000))
    table = pulse_messages(t[::10], np.arange(400, dtype=float), '/rate_table/joint_states')
    specs: dict[str, list[BagMessage]] = {
        'imu': imu_messages('/imu/data', t, g, a),
        'imu_and_table': merged(imu_messages('/imu/data', t, g, a), table),
        'two_imus': merged(imu_messages('/imu/a', t, g, a), imu_messages('/imu/b', t, g, a)),
        'imu_short': imu_messages('/imu/data', t[:40], g[:40], a[:40]),
        'imu_constant': imu_messages('/imu/data', t, np.zeros_like(g),
                                     np.tile([0.0, 0.0, 9.81], (len(t), 1))),
        'imu_nan': imu_messages('/imu/data', t, np.full_like(g, np.nan), np.full_like(a, np.nan)),
        'imu_dead_accel': imu_messages('/imu/data', t, g, np.zeros_like(a)),
        'imu_dead_gyro_z': imu_messages('/imu/data', t, np.column_stack(
            (g[:, 0], g[:, 1], np.full(len(t), 0.0125))), a),
        'pulses': pulse_messages(t, pulses),
        'pulses_locked_in': pulse_messages(t, np.full(len(t), 5071.0)),
    }
    out = {}
    for name, messages in specs.items():
        types = {m.topic: IMU for m in messages if m.topic.startswith('/imu')}
        write_bag(root / name, messages, types=types)
        out[name] = root / name
    return out


def run(capsys: pytest.CaptureFixture[str], *argv: Any) -> tuple[int, str, str]:
    status = main(['noise', *map(str, argv), '--no-progress'])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture
def outputs(tmp_path: Path) -> dict[str, Path]:
    """Files that exist before the run.

    Files that exist before the run: a failing run must leave them as they are (the
    figure is noise_adev.png in the --plot directory; the hand-off file is one a run could
    update, so the bad input found in the data is what a run reports).
    """
    (tmp_path / 'figs').mkdir()
    files = {'kalibr': tmp_path / 'imu.yaml', 'plot': tmp_path / 'figs' / 'noise_adev.png',
             'out': tmp_path / 'handoff.yaml'}
    for path in files.values():
        path.write_text(f'before {path.name}\n')
    files['kalibr'].write_text(f'# {KALIBR_MARK} (an earlier run)\nbefore: imu.yaml\n')
    BEFORE[files['kalibr']] = files['kalibr'].read_text()  # a run may replace it: ours
    write_calibration(files['out'], Calibration({}, {}), handoff_schema())
    BEFORE[files['out']] = files['out'].read_text()
    return files


BEFORE: dict[Path, str] = {}
"""The text of each pre-existing file that is not ``before NAME``."""


def unchanged(files: dict[str, Path]) -> bool:
    return (all(p.read_text() == BEFORE.get(p, f'before {p.name}\n') for p in files.values())
            and sorted(p.name for p in files['out'].parent.iterdir())
            == ['figs', 'handoff.yaml', 'imu.yaml']
            and [p.name for p in files['plot'].parent.iterdir()] == ['noise_adev.png'])


def out_flags(files: dict[str, Path]) -> list[Any]:
    return ['--kalibr', files['kalibr'], '--plot', files['plot'].parent, '--out', files['out']]


def one_line_error(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('gyro-calib: error: '), err
    return lines[0]


@pytest.mark.parametrize('bag, extra, text', [
    ('imu', ['--topic', '/imu/dta'],
     'no topic /imu/dta in the bag(s); they hold /imu/data (sensor_msgs/msg/Imu, 4000)'),
    ('imu_and_table', ['--topic', '/rate_table/joint_states'],
     'topic /rate_table/joint_states has type sensor_msgs/msg/JointState, but gyro-calib noise '
     'reads sensor_msgs/msg/Imu there'),
    ('two_imus', [], 'several inputs to characterise (/imu/a, /imu/b); choose one with --topic'),
    ('imu_short', [], 'the record of each axis (gyro_x, gyro_y, gyro_z, accel_x, accel_y, '
     'accel_z) is too short for any noise term: 40 sample(s) received'),
    ('imu_constant', [], 'each axis (gyro_x, gyro_y, gyro_z, accel_x, accel_y) on /imu/data is '
     'constant (every finite sample equals 0.0)'),
    ('imu_nan', [], 'all 4000 samples of each axis (gyro_x, gyro_y, gyro_z, accel_x, accel_y, '
     'accel_z) on /imu/data were non-finite'),
    ('pulses', [], '/gyro/pulses needs the scale factor K to turn pulses into rad, and none '
     'was given: pass --scale-factor-rad-per-pulse K, or --calibration FILE'),
    ('pulses_locked_in', ['--scale-factor-rad-per-pulse', K],
     'A static RLG inside its lock-in band without dither gives no pulses'),
])
def test_bad_input_is_one_line_exit_2_and_nothing_is_written(
        bags: dict[str, Path], outputs: dict[str, Path], capsys: pytest.CaptureFixture[str],
        bag: str, extra: list[Any], text: str) -> None:
    flags = out_flags(outputs) if bag.startswith('imu') else ['--plot', outputs['plot'].parent,
                                                              '--out', outputs['out']]
    status, out, err = run(capsys, bags[bag], *extra, *flags)
    assert status == 2, (out, err)
    assert text in one_line_error(err)
    assert unchanged(outputs)


def test_topic_error_lists_every_topic_with_its_type(
        bags: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    status, _, err = run(capsys, bags['imu_and_table'], '--topic', '/imu')
    assert status == 2
    assert ('/imu/data (sensor_msgs/msg/Imu, 4000), /rate_table/joint_states '
            '(sensor_msgs/msg/JointState, 400)') in one_line_error(err)


@pytest.mark.parametrize('what', ['a file', 'a directory without metadata.yaml',
                                  'a missing path'])
def test_a_path_that_is_not_a_bag_is_one_line_exit_2(
        bags: dict[str, Path], outputs: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str], what: str) -> None:
    other = tmp_path.parent / f'{tmp_path.name}_input'
    other.mkdir()
    if what == 'a file':
        path = other / 'imu.yaml'
        path.write_text('not: a bag\n')
    elif what == 'a directory without metadata.yaml':
        path = other / 'dir'
        path.mkdir()
        (path / 'notes.txt').write_text('x')
    else:
        path = other / 'nowhere'
    status, _, err = run(capsys, path, *out_flags(outputs))
    assert status == 2
    line = one_line_error(err)
    assert str(path) in line
    assert ('not a rosbag2 bag (a directory with metadata.yaml and the .mcap file' in line
            or 'no such file or directory' in line)
    assert unchanged(outputs)


def test_the_mcap_file_inside_a_bag_is_read_as_the_bag(
        bags: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run(capsys, bags['imu'] / 'imu.mcap')
    assert status == 0 and 'gyro_x: angle random walk N' in out


@pytest.mark.parametrize('extra, text', [
    (['--kalibr', 'K'], "Kalibr's imu.yaml describes an IMU; /gyro/pulses is a single-axis"),
    (['--out', 'DIR'], 'is a directory; give a file name'),
    (['--kalibr', 'MISSING/imu.yaml'], 'does not exist'),
])
def test_outputs_that_cannot_be_written_are_refused_before_reading(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        extra: list[str], text: str) -> None:
    subs = {'K': str(tmp_path / 'k.yaml'), 'DIR': str(tmp_path),
            'MISSING/imu.yaml': str(tmp_path / 'missing' / 'imu.yaml')}
    status, _, err = run(capsys, bags['pulses'], '--scale-factor-rad-per-pulse', K,
                         *[subs.get(x, x) for x in extra])
    assert status == 2 and text in one_line_error(err)
    assert list(tmp_path.iterdir()) == []


def test_the_kalibr_file_and_the_handoff_file_must_not_be_the_same_file(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # The README once gave noise_node kalibr_file:=imu.yaml and output_file:=imu.yaml: the
    # Kalibr file was written, then refused as a hand-off file (exit 2, a file written).
    same = tmp_path / 'imu.yaml'
    status, out, err = run(capsys, bags['imu'], '--kalibr', same, '--out', same)
    assert status == 2 and out == ''
    assert '--kalibr and --out are the same file' in one_line_error(err)
    assert list(tmp_path.iterdir()) == []


def test_a_handoff_file_of_another_gyro_is_refused_and_nothing_is_written(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out, kalibr = tmp_path / 'handoff.yaml', tmp_path / 'imu.yaml'
    assert run(capsys, bags['imu'], '--out', out, '--gyro-id', 'imu-A')[0] == 0
    before = out.read_text()
    status, _, err = run(capsys, bags['imu'], '--out', out, '--gyro-id', 'imu-B',
                         '--kalibr', kalibr)
    assert status == 2 and "holds gyro 'imu-A'" in one_line_error(err)
    assert out.read_text() == before and not kalibr.exists()


@pytest.mark.parametrize('what, text', [
    ('empty', 'is empty'),
    ('not YAML', 'is not valid YAML'),
    ('not a hand-off', 'must hold a mapping'),
    ('another gyro', "the file holds gyro 'imu-A', this calibration is for gyro 'imu-B'"),
])
def test_an_out_file_that_cannot_be_updated_is_refused_before_any_work_naming_out(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch, what: str, text: str) -> None:
    """As calibrate: one line naming --out and what to do, exit 2, nothing written."""
    import gyro_calib.bag_calibration

    def no_work(*_: Any, **__: Any) -> None:
        raise AssertionError('the bag was calibrated before --out was checked')

    monkeypatch.setattr(gyro_calib.bag_calibration, 'calibrate_bags', no_work)
    out, kalibr = tmp_path / 'handoff.yaml', tmp_path / 'imu.yaml'
    if what == 'another gyro':
        write_calibration(out, Calibration({}, {}, gyro_id='imu-A'), handoff_schema())
    else:
        out.write_text({'empty': '', 'not YAML': 'gyro: [\n', 'not a hand-off': 'notes\n'}[what])
    before = out.read_text()
    status, stdout, err = run(capsys, bags['imu'], '--out', out, '--gyro-id', 'imu-B',
                              '--kalibr', kalibr)
    line = one_line_error(err)
    assert status == 2 and stdout == '', err
    assert line.startswith(f'gyro-calib: error: --out {out} exists and cannot be updated: ')
    assert text in line and line.endswith('Give a new path, or move the file away.'), line
    assert out.read_text() == before and sorted(tmp_path.iterdir()) == [out]


def test_kalibr_replaces_only_a_kalibr_file_gyro_calib_wrote(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Walk S6: ``--kalibr notes.txt`` replaced the user's notes, exit 0."""
    notes = tmp_path / 'notes.txt'
    notes.write_text('turntable: 10 deg/s\n')
    status, out, err = run(capsys, bags['imu'], '--kalibr', notes)
    assert status == 2 and out == ''
    line = one_line_error(err)
    assert str(notes) in line and 'new path' in line and 'remove it' in line
    assert notes.read_text() == 'turntable: 10 deg/s\n' and sorted(tmp_path.iterdir()) == [notes]
    exported = tmp_path / 'imu.yaml'  # an export --format kalibr file: the same Kalibr file
    exported.write_text('# COMPLETE Kalibr imu.yaml\n# kalibr parameters from gyro_calib '
                        'hand-off h.yaml; gyro-calib export --format kalibr.\nrostopic: /x\n')
    assert run(capsys, bags['imu'], '--kalibr', exported)[0] == 0
    assert yaml.safe_load(exported.read_text())['rostopic'] == '/imu/data'
    assert run(capsys, bags['imu'], '--kalibr', exported)[0] == 0  # its own file, a 2nd run


def test_a_good_imu_run_writes_every_file_and_prints_their_paths(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    files = {'kalibr': tmp_path / 'imu.yaml', 'plot': tmp_path / 'figs' / 'noise_adev.png',
             'out': tmp_path / 'handoff.yaml'}
    status, out, err = run(capsys, bags['imu'], '--json', *out_flags(files))
    assert status == 0, err
    doc = json.loads(out)
    assert set(doc['methods']['noise']) == {'results', 'missing', 'rejections', 'axes'}
    for what, path in (('Kalibr imu.yaml', files['kalibr']), ('figure', files['plot']),
                       ('hand-off', files['out'])):
        assert f'{what} written: {path}' in err  # the human part goes to stderr with --json
    kalibr = yaml.safe_load(files['kalibr'].read_text())
    assert kalibr['rostopic'] == '/imu/data' and kalibr['update_rate'] == pytest.approx(100.0)
    gyro_n = max(doc['methods']['noise']['axes'][f'gyro_{a}']['results'][
        'angle_random_walk_rad_per_sqrt_s']['value'] for a in 'xyz')
    assert kalibr['gyroscope_noise_density'] == pytest.approx(gyro_n, rel=1e-6)
    assert files['plot'].read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    record = yaml.safe_load(files['out'].read_text())
    n = record['gyro']['imu_gyro_z_angle_random_walk_rad_per_sqrt_s']
    assert abs(n - 3e-3 * math.sqrt(0.01)) < 4 * record['gyro'][
        'imu_gyro_z_angle_random_walk_rad_per_sqrt_s_std']
    assert not [p for p in tmp_path.iterdir() if p.name.startswith('.')]


def test_a_dead_accelerometer_is_reported_and_the_gyro_axes_still_measured(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = run(capsys, bags['imu_dead_accel'], '--out', tmp_path / 'h.yaml')
    assert status == 0, err
    assert 'accel_x: no term — accel_x on /imu/data is constant' in out
    assert 'gyro_x: angle random walk N' in out
    status, out, err = run(capsys, bags['imu_dead_accel'], '--kalibr', tmp_path / 'k.yaml',
                           '--json')
    assert status == 2 and 'accelerometer_noise_density' in err.strip().splitlines()[-1]
    assert out == ''  # a failing command prints nothing on stdout
    assert not (tmp_path / 'k.yaml').exists()


def test_kalibr_with_one_dead_gyro_axis_is_written_from_the_measured_axes(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A constant gyro_z: the file comes from gyro_x, gyro_y and says gyro_z was left out."""
    target = tmp_path / 'k.yaml'
    status, out, err = run(capsys, bags['imu_dead_gyro_z'], '--kalibr', target, '--json')
    assert status == 0, err
    json.loads(out)
    text = target.read_text()
    assert '# gyro_z left out of the Kalibr file: gyro_z on /imu/data is constant' in text
    assert 'largest of 2 axes' in text and 'left out: gyro_z' in text
    assert 'gyro_z left out of the Kalibr file' in err
    assert yaml.safe_load(text)['gyroscope_noise_density'] > 0


def test_taus_flag_gives_the_grid_asked_for(bags: dict[str, Path],
                                            capsys: pytest.CaptureFixture[str]) -> None:
    listed = [0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 10.0]
    status, out, err = run(capsys, bags['imu'], '--json', '--taus', ','.join(map(str, listed)))
    assert status == 0, err
    axes = json.loads(out)['methods']['noise']['axes']
    assert axes['gyro_x']['tau_s'] == pytest.approx(listed, rel=1e-9)
    status, out, err = run(capsys, bags['imu'], '--json')
    tau = json.loads(out)['methods']['noise']['axes']['gyro_x']['tau_s']
    for decade in (0.01, 0.1, 1.0, 10.0):  # the default grid holds the decades
        assert min(abs(v / decade - 1) for v in tau) < 1e-9
    status, out, err = run(capsys, bags['imu'], '--taus', 'fortnightly')
    assert status == 2 and '--taus' in one_line_error(err) and out == ''


README_BAG = Path(__file__).resolve().parents[1] / 'bags' / 'noise_imu_static'
"""A 500 s IMU record: the README's ``--taus 1,10,100`` fits in it, all three τ."""


def test_taus_1_10_100_names_the_setting_in_the_failing_line_and_writes_the_curves(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Three τ can never give a term (a fit needs 8): the line says so, naming --taus.

    The curves computed at the three τ are written (--out, --plot), as --json holds them.
    """
    from gyro_calib.handoff import load_calibration

    target, figures, kalibr = tmp_path / 'h.yaml', tmp_path / 'figures', tmp_path / 'imu.yaml'
    status, out, err = run(capsys, README_BAG, '--taus', '1,10,100', '--json', '--out', target,
                           '--plot', figures, '--kalibr', kalibr)
    assert status == 1, err
    last = err.strip().splitlines()[-1]
    assert last.startswith('gyro-calib: no noise term is resolved (--taus 1,10,100 lists 3 '
                           'averaging time(s), fewer than the 8 a term fit needs'), last
    assert 'no record can give a term' in last and f'hand-off {target}' in last
    assert 'no Kalibr file' in last and not kalibr.exists()
    document = json.loads(out)['methods']['noise']
    assert document['axes']['gyro_x']['tau_s'] == pytest.approx([1.0, 10.0, 100.0], rel=1e-2)
    reason = document['missing']['imu_gyro_x_angle_random_walk_rad_per_sqrt_s']
    assert 'the setting taus (--taus) lists only 3' in reason and 'longer record' not in reason
    written = load_calibration(target)
    assert written.values == {}
    curves = written.methods['noise'].deviations['gyro_x']
    assert curves['tau_s'] == document['axes']['gyro_x']['tau_s']
    assert curves['adev'] == document['axes']['gyro_x']['adev']
    assert (figures / 'noise_adev.png').stat().st_size > 0


def test_curves_without_a_term_leave_a_handoff_file_with_noise_terms_as_it_was(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The same record again with too few τ: its terms are not withdrawn for bare curves."""
    target = tmp_path / 'h.yaml'
    assert run(capsys, bags['imu'], '--out', target)[0] == 0
    before = target.read_bytes()
    status, _, err = run(capsys, bags['imu'], '--out', target, '--taus', '0.1,1,10')
    assert status == 1, err
    assert f'{target} keeps its noise terms' in err.strip().splitlines()[-1]
    assert target.read_bytes() == before


def test_a_directory_given_as_the_calibration_file_is_one_line_exit_2(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, _, err = run(capsys, bags['pulses'], '--calibration', bags['imu'],
                         '--out', tmp_path / 'h.yaml')
    assert status == 2 and f'cannot read calibration file {bags["imu"]}' in one_line_error(err)
    assert list(tmp_path.iterdir()) == []


def test_an_interrupt_after_every_file_was_written_says_so_and_exits_0(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 17 item 15: Ctrl-C landing once the files are in place is not a silent 130."""
    import gyro_calib.noise.outputs as outputs

    real = outputs.write_outputs

    def interrupted(*args: Any, **kwargs: Any) -> Any:
        real(*args, **kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(outputs, 'write_outputs', interrupted)
    target = tmp_path / 'h.yaml'
    status, out, err = run(capsys, bags['imu'], '--out', target)
    assert status == 0 and target.exists()
    assert f'interrupted after every file was written (hand-off {target})' in err



@pytest.mark.parametrize('where', ['written_line', '_flush'])
def test_an_interrupt_while_the_results_are_printed_says_so_and_exits_0(
        where: str, bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C while the results go out, every file in place: said, whole JSON, exit 0.

    README walk: it was a silent 130 with the document printed.
    """
    import gyro_calib.cli.noise as noise
    import gyro_calib.noise.outputs as outputs

    module = outputs if where == 'written_line' else noise
    real = getattr(module, where)
    calls = []

    def interrupted(*args: Any, **kwargs: Any) -> Any:  # one Ctrl-C, after the first call
        result = real(*args, **kwargs)
        calls.append(args)
        if len(calls) == 1:
            raise KeyboardInterrupt
        return result

    monkeypatch.setattr(module, where, interrupted)
    kalibr, handoff = tmp_path / 'k.yaml', tmp_path / 'h.yaml'
    status, out, err = run(capsys, bags['imu'], '--kalibr', kalibr, '--plot', tmp_path / 'np',
                           '--out', handoff, '--json')
    assert status == 0 and kalibr.exists() and handoff.exists()
    assert json.loads(out)['methods']['noise']['results']  # the whole document, once
    last = err.strip().splitlines()[-1]
    assert last.startswith('gyro-calib: interrupted after every file was written (')
    assert f'hand-off {handoff}' in last and f'Kalibr imu.yaml {kalibr}' in last
    assert f'hand-off written: {handoff}' in err

def test_the_handoff_file_holds_every_deviation_per_tau_equal_to_allantools(
        bags: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--out`` keeps the curves: ADEV, MDEV, HDEV, TOTDEV per τ with std and EDF (issue 18)."""
    import allantools

    from gyro_calib.handoff import DEVIATION_FIELDS, load_calibration

    target = tmp_path / 'h.yaml'
    status, out, err = run(capsys, bags['pulses'], '--scale-factor-rad-per-pulse', K,
                           '--out', target, '--json')
    assert status == 0, err
    axis = json.loads(out)['methods']['noise']['axes']['gyro']
    table = load_calibration(target).methods['noise'].deviations['gyro']
    assert set(table) == set(DEVIATION_FIELDS)
    assert table['unit'] == 'rad/s'
    for name in set(DEVIATION_FIELDS) - {'unit'}:
        assert table[name] == axis[name], name  # the numbers --json prints, unrounded
    rng = np.random.default_rng(8)  # the bag's pulses, as the fixture made them
    phase = K * np.cumsum(1e-3 * 0.01 / K + rng.normal(0, 30.0, 4000))
    m = np.array(table['m'], dtype=np.float64)
    for name, reference in (('adev', allantools.oadev), ('mdev', allantools.mdev),
                            ('hdev', allantools.ohdev), ('totdev', allantools.totdev)):
        tau, dev, _, _ = reference(phase, rate=100.0, data_type='phase', taus=m * 0.01)
        ours = np.array([table[name][int(np.argmin(np.abs(m * 0.01 - t)))] for t in tau])
        assert len(tau) >= 8 and np.max(np.abs(ours / dev - 1.0)) < 1e-9, name
        assert all(s is None or s > 0 for s in table[f'{name}_std'])
    # a second run merges into the file: the latest run's curves are the ones kept
    status, _, err = run(capsys, bags['pulses'], '--scale-factor-rad-per-pulse', K,
                         '--out', target, '--taus', 'octave')
    assert status == 0, err
    latest = load_calibration(target).methods['noise']
    assert min(abs(t / 0.1 - 1) for t in latest.deviations['gyro']['tau_s']) > 1e-3  # octaves
    assert all(run.deviations['gyro']['tau_s'] == table['tau_s'] for run in latest.earlier)


def test_curves_without_a_term_exit_1_and_still_write_and_print_the_curves(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Exit 1 is not bad input: the curves were measured, so ``--json``, ``--out``, ``--plot``.

    The hand-off file holds them with every term missing and its reason.
    """
    rng = np.random.default_rng(2)
    t = START_NS + PERIOD_NS * np.arange(150, dtype=np.int64)
    bag = tmp_path / 'short'
    write_bag(bag, pulse_messages(t, np.cumsum(250.0 + rng.normal(0, 30.0, 150))))
    from gyro_calib.handoff import load_calibration

    target, figures = tmp_path / 'h.yaml', tmp_path / 'figures'
    status, out, err = run(capsys, bag, '--scale-factor-rad-per-pulse', K, '--out', target,
                           '--plot', figures, '--json')
    assert status == 1, err
    last = err.strip().splitlines()[-1]
    assert 'no noise term is resolved' in last and f'hand-off {target}' in last
    axis = json.loads(out)['methods']['noise']['axes']['gyro']
    assert axis['adev'] and axis['results'] == {}
    written = load_calibration(target)
    assert written.values == {} and 'angle_random_walk_rad_per_sqrt_s' in written.missing
    assert written.methods['noise'].deviations['gyro']['adev'] == axis['adev']
    assert (figures / 'noise_adev.png').stat().st_size > 0
