"""Hand-off keys of the dither-axis misalignment method (METHODS §C, seed 003)."""

from __future__ import annotations

from gyro_calib.handoff import HandoffKey

METHOD = 'dither'

KEY_A = 'dither_axis_misalignment_rad'
KEY_Z = 'dither_misalignment_z_rad'
KEY_Y = 'dither_misalignment_y_rad'
KEY_FREQUENCY = 'dither_frequency_hz'
KEY_AMPLITUDE = 'dither_amplitude_rad'
KEY_AMPLITUDE_PULSES = 'dither_amplitude_pulses'
KEY_CONING = 'coning_drift_rad_s'
KEY_CONING_TOTAL = 'coning_drift_total_rad_s'
KEY_VERDICT = 'dither_misalignment_verdict'
KEY_LOWER = 'dither_axis_misalignment_lower_rad'
KEY_UPPER = 'dither_axis_misalignment_upper_rad'
KEY_LIMIT = 'dither_misalignment_limit_rad'

HANDOFF_KEYS = (
    # every angle (and rate) key rests on the run's K (scales_with_scale_factor): θ_d and the
    # dither × rocking coning are proportional to it; a, its components, its interval and
    # eq. (24) are a ratio of the sideband to the dither line, whose value moves with K only
    # through the modelled rocking (rocking_treatment = model; the bound's width through
    # k/θ_d): the merge rule |ΔK/K|·|v| is applied to them all (θ_d decides in practice)
    HandoffKey(KEY_A, METHOD, 'dither-axis misalignment a = √(z² + y²), bias-corrected, from '
               'the table along Z and along Y (std: the statistical part and the rocking '
               'allowance as bound/√3; the interval keys below bound a), rad',
               'nonnegative', scales_with_scale_factor=True),
    HandoffKey(KEY_Z, METHOD, 'a·|sin ψ₀|, the component the table along case Z sees, '
               'bias-corrected, rad', 'nonnegative', scales_with_scale_factor=True),
    HandoffKey(KEY_Y, METHOD, 'a·|cos ψ₀|, the component the table along case Y sees, '
               'bias-corrected, rad', 'nonnegative', scales_with_scale_factor=True),
    HandoffKey(KEY_FREQUENCY, METHOD, 'dither frequency Ω_d/2π fitted from the output, Hz',
               'positive'),
    HandoffKey(KEY_AMPLITUDE, METHOD, 'dither amplitude θ_d (needs the scale factor K), rad',
               'positive', scales_with_scale_factor=True),
    HandoffKey(KEY_AMPLITUDE_PULSES, METHOD, 'dither amplitude θ_d·cos a/K as the output '
               'carries it, when K is not given, pulses', 'positive'),
    HandoffKey(KEY_CONING, METHOD, 'coning drift of §C eq. (24) ½·Ω_d·θ_xz·θ_xy·sin φ from a '
               'and the rocking model (worst case sin φ = 1 unless φ is given), rad/s',
               'nonnegative', scales_with_scale_factor=True),
    HandoffKey(KEY_CONING_TOTAL, METHOD, '§C eq. (24) plus the dither × rocking coning '
               '½·Ω_d·θ_d·θ_xy·sin φ·a·|sin ψ₀| (worst-case sum; needs K), rad/s',
               'nonnegative', scales_with_scale_factor=True),
    HandoffKey(KEY_VERDICT, METHOD, 'acceptance of a against dither_misalignment_limit_rad from '
               'the interval [lower, upper] (k = verdict_coverage_factor, rocking allowance '
               'included): accept (upper below the limit), reject (lower above it; one '
               'component\'s lower end suffices, a ≥ |component|) or undecidable', 'text',
               False),
    HandoffKey(KEY_LOWER, METHOD, 'lower end of a\'s interval at k = verdict_coverage_factor, '
               'rocking allowance included, rad', 'nonnegative', False,
               scales_with_scale_factor=True),
    HandoffKey(KEY_UPPER, METHOD, 'upper end of a\'s interval at k = verdict_coverage_factor, '
               'rocking allowance included (absent when nothing bounds a from above), rad',
               'positive', False, scales_with_scale_factor=True),
    HandoffKey(KEY_LIMIT, METHOD, 'the acceptance limit max_misalignment_arcmin the verdict '
               'was taken against, rad', 'positive', False),
)
