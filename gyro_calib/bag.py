"""Old import path of gyro_calib.bagio, kept for compatibility.

Old import path of :mod:`gyro_calib.bagio` (bag reading, writing and inspection), kept
for compatibility: it only re-exports; new code imports :mod:`gyro_calib.bagio`.
"""

from gyro_calib.bagio import *  # noqa: F403
from gyro_calib.bagio.messages import typestore as _typestore  # noqa: F401
from gyro_calib.bagio.storage import one_line as _one_line  # noqa: F401
from gyro_calib.bagio.storage import open_reader as _open_reader  # noqa: F401
from gyro_calib.bagio.storage import usable_metadata as _usable_metadata  # noqa: F401
