"""Simulator and estimator speed (as ratios to real time) and memory on a long record.

Run (from the repository root):

    nice -n 10 .venv/bin/python benchmarks/dither_throughput.py          # 1 h record, ~2-4 min
    nice -n 10 .venv/bin/python benchmarks/dither_throughput.py --quick  # 10 min record

One orientation of the default gyro (2 kHz pulses, 1 kHz joint_states) is simulated chunk by
chunk (20 000 pulse samples, 10 s) and each chunk is fed to a ``DitherCalibrator`` at once,
as a live node or a bag reader would: the whole record is never held in memory. Printed:
simulator and estimator time as multiples of real time (each measured alone), the peak
resident memory of the process before and after, and the component found. A second line
runs the estimator on the same chunks fed sample by sample (``add_*``, the live-node path)
for the first 60 s.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import time

from gyro_calib.dither.calibrator import DitherCalibrator
from gyro_calib.dither.settings import DitherSettings
from sim_nodes.dither.bench import DitherBenchConfig, DitherBenchSimulator
from sim_nodes.dither.gyro import DitheredGyroConfig
from sim_nodes.dither.vibration_table import VibrationTableConfig

ARCMIN = math.pi / 180 / 60


def peak_rss_mib() -> float:
    """Peak resident set size of this process, MiB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true')
    args = parser.parse_args()
    duration = 600.0 if args.quick else 3600.0
    gyro = DitheredGyroConfig(misalignment_arcmin=10.0)
    sim = DitherBenchSimulator(gyro, VibrationTableConfig(),
                               DitherBenchConfig(duration_s=duration))
    cal = DitherCalibrator(DitherSettings(
        scale_factor_rad_per_pulse=gyro.scale_factor_rad_per_pulse))
    print(f'dither throughput: {duration / 60:.0f} min record at 2 kHz on {os.cpu_count()} cores')
    rss0 = peak_rss_mib()
    t_sim = t_cal = 0.0
    n_chunks = 0
    while not sim.finished:
        t0 = time.perf_counter()
        chunk = sim.step(20000)
        t1 = time.perf_counter()
        cal.extend_pulses(chunk.pulse_t_ns, chunk.counts)
        cal.extend_table_states(chunk.table_t_ns, chunk.table_angle_rad, chunk.table_rate_rad_s,
                                'z')
        cal.process()
        t2 = time.perf_counter()
        t_sim += t1 - t0
        t_cal += t2 - t1
        n_chunks += 1
    t0 = time.perf_counter()
    cal.end_recording()
    comps, _ = cal.components()
    t_cal += time.perf_counter() - t0
    c = comps['z']
    print(f'simulator  {duration / t_sim:7.0f}× real time ({t_sim:.1f} s for {n_chunks} chunks)')
    print(f'estimator  {duration / t_cal:7.0f}× real time ({t_cal:.1f} s, '
          f'{c.n_blocks} blocks of {cal.settings.block_s:g} s)')
    print(f'peak RSS   {rss0:.0f} MiB after imports → {peak_rss_mib():.0f} MiB after the run '
          f'(pulse buffer bounded to one block; {len(cal.pulses)} samples held at the end)')
    print(f'component  {c.signed_rad / ARCMIN:+.2f}′ ± {c.statistical_std_rad / ARCMIN:.2f}′ '
          f'(floor {c.floor.component_std_rad / ARCMIN:.2f}′; truth a·sin ψ₀ = '
          f'{10 * math.sin(math.radians(gyro.ia_azimuth_deg)):.2f}′ shifted by the rocking)')
    # live path: sample by sample
    sim = DitherBenchSimulator(gyro, VibrationTableConfig(), DitherBenchConfig(duration_s=60.0))
    live = DitherCalibrator(cal.settings)
    t_live = 0.0
    while not sim.finished:
        chunk = sim.step(2000)
        t0 = time.perf_counter()
        j = 0
        for t, n in zip(chunk.pulse_t_ns.tolist(), chunk.counts.tolist()):
            live.add_pulses(t, n)
            if j < len(chunk.table_t_ns) and chunk.table_t_ns[j] == t:
                live.add_table_state(t, float(chunk.table_angle_rad[j]),
                                     float(chunk.table_rate_rad_s[j]), 'z')
                j += 1
        live.process()
        t_live += time.perf_counter() - t0
    print(f'live path  {60.0 / t_live:7.0f}× real time (add_pulses / add_table_state per sample, '
          'process() every second)')


if __name__ == '__main__':
    main()
