"""DDS replay under load: each committed bag into its live node, N times, beside CPU burners.

A live node must give the offline numbers whatever the replay speed and the machine's load
(issue 24 part 5(a); docs/methods.md, "Live input in stamp order"), or reject the window a
late sample spoils with a line. For every committed bag a live calibration node takes
(rbrlg, FOG, dither, thermal, noise), this script computes the hand-off file offline
(``gyro-calib calibrate --out``; ``gyro-calib noise --out`` for the noise bags), then N times
starts the method's node with the bag's bench settings, plays the bag with ``bag_player``
(unpaced by default) while ``--burners`` processes spin the CPU, stops the node once its
hand-off file has stopped changing, and compares the ``gyro`` section of the two files
exactly. It prints one row per bag: runs, runs that differ, runs whose node logged a late
sample (a window rejected for it, or a method's warning), seconds per run.

    PYTHONPATH=$PWD python benchmarks/dds_replay_under_load.py            # 20 runs per bag
    PYTHONPATH=$PWD python benchmarks/dds_replay_under_load.py --runs 2 --bags fog_turntable

Goal: 0 differing runs. Each run takes about as long as the node needs for the bag (a 1 kHz
RLG bag about a minute on 2 cores): the full table is hours; ``--runs`` and ``--bags`` cut it.
The DDS domain is ``--domain`` (default ``$ROS_DOMAIN_ID`` or 150), discovery localhost only.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'
NODES = {'rbrlg': 'calibration_node', 'fog': 'fog_calibration_node',
         'dither': 'dither_calibration_node', 'thermal': 'thermal_calibration_node',
         'noise': 'noise_node'}
"""Method → the live node that calibrates it."""
LATE_MARKS = ('reached the node after later stamps', 'arrived after later stamps')
"""What a node logs when a sample came later than its input hold (a rejected window)."""
QUIET_S = 10.0
"""The node is stopped once its hand-off file has not changed for this long, s (more than
the input hold and the thermal node's fit-after-idle)."""


def bag_method(bag: Path) -> str | None:
    """The method a live node calibrates from ``bag`` (None: no node takes it)."""
    from gyro_calib.bag_calibration import calibrate_bags
    from gyro_calib.bagio import bag_info
    from gyro_calib.errors import GyroCalibError

    if 'topic' in (bag_info(bag).scenario.get('bench') or {}):
        return 'noise'
    try:
        sessions = list(calibrate_bags([bag]).sessions)
    except GyroCalibError:
        return None
    return sessions[0] if len(sessions) == 1 else None


def node_parameters(bag: Path, method: str) -> dict[str, Any]:
    """The bench settings the bag records that the method's node takes as parameters."""
    from gyro_calib.bagio import bag_info
    from gyro_calib.registry import METHODS

    bench = bag_info(bag).scenario.get('bench') or {}
    names = set(METHODS[method].bench_settings) if method in METHODS else set()
    if method == 'noise':
        names |= {'topic', 'scale_factor_rad_per_pulse'}
    return {k: v for k, v in bench.items() if k in names and v is not None}


def offline_gyro(bag: Path, method: str, out: Path,
                 env: dict[str, str]) -> dict[str, Any] | None:
    """The ``gyro`` section of the hand-off file ``gyro-calib`` writes offline.

    None when it writes none (nothing to calibrate in the bag: exit status 1).
    """
    cmd = (['noise', str(bag)] if method == 'noise'
           else ['calibrate', str(bag), '--method', method])
    done = subprocess.run([sys.executable, '-m', 'gyro_calib.cli', *cmd, '--out', str(out),
                           '--no-progress'], env=env, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, cwd=out.parent)
    if done.returncode not in (0, 1):
        raise RuntimeError(f'{" ".join(cmd)}: {done.stderr.decode(errors="replace")}')
    if not out.exists():
        return None
    return dict(yaml.safe_load(out.read_text())['gyro'])


def _mtime(path: Path) -> float | None:
    try:
        return path.stat().st_mtime_ns / 1e9
    except FileNotFoundError:
        return None


def live_run(bag: Path, method: str, rate: float, workdir: Path,
             env: dict[str, str]) -> tuple[dict[str, Any] | None, str]:
    """One replay into the node; the ``gyro`` section it wrote (None: none) and its log."""
    from gyro_calib.nodes.processes import start_node

    out = workdir / 'live.yaml'
    params = {**node_parameters(bag, method), 'output_file': str(out)}
    log = workdir / 'node.log'
    with open(log, 'wb') as node_err, open(workdir / 'player.log', 'wb') as player_err:
        node = start_node(NODES[method], params, env, stdout=subprocess.DEVNULL,
                          stderr=node_err, cwd=workdir)
        try:
            player = start_node('bag_player', {'bag': str(bag), 'rate': rate}, env,
                                stdout=subprocess.DEVNULL, stderr=player_err, cwd=workdir)
            player.wait(timeout=1800)
            seen, since = _mtime(out), time.monotonic()
            while time.monotonic() - since < QUIET_S and node.poll() is None:
                time.sleep(0.5)
                now = _mtime(out)
                if now != seen:
                    seen, since = now, time.monotonic()
            node.send_signal(signal.SIGINT)
            node.wait(timeout=300)
        finally:
            if node.poll() is None:
                node.kill()
                node.wait()
    text = log.read_text(errors='replace')
    if not out.exists():
        return None, text
    return dict(yaml.safe_load(out.read_text())['gyro']), text


def main(argv: list[str] | None = None) -> int:
    """Print the table bag × runs × differing; exit 1 if any run differed."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--runs', type=int, default=20, help='replays per bag (20)')
    parser.add_argument('--burners', type=int, default=2, help='CPU-burning processes (2)')
    parser.add_argument('--rate', type=float, default=0.0,
                        help='bag_player rate (0 = unpaced, as fast as the readers ack)')
    parser.add_argument('--bags', nargs='*', default=None,
                        help='bag names under bags/ (default: every bag a live node takes)')
    parser.add_argument('--domain', type=int,
                        default=int(os.environ.get('ROS_DOMAIN_ID', '150')),
                        help='ROS_DOMAIN_ID of the runs')
    args = parser.parse_args(argv)
    if args.runs < 1 or args.burners < 0:
        print('--runs must be at least 1 and --burners not negative.', file=sys.stderr)
        return 2
    names = args.bags or sorted(p.name for p in BAGS.iterdir() if p.is_dir())
    missing = [n for n in names if not (BAGS / n).is_dir()]
    if missing:
        print(f'no bag {", ".join(missing)} under {BAGS}: give names of bags/ entries.',
              file=sys.stderr)
        return 2
    env = {**os.environ, 'ROS_DOMAIN_ID': str(args.domain),
           'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'PYTHONPATH': os.pathsep.join(filter(None, (str(ROOT),
                                                      os.environ.get('PYTHONPATH'))))}
    burners = [subprocess.Popen([sys.executable, '-c', 'while True: pass'])
               for _ in range(args.burners)]
    any_differs = False
    try:
        print(f'{"bag":34s} {"method":8s} {"runs":>4s} {"differ":>6s} {"late":>4s} '
              f'{"s/run":>6s}', flush=True)
        for name in names:
            bag = BAGS / name
            method = bag_method(bag)
            if method is None:
                continue
            with tempfile.TemporaryDirectory(prefix=f'replay_{name}_') as tmp:
                expected = offline_gyro(bag, method, Path(tmp) / 'offline.yaml', env)
                differ = late = 0
                started = time.monotonic()
                for run in range(args.runs):
                    workdir = Path(tmp) / f'run{run}'
                    workdir.mkdir()
                    got, log = live_run(bag, method, args.rate, workdir, env)
                    told = [line for line in log.splitlines()
                            if any(mark in line for mark in LATE_MARKS)]
                    late += bool(told)
                    for line in told[:2]:
                        print(f'  {name} run {run}: {line}', file=sys.stderr, flush=True)
                    if got != expected:
                        differ += 1
                        diff = sorted(k for k in set(expected or {}) | set(got or {})
                                      if (got or {}).get(k) != (expected or {}).get(k))
                        print(f'  {name} run {run}: differs in {", ".join(diff[:6])}',
                              file=sys.stderr, flush=True)
                per_run = (time.monotonic() - started) / args.runs
            any_differs |= differ > 0
            print(f'{name:34s} {method:8s} {args.runs:4d} {differ:6d} {late:4d} '
                  f'{per_run:6.1f}', flush=True)
    finally:
        for proc in burners:
            proc.kill()
            proc.wait()
    return 1 if any_differs else 0


if __name__ == '__main__':
    raise SystemExit(main())
