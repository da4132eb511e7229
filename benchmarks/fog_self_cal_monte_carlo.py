"""FOG self-calibration against the simulator's truth: mapping, linear-range K, small signal.

Monte Carlo over seeds of the seed 001 procedure (sim_nodes.fog scenario b: the mapping
at 20, 20.01, 20.1, 21 °/s on the turntable, then the paper's 55-plateau ladder on a static
base, the front end fitted to Table 1). For each run:

- the mapping K_map against its truth (local turntable slope at the mapping rates);
- the self-calibrated K over the linear range found, against (a) the simulator's K over
  the same plateaus (what the estimator claims to measure: coverage) and (b) the
  small-signal truth (slope at zero injection × mapping): the curvature bias inside the
  linear range, in ppm;
- the zero-amplitude K (cubic confirmed by a quintic) against the small-signal truth;
- the linear range found, the self-cal − turntable difference and its significance;
- K over 55 … 6 plateaus (mean over runs) beside the paper's Table 1.

    python benchmarks/fog_self_cal_monte_carlo.py [--quick] [--runs N]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from gyro_calib.fog import FogSettings, calibrate_fog
from gyro_calib.fog.calibrator import (
    KEY_MAPPING,
    KEY_SELF_CAL,
    KEY_SELF_CAL_DIFFERENCE,
    KEY_SELF_CAL_SMALL_SIGNAL,
)
from sim_nodes.fog import FogConfig, SelfCalLadder, TableSettings, simulate_mapping_and_self_cal
from sim_nodes.fog.paper import PAPER_LAB_K, PAPER_TABLE1


def main() -> None:
    """Run the Monte Carlo and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer runs, 200 Hz, 4 s plateaus')
    parser.add_argument('--runs', type=int, default=0)
    args = parser.parse_args()
    runs = args.runs or (6 if args.quick else 20)
    output_hz = 200.0 if args.quick else 1000.0
    plateau_s = 4.0 if args.quick else 10.0
    ladder = SelfCalLadder(plateau_s=plateau_s, end_with_zero=False)
    settings = FogSettings()
    print(f'FOG self-calibration Monte Carlo: {runs} runs, 55 plateaus of {plateau_s:g} s, '
          f'mapping 4 × 60 s, output {output_hz:g} Hz; {os.cpu_count()} cores')
    z_map, z_lin, z_small, bias_lin_ppm, bias_small_ppm, ranges, sig = [], [], [], [], [], [], []
    diff_ppm, tables, n_rejected = [], [], []
    t0 = time.perf_counter()
    for seed in range(runs):
        rec = simulate_mapping_and_self_cal(
            FogConfig(seed=300 + seed), ladder=ladder,
            table=TableSettings(output_rate_hz=output_hz, seed=400 + seed))
        cal = calibrate_fog(rec.output_t_ns, rec.output_counts,
                            injection_t_ns=rec.injection_t_ns,
                            injection_counts_s=rec.injection_counts_s,
                            table_t_ns=rec.table_t_ns, table_angle_rad=rec.table_angle_rad,
                            table_rate_rad_s=rec.table_rate_rad_s,
                            zero_index_ns=rec.zero_index_ns, settings=settings)
        res, fit = cal.results(), cal.fits().self_cal
        truth_n = dict(rec.self_cal_truth)
        small = rec.truth['self_cal_small_signal_k_counts_per_rad']
        k_map = res[KEY_MAPPING]
        z_map.append((k_map.value - rec.truth['mapping_counts_per_rad']) / k_map.std_uncertainty)
        k = res[KEY_SELF_CAL]
        n = fit.linear.plateaus
        ranges.append(n)
        z_lin.append((k.value - truth_n[n]) / k.std_uncertainty)
        bias_lin_ppm.append((k.value / small - 1) * 1e6)
        if KEY_SELF_CAL_SMALL_SIGNAL in res:
            k0 = res[KEY_SELF_CAL_SMALL_SIGNAL]
            z_small.append((k0.value - small) / k0.std_uncertainty)
            bias_small_ppm.append((k0.value / small - 1) * 1e6)
        d = res[KEY_SELF_CAL_DIFFERENCE]
        diff_ppm.append(d.value / rec.truth['turntable_k_counts_per_rad'] * 1e6)
        sig.append(fit.significance_sigma)
        rows = {r.plateaus: r.scale_factor.value for r in fit.table}
        tables.append([rows.get(m, np.nan) / rec.truth['turntable_k_counts_per_rad']
                       for m, _ in PAPER_TABLE1])
        rejected = [r.reason for r in cal.rejections if r.reason.startswith('plateau')]
        for reason in rejected:
            print(f'  run {seed}: {reason}')
        n_rejected.append(len(rejected))
    elapsed = time.perf_counter() - t0

    def cover(z: list[float]) -> str:
        a = np.abs(np.array(z))
        return (f'{np.mean(a <= 1) * 100:.0f} % within 1σ̂, {np.mean(a <= 2) * 100:.0f} % within '
                f'2σ̂, std(z) {np.std(z, ddof=1):.2f}')

    print(f'mapping K_map vs truth: {cover(z_map)}')
    print(f'linear range found: {sorted(set(ranges))} plateaus (counts {np.bincount(ranges)[3:]})')
    print(f'self-cal K over the linear range vs simulator K over the same plateaus: '
          f'{cover(z_lin)}')
    print(f'self-cal K over the linear range vs small-signal truth: bias '
          f'{np.mean(bias_lin_ppm):+.0f} ± {np.std(bias_lin_ppm):.0f} ppm (curvature inside the '
          f'range: the linear-range K is an LS slope, not the slope at zero)')
    if z_small:
        print(f'zero-amplitude K vs small-signal truth ({len(z_small)} runs): bias '
              f'{np.mean(bias_small_ppm):+.0f} ± {np.std(bias_small_ppm):.0f} ppm; '
              f'{cover(z_small)}')
    print(f'self-cal − turntable K: {np.mean(diff_ppm):+.0f} ± {np.std(diff_ppm):.0f} ppm '
          f'(injection gain error {FogConfig().injection_gain_error * 1e6:.0f} ppm + curvature), '
          f'significance {np.min(sig):.0f}–{np.max(sig):.0f} σ')
    mean_table = np.nanmean(tables, axis=0)
    print(f'plateaus rejected: {sum(n_rejected)} of {55 * runs}')
    print('plateaus  paper K/K_lab   simulated K/K_turntable (mean over runs)')
    for (m, k_paper), ratio in zip(PAPER_TABLE1, mean_table):
        print(f'{m:8d}  {k_paper / PAPER_LAB_K:13.5f}   {ratio:13.5f}  '
              f'({(ratio / (k_paper / PAPER_LAB_K) - 1) * 100:+.2f} %)')
    print(f'{elapsed:.0f} s for {runs} runs')


if __name__ == '__main__':
    main()
