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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from gyro_calib.errors import WindowError
from gyro_calib.estimate import Rejection
from gyro_calib.units import ARCSEC_PER_RAD, NS_PER_S, format_stamp

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.config import RangeCheck

TWO_PI = 2.0 * math.pi

RATE_BIAS_RUN_REVOLUTIONS = 0.9
"""A direction run whose cruise held at least this many revolutions is a rate-bias run whose
unused zero-index events are reported; a shorter one is a positioning move."""

MAX_FIT_HALF_WIDTH_S = 2.0
"""Widest fit span half-width around an index event, whatever the pulse stream's rate, s."""


class WindowSettings(Protocol):
    """The window and fit settings the cutter reads (rbrlg KTildeConfig, triad TriadSettings).

    The fields of :class:`WindowFields` and ``window_angle_source``.
    """

    @property
    def revolutions_per_window(self) -> int:
        """See :class:`WindowFields`."""
    @property
    def fit_half_width_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def fit_order(self) -> int:
        """See :class:`WindowFields`."""
    @property
    def min_fit_samples_per_side(self) -> int:
        """See :class:`WindowFields`."""
    @property
    def max_fit_gap_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def max_fit_residual_pulses(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def rate_tolerance(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def min_rate_deg_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def window_angle_tolerance_arcsec(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def index_angle_tolerance_arcsec(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def max_table_gap_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def max_pulse_gap_s(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def pulse_jump_tolerance_pulses(self) -> float:
        """See :class:`WindowFields`."""
    @property
    def window_angle_source(self) -> str:
        """'encoder' or 'nominal' (see rbrlg KTildeConfig)."""


@dataclass(frozen=True, slots=True)
class WindowFields:
    """The window and fit settings of whole-revolution windows (METHODS §A.2), declared once.

    The base of the rbrlg ``KTildeConfig`` and the triad ``TriadSettings``: these fields come
    first in both, in this order, with these defaults; each method adds its own fields and
    checks them all at once with :meth:`window_checks` first.
    """

    revolutions_per_window: int = 5
    """m: whole revolutions in one window."""
    fit_half_width_s: float = 0.1
    """Half-width of the local least-squares fit of counts around an index instant, s."""
    fit_order: int = 1
    """Polynomial order of that fit (1 = line; 2 absorbs slow rate ripple)."""
    min_fit_samples_per_side: int = 20
    """Pulse samples needed on each side of an index instant."""
    max_fit_gap_s: float = 0.01
    """Largest gap between pulse samples allowed inside a fit span, s."""
    max_fit_residual_pulses: float = 5.0
    """Largest residual of the local fit before the index event is rejected, pulses."""
    rate_tolerance: float = 0.005
    """Allowed relative deviation of the table rate from its window median."""
    min_rate_deg_s: float = 1.0
    """Slowest table rate a window may be cut at, °/s."""
    window_angle_tolerance_arcsec: float = 60.0
    """Allowed |encoder angle of a window − m·360°|, ″ (encoder resolution + index jitter)."""
    index_angle_tolerance_arcsec: float = 30.0
    """Allowed distance of an index event's encoder angle from the reference mark, ″."""
    max_table_gap_s: float = 0.1
    """Largest gap in joint_states inside a window, s."""
    max_pulse_gap_s: float = 0.5
    """Largest gap in the pulse stream inside a window, s."""
    pulse_jump_tolerance_pulses: float = 10.0
    """Allowed step of a pulse increment from the window's median rate, pulses.

    Plus rate_tolerance.
    """

    def window_checks(self, *, angle_within_half_turn: bool,
                      jump_may_be_zero: bool) -> list[RangeCheck]:
        """The range checks of these fields, in field order (for ``check_ranges``).

        ``angle_within_half_turn``: window_angle_tolerance_arcsec must stay below half a
        revolution (else only positive); ``jump_may_be_zero``: pulse_jump_tolerance_pulses
        may be 0 (else positive).
        """
        angle: RangeCheck = (
            ('window_angle_tolerance_arcsec', 0 < self.window_angle_tolerance_arcsec < 648000,
             'between 0 and 648000 (half a revolution)') if angle_within_half_turn else
            ('window_angle_tolerance_arcsec', self.window_angle_tolerance_arcsec > 0,
             'positive'))
        jump: RangeCheck = (
            ('pulse_jump_tolerance_pulses', self.pulse_jump_tolerance_pulses >= 0,
             'non-negative') if jump_may_be_zero else
            ('pulse_jump_tolerance_pulses', self.pulse_jump_tolerance_pulses > 0, 'positive'))
        return [
            ('revolutions_per_window', self.revolutions_per_window >= 1, 'at least 1'),
            ('fit_half_width_s', self.fit_half_width_s > 0, 'positive'),
            ('fit_order', self.fit_order in (1, 2), '1 or 2'),
            ('min_fit_samples_per_side', self.min_fit_samples_per_side >= 2, 'at least 2'),
            ('max_fit_gap_s', self.max_fit_gap_s > 0, 'positive'),
            ('max_fit_residual_pulses', self.max_fit_residual_pulses > 0, 'positive'),
            ('rate_tolerance', 0 < self.rate_tolerance < 1, 'between 0 and 1'),
            ('min_rate_deg_s', self.min_rate_deg_s > 0, 'positive'),
            angle,
            ('index_angle_tolerance_arcsec', self.index_angle_tolerance_arcsec > 0, 'positive'),
            ('max_table_gap_s', self.max_table_gap_s > 0, 'positive'),
            ('max_pulse_gap_s', self.max_pulse_gap_s > 0, 'positive'),
            jump,
        ]


@dataclass(frozen=True, slots=True)
class CountAtInstant:
    """Cumulative pulse count at an instant from a local fit.

    Attributes:
        value: count at the instant, pulses.
        std_uncertainty: standard uncertainty from the fit residuals, pulses.
        n_used: pulse samples in the fit.
        rate_pulses_s: fitted count rate at the instant, pulses/s.
        max_residual: largest |residual| of the fit, pulses.
    """

    value: float
    std_uncertainty: float
    n_used: int
    rate_pulses_s: float
    max_residual: float


def count_at_instant(
    t_ns: npt.NDArray[np.int64],
    counts: npt.NDArray[np.float64],
    instant_ns: int,
    *,
    half_width_s: float,
    order: int = 1,
    min_samples_per_side: int = 20,
    max_gap_s: float = 0.01,
    stream: str = 'pulse',
) -> CountAtInstant:
    """Least-squares estimate of the cumulative count at ``instant_ns``.

    Fits counts(t) = c0 + c1·(t − instant) [+ c2·(t − instant)²] to the samples
    within ±``half_width_s`` and returns c0 with its standard uncertainty.

    Args:
        t_ns: sorted sample stamps, int64 ns.
        counts: cumulative pulse counts at those stamps, pulses.
        instant_ns: the instant (zero-index stamp), int ns.
        half_width_s: half-width of the fit span, s.
        order: 1 (line) or 2 (parabola).
        min_samples_per_side: samples required before and after the instant.
        max_gap_s: largest gap between consecutive samples inside the span, s.
        stream: what the samples are, for messages ('pulse', 'joint_states').

    The same fit gives the encoder angle at the instant (``counts`` = angles): both ends of
    a window are then measured alike, so a fit error common to both streams cancels.

    Raises:
        WindowError: too few samples on a side, or a gap in the span.
    """
    half_ns = int(round(half_width_s * NS_PER_S))
    lo = int(np.searchsorted(t_ns, instant_ns - half_ns, side='left'))
    mid = int(np.searchsorted(t_ns, instant_ns, side='left'))
    hi = int(np.searchsorted(t_ns, instant_ns + half_ns, side='right'))
    n_before, n_after = mid - lo, hi - mid
    if min(n_before, n_after) < min_samples_per_side:
        raise WindowError(
            f'only {n_before} {stream} samples before and {n_after} after the zero-index event '
            f'at {format_stamp(instant_ns)} (need {min_samples_per_side} each side within '
            f'±{half_width_s:g} s): gap in the {stream} stream?'
        )
    t_span = t_ns[lo:hi]
    gaps = np.diff(t_span)
    if len(gaps) and gaps.max() > max_gap_s * NS_PER_S:
        raise WindowError(
            f'gap of {gaps.max() / 1e6:.1f} ms in the {stream} stream within ±{half_width_s:g} s '
            f'of the zero-index event at {format_stamp(instant_ns)} '
            f'(limit {max_gap_s * 1e3:g} ms).'
        )
    x = (t_span - instant_ns).astype(np.float64) / NS_PER_S
    y0 = counts[mid] if mid < hi else counts[lo]
    y = counts[lo:hi] - y0
    n = len(x)
    if order == 1:  # the straight line in closed form (the common case, ~10× faster)
        xm, ym = float(x.mean()), float(y.mean())
        dx = x - xm
        sxx = float(dx @ dx)
        slope = float(dx @ (y - ym)) / sxx
        intercept = ym - slope * xm
        residual = y - (intercept + slope * x)
        s2 = float(residual @ residual) / (n - 2)
        value, var0, rate = intercept, s2 * (1.0 / n + xm * xm / sxx), slope
    else:
        design = np.vander(x, order + 1, increasing=True)
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        residual = y - design @ coef
        s2 = float(residual @ residual) / (n - (order + 1))
        var0 = float((s2 * np.linalg.inv(design.T @ design))[0, 0])
        value, rate = float(coef[0]), float(coef[1])
    return CountAtInstant(
        value=value + float(y0),
        std_uncertainty=math.sqrt(var0),
        n_used=n,
        rate_pulses_s=rate,
        max_residual=float(np.max(np.abs(residual))),
    )


@dataclass(frozen=True, slots=True)
class IndexEvent:
    """A zero-index event with the table and gyro state at its instant.

    Attributes:
        stamp_ns: event stamp, int ns.
        encoder_angle_rad: encoder angle at the stamp (local fit, as the count), rad; NaN if
            unknown.
        rate_rad_s: table rate at the stamp, rad/s; NaN if unknown.
        count: pulse count at the stamp, or None when it could not be measured.
        problem: why ``count`` is None (or the event is unusable), else ''.
        angle_std_rad: standard uncertainty of ``encoder_angle_rad`` from its fit, rad.
        rate_spread: largest relative deviation of the table rate from ``rate_rad_s`` within
            the fit span (0 at constant rate); above ``rate_tolerance`` the table was
            accelerating at the event.
        half_width_ns: half-width of the fit span actually used around the event, ns.
    """

    stamp_ns: int
    encoder_angle_rad: float
    rate_rad_s: float
    count: CountAtInstant | None
    problem: str = ''
    angle_std_rad: float = 0.0
    rate_spread: float = 0.0
    half_width_ns: int = 0


@dataclass(frozen=True, slots=True)
class RevolutionWindow:
    """m whole revolutions between two zero-index events in one constant-rate segment.

    Attributes:
        start_ns, end_ns: the bounding event stamps, int ns.
        direction: +1 forward (encoder angle increasing), −1 reverse.
        revolutions: m.
        pulses: N, pulses counted over the window (signed).
        pulses_std: standard uncertainty of N from the two end fits, pulses.
        duration_s: end − start, s.
        pulse_samples_missing: samples missing inside the window, judged from the stamps.
        angle_rad: swept angle between the two events by the encoder (signed), rad; m·2π
            exactly when the window angle source is 'nominal'.
        angle_std_rad: standard uncertainty of ``angle_rad`` from the two encoder fits, or
            |encoder − m·2π| (the index synchronisation error the encoder shows) when the
            source is 'nominal', rad.
    """

    start_ns: int
    end_ns: int
    direction: int
    revolutions: int
    pulses: float
    pulses_std: float
    duration_s: float
    pulse_samples_missing: int = 0
    angle_rad: float = math.nan
    angle_std_rad: float = 0.0

    @property
    def swept_angle_rad(self) -> float:
        """|angle| swept, rad (m·2π when no encoder angle was recorded)."""
        if math.isfinite(self.angle_rad):
            return abs(self.angle_rad)
        return TWO_PI * self.revolutions


def _median_period_ns(t_ns: npt.NDArray[np.int64]) -> float:
    d = np.diff(t_ns)
    return float(np.median(d)) if len(d) else 0.0


@dataclass(slots=True)
class _Run:
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


class WholeRevolutionWindows:
    """Cuts m-revolution windows from resolved index events, in time order.

    Feed events with :meth:`add_event`; it returns the window that event closes
    (or None) and appends to :attr:`rejections` whatever it had to throw away.
    The pulse and table arrays passed alongside must cover the open window.

    Rules (METHODS §A.2; issue 9): an event where the table accelerates (rate outside
    ``rate_tolerance`` of the run's cruise within the fit span) never starts or ends a
    window; a rejected window gives back the events inside it, so the next candidate
    start is the next event; the first window to close is taken, which for windows of
    equal length is the largest set of non-overlapping windows (earliest-end greedy).
    """

    def __init__(self, config: WindowSettings) -> None:
        """Start with no open segment and no reference mark yet."""
        self.config = config
        self.rejections: list[Rejection] = []
        self._segment: list[IndexEvent] = []
        self._mark_angles: list[float] = []
        self._run: _Run | None = None
        self._excluded: list[IndexEvent] = []
        empty = np.zeros(0)
        self._table: tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                           npt.NDArray[np.float64]] = (empty.astype(np.int64), empty, empty)

    @property
    def open_event(self) -> IndexEvent | None:
        """The oldest event a window may still start at (None when no segment is open)."""
        return self._segment[0] if self._segment else None

    def reset(self) -> None:
        """Forget the open segment (stream restart); the reference mark is re-learned too."""
        self._segment.clear()
        self._mark_angles.clear()
        self._excluded.clear()
        self._run = None

    def finish(self, table_t_ns: npt.NDArray[np.int64], table_angle_rad: npt.NDArray[np.float64],
               table_rate_rad_s: npt.NDArray[np.float64]) -> None:
        """End of the recording: report what the open run could not use."""
        self._table = (table_t_ns, table_angle_rad, table_rate_rad_s)
        run = self._run
        if run is not None and run.usable_rates and len(table_rate_rad_s):
            cruise = float(np.median(run.usable_rates))
            if abs(table_rate_rad_s[-1] - cruise) <= self.config.rate_tolerance * abs(cruise):
                run.windows += 1  # the recording ended inside this cruise: nothing to blame
        self._end_run()

    def _reject(self, stamp_ns: int, reason: str) -> None:
        self.rejections.append(Rejection(stamp_ns, reason))

    def _is_off_mark(self, event: IndexEvent) -> str:
        """Reason if the event is not at the reference mark, learnt from earlier events."""
        tol_rad = self.config.index_angle_tolerance_arcsec / ARCSEC_PER_RAD
        angle = event.encoder_angle_rad % TWO_PI
        marks = self._mark_angles
        if len(marks) >= 3:
            agree = int(np.count_nonzero(_angle_apart(np.asarray(marks), angle) < tol_rad))
            if agree < (len(marks) + 1) // 2:
                ref = _circular_mode(marks, tol_rad)
                off = float(_angle_apart(angle, ref)) * ARCSEC_PER_RAD
                return (f'zero-index event at {format_stamp(event.stamp_ns)} is {off:.1f}″ away '
                        f'from the reference mark (tolerance '
                        f'{self.config.index_angle_tolerance_arcsec:g}″): spurious event or '
                        f'jitter burst; ignored.')
        marks.append(angle)
        del marks[:-9]
        return ''

    def _off_learnt_mark(self, event: IndexEvent) -> str:
        """Reason if ``event`` (taken before the mark was learnt) is off the mark learnt since."""
        tol_rad = self.config.index_angle_tolerance_arcsec / ARCSEC_PER_RAD
        if len(self._mark_angles) < 3:
            return ''
        ref = _circular_mode(self._mark_angles, tol_rad)
        off = float(_angle_apart(event.encoder_angle_rad, ref))
        if off < tol_rad:
            return ''
        return (f'zero-index event at {format_stamp(event.stamp_ns)} is '
                f'{off * ARCSEC_PER_RAD:.1f}″ away from the reference mark learnt since '
                f'(tolerance {self.config.index_angle_tolerance_arcsec:g}″): spurious event; '
                f'no window starts there.')

    # -- direction runs and accelerating events ---------------------------------------------
    def _enter_run(self, sign: float) -> _Run:
        """The run of direction ``sign``; a change of direction ends the current one."""
        if self._run is not None and self._run.sign != sign:
            self._end_run()
        if self._run is None:
            self._run = _Run(sign)
        return self._run

    def _seen(self, run: _Run, event: IndexEvent) -> None:
        run.first_seen_ns = run.first_seen_ns or event.stamp_ns
        run.last_seen_ns = event.stamp_ns

    def _accelerating(self, event: IndexEvent) -> None:
        """``event`` lies in an acceleration: never a window end; reported against the cruise."""
        run = self._enter_run(math.copysign(1.0, event.rate_rad_s))
        self._seen(run, event)
        if run.cruise_rad_s is not None:
            self._report_accelerating(event, run.cruise_rad_s)
        else:
            run.accelerating.append(event)  # the cruise of this run is not known yet
        self._excluded.append(event)
        del self._excluded[:-8]

    def _report_accelerating(self, event: IndexEvent, cruise_rad_s: float) -> None:
        self._reject(event.stamp_ns, (
            f'table accelerating at the zero-index event at {format_stamp(event.stamp_ns)}: '
            f'{math.degrees(event.rate_rad_s):.1f} °/s there, varying by '
            f'{event.rate_spread * 100:.2f} % within ±{event.half_width_ns / NS_PER_S:.3g} s, '
            f'against a cruise of {math.degrees(cruise_rad_s):.1f} °/s (rate_tolerance '
            f'{self.config.rate_tolerance * 100:g} %); no window starts or ends there.'))

    def _end_run(self) -> None:
        """The table reversed or stopped: report what this direction run could not use.

        Only a rate-bias run is judged: one whose constant-rate cruise held at least
        RATE_BIAS_RUN_REVOLUTIONS by the encoder. A positioning move (a station change of the
        θ procedure)
        that passes the mark is not a failed window.
        """
        run, self._run = self._run, None
        if run is None:
            return
        self._end_segment()
        extent = self._cruise_extent(run)
        if extent is None or extent[0] < RATE_BIAS_RUN_REVOLUTIONS:
            return  # a move, not a rate-bias run: nothing to report
        held, cruise, t_from, t_to = extent
        for ev in run.accelerating:
            self._report_accelerating(ev, cruise)
        if run.windows or run.tried or run.spurious:
            return  # a window was cut, or tried and rejected, or events ignored, with reasons
        m = self.config.revolutions_per_window
        revs = 0
        if run.first_usable_ns is not None:
            revs = round(abs(run.last_usable_angle_rad - run.first_usable_angle_rad) / TWO_PI)
            if revs >= m:
                return
            missing = self._missing_at_cruise_ends(run, cruise)
            if missing:
                self._reject(run.first_usable_ns, missing)
                return
        lost = len(run.accelerating)
        self._reject(run.first_usable_ns if run.first_usable_ns is not None else t_from, (
            f'no window in the constant-rate cruise {format_stamp(t_from)} → '
            f'{format_stamp(t_to)} ({held:.2f} revolutions at '
            f'{math.degrees(cruise):.1f} °/s): its {len(run.usable_rates)} usable zero-index '
            f'event(s) span {revs} revolution(s), fewer than the m = {m} a window needs'
            + (f'; {lost} more fell in the acceleration or deceleration' if lost else '')
            + ' (give the table at least m + 1 revolutions of cruise between reversals, or '
            'lower revolutions_per_window).'))

    def _cruise_extent(self, run: _Run) -> tuple[float, float, int, int] | None:
        """The run's constant-rate stretch, or None.

        (revolutions held, cruise rate rad/s, first stamp, last stamp) of the run's
        constant-rate stretch by the encoder, or None when the table data cannot say.

        The cruise is the median rate at the usable events; with none (every event fell in
        an acceleration) it is the run's fastest rate between its events.
        """
        t, angle, rate = self._table
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
        off = np.nonzero(np.abs(rate - cruise) > self.config.rate_tolerance * abs(cruise))[0]
        before, after = off[off < lo], off[off >= hi]
        first = int(before[-1]) + 1 if len(before) else 0
        last = int(after[0]) - 1 if len(after) else len(t) - 1
        first, last = min(first, lo), max(last, min(hi, len(t)) - 1)
        held = abs(float(angle[last] - angle[first])) / TWO_PI
        return held, cruise, int(t[first]), int(t[last])

    def _missing_at_cruise_ends(self, run: _Run, cruise: float) -> str:
        """Why a cruise gave too few events, if known.

        Why a cruise gave too few events, if the encoder shows it held its rate for a whole
        revolution beyond its first or last event: a zero-index event is missing.
        """
        t, angle, rate = self._table
        if len(t) < 2:
            return ''
        tol = self.config.rate_tolerance * abs(cruise)
        one_rev = TWO_PI + self.config.window_angle_tolerance_arcsec / ARCSEC_PER_RAD
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

    # -- events ------------------------------------------------------------------------------
    def add_event(
        self,
        event: IndexEvent,
        pulse_t_ns: npt.NDArray[np.int64],
        pulse_counts: npt.NDArray[np.float64],
        table_t_ns: npt.NDArray[np.int64],
        table_angle_rad: npt.NDArray[np.float64],
        table_rate_rad_s: npt.NDArray[np.float64],
    ) -> RevolutionWindow | None:
        """Take the next event; return the window it closes, if any.

        The usable events of the current constant-rate segment are kept; a window closes
        on the first earlier one exactly m revolutions back (by the encoder), so a missing
        or spurious event costs no window it does not belong to. A rejected window gives
        back the events inside it.
        """
        cfg = self.config
        self._table = (table_t_ns, table_angle_rad, table_rate_rad_s)
        if not math.isfinite(event.encoder_angle_rad) or not math.isfinite(event.rate_rad_s):
            self._end_run()
            return None
        if (abs(event.rate_rad_s) < math.radians(cfg.min_rate_deg_s)
                or event.rate_spread > cfg.rate_tolerance):
            self._accelerating(event)
            return None
        run = self._enter_run(math.copysign(1.0, event.rate_rad_s))
        self._seen(run, event)
        if event.count is not None:
            problem = self._is_off_mark(event)
            if problem:
                self._reject(event.stamp_ns, problem)
                self._excluded.append(event)
                run.spurious += 1
                return None
        if math.isnan(run.first_event_angle_rad):
            run.first_event_ns, run.first_event_angle_rad = event.stamp_ns, event.encoder_angle_rad
        run.last_event_ns, run.last_event_angle_rad = event.stamp_ns, event.encoder_angle_rad
        if event.count is not None:
            run.usable_rates.append(event.rate_rad_s)
            if run.first_usable_ns is None:
                run.first_usable_ns = event.stamp_ns
                run.first_usable_angle_rad = event.encoder_angle_rad
            run.last_usable_ns = event.stamp_ns
            run.last_usable_angle_rad = event.encoder_angle_rad
            if run.accelerating and run.cruise_rad_s is not None:
                for ev in run.accelerating:
                    self._report_accelerating(ev, run.cruise_rad_s)
                run.accelerating.clear()
        target = TWO_PI * cfg.revolutions_per_window
        tol = cfg.window_angle_tolerance_arcsec / ARCSEC_PER_RAD
        while self._segment:
            swept = abs(event.encoder_angle_rad - self._segment[0].encoder_angle_rad)
            if swept <= target + tol:
                break
            self._give_up(self._segment.pop(0), event)
        for i, start in enumerate(self._segment):
            swept = abs(event.encoder_angle_rad - start.encoder_angle_rad)
            if abs(swept - target) <= tol:
                for skipped in self._segment[:i]:
                    self._give_up(skipped, event)
                window = self._close(start, event, pulse_t_ns, pulse_counts, table_t_ns,
                                     table_rate_rad_s)
                run.tried += 1
                if window is None:  # give back the events inside the rejected window
                    self._segment = self._segment[i + 1:] + [event]
                else:
                    self._segment = [event]
                    run.windows += 1
                return window
        self._segment.append(event)
        return None

    def _give_up(self, start: IndexEvent, now: IndexEvent) -> None:
        """``start`` can no longer begin a window: say why if it was a real candidate."""
        if start.count is None:
            return  # its own problem is reported when a window would have used it
        spurious = self._off_learnt_mark(start)
        if spurious:
            self._reject(start.stamp_ns, spurious)
            return
        m = self.config.revolutions_per_window
        target = start.encoder_angle_rad + math.copysign(TWO_PI * m, now.rate_rad_s)
        tol = self.config.window_angle_tolerance_arcsec / ARCSEC_PER_RAD
        if any(abs(ev.encoder_angle_rad - target) <= tol for ev in self._excluded):
            return  # the event m revolutions on was excluded, and said why
        self._reject(start.stamp_ns, (
            f'no zero-index event {m} revolutions after {format_stamp(start.stamp_ns)} (the '
            f'next ones are at {format_stamp(now.stamp_ns)} and beyond): missing zero-index '
            'event.'))

    def _end_segment(self) -> None:
        """The constant-rate segment ended: its open events can start no window."""
        self._segment = []

    def _close(
        self,
        start: IndexEvent,
        end: IndexEvent,
        pulse_t_ns: npt.NDArray[np.int64],
        pulse_counts: npt.NDArray[np.float64],
        table_t_ns: npt.NDArray[np.int64],
        table_rate_rad_s: npt.NDArray[np.float64],
    ) -> RevolutionWindow | None:
        cfg = self.config
        off_mark = self._off_learnt_mark(start)
        if off_mark:
            self._reject(start.stamp_ns, off_mark)
            return None
        for ev in (start, end):
            if ev.count is None:
                self._reject(start.stamp_ns, f'window {format_stamp(start.stamp_ns)} → '
                             f'{format_stamp(end.stamp_ns)} rejected: {ev.problem}')
                return None
        margins = (start.half_width_ns, end.half_width_ns)
        problem = _rate_problem(table_t_ns, table_rate_rad_s, start.stamp_ns, end.stamp_ns,
                                margins, cfg)
        if not problem:
            problem = _pulse_stream_problem(pulse_t_ns, pulse_counts, start.stamp_ns,
                                            end.stamp_ns, cfg)
        if problem:
            self._reject(start.stamp_ns, f'window {format_stamp(start.stamp_ns)} → '
                         f'{format_stamp(end.stamp_ns)} rejected: {problem}')
            return None
        assert start.count is not None and end.count is not None
        lo = int(np.searchsorted(pulse_t_ns, start.stamp_ns))
        hi = int(np.searchsorted(pulse_t_ns, end.stamp_ns))
        inside = pulse_t_ns[lo:hi]
        period = _median_period_ns(inside)
        missing = 0
        if period > 0:
            missing = int(np.sum(np.round(np.diff(inside) / period) - 1))
        direction = 1 if end.encoder_angle_rad > start.encoder_angle_rad else -1
        measured = end.encoder_angle_rad - start.encoder_angle_rad
        nominal = direction * TWO_PI * cfg.revolutions_per_window
        if cfg.window_angle_source == 'encoder':
            angle, angle_std = measured, math.hypot(start.angle_std_rad, end.angle_std_rad)
        else:  # the paper's eq. (3); the encoder shows the synchronisation error it ignores
            angle, angle_std = nominal, abs(measured - nominal)
        return RevolutionWindow(
            start_ns=start.stamp_ns,
            end_ns=end.stamp_ns,
            direction=direction,
            revolutions=cfg.revolutions_per_window,
            pulses=end.count.value - start.count.value,
            pulses_std=math.hypot(end.count.std_uncertainty, start.count.std_uncertainty),
            duration_s=(end.stamp_ns - start.stamp_ns) / NS_PER_S,
            pulse_samples_missing=missing,
            angle_rad=angle,
            angle_std_rad=angle_std,
        )


def _angle_apart(a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """|a − b| wrapped into [0, π], rad (angles on a circle)."""
    apart: npt.NDArray[np.float64] = np.abs((np.asarray(a) - np.asarray(b) + math.pi) % TWO_PI
                                            - math.pi)
    return apart


def _circular_mode(angles: list[float], tol_rad: float) -> float:
    arr = np.asarray(angles)
    counts = [np.count_nonzero(_angle_apart(arr, a) < tol_rad) for a in arr]
    return float(arr[int(np.argmax(counts))])


def _span(t_ns: npt.NDArray[np.int64], lo_ns: int, hi_ns: int) -> slice:
    return slice(int(np.searchsorted(t_ns, lo_ns, 'left')),
                 int(np.searchsorted(t_ns, hi_ns, 'right')))


def _rate_problem(
    table_t_ns: npt.NDArray[np.int64],
    rate: npt.NDArray[np.float64],
    start_ns: int,
    end_ns: int,
    margins_ns: tuple[int, int],
    cfg: WindowSettings,
) -> str:
    """Why the table was not at constant rate over the window and its fit margins.

    '' if it was.
    """
    lo_ns, hi_ns = start_ns - margins_ns[0], end_ns + margins_ns[1]
    sl = _span(table_t_ns, lo_ns, hi_ns)
    t, r = table_t_ns[sl], rate[sl]
    if len(t) < 2:
        return 'no joint_states inside the window.'
    edges = np.concatenate(([lo_ns], t, [hi_ns]))
    steps = np.diff(edges)
    worst = int(np.argmax(steps))
    gap = float(steps[worst]) / NS_PER_S
    if gap > cfg.max_table_gap_s:
        return (f'gap of {gap:.3f} s in joint_states inside the window, from '
                f'{format_stamp(int(edges[worst]))} (limit {cfg.max_table_gap_s:g} s): constant '
                'rate cannot be checked.')
    flips = np.nonzero(np.sign(r) != np.sign(r[0]))[0]
    if len(flips):
        return ('the table changed direction inside the window, at '
                f'{format_stamp(int(t[flips[0]]))}.')
    med = float(np.median(r))
    rel = np.abs(r - med) / abs(med)
    worst = int(np.argmax(rel))
    if rel[worst] > cfg.rate_tolerance:
        return (f'rate excursion: the table rate was {math.degrees(float(r[worst])):.3f} °/s at '
                f'{format_stamp(int(t[worst]))}, {rel[worst] * 100:.3f} % from its window median '
                f'{math.degrees(med):.3f} °/s (rate_tolerance {cfg.rate_tolerance * 100:g} %).')
    return ''


def _pulse_stream_problem(
    pulse_t_ns: npt.NDArray[np.int64],
    counts: npt.NDArray[np.float64],
    start_ns: int,
    end_ns: int,
    cfg: WindowSettings,
) -> str:
    """Why the pulse counts inside the window cannot be trusted ('' if they can)."""
    sl = _span(pulse_t_ns, start_ns, end_ns)
    t, n = pulse_t_ns[sl], counts[sl]
    if len(t) < 2:
        return 'no pulse samples inside the window.'
    dt = np.diff(t).astype(np.float64) / NS_PER_S
    worst_gap = int(np.argmax(dt))
    gap = float(dt[worst_gap])
    if gap > cfg.max_pulse_gap_s:
        return (f'gap of {gap:.3f} s in the pulse stream inside the window, from '
                f'{format_stamp(int(t[worst_gap]))} (limit {cfg.max_pulse_gap_s:g} s).')
    dn = np.diff(n)
    rate = float(np.median(dn / dt))
    expected = rate * dt
    excess = np.abs(dn - expected) - (cfg.rate_tolerance * np.abs(expected)
                                      + cfg.pulse_jump_tolerance_pulses)
    worst = int(np.argmax(excess))
    if excess[worst] > 0:
        return (f'pulse count jumped by {dn[worst] - expected[worst]:+.0f} pulses against the '
                f'window rate at {format_stamp(int(t[worst + 1]))} (counts going backwards or a '
                f'glitch).')
    return ''


def period_near(t_ns: npt.NDArray[np.int64], t_event: int, half_ns: int) -> float:
    """Median sample period near an event, ns.

    Median sample period (the upper median for an even count) of the stamps within
    ±``half_ns`` of ``t_event`` (0 if fewer than 2), ns.
    """
    lo = int(np.searchsorted(t_ns, t_event - half_ns, 'left'))
    hi = int(np.searchsorted(t_ns, t_event + half_ns, 'right'))
    if hi - lo < 2:
        return 0.0
    d = np.diff(t_ns[lo:hi])
    k = len(d) // 2
    return float(np.partition(d, k)[k])


def fit_half_width_ns(cfg: WindowSettings, t_event: int, p_t: npt.NDArray[np.int64],
                      period_ns: float | None = None) -> int:
    """Half-width of the fits around an event.

    Half-width of the fits around an event: ``fit_half_width_s``, widened so that a
    slow pulse stream still gives ``min_fit_samples_per_side`` samples each side (its
    period read from the samples within ±``fit_half_width_s``), at most MAX_FIT_HALF_WIDTH_S.
    """
    half_ns = int(cfg.fit_half_width_s * NS_PER_S)
    period = period_near(p_t, t_event, half_ns) if period_ns is None else period_ns
    if period <= 0:
        return half_ns
    need = int((cfg.min_fit_samples_per_side + 1) * period * 1.02)
    return max(half_ns, min(need, int(MAX_FIT_HALF_WIDTH_S * NS_PER_S)))


def resolve_index_event(cfg: WindowSettings, t_event: int, p_t: npt.NDArray[np.int64],
                        counts: npt.NDArray[np.float64], s_t: npt.NDArray[np.int64],
                        s_v: npt.NDArray[np.float64]) -> IndexEvent:
    """The table and the gyro at an event (METHODS §A.2 eq. (2a)).

    The table and the gyro at an event: encoder angle and pulse count by the same
    local fit, the table rate and how much it varies over the fit span. ``s_v`` holds the
    encoder angle (rad) and rate (rad/s) as columns.
    """
    nominal_ns = int(cfg.fit_half_width_s * NS_PER_S)
    pulse_period = period_near(p_t, t_event, nominal_ns)
    half_ns = fit_half_width_ns(cfg, t_event, p_t, pulse_period)
    if half_ns != nominal_ns:
        pulse_period = period_near(p_t, t_event, half_ns)
    half_s = half_ns / NS_PER_S
    angle = rate = math.nan
    angle_std = spread = 0.0
    if len(s_t) >= 2 and s_t[0] <= t_event <= s_t[-1]:
        x = (s_t - t_event).astype(np.float64)
        rate = float(np.interp(0.0, x, s_v[:, 1]))
        angle = float(np.interp(0.0, x, s_v[:, 0]))
        sl = slice(int(np.searchsorted(s_t, t_event - half_ns, 'left')),
                   int(np.searchsorted(s_t, t_event + half_ns, 'right')))
        near = s_v[sl, 1]
        if len(near) and rate != 0.0:
            spread = float(np.max(np.abs(near - rate))) / abs(rate)
        table_gap_s = max(cfg.max_fit_gap_s, 2.5 * period_near(s_t, t_event, half_ns)
                          / NS_PER_S)
        try:
            fit = count_at_instant(s_t, s_v[:, 0], t_event, half_width_s=half_s,
                                   order=cfg.fit_order, min_samples_per_side=cfg.fit_order + 1,
                                   max_gap_s=table_gap_s, stream='joint_states')
        except WindowError:
            pass  # too few encoder samples for a fit: the interpolated angle stands
        else:
            angle, angle_std = fit.value, fit.std_uncertainty
    pulse_gap_s = max(cfg.max_fit_gap_s, 2.5 * pulse_period / NS_PER_S)
    state: dict[str, Any] = dict(angle_std_rad=angle_std, rate_spread=spread,
                                 half_width_ns=half_ns)
    try:
        count = count_at_instant(
            p_t, counts, t_event, half_width_s=half_s, order=cfg.fit_order,
            min_samples_per_side=cfg.min_fit_samples_per_side, max_gap_s=pulse_gap_s)
    except WindowError as exc:
        return IndexEvent(t_event, angle, rate, None, str(exc), **state)
    if count.max_residual > cfg.max_fit_residual_pulses:
        return IndexEvent(t_event, angle, rate, None, (
            f'pulse counts around the zero-index event at {format_stamp(t_event)} deviate '
            f'from a smooth fit by up to {count.max_residual:.1f} pulses (limit '
            f'{cfg.max_fit_residual_pulses:g}) while the table rate held within '
            f'{spread * 100:.3f} %: a count glitch, or gyro rate ripple too fast for '
            f'fit_order={cfg.fit_order} over ±{half_s:g} s.'), **state)
    return IndexEvent(t_event, angle, rate, count, **state)
