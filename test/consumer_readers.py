"""The navigation stacks' own readers of the files ``gyro-calib export`` writes (issue 36).

Each function reads a file the way the consumer's code does, and only the keys it reads:

- OpenCV ``cv::FileStorage`` (``opencv-python-headless``) for OpenVINS and VINS-Fusion, with
  the types their C++ asks for (lines cited at each function);
- ``rclpy`` parameter parsing of ``--params-file`` under the consumer's node name, with the
  names, types and defaults its code declares (:func:`ros_parameters`).

Line numbers refer to rpng/open_vins 69488123 (2025-11-30) and HKUST-Aerial-Robotics/VINS-Fusion
be55a937 (2021-07-26).
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from ros_in_process import init_undiscovered

OPENVINS_MODELS = ('kalibr', 'calibrated', 'rpng')
"""ov_msckf/src/state/StateOptions.h:143-151: any other ``model`` is "invalid imu model",
``std::exit(EXIT_FAILURE)``."""


def _storage(text: str) -> Any:
    import cv2

    with tempfile.NamedTemporaryFile('w', suffix='.yaml', delete=False,
                                     encoding='utf-8') as f:
        f.write(text)
    fs = cv2.FileStorage(f.name, cv2.FILE_STORAGE_READ)
    Path(f.name).unlink()
    assert fs.isOpened(), 'cv::FileStorage did not open the file'
    return fs


def opencv_value(node: Any) -> Any:
    """A FileNode as Python (map → dict, sequence → list, str, int, float), as OpenCV has it."""
    if node.isMap():
        return {k: opencv_value(node.getNode(k)) for k in node.keys()}
    if node.isSeq():
        return [opencv_value(node.at(i)) for i in range(node.size())]
    if node.isString():
        return node.string()
    if node.isInt():
        return int(node.real())
    if node.isReal():
        return float(node.real())
    raise AssertionError(f'OpenCV node of type {node.type()}')


def opencv_tree(text: str) -> dict[str, Any]:
    """The whole file as cv::FileStorage reads it (every string and number)."""
    fs = _storage(text)
    out = opencv_value(fs.root())
    assert isinstance(out, dict)
    return out


def _matrix3(node: Any) -> npt.NDArray[np.float64]:
    """opencv_yaml_parse.h:462-466: identity, then ``(double)node[r][c]`` for r, c < 3."""
    m = np.eye(3)
    for r in range(min(node.size(), 3)):
        for c in range(min(node.at(r).size(), 3)):
            m[r, c] = node.at(r).at(c).real()
    return m


def openvins_imu0(text: str) -> dict[str, Any]:
    """The ``imu0`` keys OpenVINS reads, with the C++ types it reads them into.

    VioManagerOptions.h:159-162 (the four densities, double), :307-315 (Tw, Ta, R_IMUtoACC,
    R_IMUtoGYRO, Tg: Eigen::Matrix3d through opencv_yaml_parse.h:448-466); StateOptions.h:142
    (``model``, std::string); ROS2Visualizer.cpp:172 (``rostopic``, std::string). A key is
    read only when present (opencv_yaml_parse.h:360 node_found); absent: the C++ default.
    """
    fs = _storage(text)
    imu0 = fs.getNode('imu0')
    assert imu0.isMap(), 'no imu0 map'
    keys = set(imu0.keys())
    out: dict[str, Any] = {}
    for key in ('gyroscope_noise_density', 'gyroscope_random_walk',
                'accelerometer_noise_density', 'accelerometer_random_walk'):
        if key in keys:
            assert imu0.getNode(key).isReal() or imu0.getNode(key).isInt(), key
            out[key] = imu0.getNode(key).real()
    for key in ('model', 'rostopic'):
        if key in keys:
            assert imu0.getNode(key).isString(), key
            out[key] = imu0.getNode(key).string()
    for key in ('Tw', 'Ta', 'R_IMUtoACC', 'R_IMUtoGYRO', 'Tg'):
        if key in keys:
            out[key] = _matrix3(imu0.getNode(key))
    return out


def vins_fusion_config(text: str) -> dict[str, Any]:
    """What VINS-Fusion's readParameters takes (vins_estimator/src/estimator/parameters.cpp).

    :92 ``USE_IMU = fsSettings["imu"]`` (int); :96 ``imu_topic`` (std::string); :98-101
    ``acc_n``, ``acc_w``, ``gyr_n``, ``gyr_w`` (double); :102 ``G.z() = fsSettings["g_norm"]``
    — an absent key reads 0 (cv::FileNode's conversion of an empty node). Returned also:
    ``present``, the keys of the file.
    """
    fs = _storage(text)
    out: dict[str, Any] = {'present': set(fs.root().keys())}
    out['imu'] = int(fs.getNode('imu').real())
    node = fs.getNode('imu_topic')
    out['imu_topic'] = node.string() if node.isString() else ''
    for key in ('acc_n', 'acc_w', 'gyr_n', 'gyr_w', 'g_norm'):
        out[key] = fs.getNode(key).real()
    return out


def ros_parameters(text: str, node_name: str, declared: dict[str, Any]) -> dict[str, Any]:
    """The parameters a ROS 2 node gets from ``--ros-args --params-file FILE``.

    rcl's YAML parser reads the file (as ``ros2 run … --params-file`` hands it over) for a
    node named ``node_name``; each of ``declared`` is declared with its default, as the
    consumer's C++ ``declare_parameter<T>(name, default)`` does, so a value of another type
    than the default's raises ``InvalidParameterTypeException`` as it does in the consumer.
    """
    import rclpy
    from rclpy.context import Context

    with tempfile.NamedTemporaryFile('w', suffix='.yaml', delete=False,
                                     encoding='utf-8') as f:
        f.write(text)
    context = Context()
    init_undiscovered(args=['--ros-args', '--params-file', f.name], context=context)
    try:
        node = rclpy.create_node(node_name, context=context)
        try:
            return {name: node.declare_parameter(name, default).value
                    for name, default in declared.items()}
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
        Path(f.name).unlink()


def gyro_white_noise_as_read(fmt: str, text: str) -> dict[str, Any]:
    """The gyro white-noise number each consumer's reader takes from our file, by its key.

    Kalibr/OpenVINS/LIO-SAM: the density N; GTSAM: the largest diagonal of
    gyroscope_covariance (N²); VINS-Fusion: gyr_n (N·√(2f)); FAST-LIO: mapping.gyr_cov and
    Autoware: angular_velocity_stddev_zz (per sample); robot_localization: the topic it reads.
    """
    import yaml
    from rclpy.parameter import Parameter

    if fmt == 'kalibr':
        return {'gyroscope_noise_density': yaml.safe_load(text)['gyroscope_noise_density']}
    if fmt == 'openvins':
        return {'gyroscope_noise_density': openvins_imu0(text)['gyroscope_noise_density']}
    if fmt == 'vins-fusion':
        return {'gyr_n': vins_fusion_config(text)['gyr_n']}
    if fmt == 'gtsam':
        import gtsam

        data = yaml.safe_load(text)
        p = gtsam.PreintegrationParams.MakeSharedU(9.81)
        p.setGyroscopeCovariance(np.asarray(data['gyroscope_covariance'], dtype=float))
        return {'gyroscope_covariance': float(np.max(np.diag(p.getGyroscopeCovariance())))}
    if fmt == 'lio-sam':
        return ros_parameters(text, 'lio_sam_imu_preintegration', {'imuGyrNoise': 1.6e-4})
    if fmt == 'fast-lio':
        return ros_parameters(text, 'laser_mapping', {'mapping.gyr_cov': 0.1})
    if fmt == 'autoware':
        return ros_parameters(text, 'imu_corrector', {'angular_velocity_stddev_zz': 0.03})
    if fmt == 'robot-localization':
        return ros_parameters(text, 'ekf_filter_node', {'imu0': Parameter.Type.STRING})
    raise AssertionError(fmt)
