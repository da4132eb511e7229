"""The table's direction runs: what a rate-bias run could not use, and why (METHODS §A.2).

Between reversals the table makes one direction run: an acceleration, a constant-rate
cruise, a deceleration. :class:`DirectionRun` keeps the zero-index events of one run; when it
ends, :func:`run_end_rejections` reports what a rate-bias run (a cruise of at least
:data:`RATE_BIAS_RUN_REVOLUTIONS`) gave no window for: events in the acceleration, a missing
zero-index event, a cruise too short for m revolutions. A shorter run is a positioning move
and is not judged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.units import ARCSEC_PER_RAD, NS_PER_S, format_stamp
from gyro_calib.windows.settings import TWO_PI

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.windows.index_events import IndexEvent
    from gyro_calib.windows.settings import WindowSettings

    Table = tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]
    """The table's stamps (ns), encoder angles (rad) and rates (rad/s)."""

RATE_BIAS_RUN_REVOLUTIONS = 0.9
"""A direction run whose cruise held at least this many revolutions is a rate-bias run whose
unused zero-index events are reported; a shorter one is a positioning move."""


@dataclass(slots=True)
class DirectionRun:
    """The zero-index events of one direction run of the table (between reversals)."""

    sign: float
    first_seen_ns: int = 0
    last_seen_ns: int = 0
    usable_rates: list[float] = field(default_factory=list)
    accelerating: list[IndexEvent] = field(default_factory=list)
    windows: int = 0
    tried: int = 0
    spurious: int = 0
    first_event_ns: int = 0
    last_event_ns: int = 0
    first_event_angle_rad: float = math.nan
    last_event_angle_rad: float = math.nan
    first_usable_ns: int | None = None
    last_usable_ns: int | None = None
    first_usable_angle_rad: float = math.nan
    last_usable_angle_rad: float = math.nan

    @property
    def cruise_rad_s(self) -> float | None:
        """Median rate at the usable events (the cruise).

        Median rate at the usable events (the cruise), once two were seen (two usable
        events are a whole revolution apart: this is a rate-bias run, not a positioning move).
        """
        return float(np.median(self.usable_rates)) if len(self.usable_rates) >= 2 else None


def accelerating_reason(event: IndexEvent, cruise_rad_s: float, rate_tolerance: float) -> str:
    """Why ``event``, in an acceleration against the run's cruise, starts or ends no window."""
    return (
        f'table accelerating at the zero-index event at {format_stamp(event.stamp_ns)}: '
        f'{math.degrees(event.rate_rad_s):.1f} °/s there, varying by '
        f'{event.rate_spread * 100:.2f} % within ±{event.half_width_ns / NS_PER_S:.3g} s, '
        f'against a cruise of {math.degrees(cruise_rad_s):.1f} °/s (rate_tolerance '
        f'{rate_tolerance * 100:g} %); no window starts or ends there.')


def run_end_rejections(run: DirectionRun, table: Table, cfg: WindowSettings) -> list[Rejection]:
    """What the ended direction run could not use, in the order reported.

    Only a rate-bias run is judged: one whose constant-rate cruise held at least
    RATE_BIAS_RUN_REVOLUTIONS by the encoder. A positioning move (a station change of the
    θ procedure)
    that passes the mark is not a failed window.
    """
    extent = cruise_extent(run, table, cfg)
    if extent is None or extent[0] < RATE_BIAS_RUN_REVOLUTIONS:
        return []  # a move, not a rate-bias run: nothing to report
    held, cruise, t_from, t_to = extent
    out = [Rejection(ev.stamp_ns, accelerating_reason(ev, cruise, cfg.rate_tolerance))
           for ev in run.accelerating]
    if run.windows or run.tried or run.spurious:
        return out  # a window was cut, or tried and rejected, or events ignored, with reasons
    m = cfg.revolutions_per_window
    revs = 0
    if run.first_usable_ns is not None:
        revs = round(abs(run.last_usable_angle_rad - run.first_usable_angle_rad) / TWO_PI)
        if revs >= m:
            return out
        missing = missing_at_cruise_ends(run, cruise, table, cfg)
        if missing:
            return [*out, Rejection(run.first_usable_ns, missing)]
    lost = len(run.accelerating)
    return [*out, Rejection(run.first_usable_ns if run.first_usable_ns is not None else t_from, (
        f'no window in the constant-rate cruise {format_stamp(t_from)} → '
        f'{format_stamp(t_to)} ({held:.2f} revolutions at '
        f'{math.degrees(cruise):.1f} °/s): its {len(run.usable_rates)} usable zero-index '
        f'event(s) span {revs} revolution(s), fewer than the m = {m} a window needs'
        + (f'; {lost} more fell in the acceleration or deceleration' if lost else '')
        + ' (give the table at least m + 1 revolutions of cruise between reversals, or '
        'lower revolutions_per_window).'))]


def cruise_extent(run: DirectionRun, table: Table,
                  cfg: WindowSettings) -> tuple[float, float, int, int] | None:
    """The run's constant-rate stretch, or None.

    (revolutions held, cruise rate rad/s, first stamp, last stamp) of the run's
    constant-rate stretch by the encoder, or None when the table data cannot say.

    The cruise is the median rate at the usable events; with none (every event fell in
    an acceleration) it is the run's fastest rate between its events.
    """
    t, angle, rate = table
    if len(t) < 2:
        return None
    if run.usable_rates:
        cruise = float(np.median(run.usable_rates))
        assert run.first_usable_ns is not None and run.last_usable_ns is not None
        lo = int(np.searchsorted(t, run.first_usable_ns, 'left'))
        hi = int(np.searchsorted(t, run.last_usable_ns, 'right'))
    else:  # the block of samples turning this way around the run's events
        at = min(int(np.searchsorted(t, run.first_seen_ns, 'left')), len(t) - 1)
        other = np.nonzero(run.sign * rate <= 0)[0]
        before, after = other[other < at], other[other > at]
        lo = int(before[-1]) + 1 if len(before) else 0
        hi = int(after[0]) if len(after) else len(t)
        if hi - lo < 1:
            return None
        peak = lo + int(np.argmax(run.sign * rate[lo:hi]))
        cruise, lo, hi = float(rate[peak]), peak, peak + 1
    if lo >= len(t):
        return None
    off = np.nonzero(np.abs(rate - cruise) > cfg.rate_tolerance * abs(cruise))[0]
    before, after = off[off < lo], off[off >= hi]
    first = int(before[-1]) + 1 if len(before) else 0
    last = int(after[0]) - 1 if len(after) else len(t) - 1
    first, last = min(first, lo), max(last, min(hi, len(t)) - 1)
    held = abs(float(angle[last] - angle[first])) / TWO_PI
    return held, cruise, int(t[first]), int(t[last])


def missing_at_cruise_ends(run: DirectionRun, cruise: float, table: Table,
                           cfg: WindowSettings) -> str:
    """Why a cruise gave too few events, if known.

    Why a cruise gave too few events, if the encoder shows it held its rate for a whole
    revolution beyond its first or last event: a zero-index event is missing.
    """
    t, angle, rate = table
    if len(t) < 2:
        return ''
    tol = cfg.rate_tolerance * abs(cruise)
    one_rev = TWO_PI + cfg.window_angle_tolerance_arcsec / ARCSEC_PER_RAD
    for stamp, ref, after in ((run.last_event_ns, run.last_event_angle_rad, True),
                              (run.first_event_ns, run.first_event_angle_rad, False)):
        i = int(np.searchsorted(t, stamp, 'right' if after else 'left'))
        side = rate[i:] if after else rate[:i][::-1]
        off = np.nonzero(np.abs(side - cruise) > tol)[0]
        k = int(off[0]) if len(off) else len(side)
        if k == 0:
            continue
        far = angle[i + k - 1] if after else angle[i - k]
        held = abs(float(far) - ref)
        if held >= one_rev:
            where = 'after' if after else 'before'
            return (f'no window in the constant-rate cruise around '
                    f'{format_stamp(stamp)}: the encoder shows the table held its cruise '
                    f'for {held / TWO_PI:.2f} revolutions {where} that zero-index event '
                    f'without another one: missing zero-index event.')
    return ''
