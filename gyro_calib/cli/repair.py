"""``gyro-calib repair BAG --out DIR``: a whole bag from the intact records of a damaged one.

    gyro-calib repair BAG --out DIR

Writes DIR, a new rosbag2 bag (``metadata.yaml`` and one .mcap with summary and indexes)
holding every message of BAG's intact chunks (:func:`gyro_calib.bagio.repair_bag`), and
prints one line saying where BAG's readable data ended and what was lost (docs/recovery.md).
DIR must not exist; it is written whole or not at all.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from gyro_calib.cli.arguments import EXIT_OK

PRELOAD: tuple[str, ...] = (
    'gyro_calib.bagio.repair',
    'gyro_calib.outputs',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def add_commands(sub: Any) -> None:
    """Add ``repair`` to the ``gyro-calib`` subcommands."""
    rep = sub.add_parser('repair', help='write a whole bag (summary, indexes, metadata.yaml) '
                         'from the intact records of a bag cut off or damaged')
    rep.add_argument('bag', type=Path, metavar='BAG',
                     help='rosbag2 bag directory, or its .mcap file (a recording never '
                     'closed: the directory with its .mcap alone)')
    rep.add_argument('--out', type=Path, required=True, metavar='DIR',
                     help='bag directory to create (must not exist)')
    rep.set_defaults(run=run_repair)


def run_repair(args: argparse.Namespace) -> int:
    """Check ``--out``, write the repaired bag, say what it holds and what was lost."""
    from gyro_calib.bagio import repair_bag
    from gyro_calib.outputs import check_new_directory

    check_new_directory(args.out, '--out')  # exists, no parent, cannot be written: refused
    if not args.bag.exists():
        from gyro_calib.bagio import BagNotFoundError

        raise BagNotFoundError(f'{args.bag}: no such file or directory.')
    info = repair_bag(args.bag, args.out)
    counts = ', '.join(f'{t.name} {t.count}' for t in sorted(info.topics.values(),
                                                              key=lambda t: t.name))
    print(f'repaired bag written: {args.out} ({info.message_count} messages: {counts})')
    if info.damage is None or (info.damage.tail_from is None and not info.damage.skipped):
        print(f'{args.bag} was whole: nothing lost.')
    else:
        for line in info.damage.lines(args.bag):
            print(line)
    return EXIT_OK
