"""Monte Carlo: does u(N) of a whole-pulse count cover the truth as often as it claims?

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/noise_pulse_coverage.py [--seeds 30] [--seconds 400]

The physics generator of ``test/test_noise_triad.py`` (a triad at rest at 100 Hz: white rate
noise N = 2e-5, 3e-5, 4.5e-5 rad/√s, the Earth rate, whole-pulse rounding with K = 1.0, 1.3,
1.7 µrad/pulse, so Q = K/√12 is there by construction), each channel analysed by the noise
method (METHODS §E.3). Per channel: how often N is reported, the share of runs with N within
±1u, ±2u, ±3u (claim 68.3, 95.4, 99.7 %), the normalised spread sd((N̂ − N)/u), the median
stated u/N against the actual scatter of N̂/N, and how often a band-limited range was cut.

Measured (30 seeds × 3 channels, 400 s): before Q stayed in the model of a pulse count,
65 % / 88 % / 90 % within 1u/2u/3u, spread 1.51, u/N 0.37 % in 10 runs, one channel with
no term; after, 72 % / 94 % / 98 %, spread 1.07, every channel reported. 100 seeds: before
67 % / 88 % / 92 %, spread 1.41, u/N down to 0.37 %, 4 spurious band-limited cuts; after 74 % /
97 % / 99.3 %, spread 0.94, u/N 0.71–0.72 % in every run against a 0.69 % scatter of N̂/N.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'test'))

N_KEY = 'angle_random_walk_rad_per_sqrt_s'


def main() -> None:
    import test_noise_triad as triad

    from gyro_calib.noise.calibrator import NoiseCalibrator
    from gyro_calib.noise.settings import NoiseSettings

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seeds', type=int, default=30)
    parser.add_argument('--seconds', type=float, default=400.0)
    args = parser.parse_args()
    triad.SECONDS = args.seconds
    start = time.time()
    rows: dict[str, list[tuple[float, float, float]]] = {c: [] for c in triad.CHANNELS}
    missing = dict.fromkeys(triad.CHANNELS, 0)
    for seed in range(args.seeds):
        t, counts = triad.counts_at_rest(seed)
        cal = NoiseCalibrator(NoiseSettings(),
                              triad=(triad.CHANNELS, tuple(float(k) for k in triad.K)))
        cal.extend_triad(t, counts)
        cal.process(flush=True)
        for i, ch in enumerate(triad.CHANNELS):
            fit = cal.axis_results()[ch].fit
            est = fit.estimates.get(N_KEY) if fit is not None else None
            if fit is None or est is None:
                missing[ch] += 1
                continue
            rows[ch].append((est.value / triad.ARW[i] - 1.0, est.std_uncertainty / est.value,
                             fit.band_limited_below_s))
    print(f'{args.seeds} seeds × {len(triad.CHANNELS)} channels, {args.seconds:g} s at '
          f'{triad.RATE_HZ:g} Hz ({time.time() - start:.0f} s)')
    print(f'{"channel":8s} {"N":>8s} {"K µrad":>7s} {"reported":>8s} {"±1u":>6s} {"±2u":>6s} '
          f'{"±3u":>6s} {"sd(z)":>6s} {"med u/N":>8s} {"sd N̂/N":>8s} {"min u/N":>8s} '
          f'{"cut":>4s}')
    every: list[tuple[float, float, float]] = []
    for i, ch in enumerate(triad.CHANNELS):
        every += rows[ch]
        _line(ch, f'{triad.ARW[i]:.2g}', f'{triad.K[i] * 1e6:.2g}', rows[ch],
              args.seeds - missing[ch], args.seeds)
    _line('all', '', '', every, len(every), args.seeds * len(triad.CHANNELS))


def _line(name: str, n: str, k: str, rows: list[tuple[float, float, float]], reported: int,
          total: int) -> None:
    a = np.array(rows).reshape(-1, 3)
    z = a[:, 0] / a[:, 1]
    print(f'{name:8s} {n:>8s} {k:>7s} {reported:>4d}/{total:<3d} '
          f'{100 * np.mean(np.abs(z) < 1):5.1f}% {100 * np.mean(np.abs(z) < 2):5.1f}% '
          f'{100 * np.mean(np.abs(z) < 3):5.1f}% {z.std():6.2f} '
          f'{100 * np.median(a[:, 1]):7.3f}% {100 * a[:, 0].std():7.3f}% '
          f'{100 * a[:, 1].min():7.3f}% {int(np.count_nonzero(a[:, 2] > 0)):4d}')


if __name__ == '__main__':
    main()
