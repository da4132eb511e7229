"""Equivalent degrees of freedom (EDF) of Allan and total variance estimates, and error bars.

Overlapping ADEV: the simple formulas of NIST SP 1065 §5.3 Table 5 (Howe, Allan & Barnes,
1981), for N phase points and averaging factor m, by power-law noise type α (rate
spectrum ∝ f^α)::

    α = +2  white PM (quantisation Q)   (N+1)(N−2m) / (2(N−m))
    α = +1  flicker PM                  exp(√(ln((N−1)/(2m)) · ln((2m+1)(N−1)/4)))
    α =  0  white FM (ARW N)            (3(N−1)/(2m) − 2(N−2)/N) · 4m²/(4m²+5)
    α = −1  flicker FM (bias instab. B) m = 1: 2(N−2)²/(2.3N−4.9);  m ≥ 2: 5N²/(4m(N+3m))
    α = −2  random-walk FM (RRW K)      (N−2)/m · ((N−1)² − 3m(N−1) + 4m²)/(N−3)²

(allantools 2024.6 ``edf_simple`` drops the square in the flicker-FM m = 1 case; SP 1065
has it.) A partial-overlap estimate from the decimation tree is the full-overlap estimate
of the phase subsampled by 2^j, so N and m are those of the subsampled series (exact,
not an approximation). Estimates pooled from several segments (weights n_i, the number of
terms) have EDF = (Σ n_i)² / Σ (n_i²/EDF_i).

Total deviation: NIST SP 1065 §5.3 Table 7, EDF = b·(T/τ) − c with (b, c) = (1.50, 0) white
FM, (1.17, 0.22) flicker FM, (0.93, 0.36) random-walk FM; white PM uses the Table 5 form; at
m = 1 (no reflected term: the overlapping Allan estimator) Greenhall's ADEV EDF (Table 7
claims twice that there, and its ±1σ covered 51 % in ``benchmarks/noise_allan.py`` (c)).

The noise type at each τ is the one whose term dominates the fitted model there (its
local log-log slope μ = d ln AVAR/d ln τ: μ ≤ −1.5 → α = 2, ≤ −0.5 → 0, ≤ 0.5 → −1,
else −2; a rate ramp counts as random-walk FM). Before a fit, white FM is assumed.

An AVAR estimate with ν EDF is distributed as AVAR·χ²_ν/ν, so its standard deviation is
AVAR·√(2/ν) and that of the ADEV is ≈ ADEV/√(2ν) (first order); that is the ``adev_std``
reported.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]

MIN_EDF = 1.0
"""EDF floor: a formula evaluated at its edge (very few terms) never claims less than 1."""


def edf_oadev(n_points: npt.ArrayLike, m: npt.ArrayLike, alpha: npt.ArrayLike) -> FloatArray:
    """EDF of the overlapping Allan variance (NIST SP 1065 Table 5), elementwise.

    Args:
        n_points: phase points N of the (possibly subsampled) series.
        m: averaging factor in that series' samples.
        alpha: noise type α ∈ {2, 1, 0, −1, −2}.
    """
    n, mm, a = np.broadcast_arrays(np.asarray(n_points, dtype=np.float64),
                                   np.asarray(m, dtype=np.float64),
                                   np.asarray(alpha, dtype=np.int64))
    out = np.full(n.shape, MIN_EDF)
    with np.errstate(all='ignore'):
        wpm = (n + 1) * (n - 2 * mm) / (2 * (n - mm))
        fpm = np.exp(np.sqrt(np.log(np.maximum((n - 1) / (2 * mm), 1.0))
                             * np.log(np.maximum((2 * mm + 1) * (n - 1) / 4, 1.0))))
        wfm = (3 * (n - 1) / (2 * mm) - 2 * (n - 2) / n) * 4 * mm**2 / (4 * mm**2 + 5)
        ffm = np.where(mm == 1, 2 * (n - 2) ** 2 / (2.3 * n - 4.9),
                       5 * n**2 / (4 * mm * (n + 3 * mm)))
        rwfm = (n - 2) / mm * ((n - 1) ** 2 - 3 * mm * (n - 1) + 4 * mm**2) / (n - 3) ** 2
    for value, formula in ((2, wpm), (1, fpm), (0, wfm), (-1, ffm), (-2, rwfm)):
        sel = a == value
        out[sel] = formula[sel]
    out = np.where(np.isfinite(out), out, MIN_EDF)
    return np.asarray(np.maximum(out, MIN_EDF), dtype=np.float64)


def edf_totdev(n_points: npt.ArrayLike, m: npt.ArrayLike, alpha: npt.ArrayLike) -> FloatArray:
    """EDF of the total variance (NIST SP 1065 Table 7; white PM from Table 5)."""
    n, mm, a = np.broadcast_arrays(np.asarray(n_points, dtype=np.float64),
                                   np.asarray(m, dtype=np.float64),
                                   np.asarray(alpha, dtype=np.int64))
    b = np.select([a == 0, a == -1, a <= -2], [1.50, 1.17, 0.93], 1.50)
    c = np.select([a == 0, a == -1, a <= -2], [0.0, 0.22, 0.36], 0.0)
    out = b * (n - 1) / mm - c  # T/τ = (N−1)·τ0 / (m·τ0)
    out = np.where(a >= 1, edf_oadev(n, mm, a), out)
    one = mm == 1  # no reflected term at m = 1: the estimator is the overlapping ADEV's
    if np.any(one):
        out = np.where(one, edf_greenhall(n, np.maximum(mm, 1), a), out)
    return np.maximum(out, MIN_EDF)


def pooled_edf(weights: FloatArray, edfs: FloatArray, axis: int = 0) -> FloatArray:
    """EDF of a weighted mean of independent variance estimates: (Σw)²/Σ(w²/ν)."""
    w = np.asarray(weights, dtype=np.float64)
    nu = np.asarray(edfs, dtype=np.float64)
    num = np.sum(w, axis=axis) ** 2
    den = np.sum(np.where(w > 0, w * w / nu, 0.0), axis=axis)
    with np.errstate(divide='ignore', invalid='ignore'):
        return np.where(den > 0, num / den, MIN_EDF)


def alpha_from_slope(slope: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Power-law noise type α from the local AVAR log-log slope μ (see module docstring)."""
    mu = np.asarray(slope, dtype=np.float64)
    return np.select([mu <= -1.5, mu <= -0.5, mu <= 0.5], [2, 0, -1], -2).astype(np.int64)


def adev_std(adev: npt.ArrayLike, edf: npt.ArrayLike) -> FloatArray:
    """Standard deviation of an ADEV estimate with ``edf`` degrees of freedom: σ/√(2ν)."""
    return np.asarray(adev, dtype=np.float64) / np.sqrt(2.0 * np.asarray(edf, dtype=np.float64))


_J_MAX = 100
"""Greenhall's cap on the terms of the basic sum (J_max of [Greenhall & Riley 2004] §4)."""

_TABLE1 = {  # (α, d) -> (a0, a1), modified variances (F = 1), r > d + 1
    (2, 2): (7.0 / 9.0, 1.0 / 2.0), (2, 3): (22.0 / 25.0, 2.0 / 3.0),
    (1, 2): (0.997, 0.616), (1, 3): (1.141, 0.843),
    (0, 2): (1.033, 0.607), (0, 3): (1.184, 0.848),
    (-1, 2): (1.048, 0.534), (-1, 3): (1.180, 0.816),
    (-2, 2): (1.302, 0.535), (-2, 3): (1.175, 0.777),
}
"""Greenhall & Riley 2004 Table 1 (d = 2, 3)."""

_TABLE2 = {  # (α, d) -> (a0, a1), unmodified variances (F = m), r > d + 1
    (2, 2): (35.0 / 18.0, 1.0), (2, 3): (231.0 / 100.0, 3.0 / 2.0),
    (1, 2): (790.0, 410.0), (1, 3): (9950.0, 6520.0),
    (0, 2): (2.0 / 3.0, 1.0 / 3.0), (0, 3): (7.0 / 9.0, 1.0 / 2.0),
    (-1, 2): (0.852, 0.375), (-1, 3): (0.997, 0.617),
    (-2, 2): (1.079, 0.368), (-2, 3): (1.033, 0.607),
}
"""Greenhall & Riley 2004 Table 2 (d = 2, 3)."""

_TABLE3 = {2: (15.23, 12.0), 3: (47.8, 40.0)}
"""Greenhall & Riley 2004 Table 3 (α = 1, unmodified): d -> (b0, b1)."""

_DIFFERENCE = {2: (6.0, (4.0, 1.0)), 3: (20.0, (15.0, 6.0, 1.0))}
"""The d-th difference's weights (eq. 9): the centre, then the pair at lags ±1, ±2, (±3)."""


def _sw(t: float, alpha: int) -> float:
    """Greenhall's generalised autocovariance sw(t) (eq. 7)."""
    if alpha == 2:
        return -abs(t)
    if alpha in (1, -1):
        return 0.0 if t == 0 else pow(t, 3 - alpha) * float(np.log(abs(t)))
    return abs(pow(t, 3 - alpha))  # α = 0: |t|³; α = −2: |t|⁵


def _sx(t: float, f: float, alpha: int) -> float:
    """sx(t) = F²·(2sw(t) − sw(t − 1/F) − sw(t + 1/F)); sw of α + 2 for F = ∞ (eq. 8)."""
    if f == float('inf'):
        return _sw(t, alpha + 2)
    a = 2 * _sw(t, alpha)
    b = _sw(t - 1.0 / float(f), alpha)
    c = _sw(t + 1.0 / float(f), alpha)
    return float(pow(f, 2) * (a - b - c))


def _sz(t: float, f: float, alpha: int, d: int) -> float:
    """sz(t): the d-th difference of sx at unit lags (eq. 9), centre, then lags −k, +k."""
    centre, pairs = _DIFFERENCE[d]
    out = centre * _sx(t, f, alpha)
    for k, w in enumerate(pairs, start=1):
        lo, hi = w * _sx(t - float(k), f, alpha), w * _sx(t + float(k), f, alpha)
        out = out - lo - hi if k % 2 else out + lo + hi
    return out


def _basic_sum(j_terms: float, m_terms: float, s: float, f: float, alpha: int, d: int) -> float:
    """Greenhall's basic sum (eq. 10)."""
    first = pow(_sz(0, f, alpha, d), 2)
    second = (1 - float(j_terms) / float(m_terms)) * pow(
        _sz(float(j_terms) / float(s), f, alpha, d), 2)
    third = 0.0
    for j in range(1, int(j_terms)):
        third += 2 * (1.0 - float(j) / float(m_terms)) * pow(
            _sz(float(j) / float(s), f, alpha, d), 2)
    return first + second + third


def _greenhall_edf(alpha: int, d: int, m: int, n_points: int, modified: bool) -> float:
    """Greenhall's EDF of an overlapping estimator (Greenhall & Riley 2004 §4, eqs. 7–13).

    The arithmetic in ``allantools.edf_greenhall``'s order (so the same float, tested on a
    grid in test/test_noise_edf.py), without its import (scipy.stats and scipy.signal, most
    of ``gyro-calib noise``'s start-up). Raises NotImplementedError for white PM with
    ⌈r⌉ ≤ d, as it does.
    """
    f = 1 if modified else m  # filter factor: 1 modified variance, m unmodified
    s = m  # stride factor: m for the overlapping estimator
    if not alpha + 2 * d > 1.0:
        raise AssertionError('Greenhall needs α + 2d > 1')
    length = m / f + m * d  # length of the filter applied to the phase
    m_terms = 1 + math.floor(s * (n_points - length) / m)
    j_terms = min(m_terms, (d + 1) * s)
    r = m_terms / s
    if f == 1 and modified:  # case 1: modified variances, every α
        if j_terms <= _J_MAX:
            inv = (1.0 / (pow(_sz(0, 1, alpha, d), 2) * m_terms)) * _basic_sum(
                j_terms, m_terms, s, 1, alpha, d)
        elif r > d + 1:
            a0, a1 = _TABLE1[(alpha, d)]
            inv = (1.0 / r) * (a0 - a1 / r)
        else:
            m_prime = _J_MAX / r
            inv = (1.0 / (pow(_sz(0, f, alpha, d), 2) * _J_MAX)) * _basic_sum(
                _J_MAX, _J_MAX, m_prime, 1, alpha, d)
        return 1.0 / inv
    if alpha <= 0:  # case 2: unmodified variances, α ≤ 0
        if j_terms <= _J_MAX:
            f_prime = m if m * (d + 1) <= _J_MAX else float('inf')
            inv = (1.0 / (pow(_sz(0, f_prime, alpha, d), 2) * m_terms)) * _basic_sum(
                j_terms, m_terms, s, f_prime, alpha, d)
        elif r > d + 1:
            a0, a1 = _TABLE2[(alpha, d)]
            inv = (1.0 / r) * (a0 - a1 / r)
        else:
            m_prime = _J_MAX / r
            inv = (1.0 / (pow(_sz(0, float('inf'), alpha, d), 2) * _J_MAX)) * _basic_sum(
                _J_MAX, _J_MAX, m_prime, float('inf'), alpha, d)
        return 1.0 / inv
    if alpha == 1:  # case 3: unmodified variances, flicker PM
        if j_terms <= _J_MAX:
            inv = (1.0 / (pow(_sz(0, m, 1, d), 2) * m_terms)) * _basic_sum(
                j_terms, m_terms, s, m, 1, d)
        else:
            b0, b1 = _TABLE3[d]
            scale = pow(b0 + b1 * float(np.log(m)), 2)
            if r > d + 1:
                a0, a1 = _TABLE2[(alpha, d)]
                inv = (1.0 / (scale * r)) * (a0 - a1 / r)
            else:
                m_prime = _J_MAX / r
                inv = (1.0 / (scale * _J_MAX)) * _basic_sum(_J_MAX, _J_MAX, m_prime, m_prime,
                                                            1, d)
        return 1.0 / inv
    # case 4: unmodified variances, white PM
    if math.ceil(r) <= d:
        raise NotImplementedError('Greenhall white PM with r <= d')
    a0 = math.comb(4 * d, 2 * d) / pow(float(math.comb(2 * d, d)), 2)
    a1 = d / 2.0
    return 1.0 / ((1.0 / m_terms) * (a0 - a1 / r))


@lru_cache(maxsize=65536)
def _greenhall(alpha: int, d: int, m: int, n_points: int, modified: bool) -> float:
    try:
        value = _greenhall_edf(alpha, d, m, n_points, modified)
    except NotImplementedError:
        # Greenhall's white-PM case for r ≤ d (a handful of terms) is not in allantools
        # 2024.6 either: the SP 1065 Table 5 formula there for the Allan variance, the
        # floor otherwise
        if d == 2 and not modified:
            return float(edf_oadev(n_points, m, alpha))
        return MIN_EDF
    except (AssertionError, ValueError, ZeroDivisionError, OverflowError):
        return MIN_EDF
    return value if np.isfinite(value) and value > MIN_EDF else MIN_EDF


def edf_greenhall(n_points: npt.ArrayLike, m: npt.ArrayLike, alpha: npt.ArrayLike, *,
                  d: int = 2, modified: bool = False) -> FloatArray:
    """EDF of an overlapping estimator by Greenhall's algorithm.

    EDF of an overlapping estimator by Greenhall's algorithm (Greenhall & Riley 2004,
    as used by Stable32 and IEEE Std 1139; ``allantools.edf_greenhall``), elementwise.

    Args:
        n_points: phase points N of the (possibly subsampled) series.
        m: averaging factor in that series' samples.
        alpha: noise type α ∈ {2, 1, 0, −1, −2}.
        d: 2 for the Allan and modified Allan variance, 3 for the Hadamard variance.
        modified: the modified Allan variance.

    Returns:
        EDF (at least :data:`MIN_EDF`; MIN_EDF where the estimator has no term).
    """
    n, mm, a = np.broadcast_arrays(np.asarray(n_points, dtype=np.float64),
                                   np.asarray(m, dtype=np.float64),
                                   np.asarray(alpha, dtype=np.int64))
    out = np.full(n.shape, MIN_EDF)
    for idx in np.ndindex(n.shape):
        nn, m_i = int(n[idx]), int(mm[idx])
        if m_i >= 1 and nn - d * m_i >= 1:
            out[idx] = _greenhall(int(a[idx]), d, m_i, nn, modified)
    return out
