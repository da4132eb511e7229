"""Each window's stated count uncertainty against the scatter of its count (issue 41 §2).

Run (from the repository root, niced):

    PYTHONPATH=$PWD nice python benchmarks/triad_window_counts.py [--seeds 6]

test/triad_bench_physics.py (paper plan and default bench, 500 Hz) through the real session;
every window's count N (two local fits, §A eq. (2a)) against the generator's unrounded count
between the same zero-index instants. Printed per bench, ARW and axis: the rms error, the rms of
the uncertainty the weights use (the fits' residuals read as white noise, floored by the q ≤ 4
bound) and of eq. (6a) (the rounding the fits leave, docs/methods/triad.md §F.2), and the rms z
of each. At 0.002 °/√h the error also holds the walk inside the fit spans (≈ a·h/3 per end),
which eq. (6b)'s a·T covers in the pair, not (6a).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))

from triad_bench_physics import Bench, random_triad, record  # noqa: E402
from triad_coverage_helpers import session_of  # noqa: E402

import gyro_calib.triad.session as triad_session  # noqa: E402


def _rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(v ** 2)))


def main(argv: list[str] | None = None) -> int:
    """Print the per-window comparison."""
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--seeds', type=int, default=6)
    a = p.parse_args(argv)
    seen: list[list[Any]] = []
    cut = triad_session.pair_windows

    def spy(*args: Any, **kw: Any) -> Any:
        seen.append(list(args[2]))
        return cut(*args, **kw)

    triad_session.pair_windows = spy  # the windows the session pairs, as it cuts them
    for paper in (True, False):
        for arw in (0.0, 0.0005, 0.002):
            rows = []
            for seed in range(a.seeds):
                rng = np.random.default_rng(10_000 + seed)
                triad = random_triad(rng, arw_rad_sqrt_s=math.radians(arw) / 60.0)
                bench = (Bench(inner_pairs=2, inner_turns=5, outer_margin_turns=0.6,
                               pulse_hz=500.0) if paper else Bench(pulse_hz=500.0))
                rec = record(bench, triad, rng)
                seen.clear()
                session_of(bench, rec)
                t = rec.pulse_t.astype(np.float64)
                assert rec.unrounded is not None
                for w in seen[-1]:
                    for c in range(3):
                        if w.rejected[c] or w.counts_model_std is None:
                            continue
                        true = (np.interp(w.end_ns, t, rec.unrounded[:, c])
                                - np.interp(w.start_ns, t, rec.unrounded[:, c]))
                        rows.append((w.axis, w.counts[c] - true, w.counts_std[c],
                                     w.counts_model_std[c]))
            for axis in ('inner', 'outer'):
                r = np.array([x[1:] for x in rows if x[0] == axis], dtype=float)
                err, weights, model = r.T
                print(f'{"paper plan" if paper else "default   "} ARW {arw:<6g} {axis}: '
                      f'{len(r):4d} windows, rms error {_rms(err):.4f} pulse | weights '
                      f'{_rms(weights):.4f} (rms z {_rms(err / weights):.2f}) | eq. (6a) '
                      f'{_rms(model):.4f} (rms z {_rms(err / model):.2f})')
    return 0


if __name__ == '__main__':
    sys.exit(main())
