"""The FOG streams in: buffers, late samples, source restarts (:class:`FogIntake`).

The base of :class:`~gyro_calib.fog.calibrator.FogCalibrator`: its state and the ``add_*`` /
``extend_*`` inputs; what is measured from them is in :mod:`gyro_calib.fog.measuring`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.fog import topics
from gyro_calib.fog.counts import CountCells
from gyro_calib.fog.segments import SegmentDetector, SteadyRun, rate_deg_s, stamp_text
from gyro_calib.fog.self_cal import PlateauMeasurement, SelfCalFit
from gyro_calib.fog.settings import FogSettings
from gyro_calib.fog.turntable import MappingFit, SegmentMeasurement, TurntableFit
from gyro_calib.streams import StampedBuffer, late_summary

if TYPE_CHECKING:
    from collections.abc import Sequence

    from numpy.typing import ArrayLike


@dataclass(slots=True)
class _Fits:
    turntable: TurntableFit | str
    mapping: MappingFit | str
    self_cal: SelfCalFit | str
    rejections: tuple[Rejection, ...] = ()
    """Segments the fits left out as unsteady (decided over all segments at fit time)."""


@dataclass(slots=True)
class FogIntake:
    """The FOG streams in: buffered by stamp, late samples and source restarts noted."""

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
