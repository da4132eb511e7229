"""Streaming dither-axis misalignment calibration: pulses and table states in, a out.

:class:`DitherCalibrator` takes ``/gyro/pulses`` (stamp, cumulative count) and
``/vibration_table/joint_states`` (stamp, angle, rate, frame_id ``'z'``/``'y'``) as arrays or
sample by sample, cuts the record into blocks of ``block_s`` on a grid anchored at the
first pulse stamp, and reduces each block as soon as both streams have passed its end:

1. fit the table motion (frequency and harmonics) from joint_states,
2. fit the output's own dither line (frequency, amplitude, phase) by nonlinear least
   squares, with the table lines and a straight line as nuisance terms,
3. build the sideband regressors G_in = ∫ω_T·φ and G_quad in closed form, project every
   nuisance term out and add the block's 2×2 reduced normal equations to its orientation.

Only the reduced sums and a few numbers per block are kept (memory bounded for hours of
2 kHz data). The orientation is the table's frame_id: the table along Z measures
a·|sin ψ₀|, along Y a·|cos ψ₀| (METHODS §C); a = √(both²) needs both. Blocks are judged
one at a time: a block without table data, without a dither line, sampled too slowly,
with the vibration frequency on a dither line or harmonic, or with glitching counts is
rejected with its reason and nothing else is lost. Results depend only on stamps and
values, never on how the data was chunked (blocks are reduced in stamp order once
complete). Call :meth:`DitherCalibrator.end_recording` between two recordings (two bags).

Modules: :mod:`~gyro_calib.dither.block` judges and reduces one block (steps 1–3),
:mod:`~gyro_calib.dither.components` turns an orientation's sums into its component,
:mod:`~gyro_calib.dither.results` assembles the summary, results and what is missing; this
module streams the samples into blocks.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

from gyro_calib.dither import topics
from gyro_calib.dither.block import (
    AXES,
    FRAME_CODES,
    BlockReduction,
    BlockSummary,
    OrientationRecord,
    line_conflicts,
)
from gyro_calib.dither.components import (
    ALLOWANCE_SECOND_ORDER,
    CLOCK_LOCK_FACTOR,
    clock_lock,
)
from gyro_calib.dither.keys import (
    KEY_A,
    KEY_AMPLITUDE,
    KEY_AMPLITUDE_PULSES,
    KEY_CONING,
    KEY_CONING_TOTAL,
    KEY_FREQUENCY,
    KEY_LIMIT,
    KEY_LOWER,
    KEY_UPPER,
    KEY_VERDICT,
    KEY_Y,
    KEY_Z,
)
from gyro_calib.dither.results import (
    COMPONENT_KEYS,
    RESULT_KEYS,
    DitherSummary,
    ResultAssembly,
    describe_component,
)
from gyro_calib.dither.settings import DitherSettings
from gyro_calib.dither.wording import arcmin, plus_minus, stamp
from gyro_calib.estimate import Rejection
from gyro_calib.streams import StampedBuffer
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


class _RecordingLike(Protocol):
    """What :func:`calibrate_dither` reads of a recording (its arrays, or a simulator's)."""

    pulse_t_ns: ArrayLike
    pulse_counts: ArrayLike
    table_t_ns: ArrayLike
    table_angle_rad: ArrayLike
    table_rate_rad_s: ArrayLike
    frame_id: str


@dataclass(frozen=True, slots=True)
class DitherRecordingArrays:
    """One recording as arrays (the shape :func:`calibrate_dither` takes).

    Attributes:
        pulse_t_ns: /gyro/pulses stamps, int ns.
        pulse_counts: cumulative counts.
        table_t_ns: /vibration_table/joint_states stamps, int ns.
        table_angle_rad: position, rad.
        table_rate_rad_s: velocity, rad/s.
        frame_id: header.frame_id, ``'z'`` or ``'y'``.
    """

    pulse_t_ns: ArrayLike
    pulse_counts: ArrayLike
    table_t_ns: ArrayLike
    table_angle_rad: ArrayLike
    table_rate_rad_s: ArrayLike
    frame_id: str


@dataclass(slots=True)
class DitherCalibrator(BlockReduction, ResultAssembly):
    """Accumulates pulses and vibration-table states into the dither misalignment (§C)."""

    settings: DitherSettings = field(default_factory=DitherSettings)
    pulses: StampedBuffer = field(init=False)
    table: StampedBuffer = field(init=False)
    orientations: dict[str, OrientationRecord] = field(init=False)
    rejections: list[Rejection] = field(default_factory=list)
    _anchor_ns: int | None = None
    _next_block: int = 0
    _notices: list[str] = field(default_factory=list)
    _bad_frames: Counter[str] = field(default_factory=Counter)
    _lag_mark: tuple[int, int] | None = None
    _n_rejections_logged: int = 0
    _recording_code: float | None = None

    def __post_init__(self) -> None:
        """Create the stream buffers and the two orientation records."""
        back = int(self.settings.restart_backstep_s * NS_PER_S)
        self.pulses = StampedBuffer(1, back)
        self.table = StampedBuffer(3, back)
        self.orientations = {axis: OrientationRecord(axis) for axis in AXES}

    # -- input ------------------------------------------------------------------------------
    def add_pulses(self, t_ns: int, count: float) -> None:
        """One /gyro/pulses sample: stamp (ns), cumulative count (pulses)."""
        if self.pulses.append(t_ns, count):
            self._restart(topics.GYRO_PULSES)

    def extend_pulses(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """Many /gyro/pulses samples at once (bag replay)."""
        if self.pulses.extend(t_ns, counts):
            self._restart(topics.GYRO_PULSES)

    def add_table_state(self, t_ns: int, angle_rad: float, rate_rad_s: float,
                        frame_id: str) -> None:
        """One /vibration_table/joint_states sample.

        One /vibration_table/joint_states sample: stamp (ns), angle (rad), rate (rad/s),
        header.frame_id (``'z'`` or ``'y'``).
        """
        code = self._frame_code(frame_id, 1)
        if code is not None and self.table.append(t_ns, angle_rad, rate_rad_s, code):
            self._restart(topics.VIBRATION_TABLE_JOINT_STATES)

    def extend_table_states(self, t_ns: ArrayLike, angle_rad: ArrayLike, rate_rad_s: ArrayLike,
                            frame_id: str | Sequence[str]) -> None:
        """Many joint_states samples at once; ``frame_id`` one for all or one per sample."""
        t = np.asarray(t_ns, dtype=np.int64)
        if isinstance(frame_id, str):
            code = self._frame_code(frame_id, len(t))
            if code is None:
                return
            codes = np.full(len(t), code)
        else:
            if len(frame_id) != len(t):
                raise ValueError('frame_id must be one string or one per sample')
            lookup = {f: self._frame_code(f, 0) for f in set(frame_id)}
            for f in lookup:
                if lookup[f] is None:
                    self._bad_frames[f] += sum(1 for x in frame_id if x == f)
            codes = np.array([np.nan if lookup[f] is None else lookup[f] for f in frame_id])
            keep = np.isfinite(codes)
            t, codes = t[keep], codes[keep]
            angle_rad = np.asarray(angle_rad, np.float64)[keep]
            rate_rad_s = np.asarray(rate_rad_s, np.float64)[keep]
        if self.table.extend(t, angle_rad, rate_rad_s, codes):
            self._restart(topics.VIBRATION_TABLE_JOINT_STATES)

    def _frame_code(self, frame_id: str, count: int) -> float | None:
        code = FRAME_CODES.get(str(frame_id).strip().lower())
        if code is None and count:
            self._bad_frames[str(frame_id)] += count
        return code

    def _restart(self, topic: str) -> None:
        """A source restarted (stamps jumped back): drop the open block, keep the sums."""
        restarted = self.pulses if topic == topics.GYRO_PULSES else self.table
        other = self.table if restarted is self.pulses else self.pulses
        back = int(self.settings.restart_backstep_s * NS_PER_S)
        new_ns = restarted.newest_ns
        if other.newest_ns is not None and (new_ns is None or other.newest_ns >= new_ns + back):
            other.clear()
        self._anchor_ns, self._next_block, self._lag_mark = None, 0, None
        self._recording_code = None
        self._notices.append(
            f'{topic} restarted (stamps jumped back by more than '
            f'{self.settings.restart_backstep_s:g} s): the open block was dropped, '
            f'{sum(r.equations.n_blocks for r in self.orientations.values())} accepted blocks '
            f'kept. Call end_recording() between recordings to keep their last block.')

    def end_recording(self) -> list[str]:
        """Judge what is left of this recording and start afresh for the next one.

        Use between two recordings (the Z bag, then the Y bag): their stamps may overlap or
        go back, and the last partial block of the first is kept. Without it (a live node),
        a change of the joint_states frame_id is taken as the end of one recording and the
        start of the next (see :meth:`process`): for recordings that follow each other in
        time the results are identical, bit for bit.
        """
        lines = self.process(flush=True)
        self.pulses.clear()
        self.table.clear()
        self._anchor_ns, self._next_block, self._lag_mark = None, 0, None
        self._recording_code = None
        return lines

    # -- processing --------------------------------------------------------------------------
    def process(self, *, flush: bool = False) -> list[str]:
        """Reduce every block both streams have passed; return new log lines.

        A change of the table's frame_id (the table re-mounted along the other case axis)
        ends one recording and starts the next, exactly as :meth:`end_recording` between
        them would: once the pulses have passed the first joint_states sample of the new
        orientation (stamp b), the block holding the old recording's last pulse is judged
        as a last block (used if it spans at least half a block, on the samples before b),
        and the block grid is anchored afresh at the first pulse from b on.

        Args:
            flush: end of the data: also judge the last, partial block (used if it spans at
                least half a block) and blocks a missing stream left open.
        """
        s = self.settings
        block_ns = int(round(s.block_s * NS_PER_S))
        accepted: Counter[str] = Counter()
        self._anchor()
        while self._anchor_ns is not None:
            start = self._anchor_ns + self._next_block * block_ns
            end = start + block_ns
            boundary = self._orientation_boundary(end, flush)
            if boundary is not None:
                axis = self._end_orientation(start, end, boundary)
                if axis is not None:
                    accepted[axis] += 1
                self._anchor()
                continue
            newest = [self.pulses.newest_ns, self.table.newest_ns]
            lead = max((n for n in newest if n is not None), default=None)
            if lead is None:
                break
            complete = all(n is not None and n >= end for n in newest)
            stalled = self._stalled(newest) and lead >= end
            if not (complete or stalled or flush):
                break
            p_t, p_v = self.pulses.arrays()
            if flush and not complete and not stalled:
                if not len(p_t) or p_t[-1] < start:
                    break
                if p_t[-1] - start < block_ns // 2:
                    if p_t[-1] > start:
                        self._notices.append(
                            f'the last {(p_t[-1] - start) / NS_PER_S:.2f} s of pulses (from '
                            f'{stamp(start)}) are shorter than half a block: not used.')
                    self.pulses.discard_before(end)
                    self.table.discard_before(end)
                    self._next_block += 1
                    break
            t_t, t_v = self.table.arrays()
            pi = slice(*np.searchsorted(p_t, [start, end]))
            ti = slice(*np.searchsorted(t_t, [start, end]))
            axis = self._reduce(start, end, p_t[pi], p_v[pi, 0], t_t[ti], t_v[ti])
            if axis is not None:
                accepted[axis] += 1
            self.pulses.discard_before(end)
            self.table.discard_before(end)
            self._next_block += 1
        return self._log_lines(accepted)

    def _anchor(self) -> None:
        """Anchor the block grid at the first pulse held, if it is not anchored."""
        if self._anchor_ns is None and self.pulses.newest_ns is not None:
            p_t, _ = self.pulses.arrays()
            if len(p_t):
                self._anchor_ns = int(p_t[0])

    def _orientation_boundary(self, end: int, flush: bool) -> int | None:
        """Stamp of the first joint_states sample of a new orientation.

        Stamp b of the first joint_states sample of a new orientation, if the current
        recording's last block is the one ending at ``end`` and the pulses before b are all
        in (or the data ends); else None.
        """
        t_t, t_v = self.table.arrays()
        if not len(t_t):
            return None
        if self._recording_code is None:
            self._recording_code = float(t_v[0, 2])
        change = np.flatnonzero(t_v[:, 2] != self._recording_code)
        if not len(change):
            return None
        b = int(t_t[change[0]])
        newest = self.pulses.newest_ns
        if not flush and (newest is None or newest < b):
            return None  # pulses of the old orientation may still arrive
        p_t, _ = self.pulses.arrays()
        n_before = int(np.searchsorted(p_t, b))
        if n_before and p_t[n_before - 1] >= end:
            return None  # the old recording goes on past this block
        return b

    def _end_orientation(self, start: int, end: int, boundary: int) -> str | None:
        """Judge the old recording's last block, then start the next.

        Judge the old recording's last block on the samples before ``boundary`` (as
        ``process(flush=True)`` judges a last block), then start the next recording there.
        """
        block_ns = end - start
        stop = min(end, boundary)
        p_t, p_v = self.pulses.arrays()
        t_t, t_v = self.table.arrays()
        pi = slice(*np.searchsorted(p_t, [start, stop]))
        ti = slice(*np.searchsorted(t_t, [start, stop]))
        old = AXES[int(self._recording_code or 0.0)]
        new_code = t_v[int(np.searchsorted(t_t, boundary)), 2]
        self._notices.append(
            f'the table was re-mounted: joint_states frame_id changed from "{old}" to '
            f'"{AXES[int(new_code)]}" at {stamp(boundary)}; the {old.upper()} recording ends '
            'there and the next starts (as end_recording() between them).')
        axis = None
        pb, counts = p_t[pi], p_v[pi, 0]
        if len(pb) and pb[-1] - start >= block_ns // 2:
            axis = self._reduce(start, end, pb, counts, t_t[ti], t_v[ti])
        elif len(pb) and pb[-1] > start:
            self._notices.append(
                f'the last {(pb[-1] - start) / NS_PER_S:.2f} s of pulses (from '
                f'{stamp(start)}) are shorter than half a block: not used.')
        self.pulses.discard_before(boundary)
        self.table.discard_before(boundary)
        self._anchor_ns, self._next_block, self._lag_mark = None, 0, None
        self._recording_code = None
        return axis

    def _stalled(self, newest: list[int | None]) -> bool:
        """True if one stream stopped while the other ran on by ``stall_timeout_s``."""
        if None in newest:
            known = [n for n in newest if n is not None]
            if not known or self._anchor_ns is None:
                return False
            return known[0] - self._anchor_ns >= self.settings.stall_timeout_s * NS_PER_S
        stamps = [n for n in newest if n is not None]  # all of them: None was ruled out
        lag, lead = min(stamps), max(stamps)
        if self._lag_mark is None or self._lag_mark[0] != lag:
            self._lag_mark = (lag, lead)
            return False
        return lead - self._lag_mark[1] >= self.settings.stall_timeout_s * NS_PER_S


    def _log_lines(self, accepted: Counter[str]) -> list[str]:
        lines: list[str] = []
        notices, self._notices = self._notices, []
        lines.extend(notices)
        new = self.rejections[self._n_rejections_logged:]
        self._n_rejections_logged = len(self.rejections)
        reasons = Counter(r.reason.split(': ', 1)[1] if ': ' in r.reason else r.reason
                          for r in new)
        for reason, n in reasons.items():
            lines.append(f'{n} block(s) rejected: {reason}')
        if self._bad_frames:
            for frame, n in self._bad_frames.items():
                lines.append(f'{n} /vibration_table/joint_states sample(s) with frame_id '
                             f'{frame!r} ignored: frame_id must be "z" or "y", the case axis the '
                             'table axis is aligned with.')
                self.rejections.append(Rejection(0, lines[-1]))
            self._n_rejections_logged = len(self.rejections)
            self._bad_frames.clear()
        comps = self.components()[0] if accepted else {}
        for axis, n in accepted.items():
            rec = self.orientations[axis]
            last = rec.blocks[-1]
            head = (f'table along {axis.upper()}: {n} block(s) accepted ({rec.equations.n_blocks} '
                    f'in all, {rec.record_s:.0f} s); dither {last.dither_frequency_hz:.2f} Hz, '
                    f'{last.dither_amplitude_pulses:.1f} pulses; table '
                    f'{last.table_frequency_hz:.2f} Hz, {last.table_rate_amplitude_rad_s:.3g} '
                    'rad/s')
            c = comps.get(axis)
            if c is not None:
                why = ('' if math.isfinite(c.std_rad) else
                       ', the rocking allowance needs the scale factor K'
                       if math.isinf(c.rocking_bound_rad) else
                       ', one block gives no scatter yet' if c.n_blocks < 2 else '')
                head += (f'; running component {arcmin(c.signed_rad)} {plus_minus(c.std_rad)}'
                         f'{why} (floor {arcmin(c.floor.component_std_rad)})')
            lines.append(head + '.')
        return lines



def calibrate_dither(*recordings: _RecordingLike,
                     settings: DitherSettings | None = None) -> DitherCalibrator:
    """Batch calibration over whole recordings (e.g. the Z run and the Y run).

    Each recording has ``pulse_t_ns``, ``pulse_counts``, ``table_t_ns``, ``table_angle_rad``,
    ``table_rate_rad_s`` and ``frame_id`` (:class:`DitherRecordingArrays`, or the simulator's
    recordings). Runs the same calibrator a node runs, one recording after the other with
    :meth:`DitherCalibrator.end_recording` between them; returns the finished calibrator.
    """
    cal = DitherCalibrator(settings or DitherSettings())
    for rec in recordings:
        cal.extend_pulses(rec.pulse_t_ns, rec.pulse_counts)
        cal.extend_table_states(rec.table_t_ns, rec.table_angle_rad, rec.table_rate_rad_s,
                                rec.frame_id)
        cal.end_recording()
    return cal


__all__ = [
    'ALLOWANCE_SECOND_ORDER', 'AXES', 'CLOCK_LOCK_FACTOR', 'COMPONENT_KEYS', 'FRAME_CODES',
    'KEY_A', 'KEY_AMPLITUDE', 'KEY_AMPLITUDE_PULSES', 'KEY_CONING', 'KEY_CONING_TOTAL',
    'KEY_FREQUENCY', 'KEY_LIMIT', 'KEY_LOWER', 'KEY_UPPER', 'KEY_VERDICT', 'KEY_Y', 'KEY_Z',
    'RESULT_KEYS', 'BlockSummary', 'DitherCalibrator', 'DitherRecordingArrays',
    'DitherSummary', 'OrientationRecord', 'calibrate_dither', 'clock_lock',
    'describe_component', 'line_conflicts',
]
