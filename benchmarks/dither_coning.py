"""Coning drift against a: eq. (24), dither × rocking, the paper's figures, exact kinematics.

Run (from the repository root):

    nice -n 10 .venv/bin/python benchmarks/dither_coning.py          # ~20 s
    nice -n 10 .venv/bin/python benchmarks/dither_coning.py --quick  # ~10 s

Part 1 — ε against a (the paper's Fig. 5 at sin φ = 1): eq. (24) under the proportional
(paper) and components rocking models (k = 1″ per 35′, Ω_d/2π = 407.3172 Hz, ψ₀ = 45°, the
components model's largest), the dither × rocking term at θ_d = 6′, and the exact coning of
the composed rotation (mean ω·IA over one dither period, table still) for the proportional
model — the signed sum, which is what the gyro sees.
Part 2 — the paper's figures: eq. (24) at 60′ (paper ≈ 0.02 °/h) and at 5′ (< 0.0005 °/h)
for dither frequencies 400 and 450 Hz (the paper's Table 1 is lost in extraction).
Part 3 — the simulator's sensed angle (Gauss–Legendre on the exact body rate, whole run) over
a long noise-free static run: its drift against the exact periodic mean and against the two
formulas.
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

from gyro_calib.dither.coning import coning_drift, coning_eq24_from_misalignment_rad_s
from sim_nodes.dither.bench import DitherBenchConfig
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.scenarios import dither_truth, simulate_dither_run
from sim_nodes.dither.vibration_table import VibrationTableConfig

ARCMIN = math.pi / 180 / 60
DEG_H = math.radians(1.0) / 3600.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true')
    args = parser.parse_args()
    print(f'coning drift against a, on {os.cpu_count()} cores')
    t0 = time.perf_counter()
    print('Part 1 — ε (°/h), sin φ = 1, ψ₀ = 45°')
    print(f'{"a":>5} {"eq24 prop.":>11} {"eq24 comp.":>11} {"dither×rock":>12} '
          f'{"exact (signed)":>15} {"formula sum":>12}')
    for a_arcmin in (1, 2, 5, 10, 20, 35, 60):
        a = a_arcmin * ARCMIN
        z = y = a / math.sqrt(2)
        prop = coning_drift(z, y, dither_frequency_hz=407.3172, dither_amplitude_rad=6 * ARCMIN)
        comp = coning_drift(z, y, dither_frequency_hz=407.3172, model='components')
        gyro = DitheredGyroConfig(misalignment_arcmin=a_arcmin, ia_azimuth_deg=45.0,
                                  rocking_phase_rad=math.pi / 2)
        truth = dither_truth(gyro, VibrationTableConfig())
        signed = truth['coning_eq24_rad_s'] + truth['coning_dither_rocking_rad_s']
        print(f'{a_arcmin:4d}′ {prop.eq24_rad_s / DEG_H:11.2e} {comp.eq24_rad_s / DEG_H:11.2e} '
              f'{prop.dither_rocking_rad_s / DEG_H:12.2e} '
              f'{truth["coning_exact_rad_s"] / DEG_H:15.3e} {signed / DEG_H:12.3e}')
    print('Part 2 — the paper\'s figures, eq. (24) proportional, sin φ = 1')
    for f in (400.0, 450.0):
        e60 = coning_eq24_from_misalignment_rad_s(60 * ARCMIN, dither_frequency_hz=f) / DEG_H
        e5 = coning_eq24_from_misalignment_rad_s(5 * ARCMIN, dither_frequency_hz=f) / DEG_H
        print(f'  Ω_d/2π = {f:.0f} Hz: ε(60′) = {e60:.4f} °/h (paper ≈ 0.02), '
              f'ε(5′) = {e5:.5f} °/h '
              f'(paper < 0.0005)')
    print('Part 3 — simulator static run (table still, no noise, no Earth), a = 60′, ψ₀ = 40°')
    duration = 10.0 if args.quick else 60.0
    for model in ('proportional', 'components'):
        gyro = DitheredGyroConfig(misalignment_arcmin=60.0, ia_azimuth_deg=40.0, quantise=False,
                                  angle_random_walk_deg_sqrt_h=0.0, bias_deg_h=0.0,
                                  earth_rate_deg_h=0.0, rocking_model=model, rocking_phase_rad=1.0)
        rec = simulate_dither_run(gyro, VibrationTableConfig(rate_amplitude_rad_s=0.0),
                                  DitherBenchConfig(duration_s=duration))
        t = (rec.pulse_t_ns - rec.pulse_t_ns[0]) / 1e9
        wd = gyro.dither_angular_frequency_rad_s
        design = np.column_stack((np.ones_like(t), t, np.cos(wd * t), np.sin(wd * t)))
        drift = np.linalg.lstsq(design, rec.pulse_counts, rcond=None)[0][1] * \
            gyro.scale_factor_rad_per_pulse
        tr = rec.truth
        formula = tr['coning_eq24_rad_s'] + tr['coning_dither_rocking_rad_s']
        print(f'  {model:12s} sim drift {drift:.6e} rad/s, exact periodic mean '
              f'{tr["coning_exact_rad_s"]:.6e} '
              f'(rel. diff {drift / tr["coning_exact_rad_s"] - 1:+.1e}),'
              f' eq24 {tr["coning_eq24_rad_s"]:.3e} + dither×rock '
              f'{tr["coning_dither_rocking_rad_s"]:.3e} = {formula:.4e} '
              f'(rel. diff {formula / tr["coning_exact_rad_s"] - 1:+.1e})')
    print(f'wall time {time.perf_counter() - t0:.0f} s')


if __name__ == '__main__':
    main()
