"""Overlapping Allan and total variance from the integrated signal (phase), batch form.

The Allan variance is computed from the phase x (the integrated signal: angle in rad for a
gyro, velocity in m/s for an accelerometer) sampled every τ0 (IEEE Std 952-1997 Annex C;
IEEE Std 647; NIST SP 1065 eq. 11)::

    AVAR(m·τ0) = Σ_{i=0}^{n−1} (x_{i+2m} − 2x_{i+m} + x_i)² / (2·n·(m·τ0)²),   n = N − 2m

with N phase points. Rate samples ω_k become phase points x_0 = 0, x_{k+1} = x_k + ω_k·τ0
(N = samples + 1, as allantools' ``frequency2phase``). The second difference is formed
as (x_{i+2m} − x_{i+m}) − (x_{i+m} − x_i), which keeps its precision when x is large.

This module holds the pieces every mode shares: the averaging-factor grid, the summing
kernel, the batch overlapping ADEV (equal to ``allantools.oadev`` on the same samples)
and the total deviation (NIST SP 1065 eq. 25, equal to ``allantools.totdev``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]

KERNEL_BLOCK = 8192
"""Terms summed per block (bounds temporaries; a fixed block makes sums reproducible). Kept
at or below 10 000: OpenBLAS runs longer dot products multi-threaded, which on a loaded
machine costs milliseconds per call instead of microseconds."""


@dataclass(frozen=True, slots=True)
class AveragingGrid:
    """Averaging factors m (τ = m·τ0) of the decimation tree and of full overlap.

    Level 0 (the samples themselves, stride 1) computes every ``level0`` factor (all
    below 2·min_m). Level j ≥ 1 holds the phase subsampled by 2^j and computes the factors
    ``level`` (in level-j samples, all in [min_m, 2·min_m)), i.e. τ = m·2^j·τ0 with stride
    2^j: at least ``min_m`` terms overlap within every non-overlapping span.

    Attributes:
        taus_per_octave: log-spaced points per octave (1 = octave points only).
        min_m: smallest averaging factor a level ≥ 1 computes (a power of two).
        level0: factors computed at level 0, ascending.
        level: factors computed at every level ≥ 1 (level units), ascending.
    """

    taus_per_octave: int
    min_m: int
    level0: tuple[int, ...]
    level: tuple[int, ...]

    @classmethod
    def make(cls, taus_per_octave: int = 4, min_m: int = 512) -> AveragingGrid:
        """Build the grid: m = round(2^(k/taus_per_octave)) (octaves exact), deduplicated."""
        if taus_per_octave < 1:
            raise ValueError('taus_per_octave must be at least 1')
        if min_m < 2 or min_m & (min_m - 1):
            raise ValueError('min_m must be a power of two, at least 2')
        octaves0 = int(math.log2(min_m)) + 1
        k = np.arange(octaves0 * taus_per_octave)
        level0 = np.unique(np.round(2.0 ** (k / taus_per_octave)).astype(np.int64))
        level0 = level0[level0 < 2 * min_m]
        k1 = np.arange(taus_per_octave)
        level = np.unique(np.round(min_m * 2.0 ** (k1 / taus_per_octave)).astype(np.int64))
        return cls(taus_per_octave, min_m, tuple(int(m) for m in level0),
                   tuple(int(m) for m in level))

    def factors_up_to(self, m_max: int) -> IntArray:
        """Every averaging factor of the grid (level-0 units) not above ``m_max``, ascending."""
        out = [m for m in self.level0 if m <= m_max]
        scale = 2
        while self.level[0] * scale <= m_max:
            out.extend(m * scale for m in self.level if m * scale <= m_max)
            scale *= 2
        return np.asarray(out, dtype=np.int64)


def second_difference_sums(x: FloatArray, m: int, lo: int, hi: int,
                           block: int = KERNEL_BLOCK) -> float:
    """Σ_{i=lo}^{hi−1} (x_{i+2m} − 2x_{i+m} + x_i)², summed block by block in index order.

    Each term is formed as D_{i+m} − D_i with D_k = x_{k+m} − x_k. Requires 0 ≤ lo and
    hi + 2m ≤ len(x). The block boundaries are fixed by ``lo`` and ``block`` only, so the
    same terms always give the same float sum.
    """
    total = 0.0
    if hi <= lo:
        return total
    size = min(block, hi - lo)
    lag = np.empty(size + m)
    diff = np.empty(size)
    for a in range(lo, hi, block):
        n = min(block, hi - a)
        d = np.subtract(x[a + m:a + n + 2 * m], x[a:a + n + m], out=lag[:n + m])
        u = np.subtract(d[m:], d[:n], out=diff[:n])
        total += float(np.dot(u, u))
    return total


def rate_to_phase(rate: npt.ArrayLike, tau0_s: float) -> FloatArray:
    """Phase points of rate samples: x_0 = 0, x_{k+1} = x_k + ω_k·τ0 (N = samples + 1)."""
    y = np.asarray(rate, dtype=np.float64)
    return np.concatenate(([0.0], np.cumsum(y) * tau0_s))


@dataclass(frozen=True, slots=True)
class AllanSums:
    """Raw sums of squared second differences per averaging factor (phase unit²).

    Attributes:
        m: averaging factors in level-0 samples (τ = m·τ0).
        sum_sq: Σ (Δ²x)² over the terms used, phase unit².
        terms: number of terms in each sum.
        stride: spacing of the term start points, samples (1 = full overlap).
        n_points: level-0 phase points of the record.
    """

    m: IntArray
    sum_sq: FloatArray
    terms: IntArray
    stride: IntArray
    n_points: int


def overlapping_allan_sums(phase: npt.ArrayLike, m: npt.ArrayLike) -> AllanSums:
    """Full-overlap sums for every m with at least one term (NIST SP 1065 eq. 11)."""
    x = np.asarray(phase, dtype=np.float64)
    ms = np.asarray(m, dtype=np.int64)
    ms = ms[(ms >= 1) & (2 * ms < len(x))]
    sums = np.array([second_difference_sums(x, int(k), 0, len(x) - 2 * int(k)) for k in ms])
    return AllanSums(ms, sums.astype(np.float64), len(x) - 2 * ms, np.ones_like(ms), len(x))


def overlapping_allan_deviation(data: npt.ArrayLike, *, tau0_s: float, m: npt.ArrayLike,
                                data_type: str = 'phase') -> tuple[FloatArray, FloatArray]:
    """Overlapping Allan deviation at τ = m·τ0 (NIST SP 1065 eq. 11; IEEE Std 952 C.1).

    Args:
        data: phase points (rad, or m/s) for ``data_type='phase'``; rate samples (rad/s,
            m/s²) for ``'rate'``.
        tau0_s: sample period τ0, s.
        m: averaging factors; those without a term (2m ≥ N) are left out.
        data_type: ``'phase'`` or ``'rate'``.

    Returns:
        (tau_s, adev): averaging times, s, and the deviation in rate unit (rad/s, m/s²).
    """
    if data_type == 'rate':
        x = rate_to_phase(data, tau0_s)
    elif data_type == 'phase':
        x = np.asarray(data, dtype=np.float64)
    else:
        raise ValueError(f"data_type must be 'phase' or 'rate', not {data_type!r}")
    s = overlapping_allan_sums(x, m)
    tau = np.asarray(s.m * tau0_s, dtype=np.float64)
    return tau, np.asarray(np.sqrt(s.sum_sq / (2.0 * s.terms)) / tau, dtype=np.float64)


def total_variance_sums(phase: npt.ArrayLike,
                        m: npt.ArrayLike) -> tuple[IntArray, FloatArray, int]:
    """Total-variance sums (NIST SP 1065 eq. 25): reflect the phase at both ends.

    x*_{1−j} = 2x_1 − x_{1+j}, x*_{N+j} = 2x_N − x_{N−j} (j = 1..N−2); the sum runs over
    i = 2..N−1 of (x*_{i−m} − 2x*_i + x*_{i+m})² and TOTVAR = sum / (2(mτ0)²(N−2)).

    Returns:
        (m, sums, N − 2) for every m with 1 ≤ m ≤ N − 2.
    """
    x = np.asarray(phase, dtype=np.float64)
    n = len(x)
    ms = np.asarray(m, dtype=np.int64)
    ms = ms[(ms >= 1) & (ms <= n - 2)]
    if n < 3:
        return ms[:0], np.zeros(0), 0
    left = (2.0 * x[0] - x[1:-1])[::-1]
    right = 2.0 * x[-1] - x[1:-1][::-1]
    ext = np.concatenate((left, x, right))
    mid = n - 2  # index of x_0 in ext
    sums = np.empty(len(ms))
    for j, k in enumerate(ms):
        k = int(k)
        c = ext[mid + 1:mid + n - 1]
        up = ext[mid + 1 + k:mid + n - 1 + k] - c
        down = c - ext[mid + 1 - k:mid + n - 1 - k]
        up -= down
        sums[j] = float(np.dot(up, up))
    return ms, sums, n - 2


def total_deviation(phase: npt.ArrayLike, *, tau0_s: float,
                    m: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Total deviation TOTDEV at τ = m·τ0 (NIST SP 1065 eq. 25), rate unit.

    Better confidence than the Allan deviation at long τ (it uses the reflected record),
    but biased low for flicker and random-walk rate noise there: E[TOTVAR] =
    AVAR·(1 − a·τ/T), a = 0 (white), 1/(3 ln 2) (flicker), 3/4 (random walk)
    (NIST SP 1065 §5.2.11). It is shown beside the ADEV, not used by the term fit.
    """
    ms, sums, n = total_variance_sums(phase, m)
    tau = np.asarray(ms * tau0_s, dtype=np.float64)
    return tau, np.asarray(np.sqrt(sums / (2.0 * n)) / tau, dtype=np.float64)


TAU_GRIDS = ('default', 'octave', 'decade', 'all')
"""Named τ grids (setting ``taus``); a list of τ in seconds is the fifth form."""


def parse_taus(spec: object) -> str | tuple[float, ...]:
    """A ``taus`` setting as a grid name or a tuple of τ, s.

    Accepts a name of :data:`TAU_GRIDS`, a list/tuple of numbers, or a string of numbers
    separated by commas or spaces (``"1, 10, 100"``, ``"[1, 10]"``).

    Raises:
        ValueError: anything else, or a τ that is not positive and finite.
    """
    if isinstance(spec, str):
        text = spec.strip().lower()
        if text in TAU_GRIDS:
            return text
        items: list[object] = [s for s in text.strip('[]()').replace(',', ' ').split() if s]
    elif isinstance(spec, (list, tuple)):
        items = list(spec)
    else:
        raise ValueError(f'taus = {spec!r}: expected one of {", ".join(TAU_GRIDS)} or a list '
                         'of averaging times in seconds')
    try:
        values = tuple(float(v) for v in items)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f'taus = {spec!r}: expected one of {", ".join(TAU_GRIDS)} or a list '
                         'of averaging times in seconds') from None
    if not values or not all(math.isfinite(v) and v > 0 for v in values):
        raise ValueError(f'taus = {spec!r}: every averaging time must be positive and finite, '
                         'in seconds, and at least one given')
    return values


@dataclass(frozen=True, slots=True)
class TauGrid:
    """Averaging factors of a τ grid for a sample period τ0 (Stable32/allantools grids).

    - ``default``: every octave m = 2^k (``taus_per_octave`` > 1 adds log-spaced points
      between them) and the decades τ = 10^k s, so values at 1, 10, 100 s can be read;
    - ``octave``: m = 2^k (allantools ``taus='octave'``);
    - ``decade``: τ = 1, 2, 4 × 10^k s (with τ0 = 1 s, allantools ``taus='decade'``);
    - ``all``: every m (one pass per m: long records take long);
    - a tuple of τ, s: m = round(τ/τ0).

    Attributes:
        spec: the grid name or the τ list, s.
        tau0_s: nominal sample period, s.
        taus_per_octave: points per octave of the default grid.
    """

    spec: str | tuple[float, ...]
    tau0_s: float
    taus_per_octave: int = 1

    def factors_up_to(self, m_max: int) -> IntArray:
        """Averaging factors 1 ≤ m ≤ m_max of the grid, ascending, unique."""
        if m_max < 1:
            return np.zeros(0, dtype=np.int64)
        spec = self.spec
        if spec == 'all':
            return np.arange(1, m_max + 1, dtype=np.int64)
        if isinstance(spec, tuple):
            m = np.round(np.asarray(spec) / self.tau0_s)
        else:
            top = math.log2(m_max) + 1.0
            per = self.taus_per_octave if spec == 'default' else 1
            parts = []
            if spec in ('default', 'octave'):
                k = np.arange(int(math.ceil(top * per)) + 1)
                parts.append(np.round(2.0 ** (k / per)))
            if spec in ('default', 'decade'):
                lo = math.floor(math.log10(self.tau0_s))
                hi = math.ceil(math.log10(m_max * self.tau0_s)) + 1
                mult = (1.0,) if spec == 'default' else (1.0, 2.0, 4.0)
                dec = np.array([f * 10.0**e for e in range(lo, hi) for f in mult])
                parts.append(np.round(dec / self.tau0_s))
            m = np.concatenate(parts)
        m = m[(m >= 1) & (m <= m_max)]
        return np.unique(m.astype(np.int64))
