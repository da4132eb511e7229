"""One sensor per hand-off file: what sensor a record or a file describes.

A hand-off file is one sensor's: a single-axis gyro (top-level ``gyro:`` keys), a gyro triad
(the ``imu:`` section of a triad's pulse channels, ``/imu/pulses``) or an IMU read from
``sensor_msgs/Imu`` (the noise method's ``imu_<axis>_…`` keys, six axes, and the multiposition
method's ``imu:`` section: the gyro in the triad's layout with ``imu.accelerometer`` beside
it, :data:`IMU_SECTION_METHODS`). A noise run also says its sample rate (1/τ₀ of its stored
curves). A single-axis gyro is of one technology: a ring-laser gyro's pulse
output (the rbrlg, dither and thermal methods, noise from ``/gyro/pulses``) or a fibre-optic
gyro's closed-loop counts (the fog method, noise from ``/fog/output``). :func:`another_sensor`
names, in one line, what differs between a run and the file it would be merged into (sensor
kind, gyro technology, channels, sample rate), so that a MEMS IMU's noise run never lands in
a triad's file, an RBRLG run never in a triad's, a triad run never in a single gyro's, nor a
FOG run in an RLG's (or the other way round).

The sample rate is compared between noise runs only: their terms (and the curves they rest
on) are of the output stream at that rate, through that output's own filter (a 100-Hz output
decimated from a 400-Hz core bends the short-τ curve), so two noise runs at other rates are
two outputs, not one to replace the other. A calibration's parameters (scale, misalignment,
bias: a multiposition run at 50 Hz) are the sensor's, not its output rate's: the same IMU
recorded at 50 Hz for the poses and at 200 Hz lying still for its noise is one sensor, and
its noise run goes into the calibration's file (docs/multiposition.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from gyro_calib.handoff.runs import CalibrationLike
from gyro_calib.handoff.schema import _base_key

SINGLE_GYRO, TRIAD, IMU = 'a single-axis gyro', 'a gyro triad', 'an IMU (sensor_msgs/Imu)'
"""The sensor kinds a hand-off file may describe."""

IMU_KEY_PREFIX = 'imu_'
"""The noise method's per-axis keys of an IMU: ``imu_<axis>_<term key>``."""

RLG, FOG = 'RLG, pulse output', 'FOG, closed-loop counts'
"""The technologies of a single-axis gyro (what its output counts are)."""

PULSE_METHODS = ('rbrlg', 'dither', 'thermal')
"""The methods of a ring-laser gyro's pulse output (``/gyro/pulses``)."""

COUNTS_METHODS = ('fog',)
"""The methods of a fibre-optic gyro's closed-loop counts (``/fog/output``)."""

IMU_SECTION_METHODS = ('multiposition',)
"""The methods whose ``imu:`` section is an IMU's read from ``sensor_msgs/Imu`` (or its
table files): a MEMS IMU's gyro in the triad's layout, its accelerometer beside it."""

SAMPLE_RATE_TOLERANCE = 0.01
"""Relative difference of two noise runs' sample rates above which they are two sensors."""


@dataclass(frozen=True, slots=True)
class Sensor:
    """What sensor a record describes.

    Attributes:
        kinds: :data:`SINGLE_GYRO`, :data:`TRIAD`, :data:`IMU` (a file written before this
            check may hold more than one).
        channels: the triad's channel names (``imu.channels``), or ().
        sample_rate_hz: the noise run's sample rate (1/τ₀ of its curves), or None.
        technologies: :data:`RLG`, :data:`FOG` (a file written before this check may hold
            both), or none (a triad, an IMU, a record that does not say).
    """

    kinds: frozenset[str]
    channels: tuple[str, ...] = ()
    sample_rate_hz: float | None = None
    technologies: frozenset[str] = frozenset()

    def words(self) -> str:
        """The sensor in a phrase: kind, technology, channels, sample rate."""
        text = ' and '.join(sorted(self.kinds)) or 'no sensor'
        if self.technologies:
            text += f' ({"; ".join(sorted(self.technologies))})'
        if self.channels:
            text += f' (channels {", ".join(self.channels)})'
        if self.sample_rate_hz is not None:
            text += f' sampled at {self.sample_rate_hz:.6g} Hz'
        return text


def _keys(calibration: CalibrationLike) -> set[str]:
    """Every key the record gives or names as missing (a run of curves alone gives none)."""
    keys = {_base_key(k) for k in calibration.values}
    for prov in calibration.methods.values():
        keys |= set(prov.missing) | set(prov.not_measurable)
    return keys


def noise_sample_rate_hz(deviations: Mapping[str, Mapping[str, Any]]) -> float | None:
    """The sample rate 1/τ₀ of a noise run's stored curves (τ₀ = τ[0]/m[0]), Hz, or None."""
    for table in deviations.values():
        taus, ms = table.get('tau_s'), table.get('m')
        if isinstance(taus, (list, tuple)) and isinstance(ms, (list, tuple)) and taus and ms:
            try:
                tau0 = float(taus[0]) / float(ms[0])
            except (TypeError, ValueError, ZeroDivisionError):
                continue
            if tau0 > 0 and math.isfinite(tau0):
                return 1.0 / tau0
    return None


def technologies_of(calibration: CalibrationLike) -> frozenset[str]:
    """The gyro technologies a record's runs and keys say (:data:`RLG`, :data:`FOG`)."""
    found = set()
    for method, prov in calibration.methods.items():
        if method in PULSE_METHODS:
            found.add(RLG)
        elif method in COUNTS_METHODS:
            found.add(FOG)
        elif method == 'noise':  # its input says: /gyro/pulses (K) or /fog/output (SF)
            topic = str(prov.settings.get('topic', '') or '')
            if topic.endswith('/fog/output') or 'fog_scale_factor_counts_per_rad' in \
                    prov.conditions:
                found.add(FOG)
            elif topic.endswith('/gyro/pulses') or 'scale_factor_rad_per_pulse' in \
                    prov.conditions:
                found.add(RLG)
    keys = {_base_key(k) for k in calibration.values}
    if any(k.startswith('fog_') for k in keys):
        found.add(FOG)
    if keys & {'k_tilde_rad_per_pulse', 'scale_factor_rad_per_pulse', 'fix_error_angle_rad'}:
        found.add(RLG)
    return frozenset(found)


def imu_section_is_an_imus(calibration: CalibrationLike) -> bool:
    """True when the record's ``imu:`` section is an IMU's (sensor_msgs/Imu), not a triad's.

    The multiposition method's section (:data:`IMU_SECTION_METHODS`) holds the gyro in the
    triad's layout with the accelerometer beside it (``imu.accelerometer``); a pulse triad's
    section has no accelerometer and comes from the triad method.
    """
    imu = calibration.imu
    return imu is not None and (bool(imu.accelerometer)
                                or any(m in IMU_SECTION_METHODS for m in calibration.methods))


def sensor_of(calibration: CalibrationLike) -> Sensor:
    """The sensor a record (a run, or a file's content) describes."""
    kinds = set()
    keys = _keys(calibration)
    imus_section = imu_section_is_an_imus(calibration)
    if calibration.imu is not None:
        kinds.add(IMU if imus_section else TRIAD)
    if any(k.startswith(IMU_KEY_PREFIX) for k in keys):
        kinds.add(IMU)
    if any(not k.startswith(IMU_KEY_PREFIX) for k in keys):
        kinds.add(SINGLE_GYRO)
    noise = calibration.methods.get('noise')
    axes = tuple(noise.deviations) if noise is not None else ()
    channels = (tuple(calibration.imu.channels)
                if calibration.imu is not None and not imus_section else ())
    if not kinds and axes:  # a run of curves alone: its axes say the sensor
        if any(a.startswith(('gyro_', 'accel_')) for a in axes):
            kinds.add(IMU)
        elif len(axes) == 3:  # a triad's curves are per channel (/imu/pulses names)
            kinds.add(TRIAD)
            channels = axes
        else:  # one axis, 'gyro'
            kinds.add(SINGLE_GYRO)
    rate = noise_sample_rate_hz(noise.deviations) if noise is not None else None
    return Sensor(frozenset(kinds), channels, rate, technologies_of(calibration))


def another_sensor(run: CalibrationLike, older: CalibrationLike) -> str | None:
    """Why ``run`` is of another sensor than the file ``older``, in one phrase, or None.

    Another kind (a single gyro, a triad, an IMU), another gyro technology (an RLG's pulses,
    a FOG's counts), other triad channels, or another sample rate of the noise runs (by
    more than :data:`SAMPLE_RATE_TOLERANCE`).
    """
    new, old = sensor_of(run), sensor_of(older)
    if not new.kinds or not old.kinds:
        return None
    differs: list[str] = []
    if not new.kinds <= old.kinds:
        differs.append('sensor kind')
    if new.technologies and old.technologies and not new.technologies <= old.technologies:
        differs.append('gyro technology')
    if new.channels and old.channels and set(new.channels) != set(old.channels):
        differs.append('channels')
    if (new.sample_rate_hz is not None and old.sample_rate_hz is not None
            and abs(new.sample_rate_hz - old.sample_rate_hz)
            > SAMPLE_RATE_TOLERANCE * old.sample_rate_hz):
        differs.append('sample rate')
    if not differs:
        return None
    verb = 'differ' if len(differs) > 1 else 'differs'
    return (f'another sensor ({", ".join(differs)} {verb}): the file holds {old.words()}, '
            f'this run is of {new.words()}')
