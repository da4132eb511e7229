"""Rotation directions and window pairs of the triad bench (METHODS §F.1–F.2).

Frames (docs/methods.md §F.1): the inner-table frame T (z along the rate-table axis oZ, x in
the plane of oZ and the outer axis ON when the rate-table angle β is 0) and the IMU body
frame B, related by the fixture rotation F (v_B = F·v_T). At rate-table angle β = ψ + ψ₀
(ψ the encoder reading, ψ₀ its offset from the tilt plane) the outer axis is

    u_T(β) = (−sin α·cos β, sin α·sin β, cos α),   u_B = F·u_T               eqs. (1)–(2)

and an inner-axis window turns the body about u_B = F·e_z. Sensitivities to the bench
settings α and ψ₀ are eq. (3). A forward and a reverse window reduce to one pair, eqs. (5)–(6).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.units import EARTH_RATE_DEG_H, RAD_PER_ARCSEC

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike

    from gyro_calib.triad.records import TriadPair

TILT = 'tilt α'
"""Name of the bench parameter α (the outer axis ON from the rate-table axis oZ)."""

STATION_OFFSET = 'station offset ψ₀'
"""Name of the bench parameter ψ₀ (rate-table encoder zero from the tilt plane)."""

EARTH_RATE_RAD_S = EARTH_RATE_DEG_H * RAD_PER_ARCSEC
"""Earth rotation rate, rad/s (15.041 °/h = 15.041 ″/s)."""

REMOUNT_AXES = {'+x': (1.0, 0.0, 0.0), '-x': (-1.0, 0.0, 0.0), '+y': (0.0, 1.0, 0.0),
                '-y': (0.0, -1.0, 0.0), '+z': (0.0, 0.0, 1.0), '-z': (0.0, 0.0, -1.0)}
"""Single-axis remount variant: the body axis mounted along the table axis, and its u."""


def _fixture(fixture: ArrayLike | None) -> npt.NDArray[np.float64]:
    f = np.eye(3) if fixture is None else np.asarray(fixture, dtype=np.float64)
    if f.shape != (3, 3) or not np.allclose(f @ f.T, np.eye(3), atol=1e-9) \
            or np.linalg.det(f) < 0:
        raise ValueError('the fixture must be a proper 3×3 rotation matrix (v_B = F·v_T).')
    return f


def outer_axis_direction(station_rad: float, tilt_rad: float, *,
                         station_offset_rad: float = 0.0,
                         fixture: ArrayLike | None = None,
                         ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """u_B of the outer axis at a rate-table station, and ∂u_B/∂(α, ψ₀) (METHODS §F eqs. 1–3).

    Args:
        station_rad: ψ, the rate-table encoder angle at the station, rad.
        tilt_rad: α, the angle from the rate-table axis oZ to the outer axis ON, rad.
        station_offset_rad: ψ₀, rate-table angle of the tilt plane's zero (β = ψ + ψ₀), rad.
        fixture: F, body-from-inner-table rotation (identity: body axes = table axes).

    Returns:
        (u, D): u the unit direction (3,) in the body frame; D (3, 2) its derivatives with
        respect to α and ψ₀ (columns in the order :data:`TILT`, :data:`STATION_OFFSET`).
    """
    f = _fixture(fixture)
    beta = station_rad + station_offset_rad
    sa, ca, sb, cb = math.sin(tilt_rad), math.cos(tilt_rad), math.sin(beta), math.cos(beta)
    u = np.array([-sa * cb, sa * sb, ca])
    d_alpha = np.array([-ca * cb, ca * sb, -sa])
    d_beta = np.array([sa * sb, sa * cb, 0.0])
    return f @ u, f @ np.column_stack((d_alpha, d_beta))


def inner_axis_direction(fixture: ArrayLike | None = None) -> npt.NDArray[np.float64]:
    """u_B = F·e_z of an inner-axis (rate-table) window (METHODS §F eq. 2)."""
    return np.asarray(_fixture(fixture)[:, 2], dtype=np.float64)


def remount_direction(axis: str) -> npt.NDArray[np.float64]:
    """u_B of a single-axis-table window with the body axis ``axis`` ('+x' … '-z') up."""
    if axis not in REMOUNT_AXES:
        raise ValueError(f'remount axis {axis!r} is not one of {", ".join(REMOUNT_AXES)}.')
    return np.array(REMOUNT_AXES[axis])


def earth_rate_along(direction_enu: ArrayLike, latitude_deg: float) -> float:
    """Ω_u = ω_E·u, the Earth rate along a direction given in East-North-Up, rad/s (eq. 13)."""
    lat = math.radians(latitude_deg)
    omega = EARTH_RATE_RAD_S * np.array([0.0, math.cos(lat), math.sin(lat)])
    u = np.asarray(direction_enu, dtype=np.float64)
    return float(omega @ (u / np.linalg.norm(u)))


def inner_axis_enu(*, tilt_rad: float, heading_deg: float,
                   position_table_angle_rad: float) -> npt.NDArray[np.float64]:
    """The rate-table axis oZ in East-North-Up, the outer axis vertical (METHODS §F eq. 13).

    oZ = (sin α·cos χ, sin α·sin χ, cos α) in the position-table base, which is ENU turned
    by the heading h about Up (χ: position-table angle), as §A eq. (4a).
    """
    h, chi = math.radians(heading_deg), position_table_angle_rad
    x, y = math.sin(tilt_rad) * math.cos(chi), math.sin(tilt_rad) * math.sin(chi)
    east = math.cos(h) * x - math.sin(h) * y
    north = math.sin(h) * x + math.cos(h) * y
    return np.array([east, north, math.cos(tilt_rad)])


def pair_from_windows(
    direction: ArrayLike, *,
    forward_counts: ArrayLike, reverse_counts: ArrayLike, counts_std: ArrayLike,
    forward_angle_rad: float, reverse_angle_rad: float,
    forward_s: float, reverse_s: float, angle_std_rad: float = 0.0,
    earth_rate_along_u_rad_s: float = math.nan,
    direction_sensitivity: ArrayLike | None = None,
    stamp_ns: int = 0, rejected: tuple[str, str, str] = ('', '', ''),
    model_counts_std: ArrayLike | None = None,
) -> TriadPair:
    """One forward and one reverse window of all channels as a pair (METHODS §F eqs. 5–6).

    Eliminating the Earth-rate + bias term between the windows (unequal angles A± and
    durations T± allowed, as §A eq. (3a)):

        ΔN = 2·(N⁺·T⁻ − N⁻·T⁺)/(T⁺ + T⁻) = 2·φ·(r·u),   φ = (A⁺·T⁻ + A⁻·T⁺)/(T⁺ + T⁻)

    Args:
        direction: u, the rotation direction in the body frame (unit, forward sense).
        forward_counts: N⁺ per channel (3,), pulses.
        reverse_counts: N⁻ per channel (3,), pulses.
        counts_std: standard uncertainty of each window's count per channel (3,), pulses
            (end fits, quantisation); the ARW over the window is added by
            :func:`~gyro_calib.triad.count_noise.with_count_walk` (the pair keeps its weight).
        forward_angle_rad: A⁺, magnitude of the forward swept angle, rad.
        reverse_angle_rad: A⁻, magnitude of the reverse swept angle, rad.
        forward_s: T⁺, forward window duration, s.
        reverse_s: T⁻, reverse window duration, s.
        angle_std_rad: standard uncertainty of each window's swept angle (encoder, index), rad.
        earth_rate_along_u_rad_s: Ω_u (eq. 13), rad/s; NaN if the site is unknown.
        direction_sensitivity: ∂u/∂p (3, q) for the bench parameters p, or None.
        stamp_ns: start stamp of the pair (for rejection lines).
        rejected: per channel, why that channel's windows are not used ('' = used).
        model_counts_std: the windows' count uncertainty from the error model (the rounding
            at the end fits, eq. (6a)) where ``counts_std`` (the weights) differs; None: the same.
    """
    from gyro_calib.triad.records import TriadPair

    n_p = np.asarray(forward_counts, dtype=np.float64)
    n_m = np.asarray(reverse_counts, dtype=np.float64)
    std = np.asarray(counts_std, dtype=np.float64)
    t_sum = forward_s + reverse_s
    wp, wm = reverse_s / t_sum, forward_s / t_sum
    phi = forward_angle_rad * wp + reverse_angle_rad * wm
    diff = 2.0 * (n_p * wp - n_m * wm)
    diff_std = 2.0 * np.hypot(wp * std, wm * std)
    model = None if model_counts_std is None else np.asarray(model_counts_std, dtype=np.float64)
    phi_std = angle_std_rad * math.hypot(wp, wm)
    return TriadPair(
        direction=np.asarray(direction, dtype=np.float64), swept_angle_rad=phi,
        count_difference=diff, count_difference_std=diff_std, swept_angle_std_rad=phi_std,
        direction_sensitivity=(None if direction_sensitivity is None
                               else np.asarray(direction_sensitivity, dtype=np.float64)),
        sum_rate=(n_p + n_m) / t_sum, sum_rate_std=math.sqrt(2.0) * std / t_sum,
        excess_rate_rad_s=(forward_angle_rad - reverse_angle_rad) / t_sum,
        earth_rate_along_u_rad_s=earth_rate_along_u_rad_s,
        stamp_ns=stamp_ns, rejected=rejected,
        walk_weight_s=4.0 * (wp * wp * forward_s + wm * wm * reverse_s), duration_s=t_sum,
        model_difference_std=None if model is None else 2.0 * np.hypot(wp * model, wm * model),
        model_sum_rate_std=None if model is None else math.sqrt(2.0) * model / t_sum)
