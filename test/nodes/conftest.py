"""Fixtures of the DDS tests: a result listener and started node processes, cleaned up."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from .dds_harness import NodeProcess, ResultListener


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
