"""OpenVINS ``kalibr_imu_chain.yaml`` (``imu0:``, OpenCV ``%YAML:1.0``; METHODS §E, §F).

Noise densities as Kalibr's (continuous; one per sensor, the largest axis). Intrinsics, the
``kalibr`` model: OpenVINS takes the gyro reading as ω_m = Tw·R_IMUtoGYRO·ω_I + b + n and
keeps the lower triangle of Dw = Tw⁻¹ (VioManagerOptions: the kalibr model), so Tw is
written lower triangular. On the stream imu_corrector compensates (the default) ω_m = ω_B
already: Tw = R_IMUtoGYRO = I. On a triad's raw stream published at a common scale factor
K₀ (ω_m,i = K₀·ṅ_i, ``--raw-scale-rad-per-pulse``) the triad's ω_B = M·ṅ − b gives
ω_m = K₀·M⁻¹·(ω_B + b): Tw·R_IMUtoGYRO = K₀·M⁻¹ (Tw lower triangular), and the bias b is
OpenVINS's to estimate online (it has no initial-bias key). Tw and R_IMUtoGYRO are written
to 17 digits (they round-trip to M bit for bit), and the gyro densities are in the raw
stream's units (METHODS §E.5 eq. (19)): OpenVINS puts its noise on ω_m, before Dw. The
accelerometer intrinsics are not measured here: Ta = R_IMUtoACC = I, Tg = 0, which OpenVINS
reads as "none".
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from gyro_calib.export.common import (
    KALIBR_DENSITIES,
    ExportOptions,
    axis_terms,
    check_stream,
    header,
    largest,
    need_accelerometers,
    need_rate,
    number,
    refuse,
)
from gyro_calib.export.opencv_yaml import opencv_string, with_header
from gyro_calib.export.source import AXES, UNITS, ExportSource, lower_times_rotation
from gyro_calib.imu_calibration import channel_of_axis

FORMAT = 'openvins'
KEYS = ('T_i_b', 'accelerometer_noise_density', 'accelerometer_random_walk',
        'gyroscope_noise_density', 'gyroscope_random_walk', 'rostopic', 'time_offset',
        'update_rate', 'model', 'Tw', 'R_IMUtoGYRO', 'Ta', 'R_IMUtoACC', 'Tg')
"""The ``imu0`` keys OpenVINS's parser asks for."""


def exact(value: float) -> str:
    """17 significant digits: the double OpenCV's strtod reads back is this one, bit for bit."""
    return f'{value:.16e}'


def _rows(name: str, m: npt.NDArray[np.float64], why: str) -> list[str]:
    out = [f'  # {name}: {why}', f'  {name}:']
    out += [f'    - [{", ".join(exact(float(v)) for v in row)}]' for row in m]
    return out


def raw_density(src: ExportSource, tw: npt.NDArray[np.float64], sym: str, key: str
                ) -> tuple[float, str]:
    """The largest channel density in the raw stream's units (METHODS §E.5 eq. (19)).

    Channel i (row i of M, of Tw) publishes ω_m,i = K₀·ṅ_i: its noise N_i/K_i pulses/√s
    becomes N_i·K₀/K_i = N_i·‖row_i(Tw)‖ (R_IMUtoGYRO is a rotation).
    """
    assert src.imu is not None
    terms = axis_terms(src, FORMAT, 'gyro', sym, key)
    by_channel = {ch: terms[AXES.index(axis)] for axis, ch in channel_of_axis(src.imu).items()}
    scales = np.linalg.norm(tw, axis=1)
    values = [(by_channel[ch].value * float(scales[i]), i, ch)
              for i, ch in enumerate(src.imu.channels)]
    value, i, ch = max(values)
    term = by_channel[ch]
    return value, (f'{term.text(UNITS[("gyro", sym)])} × ‖row {i} of Tw‖ = '
                   f'{float(scales[i]):.9g} (channel {ch} in the raw stream\'s units, K0·ṅ; '
                   'largest channel)')


def intrinsics(src: ExportSource, options: ExportOptions) -> tuple[
        npt.NDArray[np.float64], npt.NDArray[np.float64], str]:
    """(Tw, R_IMUtoGYRO, why) for the stream the options name."""
    if options.stream == 'compensated' or src.imu is None or src.imu.pulses_to_body_rad is None:
        return np.eye(3), np.eye(3), ('identity: the stream is compensated upstream'
                                      if options.stream == 'compensated'
                                      else 'identity: the hand-off holds no triad M')
    k0 = options.raw_scale_rad_per_pulse
    if k0 is None or not k0 > 0:
        raise refuse(FORMAT, 'a raw triad stream needs the scale factor its driver publishes '
                     'the channel rates with; give --raw-scale-rad-per-pulse K0.')
    s = np.asarray(k0 * np.linalg.inv(src.imu.pulses_to_body_rad), dtype=np.float64)
    tw, r = lower_times_rotation(s)
    return tw, r, (f'Tw·R_IMUtoGYRO = K0·M⁻¹ (K0 = {k0:.10g} rad/pulse, M = '
                   'imu.pulses_to_body_rad), Tw lower triangular')


def topic_string(fmt: str, topic: str) -> str:
    """The topic as an OpenCV string (quoted), or a one-line refusal."""
    try:
        return opencv_string(topic)
    except ValueError:
        raise refuse(fmt, f'--topic {topic!r} is not a ROS topic name (a quote, backslash or '
                     'line break); give the topic as ROS names it.') from None


def openvins_text(src: ExportSource, options: ExportOptions) -> str:
    """The OpenVINS ``kalibr_imu_chain.yaml`` text with its ``%YAML:1.0`` header."""
    check_stream(src, FORMAT, options, intrinsics=True)
    need_accelerometers(src, FORMAT, options, 'accelerometer_noise_density')
    tw, r, why = intrinsics(src, options)
    raw = (options.stream == 'raw' and src.imu is not None
           and src.imu.pulses_to_body_rad is not None)
    values = []
    for key, sensor, sym, unit in KALIBR_DENSITIES:
        value, text = largest(src, FORMAT, sensor, sym, key)
        if raw and sensor == 'gyro':
            value, text = raw_density(src, tw, sym, key)
        values.append(f'  {key}: {number(value)}  # {unit}; {text}; continuous density')
    rate, rate_from = need_rate(src, FORMAT, options, 'update_rate')
    lines = header(src, FORMAT, options)
    lines += ['imu0:']
    lines += _rows('T_i_b', np.eye(4), 'identity: the IMU frame is the body frame')
    lines += values
    lines += [f'  rostopic: {topic_string(FORMAT, options.topic)}',
              '  time_offset: 0.0  # s; not measured by gyro_calib',
              f'  update_rate: {rate:.6f}  # Hz; {rate_from}',
              '  # model: OpenVINS keeps the lower triangle of Dw = Tw⁻¹ (kalibr model)',
              f'  model: {opencv_string("kalibr")}']
    lines += _rows('Tw', tw, why)
    lines += _rows('R_IMUtoGYRO', r, why)
    lines += _rows('Ta', np.eye(3), 'identity: accelerometer intrinsics not measured')
    lines += _rows('R_IMUtoACC', np.eye(3), 'identity: not measured')
    lines += _rows('Tg', np.zeros((3, 3)), 'zero: g-sensitivity not measured')
    return with_header('\n'.join(lines) + '\n')
