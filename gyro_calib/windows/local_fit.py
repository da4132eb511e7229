"""The cumulative pulse count at an instant by a local least-squares fit (METHODS §A.2 eq. (2a)).

:func:`count_at_instant` estimates the count at a zero-index instant from the pulse samples
around it, not by interpolating between the two neighbouring samples: the quantisation error
of the integer counts averages down over the fit span. The same fit gives the encoder angle
at the instant, so both ends of a window are measured alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import WindowError
from gyro_calib.units import NS_PER_S, format_stamp

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class CountAtInstant:
    """Cumulative pulse count at an instant from a local fit.

    Attributes:
        value: count at the instant, pulses.
        std_uncertainty: standard uncertainty from the fit residuals, pulses.
        n_used: pulse samples in the fit.
        rate_pulses_s: fitted count rate at the instant, pulses/s.
        max_residual: largest |residual| of the fit, pulses.
    """

    value: float
    std_uncertainty: float
    n_used: int
    rate_pulses_s: float
    max_residual: float


def count_at_instant(
    t_ns: npt.NDArray[np.int64],
    counts: npt.NDArray[np.float64],
    instant_ns: int,
    *,
    half_width_s: float,
    order: int = 1,
    min_samples_per_side: int = 20,
    max_gap_s: float = 0.01,
    stream: str = 'pulse',
) -> CountAtInstant:
    """Least-squares estimate of the cumulative count at ``instant_ns``.

    Fits counts(t) = c0 + c1·(t − instant) [+ c2·(t − instant)²] to the samples
    within ±``half_width_s`` and returns c0 with its standard uncertainty.

    Args:
        t_ns: sorted sample stamps, int64 ns.
        counts: cumulative pulse counts at those stamps, pulses.
        instant_ns: the instant (zero-index stamp), int ns.
        half_width_s: half-width of the fit span, s.
        order: 1 (line) or 2 (parabola).
        min_samples_per_side: samples required before and after the instant.
        max_gap_s: largest gap between consecutive samples inside the span, s.
        stream: what the samples are, for messages ('pulse', 'joint_states').

    The same fit gives the encoder angle at the instant (``counts`` = angles): both ends of
    a window are then measured alike, so a fit error common to both streams cancels.

    Raises:
        WindowError: too few samples on a side, or a gap in the span.
    """
    half_ns = int(round(half_width_s * NS_PER_S))
    lo = int(np.searchsorted(t_ns, instant_ns - half_ns, side='left'))
    mid = int(np.searchsorted(t_ns, instant_ns, side='left'))
    hi = int(np.searchsorted(t_ns, instant_ns + half_ns, side='right'))
    n_before, n_after = mid - lo, hi - mid
    if min(n_before, n_after) < min_samples_per_side:
        raise WindowError(
            f'only {n_before} {stream} samples before and {n_after} after the zero-index event '
            f'at {format_stamp(instant_ns)} (need {min_samples_per_side} each side within '
            f'±{half_width_s:g} s): gap in the {stream} stream?'
        )
    t_span = t_ns[lo:hi]
    gaps = np.diff(t_span)
    if len(gaps) and gaps.max() > max_gap_s * NS_PER_S:
        raise WindowError(
            f'gap of {gaps.max() / 1e6:.1f} ms in the {stream} stream within ±{half_width_s:g} s '
            f'of the zero-index event at {format_stamp(instant_ns)} '
            f'(limit {max_gap_s * 1e3:g} ms).'
        )
    x = (t_span - instant_ns).astype(np.float64) / NS_PER_S
    y0 = counts[mid] if mid < hi else counts[lo]
    y = counts[lo:hi] - y0
    n = len(x)
    if order == 1:  # the straight line in closed form (the common case, ~10× faster)
        xm, ym = float(x.mean()), float(y.mean())
        dx = x - xm
        sxx = float(dx @ dx)
        slope = float(dx @ (y - ym)) / sxx
        intercept = ym - slope * xm
        residual = y - (intercept + slope * x)
        s2 = float(residual @ residual) / (n - 2)
        value, var0, rate = intercept, s2 * (1.0 / n + xm * xm / sxx), slope
    else:
        design = np.vander(x, order + 1, increasing=True)
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        residual = y - design @ coef
        s2 = float(residual @ residual) / (n - (order + 1))
        var0 = float((s2 * np.linalg.inv(design.T @ design))[0, 0])
        value, rate = float(coef[0]), float(coef[1])
    return CountAtInstant(
        value=value + float(y0),
        std_uncertainty=math.sqrt(var0),
        n_used=n,
        rate_pulses_s=rate,
        max_residual=float(np.max(np.abs(residual))),
    )

