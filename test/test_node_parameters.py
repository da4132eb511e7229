"""Node parameters as ROS users type them (issues 16 and 17 item 10).

``-p duration_s:=30`` reaches a node as an INTEGER; where the node declares a float it is
taken as 30.0 by every node executable. A value of another type (a string for a number) is
refused in one line naming the parameter, the type it takes and what to pass, exit 2.
"""

from __future__ import annotations

import importlib
import math
import os
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter
from ros_in_process import init_undiscovered

from gyro_calib.errors import ConfigError
from gyro_calib.nodes import ros_io
from gyro_calib.nodes.processes import NODE_MODULES, ros_args, ros_environment

BAGS = Path(__file__).resolve().parents[1] / 'bags'

NEEDS: dict[str, dict[str, Any]] = {
    'thermal_calibration_node': {'scale_factor_rad_per_pulse': 4.8e-6, 'latitude_deg': 34.26},
    'noise_node': {'topic': '/imu/data'},
    'bag_player': {'bag': str(BAGS / 'k_tilde_bench'), 'wait_for_subscribers': False},
}
"""What a node needs beside its defaults to come up at all."""

OWN_MAIN = {'bag_player': 'BagPlayer', 'bag_recorder': 'BagRecorder'}
"""Nodes whose main() does not go through ros_io.run_node: their node class."""


def _node_factory(name: str) -> Callable[[], Node]:
    """The executable's own node factory (what its main() hands to ros_io.run_node)."""
    module = importlib.import_module(NODE_MODULES[name])
    if name in OWN_MAIN:
        return getattr(module, OWN_MAIN[name])  # type: ignore[no-any-return]
    captured: dict[str, Callable[[], Node]] = {}
    users = [m for m in list(sys.modules.values())
             if getattr(m, 'run_node', None) is ros_io.run_node]
    for m in users:
        setattr(m, 'run_node', lambda _name, make, *_a, **_k: captured.update(make=make))
    try:
        module.main([])
    finally:
        for m in users:
            setattr(m, 'run_node', ros_io.run_node)
    return captured['make']


def _start(name: str, params: dict[str, Any]) -> Node:
    """Construct the node with ``params`` as a user types them.

    Construct the node with ``params`` given as ``-p name:=value`` (as typed by a user),
    in a fresh working directory (a node's state record binds its directory to its settings).
    """
    os.chdir(tempfile.mkdtemp(dir=os.getcwd()))
    init_undiscovered(args=ros_args({**NEEDS.get(name, {}), **params}))
    try:
        return _node_factory(name)()
    except BaseException:
        rclpy.shutdown()
        raise


def _stop(node: Node) -> None:
    node.destroy_node()
    rclpy.shutdown()


_FLOATS: dict[str, dict[str, float]] = {}


def _float_parameters(name: str, tmp_path: Path) -> dict[str, float]:
    """Every float parameter of the node with its default value (once per node)."""
    if name not in _FLOATS:
        node = _start(name, _paths(name, tmp_path, 'defaults'))
        try:
            _FLOATS[name] = {k: p.value for k, p in node._parameters.items()
                             if p.type_ == Parameter.Type.DOUBLE}
        finally:
            _stop(node)
    return _FLOATS[name]


def _paths(name: str, tmp_path: Path, tag: str) -> dict[str, Any]:
    return {'out': str(tmp_path / f'bag_{tag}')} if name == 'bag_recorder' else {}


@pytest.fixture(autouse=True)
def _in_scratch_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Run the nodes in a scratch working directory.

    Nodes write their default outputs (hand-off file, state records) in the working
    directory: here, a scratch one.
    """
    monkeypatch.chdir(tmp_path)


@pytest.mark.parametrize('name', list(NODE_MODULES))
def test_every_node_takes_an_integer_where_it_declares_a_float(
        name: str, tmp_path: Path) -> None:
    floats = _float_parameters(name, tmp_path)
    assert floats, f'{name} declares no float parameter'
    # the same values, typed as a user types them: 30 for 30.0; a NaN default gets 28
    given = {k: 28 if k == 'latitude_deg' else int(v) for k, v in floats.items()
             if k == 'latitude_deg' or math.isfinite(v) and v.is_integer()}
    assert given, f'{name}: no float parameter with a whole-number default to give as integer'
    node = _start(name, {**given, **_paths(name, tmp_path, 'ints')})
    try:
        for key, value in given.items():
            param = node.get_parameter(key)
            assert param.type_ == Parameter.Type.DOUBLE, (name, key, param.type_)
            assert param.value == float(value) and isinstance(param.value, float), (key,)
    finally:
        _stop(node)


@pytest.mark.parametrize('name', list(NODE_MODULES))
def test_every_node_refuses_a_string_for_a_float_naming_the_parameter(
        name: str, tmp_path: Path) -> None:
    key = sorted(_float_parameters(name, tmp_path))[0]
    with pytest.raises(ConfigError) as err:
        _start(name, {key: 'abc', **_paths(name, tmp_path, 'bad')})
    text = str(err.value)
    assert f'parameter {key} := \'abc\'' in text and 'takes a number' in text, text
    assert f'-p {key}:=' in text and '\n' not in text


def test_a_list_of_integers_is_taken_for_a_list_of_floats(tmp_path: Path) -> None:
    node = _start('fog_calibration_node', {'mapping_rates_deg_s': [20, 21, 22]})
    try:
        assert node.get_parameter('mapping_rates_deg_s').value == [20.0, 21.0, 22.0]
    finally:
        _stop(node)
    node = _start('fog_sim', {'turntable.rates_deg_s': [10, -10, 50], 'turntable.hold_s': 30})
    try:
        assert node.get_parameter('turntable.hold_s').value == 30.0
    finally:
        _stop(node)


@pytest.mark.parametrize('name', list(NODE_MODULES))
def test_the_executable_exits_2_with_one_line_on_a_wrong_type(
        name: str, tmp_path: Path) -> None:
    """Started as a user starts it: nothing but the one line on stderr, exit status 2."""
    key = sorted(_float_parameters(name, tmp_path))[0]
    params = {**NEEDS.get(name, {}), key: 'abc', **_paths(name, tmp_path, 'exe')}
    env = ros_environment(int(os.environ['ROS_DOMAIN_ID']))
    env['PYTHONPATH'] = str(Path(__file__).resolve().parents[1])
    done = subprocess.run([sys.executable, '-m', NODE_MODULES[name], *ros_args(params)],
                          env=env, capture_output=True, text=True, timeout=60, cwd=tmp_path)
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1 and f'parameter {key} :=' in lines[0], done.stderr
    assert 'Traceback' not in done.stderr and not done.stdout
    assert not (tmp_path / 'bag_exe').exists()


USERS_VIO_CONFIG = ('%YAML:1.0\n# my VINS-Fusion config, tuned by hand\nimu_topic: "/imu"\n'
                    'acc_n: 0.1\n')


@pytest.mark.parametrize('kind', ['a user config', 'a hand-off file'])
def test_noise_node_refuses_a_kalibr_file_it_did_not_write_at_start_up(
        kind: str, tmp_path: Path) -> None:
    """kalibr_file replaces only a Kalibr imu.yaml of ours, as ``noise --kalibr`` does.

    A user's file there stops the node before it reads anything (one line, naming the
    parameter and the way out), and the file is left as it was.
    """
    target = tmp_path / 'imu.yaml'
    text = (USERS_VIO_CONFIG if kind == 'a user config'
            else 'format_version: 4\ngyro_id: G-1\ngyro:\n  k_tilde_rad_per_pulse: 1.0e-6\n')
    target.write_text(text, encoding='utf-8')
    with pytest.raises(ConfigError, match=r'^kalibr_file: .*imu\.yaml (exists and is not a '
                                          r'Kalibr imu\.yaml gyro-calib wrote|is a gyro_calib '
                                          r'hand-off file)'):
        _stop(_start('noise_node', {'topic': '/imu/data', 'kalibr_file': str(target)}))
    assert target.read_text(encoding='utf-8') == text


def test_noise_node_takes_a_kalibr_file_of_its_own_to_replace(tmp_path: Path) -> None:
    from gyro_calib.export.names import export_mark
    from gyro_calib.noise.kalibr import KALIBR_MARK

    for n, mark in enumerate((KALIBR_MARK, export_mark('kalibr'))):
        target = tmp_path / f'imu{n}.yaml'
        target.write_text(f'# {mark}\nimu0:\n  update_rate: 200.0\n', encoding='utf-8')
        _stop(_start('noise_node', {'topic': '/imu/data', 'kalibr_file': str(target)}))
