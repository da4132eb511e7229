"""dither_calibration_node: the dither-axis misalignment of a dithered RLG, live (METHODS §C).

Subscribes /gyro/pulses and /vibration_table/joint_states (header.frame_id = the case axis the
table axis is along, "z" or "y"; a change of frame_id starts the next orientation's
recording); publishes a on /gyro_calib/dither/misalignment (rad, transient-local) once both
orientations are measured, every figure with its uncertainty, count and the reasons for what
is missing on /diagnostics (status ``gyro_calib: dither``), and updates the hand-off file
(``output_file``). Parameters: every field of
:class:`~gyro_calib.dither.settings.DitherSettings` and the common ones of
:mod:`gyro_calib.nodes.method_node` (``scale_factor_rad_per_pulse`` gives θ_d in rad).
"""

from __future__ import annotations

from gyro_calib.dither import topics
from gyro_calib.dither.keys import KEY_A
from gyro_calib.dither.settings import DitherSettings
from gyro_calib.nodes.method_node import run_method_node


def main(args: list[str] | None = None) -> None:
    """Run the dither calibration node until shut down."""
    run_method_node('dither', 'dither_calibration_node', {KEY_A: topics.DITHER_MISALIGNMENT},
                    DitherSettings, args)


if __name__ == '__main__':
    main()
