"""``gyro-calib batch``: calibrate a fleet of gyros on Dask (see :mod:`gyro_calib.batch`).

    gyro-calib batch MANIFEST --out DIR [--workers N | --scheduler tcp://HOST:PORT]
                     [--spec SPEC.yaml] [--force] [--replace] [--no-pdf] [--progress]
                     [--lab LAB.yaml] [--customer TEXT]

Exit status: 0 every gyro calibrated; 1 some gyro failed (its row says why; the others
are done) — a re-run gyro whose values would move more than 5 combined standard
uncertainties from its earlier hand-off is such a row unless ``--replace``; 2 bad input
(manifest, a bag path that does not exist — under ``--scheduler`` each worker checks its
bags, a missing one is that gyro's row —, spec, output directory, ids whose files would
collide) or another run writes
the output directory (``DIR/batch.lock``), nothing written; 130 interrupted (what finished
is kept; every other gyro is a row ``not run (interrupted)``, or its earlier row if its
folder holds one — the fleet files describe what the folders hold; a Ctrl-C while the local
cluster starts: ``interrupted; nothing written.``). A Ctrl-C once the fleet files are
written (while the cluster closes) is said in one line after the summary; the exit status
stays the run's.

Under a lab file a certificate number is reserved only after the gyro's certificate is built
(a failed gyro burns none; a failure after it names the number); a re-issued certificate names
the issued one it replaces (its ``replaces``), whose files move to ``<gyro>/superseded/``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from gyro_calib.cli.arguments import (
    EXIT_INTERRUPTED,
    EXIT_NOT_CALIBRATED,
    EXIT_OK,
    check_output_dir,
    lab_and_customer,
    lab_arguments,
    load_spec_arg,
)
from gyro_calib.cli.progress import show_progress
from gyro_calib.errors import ConfigError
from gyro_calib.file_lock import BATCH_LOCK, DirectoryLock

EXIT_SOME_FAILED = EXIT_NOT_CALIBRATED  # some gyro failed (its row says why)


PRELOAD: tuple[str, ...] = (
    'gyro_calib.batch.manifest',
    'gyro_calib.batch.run',
    'gyro_calib.handoff.load',
    'gyro_calib.handoff.write',
    'gyro_calib.outputs',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def add_commands(sub: Any) -> None:
    """Add ``batch`` to the ``gyro-calib`` subcommands."""
    bat = sub.add_parser('batch', help='calibrate many gyros in parallel (Dask): hand-off files, '
                         'certificates, fleet.csv/parquet/jsonl/html')
    bat.add_argument('manifest', type=Path, metavar='MANIFEST',
                     help='YAML or CSV listing gyro ids, bags and settings, or a directory '
                     'with one folder per gyro')
    bat.add_argument('--out', type=Path, required=True, metavar='DIR', help='output directory')
    where = bat.add_mutually_exclusive_group()
    where.add_argument('--workers', type=int, metavar='N',
                       help='local cluster of N worker processes (default: the cores)')
    where.add_argument('--scheduler', metavar='URL',
                       help='submit to a running Dask scheduler, e.g. tcp://host:8786 (bags '
                       'on a path every worker reads)')
    bat.add_argument('--spec', type=Path, metavar='SPEC',
                     help='acceptance limits and decision rule (YAML) for the certificates')
    bat.add_argument('--force', action='store_true',
                     help='recalibrate gyros whose inputs and settings are unchanged (under '
                     'a lab: new certificate numbers; each names the one it replaces)')
    bat.add_argument('--replace', action='store_true',
                     help='take a re-run gyro\'s values where they move more than 5 combined '
                     'standard uncertainties from its earlier hand-off in --out (default: that '
                     'gyro is refused, its row says why, its earlier files stay)')
    bat.add_argument('--pdf', action=argparse.BooleanOptionalAction, default=True,
                     help='a PDF beside each HTML certificate (default: yes)')
    bat.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                     help='progress bar over gyros on stderr (default: when stderr is a '
                     'terminal)')
    lab_arguments(bat)  # --customer: for the gyros whose manifest entry names none
    bat.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Check the inputs, start or reach the cluster, run the fleet, write its files."""
    from gyro_calib.batch.manifest import check_local_bags, check_repeated_bags, load_manifest
    from gyro_calib.batch.run import check_earlier_runs

    if args.workers is not None and args.workers < 1:
        raise ConfigError(f'--workers {args.workers} is invalid: it must be at least 1.')
    check_output_dir(args.out, '--out', 'one result directory per gyro and the fleet '
                     'files are written inside it', 'fleet.csv')
    created = not args.out.exists()
    jobs = load_manifest(args.manifest)
    if args.scheduler is None:  # a local cluster reads the bags from here: check them now
        check_local_bags(jobs, args.manifest)
    check_repeated_bags(jobs)  # the same data under two paths or two gyros: refused
    spec = load_spec_arg(args.spec)
    lab, jobs = lab_and_customers(args, jobs)
    lock = batch_lock(args.out)
    lock.acquire()  # a second run into the same --out stops here
    try:
        check_earlier_runs(jobs, args.out)
        return _run_locked(args, jobs, spec, lab, created)
    finally:
        lock.release()  # also removes --out if this run created it and wrote nothing


def _run_locked(args: argparse.Namespace, jobs: Any, spec: Any, lab: Any,
                created: bool) -> int:
    """Start or reach the cluster, run the fleet, print the summary (the lock is held)."""
    from gyro_calib.batch.run import (
        BatchOutcome,
        make_client,
        print_summary,
        run_batch,
        sigint_noted,
    )

    show = show_progress(args.progress)
    try:
        client, cluster = make_client(args.workers, args.scheduler)
    except OSError as exc:
        raise ConfigError(f'cannot reach the Dask scheduler {args.scheduler}: {exc}.') from None
    except (ValueError, TypeError) as exc:  # a malformed address: Dask parses it first
        raise ConfigError(f'--scheduler {args.scheduler!r} is not a Dask scheduler address '
                          f'({exc}); give it as tcp://HOST:PORT.') from None
    bar = None
    outcome: BatchOutcome | None = None
    late = False
    try:
        if show:
            from tqdm import tqdm

            bar = tqdm(total=len(jobs), desc='gyros', unit='gyro', file=sys.stderr)

        def progress(done: int, total: int) -> None:
            if bar is not None:
                bar.update(done - bar.n)

        outcome = run_batch(jobs, args.out, client=client, spec=spec, spec_path=args.spec,
                            force=args.force, pdf=args.pdf, progress=progress, lab=lab,
                            replace=args.replace)
    except OSError as exc:  # disk full: what was stored before it stays, each file whole
        from gyro_calib.outputs import write_failed

        if created and not any(p.name != BATCH_LOCK for p in args.out.iterdir()):
            raise write_failed(exc, '--out', args.out) from None  # the lock removes --out
        raise write_failed(exc, '--out', args.out,
                           ['the files of the gyros stored before it']) from None
    except KeyboardInterrupt:
        if outcome is None:
            raise
        late = True  # in the instant between run_batch's return and the block below
    finally:
        if outcome is None:
            _close(bar, client, cluster)
    # every file is written: a Ctrl-C while the cluster closes (or the summary prints) is said,
    # not taken for an interrupt of the run
    with sigint_noted() as arrived:
        _close(bar, client, cluster)
        print_summary(outcome)
    if outcome.interrupted:
        print('gyro-calib: interrupted; the gyros that finished are kept.', file=sys.stderr)
        return EXIT_INTERRUPTED
    if late or arrived or outcome.interrupted_once_written:
        print('gyro-calib: interrupted after every file was written (the written: lines '
              'above); the run is complete.', file=sys.stderr)
    return EXIT_SOME_FAILED if outcome.failed else EXIT_OK


def _close(bar: Any, client: Any, cluster: Any) -> None:
    """Close the progress bar, the client and the local cluster (if one was started)."""
    if bar is not None:
        bar.close()
    client.close()
    if cluster is not None:
        cluster.close()


def batch_lock(out_dir: Path) -> DirectoryLock:
    """The lock of a batch output directory, ``DIR/batch.lock`` (not taken yet)."""
    return DirectoryLock(out_dir, 'batch', name=BATCH_LOCK)


def lab_and_customers(args: argparse.Namespace, jobs: list[Any]) -> tuple[Any, list[Any]]:
    """The issuing lab (``--lab``, else ``lab.yaml`` in ``--out``) and each gyro's customer.

    A gyro's customer: its manifest's ``customer``, else ``--customer``, else the lab file's.

    Raises:
        ConfigError: a malformed lab file, or a gyro without a customer under a lab.
    """
    import dataclasses

    lab, default = lab_and_customer(args, args.out, per_gyro=True)
    out = []
    for job in jobs:
        customer = job.customer or default
        if lab is not None and not customer:
            raise ConfigError(f'gyro {job.gyro_id}: a certificate issued by {lab.name} names '
                              'its customer (ISO/IEC 17025 7.8.2.1 e): give a customer column '
                              f'in the manifest, --customer, or customer: in {lab.source}.')
        out.append(dataclasses.replace(job, customer=customer))
    return lab, out
