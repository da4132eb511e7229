"""The spans of a table record: steady segments, the changes between, the segment being built.

A table's states fall into *steady segments* (one constant rate; rest is the rate 0) and the
stretches between them, where the table changed rate or turned (:class:`MotionSpan`). The
segment being built keeps running sums for its least-squares line (:class:`_Current`). What
decides a segment's end is :class:`~gyro_calib.noise.table_motion.TableMotion`; the whole
story is :mod:`gyro_calib.noise.table` (METHODS §E.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_BEFORE = np.iinfo(np.int64).min
_AFTER = np.iinfo(np.int64).max


@dataclass(slots=True)
class SteadySegment:
    """One confirmed span of the table at a constant rate.

    Attributes:
        first_ns: stamp of its first state.
        last_ns: stamp of its last state (so far, while it lasts).
        states: its states.
        rate_rad_s: its rate (least-squares slope of its angles; the mean of its rates
            where no angle was given), rad/s.
        peak_before_rad_s: the largest |rate| of the states between the previous steady
            segment and this one (NaN when none lay between).
    """

    first_ns: int
    last_ns: int
    states: int
    rate_rad_s: float
    peak_before_rad_s: float = math.nan


@dataclass(slots=True)
class MotionSpan:
    """One stretch between two steady segments: the table changed rate (or turned).

    Attributes:
        start_ns: stamp of the last state of the steady segment before it (the change
            began after it); None when the record began with it.
        end_ns: stamp of the first state of the steady segment after it; None while it
            lasts (or when the record ended in it).
        max_rate_rad_s: the largest |rate| of its states (of the segments around it when
            no state lay between), rad/s.
        rate_before_rad_s: the rate of the steady segment before it (NaN: none).
        rate_after_rad_s: the rate of the steady segment after it (NaN: none).
    """

    start_ns: int | None
    end_ns: int | None
    max_rate_rad_s: float
    rate_before_rad_s: float = math.nan
    rate_after_rad_s: float = math.nan

    def what(self, rest_rate_rad_s: float) -> str:
        """'reversal', 'stop', 'start', 'move', 'change of rate' (from the rates around it)."""
        a, b = self.rate_before_rad_s, self.rate_after_rad_s
        if math.isnan(a) or math.isnan(b):
            return 'change of rate'
        if abs(a) <= rest_rate_rad_s and abs(b) <= rest_rate_rad_s:
            return 'move'
        if abs(b) <= rest_rate_rad_s:
            return 'stop'
        if abs(a) <= rest_rate_rad_s:
            return 'start'
        if a * b < 0:
            return 'reversal'
        return 'change of rate'


@dataclass(slots=True)
class _Current:
    """The segment being built: running sums of its states (t from its first, s)."""

    first_ns: int
    last_ns: int
    a0: float = math.nan
    states: int = 0
    n_a: int = 0
    s_t: float = 0.0
    s_a: float = 0.0
    s_tt: float = 0.0
    s_ta: float = 0.0
    n_r: int = 0
    s_r: float = 0.0
    peak: float = 0.0
    confirmed: bool = False

    def slope(self) -> float:
        """Least-squares slope of its angles (rad/s); NaN below two angles."""
        if self.n_a < 2:
            return math.nan
        den = self.n_a * self.s_tt - self.s_t * self.s_t
        return (self.n_a * self.s_ta - self.s_t * self.s_a) / den if den > 0 else math.nan

    def rate(self) -> float:
        """Its rate: the slope of its angles, else the mean of its rates, else 0."""
        slope = self.slope()
        if math.isfinite(slope):
            return slope
        return self.s_r / self.n_r if self.n_r else 0.0


def _nanmax(a: float, b: float) -> float:
    if math.isnan(a):
        return b
    if math.isnan(b):
        return a
    return max(a, b)


def _zero_nan(v: float) -> float:
    return 0.0 if math.isnan(v) else v

