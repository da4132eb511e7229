"""Hand-off keys of the noise characterisation (METHODS §E; IEEE Std 952 Annex C terms)."""

from __future__ import annotations

from gyro_calib.handoff import HandoffKey

METHOD = 'noise'

HANDOFF_KEYS = (
    HandoffKey('quantization_noise_rad', METHOD, 'quantisation noise Q (Allan variance −1 '
               'slope term 3Q²/τ²), rad', 'nonnegative'),
    HandoffKey('angle_random_walk_rad_per_sqrt_s', METHOD, 'angle random walk N (−½ slope, '
               'σ(1 s)), rad/√s', 'nonnegative'),
    HandoffKey('bias_instability_rad_s', METHOD, 'bias instability B (flat part / 0.664, joint '
               'fit), rad/s', 'nonnegative'),
    HandoffKey('rate_random_walk_rad_per_s_sqrt_s', METHOD, 'rate random walk K (+½ slope, '
               'σ(3 s)), rad/s/√s', 'nonnegative'),
    HandoffKey('rate_ramp_rad_per_s2', METHOD, 'rate ramp R (+1 slope), rad/s²', 'nonnegative'),
)
