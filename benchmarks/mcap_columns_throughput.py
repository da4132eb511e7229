"""Columnar MCAP decoding (gyro_calib.bagio.columns): throughput, exactness, memory.

Run (from the repository root, in the project's venv):

    nice -n 10 python benchmarks/mcap_columns_throughput.py [--hours 1.0] [--quick]
        [--cache /tmp/gyro_calib_bench] [--windows 4]

Two bags, generated once into ``--cache`` (each in a child process):

* the contract bag of ``benchmarks/bag_throughput.py`` (the k_tilde_bench scenario run for
  ``--hours``: 1 kHz pulses, 200 Hz rate-table joint states, zero-index events), made by
  its own generator;
* an IMU bag of the same length: ``sensor_msgs/Imu`` at 400 Hz (a static IMU: white gyro
  and accelerometer noise, a random-walk gyro bias, gravity on z) and
  ``sensor_msgs/Temperature`` of three sensors (cavity_a, cavity_b, shell) at 1 Hz each on
  one topic, written by gyro_calib.bagio.write_bag (rosbags' Writer, zstd chunks).

For each bag:

(a) Decoding only: ``iter_column_batches`` over the whole bag in a fresh child process —
    wall and CPU time per message, the ratio to real time (bag duration / wall time;
    target ≥ 1500×) and the ratio the CPU time alone would give (the machine may be shared:
    its load average is printed), messages rosbags had to decode, and the child's peak RSS
    (its own ru_maxrss via wait4; target < 500 MB).
(b) Exactness: ``--windows`` log-time windows spread over the bag (each about two chunks
    long) decoded both ways — columnar, and rosbags' reader + ``deserialize_cdr`` (the
    module's ``decoder='rosbags'``) — and compared bit for bit; rosbags' time per message
    on them for comparison.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'benchmarks'))

IMU_TOPIC = '/imu/data'
TEMPERATURE_TOPIC = '/imu/temperature'
IMU_RATE_HZ = 400.0
SENSORS = ('cavity_a', 'cavity_b', 'shell')


def contract_bag(cache: Path, hours: float) -> Path:
    """The 1 kHz contract bag of benchmarks/bag_throughput.py (its generator, its name)."""
    from bag_throughput import _bag

    return _bag(cache, f'k_tilde_{hours:g}h', hours * 3600.0)


def imu_bag(cache: Path, hours: float) -> Path:
    """The 400 Hz IMU bag, generated once in a child process."""
    path = cache / f'imu_400hz_{hours:g}h'
    if not (path / 'metadata.yaml').exists():
        t0 = time.perf_counter()
        subprocess.run([sys.executable, __file__, '--generate-imu', str(path), '--hours',
                        str(hours)], check=True, cwd=ROOT)
        print(f'generated {path} in {time.perf_counter() - t0:.1f} s', flush=True)
    return path


def generate_imu_bag(path: Path, hours: float, seed: int = 11) -> None:
    """A static IMU at 400 Hz and three temperature sensors at 1 Hz, streamed to a bag.

    Gyro: white noise 1e-4 rad/s per sample plus a bias random walk (1e-6 rad/s per
    sample); accelerometer: white noise 2e-3 m/s² on (0, 0, 9.80665) m/s²; temperatures:
    45 °C plus a slow drift and 0.01 °C noise. Seeded; generated in blocks of 4000 samples.
    """
    import numpy as np

    from gyro_calib.bagio import BagMessage, write_bag
    from gyro_calib.bagio import typestore as _typestore
    from gyro_calib.bagio.messages import IMU, TEMPERATURE

    store = _typestore()
    t = store.types
    time_msg, header = t['builtin_interfaces/msg/Time'], t['std_msgs/msg/Header']
    vector, quaternion = t['geometry_msgs/msg/Vector3'], t['geometry_msgs/msg/Quaternion']
    imu, temperature = t[IMU], t[TEMPERATURE]
    cov = np.zeros(9)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    n = int(hours * 3600 * IMU_RATE_HZ)
    step_ns = int(round(1e9 / IMU_RATE_HZ))
    start_ns = 1_700_000_000_000_000_000

    def stamp(t_ns: int, frame_id: str = 'imu_link') -> object:
        sec, nsec = divmod(t_ns, 1_000_000_000)
        return header(stamp=time_msg(sec=sec, nanosec=nsec), frame_id=frame_id)

    def messages():
        bias = np.zeros(3)
        for first in range(0, n, 4000):
            k = np.arange(first, min(first + 4000, n))
            walk = bias + np.cumsum(rng.normal(0, 1e-6, (len(k), 3)), axis=0)
            bias = walk[-1]
            gyro = walk + rng.normal(0, 1e-4, (len(k), 3))
            accel = rng.normal(0, 2e-3, (len(k), 3)) + (0.0, 0.0, 9.80665)
            for i, kk in enumerate(k):
                t_ns = start_ns + int(kk) * step_ns
                msg = imu(header=stamp(t_ns), orientation=quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
                          orientation_covariance=cov, angular_velocity=vector(*gyro[i]),
                          angular_velocity_covariance=cov,
                          linear_acceleration=vector(*accel[i]),
                          linear_acceleration_covariance=cov)
                yield BagMessage(IMU_TOPIC, t_ns, bytes(store.serialize_cdr(msg, IMU)))
                if kk % int(IMU_RATE_HZ) == 0:
                    for j, sensor in enumerate(SENSORS):
                        h = stamp(t_ns + j, sensor)
                        degc = 45.0 + 1e-4 * kk / IMU_RATE_HZ + rng.normal(0, 0.01)
                        yield BagMessage(TEMPERATURE_TOPIC, t_ns + j, bytes(store.serialize_cdr(
                            temperature(header=h, temperature=degc, variance=1e-4),
                            TEMPERATURE)))

    write_bag(path, messages(), types={IMU_TOPIC: IMU, TEMPERATURE_TOPIC: TEMPERATURE})


def topic_types(bag: Path) -> dict[str, str]:
    """Every topic of the bag whose type the columnar decoder knows."""
    from gyro_calib.bagio import bag_info
    from gyro_calib.bagio.layouts import KNOWN_TYPES

    return {t.name: t.msgtype for t in bag_info(bag).topics.values()
            if t.msgtype in KNOWN_TYPES}


def measure(bag: Path) -> None:
    """Child process: decode the whole bag, print one JSON line of figures."""
    from gyro_calib.bagio.columns import iter_column_batches
    from gyro_calib.bagio.plan import plan_bag

    types = topic_types(bag)
    t0, c0 = time.perf_counter(), time.process_time()
    n = fallback = batches = 0
    for batch in iter_column_batches(bag, types):
        n += batch.messages
        fallback += batch.fallback_messages
        batches += 1
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(json.dumps({'messages': n, 'fallback': fallback, 'batches': batches, 'wall': wall,
                      'cpu': cpu, 'columnar': plan_bag(bag, types).columnar}))


def decode_only(bag: Path, duration_s: float) -> None:
    with subprocess.Popen([sys.executable, __file__, '--measure', str(bag)],
                          stdout=subprocess.PIPE, text=True, cwd=ROOT) as proc:
        out = proc.stdout.read() if proc.stdout else ''
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise SystemExit(f'the measuring child failed (exit {proc.returncode})')
    r = json.loads(out.strip().splitlines()[-1])
    n, wall, cpu = r['messages'], r['wall'], r['cpu']
    load = ', '.join(f'{x:.1f}' for x in os.getloadavg())
    print(f'(a) decoding only ({"columnar" if r["columnar"] else "rosbags whole"}): '
          f'{n} messages in {wall:.2f} s wall, {cpu:.2f} s CPU: '
          f'{wall / n * 1e6:.3f} µs/message wall, {cpu / n * 1e6:.3f} µs/message CPU')
    print(f'    ratio to real time: {duration_s / wall:.0f}× (wall; target ≥ 1500×), '
          f'{duration_s / cpu:.0f}× (CPU time alone); load average {load}')
    print(f'    decoded by rosbags (layout fallback): {r["fallback"]}; {r["batches"]} batches; '
          f'peak RSS {usage.ru_maxrss / 1024:.0f} MB (target < 500 MB)')


def exactness(bag: Path, windows: int) -> None:
    import numpy as np

    from gyro_calib.bagio import bag_info
    from gyro_calib.bagio.columns import iter_column_batches
    from gyro_calib.bagio.plan import plan_bag

    types = topic_types(bag)
    info = bag_info(bag)
    plan = plan_bag(bag, types)
    chunk_ns = max((g[-1].end_ns - g[0].start_ns for g in plan.groups), default=10**9)
    starts = np.linspace(info.start_ns, info.end_ns - 2 * chunk_ns, windows).astype(np.int64)
    compared = 0
    rosbags_s = 0.0
    for start in starts:
        window = {'start_ns': int(start), 'stop_ns': int(start + 2 * chunk_ns)}
        mine = list(iter_column_batches(bag, types, **window))
        t0 = time.perf_counter()
        ref = list(iter_column_batches(bag, types, decoder='rosbags', **window))
        rosbags_s += time.perf_counter() - t0
        compared += sum(b.messages for b in ref)
        for topic in types:
            a = [b.topics[topic] for b in mine if topic in b.topics]
            b = [b.topics[topic] for b in ref if topic in b.topics]
            if not b:
                assert not a, topic
                continue
            for get in (lambda c: c.log_time_ns, lambda c: c.stamp_ns,
                        lambda c: c.frame_id.strings()):
                assert list(np.concatenate([get(c) for c in a])) == list(
                    np.concatenate([get(c) for c in b])), topic
            for name in b[0].values:
                x = np.concatenate([c.values[name] for c in a]).view(np.uint64)
                y = np.concatenate([c.values[name] for c in b]).view(np.uint64)
                assert np.array_equal(x, y), (topic, name)
    print(f'(b) bit-identical to rosbags\' reader + deserialize_cdr on {compared} messages in '
          f'{windows} windows of {2 * chunk_ns / 1e9:.1f} s (stamps, values incl. NaN bits, '
          f'frame_ids, order); rosbags took {rosbags_s / compared * 1e6:.1f} µs/message there')


def bench(label: str, bag: Path, windows: int) -> None:
    from gyro_calib.bagio import bag_info

    info = bag_info(bag)
    size = sum(f.stat().st_size for f in bag.iterdir()) / 1e6
    print(f'{label}: {bag} — {info.duration_s:.0f} s, {info.message_count} messages, '
          f'{size:.1f} MB; topics: ' + ', '.join(
              f'{t.name} ({t.msgtype.rsplit("/", 1)[-1]}, {t.count})'
              for t in info.topics.values()), flush=True)
    decode_only(bag, info.duration_s)
    exactness(bag, windows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--hours', type=float, default=1.0)
    parser.add_argument('--quick', action='store_true', help='0.1-hour bags, 2 windows')
    parser.add_argument('--cache', type=Path, default=Path('/tmp/gyro_calib_bench'))
    parser.add_argument('--windows', type=int, default=4)
    parser.add_argument('--measure', type=Path, help=argparse.SUPPRESS)
    parser.add_argument('--generate-imu', type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.measure:
        measure(args.measure)
        return
    if args.generate_imu:
        generate_imu_bag(args.generate_imu, args.hours)
        return
    hours, windows = (0.1, 2) if args.quick else (args.hours, args.windows)
    args.cache.mkdir(parents=True, exist_ok=True)
    print(f'machine: {os.cpu_count()} cores (decoding: one thread, plus one reading and '
          f'decompressing chunks ahead); load average '
          + ', '.join(f'{x:.1f}' for x in os.getloadavg()), flush=True)
    bench('contract bag (1 kHz pulses, 200 Hz joint states)', contract_bag(args.cache, hours),
          windows)
    bench('IMU bag (400 Hz Imu, 3 × 1 Hz Temperature)', imu_bag(args.cache, hours), windows)


if __name__ == '__main__':
    main()
