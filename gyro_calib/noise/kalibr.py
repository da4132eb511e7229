"""Kalibr ``imu.yaml`` from the measured noise terms.

Kalibr's IMU noise model (ethz-asl/kalibr wiki, "IMU Noise Model"; the ``imu.yaml``
format) has, per sensor, a continuous-time white noise of strength σ (E[n(t₁)n(t₂)] =
σ²δ(t₁ − t₂)) and a bias driven by white noise of strength σ_b (a random walk). On the
Allan deviation these are exactly IEEE 952's N (−½ slope, σ(1 s)) and K (+½ slope,
σ(3 s)), so:

=================================  ======================  ==============================
Kalibr key                         Kalibr unit             our term (same SI value)
=================================  ======================  ==============================
``gyroscope_noise_density``        rad/s/√Hz               angle_random_walk_rad_per_sqrt_s
``gyroscope_random_walk``          rad/s²/√Hz              rate_random_walk_rad_per_s_sqrt_s
``accelerometer_noise_density``    m/s²/√Hz                velocity_random_walk_m_s_per_sqrt_s
``accelerometer_random_walk``      m/s³/√Hz                acceleration_random_walk_m_s2_per_sqrt_s
``update_rate``                    Hz                      measured mean sample rate
``rostopic``                       —                       the Imu topic
=================================  ======================  ==============================

(rad/√s = rad/s/√Hz and rad/s/√s = rad/s²/√Hz.) Each value is the largest over the three
axes — the conservative choice Kalibr users make. An axis whose term is not resolved
contributes its 2σ upper bound from the joint fit instead (a comment in the file says so):
over-stating noise only makes Kalibr trust the IMU less, under-stating it biases the
calibration. Bias instability has no Kalibr key (Kalibr models no flicker); it is noted in
a comment.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from gyro_calib.errors import InsufficientDataError
from gyro_calib.noise.terms import ACCEL_UNITS, GYRO_UNITS, SYMBOLS

if TYPE_CHECKING:
    from gyro_calib.noise.calibrator import NoiseCalibrator
    from gyro_calib.noise.terms import TermUnits


KALIBR_MARK = 'Kalibr IMU noise parameters from gyro_calib noise'
"""The words the first line of ``noise --kalibr``'s imu.yaml carries (by them ``noise
--kalibr`` and ``export --format kalibr --out`` recognise a file they may replace)."""


class KalibrExportError(InsufficientDataError):
    """The Kalibr imu.yaml cannot be written: a required noise term is not available."""


def _axis_value(cal: NoiseCalibrator, axis: str, units: TermUnits,
                symbol: str) -> tuple[float, str] | None:
    """(value, note) of one term on one axis: the estimate, or its 2σ upper bound."""
    res = cal.axis_result(axis)
    if res.fit is None:
        return None
    k = SYMBOLS.index(symbol)
    est = res.fit.estimates.get(units.keys[k])
    if est is not None:
        return est.value, ''
    upper = res.fit.upper_bounds.get(units.keys[k], 0.0)
    if not upper > 0:
        return None
    return upper, f'{axis}: 2σ upper bound (not resolved)'


def _largest(cal: NoiseCalibrator, prefix: str, units: TermUnits,
             symbol: str, kalibr_key: str) -> tuple[float, str]:
    """The largest value over the measured axes.

    The largest value over the measured axes; axes without one (dead, constant, too
    short) are left out and named in the comment. Raises if no axis has a value.
    """
    axes = [a for a in cal.axes() if a.startswith(prefix + '_')]
    values = []
    left_out = []
    for axis in axes:
        v = _axis_value(cal, axis, units, symbol)
        if v is None:
            left_out.append(axis)
            continue
        values.append((v[0], v[1], axis))
    if not values:
        why = (f'{", ".join(left_out)} not measured; {left_out[0]}: '
               f'{cal.axis_result(left_out[0]).reason or "no fit"}') if left_out else ''
        raise KalibrExportError(f'cannot write {kalibr_key} for Kalibr: no {prefix} axis has '
                                f'a {units.names[SYMBOLS.index(symbol)]} or an upper bound'
                                + (f' ({why})' if why else ' (an Imu stream is needed)'))
    value, note, axis = max(values)
    comment = note if note else f'largest of {len(values)} axes ({axis})'
    if left_out:
        comment += f'; left out: {", ".join(left_out)} (not measured, see the header)'
    return value, comment


def kalibr_left_out(cal: NoiseCalibrator) -> list[str]:
    """One line per axis left out of the Kalibr file (no N and K, nor bounds), with why."""
    out = []
    for axis in cal.axes():
        units = GYRO_UNITS if axis.startswith('gyro') else ACCEL_UNITS
        if any(_axis_value(cal, axis, units, s) is None for s in ('N', 'K')):
            res = cal.axis_result(axis)
            why = res.reason or 'its noise terms were not measured'
            out.append(f'{axis} left out of the Kalibr file: {why}')
    return out


def kalibr_imu_yaml(cal: NoiseCalibrator, *, rostopic: str,
                    update_rate_hz: float | None = None) -> str:
    """The text of a Kalibr ``imu.yaml`` (keys at top level; see module docstring).

    Raises:
        KalibrExportError: an axis has neither the term nor an upper bound for it.
    """
    gn = _largest(cal, 'gyro', GYRO_UNITS, 'N', 'gyroscope_noise_density')
    gk = _largest(cal, 'gyro', GYRO_UNITS, 'K', 'gyroscope_random_walk')
    an = _largest(cal, 'accel', ACCEL_UNITS, 'N', 'accelerometer_noise_density')
    ak = _largest(cal, 'accel', ACCEL_UNITS, 'K', 'accelerometer_random_walk')
    rate = update_rate_hz if update_rate_hz is not None else cal.sample_rate_hz('gyro_x')
    if not (math.isfinite(rate) and rate > 0):
        raise KalibrExportError('cannot write update_rate for Kalibr: the sample rate is not '
                                'known (no Imu samples analysed).')
    lines = [
        f'# {KALIBR_MARK} (Allan deviation, joint fit to',
        '# IEEE Std 952 Annex C). Each value is the largest of the measured axes.',
        *(f'# {line}' for line in kalibr_left_out(cal)),
        '# noise_density = angle/velocity random walk N; random_walk = rate/acceleration',
        '# random walk K. Bias instability has no Kalibr key (see the noise report).',
        f'accelerometer_noise_density: {an[0]:.6e}  # m/s^2/sqrt(Hz); {an[1]}',
        f'accelerometer_random_walk: {ak[0]:.6e}  # m/s^3/sqrt(Hz); {ak[1]}',
        f'gyroscope_noise_density: {gn[0]:.6e}  # rad/s/sqrt(Hz); {gn[1]}',
        f'gyroscope_random_walk: {gk[0]:.6e}  # rad/s^2/sqrt(Hz); {gk[1]}',
        f'rostopic: {rostopic}',
        f'update_rate: {rate:.6f}  # Hz',
    ]
    return '\n'.join(lines) + '\n'


def write_kalibr_imu_yaml(path: str | Path, cal: NoiseCalibrator, *, rostopic: str,
                          update_rate_hz: float | None = None) -> Path:
    """Write the Kalibr ``imu.yaml`` atomically (temporary file, fsync, rename).

    Returns:
        The absolute path written. Nothing is written (an old file stays) on error.

    Raises:
        KalibrExportError: a required term is missing, or the file cannot be written.
    """
    text = kalibr_imu_yaml(cal, rostopic=rostopic, update_rate_hz=update_rate_hz)
    from gyro_calib.outputs import write_text_atomically

    target = Path(path).absolute()
    try:
        write_text_atomically(target, text)
    except OSError as exc:
        raise KalibrExportError(f'cannot write the Kalibr file {target}: '
                                f'{exc.strerror}.') from None
    return target
