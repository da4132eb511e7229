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
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeGuard

import numpy as np

from gyro_calib import topics
from gyro_calib.config import given
from gyro_calib.errors import ConfigError, InsufficientDataError, StreamError
from gyro_calib.noise.calibrator import IMU_AXES, NoiseCalibrator
from gyro_calib.noise.fit import NoiseFit
from gyro_calib.noise.keys import METHOD, UPPER_BOUND_SUFFIX, imu_key
from gyro_calib.noise.outliers import OutlierReport
from gyro_calib.noise.settings import NoiseSettings
from gyro_calib.noise.terms import SYMBOLS, units_for_axis
from gyro_calib.session import CalibrationOptions, MethodSession

if TYPE_CHECKING:
    from pathlib import Path

    from gyro_calib.bagio import SampleBatch
    from gyro_calib.estimate import Estimate, Rejection
    from gyro_calib.handoff import Calibration
    from gyro_calib.noise.calibrator import AxisResult

JOINT_STATE = 'sensor_msgs/msg/JointState'
IMU = 'sensor_msgs/msg/Imu'
GYRO_PULSES = topics.GYRO_PULSES
FOG_OUTPUT = topics.FOG_OUTPUT
GYRO_TOPICS = {GYRO_PULSES: JOINT_STATE, FOG_OUTPUT: JOINT_STATE}
"""The single-axis gyro streams (topic → type)."""
IMU_PULSES = topics.IMU_PULSES
JOINT_TOPICS = {**GYRO_TOPICS, IMU_PULSES: JOINT_STATE}
"""Every JointState input (the single-axis streams and a triad's three channels)."""
TABLE_TOPICS = {topics.RATE_TABLE_JOINT_STATES: JOINT_STATE,
                topics.POSITION_TABLE_JOINT_STATES: JOINT_STATE}
"""Optional inputs: the rate table's and the position table's joint states. The samples
taken while a recorded table changed rate (the position table: turned) are left out, each
steady span analysed as a segment (:mod:`gyro_calib.noise.table`)."""
NODE_NAME = 'noise_node'
"""The node's name (ROS 2 parameter files for ``--config`` use it, or ``/**``)."""
FIGURE_NAME = 'noise_adev.png'
"""File name of the Allan-deviation figure when a directory is given."""


class NoNoiseDataError(InsufficientDataError):
    """No axis of the input yields an Allan deviation.

    No axis of the input yields an Allan deviation (constant, non-finite, too short,
    no scale factor): no noise term can be measured.
    """


@dataclass(frozen=True, slots=True)
class ScaleFactor:
    """A scale factor and where it came from.

    Attributes:
        value: the value (rad/pulse or counts/rad); NaN when none was found.
        source: where it came from, for the summary ('' when none).
    """

    value: float
    source: str = ''

    @property
    def known(self) -> bool:
        """A finite positive value was found."""
        return math.isfinite(self.value) and self.value > 0


def _positive(value: Any) -> TypeGuard[float]:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value) and value > 0)


def _from_handoff(path: Path, keys: tuple[str, ...]) -> tuple[float, str] | None:
    from gyro_calib.handoff import load_calibration

    record = load_calibration(path)
    for key in keys:
        got = record.measured(key)
        if got is not None:
            return got[0], f'{key} in {path}'
    return None


def _first_scale_factor(options: CalibrationOptions, given: float | None, *, flag: str,
                        unit: str, key: str, handoff_keys: tuple[str, ...],
                        settings_source: str, order: tuple[str, str]) -> ScaleFactor:
    """The first scale factor given: the flag, hand-off file and settings in ``order``, the bag.

    ``key`` names the setting, the flag's origin and the bag's bench-settings entry; ``flag``
    and ``unit`` word the refusal of a bad flag value.

    Raises:
        ConfigError: the flag's value is not positive and finite.
        HandoffError: the hand-off file cannot be read or is invalid.
    """
    if given is not None:
        if not _positive(given):
            raise ConfigError(f'{flag} = {given!r} is invalid: it must be a positive number of '
                              f'{unit}.')
        return ScaleFactor(float(given), options.origin_of_given(key))
    setting = options.settings.get(key)
    for source in order:
        if source == 'handoff' and options.calibration_file is not None:
            got = _from_handoff(options.calibration_file, handoff_keys)
            if got is not None:
                return ScaleFactor(*got)
        elif source == 'settings' and _positive(setting):
            return ScaleFactor(float(setting), settings_source)
    stored = options.bench(key, None)
    if _positive(stored):
        return ScaleFactor(float(stored), 'the bench settings stored in the bag')
    return ScaleFactor(math.nan)


def pulse_scale_factor(options: CalibrationOptions) -> ScaleFactor:
    """K of ``/gyro/pulses``, rad/pulse, from the first source given.

    The flag (node parameter), a hand-off file (``scale_factor_rad_per_pulse``, else
    ``k_tilde_rad_per_pulse``), the settings (config file), the bag's bench settings; raises
    as :func:`_first_scale_factor`.
    """
    return _first_scale_factor(
        options, options.scale_factor_rad_per_pulse, flag='scale_factor_rad_per_pulse',
        unit='rad/pulse', key='scale_factor_rad_per_pulse',
        handoff_keys=('scale_factor_rad_per_pulse', 'k_tilde_rad_per_pulse'),
        settings_source='the settings', order=('handoff', 'settings'))


def fog_scale_factor(options: CalibrationOptions) -> ScaleFactor:
    """Scale factor of ``/fog/output``, counts/rad, from the first source given.

    The flag, the setting ``fog_scale_factor_counts_per_rad`` (node parameter, config file),
    a hand-off file (``fog_scale_factor_counts_per_rad``), the bag's bench settings; raises
    as :func:`_first_scale_factor`.
    """
    return _first_scale_factor(
        options, options.scale_factor_counts_per_rad, flag='scale_factor_counts_per_rad',
        unit='counts/rad', key='fog_scale_factor_counts_per_rad',
        handoff_keys=('fog_scale_factor_counts_per_rad',),
        settings_source='fog_scale_factor_counts_per_rad (settings)',
        order=('settings', 'handoff'))


@dataclass(frozen=True, slots=True)
class TriadScales:
    """The channels of ``/imu/pulses`` and K_i of each (METHODS §F), and where they came from.

    Attributes:
        channels: the channel names, in the hand-off's ``imu.channels`` order.
        values: K_i, rad/pulse; NaN for a channel the file does not give.
        source: the file they came from ('' when none).
    """

    channels: tuple[str, ...] = ('x', 'y', 'z')
    values: tuple[float, ...] = (math.nan, math.nan, math.nan)
    source: str = ''

    @property
    def known(self) -> bool:
        """At least one channel has a finite positive K."""
        return any(_positive(v) for v in self.values)


def triad_scale_factors(options: CalibrationOptions) -> TriadScales:
    """K_i of each ``/imu/pulses`` channel from ``--calibration`` (the ``imu:`` section).

    Raises:
        HandoffError: the hand-off file cannot be read or is invalid.
    """
    from gyro_calib.handoff import load_calibration

    if options.calibration_file is None:
        return TriadScales()
    imu = load_calibration(options.calibration_file).imu
    if imu is None or imu.scale_factor_rad_per_pulse is None:
        return TriadScales(imu.channels) if imu is not None else TriadScales()
    k = tuple(float(v) for v in imu.scale_factor_rad_per_pulse)
    return TriadScales(imu.channels, k, f'imu.scale_factor_rad_per_pulse in '
                                        f'{options.calibration_file}')


def settings_values(options: CalibrationOptions) -> tuple[dict[str, Any], str]:
    """The settings given, and where they came from.

    The settings given: the node's parameters, then the config file's values (plain
    mapping or ROS 2 parameter file of ``noise_node``); and where they came from.

    Raises:
        ConfigError: the config file is unreadable, or names an unknown setting.
    """
    values, source = options.method_settings(NoiseSettings, NODE_NAME,
                                             parameters='the node parameters')
    names = {f.name for f in dataclasses.fields(NoiseSettings)}
    unknown = sorted(set(values) - names)
    if unknown:
        raise ConfigError(f'unknown noise setting(s) {", ".join(unknown)} in {source}; the '
                          f'settings are: {", ".join(sorted(names))}.')
    return values, source


def noise_settings(options: CalibrationOptions) -> NoiseSettings:
    """The analysis settings with the scale factors resolved.

    The analysis settings (:func:`settings_values`) with the scale factors resolved by
    :func:`pulse_scale_factor` and :func:`fog_scale_factor`.

    Raises:
        ConfigError: an unknown or invalid setting, naming it and its source.
        HandoffError: the hand-off file given for a scale factor is unreadable.
    """
    values, source = settings_values(options)
    merged = dataclasses.replace(options, settings=values)
    defaults = NoiseSettings()
    for name, value in list(values.items()):
        if (isinstance(getattr(defaults, name), float) and isinstance(value, int)
                and not isinstance(value, bool)):
            values[name] = float(value)
    values['scale_factor_rad_per_pulse'] = pulse_scale_factor(merged).value
    values['fog_scale_factor_counts_per_rad'] = fog_scale_factor(merged).value
    try:
        return NoiseSettings(**values)
    except ConfigError as exc:
        raise ConfigError(f'{exc} (in {source})') from None


def input_topic(options: CalibrationOptions) -> str | None:
    """The input topic asked for, or None.

    The input topic asked for (flag, node parameter, or the bag's stored ``bench.topic``);
    None: ``/gyro/pulses`` or ``/fog/output``, whichever arrives.
    """
    topic = options.topic or options.bench('topic', None)
    return str(topic) if topic else None


def input_kind(topic: str | None) -> str:
    """'pulses', 'fog', 'triad', 'imu', or 'gyro' (either single-axis stream) for a topic."""
    if topic is None:
        return 'gyro'
    return {GYRO_PULSES: 'pulses', FOG_OUTPUT: 'fog', IMU_PULSES: 'triad'}.get(topic, 'imu')


def select_input(present: Mapping[str, tuple[str, int]], options: CalibrationOptions, *,
                 where: str, listing: str) -> str:
    """The topic ``gyro-calib noise`` reads in a bag.

    The topic ``gyro-calib noise`` reads in a bag: the one asked for, checked, or the only
    candidate (``/gyro/pulses``, ``/fog/output``, an Imu topic).

    Args:
        present: topic → (message type, message count) in the bag(s).
        options: the user's options (``topic``; the stored scenario's ``bench.topic``).
        where: the bag path(s), for messages.
        listing: 'topic (type, n), …' of the bag(s), for messages.

    Raises:
        MissingTopicError: the topic asked for is absent or empty, or no candidate is there.
        WrongMessageTypeError: the topic asked for carries another message type.
        ConfigError: several candidates and none asked for.
    """
    from gyro_calib.bagio import MissingTopicError, WrongMessageTypeError

    asked = options.topic
    if asked:
        want = JOINT_TOPICS.get(asked, IMU)
        if asked not in present:
            raise MissingTopicError(f'{where}: no topic {asked} in the bag(s); they hold '
                                    f'{listing}.')
        msgtype, count = present[asked]
        if msgtype != want:
            what = ('the pulse/FOG streams are JointState' if asked in JOINT_TOPICS else
                    f'any other topic must be {IMU} (the pulse and FOG streams are '
                    f'{GYRO_PULSES} and {FOG_OUTPUT}, {JOINT_STATE})')
            raise WrongMessageTypeError(f'{where}: topic {asked} has type {msgtype}, but '
                                        f'gyro-calib noise reads {want} there ({what}); the '
                                        f'bag(s) hold {listing}.')
        if count == 0:
            raise MissingTopicError(f'{where}: topic {asked} holds no message; the bag(s) '
                                    f'hold {listing}.')
        return asked
    candidates = [t for t, m in JOINT_TOPICS.items()
                  if t in present and present[t][0] == m and present[t][1] > 0]
    candidates += sorted(t for t, (m, n) in present.items() if m == IMU and n > 0)
    stored = options.bench('topic', None)
    if stored in candidates:
        return str(stored)
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise MissingTopicError(
            f'{where}: nothing to characterise: gyro-calib noise reads {GYRO_PULSES} or '
            f'{FOG_OUTPUT} ({JOINT_STATE}) or a {IMU} topic (--topic); the bag(s) hold '
            f'{listing}.')
    raise ConfigError(f'{where}: several inputs to characterise ({", ".join(candidates)}); '
                      f'choose one with --topic (one run per sensor); the bag(s) hold '
                      f'{listing}.')


def check_scale_factor(options: CalibrationOptions) -> ScaleFactor | None:
    """The scale factor the chosen input needs (None for an Imu).

    Raises:
        ConfigError: a pulse or FOG stream without a scale factor, naming the ways to give one.
    """
    kind = input_kind(input_topic(options))
    merged = dataclasses.replace(options, settings=settings_values(options)[0])
    if kind == 'pulses':
        k = pulse_scale_factor(merged)
        if not k.known:
            raise ConfigError(
                f'{GYRO_PULSES} needs the scale factor K to turn pulses into rad, and none was '
                'given: pass --scale-factor-rad-per-pulse K, or --calibration FILE (a hand-off '
                'file with scale_factor_rad_per_pulse or k_tilde_rad_per_pulse). No number in '
                'rad is possible without it; nothing was written.')
        return k
    if kind == 'triad':
        ks = triad_scale_factors(merged)
        if not ks.known:
            raise ConfigError(
                f'{IMU_PULSES} needs each channel\'s scale factor K_i to turn pulses into rad, '
                'and none was given: pass --calibration FILE (a format-4 hand-off file whose '
                'imu: section holds scale_factor_rad_per_pulse, from gyro-calib calibrate '
                '--method triad). Nothing was written.')
        return ScaleFactor(min(v for v in ks.values if _positive(v)), ks.source)
    if kind == 'fog':
        sf = fog_scale_factor(merged)
        if not sf.known:
            raise ConfigError(
                f'{FOG_OUTPUT} needs the scale factor (counts/rad) to turn counts into rad, and '
                'none was given: pass --scale-factor-counts-per-rad S, or --calibration FILE (a '
                'hand-off file with fog_scale_factor_counts_per_rad). Nothing was written.')
        return sf
    return None


class NoiseSession(MethodSession):
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
            deviations=self.deviation_tables()), gyro_id=gyro_id)
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

    def conditions(self) -> dict[str, Any]:
        """The scale factor the terms in rad rest on, and where it came from.

        ``scale_factor_rad_per_pulse`` (/gyro/pulses) or ``fog_scale_factor_counts_per_rad``
        (/fog/output) with ``scale_factor_from``; nothing for an Imu (no scale factor).
        """
        inputs = self.calibrator.inputs()
        out: dict[str, Any] = {}
        if 'triad' in inputs and self.triad_scale.known:
            out = {'triad_scale_factors_rad_per_pulse': ', '.join(
                f'{c} {k:.10g}' for c, k in zip(self.triad_scale.channels,
                                                 self.triad_scale.values)),
                   'scale_factor_from': self.triad_scale.source}
        for stream, name, scale in (('pulses', 'scale_factor_rad_per_pulse', self.pulse_scale),
                                    ('fog', 'fog_scale_factor_counts_per_rad', self.fog_scale)):
            if stream in inputs and scale.known:
                out = {name: scale.value, 'scale_factor_from': scale.source}
                break
        return {**out, **self.outlier_conditions()}

    def outlier_conditions(self) -> dict[str, Any]:
        """The spike treatment the terms rest on, for the run's conditions (§E.6).

        ``outliers`` (keep or remove), ``outlier_sigma``, ``outliers_found`` (all axes)
        and ``outliers_report`` (each axis with spikes: how many, the largest, what the other
        treatment changes; 'none' without spikes).
        """
        s = self.settings
        view = self.view
        reports = ([r.outliers for r in view.axis_results().values() if r.outliers is not None]
                   if view is not None else [])
        found = sum(r.tally.spikes for r in reports)
        words = []
        for r in reports:
            if not r.tally.spikes:
                continue
            change = (r.changes_words() if s.outliers == 'keep' else r.reverse_words())
            verb = 'removing' if s.outliers == 'keep' else 'keeping'
            words.append(f'{r.axis}: {r.tally.spikes} of {r.tally.screened} (largest '
                         f'{r.tally.largest_sigma:.4g} σ); {verb} them changes {change}')
        return {'outliers': s.outliers, 'outlier_sigma': float(s.outlier_sigma),
                'outliers_found': int(found), 'outliers_report': '; '.join(words) or 'none'}

    def check_measurable(self) -> None:
        """Raise unless at least one axis gives an Allan deviation in SI units.

        Raises:
            NoNoiseDataError: naming each axis's reason (constant, non-finite, too short,
                no scale factor, no samples).
        """
        results = self.axis_results()
        if any(r.curve is not None for r in results.values()):
            return
        where = self.topic or f'{GYRO_PULSES} / {FOG_OUTPUT}'
        if not results:
            raise NoNoiseDataError(f'no sample of {where} was analysed: nothing to '
                                   'characterise; nothing was written.')
        groups: dict[str, list[str]] = {}  # the same reason on several axes: said once
        for axis, res in results.items():
            groups.setdefault(res.reason.replace(axis, '{axis}', 1), []).append(axis)
        reasons = [why.replace('{axis}', axes[0] if len(axes) == 1 else
                               f'each axis ({", ".join(axes)})', 1)
                   for why, axes in groups.items()]
        raise NoNoiseDataError(f'no noise term can be measured from {where}: '
                               + ' '.join(reasons) + ' Nothing was written.')

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

    def deviation_tables(self) -> dict[str, dict[str, Any]]:
        """The per-τ ADEV, MDEV, HDEV and TOTDEV of each axis, for the hand-off file.

        The per-τ ADEV, MDEV, HDEV and TOTDEV of each axis with their standard
        uncertainties and EDF (``methods.noise.deviations``; the same numbers as ``--json``'s
        ``axes``), in the axis's rate unit.
        """
        from gyro_calib.handoff import DEVIATION_FIELDS

        view = self.view
        if view is None:
            return {}
        units = {axis: res.units.rate_unit for axis, res in view.axis_results().items()}
        return {axis: {k: (units[axis] if k == 'unit' else record[k]) for k in DEVIATION_FIELDS
                       if k == 'unit' or k in record}
                for axis, record in view.json_section()['axes'].items()}

    def summary_rows(self) -> list[tuple[str, str, str, str]]:
        """One row per resolved term: SI and the quoted unit (°/√h, °/h, µg …)."""
        rows = []
        for axis, res in self.axis_results().items():
            if res.fit is None:
                continue
            u = res.units
            for k, key in enumerate(u.keys):
                est = res.fit.estimates.get(key)
                if est is None:
                    continue
                q = u.quoted_factors[k]
                rows.append((f'{axis}: {u.names[k]}',
                             f'{est.value:.4g} {u.si_units[k]} = {est.value * q:.4g} '
                             f'{u.quoted_units[k]}',
                             f'{est.std_uncertainty:.2g} {u.si_units[k]} = '
                             f'{est.std_uncertainty * q:.2g} {u.quoted_units[k]}',
                             str(est.n_used)))
        return rows

    def _input_line(self) -> str:
        view = self.view
        rate = ''
        if view is not None and view.axes():
            hz = view.sample_rate_hz(view.axes()[0])
            if math.isfinite(hz):
                rate = f', {hz:.6g} Hz'
        if self.kind == 'imu':
            return f'input: {self.topic} ({IMU}), 6 axes{rate}.'
        if self.kind == 'triad':
            ks = self.triad_scale
            known = '; '.join(f'K_{c} = {k:.10g}' for c, k in zip(ks.channels, ks.values)
                              if _positive(k))
            return (f'input: {IMU_PULSES} ({JOINT_STATE}), {len(ks.channels)} channels'
                    f'{rate}' + (f'; {known} rad/pulse from {ks.source}' if known else '')
                    + '.')
        parts = []
        if self.kind in ('pulses', 'gyro') and self.pulse_scale.known:
            parts.append(f'K = {self.pulse_scale.value:.10g} rad/pulse from '
                         f'{self.pulse_scale.source}')
        if self.kind in ('fog', 'gyro') and self.fog_scale.known:
            parts.append(f'scale factor {self.fog_scale.value:.10g} counts/rad from '
                         f'{self.fog_scale.source}')
        topic = self.topic or ' or '.join(GYRO_TOPICS)
        return f'input: {topic} ({JOINT_STATE}){rate}' + (f'; {"; ".join(parts)}'
                                                           if parts else '') + '.'

    @staticmethod
    def _bounds(res: AxisResult) -> str:
        fit: NoiseFit | None = res.fit
        if fit is None:
            return ''
        u, parts = res.units, []
        for k, key in enumerate(u.keys):
            upper = fit.upper_bounds.get(key)
            if key in fit.estimates or upper is None:
                continue
            q = u.quoted_factors[k]
            parts.append(f'{SYMBOLS[k]} < {upper:.3g} {u.si_units[k]} ({upper * q:.3g} '
                         f'{u.quoted_units[k]})')
        return ', '.join(parts)

    def summary_lines(self) -> list[str]:
        """The summary lines of a noise run.

        Input and scale factor, the stream counts (re-sorted, duplicates, late, gaps …),
        the terms not resolved with their 2σ bounds, and axes without any term.
        """
        lines = [self._input_line()]
        view = self.view
        if view is None:
            lines.append(f'no samples analysed yet on {self.topic or " or ".join(GYRO_TOPICS)}.')
            return lines
        lines += [c.line() for c in view.stream_counts()]
        motion = view.table_line()
        if motion:
            lines.append(motion)
        scaled = []
        for axis, res in view.axis_results().items():
            if res.fit is None:
                lines.append(f'{axis}: no term — {res.reason}')
                continue
            bounds = self._bounds(res)
            if bounds:
                lines.append(f'{axis}: not resolved (2σ upper bounds): {bounds}.')
            if res.fit.covariance_scale > 1.0:
                scaled.append(f'{axis} (χ² ratio {res.fit.chi2_ratio:.3g})')
            curve = res.curve
            if curve is not None and 'Q' in res.fit.symbols_resolved and self.kind != 'imu':
                lines.append(f'{axis}: quantisation Q shows because the sub-pulse phase moves '
                             '(dither or rotation); a static, locked-in RLG shows none.')
        lines += OutlierReport.lines([res.outliers for res in view.axis_results().values()
                                      if res.outliers is not None])
        if scaled:
            lines.append('the model fits the Allan variance worse than its scatter allows on '
                         f'{", ".join(scaled)}: those uncertainties were scaled up by √ratio.')
        if any(r.fit is not None for r in view.axis_results().values()):
            where = ('imu.noise.<channel> keeps its 2σ bound' if self.kind == 'triad'
                     else 'hand-off missing: with the reason')
            lines.append(f'terms not resolved are absent ({where}); '
                         'gyro-calib info BAG --method noise prints every reason.')
        return lines

    def info_lines(self) -> list[str]:
        """The summary lines and every missing term's full reason."""
        return self.summary_lines() + [f'  {k}: {why}' for k, why in self.missing().items()]

    def limiting(self) -> str:
        """What limits the result most.

        What limits the result most: the reason nothing is measured, else the least
        certain term and the record length behind it.
        """
        results = self.axis_results()
        if not any(r.fit is not None and r.fit.estimates for r in results.values()):
            reasons = [r.reason for r in results.values() if r.reason]
            if reasons:
                return reasons[0]
            return next(iter(self.missing().values()), 'no input for noise characterisation.')
        worst: tuple[float, str, AxisResult] | None = None
        unresolved = 0
        for axis, res in results.items():
            if res.fit is None:
                unresolved += 5
                continue
            unresolved += 5 - len(res.fit.estimates)
            for k, key in enumerate(res.units.keys):
                est = res.fit.estimates.get(key)
                if est is not None and (worst is None or est.relative_uncertainty > worst[0]):
                    worst = (est.relative_uncertainty, f'{axis} {res.units.names[k]}', res)
        assert worst is not None
        rel, label, res = worst
        curve = res.curve
        span = ''
        if curve is not None:
            span = (f'; the longest averaging time is {curve.tau_s[-1]:.3g} s of '
                    f'{curve.n_samples * curve.tau0_s:.4g} s analysed, and a record k× '
                    f'longer narrows it about √k×')
        tail = (f'; {unresolved} term(s) not resolved (a longer record, or the slope is '
                f'not there)' if unresolved else '')
        return f'{label} is known to ±{rel:.1%} (k = 1){span}{tail}.'

    def plot(self, out_dir: Path) -> list[Path]:
        """One PNG with a log-log ADEV panel per axis (``noise_adev.png``)."""
        from gyro_calib.noise.plots import plot_noise_figure

        view = self.view
        if view is None or not view.axes():
            return []
        return [plot_noise_figure(view, out_dir / FIGURE_NAME)]

    def kalibr_left_out(self) -> list[str]:
        """Axes left out of the Kalibr file, one line each with the reason."""
        from gyro_calib.noise.kalibr import kalibr_left_out

        view = self.view
        return kalibr_left_out(view) if view is not None else []

    def kalibr_text(self) -> str:
        """Kalibr ``imu.yaml`` text of an IMU run (largest of the three axes per key).

        Raises:
            ConfigError: the input is a single-axis gyro (Kalibr needs an IMU).
            KalibrExportError: an axis has neither the term nor an upper bound.
        """
        from gyro_calib.noise.kalibr import kalibr_imu_yaml

        if self.kind != 'imu':
            raise ConfigError(f'Kalibr\'s imu.yaml describes an IMU (gyro and accelerometer '
                              f'triads); {self.topic or "the gyro stream"} is a single-axis '
                              'gyro: use --out (hand-off file) or --json instead.')
        view = self.view
        if view is None or not view.axes():
            raise NoNoiseDataError(f'no sample of {self.topic} was analysed: no Kalibr file.')
        assert self.topic is not None
        return kalibr_imu_yaml(view, rostopic=self.topic)
