"""A FOG's hand-off as a pulse conversion: which scale factor applies and why (eqs. (3)–(4))."""

from __future__ import annotations

from gyro_calib.errors import GyroCalibError
from gyro_calib.handoff import Calibration, HandoffError
from gyro_calib.imu_conversion.calibration import PulseCalibration

FOG_TURNTABLE_KEY = 'fog_scale_factor_counts_per_rad'
"""A FOG's turntable scale factor (IEEE 952 line fit against the table rates; METHODS §B.2)."""
FOG_SELF_CAL_KEY = 'fog_self_cal_scale_factor_counts_per_rad'
"""A FOG's ladder-wave self-calibrated scale factor (METHODS §B.4)."""
PPM = 1e-6


def fog_pulse_calibration(calibration: Calibration) -> PulseCalibration:
    """A FOG's hand-off as a pulse conversion: K = 1/SF rad/count (package docstring (3)).

    Which SF applies: the turntable's (``fog_scale_factor_counts_per_rad``) whenever the
    file has it — it is measured against the table's rates, and the self-calibrated one is
    anchored to the equivalence mapping and is its check (§B.4, ΔK); otherwise the
    self-calibrated one (``fog_self_cal_scale_factor_counts_per_rad``), valid within its
    linear range. With the turntable SF, its asymmetry (``fog_asymmetry_ppm``) is applied and
    its nonlinearity (``fog_nonlinearity_ppm``) enters the variance; with the self-cal SF,
    ``fog_self_cal_nonlinearity_ppm``. The polynomial coefficients
    (``fog_scale_factor_quadratic_s_per_rad``, ``…_cubic_…``) are not applied: they come from
    a separate fit (§B.2 eq. (8)) whose K₁ and intercept differ from the line's, so mixing them
    with SF and the bias would be inconsistent; NL bounds what they describe. The bias is
    ``fog_bias_rad_s`` (the Earth rate removed); ARW the noise method's
    ``angle_random_walk_rad_per_sqrt_s``, else ``fog_angle_random_walk_rad_per_sqrt_s``.
    """
    turntable = calibration.measured(FOG_TURNTABLE_KEY)
    self_cal = calibration.measured(FOG_SELF_CAL_KEY)
    run = _run_phrase(calibration, FOG_TURNTABLE_KEY if turntable else FOG_SELF_CAL_KEY)
    if turntable is not None:
        key, (sf, sf_std) = FOG_TURNTABLE_KEY, turntable
        asym = calibration.measured('fog_asymmetry_ppm') or (0.0, 0.0)
        nl = calibration.measured('fog_nonlinearity_ppm') or (0.0, 0.0)
        note = (f'the turntable scale factor applies ({run}): it is measured against the '
                'table\'s rates (IEEE 952, METHODS §B.2)')
        diff = calibration.measured('fog_self_cal_minus_turntable_scale_factor_counts_per_rad')
        if self_cal is not None:
            note += ('; the self-calibrated one is anchored to the equivalence mapping and is '
                     'its check' + (f' (it differs by {diff[0]:+.6g} ± {diff[1]:.2g} counts/rad)'
                                    if diff else ''))
        if asym[0]:
            note += f'; asymmetry {asym[0]:g} ppm applied by the sign of the rate'
    else:
        assert self_cal is not None
        key, (sf, sf_std) = FOG_SELF_CAL_KEY, self_cal
        asym = (0.0, 0.0)
        nl = calibration.measured('fog_self_cal_nonlinearity_ppm') or (0.0, 0.0)
        span = calibration.measured('fog_self_cal_linear_range_rad_s')
        note = (f'the self-calibrated scale factor applies ({run}): the file has no turntable '
                'scale factor; it holds within its linear range'
                + (f' |ω| ≤ {span[0]:.4g} rad/s' if span else '')
                + ' (beyond it the loop\'s front end leaves its small-signal region, '
                'METHODS §B.4)')
    if nl[0]:
        note += f'; nonlinearity {nl[0]:g} ppm in the variance'
    if sf <= 0.0:
        raise HandoffError(f'the calibration\'s {key} = {sf!r} counts/rad is not > 0.')
    bias = calibration.measured('fog_bias_rad_s')
    arw = (calibration.measured('angle_random_walk_rad_per_sqrt_s')
           or calibration.measured('fog_angle_random_walk_rad_per_sqrt_s'))
    return PulseCalibration(
        1.0 / sf, sf_std / (sf * sf), key, bias[0] if bias else 0.0, bias[1] if bias else 0.0,
        bias is not None, arw[0] if arw else 0.0, None, asym[0] * PPM, asym[1] * PPM,
        nl[0] * PPM, note)


def _run_phrase(calibration: Calibration, key: str) -> str:
    """'run SOURCE of CREATED' of the run that gave ``key`` (or 'run unknown')."""
    from gyro_calib.registry import handoff_schema

    try:
        run = calibration.source_of(key, handoff_schema())
    except (KeyError, GyroCalibError):
        run = None
    return 'run unknown' if run is None else f'from run {run.label()}'
