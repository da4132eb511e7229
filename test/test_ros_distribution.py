"""gyro_calib runs on ROS 2 Jazzy and Kilted from one source tree (issue 34).

Kilted's ``rclpy.init`` returns a context manager and Jazzy's returns None: every front door
starts rclpy through :func:`ros_context`, which needs neither. A distribution without the
APIs the nodes use is refused in one line, when building (setup.py) and when starting.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

from gyro_calib.nodes import ros_distribution
from gyro_calib.nodes.ros_distribution import UnsupportedRos, check_rclpy, ros_context

REPO = Path(__file__).resolve().parents[1]


def test_rclpy_starts_and_stops_twice_in_one_process() -> None:
    import rclpy

    for _ in range(2):
        with ros_context(['--ros-args', '--log-level', 'warn'], own_signals=True):
            assert rclpy.ok()
            node = rclpy.create_node('distribution_probe')
            node.destroy_node()
        assert not rclpy.ok()


def test_an_exception_in_the_block_still_shuts_rclpy_down() -> None:
    import rclpy

    with pytest.raises(RuntimeError, match='inside'), ros_context():
        raise RuntimeError('inside')
    assert not rclpy.ok()


@pytest.mark.parametrize('version', [(3, 1, 0), (7, 0, 9)])
def test_an_older_rclpy_is_refused_in_one_line(version: tuple[int, ...],
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(ros_distribution, 'rclpy_version', lambda: version)
    with pytest.raises(UnsupportedRos) as caught:
        check_rclpy()
    message = str(caught.value)
    assert '\n' not in message and 'Jazzy or Kilted' in message
    assert '.'.join(map(str, version)) in message and 'Humble is not supported' in message


def test_the_running_rclpy_passes_the_check() -> None:
    check_rclpy()


def test_no_front_door_uses_the_return_value_of_rclpy_init() -> None:
    """``with rclpy.init(...)`` works on Kilted only; the code uses ros_context instead."""
    offenders = []
    for path in [*REPO.glob('gyro_calib/**/*.py'), *REPO.glob('sim_nodes/**/*.py')]:
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.withitem) and isinstance(node.context_expr, ast.Call):
                func = node.context_expr.func
                if isinstance(func, ast.Attribute) and func.attr == 'init' and isinstance(
                        func.value, ast.Name) and func.value.id == 'rclpy':
                    offenders.append(f'{path.relative_to(REPO)}:{node.context_expr.lineno}')
    assert not offenders, offenders


@pytest.mark.parametrize('distro', ['humble', 'rolling'])
def test_a_build_for_another_distribution_fails_with_one_line(distro: str) -> None:
    env = {**os.environ, 'ROS_DISTRO': distro}
    result = subprocess.run([sys.executable, 'setup.py', '--version'], cwd=REPO, env=env,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode != 0 and result.stdout == ''
    assert result.stderr.strip() == (f'gyro_calib: ROS 2 {distro} is not supported; it runs on '
                                     'jazzy and kilted (rclpy >= 7.1). Source one of those.')


@pytest.mark.parametrize('distro', ['Jazzy', 'kilted'])
def test_a_build_for_a_supported_distribution_goes_on(distro: str) -> None:
    env = {**os.environ, 'ROS_DISTRO': distro}
    result = subprocess.run([sys.executable, 'setup.py', '--version'], cwd=REPO, env=env,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().splitlines()[-1] == '0.2.0'


@pytest.mark.parametrize('command', [['test', '--ros', 'humble'], ['demo', '--ros', ''],
                                     ['demo', '--ros']])
def test_run_sh_refuses_an_unsupported_distribution_in_one_line(command: list[str]) -> None:
    env = {k: v for k, v in os.environ.items() if k != 'GYRO_CALIB_ROS'}
    result = subprocess.run(['bash', str(REPO / 'run.sh'), *command], cwd=REPO, env=env,
                            capture_output=True, text=True, timeout=60)
    assert (result.returncode, result.stdout) == (2, '')
    (line,) = result.stderr.splitlines()
    assert line.startswith('run.sh: --ros must be kilted or jazzy')
