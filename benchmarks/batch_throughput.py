"""Fleet throughput: ``gyro-calib batch`` of one-hour RBRLG bags on 1 and 2 Dask workers.

Run (from the repository root, in the project's venv):

    python benchmarks/batch_throughput.py [--gyros 16] [--hours 1.0] [--workers 1 2]
        [--cache /tmp/gyro_calib_batch_bench] [--no-pdf] [--distinct N] [--standalone N]
        [--pinned-only] [--profile] [--no-ceiling] [--warm]

Each gyro gets its own bag: the paper's rate-bias bench (``k_tilde_bench``: m = 5, 150 °/s,
1 kHz pulses, 200 Hz joint states) run for ``--hours`` with its own seeds, generated once
into ``--cache`` (in child processes, two at a time). For each worker count a fresh local
cluster (one thread per worker process) calibrates the whole fleet from scratch (``force``):
per gyro the plan task (SHA-256 of the bag), the RBRLG calibration, the hand-off file and
the certificate (HTML + PDF unless ``--no-pdf``). Figures: wall time, fleet throughput =
bag time calibrated / wall time, speed-up of N workers over 1 (target ≥ 1.8× for 2 on a
2-core machine), and the peak RSS of every worker process (``ru_maxrss`` read on the worker
after the run: the streaming calibration keeps it bounded, whatever the fleet size).

The cluster is the one ``gyro-calib batch`` starts (:func:`gyro_calib.batch.run.make_client`);
the clock runs from ``run_batch`` to its return, the workers importing as their first tasks
run, as in a fleet run (``--warm``: ``gyro_calib.bag_calibration`` imported in every worker
before the clock starts, as the figures before issue 40 (d) were taken). ``--profile``:
where each run's wall goes (Dask's task stream: per task kind, each worker's busy and idle
time, its tail) and the driver's CPU by thread. ``--pinned-only`` skips the unpinned runs.

**Ceiling** (pinned runs, ``--no-ceiling`` to skip): right before N pinned workers, the same
tasks (plan, calibration, finish) in one fresh process pinned to a core, then dealt to N
fresh processes run at once, one core each, no Dask: the speed-up this (virtual) machine
allows at that moment, whose two vCPUs do not always run two identical processes as fast
as one (measured 1.03–1.45× slower). ``speed-up / ceiling`` is what the fleet keeps of it.

Then the figures the fleet is judged by (issue 25 §5):

* **where a worker's CPU goes** — per thread of the worker process (the Dask task thread,
  the event-loop thread with heartbeats and comms, the bag reader's prefetch thread that
  decompresses zstd chunks ahead of the NumPy work, any other), and the CPU of the driver
  process that holds the scheduler and client (the nannies live there too);
* **per-worker-core efficiency** — the same bags calibrated by standalone
  ``gyro-calib calibrate BAG --out H.yaml --report DIR`` processes, one after the other (the
  same work as a batch gyro: calibration, hand-off, HTML + PDF certificate; the plan task's
  SHA-256 is extra work the batch does), against the fleet's wall per gyro × worker count
  with every worker **pinned to one core** (goal ≥ 0.9); and against ``calibrate --out``
  alone, for reference;
* **pinned speed-up** — 2 workers each pinned to its own core against 1 worker pinned to
  one core (goal ≥ 1.8×). Pinning puts every thread of a worker process (read from
  ``/proc/<pid>/task``) on that core, so a worker cannot borrow the other core for its
  prefetch thread.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
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


def _pin_to(core: int) -> int:
    """Put every thread of this process on ``core`` (threads made later inherit it)."""
    for tid in os.listdir('/proc/self/task'):
        os.sched_setaffinity(int(tid), {core})
    return os.getpid()


def _count_thread_cpu() -> None:
    """From now on, add each finished thread's CPU time to a table (by name, no numbers)."""
    import builtins
    import threading

    if hasattr(builtins, '_bench_thread_cpu'):
        return
    table: Counter[str] = Counter()
    setattr(builtins, '_bench_thread_cpu', table)
    original = threading.Thread.run

    def run(self: threading.Thread) -> None:
        try:
            original(self)
        finally:
            table[self.name.rstrip('0123456789_-')] += time.thread_time()

    threading.Thread.run = run  # type: ignore[method-assign]


def _thread_cpu_s() -> dict[str, float]:
    """CPU s per thread kind: the live threads' clocks plus the finished threads' table."""
    import builtins
    import threading

    out: Counter[str] = Counter(getattr(builtins, '_bench_thread_cpu', {}))
    for thread in threading.enumerate():
        if thread.ident is not None:
            name = thread.name.rstrip('0123456789_-')
            out[name] += time.clock_gettime(time.pthread_getcpuclockid(thread.ident))
    return dict(out)


def _thread_kind(name: str) -> str:
    if name.startswith('Dask-Default-Threads') or name[:1].isdigit():
        return 'task'
    if name == 'MainThread':
        return 'event loop'
    if name.startswith('ThreadPoolExecutor'):
        return 'bag prefetch'
    return name or 'other'


def _timeline(tasks: list[dict], t0: float, wall: float, workers: int) -> str:
    """Where the run's wall time goes, from Dask's task stream.

    Per task kind (plan, rbrlg, finish, ...): count, total and largest compute s; per
    worker: busy s (compute), idle s before its first task, between tasks and after its
    last one until ``run_batch`` returned (the parent writing the fleet files; the other
    worker's tail). ``t0``: the wall-clock time (``time.time``) the run started.
    """
    kinds: dict[str, list[float]] = {}
    spans: dict[str, list[tuple[float, float]]] = {}
    for task in tasks:
        key = str(task['key']).strip("()',").split('-')[0]
        for ss in task['startstops']:
            if ss['action'] == 'compute':
                kinds.setdefault(key, []).append(ss['stop'] - ss['start'])
                spans.setdefault(task['worker'], []).append((ss['start'], ss['stop']))
    end = t0 + wall
    lines = ['  tasks: ' + ', '.join(f'{k} {len(v)}× {sum(v):.2f} s (max {max(v):.2f})'
                                     for k, v in kinds.items())]
    for worker, s in sorted(spans.items()):
        s.sort()
        busy = sum(b - a for a, b in s)
        gaps = sum(max(0.0, s[i + 1][0] - s[i][1]) for i in range(len(s) - 1))
        lines.append(f'  worker {worker.rsplit(":", 1)[-1]}: busy {busy:.2f} s, idle before '
                     f'the first task {s[0][0] - t0:.2f} s, between tasks {gaps:.2f} s '
                     f'({len(s) - 1} gaps), after its last {end - s[-1][1]:.2f} s')
    return '\n'.join(lines)


def run(paths: list[Path], workers: int, pdf: bool, pin: bool = False, profile: bool = False,
        warm: bool = False,
        ) -> tuple[float, list[tuple[float, float]], list[str], dict[str, float], float]:
    """Calibrate the fleet on a new local cluster.

    Calibrate the fleet on a new local cluster, each worker pinned to its own core when
    ``pin``; wall s, (peak RSS MB, CPU s) per worker, the reasons of the gyros that failed,
    the workers' CPU s by thread kind during the run, the driver process's CPU s.
    """
    import importlib

    from dask.distributed import get_task_stream

    from gyro_calib.batch.manifest import GyroJob
    from gyro_calib.batch.run import make_client, run_batch

    for module in ('pyarrow.parquet', 'gyro_calib.batch.fleet', 'tqdm'):
        importlib.import_module(module)  # the driver's imports, before every clock alike (the
        # first run would pay them alone: 0.9 s CPU of its driver's main thread)

    jobs = [GyroJob(f'RLG-{i:03d}', (str(p),)) for i, p in enumerate(paths)]
    client, cluster = make_client(workers, None)  # the cluster gyro-calib batch starts
    with cluster, client, tempfile.TemporaryDirectory() as tmp:
        run_batch([], Path(tmp) / 'driver', client=client)  # the driver's first-run costs,
        # outside every clock alike (a fleet run pays them once, whatever its worker count)
        if warm:  # not what a fleet run does: its workers import as their first tasks run
            client.run(lambda: __import__('gyro_calib.bag_calibration'))
        if pin:
            for core, address in enumerate(sorted(client.scheduler_info()['workers'])):
                client.run(_pin_to, core % (os.cpu_count() or 1), workers=[address])
        client.run(_count_thread_cpu)
        before = client.run(_thread_cpu_s)
        driver0 = time.process_time()
        threads0 = _thread_cpu_s()
        epoch = time.time()
        t0 = time.perf_counter()
        with get_task_stream(client) if profile else contextlib.nullcontext() as stream:
            outcome = run_batch(jobs, Path(tmp) / 'out', client=client, force=True, pdf=pdf)
        wall = time.perf_counter() - t0
        if profile:
            print(_timeline(stream.data, epoch, wall, workers), flush=True)
        driver = time.process_time() - driver0
        threads1 = _thread_cpu_s()
        if profile:  # the driver's threads: run_batch's loop (main), the cluster's event loop
            print('  driver threads: ' + ', '.join(
                f'{name or "?"} {cpu - threads0.get(name, 0.0):.2f} s'
                for name, cpu in sorted(threads1.items(), key=lambda kv: -kv[1])
                if cpu - threads0.get(name, 0.0) >= 0.01), flush=True)
        after = client.run(_thread_cpu_s)
        rss = sorted(client.run(_peak_rss_mb_and_cpu_s).values())
    kinds: Counter[str] = Counter()
    for worker, table in after.items():
        for name, cpu in table.items():
            kinds[_thread_kind(name)] += cpu - before[worker].get(name, 0.0)
    return (wall, rss, [r['reason'] for r in outcome.records if r.get('status') != 'ok'],
            dict(kinds), driver)


SEQUENCE = '''
import sys
from gyro_calib.batch.manifest import GyroJob
from gyro_calib.batch.tasks import finish_gyro, plan_gyro, run_method
pdf = sys.argv[1] == 'pdf'
for i, bag in enumerate(sys.argv[2:]):
    job = GyroJob(f'RLG-{i:03d}', (bag,))
    plan = plan_gyro(job, '', '', True)
    runs = [run_method(job, m, plan.hashed) for m in plan.methods]
    assert finish_gyro(job, plan, None, pdf, f'g{i}', *runs).record['status'] == 'ok'
'''


def ceiling(paths: list[Path], workers: int, pdf: bool) -> float:
    """The speed-up this machine allows ``workers`` processes now, without Dask.

    The batch's tasks of every gyro (plan, calibration, finish) in one fresh process pinned
    to core 0, then the gyros dealt out to ``workers`` fresh processes run at once, each
    pinned to its own core: the first wall over the second. Each process pays its imports
    as a worker does. Two identical processes on two cores of this (virtual) machine do not
    always finish as fast as one: the ratio is the ceiling of the fleet's speed-up, and the
    fleet's speed-up over it is what Dask's scheduling keeps of it.
    """
    def start(share: list[Path], core: int) -> subprocess.Popen[bytes]:
        return subprocess.Popen(
            [sys.executable, '-c', SEQUENCE, 'pdf' if pdf else 'nopdf', *map(str, share)],
            cwd=ROOT, preexec_fn=lambda: os.sched_setaffinity(0, {core}))  # noqa: PLW1509

    t0 = time.perf_counter()
    start(paths, 0).wait()
    alone = time.perf_counter() - t0
    t0 = time.perf_counter()
    procs = [start(paths[k::workers], k % (os.cpu_count() or 1)) for k in range(workers)]
    if any(proc.wait() for proc in procs):
        raise SystemExit('a task sequence failed')
    return alone / (time.perf_counter() - t0)


def standalone(paths: list[Path], report: bool) -> tuple[float, float]:
    """Wall and CPU s per gyro of ``gyro-calib calibrate`` run once per bag, one at a time."""
    import resource

    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for i, path in enumerate(paths):
            cmd = [sys.executable, '-m', 'gyro_calib.cli', 'calibrate', str(path), '--out',
                   f'{tmp}/g{i}.yaml', '--no-progress', '--gyro-id', f'RLG-{i:03d}']
            if report:
                cmd += ['--report', f'{tmp}/certificates']
            subprocess.run(cmd, check=True, cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime
    return wall / len(paths), cpu / len(paths)


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
    parser.add_argument('--warm', action='store_true',
                        help='import gyro_calib.bag_calibration in every worker before the '
                        'clock starts (the figures before issue 40 (d); a fleet run does not)')
    parser.add_argument('--ceiling', action=argparse.BooleanOptionalAction, default=True,
                        help='before each pinned run of several workers, the speed-up the '
                        'machine allows now: the same tasks in 1 process, then in N at once')
    parser.add_argument('--profile', action='store_true',
                        help='print where each run\'s wall time goes (Dask task stream)')
    parser.add_argument('--pinned-only', action='store_true',
                        help='only the runs with every worker pinned to one core')
    parser.add_argument('--standalone', type=int, default=4, metavar='N',
                        help='time standalone calibrate on the first N bags (0: skip)')
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
    alone: dict[bool, tuple[float, float]] = {}
    if args.standalone:
        for report in (False, True):
            alone[report] = standalone(paths[:args.standalone], report and args.pdf)
            what = 'calibrate --out --report' if report and args.pdf else 'calibrate --out'
            print(f'standalone {what}: {alone[report][0]:.2f} s wall, {alone[report][1]:.2f} s '
                  f'CPU per gyro ({alone[report][1] / alone[report][0]:.2f} cores)', flush=True)
    for pin in (True,) if args.pinned_only else (False, True):
        base = None
        for n in args.workers:
            ceil = None
            if pin and n > 1 and args.ceiling:
                ceil = ceiling(paths, n, args.pdf)
                print(f'  ceiling: the same tasks in 1 pinned process, then in {n} at once '
                      f'(one core each), no Dask: speed-up {ceil:.2f}×', flush=True)
            wall, rss, failed, kinds, driver = run(paths, n, args.pdf, pin, args.profile,
                                                   args.warm)
            base = base or (wall * n if n != 1 else wall)
            speed = args.gyros * args.hours * 3600.0 / wall
            total = sum(kinds.values())
            print(f'{n} worker(s){" pinned, one core each" if pin else ""}: wall {wall:.1f} s, '
                  f'{wall / args.gyros:.2f} s per gyro, {speed:.0f}× real time, speed-up over '
                  f'1 worker {base / wall:.2f}×, peak RSS per worker '
                  f'{", ".join(f"{r:.0f}" for r, _ in rss)} MB, failed {len(failed)}; '
                  + (f'speed-up / ceiling {base / wall / ceil:.2f}; ' if ceil else '')
                  + f'load average {os.getloadavg()[0]:.1f}', flush=True)
            print(f'  worker CPU {total:.1f} s = {total / wall / n:.2f} cores per worker: '
                  + ', '.join(f'{k} {v:.1f} s' for k, v in sorted(kinds.items(),
                                                                  key=lambda kv: -kv[1]))
                  + f'; driver (scheduler, client, nannies) {driver:.1f} s = '
                  f'{driver / wall:.2f} core', flush=True)
            if alone:
                per_core = wall * n / args.gyros
                print(f'  per-worker-core efficiency: {alone[True][0] / per_core:.2f} against '
                      f'calibrate --out{" --report" if args.pdf else ""}, '
                      f'{alone[False][0] / per_core:.2f} against calibrate --out', flush=True)
            for why in sorted(set(failed)):
                print(f'  failed: {why}')


if __name__ == '__main__':
    main()
