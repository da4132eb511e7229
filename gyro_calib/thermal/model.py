"""The thermal bias model an INS applies: terms, coefficients, covariance, validity.

A :class:`ThermalBiasModel` evaluates bias(H, Ḣ, ΔT_ab, ΔT_cs) in rad/s with its standard
uncertainty (the coefficient covariance and the model error u_m in quadrature, METHODS §D.3
(17d), (17g)), refuses to extrapolate beyond the calibrated temperature range by more than
a margin, and carries everything
``compensate`` needs: the scale factor it was fitted with, the site latitude and sense
axis (so the Earth rate is known), how the variables were formed (averaging interval,
Ḣ window) and the gyro it belongs to.

Hand-off dict (:meth:`ThermalBiasModel.to_dict`), every key prefixed ``thermal_``, units
in the names, coefficients in the *scaled* variables ((x − centre)/scale)::

    thermal_format_version: 1
    thermal_gyro_id: 'A-1'                         # identity check on use
    thermal_terms: ['H', 'H^2', 'Hdot']            # intercept implied, first coefficient
    thermal_coefficients_rad_s: [b0, b1, b2, b3]
    thermal_covariance_rad2_s2: [[...], ...]        # (1 + terms)²
    thermal_h_centre_c / thermal_h_scale_c
    thermal_hdot_centre_c_per_s / thermal_hdot_scale_c_per_s
    thermal_dtab_centre_c / thermal_dtab_scale_c
    thermal_dtcs_centre_c / thermal_dtcs_scale_c
    thermal_calibrated_h_min_c / thermal_calibrated_h_max_c
    thermal_calibrated_hdot_min_c_per_s / thermal_calibrated_hdot_max_c_per_s
    thermal_extrapolation_margin_c                 # allowed beyond the H range
    thermal_hdot_margin_fraction                   # allowed beyond the Ḣ range, × its span
    thermal_scale_factor_rad_per_pulse
    thermal_latitude_deg
    thermal_sense_axis_elevation_deg / thermal_sense_axis_azimuth_deg
    thermal_earth_rate_along_axis_rad_s
    thermal_averaging_interval_s / thermal_hdot_window_s
    thermal_sensors: ['cavity_a', 'cavity_b', 'shell']
    thermal_residual_std_rad_s                     # of fit-block means, thermal_fit_block_s
    thermal_fit_block_s
    thermal_calibration_style: 'continuous'        # or 'soak'
    thermal_covariance_kind: 'allan'               # 'wls', 'ols'
    thermal_n_used / thermal_dof
    thermal_max_temperature_gap_s
    thermal_model_error_rad_s                      # u_m, added in quadrature to every
    thermal_model_error_n                          #   prediction; held-out blocks it rests on
                                                   # (files without them: 0, not estimated)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.thermal.errors import ExtrapolationError, ModelFileError, ModelMismatchError
from gyro_calib.thermal.terms import (
    VARIABLES,
    VariableScaling,
    design_columns,
    parse_term,
    required_variables,
)
from gyro_calib.units import format_stamp

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike

FORMAT_VERSION = 1
"""Layout version of the hand-off dict."""

_VAR_KEYS = {'H': ('h', 'c'), 'Hdot': ('hdot', 'c_per_s'), 'dTab': ('dtab', 'c'),
             'dTcs': ('dtcs', 'c')}


@dataclass(frozen=True, slots=True)
class ThermalBiasModel:
    """A fitted thermal bias model (METHODS §D.2–3). See the module docstring for the keys.

    Attributes:
        gyro_id: identity (serial) of the gyro it was fitted on ('' = unknown).
        terms: term names (intercept implied).
        coefficients_rad_s: intercept first, in rad/s per scaled unit.
        covariance_rad2_s2: their covariance.
        scaling: centre/scale of each variable.
        h_range_c: calibrated (min, max) H, °C.
        hdot_range_c_s: calibrated (min, max) Ḣ, °C/s.
        extrapolation_margin_c: how far beyond h_range_c the model may be used, °C.
        hdot_margin_fraction: how far beyond hdot_range_c_s, as a fraction of its span.
        scale_factor_rad_per_pulse: K used to turn pulses into rate in the fit.
        latitude_deg, sense_axis_elevation_deg, sense_axis_azimuth_deg: site and axis.
        earth_rate_along_axis_rad_s: Earth rate removed from the rate in the fit.
        averaging_interval_s, hdot_window_s: how the variables were formed.
        sensors: temperature sensors the calibration recording had.
        residual_std_rad_s: residual std of the fit-block means, rad/s.
        fit_block_s: length of those blocks, s.
        calibration_style: ``continuous`` or ``soak``.
        covariance_kind: ``allan``, ``wls`` or ``ols``.
        n_used, dof: rows in the fit and its degrees of freedom.
        max_temperature_gap_s: the largest gap between a sensor's readings interpolated
            across in the fit, s (models written before it was stored: 120 s, the default).
        model_error_rad_s: model error u_m (METHODS §D.3 (17g)): the held-out scatter
            beyond noise and covariance — misfit and selection error — added in quadrature
            to every prediction, rad/s (0: not estimated, e.g. models written before it).
        model_error_n: held-out ``stability_block_s`` blocks u_m rests on (0: none).
    """

    gyro_id: str
    terms: tuple[str, ...]
    coefficients_rad_s: tuple[float, ...]
    covariance_rad2_s2: tuple[tuple[float, ...], ...]
    scaling: VariableScaling
    h_range_c: tuple[float, float]
    hdot_range_c_s: tuple[float, float]
    extrapolation_margin_c: float
    hdot_margin_fraction: float
    scale_factor_rad_per_pulse: float
    latitude_deg: float
    sense_axis_elevation_deg: float
    sense_axis_azimuth_deg: float
    earth_rate_along_axis_rad_s: float
    averaging_interval_s: float
    hdot_window_s: float
    sensors: tuple[str, ...]
    residual_std_rad_s: float
    fit_block_s: float
    calibration_style: str
    covariance_kind: str
    n_used: int
    dof: int
    max_temperature_gap_s: float = 120.0
    model_error_rad_s: float = 0.0
    model_error_n: int = 0

    @property
    def variables(self) -> tuple[str, ...]:
        """Variables the model's terms need."""
        return required_variables(tuple(parse_term(t) for t in self.terms))

    def design_rows(self, variables: dict[str, npt.NDArray[np.float64]]
                    ) -> npt.NDArray[np.float64]:
        """Design matrix rows [1, term columns…] for per-interval variables (H, Hdot, …)."""
        terms = tuple(parse_term(t) for t in self.terms)
        n = len(next(iter(variables.values())))
        cols = design_columns(terms, variables, self.scaling)
        return np.column_stack((np.ones(n), cols))

    def check_range(self, h_c: ArrayLike, hdot_c_s: ArrayLike | None = None,
                    t_ns: ArrayLike | None = None) -> None:
        """Raise ExtrapolationError outside the calibrated range.

        Raise :class:`ExtrapolationError` if any H (or Ḣ, if the model uses it) is outside
        the calibrated range plus margin; the message names the value, stamp and range.
        """
        h = np.atleast_1d(np.asarray(h_c, np.float64))
        lo, hi = self.h_range_c
        m = self.extrapolation_margin_c
        bad = np.nonzero((h < lo - m) | (h > hi + m))[0]
        if len(bad):
            i = int(bad[0])
            where = f' at {format_stamp(int(np.atleast_1d(t_ns)[i]))}' if t_ns is not None \
                else ''
            raise ExtrapolationError(
                f'mean cavity temperature H = {h[i]:.2f} °C{where} is outside the calibrated '
                f'range {lo:.2f}…{hi:.2f} °C by more than the {m:g} °C margin '
                f'({len(bad)} of {len(h)} value(s) outside): the model would extrapolate. '
                'Calibrate over the wider range, or widen extrapolation_margin_c knowingly.')
        if hdot_c_s is not None and 'Hdot' in self.variables:
            r = np.atleast_1d(np.asarray(hdot_c_s, np.float64))
            rlo, rhi = self.hdot_range_c_s
            mr = self.hdot_margin_fraction * (rhi - rlo)
            bad = np.nonzero((r < rlo - mr) | (r > rhi + mr))[0]
            if len(bad):
                i = int(bad[0])
                where = f' at {format_stamp(int(np.atleast_1d(t_ns)[i]))}' \
                    if t_ns is not None else ''
                raise ExtrapolationError(
                    f'temperature rate Ḣ = {r[i] * 60:.3f} °C/min{where} is outside the '
                    f'calibrated range {rlo * 60:.3f}…{rhi * 60:.3f} °C/min by more than '
                    f'{self.hdot_margin_fraction:g} of its span: the model would extrapolate.')

    def bias_rad_s(self, h_c: ArrayLike, hdot_c_s: ArrayLike = 0.0, dtab_c: ArrayLike = 0.0,
                   dtcs_c: ArrayLike = 0.0, *, check: bool = True
                   ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Bias and its standard uncertainty, rad/s, per input value.

        Bias and its standard uncertainty, rad/s, per input value: u² = x·C·xᵀ + u_m²
        (METHODS §D.3 (17d), (17g)).

        Args:
            h_c: H, °C.
            hdot_c_s: Ḣ, °C/s.
            dtab_c: T_a − T_b, °C.
            dtcs_c: H − T_shell, °C.
            check: refuse values outside the calibrated range (:meth:`check_range`).

        Raises:
            ExtrapolationError: see :meth:`check_range`.
        """
        h = np.atleast_1d(np.asarray(h_c, np.float64))
        n = len(h)
        vals = {'H': h}
        for name, v in (('Hdot', hdot_c_s), ('dTab', dtab_c), ('dTcs', dtcs_c)):
            vals[name] = np.broadcast_to(np.asarray(v, np.float64), (n,)).astype(np.float64)
        if check:
            self.check_range(h, vals['Hdot'])
        x = self.design_rows(vals)
        # column by column, elementwise: a value never depends on how many are evaluated
        # together (a live tracker evaluating one interval gets the offline number)
        value = np.zeros(n)
        for j, b in enumerate(self.coefficients_rad_s):
            value = value + b * x[:, j]
        var = np.zeros(n)
        for j, row in enumerate(self.covariance_rad2_s2):
            for k, c in enumerate(row):
                var = var + c * x[:, j] * x[:, k]
        return value, np.sqrt(np.maximum(var, 0.0) + self.model_error_rad_s**2)

    def check_sensors(self, sensors: tuple[str, ...]) -> None:
        """Raise :class:`ModelMismatchError` if a variable the model needs has no sensor."""
        if 'dTcs' in self.variables and 'shell' not in sensors:
            raise ModelMismatchError(
                'the thermal model uses the cavity-to-shell gradient (term with dTcs) but the '
                'recording has no shell temperature sensor (frame_id "shell"): record it, or '
                'use a model fitted without dTcs.')

    def check_gyro(self, gyro_id: str) -> None:
        """Raise :class:`ModelMismatchError` if both ids are known and differ."""
        if self.gyro_id and gyro_id and self.gyro_id != gyro_id:
            raise ModelMismatchError(
                f'the thermal model was fitted on gyro {self.gyro_id!r} but the recording is '
                f'from gyro {gyro_id!r}: a thermal model belongs to one gyro. Use that '
                "gyro's model (or calibrate this one).")

    # -- hand-off --------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Plain dict for the hand-off file (keys in the module docstring)."""
        d: dict[str, Any] = {
            'thermal_format_version': FORMAT_VERSION,
            'thermal_gyro_id': self.gyro_id,
            'thermal_terms': list(self.terms),
            'thermal_coefficients_rad_s': [float(c) for c in self.coefficients_rad_s],
            'thermal_covariance_rad2_s2': [[float(c) for c in row]
                                           for row in self.covariance_rad2_s2],
        }
        for var in VARIABLES:
            key, unit = _VAR_KEYS[var]
            d[f'thermal_{key}_centre_{unit}'] = float(self.scaling.centre[var])
            d[f'thermal_{key}_scale_{unit}'] = float(self.scaling.scale[var])
        d.update({
            'thermal_calibrated_h_min_c': float(self.h_range_c[0]),
            'thermal_calibrated_h_max_c': float(self.h_range_c[1]),
            'thermal_calibrated_hdot_min_c_per_s': float(self.hdot_range_c_s[0]),
            'thermal_calibrated_hdot_max_c_per_s': float(self.hdot_range_c_s[1]),
            'thermal_extrapolation_margin_c': float(self.extrapolation_margin_c),
            'thermal_hdot_margin_fraction': float(self.hdot_margin_fraction),
            'thermal_scale_factor_rad_per_pulse': float(self.scale_factor_rad_per_pulse),
            'thermal_latitude_deg': float(self.latitude_deg),
            'thermal_sense_axis_elevation_deg': float(self.sense_axis_elevation_deg),
            'thermal_sense_axis_azimuth_deg': float(self.sense_axis_azimuth_deg),
            'thermal_earth_rate_along_axis_rad_s': float(self.earth_rate_along_axis_rad_s),
            'thermal_averaging_interval_s': float(self.averaging_interval_s),
            'thermal_hdot_window_s': float(self.hdot_window_s),
            'thermal_sensors': list(self.sensors),
            'thermal_residual_std_rad_s': float(self.residual_std_rad_s),
            'thermal_fit_block_s': float(self.fit_block_s),
            'thermal_calibration_style': self.calibration_style,
            'thermal_covariance_kind': self.covariance_kind,
            'thermal_n_used': int(self.n_used),
            'thermal_dof': int(self.dof),
            'thermal_max_temperature_gap_s': float(self.max_temperature_gap_s),
            'thermal_model_error_rad_s': float(self.model_error_rad_s),
            'thermal_model_error_n': int(self.model_error_n),
        })
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any], *,
                  source: str = 'the thermal model') -> ThermalBiasModel:
        """Rebuild a model from :meth:`to_dict` output, checking every key.

        Raises:
            ModelFileError: naming the missing or invalid key and ``source``.
        """
        def get(key: str, kind: type | tuple[type, ...]) -> Any:
            if key not in d:
                raise ModelFileError(f'{source} has no {key}: it is not a complete thermal '
                                     'model (written by gyro_calib thermal calibration?).')
            v = d[key]
            if kind is float:
                if isinstance(v, bool) or not isinstance(v, (int, float)):
                    raise ModelFileError(f'{key} in {source} must be a number, got {v!r}.')
                return float(v)
            if not isinstance(v, kind) or isinstance(v, bool) and kind is int:
                raise ModelFileError(f'{key} in {source} has the wrong type: {v!r}.')
            return v

        version = get('thermal_format_version', int)
        if version != FORMAT_VERSION:
            raise ModelFileError(f'{source} has thermal_format_version {version}; this '
                                 f'gyro_calib reads version {FORMAT_VERSION}.')
        terms = tuple(str(t) for t in get('thermal_terms', list))
        for t in terms:
            try:
                parse_term(t)
            except Exception as exc:  # ConfigError: re-raise as a file error
                raise ModelFileError(f'thermal_terms in {source}: {exc}') from None
        coef = tuple(float(c) for c in get('thermal_coefficients_rad_s', list))
        cov_rows = get('thermal_covariance_rad2_s2', list)
        p = len(terms) + 1
        if len(coef) != p or len(cov_rows) != p or any(len(r) != p for r in cov_rows):
            raise ModelFileError(
                f'{source}: {len(terms)} term(s) need {p} coefficients and a {p}×{p} '
                f'covariance; found {len(coef)} and {len(cov_rows)} row(s).')
        cov = tuple(tuple(float(c) for c in row) for row in cov_rows)
        model_error = get('thermal_model_error_rad_s', float) \
            if 'thermal_model_error_rad_s' in d else 0.0
        if not (math.isfinite(model_error) and model_error >= 0):
            raise ModelFileError(f'thermal_model_error_rad_s in {source} must be a finite '
                                 f'number ≥ 0, got {model_error!r}.')
        if not all(math.isfinite(c) for c in coef):
            raise ModelFileError(f'{source}: a coefficient is not finite.')
        centre, scale = {}, {}
        for var in VARIABLES:
            key, unit = _VAR_KEYS[var]
            centre[var] = get(f'thermal_{key}_centre_{unit}', float)
            scale[var] = get(f'thermal_{key}_scale_{unit}', float)
            if not scale[var] > 0:
                raise ModelFileError(f'thermal_{key}_scale_{unit} in {source} must be positive.')
        h_lo, h_hi = get('thermal_calibrated_h_min_c', float), get('thermal_calibrated_h_max_c',
                                                                    float)
        if not h_lo <= h_hi:
            raise ModelFileError(f'{source}: calibrated H range {h_lo}…{h_hi} °C is empty.')
        k = get('thermal_scale_factor_rad_per_pulse', float)
        if not k > 0:
            raise ModelFileError(f'thermal_scale_factor_rad_per_pulse in {source} must be '
                                 'positive.')
        return cls(
            gyro_id=str(get('thermal_gyro_id', str)), terms=terms, coefficients_rad_s=coef,
            covariance_rad2_s2=cov, scaling=VariableScaling(centre, scale),
            h_range_c=(h_lo, h_hi),
            hdot_range_c_s=(get('thermal_calibrated_hdot_min_c_per_s', float),
                            get('thermal_calibrated_hdot_max_c_per_s', float)),
            extrapolation_margin_c=get('thermal_extrapolation_margin_c', float),
            hdot_margin_fraction=get('thermal_hdot_margin_fraction', float),
            scale_factor_rad_per_pulse=k,
            latitude_deg=get('thermal_latitude_deg', float),
            sense_axis_elevation_deg=get('thermal_sense_axis_elevation_deg', float),
            sense_axis_azimuth_deg=get('thermal_sense_axis_azimuth_deg', float),
            earth_rate_along_axis_rad_s=get('thermal_earth_rate_along_axis_rad_s', float),
            averaging_interval_s=get('thermal_averaging_interval_s', float),
            hdot_window_s=get('thermal_hdot_window_s', float),
            sensors=tuple(str(s) for s in get('thermal_sensors', list)),
            residual_std_rad_s=get('thermal_residual_std_rad_s', float),
            fit_block_s=get('thermal_fit_block_s', float),
            calibration_style=str(get('thermal_calibration_style', str)),
            covariance_kind=str(get('thermal_covariance_kind', str)),
            n_used=int(get('thermal_n_used', int)), dof=int(get('thermal_dof', int)),
            max_temperature_gap_s=(get('thermal_max_temperature_gap_s', float)
                                   if 'thermal_max_temperature_gap_s' in d else 120.0),
            model_error_rad_s=model_error,
            model_error_n=(int(get('thermal_model_error_n', int))
                           if 'thermal_model_error_n' in d else 0))
