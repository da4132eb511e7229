"""The rocking allowance against the shift the exact-kinematics simulator actually produces.

Run (from the repository root):

    nice -n 10 .venv/bin/python benchmarks/dither_rocking_allowance.py          # ~2 min
    nice -n 10 .venv/bin/python benchmarks/dither_rocking_allowance.py --quick  # ~30 s

Derivation (docs/guide/dither.md; gyro_calib/dither/misalignment.py): rocking θ_r in phase
with the dither shifts a component by θ_r/θ_d; with θ_r ≤ k·a and κ = k/θ_d each component
moves by at most κ·a and a by at most ρ·a (ρ = √2·κ with both rockings k·a, the
'proportional' model), so a ∈ [â/(1 + ρ), â/(1 − ρ)]. Rocking in quadrature shifts nothing.

Each row: one noise-free pair of orientations (unquantised phase, no ARW, no Earth rate or
bias, so the statistical σ is ~0 and what remains is the systematic shift) from the
simulator's exact composed rotation (sim_nodes.dither), rocking k = 1″ per 35′ (the paper's)
in phase with the dither, in quadrature (both rockings 90° ahead), or absent. Printed beside
each bound: the shift the simulator produced, and whether the truth lies in the interval.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

from gyro_calib.dither.calibrator import KEY_A, KEY_Y, KEY_Z, calibrate_dither
from gyro_calib.dither.settings import DitherSettings
from sim_nodes.dither.bench import DitherBenchConfig
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.kinematics import CavityMotion, Sinusoids
from sim_nodes.dither.scenarios import simulate_dither_pair
from sim_nodes.dither.vibration_table import VibrationTableConfig

ARCMIN = math.pi / 180 / 60
K = ARCMIN / 60


@dataclasses.dataclass(frozen=True, slots=True)
class LeadingRockingGyro(DitheredGyroConfig):
    """The simulator's gyro with its rockings led against the dither.

    The simulator's gyro with both transverse rockings advanced by ``rocking_lead_rad``
    relative to the dither (π/2: in quadrature).
    """

    rocking_lead_rad: float = 0.0

    def motion(self, table: Sinusoids, table_axis: str) -> CavityMotion:
        """The simulator's exact motion, the rocking phases advanced."""
        base = DitheredGyroConfig.motion(self, table, table_axis)

        def lead(s: Sinusoids) -> Sinusoids:
            return Sinusoids(s.amplitudes_rad, s.angular_frequencies_rad_s,
                             tuple(p + self.rocking_lead_rad for p in s.phases_rad))

        return dataclasses.replace(base, rocking_y=lead(base.rocking_y),
                                   rocking_z=lead(base.rocking_z))


def run_case(a_arcmin: float, psi_deg: float, theta_d_arcmin: float, rocking: str,
             duration_s: float) -> dict[str, float]:
    """One noise-free pair; the estimator's results, bounds and the truth."""
    k = 0.0 if rocking == 'absent' else 1 / 35
    gyro = LeadingRockingGyro(
        misalignment_arcmin=a_arcmin, ia_azimuth_deg=psi_deg,
        dither_amplitude_arcmin=theta_d_arcmin, rocking_arcsec_per_arcmin=k,
        rocking_phase_rad=0.0, rocking_lead_rad=math.pi / 2 if rocking == 'in quadrature' else 0.0,
        earth_rate_deg_h=0.0, bias_deg_h=0.0, angle_random_walk_deg_sqrt_h=0.0, quantise=False,
        scale_factor_rad_per_pulse=K)
    table = VibrationTableConfig(rate_amplitude_rad_s=10.0, frequency_hz=27.6,
                                 encoder_counts_per_rev=0)
    pair = simulate_dither_pair(gyro, table, DitherBenchConfig(duration_s=duration_s))
    settings = DitherSettings(scale_factor_rad_per_pulse=K, max_residual_rms_pulses=50.0)
    cal = calibrate_dither(pair['z'], pair['y'], settings=settings)
    res, parts = cal.results(), cal.result_parts()
    summary = cal.summary()
    a = a_arcmin * ARCMIN
    psi = math.radians(psi_deg)
    truth = {KEY_A: a, KEY_Z: a * abs(math.sin(psi)), KEY_Y: a * abs(math.cos(psi))}
    out = {'kappa': summary.rocking.kappa if summary.rocking else math.nan,
           'rho': summary.misalignment.rho if summary.misalignment else math.nan}
    for key in (KEY_A, KEY_Z, KEY_Y):
        out[key + ':shift'] = res[key].value - truth[key]
        out[key + ':bound'] = parts[key]['systematic_bound']
        out[key + ':stat'] = parts[key]['std_statistical']
        low, high = parts[key]['interval']
        out[key + ':in'] = float(low <= truth[key] <= high)
        out[key + ':truth'] = truth[key]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true')
    args = parser.parse_args()
    t0 = time.perf_counter()
    duration = 6.0 if args.quick else 12.0
    cases = [(a, psi, td) for a in ((35.0, 60.0) if args.quick else (10.0, 35.0, 60.0))
             for psi in ((30.0, 200.0) if args.quick else (0.0, 30.0, 45.0, 120.0, 200.0, 315.0))
             for td in (4.0, 6.0, 10.0)]
    print('rocking allowance vs the exact-kinematics shift (noise-free; k = 1″ per 35′, '
          'proportional; shifts and bounds in arcmin)')
    print(f'{"rocking":>13} {"a":>5} {"ψ₀":>5} {"θ_d":>5} {"κ":>6} {"ρ":>6} | '
          f'{"shift a":>8} {"bound a":>8} {"ratio":>6} in | {"shift z":>8} {"shift y":>8} '
          f'{"κ·a":>7} {"bound c":>8}')
    worst: dict[str, float] = {}
    misses = 0
    for rocking in ('in phase', 'in quadrature', 'absent'):
        for a, psi, td in cases:
            r = run_case(a, psi, td, rocking, duration)
            sa, ba = r[KEY_A + ':shift'] / ARCMIN, r[KEY_A + ':bound'] / ARCMIN
            sz, sy = r[KEY_Z + ':shift'] / ARCMIN, r[KEY_Y + ':shift'] / ARCMIN
            bc = r[KEY_Z + ':bound'] / ARCMIN
            ratio = abs(sa) / ba if ba and math.isfinite(ba) else math.nan
            inside = all(r[k + ':in'] for k in (KEY_A, KEY_Z, KEY_Y))
            misses += not inside
            if math.isfinite(ratio):
                worst[rocking] = max(worst.get(rocking, 0.0), ratio)
            print(f'{rocking:>13} {a:5.0f} {psi:5.0f} {td:5.1f} {r["kappa"]:6.3f} '
                  f'{r["rho"]:6.3f} | {sa:8.3f} {ba:8.3f} {ratio:6.2f} '
                  f'{"y " if inside else "NO"} | {sz:8.3f} {sy:8.3f} '
                  f'{r["kappa"] * a:7.3f} {bc:8.3f}')
    print('largest |shift of a| / bound: ' + ', '.join(f'{k} {v:.2f}' for k, v in worst.items()))
    print(f'truth outside the k = 2 interval (a or a component): {misses} case(s)')
    print(f'{time.perf_counter() - t0:.0f} s')


if __name__ == '__main__':
    main()
