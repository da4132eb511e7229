"""``gyro-calib``: calibrate, inspect and simulate bags offline (no ROS graph needed).

    gyro-calib calibrate BAG [BAG ...] [--method NAME ...] [--out FILE] [--json] [--plot DIR]
    gyro-calib info BAG [BAG ...] [--method NAME ...]
    gyro-calib simulate SCENARIO --out BAG      (gyro-calib simulate --list)

Without ``--method``, every method whose topics the bags hold runs (see ``gyro-calib
methods``). Several bags are taken together in stamp order.

Exit status: 0 done (at least one quantity measured; with ``--out`` the hand-off written,
listing what is still missing); 1 nothing could be calibrated; 2 bad input (path, bag, topic,
type, configuration), reported in one line. On any failure no output file is written or
overwritten.
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from gyro_calib.bag_calibration import BagCalibration, calibrate_bags, json_document
from gyro_calib.errors import GyroCalibError
from gyro_calib.handoff import update_calibration
from gyro_calib.registry import METHODS
from gyro_calib.session import CalibrationOptions
from gyro_calib.units import format_stamp

EXIT_OK, EXIT_NOT_CALIBRATED, EXIT_BAD_INPUT = 0, 1, 2

EXTRA_COMMANDS: tuple[str, ...] = (
    # method subcommands: modules 'gyro_calib.<method>.cli' with add_commands(subparsers)
    'gyro_calib.thermal.cli',
    'gyro_calib.noise.cli',
)
"""Modules that add a method's own subcommands (their parsers and code stay in the method)."""


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gyro-calib`` console script; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        return int(args.run(args))
    except GyroCalibError as exc:
        print(f'gyro-calib: error: {" ".join(str(exc).split())}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print('gyro-calib: interrupted; nothing written.', file=sys.stderr)
        return 130


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='gyro-calib', description='Offline optical-gyro calibration from MCAP bags.')
    sub = parser.add_subparsers(required=True, metavar='COMMAND')

    cal = sub.add_parser('calibrate', help='calibrate bags: every method whose topics are there')
    cal.add_argument('bags', nargs='+', type=Path, metavar='BAG',
                     help='rosbag2 MCAP bag (directory); several are taken together')
    method_arguments(cal)
    cal.add_argument('--out', type=Path, help='write (or update) the INS hand-off YAML here')
    cal.add_argument('--json', action='store_true',
                     help='print one JSON document of the results on stdout (the human summary '
                     'goes to stderr)')
    cal.add_argument('--plot', type=Path, metavar='DIR', help='write PNG figures into DIR')
    cal.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                     help='progress bar on stderr (default: when stderr is a terminal)')
    cal.set_defaults(run=_calibrate)

    info = sub.add_parser('info', help='topics, counts, duration, and what each method would use')
    info.add_argument('bags', nargs='+', type=Path, metavar='BAG')
    method_arguments(info)
    info.set_defaults(run=_info)

    methods = sub.add_parser('methods', help='list the calibration methods and their topics')
    methods.set_defaults(run=_methods)

    for module in EXTRA_COMMANDS:
        importlib.import_module(module).add_commands(sub)

    sim = sub.add_parser('simulate', help='write a scenario bag from the simulators')
    sim.add_argument('scenario', nargs='?', help='scenario name (see --list)')
    sim.add_argument('--out', type=Path, help='bag directory to create (must not exist)')
    sim.add_argument('--list', action='store_true', help='list the scenarios and exit')
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
    parser.add_argument('--heading-deg', type=float, help='table-base heading from East, °')
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
                        help='thermal: sense-axis azimuth from North, °')
    parser.add_argument('--gyro-id', default='', help="the gyro's serial or name (hand-off)")


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


def _calibrate(args: argparse.Namespace) -> int:
    if args.out is not None and args.out.is_dir():
        print(f'gyro-calib: error: --out {args.out} is a directory.', file=sys.stderr)
        return EXIT_BAD_INPUT
    show = sys.stderr.isatty() if args.progress is None else args.progress
    outcome = _run_with_progress(args, show)
    human = sys.stderr if args.json else sys.stdout
    print(summary_text(outcome), file=human)
    if args.plot is not None:
        for session in outcome.sessions.values():
            for path in session.plot(args.plot):
                print(f'figure written: {path.resolve()}', file=human)
    if args.json:
        print(json.dumps(json_document(outcome), indent=1, allow_nan=False,
                         default=_json_default))
    if not outcome.calibrated_anything:
        print('gyro-calib: nothing could be calibrated from the bag(s); nothing written.',
              file=sys.stderr)
        return EXIT_NOT_CALIBRATED
    if args.out is not None:
        return _write_handoff(args, outcome, human)
    return EXIT_OK


def _write_handoff(args: argparse.Namespace, outcome: BagCalibration, human: Any) -> int:
    record = None
    for session in outcome.sessions.values():
        part = session.handoff(outcome.source, gyro_id=args.gyro_id)
        if part is None:
            continue
        from gyro_calib.registry import handoff_schema

        record = part if record is None else part.merged_into(record, handoff_schema())
    if record is None:
        print(f'gyro-calib: {args.out} not written: no method measured a hand-off value.',
              file=sys.stderr)
        return EXIT_NOT_CALIBRATED
    path = update_calibration(args.out, record)
    print(f'hand-off written: {path}', file=human)
    missing = record.missing
    if missing:
        print(f'hand-off incomplete ({len(missing)} missing):', file=human)
        for key, why in missing.items():
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
        return calibrate_bags(args.bags, methods=args.method, options=options)
    from tqdm import tqdm

    with tqdm(total=1000, desc='calibrating', unit='‰', file=sys.stderr,
              bar_format='{desc} {percentage:3.0f}%|{bar}| {elapsed}<{remaining}') as bar:
        def progress(fraction: float) -> None:
            bar.update(int(fraction * 1000) - bar.n)
        return calibrate_bags(args.bags, methods=args.method, options=options,
                              progress=progress)


def summary_text(outcome: BagCalibration) -> str:
    """The human summary: per method a table of each quantity with its uncertainty and count,
    then counts, what is missing, and every rejection with its reason."""
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
    bags = ', '.join(f'{i.path} ({i.duration_s:.3f} s)' for i in outcome.infos)
    lines.append(f'bag(s): {bags}; {outcome.messages} messages decoded')
    return '\n'.join(lines)


def _info(args: argparse.Namespace) -> int:
    from gyro_calib.bag import bag_info

    for path in args.bags:
        info = bag_info(path)
        print(f'bag: {info.path}')
        print(f'duration: {info.duration_s:.3f} s  ({info.start_ns / 1e9:.6f} s → '
              f'{info.end_ns / 1e9:.6f} s), messages: {info.message_count}')
        width = max([len(t) for t in info.topics] + [5])
        print(f'{"topic".ljust(width)}  {"type":28}  {"count":>9}  {"rate Hz":>9}')
        for t in sorted(info.topics.values(), key=lambda t: t.name):
            rate = t.count / info.duration_s if info.duration_s > 0 else 0.0
            print(f'{t.name.ljust(width)}  {t.msgtype:28}  {t.count:9d}  {rate:9.1f}')
        if info.scenario:
            print(f'scenario: {info.scenario.get("name", "?")} — '
                  f'{info.scenario.get("description", "")}')
    outcome = calibrate_bags(args.bags, methods=args.method, options=_options(args))
    for name, session in outcome.sessions.items():
        print(f'== {name}: {METHODS[name].title}')
        for line in session.info_lines():
            print(line)
        rejections = session.rejections()
        print(f'rejected: {len(rejections)}')
        for rej in rejections:
            print(f'  {format_stamp(rej.stamp_ns)}: {rej.reason}')
        print(f'limits the result: {session.limiting()}')
    return EXIT_OK


def _methods(args: argparse.Namespace) -> int:
    for m in METHODS.values():
        print(f'{m.name:8} {m.title}')
        for topic, msgtype in m.topics.items():
            need = 'needed' if topic in m.reveal else 'optional'
            print(f'           {topic:32} {msgtype:28} {need}')
    return EXIT_OK


def _simulate(args: argparse.Namespace) -> int:
    from sim_nodes.scenarios import SCENARIOS, write_scenario_bag

    if args.list:
        for name, sc in SCENARIOS.items():
            print(f'{name:28} {sc.description}')
        return EXIT_OK
    if args.scenario is None or args.out is None:
        print('gyro-calib: error: simulate needs SCENARIO and --out BAG '
              '(gyro-calib simulate --list shows the scenarios).', file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.out.exists():
        print(f'gyro-calib: error: {args.out}: exists already; not overwriting it.',
              file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.scenario not in SCENARIOS:
        print(f'gyro-calib: error: unknown scenario {args.scenario!r}; known: '
              f'{", ".join(SCENARIOS)}.', file=sys.stderr)
        return EXIT_BAD_INPUT
    write_scenario_bag(args.scenario, args.out)
    print(f'wrote {args.out}')
    return EXIT_OK


def console_main() -> None:
    """setuptools console-script wrapper."""
    sys.exit(main())


if __name__ == '__main__':
    console_main()
