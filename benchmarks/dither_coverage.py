"""Coverage of the dither results' ±1σ and ±2σ (and of the k = 2 interval) over random benches.

Run (from the repository root):

    nice -n 10 .venv/bin/python benchmarks/dither_coverage.py            # 100 benches/setting
    nice -n 10 .venv/bin/python benchmarks/dither_coverage.py --n 20     # a quick look

Each bench is one pair of orientations from the exact-kinematics simulator (sim_nodes.dither;
quantised pulses, angle random walk, Earth rate and bias): a uniform in 0–60′, ψ₀ uniform,
θ_d 3–10′, f_d 350–550 Hz, table 5–10 rad/s at 15–40 Hz (not a divisor of the 2 kHz
sample rate, except in the clock-locked setting: 20 Hz), 15 s per orientation, K = 1″.
Settings: the rocking absent with rocking_treatment none (the statistical σ alone) and bound
(the default), the rocking in phase with the dither (k uniform up to the paper's 1″ per 35′,
what the allowance assumes) and in quadrature, and a clock-locked table.

Printed per setting and quantity (a, the Z and Y components): the fraction of benches whose
truth lies within ±1σ and ±2σ of the value (σ = the reported combined standard uncertainty),
within the k = 2 interval (rocking allowance included), and how many had an unbounded
uncertainty (ρ ≥ 1 at small θ_d: said so, not counted).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from dither_rocking_allowance import LeadingRockingGyro

from gyro_calib.dither.calibrator import KEY_A, KEY_Y, KEY_Z, calibrate_dither
from gyro_calib.dither.settings import DitherSettings
from sim_nodes.dither.bench import DitherBenchConfig
from sim_nodes.dither.scenarios import simulate_dither_pair
from sim_nodes.dither.vibration_table import VibrationTableConfig

ARCMIN = math.pi / 180 / 60
K = ARCMIN / 60
SETTINGS = ('absent, treatment none', 'absent, treatment bound', 'in phase, bound',
            'in quadrature, bound', 'clock-locked 20 Hz, none')


def one_bench(setting: str, rng: np.random.Generator, duration_s: float) -> dict[str, tuple]:
    """Truth, value, σ and interval per key for one random bench of ``setting``."""
    rocking = setting.split(',')[0]
    a = rng.uniform(0.0, 60.0)
    psi = rng.uniform(0.0, 360.0)
    k = rng.uniform(0.0, 1 / 35) if rocking in ('in phase', 'in quadrature') else 0.0
    gyro = LeadingRockingGyro(
        misalignment_arcmin=a, ia_azimuth_deg=psi, dither_amplitude_arcmin=rng.uniform(3, 10),
        dither_frequency_hz=rng.uniform(350, 550), dither_phase_rad=rng.uniform(0, 2 * math.pi),
        dither_axis_tilt_arcmin=rng.uniform(-20, 20), rocking_arcsec_per_arcmin=k,
        rocking_phase_rad=0.0,
        rocking_lead_rad=math.pi / 2 if rocking == 'in quadrature' else 0.0,
        heading_deg=rng.uniform(0, 360), scale_factor_rad_per_pulse=K,
        seed=int(rng.integers(2**31)))
    f_z = 20.0 if setting.startswith('clock') else rng.uniform(15.0, 40.0)
    if not setting.startswith('clock'):
        while abs(f_z - 2000.0 / round(2000.0 / f_z)) < 1.0 / duration_s:
            f_z = rng.uniform(15.0, 40.0)
    table = VibrationTableConfig(rate_amplitude_rad_s=rng.uniform(5.0, 10.0), frequency_hz=f_z,
                                 phase_rad=rng.uniform(0, 2 * math.pi))
    pair = simulate_dither_pair(gyro, table, DitherBenchConfig(duration_s=duration_s))
    treatment = 'none' if setting.endswith('none') else 'bound'
    cal = calibrate_dither(pair['z'], pair['y'], settings=DitherSettings(
        scale_factor_rad_per_pulse=K, rocking_treatment=treatment))
    res, parts = cal.results(), cal.result_parts()
    ar, pr = a * ARCMIN, math.radians(psi)
    truth = {KEY_A: ar, KEY_Z: ar * abs(math.sin(pr)), KEY_Y: ar * abs(math.cos(pr))}
    return {key: (truth[key], res[key].value, res[key].std_uncertainty,
                  tuple(parts[key]['interval'])) for key in truth if key in res}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--n', type=int, default=100, help='benches per setting')
    parser.add_argument('--duration-s', type=float, default=15.0)
    parser.add_argument('--seed', type=int, default=16)
    args = parser.parse_args()
    t0 = time.perf_counter()
    print(f'dither coverage over {args.n} random benches per setting, {args.duration_s:g} s per '
          'orientation (truth within ±1σ, ±2σ of the value; within the k = 2 interval)')
    print(f'{"setting":>26} {"key":>28} {"n":>4} {"±1σ":>6} {"±2σ":>6} {"k=2 int":>8} '
          f'{"unbnd":>5} {"median σ":>9}')
    for setting in SETTINGS:
        rng = np.random.default_rng([args.seed, SETTINGS.index(setting)])
        rows: dict[str, list[tuple]] = {KEY_A: [], KEY_Z: [], KEY_Y: []}
        for _ in range(args.n):
            for key, row in one_bench(setting, rng, args.duration_s).items():
                rows[key].append(row)
        for key, data in rows.items():
            finite = [r for r in data if math.isfinite(r[2])]
            err = np.array([abs(v - t) for t, v, _, _ in finite])
            std = np.array([s for _, _, s, _ in finite])
            inside = np.mean([lo <= t <= hi for t, _, _, (lo, hi) in finite]) if finite else 0
            print(f'{setting:>26} {key:>28} {len(finite):4d} {np.mean(err <= std):6.2f} '
                  f'{np.mean(err <= 2 * std):6.2f} {inside:8.2f} {len(data) - len(finite):5d} '
                  f'{np.median(std) / ARCMIN if len(std) else math.nan:8.2f}′')
    print(f'{time.perf_counter() - t0:.0f} s')


if __name__ == '__main__':
    main()
