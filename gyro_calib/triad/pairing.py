"""Pairing the triad's windows: forward and reverse about one direction (METHODS §F eqs. (1)–(6)).

Consecutive forward/reverse windows about one direction, nested about the reversal, form a
:class:`~gyro_calib.triad.estimator.TriadPair` with its direction u: the inner axis (u = F·e_z),
a station of the position table (u = F·u_T(β)), or a remount's mount axis; with the Earth
rate along u (eq. (13)) when the bench says where u points.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Rejection
from gyro_calib.triad.cutting import OUTER
from gyro_calib.triad.kinematics import (
    earth_rate_along,
    inner_axis_direction,
    inner_axis_enu,
    outer_axis_direction,
    pair_from_windows,
    remount_direction,
)
from gyro_calib.units import NS_PER_S, format_stamp

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.triad.cutting import TriadWindow
    from gyro_calib.triad.records import TriadPair
    from gyro_calib.triad.settings import Bench, TriadSettings

    Array = npt.NDArray[np.float64]


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
    model = None
    if fwd.counts_model_std is not None and rev.counts_model_std is not None:
        model = np.sqrt(0.5 * (fwd.counts_model_std ** 2 + rev.counts_model_std ** 2))
    angle_std = math.sqrt(0.5 * (fwd.angle_std_rad ** 2 + rev.angle_std_rad ** 2))
    rejected = tuple(f or r for f, r in zip(fwd.rejected, rev.rejected, strict=True))
    pair = pair_from_windows(
        u, forward_counts=fwd.counts, reverse_counts=rev.counts, counts_std=std,
        forward_angle_rad=fwd.angle_rad, reverse_angle_rad=rev.angle_rad,
        forward_s=fwd.duration_s, reverse_s=rev.duration_s, angle_std_rad=angle_std,
        earth_rate_along_u_rad_s=omega, direction_sensitivity=sens,
        stamp_ns=min(a.start_ns, b.start_ns),
        rejected=(rejected[0], rejected[1], rejected[2]), model_counts_std=model)
    if fwd.end_model_var is not None and rev.end_model_var is not None:
        # ΔN = 2·(w⁺·N⁺ − w⁻·N⁻), N = count(end) − count(start), w⁺ = T⁻/(T⁺ + T⁻) (eq. (5))
        t_sum = fwd.duration_s + rev.duration_s
        wp, wm = rev.duration_s / t_sum, fwd.duration_s / t_sum
        # an end is its zero-index event within its bag's mount (remount bags share a clock)
        terms = (((mount_axis, fwd.start_ns), -2.0 * wp, fwd.end_model_var[0]),
                 ((mount_axis, fwd.end_ns), 2.0 * wp, fwd.end_model_var[1]),
                 ((mount_axis, rev.start_ns), 2.0 * wm, rev.end_model_var[0]),
                 ((mount_axis, rev.end_ns), -2.0 * wm, rev.end_model_var[1]))
        # the pair's own u² from the same ends (an end shared by its two windows counted once),
        # so that with the covariance between pairs it is one sum over ends: positive definite
        by_end: dict[tuple[str, int], tuple[float, float, Array]] = {}
        for (stamp, coef, var), sign in zip(terms, (-1.0, 1.0, -1.0, 1.0), strict=True):
            d, s_, _ = by_end.get(stamp, (0.0, 0.0, var))
            by_end[stamp] = (d + coef, s_ + sign / t_sum, var)
        diff_var = sum(d * d * v for d, _, v in by_end.values())
        sum_var = sum(s_ * s_ * v for _, s_, v in by_end.values())
        pair = dataclasses.replace(
            pair, end_terms=tuple((stamp, d, v) for stamp, (d, _, v) in by_end.items()),
            model_difference_std=np.sqrt(np.maximum(diff_var, 0.0)),
            model_sum_rate_std=np.sqrt(np.maximum(sum_var, 0.0)))
    return pair, label
