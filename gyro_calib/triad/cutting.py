"""Cutting the triad's windows per channel on one table (METHODS §A.2, §F.2).

:func:`cut_windows` runs each channel's counts through the shared cutter
(:mod:`gyro_calib.windows`); the table decides the windows, so the channels' windows coincide
except where a channel's own counts failed. :func:`combine_windows` makes them
:class:`TriadWindow` s: a channel's window below ``min_pulse_rate_hz`` is rejected for that
channel alone, an outer window needs the rate table held at its station, and each count's
uncertainty is at least the quantisation floor of its two ends.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.triad.quantisation import end_floor, end_quantisation_variances
from gyro_calib.units import format_stamp
from gyro_calib.windows import RevolutionWindow, WholeRevolutionWindows, resolve_index_event

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.triad.settings import TriadSettings

    Array = npt.NDArray[np.float64]

MIN_COUNT_STD_PULSES = 1e-3
"""Floor of a window end's count uncertainty, pulses (a fit of a noiseless line gives 0)."""
INNER, OUTER = 'inner', 'outer'


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
        counts_std: u(N) per channel (3,), pulses: the end fits' residuals floored by the
            quantisation bound, the weights of the solve (the estimates rest on them).
        counts_model_std: u(N) per channel (3,), pulses, from the rounding at the two end fits
            (eq. (6a)): what the covariance rests on; None: as ``counts_std``.
        end_model_var: u²_end of the start and the end count per channel (2, 3), pulses²
            (eq. (6a)): a window sharing an end with another shares its error; or None.
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
    counts_model_std: Array | None = None
    end_model_var: Array | None = None


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
    places oZ for the Earth rate. Each window's count uncertainty (the weights) is at least the
    quantisation floor of its two ends (:func:`quantisation_floor`); its model uncertainty
    is the rounding at the two end fits (:func:`end_quantisation_variances`, eq. (6a)).
    """
    out: list[TriadWindow] = []
    rejections: list[Rejection] = []
    o_t, o_v = other
    for start, per in windows:
        ref = next(w for w in per if w is not None)
        counts, stds, model = np.zeros(3), np.ones(3), np.ones(3)
        ends = np.zeros((2, 3))
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
            model[c] = max(w.pulses_std, floor)
            if pulses is not None:
                floor = max(floor, end_floor(settings, pulses, c, w.start_ns, w.end_ns))
                v_start, v_end = end_quantisation_variances(settings, pulses, c, w.start_ns,
                                                            w.end_ns)
                if math.isfinite(v_start + v_end):
                    model[c] = max(math.sqrt(v_start + v_end), MIN_COUNT_STD_PULSES)
                    ends[:, c] = v_start, v_end
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
                               stds, (why[0], why[1], why[2]), station, held,
                               model if pulses is not None else None,
                               ends if pulses is not None else None))
    return out, rejections
