"""multiposition_calibration_node: an IMU turned by hand, calibrated live (METHODS §G).

Subscribes a sensor_msgs/Imu topic (``topic``, default /imu/data); every
``analysis_period_s`` of data, and whenever the input pauses, it finds the static poses so
far and calibrates; /diagnostics (status ``gyro_calib: multiposition``) says how many poses it
has and how many it still needs, and the hand-off file's ``imu:`` section (``output_file``,
format 4) is written through the same
:class:`~gyro_calib.multiposition.session.MultipositionSession` as ``gyro-calib calibrate
--method multiposition``. Parameters: every field of
:class:`~gyro_calib.multiposition.settings.MultipositionSettings` and the common ones of
:mod:`gyro_calib.nodes.method_node`.
"""

from __future__ import annotations

from gyro_calib.multiposition.settings import MultipositionSettings
from gyro_calib.nodes.method_node import run_method_node


def main(args: list[str] | None = None) -> None:
    """Run the multiposition calibration node until stopped."""
    run_method_node('multiposition', 'multiposition_calibration_node', {},
                    MultipositionSettings, args)


if __name__ == '__main__':
    main()
