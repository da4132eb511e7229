"""Hand-off keys of the FOG method (METHODS §B; IEEE Std 952 definitions)."""

from __future__ import annotations

from gyro_calib.fog.calibrator import (
    KEY_ARW,
    KEY_ASYMMETRY,
    KEY_BIAS,
    KEY_BIAS_PLUS_EARTH,
    KEY_CUBIC,
    KEY_MAPPING,
    KEY_NONLINEARITY,
    KEY_QUADRATIC,
    KEY_SCALE_FACTOR,
    KEY_SELF_CAL,
    KEY_SELF_CAL_DIFFERENCE,
    KEY_SELF_CAL_NONLINEARITY,
    KEY_SELF_CAL_RANGE,
    KEY_SELF_CAL_SMALL_SIGNAL,
)
from gyro_calib.handoff import HandoffKey

METHOD = 'fog'

HANDOFF_KEYS = (
    HandoffKey(KEY_SCALE_FACTOR, METHOD, 'turntable scale factor K: LS fit output rate = '
               'K·ω + bias over the constant-rate segments (IEEE Std 952), counts/rad'),
    HandoffKey(KEY_BIAS, METHOD, 'bias along the sense axis, Earth rate removed (needs the '
               'latitude), rad/s'),
    HandoffKey(KEY_BIAS_PLUS_EARTH, METHOD, 'bias plus the Earth-rate component along the sense '
               'axis (no latitude given), rad/s; holds on that bench only',
               bench_specific=True),
    HandoffKey(KEY_NONLINEARITY, METHOD, 'max |LS residual| / full-scale output, ppm',
               'nonnegative',
               follows=KEY_SCALE_FACTOR),
    HandoffKey(KEY_ASYMMETRY, METHOD, '(K₊ − K₋)/K̄ from positive and negative rates, ppm',
               follows=KEY_SCALE_FACTOR),
    HandoffKey(KEY_QUADRATIC, METHOD, 'second-order scale-factor coefficient (≥ 5 rates), '
               's/rad',
               follows=KEY_SCALE_FACTOR),
    HandoffKey(KEY_CUBIC, METHOD, 'third-order scale-factor coefficient (≥ 5 rates), s²/rad²',
               follows=KEY_SCALE_FACTOR),
    HandoffKey(KEY_ARW, METHOD, 'angle random walk from the segment scatter, rad/√s',
               'nonnegative'),
    HandoffKey(KEY_MAPPING, METHOD, 'equivalence mapping: output counts per rad/s of the '
               'turntable rate steps 0.01, 0.1, 1 °/s (docs/methods.md §B.3), counts/rad'),
    HandoffKey(KEY_SELF_CAL, METHOD, 'self-calibrated K: LS slope over the automatically found '
               'linear range (mapping uncertainty included), counts/rad'),
    HandoffKey(KEY_SELF_CAL_RANGE, METHOD, 'largest injected equivalent rate whose IEEE '
               'nonlinearity stays within self_cal_nonlinearity_spec_ppm, rad/s', 'nonnegative',
               follows=KEY_SELF_CAL),
    HandoffKey(KEY_SELF_CAL_NONLINEARITY, METHOD, 'IEEE nonlinearity over that linear range, ppm',
               'nonnegative',
               follows=KEY_SELF_CAL),
    HandoffKey(KEY_SELF_CAL_SMALL_SIGNAL, METHOD, 'self-calibrated K extrapolated to zero '
               'injection amplitude, counts/rad',
               follows=KEY_SELF_CAL),
    HandoffKey(KEY_SELF_CAL_DIFFERENCE, METHOD, 'self-calibrated minus turntable K, counts/rad',
               follows=KEY_SELF_CAL),
)
