"""Test-run settings: DDS stays on loopback, in a domain private to this test run.

The domain (1–100) is one no other test run on this machine holds: each run takes an
exclusive lock on ``gyro_calib_dds_domain_<N>.lock`` in the temporary directory for its
whole life, starting from its process id (two runs whose ids agree modulo 100 once shared
a domain, and one run's replayed zero-index events reached the other's nodes as "too
late"), and none a DDS participant of another program has bound a port of
(:func:`gyro_calib.nodes.processes.hold_free_domain`). GYRO_CALIB_TEST_DOMAIN_ID names a
domain instead. A ROS_DOMAIN_ID left in the shell is never joined by tests.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import IO

import pytest

# Every front door imports the method registry, which installs its hand-off key schema as
# the default of gyro_calib.handoff (the hand-off module never imports the registry: issue
# 19 §5); tests that call the hand-off functions or the sessions directly get it too.
import gyro_calib.registry  # noqa: F401


def _private_domain() -> tuple[int, IO[bytes] | None]:
    """A DDS domain no other test run on this machine holds, and the lock that keeps it.

    :func:`gyro_calib.nodes.processes.hold_free_domain`, as ``./run.sh demo`` takes its
    own: no other run's lock, no port of another DDS participant on this machine.
    """
    from gyro_calib.nodes.processes import hold_free_domain

    choice = hold_free_domain()
    return choice.domain, choice.lock


if 'GYRO_CALIB_TEST_DOMAIN_ID' in os.environ:
    _DOMAIN, _DOMAIN_LOCK = int(os.environ['GYRO_CALIB_TEST_DOMAIN_ID']), None
else:
    _DOMAIN, _DOMAIN_LOCK = _private_domain()

# CI (CI=true, as .ci/run is run) draws the same hypothesis examples on every run, so a
# change is judged on the same cases; a developer's run explores new ones (and a falsifying
# example found there is pinned with @example).
from hypothesis import settings as _hypothesis_settings  # noqa: E402

_hypothesis_settings.register_profile('ci', derandomize=True, database=None, print_blob=True)
if os.environ.get('CI', '').lower() in ('1', 'true', 'yes'):
    _hypothesis_settings.load_profile('ci')

# Set before any test imports rclpy or starts a node: every child process inherits it.
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['ROS_DOMAIN_ID'] = str(_DOMAIN)


def pytest_collection_modifyitems(config: object, items: list[pytest.Item]) -> None:
    """Groups for pytest-xdist's ``--dist loadgroup`` (pytest.ini runs two workers).

    A file's tests stay on one worker (its module fixtures are built once), and every DDS
    test (``test/nodes``) runs on one worker, one at a time, as in a serial run; the other
    worker runs the rest beside it (the nodes' numbers do not depend on load: stamps, not
    wall clocks).
    """
    for item in items:
        path = Path(str(item.path))
        group = 'dds' if path.parent.name == 'nodes' else path.name
        item.add_marker(pytest.mark.xdist_group(group))
