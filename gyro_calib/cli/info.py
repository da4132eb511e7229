"""``gyro-calib info BAG [BAG ...]``: topics, counts, rates, and what each method could do.

    gyro-calib info BAG [BAG ...] [--method NAME ...] [--json] (and the settings flags)

Describes each bag (:func:`bag_description`: span, topics with counts and rates from the
header stamps), says what each method could do with them (:func:`method_prospects`), and
runs the methods that would run to show what they read, reject and are limited by.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from gyro_calib.cli.arguments import (
    EXIT_OK,
    check_calibration_file,
    method_arguments,
    options_from_args,
    refuse_unused_flags,
)
from gyro_calib.cli.calibrate import json_default
from gyro_calib.registry import METHODS
from gyro_calib.units import format_stamp

PRELOAD: tuple[str, ...] = (
    'gyro_calib.bag_calibration',
    'gyro_calib.bagio.reader',
    'gyro_calib.session',
)
"""Modules the command uses, imported by :func:`gyro_calib.cli.main` once the command line
parsed, while a Ctrl-C still means nothing was done (``--help`` imports none of them)."""


def add_commands(sub: Any) -> None:
    """Add ``info`` to the ``gyro-calib`` subcommands."""
    info = sub.add_parser('info', help='topics, counts, duration, and what each method would use')
    info.add_argument('bags', nargs='+', type=Path, metavar='BAG')
    method_arguments(info)
    info.add_argument('--json', action='store_true',
                      help='print one JSON document on stdout (the shape of calibrate --json, '
                      'with each bag described)')
    info.set_defaults(run=run_info)


OWN_COMMAND = ('noise',)
"""The methods with a subcommand of their own (``gyro-calib noise``); the others run as
``gyro-calib calibrate BAG --method NAME``."""


def method_prospects(infos: Sequence[Any]) -> dict[str, dict[str, Any]]:
    """What each method could do with the bag(s): ``{"runs": bool, "how": line}`` by name.

    An automatic method runs when its revealing topics are all there with their types; a
    method that runs only when asked (noise) is offered for each input it could read.
    """
    from gyro_calib.bag_calibration import merged_topics, topic_counts
    from gyro_calib.registry import methods_revealed

    present = merged_topics(infos)
    counts = topic_counts(infos)
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
        command = (f'gyro-calib {m.name} BAG' if m.name in OWN_COMMAND
                   else f'gyro-calib calibrate BAG --method {m.name}')
        out[m.name] = ({'runs': True, 'how': f'{command} --topic T, T one of '
                        + ', '.join(f'{t} ({m.needs[t]})' if t in m.needs else t
                                    for t in inputs)} if inputs else
                       {'runs': False, 'how': 'needs '
                        + ' or '.join([*m.inputs(), *([f"a {m.any_topic} topic"]
                                                     if m.any_topic else [])])})
    return out


def bag_description(info: Any, *, strict: bool = False) -> dict[str, Any]:
    """One bag's description for ``info``.

    One bag for ``info``: span, topics with counts and rates from the header stamps
    (the sample instants; log times only for types without a decodable header), and, for
    a bag cut off or damaged, the lines saying where its readable data ends and which
    chunks were skipped (``damage``; docs/recovery.md); ``strict`` refuses a damaged chunk.
    """
    from gyro_calib.bagio import header_stamp_spans

    damage = info.damage.lines(info.path) if info.damage is not None else []
    spans = (header_stamp_spans(info.path, info, notes=damage, recover=not strict)
             if info.message_count else {})
    skipped = len(damage) > (1 if info.damage is not None else 0)  # chunks skipped on the way
    topics = []
    for t in sorted(info.topics.values(), key=lambda t: t.name):
        n, lo, hi, step_ns = spans.get(t.name, (0, 0, 0, math.nan))
        if skipped and t.name in spans:  # the messages read, not those the summary counts
            t = dataclasses.replace(t, count=n)
        if n > 1 and step_ns > 0:
            rate, basis = 1e9 / step_ns, 'header stamps, median step'
        elif info.duration_s > 0 and t.count > 1:
            rate, basis = (t.count - 1) / info.duration_s, 'log times'
        else:
            rate, basis = math.nan, 'too few messages'
        topics.append({'name': t.name, 'type': t.msgtype, 'count': t.count,
                       'rate_hz': rate if math.isfinite(rate) else None, 'rate_from': basis})
    scenario = info.scenario if isinstance(info.scenario, dict) else {}
    messages = sum(t['count'] for t in topics) if skipped else info.message_count
    return {'path': str(info.path), 'duration_s': info.duration_s,
            'start_ns': info.start_ns, 'end_ns': info.end_ns, 'messages': messages,
            'topics': topics, 'scenario_name': scenario.get('name'),
            'scenario_description': scenario.get('description'),
            'stored_settings': sorted(scenario), 'damage': damage}


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
    for line in desc['damage']:  # cut off or damaged: what the results rest on
        print(f'note: {line}', file=out)
    if desc['scenario_name']:
        print(f'scenario: {desc["scenario_name"]} — {desc["scenario_description"] or ""}',
              file=out)
    elif desc['stored_settings']:
        print(f'scenario: none named (recorded live); stored bench settings: '
              f'{", ".join(desc["stored_settings"])}', file=out)


def run_info(args: argparse.Namespace) -> int:
    """``gyro-calib info``: describe the bags, the methods' prospects, what they read."""
    from gyro_calib.bag_calibration import bag_infos, calibrate_bags, json_document

    check_calibration_file(args.calibration)
    infos, namespace_note = bag_infos(args.bags, args.namespace, strict=args.strict)
    # the text goes out once the methods have run: bad input found on the way (--method
    # NAME without its topics) is one line on stderr and nothing on stdout
    human = io.StringIO()
    if namespace_note:
        print(f'note: {namespace_note}', file=human)
    descriptions = [bag_description(i, strict=args.strict) for i in infos]
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
        outcome = calibrate_bags(args.bags, methods=names, options=options_from_args(args),
                                 namespace=args.namespace, strict=args.strict)
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
    text = json.dumps(doc, indent=1, allow_nan=False, default=json_default) if args.json else ''
    (sys.stderr if args.json else sys.stdout).write(human.getvalue())
    if args.json:
        print(text)
    return EXIT_OK
