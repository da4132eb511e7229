"""``gyro-calib methods``: the calibration methods, their topics and what each needs."""

from __future__ import annotations

import argparse
from typing import Any

from gyro_calib.cli.arguments import EXIT_OK
from gyro_calib.registry import METHODS

PRELOAD: tuple[str, ...] = ()
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def add_commands(sub: Any) -> None:
    """Add ``methods`` to the ``gyro-calib`` subcommands."""
    methods = sub.add_parser('methods', help='list the calibration methods and their topics')
    methods.set_defaults(run=run_methods, commands=sub.choices)  # filled as commands are added


def run_methods(args: argparse.Namespace) -> int:
    """``gyro-calib methods``: each method, its topics and which it needs."""
    commands = set(args.commands) if getattr(args, 'commands', None) else set()
    for m in METHODS.values():
        own = f' or gyro-calib {m.name}' if m.name in commands else ''
        print(f'{m.name:8} {m.title}' + ('' if m.auto else '  [runs when asked: '
                                              f'gyro-calib calibrate --method {m.name}{own}]'))
        for topic, msgtype in m.topics.items():
            need = ('needed' if topic in m.reveal else 'optional, beside the input'
                    if topic in m.context else 'one of these' if not m.reveal else 'optional')
            note = f'; {m.needs[topic]}' if topic in m.needs else ''
            print(f'           {topic:32} {msgtype:28} {need}{note}')
        if m.any_topic:
            print(f'           {"any topic (--topic)":32} {m.any_topic:28} one of these')
    return EXIT_OK
