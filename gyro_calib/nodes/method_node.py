"""The live node of any registered method.

The live node of any registered method: topic contract in, results, diagnostics and the
hand-off file out, through the same session the bag calibration uses.

Messages are buffered per topic as they arrive (stamp, values, frame_id) and handed to the
session as one :class:`~gyro_calib.bagio.SampleBatch` every ``process_period_s``; the
calibrators give the same result however the data are chunked, so a bag replayed into the
node gives bit for bit the numbers ``gyro-calib calibrate`` gives offline.

A method's node module is a few lines: :func:`run_method_node` with the method name, the
node name and the results to publish on their own topics (std_msgs/Float64,
transient-local). Parameters: every field of the method's settings dataclass (as for
``--config``), plus ``config_file``, ``output_file``, ``gyro_id``, ``latitude_deg``,
``heading_deg``, ``scale_factor_rad_per_pulse`` and ``process_period_s``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Collection, Mapping
from pathlib import Path
from typing import Any

import yaml
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from std_msgs.msg import Float64, String

from gyro_calib import topics
from gyro_calib.bagio import SampleBatch
from gyro_calib.bagio.columns import TopicColumns
from gyro_calib.config import BENCH_SETTINGS, config_file_notes, given, read_method_file
from gyro_calib.errors import GyroCalibError
from gyro_calib.handoff import Calibration
from gyro_calib.nodes.conventions import CalibrationNodeBase, InputSpec
from gyro_calib.nodes.live_inputs import MESSAGE_CLASSES, LiveInputs, TopicBuffer
from gyro_calib.nodes.node_state import (
    BENCH_MAX_RATE_DESCRIPTION,
    RESUME_DESCRIPTION,
    RESUME_MAX_GAP_DESCRIPTION,
    NodeState,
    calibration_complete,
    resume_max_gap_s,
    state_directory,
)
from gyro_calib.nodes.ros_io import (
    EVENT_QOS,
    RESULT_QOS,
    SCENARIO_READER_QOS,
    SENSOR_QOS,
    declare_dataclass_parameters,
    described_parameter,
    run_node,
)
from gyro_calib.registry import (
    HEADER,
    METHODS,
)
from gyro_calib.session import CalibrationOptions, MethodSession
from gyro_calib.topics import relative
from gyro_calib.units import format_stamp

GENERIC_PARAMETERS = ('config_file', 'output_file', 'gyro_id', 'latitude_deg', 'heading_deg',
                      'scale_factor_rad_per_pulse', 'process_period_s', 'state_dir',
                      'keep_state', 'resume', 'resume_max_gap_s', 'bench_max_rate_deg_s')
"""Parameters every method node declares (a settings field of the same name is not
declared twice: the session takes it from the options)."""


class MethodNode(CalibrationNodeBase):
    """Feeds a method's session from the topic contract; publishes what it measures."""

    def __init__(self, method: str, node_name: str, result_topics: Mapping[str, str],
                 settings_cls: type | None = None,
                 extra_parameters: tuple[tuple[str, Any, str], ...] = ()) -> None:
        """Declare parameters, build the session, wire topics and timers.

        Args:
            method: registry name of the method.
            node_name: the ROS node name.
            result_topics: hand-off key → topic its value is published on (Float64).
            settings_cls: the method's settings dataclass, declared as parameters.
            extra_parameters: a subclass's own (name, default, description), declared with
                the others (before the state record, which refuses a misspelt parameter);
                their values in ``self.extra_parameters``.
        """
        super().__init__(node_name)
        self.method = METHODS[method]
        settings: dict[str, Any] = {} if settings_cls is None else declare_dataclass_parameters(
            self, settings_cls, skip=GENERIC_PARAMETERS)  # those: declared once below, taken
        #                                                   by the session from the options
        p = {name: described_parameter(self, name, default, text) for name, default, text in (
            ('config_file', '', 'YAML file with the settings; its values win over parameters.'),
            ('output_file', '', 'INS hand-off YAML, updated atomically whenever the results '
             "change; other methods' keys in it are kept ('' = do not write)."),
            ('gyro_id', '', BENCH_SETTINGS['gyro_id'].description),
            ('latitude_deg', math.nan, BENCH_SETTINGS['latitude_deg'].description),
            ('heading_deg', 0.0, BENCH_SETTINGS['heading_deg'].description),
            ('scale_factor_rad_per_pulse', math.nan,
             BENCH_SETTINGS['scale_factor_rad_per_pulse'].description + ' NaN: not given.'),
            ('process_period_s', 0.2, 'How often buffered samples are handed to the '
             'calibrator, s (results do not depend on it).'),
            ('state_dir', '', "Durable record of the data consumed, replayed on restart "
             "after a crash ('' = beside output_file as <output_file>.state; no "
             'output_file and no state_dir = no record).'),
            ('keep_state', False, 'Keep the state directory after a completed calibration '
             '(default: removed once nothing is missing).'),
            ('resume', True, RESUME_DESCRIPTION),
            ('resume_max_gap_s', math.nan, RESUME_MAX_GAP_DESCRIPTION),
            ('bench_max_rate_deg_s', math.nan, BENCH_MAX_RATE_DESCRIPTION))}
        self.extra_parameters: dict[str, Any] = {
            name: described_parameter(self, name, default, text)
            for name, default, text in extra_parameters}
        options = CalibrationOptions(
            latitude_deg=None if math.isnan(p['latitude_deg']) else p['latitude_deg'],
            heading_deg=p['heading_deg'],
            config_file=Path(p['config_file']) if p['config_file'] else None,
            scale_factor_rad_per_pulse=(None if math.isnan(p['scale_factor_rad_per_pulse'])
                                        else p['scale_factor_rad_per_pulse']),
            gyro_id=p['gyro_id'], settings=settings, given_by='parameter')
        if options.config_file is not None and self.method.node:
            config_file = options.config_file
            _, bench = read_method_file(config_file, node_name=self.method.node,
                                        fields=self.method.settings_defaults())
            options = dataclasses.replace(options, config_bench=bench)
            for line in config_file_notes(config_file, node_name=self.method.node,
                                          fields=self.method.settings_defaults()):
                self.get_logger().warning(line)  # NaN / inf taken as its default, said
        self.options = options
        self.output_file = self.checked_output_file(p['output_file'])
        self.gyro_id = p['gyro_id']
        self.state = NodeState(self, method, p['gyro_id'],
                               state_directory(p['state_dir'], p['output_file']),
                               bool(p['keep_state']), parameters={**settings, **p},
                               resume=bool(p['resume']),
                               max_gap_s=resume_max_gap_s(float(p['resume_max_gap_s']),
                                                          settings),
                               bench_max_rate_deg_s=float(p['bench_max_rate_deg_s']))
        self.session: MethodSession = self.method.make_session(options)
        self.session.live = True
        self.add_on_set_parameters_callback(self._refuse_runtime_change)
        self._buffers: dict[str, TopicBuffer] = {}
        self._inputs_as_given: tuple[str, ...] = ()
        self._subscribe_inputs()
        # relative names: '-r __ns:=/bench2' moves inputs, results and diagnostics together
        self._result_pubs = {key: self.create_publisher(Float64, relative(topic), RESULT_QOS)
                             for key, topic in result_topics.items()}
        self.diag_pub = self.create_publisher(DiagnosticArray, relative(topics.DIAGNOSTICS), 10)
        self._published: dict[str, float] = {}
        self._fed = False
        self.scenario = SimScenarioBench(self, self.method.bench_settings, self._on_bench,
                                         self.state.commanded)
        self.create_timer(float(p['process_period_s']), self._inputs_busy(self._process))
        self.create_timer(1.0, self._publish_diagnostics)
        self._announce_inputs()

    def _announce_inputs(self) -> None:
        """Say which topics the node waits for.

        Say which topics the node waits for (a subclass that rewires its inputs says it
        after rewiring).
        """
        self.get_logger().info(f'{self.method.name}: waiting for {", ".join(self._buffers)}')

    def _on_bench(self, stored: tuple[tuple[str, Mapping[str, Any]], ...]) -> None:
        """A simulator published its bench: report conflicts, unset settings, the gyro id.

        The published bench never changes the session: when it arrives (before or after
        the first samples) is a matter of timing, and the numbers depend only on the data
        and the parameters (stamps, not wall clocks). The gyro id (the hand-off identity)
        is taken when the parameters give none.
        """
        options = dataclasses.replace(self.options, stored_benches=stored)
        gyro_id = self.scenario.check(options)
        if gyro_id is None:
            return
        self.scenario.tell_unset(options)
        self.take_gyro_id(gyro_id)

    def _subscribe_inputs(self, *, best_effort: tuple[str, ...] = (),
                          as_given: tuple[str, ...] = ()) -> None:
        """Subscribe the session's topics.

        Subscribe the session's topics, each into its buffer and adapting to its
        publishers' QoS (those of ``best_effort`` always best effort); by their names
        relative to the node's namespace, except those of ``as_given`` (a user's topic).
        """
        self._live_inputs = LiveInputs(self.session.topics())
        self._buffers, specs = self._live_inputs.buffers, []
        self._inputs_as_given = as_given
        for topic, msgtype in self.session.topics().items():
            buf = self._buffers[topic]
            specs.append(InputSpec(MESSAGE_CLASSES[msgtype],
                                   topic if topic in as_given else relative(topic), buf.add,
                                   EVENT_QOS if msgtype == HEADER else SENSOR_QOS,
                                   topic in best_effort))
        self.set_inputs(specs)

    def _inputs_busy(self, fn: Callable[[], None]) -> Callable[[], None]:
        """``fn`` timed off the input merge's clock (the merge may be replaced: looked up)."""
        def run() -> None:
            self._live_inputs.busy(fn)()
        return run

    def new_session(self) -> MethodSession:
        """A fresh session with the node's options (``~/reset``, cleanup)."""
        session = self.method.make_session(self.options)
        session.live = True
        return session

    def session_finished(self) -> bool:
        """The session ended the run by itself (:meth:`MethodSession.finished`)."""
        return bool(self.session.finished())

    def start_over(self) -> str:
        """A new session (``~/reset``, cleanup); how many quantities were measured."""
        measured = len(self.session.results())
        self.session = self.new_session()
        self._published = {}
        return f'{measured} measured quantities'

    def consume_now(self) -> None:
        """Hand the buffered samples to the session and do what they allow."""
        self._process()

    def measured_anything(self) -> bool:
        """Whether the session has a hand-off record (something measured)."""
        return self.session.handoff('live', gyro_id=self.gyro_id) is not None

    def saved_summary(self) -> tuple[str, Collection[str]]:
        """' with N measured quantities' and the keys the record misses."""
        record = self.session.handoff('live', gyro_id=self.gyro_id)
        return (f' with {len(self.session.results())} measured quantities',
                record.missing if record is not None else ())

    def _take_inputs(self, *, flush: bool = False) -> dict[str, TopicColumns]:
        """The samples the stamp merge released, per topic; a line for any that came late.

        A late sample (its reader lagged more than :data:`INPUT_HOLD_S`) is handed over as
        out-of-order data and the session told (:meth:`MethodSession.late_input`), which
        rejects the window that needs it or says what it could not check.
        """
        columns, late = self._live_inputs.take(flush=flush)
        if late:
            for line in self.session.late_input(late):
                self._last_line = line
                self.get_logger().warning(line)
        return columns

    def _feed(self, columns: dict[str, TopicColumns]) -> None:
        """Record the batch (state directory), then hand it to the session."""
        if not columns:
            return
        self.state.record_batch(columns)
        last = max(int(c.stamp_ns.max()) for c in columns.values())
        self._session_feed(SampleBatch(columns, sum(len(c) for c in columns.values()), last))

    def _session_feed(self, batch: SampleBatch) -> None:
        self._fed = True  # the session has data now: a bench published later only informs
        self.session.feed(batch)

    def _process(self) -> None:
        self.state.resume_once(self._session_feed, self.session.process)
        self._feed(self._take_inputs())
        lines = self.session.process()
        for line in lines:
            self._last_line = line
            self.get_logger().warning(line) if 'reject' in line else self.get_logger().info(line)
        results = self.session.results()
        changed = {k: e.value for k, e in results.items() if self._published.get(k) != e.value}
        if not changed:
            return
        self._published.update(changed)
        for key, value in changed.items():
            pub = self._result_pubs.get(key)
            if pub is not None:
                pub.publish(Float64(data=float(value)))
            est = results[key]
            self.get_logger().info(f'{key} = {est.value!r} ± {est.std_uncertainty:.3g} '
                                   f'(from {est.n_used})')
        self._write_handoff()
        self._publish_diagnostics()

    def finish(self) -> None:
        """End of the data: judge what is open, write the hand-off file.

        End of the data (shutdown): judge what is still open, write the hand-off file;
        the state directory is removed when nothing is missing (unless ``keep_state``).
        """
        self.state.resume_once(self._session_feed, self.session.process)
        self._feed(self._take_inputs(flush=True))
        for line in self.session.process(flush=True):
            self.get_logger().info(line)
        self._write_handoff()
        self.finish_state(complete=calibration_complete(self.session.missing(),
                                                        self.session.not_measurable()))

    def _write_handoff(self) -> None:
        def record() -> tuple[Calibration, Collection[str]] | None:
            made = self.session.handoff('live', gyro_id=self.gyro_id)
            return None if made is None else (made, made.missing)
        self.write_handoff_record(record)

    def _publish_diagnostics(self) -> None:
        results = self.session.results()
        values = {'rejected': str(len(self.session.rejections())), 'last_line': self._last_line}
        for key, est in results.items():
            values[key] = repr(float(est.value))
            values[key + '_std'] = repr(float(est.std_uncertainty))
            values[key + '_n'] = str(est.n_used)
        for key, why in self.session.missing().items():
            values[key + '_missing'] = why
        rejections = self.session.rejections()
        if rejections:
            r = rejections[-1]
            values['last_rejection'] = f'{format_stamp(r.stamp_ns)}: {r.reason}'
        self.publish_status(f'gyro_calib: {self.method.name}', values,
                            self.session.progress())


class SimScenarioBench:
    """The bench settings simulators publish on /sim/scenario.

    The bench settings simulators publish on /sim/scenario (YAML with a ``bench``
    mapping, transient-local), for a method node that also has them as parameters.

    Each part's bench is passed to ``on_bench`` as the stored benches of
    :class:`~gyro_calib.session.CalibrationOptions`; :meth:`check` logs (once each) the
    parameters that differ from it, and returns the gyro id the bench resolves to.
    """

    def __init__(self, node: Node, names: tuple[str, ...],
                 on_bench: Callable[[tuple[tuple[str, Mapping[str, Any]], ...]], None],
                 on_scenario: Callable[[Mapping[str, Any]], None] | None = None) -> None:
        """Listen on ``names`` for ``node``; ``on_bench`` gets the benches.

        ``on_scenario`` gets each simulator's whole scenario (its commanded procedure: the
        tables' rates bound how far a resumed record's angles and counts may move).
        """
        self.node, self.names, self.on_bench = node, names, on_bench
        self.on_scenario = on_scenario
        self.benches: dict[str, Mapping[str, Any]] = {}
        self.told: set[str] = set()
        node.create_subscription(String, relative(topics.SIM_SCENARIO), self._on_message,
                                 SCENARIO_READER_QOS)

    def _on_message(self, msg: String) -> None:
        try:
            part = yaml.safe_load(msg.data)
        except yaml.YAMLError:
            return
        if isinstance(part, dict) and self.on_scenario is not None:
            self.on_scenario(part)
        if not isinstance(part, dict) or not isinstance(part.get('bench'), dict):
            return
        where = f'{topics.SIM_SCENARIO} ({part.get("name", "simulator")})'
        self.benches[where] = dict(part['bench'])
        self.on_bench(tuple(self.benches.items()))

    def check(self, options: CalibrationOptions) -> str | None:
        """Log conflicts with the published bench; return the gyro id.

        Log each conflict between the node's parameters and the published bench once;
        the gyro id (None when the published benches disagree among themselves).
        """
        try:
            lines = options.conflicts(self.names)
            gyro_id = str(options.setting('gyro_id', '') or '')
        except GyroCalibError as exc:
            line = f'{topics.SIM_SCENARIO}: {exc}'
            if line not in self.told:
                self.told.add(line)
                self.node.get_logger().error(line)
            return None
        for line in lines:
            if line not in self.told:
                self.told.add(line)
                self.node.get_logger().warning(f'bench conflict: {line}')
        return gyro_id

    def tell_unset(self, options: CalibrationOptions) -> None:
        """Log the published bench settings left unset; none is taken.

        Log once each bench setting the parameters left unset that the published bench
        gives: it is not taken (the numbers must not depend on when it arrived).
        """
        for name in self.names:
            if name == 'gyro_id':
                continue
            value, origin = options.setting_with_origin(name)
            if not origin.startswith('the bench settings') or not given(value):
                continue
            how = (f'pass -p {name}:={value!r}' if self.node.has_parameter(name) else
                   f'set {name}: {value!r} under {self.node.get_name()}: ros__parameters: '
                   'in the config_file')  # not a parameter of this node: -p is ignored
            line = (f'{topics.SIM_SCENARIO} gives {name} = {value!r}, which the parameters '
                    f'leave unset; not taken (results depend only on the data and the '
                    f'parameters): {how} to use it.')
            if line not in self.told:
                self.told.add(line)
                self.node.get_logger().warning(line)


def run_method_node(method: str, node_name: str, result_topics: Mapping[str, str],
                    settings_cls: type | None = None, args: list[str] | None = None) -> None:
    """Run a method's node until SIGINT/SIGTERM or the session finished by itself.

    Then judge what is open and write the hand-off (exit 0 either way).
    """
    run_node(node_name, lambda: MethodNode(method, node_name, result_topics, settings_cls), args,
             on_stop=lambda node, _executor: node.finish(), done=MethodNode.session_finished)
