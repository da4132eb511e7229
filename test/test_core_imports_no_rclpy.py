"""The core (estimators, physics) imports no ROS package: it runs on bag files offline."""

from __future__ import annotations

import subprocess
import sys

import pytest

CORE_MODULES = [
    'gyro_calib.bag',
    'gyro_calib.bag_calibration',
    'gyro_calib.rbrlg.calibrator',
    'gyro_calib.cli',
    'gyro_calib.rbrlg.config',
    'gyro_calib.errors',
    'gyro_calib.rbrlg.diagnostics',
    'gyro_calib.rbrlg.error_budget',
    'gyro_calib.estimate',
    'gyro_calib.rbrlg.fix_error_angle',
    'gyro_calib.handoff',
    'gyro_calib.imu_conversion',
    'gyro_calib.rbrlg.calibration',
    'gyro_calib.rbrlg.scale_factor',
    'gyro_calib.rbrlg.stations',
    'gyro_calib.streams',
    'gyro_calib.topics',
    'gyro_calib.units',
    'gyro_calib.rbrlg.windows',
    'sim_nodes.rbrlg.bench',
    'sim_nodes.motion',
    'sim_nodes.rbrlg.procedure',
    'sim_nodes.rate_table',
    'sim_nodes.rbrlg.ring_laser_gyro',
    'sim_nodes.rbrlg.scenarios',
    'sim_nodes.rbrlg.two_axis_gyro',
]


@pytest.mark.parametrize('module', CORE_MODULES)
def test_core_module_imports_without_rclpy(module: str) -> None:
    code = (
        'import sys\n'
        "for name in ('rclpy', 'std_msgs', 'sensor_msgs', 'diagnostic_msgs'):\n"
        '    sys.modules[name] = None\n'
        f'import {module}\n'
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
