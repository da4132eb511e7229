"""Streaming K̃ calibration of a rate-biased RLG: samples in, windows and pairs out.

:class:`RateBiasCalibrator` is the accumulator a node feeds message by message
(or a bag reader feeds array by array); :func:`calibrate_k_tilde` is the batch
form over whole arrays. Both run the same code and agree exactly.

Results depend only on stamps and values: an index event is resolved once both
the pulse and the table streams have passed its stamp by the fit half-width
(or one stream stopped while the other ran on by ``stall_timeout_s``), whatever the
arrival order and however far one stream lags.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib import topics
from gyro_calib.errors import InsufficientDataError
from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.rbrlg.config import KTildeConfig
from gyro_calib.rbrlg.scale_factor import PairAccumulator, WindowPair
from gyro_calib.streams import StampedBuffer, feed_by_timeline
from gyro_calib.units import ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H, NS_PER_S, format_stamp
from gyro_calib.windows import (
    MAX_FIT_HALF_WIDTH_S,
    IndexEvent,
    RevolutionWindow,
    WholeRevolutionWindows,
    fit_half_width_ns,
    resolve_index_event,
)

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt
    from numpy.typing import ArrayLike

TABLE_HISTORY_S = 60.0
"""joint_states kept before the oldest open event, s: enough to see whether a cruise held a
whole revolution before its first zero-index event (a missing event)."""



@dataclass(frozen=True, slots=True)
class CalibrationUpdate:
    """What one :meth:`RateBiasCalibrator.process` call produced.

    Attributes:
        windows: windows accepted, in time order.
        pairs: window pairs completed (each gives one K̃).
        rejections: windows or events rejected, each with its reason.
        notices: stream events worth a log line (restarts), whole sentences.
    """

    windows: tuple[RevolutionWindow, ...] = ()
    pairs: tuple[WindowPair, ...] = ()
    rejections: tuple[Rejection, ...] = ()
    notices: tuple[str, ...] = ()


@dataclass(slots=True)
class RateBiasCalibrator:
    """Accumulates pulse, table and zero-index streams into K̃ (METHODS §A.2)."""

    config: KTildeConfig = field(default_factory=KTildeConfig)
    pulses: StampedBuffer = field(init=False)
    table: StampedBuffer = field(init=False)
    windows: list[RevolutionWindow] = field(default_factory=list)
    _index: StampedBuffer = field(init=False)
    _cutter: WholeRevolutionWindows = field(init=False)
    _pairs: PairAccumulator = field(init=False)
    _notices: list[str] = field(default_factory=list)
    _lag_mark: tuple[int, int] | None = None
    _n_rejections_reported: int = 0
    _n_pair_rejections_reported: int = 0
    _n_windows_reported: int = 0
    _n_pairs_reported: int = 0

    def __post_init__(self) -> None:
        """Create the stream buffers and the window and pair stages."""
        back = int(self.config.restart_backstep_s * NS_PER_S)
        self.pulses = StampedBuffer(1, back)
        self.table = StampedBuffer(2, back)
        self._index = StampedBuffer(1, back)
        self._cutter = WholeRevolutionWindows(self.config)
        self._pairs = PairAccumulator(
            self.config.max_pair_gap_s,
            arw_arcsec_sqrt_s=self.config.angle_random_walk_deg_sqrt_h
            * ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H)

    # -- input ------------------------------------------------------------------------------
    def add_pulses(self, t_ns: int, count: float) -> None:
        """One gyro sample: stamp (ns) and cumulative count (pulses)."""
        if self.pulses.append(t_ns, count):
            self._restart(topics.GYRO_PULSES)

    def add_table_state(self, t_ns: int, angle_rad: float, rate_rad_s: float) -> None:
        """One joint_states sample: stamp (ns), encoder angle (rad), rate (rad/s)."""
        if self.table.append(t_ns, angle_rad, rate_rad_s):
            self._restart(topics.RATE_TABLE_JOINT_STATES)

    def add_zero_index(self, t_ns: int) -> None:
        """One zero-index event stamp (ns)."""
        if self._index.append(t_ns, 0.0):
            self._restart(topics.RATE_TABLE_ZERO_INDEX)

    def extend_pulses(self, t_ns: ArrayLike, counts: ArrayLike) -> None:
        """Many gyro samples at once (bag replay)."""
        if self.pulses.extend(t_ns, counts):
            self._restart(topics.GYRO_PULSES)

    def extend_table_states(self, t_ns: ArrayLike, angle_rad: ArrayLike,
                            rate_rad_s: ArrayLike) -> None:
        """Many joint_states samples at once (bag replay)."""
        if self.table.extend(t_ns, angle_rad, rate_rad_s):
            self._restart(topics.RATE_TABLE_JOINT_STATES)

    def extend_zero_index(self, t_ns: ArrayLike) -> None:
        """Many zero-index stamps at once (bag replay)."""
        t = np.asarray(t_ns, dtype=np.int64)
        if self._index.extend(t, np.zeros(len(t))):
            self._restart(topics.RATE_TABLE_ZERO_INDEX)

    def _restart(self, topic: str) -> None:
        """A source restarted: drop what is pending, keep every accepted window and pair.

        Streams still holding stamps of the old timeline are cleared; those that already
        restarted (stamps near the new timeline) keep their samples.
        """
        restarted = {topics.GYRO_PULSES: self.pulses, topics.RATE_TABLE_JOINT_STATES: self.table,
                     topics.RATE_TABLE_ZERO_INDEX: self._index}[topic]
        new_timeline_ns = restarted.newest_ns
        back = int(self.config.restart_backstep_s * NS_PER_S)
        for buf in (self.pulses, self.table, self._index):
            if buf is not restarted and buf.newest_ns is not None and (
                    new_timeline_ns is None or buf.newest_ns >= new_timeline_ns + back):
                buf.clear()
        self._cutter.reset()
        self._pairs.drop_pending()
        self._notices.append(
            f'{topic} restarted (stamps jumped back by more than '
            f'{self.config.restart_backstep_s:g} s): the open window was dropped; '
            f'{len(self._pairs.pairs)} accepted pair(s) kept.')

    # -- processing --------------------------------------------------------------------------
    def process(self, *, flush: bool = False) -> CalibrationUpdate:
        """Resolve every index event the streams have passed; return what came of them.

        Args:
            flush: resolve all remaining events with the data there is (end of a bag).
        """
        cfg = self.config
        half_ns = int(cfg.fit_half_width_s * NS_PER_S)
        stall_ns = int(cfg.stall_timeout_s * NS_PER_S)
        new_windows: list[RevolutionWindow] = []
        new_pairs: list[WindowPair] = []
        idx_t, _ = self._index.arrays()
        newest = [b.newest_ns for b in (self.pulses, self.table)]
        dead = self._stalled_stream(newest, stall_ns)
        for t_event in idx_t.tolist():
            p_t, p_v = self.pulses.arrays()
            if not flush:
                if None in newest:
                    break
                lead, lag = max(newest), min(newest)  # type: ignore[type-var]
                if not (lag >= t_event + half_ns or (dead and lead >= t_event + half_ns)):
                    break
                reach = t_event + self._fit_half_width_ns(t_event, p_t)
                if not (lag >= reach or (dead and lead >= reach)):
                    break
            s_t, s_v = self.table.arrays()
            event = self._resolve(t_event, p_t, p_v[:, 0], s_t, s_v)
            window = self._cutter.add_event(event, p_t, p_v[:, 0], s_t, s_v[:, 0], s_v[:, 1])
            self._index.discard_before(t_event + 1)
            if window is not None:
                self.windows.append(window)
                new_windows.append(window)
                pair = self._pairs.add_window(window)
                if pair is not None:
                    new_pairs.append(pair)
            self._trim(t_event)
        if not len(idx_t):
            self._trim_idle()
        if flush:
            s_t, s_v = self.table.arrays()
            self._cutter.finish(s_t, s_v[:, 0], s_v[:, 1])
        rejections = self._cutter.rejections[self._n_rejections_reported:]
        rejections += self._pairs.rejections[self._n_pair_rejections_reported:]
        self._n_rejections_reported = len(self._cutter.rejections)
        self._n_pair_rejections_reported = len(self._pairs.rejections)
        notices, self._notices = tuple(self._notices), []
        return CalibrationUpdate(tuple(new_windows), tuple(new_pairs), tuple(rejections), notices)

    def _fit_half_width_ns(self, t_event: int, p_t: np.ndarray,
                           period_ns: float | None = None) -> int:
        """Half-width of the fits around an event (shared ``fit_half_width_ns``)."""
        return fit_half_width_ns(self.config, t_event, p_t, period_ns)

    def _stalled_stream(self, newest: list[int | None], stall_ns: int) -> bool:
        """True if the lagging stream stopped while the other ran on by ``stall_ns``.

        A lagging stream whose stamps still advance is waited for however far behind it
        is (CPU load, replay speed), so a live result equals the offline one.
        """
        if None in newest:
            return False
        stamps = [n for n in newest if n is not None]  # all of them: None was ruled out
        lag, lead = min(stamps), max(stamps)
        if self._lag_mark is None or self._lag_mark[0] != lag:
            self._lag_mark = (lag, lead)  # the lagging stream moved: restart the clock
            return False
        return lead - self._lag_mark[1] >= stall_ns

    def _resolve(self, t_event: int, p_t: np.ndarray, counts: np.ndarray,
                 s_t: np.ndarray, s_v: np.ndarray) -> IndexEvent:
        """The table and the gyro at an event (:func:`~gyro_calib.windows.resolve_index_event`)."""
        return resolve_index_event(self.config, t_event, p_t, counts, s_t, s_v)

    def _trim(self, t_event: int) -> None:
        """Keep only what an open window (or the next event's fit) can still need."""
        cfg = self.config
        half_ns = int(MAX_FIT_HALF_WIDTH_S * NS_PER_S)
        opened = self._cutter.open_event
        keep_from = (opened.stamp_ns if opened is not None else t_event) - half_ns
        limit = int(cfg.max_window_s * NS_PER_S)
        if opened is not None and t_event - opened.stamp_ns > limit:
            self._cutter.rejections.append(Rejection(opened.stamp_ns, (
                f'window opened at {format_stamp(opened.stamp_ns)} did not close within '
                f'max_window_s = {cfg.max_window_s:g} s; abandoned.')))
            self._cutter.reset()
            keep_from = t_event - half_ns
        self.pulses.discard_before(keep_from)
        self.table.discard_before(keep_from - int(TABLE_HISTORY_S * NS_PER_S))

    def _trim_idle(self) -> None:
        """Keep only what an event still to come may need.

        With no index events pending, keep only what an event still to come may need: a
        lagging event stream is waited for at most ``stall_timeout_s``, so the data older
        than that (plus the widest fit span) can no longer be asked for.

        Trims only once a buffer holds 1.25 × that span, so the cost is amortised.
        """
        limit = int((self.config.stall_timeout_s + 2 * MAX_FIT_HALF_WIDTH_S) * NS_PER_S)
        if self._cutter.open_event is not None:
            return
        for buf in (self.pulses, self.table):  # a stream never seen (no table) holds nothing
            if buf.newest_ns is not None and buf.span_ns() > limit * 5 // 4:
                buf.discard_before(buf.newest_ns - limit)

    # -- results -----------------------------------------------------------------------------
    @property
    def pairs(self) -> list[WindowPair]:
        """Every accepted window pair, in time order."""
        return self._pairs.pairs

    @property
    def rejections(self) -> list[Rejection]:
        """Every rejection so far (windows, events, unpaired windows)."""
        return self._cutter.rejections + self._pairs.rejections

    def _require_pairs(self, what: str) -> None:
        n = len(self._pairs.pairs)
        if n < self.config.min_pairs:
            raise InsufficientDataError(
                f'{n} window pair(s) accepted; {what} needs at least min_pairs = '
                f'{self.config.min_pairs}.')

    def k_tilde(self) -> Estimate:
        """Running K̃, ″/pulse: mean over pairs with s/√n (METHODS §A.2 eq. 3).

        Raises:
            InsufficientDataError: with fewer than ``config.min_pairs`` pairs.
        """
        self._require_pairs('K̃')
        return dataclasses.replace(self._pairs.k_tilde(), rejected=tuple(self.rejections))

    def earth_plus_bias_deg_h(self) -> Estimate:
        """Running ω'_e + ω_B along og, °/h, from N⁺ + N⁻ (METHODS §A.2 eqs. 1–2).

        Raises:
            InsufficientDataError: with fewer than ``config.min_pairs`` pairs.
        """
        self._require_pairs('the Earth-rate + bias term')
        return self._pairs.earth_plus_bias()


def calibrate_k_tilde(
    pulse_t_ns: ArrayLike,
    pulse_counts: ArrayLike,
    table_t_ns: ArrayLike,
    table_angle_rad: ArrayLike,
    table_rate_rad_s: ArrayLike,
    zero_index_ns: ArrayLike,
    config: KTildeConfig | None = None,
) -> RateBiasCalibrator:
    """Batch K̃ calibration over whole recordings; returns the finished calibrator.

    Read ``.k_tilde()``, ``.pairs``, ``.windows`` and ``.rejections`` from the result.
    If the source restarted (stamps jump back by ``restart_backstep_s``), each timeline
    is calibrated in turn, as the live node would, and the pairs of all are kept.
    """
    cal = RateBiasCalibrator(config or KTildeConfig())
    back = int(cal.config.restart_backstep_s * NS_PER_S)
    streams: list[tuple[Callable[..., object], npt.NDArray[np.int64],
                        tuple[npt.ArrayLike, ...]]] = [
        (cal.extend_pulses, np.asarray(pulse_t_ns, np.int64), (pulse_counts,)),
        (cal.extend_table_states, np.asarray(table_t_ns, np.int64),
         (table_angle_rad, table_rate_rad_s)),
        (cal.extend_zero_index, np.asarray(zero_index_ns, np.int64), ()),
    ]
    feed_by_timeline(streams, back, lambda: cal.process(flush=True))
    return cal
