"""The ROS conventions every calibration node keeps (issue 19 parts 3 and 4).

:class:`CalibrationNodeBase` is the base of :class:`~gyro_calib.nodes.method_node.MethodNode`
and :class:`~gyro_calib.nodes.calibration_node.CalibrationNode`. It gives them:

- inputs that follow their publishers' QoS (:mod:`gyro_calib.nodes.adaptive_qos`), by names
  relative to the node's namespace;
- services (std_srvs/Trigger) ``~/reset`` (start over: a new session, the state directory
  emptied) and ``~/save`` (write the hand-off file now, with what is measured): one
  :meth:`~CalibrationNodeBase.reset_calibration` and one
  :meth:`~CalibrationNodeBase.save_calibration` for every node, the hand-off written by one
  :meth:`~CalibrationNodeBase.write_handoff_record`;
- an opt-in managed (lifecycle) mode, parameter ``managed`` (default false, as
  robot_localization does): the node then starts unconfigured; configure → activate starts
  consuming (the inputs are subscribed), deactivate pauses (what arrived is handed to the
  calibrator, the inputs unsubscribed: data published meanwhile is a gap), cleanup clears (as
  ``~/reset``), shutdown stops consuming. Unmanaged, the node consumes from the start and
  offers no lifecycle services.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import SetParametersResult
from rclpy.lifecycle import LifecycleNodeMixin, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from std_srvs.srv import Trigger

from gyro_calib import topics
from gyro_calib.errors import GyroCalibError
from gyro_calib.handoff import Calibration, merge_lines, update_calibration
from gyro_calib.handoff.load import check_handoff_output
from gyro_calib.nodes.adaptive_qos import RELIABLE, AdaptiveSubscription
from gyro_calib.nodes.ros_io import EXIT_HANDOFF_NOT_WRITTEN, changes_line, described_parameter
from gyro_calib.outputs import os_error_text
from gyro_calib.registry import handoff_schema

if TYPE_CHECKING:
    from gyro_calib.nodes.live_inputs import LiveInputs
    from gyro_calib.nodes.node_state import NodeState
    from gyro_calib.session import Progress

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

    Subclasses give their inputs with :meth:`set_inputs`, set ``_live_inputs``, ``state``,
    ``output_file``, ``gyro_id`` and ``diag_pub``, and implement :meth:`start_over`,
    :meth:`measured_anything`, :meth:`_write_handoff`, :meth:`saved_summary` and
    :meth:`consume_now`; ``~/reset`` and ``~/save`` are the same for all.
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
    _live_inputs: LiveInputs
    """The inputs merged by stamp (set by the subclass before it is spun)."""
    state: NodeState
    """The durable record of the data consumed."""
    output_file: str
    gyro_id: str
    diag_pub: Publisher[DiagnosticArray]
    _last_line = ''
    """The last problem or notice, for the diagnostics."""
    _handoff_missing: set[str] | None = None
    """The keys the hand-off file lacked when last written (None: say its state again)."""
    _merge_told: frozenset[str] = frozenset()
    """The merge lines already logged."""
    _handoff_failure = ''
    """Why the last write of the hand-off file failed ('' = it did not, or none was made)."""
    exit_status = 0
    """The process's exit status once stopped (:func:`~gyro_calib.nodes.ros_io.run_node`):
    :data:`~gyro_calib.nodes.ros_io.EXIT_HANDOFF_NOT_WRITTEN` when the last hand-off write
    failed."""

    def checked_output_file(self, output_file: str) -> str:
        """The ``output_file`` parameter, checked before any work as ``calibrate --out`` is.

        :func:`gyro_calib.handoff.load.check_handoff_output`: not a directory, in an existing
        writable directory, and an existing file must be a hand-off file ('' = no file).

        Raises:
            ConfigError: one line naming ``output_file`` (the node stops: FATAL, exit 2).
        """
        if output_file:
            check_handoff_output(output_file, 'output_file', handoff_schema(),
                                 nothing='Nothing was started.')
        return output_file

    def finish_state(self, *, complete: bool) -> None:
        """End the state record; a hand-off file not written keeps it and fails the run.

        The record is removed when ``complete`` (unless ``keep_state``) only if the last
        write of the hand-off file succeeded; otherwise it is kept, one error line says where
        and what to do, and the node exits with :data:`EXIT_HANDOFF_NOT_WRITTEN`.
        """
        not_written = ''
        if self.output_file and self._handoff_failure:
            self.exit_status = EXIT_HANDOFF_NOT_WRITTEN
            not_written = (f'hand-off file {self.output_file} not written '
                           f'({self._handoff_failure.rstrip(".")})')
        self.state.finish(complete=complete, not_written=not_written)

    def start_over(self) -> str:
        """A new session or calibrator; what was discarded, e.g. '3 measured quantities'."""
        raise NotImplementedError

    def measured_anything(self) -> bool:
        """Whether anything is measured that the hand-off file could hold."""
        raise NotImplementedError

    def _write_handoff(self) -> None:
        """Write whatever is measured (through :meth:`write_handoff_record`)."""
        raise NotImplementedError

    def saved_summary(self) -> tuple[str, Collection[str]]:
        """After a save: what the file was written with (' with …' or ''), the keys missing."""
        raise NotImplementedError

    def consume_now(self) -> None:
        """Hand what the inputs buffered to the calibrator (deactivate, save)."""
        raise NotImplementedError

    # -- reset and save, one for every node -----------------------------------------------
    def reset_calibration(self) -> str:
        """Start over: buffered samples dropped, a new session, the state record emptied."""
        dropped = self._live_inputs.clear()
        discarded = self.start_over()
        self._last_line, self._handoff_missing = '', None
        self.state.reset()
        return (f'new session: {discarded} and {dropped} buffered samples discarded, state '
                'record emptied (the hand-off file is kept).')

    def save_calibration(self) -> tuple[bool, str]:
        """Write the hand-off file now with what is measured: (written, one line)."""
        if not self.output_file:
            return False, "output_file is '': nothing to write to."
        if not self.measured_anything():
            return False, f'nothing measured yet: {self.output_file} not written.'
        self._handoff_missing = None  # say the state of the file once more
        self._write_handoff()
        what, missing = self.saved_summary()
        return True, (f'{self.output_file} written{what}'
                      + (f'; still missing: {", ".join(missing)}' if missing else ' (complete)'))

    def write_handoff_record(self, make: Callable[[], tuple[Calibration, Collection[str]] | None]
                             ) -> None:
        """Merge the record ``make`` gives into ``output_file``.

        Merge the record ``make`` gives (None: nothing to write) into ``output_file``,
        saying once what is still missing (its second item) and each new merge line; a
        refused record or file is logged, not raised.
        """
        if not self.output_file:
            return
        try:
            made = make()
            if made is None:
                return
            record, missing = made
            report: list[str] = []
            path = update_calibration(self.output_file, record, handoff_schema(),
                                      report=report)
        except (GyroCalibError, OSError) as exc:  # e.g. the file replaced, the disk full
            why = os_error_text(exc) if isinstance(exc, OSError) else ' '.join(str(exc).split())
            self._last_line = self._handoff_failure = why
            self.get_logger().error(f'hand-off file not written: {why}')
            return
        self._handoff_failure = ''
        change = changes_line(self._handoff_missing, missing)
        self._handoff_missing = set(missing)
        if change is not None:
            self.get_logger().info(f'calibration written to {path}: {change}')
        for line in merge_lines(report):
            if line not in self._merge_told:
                self.get_logger().info(f'hand-off {line}')
        self._merge_told = frozenset(merge_lines(report))

    def _refuse_runtime_change(self, params: list[Any]) -> SetParametersResult:
        return SetParametersResult(successful=False, reason=(
            'calibration parameters are read at start-up; restart the node to change them.'))

    def take_gyro_id(self, gyro_id: str | None) -> None:
        """Take the gyro id a simulator's bench gives when the parameters give none."""
        if gyro_id and not self.gyro_id:
            self.gyro_id = gyro_id
            self.get_logger().info(f'gyro_id {gyro_id!r} taken from {topics.SIM_SCENARIO} '
                                   '(parameter gyro_id not given).')

    def publish_status(self, name: str, values: dict[str, str], progress: Progress) -> None:
        """Publish one DiagnosticStatus: ``values``, the progress's needs and problems, inputs."""
        for key, need in progress.needs.items():
            values['needs: ' + key] = need
        for i, problem in enumerate(progress.problems):
            values[f'problem {i + 1}'] = problem
        values.update(self.input_values())
        status = DiagnosticStatus(
            name=name, hardware_id=self.gyro_id or 'gyro',
            message=progress.message, level=LEVELS[progress.level],
            values=[KeyValue(key=k, value=v) for k, v in values.items()])
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        self.diag_pub.publish(array)

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
