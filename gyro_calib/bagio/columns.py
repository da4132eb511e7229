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

How a bag is read (MCAP spec, https://mcap.dev/spec; rosbag2 writes one ``.mcap`` file):

1. **Plan** (:func:`plan_bag`). The Footer points at the Summary section; its Chunk Index
   records (op 0x08) give each Chunk's file offset and length, message time range,
   compression, sizes, and the file offset of the Message Index record (op 0x07) of every
   channel in it. The per-channel message counts these imply (each Message Index record
   is 15 + 16·n bytes) must equal the Statistics record (op 0x0B), else
   :class:`CountMismatchError`. Files this module does not read itself go to rosbags whole
   (``ReadPlan.reason`` says why): no summary, chunk index or statistics (unchunked or
   unindexed files), chunk compression other than zstd or none (lz4), per-message or
   per-file rosbag2 compression, several storage files, a channel whose encoding is not
   CDR, chunks overlapping in log time beyond :data:`MAX_GROUP_CHUNKS`. Chunks without
   Message Index records raise :class:`UnindexedChunksError` instead: rosbags' reader
   returns no message from them (rosbags 0.11.9), which would be a silent loss.
2. **Chunks**, in log-time order. The Chunk record (op 0x06) header must agree with its
   index; its records are decompressed with ``zstandard`` (the frame's content checksum is
   verified when present; the chunk's CRC-32 too when non-zero), a damaged chunk raises
   :class:`DamagedChunkError`. The Message Index records behind the chunk give every
   message's (log_time, offset) per channel as one NumPy array. All Message record headers
   (op 0x05: channel_id u16, sequence u32, log_time u64, publish_time u64, data) are gathered
   at once and must match their index entries (opcode, channel, log time, length); the
   records must tile the chunk, and the few gaps (Schema and Channel records) are walked
   and must hold no Message record, else :class:`IndexMismatchError`.
3. **Messages**. For each channel, the CDR payloads are gathered as rows of equal length
   and checked against a layout derived from one of them: the encapsulation header must be
   CDR little-endian (representation identifier 0x0001; anything else goes to rosbags); the
   counts and string lengths (frame_id, JointState's name count and name length, array
   lengths) and string terminators must be those of the layout, and the payload may end
   with at most 3 bytes of padding after the last field (the bound rosbags accepts). Rows
   that match are decoded by NumPy views; any other row goes to rosbags' ``deserialize_cdr``
   on its own (an error there raises :class:`MessageDecodeError`).

CDR rules relied on (OMG CDR / XCDR1 "plain CDR" as ROS 2 writes it, and rosbags'
deserialiser): a 4-byte encapsulation header (2-byte representation identifier, 2 option
bytes, ignored), then the body; every primitive is aligned to its own size (at most 8)
relative to the start of the body; a string is a uint32 length counting its NUL terminator,
the bytes and the NUL; a sequence is a uint32 count (aligned to 4) followed by its elements,
a float64 sequence aligned to 8 only when non-empty; fixed arrays (Imu covariances) have no
count; nested messages are laid out inline.

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
import functools
import math
import struct
import zlib
from collections import deque
from collections.abc import Callable, Generator, Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from gyro_calib.bagio import storage
from gyro_calib.bagio.errors import BagError, CorruptBagError
from gyro_calib.bagio.messages import (
    HEADER,
    IMU,
    JOINT_STATE,
    JOINT_WIDTHS,
    TEMPERATURE,
    typestore,
)
from gyro_calib.errors import GyroCalibError

if TYPE_CHECKING:
    from typing import BinaryIO

    import numpy.typing as npt

MAX_GROUP_CHUNKS = 64
"""Chunks overlapping in log time are decoded together; more than this → rosbags whole."""

MAX_CHUNK_BYTES = 1 << 30
"""A chunk claiming more uncompressed bytes than this is read by rosbags whole."""

MAX_LAYOUTS = 8
"""Layouts tried per payload length in one chunk before the rest goes to rosbags."""

PREFETCH = 2
"""Chunks a worker thread reads and decompresses ahead of the one being decoded."""

_CDR_LE = b'\x00\x01'
_NS_PER_S = 1_000_000_000
_MESSAGE_HEAD = 31
"""Message record bytes before its data: opcode 1, length 8, channel 2, sequence 4, 2 × time 8."""

_CHUNK_HEAD = struct.Struct('<BQQQQII')
"""Chunk record: opcode, record length, message start/end time, uncompressed size, CRC,
compression string length (MCAP spec, "Chunk")."""

_INDEX_HEAD = struct.Struct('<BQHI')
"""Message Index record: opcode, record length, channel id, byte length of its entries."""

_INDEX_ENTRY = np.dtype([('log_time', '<u8'), ('offset', '<u8')])
_RECORD = np.dtype({'names': ['opcode', 'length', 'channel', 'log_time'],
                    'formats': ['u1', '<u8', '<u2', '<u8'],
                    'offsets': [0, 1, 9, 15], 'itemsize': 32})
"""A Message record's head, gathered 32 bytes wide (one byte of its data, or padding)."""

_PAD = 64
"""Zero bytes after a chunk's records, so rows can be gathered in whole 4-byte words."""


# ---------------------------------------------------------------------------------------
# Errors


class ColumnDecodeError(BagError):
    """The columnar decoder cannot read the bag as asked; the message names path and place."""


class UnsupportedMessageTypeError(ColumnDecodeError):
    """A topic was asked for with a message type this module has no columns for."""


class UnindexedChunksError(ColumnDecodeError):
    """The file's chunks have no Message Index records.

    The file's chunks have no Message Index records (valid MCAP, but rosbags' reader
    returns no message from them and the columnar decoder needs them).
    """


class DamagedChunkError(ColumnDecodeError, CorruptBagError):
    """A chunk is truncated, fails to decompress or fails its checksum."""


class IndexMismatchError(ColumnDecodeError, CorruptBagError):
    """A chunk's index disagrees with its records (offsets, channels, log times, lengths)."""


class CountMismatchError(ColumnDecodeError, CorruptBagError):
    """The chunk indexes list another number of messages on a channel than the statistics."""


class MessageDecodeError(ColumnDecodeError, CorruptBagError):
    """rosbags' CDR deserialiser rejected a message the columnar path handed to it."""


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
    """

    topics: dict[str, TopicColumns]
    messages: int
    last_log_time_ns: int
    fallback_messages: int


# ---------------------------------------------------------------------------------------
# Message layouts (CDR)


class _NotNarrow(Exception):
    """The payload is not one of the fixed layouts: rosbags decodes it."""


@dataclass(frozen=True, slots=True)
class _Layout:
    """Where the fields of one fixed-layout payload are, and what fixes that layout.

    Offsets count from the start of the payload, encapsulation header included.

    Attributes:
        length: payload bytes.
        words: (offset, value) of every uint32 count or string length of the layout.
        terminators: offsets of the strings' NUL bytes.
        strings: (start, stop) of each string's characters; the first is frame_id.
        fields: (value name, offset or None when the array is empty, float64 count).
    """

    length: int
    words: tuple[tuple[int, int], ...]
    terminators: tuple[int, ...]
    strings: tuple[tuple[int, int], ...]
    fields: tuple[tuple[str, int | None, int], ...]


class _Cursor:
    """Walks one CDR payload as rosbags' deserialiser does, recording the layout.

    Alignment is relative to the body (payload offset 4), as XCDR1 requires.
    """

    def __init__(self, payload: bytes) -> None:
        if len(payload) < 4 or payload[:2] != _CDR_LE:
            raise _NotNarrow
        self.buf = payload
        self.pos = 4
        self.words: list[tuple[int, int]] = []
        self.terminators: list[int] = []
        self.strings: list[tuple[int, int]] = []

    def align(self, size: int) -> None:
        self.pos = 4 + -(-(self.pos - 4) // size) * size

    def skip(self, n: int) -> int:
        start = self.pos
        if start + n > len(self.buf):
            raise _NotNarrow
        self.pos = start + n
        return start

    def count(self) -> int:
        self.align(4)
        at = self.skip(4)
        value = int.from_bytes(self.buf[at:at + 4], 'little')
        self.words.append((at, value))
        return value

    def string(self) -> None:
        n = self.count()
        if n < 1:
            raise _NotNarrow
        start = self.skip(n)
        if self.buf[start + n - 1] != 0:
            raise _NotNarrow
        self.terminators.append(start + n - 1)
        self.strings.append((start, start + n - 1))

    def header(self) -> None:
        """std_msgs/Header: stamp (int32 sec at 4, uint32 nanosec at 8), frame_id."""
        self.skip(8)
        self.string()

    def layout(self, fields: list[tuple[str, int | None, int]]) -> _Layout:
        if not 0 <= len(self.buf) - self.pos <= 3:
            raise _NotNarrow
        return _Layout(len(self.buf), tuple(self.words), tuple(self.terminators),
                       tuple(self.strings), tuple(fields))


def _joint_state_layout(payload: bytes) -> _Layout:
    """JointState with one name; position, velocity, effort of 0 or 1 element."""
    c = _Cursor(payload)
    c.header()
    if c.count() != 1:
        raise _NotNarrow
    c.string()
    fields: list[tuple[str, int | None, int]] = []
    for name in ('position', 'velocity', 'effort'):
        n = c.count()
        if n > 1:
            raise _NotNarrow
        at = None
        if n:
            c.align(8)
            at = c.skip(8)
        if name != 'effort':
            fields.append((name, at, 1))
    return c.layout(fields)


def _joints_layout(width: int) -> Callable[[bytes], _Layout]:
    """JointState with ``width`` names and positions; velocity, effort of 0 or ``width``."""
    def layout(payload: bytes) -> _Layout:
        c = _Cursor(payload)
        c.header()
        if c.count() != width:
            raise _NotNarrow
        for _ in range(width):
            c.string()
        if c.count() != width:
            raise _NotNarrow
        c.align(8)
        fields: list[tuple[str, int | None, int]] = [('position', c.skip(8 * width), width)]
        for name in ('velocity', 'effort'):
            n = c.count()
            if n not in (0, width):
                raise _NotNarrow
            at = None
            if n:
                c.align(8)
                at = c.skip(8 * n)
            if name == 'velocity':
                fields.append((name, at, 1))
        return c.layout(fields)
    return layout


def _header_layout(payload: bytes) -> _Layout:
    c = _Cursor(payload)
    c.header()
    return c.layout([])


def _imu_layout(payload: bytes) -> _Layout:
    """Imu layout: header, then 37 float64.

    Imu: header, then 37 float64 from an 8-aligned offset (quaternion, 3 × (matrix 9,
    vector 3) interleaved as orientation, cov, angular velocity, cov, acceleration, cov).
    """
    c = _Cursor(payload)
    c.header()
    c.align(8)
    at = c.skip(37 * 8)
    return c.layout([('angular_velocity_rad_s', at + 104, 3),
                     ('linear_acceleration_m_s2', at + 200, 3),
                     ('orientation_covariance_0_rad2', at + 32, 1),
                     ('angular_velocity_covariance_0_rad2_s2', at + 128, 1),
                     ('linear_acceleration_covariance_0_m2_s4', at + 224, 1)])


def _temperature_layout(payload: bytes) -> _Layout:
    c = _Cursor(payload)
    c.header()
    c.align(8)
    at = c.skip(16)
    return c.layout([('temperature_degc', at, 1), ('variance_degc2', at + 8, 1)])


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * _NS_PER_S + int(stamp.nanosec)


def _first(values: Any) -> float:
    return values[0] if len(values) else math.nan


def _joint_state_values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
    return (_stamp_ns(msg.header.stamp), msg.header.frame_id,
            (_first(msg.position), _first(msg.velocity)))


def _joints_values(width: int) -> Callable[[Any], tuple[int, str, tuple[Any, ...]]]:
    def values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
        pos = tuple(float(msg.position[k]) if len(msg.position) > k else math.nan
                    for k in range(width))
        return (_stamp_ns(msg.header.stamp), msg.header.frame_id,
                (pos, _first(msg.velocity)))
    return values


def _header_values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
    return _stamp_ns(msg.stamp), msg.frame_id, ()


def _imu_values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
    w, a = msg.angular_velocity, msg.linear_acceleration
    return (_stamp_ns(msg.header.stamp), msg.header.frame_id,
            ((w.x, w.y, w.z), (a.x, a.y, a.z), msg.orientation_covariance[0],
             msg.angular_velocity_covariance[0], msg.linear_acceleration_covariance[0]))


def _temperature_values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
    return (_stamp_ns(msg.header.stamp), msg.header.frame_id,
            (msg.temperature, msg.variance))


@dataclass(frozen=True, slots=True)
class _Codec:
    """What one message type gives and how to read it either way.

    Attributes:
        values: (value name, float64 per message) in column order.
        layout: the fixed layout of one payload (raises _NotNarrow otherwise).
        from_message: stamp, frame_id and values of a rosbags message object.
    """

    values: tuple[tuple[str, int], ...]
    layout: Callable[[bytes], _Layout]
    from_message: Callable[[Any], tuple[int, str, tuple[Any, ...]]]


CODECS: dict[str, _Codec] = {
    JOINT_STATE: _Codec((('position', 1), ('velocity', 1)), _joint_state_layout,
                        _joint_state_values),
    HEADER: _Codec((), _header_layout, _header_values),
    IMU: _Codec((('angular_velocity_rad_s', 3), ('linear_acceleration_m_s2', 3),
                 ('orientation_covariance_0_rad2', 1),
                 ('angular_velocity_covariance_0_rad2_s2', 1),
                 ('linear_acceleration_covariance_0_m2_s4', 1)), _imu_layout, _imu_values),
    TEMPERATURE: _Codec((('temperature_degc', 1), ('variance_degc2', 1)),
                        _temperature_layout, _temperature_values),
}
"""The message types this module decodes, by ROS type name."""

_JOINTS_CODECS = {width: _Codec((('position', width), ('velocity', 1)), _joints_layout(width),
                                _joints_values(width))
                  for width in set(JOINT_WIDTHS.values())}


def codec_for(topic: str, msgtype: str) -> _Codec:
    """The codec of a topic: its type's, or the multi-joint JointState's (JOINT_WIDTHS)."""
    if msgtype == JOINT_STATE and topic in JOINT_WIDTHS:
        return _JOINTS_CODECS[JOINT_WIDTHS[topic]]
    return CODECS[msgtype]

KNOWN_TYPES = frozenset(CODECS)


# ---------------------------------------------------------------------------------------
# Plan


@dataclass(frozen=True, slots=True)
class ChunkPlan:
    """One chunk from its Chunk Index record (MCAP spec, "Chunk Index").

    Attributes:
        offset, length: file offset and length of the Chunk record.
        start_ns, end_ns: first and last log time in it.
        compression: '' or 'zstd' (others go to rosbags whole).
        compressed_size, uncompressed_size: bytes of its records.
        index_offsets: channel id → file offset of its Message Index record.
        index_length: bytes of all its Message Index records (they follow the chunk).
        counts: channel id → messages, from the Message Index record lengths.
    """

    offset: int
    length: int
    start_ns: int
    end_ns: int
    compression: str
    compressed_size: int
    uncompressed_size: int
    index_offsets: dict[int, int]
    index_length: int
    counts: dict[int, int]


@dataclass(frozen=True, slots=True)
class ReadPlan:
    """How :func:`iter_column_batches` reads a bag.

    Attributes:
        path: the bag.
        mcap_path: its storage file.
        reason: why rosbags reads the bag whole; '' when the columnar path reads it.
        channels: MCAP channel id → (topic, message type), the channels rosbags' reader
            would yield for the topics asked for.
        groups: the chunks holding those channels, in log-time order, grouped where their
            log-time ranges overlap (decoded together).
        counts: channel id → messages, from the statistics.
    """

    path: Path
    mcap_path: Path | None
    reason: str
    channels: dict[int, tuple[str, str]] = field(default_factory=dict)
    groups: tuple[tuple[ChunkPlan, ...], ...] = ()
    counts: dict[int, int] = field(default_factory=dict)

    @property
    def columnar(self) -> bool:
        """True when the columnar path reads the bag."""
        return not self.reason


def _open_reader(path: Path) -> Any:
    """Open rosbags' Reader on a bag or a lone .mcap file.

    rosbags' Reader, opened by :func:`gyro_calib.bagio.storage.open_reader` for a bag
    directory (or a .mcap file in one), or on the file alone for a .mcap file without
    metadata.yaml beside it; the failures open_reader lets through (a damaged record length
    makes rosbags allocate without bound: MemoryError; struct.error, OverflowError) are
    CorruptBagError too.
    """
    try:
        if path.suffix == '.mcap' and path.is_file() and not storage.usable_metadata(
                path.parent / 'metadata.yaml'):
            from rosbags.rosbag2 import Reader

            reader = Reader(path)
            reader.open()
            return reader
        return storage.open_reader(path)
    except GyroCalibError:
        raise
    except Exception as exc:  # noqa: BLE001 -- rosbags raises many kinds on a damaged file
        raise CorruptBagError(f'{path}: damaged or truncated, cannot be read as a rosbag2 '
                              f'MCAP bag ({type(exc).__name__}: '
                              f'{" ".join(str(exc).split())}).') from exc


def _check_types(topic_types: Mapping[str, str]) -> dict[str, str]:
    unknown = {t: m for t, m in topic_types.items() if m not in CODECS}
    if unknown:
        raise UnsupportedMessageTypeError(
            f'no columns are defined for {unknown}; the columnar decoder reads '
            f'{", ".join(sorted(CODECS))}. Read these topics with gyro_calib.bagio instead.')
    return dict(topic_types)


def plan_bag(path: str | Path, topic_types: Mapping[str, str]) -> ReadPlan:
    """The plan :func:`iter_column_batches` follows for ``topic_types`` (topic → type).

    Raises:
        BagError (subclass): as :func:`gyro_calib.bagio.bag_info`; CountMismatchError or
            IndexMismatchError when the summary contradicts itself.
    """
    path = Path(path)
    types = _check_types(topic_types)
    reader = _open_reader(path)
    try:
        return _plan(path, reader, types)
    finally:
        reader.close()


def _wanted_channels(connections: list[Any], storage_connections: list[Any],
                     types: dict[str, str]) -> dict[int, tuple[str, str]]:
    """Channels rosbags' rosbag2 reader yields for the topics.

    Channels rosbags' rosbag2 Reader.messages() yields for the topics (its matching rule:
    same topic, type and QoS/format, digests equal when both known).
    """
    wanted = [c for c in connections if types.get(c.topic) == c.msgtype]
    return {x.id: (x.topic, x.msgtype) for x in storage_connections
            if any(y.topic == x.topic and y.msgtype == x.msgtype and y.ext == x.ext
                   and (not x.digest or not y.digest or y.digest == x.digest)
                   for y in wanted)}


def _chunk_counts(index: Any, path: Path) -> dict[int, int]:
    """Messages per channel from a Chunk Index.

    Messages per channel from a Chunk Index's Message Index offsets: each record is
    15 + 16·n bytes and they follow each other to the end of ``message_index_length``.
    """
    by_offset = sorted((off, ch) for ch, off in index.message_index_offsets.items())
    if not by_offset:
        return {}
    ends = [off for off, _ in by_offset[1:]]
    ends.append(index.chunk_start_offset + index.chunk_length + index.message_index_length)
    counts = {}
    for (off, ch), end in zip(by_offset, ends, strict=True):
        n, rest = divmod(end - off - 15, 16)
        if n < 0 or rest:
            raise IndexMismatchError(
                f'{path}: damaged: the chunk index at byte {index.chunk_start_offset} gives '
                f'channel {ch} a message index of {end - off} bytes, not 15 + 16·n.')
        counts[ch] = n
    return counts


def _plan(path: Path, reader: Any, types: dict[str, str]) -> ReadPlan:
    from mcap.reader import make_reader

    def whole(reason: str) -> ReadPlan:
        return ReadPlan(path, None, reason)

    # rosbags' DirectoryReader (metadata.yaml and storage files), or its McapReader
    storages = getattr(reader.storage, 'storages', [reader.storage])
    if len(storages) != 1:
        return whole(f'the bag has {len(storages)} storage files')
    if reader.compression_mode:
        return whole(f'rosbag2 {reader.compression_mode} compression')
    mcap_path = Path(storages[0].path)
    if mcap_path.suffix != '.mcap':
        return whole('its storage is not MCAP')
    channels = _wanted_channels(reader.connections, storages[0].connections, types)
    if not channels:
        return ReadPlan(path, mcap_path, '')
    try:
        with mcap_path.open('rb') as f:
            summary = make_reader(f).get_summary()
    except Exception as exc:  # noqa: BLE001 -- any parse failure: rosbags' parse decides
        return whole(f'the mcap library cannot read its summary ({type(exc).__name__})')
    if summary is None or not summary.chunk_indexes:
        return whole('it has no summary or chunk index (unchunked or unindexed file)')
    chunks = [ChunkPlan(ci.chunk_start_offset, ci.chunk_length, ci.message_start_time,
                        ci.message_end_time, ci.compression, ci.compressed_size,
                        ci.uncompressed_size, dict(ci.message_index_offsets),
                        ci.message_index_length, _chunk_counts(ci, path))
              for ci in summary.chunk_indexes]
    if not any(c.index_offsets for c in chunks):
        raise UnindexedChunksError(
            f'{path}: its chunks carry no message index, so neither the columnar decoder nor '
            f'rosbags\' reader (which returns no message from such chunks) can read it; '
            f'write the index with `mcap recover {mcap_path.name} -o indexed.mcap`.')
    if summary.statistics is None:
        return whole('its summary has no statistics record')
    for cid, (topic, msgtype) in channels.items():
        ch = summary.channels.get(cid)
        schema = summary.schemas.get(ch.schema_id) if ch is not None else None
        if ch is None or schema is None or (ch.topic, schema.name) != (topic, msgtype):
            return whole(f'the mcap library and rosbags disagree on channel {cid}')
        if ch.message_encoding != 'cdr':
            return whole(f'channel {cid} ({topic}) is encoded as {ch.message_encoding!r}')
    if len({c.offset for c in chunks}) != len(chunks):
        return whole('its summary lists a chunk twice')
    _check_counts(path, channels, chunks, summary.statistics.channel_message_counts)
    selected = [c for c in chunks if any(c.counts.get(cid) for cid in channels)]
    file_size = mcap_path.stat().st_size
    for c in selected:
        if c.offset + c.length + c.index_length > file_size:
            raise IndexMismatchError(
                f'{path}: damaged or truncated: the chunk index at byte {c.offset} points '
                f'past the end of the file ({file_size} bytes).')
        if c.compression not in ('', 'zstd'):
            return whole(f'{c.compression} chunk compression')
        if c.uncompressed_size > MAX_CHUNK_BYTES:
            return whole(f'a chunk of {c.uncompressed_size} bytes')
    groups = _overlap_groups(selected)
    if any(len(g) > MAX_GROUP_CHUNKS for g in groups):
        return whole(f'more than {MAX_GROUP_CHUNKS} chunks overlap in log time')
    counts = {cid: summary.statistics.channel_message_counts.get(cid, 0) for cid in channels}
    return ReadPlan(path, mcap_path, '', channels, groups, counts)


def _check_counts(path: Path, channels: dict[int, tuple[str, str]],
                  chunks: list[ChunkPlan], statistics: Mapping[int, int]) -> None:
    for cid, (topic, _) in channels.items():
        indexed = sum(c.counts.get(cid, 0) for c in chunks)
        stated = statistics.get(cid, 0)
        if indexed != stated:
            raise CountMismatchError(
                f'{path}: damaged: the summary statistics count {stated} messages on {topic} '
                f'(channel {cid}) but the chunk indexes list {indexed}; the file is '
                f'inconsistent, re-record or repair it (e.g. `mcap recover`).')


def _overlap_groups(chunks: list[ChunkPlan]) -> tuple[tuple[ChunkPlan, ...], ...]:
    """Chunks in rosbags' order, grouped by message order.

    Chunks in rosbags' order, grouped so that every message of a group comes after
    every message of the groups before it in that order: key (log time, chunk offset,
    record offset).
    """
    groups: list[list[ChunkPlan]] = []
    last: tuple[int, int] | None = None
    for c in sorted(chunks, key=lambda c: (c.start_ns, c.offset)):
        if last is None or (c.start_ns, c.offset) > last:
            groups.append([c])
            last = (c.end_ns, c.offset)
        else:
            groups[-1].append(c)
            last = max(last, (c.end_ns, c.offset))
    return tuple(tuple(g) for g in groups)


# ---------------------------------------------------------------------------------------
# Chunks


@functools.cache
def _store() -> Any:
    """One rosbags typestore (each new one compiles its (de)serialisers again on first use)."""
    return typestore()


def _deserialize(payload: bytes, msgtype: str) -> Any:
    """The CDR deserialiser of rosbags (its typestore loads on the first message that needs it)."""
    return _store().deserialize_cdr(payload, msgtype)


def _decompressor() -> Callable[[bytes | memoryview, int], bytes]:
    import zstandard

    dctx = zstandard.ZstdDecompressor()

    def decompress(data: bytes | memoryview, size: int) -> bytes:
        return dctx.decompress(data, max_output_size=size, allow_extra_data=False)
    return decompress


def _read_chunk(f: BinaryIO, chunk: ChunkPlan, path: Path,
                decompress: Callable[[bytes | memoryview, int], bytes]
                ) -> tuple[bytes, dict[int, npt.NDArray[Any]]]:
    """The decompressed records of ``chunk`` and its Message Index entries per channel.

    Raises:
        DamagedChunkError: truncated, header disagreeing with the index, failed
            decompression, size or CRC-32.
        IndexMismatchError: Message Index records not where the chunk index says.
    """
    where = f'{path}: damaged or truncated chunk at byte {chunk.offset}'
    f.seek(chunk.offset)
    span = f.read(chunk.length + chunk.index_length)
    if len(span) != chunk.length + chunk.index_length or chunk.length < _CHUNK_HEAD.size:
        raise DamagedChunkError(f'{where}: the file ends inside it.')
    opcode, length, start, end, size, crc, n_comp = _CHUNK_HEAD.unpack_from(span)
    body = _CHUNK_HEAD.size + n_comp + 8
    compression = span[_CHUNK_HEAD.size:_CHUNK_HEAD.size + n_comp]
    stored = (int.from_bytes(span[body - 8:body], 'little')
              if body <= chunk.length else -1)
    if (opcode, length, start, end, size, compression, stored, body + stored) != (
            0x06, chunk.length - 9, chunk.start_ns, chunk.end_ns, chunk.uncompressed_size,
            chunk.compression.encode(), chunk.compressed_size, chunk.length):
        raise DamagedChunkError(f'{where}: its header disagrees with the chunk index.')
    data = memoryview(span)[body:chunk.length]
    if chunk.compression == 'zstd':
        try:
            raw = decompress(data, size)
        except Exception as exc:  # noqa: BLE001 -- zstandard raises ZstdError and others
            raise DamagedChunkError(f'{where}: it does not decompress '
                                    f'({" ".join(str(exc).split())}).') from exc
    else:
        raw = bytes(data)
    if len(raw) != size:
        raise DamagedChunkError(f'{where}: {len(raw)} bytes decompressed, {size} expected.')
    if crc and zlib.crc32(raw) != crc:
        raise DamagedChunkError(f'{where}: its CRC-32 does not match.')
    return raw, _message_index(span, chunk, path)


def _message_index(span: bytes, chunk: ChunkPlan, path: Path) -> dict[int, npt.NDArray[Any]]:
    """Entries (log_time, offset) of the chunk's Message Index records.

    Entries (log_time, offset) of each Message Index record behind the chunk (MCAP spec,
    "Message Index": channel_id u16, then uint32-length-prefixed (u64, u64) pairs).
    """
    entries: dict[int, npt.NDArray[Any]] = {}
    pos, end = chunk.length, len(span)
    while pos < end:
        bad = pos + _INDEX_HEAD.size > end
        if not bad:
            opcode, length, cid, n_bytes = _INDEX_HEAD.unpack_from(span, pos)
            bad = (opcode != 0x07 or length != 6 + n_bytes or n_bytes % 16
                   or pos + 9 + length > end or cid in entries
                   or chunk.index_offsets.get(cid) != chunk.offset + pos)
        if bad:
            raise IndexMismatchError(f'{path}: damaged: the message index of the chunk at byte '
                                     f'{chunk.offset} is not where its chunk index says '
                                     f'(byte {chunk.offset + pos}).')
        entries[cid] = np.frombuffer(span, _INDEX_ENTRY, count=n_bytes // 16,
                                     offset=pos + _INDEX_HEAD.size)
        pos += 9 + length
    if set(entries) != set(chunk.index_offsets):
        raise IndexMismatchError(f'{path}: damaged: the chunk at byte {chunk.offset} lacks '
                                 f'the message index of channels '
                                 f'{sorted(set(chunk.index_offsets) - set(entries))}.')
    return entries


@dataclass(frozen=True, slots=True)
class _Records:
    """Message records of one channel in one chunk, in index order."""

    log_time: npt.NDArray[np.int64]
    offset: npt.NDArray[np.int64]
    payload_start: npt.NDArray[np.int64]
    payload_length: npt.NDArray[np.int64]


def _check_records(raw: bytes, data: npt.NDArray[np.uint8],
                   entries: dict[int, npt.NDArray[Any]], chunk: ChunkPlan,
                   path: Path) -> dict[int, _Records]:
    """Check the indexed Message records of a chunk.

    Check every indexed Message record against its entry and that the records tile the
    chunk; return each channel's records. ``data`` is ``raw`` followed by _PAD zero bytes.

    Raises:
        IndexMismatchError: an entry points outside the chunk or at another record, two
            records overlap, a gap holds a Message record the index does not list, or a
            log time lies outside the chunk's range.
    """
    def mismatch(what: str) -> IndexMismatchError:
        return IndexMismatchError(f'{path}: damaged: in the chunk at byte {chunk.offset}, '
                                  f'{what}.')

    ids = list(entries)
    lengths = [len(entries[c]) for c in ids]
    if not sum(lengths):
        return {}
    offset_u = np.concatenate([entries[c]['offset'] for c in ids])
    log_u = np.concatenate([entries[c]['log_time'] for c in ids])
    size = len(raw)
    if size < _MESSAGE_HEAD or (offset_u > size - _MESSAGE_HEAD).any():
        raise mismatch('a message index entry points past the end of the chunk')
    offset = offset_u.astype(np.int64)
    head = sliding_window_view(data, 32)[offset].view(_RECORD)[:, 0]
    channel = np.repeat(np.asarray(ids, dtype=np.uint16), lengths)
    bad = ((head['opcode'] != 0x05) | (head['channel'] != channel)
           | (head['log_time'] != log_u) | (head['length'] < 22)
           | (head['length'] > size))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise mismatch(f'the message index entry of channel {int(channel[i])} at record '
                       f'offset {int(offset[i])} does not point at its message record')
    end = offset + 9 + head['length'].astype(np.int64)
    order = np.argsort(offset, kind='stable')
    starts, ends = offset[order], end[order]
    if ends[-1] > size or (starts[1:] < ends[:-1]).any():
        raise mismatch('message records overlap or run past the end of the chunk')
    gap_from = np.concatenate(([0], ends))
    gap_to = np.concatenate((starts, [size]))
    for g in np.flatnonzero(gap_from != gap_to):
        _walk_gap(raw, int(gap_from[g]), int(gap_to[g]), mismatch)
    if (log_u < chunk.start_ns).any() or (log_u > chunk.end_ns).any():
        raise mismatch(f'a message log time lies outside the chunk\'s range '
                       f'[{chunk.start_ns}, {chunk.end_ns}] ns')
    log = log_u.astype(np.int64)
    records: dict[int, _Records] = {}
    bounds = np.cumsum([0, *lengths])
    for cid, a, b in zip(ids, bounds[:-1], bounds[1:], strict=True):
        rec_len = head['length'][a:b].astype(np.int64)
        records[cid] = _Records(log[a:b], offset[a:b], offset[a:b] + _MESSAGE_HEAD,
                                rec_len - 22)
    return records


def _walk_gap(raw: bytes, pos: int, stop: int,
              mismatch: Callable[[str], IndexMismatchError]) -> None:
    """Check the records between indexed messages.

    Records between indexed messages (Schema, Channel...) must tile the gap and not be
    Message records (rosbags would read those; the index does not list them).
    """
    while pos < stop:
        if pos + 9 > stop:
            raise mismatch(f'the records at offset {pos} do not fit between indexed messages')
        opcode = raw[pos]
        if opcode == 0x05:
            raise mismatch(f'the message record at offset {pos} is not in the message index')
        pos += 9 + int.from_bytes(raw[pos + 1:pos + 9], 'little')
    if pos != stop:
        raise mismatch(f'a record runs into the indexed message at offset {stop}')


# ---------------------------------------------------------------------------------------
# Payloads


class _Categories:
    """The distinct frame_ids of one topic, in order of first appearance."""

    def __init__(self) -> None:
        self.codes: dict[str, int] = {}
        self.names: list[str] = []

    def code(self, name: str) -> int:
        code = self.codes.get(name)
        if code is None:
            code = self.codes[name] = len(self.names)
            self.names.append(name)
        return code

    def code_of(self, raw: bytes) -> int:
        """The code of a frame_id's bytes, -1 when they are not UTF-8 (rosbags would fail)."""
        try:
            return self.code(raw.decode())
        except UnicodeDecodeError:
            return -1


def _distinct(chars: npt.NDArray[np.uint8]) -> tuple[npt.NDArray[np.intp], list[bytes]]:
    """Rows of equal-length strings → (code per row, distinct strings), no per-row loop."""
    n, k = chars.shape
    if k == 0 or (chars == chars[0]).all():
        return np.zeros(n, dtype=np.intp), [chars[0].tobytes()]
    keys = np.ascontiguousarray(chars).view(f'V{k}')[:, 0]
    uniq, codes = np.unique(keys, return_inverse=True)
    return codes.reshape(-1), [u.tobytes() for u in uniq]


def _utf8(raw: bytes) -> bool:
    try:
        raw.decode()
    except UnicodeDecodeError:
        return False
    return True


_Checks = tuple[tuple[int, int, int], ...]
"""(word index, mask, value): uint32 words of a payload that must equal value under mask."""


def _checks(layout: _Layout, template: bytes) -> tuple[_Checks, _Checks]:
    """Word checks for rows of a layout.

    Word checks for rows of ``layout``: of the layout alone (CDR little-endian, counts,
    string lengths, terminators), and of the layout with the strings of ``template``.

    Counts sit on 4-aligned body offsets, so on whole words of the payload; string bytes
    and terminators are masked bytes of their words; padding bytes are never checked
    (rosbags ignores them).
    """
    shape: dict[int, list[int]] = {0: [0x0000FFFF, 0x00000100]}  # identifier 0x0001 (LE)

    def add(into: dict[int, list[int]], at: int, mask: int, value: int) -> None:
        word = into.setdefault(at // 4, [0, 0])
        word[0] |= mask << 8 * (at % 4)
        word[1] |= value << 8 * (at % 4)

    for at, value in layout.words:
        add(shape, at, 0xFFFFFFFF, value)
    for at in layout.terminators:
        add(shape, at, 0xFF, 0)
    full = {j: list(mv) for j, mv in shape.items()}
    for start, stop in layout.strings:
        for at in range(start, stop):
            add(full, at, 0xFF, template[at])

    def frozen(words: dict[int, list[int]]) -> _Checks:
        return tuple((j, m, v) for j, (m, v) in sorted(words.items()))
    return frozen(shape), frozen(full)


def _match(words: npt.NDArray[np.uint32], checks: _Checks) -> npt.NDArray[np.bool_]:
    """Rows whose words pass every check (one vectorised compare per checked word)."""
    ok = np.ones(len(words), dtype=np.bool_)
    for j, mask, value in checks:
        column = words[:, j]
        ok &= (column == value) if mask == 0xFFFFFFFF else ((column & mask) == value)
    return ok


@dataclass(slots=True)
class _Piece:
    """Decoded messages of one channel in one chunk, in record-index order."""

    log_time: npt.NDArray[np.int64]
    offset: npt.NDArray[np.int64]
    stamp: npt.NDArray[np.int64]
    codes: npt.NDArray[np.int32]
    values: dict[str, npt.NDArray[np.float64]]
    fallback: int


def _decode_channel(raw: bytes, data: npt.NDArray[np.uint8], rec: _Records, msgtype: str,
                    cats: _Categories, deserialize: Callable[[bytes, str], Any],
                    where: str, topic: str = '') -> _Piece:
    """Decode one channel's messages of a chunk: fixed layouts by NumPy, others by rosbags."""
    codec = codec_for(topic, msgtype)
    n = len(rec.payload_start)
    piece = _Piece(rec.log_time, rec.offset, np.zeros(n, dtype=np.int64),
                   np.zeros(n, dtype=np.int32),
                   {name: np.full((n, w) if w > 1 else n, np.nan) for name, w in codec.values},
                   0)
    lengths = rec.payload_length
    if n and (lengths == lengths[0]).all():
        by_length = [(int(lengths[0]), np.arange(n))]
    else:
        by_length = [(int(L), np.flatnonzero(lengths == L)) for L in np.unique(lengths)]
    fallback = [_decode_rows(data, rec.payload_start[idx], length, idx, n, codec, cats, piece)
                for length, idx in by_length]
    rest = np.concatenate(fallback) if fallback else np.zeros(0, dtype=np.intp)
    for i in rest:
        start = int(rec.payload_start[i])
        try:
            msg = deserialize(raw[start:start + int(lengths[i])], msgtype)
        except Exception as exc:  # noqa: BLE001 -- rosbags raises SerdeError and others
            raise MessageDecodeError(
                f'{where}: damaged: the {msgtype} message logged at '
                f'{int(rec.log_time[i])} ns cannot be decoded by rosbags either '
                f'({type(exc).__name__}: {" ".join(str(exc).split())}).') from exc
        stamp, frame_id, values = codec.from_message(msg)
        piece.stamp[i] = stamp
        piece.codes[i] = cats.code(frame_id)
        for (name, _), value in zip(codec.values, values, strict=True):
            piece.values[name][i] = value
    piece.fallback = len(rest)
    return piece


def _decode_rows(data: npt.NDArray[np.uint8], starts: npt.NDArray[np.int64], length: int,
                 idx: npt.NDArray[np.intp], n: int, codec: _Codec, cats: _Categories,
                 piece: _Piece) -> npt.NDArray[np.intp]:
    """Decode the payloads of one length.

    Decode the payloads of one length (messages ``idx`` of the ``n`` in ``piece``);
    return the indices left to rosbags (not a fixed layout, or beyond MAX_LAYOUTS).

    Rows are gathered in whole words; a layout is taken from the first row left and
    every row is checked against it: rows with its strings too take its frame_id code,
    rows with other strings are coded by their distinct values.
    """
    rows = sliding_window_view(data, -(-length // 4) * 4)[starts]
    words = rows.view('<u4')
    todo = np.arange(len(idx))
    fallback: list[npt.NDArray[np.intp]] = []
    for _ in range(MAX_LAYOUTS):
        if not len(todo):
            break
        template = rows[todo[0], :length].tobytes()
        try:
            layout = codec.layout(template)
        except _NotNarrow:
            fallback.append(idx[todo[:1]])
            todo = todo[1:]
            continue
        shape, full = _checks(layout, template)
        whole = len(todo) == len(rows)
        sub = words if whole else words[todo]
        same = _match(sub, full)
        code = cats.code_of(template[slice(*layout.strings[0])])
        if code >= 0 and all(_utf8(template[a:b]) for a, b in layout.strings[1:]):
            every = whole and len(idx) == n and bool(same.all())
            _extract(rows if every else rows[todo[same]], layout,
                     slice(None) if every else idx[todo[same]], code, piece)
        else:
            fallback.append(idx[todo[same]])
        done = same
        like = ~same
        if like.any():
            like &= _match(sub, shape)
        if like.any():
            like_rows = rows[todo[like]]
            codes, valid = _strings(like_rows, layout, cats)
            like_idx = idx[todo[like]]
            if valid.any():
                _extract(like_rows[valid], layout, like_idx[valid], codes[valid], piece)
            fallback.append(like_idx[~valid])
            done = same | like
        todo = todo[~done]
    fallback.append(idx[todo])
    return np.concatenate(fallback)


def _strings(rows: npt.NDArray[np.uint8], layout: _Layout, cats: _Categories
             ) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.bool_]]:
    """frame_id code of each row, and whether all its strings are UTF-8 (as rosbags needs)."""
    (start, stop), *others = layout.strings
    local, names = _distinct(rows[:, start:stop])
    codes = np.asarray([cats.code_of(b) for b in names], dtype=np.int32)[local]
    valid = codes >= 0
    for start, stop in others:
        local, names = _distinct(rows[:, start:stop])
        valid &= np.asarray([_utf8(b) for b in names])[local]
    return codes, valid


def _extract(rows: npt.NDArray[np.uint8], layout: _Layout,
             dest: npt.NDArray[np.intp] | slice, codes: npt.NDArray[np.int32] | int,
             piece: _Piece) -> None:
    """Stamp, frame code and float64 fields of rows of one layout.

    Stamp (int32 sec, uint32 nanosec at payload 4 and 8), frame code and float64 fields
    of rows of one layout into ``piece`` at ``dest``.
    """
    sec = rows[:, 4:8].view('<i4')[:, 0].astype(np.int64)
    piece.stamp[dest] = sec * _NS_PER_S + rows[:, 8:12].view('<u4')[:, 0]
    piece.codes[dest] = codes
    for name, at, width in layout.fields:
        if at is not None:
            column = rows[:, at:at + 8 * width].view('<f8')
            piece.values[name][dest] = column[:, 0] if width == 1 else column


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
        batch = ColumnBatch(columns, self.messages, self.last_log, self.fallback)
        self.messages = self.fallback = 0
        return batch


def iter_column_batches(path: str | Path, topic_types: Mapping[str, str], *,
                        batch_messages: int = 50_000, start_ns: int | None = None,
                        stop_ns: int | None = None,
                        decoder: Literal['auto', 'rosbags'] = 'auto'
                        ) -> Iterator[ColumnBatch]:
    """Stream the topics of ``topic_types`` (topic → message type) as NumPy columns.

    A topic recorded with another type is skipped, as rosbags' reader skips it. Batches
    hold whole chunks (or groups of chunks overlapping in log time) and at least
    ``batch_messages`` messages, except the last; memory is bounded by that plus one group
    of chunks. See the module docstring for the order guarantee and the fallbacks.

    Args:
        path: a rosbag2 directory (or its .mcap file), or a .mcap file alone (no
            metadata.yaml beside it: its channels are the topics).
        topic_types: topic → one of :data:`KNOWN_TYPES`.
        batch_messages: messages per batch, at least.
        start_ns: only messages with ``start_ns <= log time`` (rosbags'
            ``Reader.messages(start, stop)``).
        stop_ns: only messages with ``log time < stop_ns``.
        decoder: 'rosbags' reads the whole bag with rosbags (the reference path).

    Raises:
        UnsupportedMessageTypeError: a type outside :data:`KNOWN_TYPES` was asked for.
        BagError (subclass): as :func:`gyro_calib.bagio.bag_info`; DamagedChunkError,
            IndexMismatchError, CountMismatchError, MessageDecodeError (all
            CorruptBagError) for a damaged bag.
    """
    return _iter_batches(Path(path), _check_types(topic_types), batch_messages, start_ns,
                         stop_ns, decoder)


def _iter_batches(path: Path, types: dict[str, str], batch_messages: int,
                  start_ns: int | None, stop_ns: int | None,
                  decoder: Literal['auto', 'rosbags']) -> Iterator[ColumnBatch]:
    reader = _open_reader(path)
    try:
        plan = (ReadPlan(path, None, 'asked for') if decoder == 'rosbags'
                else _plan(path, reader, types))
        if not plan.columnar:
            yield from _iter_rosbags(path, reader, types, batch_messages, start_ns, stop_ns)
            return
    finally:
        reader.close()
    yield from _iter_columnar(plan, types, batch_messages, start_ns, stop_ns)


@dataclass(frozen=True, slots=True)
class _Loaded:
    """A chunk read, decompressed and padded (``data`` is ``raw`` + _PAD zero bytes)."""

    chunk: ChunkPlan
    raw: bytes
    data: npt.NDArray[np.uint8]
    entries: dict[int, npt.NDArray[Any]]


def _load(f: BinaryIO, chunk: ChunkPlan, path: Path,
          decompress: Callable[[bytes | memoryview, int], bytes]) -> _Loaded:
    raw, entries = _read_chunk(f, chunk, path, decompress)
    data = np.empty(len(raw) + _PAD, dtype=np.uint8)
    data[:len(raw)] = np.frombuffer(raw, dtype=np.uint8)
    data[len(raw):] = 0
    return _Loaded(chunk, raw, data, entries)


def _prefetched(plan: ReadPlan, groups: list[list[ChunkPlan]]
                ) -> Generator[list[Future[_Loaded]], None, None]:
    """Each group's chunks, read ahead by one worker thread.

    Each group's chunks, read and decompressed by one worker thread up to PREFETCH
    chunks ahead (file reads and zstd release the GIL: on two cores this overlaps the
    NumPy work). Errors come out where the chunk would have been read.
    """
    assert plan.mcap_path is not None
    decompress = _decompressor()
    pending: deque[Future[_Loaded]] = deque()
    with plan.mcap_path.open('rb') as f, ThreadPoolExecutor(1) as pool:
        chunks = iter([c for g in groups for c in g])
        try:
            for group in groups:
                while len(pending) < len(group) + PREFETCH:
                    chunk = next(chunks, None)
                    if chunk is None:
                        break
                    pending.append(pool.submit(_load, f, chunk, plan.path, decompress))
                yield [pending.popleft() for _ in group]
        finally:
            for future in pending:
                future.cancel()


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
    with contextlib.closing(_prefetched(plan, [g for g in groups if g])) as loaded_groups:
        for group in loaded_groups:
            pieces: dict[str, list[tuple[int, _Piece]]] = {}
            for future in group:
                loaded = future.result()
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
    if batcher.messages:
        yield batcher.cut()
    if window is None and decoded != plan.counts:
        raise CountMismatchError(f'{plan.path}: damaged: decoded {decoded} messages per '
                                 f'channel, the statistics count {plan.counts}.')


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
