"""The dither core and its simulator import no ROS package (they run on bag files offline)."""

from __future__ import annotations

import subprocess
import sys

DITHER_CORE_MODULES = [
    'gyro_calib.dither',
    'gyro_calib.dither.calibrator',
    'gyro_calib.dither.coning',
    'gyro_calib.dither.floor',
    'gyro_calib.dither.keys',
    'gyro_calib.dither.lines',
    'gyro_calib.dither.misalignment',
    'gyro_calib.dither.plots',
    'gyro_calib.dither.regression',
    'gyro_calib.dither.session',
    'gyro_calib.dither.settings',
    'gyro_calib.dither.spectral',
    'gyro_calib.dither.topics',
    'sim_nodes.dither.bag_scenarios',
    'sim_nodes.dither.bench',
    'sim_nodes.dither.gyro',
    'sim_nodes.dither.kinematics',
    'sim_nodes.dither.scenarios',
    'sim_nodes.dither.vibration_table',
]


def test_dither_core_imports_no_ros_no_matplotlib_and_no_other_method() -> None:
    code = (
        'import sys\n'
        "for name in ('rclpy', 'std_msgs', 'sensor_msgs', 'diagnostic_msgs'):\n"
        '    sys.modules[name] = None\n'
        + ''.join(f'import {m}\n' for m in DITHER_CORE_MODULES)
        + "assert 'matplotlib' not in sys.modules, 'matplotlib must be imported lazily'\n"
        "other = ('gyro_calib.rbrlg', 'gyro_calib.fog', 'gyro_calib.noise', 'gyro_calib.thermal', "
        "'gyro_calib.rbrlg.calibrator', 'gyro_calib.rbrlg.windows', 'gyro_calib.rbrlg.stations')\n"
        "bad = [m for m in sys.modules if m.startswith(other)]\n"
        "assert not bad, f'the dither method imports another method: {bad}'\n"
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
