"""Settings of noise characterisation: one frozen dataclass, validated once.

The same :class:`NoiseSettings` serves the CLI (``gyro-calib noise``), the noise node (ROS
parameters: the attribute docstrings are their descriptions) and the tests.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from gyro_calib.config import check_ranges
from gyro_calib.errors import ConfigError
from gyro_calib.noise.outliers import OUTLIER_MODES

TABLE_REFERENCES = ('gyro', 'gyro_minus_table')
"""What the noise of a gyro on a turning table is computed from (``table_reference``)."""


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
    taus: str = 'default'
    """The τ grid: 'default' (every octave m = 2^k and the decades τ = 10^k s), 'octave'
    (m = 2^k), 'decade' (τ = 1, 2, 4 × 10^k s), 'all' (every m), or a list of averaging
    times in s ("1, 10, 100" or a YAML list). Every τ is computed with full overlap."""
    taus_per_octave: int = 1
    """Log-spaced averaging times per octave of the 'default' grid (1 = octave points
    only; each point costs one pass over the record)."""
    deviations: str = 'adev, mdev, hdev, totdev'
    """Statistics computed at every τ besides the overlapping ADEV (always): mdev
    (modified), hdev (overlapping Hadamard), totdev (total); comma-separated."""
    overlap: str = 'full'
    """'full': exact full overlap at every τ (NIST SP 1065 eq. 11, = allantools.oadev),
    the phase kept in a scratch file beyond ``memory_points``; 'partial': the older
    decimation tree (approximate at long τ, ADEV and TOTDEV only)."""
    memory_points: int = 1048576
    """Phase points per axis and segment held in memory; a longer segment's phase goes to a
    scratch file (8 bytes per point, deleted at the end) and memory stays bounded."""
    scratch_dir: str = ''
    """Directory of the scratch files ('' = the system's temporary directory)."""
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
    fit_min_clusters: float = 10.0
    """Leave averaging times with fewer non-overlapping clusters T/τ than this out of the
    term fit (they stay in the curve)."""
    fit_exclude_band_limited: int = 1
    """1: find the short-τ range where the curve departs from the model (a sensor's
    anti-alias/decimation filter) and leave it out of the term fit, saying so; 0: fit
    from fit_min_tau_s on."""
    total_deviation_points: int = 4096
    """Phase points kept per segment (decimated) for the total deviation at long τ; 0 = off."""
    table_rest_rate_rad_s: float = 1.0e-2
    """With /rate_table/joint_states (or /position_table/joint_states) in the record: a table
    state whose velocity differs by more than this from its steady segment's mean rate (from
    0 at rest) ends the segment, rad/s (above the one-count flicker of a rate differentiated
    from the encoder at any constant rate, 6e-3 rad/s for a 2^20-count encoder read at 1 kHz);
    the gyro samples while the table changes rate are left out."""
    table_rest_angle_rad: float = 2.0e-5
    """A table state whose encoder angle lies this far from the line fitted through its steady
    segment's angles (flat at rest) ends the segment (a rate change too slow for the rate
    test), rad (more than three counts of a 2^20-count encoder, 27 of the 2^23-count one of
    our benches)."""
    table_stamp_jitter_s: float = 1.0e-4
    """Jitter of the table states' stamps, s: a turning table's angle leaves the line by up to
    |rate|·this, so the angle tolerance grows by it (0.26 mrad at 150 °/s)."""
    table_min_steady_s: float = 1.0
    """A steady segment (constant rate, rest included) must span this long; a shorter one is
    part of the change around it (a slow acceleration can look steady for a few states), s.
    Shorter than the 1.28 s one span needs at 1 kHz for the white-noise term."""
    table_reference: str = 'gyro'
    """'gyro': the gyro's angle as it is (a constant table rate is a constant, which the Allan
    variance removes); 'gyro_minus_table': K·counts (or counts/SF) minus the rate table's
    encoder angle, interpolated at each gyro stamp, which also removes table-rate wander (the
    sense axis along the table's axis, counting the same way; /gyro/pulses and /fog/output)."""
    table_wait_s: float = 5.0
    """A sample waits at most this long (by the newest stamp) for a table state at or after
    its stamp; when the table's states stop or lag more, the last one holds for it (counted
    in the summary), s."""

    outliers: str = 'keep'
    """Spikes (METHODS §E.6): 'keep' analyses the record as recorded and reports what
    removing them would change; 'remove' replaces each by the median of its neighbours."""
    outlier_sigma: float = 8.0
    """k of the spike test |d − median| > k·1.4826·MAD (d: the rate sample, or the count's
    per-sample increment), robust standard deviations."""
    outlier_block_samples: int = 65536
    """Samples per block of the spike test (median and MAD of each block of a segment)."""

    def __post_init__(self) -> None:
        """Validate every field once; raise ConfigError naming the field."""
        from gyro_calib.noise.allan import parse_taus
        from gyro_calib.noise.exact import DEVIATIONS

        if isinstance(self.taus, (list, tuple)):
            object.__setattr__(self, 'taus', ', '.join(f'{float(v):g}' for v in self.taus))
        try:
            parse_taus(self.taus)
        except ValueError as exc:
            raise ConfigError(f'{exc}.') from None
        devs = [d.strip() for d in str(self.deviations).replace(' ', ',').split(',') if d.strip()]
        if not all(d in DEVIATIONS for d in devs):
            raise ConfigError(f'deviations = {self.deviations!r} is invalid: it must list some '
                              f'of {", ".join(DEVIATIONS)}, comma-separated.')
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
            ('memory_points', self.memory_points >= 1024, 'at least 1024'),
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
            ('fit_min_clusters', self.fit_min_clusters >= 0, 'zero or positive'),
            ('fit_exclude_band_limited', self.fit_exclude_band_limited in (0, 1), '0 or 1'),
            ('fit_max_tau_s', self.fit_max_tau_s > self.fit_min_tau_s,
             'greater than fit_min_tau_s'),
            ('total_deviation_points', self.total_deviation_points == 0
             or self.total_deviation_points >= 64, '0 (off) or at least 64'),
            ('table_rest_rate_rad_s', math.isfinite(self.table_rest_rate_rad_s)
             and self.table_rest_rate_rad_s > 0, 'positive'),
            ('table_rest_angle_rad', math.isfinite(self.table_rest_angle_rad)
             and self.table_rest_angle_rad > 0, 'positive'),
            ('table_wait_s', math.isfinite(self.table_wait_s) and self.table_wait_s >= 0,
             'zero or positive'),
            ('table_stamp_jitter_s', math.isfinite(self.table_stamp_jitter_s)
             and self.table_stamp_jitter_s >= 0, 'zero or positive'),
            ('table_min_steady_s', math.isfinite(self.table_min_steady_s)
             and self.table_min_steady_s >= 0, 'zero or positive'),
            ('table_reference', self.table_reference in TABLE_REFERENCES,
             ' or '.join(repr(r) for r in TABLE_REFERENCES)),
        ]
        checks += [
            ('outliers', self.outliers in OUTLIER_MODES,
             ' or '.join(repr(m) for m in OUTLIER_MODES)),
            ('outlier_sigma', math.isfinite(self.outlier_sigma) and self.outlier_sigma > 0,
             'a positive number of robust standard deviations (default 8)'),
            ('outlier_block_samples', self.outlier_block_samples >= 64, 'at least 64'),
        ]
        check_ranges(self, checks)  # one range check for every setting

    @property
    def tau_spec(self) -> str | tuple[float, ...]:
        """The τ grid: a name or the τ list, s."""
        from gyro_calib.noise.allan import parse_taus

        return parse_taus(self.taus)

    @property
    def deviation_names(self) -> tuple[str, ...]:
        """The statistics computed (adev always)."""
        from gyro_calib.noise.exact import DEVIATIONS

        devs = {d.strip() for d in self.deviations.replace(' ', ',').split(',')}
        return tuple(d for d in DEVIATIONS if d in devs or d == 'adev')
