"""Parameters of the closed-loop digital fibre-optic gyro simulator (METHODS §B, seed 001).

Defaults describe a 1 km, 10 cm coil at 1550 nm whose front end (pre-amplifier gain)
and self-calibration mapping error were fitted to the paper's Table 1 with
:func:`sim_nodes.fog.paper.fit_front_end_to_table1` (see that module for the fit and
its residuals). Every error source is switched off by setting it to zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gyro_calib.units import EARTH_RATE_DEG_H

SPEED_OF_LIGHT_M_S = 299_792_458.0
"""Speed of light in vacuum, m/s."""


@dataclass(frozen=True, slots=True)
class FogConfig:
    """Closed-loop digital FOG, its mount on the table, and the site."""

    # -- optics -------------------------------------------------------------------------------
    coil_length_m: float = 1000.0
    """L: fibre length of the sensing coil, m."""
    coil_diameter_m: float = 0.1
    """D: mean coil diameter, m."""
    wavelength_m: float = 1.55e-6
    """λ: mean source wavelength in vacuum, m."""
    group_index: float = 1.468
    """Group index of the fibre (sets the transit time τ = n·L/c)."""
    # -- detector, pre-amplifier, ADC -------------------------------------------------------
    detector_amplitude_v: float = 0.1
    """A: interference amplitude at the detector output, I = A·(1 + cos ΔΦ), V."""
    preamp_gain: float = 19.25515
    """G: small-signal gain of the AC-coupled pre-amplifier (fitted to Table 1)."""
    preamp_saturation_v: float = 5.0
    """Pre-amplifier rail: output = V_sat·tanh(G·x / V_sat), V (0 = ideal linear amplifier)."""
    adc_full_scale_v: float = 2.0
    """ADC input range ±full scale; inputs beyond it clip, V (0 = no clipping)."""
    adc_bits: int = 12
    """ADC resolution over ±full scale, bits (0 = unquantised; needs adc_full_scale_v > 0)."""
    # -- digital loop, DAC, Y-waveguide ---------------------------------------------------
    dac_bits: int = 16
    """N: bits of the staircase (ramp) word; 2^N LSB = one 2π of feedback phase."""
    integrator_gain: float = 0.125
    """k_i: staircase-height change per ADC code of demodulated error (per 2τ period)."""
    y_waveguide_gain_error: float = 0.002
    """ε: relative error of the DAC × Y-waveguide phase gain (a 2π reset gives 2π(1 + ε))."""
    injection_gain_error: float = 0.0072885
    """Error of the front-end gain the FPGA assumes when it scales a requested injection into
    an error-path word: a small injection J moves the output by J·(1 + this). The paper's
    equivalence mapping assumes 0 (internal = external digital quantity); fitted to Table 1."""
    # -- sensor errors ------------------------------------------------------------------------
    bias_deg_h: float = 0.5
    """Constant rate bias along the sense axis, °/h."""
    angle_random_walk_deg_sqrt_h: float = 0.005
    """ARW N from detector noise (referred to the input at null), °/√h."""
    scale_factor_asymmetry_ppm: float = 0.0
    """a: IEEE Std 952 asymmetry; input rate ω becomes ω·(1 + a/2·sign ω), ppm."""
    scale_factor_quadratic_s_per_rad: float = 0.0
    """k₂: the sensed rate gains k₂·ω², s/rad."""
    scale_factor_cubic_s2_per_rad2: float = 0.0
    """k₃: the sensed rate gains k₃·ω³, s²/rad²."""
    # -- mount and site -----------------------------------------------------------------------
    sense_axis_tilt_deg: float = 0.02
    """Angle between the sense axis and the table axis, °."""
    sense_axis_azimuth_deg: float = 30.0
    """Azimuth of the sense axis's tilt on the table top, from oX at table angle 0, °."""
    latitude_deg: float = 45.75
    """Site latitude, ° (Harbin, where the paper's gyro was tested)."""
    table_heading_deg: float = 0.0
    """Angle from East to the table-base oX axis, counter-clockwise about Up, °."""
    earth_rate_deg_h: float = EARTH_RATE_DEG_H
    """Earth rotation rate, °/h (0 switches Earth rate off)."""
    # -- output ---------------------------------------------------------------------------------
    quantise_output: bool = True
    """Emit whole counts (one count = 2π of digital feedback phase, fraction carried);
    False emits the fractional count."""
    seed: int = 1
    """Seed of the gyro's random stream (detector noise / ARW, initial count fraction)."""

    def __post_init__(self) -> None:
        """Reject parameters that make no physical sense."""
        positive = ('coil_length_m', 'coil_diameter_m', 'wavelength_m', 'group_index',
                    'detector_amplitude_v', 'preamp_gain', 'integrator_gain')
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f'{name} = {getattr(self, name)!r} must be positive')
        for name in ('preamp_saturation_v', 'adc_full_scale_v', 'angle_random_walk_deg_sqrt_h'):
            if not getattr(self, name) >= 0:
                raise ValueError(f'{name} = {getattr(self, name)!r} must be >= 0')
        if self.adc_bits < 0 or (self.adc_bits and not self.adc_full_scale_v):
            raise ValueError('adc_bits must be >= 0, and > 0 only with adc_full_scale_v > 0')
        if not 4 <= self.dac_bits <= 30:
            raise ValueError('dac_bits must be between 4 and 30')
        if not -0.2 < self.y_waveguide_gain_error < 0.2:
            raise ValueError('y_waveguide_gain_error must lie within ±0.2')

    # -- derived quantities -------------------------------------------------------------------
    @property
    def transit_time_s(self) -> float:
        """τ = n·L/c: light transit time through the coil, s (half the bias period)."""
        return self.group_index * self.coil_length_m / SPEED_OF_LIGHT_M_S

    @property
    def sagnac_scale_rad_per_rad_s(self) -> float:
        """2πLD/(λc): Sagnac phase per unit rotation rate, rad per rad/s (eq. 1)."""
        return (2.0 * math.pi * self.coil_length_m * self.coil_diameter_m
                / (self.wavelength_m * SPEED_OF_LIGHT_M_S))

    @property
    def scale_factor_counts_per_rad(self) -> float:
        """K = D/(n·λ): output counts per radian turned (one count = 2π of feedback phase)."""
        return self.sagnac_scale_rad_per_rad_s / (2.0 * math.pi * self.transit_time_s)

    @property
    def phase_lsb_rad(self) -> float:
        """δ = 2π/2^N: nominal feedback phase of one staircase LSB, rad."""
        return 2.0 * math.pi / 2**self.dac_bits

    @property
    def adc_lsb_v(self) -> float:
        """ADC step, V (0 when unquantised)."""
        return 2.0 * self.adc_full_scale_v / 2**self.adc_bits if self.adc_bits else 0.0

    @property
    def error_scale_v(self) -> float:
        """Volts per unit of demodulated error (the ADC LSB, or 1 mV when unquantised)."""
        return self.adc_lsb_v or 1e-3

    @property
    def front_end_gain_per_rad(self) -> float:
        """κ = G·A / LSB: small-signal demodulated error per radian of optical phase error."""
        return self.preamp_gain * self.detector_amplitude_v / self.error_scale_v

    @property
    def detector_noise_v(self) -> float:
        """σ_I per τ sample such that the loop's output shows the configured ARW, V.

        At null a phase error φ gives A·φ of intensity; white phase noise σ_φ per τ gives
        an angle random walk N = σ_φ·√τ / (2πLD/λc), so σ_I = A·N·(2πLD/λc)/√τ.
        """
        n_rad_sqrt_s = math.radians(self.angle_random_walk_deg_sqrt_h) / 60.0
        return (self.detector_amplitude_v * n_rad_sqrt_s * self.sagnac_scale_rad_per_rad_s
                / math.sqrt(self.transit_time_s))

    @property
    def bias_rad_s(self) -> float:
        """Rate bias, rad/s."""
        return math.radians(self.bias_deg_h) / 3600.0

    @property
    def angle_random_walk_rad_sqrt_s(self) -> float:
        """ARW, rad/√s."""
        return math.radians(self.angle_random_walk_deg_sqrt_h) / 60.0

    def earth_rate_base_rad_s(self) -> tuple[float, float, float]:
        """Earth-rate vector in the table-base frame (oZ up), rad/s."""
        w = math.radians(self.earth_rate_deg_h) / 3600.0
        lat = math.radians(self.latitude_deg)
        east, north, up = 0.0, w * math.cos(lat), w * math.sin(lat)
        h = math.radians(self.table_heading_deg)
        c, s = math.cos(h), math.sin(h)
        return (c * east + s * north, -s * east + c * north, up)
