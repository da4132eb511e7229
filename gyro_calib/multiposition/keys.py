"""The multiposition method's name and hand-off keys (its results go to the ``imu:`` section)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gyro_calib.handoff import HandoffKey

METHOD = 'multiposition'

HANDOFF_KEYS: tuple[HandoffKey, ...] = ()
"""None at the top level: the gyro part (K, sense axes, M, b) and the accelerometer are the
file's ``imu:`` section (:mod:`gyro_calib.imu_calibration`)."""
