"""Thermal compensation with sparse, unsynchronised sensors.

Thermal compensation on random benches with sparse, unsynchronised temperature sensors
(issue 16; METHODS §D.5).

For each of N random gyros (``random_gyro``: random hidden law and time constants) a
calibration run — ramps only, soaks, or ramps with dwells, starting hot or cold — and a
validation run of the same gyro on another day (other set points, another seed) are
simulated twice: with the sensors read **sparsely** (each on its own clock, every 2–60 s,
own first reading, 1/64 °C LSB) and, as the reference, **densely** (all three every second,
0.01 °C). The calibration (default settings: stepwise selection, held-out check) gives a
model; ``compensate`` applies it to the validation run. Printed per bench and summarised:

- improvement: 1 − compensated/raw bias stability (100 s means) on the validation run;
- comp/floor: compensated stability over the ARW + quantisation floor of 100 s means;
- rms error: rms of (model − hidden law) along the validation run's true trajectory, °/h;
- coverage: share of those points where the law lies within ±1σ / ±2σ of the model (σ: the
  model's stated standard uncertainty, covariance and model error u_m in quadrature,
  METHODS §D.3 (17g)); ``cov only``: the same with the covariance alone (u_m = 0, as stated
  before u_m existed: it ignores the selection and the terms no candidate holds). The
  validation run is another programme (soaks after ramp-only calibrations), so part of its
  model error is extrapolation in the (Ḣ, gradient) plane the held-out check cannot see;
- terms: the model's terms (a first power stays while a higher power of it does).

    python benchmarks/thermal_sparse_sensors.py [--benches N] [--quick]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gyro_calib.errors import GyroCalibError  # noqa: E402
from gyro_calib.thermal.calibrator import ThermalSettings, calibrate_thermal  # noqa: E402
from gyro_calib.thermal.compensate import compensate  # noqa: E402
from sim_nodes.thermal.chamber import (  # noqa: E402
    ramp_only_programme,
    ramp_programme,
    soak_programme,
)
from sim_nodes.thermal.gyro import RAD_S_PER_DEG_H  # noqa: E402
from sim_nodes.thermal.scenarios import random_gyro, simulate_thermal_run  # noqa: E402


def _calibration_programme(rng: np.random.Generator, kind: str, hot: bool):  # noqa: ANN202
    if kind == 'ramp_only':
        rates = tuple(float(r) for r in rng.uniform(0.4, 0.9, 5))
        return ramp_only_programme(-30.0, 35.0, rates_c_per_min=rates, duration_s=6 * 3600.0,
                                   start_hot=hot)
    if kind == 'soaks':
        points = [-30.0, -15.0, 0.0, 15.0, 30.0, 35.0]
        return soak_programme(points[::-1] if hot else points, soak_s=2400.0,
                              ramp_rate_c_per_min=1.0)
    return ramp_programme(-30.0, 35.0, rate_c_per_min=0.6, dwell_s=1200.0,
                          start_c=35.0 if hot else None)


def _run_one(seed: int, kind: str, hot: bool, sparse: bool) -> dict[str, float]:
    rng = np.random.default_rng([seed, 9])
    if sparse:
        intervals = tuple(float(x) for x in 10 ** rng.uniform(np.log10(2), np.log10(60), 3))
        offsets = tuple(float(rng.uniform(0, x)) for x in intervals)
        sensor_kw: dict = dict(sensor_read_intervals_s=intervals, sensor_clock_offsets_s=offsets,
                               temperature_resolution_c=1 / 64)
    else:
        sensor_kw = dict(temperature_rate_hz=1.0, temperature_resolution_c=0.01)
    gyro = random_gyro(seed, pulse_rate_hz=2.0, **sensor_kw)
    cal_rec = simulate_thermal_run(gyro, _calibration_programme(rng, kind, hot))
    val_gyro = dataclasses.replace(gyro, seed=seed + 10_000)
    points = [-25.0, -5.0, 10.0, 25.0]
    val_rec = simulate_thermal_run(val_gyro, soak_programme(
        points[::-1] if hot else points, soak_s=1800.0, ramp_rate_c_per_min=1.0))
    truth = cal_rec.scenario['truth']
    settings = ThermalSettings(scale_factor_rad_per_pulse=truth['scale_factor_rad_per_pulse'],
                               latitude_deg=truth['latitude_deg'], gyro_id=gyro.gyro_id)
    cal = calibrate_thermal(cal_rec.pulse_t_ns, cal_rec.pulse_counts, cal_rec.temperature_t_ns,
                            cal_rec.temperature_c, cal_rec.temperature_frame_id, settings)
    model = cal.model()
    rep = compensate(model, val_rec.pulse_t_ns, val_rec.pulse_counts, val_rec.temperature_t_ns,
                     val_rec.temperature_c, val_rec.temperature_frame_id,
                     gyro_id=gyro.gyro_id, out_of_range='skip')
    tr = val_rec.truth
    step = max(1, int(300 / np.median(np.diff(tr.t_ns)) * 1e9))
    sel = slice(step * 2, None, step)
    h = tr.h_c[sel]
    inside = (h >= model.h_range_c[0]) & (h <= model.h_range_c[1])
    value, std = model.bias_rad_s(h[inside], tr.hdot_c_s[sel][inside], tr.dtab_c[sel][inside],
                                  tr.dtcs_c[sel][inside], check=False)
    err = value - tr.law_bias_rad_s[sel][inside]
    z = np.abs(err / std)
    _, std_cov = dataclasses.replace(model, model_error_rad_s=0.0).bias_rad_s(
        h[inside], tr.hdot_c_s[sel][inside], tr.dtab_c[sel][inside], tr.dtcs_c[sel][inside],
        check=False)
    z_cov = np.abs(err / std_cov)
    raw, comp = rep.bias_stability_raw.value, rep.bias_stability_compensated.value
    return {'improvement': 1 - comp / raw, 'comp_floor': comp / rep.noise_floor.floor.value,
            'rms_deg_h': float(np.sqrt(np.mean(err**2))) / RAD_S_PER_DEG_H,
            'cover1': float(np.mean(z < 1)), 'cover2': float(np.mean(z < 2)),
            'cover1_cov': float(np.mean(z_cov < 1)), 'cover2_cov': float(np.mean(z_cov < 2)),
            'u_m_deg_h': model.model_error_rad_s / RAD_S_PER_DEG_H,
            'terms': ','.join(model.terms)}  # type: ignore[dict-item]


def main() -> None:
    """Run the benches and print the figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--benches', type=int, default=24)
    ap.add_argument('--quick', action='store_true', help='4 benches')
    args = ap.parse_args()
    n = 4 if args.quick else args.benches
    kinds = ('ramp_only', 'soaks', 'ramps_with_dwells')
    rows: dict[str, list[dict[str, float]]] = {'sparse': [], 'dense': []}
    refused: dict[str, list[str]] = {'sparse': [], 'dense': []}
    t0 = time.perf_counter()
    print(f'{"bench":>5s} {"programme":>17s} {"start":>5s} {"sensors":>7s} {"improv":>7s} '
          f'{"comp/floor":>10s} {"rms °/h":>8s} {"u_m °/h":>8s} {"±1σ":>5s} {"±2σ":>5s} '
          f'{"cov only ±1σ/±2σ":>17s}  terms')
    for i in range(n):
        seed = 500 + i
        kind, hot = kinds[i % 3], bool((i // 3) % 2)
        for mode in ('sparse', 'dense'):
            try:
                r = _run_one(seed, kind, hot, mode == 'sparse')
            except GyroCalibError as exc:
                refused[mode].append(f'{seed}: {exc}')
                print(f'{seed:5d} {kind:>17s} {"hot" if hot else "cold":>5s} {mode:>7s} '
                      f'refused: {exc}')
                continue
            rows[mode].append(r)
            print(f'{seed:5d} {kind:>17s} {"hot" if hot else "cold":>5s} {mode:>7s} '
                  f'{r["improvement"]:7.1%} {r["comp_floor"]:10.2f} {r["rms_deg_h"]:8.4f} '
                  f'{r["u_m_deg_h"]:8.4f} {r["cover1"]:5.0%} {r["cover2"]:5.0%} '
                  f'{r["cover1_cov"]:8.0%} {r["cover2_cov"]:8.0%}  {r["terms"]}')
    print()
    for mode, rs in rows.items():
        if not rs:
            continue
        imp = np.array([r['improvement'] for r in rs])
        rms = np.array([r['rms_deg_h'] for r in rs])
        cf = np.array([r['comp_floor'] for r in rs])
        print(f'{mode}: {len(rs)} benches calibrated, {len(refused[mode])} refused; improvement '
              f'median {np.median(imp):.1%} (min {imp.min():.1%}, max {imp.max():.1%}); '
              f'compensated/floor median {np.median(cf):.2f}; rms model error median '
              f'{np.median(rms):.4f} °/h (max {rms.max():.4f}); law within ±1σ '
              f'{np.mean([r["cover1"] for r in rs]):.0%}, ±2σ '
              f'{np.mean([r["cover2"] for r in rs]):.0%} of the trajectory points '
              f'(covariance only: {np.mean([r["cover1_cov"] for r in rs]):.0%}, '
              f'{np.mean([r["cover2_cov"] for r in rs]):.0%})')
    print(f'{n} benches × 2 sensor modes in {time.perf_counter() - t0:.0f} s')


if __name__ == '__main__':
    main()
