"""The core imports no ROS package.

The core (estimators, physics, bags, hand-off, CLI) imports no ROS package: it runs on bag
files offline. Every module of gyro_calib and sim_nodes is core except the ROS shells:
``gyro_calib.nodes.*`` and the simulator nodes ``sim_nodes.**.*_node``.

It also checks the one-room-per-method rule: no method subpackage imports another method.
"""

from __future__ import annotations

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import gyro_calib
import sim_nodes

METHODS = ('rbrlg', 'fog', 'noise', 'dither', 'thermal', 'triad')


def _modules(package: object) -> list[str]:
    names = []
    for info in pkgutil.walk_packages(package.__path__, package.__name__ + '.'):  # type: ignore
        if info.name.startswith('gyro_calib.nodes') or info.name.endswith('_node'):
            continue
        names.append(info.name)
    return sorted(names)


CORE_MODULES = _modules(gyro_calib) + _modules(sim_nodes)


def test_core_modules_are_discovered() -> None:
    assert {'gyro_calib.rbrlg.windows', 'gyro_calib.fog.calibrator', 'gyro_calib.registry',
            'gyro_calib.handoff', 'gyro_calib.cli', 'sim_nodes.rbrlg.bench'} <= set(CORE_MODULES)


def test_every_core_module_imports_without_rclpy() -> None:
    code = (
        'import importlib, sys\n'
        "for name in ('rclpy', 'std_msgs', 'sensor_msgs', 'diagnostic_msgs'):\n"
        '    sys.modules[name] = None\n'
        'failed = []\n'
        f'for module in {CORE_MODULES!r}:\n'
        '    try:\n'
        '        importlib.import_module(module)\n'
        '    except Exception as exc:\n'
        "        failed.append(f'{module}: {type(exc).__name__}: {exc}')\n"
        "print('\\n'.join(failed))\n"
    )
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == '', result.stdout


@pytest.mark.parametrize('root', ['gyro_calib', 'sim_nodes'])
@pytest.mark.parametrize('method', METHODS)
def test_no_method_imports_another_method(root: str, method: str) -> None:
    base = Path(gyro_calib.__file__ if root == 'gyro_calib' else sim_nodes.__file__).parent
    others = [m for m in METHODS if m != method]
    bad = []
    for path in (base / method).rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ''] if isinstance(node, ast.ImportFrom) else [])
            for name in names:
                parts = name.split('.')
                if len(parts) > 1 and parts[0] in ('gyro_calib', 'sim_nodes') \
                        and parts[1] in others:
                    bad.append(f'{path.name}: {name}')
    assert not bad, bad
