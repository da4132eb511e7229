"""Settings of the dither-axis misalignment calibration: one frozen dataclass, validated once."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from gyro_calib.config import check_ranges, settings_from_mapping
from gyro_calib.errors import ConfigError

ROCKING_TREATMENTS = ('bound', 'model', 'none')
ROCKING_MODELS = ('proportional', 'components')


@dataclass(frozen=True, slots=True)
class DitherSettings:
    """How records are cut, fitted and judged (METHODS §C)."""

    scale_factor_rad_per_pulse: float = math.nan
    """K, rad/pulse (NaN = unknown: θ_d is then reported in pulses, and what needs θ_d in rad —
    the rocking bound, the dither × rocking coning — says it needs K)."""
    block_s: float = 2.0
    """Length of the blocks the record is reduced in, s (each fits its own dither and table
    lines; the vibration frequency must be ≥ 3 lines apart, 3/block_s Hz)."""
    table_harmonics: int = 2
    """Harmonics of the vibration frequency fitted in the table motion and carried as lines."""
    dither_band_min_hz: float = 250.0
    """Lowest dither frequency searched for, Hz."""
    dither_band_max_hz: float = 650.0
    """Highest dither frequency searched for, Hz (with the vibration frequency, sets the
    sample rate the record needs: more than 2·(this + f_z))."""
    table_band_max_hz: float = 200.0
    """Highest vibration frequency searched for in joint_states, Hz."""
    min_dither_amplitude_pulses: float = 20.0
    """A dither line weaker than this is no dither (a stripped output keeps at most a small
    residual, which would scale the misalignment wrongly), pulses."""
    min_table_rate_amplitude_rad_s: float = 1e-3
    """A table moving less than this is not vibrating, rad/s."""
    min_line_separation_hz: float = 2.0
    """Closest a sideband f_d ± f_z may come to another modelled line, Hz (at least 3/block_s)."""
    max_gap_s: float = 0.02
    """Largest gap between samples (pulses or joint_states) inside a block, s."""
    max_residual_rms_pulses: float = 2.0
    """A block whose count deviates from the fitted lines by more (rms) is rejected, pulses
    (quantisation alone gives 0.29)."""
    min_blocks: int = 5
    """Blocks below which a component's note says its block-scatter check is weak (the
    component is reported all the same, with its interval)."""
    angle_random_walk_deg_sqrt_h: float = 0.0
    """N of the gyro for the predicted floor, °/√h (0 = quantisation only; RLG ARW adds
    ~1e-5 of the variance)."""
    max_misalignment_arcmin: float = 5.0
    """Acceptance limit on a, arcmin (the paper's)."""
    verdict_coverage_factor: float = 2.0
    """k: a verdict needs |a − limit| ≥ k·u(a)."""
    rocking_treatment: str = 'bound'
    """Transverse rocking in phase with the dither shifts each component by θ_r/θ_d (docs/
    methods.md §C.5): ``'bound'`` carries the allowance as an interval on a,
    a ∈ [(â − kσ)/(1 + ρ), (â + kσ)/(1 − ρ)], ρ = √2·k/θ_d (needs K; unbounded without it);
    ``'model'`` subtracts the in-phase rocking given below; ``'none'`` ignores it."""
    rocking_model: str = 'proportional'
    """Rocking amplitude model for the bound and for coning: ``'proportional'``
    (θ_xz,max = θ_xy,max = k·a, the paper's eq. (24)) or ``'components'``
    (k·a·|cos ψ₀|, k·a·|sin ψ₀|: ε ∝ a²·|sin 2ψ₀|/2)."""
    rocking_arcsec_per_arcmin: float = 1.0 / 35.0
    """k: rocking amplitude per unit misalignment at this gyro's dither amplitude, ″ per ′
    (paper: 1″ at 35′, at its own dither amplitude, lost from its Table 1; the rocking is
    driven by the dither torque, so it scales with θ_d too)."""
    rocking_phase_rad: float = math.nan
    """φ between θ_xy and θ_xz, rad (NaN = unknown: worst case sin φ = 1)."""
    rocking_in_phase_xz_arcsec: float = 0.0
    """``'model'`` only: measured rocking about case Y in phase with the dither, ″ (signed:
    positive turns the cavity right-handed about +Y while the dither angle is positive)."""
    rocking_in_phase_xy_arcsec: float = 0.0
    """``'model'`` only: measured rocking about case Z in phase with the dither, ″ (signed)."""
    restart_backstep_s: float = 1.0
    """A stamp this far before the newest one means the source restarted, s."""
    stall_timeout_s: float = 300.0
    """A stream whose stamps stop while the other's advance this far is dead: the blocks it
    left open are judged with what is there, s."""
    spectrum_samples: int = 4096
    """FFT length of the averaged spectrum kept for the plot (a power of two)."""
    target_std_arcmin: float = math.nan
    """σ per component that ``gyro-calib info`` plans the record for, arcmin (NaN = half the
    acceptance limit at the coverage factor: max_misalignment_arcmin / (2·k))."""

    def __post_init__(self) -> None:
        """Validate every field once; raise ConfigError naming the field."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            kinds: dict[str, type | tuple[type, ...]] = {
                'int': int, 'float': (int, float), 'str': str}
            kind = kinds[str(f.type)]
            if isinstance(value, bool) or not isinstance(value, kind):
                raise ConfigError(f'{f.name} = {value!r} is invalid: it must be '
                                  f'{"an integer" if kind is int else "a " + str(f.type)}.')
        k_ok = math.isnan(self.scale_factor_rad_per_pulse) or (
            0 < self.scale_factor_rad_per_pulse < 1e-2)
        checks: list[tuple[str, bool, str]] = [
            ('scale_factor_rad_per_pulse', k_ok, 'NaN (unknown) or between 0 and 0.01 rad/pulse'),
            ('block_s', 0.1 <= self.block_s <= 600, 'between 0.1 and 600 s'),
            ('table_harmonics', 1 <= self.table_harmonics <= 8, 'between 1 and 8'),
            ('dither_band_min_hz', self.dither_band_min_hz > 0, 'positive'),
            ('dither_band_max_hz', self.dither_band_max_hz > self.dither_band_min_hz,
             'above dither_band_min_hz'),
            ('table_band_max_hz', self.table_band_max_hz > 0, 'positive'),
            ('min_dither_amplitude_pulses', self.min_dither_amplitude_pulses > 0, 'positive'),
            ('min_table_rate_amplitude_rad_s', self.min_table_rate_amplitude_rad_s > 0,
             'positive'),
            ('min_line_separation_hz', self.min_line_separation_hz > 0, 'positive'),
            ('max_gap_s', self.max_gap_s > 0, 'positive'),
            ('max_residual_rms_pulses', self.max_residual_rms_pulses > 0, 'positive'),
            ('min_blocks', self.min_blocks >= 2, 'at least 2 (a scatter check needs two)'),
            ('angle_random_walk_deg_sqrt_h', self.angle_random_walk_deg_sqrt_h >= 0,
             'zero or positive'),
            ('max_misalignment_arcmin', self.max_misalignment_arcmin > 0, 'positive'),
            ('verdict_coverage_factor', self.verdict_coverage_factor > 0, 'positive'),
            ('rocking_treatment', self.rocking_treatment in ROCKING_TREATMENTS,
             f'one of {", ".join(ROCKING_TREATMENTS)}'),
            ('rocking_model', self.rocking_model in ROCKING_MODELS,
             f'one of {", ".join(ROCKING_MODELS)}'),
            ('rocking_arcsec_per_arcmin', self.rocking_arcsec_per_arcmin >= 0,
             'zero or positive'),
            ('rocking_phase_rad', math.isnan(self.rocking_phase_rad)
             or abs(self.rocking_phase_rad) <= 2 * math.pi, 'NaN (unknown) or within ±2π'),
            ('rocking_in_phase_xz_arcsec', math.isfinite(self.rocking_in_phase_xz_arcsec),
             'finite'),
            ('rocking_in_phase_xy_arcsec', math.isfinite(self.rocking_in_phase_xy_arcsec),
             'finite'),
            ('restart_backstep_s', self.restart_backstep_s > 0, 'positive'),
            ('stall_timeout_s', self.stall_timeout_s > 0, 'positive'),
            ('target_std_arcmin', math.isnan(self.target_std_arcmin)
             or self.target_std_arcmin > 0, 'NaN (half the limit at k) or positive'),
            ('spectrum_samples', self.spectrum_samples >= 256
             and self.spectrum_samples & (self.spectrum_samples - 1) == 0,
             'a power of two ≥ 256'),
        ]
        check_ranges(self, checks)  # one range check for every setting
        if self.rocking_treatment == 'model' and math.isnan(self.scale_factor_rad_per_pulse):
            raise ConfigError("rocking_treatment = 'model' needs scale_factor_rad_per_pulse: "
                              'the rocking is given in arcseconds and the dither amplitude '
                              'is measured in pulses.')

    @property
    def has_scale_factor(self) -> bool:
        """True if K is known."""
        return not math.isnan(self.scale_factor_rad_per_pulse)

    @property
    def rocking_per_misalignment(self) -> float:
        """The k as a ratio, rad of rocking per rad of misalignment."""
        return self.rocking_arcsec_per_arcmin / 60.0

    @property
    def target_std_rad(self) -> float:
        """The σ per component ``gyro-calib info`` plans for, rad."""
        arcmin = (self.max_misalignment_arcmin / (2.0 * self.verdict_coverage_factor)
                  if math.isnan(self.target_std_arcmin) else self.target_std_arcmin)
        return math.radians(arcmin / 60.0)

    @property
    def line_separation_hz(self) -> float:
        """Effective minimum separation of modelled lines, Hz."""
        return max(self.min_line_separation_hz, 3.0 / self.block_s)


def dither_settings_from_mapping(values: Mapping[str, Any], *,
                                 source: str = 'mapping') -> DitherSettings:
    """DitherSettings from a mapping (a YAML file, ROS parameters), rejecting unknown keys.

    Integers are taken for float fields (YAML ``block_s: 2``).

    Raises:
        ConfigError: an unknown field or an invalid value, naming the field and ``source``.
    """
    return settings_from_mapping(DitherSettings, values, source=source)
