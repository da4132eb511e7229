"""imu_multiposition_sim into multiposition_calibration_node over DDS.

The simulator turns its IMU through the 18 poses of ``multiposition_hand_turned`` as fast as
the calibration node acknowledges; the node finds the poses as they come, finishes by itself
once the pose set is well-conditioned (before the run's end) and exits 0; its hand-off is the
offline calibration of the simulator's samples up to the finishing stamp, bit for bit, and
every parameter is within 3 u of the truth the simulator published.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

from gyro_calib.bagio import SampleBatch
from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.handoff import load_calibration
from gyro_calib.multiposition.session import IMU, MultipositionSession
from gyro_calib.session import CalibrationOptions
from sim_nodes.multiposition.scenarios import IMU_TOPIC, SCENARIOS

from .dds_harness import NodeProcess, launch


def offline_up_to(cut_ns: int) -> MultipositionSession:
    """The scenario's samples stamped up to ``cut_ns``, calibrated offline at the site."""
    scenario = SCENARIOS['multiposition_hand_turned']
    run = scenario.run()
    stamps = scenario.stamps_ns(run)
    keep = stamps <= cut_ns
    cols = TopicColumns(IMU_TOPIC, IMU, stamps[keep].copy(), stamps[keep],
                        FrameIds(np.zeros(int(keep.sum()), dtype=np.int32), ('imu',)),
                        {'angular_velocity_rad_s': run.gyro[keep],
                         'linear_acceleration_m_s2': run.acc[keep]})
    session = MultipositionSession(CalibrationOptions(
        latitude_deg=scenario.procedure.latitude_deg))
    session.feed(SampleBatch({IMU_TOPIC: cols}, len(cols), int(stamps[keep][-1])))
    session.process(flush=True)
    return session


def test_the_node_finishes_on_the_simulated_imu_within_the_truth(
        nodes: list[NodeProcess], tmp_path: Path) -> None:
    out = tmp_path / 'imu.yaml'
    node = launch('multiposition_calibration_node', {'output_file': str(out),
                                                     'latitude_deg': 45.0})
    nodes.append(node)
    nodes.append(launch('imu_multiposition_sim', {'real_time_factor': 0.0},
                        expect_exit=(0, 3)))  # 3: its reader left (the node finished)
    try:
        status = node.proc.wait(timeout=120.0)
    except subprocess.TimeoutExpired:
        raise AssertionError('the node did not finish by itself:\n'
                             + node.log()[-3000:]) from None
    assert status == 0, node.log()[-3000:]
    log = node.log()
    assert 'pose set well-conditioned' in log
    assert '(new: #1 from 0.0 s (+x)' in log  # the first rest, named with its gravity direction
    assert 'still needed: ' in log and 'rejected' not in log  # a rest still going on is not
    cal = load_calibration(out)
    cut = int(cal.methods['multiposition'].conditions['finished_at_stamp_ns'])
    scenario = SCENARIOS['multiposition_hand_turned']
    stamps = scenario.stamps_ns(scenario.run())
    assert stamps[0] < cut < stamps[-1]  # before the end of the run
    offline = offline_up_to(cut)
    expected = offline.imu_calibration()
    assert expected is not None and expected.pulses_to_body_rad is not None
    assert cal.imu is not None and cal.imu.pulses_to_body_rad is not None
    np.testing.assert_array_equal(cal.imu.pulses_to_body_rad, expected.pulses_to_body_rad)
    np.testing.assert_array_equal(np.array(cal.imu.accelerometer['raw_to_body']),
                                  np.array(expected.accelerometer['raw_to_body']))
    truth = scenario.truth()
    for key, est in offline.results().items():
        assert abs(est.value - truth[key]) <= 3 * est.std_uncertainty, (key, est, truth[key])
