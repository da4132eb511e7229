"""Draw the figures the methods produce into docs/methods/figures/ (the figures page shows them).

    PYTHONPATH=. python docs/make_figures.py

Each figure is what ``--plot DIR`` writes for a committed bag (``bags/``): the commands are
:data:`RUNS`, in order, run in a scratch directory; the figures page names each file and the
command that drew it, and test/test_docs_build.py checks that every figure a page shows
exists and that :data:`RUNS` still draws exactly the committed set. Re-run after a change to
a method's plots.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
FIGURES = DOCS / 'methods' / 'figures'

RUNS: list[list[str]] = [
    ['calibrate', 'bags/theta_four_position', '--plot', 'figs'],
    ['calibrate', 'bags/fog_turntable', '--plot', 'figs'],
    ['calibrate', 'bags/fog_mapping_self_cal', '--plot', 'figs'],
    ['calibrate', 'bags/dither_z', 'bags/dither_y', '--method', 'dither', '--plot', 'figs'],
    ['calibrate', 'bags/thermal_calibration', '--method', 'thermal', '--out', 'thermal.yaml',
     '--plot', 'figs'],
    ['compensate', 'bags/thermal_validation', '--calibration', 'thermal.yaml', '--plot', 'figs'],
    ['noise', 'bags/noise_rlg_static', '--topic', '/gyro/pulses', '--plot', 'figs'],
]
"""``gyro-calib`` arguments of each run, in a scratch directory with bags/ linked."""


def draw(target: Path = FIGURES) -> list[str]:
    """Run :data:`RUNS` and copy every figure into ``target``; the file names, sorted."""
    sys.path.insert(0, str(ROOT))
    from gyro_calib.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        (work / 'bags').symlink_to(ROOT / 'bags')
        (work / 'figs').mkdir()
        import os

        here = Path.cwd()
        os.chdir(work)
        try:
            for args in RUNS:
                status = main(args + (['--no-progress'] if args[0] != 'compensate' else []))
                if status != 0:
                    raise SystemExit(f'gyro-calib {" ".join(args)}: exit {status}')
        finally:
            os.chdir(here)
        target.mkdir(parents=True, exist_ok=True)
        names = sorted(p.name for p in (work / 'figs').glob('*.png'))
        for name in names:
            shutil.copyfile(work / 'figs' / name, target / name)
    return names


if __name__ == '__main__':
    print('\n'.join(draw()))
