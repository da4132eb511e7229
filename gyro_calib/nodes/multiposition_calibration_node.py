"""multiposition_calibration_node: an IMU turned by hand, calibrated live (METHODS §G).

Subscribes a sensor_msgs/Imu topic (``topic``, default /imu/data); every
``analysis_period_s`` of data (at stamps first stamp + n·period), and whenever the input
pauses, it finds the static poses so far and calibrates; the log and /diagnostics (status
``gyro_calib: multiposition``) say which poses it has and what it still needs, and the
hand-off file's ``imu:`` section (``output_file``, format 4) is written through the same
:class:`~gyro_calib.multiposition.session.MultipositionSession` as ``gyro-calib calibrate
--method multiposition``. Once the pose set is well-conditioned (§G.5) it writes the
hand-off and exits 0 by itself (``finish_when_conditioned``). Parameters: every field of
:class:`~gyro_calib.multiposition.settings.MultipositionSettings` and the common ones of
:mod:`gyro_calib.nodes.method_node`.
"""

from __future__ import annotations

from gyro_calib.multiposition.settings import MultipositionSettings
from gyro_calib.nodes.method_node import run_method_node


def main(args: list[str] | None = None) -> None:
    """Run the multiposition calibration node until well-conditioned or stopped."""
    run_method_node('multiposition', 'multiposition_calibration_node', {},
                    MultipositionSettings, args)


if __name__ == '__main__':
    main()
