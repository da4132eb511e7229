"""A consumer-MEMS-like gyro at rest: do the terms come out by themselves?

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/noise_mems_band_limited.py [--n 1000000] [--seed 11]

Three gyro axes at 100 Hz for 2.8 h (10⁶ samples): white rate noise N = 2 °/√h through the
sensor's decimation filter (2nd-order Butterworth at 0.2·fs), flicker rate noise with
B = 0.007 °/s (generated in the frequency domain, two-sided PSD B²/(2πf)), a bias of 0.3 °/s
and an output LSB of 0.05 °/s (which adds LSB²·τ0/12 to N²) — the datasheet-like case of
issue 18. Printed per axis, with the default settings and with the band-limited exclusion
off: N (°/√h) and B (°/s) beside the truth, the fit's χ² ratio, where the short-τ range was
cut, and the τ range B rests on.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

DEG = math.pi / 180.0


def _flicker(rng: np.random.Generator, n: int, tau0: float, b: float) -> np.ndarray:
    big = 4 * n
    w = np.fft.rfft(rng.standard_normal(big))
    f = np.fft.rfftfreq(big, tau0)
    psd = np.zeros_like(f)
    psd[1:] = b * b / (math.pi * f[1:])  # one-sided
    return np.fft.irfft(w * np.sqrt(psd / (2.0 * tau0)), big)[:n]


def main() -> None:
    from scipy.signal import butter, sosfilt

    from gyro_calib.noise import NoiseCalibrator, NoiseSettings

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--n', type=int, default=1_000_000)
    parser.add_argument('--seed', type=int, default=11)
    args = parser.parse_args()
    n, fs = args.n, 100.0
    tau0 = 1.0 / fs
    arw, bias_inst, lsb = 2.0 * DEG / 60.0, 0.007 * DEG, 0.05 * DEG
    rng = np.random.default_rng(args.seed)
    sos = butter(2, 0.4, output='sos')  # cutoff 0.2·fs
    cols = []
    for _ in range(3):
        white = arw / math.sqrt(tau0) * rng.standard_normal(n + 2000)
        rate = sosfilt(sos, white)[2000:] + _flicker(rng, n, tau0, bias_inst) + 0.3 * DEG
        cols.append(np.round(rate / lsb) * lsb)
    gyro = np.column_stack(cols)
    t = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 10_000_000
    accel = 1e-3 * rng.standard_normal((n, 3)) + np.array([0.0, 0.0, 9.81])
    n_truth = math.sqrt(arw**2 + lsb**2 * tau0 / 12.0)
    print(f'{n} samples at 100 Hz ({n / fs / 3600:.2f} h); truth N = {n_truth * 60 / DEG:.4g} '
          f'°/√h, B = {bias_inst / DEG:.4g} °/s (flicker generator ±5 %)')
    for label, settings in (('defaults', NoiseSettings()),
                            ('band-limited exclusion off',
                             NoiseSettings(fit_exclude_band_limited=0))):
        cal = NoiseCalibrator(settings)
        cal.extend_imu(t, gyro, accel)
        cal.process(flush=True)
        print(label)
        for axis in ('gyro_x', 'gyro_y', 'gyro_z'):
            res = cal.axis_result(axis)
            assert res.fit is not None
            est = res.fit.estimates
            parts = []
            for key, scale, unit in (('angle_random_walk_rad_per_sqrt_s', 60.0 / DEG, '°/√h'),
                                     ('bias_instability_rad_s', 1.0 / DEG, '°/s')):
                e = est.get(key)
                parts.append(f'{key.split("_")[0]} {e.value * scale:.4g} ± '
                             f'{e.std_uncertainty * scale:.2g} {unit}' if e else
                             f'{key.split("_")[0]} not reported')
            rng_b = res.fit.tau_ranges.get('bias_instability_rad_s')
            where = f'B rests on τ {rng_b[0]:.3g}–{rng_b[1]:.3g} s' if rng_b else ''
            print(f'  {axis}: {"; ".join(parts)}; χ² ratio {res.fit.chi2_ratio:.3g}; short τ '
                  f'cut below {res.fit.band_limited_below_s:.3g} s; {where}')


if __name__ == '__main__':
    main()
