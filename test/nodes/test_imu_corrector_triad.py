"""imu_corrector in triad mode over DDS (issue 26 §3).

/imu/pulses in → /imu/data out: every sample after the first gives one Imu, stamped with
its stamp, frame ``imu_frame_id``, ω = M·ṅ − b and the full covariance of
:func:`gyro_calib.imu_body_rate.body_rate`; orientation and acceleration marked unavailable.
A channel with a thermal model reads /imu/<channel>/temperature and the node publishes the
core's numbers for the same messages, bit for bit.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from gyro_calib.imu_body_rate import body_rate, triad_rate_model
from gyro_calib.imu_calibration import ImuCalibration
from gyro_calib.units import RAD_PER_ARCSEC

from .dds_harness import launch, spin_watched

T0_NS = 1_795_426_200_000_000_000
K = np.array([0.84, 1.1, 2.3]) * RAD_PER_ARCSEC


def _calibration() -> ImuCalibration:
    axes = np.array([[1.0, 2e-3, -1e-3], [-3e-3, 1.0, 4e-3], [1e-3, -2e-3, 1.0]])
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    m = np.asarray(np.linalg.inv(axes / K[:, None]), dtype=np.float64)
    return ImuCalibration(('x', 'y', 'z'), np.eye(3), K, K * 1e-7, None, axes,
                          np.full(3, 1e-7), m, np.eye(9) * (1e-7 * K.min()) ** 2,
                          np.array([2e-6, -1e-6, 4e-6]), np.full(3, 1e-8),
                          {c: {'angle_random_walk_rad_per_sqrt_s': 4e-7} for c in 'xyz'})


def test_triad_mode_publishes_body_rates_with_full_covariance_on_imu_data(
        tmp_path: Path) -> None:
    import rclpy
    from sensor_msgs.msg import Imu, JointState

    from gyro_calib.nodes.ros_io import SENSOR_QOS, make_executor, ns_to_stamp, publish_paced

    cal = _calibration()
    path = tmp_path / 'imu.yaml'
    path.write_text(yaml.safe_dump({'format_version': 4, 'gyro_id': 'IMU-7',
                                    'imu': cal.to_section()}), encoding='utf-8')
    node = launch('imu_corrector', {'calibration_file': str(path), 'imu_frame_id': 'imu_body'})
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        bench = rclpy.create_node('test_triad_bench', context=context)
        pub = bench.create_publisher(JointState, '/imu/pulses', SENSOR_QOS)
        got: list[Any] = []
        sub = bench.create_subscription(Imu, '/imu/data', got.append, SENSOR_QOS)
        executor = make_executor(context)
        executor.add_node(bench)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (  # matched both ways (best effort)
                pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0
                and 'publishing /imu/data' in node.log()):
            spin_watched(executor, timeout_sec=0.05)
        assert 'publishing /imu/data' in node.log(), node.log()
        rng = np.random.default_rng(8)
        counts = np.cumsum(rng.integers(200, 900, size=(60, 3)), axis=0).astype(float)
        for i, c in enumerate(counts):
            msg = JointState(name=['y', 'z', 'x'], position=[c[1], c[2], c[0]])
            ns_to_stamp(T0_NS + i * 1_000_000, msg.header.stamp)
            publish_paced(pub, msg)
            spin_watched(executor, timeout_sec=0.002)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and len(got) < len(counts) - 1:
            spin_watched(executor, timeout_sec=0.05)
        assert len(got) == len(counts) - 1, node.log()
        model = triad_rate_model(cal)
        for i, msg in enumerate(got, start=1):
            assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == \
                T0_NS + i * 1_000_000
            assert msg.header.frame_id == 'imu_body'
            omega, cov = body_rate(counts[i - 1], counts[i], 1e-3, model)
            v = msg.angular_velocity
            np.testing.assert_allclose([v.x, v.y, v.z], omega, rtol=1e-12, atol=1e-15)
            assert list(msg.angular_velocity_covariance) == pytest.approx(
                list(cov.reshape(9)), rel=1e-12)
            assert msg.orientation_covariance[0] == -1.0
            assert msg.linear_acceleration_covariance[0] == -1.0
        bench.destroy_node()
    finally:
        rclpy.shutdown(context=context)
        node.stop()


def test_triad_channel_thermal_bias_comes_from_its_own_temperature_topic(
        tmp_path: Path) -> None:
    """Channel z's model reads /imu/z/temperature; the node gives the core's numbers exactly."""
    import rclpy
    from sensor_msgs.msg import Imu, JointState, Temperature
    from test_imu_triad_rate import _run, _thermal_model, _thermal_stream

    from gyro_calib.imu_conversion import (
        ImuAngularVelocity,
        TriadRateConverter,
        channel_thermal_models,
    )
    from gyro_calib.nodes.ros_io import SENSOR_QOS, make_executor, ns_to_stamp, publish_paced

    base = _calibration()
    k_z = float(triad_rate_model(base).scale_factor_rad_per_pulse[2])
    model = _thermal_model(k_z)
    cal = ImuCalibration(**{**{f: getattr(base, f) for f in base.__dataclass_fields__},
                            'thermal': {'z': {'thermal_model': model.to_dict()}}})
    path = tmp_path / 'imu.yaml'
    path.write_text(yaml.safe_dump({'format_version': 4, 'gyro_id': 'IMU-7',
                                    'imu': cal.to_section()}), encoding='utf-8')
    msgs = _thermal_stream(100)
    rate_model = triad_rate_model(cal)
    expected = [o for o in _run(TriadRateConverter(rate_model, channel_thermal_models(
        cal, rate_model)), msgs) if isinstance(o, ImuAngularVelocity)]
    assert len(expected) > 60
    node = launch('imu_corrector', {'calibration_file': str(path)})
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        bench = rclpy.create_node('test_triad_thermal_bench', context=context)
        pulses = bench.create_publisher(JointState, '/imu/pulses', SENSOR_QOS)
        temps = bench.create_publisher(Temperature, '/imu/z/temperature', SENSOR_QOS)
        got: list[Any] = []
        sub = bench.create_subscription(Imu, '/imu/data', got.append, SENSOR_QOS)
        executor = make_executor(context)
        executor.add_node(bench)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (
                pulses.get_subscription_count() > 0 and temps.get_subscription_count() > 0
                and sub.get_publisher_count() > 0
                and 'thermal bias of channel(s) z from /imu/z/temperature' in node.log()):
            spin_watched(executor, timeout_sec=0.05)
        assert temps.get_subscription_count() > 0, node.log()
        for m in msgs:
            if m[0] == 'p':
                msg: Any = JointState(name=['x', 'y', 'z'], position=m[2])
                ns_to_stamp(m[1], msg.header.stamp)
                publish_paced(pulses, msg)
            else:
                msg = Temperature(temperature=m[3])
                msg.header.frame_id = m[4]
                ns_to_stamp(m[2], msg.header.stamp)
                publish_paced(temps, msg)
            spin_watched(executor, timeout_sec=0.001)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and len(got) < len(expected):
            spin_watched(executor, timeout_sec=0.05)
        assert len(got) == len(expected), node.log()
        for msg, out in zip(got, expected, strict=True):
            assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == out.stamp_ns
            v = msg.angular_velocity
            assert (v.x, v.y, v.z) == out.angular_velocity_rad_s
            assert tuple(msg.angular_velocity_covariance) == out.covariance_rad2_s2
        bench.destroy_node()
    finally:
        rclpy.shutdown(context=context)
        node.stop()
