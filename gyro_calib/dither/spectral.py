"""The paper's one-orientation spectral method (seed 003, eqs. 1–5), kept for comparison.

The paper mounts the gyro once, with the vibration table axis along Z, takes the spectrum
of the gyro rate and reads the line heights: the dither line B at Ω_d, the table line at
Ω_z and the sidebands at Ω_d ± Ω_z, whose height it models as A·a/2 (its printed model
b = b₀ + a·cos(Ω_d·t + θ₀) folds the dither amplitude θ_d into a). The exact kinematics
(METHODS §C) give sidebands of height A·a·θ_d·|sin ψ₀|/2: one orientation sees only
a·|sin ψ₀|, so its error depends on the mounting azimuth ψ₀.

This implementation follows the paper's procedure — a windowed FFT of the rate, peak
heights read off bins (flat-top window, so the heights are amplitude-correct to ~0.01 dB),
θ_d from the dither line B/Ω_d — and reports 2·S̄/(A·θ_d), i.e. it applies θ_d as METHODS
§C requires. The paper's literal formula 2·S̄/A is also returned (``paper_literal_rad``,
with K): it is smaller than a·|sin ψ₀| by the factor θ_d (≈ 1/570 at θ_d = 6′).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.signal.windows import flattop

from gyro_calib.errors import InsufficientDataError
from gyro_calib.units import NS_PER_S

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


@dataclass(frozen=True, slots=True)
class SpectralResult:
    """Line heights read off the spectrum and the one-orientation misalignment.

    Attributes:
        misalignment_rad: 2·S̄/(A·θ_d): what the one-orientation method takes for a (it is
            a·|sin ψ₀| for the table along Z), rad.
        paper_literal_rad: 2·S̄·K/A, the paper's printed model (NaN without K), rad.
        sideband_rates_pulses_s: rate heights at f_d − f_z and f_d + f_z, pulses/s.
        dither_rate_pulses_s: B, rate height of the dither line, pulses/s.
        dither_frequency_hz: bin frequency of the dither line, Hz.
        table_frequency_hz: bin frequency of the table line in joint_states, Hz.
        table_rate_amplitude_rad_s: A, from the table angle line, rad/s.
    """

    misalignment_rad: float
    paper_literal_rad: float
    sideband_rates_pulses_s: tuple[float, float]
    dither_rate_pulses_s: float
    dither_frequency_hz: float
    table_frequency_hz: float
    table_rate_amplitude_rad_s: float


def _amplitude_spectrum(values: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    window = flattop(len(values), sym=False)
    spec = np.abs(np.fft.rfft((values - values.mean()) * window)) * 2.0 / window.sum()
    return np.fft.rfftfreq(len(values), 1.0 / fs), spec


def _peak(freqs: np.ndarray, spec: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    inside = np.nonzero((freqs >= lo) & (freqs <= hi))[0]
    if not len(inside):
        raise InsufficientDataError(f'no spectrum bin between {lo:.1f} and {hi:.1f} Hz.')
    k = int(inside[np.argmax(spec[inside])])
    return float(freqs[k]), float(spec[k])


def spectral_misalignment(pulse_t_ns: ArrayLike, counts: ArrayLike, table_t_ns: ArrayLike,
                          table_angle_rad: ArrayLike, *,
                          scale_factor_rad_per_pulse: float = math.nan,
                          dither_band_hz: tuple[float, float] = (250.0, 650.0),
                          table_band_max_hz: float = 200.0) -> SpectralResult:
    """One-orientation spectral estimate of the dither-axis misalignment (module docstring).

    Args:
        pulse_t_ns: /gyro/pulses stamps (uniform), int ns.
        counts: cumulative counts.
        table_t_ns: /vibration_table/joint_states stamps (uniform), int ns.
        table_angle_rad: table angle, rad.
        scale_factor_rad_per_pulse: K (only for ``paper_literal_rad``).
        dither_band_hz: where the dither line is searched, Hz.
        table_band_max_hz: highest vibration frequency searched, Hz.

    Raises:
        InsufficientDataError: with fewer than 1024 samples.
    """
    t = np.asarray(pulse_t_ns, dtype=np.int64)
    n = np.asarray(counts, dtype=np.float64)
    if len(t) < 1024:
        raise InsufficientDataError(f'{len(t)} pulse samples; the spectral method needs ≥ 1024.')
    fs = (len(t) - 1) * NS_PER_S / float(t[-1] - t[0])
    rate = np.diff(n) * fs  # pulses/s at the midpoints
    freqs, spec = _amplitude_spectrum(rate, fs)
    # a first difference scales a line at f by sin(π f/f_s)/(π f/f_s): undo it
    response = np.sinc(freqs / fs)
    spec = spec / np.where(response > 1e-3, response, 1.0)
    fd, b = _peak(freqs, spec, *dither_band_hz)
    tt = np.asarray(table_t_ns, dtype=np.int64)
    fs_t = (len(tt) - 1) * NS_PER_S / float(tt[-1] - tt[0])
    f_t, spec_t = _amplitude_spectrum(np.asarray(table_angle_rad, dtype=np.float64), fs_t)
    fz, amp_angle = _peak(f_t, spec_t, 2.0 * fs_t / len(tt), min(table_band_max_hz, fs_t / 2))
    table_rate = 2 * math.pi * fz * amp_angle
    bin_hz = freqs[1] - freqs[0]
    sidebands = tuple(_peak(freqs, spec, f - 3 * bin_hz, f + 3 * bin_hz)[1]
                      for f in (fd - fz, fd + fz))
    theta_d_pulses = b / (2 * math.pi * fd)
    mean_sb = 0.5 * (sidebands[0] + sidebands[1])
    literal = 2 * mean_sb * scale_factor_rad_per_pulse / table_rate
    return SpectralResult(2 * mean_sb / (table_rate * theta_d_pulses), literal,
                          (float(sidebands[0]), float(sidebands[1])), b, fd, fz, table_rate)
