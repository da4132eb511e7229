"""The cumulative pulse count at an instant by a local least-squares fit (METHODS §A.2 eq. (2a)).

:func:`count_at_instant` estimates the count at a zero-index instant from the pulse samples
around it, not by interpolating between the two neighbouring samples: the quantisation error
of the integer counts averages down over the fit span. The same fit gives the encoder angle
at the instant, so both ends of a window are measured alike.

Whole-pulse counts are not white noise: each sample's error is the sawtooth of the count's
phase, which advances by the count rate × the sample period. When that advance is near a
whole number of pulses (or a simple fraction) the phase drifts slowly across the fit span and
the errors do not average down: up to ±½ pulse at the instant however many samples there
are, with fit residuals near zero. :func:`quantisation_variance` is the exact variance of
the fitted value over the unknown phase (eq. (2b)); the stated uncertainty is never below it.
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


def quantisation_variance(x_s: npt.NDArray[np.float64], weights: npt.NDArray[np.float64],
                          rate_per_s: float, quantum: float) -> float:
    """Variance of a fitted Σ wᵢ·yᵢ of quantised samples over the phase (METHODS §A.2 eq. 2b).

    Sample i is a value rising at ``rate_per_s`` seen through steps of ``quantum``; its error
    is the sawtooth of the phase uᵢ = frac(rate·xᵢ/quantum + φ). Over a uniform unknown φ
    the sawtooth's autocorrelation is ½·B₂(frac(uᵢ − uⱼ)) quantum² (B₂(u) = u² − u + 1/6,
    the Bernoulli polynomial), and for |d| < 1, B₂(frac d) = d² − |d| + 1/6, so

        var = ½·quantum²·(2·S₀S₂ − 2·S₁² − Σᵢⱼ wᵢwⱼ|uᵢ − uⱼ| + S₀²/6),   Sₖ = Σ wᵢ·uᵢᵏ

    exact for any stamps, in O(n log n). 1/12 quantum² (one whole step) when every uᵢ is
    equal; ≈ Σwᵢ²/12 quantum² (white) when the phases spread evenly.
    """
    u = np.mod(rate_per_s * x_s / quantum, 1.0)
    order = np.argsort(u, kind='stable')
    u, w = u[order], weights[order]
    s0, s1, s2 = float(w.sum()), float(w @ u), float(w @ (u * u))
    below_w = np.cumsum(w) - w  # Σ wⱼ over uⱼ below uᵢ
    below_wu = np.cumsum(w * u) - w * u
    spread = 2.0 * float(w @ (u * below_w - below_wu))  # Σᵢⱼ wᵢwⱼ|uᵢ − uⱼ|
    var = 0.5 * (2.0 * s0 * s2 - 2.0 * s1 * s1 - spread + s0 * s0 / 6.0)
    return max(var, 0.0) * quantum * quantum


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
    quantum: float = 0.0,
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
        quantum: the step of the values (1 for whole pulses); when every value in the span
            is a multiple of it, the uncertainty is at least the quantisation variance of the
            fit (:func:`quantisation_variance`, eq. (2b)). 0: values taken as unquantised.

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
        weights = 1.0 / n - xm * dx / sxx  # the intercept as Σ wᵢ·yᵢ
    else:
        design = np.vander(x, order + 1, increasing=True)
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        residual = y - design @ coef
        s2 = float(residual @ residual) / (n - (order + 1))
        var0 = float((s2 * np.linalg.inv(design.T @ design))[0, 0])
        value, rate = float(coef[0]), float(coef[1])
        weights = np.linalg.solve(design.T @ design, design.T)[0]
    if quantum > 0.0 and np.all(np.mod(y / quantum, 1.0) == 0.0):
        var0 = max(var0, quantisation_variance(x, weights, rate, quantum))
    return CountAtInstant(
        value=value + float(y0),
        std_uncertainty=math.sqrt(var0),
        n_used=n,
        rate_pulses_s=rate,
        max_residual=float(np.max(np.abs(residual))),
    )

