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

from .dds_harness import bench_node, launch, spin_watched, wait_discovered

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
    from sensor_msgs.msg import Imu, JointState

    from gyro_calib.nodes.ros_io import SENSOR_QOS, ns_to_stamp, publish_paced

    cal = _calibration()
    path = tmp_path / 'imu.yaml'
    path.write_text(yaml.safe_dump({'format_version': 4, 'gyro_id': 'IMU-7',
                                    'imu': cal.to_section()}), encoding='utf-8')
    node = launch('imu_corrector', {'calibration_file': str(path), 'imu_frame_id': 'imu_body'})
    try:
        with bench_node('test_triad_bench') as (bench, executor):
            pub = bench.create_publisher(JointState, '/imu/pulses', SENSOR_QOS)
            got: list[Any] = []
            sub = bench.create_subscription(Imu, '/imu/data', got.append, SENSOR_QOS)
            wait_discovered(executor, lambda: (
                    pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0
                    and 'publishing /imu/data' in node.log()))
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
    finally:
        node.stop()


def test_triad_channel_thermal_bias_comes_from_its_own_temperature_topic(
        tmp_path: Path) -> None:
    """Channel z's model reads /imu/z/temperature; the node gives the core's numbers exactly."""
    from sensor_msgs.msg import Imu, JointState, Temperature
    from test_imu_triad_rate import _run, _thermal_model, _thermal_stream

    from gyro_calib.imu_conversion import (
        ImuAngularVelocity,
        TriadRateConverter,
        channel_thermal_models,
    )
    from gyro_calib.nodes.ros_io import SENSOR_QOS, ns_to_stamp, publish_paced

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
    try:
        with bench_node('test_triad_thermal_bench') as (bench, executor):
            pulses = bench.create_publisher(JointState, '/imu/pulses', SENSOR_QOS)
            temps = bench.create_publisher(Temperature, '/imu/z/temperature', SENSOR_QOS)
            got: list[Any] = []
            sub = bench.create_subscription(Imu, '/imu/data', got.append, SENSOR_QOS)
            wait_discovered(executor, lambda: (
                    pulses.get_subscription_count() > 0 and temps.get_subscription_count() > 0
                    and sub.get_publisher_count() > 0
                    and 'thermal bias of channel(s) z from /imu/z/temperature' in node.log()))
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
    finally:
        node.stop()


def test_triad_mode_with_an_accelerometer_input_carries_it_and_the_exported_variance(
        tmp_path: Path) -> None:
    """Issue 36 §3–4 over DDS: the driver's accelerometers and the exported variance.

    /imu/data's accelerometer is the driver's, sample by sample, and its gyro covariance is
    the per-sample variance the exports state.
    """
    import re

    from sensor_msgs.msg import Imu, JointState
    from test_export_consumers import _triad_with_noise_under_gyro

    from gyro_calib.export import ExportOptions, export_text
    from gyro_calib.nodes.ros_io import SENSOR_QOS, ns_to_stamp, publish_paced

    handoff = _triad_with_noise_under_gyro(tmp_path / 'triad.yaml')
    text = export_text(handoff, 'robot-localization',
                       ExportOptions(rate_hz=200.0, accel_topic='/imu/driver'))
    stated = float(re.search(r'angular_velocity_covariance of each message: diag (\S+)',
                             text).group(1))  # type: ignore[union-attr]
    node = launch('imu_corrector', {'calibration_file': str(handoff),
                                    'accel_input': '/imu/driver', 'equal_variances': True})
    try:
        with bench_node('test_triad_accel_bench') as (bench, executor):
            pulses = bench.create_publisher(JointState, '/imu/pulses', SENSOR_QOS)
            driver = bench.create_publisher(Imu, '/imu/driver', SENSOR_QOS)
            got: list[Any] = []
            sub = bench.create_subscription(Imu, '/imu/data', got.append, SENSOR_QOS)
            wait_discovered(executor, lambda: (
                    pulses.get_subscription_count() > 0 and driver.get_subscription_count() > 0
                    and sub.get_publisher_count() > 0 and 'publishing /imu/data' in node.log()))
            assert driver.get_subscription_count() > 0, node.log()
            n, dt_ns = 40, 5_000_000
            accel = [(0.01 * i, -0.02 * i, 9.81 + 1e-3 * i) for i in range(n)]
            acc_cov = [4e-6, 0.0, 0.0, 0.0, 5e-6, 0.0, 0.0, 0.0, 6e-6]
            for i in range(n):
                js = JointState(name=['x', 'y', 'z'], position=[1000.0, 2000.0, 3000.0])  # at rest
                ns_to_stamp(T0_NS + i * dt_ns, js.header.stamp)
                imu = Imu()
                ns_to_stamp(T0_NS + i * dt_ns, imu.header.stamp)
                a = imu.linear_acceleration
                a.x, a.y, a.z = accel[i]
                imu.linear_acceleration_covariance = acc_cov
                publish_paced(pulses, js)
                publish_paced(driver, imu)
                spin_watched(executor, timeout_sec=0.002)
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline and len(got) < n - 1:
                spin_watched(executor, timeout_sec=0.05)
            assert len(got) == n - 1, node.log()
            for msg in got:
                i = (msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec - T0_NS) // dt_ns
                a = msg.linear_acceleration
                assert (a.x, a.y, a.z) == accel[i]
                assert list(msg.linear_acceleration_covariance) == acc_cov
                cov = np.array(msg.angular_velocity_covariance).reshape(3, 3)
                assert cov[0, 0] == cov[1, 1] == cov[2, 2] == pytest.approx(stated, rel=1e-6)
    finally:
        node.stop()


def test_imu_mode_corrects_a_mems_drivers_imu_and_passes_its_accelerometers(
        tmp_path: Path) -> None:
    """Issue 36 §5 over DDS: imu_input's Imu in, /imu/data out.

    With the message's own accelerometers and the per-sample covariance of the IMU's noise
    run.
    """
    from sensor_msgs.msg import Imu
    from test_imu_corrector_modes import _imu_noise_handoff

    from gyro_calib.nodes.ros_io import SENSOR_QOS, ns_to_stamp, publish_paced

    handoff = _imu_noise_handoff(tmp_path / 'mems.yaml')
    node = launch('imu_corrector', {'calibration_file': str(handoff), 'imu_input': '/mems/imu'})
    try:
        with bench_node('test_imu_mode_bench') as (bench, executor):
            driver = bench.create_publisher(Imu, '/mems/imu', SENSOR_QOS)
            got: list[Any] = []
            sub = bench.create_subscription(Imu, '/imu/data', got.append, SENSOR_QOS)
            wait_discovered(executor, lambda: (
                    driver.get_subscription_count() > 0 and sub.get_publisher_count() > 0
                    and 'publishing /imu/data' in node.log()))
            assert driver.get_subscription_count() > 0, node.log()
            n, dt_ns = 30, 5_000_000
            for i in range(n):
                imu = Imu()
                ns_to_stamp(T0_NS + i * dt_ns, imu.header.stamp)
                w, a = imu.angular_velocity, imu.linear_acceleration
                w.x, w.y, w.z = 0.01 * i, -0.02, 0.3
                a.x, a.y, a.z = 0.0, 0.1 * i, 9.81
                publish_paced(driver, imu)
                spin_watched(executor, timeout_sec=0.002)
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline and len(got) < n - 1:
                spin_watched(executor, timeout_sec=0.05)
            assert len(got) == n - 1, node.log()
            f = 1e9 / dt_ns
            for msg in got:
                i = (msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec - T0_NS) // dt_ns
                assert (msg.angular_velocity.x, msg.angular_velocity.z) == (0.01 * i, 0.3)
                assert (msg.linear_acceleration.y, msg.linear_acceleration.z) == (0.1 * i, 9.81)
                assert msg.angular_velocity_covariance[4] == pytest.approx(1.2e-4 ** 2 * f,
                                                                           rel=1e-9)
                assert msg.linear_acceleration_covariance[0] == pytest.approx(1e-3 ** 2 * f,
                                                                              rel=1e-9)
    finally:
        node.stop()
