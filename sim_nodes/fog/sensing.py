"""What the FOG's sense axis feels: table rate, Earth rate, bias, scale-factor terms.

The sense axis sits at a small tilt θ from the table axis oZ, at azimuth β on the
table top: og = (sin θ cos β, sin θ sin β, cos θ). It feels the table rate projected on
it (cos θ·ω), the Earth rate expressed in the turning table frame (the vertical part
constant, the horizontal part turning with the table and averaging out over whole
revolutions), and the bias. The IEEE Std 952 scale-factor terms (asymmetry a, k₂, k₃)
act on the table rate along the axis, ω_t = cos θ·ω:
ω_t → ω_t + (a/2)·|ω_t| + k₂·ω_t² + k₃·ω_t³.

Also: the injection schedule (`/fog/injection` messages: a value in force from its stamp
until the next one).
"""

from __future__ import annotations

import bisect
import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    from sim_nodes.fog.config import FogConfig

    FloatArray = npt.NDArray[np.float64]


class SenseAxis:
    """Sensed rate and sensed angle of the FOG on a turning table."""

    def __init__(self, config: FogConfig) -> None:
        """Precompute the mount geometry and the Earth-rate vector."""
        self.config = config
        theta = math.radians(config.sense_axis_tilt_deg)
        self.cos_tilt, self.sin_tilt = math.cos(theta), math.sin(theta)
        self.azimuth = math.radians(config.sense_axis_azimuth_deg)
        self.earth = config.earth_rate_base_rad_s()
        self.asym_half = 0.5e-6 * config.scale_factor_asymmetry_ppm
        self.k2 = config.scale_factor_quadratic_s_per_rad
        self.k3 = config.scale_factor_cubic_s2_per_rad2

    def scale_factor_terms(self, axis_rate_rad_s: FloatArray) -> FloatArray:
        """Extra sensed rate from asymmetry, k₂ and k₃ at table rate ω_t along the axis, rad/s."""
        w = axis_rate_rad_s
        extra = np.zeros_like(w)
        if self.asym_half:
            extra = extra + self.asym_half * np.abs(w)
        if self.k2:
            extra = extra + self.k2 * w * w
        if self.k3:
            extra = extra + self.k3 * w * w * w
        return extra

    def earth_rate_rad_s(self, table_angle_rad: FloatArray) -> FloatArray:
        """Earth rate along the sense axis at table angle ψ, rad/s."""
        wx, wy, wz = self.earth
        a = self.azimuth + np.asarray(table_angle_rad, dtype=np.float64)
        return wz * self.cos_tilt + self.sin_tilt * (wx * np.cos(a) + wy * np.sin(a))

    def rate_rad_s(self, table_angle_rad: FloatArray, table_rate_rad_s: FloatArray) -> FloatArray:
        """Sensed rate at instants where the table is at ψ turning at ω, rad/s."""
        w_axis = self.cos_tilt * np.asarray(table_rate_rad_s, dtype=np.float64)
        return (w_axis + self.scale_factor_terms(w_axis)
                + self.earth_rate_rad_s(table_angle_rad) + self.config.bias_rad_s)

    def angle_increments_rad(self, dt_s: FloatArray, angle0_rad: FloatArray,
                             angle1_rad: FloatArray, rate0_rad_s: FloatArray,
                             rate1_rad_s: FloatArray) -> FloatArray:
        """Sensed angle over intervals of length dt where the table goes ψ₀ → ψ₁, rad.

        The table term is exact (cos θ·Δψ); the horizontal Earth rate is integrated in
        closed form for ψ linear in the interval; the scale-factor terms use the mean rate
        of the interval (exact at constant rate).
        """
        wx, wy, wz = self.earth
        dpsi = angle1_rad - angle0_rad
        a0, a1 = self.azimuth + angle0_rad, self.azimuth + angle1_rad
        moving = np.abs(dpsi) > 1e-9
        safe = np.where(moving, dpsi, 1.0)
        mid = 0.5 * (a0 + a1)
        int_cos = np.where(moving, (np.sin(a1) - np.sin(a0)) / safe, np.cos(mid)) * dt_s
        int_sin = np.where(moving, (np.cos(a0) - np.cos(a1)) / safe, np.sin(mid)) * dt_s
        earth = wz * self.cos_tilt * dt_s + self.sin_tilt * (wx * int_cos + wy * int_sin)
        w_mid = self.cos_tilt * 0.5 * (rate0_rad_s + rate1_rad_s)
        return (self.cos_tilt * dpsi + self.scale_factor_terms(w_mid) * dt_s + earth
                + self.config.bias_rad_s * dt_s)


class InjectionSchedule:
    """Injected ramp as the output rate a linear loop would add (counts/s), by stamp.

    A value is in force from its stamp until the next one; before the first, none (0).
    """

    def __init__(self, t_ns: npt.ArrayLike = (), rate_counts_s: npt.ArrayLike = ()) -> None:
        """Start from messages (stamps non-decreasing; a repeated stamp replaces)."""
        self._t: list[int] = []
        self._v: list[float] = []
        for t, v in zip(np.asarray(t_ns, dtype=np.int64).tolist(),
                        np.asarray(rate_counts_s, dtype=np.float64).tolist()):
            self.add(int(t), float(v))

    def add(self, t_ns: int, rate_counts_s: float) -> None:
        """Schedule a new value from ``t_ns`` on."""
        if self._t and t_ns < self._t[-1]:
            raise ValueError('injection stamps must not decrease')
        if not math.isfinite(rate_counts_s):
            raise ValueError('injection must be finite')
        if self._t and t_ns == self._t[-1]:
            self._v[-1] = rate_counts_s
        else:
            self._t.append(int(t_ns))
            self._v.append(rate_counts_s)

    def value_at(self, t_ns: int) -> float:
        """Injection in force at ``t_ns``, counts/s."""
        i = bisect.bisect_right(self._t, t_ns) - 1
        return self._v[i] if i >= 0 else 0.0

    def values_at(self, t_ns: npt.NDArray[np.int64]) -> FloatArray:
        """Injection in force at each stamp, counts/s."""
        if not self._t:
            return np.zeros(len(t_ns))
        i = np.searchsorted(np.asarray(self._t, dtype=np.int64), t_ns, side='right') - 1
        v = np.asarray(self._v, dtype=np.float64)
        return np.where(i >= 0, v[np.maximum(i, 0)], 0.0)

    def changes_in(self, t0_ns: int, t1_ns: int) -> list[tuple[int, float]]:
        """Changes with t0 < stamp < t1 (a change exactly at t1 rules the next interval)."""
        lo = bisect.bisect_right(self._t, t0_ns)
        hi = bisect.bisect_left(self._t, t1_ns)
        return list(zip(self._t[lo:hi], self._v[lo:hi]))

    @property
    def messages(self) -> tuple[npt.NDArray[np.int64], FloatArray]:
        """All scheduled (stamps ns, values counts/s)."""
        return np.asarray(self._t, dtype=np.int64), np.asarray(self._v, dtype=np.float64)
