"""Noise-characterisation simulators: one sensor axis, a 6-axis IMU, an RLG, a FOG.

Physics, not fixtures: each axis is the sum of the IEEE Std 952 noise processes of
:mod:`sim_nodes.noise.processes`, each a parameter (0 switches it off), seeded with
``np.random.SeedSequence(seed)`` (one child stream per axis and per process, spawned in a
fixed order, so switching one term off never changes another's draws), streamed in chunks
with chunked output bit-identical to one-shot output.

- :class:`AxisNoise`: rate samples of one axis (gyro rad/s or accelerometer m/s²) and the
  exact Allan variance of what it generates.
- :class:`ImuNoiseGenerator`: a static 6-axis IMU (``sensor_msgs/Imu`` angular_velocity
  and linear_acceleration), gravity on +z, integer-ns stamps with optional host-stamp
  jitter (the samples themselves stay evenly spaced: jitter is in the stamps only).
- :class:`RlgPulseGenerator`: cumulative whole pulses of a ring laser gyro. Quantisation
  shows only while the sub-pulse phase moves: under rotation, or under a dither. A static
  RLG inside its lock-in band, undithered, gives no beat: the count does not change.
- :class:`FogOutputGenerator`: cumulative output counts of a fibre-optic gyro (counts/rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sim_nodes.noise.processes import (
    FlickerRate,
    RandomWalkRate,
    RateRamp,
    WhitePhaseNoise,
    WhiteRateNoise,
)

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]

NS_PER_S = 1_000_000_000
STANDARD_GRAVITY_M_S2 = 9.80665
"""Standard gravity, m/s² (what a level accelerometer z axis reads at rest)."""


@dataclass(frozen=True, slots=True)
class NoiseTerms:
    """IEEE Std 952 noise terms of one axis, in the axis's rate unit (rad/s or m/s²).

    Every term is switched off by 0.
    """

    quantization: float = 0.0
    """Q: white angle (or velocity) noise, rad (m/s); AVAR = 3Q²/τ²."""
    random_walk: float = 0.0
    """N: angle (velocity) random walk, rate unit·√s (rad/√s); AVAR = N²/τ."""
    bias_instability: float = 0.0
    """B: flicker rate noise, rate unit; ADEV plateau 0.664·B."""
    rate_random_walk: float = 0.0
    """K: rate random walk, rate unit/√s; AVAR = K²τ/3."""
    rate_ramp: float = 0.0
    """R: rate ramp, rate unit/s; AVAR = R²τ²/2."""
    bias: float = 0.0
    """Constant bias, rate unit (invisible to the Allan variance)."""
    flicker_band_hz: tuple[float, float] = (1e-6, 0.0)
    """Band of the flicker synthesis (f_lo, f_hi), Hz; f_hi = 0 means 1/(3 τ0)."""

    def scaled(self, factor: float) -> NoiseTerms:
        """The same terms times ``factor`` (bias included)."""
        return NoiseTerms(self.quantization * factor, self.random_walk * factor,
                          self.bias_instability * factor, self.rate_random_walk * factor,
                          self.rate_ramp * factor, self.bias * factor, self.flicker_band_hz)


class AxisNoise:
    """Rate samples of one axis: bias plus the five IEEE 952 processes."""

    def __init__(self, terms: NoiseTerms, sample_rate_hz: float,
                 seed: int | np.random.SeedSequence) -> None:
        """Create the processes, each on its own child stream of ``seed``."""
        if not sample_rate_hz > 0:
            raise ValueError(f'sample_rate_hz = {sample_rate_hz!r} must be positive')
        self.terms = terms
        self.tau0_s = 1.0 / sample_rate_hz
        ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        rq, rn, rb, rk = (np.random.default_rng(s) for s in ss.spawn(4))
        self._processes = (
            WhitePhaseNoise(terms.quantization, self.tau0_s, rq),
            WhiteRateNoise(terms.random_walk, self.tau0_s, rn),
            FlickerRate(terms.bias_instability, self.tau0_s, rb, band_hz=terms.flicker_band_hz),
            RandomWalkRate(terms.rate_random_walk, self.tau0_s, rk),
            RateRamp(terms.rate_ramp, self.tau0_s),
        )

    def samples(self, n: int) -> FloatArray:
        """The next ``n`` rate samples (rate unit)."""
        out = np.full(n, self.terms.bias, dtype=np.float64)
        for p in self._processes:
            out += p.samples(n)
        return out

    def allan_variance(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Exact Allan variance of the generated sequence at τ = m·τ0, rate unit²."""
        tau = np.atleast_1d(np.asarray(tau_s, dtype=np.float64))
        return sum((p.allan_variance(tau) for p in self._processes), np.zeros_like(tau))

    def allan_deviation(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Square root of :meth:`allan_variance`, rate unit."""
        return np.sqrt(self.allan_variance(tau_s))


def _stamps(start_ns: int, index0: int, n: int, period_ns: int) -> IntArray:
    return start_ns + period_ns * np.arange(index0, index0 + n, dtype=np.int64)


def period_ns_for(sample_rate_hz: float) -> int:
    """Nominal sample period in whole nanoseconds (stamps are integer ns)."""
    period = round(NS_PER_S / sample_rate_hz)
    if period < 1:
        raise ValueError(f'sample rate {sample_rate_hz!r} Hz is above 1 GHz')
    return period


class ImuNoiseGenerator:
    """A static 6-axis IMU: gyro (rad/s) and accelerometer (m/s²) noise, gravity on +z.

    Axis order x, y, z; axis i of the gyro uses ``gyro_terms[i]`` (one NoiseTerms for all
    three is accepted). The samples are evenly spaced in the sensor's own clock; the
    stamps are ``start_ns + i·period_ns`` plus, optionally, host-stamp jitter drawn
    uniformly in ±``stamp_jitter_s`` (jitter in stamps only, as a host stamping a
    sensor that samples on its own clock).

    Output resolution: a MEMS IMU delivers integers of its ADC, which the driver scales
    to SI. ``gyro_lsb_rad_s`` / ``accel_lsb_m_s2`` round each rate sample to that step
    (0 = off: full float output). While the noise spans several steps the rounding error
    is white and uniform, so it adds white rate noise — angle (velocity) random walk
    N² += LSB²·τ0/12 (:meth:`quantisation_random_walk`), not a −1 slope.

    Decimation filter (``decimation`` D > 1, ``lowpass_cutoff_hz`` f_c > 0): as a MEMS IMU's
    digital low-pass, every axis (bias and all noise processes) is generated at D times the
    output rate, passed through a Butterworth low-pass of order ``lowpass_order`` and cutoff
    f_c (unity gain at DC, state kept across chunks, started at the bias: no transient), and
    every D-th filtered sample is output (then rounded to the LSB). Below f_c the rate PSD is
    unchanged (N, B, K stay what the terms say, plus the small alias of the filter's stop
    band, :meth:`filtered_random_walk_factor`); above it the short-τ Allan deviation bends
    below N/√τ.
    """

    def __init__(self, gyro_terms: NoiseTerms | tuple[NoiseTerms, NoiseTerms, NoiseTerms],
                 accel_terms: NoiseTerms | tuple[NoiseTerms, NoiseTerms, NoiseTerms], *,
                 sample_rate_hz: float = 400.0, seed: int = 1,
                 start_ns: int = 1_700_000_000 * NS_PER_S,
                 gravity_m_s2: float = STANDARD_GRAVITY_M_S2,
                 stamp_jitter_s: float = 0.0, gyro_lsb_rad_s: float = 0.0,
                 accel_lsb_m_s2: float = 0.0, decimation: int = 1,
                 lowpass_cutoff_hz: float = 0.0, lowpass_order: int = 2) -> None:
        """Create six independent axes on child streams of ``seed``."""
        g = gyro_terms if isinstance(gyro_terms, tuple) else (gyro_terms,) * 3
        a = accel_terms if isinstance(accel_terms, tuple) else (accel_terms,) * 3
        ss = np.random.SeedSequence(seed).spawn(7)
        self.sample_rate_hz = sample_rate_hz
        self.period_ns = period_ns_for(sample_rate_hz)
        rate = NS_PER_S / self.period_ns  # the rate the integer-ns stamps really have
        if decimation < 1 or lowpass_cutoff_hz < 0 or lowpass_order < 1:
            raise ValueError('decimation and lowpass_order must be ≥ 1, lowpass_cutoff_hz ≥ 0')
        if lowpass_cutoff_hz >= rate * decimation / 2.0:
            raise ValueError(f'lowpass_cutoff_hz = {lowpass_cutoff_hz!r} must lie below the '
                             f'internal Nyquist frequency {rate * decimation / 2.0!r} Hz')
        self.decimation, self.lowpass_cutoff_hz = decimation, lowpass_cutoff_hz
        self._sos = None
        if lowpass_cutoff_hz:
            from scipy.signal import butter

            self._sos = butter(lowpass_order, lowpass_cutoff_hz, fs=rate * decimation,
                               output='sos')
        self.gyro = tuple(AxisNoise(t, rate * decimation, s) for t, s in zip(g, ss[:3]))
        self.accel = tuple(AxisNoise(t, rate * decimation, s) for t, s in zip(a, ss[3:6]))
        self._zi: list[FloatArray | None] = [None] * 6
        self._jitter_rng = np.random.default_rng(ss[6])
        self.start_ns = start_ns
        self.gravity_m_s2, self.stamp_jitter_s = gravity_m_s2, stamp_jitter_s
        if gyro_lsb_rad_s < 0 or accel_lsb_m_s2 < 0:
            raise ValueError('output steps (LSB) must be zero (off) or positive')
        self.gyro_lsb_rad_s, self.accel_lsb_m_s2 = gyro_lsb_rad_s, accel_lsb_m_s2
        self._index = 0

    def quantisation_random_walk(self, lsb: float) -> float:
        """Random walk the output rounding to ``lsb`` adds: √(LSB²·τ0/12), rate unit·√s."""
        return math.sqrt(lsb * lsb * (self.period_ns / NS_PER_S) / 12.0)

    def filtered_random_walk_factor(self) -> float:
        """N_out/N of white rate noise through the decimation filter.

        N_out/N of white rate noise through the decimation filter: √(Σ_k |H(k·f_out)|²),
        k = 0 … D − 1 (the filter's response at DC and at the frequencies the decimation
        aliases onto DC); 1 without a filter.
        """
        if self._sos is None:
            return 1.0
        from scipy.signal import sosfreqz

        w = 2.0 * math.pi * np.arange(self.decimation) / self.decimation
        _, h = sosfreqz(self._sos, worN=w)
        return math.sqrt(float(np.sum(np.abs(h) ** 2)))

    def _axis_samples(self, k: int, axis: AxisNoise, n: int) -> FloatArray:
        """``n`` output samples of axis ``k``: generated at D× the rate, low-passed, decimated."""
        raw = axis.samples(n * self.decimation)
        if self._sos is not None:
            from scipy.signal import sosfilt, sosfilt_zi

            zi = self._zi[k]
            if zi is None:
                zi = sosfilt_zi(self._sos) * axis.terms.bias
            raw, self._zi[k] = sosfilt(self._sos, raw, zi=zi)
        return raw[self.decimation - 1::self.decimation]

    def chunk(self, n: int) -> tuple[IntArray, FloatArray, FloatArray]:
        """The next ``n`` samples: stamps (int ns), gyro (n × 3, rad/s), accel (n × 3, m/s²)."""
        t = _stamps(self.start_ns, self._index, n, self.period_ns)
        if self.stamp_jitter_s:
            jitter = self._jitter_rng.uniform(-self.stamp_jitter_s, self.stamp_jitter_s, n)
            t = t + np.round(jitter * NS_PER_S).astype(np.int64)
        self._index += n
        gyro = np.column_stack([self._axis_samples(k, ax, n) for k, ax in enumerate(self.gyro)])
        accel = np.column_stack([self._axis_samples(3 + k, ax, n)
                                 for k, ax in enumerate(self.accel)])
        accel[:, 2] += self.gravity_m_s2
        if self.gyro_lsb_rad_s:
            gyro = np.round(gyro / self.gyro_lsb_rad_s) * self.gyro_lsb_rad_s
        if self.accel_lsb_m_s2:
            accel = np.round(accel / self.accel_lsb_m_s2) * self.accel_lsb_m_s2
        return t, gyro, accel


class _IntegratingGyro:
    """Angle integrated from rate noise plus a constant rotation, and a dither angle."""

    def __init__(self, terms: NoiseTerms, sample_rate_hz: float, seed: int, start_ns: int,
                 rotation_rate_rad_s: float, dither_amplitude_rad: float,
                 dither_frequency_hz: float) -> None:
        ss = np.random.SeedSequence(seed).spawn(3)
        self.period_ns = period_ns_for(sample_rate_hz)
        self.tau0_s = self.period_ns / NS_PER_S
        self.axis = AxisNoise(terms, NS_PER_S / self.period_ns, ss[0])
        self._rng = np.random.default_rng(ss[1])
        self._dither_phase = float(np.random.default_rng(ss[2]).uniform(0.0, 2.0 * math.pi))
        self.start_ns = start_ns
        self.rotation_rate_rad_s = rotation_rate_rad_s
        self.dither_amplitude_rad = dither_amplitude_rad
        self.dither_frequency_hz = dither_frequency_hz
        self._angle_rad = 0.0  # integrated rate (without dither)
        self._index = 0

    def _angles(self, n: int) -> tuple[IntArray, FloatArray, FloatArray]:
        """Stamps, integrated angle at each stamp (rad) and dither angle at each stamp (rad)."""
        t = _stamps(self.start_ns, self._index, n, self.period_ns)
        rate = self.axis.samples(n) + self.rotation_rate_rad_s
        # the first sample integrates nothing before it (the angle starts at the first stamp)
        steps = rate * self.tau0_s
        if self._index == 0 and n:
            steps[0] = 0.0
        angle = np.cumsum(np.concatenate(([self._angle_rad], steps)))[1:]
        if n:
            self._angle_rad = float(angle[-1])
        k = np.arange(self._index, self._index + n, dtype=np.float64)
        dither = np.zeros(n)
        if self.dither_amplitude_rad:
            dither = self.dither_amplitude_rad * np.sin(
                2.0 * math.pi * self.dither_frequency_hz * self.tau0_s * k + self._dither_phase)
        self._index += n
        return t, angle, dither


class RlgPulseGenerator(_IntegratingGyro):
    """Cumulative whole pulses of a ring laser gyro (``/gyro/pulses`` position).

    count = floor(φ0 + (angle + dither)/K) with K the scale factor (rad/pulse) and φ0 a
    random initial sub-pulse phase. Quantisation (Q = K/√12 when the sub-pulse phase is
    spread evenly from sample to sample) appears only while that phase moves:

    - rotation: a constant rate ``rotation_rate_rad_s`` outside the lock-in band;
    - dither: a sinusoidal dither of ``dither_amplitude_rad`` at ``dither_frequency_hz``.
      With ``dither_stripped`` the known dither angle is subtracted from the count (as a
      dither pick-off does), leaving the quantisation error randomised by the dither
      (non-integer output); without it the dither angle stays in the count;
    - locked in: no dither and |rotation + bias| below ``lock_in_rate_rad_s``: the beams
      lock, no pulse comes, and the count stays constant (the noise is not seen at all).
    """

    def __init__(self, terms: NoiseTerms, *, scale_factor_rad_per_pulse: float,
                 sample_rate_hz: float = 1000.0, seed: int = 1,
                 start_ns: int = 1_700_000_000 * NS_PER_S, rotation_rate_rad_s: float = 0.0,
                 lock_in_rate_rad_s: float = 0.0, dither_amplitude_rad: float = 0.0,
                 dither_frequency_hz: float = 413.7, dither_stripped: bool = True,
                 table_angle: Callable[[FloatArray], FloatArray] | None = None) -> None:
        """Create the gyro; every error source is a parameter (0 = off).

        ``table_angle``: the angle (rad) of a rate table turning the gyro about its sense
        axis, as a function of the time since ``start_ns`` (s); added to the sensed angle
        (a rate-biased RLG: the table's rotation keeps it out of lock-in).
        """
        if not scale_factor_rad_per_pulse > 0:
            raise ValueError('scale_factor_rad_per_pulse must be positive')
        super().__init__(terms, sample_rate_hz, seed, start_ns, rotation_rate_rad_s,
                         dither_amplitude_rad, dither_frequency_hz)
        self.table_angle = table_angle
        self.scale_factor_rad_per_pulse = scale_factor_rad_per_pulse
        self.dither_stripped = dither_stripped
        self.locked_in = (dither_amplitude_rad == 0.0
                          and abs(rotation_rate_rad_s + terms.bias) < lock_in_rate_rad_s)
        self._phase0 = float(self._rng.uniform())

    def quantization_noise_rad(self) -> float:
        """Q this gyro shows: K/√12 while the sub-pulse phase moves, 0 when locked in."""
        return 0.0 if self.locked_in else self.scale_factor_rad_per_pulse / math.sqrt(12.0)

    def chunk(self, n: int) -> tuple[IntArray, FloatArray]:
        """The next ``n`` samples: stamps (int ns) and cumulative counts (pulses)."""
        t, angle, dither = self._angles(n)
        if self.table_angle is not None:
            angle = angle + self.table_angle((t - self.start_ns) / NS_PER_S)
        k = self.scale_factor_rad_per_pulse
        if self.locked_in:
            return t, np.full(n, math.floor(self._phase0), dtype=np.float64)
        counts = np.floor(self._phase0 + (angle + dither) / k)
        if self.dither_amplitude_rad and self.dither_stripped:
            counts = counts - dither / k
        return t, counts


class FogOutputGenerator(_IntegratingGyro):
    """Cumulative output counts of a fibre-optic gyro (``/fog/output``): angle × counts/rad.

    ``quantise`` floors the count to whole counts (Q = 1/(SF·√12) while the angle moves
    by more than a count between samples or the noise spreads it).
    """

    def __init__(self, terms: NoiseTerms, *, scale_factor_counts_per_rad: float,
                 sample_rate_hz: float = 1000.0, seed: int = 1,
                 start_ns: int = 1_700_000_000 * NS_PER_S, rotation_rate_rad_s: float = 0.0,
                 quantise: bool = False) -> None:
        """Create the gyro; every error source is a parameter (0 = off)."""
        if not scale_factor_counts_per_rad > 0:
            raise ValueError('scale_factor_counts_per_rad must be positive')
        super().__init__(terms, sample_rate_hz, seed, start_ns, rotation_rate_rad_s, 0.0, 0.0)
        self.scale_factor_counts_per_rad = scale_factor_counts_per_rad
        self.quantise = quantise
        self._phase0 = float(self._rng.uniform())

    def chunk(self, n: int) -> tuple[IntArray, FloatArray]:
        """The next ``n`` samples: stamps (int ns) and cumulative output counts."""
        t, angle, _ = self._angles(n)
        counts = self._phase0 + angle * self.scale_factor_counts_per_rad
        return t, (np.floor(counts) if self.quantise else counts)
