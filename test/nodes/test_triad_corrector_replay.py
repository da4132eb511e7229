"""imu_corrector over DDS on a replayed committed triad bag (issue 26 §3).

bag_player plays the first 12 s of /imu/pulses of ``triad_remount_bench_px`` (the table
accelerating, then cruising) into ``imu_corrector`` with the hand-off
`gyro-calib calibrate --method triad` writes for the six remount bags; every Imu it publishes
on /imu/data is, bit for bit, the rclpy-free core's rate and covariance for that stamp — the
core whose rates test/test_triad_corrector_on_bags.py checks against the simulator's truth.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from fake_node import FakeNode

from gyro_calib.bagio import BagMessage, ContractMessages, iter_raw_messages, typestore, write_bag
from gyro_calib.cli import main as gyro_calib
from gyro_calib.nodes.imu_corrector_core import ImuCorrector

from .dds_harness import NodeProcess, bench_node, launch, spin_watched

BAGS = Path(__file__).resolve().parents[2] / 'bags'
BAG = 'triad_remount_bench_px'
SECONDS = 12.0


def test_replayed_triad_bag_gives_the_cores_body_rates_on_imu_data(
        nodes: list[NodeProcess], tmp_path: Path) -> None:
    from sensor_msgs.msg import Imu
    from test_triad_corrector_on_bags import REMOUNTS

    from gyro_calib.nodes.ros_io import SENSOR_QOS

    handoff = tmp_path / 'imu.yaml'
    assert gyro_calib(['calibrate', *[str(BAGS / n) for n in REMOUNTS], '--method', 'triad',
                       '--out', str(handoff)]) == 0
    store, cdr = typestore(), ContractMessages()
    samples: list[tuple[int, list[str], list[float]]] = []
    for topic, msgtype, _, raw in iter_raw_messages(BAGS / BAG):
        if topic == '/imu/pulses':
            m = store.deserialize_cdr(raw, msgtype)
            samples.append((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec, list(m.name),
                            list(m.position)))
    samples = [s for s in samples if s[0] - samples[0][0] <= SECONDS * 1e9]
    bag = tmp_path / 'head'
    write_bag(bag, [BagMessage('/imu/pulses', t, cdr.joints_state(t, n, p))
                    for t, n, p in samples])
    core = ImuCorrector(FakeNode())
    core.poll_file(str(handoff))
    expected = {o.stamp_ns: (o.angular_velocity_rad_s, o.covariance_rad2_s2)
                for t, n, p in samples for _, o in core.on_imu_pulses(t, n, p)}
    assert len(expected) == len(samples) - 1
    corrector = launch('imu_corrector', {'calibration_file': str(handoff)})
    nodes.append(corrector)
    with bench_node('test_triad_replay_reader') as (node, executor):
        got: list[Any] = []
        sub = node.create_subscription(Imu, '/imu/data', got.append, SENSOR_QOS)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (  # the corrector's output reaches us
                sub.get_publisher_count() > 0 and 'publishing /imu/data' in corrector.log()):
            spin_watched(executor, timeout_sec=0.05)
        assert 'publishing /imu/data' in corrector.log(), corrector.log()
        nodes.append(launch('bag_player', {'bag': str(bag), 'rate': 0.0}))
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline and len(got) < len(expected):
            spin_watched(executor, timeout_sec=0.05)
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in got]
    assert len(got) == len(expected), (len(got), len(expected), corrector.log()[-2000:])
    assert stamps == sorted(expected)
    for stamp, msg in zip(stamps, got, strict=True):
        v = msg.angular_velocity
        assert ((v.x, v.y, v.z), tuple(msg.angular_velocity_covariance)) == expected[stamp]
