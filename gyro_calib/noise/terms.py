"""The five IEEE Std 952 noise terms: Allan-variance basis, hand-off keys, quoted units.

IEEE Std 952-1997 Annex C (C.1–C.7), with τ the averaging time::

    AVAR(τ) = 3Q²/τ² + N²/τ + (2 ln 2/π)·B² + K²τ/3 + R²τ²/2

    term  name                          ADEV slope  read-off point (IEEE 952)
    Q     quantisation noise            −1          σ(√3 s) = Q
    N     angle/velocity random walk    −½          σ(1 s) = N
    B     bias instability              0           plateau σ = 0.664·B
    K     rate/acceleration random walk +½          σ(3 s) = K
    R     rate/acceleration ramp        +1          σ(√2 s) = R

The coefficients are fitted jointly (:mod:`gyro_calib.noise.fit`); the read-off points are
only where the plot marks each term. The same model serves a gyro axis (angle rad, rate
rad/s) and an accelerometer axis (velocity m/s, acceleration m/s²); the keys carry the
SI unit of each.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]

SYMBOLS = ('Q', 'N', 'B', 'K', 'R')
"""Term symbols in fit order."""
AVAR_EXPONENT = np.array([-2, -1, 0, 1, 2])
"""AVAR ∝ τ^exponent for each term."""
AVAR_FACTOR = np.array([3.0, 1.0, 2.0 * math.log(2.0) / math.pi, 1.0 / 3.0, 0.5])
"""AVAR = factor·coefficient²·τ^exponent for each term."""
READ_OFF_TAU_S = np.array([math.sqrt(3.0), 1.0, math.nan, 3.0, math.sqrt(2.0)])
"""τ at which ADEV equals the coefficient on the term's own line (B: plateau, 0.664·B)."""
BIAS_INSTABILITY_ADEV_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
"""ADEV plateau / B = 0.664."""

STANDARD_GRAVITY_M_S2 = 9.80665
DEG_PER_RAD = 180.0 / math.pi


def avar_basis(tau_s: npt.ArrayLike) -> FloatArray:
    """Design matrix: column k is AVAR of term k with unit coefficient (len(τ) × 5)."""
    tau = np.asarray(tau_s, dtype=np.float64)[:, None]
    return np.asarray(AVAR_FACTOR[None, :] * tau ** AVAR_EXPONENT[None, :], dtype=np.float64)


@dataclass(frozen=True, slots=True)
class TermUnits:
    """Keys and quoted units of the five terms for one kind of axis.

    Attributes:
        kind: 'gyro' or 'accel'.
        keys: hand-off / JSON key of each term (SI unit in the name), in SYMBOLS order.
        names: human name of each term.
        si_units: SI unit of each coefficient.
        quoted_units: the unit people quote each term in.
        quoted_factors: SI value × factor = quoted value.
        rate_unit: unit of the axis's rate (ADEV) values.
        angle_unit: unit of the integrated signal.
    """

    kind: str
    keys: tuple[str, str, str, str, str]
    names: tuple[str, str, str, str, str]
    si_units: tuple[str, str, str, str, str]
    quoted_units: tuple[str, str, str, str, str]
    quoted_factors: tuple[float, float, float, float, float]
    rate_unit: str
    angle_unit: str


GYRO_UNITS = TermUnits(
    kind='gyro',
    keys=('quantization_noise_rad', 'angle_random_walk_rad_per_sqrt_s',
          'bias_instability_rad_s', 'rate_random_walk_rad_per_s_sqrt_s', 'rate_ramp_rad_per_s2'),
    names=('quantisation noise Q', 'angle random walk N', 'bias instability B',
           'rate random walk K', 'rate ramp R'),
    si_units=('rad', 'rad/√s', 'rad/s', 'rad/s/√s', 'rad/s²'),
    quoted_units=('″', '°/√h', '°/h', '°/h/√h', '°/h²'),
    quoted_factors=(DEG_PER_RAD * 3600.0, DEG_PER_RAD * 60.0, DEG_PER_RAD * 3600.0,
                    DEG_PER_RAD * 3600.0 * 60.0, DEG_PER_RAD * 3600.0**2),
    rate_unit='rad/s', angle_unit='rad')
"""Gyro axes: angle in rad, rate in rad/s."""

_UG = 1e6 / STANDARD_GRAVITY_M_S2  # µg per m/s²
ACCEL_UNITS = TermUnits(
    kind='accel',
    keys=('quantization_noise_m_s', 'velocity_random_walk_m_s_per_sqrt_s',
          'bias_instability_m_s2', 'acceleration_random_walk_m_s2_per_sqrt_s',
          'acceleration_ramp_m_s2_per_s'),
    names=('velocity quantisation Q', 'velocity random walk N', 'bias instability B',
           'acceleration random walk K', 'acceleration ramp R'),
    si_units=('m/s', 'm/s/√s', 'm/s²', 'm/s²/√s', 'm/s³'),
    quoted_units=('mm/s', 'm/s/√h', 'µg', 'µg/√h', 'µg/h'),
    quoted_factors=(1e3, 60.0, _UG, _UG * 60.0, _UG * 3600.0),
    rate_unit='m/s²', angle_unit='m/s')
"""Accelerometer axes: velocity in m/s, acceleration in m/s²."""


def units_for_axis(axis: str) -> TermUnits:
    """Units of an axis by name: 'accel…' → accelerometer, anything else → gyro."""
    return ACCEL_UNITS if axis.startswith('accel') else GYRO_UNITS
