"""Old import path of gyro_calib.bagio.columns, kept for compatibility.

Old import path of :mod:`gyro_calib.bagio.columns` (the columnar MCAP decoder), kept for
compatibility: it only re-exports; new code imports :mod:`gyro_calib.bagio.columns`.
"""

from gyro_calib.bagio.columns import *  # noqa: F403
