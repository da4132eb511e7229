"""θ, β₀, α from position-table stations (METHODS §A.3) and the error budgets (§A.2, §A.4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gyro_calib.errors import InsufficientDataError
from gyro_calib.rbrlg.error_budget import (
    fix_error_angle_error_bound_arcsec,
    scale_factor_relative_error_bound,
)
from gyro_calib.rbrlg.fix_error_angle import (
    fix_error_angle_four_position,
    fix_error_angle_multi_station,
    fix_error_angle_small_angle,
)
from gyro_calib.units import ARCSEC_PER_RAD, RAD_PER_ARCSEC

K = 0.84279066
THETA = 646.75 * RAD_PER_ARCSEC
ALPHA = math.radians(45.3)
BETA0 = math.radians(23.0)
PHI = 1296000.0  # n = 1


def _n_og(psi: np.ndarray) -> np.ndarray:
    """Eq. (10) with β = β₀ + ψ, in pulses."""
    return PHI * (math.cos(ALPHA) * math.cos(THETA)
                  - math.sin(ALPHA) * math.sin(THETA) * np.cos(BETA0 + psi)) / K


def test_multi_station_fit_recovers_theta_beta0_alpha_exactly() -> None:
    psi = np.radians(np.arange(0, 360, 10.0))
    res = fix_error_angle_multi_station(psi, _n_og(psi), scale_factor_arcsec_per_pulse=K,
                                        position_table_revolutions=1)
    assert res.fix_error_angle_rad.value * ARCSEC_PER_RAD == pytest.approx(646.75, abs=1e-6)
    assert res.beta0_rad.value == pytest.approx(BETA0, abs=1e-9)
    assert res.tilt_rad.value == pytest.approx(ALPHA, abs=1e-12)
    assert res.fix_error_angle_rad.n_used == 36


def test_four_stations_least_squares_equals_eqs_15_to_17() -> None:
    psi = np.radians([0.0, 90.0, 180.0, 270.0])
    rng = np.random.default_rng(1)
    n = _n_og(psi) + rng.normal(0, 0.3, 4)
    n[[0, 2]] += 0.2  # keep N¹+N³ = N²+N⁴ broken a little: noise in c₀ only
    n[[1, 3]] -= 0.2
    theta, beta0, alpha = fix_error_angle_four_position(
        *n, scale_factor_arcsec_per_pulse=K, position_table_revolutions=1)
    res = fix_error_angle_multi_station(psi, n, scale_factor_arcsec_per_pulse=K,
                                        position_table_revolutions=1,
                                        half_difference_std_pulses=np.full(4, 0.3))
    c0, c1, c2 = res.coefficients
    # the LS coefficients are the four-position combinations
    assert c1 == pytest.approx((n[0] - n[2]) / 2, abs=1e-9)
    assert c2 == pytest.approx((n[1] - n[3]) / 2, abs=1e-9)
    assert c0 == pytest.approx(n.mean(), abs=1e-9)
    # eqs (15)-(16) match exactly; (17) uses (N¹+N³)/2 where LS uses the mean of all four
    assert res.beta0_rad.value == pytest.approx(beta0, abs=1e-12)
    n_sym = n.copy()
    n_sym[[0, 2]] -= (n[0] + n[2] - n[1] - n[3]) / 4
    n_sym[[1, 3]] += (n[0] + n[2] - n[1] - n[3]) / 4
    theta_s, _, alpha_s = fix_error_angle_four_position(
        *n_sym, scale_factor_arcsec_per_pulse=K, position_table_revolutions=1)
    res_s = fix_error_angle_multi_station(psi, n_sym, scale_factor_arcsec_per_pulse=K,
                                          position_table_revolutions=1,
                                          half_difference_std_pulses=np.full(4, 0.3))
    assert res_s.fix_error_angle_rad.value == pytest.approx(theta_s, abs=1e-12)
    assert res_s.tilt_rad.value == pytest.approx(alpha_s, abs=1e-12)
    assert abs(theta - theta_s) * ARCSEC_PER_RAD < 0.05


def test_small_angle_eq_18_is_within_0_1_arcsec() -> None:
    psi = np.radians([0.0, 90.0, 180.0, 270.0])
    k_tilde = K / math.cos(THETA)
    theta18 = fix_error_angle_small_angle(*_n_og(psi), k_tilde_arcsec_per_pulse=k_tilde,
                                          position_table_revolutions=1)
    assert abs(theta18 - THETA) * ARCSEC_PER_RAD < 0.1


def test_multi_station_uncertainty_matches_monte_carlo_scatter() -> None:
    psi = np.radians(np.arange(0, 360, 10.0))
    rng = np.random.default_rng(2)
    thetas, stds = [], []
    for _ in range(300):
        res = fix_error_angle_multi_station(psi, _n_og(psi) + rng.normal(0, 1.0, len(psi)),
                                            scale_factor_arcsec_per_pulse=K,
                                            position_table_revolutions=1)
        thetas.append(res.fix_error_angle_rad.value)
        stds.append(res.fix_error_angle_rad.std_uncertainty)
    assert np.std(thetas) == pytest.approx(np.mean(stds), rel=0.15)


def test_stations_all_at_one_beta_make_theta_unobservable() -> None:
    psi = np.radians([30.0, 30.0, 30.0, 30.0, 30.0])
    with pytest.raises(InsufficientDataError, match='unobservable'):
        fix_error_angle_multi_station(psi, _n_og(psi), scale_factor_arcsec_per_pulse=K,
                                      position_table_revolutions=1)


def test_eq_21_with_paper_figures_stays_below_4_arcsec() -> None:
    bound = fix_error_angle_error_bound_arcsec(
        position_error_arcsec=2.0, position_table_revolutions=1, wobble_arcsec=0.5,
        station_error_arcsec=100.0, fix_error_angle_arcsec=300.0, mount_change_arcsec=1.0)
    assert 2.5 < bound < 4.0


def test_eq_5_bound_adds_sync_and_fix_error_terms() -> None:
    bound = scale_factor_relative_error_bound(
        sync_and_drift_arcsec=0.2, revolutions_per_window=5,
        fix_error_angle_arcsec=646.75, fix_error_angle_error_arcsec=0.21)
    expected = 0.2 / 12960000 + math.sin(646.75 * RAD_PER_ARCSEC) * 0.21 * RAD_PER_ARCSEC
    assert bound == pytest.approx(expected, rel=1e-12)
    assert bound < 1e-7  # the paper's "better than 1e-7"
