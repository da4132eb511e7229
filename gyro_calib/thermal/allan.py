"""Bias stability, a small overlapping Allan deviation, and the noise floor of a record.

Kept inside the thermal method on purpose (the full noise method is another
subpackage; methods do not import each other).

- Bias stability (METHODS §E, GJB practice): standard deviation of the means of
  consecutive blocks of ``block_s`` (100 s), computed from the raw pulses: each block's
  mean is K·ΣΔN/ΣΔt over its intervals, so nothing is filtered.
- Overlapping Allan deviation of a rate series sampled every τ₀ (IEEE Std 952 / NIST
  SP 1065 eq. 6, rate form): σ²(mτ₀) = ⟨(ȳ_{k+m} − ȳ_k)²⟩/2 over all overlapping pairs
  of m-sample means.
- Noise floor: the bias stability white rate noise and pulse quantisation alone would
  give for T-s block means: floor² = N²/T + 2Q²/T² (a block mean's quantisation error is
  the difference of two phase errors of variance Q² each, divided by T; Q = K/√12 once
  the sub-pulse phase is randomised between block edges by the rate and its noise — a
  simulation check in ``test/test_thermal_compensate.py`` finds the empirical std of
  100 s means within a few % of this). N comes from a weighted non-negative fit of
  σ²(τ) − 3Q²/τ² = N²/τ + B² + K²τ/3 to the overlapping Allan variance for
  10τ₀ ≤ τ ≤ T (B², K² absorb bias instability and drift). The shortest τ are left out:
  there the fractional phase of a gyro at nearly constant rate follows a quasi-periodic
  pattern and the Allan variance departs from the white-phase 3Q²/τ² by ±20 %. The
  compensated bias stability cannot honestly go below this floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Estimate
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    import numpy.typing as npt


def block_means(dcount_or_rate: npt.NDArray[np.float64], dt_ns: npt.NDArray[np.int64], *,
                intervals_per_block: int, scale: float = 1.0,
                min_fraction: float = 0.9) -> npt.NDArray[np.float64]:
    """Means of consecutive blocks of ``intervals_per_block`` intervals.

    Each block's mean is scale·Σ x_i / Σ Δt_i over its valid intervals (x = ΔN with scale K
    gives the exact mean rate of the raw pulses; x = rate·Δt with scale 1 likewise).
    Blocks with less than ``min_fraction`` of their intervals valid are NaN.
    """
    n_blocks = len(dt_ns) // intervals_per_block
    m = n_blocks * intervals_per_block
    x = np.asarray(dcount_or_rate[:m], np.float64).reshape(n_blocks, intervals_per_block)
    dt = np.asarray(dt_ns[:m], np.float64).reshape(n_blocks, intervals_per_block) / NS_PER_S
    ok = np.isfinite(x) & (dt > 0)
    num = np.where(ok, x, 0.0).sum(axis=1)
    den = np.where(ok, dt, 0.0).sum(axis=1)
    full = ok.sum(axis=1) >= min_fraction * intervals_per_block
    with np.errstate(invalid='ignore', divide='ignore'):
        return np.where(full & (den > 0), scale * num / den, np.nan)


def bias_stability(means: npt.NDArray[np.float64]) -> Estimate:
    """Std (ddof 1) of block means, with the χ² standard uncertainty s/√(2(n−1)).

    The uncertainty treats the blocks as independent; where a trend dominates (raw rate
    in a chamber run) the figure describes the spread, not a noise process.
    """
    m = np.asarray(means, np.float64)
    m = m[np.isfinite(m)]
    n = len(m)
    if n < 2:
        return Estimate(math.nan, math.nan, n, 0)
    s = float(np.std(m, ddof=1))
    return Estimate(s, s / math.sqrt(2.0 * (n - 1)), n, n - 1)


def overlapping_adev(rate: npt.NDArray[np.float64], tau0_s: float,
                     m_list: npt.NDArray[np.int64] | None = None
                     ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64],
                                npt.NDArray[np.int64]]:
    """Overlapping Allan deviation of a uniformly sampled rate (NaN-free) series.

    Returns:
        (τ in s, σ(τ) in the rate's unit, number of overlapping differences per τ).
    """
    y = np.asarray(rate, np.float64)
    n = len(y)
    if m_list is None:
        top = max(1, n // 4)
        m_list = np.unique(np.round(np.logspace(0, math.log10(top), 30)).astype(np.int64))
    cs = np.concatenate(([0.0], np.cumsum(y)))
    taus, devs, counts = [], [], []
    for m in np.asarray(m_list, np.int64):
        if 2 * m > n:
            break
        means = (cs[m:] - cs[:-m]) / m  # all m-sample means, overlapping
        d = means[m:] - means[:-m]
        taus.append(m * tau0_s)
        devs.append(math.sqrt(0.5 * float(np.mean(d * d))))
        counts.append(len(d))
    return np.array(taus), np.array(devs), np.array(counts, np.int64)


@dataclass(frozen=True, slots=True)
class NoiseFloor:
    """White-noise terms of a record and the bias-stability floor they imply.

    Attributes:
        quantisation_rad: Q, rad (angle quantisation noise; K/√12 for a randomised phase).
        angle_random_walk_rad_per_sqrt_s: N.
        floor: the block-mean std white noise and quantisation give (Estimate, rad/s).
        block_s: T of the blocks, s.
    """

    quantisation_rad: float
    angle_random_walk_rad_per_sqrt_s: float
    floor: Estimate
    block_s: float


def noise_floor(rate: npt.NDArray[np.float64], tau0_s: float, block_s: float, *,
                quantisation_rad: float | None = None, min_tau_s: float = 0.0) -> NoiseFloor:
    """Fit N (and Q) to the Allan variance for τ ≤ block_s; the floor for block_s means.

    Args:
        rate: uniformly sampled rate, rad/s (NaNs dropped).
        tau0_s: its sampling interval, s.
        block_s: T of the blocks, s.
        quantisation_rad: Q if known (K/√12 for a pulse gyro whose phase moves); then only
            N, B, K are fitted. Fitting Q and N together is poorly conditioned where both
            matter over the same τ.
        min_tau_s: the shortest τ fitted, s (0: from τ0 on).

    The fit is weighted by the Allan variance's own relative uncertainty (≈ 1/√(n/m)); the
    floor's uncertainty is propagated from that of N² (and Q² when fitted) — approximate,
    as overlapping Allan variances at neighbouring τ are correlated.
    """
    y = np.asarray(rate, np.float64)
    y = y[np.isfinite(y)]
    top = max(1, int(block_s / tau0_s))
    m_list = np.unique(np.round(np.logspace(0, math.log10(max(top, 1)), 24)).astype(np.int64))
    tau, dev, cnt = overlapping_adev(y, tau0_s, m_list)
    keep = tau >= min_tau_s
    tau, dev, cnt = tau[keep], dev[keep], cnt[keep]
    if len(tau) < 5:
        return NoiseFloor(math.nan, math.nan, Estimate(math.nan, math.nan, len(y), 0), block_s)
    avar = dev**2
    rel = 1.0 / np.sqrt(np.maximum(cnt / np.maximum(tau / tau0_s, 1.0), 1.0))
    w = 1.0 / (avar * rel)
    basis = [3.0 / tau**2, 1.0 / tau, np.ones_like(tau), tau / 3.0]
    target = avar.copy()
    if quantisation_rad is not None:
        target = target - 3.0 * quantisation_rad**2 / tau**2
        basis = basis[1:]
    a = np.column_stack(basis) * w[:, None]
    from scipy.optimize import nnls  # imported on use: scipy.optimize costs ~1 s to import

    coef, _ = nnls(a, target * w)
    if quantisation_rad is None:
        q2, n2 = float(coef[0]), float(coef[1])
        g = np.array([2.0 / block_s**2, 1.0 / block_s, 0.0, 0.0])
    else:
        q2, n2 = quantisation_rad**2, float(coef[0])
        g = np.array([1.0 / block_s, 0.0, 0.0])
    floor2 = n2 / block_s + 2.0 * q2 / block_s**2
    dof = len(tau) - a.shape[1]
    try:
        cov = np.linalg.inv(a.T @ a) * float(np.sum((a @ coef - target * w) ** 2)) / max(dof, 1)
        var_f2 = float(g @ cov @ g)
        std = 0.5 * math.sqrt(max(var_f2, 0.0)) / math.sqrt(floor2) if floor2 > 0 else math.nan
    except np.linalg.LinAlgError:
        std = math.nan
    return NoiseFloor(math.sqrt(q2), math.sqrt(n2),
                      Estimate(math.sqrt(floor2), std, len(y), max(dof, 0)), block_s)


def allan_long_run_variance(residuals: npt.NDArray[np.float64],
                            max_rows: int) -> tuple[float, int]:
    """Long-run variance of a residual series from its Allan variance.

    Long-run variance of a residual series from its Allan variance (see
    :mod:`gyro_calib.thermal.regression` for why not a lag-window/HAC estimate).

    m·σ²_A(m) is evaluated at the octaves m = 1, 2, 4 … ≤ ``max_rows`` (and ≤ n/3); the
    estimate is its largest value over the top three octaves. Short averaging times are
    left out on purpose: pulse quantisation is a differenced (blue) noise whose m·σ²_A(m)
    is largest at m = 1 but whose long-run variance is zero; a rising curve (correlated
    noise, slow misfit) is read where it is highest.

    Returns:
        (the long-run variance, the m where it was read).
    """
    r = np.asarray(residuals, np.float64)
    r = r - r.mean()
    cs = np.concatenate(([0.0], np.cumsum(r)))
    values: list[tuple[float, int]] = []
    m = 1
    while m <= max(max_rows, 1) and 3 * m <= len(r):
        means = (cs[m:] - cs[:-m]) / m
        d = means[m:] - means[:-m]
        values.append((m * 0.5 * float(np.mean(d * d)), m))
        m *= 2
    if not values:
        return float(np.mean(r * r)), 1
    return max(values[-3:])
