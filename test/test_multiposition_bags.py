"""The committed multiposition bags, calibrated offline.

- multiposition_hand_turned: a MEMS IMU turned by hand through 18 poses at 50 Hz;
- multiposition_few_poses_low_rate: the odd-but-legal end — 13 poses, 20 Hz, 2.5–3 s
  rests, 16-bit outputs (sim_nodes/multiposition).

Every accelerometer and gyro parameter lands within k = 3 of its standard uncertainty of the
truth the bag stores (the gyro bias holds the Earth rate averaged over the poses, §G.3, inside
its u), every pose is found and none rejected, the pose set is well-conditioned, and the
numbers are pinned (a change to the estimator shows here).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from gyro_calib.bag_calibration import calibrate_bags
from gyro_calib.bagio import bag_info
from gyro_calib.multiposition.session import MultipositionSession

BAGS = Path(__file__).resolve().parents[1] / 'bags'
NAMES = ('multiposition_hand_turned', 'multiposition_few_poses_low_rate')

PINNED = {  # value, u (k = 1) of each committed bag, by result key
    'multiposition_hand_turned': {
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
    },
    'multiposition_few_poses_low_rate': {
        'imu.accelerometer.misalignment_yz_rad': (0.004189034660694457, 0.000221628),
        'imu.accelerometer.misalignment_zy_rad': (-0.005625175334670904, 0.000272848),
        'imu.accelerometer.misalignment_zx_rad': (0.014318177749339887, 0.00494669),
        'imu.accelerometer.scale_x': (1.012199138873121, 0.000147093),
        'imu.accelerometer.scale_y': (0.9910838214686758, 0.000147142),
        'imu.accelerometer.scale_z': (1.0035196006287663, 0.000196299),
        'imu.accelerometer.bias_x_raw': (0.11826940967605502, 0.000943968),
        'imu.accelerometer.bias_y_raw': (-0.211004224971121, 0.0010975),
        'imu.accelerometer.bias_z_raw': (0.3466844567922858, 0.00157063),
        'imu.gyro.misalignment_yz_rad': (0.00706469299166356, 0.000853691),
        'imu.gyro.misalignment_zy_rad': (-0.0038748245431386164, 0.000371533),
        'imu.gyro.misalignment_zx_rad': (0.012751456923748478, 0.00191074),
        'imu.gyro.misalignment_xz_rad': (-0.006612239185353825, 0.00084952),
        'imu.gyro.misalignment_xy_rad': (0.004335831078347304, 0.000745363),
        'imu.gyro.misalignment_yx_rad': (0.010778435136511744, 0.00353212),
        'imu.gyro.scale_x': (0.9825879728466335, 0.00228446),
        'imu.gyro.scale_y': (1.018079050279023, 0.000331569),
        'imu.gyro.scale_z': (1.0080171258587702, 0.000742578),
        'imu.gyro.bias_x_raw': (0.010942700066468957, 8.40019e-05),
        'imu.gyro.bias_y_raw': (-0.006953775365897103, 8.31288e-05),
        'imu.gyro.bias_z_raw': (0.003834805158544019, 8.5735e-05),
    },
}


@pytest.fixture(scope='module', params=NAMES)
def calibrated(request: pytest.FixtureRequest) -> tuple[str, MultipositionSession, dict]:
    name = request.param
    s = calibrate_bags([BAGS / name], methods=['multiposition']).sessions['multiposition']
    assert isinstance(s, MultipositionSession)
    expected = yaml.safe_load((BAGS / f'{name}.expected.yaml').read_text(encoding='utf-8'))
    return name, s, expected


def test_every_parameter_is_within_its_stated_uncertainty_of_the_truth(
        calibrated: tuple[str, MultipositionSession, dict]) -> None:
    _, session, expected = calibrated
    k = expected['tolerance']['k_standard_uncertainties']
    results = session.results()
    assert len(results) == 21
    for key, est in results.items():
        truth = expected['truth'][key]
        assert abs(est.value - truth) <= k * est.std_uncertainty, (key, est, truth)
    assert session.gravity == pytest.approx(expected['truth']['gravity_m_s2'], abs=1e-12)
    assert session.gravity_source == 'normal gravity at 45°, 0 m'  # the bag's bench latitude


def test_the_numbers_are_pinned(calibrated: tuple[str, MultipositionSession, dict]) -> None:
    name, session, _ = calibrated
    results = session.results()
    assert set(results) == set(PINNED[name])
    for key, (value, u) in PINNED[name].items():
        assert results[key].value == pytest.approx(value, abs=1e-6 * u), key
        assert results[key].std_uncertainty == pytest.approx(u, rel=1e-5), key


def test_all_poses_are_found_and_the_set_is_well_conditioned(
        calibrated: tuple[str, MultipositionSession, dict]) -> None:
    name, session, expected = calibrated
    r = session.result
    assert r is not None
    assert len(r.detection.intervals) == expected['static_poses'] and not r.detection.rejected
    assert r.well_conditioned == expected['well_conditioned']
    assert bag_info(BAGS / name).scenario['bench'] == {'latitude_deg': 45.0}
