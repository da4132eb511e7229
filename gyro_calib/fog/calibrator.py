"""Streaming FOG calibration: output, injection, table and zero-index streams in, K out.

:class:`FogCalibrator` is the accumulator a node feeds message by message (``add_*``) or
a bag reader feeds array by array (``extend_*``); :func:`calibrate_fog` runs it over
whole recordings. Both run the same code, and the results do not depend on how the
streams were chunked or how far they lag one another (within ``stream_lag_s``):

1. the output counts are reduced to least-squares sums per ``cell_s`` once the stream
   has run ``reorder_margin_s`` past a cell (memory stays bounded);
2. joint_states go through the :class:`~gyro_calib.fog.segments.SegmentDetector`;
   each finished constant-rate segment is measured (:func:`measure_segment`) once the
   output cells cover it and the zero-index stream has passed its end (or the output
   has run ``stream_lag_s`` past it);
3. each injection plateau is measured (:func:`measure_plateau`) once the next message
   has closed it and the output (and the table, if present) cover it;
4. the fits (:func:`fit_turntable`, :func:`fit_mapping`, :func:`fit_self_cal`) are
   recomputed from the measured segments and plateaus when results are asked for.

Turntable segments that overlap a non-zero injection are left out of the turntable and
mapping fits (the injection is not a rotation), also when the injection message arrives
after the segment was measured.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.fog import topics
from gyro_calib.fog.counts import CountCells
from gyro_calib.fog.segments import SegmentDetector, SteadyRun, rate_deg_s, stamp_text
from gyro_calib.fog.self_cal import (
    SETTLING_NOTE,
    PlateauMeasurement,
    SelfCalFit,
    check_response,
    describe_plateau,
    fit_self_cal,
    measure_plateau,
)
from gyro_calib.fog.settings import FogSettings
from gyro_calib.fog.turntable import (
    MappingFit,
    SegmentMeasurement,
    TurntableFit,
    fit_mapping,
    fit_turntable,
    mapping_turntable_covariance,
    measure_segment,
    pooled_noise,
)
from gyro_calib.streams import StampedBuffer, feed_by_timeline, late_summary

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    import numpy.typing as npt
    from numpy.typing import ArrayLike

KEY_SCALE_FACTOR = 'fog_scale_factor_counts_per_rad'
KEY_BIAS = 'fog_bias_rad_s'
KEY_BIAS_PLUS_EARTH = 'fog_bias_plus_earth_rate_rad_s'
KEY_NONLINEARITY = 'fog_nonlinearity_ppm'
KEY_ASYMMETRY = 'fog_asymmetry_ppm'
KEY_QUADRATIC = 'fog_scale_factor_quadratic_s_per_rad'
KEY_CUBIC = 'fog_scale_factor_cubic_s2_per_rad2'
KEY_ARW = 'fog_angle_random_walk_rad_per_sqrt_s'
KEY_MAPPING = 'fog_mapping_scale_factor_counts_per_rad'
KEY_SELF_CAL = 'fog_self_cal_scale_factor_counts_per_rad'
KEY_SELF_CAL_RANGE = 'fog_self_cal_linear_range_rad_s'
KEY_SELF_CAL_NONLINEARITY = 'fog_self_cal_nonlinearity_ppm'
KEY_SELF_CAL_SMALL_SIGNAL = 'fog_self_cal_small_signal_scale_factor_counts_per_rad'
KEY_SELF_CAL_DIFFERENCE = 'fog_self_cal_minus_turntable_scale_factor_counts_per_rad'

TURNTABLE_KEYS = (KEY_SCALE_FACTOR, KEY_NONLINEARITY, KEY_ASYMMETRY, KEY_QUADRATIC, KEY_CUBIC,
                  KEY_ARW)
SELF_CAL_KEYS = (KEY_SELF_CAL, KEY_SELF_CAL_RANGE, KEY_SELF_CAL_NONLINEARITY,
                 KEY_SELF_CAL_SMALL_SIGNAL, KEY_SELF_CAL_DIFFERENCE)


@dataclass(slots=True)
class _Fits:
    turntable: TurntableFit | str
    mapping: MappingFit | str
    self_cal: SelfCalFit | str
    rejections: tuple[Rejection, ...] = ()
    """Segments the fits left out as unsteady (decided over all segments at fit time)."""


@dataclass(slots=True)
class FogCalibrator:
    """Accumulates the FOG streams into the turntable and self-calibration results."""

    settings: FogSettings = field(default_factory=FogSettings)
    rejections: list[Rejection] = field(default_factory=list)
    segments: list[SegmentMeasurement] = field(default_factory=list)
    """Every measured segment (also those an injection overlaps), in time order."""
    plateaus: list[PlateauMeasurement] = field(default_factory=list)
    """Every accepted plateau, in time order."""
    restarts: list[str] = field(default_factory=list)
    """One whole sentence per source restart (what was dropped, what was kept)."""
    _out: StampedBuffer = field(init=False)
    _table: StampedBuffer = field(init=False)
    _index: StampedBuffer = field(init=False)
    _injection: StampedBuffer = field(init=False)
    _cells: CountCells = field(init=False)
    _detector: SegmentDetector = field(init=False)
    _runs: list[SteadyRun] = field(default_factory=list)
    _excluded: set[int] = field(default_factory=set)
    _plateaus_done: int = 0
    _plateau_reference: PlateauMeasurement | None = None
    _zero_reference: PlateauMeasurement | None = None
    _log: list[str] = field(default_factory=list)
    _fits: _Fits | None = None
    _seen: set[str] = field(default_factory=set)
    _newest_out: int | None = None
    _late: list[tuple[str, int]] = field(default_factory=list)
    _spans: list[tuple[int, int]] = field(default_factory=list)
    """(start, end) of the constant-rate run each of :attr:`segments` was measured over."""

    def __post_init__(self) -> None:
        """Create the stream buffers, the output cells and the segment detector."""
        s = self.settings
        back = int(s.restart_backstep_s * 1e9)
        self._out = StampedBuffer(1, back)
        self._table = StampedBuffer(2, back)
        self._index = StampedBuffer(1, back)
        self._injection = StampedBuffer(1, back)
        self._cells = CountCells(int(round(s.cell_s * 1e9)))
        self._detector = self._new_detector()

    def _new_detector(self) -> SegmentDetector:
        s = self.settings
        return SegmentDetector(
            rate_tolerance=s.segment_rate_tolerance,
            rate_floor_rad_s=math.radians(s.segment_rate_floor_deg_s),
            min_segment_s=s.min_segment_s, guard_s=s.segment_guard_s,
            max_excursion_s=s.max_excursion_s,
            static_rate_rad_s=math.radians(s.static_rate_tolerance_deg_s),
            max_gap_s=max(1.0, 2.0 * s.segment_guard_s))

    # -- input ------------------------------------------------------------------------------
    def add_output(self, t_ns: int, count: float) -> None:
        """One `/fog/output` sample: stamp (ns) and cumulative count."""
        self._seen.add(topics.FOG_OUTPUT)
        if self._out.append(int(t_ns), float(count)):
            self._restart(topics.FOG_OUTPUT)

    def extend_output(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """Many `/fog/output` samples (bag replay)."""
        if len(np.asarray(t_ns)):
            self._seen.add(topics.FOG_OUTPUT)
        if self._out.extend(t_ns, counts):
            self._restart(topics.FOG_OUTPUT)

    def add_injection(self, t_ns: int, rate_counts_s: float) -> None:
        """One `/fog/injection` message: stamp (ns) and injected rate (counts/s)."""
        self._seen.add(topics.FOG_INJECTION)
        if self._injection.append(int(t_ns), float(rate_counts_s)):
            self._restart(topics.FOG_INJECTION)
        self._fits = None

    def extend_injection(self, t_ns: ArrayLike, rate_counts_s: ArrayLike) -> None:
        """Many `/fog/injection` messages."""
        if len(np.asarray(t_ns)):
            self._seen.add(topics.FOG_INJECTION)
        if self._injection.extend(t_ns, rate_counts_s):
            self._restart(topics.FOG_INJECTION)
        self._fits = None

    def add_table_state(self, t_ns: int, angle_rad: float, rate_rad_s: float) -> None:
        """One `/rate_table/joint_states` sample: stamp, encoder angle (rad), rate (rad/s)."""
        self._seen.add(topics.RATE_TABLE_JOINT_STATES)
        if self._table.append(int(t_ns), float(angle_rad), float(rate_rad_s)):
            self._restart(topics.RATE_TABLE_JOINT_STATES)

    def extend_table_states(self, t_ns: ArrayLike, angle_rad: ArrayLike,
                            rate_rad_s: ArrayLike) -> None:
        """Many joint_states samples."""
        if len(np.asarray(t_ns)):
            self._seen.add(topics.RATE_TABLE_JOINT_STATES)
        if self._table.extend(t_ns, angle_rad, rate_rad_s):
            self._restart(topics.RATE_TABLE_JOINT_STATES)

    def add_zero_index(self, t_ns: int) -> None:
        """One `/rate_table/zero_index` stamp (ns)."""
        self._seen.add(topics.RATE_TABLE_ZERO_INDEX)
        if self._index.append(int(t_ns), 0.0):
            self._restart(topics.RATE_TABLE_ZERO_INDEX)

    def extend_zero_index(self, t_ns: ArrayLike) -> None:
        """Many zero-index stamps."""
        t = np.asarray(t_ns, dtype=np.int64)
        if len(t):
            self._seen.add(topics.RATE_TABLE_ZERO_INDEX)
        if self._index.extend(t, np.zeros(len(t))):
            self._restart(topics.RATE_TABLE_ZERO_INDEX)

    def reject_late(self, late: Sequence[tuple[str, int]]) -> list[str]:
        """Samples a live node received after later stamps were processed: reject their windows.

        ``late`` holds (topic, stamp) (:class:`~gyro_calib.streams.WatermarkMerge`). A
        segment or plateau within :meth:`_late_margin_ns` of one would not have been
        measured as from a recording of the run: one already measured leaves the fits now,
        one still open is rejected when it closes, each with a line (docs/methods.md, "Live
        input in stamp order"). Returns the lines of what was rejected now.
        """
        self._late.extend((str(topic), int(t)) for topic, t in late)
        lines: list[str] = []
        for i, (seg, span) in enumerate(zip(self.segments, self._spans)):
            why = self._late_reason(*span)
            if i in self._excluded or why is None:
                continue
            self._excluded.add(i)
            lines.append(f'segment at {rate_deg_s(seg.rate_rad_s)} {stamp_text(seg.start_ns)} '
                         f'rejected: {why}')
            self.rejections.append(Rejection(seg.start_ns, lines[-1]))
        kept = []
        for p in self.plateaus:
            why = self._late_reason(p.start_ns, p.end_ns)
            if why is None:
                kept.append(p)
                continue
            lines.append(f'{p.describe()} rejected: {why}')
            self.rejections.append(Rejection(p.start_ns, lines[-1]))
        if lines:
            self.plateaus[:] = kept
            self._fits = None
        return lines

    def _late_margin_ns(self) -> int:
        """How far around a window a late sample still changes it, ns.

        The segment detector's guard (where a run's ends are decided) plus one output cell.
        """
        return int((self.settings.segment_guard_s + self.settings.cell_s) * 1e9)

    def _late_reason(self, start_ns: int, end_ns: int) -> str | None:
        """Why a late sample spoils the window [start, end] (None if none falls near it)."""
        margin = self._late_margin_ns()
        hits = [(topic, t) for topic, t in self._late if start_ns - margin <= t <= end_ns + margin]
        if not hits:
            return None
        return (f'{late_summary(hits)} reached the node after later stamps had been processed '
                f'(its reader lagged): measured without {"them" if len(hits) > 1 else "it"} '
                f'it would differ from the recording; not used.')

    def _restart(self, topic: str) -> None:
        """A source restarted: drop what is pending, keep everything measured."""
        self._cells.clear()
        self._detector = self._new_detector()
        self._runs.clear()
        new = {topics.FOG_OUTPUT: self._out, topics.FOG_INJECTION: self._injection,
               topics.RATE_TABLE_JOINT_STATES: self._table,
               topics.RATE_TABLE_ZERO_INDEX: self._index}
        restarted = new[topic]
        back = int(self.settings.restart_backstep_s * 1e9)
        for buf in new.values():
            if buf is not restarted and buf.newest_ns is not None and (
                    restarted.newest_ns is None or buf.newest_ns >= restarted.newest_ns + back):
                buf.clear()
        self._plateaus_done = 0
        self._plateau_reference = self._zero_reference = None
        self._newest_out = None
        self._late.clear()  # stamps of the old timeline
        note = (f'{topic} restarted (stamps jumped back by more than '
                f'{self.settings.restart_backstep_s:g} s): open segments and plateaus were '
                f'dropped; {len(self.segments)} segment(s) and {len(self.plateaus)} plateau(s) '
                f'kept.')
        self.restarts.append(note)
        self._log.append(note)

    # -- processing -------------------------------------------------------------------------
    def process(self, *, flush: bool = False) -> list[str]:
        """Measure every segment and plateau the streams allow; return new log lines.

        Args:
            flush: the recording ended: measure everything still open with what is there.
        """
        self._reduce_output(flush)
        self._advance_table(flush)
        self._measure_segments(flush)
        self._update_exclusions()
        self._measure_plateaus(flush)
        self._trim()
        if flush:
            self._log.extend(self.stream_notes())
        lines, self._log = self._log, []
        return lines

    def _reduce_output(self, flush: bool) -> None:
        newest = self._out.newest_ns
        if newest is None:
            return
        self._newest_out = newest if self._newest_out is None else max(self._newest_out, newest)
        cell = self._cells.cell_ns
        margin = int(self.settings.reorder_margin_s * 1e9)
        until = (newest // cell + 1) * cell if flush else (newest - margin) // cell * cell
        done = self._cells.reduced_until_ns
        if done is not None and until <= done:
            return
        t, v = self._out.arrays()
        k = int(np.searchsorted(t, until, side='left'))
        self._cells.add_samples(t[:k], v[:k, 0], until)
        self._out.discard_before(until)

    def _advance_table(self, flush: bool) -> None:
        newest = self._table.newest_ns
        if newest is not None:
            limit = newest if flush else newest - int(self.settings.reorder_margin_s * 1e9)
            t, v = self._table.arrays()
            k = int(np.searchsorted(t, limit, side='right'))
            if k:
                self._detector.add(t[:k].tolist(), v[:k, 0].tolist(), v[:k, 1].tolist())
                self._table.discard_before(int(t[k - 1]) + 1)
        if flush:
            self._detector.flush()
        self._runs.extend(self._detector.segments)
        self._detector.segments.clear()

    def _measure_segments(self, flush: bool) -> None:
        lag = int(self.settings.stream_lag_s * 1e9)
        while self._runs:
            run = self._runs[0]
            reduced = self._cells.reduced_until_ns
            if not flush:
                if reduced is None or reduced <= run.end_ns:
                    break
                index_newest = self._index.newest_ns
                out_newest = self._newest_out or 0
                if not ((index_newest is not None and index_newest >= run.end_ns)
                        or out_newest >= run.end_ns + lag):
                    break
            self._runs.pop(0)
            late = self._late_reason(run.start_ns, run.end_ns)
            if late is not None:
                reason = (f'segment at {rate_deg_s(run.rate_rad_s)} {stamp_text(run.start_ns)} '
                          f'rejected: {late}')
                self.rejections.append(Rejection(run.start_ns, reason))
                self._log.append(reason)
                continue
            if self._injected_during(run.start_ns, run.end_ns):
                reason = (f'segment at {rate_deg_s(run.rate_rad_s)} {stamp_text(run.start_ns)} '
                          f'overlaps a self-calibration injection: not used for the turntable '
                          f'fit.')
                self.rejections.append(Rejection(run.start_ns, reason))
                self._log.append(reason)
                continue
            idx, _ = self._index.arrays()
            result = measure_segment(run, idx, self._cells, self.settings)
            if isinstance(result, str):
                self.rejections.append(Rejection(run.start_ns, result))
                self._log.append(result)
                continue
            self.segments.append(result)
            self._spans.append((run.start_ns, run.end_ns))
            self._fits = None
            how = (f'{result.revolutions} revolution(s) between zero-index events'
                   if result.revolutions else 'no whole revolutions (Earth-rate residual ≤ '
                   f'{result.earth_bound_rad_s:.2g} rad/s)')
            self._log.append(
                f'segment at {rate_deg_s(result.rate_rad_s)} {stamp_text(result.start_ns)} '
                f'({result.duration_s:.1f} s, {how}): output {result.output_rate_counts_s:.6f} '
                f'counts/s.')

    def _injection_messages(self) -> tuple[np.ndarray, np.ndarray]:
        t, v = self._injection.arrays()
        return t, v[:, 0]

    def _injected_during(self, start_ns: int, end_ns: int) -> bool:
        """True if a non-zero injection was in force anywhere in [start, end]."""
        t, v = self._injection_messages()
        if len(t) == 0:
            return False
        k0 = max(int(np.searchsorted(t, start_ns, side='right')) - 1, 0)
        k1 = int(np.searchsorted(t, end_ns, side='right'))
        return bool(np.any(v[k0:k1] != 0.0))

    def _update_exclusions(self) -> None:
        """Leave out measured segments a (late-arriving) injection message overlaps."""
        for i, seg in enumerate(self.segments):
            if i in self._excluded or not self._injected_during(seg.start_ns, seg.end_ns):
                continue
            self._excluded.add(i)
            self._fits = None
            reason = (f'segment at {rate_deg_s(seg.rate_rad_s)} {stamp_text(seg.start_ns)} '
                      f'overlaps a self-calibration injection: not used for the turntable fit.')
            self.rejections.append(Rejection(seg.start_ns, reason))
            self._log.append(reason)

    def _plateau_groups(self) -> list[tuple[int, float, int | None]]:
        """(start, J, end or None) of each plateau: runs of equal injection values."""
        t, v = self._injection_messages()
        groups: list[tuple[int, float, int | None]] = []
        for ti, vi in zip(t.tolist(), v.tolist()):
            if groups and groups[-1][1] == vi:
                continue
            if groups:
                groups[-1] = (groups[-1][0], groups[-1][1], ti)
            groups.append((ti, vi, None))
        return groups

    def _measure_plateaus(self, flush: bool) -> None:
        groups = self._plateau_groups()
        t_msgs, v_msgs = self._injection_messages()
        reduced = self._cells.reduced_until_ns
        while self._plateaus_done < len(groups):
            start, value, end = groups[self._plateaus_done]
            if end is None:
                if not flush or self._newest_out is None:
                    break
                end = self._newest_out + 1
            if not flush:
                if reduced is None or reduced < end:
                    break
                if topics.RATE_TABLE_JOINT_STATES in self._seen and (
                        self._detector.processed_until_ns is None
                        or self._detector.processed_until_ns < end):
                    break
            self._plateaus_done += 1
            if end <= start:
                continue
            largest = float(np.max(np.abs(v_msgs[t_msgs <= end]))) if len(v_msgs) else 0.0
            reason = self._static_reason(start, end, value)
            late = self._late_reason(start, end)
            if late is not None:
                reason = f'{describe_plateau(start, value)} rejected: {late}'
            measured: PlateauMeasurement | str
            if reason is None:
                measured = measure_plateau(start, end, value, self._cells, self.settings,
                                           largest)
                if isinstance(measured, str):
                    reason = measured
                else:
                    reference = self._zero_reference or self._plateau_reference
                    reason = check_response(measured, reference, self.settings, largest)
            if reason is not None:
                self.rejections.append(Rejection(start, reason))
                self._log.append(reason)
                continue
            assert isinstance(measured, PlateauMeasurement)
            self.plateaus.append(measured)
            self._fits = None
            self._plateau_reference = measured
            if measured.injection_counts_s == 0.0:
                self._zero_reference = measured
            self._log.append(
                f'{measured.describe()}: settled after '
                f'{(measured.settled_ns - start) / 1e9:.3g} s; output '
                f'{measured.output_rate_counts_s:.6f} ± {measured.std_counts_s:.2g} counts/s '
                f'over {measured.settled_s:.1f} s.')

    def _static_reason(self, start: int, end: int, value: float) -> str | None:
        if topics.RATE_TABLE_JOINT_STATES not in self._seen:
            return None
        spans = list(self._detector.moving)
        if self._detector.moving_until() is not None:
            spans.append((self._detector.moving_until(), end))  # type: ignore[arg-type]
        for a, b in spans:
            if a < end and b > start:
                tol = self.settings.static_rate_tolerance_deg_s
                return (f'{describe_plateau(start, value)}: the rate table turned (faster '
                        f'than {tol:g} °/s) between {stamp_text(max(a, start))} and '
                        f'{stamp_text(min(b, end))}; self-calibration needs a static base; '
                        f'not used.')
        return None

    def _trim(self) -> None:
        """Forget output cells and zero-index events nothing can need any more."""
        needed = [self._detector.pending_start_ns()]
        needed += [r.start_ns for r in self._runs[:1]]
        groups = self._plateau_groups()
        if self._plateaus_done < len(groups):
            needed.append(groups[self._plateaus_done][0])
        elif topics.FOG_INJECTION not in self._seen or groups:
            # a plateau may still start at the next message: keep a lag allowance
            if self._newest_out is not None:
                needed.append(self._newest_out - int(self.settings.stream_lag_s * 1e9))
        keep = [n for n in needed if n is not None]
        if self._cells.reduced_until_ns is None:
            return
        cut = min(keep) if keep else self._cells.reduced_until_ns
        cut = min(cut, self._cells.reduced_until_ns) - self._cells.cell_ns
        self._cells.discard_before(cut)
        self._index.discard_before(cut)
        if self._late:  # late stamps before every open window were judged already
            floor = cut - self._late_margin_ns()
            self._late = [(topic, t) for topic, t in self._late if t >= floor]

    def stream_notes(self) -> list[str]:
        """One line per input stream with samples dropped or re-sorted.

        One line per input stream that had samples dropped or re-sorted (NaN/inf,
        duplicate or out-of-order stamps, restarts), naming what happened.
        """
        notes = []
        for topic, buf in ((topics.FOG_OUTPUT, self._out), (topics.FOG_INJECTION,
                                                              self._injection),
                           (topics.RATE_TABLE_JOINT_STATES, self._table),
                           (topics.RATE_TABLE_ZERO_INDEX, self._index)):
            summary = buf.stats.summary()
            if summary:
                notes.append(f'{topic}: {summary} sample(s) dropped or re-sorted (bad stamps or '
                             f'values never enter a result).')
        return notes

    # -- results -------------------------------------------------------------------------------
    @property
    def seen_topics(self) -> frozenset[str]:
        """The input topics that delivered at least one sample."""
        return frozenset(self._seen)

    @property
    def active_segments(self) -> list[SegmentMeasurement]:
        """Segments used by the turntable and mapping fits (no injection overlap)."""
        return [s for i, s in enumerate(self.segments) if i not in self._excluded]

    def fits(self) -> _Fits:
        """Turntable, mapping and self-calibration fits (each a fit or the reason why not)."""
        if self._fits is None:
            segs, unsteady = self._steady(self.active_segments)
            noise = pooled_noise(segs)
            turntable = fit_turntable(segs, noise, self.settings)
            mapping = fit_mapping(segs, noise, self.settings)
            cov = 0.0
            if isinstance(turntable, TurntableFit) and isinstance(mapping, MappingFit):
                cov = mapping_turntable_covariance(mapping, turntable, segs)
            self_cal: SelfCalFit | str
            if not self.plateaus and topics.FOG_INJECTION not in self._seen:
                self_cal = ('no /fog/injection messages: self-calibration needs the injected '
                            'plateaus (the turntable results stand on their own).')
            else:
                self_cal = fit_self_cal(
                    self.plateaus, mapping if isinstance(mapping, MappingFit) else None,
                    turntable if isinstance(turntable, TurntableFit) else None, cov,
                    self.settings)
            self._fits = _Fits(turntable, mapping, self_cal, unsteady)
        return self._fits

    def _steady(self, segments: list[SegmentMeasurement]) -> tuple[
            list[SegmentMeasurement], tuple[Rejection, ...]]:
        """Leave out segments whose output was not steady.

        Leave out segments whose output was not steady: block scatter far beyond the
        other segments' (the ARW does not depend on the rate; an unrecorded injection or a
        loop disturbance makes the output rate jump within the segment).

        The integer output's quantisation can beat slowly against the sample rate and leave
        up to ½ count in each local-fit count, so up to 1 count² in a block increment: that
        much (1/T_b counts²/s) is allowed beyond the ratio before a segment is called
        unsteady.
        """
        if len(segments) < 3:
            return segments, ()
        n2 = [s.arw_estimate()[0] if s.block_count >= 2 else math.nan for s in segments]
        ratio = self.settings.unsteady_noise_ratio
        keep, rejected = [], []
        for i, seg in enumerate(segments):
            others = [v for j, v in enumerate(n2) if j != i and math.isfinite(v)]
            median = float(np.median(others)) if len(others) >= 2 else math.nan
            excess = n2[i] - 1.0 / seg.block_s if seg.block_s > 0 else math.nan
            if math.isfinite(excess) and median > 0 and excess > ratio * median:
                reason = (f'segment at {rate_deg_s(seg.rate_rad_s)} {stamp_text(seg.start_ns)}: '
                          f'the output rate was not steady — its block scatter is '
                          f'{n2[i] / median:.3g} times the median of the other segments '
                          f'(limit unsteady_noise_ratio = {ratio:g}, beyond the count '
                          f'quantisation): the output changed during '
                          f'the segment (an injection not recorded on /fog/injection? a loop '
                          f'disturbance); not used.')
                rejected.append(Rejection(seg.start_ns, reason))
            else:
                keep.append(seg)
        return keep, tuple(rejected)

    def all_rejections(self) -> list[Rejection]:
        """Everything rejected, in stamp order.

        Everything rejected, in stamp order: while streaming (segments, plateaus) and by
        the fits (unsteady segments).
        """
        return sorted([*self.rejections, *self.fits().rejections],
                      key=lambda r: (r.stamp_ns, r.reason))

    @property
    def bias_key(self) -> str:
        """The hand-off key of the bias: with or without the Earth rate in it."""
        return KEY_BIAS if self.settings.latitude_known else KEY_BIAS_PLUS_EARTH

    def results(self) -> dict[str, Estimate]:
        """Measured quantities by hand-off key (SI units in the names), only those measured."""
        f = self.fits()
        out: dict[str, Estimate] = {}
        if isinstance(f.turntable, TurntableFit):
            t = f.turntable
            out[KEY_SCALE_FACTOR] = t.scale_factor
            out[self.bias_key] = t.bias
            out[KEY_ARW] = t.angle_random_walk_rad_sqrt_s
            for key, est in ((KEY_NONLINEARITY, t.nonlinearity_ppm),
                             (KEY_ASYMMETRY, t.asymmetry_ppm),
                             (KEY_QUADRATIC, t.quadratic_s_per_rad),
                             (KEY_CUBIC, t.cubic_s2_per_rad2)):
                if est is not None:
                    out[key] = est
        if isinstance(f.mapping, MappingFit):
            out[KEY_MAPPING] = f.mapping.scale_factor
        if isinstance(f.self_cal, SelfCalFit):
            s = f.self_cal
            if s.scale_factor is not None and s.linear is not None:
                out[KEY_SELF_CAL] = s.scale_factor
                assert s.linear_range_rad_s is not None
                out[KEY_SELF_CAL_RANGE] = s.linear_range_rad_s
                out[KEY_SELF_CAL_NONLINEARITY] = s.linear.nonlinearity_ppm
            if s.small_signal is not None:
                out[KEY_SELF_CAL_SMALL_SIGNAL] = s.small_signal
            if s.difference is not None:
                out[KEY_SELF_CAL_DIFFERENCE] = s.difference
        rejected = tuple(self.all_rejections())
        # a figure whose value or uncertainty is not a finite number is not measured
        return {k: dataclasses.replace(e, rejected=rejected) for k, e in out.items()
                if math.isfinite(e.value) and math.isfinite(e.std_uncertainty)}

    def summary(self) -> list[str]:
        """Whole-sentence summary lines of the FOG run.

        Whole-sentence lines: each measured figure with its uncertainty and count, and the
        self-calibration table (K against the plateaus used) with the linear range marked.
        """
        res = self.results()
        lines = [f'{key} = {e.value:.10g} ± {e.std_uncertainty:.3g} (k = 1, from {e.n_used})'
                 for key, e in res.items()]
        if self.bias_key == KEY_BIAS_PLUS_EARTH and KEY_BIAS_PLUS_EARTH in res:
            lines.append('the bias includes the Earth rate along the table axis (no latitude '
                         'given).')
        fit = self.fits().self_cal
        if isinstance(fit, SelfCalFit):
            lines += [n for n in fit.notes if n.startswith(SETTLING_NOTE)]
            if fit.difference is not None:
                lines.append(f'self-calibrated K differs from the turntable K by '
                             f'{fit.difference.value:+.6g} ± {fit.difference.std_uncertainty:.3g} '
                             f'counts/rad ({fit.significance_sigma:.1f} σ).')
            for row in fit.table:
                k = (f'K = {row.scale_factor.value:.8g} ± {row.scale_factor.std_uncertainty:.2g}'
                     if row.scale_factor is not None else f'slope {row.slope.value:.8g}')
                mark = '  ← linear range' if row is fit.linear else ''
                lines.append(f'  {row.plateaus:3d} plateaus: {k}, {row.nonlinearity_text()}'
                             f'{mark}')
        lines += [f'{key}: {why}' for key, why in self.missing().items()]
        return lines

    def missing(self) -> dict[str, str]:
        """Hand-off key → why it is not measured (yet), a whole sentence."""
        f = self.fits()
        have = self.results()
        keys = (KEY_SCALE_FACTOR, self.bias_key, KEY_NONLINEARITY, KEY_ASYMMETRY,
                KEY_QUADRATIC, KEY_CUBIC, KEY_ARW, KEY_MAPPING) + SELF_CAL_KEYS
        out: dict[str, str] = {}
        for key in keys:
            if key in have:
                continue
            out[key] = self._why_missing(key, f)
        return out

    def _why_missing(self, key: str, f: _Fits) -> str:
        if key == KEY_ARW and isinstance(f.turntable, TurntableFit):
            return (f'no segment was long enough for two noise blocks of min_block_s = '
                    f'{self.settings.min_block_s:g} s: no angle random walk estimate.')
        if key == KEY_NONLINEARITY and isinstance(f.turntable, TurntableFit):
            return next((n for n in f.turntable.notes if n.startswith('nonlinearity')),
                        'not measured.')
        if key in (KEY_SCALE_FACTOR, self.bias_key, KEY_NONLINEARITY, KEY_ARW):
            return self._turntable_reason(f.turntable)
        if key in (KEY_ASYMMETRY, KEY_QUADRATIC, KEY_CUBIC):
            if isinstance(f.turntable, str):
                return self._turntable_reason(f.turntable)
            word = 'asymmetry' if key == KEY_ASYMMETRY else 'quadratic'
            return next((n for n in f.turntable.notes if n.startswith(word)),
                        'not measured.')
        if key == KEY_MAPPING:
            return f.mapping if isinstance(f.mapping, str) else 'not measured.'
        if isinstance(f.self_cal, str):
            return f.self_cal
        if key == KEY_SELF_CAL_SMALL_SIGNAL and f.self_cal.scale_factor is not None:
            return ('no range of 7 or more injection levels over which a cubic and a quintic '
                    'agree on the slope at zero (too few plateaus, or too much noise).')
        notes = ' '.join(n for n in f.self_cal.notes if not n.startswith(SETTLING_NOTE))
        return notes or 'not measured.'

    def _turntable_reason(self, fit: TurntableFit | str) -> str:
        if isinstance(fit, TurntableFit):
            return 'not measured.'
        if topics.RATE_TABLE_JOINT_STATES not in self._seen:
            return (f'no {topics.RATE_TABLE_JOINT_STATES} messages: the turntable scale factor '
                    f'needs the table rates.')
        return fit


def calibrate_fog(
    output_t_ns: ArrayLike,
    output_counts: ArrayLike,
    *,
    injection_t_ns: ArrayLike = (),
    injection_counts_s: ArrayLike = (),
    table_t_ns: ArrayLike = (),
    table_angle_rad: ArrayLike = (),
    table_rate_rad_s: ArrayLike = (),
    zero_index_ns: ArrayLike = (),
    settings: FogSettings | None = None,
) -> FogCalibrator:
    """Batch FOG calibration over whole recordings; returns the flushed calibrator.

    Read ``results()``, ``missing()``, ``fits()``, ``segments``, ``plateaus`` and
    ``rejections`` from it. If a source restarted (stamps jump back by
    ``restart_backstep_s``), each timeline is calibrated in turn, as a live node would.
    """
    cal = FogCalibrator(settings or FogSettings())
    back = int(cal.settings.restart_backstep_s * 1e9)
    streams: list[tuple[Callable[..., object], npt.NDArray[np.int64],
                        tuple[ArrayLike, ...]]] = [
        (cal.extend_output, np.asarray(output_t_ns, np.int64), (output_counts,)),
        (cal.extend_injection, np.asarray(injection_t_ns, np.int64), (injection_counts_s,)),
        (cal.extend_table_states, np.asarray(table_t_ns, np.int64),
         (table_angle_rad, table_rate_rad_s)),
        (cal.extend_zero_index, np.asarray(zero_index_ns, np.int64), ()),
    ]
    feed_by_timeline(streams, back, lambda: cal.process(flush=True))
    return cal
