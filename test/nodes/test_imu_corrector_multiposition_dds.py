"""imu_corrector with a multiposition hand-off over DDS (issue 38 §4).

imu_multiposition_sim (namespace /raw: its Imu on /raw/imu/data) feeds imu_corrector
(``imu_input:=/raw/imu/data``) whose calibration file is the hand-off of the committed
hand-turned bag; every /imu/data message is the core's correction of that sample: ω = M·ω_raw
− b, a = A·r − b_a, with the covariances (test/test_imu_corrector_multiposition.py).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.handoff import write_calibration
from sim_nodes.multiposition.scenarios import SCENARIOS

from .dds_harness import NodeProcess, bench_node, launch, spin_watched

BAG = Path(__file__).resolve().parents[2] / 'bags' / 'multiposition_hand_turned'


def test_the_corrector_applies_the_multiposition_section_to_the_simulated_imu(
        nodes: list[NodeProcess], tmp_path: Path) -> None:
    from sensor_msgs.msg import Imu

    from gyro_calib.nodes.ros_io import SENSOR_QOS

    session = calibrate_bags([BAG], methods=['multiposition']).sessions['multiposition']
    cal = session.handoff(str(BAG))
    assert cal is not None and cal.imu is not None
    handoff = write_calibration(tmp_path / 'imu.yaml', cal)
    m, b = np.array(cal.imu.pulses_to_body_rad), np.array(cal.imu.bias_rad_s)
    a_mat = np.array(cal.imu.accelerometer['raw_to_body'])
    b_a = np.array(cal.imu.accelerometer['bias_m_s2'])
    scenario = SCENARIOS['multiposition_hand_turned']
    run = scenario.run()
    index = {int(t): i for i, t in enumerate(scenario.stamps_ns(run))}

    corrector = launch('imu_corrector', {'calibration_file': str(handoff),
                                         'imu_input': '/raw/imu/data'})
    nodes.append(corrector)
    # started together (the simulator waits for its reader, the corrector): whatever reaches
    # this reader is compared by its stamp
    nodes.append(launch('imu_multiposition_sim', {'real_time_factor': 20.0}, namespace='/raw'))
    with bench_node('test_mp_corrector_reader') as (reader, executor):
        got: list[Any] = []
        sub = reader.create_subscription(Imu, '/imu/data', got.append, SENSOR_QOS)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (sub.get_publisher_count() > 0
                                                   and 'K0 = 1' in corrector.log()):
            spin_watched(executor, timeout_sec=0.05)
        assert 'K0 = 1' in corrector.log(), corrector.log()
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and len(got) < 300:
            spin_watched(executor, timeout_sec=0.05)
        assert len(got) >= 300, corrector.log()[-3000:]
        for msg in got:
            i = index[msg.header.stamp.sec * 10 ** 9 + msg.header.stamp.nanosec]
            w = (msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z)
            a = (msg.linear_acceleration.x, msg.linear_acceleration.y,
                 msg.linear_acceleration.z)
            np.testing.assert_allclose(w, m @ run.gyro[i] - b, rtol=0, atol=1e-9)
            np.testing.assert_allclose(a, a_mat @ run.acc[i] - b_a, rtol=0, atol=1e-12)
            assert np.all(np.linalg.eigvalsh(np.reshape(
                msg.linear_acceleration_covariance, (3, 3))) > 0)
