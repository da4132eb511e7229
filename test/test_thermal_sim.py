"""The temperature chamber and thermal gyro simulators: physics, switches, chunking, faults."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gyro_calib.thermal.site import earth_rate_along_axis_rad_s
from gyro_calib.units import NS_PER_S
from sim_nodes.thermal.chamber import ChamberProfile, paper_soak_programme, ramp_programme
from sim_nodes.thermal.gyro import (
    RAD_S_PER_DEG_H,
    ThermalBiasLaw,
    ThermalGyroConfig,
    ThermalGyroSimulator,
    earth_rate_along_axis_deg_h,
)
from sim_nodes.thermal.scenarios import (
    GYRO_LAWS,
    ThermalFaults,
    gyro_config,
    random_gyro,
    simulate_thermal_run,
)

QUIET = dict(angle_random_walk_deg_sqrt_h=0.0, bias_instability_deg_h=0.0, quantise=False,
             temperature_noise_c=0.0, temperature_resolution_c=0.0, sensor_time_constant_s=0.0)


def _concat(parts, name):  # noqa: ANN001, ANN202
    return np.concatenate([getattr(p, name) for p in parts])


def test_chamber_paper_programme_has_seven_one_hour_soaks() -> None:
    prog = paper_soak_programme()
    soaks = [(d, c) for (d, c), prev in zip(prog.segments, [prog.start_c, *[
        c for _, c in prog.segments]]) if c == prev]
    assert [c for _, c in soaks] == [-35.0, -25.0, -15.0, 0.0, 15.0, 25.0, 35.0]
    assert all(d == 3600.0 for d, _ in soaks)
    assert prog.temperature_c(prog.duration_s) == 35.0
    slope, _ = prog.slope_at(3600.0 + 10.0)
    assert slope == pytest.approx(1.0 / 60.0)  # 1 °C/min ramp


def test_chamber_ramp_programme_returns_to_low_temperature() -> None:
    prog = ramp_programme(-10.0, 20.0, rate_c_per_min=0.5, cycles=2, dwell_s=600.0)
    assert prog.breakpoint_temperatures_c()[-1] == -10.0
    assert prog.duration_s == pytest.approx(600 + 2 * (2 * 3600 + 2 * 600))


def test_simulator_chunked_output_is_bit_identical_to_one_shot() -> None:
    cfg = gyro_config('C-1', seed=3, pulse_rate_hz=50.0, temperature_rate_hz=2.0)
    prog = paper_soak_programme(soak_s=300.0)
    one = ThermalGyroSimulator(cfg, prog, duration_s=2500.0).advance(10**15)
    sim = ThermalGyroSimulator(cfg, prog, duration_s=2500.0)
    rng = np.random.default_rng(7)
    parts, t = [], sim.start_time_ns
    while not sim.finished:
        t += int(rng.integers(1, 300)) * 10**9 + int(rng.integers(0, 10**9))
        parts.append(sim.advance(t))
    for name in ('pulse_t_ns', 'pulse_counts', 'temperature_t_ns', 'temperature_c'):
        assert np.array_equal(_concat(parts, name), getattr(one, name)), name
    assert np.array_equal(np.concatenate([p.truth.law_bias_rad_s for p in parts]),
                          one.truth.law_bias_rad_s)


def test_quiet_gyro_integrates_earth_rate_plus_law_exactly() -> None:
    law = ThermalBiasLaw(bias_deg_h=0.3, h_deg_h=(0.01, -2e-4))
    cfg = ThermalGyroConfig(law=law, warm_start=True, pulse_rate_hz=10.0, **QUIET)
    prog = ChamberProfile(20.0, ((1800.0, 20.0),))
    ch = ThermalGyroSimulator(cfg, prog).advance(10**15)
    h = ch.truth.h_c[-1]
    expected = cfg.earth_rate_along_axis_rad_s() + law.bias_deg_h_at(
        np.array([h]), np.zeros(1), np.array([0.5]), np.array([-1.25]))[0] * RAD_S_PER_DEG_H
    dt = (ch.pulse_t_ns[-1] - ch.pulse_t_ns[0]) / NS_PER_S
    rate = (ch.pulse_counts[-1] - ch.pulse_counts[0]) * cfg.scale_factor_rad_per_pulse / dt
    assert rate == pytest.approx(expected, rel=1e-9)


def test_settled_gyro_sits_at_chamber_plus_self_heating() -> None:
    cfg = ThermalGyroConfig(warm_start=True, **QUIET)
    ch = ThermalGyroSimulator(cfg, ChamberProfile(10.0, ((600.0, 10.0),))).advance(10**15)
    assert ch.truth.shell_c[-1] == pytest.approx(10.0 + cfg.shell_self_heating_c, abs=1e-9)
    assert ch.truth.dtab_c[-1] == pytest.approx(
        cfg.cavity_a_self_heating_c - cfg.cavity_b_self_heating_c, abs=1e-9)
    assert ch.truth.hdot_c_s[-1] == pytest.approx(0.0, abs=1e-12)


def test_steady_ramp_gives_the_lags_and_gradient_of_the_network() -> None:
    """On a long ramp at slope s, each first-order stage lags its input by s·τ."""
    cfg = ThermalGyroConfig(warm_start=True, **QUIET)
    s = 0.5 / 60.0
    prog = ChamberProfile(0.0, ((20000.0, 20000.0 * s),))
    ch = ThermalGyroSimulator(cfg, prog).advance(10**15)
    tr = ch.truth
    assert tr.chamber_c[-1] - tr.shell_c[-1] == pytest.approx(
        s * cfg.shell_time_constant_s - cfg.shell_self_heating_c, abs=1e-6)
    expected_dtab = (cfg.cavity_a_self_heating_c - cfg.cavity_b_self_heating_c
                     - s * (cfg.cavity_a_time_constant_s - cfg.cavity_b_time_constant_s))
    assert tr.dtab_c[-1] == pytest.approx(expected_dtab, abs=1e-6)
    assert tr.hdot_c_s[-1] == pytest.approx(s, rel=1e-6)


def test_cold_start_warms_up_by_self_heating() -> None:
    cfg = ThermalGyroConfig(**QUIET)
    ch = ThermalGyroSimulator(cfg, ChamberProfile(-20.0, ((4000.0, -20.0),))).advance(10**15)
    assert ch.truth.h_c[0] == pytest.approx(-20.0)
    assert ch.truth.hdot_c_s[1] > 0
    assert ch.truth.h_c[-1] > -20.0 + 2.0


@pytest.mark.parametrize('elevation, azimuth, expected', [
    (90.0, 0.0, lambda lat: math.sin(lat)),
    (0.0, 0.0, lambda lat: math.cos(lat)),
    (0.0, 90.0, lambda lat: 0.0),
    (-90.0, 0.0, lambda lat: -math.sin(lat)),
])
def test_earth_rate_along_axis_agrees_between_sim_and_core(elevation, azimuth,  # noqa: ANN001
                                                           expected) -> None:  # noqa: ANN001
    lat = 34.26
    sim = earth_rate_along_axis_deg_h(lat, elevation, azimuth) * RAD_S_PER_DEG_H
    core = earth_rate_along_axis_rad_s(lat, elevation, azimuth)
    assert sim == pytest.approx(core, rel=1e-12, abs=1e-18)
    assert core == pytest.approx(15.041 * RAD_S_PER_DEG_H * expected(math.radians(lat)),
                                 abs=1e-15)


def test_temperature_readings_are_rounded_to_the_resolution_with_stated_variance() -> None:
    cfg = gyro_config('A-2', temperature_resolution_c=0.0625, temperature_noise_c=0.02)
    ch = ThermalGyroSimulator(cfg, paper_soak_programme(), duration_s=300.0).advance(10**15)
    steps = ch.temperature_c / 0.0625
    assert np.allclose(steps, np.round(steps), atol=1e-9)
    assert np.allclose(ch.temperature_variance_c2, 0.02**2 + 0.0625**2 / 12)
    assert list(ch.temperature_frame_id[:3]) == ['cavity_a', 'cavity_b', 'shell']


@pytest.mark.parametrize('switch', ['angle_random_walk_deg_sqrt_h', 'bias_instability_deg_h',
                                    'temperature_noise_c'])
def test_each_noise_term_switches_off_at_zero(switch: str) -> None:
    base = dataclasses.replace(gyro_config('A-1', seed=5), **QUIET)
    on = dataclasses.replace(base, **{switch: 0.01})
    runs = [ThermalGyroSimulator(c, paper_soak_programme(), duration_s=600.0).advance(10**15)
            for c in (base, on)]
    same_p = np.array_equal(runs[0].pulse_counts, runs[1].pulse_counts)
    same_t = np.array_equal(runs[0].temperature_c, runs[1].temperature_c)
    assert not (same_p and same_t)
    quiet_again = ThermalGyroSimulator(base, paper_soak_programme(),
                                       duration_s=600.0).advance(10**15)
    assert np.array_equal(quiet_again.pulse_counts, runs[0].pulse_counts)


def test_pulses_are_whole_and_carry_the_fraction() -> None:
    cfg = gyro_config('A-1', pulse_rate_hz=1000.0)
    ch = ThermalGyroSimulator(cfg, paper_soak_programme(), duration_s=60.0).advance(10**15)
    assert np.all(ch.pulse_counts == np.floor(ch.pulse_counts))
    steps = np.diff(ch.pulse_counts)
    # ~3.7 pulses/s sampled at 1 kHz: the noise may step the counter back (up/down counter)
    assert set(np.unique(steps)) <= {-1.0, 0.0, 1.0}
    mean_rate = steps.sum() * cfg.scale_factor_rad_per_pulse / 60.0
    assert mean_rate == pytest.approx(cfg.earth_rate_along_axis_rad_s(), rel=0.2)


def test_faults_act_on_published_temperatures_only() -> None:
    faults = ThermalFaults(stuck_sensor='cavity_b', stuck_from_s=600.0, nan_sensor='shell',
                           nan_s=(100.0, 200.0), dropout_sensor='cavity_a',
                           dropout_s=(300.0, 400.0))
    rec = simulate_thermal_run(gyro_config('A-1'), paper_soak_programme(), duration_s=1200.0,
                               faults=faults)
    rel = (rec.temperature_t_ns - rec.temperature_t_ns[0]) / NS_PER_S
    fid = rec.temperature_frame_id
    stuck = rec.temperature_c[(fid == 'cavity_b') & (rel >= 600)]
    assert len(np.unique(stuck)) == 1
    assert np.all(np.isnan(rec.temperature_c[(fid == 'shell') & (rel >= 100) & (rel < 200)]))
    assert not np.any((fid == 'cavity_a') & (rel >= 300) & (rel < 400))
    assert np.all(np.isfinite(rec.truth.h_c))
    assert rec.scenario['gyro_id'] == 'A-1'


def test_random_gyros_differ_and_are_seeded() -> None:
    a, b = random_gyro(1), random_gyro(2)
    assert a.law != b.law
    assert random_gyro(1) == a
    assert set(GYRO_LAWS) == {'A-1', 'A-2', 'B-1', 'B-2', 'C-1'}


def test_paper_laws_reproduce_the_published_bias_points() -> None:
    t = np.array([-35, -25, -15, 0, 15, 25, 35.0])
    z = np.zeros(7)
    a1 = GYRO_LAWS['A-1'].bias_deg_h_at(t, z, z, z)
    a2 = GYRO_LAWS['A-2'].bias_deg_h_at(t, z, z, z)
    pub1 = np.array([0.1073, 0.1748, 0.3288, 0.4461, 0.6321, 0.6633, 0.1369])
    pub2 = np.array([0.4991, 0.4578, 0.4204, 0.4159, 0.3613, 0.2561, 0.1683])
    assert np.sqrt(np.mean((a1 - pub1) ** 2)) < 0.05  # least-squares quartic, 2 dof
    assert np.sqrt(np.mean((a2 - pub2) ** 2)) < 0.02  # least-squares cubic, 3 dof
