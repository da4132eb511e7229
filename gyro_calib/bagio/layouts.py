"""The fixed CDR layouts of the message families the columnar decoder reads, and their codecs.

One codec per message family: how the fixed layout of one payload is found (the columns
are then NumPy views of every payload of that layout), and how the same values are taken
from a message object rosbags' ``deserialize_cdr`` decoded (every payload not of such a
layout):

* ``sensor_msgs/msg/JointState`` of one joint: stamp, position[0], velocity[0] (NaN when
  the array is empty), frame_id; of several joints (a topic of ``messages.JOINT_WIDTHS``):
  the positions;
* ``std_msgs/msg/Header``: stamp, frame_id;
* ``sensor_msgs/msg/Imu``: stamp, angular_velocity, linear_acceleration, the first element
  of each covariance, frame_id;
* ``sensor_msgs/msg/Temperature``: stamp, temperature, variance, frame_id.

CDR rules relied on (OMG CDR / XCDR1 "plain CDR" as ROS 2 writes it, and rosbags'
deserialiser): a 4-byte encapsulation header (2-byte representation identifier, 2 option
bytes, ignored), then the body; every primitive is aligned to its own size (at most 8)
relative to the start of the body; a string is a uint32 length counting its NUL terminator,
the bytes and the NUL; a sequence is a uint32 count (aligned to 4) followed by its elements,
a float64 sequence aligned to 8 only when non-empty; fixed arrays (Imu covariances) have no
count; nested messages are laid out inline.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from gyro_calib.bagio.messages import HEADER, IMU, JOINT_STATE, JOINT_WIDTHS, TEMPERATURE

_CDR_LE = b'\x00\x01'
_NS_PER_S = 1_000_000_000


# ---------------------------------------------------------------------------------------
# The layout of one payload


class _NotNarrow(Exception):
    """The payload is not one of the fixed layouts: rosbags decodes it."""


@dataclass(frozen=True, slots=True)
class _Layout:
    """Where the fields of one fixed-layout payload are, and what fixes that layout.

    Offsets count from the start of the payload, encapsulation header included.

    Attributes:
        length: payload bytes.
        words: (offset, value) of every uint32 count or string length of the layout.
        terminators: offsets of the strings' NUL bytes.
        strings: (start, stop) of each string's characters; the first is frame_id.
        fields: (value name, offset or None when the array is empty, float64 count).
    """

    length: int
    words: tuple[tuple[int, int], ...]
    terminators: tuple[int, ...]
    strings: tuple[tuple[int, int], ...]
    fields: tuple[tuple[str, int | None, int], ...]


class _Cursor:
    """Walks one CDR payload as rosbags' deserialiser does, recording the layout.

    Alignment is relative to the body (payload offset 4), as XCDR1 requires.
    """

    def __init__(self, payload: bytes) -> None:
        if len(payload) < 4 or payload[:2] != _CDR_LE:
            raise _NotNarrow
        self.buf = payload
        self.pos = 4
        self.words: list[tuple[int, int]] = []
        self.terminators: list[int] = []
        self.strings: list[tuple[int, int]] = []

    def align(self, size: int) -> None:
        self.pos = 4 + -(-(self.pos - 4) // size) * size

    def skip(self, n: int) -> int:
        start = self.pos
        if start + n > len(self.buf):
            raise _NotNarrow
        self.pos = start + n
        return start

    def count(self) -> int:
        self.align(4)
        at = self.skip(4)
        value = int.from_bytes(self.buf[at:at + 4], 'little')
        self.words.append((at, value))
        return value

    def string(self) -> None:
        n = self.count()
        if n < 1:
            raise _NotNarrow
        start = self.skip(n)
        if self.buf[start + n - 1] != 0:
            raise _NotNarrow
        self.terminators.append(start + n - 1)
        self.strings.append((start, start + n - 1))

    def header(self) -> None:
        """std_msgs/Header: stamp (int32 sec at 4, uint32 nanosec at 8), frame_id."""
        self.skip(8)
        self.string()

    def layout(self, fields: list[tuple[str, int | None, int]]) -> _Layout:
        if not 0 <= len(self.buf) - self.pos <= 3:
            raise _NotNarrow
        return _Layout(len(self.buf), tuple(self.words), tuple(self.terminators),
                       tuple(self.strings), tuple(fields))


# ---------------------------------------------------------------------------------------
# The message families


def _joint_state_layout(payload: bytes) -> _Layout:
    """JointState with one name; position, velocity, effort of 0 or 1 element."""
    c = _Cursor(payload)
    c.header()
    if c.count() != 1:
        raise _NotNarrow
    c.string()
    fields: list[tuple[str, int | None, int]] = []
    for name in ('position', 'velocity', 'effort'):
        n = c.count()
        if n > 1:
            raise _NotNarrow
        at = None
        if n:
            c.align(8)
            at = c.skip(8)
        if name != 'effort':
            fields.append((name, at, 1))
    return c.layout(fields)


def _joints_layout(width: int) -> Callable[[bytes], _Layout]:
    """JointState with ``width`` names and positions; velocity, effort of 0 or ``width``."""
    def layout(payload: bytes) -> _Layout:
        c = _Cursor(payload)
        c.header()
        if c.count() != width:
            raise _NotNarrow
        for _ in range(width):
            c.string()
        if c.count() != width:
            raise _NotNarrow
        c.align(8)
        fields: list[tuple[str, int | None, int]] = [('position', c.skip(8 * width), width)]
        for name in ('velocity', 'effort'):
            n = c.count()
            if n not in (0, width):
                raise _NotNarrow
            at = None
            if n:
                c.align(8)
                at = c.skip(8 * n)
            if name == 'velocity':
                fields.append((name, at, 1))
        return c.layout(fields)
    return layout


def _header_layout(payload: bytes) -> _Layout:
    c = _Cursor(payload)
    c.header()
    return c.layout([])


def _imu_layout(payload: bytes) -> _Layout:
    """Imu layout: header, then 37 float64.

    Imu: header, then 37 float64 from an 8-aligned offset (quaternion, 3 × (matrix 9,
    vector 3) interleaved as orientation, cov, angular velocity, cov, acceleration, cov).
    """
    c = _Cursor(payload)
    c.header()
    c.align(8)
    at = c.skip(37 * 8)
    return c.layout([('angular_velocity_rad_s', at + 104, 3),
                     ('linear_acceleration_m_s2', at + 200, 3),
                     ('orientation_covariance_0_rad2', at + 32, 1),
                     ('angular_velocity_covariance_0_rad2_s2', at + 128, 1),
                     ('linear_acceleration_covariance_0_m2_s4', at + 224, 1)])


def _temperature_layout(payload: bytes) -> _Layout:
    c = _Cursor(payload)
    c.header()
    c.align(8)
    at = c.skip(16)
    return c.layout([('temperature_degc', at, 1), ('variance_degc2', at + 8, 1)])


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * _NS_PER_S + int(stamp.nanosec)


def _first(values: Any) -> float:
    return values[0] if len(values) else math.nan


def _joint_state_values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
    return (_stamp_ns(msg.header.stamp), msg.header.frame_id,
            (_first(msg.position), _first(msg.velocity)))


def _joints_values(width: int) -> Callable[[Any], tuple[int, str, tuple[Any, ...]]]:
    def values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
        pos = tuple(float(msg.position[k]) if len(msg.position) > k else math.nan
                    for k in range(width))
        return (_stamp_ns(msg.header.stamp), msg.header.frame_id,
                (pos, _first(msg.velocity)))
    return values


def _header_values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
    return _stamp_ns(msg.stamp), msg.frame_id, ()


def _imu_values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
    w, a = msg.angular_velocity, msg.linear_acceleration
    return (_stamp_ns(msg.header.stamp), msg.header.frame_id,
            ((w.x, w.y, w.z), (a.x, a.y, a.z), msg.orientation_covariance[0],
             msg.angular_velocity_covariance[0], msg.linear_acceleration_covariance[0]))


def _temperature_values(msg: Any) -> tuple[int, str, tuple[Any, ...]]:
    return (_stamp_ns(msg.header.stamp), msg.header.frame_id,
            (msg.temperature, msg.variance))


@dataclass(frozen=True, slots=True)
class _Codec:
    """What one message type gives and how to read it either way.

    Attributes:
        values: (value name, float64 per message) in column order.
        layout: the fixed layout of one payload (raises _NotNarrow otherwise).
        from_message: stamp, frame_id and values of a rosbags message object.
    """

    values: tuple[tuple[str, int], ...]
    layout: Callable[[bytes], _Layout]
    from_message: Callable[[Any], tuple[int, str, tuple[Any, ...]]]


CODECS: dict[str, _Codec] = {
    JOINT_STATE: _Codec((('position', 1), ('velocity', 1)), _joint_state_layout,
                        _joint_state_values),
    HEADER: _Codec((), _header_layout, _header_values),
    IMU: _Codec((('angular_velocity_rad_s', 3), ('linear_acceleration_m_s2', 3),
                 ('orientation_covariance_0_rad2', 1),
                 ('angular_velocity_covariance_0_rad2_s2', 1),
                 ('linear_acceleration_covariance_0_m2_s4', 1)), _imu_layout, _imu_values),
    TEMPERATURE: _Codec((('temperature_degc', 1), ('variance_degc2', 1)),
                        _temperature_layout, _temperature_values),
}
"""The message types the columnar decoder decodes, by ROS type name."""

_JOINTS_CODECS = {width: _Codec((('position', width), ('velocity', 1)), _joints_layout(width),
                                _joints_values(width))
                  for width in set(JOINT_WIDTHS.values())}


def codec_for(topic: str, msgtype: str) -> _Codec:
    """The codec of a topic: its type's, or the multi-joint JointState's (JOINT_WIDTHS)."""
    if msgtype == JOINT_STATE and topic in JOINT_WIDTHS:
        return _JOINTS_CODECS[JOINT_WIDTHS[topic]]
    return CODECS[msgtype]

KNOWN_TYPES = frozenset(CODECS)

