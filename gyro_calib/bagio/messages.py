"""Message types of the topic contract and their typestore.

Message types of the topic contract, the contract's topic → type table, and the ROS 2
Kilted typestore that (de)serialises them (message layouts only: no method knowledge).
"""

from __future__ import annotations

import functools
from typing import Any

from gyro_calib import topics

JOINT_STATE = 'sensor_msgs/msg/JointState'
HEADER = 'std_msgs/msg/Header'
IMU = 'sensor_msgs/msg/Imu'
TEMPERATURE = 'sensor_msgs/msg/Temperature'

CONTRACT_TYPES: dict[str, str] = {
    topics.GYRO_PULSES: JOINT_STATE,
    topics.RATE_TABLE_JOINT_STATES: JOINT_STATE,
    topics.RATE_TABLE_ZERO_INDEX: HEADER,
    topics.POSITION_TABLE_JOINT_STATES: JOINT_STATE,
    topics.POSITION_TABLE_ZERO_INDEX: HEADER,
    topics.FOG_OUTPUT: JOINT_STATE,
    topics.FOG_INJECTION: JOINT_STATE,
    topics.VIBRATION_TABLE_JOINT_STATES: JOINT_STATE,
    topics.GYRO_TEMPERATURE: TEMPERATURE,
    topics.IMU_PULSES: JOINT_STATE,
}
"""Message type of every input topic of the contract (docs/reference/topic-contract.md); the method
registry's topics are exactly these, in this order (test/test_layers.py checks it)."""

JOINT_WIDTHS: dict[str, int] = {topics.IMU_PULSES: 3}
"""JointState topics whose messages carry several joints: their ``position`` column is
(n, width), the joints in message order (the triad's three channels); every other JointState
topic has one joint."""

_TOPIC_ORDER = {name: i for i, name in enumerate(CONTRACT_TYPES)}


def topic_sort_key(topic: str) -> int:
    """Tie-break of messages with equal log time: contract order, then others."""
    return _TOPIC_ORDER.get(topic, len(_TOPIC_ORDER))


@functools.cache
def typestore() -> Any:
    """The ROS 2 Kilted typestore of rosbags (CDR layouts of every message type)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_KILTED)
