"""Settings of the thermal calibration: one frozen dataclass, validated once.

Field docstrings become ROS parameter descriptions; every unit is in the name or the
docstring. ``scale_factor_rad_per_pulse`` and ``latitude_deg`` default to NaN, "not
given" (so the settings, and a node's parameters, can be built before they are known);
:meth:`ThermalSettings.require_site` — called by the calibrator before it reads a sample
— refuses to start without them, naming the flag to give.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from gyro_calib.config import RangeCheck, check_ranges, settings_from_mapping
from gyro_calib.errors import ConfigError
from gyro_calib.thermal.intervals import IntervalSettings
from gyro_calib.thermal.terms import NAMED_SETS, candidate_terms
from gyro_calib.thermal.wavelet import THRESHOLD_MODES, THRESHOLD_RULES, WAVELETS

STYLES = ('continuous', 'soak')
_K_EXPECTED = ('a positive number: give K from the RBRLG calibration or the data sheet '
               '(--scale-factor-rad-per-pulse, or --calibration with a hand-off file that holds '
               'it; node parameter scale_factor_rad_per_pulse)')
_LATITUDE_EXPECTED = ('set to the site latitude in degrees (−90…90) so the Earth rate along '
                      'the sense axis can be removed (--latitude-deg; node parameter '
                      'latitude_deg)')
"""Calibration styles: regression on block means of the whole run, or on soak points."""
_INTERVALS = IntervalSettings()
"""The defaults of the stream-reduction fields, declared once in :class:`IntervalSettings`."""


@dataclass(frozen=True, slots=True)
class ThermalSettings:
    """Settings of the thermal bias calibration (METHODS §D)."""

    scale_factor_rad_per_pulse: float = math.nan
    """K, rad/pulse, turning pulses into rate (from the RBRLG calibration or the data sheet)."""
    latitude_deg: float = math.nan
    """Site latitude, °, for the Earth rate along the sense axis."""
    gyro_id: str = ''
    """Identity (serial) of the gyro under test, stored in the model for the identity check."""
    sense_axis_elevation_deg: float = 90.0
    """Sense axis elevation above the horizon, ° (90 = vertical)."""
    sense_axis_azimuth_deg: float = 0.0
    """Azimuth of the sense axis' horizontal part, from North towards East, °."""
    earth_rate_deg_h: float = 15.041
    """Earth rotation rate, °/h."""
    averaging_interval_s: float = _INTERVALS.averaging_interval_s
    """T: pulses and temperatures are reduced to means over intervals of this length, s."""
    hdot_window_s: float = _INTERVALS.hdot_window_s
    """Span of the causal least-squares slope that gives Ḣ, s."""
    fit_block_s: float = 10.0
    """Continuous style: the regression runs on means over blocks of this length, s."""
    calibration_style: str = 'continuous'
    """'continuous' (block means of the whole run) or 'soak' (one point per settled soak)."""
    candidate_terms: str = 'dynamic'
    """'static', 'dynamic', 'second_order' or a comma-separated list such as 'H,H^2,Hdot'."""
    max_h_power: int = 4
    """m: highest power of H in the named sets (eq. 14); stepwise keeps only the powers the
    data support (4 fits the paper's strongly non-monotonic A-1, 3 leaves 0.03 °/h)."""
    stepwise_start: str = 'full'
    """Stepwise starts from 'full' (all candidates) or 'constant'."""
    p_enter: float = 0.05
    """A candidate term enters when its F-test p-value is below this."""
    p_remove: float = 0.10
    """A term leaves when its p-value is above this (≥ p_enter)."""
    noise_max_span_s: float = 1800.0
    """Continuous style: longest averaging time at which the residuals' long-run variance is
    read from their Allan variance (covariance of autocorrelated residuals), s."""
    denoise: bool = True
    """Denoise the rate by the lifting wavelet transform before fitting."""
    wavelet: str = 'bior4.4'
    """'bior4.4' (CDF 9/7 lifting) or 'bior2.2' (CDF 5/3)."""
    wavelet_levels: int = 6
    """Decomposition levels (details below 2^levels intervals are thresholded)."""
    threshold_rule: str = 'universal'
    """'universal', 'minimax' or 'bayes'."""
    threshold_mode: str = 'soft'
    """'soft' or 'hard' thresholding."""
    validation_fraction: float = 0.25
    """Continuous style: share of the run held out from the fit to check the chosen terms
    (0 = no check)."""
    validation_block_s: float = 1800.0
    """Length of each held-out segment, s."""
    stability_block_s: float = 100.0
    """Block length of the bias stability (METHODS §E), s."""
    extrapolation_margin_c: float = 2.0
    """How far beyond the calibrated H range the model may be used, °C."""
    hdot_margin_fraction: float = 0.5
    """How far beyond the calibrated Ḣ range, as a fraction of that range."""
    soak_max_rate_c_per_min: float = 0.02
    """Soak style: |Ḣ| at most this counts as settled, °C/min."""
    soak_min_s: float = 600.0
    """Soak style: a plateau must last this long, s."""
    soak_settle_fraction: float = 0.5
    """Soak style: the first part of each plateau skipped as still settling (0…1)."""
    distinct_temperature_step_c: float = 2.0
    """Temperatures closer than this count as one level in the check of distinct points, °C."""
    min_valid_fraction: float = 0.5
    """A fit block needs this share of valid intervals."""
    reorder_window_s: float = _INTERVALS.reorder_window_s
    """Samples of one stream may arrive this much after newer ones, s."""
    restart_backstep_s: float = _INTERVALS.restart_backstep_s
    """A stamp this far back means the source restarted, s."""
    max_pulse_gap_s: float = _INTERVALS.max_pulse_gap_s
    """A larger gap between pulse samples invalidates its interval, s."""
    max_rate_deg_s: float = _INTERVALS.max_rate_deg_s
    """A pulse step implying a faster rate is a counter glitch, °/s."""
    sensor_stuck_s: float = _INTERVALS.sensor_stuck_s
    """A sensor reading exactly constant this long while the others move is stuck, s."""
    sensor_stuck_min_change_c: float = _INTERVALS.sensor_stuck_min_change_c
    """... while another sensor moved at least this much, °C."""
    max_temperature_gap_s: float = _INTERVALS.max_temperature_gap_s
    """Largest span between two readings of one temperature sensor across which it is
    interpolated onto the averaging intervals, s (sensors read at 0.01–1 Hz need no reading
    in every interval; a longer gap leaves its intervals unused)."""
    refit_every_s: float = 0.0
    """Live use: refit after this much new data (0 = fit only at the end of the recording), s."""

    def __post_init__(self) -> None:
        """Validate every field; raise ConfigError naming the field."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            kind = f.type if isinstance(f.type, str) else f.type.__name__
            if kind == 'bool':
                ok = isinstance(value, bool)
            elif kind == 'int':
                ok = isinstance(value, int) and not isinstance(value, bool)
            elif kind == 'str':
                ok = isinstance(value, str)
            else:
                ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not ok:
                raise ConfigError(f'{f.name} = {value!r} is invalid: it must be a {kind}.')
        t = self.averaging_interval_s
        checks: list[RangeCheck] = [
            ('scale_factor_rad_per_pulse', math.isnan(self.scale_factor_rad_per_pulse) or (
                math.isfinite(self.scale_factor_rad_per_pulse)
                and self.scale_factor_rad_per_pulse > 0), _K_EXPECTED),
            ('latitude_deg', math.isnan(self.latitude_deg) or abs(self.latitude_deg) <= 90,
             _LATITUDE_EXPECTED),
            ('sense_axis_elevation_deg', -90 <= self.sense_axis_elevation_deg <= 90,
             'between −90 and 90'),
            ('sense_axis_azimuth_deg', math.isfinite(self.sense_axis_azimuth_deg), 'finite'),
            ('earth_rate_deg_h', self.earth_rate_deg_h >= 0, 'non-negative'),
            ('averaging_interval_s', 0 < t <= 60, 'between 0 and 60'),
            ('hdot_window_s', self.hdot_window_s >= 2 * t, 'at least 2 averaging intervals'),
            ('fit_block_s', lambda: self.fit_block_s >= t and _multiple(self.fit_block_s, t),
             'a whole number of averaging intervals'),
            ('calibration_style', self.calibration_style in STYLES, ' or '.join(STYLES)),
            ('max_h_power', 1 <= self.max_h_power <= 6, 'between 1 and 6'),
            ('stepwise_start', self.stepwise_start in ('full', 'constant'),
             "'full' or 'constant'"),
            ('p_enter', 0 < self.p_enter < 1, 'between 0 and 1'),
            ('p_remove', self.p_enter <= self.p_remove < 1,
             'at least p_enter and below 1 (else terms cycle in and out)'),
            ('noise_max_span_s', self.noise_max_span_s >= self.fit_block_s,
             'at least fit_block_s'),
            ('wavelet', self.wavelet in WAVELETS, ' or '.join(WAVELETS)),
            ('wavelet_levels', 1 <= self.wavelet_levels <= 16, 'between 1 and 16'),
            ('threshold_rule', self.threshold_rule in THRESHOLD_RULES,
             ', '.join(THRESHOLD_RULES)),
            ('threshold_mode', self.threshold_mode in THRESHOLD_MODES, 'soft or hard'),
            ('validation_fraction', 0 <= self.validation_fraction <= 0.5, 'between 0 and 0.5'),
            ('validation_block_s', self.validation_block_s >= self.stability_block_s,
             'at least stability_block_s'),
            ('stability_block_s', lambda: self.stability_block_s >= t
             and _multiple(self.stability_block_s, t), 'a whole number of averaging intervals'),
            ('extrapolation_margin_c', self.extrapolation_margin_c >= 0, 'non-negative'),
            ('hdot_margin_fraction', self.hdot_margin_fraction >= 0, 'non-negative'),
            ('soak_max_rate_c_per_min', self.soak_max_rate_c_per_min > 0, 'positive'),
            ('soak_min_s', self.soak_min_s >= 2 * self.stability_block_s,
             'at least two stability blocks'),
            ('soak_settle_fraction', 0 <= self.soak_settle_fraction < 1, 'in [0, 1)'),
            ('distinct_temperature_step_c', self.distinct_temperature_step_c > 0, 'positive'),
            ('min_valid_fraction', 0 < self.min_valid_fraction <= 1, 'in (0, 1]'),
            ('reorder_window_s', self.reorder_window_s >= 0, 'non-negative'),
            ('restart_backstep_s', self.restart_backstep_s > self.reorder_window_s,
             'larger than reorder_window_s'),
            ('max_pulse_gap_s', self.max_pulse_gap_s > 0, 'positive'),
            ('max_rate_deg_s', self.max_rate_deg_s > 0, 'positive'),
            ('sensor_stuck_s', self.sensor_stuck_s > 0, 'positive'),
            ('sensor_stuck_min_change_c', self.sensor_stuck_min_change_c > 0, 'positive'),
            ('max_temperature_gap_s', 0 < self.max_temperature_gap_s < math.inf,
             'positive and finite'),
            ('refit_every_s', self.refit_every_s >= 0, 'non-negative'),
        ]
        check_ranges(self, checks)  # one range check for every setting
        if self.candidate_terms.strip() not in NAMED_SETS:
            candidate_terms(self.candidate_terms)  # raises ConfigError naming a bad term
        terms = candidate_terms(self.candidate_terms, max_h_power=self.max_h_power)
        if self.calibration_style == 'soak' and any(t.variables != ('H',) for t in terms):
            raise ConfigError(
                f'candidate_terms = {self.candidate_terms!r} is invalid with calibration_style '
                "'soak': settled soak points carry no Ḣ or gradient information, so only "
                "powers of H (the static model, eq. 14) can be fitted; use 'static'.")

    def require_site(self) -> None:
        """Raise ConfigError unless K and the latitude are given (the calibration needs both).

        Raises:
            ConfigError: naming every missing field and the flag or parameter that sets it.
        """
        missing = [f'{name} = {getattr(self, name)!r} is invalid: it must be {expected}'
                   for name, expected in (('scale_factor_rad_per_pulse', _K_EXPECTED),
                                          ('latitude_deg', _LATITUDE_EXPECTED))
                   if not math.isfinite(getattr(self, name))]
        if missing:  # every missing setting at once, not one per run
            raise ConfigError('; '.join(missing) + '.')

    def interval_settings(self) -> IntervalSettings:
        """The stream-reduction part of these settings (the fields of IntervalSettings)."""
        return IntervalSettings(**{f.name: getattr(self, f.name)
                                   for f in dataclasses.fields(IntervalSettings)})


def _multiple(x: float, t: float) -> bool:
    """True when x is a whole number of t (t > 0 and finite: checked before, see check_ranges)."""
    if not (0 < t < math.inf and math.isfinite(x)):
        return False
    r = x / t
    return abs(r - round(r)) < 1e-9 * max(r, 1.0)


def thermal_settings_from_mapping(values: dict[str, object], *,
                                  source: str = 'mapping') -> ThermalSettings:
    """Build ThermalSettings from a mapping (YAML, ROS parameters), rejecting unknown keys.

    Raises:
        ConfigError: an unknown key or an invalid value, naming ``source``.
    """
    return settings_from_mapping(ThermalSettings, values, source=source)
