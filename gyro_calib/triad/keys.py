"""The triad method's name and hand-off keys (its results go to the ``imu:`` section)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gyro_calib.handoff import HandoffKey

METHOD = 'triad'

HANDOFF_KEYS: tuple[HandoffKey, ...] = ()
"""None at the top level: K, sense axes, M and b of the three channels are the file's
``imu:`` section (:mod:`gyro_calib.imu_calibration`)."""
