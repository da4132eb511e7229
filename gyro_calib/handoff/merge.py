"""How one run's values merge into a file's, key by key, each change said in a line.

Each quantity is kept from the run that measured it best (the keys that follow it go with
it); a value differing from the file's by more than :data:`MAX_DISAGREEMENT_SIGMA` combined
standard uncertainties is refused; the ``imu:`` section is replaced or completed
(:func:`_merged_imu`). :meth:`Calibration.merged_into
<gyro_calib.handoff.calibration.Calibration.merged_into>` applies these rules.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import Any

from gyro_calib.handoff.runs import CalibrationLike, Provenance, _run_keys
from gyro_calib.handoff.schema import (
    IMU_METHODS,
    TWIN_SUFFIXES,
    HandoffError,
    HandoffKey,
    _numbers,
    _ordered,
    _pop_twins,
)
from gyro_calib.imu_calibration import ImuCalibration

MAX_DISAGREEMENT_SIGMA = 5.0
"""A run's value differing from the file's by more than this many combined standard
uncertainties is not merged (another gyro, a changed gyro, or a wrong bench setting)."""


SAME_RUN = '(same run, updated).'
"""How a merge line ends when a live node rewrote the values of its own run."""


def merge_lines(report: Iterable[str]) -> list[str]:
    """The lines of a merge report worth telling (a node's rewrites of its own run left out)."""
    return [line for line in report if not line.endswith(SAME_RUN)]


def _imu_replacement(key: str, new: tuple[Any, float], old: tuple[Any, float],
                     prov: Provenance | None, before: Provenance | None,
                     replace: bool) -> str:
    """One value of the ``imu:`` section replaced: its line, new and old.

    Raises:
        HandoffError: the values differ by more than :data:`MAX_DISAGREEMENT_SIGMA`
            combined standard uncertainties (another run, not ``replace``), naming the
            settings that changed when the data are the same.
    """
    same = prov is not None and before is not None and prov.same_run(before)
    other = (f'the same data under other settings ({prov.settings_change(before)})'
             if prov is not None and before is not None and not same
             and prov.same_data(before) else '')
    (a, ua), (b, ub) = new, old
    if _numbers(a, b) and not isinstance(a, bool) and math.isfinite(a) and math.isfinite(b):
        spread = math.hypot(ua, ub)
        z = abs(a - b) / spread if spread > 0 else 0.0
        if z > MAX_DISAGREEMENT_SIGMA and not same and not replace:
            raise HandoffError(
                f'{key}: this run gives {_with_std(a, ua)} ({prov.source if prov else "?"}), '
                f'the file holds {_with_std(b, ub)}: they differ by {z:.1f} combined standard '
                'uncertainties (' + (f'{other}: which settings are right?' if other else
                                     'a changed triad, another triad, or a wrong bench '
                                     'setting?')
                + '); nothing written. Check, then give --replace to take this run\'s values, '
                'or use another --out.')
    why = SAME_RUN[1:-2] if same else ('replace asked' if replace else 'newer run')
    return (f'replaced: {key} = {_with_std(a, ua if math.isfinite(ua) else None)} — was '
            f'{_with_std(b, ub if math.isfinite(ub) else None)} ('
            + why + (f'; {other}' if other else '') + ').')


def _triad_changes(new: CalibrationLike, older: CalibrationLike, run: ImuCalibration,
                   old: ImuCalibration, replace: bool) -> list[str]:
    """A triad or multiposition run's K_i and b against the file's section: a line each.

    A line each value replaced, old and new; a value this run gives exactly as the file
    holds it (value and uncertainty) is not replaced and gets no line. The run's own method
    (:data:`IMU_METHODS`) is the provenance compared: a live node rewriting its own run
    says nothing (:data:`SAME_RUN`).

    Raises:
        HandoffError: see :func:`_imu_replacement`.
    """
    method = _imu_method(new)
    prov, before = new.methods.get(method), older.methods.get(method)
    lines: list[str] = []
    for name, labels in (('scale_factor_rad_per_pulse', run.channels), ('bias_rad_s', 'xyz')):
        v_new, u_new = getattr(run, name), getattr(run, name + '_std')
        v_old, u_old = getattr(old, name), getattr(old, name + '_std')
        if v_new is None or v_old is None:
            continue
        for i, label in enumerate(labels):
            j = old.channels.index(label) if name != 'bias_rad_s' else i
            ua = float(u_new[i]) if u_new is not None else math.nan
            ub = float(u_old[j]) if u_old is not None else math.nan
            if v_new[i] is None or v_old[j] is None:
                continue
            same_std = ua == ub or (math.isnan(ua) and math.isnan(ub))
            if float(v_new[i]) == float(v_old[j]) and same_std:
                continue  # the same value: nothing replaced
            lines.append(_imu_replacement(f'imu.{name}[{label}]', (float(v_new[i]), ua),
                                          (float(v_old[j]), ub), prov, before, replace))
    return lines


def _per_channel_changes(new: CalibrationLike, older: CalibrationLike, run: ImuCalibration,
                         old: ImuCalibration, replace: bool) -> list[str]:
    """A run's per-channel noise and thermal terms against the file's: a line each replaced.

    Raises:
        HandoffError: see :func:`_imu_replacement`.
    """
    lines: list[str] = []
    for name in ('noise', 'thermal'):
        prov, before = new.methods.get(name), older.methods.get(name)
        for channel, terms in getattr(run, name).items():
            was = getattr(old, name).get(channel, {})
            for key, value in terms.items():
                if key.endswith(TWIN_SUFFIXES) or key not in was:
                    continue
                u_new, u_old = terms.get(key + '_std'), was.get(key + '_std')
                lines.append(_imu_replacement(
                    f'imu.{name}.{channel}.{key}',
                    (value, float(u_new) if _numbers(u_new) else math.nan),
                    (was[key], float(u_old) if _numbers(u_old) else math.nan),
                    prov, before, replace))
    return lines


def _merged_imu(new: CalibrationLike, older: CalibrationLike,
                lines: list[str], replace: bool = False) -> ImuCalibration | None:
    """The ``imu:`` section after a merge, each change said in a line.

    A triad run (:data:`IMU_METHODS`) replaces the section but keeps the file's per-channel
    ``noise`` and ``thermal`` where it brings none; any other run (the noise method on
    ``/imu/pulses``) keeps the file's section and sets its ``noise`` (and ``thermal``) per
    channel. A file without the section gets this run's.

    Each value replaced (a triad's K_i and b, a channel's noise or thermal term) is said in a
    line with its old value and checked as the top-level keys are (:func:`_imu_replacement`).

    Raises:
        HandoffError: the run's channels are not the file's section's; a value differs from
            the file's by more than :data:`MAX_DISAGREEMENT_SIGMA` combined standard
            uncertainties (without ``replace``).
    """
    run, old = new.imu, older.imu
    if run is None:
        return old
    if old is None:
        lines.append(f'imu: added (K, sense axes, M and b of the {IMU_SOURCES[_imu_method(new)]}).'
                     if any(m in IMU_METHODS for m in new.methods) else
                     f'imu: added with the channels {list(run.channels)} and their '
                     f'{_per_channel_words(run)} only.')
        return run
    if set(run.channels) != set(old.channels):
        raise HandoffError(f'the file\'s imu section has the channels {list(old.channels)}, '
                           f'this run the channels {list(run.channels)}: another IMU? Not '
                           'merging them (use another --out).')
    if any(m in IMU_METHODS for m in new.methods):
        changes = _triad_changes(new, older, run, old, replace)
        kept = {name: getattr(old, name) for name in ('noise', 'thermal')
                if getattr(old, name) and not getattr(run, name)}
        lines.append('imu: the file\'s imu section (' + _imu_run(older) + ') replaced by this '
                     'run\'s' + (f'; its {" and ".join(kept)} per channel kept (not measured '
                                  'by this run).' if kept else '.'))
        lines.extend(changes)
        return dataclasses.replace(run, **kept)
    changed = {name: getattr(run, name) for name in ('noise', 'thermal') if getattr(run, name)}
    changes = _per_channel_changes(new, older, run, old, replace)
    lines.append(f'imu: the file\'s section kept (K, sense axes, M, b); its '
                 f'{_per_channel_words(run)} ' + ('replaced by this run\'s.' if any(
                     getattr(old, n) for n in changed) else 'set by this run.'))
    lines.extend(changes)
    return dataclasses.replace(old, **changed)


def _per_channel_words(imu: ImuCalibration) -> str:
    """'noise', 'thermal' or 'noise and thermal' terms per channel of a section."""
    return ' and '.join(n for n in ('noise', 'thermal') if getattr(imu, n)) + ' terms' \
        if imu.noise or imu.thermal else 'no terms'


IMU_SOURCES = {'triad': 'triad', 'multiposition': 'multiposition calibration'}
"""What an imu: section is of, by the method it came from (:data:`IMU_METHODS`)."""


def _imu_method(calibration: CalibrationLike) -> str:
    """The method of :data:`IMU_METHODS` a record's imu section comes from ('triad' if none)."""
    return next((m for m in IMU_METHODS if m in calibration.methods), 'triad')


def _imu_run(calibration: CalibrationLike) -> str:
    """The run the file's imu section came from, as a phrase."""
    run = calibration.methods.get(_imu_method(calibration))
    return f'run {run.label()}' if run is not None else 'an earlier run'


def _lead(key: str, schema: Mapping[str, HandoffKey]) -> str:
    spec = schema.get(key)
    return spec.follows if spec is not None and spec.follows else key


def _with_std(value: Any, std: Any) -> str:
    if isinstance(value, dict):
        return '(a mapping)'
    return f'{value!r}' + (f' ± {std:.3g}' if std is not None else '')


def _merge_method(method: str, prov: Provenance, new_values: Mapping[str, Any],
                  older: CalibrationLike, values: dict[str, Any], schema: Mapping[str, HandoffKey],
                  replace: bool, lines: list[str]) -> Provenance:
    """Merge one method's run into ``values`` (changed in place); its new provenance."""
    new_keys = _run_keys(prov, method, new_values, schema)
    old_latest = older.methods.get(method)
    old_runs: list[Provenance] = []
    if old_latest is not None:
        old_runs = [dataclasses.replace(r, earlier=()) for r in (old_latest, *old_latest.earlier)]
    old_owner: dict[str, int] = {}
    for i, run in enumerate(old_runs):
        for key in _run_keys(run, method, older.values, schema):
            old_owner.setdefault(key, i)
    for key, i in list(old_owner.items()):  # a live run rewriting itself: its latest word
        if old_runs[i].same_run(prov) and key not in new_keys and not _restarted(
                prov, old_runs[i]):
            lines.append(f'withdrawn: {key} {SAME_RUN}')
            values.pop(key, None)
            _pop_twins(values, key)
            del old_owner[key]
    groups: dict[str, list[str]] = {}
    for key in sorted(new_keys | set(old_owner)):
        groups.setdefault(_lead(key, schema), []).append(key)
    taken: set[str] = set()
    kept: set[str] = set()
    for lead, members in groups.items():
        if lead not in new_keys and lead not in old_owner:  # no lead either side: key by key
            for key in members:
                _merge_group(key, [key], key in new_keys, prov, new_values, older, values,
                             old_runs, old_owner, new_keys, replace, lines, taken, kept,
                             not getattr(schema.get(key), 'bench_specific', False))
            continue
        _merge_group(lead, members, lead in new_keys, prov, new_values, older, values,
                     old_runs, old_owner, new_keys, replace, lines, taken, kept,
                     not getattr(schema.get(lead), 'bench_specific', False))
    earlier = []
    for i, run in enumerate(old_runs):
        mine = _ordered((k for k in kept if old_owner[k] == i), schema)
        if mine:
            earlier.append(dataclasses.replace(run, keys=mine))
    return dataclasses.replace(prov, keys=_ordered(taken, schema), earlier=tuple(earlier))


def _restarted(prov: Provenance, old_run: Provenance) -> bool:
    """``prov`` is ``old_run`` begun again (rests on less of the same data), not its sequel.

    The same bag replayed into a node again, or ``./run.sh demo`` run twice: its first writes
    lack what the file holds from the whole run. Those values are kept (a ``kept:`` line
    each) until the run re-measures them; a live run that goes on (as much data or more)
    and no longer gives a value withdraws it.
    """
    return prov.data_end_stamp_ns < old_run.data_end_stamp_ns


def _merge_group(lead: str, members: list[str], new_has: bool, prov: Provenance,
                 new_values: Mapping[str, Any], older: CalibrationLike, values: dict[str, Any],
                 old_runs: list[Provenance], old_owner: dict[str, int], new_keys: set[str],
                 replace: bool, lines: list[str], taken: set[str], kept: set[str],
                 comparable: bool = True) -> None:
    """Merge one group (a lead key and the keys that follow it): the run's or the file's."""
    old_has = any(k in old_owner for k in members)
    take_new = new_has
    why = ''
    if new_has and lead in new_keys and lead in old_owner:
        old_run = old_runs[old_owner[lead]]
        v_new, v_old = new_values[lead], older.values[lead]
        u_new, u_old = new_values.get(lead + '_std'), older.values.get(lead + '_std')
        if prov.same_run(old_run) or replace:
            why = SAME_RUN[1:-2] if prov.same_run(old_run) else 'replace asked' + (
                f'; the same data under other settings ({prov.settings_change(old_run)})'
                if prov.same_data(old_run) else '')
        elif u_new is not None and u_old is not None and _numbers(v_new, v_old):
            spread = math.hypot(u_new, u_old)
            z = abs(v_new - v_old) / spread if spread > 0 else (
                0.0 if v_new == v_old else math.inf)
            other = (f'the same data under other settings ({prov.settings_change(old_run)})'
                     if prov.same_data(old_run) else '')
            if z > MAX_DISAGREEMENT_SIGMA and comparable:
                raise HandoffError(
                    f'{lead}: this run gives {_with_std(v_new, u_new)} ({prov.source}), the '
                    f'file holds {_with_std(v_old, u_old)} ({old_run.source}): they differ '
                    f'by {z:.1f} combined standard uncertainties ('
                    + (f'{other}: which settings are right?' if other else
                       'a changed gyro, another gyro, or a wrong bench setting?')
                    + '); nothing written. Check, then give --replace to take this run\'s '
                    'values, or use another --out.')
            take_new = u_new <= u_old
            why = ('more precise' if u_new < u_old else 'as precise, newer') if take_new \
                else f'this run\'s {_with_std(v_new, u_new)} is less precise (--replace ' \
                'takes it)'
            why += f'; {other}' if other else ''
        else:
            why = 'newer run'
    elif new_has and not old_has:
        why = ''
    elif not new_has:
        why = 'not measured by this run'
    for key in members:
        std = key + '_std'
        old_text = (f'{_with_std(older.values[key], older.values.get(std))} from '
                    f'{old_runs[old_owner[key]].source}') if key in old_owner else ''
        if take_new:
            if key in new_keys:
                verb = 'replaced' if key in old_owner else 'added'
                was = f' — was {old_text}' if old_text else ''
                new_text = _with_std(new_values[key], new_values.get(std))
                lines.append(f'{verb}: {key} = {new_text} from {prov.source}{was}'
                             + (f' ({why})' if why else '') + '.')
                values[key] = new_values[key]
                _pop_twins(values, key)
                for twin in (key + suffix for suffix in TWIN_SUFFIXES):
                    if twin in new_values:
                        values[twin] = new_values[twin]
                taken.add(key)
            elif key in old_owner:
                lines.append(f'dropped: {key} = {old_text} — it goes with {lead}, now from '
                             f'{prov.source}, which did not measure it.')
                values.pop(key, None)
                _pop_twins(values, key)
        elif key in old_owner:
            reason = why if key == lead or not new_has else f'goes with {lead}, kept'
            lines.append(f'kept: {key} = {old_text} ({reason}).')
            kept.add(key)
