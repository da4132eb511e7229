"""What an export reads from a hand-off file: noise terms per axis, the triad's M, refusals.

A hand-off (``gyro_calib/handoff/``, formats 1–4) is read here as plain YAML — the
``imu:`` section through :func:`gyro_calib.imu_calibration.imu_from_section` — so that a
triad file (format 4) and a single-gyro file (format 3) give one :class:`ExportSource`:

- gyro noise per body axis x, y, z: a triad's channel along that axis, its noise read as
  imu_corrector reads it (:func:`~gyro_calib.imu_calibration.channel_noise`:
  ``imu.noise.<channel>``, else the noise run's ``imu_gyro_<axis>_<term>``); without an
  ``imu:`` section the noise method's ``imu_gyro_<axis>_<term>`` keys (an IMU's Imu
  stream), else the single gyro's plain keys (one gyro: taken for each axis, and said so);
- accelerometer noise per axis from ``imu_accel_<axis>_<term>`` (noise method on an Imu);
- each term is the measured value, else its ``<key>_upper_bound_2sigma`` (METHODS §E: the
  2σ bound of a term the fit did not resolve), flagged as a bound;
- what the raw stream would still need that only an upstream correction gives (scale factor,
  thermal model, FOG nonlinearity, the triad's M and b), for the ``--stream raw`` refusals.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from gyro_calib.errors import ConfigError
from gyro_calib.imu_calibration import (
    ImuCalibration,
    ImuSectionError,
    NoiseValue,
    channel_noise,
    channel_of_axis,
    imu_from_section,
    with_channel_noise,
)

AXES = ('x', 'y', 'z')
UPPER_BOUND_SUFFIX = '_upper_bound_2sigma'

GYRO_TERMS = {'N': 'angle_random_walk_rad_per_sqrt_s', 'B': 'bias_instability_rad_s',
              'K': 'rate_random_walk_rad_per_s_sqrt_s', 'Q': 'quantization_noise_rad'}
"""Gyro noise terms an export uses (IEEE Std 952; METHODS §E), by symbol."""
ACCEL_TERMS = {'N': 'velocity_random_walk_m_s_per_sqrt_s', 'B': 'bias_instability_m_s2',
               'K': 'acceleration_random_walk_m_s2_per_sqrt_s'}
"""Accelerometer noise terms an export uses, by symbol."""
UNITS = {('gyro', 'N'): 'rad/√s', ('gyro', 'B'): 'rad/s', ('gyro', 'K'): 'rad/s/√s',
         ('gyro', 'Q'): 'rad',
         ('accel', 'N'): 'm/s/√s', ('accel', 'B'): 'm/s²', ('accel', 'K'): 'm/s²/√s'}
NAMES = {'N': 'white-noise density (random walk)', 'B': 'bias instability',
         'K': 'bias random walk', 'Q': 'angle quantisation noise'}

UPSTREAM_KEYS = {
    'scale_factor_rad_per_pulse': 'the pulse scale factor',
    'k_tilde_rad_per_pulse': 'the pulse scale factor',
    'fog_scale_factor_counts_per_rad': 'the FOG scale factor',
    'thermal_model': 'the thermal bias model',
    'fog_nonlinearity_coefficients': 'the FOG scale-factor nonlinearity',
    'coning_drift_rad_s': 'the dither coning drift',
}
"""Hand-off keys no navigation stack takes: applied upstream (imu_corrector) or refused."""


class ExportError(ConfigError):
    """The hand-off cannot be exported to the asked format (one line: what and what to do)."""


@dataclass(frozen=True, slots=True)
class Term:
    """One noise term of one axis as the export uses it.

    Attributes:
        value: SI value (unit of the term key).
        key: where it came from, as written in the hand-off (``gyro.<key>`` or
            ``imu.noise.<channel>.<key>``).
        bound: True when ``value`` is the 2σ upper bound of a term not resolved.
    """

    value: float
    key: str
    bound: bool = False

    def text(self, unit: str) -> str:
        """``<key> = <value> <unit>`` and, for a bound, that it is one."""
        return (f'{self.key} = {self.value:.6g} {unit}'
                + (' (2σ upper bound: the term was not resolved)' if self.bound else ''))


@dataclass(frozen=True, slots=True)
class ExportSource:
    """A hand-off file as the exporters see it (see the module docstring).

    Attributes:
        path: the hand-off file.
        gyro_id: its gyro (or IMU) serial.
        kind: 'triad' (an ``imu:`` section), 'imu' (noise keys of an Imu stream) or 'gyro'
            (a single gyro's plain keys).
        gyro: axis → symbol ('N', 'B', 'K') → Term.
        accel: axis → symbol → Term.
        missing: hand-off key → why it is missing (top level and ``imu.missing``).
        imu: the triad's section, or None.
        upstream: what the raw stream still needs from upstream: (what, key) pairs.
        single_gyro_note: set when one gyro's terms stand for all three axes.
        sample_rate_hz: the noise run's sample rate, 1/τ₀ of its stored curves
            (``methods.noise.deviations``: τ₀ = tau_s[0]/m[0]); None without them.
        count_scale_rad: a single pulse gyro's or FOG's rad per count (K, else K̃, else
            1/SF), whose count quantisation imu_corrector adds to each rate; None otherwise.
    """

    path: str
    gyro_id: str
    kind: str
    gyro: dict[str, dict[str, Term]] = field(default_factory=dict)
    accel: dict[str, dict[str, Term]] = field(default_factory=dict)
    missing: dict[str, str] = field(default_factory=dict)
    imu: ImuCalibration | None = None
    upstream: tuple[tuple[str, str], ...] = ()
    single_gyro_note: str = ''
    sample_rate_hz: float | None = None
    count_scale_rad: float | None = None

    def why(self, key: str) -> str:
        """The hand-off's reason a key is absent, or 'not in the hand-off'."""
        for k in (key, key.removesuffix(UPPER_BOUND_SUFFIX)):
            if k in self.missing:
                return ' '.join(self.missing[k].split()).rstrip('.')
        return 'not in the hand-off'


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    v = float(value)
    return v if math.isfinite(v) and v >= 0 else None


def _term(values: Mapping[str, Any], key: str, where: str) -> Term | None:
    """The term ``key`` of ``values``: its value, else its 2σ upper bound, else None."""
    v = _number(values.get(key))
    if v is not None:
        return Term(v, where + key)
    b = _number(values.get(key + UPPER_BOUND_SUFFIX))
    if b is not None:
        return Term(b, where + key + UPPER_BOUND_SUFFIX, bound=True)
    return None


def _channel_term(noise: Mapping[str, NoiseValue], key: str) -> Term | None:
    """A triad channel's term ``key`` (:func:`~gyro_calib.imu_calibration.channel_noise`)."""
    if key in noise:
        return Term(noise[key].value, noise[key].source_key)
    bound = noise.get(key + UPPER_BOUND_SUFFIX)
    return None if bound is None else Term(bound.value, bound.source_key, bound=True)


def load_yaml_mapping(path: Path) -> dict[str, Any]:
    """The hand-off file as a mapping (one-line refusal otherwise)."""
    try:
        text = path.read_text(encoding='utf-8')
    except FileNotFoundError:
        raise ExportError(f'HANDOFF {path}: no such file; give the hand-off YAML that '
                          'gyro-calib calibrate --out wrote. Nothing was written.') from None
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else 'not UTF-8 text'
        raise ExportError(f'HANDOFF {path}: cannot be read ({why}). Nothing was written.') \
            from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, 'problem_mark', None)
        where = f' (line {mark.line + 1})' if mark is not None else ''
        raise ExportError(f'HANDOFF {path}: not valid YAML{where}. Nothing was written.') \
            from None
    if not isinstance(data, dict) or not ('gyro' in data or 'imu' in data):
        raise ExportError(f'HANDOFF {path}: not a gyro_calib hand-off (no gyro: or imu: '
                          'section). Nothing was written.')
    version = data.get('format_version', 1)
    if version not in (1, 2, 3, 4):
        raise ExportError(f'HANDOFF {path}: format_version {version!r} is not one this '
                          'gyro_calib reads (1–4). Nothing was written.')
    return data


def read_source(path: str | Path) -> ExportSource:
    """Read a hand-off file for export (see the module docstring).

    Raises:
        ExportError: not readable, not a hand-off, or a malformed ``imu:`` section.
    """
    p = Path(path)
    data = load_yaml_mapping(p)
    values = data.get('gyro') or {}
    if not isinstance(values, dict):
        raise ExportError(f'HANDOFF {p}: gyro: must be a mapping. Nothing was written.')
    missing: dict[str, str] = {}
    top = data.get('missing') or {}
    if isinstance(top, dict):
        for k, v in top.items():
            if isinstance(v, str):
                missing[str(k)] = v
            elif isinstance(v, dict):  # format 2: per method
                missing.update({str(kk): str(vv) for kk, vv in v.items()})
    imu: ImuCalibration | None = None
    if data.get('imu') is not None:
        try:
            imu = imu_from_section(data['imu'], source=str(p))
        except ImuSectionError as exc:
            raise ExportError(f'{exc} Nothing was written.') from None
        missing.update({f'imu.{k}': v for k, v in imu.missing.items()})
    gyro: dict[str, dict[str, Term]] = {a: {} for a in AXES}
    accel: dict[str, dict[str, Term]] = {a: {} for a in AXES}
    single = ''
    along = channel_of_axis(imu) if imu is not None else {}
    noise = channel_noise(imu, values) if imu is not None else {}
    for axis in AXES:
        for sym, key in GYRO_TERMS.items():
            term = None
            ch = along.get(axis)
            if imu is not None and ch is not None:
                term = _channel_term(noise[ch], key)
            else:
                term = _term(values, f'imu_gyro_{axis}_{key}', 'gyro.')
            if term is None and imu is None:
                term = _term(values, key, 'gyro.')
                if term is not None:
                    single = ('one gyro was measured: its terms stand for each of the three '
                              'axes (an assumption; measure the IMU for per-axis values)')
            if term is not None:
                gyro[axis][sym] = term
        for sym, key in ACCEL_TERMS.items():
            term = _term(values, f'imu_accel_{axis}_{key}', 'gyro.')
            if term is not None:
                accel[axis][sym] = term
    upstream = [(what, f'gyro.{key}') for key, what in UPSTREAM_KEYS.items() if key in values]
    kind = 'gyro'
    if imu is not None:
        kind = 'triad'
        imu = with_channel_noise(imu, values)  # the noise imu_corrector reads (issue 36 §4)
        if imu.pulses_to_body_rad is not None:
            upstream.append(("the triad's scale factors and axes (M)", 'imu.pulses_to_body_rad'))
        if imu.thermal:
            upstream.append(('the thermal bias model', 'imu.thermal'))
    elif any(k.startswith('imu_') for k in values):
        kind = 'imu'
    gyro_id = str(data.get('gyro_id') or '')
    return ExportSource(str(p), gyro_id, kind, gyro, accel, missing, imu, tuple(upstream),
                        single, _noise_sample_rate(data),
                        _count_scale(values) if kind == 'gyro' else None)


def with_accelerometer_of(src: ExportSource, other: ExportSource) -> ExportSource:
    """``src`` with the accelerometer terms of ``other`` (``export --accel-from``).

    One sensor per hand-off file (a triad's pulse channels in one, the IMU driver's
    sensor_msgs/Imu noise run in another): the export reads the gyro from the first and the
    accelerometer from the second, each term's comment naming its file.

    Raises:
        ExportError: ``other`` holds no accelerometer term, or ``src`` holds its own.
    """
    if not any(other.accel[a] for a in AXES):
        raise ExportError(f'--accel-from {other.path}: it holds no accelerometer term '
                          '(imu_accel_<axis>_…: a gyro-calib noise run on the IMU\'s '
                          'sensor_msgs/Imu topic). Nothing was written.')
    if any(src.accel[a] for a in AXES):
        raise ExportError(f'--accel-from {other.path}: HANDOFF {src.path} holds accelerometer '
                          'terms of its own; give one source of them (drop --accel-from). '
                          'Nothing was written.')
    accel = {a: {sym: dataclasses.replace(t, key=f'{other.path}: {t.key}')
                 for sym, t in other.accel[a].items()} for a in AXES}
    missing = {k: v for k, v in other.missing.items() if k.startswith('imu_accel_')}
    return dataclasses.replace(src, accel=accel, missing={**missing, **src.missing})


def _count_scale(values: Mapping[str, Any]) -> float | None:
    """A single gyro's rad per count (K, else K̃, else 1/SF of a FOG), or None."""
    for key in ('scale_factor_rad_per_pulse', 'k_tilde_rad_per_pulse'):
        v = _number(values.get(key))
        if v:
            return v
    for key in ('fog_scale_factor_counts_per_rad', 'fog_self_cal_scale_factor_counts_per_rad'):
        v = _number(values.get(key))
        if v:
            return 1.0 / v
    return None


def _noise_sample_rate(data: Mapping[str, Any]) -> float | None:
    """1/τ₀ of the noise run's stored curves (τ₀ = tau_s[0]/m[0]), or None."""
    try:
        deviations = data['methods']['noise']['deviations']
        for curve in deviations.values():
            tau0 = float(curve['tau_s'][0]) / float(curve['m'][0])
            if math.isfinite(tau0) and tau0 > 0:
                return 1.0 / tau0
    except (KeyError, TypeError, ValueError, IndexError, AttributeError, ZeroDivisionError):
        return None
    return None


def lower_times_rotation(s: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.float64],
                                                              npt.NDArray[np.float64]]:
    """S = T·R with T lower triangular (positive diagonal) and R a rotation (QR of Sᵀ).

    Raises:
        ExportError: det S ≤ 0 (no rotation R; a reversed channel).
    """
    if not np.linalg.det(s) > 0:
        raise ExportError('the triad matrix has a non-positive determinant (a reversed '
                          'channel): it is not a scale-misalignment times a rotation. Nothing '
                          'was written.')
    q, u = np.linalg.qr(s.T)
    d = np.diag(np.sign(np.diag(u)))
    return np.asarray((d @ u).T, dtype=np.float64), np.asarray((q @ d).T, dtype=np.float64)
