"""Shared pieces of the format writers: options, the terms a consumer needs, comments.

METHODS §E.5 eqs. (15)–(19). Every number an exporter writes carries a comment: the
hand-off key it came from, its value in our (SI) units and the conversion (N in rad/√s is a
continuous density in rad/s/√Hz; K in rad/s/√s is rad/s²/√Hz; a per-sample variance at rate
f is N²·f). Bias instability B is never written where a random walk belongs (it is a flicker
floor, not a random walk); a term the fit did not resolve is replaced by its 2σ upper bound,
and the comment says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gyro_calib import topics
from gyro_calib.export.names import export_mark
from gyro_calib.export.source import (
    ACCEL_TERMS,
    AXES,
    GYRO_TERMS,
    NAMES,
    UNITS,
    ExportError,
    ExportSource,
    Term,
)
from gyro_calib.imu_body_rate import channel_arw, count_rate_variances, rounding_variances
from gyro_calib.imu_calibration import ImuCalibration

KALIBR_DENSITIES = (('accelerometer_noise_density', 'accel', 'N', 'm/s^2/sqrt(Hz)'),
                    ('accelerometer_random_walk', 'accel', 'K', 'm/s^3/sqrt(Hz)'),
                    ('gyroscope_noise_density', 'gyro', 'N', 'rad/s/sqrt(Hz)'),
                    ('gyroscope_random_walk', 'gyro', 'K', 'rad/s^2/sqrt(Hz)'))
"""Kalibr's continuous noise densities (Kalibr, OpenVINS): (key, sensor, term, unit)."""


@dataclass(frozen=True, slots=True)
class ExportOptions:
    """What the hand-off does not say and a consumer needs.

    Attributes:
        rate_hz: the IMU's sample rate the consumer receives, Hz (discrete covariances,
            update_rate); None if not given.
        topic: the sensor_msgs/Imu topic the consumer subscribes to; '' (the default): the
            one gyro_calib's imu_corrector publishes for this hand-off (:func:`default_topic`).
        stream: one of :data:`~gyro_calib.export.names.STREAMS`.
        raw_scale_rad_per_pulse: ``raw`` triad stream only: the driver's common scale factor
            K₀ (its rate is K₀·Δn/Δt per channel), rad/pulse.
        accel_topic: the IMU driver's sensor_msgs/Imu topic whose accelerometers
            imu_corrector passes through (its ``accel_input``); '' = none.
        accel_from: another hand-off file (a noise run on the IMU driver's sensor_msgs/Imu)
            whose accelerometer terms the export takes; '' = the hand-off's own.
    """

    rate_hz: float | None = None
    topic: str = ''
    stream: str = 'compensated'
    raw_scale_rad_per_pulse: float | None = None
    accel_topic: str = ''
    accel_from: str = ''


def accelerometers_on_stream(src: ExportSource, options: ExportOptions) -> bool:
    """Whether the stream the consumer reads carries the IMU's accelerometers.

    The driver's raw stream does, and so does imu_corrector's Imu mode (an IMU hand-off:
    the driver's Imu in, its accelerometers passed through; a multiposition hand-off, whose
    ``imu.accelerometer`` imu_corrector applies to them); its pulse modes (a single gyro,
    a triad) do only when given the driver's Imu as ``accel_input`` (``--accel-topic``).
    """
    return (options.stream == 'raw' or src.kind == 'imu' or has_accelerometer_part(src)
            or bool(options.accel_topic))


def has_accelerometer_part(src: ExportSource) -> bool:
    """Whether the hand-off's ``imu:`` section is an IMU's: the gyro with ``imu.accelerometer``.

    A multiposition calibration (docs/multiposition.md): imu_corrector with the IMU driver's
    Imu (``imu_input``) publishes its rates and its accelerations corrected.
    """
    return src.imu is not None and bool(src.imu.accelerometer)


def need_accelerometers(src: ExportSource, fmt: str, options: ExportOptions,
                        consumer_key: str) -> None:
    """Refuse, in one line naming what to set, a stream without accelerometers (issue 36 §3).

    A hand-off without accelerometer terms is refused first (:func:`axis_terms`).

    Raises:
        ExportError: the consumer needs accelerometers and the hand-off has no accelerometer
            term, or the stream carries none.
    """
    axis_terms(src, fmt, 'accel', 'N', consumer_key)
    if accelerometers_on_stream(src, options):
        return
    raise refuse(fmt, f'{CONSUMER_NAMES.get(fmt, fmt)} needs accelerometers, and '
                 f'{options.topic or default_topic(src, options)} from imu_corrector carries '
                 'none (a pulse gyro has none of its own): start imu_corrector with -p '
                 'accel_input:=YOUR_IMU_DRIVER_TOPIC and export with --accel-topic '
                 'YOUR_IMU_DRIVER_TOPIC.')
STILL_TO_ADD: dict[str, tuple[tuple[str, str], ...]] = {
    'vins-fusion': (
        ('g_norm', 'absent, VINS-Fusion reads 0 and runs without gravity '
                   '(vins_estimator/src/estimator/parameters.cpp:102)'),
        ('num_of_cam', 'parameters.cpp:142'), ('body_T_cam0', 'parameters.cpp:135'),
        ('cam0_calib', 'parameters.cpp:156'), ('image0_topic', 'parameters.cpp:82')),
    'fast-lio': (
        ('mapping.extrinsic_T', '3 numbers; an absent list is indexed unchecked '
                                '(laserMapping.cpp:870, 895)'),
        ('mapping.extrinsic_R', '9 numbers, likewise (laserMapping.cpp:871, 896)'),
        ('common.lid_topic', 'and the preprocess: block of your LiDAR')),
    'lio-sam': (
        ('sensor', 'velodyne, ouster or livox (default ouster; utility.hpp:190)'),
        ('extrinsicTrans', 'LiDAR→IMU, default zero'),
        ('extrinsicRot', 'default identity'), ('extrinsicRPY', 'default identity'),
        ('N_SCAN', 'and Horizon_SCAN of your LiDAR')),
}
"""Keys a fragment's consumer needs that only the user knows: named on the file's first line."""

CONSUMER_NAMES = {'kalibr': 'Kalibr imu.yaml', 'openvins': 'OpenVINS kalibr_imu_chain.yaml',
                  'gtsam': 'GTSAM preintegration parameters',
                  'lio-sam': 'LIO-SAM params.yaml', 'fast-lio': 'FAST-LIO config',
                  'vins-fusion': 'VINS-Fusion config',
                  'autoware': 'Autoware imu_corrector.param.yaml',
                  'robot-localization': 'robot_localization ekf parameters'}


def completeness_line(fmt: str) -> str:
    """The file's first line: COMPLETE, or FRAGMENT naming the keys the user must still add."""
    name = CONSUMER_NAMES.get(fmt, fmt)
    keys = STILL_TO_ADD.get(fmt)
    if not keys:
        return (f'COMPLETE {name}: every key the consumer requires is here; use the file as '
                'it is.')
    return (f'FRAGMENT of a {name}: merge these keys into yours (gyro-calib export '
            '--merge-into YOUR_FILE), which must still set: '
            + '; '.join(f'{k} ({why})' for k, why in keys) + '.')


def default_topic(src: ExportSource, options: ExportOptions) -> str:
    """The topic the consumer subscribes to when --topic is not given.

    On the compensated stream, the one imu_corrector publishes for this hand-off:
    ``/gyro/imu`` for a single gyro, ``/imu/data`` for a triad (or an IMU's noise run); on
    the raw stream ``/imu/data`` (the driver's usual name).
    """
    if options.topic:
        return options.topic
    if options.stream == 'compensated' and src.kind == 'gyro':
        return topics.GYRO_IMU
    return topics.IMU_DATA


def refuse(fmt: str, message: str) -> ExportError:
    """The one-line refusal of format ``fmt``."""
    return ExportError(f'export --format {fmt}: {message} Nothing was written.')


def need_rate(src: ExportSource, fmt: str, options: ExportOptions,
              what: str) -> tuple[float, str]:
    """The sample rate and where it came from (--rate-hz, else the noise run's), or a refusal."""
    if options.rate_hz is not None:
        return options.rate_hz, '--rate-hz'
    if src.sample_rate_hz is not None:
        return src.sample_rate_hz, 'the noise run\'s sample rate, 1/τ₀ of methods.noise.deviations'
    raise refuse(fmt, f'{what} needs the IMU sample rate and the hand-off does not hold it '
                 f'(no noise run\'s curves); give --rate-hz HZ (the rate of {options.topic}).')


def axis_terms(src: ExportSource, fmt: str, sensor: str, sym: str,
               consumer_key: str) -> list[Term]:
    """The term ``sym`` of each axis of ``sensor`` ('gyro' or 'accel'), or a refusal."""
    table = src.gyro if sensor == 'gyro' else src.accel
    terms = GYRO_TERMS if sensor == 'gyro' else ACCEL_TERMS
    out = []
    for axis in AXES:
        term = table[axis].get(sym)
        if term is None:
            key = f'imu_{sensor}_{axis}_{terms[sym]}'
            if sensor == 'gyro' and src.kind == 'gyro':
                key = terms[sym]
            if sensor == 'accel' and not any(table[a] for a in AXES):
                raise refuse(fmt, f'{consumer_key} needs the accelerometer {NAMES[sym]} '
                             f'({key} with the other axes), and this hand-off has no '
                             'accelerometer term (a gyro-only calibration); run gyro-calib '
                             'noise on the IMU\'s sensor_msgs/Imu topic with --out IMU.yaml (a '
                             'file of its own: one sensor per file) and export again with '
                             '--accel-from IMU.yaml. No zeros are written in its place.')
            raise refuse(fmt, f'{consumer_key} needs {key} (the {sensor} {NAMES[sym]}, or its '
                         f'{key}_upper_bound_2sigma): {src.why(key)}.')
        out.append(term)
    return out


def largest(src: ExportSource, fmt: str, sensor: str, sym: str,
            consumer_key: str) -> tuple[float, str]:
    """The largest term over the three axes (a consumer with one scalar), and its comment."""
    terms = axis_terms(src, fmt, sensor, sym, consumer_key)
    best = max(terms, key=lambda t: t.value)
    distinct = len({t.key for t in terms}) > 1
    where = ' (largest of the three axes)' if distinct else ''
    return best.value, best.text(UNITS[(sensor, sym)]) + where


def gyro_sample_variance(src: ExportSource, fmt: str, consumer_key: str, rate_hz: float
                         ) -> tuple[float, str]:
    """Per-sample variance of the rate at f: N²·f + 2·Q²·f² (rad/s)² (§E.5 eq. (16)).

    The angle quantisation Q of a pulse gyro adds 2·Q²·f² to each rate sample (its rate PSD
    (4Q²/τ₀)·sin²(πfτ₀) integrated over the band); a dithered RLG's Q can dominate N²·f by
    orders of magnitude. Q is taken where the hand-off holds it (or its 2σ bound); a single
    gyro's hand-off without it gets the count quantisation imu_corrector publishes, K²·f²/6
    (2·Q² with Q = K/√12). A triad's is imu_corrector's M·C_ṅ·Mᵀ (:func:`triad_sample_variance`).
    """
    n, why = largest(src, fmt, 'gyro', 'N', consumer_key)
    if src.imu is not None and src.imu.pulses_to_body_rad is not None:
        return triad_sample_variance(src.imu, rate_hz)
    variance = n * n * rate_hz
    text = f'({why}) squared × f'
    q_terms = [src.gyro[a]['Q'] for a in AXES if 'Q' in src.gyro[a]]
    if q_terms:
        q = max(q_terms, key=lambda t: t.value)
        variance += 2.0 * q.value ** 2 * rate_hz ** 2
        text += f' + 2·({q.text(UNITS[("gyro", "Q")])})² × f² (angle quantisation per sample)'
    elif src.count_scale_rad is not None:
        k = src.count_scale_rad
        variance += k * k * rate_hz ** 2 / 6.0
        text += (f' + ({k:.6g} rad/count)² × f²/6 (the count quantisation imu_corrector adds '
                 'to each rate, imu_conversion eq. (2))')
    return variance, text



def triad_sample_variance(imu: ImuCalibration, rate_hz: float) -> tuple[float, str]:
    """The largest diagonal of M·C_ṅ·Mᵀ at f: what imu_corrector publishes (METHODS §F.6 eq.

    (17)) at rest, less the bias's own u²(b) and M's uncertainty (not sample noise): each
    channel's N_i (read as imu_corrector reads it) and the 1/6 pulse² quantisation of a
    count difference.
    """
    m = np.asarray(imu.pulses_to_body_rad, dtype=float)
    k = 1.0 / np.linalg.norm(np.linalg.inv(m), axis=1)
    arw = np.array([channel_arw(imu.noise.get(c, {})) for c in imu.channels])
    rounding_pulses2 = rounding_variances(imu, k)
    c_n = count_rate_variances(1.0 / rate_hz, k, arw, rounding_pulses2)
    variance = float(np.max(np.diag(m @ np.diag(c_n) @ m.T)))
    rounding = ('the count quantisation 1/6 pulse² × (K_i·f)²' if rounding_pulses2 is None else
                'the angle quantisation 2·Q_i²·f² (an IMU\'s rates: no count rounding)')
    text = (f'largest diagonal of M·C_ṅ·Mᵀ, the covariance imu_corrector publishes (METHODS '
            f'§F.6 eq. (17)): N_i = {", ".join(f"{v:.6g}" for v in arw)} rad/√s of channels '
            f'{", ".join(imu.channels)} squared × f, with {rounding}')
    return variance, text


def bias_instability_notes(src: ExportSource) -> list[str]:
    """Comment lines: the bias instability measured, and that it is not written."""
    lines = []
    q_terms = [src.gyro[a]['Q'] for a in AXES if 'Q' in src.gyro[a]]
    if q_terms:
        best = max(q_terms, key=lambda t: t.value)
        lines.append(f'gyro angle quantisation {best.text(UNITS[("gyro", "Q")])}: a continuous '
                     'density cannot hold it; a per-sample variance adds 2·Q²·f² '
                     '(discrete consumers: written there).')
    for sensor, table in (('gyro', src.gyro), ('accel', src.accel)):
        terms = [table[a]['B'] for a in AXES if 'B' in table[a]]
        if terms:
            best = max(terms, key=lambda t: t.value)
            lines.append(f'{sensor} bias instability {best.text(UNITS[(sensor, "B")])} is '
                         'a flicker floor, not a random walk: not written in any random-walk '
                         'key.')
    return lines


def check_stream(src: ExportSource, fmt: str, options: ExportOptions, *,
                 intrinsics: bool = False) -> None:
    """Refuse a raw stream carrying what the consumer cannot represent.

    With ``intrinsics`` (OpenVINS) the triad's M is representable, the rest is not.
    """
    if options.stream == 'compensated':
        return
    cannot = [(what, key) for what, key in src.upstream
              if not (intrinsics and key == 'imu.pulses_to_body_rad')]
    if cannot:
        what, key = cannot[0]
        raise refuse(fmt, f'{fmt} cannot represent {what} ({key}) on the raw stream; feed it '
                     'the stream imu_corrector compensates upstream (--stream compensated).')


def header(src: ExportSource, fmt: str, options: ExportOptions,
           lines: Sequence[str] = ()) -> list[str]:
    """The comment block every file starts with."""
    stream = ('the stream compensated upstream by gyro_calib imu_corrector (scale factor, '
              'axes, bias and thermal model removed there)' if options.stream == 'compensated'
              else 'the sensor driver\'s raw stream')
    if options.stream == 'compensated' and has_accelerometer_part(src):
        stream = ('the stream of gyro_calib imu_corrector\'s Imu mode with this multiposition '
                  'calibration (-p imu_input:=YOUR_IMU_DRIVER_TOPIC: ω = M·ω_raw − b and '
                  'a = A·r − b_a of each message of the driver)')
    elif options.stream == 'compensated' and src.kind == 'imu':
        stream = ('the stream of gyro_calib imu_corrector\'s Imu mode (-p imu_input:='
                  'YOUR_IMU_DRIVER_TOPIC: the driver\'s rates with this noise run\'s '
                  'per-sample covariance, its accelerometers passed through)')
    out = [completeness_line(fmt),
           f'{fmt} parameters from gyro_calib hand-off {src.path}'
           + (f' (gyro_id {src.gyro_id})' if src.gyro_id else '')
           + f'; {export_mark(fmt)}',
           f'Input: {options.topic}, {stream}'
           + (f'; accelerometers passed through from {options.accel_topic} '
              '(imu_corrector accel_input)' if options.accel_topic and options.stream ==
              'compensated' else '') + '.',
           'Each number: the hand-off key it comes from, its value in SI, the conversion.']
    if src.single_gyro_note:
        out.append(src.single_gyro_note + '.')
    out += list(lines)
    out += bias_instability_notes(src)
    return ['# ' + line for line in out]


def number(value: float) -> str:
    """A float YAML and OpenCV both read as a float (a dot in the mantissa)."""
    text = f'{value:.6e}'
    return text
