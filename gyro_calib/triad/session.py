"""The triad method behind the shared front door: /imu/pulses and the tables → K, s_i, M, b.

Whole-revolution windows are cut per channel by the shared §A machinery
(:mod:`gyro_calib.windows`: a local fit of each channel's counts and of the encoder at every
zero-index event, §A eq. (2a)), on the rate table (inner axis, u = F·e_z, or u = ±e_j of the
mount on a single-axis table) and on the position table (outer axis, u = F·u_T(β) of METHODS
§F eq. (1), β the rate-table encoder angle held at the station + ψ₀). Consecutive forward and
reverse windows about one direction form a :class:`~gyro_calib.triad.estimator.TriadPair`
(eqs. (5)–(6)); :func:`~gyro_calib.triad.estimator.triad_calibration` solves the rows with the
tilt α fitted (its stated uncertainty as prior) and the biases with the Earth rate removed
(eqs. (13)–(14)). A channel's window is rejected for that channel alone, with a line (too few
samples, a glitch, or a count rate below ``min_pulse_rate_hz``: a rate-biased RLG locked in
about that direction); a channel whose directions do not span 3-D is not measurable.

The remount variant (single-axis table) is several bags, one mount each, fed one after the
other (:meth:`TriadSession.start_bag`; the bench setting ``mount_axis`` stored per bag).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib import topics
from gyro_calib.config import check_ranges, read_method_file
from gyro_calib.errors import ConfigError, InsufficientDataError
from gyro_calib.estimate import Estimate, Rejection
from gyro_calib.imu_calibration import ImuCalibration
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.triad.estimator import BenchParameter, TriadPair, TriadResult, triad_calibration
from gyro_calib.triad.keys import METHOD
from gyro_calib.triad.kinematics import (
    REMOUNT_AXES,
    TILT,
    earth_rate_along,
    inner_axis_direction,
    inner_axis_enu,
    outer_axis_direction,
    pair_from_windows,
    remount_direction,
)
from gyro_calib.units import ARCSEC_PER_RAD, NS_PER_S, RAD_PER_ARCSEC, format_stamp
from gyro_calib.windows import (
    RevolutionWindow,
    WholeRevolutionWindows,
    WindowFields,
    resolve_index_event,
)

if TYPE_CHECKING:
    from pathlib import Path

    import numpy.typing as npt

    from gyro_calib.bagio import SampleBatch
    from gyro_calib.handoff import Calibration

    Array = npt.NDArray[np.float64]

JOINT_STATE, HEADER = 'sensor_msgs/msg/JointState', 'std_msgs/msg/Header'
TOPICS = {topics.IMU_PULSES: JOINT_STATE,
          topics.RATE_TABLE_JOINT_STATES: JOINT_STATE, topics.RATE_TABLE_ZERO_INDEX: HEADER,
          topics.POSITION_TABLE_JOINT_STATES: JOINT_STATE,
          topics.POSITION_TABLE_ZERO_INDEX: HEADER}
NODE_NAME = 'triad_calibration_node'
DEG_H = math.radians(1.0) / 3600.0
"""rad/s per °/h."""
MIN_COUNT_STD_PULSES = 1e-3
"""Floor of a window end's count uncertainty, pulses (a fit of a noiseless line gives 0)."""
INNER, OUTER = 'inner', 'outer'


@dataclass(frozen=True, slots=True)
class TriadSettings(WindowFields):
    """Window, pair and channel settings of the triad method (METHODS §F.2, §A.2's rules).

    The window and fit fields come first, from :class:`~gyro_calib.windows.WindowFields` (m:
    rate-table, inner-axis, revolutions per window; the bag's stored value wins); the pulse
    stream is /imu/pulses, a local fit's residual rejects the event for that channel alone.
    """

    window_angle_source: str = 'encoder'
    """'encoder' (swept angle measured between the events) or 'nominal' (whole turns)."""
    max_pair_gap_s: float = 120.0
    """Longest time from a window to the opposite-direction window it is paired with, s."""
    min_pulse_rate_hz: float = 0.0
    """A channel's window with a mean count rate below this is rejected for that channel
    (a rate-biased RLG locked in about that direction), pulses/s; 0 = no check."""
    station_still_deg_s: float = 0.05
    """The rate table counts as held at its station during a position-table window while its
    |rate| stays below this, °/s."""
    analysis_period_s: float = 60.0
    """Live: the windows are recut from the data held after this much more data, s."""

    def __post_init__(self) -> None:
        """Range-check every field (ConfigError naming it)."""
        check_ranges(self, [
            *self.window_checks(angle_within_half_turn=False, jump_may_be_zero=True),
            ('window_angle_source', self.window_angle_source in ('encoder', 'nominal'),
             "'encoder' or 'nominal'"),
            ('max_pair_gap_s', self.max_pair_gap_s > 0, 'positive'),
            ('min_pulse_rate_hz', self.min_pulse_rate_hz >= 0, 'non-negative'),
            ('station_still_deg_s', self.station_still_deg_s > 0, 'positive'),
            ('analysis_period_s', self.analysis_period_s > 0, 'positive'),
        ])


def triad_settings_from_mapping(values: dict[str, Any], *, source: str) -> TriadSettings:
    """The settings from a mapping (config file), refusing unknown fields by name."""
    names = {f.name for f in dataclasses.fields(TriadSettings)}
    unknown = sorted(set(values) - names)
    if unknown:
        raise ConfigError(f'{source}: unknown triad setting {unknown[0]!r}; the settings are '
                          f'{", ".join(sorted(names))}.')
    return TriadSettings(**values)


@dataclass(slots=True)
class _Stream:
    """Samples of one stream of one bag, appended batch by batch."""

    t: list[npt.NDArray[np.int64]] = field(default_factory=list)
    v: list[Array] = field(default_factory=list)

    def add(self, t: npt.NDArray[np.int64], v: Array) -> None:
        if len(t):
            self.t.append(np.asarray(t, dtype=np.int64))
            self.v.append(np.asarray(v, dtype=np.float64))

    def arrays(self, width: int) -> tuple[npt.NDArray[np.int64], Array]:
        if not self.t:
            return np.zeros(0, np.int64), np.zeros((0, width))
        t = np.concatenate(self.t)
        v = np.concatenate(self.v).reshape(len(t), width)
        order = np.argsort(t, kind='stable')
        return t[order], v[order]


@dataclass(slots=True)
class _Segment:
    """One bag (one mount) of data: the streams and its mount axis ('' on the two-axis bench)."""

    label: str
    mount_axis: str = ''
    pulses: _Stream = field(default_factory=_Stream)
    rate: _Stream = field(default_factory=_Stream)
    rate_index: _Stream = field(default_factory=_Stream)
    position: _Stream = field(default_factory=_Stream)
    position_index: _Stream = field(default_factory=_Stream)


@dataclass(frozen=True, slots=True)
class TriadWindow:
    """One whole-revolution window of all three channels.

    Attributes:
        axis: 'inner' (rate table) or 'outer' (position table).
        start_ns, end_ns: bounding zero-index stamps, int ns.
        direction: +1 forward (encoder angle increasing), −1 reverse.
        angle_rad: |swept angle|, rad; angle_std_rad its uncertainty.
        duration_s: end − start, s.
        counts: N per channel (3,), pulses (0 where rejected for the channel).
        counts_std: u(N) per channel (3,), pulses.
        rejected: per channel, why this window is not used for it ('' = used).
        station_rad: outer windows: the rate-table encoder angle ψ held, rad; else NaN.
        other_table_rad: inner windows: the position-table angle χ (Earth rate), rad; or NaN.
    """

    axis: str
    start_ns: int
    end_ns: int
    direction: int
    angle_rad: float
    angle_std_rad: float
    duration_s: float
    counts: Array
    counts_std: Array
    rejected: tuple[str, str, str]
    station_rad: float = math.nan
    other_table_rad: float = math.nan


def _window_config(settings: TriadSettings, revolutions: int) -> TriadSettings:
    return dataclasses.replace(settings, revolutions_per_window=revolutions)


def cut_windows(settings: TriadSettings, revolutions: int, channels: tuple[str, str, str],
                pulses: tuple[npt.NDArray[np.int64], Array],
                table: tuple[npt.NDArray[np.int64], Array],
                index_ns: npt.NDArray[np.int64], *, axis: str,
                ) -> tuple[list[tuple[int, list[RevolutionWindow | None]]], list[Rejection]]:
    """Whole-revolution windows of each channel on one table (METHODS §A.2, §F.2).

    Each channel's counts go through the shared cutter; the table decides the windows, so the
    channels' windows coincide except where a channel's own counts failed (its line says why).

    Returns:
        (start stamp, [window of each channel or None]) in time order, and the rejections
        (a table-caused one once, a channel's own prefixed with the channel).
    """
    cfg = _window_config(settings, revolutions)
    p_t, counts = pulses
    s_t, s_v = table
    by_start: dict[int, list[RevolutionWindow | None]] = {}
    said: dict[tuple[int, str], set[int]] = {}
    for c in range(3):
        cutter = WholeRevolutionWindows(cfg)
        col = np.ascontiguousarray(counts[:, c])
        for t_event in index_ns.tolist():
            event = resolve_index_event(cfg, int(t_event), p_t, col, s_t, s_v)
            window = cutter.add_event(event, p_t, col, s_t, s_v[:, 0], s_v[:, 1])
            if window is not None:
                by_start.setdefault(window.start_ns, [None, None, None])[c] = window
        cutter.finish(s_t, s_v[:, 0], s_v[:, 1])
        for r in cutter.rejections:
            said.setdefault((r.stamp_ns, r.reason), set()).add(c)
    rejections = []
    for (stamp, reason), chans in said.items():
        if len(chans) == 3:
            rejections.append(Rejection(stamp, f'{axis}-axis: {reason}'))
        else:
            rejections.extend(Rejection(stamp, f'{axis}-axis, channel {channels[c]}: {reason}')
                              for c in sorted(chans))
    rejections.sort(key=lambda r: r.stamp_ns)
    return sorted(by_start.items()), rejections


def quantisation_floor(rate_pulses_s: float, period_s: float, samples: int) -> float:
    """Least standard uncertainty of a fitted count at an instant under quantisation, pulses.

    A local fit of integer counts averages their ±½-pulse errors down only when the count's
    fractional part runs through its cycle within the fit span. With δ pulses per sample near
    p/q (q small) the pattern of fractional parts repeats every q samples and drifts by
    d_q = |q·δ − round(q·δ)| per q samples: amplitude 1/q, L·d_q/q cycles over L samples,

        u_q = 1/(√12·q) / max(1, L·d_q/q),   floor = max over q = 1…4 of u_q

    (near-integer δ: up to 1/√12 pulse however long the fit; METHODS §F.5 "Limits").
    """
    delta = abs(rate_pulses_s) * period_s
    worst = 0.0
    for q in range(1, 5):
        d_q = abs(q * delta - round(q * delta))
        worst = max(worst, 1.0 / (math.sqrt(12.0) * q) / max(1.0, samples * d_q / q))
    return worst


def _end_floor(settings: TriadSettings, pulses: tuple[npt.NDArray[np.int64], Array], c: int,
               start_ns: int, end_ns: int) -> float:
    """The quantisation floor of a window's count: both ends, at their local count rates."""
    t, counts = pulses
    half = int(settings.fit_half_width_s * NS_PER_S)
    var = 0.0
    for at in (start_ns, end_ns):
        lo = int(np.searchsorted(t, at - half, 'left'))
        hi = int(np.searchsorted(t, at + half, 'right')) - 1
        if hi - lo < 2:
            continue
        period = (t[hi] - t[lo]) / NS_PER_S / (hi - lo)
        rate = float(counts[hi, c] - counts[lo, c]) / (period * (hi - lo))
        var += quantisation_floor(rate, period, hi - lo + 1) ** 2
    return math.sqrt(var)


def _median_in(t: npt.NDArray[np.int64], v: Array, lo: int, hi: int) -> tuple[float, float]:
    """(median of v[:, 0], max |v[:, 1]|) over stamps in [lo, hi]; NaN without samples."""
    a, b = int(np.searchsorted(t, lo, 'left')), int(np.searchsorted(t, hi, 'right'))
    if b <= a:
        return math.nan, math.nan
    return float(np.median(v[a:b, 0])), float(np.max(np.abs(v[a:b, 1])))


def combine_windows(settings: TriadSettings, channels: tuple[str, str, str],
                    windows: list[tuple[int, list[RevolutionWindow | None]]], *, axis: str,
                    other: tuple[npt.NDArray[np.int64], Array],
                    pulses: tuple[npt.NDArray[np.int64], Array] | None = None,
                    ) -> tuple[list[TriadWindow], list[Rejection]]:
    """The channels' windows as :class:`TriadWindow` s, with per-channel rejections.

    ``other`` is the other table's joint_states: for an outer window the rate table must be
    held (its angle is the station ψ); for an inner window the position table's angle χ
    places oZ for the Earth rate. Each window's count uncertainty is at least the
    quantisation floor of its two ends (:func:`quantisation_floor`).
    """
    out: list[TriadWindow] = []
    rejections: list[Rejection] = []
    o_t, o_v = other
    for start, per in windows:
        ref = next(w for w in per if w is not None)
        counts, stds = np.zeros(3), np.ones(3)
        why = ['', '', '']
        for c, w in enumerate(per):
            if w is None:
                why[c] = 'its counts failed at this window (see its line)'
                continue
            rate = abs(w.pulses) / w.duration_s
            if rate < settings.min_pulse_rate_hz:
                why[c] = (f'count rate {rate:.3g} pulses/s < min_pulse_rate_hz = '
                          f'{settings.min_pulse_rate_hz:g}: the gyro sees too little rate about '
                          'this direction (lock-in of a rate-biased RLG)')
                rejections.append(Rejection(start, (
                    f'{axis}-axis window {format_stamp(start)} → {format_stamp(w.end_ns)} '
                    f'rejected for channel {channels[c]}: {why[c]}.')))
                continue
            counts[c] = w.pulses
            floor = MIN_COUNT_STD_PULSES
            if pulses is not None:
                floor = max(floor, _end_floor(settings, pulses, c, w.start_ns, w.end_ns))
            stds[c] = max(w.pulses_std, floor)
        other_angle, other_rate = _median_in(o_t, o_v, ref.start_ns, ref.end_ns)
        station = held = math.nan
        if axis == OUTER:
            if not math.isfinite(other_angle):
                rejections.append(Rejection(start, (
                    f'outer-axis window {format_stamp(start)} → {format_stamp(ref.end_ns)} '
                    'rejected: no rate-table joint_states during it (the station β is '
                    'unknown).')))
                continue
            if other_rate > math.radians(settings.station_still_deg_s):
                rejections.append(Rejection(start, (
                    f'outer-axis window {format_stamp(start)} → {format_stamp(ref.end_ns)} '
                    f'rejected: the rate table turned at up to {math.degrees(other_rate):.3g} '
                    f'°/s during it (station_still_deg_s {settings.station_still_deg_s:g}): '
                    'no fixed station.')))
                continue
            station = other_angle % (2 * math.pi)
        else:
            held = other_angle
        out.append(TriadWindow(axis, ref.start_ns, ref.end_ns, ref.direction,
                               ref.swept_angle_rad, ref.angle_std_rad, ref.duration_s, counts,
                               stds, (why[0], why[1], why[2]), station, held))
    return out, rejections


@dataclass(frozen=True, slots=True)
class Bench:
    """The bench settings the directions and the Earth rate rest on (METHODS §F.1, §F.5)."""

    tilt_rad: float = math.nan
    tilt_std_rad: float = 60.0 * RAD_PER_ARCSEC
    station_offset_rad: float = 0.0
    fixture: Array = field(default_factory=lambda: np.eye(3))
    latitude_deg: float = math.nan
    heading_deg: float = 0.0


def pair_windows(settings: TriadSettings, bench: Bench, windows: list[TriadWindow], *,
                 mount_axis: str = '', final: bool = True,
                 ) -> tuple[list[tuple[TriadPair, str]], list[Rejection], int]:
    """Consecutive forward/reverse windows about one direction → pairs (eqs. (1)–(6), (13)).

    ``final``: the data ended, so windows still waiting for their reverse are unpaired (live,
    before the end, they wait).

    Returns:
        (pair, axis label) in time order, the windows left unpaired with why, and the end
        stamp of the last paired window (0 without pairs).
    """
    pairs: list[tuple[TriadPair, str]] = []
    rejections: list[Rejection] = []
    stack: list[TriadWindow] = []
    last_end = 0
    station_tol = math.radians(0.01)
    gap_ns = int(settings.max_pair_gap_s * NS_PER_S)

    def same_place(a: TriadWindow, b: TriadWindow) -> bool:
        if a.axis != b.axis or b.start_ns - a.end_ns > gap_ns:
            return False
        if a.axis == OUTER:
            d = abs((a.station_rad - b.station_rad + math.pi) % (2 * math.pi) - math.pi)
            return d <= station_tol
        return True

    def unpaired(w: TriadWindow, why: str) -> None:
        rejections.append(Rejection(w.start_ns, (
            f'{w.axis}-axis window {format_stamp(w.start_ns)} → {format_stamp(w.end_ns)} '
            f'left unpaired: {why}')))

    for w in sorted(windows, key=lambda x: x.start_ns):
        if stack and same_place(stack[-1], w) and stack[-1].direction != w.direction:
            made = _pair(bench, stack.pop(), w, mount_axis)  # nested about the reversal
            if isinstance(made, str):
                rejections.append(Rejection(w.start_ns, made))
            else:
                pairs.append(made)
                last_end = max(last_end, w.end_ns)
            continue
        if stack and not (same_place(stack[-1], w) and stack[-1].direction == w.direction):
            for left in stack:
                unpaired(left, 'no opposite-direction window about the same axis'
                         + (' and station' if left.axis == OUTER else '')
                         + f' followed it within max_pair_gap_s = {settings.max_pair_gap_s:g} s.')
            stack = []
        stack.append(w)
    for left in stack if final else ():
        unpaired(left, 'no opposite-direction window followed it.')
    return pairs, rejections, last_end


def _pair(bench: Bench, a: TriadWindow, b: TriadWindow,
          mount_axis: str) -> tuple[TriadPair, str] | str:
    fwd, rev = (a, b) if a.direction > 0 else (b, a)
    sens: Array | None = None
    up = (0.0, 0.0, 1.0)
    if a.axis == OUTER:
        if not math.isfinite(bench.tilt_rad):
            return (f'outer-axis pair at {format_stamp(a.start_ns)} not used: the direction '
                    'u(β) needs the bench setting tilt_deg (α between the rate-table axis and '
                    'the position-table axis).')
        station = 0.5 * (a.station_rad + b.station_rad)
        u, d = outer_axis_direction(station, bench.tilt_rad,
                                    station_offset_rad=bench.station_offset_rad,
                                    fixture=bench.fixture)
        sens = d[:, :1]
        omega = earth_rate_along(up, bench.latitude_deg) if math.isfinite(
            bench.latitude_deg) else math.nan
        label = f'station β = {math.degrees(station + bench.station_offset_rad):.3f}°'
    elif mount_axis:
        u = remount_direction(mount_axis)
        omega = earth_rate_along(up, bench.latitude_deg) if math.isfinite(
            bench.latitude_deg) else math.nan
        label = f'mount {mount_axis}'
    else:
        u = inner_axis_direction(bench.fixture)
        sens = np.zeros((3, 1))
        chi = 0.5 * (a.other_table_rad + b.other_table_rad)
        omega = math.nan
        if math.isfinite(bench.latitude_deg) and math.isfinite(chi) and math.isfinite(
                bench.tilt_rad):
            omega = earth_rate_along(inner_axis_enu(tilt_rad=bench.tilt_rad,
                                                    heading_deg=bench.heading_deg,
                                                    position_table_angle_rad=chi),
                                     bench.latitude_deg)
        label = 'inner axis'
    std = np.sqrt(0.5 * (fwd.counts_std ** 2 + rev.counts_std ** 2))
    angle_std = math.sqrt(0.5 * (fwd.angle_std_rad ** 2 + rev.angle_std_rad ** 2))
    rejected = tuple(f or r for f, r in zip(fwd.rejected, rev.rejected, strict=True))
    pair = pair_from_windows(
        u, forward_counts=fwd.counts, reverse_counts=rev.counts, counts_std=std,
        forward_angle_rad=fwd.angle_rad, reverse_angle_rad=rev.angle_rad,
        forward_s=fwd.duration_s, reverse_s=rev.duration_s, angle_std_rad=angle_std,
        earth_rate_along_u_rad_s=omega, direction_sensitivity=sens,
        stamp_ns=min(a.start_ns, b.start_ns),
        rejected=(rejected[0], rejected[1], rejected[2]))
    return pair, label


class TriadSession(MethodSession):
    """K_i, sense axes s_i, M and biases of a gyro triad (METHODS §F)."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Settings: config file, node parameters; bench: flags, config, stored, default."""
        values: dict[str, Any] = {k: v for k, v in options.settings.items()
                                  if k in {f.name for f in dataclasses.fields(TriadSettings)}}
        if options.config_file is not None:
            from_file, _ = read_method_file(options.config_file, node_name=NODE_NAME,
                                            fields=[f.name for f in
                                                    dataclasses.fields(TriadSettings)])
            values.update(from_file)
        source = str(options.config_file) if options.config_file is not None else 'settings'
        settings = triad_settings_from_mapping(values, source=source)
        stored_m = options.bench('revolutions_per_window', None)
        if stored_m is not None and 'revolutions_per_window' not in values:
            settings = dataclasses.replace(settings, revolutions_per_window=int(stored_m))
        self.settings = settings
        self.options = options
        tilt = float(options.setting('tilt_deg', math.nan))
        fixture = options.bench('fixture_rotation', None)
        try:
            f = np.eye(3) if fixture is None else np.asarray(fixture, dtype=np.float64)
            inner_axis_direction(f)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f'fixture_rotation {fixture!r:.80} is invalid: {exc}') from None
        self.bench = Bench(
            tilt_rad=math.radians(tilt),
            tilt_std_rad=float(options.setting('tilt_std_arcsec', 60.0)) * RAD_PER_ARCSEC,
            station_offset_rad=math.radians(float(options.setting('station_offset_deg', 0.0))),
            fixture=f, latitude_deg=options.latitude,
            heading_deg=float(options.setting('heading_deg', 0.0)))
        self.channels: tuple[str, str, str] = ('x', 'y', 'z')
        self._segments = [_Segment('the bag', self._mount_of(0))]
        self._rejections: list[Rejection] = []
        self._lines: list[str] = []
        self._pairs: list[tuple[TriadPair, str]] = []
        self._result: TriadResult | None = None
        self._problem = ''
        self._analysed_to_ns: int | None = None
        self._newest_ns: int | None = None
        self._dirty = self._fed = False
        self._last_end_ns = 0

    # -- input ------------------------------------------------------------------------------
    def _mount_of(self, index: int) -> str:
        benches = self.options.stored_benches
        if benches:
            bench = benches[index][1] if index < len(benches) else {}
        else:
            bench = self.options.scenario.get('bench', {}) if isinstance(
                self.options.scenario, dict) else {}
        axis = bench.get('mount_axis', '') if isinstance(bench, dict) else ''
        given_axis = self.options.config_bench.get('mount_axis') or self.options.settings.get(
            'mount_axis')
        axis = str(given_axis or axis or '')
        if axis and axis not in REMOUNT_AXES:
            raise ConfigError(f'mount_axis = {axis!r} is invalid: it must be one of '
                              f'{", ".join(REMOUNT_AXES)}.')
        return axis

    def _check_one_procedure(self, first: Path) -> None:
        """Two-axis and remount bags are not one calibration: refused before their data.

        Raises:
            ConfigError: the bags mix a remount (``mount_axis``) and a two-axis bench.
        """
        benches = self.options.stored_benches
        mounts = [self._mount_of(i) for i in range(len(benches))] if benches else []
        if any(mounts) and not all(mounts):
            at = next(i for i, m in enumerate(mounts) if m)
            two_axis = next(benches[i][0] for i, m in enumerate(mounts) if not m)
            raise ConfigError(f'{benches[at][0]} is a remount bag (mount_axis {mounts[at]}) and '
                              f'{two_axis} is not (no mount_axis: the two-axis bench); the two '
                              'procedures are calibrated separately: give the remount bags '
                              'together, and the two-axis bag alone.')

    def topics(self) -> dict[str, str]:
        """/imu/pulses and both tables' streams."""
        return dict(TOPICS)

    def start_bag(self, index: int, path: Path) -> None:
        """Bag ``index`` is a new mount (remount variant): its windows are cut on their own."""
        seg = self._segments[-1]
        if index == 0:
            seg.label = str(path)
            seg.mount_axis = self._mount_of(0)
            self._check_one_procedure(path)
            return
        self._segments.append(_Segment(str(path), self._mount_of(index)))
        self._dirty = True

    def feed(self, batch: SampleBatch) -> None:
        """The samples of the batch (3-channel /imu/pulses, tables, zero-index events)."""
        seg = self._segments[-1]
        col = batch.columns.get(topics.IMU_PULSES)
        if col is not None and len(col):
            pos = np.asarray(col.values['position'], dtype=np.float64)
            if pos.ndim != 2 or pos.shape[1] != 3:
                raise InsufficientDataError(
                    f'{topics.IMU_PULSES} must carry three channels per message (position '
                    f'of three joints); got {pos.shape[1] if pos.ndim == 2 else 1}.')
            names = col.joint_names
            if len(names) == 3:
                self.channels = (str(names[0]), str(names[1]), str(names[2]))
            ok = np.all(np.isfinite(pos), axis=1)
            seg.pulses.add(col.stamp_ns[ok], pos[ok])
            self._seen(int(col.stamp_ns[-1]))
        for topic, stream in ((topics.RATE_TABLE_JOINT_STATES, seg.rate),
                              (topics.POSITION_TABLE_JOINT_STATES, seg.position)):
            js = batch.joint_state(topic)
            if js is not None and len(js[0]):
                ok = np.isfinite(js[1]) & np.isfinite(js[2])
                stream.add(js[0][ok], np.column_stack((js[1][ok], js[2][ok])))
        for topic, stream in ((topics.RATE_TABLE_ZERO_INDEX, seg.rate_index),
                              (topics.POSITION_TABLE_ZERO_INDEX, seg.position_index)):
            st = batch.stamps(topic)
            if st is not None and len(st):
                stream.add(st, np.zeros((len(st), 1)))
        if any(len(c) for c in batch.columns.values()):
            self._dirty = self._fed = True

    def _seen(self, stamp: int) -> None:
        self._newest_ns = stamp if self._newest_ns is None else max(self._newest_ns, stamp)
        self._dirty = self._fed = True

    # -- processing -------------------------------------------------------------------------
    def process(self, *, flush: bool = False) -> list[str]:
        """Cut windows and pairs and solve (at the end, and live).

        Live: every ``analysis_period_s`` of data, and whenever the input paused (nothing fed
        since the last call), so the numbers at the end of the data are the offline ones.
        """
        fed, self._fed = self._fed, False
        if not self._dirty:
            return []
        if not flush and fed and self._analysed_to_ns is not None \
                and self._newest_ns is not None and self._newest_ns - self._analysed_to_ns \
                < self.settings.analysis_period_s * NS_PER_S:
            return []
        self._analyse(flush)
        self._dirty = False
        self._analysed_to_ns = self._newest_ns
        lines, self._lines = self._lines, []
        return lines

    def _analyse(self, final: bool) -> None:
        rejections: list[Rejection] = []
        pairs: list[tuple[TriadPair, str]] = []
        last_end = 0
        s = self.settings
        for seg in self._segments:
            p = seg.pulses.arrays(3)
            rate = seg.rate.arrays(2)
            position = seg.position.arrays(2)
            r_idx = seg.rate_index.arrays(1)[0]
            p_idx = seg.position_index.arrays(1)[0]
            windows: list[TriadWindow] = []
            if len(p[0]) and len(rate[0]) and len(r_idx):
                cut, rej = cut_windows(s, s.revolutions_per_window, self.channels, p, rate,
                                       r_idx, axis=INNER)
                got, rej2 = combine_windows(s, self.channels, cut, axis=INNER, other=position,
                                            pulses=p)
                windows += got
                rejections += rej + rej2
            if len(p[0]) and len(position[0]) and len(p_idx) and not seg.mount_axis:
                n = int(self.options.setting('position_table_revolutions', 1))
                cut, rej = cut_windows(s, n, self.channels, p, position, p_idx, axis=OUTER)
                got, rej2 = combine_windows(s, self.channels, cut, axis=OUTER, other=rate,
                                            pulses=p)
                windows += got
                rejections += rej + rej2
            made, rej3, end = pair_windows(s, self.bench, windows, mount_axis=seg.mount_axis,
                                      final=final or seg is not self._segments[-1])
            pairs += made
            last_end = max(last_end, end)
            rejections += rej3
        new = [r for r in rejections if r not in self._rejections]
        self._lines += [f'rejected: {r.reason}' for r in new]
        self._rejections = rejections
        self._pairs = pairs
        self._last_end_ns = last_end
        outer = any(label.startswith('station') for _, label in pairs)
        params = (BenchParameter(TILT, self.bench.tilt_std_rad, fitted=True),) if outer else ()
        use = [pr if outer else dataclasses.replace(pr, direction_sensitivity=None)
               for pr, _ in pairs]
        self._result, self._problem = None, ''
        try:
            self._result = triad_calibration(use, channels=self.channels, parameters=params,
                                             prediction_complete=False)
        except InsufficientDataError as exc:
            self._problem = str(exc)

    # -- results ----------------------------------------------------------------------------
    @property
    def triad_result(self) -> TriadResult | None:
        """The estimator's result (None before any pair)."""
        return self._result

    @property
    def pairs(self) -> list[tuple[TriadPair, str]]:
        """The pairs used, each with its direction's label."""
        return list(self._pairs)

    def results(self) -> dict[str, Estimate]:
        """K and the bias of each channel, by ``imu.<channel>.<key>``."""
        out: dict[str, Estimate] = {}
        r = self._result
        if r is None:
            return out
        for ch in r.channels:
            if ch.scale_factor_rad_per_pulse is not None:
                out[f'imu.{ch.name}.scale_factor_rad_per_pulse'] = ch.scale_factor_rad_per_pulse
        if r.bias_body_rad_s is not None:
            for name, est in zip(('x', 'y', 'z'), r.bias_body_rad_s, strict=True):
                out[f'imu.bias_rad_s.{name}'] = est
        return out

    def missing(self) -> dict[str, str]:
        """Why K, s, M or b are not measured."""
        r = self._result
        if r is None:
            why = self._problem or ('no window pair yet: the triad needs forward/reverse '
                                    'pairs about at least 3 independent directions.')
            return {'imu.scale_factor_rad_per_pulse': why, 'imu.pulses_to_body_rad': why}
        out: dict[str, str] = {}
        for ch in r.channels:
            if ch.not_measurable:
                out[f'imu.{ch.name}.scale_factor_rad_per_pulse'] = ch.not_measurable
        if r.not_measurable:
            out['imu.pulses_to_body_rad'] = r.not_measurable
        if r.bias_body_rad_s is None:
            out['imu.bias_rad_s'] = r.bias_missing or 'b needs all three rows and biases.'
        return out

    def not_measurable(self) -> dict[str, str]:
        """The rows whose directions do not span 3-D (no more data of this bench helps)."""
        r = self._result
        if r is None:
            return {}
        out = {f'imu.{c.name}.scale_factor_rad_per_pulse': c.not_measurable
               for c in r.channels if c.not_measurable}
        if r.not_measurable:
            out['imu.pulses_to_body_rad'] = r.not_measurable
        return out

    def rejections(self) -> list[Rejection]:
        """Windows, events and pairs rejected, with reasons."""
        return list(self._rejections)

    def data_span_ns(self) -> tuple[int, int] | None:
        """From the start of the first paired window to the end of the last."""
        if not self._pairs:
            return None
        return min(p.stamp_ns for p, _ in self._pairs), self._last_end_ns

    def conditions(self) -> dict[str, Any]:
        """The bench settings the result rests on."""
        b = self.bench
        return {'latitude_deg': b.latitude_deg, 'heading_deg': b.heading_deg,
                'tilt_deg': math.degrees(b.tilt_rad),
                'tilt_std_arcsec': b.tilt_std_rad * ARCSEC_PER_RAD,
                'station_offset_deg': math.degrees(b.station_offset_rad),
                'revolutions_per_window': self.settings.revolutions_per_window,
                'mount_axis': ','.join(s.mount_axis for s in self._segments if s.mount_axis)}

    def handoff_values(self) -> dict[str, Any]:
        """None at the top level: the results are the ``imu:`` section (:meth:`handoff`)."""
        return {}

    def imu_calibration(self) -> ImuCalibration | None:
        """The hand-off's ``imu:`` section from the result (None before any result)."""
        r = self._result
        if r is None:
            return None
        return imu_section(r, self.channels, self.bench.fixture)

    def handoff(self, source: str, *, gyro_id: str = '') -> Calibration | None:
        """This run's record: no top-level keys, the ``imu:`` section (format 4)."""
        import dataclasses as dc

        from gyro_calib.handoff import Provenance, method_calibration

        imu = self.imu_calibration()
        span = self.data_span_ns()
        if imu is None or span is None:
            return None
        conditions = {k: v for k, v in self.conditions().items()
                      if isinstance(v, str) and v or isinstance(v, (int, float))
                      and not isinstance(v, bool) and math.isfinite(v)}
        cal = method_calibration(self.name, {}, Provenance(source, span[0], span[1],
                                                           conditions=conditions),
                                 gyro_id=gyro_id)
        return dc.replace(cal, imu=imu)

    # -- presentation -----------------------------------------------------------------------
    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """K_i (″/pulse, u in ppm), misalignments (″), M (rad/pulse), biases (°/h)."""
        r = self._result
        rows: list[tuple[str, str, str, str]] = []
        if r is None:
            return rows
        for i, ch in enumerate(r.channels):
            k = ch.scale_factor_rad_per_pulse
            if k is None or ch.sense_axis is None:
                rows.append((f'K_{ch.name} (″/pulse)', '—', '', 'not measurable'))
                continue
            rows.append((f'K_{ch.name} (″/pulse) [u ppm]', f'{k.value * ARCSEC_PER_RAD:.10f}',
                         f'{k.std_uncertainty / k.value * 1e6:.3g} ppm', str(k.n_used)))
            for j, axis in enumerate('xyz'):
                if j == i:
                    continue
                e = ch.sense_axis[j]
                rows.append((f's_{ch.name}·e_{axis} (″)', f'{e.value * ARCSEC_PER_RAD:.3f}',
                             f'{e.std_uncertainty * ARCSEC_PER_RAD:.3g}', str(e.n_used)))
            if ch.bias_rad_s is not None:
                rows.append((f'bias_{ch.name} along s (°/h)', f'{ch.bias_rad_s.value / DEG_H:.5f}',
                             f'{ch.bias_rad_s.std_uncertainty / DEG_H:.3g}',
                             str(ch.bias_rad_s.n_used)))
        if r.pulses_to_body_rad is not None:
            for i, row in enumerate(r.pulses_to_body_rad):
                rows.append((f'M row {i} (rad/pulse)', ' '.join(f'{e.value:.9e}' for e in row),
                             ' '.join(f'{e.std_uncertainty:.2e}' for e in row),
                             str(row[0].n_used)))
        if r.bias_body_rad_s is not None:
            for name, e in zip('xyz', r.bias_body_rad_s, strict=True):
                rows.append((f'b_{name} body (°/h)', f'{e.value / DEG_H:.5f}',
                             f'{e.std_uncertainty / DEG_H:.3g}', str(e.n_used)))
        for name, e in r.parameters.items():
            rows.append((f'{name} correction (″)', f'{e.value * ARCSEC_PER_RAD:.4f}',
                         f'{e.std_uncertainty * ARCSEC_PER_RAD:.3g}', str(e.n_used)))
        return rows

    def summary_lines(self) -> list[str]:
        """Pairs per direction, the uncertainty's basis, what is not measured."""
        labels: dict[str, int] = {}
        for _, label in self._pairs:
            labels[label] = labels.get(label, 0) + 1
        lines = [f'pairs: {len(self._pairs)} (' + ', '.join(f'{k}: {v}' for k, v in
                                                            labels.items()) + ')'
                 + f'; rejected: {len(self._rejections)}']
        r = self._result
        if r is not None and r.basis:
            lines.append(f'uncertainty: {r.basis}; Birge ratio {r.birge_ratio:.3g}')
        lines += [f'{key}: not measured — {why}' for key, why in self.missing().items()]
        return lines

    def json_section(self) -> dict[str, Any]:
        """The shared results and rejections, and the ``imu:`` section."""
        out = super().json_section()
        imu = self.imu_calibration()
        if imu is not None:
            out['imu'] = imu.to_section()
        return out


def imu_section(r: TriadResult, channels: tuple[str, str, str],
                fixture: Array) -> ImuCalibration:
    """The ``imu:`` section of a :class:`TriadResult` (METHODS §F eqs. (10)–(14))."""
    missing: dict[str, str] = {}
    not_measurable: dict[str, str] = {}
    k = k_std = k_dof = axes = axes_std = None
    if any(c.scale_factor_rad_per_pulse is not None and c.sense_axis is not None
           for c in r.channels):  # the solved channels; a channel not measured is NaN (null)
        nan3 = (math.nan, math.nan, math.nan)
        k, k_std, k_dof, axes_std = (np.full(3, math.nan) for _ in range(4))
        axes = np.full((3, 3), math.nan)
        for i, c in enumerate(r.channels):
            e = c.scale_factor_rad_per_pulse
            if e is None or c.sense_axis is None:
                continue
            k[i], k_std[i], k_dof[i] = e.value, e.std_uncertainty, float(e.supported_dof)
            row = np.array([a.value for a in c.sense_axis] if c.sense_axis else nan3)
            axes[i] = row / np.linalg.norm(row)
            axes_std[i] = (math.sqrt(max(float(np.trace(c.sense_axis_covariance)), 0.0))
                           if c.sense_axis_covariance is not None else 0.0)
    why = '; '.join(c.not_measurable for c in r.channels if c.not_measurable)
    if why:
        for key in ('scale_factor_rad_per_pulse', 'sense_axes'):
            not_measurable[key] = why
    m = m_cov = None
    if r.pulses_to_body_rad is not None and r.pulses_to_body_covariance is not None:
        m = np.array([[e.value for e in row] for row in r.pulses_to_body_rad])
        m_cov = 0.5 * (r.pulses_to_body_covariance + r.pulses_to_body_covariance.T)
    else:
        not_measurable['pulses_to_body_rad'] = r.not_measurable or 'M needs all three rows.'
    b = b_std = None
    if r.bias_body_rad_s is not None:
        b = np.array([e.value for e in r.bias_body_rad_s])
        b_std = np.array([e.std_uncertainty for e in r.bias_body_rad_s])
    else:
        missing['bias_rad_s'] = r.bias_missing or 'b needs all three rows and biases.'
    return ImuCalibration(channels, np.asarray(fixture, dtype=np.float64), k, k_std, k_dof,
                          axes, axes_std, m, m_cov, b, b_std, missing=missing,
                          not_measurable=not_measurable)
