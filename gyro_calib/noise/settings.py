"""Settings of noise characterisation: one frozen dataclass, validated once.

The same :class:`NoiseSettings` serves the CLI (``gyro-calib noise``), the noise node (ROS
parameters: the attribute docstrings are their descriptions) and the tests.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from gyro_calib.errors import ConfigError


@dataclass(frozen=True, slots=True)
class NoiseSettings:
    """Settings of the Allan-variance analysis and the noise-term fit (METHODS §E)."""

    scale_factor_rad_per_pulse: float = math.nan
    """RLG scale factor K for ``/gyro/pulses`` (angle = K·count), rad/pulse; NaN = not given
    (then the pulse stream yields no number, only the reason)."""
    fog_scale_factor_counts_per_rad: float = math.nan
    """FOG scale factor for ``/fog/output`` (angle = count / SF), counts/rad; NaN = not given."""
    sample_rate_hz: float = 0.0
    """Nominal sample rate, Hz; 0 = learn the nominal period from the stamps (median of the
    first 256 intervals)."""
    gap_threshold_periods: float = 1.5
    """A stamp interval longer than this many nominal periods is a gap: it ends a segment."""
    taus_per_octave: int = 4
    """Log-spaced averaging times per octave (1 = octave points only)."""
    overlap: str = 'partial'
    """'partial': decimation tree, memory bounded independently of the record length
    (within 1 % of full overlap); 'full': full overlap at every τ, keeps every sample."""
    tree_min_averaging_factor: int = 512
    """Smallest averaging factor a tree level ≥ 1 computes (a power of two): the stride of
    a partial-overlap point is at most τ divided by this. The difference from full overlap
    scales as its inverse: at 512 the largest seen was 0.37 % (flicker FM, τ = T/4)."""
    max_tau_fraction: float = 0.25
    """Longest averaging time reported, as a fraction of each segment's duration."""
    reorder_window_s: float = 1.0
    """Samples arriving up to this far behind the newest stamp are sorted in; older ones are
    dropped and counted as late, s."""
    restart_backstep_s: float = 5.0
    """A stamp this far (or more) behind the newest one means the source restarted: the
    segment ends and a new timeline begins, s."""
    min_segment_samples: int = 64
    """Segments with fewer samples are left out (counted, with a reason)."""
    period_tolerance: float = 0.01
    """A segment whose mean period differs from the nominal by more than this fraction is
    left out (another sample rate)."""
    min_term_significance: float = 2.0
    """A noise term is reported only when its squared coefficient exceeds this many standard
    uncertainties."""
    edge_term_significance: float = 3.0
    """Quantisation Q (usually absent) stays in the fit only above this many standard
    uncertainties, and is reported only then."""
    ramp_term_significance: float = 5.0
    """The same for the rate ramp R, whose +1 slope rests on the last, χ²-skewed points."""
    fit_min_tau_s: float = 0.0
    """Leave shorter averaging times out of the term fit (e.g. an anti-alias filter's
    region), s."""
    fit_max_tau_s: float = math.inf
    """Leave longer averaging times out of the term fit, s."""
    total_deviation_points: int = 4096
    """Phase points kept per segment (decimated) for the total deviation at long τ; 0 = off."""

    def __post_init__(self) -> None:
        """Validate every field once; raise ConfigError naming the field."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.type in ('int', int):
                ok, kind = isinstance(value, int) and not isinstance(value, bool), 'an integer'
            elif f.type in ('str', str):
                ok, kind = isinstance(value, str), 'a string'
            else:
                ok = isinstance(value, (int, float)) and not isinstance(value, bool)
                kind = 'a number'
            if not ok:
                raise ConfigError(f'{f.name} = {value!r} is invalid: it must be {kind}.')
        k, sf = self.scale_factor_rad_per_pulse, self.fog_scale_factor_counts_per_rad
        m = self.tree_min_averaging_factor
        checks: list[tuple[str, bool, str]] = [
            ('scale_factor_rad_per_pulse', math.isnan(k) or (math.isfinite(k) and k > 0),
             'positive (or NaN: not given)'),
            ('fog_scale_factor_counts_per_rad', math.isnan(sf) or (math.isfinite(sf) and sf > 0),
             'positive (or NaN: not given)'),
            ('sample_rate_hz', math.isfinite(self.sample_rate_hz) and self.sample_rate_hz >= 0,
             'zero (learn from the stamps) or positive'),
            ('gap_threshold_periods', self.gap_threshold_periods > 1.0, 'greater than 1'),
            ('taus_per_octave', 1 <= self.taus_per_octave <= 32, 'between 1 and 32'),
            ('overlap', self.overlap in ('partial', 'full'), "'partial' or 'full'"),
            ('tree_min_averaging_factor', 2 <= m and not m & (m - 1),
             'a power of two, at least 2'),
            ('max_tau_fraction', 0.0 < self.max_tau_fraction <= 0.5, 'in (0, 0.5]'),
            ('reorder_window_s', self.reorder_window_s >= 0, 'zero or positive'),
            ('restart_backstep_s', self.restart_backstep_s > self.reorder_window_s,
             'greater than reorder_window_s'),
            ('min_segment_samples', self.min_segment_samples >= 8, 'at least 8'),
            ('period_tolerance', 0.0 < self.period_tolerance < 0.5, 'in (0, 0.5)'),
            ('min_term_significance', self.min_term_significance > 0, 'positive'),
            ('edge_term_significance', self.edge_term_significance > 0, 'positive'),
            ('ramp_term_significance', self.ramp_term_significance > 0, 'positive'),
            ('fit_min_tau_s', self.fit_min_tau_s >= 0, 'zero or positive'),
            ('fit_max_tau_s', self.fit_max_tau_s > self.fit_min_tau_s,
             'greater than fit_min_tau_s'),
            ('total_deviation_points', self.total_deviation_points == 0
             or self.total_deviation_points >= 64, '0 (off) or at least 64'),
        ]
        for name, ok, expected in checks:
            if not ok:
                raise ConfigError(f'{name} = {getattr(self, name)!r} is invalid: '
                                  f'it must be {expected}.')
