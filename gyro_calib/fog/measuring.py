"""Segments and plateaus measured as the FOG streams allow (:class:`FogMeasuring`).

Steps 1–3 of :mod:`gyro_calib.fog.calibrator`: output cells, table segments, injection
plateaus, each measured once the streams cover it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.fog import topics
from gyro_calib.fog.intake import FogIntake
from gyro_calib.fog.segments import rate_deg_s, stamp_text
from gyro_calib.fog.self_cal import (
    PlateauMeasurement,
    check_response,
    describe_plateau,
    measure_plateau,
)
from gyro_calib.fog.turntable import measure_segment


@dataclass(slots=True)
class FogMeasuring(FogIntake):
    """The streams in, measured into segments and plateaus (:meth:`process`)."""

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
