"""A recording cut off or damaged is calibrated from exactly its intact messages (issue 42).

The specification (docs/recovery.md): a committed bag whose .mcap is cut at any byte after
its first chunk, or has any one chunk damaged, calibrates to exactly what calibrating its
intact messages gives — those an independent reader yields: the ``mcap`` library's
StreamReader on the cut file (it stops at the first incomplete record), or every chunk of
the undamaged file but the damaged one (the ``mcap`` library's chunk records) — never a
traceback, never a number from a damaged chunk; the calibration says in a line where the
readable data ends; ``--strict`` refuses; ``repair`` writes a whole bag that the ``mcap``
library's full reader and rosbags read.
"""

from __future__ import annotations

import json
import os
import shutil
import struct
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.bag_calibration import calibrate_bags, json_document
from gyro_calib.bagio import (
    BagError,
    BagMessage,
    CorruptBagError,
    bag_info,
    iter_sample_batches,
    repair_bag,
    write_bag,
)
from gyro_calib.cli import main

BAGS = Path(__file__).resolve().parent.parent / 'bags'
SMALL = sorted(p.parent.name for p in BAGS.glob('*/*.mcap')
               if os.environ.get('RECOVERY_ALL_BAGS') or p.stat().st_size < 1_300_000)
"""The committed bags the property draws from: in CI the smaller ones (each example
calibrates two bags, and the test must stay short; k_tilde_bench has its own tests below);
``RECOVERY_ALL_BAGS=1 RECOVERY_EXAMPLES=200`` draws from every committed bag."""


def _mcap(bag: Path) -> Path:
    return next(bag.glob('*.mcap'))


def _copy(name: str, where: Path) -> Path:
    bag = where / name
    shutil.copytree(BAGS / name, bag)
    return bag


def _chunks(mcap: Path) -> list[tuple[int, int]]:
    """(offset, length) of every Chunk record, from the file's summary (mcap library)."""
    from mcap.reader import make_reader

    with mcap.open('rb') as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return sorted((c.chunk_start_offset, c.chunk_length) for c in summary.chunk_indexes)


REPAIRED = 'fog_slow_loop_low_rate'
"""The bag the repair test cuts (a small one: the test reads it five ways)."""

Row = tuple[str, int, bytes]


def _stream_read(mcap: Path) -> list[Row]:
    """(topic, log time, CDR) of every message the mcap StreamReader yields before it stops."""
    from mcap.records import Channel, Message
    from mcap.stream_reader import StreamReader

    channels: dict[int, str] = {}
    rows: list[Row] = []
    with mcap.open('rb') as f:
        try:
            for record in StreamReader(f, validate_crcs=True).records:
                if isinstance(record, Channel):
                    channels[record.id] = record.topic
                elif isinstance(record, Message):
                    rows.append((channels[record.channel_id], record.log_time, record.data))
        except Exception:  # noqa: BLE001, S110 -- where it stops is the point of the test
            pass
    return rows


def _all_but_chunk(mcap: Path, skipped: int) -> list[Row]:
    """Messages of every chunk of the (undamaged) file but the one at byte ``skipped``."""
    from mcap.records import Channel, Chunk, Message
    from mcap.stream_reader import StreamReader, breakup_chunk

    with mcap.open('rb') as f:  # the skipped chunk, known by its header's fields
        f.seek(skipped + 9)
        key = struct.unpack('<QQQ', f.read(24))
    channels: dict[int, str] = {}
    rows: list[Row] = []
    with mcap.open('rb') as f:
        for record in StreamReader(f, emit_chunks=True).records:
            if not isinstance(record, Chunk):
                continue
            inner = breakup_chunk(record)
            channels.update((r.id, r.topic) for r in inner if isinstance(r, Channel))
            if (record.message_start_time, record.message_end_time,
                    record.uncompressed_size) != key:
                rows += [(channels[r.channel_id], r.log_time, r.data)
                         for r in inner if isinstance(r, Message)]
    return rows


def _reference(original: Path, rows: list[Row], where: Path) -> Path:
    """A fresh bag holding exactly ``rows``, with the original's types and scenario."""
    info = bag_info(original)
    out = where / 'reference'
    rows = sorted(rows, key=lambda r: r[1])  # stable: rosbags' order for a topic
    write_bag(out, (BagMessage(t, log, data) for t, log, data in rows),
              types={t.name: t.msgtype for t in info.topics.values()},
              scenario=info.scenario or None,
              namespace_scenarios=info.namespace_scenarios or None)
    return out


def _outcome(bag: Path) -> Any:
    """The calibration's JSON results, or the error class it raised (never a traceback)."""
    try:
        # a method that runs only when asked (an IMU's multiposition bag) is asked for by name
        methods = ['multiposition'] if bag_info(bag).topics.keys() == {'/imu/data'} else None
        outcome = calibrate_bags([bag], methods=methods)
    except BagError as exc:
        return type(exc).__name__
    document = json_document(outcome)
    del document['bags']
    return json.loads(json.dumps(document, default=str).replace(str(bag), 'BAG'))


def _check(original: Path, damaged: Path, rows: list[Row], where: Path) -> None:
    reference = _reference(original, rows, where)
    assert _outcome(damaged) == _outcome(reference)
    if rows:
        read = sum(b.messages for b in iter_sample_batches(
            damaged, {t.name: t.msgtype for t in bag_info(original).topics.values()}))
        assert read == len(rows)


@settings(max_examples=int(os.environ.get('RECOVERY_EXAMPLES', '4')), deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(SMALL), damage=st.sampled_from(['cut', 'chunk']),
       where=st.floats(0.0, 1.0), garbage=st.binary(min_size=1, max_size=16))
def test_a_cut_or_damaged_bag_calibrates_to_exactly_its_intact_messages(
        tmp_path_factory: pytest.TempPathFactory, name: str, damage: str, where: float,
        garbage: bytes) -> None:
    tmp = tmp_path_factory.mktemp('recovery')
    original = BAGS / name
    bag = _copy(name, tmp)
    mcap = _mcap(bag)
    data = bytearray(mcap.read_bytes())
    chunks = _chunks(mcap)
    if damage == 'cut':
        first_end = chunks[0][0] + chunks[0][1]
        cut = first_end + int(where * (len(data) - first_end - 1))
        mcap.write_bytes(bytes(data[:cut]))
        rows = _stream_read(mcap)
    else:
        offset, length = chunks[min(int(where * len(chunks)), len(chunks) - 1)]
        at = offset + int(where * (length - len(garbage)))
        if bytes(data[at:at + len(garbage)]) == garbage:
            garbage = bytes(b ^ 0xFF for b in garbage)
        data[at:at + len(garbage)] = garbage
        mcap.write_bytes(bytes(data))
        rows = _all_but_chunk(_mcap(original), offset)
    _check(original, bag, rows, tmp)


def test_k_tilde_bench_cut_at_80_percent_calibrates_from_the_part_before(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _copy('k_tilde_bench', tmp_path)
    mcap = _mcap(bag)
    data = mcap.read_bytes()
    mcap.write_bytes(data[:len(data) * 8 // 10])

    assert main(['calibrate', str(bag)]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if 'cut off' in ln)
    info = bag_info(bag)
    assert info.damage is not None
    assert f'readable data ends at byte {info.damage.readable_end} of {len(data) * 8 // 10}' \
        in line
    assert 'last stamps: /gyro/pulses t=83.345000 s' in line
    assert '19994 messages' in line and 'the results rest on the part before it' in line
    assert 'K̃ windows accepted: 5, pairs: 2' in out
    _check(BAGS / 'k_tilde_bench', bag, _stream_read(mcap), tmp_path)

    assert main(['info', str(bag)]) == 0
    assert line in capsys.readouterr().out

    assert main(['calibrate', str(bag), '--strict', '--out', str(tmp_path / 'h.yaml')]) == 2
    got = capsys.readouterr()
    assert got.out == '' and len(got.err.splitlines()) == 1
    assert got.err.startswith(f'gyro-calib: error: --strict refuses {bag}: the recording')
    assert not (tmp_path / 'h.yaml').exists()


def test_a_damaged_middle_chunk_is_skipped_naming_its_stamps_and_never_bridged(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _copy('k_tilde_bench', tmp_path)
    mcap = _mcap(bag)
    offset, length = _chunks(mcap)[5]
    data = bytearray(mcap.read_bytes())
    data[offset + length // 2:offset + length // 2 + 16] = bytes(16)
    mcap.write_bytes(bytes(data))

    assert main(['calibrate', str(bag)]) == 0
    out = capsys.readouterr().out
    assert (f'a damaged chunk at bytes {offset}–{offset + length} (t=46.300000 s → '
            't=55.560000 s, log times) was skipped') in out
    assert 'rejected at t=56.078333 s' in out  # the window across the gap: rejected
    rows = _all_but_chunk(_mcap(BAGS / 'k_tilde_bench'), offset)
    _check(BAGS / 'k_tilde_bench', bag, rows, tmp_path)
    assert main(['info', str(bag)]) == 0  # says the same, and counts what was read
    said = capsys.readouterr().out
    assert f'a damaged chunk at bytes {offset}–{offset + length}' in said
    assert f'messages: {len(rows)}' in said
    assert main(['calibrate', str(bag), '--strict']) == 2
    got = capsys.readouterr()
    assert got.out == '' and len(got.err.splitlines()) == 1 and 'damaged' in got.err


def test_repair_writes_a_whole_bag_that_the_mcap_library_and_rosbags_read(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from mcap.reader import make_reader
    from rosbags.rosbag2 import Reader

    bag = _copy(REPAIRED, tmp_path)
    mcap = _mcap(bag)
    data = mcap.read_bytes()
    mcap.write_bytes(data[:len(data) * 8 // 10])
    kept = repair_bag(bag, tmp_path / 'with_metadata')  # the scenario of metadata.yaml kept
    assert kept.damage is not None and kept.damage.lost_messages is not None
    assert bag_info(tmp_path / 'with_metadata').scenario == bag_info(BAGS / REPAIRED).scenario
    (bag / 'metadata.yaml').unlink()  # as a killed recorder leaves it: the .mcap alone
    rows = _stream_read(mcap)
    out = tmp_path / 'fixed'

    assert main(['repair', str(bag), '--out', str(out)]) == 0
    said = capsys.readouterr().out
    assert f'repaired bag written: {out} ({len(rows)} messages' in said
    assert 'an unknown number of messages (no metadata.yaml counts them)' in said

    with _mcap(out).open('rb') as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes and summary.statistics
        got = [(c.topic, m.log_time, m.data) for _, c, m in reader.iter_messages()]
    assert got == sorted(rows, key=lambda r: r[1])
    with Reader(out) as r:
        assert [(c.topic, t, bytes(d)) for c, t, d in r.messages()] == got
    assert bag_info(out).damage is None
    assert bag_info(out).scenario == bag_info(bag).scenario == {}  # it was in metadata.yaml
    assert _outcome(out) == _outcome(bag)

    assert main(['repair', str(bag), '--out', str(out)]) == 2  # exists: refused, untouched
    got_err = capsys.readouterr()
    assert got_err.out == '' and len(got_err.err.splitlines()) == 1


@pytest.mark.parametrize('what', ['not a bag', 'an empty .mcap', 'no intact chunk'])
def test_repair_of_what_is_really_unreadable_is_one_line_and_writes_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], what: str) -> None:
    src = tmp_path / 'src'
    src.mkdir()
    if what == 'an empty .mcap':
        (src / 'src.mcap').write_bytes(b'')
    elif what == 'no intact chunk':
        data = _mcap(BAGS / 'k_tilde_bench').read_bytes()
        offset, length = _chunks(_mcap(BAGS / 'k_tilde_bench'))[0]
        (src / 'src.mcap').write_bytes(data[:offset + length // 2])
    else:
        (src / 'notes.txt').write_text('x')
    assert main(['repair', str(src), '--out', str(tmp_path / 'out')]) == 2
    got = capsys.readouterr()
    assert got.out == '' and len(got.err.splitlines()) == 1
    assert not (tmp_path / 'out').exists()
    assert [p.name for p in tmp_path.iterdir()] == ['src']


def test_a_cut_file_whose_chunks_carry_no_checksum_is_refused(tmp_path: Path) -> None:
    """Without a CRC or zstd checksum an intact chunk cannot be told from a damaged one."""
    from mcap.writer import CompressionType, Writer

    mcap = tmp_path / 'plain.mcap'
    with mcap.open('wb') as f:
        w = Writer(f, chunk_size=4096, compression=CompressionType.NONE, enable_crcs=False)
        w.start(profile='ros2', library='test')
        schema = w.register_schema('std_msgs/msg/Header', 'ros2msg', b'')
        channel = w.register_channel('/rate_table/zero_index', 'cdr', schema)
        for i in range(2000):
            w.add_message(channel, i, b'\x00\x01\x00\x00' + bytes(12), i)
        w.finish()
    data = mcap.read_bytes()
    mcap.write_bytes(data[:len(data) // 2])
    with pytest.raises(CorruptBagError, match='no checksum') as err:
        bag_info(mcap)
    assert len(str(err.value).splitlines()) == 1


def test_a_recording_never_closed_reads_back_to_its_last_flushed_chunk(tmp_path: Path) -> None:
    """The recorder's flush: what a SIGKILL (or a full disk) leaves reads back to there."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    from gyro_calib.bagio import ContractMessages, checksum_chunks, typestore
    from gyro_calib.bagio.writer import flush_chunk, pending_chunk

    cdr = ContractMessages()
    writer = Writer(tmp_path / 'live', version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    writer.open()
    checksum_chunks(writer)
    con = writer.add_connection('/gyro/pulses', 'sensor_msgs/msg/JointState',
                                typestore=typestore())
    assert not flush_chunk(writer)  # schemas and channels only: kept for the first message
    for i in range(300):
        writer.write(con, i * 1_000_000, cdr.joint_state(i * 1_000_000, 'gyro', float(i)))
        if i in (99, 199):
            assert flush_chunk(writer)
    assert pending_chunk(writer)[1] == 100  # written since the last flush: lost when killed
    killed = tmp_path / 'killed'
    killed.mkdir()
    shutil.copy(tmp_path / 'live' / 'live.mcap', killed / 'killed.mcap')  # as SIGKILL leaves it
    writer.close()

    info = bag_info(killed)
    assert info.topics['/gyro/pulses'].count == 200 and info.damage is not None
    assert info.damage.last_stamps_ns == {'/gyro/pulses': 199_000_000}
    (batch,) = iter_sample_batches(killed, {'/gyro/pulses': 'sensor_msgs/msg/JointState'})
    pulses = batch.joint_state('/gyro/pulses')
    assert pulses is not None and list(pulses[1]) == [float(i) for i in range(200)]


def test_a_disk_filling_mid_chunk_leaves_the_chunks_before_readable(tmp_path: Path) -> None:
    import errno

    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    from gyro_calib.bagio import ContractMessages, checksum_chunks, typestore
    from gyro_calib.bagio.writer import flush_chunk

    class Full:
        """The file, refusing every write past ``limit`` bytes after writing up to it."""

        def __init__(self, f: Any, limit: int) -> None:
            self.f, self.limit = f, limit

        def write(self, b: bytes) -> int:
            room = self.limit - self.f.tell()
            if len(b) > room:
                self.f.write(b[:max(room, 0)])
                self.f.flush()
                raise OSError(errno.ENOSPC, 'No space left on device')
            return int(self.f.write(b))

        def __getattr__(self, name: str) -> Any:
            return getattr(self.f, name)

    cdr = ContractMessages()
    writer = Writer(tmp_path / 'full', version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    writer.open()
    checksum_chunks(writer)
    con = writer.add_connection('/gyro/pulses', 'sensor_msgs/msg/JointState',
                                typestore=typestore())
    for i in range(100):
        writer.write(con, i, cdr.joint_state(i, 'gyro', float(i)))
    flush_chunk(writer)
    writer.storage.bio = Full(writer.storage.bio, writer.storage.bio.tell() + 200)
    for i in range(100, 200):
        writer.write(con, i, cdr.joint_state(i, 'gyro', float(i)))
    with pytest.raises(OSError, match='No space'):
        flush_chunk(writer)
    info = bag_info(tmp_path / 'full')
    assert info.topics['/gyro/pulses'].count == 100 and info.damage is not None
    assert 'inside a chunk' in info.damage.line('full')
