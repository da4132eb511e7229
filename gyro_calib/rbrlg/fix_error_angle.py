"""Fix-error angle θ by the four-position and multi-station methods (METHODS §A.3).

The RBRLG is tilted by α on a position table (axis ON); at rate-table station β the
half-difference of the pulses over n forward and n reverse position-table turns is

    K·N_og(β) = φ_ON·(cos α·cos θ − sin α·sin θ·cos β),   φ_ON = 1296000·n ″   eq. (10)

With β = β₀ + ψ (ψ the rate-table encoder angle, β₀ unknown) this is linear in
(c₀, c₁, c₂): N_og = c₀ + c₁·cos ψ + c₂·sin ψ, with
    c₀ = φ·cos α·cos θ / K,  c₁ = −A·cos β₀,  c₂ = A·sin β₀,  A = φ·sin α·sin θ / K.
P = sin α·sin θ and Q = cos α·cos θ then give α and θ exactly:
    cos(α − θ) = Q + P,  cos(α + θ) = Q − P.
The calibration knows K̃ = K/cos θ rather than K (eq. 4); with K = K̃·cos θ eq. (10) becomes
K̃·N_og = φ·(cos α − sin α·tan θ·cos β), which gives them in closed form:
    cos α = K̃·c₀/φ,  tan θ = K̃·√(c₁² + c₂²) / (φ·sin α).
(Putting K̃ where eq. (10) needs K biases α by (1 − cos θ)·cot α: 1.0″ at θ = 647″.)
Four stations at β₀ + k·90° reduce to eqs. (15)–(17); (18) is the paper's small-angle form.

Uncertainty (issue 9 part 4): the fit is weighted by each station's predicted standard
uncertainty when given; the covariance is the larger of that prediction and the scatter of
the residuals (Birge ratio over n − 3 degrees of freedom), the scatter widened by its
Student-t factor when the prediction misses sources the fits cannot see (a changing θ,
wobble of the position table, ARW when not given).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import InsufficientDataError
from gyro_calib.estimate import Estimate
from gyro_calib.units import ARCSEC_PER_REV

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike


@dataclass(frozen=True, slots=True)
class FixErrorAngleResult:
    """θ, β₀ and α from position-table stations, each with its standard uncertainty.

    Attributes:
        fix_error_angle_rad: θ, rad.
        beta0_rad: β₀, azimuth of og's projection at rate-table angle 0, rad.
        tilt_rad: α, tilt of the rate-table axis from the position-table axis ON, rad.
        coefficients: (c₀, c₁, c₂), pulses.
        covariance: 3×3 covariance of the coefficients, pulses².
    """

    fix_error_angle_rad: Estimate
    beta0_rad: Estimate
    tilt_rad: Estimate
    coefficients: tuple[float, float, float]
    covariance: npt.NDArray[np.float64]


def _angles_from_coefficients(c: npt.NDArray[np.float64], k: float, phi: float, *,
                              k_is_k_tilde: bool = False) -> npt.NDArray[np.float64]:
    """(θ, β₀, α) in rad from (c₀, c₁, c₂) (see module docstring).

    ``k`` is K (eq. 10) or, with ``k_is_k_tilde``, K̃ = K/cos θ (the closed form).
    """
    beta0 = math.atan2(c[2], -c[1])
    if k_is_k_tilde:
        cos_alpha = k * c[0] / phi
        if not abs(cos_alpha) < 1.0:
            raise InsufficientDataError(
                f'station counts are inconsistent with eq. (10): cos α = K̃·c₀/φ = '
                f'{cos_alpha:.6f} lies outside (−1, 1) (wrong K̃ or φ_ON?).')
        alpha = math.acos(cos_alpha)
        theta = math.atan(k * math.hypot(c[1], c[2]) / (phi * math.sin(alpha)))
        return np.array([theta, beta0, alpha])
    p = k * math.hypot(c[1], c[2]) / phi
    q = k * c[0] / phi
    if not (abs(q + p) <= 1.0 and abs(q - p) <= 1.0):
        raise InsufficientDataError(
            f'station counts are inconsistent with eq. (10): cos α·cos θ ± sin α·sin θ = '
            f'{q + p:.6f}, {q - p:.6f} lie outside [−1, 1] (wrong K or φ_ON?).')
    plus, minus = math.acos(q - p), math.acos(q + p)  # α + θ, α − θ
    return np.array([(plus - minus) / 2, beta0, (plus + minus) / 2])


def fix_error_angle_multi_station(
    station_angle_rad: ArrayLike,
    half_difference_pulses: ArrayLike,
    *,
    position_table_revolutions: int,
    scale_factor_arcsec_per_pulse: float | None = None,
    k_tilde_arcsec_per_pulse: float | None = None,
    half_difference_std_pulses: ArrayLike | None = None,
    prediction_complete: bool = False,
) -> FixErrorAngleResult:
    """θ, β₀, α from any number of stations by linear least squares (METHODS §A.3).

    Args:
        station_angle_rad: rate-table encoder angle ψ at each station, rad.
        half_difference_pulses: N_og = (N⁺ − N⁻)/2 at each station, pulses.
        position_table_revolutions: n, whole position-table turns each way.
        scale_factor_arcsec_per_pulse: K (eq. 10), ″/pulse; or instead
        k_tilde_arcsec_per_pulse: K̃ = K/cos θ (what the K̃ phase measures), ″/pulse.
        half_difference_std_pulses: predicted standard uncertainty of each N_og, pulses.
            If given, the fit is weighted by them; the covariance is the larger of theirs
            and the residual scatter (from 4 stations on). Otherwise it comes from the
            scatter (needs at least 4 stations).
        prediction_complete: True when ``half_difference_std_pulses`` holds every error
            source; otherwise a scatter-based covariance is widened by its Student-t factor.

    Raises:
        InsufficientDataError: fewer than 3 stations, stations not spread in β (θ and β₀
            unobservable), or counts inconsistent with eq. (10).
    """
    from gyro_calib.estimate import student_t_factor

    if (scale_factor_arcsec_per_pulse is None) == (k_tilde_arcsec_per_pulse is None):
        raise ValueError('give exactly one of scale_factor_arcsec_per_pulse (K) and '
                         'k_tilde_arcsec_per_pulse (K̃)')
    psi = np.asarray(station_angle_rad, dtype=np.float64)
    n_og = np.asarray(half_difference_pulses, dtype=np.float64)
    if psi.shape != n_og.shape or psi.ndim != 1:
        raise ValueError('station_angle_rad and half_difference_pulses must be equal 1-D arrays')
    n = len(psi)
    if n < 3:
        raise InsufficientDataError(f'{n} station(s); the fix-error angle needs at least 3 '
                                    'at different β (4 for an uncertainty from the scatter).')
    design = np.column_stack((np.ones(n), np.cos(psi), np.sin(psi)))
    singular = np.linalg.svd(design / math.sqrt(n), compute_uv=False)
    if singular[-1] < 0.05:
        spread = math.degrees(float(np.ptp(np.unwrap(psi))))
        raise InsufficientDataError(
            f'the {n} stations span only {spread:.1f}° of rate-table angle β: θ and β₀ are '
            'unobservable; spread the stations over the circle (e.g. β₀ + k·90°).')
    dof = n - 3
    if half_difference_std_pulses is not None:
        w = 1.0 / np.asarray(half_difference_std_pulses, dtype=np.float64)
    else:
        if dof < 1:
            raise InsufficientDataError('3 stations fit exactly: give half_difference_std_pulses '
                                        'or use at least 4 stations for an uncertainty.')
        w = np.ones(n)
    coef, *_ = np.linalg.lstsq(design * w[:, None], n_og * w, rcond=None)
    cov_pred = np.linalg.inv((design * w[:, None]).T @ (design * w[:, None]))
    if dof >= 1:
        resid = (n_og - design @ coef) * w
        birge2 = float(resid @ resid) / dof
        widen = 1.0 if (prediction_complete and half_difference_std_pulses is not None) \
            else student_t_factor(dof)
        scale2 = widen * widen * birge2
    else:
        scale2, widen = 0.0, 1.0
    if half_difference_std_pulses is None:
        cov, basis = scale2 * cov_pred, f'scatter of {n} stations'
    elif scale2 > 1.0:
        cov, basis = scale2 * cov_pred, f'scatter of {n} stations (Birge ratio ' \
            f'{math.sqrt(birge2):.2f})'
    else:
        cov, basis = cov_pred, f'predicted from the fits of {n} stations'
    if widen != 1.0 and cov is not cov_pred:
        basis += f' × Student t {widen:.3f} ({dof} dof)'
    if k_tilde_arcsec_per_pulse is not None:
        k, k_is_k_tilde = k_tilde_arcsec_per_pulse, True
    else:
        k, k_is_k_tilde = float(scale_factor_arcsec_per_pulse), False  # type: ignore[arg-type]
    phi = ARCSEC_PER_REV * position_table_revolutions
    angles = _angles_from_coefficients(np.asarray(coef, np.float64), k, phi,
                                       k_is_k_tilde=k_is_k_tilde)
    jac = np.empty((3, 3))
    for j in range(3):
        step = 1e-6 * max(1.0, abs(coef[j]))
        dc = np.zeros(3)
        dc[j] = step
        jac[:, j] = (_angles_from_coefficients(coef + dc, k, phi, k_is_k_tilde=k_is_k_tilde)
                     - _angles_from_coefficients(coef - dc, k, phi, k_is_k_tilde=k_is_k_tilde)
                     ) / (2 * step)
    jac[1] = np.where(np.abs(jac[1]) > math.pi, 0.0, jac[1])
    angle_cov = jac @ cov @ jac.T
    std = np.sqrt(np.diag(angle_cov))
    return FixErrorAngleResult(
        fix_error_angle_rad=Estimate(float(angles[0]), float(std[0]), n, dof, (), basis),
        beta0_rad=Estimate(float(angles[1]), float(std[1]), n, dof, (), basis),
        tilt_rad=Estimate(float(angles[2]), float(std[2]), n, dof, (), basis),
        coefficients=(float(coef[0]), float(coef[1]), float(coef[2])),
        covariance=np.asarray(cov, np.float64),
    )


def fix_error_angle_four_position(
    n1: float, n2: float, n3: float, n4: float, *,
    scale_factor_arcsec_per_pulse: float, position_table_revolutions: int,
) -> tuple[float, float, float]:
    """θ, β₀, α (rad) from four stations at β₀ + k·90° by eqs. (15)–(17), solved jointly.

    (15) sin θ = K·√((N¹−N³)² + (N²−N⁴)²) / (2·φ·sin α)
    (16) sin β₀ = K·(N²−N⁴) / (2·φ·sin α·sin θ)   (quadrant from N¹−N³)
    (17) cos α = K·(N¹+N³) / (2·φ·cos θ)
    (15) and (17) are solved together by fixed-point iteration (θ ≈ 10⁻³ rad, so a few
    steps reach machine precision).
    """
    k, phi = scale_factor_arcsec_per_pulse, ARCSEC_PER_REV * position_table_revolutions
    root = math.hypot(n1 - n3, n2 - n4)
    theta = 0.0
    for _ in range(50):
        cos_alpha = k * (n1 + n3) / (2 * phi * math.cos(theta))
        sin_alpha = math.sqrt(1.0 - cos_alpha * cos_alpha)
        new = math.asin(k * root / (2 * phi * sin_alpha))
        if abs(new - theta) < 1e-16:
            theta = new
            break
        theta = new
    cos_alpha = k * (n1 + n3) / (2 * phi * math.cos(theta))
    alpha = math.acos(cos_alpha)
    beta0 = math.atan2(k * (n2 - n4) / (2 * phi * math.sin(alpha) * math.sin(theta)),
                       -k * (n1 - n3) / (2 * phi * math.sin(alpha) * math.sin(theta)))
    return theta, beta0, alpha


def fix_error_angle_small_angle(n1: float, n2: float, n3: float, n4: float, *,
                                k_tilde_arcsec_per_pulse: float,
                                position_table_revolutions: int) -> float:
    """θ (rad) by the paper's eq. (18): sin θ ≈ θ, cos θ ≈ 1, K ≈ K̃."""
    k = k_tilde_arcsec_per_pulse
    two_phi = 2 * ARCSEC_PER_REV * position_table_revolutions
    return k * math.hypot(n1 - n3, n2 - n4) / math.sqrt(two_phi**2 - (k * (n1 + n3)) ** 2)
