"""A gyro triad's calibration: the hand-off's ``imu:`` section (format 4; METHODS §F).

The layout (every number SI, unit in the key; ``_std`` the standard uncertainty, k = 1)::

    imu:
      channels: [x, y, z]                  # /imu/pulses JointState names, in row order
      fixture_rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
                                           # F: v_B = F·v_T, body frame from the inner table
      scale_factor_rad_per_pulse: [Kx, Ky, Kz]          # K_i = 1/|r_i| (§F eq. (10))
      scale_factor_rad_per_pulse_std: [...]
      scale_factor_rad_per_pulse_dof: [...]             # optional: ν per channel (.inf)
      sense_axes: [[...], [...], [...]]    # s_i, unit rows, body frame (§F eq. (10))
      sense_axes_std_rad: [...]            # √trace C(s_i) per row: its direction's u, rad
      misalignment_rad: [[0.0, m_xy, m_xz], [m_yx, 0.0, m_yz], [m_zx, m_zy, 0.0]]
                                           # small-angle: s_i ≈ e_i + Σ_{j≠i} m_ij·e_j
                                           # (m_ij = s_ij/s_ii), rad; the diagonal is 0;
                                           # absent when channel i is not along body axis i
      pulses_to_body_rad: [[...], [...], [...]]         # M = R⁻¹, rad/pulse (§F eq. (11))
      pulses_to_body_rad_covariance: [[... 9 ...] × 9]  # of vec(M), row-major, (rad/pulse)²
      bias_rad_s: [bx, by, bz]             # b in the body frame, ω_B = M·ṅ − b (§F eq. (14))
      bias_rad_s_std: [...]
      accelerometer:                       # optional: an IMU's accelerometer (multiposition, §G)
        raw_unit: m/s²                     # the unit of the raw samples r
        raw_to_body: [[...], [...], [...]] # A = T·diag(s): a_B = A·r − bias_m_s2
        raw_to_body_covariance: [[... 9 ...] × 9]
        bias_m_s2: [...]                   # A·b_raw, body frame
        bias_m_s2_std: [...]
        scale: [...]                       # s, m/s² per raw unit; scale_std, scale_dof
        misalignment_rad: {yz: ..., zy: ..., zx: ...}   # T's angles; misalignment_rad_std
        bias_raw: [...]                    # b_raw, raw unit; bias_raw_std
        gravity_m_s2: ...                  # g the fit rests on; gravity_m_s2_std
        poses: ...                         # static poses used
      noise:                               # optional, per channel where measured (§E)
        x: {angle_random_walk_rad_per_sqrt_s: ..., angle_random_walk_rad_per_sqrt_s_std: ...,
            quantization_noise_rad: ..., ...}
      thermal:                             # optional, per channel where measured (§D):
        x: {...}                           # that channel's thermal_* keys as in ``gyro:``
      missing: {bias_rad_s: the bias needs the site latitude ...}
      not_measurable: {pulses_to_body_rad: channel y: ...}

A quantity that was not measured is an absent key, with its reason under ``missing`` or
``not_measurable`` (as the file's top level). A channel whose row is not measurable while the
others are solved keeps its place in the per-channel lists as ``null`` (K, its ``_std`` and
``_dof``, its sense-axis row and ``sense_axes_std_rad``), and ``not_measurable`` names it
under ``scale_factor_rad_per_pulse``; M and b, which need all three rows, are then absent.
ω_B = M·(Δcounts/Δt) − b is the calibrated body
rate. :class:`ImuCalibration` is the section in memory; :func:`imu_from_section` checks and
reads it (one :class:`~gyro_calib.handoff.HandoffError`-style message per problem, raised as
:class:`ImuSectionError`), :meth:`ImuCalibration.to_section` writes it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from gyro_calib.errors import GyroCalibError

Array = npt.NDArray[np.float64]

UNIT_TOLERANCE = 1e-6
"""|‖s_i‖ − 1| above this: a sense-axis row is not a unit vector."""

SECTION_KEYS = ('channels', 'fixture_rotation', 'scale_factor_rad_per_pulse',
                'scale_factor_rad_per_pulse_std', 'scale_factor_rad_per_pulse_dof',
                'sense_axes', 'sense_axes_std_rad', 'misalignment_rad', 'pulses_to_body_rad',
                'pulses_to_body_rad_covariance', 'bias_rad_s', 'bias_rad_s_std', 'accelerometer',
                'noise', 'thermal', 'missing', 'not_measurable')
"""Every key the ``imu:`` section may hold, in the order it is written."""


ACCELEROMETER_KEYS = ('raw_unit', 'raw_to_body', 'raw_to_body_covariance', 'bias_m_s2',
                      'bias_m_s2_std', 'scale', 'scale_std', 'scale_dof', 'misalignment_rad',
                      'misalignment_rad_std', 'bias_raw', 'bias_raw_std', 'gravity_m_s2',
                      'gravity_m_s2_std', 'poses')
"""The keys of ``imu.accelerometer``."""
NOISE_TERMS = ('quantization_noise_rad', 'angle_random_walk_rad_per_sqrt_s',
               'bias_instability_rad_s', 'rate_random_walk_rad_per_s_sqrt_s',
               'rate_ramp_rad_per_s2')
"""The noise terms one channel's ``imu.noise.<channel>`` may hold: the single-gyro keys of
:mod:`gyro_calib.noise.keys` (named here: this module imports no method; a test keeps them
equal), each with its ``_std``, optional ``_dof``, and ``_upper_bound_2sigma`` where the fit
did not resolve it (METHODS §E)."""
NOISE_KEYS = tuple(term + suffix for term in NOISE_TERMS
                   for suffix in ('', '_std', '_dof', '_upper_bound_2sigma'))
"""Every key of one channel's noise mapping."""


class ImuSectionError(GyroCalibError):
    """The ``imu:`` section of a hand-off file is malformed (one sentence naming the key)."""


@dataclass(frozen=True, slots=True)
class ImuCalibration:
    """A triad's calibration (the ``imu:`` section; see the module docstring for the keys).

    Attributes:
        channels: the three channel names, in row order.
        fixture_rotation: F (3×3, orthonormal), v_B = F·v_T.
        scale_factor_rad_per_pulse: K_i (3,), rad/pulse; None if not measured.
        scale_factor_rad_per_pulse_std: u(K_i) (3,); None with it.
        scale_factor_rad_per_pulse_dof: ν per channel (3,); None if not stated.
        sense_axes: s_i as unit rows (3×3), body frame; None if not measured.
        sense_axes_std_rad: √trace C(s_i) per row (3,), rad; None with it.
        pulses_to_body_rad: M (3×3), rad/pulse; None if not measurable.
        pulses_to_body_rad_covariance: 9×9 covariance of vec(M) (row-major); None with M.
        bias_rad_s: b (3,), body frame, rad/s; None if not measured.
        bias_rad_s_std: u(b) (3,), rad/s; None with it.
        noise: channel → that channel's noise keys (``angle_random_walk_rad_per_sqrt_s``, …).
        thermal: channel → that channel's thermal keys, as the ``gyro:`` section's.
        missing: key → why it is missing.
        not_measurable: key → why this bench cannot give it.
    """

    channels: tuple[str, str, str]
    fixture_rotation: Array = field(default_factory=lambda: np.eye(3))
    scale_factor_rad_per_pulse: Array | None = None
    scale_factor_rad_per_pulse_std: Array | None = None
    scale_factor_rad_per_pulse_dof: Array | None = None
    sense_axes: Array | None = None
    sense_axes_std_rad: Array | None = None
    pulses_to_body_rad: Array | None = None
    pulses_to_body_rad_covariance: Array | None = None
    bias_rad_s: Array | None = None
    bias_rad_s_std: Array | None = None
    noise: dict[str, dict[str, float]] = field(default_factory=dict)
    thermal: dict[str, dict[str, Any]] = field(default_factory=dict)
    missing: dict[str, str] = field(default_factory=dict)
    not_measurable: dict[str, str] = field(default_factory=dict)
    accelerometer: dict[str, Any] = field(default_factory=dict)
    """An IMU's accelerometer (``imu.accelerometer``, :data:`ACCELEROMETER_KEYS`), or {}."""

    @property
    def misalignment_rad(self) -> Array | None:
        """m_ij = s_ij/s_ii off the diagonal, 0 on it (small-angle form), rad; or None.

        None also when a channel is not nominally along its own body axis (|s_ii| not the
        largest component of row i, e.g. channels listed as z, x, y): the small-angle form
        about e_i does not apply, and the section then leaves the key out.
        """
        if self.sense_axes is None:
            return None
        s = self.sense_axes
        if np.any(np.argmax(np.abs(s), axis=1) != np.arange(3)):
            return None
        m = s / np.diag(s)[:, None]
        np.fill_diagonal(m, 0.0)
        return m

    def to_section(self) -> dict[str, Any]:
        """The ``imu:`` mapping to write: plain lists and floats, in SECTION_KEYS order."""
        out: dict[str, Any] = {'channels': list(self.channels),
                               'fixture_rotation': _rows(self.fixture_rotation)}
        vectors = {'scale_factor_rad_per_pulse': self.scale_factor_rad_per_pulse,
                   'scale_factor_rad_per_pulse_std': self.scale_factor_rad_per_pulse_std,
                   'scale_factor_rad_per_pulse_dof': self.scale_factor_rad_per_pulse_dof,
                   'sense_axes_std_rad': self.sense_axes_std_rad,
                   'bias_rad_s': self.bias_rad_s, 'bias_rad_s_std': self.bias_rad_s_std}
        matrices = {'sense_axes': self.sense_axes, 'misalignment_rad': self.misalignment_rad,
                    'pulses_to_body_rad': self.pulses_to_body_rad,
                    'pulses_to_body_rad_covariance': self.pulses_to_body_rad_covariance}
        for key in SECTION_KEYS:
            if key in vectors and vectors[key] is not None:
                out[key] = [_number(v) for v in np.asarray(vectors[key], dtype=float)]
            elif key in matrices and matrices[key] is not None:
                rows = _rows(np.asarray(matrices[key], dtype=float))
                out[key] = [None if any(math.isnan(v) for v in row) else row for row in rows]
        if self.accelerometer:
            out['accelerometer'] = dict(self.accelerometer)
        if self.noise:
            out['noise'] = {c: {k: float(v) for k, v in d.items()} for c, d in self.noise.items()}
        if self.thermal:
            out['thermal'] = {c: dict(d) for c, d in self.thermal.items()}
        if self.missing:
            out['missing'] = dict(self.missing)
        if self.not_measurable:
            out['not_measurable'] = dict(self.not_measurable)
        return out


def _number(value: float) -> float | None:
    """A float to write; None (YAML null) for NaN: a channel not measured (∞ stays ∞)."""
    return None if math.isnan(value) else float(value)


def _rows(matrix: Array) -> list[list[float]]:
    return [[float(v) for v in row] for row in np.asarray(matrix, dtype=float)]


def _array(section: Mapping[str, Any], key: str, shape: tuple[int, ...], source: str,
           *, finite: bool = True, per_channel: bool = False) -> Array | None:
    if key not in section:
        return None
    raw = section[key]
    if per_channel and isinstance(raw, list):  # null: that channel was not measured
        raw = [([math.nan] * shape[1] if len(shape) == 2 else math.nan) if v is None else v
               for v in raw]
    try:
        value = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise ImuSectionError(f'{source}: imu.{key} must be numbers of shape {shape}; got '
                              f'{section[key]!r:.80}.') from None
    if value.shape != shape:
        raise ImuSectionError(f'{source}: imu.{key} must have shape {shape}; it has '
                              f'{value.shape}.')
    bad = ~np.isfinite(value) & ~np.isnan(value) if per_channel else ~np.isfinite(value)
    if finite and np.any(bad):
        raise ImuSectionError(f'{source}: imu.{key} holds a non-finite number.')
    return value


def _reasons(section: Mapping[str, Any], key: str, source: str) -> dict[str, str]:
    value = section.get(key, {}) or {}
    if not isinstance(value, Mapping) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in value.items()):
        raise ImuSectionError(f'{source}: imu.{key} must map key names to reasons (text).')
    return dict(value)


def _per_channel(section: Mapping[str, Any], key: str, channels: tuple[str, ...],
                 source: str) -> dict[str, dict[str, Any]]:
    value = section.get(key, {}) or {}
    if not isinstance(value, Mapping) or not all(isinstance(v, Mapping) for v in value.values()):
        raise ImuSectionError(f'{source}: imu.{key} must map channel names to mappings.')
    unknown = [c for c in value if c not in channels]
    if unknown:
        raise ImuSectionError(f'{source}: imu.{key} names channel {unknown[0]!r}, which is '
                              f'not one of the channels {list(channels)}.')
    return {str(c): dict(v) for c, v in value.items()}


def _channel_noise(terms: Mapping[str, Any], where: str, source: str) -> dict[str, float]:
    """One channel's noise terms, checked: known keys, numbers ≥ 0 (degrees of freedom: .inf).

    Raises:
        ImuSectionError: naming the key (the nearest known one for a typo) and what to write.
    """
    import difflib

    out: dict[str, float] = {}
    for key, value in terms.items():
        if key not in NOISE_KEYS:
            near = difflib.get_close_matches(str(key), NOISE_KEYS, n=1)
            hint = f' (did you mean {near[0]!r}?)' if near else ''
            raise ImuSectionError(f'{source}: {where} has an unknown key {key!r}{hint}; a '
                                  f'channel\'s noise keys are {", ".join(NOISE_TERMS)}, each '
                                  'with _std (and _dof, _upper_bound_2sigma).')
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        dof = key.endswith('_dof')
        if not number or math.isnan(value) or value < 0 or (not dof and math.isinf(value)):
            what = ('degrees of freedom: a number ≥ 0 (.inf for infinitely many)' if dof else
                    'a finite number ≥ 0')
            hint = (' (YAML 1.1 floats need a dot: 4.0e-6, not 4e-6)'
                    if isinstance(value, str) and _numeric(value) else '')
            raise ImuSectionError(f'{source}: {where}.{key} = {value!r} is invalid: it must be '
                                  f'{what}{hint}.')
        out[str(key)] = float(value)
    return out


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _unsolved_channels(k: Array | None, k_std: Array | None, k_dof: Array | None,
                       axes: Array | None, axes_std: Array | None, source: str) -> list[int]:
    """The channels given as null (not measured); every per-channel list must agree."""
    lists = {'scale_factor_rad_per_pulse': k, 'scale_factor_rad_per_pulse_std': k_std,
             'scale_factor_rad_per_pulse_dof': k_dof,
             'sense_axes': None if axes is None else np.where(np.isnan(axes).any(axis=1),
                                                            np.nan, 0.0),
             'sense_axes_std_rad': axes_std}
    masks = {key: np.isnan(v) for key, v in lists.items() if v is not None}
    if not masks:
        return []
    first_key, first = next(iter(masks.items()))
    for key, mask in masks.items():
        if not np.array_equal(mask, first):
            raise ImuSectionError(f'{source}: imu.{key} and imu.{first_key} are null for '
                                  'different channels; a channel not measured is null in every '
                                  'per-channel list.')
    if axes is not None and np.any(np.isnan(axes).any(axis=1) != np.isnan(axes).all(axis=1)):
        raise ImuSectionError(f'{source}: imu.sense_axes has a row partly null.')
    return [int(i) for i in np.flatnonzero(first)]


def imu_from_section(section: Any, *, source: str = 'hand-off') -> ImuCalibration:
    """Check and read an ``imu:`` section.

    Raises:
        ImuSectionError: unknown key (nearest named), wrong shape or non-finite number, a
            value without its ``_std`` (or the reverse), a sense-axis row not a unit vector,
            a fixture rotation not orthonormal, a covariance not symmetric with a
            non-negative diagonal, or a channel list that is not three distinct names.
    """
    import difflib

    if not isinstance(section, Mapping):
        raise ImuSectionError(f'{source}: imu must be a mapping; got {type(section).__name__}.')
    for key in section:
        if key not in SECTION_KEYS:
            near = difflib.get_close_matches(str(key), SECTION_KEYS, n=1)
            hint = f' (did you mean {near[0]!r}?)' if near else ''
            raise ImuSectionError(f'{source}: imu has an unknown key {key!r}{hint}.')
    channels = section.get('channels')
    if (not isinstance(channels, list) or len(channels) != 3
            or not all(isinstance(c, str) and c for c in channels)
            or len(set(channels)) != 3):
        raise ImuSectionError(f'{source}: imu.channels must be three distinct channel names; '
                              f'got {channels!r:.80}.')
    names = (channels[0], channels[1], channels[2])
    fixture = _array(section, 'fixture_rotation', (3, 3), source)
    if fixture is None:
        fixture = np.eye(3)
    elif not np.allclose(fixture @ fixture.T, np.eye(3), atol=1e-9) or np.linalg.det(fixture) < 0:
        raise ImuSectionError(f'{source}: imu.fixture_rotation is not a rotation (orthonormal, '
                              'determinant +1).')
    k = _array(section, 'scale_factor_rad_per_pulse', (3,), source, per_channel=True)
    k_std = _array(section, 'scale_factor_rad_per_pulse_std', (3,), source, per_channel=True)
    k_dof = _array(section, 'scale_factor_rad_per_pulse_dof', (3,), source, finite=False,
                   per_channel=True)
    axes = _array(section, 'sense_axes', (3, 3), source, per_channel=True)
    axes_std = _array(section, 'sense_axes_std_rad', (3,), source, per_channel=True)
    m = _array(section, 'pulses_to_body_rad', (3, 3), source)
    m_cov = _array(section, 'pulses_to_body_rad_covariance', (9, 9), source)
    bias = _array(section, 'bias_rad_s', (3,), source)
    bias_std = _array(section, 'bias_rad_s_std', (3,), source)
    for value, std, name in ((k, k_std, 'scale_factor_rad_per_pulse'),
                             (axes, axes_std, 'sense_axes'),
                             (m, m_cov, 'pulses_to_body_rad'), (bias, bias_std, 'bias_rad_s')):
        if (value is None) != (std is None):
            which = 'its uncertainty' if std is None else 'the value'
            raise ImuSectionError(f'{source}: imu.{name} is given without {which}; write both '
                                  'or neither.')
    unsolved = _unsolved_channels(k, k_std, k_dof, axes, axes_std, source)
    if unsolved and 'scale_factor_rad_per_pulse' not in _reasons(section, 'not_measurable',
                                                                  source):
        raise ImuSectionError(f'{source}: imu: channel {names[unsolved[0]]!r} has no value '
                              '(null) but not_measurable.scale_factor_rad_per_pulse gives no '
                              'reason.')
    if unsolved and (m is not None or bias is not None):
        raise ImuSectionError(f'{source}: imu: pulses_to_body_rad and bias_rad_s need all '
                              f'three rows, but channel {names[unsolved[0]]!r} is null.')
    for std, name in ((k_std, 'scale_factor_rad_per_pulse_std'),
                      (axes_std, 'sense_axes_std_rad'), (bias_std, 'bias_rad_s_std')):
        if std is not None and np.any(std < 0):
            raise ImuSectionError(f'{source}: imu.{name} holds a negative uncertainty.')
    if k is not None and np.any(k[np.isfinite(k)] <= 0):
        raise ImuSectionError(f'{source}: imu.scale_factor_rad_per_pulse must be > 0 per '
                              'channel (a reversed channel is a sense axis pointing the other '
                              'way, not a negative K).')
    if k_dof is not None and np.any(k_dof[~np.isnan(k_dof)] < 0):
        raise ImuSectionError(f'{source}: imu.scale_factor_rad_per_pulse_dof must be ≥ 0 '
                              '(.inf for ν = ∞).')
    solved = [i for i in range(3) if i not in unsolved]
    if axes is not None and np.any(
            np.abs(np.linalg.norm(axes[solved], axis=1) - 1) > UNIT_TOLERANCE):
        raise ImuSectionError(f'{source}: imu.sense_axes rows must be unit vectors (|s_i| = 1 '
                              f'within {UNIT_TOLERANCE:g}).')
    if m_cov is not None and (not np.allclose(m_cov, m_cov.T, rtol=1e-9, atol=0.0)
                              or np.any(np.diag(m_cov) < 0)):
        raise ImuSectionError(f'{source}: imu.pulses_to_body_rad_covariance must be symmetric '
                              'with a non-negative diagonal.')
    if m is not None and not math.isfinite(float(np.linalg.cond(m))):
        raise ImuSectionError(f'{source}: imu.pulses_to_body_rad is singular.')
    accelerometer = _accelerometer(section.get('accelerometer'), source)
    return ImuCalibration(
        names, fixture, k, k_std, k_dof, axes, axes_std, m, m_cov, bias, bias_std,
        {c: _channel_noise(d, f'imu.noise.{c}', source)
         for c, d in _per_channel(section, 'noise', names, source).items()},
        _per_channel(section, 'thermal', names, source),
        _reasons(section, 'missing', source), _reasons(section, 'not_measurable', source),
        accelerometer)


BODY_AXES = ('x', 'y', 'z')


def channel_of_axis(imu: ImuCalibration) -> dict[str, str]:
    """Body axis → the channel whose sense axis lies along it (row order without axes).

    The channel i with the largest |s_i| component on the axis (sense axes of a triad are
    within a few degrees of body axes, in any order); row i ↔ axis i when the section has no
    sense axes or they are not a permutation of the body axes.
    """
    default = dict(zip(BODY_AXES, imu.channels, strict=True))
    if imu.sense_axes is None:
        return default
    picks = np.argmax(np.abs(imu.sense_axes), axis=1)
    if len(set(int(p) for p in picks)) != 3:
        return default
    return {BODY_AXES[int(p)]: imu.channels[i] for i, p in enumerate(picks)}


@dataclass(frozen=True, slots=True)
class NoiseValue:
    """One noise key of one triad channel and the hand-off key it was read from."""

    value: float
    source_key: str


def channel_noise(imu: ImuCalibration, gyro: Mapping[str, Any]
                  ) -> dict[str, dict[str, NoiseValue]]:
    """Each channel's noise keys: ``imu.noise.<channel>``, else the noise run's own keys.

    The one source of a triad's noise for every reader (imu_corrector's covariance and
    ``gyro-calib export``; issue 36 §4): a noise run on the triad's Imu stream stores its
    terms as ``gyro.imu_gyro_<axis>_<key>``; channel c takes those of the body axis its sense
    axis is along (:func:`channel_of_axis`) for each key ``imu.noise.<c>`` does not hold.
    Only finite non-negative numbers are taken.
    """
    out: dict[str, dict[str, NoiseValue]] = {c: {} for c in imu.channels}
    for axis, ch in channel_of_axis(imu).items():
        prefix = f'imu_gyro_{axis}_'
        for key, value in gyro.items():
            name = str(key)
            if name.startswith(prefix) and _noise_number(value) is not None:
                out[ch][name.removeprefix(prefix)] = NoiseValue(float(value), f'gyro.{name}')
    for ch in imu.channels:
        for key, value in imu.noise.get(ch, {}).items():
            if _noise_number(value) is not None:
                out[ch][key] = NoiseValue(float(value), f'imu.noise.{ch}.{key}')
    return out


def with_channel_noise(imu: ImuCalibration, gyro: Mapping[str, Any]) -> ImuCalibration:
    """``imu`` whose ``noise`` is :func:`channel_noise` (values only)."""
    from dataclasses import replace

    noise = {c: {k: v.value for k, v in d.items()}
             for c, d in channel_noise(imu, gyro).items() if d}
    return replace(imu, noise=noise)


def _noise_number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    v = float(value)
    return v if math.isfinite(v) and v >= 0 else None


def _accelerometer(value: Any, source: str) -> dict[str, Any]:
    """``imu.accelerometer`` checked: known keys, A 3×3 and b (3,) finite, both or neither.

    Raises:
        ImuSectionError: not a mapping, an unknown key, a wrong shape or a non-finite number.
    """
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ImuSectionError(f'{source}: imu.accelerometer must be a mapping.')
    for key in value:
        if key not in ACCELEROMETER_KEYS:
            raise ImuSectionError(f'{source}: imu.accelerometer has an unknown key {key!r}; '
                                  f'the keys are {", ".join(ACCELEROMETER_KEYS)}.')
    for key, shape in (('raw_to_body', (3, 3)), ('raw_to_body_covariance', (9, 9)),
                       ('bias_m_s2', (3,)), ('bias_m_s2_std', (3,))):
        if key in value:
            _array(value, key, shape, f'{source}: accelerometer')
    if ('raw_to_body' in value) != ('bias_m_s2' in value):
        raise ImuSectionError(f'{source}: imu.accelerometer needs raw_to_body and bias_m_s2 '
                              'together.')
    return dict(value)
