"""Detector, pre-amplifier, ADC and demodulation of the FOG, and the loop's static balance.

Per transit time τ the interferometer sees ΔΦ = Φ_s + Φ_f ± π/2 (square-wave bias of
period 2τ) and the detector gives I = A·[1 + cos ΔΦ] (seed 001 eq. 4), that is
A·[1 ∓ sin(Φ_s + Φ_f)] in the two half periods (eqs. 5, 6). The AC-coupled
pre-amplifier removes the mean A and amplifies with gain G into a soft rail,
V_sat·tanh(G·x/V_sat); the ADC clips at ±full scale and quantises. Demodulating with
the bias sign, ΔI = I₊ − I₋ = −2A·sin(Φ_s + Φ_f) (eq. 7), becomes the error word

    F(a) = clip(V_sat·tanh(G·A·sin a / V_sat)) / LSB,   a = Φ_s + Φ_f.

The digital integrator changes the staircase height by −k_i·(F + j) each period 2τ,
where j is the self-calibration word the FPGA injects into this error path. The loop
therefore balances where the mean error is −j: with no injection at a ≈ 0 (the null,
where the front end only ever sees small signals), with an injection at a real optical
phase error a = F⁻¹(−j), where sin() and the pre-amplifier's compression bend the
response, and beyond max |F| (fringe peak or ADC range) not at all — the loop loses
lock. This is the mechanism behind the paper's Table 1 (METHODS §B).

2π resets: the staircase word wraps at 2^N; the DAC × Y-waveguide gain g = 1 + ε turns a
wrap into a phase jump of 2π·g, which the interferometer sees as −2π·ε·sign during one
τ. A fraction r = |Φ_f|/(2π·g) of the periods carry such a glitch; the balance uses the
mean over both kinds of period: (1 − r)·F(a) + r·F(a − 2πε·σ) = −j.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    from sim_nodes.fog.config import FogConfig

    FloatArray = npt.NDArray[np.float64]


class FrontEnd:
    """The static chain optical phase error → demodulated error word, and the loop balance."""

    def __init__(self, config: FogConfig) -> None:
        """Precompute the chain's constants from ``config``."""
        self.config = config
        self.amplitude_v = config.detector_amplitude_v
        self.gain = config.preamp_gain
        self.rail_v = config.preamp_saturation_v
        self.full_scale_v = config.adc_full_scale_v
        self.lsb_v = config.error_scale_v
        self.kappa = config.front_end_gain_per_rad
        self.tau_s = config.transit_time_s
        self.g = 1.0 + config.y_waveguide_gain_error
        self.eps2pi = 2.0 * math.pi * config.y_waveguide_gain_error
        self.delta_rad = config.phase_lsb_rad
        self.k_i = config.integrator_gain

    # -- the chain ------------------------------------------------------------------------------
    def preamp_v(self, x_v: FloatArray | float) -> FloatArray:
        """Pre-amplifier output for an input (after AC coupling) of ``x_v``, V."""
        x = self.gain * np.asarray(x_v, dtype=np.float64)
        if self.rail_v:
            return self.rail_v * np.tanh(x / self.rail_v)
        return x

    def error_word(self, phase_error_rad: FloatArray | float) -> FloatArray:
        """F(a): mean demodulated error word for an optical phase error a (unquantised)."""
        v = self.preamp_v(self.amplitude_v * np.sin(phase_error_rad))
        if self.full_scale_v:
            v = np.clip(v, -self.full_scale_v, self.full_scale_v)
        return v / self.lsb_v

    def error_word_slope(self, phase_error_rad: FloatArray | float) -> FloatArray:
        """F'(a), words per rad (0 where the ADC clips)."""
        a = np.asarray(phase_error_rad, dtype=np.float64)
        x = self.gain * self.amplitude_v * np.sin(a)
        slope = self.gain * self.amplitude_v * np.cos(a) / self.lsb_v
        if self.rail_v:
            slope = slope / np.cosh(x / self.rail_v) ** 2
            x = self.rail_v * np.tanh(x / self.rail_v)
        if self.full_scale_v:
            slope = np.where(np.abs(x) > self.full_scale_v, 0.0, slope)
        return slope

    @property
    def max_error_word(self) -> float:
        """Largest |F| the front end can deliver (fringe peak or ADC range), words."""
        v = float(self.preamp_v(self.amplitude_v))
        if self.full_scale_v:
            v = min(v, self.full_scale_v)
        return v / self.lsb_v

    def inverse_error_word(self, word: FloatArray | float) -> FloatArray:
        """The a = F⁻¹(w) on the branch through the null; NaN where |w| ≥ max |F| (no lock)."""
        w = np.asarray(word, dtype=np.float64)
        ok = np.abs(w) < self.max_error_word
        v = np.where(ok, w, 0.0) * self.lsb_v
        if self.rail_v:
            v = self.rail_v * np.arctanh(v / self.rail_v)
        s = v / (self.gain * self.amplitude_v)
        ok &= np.abs(s) < 1.0
        return np.where(ok, np.arcsin(np.clip(s, -1.0, 1.0)), np.nan)

    # -- injection ---------------------------------------------------------------------------
    def injection_word(self, rate_counts_s: FloatArray | float) -> FloatArray:
        """Error-path word the FPGA adds for a requested injection J (counts/s).

        The FPGA scales J with the front-end gain it assumes, κ·(1 + injection_gain_error),
        so that a perfectly linear loop would move the output by J·(1 + that error).
        """
        assumed = self.kappa * (1.0 + self.config.injection_gain_error)
        return 2.0 * math.pi * self.tau_s * assumed * np.asarray(rate_counts_s, np.float64)

    # -- balance of the loop -----------------------------------------------------------------
    def balance(self, sagnac_phase_rad: FloatArray | float,
                word: FloatArray | float) -> tuple[FloatArray, FloatArray]:
        """Optical phase error a where the loop balances, and dG/da there.

        Solves (1 − r)·F(a) + r·F(a − 2πε·σ) + j = 0 with r = |a − Φ_s|/(2πg) and
        σ = sign(a − Φ_s) (2π resets with gain error ε), by Newton's method from the
        ε = 0 solution a = F⁻¹(−j). NaN where the loop cannot balance (out of lock).

        Args:
            sagnac_phase_rad: Φ_s (plus any other non-reciprocal phase), rad.
            word: injected error-path word j.

        Returns:
            (a in rad, dG/da in words per rad), broadcast to a common shape.
        """
        phi, j = np.broadcast_arrays(np.asarray(sagnac_phase_rad, np.float64),
                                     np.asarray(word, np.float64))
        a = self.inverse_error_word(-j)
        if self.eps2pi == 0.0:
            return a, self.error_word_slope(a)
        for _ in range(2):  # from the ε = 0 solution, two steps reach ~1e-10 rad
            value, slope = self._balance_terms(a, phi, j)
            a = a - value / slope
        value, slope = self._balance_terms(a, phi, j)
        bad = ((np.abs(a - phi) >= 2.0 * math.pi * self.g) | ~np.isfinite(a)
               | (np.abs(value) > 1e-6 * max(1.0, self.max_error_word)))
        return np.where(bad, np.nan, a), np.where(bad, np.nan, slope)

    def _f_and_slope(self, a: FloatArray) -> tuple[FloatArray, FloatArray]:
        """F(a) and F'(a) together (one sin, cos and tanh each)."""
        x = self.gain * self.amplitude_v * np.sin(a)
        slope = self.gain * self.amplitude_v * np.cos(a) / self.lsb_v
        if self.rail_v:
            th = np.tanh(x / self.rail_v)
            slope = slope * (1.0 - th * th)
            x = self.rail_v * th
        if self.full_scale_v:
            clipped = np.abs(x) > self.full_scale_v
            x = np.where(clipped, np.sign(x) * self.full_scale_v, x)
            slope = np.where(clipped, 0.0, slope)
        return x / self.lsb_v, slope

    def _balance_terms(self, a: FloatArray, phi: FloatArray,
                       j: FloatArray) -> tuple[FloatArray, FloatArray]:
        """G(a) = (1 − r)·F(a) + r·F(a − 2πε·σ) + j and dG/da."""
        feedback = a - phi
        sigma = np.sign(feedback)
        r = np.abs(feedback) / (2.0 * math.pi * self.g)
        f0, d0 = self._f_and_slope(a)
        f1, d1 = self._f_and_slope(a - self.eps2pi * sigma)
        value = (1.0 - r) * f0 + r * f1 + j
        slope = (1.0 - r) * d0 + r * d1 + sigma / (2.0 * math.pi * self.g) * (f1 - f0)
        return value, slope

    def mean_error(self, a: float, phi: float, word: float) -> float:
        """G(a) + j for one state, with math (the averaged loop's right-hand side).

        Outside the reset model's range (|a − Φ_s| ≥ 2πg) the reset fraction is held at 1.
        """
        x = self.gain * self.amplitude_v
        rail, fs, lsb = self.rail_v, self.full_scale_v, self.lsb_v

        def f(p: float) -> float:
            v = x * math.sin(p)
            if rail:
                v = rail * math.tanh(v / rail)
            if fs:
                v = min(max(v, -fs), fs)
            return v / lsb

        f0 = f(a)
        if self.eps2pi == 0.0:
            return f0 + word
        feedback = a - phi
        r = min(abs(feedback) / (2.0 * math.pi * self.g), 1.0)
        return (1.0 - r) * f0 + r * f(a - math.copysign(self.eps2pi, feedback)) + word

    @property
    def phase_rate_per_word(self) -> float:
        """The c = k_i·g·δ/(2τ): da/dt of the averaged loop per unit of mean error, rad/s."""
        return self.k_i * self.g * self.delta_rad / (2.0 * self.tau_s)

    def output_rate_counts_s(self, sagnac_phase_rad: FloatArray | float,
                             phase_error_rad: FloatArray | float) -> FloatArray:
        """Balanced output rate y = (Φ_s − a)/(2πτ·g), counts/s (one count = 2π of Φ_f)."""
        return ((np.asarray(sagnac_phase_rad) - np.asarray(phase_error_rad))
                / (2.0 * math.pi * self.tau_s * self.g))

    def loop_time_constant_s(self, balance_slope: FloatArray | float) -> FloatArray:
        """First-order time constant of the loop about a balance point, s.

        One 2τ period maps the staircase-height error e to (1 − k_i·G'·g·δ)·e, so the
        time constant is −2τ / ln(1 − k_i·G'·g·δ).
        """
        beta = self.k_i * np.asarray(balance_slope, np.float64) * self.g * self.delta_rad
        beta = np.clip(beta, 1e-12, 1.0 - 1e-12)
        return -2.0 * self.tau_s / np.log1p(-beta)

