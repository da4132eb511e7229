"""calibration_node: K̃, θ and K of a rate-biased RLG, live from the topic contract.

Subscribes /gyro/pulses and the joint_states and zero_index of the rate table and
(for θ) the position table, feeds the core
:class:`~gyro_calib.rbrlg.calibration.RbrlgCalibrator` by stamp, and publishes
/gyro_calib/k_tilde, /gyro_calib/fix_error_angle, /gyro_calib/scale_factor
(transient-local) and /diagnostics. Parameters: every field of
:class:`~gyro_calib.rbrlg.config.KTildeConfig`, ``config_file`` (YAML; plain mapping or
ROS 2 parameter file) whose values win, ``position_table_revolutions`` (n),
``latitude_deg`` and ``heading_deg`` (site, for the bias; NaN = not given).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Collection, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from diagnostic_msgs.msg import DiagnosticArray
from std_msgs.msg import Float64

from gyro_calib import topics
from gyro_calib.bagio import SampleBatch
from gyro_calib.bagio.columns import TopicColumns
from gyro_calib.config import (
    BENCH_SETTINGS,
    config_file_notes,
    field_defaults,
    given,
    read_method_file,
)
from gyro_calib.errors import InsufficientDataError
from gyro_calib.handoff import Provenance, method_calibration
from gyro_calib.nodes.conventions import CalibrationNodeBase, InputSpec
from gyro_calib.nodes.live_inputs import MESSAGE_CLASSES, LiveInputs
from gyro_calib.nodes.method_node import SimScenarioBench
from gyro_calib.nodes.node_state import (
    BENCH_MAX_RATE_DESCRIPTION,
    RESUME_DESCRIPTION,
    RESUME_MAX_GAP_DESCRIPTION,
    NodeState,
    calibration_complete,
    feed_columns,
    resume_max_gap_s,
    state_directory,
)
from gyro_calib.nodes.ros_io import (
    EVENT_QOS,
    RESULT_QOS,
    SENSOR_QOS,
    declare_dataclass_parameters,
    described_parameter,
    run_node,
)
from gyro_calib.rbrlg.calibration import RbrlgCalibrator, handoff_values
from gyro_calib.rbrlg.calibrator import CalibrationUpdate
from gyro_calib.rbrlg.config import KTildeConfig, k_tilde_config_from_mapping
from gyro_calib.rbrlg.diagnostics import calibration_status
from gyro_calib.rbrlg.session import TOPICS as RBRLG_TOPICS
from gyro_calib.rbrlg.session import RbrlgSession, feed_calibrator, prior_k_tilde
from gyro_calib.rbrlg.stations import Station
from gyro_calib.registry import HEADER, METHODS, handoff_schema
from gyro_calib.session import CalibrationOptions
from gyro_calib.streams import late_summary
from gyro_calib.topics import relative
from gyro_calib.units import ARCSEC_PER_RAD, RAD_PER_ARCSEC

if TYPE_CHECKING:
    pass


class CalibrationNode(CalibrationNodeBase):
    """Translates the topic contract to core calls and results to topics and logs."""

    def __init__(self) -> None:
        """Declare parameters, build the calibrator, wire topics."""
        super().__init__('calibration_node')
        values = declare_dataclass_parameters(self, KTildeConfig)
        path = described_parameter(
            self, 'config_file', '',
            'YAML file with calibration settings; its values override parameters.')
        file_bench: dict[str, object] = {}
        if path:  # the node's whole parameter schema (bench settings too), as --config
            file_values, file_bench = read_method_file(
                path, node_name='calibration_node', fields=field_defaults(KTildeConfig))
            self.config = k_tilde_config_from_mapping(file_values, source=path)
            for line in config_file_notes(path, node_name='calibration_node',
                                          fields=field_defaults(KTildeConfig)):
                self.get_logger().warning(line)  # NaN / inf taken as its default, said
        else:
            self.config = k_tilde_config_from_mapping(values, source='ROS parameters')
        site = {name: described_parameter(self, name, default, text)
                for name, default, text in (
            ('position_table_revolutions', 1,
             BENCH_SETTINGS['position_table_revolutions'].description),
            ('latitude_deg', float('nan'), BENCH_SETTINGS['latitude_deg'].description),
            ('heading_deg', 0.0, BENCH_SETTINGS['heading_deg'].description),
            ('nominal_tilt_deg', 45.0, 'Nominal tilt α of the rate table on the position '
             'table, °.'),
            ('tilt_tolerance_deg', 5.0, 'Largest |fitted α − nominal| before θ is refused, °.'),
            ('output_file', 'gyro_calibration.yaml', 'INS hand-off YAML, rewritten atomically '
             'with whatever is measured whenever K̃ or θ changes; other methods\' keys in it '
             'are kept ("" = do not write).'),
            ('gyro_id', '', BENCH_SETTINGS['gyro_id'].description),
            ('state_dir', '', "Durable record of the data consumed, replayed on restart after "
             "a crash ('' = beside output_file as <output_file>.state)."),
            ('keep_state', False, 'Keep the state directory after a completed calibration.'),
            ('resume', True, RESUME_DESCRIPTION),
            ('resume_max_gap_s', math.nan, RESUME_MAX_GAP_DESCRIPTION),
            ('bench_max_rate_deg_s', math.nan, BENCH_MAX_RATE_DESCRIPTION),
            ('calibration_file', '', "Hand-off file whose K̃ gives θ and K when this run has "
             "no K̃ phase (this run's own K̃, once measured, is used instead; '' = none)."))}
        self.output_file = self.checked_output_file(str(site.pop('output_file')))
        self.gyro_id = str(site.pop('gyro_id'))
        calibration_file = str(site.pop('calibration_file'))
        prior, prior_source = (prior_k_tilde(Path(calibration_file)) if calibration_file
                               else (None, ''))
        options = CalibrationOptions(  # the one range check of every bench setting
            latitude_deg=None if math.isnan(site['latitude_deg']) else site['latitude_deg'],
            heading_deg=site['heading_deg'],
            position_table_revolutions=site['position_table_revolutions'],
            gyro_id=self.gyro_id, config_file=Path(path) if path else None,
            config_bench=file_bench, given_by='parameter')
        site['latitude_deg'] = options.latitude
        site['heading_deg'] = options.setting('heading_deg', 0.0)
        site['position_table_revolutions'] = options.setting('position_table_revolutions', 1)
        self.gyro_id = str(options.setting('gyro_id', ''))
        self.options = options
        self.add_on_set_parameters_callback(self._refuse_runtime_change)
        bench_args = (self.config, int(site['position_table_revolutions']),
                      float(site['latitude_deg']), float(site['heading_deg']),
                      float(site['nominal_tilt_deg']), float(site['tilt_tolerance_deg']))
        self._new_bench: Callable[[], RbrlgCalibrator] = lambda: RbrlgCalibrator(
            *bench_args, prior_k_tilde=prior, prior_k_tilde_source=prior_source)
        if prior is not None:
            self.get_logger().info(f'K̃ for θ until this run measures its own: {prior.value:.10f} '
                                   f'″/pulse ± {prior.std_uncertainty:.3g} from {prior_source}')
        self.bench = self._new_bench()
        self.calibrator = self.bench.k_tilde
        self._station_rejections_seen = 0
        self._live_inputs = LiveInputs(RBRLG_TOPICS)  # merged by stamp (WatermarkMerge)
        self._buffers, specs = self._live_inputs.buffers, []
        for topic, msgtype in RBRLG_TOPICS.items():
            buf = self._buffers[topic]
            specs.append(InputSpec(MESSAGE_CLASSES[msgtype], relative(topic), buf.add,
                                   EVENT_QOS if msgtype == HEADER else SENSOR_QOS))
        self.set_inputs(specs)
        self.state = NodeState(self, 'rbrlg', self.gyro_id,
                               state_directory(str(site.pop('state_dir')), self.output_file),
                               bool(site.pop('keep_state')),
                               parameters={**values, **site, 'config_file': path},
                               resume=bool(site.pop('resume')),
                               max_gap_s=resume_max_gap_s(float(site.pop('resume_max_gap_s')),
                                                          dataclasses.asdict(self.config)),
                               bench_max_rate_deg_s=float(site.pop('bench_max_rate_deg_s')))
        # relative names: '-r __ns:=/bench2' moves inputs, results and diagnostics together
        pub = self.create_publisher
        self.k_tilde_pub = pub(Float64, relative(topics.K_TILDE), RESULT_QOS)
        self.theta_pub = pub(Float64, relative(topics.FIX_ERROR_ANGLE), RESULT_QOS)
        self.k_pub = pub(Float64, relative(topics.SCALE_FACTOR), RESULT_QOS)
        self.diag_pub = pub(DiagnosticArray, relative(topics.DIAGNOSTICS), 10)
        self.scenario = SimScenarioBench(self, METHODS['rbrlg'].bench_settings, self._on_bench,
                                         self.state.commanded)
        self.create_timer(0.2, self._live_inputs.busy(self._process))
        self.create_timer(1.0, self._publish_diagnostics)
        self.get_logger().info(
            f'calibrating K̃ over m = {self.config.revolutions_per_window} revolution windows; '
            f'waiting for {topics.GYRO_PULSES}, {topics.RATE_TABLE_JOINT_STATES}, '
            f'{topics.RATE_TABLE_ZERO_INDEX}')

    def _on_bench(self, stored: tuple[tuple[str, Mapping[str, Any]], ...]) -> None:
        """A simulator published its bench: report parameters that differ, take its gyro id."""
        self.take_gyro_id(self.scenario.check(
            dataclasses.replace(self.options, stored_benches=stored)))

    def start_over(self) -> str:
        """A new calibrator (``~/reset``, cleanup); the window pairs and stations it had."""
        pairs, stations = len(self.bench.k_tilde.pairs), len(self.bench.stations.stations)
        self.bench = self._new_bench()
        self.calibrator = self.bench.k_tilde
        self._station_rejections_seen = 0
        return f'{pairs} window pair(s), {stations} station(s)'

    def consume_now(self) -> None:
        """Hand the buffered samples to the calibrator and do what they allow."""
        self._process()

    def measured_anything(self) -> bool:
        """Whether K̃ (at least) is measured, over a known data span."""
        values = handoff_values(self.bench.results(), self.bench)
        return bool(values) and self.bench.data_span_ns() is not None

    def saved_summary(self) -> tuple[str, Collection[str]]:
        """Nothing to add to 'written'; the keys still missing."""
        return '', self.bench.missing()

    def _feed(self, columns: dict[str, TopicColumns]) -> None:
        """Record a batch, then hand it to the calibrator.

        Record a batch (state directory), then hand it to the calibrator as the offline
        session does (:meth:`gyro_calib.rbrlg.session.RbrlgSession.feed`).
        """
        if not columns:
            return
        self.state.record_batch(columns)
        feed_columns(self._extend, columns)

    def _take_inputs(self) -> dict[str, TopicColumns]:
        """The samples the stamp merge released, per topic; a line for any that came late."""
        columns, late = self._live_inputs.take()
        if late:
            line = (f'{late_summary(late)} arrived after later stamps had been calibrated (the '
                    'reader lagged more than the input hold): taken as out-of-order data; the '
                    'windows around them may differ from the offline numbers of a recording '
                    '— replay slower or give the node more CPU.')
            self._last_line = line
            self.get_logger().warning(line)
        return columns

    def _extend(self, batch: SampleBatch) -> None:
        feed_calibrator(self.bench, batch)

    def _replay_process(self) -> list[str]:
        self._consume(*self.bench.process())
        return []

    def _process(self) -> None:
        self.state.resume_once(self._extend, self._replay_process)
        self._feed(self._take_inputs())
        self._consume(*self.bench.process())

    def finish(self) -> None:
        """Shutdown: take in what is buffered, write the hand-off.

        Shutdown: take in what is buffered, write the hand-off; the state directory is
        removed once θ, K and the bias are all measured (unless ``keep_state``).
        """
        self._live_inputs.ended = True  # everything held, in stamp order
        self._process()
        self._publish_results()
        self.finish_state(complete=calibration_complete(self.bench.missing(),
                                                        self.bench.not_measurable()))

    def _consume(self, update: CalibrationUpdate, stations: list[Station]) -> None:
        self._report(update)
        if stations:
            self._report_stations(stations)

    def _report_stations(self, stations: list[Station]) -> None:
        log = self.get_logger()
        for rejection in self.bench.stations.rejections[self._station_rejections_seen:]:
            self._last_line = rejection.reason
            log.warning(f'skipped: {rejection.reason}')
        self._station_rejections_seen = len(self.bench.stations.rejections)
        for st in stations:
            log.info(f'station accepted: β = {math.degrees(st.rate_table_angle_rad):.4f}°, '
                     f'N_og = {st.half_difference_pulses:.3f} ± '
                     f'{st.half_difference_std_pulses:.3f} pulses')
        self._publish_results()

    def _report(self, update: CalibrationUpdate) -> None:
        log = self.get_logger()
        for notice in update.notices:
            log.warning(notice)
        for rejection in update.rejections:
            self._last_line = rejection.reason
            log.warning(f'skipped: {rejection.reason}')
        for w in update.windows:
            log.info(f'window accepted: {"+" if w.direction > 0 else "-"}{w.revolutions} rev, '
                     f'N = {w.pulses:.3f} ± {w.pulses_std:.3f} pulses over {w.duration_s:.3f} s')
        if not update.pairs:
            return
        try:
            k = self.calibrator.k_tilde()
        except InsufficientDataError:
            return
        self.k_tilde_pub.publish(Float64(data=k.value * RAD_PER_ARCSEC))
        log.info(f'K̃ = {k.value:.10f} ″/pulse ± {k.relative_uncertainty * 1e6:.4f} ppm '
                 f'({k.n_used} pairs)')
        self._publish_results()

    def _publish_results(self) -> None:
        """θ and K once both phases gave them (or why not); the hand-off; the diagnostics."""
        res = self.bench.results()
        if res.fix_error_problem and res.fix_error_problem != self._last_line:
            self._last_line = res.fix_error_problem
            self.get_logger().warning(res.fix_error_problem)
        if res.fix_error is not None and res.scale_factor_arcsec_per_pulse is not None:
            theta, k = res.fix_error.fix_error_angle_rad, res.scale_factor_arcsec_per_pulse
            self.theta_pub.publish(Float64(data=theta.value))
            self.k_pub.publish(Float64(data=k.value * RAD_PER_ARCSEC))
            self.get_logger().info(
                f'θ = {theta.value * ARCSEC_PER_RAD:.3f}″ ± '
                f'{theta.std_uncertainty * ARCSEC_PER_RAD:.3f}″ ({theta.n_used} stations); '
                f'K = {k.value:.10f} ″/pulse ± {k.relative_uncertainty * 1e6:.4f} ppm')
        self._write_handoff()
        self._publish_diagnostics()

    def _write_handoff(self) -> None:
        """Write whatever is measured (from K̃ on), saying once what is still missing."""
        values = handoff_values(self.bench.results(), self.bench)
        span = self.bench.data_span_ns()
        if not values or span is None:
            return
        cannot = self.bench.not_measurable()
        missing = {k: v for k, v in self.bench.missing().items() if k not in cannot}
        conditions = {k: v for k, v in self.bench.conditions().items() if given(v)}
        self.write_handoff_record(lambda: (method_calibration('rbrlg', values, Provenance(
            'live', span[0], span[1], missing, conditions=conditions, not_measurable=cannot),
            gyro_id=self.gyro_id, schema=handoff_schema()), missing))

    def _publish_diagnostics(self) -> None:
        _, _, values = calibration_status(self.bench, self._last_line)
        self.publish_status('gyro_calib: k_tilde', values,
                            RbrlgSession.around(self.bench).progress())


def main(args: list[str] | None = None) -> None:
    """Run the calibration node until SIGINT/SIGTERM."""
    run_node('calibration_node', CalibrationNode, args,
             on_stop=lambda node, _executor: node.finish())


if __name__ == '__main__':
    main()
