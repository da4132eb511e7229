"""The on-disk shape of a hand-off file (format 3, or 4 with ``imu:``) and a record → it.

:class:`CalibrationYaml` and :class:`ProvenanceYaml` are the mappings written;
:func:`calibration_to_yaml_dict` turns a :class:`~gyro_calib.handoff.calibration.Calibration`
into one (keys in schema order, each value then its ``_std`` and ``_dof``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NotRequired, TypedDict

from gyro_calib.handoff.calibration import Calibration
from gyro_calib.handoff.runs import Provenance, _run_keys
from gyro_calib.handoff.schema import (
    CONVENTIONS,
    FORMAT_VERSION,
    IMU_CONVENTION,
    IMU_FORMAT_VERSION,
    HandoffKey,
    _base_key,
    _numbers,
    _ordered,
    _schema,
)


class ProvenanceYaml(TypedDict, total=False):
    """On-disk ``methods.<name>`` mapping."""

    source: str
    created_utc: str
    data_start_stamp_ns: int
    data_end_stamp_ns: int
    missing: dict[str, str]  # format 2 only (format 3: once, at the top level)
    conditions: dict[str, Any]
    keys: list[str]
    earlier_runs: list[ProvenanceYaml]
    deviations: dict[str, dict[str, Any]]
    settings: dict[str, Any]


class CalibrationYaml(TypedDict):
    """On-disk shape of the whole hand-off file, format 3 or 4 (see :mod:`gyro_calib.handoff`)."""

    format_version: int
    gyro_calib_version: str
    gyro_id: str
    conventions: dict[str, str]
    complete: bool
    missing: dict[str, str]
    not_measurable: dict[str, str]
    gyro: dict[str, Any]
    imu: NotRequired[dict[str, Any]]
    methods: dict[str, ProvenanceYaml]


_TOP_LEVEL = ('format_version', 'gyro_calib_version', 'gyro_id', 'conventions', 'complete',
              'missing', 'not_measurable', 'gyro', 'imu', 'methods')
_PROVENANCE_KEYS = ('source', 'created_utc', 'data_start_stamp_ns', 'data_end_stamp_ns',
                    'missing', 'conditions', 'settings', 'keys', 'earlier_runs',
                    'deviations')

DEVIATION_FIELDS = ('tau_s', 'm', 'clusters', 'noise_alpha', 'unit',
                    *(f'{name}{suffix}' for name in ('adev', 'mdev', 'hdev', 'totdev')
                      for suffix in ('', '_std', '_edf')))
"""What one axis of ``methods.<name>.deviations`` may hold: ``tau_s`` (the averaging times,
s), ``m`` (τ/τ₀), ``clusters`` (independent clusters at each τ), ``noise_alpha`` (the
dominant power-law noise type, an integer; the EDF blends the types by their shares,
docs/methods.md §E.2), ``unit`` (of the deviations: rad/s or m/s²), and per
deviation (ADEV overlapping, MDEV modified, HDEV overlapping Hadamard, TOTDEV total) its
value, its standard uncertainty ``_std`` and its equivalent degrees of freedom ``_edf`` at
each τ; a list per field, one entry per τ, null where a deviation has no value there."""


def _run_yaml(prov: Provenance, method: str, calibration: Calibration,
              schema: Mapping[str, HandoffKey]) -> ProvenanceYaml:
    entry = ProvenanceYaml(source=prov.source, created_utc=prov.created_utc,
                           data_start_stamp_ns=prov.data_start_stamp_ns,
                           data_end_stamp_ns=prov.data_end_stamp_ns,
                           conditions={k: (float(v) if _numbers(v) and not isinstance(v, int)
                                           else v) for k, v in prov.conditions.items()})
    if prov.settings:
        entry['settings'] = dict(prov.settings)
    keys = prov.keys if prov.keys is not None else sorted(
        _run_keys(prov, method, calibration.values, schema)
        - {k for e in prov.earlier if e.keys for k in e.keys})
    entry['keys'] = list(_ordered(keys, schema))
    if prov.deviations:
        entry['deviations'] = {axis: dict(table) for axis, table in prov.deviations.items()}
    return entry


def calibration_to_yaml_dict(calibration: Calibration,
                             schema: Mapping[str, HandoffKey] | None = None) -> CalibrationYaml:
    """The on-disk mapping of ``calibration`` (keys in schema order, each value then its std)."""
    sch = _schema(schema)
    order = {k: i for i, k in enumerate(sch)}
    keys = sorted(calibration.values, key=lambda k: (order.get(_base_key(k), len(order)),
                                                     k.endswith('_std') + 2 * k.endswith('_dof'),
                                                     k))
    methods: dict[str, ProvenanceYaml] = {}
    for name, prov in calibration.methods.items():
        entry = _run_yaml(prov, name, calibration, sch)
        entry['earlier_runs'] = [_run_yaml(e, name, calibration, sch) for e in prov.earlier]
        methods[name] = entry
    out = CalibrationYaml(
        format_version=FORMAT_VERSION, gyro_calib_version=calibration.gyro_calib_version,
        gyro_id=calibration.gyro_id, conventions=dict(CONVENTIONS, **(
            {'imu': IMU_CONVENTION} if calibration.imu is not None else {})),
        complete=calibration.complete, missing=calibration.missing,
        not_measurable=calibration.not_measurable,
        gyro={k: calibration.values[k] for k in keys}, methods=methods)
    if calibration.imu is None:
        return out
    out['format_version'] = IMU_FORMAT_VERSION
    out['imu'] = calibration.imu.to_section()
    # the imu section goes after gyro:, before methods: (a TypedDict keeps insertion order)
    moved = out.pop('methods')  # type: ignore[misc]
    out['methods'] = moved
    return out
