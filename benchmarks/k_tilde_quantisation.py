#!/usr/bin/env python3
"""K̃ error against the bench's floor, and the stated uncertainty's coverage, by pulse rate.

    python benchmarks/k_tilde_quantisation.py [--benches 200] [--seed 7]

Benches are drawn as test/test_windows_property.py draws them (its physics generator,
test/rate_bias_bench_physics.py: 20–400 °/s, 50–5000 °/s², m 1–10, K 0.5–3″, ARW 0–0.06″/√s,
…), with the pulse rate fixed at 100 Hz or drawn in a band. For each band it prints

* |K̃ error| / floor for the white-quantisation floor the test used before (whole pulses as
  white noise, Σwᵢ² / 12) and for the sawtooth floor it uses now (``_k_tilde_floor``: the
  sampled sawtooth's exact variance, METHODS §A.2 eq. (2b)): rms, largest, how many over 4;
* coverage of the stated standard uncertainty (the gyro's ARW given to the calibration, so
  its prediction is complete): the fraction of benches with |error| ≤ 1 u and ≤ 2 u, over all
  benches and over the slow-phase ones (whole-pulse floor ≥ 2 × the white one).
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'test'))

from rate_bias_bench_physics import Bench, record  # noqa: E402

from gyro_calib.errors import InsufficientDataError  # noqa: E402
from gyro_calib.rbrlg.calibrator import calibrate_k_tilde  # noqa: E402
from gyro_calib.rbrlg.config import KTildeConfig  # noqa: E402

_spec = importlib.util.spec_from_file_location(
    'windows_property', ROOT / 'test' / 'test_windows_property.py')
assert _spec is not None and _spec.loader is not None
prop = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(prop)

BANDS = ((100.0, 100.0), (100.0, 150.0), (150.0, 300.0), (300.0, 2000.0))


def draw(rng: np.random.Generator, pulse_hz: tuple[float, float]) -> tuple[Bench, int]:
    """One bench as the property test's strategy draws it, pulse rate in ``pulse_hz``."""
    m = int(rng.integers(1, 11))
    rate, accel = rng.uniform(20, 400), rng.uniform(50, 5000)
    cruise, settle = rng.uniform(m, m + 3), rng.uniform(0, 2)
    p_hz, t_hz = rng.uniform(*pulse_hz), rng.uniform(100, 2000)
    w, a = math.radians(rate), math.radians(accel)
    cycle_s = 2 * (settle + 2 * w / a + cruise * 2 * math.pi / w)
    return Bench(
        rate_deg_s=rate, accel_deg_s2=accel, cruise_revolutions=cruise, settle_s=settle,
        mark_deg=rng.uniform(0, 360), index_jitter_arcsec=rng.uniform(0, 1),
        pulse_rate_hz=p_hz, table_rate_hz=t_hz, first_direction=int(rng.choice([1, -1])),
        start_phase=rng.uniform(), duration_s=min(3.2 * cycle_s, prop.MAX_SAMPLES / (p_hz + t_hz)),
        k_arcsec_per_pulse=rng.uniform(0.5, 3), theta_arcsec=rng.uniform(0, 1000),
        earth_bias_arcsec_s=rng.uniform(-15, 15), arw_arcsec_sqrt_s=rng.uniform(0, 0.06),
        seed=int(rng.integers(2**31))), m


def white_floor(bench: Bench, config: KTildeConfig, m: int, pairs: int,
                *, pulses_only: bool = False) -> float:
    """The floor the test used before: whole pulses and encoder steps as white noise."""
    angle = 1_296_000.0 * m
    h = prop._fit_half_width_s(bench.pulse_rate_hz, config)
    pulse_fit = bench.k_arcsec_per_pulse / math.sqrt(12 * 2 * h * bench.pulse_rate_hz)
    if pulses_only:
        return math.sqrt(2 * pulse_fit**2 / (2 * pairs)) / angle
    lsb = 1_296_000.0 / bench.encoder_counts_per_rev
    encoder_fit = lsb / math.sqrt(12 * 2 * h * bench.table_rate_hz)
    window_s = angle / (bench.rate_deg_s * 3600)
    window_var = bench.arw_arcsec_sqrt_s**2 * window_s + 2 * pulse_fit**2 + 2 * encoder_fit**2
    return math.sqrt(window_var / (2 * pairs)) / angle


def band(rng: np.random.Generator, pulse_hz: tuple[float, float], benches: int) -> str:
    """One line of figures for ``benches`` benches in a pulse-rate band."""
    old, new, z, slow = [], [], [], []
    for _ in range(benches):
        bench, m = draw(rng, pulse_hz)
        config = KTildeConfig(revolutions_per_window=m,
                              angle_random_walk_deg_sqrt_h=bench.arw_arcsec_sqrt_s / 60.0)
        rec = record(bench)
        cal = calibrate_k_tilde(rec.pulse_t_ns, rec.pulse_counts, rec.table_t_ns,
                                rec.table_angle_rad, rec.table_rate_rad_s, rec.zero_index_ns,
                                config)
        try:
            k = cal.k_tilde()
        except InsufficientDataError:
            continue
        n = len(cal.pairs)
        error = k.value / bench.true_k_tilde - 1
        old.append(abs(error) / white_floor(bench, config, m, n))
        new.append(abs(error) / prop._k_tilde_floor(bench, config, m, n))
        z.append(abs(error) / (k.std_uncertainty / bench.true_k_tilde))
        slow.append(prop._k_tilde_floor(bench, config, m, n, pulses_only=True)
                    >= 2 * white_floor(bench, config, m, n, pulses_only=True))
    o, w, zz, s = np.array(old), np.array(new), np.array(z), np.array(slow, bool)
    lo, hi = pulse_hz
    name = f'{lo:g} Hz' if lo == hi else f'{lo:g}–{hi:g} Hz'
    slow_cov = (f'{np.mean(zz[s] <= 1):.2f} / {np.mean(zz[s] <= 2):.2f}' if s.any() else '–')
    return (f'{name:>13} {len(o):4d}  white: rms {np.sqrt(np.mean(o**2)):5.2f} max {o.max():5.2f} '
            f'>4 {np.sum(o > 4):2d}   sawtooth: rms {np.sqrt(np.mean(w**2)):5.2f} '
            f'max {w.max():5.2f} >4 {np.sum(w > 4):2d}   ≤1u / ≤2u {np.mean(zz <= 1):.2f} / '
            f'{np.mean(zz <= 2):.2f}   slow phase {int(s.sum()):3d}: {slow_cov}')


def main() -> None:
    """Print one line per pulse-rate band."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--benches', type=int, default=200, help='benches per band')
    parser.add_argument('--seed', type=int, default=7)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print('pulse rate  benches  |K̃ error| / floor (white, sawtooth); stated u coverage '
          '(all; slow-phase benches)')
    for pulse_hz in BANDS:
        print(band(rng, pulse_hz, args.benches), flush=True)


if __name__ == '__main__':
    main()
