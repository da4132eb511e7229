"""Tracebacks and misleading lines (issue 35 §4): each is one line, exit 2, nothing written.

- ``imu.noise.<channel>`` holding text, NaN, a negative number or negative ``_std``, or an
  unknown key: one line naming the key in ``export``, ``report``, ``noise --calibration``,
  ``calibrate --out`` and ``info``, and in ``imu_corrector``'s log;
- ``simulate --seed -1``, a ``--duration-s`` that leaves no message or that the scenario's
  procedure ignores, or that its simulator cannot take;
- Ctrl-C while the command loads its modules: one line, exit 130, no traceback;
- ``noise --taus 1 --json``: exit 1 (the curves are measured), the line naming ``--taus``
  (without an output of the curves it is refused: test/test_noise_taus.py);
  ``--latitude-deg nan`` refused;
- the lines advise flags that exist: ``noise --replace``, ``calibrate --topic``;
- ``calibrate --method noise`` on a bag without a noise input: exit 2 listing the topics;
- a triad's hand-off given to ``noise --calibration`` for a single gyro: refused;
- ``--taus all`` on a long record: refused, saying its cost, before any work.
"""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import yaml
from cli_helpers import one_line, run
from fake_node import FakeNode
from ros_in_process import init_undiscovered

from gyro_calib.cli import main
from gyro_calib.imu_calibration import NOISE_TERMS

ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'
TRIAD = BAGS / 'triad_two_axis_bench'
ARW = 'angle_random_walk_rad_per_sqrt_s'


def listing(directory: Path) -> list[str]:
    return sorted(str(p.relative_to(directory)) for p in directory.rglob('*'))


# -- imu.noise.<channel> ----------------------------------------------------------------------
@pytest.fixture(scope='module')
def triad_handoff(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A triad's hand-off (format 4) with channel x's noise terms, as a mapping."""
    path = tmp_path_factory.mktemp('triad') / 'imu.yaml'
    assert main(['calibrate', str(TRIAD), '--method', 'triad', '--out', str(path),
                 '--no-progress']) == 0
    data = yaml.safe_load(path.read_text(encoding='utf-8'))
    data['imu']['noise'] = {'x': {ARW: 1.0e-6, f'{ARW}_std': 1.0e-8, f'{ARW}_dof': 30.0}}
    return dict(data)


BAD_NOISE = {
    'text': (ARW, 'abc', f"imu.noise.x.{ARW} = 'abc' is invalid: it must be a finite number"),
    'NaN': (ARW, float('nan'), f'imu.noise.x.{ARW} = nan is invalid'),
    'negative': (ARW, -1.0e-6, f'imu.noise.x.{ARW} = -1e-06 is invalid'),
    'negative std': (f'{ARW}_std', -1.0e-8, f'imu.noise.x.{ARW}_std = -1e-08 is invalid'),
    'unknown key': ('angle_random_walk', 1.0e-6,
                    "imu.noise.x has an unknown key 'angle_random_walk' (did you mean"),
}
"""Hand edits of ``imu.noise.x``: (key, value, what the one line says)."""

DOORS = {
    'export': lambda f, out: ['export', f, '--format', 'kalibr', '--out', out / 'kalibr.yaml'],
    'report': lambda f, out: ['report', f, '--out', out / 'cert', '--no-pdf'],
    'noise --calibration': lambda f, out: ['noise', TRIAD, '--topic', '/imu/pulses',
                                           '--calibration', f, '--out', out / 'n.yaml'],
    'calibrate --out': lambda f, out: ['calibrate', TRIAD, '--method', 'triad', '--out', f],
    'info': lambda f, out: ['info', TRIAD, '--calibration', f],
}


def test_a_triad_channels_noise_keys_are_the_single_gyro_keys() -> None:
    from gyro_calib.noise.keys import SINGLE_GYRO_KEYS

    assert NOISE_TERMS == tuple(k.name for k in SINGLE_GYRO_KEYS)


@pytest.mark.parametrize('door', list(DOORS))
@pytest.mark.parametrize('edit', list(BAD_NOISE))
def test_a_bad_imu_noise_entry_is_one_line_in_every_front_door(
        edit: str, door: str, triad_handoff: dict[str, Any], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    key, value, says = BAD_NOISE[edit]
    data = yaml.safe_load(yaml.safe_dump(triad_handoff))
    data['imu']['noise']['x'][key] = value
    handoff = tmp_path / 'imu.yaml'
    handoff.write_text(yaml.safe_dump(data, allow_unicode=True, sort_keys=False),
                       encoding='utf-8')
    before = handoff.read_bytes()
    out = tmp_path / 'out'
    out.mkdir()
    quiet = ['--no-progress'] if door in ('noise --calibration', 'calibrate --out') else []
    code, stdout, stderr = run(capsys, *DOORS[door](handoff, out), *quiet)
    assert (code, stdout) == (2, ''), stderr
    assert says in one_line(stderr)
    assert listing(out) == [] and handoff.read_bytes() == before


def test_imu_corrector_logs_the_one_line_of_a_bad_noise_entry(
        triad_handoff: dict[str, Any], tmp_path: Path) -> None:
    from gyro_calib.nodes.imu_corrector_core import ImuCorrector

    data = yaml.safe_load(yaml.safe_dump(triad_handoff))
    data['imu']['noise']['x'][ARW] = 'abc'
    handoff = tmp_path / 'imu.yaml'
    handoff.write_text(yaml.safe_dump(data, sort_keys=False), encoding='utf-8')
    node = FakeNode()
    ImuCorrector(node).poll_file(str(handoff))  # type: ignore[arg-type]
    assert any(f"imu.noise.x.{ARW} = 'abc' is invalid" in line for line in node.logger.lines), \
        node.logger.lines
    assert not any('could not convert' in line for line in node.logger.lines)


# -- simulate ---------------------------------------------------------------------------------
SIMULATE = {
    'seed -1': (['noise_rlg_static', '--seed', '-1'],
                'gyro-calib: error: --seed = -1 is invalid: a seed is an integer ≥ 0.'),
    'duration 0.001': (['noise_rlg_static', '--duration-s', '0.001'],
                       'gyro-calib: error: --duration-s 0.001 leaves scenario noise_rlg_static '
                       'no message'),
    'duration 1, IMU': (['noise_imu_static', '--duration-s', '1'],
                        'gyro-calib: error: scenario noise_imu_static cannot be simulated with '
                        'duration_s = 1.0'),
    'duration 600, procedure': (['triad_remount_bench_px', '--duration-s', '600'],
                                'gyro-calib: error: --duration-s 600 does not apply to scenario '
                                'triad_remount_bench_px: its procedure sets the record length '
                                '(out: 59.8 s)'),
}


@pytest.mark.parametrize('case', list(SIMULATE))
def test_simulate_refuses_what_it_would_not_write_as_asked(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv, says = SIMULATE[case]
    code, stdout, stderr = run(capsys, 'simulate', *argv, '--out', tmp_path / 'out')
    assert (code, stdout) == (2, '')
    assert one_line(stderr).startswith(says), stderr
    assert listing(tmp_path) == []


# -- Ctrl-C while the modules load --------------------------------------------------------------
def _interrupt_once_loaded(marker: str, argv: list[str]) -> subprocess.CompletedProcess[str]:
    """Run ``gyro-calib ARGV``; Ctrl-C as soon as ``marker`` (a shared library) is mapped."""
    child = subprocess.Popen(
        [sys.executable, '-m', 'gyro_calib.cli', *argv], stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # noqa: PLW1509
    maps = Path(f'/proc/{child.pid}/maps')
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if marker in maps.read_text():
                break
        except OSError:
            break
        assert child.poll() is None, f'{marker} was never loaded: the command ended first'
        time.sleep(0.002)
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=60)
    return subprocess.CompletedProcess(child.args, child.returncode, out, err)


@pytest.mark.parametrize('marker', ['_multiarray_umath', 'scipy/special'])
@pytest.mark.parametrize('command', ['calibrate', 'simulate'])
def test_ctrl_c_while_the_modules_load_is_one_line_and_writes_nothing(
        command: str, marker: str, tmp_path: Path) -> None:
    argv = (['calibrate', str(BAGS / 'k_tilde_bench'), '--out', str(tmp_path / 'g.yaml')]
            if command == 'calibrate' else
            ['simulate', 'noise_rlg_static', '--out', str(tmp_path / 'bag')])
    done = _interrupt_once_loaded(marker, argv)
    assert (done.returncode, done.stdout) == (130, ''), done.stderr
    assert done.stderr == 'gyro-calib: interrupted; nothing written.\n'
    assert listing(tmp_path) == []


# -- noise --taus, --latitude-deg nan ---------------------------------------------------------
def test_noise_taus_1_exits_1_naming_taus_when_the_curve_is_asked_for(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, stdout, stderr = run(capsys, 'noise', BAGS / 'noise_rlg_static', '--taus', '1',
                               '--json', '--no-progress')
    assert code == 1, stderr
    last = stderr.strip().splitlines()[-1]
    assert '--taus 1 lists 1 averaging time(s), fewer than the 8 a term fit needs' in last
    assert 'too short' not in stderr


def test_a_non_finite_number_flag_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    code, stdout, stderr = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--latitude-deg',
                               'nan')
    assert (code, stdout) == (2, '')
    assert one_line(stderr) == ("gyro-calib: error: calibrate: argument --latitude-deg: 'nan' "
                                'is not a finite number; see gyro-calib calibrate --help.')


# -- advice names flags that exist ------------------------------------------------------------
def test_noise_says_replace_and_takes_it(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    handoff = tmp_path / 'g.yaml'
    spikes = BAGS / 'noise_rlg_spikes'
    copy = tmp_path / 'noise_rlg_spikes'
    shutil.copytree(spikes, copy)
    assert run(capsys, 'noise', spikes, '--outliers', 'remove', '--out', handoff,
               '--no-progress')[0] == 0
    before = handoff.read_bytes()
    code, stdout, stderr = run(capsys, 'noise', copy, '--out', handoff, '--no-progress')
    assert (code, stdout) == (2, '') and 'give --replace' in one_line(stderr)
    assert handoff.read_bytes() == before
    code, stdout, stderr = run(capsys, 'noise', copy, '--out', handoff, '--replace',
                               '--no-progress')
    assert code == 0, stderr
    assert handoff.read_bytes() != before


def test_calibrate_says_topic_and_takes_it(capsys: pytest.CaptureFixture[str]) -> None:
    bags = (BAGS / 'k_tilde_bench', BAGS / 'fog_turntable')
    code, stdout, stderr = run(capsys, 'calibrate', *bags, '--method', 'noise', '--no-progress')
    assert (code, stdout) == (2, '') and 'choose one with --topic' in one_line(stderr)
    code, stdout, stderr = run(capsys, 'calibrate', *bags, '--method', 'noise', '--topic',
                               '/fog/output', '--json', '--no-progress')
    assert code in (0, 1), stderr
    assert 'input: /fog/output' in stderr
    code, stdout, stderr = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--topic',
                               '/gyro/pulses')
    assert (code, stdout) == (2, '')
    assert '--topic does not apply to the method(s) run here (rbrlg)' in one_line(stderr)


# -- inputs that fit no method, a triad's file, --taus all ------------------------------------
def test_calibrate_method_noise_on_a_bag_without_its_input_is_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gyro_calib.bagio import BagMessage, typestore, write_bag

    store = typestore()
    text = store.types['std_msgs/msg/String']
    bag = tmp_path / 'chatter'
    write_bag(bag, [BagMessage('/chatter', 10**9 * i,
                               store.serialize_cdr(text(data='hi'), 'std_msgs/msg/String'))
                    for i in range(1, 5)], types={'/chatter': 'std_msgs/msg/String'})
    code, stdout, stderr = run(capsys, 'calibrate', bag, '--method', 'noise', '--out',
                               tmp_path / 'g.yaml', '--no-progress')
    assert (code, stdout) == (2, '')
    line = one_line(stderr)
    assert 'method noise reads one of /gyro/pulses' in line
    assert line.endswith('they hold /chatter (std_msgs/msg/String, 4).')
    assert not (tmp_path / 'g.yaml').exists()


def test_a_triads_file_for_a_single_gyros_noise_is_refused(
        triad_handoff: dict[str, Any], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    handoff = tmp_path / 'imu.yaml'
    handoff.write_text(yaml.safe_dump(triad_handoff, sort_keys=False), encoding='utf-8')
    code, stdout, stderr = run(capsys, 'noise', BAGS / 'noise_rlg_static', '--calibration',
                               handoff, '--out', tmp_path / 'g.yaml', '--no-progress')
    assert (code, stdout) == (2, '')
    line = one_line(stderr)
    assert f"--calibration {handoff} is a triad's hand-off file" in line
    assert line.endswith('or --scale-factor-rad-per-pulse K.')
    assert not (tmp_path / 'g.yaml').exists()


def test_taus_all_on_a_long_record_says_its_cost_and_is_refused_before_work(
        capsys: pytest.CaptureFixture[str]) -> None:
    started = time.monotonic()
    code, stdout, stderr = run(capsys, 'noise', BAGS / 'noise_rlg_static', '--taus', 'all')
    assert (code, stdout) == (2, '')
    line = one_line(stderr)
    assert "--taus all on /gyro/pulses's 139000 samples" in line
    assert 'this one would take about 531 CPU minutes or more' in line
    assert line.endswith('Nothing was read.')
    assert time.monotonic() - started < 30


def test_importing_the_command_in_process_keeps_ctrl_c_as_it_was() -> None:
    """Only the command starting installs the quiet handler (not a test, not a library)."""
    import gyro_calib.cli  # noqa: F401
    from gyro_calib.startup_interrupt import _INSTALLED

    assert signal.getsignal(signal.SIGINT) not in _INSTALLED


# -- a config file's NaN / inf (issue 35 round 2) ------------------------------------------------
def _bias_of(stdout: str) -> str:
    return next(line for line in stdout.splitlines() if line.startswith('bias ω_B'))


def test_a_config_files_nan_where_it_is_the_default_is_said_and_taken_as_not_given(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A dumped parameter file holds ``latitude_deg: .nan`` (not given): taken so, and said."""
    code, plain, _ = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--no-progress')
    assert code == 0
    config = tmp_path / 'c.yaml'
    config.write_text('latitude_deg: .nan\n', encoding='utf-8')
    code, stdout, stderr = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--config', config,
                               '--no-progress')
    assert code == 0, stderr
    assert one_line(stderr) == (f'gyro-calib: note: config file {config}: latitude_deg = .nan '
                                'is its documented default: taken as not given (give a number '
                                'to set it).')
    assert _bias_of(stdout) == _bias_of(plain)  # the bag's stored latitude, as without it


BAD_CONFIG = {
    'inf latitude': ('latitude_deg: .inf\n', 'latitude_deg = .inf is not a finite number (its '
                     'default is .nan)'),
    'nan heading': ('heading_deg: .nan\n', 'heading_deg = .nan is not a finite number;'),
    'nan in a list': ('latitude_deg: [1.0, .nan]\n', 'latitude_deg = [1.0, .nan] holds a number '
                      'that is not finite'),
    'inf setting': ('revolutions_per_window: .inf\n', 'revolutions_per_window = .inf is not a '
                    'finite number (its default is 5)'),
    'nan node-only': ('process_period_s: .nan\n', 'process_period_s = .nan is not a finite '
                      'number'),
}


@pytest.mark.parametrize('case', list(BAD_CONFIG))
def test_a_config_files_nan_or_inf_anywhere_else_is_one_line_naming_the_key(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text, says = BAD_CONFIG[case]
    config = tmp_path / 'c.yaml'
    config.write_text(text, encoding='utf-8')
    code, stdout, stderr = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--config', config,
                               '--out', tmp_path / 'g.yaml', '--no-progress')
    assert (code, stdout) == (2, '')
    line = one_line(stderr)
    assert line.startswith(f'gyro-calib: error: config file {config}: {says}'), line
    assert line.endswith('give a number, or leave the key out for its default.')
    assert listing(tmp_path) == ['c.yaml']


def test_noise_takes_a_dumped_files_inf_default_and_refuses_a_nan_elsewhere(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = tmp_path / 'noise.yaml'
    config.write_text('noise_node:\n  ros__parameters:\n    fit_max_tau_s: .inf\n'
                      '    fit_min_tau_s: .nan\n', encoding='utf-8')
    code, stdout, stderr = run(capsys, 'noise', BAGS / 'noise_rlg_static', '--config', config,
                               '--out', tmp_path / 'g.yaml', '--no-progress')
    assert (code, stdout) == (2, '')
    assert 'fit_min_tau_s = .nan is not a finite number' in one_line(stderr)
    config.write_text('noise_node:\n  ros__parameters:\n    fit_max_tau_s: .inf\n',
                      encoding='utf-8')
    code, stdout, stderr = run(capsys, 'noise', BAGS / 'noise_rlg_static', '--config', config,
                               '--json', '--no-progress')
    assert code == 0, stderr
    assert (f'gyro-calib: note: config file {config}: fit_max_tau_s = .inf is its documented '
            'default: the default is used') in stderr


@pytest.mark.parametrize('text, says', [
    ('latitude_deg: .inf\n', 'latitude_deg = .inf is not a finite number'),
    ('latitude_deg: .nan\n', 'latitude_deg = .nan is its documented default: taken as not '
     'given'),
])
@pytest.mark.parametrize('node', ['calibration_node', 'fog_calibration_node'])
def test_a_node_reads_the_config_file_the_same_way(node: str, text: str, says: str,
                                                   tmp_path: Path,
                                                   capfd: pytest.CaptureFixture[str]) -> None:
    """The node's ``config_file``: the same refusal, the same line (logged) as ``--config``."""
    import importlib

    import rclpy

    from gyro_calib.errors import ConfigError
    from gyro_calib.nodes.processes import ros_args

    config = tmp_path / 'c.yaml'
    config.write_text(text, encoding='utf-8')
    module, cls = {'calibration_node': ('calibration_node', 'CalibrationNode'),
                   'fog_calibration_node': ('fog_calibration_node', 'FogCalibrationNode')}[node]
    klass = getattr(importlib.import_module(f'gyro_calib.nodes.{module}'), cls)
    init_undiscovered(args=ros_args({'output_file': '', 'config_file': str(config)}))
    refused = ''
    try:
        try:
            klass().destroy_node()
        except ConfigError as exc:
            refused = str(exc)
    finally:
        rclpy.shutdown()
    logged = capfd.readouterr().err
    assert says in (refused or logged), (refused, logged)
    assert bool(refused) == ('inf' in text)


# -- bench_demo (./run.sh demo) -----------------------------------------------------------------
DEMO = {
    'pairs 0': (['--pairs', '0'], '--pairs 0 is invalid: the K̃ phase needs at least 1'),
    'speed 0': (['--speed', '0'], '--speed 0 is invalid: the real-time factor must be a '
                'positive number'),
    'speed negative': (['--speed', '-2'], '--speed -2 is invalid'),
    'speed nan': (['--speed', 'nan'], '--speed nan is invalid'),
    'seed negative': (['--seed', '-1'], '--seed -1 is invalid: a seed is an integer ≥ 0.'),
    'out a directory': (['--out', '{tmp}'], '--out {tmp} is a directory; give a file name. '
                        'Nothing was started.'),
    'out in no directory': (['--out', '{tmp}/none/g.yaml'], '--out {tmp}/none/g.yaml: the '
                            'directory {tmp}/none does not exist'),
    'out under a file': (['--out', '{tmp}/file/g.yaml'], '--out {tmp}/file/g.yaml'),
}


@pytest.mark.parametrize('case', list(DEMO))
def test_bench_demo_refuses_what_it_cannot_run_before_starting_anything(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """It waited until its timeout (minutes) with exit 1; now one line, exit 2, no node."""
    from gyro_calib.nodes import bench_demo

    def started(*args: Any, **kwargs: Any) -> None:
        raise AssertionError('a node or a DDS domain was started')

    monkeypatch.setattr(bench_demo, 'choose_domain', started)
    monkeypatch.setattr(bench_demo, 'start_node', started)
    (tmp_path / 'file').write_text('x', encoding='utf-8')
    argv, says = DEMO[case]
    code = bench_demo.main([a.format(tmp=tmp_path) for a in argv])
    out, err = capsys.readouterr()
    assert (code, out) == (2, '')
    assert one_line(err).startswith(f'bench_demo: error: {says.format(tmp=tmp_path)}'), err
    assert listing(tmp_path) == ['file']


# -- IMU spec keys naming a channel the IMU does not have -----------------------------------------
def _spec_block_of_the_docs() -> dict[str, Any]:
    text = (ROOT / 'docs' / 'certificates_imu.md').read_text(encoding='utf-8')
    block = text.split('## Spec limits for an IMU')[1].split('```yaml\n')[1].split('```')[0]
    return dict(yaml.safe_load(block))


@pytest.mark.parametrize('key, says', [
    ('imu.gy.scale_factor_rad_per_pulse', 'did you mean imu.y.scale_factor_rad_per_pulse?'),
    ('imu.x.misalignment_x_rad', 'its channels are x, y, z, its pairs x-y, y-z, z-x'),
    ('imu.y-x.non_orthogonality_rad', 'its pairs x-y, y-z, z-x'),
    ('imu.noise.gz.angle_random_walk_rad_per_sqrt_s',
     'did you mean imu.noise.z.angle_random_walk_rad_per_sqrt_s?'),
])
def test_an_imu_spec_key_naming_no_channel_of_the_file_is_refused_before_writing(
        key: str, says: str, triad_handoff: dict[str, Any], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """A misspelt channel judged nothing (the certificate came out, exit 0): one line now."""
    handoff = tmp_path / 'imu.yaml'
    handoff.write_text(yaml.safe_dump(triad_handoff, allow_unicode=True, sort_keys=False),
                       encoding='utf-8')
    spec = tmp_path / 'spec.yaml'
    spec.write_text(yaml.safe_dump({'quantities': {key: {'min': -1.0e9, 'max': 1.0e9}}}),
                    encoding='utf-8')
    out = tmp_path / 'cert'
    code, stdout, stderr = run(capsys, 'report', handoff, '--out', out, '--spec', spec,
                               '--no-pdf')
    assert (code, stdout) == (2, '')
    line = one_line(stderr)
    assert f'quantities.{key} in spec file {spec} (for {handoff}) names no quantity of this ' \
           'IMU' in line and says in line, line
    assert not out.exists()


def test_the_docs_imu_spec_names_the_committed_triads_channels(
        triad_handoff: dict[str, Any], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """docs/certificates_imu.md's example spec (it named channel ``gy``) fits its own file."""
    handoff = tmp_path / 'imu.yaml'
    handoff.write_text(yaml.safe_dump(triad_handoff, allow_unicode=True, sort_keys=False),
                       encoding='utf-8')
    spec = tmp_path / 'imu_spec.yaml'
    spec.write_text(yaml.safe_dump(_spec_block_of_the_docs(), allow_unicode=True),
                    encoding='utf-8')
    code, stdout, stderr = run(capsys, 'report', handoff, '--out', tmp_path / 'cert', '--spec',
                               spec, '--no-pdf')
    assert code == 0, stderr
    page = next((tmp_path / 'cert').glob('*.html')).read_text(encoding='utf-8')
    assert 'data-key="imu.y.scale_factor_rad_per_pulse"' in page


# -- an empty --topic -----------------------------------------------------------------------------
@pytest.mark.parametrize('argv', [
    ['noise', BAGS / 'noise_rlg_static', '--topic', ''],
    ['calibrate', BAGS / 'noise_rlg_static', '--method', 'noise', '--topic', ''],
    ['calibrate', BAGS / 'noise_rlg_static', '--method', 'noise', '--topic', ' '],
    ['info', BAGS / 'noise_rlg_static', '--topic', ''],
    ['report', '{handoff}', '--out', '{tmp}/cert', '--topic', ''],
    ['export', '{handoff}', '--format', 'kalibr', '--out', '{tmp}/k.yaml', '--topic', ''],
    ['export', '{handoff}', '--format', 'kalibr', '--out', '{tmp}/k.yaml', '--accel-topic', ''],
], ids=lambda a: ' '.join(str(x) for x in a if x in ('noise', 'calibrate', 'info', 'report',
                                                       'export', '--topic', '--accel-topic')))
def test_an_empty_topic_is_refused_not_taken_as_the_default(
        argv: list[Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--topic ""`` ran on the default input (/gyro/pulses), exit 0."""
    handoff = tmp_path / 'g.yaml'
    handoff.write_text('format_version: 3\n', encoding='utf-8')
    args = [str(a).format(handoff=handoff, tmp=tmp_path) for a in argv]
    code, stdout, stderr = run(capsys, *args)
    assert (code, stdout) == (2, '')
    flag = args[-2]
    assert one_line(stderr) == (f'gyro-calib: error: {args[0]}: argument {flag}: {args[-1]!r} is '
                                'empty: name a topic (e.g. /gyro/pulses), or leave the flag out '
                                f'for its default; see gyro-calib {args[0]} --help.')
    assert listing(tmp_path) == ['g.yaml']


# -- the count a noise term rests on --------------------------------------------------------------
@pytest.mark.parametrize('bag, samples', [
    ('noise_rlg_static', 139000 - 2),  # pulse counts in 2 gap-free segments: N − 1 rates each
    ('noise_imu_static', 100025 - 25),  # rates received less the duplicate stamps dropped
])
def test_the_noise_tables_n_is_the_number_of_rate_samples_analysed(
        bag: str, samples: int, capsys: pytest.CaptureFixture[str]) -> None:
    """The n was the phase points (samples + 1 per segment): 139000 and 100001."""
    import json

    code, stdout, stderr = run(capsys, 'noise', BAGS / bag, '--json', '--no-progress')
    assert code == 0, stderr
    doc = json.loads(stdout)['methods']['noise']
    for axis in doc['axes'].values():
        assert axis['clusters'][0] == samples  # Σ (N_i − 1) / m at m = 1
        for term in axis['results'].values():
            assert term['n'] == samples
    rows = [line for line in stderr.splitlines() if 'random walk N ' in line]
    assert rows and all(line.split()[-1] == str(samples) for line in rows), rows
