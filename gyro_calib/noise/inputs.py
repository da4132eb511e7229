"""Which input a noise run reads: the topics, their message types, and the choice among them.

One run characterises one sensor (:mod:`gyro_calib.noise.session`): ``/gyro/pulses``,
``/fog/output``, ``/imu/pulses`` (a triad) or any ``sensor_msgs/Imu`` topic — the one asked
for (flag, node parameter, the bag's stored ``bench.topic``), else the only one in the bag
(METHODS §E).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from gyro_calib import topics
from gyro_calib.errors import ConfigError

if TYPE_CHECKING:
    from gyro_calib.session import CalibrationOptions

JOINT_STATE = 'sensor_msgs/msg/JointState'
IMU = 'sensor_msgs/msg/Imu'
GYRO_PULSES = topics.GYRO_PULSES
FOG_OUTPUT = topics.FOG_OUTPUT
GYRO_TOPICS = {GYRO_PULSES: JOINT_STATE, FOG_OUTPUT: JOINT_STATE}
"""The single-axis gyro streams (topic → type)."""
IMU_PULSES = topics.IMU_PULSES
JOINT_TOPICS = {**GYRO_TOPICS, IMU_PULSES: JOINT_STATE}
"""Every JointState input (the single-axis streams and a triad's three channels)."""
TABLE_TOPICS = {topics.RATE_TABLE_JOINT_STATES: JOINT_STATE,
                topics.POSITION_TABLE_JOINT_STATES: JOINT_STATE}
"""Optional inputs: the rate table's and the position table's joint states. The samples
taken while a recorded table changed rate (the position table: turned) are left out, each
steady span analysed as a segment (:mod:`gyro_calib.noise.table`)."""


def input_topic(options: CalibrationOptions) -> str | None:
    """The input topic asked for, or None.

    The input topic asked for (flag, node parameter, or the bag's stored ``bench.topic``);
    None: ``/gyro/pulses`` or ``/fog/output``, whichever arrives.
    """
    topic = options.topic or options.bench('topic', None)
    return str(topic) if topic else None


def input_kind(topic: str | None) -> str:
    """'pulses', 'fog', 'triad', 'imu', or 'gyro' (either single-axis stream) for a topic."""
    if topic is None:
        return 'gyro'
    return {GYRO_PULSES: 'pulses', FOG_OUTPUT: 'fog', IMU_PULSES: 'triad'}.get(topic, 'imu')


def select_input(present: Mapping[str, tuple[str, int]], options: CalibrationOptions, *,
                 where: str, listing: str) -> str:
    """The topic ``gyro-calib noise`` reads in a bag.

    The topic ``gyro-calib noise`` reads in a bag: the one asked for, checked, or the only
    candidate (``/gyro/pulses``, ``/fog/output``, an Imu topic).

    Args:
        present: topic → (message type, message count) in the bag(s).
        options: the user's options (``topic``; the stored scenario's ``bench.topic``).
        where: the bag path(s), for messages.
        listing: 'topic (type, n), …' of the bag(s), for messages.

    Raises:
        MissingTopicError: the topic asked for is absent or empty, or no candidate is there.
        WrongMessageTypeError: the topic asked for carries another message type.
        ConfigError: several candidates and none asked for.
    """
    from gyro_calib.bagio import MissingTopicError, WrongMessageTypeError

    asked = options.topic
    if asked:
        want = JOINT_TOPICS.get(asked, IMU)
        if asked not in present:
            raise MissingTopicError(f'{where}: no topic {asked} in the bag(s); they hold '
                                    f'{listing}.')
        msgtype, count = present[asked]
        if msgtype != want:
            what = ('the pulse/FOG streams are JointState' if asked in JOINT_TOPICS else
                    f'any other topic must be {IMU} (the pulse and FOG streams are '
                    f'{GYRO_PULSES} and {FOG_OUTPUT}, {JOINT_STATE})')
            raise WrongMessageTypeError(f'{where}: topic {asked} has type {msgtype}, but '
                                        f'gyro-calib noise reads {want} there ({what}); the '
                                        f'bag(s) hold {listing}.')
        if count == 0:
            raise MissingTopicError(f'{where}: topic {asked} holds no message; the bag(s) '
                                    f'hold {listing}.')
        return asked
    candidates = [t for t, m in JOINT_TOPICS.items()
                  if t in present and present[t][0] == m and present[t][1] > 0]
    candidates += sorted(t for t, (m, n) in present.items() if m == IMU and n > 0)
    stored = options.bench('topic', None)
    if stored in candidates:
        return str(stored)
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise MissingTopicError(
            f'{where}: nothing to characterise: gyro-calib noise reads {GYRO_PULSES}, '
            f'{FOG_OUTPUT} or {IMU_PULSES} ({JOINT_STATE}) or a {IMU} topic (--topic); the '
            f'bag(s) hold '
            f'{listing}.')
    raise ConfigError(f'{where}: several inputs to characterise ({", ".join(candidates)}); '
                      f'choose one with --topic (one run per sensor); the bag(s) hold '
                      f'{listing}.')
