"""A node that dies makes its DDS test fail at once, never a wait to the test's timeout.

On Jazzy every node once died at start-up (issue 34) and each DDS test then waited its
whole timeout (600 s) for results that could not come.
"""

from __future__ import annotations

import time

import pytest

from .dds_harness import NodeDied, NodeProcess, ResultListener, launch


def test_a_node_that_dies_fails_the_wait_at_once_with_its_log(
        listener: ResultListener, nodes: list[NodeProcess]) -> None:
    nodes.append(launch('calibration_node', {'latitude_deg': 400.0}))  # exits 2: bad input
    start = time.monotonic()
    with pytest.raises(NodeDied, match=r'calibration_node exited with status 2(.|\n)*'
                                       r'latitude_deg'):
        listener.spin_until(lambda: False, timeout_s=120.0)
    assert time.monotonic() - start < 60.0


def test_a_node_the_test_stops_or_expects_to_end_is_no_failure(
        listener: ResultListener, nodes: list[NodeProcess]) -> None:
    bad = launch('calibration_node', {'latitude_deg': 400.0}, expect_exit=(2,))
    stopped = launch('calibration_node', {})
    nodes += [bad, stopped]
    bad.proc.wait(timeout=60)
    stopped.stop(timeout_s=30.0)
    assert not listener.spin_until(lambda: False, timeout_s=1.0)
