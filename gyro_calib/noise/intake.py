"""The intake of a record: input streams ordered, gated by the tables' motion, fed to channels.

Each input stream (``/gyro/pulses``, ``/fog/output``, ``/imu/pulses`` or an Imu topic) is
put in stamp order (:mod:`gyro_calib.noise.ordering`), its samples are held until every
recorded table's state at their stamp is known, and those taken while a table was steady
(at rest or at one constant rate) are fed to the stream's channels
(:class:`~gyro_calib.noise.channel.ChannelAccumulator`), optionally as the gyro's angle minus
the rate table's angle (METHODS §E.1 (2b)); the stretches while a table changed rate are
left out, each with a sentence saying what the table did (:mod:`gyro_calib.noise.table`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.errors import ConfigError, StreamError
from gyro_calib.estimate import Rejection
from gyro_calib.noise.channel import ChannelAccumulator, format_stamp
from gyro_calib.noise.ordering import ReorderBuffer
from gyro_calib.noise.settings import NoiseSettings
from gyro_calib.noise.table import (
    RATE_TABLE_JOINT_STATES,
    TABLE_NAMES,
    MotionSpan,
    TableGate,
    TableMotion,
)
from gyro_calib.noise.topics import FOG_OUTPUT, GYRO_PULSES, IMU_AXES, IMU_PULSES
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike

    FloatArray = npt.NDArray[np.float64]


@dataclass(slots=True)
class InputStream:
    """One input stream: its ordering buffer, its channels and what the motion gate holds."""

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


class StreamIntake:
    """Input streams into channels, gated by the tables' motion (a base of the calibrator)."""

    def __init__(self, settings: NoiseSettings | None = None, *, imu_topic: str = 'imu',
                 triad: tuple[tuple[str, ...], tuple[float, ...]] | None = None) -> None:
        """No stream yet; the tables' gate from the settings (arguments: NoiseCalibrator)."""
        self.settings = settings if settings is not None else NoiseSettings()
        self.imu_topic = imu_topic
        self.triad = triad
        self._streams: dict[str, InputStream] = {}
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

    # -- input ------------------------------------------------------------------------------
    def _stream(self, name: str) -> InputStream:
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
        stream = InputStream(topic, ReorderBuffer(len(channels), window, backstep), channels, [],
                             [])
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

    def _drain(self, stream: InputStream) -> None:
        if stream.pending_t:
            t = np.asarray(stream.pending_t, dtype=np.int64)
            v = np.asarray(stream.pending_v, dtype=np.float64).reshape(len(t), -1)
            stream.pending_t.clear()
            stream.pending_v.clear()
            self._release(stream, stream.reorder.extend(t, v))

    def _release(self, stream: InputStream, batches: list[Any]) -> None:
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
    def _feed_channels(stream: InputStream, t: npt.NDArray[np.int64], v: FloatArray) -> None:
        stream.rest_run += len(t)
        stream.longest_rest = max(stream.longest_rest, stream.rest_run)
        for k, ch in enumerate(stream.channels):
            ch.feed(t, v[:, k])

    def _wants_reference(self, stream: InputStream) -> bool:
        """gyro_minus_table was asked for and the stream is a gyro angle (pulses, FOG)."""
        return (self.settings.table_reference == 'gyro_minus_table'
                and stream.topic in (GYRO_PULSES, FOG_OUTPUT))

    def _gate(self, stream: InputStream, *, final: bool) -> None:
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

    def _referenced(self, stream: InputStream, t: npt.NDArray[np.int64], v: FloatArray,
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

    def _close_motion(self, stream: InputStream) -> None:
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

    def _extend_counts(self, name: str, topic: str, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """One single-axis stream's samples: stamps (int ns) and cumulative counts."""
        t = self._stamps(t_ns, topic)
        c = np.asarray(counts, dtype=np.float64)
        if c.shape != t.shape:
            raise StreamError(f'{topic}: {len(t)} stamps but counts of shape {c.shape}.')
        self._extend(name, t, c[:, None])

    def _add_count(self, name: str, t_ns: int, count: float) -> None:
        """One single-axis stream's sample, held until the next :meth:`process`."""
        s = self._stream(name)
        s.pending_t.append(int(t_ns))
        s.pending_v.append((float(count),))

    def extend_pulses(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """RLG samples (bag replay): stamps (int ns) and cumulative pulse counts."""
        self._extend_counts('pulses', GYRO_PULSES, t_ns, counts)

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
        self._add_count('pulses', t_ns, count)

    def extend_fog_output(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """FOG samples (bag replay): stamps (int ns) and cumulative output counts."""
        self._extend_counts('fog', FOG_OUTPUT, t_ns, counts)

    def add_fog_output(self, t_ns: int, count: float) -> None:
        """One FOG sample (live node)."""
        self._add_count('fog', t_ns, count)

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

    def _steady_words(self) -> str:
        s = self.settings
        rest_only = any(not tm.turning for _, tm in self.gate.recorded())
        return (f'steady = velocity within {s.table_rest_rate_rad_s:g} rad/s of the segment\'s '
                f'mean and angle within {s.table_rest_angle_rad:g} rad (+ |rate| × '
                f'{s.table_stamp_jitter_s:g} s) of its line, for {s.table_min_steady_s:g} s '
                'or more' + ('; the position table steady only at rest' if rest_only else ''))

    def axes(self) -> list[str]:
        """Axis names of the streams that arrived."""
        return [c.name for s in self._streams.values() for c in s.channels]

    def _channel(self, axis: str) -> tuple[InputStream, ChannelAccumulator]:
        for s in self._streams.values():
            for c in s.channels:
                if c.name == axis:
                    return s, c
        raise KeyError(f'no axis {axis!r}; axes: {", ".join(self.axes()) or "none"}')
