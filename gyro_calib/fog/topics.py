"""Topic contract of the FOG method (issue 10 Part 1 item 2): the shared names, re-exported."""

from __future__ import annotations

from gyro_calib.topics import (
    FOG_INJECTION,
    FOG_INJECTION_JOINT,
    FOG_JOINT,
    FOG_OUTPUT,
    FOG_SCALE_FACTOR,
    FOG_SELF_CAL_SCALE_FACTOR,
    RATE_TABLE_JOINT_STATES,
    RATE_TABLE_ZERO_INDEX,
)

__all__ = ['FOG_INJECTION', 'FOG_INJECTION_JOINT', 'FOG_JOINT', 'FOG_OUTPUT',
           'FOG_SCALE_FACTOR', 'FOG_SELF_CAL_SCALE_FACTOR', 'RATE_TABLE_JOINT_STATES',
           'RATE_TABLE_ZERO_INDEX']
