"""Topic names of the dither-misalignment method: the shared contract's names, re-exported.

The names live in :mod:`gyro_calib.topics` (the one topic contract); this module only gives
the method's code one place to import them from.
"""

from __future__ import annotations

from gyro_calib.topics import (
    DIAGNOSTICS,
    DITHER_MISALIGNMENT,
    GYRO_JOINT,
    GYRO_PULSES,
    SIM_SCENARIO,
    VIBRATION_TABLE_JOINT,
    VIBRATION_TABLE_JOINT_STATES,
)

__all__ = ['DIAGNOSTICS', 'DITHER_MISALIGNMENT', 'GYRO_JOINT', 'GYRO_PULSES', 'SIM_SCENARIO',
           'VIBRATION_TABLE_JOINT', 'VIBRATION_TABLE_JOINT_STATES']
