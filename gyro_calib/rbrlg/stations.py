"""Position-table stations of the θ procedure, cut from the streams (METHODS §A.3).

While the rate table holds still at a station ψ, the position table turns n whole
revolutions forward and n back. The same whole-revolution machinery that measures K̃
cuts the position table's windows (m = n) from its own zero-index events; each
forward/reverse pair gives N_og = (N⁺ − N⁻)/2 at the station angle read from the
rate-table encoder. The stations then give θ, β₀, α by least squares.
"""

from __future__ import annotations

import bisect
import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import InsufficientDataError
from gyro_calib.estimate import Rejection
from gyro_calib.rbrlg.calibrator import RateBiasCalibrator
from gyro_calib.rbrlg.config import KTildeConfig
from gyro_calib.rbrlg.fix_error_angle import FixErrorAngleResult, fix_error_angle_multi_station
from gyro_calib.streams import StampedBuffer
from gyro_calib.units import (
    ARCSEC_PER_RAD,
    ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H,
    NS_PER_S,
    format_stamp,
)

RUN_END_STILL_S = 0.5
"""A position-table run ends once the table has rested this long, s."""

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from gyro_calib.rbrlg.scale_factor import WindowPair
    from gyro_calib.windows import RevolutionWindow


@dataclass(frozen=True, slots=True)
class Station:
    """One position-table station.

    Attributes:
        start_ns, end_ns: span of its forward and reverse windows, int ns.
        rate_table_angle_rad: ψ, mean rate-table encoder angle over the span, rad.
        half_difference_pulses: N_og = (N⁺ − N⁻)/2, pulses.
        half_difference_std_pulses: its standard uncertainty from the window end fits, pulses.
    """

    start_ns: int
    end_ns: int
    rate_table_angle_rad: float
    half_difference_pulses: float
    half_difference_std_pulses: float


@dataclass(slots=True)
class StationCalibrator:
    """Accumulates position-table stations and estimates θ from them.

    Attributes:
        config: window settings for the position table (m = n, its revolutions each way).
        station_drift_tolerance_arcsec: largest rate-table angle change allowed during a
            station, ″.
    """

    config: KTildeConfig = field(default_factory=lambda: KTildeConfig(revolutions_per_window=1))
    station_drift_tolerance_arcsec: float = 5.0
    stations: list[Station] = field(default_factory=list)
    rejections: list[Rejection] = field(default_factory=list)
    _windows: RateBiasCalibrator = field(init=False)
    _rate_table: StampedBuffer = field(init=False)
    _run_starts: list[int] = field(default_factory=list)
    _runs: list[tuple[int, int, float]] = field(default_factory=list)
    _current_run: list[float] | None = None
    _last_position_ns: int | None = None
    _still_since: int | None = None

    def __post_init__(self) -> None:
        """Create the position-table window stage and the rate-table buffer."""
        self._windows = RateBiasCalibrator(self.config)
        self._windows._pairs.run_of = lambda t_ns: bisect.bisect_right(self._run_starts, t_ns)
        self._rate_table = StampedBuffer(2, int(self.config.restart_backstep_s * NS_PER_S))

    @property
    def position_table_revolutions(self) -> int:
        """n: whole position-table revolutions each way."""
        return self.config.revolutions_per_window

    def add_pulses(self, t_ns: int, count: float) -> None:
        """One gyro sample: stamp (ns), cumulative count (pulses)."""
        self._windows.add_pulses(t_ns, count)

    def add_position_table_state(self, t_ns: int, angle_rad: float, rate_rad_s: float) -> None:
        """One position-table joint_states sample."""
        self._windows.add_table_state(t_ns, angle_rad, rate_rad_s)
        self._track_runs(np.array([t_ns]), np.array([angle_rad]), np.array([rate_rad_s]))

    def add_position_zero_index(self, t_ns: int) -> None:
        """One position-table zero-index stamp."""
        self._windows.add_zero_index(t_ns)

    def add_rate_table_state(self, t_ns: int, angle_rad: float, rate_rad_s: float) -> None:
        """One rate-table joint_states sample (gives the station angle)."""
        self._rate_table.append(t_ns, angle_rad, rate_rad_s)

    def extend(self, pulses: tuple[ArrayLike, ArrayLike],
               position_table: tuple[ArrayLike, ArrayLike, ArrayLike],
               position_zero_index_ns: ArrayLike,
               rate_table: tuple[ArrayLike, ArrayLike, ArrayLike]) -> None:
        """Many samples of every stream at once (bag replay)."""
        self._windows.extend_pulses(*pulses)
        self._windows.extend_table_states(*position_table)
        self._track_runs(*(np.asarray(a) for a in position_table))
        self._windows.extend_zero_index(position_zero_index_ns)
        self._rate_table.extend(*rate_table)

    def _track_runs(self, t_ns: np.ndarray, angle: np.ndarray, rate: np.ndarray) -> None:
        """Runs of the position table (turning at ≥ min_rate_deg_s), in stamp order."""
        if self._last_position_ns is not None:
            keep = t_ns > self._last_position_ns
            t_ns, angle, rate = t_ns[keep], angle[keep], rate[keep]
        ok = np.isfinite(angle) & np.isfinite(rate)
        t_ns, angle, rate = t_ns[ok], angle[ok], rate[ok]
        if not len(t_ns):
            return
        self._last_position_ns = int(t_ns[-1])
        moving = np.abs(rate) >= math.radians(self.config.min_rate_deg_s)
        edges = np.nonzero(np.diff(moving))[0] + 1
        bounds = np.concatenate(([0], edges, [len(t_ns)]))
        hold_ns = int(RUN_END_STILL_S * NS_PER_S)
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            run = self._current_run
            if moving[lo]:
                if run is None:
                    self._run_starts.append(int(t_ns[lo]))
                    run = self._current_run = [float(t_ns[lo]), math.inf, -math.inf]
                self._still_since = None
                run[1] = min(run[1], float(angle[lo:hi].min()))
                run[2] = max(run[2], float(angle[lo:hi].max()))
            elif run is not None:  # a reversal passes through rest briefly: not an end
                if self._still_since is None:
                    self._still_since = int(t_ns[lo])
                if int(t_ns[hi - 1]) - self._still_since >= hold_ns:
                    start, low, high = run
                    self._runs.append((int(start), self._still_since,
                                       (high - low) / (2 * math.pi)))
                    self._current_run = self._still_since = None

    def process(self, *, flush: bool = False) -> list[Station]:
        """Turn every completed forward/reverse pair into a station; return the new ones.

        A position-table run that ends without giving a station is reported with its reason.
        """
        update = self._windows.process(flush=flush)
        self.rejections.extend(update.rejections)
        new = []
        for pair in update.pairs:
            station = self._station(pair)
            if station is not None:
                new.append(station)
                self.stations.append(station)
        self._judge_runs(flush)
        self._trim_rate_table()
        return new

    def _trim_rate_table(self) -> None:
        """Bound the rate-table history.

        Bound the rate-table history: a station spans one forward and one reverse window
        (each ≤ max_window_s) and the pulses deciding it may lag by stall_timeout_s, so
        older samples can never be asked for. Trims at 1.25 × that span (amortised).
        """
        cfg = self.config
        keep_ns = int((2 * cfg.max_window_s + cfg.stall_timeout_s + 60.0) * NS_PER_S)
        newest = self._rate_table.newest_ns
        if newest is not None and self._rate_table.span_ns() > keep_ns * 5 // 4:
            self._rate_table.discard_before(newest - keep_ns)

    def _judge_runs(self, flush: bool) -> None:
        newest = [self._windows.pulses.newest_ns, self._windows.table.newest_ns]
        margin = int(2 * self.config.fit_half_width_s * NS_PER_S)
        while self._runs:
            start, end, revs = self._runs[0]
            if not flush and (None in newest or min(newest) < end + margin):  # type: ignore
                return
            self._runs.pop(0)
            if any(start <= s.start_ns and s.end_ns <= end for s in self.stations):
                continue
            n = self.position_table_revolutions
            self.rejections.append(Rejection(start, (
                f'position-table run {format_stamp(start)} → {format_stamp(end)} gave no '
                f'station: it spanned {revs:.3f} revolutions and a station needs a forward '
                f'and a reverse window of {n} whole revolution(s) between zero-index marks '
                f'(too few revolutions, a reversal inside a window, or missing marks).')))

    def _station(self, pair: WindowPair) -> Station | None:
        start = min(pair.forward.start_ns, pair.reverse.start_ns)
        end = max(pair.forward.end_ns, pair.reverse.end_ns)
        t, v = self._rate_table.arrays()
        inside = (t >= start) & (t <= end)
        if not np.any(inside):
            self.rejections.append(Rejection(start, (
                f'station {format_stamp(start)} → {format_stamp(end)} skipped: no rate-table '
                'joint_states during it, so its angle β is unknown.')))
            return None
        angles = v[inside, 0]
        drift = float(np.ptp(angles)) * ARCSEC_PER_RAD
        if drift > self.station_drift_tolerance_arcsec:
            self.rejections.append(Rejection(start, (
                f'station {format_stamp(start)} → {format_stamp(end)} skipped: the rate table '
                f'moved {drift:.1f}″ during it (tolerance '
                f'{self.station_drift_tolerance_arcsec:g}″): β drifts.')))
            return None
        self._rate_table.discard_before(end)
        (n_plus, u_plus), (n_minus, u_minus) = (_whole_turns(w) for w in (pair.forward,
                                                                          pair.reverse))
        arw = self.config.angle_random_walk_deg_sqrt_h * ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H
        arw_pulses2 = 0.0
        if math.isfinite(arw):
            arw_pulses2 = arw * arw * (pair.forward.duration_s + pair.reverse.duration_s) / (
                pair.k_tilde_arcsec_per_pulse**2)
        return Station(
            start_ns=start, end_ns=end,
            rate_table_angle_rad=float(np.mean(angles)),
            half_difference_pulses=(n_plus - n_minus) / 2,
            half_difference_std_pulses=math.sqrt(u_plus**2 + u_minus**2 + arw_pulses2) / 2,
        )

    def fix_error_angle(self, k_tilde_arcsec_per_pulse: float) -> FixErrorAngleResult:
        """θ, β₀, α from the stations so far (least squares with covariance).

        Takes K̃ (eq. 10 is solved with K = K̃·cos θ). Each station is weighted by its
        predicted uncertainty (window-end fits, encoder angles, ARW when given); from four
        stations on, the larger of that and the residual scatter — widened by its Student-t
        factor, since a changing θ or a wobbling axis are not in the prediction — is reported.

        Raises:
            InsufficientDataError: fewer than 3 stations, or stations not spread in β.
        """
        st = self.stations
        return fix_error_angle_multi_station(
            [s.rate_table_angle_rad for s in st], [s.half_difference_pulses for s in st],
            k_tilde_arcsec_per_pulse=k_tilde_arcsec_per_pulse,
            position_table_revolutions=self.position_table_revolutions,
            half_difference_std_pulses=[s.half_difference_std_pulses for s in st])


def _whole_turns(window: RevolutionWindow) -> tuple[float, float]:
    """The window's count scaled to whole turns, with its uncertainty.

    The window's count scaled to exactly n whole turns by its encoder angle, and its
    standard uncertainty (counts and angle), pulses (φ_ON of eq. 10 is then exact).
    """
    nominal = 2 * math.pi * window.revolutions
    if not math.isfinite(window.angle_rad):
        return window.pulses, window.pulses_std
    scale = nominal / abs(window.angle_rad)
    rel_angle = window.angle_std_rad / abs(window.angle_rad)
    value = window.pulses * scale
    return value, math.hypot(window.pulses_std * scale, value * rel_angle)


def calibrate_fix_error_angle(
    pulses: tuple[ArrayLike, ArrayLike],
    position_table: tuple[ArrayLike, ArrayLike, ArrayLike],
    position_zero_index_ns: ArrayLike,
    rate_table: tuple[ArrayLike, ArrayLike, ArrayLike],
    *,
    k_tilde_arcsec_per_pulse: float,
    position_table_revolutions: int = 1,
    config: KTildeConfig | None = None,
) -> tuple[FixErrorAngleResult, StationCalibrator]:
    """Batch θ calibration over whole recordings of the θ procedure.

    Raises:
        InsufficientDataError: if too few usable stations were found.
    """
    cfg = dataclasses.replace(config or KTildeConfig(),
                              revolutions_per_window=position_table_revolutions)
    cal = StationCalibrator(cfg)
    cal.extend(pulses, position_table, position_zero_index_ns, rate_table)
    cal.process(flush=True)
    if not cal.stations:
        raise InsufficientDataError('no usable position-table station in the recording.')
    return cal.fix_error_angle(k_tilde_arcsec_per_pulse), cal
