"""One channel (axis) of a noise record: segments, integration, streaming Allan sums.

A :class:`ChannelAccumulator` takes the final, stamp-ordered samples of one axis (from
:class:`gyro_calib.noise.ordering.ReorderBuffer`) and:

- drops non-finite values (counted);
- learns the nominal sample period (median of the first 256 stamp intervals) unless the
  settings give the rate;
- splits the record at gaps (an interval longer than ``gap_threshold_periods`` nominal
  periods) and restarts into segments, each analysed on its own and pooled
  (:mod:`gyro_calib.noise.curve`);
- integrates: rate samples ω_k (rad/s, m/s²) become phase x_0 = 0, x_{k+1} = x_k + ω_k
  (in rate·sample units; the period τ0 cancels from the rate-unit Allan variance), phase
  samples (pulse or output counts) are the phase; a constant (the first value) is taken
  off first, which a second difference ignores but which keeps the sums precise;
- feeds the phase to an :class:`~gyro_calib.noise.tree.AllanTree` (or the full-overlap
  store) and a total-deviation reservoir.

Non-uniform stamps: the samples of a segment are treated as evenly spaced at the
segment's mean period τ0 = (t_last − t_first)/(n − 1), from integer-ns stamps. Stamps
only order the samples, find gaps and set τ0; stamp jitter below the gap threshold does
not enter the values. This is right for a sensor sampling on its own clock and stamped by
a host (the usual IMU bag): integrating ω·Δt with each stamp's Δt would turn stamp jitter
times the mean rate — 9.81 m/s² on a level accelerometer — into false white noise. A
record whose stamps bunch (many intervals below half a period) is reported.
"""

from __future__ import annotations

import copy
import math
import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.noise.allan import AllanSums, AveragingGrid, TauGrid, total_variance_sums
from gyro_calib.noise.curve import AllanCurve, CurvePool, SegmentSums
from gyro_calib.noise.exact import ExactDeviations
from gyro_calib.noise.outliers import OutlierScreen, OutlierTally
from gyro_calib.noise.tree import AllanTree, FullOverlapStore, PhaseReservoir
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.noise.settings import NoiseSettings

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]

INTERVAL_PIECE = 1 << 16
"""Stamp intervals checked at a time (see ChannelAccumulator._evenly_sampled)."""
LEARN_INTERVALS = 256
"""Stamp intervals whose median is the learnt nominal period."""


_PHASE_WORK: dict[int, FloatArray] = {}


def _phase_work(n: int) -> FloatArray:
    """This thread's work array of at least n points for a block's phase (grown, never shrunk).

    Shared by every channel of the thread: the engines copy what they keep.
    """
    key = threading.get_ident()
    work = _PHASE_WORK.get(key)
    if work is None or len(work) < n:
        work = _PHASE_WORK[key] = np.empty(n)
    return work


def format_stamp(t_ns: int) -> str:
    """A stamp as seconds with ns resolution, for log lines."""
    return f'{t_ns // NS_PER_S}.{t_ns % NS_PER_S:09d} s'


@dataclass(slots=True)
class ChannelStats:
    """Counts of one channel."""

    samples: int = 0
    non_finite: int = 0
    gaps: int = 0
    bunched_intervals: int = 0
    intervals: int = 0
    segments_short: int = 0
    segments_other_rate: int = 0
    samples_left_out: int = 0


@dataclass(frozen=True, slots=True)
class SegmentInfo:
    """One gap-free stretch of a channel.

    Attributes:
        start_ns: first stamp, int ns.
        end_ns: last stamp, int ns.
        n_samples: samples in it.
        period_s: mean sample period τ0, s (from integer-ns stamps).
        used: pooled into the channel's Allan variance.
        reason: why it was left out ('' when used).
    """

    start_ns: int
    end_ns: int
    n_samples: int
    period_s: float
    used: bool
    reason: str = ''


@dataclass(slots=True)
class _Segment:
    engine: AllanTree | FullOverlapStore | ExactDeviations
    reservoir: PhaseReservoir | None
    start_ns: int
    last_ns: int
    n_samples: int = 0
    ref: float = 0.0
    carry: float = 0.0


@dataclass(slots=True)
class ChannelAccumulator:
    """Streams one axis into pooled Allan-variance sums (see module docstring).

    Attributes:
        name: axis name ('gyro', 'gyro_x', … 'accel_z').
        kind: 'rate' (IMU samples) or 'phase' (cumulative counts).
        phase_scale: phase unit per count for 'phase' (rad/pulse, rad/count); NaN unknown.
        settings: the analysis settings.
    """

    name: str
    kind: str
    phase_scale: float
    settings: NoiseSettings
    stats: ChannelStats = field(default_factory=ChannelStats)
    segments: list[SegmentInfo] = field(default_factory=list)
    rejections: list[Rejection] = field(default_factory=list)
    notices: list[str] = field(default_factory=list)
    nominal_period_ns: float = math.nan
    _grid: AveragingGrid = field(init=False)
    _pool: CurvePool = field(default_factory=CurvePool)
    _live: _Segment | None = None
    _learn_t: list[IntArray] = field(default_factory=list)
    _learn_v: list[FloatArray] = field(default_factory=list)
    _best_reservoir: tuple[int, FloatArray, int, float] | None = None
    _constant: bool = True
    _first_value: float = math.nan
    screen_spikes: bool = True
    """Screen the samples for spikes (METHODS §E.6); off in a shadow."""
    _screen: OutlierScreen | None = None
    _intervals: IntArray | None = None
    shadow: ChannelAccumulator | None = None
    """The record with the other treatment of its spikes ('remove' when the setting is
    'keep', and the reverse), from the first spike on; None while there is none."""

    def __post_init__(self) -> None:
        """Build the averaging grid; take the nominal period from the settings if given."""
        s = self.settings
        self._grid = AveragingGrid.make(s.taus_per_octave, s.tree_min_averaging_factor)
        if s.sample_rate_hz > 0:
            self.nominal_period_ns = NS_PER_S / s.sample_rate_hz
        if self.screen_spikes:
            self._screen = OutlierScreen(self.kind, s.outlier_sigma, s.outlier_block_samples)

    @property
    def outlier_tally(self) -> OutlierTally | None:
        """What the spike screen found so far (None when it is off)."""
        return self._screen.tally if self._screen is not None else None

    def shadow_curve(self) -> AllanCurve | None:
        """Pooled Allan variance of the record with the other treatment of its spikes."""
        return self.shadow.curve() if self.shadow is not None else None

    # -- input -----------------------------------------------------------------------------
    def feed(self, t_ns: IntArray, values: FloatArray) -> None:
        """Final samples in stamp order (strictly increasing stamps)."""
        if not len(t_ns):
            return
        self.stats.samples += len(t_ns)
        finite = np.isfinite(values)
        n_bad = len(values) - int(np.count_nonzero(finite))
        if n_bad:
            self.stats.non_finite += n_bad
            t_ns, values = t_ns[finite], values[finite]
        if not len(t_ns):
            return
        if self._constant:
            if math.isnan(self._first_value):
                self._first_value = float(values[0])
            if np.any(values != self._first_value):
                self._constant = False
        if math.isnan(self.nominal_period_ns):
            self._learn_t.append(t_ns)
            self._learn_v.append(values)
            if sum(len(a) for a in self._learn_t) > LEARN_INTERVALS:
                self._learn()
            return
        self._segment(t_ns, values)

    def _learn(self) -> None:
        t = np.concatenate(self._learn_t)
        v = np.concatenate(self._learn_v)
        self._learn_t, self._learn_v = [], []
        if len(t) >= 2:
            dt = np.diff(t[:LEARN_INTERVALS + 1])
            self.nominal_period_ns = float(np.median(dt))
            self.notices.append(
                f'{self.name}: nominal sample period {self.nominal_period_ns / 1e6:.6g} ms '
                f'({NS_PER_S / self.nominal_period_ns:.6g} Hz), learnt from the median of '
                f'the first {len(dt)} stamp intervals.')
        if not math.isnan(self.nominal_period_ns):
            self._segment(t, v)
        else:
            self._learn_t, self._learn_v = [t], [v]

    def _evenly_sampled(self, t: IntArray, gap_ns: float) -> bool:
        """Every stamp interval (the one before t[0] too) in [nominal/2, gap_ns].

        Two reductions per piece of :data:`INTERVAL_PIECE` intervals formed in a reused
        array (a chunk-sized array of intervals would cost page faults).
        """
        half = 0.5 * self.nominal_period_ns
        if self._live is not None:
            first = int(t[0]) - self._live.last_ns
            if not (first >= half and first <= gap_ns):
                return False
        if self._intervals is None:
            self._intervals = np.empty(INTERVAL_PIECE, dtype=np.int64)
        for a in range(0, len(t) - 1, INTERVAL_PIECE):
            b = min(a + INTERVAL_PIECE, len(t) - 1)
            dt = np.subtract(t[a + 1:b + 1], t[a:b], out=self._intervals[:b - a])
            if dt.min() < half or dt.max() > gap_ns:
                return False
        return True

    def _segment(self, t: IntArray, v: FloatArray) -> None:
        nominal = self.nominal_period_ns
        gap_ns = self.settings.gap_threshold_periods * nominal
        self.stats.intervals += len(t) if self._live is not None else len(t) - 1
        if self._evenly_sampled(t, gap_ns):
            self._append(t, v)  # evenly sampled (the usual case): two reductions, no scan
            return
        if self._live is not None:
            dt = np.diff(np.concatenate(([self._live.last_ns], t)))  # dt[k]: interval before t[k]
        else:
            dt = np.concatenate(([0], np.diff(t)))  # t[0] has no interval before it
        self.stats.bunched_intervals += int(np.count_nonzero((dt > 0) & (dt < 0.5 * nominal)))
        pos = 0
        for gap in np.nonzero(dt > gap_ns)[0]:
            g = int(gap)
            if g > pos:
                self._append(t[pos:g], v[pos:g])
            if self._live is not None:
                self.stats.gaps += 1
                gap_s = (int(t[g]) - self._live.last_ns) / NS_PER_S
                self.notices.append(
                    f'{self.name}: a gap of {gap_s:.6g} s after '
                    f'{format_stamp(self._live.last_ns)} ends a segment '
                    f'({self._live.n_samples} samples).')
                self._close_live()
            pos = g
        if pos < len(t):
            self._append(t[pos:], v[pos:])

    def _append(self, t: IntArray, v: FloatArray) -> None:
        self._book(t, v)
        if self.shadow is not None:
            self.shadow._book(t, v)
        if self._screen is None:
            self._integrate(v)
            return
        for _, raw, clean in self._screen.push(t, v):
            self._release(raw, clean)

    def _book(self, t: IntArray, v: FloatArray) -> None:
        """Open the live segment if none is; count the samples into it."""
        s = self.settings
        if self._live is None:
            engine: AllanTree | FullOverlapStore | ExactDeviations
            reservoir = None
            if s.overlap == 'partial':
                engine = AllanTree(self._grid)
                reservoir = (PhaseReservoir(s.total_deviation_points)
                             if s.total_deviation_points else None)
            else:
                grid = TauGrid(s.tau_spec, self.nominal_period_ns / NS_PER_S,
                               s.taus_per_octave)
                engine = ExactDeviations(grid.factors_up_to, s.max_tau_fraction,
                                         deviations=s.deviation_names,
                                         memory_points=s.memory_points,
                                         scratch_dir=s.scratch_dir or None)
            self._live = _Segment(engine, reservoir, int(t[0]), int(t[0]), ref=float(v[0]))
            if self.kind == 'rate':
                self._push(np.zeros(1))
        seg = self._live
        seg.n_samples += len(t)
        seg.last_ns = int(t[-1])

    def _release(self, raw: FloatArray, clean: FloatArray) -> None:
        """A screened block (METHODS §E.6): one version to the estimator, one to the shadow.

        The shadow is created at the first spike as a copy of this channel so far.
        """
        main, other = (clean, raw) if self.settings.outliers == 'remove' else (raw, clean)
        if self.shadow is None and not (clean is raw or np.array_equal(clean, raw)):
            self.shadow = self._fork()
        self._integrate(main)
        if self.shadow is not None:
            self.shadow._integrate(other)

    def _fork(self) -> ChannelAccumulator:
        """A copy of this channel without screen or shadow, writing its own scratch file."""
        screen, self._screen = self._screen, None
        try:
            twin = copy.deepcopy(self)
        finally:
            self._screen = screen
        if twin._live is not None and isinstance(twin._live.engine, ExactDeviations):
            twin._live.engine.phase.thaw()
        return twin

    def _integrate(self, v: FloatArray) -> None:
        """Values of the live segment into its phase: rate samples integrated (§E.1).

        The phase is formed in a work array reused block after block (the engines copy what
        they keep; a fresh array of a block's size costs page faults).
        """
        seg = self._live
        assert seg is not None
        n = len(v)
        work = _phase_work(max(n + 1, self.settings.outlier_block_samples + 1))
        if self.kind == 'rate':
            buf = work[:n + 1]
            buf[0] = seg.carry
            np.subtract(v, seg.ref, out=buf[1:])
            np.cumsum(buf, out=buf)  # sequential: the same floats as a fresh cumsum
            x = buf[1:]
            seg.carry = float(x[-1])
        else:
            x = np.subtract(v, seg.ref, out=work[:n])
        self._push(x)

    def _push(self, x: FloatArray) -> None:
        assert self._live is not None
        self._live.engine.push(x)
        if self._live.reservoir is not None:
            self._live.reservoir.push(x)

    # -- segments --------------------------------------------------------------------------
    def restart(self) -> None:
        """The source restarted (new timeline): end the live segment."""
        self._flush_learning()
        if self._live is not None:
            self.notices.append(f'{self.name}: the source restarted after '
                                f'{format_stamp(self._live.last_ns)}; the segment ends there.')
        self._close_live()

    def cut(self) -> None:
        """Samples were left out upstream (the rate table moved): end the live segment.

        The next sample starts a new segment, as after a gap; no gap is counted (the
        motion gate reports what it left out).
        """
        self._flush_learning()
        self._close_live()

    def close(self) -> None:
        """End of the record: learn from what there is and end the live segment."""
        self._flush_learning()
        self._close_live()

    def _flush_learning(self) -> None:
        """Samples held while the period was being learnt: learn from them now and segment."""
        if not self._learn_t:
            return
        t = np.concatenate(self._learn_t)
        v = np.concatenate(self._learn_v)
        self._learn_t, self._learn_v = [], []
        if len(t) >= 2:
            if math.isnan(self.nominal_period_ns):
                self.nominal_period_ns = float(np.median(np.diff(t[:LEARN_INTERVALS + 1])))
            self._segment(t, v)
        else:
            self.stats.samples_left_out += len(t)

    def _period_s(self, seg: _Segment) -> float:
        if seg.n_samples >= 2:
            return (seg.last_ns - seg.start_ns) / (seg.n_samples - 1) / NS_PER_S
        return self.nominal_period_ns / NS_PER_S

    def _segment_sums(self, seg: _Segment) -> SegmentSums | None:
        tau0 = self._period_s(seg)
        if not tau0 > 0:
            return None
        extra = None
        if isinstance(seg.engine, ExactDeviations):
            extra = seg.engine.sums()
            sums = AllanSums(extra.m, extra.adev_sum, extra.adev_terms,
                             np.ones_like(extra.m), extra.n_points)
        else:
            sums = seg.engine.sums()
        if self.kind == 'rate':
            scale = 1.0
        else:
            k = self.phase_scale if math.isfinite(self.phase_scale) else 1.0
            scale = k * k / (tau0 * tau0)
        max_m = int(self.settings.max_tau_fraction * (sums.n_points - 1))
        return SegmentSums(sums, tau0, scale, max_m, extra)

    def _verdict(self, seg: _Segment) -> str:
        s = self.settings
        if seg.n_samples < s.min_segment_samples:
            return (f'{seg.n_samples} samples, fewer than min_segment_samples = '
                    f'{s.min_segment_samples}')
        period = self._period_s(seg)
        nominal = self.nominal_period_ns / NS_PER_S
        if abs(period / nominal - 1.0) > s.period_tolerance:
            return (f'mean period {period * 1e3:.6g} ms differs from the nominal '
                    f'{nominal * 1e3:.6g} ms by more than period_tolerance = '
                    f'{s.period_tolerance:g} (another sample rate)')
        return ''

    def _close_live(self) -> None:
        if self._screen is not None and self._live is not None:
            for _, raw, clean in self._screen.end_segment():
                self._release(raw, clean)
        if self.shadow is not None:
            self.shadow._close_live()
        seg = self._live
        self._live = None
        if seg is None:
            return
        reason = self._verdict(seg)
        info = SegmentInfo(seg.start_ns, seg.last_ns, seg.n_samples, self._period_s(seg),
                           not reason, reason)
        self.segments.append(info)
        if reason:
            if isinstance(seg.engine, ExactDeviations):
                seg.engine.close()
            if seg.n_samples < self.settings.min_segment_samples:
                self.stats.segments_short += 1
            else:
                self.stats.segments_other_rate += 1
            self.stats.samples_left_out += seg.n_samples
            self.rejections.append(Rejection(seg.start_ns, (
                f'{self.name}: the segment from {format_stamp(seg.start_ns)} to '
                f'{format_stamp(seg.last_ns)} is left out: {reason}.')))
            return
        sums = self._segment_sums(seg)
        if sums is not None:
            self._pool.add(sums)
        self._keep_reservoir(seg)
        if isinstance(seg.engine, ExactDeviations):
            seg.engine.close()

    def _keep_reservoir(self, seg: _Segment) -> None:
        if seg.reservoir is None:
            return
        n_points = seg.engine.n_samples
        if self._best_reservoir is None or n_points > self._best_reservoir[0]:
            self._best_reservoir = (n_points, seg.reservoir.phase(), seg.reservoir.stride,
                                    self._period_s(seg))

    # -- results ---------------------------------------------------------------------------
    @property
    def n_used_samples(self) -> int:
        """Samples in pooled segments plus the live one."""
        used = sum(s.n_samples for s in self.segments if s.used)
        return used + (self._live.n_samples if self._live is not None else 0)

    @property
    def has_live_segment(self) -> bool:
        """A segment is open (samples since the last gap, restart or close)."""
        return self._live is not None

    def used_span_ns(self) -> tuple[int, int] | None:
        """First and last stamp of the pooled segments and the live one, or None."""
        spans = [(s.start_ns, s.end_ns) for s in self.segments if s.used]
        seg = self._live
        if seg is not None and seg.n_samples >= self.settings.min_segment_samples \
                and not self._verdict(seg):
            spans.append((seg.start_ns, seg.last_ns))
        if not spans:
            return None
        return min(a for a, _ in spans), max(b for _, b in spans)

    def storage_bytes(self) -> int:
        """Bytes of sample storage held (the live segment's store, reservoirs, screen, shadow).

        The live segment's tree (or store) and reservoirs, the spike screen's open block
        (§E.6) and the shadow's storage.
        """
        total = sum(len(a) * 16 for a in self._learn_t)
        if self._live is not None:
            total += self._live.engine.nbytes()
            if self._live.reservoir is not None:
                total += self._live.reservoir.nbytes()
        if self._best_reservoir is not None:
            total += self._best_reservoir[1].nbytes
        if self._screen is not None:  # the open block of the spike screen (§E.6)
            total += self._screen.nbytes()
        if self.shadow is not None:
            total += self.shadow.storage_bytes()
        return total

    @property
    def first_value(self) -> float:
        """The first finite sample (NaN before any)."""
        return self._first_value

    @property
    def is_constant(self) -> bool:
        """Every finite sample so far had the same value."""
        return self._constant and not math.isnan(self._first_value)

    def curve(self) -> AllanCurve | None:
        """Pooled Allan variance so far (the live segment included, undisturbed)."""
        extra = None
        seg = self._live
        if (seg is not None and seg.n_samples >= self.settings.min_segment_samples
                and not self._verdict(seg)):
            extra = self._segment_sums(seg)
        return self._pool.curve(self.settings.overlap, extra)

    def total_deviation(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None:
        """TOTDEV at long τ from the longest segment's decimated phase.

        Returns:
            (tau_s, totdev, n_points, m) — totdev in rate unit; the reservoir's point count
            and averaging factors (reservoir samples) for the EDF — or None.
        """
        best = self._best_reservoir
        seg = self._live
        if seg is not None and seg.reservoir is not None and not self._verdict(seg):
            if best is None or seg.engine.n_samples > best[0]:
                best = (seg.engine.n_samples, seg.reservoir.phase(), seg.reservoir.stride,
                        self._period_s(seg))
        if best is None:
            return None
        _, x, stride, tau0 = best
        if self.kind == 'phase':
            x = x * (self.phase_scale if math.isfinite(self.phase_scale) else 1.0)
        else:
            x = x * tau0
        m_res = np.arange(8, max((len(x) - 1) // 2, 8) + 1, dtype=np.int64)
        m_eff = self._grid.factors_up_to(int(m_res[-1]) * stride)
        m_eff = m_eff[(m_eff % stride == 0) & (m_eff // stride >= 8)]
        if not len(m_eff):
            return None
        ms, sums, n_terms = total_variance_sums(x, m_eff // stride)
        if not len(ms) or n_terms <= 0:
            return None
        tau = np.asarray(ms * stride * tau0, dtype=np.float64)
        totdev = np.asarray(np.sqrt(sums / (2.0 * n_terms)) / tau, dtype=np.float64)
        return tau, totdev, np.full(len(ms), float(len(x))), ms.astype(np.float64)
