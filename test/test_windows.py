"""Window ends are measured by a local fit, beating two-sample interpolation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gyro_calib.errors import WindowError
from gyro_calib.windows import count_at_instant
from gyro_calib.windows.local_fit import quantisation_variance

RATE_PULSES_S = 640_712.345  # 150 °/s at K ≈ 0.8428 ″/pulse


def _quantised_stream(rng: np.random.Generator, phase0: float) -> tuple[np.ndarray, np.ndarray]:
    t_ns = np.arange(0, 1_000_000_001, 1_000_000, dtype=np.int64)
    counts = np.floor(phase0 + RATE_PULSES_S * t_ns / 1e9)
    return t_ns, counts


def test_count_at_instant_beats_two_sample_interpolation_on_integer_pulses() -> None:
    rng = np.random.default_rng(7)
    fit_err, interp_err = [], []
    for _ in range(200):
        phase0 = rng.uniform()
        t_ns, counts = _quantised_stream(rng, phase0)
        instant = int(rng.integers(300_000_000, 700_000_000))
        truth = phase0 + RATE_PULSES_S * instant / 1e9 - 0.5  # floor() is 0.5 low on average
        est = count_at_instant(t_ns, counts, instant, half_width_s=0.1)
        fit_err.append(est.value - truth)
        interp_err.append(np.interp(instant, t_ns, counts) - truth)
    assert np.std(fit_err) < 0.05  # pulses
    assert np.std(fit_err) < np.std(interp_err) / 4
    assert np.std(interp_err) > 0.2


def test_count_at_instant_reports_uncertainty_matching_its_scatter() -> None:
    rng = np.random.default_rng(8)
    t_ns = np.arange(0, 1_000_000_001, 1_000_000, dtype=np.int64)
    truth_rate, instant = 1000.0, 500_000_000
    errs, stds = [], []
    for _ in range(300):
        counts = truth_rate * t_ns / 1e9 + rng.normal(0, 0.3, len(t_ns))
        est = count_at_instant(t_ns, counts, instant, half_width_s=0.1)
        errs.append(est.value - truth_rate * 0.5)
        stds.append(est.std_uncertainty)
    assert np.std(errs) == pytest.approx(np.mean(stds), rel=0.15)
    assert est.n_used == 201
    assert est.rate_pulses_s == pytest.approx(truth_rate, rel=1e-2)


@pytest.mark.parametrize('pulses_per_sample', [3064.0, 3064.003, 3064.02, 3064.1, 3064.5,
                                               3064.333, 3064.7123])
def test_quantisation_variance_is_the_fits_error_variance_over_the_phase(
        pulses_per_sample: float) -> None:
    """Eq. (2b) equals the brute-force variance of a line fit of floor(r·t + φ) over φ."""
    period_s = 0.01  # 100 Hz, ±0.2142 s: the widened span of a slow stream
    x = (np.arange(43) - 21) * period_s - 0.0037
    dx = x - x.mean()
    weights = 1 / len(x) - x.mean() * dx / (dx @ dx)
    rate = pulses_per_sample / period_s
    phase = (np.arange(20_000) + 0.5) / 20_000
    exact = rate * x[None, :] + phase[:, None]
    brute = float(np.var((np.floor(exact) - exact) @ weights))
    assert quantisation_variance(x, weights, rate, 1.0) == pytest.approx(brute, rel=1e-6)


def test_count_at_instant_states_the_half_pulse_a_whole_number_per_sample_leaves() -> None:
    """Whole pulses per sample: residuals are zero, yet the instant's count is ±½ pulse."""
    rng = np.random.default_rng(9)
    t_ns = np.arange(0, 1_000_000_001, 10_000_000, dtype=np.int64)  # 100 Hz
    errors, stated = [], []
    for _ in range(300):
        phase0 = rng.uniform()
        counts = np.floor(phase0 + 306_400.0 * t_ns / 1e9)  # 3064 pulses per sample
        instant = int(rng.integers(300_000_000, 700_000_000))
        est = count_at_instant(t_ns, counts, instant, half_width_s=0.2142, quantum=1.0)
        errors.append(est.value - (phase0 + 306_400.0 * instant / 1e9 - 0.5))
        stated.append(est.std_uncertainty)
    assert np.std(errors) == pytest.approx(1 / math.sqrt(12), rel=0.1)
    assert np.allclose(stated, 1 / math.sqrt(12), rtol=1e-6)
    without = count_at_instant(t_ns, counts, instant, half_width_s=0.2142)
    assert without.std_uncertainty < 1e-6  # the residuals alone claim (near) exactness


def test_count_at_instant_second_order_absorbs_curvature() -> None:
    t_ns = np.arange(0, 1_000_000_001, 1_000_000, dtype=np.int64)
    x = t_ns / 1e9
    counts = 5e5 * x + 2e4 * x**2
    instant = 500_000_000
    est = count_at_instant(t_ns, counts, instant, half_width_s=0.1, order=2)
    assert est.value == pytest.approx(5e5 * 0.5 + 2e4 * 0.25, abs=1e-6)


def test_count_at_instant_rejects_a_gap_around_the_instant() -> None:
    t_ns = np.arange(0, 1_000_000_001, 1_000_000, dtype=np.int64)
    keep = (t_ns < 480_000_000) | (t_ns > 520_000_000)
    with pytest.raises(WindowError, match='gap of 42.0 ms'):
        count_at_instant(t_ns[keep], t_ns[keep] / 1e3, 500_000_000, half_width_s=0.1)


def test_count_at_instant_needs_samples_on_both_sides() -> None:
    t_ns = np.arange(0, 500_000_001, 1_000_000, dtype=np.int64)
    with pytest.raises(WindowError, match='0 after'):
        count_at_instant(t_ns, t_ns / 1e3, 500_500_000, half_width_s=0.1)
    assert math.isfinite(count_at_instant(t_ns, t_ns / 1e3, 400_000_000, half_width_s=0.1).value)
