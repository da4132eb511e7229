"""rosbag2 MCAP bags of the topic contract: write, inspect and stream-decode (no rclpy).

Bags are rosbag2 directories (``metadata.yaml`` + one zstd-chunked ``.mcap``) written
and read with `rosbags`; messages are CDR-serialised by rosbags' typestore (ROS 2
Kilted definitions). A bag may carry its scenario (simulator parameters, seed and
truth) as YAML under ``custom_data['gyro_calib.scenario']`` of ``metadata.yaml``.

Reading is streamed: :func:`iter_sample_batches` yields the contract's samples as
NumPy arrays a few tens of thousands of messages at a time, so memory stays bounded
whatever the bag's length.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from gyro_calib import topics
from gyro_calib.errors import GyroCalibError

SCENARIO_KEY = 'gyro_calib.scenario'
"""custom_data key of the scenario YAML in metadata.yaml."""

JOINT_STATE = 'sensor_msgs/msg/JointState'
HEADER = 'std_msgs/msg/Header'

CONTRACT_TYPES: dict[str, str] = {
    topics.GYRO_PULSES: JOINT_STATE,
    topics.RATE_TABLE_JOINT_STATES: JOINT_STATE,
    topics.RATE_TABLE_ZERO_INDEX: HEADER,
    topics.POSITION_TABLE_JOINT_STATES: JOINT_STATE,
    topics.POSITION_TABLE_ZERO_INDEX: HEADER,
}
"""Message type of every calibration input topic."""

REQUIRED_TOPICS = (topics.GYRO_PULSES, topics.RATE_TABLE_JOINT_STATES,
                   topics.RATE_TABLE_ZERO_INDEX)
"""Topics a bag must hold to be calibrated (the position table's are optional: θ)."""

_TOPIC_ORDER = {name: i for i, name in enumerate(CONTRACT_TYPES)}


class BagError(GyroCalibError):
    """A bag cannot be read or written as asked; the message names the path and the problem."""


class BagNotFoundError(BagError):
    """The path does not exist."""


class NotABagError(BagError):
    """The path exists but is not a rosbag2 bag (no metadata.yaml / storage file)."""


class CorruptBagError(BagError):
    """The bag's files are truncated or damaged."""


class MissingTopicError(BagError):
    """A topic the calibration needs is not in the bag."""


class WrongMessageTypeError(BagError):
    """A contract topic is recorded with another message type."""


class EmptyBagError(BagError):
    """The bag holds no message (on the topics asked for)."""


def _typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_KILTED)


# ---------------------------------------------------------------------------------------
# Writing


@dataclass(frozen=True, slots=True)
class BagMessage:
    """One message to write: topic, log time (ns) and its CDR bytes."""

    topic: str
    log_time_ns: int
    cdr: bytes


class ContractMessages:
    """CDR serialisation of the contract's messages (JointState with one joint, Header)."""

    def __init__(self) -> None:
        """Load the ROS 2 Kilted typestore."""
        self.store = _typestore()
        types = self.store.types
        self._joint_state = types[JOINT_STATE]
        self._header = types[HEADER]
        self._time = types['builtin_interfaces/msg/Time']
        self._empty = np.zeros(0, dtype=np.float64)

    def joint_state(self, t_ns: int, joint: str, position: float,
                    velocity: float | None = None) -> bytes:
        """sensor_msgs/JointState of one joint (position, and velocity when given)."""
        sec, nsec = divmod(int(t_ns), 1_000_000_000)
        msg = self._joint_state(
            header=self._header(stamp=self._time(sec=sec, nanosec=nsec), frame_id=joint),
            name=[joint], position=np.array([position], dtype=np.float64),
            velocity=(self._empty if velocity is None
                      else np.array([velocity], dtype=np.float64)),
            effort=self._empty)
        return bytes(self.store.serialize_cdr(msg, JOINT_STATE))

    def header(self, t_ns: int, frame_id: str) -> bytes:
        """std_msgs/Header with the given stamp."""
        sec, nsec = divmod(int(t_ns), 1_000_000_000)
        msg = self._header(stamp=self._time(sec=sec, nanosec=nsec), frame_id=frame_id)
        return bytes(self.store.serialize_cdr(msg, HEADER))


def write_bag(path: str | Path, messages: Iterable[BagMessage], *,
              types: dict[str, str] | None = None,
              scenario: dict[str, Any] | None = None) -> None:
    """Write ``messages`` (log-time order) to a new rosbag2 MCAP bag at ``path``.

    Chunks are zstd-compressed inside the MCAP (rosbag2's storage compression), the
    layout is rosbag2 version 9 (``metadata.yaml`` + ``<name>.mcap``), and ``scenario``
    is stored as YAML in ``custom_data``. The bag is written under a temporary name and
    renamed when complete, so a failed write leaves nothing at ``path``.

    Raises:
        BagError: ``path`` exists, or a message names a topic without a type.
    """
    import shutil

    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    path = Path(path)
    if path.exists():
        raise BagError(f'{path}: exists already; not overwriting it.')
    types = {**CONTRACT_TYPES, **(types or {})}
    store = _typestore()
    tmp = path.with_name(f'.{path.name}.partial')
    if tmp.exists():
        shutil.rmtree(tmp)
    writer = Writer(tmp, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    if scenario is not None:
        writer.set_custom_data(SCENARIO_KEY, yaml.safe_dump(scenario, sort_keys=True))
    connections: dict[str, Any] = {}
    try:
        with writer:
            checksum_chunks(writer)
            for m in messages:
                con = connections.get(m.topic)
                if con is None:
                    if m.topic not in types:
                        raise BagError(f'{path}: no message type known for topic {m.topic}.')
                    con = connections[m.topic] = writer.add_connection(
                        m.topic, types[m.topic], typestore=store)
                writer.write(con, m.log_time_ns, m.cdr)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    # rosbags names the storage file after the directory: rename it with the directory
    (tmp / f'{tmp.name}.mcap').rename(tmp / f'{path.name}.mcap')
    meta = tmp / 'metadata.yaml'
    meta.write_text(meta.read_text().replace(f'{tmp.name}.mcap', f'{path.name}.mcap'))
    tmp.rename(path)


# ---------------------------------------------------------------------------------------
# Reading


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """One topic of a bag: name, message type, message count."""

    name: str
    msgtype: str
    count: int


@dataclass(frozen=True, slots=True)
class BagInfo:
    """What a bag holds, from its metadata (nothing decoded).

    Attributes:
        path: the bag directory.
        topics: topic name → :class:`TopicInfo`.
        start_ns, end_ns: first and last log time, ns.
        message_count: messages in all topics.
        scenario: the scenario YAML stored by the writer (parameters, seed, truth), or {}.
    """

    path: Path
    topics: dict[str, TopicInfo]
    start_ns: int
    end_ns: int
    message_count: int
    scenario: dict[str, Any] = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        """Log-time span, s."""
        return (self.end_ns - self.start_ns) / 1e9 if self.message_count else 0.0


def _one_line(exc: BaseException) -> str:
    return ' '.join(str(exc).split())


def checksum_chunks(writer: Any) -> None:
    """Make rosbags' MCAP writer add a zstd content checksum to every chunk.

    rosbags writes the MCAP chunk CRC as 0, so damaged chunk data would otherwise decode
    into wrong numbers unnoticed; its reader verifies zstd checksums. (rosbags 0.11.9:
    ``writer.storage.compressor``; other versions keep the default compressor.)
    """
    import functools
    import sys

    if sys.version_info >= (3, 14):
        from compression import zstd
    else:
        from backports import zstd
    storage = getattr(writer, 'storage', None)
    if storage is not None and getattr(storage, 'compression', '') == 'zstd':
        storage.compressor = functools.partial(
            zstd.compress, options={zstd.CompressionParameter.checksum_flag: 1})


def _open_reader(path: Path) -> Any:
    """An opened rosbags Reader, with every failure turned into a named BagError."""
    from rosbags.rosbag2 import Reader
    from rosbags.rosbag2.errors import ReaderError

    if not path.exists():
        raise BagNotFoundError(f'{path}: no such file or directory.')
    if path.is_file() and path.suffix == '.mcap':
        path = path.parent
    if not path.is_dir() or not (path / 'metadata.yaml').is_file():
        raise NotABagError(f'{path}: not a rosbag2 bag (a directory with metadata.yaml and '
                           'the .mcap file).')
    meta = path / 'metadata.yaml'
    try:
        yaml.safe_load(meta.read_text(encoding='utf-8'))
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        raise CorruptBagError(f'{meta}: damaged or truncated, not valid YAML '
                              f'({_one_line(exc)}).') from exc
    except OSError as exc:
        raise CorruptBagError(f'{meta}: cannot be read ({exc.strerror or exc}).') from exc
    try:
        reader = Reader(path)
        reader.open()
    except ReaderError as exc:
        raise CorruptBagError(f'{path}: damaged or truncated, cannot be read as a rosbag2 '
                              f'MCAP bag ({_one_line(exc)}).') from exc
    except (OSError, ValueError, KeyError, IndexError, EOFError) as exc:
        raise CorruptBagError(f'{path}: damaged or truncated ({type(exc).__name__}: '
                              f'{_one_line(exc)}).') from exc
    return reader


def bag_info(path: str | Path) -> BagInfo:
    """Topics, counts, time span and scenario of the bag at ``path``.

    Raises:
        BagError (subclass): the path is missing, not a bag, or the bag is damaged.
    """
    path = Path(path)
    reader = _open_reader(path)
    try:
        counts: dict[str, TopicInfo] = {}
        for con in reader.connections:
            prior = counts.get(con.topic)
            n = con.msgcount + (prior.count if prior else 0)
            counts[con.topic] = TopicInfo(con.topic, con.msgtype, n)
        metadata = getattr(reader.storage, 'metadata', None)
        custom = (metadata.custom if metadata is not None else None) or {}
        try:
            scenario = yaml.safe_load(custom.get(SCENARIO_KEY, '')) or {}
        except yaml.YAMLError as exc:
            raise CorruptBagError(f'{path}: the stored scenario is not valid YAML: {exc}') from exc
        total = sum(t.count for t in counts.values())
        return BagInfo(path, counts, int(reader.start_time) if total else 0,
                       int(reader.end_time) if total else 0, total, scenario)
    finally:
        reader.close()


def check_calibration_topics(info: BagInfo) -> None:
    """Raise unless the bag holds the calibration's input topics with the contract types.

    Raises:
        EmptyBagError: no message at all.
        MissingTopicError: a required topic is absent or has no message.
        WrongMessageTypeError: a contract topic carries another message type.
    """
    if info.message_count == 0:
        raise EmptyBagError(f'{info.path}: the bag holds no message.')
    for name, msgtype in CONTRACT_TYPES.items():
        got = info.topics.get(name)
        if got is not None and got.msgtype != msgtype:
            raise WrongMessageTypeError(f'{info.path}: topic {name} has type {got.msgtype}, '
                                        f'expected {msgtype}.')
    for name in REQUIRED_TOPICS:
        if name not in info.topics or info.topics[name].count == 0:
            raise MissingTopicError(f'{info.path}: required topic {name} '
                                    f'({CONTRACT_TYPES[name]}) is missing or empty.')


@dataclass(slots=True)
class SampleBatch:
    """Decoded contract samples of a stretch of the bag, in log-time order per topic.

    Attributes:
        joint_states: topic → (t_ns int64, position float64, velocity float64); a
            message without a position (or velocity) gives NaN, which the calibrator
            drops and counts.
        events: topic → stamps (int64 ns) of zero-index Header messages.
        messages: how many messages this batch decoded.
        last_log_time_ns: log time of the batch's last message.
    """

    joint_states: dict[str, tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                                  npt.NDArray[np.float64]]]
    events: dict[str, npt.NDArray[np.int64]]
    messages: int
    last_log_time_ns: int


def iter_sample_batches(path: str | Path, *, batch_messages: int = 50_000,
                        topics_wanted: Iterable[str] | None = None) -> Iterator[SampleBatch]:
    """Stream the contract topics of a bag as :class:`SampleBatch` es.

    Memory is bounded by ``batch_messages``. Messages are decoded with rosbags' CDR
    deserialiser; stamps are the header stamps (never the log times).

    Raises:
        CorruptBagError: a chunk cannot be read or a message cannot be decoded.
    """
    from rosbags.rosbag2.errors import ReaderError

    path = Path(path)
    wanted = set(topics_wanted or CONTRACT_TYPES)
    store = _typestore()
    reader = _open_reader(path)
    try:
        cons = [c for c in reader.connections if c.topic in wanted
                and CONTRACT_TYPES.get(c.topic) == c.msgtype]
        if not cons:
            return
        js: dict[str, tuple[list[int], list[float], list[float]]] = {}
        ev: dict[str, list[int]] = {}
        n, log_ns = 0, 0
        deserialize = store.deserialize_cdr
        try:
            for con, log_ns, raw in reader.messages(connections=cons):
                msg = deserialize(raw, con.msgtype)
                if con.msgtype == HEADER:
                    ev.setdefault(con.topic, []).append(
                        int(msg.stamp.sec) * 1_000_000_000 + int(msg.stamp.nanosec))
                else:
                    stamp = msg.header.stamp
                    t_ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
                    lists = js.setdefault(con.topic, ([], [], []))
                    lists[0].append(t_ns)
                    lists[1].append(float(msg.position[0]) if len(msg.position) else math.nan)
                    lists[2].append(float(msg.velocity[0]) if len(msg.velocity) else math.nan)
                n += 1
                if n >= batch_messages:
                    yield _batch(js, ev, n, log_ns)
                    js, ev, n = {}, {}, 0
        except (ReaderError, ValueError, KeyError, IndexError, EOFError, OSError) as exc:
            raise CorruptBagError(f'{path}: damaged or truncated after log time '
                                  f'{log_ns / 1e9:.6f} s ({type(exc).__name__}: {exc}).'
                                  ) from exc
        except Exception as exc:  # rosbags' decoder raises plain errors on damaged data
            if isinstance(exc, GyroCalibError):
                raise
            raise CorruptBagError(f'{path}: damaged, a message could not be decoded after log time '
                                  f'{log_ns / 1e9:.6f} s ({type(exc).__name__}: {exc}).'
                                  ) from exc
        if n:
            yield _batch(js, ev, n, log_ns)
    finally:
        reader.close()


def _batch(js: dict[str, tuple[list[int], list[float], list[float]]],
           ev: dict[str, list[int]], n: int, log_ns: int) -> SampleBatch:
    return SampleBatch(
        joint_states={k: (np.asarray(t, dtype=np.int64), np.asarray(p, dtype=np.float64),
                          np.asarray(v, dtype=np.float64)) for k, (t, p, v) in js.items()},
        events={k: np.asarray(v, dtype=np.int64) for k, v in ev.items()},
        messages=n, last_log_time_ns=int(log_ns))


def iter_raw_messages(path: str | Path) -> Iterator[tuple[str, str, int, bytes]]:
    """(topic, msgtype, log time ns, CDR bytes) of every message, in log-time order.

    Raises:
        BagError (subclass): as :func:`bag_info`, or a damaged chunk while reading.
    """
    path = Path(path)
    reader = _open_reader(path)
    try:
        try:
            for con, log_ns, raw in reader.messages():
                yield con.topic, con.msgtype, int(log_ns), bytes(raw)
        except GyroCalibError:
            raise
        except Exception as exc:  # rosbags/zstd raise many kinds on damaged data
            raise CorruptBagError(f'{path}: damaged or truncated ({type(exc).__name__}: '
                                  f'{_one_line(exc)}).') from exc
    finally:
        reader.close()


def topic_sort_key(topic: str) -> int:
    """Tie-break of messages with equal log time: contract order, then others."""
    return _TOPIC_ORDER.get(topic, len(_TOPIC_ORDER))
