"""The paper's one-orientation spectral method against the two-orientation estimator, over ψ₀.

Run (from the repository root):

    nice -n 10 .venv/bin/python benchmarks/dither_one_orientation.py          # ~1-2 min
    nice -n 10 .venv/bin/python benchmarks/dither_one_orientation.py --quick  # ~30 s

A gyro with a = 30′ (rocking off, so both methods have the same target; everything else as
``DitheredGyroConfig`` defaults: whole pulses of 1″, Earth rate, bias, ARW) is mounted at
azimuths ψ₀ = 0°, 15°, …, 90° and run on a 20 rad/s, 20 Hz table for T per orientation.
Columns:
    spectral a    ``spectral_misalignment`` on the Z run (flat-top FFT peak heights, θ_d applied
                  as METHODS §C requires): what the one-orientation method reports as a
    its error     spectral a − a: follows a·(|sin ψ₀| − 1), whatever the record length
    literal       the paper's printed model 2·S̄·K/A (θ_d folded in), in arcseconds
    two-orient.   â ± u(â) from ``calibrate_dither`` on both runs (rocking_treatment none)
    its error     â − a, with its ratio to u(â)
"""

from __future__ import annotations

import argparse
import math
import os
import time
from multiprocessing import Pool

from gyro_calib.dither.calibrator import KEY_A, calibrate_dither
from gyro_calib.dither.settings import DitherSettings
from gyro_calib.dither.spectral import spectral_misalignment
from sim_nodes.dither.bench import DitherBenchConfig
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.scenarios import simulate_dither_pair
from sim_nodes.dither.vibration_table import VibrationTableConfig

ARCMIN = math.pi / 180 / 60


def one(job: tuple[float, float, int]) -> tuple[float, float, float, float, float, float]:
    """(ψ₀, a, spectral a, literal a, â, u(â)) for one mounting azimuth."""
    psi, record_s, seed = job
    gyro = DitheredGyroConfig(misalignment_arcmin=30.0, ia_azimuth_deg=psi, seed=seed,
                              rocking_arcsec_per_arcmin=0.0)
    runs = simulate_dither_pair(gyro, VibrationTableConfig(rate_amplitude_rad_s=20.0),
                                DitherBenchConfig(duration_s=record_s))
    z = runs['z']
    spec = spectral_misalignment(z.pulse_t_ns, z.pulse_counts, z.table_t_ns, z.table_angle_rad,
                                 scale_factor_rad_per_pulse=gyro.scale_factor_rad_per_pulse)
    cal = calibrate_dither(runs['z'], runs['y'], settings=DitherSettings(
        scale_factor_rad_per_pulse=gyro.scale_factor_rad_per_pulse, rocking_treatment='none',
        max_misalignment_arcmin=60.0))
    a = cal.results()[KEY_A]
    return (psi, z.truth['misalignment_rad'], spec.misalignment_rad, spec.paper_literal_rad,
            a.value, a.std_uncertainty)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true')
    parser.add_argument('--jobs', type=int, default=os.cpu_count() or 1)
    args = parser.parse_args()
    record_s = 20.0 if args.quick else 60.0
    print(f'one-orientation vs two-orientation, a = 30′, A = 20 rad/s, T = {record_s:g} s per '
          f'orientation, on {os.cpu_count()} cores')
    t0 = time.perf_counter()
    with Pool(args.jobs) as pool:
        rows = pool.map(one, [(psi, record_s, 7 + i) for i, psi in enumerate(range(0, 91, 15))])
    print(f'{"ψ₀":>4} {"spectral a":>11} {"its error":>10} {"a(|sin ψ₀|−1)":>14} {"literal":>9}'
          f' {"two-orient. â ± u":>19} {"its error":>10} {"err/u":>6}')
    for psi, a, spec, literal, est, u in rows:
        print(f'{psi:4.0f} {spec / ARCMIN:10.2f}′ {(spec - a) / ARCMIN:+9.2f}′ '
              f'{a * (abs(math.sin(math.radians(psi))) - 1) / ARCMIN:+13.2f}′ '
              f'{literal * 206264.8:8.3f}″ {est / ARCMIN:10.2f}′ ± {u / ARCMIN:4.2f}′ '
              f'{(est - a) / ARCMIN:+9.2f}′ {(est - a) / u:+6.2f}')
    print(f'wall time {time.perf_counter() - t0:.0f} s')


if __name__ == '__main__':
    main()
