"""Columnar decoding of fixed-layout ROS 2 messages straight from MCAP chunks (no rclpy).

rosbags' reader and CDR deserialiser handle one message at a time in Python (3–4 µs to
find a message, 14–18 µs to decode it). This module decodes the few fixed-layout message
types the calibrations read a whole chunk at a time with NumPy, and hands every message
whose bytes are not one of those layouts to rosbags' ``deserialize_cdr``, so the columns
are bit for bit what rosbags gives, or a named error (never another number):

* ``sensor_msgs/msg/JointState`` of one joint: stamp, position[0], velocity[0] (NaN when
  the array is empty), frame_id;
* ``std_msgs/msg/Header``: stamp, frame_id;
* ``sensor_msgs/msg/Imu``: stamp, angular_velocity, linear_acceleration, the first element
  of each covariance, frame_id;
* ``sensor_msgs/msg/Temperature``: stamp, temperature, variance, frame_id.

How a bag is read (MCAP spec, https://mcap.dev/spec; rosbag2 writes one ``.mcap`` file),
one module per step:

1. **Plan** (:mod:`~gyro_calib.bagio.plan`): the chunks holding the topics, from the
   file's summary, or why rosbags reads the bag whole;
2. **Chunks** (:mod:`~gyro_calib.bagio.chunks`): read ahead by a worker thread,
   decompressed and checked against their indexes;
3. **Messages** (:mod:`~gyro_calib.bagio.payloads`): each channel's payloads decoded by
   the fixed CDR layout of their message family (:mod:`~gyro_calib.bagio.layouts`), any
   other payload by rosbags;

and here the decoded pieces are put in order and cut into batches (:class:`ColumnBatch`).

Order guarantee: rosbags' reader yields messages in log-time order across all topics (equal
log times: earlier chunk in the file first, then record order in the chunk). Each topic's
columns here are in exactly that order, and batches hold whole groups of chunks, so every
message of a batch comes before every message of the next one in that order; concatenating
a batch's topics and sorting stably by ``log_time_ns`` gives rosbags' order except among
different topics at the same log time. The calibrators need only per-topic order and
``ColumnBatch.last_log_time_ns`` for progress.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from gyro_calib.bagio import recovery
from gyro_calib.bagio.chunks import _check_records, _prefetched
from gyro_calib.bagio.errors import (
    CorruptBagError,
    CountMismatchError,
    DamagedChunkError,
    IndexMismatchError,
    MessageDecodeError,
)
from gyro_calib.bagio.layouts import codec_for
from gyro_calib.bagio.messages import JOINT_WIDTHS
from gyro_calib.bagio.payloads import _Categories, _decode_channel, _deserialize, _Piece, _store
from gyro_calib.bagio.plan import ReadPlan, _check_types, _open_reader, _plan
from gyro_calib.bagio.records import SkippedChunk
from gyro_calib.errors import GyroCalibError

if TYPE_CHECKING:
    import numpy.typing as npt


# ---------------------------------------------------------------------------------------
# Results


@dataclass(frozen=True, slots=True)
class FrameIds:
    """A categorical column of ``header.frame_id`` strings.

    Attributes:
        codes: per message, the index of its frame_id in ``names`` (int32).
        names: the distinct frame_ids seen on the topic so far, in order of first
            appearance; a code keeps its meaning over all batches of one read.
    """

    codes: npt.NDArray[np.int32]
    names: tuple[str, ...]

    def strings(self) -> npt.NDArray[np.object_]:
        """The frame_id of every message (an object array; for inspection and tests)."""
        return np.array(self.names, dtype=object)[self.codes]


@dataclass(frozen=True, slots=True)
class TopicColumns:
    """The messages of one topic in a batch, as NumPy columns in log-time order.

    Attributes:
        topic: topic name.
        msgtype: ROS message type.
        log_time_ns: log (receive) time of each message, int64 ns.
        stamp_ns: header stamp of each message, int64 ns (sec · 10⁹ + nanosec).
        frame_id: header frame_id of each message.
        values: per message type (float64, NaN where a JointState array is empty):
            JointState ``position``, ``velocity`` (the joint's units);
            Imu ``angular_velocity_rad_s`` and ``linear_acceleration_m_s2`` (N × 3),
            ``orientation_covariance_0_rad2``, ``angular_velocity_covariance_0_rad2_s2``,
            ``linear_acceleration_covariance_0_m2_s4`` (first element of each matrix);
            Temperature ``temperature_degc``, ``variance_degc2``; Header none.
    """

    topic: str
    msgtype: str
    log_time_ns: npt.NDArray[np.int64]
    stamp_ns: npt.NDArray[np.int64]
    frame_id: FrameIds
    values: dict[str, npt.NDArray[np.float64]]
    joint_names: tuple[str, ...] = ()
    """A multi-joint JointState topic's joint names (``messages.JOINT_WIDTHS``), else ()."""

    def __len__(self) -> int:
        """Messages in the batch."""
        return len(self.stamp_ns)


@dataclass(frozen=True, slots=True)
class ColumnBatch:
    """Decoded messages of whole chunks, per topic (topics without message are left out).

    Attributes:
        topics: topic → its columns.
        messages: messages in the batch, all topics.
        last_log_time_ns: the largest log time in the batch.
        fallback_messages: how many of them rosbags' deserialiser decoded (a layout the
            columnar path does not know, or the whole bag read by rosbags).
        notes: damaged chunks skipped since the batch before, one line each.
    """

    topics: dict[str, TopicColumns]
    messages: int
    last_log_time_ns: int
    fallback_messages: int
    notes: tuple[str, ...] = ()



# ---------------------------------------------------------------------------------------
# Streaming


class _Batcher:
    """Collects decoded pieces per topic and cuts them into ColumnBatches."""

    def __init__(self, topics: dict[str, str]) -> None:
        self.types = topics
        self.cats = {t: _Categories() for t in topics}
        self.parts: dict[str, list[tuple[Any, ...]]] = {t: [] for t in topics}
        self.messages = 0
        self.fallback = 0
        self.last_log = -1
        self.joint_names: dict[str, tuple[str, ...]] = {}
        self.notes: list[str] = []

    def names_from(self, topic: str, msg: Any) -> None:
        """A multi-joint topic's joint names, from its first message."""
        self.joint_names[topic] = tuple(str(n) for n in msg.name)

    def add(self, topic: str, log: npt.NDArray[np.int64], stamp: npt.NDArray[np.int64],
            codes: npt.NDArray[np.int32], values: dict[str, npt.NDArray[np.float64]],
            fallback: int) -> None:
        if not len(log):
            return
        self.parts[topic].append((log, stamp, codes, values))
        self.messages += len(log)
        self.fallback += fallback
        self.last_log = max(self.last_log, int(log[-1]))

    def cut(self) -> ColumnBatch:
        columns = {}
        for topic, parts in self.parts.items():
            if not parts:
                continue
            names = [name for name, _ in codec_for(topic, self.types[topic]).values]
            columns[topic] = TopicColumns(
                topic, self.types[topic],
                np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                FrameIds(np.concatenate([p[2] for p in parts]),
                         tuple(self.cats[topic].names)),
                {name: np.concatenate([p[3][name] for p in parts]) for name in names},
                self.joint_names.get(topic, ()))
            parts.clear()
        batch = ColumnBatch(columns, self.messages, self.last_log, self.fallback,
                            tuple(self.notes))
        self.messages = self.fallback = 0
        self.notes.clear()
        return batch


def iter_column_batches(path: str | Path, topic_types: Mapping[str, str], *,
                        batch_messages: int = 50_000, start_ns: int | None = None,
                        stop_ns: int | None = None,
                        decoder: Literal['auto', 'rosbags'] = 'auto',
                        recover: bool = True) -> Iterator[ColumnBatch]:
    """Stream the topics of ``topic_types`` (topic → message type) as NumPy columns.

    A topic recorded with another type is skipped, as rosbags' reader skips it. Batches
    hold whole chunks (or groups of chunks overlapping in log time) and at least
    ``batch_messages`` messages, except the last; memory is bounded by that plus one group
    of chunks. See the module docstring for the order guarantee, and
    :mod:`~gyro_calib.bagio.plan` for the fallbacks.

    Args:
        path: a rosbag2 directory (or its .mcap file), or a .mcap file alone (no
            metadata.yaml beside it: its channels are the topics).
        topic_types: topic → one of :data:`~gyro_calib.bagio.layouts.KNOWN_TYPES`.
        batch_messages: messages per batch, at least.
        start_ns: only messages with ``start_ns <= log time`` (rosbags'
            ``Reader.messages(start, stop)``).
        stop_ns: only messages with ``log time < stop_ns``.
        decoder: 'rosbags' reads the whole bag with rosbags (the reference path).
        recover: read what is intact of a damaged bag (docs/recovery.md): a file without
            usable summary record by record (:mod:`~gyro_calib.bagio.recovery`), a
            damaged chunk of a file whose chunks carry checksums skipped, with a line in the
            next batch's ``notes``. False: a damaged bag raises.

    Raises:
        UnsupportedMessageTypeError: a type outside
            :data:`~gyro_calib.bagio.layouts.KNOWN_TYPES` was asked for.
        BagError (subclass): as :func:`gyro_calib.bagio.bag_info`; DamagedChunkError,
            IndexMismatchError, CountMismatchError, MessageDecodeError (all
            CorruptBagError) for a damaged bag.
    """
    return _iter_batches(Path(path), _check_types(topic_types), batch_messages, start_ns,
                         stop_ns, decoder, recover)


def _iter_batches(path: Path, types: dict[str, str], batch_messages: int,
                  start_ns: int | None, stop_ns: int | None,
                  decoder: Literal['auto', 'rosbags'], recover: bool) -> Iterator[ColumnBatch]:
    try:
        reader = _open_reader(path)
    except CorruptBagError as exc:
        if not recover or decoder == 'rosbags':
            raise
        got = recovery.recoverable(path, exc)
        yield from _iter_columnar(recovery.recovered_plan(path, got, types), types,
                                  batch_messages, start_ns, stop_ns)
        return
    try:
        plan = (ReadPlan(path, None, 'asked for') if decoder == 'rosbags'
                else _plan(path, reader, types))
        if not plan.columnar:
            yield from _iter_rosbags(path, reader, types, batch_messages, start_ns, stop_ns)
            return
    finally:
        reader.close()
    if recover:
        plan = recovery.checksummed_plan(plan)
    yield from _iter_columnar(plan, types, batch_messages, start_ns, stop_ns)



def _iter_columnar(plan: ReadPlan, types: dict[str, str], batch_messages: int,
                   start_ns: int | None, stop_ns: int | None) -> Iterator[ColumnBatch]:
    if not plan.channels:
        return
    window = None if start_ns is None and stop_ns is None else (
        -1 if start_ns is None else start_ns, 2**63 if stop_ns is None else stop_ns)
    groups = [[c for c in g if window is None or window[0] <= c.end_ns
               and c.start_ns < window[1]] for g in plan.groups]
    batcher = _Batcher({topic: msgtype for topic, msgtype in plan.channels.values()})
    decoded = dict.fromkeys(plan.channels, 0)
    todo = [g for g in groups if g]
    with contextlib.closing(_prefetched(plan, todo)) as loaded_groups:
        for chunks, group in zip(todo, loaded_groups, strict=True):
            pieces: dict[str, list[tuple[int, _Piece]]] = {}
            for chunk, future in zip(chunks, group, strict=True):
                try:
                    loaded = future.result()
                except (DamagedChunkError, IndexMismatchError) as exc:
                    if not chunk.checksummed:  # cannot be told apart from the others
                        raise
                    batcher.notes.append(SkippedChunk(
                        chunk.offset, chunk.offset + chunk.length, chunk.start_ns,
                        chunk.end_ns, _reason(exc, chunk.offset)).line(plan.path))
                    for cid in decoded:
                        decoded[cid] += chunk.counts.get(cid, 0)
                    continue
                records = _check_records(loaded.raw, loaded.data, loaded.entries,
                                         loaded.chunk, plan.path)
                for cid, rec in records.items():
                    if cid not in plan.channels:
                        continue
                    topic, msgtype = plan.channels[cid]
                    decoded[cid] += len(rec.log_time)
                    piece = _decode_channel(loaded.raw, loaded.data, rec, msgtype,
                                            batcher.cats[topic], _deserialize,
                                            f'{plan.path}: {topic}', topic)
                    if topic in JOINT_WIDTHS and topic not in batcher.joint_names \
                            and len(rec.payload_start):
                        batcher.names_from(topic, _deserialize(
                            loaded.raw[int(rec.payload_start[0]):int(rec.payload_start[0])
                                       + int(rec.payload_length[0])], msgtype))
                    pieces.setdefault(topic, []).append((loaded.chunk.offset, piece))
            for topic, parts in pieces.items():
                _add_in_order(batcher, topic, parts, window)
            if batcher.messages >= batch_messages:
                yield batcher.cut()
    if batcher.messages or batcher.notes:
        yield batcher.cut()
    if window is None and decoded != plan.counts:
        raise CountMismatchError(f'{plan.path}: damaged: decoded {decoded} messages per '
                                 f'channel, the statistics count {plan.counts}.')


def _reason(exc: Exception, offset: int) -> str:
    """What is wrong with a chunk, from the error its read raised (without path and place)."""
    text = ' '.join(str(exc).split()).rstrip('.')
    for place in (f'chunk at byte {offset}: ', f'chunk at byte {offset}, '):
        if place in text:
            return text.split(place, 1)[1]
    return text.split(': damaged: ', 1)[-1]


def _add_in_order(batcher: _Batcher, topic: str, parts: list[tuple[int, _Piece]],
                  window: tuple[int, int] | None) -> None:
    """Sort a group's pieces of one topic into rosbags' order.

    Sort a group's pieces of one topic by (log time, chunk offset, record offset), the
    order rosbags' reader yields them in, keep start <= log time < stop of ``window``, and
    add them to the batch.
    """
    if len(parts) == 1:
        piece = parts[0][1]
        log, offset, stamp, codes = piece.log_time, piece.offset, piece.stamp, piece.codes
        values = piece.values
        step = np.diff(log)
        in_order = bool(((step > 0) | ((step == 0) & (np.diff(offset) > 0))).all())
        order = None if in_order else np.lexsort((offset, log))
    else:
        log = np.concatenate([p.log_time for _, p in parts])
        offset = np.concatenate([p.offset for _, p in parts])
        chunk = np.concatenate([np.full(len(p.log_time), c) for c, p in parts])
        order = np.lexsort((offset, chunk, log))
        stamp = np.concatenate([p.stamp for _, p in parts])
        codes = np.concatenate([p.codes for _, p in parts])
        values = {name: np.concatenate([p.values[name] for _, p in parts])
                  for name in parts[0][1].values}
    keep = order
    if window is not None:
        inside = (log >= window[0]) & (log < window[1])
        if not inside.all():
            keep = np.flatnonzero(inside) if order is None else order[inside[order]]
    if keep is not None:
        log, stamp, codes = log[keep], stamp[keep], codes[keep]
        values = {name: v[keep] for name, v in values.items()}
    batcher.add(topic, log, stamp, codes, values, sum(p.fallback for _, p in parts))


def _iter_rosbags(path: Path, reader: Any, types: dict[str, str], batch_messages: int,
                  start_ns: int | None, stop_ns: int | None) -> Iterator[ColumnBatch]:
    """The reference path: rosbags' reader and ``deserialize_cdr``, one message at a time."""
    cons = [c for c in reader.connections if types.get(c.topic) == c.msgtype]
    if not cons:
        return
    deserialize = _store().deserialize_cdr
    batcher = _Batcher({c.topic: c.msgtype for c in cons})
    rows: dict[str, list[tuple[int, int, int, tuple[Any, ...]]]] = {c.topic: [] for c in cons}
    log_ns, pending = 0, 0
    try:
        for con, log_ns, raw in reader.messages(connections=cons, start=start_ns,
                                                stop=stop_ns):
            try:
                msg = deserialize(raw, con.msgtype)
            except Exception as exc:  # noqa: BLE001 -- rosbags raises SerdeError and others
                raise MessageDecodeError(
                    f'{path}: damaged: the {con.msgtype} message on {con.topic} logged at '
                    f'{log_ns} ns cannot be decoded ({type(exc).__name__}: '
                    f'{" ".join(str(exc).split())}).') from exc
            stamp, frame_id, values = codec_for(con.topic, con.msgtype).from_message(msg)
            if con.topic in JOINT_WIDTHS and con.topic not in batcher.joint_names:
                batcher.names_from(con.topic, msg)
            rows[con.topic].append((log_ns, stamp, batcher.cats[con.topic].code(frame_id),
                                    values))
            pending += 1
            if pending >= batch_messages:
                yield _rows_batch(batcher, rows)
                pending = 0
    except GyroCalibError:
        raise
    except Exception as exc:  # noqa: BLE001 -- rosbags/zstd raise many kinds on damaged data
        raise DamagedChunkError(f'{path}: damaged or truncated after log time {log_ns} ns '
                                f'({type(exc).__name__}: {" ".join(str(exc).split())}).'
                                ) from exc
    if any(rows.values()):
        yield _rows_batch(batcher, rows)


def _rows_batch(batcher: _Batcher,
                rows: dict[str, list[tuple[int, int, int, tuple[Any, ...]]]]) -> ColumnBatch:
    for topic, got in rows.items():
        if not got:
            continue
        codec = codec_for(topic, batcher.types[topic])
        values = {name: np.asarray([r[3][k] for r in got], dtype=np.float64)
                  for k, (name, _) in enumerate(codec.values)}
        batcher.add(topic, np.asarray([r[0] for r in got], dtype=np.int64),
                    np.asarray([r[1] for r in got], dtype=np.int64),
                    np.asarray([r[2] for r in got], dtype=np.int32), values, len(got))
        got.clear()
    return batcher.cut()
