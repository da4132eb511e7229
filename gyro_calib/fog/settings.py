"""Settings of the FOG calibration: one frozen dataclass, validated once (METHODS §B).

The attribute docstrings become the ROS parameter descriptions of the FOG node.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from gyro_calib.config import check_ranges, settings_from_mapping
from gyro_calib.errors import ConfigError


@dataclass(frozen=True, slots=True)
class FogSettings:
    """How segments, plateaus and fits are cut and judged."""

    latitude_deg: float = math.nan
    """Site latitude, ° (NaN = not given: the bias is reported with the Earth rate in it,
    under fog_bias_plus_earth_rate_rad_s)."""
    segment_rate_tolerance: float = 2e-4
    """Allowed relative deviation of the table rate from its segment's mean rate."""
    segment_rate_floor_deg_s: float = 1e-3
    """Absolute floor of that tolerance, °/s (rules near zero rate)."""
    min_segment_s: float = 5.0
    """Shortest constant-rate span (after the guards) used as a turntable point, s."""
    segment_guard_s: float = 0.5
    """Time left out after an acceleration ends and before the next begins, s."""
    max_excursion_s: float = 30.0
    """A departure from a constant rate that returns to the same rate within this time, with
    no other constant rate in between, is a rate excursion: the segment is rejected, s."""
    index_angle_tolerance_deg: float = 0.5
    """Zero-index events farther than this from the segment's reference mark are spurious, °."""
    max_sense_axis_tilt_deg: float = 0.1
    """Bound on the sense-axis tilt from the table axis, °; bounds the horizontal Earth-rate
    residual of segments without whole revolutions between zero-index events."""
    fit_half_width_s: float = 0.1
    """Half-width of the local line fit that gives the count at an instant, s."""
    min_fit_samples: int = 10
    """Output samples needed in a local fit."""
    min_fit_transitions: float = 8.0
    """A local fit seeing fewer count transitions is widened (slow outputs), up to..."""
    max_fit_half_width_s: float = 1.0
    """...this half-width, s."""
    max_fit_residual_counts: float = 5.0
    """Largest rms residual of a local fit before the span is rejected, counts."""
    noise_blocks: int = 10
    """Blocks a segment or plateau is cut into to measure its noise (Type A)."""
    min_block_s: float = 0.5
    """Shortest noise block, s."""
    unsteady_noise_ratio: float = 25.0
    """A segment whose block scatter (its angle-random-walk estimate, less the most the count
    quantisation can add) exceeds this multiple of the median of the other segments' did not
    see a steady output (an unrecorded injection, a loop disturbance): it is rejected. Needs
    three or more segments."""
    min_turntable_rates: int = 3
    """Distinct table rates needed for the turntable least squares."""
    mapping_rates_deg_s: tuple[float, ...] = (20.0, 20.01, 20.1, 21.0)
    """Table rates of the equivalence mapping, °/s (seed 001 §3)."""
    mapping_rate_tolerance_deg_s: float = 0.003
    """A segment within this of a mapping rate belongs to the mapping, °/s."""
    static_rate_tolerance_deg_s: float = 0.01
    """|table rate| up to which the base counts as static for self-calibration, °/s."""
    min_plateau_settled_s: float = 1.0
    """Settled time a plateau must leave after the output has settled, s."""
    settle_threshold_sigma: float = 5.0
    """An output-rate cell farther than this many σ (robust scatter, at least the count
    quantisation) from the plateau's final level is still settling."""
    plateau_drift_sigma: float = 6.0
    """A plateau whose output rate differs between the halves of its settled part by more
    than this many σ..."""
    plateau_drift_fraction: float = 1e-4
    """...and by more than this fraction of the largest |injection| so far was not held."""
    min_response_ratio: float = 0.5
    """Smallest accepted (output change)/(injection change) against the reference plateau."""
    max_response_ratio: float = 5.0
    """Largest accepted (output change)/(injection change) against the reference plateau."""
    self_cal_nonlinearity_spec_ppm: float = 100.0
    """IEEE nonlinearity allowed over the self-calibration's linear range, ppm."""
    min_plateaus: int = 3
    """Plateaus (with at least two injection levels) a self-calibration fit needs."""
    cell_s: float = 0.05
    """Output samples are reduced to least-squares sums per cell of this length, s."""
    reorder_margin_s: float = 0.5
    """Output samples are reduced this far behind the newest stamp (later ones are late), s."""
    stream_lag_s: float = 30.0
    """How far the output stream runs past a segment or plateau before it is measured with
    the zero-index and injection messages there are, s (a lag allowance for rare streams)."""
    restart_backstep_s: float = 1.0
    """A stamp this far before the newest one means the source restarted, s."""

    def __post_init__(self) -> None:
        """Validate every field once; raise ConfigError naming the field."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == 'mapping_rates_deg_s':
                if not isinstance(value, tuple) or not all(
                        isinstance(v, (int, float)) and not isinstance(v, bool)
                        and math.isfinite(v) for v in value):
                    raise ConfigError(f'{f.name} = {value!r} is invalid: it must be a tuple '
                                      f'of finite numbers (°/s).')
                continue
            want_int = f.type in ('int', int)
            if isinstance(value, bool) or not isinstance(value, int if want_int else (int, float)):
                kind = 'an integer' if want_int else 'a number'
                raise ConfigError(f'{f.name} = {value!r} is invalid: it must be {kind}.')
            if f.name != 'latitude_deg' and not math.isfinite(value):
                raise ConfigError(f'{f.name} = {value!r} is invalid: it must be finite.')
        checks: list[tuple[str, bool, str]] = [
            ('latitude_deg', math.isnan(self.latitude_deg) or -90 <= self.latitude_deg <= 90,
             'NaN or between -90 and 90'),
            ('segment_rate_tolerance', 0 < self.segment_rate_tolerance < 0.1,
             'between 0 and 0.1'),
            ('segment_rate_floor_deg_s', self.segment_rate_floor_deg_s > 0, 'positive'),
            ('min_segment_s', self.min_segment_s > 0, 'positive'),
            ('segment_guard_s', self.segment_guard_s >= self.fit_half_width_s,
             'at least fit_half_width_s'),
            ('max_excursion_s', self.max_excursion_s > 0, 'positive'),
            ('index_angle_tolerance_deg', 0 < self.index_angle_tolerance_deg < 90,
             'between 0 and 90'),
            ('max_sense_axis_tilt_deg', 0 <= self.max_sense_axis_tilt_deg < 90,
             'between 0 and 90'),
            ('fit_half_width_s', self.fit_half_width_s > 0, 'positive'),
            ('min_fit_samples', self.min_fit_samples >= 3, 'at least 3'),
            ('min_fit_transitions', self.min_fit_transitions >= 0, 'at least 0'),
            ('max_fit_half_width_s', self.max_fit_half_width_s >= self.fit_half_width_s,
             'at least fit_half_width_s'),
            ('max_fit_residual_counts', self.max_fit_residual_counts > 0, 'positive'),
            ('noise_blocks', self.noise_blocks >= 2, 'at least 2'),
            ('min_block_s', self.min_block_s > 0, 'positive'),
            ('unsteady_noise_ratio', self.unsteady_noise_ratio > 1, 'greater than 1'),
            ('min_turntable_rates', self.min_turntable_rates >= 2, 'at least 2'),
            ('mapping_rate_tolerance_deg_s', self.mapping_rate_tolerance_deg_s > 0, 'positive'),
            ('static_rate_tolerance_deg_s', self.static_rate_tolerance_deg_s > 0, 'positive'),
            ('min_plateau_settled_s', self.min_plateau_settled_s > 0, 'positive'),
            ('settle_threshold_sigma', self.settle_threshold_sigma > 0, 'positive'),
            ('plateau_drift_sigma', self.plateau_drift_sigma > 0, 'positive'),
            ('plateau_drift_fraction', self.plateau_drift_fraction >= 0, 'at least 0'),
            ('min_response_ratio', 0 < self.min_response_ratio < 1, 'between 0 and 1'),
            ('max_response_ratio', self.max_response_ratio > 1, 'greater than 1'),
            ('self_cal_nonlinearity_spec_ppm', self.self_cal_nonlinearity_spec_ppm > 0,
             'positive'),
            ('min_plateaus', self.min_plateaus >= 3, 'at least 3'),
            ('cell_s', 0 < self.cell_s <= self.fit_half_width_s, 'positive, at most '
             'fit_half_width_s'),
            ('reorder_margin_s', self.reorder_margin_s >= 0, 'at least 0'),
            ('stream_lag_s', self.stream_lag_s >= 0, 'at least 0'),
            ('restart_backstep_s', self.restart_backstep_s > self.reorder_margin_s,
             'greater than reorder_margin_s'),
        ]
        check_ranges(self, checks)  # one range check for every setting
        mapped = sorted(self.mapping_rates_deg_s)
        if any(b - a <= 2 * self.mapping_rate_tolerance_deg_s for a, b in zip(mapped, mapped[1:])):
            raise ConfigError('mapping_rates_deg_s must be more than twice '
                              'mapping_rate_tolerance_deg_s apart.')

    @property
    def latitude_known(self) -> bool:
        """True when a site latitude was given."""
        return not math.isnan(self.latitude_deg)


def fog_settings_from_mapping(values: dict[str, Any], *, source: str = 'mapping') -> FogSettings:
    """Build FogSettings from a mapping (YAML, ROS parameters), rejecting unknown keys."""
    kwargs = dict(values)
    if 'mapping_rates_deg_s' in kwargs and isinstance(kwargs['mapping_rates_deg_s'], list):
        kwargs['mapping_rates_deg_s'] = tuple(kwargs['mapping_rates_deg_s'])
    return settings_from_mapping(FogSettings, kwargs, source=source)
