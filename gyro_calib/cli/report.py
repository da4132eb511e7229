"""``gyro-calib report`` and ``gyro-calib calibrate … --report DIR``: the certificate of a gyro.

    gyro-calib report HANDOFF.yaml [BAG ...] [--spec SPEC.yaml] --out DIR [--no-pdf]
                      [--lab LAB.yaml] [--customer TEXT] [--accept-handoff-values]

writes ``DIR/<gyro_id>.html`` (self-contained) and ``DIR/<gyro_id>.pdf``. With bags, the
methods of the hand-off file whose topics the bags hold are run again on them (with the same
settings flags as ``calibrate``) for the degrees of freedom, budgets, rejections, figures and
input hashes; without, the certificate rests on the hand-off file alone and says so. With a
lab file (``--lab``, or ``lab.yaml`` in DIR; :mod:`gyro_calib.report.lab`) the certificate is
issued by that laboratory under the next number of its register; without, it is a draft. A
hand-off value the bags contradict is refused (exit 2) unless ``--accept-handoff-values``.
An issued certificate already in DIR is never replaced (refused before any work); a draft is,
said in a line. Every refusal comes before the number is reserved (none is burned by it).
One certificate writer per directory, draft or issued (:func:`certificate_lock`, a
:class:`~gyro_calib.file_lock.DirectoryLock` on ``DIR/.certificates.lock``): a second run
writing DIR at the same time is refused in one line, before any number is reserved.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gyro_calib.cli.arguments import (
    EXIT_OK,
    check_output_dir,
    lab_and_customer,
    lab_arguments,
    load_spec_arg,
    method_arguments,
    options_from_args,
)
from gyro_calib.errors import ConfigError
from gyro_calib.file_lock import CERTIFICATES_LOCK, DirectoryLock

if TYPE_CHECKING:
    from gyro_calib.bag_calibration import BagCalibration
    from gyro_calib.handoff import Calibration
    from gyro_calib.report.evidence import RunEvidence
    from gyro_calib.report.lab import Lab
    from gyro_calib.report.spec import Spec


PRELOAD: tuple[str, ...] = (
    'gyro_calib.bag_calibration',
    'gyro_calib.bagio.reader',
    'gyro_calib.handoff.load',
    'gyro_calib.handoff.write',
    'gyro_calib.outputs',
    'gyro_calib.session',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def add_commands(sub: Any) -> None:
    """Add ``report`` to the ``gyro-calib`` subcommands."""
    rep = sub.add_parser('report', help='the calibration certificate of a gyro (HTML + PDF)')
    rep.add_argument('handoff', type=Path, metavar='HANDOFF', help='the hand-off YAML file')
    rep.add_argument('bags', nargs='*', type=Path, metavar='BAG',
                     help='the bags it was calibrated from (for degrees of freedom, budgets, '
                     'rejections, figures, hashes)')
    rep.add_argument('--out', type=Path, required=True, metavar='DIR',
                     help='directory for <gyro_id>.html and <gyro_id>.pdf (a draft there is '
                     'replaced; an issued certificate never is)')
    rep.add_argument('--spec', type=Path, metavar='SPEC',
                     help='acceptance limits and decision rule (YAML); without it no verdicts')
    rep.add_argument('--pdf', action=argparse.BooleanOptionalAction, default=True,
                     help='write the PDF beside the HTML (default: yes)')
    lab_arguments(rep)
    rep.add_argument('--accept-handoff-values', action='store_true',
                     help='certify the hand-off file\'s values as they stand where the bags '
                     'give others (each such row says what the bags give); default: refuse')
    method_arguments(rep)
    rep.set_defaults(run=run_report)


def certificate_lock(out_dir: Path, command: str, flag: str = '--out') -> DirectoryLock:
    """The lock of a certificate directory (not taken yet): one writer, draft or issued.

    ``report`` and ``calibrate --report`` hold DIR from their first look at it (is an
    issued certificate there?) until the certificate is in place, as ``batch`` holds its
    ``DIR/batch.lock``: a second writer is refused in one line before it reserves a number,
    so two runs can neither both say "certificate written" while one issued certificate
    replaces the other, nor leave one draft's HTML beside the other's PDF (issue 35 §3).
    """
    return DirectoryLock(
        out_dir, command, name=CERTIFICATES_LOCK, flag=flag, writer='certificate run',
        wait_note=' (then see whether its certificate is the one you want)',
        refused_note=' and no certificate number was reserved')


def check_calibrate_report(args: argparse.Namespace) -> DirectoryLock:
    """``calibrate --report DIR [--spec SPEC] [--lab LAB] [--customer TEXT] [--no-pdf]``: first.

    Returns the lock on DIR, held (one certificate writer per directory): the caller
    releases it once the certificate is written or the run ends.
    """
    if args.report is None:
        given = [f for f, v in (('--spec', args.spec), ('--lab', args.lab),
                                ('--customer', args.customer),
                                ('--pdf' if args.pdf else '--no-pdf', args.pdf)) if v is not None]
        raise ConfigError(f'{" and ".join(given)} appl{"ies" if len(given) == 1 else "y"} only '
                          'with --report DIR (the certificate).')
    check_output_dir(args.report, '--report')
    load_spec_arg(args.spec)
    lab_and_customer(args, args.report)
    from gyro_calib.report.certificate import certificate_stem, replacing

    gyro_id = args.gyro_id
    if not gyro_id and args.out is not None and Path(args.out).is_file():
        from gyro_calib.handoff import load_calibration
        from gyro_calib.handoff.schema import HandoffError
        from gyro_calib.registry import handoff_schema

        try:
            gyro_id = load_calibration(args.out, handoff_schema()).gyro_id
        except (ConfigError, HandoffError):
            pass  # calibrate names what is wrong with it
    where = '(this run; no --out file)' if args.out is None else str(args.out)
    lock = certificate_lock(args.report, 'calibrate --report', '--report')
    lock.acquire()
    try:
        replacing(args.report, certificate_stem(gyro_id, where), pdf=args.pdf is not False,
                  flag='--report')
    except BaseException:
        lock.release()
        raise
    return lock


def run_report(args: argparse.Namespace) -> int:
    """``gyro-calib report``: load, (re-)run the bags, build and write the certificate."""
    from gyro_calib.handoff import load_calibration
    from gyro_calib.registry import handoff_schema
    from gyro_calib.report.certificate import certificate_stem, replacing
    from gyro_calib.report.spec import refuse_unknown_imu_channels

    check_output_dir(args.out)
    spec = load_spec_arg(args.spec)
    lab, customer = lab_and_customer(args, args.out)
    calibration = load_calibration(args.handoff, handoff_schema())
    refuse_unknown_imu_channels(spec, calibration.imu.channels if calibration.imu is not None
                                else None, str(args.handoff))  # before the bags are read
    lock = certificate_lock(args.out, 'report')  # held from the first look to the last write
    lock.acquire()
    try:
        replacing(args.out, certificate_stem(calibration.gyro_id, str(args.handoff)),
                  pdf=args.pdf)
        evidence = None
        if args.bags:
            options = options_from_args(args)
            if not options.gyro_id and calibration.gyro_id:
                options = dataclasses.replace(options, gyro_id=calibration.gyro_id)
            evidence = evidence_from_bags(args.bags, calibration, options, args.method,
                                          strict=args.strict)
        lines = write_report(calibration, evidence, spec, args.out,
                             handoff_path=str(args.handoff), pdf=args.pdf, lab=lab,
                             customer=customer, accept_handoff_values=args.accept_handoff_values)
    finally:
        lock.release()
    for line in lines:
        print(line)
    return EXIT_OK


def evidence_from_bags(bags: list[Path], calibration: Calibration, options: Any,
                       methods: list[str] | None, *, strict: bool = False) -> RunEvidence:
    """Run the hand-off's methods whose topics the bags hold; their evidence.

    Raises:
        BagError, ConfigError: as ``calibrate`` does; also when the bags hold none of the
            hand-off's methods' topics.
    """
    from gyro_calib.bag_calibration import calibrate_bags, merged_topics
    from gyro_calib.bagio import bag_info
    from gyro_calib.registry import METHODS
    from gyro_calib.report.evidence import evidence_from_outcome

    if not methods:
        present = merged_topics([bag_info(p, recover=not strict) for p in bags])
        methods = [name for name in calibration.methods if name in METHODS and (
            all(present.get(t) == METHODS[name].topics[t] for t in METHODS[name].reveal)
            if METHODS[name].reveal else
            any(present.get(t) == ty for t, ty in METHODS[name].inputs().items()))]
        if not methods:
            raise ConfigError(f'the bag(s) {", ".join(map(str, bags))} hold the topics of none '
                              f'of the hand-off file\'s methods ({", ".join(calibration.methods)})'
                              '; give the bags it was calibrated from, or none.')
    outcome = calibrate_bags(bags, methods=methods, options=options, strict=strict)
    return evidence_from_outcome(outcome, options)


def write_report(calibration: Calibration, evidence: RunEvidence | None, spec: Spec | None,
                 out_dir: Path, *, handoff_path: str = '', pdf: bool = True,
                 lab: Lab | None = None, customer: str = '',
                 accept_handoff_values: bool = False, flag: str = '--out') -> list[str]:
    """Build the certificate and write its HTML (and PDF) into ``out_dir``; the lines to print.

    Every check that can refuse the run (the hand-off's content, the bags' contradictions,
    an issued certificate already in ``out_dir``: :func:`~gyro_calib.report.certificate.
    replacing`) comes before the lab's next certificate number is reserved, so a refused
    run burns no number; a write that fails after it (disk full) says which number stays
    reserved, unused.

    Raises:
        ConfigError: as :func:`~gyro_calib.report.certificate.build_certificate` and
            :func:`~gyro_calib.report.certificate.replacing`; a failed write.
    """
    from gyro_calib.outputs import write_failed
    from gyro_calib.report.certificate import (
        build_certificate,
        replacing,
        with_issue,
        write_certificate,
    )

    cert = build_certificate(calibration, evidence, spec, handoff_path=handoff_path,
                             customer=customer, accept_handoff_values=accept_handoff_values)
    lines = replacing(out_dir, cert.file_stem, pdf=pdf, flag=flag)
    issue = None
    try:
        if lab is not None:
            from gyro_calib.report.lab import reserve_number

            issue = reserve_number(lab, calibration.gyro_id or Path(handoff_path).stem,
                                   customer)
            cert = with_issue(cert, issue)
        paths = write_certificate(cert, out_dir, pdf=pdf)
    except KeyboardInterrupt:  # the number is taken for good: the interrupt line names it
        if issue is not None:
            from gyro_calib.cli.interrupt import KEPT_AT_INTERRUPT

            KEPT_AT_INTERRUPT.append(f'certificate number {issue.number} stays reserved in '
                                     f'{issue.lab.counter}, unused (numbers are never reused)')
        raise
    except OSError as exc:  # disk full: each document is written whole or not at all
        error = write_failed(exc, flag, out_dir)
        if issue is not None:
            error = ConfigError(f'{error} Certificate number {issue.number} stays reserved in '
                                f'{issue.lab.counter}, unused (numbers are never reused).')
        raise error from None
    return [*lines, *(f'certificate written: {path}' for path in paths)]


def report_after_calibrate(args: argparse.Namespace, outcome: BagCalibration,
                           human: Any = None) -> None:
    """``calibrate --report DIR``: the certificate of the run.

    ``calibrate --report DIR``: the certificate of the run just made (the hand-off file of
    ``--out`` as merged, else this run's record).
    """
    from gyro_calib.handoff import load_calibration
    from gyro_calib.registry import handoff_schema
    from gyro_calib.report.evidence import evidence_from_outcome

    if args.out is not None and Path(args.out).exists():
        record = load_calibration(args.out, handoff_schema())
        where = str(args.out)
    else:
        record = None
        for session in outcome.sessions.values():
            part = session.handoff(outcome.source, gyro_id=args.gyro_id)
            if part is not None:
                record = part if record is None else part.merged_into(record, handoff_schema())
        where = '(this run; no --out file)'
    if record is None:
        print('gyro-calib: no certificate: nothing was measured.', file=sys.stderr)
        return
    human = sys.stdout if human is None else human
    evidence = evidence_from_outcome(outcome, options_from_args(args))
    lab, customer = lab_and_customer(args, args.report)
    for line in write_report(record, evidence, load_spec_arg(args.spec), args.report,
                             handoff_path=where, pdf=args.pdf is not False, lab=lab,
                             customer=customer, flag='--report'):
        print(line, file=human)
