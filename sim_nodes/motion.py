"""Turntable kinematics: piecewise constant-acceleration motion profiles (pure NumPy).

A profile is a list of pieces, each with a duration and a constant angular
acceleration, starting from a given angle and rate. Angles in rad, rates in
rad/s, times in s relative to the profile start. An optional sinusoidal rate
ripple (METHODS §A.6) is superposed on the whole profile.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class RateRipple:
    """Sinusoidal rate ripple: rate += fraction·nominal_rate·cos(2π·f·t).

    Attributes:
        fraction: ripple amplitude relative to ``nominal_rate_rad_s`` (dimensionless).
        frequency_hz: ripple frequency, Hz.
        nominal_rate_rad_s: rate the fraction refers to, rad/s.
    """

    fraction: float = 0.0
    frequency_hz: float = 5.0
    nominal_rate_rad_s: float = 0.0

    @property
    def angle_amplitude_rad(self) -> float:
        """Amplitude of the angle ripple, rad."""
        if self.fraction == 0.0:
            return 0.0
        return self.fraction * self.nominal_rate_rad_s / (2.0 * math.pi * self.frequency_hz)


class MotionProfile:
    """Angle and rate of a turntable as exact functions of time."""

    def __init__(
        self,
        durations_s: list[float],
        accelerations_rad_s2: list[float],
        *,
        initial_angle_rad: float = 0.0,
        initial_rate_rad_s: float = 0.0,
        ripple: RateRipple | None = None,
    ) -> None:
        """Build a profile from consecutive (duration, acceleration) pieces."""
        if len(durations_s) != len(accelerations_rad_s2) or not durations_s:
            raise ValueError('durations_s and accelerations_rad_s2 must be equal, non-empty lists')
        self._dur = np.asarray(durations_s, dtype=np.float64)
        self._acc = np.asarray(accelerations_rad_s2, dtype=np.float64)
        self._start = np.concatenate(([0.0], np.cumsum(self._dur)[:-1]))
        rate0 = np.empty_like(self._dur)
        angle0 = np.empty_like(self._dur)
        rate, angle = initial_rate_rad_s, initial_angle_rad
        for i, (d, a) in enumerate(zip(self._dur, self._acc)):
            rate0[i], angle0[i] = rate, angle
            angle = angle + rate * d + 0.5 * a * d * d
            rate = rate + a * d
        self._rate0, self._angle0 = rate0, angle0
        self._end_angle, self._end_rate = angle, rate
        self.duration_s = float(np.sum(self._dur))
        self.pieces = (self._dur.tolist(), self._acc.tolist())
        """(durations_s, accelerations_rad_s2) the profile was built from."""
        self.ripple = ripple or RateRipple()

    def _piece(self, t_s: FloatArray) -> tuple[npt.NDArray[np.intp], FloatArray]:
        idx = np.searchsorted(self._start, t_s, side='right') - 1
        idx = np.clip(idx, 0, len(self._dur) - 1)
        return idx, t_s - self._start[idx]

    def angle_rad(self, t_s: FloatArray) -> FloatArray:
        """Table angle (unwrapped), rad, at times ``t_s`` (s from the profile start)."""
        t_s = np.asarray(t_s, dtype=np.float64)
        idx, s = self._piece(t_s)
        angle = self._angle0[idx] + self._rate0[idx] * s + 0.5 * self._acc[idx] * s * s
        amp = self.ripple.angle_amplitude_rad
        if amp:
            angle = angle + amp * np.sin(2.0 * math.pi * self.ripple.frequency_hz * t_s)
        return angle

    def rate_rad_s(self, t_s: FloatArray) -> FloatArray:
        """Table rate, rad/s, at times ``t_s`` (s from the profile start)."""
        t_s = np.asarray(t_s, dtype=np.float64)
        idx, s = self._piece(t_s)
        rate = self._rate0[idx] + self._acc[idx] * s
        if self.ripple.fraction:
            w = 2.0 * math.pi * self.ripple.frequency_hz
            rate = rate + self.ripple.fraction * self.ripple.nominal_rate_rad_s * np.cos(w * t_s)
        return rate


def rate_bias_profile(
    *,
    rate_rad_s: float,
    acceleration_rad_s2: float,
    revolutions_per_segment: float,
    duration_s: float,
    initial_angle_rad: float = 0.0,
    ripple: RateRipple | None = None,
    settle_s: float = 0.0,
) -> MotionProfile:
    """Rate-bias turntable motion (METHODS §A.1).

    From rest: accelerate to +rate, turn ``revolutions_per_segment`` revolutions
    at constant rate, reverse through zero at constant deceleration to -rate (resting
    ``settle_s`` at zero rate on the way, when given), turn the same number of revolutions
    back, reverse again, and so on until ``duration_s``. The constant-rate segments always
    span the same angles.
    """
    if rate_rad_s <= 0.0 or acceleration_rad_s2 <= 0.0 or revolutions_per_segment <= 0.0:
        raise ValueError('rate, acceleration and revolutions_per_segment must be positive')
    if settle_s < 0.0:
        raise ValueError('settle_s must not be negative')
    t_const = revolutions_per_segment * 2.0 * math.pi / rate_rad_s
    t_half = rate_rad_s / acceleration_rad_s2
    durations = [t_half]
    accels = [acceleration_rad_s2]
    direction = 1.0
    while sum(durations) < duration_s:
        if settle_s > 0.0:
            durations += [t_const, t_half, settle_s, t_half]
            accels += [0.0, -direction * acceleration_rad_s2, 0.0,
                       -direction * acceleration_rad_s2]
        else:
            durations += [t_const, 2.0 * t_half]
            accels += [0.0, -direction * acceleration_rad_s2]
        direction = -direction
    return MotionProfile(
        durations, accels, initial_angle_rad=initial_angle_rad, ripple=ripple
    )
