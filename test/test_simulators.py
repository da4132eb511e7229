"""Simulators are physics: their outputs follow from the configured error sources alone."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gyro_calib.units import ARCSEC_PER_RAD, RAD_PER_ARCSEC
from sim_nodes.motion import rate_bias_profile
from sim_nodes.rate_table import RateTableConfig, RateTableSimulator
from sim_nodes.rbrlg.bench import simulate_rate_bias_bench
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig, RingLaserGyroSimulator

QUIET_TABLE = RateTableConfig(duration_s=40.0, zero_index_jitter_arcsec=0.0,
                              encoder_counts_per_rev=0)


def test_rate_bias_profile_reverses_through_same_constant_rate_angles() -> None:
    profile = rate_bias_profile(rate_rad_s=math.radians(150),
                                acceleration_rad_s2=math.radians(1000),
                                revolutions_per_segment=6, duration_s=100)
    t = np.linspace(0, 100, 100001)
    rate = profile.rate_rad_s(t)
    assert np.max(np.abs(rate)) == pytest.approx(math.radians(150))
    # rate is continuous: the largest change per 1 ms is the acceleration × 1 ms
    assert np.max(np.abs(np.diff(rate))) <= math.radians(1000) * 1e-3 * 1.0001
    # angle is the integral of the rate
    angle = profile.angle_rad(t)
    trapezoid = np.concatenate(([0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * 1e-3)))
    assert np.max(np.abs(angle - angle[0] - trapezoid)) < 1e-9


def test_zero_index_events_lie_exactly_at_reference_mark_without_jitter() -> None:
    sim = RateTableSimulator(QUIET_TABLE)
    events = np.concatenate([sim.step(50).zero_index_ns for _ in range(800)])
    assert len(events) >= 15
    angles = sim.profile.angle_rad(events / 1e9)
    offset = (angles - math.radians(QUIET_TABLE.zero_index_angle_deg)) / (2 * math.pi)
    assert np.max(np.abs(offset - np.round(offset))) * 1296000 < 1e-3  # < 0.001″


def test_zero_index_jitter_has_configured_angle_std() -> None:
    cfg = dataclasses.replace(QUIET_TABLE, duration_s=600.0, zero_index_jitter_arcsec=0.1)
    sim = RateTableSimulator(cfg)
    events = np.concatenate([sim.step(1000).zero_index_ns for _ in range(601)])
    rates = sim.profile.rate_rad_s(events / 1e9)
    constant = np.abs(rates) > math.radians(149)
    angles = sim.profile.angle_rad(events[constant] / 1e9)
    offset = (angles - math.radians(cfg.zero_index_angle_deg)) / (2 * math.pi)
    err_arcsec = (offset - np.round(offset)) * 1296000
    assert np.std(err_arcsec) == pytest.approx(0.1, rel=0.2)  # ~200 events


def test_table_output_does_not_depend_on_chunk_size() -> None:
    cfg = dataclasses.replace(QUIET_TABLE, zero_index_jitter_arcsec=0.1, duration_s=20.0)
    a, b = RateTableSimulator(cfg), RateTableSimulator(cfg)
    ev_a = np.concatenate([a.step(50).zero_index_ns for _ in range(401)])
    ev_b = np.concatenate([b.step(333).zero_index_ns for _ in range(61)])
    assert np.array_equal(ev_a, ev_b)


def test_gyro_output_does_not_depend_on_chunk_size() -> None:
    table = dataclasses.replace(QUIET_TABLE, duration_s=10.0)
    run_a = simulate_rate_bias_bench(table, RingLaserGyroConfig(), chunk_samples=50)
    run_b = simulate_rate_bias_bench(table, RingLaserGyroConfig(), chunk_samples=777)
    assert np.array_equal(run_a.pulse_counts, run_b.pulse_counts)


def test_gyro_senses_table_angle_times_cos_theta_over_whole_revolutions() -> None:
    gyro = RingLaserGyroConfig(earth_rate_deg_h=0.0, bias_deg_h=0.0, bias_drift_deg_h_per_h=0.0,
                               angle_random_walk_deg_sqrt_h=0.0, quantise=False)
    sim = RingLaserGyroSimulator(gyro)
    t_ns = np.arange(0, 2_400_000_001, 1_000_000, dtype=np.int64)
    angle = np.radians(150.0) * t_ns / 1e9  # one revolution
    counts = sim.step(t_ns, angle)
    theta = gyro.fix_error_angle_arcsec * RAD_PER_ARCSEC
    expected = 1296000 * math.cos(theta) / gyro.scale_factor_arcsec_per_pulse
    assert counts[-1] - counts[0] == pytest.approx(expected, rel=1e-13)


def test_earth_rate_across_table_axis_cancels_over_whole_revolutions() -> None:
    """Only the component along oZ remains: ω_e·sin(lat)·cos θ per second (METHODS §A.2)."""
    gyro = RingLaserGyroConfig(bias_deg_h=0.0, bias_drift_deg_h_per_h=0.0,
                               angle_random_walk_deg_sqrt_h=0.0, quantise=False,
                               fix_error_angle_arcsec=3000.0)
    still = dataclasses.replace(gyro, earth_rate_deg_h=0.0)
    t_ns = np.arange(0, 4_800_000_001, 1_000_000, dtype=np.int64)
    angle = np.radians(150.0) * t_ns / 1e9  # two revolutions
    with_earth = RingLaserGyroSimulator(gyro).step(t_ns, angle)
    without = RingLaserGyroSimulator(still).step(t_ns, angle)
    earth_pulses = (with_earth[-1] - with_earth[0]) - (without[-1] - without[0])
    theta = gyro.fix_error_angle_arcsec * RAD_PER_ARCSEC
    vertical = gyro.earth_rate_deg_h * math.sin(math.radians(gyro.latitude_deg))  # ″/s
    expected = vertical * math.cos(theta) * 4.8 / gyro.scale_factor_arcsec_per_pulse
    assert earth_pulses == pytest.approx(expected, rel=1e-9)


def test_pulses_are_whole_and_fraction_carries_over() -> None:
    gyro = RingLaserGyroConfig()
    run = simulate_rate_bias_bench(dataclasses.replace(QUIET_TABLE, duration_s=5.0), gyro)
    assert np.all(run.pulse_counts == np.round(run.pulse_counts))
    phase_run = simulate_rate_bias_bench(dataclasses.replace(QUIET_TABLE, duration_s=5.0),
                                         dataclasses.replace(gyro, quantise=False))
    # floor of the carried phase: never more than one pulse behind, never ahead
    lag = phase_run.pulse_counts - run.pulse_counts
    assert np.all((lag >= -1e-6) & (lag < 1.0 + 1e-6))


def test_lock_in_band_gives_no_pulses_at_low_rate() -> None:
    gyro = RingLaserGyroConfig(lock_in_rate_deg_s=0.5, angle_random_walk_deg_sqrt_h=0.0)
    sim = RingLaserGyroSimulator(gyro)
    t_ns = np.arange(0, 1_000_000_001, 1_000_000, dtype=np.int64)
    counts = sim.step(t_ns, np.radians(0.3) * t_ns / 1e9)  # 0.3 °/s < 0.5 °/s band
    assert counts[-1] == counts[0]


def test_same_seed_same_run_and_different_seed_different_run() -> None:
    table = dataclasses.replace(QUIET_TABLE, duration_s=5.0, zero_index_jitter_arcsec=0.1)
    a = simulate_rate_bias_bench(table, RingLaserGyroConfig(seed=3))
    b = simulate_rate_bias_bench(table, RingLaserGyroConfig(seed=3))
    c = simulate_rate_bias_bench(table, RingLaserGyroConfig(seed=4))
    assert np.array_equal(a.pulse_counts, b.pulse_counts)
    assert not np.array_equal(a.pulse_counts, c.pulse_counts)


def test_encoder_reading_is_quantised_to_its_resolution() -> None:
    cfg = dataclasses.replace(QUIET_TABLE, encoder_counts_per_rev=2**16, duration_s=2.0)
    chunk = RateTableSimulator(cfg).step(2001)
    steps = chunk.encoder_angle_rad / (2 * math.pi / 2**16)
    assert np.allclose(steps, np.round(steps), atol=1e-6)
    assert np.max(np.abs(chunk.encoder_angle_rad - chunk.true_angle_rad)) * ARCSEC_PER_RAD <= (
        1296000 / 2**16 / 2 + 1e-6)
