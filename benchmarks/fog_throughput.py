"""FOG simulator and calibration throughput, as ratios to real time, and peak memory.

- the equivalent (long-run) loop model over both offline scenarios at 1 kHz;
- the loop simulated every transit time τ (≈ 4.9 µs) over a short run;
- calibration of those recordings: batch (one call per stream) and streamed in chunks of
  50 000 messages per stream (as a bag reader feeds it);
- peak resident memory of this process.

    python benchmarks/fog_throughput.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import time

import numpy as np

from gyro_calib.fog import FogCalibrator, calibrate_fog
from sim_nodes.fog import (
    FogConfig,
    FogSimulator,
    InjectionSchedule,
    SelfCalLadder,
    TableSettings,
    simulate_mapping_and_self_cal,
    simulate_turntable,
)
from sim_nodes.fog.scenarios import FogRecording


def _streamed(rec: FogRecording, chunk: int) -> FogCalibrator:
    cal = FogCalibrator()
    streams = [(rec.output_t_ns, (rec.output_counts,), cal.extend_output),
               (rec.injection_t_ns, (rec.injection_counts_s,), cal.extend_injection),
               (rec.table_t_ns, (rec.table_angle_rad, rec.table_rate_rad_s),
                cal.extend_table_states),
               (rec.zero_index_ns, (), cal.extend_zero_index)]
    longest = max(len(s[0]) for s in streams)
    for start in range(0, longest, chunk):
        for t, values, extend in streams:
            if start < len(t):
                extend(t[start:start + chunk], *(v[start:start + chunk] for v in values))
        cal.process()
    cal.process(flush=True)
    return cal


def main() -> None:
    """Time the simulator and the calibration; print ratios to real time."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='shorter scenarios')
    args = parser.parse_args()
    hold = 20.0 if args.quick else 60.0
    plateau = 4.0 if args.quick else 10.0
    print(f'FOG throughput ({os.cpu_count()} cores)')
    table = TableSettings(output_rate_hz=1000.0)
    for name, make in (
            ('turntable multi-rate', lambda: simulate_turntable(hold_s=hold, table=table)),
            ('mapping + self-cal (55 plateaus)', lambda: simulate_mapping_and_self_cal(
                mapping_hold_s=hold, ladder=SelfCalLadder(plateau_s=plateau), table=table))):
        t0 = time.perf_counter()
        rec = make()
        sim_s = time.perf_counter() - t0
        span = rec.duration_s
        t0 = time.perf_counter()
        batch = calibrate_fog(rec.output_t_ns, rec.output_counts,
                              injection_t_ns=rec.injection_t_ns,
                              injection_counts_s=rec.injection_counts_s,
                              table_t_ns=rec.table_t_ns, table_angle_rad=rec.table_angle_rad,
                              table_rate_rad_s=rec.table_rate_rad_s,
                              zero_index_ns=rec.zero_index_ns)
        batch_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        streamed = _streamed(rec, 50_000)
        stream_s = time.perf_counter() - t0
        same = streamed.results() == batch.results()
        n = len(rec.output_t_ns)
        print(f'{name}: {span:.0f} s of data, {n} output samples at 1 kHz')
        print(f'  simulation (equivalent model, table + FOG): {sim_s:.2f} s = '
              f'{span / sim_s:.0f}× real time')
        print(f'  calibration batch: {batch_s:.2f} s = {span / batch_s:.0f}× real time; '
              f'streamed in 50 000-message chunks: {stream_s:.2f} s = {span / stream_s:.0f}× '
              f'(results identical: {same})')
    cfg = FogConfig()
    duration = 0.5 if args.quick else 2.0
    t = np.arange(0, int(duration * 1e9) + 1, 1_000_000, dtype=np.int64)
    w = np.full(len(t), math.radians(20.0))
    sim = FogSimulator(cfg, model='loop', injection=InjectionSchedule([int(duration / 2 * 1e9)],
                                                                      [5000.0]))
    t0 = time.perf_counter()
    sim.step(t, w * t / 1e9, w)
    loop_s = time.perf_counter() - t0
    steps = duration / cfg.transit_time_s
    print(f'loop every τ = {cfg.transit_time_s * 1e6:.3f} µs: {duration:g} s ({steps:.0f} steps) '
          f'in {loop_s:.2f} s = {duration / loop_s:.2f}× real time '
          f'({loop_s / steps * 1e6:.2f} µs per step)')
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f'peak RSS of this process: {peak:.0f} MiB')


if __name__ == '__main__':
    main()
