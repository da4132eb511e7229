"""bench_demo: the simulated bench calibrating a rate-biased RLG end to end over DDS.

Starts calibration_node, rlg_sim and rate_table_sim on a private, loopback-only DDS
domain, faster than real time, and runs the full procedure: the K̃ phase (rate table
spinning on the tilted mount), then the θ phase (rate table at four stations, position
table turning). Every node's own log (accepted windows and stations, rejections) is shown
as it comes; at the end K̃, θ, K and bias are printed beside the simulator's truth, and
the hand-off file is written where ``--out`` says.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import time

from gyro_calib.nodes.processes import pick_domain_id, ros_environment, start_node
from gyro_calib.units import ARCSEC_PER_RAD
from sim_nodes.rbrlg.bench import true_k_tilde_arcsec_per_pulse
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """Command-line options of the demo."""
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                allow_abbrev=False)
    p.add_argument('--pairs', type=int, default=3, help='K̃-phase window pairs (3)')
    p.add_argument('--speed', type=float, default=5.0, help='real-time factor (5)')
    p.add_argument('--seed', type=int, default=1, help='simulator seed (1)')
    p.add_argument('--out', default='gyro_calibration.yaml',
                   help='hand-off file to write (gyro_calibration.yaml)')
    return p.parse_args(argv)


def refusal(opts: argparse.Namespace) -> str | None:
    """Why the options cannot run the bench, in one line (None: they can), before any work.

    ``--pairs`` at least 1 (the K̃ phase needs a forward/reverse pair), ``--speed`` a
    positive finite real-time factor, ``--seed`` at least 0, ``--out`` a file that can be
    written (not a directory, in an existing writable directory).
    """
    from gyro_calib.errors import ConfigError
    from gyro_calib.outputs import check_output_file

    if opts.pairs < 1:
        return (f'--pairs {opts.pairs} is invalid: the K̃ phase needs at least 1 '
                'forward/reverse window pair; give --pairs 1 or more.')
    if not (math.isfinite(opts.speed) and opts.speed > 0):
        return (f'--speed {opts.speed:g} is invalid: the real-time factor must be a positive '
                'number (e.g. 5 for five times real time).')
    if opts.seed < 0:
        return f'--seed {opts.seed} is invalid: a seed is an integer ≥ 0.'
    try:
        check_output_file(opts.out, '--out', follow_links=True)
    except ConfigError as exc:
        return str(exc).replace('Nothing was read.', 'Nothing was started.')
    return None


def main(argv: list[str] | None = None) -> int:
    """Run the bench; return 0 when K was measured, 2 for options it cannot run with."""
    opts = parse_args(argv)
    why = refusal(opts)
    if why is not None:
        print(f'bench_demo: error: {why}', file=sys.stderr)
        return 2
    domain = pick_domain_id()
    env = ros_environment(domain)
    gyro = RingLaserGyroConfig(seed=opts.seed)
    print(f'bench_demo: DDS domain {domain} (loopback only); full procedure at '
          f'{opts.speed:g}× real time', flush=True)
    out = os.path.abspath(opts.out)
    procs = [
        start_node('calibration_node', {'latitude_deg': gyro.latitude_deg, 'output_file': out,
                                        'angle_random_walk_deg_sqrt_h':
                                            gyro.angle_random_walk_deg_sqrt_h},
                   env),
        start_node('rlg_sim', {'seed': opts.seed}, env),
    ]
    table = start_node('rate_table_sim', {'scenario': 'full', 'k_tilde_pairs': opts.pairs,
                                          'real_time_factor': float(opts.speed),
                                          'seed': opts.seed}, env)
    procs.append(table)
    try:
        result = _watch(env, table, timeout_s=(60 * opts.pairs + 230) / max(opts.speed, 0.1)
                        + 300.0)
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        for proc in procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
    if 'scale_factor_rad_per_pulse' not in result:
        print('bench_demo: the calibration did not complete.', file=sys.stderr)
        return 1
    _print_summary(result, gyro, out)
    return 0


def _print_summary(diag: dict[str, str], gyro: RingLaserGyroConfig, out: str) -> None:
    k_tilde = float(diag['k_tilde_arcsec_per_pulse'])
    k = float(diag['scale_factor_rad_per_pulse']) * ARCSEC_PER_RAD
    k_std = float(diag['scale_factor_std_uncertainty_rad_per_pulse']) * ARCSEC_PER_RAD
    theta = float(diag['fix_error_angle_rad']) * ARCSEC_PER_RAD
    theta_std = float(diag['fix_error_angle_std_uncertainty_rad']) * ARCSEC_PER_RAD
    rows = [
        ('K̃ (″/pulse)', f'{k_tilde:.10f}',
         f'{float(diag["k_tilde_std_uncertainty_arcsec_per_pulse"]):.1e}',
         f'{true_k_tilde_arcsec_per_pulse(gyro):.10f}'),
        ('θ (″)', f'{theta:.3f}', f'{theta_std:.3f}', f'{gyro.fix_error_angle_arcsec:.3f}'),
        ('K (″/pulse)', f'{k:.10f}', f'{k_std:.1e}', f'{gyro.scale_factor_arcsec_per_pulse:.10f}'),
        ('bias (°/h)', f'{float(diag["bias_deg_h"]):.4f}',
         f'{float(diag["bias_std_uncertainty_deg_h"]):.4f}', f'{gyro.bias_deg_h:.4f} + drift'),
    ]
    print(f'\n{"quantity":<14}{"measured":>16}{"std unc.":>12}{"truth":>18}')
    for row in rows:
        print(f'{row[0]:<14}{row[1]:>16}{row[2]:>12}{row[3]:>18}')
    print(f'K error {(k / gyro.scale_factor_arcsec_per_pulse - 1) * 1e9:+.2f} ppb from '
          f'{diag["window_pairs"]} window pairs and {diag["stations"]} stations; '
          f'hand-off file: {out}', flush=True)


def _watch(env: dict[str, str], table: subprocess.Popen[bytes],
           timeout_s: float) -> dict[str, str]:
    """Listen to /diagnostics in this process until the table has finished."""
    os.environ.update(env)
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray

    from gyro_calib import topics
    from gyro_calib.nodes.ros_distribution import ros_context
    from gyro_calib.nodes.ros_io import make_executor

    latest: dict[str, str] = {}
    with ros_context():
        node = rclpy.create_node('bench_demo')

        def on_diag(msg: DiagnosticArray) -> None:
            for status in msg.status:
                if status.name == 'gyro_calib: k_tilde':
                    latest.clear()
                    latest.update({kv.key: kv.value for kv in status.values})

        node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, on_diag, 10)
        executor = make_executor()
        executor.add_node(node)
        deadline = time.monotonic() + timeout_s
        finished_at = None
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
            if finished_at is None and table.poll() is not None:
                finished_at = time.monotonic()
            if finished_at is not None and latest.get('stations') == '4' and (
                    'scale_factor_rad_per_pulse' in latest):
                break
        node.destroy_node()
    return dict(latest)


if __name__ == '__main__':
    sys.exit(main())
