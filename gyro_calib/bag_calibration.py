"""Calibrate recorded bags offline, streaming them through the same cores as the live nodes.

:func:`calibrate_bags` opens one or more bags, picks the methods (those asked for, or every
method whose topics the bags hold; :mod:`gyro_calib.registry`), and feeds each method's
session batch by batch in stamp order (:func:`gyro_calib.bagio.iter_bags`), so a bag gives the
same numbers offline as when it is replayed into a method's node.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gyro_calib import topics
from gyro_calib.bagio import (
    CONTRACT_TYPES,
    BagError,
    BagInfo,
    CorruptBagError,
    EmptyBagError,
    MissingTopicError,
    WrongMessageTypeError,
    bag_info,
    check_topics,
    iter_bags,
    iter_sample_batches,
    topics_present,
)
from gyro_calib.bagio.duplicates import refuse_repeated_bags
from gyro_calib.config import read_method_file
from gyro_calib.errors import ConfigError
from gyro_calib.registry import METHODS, Method, methods_revealed
from gyro_calib.session import CalibrationOptions, MethodSession


@dataclass(slots=True)
class BagCalibration:
    """The outcome of calibrating one or more bags.

    Attributes:
        infos: each bag's topics, counts, span and scenario.
        sessions: method name → its session (results, rejections, hand-off...).
        messages: messages decoded.
        log: lines the sessions logged while the bags streamed (rejections, notices).
        options: method name → the options its session was built with (its own bags'
            stored bench settings, the config file's bench settings).
        notes: given settings that differ from the bench settings the bags store, and the
            namespace read when it was found in the bags rather than given.
        namespace: the namespace whose topics were read ('' = the root).
    """

    infos: list[BagInfo]
    sessions: dict[str, MethodSession]
    messages: int
    log: list[str] = field(default_factory=list)
    options: dict[str, CalibrationOptions] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    namespace: str = ''

    def gyro_id(self, method: str) -> str:
        """The gyro id of a method's run: given, in the config file, or stored with its bags."""
        options = self.options.get(method)
        return str(options.setting('gyro_id', '') or '') if options is not None else ''

    @property
    def calibrated_anything(self) -> bool:
        """True when at least one method measured at least one quantity."""
        return any(s.calibrated_anything() for s in self.sessions.values())

    @property
    def source(self) -> str:
        """The bag path(s), for the hand-off provenance."""
        return ', '.join(str(i.path) for i in self.infos)


def resolve_namespace(infos: Sequence[BagInfo], namespace: str | None) -> tuple[str, str]:
    """(the namespace to read, a note saying it was found in the bags, or '').

    Given (``--namespace``), it is checked to hold topics. Not given: the root when it holds a
    topic of the contract, else the one namespace that does (several: refused).

    Raises:
        ConfigError: a malformed namespace; one that holds no topic of the bags (the
            namespaces that do are named); several benches and none chosen.
    """
    names = [t for info in infos for t in info.topics]
    found = topics.namespaces_holding(names, CONTRACT_TYPES)
    shown = ', '.join(n or '/' for n in found) or 'none'
    if namespace is not None:
        try:
            ns = topics.normalized_namespace(namespace)
        except ValueError as exc:
            raise ConfigError(f'--namespace: {exc}') from None
        if ns and not any(t.startswith(ns + '/') for t in names):
            raise ConfigError(f'--namespace {ns}: no topic of the bag(s) lies under it; the '
                              f'namespaces holding calibration topics are: {shown}.')
        return ns, ''
    if '' in found or not found:
        return '', ''
    if len(found) > 1:
        raise ConfigError(f'the bag(s) hold the topics of several benches, under {shown}: '
                          'choose one with --namespace.')
    return found[0], (f'reading the topics under {found[0]}, the one namespace in the bag(s) '
                      'holding calibration topics.')


def bag_infos(paths: Sequence[str | Path], namespace: str | None = None, *,
              strict: bool = False) -> tuple[list[BagInfo], str]:
    """Each bag's info as seen from the namespace read.

    Each bag's info as seen from the namespace read (:func:`resolve_namespace`), and the
    note saying the namespace was found in the bags ('' when given or the root). A bag cut
    off or damaged is read up to where its readable data ends (``BagInfo.damage``;
    docs/recovery.md); ``strict`` refuses it instead.

    Raises:
        BagError (subclass): as :func:`gyro_calib.bagio.bag_info`; CorruptBagError for a
            damaged bag with ``strict``.
        ConfigError: as :func:`resolve_namespace`; two bags holding the same data
            (:func:`gyro_calib.bagio.duplicates.refuse_repeated_bags`).
    """
    infos = [_strict_bag_info(p) if strict else bag_info(p) for p in paths]
    refuse_repeated_bags(infos)  # the same data under two paths would count twice
    ns, note = resolve_namespace(infos, namespace)
    return [i.in_namespace(ns) for i in infos], note


def _strict_bag_info(path: str | Path) -> BagInfo:
    """The bag's info, or one line refusing it when it is cut off or damaged (``--strict``).

    Raises:
        BagError (subclass): as :func:`gyro_calib.bagio.bag_info`; CorruptBagError naming
            what the intact part would have been.
    """
    try:
        return bag_info(path, recover=False)
    except CorruptBagError as exc:
        try:
            damage = bag_info(path).damage
        except BagError:
            raise exc from None
        if damage is None:
            raise
        what = damage.line(path).removeprefix(f'{path}: ').split('; the results rest on')[0]
        raise CorruptBagError(
            f'--strict refuses {path}: {what}. Without --strict the part before is calibrated; '
            f'`gyro-calib repair {path} --out DIR` writes a whole copy of it.') from None


def merged_topics(infos: Sequence[BagInfo]) -> dict[str, str]:
    """Topic → type over all bags.

    Raises:
        WrongMessageTypeError: one topic recorded with two types in different bags.
    """
    out: dict[str, str] = {}
    for info in infos:
        for t in info.topics.values():
            if out.setdefault(t.name, t.msgtype) != t.msgtype:
                raise WrongMessageTypeError(f'topic {t.name} has type {out[t.name]} in one bag '
                                            f'and {t.msgtype} in {info.path}.')
    return out


def topic_counts(infos: Sequence[BagInfo]) -> dict[str, int]:
    """Topic → its message count summed over all bags."""
    counts: dict[str, int] = {}
    for info in infos:
        for t in info.topics.values():
            counts[t.name] = counts.get(t.name, 0) + t.count
    return counts


def own_bags(method: Method, infos: Sequence[BagInfo]) -> list[BagInfo]:
    """The bags that are the method's own.

    The bags that are the method's own: those holding all its revealing topics (with their
    types); when none does (or it has none), those holding any of its input topics (a
    context topic such as noise's rate table alone does not make a bag its own).
    """
    def holds(info: BagInfo, topic: str) -> bool:
        t = info.topics.get(topic)
        return t is not None and t.msgtype == method.topics[topic]

    mine = [i for i in infos if method.reveal and all(holds(i, t) for t in method.reveal)]
    return mine or [i for i in infos if any(holds(i, t) for t in method.inputs()) or (
        method.any_topic and any(t.msgtype == method.any_topic for t in i.topics.values()))]


def stored_benches(infos: Sequence[BagInfo], *,
                   every_bag: bool = True) -> tuple[tuple[str, dict[str, Any]], ...]:
    """(bag, its stored bench settings ``scenario.bench``) of each bag, in order.

    A bag storing none counts with ``{}``, so another bag's settings never stand in for it
    (:meth:`~gyro_calib.session.CalibrationOptions.stored`); with ``every_bag=False`` it is
    left out.
    """
    out = []
    for info in infos:
        bench = info.scenario.get('bench')
        if isinstance(bench, dict) or every_bag:
            out.append((str(info.path), bench if isinstance(bench, dict) else {}))
    return tuple(out)


def method_options(options: CalibrationOptions, method: Method,
                   infos: Sequence[BagInfo]) -> CalibrationOptions:
    """Options for one method, with its bags' bench settings.

    ``options`` for one method: the bench settings stored with its own bags (never another
    method's bags) and the bench settings in its config file.

    Raises:
        ConfigError: the config file is unreadable, or a bench setting in it out of range.
    """
    changes: dict[str, Any] = {}
    if not options.stored_benches and not options.scenario:
        changes['stored_benches'] = stored_benches(own_bags(method, infos), every_bag=False)
        first = next((i.scenario for i in own_bags(method, infos) if i.scenario), {})
        changes['scenario'] = first
    if options.config_file is not None and method.node and not options.config_bench:
        _, bench = read_method_file(options.config_file, node_name=method.node,
                                    fields=method.settings_defaults())
        changes['config_bench'] = bench
    return dataclasses.replace(options, **changes) if changes else options


def _check_some_input(where: BagInfo, method: Method, infos: Sequence[BagInfo]) -> None:
    """A method revealed by none of its topics (noise) needs one of its inputs, with samples.

    Raises:
        MissingTopicError: none is there (a context topic alone is no input), listing the
            inputs it reads and the topics the bag(s) hold.
    """
    counts = topic_counts(infos)
    present = merged_topics(infos)
    if any(present.get(t) == typ and counts.get(t) for t, typ in method.inputs().items()):
        return
    if method.any_topic and any(typ == method.any_topic and counts.get(t)
                                for t, typ in present.items()):
        return
    inputs = ', '.join(f'{t} ({typ})' for t, typ in method.inputs().items())
    other = f' or any {method.any_topic} topic (--topic)' if method.any_topic else ''
    raise MissingTopicError(f'{where.path}: method {method.name} reads one of {inputs}{other}, '
                            'and the bag(s) hold none with samples; they hold '
                            f'{topics_present(where)}.')


def select_methods(infos: Sequence[BagInfo], names: Sequence[str] | None) -> list[Method]:
    """The methods asked for (checked against the bags' topics), or every method revealed.

    Raises:
        ConfigError: an unknown method name.
        MissingTopicError: a method asked for whose topics are not there, or no method's
            topics at all; the message lists the topics present with their types.
        WrongMessageTypeError: a topic a method reads recorded with another type.
    """
    present = merged_topics(infos)
    where = infos[0] if len(infos) == 1 else dataclasses.replace(
        infos[0], path=Path(' + '.join(str(i.path) for i in infos)),
        topics={k: v for i in infos for k, v in i.topics.items()},
        message_count=sum(i.message_count for i in infos))
    if names:
        chosen = []
        for name in names:
            if name not in METHODS:
                raise ConfigError(f'unknown method {name!r}; the methods are: '
                                  f'{", ".join(METHODS)}.')
            method = METHODS[name]
            check_topics(where, method.topics, method.reveal, what=f'method {name}')
            if method.any_topic and not method.topics and method.any_topic not in \
                    present.values():  # multiposition: any Imu topic, none in the bags
                raise MissingTopicError(f'{where.path}: method {name} reads a '
                                        f'{method.any_topic} topic and the bag(s) hold none; '
                                        f'they hold {topics_present(where)}.')
            if not method.reveal:
                _check_some_input(where, method, infos)
            chosen.append(method)
        return chosen
    for info in infos:
        check_topics(info, {}, (), what='calibration')  # empty bags
    # A topic recorded empty (bag_recorder opens every contract topic) reveals nothing, as
    # in ``gyro-calib info``.
    recorded = {t.name for i in infos for t in i.topics.values() if t.count}
    revealed = methods_revealed({k: v for k, v in present.items() if k in recorded})
    if not revealed:
        auto = [m for m in METHODS.values() if m.auto and m.reveal]
        partly = max(auto, key=lambda m: sum(t in present for t in m.reveal))
        if any(t in present for t in partly.reveal):  # name what that method misses
            check_topics(where, partly.topics, partly.reveal, what=f'method {partly.name}')
        needs = '; '.join(f'{m.name} needs {", ".join(m.reveal)}' for m in auto)
        raise MissingTopicError(f'{where.path}: no method has its topics in the bag(s) ({needs}; '
                                f'others run when asked with --method); the bag(s) hold '
                                f'{topics_present(where)}.')
    for method in revealed:
        check_topics(where, method.topics, method.reveal, what=f'method {method.name}')
    return revealed


def calibrate_bags(paths: Sequence[str | Path], *, methods: Sequence[str] | None = None,
                   options: CalibrationOptions | None = None,
                   progress: Callable[[float], None] | None = None,
                   batch_messages: int = 50_000,
                   namespace: str | None = None, strict: bool = False) -> BagCalibration:
    """Stream the bags at ``paths`` (together, in stamp order) through the methods' sessions.

    ``options`` carry the user's settings; the bench settings a simulated bag stores fill in
    the rest. ``progress`` is called with the fraction of the bags' messages decoded.
    ``namespace`` names the bench whose topics are read (None: the root, or the one
    namespace the bags hold; :func:`resolve_namespace`). A bag cut off or damaged is read
    up to where its readable data ends, each damaged chunk skipped, each said in a line of
    ``notes`` (docs/recovery.md); ``strict`` refuses it instead.

    Raises:
        BagError (subclass): missing path, not a bag, damaged bag, missing topic, wrong
            message type, empty bag — before any result exists.
        ConfigError: an unknown method or a wrong setting.
    """
    if not paths:
        raise ConfigError('no bag given.')
    infos, ns_note = bag_infos(paths, namespace, strict=strict)
    ns = infos[0].namespace
    chosen = select_methods(infos, methods)
    options = options or CalibrationOptions()
    per_method = {m.name: method_options(options, m, infos) for m in chosen}
    sessions = {m.name: m.make_session(per_method[m.name]) for m in chosen}
    notes = [f'{m.name}: note: {line}' for m in chosen
             for line in per_method[m.name].conflicts(m.bench_settings)]
    if ns_note:
        notes.insert(0, f'note: {ns_note}')
    notes += [f'note: {line}' for info in infos if info.damage is not None
              for line in info.damage.lines(info.path)]
    present = merged_topics(infos)
    log: list[str] = []
    counts = [0]
    total = max(sum(t.count for i in infos for t in i.topics.values()
                    if any(t.name in s.topics() for s in sessions.values())), 1)
    separate = [m.name for m in chosen if m.separate_bags and len(infos) > 1]
    together = [m.name for m in chosen if m.name not in separate]

    def run(names: list[str], stream: Any, starts: bool) -> None:
        types: dict[str, str] = {}
        for name in names:
            types.update(sessions[name].topics())
        types = {t: m for t, m in types.items() if present.get(t) == m}
        current = -1
        for index, batch in stream(types):
            notes.extend(f'note: {line}' for line in batch.notes
                         if f'note: {line}' not in notes)
            if starts and index != current:
                current = index
                for name in names:
                    sessions[name].start_bag(index, infos[index].path)
            for name in names:
                sessions[name].feed(batch)
                log.extend(f'{name}: {line}' for line in sessions[name].process())
            counts[0] += batch.messages
            if progress is not None:
                progress(min(1.0, counts[0] / total))

    paths_ = [i.path for i in infos]
    if together:
        run(together, lambda types: iter_bags(paths_, types, batch_messages=batch_messages,
                                              namespace=ns, recover=not strict), False)
    if separate:
        def one_by_one(types: dict[str, str]) -> Any:
            for index, path in enumerate(paths_):
                for batch in iter_sample_batches(path, types, batch_messages=batch_messages,
                                                 namespace=ns, recover=not strict):
                    yield index, batch
        run(separate, one_by_one, True)
    if counts[0] == 0 and (any(i.damage is not None for i in infos)
                           or any(n.startswith('note: ') for n in notes)):
        # nothing readable: as a bag holding no message (docs/recovery.md), not a 0-message run
        raise EmptyBagError(f'{", ".join(str(i.path) for i in infos)}: no message is readable '
                            '(every chunk holding one is cut off or damaged: '
                            + '; '.join(n.removeprefix('note: ') for n in notes) + ').')
    for name, s in sessions.items():
        log += [f'{name}: {line}' for line in s.process(flush=True)]
    if progress is not None:
        progress(1.0)
    return BagCalibration(infos, sessions, counts[0], log, per_method, notes, ns)


def calibrate_recording(paths: Sequence[Path], *, fmt: str, rate_hz: float | None,
                        options: CalibrationOptions | None = None,
                        sections: Path | None = None,
                        turn_angle_deg: float = -360.0) -> BagCalibration:
    """A plain recording (``--format``: docs/multiposition.md) through the multiposition session.

    ``sections`` (imucal's section list, JSON ``{name: {start, end}}``) makes it the Ferraris
    variant (§G.6) with turns of ``turn_angle_deg`` (signed as imucal's expected_angle).

    Raises:
        ConfigError: the files cannot be read in that format (one line naming the file), the
            format needs a rate or two files and did not get them, or the section list is
            unreadable or lacks a section.
    """
    from gyro_calib.bagio import BagInfo, TopicInfo
    from gyro_calib.multiposition.readers import (
        FORMATS,
        RecordingFormatError,
        read_imu_tk,
        read_imucal,
        read_xyz6,
    )
    from gyro_calib.multiposition.session import IMU, MultipositionSession

    if fmt not in FORMATS:
        raise ConfigError(f'--format {fmt!r}: the formats are {", ".join(FORMATS)}.')
    want = 2 if fmt == 'imu_tk' else 1
    if len(paths) != want:
        files = 'two files (accelerometer, gyro)' if want == 2 else 'one file'
        raise ConfigError(f'--format {fmt} reads {files}; {len(paths)} given.')
    if fmt != 'imu_tk' and (rate_hz is None or not rate_hz > 0):
        raise ConfigError(f'--format {fmt} has no stamps: give its sampling rate with '
                          '--rate-hz HZ.')
    for p in paths:
        if not Path(p).is_file():
            raise ConfigError(f'{p}: no such file.')
    try:
        if fmt == 'imu_tk':
            rec = read_imu_tk(Path(paths[0]), Path(paths[1]))
        elif fmt == 'imucal':
            rec = read_imucal(Path(paths[0]), float(rate_hz or 0), gyro_unit='deg/s')
        else:
            rec = read_xyz6(Path(paths[0]), float(rate_hz or 0))
    except (RecordingFormatError, ValueError) as exc:
        raise ConfigError(str(exc)) from None
    options = options or CalibrationOptions()
    session = MultipositionSession(options)
    notes: list[str] = []
    if sections is not None:
        if fmt != 'imucal':
            raise ConfigError('--sections (the Ferraris variant) reads an imucal session: give '
                              '--format imucal.')
        import json
        try:
            raw = json.loads(Path(sections).read_text(encoding='utf-8'))
            parts = {str(k): (int(v['start']), int(v['end'])) for k, v in raw.items()}
            session.feed_ferraris(rec, parts, rate_hz=float(rate_hz or 0),
                                  turn_angle=turn_angle_deg)
        except (OSError, ValueError, TypeError, KeyError, AttributeError) as exc:
            raise ConfigError(f'--sections {sections}: {exc} (imucal\'s section list: '
                              '{"x_p": {"start": N, "end": M}, …}).') from None
        log: list[str] = []
    else:
        session.feed_recording(rec)
        log = [f'multiposition: {line}' for line in session.process(flush=True)]
        if fmt == 'imucal' and session.missing():
            notes.append('note: an imucal session of six positions and three turns is the '
                         'Ferraris variant (§G.6): give its section list with --sections.')
    start, end = int(round(rec.t_s[0] * 1e9)), int(round(rec.t_s[-1] * 1e9))
    info = BagInfo(Path(rec.source), {session.topic: TopicInfo(session.topic, IMU, len(rec))},
                   start, end, len(rec), {})
    return BagCalibration([info], {'multiposition': session}, len(rec), log,
                          {'multiposition': options}, notes)


def json_document(outcome: BagCalibration, command: str = 'calibrate') -> dict[str, Any]:
    """The ``--json`` document every command shares.

    The ``--json`` document every command shares (``gyro_calib/schema/result.schema.json``):
    ``{"command", "methods": {NAME: {"results", "missing", "rejections", ...}}, "bags",
    "messages"}``.
    """
    return {'command': command,
            'methods': {name: s.json_section() for name, s in outcome.sessions.items()},
            'bags': [str(i.path) for i in outcome.infos], 'messages': outcome.messages}
