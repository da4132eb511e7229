"""Start-up cost of the ``gyro-calib`` command: this tree against a reference revision.

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/startup_time.py [--reference REV] [--runs 7]

Each command runs as a child of this script, the reference tree's (``git archive REV`` into
a temporary directory) and this tree's in turn, ``--runs`` times; the figure is the child's
CPU time (user + sys, through ``wait4``), whose median is far less sensitive to a loaded
machine than the wall time. The floor is ``python -c "import numpy"``, the least a command
that computes anything pays. Printed: each median, and the ratios after/before and to the
floor (issue 40: imports on demand).
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
COMMANDS = {
    'gyro-calib --help': ['-m', 'gyro_calib.cli', '--help'],
    'gyro-calib noise --help': ['-m', 'gyro_calib.cli', 'noise', '--help'],
    'import gyro_calib.noise': ['-c', 'import gyro_calib.noise'],
}
FLOOR = ['-c', 'import numpy']


def cpu_s(args: list[str], tree: str) -> float:
    """CPU time (user + sys) of ``python ARGS`` with ``tree`` first on the path, s."""
    proc = subprocess.Popen([sys.executable, *args], env=dict(os.environ, PYTHONPATH=tree),
                            stdout=subprocess.DEVNULL, cwd=tempfile.gettempdir())
    _, status, usage = os.wait4(proc.pid, 0)
    if status != 0:
        raise SystemExit(f'{args} failed in {tree} (status {status})')
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--reference', default='c826ee9',
                        help='git revision to compare against (default: the tree before '
                             'issue 40)')
    parser.add_argument('--runs', type=int, default=7)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as ref:
        archive = subprocess.run(['git', 'archive', args.reference, 'gyro_calib'], cwd=ROOT,
                                 check=True, capture_output=True).stdout
        subprocess.run(['tar', '-x', '-C', ref], input=archive, check=True)
        trees = {'before': ref, 'after': str(ROOT)}
        got: dict[tuple[str, str], list[float]] = {}
        for _ in range(args.runs):
            for name, cmd in COMMANDS.items():
                for label, tree in trees.items():
                    got.setdefault((name, label), []).append(cpu_s(cmd, tree))
            got.setdefault(('floor', ''), []).append(cpu_s(FLOOR, str(ROOT)))
    med = {k: statistics.median(v) for k, v in got.items()}
    floor = med[('floor', '')]
    print(f'start-up CPU time (user + sys), median of {args.runs} runs each, interleaved; '
          f'load average {os.getloadavg()[0]:.1f}; reference {args.reference}')
    print(f'  floor: python -c "import numpy": {floor:.3f} s')
    for name in COMMANDS:
        b, a = med[(name, 'before')], med[(name, 'after')]
        print(f'  {name}: before {b:.3f} s ({b / floor:.2f}× the floor), after {a:.3f} s '
              f'({a / floor:.2f}× the floor): after/before = {a / b:.2f}')


if __name__ == '__main__':
    main()
