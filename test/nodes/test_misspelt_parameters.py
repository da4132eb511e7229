"""A misspelt node parameter stops the node before any work; it is not run on its default.

(The last walk: ``-p latitude_dg:=48.1`` to a calibration node only warned, and the node
calibrated with the latitude unset — a typo that ROS ignores, with exit 0.)

- a parameter given to this node by name (``-p``, or its own section of a ``--params-file``)
  that it lacks but nearly spells (difflib ratio ≥ 0.8 to one it has) → one FATAL line naming
  both, exit 2, nothing written (no state directory, no lock, no hand-off);
- one that is not near any of its names, or one given to every node (a ``/**`` section of a
  shared parameters file), still only warns: it may be meant for another node;
- a subclass's own parameter (``fit_after_idle_s``) is declared before the check, so it is
  never taken for a typo.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from gyro_calib.nodes.ros_io import addressed_parameters

from .dds_harness import NodeProcess, launch


def test_parameters_given_by_name_are_told_from_those_given_to_every_node(
        tmp_path: Path) -> None:
    """``-p``, ``--param``, ``node:name`` and the node's own file section count; ``/**`` not."""
    shared = tmp_path / 'params.yaml'
    shared.write_text(
        '/**:\n  ros__parameters:\n    latitude_dg: 1.0\n'
        '/triad_calibration_node:\n  ros__parameters:\n    gyro_idd: a\n'
        '    nested:\n      depth: 2\n'
        'other_node:\n  ros__parameters:\n    heading_dg: 2.0\n', encoding='utf-8')
    args = ['prog', '--ros-args', '-p', 'out_file:=a.yaml', '--param', 'keep_stat:=true',
            '-p', 'triad_calibration_node:resum:=false', '-p', 'other_node:x:=1',
            '--params-file', str(shared), '--', '-p', 'not_ros:=1']
    names = ('triad_calibration_node', '/triad_calibration_node')
    assert addressed_parameters(args, names) == {
        'out_file', 'keep_stat', 'resum', 'gyro_idd', 'nested.depth'}
    assert addressed_parameters(['prog'], names) == set()


def _wait(proc: NodeProcess, timeout_s: float = 60.0) -> int:
    try:
        return proc.proc.wait(timeout=timeout_s)
    except Exception:  # noqa: BLE001 - TimeoutExpired: the node ran on
        pytest.fail(f'{proc.name} ran on with a misspelt parameter:\n{proc.log()}')


@pytest.mark.parametrize(('node', 'typo', 'meant'), [
    ('calibration_node', 'latitude_dg', 'latitude_deg'),
    ('triad_calibration_node', 'gyro_idd', 'gyro_id'),
    ('noise_node', 'kalibr_fle', 'kalibr_file'),
])
def test_a_misspelt_parameter_stops_the_node_before_it_writes_anything(
        tmp_path: Path, node: str, typo: str, meant: str, nodes: list[NodeProcess]) -> None:
    """One FATAL line naming the typo and the parameter it nearly spells; exit 2; no files."""
    out = tmp_path / 'gyro.yaml'
    proc = launch(node, {'output_file': str(out), typo: 48.1 if 'dg' in typo else 'x'},
                  expect_exit=(2,))
    nodes.append(proc)
    assert _wait(proc) == 2, proc.log()
    time.sleep(0.2)  # the reader thread takes the last lines
    fatal = [line for line in proc.lines if '[FATAL]' in line]
    assert len(fatal) == 1, proc.log()
    assert f"'{typo}' (did you mean '{meant}'?)" in fatal[0], fatal
    assert 'Nothing was started' in fatal[0]
    assert 'Traceback' not in proc.log()
    assert list(tmp_path.iterdir()) == []  # no hand-off, no .state, no .lock


def test_a_parameter_near_none_of_the_nodes_still_only_warns(
        tmp_path: Path, nodes: list[NodeProcess]) -> None:
    """A name close to none of the node's (meant for another node?) is said, not fatal.

    The thermal node's own ``fit_after_idle_s`` is no typo.
    """
    proc = launch('thermal_calibration_node', {
        'output_file': str(tmp_path / 'gyro.yaml'), 'fit_after_idle_s': 1.0,
        'scale_factor_rad_per_pulse': 4.6e-6, 'latitude_deg': 48.1,
        'use_sim_clock_of_bench': True})
    nodes.append(proc)
    deadline = time.monotonic() + 60.0
    while not any('waiting for' in line for line in proc.lines):
        assert proc.proc.poll() is None, proc.log()
        assert time.monotonic() < deadline, proc.log()
        time.sleep(0.1)
    proc.stop()
    log = proc.log()
    assert '[FATAL]' not in log, log
    assert 'parameter(s) use_sim_clock_of_bench given but not declared' in log, log
    assert 'fit_after_idle_s' not in log, log


@pytest.mark.parametrize(('node', 'params', 'typo', 'meant'), [
    ('bag_recorder', {'topcs': ['/gyro/pulses']}, 'topcs', 'topics'),
    ('bag_player', {'bag': 'absent', 'rat': 0.0}, 'rat', 'rate'),
])
def test_the_bag_nodes_refuse_a_misspelt_parameter_before_opening_a_bag(
        tmp_path: Path, node: str, params: dict[str, object], typo: str, meant: str,
        nodes: list[NodeProcess]) -> None:
    """The recorder creates no bag directory; the player names the typo before the bag."""
    out = tmp_path / 'lab'
    given = {'out': str(out), **params} if node == 'bag_recorder' else params
    proc = launch(node, given, expect_exit=(2,))
    nodes.append(proc)
    assert _wait(proc) == 2, proc.log()
    time.sleep(0.2)
    assert proc.lines[-1:] and f"'{typo}' (did you mean '{meant}'?)" in proc.lines[-1], \
        proc.log()
    assert 'Traceback' not in proc.log()
    assert list(tmp_path.iterdir()) == []


def test_a_command_line_given_to_run_node_is_not_kept_for_the_next_node() -> None:
    """run_node notes its args for the check and forgets them when it returns."""
    from gyro_calib.nodes import ros_io

    def refused() -> None:
        raise SystemExit(0)

    with pytest.raises(SystemExit):
        ros_io.run_node('probe', refused, ['x', '--ros-args', '-p', 'gyro_idd:=a'])
    assert ros_io._COMMAND_LINE is None
