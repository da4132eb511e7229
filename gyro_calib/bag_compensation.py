"""``gyro-calib compensate``'s driver: a gyro's thermal bias model applied to bags (§D, §E).

:func:`compensate_bags` streams the bags (bounded memory) through the hand-off file's
``thermal_model`` and reduces them exactly as the calibration reduced its run
(:mod:`gyro_calib.thermal.compensate`); :func:`write_compensated_bag` writes a copy of the
(single) bag with the compensated rate added on ``/gyro/imu`` (sensor_msgs/Imu, one message
per pulse sample after the first, stamped with its later sample, log time = that pulse
message's; angular_velocity.z = K·Δn/Δt − b with b the model's bias of the averaging
interval holding the sample's midpoint, and the variance imu_corrector gives; no message
where the model gives no bias).
"""

from __future__ import annotations

import dataclasses
import math
import struct
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib.errors import ConfigError
from gyro_calib.registry import IMU, JOINT_STATE, TEMPERATURE
from gyro_calib.thermal.compensate import (
    CompensatedPair,
    CompensationReducer,
    check_identity,
    compensate_reduced,
    pairs_with_bias,
)
from gyro_calib.thermal.compensation_summary import BagCompensation
from gyro_calib.thermal.topics import GYRO_IMU, GYRO_PULSES, GYRO_TEMPERATURE

TOPICS = {GYRO_PULSES: JOINT_STATE, GYRO_TEMPERATURE: TEMPERATURE}


def compensate_bags(paths: Sequence[Path], calibration_file: Path, *, gyro_id: str = '',
                    block_s: float = 100.0, out_of_range: str = 'raise',
                    batch_messages: int = 50_000) -> BagCompensation:
    """Stream the bags through the file's thermal model and report the figures.

    Raises:
        HandoffError: the file is unreadable or invalid.
        ConfigError: the file holds no thermal_model, or a bad ``block_s``.
        BagError (subclass): a missing path, not a bag, a missing topic, a wrong type.
        ModelMismatchError: a model of another gyro or K; TemperatureDataError,
            ExtrapolationError, InsufficientDataError: as
            :func:`gyro_calib.thermal.compensate.compensate`.
    """
    from gyro_calib.bag_calibration import merged_topics
    from gyro_calib.bagio import bag_info, check_topics, iter_bags
    from gyro_calib.handoff import load_calibration
    from gyro_calib.imu_conversion import pulse_calibration, thermal_model

    if not (math.isfinite(block_s) and block_s > 0):
        raise ConfigError(f'--block-s = {block_s!r} is invalid: it must be a positive number of '
                          'seconds.')
    calibration = load_calibration(calibration_file)
    model = thermal_model(calibration)
    if model is None:
        raise ConfigError(f'{calibration_file} holds no thermal_model: calibrate a chamber run '
                          f'first (gyro-calib calibrate BAG --method thermal --out '
                          f'{calibration_file}).')
    infos = [bag_info(p, recover=False) for p in paths]  # it copies bags: whole ones only
    where = infos[0] if len(infos) == 1 else dataclasses.replace(
        infos[0], path=Path(' + '.join(str(i.path) for i in infos)),
        topics={k: v for i in infos for k, v in i.topics.items()},
        message_count=sum(i.message_count for i in infos))
    merged_topics(infos)
    check_topics(where, TOPICS, tuple(TOPICS), what='gyro-calib compensate')
    recorded, k_bag = _stored_identity(infos, gyro_id)
    check_identity(model, gyro_id=recorded,
                   scale_factor_rad_per_pulse=float(k_bag) if k_bag is not None else None)
    pcal = pulse_calibration(calibration, gyro_id=recorded)
    reducer = CompensationReducer(model)
    for _, batch in iter_bags([i.path for i in infos], TOPICS, batch_messages=batch_messages,
                              recover=False):
        pulses = batch.joint_state(GYRO_PULSES)
        if pulses is not None:
            reducer.extend_pulses(pulses[0], pulses[1])
        temps = batch.columns.get(GYRO_TEMPERATURE)
        if temps is not None and len(temps.stamp_ns):
            frame = temps.frame_id
            ids = np.asarray(frame.names, dtype=str)[frame.codes] if len(frame.names) else \
                np.full(len(temps.stamp_ns), '')
            reducer.extend_temperatures(temps.stamp_ns, temps.values['temperature_degc'], ids)
        reducer.process()
    reducer.process(flush=True)
    report = compensate_reduced(reducer, gyro_id=recorded, block_s=block_s,
                                out_of_range=out_of_range)
    return BagCompensation(report, model, pcal, recorded, tuple(i.path for i in infos))


def _stored_identity(infos: Sequence[Any], gyro_id: str) -> tuple[str, Any]:
    """The recording's gyro id and stored K.

    (the recording's gyro id, its stored K or None) from the bench settings stored with the
    chamber run's own bags (those holding its pulses and temperatures), never another bag's.

    Raises:
        ConfigError: a bag that is not the chamber run's (it lacks the thermal topics while
            another holds them); the bags store different gyro ids (``--gyro-id`` decides) or
            different K (compensate them separately), naming the setting and the bags.
    """
    from gyro_calib.bag_calibration import own_bags, stored_benches
    from gyro_calib.registry import METHODS
    from gyro_calib.session import CalibrationOptions

    own = own_bags(METHODS['thermal'], infos)
    mine = {id(i) for i in own}
    others = [str(i.path) for i in infos if id(i) not in mine]
    if others:
        raise ConfigError(f'{", ".join(others)}: not part of the chamber run (no '
                          f'{" and ".join(TOPICS)} in it, while {own[0].path} holds them); '
                          'gyro-calib compensate reads the pulses and temperatures of one run: '
                          'give its bags only.')
    options = CalibrationOptions(stored_benches=stored_benches(own))
    try:
        if not gyro_id:
            gyro_id = str(options.bench('gyro_id', '') or '')
        k_bag = options.bench('scale_factor_rad_per_pulse', None)
    except ConfigError as exc:  # compensate has no K flag: the model's K decides
        raise ConfigError(str(exc).replace(
            'give --scale-factor-rad-per-pulse (or calibrate the bags separately)',
            'compensate the bags separately').replace(
            '(or calibrate the bags separately)', '(or compensate the bags separately)')
        ) from None
    return gyro_id, k_bag


def _pulse_samples(path: Path) -> Iterator[tuple[int, float]]:
    from gyro_calib.bagio import iter_sample_batches

    for batch in iter_sample_batches(path, {GYRO_PULSES: JOINT_STATE}):
        js = batch.joint_state(GYRO_PULSES)
        if js is not None:
            yield from zip(js[0].tolist(), js[1].tolist())


class _ImuMessages:
    """sensor_msgs/Imu CDR as imu_corrector publishes it.

    sensor_msgs/Imu CDR as imu_corrector publishes it (x, y unknown; no orientation,
    no acceleration).
    """

    def __init__(self, frame_id: str) -> None:
        from gyro_calib.bagio import ContractMessages

        self.store = ContractMessages().store
        t = self.store.types
        self._imu, self._header, self._time = (t[IMU], t['std_msgs/msg/Header'],
                                               t['builtin_interfaces/msg/Time'])
        self._quat, self._vec = t['geometry_msgs/msg/Quaternion'], t['geometry_msgs/msg/Vector3']
        self.frame_id = frame_id
        self._unavailable = np.zeros(9)
        self._unavailable[0] = -1.0

    def cdr(self, out: Any) -> bytes:
        sec, nsec = divmod(int(out.stamp_ns), 1_000_000_000)
        x, y, z = out.angular_velocity_rad_s
        msg = self._imu(
            header=self._header(stamp=self._time(sec=sec, nanosec=nsec), frame_id=self.frame_id),
            orientation=self._quat(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=self._unavailable.copy(),
            angular_velocity=self._vec(x=x, y=y, z=z),
            angular_velocity_covariance=np.array(out.covariance_rad2_s2, dtype=np.float64),
            linear_acceleration=self._vec(x=0.0, y=0.0, z=0.0),
            linear_acceleration_covariance=self._unavailable.copy())
        return bytes(self.store.serialize_cdr(msg, IMU))


def write_compensated_bag(result: BagCompensation, out: Path, *, calibration_file: Path,
                          frame_id: str = 'gyro') -> tuple[int, int]:
    """Copy the bag to ``out`` with the compensated rate on /gyro/imu (module docstring).

    Returns:
        (Imu messages written, pulse samples left without one).

    Raises:
        ConfigError: more than one input bag. BagError: ``out`` exists, or the bag's pulse
            stream does not read back as it did.
    """
    from gyro_calib.bagio import BagError, BagMessage, bag_info, iter_raw_messages, write_bag
    from gyro_calib.imu_conversion import angular_velocity_from_pulses

    if len(result.bags) != 1:
        raise ConfigError('--out writes a copy of one bag: give a single BAG with it.')
    src = result.bags[0]
    info = bag_info(src, recover=False)
    rep = result.report
    tint = int(round(result.model.averaging_interval_s * 1e9))
    k0 = int(rep.t_mid_ns[0]) // tint
    bias, bias_std = rep.bias_model_rad_s, rep.bias_model_std_rad_s
    pcal = result.pulse_calibration
    imu = _ImuMessages(frame_id)
    counts = {'written': 0, 'without': 0}

    def messages() -> Iterator[BagMessage]:
        samples = _pulse_samples(src)
        read: list[int] = []

        def checked() -> Iterator[tuple[int, float]]:
            for t_ns, count in samples:
                read.append(t_ns)
                yield t_ns, count

        pairs = pairs_with_bias(checked(), k0, tint, bias, bias_std)
        for topic, _, log_ns, cdr in iter_raw_messages(src):
            if topic == GYRO_IMU:
                continue  # replaced
            yield BagMessage(topic, log_ns, cdr)
            if topic != GYRO_PULSES:
                continue
            pair = next(pairs)
            sec, nsec = struct.unpack_from('<iI', cdr, 4)  # header.stamp opens the body
            if sec * 1_000_000_000 + nsec != read[-1]:
                raise BagError(f'{src}: the pulse messages did not read back in the same order '
                               'as their columns; nothing written.')
            if pair is None:
                continue
            if not isinstance(pair, CompensatedPair):
                counts['without'] += 1
                continue
            cal = dataclasses.replace(pcal, bias_rad_s=pair.bias_rad_s, bias_std=pair.bias_std)
            out_msg = angular_velocity_from_pulses(pair.t0_ns, pair.count0, pair.t1_ns,
                                                   pair.count1, cal)
            counts['written'] += 1
            yield BagMessage(GYRO_IMU, log_ns, imu.cdr(out_msg))

    scenario = dict(info.scenario)
    scenario['thermal_compensation'] = {
        'source_bag': str(src), 'calibration_file': str(calibration_file),
        'gyro_id': result.model.gyro_id, 'terms': list(result.model.terms),
        'topic': GYRO_IMU}
    types = {t.name: t.msgtype for t in info.topics.values()}
    types[GYRO_IMU] = IMU
    write_bag(out, messages(), types=types, scenario=scenario)
    return counts['written'], counts['without']
