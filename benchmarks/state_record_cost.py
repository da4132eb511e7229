"""What a node's state directory costs per hour of data: disk, append CPU, replay time.

Run (from the repository root, in the project's venv):

    python benchmarks/state_record_cost.py [--hours 1.0] [--pulse-hz 1000] [--table-hz 200]
        [--imu-hz 0]

One hour of a rate-bias bench is handed to :class:`gyro_calib.state_record.StateRecord` as
a live node does: every 0.2 s one batch of the pulses, the table's joint states and the
zero-index events (and, with ``--imu-hz``, a six-axis Imu stream) is appended. Printed:
bytes on disk per hour, CPU seconds spent appending per hour (and as a share of the hour),
and the time to replay the whole record after a crash.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.state_record import StateRecord

PERIOD_S = 0.2
"""A node's hand-over period (process_period_s)."""


def _columns(topic: str, msgtype: str, t_ns: np.ndarray,
             values: dict[str, np.ndarray]) -> TopicColumns:
    frames = FrameIds(np.zeros(len(t_ns), np.int32), ('',))
    return TopicColumns(topic, msgtype, t_ns, t_ns, frames, values)


def main() -> None:
    """Append one simulated hour in 0.2 s batches; print disk, CPU and replay figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--hours', type=float, default=1.0)
    parser.add_argument('--pulse-hz', type=float, default=1000.0)
    parser.add_argument('--table-hz', type=float, default=200.0)
    parser.add_argument('--imu-hz', type=float, default=0.0)
    args = parser.parse_args()
    directory = Path(tempfile.mkdtemp(prefix='gyro_calib_state_bench_'))
    record = StateRecord(directory / 'state', {'method': 'rbrlg'})
    n_batches = int(round(args.hours * 3600.0 / PERIOD_S))
    rng = np.random.default_rng(1)
    messages = 0
    cpu = 0.0
    for k in range(n_batches):
        t0 = int(k * PERIOD_S * 1e9)

        def stamps(rate_hz: float, t0: int = t0) -> np.ndarray:
            n = int(round(rate_hz * PERIOD_S))
            return t0 + (np.arange(n) * (1e9 / rate_hz)).astype(np.int64)

        batch = {}
        if args.pulse_hz > 0:
            tp = stamps(args.pulse_hz)
            batch['/gyro/pulses'] = _columns(
                '/gyro/pulses', 'sensor_msgs/msg/JointState', tp,
                {'position': np.cumsum(rng.integers(0, 2000, len(tp))).astype(float),
                 'velocity': np.full(len(tp), np.nan)})
        if args.table_hz > 0:
            tt = stamps(args.table_hz)
            batch['/rate_table/joint_states'] = _columns(
                '/rate_table/joint_states', 'sensor_msgs/msg/JointState', tt,
                {'position': rng.normal(size=len(tt)), 'velocity': rng.normal(size=len(tt))})
        if k % 12 == 0 and args.table_hz > 0:
            batch['/rate_table/zero_index'] = _columns(
                '/rate_table/zero_index', 'std_msgs/msg/Header', np.array([t0], np.int64), {})
        if args.imu_hz > 0:
            ti = stamps(args.imu_hz)
            batch['/imu/data'] = _columns(
                '/imu/data', 'sensor_msgs/msg/Imu', ti,
                {'angular_velocity_rad_s': rng.normal(size=(len(ti), 3)),
                 'linear_acceleration_m_s2': rng.normal(size=(len(ti), 3))})
        messages += sum(len(c) for c in batch.values())
        started = time.process_time()
        record.append(batch)
        cpu += time.process_time() - started
    record.close()
    size = sum(p.stat().st_size for p in (directory / 'state').iterdir())
    started = time.perf_counter()
    reread = StateRecord(directory / 'state', {'method': 'rbrlg'})
    replayed = sum(sum(len(c) for c in b.values()) for b in reread.replay())
    replay_s = time.perf_counter() - started
    hours = args.hours
    print(f'{hours:g} h: {messages} messages in {n_batches} batches of {PERIOD_S:g} s '
          f'(pulses {args.pulse_hz:g} Hz, table {args.table_hz:g} Hz'
          + (f', Imu {args.imu_hz:g} Hz' if args.imu_hz else '') + ')')
    print(f'disk: {size / 1e6 / hours:.1f} MB per hour ({size / messages:.1f} bytes/message)')
    print(f'append CPU: {cpu / hours:.2f} s per hour ({100 * cpu / (hours * 3600):.3f} % of '
          f'the hour; {1e6 * cpu / messages:.2f} µs/message, fsync every 5 s included)')
    print(f'replay after a crash: {replay_s:.2f} s for {replayed} messages')
    assert replayed == messages
    shutil.rmtree(directory, ignore_errors=True)


if __name__ == '__main__':
    main()
