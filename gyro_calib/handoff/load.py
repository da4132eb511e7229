"""Reading a hand-off file: formats 1 to 4, every field checked, errors naming the file.

:func:`load_calibration` reads a file, :func:`calibration_from_yaml_dict` a mapping; a file
of format 1 (RBRLG only, flat metadata) or 2 (one provenance per method) loads as well.
"""

from __future__ import annotations

import dataclasses
import datetime
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from gyro_calib import __version__
from gyro_calib.handoff.calibration import Calibration
from gyro_calib.handoff.layout import _PROVENANCE_KEYS, _TOP_LEVEL, DEVIATION_FIELDS
from gyro_calib.handoff.runs import Provenance
from gyro_calib.handoff.schema import (
    FORMAT_VERSION,
    IMU_FORMAT_VERSION,
    IMU_METHODS,
    READ_VERSIONS,
    HandoffError,
    HandoffKey,
    _base_key,
    _checked_values,
    _numbers,
    _schema,
)
from gyro_calib.imu_calibration import ImuSectionError, imu_from_section


def calibration_from_yaml_dict(data: Any, *, source: str = 'mapping',
                               schema: Mapping[str, HandoffKey] | None = None) -> Calibration:
    """Validate an on-disk mapping (format 2, or format 1) and build its :class:`Calibration`.

    Raises:
        HandoffError: naming ``source`` and the key, for a document that is not a mapping,
            an unknown ``format_version``, missing or unknown keys, wrong types or values.
    """
    if data is None:
        raise HandoffError(f'{source} is empty: a hand-off file holds a YAML mapping '
                           '(format_version, gyro, methods).')
    if not isinstance(data, dict):
        raise HandoffError(f'{source} must hold a mapping, got {type(data).__name__}.')
    version = data.get('format_version')
    if version == 1:
        return _from_format_1(data, source, _schema(schema))
    if 'format_version' in data and version not in READ_VERSIONS:
        raise HandoffError(f'{source} has format_version {version!r}; this gyro_calib '
                           f'({__version__}) reads format_version 1, 2, {FORMAT_VERSION} and '
                           f'{IMU_FORMAT_VERSION}.')
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
    for field_name in ('missing', 'not_measurable'):  # format 3: once, at the top level
        listed = data.get(field_name, {}) or {}
        if not isinstance(listed, dict) or not all(
                isinstance(k, str) and isinstance(v, str) for k, v in listed.items()):
            raise HandoffError(f'field {field_name} in {source} must map keys to reasons.')
        if version == 2:
            continue  # format 2 repeats missing per method (read there)
        for key, why in listed.items():
            spec = sch.get(key)
            if spec is None or spec.method not in provenance:
                raise HandoffError(f'{field_name}.{key} in {source} is not a key of a method '
                                   'under methods.')
            prov = provenance[spec.method]
            target = dict(getattr(prov, field_name))
            target[key] = why
            change: dict[str, Any] = {field_name: target}
            provenance[spec.method] = dataclasses.replace(prov, **change)
    conventions = data.get('conventions', {})
    if not isinstance(conventions, dict):
        raise HandoffError(f'field conventions in {source} must be a mapping.')
    gyro_id = data.get('gyro_id', '')
    if not isinstance(gyro_id, str):
        raise HandoffError(f'field gyro_id in {source} must be a string.')
    imu = None
    if 'imu' in data:
        if version != IMU_FORMAT_VERSION:
            raise HandoffError(f'{source} has an imu section but format_version {version!r}; '
                               f'a file with an imu section is format_version '
                               f'{IMU_FORMAT_VERSION}.')
        try:
            imu = imu_from_section(data['imu'], source=source)
        except ImuSectionError as exc:
            raise HandoffError(str(exc)) from None
    return Calibration(values, provenance, gyro_id, str(data.get('gyro_calib_version', '')),
                       int(data['format_version']), imu)  # = version, checked above


def _provenance(name: str, entry: Any, source: str,
                schema: Mapping[str, HandoffKey], *, nested: bool = False) -> Provenance:
    where = f'methods.{name} in {source}'
    if name not in {k.method for k in schema.values()} | set(IMU_METHODS):
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
    conditions = entry.get('conditions', {}) or {}
    if not isinstance(conditions, dict):
        raise HandoffError(f'{where}: conditions must be a mapping of bench settings.')
    settings = entry.get('settings', {}) or {}
    if not isinstance(settings, dict) or not all(isinstance(k, str) for k in settings):
        raise HandoffError(f'{where}: settings must be a mapping of the run\'s settings.')
    keys = entry.get('keys')
    if keys is not None and (not isinstance(keys, list) or not all(
            isinstance(k, str) and schema.get(k, HandoffKey(k, '', '')).method == name
            for k in keys)):
        raise HandoffError(f'{where}: keys must list hand-off keys of method {name}.')
    earlier_entries = entry.get('earlier_runs', []) or []
    if not isinstance(earlier_entries, list) or (nested and earlier_entries):
        raise HandoffError(f'{where}: earlier_runs must be a list of runs (not nested).')
    earlier = tuple(_provenance(name, e, source, schema, nested=True) for e in earlier_entries)
    return Provenance(entry['source'], start, end, dict(missing_keys), str(created),
                      dict(conditions), {}, tuple(keys) if keys is not None else None, earlier,
                      _deviations(entry.get('deviations', {}) or {}, where), dict(settings))


def _deviations(tables: Any, where: str) -> dict[str, dict[str, Any]]:
    """Check ``methods.<name>.deviations``: axis → field → a list per τ (or the unit)."""
    if not isinstance(tables, dict):
        raise HandoffError(f'{where}: deviations must map axes to tables.')
    out: dict[str, dict[str, Any]] = {}
    for axis, table in tables.items():
        if not isinstance(table, dict) or not isinstance(table.get('tau_s'), list):
            raise HandoffError(f'{where}: deviations.{axis} must be a table with tau_s.')
        n = len(table['tau_s'])
        for name, column in table.items():
            if name not in DEVIATION_FIELDS:
                raise HandoffError(f'{where}: deviations.{axis}.{name} is not one of '
                                   f'{", ".join(DEVIATION_FIELDS)}.')
            if name == 'unit':
                if not isinstance(column, str):
                    raise HandoffError(f'{where}: deviations.{axis}.unit must be a string.')
                continue
            if not isinstance(column, list) or len(column) != n or not all(
                    v is None or (_numbers(v) and not isinstance(v, bool)) for v in column):
                raise HandoffError(f'{where}: deviations.{axis}.{name} must list {n} numbers '
                                   '(null where there is none), one per tau_s.')
        out[str(axis)] = dict(table)
    return out


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


def check_handoff_output(path: str | Path, what: str,
                         schema: Mapping[str, HandoffKey] | None = None, *,
                         gyro_id: str = '', nothing: str = 'Nothing was read.') -> Path:
    """A hand-off file to be written or updated, checked before any work; its absolute path.

    The one check of every front door that writes a hand-off file (``gyro-calib calibrate
    --out``, ``noise --out``, ``bench_demo --out``, a calibration node's ``output_file``): a
    file that can be written there (:func:`gyro_calib.outputs.check_output_file`: not a
    directory, in an existing writable directory, a link's target directory too), and an
    existing file that is a hand-off file this run can update (``gyro_id`` given: of that
    gyro or none). ``nothing`` ends a refusal of the place ('Nothing was started.' for a
    node).

    Raises:
        ConfigError: one line naming ``what`` (``--out``, ``output_file``) and ``path``.
    """
    from gyro_calib.errors import ConfigError
    from gyro_calib.outputs import check_output_file

    try:
        checked = check_output_file(path, what, follow_links=True)
    except ConfigError as exc:
        raise ConfigError(str(exc).replace('Nothing was read.', nothing)) from None
    if not checked.exists():
        return checked
    try:
        held = load_calibration(checked, schema).gyro_id
    except HandoffError as exc:
        raise ConfigError(f'{what} {path} exists and cannot be updated: {exc} Give a new path, '
                          'or move the file away.') from None
    if gyro_id and held and held != gyro_id:
        raise ConfigError(f'{what} {path} exists and cannot be updated: the file holds gyro '
                          f'{held!r}, this calibration is for gyro {gyro_id!r}; not merging '
                          'them. Give a new path, or move the file away.')
    return checked
