"""thermal_calibration_node: a gyro's temperature bias model from a live chamber run (METHODS §D).

Subscribes /gyro/pulses (sensor_msgs/JointState) and /gyro/temperature
(sensor_msgs/Temperature, header.frame_id cavity_a, cavity_b, shell) and feeds the same
session ``gyro-calib calibrate --method thermal`` uses (:mod:`gyro_calib.thermal.session`).
The model is fitted at the end of the recording, which live means: once no message has
arrived for ``fit_after_idle_s`` (wall time decides only *when*; the model depends only on
the messages), and when the node is shut down with data not yet fitted (the hand-off file is
then still written). With ``refit_every_s`` > 0 it also refits on the way. Every figure, with
its uncertainty, count and the reason for anything missing, goes to /diagnostics (status
``gyro_calib: thermal``); the model goes into the hand-off file (``output_file``) as
``thermal_model``.

Parameters: every field of :class:`~gyro_calib.thermal.settings.ThermalSettings`, the
common ones of :mod:`gyro_calib.nodes.method_node` (``scale_factor_rad_per_pulse`` and
``latitude_deg`` are required; ``gyro_id`` goes into the model), and ``fit_after_idle_s``.
"""

from __future__ import annotations

import time

from gyro_calib.errors import GyroCalibError
from gyro_calib.nodes.method_node import MethodNode
from gyro_calib.nodes.node_state import calibration_complete
from gyro_calib.nodes.ros_io import run_node
from gyro_calib.thermal.settings import ThermalSettings


class ThermalCalibrationNode(MethodNode):
    """The generic method node, plus the end-of-recording fit."""

    def __init__(self) -> None:
        """Declare parameters (settings, common ones, fit_after_idle_s) and wire topics."""
        super().__init__('thermal', 'thermal_calibration_node', {}, ThermalSettings, (
            ('fit_after_idle_s', 5.0, 'Fit the model once no message has arrived for this '
             'long, s (the end of the recording; 0 = only at shut-down or every '
             'refit_every_s).'),))
        self.fit_after_idle_s = float(self.extra_parameters['fit_after_idle_s'])
        self._last_data = time.monotonic()
        self.unfitted = False

    def _process(self) -> None:
        got = self._live_inputs.pending() > 0
        super()._process()
        now = time.monotonic()
        if got:
            self._last_data, self.unfitted = now, True
        elif self.unfitted and self.fit_after_idle_s > 0 \
                and now - self._last_data >= self.fit_after_idle_s:
            self.get_logger().info(f'no message for {self.fit_after_idle_s:g} s: end of the '
                                   'recording, fitting the model.')
            self.finish()
            super()._process()  # publishes the new results, hand-off and diagnostics

    def consume_now(self) -> None:
        """Take in the buffered samples and fit the model on what came (``~/save``)."""
        super().consume_now()
        if self.unfitted:
            self.finish()
            super()._process()

    def finish(self) -> None:
        """Fit on everything received so far (the end of the recording)."""
        self.unfitted = False
        self.state.resume_once(self.session.feed, self.session.process)
        # messages that arrived since the last hand-over (shut-down): recorded, then fed
        self._feed(self._take_inputs(flush=True))
        try:
            lines = self.session.process(flush=True)
        except GyroCalibError as exc:  # a sensor too sparse to interpolate: say so, fit nothing
            lines = [f'thermal model not fitted: {exc}']
        for line in lines:
            self._last_line = line
            log = self.get_logger()
            log.warning(line) if 'not fitted' in line or 'reject' in line else log.info(line)


def main(args: list[str] | None = None) -> None:
    """Run the thermal calibration node until SIGINT/SIGTERM.

    Stopped mid-recording, it fits what came.
    """

    def fit_what_came(node: ThermalCalibrationNode, _executor: object) -> None:
        if node.unfitted:
            node.finish()
            node._write_handoff()
        node.finish_state(complete=calibration_complete(node.session.missing(),
                                                        node.session.not_measurable()))

    run_node('thermal_calibration_node', ThermalCalibrationNode, args, on_stop=fit_what_came)


if __name__ == '__main__':
    main()
