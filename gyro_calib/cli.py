"""``gyro-calib``: calibrate, inspect and simulate bags offline (no ROS graph needed).

    gyro-calib calibrate BAG [--out calib.yaml] [--config k_tilde.yaml] [--latitude-deg ..]
    gyro-calib info BAG
    gyro-calib simulate SCENARIO --out BAG      (gyro-calib simulate --list)

Exit status: 0 done; 1 nothing could be calibrated (or the hand-off asked for with
``--out`` is incomplete); 2 bad input (path, bag, topic, type, configuration), reported
in one line. On any failure no output file is written or overwritten.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from gyro_calib.bag import BagInfo, bag_info
from gyro_calib.bag_calibration import BagCalibration, calibrate_bag
from gyro_calib.rbrlg.config import KTildeConfig, load_k_tilde_config
from gyro_calib.errors import GyroCalibError
from gyro_calib.handoff import write_calibration
from gyro_calib.rbrlg.calibration import RbrlgCalibrator, handoff_calibration
from gyro_calib.units import RAD_PER_ARCSEC

EXIT_OK, EXIT_NOT_CALIBRATED, EXIT_BAD_INPUT = 0, 1, 2


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

    cal = sub.add_parser('calibrate', help='calibrate a bag: K̃, θ, K, bias')
    cal.add_argument('bag', type=Path, help='rosbag2 MCAP bag (directory)')
    cal.add_argument('--out', type=Path, help='write the INS hand-off YAML here')
    _bench_arguments(cal)
    cal.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                     help='progress bar on stderr (default: when stderr is a terminal)')
    cal.set_defaults(run=_calibrate)

    info = sub.add_parser('info', help='topics, counts, duration, windows and stations')
    info.add_argument('bag', type=Path)
    _bench_arguments(info)
    info.set_defaults(run=_info)

    sim = sub.add_parser('simulate', help='write a scenario bag from the simulators')
    sim.add_argument('scenario', nargs='?', help='scenario name (see --list)')
    sim.add_argument('--out', type=Path, help='bag directory to create (must not exist)')
    sim.add_argument('--list', action='store_true', help='list the scenarios and exit')
    sim.set_defaults(run=_simulate)
    return parser


def _bench_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--config', type=Path, help='K̃ settings YAML (the calibration '
                        "node's config_file: plain mapping or ROS 2 parameter file)")
    parser.add_argument('--latitude-deg', type=float,
                        help='site latitude, ° (default: the bench settings stored in the '
                        'bag, else unknown: bias not separated from Earth rate)')
    parser.add_argument('--heading-deg', type=float, help='table-base heading from East, °')
    parser.add_argument('--position-table-revolutions', type=int,
                        help='n, position-table revolutions each way per station')


def _calibrator(args: argparse.Namespace, info: BagInfo) -> RbrlgCalibrator:
    """Flags first, then the bench settings stored in the bag, then the defaults."""
    stored = info.scenario.get('bench', {}) if isinstance(info.scenario, dict) else {}
    k_config = load_k_tilde_config(args.config) if args.config else KTildeConfig()

    def pick(flag: Any, key: str, default: Any) -> Any:
        return flag if flag is not None else stored.get(key, default)

    return RbrlgCalibrator(
        k_config=k_config,
        position_table_revolutions=int(pick(args.position_table_revolutions,
                                            'position_table_revolutions', 1)),
        latitude_deg=float(pick(args.latitude_deg, 'latitude_deg', math.nan)),
        heading_deg=float(pick(args.heading_deg, 'heading_deg', 0.0)))


def _calibrate(args: argparse.Namespace) -> int:
    if args.out is not None and args.out.is_dir():
        print(f'gyro-calib: error: --out {args.out} is a directory.', file=sys.stderr)
        return EXIT_BAD_INPUT
    info = bag_info(args.bag)
    calibrator = _calibrator(args, info)
    show = sys.stderr.isatty() if args.progress is None else args.progress
    outcome = _run_with_progress(args.bag, calibrator, show)
    print(summary_table(outcome))
    if not outcome.calibrated_anything:
        print('gyro-calib: nothing could be calibrated from this bag (no K̃); '
              'nothing written.', file=sys.stderr)
        return EXIT_NOT_CALIBRATED
    if args.out is not None:
        record = handoff_calibration(outcome.results, outcome.calibrator,
                                     source=str(args.bag))
        if record is None:
            missing = _missing_for_handoff(outcome)
            print(f'gyro-calib: {args.out} not written: the hand-off needs K̃, θ, K and the '
                  f'bias; missing {missing}.', file=sys.stderr)
            return EXIT_NOT_CALIBRATED
        write_calibration(args.out, record)
        print(f'hand-off written: {args.out}')
    return EXIT_OK


def _run_with_progress(bag: Path, calibrator: RbrlgCalibrator, show: bool) -> BagCalibration:
    if not show:
        return calibrate_bag(bag, calibrator)
    from tqdm import tqdm

    with tqdm(total=1000, desc='calibrating', unit='‰', file=sys.stderr,
              bar_format='{desc} {percentage:3.0f}%|{bar}| {elapsed}<{remaining}') as bar:
        def progress(fraction: float) -> None:
            bar.update(int(fraction * 1000) - bar.n)
        return calibrate_bag(bag, calibrator, progress=progress)


def _missing_for_handoff(outcome: BagCalibration) -> str:
    r = outcome.results
    missing = [name for name, value in (('K̃', r.k_tilde_arcsec_per_pulse),
                                        ('θ', r.fix_error),
                                        ('K', r.scale_factor_arcsec_per_pulse),
                                        ('bias', r.bias_deg_h)) if value is None]
    text = ', '.join(missing)
    if r.bias_deg_h is None and r.earth_plus_bias_deg_h is not None and r.fix_error:
        text += ' (give --latitude-deg to separate the bias from the Earth rate)'
    if r.fix_error_problem:
        text += f' — {r.fix_error_problem}'
    return text


def summary_table(outcome: BagCalibration) -> str:
    """The human summary: each quantity with its uncertainty and count, then windows,
    stations and every rejection reason."""
    r = outcome.results
    rows = [('quantity', 'value', 'std uncertainty', 'n')]

    def add(name: str, est: Any, scale: float = 1.0, fmt: str = '.9f') -> None:
        if est is None:
            rows.append((name, '—', '', ''))
        else:
            rows.append((name, f'{est.value * scale:{fmt}}',
                         f'{est.std_uncertainty * scale:.3g}', str(est.n_used)))

    add('K̃ (″/pulse)', r.k_tilde_arcsec_per_pulse)
    add('θ (″)', r.fix_error.fix_error_angle_rad if r.fix_error else None,
        1.0 / RAD_PER_ARCSEC, '.3f')
    add('α (°)', r.fix_error.tilt_rad if r.fix_error else None, math.degrees(1.0), '.5f')
    add('K (″/pulse)', r.scale_factor_arcsec_per_pulse)
    add('ω′ₑ+ω_B (°/h)', r.earth_plus_bias_deg_h, fmt='.5f')
    add('bias ω_B (°/h)', r.bias_deg_h, fmt='.5f')
    widths = [max(len(row[i]) for row in rows) for i in range(4)]
    lines = ['  '.join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]
    cal = outcome.calibrator
    lines.append('')
    lines.append(f'bag: {outcome.info.path}  ({outcome.messages} messages, '
                 f'{outcome.info.duration_s:.3f} s)')
    lines.append(f'K̃ windows accepted: {len(cal.k_tilde.windows)}, pairs: '
                 f'{len(cal.k_tilde.pairs)}; stations: {len(cal.stations.stations)}; '
                 f'rejected: {len(outcome.rejections)}')
    if r.fix_error_problem:
        lines.append(f'θ: {r.fix_error_problem}')
    for rej in outcome.rejections:
        lines.append(f'  rejected at t={rej.stamp_ns / 1e9:.6f} s: {rej.reason}')
    for notice in outcome.notices:
        lines.append(f'  note: {notice}')
    return '\n'.join(lines)


def _info(args: argparse.Namespace) -> int:
    info = bag_info(args.bag)
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
    outcome = calibrate_bag(args.bag, _calibrator(args, info))
    cal = outcome.calibrator
    print(f'K̃ windows it would use: {len(cal.k_tilde.windows)} '
          f'({len(cal.k_tilde.pairs)} forward/reverse pairs)')
    for w in cal.k_tilde.windows:
        print(f'  t={w.start_ns / 1e9:.6f} s → {w.end_ns / 1e9:.6f} s  '
              f'{w.direction * w.revolutions:+d} rev  N = {w.pulses:.3f} pulses')
    print(f'θ stations it would use: {len(cal.stations.stations)}')
    for s in cal.stations.stations:
        print(f'  β = {math.degrees(s.rate_table_angle_rad):.4f}°  '
              f'N_og = {s.half_difference_pulses:.3f} pulses')
    print(f'rejected: {len(outcome.rejections)}')
    for rej in outcome.rejections:
        print(f'  t={rej.stamp_ns / 1e9:.6f} s: {rej.reason}')
    return EXIT_OK


def _simulate(args: argparse.Namespace) -> int:
    from sim_nodes.rbrlg.scenarios import SCENARIOS, write_scenario_bag

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
