"""The record of one gyro: :class:`Calibration`, its queries and its merge with a file.

:func:`method_calibration` builds one method's results, every key validated;
:meth:`Calibration.merged_into` merges a run into a file's content
(:mod:`~gyro_calib.handoff.merge`, :mod:`~gyro_calib.handoff.scale_factor`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from gyro_calib import __version__
from gyro_calib.handoff.merge import _merge_method, _merged_imu, _with_std
from gyro_calib.handoff.runs import Provenance, _own_keys
from gyro_calib.handoff.scale_factor import scale_factor_findings
from gyro_calib.handoff.schema import (
    FORMAT_VERSION,
    HandoffError,
    HandoffKey,
    _base_key,
    _checked_values,
    _ordered,
    _pop_twins,
    _schema,
)
from gyro_calib.handoff.sensor import another_sensor
from gyro_calib.imu_calibration import ImuCalibration


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
    imu: ImuCalibration | None = None

    @property
    def missing(self) -> dict[str, str]:
        """Every measurable key not measured, with its reason.

        Every key the latest run of a method could measure from its bench but did not (and
        no earlier run gave), with its reason.
        """
        out: dict[str, str] = {}
        for prov in self.methods.values():
            out.update({k: v for k, v in prov.missing.items()
                        if k not in self.values and k not in prov.not_measurable})
        return out

    @property
    def not_measurable(self) -> dict[str, str]:
        """Keys the methods that ran give, but not from the benches they ran on, with why."""
        out: dict[str, str] = {}
        for prov in self.methods.values():
            out.update({k: v for k, v in prov.not_measurable.items() if k not in self.values})
        return out

    @property
    def complete(self) -> bool:
        """True when the methods that ran measured everything their benches can give."""
        return not self.missing

    def source_of(self, key: str, schema: Mapping[str, HandoffKey] | None = None,
                  ) -> Provenance | None:
        """The run a value came from (None when absent)."""
        base = _base_key(key)
        if base not in self.values:
            return None
        method = _schema(schema)[base].method
        latest = self.methods.get(method)
        if latest is None:
            return None
        for run in (latest, *latest.earlier):
            if run.keys is None or base in run.keys:
                return run
        return latest

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

    def merged_into(self, older: Calibration, schema: Mapping[str, HandoffKey], *,
                    replace: bool = False, report: list[str] | None = None) -> Calibration:
        """``older`` (a file) updated with this run, key by key (see the module docstring).

        Args:
            older: the file's content.
            schema: the known keys.
            replace: take this run's values even where the file's are more precise or
                disagree with them (the gyro was repaired, a bench setting was wrong).
            report: one line per key of the methods that ran is appended to it: added,
                replaced, kept (and why) or dropped.

        Raises:
            HandoffError: the file is of another gyro or another sensor (kind, channels, sample
                rate: :func:`~gyro_calib.handoff.sensor.another_sensor`); a value differs from the
                file's by more than :data:`MAX_DISAGREEMENT_SIGMA` combined standard uncertainties
                (without ``replace``); the result would hold a model fitted with another scale
                factor than the file's, or a run whose values rest on another scale factor than the
                file's by more than :data:`MAX_SCALE_FACTOR_SHIFT` of a standard uncertainty (with
                ``replace``, a new scale factor drops such a run of the file instead).
        """
        lines = report if report is not None else []
        if self.gyro_id and older.gyro_id and self.gyro_id != older.gyro_id:
            raise HandoffError(f'the file holds gyro {older.gyro_id!r}, this calibration is for '
                               f'gyro {self.gyro_id!r}; not merging them (use another --out).')
        if older.gyro_id and not self.gyro_id:
            lines.append(f'gyro_id: this run named no gyro; the file is for gyro '
                         f'{older.gyro_id!r}, so its values are taken as that gyro\'s.')
        elif self.gyro_id and not older.gyro_id and older.values:
            lines.append(f'gyro_id: the file named no gyro; it is now gyro {self.gyro_id!r}.')
        other = another_sensor(self, older)
        if other is not None:
            raise HandoffError(f'{other}; not merging them: one sensor per file (use another '
                               '--out).')
        values = dict(older.values)
        methods = dict(older.methods)
        for method, prov in self.methods.items():
            methods[method] = _merge_method(method, prov, self.values, older, values, schema,
                                            replace, lines)
        imu = _merged_imu(self, older, lines, replace)
        merged = Calibration(values, methods, self.gyro_id or older.gyro_id, imu=imu)
        findings = scale_factor_findings(merged, schema, new_methods=self.methods)
        while findings.problem and replace and findings.stale is not None:
            merged = _without_run(merged, *findings.stale, schema, lines)
            findings = scale_factor_findings(merged, schema, new_methods=self.methods)
        if findings.problem:
            raise HandoffError(findings.problem)
        others = sorted({schema[_base_key(k)].method for k in merged.values
                         if _base_key(k) in schema} - set(self.methods))
        if others:
            n = len({_base_key(k) for k in merged.values
                     if schema.get(_base_key(k), HandoffKey(k, '', '')).method in others})
            lines.append(f'unchanged: {n} key(s) of method(s) {", ".join(others)}.')
        lines.extend(findings.notes)
        return merged


def _without_run(calibration: Calibration, method: str, run: Provenance, why: str,
                 schema: Mapping[str, HandoffKey], lines: list[str]) -> Calibration:
    """``calibration`` without the values of ``run`` (one of ``method``'s), each said in a line.

    Its values go together (they rest on one scale factor, ``why``); the keys become missing
    with that reason, and the run stays named (no keys) when it is the method's latest.
    """
    latest = calibration.methods[method]
    dropped = _ordered(_own_keys(run, latest, method, calibration.values, schema), schema)
    values = dict(calibration.values)
    reason = (f'dropped (replace asked): the {method} run {run.source} {why}; re-run {method} '
              'with --calibration FILE.')
    lines.append(f'{reason[:-1]}: its {len(dropped)} value(s) go.')
    for key in dropped:
        lines.append(f'dropped: {key} = {_with_std(values.get(key), values.get(key + "_std"))} '
                     f'from {run.source} (rests on another scale factor).')
        values.pop(key, None)
        _pop_twins(values, key)
    missing = {**latest.missing, **{k: reason for k in dropped}}
    if run is latest:
        latest = dataclasses.replace(latest, keys=(), missing=missing)
    else:
        latest = dataclasses.replace(latest, missing=missing,
                                     earlier=tuple(e for e in latest.earlier if e is not run))
    return dataclasses.replace(calibration, values=values,
                               methods={**calibration.methods, method: latest})


def method_calibration(method: str, values: Mapping[str, Any], provenance: Provenance, *,
                       gyro_id: str = '',
                       schema: Mapping[str, HandoffKey] | None = None) -> Calibration:
    """One method's results as a :class:`Calibration`, every key validated.

    Args:
        method: the method name (its keys must belong to it).
        values: hand-off key → value, with ``<key>_std`` beside each uncertain value.
        provenance: source, data span, missing keys with reasons.
        gyro_id: the gyro's serial or name, if known.
        schema: the known keys (default: the installed schema, every registered method's).

    Raises:
        HandoffError: a key unknown or of another method, a value invalid, a ``_std`` missing.
    """
    sch = _schema(schema)
    for key in values:
        spec = sch.get(_base_key(key))
        if spec is None or spec.method != method:
            raise HandoffError(f'{key} is not a hand-off key of method {method}.')
    checked = _checked_values(dict(values), sch, source=f'{method} results')
    keys = _ordered({_base_key(k) for k in checked}, sch)
    return Calibration(checked, {method: dataclasses.replace(provenance, keys=keys)}, gyro_id)
