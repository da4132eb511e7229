"""Pulse counts → calibrated angular rate with its variance, for sensor_msgs/Imu.

Between two samples of the cumulative count, (t₀, n₀) and (t₁, n₁), the rate about the
gyro's sense axis is

    ω = K·(n₁ − n₀)/(t₁ − t₀) − b                                              (1)

with K the scale factor (rad/pulse) and b the bias (rad/s) of the hand-off file
(:mod:`gyro_calib.handoff`, taken by :func:`pulse_calibration`). Its variance sums independent terms (GUM, first order):

    u²(ω) = N²/Δt                angle random walk N (rad/√s) over Δt: white rate noise
          + K²/(6·Δt²)           quantisation: each count is the true angle/K rounded to
                                 a whole pulse, uniform in ±½ pulse (variance 1/12 pulse²)
                                 at each end, independent → 1/6 pulse² for the difference
          + (ω + b)²·u²(K)/K²    scale-factor uncertainty, relative, on the measured rate
          + u²(b)                bias uncertainty                                     (2)

An absent angle random walk contributes nothing (the quantisation term then stands for
the noise; for a rate-biased RLG at 1 kHz it is the larger one by orders of magnitude).
Consecutive rates share a count, so their quantisation errors are anticorrelated; the
per-message variance is still (2).

The gyro measures about one axis, taken as the Imu frame's z axis. x and y carry 0 with
the variance :data:`UNKNOWN_AXIS_VARIANCE_RAD2_S2`: sensor_msgs/Imu and REP 145 only
offer ``covariance[0] = -1`` to mark a *whole* field unavailable, which would also hide
z; a large, finite variance tells a filter "no information" per axis without the
infinities or NaNs (∞·0) some consumers choke on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gyro_calib.errors import StreamError
from gyro_calib.estimate import Rejection
from gyro_calib.handoff import Calibration

UNKNOWN_AXIS_VARIANCE_RAD2_S2 = 1.0e6
"""Variance of the unmeasured x and y rates, (rad/s)²: σ = 1000 rad/s, beyond any real
rotation, so any fusion filter gives those zeros no weight."""


@dataclass(frozen=True, slots=True)
class PulseCalibration:
    """What the conversion needs from the hand-off file, in SI.

    Attributes:
        scale_factor_rad_per_pulse: K (or K̃ when told to take θ = 0), rad/pulse.
        scale_factor_std: its standard uncertainty, rad/pulse.
        scale_factor_key: the hand-off key it came from.
        bias_rad_s: b, rad/s (0 when the file has none: ``bias_known`` False).
        bias_std: its standard uncertainty, rad/s.
        bias_known: the file holds ``bias_rad_s``.
        angle_random_walk_rad_per_sqrt_s: N, rad/√s (0 when the file has none).
    """

    scale_factor_rad_per_pulse: float
    scale_factor_std: float
    scale_factor_key: str = 'scale_factor_rad_per_pulse'
    bias_rad_s: float = 0.0
    bias_std: float = 0.0
    bias_known: bool = False
    angle_random_walk_rad_per_sqrt_s: float = 0.0


def pulse_calibration(calibration: Calibration, *, use_k_tilde: bool = False) -> PulseCalibration:
    """The scale factor, bias and ARW the conversion uses.

    Args:
        calibration: the hand-off file's content.
        use_k_tilde: take K̃ as the scale factor (θ = 0: a gyro whose fix-error angle was not
            measured); otherwise K = K̃·cos θ is required.

    Raises:
        HandoffError: naming the missing key (``scale_factor_rad_per_pulse``, or
            ``k_tilde_rad_per_pulse`` with ``use_k_tilde``).
    """
    if use_k_tilde:
        key, why = 'k_tilde_rad_per_pulse', 'imu_corrector was told to use K̃ with θ = 0'
    else:
        key, why = 'scale_factor_rad_per_pulse', (
            'K = K̃·cos θ needs the fix-error angle θ; set use_k_tilde to take K̃ with θ = 0')
    k, k_std = calibration.require(key, why=why)
    bias = calibration.measured('bias_rad_s')
    arw = calibration.measured('angle_random_walk_rad_per_sqrt_s')
    return PulseCalibration(k, k_std, key, bias[0] if bias else 0.0, bias[1] if bias else 0.0,
                            bias is not None, arw[0] if arw else 0.0)


@dataclass(frozen=True, slots=True)
class ImuAngularVelocity:
    """The angular_velocity part of one sensor_msgs/Imu.

    Attributes:
        stamp_ns: header stamp, the later sample's stamp, int ns.
        angular_velocity_rad_s: (x, y, z) in the Imu frame, rad/s; z is the sense axis.
        covariance_rad2_s2: 3×3 covariance, row-major (9 values), (rad/s)².
    """

    stamp_ns: int
    angular_velocity_rad_s: tuple[float, float, float]
    covariance_rad2_s2: tuple[float, ...]


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
    u = UNKNOWN_AXIS_VARIANCE_RAD2_S2
    return ImuAngularVelocity(
        stamp_ns=t1_ns,
        angular_velocity_rad_s=(0.0, 0.0, measured_rad_s - c.bias_rad_s),
        covariance_rad2_s2=(u, 0.0, 0.0, 0.0, u, 0.0, 0.0, 0.0, variance))


class PulseRateConverter:
    """Streaming form of :func:`angular_velocity_from_pulses` for a node.

    Feed samples in arrival order; each one after the first gives the rate since the one
    before. Skipped (returned as a :class:`Rejection`, no rate):

    * a non-finite count — the previous sample stays the reference;
    * a stamp not after the previous one — it becomes the new reference, so a source that
      restarted (stamps jumped back) is followed again from its next sample.

    The calibration may be replaced between samples (the reference sample stays).
    """

    def __init__(self, calibration: PulseCalibration) -> None:
        """Start with no reference sample."""
        self.calibration = calibration
        self._last: tuple[int, float] | None = None

    def add(self, t_ns: int, count: float) -> ImuAngularVelocity | Rejection | None:
        """The rate since the previous sample, a Rejection saying why not, or None (first)."""
        if not math.isfinite(count):
            return Rejection(t_ns, f'pulse count {count!r} at stamp {t_ns} ns is not finite.')
        last, self._last = self._last, (t_ns, count)
        if last is None:
            return None
        if t_ns <= last[0]:
            return Rejection(t_ns, f'stamp {t_ns} ns is not after the previous one, {last[0]} '
                                   'ns; it becomes the new reference.')
        return angular_velocity_from_pulses(last[0], last[1], t_ns, count, self.calibration)
