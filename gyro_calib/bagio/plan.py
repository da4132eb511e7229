"""Step 1 of the columnar decoder: plan a read from the MCAP summary (which chunks, in order).

The Footer points at the Summary section; its Chunk Index records (op 0x08) give each
Chunk's file offset and length, message time range, compression, sizes, and the file
offset of the Message Index record (op 0x07) of every channel in it. The per-channel
message counts these imply (each Message Index record is 15 + 16·n bytes) must equal the
Statistics record (op 0x0B), else :class:`~gyro_calib.bagio.errors.CountMismatchError`.
Files the columnar decoder does not read itself go to rosbags whole (``ReadPlan.reason``
says why): no summary, chunk index or statistics (unchunked or unindexed files), chunk
compression other than zstd or none (lz4), per-message or per-file rosbag2 compression,
several storage files, a channel whose encoding is not CDR, chunks overlapping in log time
beyond :data:`MAX_GROUP_CHUNKS`. Chunks without Message Index records raise
:class:`~gyro_calib.bagio.errors.UnindexedChunksError` instead: rosbags' reader returns
no message from them (rosbags 0.11.9), which would be a silent loss.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gyro_calib.bagio import storage
from gyro_calib.bagio.errors import (
    CorruptBagError,
    CountMismatchError,
    IndexMismatchError,
    UnindexedChunksError,
    UnsupportedMessageTypeError,
)
from gyro_calib.bagio.layouts import CODECS
from gyro_calib.errors import GyroCalibError

MAX_GROUP_CHUNKS = 64
"""Chunks overlapping in log time are decoded together; more than this → rosbags whole."""

MAX_CHUNK_BYTES = 1 << 30
"""A chunk claiming more uncompressed bytes than this is read by rosbags whole."""


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
        walked: no Message Index records are read: the entries come from walking the
            chunk's records (a chunk found by :mod:`~gyro_calib.bagio.recovery`).
        checksummed: the chunk must carry a CRC-32 or a zstd content checksum (a file
            whose chunks carry them: one without is taken for damaged).
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
    walked: bool = False
    checksummed: bool = False


@dataclass(frozen=True, slots=True)
class ReadPlan:
    """How :func:`~gyro_calib.bagio.columns.iter_column_batches` reads a bag.

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
        lone = storage.lone_mcap_in(path) or path
        if lone.suffix == '.mcap' and lone.is_file() and not storage.usable_metadata(
                lone.parent / 'metadata.yaml'):
            from rosbags.rosbag2 import Reader

            reader = Reader(lone)
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
    """The read plan for ``topic_types`` (topic → type).

    The plan :func:`~gyro_calib.bagio.columns.iter_column_batches` follows, for inspection.

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
