"""Property: on any FOG bench a user may have, every FOG result covers the truth (issue 16).

The benches come from ``fog_bench_physics`` (the IEEE Std 952 FOG output model and the
closed-loop injection physics written for the tests; nothing from sim_nodes): K, bias,
asymmetry, quadratic and cubic terms, angle random walk, integer counts at 50 Hz–1 kHz, any
latitude (known to the calibration or not) and sense-axis tilt; 2–10 turntable rates of
either sign at 0.5–200 °/s held 6–60 s, the equivalence-mapping rates or not; a ladder of
0–40 injected plateaus of 2–8 s, in any order, up to 0.3–95 % of the largest injection the
loop can balance (an equivalent 0.05–2 rad/s), settling with τ 0.02–0.5 s.

"The truth" of a fitted quantity is what the estimator's documented fit gives on the
bench's noise-free outputs over the same segments and plateaus it used (the IEEE Std 952
line, two-slope and cubic fits; the self-calibration slope over its linear range times the
noise-free equivalence mapping); the angle random walk and the small-signal K are the
generator's own parameters. Each example: every result lies within 4.5 standard
uncertainties of its truth, every missing result has a named reason, the summary prints no
'nan', and nothing raises. Over the examples, ±1σ and ±2σ must cover the truth about as
often as they should: pooled, ≥ 45 % and ≥ 80 % over the CI's 25 examples (the results of
one example share its noise); ``GYRO_CALIB_STRESS=1`` runs 200 examples and requires ±1σ to
cover ≥ 60 % pooled and ±2σ ≥ 85 % of each result with 20 or more values (the ARW is an
interval with a rectangular σ: its ±1σ alone covers about 40 %).
"""

from __future__ import annotations

import math
import os
from collections import defaultdict

import numpy as np
import numpy.typing as npt
from fog_bench_physics import MAPPING_RATES_DEG_S, FogBench, Recording, record
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gyro_calib.fog import FogSettings, calibrate_fog
from gyro_calib.fog.calibrator import (
    KEY_ARW,
    KEY_ASYMMETRY,
    KEY_CUBIC,
    KEY_MAPPING,
    KEY_NONLINEARITY,
    KEY_QUADRATIC,
    KEY_SCALE_FACTOR,
    KEY_SELF_CAL,
    KEY_SELF_CAL_DIFFERENCE,
    KEY_SELF_CAL_NONLINEARITY,
    KEY_SELF_CAL_RANGE,
    KEY_SELF_CAL_SMALL_SIGNAL,
    FogCalibrator,
)
from gyro_calib.fog.self_cal import SelfCalFit
from gyro_calib.fog.turntable import MappingFit, TurntableFit

STRESS = os.environ.get('GYRO_CALIB_STRESS') == '1'
MAX_EXAMPLES = 200 if STRESS else 25
MAX_OUTPUT_SAMPLES = 400_000
"""Output samples per bench (bounds the test's time)."""
Z_LIMIT = 4.5
"""Largest |error|/σ accepted in any one example."""

FloatArray = npt.NDArray[np.float64]


@st.composite
def benches(draw: st.DrawFn) -> tuple[FogBench, bool]:
    n_rates = draw(st.integers(2, 10), label='rates')
    magnitudes = draw(st.lists(st.floats(0.5, 200.0), min_size=n_rates, max_size=n_rates,
                               unique=True), label='rates_deg_s')
    signs = draw(st.lists(st.sampled_from([1.0, -1.0]), min_size=n_rates, max_size=n_rates),
                 label='signs')
    rates = [round(m * s, 3) for m, s in zip(magnitudes, signs)]
    holds = [draw(st.floats(6.0, 60.0), label='hold_s') for _ in rates]
    if draw(st.booleans(), label='mapping'):
        rates += list(MAPPING_RATES_DEG_S)
        holds += [draw(st.floats(10.0, 40.0), label='mapping_hold_s')] * 4
    n_plateaus = draw(st.sampled_from([0, 0, 2, 3, 5, 8, 15, 25, 40]), label='plateaus')
    k = draw(st.floats(2e4, 2e6), label='K')
    # the loop balances injections up to an equivalent rate of 0.05–2 rad/s
    limit = k * draw(st.floats(0.05, 2.0), label='injection_limit_rad_s')
    reach = draw(st.sampled_from([0.003, 0.01, 0.05, 0.3, 0.95]), label='ladder_reach')
    step = reach * limit / max(n_plateaus // 2, 1)
    order = draw(st.sampled_from(['alternating', 'ascending', 'shuffled']), label='order')
    levels = [0.0] + [step * ((i + 1) // 2) * (1 if i % 2 else -1)
                      for i in range(1, n_plateaus)] if n_plateaus else []
    if order == 'ascending':
        levels = sorted(levels)
    elif order == 'shuffled':
        levels = draw(st.permutations(levels), label='shuffled')
    output_hz = draw(st.sampled_from([50.0, 100.0, 200.0, 500.0, 1000.0]), label='output_hz')
    bench = FogBench(
        k_counts_per_rad=k,
        bias_rad_s=draw(st.floats(-1e-4, 1e-4), label='bias_rad_s'),
        asymmetry=draw(st.sampled_from([0.0, 0.0, 1e-4, -3e-4, 1e-3]), label='asymmetry'),
        k2_s_per_rad=draw(st.sampled_from([0.0, 0.0, 2e-4, -1e-4]), label='k2'),
        k3_s2_per_rad2=draw(st.sampled_from([0.0, 0.0, 5e-5, -3e-5]), label='k3'),
        arw_rad_sqrt_s=10 ** draw(st.floats(-7.0, -4.3), label='log10_arw_rad_sqrt_s'),
        latitude_deg=draw(st.floats(-80.0, 80.0), label='latitude_deg'),
        tilt_deg=draw(st.floats(0.0, 0.1), label='tilt_deg'),
        output_hz=output_hz,
        table_hz=draw(st.sampled_from([50.0, 100.0, 200.0]), label='table_hz'),
        rates_deg_s=tuple(rates), holds_s=tuple(holds),
        accel_deg_s2=draw(st.floats(5.0, 200.0), label='accel_deg_s2'),
        mark_deg=draw(st.floats(0.0, 360.0, exclude_max=True), label='mark_deg'),
        ladder_counts_s=tuple(levels),
        plateau_s=draw(st.floats(2.0, 8.0), label='plateau_s'),
        settle_tau_s=draw(st.floats(0.02, 0.5), label='settle_tau_s'),
        injection_gain_error=draw(st.floats(-0.01, 0.01), label='injection_gain_error'),
        injection_limit_counts_s=limit,
        seed=draw(st.integers(0, 2**31 - 1), label='seed'))
    latitude_known = draw(st.booleans(), label='latitude_known')
    return bench, latitude_known


# -- truth: the estimator's documented fits on the noise-free bench ---------------------------
def _ols(design: FloatArray, y: FloatArray) -> FloatArray:
    return np.asarray(np.linalg.lstsq(design, y, rcond=None)[0], dtype=np.float64)


def _line(x: FloatArray) -> FloatArray:
    return np.column_stack((x, np.ones_like(x)))


def _true_rate(rec: Recording, start_ns: int, end_ns: int) -> float:
    """The commanded table rate of the hold a measured segment lies in, rad/s."""
    mid = (start_ns + end_ns) // 2
    for a, b, w in rec.holds:
        if a <= mid <= b:
            return w
    raise AssertionError(f'segment at {mid / 1e9:.1f} s lies in no hold')


def turntable_truth(bench: FogBench, rec: Recording, fit: TurntableFit,
                    latitude_known: bool) -> dict[str, float]:
    w = np.array([_true_rate(rec, s.start_ns, s.end_ns) for s in fit.segments])
    r = bench.output_rate(w + bench.vertical_earth_rad_s)
    k, b = _ols(_line(w), r)
    out = {KEY_SCALE_FACTOR: k, KEY_ARW: bench.arw_rad_sqrt_s}
    res = r - (k * w + b)
    out[KEY_NONLINEARITY] = float(np.max(np.abs(res)) / np.max(np.abs(r)) * 1e6)
    bias = b / k
    if np.any(w > 0) and np.any(w < 0) and fit.asymmetry_ppm is not None:
        p, q, b2 = _ols(np.column_stack((np.maximum(w, 0), np.minimum(w, 0), np.ones_like(w))),
                        r)
        out[KEY_ASYMMETRY] = 2.0 * (p - q) / (p + q) * 1e6
        bias = b2 / k
    if latitude_known:
        bias -= bench.vertical_earth_rad_s
    out['bias'] = bias
    if fit.quadratic_s_per_rad is not None:
        k1, k2, k3, _ = _ols(np.column_stack((w, w**2, w**3, np.ones_like(w))), r)
        out[KEY_QUADRATIC], out[KEY_CUBIC] = k2 / k1, k3 / k1
    return out


def mapping_truth(bench: FogBench, rec: Recording, cal: FogCalibrator,
                  fit: MappingFit) -> float:
    turntable = cal.fits().turntable
    segs = list(turntable.segments) if isinstance(turntable, TurntableFit) else []
    used = [segs[i] for i in fit.segments]
    w = np.array([_true_rate(rec, s.start_ns, s.end_ns) for s in used])
    t = np.array([s.duration_s for s in used])
    r = bench.output_rate(w + bench.vertical_earth_rad_s)
    x = _line(w) * np.sqrt(t)[:, None]
    return float(_ols(x, r * np.sqrt(t))[0])


def self_cal_truth(bench: FogBench, fit: SelfCalFit, k_map: float | None) -> dict[str, float]:
    out: dict[str, float] = {}
    if k_map is None:
        return out
    out[KEY_SELF_CAL_SMALL_SIGNAL] = (1.0 + bench.injection_gain_error) * k_map
    if fit.linear is not None:
        n = fit.linear.plateaus
        j = np.array([p.injection_counts_s for p in fit.plateaus[:n]])
        y = bench.output_rate(bench.vertical_earth_rad_s) + bench.injection_response(j)
        s, c = _ols(_line(j), y)
        out[KEY_SELF_CAL] = s * k_map
        out[KEY_SELF_CAL_RANGE] = float(np.max(np.abs(j))) / abs(k_map)
        res = y - (s * j + c)
        out[KEY_SELF_CAL_NONLINEARITY] = float(np.max(np.abs(res)) / np.max(np.abs(y)) * 1e6)
    return out


# -- the property -------------------------------------------------------------------------------
Z: dict[str, list[float]] = defaultdict(list)
"""|error|/σ per result key over the examples run."""
FAILURES: list[str] = []
"""With COLLECT set (benchmarks/fog_bench_property_count.py), failures are counted here
instead of failing the example."""
COLLECT = False


def check_bench(bench: FogBench, latitude_known: bool) -> list[str]:
    """Calibrate one bench; return the failures (and record every z in Z)."""
    rec = record(bench)
    settings_ = FogSettings(latitude_deg=bench.latitude_deg if latitude_known else math.nan)
    cal = calibrate_fog(rec.output_t_ns, rec.output_counts, injection_t_ns=rec.injection_t_ns,
                        injection_counts_s=rec.injection_counts_s, table_t_ns=rec.table_t_ns,
                        table_angle_rad=rec.table_angle_rad,
                        table_rate_rad_s=rec.table_rate_rad_s, zero_index_ns=rec.zero_index_ns,
                        settings=settings_)
    results, missing, fits = cal.results(), cal.missing(), cal.fits()
    failures: list[str] = []
    truth: dict[str, float] = {}
    if isinstance(fits.turntable, TurntableFit):
        tt = turntable_truth(bench, rec, fits.turntable, latitude_known)
        tt[cal.bias_key] = tt.pop('bias')
        truth.update(tt)
    k_map = None
    if isinstance(fits.mapping, MappingFit):
        k_map = truth[KEY_MAPPING] = mapping_truth(bench, rec, cal, fits.mapping)
    if isinstance(fits.self_cal, SelfCalFit):
        truth.update(self_cal_truth(bench, fits.self_cal, k_map))
        if KEY_SELF_CAL in truth and KEY_SCALE_FACTOR in truth:
            truth[KEY_SELF_CAL_DIFFERENCE] = truth[KEY_SELF_CAL] - truth[KEY_SCALE_FACTOR]
    for key, est in results.items():
        if key not in truth:
            failures.append(f'{key} = {est.value:.6g} reported but the test has no truth')
            continue
        err = est.value - truth[key]
        z = abs(err) / est.std_uncertainty if est.std_uncertainty > 0 else (
            0.0 if err == 0 else math.inf)
        Z[key].append(z)
        if z > Z_LIMIT:
            failures.append(f'{key} = {est.value:.8g} ± {est.std_uncertainty:.3g}, truth '
                            f'{truth[key]:.8g} ({z:.1f} σ)')
    for key, why in missing.items():
        if not why or why == 'not measured.':
            failures.append(f'{key} missing without a named reason ({why!r})')
    for line in cal.summary():
        if 'nan' in line.lower().split():
            failures.append(f'summary line shows nan: {line}')
    return failures


@settings(max_examples=MAX_EXAMPLES, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(benches())
def _every_result_covers_the_truth(case: tuple[FogBench, bool]) -> None:
    bench, latitude_known = case
    n_out = sum(bench.holds_s) * bench.output_hz + len(bench.ladder_counts_s) * \
        bench.plateau_s * bench.output_hz
    if n_out > MAX_OUTPUT_SAMPLES:  # shorten the holds: the bench stays the same otherwise
        scale = MAX_OUTPUT_SAMPLES / n_out
        bench = FogBench(**{**bench.__dict__, 'holds_s': tuple(max(6.0, h * scale)
                                                               for h in bench.holds_s)})
    try:
        failures = check_bench(bench, latitude_known)
    except Exception as exc:  # noqa: BLE001 - counted, then re-raised
        failures = [f'raised {type(exc).__name__}: {exc}']
        if not COLLECT:
            raise
    if COLLECT:
        FAILURES.extend(f'{bench}: {f}' for f in failures)
        return
    assert not failures, '\n'.join(failures)


def test_fog_results_cover_the_generators_truth_on_any_bench() -> None:
    Z.clear()
    _every_result_covers_the_truth()
    all_z = np.concatenate([np.asarray(v) for v in Z.values()])
    within1, within2 = np.mean(all_z <= 1.0), np.mean(all_z <= 2.0)
    per_key = {k: (float(np.mean(np.asarray(v) <= 1)), float(np.mean(np.asarray(v) <= 2)),
                   len(v)) for k, v in Z.items()}
    # the results of one example share its noise: over a dozen examples the pooled coverage
    # is itself uncertain by several per cent; the stress run checks each result on its own
    assert within1 >= 0.45 and within2 >= 0.80, (within1, within2, per_key)
    if STRESS:  # pooled ±1σ, and ±2σ of every result with 20 or more values
        short = {k: c for k, c in per_key.items() if c[2] >= 20 and c[1] < 0.85}
        assert within1 >= 0.6 and not short, (within1, short)


def test_two_rates_and_two_plateaus_give_no_nonlinearity_but_say_why() -> None:
    """Two rates and two plateaus give no nonlinearity.

    A line through two rates (or two injection levels) leaves no residual: the
    nonlinearity is not measurable, and the summary says so instead of 'nan ppm'.
    """
    bench = FogBench(k_counts_per_rad=44277.0, bias_rad_s=1e-6, asymmetry=0.0,
                     k2_s_per_rad=0.0, k3_s2_per_rad2=0.0, arw_rad_sqrt_s=1.5e-6,
                     latitude_deg=45.0, tilt_deg=0.0, output_hz=200.0, table_hz=100.0,
                     rates_deg_s=(10.0, -10.0), holds_s=(20.0, 20.0), accel_deg_s2=20.0,
                     mark_deg=37.0, ladder_counts_s=(300.0, -300.0), plateau_s=4.0,
                     settle_tau_s=0.05, injection_limit_counts_s=1e5, seed=4)
    rec = record(bench)
    cal = calibrate_fog(rec.output_t_ns, rec.output_counts, injection_t_ns=rec.injection_t_ns,
                        injection_counts_s=rec.injection_counts_s, table_t_ns=rec.table_t_ns,
                        table_angle_rad=rec.table_angle_rad,
                        table_rate_rad_s=rec.table_rate_rad_s, zero_index_ns=rec.zero_index_ns,
                        settings=FogSettings(latitude_deg=45.0, min_turntable_rates=2))
    assert KEY_SCALE_FACTOR in cal.results() and KEY_NONLINEARITY not in cal.results()
    assert 'not measurable from 2 distinct rates' in cal.missing()[KEY_NONLINEARITY]
    summary = '\n'.join(cal.summary())
    assert 'nan' not in summary.lower().split() and 'nan ppm' not in summary
    assert 'nonlinearity not measurable from 2 plateaus' in summary


def test_a_loop_settling_unseen_in_each_plateau_is_found_over_the_ladder() -> None:
    """A loop settling unseen in each plateau is found over all.

    A noisy output (20 counts/√s) and a loop settling with τ = 0.25 s on 2.8 s plateaus of
    ±41…830 counts/s: no single plateau shows its transient, but over the alternating ladder
    the first halves lag; measured over their second halves the small-signal K covers the
    truth (it was 13 % low, 3.5 σ, with the transients in).
    """
    step = 41.480897728718084
    levels = (0.0,) + tuple(step * ((i + 1) // 2) * (1 if i % 2 else -1) for i in range(1, 40))
    bench = FogBench(
        k_counts_per_rad=1296000.0, bias_rad_s=-6.838658771128116e-05, asymmetry=0.001,
        k2_s_per_rad=-0.0001, k3_s2_per_rad2=-3e-05, arw_rad_sqrt_s=1.5965828388891124e-05,
        latitude_deg=3.042801306208162, tilt_deg=0.006147010629700024, output_hz=500.0,
        table_hz=50.0,
        rates_deg_s=(-92.12, 6.281, -199.0, 129.836, -124.253, -192.356, -192.496, -53.191,
                     188.863, 121.501) + MAPPING_RATES_DEG_S,
        holds_s=(51.93346259711671, 29.754233649589512, 50.29517309774146, 14.354691557691003,
                 60.0, 22.61368338054193, 15.382746783422894, 30.0, 36.921580125620395,
                 51.98734609048911) + (30.36355633060026,) * 4,
        accel_deg_s2=131.994254758958, mark_deg=0.0, ladder_counts_s=levels,
        plateau_s=2.8105071503215155, settle_tau_s=0.2516109638442696,
        injection_limit_counts_s=18340.712781969756, seed=168)
    Z.clear()
    assert not check_bench(bench, latitude_known=True)
    assert Z[KEY_SELF_CAL_SMALL_SIGNAL][0] < 2.0
    rec = record(bench)
    cal = calibrate_fog(rec.output_t_ns, rec.output_counts, injection_t_ns=rec.injection_t_ns,
                        injection_counts_s=rec.injection_counts_s, table_t_ns=rec.table_t_ns,
                        table_angle_rad=rec.table_angle_rad,
                        table_rate_rad_s=rec.table_rate_rad_s, zero_index_ns=rec.zero_index_ns,
                        settings=FogSettings(latitude_deg=bench.latitude_deg))
    assert any('still settling in the first halves' in line for line in cal.summary())
