"""FOG turntable scale factor: precision against the ARW + quantisation floor, and coverage.

Monte Carlo over seeds of the IEEE Std 952 multi-rate scenario (sim_nodes.fog). For each
run the calibrator's K, its stated standard uncertainty and the segments it used are
kept. The floor is predicted from the simulator's true angle random walk and the output
quantisation for the spans the calibrator actually measured:

    var(R_i) = N_c²/T_i + (q_a² + q_b²)/T_i²,   q² = (1/12)/looks,

(q: the quantisation left in a local-fit end count, one look per count transition in its
window, at most one per sample), propagated to K through the least-squares operator.
Prints measured std / predicted floor (target ≤ 1.2), the bias, and how often K ± σ̂
(and ± 2σ̂) covers the truth (targets ~68 % and ~95 %).

    python benchmarks/fog_turntable_monte_carlo.py [--quick] [--runs N]
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

from gyro_calib.fog import FogSettings, calibrate_fog
from gyro_calib.fog.calibrator import KEY_ARW, KEY_SCALE_FACTOR
from gyro_calib.fog.fits import line_design, weighted_least_squares
from sim_nodes.fog import FogConfig, TableSettings, simulate_turntable
from sim_nodes.fog.scenarios import IEEE_RATES_DEG_S


def predicted_floor(segments: list, settings: FogSettings, cfg: FogConfig,
                    output_hz: float) -> float:
    """Standard deviation of K from ARW and output quantisation for these segments."""
    k = cfg.scale_factor_counts_per_rad
    n_c2 = (cfg.angle_random_walk_rad_sqrt_s * k) ** 2
    var = []
    for s in segments:
        rate = abs(s.output_rate_counts_s)
        h = settings.fit_half_width_s
        if rate * 2 * h < settings.min_fit_transitions:
            h = min(settings.max_fit_half_width_s,
                    h * settings.min_fit_transitions / max(rate * 2 * h, 1.0))
        looks = min(2 * h * output_hz, 1.0 + rate * 2 * h)
        q2 = 1.0 / (12.0 * looks)
        var.append(n_c2 / s.duration_s + 2 * q2 / s.duration_s**2)
    w = np.array([s.rate_rad_s for s in segments])
    fit = weighted_least_squares(line_design(w), np.zeros(len(w)), np.ones(len(w)),
                                 np.array(var))
    return fit.std(0)


def main() -> None:
    """Run the Monte Carlo and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer, shorter runs at 200 Hz')
    parser.add_argument('--runs', type=int, default=0)
    args = parser.parse_args()
    runs = args.runs or (12 if args.quick else 40)
    hold = 20.0 if args.quick else 60.0
    output_hz = 200.0 if args.quick else 1000.0
    settings = FogSettings(latitude_deg=FogConfig().latitude_deg)
    print(f'FOG turntable Monte Carlo: {runs} runs, rates {IEEE_RATES_DEG_S} °/s, '
          f'hold {hold:g} s, '
          f'output {output_hz:g} Hz; {os.cpu_count()} cores')
    z, rel_err, ratio_arw, sigmas, floors = [], [], [], [], []
    truth = None
    t0 = time.perf_counter()
    for seed in range(runs):
        cfg = FogConfig(seed=100 + seed)
        table = TableSettings(output_rate_hz=output_hz, seed=200 + seed)
        rec = simulate_turntable(cfg, hold_s=hold, table=table)
        cal = calibrate_fog(rec.output_t_ns, rec.output_counts, table_t_ns=rec.table_t_ns,
                            table_angle_rad=rec.table_angle_rad,
                            table_rate_rad_s=rec.table_rate_rad_s,
                            zero_index_ns=rec.zero_index_ns, settings=settings)
        res = cal.results()
        k = res[KEY_SCALE_FACTOR]
        truth = rec.truth['turntable_k_counts_per_rad']
        z.append((k.value - truth) / k.std_uncertainty)
        rel_err.append(k.value / truth - 1.0)
        sigmas.append(k.std_uncertainty)
        floors.append(predicted_floor(cal.active_segments, settings, cfg, output_hz))
        ratio_arw.append(res[KEY_ARW].value / cfg.angle_random_walk_rad_sqrt_s)
    elapsed = time.perf_counter() - t0
    err = np.array(rel_err) * truth
    floor = float(np.mean(floors))
    measured = float(np.std(err, ddof=1))
    zz = np.array(z)
    print(f'K truth {truth:.6f} counts/rad; predicted floor σ_K = {floor:.3e} counts/rad '
          f'({floor / truth:.2e} relative)')
    print(f'measured std of K over runs   = {measured:.3e} counts/rad '
          f'(± {measured / math.sqrt(2 * (runs - 1)):.1e}); measured/predicted = '
          f'{measured / floor:.3f}  (target ≤ 1.2)')
    print(f'mean stated σ̂ = {np.mean(sigmas):.3e}; stated/predicted = '
          f'{np.mean(sigmas) / floor:.3f}')
    print(f'bias: mean(K − truth) = {np.mean(err):+.2e} ± {measured / math.sqrt(runs):.1e} '
          f'counts/rad ({np.mean(err) / truth:+.2e} relative)')
    print(f'coverage: |K − truth| ≤ σ̂ in {np.mean(np.abs(zz) <= 1) * 100:.0f} % of runs '
          f'(~68 % expected), ≤ 2σ̂ in {np.mean(np.abs(zz) <= 2) * 100:.0f} % (~95 %); '
          f'std of z = {np.std(zz, ddof=1):.2f}')
    print(f'ARW estimate / truth: mean {np.mean(ratio_arw):.3f}, std {np.std(ratio_arw):.3f}')
    print(f'{elapsed:.0f} s for {runs} runs')


if __name__ == '__main__':
    main()
