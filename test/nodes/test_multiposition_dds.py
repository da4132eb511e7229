"""The multiposition method over DDS.

A replayed bag of a hand-turned IMU into multiposition_calibration_node gives the offline
hand-off (the imu: section's M and the accelerometer's A) bit for bit.
"""

from __future__ import annotations

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
