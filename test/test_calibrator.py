"""K̃ from the simulated bench, offline, through the same core the node uses."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gyro_calib.rbrlg.calibrator import calibrate_k_tilde
from sim_nodes.rate_table import RateTableConfig
from sim_nodes.rbrlg.bench import (
    BenchRecording,
    simulate_rate_bias_bench,
    true_k_tilde_arcsec_per_pulse,
)
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig

NOISE_OFF_TABLE = RateTableConfig(duration_s=600.0, zero_index_jitter_arcsec=0.0)
NOISE_OFF_GYRO = RingLaserGyroConfig(angle_random_walk_deg_sqrt_h=0.0)


def _calibrate(run: BenchRecording):  # noqa: ANN202
    return calibrate_k_tilde(run.pulse_t_ns, run.pulse_counts, run.table_t_ns,
                             run.table_angle_rad, run.table_rate_rad_s, run.zero_index_ns)


@pytest.fixture(scope='module')
def noise_off_run() -> BenchRecording:
    return simulate_rate_bias_bench(NOISE_OFF_TABLE, NOISE_OFF_GYRO)


def test_noise_off_k_tilde_equals_k_over_cos_theta_to_1e_9(noise_off_run: BenchRecording) -> None:
    """Earth rate, bias and drift stay on: forward minus reverse must cancel them."""
    cal = _calibrate(noise_off_run)
    truth = true_k_tilde_arcsec_per_pulse(NOISE_OFF_GYRO)
    k = cal.k_tilde()
    assert k.n_used >= 18
    assert abs(k.value / truth - 1) < 1e-9
    per_pair = np.array([p.k_tilde_arcsec_per_pulse for p in cal.pairs]) / truth - 1
    assert np.max(np.abs(per_pair)) < 3e-9  # integer pulses alone, averaged by the end fits
    assert not cal.rejections


def test_unquantised_noise_off_k_tilde_is_exact_to_1e_12() -> None:
    table = dataclasses.replace(NOISE_OFF_TABLE, duration_s=70.0, encoder_counts_per_rev=0)
    # bias drift off too: a drifting bias differs between the two windows (P± of eq. 5)
    gyro = dataclasses.replace(NOISE_OFF_GYRO, quantise=False, bias_drift_deg_h_per_h=0.0)
    cal = _calibrate(simulate_rate_bias_bench(table, gyro))
    truth = true_k_tilde_arcsec_per_pulse(gyro)
    assert [abs(p.k_tilde_arcsec_per_pulse / truth - 1) < 1e-12 for p in cal.pairs] == [True] * 2


def test_earth_plus_bias_term_matches_vertical_earth_rate_plus_bias(
        noise_off_run: BenchRecording) -> None:
    eb = _calibrate(noise_off_run).earth_plus_bias_deg_h()
    g = NOISE_OFF_GYRO
    vertical = g.earth_rate_deg_h * np.sin(np.radians(g.latitude_deg))
    mean_drift = g.bias_drift_deg_h_per_h * (NOISE_OFF_TABLE.duration_s / 2 / 3600)
    assert eb.value == pytest.approx(vertical + g.bias_deg_h + mean_drift, abs=2e-3)
    assert eb.std_uncertainty < 2e-3


def test_paper_bench_reaches_the_jitter_and_arw_floor() -> None:
    """0.1″ jitter and 0.0005 °/√h ARW: per-pair relative std ≈ 1.9e-8 (METHODS §A.5)."""
    gyro = RingLaserGyroConfig(seed=5)
    cal = _calibrate(simulate_rate_bias_bench(RateTableConfig(duration_s=900.0, seed=5), gyro))
    truth = true_k_tilde_arcsec_per_pulse(gyro)
    rel = np.array([p.k_tilde_arcsec_per_pulse for p in cal.pairs]) / truth - 1
    assert len(rel) >= 29
    assert 1.0e-8 < np.std(rel, ddof=1) < 3.0e-8
    k = cal.k_tilde()
    assert abs(k.value / truth - 1) < 4 * k.relative_uncertainty
