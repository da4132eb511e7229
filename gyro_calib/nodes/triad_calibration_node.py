"""triad_calibration_node: K, sense axes, M and biases of a gyro triad, live (METHODS §F).

Subscribes /imu/pulses (three channels), /rate_table/joint_states and /zero_index and, on the
two-axis bench, /position_table/joint_states and /zero_index; reports on /diagnostics (status
``gyro_calib: triad``) and writes the hand-off file's ``imu:`` section (``output_file``,
format 4) through the same :class:`~gyro_calib.triad.session.TriadSession` as
``gyro-calib calibrate --method triad``. Parameters: every field of
:class:`~gyro_calib.triad.session.TriadSettings` and the common ones of
:mod:`gyro_calib.nodes.method_node`; the bench settings (tilt_deg, …) from ``config_file``
or /sim/scenario.
"""

from __future__ import annotations

from gyro_calib.nodes.method_node import run_method_node
from gyro_calib.triad.session import TriadSettings


def main(args: list[str] | None = None) -> None:
    """Run the triad calibration node until stopped."""
    run_method_node('triad', 'triad_calibration_node', {}, TriadSettings, args)


if __name__ == '__main__':
    main()
