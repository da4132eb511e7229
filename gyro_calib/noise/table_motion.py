"""One table's states classified into steady segments, and gyro stamps gated by them.

:class:`TableMotion` is the classifier of :mod:`gyro_calib.noise.table` (METHODS §E.1): a
state joins the current segment when its rate and angle stay on the segment's line, a
segment is steady once it spans ``table_min_steady_s``, and a gyro stamp is analysed when it
lies in a steady segment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.noise.table_spans import (
    _AFTER,
    _BEFORE,
    MotionSpan,
    SteadySegment,
    _Current,
    _nanmax,
    _zero_nan,
)
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]
    BoolArray = npt.NDArray[np.bool_]


@dataclass(slots=True)
class TableMotion:
    """Classifies one table's states into steady segments and gates gyro stamps.

    See :mod:`gyro_calib.noise.table`.

    Attributes:
        rest_rate_rad_s: ω_tol, rad/s.
        rest_angle_rad: θ_tol at rest, rad.
        min_steady_s: the shortest steady segment, s.
        stamp_jitter_s: σ_t, s (θ_tol grows by |ω|·σ_t).
        turning: a constant rotation is steady (rate table); False: only rest is (position
            table).
        keep_angles: keep the states' angles for :meth:`angle_at`.
        states: table states taken in.
        unusable: states without a finite angle or rate (dropped).
        behind: states stamped at or before one already taken in (dropped).
        segments: the confirmed steady segments, in time order.
    """

    rest_rate_rad_s: float
    rest_angle_rad: float
    min_steady_s: float = 1.0
    stamp_jitter_s: float = 0.0
    turning: bool = True
    keep_angles: bool = False
    states: int = 0
    unusable: int = 0
    behind: int = 0
    segments: list[SteadySegment] = field(default_factory=list)
    first_ns: int | None = None
    last_ns: int | None = None
    _cur: _Current | None = None
    _pending_peak: float = math.nan
    _last_angle: float = math.nan
    _steady_states: int = 0
    _hist_t: list[IntArray] = field(default_factory=list)
    _hist_a: list[FloatArray] = field(default_factory=list)

    @property
    def seen(self) -> bool:
        """A table state has arrived: the gate is active."""
        return self.states > 0

    # -- what the record shows ---------------------------------------------------------------
    def changes(self) -> list[MotionSpan]:
        """The stretches left out (between steady segments), as the record stands now.

        A segment not yet confirmed counts as part of a change (what the end of the record
        would make of it).
        """
        if not self.seen:
            return []
        segs = self.segments
        cur = self._cur
        tail_peak = self._pending_peak
        if cur is not None and not cur.confirmed:
            tail_peak = _nanmax(tail_peak, cur.peak)
        if not segs:
            return [MotionSpan(None, None, _zero_nan(tail_peak))]
        out = []
        if segs[0].first_ns != self.first_ns:
            out.append(MotionSpan(None, segs[0].first_ns, _zero_nan(segs[0].peak_before_rad_s),
                                  math.nan, segs[0].rate_rad_s))
        for a, b in zip(segs[:-1], segs[1:]):
            peak = b.peak_before_rad_s
            if math.isnan(peak):
                peak = max(abs(a.rate_rad_s), abs(b.rate_rad_s))
            out.append(MotionSpan(a.last_ns, b.first_ns, peak, a.rate_rad_s, b.rate_rad_s))
        last = segs[-1]
        if last.last_ns != self.last_ns:
            out.append(MotionSpan(last.last_ns, None, _zero_nan(tail_peak), last.rate_rad_s))
        return out

    @property
    def spans(self) -> list[MotionSpan]:
        """:meth:`changes` (the stretches left out)."""
        return self.changes()

    @property
    def moved(self) -> bool:
        """Some stretch of the record was left out.

        The table changed rate (or turned, where only rest is steady).
        """
        return bool(self.changes())

    @property
    def moving_states(self) -> int:
        """States outside every steady segment."""
        return self.states - self._steady_states

    @property
    def max_rate_rad_s(self) -> float:
        """The largest |rate| of the stretches left out, rad/s (0 when none)."""
        return max((s.max_rate_rad_s for s in self.changes()), default=0.0)

    def steady_rates(self) -> list[float]:
        """The rate of every steady segment, rad/s, in time order."""
        return [s.rate_rad_s for s in self.segments]

    def turning_s(self) -> float:
        """Time in steady segments at a rate above ω_tol (turning steadily), s."""
        return sum((s.last_ns - s.first_ns) / NS_PER_S for s in self.segments
                   if abs(s.rate_rad_s) > self.rest_rate_rad_s)

    def record_s(self) -> float:
        """Time from the first to the last table state, s."""
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        return (self.last_ns - self.first_ns) / NS_PER_S

    def moving_s(self) -> float:
        """Time of the stretches left out within the record, s."""
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        total = 0
        for s in self.changes():
            a = self.first_ns if s.start_ns is None else s.start_ns
            b = self.last_ns if s.end_ns is None else s.end_ns
            total += max(0, b - a)
        return total / NS_PER_S

    # -- table states ------------------------------------------------------------------------
    def extend(self, t_ns: IntArray, angle_rad: FloatArray, rate_rad_s: FloatArray) -> None:
        """Table states (stamps int ns, unwrapped angle rad, rate rad/s; NaN = not given)."""
        t = np.asarray(t_ns, dtype=np.int64)
        angle = np.asarray(angle_rad, dtype=np.float64)
        rate = np.asarray(rate_rad_s, dtype=np.float64)
        if not len(t):
            return
        order = np.argsort(t, kind='stable')
        t, angle, rate = t[order], angle[order], rate[order]
        ok = np.isfinite(angle) | np.isfinite(rate)
        self.unusable += int(len(t) - np.count_nonzero(ok))
        t, angle, rate = t[ok], angle[ok], rate[ok]
        keep = np.ones(len(t), dtype=bool)
        keep[1:] = np.diff(t) > 0
        if self.last_ns is not None:
            keep &= t > self.last_ns
        self.behind += int(len(t) - np.count_nonzero(keep))
        t, angle, rate = t[keep], angle[keep], rate[keep]
        if not len(t):
            return
        speed = self._speeds(t, angle, rate)
        if self.first_ns is None:
            self.first_ns = int(t[0])
        i = 0
        while i < len(t):
            i = self._take(t, angle, rate, speed, i)
        self.states += len(t)
        self.last_ns = int(t[-1])
        self._last_angle = float(angle[-1])  # the previous state's, NaN or not (_speeds)
        finite = np.flatnonzero(np.isfinite(angle))
        if len(finite):
            if self.keep_angles:
                self._hist_t.append(t[finite])
                self._hist_a.append(angle[finite])

    def _speeds(self, t: IntArray, angle: FloatArray, rate: FloatArray) -> FloatArray:
        """|rate| where given, else |Δθ/Δt| from the previous state, rad/s."""
        prev_t = np.concatenate(([self.last_ns if self.last_ns is not None else t[0]], t[:-1]))
        prev_a = np.concatenate(([self._last_angle], angle[:-1]))
        dt = (t - prev_t) / NS_PER_S
        with np.errstate(invalid='ignore', divide='ignore'):
            diff = np.where(dt > 0, np.abs(angle - prev_a) / np.where(dt > 0, dt, 1.0), np.nan)
        return np.where(np.isfinite(rate), np.abs(rate), diff)

    def _start(self, t: IntArray, angle: FloatArray, rate: FloatArray, speed: FloatArray,
               i: int) -> None:
        """State i starts a segment (a table that must rest: only a state at rest does)."""
        if not self.turning and abs(rate[i]) > self.rest_rate_rad_s:  # NaN: no rate test
            self._pending_peak = _nanmax(self._pending_peak, float(speed[i]))
            self._cur = None
            return
        self._cur = _Current(int(t[i]), int(t[i]))
        self._absorb_one(self._cur, int(t[i]), float(angle[i]), float(rate[i]), float(speed[i]))

    def _absorb(self, cur: _Current, t: IntArray, angle: FloatArray, rate: FloatArray,
                speed: FloatArray) -> None:
        """Add states to the current segment (sums in time order: chunking changes no bit)."""
        if math.isnan(cur.a0):
            finite = np.flatnonzero(np.isfinite(angle))
            if len(finite):
                cur.a0 = float(angle[finite[0]])
        ts = (t - cur.first_ns) / NS_PER_S
        fa = np.isfinite(angle)
        if fa.any():
            x, y = ts[fa], angle[fa] - cur.a0
            cur.n_a += len(x)
            cur.s_t = float(np.cumsum(np.concatenate(([cur.s_t], x)))[-1])
            cur.s_a = float(np.cumsum(np.concatenate(([cur.s_a], y)))[-1])
            cur.s_tt = float(np.cumsum(np.concatenate(([cur.s_tt], x * x)))[-1])
            cur.s_ta = float(np.cumsum(np.concatenate(([cur.s_ta], x * y)))[-1])
        fr = np.isfinite(rate)
        if fr.any():
            cur.n_r += int(np.count_nonzero(fr))
            cur.s_r = float(np.cumsum(np.concatenate(([cur.s_r], rate[fr])))[-1])
        if np.isfinite(speed).any():
            cur.peak = max(cur.peak, float(np.nanmax(speed)))
        cur.states += len(t)
        cur.last_ns = int(t[-1])
        self._settle(cur, len(t))

    def _absorb_one(self, cur: _Current, t: int, angle: float, rate: float,
                    speed: float) -> None:
        """:meth:`_absorb` of one state, in scalars (the same float operations, in order)."""
        if math.isnan(cur.a0) and math.isfinite(angle):
            cur.a0 = angle
        if math.isfinite(angle):
            x, y = (t - cur.first_ns) / NS_PER_S, angle - cur.a0
            cur.n_a += 1
            cur.s_t += x
            cur.s_a += y
            cur.s_tt += x * x
            cur.s_ta += x * y
        if math.isfinite(rate):
            cur.n_r += 1
            cur.s_r += rate
        if math.isfinite(speed):
            cur.peak = max(cur.peak, speed)
        cur.states += 1
        cur.last_ns = t
        self._settle(cur, 1)

    def _settle(self, cur: _Current, added: int) -> None:
        """Confirm the current segment once it spans table_min_steady_s; keep it up to date."""
        if cur.confirmed:
            seg = self.segments[-1]
            seg.last_ns, seg.states, seg.rate_rad_s = cur.last_ns, cur.states, cur.rate()
            self._steady_states += added
        elif cur.last_ns - cur.first_ns >= self.min_steady_s * NS_PER_S:
            cur.confirmed = True
            peak = self._pending_peak
            self.segments.append(SteadySegment(cur.first_ns, cur.last_ns, cur.states,
                                               cur.rate(), peak))
            self._pending_peak = math.nan
            self._steady_states += cur.states

    def _take(self, t: IntArray, angle: FloatArray, rate: FloatArray, speed: FloatArray,
              i: int) -> int:
        """Take states from i on while they join the current segment; return the next."""
        cur = self._cur
        if cur is None:
            self._start(t, angle, rate, speed, i)
            return i + 1
        while i < len(t) and cur.states < 4:  # a young segment (a change breaks it at once)
            if self._fails_one(cur, int(t[i]), float(angle[i]), float(rate[i])):
                return self._break(cur, t, angle, rate, speed, i)
            self._absorb_one(cur, int(t[i]), float(angle[i]), float(rate[i]), float(speed[i]))
            i += 1
        w = 16  # growing windows: a steady record costs O(n)
        while i < len(t):
            j = min(len(t), i + w)
            bad = np.flatnonzero(self._fails(cur, t[i:j], angle[i:j], rate[i:j]))
            stop = i + int(bad[0]) if len(bad) else j
            if stop > i:
                self._absorb(cur, t[i:stop], angle[i:stop], rate[i:stop], speed[i:stop])
            if stop < j:
                return self._break(cur, t, angle, rate, speed, stop)
            i, w = j, 2 * w
        return i

    def _break(self, cur: _Current, t: IntArray, angle: FloatArray, rate: FloatArray,
               speed: FloatArray, i: int) -> int:
        """State i does not join: the segment ends, state i starts the next; return i + 1."""
        if not cur.confirmed:  # broken before it was steady: part of the change
            self._pending_peak = _nanmax(self._pending_peak, cur.peak)
        self._start(t, angle, rate, speed, i)
        return i + 1

    def _fails_one(self, cur: _Current, t: int, angle: float, rate: float) -> bool:
        """:meth:`_fails` of one state, in scalars (the same float operations, in order)."""
        x = (t - cur.first_ns) / NS_PER_S
        fa = math.isfinite(angle)
        a0 = cur.a0 if not math.isnan(cur.a0) else (angle if fa else 0.0)
        if self.turning:
            mean_rate = cur.s_r / cur.n_r if cur.n_r > 0 else math.nan
        else:
            mean_rate = 0.0
        rate_off = abs(rate - mean_rate) > self.rest_rate_rad_s  # NaN: no test
        if not self.turning:  # flat through where the table came to rest
            line, slope, has_line = 0.0, 0.0, True
        else:
            n_a = cur.n_a
            den = n_a * cur.s_tt - cur.s_t * cur.s_t
            slope = (n_a * cur.s_ta - cur.s_t * cur.s_a) / den if den > 0 else math.nan
            if n_a < 2:
                slope = mean_rate  # one angle: the given rate
            line = (cur.s_a - slope * cur.s_t) / max(n_a, 1) + slope * x
            has_line = n_a >= 1 and math.isfinite(slope)
        tol = self.rest_angle_rad + abs(slope if math.isfinite(slope) else 0.0) \
            * self.stamp_jitter_s
        angle_off = fa and has_line and abs(angle - a0 - line) > tol
        return bool(rate_off or angle_off)

    def _fails(self, cur: _Current, t: IntArray, angle: FloatArray,
               rate: FloatArray) -> BoolArray:
        """Whether each state fails (2a) of METHODS §E.1, were all before it to join."""
        n = len(t)
        ts = (t - cur.first_ns) / NS_PER_S
        fa = np.isfinite(angle)
        a0 = cur.a0 if not math.isnan(cur.a0) else (float(angle[fa][0]) if fa.any() else 0.0)
        x = np.where(fa, ts, 0.0)
        y = np.where(fa, angle - a0, 0.0)

        def before(carry: float, v: FloatArray) -> FloatArray:  # sums over the states before
            return np.cumsum(np.concatenate(([carry], v)))[:-1]

        fr = np.isfinite(rate)
        n_r = cur.n_r + np.concatenate(([0], np.cumsum(fr)))[:-1]
        s_r = before(cur.s_r, np.where(fr, rate, 0.0))
        with np.errstate(invalid='ignore', divide='ignore'):
            if self.turning:
                mean_rate = np.where(n_r > 0, s_r / np.maximum(n_r, 1), np.nan)
            else:
                mean_rate = np.zeros(n)
            rate_off = np.abs(rate - mean_rate) > self.rest_rate_rad_s  # NaN: no test
            if not self.turning:  # flat through where the table came to rest
                line, slope, has_line = np.zeros(n), np.zeros(n), np.ones(n, dtype=bool)
            else:
                n_a = cur.n_a + np.concatenate(([0], np.cumsum(fa)))[:-1]
                s_t, s_a = before(cur.s_t, x), before(cur.s_a, y)
                s_tt, s_ta = before(cur.s_tt, x * x), before(cur.s_ta, x * y)
                den = n_a * s_tt - s_t * s_t
                slope = np.where(den > 0, (n_a * s_ta - s_t * s_a) / np.where(den > 0, den, 1.0),
                                 np.nan)
                slope = np.where(n_a >= 2, slope, mean_rate)  # one angle: the given rate
                line = (s_a - slope * s_t) / np.maximum(n_a, 1) + slope * ts
                has_line = (n_a >= 1) & np.isfinite(slope)
            tol = self.rest_angle_rad + np.abs(np.where(np.isfinite(slope), slope, 0.0)) \
                * self.stamp_jitter_s
            angle_off = fa & has_line & (np.abs(angle - a0 - line) > tol)
        return np.asarray(rate_off | angle_off, dtype=bool)

    # -- gyro stamps -------------------------------------------------------------------------
    def _segment_bounds(self) -> tuple[IntArray, IntArray]:
        firsts = np.array([s.first_ns for s in self.segments], dtype=np.int64)
        lasts = np.array([s.last_ns for s in self.segments], dtype=np.int64)
        if len(firsts):
            assert self.first_ns is not None and self.last_ns is not None
            if firsts[0] == self.first_ns:
                firsts[0] = _BEFORE  # before the first state: the first holds
            cur = self._cur
            if cur is not None and cur.confirmed and lasts[-1] == self.last_ns:
                lasts[-1] = _AFTER  # after the last state: the last holds (decided at final)
        return firsts, lasts

    def decide(self, t_ns: IntArray, *, final: bool) -> tuple[int, IntArray]:
        """How many of the (ordered) gyro stamps can be decided now, and where they lie.

        Args:
            t_ns: gyro stamps in increasing order, int ns.
            final: no table state will follow (end of the record, or the wait is over): the
                last state holds and a segment not yet confirmed is a change.

        Returns:
            (n, seg): the first n stamps are decided; seg[k] is the index in
            :attr:`segments` of the steady segment t_ns[k] lies in, −1 when it lies in a
            change (left out) (k < n).
        """
        if not self.seen or not len(t_ns):
            return len(t_ns), np.full(len(t_ns), -2, dtype=np.int64)
        assert self.last_ns is not None
        n = len(t_ns)
        if not final:
            cur = self._cur
            if cur is not None and not cur.confirmed:
                hold_from = _BEFORE if cur.first_ns == self.first_ns else cur.first_ns
                n = int(np.searchsorted(t_ns, hold_from, side='left'))
            else:
                n = int(np.searchsorted(t_ns, self.last_ns, side='right'))
        t = t_ns[:n]
        firsts, lasts = self._segment_bounds()
        if not len(firsts):
            return n, np.full(n, -1, dtype=np.int64)
        k = np.searchsorted(firsts, t, side='right') - 1
        inside = (k >= 0) & (t <= lasts[np.maximum(k, 0)])
        return n, np.where(inside, k, -1).astype(np.int64)

    def segment_rate(self, index: int) -> float:
        """The rate of steady segment ``index``, rad/s."""
        return self.segments[index].rate_rad_s

    def angle_at(self, t_ns: IntArray, index: int) -> FloatArray:
        """The table's angle at gyro stamps of steady segment ``index``, rad.

        Linear between the states around each stamp; beyond the first or last state along
        the segment's rate. Needs ``keep_angles``.
        """
        if len(self._hist_t) > 1:
            self._hist_t = [np.concatenate(self._hist_t)]
            self._hist_a = [np.concatenate(self._hist_a)]
        ht, ha = self._hist_t[0], self._hist_a[0]
        assert self.first_ns is not None
        origin = self.first_ns  # fixed: the numbers do not depend on what was forgotten
        x = (t_ns - origin) / NS_PER_S
        xs = (ht - origin) / NS_PER_S
        out = np.interp(x, xs, ha)
        rate = self.segments[index].rate_rad_s
        lo, hi = x < xs[0], x > xs[-1]
        out = np.where(lo, ha[0] + rate * (x - xs[0]), out)
        return np.where(hi, ha[-1] + rate * (x - xs[-1]), out)

    def has_angles(self) -> bool:
        """Angles were kept (``keep_angles``) and some state gave one."""
        return bool(self._hist_t)

    def forget_before(self, t_ns: int) -> None:
        """Drop the kept angles no later gyro stamp needs (all but the last state ≤ t_ns)."""
        if not self._hist_t:
            return
        ht = np.concatenate(self._hist_t) if len(self._hist_t) > 1 else self._hist_t[0]
        ha = np.concatenate(self._hist_a) if len(self._hist_a) > 1 else self._hist_a[0]
        k = max(0, int(np.searchsorted(ht, t_ns, side='right')) - 1)
        self._hist_t, self._hist_a = [ht[k:]], [ha[k:]]

    def overlaps(self, start_ns: int, end_ns: int) -> bool:
        """A stretch left out overlaps [start_ns, end_ns]."""
        return bool(self._overlapping(start_ns, end_ns))

    def _overlapping(self, start_ns: int, end_ns: int) -> list[MotionSpan]:
        out = []
        for s in self.changes():
            a = _BEFORE if s.start_ns is None else s.start_ns
            b = _AFTER if s.end_ns is None else s.end_ns
            if a < end_ns and b > start_ns:
                out.append(s)
        return out

    def span_max_rate(self, start_ns: int, end_ns: int) -> float:
        """The largest |rate| of the stretches left out overlapping [start_ns, end_ns], rad/s."""
        return max((s.max_rate_rad_s for s in self._overlapping(start_ns, end_ns)), default=0.0)

    def spans_within(self, start_ns: int, end_ns: int) -> list[MotionSpan]:
        """The stretches left out overlapping [start_ns, end_ns]."""
        return self._overlapping(start_ns, end_ns)
