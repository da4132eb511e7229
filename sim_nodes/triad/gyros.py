"""Three pulse gyros of an IMU on the two-axis bench or a single-axis table (METHODS §F.1–F.2).

Frames (docs/methods.md §F.1): P, the position-table base (East-North-Up turned by the heading
about Up); its top turns by χ about ON = z_P; the rate-table base is tilted by α from ON about
y_P; the rate-table top T turns by β = ψ + ψ₀ about oZ; the IMU body B sits on T through the
fixture rotation F (v_B = F·v_T). The body's orientation in P is

    R_PB = R_z(χ)·R_y(α)·R_z(ψ + ψ₀)·Fᵀ                      (two-axis bench)
    R_PB = R_z(ψ)·G(axis)                                     (single-axis table, remounted)

with G(axis) the mount taking the body axis ``axis`` ('+x' … '-z') to the table axis, up.
Over a sample step each gyro i integrates s_i·ω_B: the body increment rotvec(R₀ᵀR₁) plus the
Earth rate rotated into the body at the step's midpoint, plus its bias (along s_i) and angle
random walk, divided by its scale factor K_i; counts are cumulative whole pulses (the
fractional phase carries over, from a random start). No formula of the estimator is used: the
directions u of §F eq. (1)–(2) follow from the composed rotations, and a test checks that they
agree with the estimator's.

Chunks are processed in time order and the random draws are consumed in sample order, so the
output does not depend on how the run is cut into chunks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from gyro_calib.units import (
    ARCSEC_PER_RAD,
    ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H,
    EARTH_RATE_DEG_H,
    NS_PER_S,
    RAD_PER_ARCSEC,
)

if TYPE_CHECKING:
    import numpy.typing as npt

Vector = tuple[float, float, float]
Matrix = tuple[Vector, Vector, Vector]

IDENTITY: Matrix = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))

MOUNT_AXES = ('+x', '-x', '+y', '-y', '+z', '-z')
"""Body axes the remount variant puts along the table axis (pointing up)."""

_MOUNTS: dict[str, tuple[str, float]] = {
    '+x': ('y', -90.0), '-x': ('y', 90.0), '+y': ('x', 90.0), '-y': ('x', -90.0),
    '+z': ('z', 0.0), '-z': ('x', 180.0)}
"""G(axis) as one elementary rotation (body → table top) taking ``axis`` to +z."""


def mount_rotation(axis: str) -> Rotation:
    """G: body → table top with the body axis ``axis`` along the table axis, up."""
    if axis not in _MOUNTS:
        raise ValueError(f'mount axis {axis!r} is not one of {", ".join(MOUNT_AXES)}.')
    about, deg = _MOUNTS[axis]
    return Rotation.from_euler(about, deg, degrees=True)


def _unit(v: Vector) -> Vector:
    n = math.sqrt(sum(c * c for c in v))
    return (v[0] / n, v[1] / n, v[2] / n)


DEFAULT_SENSE_AXES: Matrix = (
    _unit((1.0, 2.1e-3, -1.4e-3)),
    _unit((-0.9e-3, 1.0, 2.6e-3)),
    _unit((3.1e-3, -1.7e-3, 1.0)))
"""Sense axes of the default triad: a few mrad off the body axes, not orthogonal."""


@dataclass(frozen=True, slots=True)
class TriadConfig:
    """Three pulse gyros and the site; every error source is switched off at 0.

    Sense axes are unit vectors in the body frame (given vectors are normalised).
    """

    channels: tuple[str, str, str] = ('x', 'y', 'z')
    """Channel names on /imu/pulses (JointState ``name``), in row order."""
    scale_factor_arcsec_per_pulse: Vector = (0.84279066, 1.1034519, 0.9571233)
    """K_i, ″/pulse."""
    sense_axes: Matrix = DEFAULT_SENSE_AXES
    """s_i, body frame, one row per channel."""
    bias_deg_h: Vector = (0.01, -0.02, 0.015)
    """Constant bias of each gyro along its sense axis, °/h."""
    angle_random_walk_deg_sqrt_h: Vector = (0.0005, 0.0005, 0.0005)
    """Angle random walk of each gyro, °/√h."""
    quantise: bool = True
    """Emit whole pulses (the fractional phase carries over); False emits the phase."""
    latitude_deg: float = 28.2
    """Site latitude, °."""
    heading_deg: float = 0.0
    """Angle from East to the position-table base x axis, counter-clockwise about Up, °."""
    earth_rate_deg_h: float = EARTH_RATE_DEG_H
    """Earth rotation rate, °/h (0 switches the Earth rate off)."""
    seed: int = 1
    """Seed of the gyros' random stream (initial phases, ARW)."""

    def unit_sense_axes(self) -> npt.NDArray[np.float64]:
        """S: the sense axes as unit rows (3, 3)."""
        s = np.asarray(self.sense_axes, dtype=np.float64)
        return np.asarray(s / np.linalg.norm(s, axis=1, keepdims=True), dtype=np.float64)

    def scale_factor_rad_per_pulse(self) -> npt.NDArray[np.float64]:
        """K_i, rad/pulse."""
        return np.asarray(self.scale_factor_arcsec_per_pulse, dtype=np.float64) * RAD_PER_ARCSEC

    def pulses_to_body_rad(self) -> npt.NDArray[np.float64]:
        """M = S⁻¹·diag(K), rad/pulse: ω_B = M·ṅ − b (METHODS §F eq. 11)."""
        return np.asarray(np.linalg.inv(self.unit_sense_axes())
                          @ np.diag(self.scale_factor_rad_per_pulse()), dtype=np.float64)

    def bias_body_rad_s(self) -> npt.NDArray[np.float64]:
        """The body-frame bias b = S⁻¹·b_s, rad/s (METHODS §F eq. 14)."""
        b_s = np.asarray(self.bias_deg_h, dtype=np.float64) * RAD_PER_ARCSEC  # °/h = ″/s
        return np.asarray(np.linalg.solve(self.unit_sense_axes(), b_s), dtype=np.float64)

    def earth_rate_base_rad_s(self) -> npt.NDArray[np.float64]:
        """Earth-rate vector in the position-table base (ENU turned by the heading), rad/s."""
        lat, h = math.radians(self.latitude_deg), math.radians(self.heading_deg)
        east, north, up = self.earth_rate_deg_h * np.array(
            [0.0, math.cos(lat), math.sin(lat)]) * RAD_PER_ARCSEC
        c, s = math.cos(h), math.sin(h)
        return np.array([c * east + s * north, -s * east + c * north, up])


@dataclass(frozen=True, slots=True)
class TriadMountConfig:
    """How the IMU sits on the bench (the truth; the bench settings state the nominal values)."""

    tilt_deg: float = 45.0
    """Nominal α, the rate-table axis oZ from the vertical position-table axis ON, °."""
    tilt_error_arcsec: float = 0.0
    """True α minus the nominal α, ″ (the calibration may fit it within its stated u)."""
    tilt_std_arcsec: float = 60.0
    """The stated standard uncertainty of α, ″ (a bench setting: the fit's prior)."""
    station_offset_deg: float = 0.0
    """ψ₀: rate-table angle of the tilt plane's zero (β = ψ + ψ₀), °."""
    fixture_rotation: Matrix = IDENTITY
    """F: v_B = F·v_T."""
    mount_axis: str = ''
    """Single-axis table: the body axis along the table axis, up ('+x' … '-z'); '' = two-axis."""

    def true_tilt_rad(self) -> float:
        """α as built, rad."""
        return math.radians(self.tilt_deg) + self.tilt_error_arcsec * RAD_PER_ARCSEC

    def fixture(self) -> Rotation:
        """F as a rotation (refused unless a proper rotation matrix)."""
        f = np.asarray(self.fixture_rotation, dtype=np.float64)
        if f.shape != (3, 3) or not np.allclose(f @ f.T, np.eye(3), atol=1e-9) \
                or np.linalg.det(f) < 0:
            raise ValueError('fixture_rotation must be a proper 3×3 rotation matrix.')
        return Rotation.from_matrix(f)

    def orientation(self, chi: npt.NDArray[np.float64],
                    psi: npt.NDArray[np.float64]) -> Rotation:
        """R_PB: body → position-table base at position-table angle χ, rate-table angle ψ."""
        zeros = np.zeros_like(psi)
        if self.mount_axis:
            return (Rotation.from_rotvec(np.column_stack((zeros, zeros, psi)))
                    * mount_rotation(self.mount_axis))
        beta = psi + math.radians(self.station_offset_deg)
        return (Rotation.from_rotvec(np.column_stack((zeros, zeros, chi)))
                * Rotation.from_rotvec([0.0, self.true_tilt_rad(), 0.0])
                * Rotation.from_rotvec(np.column_stack((zeros, zeros, beta)))
                * self.fixture().inv())


@dataclass(slots=True)
class _State:
    t_ns: int
    chi: float
    psi: float
    phase: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))


class TriadGyroSimulator:
    """Cumulative pulses of three gyros on the bench, streamed in time order."""

    def __init__(self, gyros: TriadConfig, mount: TriadMountConfig) -> None:
        """Create the triad in its initial state (random initial count phases)."""
        self.gyros, self.mount = gyros, mount
        self._rng = np.random.default_rng(np.random.SeedSequence(gyros.seed).spawn(1)[0])
        self._start_phase = self._rng.uniform(size=3)
        self._state: _State | None = None
        self._s = gyros.unit_sense_axes()
        self._k_arcsec = np.asarray(gyros.scale_factor_arcsec_per_pulse, dtype=np.float64)
        self._earth = gyros.earth_rate_base_rad_s()
        mount.fixture()  # refuse a bad fixture now, not at the first sample

    def step(self, t_ns: npt.NDArray[np.int64], position_table_rad: npt.NDArray[np.float64],
             rate_table_rad: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Integrate the tables' true angles at ``t_ns``; cumulative counts (n, 3), pulses.

        ``position_table_rad`` is ignored on the single-axis table (pass zeros).
        """
        t_ns = np.asarray(t_ns, dtype=np.int64)
        chi = np.asarray(position_table_rad, dtype=np.float64)
        psi = np.asarray(rate_table_rad, dtype=np.float64)
        if len(t_ns) == 0:
            return np.zeros((0, 3))
        if self._state is None:
            self._state = _State(int(t_ns[0]), float(chi[0]), float(psi[0]),
                                 self._start_phase.copy())
            head = self._emit(self._state.phase[None, :])
            return np.concatenate((head, self.step(t_ns[1:], chi[1:], psi[1:])))
        st = self._state
        t_all = np.concatenate(([st.t_ns], t_ns))
        chi_all = np.concatenate(([st.chi], chi))
        psi_all = np.concatenate(([st.psi], psi))
        dt_s = np.diff(t_all) / NS_PER_S
        rot = self.mount.orientation(chi_all, psi_all)
        turned = (rot[:-1].inv() * rot[1:]).as_rotvec()  # body frame, rad
        mid = self.mount.orientation(0.5 * (chi_all[1:] + chi_all[:-1]),
                                     0.5 * (psi_all[1:] + psi_all[:-1]))
        earth_body = mid.inv().apply(self._earth)  # rad/s in the body
        sensed_arcsec = (turned + earth_body * dt_s[:, None]) @ self._s.T * ARCSEC_PER_RAD
        bias = np.asarray(self.gyros.bias_deg_h, dtype=np.float64)  # °/h = ″/s
        sensed_arcsec += bias[None, :] * dt_s[:, None]
        arw = np.asarray(self.gyros.angle_random_walk_deg_sqrt_h, dtype=np.float64)
        if np.any(arw):
            noise = self._rng.standard_normal((len(dt_s), 3))
            sensed_arcsec += (arw * ARCSEC_PER_SQRT_S_PER_DEG_PER_SQRT_H)[None, :] \
                * np.sqrt(dt_s)[:, None] * noise
        phase = np.cumsum(np.concatenate((st.phase[None, :],
                                          sensed_arcsec / self._k_arcsec[None, :])), axis=0)[1:]
        self._state = _State(int(t_ns[-1]), float(chi[-1]), float(psi[-1]), phase[-1].copy())
        return self._emit(phase)

    def _emit(self, phase: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        return np.floor(phase) if self.gyros.quantise else phase
