"""Lifting-wavelet denoising of the gyro rate and the signal-to-noise ratio (METHODS §D.1).

The paper's second-generation (lifting) transform splits a series into even and odd
samples, predicts the odd from the even (detail = odd − P(even)), updates the even
(approximation = even + U(detail)), and repeats on the approximation for N levels; the
details are thresholded and the inverse (undo update, undo predict, merge) rebuilds the
signal. With the CDF 5/3 or CDF 9/7 predict/update pair this *is* the biorthogonal
wavelet transform PyWavelets calls ``bior2.2`` / ``bior4.4``: :func:`lifting_forward`
implements the lifting steps literally, and for periodic extension

    cA = ζ·s,   cD = −d/ζ

equals ``pywt.dwt(x, wavelet, mode='periodization')`` exactly (ζ = √2 for 5/3, ζ =
1.149604398860241 for 9/7; ``test/test_thermal_wavelet.py`` checks it). Denoising itself
uses PyWavelets (``wavedec`` / ``threshold`` / ``waverec``, symmetric extension).

Only the detail coefficients are thresholded; the approximation after ``levels`` levels —
everything slower than about 2^levels samples — passes untouched, so the thermal
(model-band) content is not changed (a test checks this too).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pywt

from gyro_calib.errors import ConfigError

if TYPE_CHECKING:
    import numpy.typing as npt

WAVELETS = ('bior2.2', 'bior4.4')
"""Wavelets offered: the CDF 5/3 and CDF 9/7 lifting pairs."""
THRESHOLD_RULES = ('universal', 'minimax', 'bayes')
"""Threshold rules (VisuShrink σ√(2 ln n); Donoho–Johnstone minimax; BayesShrink σ²/σ_x)."""
THRESHOLD_MODES = ('soft', 'hard')
"""How a coefficient is shrunk."""

# Lifting steps: a sequence of ('predict'|'update', c) with
#   predict: odd  += c·(even[k] + even[k+1])
#   update:  even += c·(odd[k−1] + odd[k])
# followed by the normalisation ζ (cA = ζ·even, cD = −odd/ζ).
_LIFTING: dict[str, tuple[tuple[tuple[str, float], ...], float]] = {
    'bior2.2': ((('predict', -0.5), ('update', 0.25)), math.sqrt(2.0)),
    'bior4.4': ((('predict', -1.586134342059924), ('update', -0.052980118572961),
                 ('predict', 0.882911075530934), ('update', 0.443506852043971)),
                1.149604398860241),
}


def lifting_forward(x: npt.ArrayLike, wavelet: str = 'bior4.4', levels: int = 1
                    ) -> tuple[npt.NDArray[np.float64], list[npt.NDArray[np.float64]]]:
    """The paper's split / predict / update, ``levels`` times, with periodic extension.

    Args:
        x: series whose length is a multiple of 2**levels.
        wavelet: ``bior2.2`` (CDF 5/3) or ``bior4.4`` (CDF 9/7).
        levels: N.

    Returns:
        (approximation at level N, [details at level N, …, level 1]) — the order of
        ``pywt.wavedec``.
    """
    steps, zeta = _lifting_pair(wavelet)
    s = np.asarray(x, np.float64)
    if len(s) % (2**levels):
        raise ValueError(f'length {len(s)} is not a multiple of 2**{levels}')
    details: list[npt.NDArray[np.float64]] = []
    for _ in range(levels):
        even, odd = s[0::2].copy(), s[1::2].copy()
        for kind, c in steps:
            if kind == 'predict':
                odd = odd + c * (even + np.roll(even, -1))
            else:
                even = even + c * (np.roll(odd, 1) + odd)
        s = zeta * even
        details.insert(0, -odd / zeta)
    return s, details


def lifting_inverse(approx: npt.ArrayLike, details: list[npt.NDArray[np.float64]],
                    wavelet: str = 'bior4.4') -> npt.NDArray[np.float64]:
    """Undo :func:`lifting_forward`: undo normalisation, undo update, undo predict, merge."""
    steps, zeta = _lifting_pair(wavelet)
    s = np.asarray(approx, np.float64)
    for d in details:
        even, odd = s / zeta, -np.asarray(d, np.float64) * zeta
        for kind, c in reversed(steps):
            if kind == 'predict':
                odd = odd - c * (even + np.roll(even, -1))
            else:
                even = even - c * (np.roll(odd, 1) + odd)
        s = np.empty(2 * len(even))
        s[0::2], s[1::2] = even, odd
    return s


def _lifting_pair(wavelet: str) -> tuple[tuple[tuple[str, float], ...], float]:
    if wavelet not in _LIFTING:
        raise ConfigError(f'wavelet {wavelet!r} is not offered: use {" or ".join(WAVELETS)}.')
    return _LIFTING[wavelet]


@dataclass(frozen=True, slots=True)
class DenoiseResult:
    """A denoised series and what was done to it.

    Attributes:
        values: the denoised series (same length and unit as the input).
        levels: decomposition levels actually used (fewer than asked for short series).
        noise_std: robust noise estimate per detail level (finest first), input unit.
        thresholds: threshold applied per detail level (finest first), input unit.
    """

    values: npt.NDArray[np.float64]
    levels: int
    noise_std: tuple[float, ...]
    thresholds: tuple[float, ...]


def denoise(x: npt.ArrayLike, *, wavelet: str = 'bior4.4', levels: int = 6,
            threshold_rule: str = 'universal', threshold_mode: str = 'soft') -> DenoiseResult:
    """Wavelet-threshold denoising of a uniformly sampled series (METHODS §D.1).

    Each detail level j gets its own noise estimate σ_j = median|d_j|/0.6745 (the noise
    of a pulse-quantised gyro rate is not white, so one σ for all levels would be wrong)
    and threshold: ``universal`` σ_j·√(2 ln n), ``minimax`` σ_j·(0.3936 + 0.1829 log₂ n),
    ``bayes`` σ_j²/√max(var d_j − σ_j², 0). The approximation is never thresholded.
    Levels are capped at what the length allows (``pywt.dwt_max_level``).

    Raises:
        ConfigError: on an unknown wavelet, rule or mode.
    """
    _lifting_pair(wavelet)
    if threshold_rule not in THRESHOLD_RULES:
        raise ConfigError(f'threshold_rule {threshold_rule!r} is unknown: use one of '
                          f'{", ".join(THRESHOLD_RULES)}.')
    if threshold_mode not in THRESHOLD_MODES:
        raise ConfigError(f'threshold_mode {threshold_mode!r} is unknown: use soft or hard.')
    y = np.asarray(x, np.float64)
    n = len(y)
    w = pywt.Wavelet(wavelet)
    use = min(levels, pywt.dwt_max_level(n, w.dec_len)) if n else 0
    if use < 1:
        return DenoiseResult(y.copy(), 0, (), ())
    coeffs = pywt.wavedec(y, w, mode='symmetric', level=use)
    sigmas: list[float] = []
    lams: list[float] = []
    out = [coeffs[0]]
    for d in coeffs[1:]:
        sigma = float(np.median(np.abs(d))) / 0.6745
        if threshold_rule == 'universal':
            lam = sigma * math.sqrt(2.0 * math.log(n))
        elif threshold_rule == 'minimax':
            lam = sigma * (0.3936 + 0.1829 * math.log2(n)) if n > 32 else 0.0
        else:
            signal_var = max(float(np.var(d)) - sigma**2, 0.0)
            lam = sigma**2 / math.sqrt(signal_var) if signal_var > 0 else float(
                np.max(np.abs(d)))
        sigmas.append(sigma)
        lams.append(lam)
        out.append(pywt.threshold(d, lam, mode=threshold_mode))
    values = pywt.waverec(out, w, mode='symmetric')[:n]
    # wavedec lists the coarsest level first; report finest first
    return DenoiseResult(values, use, tuple(reversed(sigmas)), tuple(reversed(lams)))


def snr_db(x: npt.ArrayLike, reference: npt.ArrayLike | None = None) -> float:
    """Signal-to-noise ratio of one segment, dB.

    Without ``reference`` (what a bench can compute): signal = the least-squares straight
    line through the segment (its slowly varying level, which on a static base is the
    Earth rate along the axis plus the bias), noise = the series minus that line;
    SNR = 10·log₁₀(Σ line² / Σ (x − line)²). With ``reference`` (simulation truth):
    signal = reference, noise = x − reference. The figure depends on the averaging
    interval of ``x`` and on the Earth rate, so it describes a record, not a gyro; the
    paper does not define its SNR.
    """
    y = np.asarray(x, np.float64)
    if reference is None:
        t = np.arange(len(y), dtype=np.float64)
        if len(y) < 3:
            return math.nan
        coef = np.polyfit(t, y, 1)
        signal = np.polyval(coef, t)
    else:
        signal = np.asarray(reference, np.float64)
    noise_power = float(np.sum((y - signal) ** 2))
    signal_power = float(np.sum(signal**2))
    if noise_power == 0.0:
        return math.inf
    return 10.0 * math.log10(signal_power / noise_power)
