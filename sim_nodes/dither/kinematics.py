"""Exact kinematics of a dithered RLG cavity on a single-axis angular vibration table.

Frames (METHODS §C): the gyro case frame has X normal to the mounting face (nominal input
axis), Z toward the cathode, Y toward the anode. The dither axis DI lies in the XZ plane,
tilted from X by b₀: DI = (cos b₀, 0, sin b₀). With ẑ' = (−sin b₀, 0, cos b₀) and
ŷ' = ẑ' × DI = Y, the input axis IA, fixed in the cavity, is at the dither-axis
misalignment a from DI and azimuth ψ₀:

    IA = cos a·DI + sin a·(cos ψ₀·ẑ' + sin ψ₀·ŷ')          (cavity frame, at φ = 0)

The cavity orientation in the laboratory is the composition

    R(t) = R_mount · R_T(θ_T(t)) · R_Y(θ_xz(t)) · R_Z(θ_xy(t)) · R_DI(φ(t))

(SciPy ``Rotation``): the table turns the case about its axis (case Z or case Y) by θ_T;
the transverse rocking turns the cavity about case Y by θ_xz and about case Z by θ_xy; the
dither turns it about DI by φ. Each factor is a rotation about a fixed axis, so the cavity
(body-frame) angular velocity follows exactly from the chain rule

    ω_b = R_DIᵀ·(R_Zᵀ·(R_Yᵀ·θ̇_T·n_T + θ̇_xz·Y) + θ̇_xy·Z) + φ̇·DI  (+ Rᵀ·ω_earth)

with no small-angle approximation. The angle an RLG senses is ∫ω_b·IA dt; it is integrated
per output sample by Gauss–Legendre quadrature, whose error for the band-limited integrand
here (lines at Ω_d, Ω_z, their sums and harmonics) is below 1e-12 of a step's increment.

Sign convention: a positive dither φ (right-handed about DI) turns IA's azimuth from ψ₀ to
ψ₀ − φ, so with the table along Z the gyro sees ω_T·(b₀ + a·cos(ψ₀ − φ)): the sideband
coefficient of φ·ω_T is +a·sin ψ₀ (along Y it is −a·cos ψ₀), as METHODS §C eq. 1. The
seed write-up had a·cos(ψ₀ + φ); only the sign convention of ψ₀ differs, the magnitudes
a·|sin ψ₀| and a·|cos ψ₀| are the same.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]

X_AXIS = np.array([1.0, 0.0, 0.0])
Y_AXIS = np.array([0.0, 1.0, 0.0])
Z_AXIS = np.array([0.0, 0.0, 1.0])
CASE_AXES = {'z': Z_AXIS, 'y': Y_AXIS}
"""Case axis the vibration table axis is aligned with, by joint_states frame_id."""


@dataclass(frozen=True, slots=True)
class Sinusoids:
    """An angle that is a sum of sinusoids: θ(t) = Σ amplitude_i·sin(ω_i·t + phase_i).

    Attributes:
        amplitudes_rad: angle amplitudes, rad.
        angular_frequencies_rad_s: ω_i, rad/s.
        phases_rad: phases at t = 0, rad.
    """

    amplitudes_rad: tuple[float, ...] = ()
    angular_frequencies_rad_s: tuple[float, ...] = ()
    phases_rad: tuple[float, ...] = ()

    def angle_rad(self, t_s: FloatArray) -> FloatArray:
        """θ(t), rad."""
        out = np.zeros_like(t_s)
        for amp, w, p in zip(self.amplitudes_rad, self.angular_frequencies_rad_s,
                             self.phases_rad):
            if amp:
                out += amp * np.sin(w * t_s + p)
        return out

    def rate_rad_s(self, t_s: FloatArray) -> FloatArray:
        """θ̇(t), rad/s."""
        out = np.zeros_like(t_s)
        for amp, w, p in zip(self.amplitudes_rad, self.angular_frequencies_rad_s,
                             self.phases_rad):
            if amp:
                out += amp * w * np.cos(w * t_s + p)
        return out

    @property
    def active(self) -> bool:
        """True if any amplitude is non-zero."""
        return any(self.amplitudes_rad)


@dataclass(frozen=True, slots=True)
class CavityGeometry:
    """Where the dither axis and the input axis sit (METHODS §C).

    Attributes:
        misalignment_rad: a, angle between DI and IA, rad.
        ia_azimuth_rad: ψ₀, azimuth of IA about DI, from ẑ' toward ŷ' = Y, rad.
        di_tilt_rad: b₀, static tilt of DI from case X in the XZ plane (toward Z), rad.
    """

    misalignment_rad: float
    ia_azimuth_rad: float
    di_tilt_rad: float

    @property
    def dither_axis(self) -> FloatArray:
        """DI in the case (and cavity) frame."""
        b = self.di_tilt_rad
        return np.array([math.cos(b), 0.0, math.sin(b)])

    @property
    def input_axis(self) -> FloatArray:
        """IA in the cavity frame (equal to the case frame at φ = 0, no rocking)."""
        b, a, psi = self.di_tilt_rad, self.misalignment_rad, self.ia_azimuth_rad
        z_prime = np.array([-math.sin(b), 0.0, math.cos(b)])
        return (math.cos(a) * self.dither_axis
                + math.sin(a) * (math.cos(psi) * z_prime + math.sin(psi) * Y_AXIS))


@dataclass(frozen=True, slots=True)
class CavityMotion:
    """Every angle that moves the cavity, as functions of time.

    Attributes:
        table_axis: case axis the table turns about, ``'z'`` or ``'y'``.
        table: table angle θ_T(t).
        dither: dither angle φ(t) about DI.
        rocking_y: θ_xz(t), transverse rocking about case Y.
        rocking_z: θ_xy(t), transverse rocking about case Z.
        mount: rotation from the case frame (table at zero) to the laboratory frame.
        earth_rate_lab_rad_s: Earth rate in the laboratory frame, rad/s.
    """

    table_axis: str
    table: Sinusoids
    dither: Sinusoids
    rocking_y: Sinusoids
    rocking_z: Sinusoids
    mount: Rotation
    earth_rate_lab_rad_s: FloatArray

    def body_rate_rad_s(self, t_s: FloatArray, geometry: CavityGeometry) -> FloatArray:
        """Angular velocity of the cavity in its own frame at times ``t_s`` (n × 3), rad/s.

        Exact for the composition in the module docstring (chain rule on fixed-axis
        rotations; no small-angle approximation).
        """
        n_t = CASE_AXES[self.table_axis]
        di = geometry.dither_axis
        # case frame: table rate about its axis plus the Earth rate seen by the turned case
        omega = self.table.rate_rad_s(t_s)[:, None] * n_t
        if np.any(self.earth_rate_lab_rad_s):
            earth_case = self.mount.apply(self.earth_rate_lab_rad_s, inverse=True)
            r_t = Rotation.from_rotvec(self.table.angle_rad(t_s)[:, None] * n_t)
            omega = omega + r_t.apply(earth_case, inverse=True)
        for axis, rock in ((Y_AXIS, self.rocking_y), (Z_AXIS, self.rocking_z)):
            if rock.active:
                r = Rotation.from_rotvec(rock.angle_rad(t_s)[:, None] * axis)
                omega = r.apply(omega, inverse=True) + rock.rate_rad_s(t_s)[:, None] * axis
        r_d = Rotation.from_rotvec(self.dither.angle_rad(t_s)[:, None] * di)
        omega = r_d.apply(omega, inverse=True) + self.dither.rate_rad_s(t_s)[:, None] * di
        return omega

    def sensed_rate_rad_s(self, t_s: FloatArray, geometry: CavityGeometry) -> FloatArray:
        """ω_b·IA at times ``t_s``, rad/s (what the RLG senses, before bias and noise)."""
        return self.body_rate_rad_s(t_s, geometry) @ geometry.input_axis


def gauss_legendre_increments(motion: CavityMotion, geometry: CavityGeometry,
                              t0_s: FloatArray, t1_s: FloatArray, nodes: int) -> FloatArray:
    """∫ω_b·IA dt over each interval [t0_s[i], t1_s[i]], rad (Gauss–Legendre, ``nodes`` points).

    Each interval is integrated on its own, so the result for an interval does not depend on
    which other intervals are computed with it (chunking never changes a sample).
    """
    x, w = np.polynomial.legendre.leggauss(nodes)
    half = 0.5 * (t1_s - t0_s)
    mid = 0.5 * (t1_s + t0_s)
    t_nodes = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    rate = motion.sensed_rate_rad_s(t_nodes, geometry).reshape(len(t0_s), nodes)
    return (rate * w[None, :]).sum(axis=1) * half


def periodic_mean_sensed_rate_rad_s(motion: CavityMotion, geometry: CavityGeometry,
                                    period_s: float, points: int = 512) -> float:
    """Mean of ω_b·IA over one period of a periodic motion, rad/s (the exact coning drift).

    The trapezoid rule on a periodic, band-limited integrand converges exponentially, so
    with the table still this is the exact drift of the sensed angle to machine precision.
    """
    t = np.arange(points) * (period_s / points)
    return float(np.mean(motion.sensed_rate_rad_s(t, geometry)))


def mount_rotation(table_axis: str, heading_rad: float) -> Rotation:
    """Case → laboratory (East-North-Up) rotation for a vertical table axis.

    The case axis along the table axis points Up; case X is horizontal, at ``heading_rad``
    counter-clockwise from East about Up.
    """
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    x_lab = np.array([c, s, 0.0])
    up = np.array([0.0, 0.0, 1.0])
    if table_axis == 'z':
        z_lab = up
        y_lab = np.cross(z_lab, x_lab)
    elif table_axis == 'y':
        y_lab = up
        z_lab = np.cross(x_lab, y_lab)
    else:
        raise ValueError(f"table_axis must be 'z' or 'y', got {table_axis!r}")
    return Rotation.from_matrix(np.column_stack((x_lab, y_lab, z_lab)))


def earth_rate_enu_rad_s(earth_rate_rad_s: float, latitude_rad: float) -> FloatArray:
    """Earth-rate vector in East-North-Up, rad/s."""
    return earth_rate_rad_s * np.array([0.0, math.cos(latitude_rad), math.sin(latitude_rad)])
