"""`colcon build` of this package, and starting an installed node the way `ros2 run` does.

The build goes into a temporary directory (build, install and log bases, cwd), so the
repository gets no build/ install/ log/. Every child gets a full copy of os.environ:
the ROS wheels re-exec Python once to set LD_LIBRARY_PATH, and a child that inherits
_ROS_WHEELS_BOOTSTRAP_COMPLETE without that LD_LIBRARY_PATH cannot import rclpy.
"""

from __future__ import annotations

import ast
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

PACKAGE = 'gyro_calib'
REPO = Path(__file__).resolve().parent.parent
COLCON = Path(sys.executable).parent / 'colcon'
READY_LINE = 'calibrating K̃'


def console_scripts() -> list[str]:
    """Names of the console_scripts in setup.py's entry_points (parsed, not imported)."""
    for node in ast.walk(ast.parse((REPO / 'setup.py').read_text(encoding='utf-8'))):
        if isinstance(node, ast.keyword) and node.arg == 'entry_points':
            scripts = ast.literal_eval(node.value)['console_scripts']
            return sorted(spec.split('=')[0].strip() for spec in scripts)
    raise AssertionError('setup.py has no entry_points keyword')


@pytest.fixture(scope='module')
def built(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, str]:
    """Run colcon build once; return (tmp dir, package install prefix, colcon output)."""
    tmp = tmp_path_factory.mktemp('colcon')
    cmd = [str(COLCON), '--log-base', str(tmp / 'log'), 'build',
           '--base-paths', str(REPO),  # the repo root is the package: no deeper crawl
           '--build-base', str(tmp / 'build'), '--install-base', str(tmp / 'install')]
    result = subprocess.run(cmd, cwd=tmp, env=dict(os.environ), capture_output=True,
                            text=True, timeout=150)
    output = result.stdout + result.stderr
    if result.returncode != 0:
        pytest.fail(f'colcon build exited {result.returncode}:\n{output}')
    return tmp, tmp / 'install' / PACKAGE, output


def ros2_run_env(prefix: Path) -> dict[str, str]:
    """os.environ plus what sourcing the install's setup.sh would add for this package."""
    python = f'python{sys.version_info.major}.{sys.version_info.minor}'
    site = prefix / 'lib' / python / 'site-packages'
    assert site.is_dir(), f'no site-packages in {prefix}/lib'
    env = dict(os.environ)
    env['PYTHONPATH'] = os.pathsep.join(p for p in (str(site), env.get('PYTHONPATH')) if p)
    env['AMENT_PREFIX_PATH'] = os.pathsep.join(
        p for p in (str(prefix), env.get('AMENT_PREFIX_PATH')) if p)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # conftest.py set ROS_DOMAIN_ID
    return env


def test_colcon_build_installs_ament_marker_and_executables(built) -> None:
    _, prefix, output = built
    assert 'Failed to parse ROS package manifest' not in output, output
    assert (prefix / 'share/ament_index/resource_index/packages' / PACKAGE).is_file()
    assert (prefix / 'share' / PACKAGE / 'package.xml').is_file()
    # Only written when colcon-ros identified the package as ros.ament_python.
    assert (prefix / 'share' / PACKAGE / 'hook/ament_prefix_path.dsv').is_file(), output
    scripts = console_scripts()
    assert {'calibration_node', 'rate_table_sim', 'rlg_sim', 'bench_demo'} <= set(scripts)
    installed = sorted(str(p.relative_to(prefix)) for p in prefix.glob('*/*'))
    for name in scripts:
        exe = prefix / 'lib' / PACKAGE / name
        assert exe.is_file(), f'{exe} missing; install has {installed}'
        assert os.access(exe, os.X_OK), f'{exe} is not executable'


def test_installed_package_is_imported_from_install_tree_and_found_by_ament_index(built) -> None:
    tmp, prefix, _ = built
    env = ros2_run_env(prefix)
    found = subprocess.run([sys.executable, '-c', f'import {PACKAGE}; print({PACKAGE}.__file__)'],
                           cwd=tmp, env=env, capture_output=True, text=True, timeout=60)
    assert found.returncode == 0, found.stderr
    assert Path(found.stdout.strip()).is_relative_to(prefix), found.stdout
    env['AMENT_PREFIX_PATH'] = str(prefix)
    code = ('from ament_index_python.packages import get_package_prefix; '
            f'print(get_package_prefix({PACKAGE!r}))')
    prefix_seen = subprocess.run([sys.executable, '-c', code], cwd=tmp, env=env,
                                 capture_output=True, text=True, timeout=60)
    assert prefix_seen.returncode == 0, prefix_seen.stderr
    assert prefix_seen.stdout.strip() == str(prefix)


def test_installed_calibration_node_starts_like_ros2_run_and_stops_on_sigint(built) -> None:
    tmp, prefix, _ = built
    exe = prefix / 'lib' / PACKAGE / 'calibration_node'
    proc = subprocess.Popen([str(exe)], cwd=tmp, env=ros2_run_env(prefix),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, encoding='utf-8', errors='replace')
    lines: queue.Queue[str | None] = queue.Queue()

    def pump() -> None:
        for text in proc.stdout:
            lines.put(text)
        lines.put(None)

    reader = threading.Thread(target=pump, daemon=True)
    reader.start()
    seen: list[str] = []
    ready = False
    try:
        deadline = time.monotonic() + 30
        while not ready and time.monotonic() < deadline:
            try:
                line = lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                break
            if line is None:
                break
            seen.append(line)
            ready = READY_LINE in line
        assert ready, f'no {READY_LINE!r} line within 30 s (exit {proc.poll()}):\n' + ''.join(seen)
        proc.send_signal(signal.SIGINT)
        try:
            returncode = proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            pytest.fail('calibration_node still running 10 s after SIGINT:\n' + ''.join(seen))
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    reader.join(timeout=5)
    proc.stdout.close()
    while not lines.empty():
        seen.append(lines.get_nowait() or '')
    output = ''.join(seen)
    assert 'Traceback' not in output, output
    assert returncode == 0, f'exit {returncode} after SIGINT (main() exits 0 on it):\n{output}'
