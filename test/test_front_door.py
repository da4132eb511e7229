"""One contract for every ``gyro-calib`` command (issue 17 items 8–12, 15).

- item 8: every command's ``--json`` (calibrate, noise, compensate, info) validates against
  the schema shipped in the package, ``methods.<m>.{results, missing, rejections}``;
- item 9: output paths are checked before any work, ``--plot`` names a directory for every
  command, parent directories are never created, files get the user's umask;
- item 10: no abbreviated flags; ``--calibration`` is read even when unused; a flag that
  does not apply is refused;
- item 11: ``info`` describes any bag and says what each method could do; ``methods``
  lists noise's Imu; ``--version``; ``info --json``; ``simulate`` takes the main parameters;
- item 12: a lone ``.mcap``, a ROS 1 ``.bag`` (one-line hint), a CSV/text table;
- item 15: ``β₀`` read back whole, a live-recorded bag's scenario line, an empty
  metadata.yaml, rates from header stamps, ``run.sh`` usage.

``main`` runs in-process; output is captured with capsys.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
import pytest
import yaml
from cli_helpers import one_line as one_error_line
from cli_helpers import run

import gyro_calib
from gyro_calib import bag_calibration
from gyro_calib.bagio import BagMessage, ContractMessages, bag_info, write_bag
from gyro_calib.cli import main

ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'
SCHEMA = json.loads((ROOT / 'gyro_calib' / 'schema' / 'result.schema.json').read_text())
K_RLG = 4.0859845e-06


@pytest.fixture(scope='module')
def thermal_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A hand-off file holding the thermal model of the committed chamber run."""
    path = tmp_path_factory.mktemp('model') / 'gyro.yaml'
    assert main(['calibrate', str(BAGS / 'thermal_calibration'), '--out', str(path),
                 '--no-progress']) == 0
    return path


@pytest.fixture
def umask_027() -> Iterator[None]:
    old = os.umask(0o027)
    try:
        yield
    finally:
        os.umask(old)


# -- item 8: one --json shape, validated against the shipped schema ---------------------------
def test_every_commands_json_validates_against_the_shipped_schema(
        thermal_model: Path, capsys: pytest.CaptureFixture[str]) -> None:
    runs = {
        'calibrate': ['calibrate', BAGS / 'k_tilde_bench', '--json', '--no-progress'],
        'noise': ['noise', BAGS / 'noise_rlg_static', '--json', '--no-progress'],
        'compensate': ['compensate', BAGS / 'thermal_validation', '--calibration',
                       thermal_model, '--json'],
        'info': ['info', BAGS / 'noise_imu_static', '--json'],
    }
    for command, argv in runs.items():
        code, out, _ = run(capsys, *argv)
        assert code == 0, command
        doc = json.loads(out)
        jsonschema.validate(doc, SCHEMA)
        assert doc['command'] == command
        for name, section in doc['methods'].items():
            assert {'results', 'missing', 'rejections'} <= set(section), (command, name)
    noise = json.loads(run(capsys, *runs['noise'])[1])['methods']['noise']
    assert noise['results'] and noise['axes']['gyro']['tau_s']  # the curves beside


def test_the_schema_refuses_a_document_without_the_common_shape() -> None:
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({'command': 'noise', 'bags': ['b'],
                             'methods': {'noise': {'axes': {}}}}, SCHEMA)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({'command': 'calibrate', 'bags': ['b'], 'methods': {'rbrlg': {
            'results': {'k': {'value': 1.0, 'std': 0.1}}, 'missing': {}, 'rejections': []}}},
            SCHEMA)


# -- item 9: outputs ---------------------------------------------------------------------------
def test_plot_at_an_existing_file_is_refused_before_any_work_and_nothing_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    fig = tmp_path / 'fig.png'
    fig.write_bytes(b'old')
    out = tmp_path / 'h.yaml'

    def no_work(*_: Any, **__: Any) -> None:
        raise AssertionError('the calibration ran before the output paths were checked')
    monkeypatch.setattr(bag_calibration, 'calibrate_bags', no_work)
    code, out_text, err = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--plot', fig,
                              '--out', out)
    assert code == 2 and out_text == ''
    assert '--plot' in one_error_line(err) and 'is a file' in err
    assert fig.read_bytes() == b'old' and not out.exists()


@pytest.mark.parametrize('command', ['calibrate', 'noise', 'compensate'])
def test_plot_names_a_directory_for_every_command(
        command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    extra = {'calibrate': [BAGS / 'k_tilde_bench'],
             'noise': [BAGS / 'noise_rlg_static'],
             'compensate': [BAGS / 'thermal_validation', '--calibration', tmp_path / 'x.yaml']}
    code, _, err = run(capsys, command, *extra[command], '--plot', tmp_path / 'fig.png')
    assert code == 2 and 'takes a directory' in one_error_line(err)
    assert list(tmp_path.iterdir()) == []


def test_out_in_a_missing_directory_is_refused_before_any_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bag_calibration, 'calibrate_bags',
                        lambda *a, **k: pytest.fail('work was done'))
    code, _, err = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--out',
                       tmp_path / 'missing' / 'dir' / 'gyro.yaml')
    assert code == 2 and 'does not exist' in one_error_line(err)
    assert 'does not create parent directories' in err and list(tmp_path.iterdir()) == []


def test_files_are_created_with_the_users_umask(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], umask_027: None) -> None:
    csv = tmp_path / 'imu.csv'
    rng = np.random.default_rng(3)
    n = 8000
    data = np.column_stack([np.arange(n) / 100.0, rng.normal(0, 0.03, (n, 6))])
    np.savetxt(csv, data, delimiter=',', comments='',
               header='time_s,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z')
    out = tmp_path / 'out'
    out.mkdir()
    code, _, err = run(capsys, 'noise', csv, '--kalibr', out / 'imu.yaml', '--out',
                       out / 'h.yaml', '--plot', out / 'figs', '--no-progress')
    assert code == 0, err
    for path in (out / 'imu.yaml', out / 'h.yaml', out / 'figs' / 'noise_adev.png'):
        assert path.stat().st_mode & 0o777 == 0o640, path
    assert (out / 'figs').stat().st_mode & 0o777 == 0o750


# -- item 10: flags ----------------------------------------------------------------------------
def test_abbreviated_flags_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--lat', '10')
    assert code == 2 and 'unrecognized arguments: --lat' in err


def test_the_calibration_file_is_read_even_when_no_method_run_uses_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / 'h.yaml'
    bad.write_text('not: a hand-off\n')
    code, out, err = run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--calibration', bad)
    assert code == 2 and out == '' and str(bad) in one_error_line(err)


@pytest.mark.parametrize('argv, text', [
    (['calibrate', BAGS / 'k_tilde_bench', '--sense-axis-azimuth-deg', '10'],
     '--sense-axis-azimuth-deg does not apply to the method(s) run here (rbrlg)'),
    (['noise', BAGS / 'noise_imu_static', '--scale-factor-rad-per-pulse', K_RLG],
     '--scale-factor-rad-per-pulse applies to /gyro/pulses, but the input read is /imu/data'),
])
def test_a_flag_that_does_not_apply_is_refused(
        argv: list[Any], text: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == '' and text in one_error_line(err)


# -- item 11: info, methods, --version, simulate -----------------------------------------------
@pytest.mark.parametrize('name, topic', [('noise_imu_static', '/imu/data'),
                                         ('noise_rlg_static', '/gyro/pulses')])
def test_info_describes_a_noise_bag_and_what_each_method_could_do(
        name: str, topic: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, 'info', BAGS / name)
    assert code == 0 and err == ''
    assert f'  noise    yes  gyro-calib noise BAG --topic T, T one of {topic}' in out
    assert re.search(r'^  rbrlg +no +needs .*/rate_table/joint_states', out, re.M)


def test_methods_lists_the_imu_noise_reads_and_version_prints_it(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, 'methods')
    assert code == 0
    noise = out[out.index('\nnoise '):]
    assert 'any topic (--topic)' in noise and 'sensor_msgs/msg/Imu' in noise
    code, out, _ = run(capsys, '--version')
    assert code == 0 and out.strip() == f'gyro-calib {gyro_calib.__version__}'


def test_simulate_takes_seed_duration_and_rate(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'short'
    code, _, err = run(capsys, 'simulate', 'noise_rlg_static', '--out', out, '--seed', '5',
                       '--duration-s', '20', '--sample-rate-hz', '250')
    assert code == 0, err
    info = bag_info(out)
    stored = info.scenario
    assert (stored['seed'], stored['duration_s'], stored['sample_rate_hz']) == (5, 20.0, 250.0)
    assert abs(info.topics['/gyro/pulses'].count - 20 * 250) <= 2 * 250 + 1  # less the gap
    code, _, err = run(capsys, 'simulate', 'thermal_calibration', '--out', tmp_path / 'x',
                       '--sample-rate-hz', '5')
    assert code == 2 and 'has no sample_rate_hz parameter' in one_error_line(err)
    assert not (tmp_path / 'x').exists()


# -- item 12: inputs ---------------------------------------------------------------------------
def test_a_lone_mcap_file_is_read_with_its_own_summary(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lone = tmp_path / 'run.mcap'
    shutil.copy(BAGS / 'k_tilde_bench' / 'k_tilde_bench.mcap', lone)
    code, out, err = run(capsys, 'calibrate', lone, '--json', '--no-progress')
    assert code == 0, err
    ref = json.loads(run(capsys, 'calibrate', BAGS / 'k_tilde_bench', '--json',
                         '--no-progress')[1])
    assert json.loads(out)['methods'] == ref['methods']  # bench settings come along too


def test_a_ros1_bag_gets_a_one_line_conversion_hint(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / 'run.bag'
    bag.write_bytes(b'#ROSBAG V2.0\n')
    code, _, err = run(capsys, 'info', bag)
    assert code == 2 and 'rosbags-convert --src' in one_error_line(err)


def test_a_csv_table_of_a_static_record_gives_the_noise_terms(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = np.random.default_rng(7)
    rate_hz, n, arw = 200.0, 20000, 3e-3  # white rate noise: N = σ/√f_s
    gyro = rng.normal(0.0, arw * np.sqrt(rate_hz), (n, 3))
    table = tmp_path / 'static.csv'
    np.savetxt(table, np.column_stack([np.arange(n) / rate_hz, gyro]), delimiter=',',
               header='time_s,gyro_x,gyro_y,gyro_z', comments='# a static record\n')
    code, out, err = run(capsys, 'noise', table, '--json', '--no-progress')
    assert code == 0, err
    axes = json.loads(out)['methods']['noise']['axes']
    for a in 'xyz':
        est = axes[f'gyro_{a}']['results']['angle_random_walk_rad_per_sqrt_s']
        assert abs(est['value'] - arw) < 4 * est['std']
    bad = tmp_path / 'bad.csv'
    bad.write_text('time_s,omega\n0,1\n')
    code, _, err = run(capsys, 'noise', bad)
    assert code == 2 and 'unknown column(s) omega' in one_error_line(err)


# -- item 15: small ones -----------------------------------------------------------------------
def test_info_shows_the_stored_description_whole(capsys: pytest.CaptureFixture[str]) -> None:
    assert bag_info(BAGS / 'theta_four_position').scenario['description'].endswith(
        'four stations β₀ + k·90°.')


def test_a_scenario_with_a_folded_unicode_line_round_trips(tmp_path: Path) -> None:
    scenario = {'description': 'β₀ ' * 60 + '— K̃ ' * 40, 'bench': {'latitude_deg': 28.2}}
    path = tmp_path / 'b'
    write_bag(path, [BagMessage('/gyro/pulses', 1, ContractMessages().joint_state(1, 'g', 0.0))],
              scenario=scenario)
    assert bag_info(path).scenario == scenario


def _live_bag(path: Path, scenario: dict[str, Any]) -> Path:
    """A 1 kHz gyro recorded live: log (receive) times bunched in 10 ms bursts."""
    cm = ContractMessages()
    msgs = [BagMessage('/gyro/pulses', 10**9 + (i // 20) * 10_000_000,
                       cm.joint_state(10**9 + i * 1_000_000, 'gyro', float(i)))
            for i in range(2001)]
    write_bag(path, msgs, scenario=scenario)
    return path


def test_info_rates_come_from_header_stamps_and_a_live_bag_has_no_question_mark(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _live_bag(tmp_path / 'live', {'bench': {'latitude_deg': 45.0}})
    code, out, _ = run(capsys, 'info', bag)
    assert code == 0
    line = next(ln for ln in out.splitlines() if ln.startswith('/gyro/pulses'))
    assert ' 1000.0  (header stamps' in line
    assert 'scenario: none named (recorded live); stored bench settings: bench' in out
    assert '?' not in out


def test_an_empty_metadata_yaml_is_named_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / 'cut'
    shutil.copytree(BAGS / 'k_tilde_bench', bag)
    (bag / 'metadata.yaml').write_text('')
    code, _, err = run(capsys, 'info', bag)
    line = one_error_line(err)
    assert code == 2 and 'metadata.yaml: damaged or truncated (the file is empty)' in line
    assert 'NoneType' not in line


def test_run_sh_usage_advertises_only_the_demos_options() -> None:
    text = (ROOT / 'run.sh').read_text()
    usage = next(ln for ln in text.splitlines() if 'usage:' in ln)
    assert '--duration' not in usage
    from gyro_calib.nodes.bench_demo import parse_args

    for flag in ('--pairs', '--speed', '--seed', '--out'):
        assert flag in usage
        parse_args([flag, '1'])  # each one the demo takes


def test_scenario_metadata_is_one_line_in_metadata_yaml(tmp_path: Path) -> None:
    path = _live_bag(tmp_path / 'b', {'name': 'x', 'description': 'β₀ ' * 80})
    meta = yaml.safe_load((path / 'metadata.yaml').read_text())
    text = meta['rosbag2_bagfile_information']['custom_data']['gyro_calib.scenario']
    assert '\n' not in text and '\\u' not in text


def test_a_topic_recorded_empty_reveals_no_method_as_in_info() -> None:
    # bag_recorder opens every contract topic: a bench that published only the RBRLG topics
    # leaves /fog/output, /vibration_table/joint_states and /gyro/temperature with 0
    # messages. calibrate then ran fog on them and stopped (exit 2: '/fog/output ... is
    # missing or empty'), while info said fog could not run; both now pick the RBRLG alone.
    import dataclasses

    from gyro_calib.bag_calibration import select_methods
    from gyro_calib.bagio import TopicInfo

    info = bag_info(BAGS / 'k_tilde_bench')
    empty = {t: TopicInfo(t, ty, 0) for t, ty in (
        ('/fog/output', 'sensor_msgs/msg/JointState'),
        ('/vibration_table/joint_states', 'sensor_msgs/msg/JointState'),
        ('/gyro/temperature', 'sensor_msgs/msg/Temperature'))}
    recorded = dataclasses.replace(info, topics={**info.topics, **empty})
    assert [m.name for m in select_methods([recorded], None)] == ['rbrlg']


def test_a_hand_off_refused_after_the_calibration_leaves_nothing_on_stdout(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A hand-off refused after the calibration leaves nothing on stdout.

    The README walk-through: a thermal model merged into a file holding another gyro's
    K is refused (exit 2) after the calibration ran; the summary must not reach stdout then
    (it did), and the file stays as it was.
    """
    out = tmp_path / 'gyro.yaml'
    assert main(['calibrate', str(BAGS / 'theta_four_position'), '--out', str(out),
                 '--no-progress']) == 0
    before = out.read_bytes()
    capsys.readouterr()
    assert main(['calibrate', str(BAGS / 'thermal_validation'), '--out', str(out),
                 '--no-progress']) == 2
    captured = capsys.readouterr()
    assert captured.out == ''
    assert len(captured.err.strip().splitlines()) == 1, captured.err
    assert out.read_bytes() == before
