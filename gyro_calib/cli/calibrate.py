"""``gyro-calib calibrate BAG [BAG ...]``: every method whose topics the bags hold.

    gyro-calib calibrate BAG [BAG ...] [--method NAME ...] [--out FILE] [--replace] [--json]
                         [--plot DIR] [--progress] [--report DIR [--spec SPEC] [--lab LAB]
                         [--customer TEXT] [--no-pdf]] (and the settings flags of every method)

Prints the summary (:func:`summary_text`), writes the hand-off (``--out``), the figures
(``--plot``) and the certificate (``--report``, :mod:`gyro_calib.cli.report`); exit status
as the package's docstring says.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gyro_calib.cli.arguments import (
    EXIT_NOT_CALIBRATED,
    EXIT_OK,
    calibrate_arguments,
    check_calibration_file,
    check_handoff_out,
    method_arguments,
    options_from_args,
    output_file,
    refuse_unused_flags,
    say_config_defaults,
)
from gyro_calib.cli.interrupt import Ledger
from gyro_calib.cli.progress import progress_bar
from gyro_calib.errors import ConfigError
from gyro_calib.registry import METHODS, handoff_schema
from gyro_calib.units import format_stamp

if TYPE_CHECKING:
    from gyro_calib.bag_calibration import BagCalibration


PRELOAD: tuple[str, ...] = (
    'gyro_calib.bag_calibration',
    'gyro_calib.handoff.load',
    'gyro_calib.handoff.write',
    'gyro_calib.outputs',
    'gyro_calib.session',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def add_commands(sub: Any) -> None:
    """Add ``calibrate`` to the ``gyro-calib`` subcommands."""
    cal = sub.add_parser('calibrate', help='calibrate bags: every method whose topics are there')
    cal.add_argument('bags', nargs='+', type=Path, metavar='BAG',
                     help='rosbag2 MCAP bag (directory); several are taken together')
    method_arguments(cal)
    cal.add_argument('--out', type=output_file('handoff.yaml'),
                     help='write (or update) the INS hand-off YAML here')
    cal.add_argument('--replace', action='store_true',
                     help="--out: take this run's values even where the file's are more precise "
                     'or disagree with them (a repaired gyro, a corrected bench setting)')
    cal.add_argument('--json', action='store_true',
                     help='print one JSON document of the results on stdout (the human summary '
                     'goes to stderr)')
    cal.add_argument('--plot', type=Path, metavar='DIR', help='write PNG figures into DIR '
                     '(created if absent, in an existing directory)')
    cal.add_argument('--format', choices=['imu_tk', 'imucal', 'xyz6'], default=None,
                     help='multiposition: BAG is a plain recording instead: imu_tk (two ASCII '
                     'files t x y z, accelerometer then gyro, raw counts), imucal (CSV acc_x … '
                     'gyr_z, m/s² and deg/s) or xyz6 (ax ay az wx wy wz per line, m/s² and '
                     'rad/s); see docs/multiposition.md')
    cal.add_argument('--sections', type=Path, default=None, metavar='JSON',
                     help='--format imucal: its section list (x_p … z_rot): the Ferraris variant '
                     '(six positions, three known turns; docs/methods.md §G.6)')
    cal.add_argument('--turn-angle-deg', type=float, default=-360.0,
                     help='--sections: each turn\'s known angle, signed as imucal\'s '
                     'expected_angle (default −360: clockwise)')
    cal.add_argument('--rate-hz', type=float, default=None,
                     help='--format imucal / xyz6: the sampling rate, Hz (they have no stamps)')
    cal.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                     help='progress bar on stderr (default: when stderr is a terminal)')
    cal.set_defaults(run=run_calibrate)
    calibrate_arguments(cal)  # --report DIR, --spec


def _refuse_a_bag_given_twice(bags: Sequence[Path]) -> None:
    """The same bag twice would count its data twice (and shrink every u by √2)."""
    seen: dict[Path, Path] = {}
    for bag in bags:
        key = Path(bag).resolve()
        if key in seen:
            raise ConfigError(f'bag {bag} is given twice (as {seen[key]} too): its data would '
                              'be counted twice; give each bag once.')
        seen[key] = Path(bag)


def run_calibrate(args: argparse.Namespace) -> int:
    """Check every output and flag before any work, calibrate, write; the exit status."""
    from gyro_calib.outputs import check_plot_dir

    if args.out is not None:  # a place or a file that cannot be updated: refused before work
        check_handoff_out(args.out)
    plot_dir = check_plot_dir(args.plot) if args.plot is not None else None
    if any(v is not None for v in (args.report, args.spec, args.lab, args.customer, args.pdf)):
        from gyro_calib.cli.report import check_calibrate_report

        lock = check_calibrate_report(args)  # --report DIR held until the run ends
        try:
            return _run_checked(args, plot_dir)
        finally:
            lock.release()
    return _run_checked(args, plot_dir)


def _run_checked(args: argparse.Namespace, plot_dir: Path | None) -> int:
    """:func:`run_calibrate` once its outputs are checked (and ``--report DIR`` held)."""
    from gyro_calib.bag_calibration import bag_infos, calibrate_bags, select_methods

    check_calibration_file(args.calibration)
    _refuse_a_bag_given_twice(args.bags)
    if any(getattr(args, name, None) is not None for name in ('format', 'rate_hz', 'sections')):
        return _run_plain(args, plot_dir)
    infos, _ = bag_infos(args.bags, args.namespace, strict=args.strict)
    to_run = [m.name for m in select_methods(infos, args.method)]
    refuse_unused_flags(args, to_run)
    say_config_defaults(args.config, to_run)
    options = options_from_args(args)
    with progress_bar(args.progress, 'calibrating') as progress:
        outcome = calibrate_bags(args.bags, methods=args.method, options=options,
                                 progress=progress, namespace=args.namespace,
                                 strict=args.strict)
    # the human text goes out only once the files are written: a refusal on the way (a
    # hand-off the run cannot be merged into, a full disk) leaves one line on stderr and
    # nothing on stdout
    human, document = io.StringIO(), io.StringIO()
    ledger = args.ledger if hasattr(args, 'ledger') else Ledger()  # main() gives one
    for flag, given, path, label in (('--out', args.out, args.out, 'hand-off'),
                                     ('--plot', args.plot, plot_dir, 'figure'),
                                     ('--report', args.report, args.report, 'certificate')):
        if path is not None:
            ledger.watch(f'{flag} {given}', path, label, directory=flag != '--out')
    try:
        status = _calibrate_outputs(args, outcome, human, document, plot_dir, ledger)
    except KeyboardInterrupt:  # what was measured and written is printed, the document
        (sys.stderr if args.json else sys.stdout).write(human.getvalue())
        if ledger.complete():  # once every file is in place
            sys.stdout.write(document.getvalue())
        raise  # main() names the files written, each whole, and those not written
    (sys.stderr if args.json else sys.stdout).write(human.getvalue())
    sys.stdout.write(document.getvalue())
    return status


def _run_plain(args: argparse.Namespace, plot_dir: Path | None) -> int:
    """``--format``: a plain recording through the multiposition method; the exit status.

    Raises:
        ConfigError: --rate-hz without --format, another method asked for, or the files
            cannot be read (before any work).
    """
    from gyro_calib.bag_calibration import calibrate_recording

    if args.format is None:
        raise ConfigError('--rate-hz applies to a plain recording: give its --format too.')
    if args.method not in (None, ['multiposition']):
        raise ConfigError(f'--format {args.format}: plain recordings are calibrated by the '
                          'multiposition method only; drop --method or give --method '
                          'multiposition.')
    refuse_unused_flags(args, ['multiposition'])
    say_config_defaults(args.config, ['multiposition'])
    outcome = calibrate_recording(args.bags, fmt=args.format, rate_hz=args.rate_hz,
                                  options=options_from_args(args), sections=args.sections,
                                  turn_angle_deg=args.turn_angle_deg)
    human, document = io.StringIO(), io.StringIO()
    ledger = args.ledger if hasattr(args, 'ledger') else Ledger()
    for flag, given, path, label in (('--out', args.out, args.out, 'hand-off'),
                                     ('--plot', args.plot, plot_dir, 'figure')):
        if path is not None:
            ledger.watch(f'{flag} {given}', path, label, directory=flag != '--out')
    status = _calibrate_outputs(args, outcome, human, document, plot_dir, ledger)
    (sys.stderr if args.json else sys.stdout).write(human.getvalue())
    sys.stdout.write(document.getvalue())
    return status


def _calibrate_outputs(args: argparse.Namespace, outcome: BagCalibration, human: Any,
                       document: Any, plot_dir: Path | None, ledger: Ledger) -> int:
    """Summary, hand-off, figures, certificate and JSON of a finished calibration.

    An output that fails while being written (disk full) ends the command in one line
    naming it and what was written before it.
    """
    from gyro_calib.bag_calibration import json_document
    from gyro_calib.outputs import write_failed, write_figures

    print(summary_text(outcome), file=human)

    def print_json() -> None:  # last: a command whose files failed prints nothing on stdout
        if args.json:
            print(json.dumps(json_document(outcome), indent=1, allow_nan=False,
                             default=json_default), file=document)
    if not outcome.calibrated_anything:
        ledger.status = EXIT_NOT_CALIBRATED
        print_json()
        print('gyro-calib: nothing could be calibrated from the bag(s); nothing written.',
              file=sys.stderr)
        return EXIT_NOT_CALIBRATED
    # the hand-off first: the measured values are kept whatever happens to a figure
    status = _write_handoff(args, outcome, human) if args.out is not None else EXIT_OK
    ledger.status = status
    if status != EXIT_OK:  # no hand-off value (said), so no certificate either
        ledger.drop(args.out)
        if args.report is not None:
            ledger.drop(args.report)
    written = [f'--out {args.out}'] if status == EXIT_OK and args.out is not None else []
    if plot_dir is not None:
        try:
            figures = write_figures(plot_dir, lambda stage: [
                path for session in outcome.sessions.values() for path in session.plot(stage)])
        except OSError as exc:
            raise write_failed(exc, '--plot', plot_dir, written) from None
        ledger.finished(plot_dir)
        for path in figures:
            print(f'figure written: {path.resolve()}', file=human)
        written.append(f'--plot {plot_dir}')
    if args.report is not None and status == EXIT_OK:
        from gyro_calib.cli.report import report_after_calibrate

        try:
            report_after_calibrate(args, outcome, human)
            ledger.finished(args.report)
        except OSError as exc:
            raise write_failed(exc, '--report', args.report, written) from None
    print_json()
    return status


def _write_handoff(args: argparse.Namespace, outcome: BagCalibration, human: Any) -> int:
    from gyro_calib.handoff import load_calibration, update_calibration

    record = None
    for session in outcome.sessions.values():
        part = session.handoff(outcome.source, gyro_id=outcome.gyro_id(session.name))
        if part is None:
            continue
        record = part if record is None else part.merged_into(record, handoff_schema())
    if record is None:
        print(f'gyro-calib: {args.out} not written: no method measured a hand-off value.',
              file=sys.stderr)
        return EXIT_NOT_CALIBRATED
    report: list[str] = []
    path = update_calibration(args.out, record, handoff_schema(), replace=args.replace,
                              report=report)
    print(f'hand-off written: {path}', file=human)
    for line in report:
        print(f'  {line}', file=human)
    # the file's state, with what earlier runs gave
    written = load_calibration(path, handoff_schema())
    if written.missing:
        print(f'hand-off incomplete ({len(written.missing)} missing):', file=human)
        for key, why in written.missing.items():
            print(f'  {key}: {why}', file=human)
    if written.not_measurable:
        print(f'not measurable on the bench(es) calibrated ({len(written.not_measurable)}; the '
              'file is complete without them):', file=human)
        for key, why in written.not_measurable.items():
            print(f'  {key}: {why}', file=human)
    return EXIT_OK


def json_default(value: Any) -> Any:
    """``json.dumps``' default of every ``--json``: arrays as lists, NaN and ±inf as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, 'tolist'):
        return value.tolist()
    raise TypeError(f'{type(value).__name__} is not JSON serialisable')


def summary_text(outcome: BagCalibration) -> str:
    """The human summary of a calibration.

    The human summary: per method a table of each quantity with its uncertainty and count,
    then counts, what is missing, and every rejection with its reason.
    """
    lines = []
    for name, session in outcome.sessions.items():
        lines.append(f'== {name}: {METHODS[name].title}')
        rows = [('quantity', 'value', 'std uncertainty', 'n'), *session.summary_rows()]
        widths = [max(len(row[i]) for row in rows) for i in range(4)]
        lines += ['  '.join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
        lines += session.summary_lines()
        for rej in session.rejections():
            lines.append(f'  rejected at {format_stamp(rej.stamp_ns)}: {rej.reason}')
        for notice in session.notices():
            lines.append(f'  note: {notice}')
        lines.append('')
    lines += outcome.notes
    bags = ', '.join(f'{i.path} ({i.duration_s:.3f} s)' for i in outcome.infos)
    lines.append(f'bag(s): {bags}; {outcome.messages} messages decoded')
    return '\n'.join(lines)
