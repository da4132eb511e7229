"""Old import path of gyro_calib.bagio.tables, kept for compatibility.

Old import path of :mod:`gyro_calib.bagio.tables` (CSV/text tables read wherever a bag is),
kept for compatibility: it only re-exports; new code imports :mod:`gyro_calib.bagio.tables`.
"""

from gyro_calib.bagio.tables import *  # noqa: F403
