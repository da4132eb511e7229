"""What a hand-off file may hold: format versions, conventions, keys and their checks.

The versions written and read, the ``conventions:`` text, :class:`HandoffKey` (one value a
method may write) with the check of a value against it, the twins ``<key>_std`` and
``<key>_dof`` that go with an uncertain value, and the schema (every registered method's
keys) used when a caller passes none (:func:`install_default_schema`). The file's layout is
described in :mod:`gyro_calib.handoff`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from gyro_calib.errors import GyroCalibError

FORMAT_VERSION = 3
"""The layout version written for one gyro; formats 1 and 2 are still read."""

IMU_FORMAT_VERSION = 4
"""The layout version of a file with an ``imu:`` section (a triad, METHODS §F; the section's
layout: :mod:`gyro_calib.imu_calibration`); formats 1–3 are still read."""

READ_VERSIONS = (1, 2, FORMAT_VERSION, IMU_FORMAT_VERSION)

IMU_METHODS = ('triad', 'multiposition')
"""Methods whose results are the ``imu:`` section (no top-level keys of their own)."""

CONVENTIONS: dict[str, str] = {
    'axis': "every rate, angle and bias is about the gyro's sense (input) axis, positive "
            'right-handed about it: the sense in which the pulse count or FOG output count '
            'increases; sensor_msgs/Imu consumers (imu_corrector) carry it as the '
            "frame's z axis.",
    'rate': 'a pulse gyro: ω = K·Δcount/Δt − b (K scale_factor_rad_per_pulse); a FOG: '
            'ω = Δcount/(SF·Δt) − b (SF fog_scale_factor_counts_per_rad); b the bias (bias_rad_s, '
            'fog_bias_rad_s, or thermal_model at the gyro\'s temperatures), rad/s.',
    'bias': 'a bias key holds the gyro bias with the Earth rate along the sense axis removed, '
            'for the latitude and heading in its run\'s conditions; a *_plus_earth_rate key '
            'still holds that Earth rate (valid only on that bench, in that orientation).',
    'units': 'SI, unit in each key name; <key>_std is the standard (k = 1) uncertainty in '
             'the same unit, <key>_dof (where given) its degrees of freedom; an absent key was '
             'not measured (missing / not_measurable say why).',
}
"""What every number in the file is (written under ``conventions:``)."""

IMU_CONVENTION = ('the imu: section is a triad of gyros in the IMU body frame (the inner-table '
                  'frame through fixture_rotation): ω_B = M·ṅ − b, M = pulses_to_body_rad '
                  '(rad/pulse), ṅ the three channels\' count rates in channels order, '
                  'b = bias_rad_s (rad/s, body frame, Earth rate removed); sense_axes are unit '
                  'rows in the body '
                  'frame (docs/methods.md §F).')
"""The ``conventions.imu`` line, written when the file has an ``imu:`` section."""


class HandoffError(GyroCalibError):
    """The hand-off calibration file cannot be written, read, or holds invalid content."""


@dataclass(frozen=True, slots=True)
class HandoffKey:
    """One value a method may write to the hand-off file.

    Attributes:
        name: the key, with its SI unit in the name.
        method: the method that writes it ('rbrlg', 'fog', 'noise', 'dither', 'thermal').
        description: what it is, with the METHODS equation where there is one.
        kind: 'float', 'positive', 'nonnegative', 'count' (integer ≥ 0), 'text',
            'float_list' (list of finite numbers) or 'mapping' (checked by ``check``).
        has_std: a ``<name>_std`` twin (standard uncertainty, same unit) goes with it.
        check: extra validation of the value: returns a problem ('' if fine).
        follows: the key it goes with when a file is updated (a count, or a quantity of the
            same fit): it is always from the same run as that key. '' = its own.
        bench_specific: its value holds on the bench it was measured on only (a bias with the
            Earth rate along that bench's axis in it): runs on other benches are not compared
            with it for consistency.
        scales_with_scale_factor: an angle (or rate) the run turned from the gyro's output
            with the scale factor its conditions name (:data:`SCALE_FACTOR_CONDITIONS`): the
            relative difference of another scale factor moves it by at most that fraction of
            its value (:func:`scale_factor_findings`).
    """

    name: str
    method: str
    description: str
    kind: str = 'float'
    has_std: bool = True
    check: Callable[[Any], str] | None = None
    follows: str = ''
    bench_specific: bool = False
    scales_with_scale_factor: bool = False


def _problem(key: HandoffKey, value: Any) -> str:
    """Why ``value`` is not a valid ``key`` ('' if it is)."""
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if key.kind in ('float', 'positive', 'nonnegative'):
        if not number or not math.isfinite(value):
            return 'it must be a finite number'
        if key.kind == 'positive' and not value > 0:
            return 'it must be positive'
        if key.kind == 'nonnegative' and value < 0:
            return 'it must be non-negative'
    elif key.kind == 'count':
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            return 'it must be a non-negative integer'
    elif key.kind == 'text':
        if not isinstance(value, str):
            return 'it must be a string'
    elif key.kind == 'float_list':
        if not isinstance(value, list) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in value):
            return 'it must be a list of finite numbers'
    elif key.kind == 'mapping':
        if not isinstance(value, dict):
            return 'it must be a mapping'
    return key.check(value) if key.check is not None else ''


_DEFAULT_SCHEMA: list[Callable[[], Mapping[str, HandoffKey]]] = []
"""The schema used when a caller passes none: installed by the method registry above
(:func:`install_default_schema`); this module never imports the registry (issue 19 §5)."""


def install_default_schema(provider: Callable[[], Mapping[str, HandoffKey]]) -> None:
    """Make ``provider()`` the schema of every call that passes ``schema=None``.

    The method registry installs its :func:`~gyro_calib.registry.handoff_schema` when it is
    imported, so the sessions below it (which never import the registry) read and write
    hand-off files with every method's keys; the front doors pass the schema explicitly.
    """
    _DEFAULT_SCHEMA[:] = [provider]


def _schema(schema: Mapping[str, HandoffKey] | None) -> Mapping[str, HandoffKey]:
    if schema is not None:
        return schema
    if not _DEFAULT_SCHEMA:
        raise RuntimeError('no hand-off schema: pass schema= (the method registry\'s '
                           'gyro_calib.registry.handoff_schema()), or import gyro_calib.registry '
                           'first, which installs it as the default.')
    return _DEFAULT_SCHEMA[0]()


TWIN_SUFFIXES = ('_std', '_dof')
"""The keys that go with an uncertain value ``<key>``: its standard uncertainty and its
degrees of freedom (optional)."""


def _base_key(key: str) -> str:
    return key[:-4] if key.endswith(TWIN_SUFFIXES) else key


def _pop_twins(values: dict[str, Any], key: str) -> None:
    """Remove ``key``'s ``_std`` and ``_dof`` from ``values`` (changed in place)."""
    for suffix in TWIN_SUFFIXES:
        values.pop(key + suffix, None)


def _ordered(keys: Iterable[str], schema: Mapping[str, HandoffKey]) -> tuple[str, ...]:
    """Keys in schema order (the order of the file)."""
    order = {k: i for i, k in enumerate(schema)}
    return tuple(sorted(keys, key=lambda k: (order.get(k, len(order)), k)))


def _checked_values(values: dict[str, Any], schema: Mapping[str, HandoffKey], *,
                    source: str) -> dict[str, Any]:
    """``values`` validated against ``schema`` (numbers made floats where floats are meant)."""
    unknown = sorted(k for k in values if _base_key(k) not in schema
                     or (k.endswith(TWIN_SUFFIXES) and not schema[_base_key(k)].has_std))
    if unknown:
        raise HandoffError(f'unknown field(s) {", ".join("gyro." + k for k in unknown)} in '
                           f'{source}.')
    out: dict[str, Any] = {}
    for key, value in values.items():
        spec = schema[_base_key(key)]
        if key.endswith('_std'):
            if key[:-4] not in values:
                raise HandoffError(f'gyro.{key} in {source} has no gyro.{key[:-4]} beside it.')
            std_spec = HandoffKey(key, spec.method, '', 'nonnegative', False)
            problem = _problem(std_spec, value)
        elif key.endswith('_dof'):
            if key[:-4] not in values:
                raise HandoffError(f'gyro.{key} in {source} has no gyro.{key[:-4]} beside it.')
            problem = _dof_problem(value)
        else:
            if spec.has_std and key + '_std' not in values:
                raise HandoffError(f'gyro.{key} in {source} has no gyro.{key}_std beside it '
                                   '(every value goes with its standard uncertainty).')
            problem = _problem(spec, value)
        if problem:
            if isinstance(value, str) and spec.kind != 'text':
                problem += ' (YAML 1.1 floats need a dot: 4.0e-6, not 4e-6)'
            raise HandoffError(f'gyro.{key} = {value!r} in {source} is invalid: {problem}.')
        is_float = key.endswith('_std') or (spec.kind in ('float', 'positive', 'nonnegative')
                                            and not key.endswith('_dof'))
        out[key] = float(value) if is_float else value
    return out


def _dof_problem(value: Any) -> str:
    """Why ``value`` is not degrees of freedom ('' if it is): a number ≥ 0, or .inf.

    0 says that no coverage interval can be stated (one measurement, no scatter).
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        return 'degrees of freedom must be a number (.inf for infinitely many)'
    return '' if value >= 0 else 'degrees of freedom must not be negative'


def _numbers(*values: Any) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def keys_table(keys: Iterable[HandoffKey]) -> str:
    """A Markdown table of hand-off keys (docs/reference/handoff.md)."""
    lines = ['| key | method | meaning |', '|---|---|---|']
    for k in keys:
        std = ' (+ `_std`)' if k.has_std else ''
        text = k.description.replace('|', '\\|')
        lines.append(f'| `{k.name}`{std} | {k.method} | {text} |')
    return '\n'.join(lines)
