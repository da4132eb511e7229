"""Specification of the Allan-deviation core: full overlap = allantools, partial within 1 %."""

from __future__ import annotations

import allantools
import numpy as np
import pytest

from gyro_calib.noise.allan import (
    AveragingGrid,
    overlapping_allan_deviation,
    rate_to_phase,
    total_deviation,
)
from gyro_calib.noise.edf import adev_std, edf_oadev, edf_totdev, pooled_edf
from gyro_calib.noise.tree import TREE_BLOCK, AllanTree, FullOverlapStore, PhaseReservoir


def _mixed_noise(n: int, seed: int) -> np.ndarray:
    """Rate samples: white + random walk + an AR(1) — written here from the physics."""
    rng = np.random.default_rng(seed)
    white = rng.standard_normal(n)
    walk = np.cumsum(rng.standard_normal(n)) * 3e-3
    ar = np.zeros(n)
    e = rng.standard_normal(n) * 0.05
    for i in range(1, n):
        ar[i] = 0.999 * ar[i - 1] + e[i]
    return white + walk + ar


def _adev(sums: object, tau0: float) -> tuple[np.ndarray, np.ndarray]:
    m = sums.m  # type: ignore[attr-defined]
    avar = sums.sum_sq / (2.0 * sums.terms * (m * tau0) ** 2)  # type: ignore[attr-defined]
    return m, np.sqrt(avar)


def test_grid_holds_every_octave_and_log_spaced_points_between() -> None:
    grid = AveragingGrid.make(taus_per_octave=4, min_m=256)
    m = grid.factors_up_to(1 << 20)
    octaves = [1 << k for k in range(21)]
    assert set(octaves) <= set(m.tolist())
    ratios = m[1:] / m[:-1]
    assert np.all(m[1:] > m[:-1])
    assert np.max(ratios[m[:-1] >= 16]) < 2 ** (1 / 4) * 1.05


@pytest.mark.parametrize('data_type', ['phase', 'rate'])
@pytest.mark.parametrize('n', [1000, 40_001])
def test_full_overlap_adev_equals_allantools_oadev(data_type: str, n: int) -> None:
    rng = np.random.default_rng(n)
    data = rng.standard_normal(n).cumsum() if data_type == 'phase' else _mixed_noise(n, 2)
    tau0 = 2.5e-3
    m = AveragingGrid.make(4, 256).factors_up_to(n // 2)
    tau, adev = overlapping_allan_deviation(data, tau0_s=tau0, m=m, data_type=data_type)
    ref_tau, ref, _, _ = allantools.oadev(data, rate=1 / tau0,
                                          data_type='phase' if data_type == 'phase' else 'freq',
                                          taus=tau)
    common = np.isin(np.round(tau / tau0), np.round(ref_tau / tau0))
    assert np.allclose(tau[common], ref_tau, rtol=1e-12)
    assert np.max(np.abs(adev[common] / ref - 1)) < 1e-9


def test_full_overlap_store_equals_allantools_oadev() -> None:
    x = rate_to_phase(_mixed_noise(30_000, 4), 1.0)
    store = FullOverlapStore(AveragingGrid.make(4, 256))
    for part in np.array_split(x, 7):
        store.push(part)
    m, adev = _adev(store.sums(), 1.0)
    _, ref, _, _ = allantools.oadev(x, rate=1.0, data_type='phase', taus=m.astype(float))
    assert np.max(np.abs(adev[:len(ref)] / ref - 1)) < 1e-9


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_partial_overlap_stays_within_one_percent_of_full_overlap(seed: int) -> None:
    n = 1 << 18
    x = rate_to_phase(_mixed_noise(n, seed), 1.0)
    grid = AveragingGrid.make(4, 256)
    tree, store = AllanTree(grid), FullOverlapStore(grid)
    tree.push(x)
    store.push(x)
    m_p, partial = _adev(tree.sums(), 1.0)
    m_f, full = _adev(store.sums(), 1.0)
    keep = m_p <= n // 4  # the reported range: τ ≤ T/4
    idx = np.searchsorted(m_f, m_p[keep])
    assert np.array_equal(m_f[idx], m_p[keep])
    assert np.max(np.abs(partial[keep] / full[idx] - 1)) < 0.01


def test_tree_sums_are_bit_identical_however_the_phase_is_chunked() -> None:
    x = rate_to_phase(_mixed_noise(100_000, 5), 1.0)
    grid = AveragingGrid.make(4, 256)
    one = AllanTree(grid)
    one.push(x)
    many = AllanTree(grid)
    cuts = np.sort(np.random.default_rng(0).integers(0, len(x), 40))
    for part in np.split(x, cuts):
        many.push(part)
    a, b = one.sums(), many.sums()
    assert np.array_equal(a.m, b.m) and np.array_equal(a.sum_sq, b.sum_sq)
    assert np.array_equal(a.terms, b.terms)


def test_tree_sums_leave_the_stream_undisturbed() -> None:
    x = rate_to_phase(_mixed_noise(60_000, 6), 1.0)
    grid = AveragingGrid.make(4, 256)
    probed, plain = AllanTree(grid), AllanTree(grid)
    for part in np.array_split(x, 6):
        probed.push(part)
        plain.push(part)
        probed.sums()
    assert np.array_equal(probed.sums().sum_sq, plain.sums().sum_sq)


def test_tree_memory_grows_only_by_one_level_per_doubling() -> None:
    grid = AveragingGrid.make(4, 256)
    sizes = []
    for n in (1 << 16, 1 << 20):
        tree = AllanTree(grid)
        x = np.zeros(1 << 14)
        for _ in range(n // len(x)):
            tree.push(x)
        sizes.append(tree.nbytes())
    per_level = (TREE_BLOCK + 4 * 256) * 8  # one pending block and one tail, float64
    assert sizes[1] - sizes[0] <= 4 * per_level  # 16× the record: 4 more levels at most
    assert sizes[1] < 2_000_000


def test_partial_overlap_point_is_full_overlap_of_the_subsampled_phase() -> None:
    x = rate_to_phase(_mixed_noise(50_000, 7), 1.0)
    tree = AllanTree(AveragingGrid.make(1, 16))
    tree.push(x)
    s = tree.sums()
    k = int(np.nonzero(s.stride == 4)[0][0])
    m_level = int(s.m[k] // 4)
    sub = x[::4]
    d = sub[2 * m_level:] - 2 * sub[m_level:-m_level] + sub[:-2 * m_level]
    assert s.terms[k] == len(d)
    assert s.sum_sq[k] == pytest.approx(float(np.dot(d, d)), rel=1e-12)


def test_total_deviation_equals_allantools_totdev() -> None:
    x = rate_to_phase(_mixed_noise(4000, 8), 0.01)
    m = np.array([1, 2, 4, 16, 64, 256, 1000, 1999])
    tau, dev = total_deviation(x, tau0_s=0.01, m=m)
    ref_tau, ref, _, _ = allantools.totdev(x, rate=100.0, data_type='phase', taus=m * 0.01)
    assert np.allclose(tau, ref_tau)
    assert np.max(np.abs(dev / ref - 1)) < 1e-9


def test_reservoir_keeps_an_exact_power_of_two_subsample() -> None:
    x = np.arange(10_001, dtype=float)
    res = PhaseReservoir(capacity=600)
    for part in np.array_split(x, 13):
        res.push(part)
    assert res.stride == 16
    assert np.array_equal(res.phase(), x[::16])


@pytest.mark.parametrize(('alpha', 'n', 'm', 'expected'), [
    (2, 1001, 10, 1002 * 981 / (2 * 991)),                        # white PM
    (0, 1001, 10, (3 * 1000 / 20 - 2 * 999 / 1001) * 400 / 405),  # white FM
    (-1, 1001, 1, 2 * 999**2 / (2.3 * 1001 - 4.9)),               # flicker FM, m = 1 (squared)
    (-1, 1001, 10, 5 * 1001**2 / (40 * 1031)),                    # flicker FM, m ≥ 2
    (-2, 1001, 10, 999 / 10 * (1000**2 - 30 * 1000 + 400) / 998**2),  # random-walk FM
])
def test_edf_follows_nist_sp1065_table5(alpha: int, n: int, m: int, expected: float) -> None:
    assert edf_oadev(n, m, alpha) == pytest.approx(expected, rel=1e-12)


def test_total_deviation_edf_follows_nist_sp1065_table7() -> None:
    assert edf_totdev(1001, 10, 0) == pytest.approx(1.5 * 100)
    assert edf_totdev(1001, 10, -2) == pytest.approx(0.93 * 100 - 0.36)


def test_pooled_edf_of_equal_segments_adds_up() -> None:
    assert pooled_edf(np.array([5.0, 5.0]), np.array([10.0, 10.0])) == pytest.approx(20.0)


def test_adev_error_bars_cover_the_truth_about_as_often_as_they_claim() -> None:
    """White rate noise of unit variance: ADEV(τ = m) = 1/√m; EDF error bars, 400 seeds."""
    n, m = 2000, np.array([1, 8, 64, 250])
    hits = np.zeros(len(m))
    trials = 400
    rng = np.random.default_rng(12)
    for _ in range(trials):
        x = rate_to_phase(rng.standard_normal(n), 1.0)
        tau, adev = overlapping_allan_deviation(x, tau0_s=1.0, m=m)
        std = adev_std(adev, edf_oadev(n + 1, m, 0))
        hits += np.abs(adev - 1 / np.sqrt(m)) < std
    coverage = hits / trials
    assert np.all((coverage > 0.6) & (coverage < 0.77)), coverage


def test_tau_from_integer_ns_stamps_is_exact_over_an_hour() -> None:
    """τ0 = (t_last − t_first)/(n − 1) in integer ns: exact even at epoch-sized stamps."""
    from gyro_calib.noise.calibrator import NoiseCalibrator

    period_ns, n = 100_000_000, 10 * 3600
    t = 1_700_000_000_000_000_000 + period_ns * np.arange(n, dtype=np.int64)
    rng = np.random.default_rng(3)
    cal = NoiseCalibrator()
    cal.extend_imu(t, rng.standard_normal((n, 3)), rng.standard_normal((n, 3)))
    cal.process(flush=True)
    curve = cal.axis_result('gyro_x').curve
    assert curve is not None and curve.tau0_s == 0.1
    assert np.allclose(curve.tau_s, curve.m * 0.1, rtol=1e-14, atol=0)
