"""Whole-revolution windows from zero-index events (METHODS §A.1–A.2).

Two steps:

1. :func:`count_at_instant` estimates the cumulative pulse count at a zero-index
   instant from the pulse samples around it by a local least-squares fit, not by
   interpolating between the two neighbouring samples: the quantisation error of
   the integer counts averages down over the fit span.
2. :class:`WholeRevolutionWindows` walks the resolved index events in time order
   and cuts windows of exactly m revolutions (checked against the encoder angle)
   that lie inside one constant-rate segment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import WindowError
from gyro_calib.estimate import Rejection
from gyro_calib.units import ARCSEC_PER_RAD, NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.config import KTildeConfig

TWO_PI = 2.0 * math.pi


def format_stamp(t_ns: int) -> str:
    """A stamp in seconds for log lines, e.g. ``t=123.456789 s``."""
    return f't={t_ns / NS_PER_S:.6f} s'


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
            f'only {n_before} pulse samples before and {n_after} after the zero-index event at '
            f'{format_stamp(instant_ns)} (need {min_samples_per_side} each side within '
            f'±{half_width_s:g} s): gap in the pulse stream?'
        )
    t_span = t_ns[lo:hi]
    gaps = np.diff(t_span)
    if len(gaps) and gaps.max() > max_gap_s * NS_PER_S:
        raise WindowError(
            f'gap of {gaps.max() / 1e6:.1f} ms in the pulse stream within ±{half_width_s:g} s '
            f'of the zero-index event at {format_stamp(instant_ns)} (limit {max_gap_s * 1e3:g} ms).'
        )
    x = (t_span - instant_ns).astype(np.float64) / NS_PER_S
    y0 = counts[mid] if mid < hi else counts[lo]
    y = counts[lo:hi] - y0
    design = np.vander(x, order + 1, increasing=True)
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    residual = y - design @ coef
    dof = len(x) - (order + 1)
    s2 = float(residual @ residual) / dof
    cov = s2 * np.linalg.inv(design.T @ design)
    return CountAtInstant(
        value=float(coef[0] + y0),
        std_uncertainty=math.sqrt(cov[0, 0]),
        n_used=len(x),
        rate_pulses_s=float(coef[1]),
        max_residual=float(np.max(np.abs(residual))),
    )


@dataclass(frozen=True, slots=True)
class IndexEvent:
    """A zero-index event with the table and gyro state at its instant.

    Attributes:
        stamp_ns: event stamp, int ns.
        encoder_angle_rad: encoder angle at the stamp (interpolated), rad; NaN if unknown.
        rate_rad_s: table rate at the stamp, rad/s; NaN if unknown.
        count: pulse count at the stamp, or None when it could not be measured.
        problem: why ``count`` is None (or the event is unusable), else ''.
    """

    stamp_ns: int
    encoder_angle_rad: float
    rate_rad_s: float
    count: CountAtInstant | None
    problem: str = ''


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
    """

    start_ns: int
    end_ns: int
    direction: int
    revolutions: int
    pulses: float
    pulses_std: float
    duration_s: float
    pulse_samples_missing: int = 0


def _median_period_ns(t_ns: npt.NDArray[np.int64]) -> float:
    d = np.diff(t_ns)
    return float(np.median(d)) if len(d) else 0.0


class WholeRevolutionWindows:
    """Cuts m-revolution windows from resolved index events, in time order.

    Feed events with :meth:`add_event`; it returns the window that event closes
    (or None) and appends to :attr:`rejections` whatever it had to throw away.
    The pulse and table arrays passed alongside must cover the open window.
    """

    def __init__(self, config: KTildeConfig) -> None:
        """Start with no open segment and no reference mark yet."""
        self.config = config
        self.rejections: list[Rejection] = []
        self._segment: list[IndexEvent] = []
        self._mark_angles: list[float] = []

    @property
    def open_event(self) -> IndexEvent | None:
        """The oldest event a window may still start at (None when no segment is open)."""
        return self._segment[0] if self._segment else None

    def reset(self) -> None:
        """Forget the open segment (stream restart); the reference mark is re-learned too."""
        self._segment.clear()
        self._mark_angles.clear()

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

    def add_event(
        self,
        event: IndexEvent,
        pulse_t_ns: npt.NDArray[np.int64],
        pulse_counts: npt.NDArray[np.float64],
        table_t_ns: npt.NDArray[np.int64],
        table_rate_rad_s: npt.NDArray[np.float64],
    ) -> RevolutionWindow | None:
        """Take the next event; return the window it closes, if any.

        The usable events of the current constant-rate segment are kept; a window closes
        on the first earlier one exactly m revolutions back (by the encoder), so a missing
        or spurious event costs no window it does not belong to.
        """
        cfg = self.config
        if not math.isfinite(event.encoder_angle_rad) or not math.isfinite(event.rate_rad_s):
            self._end_segment(event, 'no joint_states around it')
            return None
        if abs(event.rate_rad_s) < math.radians(cfg.min_rate_deg_s):
            self._end_segment(event, 'the table left constant rate')
            return None
        if event.count is not None:
            problem = self._is_off_mark(event)
            if problem:
                self._reject(event.stamp_ns, problem)
                return None
        if self._segment and (math.copysign(1.0, event.rate_rad_s)
                              != math.copysign(1.0, self._segment[0].rate_rad_s)):
            self._end_segment(event, 'the table reversed')
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
                self._segment = [event]
                return self._close(start, event, pulse_t_ns, pulse_counts, table_t_ns,
                                   table_rate_rad_s)
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
        self._reject(start.stamp_ns, (
            f'no zero-index event {self.config.revolutions_per_window} revolutions after '
            f'{format_stamp(start.stamp_ns)} (the next ones are at {format_stamp(now.stamp_ns)} '
            f'and beyond): missing zero-index event.'))

    def _end_segment(self, event: IndexEvent, why: str) -> None:
        """The constant-rate segment ended at ``event``: report a window it could not close."""
        if self._segment:
            first = self._segment[0]
            revs = abs(self._segment[-1].encoder_angle_rad - first.encoder_angle_rad) / TWO_PI
            if revs > 0.99 and first.count is not None and not self._off_learnt_mark(first):
                m = self.config.revolutions_per_window
                self._reject(first.stamp_ns, (
                    f'no window closed in the constant-rate segment from '
                    f'{format_stamp(first.stamp_ns)}: {why} at {format_stamp(event.stamp_ns)} '
                    f'after {revs:.3f} revolutions between zero-index events, fewer than the '
                    f'{m} a window needs (direction change inside the window, or a missing '
                    f'zero-index event at its end).'))
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
        problem = _rate_problem(table_t_ns, table_rate_rad_s, start.stamp_ns, end.stamp_ns, cfg)
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
        return RevolutionWindow(
            start_ns=start.stamp_ns,
            end_ns=end.stamp_ns,
            direction=direction,
            revolutions=cfg.revolutions_per_window,
            pulses=end.count.value - start.count.value,
            pulses_std=math.hypot(end.count.std_uncertainty, start.count.std_uncertainty),
            duration_s=(end.stamp_ns - start.stamp_ns) / NS_PER_S,
            pulse_samples_missing=missing,
        )


def _angle_apart(a: npt.ArrayLike, b: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """|a − b| wrapped into [0, π], rad (angles on a circle)."""
    return np.abs((np.asarray(a) - np.asarray(b) + math.pi) % TWO_PI - math.pi)


def _circular_mode(angles: list[float], tol_rad: float) -> float:
    arr = np.asarray(angles)
    counts = [np.count_nonzero(_angle_apart(arr, a) < tol_rad) for a in arr]
    return float(arr[int(np.argmax(counts))])


def _span(t_ns: npt.NDArray[np.int64], lo_ns: int, hi_ns: int) -> slice:
    return slice(int(np.searchsorted(t_ns, lo_ns, 'left')), int(np.searchsorted(t_ns, hi_ns, 'right')))


def _rate_problem(
    table_t_ns: npt.NDArray[np.int64],
    rate: npt.NDArray[np.float64],
    start_ns: int,
    end_ns: int,
    cfg: KTildeConfig,
) -> str:
    """Why the table was not at constant rate over the window and its fit margins ('' if it was)."""
    margin = int(cfg.fit_half_width_s * NS_PER_S)
    sl = _span(table_t_ns, start_ns - margin, end_ns + margin)
    t, r = table_t_ns[sl], rate[sl]
    if len(t) < 2:
        return 'no joint_states inside the window.'
    edges = np.concatenate(([start_ns - margin], t, [end_ns + margin]))
    gap = float(np.max(np.diff(edges))) / NS_PER_S
    if gap > cfg.max_table_gap_s:
        return (f'gap of {gap:.3f} s in joint_states inside the window '
                f'(limit {cfg.max_table_gap_s:g} s): constant rate cannot be checked.')
    if np.any(np.sign(r) != np.sign(r[0])):
        return 'the table changed direction inside the window.'
    med = float(np.median(r))
    dev = float(np.max(np.abs(r - med))) / abs(med)
    if dev > cfg.rate_tolerance:
        return (f'table rate deviated by {dev * 100:.3f} % from its median '
                f'{math.degrees(med):.3f} °/s (tolerance {cfg.rate_tolerance * 100:g} %).')
    return ''


def _pulse_stream_problem(
    pulse_t_ns: npt.NDArray[np.int64],
    counts: npt.NDArray[np.float64],
    start_ns: int,
    end_ns: int,
    cfg: KTildeConfig,
) -> str:
    """Why the pulse counts inside the window cannot be trusted ('' if they can)."""
    sl = _span(pulse_t_ns, start_ns, end_ns)
    t, n = pulse_t_ns[sl], counts[sl]
    if len(t) < 2:
        return 'no pulse samples inside the window.'
    dt = np.diff(t).astype(np.float64) / NS_PER_S
    gap = float(dt.max())
    if gap > cfg.max_pulse_gap_s:
        return (f'gap of {gap:.3f} s in the pulse stream inside the window '
                f'(limit {cfg.max_pulse_gap_s:g} s).')
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
