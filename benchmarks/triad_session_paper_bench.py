"""The triad session end to end on the paper bench: |ΔK/K| and direction errors (METHODS §F.4).

Run (from the repository root):

    PYTHONPATH=$PWD python benchmarks/triad_session_paper_bench.py           # 20 runs, ~1 min
    PYTHONPATH=$PWD python benchmarks/triad_session_paper_bench.py --quick   # 3 runs
    PYTHONPATH=$PWD python benchmarks/triad_session_paper_bench.py --encoder-counts-per-rev 8388608

Unlike benchmarks/triad_precision.py (the estimator fed pairs with ±½-pulse end errors), the
streams here go through the session: counts quantised at 1 kHz, encoders at 250 Hz, zero-index
events jittered by 0.1″ of table angle, the window ends measured by the §A local fits (which
average the quantisation down unless the count rate beats with the sample rate, see
``quantisation_floor``). Generator: test/triad_bench_physics.py (the kinematics composed from
rotations). Bench: α = 45°, four stations 90° apart, one position-table revolution each way at
150 °/s (one window each way), P inner pairs of m = 5 turns at 150 °/s, K = 0.8428″/pulse for
all three gyros, sense axes within ±5 mrad of the body axes, bias ≤ 0.02 °/h.

Prints per run |ΔK/K| per gyro, the direction error |Δs_i| (″), the stated u, and at the end
the rms over the runs against the issue 26 targets (≤ 2e-8 z, ≤ 1e-7 x, y, ≤ 0.5″).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))

from triad_bench_physics import ARCSEC, Bench, Triad, random_triad, record  # noqa: E402

from gyro_calib.session import CalibrationOptions  # noqa: E402
from gyro_calib.triad.session import TriadSession  # noqa: E402

K_PAPER = 0.8428 * ARCSEC


def one_run(seed: int, inner_pairs: int, encoder_counts_per_rev: int = 0,
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(|ΔK/K|, stated u(K)/K, |Δs| ″, stated √trace C(s) ″) per gyro for one run."""
    rng = np.random.default_rng(seed)
    t = random_triad(rng)
    triad = Triad(np.full(3, K_PAPER), t.sense_axes, t.bias_rad_s)
    rate = math.radians(150.0)
    bench = Bench(inner_pairs=inner_pairs, inner_turns=5, outer_rate_rad_s=rate,
                  outer_accel_rad_s2=2 * rate, outer_margin_turns=0.6,
                  index_jitter_s=0.1 * ARCSEC / rate,
                  encoder_counts_per_rev=encoder_counts_per_rev)
    rec = record(bench, triad, rng)
    session = TriadSession(CalibrationOptions(
        latitude_deg=bench.latitude_deg, heading_deg=bench.heading_deg,
        scenario={'bench': {'tilt_deg': 45.0, 'tilt_std_arcsec': 60.0,
                            'revolutions_per_window': 5}}))
    from test_triad_session import batches  # the test's batching, as a bag reader gives

    for batch in batches(rec):
        session.feed(batch)
    session.process(flush=True)
    r = session.triad_result
    assert r is not None
    dk, uk, ds, us = (np.zeros(3) for _ in range(4))
    for i, ch in enumerate(r.channels):
        k, s, cov = ch.scale_factor_rad_per_pulse, ch.sense_axis, ch.sense_axis_covariance
        assert k is not None and s is not None and cov is not None, ch.not_measurable
        dk[i] = abs(k.value - K_PAPER) / K_PAPER
        uk[i] = k.std_uncertainty / k.value
        ds[i] = np.linalg.norm(np.array([e.value for e in s]) - triad.sense_axes[i]) / ARCSEC
        us[i] = math.sqrt(np.trace(cov)) / ARCSEC
    return dk, uk, ds, us


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='3 runs instead of 20')
    parser.add_argument('--inner-pairs', type=int, default=10)
    parser.add_argument('--encoder-counts-per-rev', type=int, default=0,
                        help='quantise both encoders (e.g. 8388608 = 2^23); 0 = exact')
    args = parser.parse_args()
    runs = 3 if args.quick else 20
    rows = []
    start = time.perf_counter()
    print(f'paper bench through the session, {args.inner_pairs} inner pairs of 5 turns, '
          f'encoder {args.encoder_counts_per_rev or "exact"} counts/rev')
    print('seed | |ΔK/K| x, y, z | u(K)/K x, y, z | |Δs| ″ x, y, z | u(s) ″ x, y, z')
    for seed in range(runs):
        dk, uk, ds, us = one_run(seed, args.inner_pairs, args.encoder_counts_per_rev)
        rows.append((dk, uk, ds, us))
        print(f'{seed:4d} | ' + ' '.join(f'{v:.1e}' for v in dk) + ' | '
              + ' '.join(f'{v:.1e}' for v in uk) + ' | '
              + ' '.join(f'{v:.3f}' for v in ds) + ' | ' + ' '.join(f'{v:.3f}' for v in us))
    dk_all = np.array([r[0] for r in rows])
    uk_all = np.array([r[1] for r in rows])
    ds_all = np.array([r[2] for r in rows])
    rms = np.sqrt(np.mean(dk_all ** 2, axis=0))
    print(f'rms |ΔK/K| over {runs} runs: x {rms[0]:.2e}, y {rms[1]:.2e}, z {rms[2]:.2e} '
          f'(targets 1e-7, 1e-7, 2e-8); mean stated u: '
          + ', '.join(f'{v:.2e}' for v in uk_all.mean(axis=0)))
    print(f'largest |Δs|: {ds_all.max():.3f}″ (target 0.5″); '
          f'{time.perf_counter() - start:.0f} s')


if __name__ == '__main__':
    main()
