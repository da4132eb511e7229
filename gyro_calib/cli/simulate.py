"""``gyro-calib simulate SCENARIO --out BAG``: write a scenario bag from the simulators.

    gyro-calib simulate SCENARIO --out BAG [--seed N] [--duration-s S] [--sample-rate-hz HZ]
    gyro-calib simulate --list

The scenarios are :mod:`sim_nodes.scenarios`' (a group writes one bag per member into
``--out``); the bag is written whole or not at all.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import sys
from pathlib import Path
from typing import Any

from gyro_calib.cli.arguments import EXIT_BAD_INPUT, EXIT_OK

PRELOAD: tuple[str, ...] = (
    'gyro_calib.bagio.writer',
    'gyro_calib.outputs',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


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

    if Path(args.out).suffix.lower() in ('.mcap', '.db3', '.yaml'):
        print(f'gyro-calib: error: --out {args.out}: a bag is a directory (metadata.yaml and '
              f'its .mcap file inside); give the directory\'s name, e.g. --out '
              f'{Path(args.out).with_suffix("")}; nothing was written.', file=sys.stderr)
        return EXIT_BAD_INPUT
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
    if overrides.get('seed', 0) < 0:
        print(f'gyro-calib: error: --seed = {args.seed} is invalid: a seed is an integer ≥ 0.',
              file=sys.stderr)
        return EXIT_BAD_INPUT
    too_many = _too_many_messages(args.scenario, overrides)
    if too_many:
        print(f'gyro-calib: error: {too_many}; nothing was written.', file=sys.stderr)
        return EXIT_BAD_INPUT
    out = Path(args.out).absolute()
    stage = out.with_name(f'.{out.name}.simulate-{os.getpid()}')  # checked, then moved out
    shutil.rmtree(stage, ignore_errors=True)
    try:
        stage.mkdir()
        try:
            write_scenario_bag_with(args.scenario, stage / out.name, overrides)
        except KeyError as exc:
            print(f'gyro-calib: error: {exc.args[0]}', file=sys.stderr)
            return EXIT_BAD_INPUT
        except (ValueError, IndexError, ZeroDivisionError) as exc:
            if not overrides:
                raise  # the scenario as committed: a bug, not the user's input
            print(f'gyro-calib: error: scenario {args.scenario} cannot be simulated with '
                  f'{_given(overrides)} ({type(exc).__name__}: {" ".join(str(exc).split())}); '
                  'give values nearer its defaults '
                  f'({scenario_parameters(GROUPS.get(args.scenario, (args.scenario,))[0])}); '
                  'nothing was written.', file=sys.stderr)
            return EXIT_BAD_INPUT
        refusal = _does_not_hold(args.scenario, stage / out.name, overrides)
        if refusal:
            print(f'gyro-calib: error: {refusal}; nothing was written.', file=sys.stderr)
            return EXIT_BAD_INPUT
        from gyro_calib.bagio.writer import publish_directory

        publish_directory(stage / out.name, out)
    except OSError as exc:  # the bag is written whole (a .partial directory renamed) or not
        from gyro_calib.outputs import write_failed

        raise write_failed(exc, '--out', args.out) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    member = GROUPS.get(args.scenario, (args.scenario,))[0]
    print(f'wrote {args.out}' + (f' ({_changes(member, overrides)})' if overrides else ''))
    return EXIT_OK


def _changes(scenario: str, overrides: dict[str, Any]) -> str:
    """'table.seed 21 → 3, gyro.seed 21 → 4, …': each parameter the flags set, old → new."""
    from sim_nodes.scenarios import parameters_changed

    moved = [f'{p} {old:g} → {new:g}' if isinstance(old, float) else f'{p} {old} → {new}'
             for p, old, new in parameters_changed(scenario, overrides)]
    return ', '.join(moved) or f"{_given(overrides)}: the scenario's own values"


def _given(overrides: dict[str, Any]) -> str:
    return ', '.join(f'{k} = {v}' for k, v in overrides.items())


def _too_many_messages(scenario: str, overrides: dict[str, Any]) -> str:
    """Why ``scenario`` with ``overrides`` is too big to simulate ('' if it is not).

    Over :data:`sim_nodes.scenarios.MAX_SIMULATED_MESSAGES` messages in a bag (docs/howto/
    offline.md): without this a ``--sample-rate-hz 1e9`` ran for hours, silent.
    """
    from sim_nodes.scenarios import MAX_SIMULATED_MESSAGES, estimated_message_count

    estimate = estimated_message_count(scenario, overrides)
    if estimate <= MAX_SIMULATED_MESSAGES:
        return ''
    advice = ' or '.join(flag for key, flag in (('duration_s', 'a shorter --duration-s'),
                                                  ('sample_rate_hz', 'a lower --sample-rate-hz'))
                         if key in overrides)
    return (f'scenario {scenario} with {_given(overrides)} would write about {estimate:.2g} '
            f'messages, over the limit of {MAX_SIMULATED_MESSAGES:,} messages per bag '
            f'(see "gyro-calib simulate" in docs/howto/offline.md); give {advice}')


def _does_not_hold(scenario: str, stage: Path, overrides: dict[str, Any]) -> str:
    """Why the simulated bag(s) at ``stage`` are not what was asked for ('' if they are).

    A ``--duration-s`` the scenario ignores (its procedure sets the length: the bag is not
    that long) or so short that a bag holds no message (issue 35 §4).
    """
    from gyro_calib.bagio import bag_info
    from sim_nodes.scenarios import GROUPS

    members = GROUPS.get(scenario)
    for bag in [stage / m for m in members] if members else [stage]:
        info = bag_info(bag)
        if info.message_count == 0:
            return (f'--duration-s {overrides.get("duration_s")} leaves scenario {scenario} '
                    f'no message ({bag.name}): give a longer record')
        if 'duration_s' not in overrides:
            continue
        asked = float(overrides['duration_s'])
        if abs(info.duration_s - asked) > 0.01 * asked + 0.05:
            return (f'--duration-s {asked:g} does not apply to scenario {scenario}: its '
                    f'procedure sets the record length ({bag.name}: {info.duration_s:.1f} s); '
                    'drop --duration-s')
    return ''
