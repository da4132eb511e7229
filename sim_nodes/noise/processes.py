"""Seeded, chunk-invariant noise processes of an inertial sensor axis (IEEE Std 952 Annex C).

Each process turns a count of samples into rate samples (rad/s for a gyro, m/s² for an
accelerometer; "rate unit" below) at a fixed sample period τ0, keeping its state between
calls: drawing ``n1`` then ``n2`` samples gives bit for bit the ``n1 + n2`` samples of one
call (random numbers are drawn in sample order from the process's own stream, and every
recursion carries its state exactly). Each also knows the exact Allan variance of the
discrete sequence it produces, so a test compares an estimator with the process itself,
not with a textbook asymptote.

The terms and their Allan variances (IEEE Std 952-1997 Annex C, eq. C.2 ff.)::

    quantisation Q        white phase (angle) noise    AVAR = 3·Q²/τ²
    angle random walk N   white rate noise             AVAR = N²/τ
    bias instability B    flicker rate noise           AVAR = (2·ln 2/π)·B²   (plateau)
    rate random walk K    random-walk rate             AVAR = K²·τ/3 (+ K²·τ0²/(6τ))
    rate ramp R           rate growing linearly        AVAR = R²·τ²/2

Flicker noise is synthesised as the output an integrating sensor gives of a continuous
1/f rate: a sum of continuous Ornstein–Uhlenbeck (first-order Gauss–Markov) processes
whose corner frequencies are spaced evenly in log frequency (``poles_per_decade``) over
[f_lo, f_hi], each with variance c = B²·ln(r)/π (r the corner ratio), so that the
two-sided spectrum of the sum is ≈ B²/(2π f) inside the band (Σ_k c/(π f_k)/(1 +
(f/f_k)²) → c/(2 f ln r)), the IEEE 952 flicker spectrum. Each sample is the exact mean
of the process over its interval: the state and the interval integral of every component
are propagated exactly as a jointly Gaussian pair, so the Allan variance of the samples
is the continuous one at τ = m·τ0, flat down to τ0 when f_hi ≫ 1/τ0 (default 1000/τ0).
Verified with the exact Allan variance (:meth:`FlickerRate.allan_variance`): with the
default band [1e-6 Hz, 1000/τ0] and 2 poles per decade the Allan deviation stays within
0.1 % of 0.664·B for τ from τ0 to 1e3 s and within 1 % to 1e4 s (checked at τ0 = 1 ms and
1 s); ``test_noise_generators.py`` checks the exact curve and a simulated estimate.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.signal import lfilter

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]


def _as_m(tau_s: npt.ArrayLike, tau0_s: float) -> FloatArray:
    return np.asarray(tau_s, dtype=np.float64) / tau0_s


class WhitePhaseNoise:
    """Quantisation-like white angle noise Q: the angle sample carries e_k ~ N(0, Q²).

    The rate sample is (e_k − e_{k−1})/τ0, so the integrated angle is white with
    standard deviation Q (plus the constant −e_{−1}).
    """

    def __init__(self, q: float, tau0_s: float, rng: np.random.Generator) -> None:
        """Q in the angle unit (rad or m/s); τ0 in s; ``rng`` the process's own stream."""
        self.q, self.tau0_s, self._rng = q, tau0_s, rng
        self._prev = q * float(rng.standard_normal()) if q else 0.0

    def samples(self, n: int) -> FloatArray:
        """The next ``n`` rate samples, rate unit."""
        if not self.q:
            return np.zeros(n)
        e = self.q * self._rng.standard_normal(n)
        out = np.diff(np.concatenate(([self._prev], e))) / self.tau0_s
        if n:
            self._prev = float(e[-1])
        return out

    def allan_variance(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Exact Allan variance of the sequence at τ = m·τ0 (m ≥ 1): 3Q²/τ²."""
        tau = np.asarray(tau_s, dtype=np.float64)
        return 3.0 * self.q**2 / tau**2


class WhiteRateNoise:
    """Angle random walk N: independent rate samples with standard deviation N/√τ0."""

    def __init__(self, n: float, tau0_s: float, rng: np.random.Generator) -> None:
        """N in rate unit·√s (rad/√s for a gyro); τ0 in s."""
        self.n, self.tau0_s, self._rng = n, tau0_s, rng

    def samples(self, count: int) -> FloatArray:
        """The next ``count`` rate samples."""
        if not self.n:
            return np.zeros(count)
        return (self.n / math.sqrt(self.tau0_s)) * self._rng.standard_normal(count)

    def allan_variance(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Exact Allan variance: N²/τ."""
        return self.n**2 / np.asarray(tau_s, dtype=np.float64)


class RandomWalkRate:
    """Rate random walk K: the rate sample is a random walk with steps K·√τ0, from 0."""

    def __init__(self, k: float, tau0_s: float, rng: np.random.Generator) -> None:
        """K in rate unit/√s; τ0 in s."""
        self.k, self.tau0_s, self._rng = k, tau0_s, rng
        self._state = 0.0

    def samples(self, n: int) -> FloatArray:
        """The next ``n`` rate samples."""
        if not self.k:
            return np.zeros(n)
        steps = (self.k * math.sqrt(self.tau0_s)) * self._rng.standard_normal(n)
        walk = np.cumsum(np.concatenate(([self._state], steps)))[1:]
        if n:
            self._state = float(walk[-1])
        return walk

    def allan_variance(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Exact Allan variance of the discrete walk: K²τ/3 + K²τ0²/(6τ)."""
        tau = np.asarray(tau_s, dtype=np.float64)
        return self.k**2 * (tau / 3.0 + self.tau0_s**2 / (6.0 * tau))


class RateRamp:
    """Rate ramp R: the rate sample k is R·k·τ0 (deterministic)."""

    def __init__(self, r: float, tau0_s: float) -> None:
        """R in rate unit/s; τ0 in s."""
        self.r, self.tau0_s = r, tau0_s
        self._index = 0

    def samples(self, n: int) -> FloatArray:
        """The next ``n`` rate samples."""
        k = np.arange(self._index, self._index + n, dtype=np.float64)
        self._index += n
        return self.r * self.tau0_s * k

    def allan_variance(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Exact Allan variance: R²τ²/2."""
        return 0.5 * self.r**2 * np.asarray(tau_s, dtype=np.float64) ** 2


def ou_allan_variance(tau_s: npt.ArrayLike, variance: float, rate_hz: float) -> FloatArray:
    """Exact Allan variance of interval means of a stationary Ornstein–Uhlenbeck process.

    R(s) = σ²·e^{−λ|s|} with λ = 2π·``rate_hz``. With V(τ) = Var(∫_0^τ y) =
    2σ²[τ/λ − (1 − e^{−λτ})/λ²], AVAR(τ) = (4·V(τ) − V(2τ))/(2τ²). For λτ < 1e-2 the
    series σ²(2x/3 − x²/2 + 7x³/30 − x⁴/12), x = λτ, replaces the cancelling closed form.
    """
    tau = np.atleast_1d(np.asarray(tau_s, dtype=np.float64))
    lam = 2.0 * math.pi * rate_hz
    x = lam * tau
    out = np.empty_like(x)
    small = x < 1e-2
    xs = x[small]
    out[small] = 2 * xs / 3 - xs**2 / 2 + 7 * xs**3 / 30 - xs**4 / 12
    xl = x[~small]

    def v(y: FloatArray) -> FloatArray:  # V(τ)·λ²/(2σ²) at y = λτ
        return y + np.expm1(-y)

    out[~small] = (4.0 * v(xl) - v(2.0 * xl)) / (xl * xl)
    return variance * out


class FlickerRate:
    """Bias instability B: interval means of a continuous 1/f rate (see module doc)."""

    def __init__(self, b: float, tau0_s: float, rng: np.random.Generator, *,
                 band_hz: tuple[float, float] = (1e-6, 0.0), poles_per_decade: int = 2) -> None:
        """B in rate unit; τ0 in s.

        Args:
            b: bias instability B (the Allan deviation plateau is 0.664·B).
            tau0_s: sample period τ0, s.
            rng: the process's own random stream.
            band_hz: (f_lo, f_hi), corner frequencies of the slowest and fastest
                Ornstein–Uhlenbeck components, Hz; f_hi = 0 means 1000/τ0.
            poles_per_decade: components per decade of frequency.
        """
        f_lo, f_hi = band_hz
        if f_hi <= 0.0:
            f_hi = 1000.0 / tau0_s
        if not 0.0 < f_lo < f_hi:
            raise ValueError(f'flicker band {band_hz!r} Hz must satisfy 0 < f_lo < f_hi')
        if poles_per_decade < 1:
            raise ValueError('poles_per_decade must be at least 1')
        self.b, self.tau0_s, self._rng = b, tau0_s, rng
        ratio = 10.0 ** (1.0 / poles_per_decade)
        count = int(math.floor(math.log10(f_hi / f_lo) * poles_per_decade + 1e-9)) + 1
        self.corners_hz = f_lo * ratio ** np.arange(count)
        var = b * b * math.log(ratio) / math.pi
        self.component_variance = var
        x = 2.0 * math.pi * self.corners_hz * tau0_s  # λτ0
        self._phi = np.exp(-x)
        one_m_phi = -np.expm1(-x)
        sd = math.sqrt(var)
        # exact one-step propagation of (state, interval integral / τ0) for each component
        self._gain = one_m_phi / x  # mean of the interval integral per unit state, / τ0
        a11 = sd * np.sqrt(-np.expm1(-2.0 * x))
        cov12 = var * one_m_phi**2 / x  # Cov(w1, w2/τ0)
        series = 2 * x / 3 - x**2 / 2 + 7 * x**3 / 30 - x**4 / 12
        closed = (2 * x - 3 + 4 * self._phi - self._phi**2) / np.where(x > 0, x * x, 1.0)
        var2 = var * np.where(x < 1e-2, series, closed)  # Var(w2/τ0)
        self._a11 = a11
        self._a21 = np.divide(cov12, a11, out=np.zeros_like(a11), where=a11 > 0)
        self._a22 = np.sqrt(np.clip(var2 - self._a21**2, 0.0, None))
        # stationary start: no warm-up transient
        self._state = sd * rng.standard_normal(count) if b else np.zeros(count)

    def samples(self, n: int) -> FloatArray:
        """The next ``n`` rate samples (sum of the components' interval means)."""
        if not self.b:
            return np.zeros(n)
        if n == 0:
            return np.zeros(0)
        z = self._rng.standard_normal((n, len(self._phi), 2))
        w1 = z[:, :, 0] * self._a11
        w2 = z[:, :, 0] * self._a21 + z[:, :, 1] * self._a22
        out = np.zeros(n)
        for k, phi in enumerate(self._phi):
            after, _ = lfilter([1.0], [1.0, -phi], w1[:, k], zi=[phi * self._state[k]])
            before = np.concatenate(([self._state[k]], after[:-1]))
            out += before * self._gain[k] + w2[:, k]
            self._state[k] = after[-1]
        return out

    def allan_variance(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Exact Allan variance of the generated sequence at τ = m·τ0."""
        tau = np.atleast_1d(np.asarray(tau_s, dtype=np.float64))
        total = np.zeros_like(tau)
        for f in self.corners_hz:
            total += ou_allan_variance(tau, self.component_variance, float(f))
        return total
