"""fog_calibration_node: a closed-loop FOG's scale factor, live (METHODS §B).

Subscribes /fog/output, /fog/injection, /rate_table/joint_states and /rate_table/zero_index;
publishes the turntable K on /gyro_calib/fog/scale_factor and the self-calibrated K on
/gyro_calib/fog/self_cal_scale_factor (counts/rad, transient-local) as they firm up, every
figure with its uncertainty on /diagnostics (status ``gyro_calib: fog``), and updates the
hand-off file (``output_file``) atomically. Parameters: every field of
:class:`~gyro_calib.fog.settings.FogSettings` and the common ones of
:mod:`gyro_calib.nodes.method_node`.

When it is stopped (Ctrl-C, SIGINT, SIGTERM) the recording has ended: the node takes the
messages its readers already hold, measures the last open segment and plateau as the
offline calibration does at the end of a bag, publishes the final results and diagnostics,
writes the hand-off file, and exits — so the live numbers equal ``gyro-calib calibrate`` on a
recording of the same run, bit for bit.
"""

from __future__ import annotations

from typing import Any

import rclpy

from gyro_calib import topics
from gyro_calib.fog.calibrator import KEY_SCALE_FACTOR, KEY_SELF_CAL
from gyro_calib.fog.session import FogSession
from gyro_calib.fog.settings import FogSettings
from gyro_calib.nodes.method_node import MethodNode
from gyro_calib.nodes.node_state import calibration_complete
from gyro_calib.nodes.ros_io import run_node, spin_until_quiet

RESULT_TOPICS = {KEY_SCALE_FACTOR: topics.FOG_SCALE_FACTOR,
                 KEY_SELF_CAL: topics.FOG_SELF_CAL_SCALE_FACTOR}
"""Hand-off key → the topic its value is published on (std_msgs/Float64, counts/rad)."""


class FogCalibrationNode(MethodNode):
    """The FOG method node; flushes the recording when it is stopped."""

    def __init__(self) -> None:
        """Declare parameters, build the FOG session, wire topics and timers."""
        super().__init__('fog', 'fog_calibration_node', RESULT_TOPICS, FogSettings)

    def received(self) -> int:
        """Messages received so far (handed to the session, held or buffered)."""
        return self._live_inputs.arrived

    # It spins the executor before the generic finish: called only by this node's main.
    def finish(self, executor: Any) -> None:  # type: ignore[override]
        """The recording ended: take what the readers hold, flush, publish, write.

        What the readers hold is taken in first (:func:`spin_until_quiet`): a reliable writer
        counts a sample delivered once our reader has it, before our callback ran.
        """
        spin_until_quiet(executor, self.received)
        self._live_inputs.ended = True  # everything held goes to the session, in stamp order
        session = self.session
        assert isinstance(session, FogSession)
        session.end_of_recording()
        self._process()  # feeds the rest, flushes, publishes what changed, writes the file
        self._write_handoff()  # also when only the reasons of what is missing changed
        self._publish_diagnostics()
        self.get_logger().info(f'recording ended after {self.received()} messages: last '
                               f'segment and plateau measured; {len(session.results())} '
                               'quantities final.')
        self.finish_state(complete=calibration_complete(session.missing(),
                                                        session.not_measurable()))
        pubs = [*self._result_pubs.values(), self.diag_pub]
        for pub in pubs:
            pub.wait_for_all_acked(rclpy.duration.Duration(seconds=5.0))


def main(args: list[str] | None = None) -> None:
    """Run the FOG calibration node until stopped; then flush and publish the final results."""
    run_node('fog_calibration_node', FogCalibrationNode, args,
             on_stop=lambda node, executor: node.finish(executor))


if __name__ == '__main__':
    main()
