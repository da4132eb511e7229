"""Were the bench's tables at rest? The motion gate of a noise record (METHODS §E).

Noise characterisation (IEEE Std 952 Allan analysis) describes a *static* sensor: the
gyro's output must be its noise plus a constant rate. A rate table that turns during the
record puts its own motion profile into the Allan variance — reversals between ±Ω every D
seconds give σ(τ = D) ≈ 0.8·Ω (a square wave: σ² = 2Ω²/3) — and the fit then reports the
table's profile as "noise terms". When the bag (or the live graph) also carries the table's
joint states (``/rate_table/joint_states``: unwrapped encoder angle, rad; rate, rad/s),
:class:`TableMotion` classifies each table state and tells the calibrator which gyro
samples fall while the table moved; those are left out and each span at rest is analysed
as its own segment, as a gap would split it. The two-axis RBRLG bench also records its
position table (``/position_table/joint_states``, same fields), which turns while the rate
table is held in the θ phase: :class:`TableGate` classifies every recorded table alike (each
its own states, the same thresholds) and a gyro sample is at rest only when every recorded
table is; a table never recorded holds nothing back.

A table state is *moving* when

- its rate exceeds ``table_rest_rate_rad_s`` (|ω| > ω_rest), or
- its encoder angle lies more than ``table_rest_angle_rad`` from the angle at which the
  table last came to rest (|θ − θ_ref| > θ_rest; θ_ref is the first state's angle, reset to
  a moving state's angle after each moving state), which catches a creep too slow for the
  rate test.

The defaults sit above the noise of a table encoder at rest: ±1 count is 0.75 µrad for the
2²³-count encoder of our benches and 6 µrad for a coarse 2²⁰-count one, so θ_rest = 2·10⁻⁵ rad
(4.1″) is more than three counts of the coarsest; a rate differentiated from such an encoder
flickers by one count per sample interval, 0.75 µrad × 200 Hz = 1.5·10⁻⁴ rad/s up to
6 µrad × 1 kHz = 6·10⁻³ rad/s, so ω_rest = 10⁻² rad/s (0.57 °/s) is above it; any slower motion
passes θ_rest within θ_rest/ω (2 ms at ω_rest, 0.2 s at 10⁻⁴ rad/s). Motion below both
thresholds is not detected (the summary states them).

Between two table states the table is taken to have moved when either of them is moving
(conservative: motion began after the last state at rest and ended before the first state
at rest after it); before the first state the table is taken as in the first state, after
the last as in the last (zero-order hold). Gyro samples are therefore decided once a table
state at or after their stamp has arrived (or at once while the table moves); the
calibrator holds the others. Before any table state has arrived there is no table on the
graph and every sample is analysed, as without one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]
    BoolArray = npt.NDArray[np.bool_]

RATE_TABLE_JOINT_STATES = '/rate_table/joint_states'
"""The rate table's joint states (the topic contract's name, repeated here so the noise
method imports no other)."""
POSITION_TABLE_JOINT_STATES = '/position_table/joint_states'
"""The two-axis bench's position table (topic contract; the same fields as the rate table's)."""
TABLE_NAMES = {RATE_TABLE_JOINT_STATES: 'rate table',
               POSITION_TABLE_JOINT_STATES: 'position table'}
"""Every table that gates the gyro samples, by topic, with the name the lines give it."""
_BEFORE = np.iinfo(np.int64).min
_AFTER = np.iinfo(np.int64).max


@dataclass(slots=True)
class MotionSpan:
    """One stretch during which the table moved.

    Attributes:
        start_ns: stamp of the last state at rest before it (motion began after it);
            None when the first state already moved.
        end_ns: stamp of the first state at rest after it (motion ended before it); None
            while it lasts.
        first_moving_ns: stamp of its first moving state.
        last_moving_ns: stamp of its last moving state so far.
        max_rate_rad_s: the largest |rate| of its states, rad/s.
    """

    start_ns: int | None
    end_ns: int | None
    first_moving_ns: int
    last_moving_ns: int
    max_rate_rad_s: float = 0.0


@dataclass(slots=True)
class TableMotion:
    """Classifies the rate table's states and gates gyro stamps (see the module docstring).

    Attributes:
        rest_rate_rad_s: ω_rest, rad/s.
        rest_angle_rad: θ_rest, rad.
        states: table states taken in.
        moving_states: those classified moving.
        unusable: states without a finite angle or rate (dropped).
        behind: states stamped at or before one already taken in (dropped).
        spans: the motion spans, in time order.
    """

    rest_rate_rad_s: float
    rest_angle_rad: float
    states: int = 0
    moving_states: int = 0
    unusable: int = 0
    behind: int = 0
    spans: list[MotionSpan] = field(default_factory=list)
    first_ns: int | None = None
    last_ns: int | None = None
    _last_angle: float = math.nan
    _ref_angle: float = math.nan
    _last_moving: bool = False
    _starts: IntArray | None = None
    _ends: IntArray | None = None

    @property
    def seen(self) -> bool:
        """A table state has arrived: the gate is active."""
        return self.states > 0

    @property
    def moved(self) -> bool:
        """The table moved at some time of the record."""
        return bool(self.spans)

    @property
    def max_rate_rad_s(self) -> float:
        """The largest |rate| of any moving state, rad/s (0 when it never moved)."""
        return max((s.max_rate_rad_s for s in self.spans), default=0.0)

    def record_s(self) -> float:
        """Time from the first to the last table state, s."""
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        return (self.last_ns - self.first_ns) / NS_PER_S

    def moving_s(self) -> float:
        """Time the table moved within its record, s (each span clipped to the record)."""
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        total = 0
        for s in self.spans:
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
        fast = np.abs(rate) > self.rest_rate_rad_s  # NaN rate: no rate test
        if self.first_ns is None:
            self.first_ns = int(t[0])
            finite = np.flatnonzero(np.isfinite(angle))
            self._ref_angle = float(angle[finite[0]]) if len(finite) else math.nan
        moving = self._classify(angle, fast)
        self._spans(t, moving, speed)
        self.states += len(t)
        self.moving_states += int(np.count_nonzero(moving))
        self.last_ns = int(t[-1])
        finite = np.flatnonzero(np.isfinite(angle))
        if len(finite):
            self._last_angle = float(angle[finite[-1]])
        self._starts = self._ends = None

    def _speeds(self, t: IntArray, angle: FloatArray, rate: FloatArray) -> FloatArray:
        """|rate| where given, else |Δθ/Δt| from the previous state, rad/s."""
        prev_t = np.concatenate(([self.last_ns if self.last_ns is not None else t[0]], t[:-1]))
        prev_a = np.concatenate(([self._last_angle], angle[:-1]))
        dt = (t - prev_t) / NS_PER_S
        with np.errstate(invalid='ignore', divide='ignore'):
            diff = np.where(dt > 0, np.abs(angle - prev_a) / np.where(dt > 0, dt, 1.0), np.nan)
        return np.where(np.isfinite(rate), np.abs(rate), diff)

    def _classify(self, angle: FloatArray, fast: BoolArray) -> BoolArray:
        """Moving flags of consecutive states (the angle test is sequential in θ_ref)."""
        ref, thr = self._ref_angle, self.rest_angle_rad
        if not fast.any() and not math.isnan(ref):
            with np.errstate(invalid='ignore'):
                far = np.abs(angle - ref) > thr
            if not far.any():  # at rest throughout (the usual static bench): no loop
                return np.zeros(len(angle), dtype=bool)
        if fast.all():  # turning throughout
            finite = np.flatnonzero(np.isfinite(angle))
            if len(finite):
                self._ref_angle = float(angle[finite[-1]])
            return np.ones(len(angle), dtype=bool)
        moving = np.zeros(len(angle), dtype=bool)
        for i in range(len(angle)):
            a = float(angle[i])
            if math.isnan(ref):
                ref = a
            if fast[i] or abs(a - ref) > thr:
                moving[i] = True
                if not math.isnan(a):
                    ref = a
        self._ref_angle = ref
        return moving

    def _spans(self, t: IntArray, moving: BoolArray, speed: FloatArray) -> None:
        """Open, extend and close the motion spans with the new states."""
        prev_moving = self._last_moving
        prev_ns = self.last_ns
        edges = np.flatnonzero(np.diff(np.concatenate(([prev_moving], moving)).astype(np.int8)))
        bounds = [0, *edges.tolist(), len(t)]
        for a, b in zip(bounds[:-1], bounds[1:]):
            if a == b:
                continue
            if moving[a]:
                peak = float(np.nanmax(speed[a:b])) if np.isfinite(speed[a:b]).any() else 0.0
                if a == 0 and prev_moving and self.spans:
                    span = self.spans[-1]
                    span.max_rate_rad_s = max(span.max_rate_rad_s, peak)
                    span.last_moving_ns = int(t[b - 1])
                else:
                    start = prev_ns if a == 0 else int(t[a - 1])
                    self.spans.append(MotionSpan(start, None, int(t[a]), int(t[b - 1]), peak))
            elif a > 0 or prev_moving:
                if self.spans and self.spans[-1].end_ns is None:
                    self.spans[-1].end_ns = int(t[a])
        self._last_moving = bool(moving[-1])

    # -- gyro stamps -------------------------------------------------------------------------
    def _bounds(self) -> tuple[IntArray, IntArray]:
        if self._starts is None or self._ends is None:
            self._starts = np.array([_BEFORE if s.start_ns is None else s.start_ns
                                     for s in self.spans], dtype=np.int64)
            self._ends = np.array([_AFTER if s.end_ns is None else s.end_ns
                                   for s in self.spans], dtype=np.int64)
        return self._starts, self._ends

    def decide(self, t_ns: IntArray, *, final: bool) -> tuple[int, BoolArray]:
        """How many of the (ordered) gyro stamps can be decided now, and which moved.

        Args:
            t_ns: gyro stamps in increasing order, int ns.
            final: no table state will follow (end of the record): the last state holds.

        Returns:
            (n, moving): the first n stamps are decided; moving[k] is True when the table
            moved at t_ns[k] (k < n).
        """
        if not self.seen or not len(t_ns):
            return len(t_ns), np.zeros(len(t_ns), dtype=bool)
        assert self.last_ns is not None
        n = len(t_ns)
        if not final and not self._last_moving:
            n = int(np.searchsorted(t_ns, self.last_ns, side='right'))
        t = t_ns[:n]
        starts, ends = self._bounds()
        if not len(starts):
            return n, np.zeros(n, dtype=bool)
        k = np.searchsorted(starts, t, side='left') - 1
        moving = (k >= 0) & (t < ends[np.maximum(k, 0)])
        return n, moving

    def overlaps(self, start_ns: int, end_ns: int) -> bool:
        """A motion span overlaps [start_ns, end_ns]."""
        for s in self.spans:
            a = _BEFORE if s.start_ns is None else s.start_ns
            b = _AFTER if s.end_ns is None else s.end_ns
            if a < end_ns and b > start_ns:
                return True
        return False

    def span_max_rate(self, start_ns: int, end_ns: int) -> float:
        """The largest |rate| of the motion spans overlapping [start_ns, end_ns], rad/s."""
        out = 0.0
        for s in self.spans:
            a = _BEFORE if s.start_ns is None else s.start_ns
            b = _AFTER if s.end_ns is None else s.end_ns
            if a < end_ns and b > start_ns:
                out = max(out, s.max_rate_rad_s)
        return out


@dataclass(slots=True)
class TableGate:
    """Every table the bench records (:data:`TABLE_NAMES`): the gyro is at rest when all are.

    Attributes:
        tables: each table's :class:`TableMotion`, by topic (rate table first).
    """

    tables: dict[str, TableMotion]

    @classmethod
    def create(cls, rest_rate_rad_s: float, rest_angle_rad: float) -> TableGate:
        """A gate over every table of :data:`TABLE_NAMES`, each with the same thresholds."""
        return cls({topic: TableMotion(rest_rate_rad_s, rest_angle_rad) for topic in TABLE_NAMES})

    def recorded(self) -> list[tuple[str, TableMotion]]:
        """The tables a state arrived from, as (topic, motion), rate table first."""
        return [(topic, tm) for topic, tm in self.tables.items() if tm.seen]

    @property
    def seen(self) -> bool:
        """A state of some table has arrived: the gate is active."""
        return any(tm.seen for tm in self.tables.values())

    def decide(self, t_ns: IntArray, *, final: bool) -> tuple[int, BoolArray]:
        """:meth:`TableMotion.decide` over every recorded table.

        The first n stamps every recorded table decides are decided; a stamp moved when any
        recorded table moved at it. With one table recorded, exactly its decision.
        """
        n = len(t_ns)
        moving = np.zeros(n, dtype=bool)
        for _, tm in self.recorded():
            k, m = tm.decide(t_ns, final=final)
            n = min(n, k)
            moving = moving[:n] | m[:n]
        return n, moving

    def moved_within(self, start_ns: int, end_ns: int) -> list[tuple[str, float]]:
        """The tables that moved within [start_ns, end_ns]: (topic, largest |rate| rad/s)."""
        return [(topic, tm.span_max_rate(start_ns, end_ns)) for topic, tm in self.recorded()
                if tm.overlaps(start_ns, end_ns)]
