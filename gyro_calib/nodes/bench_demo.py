"""bench_demo: the simulated bench calibrating K̃ end to end over DDS.

Starts calibration_node, rlg_sim and rate_table_sim on a private, loopback-only
DDS domain, faster than real time, and prints the running K̃ beside the truth
the simulator was given (K / cos θ). Every node's own log (accepted windows,
rejections) is shown as it comes.
"""

from __future__ import annotations

import argparse
import math
import signal
import subprocess
import sys
import time

from gyro_calib.nodes.processes import pick_domain_id, ros_environment, start_node
from gyro_calib.units import ARCSEC_PER_RAD
from sim_nodes.bench import true_k_tilde_arcsec_per_pulse
from sim_nodes.ring_laser_gyro import RingLaserGyroConfig


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line options of the demo."""
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--duration', type=float, default=300.0, help='simulated seconds (300)')
    p.add_argument('--speed', type=float, default=5.0, help='real-time factor (5)')
    p.add_argument('--seed', type=int, default=1, help='simulator seed (1)')
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Run the bench; return 0 when K̃ was measured."""
    opts = parse_args(argv)
    domain = pick_domain_id()
    env = ros_environment(domain)
    gyro = RingLaserGyroConfig(seed=opts.seed)
    truth = true_k_tilde_arcsec_per_pulse(gyro)
    print(f'bench_demo: DDS domain {domain} (loopback only); simulating {opts.duration:g} s at '
          f'{opts.speed:g}× real time', flush=True)
    print(f'truth: K = {gyro.scale_factor_arcsec_per_pulse:.8f} ″/pulse, θ = '
          f'{gyro.fix_error_angle_arcsec:g}″ → K̃ = K/cos θ = {truth:.10f} ″/pulse', flush=True)
    procs = [start_node('calibration_node', {}, env), start_node('rlg_sim', {'seed': opts.seed}, env)]
    table = start_node('rate_table_sim', {'duration_s': float(opts.duration),
                                          'real_time_factor': float(opts.speed),
                                          'seed': opts.seed}, env)
    procs.append(table)
    result = _watch(env, table, timeout_s=opts.duration / max(opts.speed, 0.1) + 120.0)
    for proc in procs:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    for proc in procs:
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
    if result is None:
        print('bench_demo: no K̃ was published.', file=sys.stderr)
        return 1
    k_rad, n_pairs = result
    k = k_rad * ARCSEC_PER_RAD
    print(f'\nresult: K̃ = {k:.10f} ″/pulse from {n_pairs} window pairs; truth {truth:.10f}; '
          f'error {(k / truth - 1) * 1e9:+.2f} ppb', flush=True)
    return 0


def _watch(env: dict[str, str], table: subprocess.Popen[bytes],
           timeout_s: float) -> tuple[float, int] | None:
    """Listen to the results in this process until the table has finished."""
    import os

    os.environ.update(env)
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import Float64

    from gyro_calib import topics
    from gyro_calib.nodes.ros_io import RESULT_QOS

    latest: dict[str, float | int] = {}
    with rclpy.init():
        node = rclpy.create_node('bench_demo')
        node.create_subscription(Float64, topics.K_TILDE,
                                 lambda m: latest.__setitem__('k', m.data), RESULT_QOS)

        def on_diag(msg: DiagnosticArray) -> None:
            for status in msg.status:
                if status.name == 'gyro_calib: k_tilde':
                    values = {kv.key: kv.value for kv in status.values}
                    latest['pairs'] = int(values.get('window_pairs', 0))

        node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, on_diag, 10)
        deadline = time.monotonic() + timeout_s
        finished_at = None
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
            if finished_at is None and table.poll() is not None:
                finished_at = time.monotonic()
            if finished_at is not None and time.monotonic() - finished_at > 3.0:
                break
        node.destroy_node()
    if 'k' not in latest:
        return None
    return float(latest['k']), int(latest.get('pairs', 0))


if __name__ == '__main__':
    sys.exit(main())
