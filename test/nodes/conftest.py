"""Fixtures of the DDS tests: a result listener and started node processes, cleaned up."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from .dds_harness import _WATCHED, NodeProcess, ResultListener


@pytest.fixture
def listener() -> Iterator[ResultListener]:
    lst = ResultListener()
    yield lst
    lst.close()


@pytest.fixture
def nodes() -> Iterator[list[NodeProcess]]:
    started: list[NodeProcess] = []
    yield started
    for node in started:
        node.stop()


@pytest.fixture(autouse=True)
def _watch_started_nodes() -> Iterator[None]:
    """Each test watches only the nodes it started (dds_harness.check_no_node_died)."""
    _WATCHED.clear()
    yield
    _WATCHED.clear()
