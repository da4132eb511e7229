"""The committed multiposition bag (bags/multiposition_hand_turned), calibrated offline.

A MEMS IMU turned by hand through 18 poses (sim_nodes/multiposition): every accelerometer and
gyro parameter lands within k = 3 of its standard uncertainty of the truth the bag stores
(the gyro bias holds the Earth rate averaged over the poses, §G.3, inside its u), the pose set
is well-conditioned, and the numbers are pinned (a change to the estimator shows here).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import bag_info
from gyro_calib.multiposition.session import MultipositionSession

BAGS = Path(__file__).resolve().parents[1] / 'bags'
NAME = 'multiposition_hand_turned'

PINNED = {  # value, u (k = 1) of the committed bag, by result key
    'imu.accelerometer.misalignment_yz_rad': (0.00403378779736353, 0.000147781),
    'imu.accelerometer.misalignment_zy_rad': (-0.006141891056290413, 0.000146593),
    'imu.accelerometer.misalignment_zx_rad': (0.009132053557389294, 0.00014955),
    'imu.accelerometer.scale_x': (1.0120593500809736, 8.22445e-05),
    'imu.accelerometer.scale_y': (0.9911261536685761, 8.07688e-05),
    'imu.accelerometer.scale_z': (1.0038666735510284, 8.65004e-05),
    'imu.accelerometer.bias_x_raw': (0.12007191483052233, 0.000570455),
    'imu.accelerometer.bias_y_raw': (-0.20921642999404633, 0.000584034),
    'imu.accelerometer.bias_z_raw': (0.34984289135452, 0.000600867),
    'imu.gyro.misalignment_yz_rad': (0.005802758198164406, 0.000134399),
    'imu.gyro.misalignment_zy_rad': (-0.004205022577727766, 0.000132675),
    'imu.gyro.misalignment_zx_rad': (0.011211211364791465, 0.000143664),
    'imu.gyro.misalignment_xz_rad': (-0.008026623350093891, 0.000141559),
    'imu.gyro.misalignment_xy_rad': (0.004764117423732232, 0.0001361),
    'imu.gyro.misalignment_yx_rad': (0.007216151966465339, 0.000139111),
    'imu.gyro.scale_x': (0.9852030996874502, 8.91698e-05),
    'imu.gyro.scale_y': (1.0180910328799966, 0.000154588),
    'imu.gyro.scale_z': (1.0070143201786428, 9.91901e-05),
    'imu.gyro.bias_x_raw': (0.010934033872727537, 3.82726e-05),
    'imu.gyro.bias_y_raw': (-0.007052894570386686, 3.38889e-05),
    'imu.gyro.bias_z_raw': (0.0040232153070200736, 4.38825e-05),
}


@pytest.fixture(scope='module')
def session() -> MultipositionSession:
    s = calibrate_bags([BAGS / NAME], methods=['multiposition']).sessions['multiposition']
    assert isinstance(s, MultipositionSession)
    return s


def test_every_parameter_is_within_its_stated_uncertainty_of_the_truth(
        session: MultipositionSession) -> None:
    expected = yaml.safe_load((BAGS / f'{NAME}.expected.yaml').read_text(encoding='utf-8'))
    k = expected['tolerance']['k_standard_uncertainties']
    results = session.results()
    assert len(results) == 21
    for key, est in results.items():
        truth = expected['truth'][key]
        assert abs(est.value - truth) <= k * est.std_uncertainty, (key, est, truth)
    assert session.gravity == pytest.approx(expected['truth']['gravity_m_s2'], abs=1e-12)
    assert session.gravity_source == 'normal gravity at 45°, 0 m'  # the bag's bench latitude


def test_the_numbers_are_pinned(session: MultipositionSession) -> None:
    results = session.results()
    assert set(results) == set(PINNED)
    for key, (value, u) in PINNED.items():
        assert results[key].value == pytest.approx(value, abs=1e-6 * u), key
        assert results[key].std_uncertainty == pytest.approx(u, rel=1e-5), key


def test_all_poses_are_found_and_the_set_is_well_conditioned(
        session: MultipositionSession) -> None:
    expected = yaml.safe_load((BAGS / f'{NAME}.expected.yaml').read_text(encoding='utf-8'))
    r = session.result
    assert r is not None
    assert len(r.detection.intervals) == expected['static_poses'] and not r.detection.rejected
    assert r.well_conditioned
    assert bag_info(BAGS / NAME).scenario['bench'] == {'latitude_deg': 45.0}
