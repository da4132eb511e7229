"""A live node's inputs: messages buffered per topic, merged by stamp, taken as columns.

Each reader's callback hands its message to :class:`LiveInputs`; the watermark merge
(:class:`~gyro_calib.streams.WatermarkMerge`) releases them in the order of a recording, so
the session sees what a bag replay gives (bit for bit the offline numbers).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from typing import Any, cast

import numpy as np
from sensor_msgs.msg import Imu, JointState, Temperature
from std_msgs.msg import Header

from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.bagio.messages import JOINT_WIDTHS
from gyro_calib.nodes.ros_io import INPUT_HOLD_S, stamp_to_ns
from gyro_calib.registry import HEADER, IMU, JOINT_STATE, TEMPERATURE
from gyro_calib.streams import WatermarkMerge

MESSAGE_CLASSES = {JOINT_STATE: JointState, HEADER: Header, IMU: Imu, TEMPERATURE: Temperature}


def _values(msgtype: str, msg: Any, width: int = 1) -> tuple[float, ...]:
    """The columns :mod:`gyro_calib.bagio.columns` decodes, from one live message.

    A JointState topic of ``width`` joints (:data:`~gyro_calib.bagio.messages.JOINT_WIDTHS`)
    gives its first ``width`` positions (NaN where absent), then the first velocity.
    """
    if msgtype == JOINT_STATE:
        positions = tuple(float(msg.position[k]) if len(msg.position) > k else math.nan
                          for k in range(width))
        return (*positions, float(msg.velocity[0]) if len(msg.velocity) else math.nan)
    if msgtype == IMU:
        w, a = msg.angular_velocity, msg.linear_acceleration
        return (w.x, w.y, w.z, a.x, a.y, a.z)
    if msgtype == TEMPERATURE:
        return (float(msg.temperature), float(msg.variance))
    return ()


class TopicBuffer:
    """Samples of one topic since the last hand-over, as TopicColumns rows."""

    def __init__(self, topic: str, msgtype: str, inputs: LiveInputs) -> None:
        """An empty buffer of ``topic`` (its message type), feeding ``inputs``' merge."""
        self.topic, self.msgtype = topic, msgtype
        self.inputs = inputs
        self.stamps: list[int] = []
        self.rows: list[tuple[float, ...]] = []
        self.frames: list[int] = []
        self.names: list[str] = []
        self._codes: dict[str, int] = {}
        self.width = JOINT_WIDTHS.get(topic, 1) if msgtype == JOINT_STATE else 1
        self.joint_names: tuple[str, ...] = ()

    def add(self, msg: Any) -> None:
        """One message from the reader, into the stamp merge (:meth:`put` when released)."""
        header = msg if self.msgtype == HEADER else msg.header
        if self.width > 1 and len(msg.name) >= self.width:
            self.joint_names = tuple(str(n) for n in msg.name[:self.width])
        self.inputs.add(self.topic, stamp_to_ns(header.stamp),
                        (_values(self.msgtype, msg, self.width), header.frame_id))

    def put(self, stamp: int, row: tuple[float, ...], frame_id: str) -> None:
        """One released sample, to be handed over by :meth:`take`."""
        self.stamps.append(stamp)
        self.rows.append(row)
        code = self._codes.get(frame_id)
        if code is None:
            code = self._codes[frame_id] = len(self.names)
            self.names.append(frame_id)
        self.frames.append(code)

    def take(self) -> TopicColumns | None:
        """The samples put since the last take, as columns (None when there are none)."""
        if not self.stamps:
            return None
        t = np.asarray(self.stamps, dtype=np.int64)
        rows = np.asarray(self.rows, dtype=np.float64).reshape(len(t), -1)
        values: dict[str, np.ndarray] = {}
        if self.msgtype == JOINT_STATE:
            w = self.width
            values = {'position': rows[:, :w] if w > 1 else rows[:, 0], 'velocity': rows[:, w]}
        elif self.msgtype == IMU:
            values = {'angular_velocity_rad_s': rows[:, 0:3],
                      'linear_acceleration_m_s2': rows[:, 3:6]}
        elif self.msgtype == TEMPERATURE:
            values = {'temperature_degc': rows[:, 0], 'variance_degc2': rows[:, 1]}
        cols = TopicColumns(self.topic, self.msgtype, t.copy(), t,
                            FrameIds(np.asarray(self.frames, dtype=np.int32), tuple(self.names)),
                            values, self.joint_names)
        self.stamps, self.rows, self.frames = [], [], []
        return cols


class LiveInputs:
    """Every input topic of a live calibration node, merged by stamp before the session.

    Each reader's callback hands its message to one :class:`~gyro_calib.streams.WatermarkMerge`
    (the wall clock it is given runs only while the node is free to take messages: time
    spent in :meth:`busy` callbacks does not count towards :data:`INPUT_HOLD_S`);
    :meth:`take` releases what the watermark passed into the per-topic buffers and hands it
    over as columns, in the order of a recording.
    """

    def __init__(self, topic_types: Mapping[str, str]) -> None:
        """One buffer per topic (topic → message type), one merge over them all."""
        self.buffers = {topic: TopicBuffer(topic, msgtype, self)
                        for topic, msgtype in topic_types.items()}
        self.merge = WatermarkMerge(tuple(topic_types), hold_s=INPUT_HOLD_S)
        self.arrived = 0
        """Messages the readers delivered so far."""
        self.ended = False
        """The input ended (the node is stopping): release everything held."""
        self._busy_s = 0.0

    def now(self) -> float:
        """Monotonic wall time, s, less the time spent in :meth:`busy` callbacks."""
        return time.monotonic() - self._busy_s

    def busy(self, fn: Callable[[], None]) -> Callable[[], None]:
        """``fn`` (a timer callback), its run time kept off the merge's clock."""
        def timed() -> None:
            start = time.monotonic()
            try:
                fn()
            finally:
                self._busy_s += time.monotonic() - start
        return timed

    def add(self, topic: str, stamp: int, payload: tuple[tuple[float, ...], str]) -> None:
        """One message of ``topic``: held until the watermark passes its stamp."""
        self.arrived += 1
        self.merge.add(topic, stamp, payload, self.now())

    def take(self, *, flush: bool = False) -> tuple[dict[str, TopicColumns],
                                                    list[tuple[str, int]]]:
        """What the watermark released, per topic; and the (topic, stamp) that came late."""
        for topic, stamp, payload in self.merge.release(self.now(), flush=flush or self.ended):
            row, frame_id = cast('tuple[tuple[float, ...], str]', payload)
            self.buffers[topic].put(stamp, row, frame_id)
        columns = {t: c for t, b in self.buffers.items() if (c := b.take()) is not None}
        return columns, self.merge.take_late()

    def pending(self) -> int:
        """Messages received and not yet handed over (held or buffered)."""
        return self.merge.held() + sum(len(b.stamps) for b in self.buffers.values())

    def clear(self) -> int:
        """Drop everything not yet handed over (a new session); how many were dropped."""
        dropped = self.pending()
        for buf in self.buffers.values():
            buf.take()
        self.merge.clear()
        return dropped
