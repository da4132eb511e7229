"""The fleet files across runs: they always describe what the per-gyro folders hold.

A complete run, then a second run into the same ``--out`` that is stopped by Ctrl-C before
any gyro finished (with and without ``--force``), that refuses a gyro whose values would move
beyond 5σ, or whose fleet files cannot all be written: every gyro that second run left alone
keeps its earlier row (the values its folder still holds) in fleet.csv, .parquet, .jsonl and
.html, its ``this_run`` saying what happened. A bag path typo is one line, exit 2, before any
work; under ``--scheduler`` the workers check their own paths.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from dask_helpers import in_process_client, lend_client_to_batch

from gyro_calib.cli import main

BAGS = Path(__file__).resolve().parent.parent / 'bags'
GYROS = {'R-1': 'k_tilde_bench', 'F-1': 'fog_turntable'}
FLEET_FILES = ('fleet.csv', 'fleet.parquet', 'fleet.jsonl', 'fleet.html')
RUN_COLUMNS = ('fleet_run', 'this_run')
"""The columns that say what a run did, not what a folder holds."""


@pytest.fixture(scope='module')
def local_client() -> Iterator[Any]:
    with in_process_client() as c:
        yield c


@pytest.fixture
def shared(local_client: Any, monkeypatch: pytest.MonkeyPatch) -> Any:
    lend_client_to_batch(local_client, monkeypatch)
    return local_client


def _write_manifest(path: Path, latitude: float | None = None,
                    bags: dict[str, str] | None = None) -> None:
    path.write_text(yaml.safe_dump([
        {'id': gid, 'bags': [str(BAGS / bag)],
         **({'settings': {'latitude_deg': latitude}} if latitude is not None and gid == 'R-1'
            else {})} for gid, bag in (bags or GYROS).items()]), encoding='utf-8')


def _csv_rows(out: Path) -> list[dict[str, str]]:
    with (out / 'fleet.csv').open(encoding='utf-8') as stream:
        return list(csv.DictReader(stream))


def _held(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    """The rows without the columns that say what the run did."""
    return [{k: v for k, v in r.items() if k not in RUN_COLUMNS} for r in rows]


def _complete_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[
        list[str], Path]:
    manifest, out = tmp_path / 'm.yaml', tmp_path / 'out'
    _write_manifest(manifest)
    argv = ['batch', str(manifest), '--out', str(out), '--no-pdf', '--no-progress']
    assert main(argv) == 0
    capsys.readouterr()
    rows = _csv_rows(out)
    assert {r['status'] for r in rows} == {'ok'}
    assert {r['this_run'] for r in rows} == {'calibrated'}
    return argv, out


class _StoppedAtOnce:
    """``as_completed`` whose first wait is a Ctrl-C: no gyro of the run has finished."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        pass

    def add(self, future: Any) -> None:
        pass

    def __iter__(self) -> Iterator[Any]:
        raise KeyboardInterrupt
        yield  # pragma: no cover


@pytest.mark.parametrize('flags', [[], ['--force']])
def test_ctrl_c_during_a_rerun_keeps_every_earlier_row_in_every_fleet_file(
        flags: list[str], tmp_path: Path, shared: Any, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """S4: a plain (or forced) re-run stopped at once: exit 130, nothing lost."""
    import dask.distributed
    import pyarrow.parquet as pq

    argv, out = _complete_run(tmp_path, capsys)
    before = _csv_rows(out)
    folders = {p: p.read_bytes() for g in GYROS for p in (out / g).iterdir()}
    monkeypatch.setattr(dask.distributed, 'as_completed', _StoppedAtOnce)
    assert main([*argv, *flags]) == 130
    printed = capsys.readouterr()
    assert {p: p.read_bytes() for g in GYROS for p in (out / g).iterdir()} == folders
    after = _csv_rows(out)
    assert _held(after) == _held(before)  # every value, status and reason as before
    assert 'R-1: not run (interrupted)' in printed.out
    assert ('  the fleet files keep its earlier results, as its folder R-1/ does'
            in printed.out)
    assert {r['fleet_run'] for r in after} == {'interrupted'}
    assert {r['this_run'] for r in after} == {'not run (interrupted); earlier results kept'}
    table = pq.read_table(out / 'fleet.parquet').to_pylist()
    assert [(r['gyro_id'], r['key'], r['value'], r['status']) for r in table] == [
        (r['gyro_id'], r['key'], float(r['value']) if r['value'] else None, r['status'])
        for r in before]
    records = [json.loads(line) for line in (out / 'fleet.jsonl').read_text().splitlines()]
    assert [(r['gyro_id'], r['status'], len(r['certificate']['quantities']))
            for r in records] == [(g, 'ok', len([b for b in before if b['gyro_id'] == g]))
                                  for g in GYROS]
    page = (out / 'fleet.html').read_text(encoding='utf-8')
    assert 'R-1.html' in page and 'this run: not run (interrupted); earlier results kept' in page


def test_a_refused_rerun_keeps_the_earlier_rows_and_says_it_was_refused(
        tmp_path: Path, shared: Any, capsys: pytest.CaptureFixture[str]) -> None:
    """S5: only latitude_deg changed; R-1 refused (exit 1), its earlier row stays."""
    argv, out = _complete_run(tmp_path, capsys)
    before = _csv_rows(out)
    _write_manifest(Path(argv[1]), latitude=60.0)
    assert main(argv) == 1
    printed = capsys.readouterr().out
    assert 'R-1: failed: refused: gyro.bias_rad_s would move' in printed
    after = _csv_rows(out)
    assert _held(after) == _held(before)
    this_run = {r['gyro_id']: r['this_run'] for r in after}
    assert this_run['F-1'] == 'skipped (unchanged)'
    assert this_run['R-1'].startswith('refused: gyro.bias_rad_s would move')
    assert this_run['R-1'].endswith("; earlier results kept")
    records = {json.loads(line)['gyro_id']: json.loads(line)
               for line in (out / 'fleet.jsonl').read_text().splitlines()}
    assert records['R-1']['status'] == 'ok' and records['R-1']['certificate']['quantities']
    assert records['R-1']['this_run'] == this_run['R-1']
    # --replace takes the new values: the row is this run's again
    assert main([*argv, '--replace']) == 0
    capsys.readouterr()
    rows = [r for r in _csv_rows(out) if r['gyro_id'] == 'R-1']
    assert {r['this_run'] for r in rows} == {'calibrated'}
    assert _held(rows) != _held([r for r in before if r['gyro_id'] == 'R-1'])


def test_a_gyro_whose_record_is_gone_keeps_its_row_from_the_earlier_fleet_file(
        tmp_path: Path, shared: Any, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Without record.json the earlier fleet.jsonl row is what the folder holds."""
    import dask.distributed

    argv, out = _complete_run(tmp_path, capsys)
    before = _csv_rows(out)
    (out / 'F-1' / 'record.json').unlink()
    monkeypatch.setattr(dask.distributed, 'as_completed', _StoppedAtOnce)
    assert main(argv) == 130
    capsys.readouterr()
    assert _held(_csv_rows(out)) == _held(before)


def test_an_interrupted_run_that_cannot_write_every_fleet_file_leaves_the_old_ones(
        tmp_path: Path, shared: Any, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """All four or none: a disk that fills at the third file leaves the earlier four whole."""
    import dask.distributed

    import gyro_calib.outputs as outputs

    argv, out = _complete_run(tmp_path, capsys)
    old = {name: (out / name).read_bytes() for name in FLEET_FILES}
    staged = outputs._staged
    calls: list[Path] = []

    def full_at_third(target: Path, data: bytes) -> str:
        if target.name.startswith('fleet.'):
            calls.append(target)
            if len(calls) == 3:
                raise OSError(28, 'No space left on device', str(target))
        return staged(target, data)

    monkeypatch.setattr(outputs, '_staged', full_at_third)
    monkeypatch.setattr(dask.distributed, 'as_completed', _StoppedAtOnce)
    assert main(argv) == 130
    printed = capsys.readouterr()
    assert {name: (out / name).read_bytes() for name in FLEET_FILES} == old
    assert 'written: ' not in printed.out
    (line,) = [x for x in printed.out.splitlines() if x.startswith('fleet files not rewritten')]
    assert 'No space left on device' in line and 'left as they were' in line
    assert sorted(p.name for p in out.iterdir() if p.name.startswith('fleet')) == sorted(
        FLEET_FILES)  # no temporary file left beside them


def test_a_bag_path_typo_under_a_scheduler_is_that_gyros_row(
        tmp_path: Path, shared: Any, capsys: pytest.CaptureFixture[str]) -> None:
    """Under --scheduler the parent does not judge the workers' paths: the worker does."""
    manifest, out = tmp_path / 'm.yaml', tmp_path / 'out'
    _write_manifest(manifest, bags={'R-1': 'k_tilde_bnch', 'F-1': 'fog_turntable'})
    argv = ['batch', str(manifest), '--out', str(out), '--no-pdf', '--no-progress',
            '--scheduler', 'tcp://127.0.0.1:8786']
    assert main(argv) == 1
    printed = capsys.readouterr().out
    (row,) = [line for line in printed.splitlines() if line.startswith('R-1: ')]
    assert row.startswith('R-1: failed: ') and 'k_tilde_bnch' in row
    assert 'F-1: ok' in printed
