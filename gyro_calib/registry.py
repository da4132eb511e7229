"""The methods gyro_calib calibrates: one entry each, the one place the front door looks.

``gyro-calib calibrate`` and ``info``, the bag calibration and the hand-off file go through
:data:`METHODS`: for each method its name, the input topics that reveal it in a bag, its
session (the streaming calibrator behind the shared interface, imported only when used) and
its hand-off keys. Adding a method touches its subpackage, its simulator, its node and one
entry here.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

from gyro_calib import topics
from gyro_calib.bagio.messages import HEADER, IMU, JOINT_STATE, TEMPERATURE
from gyro_calib.handoff.schema import install_default_schema

if TYPE_CHECKING:
    from gyro_calib.handoff import HandoffKey
    from gyro_calib.session import CalibrationOptions, MethodSession

__all__ = ['HEADER', 'IMU', 'JOINT_STATE', 'METHODS', 'TEMPERATURE', 'Method', 'handoff_schema',
           'methods_revealed', 'topic_types']


@dataclasses.dataclass(frozen=True, slots=True)
class Method:
    """One calibration method.

    Attributes:
        name: the name users give to ``--method``.
        title: one line for listings.
        topics: topic → message type the method reads.
        reveal: topics that must all be in a bag for the method to run on it.
        session: 'module:Class' of its :class:`~gyro_calib.session.MethodSession`.
        keys: 'module' whose ``HANDOFF_KEYS`` are its hand-off keys.
        auto: runs on every bag that reveals it when no ``--method`` is given (False: only
            when asked, e.g. noise characterisation, which any gyro stream would reveal).
        separate_bags: several bags are separate runs (e.g. one per mounting orientation),
            fed one after the other with :meth:`MethodSession.start_bag` between them, even when
            their stamps overlap; otherwise bags recorded at the same time are interleaved.
        any_topic: a message type the method also reads on any topic the user names
            (``--topic``; noise: ``sensor_msgs/Imu``), '' if none.
        node: its live node's name (the key of its ROS 2 parameter files).
        settings: 'module:Class' of its settings dataclass (node parameters, ``--config``).
        handoff_lead: a key every other key of the method goes with when a hand-off file is
            updated (one fit: a newer run replaces them all, or keeps them all), '' = none.
        bench_settings: the bench settings (:data:`gyro_calib.config.BENCH_SETTINGS`) it
            uses; the bench settings stored with its own bags must agree on these.
        context: topics among ``topics`` read beside an input when they are there, never an
            input themselves (noise: the rate and position tables, whose motion is left out).
        needs: input topic → what else a run from it needs, in words (noise from a triad's
            ``/imu/pulses``: each channel's K_i from ``--calibration``), for listings.
    """

    name: str
    title: str
    topics: Mapping[str, str]
    reveal: tuple[str, ...]
    session: str
    keys: str
    auto: bool = True
    separate_bags: bool = False
    any_topic: str = ''
    node: str = ''
    settings: str = ''
    bench_settings: tuple[str, ...] = ()
    handoff_lead: str = ''
    context: tuple[str, ...] = ()
    needs: Mapping[str, str] = dataclasses.field(default_factory=dict)

    def inputs(self) -> dict[str, str]:
        """Topic → type of the topics it can run from (``topics`` without ``context``)."""
        return {t: m for t, m in self.topics.items() if t not in self.context}

    def make_session(self, options: CalibrationOptions) -> MethodSession:
        """A new session of this method with the user's options."""
        from gyro_calib.session import run_settings

        module, cls = self.session.split(':')
        session: MethodSession = getattr(importlib.import_module(module), cls)(options)
        session.run_settings = run_settings(options)
        return session

    def settings_class(self) -> type:
        """Its settings dataclass."""
        module, cls = self.settings.split(':')
        return getattr(importlib.import_module(module), cls)  # type: ignore[no-any-return]

    def settings_fields(self) -> tuple[str, ...]:
        """The fields of its settings dataclass."""
        return tuple(f.name for f in dataclasses.fields(self.settings_class()))

    def settings_defaults(self) -> dict[str, Any]:
        """Each field of its settings dataclass with its default (the node parameter's)."""
        from gyro_calib.config import field_defaults

        return field_defaults(self.settings_class())

    def handoff_keys(self) -> tuple[HandoffKey, ...]:
        """The keys this method may write to the hand-off file."""
        keys = tuple(importlib.import_module(self.keys).HANDOFF_KEYS)
        if not self.handoff_lead:
            return keys
        return tuple(k if k.name == self.handoff_lead or k.follows
                     else dataclasses.replace(k, follows=self.handoff_lead) for k in keys)


_RATE_TABLE = (topics.RATE_TABLE_JOINT_STATES, topics.RATE_TABLE_ZERO_INDEX)
"""The rate table's encoder and zero-index topics (revealing rbrlg and triad with the gyro's)."""
_TWO_AXIS_BENCH = {topics.RATE_TABLE_JOINT_STATES: JOINT_STATE,
                   topics.RATE_TABLE_ZERO_INDEX: HEADER,
                   topics.POSITION_TABLE_JOINT_STATES: JOINT_STATE,
                   topics.POSITION_TABLE_ZERO_INDEX: HEADER}
"""The two-axis bench's topics (rate table, position table) the rbrlg and triad methods read."""

METHODS: dict[str, Method] = {m.name: m for m in (
    Method('rbrlg', 'rate-biased RLG: K̃, θ, K = K̃·cos θ, bias (docs/methods.md §A)',
           {topics.GYRO_PULSES: JOINT_STATE, **_TWO_AXIS_BENCH},
           (topics.GYRO_PULSES, *_RATE_TABLE),
           'gyro_calib.rbrlg.session:RbrlgSession', 'gyro_calib.rbrlg.keys',
           node='calibration_node', settings='gyro_calib.rbrlg.config:KTildeConfig',
           bench_settings=('latitude_deg', 'heading_deg', 'position_table_revolutions',
                           'gyro_id')),
    Method('fog', 'FOG scale factor: turntable (IEEE Std 952) and ladder-wave self-calibration '
           '(docs/methods.md §B)',
           {topics.FOG_OUTPUT: JOINT_STATE, topics.FOG_INJECTION: JOINT_STATE,
            topics.RATE_TABLE_JOINT_STATES: JOINT_STATE, topics.RATE_TABLE_ZERO_INDEX: HEADER},
           (topics.FOG_OUTPUT,),
           'gyro_calib.fog.session:FogSession', 'gyro_calib.fog.keys',
           node='fog_calibration_node', settings='gyro_calib.fog.settings:FogSettings',
           bench_settings=('latitude_deg', 'gyro_id')),
    Method('dither', 'dither-axis misalignment of a dithered RLG and its coning drift '
           '(docs/methods.md §C)',
           {topics.GYRO_PULSES: JOINT_STATE, topics.VIBRATION_TABLE_JOINT_STATES: JOINT_STATE},
           (topics.GYRO_PULSES, topics.VIBRATION_TABLE_JOINT_STATES),
           'gyro_calib.dither.session:DitherSession', 'gyro_calib.dither.keys',
           separate_bags=True, node='dither_calibration_node',
           settings='gyro_calib.dither.settings:DitherSettings',
           bench_settings=('scale_factor_rad_per_pulse', 'gyro_id'),
           handoff_lead='dither_axis_misalignment_rad'),
    Method('thermal', 'temperature bias model: lifting-wavelet denoising, stepwise regression '
           '(docs/methods.md §D)',
           {topics.GYRO_PULSES: JOINT_STATE, topics.GYRO_TEMPERATURE: TEMPERATURE},
           (topics.GYRO_PULSES, topics.GYRO_TEMPERATURE),
           'gyro_calib.thermal.session:ThermalSession', 'gyro_calib.thermal.keys',
           node='thermal_calibration_node',
           settings='gyro_calib.thermal.settings:ThermalSettings',
           bench_settings=('scale_factor_rad_per_pulse', 'latitude_deg',
                           'sense_axis_elevation_deg', 'sense_axis_azimuth_deg', 'gyro_id'),
           handoff_lead='thermal_model'),
    Method('noise', 'noise characterisation: Allan deviation, IEEE 952 terms, Kalibr imu.yaml '
           '(docs/methods.md §E)',
           {topics.GYRO_PULSES: JOINT_STATE, topics.FOG_OUTPUT: JOINT_STATE,
            topics.IMU_PULSES: JOINT_STATE, topics.RATE_TABLE_JOINT_STATES: JOINT_STATE,
            topics.POSITION_TABLE_JOINT_STATES: JOINT_STATE},
           (), 'gyro_calib.noise.session:NoiseSession', 'gyro_calib.noise.keys', auto=False,
           any_topic=IMU, node='noise_node',
           settings='gyro_calib.noise.settings:NoiseSettings',
           bench_settings=('scale_factor_rad_per_pulse', 'fog_scale_factor_counts_per_rad',
                           'gyro_id'),
           context=(topics.RATE_TABLE_JOINT_STATES, topics.POSITION_TABLE_JOINT_STATES),
           needs={topics.IMU_PULSES: 'needs --calibration FILE, a triad hand-off with K_i of '
                  'each channel'}),
    Method('triad', 'gyro triad (IMU): K, sense axes and M of three gyros, biases, on the '
           'two-axis bench or by remounting (docs/methods.md §F)',
           {topics.IMU_PULSES: JOINT_STATE, **_TWO_AXIS_BENCH},
           (topics.IMU_PULSES, *_RATE_TABLE),
           'gyro_calib.triad.session:TriadSession', 'gyro_calib.triad.keys',
           separate_bags=True, node='triad_calibration_node',
           settings='gyro_calib.triad.session:TriadSettings',
           bench_settings=('latitude_deg', 'heading_deg', 'position_table_revolutions',
                           'tilt_deg', 'tilt_std_arcsec', 'station_offset_deg', 'gyro_id')),
    Method('multiposition', 'IMU without a turntable: accelerometer and gyro scale, '
           'misalignment and bias from static poses and the turns between them '
           '(docs/methods.md §G)',
           {}, (), 'gyro_calib.multiposition.session:MultipositionSession',
           'gyro_calib.multiposition.keys', auto=False, any_topic=IMU,
           node='multiposition_calibration_node',
           settings='gyro_calib.multiposition.settings:MultipositionSettings',
           bench_settings=('latitude_deg', 'gyro_id')),
)}
"""Every method, by name."""


@functools.cache
def handoff_schema() -> dict[str, HandoffKey]:
    """Every hand-off key of every method, by key name (the loader's schema)."""
    out: dict[str, HandoffKey] = {}
    for method in METHODS.values():
        for key in method.handoff_keys():
            if key.name in out:
                raise RuntimeError(f'hand-off key {key.name} is claimed by {out[key.name].method} '
                                   f'and {key.method}')
            out[key.name] = key
    return out


install_default_schema(handoff_schema)  # the loader's default, handed down


def methods_revealed(topic_types: Mapping[str, str]) -> list[Method]:
    """The automatic methods whose revealing topics are all present (with their types)."""
    return [m for m in METHODS.values() if m.auto and m.reveal
            and all(topic_types.get(t) == m.topics[t] for t in m.reveal)]


def topic_types(methods: Iterable[Method]) -> dict[str, str]:
    """Topic → type of everything the given methods read."""
    out: dict[str, str] = {}
    for m in methods:
        out.update(m.topics)
    return out
