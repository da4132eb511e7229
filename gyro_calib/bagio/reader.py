"""Reading and inspecting rosbag2 MCAP bags (and tables read as bags), no rclpy.

Bags are rosbag2 directories (``metadata.yaml`` + one zstd-chunked ``.mcap``) written
(:mod:`gyro_calib.bagio.writer`) and read with `rosbags`; messages are CDR-serialised by
rosbags' typestore (ROS 2 Kilted definitions). A bag may carry its scenario (simulator
parameters, seed and truth) as YAML under ``custom_data['gyro_calib.scenario']`` of
``metadata.yaml`` (:mod:`gyro_calib.bagio.metadata`).

Reading is streamed: :func:`iter_sample_batches` yields the asked topics' samples as
NumPy arrays a few tens of thousands of messages at a time, so memory stays bounded
whatever the bag's length. The callers say which topics they want (the method registry
hands down its methods' topics); without them, the topic contract's.
"""

from __future__ import annotations

import dataclasses
import heapq
import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np
import yaml

from gyro_calib import topics
from gyro_calib.bagio import columns as mcap_columns
from gyro_calib.bagio import recovery
from gyro_calib.bagio import tables as table_input
from gyro_calib.bagio.errors import (
    CorruptBagError,
    EmptyBagError,
    MissingTopicError,
    WrongMessageTypeError,
)
from gyro_calib.bagio.layouts import CODECS
from gyro_calib.bagio.messages import CONTRACT_TYPES
from gyro_calib.bagio.metadata import SCENARIO_KEY, parse_scenario_text
from gyro_calib.bagio.records import BagInfo, SampleBatch, TopicInfo
from gyro_calib.bagio.storage import lone_mcap_custom_data, lone_mcap_in, one_line, open_reader
from gyro_calib.errors import GyroCalibError


def bag_info(path: str | Path, *, recover: bool = True) -> BagInfo:
    """Topics, counts, time span and scenario of the bag at ``path``.

    A bag whose .mcap file has no usable summary (cut off, never closed, damaged) is read
    record by record when ``recover`` (:mod:`~gyro_calib.bagio.recovery`): its info is that
    of the intact part, with what is lost in ``BagInfo.damage``.

    Raises:
        BagError (subclass): the path is missing, not a bag, or the bag is damaged (with
            ``recover``: nothing of it can be read).
    """
    path = Path(path)
    if table_input.is_table(path):
        return table_input.table_info(path)
    try:
        reader = open_reader(path)
    except CorruptBagError as exc:
        if not recover:
            raise
        return recovery.recovered_info(path, recovery.recoverable(path, exc))
    try:
        counts: dict[str, TopicInfo] = {}
        for con in reader.connections:
            prior = counts.get(con.topic)
            n = con.msgcount + (prior.count if prior else 0)
            counts[con.topic] = TopicInfo(con.topic, con.msgtype, n)
        metadata = getattr(reader.storage, 'metadata', None)
        custom = (metadata.custom if metadata is not None else None) or {}
        lone = lone_mcap_in(path) or path
        if not custom and lone.is_file():
            custom = lone_mcap_custom_data(lone)
        try:
            scenario = parse_scenario_text(custom.get(SCENARIO_KEY, '')) or {}
            benches = {key[len(SCENARIO_KEY) + 1:]: parse_scenario_text(text) or {}
                       for key, text in custom.items() if key.startswith(SCENARIO_KEY + ':')}
        except yaml.YAMLError as exc:
            raise CorruptBagError(f'{path}: the stored scenario is not valid YAML: {exc}') from exc
        total = sum(t.count for t in counts.values())
        return BagInfo(path, counts, int(reader.start_time) if total else 0,
                       int(reader.end_time) if total else 0, total, scenario,
                       namespace_scenarios=benches)
    finally:
        reader.close()


def header_stamp_spans(path: str | Path, info: BagInfo, *,
                       notes: list[str] | None = None, recover: bool = True
                       ) -> dict[str, tuple[int, int, int, float]]:
    """Per stamped topic: messages, stamp span and sample interval.

    Topic → (messages, earliest and latest header stamp ns, typical sample interval ns)
    of every topic whose type carries a header stamp the columnar decoder reads (JointState,
    Header, Imu, Temperature): rates from the sample instants, not the receive (log) times.
    The typical interval is the median over batches of each batch's median positive stamp
    step, so gaps and a few disordered stamps do not move it. The lines of damaged chunks
    skipped go to ``notes``; without ``recover`` a damaged chunk raises.

    Raises:
        CorruptBagError: a chunk cannot be read or a message cannot be decoded.
    """
    types = {t.name: t.msgtype for t in info.topics.values()
             if t.msgtype in CODECS and t.count}
    spans: dict[str, tuple[int, int, int]] = {}
    steps: dict[str, list[float]] = {}
    if not types:
        return {}
    for batch in iter_sample_batches(path, types, namespace=info.namespace, recover=recover):
        if notes is not None:
            notes.extend(batch.notes)
        for topic, cols in batch.columns.items():
            stamps = np.sort(np.asarray(cols.stamp_ns, dtype=np.int64))
            if not len(stamps):
                continue
            n, lo, hi = spans.get(topic, (0, int(stamps[0]), int(stamps[-1])))
            spans[topic] = (n + len(stamps), min(lo, int(stamps[0])), max(hi, int(stamps[-1])))
            diffs = np.diff(stamps)
            diffs = diffs[diffs > 0]
            if len(diffs):
                steps.setdefault(topic, []).append(float(np.median(diffs)))
    return {t: (*v, float(np.median(steps[t])) if t in steps else math.nan)
            for t, v in spans.items()}


def check_topics(info: BagInfo, wanted: Mapping[str, str], required: Iterable[str], *,
                 what: str) -> None:
    """Raise unless the bag holds ``required`` topics, and ``wanted`` ones with their types.

    Args:
        info: the bag.
        wanted: topic → message type the calibration reads.
        required: topics that must be present and non-empty.
        what: what needs them, for the message (e.g. 'method rbrlg').

    Raises:
        EmptyBagError: no message at all.
        MissingTopicError: a required topic is absent or has no message; the message lists
            the topics present with their types.
        WrongMessageTypeError: a wanted topic carries another message type.
    """
    if info.message_count == 0:
        raise EmptyBagError(f'{info.path}: the bag holds no message.')
    for name, msgtype in wanted.items():
        got = info.topics.get(name)
        if got is not None and got.msgtype != msgtype:
            raise WrongMessageTypeError(f'{info.path}: topic {name} has type {got.msgtype}, '
                                        f'expected {msgtype} ({what}).')
    for name in required:
        if name not in info.topics or info.topics[name].count == 0:
            raise MissingTopicError(
                f'{info.path}: {what} needs topic {name} ({wanted.get(name, "?")}), which is '
                f'missing or empty; the bag holds {topics_present(info)}.')


def topics_present(info: BagInfo) -> str:
    """'topic (type, n messages), …' of a bag, for messages naming what is there."""
    if not info.topics:
        return 'no topic'
    return ', '.join(f'{t.name} ({t.msgtype}, {t.count})'
                     for t in sorted(info.topics.values(), key=lambda t: t.name))


def iter_sample_batches(path: str | Path, topic_types: Mapping[str, str] | None = None, *,
                        batch_messages: int = 50_000,
                        namespace: str = '', recover: bool = True) -> Iterator[SampleBatch]:
    """Stream the given topics of a bag as :class:`SampleBatch` es.

    Decoded by :mod:`gyro_calib.bagio.columns`: whole chunks at a time with NumPy,
    bit-identical to rosbags' CDR deserialiser, which decodes any message of another
    layout (and whole bags the columnar path does not read itself). Memory is bounded by
    ``batch_messages`` plus one group of chunks; stamps are the header stamps (never the
    log times). With a ``namespace``, the topics are read under it and named as in the
    contract (:meth:`BagInfo.in_namespace`). With ``recover``, what is intact of a damaged
    bag (:func:`~gyro_calib.bagio.columns.iter_column_batches`), a skipped chunk named in
    ``SampleBatch.notes``.

    Raises:
        CorruptBagError: a chunk cannot be read or a message cannot be decoded.
    """
    if table_input.is_table(path):
        yield from table_input.iter_table_batches(path, topic_types, batch_messages)
        return
    types = dict(topic_types if topic_types is not None else CONTRACT_TYPES)
    ns = topics.normalized_namespace(namespace)
    if ns:
        types = {ns + t: m for t, m in types.items()}
    for batch in mcap_columns.iter_column_batches(path, types, batch_messages=batch_messages,
                                                  recover=recover):
        columns = batch.topics
        if ns:
            columns = {t[len(ns):]: dataclasses.replace(c, topic=t[len(ns):])
                       for t, c in columns.items()}
        yield SampleBatch(columns, batch.messages, batch.last_log_time_ns, batch.notes)


def iter_bags(paths: Sequence[str | Path], topic_types: Mapping[str, str], *,
              batch_messages: int = 50_000, namespace: str = '',
              recover: bool = True) -> Iterator[tuple[int, SampleBatch]]:
    """(bag index, batch) of several bags taken together in stamp order.

    Bags that share a topic are separate recordings (or one recording split in time) and
    are read one after the other, in order of their start; a source whose stamps jump back
    from one to the next is then a restart to the calibrators. Bags that share no topic and
    overlap in time (one recording split by topic) are interleaved batch by batch by log
    time, so their streams reach the calibrators together. With a ``namespace``, the
    topics of the bench in it (:meth:`BagInfo.in_namespace`).
    """
    infos = [bag_info(p, recover=recover).in_namespace(namespace) for p in paths]
    order = sorted(range(len(paths)), key=lambda i: infos[i].start_ns)
    split_by_topic = all(
        not (set(infos[a].topics) & set(infos[b].topics) & set(topic_types))
        for x, a in enumerate(order) for b in order[x + 1:])
    if not split_by_topic:
        for i in order:
            for batch in iter_sample_batches(paths[i], topic_types,
                                             batch_messages=batch_messages,
                                             namespace=namespace, recover=recover):
                yield i, batch
        return
    iters = {i: iter_sample_batches(paths[i], topic_types, batch_messages=batch_messages,
                                    namespace=namespace, recover=recover)
             for i in order}
    heap: list[tuple[int, int, SampleBatch]] = []
    for i, it in iters.items():
        first = next(it, None)
        if first is not None:
            heap.append((first.last_log_time_ns, i, first))
    heapq.heapify(heap)
    while heap:
        _, i, batch = heapq.heappop(heap)
        yield i, batch
        nxt = next(iters[i], None)
        if nxt is not None:
            heapq.heappush(heap, (nxt.last_log_time_ns, i, nxt))


def iter_raw_messages(path: str | Path) -> Iterator[tuple[str, str, int, bytes]]:
    """(topic, msgtype, log time ns, CDR bytes) of every message, in log-time order.

    Raises:
        BagError (subclass): as :func:`bag_info`, or a damaged chunk while reading.
    """
    path = Path(path)
    reader = open_reader(path)
    try:
        try:
            for con, log_ns, raw in reader.messages():
                yield con.topic, con.msgtype, int(log_ns), bytes(raw)
        except GyroCalibError:
            raise
        except Exception as exc:  # rosbags/zstd raise many kinds on damaged data
            raise CorruptBagError(f'{path}: damaged or truncated ({type(exc).__name__}: '
                                  f'{one_line(exc)}).') from exc
    finally:
        reader.close()
