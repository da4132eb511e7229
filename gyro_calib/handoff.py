"""The INS hand-off calibration file: what gyro_calib measured, for the navigation system.

One YAML file per gyro holds every value measured, by any method, each with its standard
(k = 1) uncertainty beside it as ``<name>_std``, under a top-level ``gyro:`` mapping; which
method produced them, from what data and when, under ``methods:``; and whether anything the
methods that ran would measure is still missing (``complete``, ``missing`` with reasons). All
units are SI and in the key names. A value that was not measured is an *absent key* — never a
placeholder number. Method-specific keys carry the method's prefix (``fog_…``, ``dither_…``,
``thermal_…``); the RBRLG keys keep the names of format 1.

Example (``format_version: 2``)::

    # gyro_calib INS hand-off calibration; layout: gyro_calib/handoff.py
    format_version: 2
    gyro_calib_version: 0.2.0
    gyro_id: ''                          # serial or name, when given (--gyro-id)
    complete: false
    missing:
      bias_rad_s: the bias needs the site latitude (--latitude-deg) to remove the Earth rate.
    gyro:
      k_tilde_rad_per_pulse: 4.0860157e-06           # K̃ (METHODS §A.2, eq. 3)
      k_tilde_rad_per_pulse_std: 4.8e-14
      bias_plus_earth_rate_rad_s: 2.4e-05            # ω′ₑ + ω_B along the sense axis
      bias_plus_earth_rate_rad_s_std: 3.0e-08
      scale_factor_rad_per_pulse: 4.0859955e-06      # K = K̃·cos θ (eq. 4)
      scale_factor_rad_per_pulse_std: 5.1e-14
      fix_error_angle_rad: 0.0031355                 # θ (METHODS §A.3)
      fix_error_angle_rad_std: 2.0e-06
      window_pairs: 3
      stations: 4
    methods:
      rbrlg:
        source: bags/bench_2026-11-23
        created_utc: '2026-11-23T09:30:00+00:00'
        data_start_stamp_ns: 1795426200000000000
        data_end_stamp_ns: 1795426500000000000
        missing:
          bias_rad_s: the bias needs the site latitude (--latitude-deg) to remove the Earth rate.

The keys each method may write, with units and meaning, are its ``HANDOFF_KEYS`` (listed in
the README); unknown keys are refused (a misspelt key would otherwise be silently dropped).
Floats need a dot in the mantissa (YAML 1.1: ``4.0e-6``, not ``4e-6``, which reads as a
string). Files of ``format_version: 1`` (RBRLG only, flat metadata) still load.

:func:`write_calibration` replaces the file atomically (temporary file in the same
directory, fsync, rename, fsync of the directory), so a reader such as ``imu_corrector``
sees the old file or the new one, never half of one. :func:`update_calibration` merges a
method's new record into the gyro's file: the keys of the methods that ran are replaced,
those of other methods kept.
"""

from __future__ import annotations

import datetime
import math
import os
import tempfile
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

import yaml

from gyro_calib import __version__
from gyro_calib.errors import GyroCalibError
from gyro_calib.outputs import new_file_mode

FORMAT_VERSION = 2
"""The layout version this module writes; format 1 files are still read."""


class HandoffError(GyroCalibError):
    """The hand-off calibration file cannot be written, read, or holds invalid content."""


# ---------------------------------------------------------------------------------------
# Keys


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
    """

    name: str
    method: str
    description: str
    kind: str = 'float'
    has_std: bool = True
    check: Callable[[Any], str] | None = None


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


def _schema(schema: Mapping[str, HandoffKey] | None) -> Mapping[str, HandoffKey]:
    if schema is not None:
        return schema
    from gyro_calib.registry import handoff_schema  # the methods' keys

    return handoff_schema()


# ---------------------------------------------------------------------------------------
# Records


def _utc_now_iso() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')


@dataclass(frozen=True, slots=True)
class Provenance:
    """Where one method's values came from.

    Attributes:
        source: 'live' or the bag path(s) calibrated.
        data_start_stamp_ns, data_end_stamp_ns: header stamps of the first and last sample the
            values rest on, int ns.
        missing: keys this method would measure but did not, each with the reason.
        created_utc: when the values were produced, ISO-8601 UTC.
    """

    source: str
    data_start_stamp_ns: int
    data_end_stamp_ns: int
    missing: Mapping[str, str] = field(default_factory=dict)
    created_utc: str = field(default_factory=_utc_now_iso)


@dataclass(frozen=True, slots=True)
class Calibration:
    """Everything known about one gyro: values (with ``_std`` twins) and their provenance.

    Build it with :func:`method_calibration` (one method's results) or read it with
    :func:`load_calibration`; both validate every key. ``values`` maps hand-off key → value.
    """

    values: Mapping[str, Any]
    methods: Mapping[str, Provenance]
    gyro_id: str = ''
    gyro_calib_version: str = __version__
    format_version: int = FORMAT_VERSION

    @property
    def missing(self) -> dict[str, str]:
        """Every key a method that ran would measure but did not, with its reason."""
        out: dict[str, str] = {}
        for prov in self.methods.values():
            out.update({k: v for k, v in prov.missing.items() if k not in self.values})
        return out

    @property
    def complete(self) -> bool:
        """True when the methods that ran measured everything they measure."""
        return not self.missing

    def get(self, key: str) -> Any:
        """The value of ``key`` or None when it was not measured."""
        return self.values.get(key)

    def measured(self, key: str) -> tuple[float, float] | None:
        """(value, standard uncertainty) of ``key``, or None when it was not measured."""
        if key not in self.values:
            return None
        return float(self.values[key]), float(self.values.get(key + '_std', 0.0))

    def require(self, key: str, *, why: str = '') -> tuple[float, float]:
        """(value, standard uncertainty) of ``key``.

        Raises:
            HandoffError: naming the key (and what it was needed for) when it is absent.
        """
        got = self.measured(key)
        if got is None:
            reason = self.missing.get(key, '')
            raise HandoffError(f'the calibration has no {key}' + (f' ({why})' if why else '')
                               + (f': {reason}' if reason else '.'))
        return got

    def merged_into(self, older: Calibration, schema: Mapping[str, HandoffKey]) -> Calibration:
        """``older`` with the keys of this calibration's methods replaced by this one's.

        Raises:
            HandoffError: the two are for different gyros (``gyro_id`` given and different).
        """
        if self.gyro_id and older.gyro_id and self.gyro_id != older.gyro_id:
            raise HandoffError(f'the file holds gyro {older.gyro_id!r}, this calibration is for '
                               f'gyro {self.gyro_id!r}; not merging them (use another --out).')
        mine = set(self.methods)
        kept = {k: v for k, v in older.values.items()
                if schema.get(_base_key(k), HandoffKey(k, '', '')).method not in mine}
        methods = {m: p for m, p in older.methods.items() if m not in mine}
        methods.update(self.methods)
        return Calibration({**kept, **self.values}, methods, self.gyro_id or older.gyro_id)


def _base_key(key: str) -> str:
    return key[:-4] if key.endswith('_std') else key


def method_calibration(method: str, values: Mapping[str, Any], provenance: Provenance, *,
                       gyro_id: str = '',
                       schema: Mapping[str, HandoffKey] | None = None) -> Calibration:
    """One method's results as a :class:`Calibration`, every key validated.

    Args:
        method: the method name (its keys must belong to it).
        values: hand-off key → value, with ``<key>_std`` beside each uncertain value.
        provenance: source, data span, missing keys with reasons.
        gyro_id: the gyro's serial or name, if known.
        schema: the known keys (default: every registered method's).

    Raises:
        HandoffError: a key unknown or of another method, a value invalid, a ``_std`` missing.
    """
    sch = _schema(schema)
    for key in values:
        spec = sch.get(_base_key(key))
        if spec is None or spec.method != method:
            raise HandoffError(f'{key} is not a hand-off key of method {method}.')
    checked = _checked_values(dict(values), sch, source=f'{method} results')
    return Calibration(checked, {method: provenance}, gyro_id)


def _checked_values(values: dict[str, Any], schema: Mapping[str, HandoffKey], *,
                    source: str) -> dict[str, Any]:
    """``values`` validated against ``schema`` (numbers made floats where floats are meant)."""
    unknown = sorted(k for k in values if _base_key(k) not in schema
                     or (k.endswith('_std') and not schema[_base_key(k)].has_std))
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
        else:
            if spec.has_std and key + '_std' not in values:
                raise HandoffError(f'gyro.{key} in {source} has no gyro.{key}_std beside it '
                                   '(every value goes with its standard uncertainty).')
            problem = _problem(spec, value)
        if problem:
            if isinstance(value, str) and spec.kind != 'text':
                problem += ' (YAML 1.1 floats need a dot: 4.0e-6, not 4e-6)'
            raise HandoffError(f'gyro.{key} = {value!r} in {source} is invalid: {problem}.')
        is_float = key.endswith('_std') or spec.kind in ('float', 'positive', 'nonnegative')
        out[key] = float(value) if is_float else value
    return out


# ---------------------------------------------------------------------------------------
# On-disk shape


class ProvenanceYaml(TypedDict, total=False):
    """On-disk ``methods.<name>`` mapping."""

    source: str
    created_utc: str
    data_start_stamp_ns: int
    data_end_stamp_ns: int
    missing: dict[str, str]


class CalibrationYaml(TypedDict):
    """On-disk shape of the whole hand-off file, format 2 (see the module docstring)."""

    format_version: int
    gyro_calib_version: str
    gyro_id: str
    complete: bool
    missing: dict[str, str]
    gyro: dict[str, Any]
    methods: dict[str, ProvenanceYaml]


_TOP_LEVEL = ('format_version', 'gyro_calib_version', 'gyro_id', 'complete', 'missing', 'gyro',
              'methods')
_PROVENANCE_KEYS = ('source', 'created_utc', 'data_start_stamp_ns', 'data_end_stamp_ns',
                    'missing')


def calibration_to_yaml_dict(calibration: Calibration,
                             schema: Mapping[str, HandoffKey] | None = None) -> CalibrationYaml:
    """The on-disk mapping of ``calibration`` (keys in schema order, each value then its std)."""
    sch = _schema(schema)
    order = {k: i for i, k in enumerate(sch)}
    keys = sorted(calibration.values, key=lambda k: (order.get(_base_key(k), len(order)),
                                                     k.endswith('_std'), k))
    methods: dict[str, ProvenanceYaml] = {}
    for name, prov in calibration.methods.items():
        entry = ProvenanceYaml(source=prov.source, created_utc=prov.created_utc,
                               data_start_stamp_ns=prov.data_start_stamp_ns,
                               data_end_stamp_ns=prov.data_end_stamp_ns)
        missing = {k: v for k, v in prov.missing.items() if k not in calibration.values}
        if missing:
            entry['missing'] = missing
        methods[name] = entry
    return CalibrationYaml(
        format_version=FORMAT_VERSION, gyro_calib_version=calibration.gyro_calib_version,
        gyro_id=calibration.gyro_id, complete=calibration.complete,
        missing=calibration.missing, gyro={k: calibration.values[k] for k in keys},
        methods=methods)


def calibration_from_yaml_dict(data: Any, *, source: str = 'mapping',
                               schema: Mapping[str, HandoffKey] | None = None) -> Calibration:
    """Validate an on-disk mapping (format 2, or format 1) and build its :class:`Calibration`.

    Raises:
        HandoffError: naming ``source`` and the key, for a document that is not a mapping,
            an unknown ``format_version``, missing or unknown keys, wrong types or values.
    """
    if not isinstance(data, dict):
        raise HandoffError(f'{source} must hold a mapping, got {type(data).__name__}.')
    version = data.get('format_version')
    if version == 1:
        return _from_format_1(data, source, _schema(schema))
    if 'format_version' in data and version != FORMAT_VERSION:
        raise HandoffError(f'{source} has format_version {version!r}; this gyro_calib '
                           f'({__version__}) reads format_version 1 and {FORMAT_VERSION}.')
    missing_top = [k for k in ('format_version', 'gyro', 'methods') if k not in data]
    if missing_top:
        raise HandoffError(f'field(s) {", ".join(missing_top)} missing in {source}.')
    unknown = sorted(set(data) - set(_TOP_LEVEL))
    if unknown:
        raise HandoffError(f'unknown field(s) {", ".join(unknown)} in {source}.')
    gyro, methods = data['gyro'], data['methods']
    if not isinstance(gyro, dict) or not isinstance(methods, dict):
        raise HandoffError(f'fields gyro and methods in {source} must be mappings.')
    sch = _schema(schema)
    values = _checked_values(dict(gyro), sch, source=source)
    provenance = {name: _provenance(name, entry, source, sch)
                  for name, entry in methods.items()}
    for key in values:
        owner = sch[_base_key(key)].method
        if owner not in provenance:
            raise HandoffError(f'gyro.{key} in {source} belongs to method {owner}, which has no '
                               'entry under methods.')
    gyro_id = data.get('gyro_id', '')
    if not isinstance(gyro_id, str):
        raise HandoffError(f'field gyro_id in {source} must be a string.')
    return Calibration(values, provenance, gyro_id, str(data.get('gyro_calib_version', '')),
                       FORMAT_VERSION)


def _provenance(name: str, entry: Any, source: str,
                schema: Mapping[str, HandoffKey]) -> Provenance:
    where = f'methods.{name} in {source}'
    if name not in {k.method for k in schema.values()}:
        raise HandoffError(f'unknown method {name!r} under methods in {source}.')
    if not isinstance(entry, dict):
        raise HandoffError(f'{where} must be a mapping.')
    missing = [k for k in _PROVENANCE_KEYS[:4] if k not in entry]
    unknown = sorted(set(entry) - set(_PROVENANCE_KEYS))
    if missing or unknown:
        raise HandoffError(f'{where}: ' + '; '.join(
            ([f'field(s) {", ".join(missing)} missing'] if missing else [])
            + ([f'unknown field(s) {", ".join(unknown)}'] if unknown else [])) + '.')
    created = entry['created_utc']
    if isinstance(created, datetime.datetime):  # YAML read an unquoted timestamp
        created = created.isoformat()
    try:
        datetime.datetime.fromisoformat(str(created))
    except ValueError:
        raise HandoffError(f'{where}: created_utc = {created!r} is invalid: it must be an '
                           'ISO-8601 date and time.') from None
    start, end = entry['data_start_stamp_ns'], entry['data_end_stamp_ns']
    for key, value in (('data_start_stamp_ns', start), ('data_end_stamp_ns', end)):
        if isinstance(value, bool) or not isinstance(value, int):
            raise HandoffError(f'{where}: {key} = {value!r} is invalid: it must be an integer.')
    if end < start:
        raise HandoffError(f'{where}: data_end_stamp_ns = {end} is invalid: it must be at '
                           f'least data_start_stamp_ns = {start}.')
    if not isinstance(entry['source'], str):
        raise HandoffError(f'{where}: source must be a string.')
    missing_keys = entry.get('missing', {}) or {}
    if not isinstance(missing_keys, dict) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in missing_keys.items()):
        raise HandoffError(f'{where}: missing must map keys to reasons.')
    return Provenance(entry['source'], start, end, dict(missing_keys), str(created))


_FORMAT_1_TOP = ('format_version', 'gyro_calib_version', 'created_utc', 'source',
                 'data_start_stamp_ns', 'data_end_stamp_ns', 'gyro')
_FORMAT_1_GYRO = ('k_tilde_rad_per_pulse', 'k_tilde_rad_per_pulse_std',
                  'scale_factor_rad_per_pulse', 'scale_factor_rad_per_pulse_std',
                  'fix_error_angle_rad', 'fix_error_angle_rad_std', 'bias_rad_s',
                  'bias_rad_s_std', 'angle_random_walk_rad_per_sqrt_s',
                  'angle_random_walk_rad_per_sqrt_s_std', 'window_pairs', 'stations')
_FORMAT_1_REQUIRED = ('k_tilde_rad_per_pulse', 'k_tilde_rad_per_pulse_std', 'bias_rad_s',
                      'bias_rad_s_std', 'window_pairs', 'stations')


def _from_format_1(data: dict[str, Any], source: str,
                   schema: Mapping[str, HandoffKey]) -> Calibration:
    """A format 1 file (RBRLG only; gyro_calib 0.1): same keys, flat metadata."""
    gyro = data.get('gyro')
    if 'gyro' in data and not isinstance(gyro, dict):
        raise HandoffError(f'field gyro in {source} must be a mapping of values.')
    gyro = gyro or {}
    missing = [k for k in _FORMAT_1_TOP if k not in data] + [
        f'gyro.{k}' for k in _FORMAT_1_REQUIRED if 'gyro' in data and k not in gyro]
    if missing:
        raise HandoffError(f'field(s) {", ".join(missing)} missing in {source}.')
    unknown = sorted(set(data) - set(_FORMAT_1_TOP)) + sorted(
        f'gyro.{k}' for k in set(gyro) - set(_FORMAT_1_GYRO))
    if unknown:
        raise HandoffError(f'unknown field(s) {", ".join(unknown)} in {source}.')
    if ('fix_error_angle_rad' in gyro) != ('scale_factor_rad_per_pulse' in gyro):
        raise HandoffError(f'fix_error_angle_rad and scale_factor_rad_per_pulse must be given '
                           f'together or both left out in {source}.')
    values = _checked_values(dict(gyro), schema, source=source)
    entry = {k: data[k] for k in ('source', 'created_utc', 'data_start_stamp_ns',
                                  'data_end_stamp_ns')}
    methods = {'rbrlg': _provenance('rbrlg', entry, source, schema)}
    if 'angle_random_walk_rad_per_sqrt_s' in values:
        methods['noise'] = methods['rbrlg']
    return Calibration(values, methods, '', str(data['gyro_calib_version']), 1)


# ---------------------------------------------------------------------------------------
# Files


def write_calibration(path: str | Path, calibration: Calibration,
                      schema: Mapping[str, HandoffKey] | None = None) -> Path:
    """Write ``calibration`` to ``path`` atomically: the old file or the new, never a mix.

    A temporary file in the same directory is written, flushed and fsynced, renamed onto
    the target by ``os.replace`` and the directory is fsynced. The file keeps the mode of
    the file it replaces (new files: 0666 & ~umask, :mod:`gyro_calib.outputs`). Symbolic
    links are followed: the link's target is replaced.

    Returns:
        The absolute path written.

    Raises:
        HandoffError: naming the path and the OS reason, if any step fails; no temporary
            file is left behind and an existing file is untouched (unless only the final
            directory fsync failed, as the message then says).
    """
    target = Path(path).resolve()
    text = ('# gyro_calib INS hand-off calibration; layout: gyro_calib/handoff.py\n'
            + yaml.safe_dump(dict(calibration_to_yaml_dict(calibration, schema)),
                             sort_keys=False, allow_unicode=True, width=100))
    tmp: str | None = None
    try:
        mode = new_file_mode(target)
        fd, tmp = tempfile.mkstemp(prefix=f'.{target.name}.', suffix='.tmp', dir=target.parent)
        with os.fdopen(fd, 'w', encoding='utf-8') as stream:
            stream.write(text)
            stream.flush()
            os.fchmod(stream.fileno(), mode)
            os.fsync(stream.fileno())
        os.replace(tmp, target)
        tmp = None
    except OSError as exc:
        raise HandoffError(f'cannot write calibration file {target}: '
                           f'{exc.strerror or exc}.') from None
    finally:
        if tmp is not None:  # failed (or interrupted) before the rename
            try:
                os.unlink(tmp)
            except OSError:
                pass
    try:
        _fsync_directory(target.parent)
    except OSError as exc:
        raise HandoffError(f'calibration file {target} was written but its directory could '
                           f'not be synced, so it may not survive a power loss: '
                           f'{exc.strerror or exc}.') from None
    return target


def update_calibration(path: str | Path, calibration: Calibration,
                       schema: Mapping[str, HandoffKey] | None = None) -> Path:
    """Merge ``calibration`` into the gyro's file at ``path`` (created if absent), atomically.

    The keys of the methods in ``calibration`` are replaced; other methods' keys and their
    provenance are kept, so calibrating one method never loses what another measured.

    Raises:
        HandoffError: the existing file is unreadable or invalid (it is left untouched: fix or
            move it), it belongs to another gyro, or the write fails.
    """
    sch = _schema(schema)
    target = Path(path)
    if target.exists():
        calibration = calibration.merged_into(load_calibration(target, sch), sch)
    return write_calibration(target, calibration, sch)


def _fsync_directory(directory: Path) -> None:
    fd = os.open(directory, os.O_RDONLY | getattr(os, 'O_DIRECTORY', 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def load_calibration(path: str | Path,
                     schema: Mapping[str, HandoffKey] | None = None) -> Calibration:
    """Read and validate a hand-off calibration file (format 2 or 1).

    Raises:
        HandoffError: naming the file, if it is missing or unreadable, not valid YAML, or
            its content is invalid (see :func:`calibration_from_yaml_dict`).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except OSError as exc:
        raise HandoffError(f'cannot read calibration file {path}: '
                           f'{exc.strerror or exc}.') from None
    except UnicodeDecodeError as exc:
        raise HandoffError(f'calibration file {path} is not UTF-8 text: {exc.reason}.') from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        reason = ' '.join(str(exc).split())
        raise HandoffError(f'calibration file {path} is not valid YAML: {reason}.') from None
    return calibration_from_yaml_dict(data, source=f'calibration file {path}', schema=schema)


def keys_table(keys: Iterable[HandoffKey]) -> str:
    """A Markdown table of hand-off keys (README)."""
    lines = ['| key | method | meaning |', '|---|---|---|']
    for k in keys:
        std = ' (+ `_std`)' if k.has_std else ''
        text = k.description.replace('|', '\\|')
        lines.append(f'| `{k.name}`{std} | {k.method} | {text} |')
    return '\n'.join(lines)
