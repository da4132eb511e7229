"""Fleet throughput: ``gyro-calib batch`` of one-hour RBRLG bags on 1 and 2 Dask workers.

Run (from the repository root, in the project's venv):

    python benchmarks/batch_throughput.py [--gyros 16] [--hours 1.0] [--workers 1 2]
        [--cache /tmp/gyro_calib_batch_bench] [--no-pdf]

Each gyro gets its own bag: the paper's rate-bias bench (``k_tilde_bench``: m = 5, 150 °/s,
1 kHz pulses, 200 Hz joint states) run for ``--hours`` with its own seeds, generated once
into ``--cache`` (in child processes, two at a time). For each worker count a fresh local
cluster (one thread per worker process) calibrates the whole fleet from scratch (``force``):
per gyro the plan task (SHA-256 of the bag), the RBRLG calibration, the hand-off file and
the certificate (HTML + PDF unless ``--no-pdf``). Figures: wall time, fleet throughput =
bag time calibrated / wall time, speed-up of N workers over 1 (target ≥ 1.8× for 2 on a
2-core machine), and the peak RSS of every worker process (``ru_maxrss`` read on the worker
after the run: the streaming calibration keeps it bounded, whatever the fleet size).
"""

from __future__ import annotations

import argparse
import logging
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

GENERATE = '''
import dataclasses, sys
from sim_nodes.rbrlg.scenarios import SCENARIOS, write_scenario_bag
base = SCENARIOS['k_tilde_bench']
seed = int(sys.argv[3])
sc = dataclasses.replace(
    base, name=sys.argv[2], expected={},
    table=dataclasses.replace(base.table, duration_s=float(sys.argv[4]), seed=seed),
    gyro=dataclasses.replace(base.gyro, seed=seed),
    description='The paper rate-bias bench (m = 5, 150 deg/s, 1 kHz), seed ' + sys.argv[3])
write_scenario_bag(sc, sys.argv[1])
'''


def bags(cache: Path, gyros: int, hours: float, distinct: int | None = None) -> list[Path]:
    """One bag per gyro, generated once.

    One bag per gyro, generated once (two child processes at a time). With ``distinct``,
    only that many are generated and the gyros take them in turn, each through its own
    directory of symbolic links (calibration cost does not depend on the seed; generating is
    what is slow).
    """
    cache.mkdir(parents=True, exist_ok=True)
    made = gyros if distinct is None else min(distinct, gyros)
    paths = [cache / f'rbrlg_{hours:g}h_seed{100 + i}' for i in range(made)]

    def make(i: int) -> None:
        path = paths[i]
        if (path / 'metadata.yaml').exists():
            return
        t0 = time.perf_counter()
        subprocess.run([sys.executable, '-c', GENERATE, str(path), path.name, str(100 + i),
                        str(hours * 3600.0)], check=True, cwd=ROOT)
        print(f'generated {path.name} in {time.perf_counter() - t0:.1f} s', flush=True)

    with ThreadPoolExecutor(2) as pool:
        list(pool.map(make, range(made)))
    out = []
    for i in range(gyros):
        source = paths[i % made]
        if i < made:
            out.append(source)
            continue
        link = cache / f'{source.name}_as_gyro{i}'
        link.mkdir(exist_ok=True)
        for f in source.iterdir():
            if not (link / f.name).exists():
                (link / f.name).symlink_to(f)
        out.append(link)
    return out


def _peak_rss_mb_and_cpu_s() -> tuple[float, float]:
    import resource

    use = resource.getrusage(resource.RUSAGE_SELF)
    return use.ru_maxrss / 1024, use.ru_utime + use.ru_stime


SPIN = 'import time\nt = time.process_time()\nx = 0\nfor i in range(20_000_000): x += i\n'


def cores_available() -> float:
    """Cores this machine gives now, measured.

    How many cores this machine gives now: CPU-bound loops run alone and two at once; the
    ratio of their total throughput (2.0 on an idle 2-core machine, ~1 when other jobs take
    the second core).
    """
    def one() -> float:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, '-c', SPIN], check=True)
        return time.perf_counter() - t0

    alone = one()
    with ThreadPoolExecutor(2) as pool:
        t0 = time.perf_counter()
        list(pool.map(lambda _: one(), range(2)))
        both = time.perf_counter() - t0
    return 2.0 * alone / both


def run(paths: list[Path], workers: int, pdf: bool,
        ) -> tuple[float, list[tuple[float, float]], list[str]]:
    """Calibrate the fleet on a new local cluster.

    Calibrate the fleet on a new local cluster; wall s, (peak RSS MB, CPU s) per worker,
    the reasons of the gyros that failed.
    """
    from dask.distributed import Client, LocalCluster

    from gyro_calib.batch.manifest import GyroJob
    from gyro_calib.batch.run import run_batch

    jobs = [GyroJob(f'RLG-{i:03d}', (str(p),)) for i, p in enumerate(paths)]
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      host='127.0.0.1', dashboard_address='127.0.0.1:0',
                      silence_logs=logging.CRITICAL) as cluster, \
            Client(cluster) as client, tempfile.TemporaryDirectory() as tmp:
        client.run(lambda: __import__('gyro_calib.bag_calibration'))  # warm imports, both runs
        t0 = time.perf_counter()
        outcome = run_batch(jobs, Path(tmp) / 'out', client=client, force=True, pdf=pdf)
        wall = time.perf_counter() - t0
        rss = sorted(client.run(_peak_rss_mb_and_cpu_s).values())
    return wall, rss, [r['reason'] for r in outcome.records if r.get('status') != 'ok']


def main() -> None:
    """Print the fleet figures for each worker count."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--gyros', type=int, default=16)
    parser.add_argument('--hours', type=float, default=1.0)
    parser.add_argument('--workers', type=int, nargs='+', default=[1, 2])
    parser.add_argument('--cache', type=Path, default=Path('/tmp/gyro_calib_batch_bench'))
    parser.add_argument('--pdf', action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument('--distinct', type=int, default=None,
                        help='generate only this many distinct bags; gyros share them in turn')
    args = parser.parse_args()
    paths = bags(args.cache, args.gyros, args.hours, args.distinct)
    size = sum(f.stat().st_size for p in paths for f in p.iterdir()) / 1e9
    print(f'{args.gyros} gyros × {args.hours:g} h of 1 kHz RBRLG bench = '
          f'{args.gyros * args.hours:g} bag-hours, {size:.2f} GB read '
          f'({len({(p / "metadata.yaml").resolve() for p in paths})} distinct bags); '
          f'cores {os.cpu_count()}; '
          f'load average {os.getloadavg()[0]:.1f}; PDF {"on" if args.pdf else "off"}')
    print(f'cores this machine gives now (CPU-bound loops alone vs two at once): '
          f'{cores_available():.2f}', flush=True)
    base = None
    for n in args.workers:
        wall, rss, failed = run(paths, n, args.pdf)
        base = base or (wall * n if n != 1 else wall)
        speed = args.gyros * args.hours * 3600.0 / wall
        print(f'{n} worker(s): wall {wall:.1f} s, {wall / args.gyros:.2f} s per gyro, '
              f'{speed:.0f}× real time, speed-up over 1 worker {base / wall:.2f}×, '
              f'peak RSS per worker {", ".join(f"{r:.0f}" for r, _ in rss)} MB, CPU per worker '
              f'{", ".join(f"{c:.0f}" for _, c in rss)} s, failed '
              f'{len(failed)}; load average {os.getloadavg()[0]:.1f}', flush=True)
        for why in sorted(set(failed)):
            print(f'  failed: {why}')


if __name__ == '__main__':
    main()
