"""``gyro-calib compensate``: apply a gyro's thermal bias model to a bag (METHODS §D, §E).

    gyro-calib compensate BAG [BAG ...] --calibration FILE [--out BAG2] [--json] [--plot DIR]
                          [--gyro-id ID] [--skip-out-of-range] [--block-s 100]

Needs nothing but the hand-off file: its ``thermal_model`` carries the scale factor the model
was fitted with, the averaging interval and Ḣ window, the calibrated range, the site and the
gyro id. The bag(s) must hold /gyro/pulses and /gyro/temperature; they are streamed (bounded
memory) and reduced exactly as the calibration reduced its run. Reported (the unfiltered
rate throughout; :func:`gyro_calib.thermal.compensate.compensate`):

- ``bias_stability_raw_rad_s``: std of consecutive ``--block-s`` (100 s) means of K·ΔN/Δt;
- ``bias_stability_compensated_rad_s``: the same of raw − model;
- ``mean_rate_compensated_rad_s``: mean of raw − model (on a static base the Earth rate
  along the sense axis, printed beside it);
- ``bias_stability_noise_floor_rad_s``: what angle random walk and pulse quantisation alone
  give for 100 s means — the compensated figure cannot honestly go below it;
- the overlapping Allan deviation of the interval rates before and after.

``--out BAG2`` writes a copy of the (single) bag with the compensated rate added on
``/gyro/imu`` (sensor_msgs/Imu, one message per pulse sample after the first, stamped with
its later sample, log time = that pulse message's; angular_velocity.z = K·Δn/Δt − b with b
the model's bias of the averaging interval holding the sample's midpoint, and the variance
imu_corrector gives; no message where the model gives no bias). Exit status as
``gyro-calib calibrate``: 0 done, 2 bad input (one line naming what was wrong); on any
failure nothing is written.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
from pathlib import Path
from typing import Any

from gyro_calib.errors import ConfigError
from gyro_calib.registry import IMU
from gyro_calib.thermal.topics import GYRO_IMU

PRELOAD: tuple[str, ...] = (
    'gyro_calib.bag_compensation',
    'gyro_calib.thermal.compensation_summary',
    'gyro_calib.outputs',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def add_commands(subparsers: Any) -> None:
    """Add ``compensate`` to the ``gyro-calib`` subcommands."""
    p = subparsers.add_parser(
        'compensate', help='apply a thermal bias model to bags: bias stability before/after, '
        'noise floor, Allan deviation; --out writes the compensated rate',
        description=__doc__.split('\n\n')[0])
    p.add_argument('bags', nargs='+', type=Path, metavar='BAG',
                   help='rosbag2 MCAP bag(s) with /gyro/pulses and /gyro/temperature')
    p.add_argument('--calibration', type=Path, required=True, metavar='FILE',
                   help='the hand-off file holding thermal_model (gyro-calib calibrate BAG '
                   '--method thermal --out FILE)')
    p.add_argument('--out', type=Path, metavar='BAG2', help='write a copy of the bag with the '
                   f'compensated rate on {GYRO_IMU} (sensor_msgs/Imu); must not exist')
    p.add_argument('--json', action='store_true', help='print one JSON document on stdout '
                   '(the human summary goes to stderr)')
    p.add_argument('--plot', type=Path, metavar='DIR', help='write PNG figures into DIR '
                   '(created if absent, in an existing directory)')
    p.add_argument('--gyro-id', default='', help='the recorded gyro (default: the bench '
                   'settings stored in the bag); a model of another gyro is refused')
    p.add_argument('--skip-out-of-range', action='store_true',
                   help='leave intervals outside the calibrated range (plus margin) '
                   'uncompensated and list them, instead of refusing the bag')
    p.add_argument('--block-s', type=float, default=100.0,
                   help='bias-stability block, s (default 100, docs/methods.md §E eq. (12))')
    p.set_defaults(run=run_compensate)


def run_compensate(args: argparse.Namespace) -> int:
    """``gyro-calib compensate``: exit status 0, or a GyroCalibError for main() to print."""
    from gyro_calib.bag_compensation import compensate_bags, write_compensated_bag
    from gyro_calib.outputs import (
        check_new_directory,
        check_plot_dir,
        write_failed,
        write_figures,
    )
    from gyro_calib.thermal.compensation_summary import json_document, summary_text

    if args.out is not None:
        check_new_directory(args.out, '--out')
    plot_dir = check_plot_dir(args.plot) if args.plot is not None else None
    if args.out is not None and len(args.bags) != 1:
        raise ConfigError('--out writes a copy of one bag: give a single BAG with it.')
    result = compensate_bags(args.bags, args.calibration, gyro_id=args.gyro_id,
                             block_s=args.block_s,
                             out_of_range='skip' if args.skip_out_of_range else 'raise')
    human = io.StringIO()  # out once the files are written: a failed write prints one line
    print(summary_text(result, args.calibration), file=human)
    doc = json_document(result)
    if args.out is not None:
        try:
            written, without = write_compensated_bag(result, args.out,
                                                     calibration_file=args.calibration)
        except OSError as exc:  # the bag is written whole (a .partial directory) or not
            raise write_failed(exc, '--out', args.out) from None
        print(f'compensated bag written: {args.out.resolve()} ({written} {GYRO_IMU} messages'
              + (f'; {without} pulse samples without a model bias got none' if without else '')
              + ')', file=human)
        doc['out'] = {'bag': str(args.out.resolve()), 'topic': GYRO_IMU,
                      'type': IMU, 'messages': written, 'samples_without_bias': without}
    if plot_dir is not None:
        from gyro_calib.thermal.plots import plot_compensation

        try:
            figures = write_figures(plot_dir, lambda stage: plot_compensation(result.report,
                                                                              stage))
        except OSError as exc:
            raise write_failed(exc, '--plot', plot_dir,
                               [f'--out {args.out}'] if args.out is not None else []) from None
        for path in figures:
            print(f'figure written: {path.resolve()}', file=human)
    (sys.stderr if args.json else sys.stdout).write(human.getvalue())
    if args.json:
        print(json.dumps(doc, indent=1, allow_nan=False))
    return 0
