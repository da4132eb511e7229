"""Cutting windows of exactly m revolutions from resolved zero-index events (METHODS §A.2).

:class:`WholeRevolutionWindows` walks the resolved index events in time order and cuts
windows of exactly m revolutions (checked against the encoder angle) that lie inside one
constant-rate segment; :class:`RevolutionWindow` is one such window. Events off the reference
mark (:mod:`~gyro_calib.windows.mark`), windows whose table rate or pulse stream fail
(:mod:`~gyro_calib.windows.checks`) and runs that gave no window
(:mod:`~gyro_calib.windows.runs`) are rejected with a reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.units import ARCSEC_PER_RAD, NS_PER_S, format_stamp
from gyro_calib.windows.checks import pulse_stream_problem, rate_problem
from gyro_calib.windows.mark import off_learnt_mark, off_mark
from gyro_calib.windows.runs import DirectionRun, accelerating_reason, run_end_rejections
from gyro_calib.windows.settings import TWO_PI

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.windows.index_events import IndexEvent
    from gyro_calib.windows.settings import WindowSettings


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
        self._run: DirectionRun | None = None
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
        return off_mark(self._mark_angles, event, self.config.index_angle_tolerance_arcsec)

    def _off_learnt_mark(self, event: IndexEvent) -> str:
        """Reason if ``event`` (taken before the mark was learnt) is off the mark learnt since."""
        return off_learnt_mark(self._mark_angles, event, self.config.index_angle_tolerance_arcsec)

    # -- direction runs and accelerating events ---------------------------------------------
    def _enter_run(self, sign: float) -> DirectionRun:
        """The run of direction ``sign``; a change of direction ends the current one."""
        if self._run is not None and self._run.sign != sign:
            self._end_run()
        if self._run is None:
            self._run = DirectionRun(sign)
        return self._run

    def _seen(self, run: DirectionRun, event: IndexEvent) -> None:
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
        self._reject(event.stamp_ns,
                     accelerating_reason(event, cruise_rad_s, self.config.rate_tolerance))

    def _end_run(self) -> None:
        """The table reversed or stopped: report what this direction run could not use."""
        run, self._run = self._run, None
        if run is None:
            return
        self._end_segment()
        self.rejections += run_end_rejections(run, self._table, self.config)

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
        problem = rate_problem(table_t_ns, table_rate_rad_s, start.stamp_ns, end.stamp_ns,
                                margins, cfg)
        if not problem:
            problem = pulse_stream_problem(pulse_t_ns, pulse_counts, start.stamp_ns,
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
