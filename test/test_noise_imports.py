"""The noise method's core and generators import no ROS package (they run on bags offline)."""

from __future__ import annotations

import subprocess
import sys

import pytest

MODULES = [
    'gyro_calib.noise', 'gyro_calib.noise.allan', 'gyro_calib.noise.calibrator',
    'gyro_calib.noise.channel', 'gyro_calib.noise.covariance', 'gyro_calib.noise.curve',
    'gyro_calib.noise.edf', 'gyro_calib.noise.fit', 'gyro_calib.noise.kalibr',
    'gyro_calib.noise.ordering', 'gyro_calib.noise.plots', 'gyro_calib.noise.settings',
    'gyro_calib.noise.terms', 'gyro_calib.noise.tree', 'sim_nodes.noise',
    'sim_nodes.noise.processes', 'sim_nodes.noise.sensors',
]


def test_noise_modules_import_without_ros_and_without_other_methods() -> None:
    code = (
        'import sys\n'
        "for name in ('rclpy', 'std_msgs', 'sensor_msgs', 'diagnostic_msgs'):\n"
        '    sys.modules[name] = None\n'
        f'for m in {MODULES!r}:\n'
        '    __import__(m)\n'
        "other = [m for m in sys.modules if m in ('gyro_calib.calibrator', 'gyro_calib.windows',"
        " 'gyro_calib.stations', 'gyro_calib.rbrlg_calibration', 'matplotlib')]\n"
        'assert not other, other\n'
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize('module', ['gyro_calib.noise', 'sim_nodes.noise'])
def test_noise_package_exports_resolve(module: str) -> None:
    mod = __import__(module, fromlist=['__all__'])
    for name in mod.__all__:
        assert hasattr(mod, name), name
