"""Hand-off keys of the RBRLG method (the names of format 1, kept: INS code reads them)."""

from __future__ import annotations

from gyro_calib.handoff import HandoffKey

METHOD = 'rbrlg'

HANDOFF_KEYS = (
    HandoffKey('k_tilde_rad_per_pulse', METHOD, 'K̃, scale factor assuming cos θ = 1 '
               '(docs/methods.md §A.2 eq. (3)), rad/pulse', 'positive'),
    HandoffKey('scale_factor_rad_per_pulse', METHOD,
               'K = K̃·cos θ (§A eq. (4)), rad/pulse; needs θ', 'positive',
               follows='fix_error_angle_rad'),
    HandoffKey('fix_error_angle_rad', METHOD, 'θ, the sense axis tilt from the rate-table axis '
               '(§A.3, multi-station fit), rad'),
    HandoffKey('bias_plus_earth_rate_rad_s', METHOD, 'ω′ₑ + ω_B along the sense axis from the '
               'K̃ windows (§A eqs. (1) + (2)), rad/s; holds on that bench only (the Earth rate '
               'along its table axis is in it)', bench_specific=True),
    HandoffKey('bias_rad_s', METHOD, 'ω_B, the gyro bias along its sense axis (Earth rate along '
               'the table axis removed: needs the site latitude), rad/s'),
    HandoffKey('window_pairs', METHOD, 'forward/reverse window pairs K̃ rests on', 'count',
               has_std=False,
               follows='k_tilde_rad_per_pulse'),
    HandoffKey('stations', METHOD, 'position-table stations θ rests on', 'count',
               has_std=False,
               follows='fix_error_angle_rad'),
)
