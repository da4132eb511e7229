"""A window end's count uncertainty is the rounding its local fit leaves (§F eq. (6a)).

Whole-pulse counts floor(ρ·t + φ) of a constant rate ρ, sampled as a gyro publishes them, fitted
by the cutter's own local fit (:func:`~gyro_calib.windows.count_at_instant`) at an instant:
over start phases φ the fit's error scatters as :func:`fitted_count_variance` says — on a rate
whose phase runs through its cycle (where the white-noise reading of the residuals overstates
it several times), near a whole number of pulses per sample (no averaging at all) and near a
half. Generated here from the definition, not from a simulator.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gyro_calib.triad.quantisation import fitted_count_variance, sawtooth_covariance
from gyro_calib.windows import count_at_instant

PULSE_HZ = 500.0
HALF_WIDTH_S = 0.1
PHASES = 1500


def _errors(pulses_per_sample: float, rng: np.random.Generator
            ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Fit errors over random phases, the fits' own (white) u, and the model's u².

    The model at the true rate, and at the rate of the fit itself (as the session has it).
    """
    t_ns = (np.arange(400) * (1e9 / PULSE_HZ)).astype(np.int64) + 10**12
    instant = int(t_ns[200] + 0.37e9 / PULSE_HZ)
    rate = pulses_per_sample * PULSE_HZ
    x = (t_ns - t_ns[0]) / 1e9
    errs, white = [], []
    for phi in rng.uniform(0.0, 1.0, PHASES):
        counts = np.floor(rate * x + phi)
        fit = count_at_instant(t_ns, counts, instant, half_width_s=HALF_WIDTH_S)
        errs.append(fit.value - (rate * (instant - t_ns[0]) / 1e9 + phi - 0.5))
        white.append(fit.std_uncertainty)
    half = int(HALF_WIDTH_S * 1e9)
    model = fitted_count_variance(t_ns, np.floor(rate * x + 0.3), instant, half,
                                  rate_pulses_s=rate)
    from_fit = fitted_count_variance(t_ns, np.floor(rate * x + 0.3), instant, half)
    return np.array(errs), np.array(white), model, from_fit


def test_the_sawtooth_covariance_is_a_twelfth_at_zero_and_minus_a_24th_at_a_half() -> None:
    got = sawtooth_covariance(np.array([0.0, 0.5, 1.0, -0.25, 0.25, 3.0]))
    assert got == pytest.approx([1 / 12, -1 / 24, 1 / 12, 1 / 12 - 3 / 32, 1 / 12 - 3 / 32,
                                 1 / 12])


@pytest.mark.parametrize('pulses_per_sample', [7.3819, 12.5013, 3.0004, 0.61803])
def test_the_fit_error_over_phases_scatters_as_the_rounding_model_says(
        pulses_per_sample: float) -> None:
    errs, white, model, from_fit = _errors(pulses_per_sample, np.random.default_rng(7))
    empirical = float(np.mean(errs ** 2))
    # the mean-square error over 1500 phases is within 10 % of the model at the true rate
    # (its sampling scatter is a few %), whether the model is ~1e-5 pulse² or 1/12; at the
    # fit's own rate (what the session knows) within 20 % (the slope's rounding error moves
    # the phases over the span)
    assert empirical == pytest.approx(model, rel=0.10), (empirical, model)
    assert empirical == pytest.approx(from_fit, rel=0.20), (empirical, from_fit)


def test_white_noise_reading_of_the_residuals_overstates_a_cycling_phase() -> None:
    errs, white, model, from_fit = _errors(7.3819, np.random.default_rng(3))
    rms = math.sqrt(float(np.mean(errs ** 2)))
    assert float(np.median(white)) > 2.0 * rms  # what the windows stated before eq. (6a)
    assert math.sqrt(model) == pytest.approx(rms, rel=0.06)
    assert math.sqrt(from_fit) == pytest.approx(rms, rel=0.12)
