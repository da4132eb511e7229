"""Reading what is intact of an MCAP file cut off or damaged (issue 42; docs/recovery.md).

A recording cut off mid-write (power loss, a killed recorder, a full disk) has no summary
and no footer, and its last chunk is incomplete; rosbags' reader refuses it. The file is
then walked record by record from its start (MCAP spec, "Records"): every Chunk record
must lie whole in the file, decompress to its stated size, pass its checksum (a CRC-32, or
the zstd frame's content checksum) and be tiled by Schema, Channel and Message records
whose log times lie in the chunk's range; anything else is damage. After damage the walk
looks for the next chunk that passes all of this (a damaged chunk between intact ones is
skipped); when none follows, the rest of the file is the lost tail. A chunk without any
checksum cannot be told intact from damaged, so it is never used here (the recorder and
:func:`~gyro_calib.bagio.writer.write_bag` give every chunk a zstd checksum).

:func:`survey` gives the intact chunks (read then by the columnar decoder,
:func:`recovered_plan`), the channels, where the readable data ends and what is lost;
:func:`recovered_info` the bag's :class:`~gyro_calib.bagio.records.BagInfo` with its
:class:`~gyro_calib.bagio.records.Damage`.
"""

from __future__ import annotations

import dataclasses
import mmap
import struct
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from gyro_calib.bagio.chunks import Walk, _decompressor, has_checksum, walk_records
from gyro_calib.bagio.errors import CorruptBagError
from gyro_calib.bagio.layouts import CODECS, codec_for
from gyro_calib.bagio.metadata import SCENARIO_KEY, parse_scenario_text
from gyro_calib.bagio.payloads import _deserialize
from gyro_calib.bagio.plan import MAX_CHUNK_BYTES, ChunkPlan, ReadPlan, _overlap_groups
from gyro_calib.bagio.records import BagInfo, Damage, SkippedChunk, TopicInfo
from gyro_calib.bagio.storage import usable_metadata

MAGIC = b'\x89MCAP0\r\n'
"""The MCAP magic at the start (and end) of a file."""

_CHUNK_HEAD = struct.Struct('<BQQQQII')
_MESSAGE_HEAD = 31


@dataclass(frozen=True, slots=True)
class IntactChunk:
    """A chunk that passed every check.

    Attributes:
        plan: the chunk as the columnar decoder reads it (its records walked, no index).
        counts: channel id → messages.
        last: channel id → (log time, CDR payload) of its last message (greatest log time).
        first_ns, last_ns: first and last log time of its messages.
    """

    plan: ChunkPlan
    counts: dict[int, int]
    last: dict[int, tuple[int, bytes]]
    first_ns: int
    last_ns: int


@dataclass(frozen=True, slots=True)
class _Lost:
    offset: int
    end: int
    header_ns: tuple[int, int] | None
    reason: str
    where: str


@dataclass(frozen=True, slots=True)
class Survey:
    """A .mcap file walked record by record.

    Attributes:
        mcap_path: the file.
        size: its bytes.
        schemas: schema id → (name, encoding, data).
        channels: channel id → (topic, schema id, message encoding, metadata).
        chunks: the intact chunks, in file order.
        skipped: damaged chunks between intact ones.
        tail_from, tail_reason, tail_where: the unreadable tail (None: none), why, and
            where it begins (:attr:`~gyro_calib.bagio.records.Damage.tail_where`).
        footer: the walk reached the Footer record.
        custom_data: custom_data of the rosbag2 Metadata record, when it is intact.
    """

    mcap_path: Path
    size: int
    schemas: dict[int, tuple[str, str, bytes]]
    channels: dict[int, tuple[str, int, str, dict[str, str]]]
    chunks: tuple[IntactChunk, ...]
    skipped: tuple[SkippedChunk, ...]
    tail_from: int | None
    tail_reason: str
    tail_where: str
    footer: bool
    custom_data: dict[str, str]

    @property
    def whole(self) -> bool:
        """True when nothing is lost: footer reached, no chunk skipped."""
        return self.footer and self.tail_from is None and not self.skipped

    @property
    def readable_end(self) -> int:
        """The byte where the readable data ends: the end of the last intact chunk."""
        return max((c.plan.offset + c.plan.length for c in self.chunks), default=8)

    def msgtype(self, cid: int) -> str:
        """The message type (schema name) of a channel ('' when its schema is unknown)."""
        schema = self.schemas.get(self.channels[cid][1])
        return schema[0] if schema is not None else ''


def _chunk_at(mm: Any, pos: int, size: int,
              decompress: Callable[[bytes | memoryview, int], bytes]
              ) -> tuple[IntactChunk, Walk] | str:
    """The intact chunk whose record starts at ``pos``, or why it is not one."""
    if pos + _CHUNK_HEAD.size > size:
        return 'the file ends inside a chunk header'
    opcode, length, start, end, usize, crc, n_comp = _CHUNK_HEAD.unpack_from(mm, pos)
    stop = pos + 9 + length
    if opcode != 0x06 or n_comp > 16:
        return 'not a chunk record'
    if stop > size:
        return f'the chunk record of {length} bytes runs past the end of the file'
    body = pos + _CHUNK_HEAD.size + n_comp + 8
    if body > stop:
        return 'its header is malformed'
    try:
        compression = bytes(mm[pos + _CHUNK_HEAD.size:body - 8]).decode()
    except UnicodeDecodeError:
        return 'its compression name is not text'
    (stored,) = struct.unpack_from('<Q', mm, body - 8)
    if body + stored != stop or start > end:
        return 'its header is malformed'
    if compression not in ('', 'zstd'):
        return f'{compression!r} chunk compression is not read record by record'
    if usize > MAX_CHUNK_BYTES:
        return f'it claims {usize} bytes of records'
    data = memoryview(mm)[body:stop]
    try:
        if not has_checksum(crc, compression, data):
            return ('it carries no checksum (CRC-32 0, no zstd checksum), so it cannot be '
                    'told intact from damaged')
        try:
            raw = decompress(data, usize) if compression == 'zstd' else bytes(data)
        except Exception as exc:  # noqa: BLE001 -- zstandard raises ZstdError and others
            return f'it does not decompress ({" ".join(str(exc).split())})'
        if len(raw) != usize:
            return f'{len(raw)} bytes decompressed, {usize} stated'
        import zlib

        if crc and zlib.crc32(raw) != crc:
            return 'its CRC-32 does not match'
    finally:
        data.release()
    walk = walk_records(raw)
    if walk.bad:
        return f'its records do not tile it ({walk.bad})'
    logs = [log for rows in walk.messages.values() for log, _ in rows]
    if logs and (min(logs) < start or max(logs) > end):
        return 'a message log time lies outside its stated range'
    last: dict[int, tuple[int, bytes]] = {}
    for cid, rows in walk.messages.items():
        log, at = max(rows)
        n = int.from_bytes(raw[at + 1:at + 9], 'little')
        last[cid] = (log, raw[at + _MESSAGE_HEAD:at + 9 + n])
    plan = ChunkPlan(pos, stop - pos, start, end, compression, stored, usize, {}, 0,
                     {cid: len(rows) for cid, rows in walk.messages.items()},
                     walked=True, checksummed=True)
    return IntactChunk(plan, dict(plan.counts), last, min(logs, default=start),
                       max(logs, default=end)), walk


def _next_chunk(mm: Any, pos: int, size: int,
                decompress: Callable[[bytes | memoryview, int], bytes]
                ) -> tuple[int, IntactChunk, Walk] | None:
    """The next intact chunk at or after ``pos`` (the walk resynchronised), or None."""
    while True:
        pos = mm.find(b'\x06', pos, size)
        if pos < 0:
            return None
        if pos + _CHUNK_HEAD.size <= size:
            _, length, start, end, _, _, n_comp = _CHUNK_HEAD.unpack_from(mm, pos)
            if n_comp in (0, 4) and start <= end and pos + 9 + length <= size:
                got = _chunk_at(mm, pos, size, decompress)
                if not isinstance(got, str):
                    return pos, *got
        pos += 1


def _metadata_record(record: bytes) -> tuple[str, dict[str, str]] | None:
    """(name, map) of a Metadata record's content, or None when malformed."""
    try:
        (n,) = struct.unpack_from('<I', record, 0)
        name = record[4:4 + n].decode()
        at = 4 + n
        (total,) = struct.unpack_from('<I', record, at)
        at += 4
        stop, out = at + total, {}
        while at < stop:
            (k,) = struct.unpack_from('<I', record, at)
            key = record[at + 4:at + 4 + k].decode()
            at += 4 + k
            (v,) = struct.unpack_from('<I', record, at)
            out[key] = record[at + 4:at + 4 + v].decode()
            at += 4 + v
    except (struct.error, UnicodeDecodeError):
        return None
    return name, out


def _rosbag2_custom_data(text: str) -> dict[str, str]:
    try:
        meta = yaml.safe_load(text)
    except yaml.YAMLError:
        return {}
    info = meta.get('rosbag2_bagfile_information', meta) if isinstance(meta, dict) else None
    custom = info.get('custom_data') if isinstance(info, dict) else None
    return {str(k): str(v) for k, v in custom.items()} if isinstance(custom, dict) else {}


def _walk(mm: Any, path: Path, size: int) -> Survey:  # noqa: C901 -- one record kind per branch
    decompress = _decompressor()
    schemas: dict[int, tuple[str, str, bytes]] = {}
    channels: dict[int, tuple[str, int, str, dict[str, str]]] = {}
    chunks: list[IntactChunk] = []
    lost: list[_Lost] = []
    custom: dict[str, str] = {}
    footer = data_end = False
    pos = 8

    def keep(chunk: IntactChunk, walk: Walk) -> None:
        chunks.append(chunk)
        schemas.update(walk.schemas)
        channels.update(walk.channels)

    while pos < size:
        problem = ''
        opcode = mm[pos]
        if pos + 9 > size:
            problem = 'the file ends inside a record head'
        else:
            end = pos + 9 + int.from_bytes(mm[pos + 1:pos + 9], 'little')
            if opcode == 0x06:
                got = _chunk_at(mm, pos, size, decompress)
                if not isinstance(got, str):
                    keep(*got)
                    pos = end
                    continue
                problem = got
            elif not 0x01 <= opcode <= 0x0F:
                problem = f'no record starts there (opcode {opcode:#04x})'
            elif end > size:
                problem = f'the file ends inside a record of opcode {opcode:#04x}'
            elif opcode == 0x05:
                problem = 'a message record outside any chunk is not read record by record'
            else:
                if opcode in (0x03, 0x04):  # outside chunks: as inside them
                    walk = walk_records(bytes(mm[pos:end]))
                    schemas.update(walk.schemas)
                    channels.update(walk.channels)
                elif opcode == 0x0C:
                    got_meta = _metadata_record(bytes(mm[pos + 9:end]))
                    if got_meta is not None and got_meta[0] == 'rosbag2':
                        custom = _rosbag2_custom_data(
                            got_meta[1].get('serialized_metadata', ''))
                elif opcode == 0x0F:
                    data_end = True
                elif opcode == 0x02:
                    footer = end + len(MAGIC) == size and bytes(mm[end:size]) == MAGIC
                    if not footer:
                        problem = 'the end magic after the footer is missing or damaged'
                if not problem:
                    if opcode == 0x02:
                        break
                    pos = end
                    continue
        header_ns = None
        if opcode == 0x06 and pos + 25 <= size:
            first, last = struct.unpack_from('<QQ', mm, pos + 9)
            header_ns = (int(first), int(last)) if first <= last else None
        nxt = None if data_end else _next_chunk(mm, pos + 1, size, decompress)
        where = ('in its summary section' if data_end else 'inside a chunk'
                 if opcode == 0x06 or not 0x01 <= opcode <= 0x0F else
                 'after its last intact chunk')
        lost.append(_Lost(pos, nxt[0] if nxt else size, header_ns, problem, where))
        if nxt is None:
            break
        keep(nxt[1], nxt[2])
        pos = nxt[0] + nxt[1].plan.length
    return _survey(path, size, schemas, channels, chunks, lost, footer, custom)


def _survey(path: Path, size: int, schemas: dict[int, tuple[str, str, bytes]],
            channels: dict[int, tuple[str, int, str, dict[str, str]]],
            chunks: list[IntactChunk], lost: list[_Lost], footer: bool,
            custom: dict[str, str]) -> Survey:
    """Name each lost span: a skipped chunk between intact ones, or the tail."""
    skipped: list[SkippedChunk] = []
    tail: _Lost | None = None
    for span in lost:
        before = [c for c in chunks if c.plan.offset < span.offset]
        after = [c for c in chunks if c.plan.offset >= span.end]
        if not after:
            tail = span
            continue
        lo = max((c.last_ns for c in before), default=0)
        hi = min(c.first_ns for c in after)
        start, end = (span.header_ns if span.header_ns is not None
                      and lo <= span.header_ns[0] <= span.header_ns[1] <= hi else (lo, hi))
        skipped.append(SkippedChunk(span.offset, span.end, start, end, span.reason))
    return Survey(path, size, schemas, channels, tuple(chunks), tuple(skipped),
                  tail.offset if tail else None, tail.reason if tail else '',
                  tail.where if tail else '', footer, custom)


_CACHE: dict[tuple[str, int, int], Survey] = {}
_CACHED = 8
"""Surveys kept (each small: chunk places and one message per channel)."""


def survey(mcap_path: Path) -> Survey:
    """Walk ``mcap_path`` record by record (the last few cached while unchanged).

    Raises:
        CorruptBagError: the file does not start with the MCAP magic, or cannot be read.
    """
    try:
        stat = mcap_path.stat()
        key = (str(mcap_path.resolve()), stat.st_size, stat.st_mtime_ns)
        if key in _CACHE:
            return _CACHE[key]
        with mcap_path.open('rb') as f:
            if f.read(len(MAGIC)) != MAGIC:
                raise CorruptBagError(f'{mcap_path}: not an MCAP file (no MCAP magic at its '
                                      'start).')
            with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
                got = _walk(mm, mcap_path, stat.st_size)
    except OSError as exc:
        raise CorruptBagError(f'{mcap_path}: cannot be read ({exc.strerror or exc}).') from exc
    while len(_CACHE) >= _CACHED:  # the oldest out: a few bags read together
        del _CACHE[next(iter(_CACHE))]
    _CACHE[key] = got
    return got


def storage_file(path: Path) -> tuple[Path, dict[str, Any] | None]:
    """The one .mcap file of a bag path, and its usable metadata.yaml document (or None).

    Returns (the path itself, None) for a .mcap file without a usable metadata.yaml.

    Raises:
        CorruptBagError: not one .mcap file to read (a directory with none, or several).
    """
    meta_path = (path.parent if path.is_file() else path) / 'metadata.yaml'
    document = (yaml.safe_load(meta_path.read_text(encoding='utf-8'))
                if usable_metadata(meta_path) else None)
    if path.is_file():
        return path, document
    if document is not None:
        info = document['rosbag2_bagfile_information']
        files = [str(f.get('path', '')) for f in info.get('files') or []
                 if isinstance(f, dict)] or [str(f) for f in
                                             info.get('relative_file_paths') or []]
        candidates = [path / f for f in files]
    else:
        candidates = sorted(path.glob('*.mcap'))
    if len(candidates) != 1 or candidates[0].suffix != '.mcap' or not candidates[0].is_file():
        raise CorruptBagError(f'{path}: not one .mcap storage file to read record by record '
                              f'({len(candidates)} found).')
    return candidates[0], document


def recoverable(path: Path, refusal: CorruptBagError) -> Survey:
    """The survey of a bag rosbags refused, when it has intact data to read.

    Raises:
        CorruptBagError: ``refusal`` (with the survey's reason) when nothing can be read:
            no intact chunk, or a whole file (then rosbags' refusal has another cause).
    """
    try:
        got = survey(storage_file(path)[0])
    except CorruptBagError as exc:
        raise CorruptBagError(f'{refusal} Read record by record: {exc}') from refusal
    if got.whole:
        raise refusal
    if not got.chunks or not got.channels:
        why = (got.tail_reason or (got.skipped[0].reason if got.skipped else '')) or 'none'
        raise CorruptBagError(f'{" ".join(str(refusal).split())} Read record by record: no '
                              f'intact chunk (at byte {got.tail_from or 8}: {why}).'
                              ) from refusal
    return got


def _last_stamp(topic: str, msgtype: str, log_ns: int, payload: bytes) -> int:
    """The header stamp of a message (its log time for a type without a decoded header)."""
    if msgtype not in CODECS:
        return log_ns
    try:
        return int(codec_for(topic, msgtype).from_message(_deserialize(payload, msgtype))[0])
    except Exception:  # noqa: BLE001 -- an undecodable last message: its log time
        return log_ns


def recovered_info(path: Path, got: Survey) -> BagInfo:
    """The bag's info from its intact chunks, with what is lost (:class:`Damage`)."""
    _, document = storage_file(path)
    counts: dict[str, TopicInfo] = {}
    last: dict[str, tuple[int, str, bytes]] = {}
    for chunk in got.chunks:
        for cid, n in chunk.counts.items():
            if cid not in got.channels:
                continue
            topic, msgtype = got.channels[cid][0], got.msgtype(cid)
            prior = counts.get(topic)
            counts[topic] = TopicInfo(topic, msgtype, n + (prior.count if prior else 0))
            log, payload = chunk.last[cid]
            if topic not in last or log >= last[topic][0]:
                last[topic] = (log, msgtype, payload)
    for topic, msgtype in {c[0]: got.msgtype(cid) for cid, c in got.channels.items()}.items():
        counts.setdefault(topic, TopicInfo(topic, msgtype, 0))
    info = (document or {}).get('rosbag2_bagfile_information') or {}
    lost: dict[str, int] | None = None
    if document is not None:
        stated = {str(t['topic_metadata']['name']): int(t.get('message_count', 0))
                  for t in info.get('topics_with_message_count') or []
                  if isinstance(t, dict) and isinstance(t.get('topic_metadata'), dict)}
        lost = {t: max(n - (counts[t].count if t in counts else 0), 0)
                for t, n in stated.items()}
    custom = info.get('custom_data') or got.custom_data
    try:
        scenario = parse_scenario_text(custom.get(SCENARIO_KEY, '')) or {}
        benches = {key[len(SCENARIO_KEY) + 1:]: parse_scenario_text(text) or {}
                   for key, text in custom.items() if key.startswith(SCENARIO_KEY + ':')}
    except yaml.YAMLError as exc:
        raise CorruptBagError(f'{path}: the stored scenario is not valid YAML: {exc}') from exc
    total = sum(t.count for t in counts.values())
    start = min((c.first_ns for c in got.chunks if c.counts), default=0)
    end = max((c.last_ns for c in got.chunks if c.counts), default=0)
    reason = got.tail_reason or ('its footer is intact' if got.footer else
                                 'it has no footer')
    damage = Damage(got.mcap_path, got.size, got.readable_end, got.tail_from, reason,
                    got.tail_where, got.skipped,
                    {t: _last_stamp(t, m, log, p) for t, (log, m, p) in last.items()},
                    lost, (start, end))
    return BagInfo(path, counts, start if total else 0, end if total else 0, total, scenario,
                   namespace_scenarios=benches, damage=damage)


def recovered_plan(path: Path, got: Survey, types: dict[str, str]) -> ReadPlan:
    """The columnar decoder's plan over the intact chunks, for the topics of ``types``."""
    channels = {cid: (c[0], got.msgtype(cid)) for cid, c in got.channels.items()
                if types.get(c[0]) == got.msgtype(cid) and c[2] == 'cdr'}
    selected = [c.plan for c in got.chunks if any(c.counts.get(cid) for cid in channels)]
    counts = {cid: sum(c.counts.get(cid, 0) for c in got.chunks) for cid in channels}
    return ReadPlan(path, got.mcap_path, '', channels, _overlap_groups(selected), counts)


def checksummed_plan(plan: ReadPlan) -> ReadPlan:
    """The plan with every chunk marked ``checksummed`` when the file's first chunk is.

    A file whose chunks carry checksums (its first chunk read shows it) has each damaged
    chunk skipped by the columnar decoder, with a line; a chunk there without a checksum is
    taken for damaged. Other files are read as before (a damaged chunk raises).
    """
    first = next((c for g in plan.groups for c in g), None)
    if first is None or plan.mcap_path is None:
        return plan
    try:
        with plan.mcap_path.open('rb') as f:
            f.seek(first.offset)
            head = f.read(_CHUNK_HEAD.size + len(first.compression) + 8 + 5)
        crc = _CHUNK_HEAD.unpack_from(head)[5]
    except (OSError, struct.error):
        return plan
    if not has_checksum(crc, first.compression, head[-5:]):
        return plan
    groups = tuple(tuple(dataclasses.replace(c, checksummed=True) for c in g)
                   for g in plan.groups)
    return dataclasses.replace(plan, groups=groups)


def intact_messages(got: Survey) -> Iterator[tuple[int, int, bytes]]:
    """(channel id, log time ns, CDR bytes) of every intact message, in log-time order.

    In rosbags' order (log time, then chunk, then record), chunk by chunk within groups
    of chunks overlapping in log time; for :mod:`~gyro_calib.bagio.repair`.
    """
    decompress = _decompressor()
    with got.mcap_path.open('rb') as f:
        for group in _overlap_groups([c.plan for c in got.chunks]):
            rows: list[tuple[int, int, int, int, bytes]] = []
            for plan in group:
                f.seek(plan.offset)
                span = f.read(plan.length)
                body = _CHUNK_HEAD.size + len(plan.compression) + 8
                data = span[body:]
                raw = (decompress(data, plan.uncompressed_size) if plan.compression == 'zstd'
                       else data)
                for cid, entries in walk_records(raw).messages.items():
                    for log, at in entries:
                        n = int.from_bytes(raw[at + 1:at + 9], 'little')
                        rows.append((log, plan.offset, at, cid,
                                     raw[at + _MESSAGE_HEAD:at + 9 + n]))
            rows.sort(key=lambda r: r[:3])
            for log, _, _, cid, payload in rows:
                yield cid, log, payload
