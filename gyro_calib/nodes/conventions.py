"""The ROS conventions every calibration node keeps (issue 19 parts 3 and 4).

:class:`CalibrationNodeBase` is the base of :class:`~gyro_calib.nodes.method_node.MethodNode`
and :class:`~gyro_calib.nodes.calibration_node.CalibrationNode`. It gives them:

- inputs that follow their publishers' QoS (:mod:`gyro_calib.nodes.adaptive_qos`), by names
  relative to the node's namespace;
- services (std_srvs/Trigger) ``~/reset`` (start over: a new session, the state directory
  emptied) and ``~/save`` (write the hand-off file now, with what is measured);
- an opt-in managed (lifecycle) mode, parameter ``managed`` (default false, as
  robot_localization does): the node then starts unconfigured; configure → activate starts
  consuming (the inputs are subscribed), deactivate pauses (what arrived is handed to the
  calibrator, the inputs unsubscribed: data published meanwhile is a gap), cleanup clears (as
  ``~/reset``), shutdown stops consuming. Unmanaged, the node consumes from the start and
  offers no lifecycle services.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.lifecycle import LifecycleNodeMixin, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.qos import QoSProfile
from std_srvs.srv import Trigger

from gyro_calib.nodes.adaptive_qos import RELIABLE, AdaptiveSubscription
from gyro_calib.nodes.ros_io import described_parameter

SUCCESS = TransitionCallbackReturn.SUCCESS

LEVELS = {'OK': DiagnosticStatus.OK, 'WARN': DiagnosticStatus.WARN,
          'ERROR': DiagnosticStatus.ERROR}
"""A :class:`~gyro_calib.session.Progress` level → the DiagnosticStatus level."""


@dataclass(frozen=True, slots=True)
class InputSpec:
    """One input of a calibration node.

    One input: message class, topic (relative resolves in the namespace), callback, the
    profile while reliable, and whether best effort is forced.
    """

    msg_class: type
    topic: str
    callback: Callable[[Any], None]
    qos: QoSProfile
    forced_best_effort: bool = False


class CalibrationNodeBase(LifecycleNodeMixin, Node):
    """A calibration node: adaptive inputs, ``~/reset`` and ``~/save``, optional lifecycle.

    Subclasses give their inputs with :meth:`set_inputs` and implement
    :meth:`reset_calibration`, :meth:`save_calibration` and :meth:`consume_now`.
    """

    def __init__(self, node_name: str) -> None:
        """Create the node, read ``managed``, offer the services, start the QoS poll."""
        Node.__init__(self, node_name)
        self.managed = bool(described_parameter(
            self, 'managed', False, 'Managed (lifecycle) node: start unconfigured and consume '
            'only while active (configure, activate, deactivate, cleanup); default: consume '
            'from the start.'))
        LifecycleNodeMixin.__init__(self, enable_communication_interface=self.managed)
        self.consuming = not self.managed
        self._input_specs: list[InputSpec] = []
        self._inputs: list[AdaptiveSubscription] = []
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(Trigger, '~/save', self._on_save)
        self.create_timer(0.5, self._adapt_qos)
        if self.managed:
            self.get_logger().info('managed node: unconfigured; configure and activate it to '
                                   'start consuming.')

    # -- inputs ---------------------------------------------------------------------------
    def set_inputs(self, specs: list[InputSpec]) -> None:
        """Replace the inputs; subscribed at once while consuming."""
        self._close_inputs()
        self._input_specs = list(specs)
        if self.consuming:
            self._open_inputs()

    def _open_inputs(self) -> None:
        self._close_inputs()
        self._inputs = [AdaptiveSubscription(self, s.msg_class, s.topic, s.callback, s.qos,
                                             forced_best_effort=s.forced_best_effort)
                        for s in self._input_specs]

    def _close_inputs(self) -> None:
        for sub in self._inputs:
            sub.destroy()
        self._inputs = []

    def _adapt_qos(self) -> None:
        for sub in self._inputs:
            sub.adapt()

    def input_values(self) -> dict[str, str]:
        """Diagnostics values: the lifecycle state when managed, each input's reliability."""
        out = {'lifecycle': self._state_machine.current_state[1]} if self.managed else {}
        if self.managed and not self.consuming:
            out['inputs'] = 'not consuming (activate the node)'
        for sub in self._inputs:
            out['input ' + sub.topic] = ('reliable' if sub.reliability == RELIABLE
                                         else 'best effort')
        return out

    # -- what subclasses do ---------------------------------------------------------------
    def reset_calibration(self) -> str:
        """Start over (new session, empty state record); one line saying what was dropped."""
        raise NotImplementedError

    def save_calibration(self) -> tuple[bool, str]:
        """Write the hand-off now with what is measured: (written, one line)."""
        raise NotImplementedError

    def consume_now(self) -> None:
        """Hand what the inputs buffered to the calibrator (deactivate, save)."""
        raise NotImplementedError

    # -- services -------------------------------------------------------------------------
    def _on_reset(self, _request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        response.message = self.reset_calibration()
        response.success = True
        self.get_logger().info(f'~/reset: {response.message}')
        return response

    def _on_save(self, _request: Trigger.Request, response: Trigger.Response
                 ) -> Trigger.Response:
        self.consume_now()
        response.success, response.message = self.save_calibration()
        self.get_logger().info(f'~/save: {response.message}')
        return response

    # -- lifecycle (managed mode) ---------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Ready to consume (the session was built from the parameters at start)."""
        self.get_logger().info('configured; activate to start consuming.')
        return SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Subscribe the inputs: consuming from now on."""
        self.consuming = True
        self._open_inputs()
        self.get_logger().info('active: consuming ' + ', '.join(s.topic for s in self._inputs))
        return SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Pause: hand over what arrived, unsubscribe (data published meanwhile is a gap)."""
        self.consume_now()
        self.consuming = False
        self._close_inputs()
        self.get_logger().info('inactive: paused (data published now is a gap).')
        return SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Clear: start over as ``~/reset`` does."""
        self.get_logger().info(f'cleaned up: {self.reset_calibration()}')
        return SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Stop consuming (the hand-off is written when the process ends)."""
        self.consuming = False
        self._close_inputs()
        return SUCCESS
