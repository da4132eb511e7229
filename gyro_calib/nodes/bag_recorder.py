"""bag_recorder: record topics from DDS into a rosbag2 MCAP bag, like ``ros2 bag record``.

Subscribes reliable/keep-all (nothing dropped at the bench's rates) and writes each
message's CDR bytes unchanged, with the receive time as log time (rosbag2's default)
or, with ``log_time:=header``, the message's header stamp. A scenario description
published by the simulators on /sim/scenario (std_msgs/String, YAML, transient-local)
is stored in the bag's metadata under ``custom_data['gyro_calib.scenario']``.
The bag is closed properly on Ctrl-C / SIGINT, or after ``duration_s``.

Killed (SIGKILL, power loss) or stopped by a full disk, the recorder leaves a .mcap file
without summary that gyro-calib reads back up to its last written chunk
(docs/recovery.md): every chunk is written and synced to the disk once it holds
``chunk_size_bytes`` of messages or its first message is ``flush_interval_s`` old, so at
most the messages of the last ``flush_interval_s`` (and at most ``chunk_size_bytes``) are
lost. A full disk ends the recording with one error line naming the bag (exit status 1).

Parameters: ``out`` (bag directory to create, required), ``topics`` (default: the
calibration inputs of the topic contract), ``namespaces`` (the benches whose contract topics
are recorded, e.g. ``['/bench1', '/bench2']``; default the root: one bench), ``duration_s``
(0 = until stopped), ``log_time`` (``receive`` | ``header``), ``flush_interval_s`` (default
1.0) and ``chunk_size_bytes`` (default and most 1 MiB, rosbags' chunk size). Each namespaced
bench's
scenario is stored under its own key (:func:`gyro_calib.bagio.scenario_key`).

    bag_recorder --ros-args -p out:=my_run
    bag_recorder --ros-args -p out:=lab -p "namespaces:=['/bench1', '/bench2']"
"""

from __future__ import annotations

import functools
import sys
import time
from pathlib import Path
from typing import Any

import yaml
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from std_msgs.msg import String

from gyro_calib import topics
from gyro_calib.bagio import (
    CONTRACT_TYPES,
    BagError,
    checksum_chunks,
    scenario_key,
    scenario_text,
    store_custom_data,
)
from gyro_calib.bagio.writer import MAX_CHUNK_BYTES, flush_chunk, pending_chunk
from gyro_calib.errors import GyroCalibError
from gyro_calib.nodes.bag_player import message_class
from gyro_calib.nodes.ros_io import (
    SCENARIO_READER_QOS,
    SENSOR_QOS,
    described_parameter,
    make_executor,
    refuse_misspelt_parameters,
    report_unused_parameters,
    spin_until_quiet,
    stamp_to_ns,
)


class BagRecorder(Node):
    """Writes every received message of the chosen topics to one bag."""

    def __init__(self) -> None:
        """Declare parameters, open the bag, subscribe."""
        super().__init__('bag_recorder')
        param = functools.partial(described_parameter, self)

        out = str(param('out', '', 'Bag directory to create (required; must not exist).'))
        given = [t for t in param('topics', [''], 'Topics to record (default: the '
                                  'calibration inputs).') if t]
        try:
            self.namespaces = sorted({topics.normalized_namespace(n) for n in param(
                'namespaces', [''], "Namespaces of the benches recorded ([''] = the root): "
                'the contract topics under each (unless topics is given) and its scenario.')})
        except ValueError as exc:
            raise GyroCalibError(f'parameter namespaces: {exc}') from None
        names = given or [ns + t for ns in self.namespaces for t in CONTRACT_TYPES]
        self.duration_s = float(param('duration_s', 0.0, 'Stop after this many seconds '
                                      '(0 = until stopped).'))
        self.log_time = str(param('log_time', 'receive', 'Log time of each message: '
                                  'receive (as rosbag2) or header (its header stamp).'))
        self.flush_interval_s = float(param(
            'flush_interval_s', 1.0, 'Write (and sync) each chunk once its first message is '
            'this old, s: a killed recorder loses at most this much (docs/recovery.md).'))
        self.chunk_size_bytes = int(param(
            'chunk_size_bytes', MAX_CHUNK_BYTES, 'Write each chunk once it holds this many '
            f'bytes of messages (at most {MAX_CHUNK_BYTES}, rosbags\' chunk size).'))
        refuse_misspelt_parameters(self)  # before anything is opened
        if not out:
            raise GyroCalibError('parameter out (the bag directory to create) is required.')
        if not 0 < self.flush_interval_s <= 3600:
            raise GyroCalibError(f'flush_interval_s must be in (0, 3600] s, got '
                                 f'{self.flush_interval_s:g}.')
        if not 0 < self.chunk_size_bytes <= MAX_CHUNK_BYTES:
            raise GyroCalibError(f'chunk_size_bytes must be in (0, {MAX_CHUNK_BYTES}], got '
                                 f'{self.chunk_size_bytes}.')
        if self.log_time not in ('receive', 'header'):
            raise GyroCalibError(f'log_time must be receive or header, got {self.log_time!r}.')
        self.path = Path(out)
        if self.path.exists():
            raise BagError(f'{self.path}: exists already; not overwriting it.')
        types = {name: self._type_of(name) for name in names}
        self.counts = dict.fromkeys(names, 0)
        self.scenarios: dict[str, dict[str, Any]] = {ns: {} for ns in self.namespaces}
        self._writer, self._connections = self._open(types)
        for name, msgtype in types.items():
            cls = message_class(msgtype)
            self.create_subscription(
                cls, name, lambda raw, n=name, c=cls: self._on_message(n, c, raw),
                SENSOR_QOS, raw=True)
        for ns in self.namespaces:
            self.create_subscription(String, ns + topics.SIM_SCENARIO,
                                     functools.partial(self._on_scenario, ns),
                                     SCENARIO_READER_QOS)
        self.started = time.monotonic()
        self.failed = ''  # the write error that ended the recording (a full disk)
        self._chunk_started: float | None = None
        self.create_timer(max(min(self.flush_interval_s / 4, 0.25), 0.01), self._flush_if_due)

    def _type_of(self, name: str, timeout_s: float = 10.0) -> str:
        """The type of a topic to record.

        Contract topics (in any recorded namespace) have fixed types; others are looked up
        in the ROS graph.
        """
        for ns in self.namespaces:
            if name.startswith(ns + '/') and name[len(ns):] in CONTRACT_TYPES:
                return CONTRACT_TYPES[name[len(ns):]]
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for topic, kinds in self.get_topic_names_and_types():
                if topic == name and kinds:
                    return kinds[0]
            time.sleep(0.1)
        raise GyroCalibError(f'topic {name}: no publisher found within {timeout_s:g} s, so '
                             'its message type is unknown.')

    def _open(self, types: dict[str, str]) -> tuple[Any, dict[str, Any]]:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
        from rosbags.typesys import Stores, get_typestore

        store = get_typestore(Stores.ROS2_KILTED)
        writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        writer.open()
        checksum_chunks(writer)
        return writer, {name: writer.add_connection(name, msgtype, typestore=store)
                        for name, msgtype in types.items()}

    def _on_message(self, name: str, cls: type, raw: bytes) -> None:
        if self.log_time == 'header':
            msg: Any = deserialize_message(raw, cls)
            stamp = msg.stamp if hasattr(msg, 'stamp') else msg.header.stamp
            log_ns = stamp_to_ns(stamp)
        else:
            log_ns = self.get_clock().now().nanoseconds
        if self.failed:
            return
        try:
            self._writer.write(self._connections[name], log_ns, raw)
            self.counts[name] += 1
            if self._chunk_started is None:
                self._chunk_started = time.monotonic()
            if pending_chunk(self._writer)[0] >= self.chunk_size_bytes:
                self._flush()
        except OSError as exc:
            self._fail(exc)

    def _flush_if_due(self) -> None:
        if self.failed or self._chunk_started is None:
            return
        if time.monotonic() - self._chunk_started >= self.flush_interval_s:
            try:
                self._flush()
            except OSError as exc:
                self._fail(exc)

    def _flush(self) -> None:
        flush_chunk(self._writer)
        self._chunk_started = None

    def _fail(self, exc: OSError) -> None:
        """Stop recording: the file keeps every chunk written before (a full disk)."""
        self.failed = f'{exc.strerror or exc}'
        self.get_logger().error(
            f'{self.path}: cannot write ({self.failed}); recording stopped. The bag reads '
            'back up to its last whole chunk; `gyro-calib repair` writes a closed copy of it.')

    def _on_scenario(self, namespace: str, msg: String) -> None:
        try:
            part = yaml.safe_load(msg.data)
        except yaml.YAMLError as exc:
            self.get_logger().warning(f'{topics.SIM_SCENARIO}: not YAML ({exc}); ignored.')
            return
        if isinstance(part, dict):
            self.scenarios[namespace].update(part)

    @property
    def done(self) -> bool:
        """True once ``duration_s`` has passed (if set), or a write failed."""
        return bool(self.failed) or (
            self.duration_s > 0 and time.monotonic() - self.started >= self.duration_s)

    def close(self) -> None:
        """Store the scenario and close the bag (writes metadata.yaml).

        After a failed write the bag is left as it is (unclosed, every chunk before whole).
        """
        if self.failed:
            return
        for ns, scenario in self.scenarios.items():
            if scenario:
                self._writer.set_custom_data(scenario_key(ns), scenario_text(scenario))
        self._writer.close()
        for ns, scenario in self.scenarios.items():  # unfolded: a fold can split an escape
            if scenario:
                store_custom_data(self.path, scenario_key(ns), scenario_text(scenario))
        summary = ', '.join(f'{name}: {n}' for name, n in self.counts.items())
        self.get_logger().info(f'wrote {self.path} ({summary})')


def main(args: list[str] | None = None) -> None:
    """Record until Ctrl-C / SIGINT / SIGTERM (or ``duration_s``), then close the bag.

    On a stop request the recorder first writes what its readers already hold: a
    reliable writer counts a sample delivered once our DDS reader has it, before our
    callback ran, so closing at once would lose the acknowledged backlog.
    """
    import signal
    import threading

    from gyro_calib.nodes.ros_distribution import ros_context

    stop = threading.Event()
    recorder = None
    with ros_context(args, own_signals=True):
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: stop.set())
        try:
            recorder = BagRecorder()
        except GyroCalibError as exc:
            print(f'bag_recorder: error: {exc}', file=sys.stderr)  # bad input
            raise SystemExit(2) from None
        report_unused_parameters(recorder)
        recorder.get_logger().info(f'recording {", ".join(recorder.counts)} to '
                                   f'{recorder.path}')
        executor = make_executor()
        executor.add_node(recorder)
        try:
            while not stop.is_set() and not recorder.done:
                executor.spin_once(timeout_sec=0.1)
            spin_until_quiet(executor, lambda: sum(recorder.counts.values()))
        except ExternalShutdownException:
            pass
        finally:
            try:
                recorder.close()
            except OSError as exc:  # the disk filled while closing: the chunks before are kept
                recorder._fail(exc)
    if recorder is not None and recorder.failed:
        raise SystemExit(1)


if __name__ == '__main__':
    main()
