"""``rclpy.init`` for a test that builds nodes in the pytest process, out of discovery.

A node built and destroyed in the pytest worker shares the process with the DDS
participants earlier tests left (a node whose constructor raised is never destroyed on
Jazzy; its participant lives until garbage collection). With discovery on, those send
their endpoints to each new participant, in process; destroying the node while that
delivery runs deadlocked Fast DDS 3.2 in a local CI run (Kilted, test_node_parameters:
``DomainParticipant::set_listener`` spinning in ``rmw_destroy_node`` while a discovery
thread waited for the participant's listener lock; the worker hung at 100 % CPU, the run
never ended). These tests need no discovery — a node's own endpoints match inside its
participant — so their contexts start with ``ROS_AUTOMATIC_DISCOVERY_RANGE=OFF``.
"""

from __future__ import annotations

import os
from typing import Any


def init_undiscovered(args: list[str] | None = None, **kwargs: Any) -> None:
    """``rclpy.init(args=args, **kwargs)`` with discovery off for that context."""
    import rclpy

    before = os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE')
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'OFF'  # read by rcl at init
    try:
        rclpy.init(args=args, **kwargs)
    finally:
        if before is None:
            del os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']
        else:
            os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = before
