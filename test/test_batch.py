"""``gyro-calib batch``: a fleet of gyros on Dask, as a production line runs it.

Six small gyros (committed bags: three RBRLG benches, two FOG benches, one noise record) and
one gyro whose bag is broken run on a 2-worker local cluster. Each gyro's hand-off file holds
exactly the values ``gyro-calib calibrate`` gives for that gyro alone; the broken gyro is a
row with its reason while the others finish; the fleet files hold one row per gyro and
quantity (CSV and Parquet alike), one record per gyro (JSONL) and the fleet page. A re-run
skips every unchanged gyro (files untouched) and redoes only the one whose settings changed;
``--force`` redoes all. Finally the same command runs against a separately started
``dask scheduler`` + ``dask worker`` on 127.0.0.1. Bad manifests: one line, exit 2, nothing
written.
"""

from __future__ import annotations

import csv
import io
import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from dask_helpers import in_process_client, lend_client_to_batch

from gyro_calib.batch.manifest import load_manifest
from gyro_calib.batch.run import print_summary, run_batch
from gyro_calib.cli import main
from gyro_calib.handoff import calibration_text, load_calibration
from gyro_calib.registry import handoff_schema
from gyro_calib.report.spec import load_spec

BAGS = Path(__file__).resolve().parent.parent / 'bags'
FLEET = {'R-1': ['k_tilde_bench'], 'R-2': ['fault_lock_in'], 'R-3': ['theta_four_position'],
         'F-1': ['fog_turntable'], 'F-2': ['fog_fault_short_plateau'],
         'N-1': ['noise_rlg_static']}
METHODS = {'N-1': ['noise']}


def _terminal_sigint() -> None:
    """In the child: Ctrl-C as a terminal delivers it (default action).

    Whatever the test process has: a child inherits an ignored SIGINT, and Python then never
    raises it.
    """
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _manifest(tmp: Path, extra: dict[str, Any] | None = None) -> Path:
    broken = tmp / 'broken_bag'
    broken.mkdir(exist_ok=True)
    (broken / 'metadata.yaml').write_text('rosbag2_bagfile_information: [not closed\n')
    (broken / 'broken_bag_0.mcap').write_bytes(b'\x89MCAP0\r\n' + b'\0' * 64)
    gyros = [{'id': gid, 'bags': [str(BAGS / b) for b in bags],
              **({'methods': METHODS[gid]} if gid in METHODS else {}),
              **({'settings': extra[gid]} if extra and gid in extra else {})}
             for gid, bags in FLEET.items()]
    gyros.insert(3, {'id': 'X-1', 'bags': ['broken_bag']})
    path = tmp / 'fleet.yaml'
    path.write_text(yaml.safe_dump({'gyros': gyros}), encoding='utf-8')
    return path


@pytest.fixture(scope='module')
def client() -> Iterator[Any]:
    import logging

    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      host='127.0.0.1', dashboard_address='127.0.0.1:0',
                      silence_logs=logging.CRITICAL) as cluster, \
            Client(cluster) as c:
        yield c


@pytest.fixture(scope='module')
def fleet(tmp_path_factory: pytest.TempPathFactory, client: Any) -> dict[str, Any]:
    tmp = tmp_path_factory.mktemp('fleet')
    spec_path = tmp / 'spec.yaml'
    spec_path.write_text(yaml.safe_dump({'quantities': {
        'k_tilde_rad_per_pulse': {'unit': '″/pulse', 'min': 0.8427, 'max': 0.8429},
        'fog_nonlinearity_ppm': {'max': 20.0}}}, allow_unicode=True), encoding='utf-8')
    manifest = _manifest(tmp)
    out = tmp / 'out'
    outcome = run_batch(load_manifest(manifest), out, client=client, spec=load_spec(spec_path),
                        spec_path=spec_path, pdf=False)
    return {'tmp': tmp, 'out': out, 'outcome': outcome, 'manifest': manifest,
            'spec': spec_path}


def test_each_gyro_equals_calibrating_it_alone(fleet: dict[str, Any], tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    out = fleet['out']
    for gid, bags in FLEET.items():
        alone = tmp_path / f'{gid}.yaml'
        argv = ['calibrate', *[str(BAGS / b) for b in bags], '--gyro-id', gid, '--out',
                str(alone)] + [a for m in METHODS.get(gid, []) for a in ('--method', m)]
        assert main(argv) == 0
        batch = load_calibration(out / gid / f'{gid}.yaml')
        assert batch.values == load_calibration(alone).values
        # one writer: the batch's file is in the layout `calibrate --out` writes (issue 28)
        assert (out / gid / f'{gid}.yaml').read_text(encoding='utf-8') == calibration_text(
            batch, handoff_schema())
        assert alone.read_text(encoding='utf-8') == calibration_text(
            load_calibration(alone), handoff_schema())
        assert batch.gyro_id == gid
        assert (out / gid / f'{gid}.html').exists()
    capsys.readouterr()


def test_a_broken_bag_is_its_own_row_and_the_others_finish(fleet: dict[str, Any]) -> None:
    outcome = fleet['outcome']
    status = {r['gyro_id']: r['status'] for r in outcome.records}
    assert status == {**{g: 'ok' for g in FLEET}, 'X-1': 'failed'}
    assert outcome.failed == ['X-1']
    broken = next(r for r in outcome.records if r['gyro_id'] == 'X-1')
    assert 'metadata.yaml' in broken['reason'] and 'Traceback' not in broken['reason']
    assert [r['gyro_id'] for r in outcome.records] == list(FLEET)[:3] + ['X-1'] + list(FLEET)[3:]


def test_fleet_files_one_row_per_gyro_and_quantity(fleet: dict[str, Any]) -> None:
    import pyarrow.parquet as pq

    out, outcome = fleet['out'], fleet['outcome']
    with (out / 'fleet.csv').open(encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    expected = sum(len(load_calibration(out / g / f'{g}.yaml').values) for g in FLEET)
    handoff_rows = [r for r in rows if r['in_handoff'] == 'True']
    counted = {g: {k for k in load_calibration(out / g / f'{g}.yaml').values
                   if not k.endswith(('_std', '_dof')) and k + '_std' in
                   load_calibration(out / g / f'{g}.yaml').values} for g in FLEET}
    assert len(handoff_rows) == sum(len(v) for v in counted.values()) <= expected
    for row in handoff_rows:
        assert row['key'] in counted[row['gyro_id']] and row['inputs_sha256']
        assert float(row['U']) == pytest.approx(float(row['k']) * float(row['std']))
    failed = [r for r in rows if r['gyro_id'] == 'X-1']
    assert len(failed) == 1 and failed[0]['status'] == 'failed' and failed[0]['reason']
    table = pq.read_table(out / 'fleet.parquet').to_pylist()
    assert len(table) == len(rows)
    assert [t['key'] or '' for t in table] == [r['key'] for r in rows]
    records = [json.loads(line) for line in (out / 'fleet.jsonl').read_text().splitlines()]
    assert [r['gyro_id'] for r in records] == [r['gyro_id'] for r in outcome.records]
    r1 = next(r for r in records if r['gyro_id'] == 'R-1')
    k = next(q for q in r1['certificate']['quantities'] if q['key'] == 'k_tilde_rad_per_pulse')
    assert (k['limit'], k['verdict']) == ('0.8427 … 0.8429 ″/pulse', 'PASS')
    assert r1['inputs'][str(BAGS / 'k_tilde_bench')]
    page = (out / 'fleet.html').read_text(encoding='utf-8')
    for key in ('k_tilde_rad_per_pulse', 'fog_scale_factor_counts_per_rad',
                'angle_random_walk_rad_per_sqrt_s'):
        assert f'data-key="{key}"' in page
    assert 'href="R-1/R-1.html"' in page and 'Cpk' in page and 'X-1' in page
    assert '<script' not in page


def test_a_rerun_skips_unchanged_gyros_and_redoes_a_changed_one(
        fleet: dict[str, Any], client: Any) -> None:
    out = fleet['out']
    stamps = {g: (out / g / f'{g}.html').stat().st_mtime_ns for g in FLEET}
    again = run_batch(load_manifest(fleet['manifest']), out, client=client,
                      spec=load_spec(fleet['spec']), spec_path=fleet['spec'], pdf=False)
    assert sorted(again.skipped) == sorted(FLEET)
    assert again.failed == ['X-1']  # a failed gyro is tried again
    assert {g: (out / g / f'{g}.html').stat().st_mtime_ns for g in FLEET} == stamps
    changed = _manifest(fleet['tmp'], {'R-1': {'latitude_deg': 60.0}})
    refused = run_batch(load_manifest(changed), out, client=client,
                        spec=load_spec(fleet['spec']), spec_path=fleet['spec'], pdf=False)
    assert sorted(refused.skipped) == sorted(set(FLEET) - {'R-1'})
    assert refused.failed == ['R-1', 'X-1']  # bias_rad_s moves by thousands of σ: refused
    assert (out / 'R-1' / 'R-1.html').stat().st_mtime_ns == stamps['R-1']
    third = run_batch(load_manifest(changed), out, client=client, replace=True,
                      spec=load_spec(fleet['spec']), spec_path=fleet['spec'], pdf=False)
    assert sorted(third.skipped) == sorted(set(FLEET) - {'R-1'})
    assert (out / 'R-1' / 'R-1.html').stat().st_mtime_ns != stamps['R-1']
    (r1,) = [r for r in third.records if r['gyro_id'] == 'R-1']  # old → new, said (issue 35)
    (bias,) = [line for line in r1['replaced'] if line.startswith('replaced: gyro.bias_rad_s')]
    assert ' — was ' in bias and 'combined standard uncertainties; --replace)' in bias
    summary = io.StringIO()
    print_summary(third, summary)
    assert f'  {bias}' in summary.getvalue()
    forced = run_batch(load_manifest(changed), out, client=client, spec=load_spec(fleet['spec']),
                       spec_path=fleet['spec'], pdf=False, force=True)
    assert forced.skipped == []


def test_a_rerun_under_other_settings_that_moves_a_value_beyond_5_sigma_is_refused(
        tmp_path: Path, client: Any, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """First run, manifest edited (latitude), second run: that gyro refused; --replace takes it.

    As ``calibrate`` refuses the same bag under other settings when a value moves beyond 5
    combined standard uncertainties (issue 35 item 1), so does ``batch``: the gyro's row says
    why in one line (the value, both numbers, the setting old -> new, --replace), exit 1,
    its folder untouched (hand-off, certificate, record); the other gyro is done.
    ``--replace`` takes the new values, each replacement said old → new.
    """
    lend_client_to_batch(client, monkeypatch)
    manifest, out = tmp_path / 'm.yaml', tmp_path / 'out'

    def write(latitude: float | None) -> None:
        manifest.write_text(yaml.safe_dump([
            {'id': 'R-1', 'bags': [str(BAGS / 'k_tilde_bench')],
             **({'settings': {'latitude_deg': latitude}} if latitude is not None else {})},
            {'id': 'F-1', 'bags': [str(BAGS / 'fog_turntable')]}]), encoding='utf-8')

    argv = ['batch', str(manifest), '--out', str(out), '--no-pdf', '--no-progress']
    write(None)
    assert main(argv) == 0
    capsys.readouterr()
    before = {p: p.read_bytes() for p in (out / 'R-1').iterdir()}
    write(60.0)  # the manifest edited: R-1's bench at latitude 60°
    assert main(argv) == 1
    printed = capsys.readouterr().out.splitlines()
    (row,) = [line for line in printed if line.startswith('R-1: ')]
    assert row.startswith('R-1: failed: refused: gyro.bias_rad_s would move to -2.864')
    assert ('from the 5.16045e-08 ± 1.33e-08 of R-1.yaml (' in row
            and " combined standard uncertainties): the same data under other settings "
            "(latitude_deg: 'not given' -> 60.0) — which are right? R-1/ keeps the earlier "
            "run's files; check, then give --replace to take this run's values for R-1."
            ) in row, row
    # record.json too: the next run is refused again (its fingerprint still differs)
    assert {p: p.read_bytes() for p in (out / 'R-1').iterdir()} == before
    with (out / 'fleet.csv').open(encoding='utf-8') as stream:
        rows = [r for r in csv.DictReader(stream) if r['gyro_id'] == 'R-1']
    # the fleet files keep what R-1/ holds (its earlier row), and say it was refused
    assert {(r['status'], r['this_run']) for r in rows} == {
        ('ok', row[len('R-1: failed: '):] + '; earlier results kept')}
    assert len(rows) > 1 and all(r['value'] for r in rows)
    assert main([*argv, '--replace']) == 0
    printed = capsys.readouterr().out.splitlines()
    assert 'R-1: ok' in printed
    (bias,) = [line for line in printed if line.startswith('  replaced: gyro.bias_rad_s = ')]
    assert 'combined standard uncertainties; --replace)' in bias
    assert (out / 'R-1' / 'R-1.yaml').read_bytes() != before[out / 'R-1' / 'R-1.yaml']
    assert main(argv) == 0  # and the next run, unchanged, skips it
    assert 'R-1: ok (unchanged: skipped)' in capsys.readouterr().out


def test_the_rerun_check_compares_a_triads_k_i_b_and_each_channels_terms(
        tmp_path: Path) -> None:
    """A triad's values are compared one by one (K_i per channel, b per axis, noise terms)."""
    from gyro_calib.batch.rerun import refused_move

    def handoff(k_y: float, arw_z: float) -> dict[str, Any]:
        return {'gyro': {}, 'imu': {
            'channels': ['x', 'y', 'z'],
            'scale_factor_rad_per_pulse': [4e-6, k_y, 4e-6],
            'scale_factor_rad_per_pulse_std': [1e-12, 1e-12, 1e-12],
            'bias_rad_s': [1e-6, 2e-6, 3e-6], 'bias_rad_s_std': [1e-7, 1e-7, 1e-7],
            'noise': {'z': {'angle_random_walk_rad_per_sqrt_s': arw_z,
                            'angle_random_walk_rad_per_sqrt_s_std': 1e-8}}},
            'methods': {'triad': {'source': 'bags/t', 'data_start_stamp_ns': 1,
                                  'settings': {}}}}

    path = tmp_path / 'T-1' / 'T-1.yaml'
    path.parent.mkdir()
    path.write_text(yaml.safe_dump(handoff(4e-6, 1e-6)), encoding='utf-8')
    schema = handoff_schema()
    same = yaml.safe_dump(handoff(4e-6 + 3e-12, 1e-6 + 3e-8)).encode()
    assert refused_move(path, same, schema, 'T-1') == ''  # 2.1σ apart each: taken
    moved = refused_move(path, yaml.safe_dump(handoff(4.001e-6, 2e-6)).encode(), schema, 'T-1')
    assert moved.startswith('refused: imu.scale_factor_rad_per_pulse[y] would move to '
                            '4.001e-06 ± 1e-12 from the 4e-06 ± 1e-12 of T-1.yaml (707.1 '
                            'combined standard uncertainties) (and 1 more value(s)): the same '
                            'data under the same settings'), moved


@pytest.mark.parametrize('case', ['missing manifest', 'unknown setting', 'out of range',
                                  'duplicate id', 'workers 0', 'bag path typo'])
def test_bad_manifest_is_one_line_exit_2_nothing_written(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    manifest = tmp_path / 'm.yaml'
    bag = str(BAGS / 'k_tilde_bench')
    gyros: Any = {'unknown setting': [{'id': 'A', 'bags': [bag], 'settings': {'latitud': 1.0}}],
                  'out of range': [{'id': 'A', 'bags': [bag],
                                    'settings': {'latitude_deg': 128.2}}],
                  'duplicate id': [{'id': 'A', 'bags': [bag]}, {'id': 'A', 'bags': [bag]}],
                  'workers 0': [{'id': 'A', 'bags': [bag]}],
                  'bag path typo': [{'id': 'A', 'bags': [bag]},
                                    {'id': 'B', 'bags': [str(BAGS / 'k_tilde_bnch')]}],
                  }.get(case)
    if gyros is not None:
        manifest.write_text(yaml.safe_dump(gyros), encoding='utf-8')
    argv = ['batch', str(manifest), '--out', str(tmp_path / 'out')]
    if case == 'workers 0':
        argv += ['--workers', '0']
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and len(captured.err.strip().splitlines()) == 1
    assert captured.err.startswith('gyro-calib: error:')
    assert not (tmp_path / 'out').exists()
    if case == 'bag path typo':
        assert ("gyro B: bag " in captured.err and "k_tilde_bnch does not exist (did you mean "
                "'k_tilde_bench'?)" in captured.err), captured.err


def test_manifest_csv_and_directory_forms(tmp_path: Path) -> None:
    (tmp_path / 'm.csv').write_text(
        'gyro_id,bags,methods,latitude_deg\n'
        f'A-1,{BAGS / "k_tilde_bench"},,28.2\n'
        f'N-1,{BAGS / "noise_rlg_static"},noise,\n', encoding='utf-8')
    jobs = load_manifest(tmp_path / 'm.csv')
    assert [(j.gyro_id, j.methods, j.settings) for j in jobs] == [
        ('A-1', (), {'latitude_deg': 28.2}), ('N-1', ('noise',), {})]
    fleet_dir = tmp_path / 'line'
    (fleet_dir / 'B-2').mkdir(parents=True)
    os.symlink(BAGS / 'fog_turntable', fleet_dir / 'B-2' / 'turntable')
    (fleet_dir / 'B-2' / 'settings.yaml').write_text('latitude_deg: 45.0\n')
    jobs = load_manifest(fleet_dir)
    assert [(j.gyro_id, len(j.bags), j.settings) for j in jobs] == [
        ('B-2', 1, {'latitude_deg': 45.0})]


def test_against_a_separately_started_dask_scheduler_and_worker(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scheduler_file = tmp_path / 'scheduler.json'
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(Path(__file__).resolve().parent.parent), os.environ.get('PYTHONPATH', '')])}
    dask = [sys.executable, '-m', 'distributed.cli.dask_scheduler']
    procs = [subprocess.Popen(dask + ['--host', '127.0.0.1', '--port', '0', '--no-dashboard',
                                      '--scheduler-file', str(scheduler_file)],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(scheduler_file.read_text())['address']
        assert address.startswith('tcp://127.0.0.1:')
        procs.append(subprocess.Popen(
            [sys.executable, '-m', 'distributed.cli.dask_worker', address, '--nthreads', '1',
             '--nworkers', '1', '--host', '127.0.0.1', '--no-dashboard'],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from dask.distributed import Client

        with Client(address, timeout='30s') as c:
            c.wait_for_workers(1, timeout=60)
        manifest = tmp_path / 'm.yaml'
        manifest.write_text(yaml.safe_dump([
            {'id': 'R-1', 'bags': [str(BAGS / 'k_tilde_bench')]},
            {'id': 'F-1', 'bags': [str(BAGS / 'fog_turntable')]}]), encoding='utf-8')
        out = tmp_path / 'out'
        assert main(['batch', str(manifest), '--out', str(out), '--scheduler', address]) == 0
        printed = capsys.readouterr().out
        assert 'R-1: ok' in printed and 'F-1: ok' in printed
        for gid in ('R-1', 'F-1'):
            for suffix in ('yaml', 'html', 'pdf'):
                assert (out / gid / f'{gid}.{suffix}').stat().st_size > 0
        assert (out / 'fleet.parquet').exists()
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in reversed(procs):
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def test_ctrl_c_stops_cleanly_keeps_what_finished_and_lists_every_gyro(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Ctrl-C stops cleanly, keeps what finished, and the fleet files say it was interrupted.

    SIGINT to the whole process group (as Ctrl-C at a terminal) once the first gyro is
    written: exit 130, one line on stderr (no worker traceback), the gyros that finished are
    in the fleet files with their files, every other manifest gyro is a row ``not run
    (interrupted)``, every fleet file says the run was interrupted, and no process of the run
    is left. While it runs, a second run into the same --out is refused, naming its pid.
    """
    import signal

    import pyarrow.parquet as pq

    manifest = _manifest(tmp_path)
    out = tmp_path / 'out'
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(Path(__file__).resolve().parent.parent), os.environ.get('PYTHONPATH', '')])}
    proc = subprocess.Popen(
        [sys.executable, '-m', 'gyro_calib.cli', 'batch', str(manifest), '--out', str(out),
         '--workers', '1', '--no-pdf', '--no-progress'], env=env, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=_terminal_sigint)  # noqa: PLW1509
    deadline = time.monotonic() + 120
    while not list(out.glob('*/record.json')) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert main(['batch', str(manifest), '--out', str(out)]) == 2  # the second run
    refused = capsys.readouterr()
    assert refused.out == '' and len(refused.err.strip().splitlines()) == 1
    assert f'pid {proc.pid} ' in refused.err and 'started 20' in refused.err
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130
    assert stderr.strip() == 'gyro-calib: interrupted; the gyros that finished are kept.'
    every = list(FLEET)[:3] + ['X-1'] + list(FLEET)[3:]
    with (out / 'fleet.csv').open(encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    assert list(dict.fromkeys(r['gyro_id'] for r in rows)) == every
    assert {r['fleet_run'] for r in rows} == {'interrupted'}
    not_run = {r['gyro_id'] for r in rows if r['status'] == 'not run'}
    finished = set(every) - not_run
    assert finished and not_run, (finished, not_run)
    for r in rows:
        if r['gyro_id'] in not_run:
            assert r['reason'].startswith('not run (interrupted)') and r['key'] == ''
    for gid in finished - {'X-1'}:
        assert (out / gid / f'{gid}.yaml').exists() and (out / gid / f'{gid}.html').exists()
    for gid in not_run:
        assert not (out / gid / 'record.json').exists()
    records = [json.loads(line) for line in (out / 'fleet.jsonl').read_text().splitlines()]
    assert [r['gyro_id'] for r in records] == every
    assert {r['fleet_run'] for r in records} == {'interrupted'}
    table = pq.read_table(out / 'fleet.parquet')
    assert table.schema.metadata[b'gyro_calib.fleet_run'] == b'interrupted'
    page = (out / 'fleet.html').read_text(encoding='utf-8')
    assert f'run interrupted, {len(not_run)} not run' in page and 'not a complete fleet' in page
    assert f'{len(not_run)} not run (interrupted): not counted' in page
    assert f'{len(not_run)} not run (interrupted)' in stdout
    assert not (out / 'batch.lock').exists()
    left = ''
    for _ in range(100):  # nothing of the run is left (workers, nannies, resource tracker)
        left = subprocess.run(['ps', '-o', 'pid=,cmd=', '-g', str(proc.pid)],
                              capture_output=True, text=True, check=False).stdout.strip()
        if not left:
            break
        time.sleep(0.1)
    assert not left


def _command_processes(pid: int) -> list[str]:
    """The command lines of the processes ``pid`` started (empty once it has none)."""
    import psutil

    try:
        children = psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []
    lines = []
    for child in children:
        try:
            lines.append(' '.join(child.cmdline()))
        except psutil.Error:
            continue
    return lines


@pytest.mark.parametrize('moment', ['the first process it starts', 'its first worker process',
                                    0.5, 1.0, 2.0, 3.0, 5.0])
def test_ctrl_c_at_any_moment_is_exit_130_one_line_and_nothing_half_written(
        moment: str | float, tmp_path: Path) -> None:
    """Ctrl-C at any instant ends the run with exit 130 and one line, nothing half-written.

    At any instant — while the modules load, while the local cluster starts (its resource
    tracker, its workers), once it runs — the run ends with exit 130 and one line:
    ``interrupted; nothing written.`` (no --out left) before the fleet runs, ``interrupted;
    the gyros that finished are kept.`` after, with fleet files that say so and every gyro
    folder whole. Never a traceback, never a run that goes on to exit 0 (issue 35 §4: the
    cluster's start-up ignored SIGINT), never a process left. (Ctrl-C once a gyro is
    written: the test above.)
    """
    import signal

    manifest = _manifest(tmp_path)
    out = tmp_path / 'out'
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(Path(__file__).resolve().parent.parent), os.environ.get('PYTHONPATH', '')])}
    proc = subprocess.Popen(
        [sys.executable, '-m', 'gyro_calib.cli', 'batch', str(manifest), '--out', str(out),
         '--workers', '1', '--no-pdf', '--no-progress'], env=env, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=_terminal_sigint)  # noqa: PLW1509
    try:
        deadline = time.monotonic() + 120
        if isinstance(moment, float):
            time.sleep(moment)
        while isinstance(moment, str) and time.monotonic() < deadline:
            started = _command_processes(proc.pid)
            if (moment == 'the first process it starts' and started
                    or moment == 'its first worker process' and any(
                        'spawn_main' in line for line in started)):
                break
            time.sleep(0.005)
        os.killpg(proc.pid, signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, (stdout, stderr)
    assert 'Traceback' not in stdout + stderr
    if stderr == 'gyro-calib: interrupted; nothing written.\n':
        assert stdout == '' and not out.exists()
    else:
        assert stderr == 'gyro-calib: interrupted; the gyros that finished are kept.\n'
        with (out / 'fleet.csv').open(encoding='utf-8') as stream:
            assert {r['fleet_run'] for r in csv.DictReader(stream)} == {'interrupted'}
        for record in out.glob('*/record.json'):
            rec = json.loads(record.read_text(encoding='utf-8'))
            if rec['status'] == 'ok':
                assert (record.parent / f'{rec["stem"]}.yaml').exists()
                assert (record.parent / f'{rec["stem"]}.html').exists()
        assert not (out / 'batch.lock').exists()
        assert 'not run (interrupted)' in stdout
    left: list[str] = []
    for _ in range(100):  # nothing of the run is left (workers, nannies, resource tracker)
        left = subprocess.run(['ps', '-o', 'pid=,cmd=', '-g', str(proc.pid)],
                              capture_output=True, text=True, check=False).stdout.split('\n')
        left = [line for line in left if line.strip()]
        if not left:
            break
        time.sleep(0.1)
    assert not left


def test_a_lock_left_by_a_killed_run_is_taken_over_with_a_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A run killed with SIGKILL leaves batch.lock; the next run takes it over and says so."""
    import signal

    out = tmp_path / 'out'
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(Path(__file__).resolve().parent.parent), os.environ.get('PYTHONPATH', '')])}
    killed = subprocess.Popen(
        [sys.executable, '-c', 'import os, sys; from pathlib import Path; '
         'from gyro_calib.file_lock import BATCH_LOCK, DirectoryLock; '
         'DirectoryLock(Path(sys.argv[1]), "batch", name=BATCH_LOCK).acquire(); '
         'os.kill(os.getpid(), 9)', str(out)], env=env)
    assert killed.wait(timeout=60) == -signal.SIGKILL
    left = (out / 'batch.lock').read_text(encoding='utf-8').strip()
    assert left.startswith(f'gyro-calib batch, pid {killed.pid} on ') and ', started 20' in left
    manifest = _manifest(tmp_path)  # only the broken gyro: the run is short
    only_broken = [g for g in yaml.safe_load(manifest.read_text())['gyros'] if g['id'] == 'X-1']
    manifest.write_text(yaml.safe_dump(only_broken), encoding='utf-8')
    assert main(['batch', str(manifest), '--out', str(out), '--workers', '1', '--no-pdf']) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f'gyro-calib: --out {out}: taking over the lock left by {left}, a run that '
                   'ended without releasing it.']
    assert (out / 'fleet.csv').exists() and not (out / 'batch.lock').exists()


def test_fleet_page_says_a_lone_units_spread_is_not_defined() -> None:
    """A quantity measured on one unit has no spread: the page says so, not 'nan'."""
    from gyro_calib.batch.fleet import fleet_html

    record = {'gyro_id': 'G-1', 'stem': 'G-1', 'status': 'ok',
              'certificate': {'overall': '', 'quantities': [
                  {'key': 'fog_bias_rad_s', 'value': 0.5, 'unit': '°/h'}]}}
    page = fleet_html([record], {})
    assert '— (one unit)' in page and '>nan<' not in page


# --- Fleet records that never lose or misreport a gyro (issue 25 §4) ---------------------


@pytest.mark.parametrize('ids', [('A/1', 'A_1'), ('A-1', 'a-1'), ('A 1', 'A?1')])
def test_ids_sharing_a_file_stem_are_refused_before_any_work(
        ids: tuple[str, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Two ids stored under one stem (or one folder on a case-insensitive file system)."""
    manifest = tmp_path / 'm.yaml'
    manifest.write_text(yaml.safe_dump([{'id': g, 'bags': [str(BAGS / 'k_tilde_bench')]}
                                        for g in ids]), encoding='utf-8')
    assert main(['batch', str(manifest), '--out', str(tmp_path / 'out')]) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and len(captured.err.strip().splitlines()) == 1
    assert all(repr(g) in captured.err for g in ids)
    assert not (tmp_path / 'out').exists()


def test_a_gyro_id_naming_a_fleet_file_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    manifest = tmp_path / 'm.yaml'
    manifest.write_text(yaml.safe_dump([{'id': 'Fleet.HTML', 'bags': ['b']}]), encoding='utf-8')
    assert main(['batch', str(manifest), '--out', str(tmp_path / 'out')]) == 2
    assert "'Fleet.HTML'" in capsys.readouterr().err
    assert not (tmp_path / 'out').exists()


def test_a_gyro_whose_folder_holds_another_gyros_earlier_results_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``A_1`` ran before into this --out; ``A/1`` now would overwrite its files."""
    out = tmp_path / 'out'
    (out / 'A_1').mkdir(parents=True)
    earlier = json.dumps({'gyro_id': 'A_1', 'stem': 'A_1', 'status': 'ok'})
    (out / 'A_1' / 'record.json').write_text(earlier, encoding='utf-8')
    manifest = tmp_path / 'm.yaml'
    manifest.write_text(yaml.safe_dump([{'id': 'A/1', 'bags': [str(BAGS / 'k_tilde_bench')]}]),
                        encoding='utf-8')
    assert main(['batch', str(manifest), '--out', str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and len(captured.err.strip().splitlines()) == 1
    assert "'A_1'" in captured.err and "'A/1'" in captured.err
    assert sorted(p.name for p in out.rglob('*')) == ['A_1', 'record.json']
    assert (out / 'A_1' / 'record.json').read_text(encoding='utf-8') == earlier


def test_fleet_columns_are_spc_ready(fleet: dict[str, Any]) -> None:
    """SI value/std/U under the SI unit, the certificate's unit beside; numeric n, ν, limits."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from gyro_calib.units import ARCSEC_PER_RAD

    out = fleet['out']
    table = pq.read_table(out / 'fleet.parquet')
    for column in ('n', 'dof'):
        assert table.schema.field(column).type == pa.int64()
    for column in ('value', 'std', 'U', 'lsl', 'usl', 'display_value', 'display_lsl'):
        assert table.schema.field(column).type == pa.float64()
    handoff = load_calibration(out / 'R-1' / 'R-1.yaml').values
    rows = [r for r in table.to_pylist()
            if (r['gyro_id'], r['key']) == ('R-1', 'k_tilde_rad_per_pulse')]
    assert len(rows) == 1
    k = rows[0]
    assert (k['unit'], k['display_unit']) == ('rad/pulse', '″/pulse')
    assert k['value'] == handoff['k_tilde_rad_per_pulse']
    assert k['std'] == handoff['k_tilde_rad_per_pulse_std']
    assert k['display_value'] == pytest.approx(k['value'] * ARCSEC_PER_RAD, rel=1e-15)
    assert k['U'] == pytest.approx(k['k'] * k['std'])
    assert (k['display_lsl'], k['display_usl']) == (0.8427, 0.8429)
    assert k['lsl'] == pytest.approx(0.8427 / ARCSEC_PER_RAD, rel=1e-15)
    assert k['usl'] == pytest.approx(0.8429 / ARCSEC_PER_RAD, rel=1e-15)
    assert k['lsl'] < k['value'] < k['usl'] and k['limit'] == '0.8427 … 0.8429 ″/pulse'
    assert isinstance(k['n'], int) and k['n'] >= 2 and isinstance(k['dof'], int)
    assert 1 <= k['dof'] and k['k'] > 2  # ν from a few window pairs: t-factor above 2
    records = [json.loads(line) for line in (out / 'fleet.jsonl').read_text().splitlines()]
    r1 = next(r for r in records if r['gyro_id'] == 'R-1')
    q = next(q for q in r1['certificate']['quantities'] if q['key'] == 'k_tilde_rad_per_pulse')
    assert {c: q[c] for c in ('value', 'n', 'dof', 'lsl', 'display_unit')} == {
        c: k[c] for c in ('value', 'n', 'dof', 'lsl', 'display_unit')}
    assert type(q['n']) is int and type(q['dof']) is int
    assert q['value_si'] == q['value']  # the older key stays for its readers
    with (out / 'fleet.csv').open(encoding='utf-8') as stream:
        row = next(r for r in csv.DictReader(stream)
                   if (r['gyro_id'], r['key']) == ('R-1', 'k_tilde_rad_per_pulse'))
    assert float(row['value']) == k['value'] and row['n'] == str(k['n'])
    assert float(row['lsl']) == k['lsl'] and row['unit'] == 'rad/pulse'
    assert {r['fleet_run'] for r in table.to_pylist()} == {'complete'}


def test_a_quantity_stored_in_the_older_layout_reads_in_the_new_one() -> None:
    """record.json of an earlier version: value in the quoted unit, n and ν as text."""
    from gyro_calib.batch.fleet import spc_quantity
    from gyro_calib.report.spec import Limit
    from gyro_calib.units import ARCSEC_PER_RAD

    old = {'key': 'k_tilde_rad_per_pulse', 'method': 'rbrlg', 'unit': '″/pulse',
           'value': 0.8428, 'std': 2e-6, 'k': 4.3, 'U': 8.6e-6, 'n': '3', 'dof': '2',
           'limit': '≤ 0.9 ″/pulse', 'verdict': 'PASS', 'value_si': 0.8428 / ARCSEC_PER_RAD,
           'std_si': 2e-6 / ARCSEC_PER_RAD, 'in_handoff': True}
    new = spc_quantity(old, Limit('k_tilde_rad_per_pulse', '″/pulse', None, 0.9))
    assert (new['unit'], new['display_unit']) == ('rad/pulse', '″/pulse')
    assert new['value'] == old['value_si'] and new['display_value'] == pytest.approx(0.8428)
    assert new['U'] == pytest.approx(8.6e-6 / ARCSEC_PER_RAD)
    assert (new['n'], new['dof'], new['lsl'], new['display_usl']) == (3, 2, None, 0.9)
    assert spc_quantity(new) == new


def test_fleet_page_shows_the_spread_of_k_tilde_in_ppm() -> None:
    """Six gyros whose K̃ differ by about a ppm: each value and its deviation are visible."""
    from gyro_calib.batch.fleet import fleet_html

    base = 0.8427948
    offsets_ppm = [0.0, 1.0, -1.0, 2.0, -2.0, 0.5]
    records = [_gyro_record(f'G-{i}', 'k_tilde_rad_per_pulse', '″/pulse',
                            base * (1 + p * 1e-6), 2e-7) for i, p in enumerate(offsets_ppm)]
    page = fleet_html(records, {})
    shown = [f'{base * (1 + p * 1e-6):.8f}' for p in offsets_ppm]
    assert len(set(shown)) == len(shown) and all(f'>{s}<' in page for s in shown)
    assert 'deviation from the mean (ppm)' in page
    mean = sum(offsets_ppm) / len(offsets_ppm)  # u = 0.24 ppm: deviations to 0.01 ppm
    assert f'>{offsets_ppm[3] - mean:+.2f}<' in page and '>+1.92<' in page


def test_an_outlier_is_beyond_the_fleet_spread_and_its_own_2u() -> None:
    """G-5 and G-6 lie equally far out; G-5's own u covers it, G-6's does not."""
    from gyro_calib.batch.fleet import fleet_html

    values = [10.0, 10.1, 9.9, 10.05, 9.95, 13.0, 13.0]
    stds = [0.1, 0.1, 0.1, 0.1, 0.1, 2.0, 0.1]
    records = [_gyro_record(f'G-{i}', 'fog_bias_rad_s', '°/h', v, u)
               for i, (v, u) in enumerate(zip(values, stds))]
    page = fleet_html(records, {})
    outliers = page.split('class="outliers">', 1)[1].split('</td>', 1)[0]
    assert 'G-6' in outliers and 'G-5' not in outliers


def test_yield_counts_every_gyro_judged_or_failed_and_says_so() -> None:
    from gyro_calib.batch.fleet import fleet_html

    records = [_gyro_record('P-1', 'fog_bias_rad_s', '°/h', 1.0, 0.1, 'PASS'),
               _gyro_record('P-2', 'fog_bias_rad_s', '°/h', 1.0, 0.1, 'PASS'),
               _gyro_record('F-1', 'fog_bias_rad_s', '°/h', 9.0, 0.1, 'FAIL'),
               {'gyro_id': 'X-1', 'stem': 'X-1', 'status': 'failed', 'reason': 'bad bag'},
               {'gyro_id': 'Z-1', 'stem': 'Z-1', 'status': 'not run',
                'reason': 'not run (interrupted)'}]
    page = fleet_html(records, {}, interrupted=True)
    assert ('Yield 50.0 % = 2 PASS of 4 gyros judged or failed (3 judged: 2 PASS, 1 FAIL; '
            '1 failed to calibrate, counted as not passing). 1 not run (interrupted): not '
            'counted.') in page
    assert 'This run was interrupted' in page


def _gyro_record(gid: str, key: str, unit: str, value: float, std: float,
                 verdict: str = '') -> dict[str, Any]:
    """A gyro's record as an earlier run stored it (values in the quoted unit)."""
    from gyro_calib.report.units import user_unit

    f = user_unit(key).factor
    return {'gyro_id': gid, 'stem': gid, 'status': 'ok',
            'certificate': {'overall': verdict, 'quantities': [
                {'key': key, 'unit': unit, 'value': value, 'std': std, 'value_si': value / f,
                 'std_si': std / f, 'verdict': verdict, 'limit': '≤ 5 °/h' if verdict else ''}]}}


@pytest.mark.parametrize('address', ['notaurl', 'tcp://127.0.0.1:abc', 'http://127.0.0.1:8786'])
def test_a_malformed_scheduler_address_is_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], address: str) -> None:
    manifest = tmp_path / 'fleet.yaml'
    manifest.write_text(yaml.safe_dump({'gyros': [
        {'id': 'A-1', 'bags': [str(BAGS / 'k_tilde_bench')]}]}))
    status = main(['batch', str(manifest), '--out', str(tmp_path / 'out'),
                   '--scheduler', address, '--no-progress'])
    out, err = capsys.readouterr()
    assert status == 2 and out == ''
    assert len(err.strip().splitlines()) == 1 and 'tcp://HOST:PORT' in err, err
    assert not (tmp_path / 'out').exists()


def test_a_triad_gyro_gets_its_hand_off_and_certificate() -> None:
    """A triad in a fleet: the hand-off with its imu: section and the IMU's certificate.

    (It ended "failed" before issue 37; fleets of IMUs: test/test_batch_imu.py.)
    """
    from gyro_calib.batch.manifest import GyroJob
    from gyro_calib.batch.tasks import finish_gyro, plan_gyro, run_method

    job = GyroJob('IMU-1', (str(BAGS / 'triad_two_axis_bench'),), ('triad',))
    plan = plan_gyro(job, '', '', True)
    assert plan.methods == ('triad',), plan.error
    result = finish_gyro(job, plan, None, False, 'IMU-1', run_method(job, 'triad'))
    assert result.record['status'] == 'ok', result.record['reason']
    handoff = yaml.safe_load(result.files['IMU-1/IMU-1.yaml'])
    assert handoff['format_version'] == 4 and handoff['gyro_id'] == 'IMU-1'
    assert len(handoff['imu']['scale_factor_rad_per_pulse']) == 3
    assert b'IMU IMU-1' in result.files['IMU-1/IMU-1.html']
    channels = {q.get('channel') for q in result.record['certificate']['quantities']}
    assert channels == {'x', 'y', 'z'}


LAB_FILE = {'laboratory': {'name': 'Gyro Metrology Laboratory', 'address': '1 Bench Road'},
            'signatory': {'name': 'Dr A. Example', 'function': 'Head of calibration'},
            'traceability': {k: f'{k} traced, cert. T-1.' for k in (
                'rate_table', 'encoder', 'clock', 'temperature_sensors')},
            'certificate_number': 'GML-{year}-{seq:05d}', 'customer': 'ACME Nav'}


@pytest.fixture(scope='module')
def local_client() -> Iterator[Any]:
    """An in-process cluster: the tasks run in this process (monkeypatching reaches them)."""
    with in_process_client() as c:
        yield c


def _lab_fleet(tmp: Path, gyros: tuple[str, ...] = ('F-1',)) -> tuple[Any, list[Any], Path]:
    from gyro_calib.report.lab import load_lab

    out = tmp / 'out'
    out.mkdir()
    (out / 'lab.yaml').write_text(yaml.safe_dump(LAB_FILE), encoding='utf-8')
    manifest = tmp / 'fleet.csv'
    manifest.write_text('gyro_id,bags,customer\n' + ''.join(
        f'{g},{BAGS / "fog_turntable"},ACME Nav\n' for g in gyros), encoding='utf-8')
    return load_lab(out / 'lab.yaml'), load_manifest(manifest), out


def _register(out: Path) -> list[str]:
    path = out / 'certificate_numbers.tsv'
    text = path.read_text(encoding='utf-8') if path.exists() else ''
    return [line.split('\t')[1] for line in text.splitlines() if not line.startswith('#')]


def issued_number(html: Path) -> str:
    """The certificate number printed in a certificate's HTML."""
    import re

    found = re.search(r'<td id="certificate-number">([^<]*)</td>', html.read_text('utf-8'))
    assert found is not None
    return found.group(1)


@pytest.mark.parametrize('how', ['--force', 'gyro changed', 'lab file changed'])
def test_a_reissued_certificate_names_the_one_it_replaces_and_moves_its_files_aside(
        how: str, tmp_path: Path, local_client: Any,
        capsys: pytest.CaptureFixture[str]) -> None:
    import dataclasses

    from gyro_calib.batch.run import print_summary
    from gyro_calib.report.lab import load_lab

    lab, jobs, out = _lab_fleet(tmp_path)
    first = run_batch(jobs, out, client=local_client, pdf=True, lab=lab)
    old = first.records[0]['certificate']['certificate_number']
    assert old and issued_number(out / 'F-1' / 'F-1.html') == old
    assert 'replaces' not in first.records[0]
    if how == 'gyro changed':
        jobs = [dataclasses.replace(jobs[0], customer='Other Nav')]
    elif how == 'lab file changed':
        (out / 'lab.yaml').write_text(yaml.safe_dump(
            {**LAB_FILE, 'signatory': {'name': 'Dr B. Example', 'function': 'Head'}}))
        lab = load_lab(out / 'lab.yaml')
    # a re-run gyro is re-issued under a new number: never silently, never mixed
    again = run_batch(jobs, out, client=local_client, pdf=False, lab=lab,
                      force=how == '--force')
    rec, = again.records
    new = rec['certificate']['certificate_number']
    assert new != old and _register(out) == [old, new]
    assert rec['replaces'] == old
    assert json.loads((out / 'F-1' / 'record.json').read_text())['replaces'] == old
    assert issued_number(out / 'F-1' / 'F-1.html') == new
    assert not (out / 'F-1' / 'F-1.pdf').exists()  # the old PDF is not left beside the new
    kept = out / 'F-1' / 'superseded'
    assert sorted(p.name for p in kept.iterdir()) == [f'F-1-{old}.html', f'F-1-{old}.pdf']
    assert issued_number(kept / f'F-1-{old}.html') == old
    with (out / 'fleet.csv').open(encoding='utf-8') as f:
        assert {r['replaces'] for r in csv.DictReader(f)} == {old}
    line = json.loads((out / 'fleet.jsonl').read_text(encoding='utf-8').splitlines()[0])
    assert line['replaces'] == old
    assert f'replaces the issued certificate {old}' in (out / 'fleet.html').read_text()
    capsys.readouterr()
    print_summary(again)
    assert (f'F-1: ok (certificate {new} replaces the issued certificate {old}; its files '
            'moved to F-1/superseded/)') in capsys.readouterr().out


def test_a_gyro_that_fails_under_a_lab_burns_no_certificate_number(
        tmp_path: Path, local_client: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    import gyro_calib.batch.run as batch_run
    from gyro_calib.batch.tasks import MethodRun

    def failing(job: Any, method: str, hashed: Any = None) -> MethodRun:
        return MethodRun(job.gyro_id, method, error=f'{method}: the bench stopped')

    lab, jobs, out = _lab_fleet(tmp_path, ('F-1', 'F-2'))
    monkeypatch.setattr(batch_run, 'run_method', failing)
    outcome = run_batch(jobs, out, client=local_client, pdf=False, lab=lab)
    assert outcome.failed == ['F-1', 'F-2']
    assert _register(out) == []  # the finish task refused both before any number


def test_a_failure_after_the_number_is_reserved_names_the_number_in_the_row(
        tmp_path: Path, local_client: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    import gyro_calib.report.certificate as certificate

    def broken(*args: Any) -> Any:
        raise OSError('no fonts for the PDF')

    lab, jobs, out = _lab_fleet(tmp_path)
    monkeypatch.setattr(certificate, 'render_html', broken)
    outcome = run_batch(jobs, out, client=local_client, pdf=False, lab=lab)
    number, = _register(out)
    rec, = outcome.records
    assert rec['status'] == 'failed'
    assert f'certificate number {number} was reserved' in rec['reason']
    assert 'stays reserved in the register, unused' in rec['reason']
    assert 'no fonts for the PDF' in rec['reason']
    with (out / 'fleet.csv').open(encoding='utf-8') as f:
        assert number in next(csv.DictReader(f))['reason']


def test_a_rerun_that_fails_keeps_the_issued_certificate_and_says_so(
        tmp_path: Path, local_client: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    import gyro_calib.batch.run as batch_run
    from gyro_calib.batch.tasks import MethodRun

    lab, jobs, out = _lab_fleet(tmp_path)
    first = run_batch(jobs, out, client=local_client, pdf=False, lab=lab)
    old = first.records[0]['certificate']['certificate_number']
    html = (out / 'F-1' / 'F-1.html').read_bytes()
    monkeypatch.setattr(batch_run, 'run_method', lambda job, method, hashed=None: MethodRun(
        job.gyro_id, method, error=f'{method}: the bench stopped'))
    again = run_batch(jobs, out, client=local_client, pdf=False, lab=lab, force=True)
    rec, = again.records
    assert rec['status'] == 'failed' and 'replaces' not in rec
    assert rec['reason'] == (f'fog: the bench stopped; the issued certificate {old} of an '
                             'earlier run stays in F-1/ (not replaced)')
    assert (out / 'F-1' / 'F-1.html').read_bytes() == html
    assert _register(out) == [old]


def test_ctrl_c_once_every_file_is_written_prints_the_summary_and_exits_as_done(
        tmp_path: Path) -> None:
    """Ctrl-C once the fleet files are written (while the local cluster closes) is no interrupt.

    The fleet tutorial's manifest and spec; SIGINT to the process group as soon as every
    fleet file is in place and fleet.csv says ``complete``: the per-gyro lines and the
    ``written:`` lines on stdout, one stderr line saying every file was written, exit 0 —
    never ``interrupted; nothing written.`` over files it wrote (docs/howto/offline.md: a
    Ctrl-C once every file is written says so and exits as done).
    """
    import signal

    (tmp_path / 'spec.yaml').write_text(
        'decision_rule: guarded_k2\nquantities:\n'
        '  k_tilde_rad_per_pulse: {unit: ″/pulse, min: 0.8427, max: 0.8429}\n'
        '  bias_rad_s: {unit: °/h, min: -0.05, max: 0.05}\n', encoding='utf-8')
    (tmp_path / 'manifest.yaml').write_text(yaml.safe_dump({'gyros': [
        {'id': gid, 'bags': [str(BAGS / bag)], 'methods': ['rbrlg'],
         'settings': {'latitude_deg': 28.2}}
        for gid, bag in (('RLG-101', 'k_tilde_bench'), ('RLG-102', 'theta_four_position'))]}),
        encoding='utf-8')
    out = tmp_path / 'l4'
    fleet = [out / f'fleet.{ext}' for ext in ('csv', 'html', 'jsonl', 'parquet')]
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(Path(__file__).resolve().parent.parent), os.environ.get('PYTHONPATH', '')])}
    proc = subprocess.Popen(
        [sys.executable, '-m', 'gyro_calib.cli', 'batch', 'manifest.yaml', '--out', 'l4',
         '--workers', '1', '--no-pdf', '--spec', 'spec.yaml', '--no-progress'], env=env,
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True, preexec_fn=_terminal_sigint)  # noqa: PLW1509
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if all(p.exists() for p in fleet) and ',complete' in fleet[0].read_text('utf-8'):
                break
            time.sleep(0.005)
        assert proc.poll() is None, 'the run ended before the test could interrupt it'
        os.killpg(proc.pid, signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 0, (stdout, stderr)
    assert stdout.splitlines()[:3] == [
        'RLG-101: ok PASS', 'RLG-102: ok PASS', '2 gyros: 2 ok, 0 failed, 0 skipped as unchanged']
    assert {line.removeprefix('written: ') for line in stdout.splitlines()[3:]} >= {
        str(p.resolve()) for p in fleet}
    assert stderr == ('gyro-calib: interrupted after every file was written (the written: '
                      'lines above); the run is complete.\n'), stderr
    with fleet[0].open(encoding='utf-8') as stream:
        assert {r['fleet_run'] for r in csv.DictReader(stream)} == {'complete'}
    assert not (out / 'batch.lock').exists()
