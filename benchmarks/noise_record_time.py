"""``gyro-calib noise`` of a 500 000-sample 6-axis IMU record, all in (issue 40 (b)).

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/noise_record_time.py [--samples 500000] [--runs 3]
        [--reference REV] [--cache /tmp/gyro_calib_bench]

The record: a static IMU, ``sensor_msgs/Imu`` at 400 Hz (gyro and accelerometer, six axes)
plus three 1 Hz temperature sensors (``benchmarks/mcap_columns_throughput.py``'s generator),
``--samples`` messages, generated once into ``--cache``.

``gyro-calib noise BAG --no-progress`` runs as a child — this tree's and, in turn, the
reference tree's (``git archive REV``; default the tree before issue 40's EDF work) —
``--runs`` times each after one warm-up each (byte-compiled modules written, as an installed
package has them). Figures: wall time (min and median; the goal ≤ 2.0 s), the child's CPU
time (user + sys through ``wait4``, less disturbed by other processes on the cores), peak
RSS, and after/before ratios of both. Floors, run in turn with them: ``python -c "import
numpy"`` (the least any command pays) and the record's decode alone (the columnar reader
over the IMU topic, no calibration). Where the time goes: one more run of this tree under
a stopwatch (imports, decode, Allan sums and screen, term fit, rest; each exclusive of
the others). The load average is printed.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'benchmarks'))

DECODE = ('import sys\n'
          'from gyro_calib.bagio.reader import iter_sample_batches\n'
          'n = 0\n'
          'for batch in iter_sample_batches(sys.argv[1], {sys.argv[2]: sys.argv[3]}):\n'
          '    n += batch.messages\n'
          'assert n > 0\n')

PARTS = ['decode=gyro_calib.bag_calibration:iter_bags:iter',
         'Allan sums and screen=gyro_calib.noise.session:NoiseSession.feed',
         'Allan sums and screen=gyro_calib.noise.session:NoiseSession.process',
         'term fit=gyro_calib.noise.axis:fit_noise_terms']
"""The stopwatch's parts (benchmarks/where_time_goes.py); imports and the rest besides."""


def child(args: list[str], tree: str) -> tuple[float, float, float, str]:
    """Run ``args`` with ``tree`` first on the path: (wall s, CPU s, peak RSS MB, stdout)."""
    import time

    env = dict(os.environ, PYTHONPATH=tree, OPENBLAS_NUM_THREADS='1')
    env.pop('PYTHONDONTWRITEBYTECODE', None)  # an installed package has its .pyc
    with tempfile.TemporaryFile('w+') as out:
        t0 = time.perf_counter()
        proc = subprocess.Popen(args, stdout=out, stderr=subprocess.DEVNULL, env=env,
                                cwd=tempfile.gettempdir())
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        out.seek(0)
        text = out.read()
    if os.waitstatus_to_exitcode(status) not in (0, 1):
        raise SystemExit(f'{args[:3]} failed in {tree} (status {status})')
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024, text


def summary(runs: list[tuple[float, float, float, str]]) -> str:
    walls, cpus = [r[0] for r in runs], [r[1] for r in runs]
    return (f'wall min {min(walls):.2f} s, median {statistics.median(walls):.2f} s; CPU min '
            f'{min(cpus):.2f} s, median {statistics.median(cpus):.2f} s; peak RSS '
            f'{max(r[2] for r in runs):.0f} MB')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--samples', type=int, default=500_000)
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--reference', default='d233d2c',
                        help='git revision to compare against (default: before issue 40 (b))')
    parser.add_argument('--cache', type=Path, default=Path('/tmp/gyro_calib_bench'))
    args = parser.parse_args()
    from mcap_columns_throughput import IMU_RATE_HZ, IMU_TOPIC, imu_bag

    from gyro_calib.bagio.messages import IMU

    args.cache.mkdir(parents=True, exist_ok=True)
    bag = imu_bag(args.cache, args.samples / IMU_RATE_HZ / 3600.0)
    exe = str(Path(sys.executable).with_name('gyro-calib'))
    command = [exe, 'noise', str(bag), '--no-progress']
    floors = {'python -c "import numpy"': [sys.executable, '-c', 'import numpy'],
              'decode alone': [sys.executable, '-c', DECODE, str(bag), IMU_TOPIC, IMU]}
    with tempfile.TemporaryDirectory() as ref:
        archive = subprocess.run(['git', 'archive', args.reference, 'gyro_calib'], cwd=ROOT,
                                 check=True, capture_output=True).stdout
        subprocess.run(['tar', '-x', '-C', ref], input=archive, check=True)
        trees = {'before': ref, 'after': str(ROOT)}
        for tree in trees.values():  # warm-up: byte-compiled modules, the bag in the cache
            child(command, tree)
        got: dict[str, list[tuple[float, float, float, str]]] = {}
        for _ in range(args.runs):
            for label, tree in trees.items():
                got.setdefault(label, []).append(child(command, tree))
            for label, cmd in floors.items():
                got.setdefault(label, []).append(child(cmd, str(ROOT)))
        profiled = child([sys.executable, str(ROOT / 'benchmarks' / 'where_time_goes.py'),
                          *PARTS, '--', 'noise', str(bag), '--no-progress'], str(ROOT))[3]
        whole, parts = eval(profiled.strip().splitlines()[-1])
    load = ', '.join(f'{x:.1f}' for x in os.getloadavg())
    print(f'gyro-calib noise of {bag.name} ({args.samples} Imu messages, 6 axes, 400 Hz); '
          f'{args.runs} runs each, interleaved; load average {load}')
    for label in ('before', 'after', *floors):
        name = {'before': f'before ({args.reference})', 'after': 'after (this tree)'}.get(
            label, f'floor: {label}')
        print(f'  {name}: {summary(got[label])}')
    med = {k: (statistics.median(r[0] for r in v), statistics.median(r[1] for r in v))
           for k, v in got.items()}
    print(f'  after/before: wall {med["after"][0] / med["before"][0]:.2f}, CPU '
          f'{med["after"][1] / med["before"][1]:.2f} (medians)')
    numpy_floor = med[next(iter(floors))][1]
    print(f'  after against the floors (CPU medians): {med["after"][1] / numpy_floor:.1f}× '
          f'import numpy, {med["after"][1] / med["decode alone"][1]:.1f}× the decode alone')
    best = min(r[0] for r in got['after'])
    print(f'  goal ≤ 2.0 s all in: {"met" if best <= 2.0 else "not met"} (min wall {best:.2f} s, '
          f'median {med["after"][0]:.2f} s)')
    print(f'  where the time goes (this tree, one more run, wall {whole:.2f} s; exclusive, '
          f'imports wherever they happen): ' + ', '.join(
              f'{k} {v:.2f} s ({100 * v / whole:.0f} %)' for k, v in parts.items()))


if __name__ == '__main__':
    main()
