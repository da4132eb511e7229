"""Lifting wavelet (METHODS §D.1).

Lifting wavelet (METHODS §D.1): equals PyWavelets' bior2.2/bior4.4; denoising keeps the
slow (model-band) content; SNR definition.
"""

from __future__ import annotations

import numpy as np
import pytest
import pywt
from hypothesis import given, settings
from hypothesis import strategies as st

from gyro_calib.errors import ConfigError
from gyro_calib.thermal.regression import fit_linear
from gyro_calib.thermal.wavelet import denoise, lifting_forward, lifting_inverse, snr_db


@pytest.mark.parametrize('wavelet', ['bior2.2', 'bior4.4'])
@pytest.mark.parametrize('levels', [1, 3, 5])
def test_lifting_steps_equal_pywavelets_periodized_transform(wavelet: str, levels: int) -> None:
    x = np.random.default_rng(levels).standard_normal(512)
    approx, details = lifting_forward(x, wavelet, levels)
    ref = pywt.wavedec(x, wavelet, mode='periodization', level=levels)
    assert np.allclose(approx, ref[0], rtol=0, atol=1e-10)  # constants known to ~1e-15
    for mine, theirs in zip(details, ref[1:]):
        assert np.allclose(mine, theirs, rtol=0, atol=1e-10)


@pytest.mark.parametrize('wavelet', ['bior2.2', 'bior4.4'])
def test_lifting_inverse_undoes_forward(wavelet: str) -> None:
    x = np.random.default_rng(3).standard_normal(128)
    approx, details = lifting_forward(x, wavelet, 4)
    assert np.allclose(lifting_inverse(approx, details, wavelet), x, atol=1e-12)


def _thermal_curve(n: int) -> np.ndarray:
    """A slow bias curve over n seconds: a cubic in time plus a 2 h swing, rad/s scale."""
    t = np.arange(n) / n
    return 1e-6 * (0.5 + 0.3 * t - 0.6 * t**2 + 0.2 * t**3 + 0.1 * np.sin(2 * np.pi * t * 2))


@pytest.mark.parametrize('wavelet', ['bior2.2', 'bior4.4'])
def test_denoising_passes_a_noise_free_slow_signal_unchanged(wavelet: str) -> None:
    x = _thermal_curve(14400)
    out = denoise(x, wavelet=wavelet, levels=6).values
    assert np.max(np.abs(out - x)) < 1e-3 * np.ptp(x)


@pytest.mark.parametrize('rule', ['universal', 'minimax', 'bayes'])
def test_denoising_changes_no_model_band_content(rule: str) -> None:
    """Denoising changes no model-band content.

    The thermal model is fitted to content slower than ~30 min. With 6 levels (64
    samples) the denoised series keeps it: 1800-sample means move by < 0.2 of their own
    noise (the change falls as √(2^levels / block): only wavelets straddling a block edge
    reach a block mean), and a slow fit moves by < 0.25σ.
    """
    rng = np.random.default_rng(11)
    n = 28800
    slow = _thermal_curve(n)
    white = 5e-6 * rng.standard_normal(n)
    q = 2.3 * 4.85e-6 * rng.uniform(size=n + 1)
    x = slow + white + np.diff(q)  # white rate noise + quantisation (differenced phase)
    out = denoise(x, levels=6, threshold_rule=rule).values
    diff_means = (out - x).reshape(-1, 1800).mean(axis=1)
    noise_means = (x - slow).reshape(-1, 1800).mean(axis=1)
    assert np.std(diff_means) < 0.2 * np.std(noise_means)
    t = (np.arange(n) - n / 2) / (n / 2)
    cols = {f't{j}': t**j for j in range(1, 4)}
    f_raw = fit_linear(x, cols, list(cols))
    f_dn = fit_linear(out, cols, list(cols))
    assert np.all(np.abs(f_dn.coefficients - f_raw.coefficients)
                  < 0.25 * f_raw.std_uncertainties)


def test_slow_fit_to_denoised_data_is_unbiased_and_no_worse() -> None:
    """A slow fit to denoised data is unbiased and no worse.

    Over 10 noise draws the fit to the denoised series errs (vs the truth) as the raw
    fit does: denoising removes noise, not slow signal.
    """
    n = 28800
    t = (np.arange(n) - n / 2) / (n / 2)
    cols = {f't{j}': t**j for j in range(1, 4)}
    truth = fit_linear(_thermal_curve(n), cols, list(cols)).coefficients
    err_raw, err_dn = [], []
    for seed in range(10):
        x = _thermal_curve(n) + 5e-6 * np.random.default_rng(seed).standard_normal(n)
        f_raw = fit_linear(x, cols, list(cols))
        f_dn = fit_linear(denoise(x, levels=6).values, cols, list(cols))
        err_raw.append((f_raw.coefficients - truth) / f_raw.std_uncertainties)
        err_dn.append((f_dn.coefficients - truth) / f_raw.std_uncertainties)
    rms_raw = np.sqrt(np.mean(np.square(err_raw), axis=0))
    rms_dn = np.sqrt(np.mean(np.square(err_dn), axis=0))
    assert np.all(rms_dn < 1.1 * rms_raw)
    assert np.all(np.abs(np.mean(err_dn, axis=0)) < 3.0 * 1.3 / np.sqrt(10))


def test_denoising_raises_snr_against_truth() -> None:
    rng = np.random.default_rng(2)
    slow = _thermal_curve(4096) + 4e-5
    x = slow + 4e-6 * rng.standard_normal(4096)
    out = denoise(x, levels=6).values
    assert snr_db(out, slow) > snr_db(x, slow) + 10.0
    assert snr_db(out) > snr_db(x)


def test_snr_of_a_line_plus_noise_matches_its_definition() -> None:
    rng = np.random.default_rng(5)
    line = 2.0 + 0.001 * np.arange(1000)
    noise = rng.standard_normal(1000) * 0.1
    got = snr_db(line + noise)
    expected = 10 * np.log10(np.sum(line**2) / np.sum(noise**2))
    assert got == pytest.approx(expected, abs=0.1)


def test_denoise_caps_levels_for_short_series_and_rejects_bad_names() -> None:
    res = denoise(np.arange(40.0), levels=9)
    assert 1 <= res.levels < 9
    with pytest.raises(ConfigError, match='wavelet'):
        denoise(np.zeros(64), wavelet='db4')
    with pytest.raises(ConfigError, match='threshold_rule'):
        denoise(np.zeros(64), threshold_rule='sure')


@settings(max_examples=15, deadline=None)
@given(amplitude=st.floats(1e-7, 1e-4), offset=st.floats(-1e-4, 1e-4),
       seed=st.integers(0, 2**16), levels=st.integers(3, 6))
def test_denoising_keeps_the_slow_fit_for_any_noise_level(amplitude: float, offset: float,
                                                          seed: int, levels: int) -> None:
    """Property: denoising keeps a slow fit unchanged.

    Property: for any white noise level and offset, and depths up to 6 levels on 8192
    samples, a slow (cubic) fit to the denoised series equals the raw fit within 0.6σ
    (deeper levels on short records do distort the ends: keep 2^levels ≪ record).
    """
    rng = np.random.default_rng(seed)
    n = 8192
    x = offset + _thermal_curve(n) + amplitude * rng.standard_normal(n)
    out = denoise(x, levels=levels).values
    t = (np.arange(n) - n / 2) / (n / 2)
    cols = {f't{j}': t**j for j in range(1, 4)}
    f_raw = fit_linear(x, cols, list(cols))
    f_dn = fit_linear(out, cols, list(cols))
    assert np.all(np.abs(f_dn.coefficients - f_raw.coefficients)
                  < 0.6 * f_raw.std_uncertainties + 1e-12)
