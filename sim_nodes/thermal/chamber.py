"""Temperature chamber: a programme of soaks at set points and ramps at set rates.

The chamber air temperature follows its programme exactly: piecewise linear in time
(soak = a segment of zero slope, ramp = a segment of constant slope). A real chamber's
controller ripple and air-flow non-uniformity are not modelled here; the gyro's own
thermal lags (:mod:`sim_nodes.thermal.gyro`) make its cavity temperatures smooth.

Programmes used as scenarios (METHODS §D.2, §D.4):

- :func:`paper_soak_programme`: the paper's fixed-point calibration, −35…35 °C at seven
  set points, 1 h soak each, joined by ramps (the paper gives no ramp rate: 1 °C/min);
- :func:`ramp_programme`: continuous slow ramps between two temperatures with dwells at
  the ends (the paper's second calibration style);
- :func:`ramp_only_programme`: ramps back and forth at changing rates, never dwelling (a
  soak-free chamber run).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike

PAPER_SET_POINTS_C = (-35.0, -25.0, -15.0, 0.0, 15.0, 25.0, 35.0)
"""The paper's seven temperature points, °C (METHODS §D.4)."""


@dataclass(frozen=True, slots=True)
class ChamberProfile:
    """Piecewise-linear chamber air temperature.

    Attributes:
        start_c: air temperature at t = 0, °C.
        segments: (duration_s, end_c) pairs: the air moves linearly from the previous end
            temperature to ``end_c`` over ``duration_s`` seconds. After the last segment the
            temperature holds.
    """

    start_c: float
    segments: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        """Check every duration is positive and every temperature finite."""
        if not math.isfinite(self.start_c):
            raise ValueError(f'start_c = {self.start_c!r} must be finite')
        for i, (duration_s, end_c) in enumerate(self.segments):
            if not (math.isfinite(duration_s) and duration_s > 0 and math.isfinite(end_c)):
                raise ValueError(f'segment {i} = ({duration_s!r}, {end_c!r}) needs a positive '
                                 'duration in s and a finite end temperature in °C')

    @property
    def duration_s(self) -> float:
        """Length of the programme, s."""
        return float(sum(d for d, _ in self.segments))

    def breakpoints_s(self) -> npt.NDArray[np.float64]:
        """Segment boundaries, s from the start (first 0, last = duration_s)."""
        return np.concatenate(([0.0], np.cumsum([d for d, _ in self.segments])))

    def breakpoint_temperatures_c(self) -> npt.NDArray[np.float64]:
        """Air temperature at each breakpoint, °C."""
        return np.array([self.start_c] + [c for _, c in self.segments])

    def temperature_c(self, t_s: ArrayLike) -> npt.NDArray[np.float64]:
        """Air temperature at ``t_s`` (s from the start), °C; held before 0 and after the end."""
        return np.interp(np.asarray(t_s, np.float64), self.breakpoints_s(),
                         self.breakpoint_temperatures_c())

    def slope_at(self, t_s: float) -> tuple[float, float]:
        """Slope of the segment holding ``t_s`` (°C/s) and the next breakpoint after it (s).

        Beyond the end the slope is 0 and the next breakpoint is infinity.
        """
        breaks = self.breakpoints_s()
        temps = self.breakpoint_temperatures_c()
        i = int(np.searchsorted(breaks, t_s, side='right')) - 1
        if i < 0:
            return 0.0, float(breaks[0])
        if i >= len(self.segments):
            return 0.0, math.inf
        return float((temps[i + 1] - temps[i]) / (breaks[i + 1] - breaks[i])), float(breaks[i + 1])


def soak_programme(set_points_c: Sequence[float], *, soak_s: float,
                   ramp_rate_c_per_min: float, start_c: float | None = None) -> ChamberProfile:
    """Soak at each set point in turn, joined by ramps at ``ramp_rate_c_per_min``.

    The chamber starts at ``start_c`` (default: the first set point, so the first soak
    begins at once: the gyro is switched on already cold-soaked).
    """
    if ramp_rate_c_per_min <= 0 or soak_s <= 0 or not set_points_c:
        raise ValueError('need set points, soak_s > 0 and ramp_rate_c_per_min > 0')
    first = float(set_points_c[0]) if start_c is None else float(start_c)
    segments: list[tuple[float, float]] = []
    current = first
    for point in set_points_c:
        if point != current:
            segments.append((abs(point - current) / ramp_rate_c_per_min * 60.0, float(point)))
            current = float(point)
        segments.append((float(soak_s), float(point)))
    return ChamberProfile(first, tuple(segments))


def paper_soak_programme(soak_s: float = 3600.0,
                         ramp_rate_c_per_min: float = 1.0) -> ChamberProfile:
    """The paper's fixed-point programme: 7 set points −35…35 °C, 1 h soak each (§D.4)."""
    return soak_programme(PAPER_SET_POINTS_C, soak_s=soak_s,
                          ramp_rate_c_per_min=ramp_rate_c_per_min)


def ramp_programme(low_c: float, high_c: float, *, rate_c_per_min: float, cycles: int = 1,
                   dwell_s: float = 1800.0, start_c: float | None = None) -> ChamberProfile:
    """Continuous ramps low → high → low (``cycles`` times), dwelling ``dwell_s`` at the ends.

    The chamber starts at ``start_c`` (default ``low_c``) and dwells there first.
    """
    if not high_c > low_c or rate_c_per_min <= 0 or cycles < 1 or dwell_s <= 0:
        raise ValueError('need high_c > low_c, rate_c_per_min > 0, cycles >= 1, dwell_s > 0')
    first = float(low_c) if start_c is None else float(start_c)
    segments: list[tuple[float, float]] = []
    if first != low_c:
        segments.append((abs(first - low_c) / rate_c_per_min * 60.0, float(low_c)))
    ramp_s = (high_c - low_c) / rate_c_per_min * 60.0
    segments.append((dwell_s, float(low_c)))
    for _ in range(cycles):
        segments += [(ramp_s, float(high_c)), (dwell_s, float(high_c)),
                     (ramp_s, float(low_c)), (dwell_s, float(low_c))]
    return ChamberProfile(first, tuple(segments))


def ramp_only_programme(low_c: float, high_c: float, *, rates_c_per_min: Sequence[float],
                        duration_s: float, start_hot: bool = False) -> ChamberProfile:
    """Ramps between ``low_c`` and ``high_c`` and back.

    Ramps between ``low_c`` and ``high_c`` and back, never dwelling, the k-th leg at the
    k-th rate of ``rates_c_per_min`` (cycled), until ``duration_s``; the chamber starts at
    ``low_c`` (``high_c`` with ``start_hot``), the gyro already at the chamber temperature.
    """
    if not high_c > low_c or not rates_c_per_min or min(rates_c_per_min) <= 0 \
            or duration_s <= 0:
        raise ValueError('need high_c > low_c, positive rates_c_per_min and duration_s > 0')
    current = float(high_c if start_hot else low_c)
    segments: list[tuple[float, float]] = []
    t, k = 0.0, 0
    while t < duration_s:
        target = float(low_c if current == high_c else high_c)
        leg_s = abs(target - current) / float(rates_c_per_min[k % len(rates_c_per_min)]) * 60.0
        segments.append((leg_s, target))
        t += leg_s
        current = target
        k += 1
    return ChamberProfile(float(high_c if start_hot else low_c), tuple(segments))
