"""Ring laser gyro on a rate-bias turntable: exact sensed angle, pulses (pure physics).

The gyro sense axis og sits at the fix-error angle θ from the table axis oZ, at
azimuth β in the table-top frame: og = (sin θ cos β, sin θ sin β, cos θ)
(METHODS §A.3). Over each sample step it integrates the inertial rate projected
on og: the table rate about oZ (exact from the angle difference) plus the Earth
rate expressed in the table-top frame (integrated in closed form for a
linearly moving table angle), plus bias, bias drift and angle random walk.
The output is a cumulative count of whole pulses; the fractional phase carries
over (METHODS §A.6). Within the lock-in band the beams lock and no pulse comes.

Chunks are processed in time order and random draws are consumed in sample
order, so the output does not depend on how the run is cut into chunks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import (
    ARCSEC_PER_RAD,
    ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H,
    EARTH_RATE_DEG_H,
    NS_PER_S,
    RAD_PER_ARCSEC,
)

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class RingLaserGyroConfig:
    """RLG and site parameters; defaults are the paper's gyro (seed 000).

    Every error source is switched off by setting it to zero (or ``quantise=False``).
    """

    scale_factor_arcsec_per_pulse: float = 0.84279066
    """True scale factor K, ″/pulse."""
    fix_error_angle_arcsec: float = 646.75
    """Fix-error angle θ between sense axis og and table axis oZ, ″."""
    sense_axis_azimuth_deg: float = 30.0
    """Azimuth β of og's projection on the table top, from oX at table angle 0, °."""
    latitude_deg: float = 28.2
    """Site latitude, ° (Earth-rate vertical component 15.041·sin(latitude) °/h)."""
    table_heading_deg: float = 0.0
    """Angle from East to the table-base oX axis, counter-clockwise about Up, °."""
    earth_rate_deg_h: float = EARTH_RATE_DEG_H
    """Earth rotation rate, °/h (0 switches Earth rate off)."""
    bias_deg_h: float = 0.01
    """Constant gyro bias ω_B, °/h."""
    bias_drift_deg_h_per_h: float = 0.002
    """Linear bias drift, (°/h) per hour."""
    angle_random_walk_deg_sqrt_h: float = 0.0005
    """Angle random walk N, °/√h."""
    lock_in_rate_deg_s: float = 0.05
    """Lock-in dead band: |sensed rate| below this gives no pulses, °/s."""
    quantise: bool = True
    """Emit whole pulses (the fractional phase carries over); False emits the phase."""
    seed: int = 1
    """Seed of the gyro's random stream (ARW, initial phase)."""

    def earth_rate_base_arcsec_s(self) -> npt.NDArray[np.float64]:
        """Earth-rate vector in the table-base frame (oZ up), ″/s."""
        lat = math.radians(self.latitude_deg)
        east_north_up = self.earth_rate_deg_h * np.array([0.0, math.cos(lat), math.sin(lat)])
        h = math.radians(self.table_heading_deg)
        # base frame = ENU turned by h about Up; components of the same vector in it
        c, s = math.cos(h), math.sin(h)
        x = c * east_north_up[0] + s * east_north_up[1]
        y = -s * east_north_up[0] + c * east_north_up[1]
        return np.array([x, y, east_north_up[2]])  # °/h equals ″/s


class RingLaserGyroSimulator:
    """Turns the table's true motion into cumulative gyro pulse counts."""

    def __init__(self, config: RingLaserGyroConfig) -> None:
        """Create the gyro in its initial state (random initial fractional phase)."""
        self.config = config
        self._rng = np.random.default_rng(np.random.SeedSequence(config.seed).spawn(2)[1])
        self._phase_pulses = float(self._rng.uniform())  # initial fractional phase
        self._last_t_ns: int | None = None
        self._last_angle_rad = 0.0
        self._first_t_ns: int | None = None
        theta = config.fix_error_angle_arcsec * RAD_PER_ARCSEC
        self._cos_theta, self._sin_theta = math.cos(theta), math.sin(theta)
        self._beta = math.radians(config.sense_axis_azimuth_deg)
        self._earth = config.earth_rate_base_arcsec_s()

    @property
    def last_stamp_ns(self) -> int | None:
        """Stamp of the last sample integrated, ns (None before the first)."""
        return self._last_t_ns

    def sensed_increments_arcsec(
        self, t_ns: npt.NDArray[np.int64], angle_rad: npt.NDArray[np.float64]
    ) -> npt.NDArray[np.float64]:
        """Angle sensed along og over each step ending at a sample, ″ (before lock-in)."""
        cfg = self.config
        assert self._last_t_ns is not None and self._first_t_ns is not None  # the first sample
        t_all = np.concatenate(([self._last_t_ns], t_ns)).astype(np.int64)
        psi = np.concatenate(([self._last_angle_rad], angle_rad))
        dt_s = np.diff(t_all) / NS_PER_S
        dpsi = np.diff(psi)
        # ∫cos(β+ψ)dt and ∫sin(β+ψ)dt for ψ linear in the step (exact closed form)
        a0, a1 = self._beta + psi[:-1], self._beta + psi[1:]
        moving = np.abs(dpsi) > 1e-9
        safe = np.where(moving, dpsi, 1.0)
        mid = 0.5 * (a0 + a1)
        int_cos = np.where(moving, (np.sin(a1) - np.sin(a0)) / safe, np.cos(mid)) * dt_s
        int_sin = np.where(moving, (np.cos(a0) - np.cos(a1)) / safe, np.sin(mid)) * dt_s
        wx, wy, wz = self._earth
        earth = wz * self._cos_theta * dt_s + self._sin_theta * (wx * int_cos + wy * int_sin)
        t_h = (t_ns - self._first_t_ns) / NS_PER_S / 3600.0
        bias = (cfg.bias_deg_h + cfg.bias_drift_deg_h_per_h * t_h) * dt_s
        increments = self._cos_theta * dpsi * ARCSEC_PER_RAD + earth + bias
        if cfg.angle_random_walk_deg_sqrt_h:
            n_arw = cfg.angle_random_walk_deg_sqrt_h * ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H
            increments = increments + n_arw * np.sqrt(dt_s) * self._rng.standard_normal(len(dt_s))
        return np.asarray(increments, np.float64)

    def step(
        self, t_ns: npt.NDArray[np.int64], angle_rad: npt.NDArray[np.float64]
    ) -> npt.NDArray[np.float64]:
        """Integrate true table angles at stamps ``t_ns``; return cumulative counts (pulses).

        Raises:
            ValueError: if the stamps do not increase strictly from the last call on.
        """
        t_ns = np.asarray(t_ns, dtype=np.int64)
        angle_rad = np.asarray(angle_rad, dtype=np.float64)
        if len(t_ns) == 0:
            return np.zeros(0)
        if self._last_t_ns is None:
            self._first_t_ns = int(t_ns[0])
            self._last_t_ns, self._last_angle_rad = int(t_ns[0]) - 1, float(angle_rad[0])
            # the very first sample has no step before it: integrate nothing there
            first = self._counts(np.zeros(1))
            self._last_t_ns = int(t_ns[0])
            if len(t_ns) == 1:
                return first
            return np.concatenate((first, self.step(t_ns[1:], angle_rad[1:])))
        if np.any(np.diff(np.concatenate(([self._last_t_ns], t_ns))) <= 0):
            raise ValueError('sample stamps must increase strictly')
        increments = self.sensed_increments_arcsec(t_ns, angle_rad)
        dt_s = np.diff(np.concatenate(([self._last_t_ns], t_ns))) / NS_PER_S
        lock_in = self.config.lock_in_rate_deg_s * 3600.0  # ″/s
        if lock_in:
            increments = np.where(np.abs(increments) < lock_in * dt_s, 0.0, increments)
        self._last_t_ns, self._last_angle_rad = int(t_ns[-1]), float(angle_rad[-1])
        return self._counts(increments / self.config.scale_factor_arcsec_per_pulse)

    def _counts(self, increments_pulses: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        phase = np.cumsum(np.concatenate(([self._phase_pulses], increments_pulses)))[1:]
        self._phase_pulses = float(phase[-1])
        return np.floor(phase) if self.config.quantise else phase
