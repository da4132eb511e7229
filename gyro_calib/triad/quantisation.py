"""The quantisation error of a window's count, from its end fits (METHODS §F.2 eq. (6a)).

The counts are whole pulses: a count at sample k is the angle (in pulses) less its fractional
part, a sawtooth of the count phase, not white noise. At a constant rate the phase advances by a
known amount from sample to sample, so the error the local fit leaves at the instant follows
from the sawtooth's covariance over a uniform start phase (:func:`fitted_count_variance`,
eq. (6a)); :func:`window_quantisation_std` is that of a window's two ends.
:func:`quantisation_floor` is the older, cruder bound (kept for its callers).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import NS_PER_S
from gyro_calib.windows import fit_half_width_ns

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.triad.settings import TriadSettings

    Array = npt.NDArray[np.float64]


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


def sawtooth_covariance(phase_difference_pulses: Array) -> Array:
    """Cov of the rounding errors of two counts whose phases differ by d pulses (eq. (6a)).

    The error frac(x + φ) − ½ of a count over a uniform start phase φ is a sawtooth of
    period 1: E[e(x)·e(x + d)] = 1/12 − f·(1 − f)/2, f = frac(d) (1/12 at d = 0, −1/24 at ½).
    """
    f = phase_difference_pulses - np.floor(phase_difference_pulses)
    return np.asarray(1.0 / 12.0 - 0.5 * f * (1.0 - f), dtype=np.float64)


def fitted_count_variance(t_ns: npt.NDArray[np.int64], counts: Array, instant_ns: int,
                          half_width_ns: int, order: int = 1,
                          rate_pulses_s: float | None = None) -> float:
    """Variance of the local fit's count at an instant from the whole-pulse rounding, pulses².

    The fit (§A eq. (2a), :func:`~gyro_calib.windows.count_at_instant`) over the samples
    within ±``half_width_ns`` gives the count at the instant as Σ w_k·n_k (w the intercept row
    of its least-squares solution); with the count rate ρ (pulses/s) constant over the span,
    the rounding errors of samples j and k have covariance R(ρ·(t_j − t_k))
    (:func:`sawtooth_covariance`):

        u²_end = Σ_jk w_j·w_k·R(ρ·(t_j − t_k))                                          (6a)

    small (~1/L²) when the phase runs through its cycle, up to 1/12 when ρ·period is near a
    whole number (every sample the same fractional part). ρ is ``rate_pulses_s`` or, not
    given, the same fit's slope (its own rounding error moves u²_end: averaged over the window
    ends of the sim_nodes two-axis bench, 0.7–1.8× its value at the true sample phases by
    channel and axis; docs/triad_coverage.md). NaN with fewer than order + 2 samples.
    """
    lo = int(np.searchsorted(t_ns, instant_ns - half_width_ns, 'left'))
    hi = int(np.searchsorted(t_ns, instant_ns + half_width_ns, 'right'))
    if hi - lo < order + 2:
        return math.nan
    x = (t_ns[lo:hi] - instant_ns).astype(np.float64) / NS_PER_S
    y = counts[lo:hi] - counts[lo]
    design = np.vander(x, order + 1, increasing=True)
    solve = np.linalg.pinv(design)  # (order + 1, L): coefficients = solve @ y
    rate = float(solve[1] @ y) if rate_pulses_s is None else rate_pulses_s
    w = solve[0]
    phase = rate * x
    return float(w @ sawtooth_covariance(phase[:, None] - phase[None, :]) @ w)


def end_quantisation_variances(settings: TriadSettings,
                               pulses: tuple[npt.NDArray[np.int64], Array], c: int,
                               start_ns: int, end_ns: int) -> tuple[float, float]:
    """u²_end of a window's start and end count (eq. (6a)), pulses²; NaN: too few samples."""
    t, counts = pulses
    col = np.ascontiguousarray(counts[:, c], dtype=np.float64)
    v = [fitted_count_variance(t, col, at, fit_half_width_ns(settings, at, t),
                               settings.fit_order) for at in (start_ns, end_ns)]
    return v[0], v[1]


def window_quantisation_std(settings: TriadSettings,
                            pulses: tuple[npt.NDArray[np.int64], Array], c: int,
                            start_ns: int, end_ns: int) -> float:
    """The u of a window's count from the rounding at its two end fits (eq. (6a)), pulses.

    The ends are far apart (a turn or more): their rounding errors are independent. Each end's
    fit spans what the cutter's fit spans (:func:`~gyro_calib.windows.fit_half_width_ns`).
    NaN where an end has too few samples.
    """
    return math.sqrt(sum(end_quantisation_variances(settings, pulses, c, start_ns, end_ns)))


def end_floor(settings: TriadSettings, pulses: tuple[npt.NDArray[np.int64], Array], c: int,
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
