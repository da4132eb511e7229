"""Deprecated old import path of :mod:`gyro_calib.bagio.tables`, removed in the next release.

Kept one release for code written against it: it re-exports :mod:`gyro_calib.bagio.tables`
(CSV/text tables read wherever a bag is) and warns (DeprecationWarning) when imported.
"""

import warnings as _warnings

from gyro_calib.bagio.tables import *  # noqa: F403

_warnings.warn('gyro_calib.table_input is deprecated; import from gyro_calib.bagio.tables; it '
               'will be removed in the next release', DeprecationWarning, stacklevel=2)
