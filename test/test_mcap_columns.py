"""Columnar MCAP decoding (gyro_calib.bagio.columns) is bit for bit rosbags' reading.

The reference everywhere is rosbags: its Reader yields (connection, log time, CDR bytes),
its typestore's ``deserialize_cdr`` decodes them, and the columns are pulled out of the
message objects here, independently of the module. Bit-identical means: log times and
stamps equal as int64, float64 columns equal as uint64 bit patterns (NaN payloads and
signed zeros included), frame_id strings equal message by message, in the same order.
"""

from __future__ import annotations

import functools
import math
import random
import shutil
import struct
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from gyro_calib.bagio import CONTRACT_TYPES, BagMessage, CorruptBagError, write_bag
from gyro_calib.bagio.columns import iter_column_batches
from gyro_calib.bagio.errors import (
    CountMismatchError,
    DamagedChunkError,
    MessageDecodeError,
    UnindexedChunksError,
    UnsupportedMessageTypeError,
)
from gyro_calib.bagio.messages import HEADER, IMU, JOINT_STATE, JOINT_WIDTHS, TEMPERATURE
from gyro_calib.bagio.plan import plan_bag

BAGS = Path(__file__).resolve().parents[1] / 'bags'
COMMITTED = sorted(p.name for p in BAGS.iterdir() if (p / 'metadata.yaml').is_file())

VALUE_NAMES = {
    JOINT_STATE: ('position', 'velocity'),
    HEADER: (),
    IMU: ('angular_velocity_rad_s', 'linear_acceleration_m_s2', 'orientation_covariance_0_rad2',
          'angular_velocity_covariance_0_rad2_s2', 'linear_acceleration_covariance_0_m2_s4'),
    TEMPERATURE: ('temperature_degc', 'variance_degc2'),
}
NAN_WITH_PAYLOAD, SIGNALLING_NAN = (float(x) for x in np.array(
    [0x7FF8_0000_DEAD_BEEF, 0x7FF0_0000_0000_0001], dtype=np.uint64).view(np.float64))
SPECIAL_FLOATS = (NAN_WITH_PAYLOAD, SIGNALLING_NAN, math.nan, -0.0, math.inf, -math.inf,
                  5e-324, -1.5e308)


# -- the reference: rosbags' reader + deserialize_cdr ----------------------------------------
def _stamp(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _reference_row(msgtype: str, msg: Any, topic: str = '') -> tuple[int, str, tuple[Any, ...]]:
    if msgtype == HEADER:
        return _stamp(msg.stamp), msg.frame_id, ()
    head = (_stamp(msg.header.stamp), msg.header.frame_id)
    if msgtype == JOINT_STATE and topic in JOINT_WIDTHS:  # one column per joint (/imu/pulses)
        width = JOINT_WIDTHS[topic]
        return (*head, (tuple(msg.position[:width]) if len(msg.position) else (math.nan,) * width,
                        msg.velocity[0] if len(msg.velocity) else math.nan))  # velocity: one
    if msgtype == JOINT_STATE:
        return (*head, (msg.position[0] if len(msg.position) else math.nan,
                        msg.velocity[0] if len(msg.velocity) else math.nan))
    if msgtype == IMU:
        w, a = msg.angular_velocity, msg.linear_acceleration
        return (*head, ((w.x, w.y, w.z), (a.x, a.y, a.z), msg.orientation_covariance[0],
                        msg.angular_velocity_covariance[0],
                        msg.linear_acceleration_covariance[0]))
    assert msgtype == TEMPERATURE
    return (*head, (msg.temperature, msg.variance))


@functools.cache
def typestore() -> Any:
    """The ROS 2 Kilted typestore of rosbags, one for the run (each new one compiles anew)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_KILTED)


def rosbags_columns(bag: Path, topic_types: Mapping[str, str], *, start: int | None = None,
                    stop: int | None = None) -> dict[str, dict[str, Any]]:
    """Each topic → {'log', 'stamp', 'frame', value names...} read by rosbags alone."""
    from rosbags.rosbag2 import Reader

    deserialize = typestore().deserialize_cdr
    rows: dict[str, list[tuple[int, int, str, tuple[Any, ...]]]] = {}
    with Reader(bag) as reader:
        cons = [c for c in reader.connections if topic_types.get(c.topic) == c.msgtype]
        if not cons:
            return {}
        for con, log_ns, raw in reader.messages(connections=cons, start=start, stop=stop):
            stamp, frame, values = _reference_row(con.msgtype, deserialize(raw, con.msgtype),
                                                  con.topic)
            rows.setdefault(con.topic, []).append((log_ns, stamp, frame, values))
    out = {}
    for topic, got in rows.items():
        cols: dict[str, Any] = {'log': np.array([r[0] for r in got], dtype=np.int64),
                                'stamp': np.array([r[1] for r in got], dtype=np.int64),
                                'frame': [r[2] for r in got]}
        for k, name in enumerate(VALUE_NAMES[topic_types[topic]]):
            cols[name] = np.array([r[3][k] for r in got], dtype=np.float64)
        out[topic] = cols
    return out


def columnar_columns(bag: Path, topic_types: Mapping[str, str], **kwargs: Any
                     ) -> tuple[dict[str, dict[str, Any]], int]:
    """The same shape from iter_column_batches, and how many messages rosbags decoded."""
    parts: dict[str, list[Any]] = {}
    fallback = 0
    for batch in iter_column_batches(bag, topic_types, **kwargs):
        fallback += batch.fallback_messages
        assert batch.messages == sum(len(c) for c in batch.topics.values())
        for topic, cols in batch.topics.items():
            assert len(cols) and cols.msgtype == topic_types[topic]
            parts.setdefault(topic, []).append(cols)
    out = {}
    for topic, got in parts.items():
        cols = {'log': np.concatenate([c.log_time_ns for c in got]),
                'stamp': np.concatenate([c.stamp_ns for c in got]),
                'frame': [s for c in got for s in c.frame_id.strings()]}
        for name in VALUE_NAMES[topic_types[topic]]:
            cols[name] = np.concatenate([c.values[name] for c in got])
        out[topic] = cols
    return out, fallback


def assert_bit_identical(got: dict[str, dict[str, Any]], want: dict[str, dict[str, Any]]
                         ) -> None:
    assert sorted(got) == sorted(want)
    for topic, cols in want.items():
        assert sorted(got[topic]) == sorted(cols), topic
        for name, column in cols.items():
            mine = got[topic][name]
            if name == 'frame':
                assert mine == column, topic
            else:
                assert mine.dtype == column.dtype and mine.shape == column.shape, (topic, name)
                bits = np.uint64 if column.dtype == np.float64 else np.int64
                assert np.array_equal(mine.view(bits), column.view(bits)), (topic, name)


# -- writing test bags -----------------------------------------------------------------------
class Cdr:
    """CDR bytes of the four message types, serialised by rosbags' typestore."""

    def __init__(self) -> None:
        self.store = typestore()
        self.t = self.store.types

    def _header(self, t_ns: int, frame: str) -> Any:
        sec, nsec = divmod(t_ns, 1_000_000_000)
        return self.t[HEADER](stamp=self.t['builtin_interfaces/msg/Time'](sec=sec, nanosec=nsec),
                              frame_id=frame)

    def _cdr(self, msg: Any, msgtype: str, little_endian: bool = True) -> bytes:
        return bytes(self.store.serialize_cdr(msg, msgtype, little_endian=little_endian))

    def header(self, t_ns: int, frame: str) -> bytes:
        return self._cdr(self._header(t_ns, frame), HEADER)

    def joint_state(self, t_ns: int, frame: str, names: Iterable[str] = ('gyro',),
                    position: Iterable[float] = (1.0,), velocity: Iterable[float] = (),
                    effort: Iterable[float] = (), little_endian: bool = True) -> bytes:
        def arr(v: Iterable[float]) -> np.ndarray:
            return np.array(list(v), dtype=np.float64)
        msg = self.t[JOINT_STATE](header=self._header(t_ns, frame), name=list(names),
                                  position=arr(position), velocity=arr(velocity),
                                  effort=arr(effort))
        return self._cdr(msg, JOINT_STATE, little_endian)

    def imu(self, t_ns: int, frame: str, w: Iterable[float], a: Iterable[float],
            cov0: float) -> bytes:
        v3 = self.t['geometry_msgs/msg/Vector3']
        cov = np.full(9, cov0)
        msg = self.t[IMU](header=self._header(t_ns, frame),
                          orientation=self.t['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0,
                                                                             w=1.0),
                          orientation_covariance=-cov, angular_velocity=v3(*w),
                          angular_velocity_covariance=cov, linear_acceleration=v3(*a),
                          linear_acceleration_covariance=2 * cov)
        return self._cdr(msg, IMU)

    def temperature(self, t_ns: int, frame: str, degc: float, variance: float) -> bytes:
        return self._cdr(self.t[TEMPERATURE](header=self._header(t_ns, frame), temperature=degc,
                                             variance=variance), TEMPERATURE)


@pytest.fixture(scope='module')
def cdr() -> Cdr:
    return Cdr()


def write_test_bag(path: Path, messages: list[tuple[str, int, bytes]],
                   types: dict[str, str]) -> Path:
    """A rosbags-written bag (zstd chunks, as gyro_calib.bagio.write_bag makes them)."""
    write_bag(path, [BagMessage(topic, t, raw) for topic, t, raw in messages], types=types)
    return path


def rewrite_mcap(bag: Path, out: Path, *, reorder: random.Random | None = None,
                 **writer: Any) -> Path:
    """Copy of ``bag`` rewritten by the mcap library's Writer.

    Copy of ``bag`` whose .mcap the mcap library's Writer rewrote (same channels and
    messages; ``writer`` chooses chunking, compression, indexes, statistics, CRCs);
    ``reorder`` shuffles the messages in windows of 40, so chunks overlap in log time.
    """
    from mcap.reader import make_reader
    from mcap.writer import Writer

    shutil.copytree(bag, out)
    (mcap,) = out.glob('*.mcap')
    with mcap.open('rb') as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        messages = [(c.id, m.log_time, m.data, m.publish_time, m.sequence)
                    for _, c, m in reader.iter_messages(log_time_order=False)]
    if reorder is not None:
        for k in range(0, len(messages), 40):
            window = messages[k:k + 40]
            reorder.shuffle(window)
            messages[k:k + 40] = window
    with mcap.open('wb') as f:
        w = Writer(f, **writer)
        w.start(profile='ros2', library='test')
        schema_ids = {sid: w.register_schema(s.name, s.encoding, s.data)
                      for sid, s in sorted(summary.schemas.items())}
        channel_ids = {cid: w.register_channel(c.topic, c.message_encoding,
                                               schema_ids[c.schema_id], c.metadata)
                       for cid, c in sorted(summary.channels.items())}
        for cid, log_time, data, publish_time, sequence in messages:
            w.add_message(channel_ids[cid], log_time, data, publish_time, sequence)
        w.finish()
    return out


def summary_records(data: bytes) -> Iterable[tuple[int, int, int]]:
    """(opcode, offset, length) of each record of an MCAP file's summary section."""
    footer = len(data) - 8 - 29
    (summary_start,) = struct.unpack_from('<Q', data, footer + 9)
    pos = summary_start
    while pos < footer:
        opcode, length = struct.unpack_from('<BQ', data, pos)
        yield opcode, pos, length
        pos += 9 + length


def _mcap(bag: Path) -> Path:
    (mcap,) = bag.glob('*.mcap')
    return mcap


# -- committed bags --------------------------------------------------------------------------
@pytest.mark.parametrize('name', COMMITTED)
def test_committed_bag_decodes_bit_identical_to_rosbags_without_fallback(name: str) -> None:
    plan = plan_bag(BAGS / name, CONTRACT_TYPES)
    got, fallback = columnar_columns(BAGS / name, CONTRACT_TYPES)

    assert plan.columnar, plan.reason
    # chunks that share only their boundary log time are still decoded one by one
    assert all(len(group) == 1 for group in plan.groups)
    assert fallback == 0
    assert_bit_identical(got, rosbags_columns(BAGS / name, CONTRACT_TYPES))


def test_committed_bags_are_all_tested() -> None:
    assert len(COMMITTED) >= 8 and 'k_tilde_bench' in COMMITTED


# -- synthetic bags: Imu, Temperature, Header frame_ids -------------------------------------
IMU_TYPES = {'/imu/data': IMU, '/cavity/temperature': TEMPERATURE,
             '/vibration_table/zero_index': HEADER}


def imu_bag(path: Path, cdr: Cdr, *, seconds: float = 2.0, seed: int = 3) -> Path:
    """An Imu, temperature and zero-index bag.

    400 Hz Imu (special floats sprinkled in), 3 temperature sensors on one topic at 10 Hz
    each, vibration-table zero-index events with frame_id z or y.
    """
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    messages = []
    for k in range(int(seconds * 400)):
        t = 1_700_000_000_000_000_000 + k * 2_500_000
        w, a = rng.normal(0, 0.01, 3), rng.normal(0, 9.81, 3)
        if k % 37 == 5:
            w[k % 3] = SPECIAL_FLOATS[k % len(SPECIAL_FLOATS)]
        messages.append(('/imu/data', t, cdr.imu(t, 'imu_link', w, a, 1e-6 * (k % 5))))
        if k % 40 < 3:
            sensor = ('cavity_a', 'cavity_b', 'shell')[k % 40]
            messages.append(('/cavity/temperature', t + 7,
                             cdr.temperature(t, sensor, 45.0 + rng.normal(0, 0.1),
                                             SPECIAL_FLOATS[k % len(SPECIAL_FLOATS)])))
        if k % 50 == 0:
            messages.append(('/vibration_table/zero_index', t + 11,
                             cdr.header(t + 3, 'zy'[int(rng.integers(2))])))
    return write_test_bag(path, messages, IMU_TYPES)


def test_imu_temperature_and_header_bag_decodes_bit_identical_to_rosbags(
        tmp_path: Path, cdr: Cdr) -> None:
    bag = imu_bag(tmp_path / 'imu', cdr)

    got, fallback = columnar_columns(bag, IMU_TYPES)

    assert plan_bag(bag, IMU_TYPES).columnar and fallback == 0
    assert_bit_identical(got, rosbags_columns(bag, IMU_TYPES))
    assert set(got['/cavity/temperature']['frame']) == {'cavity_a', 'cavity_b', 'shell'}
    assert set(got['/vibration_table/zero_index']['frame']) == {'z', 'y'}
    assert got['/imu/data']['angular_velocity_rad_s'].shape == (800, 3)


def test_frame_ids_are_a_categorical_column_whose_codes_keep_their_meaning_across_batches(
        tmp_path: Path, cdr: Cdr) -> None:
    bag = imu_bag(tmp_path / 'imu', cdr, seconds=60.0)
    seen: list[tuple[str, ...]] = []

    batches = list(iter_column_batches(bag, IMU_TYPES, batch_messages=1000))

    assert len(batches) > 2
    for batch in batches:
        cols = batch.topics['/cavity/temperature']
        assert cols.frame_id.codes.dtype == np.int32
        assert set(cols.frame_id.strings()) <= set(cols.frame_id.names)
        seen.append(cols.frame_id.names)
    assert all(later[:len(earlier)] == earlier for earlier, later in zip(seen, seen[1:]))
    assert set(seen[-1]) == {'cavity_a', 'cavity_b', 'shell'}
    assert all(b.messages >= 1000 for b in batches[:-1])
    assert [b.last_log_time_ns for b in batches] == sorted(b.last_log_time_ns for b in batches)


# -- other layouts mid-stream ----------------------------------------------------------------
ODD_TYPES = {'/gyro/pulses': JOINT_STATE, '/vibration_table/zero_index': HEADER}


def odd_layout_bag(path: Path, cdr: Cdr) -> tuple[Path, int]:
    """Pulses with messages of other layouts mid-stream.

    Pulses of the contract layout with, mid-stream, messages of other layouts; returns the
    bag and how many of them no fixed layout covers (rosbags must decode those).
    """
    def pulse(t: int, **kw: Any) -> bytes:
        return cdr.joint_state(t, kw.pop('frame', 'gyro'), position=kw.pop('position', (t,)),
                               **kw)
    odd: dict[int, Any] = {
        # not a fixed layout: rosbags decodes these
        50: lambda t: pulse(t, names=('gyro', 'spare'), position=(1.5, 2.5)),
        80: lambda t: pulse(t, velocity=(0.5, 0.25)),
        90: lambda t: pulse(t, little_endian=False, velocity=(3.0,)),
        95: lambda t: pulse(t, names=()),
        # other fixed layouts: decoded by NumPy, never mistaken for the common one
        60: lambda t: pulse(t, position=()),
        70: lambda t: pulse(t, frame='gyro_cavity_b', velocity=(-0.0,)),
        100: lambda t: pulse(t, effort=(1.0,)),
        110: lambda t: pulse(t, names=('',)),
        120: lambda t: pulse(t) + b'\x00\x00\x00',  # 3 bytes of padding: rosbags accepts
        130: lambda t: b'\x00\x01\x00\x03' + pulse(t)[4:],  # options bytes: rosbags ignores
        140: lambda t: pulse(t, position=(NAN_WITH_PAYLOAD,), velocity=(math.inf,)),
    }
    messages = []
    for k in range(200):
        t = 5_000_000_000 + k * 1_000_000
        messages.append(('/gyro/pulses', t, odd[k](t) if k in odd else pulse(t)))
        if k % 20 == 3:
            messages.append(('/vibration_table/zero_index', t,
                             cdr.header(t, ('z', 'y', 'zz', '')[k % 4])))
    return write_test_bag(path, messages, ODD_TYPES), 4


def test_a_message_of_another_layout_goes_to_rosbags_alone_with_the_right_values(
        tmp_path: Path, cdr: Cdr) -> None:
    bag, not_fixed = odd_layout_bag(tmp_path / 'odd', cdr)

    got, fallback = columnar_columns(bag, ODD_TYPES)

    assert fallback == not_fixed
    assert_bit_identical(got, rosbags_columns(bag, ODD_TYPES))
    pulses = got['/gyro/pulses']
    assert math.isnan(pulses['position'][60]) and pulses['position'][61] == 5_061_000_000
    assert pulses['frame'][70] == 'gyro_cavity_b' and pulses['frame'][71] == 'gyro'
    assert pulses['position'][50] == 1.5 and pulses['velocity'][90] == 3.0


@pytest.mark.parametrize('damage', ['4 bytes of trailing garbage', 'frame_id not UTF-8'])
def test_a_message_rosbags_cannot_decode_either_raises_message_decode_error(
        tmp_path: Path, cdr: Cdr, damage: str) -> None:
    def bad(t: int) -> bytes:
        good = cdr.joint_state(t, 'gyro')
        if damage.startswith('4'):
            return good + b'\x00' * 4
        return good.replace(b'gyro', b'gy\xffo', 1)
    messages = [('/gyro/pulses', t, bad(t) if k == 30 else cdr.joint_state(t, 'gyro'))
                for k, t in enumerate(range(1_000, 101_000, 1_000))]
    bag = write_test_bag(tmp_path / 'bag', messages, ODD_TYPES)

    with pytest.raises(MessageDecodeError, match='damaged') as err:
        list(iter_column_batches(bag, ODD_TYPES))

    assert isinstance(err.value, CorruptBagError) and str(bag) in str(err.value)
    with pytest.raises(Exception):  # rosbags refuses the same message
        rosbags_columns(bag, ODD_TYPES)


# -- chunk files the module reads itself or hands to rosbags whole ---------------------------
def test_uncompressed_crc_checked_chunks_overlapping_in_log_time_come_out_in_rosbags_order(
        tmp_path: Path, cdr: Cdr) -> None:
    from mcap.writer import CompressionType

    bag = rewrite_mcap(imu_bag(tmp_path / 'imu', cdr), tmp_path / 'overlap',
                       reorder=random.Random(5), chunk_size=6000,
                       compression=CompressionType.NONE, enable_crcs=True)

    plan = plan_bag(bag, IMU_TYPES)
    got, fallback = columnar_columns(bag, IMU_TYPES)

    assert plan.columnar and fallback == 0
    assert max(len(g) for g in plan.groups) > 1, 'the reordering should overlap chunks'
    assert all(c.compression == '' for g in plan.groups for c in g)
    assert_bit_identical(got, rosbags_columns(bag, IMU_TYPES))


@pytest.mark.parametrize('variant, writer, reason', [
    ('lz4 chunks', {'compression': 'LZ4'}, 'lz4'),
    ('unchunked', {'use_chunking': False}, 'unchunked or unindexed'),
    ('no statistics', {'use_statistics': False}, 'statistics'),
])
def test_a_bag_the_module_does_not_read_goes_to_rosbags_whole(
        tmp_path: Path, cdr: Cdr, variant: str, writer: dict[str, Any], reason: str) -> None:
    from mcap.writer import CompressionType

    if 'compression' in writer:
        writer = {**writer, 'compression': CompressionType[writer['compression']]}
    bag = rewrite_mcap(imu_bag(tmp_path / 'imu', cdr, seconds=0.5), tmp_path / 'bag', **writer)

    plan = plan_bag(bag, IMU_TYPES)
    got, fallback = columnar_columns(bag, IMU_TYPES)

    assert not plan.columnar and reason in plan.reason, (variant, plan.reason)
    want = rosbags_columns(bag, IMU_TYPES)
    assert fallback == sum(len(c['log']) for c in want.values()) > 0
    assert_bit_identical(got, want)


def test_chunks_without_message_index_raise_a_named_error_where_rosbags_returns_nothing(
        tmp_path: Path, cdr: Cdr) -> None:
    from mcap.writer import IndexType

    bag = rewrite_mcap(imu_bag(tmp_path / 'imu', cdr, seconds=0.5), tmp_path / 'bag',
                       index_types=IndexType.CHUNK)

    with pytest.raises(UnindexedChunksError, match='mcap recover'):
        plan_bag(bag, IMU_TYPES)
    with pytest.raises(UnindexedChunksError):
        iter_column_batches(bag, IMU_TYPES).__next__()
    assert rosbags_columns(bag, IMU_TYPES) == {}, 'rosbags 0.11.9 silently reads nothing'


def test_a_time_window_gives_what_rosbags_gives_for_start_and_stop(
        tmp_path: Path, cdr: Cdr) -> None:
    bag = imu_bag(tmp_path / 'imu', cdr, seconds=4.0)
    start = 1_700_000_000_000_000_000 + 1_234_567_890
    stop = start + 1_500_000_000

    got, _ = columnar_columns(bag, IMU_TYPES, start_ns=start, stop_ns=stop)

    assert_bit_identical(got, rosbags_columns(bag, IMU_TYPES, start=start, stop=stop))
    assert got['/imu/data']['log'].min() >= start and got['/imu/data']['log'].max() < stop


def test_the_rosbags_decoder_can_be_asked_for_and_agrees(tmp_path: Path, cdr: Cdr) -> None:
    bag, not_fixed = odd_layout_bag(tmp_path / 'odd', cdr)

    got, fallback = columnar_columns(bag, ODD_TYPES, decoder='rosbags')

    assert fallback == 200 + 10
    assert_bit_identical(got, columnar_columns(bag, ODD_TYPES)[0])


# -- bad input -------------------------------------------------------------------------------
def test_garbage_over_a_chunk_raises_damaged_chunk_error_naming_the_bag(tmp_path: Path) -> None:
    bag = tmp_path / 'k_tilde_bench'
    shutil.copytree(BAGS / 'k_tilde_bench', bag)
    plan = plan_bag(bag, CONTRACT_TYPES)
    chunk = plan.groups[len(plan.groups) // 2][0]
    data = bytearray(_mcap(bag).read_bytes())
    middle = chunk.offset + chunk.length // 2
    data[middle:middle + 16] = random.Random(7).randbytes(16)
    _mcap(bag).write_bytes(bytes(data))

    with pytest.raises(DamagedChunkError, match='damaged') as err:
        list(iter_column_batches(bag, CONTRACT_TYPES, recover=False))

    assert isinstance(err.value, CorruptBagError) and str(bag) in str(err.value)
    assert len(str(err.value).splitlines()) == 1
    # read to recover (the default): the chunk is skipped with one line naming it
    notes = [n for b in iter_column_batches(bag, CONTRACT_TYPES) for n in b.notes]
    assert len(notes) == 1 and f'a damaged chunk at bytes {chunk.offset}–' in notes[0]


def test_statistics_that_disagree_with_the_chunk_indexes_raise_count_mismatch_error(
        tmp_path: Path, cdr: Cdr) -> None:
    bag = imu_bag(tmp_path / 'imu', cdr, seconds=0.5)
    data = bytearray(_mcap(bag).read_bytes())
    (at,) = [pos for opcode, pos, _ in summary_records(bytes(data)) if opcode == 0x0B]
    channel_counts = at + 9 + 42 + 4  # Statistics: 42 bytes of fields, then the count map
    channel, count = struct.unpack_from('<HQ', data, channel_counts)
    struct.pack_into('<HQ', data, channel_counts, channel, count + 1)
    _mcap(bag).write_bytes(bytes(data))

    with pytest.raises(CountMismatchError, match=f'{count + 1} messages'):
        plan_bag(bag, IMU_TYPES)
    with pytest.raises(CountMismatchError):
        next(iter_column_batches(bag, IMU_TYPES))
    assert rosbags_columns(bag, IMU_TYPES), 'rosbags reads it, statistics unchecked'


def test_a_type_without_columns_is_refused_naming_it() -> None:
    with pytest.raises(UnsupportedMessageTypeError, match='std_msgs/msg/Float64'):
        iter_column_batches(BAGS / 'k_tilde_bench', {'/x': 'std_msgs/msg/Float64'})


def test_a_topic_recorded_with_another_type_is_skipped_as_rosbags_skips_it() -> None:
    types = {'/gyro/pulses': HEADER, '/rate_table/zero_index': HEADER}

    got, _ = columnar_columns(BAGS / 'k_tilde_bench', types)

    assert list(got) == ['/rate_table/zero_index']
    assert_bit_identical(got, rosbags_columns(BAGS / 'k_tilde_bench', types))
