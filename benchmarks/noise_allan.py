"""Allan deviation of a day at 1 kHz and beyond.

Allan deviation of a day at 1 kHz and beyond: exactness, speed and memory against
allantools, and the coverage of the EDF error bars.

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/noise_allan.py [--quick] [--n 100000000] [--n-large 1000000000]
        [--skip-allantools] [--skip-large] [--skip-no-screen] [--mc-trials 400]

(a) Streaming, exact. N samples (a day at ~1 kHz for 10⁸) of a FOG's integrated angle
    (white rate noise + random-walk rate, generated in 10⁶-sample chunks, integer-ns
    stamps) are fed to :class:`gyro_calib.noise.NoiseCalibrator` in a child process, full
    overlap at every τ of the octave grid (the phase goes to a scratch file beyond 2²⁰
    points), once for the ADEV alone and once with MDEV, HDEV and TOTDEV too. Figures:
    time in the calibrator (generation excluded), samples/s, and the child's peak RSS
    (its own ``ru_maxrss`` through ``wait4``; target < 500 MB), where the time goes (the
    spike screen, the sums, the ordering stage, the rest) and the floor: one NumPy pass
    over the same samples in the same child. The ADEV alone is also run without the spike
    screen (the path before it, the reference of its cost; ``--skip-no-screen`` leaves it
    out). Also for ``--n-large``
    (10⁹, ADEV only; all four with ``--large-all``) unless ``--skip-large``, last.

(b) allantools. The same samples in one array, then ``allantools.oadev`` (which must hold
    them all; not run at 10⁹: 8 GB for the phase alone, more for its temporaries) at the
    same τ, in another child: time, peak RSS, the largest |ours/allantools − 1|, and each of
    our times as a ratio to it (the machine's load cancels in the ratio; the issue 40 goals:
    ADEV ≤ 0.2, all four ≤ 0.5).

(c) EDF error bars. White FM, flicker FM and random-walk FM records of 4096 samples,
    ``--mc-trials`` each: at every octave τ the fraction of trials whose ±1σ bar
    (σ = dev/√(2·EDF), EDF by Greenhall's algorithm for OADEV, MDEV, HDEV and SP 1065
    Table 7 for TOTDEV, the noise type known) covers the true deviation (the root mean
    of the variance over all trials). Target 60–75 %.

``--quick`` uses 10⁷ samples, no 10⁹ run, 200 trials.
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


class _Stopwatch:
    """Seconds spent inside wrapped methods, per calibrator (a breakdown of its time)."""

    def __init__(self) -> None:
        self.spent: dict[str, dict[str, float]] = {}
        self.current = ''
        self._depth = 0

    def wrap(self, owner: type, name: str, label: str) -> None:
        inner = getattr(owner, name)

        def timed(*args, **kwargs):  # type: ignore[no-untyped-def]
            if self._depth:  # nested: counted once, outside
                return inner(*args, **kwargs)
            self._depth += 1
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self._depth -= 1
                part = self.spent.setdefault(self.current, {})
                part[label] = part.get(label, 0.0) + time.perf_counter() - t0

        setattr(owner, name, timed)


def child_ours(n: int, seed: int, deviations: str, out: str, paths: list[str]) -> None:
    """Stream the samples into one calibrator per path, chunk by chunk in turn, timed apart.

    Paths: 'screened' (as shipped), 'bare' (the path before the spike screen, METHODS §E.6:
    samples straight in), 'floor' (one NumPy pass over the samples: their increments into a
    reused array). Interleaved chunk by chunk, the machine's load falls alike on each.
    """
    from gyro_calib.noise import NoiseCalibrator, NoiseSettings
    from gyro_calib.noise.channel import ChannelAccumulator
    from gyro_calib.noise.exact import ExactDeviations
    from gyro_calib.noise.ordering import ReorderBuffer
    from gyro_calib.noise.outliers import OutlierScreen

    import_s = 0.0  # (the calibrator no longer imports allantools for Greenhall's EDF)
    watch = _Stopwatch()
    post_init = ChannelAccumulator.__post_init__

    def maybe_unscreened(self: ChannelAccumulator) -> None:
        post_init(self)
        if watch.current == 'bare':
            self._screen = None

    ChannelAccumulator.__post_init__ = maybe_unscreened  # type: ignore[method-assign]
    # the screen's own work (median, MAD, the tally), without the sums of the blocks it
    # releases: OutlierScreen._decide is timed, ExactDeviations.push apart
    watch.wrap(OutlierScreen, '_decide', 'screen')
    watch.wrap(ExactDeviations, 'push', 'sums')
    watch.wrap(ExactDeviations, 'sums', 'sums')
    watch.wrap(ReorderBuffer, 'extend', 'ordering')
    settings = NoiseSettings(fog_scale_factor_counts_per_rad=1.0, taus='octave',
                             deviations=deviations)
    cals = {p: NoiseCalibrator(settings) for p in paths if p != 'floor'}
    spent = dict.fromkeys(paths, 0.0)
    cpu = dict.fromkeys(paths, 0.0)  # CPU time of the process (all threads), s
    work = np.empty(CHUNK)
    for t, a in _chunks(n, seed):
        for p in paths:
            watch.current = p
            t0, c0 = time.perf_counter(), time.process_time()
            if p == 'floor':
                np.subtract(a[1:], a[:-1], out=work[:len(a) - 1])
            else:
                cals[p].extend_fog_output(t, a)
                cals[p].process()
            spent[p] += time.perf_counter() - t0
            cpu[p] += time.process_time() - c0
    info: dict[str, object] = {'import_s': import_s, 'paths': {}}
    for p, cal in cals.items():
        watch.current = p
        t0, c0 = time.perf_counter(), time.process_time()
        cal.process(flush=True)
        curve = cal.curve('gyro')
        spent_curve = time.perf_counter() - t0
        cpu[p] += time.process_time() - c0
        t0 = time.perf_counter()
        res = cal.results().get('gyro', {})
        spent_fit = time.perf_counter() - t0
        assert curve is not None
        if p == paths[0]:
            np.savez(out, tau=curve.tau_s, adev=curve.adev, m=curve.m)
            info['n_tau'] = len(curve.tau_s)
        info['paths'][p] = {  # type: ignore[index]
            'stream_s': spent[p], 'flush_s': spent_curve, 'fit_s': spent_fit, 'cpu_s': cpu[p],
            'parts': watch.spent.get(p, {}),
            'terms': {k: [v.value, v.std_uncertainty] for k, v in res.items()}}
    info['floor_s'] = spent.get('floor', float('nan'))
    info['kernel_ns'] = kernel_floor_ns()
    print(json.dumps(info))


def kernel_floor_ns(block: int = 1 << 15, reps: int = 200) -> dict[str, float]:
    """Ns per term of the NumPy operations each statistic's exact sums cannot do without.

    The sums are bit-identical to the shipped ones only if every term is formed by the same
    IEEE operations and summed by the same BLAS dot over the same pieces: for the ADEV
    D = x_{i+m} − x_i and u = D_{i+m} − D_i (two subtractions) and ddot; the HDEV adds the
    third difference (one subtraction) and its ddot; the MDEV the running sum of it (a
    sequential cumsum), the carry and a ddot. Timed on one block held in the cache (the
    best case: no file, no Python between the calls).
    """
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.standard_normal(3 * block + 64))
    d, u, t, v = (np.empty(2 * block) for _ in range(4))
    m = 16

    def per_term(f) -> float:  # type: ignore[no-untyped-def]
        f()
        t0 = time.perf_counter()
        for _ in range(reps):
            f()
        return (time.perf_counter() - t0) / reps / block * 1e9

    def adev() -> None:
        dd = np.subtract(x[m:block + 2 * m], x[:block + m], out=d[:block + m])
        uu = np.subtract(dd[m:], dd[:block], out=u[:block])
        for a in range(0, block, 8192):
            p = uu[a:a + 8192]
            float(np.dot(p, p))

    def third() -> None:
        tt = np.subtract(u[m:block + m], u[:block], out=t[:block])
        for a in range(0, block, 8192):
            p = tt[a:a + 8192]
            float(np.dot(p, p))

    def mdev() -> None:
        vv = np.cumsum(t[:block], out=v[:block])
        vv += 1.0
        for a in range(0, block, 8192):
            p = vv[a:a + 8192]
            float(np.dot(p, p))

    return {'adev': per_term(adev), 'hdev': per_term(third), 'mdev': per_term(mdev)}


def child_allantools(n: int, seed: int, out: str, m_list: str) -> None:
    import allantools

    x = np.empty(n)
    i = 0
    for _, a in _chunks(n, seed):
        x[i:i + len(a)] = a
        i += len(a)
    m = np.array([int(v) for v in m_list.split(',')])
    t0, c0 = time.perf_counter(), time.process_time()
    tau, adev, _, _ = allantools.oadev(x, rate=1e9 / PERIOD_NS, data_type='phase',
                                       taus=m * PERIOD_NS / 1e9)
    spent, cpu = time.perf_counter() - t0, time.process_time() - c0
    np.savez(out, tau=tau, adev=adev)
    print(json.dumps({'oadev_s': spent, 'oadev_cpu_s': cpu, 'n_tau': len(tau)}))


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


def _flicker(rng: np.random.Generator, n: int) -> np.ndarray:
    """Flicker rate noise (two-sided PSD ∝ 1/f) shaped from white noise over 4n samples."""
    w = np.fft.rfft(rng.standard_normal(4 * n))
    f = np.fft.rfftfreq(4 * n)
    h = np.zeros_like(f)
    h[1:] = 1.0 / np.sqrt(f[1:])
    return np.fft.irfft(w * h, 4 * n)[:n]


def part_c(n: int, trials: int) -> None:
    from gyro_calib.noise.allan import TauGrid
    from gyro_calib.noise.edf import edf_greenhall, edf_totdev
    from gyro_calib.noise.exact import ExactDeviations

    kinds = {'white FM (α = 0)': (0, lambda r: r.standard_normal(n)),
             'flicker FM (α = −1)': (-1, lambda r: _flicker(r, n)),
             'random-walk FM (α = −2)': (-2, lambda r: np.cumsum(r.standard_normal(n)))}
    norms = {'adev': lambda m: 2.0 * m**2, 'mdev': lambda m: 2.0 * m**4,
             'hdev': lambda m: 6.0 * m**2, 'totdev': lambda m: 2.0 * m**2}
    print(f'\n(c) ±1σ coverage of the EDF error bars, {n} samples, {trials} trials per noise '
          'type (target 60–75 %); per τ: m, coverage %, EDF')
    grid = TauGrid('octave', 1.0)
    for name, (alpha, make) in kinds.items():
        rng = np.random.default_rng(7)
        variances = {d: [] for d in norms}
        ms = None
        for _ in range(trials):
            x = np.concatenate(([0.0], np.cumsum(make(rng))))
            store = ExactDeviations(grid.factors_up_to, 0.25, block=4096)
            store.push(x)
            s = store.sums()
            ms = s.m.astype(np.float64)
            for d in norms:
                variances[d].append(getattr(s, f'{d}_sum') / (norms[d](ms)
                                                             * getattr(s, f'{d}_terms')))
        assert ms is not None
        n_points = n + 1
        edf = {'adev': edf_greenhall(n_points, ms, alpha),
               'mdev': edf_greenhall(n_points, ms, alpha, modified=True),
               'hdev': edf_greenhall(n_points, ms, alpha, d=3),
               'totdev': edf_totdev(n_points, ms, alpha)}
        print(f'  {name}')
        for d in norms:
            v = np.array(variances[d])
            ok = np.all(np.isfinite(v), axis=0)
            truth = np.sqrt(np.mean(v[:, ok], axis=0))
            dev = np.sqrt(v[:, ok])
            half = dev / np.sqrt(2.0 * edf[d][ok])
            cover = np.mean(np.abs(dev - truth) <= half, axis=0)
            cells = '  '.join(f'{int(m)}:{100 * c:.0f}%/{e:.3g}'
                              for m, c, e in zip(ms[ok], cover, edf[d][ok]))
            overall = 100 * float(np.mean(cover))
            print(f'    {d:6s} mean {overall:.1f} %, range {100 * cover.min():.0f}–'
                  f'{100 * cover.max():.0f} %  [{cells}]')


def _ours(n: int, seed: int, deviations: str, tmp: str, label: str,
          reference: bool = False) -> tuple[dict, str]:
    """One child: our calibrator (and, with ``reference``, the path without the screen)."""
    out = str(Path(tmp) / f'ours_{label}.npz')
    paths = ['screened', 'bare', 'floor'] if reference else ['screened', 'floor']
    info, wall, rss = _run_child(['--child', 'ours', '--n', str(n), '--seed', str(seed),
                                  '--deviations', deviations, '--out', out,
                                  '--paths', ','.join(paths)])
    both = ' (both calibrators together)' if reference else ''
    print(f'  {n:.0e} samples, {label}: {info["n_tau"]} τ; child wall {wall:.1f} s (generation '
          f'included); peak RSS {rss:.0f} MB{both}')
    floor = info['floor_s']
    for p, run in info['paths'].items():
        spent = run['stream_s'] + run['flush_s']
        run['total_s'] = spent
        name = {'screened': 'as shipped', 'bare': 'without the spike screen'}[p]
        print(f'    {name}: {run["stream_s"]:.2f} s streaming + {run["flush_s"]:.2f} s curve = '
              f'{spent:.2f} s ({n / spent / 1e6:.1f} M samples/s) = {spent / floor:.0f}× the '
              f'floor (CPU {run["cpu_s"]:.2f} s); fit {run["fit_s"]:.2f} s')
        parts = dict(run['parts'])
        parts['rest'] = spent - sum(parts.values())
        print('      where the time goes: ' + ', '.join(
            f'{k} {v:.2f} s ({100 * v / spent:.0f} %)' for k, v in parts.items()))
    print(f'    floor (one NumPy pass over the samples, interleaved chunk by chunk with the '
          f'calibrators): {floor:.3f} s')
    if reference:
        a_s = info['paths']['screened']['total_s']
        b_s = info['paths']['bare']['total_s']
        print(f'    the spike screen costs {a_s / b_s - 1:+.1%} of the path without it '
              f'(interleaved in one child)')
    k = info['kernel_ns']
    factors = info['n_tau']
    need = {'adev': k['adev']} if deviations == 'adev' else {
        'adev': k['adev'], 'hdev': k['hdev'], 'mdev': k['mdev']}
    floor_sums = n * factors * sum(need.values()) / 1e9
    run = info['paths']['screened']
    sums = run['parts'].get('sums', float('nan'))
    info['floor_sums_s'] = floor_sums
    print('    floor of the exact sums (the NumPy operations every term needs for the same '
          'floats, one cached block, no file, no Python): '
          + ', '.join(f'{d} {v:.2f}' for d, v in need.items())
          + f' ns per term and factor × {n:.0e} terms × {factors} factors = {floor_sums:.2f} s '
          f'CPU; our sums took {sums:.2f} s = {sums / floor_sums:.2f}× it')
    for key, (value, std) in info['paths']['screened']['terms'].items():
        truth = ARW if key.startswith('angle') else RRW
        print(f'    {key} = {value:.5g} ± {std:.2g} (truth {truth:g})')
    return info, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--n', type=int, default=100_000_000)
    parser.add_argument('--n-large', type=int, default=1_000_000_000)
    parser.add_argument('--quick', action='store_true', help='10⁷ samples, no 10⁹, 200 trials')
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--skip-allantools', action='store_true')
    parser.add_argument('--skip-large', action='store_true')
    parser.add_argument('--large-all', action='store_true',
                        help='at 10⁹ also MDEV, HDEV, TOTDEV (about 4× the time)')
    parser.add_argument('--mc-trials', type=int, default=400)
    parser.add_argument('--child', choices=['ours', 'allantools'])
    parser.add_argument('--deviations', default='adev')
    parser.add_argument('--out', default='')
    parser.add_argument('--m', default='')
    parser.add_argument('--paths', default='screened,floor')
    parser.add_argument('--skip-no-screen', action='store_true',
                        help='no reference run of the path without the spike screen')
    args = parser.parse_args()
    if args.child == 'ours':
        child_ours(args.n, args.seed, args.deviations, args.out, args.paths.split(','))
        return
    if args.child == 'allantools':
        child_allantools(args.n, args.seed, args.out, args.m)
        return
    n = 10_000_000 if args.quick else args.n
    cores = len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else os.cpu_count()
    print(f'noise ADEV benchmark on {os.cpu_count()} cores ({cores} usable), load average '
          f'{os.getloadavg()[0]:.1f}; {n:.3g} samples at 1 kHz ({n / 1000 / 3600:.2f} h)')
    with tempfile.TemporaryDirectory() as tmp:
        print('\n(a) NoiseCalibrator, exact full overlap at every octave τ, streamed in 10⁶ '
              'chunks')
        adev_info, adev_out = _ours(n, args.seed, 'adev', tmp, 'ADEV only',
                                    reference=not args.skip_no_screen)
        all_info, _ = _ours(n, args.seed, 'adev, mdev, hdev, totdev', tmp,
                            'ADEV + MDEV + HDEV + TOTDEV')
        if not args.skip_allantools:
            ours = np.load(adev_out)
            out = str(Path(tmp) / 'at.npz')
            print(f'\n(b) allantools.oadev on the same {n:.0e} samples (one array), the same τ')
            info, wall, rss = _run_child(['--child', 'allantools', '--n', str(n), '--seed',
                                          str(args.seed), '--out', out, '--m',
                                          ','.join(str(int(v)) for v in ours['m'])])
            ref = np.load(out)
            common = np.isin(ours['m'], np.round(ref['tau'] * 1e9 / PERIOD_NS))
            dev = np.max(np.abs(ours['adev'][common] / ref['adev'] - 1))
            a_s = adev_info['paths']['screened']['total_s']
            f_s = all_info['paths']['screened']['total_s']
            print(f'  allantools.oadev: {info["oadev_s"]:.1f} s for {info["n_tau"]} τ; child '
                  f'peak RSS {rss:.0f} MB')
            print(f'  ours, ADEV: {a_s:.1f} s = {a_s / info["oadev_s"]:.3f} of allantools; '
                  f'with MDEV, HDEV, TOTDEV too: {f_s:.1f} s = {f_s / info["oadev_s"]:.3f}')
            a_c = adev_info['paths']['screened']['cpu_s']
            f_c = all_info['paths']['screened']['cpu_s']
            at_c = info['oadev_cpu_s']
            print(f'  in CPU time (all threads; less sensitive to other processes than the '
                  f'wall time): allantools {at_c:.1f} s; ours, ADEV {a_c:.1f} s = '
                  f'{a_c / at_c:.3f}; all four {f_c:.1f} s = {f_c / at_c:.3f}'
                  + (f'; ADEV without the screen {adev_info["paths"]["bare"]["cpu_s"]:.1f} s '
                     f'= {adev_info["paths"]["bare"]["cpu_s"] / at_c:.3f}'
                     if 'bare' in adev_info['paths'] else ''))
            if 'bare' in adev_info['paths']:
                b_s = adev_info['paths']['bare']['total_s']
                print(f'  ours, ADEV without the spike screen: {b_s:.1f} s = '
                      f'{b_s / info["oadev_s"]:.3f} of allantools')
            print(f'  largest |ours/allantools − 1| = {dev:.2e} over {int(common.sum())} τ '
                  f'(τ ≤ T/4, clusters down to 4)')
            for label, run_info, goal in (('ADEV', adev_info, 0.2),
                                          ('all four', all_info, 0.5)):
                run = run_info['paths']['screened']
                other = run['total_s'] - run['parts'].get('sums', 0.0)
                least = run_info['floor_sums_s'] + other
                print(f'  {label}: goal ≤ {goal} of allantools = {goal * info["oadev_s"]:.1f} s; '
                      f'the floor of the exact sums + everything else as measured = '
                      f'{run_info["floor_sums_s"]:.1f} + {other:.1f} = {least:.1f} s = '
                      f'{least / info["oadev_s"]:.3f} of allantools (one thread)')
        if args.quick or args.mc_trials > 0:
            part_c(4096, 200 if args.quick else args.mc_trials)
        if not (args.quick or args.skip_large):
            print(f'\n(d) {args.n_large:.0e} samples (allantools cannot hold them here)')
            _ours(args.n_large, args.seed, 'adev', tmp, 'ADEV only')
            if args.large_all:
                _ours(args.n_large, args.seed, 'adev, mdev, hdev, totdev', tmp,
                      'ADEV + MDEV + HDEV + TOTDEV')


if __name__ == '__main__':
    main()
