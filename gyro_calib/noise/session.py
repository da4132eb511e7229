"""The noise characterisation behind the shared front door (registry, CLI, bag calibration, node).

One session characterises one sensor, from one of (issue 11 Part 2 item 1):

================  ==========================  ===========================================
input             message, fields             needs
================  ==========================  ===========================================
``/gyro/pulses``  sensor_msgs/JointState,     K, rad/pulse: ``scale_factor_rad_per_pulse``
                  position[0] cumulative      (flag, node parameter), else a hand-off file
                  pulses                      (``scale_factor_rad_per_pulse``, else
                                              ``k_tilde_rad_per_pulse``), else the bench
                                              settings a simulated bag stores
``/fog/output``   sensor_msgs/JointState,     counts/rad: ``scale_factor_counts_per_rad``
                  position[0] cumulative      (flag) or ``fog_scale_factor_counts_per_rad``
                  output counts               (setting, hand-off file, bag bench settings)
any Imu topic     sensor_msgs/Imu,            nothing (``topic``: the flag, node parameter
                  angular_velocity xyz,       or the bag's stored ``bench.topic``)
                  linear_acceleration xyz
``/imu/pulses``   sensor_msgs/JointState,     K_i per channel: the ``imu:`` section of a
                  three joints (the channels) format-4 hand-off file (``--calibration``,
                  cumulative pulses           ``imu.scale_factor_rad_per_pulse``)
================  ==========================  ===========================================

A triad (``/imu/pulses``) gives one axis per channel, named by the channel; its terms go to
the hand-off's ``imu.noise.<channel>`` (the single-gyro keys), not to the top level.

Results are flattened for the front door: a single gyro gives the five plain keys of
:mod:`gyro_calib.noise.keys` (``angle_random_walk_rad_per_sqrt_s`` …), an IMU one key per
axis and term (``imu_gyro_x_angle_random_walk_rad_per_sqrt_s`` …). ``--json`` keeps the
core's nested shape (:meth:`NoiseSession.json_section`).

Running results: the calibrator holds back the newest ``reorder_window_s`` of samples
(a late sample may still sort in) and ends its last segment only at the end of the record.
Before the end, results come from a *snapshot*: a copy of the calibrator flushed as if the
record ended now — what ``gyro-calib noise`` would say of the samples so far, bit for bit.
Offline a snapshot is taken whenever results are asked for after new data; a live node
sets :attr:`NoiseSession.auto_refresh` to False and calls :meth:`NoiseSession.refresh`
at its own pace (a snapshot costs a copy and a fit per axis).

Built from :mod:`~gyro_calib.noise.inputs` (which topic a run reads),
:mod:`~gyro_calib.noise.scale_factors` (K, counts/rad, K_i and where each came from),
:mod:`~gyro_calib.noise.options` (the settings read from the options; the scale-factor check)
and :mod:`~gyro_calib.noise.session_report` (what a run says); this module holds
:class:`NoiseSession` (input, snapshots, results, hand-off) and re-exports their names.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from gyro_calib.config import given
from gyro_calib.errors import ConfigError, StreamError
from gyro_calib.noise.calibrator import IMU_AXES, NoiseCalibrator
from gyro_calib.noise.inputs import (
    FOG_OUTPUT,
    GYRO_PULSES,
    GYRO_TOPICS,
    IMU,
    IMU_PULSES,
    JOINT_STATE,
    JOINT_TOPICS,
    TABLE_TOPICS,
    input_kind,
    input_topic,
    select_input,
)
from gyro_calib.noise.keys import METHOD, UPPER_BOUND_SUFFIX, imu_key
from gyro_calib.noise.options import (
    NODE_NAME,
    check_scale_factor,
    noise_settings,
    settings_values,
)
from gyro_calib.noise.scale_factors import (
    ScaleFactor,
    TriadScales,
    fog_scale_factor,
    pulse_scale_factor,
    triad_scale_factors,
)
from gyro_calib.noise.session_report import FIGURE_NAME, NoiseReport, NoNoiseDataError
from gyro_calib.noise.terms import units_for_axis
from gyro_calib.session import CalibrationOptions, MethodSession

if TYPE_CHECKING:
    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection
    from gyro_calib.handoff import Calibration
    from gyro_calib.noise.calibrator import AxisResult

__all__ = ['FIGURE_NAME', 'FOG_OUTPUT', 'GYRO_PULSES', 'GYRO_TOPICS', 'IMU', 'IMU_PULSES',
           'JOINT_STATE', 'JOINT_TOPICS', 'NODE_NAME', 'TABLE_TOPICS', 'NoNoiseDataError',
           'NoiseSession', 'ScaleFactor', 'TriadScales', 'check_scale_factor',
           'fog_scale_factor', 'input_kind', 'input_topic', 'noise_settings',
           'pulse_scale_factor', 'select_input', 'settings_values', 'triad_scale_factors']


class NoiseSession(NoiseReport, MethodSession):
    """Allan deviation and IEEE Std 952 noise terms of one gyro or IMU (METHODS §E)."""

    name = METHOD

    def __init__(self, options: CalibrationOptions) -> None:
        """Resolve the input and scale factors; build the calibrator.

        Raises:
            ConfigError: an invalid setting or scale factor.
            HandoffError: the hand-off file given for the scale factor is unreadable.
        """
        self.options = options
        self.topic = input_topic(options)
        self.kind = input_kind(self.topic)
        self.settings = noise_settings(options)
        merged = dataclasses.replace(options, settings=settings_values(options)[0])
        self.pulse_scale = pulse_scale_factor(merged) if self.kind in ('pulses', 'gyro') \
            else ScaleFactor(math.nan)
        self.fog_scale = fog_scale_factor(merged) if self.kind in ('fog', 'gyro') \
            else ScaleFactor(math.nan)
        self.triad_scale = triad_scale_factors(merged) if self.kind == 'triad' \
            else TriadScales()
        self.calibrator = NoiseCalibrator(self.settings, imu_topic=self.topic or 'imu')
        if self.kind == 'triad' and self.triad_scale.known:
            self.calibrator.triad = (self.triad_scale.channels, self.triad_scale.values)
        self.auto_refresh = True
        """Take a new snapshot whenever results are asked for after new data (offline);
        a live node sets False and calls :meth:`refresh` at its own pace."""
        self._flushed = False
        self._snapshot: tuple[tuple[tuple[str, int], ...], NoiseCalibrator] | None = None

    # -- input ------------------------------------------------------------------------------
    def topics(self) -> dict[str, str]:
        """The input topic, and the tables' joint states (optional).

        The input topic (an Imu), or both single-axis gyro streams when none was named;
        and ``/rate_table/joint_states`` and ``/position_table/joint_states``, read when
        recorded to leave out what the sensor gave while a table moved.
        """
        if self.kind == 'imu':
            assert self.topic is not None
            return {self.topic: IMU, **TABLE_TOPICS}
        if self.kind == 'gyro':
            return {**GYRO_TOPICS, **TABLE_TOPICS}
        assert self.topic is not None
        return {self.topic: JOINT_STATE, **TABLE_TOPICS}

    def feed(self, batch: SampleBatch) -> None:
        """The input stream's samples of one batch.

        Raises:
            ConfigError: both /gyro/pulses and /fog/output arrived and no topic was chosen.
        """
        cal = self.calibrator
        for topic in TABLE_TOPICS:  # first: they decide the gyro samples of the same batch
            table = batch.joint_state(topic)
            if table is not None and self.topic != topic:
                cal.extend_table(*table, topic=topic)
        try:
            if self.kind in ('pulses', 'gyro'):
                pulses = batch.joint_state(GYRO_PULSES)
                if pulses is not None:
                    cal.extend_pulses(pulses[0], pulses[1])
            if self.kind in ('fog', 'gyro'):
                out = batch.joint_state(FOG_OUTPUT)
                if out is not None:
                    cal.extend_fog_output(out[0], out[1])
        except StreamError as exc:
            if 'both' not in str(exc):
                raise
            raise ConfigError(f'both {GYRO_PULSES} and {FOG_OUTPUT} carry samples; one noise '
                              'run characterises one gyro: choose one with --topic (node: '
                              'parameter topic).') from None
        if self.kind == 'triad':
            self._feed_triad(batch)
        if self.kind == 'imu':
            c = batch.columns.get(self.topic) if self.topic is not None else None
            if c is not None and c.msgtype == IMU:
                cal.extend_imu(c.stamp_ns, c.values['angular_velocity_rad_s'],
                               c.values['linear_acceleration_m_s2'])

    def _feed_triad(self, batch: SampleBatch) -> None:
        """The three channels of ``/imu/pulses``, in the hand-off's channel order.

        Raises:
            ConfigError: the bag's joint names are not the hand-off's channels.
        """
        col = batch.columns.get(IMU_PULSES)
        if col is None or not len(col):
            return
        pos = np.asarray(col.values['position'], dtype=np.float64)
        if pos.ndim != 2:
            pos = pos.reshape(len(pos), -1)
        names = tuple(str(n) for n in col.joint_names) or tuple(
            'xyz'[i] if pos.shape[1] == 3 else str(i) for i in range(pos.shape[1]))
        cal = self.calibrator
        if cal.triad is None:  # no K known: every channel's reason says so
            cal.triad = (names, tuple(math.nan for _ in names))
        want = cal.triad[0]
        if sorted(names) != sorted(want):
            raise ConfigError(f'{IMU_PULSES} carries the channels {list(names)}, but '
                              f'{self.triad_scale.source or "the hand-off"} gives K for '
                              f'{list(want)}: the file is of another IMU (or its channels are '
                              'named otherwise); pass its own hand-off with --calibration.')
        order = [names.index(c) for c in want]
        cal.extend_triad(col.stamp_ns, pos[:, order])

    def process(self, *, flush: bool = False) -> list[str]:
        """Take in what is final; at ``flush`` the rest.

        Take in what is final; at ``flush`` the rest. New log lines (periods learnt,
        gaps, restarts, segments left out; at the end the ordering counts).
        """
        lines = self.calibrator.process(flush=flush)
        if flush:
            self._flushed = True
            self._snapshot = None
        return lines

    # -- snapshots --------------------------------------------------------------------------
    def _data_key(self) -> tuple[tuple[str, int], ...]:
        return (*((t, s.received) for t, s in self.calibrator.ordering_stats().items()),
                *((topic, table.states + table.unusable + table.behind)
                  for topic, table in self.calibrator.gate.tables.items()))

    def refresh(self) -> bool:
        """Take a snapshot of the samples so far (flushed copy, fitted); True when new.

        Nothing to do at the end of the record (the calibrator itself is flushed) or when
        no sample arrived since the last snapshot.
        """
        if self._flushed:
            return False
        key = self._data_key()
        if self._snapshot is not None and self._snapshot[0] == key:
            return False
        snap = copy.deepcopy(self.calibrator)
        snap.process(flush=True)
        snap.axis_results()  # the fits, once
        self._snapshot = (key, snap)
        return True

    @property
    def view(self) -> NoiseCalibrator | None:
        """The calibrator results come from.

        The calibrator results come from: itself once flushed, else the latest snapshot
        (taken now when :attr:`auto_refresh`); None before any data or snapshot.
        """
        if self._flushed:
            return self.calibrator
        if not self.calibrator.axes():
            return None
        if self.auto_refresh:
            self.refresh()
        return self._snapshot[1] if self._snapshot is not None else None

    def axis_results(self) -> dict[str, AxisResult]:
        """Curve, fit and reason of every axis (empty before any data)."""
        view = self.view
        return view.axis_results() if view is not None else {}

    # -- results ----------------------------------------------------------------------------
    def hand_off_key(self, axis: str, term_key: str) -> str:
        """The flattened key of one term.

        Plain for a single gyro, per axis for an IMU, ``imu.noise.<channel>.<key>`` for a
        triad's channel (where the hand-off holds it).
        """
        if self.kind == 'triad':
            return f'imu.noise.{axis}.{term_key}'
        return imu_key(axis, term_key) if self.kind == 'imu' else term_key

    def _expected_axes(self) -> tuple[str, ...]:
        if self.kind == 'triad':
            got = self.calibrator.triad
            return tuple(got[0]) if got is not None else self.triad_scale.channels
        return IMU_AXES if self.kind == 'imu' else ('gyro',)

    def results(self) -> dict[str, Estimate]:
        """Resolved terms by hand-off key (SI units in the keys)."""
        view = self.view
        if view is None:
            return {}
        return {self.hand_off_key(axis, key): est
                for axis, terms in view.results().items() for key, est in terms.items()}

    def upper_bounds(self) -> dict[str, float]:
        """2σ upper bounds of the terms not resolved, by hand-off key (METHODS §E; SI)."""
        view = self.view
        if view is None:
            return {}
        out: dict[str, float] = {}
        for axis, res in view.axis_results().items():
            if res.fit is None:
                continue
            for key, upper in res.fit.upper_bounds.items():
                if key not in res.fit.estimates and math.isfinite(upper) and upper >= 0:
                    out[self.hand_off_key(axis, key)] = float(upper)
        return out

    def handoff_values(self) -> dict[str, Any]:
        """The resolved terms, and each unresolved term's bound (``_upper_bound_2sigma``).

        Resolved terms with ``_std`` and ``_dof``; for each term not resolved its 2σ upper
        bound (METHODS §E), machine-readable for ``gyro-calib export`` (issue 27 §1).
        """
        if self.kind == 'triad':
            return {}  # the terms are the imu: section's noise (:meth:`handoff`)
        out = super().handoff_values()
        if out:
            for key, upper in self.upper_bounds().items():
                out[key + UPPER_BOUND_SUFFIX] = upper
        return out

    def triad_noise(self) -> dict[str, dict[str, float]]:
        """A triad's terms per channel, as ``imu.noise.<channel>`` holds them.

        Per channel the single-gyro keys (:mod:`gyro_calib.noise.keys`) with ``_std`` and
        ``_dof``, and each unresolved term's 2σ bound (``_upper_bound_2sigma``; METHODS §E).
        """
        view = self.view
        out: dict[str, dict[str, float]] = {}
        for axis, res in (view.axis_results().items() if view is not None else ()):
            if res.fit is None:
                continue
            terms: dict[str, float] = {}
            for key in res.units.keys:
                est = res.fit.estimates.get(key)
                upper = res.fit.upper_bounds.get(key, math.nan)
                if est is not None:
                    terms[key] = float(est.value)
                    terms[key + '_std'] = float(est.std_uncertainty)
                    terms[key + '_dof'] = float(est.supported_dof)
                elif math.isfinite(upper) and upper >= 0:
                    terms[key + UPPER_BOUND_SUFFIX] = float(upper)
            if terms:
                out[axis] = terms
        return out

    def handoff(self, source: str, *, gyro_id: str = '') -> Calibration | None:
        """This run's record; a triad's terms go to ``imu.noise.<channel>`` (format 4)."""
        if self.kind != 'triad':
            return super().handoff(source, gyro_id=gyro_id)
        from gyro_calib.handoff import Provenance, method_calibration
        from gyro_calib.imu_calibration import ImuCalibration

        noise = self.triad_noise()
        span = self.data_span_ns()
        channels = self._expected_axes()
        if not noise or span is None or len(channels) != 3:
            return None
        conditions = {k: v for k, v in self.conditions().items() if given(v)}
        cal = method_calibration(self.name, {}, Provenance(
            source, span[0], span[1], conditions=conditions,
            deviations=self.deviation_tables(), settings=dict(self.run_settings)),
            gyro_id=gyro_id)
        return dataclasses.replace(cal, imu=ImuCalibration(
            (channels[0], channels[1], channels[2]), noise=noise))

    def missing(self) -> dict[str, str]:
        """Every term not resolved (yet), by hand-off key, with the reason."""
        view = self.view
        nested = view.missing() if view is not None else {}
        seen = set(view.axes()) if view is not None else set()
        where = self.topic or f'{GYRO_PULSES} or {FOG_OUTPUT}'
        out: dict[str, str] = {}
        for axis in self._expected_axes():
            if axis not in seen:
                why = (f'no samples on {where} analysed yet.' if not self.calibrator.axes()
                       else 'no running result yet.')
                for key in units_for_axis(axis).keys:
                    out[self.hand_off_key(axis, key)] = why
                continue
            for key, why in nested.get(axis, {}).items():
                out[self.hand_off_key(axis, key)] = why
        return out

    def rejections(self) -> list[Rejection]:
        """Segments left out (too short, another sample rate), with reasons."""
        view = self.view
        return list((view if view is not None else self.calibrator).rejections)

    def data_span_ns(self) -> tuple[int, int] | None:
        """First and last stamp of the segments analysed."""
        view = self.view
        return view.data_span_ns() if view is not None else None

    # -- output -----------------------------------------------------------------------------
    def json_section(self) -> dict[str, Any]:
        """The noise method's JSON section, with the curves.

        Every method's ``{"results", "missing", "rejections"}`` (hand-off keys) plus the
        curves: ``"axes": {AXIS: {"tau_s", "adev", "adev_std", "results": {KEY: {"value",
        "std", "n"}}}}`` — axis ``gyro`` for a single gyro, ``gyro_x`` … ``accel_z`` for an
        IMU; term keys as :mod:`gyro_calib.noise.terms` names them.
        """
        view = self.view
        out = super().json_section()
        out.update(view.json_section() if view is not None else {'axes': {}})
        return out
