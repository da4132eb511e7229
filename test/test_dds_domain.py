"""Each test run holds a DDS domain of its own, so two runs on one machine never cross-talk."""

from __future__ import annotations

import os

import conftest


def test_a_domain_held_by_one_run_is_never_given_to_another() -> None:
    assert os.environ['ROS_DOMAIN_ID'] == str(conftest._DOMAIN)
    # two more runs starting from the same process id modulo 100 (as two runs once did)
    first, first_lock = conftest._private_domain()
    second, second_lock = conftest._private_domain()
    try:
        assert first_lock is not None and second_lock is not None
        assert len({first, second, conftest._DOMAIN}) == 3 or (
            conftest._DOMAIN_LOCK is None and first != second)  # a named domain: not locked
        assert all(1 <= d <= 100 for d in (first, second))
    finally:
        for lock in (first_lock, second_lock):
            if lock is not None:
                lock.close()
