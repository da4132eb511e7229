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

from gyro_calib.batch.manifest import load_manifest
from gyro_calib.batch.run import run_batch
from gyro_calib.cli import main
from gyro_calib.handoff import load_calibration
from gyro_calib.report.spec import load_spec

BAGS = Path(__file__).resolve().parent.parent / 'bags'
FLEET = {'R-1': ['k_tilde_bench'], 'R-2': ['fault_lock_in'], 'R-3': ['theta_four_position'],
         'F-1': ['fog_turntable'], 'F-2': ['fog_fault_short_plateau'],
         'N-1': ['noise_rlg_static']}
METHODS = {'N-1': ['noise']}


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
    changed = _manifest(fleet['tmp'], {'R-1': {'heading_deg': 10.0}})
    third = run_batch(load_manifest(changed), out, client=client,
                      spec=load_spec(fleet['spec']), spec_path=fleet['spec'], pdf=False)
    assert sorted(third.skipped) == sorted(set(FLEET) - {'R-1'})
    assert (out / 'R-1' / 'R-1.html').stat().st_mtime_ns != stamps['R-1']
    forced = run_batch(load_manifest(changed), out, client=client, spec=load_spec(fleet['spec']),
                       spec_path=fleet['spec'], pdf=False, force=True)
    assert forced.skipped == []


@pytest.mark.parametrize('case', ['missing manifest', 'unknown setting', 'out of range',
                                  'duplicate id', 'workers 0'])
def test_bad_manifest_is_one_line_exit_2_nothing_written(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    manifest = tmp_path / 'm.yaml'
    bag = str(BAGS / 'k_tilde_bench')
    gyros: Any = {'unknown setting': [{'id': 'A', 'bags': [bag], 'settings': {'latitud': 1.0}}],
                  'out of range': [{'id': 'A', 'bags': [bag],
                                    'settings': {'latitude_deg': 128.2}}],
                  'duplicate id': [{'id': 'A', 'bags': [bag]}, {'id': 'A', 'bags': [bag]}],
                  'workers 0': [{'id': 'A', 'bags': [bag]}]}.get(case)
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


def test_ctrl_c_stops_cleanly_and_keeps_what_finished(tmp_path: Path) -> None:
    """Ctrl-C stops cleanly and keeps what finished.

    SIGINT to the whole process group (as Ctrl-C at a terminal): exit 130, one line on
    stderr (no worker traceback), the gyros that finished are in the fleet files with their
    files, and no process of the run is left.
    """
    import signal

    manifest = _manifest(tmp_path)
    out = tmp_path / 'out'
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(Path(__file__).resolve().parent.parent), os.environ.get('PYTHONPATH', '')])}
    proc = subprocess.Popen(
        [sys.executable, '-m', 'gyro_calib.cli', 'batch', str(manifest), '--out', str(out),
         '--workers', '1', '--no-pdf', '--no-progress'], env=env, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 120
    while not list(out.glob('*/record.json')) and time.monotonic() < deadline:
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130
    assert stderr.strip() == 'gyro-calib: interrupted; the gyros that finished are kept.'
    with (out / 'fleet.csv').open(encoding='utf-8') as stream:
        listed = {r['gyro_id'] for r in csv.DictReader(stream)}
    assert listed and listed < set(FLEET) | {'X-1'}
    for gid in listed - {'X-1'}:
        assert (out / gid / f'{gid}.yaml').exists() and (out / gid / f'{gid}.html').exists()
    assert 'interrupted' in stdout
    left = ''
    for _ in range(100):  # nothing of the run is left (workers, nannies, resource tracker)
        left = subprocess.run(['ps', '-o', 'pid=,cmd=', '-g', str(proc.pid)],
                              capture_output=True, text=True, check=False).stdout.strip()
        if not left:
            break
        time.sleep(0.1)
    assert not left


def test_fleet_page_says_a_lone_units_spread_is_not_defined() -> None:
    """A quantity measured on one unit has no spread: the page says so, not 'nan'."""
    from gyro_calib.batch.fleet import fleet_html

    record = {'gyro_id': 'G-1', 'stem': 'G-1', 'status': 'ok',
              'certificate': {'overall': '', 'quantities': [
                  {'key': 'fog_bias_rad_s', 'value': 0.5, 'unit': '°/h'}]}}
    page = fleet_html([record], {})
    assert '— (one unit)' in page and '>nan<' not in page
