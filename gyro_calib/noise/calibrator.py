"""Streaming noise characterisation: samples in, Allan deviation and IEEE 952 terms out.

:class:`NoiseCalibrator` is the accumulator a node feeds message by message (``add_*``)
or a bag reader feeds array by array (``extend_*``); :func:`calibrate_noise` is the batch
form over whole arrays. Both run the same code and agree exactly, however the data was
chunked (bit-identical: the ordering stage and the Allan sums depend only on the sample
sequence, see :mod:`gyro_calib.noise.ordering` and :mod:`gyro_calib.noise.tree`).

Input streams (topic contract; the lead wires topics to these calls):

================  ==========================  ===========================================
stream            message, fields             axis / unit
================  ==========================  ===========================================
``/gyro/pulses``  sensor_msgs/JointState,     ``gyro``: angle = K·count, K from
                  position[0] cumulative      ``scale_factor_rad_per_pulse``
                  pulse count
``/fog/output``   cumulative output counts    ``gyro``: angle = count / SF, SF from
                                              ``fog_scale_factor_counts_per_rad``
``/imu/pulses``   sensor_msgs/JointState,     one axis per channel, named by its joint:
                  position[0:3] cumulative    angle_i = K_i·count_i (``extend_triad``)
                  pulse counts (a triad)
any Imu topic     sensor_msgs/Imu,            ``gyro_x``, ``gyro_y``, ``gyro_z`` (rad/s),
                  angular_velocity xyz,       ``accel_x``, ``accel_y``, ``accel_z`` (m/s²);
                  linear_acceleration xyz     rate samples integrated (rate·τ0)
================  ==========================  ===========================================

Results are keyed by axis, then by term key (SI unit in the key; accelerometer axes use
velocity/acceleration keys, see :mod:`gyro_calib.noise.terms`)::

    results()  -> {'gyro_x': {'angle_random_walk_rad_per_sqrt_s': Estimate, ...}, ...}
    missing()  -> {'gyro_x': {'rate_ramp_rad_per_s2': 'why it is not reported'}, ...}

Each Estimate: value, standard uncertainty (k = 1), n_used = samples analysed, dof = τ
points fitted − terms fitted. Memory is bounded independently of the record length in
'partial' overlap mode (a few MB per axis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.errors import ConfigError, StreamError
from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.noise.channel import ChannelAccumulator, format_stamp
from gyro_calib.noise.edf import adev_std, edf_totdev
from gyro_calib.noise.fit import NoiseFit, fit_noise_terms
from gyro_calib.noise.mixture import (
    TERM_ALPHA,
    blended_edf,
    curve_edf,
    curve_shares,
    dominant_alpha,
    model_shares,
    slope_shares,
    uniform_quantisation_factor,
)
from gyro_calib.noise.ordering import OrderingStats, ReorderBuffer
from gyro_calib.noise.outliers import OutlierReport, adev_at
from gyro_calib.noise.settings import NoiseSettings
from gyro_calib.noise.table import (
    RATE_TABLE_JOINT_STATES,
    TABLE_NAMES,
    MotionSpan,
    TableGate,
    TableMotion,
)
from gyro_calib.noise.terms import SYMBOLS, TermUnits, units_for_axis
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike

    from gyro_calib.noise.curve import AllanCurve

    FloatArray = npt.NDArray[np.float64]

GYRO_PULSES = '/gyro/pulses'
"""RLG pulse topic (shared contract name, repeated here so the method imports no other)."""
FOG_OUTPUT = '/fog/output'
"""FOG output topic (cumulative output counts)."""
IMU_PULSES = '/imu/pulses'
"""A triad's pulse topic: three joints (the channels), cumulative counts (METHODS §F)."""
PULSE_TOPICS = (GYRO_PULSES, IMU_PULSES)
"""The pulse-count streams (whole pulses: uniform quantisation, lock-in notes)."""
IMU_AXES = ('gyro_x', 'gyro_y', 'gyro_z', 'accel_x', 'accel_y', 'accel_z')
"""Axis names of an Imu stream, in column order."""


@dataclass(frozen=True, slots=True)
class AxisResult:
    """Everything measured on one axis.

    Attributes:
        axis: axis name.
        units: its keys and units.
        curve: pooled Allan variance (None when there is none in SI units).
        fit: the joint term fit (None when no fit ran).
        adev_std: standard deviation of each ADEV point (from the EDF), rate unit.
        total_deviation: (tau_s, totdev, totdev_std) at long τ, or None.
        reason: why the axis has no terms at all ('' when the fit ran).
        alpha: the dominant noise type α at each τ (the term with the largest share of the
            Allan variance; ``noise_alpha``).
        others: 'mdev', 'hdev', 'totdev' → (deviation, its std, its EDF) at the curve's τ
            (full overlap only; NaN where the statistic has no term).
        edf: EDF of the ADEV at each τ, blended over the noise types by their shares
            (:mod:`gyro_calib.noise.mixture`).
        shares: share of Q, N, B, K, R in the Allan variance at each τ (len × 5): the
            fitted model's, or the curve's local slope's where there is no model.
    """

    axis: str
    units: TermUnits
    curve: AllanCurve | None
    fit: NoiseFit | None
    adev_std: FloatArray | None
    total_deviation: tuple[FloatArray, FloatArray, FloatArray] | None
    reason: str = ''
    alpha: npt.NDArray[np.int64] | None = None
    others: dict[str, tuple[FloatArray, FloatArray, FloatArray]] | None = None
    edf: FloatArray | None = None
    shares: FloatArray | None = None
    outliers: OutlierReport | None = None
    """The spikes found and what removing them (or keeping them) changes (§E.6)."""


@dataclass(frozen=True, slots=True)
class StreamCounts:
    """What the ordering and segmenting stages did with one input stream (summary counts).

    Attributes:
        topic: the input topic.
        kind: 'pulses', 'fog', 'imu' or 'triad'.
        received: samples received.
        out_of_order: samples that arrived behind a newer stamp and were sorted in.
        duplicate: samples whose stamp was already held (dropped; the first kept).
        late: samples more than ``reorder_window_s`` behind (dropped).
        restarts: stamp jumps back of ``restart_backstep_s`` or more (new timelines).
        segments: gap-free segments (the live one included).
        gaps: gaps that ended a segment.
        segments_left_out: segments too short or at another sample rate.
        samples_left_out: samples in those.
        non_finite: axis → NaN/inf samples dropped (axes with any).
    """

    topic: str
    kind: str
    received: int
    out_of_order: int
    duplicate: int
    late: int
    restarts: int
    segments: int
    gaps: int
    segments_left_out: int
    samples_left_out: int
    non_finite: dict[str, int]

    def line(self) -> str:
        """One summary line with every count (zeros included)."""
        bad = ', '.join(f'{a} {n}' for a, n in self.non_finite.items()) or '0'
        return (f'{self.topic}: {self.received} samples received; {self.out_of_order} '
                f're-sorted (out of order), {self.duplicate} duplicate stamps dropped, '
                f'{self.late} too late (dropped), {self.restarts} restart(s); '
                f'{self.segments} segment(s), {self.gaps} gap(s), {self.segments_left_out} '
                f'segment(s) left out ({self.samples_left_out} samples); non-finite '
                f'values dropped: {bad}.')


@dataclass(slots=True)
class _Stream:
    topic: str
    reorder: ReorderBuffer
    channels: list[ChannelAccumulator]
    pending_t: list[int]
    pending_v: list[tuple[float, ...]]
    held_t: list[npt.NDArray[np.int64]] = field(default_factory=list)
    """Final samples waiting for the table state at their stamp (motion gate)."""
    held_v: list[FloatArray] = field(default_factory=list)
    moving_run: list[int] | None = None
    """[first stamp, last stamp, samples] of the samples left out since the table began
    to move, while it moves."""
    left_out: int = 0
    """Samples left out because a table (rate or position) moved."""
    before_table: int = 0
    """Samples analysed before any table state had arrived."""
    beyond_table: int = 0
    """Samples decided by the last table state because none followed within table_wait_s."""
    rest_run: int = 0
    """Samples analysed since the table last moved."""
    longest_rest: int = 0
    """The most samples analysed between two motions of the table."""
    final: list[int] = field(default_factory=lambda: [0, 0, 0])
    """[first stamp, last stamp, samples] of the final (ordered) samples, for the mean period."""
    segment_key: tuple[int, ...] | None = None
    """The tables' steady segments the last analysed sample lay in (a change of them cuts)."""
    referenced: int = 0
    """Samples analysed as the gyro's angle minus the rate table's angle."""
    unreferenced: int = 0
    """Samples analysed as the gyro alone although gyro_minus_table was asked for (no rate
    table angle at their stamp)."""


class NoiseCalibrator:
    """Accumulates gyro/IMU streams into Allan deviations and IEEE 952 noise terms."""

    def __init__(self, settings: NoiseSettings | None = None, *, imu_topic: str = 'imu',
                 triad: tuple[tuple[str, ...], tuple[float, ...]] | None = None) -> None:
        """Start empty; streams are created by their first sample.

        Args:
            settings: analysis settings (defaults if None).
            imu_topic: name of the Imu topic, for log lines and reasons.
            triad: the channel names of ``/imu/pulses`` and each channel's K_i (rad/pulse;
                NaN: not known), for :meth:`extend_triad`.
        """
        self.settings = settings if settings is not None else NoiseSettings()
        self.imu_topic = imu_topic
        self.triad = triad
        self._streams: dict[str, _Stream] = {}
        self._n_notices: dict[str, int] = {}
        self._n_rejections_reported = 0
        s = self.settings
        self.gate = TableGate.create(s.table_rest_rate_rad_s, s.table_rest_angle_rad,
                                     min_steady_s=s.table_min_steady_s,
                                     stamp_jitter_s=s.table_stamp_jitter_s,
                                     keep_angles=s.table_reference == 'gyro_minus_table')
        """Every table's motion (optional inputs: a table without states gates nothing;
        :mod:`gyro_calib.noise.table`)."""
        self.table: TableMotion = self.gate.tables[RATE_TABLE_JOINT_STATES]
        """The rate table's motion."""
        self._motion_rejections: list[Rejection] = []
        self._n_motion_reported = 0
        self._flushed = False
        self._cache: dict[str, tuple[tuple[int, int, bool], AxisResult]] = {}

    # -- input ------------------------------------------------------------------------------
    def _stream(self, name: str) -> _Stream:
        if name in self._streams:
            return self._streams[name]
        s = self.settings
        if name in ('pulses', 'fog') and ({'pulses', 'fog'} & set(self._streams)):
            raise StreamError(
                'one NoiseCalibrator characterises one single-axis gyro: both /gyro/pulses '
                'and /fog/output arrived; run one calibrator per gyro.')
        if name == 'pulses':
            channels = [ChannelAccumulator('gyro', 'phase', s.scale_factor_rad_per_pulse, s)]
            topic = GYRO_PULSES
        elif name == 'fog':
            channels = [ChannelAccumulator('gyro', 'phase',
                                           1.0 / s.fog_scale_factor_counts_per_rad, s)]
            topic = FOG_OUTPUT
        elif name == 'triad':
            if self.triad is None:
                raise StreamError(f'{IMU_PULSES}: the calibrator was made without the '
                                  'channels and their K (triad=...).')
            channels = [ChannelAccumulator(c, 'phase', k, s) for c, k in zip(*self.triad)]
            topic = IMU_PULSES
        else:
            channels = [ChannelAccumulator(a, 'rate', 1.0, s) for a in IMU_AXES]
            topic = self.imu_topic
        window = int(round(s.reorder_window_s * NS_PER_S))
        backstep = int(round(s.restart_backstep_s * NS_PER_S))
        stream = _Stream(topic, ReorderBuffer(len(channels), window, backstep), channels, [], [])
        self._streams[name] = stream
        return stream

    def inputs(self) -> tuple[str, ...]:
        """The streams that arrived: 'pulses', 'fog', 'imu', 'triad' (/imu/pulses)."""
        return tuple(self._streams)

    @staticmethod
    def _stamps(t_ns: ArrayLike, what: str) -> npt.NDArray[np.int64]:
        t = np.asarray(t_ns)
        if t.ndim != 1:
            raise StreamError(f'{what}: stamps must be a 1-D array of int ns, '
                              f'got shape {t.shape}.')
        if len(t) and t.dtype.kind not in 'iu':
            raise StreamError(f'{what}: stamps must be integer nanoseconds (int64), '
                              f'got {t.dtype}; convert header stamps with sec·10⁹ + nanosec.')
        return t.astype(np.int64, copy=False)

    def _extend(self, name: str, t_ns: ArrayLike, columns: FloatArray) -> None:
        stream = self._stream(name)
        self._drain(stream)
        self._release(stream, stream.reorder.extend(t_ns, columns))

    def _drain(self, stream: _Stream) -> None:
        if stream.pending_t:
            t = np.asarray(stream.pending_t, dtype=np.int64)
            v = np.asarray(stream.pending_v, dtype=np.float64).reshape(len(t), -1)
            stream.pending_t.clear()
            stream.pending_v.clear()
            self._release(stream, stream.reorder.extend(t, v))

    def _release(self, stream: _Stream, batches: list[Any]) -> None:
        for batch in batches:
            if batch is None:
                self._gate(stream, final=True)  # the old timeline ends: its held samples too
                self._close_motion(stream)
                for ch in stream.channels:
                    ch.restart()
                continue
            t, v = batch
            if len(t):
                if not stream.final[2]:
                    stream.final[0] = int(t[0])
                stream.final[1] = int(t[-1])
                stream.final[2] += len(t)
            if not self.gate.seen and not self._wants_reference(stream):
                stream.before_table += len(t)  # no table (yet): analysed as without one
                self._feed_channels(stream, t, v)
                continue
            stream.held_t.append(t)
            stream.held_v.append(v)
            self._gate(stream, final=False)

    @staticmethod
    def _feed_channels(stream: _Stream, t: npt.NDArray[np.int64], v: FloatArray) -> None:
        stream.rest_run += len(t)
        stream.longest_rest = max(stream.longest_rest, stream.rest_run)
        for k, ch in enumerate(stream.channels):
            ch.feed(t, v[:, k])

    def _wants_reference(self, stream: _Stream) -> bool:
        """gyro_minus_table was asked for and the stream is a gyro angle (pulses, FOG)."""
        return (self.settings.table_reference == 'gyro_minus_table'
                and stream.topic in (GYRO_PULSES, FOG_OUTPUT))

    def _gate(self, stream: _Stream, *, final: bool) -> None:
        """Feed the held samples of steady segments; leave out those while a table changed."""
        if not stream.held_t:
            return
        t = np.concatenate(stream.held_t) if len(stream.held_t) > 1 else stream.held_t[0]
        v = np.concatenate(stream.held_v) if len(stream.held_v) > 1 else stream.held_v[0]
        refer = self._wants_reference(stream)
        n, seg = self.gate.decide(t, final=final, hold_unseen=refer)
        if n < len(t):  # the table's states lag or stopped: the last one holds beyond the wait
            wait_ns = int(round(self.settings.table_wait_s * NS_PER_S))
            m = int(np.searchsorted(t, int(t[-1]) - wait_ns, side='right'))
            if m > n:
                seg = np.concatenate((seg, self.gate.decide(t[n:m], final=True)[1]))
                if self.gate.seen:
                    stream.beyond_table += m - n
                else:
                    stream.before_table += m - n
                n = m
        stream.held_t, stream.held_v = ([t[n:]], [v[n:]]) if n < len(t) else ([], [])
        if n == 0:
            return
        moving = np.any(seg == -1, axis=1)
        change = np.zeros(n, dtype=bool)
        change[1:] = (moving[1:] != moving[:-1]) | np.any(seg[1:] != seg[:-1], axis=1)
        bounds = [*np.flatnonzero(change).tolist(), n]
        if bounds[0] != 0:
            bounds.insert(0, 0)
        for a, b in zip(bounds[:-1], bounds[1:]):
            if not moving[a]:
                key = tuple(int(k) for k in seg[a])
                if stream.moving_run is None and stream.segment_key not in (None, key):
                    for ch in stream.channels:  # another steady segment, nothing between
                        ch.cut()
                self._close_motion(stream)
                stream.segment_key = key
                vv = self._referenced(stream, t[a:b], v[a:b], key) if refer else v[a:b]
                self._feed_channels(stream, t[a:b], vv)
                continue
            stream.left_out += b - a
            stream.rest_run = 0
            if stream.moving_run is None:
                for ch in stream.channels:
                    ch.cut()
                stream.moving_run = [int(t[a]), int(t[b - 1]), b - a]
            else:
                stream.moving_run[1] = int(t[b - 1])
                stream.moving_run[2] += b - a
        if refer:
            self.gate.tables[RATE_TABLE_JOINT_STATES].forget_before(int(t[n - 1]))

    def _referenced(self, stream: _Stream, t: npt.NDArray[np.int64], v: FloatArray,
                    key: tuple[int, ...]) -> FloatArray:
        """The counts minus the rate table's angle in counts: METHODS §E.1 (2b)."""
        table = self.gate.tables[RATE_TABLE_JOINT_STATES]
        scale = stream.channels[0].phase_scale
        index = key[list(self.gate.tables).index(RATE_TABLE_JOINT_STATES)]
        if index < 0 or not table.has_angles() or not math.isfinite(scale):
            stream.unreferenced += len(t)
            return v
        angle = table.angle_at(t, index)
        rate = table.segment_rate(index)
        span_s = (int(t[-1]) - int(t[0])) / NS_PER_S
        if span_s >= 0.1 and abs(rate) > 10.0 * self.settings.table_rest_rate_rad_s:
            gyro_rate = (float(v[-1, 0]) - float(v[0, 0])) * scale / span_s
            if abs(gyro_rate - rate) > 0.5 * abs(rate):
                raise ConfigError(
                    f'table_reference = gyro_minus_table: {stream.topic} turns at '
                    f'{math.degrees(gyro_rate):.4g} °/s while the rate table turns at '
                    f'{math.degrees(rate):.4g} °/s (from {format_stamp(int(t[0]))}): the '
                    'sense axis does not lie along the table\'s axis counting the same way, '
                    'so its angle minus the table\'s is not its noise; use table_reference = '
                    'gyro (a constant rate is removed anyway). Nothing was written.')
        stream.referenced += len(t)
        return v - (angle / scale)[:, None]

    def _close_motion(self, stream: _Stream) -> None:
        """A steady segment began (or the record ended): say what was left out and why."""
        run = stream.moving_run
        if run is None:
            return
        stream.moving_run = None
        first, last, n = run
        movers = [(topic, tm, tm.spans_within(first, last)) for topic, tm in self.gate.recorded()
                  if tm.overlaps(first, last)]
        if not movers:
            movers = [(topic, tm, tm.changes()) for topic, tm in self.gate.recorded() if tm.moved]
        whats = []
        for topic, tm, spans in movers:
            rate = max((sp.max_rate_rad_s for sp in spans), default=0.0)
            kinds = sorted({self._change_words(tm, sp) for sp in spans})
            whats.append(f'the {TABLE_NAMES[topic]} {" and ".join(kinds) or "changed rate"} '
                         f'({topic} up to {rate:.4g} rad/s = {math.degrees(rate):.4g} °/s)')
        self._motion_rejections.append(Rejection(first, (
            f'{stream.topic}: the {n} sample(s) from {format_stamp(first)} to '
            f'{format_stamp(last)} are left out: {" and ".join(whats)}; '
            f'{self._steady_words()}.')))

    @staticmethod
    def _change_words(tm: TableMotion, span: MotionSpan) -> str:
        """What a table did: 'was turning' (one that must rest), 'reversed from 37.9 °/s …'."""
        if not tm.turning:
            return 'was turning'
        verb = {'reversal': 'reversed', 'stop': 'stopped', 'start': 'started',
                'move': 'moved'}.get(span.what(tm.rest_rate_rad_s),
                                                       'changed rate')
        a, b = span.rate_before_rad_s, span.rate_after_rad_s

        def deg(r: float) -> str:
            return 'rest' if abs(r) <= tm.rest_rate_rad_s else f'{math.degrees(r):.4g} °/s'

        frm = f' from {deg(a)}' if not math.isnan(a) else ''
        to = f' to {deg(b)}' if not math.isnan(b) else ''
        return f'{verb}{frm}{to}'

    def extend_pulses(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """RLG samples (bag replay): stamps (int ns) and cumulative pulse counts."""
        t = self._stamps(t_ns, GYRO_PULSES)
        c = np.asarray(counts, dtype=np.float64)
        if c.shape != t.shape:
            raise StreamError(f'{GYRO_PULSES}: {len(t)} stamps but counts of shape {c.shape}.')
        self._extend('pulses', t, c[:, None])

    def extend_triad(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """Triad samples (bag replay): stamps (int ns), counts (N × channels), K_i each."""
        t = self._stamps(t_ns, IMU_PULSES)
        c = np.asarray(counts, dtype=np.float64)
        width = len(self.triad[0]) if self.triad is not None else 3
        if c.shape != (len(t), width):
            raise StreamError(f'{IMU_PULSES}: {len(t)} stamps need counts of shape '
                              f'({len(t)}, {width}); got {c.shape}.')
        self._extend('triad', t, c)

    def add_pulses(self, t_ns: int, count: float) -> None:
        """One RLG sample (live node)."""
        s = self._stream('pulses')
        s.pending_t.append(int(t_ns))
        s.pending_v.append((float(count),))

    def extend_fog_output(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """FOG samples (bag replay): stamps (int ns) and cumulative output counts."""
        t = self._stamps(t_ns, FOG_OUTPUT)
        c = np.asarray(counts, dtype=np.float64)
        if c.shape != t.shape:
            raise StreamError(f'{FOG_OUTPUT}: {len(t)} stamps but counts of shape {c.shape}.')
        self._extend('fog', t, c[:, None])

    def add_fog_output(self, t_ns: int, count: float) -> None:
        """One FOG sample (live node)."""
        s = self._stream('fog')
        s.pending_t.append(int(t_ns))
        s.pending_v.append((float(count),))

    def extend_imu(self, t_ns: ArrayLike, gyro_xyz: ArrayLike, accel_xyz: ArrayLike) -> None:
        """Imu samples (bag replay).

        Imu samples (bag replay): stamps (int ns), angular velocity (N × 3, rad/s) and
        linear acceleration (N × 3, m/s²).
        """
        t = self._stamps(t_ns, 'imu')
        g = np.asarray(gyro_xyz, dtype=np.float64)
        a = np.asarray(accel_xyz, dtype=np.float64)
        if g.shape != (len(t), 3) or a.shape != (len(t), 3):
            raise StreamError(f'imu: {len(t)} stamps need gyro and accel arrays of shape '
                              f'({len(t)}, 3); got {g.shape} and {a.shape}.')
        self._extend('imu', t, np.hstack((g, a)))

    def extend_table(self, t_ns: ArrayLike, angle_rad: ArrayLike, rate_rad_s: ArrayLike, *,
                     topic: str = RATE_TABLE_JOINT_STATES) -> None:
        """Table states, NaN where a message gave none.

        ``/rate_table/joint_states``, or with ``topic`` the position table's
        ``/position_table/joint_states``. Stamps (int ns), unwrapped encoder angle (rad)
        and rate (rad/s). The gyro samples held for want of a state of every recorded table
        at their stamp are decided now (:mod:`gyro_calib.noise.table`).
        """
        if topic not in self.gate.tables:
            raise StreamError(f'{topic}: not a table the noise gate reads; tables: '
                              f'{", ".join(self.gate.tables)}.')
        t = self._stamps(t_ns, topic)
        a = np.asarray(angle_rad, dtype=np.float64)
        r = np.asarray(rate_rad_s, dtype=np.float64)
        if a.shape != t.shape or r.shape != t.shape:
            raise StreamError(f'{topic}: {len(t)} stamps but angles of shape '
                              f'{a.shape} and rates of shape {r.shape}.')
        self.gate.tables[topic].extend(t, a, r)
        for stream in self._streams.values():
            self._gate(stream, final=False)

    def add_imu(self, t_ns: int, gyro_xyz: ArrayLike, accel_xyz: ArrayLike) -> None:
        """One Imu sample (live node): angular velocity (3, rad/s), acceleration (3, m/s²)."""
        s = self._stream('imu')
        s.pending_t.append(int(t_ns))
        s.pending_v.append(tuple(np.concatenate((np.ravel(gyro_xyz), np.ravel(accel_xyz)))))

    # -- processing -------------------------------------------------------------------------
    def process(self, *, flush: bool = False) -> list[str]:
        """Take in everything final so far; at ``flush`` the rest. Return new log lines.

        The lines report learnt sample rates, gaps, restarts, segments left out and, at
        ``flush``, the ordering and channel summaries. The terms themselves are in
        :meth:`results`, :meth:`result_lines` and :meth:`summary_table` (they cost a fit).
        """
        for stream in self._streams.values():
            self._drain(stream)
            if flush:
                self._release(stream, stream.reorder.flush())
                self._gate(stream, final=True)  # no table state follows: the last one holds
                self._close_motion(stream)
                for ch in stream.channels:
                    ch.close()
        lines: list[str] = []
        for stream in self._streams.values():
            for ch in stream.channels:
                seen = self._n_notices.get(ch.name, 0)
                lines.extend(ch.notices[seen:])
                self._n_notices[ch.name] = len(ch.notices)
        rejections = self._segment_rejections()
        lines.extend(r.reason for r in rejections[self._n_rejections_reported:])
        self._n_rejections_reported = len(rejections)
        lines.extend(r.reason for r in self._motion_rejections[self._n_motion_reported:])
        self._n_motion_reported = len(self._motion_rejections)
        if flush and not self._flushed:
            self._flushed = True
            for stream in self._streams.values():
                summary = stream.reorder.stats.summary()
                if summary:
                    lines.append(f'{stream.topic}: {summary}.')
                lines.extend(self._channel_summaries(stream))
            motion = self.table_line()
            if motion:
                lines.append(motion)
        return lines

    def _channel_summaries(self, stream: _Stream) -> list[str]:
        out = []
        ch = stream.channels[0]
        st = ch.stats
        if st.gaps or st.segments_short or st.segments_other_rate:
            out.append(f'{stream.topic}: {len(ch.segments)} segment(s), {st.gaps} gap(s); '
                       f'{st.segments_short + st.segments_other_rate} segment(s) left out '
                       f'({st.samples_left_out} samples).')
        if st.intervals and st.bunched_intervals > 0.01 * st.intervals:
            out.append(f'{stream.topic}: {st.bunched_intervals} of {st.intervals} stamp '
                       f'intervals are shorter than half the nominal period (bursty host '
                       f"stamps); samples are treated as evenly spaced at each segment's "
                       f'mean period.')
        for c in stream.channels:
            if c.stats.non_finite:
                out.append(f'{c.name}: {c.stats.non_finite} non-finite sample(s) dropped.')
        return out

    def result_lines(self) -> list[str]:
        """One line per measured term (or per axis without terms): value ± std, SI and quoted."""
        return [line for axis, res in self.axis_results().items()
                for line in self._result_lines(axis, res)]

    @staticmethod
    def _result_lines(axis: str, res: AxisResult) -> list[str]:
        if res.fit is None:
            return [f'{axis}: {res.reason}']
        out = []
        for k, key in enumerate(res.units.keys):
            est = res.fit.estimates.get(key)
            if est is not None:
                q = res.units.quoted_factors[k]
                out.append(f'{axis}: {res.units.names[k]} = {est.value:.4g} ± '
                           f'{est.std_uncertainty:.2g} {res.units.si_units[k]} '
                           f'({est.value * q:.4g} ± {est.std_uncertainty * q:.2g} '
                           f'{res.units.quoted_units[k]})')
        return out

    # -- results ----------------------------------------------------------------------------
    def _segment_rejections(self) -> list[Rejection]:
        return [r for s in self._streams.values() for c in s.channels for r in c.rejections]

    @property
    def rejections(self) -> list[Rejection]:
        """Segments left out, then the spans left out while the table moved, with reasons."""
        return self._segment_rejections() + list(self._motion_rejections)

    def _steady_words(self) -> str:
        s = self.settings
        rest_only = any(not tm.turning for _, tm in self.gate.recorded())
        return (f'steady = velocity within {s.table_rest_rate_rad_s:g} rad/s of the segment\'s '
                f'mean and angle within {s.table_rest_angle_rad:g} rad (+ |rate| × '
                f'{s.table_stamp_jitter_s:g} s) of its line, for {s.table_min_steady_s:g} s '
                'or more' + ('; the position table steady only at rest' if rest_only else ''))

    @staticmethod
    def _rates_words(tm: TableMotion) -> str:
        """'at rest', 'at 37.9 °/s', 'at rest, at ±150 °/s' … of the steady segments."""
        out: list[str] = []
        for r in tm.steady_rates():
            word = 'at rest' if abs(r) <= tm.rest_rate_rad_s else f'at {math.degrees(r):.4g} °/s'
            if word not in out:
                out.append(word)
        if len(out) > 4:
            out = [*out[:4], '…']
        return ', '.join(out) or 'none'

    def _table_clause(self, topic: str, tm: TableMotion) -> str:
        name = TABLE_NAMES[topic]
        segs = tm.segments
        if not tm.moved:
            if segs and all(abs(r) <= tm.rest_rate_rad_s for r in tm.steady_rates()):
                return (f'{topic}: the {name} stayed at rest throughout its {tm.record_s():.6g} s '
                        f'record ({tm.states} states')
            return (f'{topic}: the {name} kept a constant rate throughout its '
                    f'{tm.record_s():.6g} s record ({tm.states} states, '
                    f'{self._rates_words(tm)}')
        rate = tm.max_rate_rad_s
        changes = tm.changes()
        if not tm.turning:
            return (f'{topic}: the {name} moved during {tm.moving_s():.6g} s of its '
                    f'{tm.record_s():.6g} s record ({len(changes)} span(s), largest rate '
                    f'{rate:.4g} rad/s = {math.degrees(rate):.4g} °/s')
        kinds: dict[str, int] = {}
        for sp in changes:
            w = sp.what(tm.rest_rate_rad_s)
            kinds[w] = kinds.get(w, 0) + 1
        kind = ', '.join(f'{n} × {w}' for w, n in kinds.items())
        return (f'{topic}: the {name} changed rate during {tm.moving_s():.6g} s of its '
                f'{tm.record_s():.6g} s record ({len(changes)} span(s): {kind}; largest rate '
                f'{rate:.4g} rad/s = {math.degrees(rate):.4g} °/s) and held {len(segs)} steady '
                f'segment(s) ({self._rates_words(tm)}')

    def reference_words(self) -> str:
        """Which reference the gyro samples were analysed against ('' without a gyro angle)."""
        streams = [st for st in self._streams.values() if st.topic in (GYRO_PULSES, FOG_OUTPUT)]
        if not streams:
            return ''
        if self.settings.table_reference != 'gyro_minus_table':
            return 'reference: the gyro alone (table_reference = gyro)'
        ref = sum(st.referenced for st in streams)
        alone = sum(st.unreferenced for st in streams)
        angle = 'K·counts' if streams[0].topic == GYRO_PULSES else 'counts/SF'
        words = (f'reference: the gyro angle minus the rate table\'s encoder angle ({angle} − '
                 f'encoder angle) for {ref} sample(s)')
        if alone:
            words += f', the gyro alone for {alone} (no rate table angle at their stamps)'
        return words

    def reference_used(self) -> str:
        """'gyro', 'gyro_minus_table', or 'mixed' (some samples had no table angle)."""
        streams = [st for st in self._streams.values() if st.topic in (GYRO_PULSES, FOG_OUTPUT)]
        if self.settings.table_reference != 'gyro_minus_table' or not streams:
            return 'gyro'
        ref = sum(st.referenced for st in streams)
        alone = sum(st.unreferenced for st in streams)
        return 'gyro_minus_table' if not alone else ('gyro' if not ref else 'mixed')

    def table_line(self) -> str:
        """One line on the tables' motion ('' when no table state arrived).

        Each recorded table's steady segments (their rates) and the stretches of changing
        rate left out (how many, what kind, for how long, the largest rate); how many
        samples of each input were left out; and the reference the samples were analysed
        against (the gyro alone, or minus the rate table's angle).
        """
        recorded, s = self.gate.recorded(), self.settings
        if not recorded:
            if s.table_reference == 'gyro_minus_table' and any(
                    st.topic in (GYRO_PULSES, FOG_OUTPUT) for st in self._streams.values()):
                return ('table_reference = gyro_minus_table, but no /rate_table/joint_states '
                        'state was recorded: reference: the gyro alone.')
            return ''
        clauses = [self._table_clause(topic, tm) for topic, tm in recorded]
        head = (f'{clauses[0]}; {self._steady_words()})' if len(clauses) == 1
                else '; '.join(f'{c})' for c in clauses) + f'; {self._steady_words()}')
        reference = self.reference_words()
        tail = f'; {reference}.' if reference else '.'
        if not any(tm.moved for _, tm in recorded):
            late = [f'{st.before_table} of {st.topic} before its first state'
                    for st in self._streams.values() if st.before_table]
            late += [f'{st.beyond_table} of {st.topic} after waiting {s.table_wait_s:g} s for a '
                     'later state' for st in self._streams.values() if st.beyond_table]
            unknown = f' ({", ".join(late)}: taken as steady)' if late else ''
            return f'{head}: every sample analysed{unknown}{tail}'
        parts = []
        for st in self._streams.values():
            received = st.reorder.stats.received
            pct = 100.0 * st.left_out / received if received else 0.0
            early = (f', {st.before_table} analysed before the first table state'
                     if st.before_table else '')
            if st.beyond_table:
                early += (f', {st.beyond_table} decided by the last table state after '
                          f'waiting {self.settings.table_wait_s:g} s for a later one')
            parts.append(f'{st.left_out} of {received} samples of {st.topic} '
                         f'({pct:.3g} %){early}')
        kept = any(st.left_out < st.reorder.stats.received for st in self._streams.values())
        return (f'{head}: {", ".join(parts) or "no gyro sample"} left out (the stretches of '
                'changing rate); '
                + ('each steady segment is analysed as a segment of a static record'
                   if kept else 'no sample in a steady segment remains') + tail)

    @staticmethod
    def _table_fields(tm: TableMotion) -> dict[str, Any]:
        changes = tm.changes()
        return {'moved': tm.moved, 'states': tm.states, 'moving_states': tm.moving_states,
                'record_s': tm.record_s(), 'moving_s': tm.moving_s(), 'spans': len(changes),
                'max_rate_rad_s': tm.max_rate_rad_s, 'steady_segments': len(tm.segments),
                'steady_rates_rad_s': [float(r) for r in tm.steady_rates()],
                'turning_s': tm.turning_s(), 'turning_allowed': tm.turning,
                'changes': [sp.what(tm.rest_rate_rad_s) if tm.turning else 'turning'
                            for sp in changes]}

    def table_record(self) -> dict[str, Any] | None:
        """The tables' motion for ``--json`` (``table_motion``), or None without a table.

        The top-level fields describe ``topic``: the rate table when it was recorded, else
        the position table; ``tables`` has the same fields for every recorded table, by
        topic; the samples left out are those while any recorded table changed rate (the
        position table: turned). ``moved``: some stretch was left out; ``steady_segments``,
        ``steady_rates_rad_s``, ``turning_s`` (steady at a non-zero rate), ``changes`` (what
        each stretch was) and ``reference`` (what the samples were analysed against) besides.
        """
        recorded = self.gate.recorded()
        if not recorded:
            return None
        topic, tm = recorded[0]
        s = self.settings
        return {
            'topic': topic, **self._table_fields(tm),
            'samples_left_out': {st.topic: st.left_out for st in self._streams.values()},
            'samples_received': {st.topic: st.reorder.stats.received
                                 for st in self._streams.values()},
            'rest_rate_rad_s': s.table_rest_rate_rad_s,
            'rest_angle_rad': s.table_rest_angle_rad,
            'stamp_jitter_s': s.table_stamp_jitter_s,
            'min_steady_s': s.table_min_steady_s,
            'reference': self.reference_used(),
            'samples_referenced': {st.topic: st.referenced for st in self._streams.values()},
            'line': self.table_line(),
            'tables': {t: self._table_fields(m) for t, m in recorded},
        }

    def _tables_phrase(self) -> str:
        """'the rate table', 'the position table' (the one recorded) or 'every table'."""
        recorded = self.gate.recorded()
        return f'the {TABLE_NAMES[recorded[0][0]]}' if len(recorded) == 1 else 'every table'

    def _motion_reason(self, stream: _Stream) -> str:
        """Why a record whose table changed rate gives no term, and what record would."""
        if not stream.left_out:
            return ''
        s = self.settings
        # the fit needs 8 τ points (octaves m = 1 … 128) with fit_min_clusters clusters each
        # and within max_tau_fraction of the span: the least record for the white-noise term
        need = int(math.ceil(max(s.fit_min_clusters, 1.0 / s.max_tau_fraction) * 128)) + 1
        first, last, n = stream.final
        period = (last - first) / (n - 1) / NS_PER_S if n > 1 and last > first else math.nan
        secs = f' ({need * period:.3g} s)' if math.isfinite(period) else ''
        turned = ' and '.join(
            f'the {TABLE_NAMES[topic]} {"changed rate" if tm.turning else "turned"} during '
            f'{tm.moving_s():.6g} s of its {tm.record_s():.6g} s record ({len(tm.changes())} '
            f'span(s), up to {tm.max_rate_rad_s:.4g} rad/s = '
            f'{math.degrees(tm.max_rate_rad_s):.4g} °/s)'
            for topic, tm in self.gate.recorded() if tm.moved)
        return (f' {turned[:1].upper()}{turned[1:]}: '
                f'{stream.left_out} samples of {stream.topic} were left out and the longest '
                f'steady span holds {stream.longest_rest}. Noise terms need a constant input '
                f'rate: record with the rate table at rest or at one constant rate (the '
                f'position table at rest), {need} samples{secs} or more in one steady span for '
                f'the white-noise term (8 octaves of τ with {s.fit_min_clusters:g} clusters '
                'each), hours for bias instability and the random walks.')

    def ordering_stats(self) -> dict[str, OrderingStats]:
        """Per input topic: samples received, re-sorted, duplicate, late (dropped), restarts."""
        return {s.topic: s.reorder.stats for s in self._streams.values()}

    def stream_counts(self) -> list[StreamCounts]:
        """Per input stream: ordering, segment and non-finite counts (see StreamCounts)."""
        out = []
        for kind, s in self._streams.items():
            o, ch = s.reorder.stats, s.channels[0]
            st = ch.stats
            live = 1 if ch.has_live_segment else 0
            out.append(StreamCounts(
                s.topic, kind, o.received, o.out_of_order, o.duplicate, o.late, o.restarts,
                len(ch.segments) + live, st.gaps, st.segments_short + st.segments_other_rate,
                st.samples_left_out,
                {c.name: c.stats.non_finite for c in s.channels if c.stats.non_finite}))
        return out

    def data_span_ns(self) -> tuple[int, int] | None:
        """First and last stamp of the segments analysed (all axes), or None."""
        spans = [span for s in self._streams.values() for c in s.channels
                 if (span := c.used_span_ns()) is not None]
        if not spans:
            return None
        return min(a for a, _ in spans), max(b for _, b in spans)

    def sample_storage_bytes(self) -> int:
        """Bytes of sample storage held now (bounded in 'partial' overlap mode).

        The samples held for the table state at their stamp included (a table stream that
        lags the gyro by Δt holds Δt of samples).
        """
        held = sum(a.nbytes for s in self._streams.values() for a in (*s.held_t, *s.held_v))
        return held + sum(c.storage_bytes() for s in self._streams.values() for c in s.channels)

    def axes(self) -> list[str]:
        """Axis names of the streams that arrived."""
        return [c.name for s in self._streams.values() for c in s.channels]

    def _channel(self, axis: str) -> tuple[_Stream, ChannelAccumulator]:
        for s in self._streams.values():
            for c in s.channels:
                if c.name == axis:
                    return s, c
        raise KeyError(f'no axis {axis!r}; axes: {", ".join(self.axes()) or "none"}')

    def curve(self, axis: str) -> AllanCurve | None:
        """Pooled Allan variance of one axis so far (no fit; cheap), rate unit²."""
        stream, ch = self._channel(axis)
        self._drain(stream)
        return ch.curve()

    def sample_rate_hz(self, axis: str) -> float:
        """Mean sample rate of an axis over its analysed segments, Hz (NaN if unknown)."""
        _, ch = self._channel(axis)
        curve = ch.curve()
        if curve is not None:
            return 1.0 / curve.tau0_s
        return NS_PER_S / ch.nominal_period_ns if ch.nominal_period_ns > 0 else math.nan

    def axis_result(self, axis: str) -> AxisResult:
        """Curve, fit, error bars and total deviation of one axis (cached until new data)."""
        stream, ch = self._channel(axis)
        self._drain(stream)  # samples added one by one count at once
        key = (ch.stats.samples, ch.n_used_samples, self._flushed)
        cached = self._cache.get(axis)
        if cached is not None and cached[0] == key:
            return cached[1]
        res = self._compute(stream, ch)
        self._cache[axis] = (key, res)
        return res

    def axis_results(self) -> dict[str, AxisResult]:
        """:meth:`axis_result` of every axis."""
        return {a: self.axis_result(a) for a in self.axes()}

    def _compute(self, stream: _Stream, ch: ChannelAccumulator) -> AxisResult:
        units = units_for_axis(ch.name)
        s = self.settings
        st = ch.stats

        def none(reason: str) -> AxisResult:
            return AxisResult(ch.name, units, None, None, None, None, reason,
                              outliers=self._outlier_report(ch, units, None, None))

        motion = self._motion_reason(stream)
        if st.samples == 0 and motion:
            return none(f'no sample of {ch.name} on {stream.topic} was taken with '
                        f'{self._tables_phrase()} steady (at rest or at one constant '
                        f'rate).{motion}')
        if motion and st.non_finite < st.samples:
            rest_curve = ch.curve()
            if rest_curve is None or int(np.count_nonzero(rest_curve.avar > 0)) < 2:
                return none(f'the spans of {ch.name} on {stream.topic} with '
                            f'{self._tables_phrase()} steady are too short for any noise '
                            f'term ({st.samples} sample(s) '
                            f'in steady spans).{motion}')
        if st.samples == 0:
            return none(f'no samples have arrived on {stream.topic} yet.')
        if st.non_finite == st.samples:
            return none(f'all {st.samples} samples of {ch.name} on {stream.topic} were '
                        f'non-finite (NaN or inf): the channel carries no data.')
        if ch.is_constant:
            lock = (' A static RLG inside its lock-in band without dither gives no pulses: '
                    'dither it or turn it.' if stream.topic in PULSE_TOPICS else '')
            return none(f'{ch.name} on {stream.topic} is constant (every finite sample equals '
                        f'{ch.first_value!r}): a stuck or disconnected channel shows no noise, '
                        f'so no term can be measured.{lock}')
        if ch.kind == 'phase' and not math.isfinite(ch.phase_scale):
            what = ('scale_factor_rad_per_pulse (CLI --scale-factor-rad-per-pulse, or '
                    '--calibration with a hand-off file holding scale_factor_rad_per_pulse)'
                    if stream.topic == GYRO_PULSES else
                    f'K of channel {ch.name} (--calibration with a format-4 hand-off file '
                    'whose imu: section holds scale_factor_rad_per_pulse)'
                    if stream.topic == IMU_PULSES else
                    'fog_scale_factor_counts_per_rad')
            return none(f'{stream.topic} needs a scale factor to turn counts into rad and '
                        f'none was given: set {what}. No value in rad is reported.')
        curve = ch.curve()
        usable = 0 if curve is None else int(np.count_nonzero(curve.avar > 0))
        if curve is None or usable < 2:
            n = ch.n_used_samples
            need = max(s.min_segment_samples, int(math.ceil(4.0 / s.max_tau_fraction)) + 1)
            longest = max((g.n_samples for g in ch.segments), default=0)
            return none(f'the record of {ch.name} is too short for any noise term: '
                        f'{st.samples} sample(s) received, the longest gap-free segment has '
                        f'{longest}, {n} usable in segments of at least '
                        f'{s.min_segment_samples}; the Allan '
                        f'variance needs averaging times up to a fraction '
                        f'{s.max_tau_fraction:g} of a segment, so at least {need} samples in '
                        f'one segment.{motion}')
        context = 'pulses' if stream.topic in PULSE_TOPICS else ''
        fit = self._fit(curve, units, context)
        # error bars (§E.2): the EDF blended over the noise types by their shares at each τ
        model = self._noise_model(curve, fit, units)
        shares = curve_shares(curve, model)
        alpha = dominant_alpha(shares)
        edf = curve_edf(curve, shares, uniform_quantisation=stream.topic in PULSE_TOPICS)
        std = adev_std(curve.adev, edf)
        others = {}
        for name, (var, _, _) in curve.others.items():
            dev = np.sqrt(var)
            nu = curve_edf(curve, curve_shares(curve, model, name), name)
            others[name] = (dev, adev_std(dev, nu), nu)
        totdev = (self._totdev(ch, model, curve.tau0_s, stream.topic in PULSE_TOPICS)
                  if curve.overlap == 'partial' else None)
        return AxisResult(ch.name, units, curve, fit, std, totdev, '', alpha, others, edf,
                          shares, self._outlier_report(ch, units, curve, fit, context))

    def _fit(self, curve: AllanCurve, units: TermUnits, context: str) -> NoiseFit:
        """The joint term fit of one curve with the settings' limits (§E.3)."""
        s = self.settings
        return fit_noise_terms(curve, units, min_significance=s.min_term_significance,
                               edge_significance=s.edge_term_significance,
                               ramp_significance=s.ramp_term_significance,
                               min_tau_s=s.fit_min_tau_s, max_tau_s=s.fit_max_tau_s,
                               context=context, min_clusters=s.fit_min_clusters,
                               exclude_band_limited=bool(s.fit_exclude_band_limited),
                               tau_list=s.tau_spec if isinstance(s.tau_spec, tuple) else None)

    def _outlier_report(self, ch: ChannelAccumulator, units: TermUnits,
                        curve: AllanCurve | None, fit: NoiseFit | None,
                        context: str = '') -> OutlierReport | None:
        """The spikes of one channel and what the other treatment of them gives (§E.6)."""
        tally = ch.outlier_tally
        if tally is None:
            return None
        s = self.settings
        statistic = 'rate' if ch.kind == 'rate' else 'increment'
        other = ch.shadow_curve()
        if not tally.spikes or curve is None or other is None:
            return OutlierReport(ch.name, s.outliers, s.outlier_sigma, s.outlier_block_samples,
                                 statistic, tally)
        main_1s = adev_at(curve.tau_s, curve.adev)
        other_1s = adev_at(other.tau_s, other.adev)
        other_fit = self._fit(other, units, context) if int(
            np.count_nonzero(other.avar > 0)) >= 2 else None
        terms: dict[str, tuple[float, float]] = {}
        for key in units.keys:
            a = fit.estimates.get(key) if fit is not None else None
            b = other_fit.estimates.get(key) if other_fit is not None else None
            if a is None and b is None:
                continue
            terms[key] = (float(a.value) if a is not None else math.nan,
                          float(b.value) if b is not None else math.nan)
        if s.outliers == 'remove':  # (recorded, removed) whichever the estimator took
            main_1s, other_1s = other_1s, main_1s
            terms = {k: (b, a) for k, (a, b) in terms.items()}
        symbols = {key: SYMBOLS[k] for k, key in enumerate(units.keys)}
        return OutlierReport(ch.name, s.outliers, s.outlier_sigma, s.outlier_block_samples,
                             statistic, tally, (main_1s, other_1s), terms, symbols)

    def _noise_model(self, curve: AllanCurve, fit: NoiseFit,
                     units: TermUnits) -> FloatArray | None:
        """(Q², N², B², K², R²) that identifies the noise types at each τ (§E.2).

        The term fit's model; where it has no random term (too few τ points once a
        band-limited range was left out, say), the same fit over every τ with enough
        clusters, nothing left out for misfit and no term reported — only to read the
        types' shares; None when that has none either (then the local slope decides).
        """
        if np.any(fit.theta[:4] > 0):
            return fit.theta
        s = self.settings
        wide = fit_noise_terms(curve, units, min_tau_s=s.fit_min_tau_s, max_tau_s=s.fit_max_tau_s,
                               min_clusters=s.fit_min_clusters, exclude_band_limited=False,
                               min_points=3)
        return wide.theta if np.any(wide.theta[:4] > 0) else None

    @staticmethod
    def _totdev(ch: ChannelAccumulator, model: FloatArray | None, tau0_s: float,
                pulses: bool) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        """TOTDEV at long τ (partial overlap) with its blended EDF (§E.2 (6a))."""
        td = ch.total_deviation()
        if td is None:
            return None
        tau, dev, n_points, m = td
        level0 = np.maximum(np.round(tau / tau0_s), 1).astype(np.int64)
        shares = None if model is None else model_shares('totdev', level0, tau0_s, model)
        if shares is None:
            shares = slope_shares(tau, dev**2)
        pure = np.stack([edf_totdev(n_points, m, a) for a in TERM_ALPHA[:4]])
        if pulses:
            pure[0] = pure[0] * uniform_quantisation_factor('totdev', level0)
        edf = blended_edf(shares, pure, level0)
        return tau, dev, adev_std(dev, edf)

    def results(self) -> dict[str, dict[str, Estimate]]:
        """Measured terms so far: axis → term key → Estimate (only resolved terms)."""
        out: dict[str, dict[str, Estimate]] = {}
        for axis, res in self.axis_results().items():
            if res.fit is not None and res.fit.estimates:
                out[axis] = dict(res.fit.estimates)
        return out

    def missing(self) -> dict[str, dict[str, str]]:
        """Terms not measured (yet): axis → term key → why, a whole sentence."""
        out: dict[str, dict[str, str]] = {}
        for axis, res in self.axis_results().items():
            if res.fit is None:
                out[axis] = {key: res.reason for key in res.units.keys}
            elif res.fit.missing:
                out[axis] = dict(res.fit.missing)
        return out

    # -- outputs ----------------------------------------------------------------------------
    def json_section(self) -> dict[str, Any]:
        """The ``--json`` section of the noise method (issue 11 Part 2 item 4).

        Shape: ``{"axes": {AXIS: {"tau_s": [...], "adev": [...], "adev_std": [...],
        "results": {KEY: {"value": v, "std": s, "n": k}}}}}`` — AXIS ``gyro`` for a single
        gyro, ``gyro_x`` … ``accel_z`` for an Imu; adev in rad/s (gyro) or m/s² (accel);
        only resolved terms under "results". Axes with no Allan deviation in SI units
        (no samples, no scale factor, constant, too short) are absent; :meth:`missing`
        says why. With table states (rate or position table) in the record,
        ``"table_motion"``: whether each table moved, for how long, its largest rate and
        the samples left out (:meth:`table_record`).
        """
        axes: dict[str, Any] = {}
        for axis, res in self.axis_results().items():
            if res.curve is None or res.adev_std is None:
                continue
            results = {}
            if res.fit is not None:
                for key, est in res.fit.estimates.items():
                    results[key] = {'value': float(est.value), 'std': float(est.std_uncertainty),
                                    'n': int(est.n_used)}
            c = res.curve
            record: dict[str, Any] = {'tau_s': _floats(c.tau_s), 'adev': _floats(c.adev),
                                      'adev_std': _floats(res.adev_std), 'results': results}
            record['m'] = [int(v) for v in c.m]
            if c.clusters is not None:
                record['clusters'] = _floats(c.clusters)
            if res.alpha is not None and res.edf is not None:
                record['noise_alpha'] = [int(v) for v in res.alpha]
                record['adev_edf'] = _floats(res.edf)
            for name, (dev, std, nu) in (res.others or {}).items():
                record[name] = _floats(dev)
                record[f'{name}_std'] = _floats(std)
                record[f'{name}_edf'] = _floats(nu)
            if res.fit is not None:
                record['fit'] = res.fit.json_record(c)
            if res.outliers is not None:
                record['outliers'] = res.outliers.record()
            axes[axis] = record
        out: dict[str, Any] = {'axes': axes}
        table = self.table_record()
        if table is not None:
            out['table_motion'] = table
        return out

    def summary_table(self) -> str:
        """The noise terms as a table, in SI and the units people quote (°/√h, °/h, µg)."""
        rows = [f'{"axis":8s} {"term":28s} {"value (SI)":>24s} {"quoted":>24s}']
        notes: list[str] = []
        for axis, res in self.axis_results().items():
            if res.fit is None:
                notes.append(f'{axis}: {res.reason}')
                continue
            u = res.units
            for k, key in enumerate(u.keys):
                est = res.fit.estimates.get(key)
                if est is None:
                    rows.append(f'{axis:8s} {u.names[k]:28s} {"not resolved":>24s}')
                    notes.append(f'{axis}: {res.fit.missing[key]}')
                    continue
                q = u.quoted_factors[k]
                si = f'{est.value:.4g} ± {est.std_uncertainty:.2g} {u.si_units[k]}'
                quoted = (f'{est.value * q:.4g} ± {est.std_uncertainty * q:.2g} '
                          f'{u.quoted_units[k]}')
                rows.append(f'{axis:8s} {u.names[k]:28s} {si:>24s} {quoted:>24s}')
            notes.extend(f'{axis}: {n}' for n in res.fit.notes)
            for key, (lo, hi, _) in res.fit.tau_ranges.items():
                notes.append(f'{axis}: {key} rests on τ = {lo:.3g} … {hi:.3g} s.')
        return '\n'.join(rows + [''] + notes if notes else rows)

    def handoff_entries(self, axis: str = 'gyro') -> dict[str, float]:
        """Measured terms of one axis as hand-off entries: ``key`` and ``key_std`` (SI)."""
        out: dict[str, float] = {}
        for key, est in self.results().get(axis, {}).items():
            out[key] = float(est.value)
            out[f'{key}_std'] = float(est.std_uncertainty)
        return out


def calibrate_noise(*, pulses: tuple[ArrayLike, ArrayLike] | None = None,
                    fog_output: tuple[ArrayLike, ArrayLike] | None = None,
                    imu: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None,
                    settings: NoiseSettings | None = None) -> NoiseCalibrator:
    """Batch form: run a :class:`NoiseCalibrator` over whole arrays and flush it.

    Args:
        pulses: (t_ns, cumulative counts) of ``/gyro/pulses``.
        fog_output: (t_ns, cumulative counts) of ``/fog/output``.
        imu: (t_ns, gyro N × 3 rad/s, accel N × 3 m/s²) of an Imu topic.
        settings: analysis settings (defaults if None).

    Returns:
        The flushed calibrator (``results()``, ``missing()``, ``json_section()`` …).
    """
    cal = NoiseCalibrator(settings)
    if pulses is not None:
        cal.extend_pulses(*pulses)
    if fog_output is not None:
        cal.extend_fog_output(*fog_output)
    if imu is not None:
        cal.extend_imu(*imu)
    cal.process(flush=True)
    return cal


def _floats(values: npt.ArrayLike) -> list[float | None]:
    """JSON numbers (None where a statistic has no value at that τ)."""
    return [float(v) if math.isfinite(float(v)) else None for v in np.asarray(values).ravel()]


__all__ = ['AxisResult', 'NoiseCalibrator', 'NoiseSettings', 'SYMBOLS', 'StreamCounts',
           'calibrate_noise']
