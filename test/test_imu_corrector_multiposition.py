"""imu_corrector with a multiposition hand-off: a MEMS sensor_msgs/Imu stream corrected.

Specification (issue 38 §4): with the ``imu:`` section of ``calibrate --method
multiposition`` (gyro M, b; accelerometer A, b_a) and ``imu_input`` the IMU driver's topic,
each message comes out on /imu/data as ω = M·ω_raw − b (K₀ = 1: the section's "pulse" is one
raw unit·s) and a = A·r − b_a, with covariances; the corrected samples of the committed
hand-turned bag match the simulator's true sensor model within the published uncertainty,
where the raw ones are off by the IMU's percent-level errors.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fake_node import FakeNode

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.handoff import write_calibration
from gyro_calib.nodes.imu_corrector_core import IMU_DATA, ImuCorrector
from sim_nodes.multiposition.imu import misalignment_matrix
from sim_nodes.multiposition.scenarios import SCENARIOS

BAG = Path(__file__).resolve().parents[1] / 'bags' / 'multiposition_hand_turned'


@pytest.fixture(scope='module')
def handoff(tmp_path_factory: pytest.TempPathFactory) -> Path:
    session = calibrate_bags([BAG], methods=['multiposition']).sessions['multiposition']
    cal = session.handoff(str(BAG), gyro_id='MEMS-1')
    assert cal is not None and cal.imu is not None
    return write_calibration(tmp_path_factory.mktemp('mp') / 'imu.yaml', cal)


def corrected(path: Path, n: int | None = None) -> tuple[list, FakeNode, np.ndarray,
                                                         np.ndarray, np.ndarray]:
    """The first ``n`` (None: all) samples of the scenario through the corrector."""
    scenario = SCENARIOS['multiposition_hand_turned']
    run = scenario.run()
    stamps = scenario.stamps_ns(run)[:n]
    node = FakeNode()
    corrector = ImuCorrector(node, imu_input='/imu/raw')  # type: ignore[arg-type]
    corrector.poll_file(str(path))
    out = []
    gyro, acc = run.gyro[:n], run.acc[:n]
    for t, w, a in zip(stamps.tolist(), gyro.tolist(), acc.tolist(), strict=True):
        out += corrector.on_imu(t, tuple(w), tuple(a), (4e-4, 0, 0, 0, 4e-4, 0, 0, 0, 4e-4))
    return out, node, stamps, gyro, acc


def test_gyro_and_accelerometer_are_corrected_to_the_true_sensor_model(handoff: Path) -> None:
    out, node, stamps, gyro, acc = corrected(handoff)
    assert any('IMU section (multiposition)' in line and 'K0 = 1' in line
               for line in node.logger.lines), node.logger.lines
    assert len(out) == len(stamps) - 1 and all(topic == IMU_DATA for topic, _ in out)
    imu = SCENARIOS['multiposition_hand_turned'].imu
    true_g = misalignment_matrix(imu.gyro_misalignment_rad) @ np.diag(imu.gyro_scale)
    true_a = misalignment_matrix(imu.acc_misalignment_rad) @ np.diag(imu.acc_scale)
    w_true = (gyro[1:] - imu.gyro_bias) @ true_g.T  # what an ideal gyro would read
    a_true = (acc[1:] - imu.acc_bias) @ true_a.T
    w = np.array([o.angular_velocity_rad_s for _, o in out])
    a = np.array([o.linear_acceleration_m_s2 for _, o in out])
    w_var = np.array([np.diag(np.reshape(o.covariance_rad2_s2, (3, 3))) for _, o in out])
    a_var = np.array([np.diag(np.reshape(o.linear_acceleration_covariance, (3, 3)))
                      for _, o in out])
    # the calibration's error is common to all samples: judged against its own u per sample
    assert np.mean(np.abs(w - w_true) <= 3 * np.sqrt(w_var)) > 0.99
    assert np.mean(np.abs(a - a_true) <= 3 * np.sqrt(a_var)) > 0.99
    # the raw samples are far off the truth (the IMU's errors), the corrected ones close
    # (measured: 0.0123 → 1.8e-4 rad/s, 0.25 → 9.8e-4 m/s²)
    assert np.sqrt(np.mean((w - w_true) ** 2)) < np.sqrt(np.mean((gyro[1:] - w_true) ** 2)) / 30
    assert np.sqrt(np.mean((a - a_true) ** 2)) < np.sqrt(np.mean((acc[1:] - a_true) ** 2)) / 100


def test_the_correction_is_the_sections_matrices_exactly(handoff: Path) -> None:
    import yaml

    section = yaml.safe_load(handoff.read_text(encoding='utf-8'))['imu']
    m = np.array(section['pulses_to_body_rad'])
    b = np.array(section['bias_rad_s'])
    acc_section = section['accelerometer']
    a_mat, b_a = np.array(acc_section['raw_to_body']), np.array(acc_section['bias_m_s2'])
    out, _, _, gyro, acc = corrected(handoff, 300)
    assert len(out) == 299
    for i, (_, o) in enumerate(out):
        np.testing.assert_allclose(o.angular_velocity_rad_s, m @ gyro[i + 1] - b,
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(o.linear_acceleration_m_s2, a_mat @ acc[i + 1] - b_a,
                                   rtol=0, atol=1e-12)
        cov = np.reshape(o.linear_acceleration_covariance, (3, 3))
        assert np.all(np.linalg.eigvalsh(cov) > 0)  # the driver's 4e-4 through A, plus A's u


def test_a_given_raw_scale_other_than_one_is_used_and_named(handoff: Path) -> None:
    node = FakeNode()
    corrector = ImuCorrector(node, imu_input='/imu/raw',  # type: ignore[arg-type]
                             raw_scale_rad_per_pulse=2.0)
    corrector.poll_file(str(handoff))
    assert corrector.k0 == 2.0
    assert any('raw_scale_rad_per_pulse as given; the section implies 1' in line
               for line in node.logger.lines)


def test_a_triad_section_without_accelerometer_still_needs_raw_scale(tmp_path: Path) -> None:
    from test_imu_corrector_modes import _write_triad

    node = FakeNode()
    corrector = ImuCorrector(node, imu_input='/imu/raw')  # type: ignore[arg-type]
    corrector.poll_file(str(_write_triad(tmp_path / 'triad.yaml', ('x', 'y', 'z'))))
    assert corrector.k0 == 0.0 and corrector.accel_correction is None
    assert any('needs raw_scale_rad_per_pulse' in line for line in node.logger.lines)
