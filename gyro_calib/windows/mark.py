"""The reference mark: where on the circle the zero-index events fall (METHODS §A.2).

The mark is learnt from the events themselves (the mode of their encoder angles); an event
off it by more than ``index_angle_tolerance_arcsec`` is spurious or a jitter burst and starts
no window.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import ARCSEC_PER_RAD, format_stamp
from gyro_calib.windows.settings import TWO_PI

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.windows.index_events import IndexEvent


def angle_apart(a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """|a − b| wrapped into [0, π], rad (angles on a circle)."""
    apart: npt.NDArray[np.float64] = np.abs((np.asarray(a) - np.asarray(b) + math.pi) % TWO_PI
                                            - math.pi)
    return apart


def circular_mode(angles: list[float], tol_rad: float) -> float:
    """The angle with the most others within ``tol_rad`` of it, rad."""
    arr = np.asarray(angles)
    counts = [np.count_nonzero(angle_apart(arr, a) < tol_rad) for a in arr]
    return float(arr[int(np.argmax(counts))])


def off_mark(marks: list[float], event: IndexEvent, tolerance_arcsec: float) -> str:
    """Reason if the event is not at the reference mark, learnt from earlier events.

    ``marks`` holds the mark angles of the latest events; ``event``'s is added to them
    when it is on the mark ('' returned).
    """
    tol_rad = tolerance_arcsec / ARCSEC_PER_RAD
    angle = event.encoder_angle_rad % TWO_PI
    if len(marks) >= 3:
        agree = int(np.count_nonzero(angle_apart(np.asarray(marks), angle) < tol_rad))
        if agree < (len(marks) + 1) // 2:
            ref = circular_mode(marks, tol_rad)
            off = float(angle_apart(angle, ref)) * ARCSEC_PER_RAD
            return (f'zero-index event at {format_stamp(event.stamp_ns)} is {off:.1f}″ away '
                    f'from the reference mark (tolerance '
                    f'{tolerance_arcsec:g}″): spurious event or '
                    f'jitter burst; ignored.')
    marks.append(angle)
    del marks[:-9]
    return ''


def off_learnt_mark(marks: list[float], event: IndexEvent, tolerance_arcsec: float) -> str:
    """Reason if ``event`` (taken before the mark was learnt) is off the mark learnt since."""
    tol_rad = tolerance_arcsec / ARCSEC_PER_RAD
    if len(marks) < 3:
        return ''
    ref = circular_mode(marks, tol_rad)
    off = float(angle_apart(event.encoder_angle_rad, ref))
    if off < tol_rad:
        return ''
    return (f'zero-index event at {format_stamp(event.stamp_ns)} is '
            f'{off * ARCSEC_PER_RAD:.1f}″ away from the reference mark learnt since '
            f'(tolerance {tolerance_arcsec:g}″): spurious event; '
            f'no window starts there.')
