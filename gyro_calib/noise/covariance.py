"""Correlation between Allan-variance estimates at different τ, from the noise model.

Neighbouring points of a dense τ grid share most of their data: their estimates are
strongly correlated (ρ ≈ 0.9 at 4 points per octave), and a fit that treats them as
independent understates its uncertainty about twofold. This module models that
correlation from the fitted noise terms.

Model. With the phase x sampled every τ0 and u_{a,i} = x_{i+2m_a} − 2x_{i+m_a} + x_i, each
AVAR estimate is a mean of u_{a,i}² over its term start points. For Gaussian noise
cov(u², v²) = 2·cov(u, v)², and for records long against 2m the covariance of the two
estimates is (2/max(L_a, L_b))·Σ_d γ_ab(d)² / (4·m_a²·m_b²·τ0⁴), where L = N − 2m is the
span of term start points (level-0 samples) and γ_ab(d) = cov(u_{a,i}, u_{b,i+d}). The
stride of a partial-overlap estimate drops out of this (it is ≪ m). Every IEEE 952 noise
term has a generalised covariance K(t) of the phase (t in samples), valid for the second
differences used here (they annihilate polynomials of degree ≤ 1)::

    Q (white PM)       Q²·[t = 0]
    N (white FM)       −N²·τ0·|t|/2
    B (flicker FM)     B²·τ0²·t²·ln|t| / (2π)
    K (random-walk FM) K²·τ0³·|t|³/12

(each gives back its Annex C Allan variance: 3Q²/τ², N²/τ, (2 ln 2/π)B², K²τ/3), and
γ_ab(d) = Σ_{p,q} λ_p·λ_q·K(d + q·m_b − p·m_a) with λ = (1, −2, 1). A rate ramp is
deterministic and adds no variance at this order. Σ_d γ² is summed exactly over integer
lags near the kinks of γ when an averaging factor is small (< 32) and integrated with
Gauss–Legendre quadrature elsewhere (γ is polynomial or t²ln t between kinks); the
flicker tail beyond 64·(m_a + m_b) uses γ ≈ −m_a²m_b²/(π d²). The per-pair sums are cached.

Only the correlation ρ is taken from here; the variances come from the EDF formulas
(:mod:`gyro_calib.noise.edf`). ``test_noise_fit.py`` compares ρ with a Monte Carlo.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]

TERMS = ('Q', 'N', 'B', 'K')
"""Noise terms with a variance contribution, in the order of the basis matrices."""
TAU0_POWER = np.array([0, 1, 2, 3])
"""γ of term T scales with τ0 to this power."""
SMALL_M = 32
"""Below this averaging factor the lag sums are exact near the kinks of γ."""

_LAMBDA = np.array([1.0, -2.0, 1.0])
_GL16 = np.polynomial.legendre.leggauss(16)


def _gammas(d: FloatArray, offsets: FloatArray, weights: FloatArray,
            span: tuple[float, float]) -> FloatArray:
    """γ of N, B, K at lags d (rows: N, B, K); N and K vanish outside ``span``.

    Unit kernels K(t) (module docstring): N −|t|/2, B t²·ln|t|/(2π) (0 at t = 0), K |t|³/12,
    evaluated together in one pass (this runs for every pair of averaging factors of a fit).
    """
    args = d[:, None] + offsets[None, :]
    a = np.abs(args)
    positive = a > 0
    logs = np.log(np.where(positive, a, 1.0))
    kernels = np.stack((-0.5 * a, np.where(positive, args * args * logs / (2.0 * math.pi),
                                           0.0), a**3 / 12.0))
    out = kernels @ weights
    outside = (d < span[0]) | (d > span[1])
    out[0, outside] = 0.0
    out[2, outside] = 0.0
    return out


def _quadrature(pieces: list[tuple[float, float]]) -> tuple[FloatArray, FloatArray]:
    """Nodes and weights of 16-point Gauss–Legendre on each piece (empty pieces dropped)."""
    x, w = _GL16
    p = np.array([(a, b) for a, b in pieces if b > a], dtype=np.float64).reshape(-1, 2)
    half = 0.5 * (p[:, 1] - p[:, 0])[:, None]
    nodes = half * x[None, :] + 0.5 * (p[:, 0] + p[:, 1])[:, None]
    return nodes.ravel(), (half * w[None, :]).ravel()


def _geometric_pieces(start: float, width: float, direction: int) -> list[tuple[float, float]]:
    edges = [start + direction * width * (2.0**i - 1.0) for i in range(7)]  # to 63·width
    return [(min(a, b), max(a, b)) for a, b in zip(edges[:-1], edges[1:])]


_POWER = np.array([0, 1, 2, 3])
_PAIR_SCALE_POWER = _POWER[:, None] + _POWER[None, :] + 1
_PAIR_SCALE_POWER[0, 0] = 0
_PAIR_SCALE_POWER[0, 1:] = _PAIR_SCALE_POWER[1:, 0] = _POWER[1:]
"""pair_basis(s·m_a, s·m_b) = s^power · pair_basis(m_a, m_b) (both factors integrated):
γ_T scales as s^p with p = 1, 2, 3 for N, B, K (the flicker kernel's s²t²·ln s part is a
polynomial the second differences annihilate), the lag sum adds one power; the white-PM
spikes sit at the same kinks (Q·Q unchanged, Q·U as γ_U)."""


def pair_basis(m_a: int, m_b: int) -> tuple[tuple[float, ...], ...]:
    """Σ_d γ_T(d)·γ_U(d) for T, U ∈ (Q, N, B, K), unit terms and τ0 = 1 (4 × 4, symmetric).

    Pairs whose factors share a power of two and stay integrated (≥ SMALL_M) when halved are
    computed at the halved scale and scaled (:data:`_PAIR_SCALE_POWER`, equal to 1e-13):
    the τ grid repeats per octave, so one curve needs far fewer distinct pairs.
    """
    shift = 0
    while m_a % 2 == 0 and m_b % 2 == 0 and min(m_a, m_b) >= 2 * SMALL_M:
        m_a, m_b, shift = m_a // 2, m_b // 2, shift + 1
    base = _pair_basis(m_a, m_b)
    if not shift:
        return base
    scaled = np.asarray(base) * np.ldexp(1.0, shift * _PAIR_SCALE_POWER)
    return tuple(tuple(float(v) for v in row) for row in scaled)


@lru_cache(maxsize=200_000)
def _pair_basis(m_a: int, m_b: int) -> tuple[tuple[float, ...], ...]:
    """pair_basis computed at this scale (see there)."""
    p = np.repeat(np.arange(3), 3)
    q = np.tile(np.arange(3), 3)
    offsets = (q * m_b - p * m_a).astype(np.float64)
    weights = _LAMBDA[p] * _LAMBDA[q]
    kinks = np.unique(-offsets)  # lags where an argument is 0
    span = (float(kinks[0]), float(kinks[-1]))
    width = float(m_a + m_b)
    small = min(m_a, m_b) < SMALL_M
    exact: list[tuple[int, int]] = []  # integer lag ranges summed exactly
    pieces: list[tuple[float, float]] = []  # ranges integrated
    if small and width <= 4 * SMALL_M:
        lo, hi = int(span[0] - 2 * width) - 4, int(span[1] + 2 * width) + 4
        exact.append((lo, hi))
        left, right = lo - 0.5, hi + 0.5
        pieces += _geometric_pieces(right, width, 1) + _geometric_pieces(left, width, -1)
        far_from = max(abs(left - 63.0 * width), abs(right + 63.0 * width))
    else:
        if small:
            pad = 2 * min(m_a, m_b) + 4
            clusters: list[list[float]] = [[kinks[0], kinks[0]]]
            for k in kinks[1:]:
                if k - clusters[-1][1] <= pad:
                    clusters[-1][1] = k
                else:
                    clusters.append([k, k])
            windows = [(int(c0) - pad, int(c1) + pad) for c0, c1 in clusters]
            exact.extend(windows)
            pieces.extend((a1 + 0.5, b0 - 0.5) for (_, a1), (b0, _) in zip(windows, windows[1:]))
            left, right = windows[0][0] - 0.5, windows[-1][1] + 0.5
        else:
            pieces.extend(zip(kinks[:-1].tolist(), kinks[1:].tolist()))
            left, right = span
        pieces += _geometric_pieces(right, width, 1) + _geometric_pieces(left, width, -1)
        far_from = max(abs(left - 63.0 * width), abs(right + 63.0 * width))
    g = np.zeros((3, 3))
    lags, inverse = np.unique(-offsets, return_inverse=True)
    d = (np.concatenate([np.arange(a, b + 1, dtype=np.float64) for a, b in exact])
         if exact else np.zeros(0))
    t, w = _quadrature(pieces) if pieces else (np.zeros(0), np.zeros(0))
    every = _gammas(np.concatenate((d, t, lags)), offsets, weights, span)  # one pass
    if exact:
        ge = every[:, :len(d)]
        g += ge @ ge.T
    if pieces:
        gi = every[:, len(d):len(d) + len(t)]
        g += (gi * w) @ gi.T
    # flicker tail beyond the numerical reach: γ_B ≈ −m_a²m_b²/(π d²), both sides
    g[1, 1] += (float(m_a) ** 2 * float(m_b) ** 2 / math.pi) ** 2 * 2.0 / (3.0 * far_from**3)
    # white PM spikes at the kinks: γ_Q(d) = Σ λ_pλ_q over d + q m_b − p m_a = 0
    out = np.zeros((4, 4))
    out[1:, 1:] = g
    gq = np.zeros(len(lags))
    np.add.at(gq, inverse, weights)
    gc = every[:, len(d) + len(t):]
    out[0, 0] = float(gq @ gq)
    out[0, 1:] = out[1:, 0] = gc @ gq
    return tuple(tuple(float(v) for v in row) for row in out)


@lru_cache(maxsize=256)
def _basis_stack(ms: tuple[int, ...]) -> FloatArray:
    """pair_basis of every pair of averaging factors, read-only.

    pair_basis of every pair of averaging factors (len × len × 4 × 4), read-only; one
    curve's factors are fitted several times (iterations, edge terms, snapshots).
    """
    n = len(ms)
    out = np.empty((n, n, 4, 4))
    for i in range(n):
        for j in range(i, n):
            out[i, j] = out[j, i] = pair_basis(min(ms[i], ms[j]), max(ms[i], ms[j]))
    out.setflags(write=False)
    return out


def allan_correlation(m: npt.ArrayLike, spans: npt.ArrayLike, tau0_s: float,
                      terms_sq: npt.ArrayLike) -> FloatArray:
    """Correlation matrix of AVAR estimates at averaging factors ``m`` (see module doc).

    Args:
        m: averaging factors in level-0 samples.
        spans: L = N − 2m, level-0 span of each estimate's term start points.
        tau0_s: sample period, s.
        terms_sq: (Q², N², B², K²) of the noise model (rate-unit based, as the fit's θ).

    Returns:
        ρ (len(m) × len(m)); the identity where the model has no variance.
    """
    ms = tuple(int(v) for v in np.asarray(m))
    theta = np.asarray(terms_sq, dtype=np.float64)[:4]
    coeff = theta * float(tau0_s) ** TAU0_POWER
    n = len(ms)
    g = np.einsum('ijkl,l->ijk', _basis_stack(ms), coeff) @ coeff
    diag = np.sqrt(np.clip(np.diag(g), 0.0, None))
    ok = diag > 0
    rho = np.eye(n)
    if np.any(ok):
        sub = g[np.ix_(ok, ok)] / np.outer(diag[ok], diag[ok])
        lengths = np.asarray(spans, dtype=np.float64)[ok]
        lengths = np.maximum(lengths, 1.0)
        sub *= np.sqrt(np.minimum.outer(lengths, lengths) / np.maximum.outer(lengths, lengths))
        rho[np.ix_(ok, ok)] = np.clip(sub, -1.0, 1.0)
        np.fill_diagonal(rho, 1.0)
    return rho


def lag_model_edf(m: int, span: float, tau0_s: float, terms_sq: npt.ArrayLike,
                  avar: float) -> float:
    """EDF the lag model gives one estimate (large-record limit), for cross-checks."""
    theta = np.asarray(terms_sq, dtype=np.float64)[:4]
    coeff = theta * float(tau0_s) ** TAU0_POWER
    g = float(coeff @ np.asarray(pair_basis(m, m)) @ coeff)
    var = 2.0 * g / (span * 4.0 * m**4 * tau0_s**4)
    return 2.0 * avar**2 / var
