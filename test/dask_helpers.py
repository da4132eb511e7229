"""In-process Dask clusters for the batch tests, and a client ``gyro-calib batch`` cannot close."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest


@contextmanager
def in_process_client() -> Iterator[Any]:
    """A one-worker cluster in this process, and its client.

    The tasks run in this process: no worker start-up, and monkeypatching reaches them.
    """
    import logging

    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None, silence_logs=logging.CRITICAL) as cluster, \
            Client(cluster) as client:
        yield client


class SharedClient:
    """A test module's client lent to an in-process ``gyro-calib batch``, not closed by it."""

    def __init__(self, client: Any) -> None:
        self._client = client

    def __getattr__(self, name: str) -> Any:
        return getattr(self._client, name)

    def close(self) -> None:
        """Kept open for the other tests."""


def lend_client_to_batch(client: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """``gyro-calib batch`` run in this process uses ``client`` instead of making its own."""
    import gyro_calib.batch.run as batch_run

    monkeypatch.setattr(batch_run, 'make_client',
                        lambda workers, scheduler: (SharedClient(client), None))
