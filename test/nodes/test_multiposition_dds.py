"""The multiposition method over DDS.

A replayed bag of a hand-turned IMU into multiposition_calibration_node gives the offline
hand-off (the imu: section's M and the accelerometer's A) bit for bit.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import numpy as np

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.handoff import HandoffError, load_calibration
from gyro_calib.multiposition.session import MultipositionSession

from .dds_harness import NodeProcess, launch


def test_replayed_imu_bag_gives_the_offline_imu_section(nodes: list[NodeProcess],
                                                         tmp_path: Path) -> None:
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from multiposition_physics import random_unit, record
    from test_multiposition_cli import imu_bag

    rng = np.random.default_rng(11)
    t, acc, gyro, _ = record(random_unit(rng), rng, poses=13, rate_hz=50.0)
    bag = imu_bag(tmp_path / 'turned', t, gyro, acc)
    offline = calibrate_bags([bag], methods=['multiposition']).sessions['multiposition']
    assert isinstance(offline, MultipositionSession)
    expected = offline.imu_calibration()
    assert expected is not None and expected.pulses_to_body_rad is not None
    out = tmp_path / 'imu.yaml'
    node = launch('multiposition_calibration_node', {'output_file': str(out),
                                                     'analysis_period_s': 1000.0})
    nodes.append(node)
    time.sleep(1.5)
    nodes.append(launch('bag_player', {'bag': str(bag), 'rate': 0.0}))
    got = None
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline:
        try:
            imu = load_calibration(out).imu if out.exists() else None
        except HandoffError:
            imu = None
        if imu is not None and imu.pulses_to_body_rad is not None and np.array_equal(
                imu.pulses_to_body_rad, expected.pulses_to_body_rad):
            got = imu
            break
        time.sleep(1.0)
    assert got is not None, node.log()[-3000:]
    np.testing.assert_array_equal(np.array(got.accelerometer['raw_to_body']),
                                  np.array(expected.accelerometer['raw_to_body']))


def test_the_node_finishes_by_itself_once_the_pose_set_is_well_conditioned(
        nodes: list[NodeProcess], tmp_path: Path) -> None:
    """A replayed recording: the node exits 0 by itself, with the offline result up to then.

    Its hand-off is written at each analysis; the rewrites of its own run log no "replaced"
    line (the new-user walk found one per value at each write, marked "newer run").
    """
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from multiposition_physics import random_unit, record
    from test_multiposition_cli import START_NS, imu_bag

    rng = np.random.default_rng(1)  # 30 poses: well-conditioned from 120 s of 147 s
    t, acc, gyro, _ = record(random_unit(rng), rng, poses=30)
    bag = imu_bag(tmp_path / 'turned', t, gyro, acc)
    out = tmp_path / 'imu.yaml'
    node = launch('multiposition_calibration_node', {'output_file': str(out)})
    nodes.append(node)
    time.sleep(1.5)
    nodes.append(launch('bag_player', {'bag': str(bag), 'rate': 0.0}, expect_exit=(0, 3)))
    try:
        status = node.proc.wait(timeout=120.0)
    except subprocess.TimeoutExpired:
        raise AssertionError('the node did not finish by itself:\n'
                             + node.log()[-3000:]) from None
    assert status == 0, node.log()[-3000:]
    assert 'pose set well-conditioned' in node.log()
    assert 'still needed: a pose with gravity near' in node.log()
    # each write of the hand-off rewrites this run's own values: no "replaced … (newer run)"
    assert node.log().count('calibration written to') + node.log().count('hand-off ') >= 1
    assert 'replaced:' not in node.log(), node.log()[-3000:]
    cal = load_calibration(out)
    cut = int(cal.methods['multiposition'].conditions['finished_at_stamp_ns'])
    stamps = START_NS + np.round(t * 1e9).astype(np.int64)
    assert stamps[0] < cut < stamps[-1]
    keep = stamps <= cut
    part = imu_bag(tmp_path / 'up_to_then', t[keep], gyro[keep], acc[keep])
    offline = calibrate_bags([part], methods=['multiposition']).sessions['multiposition']
    assert isinstance(offline, MultipositionSession)
    expected = offline.imu_calibration()
    assert expected is not None and expected.pulses_to_body_rad is not None
    assert cal.imu is not None and cal.imu.pulses_to_body_rad is not None
    np.testing.assert_array_equal(cal.imu.pulses_to_body_rad, expected.pulses_to_body_rad)
    np.testing.assert_array_equal(np.array(cal.imu.accelerometer['raw_to_body']),
                                  np.array(expected.accelerometer['raw_to_body']))
