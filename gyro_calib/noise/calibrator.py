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

The class is built in layers, one idea a module: :mod:`~gyro_calib.noise.intake` (streams
ordered, gated by the tables' motion, fed to channels), :mod:`~gyro_calib.noise.table_report`
(the tables' motion in words), :mod:`~gyro_calib.noise.axis` (one axis from curve to terms),
:mod:`~gyro_calib.noise.results` (results, missing, table, ``--json``); this module runs them
over a record (:meth:`NoiseCalibrator.process`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from gyro_calib.noise.axis import AxisResult
from gyro_calib.noise.intake import InputStream
from gyro_calib.noise.results import ResultAssembly
from gyro_calib.noise.settings import NoiseSettings
from gyro_calib.noise.terms import SYMBOLS
from gyro_calib.noise.topics import (
    FOG_OUTPUT,
    GYRO_PULSES,
    IMU_AXES,
    IMU_PULSES,
    PULSE_TOPICS,
)
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from gyro_calib.estimate import Rejection
    from gyro_calib.noise.curve import AllanCurve
    from gyro_calib.noise.ordering import OrderingStats


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


class NoiseCalibrator(ResultAssembly):
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
        super().__init__(settings, imu_topic=imu_topic, triad=triad)
        self._n_notices: dict[str, int] = {}
        self._n_rejections_reported = 0
        self._n_motion_reported = 0
        self._flushed = False
        self._cache = {}

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

    def _channel_summaries(self, stream: InputStream) -> list[str]:
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

    # -- what the run did ----------------------------------------------------------------------
    def _segment_rejections(self) -> list[Rejection]:
        return [r for s in self._streams.values() for c in s.channels for r in c.rejections]

    @property
    def rejections(self) -> list[Rejection]:
        """Segments left out, then the spans left out while the table moved, with reasons."""
        return self._segment_rejections() + list(self._motion_rejections)

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


__all__ = ['FOG_OUTPUT', 'GYRO_PULSES', 'IMU_AXES', 'IMU_PULSES', 'PULSE_TOPICS', 'SYMBOLS',
           'AxisResult', 'InputStream', 'NoiseCalibrator', 'NoiseSettings', 'StreamCounts',
           'calibrate_noise']
