"""Old import path of the whole-revolution windows, now shared: :mod:`gyro_calib.windows`."""

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
