"""``./run.sh demo`` (bench_demo) stopped the ways users stop it (walk F2, F5).

- Ctrl-C as a terminal sends it (SIGINT to the whole foreground process group), while the
  nodes start (~1 s) or while they run (~6 s): one line from the demo, exit 130, no
  traceback (nor ``Fatal Python error``) from it or the nodes it started, no node left;
- a second demo on an ``--out`` another run is writing: refused before anything starts
  (one line, exit 2, nothing written);
- a node that stops with an error while the demo runs (its state directory taken after the
  demo's own check): the demo stops the others at once, one line with the node's fatal
  line, exit 2 — it waited without end.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gyro_calib.state_record import StateLock

ROOT = Path(__file__).resolve().parents[2]
FAST = ['--pairs', '1', '--speed', '50']


def demo(out: Path, **popen: object) -> subprocess.Popen[str]:
    """``python -m gyro_calib.nodes.bench_demo`` in a session of its own (as in a terminal)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))

    def as_in_a_terminal() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.setsid()

    return subprocess.Popen(  # noqa: PLW1509 (preexec_fn: the child's own session)
        [sys.executable, '-m', 'gyro_calib.nodes.bench_demo', *FAST, '--out', str(out)],
        env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT,
        preexec_fn=as_in_a_terminal, **popen)


def finish(proc: subprocess.Popen[str], timeout_s: float, why: str) -> tuple[str, str]:
    """(stdout, stderr) of ``proc``; on a timeout its session and nodes are killed, and fail."""
    try:
        return proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        left = children(proc.pid)
        os.killpg(proc.pid, signal.SIGKILL)
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        proc.communicate()
        pytest.fail(why)


def children(pid: int) -> set[int]:
    """Every live descendant of ``pid`` (from /proc)."""
    parent: dict[int, int] = {}
    for entry in Path('/proc').iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / 'stat').read_text()
            except OSError:
                continue
            parent[int(entry.name)] = int(stat.rsplit(')', 1)[1].split()[1])
    found, todo = set(), [pid]
    while todo:
        p = todo.pop()
        kids = {c for c, pp in parent.items() if pp == p}
        found |= kids
        todo += list(kids)
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()[0]
    except OSError:
        return False
    return state != 'Z'


@pytest.mark.parametrize('after_s', [1.0, 6.0])
def test_ctrl_c_to_the_process_group_gives_one_line_exit_130_and_leaves_no_node(
        after_s: float, tmp_path: Path) -> None:
    """Ctrl-C while the nodes import (1 s) or run (6 s): one line, 130, every node gone.

    It gave 4 import-time tracebacks and 3 'Fatal Python error' (rc -2) at 1 s, and a
    traceback from _watch at 6 s.
    """
    proc = demo(tmp_path / 'g.yaml')
    time.sleep(after_s)
    started = children(proc.pid)
    os.killpg(proc.pid, signal.SIGINT)
    out, err = finish(proc, 30, 'the demo did not end within 30 s of Ctrl-C')
    assert proc.returncode == 130, err
    assert 'Traceback' not in err and 'Fatal Python error' not in err, err
    assert 'KeyboardInterrupt' not in err, err
    assert err.strip().splitlines()[-1].startswith('bench_demo: interrupted; '), err
    if after_s > 3:
        assert started, 'the nodes had not started yet: the test interrupts too early'
    time.sleep(0.5)
    assert not [p for p in started if alive(p)], 'a node the demo started is still running'


def test_an_out_another_run_is_writing_is_refused_before_anything_starts(
        tmp_path: Path) -> None:
    """The second demo's node stopped with a fatal line and the demo waited (276 s)."""
    out = tmp_path / 'g.yaml'
    lock = StateLock(Path(f'{out}.state'))
    lock.acquire()
    try:
        proc = demo(out)
        stdout, err = finish(proc, 30, 'the demo went on with its output in use')
    finally:
        lock.release()
    assert (proc.returncode, stdout) == (2, '')
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith(f'bench_demo: error: another run (pid {os.getpid()} '), err
    assert f'is writing {out}: wait for it or give another --out. Nothing was started.' in err
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # the test's own lock: removed


def test_a_node_that_stops_with_an_error_stops_the_demo_at_once(tmp_path: Path) -> None:
    """A node's fatal error stops the demo: the other nodes stopped, its line, exit 2.

    The state directory, taken after the demo's own check, stops its calibration node.
    """
    out = tmp_path / 'g.yaml'
    proc = demo(out)
    assert proc.stdout is not None
    first = proc.stdout.readline()  # printed once the options were checked, before any node
    assert first.startswith(f'bench_demo: DDS domain {os.environ["ROS_DOMAIN_ID"]} (loopback '
                            'only; ROS_DOMAIN_ID); full procedure at'), first
    lock = StateLock(Path(f'{out}.state'))
    lock.acquire()  # the node is still importing (seconds): it finds the lock taken
    time.sleep(0.5)
    started = children(proc.pid)
    t0 = time.monotonic()
    try:
        stdout, err = finish(proc, 30, 'the demo went on after its calibration node stopped')
    finally:
        lock.release()
    assert time.monotonic() - t0 < 20
    assert proc.returncode == 2, err
    assert 'Traceback' not in err, err
    last = err.strip().splitlines()[-1]
    assert last.startswith('bench_demo: error: calibration_node stopped (exit 2): state '
                           f'directory {out}.state is being written by pid {os.getpid()}'), err
    assert last.endswith('the other nodes were stopped.'), err
    assert stdout == ''
    time.sleep(0.5)
    assert started and not [p for p in started if alive(p)]
