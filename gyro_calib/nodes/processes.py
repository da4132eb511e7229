"""Start gyro_calib nodes as child processes on a loopback-only, private DDS domain.

Used by the bench demo and the DDS tests. Children get a full copy of the
environment (the ROS wheels re-execute Python once to set LD_LIBRARY_PATH and
need the rest of it), with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST forced.
"""

from __future__ import annotations

import os
import subprocess
import sys
from typing import Any

import yaml

NODE_MODULES = {
    'calibration_node': 'gyro_calib.nodes.calibration_node',
    'imu_corrector': 'gyro_calib.nodes.imu_corrector_node',
    'rate_table_sim': 'sim_nodes.rate_table_node',
    'rlg_sim': 'sim_nodes.rbrlg.rlg_node',
    'bag_recorder': 'gyro_calib.nodes.bag_recorder',
    'bag_player': 'gyro_calib.nodes.bag_player',
    'fog_calibration_node': 'gyro_calib.nodes.fog_calibration_node',
    'fog_sim': 'sim_nodes.fog.fog_node',
    'dither_calibration_node': 'gyro_calib.nodes.dither_calibration_node',
    'vibration_table_sim': 'sim_nodes.dither.vibration_table_node',
    'thermal_calibration_node': 'gyro_calib.nodes.thermal_calibration_node',
    'thermal_chamber_sim': 'sim_nodes.thermal.chamber_node',
    'noise_node': 'gyro_calib.nodes.noise_node',
    'triad_sim': 'sim_nodes.triad.triad_node',
    'triad_calibration_node': 'gyro_calib.nodes.triad_calibration_node',
    'multiposition_calibration_node': 'gyro_calib.nodes.multiposition_calibration_node',
    'imu_multiposition_sim': 'sim_nodes.multiposition.imu_node',
}


def pick_domain_id() -> int:
    """A DDS domain for this run: ROS_DOMAIN_ID if set, else one derived from the PID (1–100)."""
    if os.environ.get('ROS_DOMAIN_ID'):
        return int(os.environ['ROS_DOMAIN_ID'])
    return 1 + os.getpid() % 100


def ros_environment(domain_id: int) -> dict[str, str]:
    """A copy of this process's environment with DDS kept on loopback in ``domain_id``."""
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env.setdefault('PYTHONUNBUFFERED', '1')
    return env


def _yaml_string(value: str) -> str:
    """``value`` quoted so that rcl reads it back as the same string.

    ``value`` as rcl reads it back as the same string: rcl parses ``-p`` values as YAML,
    so '' (rejected outright), 'true', '1.5' or 'a: b' must be quoted.
    """
    try:  # rcl's YAML 1.1 also reads y/n/yes/no/on/off as booleans; PyYAML reads y/n as text
        plain = yaml.safe_load(value) == value and value.lower() not in ('y', 'n')
    except yaml.YAMLError:
        plain = False
    return value if plain else "'" + value.replace("'", "''") + "'"


def ros_args(params: dict[str, Any]) -> list[str]:
    """``--ros-args -p name:=value ...`` for a parameter mapping.

    ``--ros-args -p name:=value ...`` for a parameter mapping (floats keep their dot,
    strings stay strings).
    """
    args = ['--ros-args']
    for name, value in params.items():
        if isinstance(value, bool):
            text = 'true' if value else 'false'
        elif isinstance(value, float):
            text = repr(value)  # YAML 1.1 wants a dot in the mantissa: 1e-05 -> 1.0e-05
            mantissa, _, exponent = text.partition('e')
            if exponent and '.' not in mantissa:
                text = f'{mantissa}.0e{exponent}'
        elif isinstance(value, str):
            text = _yaml_string(value)
        elif isinstance(value, tuple):  # a dataclass field's tuple is a ROS list
            text = str(list(value))
        else:
            text = str(value)
        args += ['-p', f'{name}:={text}']
    return args


def start_node(name: str, params: dict[str, Any], env: dict[str, str], *,
               namespace: str = '', **popen: Any) -> subprocess.Popen[bytes]:
    """Start node ``name`` in a child process.

    Start node ``name`` (a key of NODE_MODULES) with ``params`` in a child process, in
    ``namespace`` ('' = the root; ``-r __ns:=...``).
    """
    remap = ['-r', f'__ns:={namespace}'] if namespace else []
    cmd = [sys.executable, '-m', NODE_MODULES[name], *ros_args(params), *remap]
    return subprocess.Popen(cmd, env=env, **popen)
