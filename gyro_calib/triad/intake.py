"""Reading the bench topics: /imu/pulses (three channels) and both tables' streams, per bag.

:data:`TOPICS` names the streams the triad reads; a :class:`Segment` holds one bag's (one
mount's) samples, appended batch by batch by :func:`add_batch`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib import topics
from gyro_calib.errors import InsufficientDataError

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.bagio import SampleBatch

    Array = npt.NDArray[np.float64]

JOINT_STATE, HEADER = 'sensor_msgs/msg/JointState', 'std_msgs/msg/Header'
TOPICS = {topics.IMU_PULSES: JOINT_STATE,
          topics.RATE_TABLE_JOINT_STATES: JOINT_STATE, topics.RATE_TABLE_ZERO_INDEX: HEADER,
          topics.POSITION_TABLE_JOINT_STATES: JOINT_STATE,
          topics.POSITION_TABLE_ZERO_INDEX: HEADER}


@dataclass(slots=True)
class Stream:
    """Samples of one stream of one bag, appended batch by batch."""

    t: list[npt.NDArray[np.int64]] = field(default_factory=list)
    v: list[Array] = field(default_factory=list)

    def add(self, t: npt.NDArray[np.int64], v: Array) -> None:
        """Append a batch's stamps and values (none when empty)."""
        if len(t):
            self.t.append(np.asarray(t, dtype=np.int64))
            self.v.append(np.asarray(v, dtype=np.float64))

    def arrays(self, width: int) -> tuple[npt.NDArray[np.int64], Array]:
        """All samples so far in time order: stamps, values as ``width`` columns."""
        if not self.t:
            return np.zeros(0, np.int64), np.zeros((0, width))
        t = np.concatenate(self.t)
        v = np.concatenate(self.v).reshape(len(t), width)
        order = np.argsort(t, kind='stable')
        return t[order], v[order]


@dataclass(slots=True)
class Segment:
    """One bag (one mount) of data: the streams and its mount axis ('' on the two-axis bench)."""

    label: str
    mount_axis: str = ''
    pulses: Stream = field(default_factory=Stream)
    rate: Stream = field(default_factory=Stream)
    rate_index: Stream = field(default_factory=Stream)
    position: Stream = field(default_factory=Stream)
    position_index: Stream = field(default_factory=Stream)



def add_batch(seg: Segment, batch: SampleBatch) -> tuple[tuple[str, str, str] | None, int | None]:
    """Append the batch's samples to ``seg`` (3-channel /imu/pulses, tables, zero-index events).

    Returns:
        the channel names the pulse messages carry (None without three), and the newest
        pulse stamp (None without pulse samples).

    Raises:
        InsufficientDataError: /imu/pulses does not carry three channels per message.
    """
    names_given: tuple[str, str, str] | None = None
    newest: int | None = None
    col = batch.columns.get(topics.IMU_PULSES)
    if col is not None and len(col):
        pos = np.asarray(col.values['position'], dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise InsufficientDataError(
                f'{topics.IMU_PULSES} must carry three channels per message (position '
                f'of three joints); got {pos.shape[1] if pos.ndim == 2 else 1}.')
        names = col.joint_names
        if len(names) == 3:
            names_given = (str(names[0]), str(names[1]), str(names[2]))
        ok = np.all(np.isfinite(pos), axis=1)
        seg.pulses.add(col.stamp_ns[ok], pos[ok])
        newest = int(col.stamp_ns[-1])
    for topic, stream in ((topics.RATE_TABLE_JOINT_STATES, seg.rate),
                          (topics.POSITION_TABLE_JOINT_STATES, seg.position)):
        js = batch.joint_state(topic)
        if js is not None and len(js[0]):
            ok = np.isfinite(js[1]) & np.isfinite(js[2])
            stream.add(js[0][ok], np.column_stack((js[1][ok], js[2][ok])))
    for topic, stream in ((topics.RATE_TABLE_ZERO_INDEX, seg.rate_index),
                          (topics.POSITION_TABLE_ZERO_INDEX, seg.position_index)):
        st = batch.stamps(topic)
        if st is not None and len(st):
            stream.add(st, np.zeros((len(st), 1)))
    return names_given, newest
