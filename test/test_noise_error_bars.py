"""Specification of the Allan error bars: EDF of a noise mixture, and coverage over seeds.

Issue 24 §3: one noise type per τ (its EDF) flipped from seed to seed and between
neighbouring τ where two types share the Allan variance, giving bars 7× too wide or 25×
too narrow. The EDF now blends the types by their shares (methods §E.2, (E.6)); these
tests check the blend against simulated records and the bars' coverage over seeds (the
full table: ``benchmarks/noise_error_bars.py``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binom, chi2

from gyro_calib.noise.edf import edf_greenhall
from gyro_calib.noise.mixture import (
    blended_edf,
    dominant_alpha,
    model_shares,
    slope_shares,
    uniform_quantisation_factor,
    unit_term_variances,
)
from gyro_calib.noise.terms import avar_basis

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'benchmarks'))
from noise_error_bars import analyse, coverage  # noqa: E402

PURE_ALPHAS = (2, 0, -1, -2)


def _avar_scatter(phase: np.ndarray, m: int) -> tuple[float, float]:
    """Mean and variance over records (rows) of the fully overlapping AVAR at m (τ0 = 1)."""
    u = phase[:, 2 * m:] - 2.0 * phase[:, m:-m] + phase[:, :-2 * m]
    avar = np.mean(u * u, axis=1) / (2.0 * m * m)
    return float(avar.mean()), float(avar.var(ddof=1))


def test_unit_terms_give_back_annex_c_and_the_known_mdev_hdev_ratios() -> None:
    for m in (1, 3, 64, 5000):
        adev = np.array(unit_term_variances('adev', m))
        assert adev == pytest.approx(avar_basis(np.array([float(m)]))[0], rel=1e-9)
    big = 1 << 14
    mdev = np.array(unit_term_variances('mdev', big)) / np.array(unit_term_variances('adev', big))
    hdev = np.array(unit_term_variances('hdev', 64)) / np.array(unit_term_variances('adev', 64))
    # Mod σ²/σ² for large m: 1/m, 0.5, 0.674, 0.825 (NIST SP 1065 §5.2.5); HVAR/AVAR: white
    # PM 10/9 (weights 1, −3, 3, −1: Σw² = 20, /6 against 6/2), white FM 1, flicker FM
    # (8 ln 2 − 3 ln 3)/(4 ln 2), random-walk FM 1/2 (K²τ/6)
    assert mdev[:4] * [big, 1, 1, 1] == pytest.approx([1.0, 0.5, 0.6746, 0.825], abs=1e-3)
    flicker = (8 * math.log(2) - 3 * math.log(3)) / (4 * math.log(2))
    assert hdev[:4] == pytest.approx([10 / 9, 1.0, flicker, 0.5], rel=1e-6)


def test_a_single_type_gives_its_own_edf_and_a_mixture_lies_between() -> None:
    pure = edf_greenhall(np.full(4, 4096), np.full(4, 16), np.array(PURE_ALPHAS))
    for k in range(4):
        shares = np.zeros((1, 5))
        shares[0, k] = 1.0
        assert blended_edf(shares, pure[:, None], [16])[0] == pytest.approx(pure[k])
    half = np.array([[0.5, 0.5, 0.0, 0.0, 0.0]])
    assert pure[1] < blended_edf(half, pure[:, None], [16])[0] < pure[0]
    # a deterministic ramp adds to the variance and nothing to its scatter: more EDF
    ramp = np.array([[0.0, 0.5, 0.0, 0.0, 0.5]])
    assert blended_edf(ramp, pure[:, None], [16])[0] == pytest.approx(4 * pure[1])


def test_blended_edf_matches_the_scatter_of_a_white_pm_plus_white_fm_record() -> None:
    # 2000 records of 4096 points: white PM and white FM with equal shares at m = 16, where
    # one type's EDF (white PM ~1900, white FM ~370) would be 1.9× or 2.6× off
    rng = np.random.default_rng(5)
    n, m, records = 4096, 16, 2000
    q2, n2 = m / 3.0, 1.0  # 3Q²/τ² = N²/τ at τ = m
    phase = (math.sqrt(q2) * rng.standard_normal((records, n))
             + np.cumsum(math.sqrt(n2) * rng.standard_normal((records, n)), axis=1))
    mean, var = _avar_scatter(phase, m)
    observed = 2.0 * mean**2 / var
    shares = model_shares('adev', [m], 1.0, [q2, n2, 0.0, 0.0, 0.0])
    assert shares is not None and shares[0, :2] == pytest.approx([0.5, 0.5])
    pure = edf_greenhall(np.full(4, n), np.full(4, m), np.array(PURE_ALPHAS))
    nu = blended_edf(shares, pure[:, None], [m])[0]
    # the variance of a variance from 2000 records: ±3.2 % (1σ); band ±12 %
    assert observed == pytest.approx(nu, rel=0.12), (observed, nu, pure[:2])
    assert not 0.6 < pure[0] / observed < 1.6 and not 0.6 < pure[1] / observed < 1.6


def test_uniform_rounding_of_a_count_scatters_less_than_gaussian_white_pm() -> None:
    rng = np.random.default_rng(6)
    n, records = 2048, 3000
    for m in (1, 8, 64):
        phase = rng.uniform(-0.5, 0.5, (records, n))
        mean, var = _avar_scatter(phase, m)
        gaussian = float(np.asarray(edf_greenhall(n, m, 2)))
        expected = gaussian * float(uniform_quantisation_factor('adev', m)[0])
        assert 2.0 * mean**2 / var == pytest.approx(expected, rel=0.12), m
    assert uniform_quantisation_factor('adev', [1, 64]) == pytest.approx(140 / 96.8)
    assert uniform_quantisation_factor('hdev', [1, 64]) == pytest.approx(1848 / 1368)
    mdev = uniform_quantisation_factor('mdev', [1, 4, 64])
    assert mdev[0] == pytest.approx(140 / 96.8) and 1.0 < mdev[2] < mdev[1] < mdev[0]


def test_the_local_slope_splits_between_the_bracketing_types_without_a_switch() -> None:
    m = np.unique(np.round(np.logspace(0, 5, 60)).astype(np.int64))
    tau = 0.01 * m
    avar = 3e-12 / tau**2 + 1e-12 / tau + 2e-16 * tau
    shares = slope_shares(tau, avar)
    assert np.allclose(shares.sum(axis=1), 1.0)
    model = model_shares('adev', m, 0.01, [1e-12, 1e-12, 0.0, 6e-16, 0.0])
    assert model is not None
    # a pure two-type curve: the slope's split is the model's (white PM + white FM here)
    assert np.abs(shares[:12, :2] - model[:12, :2]).max() < 0.05
    assert np.abs(np.diff(shares, axis=0)).max() < 0.3  # a hard switch would move one by 1
    assert list(dominant_alpha(shares)[[0, 35, -1]]) == [2, 0, -2]


def _band(n: int, points: int, risk: float = 1e-3) -> tuple[float, float]:
    """Acceptance band of a ±1σ coverage from n seeds, family-wise risk over ``points`` τ.

    A bar with the right EDF covers 62–68 % of a χ² estimate's draws (ν = 2 … ∞); each τ
    is tested at risk/points (both tails), from the binomial with n draws.
    """
    r = risk / (2 * points)
    return float(binom.ppf(r, n, 0.62)) / n, float(binom.isf(r, n, 0.683) + 1) / n


@pytest.mark.parametrize(('scenario', 'seeds', 'duration_s'), [
    ('noise_rlg_static', 48, 30.0),  # 2 s
    ('noise_imu_static', 24, 20.0),  # 5 s: six axes
])
def test_error_bars_cover_the_scatter_over_seeds(scenario: str, seeds: int,
                                                 duration_s: float) -> None:
    # issue 24: on the RLG at 60 s the noise type flipped 2 ↔ 0 from τ = 0.128 s on and
    # the bars were 7× too wide at mid τ (coverage 1.0) or 25× too narrow at long τ
    runs = [analyse(scenario, 3000 + k, duration_s) for k in range(seeds)]
    tables = {axis: coverage([r[axis] for r in runs]) for axis in runs[0]}
    points = sum(int(np.count_nonzero(c['clusters'] >= 10)) for c in tables.values())
    lo, hi = _band(seeds, points)
    # the scatter over seeds against the median bar: a sample standard deviation of n
    # draws is σ·√(χ²_{n−1}/(n−1)); same family-wise risk, 5 % allowed for the median bar
    r = 1e-3 / (2 * points)
    low = math.sqrt(chi2.ppf(r, seeds - 1) / (seeds - 1)) / 1.05
    high = math.sqrt(chi2.isf(r, seeds - 1) / (seeds - 1)) * 1.05
    for axis, c in tables.items():
        counted = c['clusters'] >= 10
        bad = [(round(float(t), 4), float(v)) for t, v, ok in
               zip(c['tau_s'], c['coverage'], counted) if ok and not lo <= v <= hi]
        assert not bad, (axis, lo, hi, bad)
        ratio = (c['scatter'] / c['claimed'])[counted]
        assert np.all((ratio > low) & (ratio < high)), (axis, low, high,
                                                        ratio.round(2).tolist())
        # the same record length gives the same bar within the scatter of the
        # identification: the switch between white PM and white FM made it differ 7×
        rel = np.array([np.asarray(r[axis]['adev_std']) / np.asarray(r[axis]['adev'])
                        for r in runs])
        spread = (rel.max(axis=0) / rel.min(axis=0))[counted]
        assert np.all(spread < 4.0), (axis, spread.round(2).tolist())
