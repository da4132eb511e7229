"""``gyro-calib compensate``: apply a gyro's thermal bias model to a bag (METHODS §D, §E).

    gyro-calib compensate BAG [BAG ...] --calibration FILE [--out BAG2] [--json] [--plot DIR]
                          [--gyro-id ID] [--skip-out-of-range] [--block-s 100]

Needs nothing but the hand-off file: its ``thermal_model`` carries the scale factor the model
was fitted with, the averaging interval and Ḣ window, the calibrated range, the site and the
gyro id. The bag(s) must hold /gyro/pulses and /gyro/temperature; they are streamed (bounded
memory) and reduced exactly as the calibration reduced its run. Reported (the unfiltered
rate throughout; :func:`gyro_calib.thermal.compensate.compensate`):

- ``bias_stability_raw_rad_s``: std of consecutive ``--block-s`` (100 s) means of K·ΔN/Δt;
- ``bias_stability_compensated_rad_s``: the same of raw − model;
- ``mean_rate_compensated_rad_s``: mean of raw − model (on a static base the Earth rate
  along the sense axis, printed beside it);
- ``bias_stability_noise_floor_rad_s``: what angle random walk and pulse quantisation alone
  give for 100 s means — the compensated figure cannot honestly go below it;
- the overlapping Allan deviation of the interval rates before and after.

``--out BAG2`` writes a copy of the (single) bag with the compensated rate added on
``/gyro/imu`` (sensor_msgs/Imu, one message per pulse sample after the first, stamped with
its later sample, log time = that pulse message's; angular_velocity.z = K·Δn/Δt − b with b
the model's bias of the averaging interval holding the sample's midpoint, and the variance
imu_corrector gives; no message where the model gives no bias). Exit status as
``gyro-calib calibrate``: 0 done, 2 bad input (one line naming what was wrong); on any
failure nothing is written.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import json
import math
import struct
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from gyro_calib.errors import ConfigError
from gyro_calib.estimate import Estimate
from gyro_calib.registry import IMU, JOINT_STATE, TEMPERATURE
from gyro_calib.thermal.compensate import (
    CompensatedPair,
    CompensationReducer,
    CompensationReport,
    check_identity,
    compensate_reduced,
    pairs_with_bias,
)
from gyro_calib.thermal.model import ThermalBiasModel
from gyro_calib.thermal.site import RAD_S_PER_DEG_H
from gyro_calib.thermal.topics import GYRO_IMU, GYRO_PULSES, GYRO_TEMPERATURE
from gyro_calib.units import format_stamp

TOPICS = {GYRO_PULSES: JOINT_STATE, GYRO_TEMPERATURE: TEMPERATURE}
RESULT_KEYS = ('bias_stability_raw_rad_s', 'bias_stability_compensated_rad_s',
               'bias_stability_noise_floor_rad_s', 'mean_rate_compensated_rad_s')


def add_commands(subparsers: Any) -> None:
    """Add ``compensate`` to the ``gyro-calib`` subcommands."""
    p = subparsers.add_parser(
        'compensate', help='apply a thermal bias model to bags: bias stability before/after, '
        'noise floor, Allan deviation; --out writes the compensated rate',
        description=__doc__.split('\n\n')[0])
    p.add_argument('bags', nargs='+', type=Path, metavar='BAG',
                   help='rosbag2 MCAP bag(s) with /gyro/pulses and /gyro/temperature')
    p.add_argument('--calibration', type=Path, required=True, metavar='FILE',
                   help='the hand-off file holding thermal_model (gyro-calib calibrate BAG '
                   '--method thermal --out FILE)')
    p.add_argument('--out', type=Path, metavar='BAG2', help='write a copy of the bag with the '
                   f'compensated rate on {GYRO_IMU} (sensor_msgs/Imu); must not exist')
    p.add_argument('--json', action='store_true', help='print one JSON document on stdout '
                   '(the human summary goes to stderr)')
    p.add_argument('--plot', type=Path, metavar='DIR', help='write PNG figures into DIR '
                   '(created if absent, in an existing directory)')
    p.add_argument('--gyro-id', default='', help='the recorded gyro (default: the bench '
                   'settings stored in the bag); a model of another gyro is refused')
    p.add_argument('--skip-out-of-range', action='store_true',
                   help='leave intervals outside the calibrated range (plus margin) '
                   'uncompensated and list them, instead of refusing the bag')
    p.add_argument('--block-s', type=float, default=100.0,
                   help='bias-stability block, s (default 100, docs/methods.md §E eq. (12))')
    p.set_defaults(run=run_compensate)


@dataclasses.dataclass(frozen=True, slots=True)
class BagCompensation:
    """A compensated recording: the figures, the model, and what the file gave.

    Attributes:
        report: the figures (:class:`CompensationReport`).
        model: the thermal model applied.
        pulse_calibration: K, ARW and the model as the Imu conversion uses them.
        gyro_id: the recording's gyro id ('' = unknown).
        bags: the bag paths.
    """

    report: CompensationReport
    model: ThermalBiasModel
    pulse_calibration: Any
    gyro_id: str
    bags: tuple[Path, ...]


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
    infos = [bag_info(p) for p in paths]
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
    for _, batch in iter_bags([i.path for i in infos], TOPICS, batch_messages=batch_messages):
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
    from gyro_calib.bag_calibration import own_bags
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
    benches: list[tuple[str, dict[str, Any]]] = []
    for info in own:
        bench = info.scenario.get('bench')
        benches.append((str(info.path), bench if isinstance(bench, dict) else {}))
    options = CalibrationOptions(stored_benches=tuple(benches))
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


# ----------------------------------------------------------------------------- --out


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
    info = bag_info(src)
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


# ------------------------------------------------------------------------ reporting


def _est(e: Estimate) -> dict[str, Any]:
    return {'value': e.value, 'std': e.std_uncertainty, 'n': e.n_used}


def json_document(result: BagCompensation) -> dict[str, Any]:
    """The ``--json`` document of ``compensate``.

    The ``--json`` document, in the shape every command shares (README, ``gyro_calib/
    schema/result.schema.json``): ``methods.thermal.{results, missing, rejections}`` plus
    the compensation's figures, model and notes (rates in rad/s; NaN → null).
    """
    from gyro_calib.thermal.session import finite_json

    r = result.report
    fl = r.noise_floor
    m = result.model
    document: dict[str, Any] = finite_json({'command': 'compensate', 'methods': {'thermal': {
        'results': {k: _est(e) for k, e in r.results().items()},
        'missing': {},
        'rejections': [f'{format_stamp(x.stamp_ns)}: {x.reason}' for x in r.rejections],
        'earth_rate_along_axis_rad_s': r.earth_rate_along_axis_rad_s,
        'improvement': r.improvement,
        'noise_floor': {'bias_stability_rad_s': _est(fl.floor),
                        'angle_random_walk_rad_per_sqrt_s': fl.angle_random_walk_rad_per_sqrt_s,
                        'quantisation_rad': fl.quantisation_rad, 'block_s': fl.block_s},
        'allan_deviation': {'tau_s': r.adev_tau_s.tolist(), 'raw_rad_s': r.adev_raw_rad_s.tolist(),
                            'compensated_rad_s': r.adev_compensated_rad_s.tolist()},
        'block_s': r.block_s,
        'model': {'gyro_id': m.gyro_id, 'terms': list(m.terms),
                  'calibrated_h_c': list(m.h_range_c),
                  'extrapolation_margin_c': m.extrapolation_margin_c,
                  'scale_factor_rad_per_pulse': m.scale_factor_rad_per_pulse},
        'gyro_id': result.gyro_id,
        'notes': list(r.notes)}},
        'bags': [str(b) for b in result.bags],
    })
    return document


def summary_text(result: BagCompensation, calibration_file: Path) -> str:
    """The human summary: figures in °/h and rad/s, the Allan deviation, notes, rejections."""
    r, m = result.report, result.model
    d = RAD_S_PER_DEG_H
    lines = [f'== compensate: {", ".join(str(b) for b in result.bags)} with the thermal model of '
             f'gyro {m.gyro_id or "(unnamed)"} from {calibration_file}',
             f'model: bias = b0 + {" + ".join(m.terms) or "(constant)"}; calibrated H '
             f'{m.h_range_c[0]:.2f}…{m.h_range_c[1]:.2f} °C ± {m.extrapolation_margin_c:g} °C; '
             f'K = {m.scale_factor_rad_per_pulse!r} rad/pulse']
    rows = [('quantity', '°/h', 'rad/s', 'std (°/h)', 'n')]
    for key, est in r.results().items():
        rows.append((key, f'{est.value / d:.5f}', f'{est.value:.6g}',
                     f'{est.std_uncertainty / d:.2g}', str(est.n_used)))
    widths = [max(len(row[i]) for row in rows) for i in range(5)]
    lines += ['  '.join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
    raw, comp = r.bias_stability_raw.value, r.bias_stability_compensated.value
    floor = r.noise_floor.floor.value
    arw_deg_sqrt_h = r.noise_floor.angle_random_walk_rad_per_sqrt_s / (math.pi / 10800)
    excess = 1 - math.sqrt(max(comp**2 - floor**2, 0.0)) / math.sqrt(max(raw**2 - floor**2,
                                                                          1e-300))
    lines.append(f'Earth rate along the sense axis: {r.earth_rate_along_axis_rad_s / d:.5f} °/h '
                 f'(the compensated mean rate on a static base).')
    lines.append(f'bias stability ({r.block_s:g} s means of the unfiltered rate): '
                 f'{raw / d:.4f} → {comp / d:.4f} °/h, {r.improvement:.1%} better; the noise '
                 f'floor (ARW {arw_deg_sqrt_h:.4f} °/√h and pulse quantisation) allows '
                 f'{floor / d:.4f} °/h, so {excess:.1%} of the thermal excess above it was '
                 'removed.')
    if len(r.adev_tau_s):
        lines.append('Allan deviation (°/h):   τ (s)      raw   compensated')
        for target in (1.0, 10.0, 100.0, 1000.0, 3000.0):
            i = int(np.argmin(np.abs(np.log(r.adev_tau_s / target))))
            if abs(math.log(r.adev_tau_s[i] / target)) < 0.5:
                lines.append(f'  {r.adev_tau_s[i]:20.0f} {r.adev_raw_rad_s[i] / d:9.4f} '
                             f'{r.adev_compensated_rad_s[i] / d:9.4f}')
    lines += [f'note: {n}' for n in r.notes]
    for rej in r.rejections:
        lines.append(f'  rejected at {format_stamp(rej.stamp_ns)}: {rej.reason}')
    return '\n'.join(lines)


def run_compensate(args: argparse.Namespace) -> int:
    """``gyro-calib compensate``: exit status 0, or a GyroCalibError for main() to print."""
    from gyro_calib.outputs import (
        check_new_directory,
        check_plot_dir,
        write_failed,
        write_figures,
    )

    if args.out is not None:
        check_new_directory(args.out, '--out')
    plot_dir = check_plot_dir(args.plot) if args.plot is not None else None
    if args.out is not None and len(args.bags) != 1:
        raise ConfigError('--out writes a copy of one bag: give a single BAG with it.')
    result = compensate_bags(args.bags, args.calibration, gyro_id=args.gyro_id,
                             block_s=args.block_s,
                             out_of_range='skip' if args.skip_out_of_range else 'raise')
    human = io.StringIO()  # out once the files are written: a failed write prints one line
    print(summary_text(result, args.calibration), file=human)
    doc = json_document(result)
    if args.out is not None:
        try:
            written, without = write_compensated_bag(result, args.out,
                                                     calibration_file=args.calibration)
        except OSError as exc:  # the bag is written whole (a .partial directory) or not
            raise write_failed(exc, '--out', args.out) from None
        print(f'compensated bag written: {args.out.resolve()} ({written} {GYRO_IMU} messages'
              + (f'; {without} pulse samples without a model bias got none' if without else '')
              + ')', file=human)
        doc['out'] = {'bag': str(args.out.resolve()), 'topic': GYRO_IMU,
                      'type': IMU, 'messages': written, 'samples_without_bias': without}
    if plot_dir is not None:
        from gyro_calib.thermal.plots import plot_compensation

        try:
            figures = write_figures(plot_dir, lambda stage: plot_compensation(result.report,
                                                                              stage))
        except OSError as exc:
            raise write_failed(exc, '--plot', plot_dir,
                               [f'--out {args.out}'] if args.out is not None else []) from None
        for path in figures:
            print(f'figure written: {path.resolve()}', file=human)
    (sys.stderr if args.json else sys.stdout).write(human.getvalue())
    if args.json:
        print(json.dumps(doc, indent=1, allow_nan=False))
    return 0
