"""Test-run settings: DDS stays on loopback, in a domain private to this test run.

The domain is derived from the pytest process id (1–100) unless
GYRO_CALIB_TEST_DOMAIN_ID names one, so two runs on one machine do not cross-talk
and a ROS_DOMAIN_ID left in the shell is never joined by tests.
"""

from __future__ import annotations

import os

# Every front door imports the method registry, which installs its hand-off key schema as
# the default of gyro_calib.handoff (the hand-off module never imports the registry: issue
# 19 §5); tests that call the hand-off functions or the sessions directly get it too.
import gyro_calib.registry  # noqa: F401

# Set before any test imports rclpy or starts a node: every child process inherits it.
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['ROS_DOMAIN_ID'] = os.environ.get('GYRO_CALIB_TEST_DOMAIN_ID',
                                             str(1 + os.getpid() % 100))
