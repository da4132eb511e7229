"""One rate and its covariance from two count samples, eqs. (1)–(4)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from gyro_calib.errors import StreamError
from gyro_calib.imu_conversion.calibration import PulseCalibration

UNKNOWN_AXIS_VARIANCE_RAD2_S2 = 1.0e6
"""Variance of the unmeasured x and y rates, (rad/s)²: σ = 1000 rad/s, beyond any real
rotation, so any fusion filter gives those zeros no weight."""


@dataclass(frozen=True, slots=True)
class ImuAngularVelocity:
    """The angular_velocity part of one sensor_msgs/Imu.

    Attributes:
        stamp_ns: header stamp, the later sample's stamp, int ns.
        angular_velocity_rad_s: (x, y, z) in the Imu frame, rad/s; z is the sense axis.
        covariance_rad2_s2: 3×3 covariance, row-major (9 values), (rad/s)².
        linear_acceleration_m_s2: the IMU's accelerometers at this stamp (m/s², the Imu
            frame), or None: the message carries no accelerometer (covariance[0] = −1).
        linear_acceleration_covariance: their 3×3 covariance, row-major, (m/s²)².
    """

    stamp_ns: int
    angular_velocity_rad_s: tuple[float, float, float]
    covariance_rad2_s2: tuple[float, ...]
    linear_acceleration_m_s2: tuple[float, float, float] | None = None
    linear_acceleration_covariance: tuple[float, ...] | None = None


def angular_velocity_from_pulses(t0_ns: int, count0: float, t1_ns: int, count1: float,
                                 calibration: PulseCalibration) -> ImuAngularVelocity:
    """Calibrated sense-axis rate and covariance from two count samples, eqs. (1) and (2).

    Args:
        t0_ns: stamp of the earlier sample, int ns.
        count0: cumulative pulse count at ``t0_ns``, pulses.
        t1_ns: stamp of the later sample, int ns (> ``t0_ns``).
        count1: cumulative pulse count at ``t1_ns``, pulses.
        calibration: K, bias and ARW (:func:`pulse_calibration`).

    Returns:
        The rate about x, y, z (z = sense axis) at ``t1_ns`` and its covariance.

    Raises:
        StreamError: if ``t1_ns <= t0_ns``.
    """
    c = calibration
    k, k_std = c.scale_factor_rad_per_pulse, c.scale_factor_std
    if t1_ns <= t0_ns:
        raise StreamError(f'stamps must increase: t1_ns = {t1_ns} <= t0_ns = {t0_ns}.')
    dt_s = (t1_ns - t0_ns) / 1e9
    measured_rad_s = k * (count1 - count0) / dt_s
    arw = c.angle_random_walk_rad_per_sqrt_s
    variance = (arw * arw / dt_s
                + k * k / (6.0 * dt_s * dt_s)
                + (measured_rad_s * k_std / k) ** 2
                + c.bias_std ** 2)
    rate = measured_rad_s - c.bias_rad_s
    if c.asymmetry or c.nonlinearity:  # a FOG's scale-factor model, eqs. (3) and (4)
        half = math.copysign(0.5, rate) * c.asymmetry
        rate /= 1.0 + half
        variance = (variance / (1.0 + half) ** 2 + (0.5 * rate * c.asymmetry_std) ** 2
                    + (c.nonlinearity * rate) ** 2 / 3.0)
    u = UNKNOWN_AXIS_VARIANCE_RAD2_S2
    return ImuAngularVelocity(
        stamp_ns=t1_ns,
        angular_velocity_rad_s=(0.0, 0.0, rate),
        covariance_rad2_s2=(u, 0.0, 0.0, 0.0, u, 0.0, 0.0, 0.0, variance))
