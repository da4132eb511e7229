"""Coverage of the multiposition uncertainties over simulated hand-turned IMUs (issue 38).

Run (from the repository root):

    nice -n 10 .venv/bin/python benchmarks/multiposition_coverage.py           # 120 seeds
    nice -n 10 .venv/bin/python benchmarks/multiposition_coverage.py --n 30    # a quick look
    nice -n 10 .venv/bin/python benchmarks/multiposition_coverage.py --first 120  # other seeds

Each seed is a unit and a recording from test/multiposition_physics.py (random poses and
turns about random body axes, lever-arm accelerations, Earth rate, white noise of a random
level, gyro bias drift, quantisation for a third of the units). Printed per parameter: the
fraction of seeds whose truth lies within ±1σ (target 60–76 %) and ±2σ of the estimate.
The gyro bias is judged against the true bias averaged over the static samples (what the
static intervals measure when the bias drifts).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
from multiposition_physics import random_unit, record  # noqa: E402

from gyro_calib.multiposition.calibrator import calibrate  # noqa: E402
from gyro_calib.multiposition.recording import Recording  # noqa: E402
from gyro_calib.multiposition.records import ACC_NAMES, GYRO_NAMES  # noqa: E402


def z_scores(seed: int) -> tuple[np.ndarray, np.ndarray] | None:
    """|estimate − truth|/u of every accelerometer and gyro parameter of one seed."""
    rng = np.random.default_rng(seed)
    unit = random_unit(rng)
    t, acc, gyro, mean_bias = record(unit, rng)
    r = calibrate(Recording(t, acc, gyro, 'm/s²', 'rad/s'), gravity_m_s2=9.80665,
                  gravity_std_m_s2=0.0)
    if r.accelerometer is None or r.gyro is None:
        return None
    truth = unit.gyro_truth()
    truth[9:] = mean_bias
    return (np.abs(r.accelerometer.values - unit.acc_truth()) / r.accelerometer.std,
            np.abs(r.gyro.values - truth) / r.gyro.std)


def main() -> None:
    """Print the coverage table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--n', type=int, default=120, help='seeds (default 120)')
    parser.add_argument('--first', type=int, default=0, help='first seed (default 0)')
    args = parser.parse_args()
    start = time.perf_counter()
    za, zg, failed = [], [], 0
    for seed in range(args.first, args.first + args.n):
        got = z_scores(seed)
        if got is None:
            failed += 1
            continue
        za.append(got[0])
        zg.append(got[1])
    a, g = np.array(za), np.array(zg)
    print(f'{len(a)} seeds calibrated, {failed} not ({time.perf_counter() - start:.0f} s)')
    print(f'{"parameter":32} {"±1σ":>6} {"±2σ":>6}')
    for sensor, names, z in (('accelerometer', ACC_NAMES, a), ('gyro', GYRO_NAMES, g)):
        for i, name in enumerate(names):
            print(f'{sensor + " " + name:32} {np.mean(z[:, i] <= 1):6.2f} '
                  f'{np.mean(z[:, i] <= 2):6.2f}')


if __name__ == '__main__':
    main()
