"""bench_demo: the simulated bench calibrating a rate-biased RLG end to end over DDS.

Starts calibration_node, rlg_sim and rate_table_sim on a private, loopback-only DDS
domain, faster than real time, and runs the full procedure: the K̃ phase (rate table
spinning on the tilted mount), then the θ phase (rate table at four stations, position
table turning). Every node's own log (accepted windows and stations, rejections) is shown
as it comes; at the end K̃, θ, K and bias are printed beside the simulator's truth, and
the hand-off file is written where ``--out`` says.

Ctrl-C (at any instant, to the demo alone or to its whole process group as a terminal
sends it): one line, ``bench_demo: interrupted; …`` naming what was written, exit 130, no
traceback. The nodes run in their own process group, so a terminal's Ctrl-C reaches only
the demo, which stops them itself (SIGTERM: silent while a node still starts, a clean stop
once it runs). A node that exits with an error stops the demo at once: the others are
stopped and one line names the node and its fatal line (exit 2 when the node refused its
input, 1 otherwise). An ``--out`` whose state directory another run holds is refused before
anything starts (exit 2).
"""

from __future__ import annotations

import os
import signal
import sys

from gyro_calib.startup_interrupt import quiet_interrupt_while_starting

quiet_interrupt_while_starting('bench_demo', os.path.join('gyro_calib', 'nodes', 'bench_demo.py'),
                               'nothing started, nothing written')

import argparse  # noqa: E402  (after the interrupt handler: the imports below take seconds)
import math  # noqa: E402
import subprocess  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import IO  # noqa: E402

from gyro_calib.nodes.processes import choose_domain, ros_environment, start_node  # noqa: E402
from gyro_calib.units import ARCSEC_PER_RAD  # noqa: E402
from sim_nodes.rbrlg.bench import true_k_tilde_arcsec_per_pulse  # noqa: E402
from sim_nodes.rbrlg.ring_laser_gyro import RingLaserGyroConfig  # noqa: E402

EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT), as every gyro_calib command."""

STOP_WAIT_S = 10.0
"""How long a node may take to stop cleanly (write its hand-off) before it is killed, s."""


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
    positive finite real-time factor, ``--seed`` at least 0, ``--out`` a hand-off file that
    can be written or updated, checked as ``gyro-calib calibrate --out`` is
    (:func:`gyro_calib.handoff.load.check_handoff_output`: not a directory, in an existing
    writable directory, an existing file a hand-off file).
    """
    from gyro_calib.errors import ConfigError
    from gyro_calib.handoff.load import check_handoff_output
    from gyro_calib.registry import handoff_schema

    if opts.pairs < 1:
        return (f'--pairs {opts.pairs} is invalid: the K̃ phase needs at least 1 '
                'forward/reverse window pair; give --pairs 1 or more.')
    if not (math.isfinite(opts.speed) and opts.speed > 0):
        return (f'--speed {opts.speed:g} is invalid: the real-time factor must be a positive '
                'number (e.g. 5 for five times real time).')
    if opts.seed < 0:
        return f'--seed {opts.seed} is invalid: a seed is an integer ≥ 0.'
    try:
        check_handoff_output(opts.out, '--out', handoff_schema(), nothing='Nothing was started.')
    except ConfigError as exc:
        return str(exc)
    holder = state_lock_holder(os.path.abspath(opts.out))
    if holder is not None:
        return (f'another run ({holder}) is writing {opts.out}: wait for it or give another '
                '--out. Nothing was started.')
    return None


def state_lock_holder(out: str) -> str | None:
    """Who holds the state-directory lock of the hand-off file ``out`` (None: nobody).

    The calibration node keeps its record in ``<out>.state`` and takes ``<out>.state.lock``
    (:class:`~gyro_calib.state_record.StateLock`); a second node on the same file stops
    with a fatal line. The lock is only tested here (never created, never kept).
    """
    import fcntl

    from gyro_calib.nodes.node_state import state_directory

    directory = state_directory('', out)
    assert directory is not None
    try:
        fd = os.open(directory.with_name(directory.name + '.lock'), os.O_RDONLY)
    except OSError:  # no lock file (or none readable): no live holder to wait for
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return ' '.join(os.pread(fd, 300, 0).decode(errors='replace').split()) or 'a process'
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


class _Node:
    """A node the demo started: its process, and the last fatal/error line it logged."""

    def __init__(self, name: str, proc: subprocess.Popen[bytes]) -> None:
        self.name = name
        self.proc = proc
        self.fatal = ''
        self._copier = threading.Thread(target=self._copy, args=(proc.stderr,), daemon=True)
        self._copier.start()

    def _copy(self, stream: IO[bytes] | None) -> None:
        """Pass the node's log on to the demo's stderr, keeping its last fatal/error line."""
        if stream is None:
            return
        for raw in iter(stream.readline, b''):
            line = raw.decode(errors='replace')
            if '[FATAL]' in line or ('[ERROR]' in line and not self.fatal):
                self.fatal = line.strip()
            try:
                sys.stderr.write(line)
                sys.stderr.flush()
            except (OSError, ValueError):  # our stderr closed: keep draining the node's
                pass

    def failed(self, *, may_end: bool) -> int | None:
        """The node's exit status if it ended when it should not have (None: it did not)."""
        code = self.proc.poll()
        if code is None or (code == 0 and may_end):
            return None
        return code

    def stop(self) -> None:
        """SIGTERM (silent while it starts, a clean stop once it runs), then kill."""
        if self.proc.poll() is None:
            self.proc.terminate()
        try:
            self.proc.wait(timeout=STOP_WAIT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self._copier.join(timeout=2.0)

    def why(self) -> str:
        """The node's fatal line without its level/stamp/name prefix."""
        return self.fatal.split(']: ', 1)[-1] if self.fatal else ''


def main(argv: list[str] | None = None) -> int:
    """Run the bench; 0 when K was measured, 2 for options it cannot run with, 130 on Ctrl-C.

    1 when the calibration did not complete or a node failed (2 if it refused its input).
    """
    opts = parse_args(argv)
    why = refusal(opts)
    if why is not None:
        print(f'bench_demo: error: {why}', file=sys.stderr)
        return 2
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _run(opts, stop)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _run(opts: argparse.Namespace, stop: threading.Event) -> int:
    """Run the nodes until the calibration is complete, one fails or Ctrl-C; the exit status.

    The nodes are stopped on every way out (``stop`` is set by SIGINT/SIGTERM).
    """
    domain = choose_domain()
    env = ros_environment(domain.domain)
    gyro = RingLaserGyroConfig(seed=opts.seed)
    print(f'bench_demo: DDS domain {domain.domain} (loopback only; {domain.how}); full '
          f'procedure at {opts.speed:g}× real time', flush=True)
    out = os.path.abspath(opts.out)
    before, state_before = _file_state(out), _file_state(out + '.state')

    def started(name: str, params: dict[str, object]) -> _Node:
        # own process group: a terminal's Ctrl-C reaches the demo only, which stops them
        return _Node(name, start_node(name, params, env, process_group=0,
                                      stderr=subprocess.PIPE))

    nodes: list[_Node] = []
    try:
        nodes.append(started('calibration_node', {
            'latitude_deg': gyro.latitude_deg, 'output_file': out,
            'angle_random_walk_deg_sqrt_h': gyro.angle_random_walk_deg_sqrt_h}))
        nodes.append(started('rlg_sim', {'seed': opts.seed}))
        nodes.append(started('rate_table_sim', {
            'scenario': 'full', 'k_tilde_pairs': opts.pairs,
            'real_time_factor': float(opts.speed), 'seed': opts.seed}))
        result, failed = _watch(env, nodes, stop, timeout_s=(60 * opts.pairs + 230)
                                / max(opts.speed, 0.1) + 300.0)
    finally:
        for node in nodes:
            if node.proc.poll() is None:
                node.proc.terminate()
        for node in nodes:
            node.stop()
    if stop.is_set():
        state = out + '.state'
        written = (f'{out} holds what was measured so far' if _file_state(out) != before
                   else f'{out} not written (the calibration node kept its record in {state})'
                   if _file_state(state) != state_before else 'nothing written')
        print(f'bench_demo: interrupted; {written}.', file=sys.stderr, flush=True)
        return EXIT_INTERRUPTED
    if failed is not None:
        code = failed.proc.returncode
        said = failed.why() or 'see its log above'
        print(f'bench_demo: error: {failed.name} stopped (exit {code}): {said}; the other '
              'nodes were stopped.', file=sys.stderr, flush=True)
        return 2 if code == 2 else 1
    calibrator = nodes[0]
    if calibrator.proc.returncode not in (0, None):  # it stopped cleanly but wrote nothing
        code = calibrator.proc.returncode
        said = calibrator.why() or 'see its log above'
        print(f'bench_demo: error: calibration_node ended with exit {code}: {said}; the '
              f'hand-off file {out} was not written (the node kept its record, see its last '
              'line above).', file=sys.stderr, flush=True)
        return 1
    if 'scale_factor_rad_per_pulse' not in result:
        print('bench_demo: the calibration did not complete.', file=sys.stderr)
        return 1
    _print_summary(result, gyro, out)
    return 0


def _file_state(path: str) -> tuple[int, int] | None:
    """(mtime ns, size) of ``path``, None if absent: tells whether a node wrote it."""
    try:
        st = Path(path).stat()
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


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


def _watch(env: dict[str, str], nodes: list[_Node], stop: threading.Event,
           timeout_s: float) -> tuple[dict[str, str], _Node | None]:
    """Listen to /diagnostics in this process until the table has finished.

    Also ends at once when ``stop`` is set (Ctrl-C) or a node ends when it should not
    (returned second; the table may end with 0, the others not before the demo stops them).
    """
    os.environ.update(env)
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray

    from gyro_calib import topics
    from gyro_calib.nodes.ros_distribution import ros_context
    from gyro_calib.nodes.ros_io import make_executor

    table = nodes[-1]
    latest: dict[str, str] = {}
    failed: _Node | None = None
    if stop.is_set():
        return latest, None
    with ros_context(own_signals=True):
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
        while time.monotonic() < deadline and not stop.is_set():
            executor.spin_once(timeout_sec=0.1)
            failed = next((n for n in nodes if n.failed(may_end=n is table) is not None), None)
            if failed is not None:
                break
            if finished_at is None and table.proc.poll() is not None:
                finished_at = time.monotonic()
            if finished_at is not None and latest.get('stations') == '4' and (
                    'scale_factor_rad_per_pulse' in latest):
                break
        executor.remove_node(node)
        executor.shutdown()
        node.destroy_node()
    return dict(latest), failed


if __name__ == '__main__':
    sys.exit(main())
