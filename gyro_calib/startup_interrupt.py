"""Ctrl-C while a command still loads its modules: one line, exit 130, no traceback.

Imports only the standard library, so a command installs it before its slow imports: the
``gyro-calib`` command and bench_demo name themselves; a node started alone (``ros2 run
gyro_calib NODE``, its console script, ``python -m MODULE``) is found by
:func:`quiet_interrupt_while_a_node_starts`, which the ``gyro_calib.nodes`` and
``sim_nodes`` packages call as they are imported, and rclpy's start
(:func:`gyro_calib.nodes.ros_distribution.ros_context`) ends it.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Callable

NODE_ENTRY_POINTS = {
    'calibration_node': 'gyro_calib.nodes.calibration_node',
    'imu_corrector': 'gyro_calib.nodes.imu_corrector_node',
    'thermal_bias_node': 'gyro_calib.nodes.thermal_bias_node',
    'rate_table_sim': 'sim_nodes.rate_table_node',
    'rlg_sim': 'sim_nodes.rbrlg.rlg_node',
    'bag_recorder': 'gyro_calib.nodes.bag_recorder',
    'bag_player': 'gyro_calib.nodes.bag_player',
    'fog_calibration_node': 'gyro_calib.nodes.fog_calibration_node',
    'fog_sim': 'sim_nodes.fog.fog_node',
    'dither_calibration_node': 'gyro_calib.nodes.dither_calibration_node',
    'vibration_table_sim': 'sim_nodes.dither.vibration_table_node',
    'thermal_calibration_node': 'gyro_calib.nodes.thermal_calibration_node',
    'thermal_chamber_sim': 'sim_nodes.thermal.chamber_node',
    'noise_node': 'gyro_calib.nodes.noise_node',
    'triad_sim': 'sim_nodes.triad.triad_node',
    'triad_calibration_node': 'gyro_calib.nodes.triad_calibration_node',
    'multiposition_calibration_node': 'gyro_calib.nodes.multiposition_calibration_node',
    'imu_multiposition_sim': 'sim_nodes.multiposition.imu_node',
}
"""Each node's name (its console script, ``ros2 run gyro_calib NAME``) → its module: setup.py's
entry points but ``gyro-calib`` and bench_demo (test/test_node_startup_interrupt.py)."""

_INSTALLED: list[Callable[[int, object], None]] = []
"""The start-up handlers installed in this process."""


def quiet_interrupt_while_starting(command: str, script: str, nothing_done: str) -> None:
    """Until the command installs its own handler, Ctrl-C says ``nothing_done`` and exits 130.

    Only when this process is ``command`` starting (console script ``command``, ``python -m``,
    or the file ending in ``script``) and SIGINT still has Python's default handler.
    """
    start = os.path.basename(sys.argv[0]) if sys.argv else ''
    starting = start in (command, '-m') or (bool(sys.argv) and sys.argv[0].endswith(script))
    if not starting or signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return

    def interrupted(signum: int, frame: object) -> None:
        sys.stderr.write(f'{command}: interrupted; {nothing_done}.\n')
        sys.stderr.flush()
        os._exit(130)  # not SystemExit: half-imported modules would raise on the way out

    _INSTALLED.append(interrupted)
    signal.signal(signal.SIGINT, interrupted)


def starting_node() -> str:
    """The node this process is starting (a key of :data:`NODE_ENTRY_POINTS`), '' if none.

    Its console script (``ros2 run`` runs it) names it in ``sys.argv[0]``; ``python -m
    MODULE`` in ``sys.orig_argv`` (``sys.argv[0]`` is ``-m`` while the packages load);
    ``python path/to/module.py`` by the file.
    """
    if not sys.argv:
        return ''
    start = sys.argv[0]
    if os.path.basename(start) in NODE_ENTRY_POINTS:
        return os.path.basename(start)
    modules = {module: name for name, module in NODE_ENTRY_POINTS.items()}
    if start == '-m':
        given = getattr(sys, 'orig_argv', [])
        after = [given[i + 1] for i, a in enumerate(given[:-1]) if a == '-m']
        return modules.get(after[0], '') if after else ''
    return next((name for module, name in modules.items()
                 if start.endswith(module.replace('.', os.sep) + '.py')), '')


def quiet_interrupt_while_a_node_starts() -> None:
    """A node started alone: Ctrl-C while it loads its modules is one line and exit 130.

    ``NODE: interrupted; not started, nothing written.`` instead of a traceback through
    the imports (the same rule as the ``gyro-calib`` command's). Nothing when this process
    is not a node starting (a test, a library user, another command).
    """
    node = starting_node()
    if node:
        quiet_interrupt_while_starting(node, NODE_ENTRY_POINTS[node].replace('.', os.sep) + '.py',
                                       'not started, nothing written')


def end_of_starting() -> None:
    """Give SIGINT back to Python's default handler if the start-up one still holds it."""
    if signal.getsignal(signal.SIGINT) in _INSTALLED:
        signal.signal(signal.SIGINT, signal.default_int_handler)
