"""imu_corrector fed a replayed thermal bag over DDS, under CPU load: the offline numbers?

Issue 24 §5b: imu_corrector judged each pulse against the newest temperature that had
arrived, so a replay gave other numbers depending on how DDS interleaved /gyro/pulses and
/gyro/temperature (a flaky DDS test). This replays a slice of a committed thermal bag
(``bags/thermal_validation``, the first ``--seconds``) with ``bag_player`` as fast as the
readers take it (rate 0) to ``imu_corrector`` holding the model fitted on
``bags/thermal_calibration``, ``--runs`` times, beside two CPU-burning processes, and
compares every /gyro/imu message with what the offline compensation gives the same pulse
pair (:func:`gyro_calib.thermal.compensate.offline_pairs`, the numbers
``gyro-calib compensate --out`` writes): angular_velocity.z and its variance bit for bit.

A run *differs* when one message differs from the offline number, or when a pulse pair the
offline compensation gives a rate (more than 40 s before the end of the slice: the tail
stays held, no later temperature decides it) got none. Goal: 0 runs differ.

    python benchmarks/imu_corrector_replay_under_load.py [--runs 20] [--seconds 600]

Runs on its own DDS domain (``--domain``, default 154), loopback only.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

BAG = REPO / 'bags' / 'thermal_validation'
CALIBRATION_BAG = REPO / 'bags' / 'thermal_calibration'


def slice_bag(src: Path, out: Path, seconds: float) -> None:
    """The first ``seconds`` (log time) of ``src`` as a new bag at ``out``."""
    from gyro_calib.bagio import BagMessage, bag_info, iter_raw_messages, write_bag

    info = bag_info(src)
    start: int | None = None

    def messages() -> Any:
        nonlocal start
        for topic, _, log_ns, cdr in iter_raw_messages(src):
            start = log_ns if start is None else start
            if log_ns - start > seconds * 1e9:
                return
            yield BagMessage(topic, log_ns, cdr)

    write_bag(out, messages(), types={t.name: t.msgtype for t in info.topics.values()},
              scenario=dict(info.scenario))


def model_file(out: Path) -> Path:
    """The thermal model of the calibration bag, as a hand-off file."""
    from gyro_calib.bag_calibration import calibrate_bags
    from gyro_calib.handoff import write_calibration

    session = calibrate_bags([CALIBRATION_BAG], methods=['thermal']).sessions['thermal']
    record = session.handoff('imu_corrector_replay_under_load')
    assert record is not None, 'the calibration bag gave no thermal model'
    write_calibration(out, record)
    return out


def offline_rates(bag: Path, calibration: Path) -> dict[int, tuple[float, float]]:
    """Stamp → (angular_velocity.z, its variance) the offline compensation gives."""
    from gyro_calib.bagio import iter_sample_batches
    from gyro_calib.handoff import load_calibration
    from gyro_calib.imu_conversion import angular_velocity_from_pulses, pulse_calibration
    from gyro_calib.registry import JOINT_STATE, TEMPERATURE
    from gyro_calib.thermal.compensate import CompensatedPair, offline_pairs
    from gyro_calib.thermal.topics import GYRO_PULSES, GYRO_TEMPERATURE

    pt: list[np.ndarray] = []
    pc: list[np.ndarray] = []
    tt: list[np.ndarray] = []
    tc: list[np.ndarray] = []
    tf: list[np.ndarray] = []
    for batch in iter_sample_batches(bag, {GYRO_PULSES: JOINT_STATE,
                                           GYRO_TEMPERATURE: TEMPERATURE}):
        js = batch.joint_state(GYRO_PULSES)
        if js is not None:
            pt.append(js[0])
            pc.append(js[1])
        temps = batch.columns.get(GYRO_TEMPERATURE)
        if temps is not None and len(temps.stamp_ns):
            tt.append(temps.stamp_ns)
            tc.append(temps.values['temperature_degc'])
            tf.append(np.asarray(temps.frame_id.names, dtype=str)[temps.frame_id.codes])
    cal = pulse_calibration(load_calibration(calibration))
    assert cal.thermal_model is not None
    pairs = offline_pairs(cal.thermal_model, np.concatenate(pt), np.concatenate(pc),
                          np.concatenate(tt), np.concatenate(tc), np.concatenate(tf))
    out = {}
    for o in pairs:
        if isinstance(o, CompensatedPair):
            r = angular_velocity_from_pulses(o.t0_ns, o.count0, o.t1_ns, o.count1,
                                             dataclasses.replace(cal, bias_rad_s=o.bias_rad_s,
                                                                 bias_std=o.bias_std))
            out[o.t1_ns] = (r.angular_velocity_rad_s[2], r.covariance_rad2_s2[8])
    return out


class Listener:
    """Collects /gyro/imu in this process."""

    def __init__(self) -> None:
        import rclpy
        from sensor_msgs.msg import Imu

        from gyro_calib.nodes.ros_io import SENSOR_QOS, make_executor

        self._rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('replay_under_load_listener', context=self.context)
        self.imu: list[Any] = []
        self.node.create_subscription(Imu, '/gyro/imu', self.imu.append, SENSOR_QOS)
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)

    def spin(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        self.node.destroy_node()
        self._rclpy.shutdown(context=self.context)


def one_run(bag: Path, calibration: Path, env: dict[str, str], timeout_s: float,
            last_stamp: int) -> tuple[list[Any], str]:
    """Start imu_corrector and bag_player; the /gyro/imu messages received, the node's log.

    Waits until a message stamped ``last_stamp`` or later came, or 60 s without a new one
    once the player is done (the corrector works through its backlog after the player
    finishes: reliable delivery paces the player by the reader's acknowledgements only).
    """
    from gyro_calib.nodes.processes import start_node

    def stamp(m: Any) -> int:
        return int(m.header.stamp.sec) * 10**9 + int(m.header.stamp.nanosec)

    listener = Listener()
    with tempfile.TemporaryDirectory() as scratch:
        log = Path(scratch) / 'imu_corrector.log'
        with log.open('wb') as err:
            corrector = start_node('imu_corrector', {'calibration_file': str(calibration)},
                                   env, stdout=subprocess.DEVNULL, stderr=err, cwd=scratch)
        try:
            player = start_node('bag_player', {'bag': str(bag), 'rate': 0.0}, env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                cwd=scratch)  # waits for the corrector's subscriptions
            deadline = time.monotonic() + timeout_s
            while player.poll() is None and time.monotonic() < deadline:
                listener.spin(0.5)
            if player.poll() is None:
                player.kill()
            player.wait()
            n, quiet_since = len(listener.imu), time.monotonic()
            while time.monotonic() < deadline and time.monotonic() - quiet_since < 60:
                if listener.imu and stamp(listener.imu[-1]) >= last_stamp:
                    break
                listener.spin(1.0)
                if len(listener.imu) != n:
                    n, quiet_since = len(listener.imu), time.monotonic()
        finally:
            corrector.terminate()
            corrector.wait()
        text = log.read_text(errors='replace')
    msgs = list(listener.imu)
    listener.close()
    return msgs, text


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--runs', type=int, default=20)
    parser.add_argument('--seconds', type=float, default=600.0,
                        help='length of the slice of bags/thermal_validation replayed, s')
    parser.add_argument('--burners', type=int, default=2)
    parser.add_argument('--domain', type=int, default=154)
    parser.add_argument('--timeout', type=float, default=600.0, help='per replay, s')
    parser.add_argument('--node-tree', type=Path, default=REPO,
                        help='checkout the nodes run from (another one: before/after)')
    args = parser.parse_args()
    from gyro_calib.nodes.processes import ros_environment

    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ['ROS_DOMAIN_ID'] = str(args.domain)
    env = ros_environment(args.domain)
    env['PYTHONPATH'] = str(args.node_tree.resolve())
    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / 'slice'
        slice_bag(BAG, bag, args.seconds)
        calibration = model_file(Path(tmp) / 'thermal.yaml')
        offline = offline_rates(bag, calibration)
        end = max(offline)
        settled = {t for t in offline if t <= end - 40 * 10**9}
        print(f'{BAG.name}, first {args.seconds:g} s: {len(offline)} offline rates '
              f'({len(settled)} before the last 40 s); {args.runs} replays at rate 0 beside '
              f'{args.burners} CPU burners')
        burners = [subprocess.Popen([sys.executable, '-c', 'while True: pass'])
                   for _ in range(args.burners)]
        differing = 0
        try:
            print(f'{"run":>4} {"received":>9} {"wrong":>6} {"missing":>8} {"held":>5} '
                  f'{"wall s":>7}')
            for run in range(1, args.runs + 1):
                t0 = time.monotonic()
                msgs, log = one_run(bag, calibration, env, args.timeout, max(settled))
                got = {m.header.stamp.sec * 10**9 + m.header.stamp.nanosec:
                       (m.angular_velocity.z, m.angular_velocity_covariance[8]) for m in msgs}
                wrong = sum(1 for t, v in got.items() if offline.get(t) != v)
                missing = len(settled - set(got))
                held = len(set(offline) - set(got) - settled)
                differing += bool(wrong or missing)
                print(f'{run:>4} {len(got):>9} {wrong:>6} {missing:>8} {held:>5} '
                      f'{time.monotonic() - t0:>7.1f}', flush=True)
                if wrong or missing:
                    print('     imu_corrector log (last lines):\n     '
                          + '\n     '.join(log.splitlines()[-6:]), flush=True)
        finally:
            for b in burners:
                b.kill()
                b.wait()
    print(f'runs differing from the offline numbers: {differing} of {args.runs}')
    return 0 if differing == 0 else 1


if __name__ == '__main__':
    sys.exit(main())
