"""A hand-off file that cannot be written is refused before any work, and never lost after.

(New-user walk: ``./run.sh demo --out notyaml.yaml`` ran the whole procedure, logged
``hand-off file not written`` and then removed the state directory, exit 0, claiming the
file.)

- ``bench_demo --out`` and every calibration node's ``output_file`` are checked as
  ``gyro-calib calibrate --out`` is (one function, ``check_handoff_output``): an existing
  file that is no hand-off file, a directory, a missing parent → one line (a node: one FATAL
  line), exit 2, nothing started, nothing written (no state directory, no lock file);
- a hand-off write that fails at the end keeps the state directory, says where and what to
  do, and fails the run (exit :data:`EXIT_HANDOFF_NOT_WRITTEN`);
- a node stopped before any data says no state was kept, and removes the lock file it made.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.handoff import Provenance, method_calibration
from gyro_calib.nodes.conventions import CalibrationNodeBase
from gyro_calib.nodes.node_state import NodeState
from gyro_calib.nodes.ros_io import EXIT_HANDOFF_NOT_WRITTEN
from gyro_calib.registry import handoff_schema

from .dds_harness import NodeProcess, launch

ROOT = Path(__file__).resolve().parents[2]


class Log:
    """A node logger that keeps (level, line)."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def __getattr__(self, level: str) -> Any:
        return lambda line: self.lines.append((level, line))


def _not_a_handoff(tmp_path: Path) -> Path:
    path = tmp_path / 'notyaml.yaml'
    path.write_text('hello\n', encoding='utf-8')
    return path


def _wait(proc: subprocess.Popen[Any], timeout_s: float = 60.0) -> int:
    try:
        return proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        pytest.fail('the node ran on with an output_file it cannot write')


@pytest.mark.parametrize(('node', 'kind'), [
    ('calibration_node', 'not a hand-off'), ('calibration_node', 'directory'),
    ('calibration_node', 'missing parent'), ('dither_calibration_node', 'not a hand-off')])
def test_a_node_refuses_an_output_file_it_cannot_write_at_start(
        tmp_path: Path, node: str, kind: str, nodes: list[NodeProcess]) -> None:
    """One FATAL line naming output_file, exit 2; the file as it was, no state, no lock."""
    target = {'not a hand-off': _not_a_handoff(tmp_path), 'directory': tmp_path,
              'missing parent': tmp_path / 'absent' / 'g.yaml'}[kind]
    before = sorted(p.name for p in tmp_path.iterdir())
    proc = launch(node, {'output_file': str(target)}, expect_exit=(2,))
    nodes.append(proc)  # stopped after the test whatever happens
    assert _wait(proc.proc) == 2, proc.log()
    time.sleep(0.2)  # the reader thread takes the last lines
    fatal = [line for line in proc.lines if '[FATAL]' in line]
    assert len(fatal) == 1, proc.log()
    assert f'output_file {target}' in fatal[0], fatal
    assert 'Traceback' not in proc.log()
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no .state, no .lock
    if kind == 'not a hand-off':
        assert target.read_text(encoding='utf-8') == 'hello\n'
        assert 'exists and cannot be updated' in fatal[0]
        assert 'must hold a mapping, got str' in fatal[0]


def test_the_demo_refuses_an_out_that_is_not_a_handoff_file_before_anything_starts(
        tmp_path: Path) -> None:
    """The walk's case: one line as ``calibrate --out`` gives, exit 2, no node started."""
    out = _not_a_handoff(tmp_path)
    proc = subprocess.run(
        [sys.executable, '-m', 'gyro_calib.nodes.bench_demo', '--out', str(out)],
        env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True,
        timeout=30, check=False)
    assert (proc.returncode, proc.stdout) == (2, ''), proc.stderr
    assert proc.stderr.count('\n') == 1, proc.stderr
    assert proc.stderr.startswith(f'bench_demo: error: --out {out} exists and cannot be '
                                  'updated: calibration file'), proc.stderr
    assert 'must hold a mapping, got str.' in proc.stderr
    assert out.read_text(encoding='utf-8') == 'hello\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ['notyaml.yaml']


def _columns() -> dict[str, TopicColumns]:
    stamps = np.arange(1, 4, dtype=np.int64) * 1_000_000
    return {'/rate_table/zero_index': TopicColumns(
        '/rate_table/zero_index', 'std_msgs/msg/Header', stamps, stamps,
        FrameIds(np.zeros(3, dtype=np.int32), ('table',)), {})}


def _node(tmp_path: Path, output_file: Path) -> Any:
    """A calibration node's hand-off and state logic, without ROS around it."""
    node = SimpleNamespace(output_file=str(output_file), _handoff_missing=None,
                           _merge_told=frozenset(), _last_line='', _handoff_failure='',
                           exit_status=0, log=Log())
    node.get_logger = lambda: node.log
    node.state = NodeState(node, 'rbrlg', 'G-1', Path(f'{output_file}.state'), keep=False)
    return node


def _record() -> Any:
    """What a node's ``make`` gives: an rbrlg record (K̃ only), nothing said missing."""
    record = method_calibration('rbrlg', {'k_tilde_rad_per_pulse': 4.086e-6,
                                          'k_tilde_rad_per_pulse_std': 1e-13},
                                Provenance('live', 1, 2), gyro_id='G-1',
                                schema=handoff_schema())
    return lambda: (record, ())


def test_a_handoff_write_that_fails_at_the_end_keeps_the_state_and_fails_the_run(
        tmp_path: Path) -> None:
    """The file replaced by something that is no hand-off file during the run."""
    out = tmp_path / 'g.yaml'
    node = _node(tmp_path, out)
    node.state.record_batch(_columns())
    out.write_text('hello\n', encoding='utf-8')  # replaced meanwhile
    CalibrationNodeBase.write_handoff_record(node, _record())
    CalibrationNodeBase.finish_state(node, complete=True)
    assert node.exit_status == EXIT_HANDOFF_NOT_WRITTEN != 0
    assert (out.parent / 'g.yaml.state').is_dir()  # the data are not removed
    assert out.read_text(encoding='utf-8') == 'hello\n'
    errors = [line for level, line in node.log.lines if level == 'error']
    assert errors[-1].startswith(f'hand-off file {out} not written (calibration file {out} '
                                 'must hold a mapping, got str): the data consumed are kept '
                                 f'in {out}.state (not removed).'), errors
    assert 'start the node again with the same parameters' in errors[-1]
    assert not any('removed' in line and 'not removed' not in line
                   for _, line in node.log.lines)
    assert not (tmp_path / 'g.yaml.state.lock').exists()


def test_a_write_that_succeeds_after_a_failed_one_clears_it(tmp_path: Path) -> None:
    out = tmp_path / 'g.yaml'
    node = _node(tmp_path, out)
    node.state.record_batch(_columns())
    out.write_text('hello\n', encoding='utf-8')
    CalibrationNodeBase.write_handoff_record(node, _record())
    out.unlink()  # the user moved it away: the next write succeeds
    CalibrationNodeBase.write_handoff_record(node, _record())
    CalibrationNodeBase.finish_state(node, complete=True)
    assert node.exit_status == 0
    assert not (tmp_path / 'g.yaml.state').exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ['g.yaml']


def test_a_node_stopped_before_any_data_says_no_state_was_kept_and_leaves_no_lock(
        tmp_path: Path, nodes: list[NodeProcess]) -> None:
    """It said 'state kept in g.yaml.state' (no such directory) and left g.yaml.state.lock."""
    out = tmp_path / 'g.yaml'
    proc = launch('calibration_node', {'output_file': str(out)})
    nodes.append(proc)
    deadline = time.monotonic() + 60  # a loaded machine: imports take seconds
    while not any('calibrating K̃' in line for line in proc.lines):
        assert time.monotonic() < deadline and proc.proc.poll() is None, proc.log()
        time.sleep(0.1)
    assert (tmp_path / 'g.yaml.state.lock').exists()
    proc.send_signal(signal.SIGTERM)
    assert _wait(proc.proc) == 0, proc.log()
    time.sleep(0.2)
    assert 'state kept in' not in proc.log()
    assert f'no data recorded: no state directory {out}.state left behind' in proc.log()
    assert sorted(p.name for p in tmp_path.iterdir()) == []
