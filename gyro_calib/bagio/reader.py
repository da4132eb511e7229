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

import dataclasses
import functools
import heapq
import math
import re
import struct
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from gyro_calib import topics
from gyro_calib.errors import GyroCalibError

SCENARIO_KEY = 'gyro_calib.scenario'
"""custom_data key of the scenario YAML in metadata.yaml (the bench in the root namespace;
:func:`scenario_key` names a namespaced bench's)."""


def scenario_key(namespace: str) -> str:
    """custom_data key of the scenario of the bench in ``namespace`` ('' = the root)."""
    ns = topics.normalized_namespace(namespace)
    return f'{SCENARIO_KEY}:{ns}' if ns else SCENARIO_KEY

JOINT_STATE = 'sensor_msgs/msg/JointState'
HEADER = 'std_msgs/msg/Header'
IMU = 'sensor_msgs/msg/Imu'
TEMPERATURE = 'sensor_msgs/msg/Temperature'


def _contract_types() -> dict[str, str]:
    from gyro_calib.registry import METHODS, topic_types

    return topic_types(METHODS.values())


CONTRACT_TYPES: dict[str, str] = _contract_types()
"""Message type of every input topic of every method (the topic contract)."""

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


def scenario_text(scenario: Mapping[str, Any]) -> str:
    """The scenario as stored in ``custom_data``: one line of flow-style YAML, Unicode kept
    (no ``\\u`` escapes; :func:`store_custom_data` writes it unfolded)."""
    text = yaml.safe_dump(dict(scenario), sort_keys=True, default_flow_style=True,
                          allow_unicode=True, width=2**31 - 1)
    return text.strip()


def store_custom_data(bag_dir: str | Path, key: str, text: str) -> None:
    """Write ``custom_data[key] = text`` into the bag's metadata.yaml unfolded.

    rosbags dumps metadata.yaml with ruamel at 80 columns, and ruamel's folding of a
    double-quoted scalar can split an escape (``\\\\`` came back as ``\\ \\``), so the
    value it wrote may read back changed; the file is re-dumped here with the value as given
    and no line folding (every other field as rosbags wrote it).
    """
    meta = Path(bag_dir) / 'metadata.yaml'
    doc = yaml.safe_load(meta.read_text(encoding='utf-8'))
    info = doc['rosbag2_bagfile_information']
    custom = info.get('custom_data') or {}
    custom[key] = text
    info['custom_data'] = custom
    meta.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True,
                                   default_flow_style=False, width=2**31 - 1),
                    encoding='utf-8')


_SPLIT_ESCAPE = re.compile(r'\\ (?=u[0-9A-Fa-f]{4}|x[0-9A-Fa-f]{2}|U[0-9A-Fa-f]{8})')


def parse_scenario_text(text: str) -> Any:
    """The stored scenario; repairs an escape split by the ruamel line fold of bags written
    before :func:`scenario_text` (``\\ u2080`` → ``\\u2080`` inside a quoted scalar)."""
    return yaml.safe_load(_SPLIT_ESCAPE.sub(lambda m: '\\', text))


@functools.cache
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
              scenario: dict[str, Any] | None = None,
              namespace_scenarios: Mapping[str, Mapping[str, Any]] | None = None) -> None:
    """Write ``messages`` (log-time order) to a new rosbag2 MCAP bag at ``path``.

    ``namespace_scenarios`` stores the scenario of each namespaced bench
    (:func:`scenario_key`), as :mod:`gyro_calib.nodes.bag_recorder` does.

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
        writer.set_custom_data(SCENARIO_KEY, scenario_text(scenario))
    for ns, part in (namespace_scenarios or {}).items():
        writer.set_custom_data(scenario_key(ns), scenario_text(part))
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
    if scenario is not None:  # unfolded: rosbags' folding can split an escape
        store_custom_data(tmp, SCENARIO_KEY, scenario_text(scenario))
    for ns, part in (namespace_scenarios or {}).items():
        store_custom_data(tmp, scenario_key(ns), scenario_text(part))
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
        namespace: the namespace the bag is seen from ('' = the root; see
            :meth:`in_namespace`): its topics are named as in the contract.
        namespace_scenarios: namespace → the scenario stored for the bench there.
    """

    path: Path
    topics: dict[str, TopicInfo]
    start_ns: int
    end_ns: int
    message_count: int
    scenario: dict[str, Any] = field(default_factory=dict)
    namespace: str = ''
    namespace_scenarios: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        """Log-time span, s."""
        return (self.end_ns - self.start_ns) / 1e9 if self.message_count else 0.0

    def in_namespace(self, namespace: str) -> BagInfo:
        """The bag as the bench in ``namespace`` sees it: the topics under it, named without
        the namespace ('/bench2/gyro/pulses' → '/gyro/pulses'), the others left out, and that
        bench's scenario. The root namespace ('' or '/') gives the bag as it is."""
        ns = topics.normalized_namespace(namespace)
        if not ns:
            return self
        inside = {name[len(ns):]: TopicInfo(name[len(ns):], t.msgtype, t.count)
                  for name, t in self.topics.items() if name.startswith(ns + '/')}
        return dataclasses.replace(self, topics=inside, namespace=ns,
                                   message_count=sum(t.count for t in inside.values()),
                                   scenario=self.namespace_scenarios.get(ns, {}))


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


def _usable_metadata(meta: Path) -> bool:
    """True when ``meta`` is a readable rosbag2 metadata.yaml (a mapping with
    ``rosbag2_bagfile_information``)."""
    try:
        document = yaml.safe_load(meta.read_text(encoding='utf-8'))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return False
    return isinstance(document, dict) and isinstance(
        document.get('rosbag2_bagfile_information'), dict)


def _open_lone_mcap(path: Path) -> Any:
    """rosbags' Reader on a .mcap file without its bag's metadata.yaml (counts and span
    from the file's own summary)."""
    from rosbags.rosbag2 import Reader

    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # noqa: BLE001 -- rosbags raises many kinds on a damaged file
        raise CorruptBagError(f'{path}: damaged or truncated, cannot be read as an MCAP file '
                              f'({type(exc).__name__}: {_one_line(exc)}).') from exc
    return reader


def _lone_mcap_custom_data(path: Path) -> dict[str, str]:
    """custom_data of the rosbag2 metadata record a .mcap file carries ({} if none)."""
    try:
        from mcap.reader import make_reader

        with open(path, 'rb') as f:
            for record in make_reader(f).iter_metadata():
                if record.name == 'rosbag2':
                    meta = yaml.safe_load(record.metadata.get('serialized_metadata', ''))
                    info = meta.get('rosbag2_bagfile_information', meta)
                    custom = info.get('custom_data') if isinstance(info, dict) else None
                    return dict(custom) if isinstance(custom, dict) else {}
    except Exception:  # noqa: BLE001 -- the stored scenario is optional
        return {}
    return {}


def _open_reader(path: Path) -> Any:
    """An opened rosbags Reader, with every failure turned into a named BagError."""
    from rosbags.rosbag2 import Reader
    from rosbags.rosbag2.errors import ReaderError

    if not path.exists():
        raise BagNotFoundError(f'{path}: no such file or directory.')
    if path.is_file() and path.suffix == '.bag':
        raise NotABagError(f'{path}: a ROS 1 bag; convert it first with `rosbags-convert '
                           f'--src {path} --dst {path.with_suffix("")}` (installed with '
                           'rosbags), then pass the rosbag2 directory it writes.')
    if path.is_file() and path.suffix == '.mcap':
        if not _usable_metadata(path.parent / 'metadata.yaml'):
            return _open_lone_mcap(path)
        path = path.parent
    if not path.is_dir() or not (path / 'metadata.yaml').is_file():
        raise NotABagError(f'{path}: not a rosbag2 bag (a directory with metadata.yaml and '
                           'the .mcap file, or a lone .mcap file).')
    meta = path / 'metadata.yaml'
    try:
        document = yaml.safe_load(meta.read_text(encoding='utf-8'))
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        raise CorruptBagError(f'{meta}: damaged or truncated, not valid YAML '
                              f'({_one_line(exc)}).') from exc
    except OSError as exc:
        raise CorruptBagError(f'{meta}: cannot be read ({exc.strerror or exc}).') from exc
    if not isinstance(document, dict) or not isinstance(
            document.get('rosbag2_bagfile_information'), dict):
        what = 'the file is empty' if document is None else 'no rosbag2_bagfile_information'
        raise CorruptBagError(f'{meta}: damaged or truncated ({what}): the recording was '
                              'not closed properly; `ros2 bag reindex` rebuilds it, or pass '
                              'the .mcap file itself (read with its own summary).')
    try:
        reader = Reader(path)
        reader.open()
    except ReaderError as exc:
        raise CorruptBagError(f'{path}: damaged or truncated, cannot be read as a rosbag2 '
                              f'MCAP bag ({_one_line(exc)}).') from exc
    except (OSError, ValueError, KeyError, IndexError, EOFError, MemoryError, OverflowError,
            struct.error) as exc:
        raise CorruptBagError(f'{path}: damaged or truncated ({type(exc).__name__}: '
                              f'{_one_line(exc)}).') from exc
    return reader


def bag_info(path: str | Path) -> BagInfo:
    """Topics, counts, time span and scenario of the bag at ``path``.

    Raises:
        BagError (subclass): the path is missing, not a bag, or the bag is damaged.
    """
    from gyro_calib.bagio import tables as table_input

    path = Path(path)
    if table_input.is_table(path):
        return table_input.table_info(path)  # type: ignore[no-any-return]
    reader = _open_reader(path)
    try:
        counts: dict[str, TopicInfo] = {}
        for con in reader.connections:
            prior = counts.get(con.topic)
            n = con.msgcount + (prior.count if prior else 0)
            counts[con.topic] = TopicInfo(con.topic, con.msgtype, n)
        metadata = getattr(reader.storage, 'metadata', None)
        custom = (metadata.custom if metadata is not None else None) or {}
        if not custom and path.is_file():
            custom = _lone_mcap_custom_data(path)
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


def header_stamp_spans(path: str | Path, info: BagInfo) -> dict[str, tuple[int, int, int,
                                                                         float]]:
    """Topic → (messages, earliest and latest header stamp ns, typical sample interval ns)
    of every topic whose type carries a header stamp the columnar decoder reads (JointState,
    Header, Imu, Temperature): rates from the sample instants, not the receive (log) times.
    The typical interval is the median over batches of each batch's median positive stamp
    step, so gaps and a few disordered stamps do not move it.

    Raises:
        CorruptBagError: a chunk cannot be read or a message cannot be decoded.
    """
    from gyro_calib.bagio import columns as mcap_columns

    types = {t.name: t.msgtype for t in info.topics.values()
             if t.msgtype in mcap_columns.CODECS and t.count}
    spans: dict[str, tuple[int, int, int]] = {}
    steps: dict[str, list[float]] = {}
    if not types:
        return {}
    for batch in iter_sample_batches(path, types, namespace=info.namespace):
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


@dataclass(slots=True)
class SampleBatch:
    """Decoded samples of a stretch of the bag(s), per topic, in log-time order per topic.

    Attributes:
        columns: topic → its columns (:class:`gyro_calib.bagio.columns.TopicColumns`: header
            stamps, frame_ids, the message type's values).
        messages: how many messages this batch decoded.
        last_log_time_ns: log time of the batch's last message.
    """

    columns: dict[str, Any]
    messages: int
    last_log_time_ns: int

    def joint_state(self, topic: str) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                                               npt.NDArray[np.float64]] | None:
        """(header stamp ns, position, velocity) of a JointState topic; NaN where a message
        had no position (or velocity), which the calibrators drop and count."""
        c = self.columns.get(topic)
        if c is None or c.msgtype != JOINT_STATE:
            return None
        return c.stamp_ns, c.values['position'], c.values['velocity']

    def stamps(self, topic: str) -> npt.NDArray[np.int64] | None:
        """Header stamps (ns) of a topic's messages (zero-index events)."""
        c = self.columns.get(topic)
        return None if c is None else c.stamp_ns


def iter_sample_batches(path: str | Path, topic_types: Mapping[str, str] | None = None, *,
                        batch_messages: int = 50_000,
                        namespace: str = '') -> Iterator[SampleBatch]:
    """Stream the given topics of a bag as :class:`SampleBatch` es.

    Decoded by :mod:`gyro_calib.bagio.columns`: whole chunks at a time with NumPy,
    bit-identical to rosbags' CDR deserialiser, which decodes any message of another
    layout (and whole bags the columnar path does not read itself). Memory is bounded by
    ``batch_messages`` plus one group of chunks; stamps are the header stamps (never the
    log times). With a ``namespace``, the topics are read under it and named as in the
    contract (:meth:`BagInfo.in_namespace`).

    Raises:
        CorruptBagError: a chunk cannot be read or a message cannot be decoded.
    """
    from gyro_calib.bagio import columns as mcap_columns
    from gyro_calib.bagio import tables as table_input

    if table_input.is_table(path):
        yield from table_input.iter_table_batches(path, topic_types, batch_messages)
        return
    types = dict(topic_types if topic_types is not None else CONTRACT_TYPES)
    ns = topics.normalized_namespace(namespace)
    if ns:
        types = {ns + t: m for t, m in types.items()}
    for batch in mcap_columns.iter_column_batches(path, types, batch_messages=batch_messages):
        columns = batch.topics
        if ns:
            columns = {t[len(ns):]: dataclasses.replace(c, topic=t[len(ns):])
                       for t, c in columns.items()}
        yield SampleBatch(columns, batch.messages, batch.last_log_time_ns)


def iter_bags(paths: Sequence[str | Path], topic_types: Mapping[str, str], *,
              batch_messages: int = 50_000,
              namespace: str = '') -> Iterator[tuple[int, SampleBatch]]:
    """(bag index, batch) of several bags taken together in stamp order.

    Bags that share a topic are separate recordings (or one recording split in time) and
    are read one after the other, in order of their start; a source whose stamps jump back
    from one to the next is then a restart to the calibrators. Bags that share no topic and
    overlap in time (one recording split by topic) are interleaved batch by batch by log
    time, so their streams reach the calibrators together. With a ``namespace``, the
    topics of the bench in it (:meth:`BagInfo.in_namespace`).
    """
    infos = [bag_info(p).in_namespace(namespace) for p in paths]
    order = sorted(range(len(paths)), key=lambda i: infos[i].start_ns)
    split_by_topic = all(
        not (set(infos[a].topics) & set(infos[b].topics) & set(topic_types))
        for x, a in enumerate(order) for b in order[x + 1:])
    if not split_by_topic:
        for i in order:
            for batch in iter_sample_batches(paths[i], topic_types,
                                             batch_messages=batch_messages,
                                             namespace=namespace):
                yield i, batch
        return
    iters = {i: iter_sample_batches(paths[i], topic_types, batch_messages=batch_messages,
                                    namespace=namespace)
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
