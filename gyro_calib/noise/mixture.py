"""Error bars for a mixture of noise types: the EDF blended by each type's share (§E.2).

An Allan-family estimate at one τ rarely sees one power-law noise type alone: on a dithered
RLG quantisation (white PM) and angle random walk (white FM) share the mid-τ range, on a
MEMS gyro white FM and flicker FM share the plateau. Reading one "noise type" per τ and
using its EDF switches the error bar by up to 7× between neighbouring τ and from seed to
seed where two types are comparable. Here the variance of the estimate is that of the
mixture ([NIST SP 1065] §5.3 assumes one type; the mixture follows from it). With u the
statistic's phase combination and independent Gaussian noise terms T (Q, N, B, K),
u = Σ_T u_T, and for an estimate V̂ = mean of u²::

    Var(V̂) = Σ_T Σ_U ρ_TU·√(Var_T·Var_U),   Var_T = 2·V_T²/ν_T                        (E.6a)
    2/ν = Var(V̂)/V² = Σ_T Σ_U f_T·f_U·ρ_TU·√((2/ν_T)(2/ν_U)),   f_T = V_T/V            (E.6b)

ν_T is the EDF of type T alone (Greenhall's algorithm, exact for the record's N and m),
f_T its share of the statistic at that τ (the rate ramp R adds its share to V and no
variance), and ρ_TU = Σ_d γ_T(d)γ_U(d)/√(Σγ_T²·Σγ_U²) the correlation of the types'
contributions from their generalised covariances (:func:`gyro_calib.noise.covariance.
pair_basis`, the Allan variance's lags; used for every statistic). One type alone gives its
own ν; the blend moves continuously with the shares, so no hard switch between τ.

Shares come from the fitted model (:mod:`gyro_calib.noise.fit`) at every τ of the curve,
each term's expected statistic from the same generalised covariances (exact for sampled
data: ADEV gives back 3Q²/τ², N²/τ, (2 ln 2/π)B², K²τ/3). Without a model (no fit, or a
model with no random term) the curve's own local log-log slope μ splits the τ between the
two types whose slopes bracket it (μ = the share-weighted mean slope).

Quantisation of a pulse count (an RLG's ``/gyro/pulses``): the rounding error to whole
pulses is uniform, not Gaussian (excess kurtosis κ = −6/5), and the estimate of its white-PM
variance scatters less. A term Σ_k c_k·x_k of i.i.d. phase noise gives, for a long record,
Var(mean of terms²) ∝ 2·Σ_d r(d)² + κ·(Σ_k c_k²)² with r the autocorrelation of c, so ν_Q
grows by 2Σr²/(2Σr² + κ(Σc²)²): ADEV (c = 1, −2, 1) 140/96.8 = 1.446, HDEV 1848/1368 = 1.351,
MDEV 1.446 at m = 1 falling towards 1 (its terms average m points).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.noise.covariance import TAU0_POWER, pair_basis

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.noise.curve import AllanCurve

    FloatArray = npt.NDArray[np.float64]

TERM_ALPHA = (2, 0, -1, -2, -2)
"""Noise type α of each term Q, N, B, K, R (a rate ramp reads as random-walk FM)."""
SLOPES = (-2.0, -1.0, 0.0, 1.0)
"""AVAR log-log slope of Q, N, B, K."""
STATISTICS = ('adev', 'mdev', 'hdev', 'totdev')

_LAMBDA = {'adev': (1.0, -2.0, 1.0), 'hdev': (-1.0, 3.0, -3.0, 1.0)}
UNIFORM_EXCESS_KURTOSIS = -1.2
"""Excess kurtosis of a uniform distribution (rounding to whole pulses)."""
MDEV_EXACT_M = 4096
"""Beyond this averaging factor the MDEV/ADEV ratio of N, B and K is taken as at it (the
ratios have converged to 1e-4; Q's 1/m is exact): the lag sum costs O(m)."""


def _kernels(t: FloatArray) -> FloatArray:
    """Unit generalised covariances of Q, N, B, K at lags t (4 × len(t)), τ0 = 1."""
    a = np.abs(t)
    pos = a > 0
    logs = np.log(np.where(pos, a, 1.0))
    return np.stack((np.where(a == 0, 1.0, 0.0), -0.5 * a,
                     np.where(pos, t * t * logs / (2.0 * math.pi), 0.0), a**3 / 12.0))


@lru_cache(maxsize=4096)
def unit_term_variances(statistic: str, m: int) -> tuple[float, float, float, float, float]:
    """Expected statistic of unit terms Q, N, B, K, R at averaging factor m (τ0 = 1).

    The statistic (AVAR, MVAR, HVAR; TOTVAR as AVAR) of Q = N = B = K = R = 1 with phase
    sampled at τ0 = 1; :func:`term_variances` scales them. From the generalised covariances
    (covariance.py): E[u²] = Σ_pq w_p·w_q·K((p − q)·m) for ADEV (w = 1, −2, 1) and HDEV
    (w = −1, 3, −3, 1), E[(Σ_{j<m} u_j)²] = Σ_d (m − |d|)·γ(d) for MDEV; the ramp's
    second differences are constant (R²τ²/2 for ADEV and MDEV, 0 for HDEV).
    """
    mf = float(m)
    if statistic == 'mdev' and m > MDEV_EXACT_M:
        far = np.asarray(unit_term_variances('mdev', MDEV_EXACT_M))
        ratio = far / np.asarray(unit_term_variances('adev', MDEV_EXACT_M))
        ratio[0] = 1.0 / mf
        out = np.asarray(unit_term_variances('adev', m)) * np.nan_to_num(ratio, nan=1.0)
        return float(out[0]), float(out[1]), float(out[2]), float(out[3]), float(out[4])
    if statistic == 'mdev':
        w = np.asarray(_LAMBDA['adev'])
        d = np.arange(-(m - 1), m, dtype=np.float64)
        gamma = np.zeros((4, len(d)))
        for p in range(3):
            for q in range(3):
                gamma += w[p] * w[q] * _kernels(d + (q - p) * mf)
        e = gamma @ (mf - np.abs(d))
        var = e / (2.0 * mf**4)
        ramp = 0.5 * mf**2
    else:
        w = np.asarray(_LAMBDA['hdev' if statistic == 'hdev' else 'adev'])
        idx = np.arange(len(w), dtype=np.float64)
        lags = (idx[:, None] - idx[None, :]).ravel() * mf
        weights = (w[:, None] * w[None, :]).ravel()
        e = _kernels(lags) @ weights
        var = e / ((6.0 if statistic == 'hdev' else 2.0) * mf**2)
        ramp = 0.0 if statistic == 'hdev' else 0.5 * mf**2
    v = np.maximum(var, 0.0)
    return float(v[0]), float(v[1]), float(v[2]), float(v[3]), ramp


def term_variances(statistic: str, m: npt.ArrayLike, tau0_s: float,
                   theta: npt.ArrayLike) -> FloatArray:
    """Each term's expected statistic at averaging factors m (len(m) × 5), rate unit².

    Args:
        statistic: 'adev', 'mdev', 'hdev' or 'totdev' (as the ADEV).
        m: averaging factors.
        tau0_s: sample period, s.
        theta: (Q², N², B², K², R²) of the noise model.
    """
    stat = 'adev' if statistic == 'totdev' else statistic
    th = np.asarray(theta, dtype=np.float64)
    scale = np.append(th[:4] * float(tau0_s) ** TAU0_POWER / float(tau0_s) ** 2,
                      th[4] * float(tau0_s) ** 2)
    unit = np.array([unit_term_variances(stat, int(v)) for v in np.asarray(m).ravel()])
    return np.asarray(unit.reshape(-1, 5) * scale[None, :], dtype=np.float64)


def model_shares(statistic: str, m: npt.ArrayLike, tau0_s: float,
                 theta: npt.ArrayLike) -> FloatArray | None:
    """Share of each term Q, N, B, K, R in the statistic at each m (rows sum to 1).

    None where the model has no random term (then :func:`slope_shares`).
    """
    th = np.asarray(theta, dtype=np.float64)
    if not np.any(th[:4] > 0):
        return None
    parts = term_variances(statistic, m, tau0_s, th)
    total = parts.sum(axis=1)
    if not np.all(total > 0):
        return None
    return np.asarray(parts / total[:, None], dtype=np.float64)


def slope_shares(tau_s: npt.ArrayLike, variance: npt.ArrayLike) -> FloatArray:
    """Shares Q, N, B, K, R (R = 0) from the curve's local log-log slope μ (len × 5).

    μ (central differences; one-sided at the ends) is split between the two terms whose
    slopes bracket it, clipped to [−2, 1]; a τ without a usable slope counts as white FM.
    """
    tau = np.asarray(tau_s, dtype=np.float64)
    var = np.asarray(variance, dtype=np.float64)
    n = len(tau)
    mu = np.full(n, -1.0)
    if n >= 2:
        with np.errstate(invalid='ignore', divide='ignore'):
            lv = np.log(np.where(var > 0, var, np.nan))
            mu = np.gradient(lv, np.log(tau))
        mu = np.where(np.isfinite(mu), mu, -1.0)
    mu = np.clip(mu, SLOPES[0], SLOPES[-1])
    lower = np.clip(np.floor(mu - SLOPES[0]).astype(np.int64), 0, len(SLOPES) - 2)
    upper_share = mu - np.asarray(SLOPES)[lower]
    out = np.zeros((n, 5))
    rows = np.arange(n)
    out[rows, lower] = 1.0 - upper_share
    out[rows, lower + 1] += upper_share
    return out


def dominant_alpha(shares: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Noise type α of the term with the largest share at each τ (``noise_alpha``)."""
    s = np.asarray(shares, dtype=np.float64)
    return np.asarray(np.asarray(TERM_ALPHA)[np.argmax(s, axis=1)], dtype=np.int64)


@lru_cache(maxsize=4096)
def type_correlation(m: int) -> tuple[tuple[float, ...], ...]:
    """ρ_TU of (E.6) between the contributions of Q, N, B, K at averaging factor m (4 × 4)."""
    g = np.asarray(pair_basis(m, m))
    d = np.sqrt(np.clip(np.diag(g), 0.0, None))
    with np.errstate(invalid='ignore', divide='ignore'):
        rho = np.where(np.outer(d, d) > 0, g / np.outer(d, d), 0.0)
    rho = np.clip(rho, -1.0, 1.0)
    np.fill_diagonal(rho, 1.0)
    return tuple(tuple(float(v) for v in row) for row in rho)


@lru_cache(maxsize=4096)
def _uniform_factor(statistic: str, m: int) -> float:
    if statistic == 'mdev' and m > MDEV_EXACT_M:
        return _uniform_factor('mdev', MDEV_EXACT_M)
    if statistic == 'mdev':
        c = np.repeat(np.asarray(_LAMBDA['adev']), m)  # Σ_{j<m} of second differences
    else:
        # c holds the weights every m samples, zeros between: its autocorrelation is the
        # weights' at the lags q·m and 0 elsewhere, so Σr² and Σc² are the weights' own (the
        # same whole numbers, exact in floats, for every m: O(1), not the O(m²) correlation
        # of the spread-out c, which took most of a long record's run)
        c = np.asarray(_LAMBDA['hdev' if statistic == 'hdev' else 'adev'])
    r = np.correlate(c, c, mode='full')
    gaussian = 2.0 * float(r @ r)
    return gaussian / (gaussian + UNIFORM_EXCESS_KURTOSIS * float(c @ c) ** 2)


def uniform_quantisation_factor(statistic: str, m: npt.ArrayLike) -> FloatArray:
    """ν_Q(uniform rounding)/ν_Q(Gaussian white PM) of a statistic at m (module doc).

    For a statistic whose terms are Σ_k c_k·x_k of i.i.d. phase noise with excess kurtosis
    κ: Var(mean of terms²) ∝ 2·Σ_d r(d)² + κ·(Σ c_k²)², r the autocorrelation of c (long
    records); ADEV 140/96.8 = 1.446, HDEV 1848/1368 = 1.351, MDEV from 1.446 at m = 1 towards
    1 as m grows (TOTDEV as ADEV).
    """
    stat = 'adev' if statistic == 'totdev' else statistic
    return np.array([_uniform_factor(stat, max(int(v), 1)) for v in np.asarray(m).ravel()])


def blended_edf(shares: npt.ArrayLike, pure_edf: npt.ArrayLike,
                m: npt.ArrayLike) -> FloatArray:
    """EDF of a mixture, (E.6b).

    Args:
        shares: (len × 5) shares of Q, N, B, K, R in the statistic.
        pure_edf: (4 × len) EDF of the statistic for white PM, white FM, flicker FM and
            random-walk FM alone (α = 2, 0, −1, −2).
        m: averaging factor at each τ (for ρ_TU).

    Returns:
        ν at each τ (a ramp-only τ: the largest pure EDF).
    """
    f = np.asarray(shares, dtype=np.float64)[:, :4]
    nu = np.asarray(pure_edf, dtype=np.float64)
    out = np.empty(f.shape[0])
    for k, mk in enumerate(np.asarray(m).ravel()):
        a = f[k] * np.sqrt(2.0 / nu[:, k])
        rel = float(a @ np.asarray(type_correlation(int(mk))) @ a)
        out[k] = 2.0 / rel if rel > 0 else float(np.max(nu[:, k]))
    return out


def pure_rows(curve: AllanCurve, statistic: str = 'adev') -> FloatArray:
    """The curve's pure-type EDF rows for α = 2, 0, −1, −2 (4 × len) of one statistic."""
    from gyro_calib.noise.curve import ALPHAS

    table = curve.edf_by_alpha if statistic == 'adev' else curve.others[statistic][2]
    return np.asarray(table[[ALPHAS.index(a) for a in TERM_ALPHA[:4]]], dtype=np.float64)


def curve_edf(curve: AllanCurve, shares: npt.ArrayLike, statistic: str = 'adev', *,
              uniform_quantisation: bool = False) -> FloatArray:
    """Blended EDF of one statistic of the curve at each τ (E.6b).

    ``uniform_quantisation``: Q is the rounding of a pulse count (ν_Q raised by
    :func:`uniform_quantisation_factor`; module docstring).
    """
    rows = pure_rows(curve, statistic).copy()
    if uniform_quantisation:
        rows[0] = rows[0] * uniform_quantisation_factor(statistic, curve.m)
    return blended_edf(shares, rows, curve.m)


def curve_shares(curve: AllanCurve, theta: npt.ArrayLike | None,
                 statistic: str = 'adev') -> FloatArray:
    """Shares of Q, N, B, K, R at each τ: the model's, else the local slope's."""
    if theta is not None:
        shares = model_shares(statistic, curve.m, curve.tau0_s, theta)
        if shares is not None:
            return shares
    var = curve.avar if statistic == 'adev' else curve.others[statistic][0]
    return slope_shares(curve.tau_s, var)
