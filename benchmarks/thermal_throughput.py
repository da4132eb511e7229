"""Time per hour of data: thermal simulator, streaming calibrator, compensation.

Measures, on this machine (print includes the core count):

- the simulator (offline, streamed in 10-minute chunks) at 10 Hz and 1 kHz pulses;
- the ThermalCalibrator fed in 50 000-sample chunks with ``process()`` after each (as a
  bag reader would), at 1 kHz pulses over a −35…35 °C ramp cycle: reduction speed, the
  fit at the end, and the most pulse samples it ever holds;
- ``compensate`` on a 10 Hz recording.

    python benchmarks/thermal_throughput.py [--quick] [--hours H]
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gyro_calib.thermal.calibrator import ThermalCalibrator, ThermalSettings  # noqa: E402
from gyro_calib.thermal.compensate import compensate  # noqa: E402
from sim_nodes.thermal.chamber import paper_soak_programme, ramp_programme  # noqa: E402
from sim_nodes.thermal.gyro import ThermalGyroSimulator  # noqa: E402
from sim_nodes.thermal.scenarios import gyro_config, paper_soak_scenario  # noqa: E402


def _simulate(rate_hz: float, hours: float) -> tuple[float, int]:
    cfg = gyro_config('A-1', pulse_rate_hz=rate_hz)
    sim = ThermalGyroSimulator(cfg, paper_soak_programme(), duration_s=hours * 3600)
    t = time.perf_counter()
    n = sum(len(c.pulse_t_ns) for c in sim.chunks(600.0))
    return time.perf_counter() - t, n


def main() -> None:
    """Print the figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--quick', action='store_true', help='0.5 h at 1 kHz instead of 2 h')
    ap.add_argument('--hours', type=float, default=None)
    args = ap.parse_args()
    hours = args.hours or (0.5 if args.quick else 2.0)
    print(f'thermal throughput, {os.cpu_count()} cores')
    for rate in (10.0, 1000.0):
        h = 8.0 if rate == 10.0 else hours
        dt, n = _simulate(rate, h)
        print(f'simulator {rate:6g} Hz: {dt / h:6.2f} s per hour of data '
              f'({n} pulse samples, {h * 3600 / dt:,.0f}× real time)')

    cfg = gyro_config('A-1', pulse_rate_hz=1000.0)
    span = hours * 3600
    ramps = ramp_programme(-35.0, 35.0, rate_c_per_min=70.0 / (0.4 * span / 60),
                           dwell_s=0.06 * span)
    sim = ThermalGyroSimulator(cfg, ramps, duration_s=span)
    settings = ThermalSettings(scale_factor_rad_per_pulse=cfg.scale_factor_rad_per_pulse,
                               latitude_deg=cfg.latitude_deg, gyro_id='A-1',
                               candidate_terms='static')
    cal = ThermalCalibrator(settings)
    t_reduce = 0.0
    peak_held = 0
    for chunk in sim.chunks(50.0):  # 50 000 samples at 1 kHz
        t = time.perf_counter()
        cal.extend_pulses(chunk.pulse_t_ns, chunk.pulse_counts)
        cal.extend_temperatures(chunk.temperature_t_ns, chunk.temperature_c,
                                chunk.temperature_frame_id)
        cal.process()
        t_reduce += time.perf_counter() - t
        peak_held = max(peak_held, len(cal._pulses.buffer))
    t = time.perf_counter()
    lines = cal.process(flush=True)
    t_fit = time.perf_counter() - t
    if not cal.results():
        print('  (fit failed: ' + ' '.join(lines) + ')')
    print(f'calibrator 1 kHz: reduction {t_reduce / hours:6.2f} s per hour of data '
          f'({hours * 3600 / t_reduce:,.0f}× real time); pulse samples held at most '
          f'{peak_held}; fit of {hours:g} h {t_fit:.2f} s')

    rec = paper_soak_scenario('A-1', seed=1)
    hours_rec = rec.duration_s / 3600
    settings = ThermalSettings(scale_factor_rad_per_pulse=cfg.scale_factor_rad_per_pulse,
                               latitude_deg=cfg.latitude_deg, gyro_id='A-1', max_h_power=4)
    cal = ThermalCalibrator(settings)
    t = time.perf_counter()
    cal.extend_pulses(rec.pulse_t_ns, rec.pulse_counts)
    cal.extend_temperatures(rec.temperature_t_ns, rec.temperature_c, rec.temperature_frame_id)
    cal.process(flush=True)
    t_cal = time.perf_counter() - t
    t = time.perf_counter()
    compensate(cal.model(), rec.pulse_t_ns, rec.pulse_counts, rec.temperature_t_ns,
               rec.temperature_c, rec.temperature_frame_id, gyro_id='A-1')
    t_comp = time.perf_counter() - t
    print(f'paper run ({hours_rec:.1f} h, 10 Hz, dynamic terms up to H^4): calibration '
          f'{t_cal:.2f} s ({t_cal / hours_rec:.2f} s/h), compensation {t_comp:.2f} s '
          f'({t_comp / hours_rec:.3f} s/h)')
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f'peak RSS of this process {rss:.0f} MiB (includes the whole 10 Hz recording arrays)')



if __name__ == '__main__':
    main()
