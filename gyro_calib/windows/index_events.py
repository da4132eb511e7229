"""The table and the gyro at one zero-index event (METHODS §A.2 eq. (2a)).

:func:`resolve_index_event` states an event: encoder angle and pulse count by the same local
fit (:func:`~gyro_calib.windows.local_fit.count_at_instant`), the table rate and how much it
varies over the fit span, or why the count could not be measured. The fit span is widened
for a slow pulse stream (:func:`fit_half_width_ns`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.errors import WindowError
from gyro_calib.units import NS_PER_S, format_stamp
from gyro_calib.windows.local_fit import CountAtInstant, count_at_instant

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.windows.settings import WindowSettings


MAX_FIT_HALF_WIDTH_S = 2.0
"""Widest fit span half-width around an index event, whatever the pulse stream's rate, s."""


@dataclass(frozen=True, slots=True)
class IndexEvent:
    """A zero-index event with the table and gyro state at its instant.

    Attributes:
        stamp_ns: event stamp, int ns.
        encoder_angle_rad: encoder angle at the stamp (local fit, as the count), rad; NaN if
            unknown.
        rate_rad_s: table rate at the stamp, rad/s; NaN if unknown.
        count: pulse count at the stamp, or None when it could not be measured.
        problem: why ``count`` is None (or the event is unusable), else ''.
        angle_std_rad: standard uncertainty of ``encoder_angle_rad`` from its fit, rad.
        rate_spread: largest relative deviation of the table rate from ``rate_rad_s`` within
            the fit span (0 at constant rate); above ``rate_tolerance`` the table was
            accelerating at the event.
        half_width_ns: half-width of the fit span actually used around the event, ns.
    """

    stamp_ns: int
    encoder_angle_rad: float
    rate_rad_s: float
    count: CountAtInstant | None
    problem: str = ''
    angle_std_rad: float = 0.0
    rate_spread: float = 0.0
    half_width_ns: int = 0



def period_near(t_ns: npt.NDArray[np.int64], t_event: int, half_ns: int) -> float:
    """Median sample period near an event, ns.

    Median sample period (the upper median for an even count) of the stamps within
    ±``half_ns`` of ``t_event`` (0 if fewer than 2), ns.
    """
    lo = int(np.searchsorted(t_ns, t_event - half_ns, 'left'))
    hi = int(np.searchsorted(t_ns, t_event + half_ns, 'right'))
    if hi - lo < 2:
        return 0.0
    d = np.diff(t_ns[lo:hi])
    k = len(d) // 2
    return float(np.partition(d, k)[k])


def fit_half_width_ns(cfg: WindowSettings, t_event: int, p_t: npt.NDArray[np.int64],
                      period_ns: float | None = None) -> int:
    """Half-width of the fits around an event.

    Half-width of the fits around an event: ``fit_half_width_s``, widened so that a
    slow pulse stream still gives ``min_fit_samples_per_side`` samples each side (its
    period read from the samples within ±``fit_half_width_s``), at most MAX_FIT_HALF_WIDTH_S.
    """
    half_ns = int(cfg.fit_half_width_s * NS_PER_S)
    period = period_near(p_t, t_event, half_ns) if period_ns is None else period_ns
    if period <= 0:
        return half_ns
    need = int((cfg.min_fit_samples_per_side + 1) * period * 1.02)
    return max(half_ns, min(need, int(MAX_FIT_HALF_WIDTH_S * NS_PER_S)))


def resolve_index_event(cfg: WindowSettings, t_event: int, p_t: npt.NDArray[np.int64],
                        counts: npt.NDArray[np.float64], s_t: npt.NDArray[np.int64],
                        s_v: npt.NDArray[np.float64]) -> IndexEvent:
    """The table and the gyro at an event (METHODS §A.2 eq. (2a)).

    The table and the gyro at an event: encoder angle and pulse count by the same
    local fit, the table rate and how much it varies over the fit span. ``s_v`` holds the
    encoder angle (rad) and rate (rad/s) as columns.
    """
    nominal_ns = int(cfg.fit_half_width_s * NS_PER_S)
    pulse_period = period_near(p_t, t_event, nominal_ns)
    half_ns = fit_half_width_ns(cfg, t_event, p_t, pulse_period)
    if half_ns != nominal_ns:
        pulse_period = period_near(p_t, t_event, half_ns)
    half_s = half_ns / NS_PER_S
    angle = rate = math.nan
    angle_std = spread = 0.0
    if len(s_t) >= 2 and s_t[0] <= t_event <= s_t[-1]:
        x = (s_t - t_event).astype(np.float64)
        rate = float(np.interp(0.0, x, s_v[:, 1]))
        angle = float(np.interp(0.0, x, s_v[:, 0]))
        sl = slice(int(np.searchsorted(s_t, t_event - half_ns, 'left')),
                   int(np.searchsorted(s_t, t_event + half_ns, 'right')))
        near = s_v[sl, 1]
        if len(near) and rate != 0.0:
            spread = float(np.max(np.abs(near - rate))) / abs(rate)
        table_gap_s = max(cfg.max_fit_gap_s, 2.5 * period_near(s_t, t_event, half_ns)
                          / NS_PER_S)
        try:
            fit = count_at_instant(s_t, s_v[:, 0], t_event, half_width_s=half_s,
                                   order=cfg.fit_order, min_samples_per_side=cfg.fit_order + 1,
                                   max_gap_s=table_gap_s, stream='joint_states')
        except WindowError:
            pass  # too few encoder samples for a fit: the interpolated angle stands
        else:
            angle, angle_std = fit.value, fit.std_uncertainty
    pulse_gap_s = max(cfg.max_fit_gap_s, 2.5 * pulse_period / NS_PER_S)
    state: dict[str, Any] = dict(angle_std_rad=angle_std, rate_spread=spread,
                                 half_width_ns=half_ns)
    try:
        count = count_at_instant(
            p_t, counts, t_event, half_width_s=half_s, order=cfg.fit_order,
            min_samples_per_side=cfg.min_fit_samples_per_side, max_gap_s=pulse_gap_s,
            quantum=1.0)  # whole pulses: their quantisation floor (eq. (2b))
    except WindowError as exc:
        return IndexEvent(t_event, angle, rate, None, str(exc), **state)
    if count.max_residual > cfg.max_fit_residual_pulses:
        return IndexEvent(t_event, angle, rate, None, (
            f'pulse counts around the zero-index event at {format_stamp(t_event)} deviate '
            f'from a smooth fit by up to {count.max_residual:.1f} pulses (limit '
            f'{cfg.max_fit_residual_pulses:g}) while the table rate held within '
            f'{spread * 100:.3f} %: a count glitch, or gyro rate ripple too fast for '
            f'fit_order={cfg.fit_order} over ±{half_s:g} s.'), **state)
    return IndexEvent(t_event, angle, rate, count, **state)
