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
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from gyro_calib.dither import topics
from gyro_calib.dither.coning import ConingDrift, coning_drift
from gyro_calib.dither.floor import (
    detection_floor,
    required_record_s,
    required_table_rate_amplitude_rad_s,
)
from gyro_calib.dither.lines import (
    fit_dither_line,
    fit_table_motion,
    nuisance_columns,
    sinusoid_columns,
)
from gyro_calib.dither.misalignment import (
    RAD_PER_ARCMIN,
    Component,
    Interval,
    Misalignment,
    RockingAllowance,
    Verdict,
    allowance_half_width,
    combine_components,
    interval_verdict,
    misalignment_interval,
)
from gyro_calib.dither.regression import (
    ReducedNormalEquations,
    choose_null_multiples,
    null_sideband_regressors,
    reduce_block,
    sideband_regressors,
)
from gyro_calib.dither.settings import DitherSettings
from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.streams import StampedBuffer
from gyro_calib.units import NS_PER_S, RAD_PER_ARCSEC

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike

    from gyro_calib.dither.regression import SidebandSolution

    FloatArray = npt.NDArray[np.float64]

AXES = ('z', 'y')
FRAME_CODES = {'z': 0.0, 'y': 1.0}

from gyro_calib.dither.keys import (  # noqa: E402  (names shared with the hand-off keys)
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

RESULT_KEYS = (KEY_A, KEY_Z, KEY_Y, KEY_FREQUENCY, KEY_AMPLITUDE, KEY_AMPLITUDE_PULSES,
               KEY_CONING, KEY_CONING_TOTAL)
"""Every key :meth:`DitherCalibrator.results` may return (issue 12 part 2, the total coning,
and ``dither_amplitude_pulses``, given instead of ``dither_amplitude_rad`` without K)."""
COMPONENT_KEYS = {'z': KEY_Z, 'y': KEY_Y}

CLOCK_LOCK_FACTOR = 2.0
"""λ: with the vibration frequency dividing the pulse sample rate (table and sample clocks
locked, e.g. 20 Hz at 2 kHz), a component's random uncertainty is at least λ times its
white-noise σ. The pulse quantisation then repeats with the table phase at every sample and
only the dither and the count drift can decorrelate it; where they do not (the drift of a
gyro with IA north, 11.5 pulses/s), part of the quantisation error stays coherent with the
sidebands for longer than the data checks (block scatter, null sidebands) can see on one
record. Monte Carlo (benchmarks/dither_floor_monte_carlo.py, A = 20 rad/s, 60 s, IA north,
20 Hz): scatter 1.8× the white σ, ±1σ coverage 50 % without this widening."""


ALLOWANCE_SECOND_ORDER = 0.01
"""Relative margin on κ = k/θ_d for what the first-order allowance leaves out (the shift
θ_r/θ_d is exact to first order in the small angles; the exact kinematics moved a component
by up to 1.0002·κ·a and a by up to 1.0004·ρ·a at a = 60′,
benchmarks/dither_rocking_allowance.py)."""


def clock_lock(table_hz: float, sample_rate_hz: float, record_s: float) -> int:
    """The n if the vibration frequency divides the sample rate (|f_z − f_s/n| < 1/T), else 0.

    Then the table phase at the samples repeats every n samples and slips by less than one
    table cycle over the record T: the table never dithers the quantisation.
    """
    if not (table_hz > 0 and sample_rate_hz > 0 and record_s > 0):
        return 0
    n = max(round(sample_rate_hz / table_hz), 1)
    return n if abs(table_hz - sample_rate_hz / n) < 1.0 / record_s else 0


def _arcmin(value_rad: float) -> str:
    return f'{value_rad / RAD_PER_ARCMIN:.2f}′'


def _stamp(t_ns: int) -> str:
    return f'{t_ns / NS_PER_S:.3f} s'


@dataclass(frozen=True, slots=True)
class BlockSummary:
    """What one accepted block found (kept for plots and checks; a few numbers).

    Attributes:
        start_ns: block start stamp, ns.
        span_s: time covered by its pulse samples, s.
        beta: the block's own (β_in, β_quad), rad.
        beta_std: their standard uncertainties from the block alone, rad.
        dither_frequency_hz: fitted Ω_d/2π, Hz.
        dither_amplitude_pulses: fitted |P|, pulses.
        table_frequency_hz: fitted Ω_z/2π, Hz.
        table_rate_amplitude_rad_s: fitted A, rad/s.
        residual_rms_pulses: rms residual of the block's model, pulses.
        sample_rate_hz: pulse sample rate in the block, Hz.
        drift_pulses_s: straight-line drift of the count (Earth rate + bias), pulses/s.
    """

    start_ns: int
    span_s: float
    beta: tuple[float, float]
    beta_std: tuple[float, float]
    dither_frequency_hz: float
    dither_amplitude_pulses: float
    table_frequency_hz: float
    table_rate_amplitude_rad_s: float
    residual_rms_pulses: float
    sample_rate_hz: float
    drift_pulses_s: float


@dataclass(slots=True)
class OrientationRecord:
    """Everything kept about one orientation: reduced sums, block summaries, spectra."""

    axis: str
    equations: ReducedNormalEquations = field(default_factory=ReducedNormalEquations)
    blocks: list[BlockSummary] = field(default_factory=list)
    spectrum_sum: FloatArray | None = None
    residual_spectrum_sum: FloatArray | None = None
    spectrum_rate_hz: float = math.nan
    n_spectra: int = 0
    last_residual: tuple[FloatArray, FloatArray] | None = None
    null_multiples: tuple[int, ...] | None = None

    @property
    def record_s(self) -> float:
        """Time covered by accepted blocks, s."""
        return float(sum(b.span_s for b in self.blocks))

    def mean(self, name: str) -> float:
        """Mean of a block attribute over accepted blocks."""
        return float(np.mean([getattr(b, name) for b in self.blocks]))


class _RecordingLike(Protocol):
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


def line_conflicts(dither_hz: float, table_hz: float, *, separation_hz: float,
                   harmonics: int) -> list[str]:
    """Why the sidebands f_d ± f_z cannot be told from another modelled line (empty if fine).

    Lines modelled: zero frequency (the straight line), the dither line f_d and its
    harmonic 2·f_d, the table lines h·f_z (h = 1 … H). A sideband within ``separation_hz``
    of any of them — the vibration frequency near the dither frequency, a harmonic or a
    sub-harmonic of it, or too low — is collinear with that line over a block.
    """
    lines = {'zero frequency': 0.0, 'the dither line f_d': dither_hz,
             'the dither harmonic 2·f_d': 2 * dither_hz}
    lines.update({('the table line f_z' if h == 1 else f'the table harmonic {h}·f_z'):
                  h * table_hz for h in range(1, harmonics + 1)})
    out = []
    for name, sb in (('f_d − f_z', abs(dither_hz - table_hz)),
                     ('f_d + f_z', dither_hz + table_hz)):
        for line_name, f in lines.items():
            if abs(sb - f) < separation_hz:
                out.append(f'the sideband {name} = {sb:.2f} Hz lies within {separation_hz:g} Hz '
                           f'of {line_name} ({f:.2f} Hz)')
    for h in range(1, harmonics + 1):
        if abs(dither_hz - h * table_hz) < separation_hz:
            out.append(f'the dither line ({dither_hz:.2f} Hz) lies on the table line '
                       f'{h}·f_z = {h * table_hz:.2f} Hz')
    return out


def _pm(std_rad: float) -> str:
    """'± x′', or '± unbounded' when the uncertainty cannot be stated."""
    return f'± {_arcmin(std_rad)}' if math.isfinite(std_rad) else '± unbounded'


def describe_component(c: Component) -> str:
    """One component as the summary, the figures and the log state it (same numbers)."""
    ab = 'a·|sin ψ₀|' if c.axis == 'z' else 'a·|cos ψ₀|'
    if c.rocking_bound_rad == 0.0:
        rock = ''
    elif math.isinf(c.rocking_bound_rad):
        rock = '; rocking allowance unbounded'
    else:
        rock = f'; rocking allowance ±{_arcmin(c.rocking_bound_rad)}'
    lock = (f'; clock-lock {_arcmin(c.clock_lock_std_rad)}' if c.clock_lock_std_rad else '')
    return (f'table along {c.axis.upper()}: {ab} = {_arcmin(c.magnitude_rad)} {_pm(c.std_rad)} '
            f'(statistical {_arcmin(c.statistical_std_rad)}{lock}{rock}; floor for this '
            f'{c.record_s:.0f} s record {_arcmin(c.floor.component_std_rad)}; {c.n_blocks} '
            'blocks)')


@dataclass(frozen=True, slots=True)
class DitherSummary:
    """Everything measured so far, for reports and plots.

    Attributes:
        components: per measured orientation, its :class:`Component` (every one measured is
            reported, however wide its uncertainty).
        withheld: per orientation with no component, why (no accepted block).
        misalignment: a from both (None until both orientations are measured).
        verdict: acceptance against ``max_misalignment_arcmin`` from the interval (None
            without a component).
        coning: eq. (24) and the dither × rocking term (None without a).
        dither_frequency_hz: mean Ω_d/2π over accepted blocks (NaN if none).
        dither_amplitude_pulses: mean fitted dither line amplitude (NaN if none).
        dither_amplitude_rad: θ_d with K (NaN without K).
        notes: per orientation, conditions worth a line (e.g. a vibration frequency that
            divides the sample rate).
        unresolved: per orientation whose component rests on few blocks or cannot be told
            from zero, a sentence with what would resolve it.
        interval: a's k-interval with the rocking allowance (None without a component).
        rocking: the rocking allowance the results rest on.
    """

    components: dict[str, Component]
    withheld: dict[str, str]
    misalignment: Misalignment | None
    verdict: Verdict | None
    coning: ConingDrift | None
    dither_frequency_hz: float
    dither_amplitude_pulses: float
    dither_amplitude_rad: float
    notes: dict[str, str] = field(default_factory=dict)
    unresolved: dict[str, str] = field(default_factory=dict)
    interval: Interval | None = None
    rocking: RockingAllowance | None = None

    def misalignment_line(self) -> str | None:
        """The a as the summary and the figures state it (None without a)."""
        m = self.misalignment
        if m is None:
            return None
        floor = max(c.floor.component_std_rad for c in self.components.values())
        state = '' if m.resolved else ' (not resolved from zero)'
        if m.rocking_bound_rad == 0.0:
            rock = ''
        elif math.isinf(m.rocking_bound_rad):
            rock = '; rocking allowance unbounded'
        else:
            rock = (f'; rocking allowance ±{_arcmin(m.rocking_bound_rad)}: a ∈ '
                    f'[â/(1 + {m.rho:.3g}), â/(1 − {m.rho:.3g})]')
        lock = (f'; clock-lock {_arcmin(m.clock_lock_std_rad)}' if m.clock_lock_std_rad
                else '')
        return (f'a = {_arcmin(m.value_rad)} {_pm(m.std_rad)}{state} (statistical '
                f'{_arcmin(m.statistical_std_rad)}{lock}{rock}); floor {_arcmin(floor)}; '
                f'ψ₀ = {math.degrees(m.azimuth_rad):.0f}° (kinematics sign convention)')

    def lines(self) -> list[str]:
        """Human summary: each component and a with the floor beside it, verdict, coning."""
        out = []
        for axis in AXES:
            c = self.components.get(axis)
            if c is not None:
                out.append(describe_component(c))
            elif axis in self.withheld:
                out.append(f'table along {axis.upper()}: {self.withheld[axis]}')
        out.extend(self.unresolved.values())
        out.extend(self.notes.values())
        for axis, c in self.components.items():
            if c.null_ratio_squared > 1.5:
                out.append(
                    f'table along {axis.upper()}: the noise at the sidebands is not white '
                    f'(null-sideband χ²/dof = {c.null_ratio_squared:.2f}; the count drifts '
                    f'{c.count_drift_pulses_s:.2g} pulses/s): pulse quantisation is locked to '
                    'the dither, table and sample clocks, and σ was widened by '
                    f'{math.sqrt(c.null_ratio_squared):.2f}×. A vibration frequency that does '
                    'not divide the sample rate (e.g. 19.87 Hz rather than 20 Hz at 2 kHz) '
                    'avoids it.')
        notes = {c.rocking_note for c in self.components.values() if c.rocking_note}
        out.extend(f'rocking allowance unbounded: {n}.' for n in sorted(notes))
        line = self.misalignment_line()
        if line is not None:
            out.append(line)
        if self.verdict is not None:
            out.append(self.verdict.sentence)
        if self.coning is not None:
            cd = self.coning
            total = (f'{cd.total_rad_s:.3g} rad/s' if math.isfinite(cd.total_rad_s)
                     else 'needs K (θ_d in rad)')
            out.append(f'coning drift eq. (24): {cd.eq24_rad_s:.3g} rad/s '
                       f'({math.degrees(cd.eq24_rad_s) * 3600:.2g} °/h); with dither × rocking '
                       f'(worst case): {total}')
        if math.isfinite(self.dither_frequency_hz):
            amp = (f'{self.dither_amplitude_rad / RAD_PER_ARCSEC:.1f}″'
                   if math.isfinite(self.dither_amplitude_rad)
                   else f'{self.dither_amplitude_pulses:.2f} pulses (no K given)')
            out.append(f'dither: {self.dither_frequency_hz:.3f} Hz, amplitude {amp}')
        return out


@dataclass(slots=True)
class DitherCalibrator:
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
                            f'{_stamp(start)}) are shorter than half a block: not used.')
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
            f'"{AXES[int(new_code)]}" at {_stamp(boundary)}; the {old.upper()} recording ends '
            'there and the next starts (as end_recording() between them).')
        axis = None
        pb, counts = p_t[pi], p_v[pi, 0]
        if len(pb) and pb[-1] - start >= block_ns // 2:
            axis = self._reduce(start, end, pb, counts, t_t[ti], t_v[ti])
        elif len(pb) and pb[-1] > start:
            self._notices.append(
                f'the last {(pb[-1] - start) / NS_PER_S:.2f} s of pulses (from '
                f'{_stamp(start)}) are shorter than half a block: not used.')
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

    def _reject(self, start_ns: int, reason: str) -> None:
        self.rejections.append(Rejection(start_ns, reason))

    def _reduce(self, start: int, end: int, p_t: npt.NDArray[np.int64], counts: FloatArray,
                t_t: npt.NDArray[np.int64], t_v: FloatArray) -> str | None:
        """Judge and reduce one block; return its axis if accepted."""
        s = self.settings
        where = f'block {_stamp(start)}–{_stamp(end)}'
        if len(p_t) < 64:
            self._reject(start, f'{where}: {len(p_t)} pulse samples; a block needs at least 64 '
                                '(is /gyro/pulses recorded?).')
            return None
        if len(t_t) < 16:
            self._reject(start, (
                f'{where}: {len(t_t)} /vibration_table/joint_states samples: the table stream '
                'is missing or stopped; each orientation needs the table joint_states beside '
                'the pulses.'))
            return None
        codes = np.unique(t_v[:, 2])
        if len(codes) > 1:
            self._reject(start, f'{where}: the joint_states frame_id changes inside the block '
                                '(orientation changed); the block is not used.')
            return None
        axis = AXES[int(codes[0])]
        max_gap = int(s.max_gap_s * NS_PER_S)
        for name, t in (('pulse', p_t), ('joint_states', t_t)):
            gaps = np.diff(t)
            if len(gaps) and gaps.max() > max_gap:
                i = int(np.argmax(gaps))
                self._reject(start, f'{where}: {name} samples missing for '
                                    f'{gaps[i] / NS_PER_S:.3f} s from {_stamp(int(t[i]))} '
                                    f'(max_gap_s = {s.max_gap_s:g}).')
                return None
        if t_t[0] - p_t[0] > max_gap or p_t[-1] - t_t[-1] > max_gap:
            self._reject(start, (
                f'{where}: joint_states cover only {_stamp(int(t_t[0]))}–{_stamp(int(t_t[-1]))} '
                f'of the pulses\' {_stamp(int(p_t[0]))}–{_stamp(int(p_t[-1]))}: the table stream '
                'started late or stopped early.'))
            return None
        mid = (int(p_t[0]) + int(p_t[-1])) // 2
        tau = (p_t - mid).astype(np.float64) / NS_PER_S
        tau_t = (t_t - mid).astype(np.float64) / NS_PER_S
        span = float(tau[-1] - tau[0])
        fs = (len(p_t) - 1) / span
        fs_table = (len(t_t) - 1) / float(tau_t[-1] - tau_t[0])
        table = fit_table_motion(tau_t, t_v[:, 0], harmonics=s.table_harmonics,
                                 sample_rate_hz=fs_table,
                                 band_hz=(2.0 / span, min(s.table_band_max_hz, 0.45 * fs_table)))
        amp = table.rate_amplitude_rad_s
        if not amp >= s.min_table_rate_amplitude_rad_s:
            self._reject(start, f'{where}: the table along {axis.upper()} is not vibrating '
                                f'(rate amplitude {amp:.2g} rad/s < '
                                f'{s.min_table_rate_amplitude_rad_s:g}).')
            return None
        fz = table.frequency_hz
        if fs / 2 <= s.dither_band_max_hz:
            self._reject(start, (
                f'{where}: pulses sampled at {fs:.0f} Hz cannot resolve a dither up to '
                f'{s.dither_band_max_hz:g} Hz (it would alias): sample faster than '
                f'{2 * (s.dither_band_max_hz + fz):.0f} Hz '
                f'(dither and sidebands at ±{fz:.1f} Hz), '
                'or set dither_band_max_hz to just above your gyro\'s dither frequency.'))
            return None
        y = counts - counts[0]
        dither = fit_dither_line(tau, y, table, harmonics=s.table_harmonics, sample_rate_hz=fs,
                                 band_hz=(s.dither_band_min_hz, s.dither_band_max_hz))
        fd = dither.frequency_hz
        edge = 2.0 / span
        if (dither.amplitude_pulses < s.min_dither_amplitude_pulses
                or not s.dither_band_min_hz + edge <= fd <= s.dither_band_max_hz - edge):
            self._reject(start, (
                f'{where}: no dither line in the output (strongest line '
                f'{dither.amplitude_pulses:.2f} pulses at {fd:.1f} Hz; needs '
                f'≥ {s.min_dither_amplitude_pulses:g} pulses inside {s.dither_band_min_hz:g}–'
                f'{s.dither_band_max_hz:g} Hz): the output looks dither-stripped. The method '
                'needs the raw (unstripped) pulse output, whose dither line gives φ(t).'))
            return None
        if fd + fz >= fs / 2:
            self._reject(start, (
                f'{where}: the upper sideband f_d + f_z = {fd + fz:.1f} Hz is above the Nyquist '
                f'frequency {fs / 2:.0f} Hz of the {fs:.0f} Hz pulses (it aliases): sample faster '
                f'than {2 * (fd + fz):.0f} Hz or vibrate slower.'))
            return None
        if dither.residual_rms_pulses > s.max_residual_rms_pulses:
            self._reject(start, (
                f'{where}: counts deviate from the fitted dither and table lines by '
                f'{dither.residual_rms_pulses:.2f} pulses rms (limit '
                f'{s.max_residual_rms_pulses:g}): count glitches or an unsteady dither.'))
            return None
        conflicts = line_conflicts(fd, fz, separation_hz=s.line_separation_hz,
                                   harmonics=s.table_harmonics)
        if conflicts:
            self._reject(start, (
                f'{where}: vibration frequency {fz:.2f} Hz is too close to the dither frequency '
                f'{fd:.2f} Hz, a harmonic or sub-harmonic of it: {"; ".join(conflicts)}. Choose '
                f'a vibration frequency clear of them (e.g. {0.05 * fd:.0f}–{0.12 * fd:.0f} Hz).'))
            return None
        rec = self.orientations[axis]
        if rec.null_multiples is None:  # fixed at the orientation's first block
            rec.null_multiples = choose_null_multiples(
                fd, fz, fs, harmonics=s.table_harmonics, separation_hz=s.line_separation_hz)
        g_in, g_quad = sideband_regressors(tau, dither, table)
        nulls = null_sideband_regressors(tau, dither, table, rec.null_multiples)
        nuisance = np.hstack((nuisance_columns(tau, table, s.table_harmonics),
                              sinusoid_columns(tau, np.array([dither.angular_frequency_rad_s]))))
        reduction, residual = reduce_block(dither.residual_pulses, nuisance,
                                           np.column_stack((g_in, g_quad, nulls)))
        rec.equations.add(reduction)
        dof = max(reduction.n_samples - reduction.n_nuisance - len(reduction.rhs), 1)
        sigma2 = float(residual @ residual) / dof
        beta = reduction.solve()
        std = np.sqrt(np.diag(np.linalg.inv(reduction.normal)) * sigma2)
        rec.blocks.append(BlockSummary(start, span, (float(beta[0]), float(beta[1])),
                                       (float(std[0]), float(std[1])), fd,
                                       dither.amplitude_pulses, fz, amp,
                                       float(np.sqrt(np.mean(residual ** 2))), fs,
                                       dither.drift_pulses_s))
        self._add_spectra(rec, y - y.mean(), residual, fs)
        rec.last_residual = (tau, residual)
        return axis

    def _add_spectra(self, rec: OrientationRecord, counts: FloatArray, residual: FloatArray,
                     fs: float) -> None:
        n = self.settings.spectrum_samples
        if len(counts) < n // 2:
            return
        window = np.hanning(n)
        norm = 2.0 / window.sum()
        spectra = []
        for series in (counts, residual):
            part = series[:n] - np.mean(series[:n])
            if len(part) < n:
                part = np.concatenate((part, np.zeros(n - len(part))))
            spectra.append((np.abs(np.fft.rfft(part * window)) * norm) ** 2)
        if rec.spectrum_sum is None:
            rec.spectrum_sum, rec.residual_spectrum_sum = spectra
            rec.spectrum_rate_hz = fs
        else:
            rec.spectrum_sum = rec.spectrum_sum + spectra[0]
            rec.residual_spectrum_sum = rec.residual_spectrum_sum + spectra[1]
        rec.n_spectra += 1

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
                head += (f'; running component {_arcmin(c.signed_rad)} {_pm(c.std_rad)}'
                         f'{why} (floor {_arcmin(c.floor.component_std_rad)})')
            lines.append(head + '.')
        return lines

    # -- results -----------------------------------------------------------------------------
    def _raw_solution(self, axis: str) -> SidebandSolution | None:
        rec = self.orientations[axis]
        if rec.equations.n_blocks < 1:
            return None
        return rec.equations.solve()

    def _dither_amplitude_pulses(self) -> float:
        amps = [b.dither_amplitude_pulses for r in self.orientations.values() for b in r.blocks]
        return float(np.mean(amps)) if amps else math.nan

    def rocking_allowance(self, theta_d_rad: float) -> RockingAllowance:
        """The rocking allowance of these settings at dither amplitude θ_d (rad; NaN = no K)."""
        s = self.settings
        k = s.rocking_per_misalignment if s.rocking_treatment == 'bound' else 0.0
        kappa = 0.0 if k == 0.0 else k / theta_d_rad * (1.0 + ALLOWANCE_SECOND_ORDER)
        return RockingAllowance(s.rocking_treatment, s.rocking_model, kappa,
                                s.rocking_arcsec_per_arcmin)

    def components(self) -> tuple[dict[str, Component], dict[str, str]]:
        """Each measured orientation's component, and why the others have none.

        Every measured component is reported (issue 16): one the record cannot tell from
        zero gets its interval and a note saying what would resolve it (:meth:`summary`).
        """
        s = self.settings
        sols = {axis: self._raw_solution(axis) for axis in AXES}
        raw = {axis: float(sol.beta[0]) for axis, sol in sols.items() if sol is not None}
        a_raw = math.hypot(*raw.values()) if raw else 0.0
        cos_a = math.cos(a_raw)  # the output's dither line is θ_d·cos a/K
        amp_pulses = self._dither_amplitude_pulses()
        theta_d = (s.scale_factor_rad_per_pulse * amp_pulses / cos_a if s.has_scale_factor
                   else math.nan)
        rocking = self.rocking_allowance(theta_d)
        arw_pulses = (math.radians(s.angle_random_walk_deg_sqrt_h) / 60.0
                      / s.scale_factor_rad_per_pulse if s.has_scale_factor else 0.0)
        comps: dict[str, Component] = {}
        missing: dict[str, str] = {}
        signed: dict[str, float] = {}
        for axis in AXES:
            sol, rec = sols[axis], self.orientations[axis]
            if sol is None or not math.isfinite(sol.residual_variance_pulses2):
                missing[axis] = (f'no accepted block with the table along {axis.upper()} '
                                 '(joint_states frame_id "' + axis + '").')
                continue
            sign = 1.0 if axis == 'z' else -1.0
            value = sign * sol.beta[0] * cos_a
            if s.rocking_treatment == 'model':
                in_phase = (s.rocking_in_phase_xz_arcsec if axis == 'z'
                            else s.rocking_in_phase_xy_arcsec) * RAD_PER_ARCSEC
                value += in_phase / theta_d
            signed[axis] = float(value)
        random_std: dict[str, float] = {}
        built: dict[str, dict[str, Any]] = {}
        for axis in signed:
            sol, rec = sols[axis], self.orientations[axis]
            assert sol is not None  # signed holds only the axes with a solution
            sigma = math.sqrt(sol.covariance[0, 0]) * cos_a
            fs = rec.mean('sample_rate_hz')
            floor = detection_floor(
                table_rate_amplitude_rad_s=rec.mean('table_rate_amplitude_rad_s'),
                dither_amplitude_rad=rec.mean('dither_amplitude_pulses'),
                record_s=rec.record_s, sample_rate_hz=fs, scale_factor_rad_per_pulse=1.0,
                angle_random_walk_rad_sqrt_s=arw_pulses,
                dither_frequency_hz=rec.mean('dither_frequency_hz'),
                table_frequency_hz=rec.mean('table_frequency_hz'),
                misalignment_rad=abs(signed[axis]))
            fz = rec.mean('table_frequency_hz')
            lock_std, lock_note = 0.0, ''
            n_lock = clock_lock(fz, fs, rec.record_s)
            if n_lock:
                white = sigma / math.sqrt(max(sol.inflation, 1.0))
                lock_std = math.sqrt(max((CLOCK_LOCK_FACTOR * white) ** 2 - sigma ** 2, 0.0))
                lock_note = (
                    f'table along {axis.upper()}: the vibration frequency {fz:.3f} Hz divides the '
                    f'{fs:.0f} Hz sample rate ({n_lock}×): the pulse quantisation is locked to '
                    'the table phase and does not average as white noise (Monte Carlo: up to '
                    '1.8× the floor at 60 s, ±1σ coverage 50 %), which the data checks of one '
                    f'record cannot fully see; the uncertainty is therefore widened to '
                    f'{CLOCK_LOCK_FACTOR:g}× the white-noise σ ({_arcmin(white)} → '
                    f'{_arcmin(math.hypot(sigma, lock_std))}). For the floor, vibrate half way '
                    f'between two divisors of the sample rate, e.g. {fs / (n_lock + 0.5):.2f} Hz '
                    f'or {fs / (n_lock - 0.5):.2f} Hz.')
            random_std[axis] = math.hypot(sigma, lock_std)
            built[axis] = dict(
                axis=axis, signed_rad=signed[axis], statistical_std_rad=sigma,
                quadrature_rad=(-1.0 if axis == 'z' else 1.0) * float(sol.beta[1]) * cos_a,
                quadrature_std_rad=math.sqrt(sol.covariance[1, 1]) * cos_a, floor=floor,
                n_blocks=sol.n_blocks, dof=sol.dof, record_s=rec.record_s, sample_rate_hz=fs,
                birge_ratio_squared=sol.birge_ratio_squared,
                null_ratio_squared=sol.null_ratio_squared,
                count_drift_pulses_s=rec.mean('drift_pulses_s'),
                clock_lock_std_rad=lock_std, clock_lock_note=lock_note,
                table_rate_amplitude_rad_s=rec.mean('table_rate_amplitude_rad_s'))
        bound, note = self._component_allowance(signed, built, rocking)
        for axis, kw in built.items():
            comps[axis] = Component(rocking_bound_rad=bound, rocking_note=note, **kw)
        return comps, missing

    @staticmethod
    def _component_allowance(signed: dict[str, float], built: dict[str, dict[str, Any]],
                             rocking: RockingAllowance) -> tuple[float, str]:
        """(κ·â/(1 − ρ), why unbounded) for the components (module misalignment docstring).

        The shift of one component is at most κ·a, and a is bounded only with both
        orientations measured and ρ < 1; without K, κ is not known at all.
        """
        if rocking.kappa == 0.0:
            return 0.0, ''
        if not rocking.sized:
            return math.inf, ('the rocking allowance k·a/θ_d needs θ_d in rad, i.e. the scale '
                              'factor K (give --scale-factor-rad-per-pulse or --calibration '
                              'FILE, or rocking_treatment: none if the bench has no '
                              'transverse rocking)')
        if len(signed) < 2:
            return math.inf, ('the rocking allowance κ·a needs a, and one orientation bounds '
                              'a only from below: record the other orientation')
        if rocking.rho >= 1.0:
            return math.inf, (f'ρ = {rocking.rho:.2f} ≥ 1: the rocking k·a may be as large as '
                              'the misalignment signal (κ = k/θ_d); measure the rocking '
                              '(rocking_treatment = model) or use a larger dither amplitude')
        vz, vy = (built[a]['statistical_std_rad'] ** 2 for a in AXES)
        value = math.sqrt(max(0.0, signed['z'] ** 2 + signed['y'] ** 2 - vz - vy))
        return allowance_half_width(value, rocking.kappa, rocking.rho), ''

    def _resolution_note(self, c: Component) -> str | None:
        """What a weak component rests on.

        What a component rests on when it is weak: few blocks, or not told from zero
        (then the table amplitude or record that would resolve half the limit).
        """
        s = self.settings
        rec = self.orientations[c.axis]
        notes = []
        if c.n_blocks < s.min_blocks:
            notes.append(f'rests on only {c.n_blocks} block(s) ({c.record_s:.0f} s; min_blocks '
                          f'= {s.min_blocks}): its block-scatter check is weak')
        k = s.verdict_coverage_factor
        if not c.significant:
            target = s.max_misalignment_arcmin * RAD_PER_ARCMIN / (2 * k)
            amp = rec.mean('table_rate_amplitude_rad_s')
            common = dict(dither_amplitude_rad=rec.mean('dither_amplitude_pulses'),
                          sample_rate_hz=c.sample_rate_hz, scale_factor_rad_per_pulse=1.0,
                          dither_frequency_hz=rec.mean('dither_frequency_hz'),
                          table_frequency_hz=rec.mean('table_frequency_hz'))
            a_needed = required_table_rate_amplitude_rad_s(target, record_s=c.record_s,
                                                           **common)
            t_needed = required_record_s(target, table_rate_amplitude_rad_s=amp, **common)
            notes.append(
                f'cannot be told from zero ({_arcmin(c.signed_rad)} ± '
                f'{_arcmin(c.random_std_rad)} statistical; the floor of this {c.record_s:.0f} s '
                f'record at table rate amplitude {amp:.3g} rad/s is '
                f'{_arcmin(c.floor.component_std_rad)}); to resolve half the '
                f'{s.max_misalignment_arcmin:g}′ limit at k = {k:g} (σ ≤ {_arcmin(target)}) '
                f'use A ≥ {a_needed:.3g} rad/s for the same record, or record '
                f'{t_needed / 60:.0f} min at this amplitude')
        if not notes:
            return None
        return f'table along {c.axis.upper()}: the component ' + '; it '.join(notes) + '.'

    def summary(self) -> DitherSummary:
        """Everything measured so far (components, a, interval, verdict, coning, dither)."""
        s = self.settings
        comps, missing = self.components()
        unresolved: dict[str, str] = {}
        for axis, c in comps.items():
            reason = self._resolution_note(c)
            if reason is not None:
                unresolved[axis] = reason
        misalignment = verdict = coning = interval = None
        freqs = [b.dither_frequency_hz for r in self.orientations.values() for b in r.blocks]
        amp_pulses = self._dither_amplitude_pulses()
        a_for_cos = math.hypot(*(c.signed_rad for c in comps.values())) if comps else 0.0
        theta_d = (s.scale_factor_rad_per_pulse * amp_pulses / math.cos(a_for_cos)
                   if s.has_scale_factor else math.nan)
        rocking = self.rocking_allowance(theta_d)
        if len(comps) == 2:
            z, y = comps['z'], comps['y']
            misalignment = combine_components(z, y, rocking)
            coning = coning_drift(z.magnitude_rad, y.magnitude_rad,
                                  dither_frequency_hz=float(np.mean(freqs)),
                                  dither_amplitude_rad=theta_d,
                                  rocking_per_misalignment=s.rocking_per_misalignment,
                                  rocking_phase_rad=s.rocking_phase_rad, model=s.rocking_model)
        if comps:
            interval = misalignment_interval(misalignment, comps, rocking,
                                             s.verdict_coverage_factor)
            verdict = interval_verdict(
                interval, misalignment, rocking,
                limit_rad=s.max_misalignment_arcmin * RAD_PER_ARCMIN,
                record_s=min(c.record_s for c in comps.values()),
                sample_rate_hz=min(c.sample_rate_hz for c in comps.values()),
                table_rate_amplitude_rad_s=max(c.table_rate_amplitude_rad_s
                                               for c in comps.values()),
                missing_axes=tuple(a for a in AXES if a not in comps))
        notes = {axis: c.clock_lock_note for axis, c in comps.items() if c.clock_lock_note}
        return DitherSummary(comps, missing, misalignment, verdict, coning,
                             float(np.mean(freqs)) if freqs else math.nan, amp_pulses, theta_d,
                             notes, unresolved, interval, rocking)

    def _coning_estimates(self, summary: DitherSummary) -> dict[str, Estimate]:
        """Eq. (24) and the total, with uncertainty by the unscented transform of (ŝ_z, ŝ_y)."""
        s = self.settings
        z, y = summary.components['z'], summary.components['y']
        sz, sy, vz, vy = z.magnitude_rad, y.magnitude_rad, z.std_rad, y.std_rad
        spread = math.sqrt(3.0)
        points = [(sz, sy, 1 / 3)] + [(sz + d * spread * vz, sy, 1 / 6) for d in (-1, 1)] + [
            (sz, sy + d * spread * vy, 1 / 6) for d in (-1, 1)]
        vals = [coning_drift(abs(pz), abs(py), dither_frequency_hz=summary.dither_frequency_hz,
                             dither_amplitude_rad=summary.dither_amplitude_rad,
                             rocking_per_misalignment=s.rocking_per_misalignment,
                             rocking_phase_rad=s.rocking_phase_rad, model=s.rocking_model)
                for pz, py, _ in points]
        weights = np.array([w for *_, w in points])
        out = {}
        n = z.n_blocks + y.n_blocks
        dof = min(z.dof, y.dof)
        unbounded = not (math.isfinite(vz) and math.isfinite(vy))
        for key, attr in ((KEY_CONING, 'eq24_rad_s'), (KEY_CONING_TOTAL, 'total_rad_s')):
            if unbounded:  # a's uncertainty has no bound, so has ε's (value still measured)
                value = getattr(vals[0], attr)
                if math.isfinite(value):
                    out[key] = Estimate(float(value), math.inf, n, dof)
                continue
            v = np.array([getattr(c, attr) for c in vals])
            if not np.all(np.isfinite(v)):
                continue
            mean = float(weights @ v)
            std = math.sqrt(max(float(weights @ (v - mean) ** 2), 0.0))
            out[key] = Estimate(float(v[0]), std, n, dof)
        return out

    def results(self) -> dict[str, Estimate]:
        """Measured quantities by hand-off key (SI units), only those measured so far.

        ``dither_misalignment_z_rad`` / ``_y_rad``: bias-corrected a·|sin ψ₀|, a·|cos ψ₀|;
        ``dither_axis_misalignment_rad``: bias-corrected a (both orientations needed). Every
        measured one is returned, however wide: the standard uncertainty combines the
        statistical part and the rocking allowance (bound/√3) and is inf when the allowance
        cannot be sized (:meth:`result_parts` has the parts and the interval).
        ``dither_amplitude_rad`` needs K; without it ``dither_amplitude_pulses`` is given.
        """
        summary = self.summary()
        out: dict[str, Estimate] = {}
        for axis, c in summary.components.items():
            out[COMPONENT_KEYS[axis]] = Estimate(c.magnitude_rad, c.std_rad, c.n_blocks, c.dof,
                                                 tuple(self.rejections), c.clock_lock_note)
        m = summary.misalignment
        if m is not None:
            z, y = summary.components['z'], summary.components['y']
            out[KEY_A] = Estimate(m.value_rad, m.std_rad, z.n_blocks + y.n_blocks,
                                  min(z.dof, y.dof), tuple(self.rejections),
                                  ' '.join(c.clock_lock_note for c in (z, y)
                                           if c.clock_lock_note))
            out.update(self._coning_estimates(summary))
        blocks = [b for r in self.orientations.values() for b in r.blocks]
        if blocks:
            n = len(blocks)
            freqs = np.array([b.dither_frequency_hz for b in blocks])
            amps = np.array([b.dither_amplitude_pulses for b in blocks])
            f_std = float(np.std(freqs, ddof=1) / math.sqrt(n)) if n > 1 else math.nan
            a_std = float(np.std(amps, ddof=1) / math.sqrt(n)) if n > 1 else math.nan
            out[KEY_FREQUENCY] = Estimate(float(freqs.mean()), f_std, n, n - 1)
            if self.settings.has_scale_factor:
                scale = summary.dither_amplitude_rad / float(amps.mean())
                # θ_d = K·P/cos a: a's uncertainty (rocking bound included) enters as tan a·u(a)
                comps = self.components()[0]
                a_raw = math.hypot(*(c.signed_rad for c in comps.values())) if comps else 0.0
                u_a = (m.std_rad if m is not None else
                       math.hypot(*(c.std_rad for c in comps.values())) if comps else 0.0)
                if not math.isfinite(u_a):  # unbounded a: its statistical part instead
                    u_a = (m.random_std_rad if m is not None else
                           math.hypot(*(c.random_std_rad for c in comps.values())))
                rel = math.tan(a_raw) * u_a
                std = math.hypot(a_std * scale, rel * summary.dither_amplitude_rad)
                out[KEY_AMPLITUDE] = Estimate(summary.dither_amplitude_rad, std, n, n - 1)
            else:
                out[KEY_AMPLITUDE_PULSES] = Estimate(float(amps.mean()), a_std, n, n - 1)
        return out

    def result_parts(self) -> dict[str, dict[str, Any]]:
        """Per misalignment key, the parts of its uncertainty (``--json``).

        ``std_statistical`` (the random part: residuals, block scatter, clock-lock widening),
        ``systematic_bound`` (half-width of the rocking allowance; inf when it cannot be
        sized, 0 when not bounded), ``systematic_model`` (what the bound rests on),
        ``interval`` ([lower, upper] at ``coverage_factor``, the allowance included).
        """
        summary = self.summary()
        rocking = summary.rocking
        model = rocking.description() if rocking is not None else ''
        k = self.settings.verdict_coverage_factor
        out: dict[str, dict[str, Any]] = {}
        m = summary.misalignment
        a_hi = (summary.interval.upper_rad if summary.interval is not None else math.inf)
        kappa = rocking.kappa if rocking is not None else 0.0
        for axis, c in summary.components.items():
            slack = k * c.random_std_rad + (kappa * a_hi if kappa else 0.0)
            out[COMPONENT_KEYS[axis]] = {
                'std_statistical': c.random_std_rad, 'systematic_bound': c.rocking_bound_rad,
                'systematic_model': model + (f' ({c.rocking_note})' if c.rocking_note else ''),
                'interval': [max(c.magnitude_rad - slack, 0.0), c.magnitude_rad + slack],
                'coverage_factor': k}
        if m is not None and summary.interval is not None:
            out[KEY_A] = {
                'std_statistical': m.random_std_rad, 'systematic_bound': m.rocking_bound_rad,
                'systematic_model': model,
                'interval': [summary.interval.lower_rad, summary.interval.upper_rad],
                'coverage_factor': k}
        return out

    def missing(self) -> dict[str, str]:
        """Hand-off key → why it is not measured (yet), a whole sentence."""
        s = self.settings
        summary = self.summary()
        have = self.results()
        out: dict[str, str] = {}
        last = self.rejections[-1].reason if self.rejections else None
        tail = f' Last rejection: {last}' if last else ''
        for axis in AXES:
            key = COMPONENT_KEYS[axis]
            if key not in have:
                out[key] = summary.withheld.get(axis, f'no table along {axis.upper()} yet.') + (
                    tail if axis not in summary.components else '')
        if KEY_A not in have:
            absent = [a.upper() for a in AXES if a not in summary.components]
            out[KEY_A] = (f'a = √(z² + y²) needs both orientations\' components; none with '
                          f'the table along {" and ".join(absent)}. One orientation sees only '
                          'a·|sin ψ₀| or a·|cos ψ₀|, which depends on the mounting azimuth ψ₀ '
                          '(it bounds a from below: see the verdict).')
            for key in (KEY_CONING, KEY_CONING_TOTAL):
                out[key] = 'the coning drift needs a, which needs both orientations.'
        elif KEY_CONING_TOTAL not in have:
            out[KEY_CONING_TOTAL] = ('the dither × rocking coning needs θ_d in rad: give '
                                     'scale_factor_rad_per_pulse (K).')
        for key, est in have.items():
            if math.isinf(est.std_uncertainty):
                out[key] = (f'its value ({est.value:.6g}) is measured and shown with its '
                            'statistical part (summary, --json), but its uncertainty is '
                            'unbounded (the rocking allowance, see above): the hand-off file '
                            'takes only values with a stated uncertainty.')
        interval, verdict = summary.interval, summary.verdict
        if verdict is None:
            for key in (KEY_VERDICT, KEY_LOWER, KEY_UPPER, KEY_LIMIT):
                out[key] = 'the verdict needs at least one measured component.'
        elif interval is not None and not math.isfinite(interval.upper_rad):
            out[KEY_UPPER] = ('nothing bounds a from above yet: ' + verdict.sentence)
        if KEY_FREQUENCY not in have:
            out[KEY_FREQUENCY] = 'no accepted block yet (needs the dither line).' + tail
        if KEY_AMPLITUDE not in have:
            out[KEY_AMPLITUDE] = (
                'θ_d in rad needs the scale factor K (scale_factor_rad_per_pulse); it is '
                'reported in pulses under dither_amplitude_pulses.'
                if not s.has_scale_factor else 'no accepted block yet.' + tail)
        return out


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
