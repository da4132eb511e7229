"""Step 2 of the columnar decoder: read the planned chunks, ahead, and check their records.

Chunks are read in log-time order. The Chunk record (op 0x06) header must agree with its
index; its records are decompressed with ``zstandard`` (the frame's content checksum is
verified when present; the chunk's CRC-32 too when non-zero), a damaged chunk raises
:class:`~gyro_calib.bagio.errors.DamagedChunkError`. The Message Index records behind the
chunk give every message's (log_time, offset) per channel as one NumPy array. All Message
record headers (op 0x05: channel_id u16, sequence u32, log_time u64, publish_time u64,
data) are gathered at once and must match their index entries (opcode, channel, log time,
length); the records must tile the chunk, and the few gaps (Schema and Channel records)
are walked and must hold no Message record, else
:class:`~gyro_calib.bagio.errors.IndexMismatchError`.

One worker thread reads and decompresses up to :data:`PREFETCH` chunks ahead of the one
being decoded (:func:`_prefetched`).
"""

from __future__ import annotations

import struct
import zlib
from collections import deque
from collections.abc import Callable, Generator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from gyro_calib.bagio.errors import DamagedChunkError, IndexMismatchError
from gyro_calib.bagio.plan import ChunkPlan, ReadPlan

if TYPE_CHECKING:
    from typing import BinaryIO

    import numpy.typing as npt

PREFETCH = 2
"""Chunks a worker thread reads and decompresses ahead of the one being decoded."""

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
# One chunk


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
    if chunk.checksummed and not has_checksum(crc, chunk.compression, data):
        raise DamagedChunkError(f'{where}: it carries no checksum, unlike the file\'s other '
                                'chunks.')
    if chunk.walked:
        return raw, walked_index(raw, chunk, path)
    return raw, _message_index(span, chunk, path)


def has_checksum(crc: int, compression: str, data: bytes | memoryview) -> bool:
    """True when a chunk's records are checked: a CRC-32, or a zstd frame content checksum.

    ``data`` is the chunk's compressed records; a zstd frame's descriptor (the byte after
    its magic) has bit 2 set when the frame ends with a checksum (RFC 8878 §3.1.1.1.1).
    """
    if crc:
        return True
    return (compression == 'zstd' and len(data) > 4
            and bytes(data[:4]) == b'\x28\xb5\x2f\xfd' and bool(data[4] & 0x04))


@dataclass(frozen=True, slots=True)
class Walk:
    """The records of a decompressed chunk, walked one by one (MCAP spec, "Chunk").

    Attributes:
        messages: channel id → (log time ns, record offset) of its Message records.
        schemas: Schema records (id → name, encoding, data).
        channels: Channel records (id → topic, schema id, message encoding, metadata).
        bad: why the records do not tile the chunk ('' when they do).
    """

    messages: dict[int, list[tuple[int, int]]]
    schemas: dict[int, tuple[str, str, bytes]]
    channels: dict[int, tuple[str, int, str, dict[str, str]]]
    bad: str


_RECORD_HEAD = struct.Struct('<BQ')
"""A record's opcode and length."""

_MESSAGE_IDS = struct.Struct('<HIQ')
"""A Message record's channel id, sequence and log time."""


def _text(raw: bytes, pos: int) -> tuple[str, int]:
    (n,) = struct.unpack_from('<I', raw, pos)
    return raw[pos + 4:pos + 4 + n].decode(), pos + 4 + n


def walk_records(raw: bytes) -> Walk:
    """Walk the Schema, Channel and Message records of a decompressed chunk.

    Every record must lie whole inside the chunk and be one of those three (MCAP spec);
    otherwise ``bad`` says where it stops.
    """
    messages: dict[int, list[tuple[int, int]]] = {}
    schemas: dict[int, tuple[str, str, bytes]] = {}
    channels: dict[int, tuple[str, int, str, dict[str, str]]] = {}
    pos, size = 0, len(raw)
    head, message = _RECORD_HEAD.unpack_from, _MESSAGE_IDS.unpack_from  # the hot loop
    try:
        while pos < size:
            if pos + 9 > size:
                return Walk(messages, schemas, channels, f'a record head at offset {pos} is cut')
            opcode, length = head(raw, pos)
            end = pos + 9 + length
            if end > size:
                return Walk(messages, schemas, channels,
                            f'the record at offset {pos} runs past the chunk')
            if opcode == 0x05:
                if end - pos < _MESSAGE_HEAD:
                    return Walk(messages, schemas, channels,
                                f'the message record at offset {pos} is too short')
                cid, _, log = message(raw, pos + 9)
                rows = messages.get(cid)
                if rows is None:
                    rows = messages[cid] = []
                rows.append((log, pos))
            elif opcode == 0x03:
                (sid,) = struct.unpack_from('<H', raw, pos + 9)
                name, at = _text(raw, pos + 11)
                encoding, at = _text(raw, at)
                (n,) = struct.unpack_from('<I', raw, at)
                if at + 4 + n != end:
                    return Walk(messages, schemas, channels,
                                f'the schema record at offset {pos} is malformed')
                schemas[sid] = (name, encoding, bytes(raw[at + 4:at + 4 + n]))
            elif opcode == 0x04:
                cid, sid = struct.unpack_from('<HH', raw, pos + 9)
                topic, at = _text(raw, pos + 13)
                encoding, at = _text(raw, at)
                (n,) = struct.unpack_from('<I', raw, at)
                at += 4
                stop, meta = at + n, {}
                while at < stop:
                    key, at = _text(raw, at)
                    meta[key], at = _text(raw, at)
                if at != end:
                    return Walk(messages, schemas, channels,
                                f'the channel record at offset {pos} is malformed')
                channels[cid] = (topic, sid, encoding, meta)
            else:
                return Walk(messages, schemas, channels,
                            f'a record of opcode {opcode:#04x} at offset {pos} cannot be in a '
                            'chunk')
            pos = end
    except (struct.error, UnicodeDecodeError):
        return Walk(messages, schemas, channels, f'the record at offset {pos} is malformed')
    return Walk(messages, schemas, channels, '')


def walked_index(raw: bytes, chunk: ChunkPlan, path: Path) -> dict[int, npt.NDArray[Any]]:
    """Entries (log_time, offset) per channel from walking the chunk's records.

    Entries (log_time, offset) per channel, as its Message Index records would give them,
    from walking the chunk's records (a chunk without a usable index).

    Raises:
        DamagedChunkError: the records do not tile the chunk.
    """
    walk = walk_records(raw)
    if walk.bad:
        raise DamagedChunkError(f'{path}: damaged chunk at byte {chunk.offset}: {walk.bad}.')
    return {cid: np.array(rows, dtype=_INDEX_ENTRY) for cid, rows in walk.messages.items()}


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
# Reading ahead


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
