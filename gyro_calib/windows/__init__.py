"""Whole-revolution windows from zero-index events (METHODS §A.1–A.2), shared by methods.

The rbrlg (§A) and triad (§F.2) methods cut their windows here. Three steps:

1. :func:`count_at_instant` estimates the cumulative pulse count at a zero-index
   instant from the pulse samples around it by a local least-squares fit, not by
   interpolating between the two neighbouring samples: the quantisation error of
   the integer counts averages down over the fit span.
2. :func:`resolve_index_event` states the table and the gyro at one zero-index event: encoder
   angle and pulse count by the same local fit, the table rate and its spread.
3. :class:`WholeRevolutionWindows` walks the resolved index events in time order
   and cuts windows of exactly m revolutions (checked against the encoder angle)
   that lie inside one constant-rate segment.

settings      the window and fit settings (WindowFields, their checks; WindowSettings)
local_fit     the count (or encoder angle) at an instant by a local least-squares fit
index_events  the table and the gyro at one zero-index event; the fit span around it
mark          the reference mark the events fall on; events off it
checks        why a window is rejected: table not at constant rate, pulse stream gaps/jumps
runs          the table's direction runs: what a rate-bias run gave no window for, and why
cutter        the windows of m revolutions cut from the events in time order
"""

from gyro_calib.windows.cutter import RevolutionWindow, WholeRevolutionWindows
from gyro_calib.windows.index_events import (
    MAX_FIT_HALF_WIDTH_S,
    IndexEvent,
    fit_half_width_ns,
    period_near,
    resolve_index_event,
)
from gyro_calib.windows.local_fit import CountAtInstant, count_at_instant
from gyro_calib.windows.runs import RATE_BIAS_RUN_REVOLUTIONS
from gyro_calib.windows.settings import TWO_PI, WindowFields, WindowSettings

__all__ = ['MAX_FIT_HALF_WIDTH_S', 'RATE_BIAS_RUN_REVOLUTIONS', 'TWO_PI', 'CountAtInstant',
           'IndexEvent', 'RevolutionWindow', 'WholeRevolutionWindows', 'WindowFields',
           'WindowSettings', 'count_at_instant', 'fit_half_width_ns', 'period_near',
           'resolve_index_event']
