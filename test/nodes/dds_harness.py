"""Start bench nodes as processes and listen to their results, for DDS tests.

Every process inherits the loopback-only, private ROS_DOMAIN_ID that conftest.py set, and
runs in a scratch directory, so a default output (the calibration node's hand-off YAML) never
lands in the work tree.
"""

from __future__ import annotations

import atexit
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from gyro_calib.nodes.processes import ros_environment, start_node


class NodeDied(AssertionError):
    """A node a test started ended on its own with a failure status while the test waited."""


@dataclass
class NodeProcess:
    """A started node with its stderr (where ROS logs go) collected line by line.

    ``expect_exit``: the exit statuses of a node ending on its own that are no failure (a
    node the test signalled may end with any).
    """

    name: str
    proc: subprocess.Popen[bytes]
    lines: list[str] = field(default_factory=list)
    expect_exit: tuple[int, ...] = (0,)
    signalled: bool = False

    def __post_init__(self) -> None:
        threading.Thread(target=self._read, daemon=True).start()
        _WATCHED.append(self)

    def send_signal(self, sig: int) -> None:
        """Signal the node (SIGINT, SIGKILL, ...): its end is then the test's doing."""
        self.signalled = True
        self.proc.send_signal(sig)

    def died(self) -> str:
        """'' while the node runs or ended as expected; else what ended it, with its log."""
        code = self.proc.poll()
        if code is None or self.signalled or code in self.expect_exit:
            return ''
        time.sleep(0.2)  # the reader thread takes the last lines
        tail = '\n'.join(self.lines[-30:])
        return f'{self.name} exited with status {code} while the test waited:\n{tail}'

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for raw in self.proc.stderr:
            self.lines.append(raw.decode(errors='replace').rstrip())

    def log(self) -> str:
        return '\n'.join(self.lines)

    def stop(self, timeout_s: float = 10.0) -> None:
        self.signalled = True
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


_WATCHED: list[NodeProcess] = []
"""Every node the running test started (test/nodes/conftest.py empties it after each test)."""


def check_no_node_died() -> None:
    """Raise :class:`NodeDied` at once if a node the test started has failed.

    A dead node never publishes what a test waits for: without this the wait ran to its
    timeout (600 s on Jazzy before issue 34).
    """
    for process in _WATCHED:
        reason = process.died()
        if reason:
            raise NodeDied(reason)


def spin_watched(executor: Any, timeout_sec: float) -> None:
    """``executor.spin_once(timeout_sec)``, then fail at once if a started node died."""
    executor.spin_once(timeout_sec=timeout_sec)
    check_no_node_died()


DISCOVERY_SETTLE_S = 2.0
"""How long a bench keeps spinning after its side of discovery matched (bag_player: 1 s).

A bench's publisher counts the node's reader as soon as the bench has discovered it; the
node's reader takes the bench's writer on its own discovery, later under load, and a
volatile reader drops what reached it before (a CI run lost the first 28 of 194 samples,
and all 40 of another test's)."""


@contextmanager
def bench_node(name: str) -> Iterator[tuple[Any, Any]]:
    """A node of this test process in a context of its own, and its executor.

    Destroyed on the way out whatever happened: a bench left alive after a failed assertion
    kept a reliable reader that never read, and the next test's player stalled on it.
    """
    import rclpy

    from gyro_calib.nodes.ros_io import make_executor

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node(name, context=context)
        executor = make_executor(context)
        executor.add_node(node)
        try:
            yield node, executor
        finally:
            executor.remove_node(node)
            executor.shutdown()
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def wait_discovered(executor: Any, matched: Callable[[], bool], timeout_s: float = 60.0,
                    settle_s: float = DISCOVERY_SETTLE_S) -> bool:
    """Spin until ``matched()`` (this side of discovery), then ``settle_s`` more.

    Returns whether ``matched()`` held in time; the settle lets the node's side match too.
    """
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not matched():
        spin_watched(executor, timeout_sec=0.05)
    if not matched():
        return False
    settle = time.monotonic() + settle_s
    while time.monotonic() < settle:
        spin_watched(executor, timeout_sec=0.05)
    return True


def _scratch_dir() -> str:
    """A fresh directory per node process.

    A fresh directory per node process: a default output (and the state directory beside
    it) of one test is never resumed by another.
    """
    path = tempfile.mkdtemp(prefix='gyro_calib_dds_')
    atexit.register(shutil.rmtree, path, ignore_errors=True)
    return path


def launch(name: str, params: dict[str, Any], namespace: str = '', *,
           expect_exit: tuple[int, ...] = (0,)) -> NodeProcess:
    """Start node ``name`` (watched: see :func:`check_no_node_died`)."""
    env = ros_environment(int(os.environ['ROS_DOMAIN_ID']))
    proc = start_node(name, params, env, namespace=namespace, stdout=subprocess.DEVNULL,
                      stderr=subprocess.PIPE, cwd=_scratch_dir())
    return NodeProcess(name, proc, expect_exit=expect_exit)


class ResultListener:
    """Subscribes to /gyro_calib/k_tilde and /diagnostics in this test process."""

    def __init__(self) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from std_msgs.msg import Float64

        from gyro_calib import topics
        from gyro_calib.nodes.ros_io import RESULT_QOS, make_executor

        self._rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('test_listener', context=self.context)
        self.k_tilde: list[float] = []
        self.diagnostics: dict[str, str] = {}
        self.node.create_subscription(Float64, topics.K_TILDE,
                                      lambda m: self.k_tilde.append(m.data), RESULT_QOS)
        self.node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self._on_diag, 10)
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)

    def _on_diag(self, msg: Any) -> None:
        for status in msg.status:
            if status.name == 'gyro_calib: k_tilde':
                self.diagnostics = {kv.key: kv.value for kv in status.values}

    def spin_until(self, done: Any, timeout_s: float, *, source: NodeProcess | None = None,
                   grace_s: float = 600.0) -> bool:
        """Spin until ``done()`` or a timeout.

        Spin until ``done()``; give up after ``timeout_s``, or ``grace_s`` after the
        ``source`` process (the simulator feeding the bench) has exited.
        """
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            spin_watched(self.executor, timeout_sec=0.1)
            if done():
                return True
            if source is not None and source.proc.poll() is not None:
                deadline = min(deadline, time.monotonic() + grace_s)
                source = None
        return False

    def close(self) -> None:
        self.node.destroy_node()
        self._rclpy.shutdown(context=self.context)
