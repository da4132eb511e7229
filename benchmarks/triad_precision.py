"""Precision of the triad's K_i and sense-axis directions on the two-axis bench (METHODS §F).

Run (from the repository root):

    PYTHONPATH=$PWD /work/main/.venv/bin/python benchmarks/triad_precision.py          # ~5 min
    PYTHONPATH=$PWD /work/main/.venv/bin/python benchmarks/triad_precision.py --quick  # seconds

The triad: three gyros with K = 0.8428″/pulse (the paper's RLG), sense axes tilted a few mrad
from the body axes (z along the rate-table axis), bias 0.005 °/h. The bench: tilt α = 45°,
both tables at 150 °/s, stations at β₀ + k·360°/S, n position-table turns each way per station,
P K̃ pairs of m = 5 turns on the inner axis. Error sources: whole-pulse quantisation with a
random phase (±0.5 pulse at each window end), zero-index jitter σ_I = 0.1″ at each window end
(the swept angle is taken as nominal, as the paper does), optional ARW.

Part 1 — what the uncertainty model predicts (no Monte Carlo): u(K)/K of the gyro along the
rate-table axis (z) and of the other two (x, y), and the rms direction uncertainty √trace C(s)
of each, for the paper bench (S = 4, n = 1) and P K̃ pairs, with the tilt α (a) exact, (b) a
stated bench setting ± 0.5″ (propagated systematic), (c) fitted from the data (prior ± 60″).
Targets (issue 26): |ΔK/K| ≤ 2e-8 (z), ≤ 1e-7 (x, y), direction ≤ 0.5″.

Part 2 — Monte Carlo per station count S and revolutions n (P = 10, α fitted): over R runs,
the std of ΔK/K per gyro and the rms direction error (″), beside the mean predicted value,
and the fraction of K_i and misalignment components inside ±1σ (coverage).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from gyro_calib.triad.estimator import BenchParameter, TriadPair, triad_calibration
from gyro_calib.triad.kinematics import (
    EARTH_RATE_RAD_S,
    STATION_OFFSET,
    TILT,
    inner_axis_direction,
    outer_axis_direction,
    pair_from_windows,
)

ARCSEC = math.pi / 648000
RATE = math.radians(150.0)
K = 0.8428 * ARCSEC
LAT = math.radians(34.0)


def axes(rng: np.random.Generator) -> np.ndarray:
    a = np.eye(3) + rng.uniform(-5e-3, 5e-3, (3, 3)) * (1 - np.eye(3))
    return np.asarray(a / np.linalg.norm(a, axis=1)[:, None], dtype=np.float64)


def window(rng: np.random.Generator, s: np.ndarray, u: np.ndarray, turns: int, sign: int,
           omega_u: float, jitter: float, arw: float, noise_free: bool) -> np.ndarray:
    """Counts of all channels over one whole-turn window (Earth rate along u averaged)."""
    a = 2 * math.pi * turns
    if not noise_free:
        a += jitter * (rng.standard_normal() - rng.standard_normal())
    t = a / RATE
    c = (sign * a * (s @ u) + (s @ u) * omega_u * t + 0.005 * ARCSEC * t) / K
    if noise_free:
        return np.asarray(c)
    c = c + arw * math.sqrt(t) / K * rng.standard_normal(3)
    start = rng.uniform(0, 1, 3)
    return np.asarray(np.floor(start + c) - np.floor(start), dtype=np.float64)


def run(rng: np.random.Generator, truth: np.ndarray, *, stations: int, turns: int,
        k_pairs: int, tilt: str, jitter: float = 0.1 * ARCSEC, arw: float = 0.0,
        noise_free: bool = False) -> tuple[object, list[TriadPair]]:
    alpha = math.radians(45.0)
    t_inner, t_outer = 2 * math.pi * 5 / RATE, 2 * math.pi * turns / RATE
    var_inner = 1 / 6 + arw**2 * t_inner / K**2  # ARW over each window's own length (6b)
    var_outer = 1 / 6 + arw**2 * t_outer / K**2
    pairs = []
    specs = [(inner_axis_direction(), np.zeros((3, 2)), 5, EARTH_RATE_RAD_S * 0.6)] * k_pairs
    offset = rng.uniform(0, 2 * math.pi)
    for j in range(stations):
        u, d = outer_axis_direction(offset + 2 * math.pi * j / stations, alpha)
        specs.append((u, d, turns, EARTH_RATE_RAD_S * math.sin(LAT)))
    for u, d, m, om in specs:
        n_p = window(rng, truth, u, m, +1, om, jitter, arw, noise_free)
        n_m = window(rng, truth, u, m, -1, om, jitter, arw, noise_free)
        a = 2 * math.pi * m
        pairs.append(pair_from_windows(
            u, forward_counts=n_p, reverse_counts=n_m,
            counts_std=np.full(3, math.sqrt(var_inner if not d.any() else var_outer)),
            forward_angle_rad=a, reverse_angle_rad=a,
            forward_s=a / RATE, reverse_s=a / RATE, angle_std_rad=math.sqrt(2) * jitter,
            earth_rate_along_u_rad_s=om, direction_sensitivity=d))
    params = {'exact': [BenchParameter(TILT, 0.0), BenchParameter(STATION_OFFSET, 0.0)],
              'stated': [BenchParameter(TILT, 0.5 * ARCSEC), BenchParameter(STATION_OFFSET, 0.0)],
              'fitted': [BenchParameter(TILT, 60 * ARCSEC, True),
                         BenchParameter(STATION_OFFSET, 0.0)]}[tilt]
    return triad_calibration(pairs, parameters=params), pairs


def predicted(res: object) -> tuple[np.ndarray, np.ndarray]:
    """u(K)/K and √trace C(s) (″) per channel."""
    chans = res.channels  # type: ignore[attr-defined]
    rel = np.array([c.scale_factor_rad_per_pulse.relative_uncertainty for c in chans])
    ang = np.array([math.sqrt(np.trace(c.sense_axis_covariance)) / ARCSEC for c in chans])
    return rel, ang


def part1(k_pair_counts: list[int]) -> None:
    print('Part 1 — predicted by the uncertainty model, paper bench (S = 4 stations, n = 1, '
          'm = 5, σ_I = 0.1″, quantisation)')
    print(f'{"K̃ pairs":>8} {"tilt α":>14} {"u(Kz)/Kz":>10} {"u(Kx)/Kx":>10} {"u(Ky)/Ky":>10} '
          f'{"u(s_z)″":>8} {"u(s_x)″":>8} {"u(s_y)″":>8}  targets 2e-8 / 1e-7 / 0.5″')
    rng = np.random.default_rng(0)
    truth = axes(rng)
    for p in k_pair_counts:
        for tilt in ('exact', 'stated ±0.5″', 'fitted ±60″'):
            res, _ = run(rng, truth, stations=4, turns=1, k_pairs=p, tilt=tilt.split()[0],
                         noise_free=True)
            rel, ang = predicted(res)
            ok = rel[2] <= 2e-8 and max(rel[:2]) <= 1e-7 and max(ang) <= 0.5
            print(f'{p:>8} {tilt:>14} {rel[2]:10.2e} {rel[0]:10.2e} {rel[1]:10.2e} '
                  f'{ang[2]:8.3f} {ang[0]:8.3f} {ang[1]:8.3f}  {"met" if ok else "NOT met"}')


def part2(runs: int, station_counts: list[int], turn_counts: list[int], arw: float = 0.0,
          k_pairs: int = 10) -> None:
    print(f'\nPart 2 — Monte Carlo, {runs} runs each (K̃ pairs P = {k_pairs}, α fitted ±60″ '
          f'prior, σ_I = 0.1″, quantisation, ARW {math.degrees(arw) * 60:g} °/√h): std over '
          'runs | mean predicted; last: 95th percentile of max(|ΔK_x|, |ΔK_y|)/K')
    print(f'{"S":>3} {"n":>3} {"ΔKz/Kz":>17} {"ΔKx/Kx":>17} {"ΔKy/Ky":>17} '
          f'{"dir z ″":>13} {"dir x ″":>13} {"dir y ″":>13} {"cover":>6}')
    for s in station_counts:
        for n in turn_counts:
            rng = np.random.default_rng(1000 * s + n)
            truth = axes(rng)
            err_k, err_d, pred_k, pred_d, cover = [], [], [], [], []
            for _ in range(runs):
                res, _ = run(rng, truth, stations=s, turns=n, k_pairs=k_pairs, tilt='fitted',
                             arw=arw)
                rel, ang = predicted(res)
                pred_k.append(rel)
                pred_d.append(ang)
                ek, ed = np.empty(3), np.empty(3)
                for i, ch in enumerate(res.channels):  # type: ignore[attr-defined]
                    k = ch.scale_factor_rad_per_pulse
                    ek[i] = k.value / K - 1
                    cover.append(abs(k.value - K) <= k.std_uncertainty)
                    sv = np.array([e.value for e in ch.sense_axis])
                    ed[i] = math.atan2(np.linalg.norm(np.cross(sv, truth[i])), sv @ truth[i])
                    cover += [abs(ch.sense_axis[j].value - truth[i, j])
                              <= ch.sense_axis[j].std_uncertainty for j in range(3) if j != i]
                err_k.append(ek)
                err_d.append(ed / ARCSEC)
            sk = np.std(err_k, axis=0)
            rd = np.sqrt(np.mean(np.square(err_d), axis=0))
            pk, pd = np.mean(pred_k, axis=0), np.mean(pred_d, axis=0)
            cols = [f'{sk[i]:8.2e}|{pk[i]:8.2e}' for i in (2, 0, 1)]
            cols += [f'{rd[i]:6.3f}|{pd[i]:6.3f}' for i in (2, 0, 1)]
            p95 = float(np.percentile(np.max(np.abs(np.array(err_k)[:, :2]), axis=1), 95))
            print(f'{s:>3} {n:>3} ' + ' '.join(f'{c:>17}' for c in cols[:3]) + ' '
                  + ' '.join(f'{c:>13}' for c in cols[3:]) + f' {np.mean(cover):6.3f}'
                  + f' {p95:8.2e}{" ≤ 1e-7" if p95 <= 1e-7 else ""}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='a few runs, smoke version')
    parser.add_argument('--runs', type=int, default=200, help='Monte Carlo runs per row')
    parser.add_argument('--arw', type=float, default=0.0, help='ARW of each gyro, °/√h')
    parser.add_argument('--k-pairs', type=int, default=10, help='K̃ (inner) pairs P')
    parser.add_argument('--part2-only', action='store_true')
    args = parser.parse_args()
    start = time.perf_counter()
    arw = math.radians(args.arw) / 60.0
    if not args.part2_only:
        part1([1, 4, 10, 30] if not args.quick else [10])
    if args.quick:
        part2(20, [4], [1], arw, args.k_pairs)
    else:
        part2(args.runs, [3, 4, 6, 8], [1, 2, 5], arw, args.k_pairs)
    print(f'\n{time.perf_counter() - start:.1f} s')


if __name__ == '__main__':
    main()
