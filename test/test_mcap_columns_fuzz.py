"""Fuzz: damaged bags decode to rosbags' result bit for bit, or to a named error.

The file fuzzed is a truncated copy of the committed ``theta_four_position`` bag's .mcap
(its first 6 s: pulses, both tables' joint states, rate-table zero-index events; ~2100
messages), rewritten in 8 KiB chunks by the mcap library and read as a lone .mcap file.
Bytes of the file are flipped (anywhere, or inside a Message record's head and CDR
payload), swapped (reordered), deleted or duplicated, or the file is cut short. Whatever
is done, ``iter_column_batches`` either raises a ``BagError``, or returns exactly the
columns rosbags' reader + ``deserialize_cdr`` give for the same file (which must then
have read it without error), or — the damage said (a chunk skipped, the file read record
by record: docs/recovery.md) — only messages of the undamaged file, bit for bit: never
other numbers.

The uncompressed copy carries no chunk CRC, so damage reaches the record and CDR checks
(and it is never read record by record: an unchecked chunk cannot be told intact); the zstd
copy's frames carry the zstd content checksum, so its damaged chunks are skipped. Where
random damage is sparse, one message of each layout has every byte flipped in turn.
"""

from __future__ import annotations

import struct
import tempfile
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from test_mcap_columns import BAGS, assert_bit_identical, columnar_columns, rosbags_columns

from gyro_calib.bagio import CONTRACT_TYPES, BagError

PREFIX_NS = 6_000_000_000
"""Messages the fuzzed copy keeps from the committed bag: log time below this."""

TINY_NS = 330_000_000
"""Messages the tiny copy keeps (one chunk, the first rate-table zero-index event in it)."""


def truncated_copy(out: Path, *, ending_before_ns: int, compression: str = 'NONE',
                   chunk_size: int = 8192) -> tuple[Path, bytes, list[int]]:
    """The theta_four_position bag cut and rewritten in chunks.

    The committed ``theta_four_position`` bag's .mcap cut to its messages logged before
    ``ending_before_ns``, written by the mcap library in chunks of ``chunk_size`` bytes
    without CRCs, as a lone .mcap file (no metadata.yaml to parse: both readers open it in
    milliseconds); returns its path, bytes and the file offset of every Message record
    (uncompressed chunks only).
    """
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    with (BAGS / 'theta_four_position' / 'theta_four_position.mcap').open('rb') as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        kept = [(c.id, m) for _, c, m in reader.iter_messages(ending_before=ending_before_ns)]
    mcap = out / 'copy.mcap'
    with mcap.open('wb') as f:
        w = Writer(f, chunk_size=chunk_size, compression=CompressionType[compression],
                   enable_crcs=False)
        w.start(profile='ros2', library='test')
        schemas = {k: w.register_schema(s.name, s.encoding, s.data)
                   for k, s in sorted(summary.schemas.items())}
        channels = {k: w.register_channel(c.topic, c.message_encoding, schemas[c.schema_id],
                                          c.metadata)
                    for k, c in sorted(summary.channels.items())}
        for cid, m in kept:
            w.add_message(channels[cid], m.log_time, m.data, m.publish_time, m.sequence)
        w.finish()
    data = mcap.read_bytes()
    return mcap, data, message_record_offsets(data) if compression == 'NONE' else []


def message_record_offsets(data: bytes) -> list[int]:
    """File offsets of the Message records inside uncompressed Chunk records."""
    offsets, pos = [], 8
    while pos + 9 <= len(data):
        opcode, length = struct.unpack_from('<BQ', data, pos)
        if opcode == 0x06:
            (n_comp,) = struct.unpack_from('<I', data, pos + 9 + 28)
            start = pos + 9 + 32 + n_comp + 8
            inner = start
            while inner < pos + 9 + length:
                op, ln = struct.unpack_from('<BQ', data, inner)
                if op == 0x05:
                    offsets.append(inner)
                inner += 9 + ln
        elif opcode == 0x0F:
            break
        pos += 9 + length
    return offsets


@pytest.fixture(scope='module')
def base(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], tuple[Path, bytes,
                                                                            list[int]]]:
    built: dict[str, tuple[Path, bytes, list[int]]] = {}

    def make(compression: str) -> tuple[Path, bytes, list[int]]:
        if compression not in built:
            built[compression] = truncated_copy(
                tmp_path_factory.mktemp(f'fuzz_{compression.lower()}'),
                ending_before_ns=PREFIX_NS, compression=compression)
        return built[compression]
    return make


# -- mutations -------------------------------------------------------------------------------
FRACTION = st.integers(0, 2**20 - 1).map(lambda k: k / 2**20)
BYTE = st.integers(1, 255)
IN_RECORD = st.integers(0, 95)
"""A byte of a Message record: its 31-byte head, then the CDR payload."""
MUTATION = st.one_of(
    st.tuples(st.just('flip'), FRACTION, BYTE),
    st.tuples(st.just('flip in a message'), FRACTION, IN_RECORD, BYTE),
    st.tuples(st.just('flip in a message'), FRACTION, IN_RECORD, BYTE),
    st.tuples(st.just('swap in a message'), FRACTION, IN_RECORD, IN_RECORD),
    st.tuples(st.just('swap'), FRACTION, FRACTION, st.integers(1, 48)),
    st.tuples(st.just('truncate'), FRACTION),
    st.tuples(st.just('delete'), FRACTION, st.integers(1, 48)),
    st.tuples(st.just('duplicate'), FRACTION, st.integers(1, 48)),
)
"""Byte damage: flips anywhere or inside a Message record (twice as likely: they reach the
layout checks), byte swaps inside a record or blocks swapped anywhere (reordering), the
file cut short, blocks deleted or duplicated (shifting everything after them)."""


def mutate(data: bytes, messages: list[int], mutations: list[tuple[Any, ...]]) -> bytes:
    out = bytearray(data)
    for kind, *args in mutations:
        if not out:
            break
        if kind == 'flip at':
            out[args[0]] ^= args[1]
            continue
        at = int(args[0] * len(out))
        if kind == 'flip':
            out[at] ^= args[1]
        elif kind == 'flip in a message':
            at = messages[int(args[0] * len(messages))] + args[1] if messages else at
            if at < len(out):
                out[at] ^= args[2]
        elif kind == 'swap in a message':
            record = messages[int(args[0] * len(messages))] if messages else at
            a, b = record + args[1], record + args[2]
            if max(a, b) < len(out):
                out[a], out[b] = out[b], out[a]
        elif kind == 'truncate':
            del out[at:]
        elif kind == 'swap':
            n = args[2]
            other = int(args[1] * len(out))
            a, b = sorted((at, other))
            if a + n <= b and b + n <= len(out):
                out[a:a + n], out[b:b + n] = out[b:b + n], out[a:a + n]
        elif kind == 'delete':
            del out[at:at + args[1]]
        else:
            out[at:at] = out[at:at + args[1]]
    return bytes(out)


def check_mutant(bag: Path, data: bytes, messages: list[int],
                 mutations: list[tuple[Any, ...]],
                 note: Callable[[str], object] = event) -> None:
    """The mutant decodes as rosbags does, or raises a BagError.

    The mutant's columns are rosbags' columns, or it raises a BagError; ``note`` hears
    which.
    """
    mutant = mutate(data, messages, mutations)
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / 'mutant.mcap'
        copy.write_bytes(mutant)
        try:
            got, _ = columnar_columns(copy, CONTRACT_TYPES)
        except BagError as exc:
            note(f'named error: {type(exc).__name__}')
            return
        if said_damaged(copy):
            note('damage said: only messages of the undamaged file')
            assert_rows_of(got, bag)
            return
        try:
            want = rosbags_columns(copy, CONTRACT_TYPES)
        except Exception as exc:  # noqa: BLE001 -- rosbags fails in many ways on damage
            pytest.fail(f'rosbags fails ({type(exc).__name__}: {exc}) where the columnar '
                        f'decoder returned columns, after {mutations}')
        note('columns equal to rosbags\'')
        assert_bit_identical(got, want)


def said_damaged(mutant: Path) -> bool:
    """True when reading ``mutant`` says it is damaged.

    A chunk skipped, or the file read record by record (docs/recovery.md).
    """
    from gyro_calib.bagio import bag_info
    from gyro_calib.bagio.columns import iter_column_batches

    return bag_info(mutant).damage is not None or any(
        b.notes for b in iter_column_batches(mutant, CONTRACT_TYPES))


def _rows(columns: dict[str, dict[str, Any]]) -> Counter[tuple[Any, ...]]:
    """Every message as a hashable row (topic, log, stamp, frame, value bits...)."""
    import numpy as np

    rows: Counter[tuple[Any, ...]] = Counter()
    for topic, cols in columns.items():
        names = sorted(n for n in cols if n not in ('log', 'stamp', 'frame'))
        bits = [np.ascontiguousarray(cols[n]).view(np.uint64).reshape(len(cols['log']), -1)
                for n in names]
        for i in range(len(cols['log'])):
            rows[(topic, int(cols['log'][i]), int(cols['stamp'][i]), cols['frame'][i],
                  *(tuple(int(x) for x in b[i]) for b in bits))] += 1
    return rows


def assert_rows_of(got: dict[str, dict[str, Any]], original: Path) -> None:
    """Every message of ``got`` is one of the undamaged file's, bit for bit."""
    extra = _rows(got) - _rows(rosbags_columns(original, CONTRACT_TYPES))
    assert not extra, f'{sum(extra.values())} messages not in the undamaged file'


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutations=st.lists(MUTATION, min_size=1, max_size=3))
def test_damaged_uncompressed_bag_gives_rosbags_columns_or_a_named_error(
        base: Callable[[str], tuple[Path, bytes, list[int]]],
        mutations: list[tuple[Any, ...]]) -> None:
    check_mutant(*base('NONE'), mutations)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutations=st.lists(MUTATION, min_size=1, max_size=2))
def test_damaged_zstd_bag_gives_rosbags_columns_or_a_named_error(
        base: Callable[[str], tuple[Path, bytes, list[int]]],
        mutations: list[tuple[Any, ...]]) -> None:
    check_mutant(*base('ZSTD'), mutations)


def test_the_undamaged_copies_decode_to_rosbags_columns(
        base: Callable[[str], tuple[Path, bytes, list[int]]]) -> None:
    for compression in ('NONE', 'ZSTD'):
        bag, _, _ = base(compression)
        got, fallback = columnar_columns(bag, CONTRACT_TYPES)
        assert fallback == 0 and sum(len(c['log']) for c in got.values()) > 2000
        assert_bit_identical(got, rosbags_columns(bag, CONTRACT_TYPES))
    assert len(base('NONE')[2]) == sum(len(c['log']) for c in got.values())


@pytest.mark.parametrize('topic', ['/gyro/pulses', '/rate_table/joint_states',
                                   '/position_table/joint_states', '/rate_table/zero_index'])
def test_every_byte_of_a_message_flipped_gives_rosbags_columns_or_a_named_error(
        tmp_path: Path, topic: str) -> None:
    """Each byte of one Message record of each layout, mutated.

    Exhaustive where the fuzz is sparse: each byte of one Message record of each layout
    (head and CDR payload; a record that does not fix its chunk's layout), flipped in its
    lowest bit and in all bits, in a one-chunk copy.
    """
    from mcap.reader import make_reader

    bag, data, offsets = truncated_copy(tmp_path, ending_before_ns=TINY_NS, chunk_size=1 << 20)
    with bag.open('rb') as f:
        topics = [c.topic for _, c, _ in make_reader(f).iter_messages(log_time_order=False)]
    records = [at for at, t in zip(offsets, topics, strict=True) if t == topic]
    record = records[min(2, len(records) - 1)]
    (length,) = struct.unpack_from('<Q', data, record + 1)
    outcomes: Counter[str] = Counter()
    for at in range(9 + length):
        for mask in (0x01, 0xFF):
            check_mutant(bag, data, offsets, [('flip at', record + at, mask)],
                         lambda what: outcomes.update([what]))
    assert outcomes['columns equal to rosbags\''] and outcomes['named error: IndexMismatchError']
