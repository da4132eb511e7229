"""Monte Carlo: do the noise-term uncertainties cover the truth as often as they claim?

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/noise_terms_coverage.py [--quick] [--seeds 100] [--jobs 1]

Each scenario is simulated with many seeds (``sim_nodes.noise``) and analysed by the full
pipeline (:func:`gyro_calib.noise.calibrate_noise`: streaming Allan sums, joint fit). For
every true term: how often it is reported, and of those reports how often the truth lies
within ±1σ (claim 68.3 %) and ±2σ (claim 95.4 %); the mean of (estimate − truth)/σ; and,
in θ = coefficient² (what is fitted), the empirical spread of the fitted θ over seeds
against the median claimed σ(θ). For absent terms: how often one is reported anyway.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

KEYS = ('quantization_noise_rad', 'angle_random_walk_rad_per_sqrt_s', 'bias_instability_rad_s',
        'rate_random_walk_rad_per_s_sqrt_s', 'rate_ramp_rad_per_s2')
SCENARIOS = {
    # name: (terms Q, N, B, K, R; sample rate Hz; samples; source)
    'N+B+K, 1 Hz, 33 h (each term its decade)': ((0, 3.6e-5, 1e-5, 4.7e-7, 0), 1.0, 120_000,
                                                 'fog'),
    'N+B+K, 100 Hz, 1 h (IMU-like; K unresolved)': ((0, 2e-4, 3e-5, 3e-6, 0), 100.0, 360_000,
                                                    'fog'),
    'N+K, 10 Hz, 17 min': ((0, 1e-4, 0, 1e-5, 0), 10.0, 10_000, 'fog'),
    'N+R, 5 Hz, 5.6 h': ((0, 1e-4, 0, 0, 2e-8), 5.0, 100_000, 'fog'),
    'Q+N, RLG pulses, stripped dither, 100 Hz': ((1e-5 / math.sqrt(12), 5e-5, 0, 0, 0), 100.0,
                                                  50_000, 'rlg'),
}


def one_run(args: tuple[str, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(reported mask, value, std, θ, σθ) arrays over the five terms for one seed."""
    from gyro_calib.noise import NoiseSettings, calibrate_noise
    from sim_nodes.noise import AxisNoise, NoiseTerms, RlgPulseGenerator

    name, seed = args
    (q, n, b, k, r), rate_hz, count, source = SCENARIOS[name]
    if source == 'rlg':
        rlg = RlgPulseGenerator(NoiseTerms(random_walk=n), scale_factor_rad_per_pulse=1e-5,
                                sample_rate_hz=rate_hz, dither_amplitude_rad=5e-4, seed=seed)
        cal = calibrate_noise(pulses=rlg.chunk(count),
                              settings=NoiseSettings(scale_factor_rad_per_pulse=1e-5))
    else:
        axis = AxisNoise(NoiseTerms(q, n, b, k, r), rate_hz, seed)
        tau0 = 1.0 / rate_hz
        angle = np.concatenate(([0.0], np.cumsum(axis.samples(count)) * tau0))
        t = np.arange(count + 1, dtype=np.int64) * round(tau0 * 1e9)
        cal = calibrate_noise(fog_output=(t, angle),
                              settings=NoiseSettings(fog_scale_factor_counts_per_rad=1.0))
    res = cal.axis_result('gyro')
    assert res.fit is not None
    reported = np.array([key in res.fit.estimates for key in KEYS])
    value = np.array([res.fit.estimates[k].value if k in res.fit.estimates else np.nan
                      for k in KEYS])
    std = np.array([res.fit.estimates[k].std_uncertainty if k in res.fit.estimates else np.nan
                    for k in KEYS])
    theta = res.fit.theta.copy()
    sigma = np.sqrt(np.clip(np.diag(res.fit.theta_cov), 0, None))
    return reported, value, std, np.vstack((theta, sigma))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seeds', type=int, default=100)
    parser.add_argument('--quick', action='store_true', help='20 seeds')
    parser.add_argument('--jobs', type=int, default=1)
    args = parser.parse_args()
    seeds = 20 if args.quick else args.seeds
    print(f'noise-term coverage Monte Carlo on {os.cpu_count()} cores, {args.jobs} worker(s), '
          f'{seeds} seeds per scenario')
    with ProcessPoolExecutor(args.jobs) as pool:
        for name, ((q, n, b, k, r), rate_hz, count, _) in SCENARIOS.items():
            t0 = time.perf_counter()
            runs = list(pool.map(one_run, [(name, 1000 + s) for s in range(seeds)]))
            truth = np.array([q, n, b, k, r])
            reported = np.array([x[0] for x in runs])
            value = np.array([x[1] for x in runs])
            std = np.array([x[2] for x in runs])
            theta = np.array([x[3][0] for x in runs])
            sigma = np.array([x[3][1] for x in runs])
            print(f'\n{name}: {count} samples at {rate_hz:g} Hz '
                  f'({time.perf_counter() - t0:.0f} s)')
            print(f'  {"term":36s} {"reported":>8s} {"±1σ":>6s} {"±2σ":>6s} {"mean z":>7s} '
                  f'{"θ sd emp.":>10s} {"claimed":>8s}')
            for j, key in enumerate(KEYS):
                rep = reported[:, j]
                if truth[j] == 0:
                    if rep.any():
                        print(f'  {key:36s} {rep.mean():8.0%}  reported though absent '
                              f'(false positives)')
                    continue
                z = (value[rep, j] - truth[j]) / std[rep, j]
                in_model = sigma[:, j] > 0
                emp = np.std(theta[in_model, j]) / truth[j] ** 2 if in_model.any() else np.nan
                claimed = (np.median(sigma[in_model, j]) / truth[j] ** 2
                           if in_model.any() else np.nan)
                c1 = np.mean(np.abs(z) < 1) if len(z) else np.nan
                c2 = np.mean(np.abs(z) < 2) if len(z) else np.nan
                mz = np.mean(z) if len(z) else np.nan
                print(f'  {key:36s} {rep.mean():8.0%} {c1:6.0%} {c2:6.0%} {mz:+7.2f} '
                      f'{emp:10.3g} {claimed:8.3g}')


if __name__ == '__main__':
    main()
