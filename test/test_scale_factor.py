"""K̃ and K from window pairs (METHODS §A.2), checked against the paper's numbers (§A.5)."""

from __future__ import annotations

import math

import pytest

from gyro_calib.errors import InsufficientDataError, WindowError
from gyro_calib.estimate import Estimate
from gyro_calib.rbrlg.scale_factor import k_tilde_from_windows, mean_estimate, scale_factor
from gyro_calib.units import RAD_PER_ARCSEC
from gyro_calib.windows import RevolutionWindow

K_PAPER = 0.84279066          # ″/pulse
THETA_PAPER = 646.75          # ″
K_TILDE_PAPER = 0.84279480    # ″/pulse


def _window(direction: int, pulses: float, duration_s: float = 12.0) -> RevolutionWindow:
    return RevolutionWindow(0, int(duration_s * 1e9), direction, 5, pulses, 0.03, duration_s)


def test_k_tilde_from_pair_follows_eq_3_and_cancels_earth_rate_and_bias() -> None:
    k, theta = K_PAPER, THETA_PAPER * RAD_PER_ARCSEC
    drift = 7.1 * 12.0  # (ω_e' + ω_B)·τ_R·m, ″
    n_plus = (1296000 * 5 + drift) * math.cos(theta) / k
    n_minus = (-1296000 * 5 + drift) * math.cos(theta) / k
    pair = k_tilde_from_windows(_window(1, n_plus), _window(-1, n_minus))
    assert pair.k_tilde_arcsec_per_pulse == pytest.approx(k / math.cos(theta), rel=1e-14)
    assert pair.earth_plus_bias_deg_h == pytest.approx(7.1, rel=1e-9)


def test_paper_k_tilde_and_theta_give_paper_k() -> None:
    k = scale_factor(Estimate(K_TILDE_PAPER, 3e-8, 300, 299),
                     Estimate(THETA_PAPER * RAD_PER_ARCSEC, 0.21 * RAD_PER_ARCSEC, 80, 79))
    assert k.value == pytest.approx(K_PAPER, abs=5e-9)
    assert k.n_used == 80


def test_ignoring_300_arcsec_fix_error_biases_k_by_1_06e_minus_6() -> None:
    assert 1 - math.cos(300 * RAD_PER_ARCSEC) == pytest.approx(1.06e-6, rel=0.01)


def test_scale_factor_propagates_both_uncertainties() -> None:
    theta = Estimate(0.01, 1e-4, 4, 3)
    k_t = Estimate(1.0, 1e-7, 10, 9)
    k = scale_factor(k_t, theta)
    expected = math.hypot(math.cos(0.01) * 1e-7, math.sin(0.01) * 1e-4)
    assert k.std_uncertainty == pytest.approx(expected, rel=1e-12)


def test_pair_of_two_forward_windows_is_refused() -> None:
    with pytest.raises(WindowError, match='one forward'):
        k_tilde_from_windows(_window(1, 7.6e6), _window(1, 7.6e6))


def test_mean_needs_two_values_for_an_uncertainty() -> None:
    with pytest.raises(InsufficientDataError, match='need at least 2'):
        mean_estimate([1.0])
    est = mean_estimate([1.0, 3.0])
    assert (est.value, est.std_uncertainty, est.n_used, est.dof) == (2.0, 1.0, 2, 1)
