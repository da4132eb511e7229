"""Writing rosbag2 MCAP bags of the topic contract (rosbags' Writer, zstd chunks)."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib.bagio.errors import BagError
from gyro_calib.bagio.messages import CONTRACT_TYPES, HEADER, JOINT_STATE, typestore
from gyro_calib.bagio.metadata import (
    SCENARIO_KEY,
    scenario_key,
    scenario_text,
    store_custom_data,
)
from gyro_calib.bagio.storage import checksum_chunks


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
        self.store = typestore()
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

    def joints_state(self, t_ns: int, joints: Sequence[str], positions: Sequence[float],
                     frame_id: str = '') -> bytes:
        """sensor_msgs/JointState of several joints (positions only; /imu/pulses)."""
        sec, nsec = divmod(int(t_ns), 1_000_000_000)
        msg = self._joint_state(
            header=self._header(stamp=self._time(sec=sec, nanosec=nsec), frame_id=frame_id),
            name=list(joints), position=np.asarray(positions, dtype=np.float64),
            velocity=self._empty, effort=self._empty)
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
    store = typestore()
    tmp = path.with_name(f'.{path.name}.partial-{os.getpid()}')  # this run's own: two runs
    if tmp.exists():                                            # into one path never mix
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
    publish_directory(tmp, path)


def publish_directory(tmp: Path, path: Path) -> None:
    """Rename the finished ``tmp`` to ``path``; if another run wrote ``path`` meanwhile, say so.

    Raises:
        BagError: ``path`` appeared while this run wrote (``tmp`` removed; nothing written).
    """
    import shutil

    try:
        if path.exists():
            raise OSError
        tmp.rename(path)  # fails onto a directory another run has filled
    except OSError:
        shutil.rmtree(tmp, ignore_errors=True)
        raise BagError(f'{path}: another run wrote it while this one was writing; this run '
                       'wrote nothing (give each run its own path).') from None


MAX_CHUNK_BYTES = 1 << 20
"""rosbags' MCAP writer closes a chunk once it holds this many bytes of records."""


def pending_chunk(writer: Any) -> tuple[int, int]:
    """(bytes of records, messages) in the chunk rosbags' MCAP writer has not written yet."""
    chunk = getattr(getattr(writer, 'storage', None), 'chunk', None)
    if chunk is None:
        return 0, 0
    return int(chunk.bio.tell()), sum(len(m) for m in chunk.msgs.values())


def flush_chunk(writer: Any, *, sync: bool = True) -> bool:
    """Write the pending chunk of rosbags' MCAP writer to the file now; True if there was one.

    rosbags keeps up to :data:`MAX_CHUNK_BYTES` of records in memory until a chunk is full
    (rosbags 0.11.9: ``writer.storage.close_chunk``); a recording killed before then loses
    them. The chunk (with its message index records) is written, the file flushed and, with
    ``sync``, synced to the disk (os.fsync), so the file reads back to here whatever comes
    next (docs/recovery.md). A chunk holding no message yet (only the schemas and channels
    written when the bag opens) is kept: its log-time range would be empty.

    Raises:
        OSError: the disk is full or the file cannot be written.
    """
    storage = getattr(writer, 'storage', None)
    if storage is None or not pending_chunk(writer)[1]:
        return False
    storage.close_chunk()
    storage.bio.flush()
    if sync:
        os.fsync(storage.bio.fileno())
    return True
