"""Old import path of :mod:`gyro_calib.bagio.reader` (bag reading, writing and inspection),
kept for compatibility: it only re-exports; new code imports :mod:`gyro_calib.bagio`."""

from gyro_calib.bagio.reader import *  # noqa: F403
from gyro_calib.bagio.reader import _open_reader, _typestore  # noqa: F401
