"""``gyro-calib export`` files read by each navigation stack's own reader (issue 36).

Not our reader, not PyYAML: OpenCV's ``cv::FileStorage`` as OpenVINS and VINS-Fusion read,
rclpy's parameter parsing under the consumer's node name, Autoware's JSON schema
(:mod:`consumer_readers`). Values are checked against the conversions docs/methods.md §E.5
derives from each consumer's propagation code.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from consumer_readers import (
    OPENVINS_MODELS,
    opencv_tree,
    openvins_imu0,
    ros_parameters,
    vins_fusion_config,
)
from test_export import K_A, K_G_BOUND_Z, M_TRIAD, N_A, N_G, RATE, export

from gyro_calib.export import ExportOptions, export_text
from gyro_calib.export.opencv_yaml import read_opencv_yaml

pytest_plugins = ['test_export']


# -- 1. OpenCV files: every string and number as cv::FileStorage reads it ---------------------

OPENCV_CASES = [('openvins', 'imu_handoff', {}),
                ('openvins', 'triad_handoff', {'accel_topic': '/imu/driver'}),
                ('openvins', 'triad_handoff', {'stream': 'raw', 'raw_scale_rad_per_pulse': 4e-6}),
                ('vins-fusion', 'imu_handoff', {})]


@pytest.mark.parametrize(('fmt', 'handoff', 'kw'), OPENCV_CASES)
def test_opencv_reads_every_string_and_number_we_meant(
        fmt: str, handoff: str, kw: dict[str, Any], request: pytest.FixtureRequest) -> None:
    """cv::FileStorage keeps an inline comment inside a plain string: none may be written."""
    text = export(request.getfixturevalue(handoff), fmt, **kw)
    assert opencv_tree(text) == read_opencv_yaml(text)


@pytest.mark.parametrize(('handoff', 'kw'), [(h, kw) for f, h, kw in OPENCV_CASES
                                             if f == 'openvins'])
def test_openvins_starts_with_a_model_it_knows_and_the_topic_given(
        handoff: str, kw: dict[str, Any], request: pytest.FixtureRequest) -> None:
    text = export(request.getfixturevalue(handoff), 'openvins', topic='/imu/data', **kw)
    imu0 = openvins_imu0(text)
    assert imu0['model'] == 'kalibr' and imu0['model'] in OPENVINS_MODELS
    assert imu0['rostopic'] == '/imu/data'


def test_vins_fusion_reads_use_imu_and_the_topic_given(imu_handoff: Path) -> None:
    cfg = vins_fusion_config(export(imu_handoff, 'vins-fusion', topic='/imu/data'))
    assert cfg['imu'] == 1 and cfg['imu_topic'] == '/imu/data'


# -- 2. Each consumer's own propagation at rest: N²·T and K²·T -------------------------------
#
# The propagation of each consumer at rest (zero rate, zero specific force, identity
# attitude), with the numbers its reader took from our file: the variance it carries after
# T seconds must be the one our terms predict, N²·T (rotation, gyro white noise alone) and
# K²·T (gyro bias). Largest axis: N_G['y'], the z axis's 2σ bound for K.

T_S = 2.0
STEPS = int(T_S * RATE)
DT = 1.0 / RATE
N, K = max(N_G.values()), K_G_BOUND_Z
NA, KA = max(N_A.values()), max(K_A.values())


def propagate(f: npt.NDArray[np.float64], g: npt.NDArray[np.float64],
              q: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """P ← F·P·Fᵀ + G·Q·Gᵀ, STEPS times from P = 0."""
    p = np.zeros_like(f)
    for _ in range(STEPS):
        p = f @ p @ f.T + g @ q @ g.T
    return p


def test_vins_fusion_midpoint_preintegration_carries_n2t_and_k2t(imu_handoff: Path) -> None:
    """integration_base.h midPointIntegration at rest (lines 100–134), noise of lines 30–36.

    States δp, δθ, δv, δb_a, δb_g (0, 3, 6, 9, 12); noise n_a0, n_g0, n_a1, n_g1, n_ba, n_bg.
    """
    cfg = vins_fusion_config(export(imu_handoff, 'vins-fusion'))
    i3, dt = np.eye(3), DT
    f = np.eye(15)
    f[0:3, 6:9] = i3 * dt                       # line 103
    f[0:3, 9:12] = -0.25 * 2 * i3 * dt * dt     # line 104
    f[3:6, 12:15] = -i3 * dt                    # line 107
    f[6:9, 9:12] = -0.5 * 2 * i3 * dt           # line 111
    v = np.zeros((15, 18))
    v[0:3, 0:3] = v[0:3, 6:9] = 0.25 * i3 * dt * dt  # lines 118, 120
    v[3:6, 3:6] = v[3:6, 9:12] = 0.5 * i3 * dt       # lines 122–123
    v[6:9, 0:3] = v[6:9, 6:9] = 0.5 * i3 * dt        # lines 124, 126
    v[9:12, 12:15] = v[12:15, 15:18] = i3 * dt       # lines 128–129

    def noise(acc_n: float, gyr_n: float, acc_w: float, gyr_w: float) -> Any:
        return np.diag(np.repeat([acc_n, gyr_n, acc_n, gyr_n, acc_w, gyr_w], 3) ** 2)

    white = propagate(f, v, noise(cfg['acc_n'], cfg['gyr_n'], 0.0, 0.0))
    walk = propagate(f, v, noise(0.0, 0.0, cfg['acc_w'], cfg['gyr_w']))
    assert white[3, 3] == pytest.approx(N ** 2 * T_S, rel=1e-6)
    assert white[6, 6] == pytest.approx(NA ** 2 * T_S, rel=1e-6)
    assert walk[12, 12] == pytest.approx(K ** 2 * T_S, rel=1e-6)
    assert walk[9, 9] == pytest.approx(KA ** 2 * T_S, rel=1e-6)


def test_openvins_discrete_propagation_carries_n2t_and_k2t(imu_handoff: Path) -> None:
    """OpenVINS Propagator.cpp at rest; states δθ, δb_g, noise n_g, n_bg.

    Qc = σ²/Δt (lines 462–466), G θ-block −Δt·R·Dw, bias block Δt·I (lines 956, 960);
    Qd = G·Qc·Gᵀ (line 470).
    """
    imu0 = openvins_imu0(export(imu_handoff, 'openvins'))
    dw = np.linalg.inv(imu0['Tw'])
    g = np.zeros((6, 6))
    g[0:3, 0:3] = -DT * imu0['R_IMUtoGYRO'].T @ dw
    g[3:6, 3:6] = DT * np.eye(3)
    q = np.diag(np.repeat([imu0['gyroscope_noise_density'] ** 2 / DT,
                           imu0['gyroscope_random_walk'] ** 2 / DT], 3))
    p = propagate(np.eye(6), g, q)
    assert p[0, 0] == pytest.approx(N ** 2 * T_S, rel=1e-6)
    assert p[3, 3] == pytest.approx(K ** 2 * T_S, rel=1e-6)


FAST_LIO_DECLARED = {'common.imu_topic': '/livox/imu', 'mapping.gyr_cov': 0.1,
                     'mapping.acc_cov': 0.1, 'mapping.b_gyr_cov': 0.0001,
                     'mapping.b_acc_cov': 0.0001}
"""FAST-LIO ROS2 branch laserMapping.cpp:810, 819–822 (node ``laser_mapping``, line 799)."""


def test_fast_lio_esekf_carries_n2t_and_k2t(imu_handoff: Path) -> None:
    """FAST-LIO's esekf at rest, with the parameters rclpy hands node laser_mapping.

    IMU_Processing.hpp:280–284 Q = diag(cov_gyr, cov_acc, cov_bias_gyr, cov_bias_acc);
    esekfom.hpp:381 P += (Δt·f_w)·Q·(Δt·f_w)ᵀ; use-ikfom.hpp:83–86 f_w: −I on δθ ← n_g,
    I on δb_g ← n_bg.
    """
    p = ros_parameters(export(imu_handoff, 'fast-lio'), 'laser_mapping', FAST_LIO_DECLARED)
    fw = np.zeros((6, 6))
    fw[0:3, 0:3], fw[3:6, 3:6] = -np.eye(3), np.eye(3)
    q = np.diag(np.repeat([p['mapping.gyr_cov'], p['mapping.b_gyr_cov']], 3))
    cov = propagate(np.eye(6), DT * fw, q)
    assert cov[0, 0] == pytest.approx(N ** 2 * T_S, rel=1e-6)
    assert cov[3, 3] == pytest.approx(K ** 2 * T_S, rel=1e-6)


def test_gtsam_preintegration_carries_n2t_and_k2t(imu_handoff: Path) -> None:
    """GTSAM itself: PreintegratedCombinedMeasurements over T at rest from our matrices."""
    import gtsam

    from gyro_calib.export.gtsam import gtsam_matrices

    m = gtsam_matrices(export(imu_handoff, 'gtsam'))
    params = gtsam.PreintegrationCombinedParams.MakeSharedU(0.0)
    params.setGyroscopeCovariance(m['gyroscope_covariance'])
    params.setAccelerometerCovariance(m['accelerometer_covariance'])
    params.setIntegrationCovariance(m['integration_covariance'])
    params.setBiasOmegaCovariance(m['bias_omega_covariance'])
    params.setBiasAccCovariance(m['bias_acc_covariance'])
    pim = gtsam.PreintegratedCombinedMeasurements(params, gtsam.imuBias.ConstantBias())
    for _ in range(STEPS):
        pim.integrateMeasurement(np.zeros(3), np.zeros(3), DT)
    cov = pim.preintMeasCov()  # δθ 0:3, δp 3:6, δv 6:9, δb_a 9:12, δb_g 12:15
    np.testing.assert_allclose(np.diag(cov)[12:15], np.array(
        [2e-6 ** 2, 3e-6 ** 2, K ** 2]) * T_S, rtol=1e-6)
    # the rotation's own white-noise part: the bias walk adds K²·T³/3 on top of N²·T
    k2 = np.diag(m['bias_omega_covariance'])
    np.testing.assert_allclose(np.diag(cov)[0:3] - k2 * T_S ** 3 / 3,
                               [N_G[a] ** 2 * T_S for a in 'xyz'], rtol=2e-5)


LIO_SAM_DECLARED = {'imuTopic': 'imu/data', 'imuAccNoise': 9e-4, 'imuGyrNoise': 1.6e-4,
                    'imuAccBiasN': 5e-4, 'imuGyrBiasN': 7e-5}
"""LIO-SAM ros2 branch include/lio_sam/utility.hpp:159, 223–229."""


def test_lio_sam_gtsam_parameters_carry_n2t_and_k2t(imu_handoff: Path) -> None:
    """LIO-SAM's GTSAM parameters from what rclpy hands its node.

    imuPreintegration.cpp (ros2): gyroscopeCovariance = imuGyrNoise²·I (line 250); the
    bias between-factor σ = √Δt_ij·imuGyrBiasN (lines 259, 409); node
    ``lio_sam_imu_preintegration`` (line 225).
    """
    import gtsam

    p = ros_parameters(export(imu_handoff, 'lio-sam'), 'lio_sam_imu_preintegration',
                       LIO_SAM_DECLARED)
    params = gtsam.PreintegrationParams.MakeSharedU(0.0)
    params.setGyroscopeCovariance(np.eye(3) * p['imuGyrNoise'] ** 2)
    params.setAccelerometerCovariance(np.eye(3) * p['imuAccNoise'] ** 2)
    params.setIntegrationCovariance(np.eye(3) * 1e-8)
    pim = gtsam.PreintegratedImuMeasurements(params, gtsam.imuBias.ConstantBias())
    for _ in range(STEPS):
        pim.integrateMeasurement(np.zeros(3), np.zeros(3), DT)
    assert pim.preintMeasCov()[0, 0] == pytest.approx(N ** 2 * T_S, rel=1e-6)
    assert (np.sqrt(pim.deltaTij()) * p['imuGyrBiasN']) ** 2 == pytest.approx(
        K ** 2 * T_S, rel=1e-6)


def test_kalibr_discrete_sigma_carries_n2t(imu_handoff: Path) -> None:
    """Kalibr's discrete σ, each sample's rate error integrated over Δt.

    kalibr_common/ConfigReader.py:491: σ_discrete = N/√(1/update_rate).
    """
    import yaml

    data = yaml.safe_load(export(imu_handoff, 'kalibr'))
    sigma = data['gyroscope_noise_density'] / np.sqrt(1.0 / data['update_rate'])
    assert sigma ** 2 * DT ** 2 * STEPS == pytest.approx(N ** 2 * T_S, rel=1e-6)
    assert data['gyroscope_random_walk'] ** 2 * T_S == pytest.approx(K ** 2 * T_S, rel=1e-6)


# -- 7. Autoware: what its schema requires ---------------------------------------------------

AUTOWARE_SCHEMA: dict[str, Any] = {
    'type': 'object', 'required': ['/**'],
    'properties': {'/**': {'type': 'object', 'required': ['ros__parameters'], 'properties': {
        'ros__parameters': {
            'type': 'object',
            'required': [f'angular_velocity_offset_{a}' for a in 'xyz']
            + [f'angular_velocity_stddev_{a}{a}' for a in 'xyz'] + ['acceleration_stddev'],
            'properties': {k: {'type': 'number'} for k in
                           [f'angular_velocity_offset_{a}' for a in 'xyz']
                           + [f'angular_velocity_stddev_{a}{a}' for a in 'xyz']
                           + ['acceleration_stddev']}}}}}}
"""The constraints of autoware_universe sensing/autoware_imu_corrector/schema/
imu_corrector.schema.json (required keys, their JSON types), restated."""
AUTOWARE_DECLARED = {**{f'angular_velocity_offset_{a}': 0.0 for a in 'xyz'},
                     **{f'angular_velocity_stddev_{a}{a}': 0.03 for a in 'xyz'},
                     'acceleration_stddev': 10000.0}
"""imu_corrector_core.cpp, ImuCorrector constructor: declare_parameter<double> each, node
``imu_corrector``."""


@pytest.mark.parametrize('handoff', ['gyro_only_handoff', 'imu_handoff', 'triad_handoff'])
def test_autoware_file_meets_its_schema_and_its_node_reads_it(
        handoff: str, request: pytest.FixtureRequest) -> None:
    import jsonschema
    import yaml

    text = export(request.getfixturevalue(handoff), 'autoware')
    jsonschema.validate(yaml.safe_load(text), AUTOWARE_SCHEMA)
    p = ros_parameters(text, 'imu_corrector', AUTOWARE_DECLARED)
    assert p['angular_velocity_stddev_xx'] == p['angular_velocity_stddev_zz'] > 0
    if handoff == 'imu_handoff':
        assert p['acceleration_stddev'] == pytest.approx(NA * np.sqrt(RATE), rel=1e-6)
    elif handoff == 'gyro_only_handoff':
        assert p['acceleration_stddev'] == 10000.0  # Autoware's own, said in the comment
        assert 'no accelerometer term' in text


# -- 6. robot_localization subscribes what imu_corrector publishes ---------------------------

def robot_localization_declared() -> dict[str, Any]:
    """What robot_localization's ekf node declares for imu0 (ros2 1cb95337, src/ros_filter.cpp).

    imu0 as PARAMETER_STRING (1529), imu0_differential, _relative (1540–1545),
    _remove_gravitational_acceleration (1575–1578), imu0_config: 15 booleans
    (loadUpdateConfig, 2618–2623); node ekf_filter_node (src/ekf_node.cpp:42).
    """
    from rclpy.parameter import Parameter

    return {'imu0': Parameter.Type.STRING, 'imu0_differential': False, 'imu0_relative': False,
            'imu0_remove_gravitational_acceleration': False, 'imu0_config': [False] * 15}


@pytest.mark.parametrize(('handoff', 'published'), [('gyro_only_handoff', '/gyro/imu'),
                                                    ('triad_handoff', '/imu/data')])
def test_robot_localization_subscribes_the_topic_imu_corrector_publishes(
        handoff: str, published: str, request: pytest.FixtureRequest) -> None:
    """imu_corrector publishes /gyro/imu for a single gyro, /imu/data for a triad."""
    from gyro_calib.nodes.imu_corrector_core import GYRO_IMU, IMU_DATA

    assert published in (GYRO_IMU, IMU_DATA)
    text = export_text(request.getfixturevalue(handoff), 'robot-localization',
                       ExportOptions(rate_hz=RATE))
    p = ros_parameters(text, 'ekf_filter_node', robot_localization_declared())
    assert p['imu0'] == published
    assert len(p['imu0_config']) == 15
    assert f'Input: {published}' in text


# -- 4. imu_corrector publishes the covariance the export states ------------------------------

def _triad_with_noise_under_gyro(path: Path) -> Path:
    """A triad hand-off whose noise run is stored as gyro.imu_gyro_<axis>_… (no imu.noise)."""
    import yaml

    from gyro_calib.imu_calibration import ImuCalibration

    imu = ImuCalibration(('x', 'y', 'z'), pulses_to_body_rad=M_TRIAD,
                         pulses_to_body_rad_covariance=np.eye(9) * 1e-30,
                         bias_rad_s=np.array([1e-6, -2e-6, 3e-6]),
                         bias_rad_s_std=np.full(3, 1e-9))
    gyro: dict[str, Any] = {}
    for a in 'xyz':
        gyro[f'imu_gyro_{a}_angle_random_walk_rad_per_sqrt_s'] = N_G[a]
        gyro[f'imu_gyro_{a}_rate_random_walk_rad_per_s_sqrt_s'] = 2e-6
        gyro[f'imu_accel_{a}_velocity_random_walk_m_s_per_sqrt_s'] = N_A[a]
        gyro[f'imu_accel_{a}_acceleration_random_walk_m_s2_per_sqrt_s'] = K_A[a]
    path.write_text(yaml.safe_dump({'format_version': 4, 'gyro_id': 'TRIAD-2',
                                    'imu': imu.to_section(), 'gyro': gyro}), encoding='utf-8')
    return path


def published_covariance(handoff: Path) -> npt.NDArray[np.float64]:
    """imu_corrector's /imu/data covariance for the triad at rest at RATE (no DDS)."""
    from fake_node import FakeNode

    from gyro_calib.nodes.imu_corrector_core import IMU_DATA, ImuCorrector

    node = FakeNode()
    corrector = ImuCorrector(node)  # type: ignore[arg-type]
    corrector.poll_file(str(handoff))
    dt_ns = int(round(1e9 / RATE))
    outs = []
    for i in range(3):
        outs += corrector.on_imu_pulses(1_700_000_000_000_000_000 + i * dt_ns, ['x', 'y', 'z'],
                                        [1000.0, 2000.0, 3000.0])
    assert outs and all(topic == IMU_DATA for topic, _ in outs)
    return np.array(outs[-1][1].covariance_rad2_s2).reshape(3, 3)


@pytest.mark.parametrize('where', ['imu.noise', 'gyro.imu_gyro'])
def test_imu_corrector_publishes_the_per_sample_variance_the_exports_state(
        where: str, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    """Wherever the noise run is stored, corrector and export read the same N (issue 36 §4)."""
    import re

    handoff = (request.getfixturevalue('triad_handoff') if where == 'imu.noise'
               else _triad_with_noise_under_gyro(tmp_path / 'triad.yaml'))
    published = float(np.max(np.diag(published_covariance(handoff))))
    rl = export(handoff, 'robot-localization')
    stated = float(re.search(r'angular_velocity_covariance of each message: diag (\S+)',
                             rl).group(1))  # type: ignore[union-attr]
    assert stated == pytest.approx(published, rel=1e-6)
    autoware = ros_parameters(export(handoff, 'autoware'), 'imu_corrector', AUTOWARE_DECLARED)
    assert autoware['angular_velocity_stddev_xx'] ** 2 == pytest.approx(published, rel=1e-6)
    fast_lio = ros_parameters(export(handoff, 'fast-lio', accel_topic='/imu/driver'),
                              'laser_mapping', FAST_LIO_DECLARED)
    assert fast_lio['mapping.gyr_cov'] == pytest.approx(published, rel=1e-6)
    assert published > max(N_G.values()) ** 2 * RATE  # N²·f and the count quantisation


# -- 9. OpenVINS on a triad's raw stream: exact intrinsics, densities in raw units -------------

K0 = 4.0e-6


def test_openvins_raw_intrinsics_round_trip_to_m_as_opencv_reads_them(
        triad_handoff: Path) -> None:
    """K₀·(Tw·R_IMUtoGYRO)⁻¹ = M far below u(M) (0.005 ppm): written to 17 digits."""
    imu0 = openvins_imu0(export(triad_handoff, 'openvins', stream='raw',
                                raw_scale_rad_per_pulse=K0))
    back = K0 * np.linalg.inv(imu0['Tw'] @ imu0['R_IMUtoGYRO'])
    np.testing.assert_allclose(back, M_TRIAD, rtol=0, atol=1e-13 * np.abs(M_TRIAD).max())
    assert np.allclose(np.triu(imu0['Tw'], 1), 0.0)  # OpenVINS's kalibr model: lower


def test_openvins_raw_densities_carry_each_body_axis_n2t_through_dw(triad_handoff: Path) -> None:
    """In raw units, each body axis carries at least its N²·T, the largest channel exactly.

    OpenVINS adds its gyro noise to ω_m, before Dw (Propagator.cpp:956, G θ-block
    −Δt·R_GYROtoIMU·Dw).
    """
    imu0 = openvins_imu0(export(triad_handoff, 'openvins', stream='raw',
                                raw_scale_rad_per_pulse=K0))
    dw = np.linalg.inv(imu0['Tw'])
    g = -DT * imu0['R_IMUtoGYRO'].T @ dw
    per_step = g @ (np.eye(3) * imu0['gyroscope_noise_density'] ** 2 / DT) @ g.T
    body = np.diag(per_step) * STEPS
    want = np.array([N_G[a] ** 2 for a in 'xyz']) * T_S
    assert np.all(body >= want * (1 - 1e-5))
    assert np.min(body / want) == pytest.approx(1.0, rel=1e-5)


# -- 8. complete file or fragment: the first line says which ---------------------------------

def first_statement(text: str) -> str:
    """The first line, after OpenCV's ``%YAML:1.0`` and ``---`` where the format has them."""
    lines = [ln for ln in text.splitlines() if ln not in ('%YAML:1.0', '---')]
    return lines[0]


@pytest.mark.parametrize('fmt', ['kalibr', 'openvins', 'gtsam', 'autoware',
                                 'robot-localization'])
def test_a_complete_file_says_so_and_holds_every_key_its_reader_takes(
        fmt: str, imu_handoff: Path) -> None:
    import jsonschema
    import yaml

    from gyro_calib.export.kalibr import KEYS as KALIBR_KEYS

    text = export(imu_handoff, fmt)
    assert first_statement(text).startswith('# COMPLETE ')
    if fmt == 'kalibr':
        assert set(KALIBR_KEYS) <= set(yaml.safe_load(text))
    elif fmt == 'openvins':  # every imu0 key OpenVINS reads (consumer_readers.openvins_imu0)
        assert set(openvins_imu0(text)) == {
            'gyroscope_noise_density', 'gyroscope_random_walk', 'accelerometer_noise_density',
            'accelerometer_random_walk', 'model', 'rostopic', 'Tw', 'Ta', 'R_IMUtoACC',
            'R_IMUtoGYRO', 'Tg'}
    elif fmt == 'autoware':
        jsonschema.validate(yaml.safe_load(text), AUTOWARE_SCHEMA)


def test_vins_fusion_fragment_names_g_norm_which_it_would_read_as_zero(
        imu_handoff: Path) -> None:
    text = export(imu_handoff, 'vins-fusion')
    line = first_statement(text)
    assert line.startswith('# FRAGMENT ')
    assert vins_fusion_config(text)['g_norm'] == 0.0  # what VINS-Fusion would run with
    for key in ('g_norm', 'num_of_cam', 'body_T_cam0'):
        assert key in line


def test_fast_lio_and_lio_sam_fragments_name_the_extrinsics_they_would_miss(
        imu_handoff: Path) -> None:
    from rclpy.parameter import Parameter

    text = export(imu_handoff, 'fast-lio')
    assert first_statement(text).startswith('# FRAGMENT ')
    p = ros_parameters(text, 'laser_mapping',
                       {'mapping.extrinsic_T': Parameter.Type.DOUBLE_ARRAY,
                        'mapping.extrinsic_R': Parameter.Type.DOUBLE_ARRAY})
    assert p == {'mapping.extrinsic_T': None, 'mapping.extrinsic_R': None}
    assert 'mapping.extrinsic_T' in first_statement(text)
    assert 'mapping.extrinsic_R' in first_statement(text)
    line = first_statement(export(imu_handoff, 'lio-sam'))
    assert line.startswith('# FRAGMENT ')
    for key in ('sensor', 'extrinsicTrans', 'extrinsicRot', 'extrinsicRPY'):
        assert key in line


# -- 3. accelerometer consumers are never pointed at a stream without accelerometers ----------

@pytest.mark.parametrize('fmt', ['kalibr', 'openvins', 'lio-sam', 'fast-lio', 'vins-fusion'])
def test_an_accelerometer_consumer_refuses_a_triad_stream_without_them_naming_what_to_set(
        fmt: str, triad_handoff: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The triad hand-off holds accelerometer terms; its /imu/data has none of its own.

    imu_corrector carries them only when given the driver's Imu (accel_input).
    """
    from gyro_calib.cli import main

    out = tmp_path / 'out.yaml'
    code = main(['export', str(triad_handoff), '--format', fmt, '--out', str(out),
                 '--rate-hz', '200'])
    err = capsys.readouterr()
    assert code == 2 and err.out == '' and not out.exists()
    assert len(err.err.strip().splitlines()) == 1
    assert 'accel_input:=' in err.err and '--accel-topic' in err.err
    assert main(['export', str(triad_handoff), '--format', fmt, '--out', str(out),
                 '--rate-hz', '200', '--accel-topic', '/imu/driver']) == 0
    assert 'accelerometers passed through from /imu/driver' in out.read_text()


def test_robot_localization_fuses_no_acceleration_the_stream_does_not_carry(
        triad_handoff: Path) -> None:
    """robot_localization would fuse ax ay az = 0 against −g at σ ≈ 3e-5 m/s²."""
    declared = robot_localization_declared()
    p = ros_parameters(export(triad_handoff, 'robot-localization'), 'ekf_filter_node',
                       declared)
    assert p['imu0_config'][12:] == [False, False, False]
    assert p['imu0_remove_gravitational_acceleration'] is False
    q = ros_parameters(export(triad_handoff, 'robot-localization', accel_topic='/imu/driver'),
                       'ekf_filter_node', declared)
    assert q['imu0_config'][12:] == [True, True, True]


# -- 8. --merge-into THEIR_FILE: their config, only our keys replaced --------------------------

THEIR_FAST_LIO = '''\
/**:
    ros__parameters:
        feature_extract_enable: false
        max_iteration: 3   # my tuning

        common:
            lid_topic:  "/livox/lidar"
            imu_topic:  "/livox/imu"   # old
            time_sync_en: false

        mapping:
            acc_cov: 0.1
            gyr_cov: 0.1   # default
            b_acc_cov: 0.0001
            b_gyr_cov: 0.0001
            fov_degree:    360.0
            extrinsic_T: [ -0.011, -0.02329, 0.04412 ]
            extrinsic_R: [ 1., 0., 0.,
                           0., 1., 0.,
                           0., 0., 1. ]
'''

THEIR_VINS = '''\
%YAML:1.0

#common parameters
imu: 1
num_of_cam: 2

imu_topic: "/imu0"
image0_topic: "/cam0/image_raw"
output_path: "/home/me/output/"

body_T_cam0: !!opencv-matrix
   rows: 4
   cols: 4
   dt: d
   data: [1.0, 0.0, 0.0, 0.0,
          0.0, 1.0, 0.0, 0.0,
          0.0, 0.0, 1.0, 0.0,
          0.0, 0.0, 0.0, 1.0]

#imu parameters       The more accurate parameters you provide, the better performance
acc_n: 0.1          # accelerometer measurement noise standard deviation.
gyr_n: 0.01         # gyroscope measurement noise standard deviation.
acc_w: 0.001        # accelerometer bias random work noise standard deviation.
gyr_w: 0.0001       # gyroscope bias random work noise standard deviation.
g_norm: 9.81007     # gravity magnitude
'''

THEIR_LIO_SAM = '''\
/**:
  ros__parameters:
    # Topics
    pointCloudTopic: "/points"
    imuTopic: "/imu/raw"
    sensor: velodyne
    # IMU Settings
    imuAccNoise: 3.9939570888238808e-03
    imuGravity: 9.80511
    extrinsicTrans: [0.0, 0.0, 0.0]
'''


def _changed(before: str, after: str) -> list[str]:
    """Their lines that are no longer in the merged text."""
    kept = after.split('\n')
    return [ln for ln in before.split('\n') if ln not in kept]


def test_merge_into_their_fast_lio_config_replaces_our_keys_only(
        imu_handoff: Path, tmp_path: Path) -> None:
    from gyro_calib.cli import main

    theirs = tmp_path / 'mid360.yaml'
    theirs.write_text(THEIR_FAST_LIO)
    assert main(['export', str(imu_handoff), '--format', 'fast-lio', '--rate-hz', '200',
                 '--merge-into', str(theirs), '--out', str(theirs)]) == 0
    merged = theirs.read_text()
    changed = _changed(THEIR_FAST_LIO, merged)
    assert [ln.split(':')[0].strip() for ln in changed] == [
        'imu_topic', 'acc_cov', 'gyr_cov', 'b_acc_cov', 'b_gyr_cov']
    p = ros_parameters(merged, 'laser_mapping', {
        **FAST_LIO_DECLARED, 'mapping.extrinsic_T': [0.0], 'max_iteration': 4,
        'mapping.fov_degree': 180.0})
    assert p['mapping.gyr_cov'] == pytest.approx(N ** 2 * RATE, rel=1e-6)
    assert p['mapping.b_gyr_cov'] == pytest.approx(K ** 2 * RATE, rel=1e-6)
    assert p['common.imu_topic'] == '/imu/data'
    assert p['mapping.extrinsic_T'] == [-0.011, -0.02329, 0.04412]  # theirs, kept
    assert p['max_iteration'] == 3 and '# my tuning' in merged


def test_merge_into_their_vins_fusion_config_keeps_g_norm_and_cameras(
        imu_handoff: Path, tmp_path: Path) -> None:
    from gyro_calib.cli import main

    theirs, out = tmp_path / 'euroc.yaml', tmp_path / 'merged.yaml'
    theirs.write_text(THEIR_VINS)
    assert main(['export', str(imu_handoff), '--format', 'vins-fusion', '--rate-hz', '200',
                 '--merge-into', str(theirs), '--out', str(out)]) == 0
    merged = out.read_text()
    assert theirs.read_text() == THEIR_VINS  # --out elsewhere: their file untouched
    assert [ln.split(':')[0] for ln in _changed(THEIR_VINS, merged)] == [
        'imu_topic', 'acc_n', 'gyr_n', 'acc_w', 'gyr_w']
    cfg = vins_fusion_config(merged)
    assert cfg['g_norm'] == 9.81007 and cfg['imu'] == 1 and cfg['imu_topic'] == '/imu/data'
    assert cfg['gyr_n'] == pytest.approx(N * np.sqrt(2 * RATE), rel=1e-6)
    assert {'num_of_cam', 'body_T_cam0', 'image0_topic'} <= cfg['present']


def test_merge_into_adds_a_key_they_lack_inside_their_block(
        imu_handoff: Path, tmp_path: Path) -> None:
    from gyro_calib.cli import main

    theirs = tmp_path / 'params.yaml'
    theirs.write_text(THEIR_LIO_SAM)
    assert main(['export', str(imu_handoff), '--format', 'lio-sam',
                 '--merge-into', str(theirs), '--out', str(theirs)]) == 0
    merged = theirs.read_text()
    p = ros_parameters(merged, 'lio_sam_imu_preintegration',
                       {**LIO_SAM_DECLARED, 'sensor': 'ouster', 'imuGravity': 9.8})
    assert p['imuGyrNoise'] == pytest.approx(N, rel=1e-6)  # added: they had none
    assert p['imuAccNoise'] == pytest.approx(NA, rel=1e-6)  # replaced
    assert p['sensor'] == 'velodyne' and p['imuGravity'] == 9.80511
    assert '    # IMU Settings' in merged


def test_merge_into_refuses_in_one_line_what_it_cannot_place(
        imu_handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gyro_calib.cli import main

    theirs, out = tmp_path / 'bad.yaml', tmp_path / 'out.yaml'
    theirs.write_text('/**:\n  ros__parameters:\n    common:\n      imu_topic: "/a"\n')
    assert main(['export', str(imu_handoff), '--format', 'fast-lio', '--rate-hz', '200',
                 '--merge-into', str(theirs), '--out', str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and 'mapping: block' in err
    assert not out.exists()
    assert main(['export', str(imu_handoff), '--format', 'openvins', '--rate-hz', '200',
                 '--merge-into', str(theirs), '--out', str(out)]) == 2
    assert 'lists or matrices' in capsys.readouterr().err


def test_single_gyro_corrector_publishes_the_per_sample_variance_the_exports_state(
        tmp_path: Path) -> None:
    """/gyro/imu's z variance at rest (N²·f + K²·f²/6) is the export's (issue 36 §4)."""
    import re

    from fake_node import FakeNode

    from gyro_calib.handoff import Provenance, method_calibration, write_calibration
    from gyro_calib.nodes.imu_corrector_core import GYRO_IMU, ImuCorrector
    from gyro_calib.registry import handoff_schema

    prov = Provenance('rlg.bag', 0, 10**12)
    rbrlg = method_calibration('rbrlg', {
        'k_tilde_rad_per_pulse': 4.0e-6, 'k_tilde_rad_per_pulse_std': 1e-13,
        'scale_factor_rad_per_pulse': 4.0e-6, 'scale_factor_rad_per_pulse_std': 1e-13,
        'fix_error_angle_rad': 1e-3, 'fix_error_angle_rad_std': 1e-6, 'window_pairs': 3,
        'stations': 4, 'bias_rad_s': 7e-6, 'bias_rad_s_std': 3e-9}, prov)
    noise = method_calibration('noise', {'angle_random_walk_rad_per_sqrt_s': 1e-4,
                                         'angle_random_walk_rad_per_sqrt_s_std': 1e-6}, prov)
    gyro_only_handoff = write_calibration(tmp_path / 'rlg.yaml',
                                          noise.merged_into(rbrlg, handoff_schema()))
    corrector = ImuCorrector(FakeNode())  # type: ignore[arg-type]
    corrector.poll_file(str(gyro_only_handoff))
    dt_ns, outs = int(round(1e9 / RATE)), []
    for i in range(3):
        outs += corrector.on_gyro_pulses(1_700_000_000_000_000_000 + i * dt_ns, ['gyro'],
                                         [5000.0])
    assert outs and all(topic == GYRO_IMU for topic, _ in outs)
    published = outs[-1][1].covariance_rad2_s2[8]
    text = export(gyro_only_handoff, 'robot-localization')
    stated = float(re.search(r'angular_velocity_covariance of each message: diag (\S+)',
                             text).group(1))  # type: ignore[union-attr]
    assert stated == pytest.approx(published, rel=1e-6)
    autoware = ros_parameters(export(gyro_only_handoff, 'autoware'), 'imu_corrector',
                              AUTOWARE_DECLARED)
    assert autoware['angular_velocity_stddev_zz'] ** 2 == pytest.approx(published, rel=1e-6)


def test_merge_into_twice_gives_the_same_file_and_an_empty_file_is_refused_or_filled(
        imu_handoff: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A second run changes nothing; an empty file is refused or filled.

    FAST-LIO's blocks are missing from it (one-line refusal); Kalibr's keys are top level
    (all written).
    """
    import yaml

    from gyro_calib.cli import main

    theirs = tmp_path / 'mid360.yaml'
    theirs.write_text(THEIR_FAST_LIO)
    run = ['export', str(imu_handoff), '--format', 'fast-lio', '--rate-hz', '200',
           '--merge-into', str(theirs), '--out', str(theirs)]
    assert main(run) == 0
    once = theirs.read_text()
    assert main(run) == 0
    assert theirs.read_text() == once
    empty = tmp_path / 'empty.yaml'
    empty.write_text('')
    assert main(['export', str(imu_handoff), '--format', 'fast-lio', '--rate-hz', '200',
                 '--merge-into', str(empty), '--out', str(empty)]) == 2
    assert empty.read_text() == ''
    capsys.readouterr()
    assert main(['export', str(imu_handoff), '--format', 'kalibr', '--rate-hz', '200',
                 '--merge-into', str(empty), '--out', str(empty)]) == 0
    from gyro_calib.export.kalibr import KEYS

    assert set(yaml.safe_load(empty.read_text())) == set(KEYS)
