"""Bag throughput: ``gyro-calib calibrate`` on a 1-hour 1 kHz bag, and DDS replay loss.

Run (from the repository root, in the project's venv):

    python benchmarks/bag_throughput.py [--hours 1.0] [--cache /tmp/gyro_calib_bench]
        [--replay-duration 300] [--skip-replay]

(a) Offline. A rate-bias bench bag of ``--hours`` (paper bench, 1 kHz pulses, 200 Hz
    joint states; generated once into ``--cache``) is calibrated by the ``gyro-calib
    calibrate`` console script in a child process. Figures: wall time, throughput =
    bag duration / wall time (target ≥ 500×), peak RSS of the child (target < 500 MB),
    K̃ pairs found.

(b) DDS replay. A ``--replay-duration`` bag is played by ``bag_player`` as fast as the
    readers acknowledge (rate 0) into ``calibration_node`` and ``bag_recorder`` on a
    private loopback domain. Figures: messages in the bag, recorded by the recorder,
    lost (= difference, target 0), replay speed (bag duration / wall time of the
    player), and whether the node's K̃ equals the offline one bit for bit.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def _bag(cache: Path, name: str, duration_s: float) -> Path:
    """The k_tilde_bench scenario stretched to ``duration_s``, generated once into ``cache``.

    Generated in a child process: a child forked from a large parent inherits its resident
    pages, which would inflate the peak RSS measured for ``gyro-calib`` below.
    """
    path = cache / name
    if not (path / 'metadata.yaml').exists():
        code = ('import dataclasses, sys\n'
                'from sim_nodes.scenarios import SCENARIOS, write_scenario_bag\n'
                "base = SCENARIOS['k_tilde_bench']\n"
                'sc = dataclasses.replace(base, name=sys.argv[2], table=dataclasses.replace('
                'base.table, duration_s=float(sys.argv[3])))\n'
                'write_scenario_bag(sc, sys.argv[1])\n')
        t0 = time.perf_counter()
        subprocess.run([sys.executable, '-c', code, str(path), name, str(duration_s)],
                       check=True, cwd=Path(__file__).resolve().parent.parent)
        print(f'generated {path} in {time.perf_counter() - t0:.1f} s')
    return path


def offline(cache: Path, hours: float) -> None:
    from gyro_calib.bag import bag_info

    bag = _bag(cache, f'k_tilde_{hours:g}h', hours * 3600.0)
    info = bag_info(bag)
    size = sum(f.stat().st_size for f in bag.iterdir()) / 1e6
    exe = Path(sys.executable).with_name('gyro-calib')
    parent_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    t0 = time.perf_counter()
    proc = subprocess.run([str(exe), 'calibrate', str(bag), '--no-progress'],
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    pairs = [ln for ln in proc.stdout.splitlines() if 'pairs' in ln]
    print(f'(a) offline: bag {info.duration_s:.0f} s, {info.message_count} messages, '
          f'{size:.1f} MB')
    print(f'    gyro-calib calibrate: exit {proc.returncode}, wall {wall:.1f} s, '
          f'throughput {info.duration_s / wall:.1f}× real time '
          f'({info.message_count / wall / 1e3:.1f} k msg/s), peak RSS {peak_mb:.0f} MB '
          f'(child ru_maxrss; includes up to {parent_mb:.0f} MB inherited at fork)')
    print(f'    {pairs[0] if pairs else proc.stderr.strip()[-300:]}')


def replay(cache: Path, duration_s: float) -> None:
    import tempfile

    from gyro_calib import topics
    from gyro_calib.bag import bag_info
    from gyro_calib.bag_calibration import calibrate_bag
    from gyro_calib.nodes.processes import ros_environment, start_node

    bag = _bag(cache, f'k_tilde_{duration_s:g}s', duration_s)
    info = bag_info(bag)
    env = ros_environment(101 + os.getpid() % 100)
    out = Path(tempfile.mkdtemp()) / 'replayed'
    procs = [start_node('calibration_node', {}, env, stderr=subprocess.PIPE, text=True),
             start_node('bag_recorder', {'out': str(out)}, env, stderr=subprocess.PIPE,
                        text=True)]
    time.sleep(2.0)
    player = start_node('bag_player', {'bag': str(bag), 'rate': 0.0}, env,
                        stderr=subprocess.PIPE, text=True)
    _, player_log = player.communicate(timeout=3600)
    time.sleep(3.0)
    logs = []
    for p in procs:
        p.send_signal(2)
        logs.append(p.communicate(timeout=60)[1])
    recorded = bag_info(out)
    sent = info.message_count
    got = recorded.message_count
    played = [ln for ln in player_log.splitlines() if 'played' in ln]
    offline_k = calibrate_bag(bag).results.k_tilde_arcsec_per_pulse
    live = [ln for ln in logs[0].splitlines() if 'K̃ =' in ln]
    print(f'(b) DDS replay of {info.duration_s:.0f} s ({sent} messages): recorded {got}, '
          f'lost {sent - got}; per topic: ' + ', '.join(
              f'{t}: {info.topics[t].count - recorded.topics[t].count}'
              for t in info.topics if t in recorded.topics))
    print(f'    player: {played[-1].split("]: ")[-1] if played else player_log[-300:]}')
    print(f'    node last: {live[-1].split("]: ")[-1] if live else "no K̃"}; offline K̃ '
          f'{offline_k.value:.10f} ″/pulse ({offline_k.n_used} pairs)' if offline_k else '')
    del topics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--hours', type=float, default=1.0)
    parser.add_argument('--cache', type=Path, default=Path('/tmp/gyro_calib_bench'))
    parser.add_argument('--replay-duration', type=float, default=300.0)
    parser.add_argument('--skip-replay', action='store_true')
    parser.add_argument('--skip-offline', action='store_true')
    args = parser.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    if not args.skip_offline:
        offline(args.cache, args.hours)
    if not args.skip_replay:
        replay(args.cache, args.replay_duration)


if __name__ == '__main__':
    main()
