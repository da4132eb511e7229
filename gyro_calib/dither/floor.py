"""Detection floor of the dither-axis misalignment: what a record can resolve (METHODS §C).

Derivation. With the table along Z, the sensed angle carries the sideband term

    s·G(t),   G(t) = ∫ω_T·φ dt = −(A·θ_d/2)·[cos(Ω₊t)/Ω₊ + cos(Ω₋t)/Ω₋],   Ω± = Ω_d ± Ω_z

(s = a·sin ψ₀; along Y, a·cos ψ₀), whose mean square is (A·θ_d)²/(4·Ω²) with
1/Ω² = ½·(1/Ω₊² + 1/Ω₋²). Least squares of the cumulative count on G, with white count
quantisation of variance K²/12 at f_s samples per second over T seconds, gives
Var(ŝ) = (K²/12)/(f_s·T·(A·θ_d)²/(4·Ω²)) = K²·Ω²/(3·f_s·T·(A·θ_d)²). Angle random walk N
(white rate noise of density N²) against the rate-domain sideband A·θ_d·s·(cos Ω₊t + cos Ω₋t)/2,
of mean square (A·θ_d)²/4, adds 4·N²/(T·(A·θ_d)²). Together, per orientation,

    σ_c = √(K²·Ω²/(3·f_s) + 4·N²) / (A·θ_d·√T)

In pulse units (K = 1, θ_d in pulses, N in pulses/√s) the same formula holds, so the floor
needs no scale factor. With both orientations measured to σ_c each, a = √(s_z² + s_y²) has
standard uncertainty σ_c too (for a ≫ σ_c, whatever ψ₀). Quantisation dominates ARW by
~10⁴ in variance on an RLG, so only the number of samples f_s·T counts: halving σ takes four
times the record or four times the sample rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gyro_calib.errors import ConfigError


@dataclass(frozen=True, slots=True)
class DetectionFloor:
    """The floor of one record (per orientation) and what it means for a.

    Attributes:
        component_std_rad: σ_c, standard uncertainty of one orientation's component, rad.
        quantisation_std_rad: the quantisation part of σ_c alone, rad.
        arw_std_rad: the angle-random-walk part of σ_c alone, rad.
        misalignment_rad: the a it was asked about (NaN if none), rad.
        snr: a / σ_c (NaN if no a was given).
    """

    component_std_rad: float
    quantisation_std_rad: float
    arw_std_rad: float
    misalignment_rad: float = math.nan
    snr: float = math.nan

    @property
    def misalignment_std_rad(self) -> float:
        """σ_a with both orientations measured at this floor (a ≫ σ_c), rad."""
        return self.component_std_rad


def effective_sideband_angular_frequency_rad_s(dither_frequency_hz: float,
                                               table_frequency_hz: float) -> float:
    """Ω with 1/Ω² = ½·(1/(Ω_d+Ω_z)² + 1/(Ω_d−Ω_z)²), rad/s (METHODS §C)."""
    wd, wz = 2 * math.pi * dither_frequency_hz, 2 * math.pi * table_frequency_hz
    if wd == wz:
        return math.inf
    return 1.0 / math.sqrt(0.5 * (1.0 / (wd + wz) ** 2 + 1.0 / (wd - wz) ** 2))


def _check_positive(**values: float) -> None:
    for name, value in values.items():
        if not (value > 0 and math.isfinite(value)):
            raise ConfigError(f'{name} = {value!r} is invalid: it must be a positive number.')


def detection_floor(*, table_rate_amplitude_rad_s: float, dither_amplitude_rad: float,
                    record_s: float, sample_rate_hz: float, scale_factor_rad_per_pulse: float,
                    angle_random_walk_rad_sqrt_s: float = 0.0,
                    dither_frequency_hz: float = 400.0, table_frequency_hz: float = 20.0,
                    misalignment_rad: float = math.nan) -> DetectionFloor:
    """σ_c = √(K²·Ω²/(3·f_s) + 4·N²) / (A·θ_d·√T) for one orientation (METHODS §C).

    Args:
        table_rate_amplitude_rad_s: A, rad/s.
        dither_amplitude_rad: θ_d, rad (or pulses, with K = 1 and N in pulses/√s).
        record_s: T, s of record in this orientation.
        sample_rate_hz: f_s of the pulse samples, Hz.
        scale_factor_rad_per_pulse: K, rad/pulse.
        angle_random_walk_rad_sqrt_s: N, rad/√s (0 = quantisation only).
        dither_frequency_hz: Ω_d/2π, Hz.
        table_frequency_hz: Ω_z/2π, Hz.
        misalignment_rad: a, rad (optional): fills in ``snr``.

    Raises:
        ConfigError: if a required argument is not a positive number.
    """
    _check_positive(table_rate_amplitude_rad_s=table_rate_amplitude_rad_s,
                    dither_amplitude_rad=dither_amplitude_rad, record_s=record_s,
                    sample_rate_hz=sample_rate_hz,
                    scale_factor_rad_per_pulse=scale_factor_rad_per_pulse,
                    dither_frequency_hz=dither_frequency_hz, table_frequency_hz=table_frequency_hz)
    omega = effective_sideband_angular_frequency_rad_s(dither_frequency_hz, table_frequency_hz)
    scale = table_rate_amplitude_rad_s * dither_amplitude_rad * math.sqrt(record_s)
    quant = math.sqrt(scale_factor_rad_per_pulse ** 2 * omega ** 2 / (3 * sample_rate_hz))
    arw = 2.0 * abs(angle_random_walk_rad_sqrt_s)
    sigma = math.hypot(quant, arw) / scale
    snr = misalignment_rad / sigma if math.isfinite(misalignment_rad) else math.nan
    return DetectionFloor(sigma, quant / scale, arw / scale, misalignment_rad, snr)


def required_record_s(target_std_rad: float, *, table_rate_amplitude_rad_s: float,
                      dither_amplitude_rad: float, sample_rate_hz: float,
                      scale_factor_rad_per_pulse: float,
                      angle_random_walk_rad_sqrt_s: float = 0.0,
                      dither_frequency_hz: float = 400.0,
                      table_frequency_hz: float = 20.0) -> float:
    """Record length per orientation for σ_c = ``target_std_rad``, s (σ_c ∝ 1/√T)."""
    _check_positive(target_std_rad=target_std_rad)
    one = detection_floor(table_rate_amplitude_rad_s=table_rate_amplitude_rad_s,
                          dither_amplitude_rad=dither_amplitude_rad, record_s=1.0,
                          sample_rate_hz=sample_rate_hz,
                          scale_factor_rad_per_pulse=scale_factor_rad_per_pulse,
                          angle_random_walk_rad_sqrt_s=angle_random_walk_rad_sqrt_s,
                          dither_frequency_hz=dither_frequency_hz,
                          table_frequency_hz=table_frequency_hz)
    return (one.component_std_rad / target_std_rad) ** 2


def required_sample_rate_hz(target_std_rad: float, *, record_s: float,
                            table_rate_amplitude_rad_s: float, dither_amplitude_rad: float,
                            scale_factor_rad_per_pulse: float,
                            angle_random_walk_rad_sqrt_s: float = 0.0,
                            dither_frequency_hz: float = 400.0,
                            table_frequency_hz: float = 20.0) -> float:
    """Pulse sample rate for σ_c = ``target_std_rad`` with ``record_s`` per orientation, Hz.

    Returns ``math.inf`` when angle random walk alone is above the target (no sample rate
    reaches it; only a longer record or a larger A·θ_d does).
    """
    _check_positive(target_std_rad=target_std_rad, record_s=record_s,
                    table_rate_amplitude_rad_s=table_rate_amplitude_rad_s,
                    dither_amplitude_rad=dither_amplitude_rad,
                    scale_factor_rad_per_pulse=scale_factor_rad_per_pulse)
    omega = effective_sideband_angular_frequency_rad_s(dither_frequency_hz, table_frequency_hz)
    budget = (target_std_rad * table_rate_amplitude_rad_s * dither_amplitude_rad) ** 2 * record_s
    quant_budget = budget - 4.0 * angle_random_walk_rad_sqrt_s ** 2
    if quant_budget <= 0:
        return math.inf
    return scale_factor_rad_per_pulse ** 2 * omega ** 2 / (3.0 * quant_budget)


def required_table_rate_amplitude_rad_s(target_std_rad: float, *, record_s: float,
                                        dither_amplitude_rad: float, sample_rate_hz: float,
                                        scale_factor_rad_per_pulse: float,
                                        angle_random_walk_rad_sqrt_s: float = 0.0,
                                        dither_frequency_hz: float = 400.0,
                                        table_frequency_hz: float = 20.0) -> float:
    """Table rate amplitude A for σ_c = ``target_std_rad`` (σ_c ∝ 1/A), rad/s."""
    _check_positive(target_std_rad=target_std_rad)
    one = detection_floor(table_rate_amplitude_rad_s=1.0,
                          dither_amplitude_rad=dither_amplitude_rad, record_s=record_s,
                          sample_rate_hz=sample_rate_hz,
                          scale_factor_rad_per_pulse=scale_factor_rad_per_pulse,
                          angle_random_walk_rad_sqrt_s=angle_random_walk_rad_sqrt_s,
                          dither_frequency_hz=dither_frequency_hz,
                          table_frequency_hz=table_frequency_hz)
    return one.component_std_rad / target_std_rad
