"""Specification of the noise generators (sim_nodes.noise): seeded, chunk-invariant, exact."""

from __future__ import annotations

import math

import allantools
import numpy as np
import pytest

from sim_nodes.noise import (
    AxisNoise,
    FogOutputGenerator,
    ImuNoiseGenerator,
    NoiseTerms,
    RlgPulseGenerator,
)
from sim_nodes.noise.processes import FlickerRate, ou_allan_variance

TERMS = {
    'quantization': NoiseTerms(quantization=1e-6),
    'white': NoiseTerms(random_walk=1e-4),
    'flicker': NoiseTerms(bias_instability=1e-5),
    'random_walk': NoiseTerms(rate_random_walk=1e-6),
    'ramp': NoiseTerms(rate_ramp=1e-7),
    'all': NoiseTerms(1e-6, 1e-4, 1e-5, 1e-6, 1e-7, 0.01),
}


def _split(n: int, seed: int) -> list[int]:
    cuts = np.sort(np.random.default_rng(seed).integers(0, n, 7))
    return list(np.diff(np.concatenate(([0], cuts, [n]))))


@pytest.mark.parametrize('name', TERMS)
def test_axis_noise_is_bit_identical_however_chunked(name: str) -> None:
    n = 5000
    whole = AxisNoise(TERMS[name], 100.0, 7).samples(n)
    gen = AxisNoise(TERMS[name], 100.0, 7)
    chunked = np.concatenate([gen.samples(k) for k in _split(n, 3)])
    assert np.array_equal(whole, chunked)


def test_axis_noise_terms_draw_from_their_own_streams() -> None:
    both = AxisNoise(NoiseTerms(random_walk=1e-4, rate_random_walk=1e-6), 100.0, 5).samples(2000)
    white = AxisNoise(NoiseTerms(random_walk=1e-4), 100.0, 5).samples(2000)
    walk = AxisNoise(NoiseTerms(rate_random_walk=1e-6), 100.0, 5).samples(2000)
    assert np.allclose(both, white + walk, rtol=0, atol=1e-15)


def test_ou_allan_variance_matches_a_numerical_double_integral() -> None:
    from scipy.integrate import quad

    var, f_c = 2.0, 0.3
    lam = 2 * math.pi * f_c

    def block_variance(tau: float) -> float:  # Var(∫_0^τ y) = 2∫_0^τ (τ − s)·R(s) ds
        return 2 * quad(lambda u: (tau - u) * var * math.exp(-lam * u), 0, tau)[0]

    for tau in (0.05, 0.5, 3.0, 40.0):
        direct = (4 * block_variance(tau) - block_variance(2 * tau)) / (2 * tau * tau)
        assert ou_allan_variance(tau, var, f_c)[0] == pytest.approx(direct, rel=1e-8)


def test_ou_allan_variance_series_branch_joins_the_closed_form() -> None:
    f_c = 1e-2 / (2 * math.pi)  # λτ = 1e-2 at τ = 1 s
    below = ou_allan_variance(1 - 1e-9, 1.0, f_c)[0]
    above = ou_allan_variance(1 + 1e-9, 1.0, f_c)[0]
    assert below == pytest.approx(above, rel=1e-8)


@pytest.mark.parametrize('tau0', [1e-3, 1.0])
def test_flicker_exact_allan_deviation_is_flat_at_0664_b_from_tau0(tau0: float) -> None:
    flicker = FlickerRate(2e-5, tau0, np.random.default_rng(0))
    plateau = math.sqrt(2 * math.log(2) / math.pi) * 2e-5  # 0.664·B
    tau = tau0 * np.unique(np.round(np.logspace(0, 9, 400)))
    ratio = np.sqrt(flicker.allan_variance(tau)) / plateau
    assert np.max(np.abs(ratio[tau <= 1e3] - 1)) < 0.001
    assert np.max(np.abs(ratio[tau <= 1e4] - 1)) < 0.01


def test_simulated_flicker_shows_its_plateau_within_the_estimate_scatter() -> None:
    rate_hz, n = 50.0, 400_000
    gen = AxisNoise(NoiseTerms(bias_instability=1e-5), rate_hz, 11)
    y = gen.samples(n)
    taus = np.array([1.0, 4.0, 16.0, 64.0])
    tau, adev, _, ns = allantools.oadev(y, rate=rate_hz, data_type='freq', taus=taus)
    truth = gen.allan_deviation(tau)
    # flicker FM EDF (NIST SP 1065 Table 5): 5N²/(4m(N+3m)); ADEV sd ≈ σ/√(2·EDF)
    m = tau * rate_hz
    edf = 5 * n**2 / (4 * m * (n + 3 * m))
    assert np.all(np.abs(adev / truth - 1) < 4 / np.sqrt(2 * edf))
    assert np.all(np.abs(truth / (0.664 * 1e-5) - 1) < 0.002)


@pytest.mark.parametrize('terms', [NoiseTerms(random_walk=3e-4), NoiseTerms(rate_random_walk=2e-5),
                                   NoiseTerms(quantization=1e-5), NoiseTerms(rate_ramp=1e-4)])
def test_generated_allan_deviation_matches_the_exact_curve(terms: NoiseTerms) -> None:
    rate_hz = 100.0
    gen = AxisNoise(terms, rate_hz, 4)
    y = gen.samples(200_000)
    tau, adev, _, ns = allantools.oadev(y, rate=rate_hz, data_type='freq', taus=[0.01, 0.1, 1.0])
    truth = gen.allan_deviation(tau)
    assert np.all(np.abs(adev / truth - 1) < 0.05)


def test_imu_generator_gives_six_axes_gravity_on_z_and_jitter_in_stamps_only() -> None:
    g, a = NoiseTerms(random_walk=1e-4), NoiseTerms(random_walk=1e-3)
    clean = ImuNoiseGenerator(g, a, sample_rate_hz=400.0, seed=3)
    jittered = ImuNoiseGenerator(g, a, sample_rate_hz=400.0, seed=3, stamp_jitter_s=1e-4)
    t0, g0, a0 = clean.chunk(1000)
    t1, g1, a1 = jittered.chunk(1000)
    assert g0.shape == a0.shape == (1000, 3)
    assert np.all(np.diff(t0) == 2_500_000)
    assert np.array_equal(g0, g1) and np.array_equal(a0, a1)
    assert 0 < np.max(np.abs(t1 - t0)) <= 100_000
    assert abs(np.mean(a0[:, 2]) - 9.80665) < 1e-3


def test_imu_generator_is_bit_identical_however_chunked() -> None:
    terms = NoiseTerms(1e-6, 1e-4, 1e-5, 1e-6)
    whole = ImuNoiseGenerator(terms, terms, sample_rate_hz=200.0, seed=9, stamp_jitter_s=1e-4)
    parts = ImuNoiseGenerator(terms, terms, sample_rate_hz=200.0, seed=9, stamp_jitter_s=1e-4)
    t, g, a = whole.chunk(3000)
    chunks = [parts.chunk(k) for k in _split(3000, 1)]
    assert np.array_equal(t, np.concatenate([c[0] for c in chunks]))
    assert np.array_equal(g, np.concatenate([c[1] for c in chunks]))
    assert np.array_equal(a, np.concatenate([c[2] for c in chunks]))


def test_locked_in_static_rlg_gives_a_constant_count() -> None:
    rlg = RlgPulseGenerator(NoiseTerms(random_walk=1e-6, bias=1e-6),
                            scale_factor_rad_per_pulse=4e-6, lock_in_rate_rad_s=1e-3)
    _, counts = rlg.chunk(1000)
    assert rlg.locked_in and np.all(counts == counts[0])
    assert rlg.quantization_noise_rad() == 0.0


def test_rotating_rlg_gives_whole_pulses_and_chunking_does_not_matter() -> None:
    kwargs = dict(scale_factor_rad_per_pulse=4e-6, rotation_rate_rad_s=0.01, seed=2)
    whole = RlgPulseGenerator(NoiseTerms(random_walk=1e-5), **kwargs)
    parts = RlgPulseGenerator(NoiseTerms(random_walk=1e-5), **kwargs)
    t, counts = whole.chunk(4000)
    chunked = np.concatenate([parts.chunk(k)[1] for k in _split(4000, 2)])
    assert np.array_equal(counts, chunked)
    assert np.all(counts == np.floor(counts))
    assert np.mean(np.diff(counts)) == pytest.approx(0.01 * 1e-3 / 4e-6, rel=0.01)


def test_stripped_dither_removes_the_dither_angle_but_keeps_its_quantisation() -> None:
    rlg = RlgPulseGenerator(NoiseTerms(), scale_factor_rad_per_pulse=4e-6,
                            dither_amplitude_rad=4e-4, seed=3)
    _, counts = rlg.chunk(20_000)
    residual = counts - counts.mean()
    # what is left is the quantisation error, uniform over one pulse: sd = 1/√12
    assert np.std(residual) == pytest.approx(1 / math.sqrt(12), rel=0.05)


def test_fog_output_is_angle_times_scale_factor() -> None:
    fog = FogOutputGenerator(NoiseTerms(), scale_factor_counts_per_rad=1e6,
                             rotation_rate_rad_s=1e-3, sample_rate_hz=100.0)
    _, counts = fog.chunk(101)
    assert counts[-1] - counts[0] == pytest.approx(1e-3 * 1.0 * 1e6, rel=1e-9)


def test_imu_decimation_filter_bends_short_tau_keeps_n_and_is_chunk_independent() -> None:
    """An IMU's decimation filter bends short τ and keeps N.

    A MEMS IMU's own low-pass (core at D× the output rate, Butterworth at f_c, every D-th
    sample out): the per-sample scatter falls well below N/√τ0 (white noise band-limited to
    f_c ≪ f_s/2), the 1 s means keep N/√τ (DC gain 1), and chunking changes no bit.
    """
    n_rw = 1e-3
    terms = NoiseTerms(random_walk=n_rw, bias=0.01)
    def imu() -> ImuNoiseGenerator:
        return ImuNoiseGenerator(terms, terms, sample_rate_hz=100.0, seed=5, decimation=4,
                                 lowpass_cutoff_hz=10.0)

    gen = imu()
    _, g, _ = gen.chunk(60_000)
    x = g[:, 0]
    assert 0.99 < gen.filtered_random_walk_factor() < 1.01
    assert abs(x[:100].mean() - 0.01) < 5 * n_rw  # started at the bias: no transient
    assert np.std(x) < 0.6 * n_rw * math.sqrt(100.0)  # bent at τ0 = 0.01 s
    means = x.reshape(-1, 100).mean(axis=1)  # τ = 1 s
    adev_1s = math.sqrt(0.5 * np.mean(np.diff(means) ** 2))
    assert abs(adev_1s / n_rw - 1) < 0.1  # 600 clusters: ADEV scatter ≈ 3 %
    parts = imu()
    chunks = [parts.chunk(k) for k in _split(60_000, 3)]
    assert np.array_equal(g, np.concatenate([c[1] for c in chunks]))
