"""noise_node: Allan deviation and IEEE Std 952 noise terms of a live gyro or IMU (METHODS §E).

The live twin of ``gyro-calib noise``: the same session (:class:`~gyro_calib.noise.session.
NoiseSession`) fed from DDS instead of a bag, so a bag replayed into the node gives bit for
bit the numbers the command gives offline.

Input: the ``sensor_msgs/Imu`` topic named by ``topic`` (all six axes), or with ``topic``
empty ``/gyro/pulses`` (K from ``scale_factor_rad_per_pulse`` or ``calibration_file``) or
``/fog/output`` (``fog_scale_factor_counts_per_rad`` or ``calibration_file``); and
``/rate_table/joint_states`` and ``/position_table/joint_states`` when published: the
samples taken while the rate table changed rate (or the position table turned) are left out,
each steady span analysed as a segment (:mod:`gyro_calib.noise.table`).

Output: every ``results_period_s`` (wall clock; the numbers do not depend on it) the running
terms — the record so far analysed as if it ended now — on ``/diagnostics`` (status
``gyro_calib: noise``: each hand-off key with ``_std``, ``_n``, and ``_missing`` reasons;
per-axis keys ``imu_gyro_x_…`` for an IMU) and in ``output_file``. On shutdown (Ctrl-C,
SIGINT, SIGTERM) it takes in what its readers already hold, ends the record and writes
``kalibr_file`` (Kalibr ``imu.yaml``, IMU only), ``plot_file`` (ADEV figure) and
``output_file`` (hand-off): each complete (written beside and renamed) or, on an error, not
touched; the paths are logged. An existing ``kalibr_file`` is replaced only when it is a
Kalibr imu.yaml gyro_calib wrote (``noise --kalibr``, ``export --format kalibr``): any other
file there (a user's VIO config, a hand-off, a bag) stops the node at start-up, exit 2.

Parameters: ``topic``, ``calibration_file``, ``best_effort``, ``results_period_s``,
``kalibr_file``, ``plot_file``; every field of :class:`~gyro_calib.noise.settings.
NoiseSettings`; the common ones of :mod:`gyro_calib.nodes.method_node` (``output_file``,
``gyro_id``, ``config_file``, ``scale_factor_rad_per_pulse``, ``process_period_s``).

    noise_node --ros-args -p topic:=/imu/data -p kalibr_file:=imu.yaml -p plot_file:=adev.png
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any

from gyro_calib.errors import ConfigError, GyroCalibError
from gyro_calib.export.ownership import (
    refuse_to_overwrite_records,
    refuse_to_replace_a_foreign_file,
)
from gyro_calib.nodes.method_node import GENERIC_PARAMETERS, MethodNode
from gyro_calib.nodes.ros_io import run_node, spin_until_quiet
from gyro_calib.noise.kalibr import KALIBR_MARK
from gyro_calib.noise.keys import METHOD
from gyro_calib.noise.outputs import resolve_targets, write_outputs, written_line
from gyro_calib.noise.session import IMU, NoiseSession, check_scale_factor
from gyro_calib.noise.settings import NoiseSettings
from gyro_calib.registry import handoff_schema
from gyro_calib.session import CalibrationOptions

NODE_NAME = 'noise_node'


class NoiseNode(MethodNode):
    """A :class:`MethodNode` of the noise method, with its own input wiring and shutdown files.

    The generic node builds its session from the common parameters before this class can
    declare ``topic`` and ``calibration_file``; the session is therefore rebuilt here and
    the subscriptions re-wired to its topics.
    """

    session: NoiseSession

    def __init__(self) -> None:
        """Declare the parameters, build the session, subscribe, start the refresh timer.

        Raises:
            ConfigError: a pulse/FOG input without a scale factor, Kalibr asked for a gyro,
                an output directory that does not exist, an invalid setting.
            HandoffError: the calibration file cannot be read.
        """
        super().__init__(METHOD, NODE_NAME, {}, NoiseSettings, (
            ('topic', '', 'The sensor_msgs/Imu topic to characterise (all six axes); '
             "'' = /gyro/pulses or /fog/output, whichever arrives."),
            ('calibration_file', '', 'Hand-off file to take the scale factor from '
             '(scale_factor_rad_per_pulse or k_tilde_rad_per_pulse; '
             'fog_scale_factor_counts_per_rad).'),
            ('kalibr_file', '', "Kalibr imu.yaml written on shutdown (IMU only; '' = none)."),
            ('plot_file', '', "Allan-deviation figure (PNG) written on shutdown ('' = none; a "
             'directory gets noise_adev.png).'),
            ('best_effort', False, 'Subscribe the Imu topic best effort whatever its '
             'publishers offer (without it the node reads best effort as soon as one '
             'publisher does).'),
            ('results_period_s', 5.0, 'How often the running terms are recomputed, s (a copy '
             'and a fit per axis; the numbers do not depend on it).')))
        extra = self.extra_parameters
        topic, calibration = str(extra['topic']), str(extra['calibration_file'])
        kalibr, plot = str(extra['kalibr_file']), str(extra['plot_file'])
        best_effort = bool(extra['best_effort'])
        self.results_period_s = float(extra['results_period_s'])
        if not self.results_period_s > 0:
            raise ConfigError(f'results_period_s = {self.results_period_s!r} is invalid: it '
                              'must be positive.')
        get = self.get_parameter
        settings = {f.name: get(f.name).value for f in dataclasses.fields(NoiseSettings)
                    if f.name not in GENERIC_PARAMETERS}
        k = float(get('scale_factor_rad_per_pulse').value)
        config = str(get('config_file').value)
        options = CalibrationOptions(
            config_file=Path(config) if config else None,
            scale_factor_rad_per_pulse=None if math.isnan(k) else k,
            calibration_file=Path(calibration) if calibration else None,
            topic=topic or None, gyro_id=self.gyro_id, settings=settings)
        session = NoiseSession(options)
        if session.kind == 'gyro':
            if not (session.pulse_scale.known or session.fog_scale.known):
                raise ConfigError(
                    "with topic '' the node reads /gyro/pulses or /fog/output, and neither "
                    'scale factor is given: set scale_factor_rad_per_pulse, '
                    'fog_scale_factor_counts_per_rad or calibration_file (or set topic to an '
                    'Imu topic).')
        else:
            check_scale_factor(options)
        self.targets = resolve_targets(kalibr, plot, self.output_file)
        if self.targets.kalibr is not None and session.kind != 'imu':
            raise ConfigError(f"kalibr_file: Kalibr's imu.yaml describes an IMU; "
                              f"{topic or '/gyro/pulses or /fog/output'} is a single-axis "
                              'gyro (set topic to an Imu topic, or kalibr_file to "").')
        if self.targets.kalibr is not None:  # a user's file at that path is never replaced
            refuse_to_overwrite_records(self.targets.kalibr, 'kalibr_file:',
                                        "Kalibr's imu.yaml")
            refuse_to_replace_a_foreign_file(self.targets.kalibr, 'kalibr', 'kalibr_file:',
                                             other_marks=(KALIBR_MARK,))
        session.auto_refresh = False
        self.session, self._noise_options = session, options
        self.best_effort = best_effort
        self._rewire(topic)
        self.create_timer(self.results_period_s, self._inputs_busy(self._refresh))
        self._last_terms = ''
        self.get_logger().info(
            f'noise: waiting for '
            f'{", ".join(f"{t} ({m})" for t, m in session.topics().items())}'
            + (' best effort' if best_effort else '')
            + f'; running terms every {self.results_period_s:g} s; on shutdown: '
            + (', '.join(f'{w} {p}' for w, p in (('kalibr', self.targets.kalibr),
                                                 ('plot', self.targets.plot),
                                                 ('hand-off', self.targets.handoff)) if p)
               or 'no files'))

    def _announce_inputs(self) -> None:
        """Said after the inputs are rewired.

        Said after the inputs are rewired (the generic node's default topics are not
        what this node reads).
        """

    def new_session(self) -> NoiseSession:
        """A fresh noise session with the node's input and settings (``~/reset``)."""
        session = NoiseSession(self._noise_options)
        session.auto_refresh = False
        return session

    def consume_now(self) -> None:
        """Take in the buffered samples and recompute the running terms (``~/save``)."""
        self._refresh()

    def _rewire(self, topic: str) -> None:
        """Subscribe exactly the session's topics.

        Subscribe exactly the session's topics (the generic node subscribed its default);
        ``topic`` (the user's Imu topic) by the name given, the contract's relative to the
        namespace.
        """
        imu = tuple(t for t, m in self.session.topics().items() if m == IMU)
        self._subscribe_inputs(best_effort=imu if self.best_effort else (),
                               as_given=(topic,) if topic else ())

    def _process(self) -> None:
        """Hand the buffered samples to the session (results come from :meth:`_refresh`)."""
        self.state.resume_once(self.session.feed, self.session.process)
        self._feed(self._take_inputs())
        for line in self.session.process():
            self._last_line = line
            self.get_logger().info(line)

    def received(self) -> int:
        """Samples received so far (handed over or still buffered)."""
        held = self._live_inputs.pending()
        return held + sum(s.received for s in self.session.calibrator.ordering_stats().values())

    def _refresh(self) -> None:
        """Recompute the running terms if samples arrived; publish and update the hand-off."""
        self._process()
        if not self.session.calibrator.axes():
            return
        started = time.monotonic()
        if not self.session.refresh():
            return
        line = self._terms_line(time.monotonic() - started)
        terms = line.split(' (', 1)[0] + line.split('):', 1)[-1]  # without the compute time
        if terms != self._last_terms:  # what changed, not the same line every period
            self._last_terms = terms
            self.get_logger().info(line)
        self._write_handoff()
        self._publish_diagnostics()

    def _terms_line(self, seconds: float) -> str:
        parts = []
        for axis, res in self.session.axis_results().items():
            if res.fit is None:
                continue
            u = res.units
            terms = [f'{u.names[k].rsplit(" ", 1)[-1]} {est.value * u.quoted_factors[k]:.4g} '
                     f'{u.quoted_units[k]}' for k, key in enumerate(u.keys)
                     if (est := res.fit.estimates.get(key)) is not None]
            if terms:
                parts.append(f'{axis}: {", ".join(terms)}')
        n = self.session.data_span_ns()
        span = f' over {(n[1] - n[0]) / 1e9:.1f} s' if n else ''
        return (f'running terms{span} ({seconds:.2f} s to compute): '
                + ('; '.join(parts) if parts else 'none resolved yet'))

    def drain(self, executor: Any) -> None:
        """Take in the samples DDS already acknowledged to the publisher before the end."""
        spin_until_quiet(executor, self.received, limit_s=30.0)

    def finish(self) -> int:  # type: ignore[override]  # main() exits with this status
        """End the record, publish the final terms, write the files; 0, or 1 on failure."""
        log = self.get_logger()
        self._live_inputs.ended = True  # everything held goes to the session, in stamp order
        self._process()
        for line in self.session.process(flush=True):
            log.info(line)
        self._publish_diagnostics()
        try:
            self.session.check_measurable()
            merge: list[str] = []
            written = write_outputs(self.session, self.targets, source='live',
                                    schema=handoff_schema(), gyro_id=self.gyro_id,
                                    merge_report=merge)
        except (GyroCalibError, OSError) as exc:
            why = ' '.join(str(exc).split())
            log.error(f'noise: files not written: {why}')
            self.state.finish(complete=False, not_written=f'noise: files not written ({why})')
            return 1
        log.info(self._terms_line(0.0).replace('running terms', 'final terms', 1))
        for what, path in written:
            log.info(written_line(what, path))
        for line in merge:  # every change to the hand-off file, each replacement new — was old
            log.info(f'hand-off {line}')
        self.state.finish(complete=True)
        return 0


def main(args: list[str] | None = None) -> None:
    """Run until SIGINT/SIGTERM, then take in the backlog, end the record, write the files."""
    status: list[int] = []

    def finish(node: NoiseNode, executor: Any) -> None:
        node.drain(executor)
        status.append(node.finish())

    run_node(NODE_NAME, NoiseNode, args, on_stop=finish)
    if status and status[0]:
        raise SystemExit(status[0])


if __name__ == '__main__':
    main()
