"""Parts of the multiposition method: local g, the imu.accelerometer section, the readers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gyro_calib.imu_calibration import ImuCalibration, ImuSectionError, imu_from_section
from gyro_calib.multiposition.gravity import normal_gravity_m_s2
from gyro_calib.multiposition.readers import RecordingFormatError, read_imu_tk, read_xyz6
from gyro_calib.multiposition.rotation import body_rotations


@pytest.mark.parametrize(('lat', 'h', 'g'), [
    (0.0, 0.0, 9.7803253359), (90.0, 0.0, 9.8321849379), (45.0, 0.0, 9.806199203),
    (45.0, 1000.0, 9.806199203 - 3.0860e-3)])
def test_normal_gravity_is_wgs84(lat: float, h: float, g: float) -> None:
    """WGS 84 normal gravity on the ellipsoid; about −3.086 mGal per 10 m above it."""
    assert normal_gravity_m_s2(lat, h) == pytest.approx(g, abs=2e-6)


def test_the_accelerometer_part_round_trips_and_unknown_keys_are_refused() -> None:
    """imu.accelerometer written is read back; a typo'd key is named."""
    acc = {'raw_unit': 'm/s²', 'raw_to_body': np.eye(3).tolist(),
           'bias_m_s2': [0.1, 0.2, 0.3], 'bias_m_s2_std': [0.01] * 3, 'poses': 20}
    section = ImuCalibration(('x', 'y', 'z'), accelerometer=acc).to_section()
    assert imu_from_section(section).accelerometer == acc
    section['accelerometer'] = {**acc, 'bias_ms2': [0, 0, 0]}
    with pytest.raises(ImuSectionError, match='bias_ms2'):
        imu_from_section(section)
    section['accelerometer'] = {'raw_to_body': np.eye(3).tolist()}
    with pytest.raises(ImuSectionError, match='together'):
        imu_from_section(section)


def test_rotations_compose_in_order() -> None:
    """Two quarter turns, about x then about the new z, compose as R_x·R_z."""
    steps = np.zeros((1, 2, 3))
    steps[0, 0] = [math.pi / 2, 0, 0]
    steps[0, 1] = [0, 0, math.pi / 2]
    rx = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    rz = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    np.testing.assert_allclose(body_rotations(steps)[0], rx @ rz, atol=1e-12)


def test_readers_refuse_mismatched_or_short_files(tmp_path: Path) -> None:
    """IMU-TK files with different stamps, a log of five columns: one sentence each."""
    a, g = tmp_path / 'a.mat', tmp_path / 'g.mat'
    a.write_text('0.0 1 2 3\n0.01 1 2 3\n')
    g.write_text('0.0 1 2 3\n0.02 1 2 3\n')
    with pytest.raises(RecordingFormatError, match='stamps differ'):
        read_imu_tk(a, g)
    log = tmp_path / 'x.log'
    log.write_text('1 2 3 4 5\n')
    with pytest.raises(RecordingFormatError, match='6'):
        read_xyz6(log, 100.0)


def test_the_directions_gravity_never_came_near_are_named() -> None:
    """Poses with gravity only near +z and −x: the other four directions are still needed."""
    from gyro_calib.multiposition.calibrator import directions_not_held

    u = np.array([[0.0, 0.0, 1.0], [0.2, 0.0, 0.98], [-1.0, 0.0, 0.0]])
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    assert directions_not_held(u) == ['+x', '+y', '−y', '−z']
    assert directions_not_held(np.vstack((np.eye(3), -np.eye(3)))) == []
