"""Constant-rate segments of the rate table, found from its joint_states (METHODS §B, §E).

A segment is a maximal run of joint_states samples whose rate stays within
``segment_rate_tolerance``·|ω̄| + ``segment_rate_floor`` of the run's running mean ω̄;
an acceleration breaks it. A run that returns to the same rate within ``max_excursion_s``
without another constant rate in between had a rate excursion: the whole span is
reported as one segment marked with the excursion, which the calibrator rejects. The
detector also records when the table moved at all (for the self-calibration's static
base). Samples are processed in stamp order, one at a time, so the result does not depend
on chunking.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field


@dataclass(frozen=True, slots=True)
class SteadyRun:
    """A constant-rate span of the table.

    Attributes:
        start_ns, end_ns: first and last joint_states stamps of the span, ns.
        rate_rad_s: mean reported rate over the span, rad/s.
        n_samples: joint_states samples in the span.
        span_a: (stamp ns, encoder angle rad) of the first sample ≥ start + guard, or None.
        span_b: (stamp ns, encoder angle rad) of the last sample ≤ end − guard, or None.
        excursion: (start ns, end ns, largest |rate − ω̄| rad/s) of a rate excursion, or None.
    """

    start_ns: int
    end_ns: int
    rate_rad_s: float
    n_samples: int
    span_a: tuple[int, float] | None
    span_b: tuple[int, float] | None
    excursion: tuple[int, int, float] | None = None

    @property
    def duration_s(self) -> float:
        """Length of the span, s."""
        return (self.end_ns - self.start_ns) / 1e9


@dataclass(slots=True)
class _Open:
    start_ns: int
    end_ns: int
    end_angle: float
    n: int
    rate_sum: float
    span_a: tuple[int, float] | None = None
    recent: deque[tuple[int, float]] = field(default_factory=deque)

    @property
    def rate(self) -> float:
        return self.rate_sum / self.n


@dataclass(slots=True)
class _Pending:
    run: SteadyRun
    excursion_start_ns: int | None = None
    excursion_dev: float = 0.0
    merged: bool = False


class SegmentDetector:
    """Turns the joint_states stream into constant-rate segments and moving spans."""

    def __init__(self, *, rate_tolerance: float, rate_floor_rad_s: float, min_segment_s: float,
                 guard_s: float, max_excursion_s: float, static_rate_rad_s: float,
                 max_gap_s: float) -> None:
        """Create the detector with the segment rules (see :class:`FogSettings`)."""
        self.rate_tolerance = rate_tolerance
        self.rate_floor = rate_floor_rad_s
        self.min_segment_ns = int(min_segment_s * 1e9)
        self.guard_ns = int(guard_s * 1e9)
        self.max_excursion_ns = int(max_excursion_s * 1e9)
        self.static_rate = static_rate_rad_s
        self.max_gap_ns = int(max_gap_s * 1e9)
        self.segments: list[SteadyRun] = []
        """Finished segments not yet taken by the caller, in time order."""
        self.moving: list[tuple[int, int]] = []
        """Closed spans (start ns, end ns) in which |rate| exceeded the static tolerance."""
        self._open: _Open | None = None
        self._pending: _Pending | None = None
        self._moving_since: int | None = None
        self._last_t: int | None = None
        self.processed_until_ns: int | None = None
        """Stamp of the newest sample processed."""

    def tolerance(self, rate_rad_s: float) -> float:
        """Allowed |rate − mean| at a mean rate, rad/s."""
        return self.rate_tolerance * abs(rate_rad_s) + self.rate_floor

    def _qualifies(self, run: SteadyRun) -> bool:
        return run.end_ns - run.start_ns >= self.min_segment_ns + 2 * self.guard_ns

    # -- input -------------------------------------------------------------------------------
    def add(self, t_ns: list[int], angle_rad: list[float], rate_rad_s: list[float]) -> None:
        """Process joint_states samples in stamp order."""
        for t, angle, rate in zip(t_ns, angle_rad, rate_rad_s):
            self._track_motion(t, rate)
            run = self._open
            gap = self._last_t is not None and t - self._last_t > self.max_gap_ns
            if run is not None and not gap and abs(rate - run.rate) <= self.tolerance(run.rate):
                run.n += 1
                run.rate_sum += rate
                run.end_ns, run.end_angle = t, angle
                if run.span_a is None and t >= run.start_ns + self.guard_ns:
                    run.span_a = (t, angle)
                run.recent.append((t, angle))
                while len(run.recent) > 2 and run.recent[1][0] <= t - self.guard_ns:
                    run.recent.popleft()
            else:
                if run is not None:
                    self._close(run)
                self._open = _Open(t, t, angle, 1, rate, None, deque([(t, angle)]))
                self._note_excursion(t, rate)
            self._last_t = t
            self.processed_until_ns = t
            self._check_timeout(t)

    def flush(self) -> None:
        """End of the stream: close the open run and hand over everything pending."""
        if self._open is not None:
            self._close(self._open)
            self._open = None
        if self._pending is not None:
            self.segments.append(self._finish(self._pending))
            self._pending = None
        if self._moving_since is not None and self._last_t is not None:
            self.moving.append((self._moving_since, self._last_t))
            self._moving_since = None

    def reset(self) -> None:
        """Forget the open and pending runs (a source restart); finished segments stay."""
        self._open = None
        self._pending = None
        self._moving_since = None
        self._last_t = None

    # -- internals ---------------------------------------------------------------------------
    def _track_motion(self, t: int, rate: float) -> None:
        moving = abs(rate) > self.static_rate
        if moving and self._moving_since is None:
            self._moving_since = self._last_t if self._last_t is not None else t
        elif not moving and self._moving_since is not None:
            self.moving.append((self._moving_since, t))
            self._moving_since = None

    def moving_until(self) -> int | None:
        """Start of a still-open moving span (None if the table is static now)."""
        return self._moving_since

    def _to_run(self, run: _Open) -> SteadyRun:
        span_b = None
        for t, angle in reversed(run.recent):
            if t <= run.end_ns - self.guard_ns:
                span_b = (t, angle)
                break
        return SteadyRun(run.start_ns, run.end_ns, run.rate, run.n, run.span_a, span_b)

    def _close(self, open_run: _Open) -> None:
        run = self._to_run(open_run)
        pending = self._pending
        if pending is not None:
            same = abs(run.rate_rad_s - pending.run.rate_rad_s) <= self.tolerance(
                pending.run.rate_rad_s)
            if same and run.start_ns - pending.run.end_ns <= self.max_excursion_ns:
                self._merge(pending, run)
                return
            if self._qualifies(run):
                self.segments.append(self._finish(pending))
                self._pending = _Pending(run)
            return
        if self._qualifies(run):
            self._pending = _Pending(run)

    def _merge(self, pending: _Pending, run: SteadyRun) -> None:
        old = pending.run
        start = pending.excursion_start_ns if pending.excursion_start_ns is not None \
            else old.end_ns
        n = old.n_samples + run.n_samples
        rate = (old.rate_rad_s * old.n_samples + run.rate_rad_s * run.n_samples) / n
        excursion = (start, run.start_ns, pending.excursion_dev)
        if old.excursion is not None:
            excursion = (old.excursion[0], run.start_ns, max(old.excursion[2],
                                                             pending.excursion_dev))
        pending.run = SteadyRun(old.start_ns, run.end_ns, rate, n, old.span_a, run.span_b,
                                excursion)
        pending.excursion_start_ns = None
        pending.excursion_dev = 0.0
        pending.merged = True

    def _note_excursion(self, t: int, rate: float) -> None:
        pending = self._pending
        if pending is None:
            return
        if pending.excursion_start_ns is None:
            pending.excursion_start_ns = pending.run.end_ns
        pending.excursion_dev = max(pending.excursion_dev,
                                    abs(rate - pending.run.rate_rad_s))

    def _check_timeout(self, t: int) -> None:
        pending = self._pending
        if pending is None or t - pending.run.end_ns <= self.max_excursion_ns:
            return
        run = self._open
        if run is not None:
            same = abs(run.rate - pending.run.rate_rad_s) <= self.tolerance(
                pending.run.rate_rad_s)
            if same and run.start_ns - pending.run.end_ns <= self.max_excursion_ns:
                return  # the rate came back: the open run will merge when it closes
        self.segments.append(self._finish(pending))
        self._pending = None

    @staticmethod
    def _finish(pending: _Pending) -> SteadyRun:
        return pending.run

    def pending_start_ns(self) -> int | None:
        """Start of the earliest run not yet handed over (open or pending), for trimming."""
        starts = [r for r in (self._pending.run.start_ns if self._pending else None,
                              self._open.start_ns if self._open else None) if r is not None]
        return min(starts) if starts else None


def rate_deg_s(rate_rad_s: float) -> str:
    """A rate for log lines, e.g. ``+20.0100 °/s``."""
    return f'{math.degrees(rate_rad_s):+.4f} °/s'


def stamp_text(t_ns: int) -> str:
    """A stamp for log lines, e.g. ``t=123.456789 s``."""
    return f't={t_ns / 1e9:.6f} s'
