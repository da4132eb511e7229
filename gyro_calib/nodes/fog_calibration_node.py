"""fog_calibration_node: a closed-loop FOG's scale factor, live (METHODS §B).

Subscribes /fog/output, /fog/injection, /rate_table/joint_states and /rate_table/zero_index;
publishes the turntable K on /gyro_calib/fog/scale_factor and the self-calibrated K on
/gyro_calib/fog/self_cal_scale_factor (counts/rad, transient-local), every figure with its
uncertainty on /diagnostics, and updates the hand-off file. Parameters: every field of
:class:`~gyro_calib.fog.settings.FogSettings` and the common ones of
:mod:`gyro_calib.nodes.method_node`.
"""

from __future__ import annotations

from gyro_calib import topics
from gyro_calib.fog.calibrator import KEY_SCALE_FACTOR, KEY_SELF_CAL
from gyro_calib.fog.settings import FogSettings
from gyro_calib.nodes.method_node import run_method_node


def main(args: list[str] | None = None) -> None:
    """Run the FOG calibration node until shut down."""
    run_method_node('fog', 'fog_calibration_node',
                    {KEY_SCALE_FACTOR: topics.FOG_SCALE_FACTOR,
                     KEY_SELF_CAL: topics.FOG_SELF_CAL_SCALE_FACTOR}, FogSettings, args)


if __name__ == '__main__':
    main()
