"""``gyro-calib simulate SCENARIO --out BAG``: write a scenario bag from the simulators.

    gyro-calib simulate SCENARIO --out BAG [--seed N] [--duration-s S] [--sample-rate-hz HZ]
    gyro-calib simulate --list

The scenarios are :mod:`sim_nodes.scenarios`' (a group writes one bag per member into
``--out``); the bag is written whole or not at all.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from gyro_calib.cli.arguments import EXIT_BAD_INPUT, EXIT_OK


def add_commands(sub: Any) -> None:
    """Add ``simulate`` to the ``gyro-calib`` subcommands."""
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
    sim.set_defaults(run=run_simulate)


def run_simulate(args: argparse.Namespace) -> int:
    """``gyro-calib simulate``: list the scenarios, or write one's bag; the exit status."""
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
