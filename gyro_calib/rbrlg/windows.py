"""Deprecated old import path of the whole-revolution windows, removed in the next release.

The windows are shared by rbrlg and the triad since issue 26: :mod:`gyro_calib.windows`.
Kept one release for code written against the old path: it re-exports the names it gave and
warns (DeprecationWarning) when imported.
"""

import warnings as _warnings

from gyro_calib.windows import (
    RATE_BIAS_RUN_REVOLUTIONS,
    TWO_PI,
    CountAtInstant,
    IndexEvent,
    RevolutionWindow,
    WholeRevolutionWindows,
    count_at_instant,
)

__all__ = ['RATE_BIAS_RUN_REVOLUTIONS', 'TWO_PI', 'CountAtInstant', 'IndexEvent',
           'RevolutionWindow', 'WholeRevolutionWindows', 'count_at_instant']

_warnings.warn('gyro_calib.rbrlg.windows is deprecated; import from gyro_calib.windows; it '
               'will be removed in the next release', DeprecationWarning, stacklevel=2)
