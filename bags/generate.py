#!/usr/bin/env python3
"""Regenerate the committed scenario bags and their expected results (deterministic).

    python bags/generate.py                 # every scenario, into bags/
    python bags/generate.py --out DIR NAME  # chosen scenarios, elsewhere

Each scenario gives ``<name>/`` (rosbag2 MCAP bag) and ``<name>.expected.yaml`` (truth,
tolerances, expected counts and rejection reasons). Existing outputs are replaced.
test/test_bags.py regenerates every bag and compares it message for message.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sim_nodes.scenarios import SCENARIOS, write_scenario_files  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('names', nargs='*',
                        help=f'scenarios (default all: {", ".join(SCENARIOS)})')
    parser.add_argument('--out', type=Path, default=Path(__file__).resolve().parent)
    args = parser.parse_args()
    for name in args.names or list(SCENARIOS):
        bag = args.out / name
        if bag.exists():
            shutil.rmtree(bag)
        write_scenario_files(name, args.out)
        size = sum(f.stat().st_size for f in bag.iterdir()) / 1e6
        print(f'{name}: {size:.2f} MB')


if __name__ == '__main__':
    main()
