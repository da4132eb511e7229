"""``gyro-calib noise`` all in: ratio to real time and peak memory on 1-hour bags (issue 11 2.6).

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/noise_throughput.py [--hours 1.0] [--quick]
        [--cache /tmp/gyro_calib_bench] [--repeat 2]

Three bags, generated once into ``--cache`` (each in a child process, so the measured child
inherits none of the generator's memory):

* IMU: ``sensor_msgs/Imu`` at 400 Hz plus three 1 Hz Temperature sensors (the generator of
  ``benchmarks/mcap_columns_throughput.py``);
* static RLG: the ``noise_rlg_static`` scenario (dithered RLG at rest) at 1 kHz for the
  whole length, no gap;
* rate-bias bench: the paper's bench, 1 kHz ``/gyro/pulses`` plus 200 Hz joint states and
  zero-index events (``benchmarks/bag_throughput.py``'s bag, Part 1's figure). The table
  turns, so no noise term resolves (exit 1, nothing written): the reading and analysing
  are the same work.

Each is run as ``gyro-calib noise BAG`` alone (decode, Allan sums, joint fit per axis,
summary) and, for the first two, with every output (``--kalibr`` for the IMU, ``--plot``,
``--out``, ``--json``): the console script in a child process, ``--repeat`` times; figures
of the fastest run: wall time, ratio to real time = bag duration / wall (target ≥ 500×),
CPU time of the child (user + system; the machine may be shared — the load average is
printed), input messages per second, and the child's own peak RSS (``ru_maxrss`` through
``wait4``; target < 500 MB). ``--quick`` uses 0.1-hour bags.

``--reference REV`` also runs the same commands on the tree of git revision ``REV`` (its
``gyro_calib`` first on the path), in turn with this tree's runs, and prints each figure's
ratio after/before in CPU time, which the machine's other load disturbs far less than the
wall time (issue 40).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'benchmarks'))

K_RAD_PER_PULSE = 0.84279066 * 3.141592653589793 / 648_000.0
"""The simulated RLG's scale factor (0.84279066″/pulse), rad/pulse."""


def static_rlg_bag(cache: Path, hours: float) -> Path:
    """A dithered RLG at rest, 1 kHz pulses, generated once.

    A dithered RLG at rest, 1 kHz /gyro/pulses (the noise_rlg_static scenario run for
    ``hours`` without its gap), generated once in a child process.
    """
    path = cache / f'rlg_static_1khz_{hours:g}h'
    if not (path / 'metadata.yaml').exists():
        code = ('import dataclasses, sys\n'
                'from sim_nodes.noise.bag_scenarios import SCENARIOS, write_scenario_bag\n'
                "sc = dataclasses.replace(SCENARIOS['noise_rlg_static'], name=sys.argv[2], "
                'duration_s=float(sys.argv[3]), sample_rate_hz=1000.0, gap_s=(1e9, 1e9))\n'
                'write_scenario_bag(sc, sys.argv[1])\n')
        t0 = time.perf_counter()
        subprocess.run([sys.executable, '-c', code, str(path), path.name, str(hours * 3600.0)],
                       check=True, cwd=ROOT)
        print(f'generated {path} in {time.perf_counter() - t0:.1f} s', flush=True)
    return path


REFERENCE: list[str] = []
"""The reference tree's directory, when ``--reference`` is given."""


def run_once(argv: list[str], tree: str | None = None) -> tuple[int, float, float, float, str]:
    """Run ``gyro-calib`` with ``argv`` in a child: (exit, wall s, CPU s, peak RSS MB, stderr).

    ``tree``: a directory whose ``gyro_calib`` is imported instead (the reference run).
    """
    exe = Path(sys.executable).with_name('gyro-calib')
    env = dict(os.environ, PYTHONPATH=tree) if tree else None
    with tempfile.TemporaryFile('w+') as out, tempfile.TemporaryFile('w+') as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen([str(exe), *argv], stdout=out, stderr=err, text=True, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        err.seek(0)
        return (os.waitstatus_to_exitcode(status), wall, usage.ru_utime + usage.ru_stime,
                usage.ru_maxrss / 1024, err.read())


def bench(label: str, bag: Path, topic: str, flags: list[str], repeat: int, *,
          ok_exits: tuple[int, ...] = (0,), files: bool = True) -> None:
    from gyro_calib.bagio import bag_info

    info = bag_info(bag)
    size = sum(f.stat().st_size for f in bag.iterdir()) / 1e6
    print(f'{label}: {bag} — {info.duration_s:.0f} s, {info.message_count} messages, '
          f'{size:.0f} MB; ' + ', '.join(f'{t.name} ({t.msgtype.rsplit("/", 1)[-1]}, '
                                         f'{t.count})' for t in info.topics.values()),
          flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        outs = ['--no-progress'] + (['--plot', f'{tmp}/figures', '--out',
                                     f'{tmp}/handoff.yaml', '--json'] if files else [])
        flags = [f.replace('{tmp}', tmp) for f in flags]
        runs, ref_runs = [], []
        for _ in range(repeat):
            runs.append(run_once(['noise', str(bag), *flags, *outs]))
            if REFERENCE:
                ref_runs.append(run_once(['noise', str(bag), *flags, *outs], REFERENCE[0]))
        written = sorted(p.name for p in Path(tmp).iterdir())
    code, wall, cpu, rss, err = min(runs, key=lambda r: r[1])
    if code not in ok_exits:
        raise SystemExit(f'gyro-calib noise failed (exit {code}): {err.strip()[-500:]}')
    read = info.topics[topic].count
    load = ', '.join(f'{x:.1f}' for x in os.getloadavg())
    print(f'    gyro-calib noise (fastest of {repeat}): wall {wall:.2f} s → '
          f'{info.duration_s / wall:.0f}× real time (target ≥ 500×); CPU {cpu:.2f} s → '
          f'{info.duration_s / cpu:.0f}× on CPU time alone; {read / wall / 1e6:.2f} M input '
          f'messages/s; peak RSS {rss:.0f} MB (target < 500 MB); load average {load}')
    print(f'    exit {code}; all runs (wall s): {", ".join(f"{r[1]:.2f}" for r in runs)}; '
          f'files written: {", ".join(written) or "none"}')
    if ref_runs:
        cpu_ref = min(r[2] for r in ref_runs)
        cpu_new = min(r[2] for r in runs)
        print(f'    against the reference tree, run in turn: CPU {cpu_new:.2f} s against '
              f'{cpu_ref:.2f} s (least of {repeat} each) = {cpu_new / cpu_ref:.2f}; peak RSS '
              f'{min(r[3] for r in runs):.0f} against {min(r[3] for r in ref_runs):.0f} MB')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--hours', type=float, default=1.0)
    parser.add_argument('--quick', action='store_true', help='0.1-hour bags, one run each')
    parser.add_argument('--cache', type=Path, default=Path('/tmp/gyro_calib_bench'))
    parser.add_argument('--repeat', type=int, default=2)
    parser.add_argument('--reference', default='',
                        help='git revision whose gyro_calib is run in turn, for CPU ratios')
    args = parser.parse_args()
    hours, repeat = (0.1, 1) if args.quick else (args.hours, args.repeat)
    if args.reference:
        ref = tempfile.mkdtemp(prefix='gyro_calib_reference_')
        archive = subprocess.run(['git', 'archive', args.reference, 'gyro_calib'], cwd=ROOT,
                                 check=True, capture_output=True).stdout
        subprocess.run(['tar', '-x', '-C', ref], input=archive, check=True)
        REFERENCE.append(ref)
    args.cache.mkdir(parents=True, exist_ok=True)
    print(f'machine: {os.cpu_count()} cores (gyro-calib noise: one thread decoding and '
          f'calibrating, plus one reading and decompressing chunks ahead); load average '
          + ', '.join(f'{x:.1f}' for x in os.getloadavg()), flush=True)
    from mcap_columns_throughput import IMU_TOPIC, contract_bag, imu_bag

    imu = imu_bag(args.cache, hours)
    bench(f'IMU bag ({hours:g} h, 400 Hz Imu, 3 × 1 Hz Temperature), the command alone', imu,
          IMU_TOPIC, ['--topic', IMU_TOPIC], repeat, files=False)
    bench('IMU bag, every file (Kalibr, figure, hand-off, JSON)', imu, IMU_TOPIC,
          ['--topic', IMU_TOPIC, '--kalibr', '{tmp}/imu.yaml'], repeat)
    rlg = static_rlg_bag(args.cache, hours)
    bench(f'static RLG bag ({hours:g} h, 1 kHz /gyro/pulses, dithered), the command alone',
          rlg, '/gyro/pulses', [], repeat, files=False)
    bench('static RLG bag, every file (figure, hand-off, JSON)', rlg, '/gyro/pulses', [],
          repeat)
    bench(f'rate-bias bench bag ({hours:g} h, 1 kHz /gyro/pulses, 200 Hz joint states; the '
          'table turns: no term resolves, exit 1, nothing written)',
          contract_bag(args.cache, hours), '/gyro/pulses',
          ['--scale-factor-rad-per-pulse', repr(K_RAD_PER_PULSE)], repeat, ok_exits=(0, 1))


if __name__ == '__main__':
    main()
