#!/usr/bin/env python3
"""Coverage of the RBRLG ±1σ intervals from few pairs and few stations (issue 9, part 4).

    python benchmarks/rbrlg_coverage.py [--runs-k 300] [--runs-theta 300] [--quick]
        [--sections k theta full]

For each case, many seeded simulated benches are calibrated; the fraction of runs whose
|estimate − truth| ≤ the reported standard uncertainty is printed with its binomial standard
error, beside the median dof and the uncertainty basis. Target: 60–75 % for K̃, ω′ₑ + ω_B, θ
and K.

* K̃ and ω′ₑ + ω_B at 2, 3, 5 and 10 pairs: the paper's rate-bias bench (150 °/s, m = 5, ARW
  0.0005 °/√h, 0.1″ index jitter, integer pulses, bias drift), with the gyro's ARW unknown to
  the calibration (the scatter is then widened by its Student-t factor) and known
  (``angle_random_walk_deg_sqrt_h``; the prediction is then complete). The truth is the same
  bench calibrated with every noise source off (so the projection of the Earth rate and the
  drifting bias are what the estimator measures, exactly).
* θ at 4, 8 and 80 stations: the θ procedure with the simulator's default error sources, and
  with the paper's position-table sync error (2″) and axis wobble (0.5″); truth 646.75″.
* K = K̃·cos θ at 2, 3, 5, 10 pairs: the full procedure (10 pairs, then 4 stations).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from gyro_calib.errors import InsufficientDataError  # noqa: E402
from gyro_calib.rbrlg.calibration import calibrate_rbrlg  # noqa: E402
from gyro_calib.rbrlg.calibrator import calibrate_k_tilde  # noqa: E402
from gyro_calib.rbrlg.config import KTildeConfig  # noqa: E402
from gyro_calib.rbrlg.scale_factor import mean_estimate, scale_factor  # noqa: E402
from gyro_calib.rbrlg.stations import calibrate_fix_error_angle  # noqa: E402
from gyro_calib.units import ARCSEC_PER_RAD  # noqa: E402
from sim_nodes.rate_table import RateTableConfig  # noqa: E402
from sim_nodes.rbrlg.bench import (  # noqa: E402
    simulate_full_procedure,
    simulate_rate_bias_bench,
    simulate_theta_procedure,
    true_k_tilde_arcsec_per_pulse,
)
from sim_nodes.rbrlg.procedure import ThetaProcedureConfig  # noqa: E402
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig  # noqa: E402
from sim_nodes.rbrlg.two_axis_gyro import TiltedMountConfig  # noqa: E402

PAIRS = (2, 3, 5, 10)
STATIONS = (4, 8, 80)
ARW_DEG_SQRT_H = 0.0005
CHUNK = 2000


def _k_runs(seed: int) -> dict[str, list[tuple[float, float, int, str]]]:
    """One K̃ bench: per case, (error, std, dof, basis) at each pair count."""
    table = RateTableConfig(duration_s=10 * 29.6 + 5, seed=seed)
    gyro = RingLaserGyroConfig(seed=seed)
    quiet = RingLaserGyroConfig(seed=seed, angle_random_walk_deg_sqrt_h=0.0, quantise=False)
    rec = simulate_rate_bias_bench(table, gyro, chunk_samples=CHUNK)
    ref_rec = simulate_rate_bias_bench(dataclasses.replace(table, zero_index_jitter_arcsec=0.0),
                                       quiet, chunk_samples=CHUNK)
    ref = calibrate_k_tilde(ref_rec.pulse_t_ns, ref_rec.pulse_counts, ref_rec.table_t_ns,
                            ref_rec.table_angle_rad, ref_rec.table_rate_rad_s,
                            ref_rec.zero_index_ns)
    out: dict[str, list[tuple[float, float, int, str]]] = {}
    for known in (False, True):
        cfg = KTildeConfig(angle_random_walk_deg_sqrt_h=ARW_DEG_SQRT_H if known else math.nan)
        cal = calibrate_k_tilde(rec.pulse_t_ns, rec.pulse_counts, rec.table_t_ns,
                                rec.table_angle_rad, rec.table_rate_rad_s, rec.zero_index_ns,
                                cfg)
        tag = 'ARW known' if known else 'ARW unknown'
        for n in PAIRS:
            pairs, ref_pairs = cal.pairs[:n], ref.pairs[:n]
            if len(pairs) < n or len(ref_pairs) < n:
                continue
            complete = all(p.prediction_complete for p in pairs)
            k = mean_estimate([p.k_tilde_arcsec_per_pulse for p in pairs],
                              predicted_std=[p.k_tilde_std for p in pairs],
                              prediction_complete=complete)
            truth_k = true_k_tilde_arcsec_per_pulse(gyro)
            out.setdefault(f'K̃, {tag}, {n} pairs', []).append(
                ((k.value - truth_k) / truth_k, k.relative_uncertainty, k.dof, k.basis))
            eb = mean_estimate([p.earth_plus_bias_deg_h for p in pairs],
                               predicted_std=[p.earth_plus_bias_std for p in pairs],
                               prediction_complete=complete)
            truth_eb = float(np.mean([p.earth_plus_bias_deg_h for p in ref_pairs]))
            out.setdefault(f'ω′ₑ+ω_B, {tag}, {n} pairs', []).append(
                (eb.value - truth_eb, eb.std_uncertainty, eb.dof, eb.basis))
    return out


def _theta_runs(args: tuple[int, int, str]) -> dict[str, list[tuple[float, float, int, str]]]:
    seed, n_stations, sources = args
    gyro = RingLaserGyroConfig(seed=seed, bias_drift_deg_h_per_h=0.0)
    mount = TiltedMountConfig()
    proc = ThetaProcedureConfig(stations_deg=tuple(np.arange(n_stations) * 360.0 / n_stations),
                                seed=seed)
    if sources == 'paper':
        mount = TiltedMountConfig(wobble_arcsec=0.5)
        proc = dataclasses.replace(proc, position_table_index_jitter_arcsec=2.0)
    rec = simulate_theta_procedure(proc, RateTableConfig(seed=seed), gyro, mount,
                                   chunk_samples=CHUNK)
    try:
        res, _ = calibrate_fix_error_angle(
            (rec.pulse_t_ns, rec.pulse_counts), rec.position_table, rec.position_zero_index_ns,
            rec.rate_table, k_tilde_arcsec_per_pulse=true_k_tilde_arcsec_per_pulse(gyro))
    except InsufficientDataError:
        return {}
    th = res.fix_error_angle_rad
    return {f'θ, {sources} sources, {n_stations} stations': [
        (th.value * ARCSEC_PER_RAD - gyro.fix_error_angle_arcsec,
         th.std_uncertainty * ARCSEC_PER_RAD, th.dof, th.basis)]}


def _full_runs(seed: int) -> dict[str, list[tuple[float, float, int, str]]]:
    gyro = RingLaserGyroConfig(seed=seed)
    rec = simulate_full_procedure(ThetaProcedureConfig(seed=seed), RateTableConfig(seed=seed),
                                  gyro, TiltedMountConfig(), k_tilde_pairs=10,
                                  chunk_samples=CHUNK)
    res, cal = calibrate_rbrlg(rec, latitude_deg=gyro.latitude_deg)
    if res.fix_error is None:
        return {}
    pairs = cal.k_tilde.pairs
    out: dict[str, list[tuple[float, float, int, str]]] = {}
    for n in PAIRS:
        if len(pairs) < n:
            continue
        k_tilde = mean_estimate([p.k_tilde_arcsec_per_pulse for p in pairs[:n]],
                                predicted_std=[p.k_tilde_std for p in pairs[:n]],
                                prediction_complete=False)
        k = scale_factor(k_tilde, res.fix_error.fix_error_angle_rad)
        truth = gyro.scale_factor_arcsec_per_pulse
        out[f'K, ARW unknown, {n} pairs, 4 stations'] = [
            ((k.value - truth) / truth, k.std_uncertainty / k.value, k.dof, k.basis)]
    return out


def _merge(into: dict[str, list], part: dict[str, list]) -> None:
    for key, rows in part.items():
        into.setdefault(key, []).extend(rows)


def _report(results: dict[str, list[tuple[float, float, int, str]]]) -> None:
    print(f'{"case":48} {"runs":>5} {"±1σ coverage":>16} {"±2σ":>6} {"dof":>4}  basis (typical)')
    for key in sorted(results):
        rows = results[key]
        err = np.array([r[0] for r in rows])
        std = np.array([r[1] for r in rows])
        cover = float(np.mean(np.abs(err) <= std))
        cover2 = float(np.mean(np.abs(err) <= 2 * std))
        se = math.sqrt(cover * (1 - cover) / len(rows))
        dof = int(np.median([r[2] for r in rows]))
        basis = max(set(r[3].split(' (')[0] for r in rows),
                    key=[r[3].split(' (')[0] for r in rows].count)
        flag = '' if 0.60 <= cover <= 0.75 else '  ← outside 60–75 %'
        print(f'{key:48} {len(rows):5d} {cover * 100:8.1f} ± {se * 100:4.1f} % '
              f'{cover2 * 100:5.1f}% {dof:4d}  {basis}{flag}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--runs-k', type=int, default=300)
    parser.add_argument('--runs-theta', type=int, default=300)
    parser.add_argument('--runs-80', type=int, default=60)
    parser.add_argument('--runs-full', type=int, default=200)
    parser.add_argument('--quick', action='store_true', help='a tenth of the runs')
    parser.add_argument('--workers', type=int, default=os.cpu_count() or 1)
    parser.add_argument('--sections', nargs='+', choices=('k', 'theta', 'full'),
                        default=['k', 'theta', 'full'], help='which sections to run')
    args = parser.parse_args()
    scale = 0.1 if args.quick else 1.0
    runs = {k: max(3, int(getattr(args, k) * scale)) for k in
            ('runs_k', 'runs_theta', 'runs_80', 'runs_full')}
    print(f'rbrlg coverage Monte Carlo on {os.cpu_count()} cores ({args.workers} workers): '
          f'{runs}')
    t0 = time.perf_counter()
    sections = [
        ('k', 'K̃ and ω′ₑ+ω_B', _k_runs, list(range(1000, 1000 + runs['runs_k']))),
        ('theta', 'θ', _theta_runs, [(s, n, src) for src in ('default', 'paper') for n in STATIONS
                            for s in range(2000, 2000 + (runs['runs_80'] if n == 80
                                                         else runs['runs_theta']))]),
        ('full', 'K', _full_runs, list(range(3000, 3000 + runs['runs_full']))),
    ]
    with ProcessPoolExecutor(args.workers) as pool:
        for key, title, job, items in sections:
            if key not in args.sections:
                continue
            results: dict[str, list] = {}
            for part in pool.map(job, items, chunksize=1):
                _merge(results, part)
            print(f'\n== {title} ({time.perf_counter() - t0:.0f} s so far)', flush=True)
            _report(results)
    print(f'({time.perf_counter() - t0:.0f} s)')


if __name__ == '__main__':
    main()
