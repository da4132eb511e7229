"""RLG on a rate table mounted tilted on a position table: exact composed rotation.

Frames (METHODS §A.3): P, the position-table base (East-North-Up turned by
``table_heading_deg`` about Up); its top turns by χ about ON = z_P, with an optional
axis wobble of amplitude Δα; the rate-table base oXYZ is tilted by α from ON so that
ON = (−sin α, 0, cos α) in oXYZ; the rate-table top turns by ψ about oZ; the sense axis
og = (sin θ cos β₀, sin θ sin β₀, cos θ) in the rate-table top.

The gyro case orientation is the composition R = R_z(χ)·R_wobble(χ)·R_y(α)·R_z(ψ)
(SciPy ``Rotation``); the angle sensed over a sample step is og · rotvec(R₀ᵀR₁) plus the
Earth rate along og, bias, drift and angle random walk. No small-angle formula of the
estimator is used, so the estimator is checked against the physics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from gyro_calib.units import (
    ARCSEC_PER_RAD,
    ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H,
    NS_PER_S,
    RAD_PER_ARCSEC,
)
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class TiltedMountConfig:
    """How the RBRLG sits on the position table; error sources switch off at 0."""

    tilt_deg: float = 45.0
    """α: tilt of the rate-table axis oZ from the position-table axis ON, °."""
    wobble_arcsec: float = 0.0
    """Δα: amplitude of the position-table axis wobble (once per revolution), ″."""
    fix_error_change_arcsec: float = 0.0
    """Δθ: std of a random change of θ each time the rate table moves to a station, ″."""


class TwoAxisGyroSimulator:
    """Cumulative pulses of an RLG on the two-axis bench, streamed in time order."""

    def __init__(self, gyro: RingLaserGyroConfig, mount: TiltedMountConfig) -> None:
        """Create the gyro in its initial state."""
        self.gyro, self.mount = gyro, mount
        self._rng = np.random.default_rng(np.random.SeedSequence(gyro.seed).spawn(3)[2])
        self._phase = float(self._rng.uniform())
        self._last: tuple[int, float, float] | None = None
        self._first_t_ns: int | None = None
        self._theta = gyro.fix_error_angle_arcsec * RAD_PER_ARCSEC
        self._last_station_psi: float | None = None
        self._earth = gyro.earth_rate_base_arcsec_s() * RAD_PER_ARCSEC  # rad/s in P

    def _sense_axis(self) -> npt.NDArray[np.float64]:
        b = math.radians(self.gyro.sense_axis_azimuth_deg)
        th = self._theta
        return np.array([math.sin(th) * math.cos(b), math.sin(th) * math.sin(b), math.cos(th)])

    def orientation(self, chi: npt.NDArray[np.float64],
                    psi: npt.NDArray[np.float64]) -> Rotation:
        """Gyro case (rate-table top) → position-table base, for angles χ, ψ (rad)."""
        wob = self.mount.wobble_arcsec * RAD_PER_ARCSEC
        wobble = Rotation.from_rotvec(np.column_stack(
            (wob * np.cos(chi), wob * np.sin(chi), np.zeros_like(chi))))
        tilt = Rotation.from_rotvec([0.0, math.radians(self.mount.tilt_deg), 0.0])
        return (Rotation.from_rotvec(np.column_stack((0 * chi, 0 * chi, chi))) * wobble * tilt
                * Rotation.from_rotvec(np.column_stack((0 * psi, 0 * psi, psi))))

    def step(self, t_ns: npt.NDArray[np.int64], position_table_rad: npt.NDArray[np.float64],
             rate_table_rad: npt.NDArray[np.float64],
             rate_table_still: npt.NDArray[np.bool_] | None = None) -> npt.NDArray[np.float64]:
        """Integrate both tables' true angles at ``t_ns``; return cumulative counts (pulses).

        ``rate_table_still`` marks samples where the rate table holds a station; a new
        station draws a new fix-error change Δθ (if configured).
        """
        t_ns = np.asarray(t_ns, dtype=np.int64)
        chi = np.asarray(position_table_rad, dtype=np.float64)
        psi = np.asarray(rate_table_rad, dtype=np.float64)
        if self._last is None:
            self._first_t_ns = int(t_ns[0])
            self._last = (int(t_ns[0]), float(chi[0]), float(psi[0]))
            head = self._counts(np.zeros(1))
            if len(t_ns) == 1:
                return head
            still = None if rate_table_still is None else rate_table_still[1:]
            return np.concatenate((head, self.step(t_ns[1:], chi[1:], psi[1:], still)))
        cfg = self.gyro
        t_all = np.concatenate(([self._last[0]], t_ns))
        chi_all = np.concatenate(([self._last[1]], chi))
        psi_all = np.concatenate(([self._last[2]], psi))
        dt_s = np.diff(t_all) / NS_PER_S
        if self.mount.fix_error_change_arcsec and rate_table_still is not None:
            self._maybe_new_station(psi, rate_table_still)
        og = self._sense_axis()
        rot = self.orientation(chi_all, psi_all)
        relative = (rot[:-1].inv() * rot[1:]).as_rotvec()  # body frame, rad
        mid = self.orientation(0.5 * (chi_all[1:] + chi_all[:-1]),
                               0.5 * (psi_all[1:] + psi_all[:-1]))
        earth_body = mid.inv().apply(self._earth)  # rad/s in the gyro case
        sensed_rad = relative @ og + (earth_body @ og) * dt_s
        assert self._first_t_ns is not None  # set by the first sample
        t_h = (t_ns - self._first_t_ns) / NS_PER_S / 3600.0
        bias = (cfg.bias_deg_h + cfg.bias_drift_deg_h_per_h * t_h) * dt_s  # ″
        increments = sensed_rad * ARCSEC_PER_RAD + bias
        if cfg.angle_random_walk_deg_sqrt_h:
            n_arw = cfg.angle_random_walk_deg_sqrt_h * ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H
            increments = increments + n_arw * np.sqrt(dt_s) * self._rng.standard_normal(len(dt_s))
        lock_in = cfg.lock_in_rate_deg_s * 3600.0
        if lock_in:
            increments = np.where(np.abs(increments) < lock_in * dt_s, 0.0, increments)
        self._last = (int(t_ns[-1]), float(chi[-1]), float(psi[-1]))
        return self._counts(increments / cfg.scale_factor_arcsec_per_pulse)

    def _maybe_new_station(self, psi: npt.NDArray[np.float64],
                           still: npt.NDArray[np.bool_]) -> None:
        if not np.any(still):
            return
        station = float(psi[np.argmax(still)])
        if self._last_station_psi is None or abs(station - self._last_station_psi) > 1e-3:
            base = self.gyro.fix_error_angle_arcsec
            change = self._rng.normal() * self.mount.fix_error_change_arcsec
            self._theta = (base + change) * RAD_PER_ARCSEC
            self._last_station_psi = station

    def _counts(self, increments_pulses: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        phase = np.cumsum(np.concatenate(([self._phase], increments_pulses)))[1:]
        self._phase = float(phase[-1])
        return np.floor(phase) if self.gyro.quantise else phase
