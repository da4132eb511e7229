"""Hand-off keys of the noise characterisation (METHODS §E; IEEE Std 952 Annex C terms).

A single-axis gyro (``/gyro/pulses``, ``/fog/output``) writes the five plain keys. An IMU
(``sensor_msgs/Imu``) writes one key per axis and term, ``imu_<axis>_<term key>``: the
gyro axes ``gyro_x``, ``gyro_y``, ``gyro_z`` with the gyro keys (rad, rad/s), the
accelerometer axes ``accel_x`` … ``accel_z`` with the accelerometer keys (m/s, m/s²), as
:mod:`gyro_calib.noise.terms` names them — e.g. ``imu_gyro_x_angle_random_walk_rad_per_sqrt_s``,
``imu_accel_z_velocity_random_walk_m_s_per_sqrt_s``. One hand-off file per IMU.
"""

from __future__ import annotations

from gyro_calib.handoff import HandoffKey
from gyro_calib.noise.terms import SYMBOLS, units_for_axis
from gyro_calib.noise.topics import IMU_AXES

METHOD = 'noise'

_SLOPES = {'Q': '−1 slope', 'N': '−½ slope, σ(1 s)', 'B': 'flat part / 0.664, joint fit',
           'K': '+½ slope, σ(3 s)', 'R': '+1 slope'}

SINGLE_GYRO_KEYS = (
    HandoffKey('quantization_noise_rad', METHOD, 'quantisation noise Q (Allan variance −1 '
               'slope term 3Q²/τ²), rad', 'nonnegative',
               scales_with_scale_factor=True),
    HandoffKey('angle_random_walk_rad_per_sqrt_s', METHOD, 'angle random walk N (−½ slope, '
               'σ(1 s)), rad/√s', 'nonnegative',
               scales_with_scale_factor=True),
    HandoffKey('bias_instability_rad_s', METHOD, 'bias instability B (flat part / 0.664, joint '
               'fit), rad/s', 'nonnegative',
               scales_with_scale_factor=True),
    HandoffKey('rate_random_walk_rad_per_s_sqrt_s', METHOD, 'rate random walk K (+½ slope, '
               'σ(3 s)), rad/s/√s', 'nonnegative',
               scales_with_scale_factor=True),
    HandoffKey('rate_ramp_rad_per_s2', METHOD, 'rate ramp R (+1 slope), rad/s²', 'nonnegative',
               scales_with_scale_factor=True),
)
"""The five terms of a single-axis gyro."""


def imu_key(axis: str, term_key: str) -> str:
    """The hand-off key of one term of one IMU axis: ``imu_<axis>_<term key>``."""
    return f'imu_{axis}_{term_key}'


IMU_KEYS = tuple(
    HandoffKey(imu_key(axis, units.keys[k]), METHOD,
               f'IMU {axis}: {units.names[k]} ({_SLOPES[symbol]}), {units.si_units[k]}',
               'nonnegative')
    for axis in IMU_AXES for units in (units_for_axis(axis),) for k, symbol in enumerate(SYMBOLS))
"""The five terms of each of the six IMU axes (30 keys)."""

UPPER_BOUND_SUFFIX = '_upper_bound_2sigma'
"""``<term key>_upper_bound_2sigma``: the 2σ upper bound √(θ + 2σ(θ)) of a term the joint fit
did not resolve (METHODS §E), same unit as the term; written only while the term is absent."""


def upper_bound_keys(keys: tuple[HandoffKey, ...]) -> tuple[HandoffKey, ...]:
    """The ``_upper_bound_2sigma`` twin of each term key (follows the term in a merge)."""
    return tuple(HandoffKey(k.name + UPPER_BOUND_SUFFIX, METHOD,
                            f'2σ upper bound of {k.description.split(" (")[0]} where the fit '
                            'did not resolve it (absent when the term is)', 'nonnegative',
                            has_std=False, follows=k.name,
                            scales_with_scale_factor=k.scales_with_scale_factor)
                 for k in keys)


HANDOFF_KEYS = (SINGLE_GYRO_KEYS + IMU_KEYS + upper_bound_keys(SINGLE_GYRO_KEYS)
                + upper_bound_keys(IMU_KEYS))
