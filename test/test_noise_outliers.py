"""Spikes in a noise record (METHODS §E.6): found, reported, removed only when asked.

The screen flags |d − median| > k·1.4826·MAD per block (d: the rate, or a count's per-sample
increment); the report gives the count, the largest in robust σ, the first stamps and what
the other treatment changes; ``outliers = keep`` leaves the data exactly as recorded. The
property test injects spikes of known count and size into IEEE 952 noise sums; the 10⁷-
sample false-alarm check is ``benchmarks/noise_outliers.py``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from gyro_calib.cli import main
from gyro_calib.errors import ConfigError
from gyro_calib.noise import NoiseCalibrator, NoiseSettings, calibrate_noise
from gyro_calib.noise.outliers import (
    OutlierReport,
    OutlierScreen,
    OutlierTally,
    repair_increments,
    replace_spikes,
    robust_center_scale,
)
from sim_nodes.noise import AxisNoise, NoiseTerms, RlgPulseGenerator

BAGS = Path(__file__).resolve().parents[1] / 'bags'
PERIOD_NS = 10_000_000  # 100 Hz


def _imu(gyro_x: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An Imu record whose gyro_x is ``gyro_x`` (the other axes white)."""
    n = len(gyro_x)
    rng = np.random.default_rng(seed)
    gyro = np.column_stack((gyro_x, rng.normal(0, 1e-4, (n, 2))))
    return np.arange(n, dtype=np.int64) * PERIOD_NS, gyro, rng.normal(0, 1e-3, (n, 3))


def _white(n: int, sigma: float = 1e-4, seed: int = 1) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, sigma, n)


def test_robust_scale_is_sigma_for_gaussian_data_and_ignores_spikes() -> None:
    d = _white(200_000, 2.0)
    d[:1000] = 1e6  # 0.5 % wild values move neither
    center, scale, mad_zero = robust_center_scale(d)
    assert abs(center) < 0.03 and scale == pytest.approx(2.0, rel=0.01) and not mad_zero


def test_a_quantised_output_whose_mad_is_zero_takes_its_step_or_mean_deviation() -> None:
    d = np.zeros(1000)
    d[::10] = 1.0  # 90 % of the samples equal: MAD 0; the step 1 is common
    center, scale, mad_zero = robust_center_scale(d)
    assert (center, scale, mad_zero) == (0.0, 1.0, True)
    d[::10] = 0.0
    d[:400:2] = 5.0  # 20 % at 5: the common step 5 exceeds 1.2533 · mean|d| = 1.25
    d[1] = 0.5  # one value half a step off is not the step (held by < 0.1 %)
    center, scale, mad_zero = robust_center_scale(d)
    assert center == 0.0 and mad_zero and scale == pytest.approx(5.0)


@pytest.mark.parametrize('sigma_lsb', [0.05, 0.3, 0.5])
def test_noise_below_one_step_gives_no_false_alarm_and_its_spikes_are_found(
        sigma_lsb: float) -> None:
    """An output quantised to a step (LSB) larger than its noise: most samples equal, MAD 0.

    The ±1-step values are noise, not spikes (the scale is at least the step; at 0.3 LSB
    the mean absolute deviation alone flagged 381 656 of 4·10⁶ samples); 20-step spikes
    are still found, also where no other sample leaves the median (0.05 LSB).
    """
    v = np.round(np.random.default_rng(4).normal(0.0, sigma_lsb, 400_000))
    for spikes in (0, 8):
        x = v.copy()
        x[25_000::50_000][:spikes] += 20.0
        screen = OutlierScreen('rate', 8.0, 65_536)
        screen.push(np.arange(len(x)), x)
        screen.end_segment()
        assert screen.tally.spikes == spikes and screen.tally.mad_zero_blocks == 7


def test_a_rate_spike_is_replaced_by_the_median_of_its_neighbours() -> None:
    d = np.array([1.0, 2.0, 3.0, 4.0, 99.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    out = replace_spikes(d, d > 50, center=5.0)
    assert out[4] == np.median([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0])
    assert np.array_equal(np.delete(out, 4), np.delete(d, 4))


def test_a_count_glitch_is_interpolated_across_and_a_jump_is_taken_out() -> None:
    x = np.arange(20, dtype=float) * 3.0  # 3 pulses per sample
    glitch = x.copy()
    glitch[7] += 512.0  # read wrong once, right again
    jump = x.copy()
    jump[12:] += 512.0  # pulses gained
    for counts in (glitch, jump):
        d = np.diff(counts)
        spikes = np.abs(d - 3.0) > 8.0
        fixed = np.concatenate(([counts[0]], counts[0] + np.cumsum(
            repair_increments(d, spikes, 3.0, 1.0, 8.0))))
        assert np.allclose(fixed, x)


def test_the_screen_gives_the_same_result_however_the_record_is_chunked() -> None:
    v = _white(10_000)
    v[[5, 2047, 2048, 9000]] += 0.05
    screens = []
    for chunk in (10_000, 777, 1):
        screen = OutlierScreen('rate', 8.0, 2048)
        out = []
        for a in range(0, len(v), chunk):
            out += screen.push(np.arange(a, min(a + chunk, len(v))), v[a:a + chunk])
        out += screen.end_segment()
        screens.append((screen.tally, np.concatenate([c for _, _, c in out])))
    (t0, c0), *rest = screens
    assert t0.spikes == 4 and [ns for ns, _ in t0.first] == [5, 2047, 2048, 9000]
    for tally, clean in rest:
        assert tally == t0 and np.array_equal(clean, c0)


def test_keep_analyses_the_record_exactly_as_recorded_and_remove_is_its_mirror() -> None:
    """keep: the curve is bit for bit that of the record with no sample flagged.

    The two settings swap the estimator's curve and the other one (also when the phase
    spills to the scratch file).
    """
    v = _white(50_000)
    v[np.arange(100, 50_000, 997)] += 0.02
    imu = _imu(v)
    def run(**values: object) -> NoiseCalibrator:
        return calibrate_noise(imu=imu, settings=NoiseSettings(
            memory_points=4096, outlier_block_samples=8192, **values))  # type: ignore[arg-type]

    keep, blind, remove = run(), run(outlier_sigma=1e12), run(outliers='remove')
    curve, blind_curve = keep.curve('gyro_x'), blind.curve('gyro_x')
    assert curve is not None and blind_curve is not None
    assert np.array_equal(curve.avar, blind_curve.avar)
    k_ch, r_ch = keep._channel('gyro_x')[1], remove._channel('gyro_x')[1]
    k_other, r_main, r_other = k_ch.shadow_curve(), r_ch.curve(), r_ch.shadow_curve()
    assert k_other is not None and r_main is not None and r_other is not None
    assert np.array_equal(k_other.avar, r_main.avar)
    assert np.array_equal(r_other.avar, curve.avar)
    assert keep._channel('gyro_y')[1].shadow is None  # no spike: no second estimator


def test_the_report_says_how_many_how_large_where_and_what_removal_changes() -> None:
    v = _white(200_000)
    at = np.array([1000, 50_000, 120_000])
    v[at] += np.array([3e-3, -5e-3, 2e-3])
    cal = calibrate_noise(imu=_imu(v))
    report = cal.axis_result('gyro_x').outliers
    assert report is not None
    rec = report.record()
    assert rec['found'] == 3 and rec['mode'] == 'keep' and rec['statistic'] == 'rate'
    assert rec['first_stamps_s'] == [i * PERIOD_NS / 1e9 for i in at]
    assert rec['largest_sigma'] == pytest.approx(50.0, rel=0.05)
    assert rec['largest_stamp_s'] == 500.0
    adev_1s = rec['adev_1s']
    assert isinstance(adev_1s, dict) and adev_1s['change'] < 0  # the spikes raise the white noise
    line = report.line()
    assert line.startswith('gyro_x: spikes: 3 of 200000 samples (0.0015 %) beyond 8 robust σ')
    assert 'the first at 10.000000000 s' in line and 'removing them would change ADEV(1 s)' in line
    clean = cal.axis_result('gyro_y').outliers
    assert clean is not None and clean.line().startswith('gyro_y: spikes: none of 200000')
    assert 'adev_1s' not in clean.record()
    reports = [r.outliers for r in cal.axis_results().values() if r.outliers is not None]
    first, *others = OutlierReport.lines(reports)  # the axes without spikes: one line
    assert first == line and len(others) == 1
    assert others[0].startswith('gyro_y, gyro_z, accel_x, accel_y, accel_z: spikes: none '
                                'beyond 8 robust σ (')
    assert '; the largest: gyro_y ' in others[0]


TERMS = {
    'white rate (N)': NoiseTerms(random_walk=1e-4),
    'N + flicker (B)': NoiseTerms(random_walk=1e-4, bias_instability=2e-5),
    'N + random walk (K)': NoiseTerms(random_walk=1e-4, rate_random_walk=2e-6),
    'Q + N': NoiseTerms(quantization=1e-6, random_walk=1e-4),
}


@settings(max_examples=6, deadline=None, derandomize=True)  # CI sees the same benches each run
@example(name='N + random walk (K)', seed=89, count=1, size=12.0)  # a term at its limit tips
@example(name='Q + N', seed=1846, count=21, size=12.0)  # Q 6σ clean, a 2σ bound after removal
@given(name=st.sampled_from(sorted(TERMS)), seed=st.integers(0, 10_000),
       count=st.integers(1, 60), size=st.floats(12.0, 1e4))
def test_injected_spikes_are_all_found_none_on_clean_data_and_removal_restores_the_terms(
        name: str, seed: int, count: int, size: float) -> None:
    n = 120_000
    axis = AxisNoise(TERMS[name], 100.0, seed)
    clean = axis.samples(n)
    sigma = float(np.sqrt(axis.allan_variance(0.01)[0]))  # the per-sample σ
    rng = np.random.default_rng(seed + 1)
    at = np.sort(rng.choice(np.arange(0, n, 2), count, replace=False))
    spiky = clean.copy()
    spiky[at] += rng.choice([-1.0, 1.0], count) * size * sigma
    base = calibrate_noise(imu=_imu(clean, seed))
    removed = calibrate_noise(imu=_imu(spiky, seed), settings=NoiseSettings(outliers='remove'))
    before, after = base.axis_result('gyro_x').outliers, removed.axis_result('gyro_x').outliers
    assert before is not None and after is not None
    assert before.tally.spikes == 0  # no false alarm
    assert after.tally.spikes == count  # every one found, nothing else
    truth, got = base.results()['gyro_x'], removed.results()['gyro_x']
    bounds = {id(base): base.axis_result('gyro_x').fit.upper_bounds,
              id(removed): removed.axis_result('gyro_x').fit.upper_bounds}
    for key in set(got) ^ set(truth):  # resolved by one fit only: the other's 2σ upper bound
        est, other = (got[key], base) if key in got else (truth[key], removed)  # must agree
        bound = bounds[id(other)].get(key)  # (seed 89: a 3.x σ rate ramp; seed 1846: Q 6σ
        assert bound is not None and bound >= est.value - 2.0 * est.std_uncertainty, (
            key, est, bound)  # clean, ≤ 1.3e-6 at 2σ after removal: both true of Q = 1e-6)
    for key in set(got) & set(truth):
        assert abs(got[key].value - truth[key].value) <= truth[key].std_uncertainty, key


def test_rlg_count_glitches_are_repaired_to_the_clean_terms() -> None:
    k = 1e-5
    gen = RlgPulseGenerator(NoiseTerms(random_walk=5e-5), scale_factor_rad_per_pulse=k,
                            sample_rate_hz=100.0, dither_amplitude_rad=5e-4, seed=3)
    t, counts = gen.chunk(60_000)
    spiky = counts.copy()
    spiky[np.arange(500, 60_000, 2000)] += 256.0
    s = NoiseSettings(scale_factor_rad_per_pulse=k)
    clean = calibrate_noise(pulses=(t, counts), settings=s)
    fixed = calibrate_noise(pulses=(t, spiky), settings=NoiseSettings(
        scale_factor_rad_per_pulse=k, outliers='remove'))
    rec = fixed.axis_result('gyro').outliers
    assert rec is not None and rec.tally.spikes == 2 * 30 and rec.statistic == 'increment'
    a, b = clean.curve('gyro'), fixed.curve('gyro')
    assert a is not None and b is not None
    assert np.allclose(a.adev, b.adev, rtol=1e-3)


@pytest.mark.parametrize('values', [{'outliers': 'drop'}, {'outliers': 'Keep'},
                                    {'outlier_sigma': 0.0}, {'outlier_sigma': -3.0},
                                    {'outlier_sigma': math.inf}, {'outlier_block_samples': 8}])
def test_a_wrong_outlier_setting_is_refused_naming_it(values: dict[str, object]) -> None:
    with pytest.raises(ConfigError, match=next(iter(values))):
        NoiseSettings(**values)  # type: ignore[arg-type]


@pytest.mark.parametrize('argv, named', [
    (['--outliers', 'kep'], "--outliers 'kep' is invalid"),
    (['--outlier-sigma', '0'], "--outlier-sigma '0' is invalid"),
    (['--outlier-sigma', '-8'], "--outlier-sigma '-8' is invalid"),
    (['--outlier-sigma', 'eight'], "--outlier-sigma 'eight' is invalid"),
])
def test_bad_outlier_flags_give_one_line_and_exit_2(
        argv: list[str], named: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / 'h.yaml'
    code = main(['noise', str(BAGS / 'noise_rlg_spikes'), '--out', str(out), *argv])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == '' and not out.exists()
    assert captured.err.count('\n') == 1 and named in captured.err


def test_a_config_file_with_a_misspelt_mode_gives_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = tmp_path / 'noise.yaml'
    config.write_text('outliers: remvoe\n', encoding='utf-8')
    code = main(['noise', str(BAGS / 'noise_rlg_spikes'), '--config', str(config), '--json'])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == '' and captured.err.count('\n') == 1
    assert "outliers" in captured.err and "'keep' or 'remove'" in captured.err


def test_json_of_a_spiky_record_carries_the_report(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(['noise', str(BAGS / 'noise_rlg_spikes'), '--json', '--outlier-sigma', '10'])
    doc = json.loads(capsys.readouterr().out)
    rec = doc['methods']['noise']['axes']['gyro']['outliers']
    assert code == 0 and rec['sigma'] == 10.0 and rec['found'] == 80 and rec['mode'] == 'keep'


@pytest.mark.parametrize('mode, words', [
    ('keep', 'removing them would change ADEV(1 s) -50 %, Q not resolved without them, N -10 %'),
    ('remove', 'keeping them would change ADEV(1 s) +100 %, Q resolved only with them, N +11.1 %'),
])
def test_the_change_reads_from_the_treatment_used_to_the_other(mode: str, words: str) -> None:
    tally = OutlierTally(screened=1000, spikes=2, largest_sigma=40.0, largest_ns=5,
                         first=[(5, 40.0), (9, 20.0)])
    report = OutlierReport('gyro', mode, 8.0, 65536, 'increment', tally, (2.0, 1.0),
                           {'q': (3.0, math.nan), 'n': (1.0, 0.9)}, {'q': 'Q', 'n': 'N'})
    assert report.line().endswith(f'{words}.')
    assert report.record()['terms'] == {
        'q': {'recorded': 3.0, 'removed': None, 'change': None},
        'n': {'recorded': 1.0, 'removed': 0.9, 'change': pytest.approx(-0.1)}}
