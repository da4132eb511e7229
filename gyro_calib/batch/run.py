"""Run a fleet on Dask distributed: a local cluster of worker processes, or a given scheduler.

Per gyro: one plan task (hash the bags, skip when unchanged, pick the methods), one task per
method (the streaming bag calibration), one finish task (hand-off file and certificate as
bytes) that depends on them; under a lab the finish task returns the certificate built but
unnumbered, the parent reserves its number and one issue task renders it. The parent
schedules, writes what the tasks return, and never opens a bag. Ctrl-C cancels what is
pending and keeps what finished; every other gyro is a row ``not run (interrupted)`` (one
whose number was reserved names it).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gyro_calib.batch.fleet import CALIBRATED, KEPT, SKIPPED, _atomic_write, write_fleet
from gyro_calib.batch.manifest import GyroJob, gyro_stem
from gyro_calib.batch.rerun import refused_move, replaced_lines
from gyro_calib.batch.tasks import (
    GyroResult,
    Plan,
    burned,
    finish_gyro,
    issue_gyro,
    plan_gyro,
    reason,
    run_method,
)
from gyro_calib.errors import ConfigError
from gyro_calib.report.lab import reserve_number

__all__ = ['BatchOutcome', 'gyro_stem', 'make_client', 'print_summary', 'run_batch',
           'sigint_noted']

RECORD = 'record.json'
"""Each gyro's record (fingerprint, inputs, certificate rows) in its folder."""


@dataclass(slots=True)
class BatchOutcome:
    """What a batch did: the records by gyro (in manifest order) and what was skipped."""

    records: list[dict[str, Any]]
    skipped: list[str] = field(default_factory=list)
    interrupted: bool = False
    files: list[Path] = field(default_factory=list)
    interrupted_once_written: bool = False
    """A Ctrl-C came once every file was being (or had been) written: noted, not acted on."""
    kept: list[str] = field(default_factory=list)
    """Gyros this run left alone (not run, refused, failed before any file) whose earlier
    results stay in their folders and so, as earlier rows, in the fleet files."""
    fleet_not_written: str = ''
    """Why an interrupted run left the earlier fleet files as they were ('' it wrote them)."""

    @property
    def failed(self) -> list[str]:
        """Gyros that failed, in whole or in part."""
        return [r['gyro_id'] for r in self.records if r.get('status') in ('failed', 'partial')]

    @property
    def not_run(self) -> list[str]:
        """Gyros an interrupted run never finished."""
        return [r['gyro_id'] for r in self.records if r.get('status') == NOT_RUN]


NOT_RUN = 'not run'
"""The status of a gyro an interrupted run never finished."""
NOT_RUN_REASON = 'not run (interrupted): the run was stopped before this gyro finished'


def check_earlier_runs(jobs: Sequence[GyroJob], out_dir: Path) -> None:
    """Refuse a gyro whose folder holds another gyro's results from an earlier run.

    ``A/1`` now and ``A_1`` before (or ``a-1`` before, on a case-insensitive file system)
    map to one folder: running would overwrite the earlier gyro's hand-off and certificate.

    Raises:
        ConfigError: naming both gyros and the folder.
    """
    for job in jobs:
        stem = gyro_stem(job.gyro_id)
        try:
            earlier = json.loads((out_dir / stem / RECORD).read_text(encoding='utf-8'))
        except (OSError, ValueError):
            continue
        other = earlier.get('gyro_id') if isinstance(earlier, dict) else None
        if isinstance(other, str) and other != job.gyro_id:
            raise ConfigError(
                f'--out {out_dir}: folder {stem!r} holds gyro {other!r} of an earlier run; '
                f'gyro {job.gyro_id!r} would overwrite it: give another --out or rename the '
                'gyro.')


def spec_digest(path: Path | None) -> str:
    """SHA-256 of the spec file's bytes ('' without one)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest() if path else ''


def longest_first(jobs: Sequence[GyroJob]) -> list[GyroJob]:
    """The gyros in the order they are handed to the cluster: the most bag bytes first.

    The longest calibrations start first, so the fleet does not end waiting on one long
    gyro begun last; gyros of equal size (and bags this process cannot see, counted as 0)
    keep the manifest's order. Results are kept in the manifest's order whatever this is.
    """
    def size(job: GyroJob) -> int:
        total = 0
        for bag in job.bags:
            path = Path(bag)
            try:
                files = [path] if not path.is_dir() else [p for p in path.rglob('*')
                                                         if p.is_file()]
                total += sum(f.stat().st_size for f in files)
            except OSError:
                continue
        return total

    return sorted(jobs, key=size, reverse=True)


def _previous(out_dir: Path, stem: str) -> dict[str, Any] | None:
    """The gyro's previous record, if its results are all still there."""
    path = out_dir / stem / RECORD
    try:
        record = json.loads(path.read_text(encoding='utf-8'))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get('status') not in ('ok', 'partial'):
        return None
    if not (out_dir / stem / f'{stem}.yaml').exists() or not (
            out_dir / stem / f'{stem}.html').exists():
        return None
    return record


def _earlier_fleet_rows(out_dir: Path) -> dict[str, dict[str, Any]]:
    """Each gyro's record in the earlier run's fleet.jsonl (none if absent or unreadable)."""
    try:
        text = (out_dir / 'fleet.jsonl').read_text(encoding='utf-8')
    except (OSError, UnicodeDecodeError):
        return {}
    rows: dict[str, dict[str, Any]] = {}
    for line in text.splitlines():
        try:
            row = json.loads(line)
        except ValueError:
            continue
        if isinstance(row, dict) and isinstance(row.get('gyro_id'), str):
            rows[row['gyro_id']] = row
    return rows


def _earlier(out_dir: Path, stem: str, gyro_id: str,
             fleet_rows: dict[str, dict[str, Any]]) -> dict[str, Any] | None:
    """What the gyro's folder holds of an earlier run, as a record (None: nothing usable).

    Its record.json when that is there; without one (removed, unreadable) its row of the
    earlier fleet.jsonl, when that row is a result and its hand-off and certificate are there.
    """
    if (out_dir / stem / RECORD).exists():
        return _previous(out_dir, stem)
    row = fleet_rows.get(gyro_id)
    if row is None or row.get('status') not in ('ok', 'partial') or not (
            out_dir / stem / f'{stem}.yaml').exists() or not (
            out_dir / stem / f'{stem}.html').exists():
        return None
    return {k: v for k, v in row.items() if k not in ('fleet_run', 'this_run')}


def this_run(record: dict[str, Any], skipped: bool) -> str:
    """What this run did with a gyro, as the fleet files' ``this_run`` says it."""
    status, why = record.get('status'), str(record.get('reason', ''))
    if skipped:
        return SKIPPED
    if status in ('ok', 'partial'):
        return CALIBRATED
    if status == NOT_RUN:
        return NOT_RUN_STATE if why == NOT_RUN_REASON else why
    return why if why.startswith('refused') else f'failed: {why}'


NOT_RUN_STATE = 'not run (interrupted)'


def fleet_entries(jobs: Sequence[GyroJob], records: Sequence[dict[str, Any]],
                  skipped: Sequence[str], written: set[str],
                  earlier: dict[str, dict[str, Any] | None]) -> tuple[list[dict[str, Any]],
                                                                     list[str]]:
    """The fleet files' records: what each gyro's folder holds, and what this run did.

    A gyro whose folder this run wrote (or found unchanged) is its record; one it left
    alone (not run, refused, failed before writing a file) with an earlier result in its
    folder is that earlier record, its ``this_run`` saying what happened and ending
    :data:`~gyro_calib.batch.fleet.KEPT`. Returns the records and the gyros kept so.
    """
    entries, kept = [], []
    for job, rec in zip(jobs, records, strict=True):
        gid = job.gyro_id
        done = this_run(rec, gid in skipped)
        before = earlier.get(gid)
        if gid in written or gid in skipped or before is None:
            entries.append({**rec, 'this_run': done})
            continue
        kept.append(gid)
        entries.append({**before, 'this_run': done + KEPT})
    return entries, kept


LOCAL_WORKER_CONFIG = {'distributed.worker.profile.enabled': False}
"""Dask settings of the workers of a local cluster (:func:`make_client`)."""


def make_client(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    """A Dask client, to a scheduler or a new local cluster.

    A Dask client: to ``scheduler``, or to a new local cluster of ``workers`` processes
    (one thread each; default: the machine's cores). Returns (client, cluster or None).

    The local workers run without Dask's statistical profiler (``distributed.worker.profile``:
    it sampled the task thread's stack every 10 ms, for a dashboard ``gyro-calib batch`` never
    shows — about a twentieth of each worker's CPU).

    The worker processes never see SIGINT: Ctrl-C at a terminal reaches the whole process
    group, and only the parent acts on it (cancel, close the cluster, keep what finished) —
    not every worker with a traceback. A Ctrl-C while the cluster starts is kept
    (:func:`_sigint_held`) and acted on once it stands: the cluster is closed and
    ``KeyboardInterrupt`` raised (nothing was written).
    """
    import dask
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler, timeout='20s'), None
    with _sigint_held() as arrived, dask.config.set(LOCAL_WORKER_CONFIG):
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                               processes=True, host='127.0.0.1', dashboard_address='127.0.0.1:0',
                               silence_logs=logging.CRITICAL)
        try:
            client = Client(cluster)
        except BaseException:
            cluster.close()
            raise
    if arrived:
        with _sigint_deferred():  # the Ctrl-C came while it started: stop it, then say so
            client.close()
            cluster.close()
        raise KeyboardInterrupt
    return client, cluster


@contextlib.contextmanager
def _sigint_held() -> Iterator[list[int]]:
    """Block SIGINT in this thread (and so in every thread and process started in the block).

    Blocked, not ignored: the threads and worker processes started in the block inherit the
    mask and never take a Ctrl-C, while a Ctrl-C that comes meanwhile stays pending for this
    process, is noted in the yielded list (non-empty: it came) when the block ends, and is
    not lost. (An ignored SIGINT, which the workers would inherit too, is discarded.)

    The multiprocessing resource tracker is started first: starting it unblocks SIGINT in
    the thread that starts it (CPython's ``resource_tracker.ensure_running``), which would
    leave the cluster's own thread, and the workers it starts, taking Ctrl-C.
    """
    if threading.current_thread() is not threading.main_thread() or not hasattr(
            signal, 'pthread_sigmask'):
        yield []
        return
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()
    arrived: list[int] = []

    def note(signum: int, frame: object) -> None:
        arrived.append(signum)

    previous = signal.signal(signal.SIGINT, note)
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield arrived
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # a pending one: note()
        signal.signal(signal.SIGINT, previous)


def run_batch(jobs: Sequence[GyroJob], out_dir: Path, *, client: Any, spec: Any = None,
              spec_path: Path | None = None, force: bool = False, pdf: bool = True,
              progress: Callable[[int, int], None] | None = None,
              lab: Any = None, replace: bool = False) -> BatchOutcome:
    """Calibrate every gyro of ``jobs`` on the cluster (see :func:`_run_batch`).

    From the moment the fleet files are written a Ctrl-C is noted, not raised (the outcome's
    ``interrupted_once_written``): the run's futures are released as :func:`_run_batch`
    returns, and a ``KeyboardInterrupt`` in their ``__del__`` would be lost in an
    ``Exception ignored`` traceback.
    """
    arrived: list[int] = []
    previous = signal.getsignal(signal.SIGINT)
    try:
        outcome = _run_batch(jobs, out_dir, client=client, spec=spec, spec_path=spec_path,
                             force=force, pdf=pdf, progress=progress, lab=lab, replace=replace,
                             arrived=arrived)
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, previous)
    outcome.interrupted_once_written = bool(arrived)
    return outcome


def _run_batch(jobs: Sequence[GyroJob], out_dir: Path, *, client: Any, spec: Any,
               spec_path: Path | None, force: bool, pdf: bool,
               progress: Callable[[int, int], None] | None, lab: Any, replace: bool,
               arrived: list[int]) -> BatchOutcome:
    """Calibrate every gyro of ``jobs`` on the cluster.

    Calibrate every gyro of ``jobs`` on ``client``'s cluster; write per-gyro and fleet
    files into ``out_dir``. When interrupted, what finished is kept and every other gyro is
    a row ``not run (interrupted)``; the fleet files say the run was interrupted. With a
    ``lab`` (:class:`~gyro_calib.report.lab.Lab`) each certificate made is issued under the
    next number of its register, reserved here in the parent once the gyro's finish task has
    built its certificate (every check that can refuse the gyro done: a failed gyro burns no
    number; a failure after it names the number in the gyro's reason); an unchanged gyro
    keeps its certificate and number. A re-run gyro whose folder holds an issued certificate
    replaces it: its record's ``replaces`` names the old number, whose files are moved to
    ``<stem>/superseded/`` (see :func:`_store`). A re-run gyro whose values would move more
    than 5 combined standard uncertainties from its earlier hand-off is refused (a failed row
    saying why, its folder untouched, no number reserved) unless ``replace``
    (:func:`~gyro_calib.batch.rerun.refused_move`).

    Raises:
        ConfigError: a gyro's folder holds another gyro's earlier results (nothing run).
    """
    from dask.distributed import as_completed

    check_earlier_runs(jobs, out_dir)
    out_dir.mkdir(exist_ok=True)  # checked before any work; parents are never created
    digest = spec_digest(spec_path) + (spec_digest(lab.source) if lab is not None else '')
    stems = {j.gyro_id: gyro_stem(j.gyro_id) for j in jobs}
    previous = {j.gyro_id: _previous(out_dir, stems[j.gyro_id]) for j in jobs}
    fleet_before = _earlier_fleet_rows(out_dir)
    earlier = {j.gyro_id: _earlier(out_dir, stems[j.gyro_id], j.gyro_id, fleet_before)
               for j in jobs}
    written: set[str] = set()  # gyros whose folder this run wrote

    def store(result: GyroResult, late: bool = True) -> dict[str, Any]:
        """Store a gyro whole: a Ctrl-C meanwhile is raised once its record is in place."""
        with sigint_noted() as arrived:  # acted on once the gyro's files are all in place
            written.add(result.gyro_id)
            records[result.gyro_id] = record = _store(out_dir, result, replace)
        if arrived and late:
            raise KeyboardInterrupt
        return record
    records: dict[str, dict[str, Any]] = {}
    skipped: list[str] = []
    by_id = {j.gyro_id: j for j in jobs}
    pending: dict[str, tuple[str, str, Any]] = {}
    reserved: dict[str, str] = {}  # gyro → the number reserved for its certificate
    queue = as_completed()
    submitted: list[Any] = []
    for job in longest_first(jobs):
        prev = previous[job.gyro_id]
        fut = client.submit(plan_gyro, job, (prev or {}).get('fingerprint', ''), digest, force,
                            key=f'plan-{stems[job.gyro_id]}-{os.urandom(4).hex()}', pure=False)
        pending[fut.key] = ('plan', job.gyro_id, fut)
        submitted.append(fut)
        queue.add(fut)
    done = 0
    interrupted = False
    try:
        for fut in queue:
            kind, gid, _ = pending.pop(fut.key)
            job = by_id[gid]
            try:
                result = fut.result()
            except Exception as exc:  # noqa: BLE001  (a worker died: that gyro's row says so)
                why = f'task {kind} failed: {reason(exc)}'
                records[gid] = _failed(job, stems[gid], burned(reserved[gid], why)
                                       if gid in reserved else why)
                done += 1
            else:
                if kind == 'plan':
                    plan: Plan = result
                    if plan.error:
                        records[gid] = _failed(job, stems[gid], plan.error, plan)
                        done += 1
                    elif plan.skip:
                        records[gid] = previous[gid] or {}
                        skipped.append(gid)
                        done += 1
                    else:
                        runs = [client.submit(run_method, job, m, plan.hashed, pure=False,
                                              key=f'{m}-{stems[gid]}-{os.urandom(4).hex()}')
                                for m in plan.methods]
                        fin = client.submit(finish_gyro, job, plan, spec, pdf, stems[gid], *runs,
                                            defer_issue=lab is not None, pure=False,
                                            key=f'finish-{stems[gid]}-{os.urandom(4).hex()}')
                        pending[fin.key] = ('finish', gid, fin)
                        submitted += [*runs, fin]
                        queue.add(fin)
                elif kind == 'finish' and not replace and (why := _refused(out_dir, result)):
                    records[gid] = _failed(job, stems[gid], why)
                    done += 1
                elif kind == 'finish' and lab is not None and result.certificate is not None:
                    issue = reserve_number(lab, gid, job.customer)  # all checks passed
                    reserved[gid] = issue.number
                    fut2 = client.submit(issue_gyro, result, issue, spec, pdf, pure=False,
                                         key=f'issue-{stems[gid]}-{os.urandom(4).hex()}')
                    pending[fut2.key] = ('issue', gid, fut2)
                    submitted.append(fut2)
                    queue.add(fut2)
                else:
                    records[gid] = store(result)
                    done += 1
            if progress is not None and gid in records:
                progress(done, len(jobs))
    except KeyboardInterrupt:
        interrupted = True
        with _sigint_deferred():
            client.cancel([f for f in submitted if f.status != 'finished'])
            for kind, gid, fut in pending.values():  # finished, not yet taken from the queue
                if gid in records:
                    continue
                if fut.status == 'finished' and (kind == 'issue' or kind == 'finish' and (
                        fut.result().certificate is None)):
                    why = '' if replace or kind == 'issue' else _refused(out_dir, fut.result())
                    records[gid] = (_failed(by_id[gid], stems[gid], why) if why else
                                    store(fut.result(), late=False))
                elif gid in reserved:
                    records[gid] = {**_not_run(by_id[gid], stems[gid]), 'reason': burned(
                        reserved[gid], 'the run was stopped before its certificate was made')}
            client.cancel(submitted)
    # a Ctrl-C from here on must not leave the fleet files half-updated: noted in `arrived`
    # (and left so until run_batch, after this frame's futures are released, puts it back)
    _note_sigint(arrived)
    ordered = [records[j.gyro_id] if j.gyro_id in records
               else _not_run(j, stems[j.gyro_id]) for j in jobs]
    entries, kept = fleet_entries(jobs, ordered, skipped, written, earlier)
    limits = spec.limits if spec is not None else None
    try:
        files = write_fleet(entries, out_dir, spec_limits=limits, interrupted=interrupted)
    except OSError as exc:
        if not interrupted:
            raise
        return BatchOutcome(ordered, skipped, interrupted, [], kept=kept,
                            fleet_not_written=f'{exc.strerror or exc}: {exc.filename}')
    return BatchOutcome(ordered, skipped, interrupted, files, kept=kept)


def _note_sigint(arrived: list[int]) -> None:
    """From now on a Ctrl-C (main thread only) is appended to ``arrived``, not raised."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, lambda signum, frame: arrived.append(signum))


@contextlib.contextmanager
def sigint_noted() -> Iterator[list[int]]:
    """While the block runs a Ctrl-C is noted in the yielded list (non-empty: it came).

    For what follows the writing of every file (closing the cluster, printing the summary):
    the run is done, and a Ctrl-C then is said, not acted on; and for a gyro's files and
    record, written together (the caller acts on it once they are all in place, so a folder
    never holds one run's hand-off beside another's record).
    """
    arrived: list[int] = []
    previous = signal.getsignal(signal.SIGINT)
    _note_sigint(arrived)
    try:
        yield arrived
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def _sigint_deferred() -> Iterator[None]:
    """Hold SIGINT while the block runs (main thread only); a Ctrl-C in it is dropped."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _not_run(job: GyroJob, stem: str) -> dict[str, Any]:
    return {'gyro_id': job.gyro_id, 'stem': stem, 'status': NOT_RUN, 'reason': NOT_RUN_REASON,
            'fingerprint': '', 'settings': job.settings, 'methods': list(job.methods),
            'inputs': {}, 'errors': []}


def _failed(job: GyroJob, stem: str, why: str, plan: Plan | None = None) -> dict[str, Any]:
    return {'gyro_id': job.gyro_id, 'stem': stem, 'status': 'failed', 'reason': why,
            'fingerprint': '', 'settings': job.settings, 'methods': list(job.methods),
            'inputs': {b: [list(f) for f in files] for b, files in
                       (plan.inputs.items() if plan else ())}, 'errors': [why]}




def issued_number(html_path: Path) -> str:
    """The number of the issued certificate ``html_path`` ('' if none, a draft or unreadable)."""
    from gyro_calib.report.certificate import number_cell

    try:
        number = number_cell(html_path.read_text(encoding='utf-8', errors='replace'))
    except OSError:
        return ''
    return '' if number is None or number.startswith('none') else number


SUPERSEDED = 'superseded'
"""The folder in a gyro's folder that keeps the files of its replaced issued certificates."""


def _supersede(folder: Path, stem: str, new_files: Sequence[str]) -> str:
    """Move an issued certificate of an earlier run out of the way of this run's files.

    When this run writes a certificate (``new_files``: the relative paths it writes) into a
    folder holding an issued one, the old HTML and PDF move to ``superseded/<stem>-<number>``
    (never mixed with the new, never lost); a draft's PDF that the new files do not replace
    is removed. Returns the old certificate's number ('' if it was none or a draft).
    """
    from gyro_calib.report.certificate import certificate_stem

    html, pdf = folder / f'{stem}.html', folder / f'{stem}.pdf'
    if f'{stem}/{stem}.html' not in new_files:
        return ''
    number = issued_number(html)
    if number:
        keep = folder / SUPERSEDED
        keep.mkdir(exist_ok=True)
        name = certificate_stem(f'{stem}-{number}')  # the certificates' own file-name rule
        for old in (html, pdf):
            if old.exists():
                old.replace(keep / f'{name}{old.suffix}')
    elif pdf.exists() and f'{stem}/{stem}.pdf' not in new_files:
        pdf.unlink()  # a draft's PDF beside the new HTML would not match it
    return number


def _refused(out_dir: Path, result: GyroResult) -> str:
    """Why a finished gyro's hand-off may not replace its earlier one ('' if it may)."""
    from gyro_calib.registry import handoff_schema

    if result.record.get('status') not in ('ok', 'partial'):
        return ''
    schema = handoff_schema()
    for rel, data in result.files.items():
        if rel.endswith('.yaml') and (out_dir / rel).exists():
            why = refused_move(out_dir / rel, data, schema, result.gyro_id)
            if why:
                return why
    return ''


def _store(out_dir: Path, result: GyroResult, replace: bool = False) -> dict[str, Any]:
    """Write a finished gyro's files, then its record.

    Write a finished gyro's files (each atomically), then its record (last: a record means
    the files are there). An issued certificate of an earlier run that the new one replaces
    is moved aside (:func:`_supersede`) and named in the record's ``replaces``.
    """
    record = dict(result.record)
    folder = out_dir / record['stem']
    folder.mkdir(exist_ok=True)
    replaces = _supersede(folder, record['stem'], list(result.files))
    if replaces:
        record['replaces'] = replaces
    stands = issued_number(folder / f'{record["stem"]}.html') if not replaces else ''
    if stands and record.get('status') == 'failed':
        record['reason'] = (f'{record.get("reason", "")}; the issued certificate {stands} of '
                            f'an earlier run stays in {record["stem"]}/ (not replaced)')
    replaced = [line for rel, data in result.files.items() if rel.endswith('.yaml')
                for line in replaced_lines(out_dir / rel, data, replace=replace)]
    if replaced:
        record['replaced'] = replaced
    for rel, data in result.files.items():
        _atomic_write(out_dir / rel, data)
    if record.get('status') == 'failed':
        record['fingerprint'] = ''  # never skipped: re-runs retry it
    _atomic_write(folder / RECORD, json.dumps(record, sort_keys=True, indent=1,
                                              default=str).encode('utf-8'))
    return record


def print_summary(outcome: BatchOutcome, stream: Any = None) -> None:
    """One line per gyro, then the totals and the fleet files (on stdout by default)."""
    stream = sys.stdout if stream is None else stream
    for rec in outcome.records:
        kept = (f'  the fleet files keep its earlier results, as its folder {rec["stem"]}/ '
                'does' if rec['gyro_id'] in outcome.kept else '')
        if rec.get('status') == NOT_RUN:
            print(f'{rec["gyro_id"]}: not run (interrupted)', file=stream)
            if kept:
                print(kept, file=stream)
            continue
        cert = rec.get('certificate') or {}
        skipped = ' (unchanged: skipped)' if rec['gyro_id'] in outcome.skipped else ''
        verdict = f' {cert["overall"]}' if cert.get('overall') else ''
        why = f': {rec["reason"]}' if rec.get('reason') else ''
        if rec.get('replaces') and rec['gyro_id'] not in outcome.skipped:
            now = cert.get('certificate_number') or 'a draft'
            why += (f' (certificate {now} replaces the issued certificate {rec["replaces"]}; '
                    f'its files moved to {rec["stem"]}/{SUPERSEDED}/)')
        print(f'{rec["gyro_id"]}: {rec.get("status")}{verdict}{skipped}{why}', file=stream)
        for note in rec.get('notes', ()):  # as calibrate prints them (its certificate too)
            print(f'  {note}', file=stream)
        if rec['gyro_id'] not in outcome.skipped:
            for line in rec.get('replaced', ()):  # what this run's hand-off replaced
                print(f'  {line}', file=stream)
        if kept:
            print(kept, file=stream)
    n_ok = sum(r.get('status') == 'ok' for r in outcome.records)
    not_run = len(outcome.not_run)
    print(f'{len(outcome.records)} gyros: {n_ok} ok, {len(outcome.failed)} failed'
          + (f', {not_run} not run (interrupted)' if outcome.interrupted else '')
          + f', {len(outcome.skipped)} skipped as unchanged', file=stream)
    for path in outcome.files:
        print(f'written: {path.resolve()}', file=stream)
    if outcome.fleet_not_written:
        print(f'fleet files not rewritten ({outcome.fleet_not_written}): the earlier '
              'fleet.csv, .parquet, .jsonl and .html are left as they were', file=stream)
