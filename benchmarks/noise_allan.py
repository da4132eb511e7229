"""Allan deviation of a day at 1 kHz: speed and memory against allantools, and accuracy.

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/noise_allan.py [--quick] [--n 100000000] [--skip-allantools]

(a) Streaming. 10⁸ samples (a day at ~1 kHz) of a FOG's integrated angle (white rate
    noise + random-walk rate, generated in 10⁶-sample chunks, integer-ns stamps) are fed
    to :class:`gyro_calib.noise.NoiseCalibrator` in a child process, partial overlap
    (the decimation tree), 4 τ per octave and octave τ only. Figures: time spent in the
    calibrator (generation excluded), its rate in samples/s, and the child's peak RSS
    (its own ``ru_maxrss`` through ``wait4``; target < 500 MB).

(b) allantools. The same samples (same generator, concatenated) in one array, then
    ``allantools.oadev`` (which must hold them all) at octave τ, in another child: time
    and peak RSS. Also the largest |ours/allantools − 1| at the common τ ≤ T/4.

(c) Partial against full overlap. For white FM, flicker FM, random-walk FM, a gyro mix
    and white PM (quantisation alone), 2²⁰ samples, 4 seeds: the largest relative
    difference of the partial-overlap ADEV from full overlap at τ ≤ T/4.

``--quick`` uses 10⁷ samples.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

CHUNK = 1_000_000
PERIOD_NS = 1_000_000  # 1 kHz
ARW, RRW = 1e-5, 2e-7  # rad/√s, rad/s/√s


def _chunks(n: int, seed: int):  # type: ignore[no-untyped-def]
    """(t_ns, angle_rad) chunks of a FOG at 1 kHz: white + random-walk rate, integrated."""
    rng = np.random.default_rng(seed)
    tau0 = PERIOD_NS / 1e9
    angle, walk, done = 0.0, 0.0, 0
    while done < n:
        k = min(CHUNK, n - done)
        w = np.cumsum(np.concatenate(([walk], RRW * np.sqrt(tau0) * rng.standard_normal(k))))
        walk = float(w[-1])
        rate = ARW / np.sqrt(tau0) * rng.standard_normal(k) + w[1:]
        a = np.cumsum(np.concatenate(([angle], rate * tau0)))[1:]
        angle = float(a[-1])
        t = (1_700_000_000_000_000_000 + PERIOD_NS * np.arange(done, done + k, dtype=np.int64))
        yield t, a
        done += k


def child_ours(n: int, seed: int, taus_per_octave: int, out: str) -> None:
    from gyro_calib.noise import NoiseCalibrator, NoiseSettings

    cal = NoiseCalibrator(NoiseSettings(fog_scale_factor_counts_per_rad=1.0,
                                        taus_per_octave=taus_per_octave))
    spent = 0.0
    for t, a in _chunks(n, seed):
        t0 = time.perf_counter()
        cal.extend_fog_output(t, a)
        cal.process()
        spent += time.perf_counter() - t0
    t0 = time.perf_counter()
    cal.process(flush=True)
    curve = cal.curve('gyro')
    spent_curve = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = cal.results().get('gyro', {})
    spent_fit = time.perf_counter() - t0
    assert curve is not None
    np.savez(out, tau=curve.tau_s, adev=curve.adev, m=curve.m)
    print(json.dumps({'stream_s': spent, 'flush_s': spent_curve, 'fit_s': spent_fit,
                      'n_tau': len(curve.tau_s),
                      'terms': {k: [v.value, v.std_uncertainty] for k, v in res.items()}}))


def child_allantools(n: int, seed: int, out: str, m_list: str) -> None:
    import allantools

    x = np.empty(n)
    i = 0
    for _, a in _chunks(n, seed):
        x[i:i + len(a)] = a
        i += len(a)
    m = np.array([int(v) for v in m_list.split(',')])
    t0 = time.perf_counter()
    tau, adev, _, _ = allantools.oadev(x, rate=1e9 / PERIOD_NS, data_type='phase',
                                       taus=m * PERIOD_NS / 1e9)
    spent = time.perf_counter() - t0
    np.savez(out, tau=tau, adev=adev)
    print(json.dumps({'oadev_s': spent, 'n_tau': len(tau)}))


def _run_child(args: list[str]) -> tuple[dict, float, float]:
    """Run this script as a child; return its JSON line, wall time, peak RSS (MB)."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS='1')
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, __file__, *args], stdout=subprocess.PIPE,
                            env=env, text=True)
    assert proc.stdout is not None
    out = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if status != 0:
        raise SystemExit(f'child {args[:2]} failed with status {status}')
    return json.loads(out.strip().splitlines()[-1]), wall, usage.ru_maxrss / 1024


def part_c(n: int, seeds: int) -> None:
    from gyro_calib.noise.allan import AveragingGrid, rate_to_phase
    from gyro_calib.noise.tree import AllanTree, FullOverlapStore
    from sim_nodes.noise import AxisNoise, NoiseTerms

    kinds = {
        'white FM (N)': NoiseTerms(random_walk=1e-4),
        'flicker FM (B)': NoiseTerms(bias_instability=1e-5),
        'random-walk FM (K)': NoiseTerms(rate_random_walk=1e-5),
        'gyro mix Q+N+B+K': NoiseTerms(1e-6, 1e-4, 1e-5, 1e-6),
        'white PM alone (Q)': NoiseTerms(quantization=1e-6),
    }
    from gyro_calib.noise import NoiseSettings

    min_m = NoiseSettings().tree_min_averaging_factor
    grid = AveragingGrid.make(4, min_m)
    print(f'\n(c) partial vs full overlap, {n} samples, {seeds} seeds, τ ≤ T/4, 4 τ/octave, '
          f'tree min_m = {min_m}')
    for name, terms in kinds.items():
        worst = 0.0
        for seed in range(seeds):
            y = AxisNoise(terms, 100.0, seed).samples(n)
            x = rate_to_phase(y - y[0], 1.0)
            tree, store = AllanTree(grid), FullOverlapStore(grid)
            tree.push(x)
            store.push(x)
            p, f = tree.sums(), store.sums()
            keep = p.m <= n // 4
            idx = np.searchsorted(f.m, p.m[keep])
            ratio = np.sqrt((p.sum_sq[keep] / p.terms[keep]) / (f.sum_sq[idx] / f.terms[idx]))
            worst = max(worst, float(np.max(np.abs(ratio - 1))))
        flag = '' if worst < 0.01 else '  (over 1 %: white PM at long τ, see tree.py)'
        print(f'  {name:22s} max |partial/full − 1| = {100 * worst:.3f} %{flag}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--n', type=int, default=100_000_000)
    parser.add_argument('--quick', action='store_true', help='10⁷ samples, fewer seeds')
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--skip-allantools', action='store_true')
    parser.add_argument('--child', choices=['ours', 'allantools'])
    parser.add_argument('--taus-per-octave', type=int, default=4)
    parser.add_argument('--out', default='')
    parser.add_argument('--m', default='')
    args = parser.parse_args()
    if args.child == 'ours':
        child_ours(args.n, args.seed, args.taus_per_octave, args.out)
        return
    if args.child == 'allantools':
        child_allantools(args.n, args.seed, args.out, args.m)
        return
    n = 10_000_000 if args.quick else args.n
    cores = len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else os.cpu_count()
    print(f'noise ADEV benchmark on {os.cpu_count()} cores ({cores} usable), load average '
          f'{os.getloadavg()[0]:.1f}; {n:.3g} samples at 1 kHz ({n / 1000 / 3600:.2f} h)')
    with tempfile.TemporaryDirectory() as tmp:
        print('\n(a) NoiseCalibrator, partial overlap (decimation tree), streamed in 10⁶ chunks')
        results = {}
        for tpo in (1, 4):
            out = str(Path(tmp) / f'ours{tpo}.npz')
            info, wall, rss = _run_child(['--child', 'ours', '--n', str(n), '--seed',
                                          str(args.seed), '--taus-per-octave', str(tpo),
                                          '--out', out])
            results[tpo] = (info, out)
            print(f'  {tpo} τ/octave: {info["n_tau"]} τ points; in the calibrator '
                  f'{info["stream_s"]:.1f} s streaming + {info["flush_s"]:.2f} s curve '
                  f'({n / (info["stream_s"] + info["flush_s"]) / 1e6:.1f} M samples/s), '
                  f'fit {info["fit_s"]:.2f} s; child wall {wall:.1f} s (generation included); '
                  f'peak RSS {rss:.0f} MB')
            for key, (value, std) in info['terms'].items():
                truth = ARW if key.startswith('angle') else RRW
                print(f'    {key} = {value:.5g} ± {std:.2g} (truth {truth:g})')
        if not args.skip_allantools:
            ours = np.load(results[1][1])
            m = ours['m'][ours['m'] <= n // 4]
            out = str(Path(tmp) / 'at.npz')
            print('\n(b) allantools.oadev on the same samples (one array), octave τ')
            info, wall, rss = _run_child(['--child', 'allantools', '--n', str(n), '--seed',
                                          str(args.seed), '--out', out, '--m',
                                          ','.join(str(int(v)) for v in m)])
            ref = np.load(out)
            common = np.isin(ours['m'], np.round(ref['tau'] * 1e9 / PERIOD_NS))
            dev = np.max(np.abs(ours['adev'][common] / ref['adev'] - 1))
            ours_s = results[1][0]['stream_s'] + results[1][0]['flush_s']
            print(f'  allantools.oadev: {info["oadev_s"]:.1f} s for {info["n_tau"]} τ; child '
                  f'peak RSS {rss:.0f} MB')
            print(f'  ours at the same octave τ: {ours_s:.1f} s → {info["oadev_s"] / ours_s:.1f}× '
                  f'faster; largest |ours/allantools − 1| = {100 * dev:.3f} % '
                  f'({int(common.sum())} τ ≤ T/4)')
    part_c(1 << (18 if args.quick else 20), 2 if args.quick else 4)


if __name__ == '__main__':
    main()
