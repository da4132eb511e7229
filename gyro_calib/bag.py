"""Deprecated old import path of :mod:`gyro_calib.bagio`, removed in the next release.

Kept one release for code written against it: it re-exports :mod:`gyro_calib.bagio` (bag
reading, writing and inspection) and warns (DeprecationWarning) when imported.
"""

import warnings as _warnings

from gyro_calib.bagio import *  # noqa: F403
from gyro_calib.bagio.messages import typestore as _typestore  # noqa: F401
from gyro_calib.bagio.storage import one_line as _one_line  # noqa: F401
from gyro_calib.bagio.storage import open_reader as _open_reader  # noqa: F401
from gyro_calib.bagio.storage import usable_metadata as _usable_metadata  # noqa: F401

_warnings.warn('gyro_calib.bag is deprecated; import from gyro_calib.bagio; it will be '
               'removed in the next release', DeprecationWarning, stacklevel=2)
