"""Bag throughput: ``gyro-calib calibrate`` on a 1-hour 1 kHz bag, and DDS replay loss.

Run (from the repository root, in the project's venv):

    python benchmarks/bag_throughput.py [--hours 1.0] [--cache /tmp/gyro_calib_bench]
        [--replay-duration 300] [--skip-offline] [--skip-floor] [--skip-replay]

(a) Offline. A rate-bias bench bag of ``--hours`` (paper bench, 1 kHz pulses, 200 Hz
    joint states; generated once into ``--cache``) is calibrated by the ``gyro-calib
    calibrate`` console script in a child process, ``--runs`` times after a warm-up, in
    turn with the same command on the ``--reference`` revision's tree and the floors
    (``python -c "import numpy"``; the bag's decode alone by our columnar reader).
    Figures: wall and CPU time (min, median), throughput = bag duration / wall time
    (issue 40 goal ≥ 1500×), peak RSS of the child (goal < 200 MB), the ratios
    after/before and to the floors, K̃ pairs found, and where the time goes (imports,
    decode, the RBRLG calibration, the rest: ``benchmarks/where_time_goes.py``).

(b) Reader floor. The same bag iterated by the MCAP readers we may use (rosbags'
    Reader, the mcap library's reader), undecoded and with rosbags' CDR deserialiser, in
    this process: per-message cost and the throughput each would cap
    ``gyro-calib calibrate`` at even if calibrating cost nothing. 500× on a 1 kHz bag
    needs ≤ 1/(500 · messages per second) per message, all in.

(c) DDS replay. A ``--replay-duration`` bag is played by ``bag_player`` as fast as the
    readers acknowledge (rate 0) into ``calibration_node`` and ``bag_recorder`` on a
    private loopback domain. Figures: messages in the bag, recorded by the recorder,
    lost (= difference, target 0), replay speed (bag duration / wall time of the
    player), end to end (bag duration / time until the node logs the offline pair count:
    a short bag fits in the DDS queues, so the player can finish long before the node),
    and whether the node's K̃ equals the offline one bit for bit.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
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
                'from sim_nodes.rbrlg.scenarios import SCENARIOS, write_scenario_bag\n'
                "base = SCENARIOS['k_tilde_bench']\n"
                'sc = dataclasses.replace(base, name=sys.argv[2], table=dataclasses.replace('
                'base.table, duration_s=float(sys.argv[3])), description=('
                '"The paper\'s rate-bias bench (m = 5, 150 °/s, 1 kHz) run for " + sys.argv[3] '
                '+ " s."), expected={})\n'
                'write_scenario_bag(sc, sys.argv[1])\n')
        t0 = time.perf_counter()
        subprocess.run([sys.executable, '-c', code, str(path), name, str(duration_s)],
                       check=True, cwd=Path(__file__).resolve().parent.parent)
        print(f'generated {path} in {time.perf_counter() - t0:.1f} s')
    return path


DECODE = ('import sys\n'
          'from gyro_calib.bagio.reader import iter_sample_batches\n'
          'n = 0\n'
          'for batch in iter_sample_batches(sys.argv[1]):\n'
          '    n += batch.messages\n'
          'assert n > 0\n')
"""The floor: the bag's contract topics decoded by our columnar reader, nothing calibrated."""

PARTS = ['decode=gyro_calib.bag_calibration:iter_bags:iter',
         'RBRLG calibration=gyro_calib.rbrlg.session:RbrlgSession.feed',
         'RBRLG calibration=gyro_calib.rbrlg.session:RbrlgSession.process',
         'RBRLG calibration=gyro_calib.rbrlg.session:RbrlgSession.results']
"""The stopwatch's parts (benchmarks/where_time_goes.py); imports and the rest besides."""


def _child(args: list[str], tree: str) -> tuple[int, float, float, float, str]:
    """Run ``args`` with ``tree`` first on the path: (exit, wall s, CPU s, peak RSS MB, out).

    wait4 gives this child's own rusage; RUSAGE_CHILDREN would also count the bag
    generator child (≈ 630 MB for the 1-hour bag).
    """
    env = dict(os.environ, PYTHONPATH=tree, OPENBLAS_NUM_THREADS='1')
    env.pop('PYTHONDONTWRITEBYTECODE', None)  # an installed package has its .pyc
    with tempfile.TemporaryFile('w+') as out:
        t0 = time.perf_counter()
        proc = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, text=True, env=env,
                                cwd=tempfile.gettempdir())
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        out.seek(0)
        text = out.read()
    return (os.waitstatus_to_exitcode(status), wall, usage.ru_utime + usage.ru_stime,
            usage.ru_maxrss / 1024, text)


def offline(cache: Path, hours: float, runs: int = 3, reference: str = '') -> None:
    """``gyro-calib calibrate`` of the bag, ``runs`` times, in turn with reference and floors."""
    import statistics

    from gyro_calib.bagio import bag_info

    bag = _bag(cache, f'k_tilde_{hours:g}h', hours * 3600.0)
    info = bag_info(bag)
    size = sum(f.stat().st_size for f in bag.iterdir()) / 1e6
    exe = str(Path(sys.executable).with_name('gyro-calib'))
    root = str(Path(__file__).resolve().parent.parent)
    command = [exe, 'calibrate', str(bag), '--no-progress']
    commands = {'after (this tree)': (command, root)}
    floors = {'floor: python -c "import numpy"': [sys.executable, '-c', 'import numpy'],
              'floor: decode alone (columnar reader, contract topics)':
                  [sys.executable, '-c', DECODE, str(bag)]}
    with tempfile.TemporaryDirectory() as ref:
        if reference:
            archive = subprocess.run(['git', 'archive', reference, 'gyro_calib'], cwd=root,
                                     check=True, capture_output=True).stdout
            subprocess.run(['tar', '-x', '-C', ref], input=archive, check=True)
            commands = {f'before ({reference})': (command, ref), **commands}
        commands.update({k: (v, root) for k, v in floors.items()})
        for args, tree in commands.values():  # warm-up: .pyc written, the bag in the cache
            if args is command:
                _child(args, tree)
        got: dict[str, list[tuple[int, float, float, float, str]]] = {}
        for _ in range(runs):
            for label, (args, tree) in commands.items():
                got.setdefault(label, []).append(_child(args, tree))
        stopwatch = _child([sys.executable, str(Path(__file__).with_name('where_time_goes.py')),
                            *PARTS, '--', 'calibrate', str(bag), '--no-progress'], root)
    load = ', '.join(f'{x:.1f}' for x in os.getloadavg())
    print(f'(a) offline: bag {info.duration_s:.0f} s, {info.message_count} messages, '
          f'{size:.1f} MB; {runs} runs each, in turn; load average {load}')
    med: dict[str, tuple[float, float]] = {}
    for label, rs in got.items():
        if any(r[0] != 0 for r in rs):
            raise SystemExit(f'{label} failed: {rs[0][4].strip()[-300:]}')
        walls, cpus = [r[1] for r in rs], [r[2] for r in rs]
        med[label] = (statistics.median(walls), statistics.median(cpus))
        print(f'    {label}: wall min {min(walls):.2f} s, median {med[label][0]:.2f} s → '
              f'{info.duration_s / min(walls):.0f}× / {info.duration_s / med[label][0]:.0f}× '
              f'real time; CPU min {min(cpus):.2f} s, median {med[label][1]:.2f} s → '
              f'{info.duration_s / med[label][1]:.0f}× on CPU time; peak RSS '
              f'{max(r[3] for r in rs):.0f} MB')
    after = med['after (this tree)']
    if reference:
        before = med[f'before ({reference})']
        print(f'    after/before (medians): wall {after[0] / before[0]:.2f}, CPU '
              f'{after[1] / before[1]:.2f}')
    for label in floors:
        print(f'    after / {label.split(": ", 1)[1]} (CPU medians): '
              f'{after[1] / med[label][1]:.2f}')
    best = min(r[1] for r in got['after (this tree)'])
    print(f'    goal ≥ 1500× real time, < 200 MB: {info.duration_s / best:.0f}× at the fastest '
          f'run, {max(r[3] for r in got["after (this tree)"]):.0f} MB')
    pairs = [ln for ln in got['after (this tree)'][0][4].splitlines() if 'pairs' in ln]
    print(f'    {pairs[0].strip() if pairs else "no K̃ pairs line"}')
    whole, parts = eval(stopwatch[4].strip().splitlines()[-1])
    print(f'    where the time goes (one more run, wall {whole:.2f} s; exclusive, imports '
          f'wherever they happen): ' + ', '.join(
              f'{k} {v:.2f} s ({100 * v / whole:.0f} %)' for k, v in parts.items()))


def reader_floor(cache: Path, hours: float) -> None:
    from mcap.reader import make_reader
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    from gyro_calib.bagio import bag_info

    bag = _bag(cache, f'k_tilde_{hours:g}h', hours * 3600.0)
    info = bag_info(bag)
    budget_us = 1e6 / (500.0 * info.message_count / info.duration_s)
    print(f'(b) reader floor on {info.message_count} messages over {info.duration_s:.0f} s: '
          f'500× allows {budget_us:.2f} µs per message in total')

    def report(label: str, seconds: float, n: int) -> None:
        print(f'    {label}: {seconds:.1f} s, {seconds / n * 1e6:.2f} µs/message, caps '
              f'throughput at {info.duration_s / seconds:.0f}× real time')

    t0, n = time.perf_counter(), 0
    with Reader(bag) as reader:
        for _ in reader.messages():
            n += 1
    report('rosbags Reader.messages(), undecoded', time.perf_counter() - t0, n)
    mcap_file = next(bag.glob('*.mcap'))
    t0, n = time.perf_counter(), 0
    with mcap_file.open('rb') as f:
        for _ in make_reader(f).iter_messages():
            n += 1
    report('mcap make_reader().iter_messages(), undecoded', time.perf_counter() - t0, n)
    deserialize = get_typestore(Stores.ROS2_KILTED).deserialize_cdr
    t0, n = time.perf_counter(), 0
    with Reader(bag) as reader:
        for con, _, raw in reader.messages():
            deserialize(raw, con.msgtype)
            n += 1
    report('rosbags Reader.messages() + deserialize_cdr', time.perf_counter() - t0, n)


def replay(cache: Path, duration_s: float) -> None:
    from gyro_calib.bag_calibration import calibrate_bags
    from gyro_calib.bagio import bag_info
    from gyro_calib.nodes.processes import ros_environment, start_node

    bag = _bag(cache, f'k_tilde_{duration_s:g}s', duration_s)
    info = bag_info(bag)
    offline_k = calibrate_bags([bag]).sessions['rbrlg'].rbrlg_results.k_tilde_arcsec_per_pulse
    final_line = f'({offline_k.n_used} pairs)' if offline_k else '(no result expected)'
    env = ros_environment(101 + os.getpid() % 100)
    out = Path(tempfile.mkdtemp()) / 'replayed'
    node = start_node('calibration_node', {'output_file': ''}, env, stderr=subprocess.PIPE,
                      text=True)
    node_lines: list[tuple[float, str]] = []
    reader = threading.Thread(target=lambda: node_lines.extend(
        (time.perf_counter(), ln) for ln in node.stderr), daemon=True)
    reader.start()
    recorder = start_node('bag_recorder', {'out': str(out)}, env, stderr=subprocess.PIPE,
                          text=True)
    time.sleep(2.0)
    t_play = time.perf_counter()
    player = start_node('bag_player', {'bag': str(bag), 'rate': 0.0}, env,
                        stderr=subprocess.PIPE, text=True)
    _, player_log = player.communicate(timeout=3600)
    # The player is done once the readers' DDS layers acknowledged; the node may still be
    # working through its queue. End to end = until it logs the offline pair count.
    deadline = time.perf_counter() + 600.0
    while time.perf_counter() < deadline and node.poll() is None and not any(
            'K̃ =' in ln and final_line in ln for _, ln in list(node_lines)):
        time.sleep(0.2)
    done = [t for t, ln in list(node_lines) if 'K̃ =' in ln and final_line in ln]
    for proc in (node, recorder):
        proc.send_signal(2)
    recorder.communicate(timeout=60)
    node.wait(timeout=60)
    reader.join(timeout=10)
    recorded = bag_info(out)
    sent = info.message_count
    got = recorded.message_count
    played = [ln for ln in player_log.splitlines() if 'played' in ln]
    live = [ln for _, ln in node_lines if 'K̃ =' in ln]
    print(f'(c) DDS replay of {info.duration_s:.0f} s ({sent} messages): recorded {got}, '
          f'lost {sent - got}; per topic: ' + ', '.join(
              f'{t}: {info.topics[t].count - recorded.topics[t].count}'
              for t in info.topics if t in recorded.topics))
    print(f'    player: {played[-1].split("]: ")[-1] if played else player_log[-300:]}')
    print('    end to end (player start → node logs the last pair): ' + (
        f'{done[0] - t_play:.1f} s, {info.duration_s / (done[0] - t_play):.2f}× real time'
        if done else 'the node never reached the offline pair count'))
    print(f'    node last: {live[-1].split("]: ")[-1].strip() if live else "no K̃"}; offline K̃ '
          + (f'{offline_k.value:.10f} ″/pulse ({offline_k.n_used} pairs)' if offline_k
             else 'none'))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--hours', type=float, default=1.0)
    parser.add_argument('--cache', type=Path, default=Path('/tmp/gyro_calib_bench'))
    parser.add_argument('--replay-duration', type=float, default=300.0)
    parser.add_argument('--skip-replay', action='store_true')
    parser.add_argument('--skip-offline', action='store_true')
    parser.add_argument('--skip-floor', action='store_true')
    parser.add_argument('--runs', type=int, default=3, help='(a): runs of each command')
    parser.add_argument('--reference', default='d233d2c',
                        help="(a): git revision whose gyro_calib is run in turn ('' for none)")
    args = parser.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    if not args.skip_offline:
        offline(args.cache, args.hours, args.runs, args.reference)
    if not args.skip_floor:
        reader_floor(args.cache, args.hours)
    if not args.skip_replay:
        replay(args.cache, args.replay_duration)


if __name__ == '__main__':
    main()
