"""``gyro-calib``: calibrate, inspect and simulate bags offline (no ROS graph needed).

    gyro-calib calibrate BAG [BAG ...] [--method NAME ...] [--out FILE] [--json] [--plot DIR]
    gyro-calib info BAG [BAG ...] [--method NAME ...] [--json]
    gyro-calib simulate SCENARIO --out BAG [--seed N] [--duration-s S] [--sample-rate-hz HZ]
    gyro-calib methods | --version
    gyro-calib report HANDOFF [BAG ...] --out DIR [--spec SPEC]   (certificate, HTML + PDF)
    gyro-calib batch MANIFEST --out DIR [--workers N | --scheduler URL] [--spec SPEC]
    gyro-calib export HANDOFF --format F --out FILE   (a navigation stack's own keys)

BAG is a rosbag2 directory, the .mcap file inside one or a lone .mcap file (read with its
own summary), or a CSV/text table of a static record (:mod:`gyro_calib.bagio.tables`). Every
output path is checked before any work (:mod:`gyro_calib.outputs`). Abbreviated flags are
not accepted (``--lat`` is an error, not ``--latitude-deg``). A flag that no method run
uses is refused (exit 2), naming the methods it applies to.

Without ``--method``, every method whose topics the bags hold runs (see ``gyro-calib
methods``). Several bags are taken together in stamp order.

Exit status: 0 done (at least one quantity measured; with ``--out`` the hand-off written,
listing what is still missing); 1 nothing could be calibrated; 2 bad input (path, bag, topic,
type, configuration, an output path that cannot be written), reported in one line. On any
failure no output file is written or overwritten — except an output that fails while being
written (disk full): one line then names it and what was written before it, each whole.
"""

from __future__ import annotations

import argparse
import importlib
import io
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from gyro_calib.bag_calibration import BagCalibration, calibrate_bags, json_document
from gyro_calib.errors import ConfigError, GyroCalibError
from gyro_calib.handoff import load_calibration, update_calibration
from gyro_calib.registry import METHODS, handoff_schema
from gyro_calib.session import CalibrationOptions
from gyro_calib.units import format_stamp

EXIT_OK, EXIT_NOT_CALIBRATED, EXIT_BAD_INPUT = 0, 1, 2

EXTRA_COMMANDS: tuple[str, ...] = (
    # method subcommands: modules 'gyro_calib.<method>.cli' with add_commands(subparsers)
    'gyro_calib.thermal.cli',
    'gyro_calib.noise.cli',
    'gyro_calib.report.cli',
    'gyro_calib.batch.cli',
    'gyro_calib.export.cli',
)
"""Modules that add a method's own subcommands (their parsers and code stay in the method)."""


class _Parser(argparse.ArgumentParser):
    """argparse with abbreviations off (``--lat`` is not silently ``--latitude-deg``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs['allow_abbrev'] = False
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        """One line, as every other bad input (argparse prints its usage block), exit 2."""
        command = self.prog.removeprefix('gyro-calib').strip()
        where = f'{command}: ' if command else ''
        self.exit(EXIT_BAD_INPUT, f'gyro-calib: error: {where}{" ".join(message.split())}; '
                                  f'see {self.prog} --help.\n')


FLAG_METHODS: dict[str, tuple[str, ...]] = {
    'latitude_deg': ('rbrlg', 'fog', 'thermal', 'triad'),
    'heading_deg': ('rbrlg', 'triad'),
    'position_table_revolutions': ('rbrlg',),
    'scale_factor_rad_per_pulse': ('dither', 'thermal', 'noise'),
    'scale_factor_counts_per_rad': ('noise',),
    'calibration': ('rbrlg', 'dither', 'thermal', 'noise'),
    'sense_axis_elevation_deg': ('thermal',),
    'sense_axis_azimuth_deg': ('thermal',),
}
"""Flag (argparse dest) → the methods that use it; a flag none of the methods run uses is
refused (:func:`refuse_unused_flags`). ``--config`` and ``--gyro-id`` serve every method."""


def _flag(dest: str) -> str:
    return '--' + dest.replace('_', '-')


def refuse_unused_flags(args: argparse.Namespace, methods: Sequence[str]) -> None:
    """Refuse a settings flag that none of ``methods`` uses.

    Raises:
        ConfigError: naming the flag, the methods run and the methods it applies to.
    """
    from gyro_calib.errors import ConfigError

    for dest, users in FLAG_METHODS.items():
        if getattr(args, dest, None) is None or any(m in users for m in methods):
            continue
        run = (f' to the method(s) run here ({", ".join(methods)})' if methods else
               ': no method runs on these bags')
        raise ConfigError(f'{_flag(dest)} does not apply{run}; it is used by '
                          f'{", ".join(users)}. Drop it, or choose the method with --method. '
                          'Nothing was read.')
    if not methods:  # the flags that serve every method serve none here
        for dest, flag in (('config', '--config'), ('gyro_id', '--gyro-id')):
            if getattr(args, dest, None):
                raise ConfigError(f'{flag} does not apply: no method runs on these bags. Drop '
                                  'it, or choose the method with --method. Nothing was read.')


def check_calibration_file(path: Path | None) -> None:
    """Load a ``--calibration`` hand-off file before any work.

    Load a ``--calibration`` hand-off file before any work, whether or not the methods
    run use it, so a wrong file is never silently ignored.

    Raises:
        HandoffError: the file is missing, unreadable or invalid.
    """
    if path is None:
        return
    from gyro_calib.handoff import load_calibration

    load_calibration(path, handoff_schema())


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gyro-calib`` console script; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        return int(args.run(args))
    except GyroCalibError as exc:
        print(f'gyro-calib: error: {" ".join(str(exc).split())}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # e.g. the disk filled while an output was written: one line
        from gyro_calib.outputs import os_error_text

        print(f'gyro-calib: error: {" ".join(os_error_text(exc).split())}; stopped there.',
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print('gyro-calib: interrupted; nothing written.', file=sys.stderr)
        return 130


def _parser() -> argparse.ArgumentParser:
    from gyro_calib import __version__

    parser = _Parser(
        prog='gyro-calib', description='Offline optical-gyro calibration from MCAP bags.')
    parser.add_argument('--version', action='version', version=f'gyro-calib {__version__}')
    sub = parser.add_subparsers(required=True, metavar='COMMAND', parser_class=_Parser)

    cal = sub.add_parser('calibrate', help='calibrate bags: every method whose topics are there')
    cal.add_argument('bags', nargs='+', type=Path, metavar='BAG',
                     help='rosbag2 MCAP bag (directory); several are taken together')
    method_arguments(cal)
    cal.add_argument('--out', type=Path, help='write (or update) the INS hand-off YAML here')
    cal.add_argument('--replace', action='store_true',
                     help="--out: take this run's values even where the file's are more precise "
                     'or disagree with them (a repaired gyro, a corrected bench setting)')
    cal.add_argument('--json', action='store_true',
                     help='print one JSON document of the results on stdout (the human summary '
                     'goes to stderr)')
    cal.add_argument('--plot', type=Path, metavar='DIR', help='write PNG figures into DIR '
                     '(created if absent, in an existing directory)')
    cal.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                     help='progress bar on stderr (default: when stderr is a terminal)')
    cal.set_defaults(run=_calibrate)
    from gyro_calib.report.cli import calibrate_arguments

    calibrate_arguments(cal)  # --report DIR, --spec

    info = sub.add_parser('info', help='topics, counts, duration, and what each method would use')
    info.add_argument('bags', nargs='+', type=Path, metavar='BAG')
    method_arguments(info)
    info.add_argument('--json', action='store_true',
                      help='print one JSON document on stdout (the shape of calibrate --json, '
                      'with each bag described)')
    info.set_defaults(run=_info)

    methods = sub.add_parser('methods', help='list the calibration methods and their topics')
    methods.set_defaults(run=_methods)

    for module in EXTRA_COMMANDS:
        importlib.import_module(module).add_commands(sub)

    sim = sub.add_parser('simulate', help='write a scenario bag from the simulators')
    sim.add_argument('scenario', nargs='?', help='scenario name (see --list)')
    sim.add_argument('--out', type=Path, help='bag directory to create (must not exist)')
    sim.add_argument('--list', action='store_true', help='list the scenarios and exit')
    sim.add_argument('--seed', type=int, help="the scenario's seed (each random source gets "
                     'SEED + k)')
    sim.add_argument('--duration-s', type=float, help='record length, s (where the scenario '
                     'has one; procedure-driven scenarios take their length from the '
                     'procedure)')
    sim.add_argument('--sample-rate-hz', type=float, help='sample (output) rate, Hz')
    sim.set_defaults(run=_simulate)
    return parser


def method_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags every calibrating subcommand shares (methods, settings, site, scale factors)."""
    parser.add_argument('--method', action='append', choices=list(METHODS), metavar='NAME',
                        help=f'run only these methods ({", ".join(METHODS)}); repeatable')
    parser.add_argument('--config', type=Path, help="the method's settings YAML (the node's "
                        'config_file: plain mapping or ROS 2 parameter file)')
    parser.add_argument('--latitude-deg', type=float,
                        help='site latitude, ° (default: the bench settings stored in the '
                        'bag, else unknown: bias not separated from Earth rate)')
    parser.add_argument('--heading-deg', type=float,
                        help='rbrlg: heading of the position-table base x axis, from East '
                        'towards North (0 = East, 90 = North; = 90 − an azimuth), °')
    parser.add_argument('--position-table-revolutions', type=int,
                        help='rbrlg: n, position-table revolutions each way per station')
    parser.add_argument('--scale-factor-rad-per-pulse', type=float,
                        help="a pulse gyro's scale factor K, rad/pulse (dither, thermal, noise)")
    parser.add_argument('--scale-factor-counts-per-rad', type=float,
                        help="a FOG's scale factor, counts/rad (noise)")
    parser.add_argument('--calibration', type=Path, metavar='FILE',
                        help='a hand-off file to take the scale factor (and gyro id) from')
    parser.add_argument('--sense-axis-elevation-deg', type=float,
                        help='thermal: sense-axis elevation on the static base, ° (default 90: '
                        'vertical)')
    parser.add_argument('--sense-axis-azimuth-deg', type=float,
                        help='thermal: sense-axis azimuth, from North towards East (0 = '
                        'North, 90 = East; = 90 − a heading), °')
    parser.add_argument('--gyro-id', default='', help="the gyro's serial or name (hand-off)")
    namespace_argument(parser)


def namespace_argument(parser: argparse.ArgumentParser) -> None:
    """``--namespace NS``: read the topics of the bench in namespace NS."""
    parser.add_argument('--namespace', metavar='NS',
                        help="read the method's topics under NS (e.g. /bench2, for a bag "
                        'recorded from several benches; default: the root, or the one '
                        'namespace the bag holds)')


def options_from_args(args: argparse.Namespace) -> CalibrationOptions:
    """The CalibrationOptions of the common flags (also used by method subcommands)."""
    return CalibrationOptions(
        latitude_deg=args.latitude_deg, heading_deg=args.heading_deg, config_file=args.config,
        position_table_revolutions=args.position_table_revolutions,
        scale_factor_rad_per_pulse=args.scale_factor_rad_per_pulse,
        scale_factor_counts_per_rad=args.scale_factor_counts_per_rad,
        calibration_file=args.calibration,
        sense_axis_elevation_deg=args.sense_axis_elevation_deg,
        sense_axis_azimuth_deg=args.sense_axis_azimuth_deg, gyro_id=args.gyro_id)


_options = options_from_args


def _refuse_a_bag_given_twice(bags: Sequence[Path]) -> None:
    """The same bag twice would count its data twice (and shrink every u by √2)."""
    seen: dict[Path, Path] = {}
    for bag in bags:
        key = Path(bag).resolve()
        if key in seen:
            raise ConfigError(f'bag {bag} is given twice (as {seen[key]} too): its data would '
                              'be counted twice; give each bag once.')
        seen[key] = Path(bag)


def _calibrate(args: argparse.Namespace) -> int:
    from gyro_calib.bag_calibration import bag_infos, select_methods
    from gyro_calib.outputs import check_output_file, check_plot_dir

    if args.out is not None:
        check_output_file(args.out, '--out', follow_links=True)
        if args.out.exists():
            from gyro_calib.handoff import HandoffError, load_calibration

            try:  # a file that cannot be updated: refused before work
                load_calibration(args.out, handoff_schema())
            except HandoffError as exc:
                raise ConfigError(f'--out {args.out} exists and cannot be updated: {exc} Give '
                                  'a new path, or move the file away.') from None
    plot_dir = check_plot_dir(args.plot) if args.plot is not None else None
    if any(v is not None for v in (args.report, args.spec, args.lab, args.customer)):  # first
        from gyro_calib.report.cli import check_calibrate_report

        check_calibrate_report(args)
    check_calibration_file(args.calibration)
    _refuse_a_bag_given_twice(args.bags)
    infos, _ = bag_infos(args.bags, args.namespace)
    to_run = [m.name for m in select_methods(infos, args.method)]
    refuse_unused_flags(args, to_run)
    if args.report is not None and 'triad' in to_run:
        raise ConfigError('--report: certificates do not cover a triad yet; calibrate it '
                          'without --report (--out writes its imu: section to the hand-off).')
    show = sys.stderr.isatty() if args.progress is None else args.progress
    outcome = _run_with_progress(args, show)
    # the human text goes out only once the files are written: a refusal on the way (a
    # hand-off the run cannot be merged into, a full disk) leaves one line on stderr and
    # nothing on stdout
    human, document = io.StringIO(), io.StringIO()
    status = _calibrate_outputs(args, outcome, human, document, plot_dir)
    (sys.stderr if args.json else sys.stdout).write(human.getvalue())
    sys.stdout.write(document.getvalue())
    return status


def _calibrate_outputs(args: argparse.Namespace, outcome: BagCalibration, human: Any,
                       document: Any, plot_dir: Path | None) -> int:
    """Summary, hand-off, figures, certificate and JSON of a finished calibration.

    An output that fails while being written (disk full) ends the command in one line
    naming it and what was written before it.
    """
    from gyro_calib.outputs import write_failed, write_figures

    print(summary_text(outcome), file=human)

    def print_json() -> None:  # last: a command whose files failed prints nothing on stdout
        if args.json:
            print(json.dumps(json_document(outcome), indent=1, allow_nan=False,
                             default=_json_default), file=document)
    if not outcome.calibrated_anything:
        print_json()
        print('gyro-calib: nothing could be calibrated from the bag(s); nothing written.',
              file=sys.stderr)
        return EXIT_NOT_CALIBRATED
    # the hand-off first: the measured values are kept whatever happens to a figure
    status = _write_handoff(args, outcome, human) if args.out is not None else EXIT_OK
    written = [f'--out {args.out}'] if status == EXIT_OK and args.out is not None else []
    if plot_dir is not None:
        try:
            figures = write_figures(plot_dir, lambda stage: [
                path for session in outcome.sessions.values() for path in session.plot(stage)])
        except OSError as exc:
            raise write_failed(exc, '--plot', plot_dir, written) from None
        for path in figures:
            print(f'figure written: {path.resolve()}', file=human)
        written.append(f'--plot {plot_dir}')
    if args.report is not None and status == EXIT_OK:
        from gyro_calib.report.cli import report_after_calibrate

        try:
            report_after_calibrate(args, outcome, human)
        except OSError as exc:
            raise write_failed(exc, '--report', args.report, written) from None
    print_json()
    return status


def _write_handoff(args: argparse.Namespace, outcome: BagCalibration, human: Any) -> int:
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


def _json_default(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, 'tolist'):
        return value.tolist()
    raise TypeError(f'{type(value).__name__} is not JSON serialisable')


def _run_with_progress(args: argparse.Namespace, show: bool) -> BagCalibration:
    options = _options(args)
    if not show:
        return calibrate_bags(args.bags, methods=args.method, options=options,
                              namespace=args.namespace)
    from tqdm import tqdm

    with tqdm(total=1000, desc='calibrating', unit='‰', file=sys.stderr,
              bar_format='{desc} {percentage:3.0f}%|{bar}| {elapsed}<{remaining}') as bar:
        def progress(fraction: float) -> None:
            bar.update(int(fraction * 1000) - bar.n)
        return calibrate_bags(args.bags, methods=args.method, options=options,
                              progress=progress, namespace=args.namespace)


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


def method_prospects(infos: Sequence[Any]) -> dict[str, dict[str, Any]]:
    """What each method could do with the bag(s): ``{"runs": bool, "how": line}`` by name.

    An automatic method runs when its revealing topics are all there with their types; a
    method that runs only when asked (noise) is offered for each input it could read.
    """
    from gyro_calib.bag_calibration import merged_topics
    from gyro_calib.registry import methods_revealed

    present = merged_topics(infos)
    counts: dict[str, int] = {}
    for info in infos:
        for t in info.topics.values():
            counts[t.name] = counts.get(t.name, 0) + t.count
    revealed = {m.name for m in methods_revealed(
        {t: m for t, m in present.items() if counts.get(t)})}
    out: dict[str, dict[str, Any]] = {}
    for m in METHODS.values():
        if m.auto:
            lacking = [f'{t} ({m.topics[t]})' for t in m.reveal
                       if present.get(t) != m.topics[t] or not counts.get(t)]
            out[m.name] = ({'runs': True, 'how': 'runs by default (gyro-calib calibrate)'}
                           if m.name in revealed else
                           {'runs': False, 'how': f'needs {", ".join(lacking)}'})
            continue
        inputs = [t for t, typ in m.inputs().items() if present.get(t) == typ and counts.get(t)]
        if m.any_topic:
            inputs += sorted(t for t, typ in present.items()
                             if typ == m.any_topic and counts.get(t))
        out[m.name] = ({'runs': True, 'how': f'gyro-calib {m.name} BAG --topic T, T one of '
                        f'{", ".join(inputs)}'} if inputs else
                       {'runs': False, 'how': 'needs one of '
                        + ', '.join([*m.inputs(), *([f"a {m.any_topic} topic"]
                                                  if m.any_topic else [])])})
    return out


def bag_description(info: Any) -> dict[str, Any]:
    """One bag's description for ``info``.

    One bag for ``info``: span, topics with counts and rates from the header stamps
    (the sample instants; log times only for types without a decodable header).
    """
    from gyro_calib.bagio import header_stamp_spans

    spans = header_stamp_spans(info.path, info) if info.message_count else {}
    topics = []
    for t in sorted(info.topics.values(), key=lambda t: t.name):
        n, lo, hi, step_ns = spans.get(t.name, (0, 0, 0, math.nan))
        if n > 1 and step_ns > 0:
            rate, basis = 1e9 / step_ns, 'header stamps, median step'
        elif info.duration_s > 0 and t.count > 1:
            rate, basis = (t.count - 1) / info.duration_s, 'log times'
        else:
            rate, basis = math.nan, 'too few messages'
        topics.append({'name': t.name, 'type': t.msgtype, 'count': t.count,
                       'rate_hz': rate if math.isfinite(rate) else None, 'rate_from': basis})
    scenario = info.scenario if isinstance(info.scenario, dict) else {}
    return {'path': str(info.path), 'duration_s': info.duration_s,
            'start_ns': info.start_ns, 'end_ns': info.end_ns, 'messages': info.message_count,
            'topics': topics, 'scenario_name': scenario.get('name'),
            'scenario_description': scenario.get('description'),
            'stored_settings': sorted(scenario)}


def _print_bag(desc: dict[str, Any], out: Any) -> None:
    print(f'bag: {desc["path"]}', file=out)
    print(f'duration: {desc["duration_s"]:.3f} s  ({desc["start_ns"] / 1e9:.6f} s → '
          f'{desc["end_ns"] / 1e9:.6f} s, log times), messages: {desc["messages"]}', file=out)
    width = max([len(t['name']) for t in desc['topics']] + [5])
    print(f'{"topic".ljust(width)}  {"type":28}  {"count":>9}  {"rate Hz":>9}  (rate from)',
          file=out)
    for t in desc['topics']:
        rate = f'{t["rate_hz"]:9.1f}' if t['rate_hz'] is not None else f'{"—":>9}'
        print(f'{t["name"].ljust(width)}  {t["type"]:28}  {t["count"]:9d}  {rate}  '
              f'({t["rate_from"]})', file=out)
    if desc['scenario_name']:
        print(f'scenario: {desc["scenario_name"]} — {desc["scenario_description"] or ""}',
              file=out)
    elif desc['stored_settings']:
        print(f'scenario: none named (recorded live); stored bench settings: '
              f'{", ".join(desc["stored_settings"])}', file=out)


def _info(args: argparse.Namespace) -> int:
    from gyro_calib.bag_calibration import bag_infos

    check_calibration_file(args.calibration)
    infos, namespace_note = bag_infos(args.bags, args.namespace)
    human = sys.stderr if args.json else sys.stdout
    if namespace_note:
        print(f'note: {namespace_note}', file=human)
    descriptions = [bag_description(i) for i in infos]
    prospects = method_prospects(infos)
    names = list(args.method or [n for n, p in prospects.items()
                                 if p['runs'] and METHODS[n].auto])
    refuse_unused_flags(args, names)  # also when no method runs: before anything is printed
    for desc in descriptions:
        _print_bag(desc, human)
    print('what each method could do with the bag(s):', file=human)
    for name, p in prospects.items():
        print(f'  {name:8} {"yes" if p["runs"] else "no ":3}  {p["how"]}', file=human)
    doc: dict[str, Any] = {'command': 'info', 'methods': {},
                           'bags': [str(i.path) for i in infos], 'messages': 0,
                           'bag_info': descriptions}
    if names:
        outcome = calibrate_bags(args.bags, methods=names, options=_options(args),
                                 namespace=args.namespace)
        doc = {**json_document(outcome, 'info'), 'bag_info': descriptions}
        for name, session in outcome.sessions.items():
            print(f'== {name}: {METHODS[name].title}', file=human)
            for line in session.info_lines():
                print(line, file=human)
            rejections = session.rejections()
            print(f'rejected: {len(rejections)}', file=human)
            for rej in rejections:
                print(f'  {format_stamp(rej.stamp_ns)}: {rej.reason}', file=human)
            print(f'limits the result: {session.limiting()}', file=human)
            doc['methods'][name]['limiting'] = session.limiting()
    for name, p in prospects.items():
        doc['methods'].setdefault(name, {'results': {}, 'missing': {}, 'rejections': []})
        doc['methods'][name]['prospect'] = p
    if args.json:
        print(json.dumps(doc, indent=1, allow_nan=False, default=_json_default))
    return EXIT_OK


def _methods(args: argparse.Namespace) -> int:
    for m in METHODS.values():
        print(f'{m.name:8} {m.title}' + ('' if m.auto else '  [runs when asked: --method '
                                              f'{m.name} or gyro-calib {m.name}]'))
        for topic, msgtype in m.topics.items():
            need = ('needed' if topic in m.reveal else 'optional, beside the input'
                    if topic in m.context else 'one of these' if not m.reveal else 'optional')
            print(f'           {topic:32} {msgtype:28} {need}')
        if m.any_topic:
            print(f'           {"any topic (--topic)":32} {m.any_topic:28} one of these')
    return EXIT_OK


def _simulate(args: argparse.Namespace) -> int:
    from sim_nodes.scenarios import GROUPS, SCENARIOS

    if args.list:
        for name, sc in SCENARIOS.items():
            print(f'{name:28} {sc.description}')
        for name, members in GROUPS.items():
            print(f'{name:28} One bag each (--out is a directory): {", ".join(members)}.')
        return EXIT_OK
    if args.scenario is None or args.out is None:
        print('gyro-calib: error: simulate needs SCENARIO and --out BAG '
              '(gyro-calib simulate --list shows the scenarios).', file=sys.stderr)
        return EXIT_BAD_INPUT
    from gyro_calib.outputs import check_new_directory
    from sim_nodes.scenarios import scenario_parameters, write_scenario_bag_with

    check_new_directory(args.out, '--out')  # exists, no parent, cannot be written: refused
    if args.scenario not in SCENARIOS and args.scenario not in GROUPS:
        print(f'gyro-calib: error: unknown scenario {args.scenario!r}; known: '
              f'{", ".join([*SCENARIOS, *GROUPS])}.', file=sys.stderr)
        return EXIT_BAD_INPUT
    overrides = {k: v for k, v in (('seed', args.seed), ('duration_s', args.duration_s),
                                   ('sample_rate_hz', args.sample_rate_hz)) if v is not None}
    for key in ('duration_s', 'sample_rate_hz'):
        if key in overrides and not (math.isfinite(overrides[key]) and overrides[key] > 0):
            print(f'gyro-calib: error: --{key.replace("_", "-")} = {overrides[key]!r} is '
                  'invalid: it must be a positive number.', file=sys.stderr)
            return EXIT_BAD_INPUT
    try:
        write_scenario_bag_with(args.scenario, args.out, overrides)
    except KeyError as exc:
        print(f'gyro-calib: error: {exc.args[0]}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # the bag is written whole (a .partial directory renamed) or not
        from gyro_calib.outputs import write_failed

        raise write_failed(exc, '--out', args.out) from None
    changed = ', '.join(f'{k} = {v}' for k, v in overrides.items())
    member = GROUPS.get(args.scenario, (args.scenario,))[0]
    print(f'wrote {args.out}' + (f' ({changed}; defaults: {scenario_parameters(member)})'
                                 if changed else ''))
    return EXIT_OK


def console_main() -> None:
    """Console-script wrapper for setuptools."""
    sys.exit(main())


if __name__ == '__main__':
    console_main()
