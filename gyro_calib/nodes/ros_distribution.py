"""The ROS 2 distributions gyro_calib runs on, and the one way every front door starts rclpy.

Supported and tested on every change (README, Supported ROS 2): **Jazzy** (the LTS, rclpy
7.x) and **Kilted** (rclpy 9.x). Humble (rclpy 3.x, Python 3.10) is not supported: it has
no ``rclpy.experimental.events_executor`` and no ``rclpy.event_handler``, which the nodes
use. The two supported distributions differ in what ``rclpy.init`` returns: Kilted's is a
context manager that shuts the context down, Jazzy's returns ``None``. :func:`ros_context`
is the one form every front door uses, so no code depends on either return value.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
from collections.abc import Iterator
from contextlib import contextmanager

SUPPORTED_DISTRIBUTIONS = ('jazzy', 'kilted')
"""The ROS 2 distributions the suite runs on (``./run.sh test`` and ``--ros jazzy``)."""

RCLPY_MINIMUM = (7, 1)
"""The oldest rclpy (Jazzy's 7.1) with every API the nodes use."""


class UnsupportedRos(RuntimeError):
    """The rclpy found is older than every supported distribution."""


def rclpy_version() -> tuple[int, ...] | None:
    """The installed rclpy's version (from its distribution metadata), or None if unknown."""
    for distribution in ('ros-rclpy', 'rclpy'):
        try:
            text = importlib.metadata.version(distribution)
        except importlib.metadata.PackageNotFoundError:
            continue
        parts = []
        for part in text.split('.'):
            if not part.isdigit():
                break
            parts.append(int(part))
        return tuple(parts) or None
    return None


def check_rclpy() -> None:
    """Raise :class:`UnsupportedRos` in one line if this rclpy lacks what the nodes use.

    A source build (colcon on a sourced ROS) has no wheel metadata: then the API itself
    decides (the events executor, added in Jazzy).
    """
    version = rclpy_version()
    has_events_executor = importlib.util.find_spec('rclpy.experimental') is not None
    if (version is not None and version[:2] < RCLPY_MINIMUM) or not has_events_executor:
        found = '.'.join(map(str, version)) if version else 'without rclpy.experimental'
        raise UnsupportedRos(
            f'gyro_calib needs ROS 2 Jazzy or Kilted (rclpy >= '
            f'{".".join(map(str, RCLPY_MINIMUM))}); found rclpy {found}. Source a Jazzy or '
            f'Kilted installation (Humble is not supported).')


@contextmanager
def ros_context(args: list[str] | None = None, *, own_signals: bool = False) -> Iterator[None]:
    """``rclpy.init`` for the block, ``rclpy.try_shutdown`` after it, on Jazzy and Kilted.

    ``own_signals``: the caller handles SIGINT/SIGTERM itself (rclpy installs no handler).
    """
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from gyro_calib.startup_interrupt import end_of_starting

    end_of_starting()  # the node's modules are loaded: Ctrl-C is the node's (or rclpy's) now
    check_rclpy()
    options = SignalHandlerOptions.NO if own_signals else None
    rclpy.init(args=args, signal_handler_options=options)
    try:
        yield
    finally:
        rclpy.try_shutdown()
