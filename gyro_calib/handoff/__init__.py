"""The INS hand-off calibration file: what gyro_calib measured, for the navigation system.

One YAML file per gyro holds every value measured, by any method, each with its standard
(k = 1) uncertainty beside it as ``<name>_std`` and, where the estimator knows them, the
degrees of freedom ν of that uncertainty as ``<name>_dof`` (a certificate's k for 95 % is
Student t at ν; never more than the n − 1 the n independent measurements support), under a
top-level ``gyro:`` mapping; which
method produced them, from what data and when, under ``methods:``; and whether anything the
methods that ran would measure is still missing (``complete``, ``missing`` with reasons). All
units are SI and in the key names. A value that was not measured is an *absent key* — never a
placeholder number. Method-specific keys carry the method's prefix (``fog_…``, ``dither_…``,
``thermal_…``); the RBRLG keys keep the names of format 1.

Example (``format_version: 3``)::

    # gyro_calib INS hand-off calibration; layout: gyro_calib/handoff.py
    format_version: 3
    gyro_calib_version: 0.2.0
    gyro_id: A-1                         # serial or name; binds: another gyro's run is refused
    conventions:                         # what every number is (CONVENTIONS)
      axis: ...
      rate: ...
      units: ...
    complete: false                      # false: a key this bench could give is missing
    missing:                             # those keys, once, each with why
      bias_rad_s: the bias needs the site latitude (--latitude-deg) to remove the Earth rate.
    not_measurable:                      # keys the methods give, but not from such a bench
      fix_error_angle_rad: θ needs the position-table stations of the four-position procedure.
    gyro:
      k_tilde_rad_per_pulse: 4.0860157e-06           # K̃ (§A eq. (3))
      k_tilde_rad_per_pulse_std: 4.8e-14
      k_tilde_rad_per_pulse_dof: 2                   # ν: 3 window pairs (optional key)
      bias_plus_earth_rate_rad_s: 2.4e-05            # ω′ₑ + ω_B along the sense axis
      bias_plus_earth_rate_rad_s_std: 3.0e-08
      window_pairs: 3
    methods:
      rbrlg:                             # the latest run of each method
        source: bags/k_tilde_bench
        created_utc: '2026-11-23T09:30:00+00:00'
        data_start_stamp_ns: 1795426200000000000
        data_end_stamp_ns: 1795426500000000000
        conditions: {heading_deg: 0.0}   # the bench settings its values rest on
        keys: [k_tilde_rad_per_pulse, bias_plus_earth_rate_rad_s, window_pairs]
        earlier_runs: []                 # runs whose values were kept (each with its keys)

A noise run keeps its curves with it, ``methods.noise.deviations.<axis>``: ADEV, MDEV,
HDEV and TOTDEV per τ with their standard uncertainties and EDF (:data:`DEVIATION_FIELDS`).

Each value comes from exactly one run, named by the ``keys`` of its method's latest run or of
one of its ``earlier_runs``: a K̃ of one run beside a θ of another is stated, with each run's
conditions (latitude and heading a bias rests on, the K a thermal model was fitted with; the
scale factor a dither or noise run turned the output into rad with, and where it came from:
``scale_factor_rad_per_pulse`` or, for a FOG's output, ``fog_scale_factor_counts_per_rad``,
with ``scale_factor_from``, absent when the run used none).

The keys each method may write, with units and meaning, are its ``HANDOFF_KEYS`` (listed in
the README); unknown keys are refused (a misspelt key would otherwise be silently dropped).
Floats need a dot in the mantissa (YAML 1.1: ``4.0e-6``, not ``4e-6``, which reads as a
string). Files of ``format_version`` 1 (RBRLG only, flat metadata) and 2 (one provenance per
method, ``missing`` per method too) still load; they are rewritten as format 3. ``_dof`` is
optional (files written before it still load; a certificate then assumes k = 2 and says so);
it is a number ≥ 0 (``.inf`` for ν = ∞; 0: no coverage interval) and travels with its value
in a merge.

:func:`write_calibration` replaces the file atomically (temporary file in the same
directory, fsync, rename, fsync of the directory), so a reader such as ``imu_corrector``
sees the old file or the new one, never half of one. :func:`update_calibration` merges a
run into the gyro's file key by key (:meth:`Calibration.merged_into`): each quantity is kept
from the run that measured it best (smaller standard uncertainty; the keys that follow it —
counts, quantities derived in the same fit — go with it), one line per key says what was
added, replaced, kept or dropped, and what would make the file inconsistent is refused:
another gyro, a value differing from the file's by more than 5 combined standard
uncertainties (``replace`` takes the run's values), a model fitted with another scale factor,
a run whose values rest on a scale factor other than the file's by enough to move one of them
by more than 1/5 of its standard uncertainty, either side new (``replace`` with a new scale
factor drops the values of the run resting on the old one, each with a line, and lists them as
missing), while a smaller difference is merged with a line giving the ppm and the shift
(:func:`scale_factor_findings`).
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NotRequired, TypedDict

import yaml

from gyro_calib import __version__
from gyro_calib.errors import GyroCalibError
from gyro_calib.imu_calibration import ImuCalibration, ImuSectionError, imu_from_section
from gyro_calib.outputs import write_text_atomically

FORMAT_VERSION = 3
"""The layout version this module writes for one gyro; formats 1 and 2 are still read."""

IMU_FORMAT_VERSION = 4
"""The layout version of a file with an ``imu:`` section (a triad, METHODS §F; the section's
layout: :mod:`gyro_calib.imu_calibration`); formats 1–3 are still read."""

READ_VERSIONS = (1, 2, FORMAT_VERSION, IMU_FORMAT_VERSION)

IMU_METHODS = ('triad',)
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

MAX_DISAGREEMENT_SIGMA = 5.0
"""A run's value differing from the file's by more than this many combined standard
uncertainties is not merged (another gyro, a changed gyro, or a wrong bench setting)."""


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
        missing: keys this method would measure from such a bench but did not, with why.
        created_utc: when the values were produced, ISO-8601 UTC.
        conditions: the bench settings the values rest on (latitude_deg, heading_deg, the
            scale factor a model was fitted with...), by name.
        not_measurable: keys the method gives, but not from such a bench, with why.
        keys: the keys (no ``_std``) of the file this run gave; None = all of its method's
            (a record not yet merged, or a format 1/2 file).
        earlier: earlier runs of the method whose keys the file kept (each with its keys).
        deviations: the per-τ tables the run's values rest on, by axis (a noise run: τ,
            ADEV, MDEV, HDEV, TOTDEV with their standard uncertainties and EDF; see
            :data:`DEVIATION_FIELDS`); empty for the other methods.
    """

    source: str
    data_start_stamp_ns: int
    data_end_stamp_ns: int
    missing: Mapping[str, str] = field(default_factory=dict)
    created_utc: str = field(default_factory=_utc_now_iso)
    conditions: Mapping[str, Any] = field(default_factory=dict)
    not_measurable: Mapping[str, str] = field(default_factory=dict)
    keys: tuple[str, ...] | None = None
    earlier: tuple[Provenance, ...] = ()
    deviations: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def same_run(self, other: Provenance) -> bool:
        """True when both describe one run (a live node rewriting its file as it goes)."""
        return (self.source, self.data_start_stamp_ns) == (other.source,
                                                            other.data_start_stamp_ns)

    def label(self) -> str:
        """The run in one phrase, for merge lines."""
        return f'{self.source} ({self.created_utc})'


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
            HandoffError: the file is of another gyro; a value differs from the file's by more
                than :data:`MAX_DISAGREEMENT_SIGMA` combined standard uncertainties (without
                ``replace``); the result would hold a model fitted with another scale factor
                than the file's, or a run whose values rest on another scale factor than the
                file's by more than :data:`MAX_SCALE_FACTOR_SHIFT` of a standard uncertainty
                (with ``replace``, a new scale factor drops such a run of the file instead).
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
        values = dict(older.values)
        methods = dict(older.methods)
        for method, prov in self.methods.items():
            methods[method] = _merge_method(method, prov, self.values, older, values, schema,
                                            replace, lines)
        imu = _merged_imu(self, older, lines)
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


def _merged_imu(new: Calibration, older: Calibration, lines: list[str]) -> ImuCalibration | None:
    """The ``imu:`` section after a merge, each change said in a line.

    A triad run (:data:`IMU_METHODS`) replaces the section but keeps the file's per-channel
    ``noise`` and ``thermal`` where it brings none; any other run (the noise method on
    ``/imu/pulses``) keeps the file's section and sets its ``noise`` (and ``thermal``) per
    channel. A file without the section gets this run's.

    Raises:
        HandoffError: the run's channels are not the file's section's.
    """
    run, old = new.imu, older.imu
    if run is None:
        return old
    if old is None:
        lines.append('imu: added (K, sense axes, M and b of the triad).'
                     if any(m in IMU_METHODS for m in new.methods) else
                     f'imu: added with the channels {list(run.channels)} and their '
                     f'{_per_channel_words(run)} only.')
        return run
    if set(run.channels) != set(old.channels):
        raise HandoffError(f'the file\'s imu section has the channels {list(old.channels)}, '
                           f'this run the channels {list(run.channels)}: another IMU? Not '
                           'merging them (use another --out).')
    if any(m in IMU_METHODS for m in new.methods):
        kept = {name: getattr(old, name) for name in ('noise', 'thermal')
                if getattr(old, name) and not getattr(run, name)}
        lines.append('imu: the file\'s imu section (' + _imu_run(older) + ') replaced by this '
                     'run\'s' + (f'; its {" and ".join(kept)} per channel kept (not measured '
                                  'by this run).' if kept else '.'))
        return dataclasses.replace(run, **kept)
    changed = {name: getattr(run, name) for name in ('noise', 'thermal') if getattr(run, name)}
    lines.append(f'imu: the file\'s section kept (K, sense axes, M, b); its '
                 f'{_per_channel_words(run)} ' + ('replaced by this run\'s.' if any(
                     getattr(old, n) for n in changed) else 'set by this run.'))
    return dataclasses.replace(old, **changed)


def _per_channel_words(imu: ImuCalibration) -> str:
    """'noise', 'thermal' or 'noise and thermal' terms per channel of a section."""
    return ' and '.join(n for n in ('noise', 'thermal') if getattr(imu, n)) + ' terms' \
        if imu.noise or imu.thermal else 'no terms'


def _imu_run(calibration: Calibration) -> str:
    """The run the file's imu section came from, as a phrase."""
    from_triad = calibration.methods.get('triad')
    return f'run {from_triad.label()}' if from_triad is not None else 'an earlier run'


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


def _run_keys(prov: Provenance, method: str, values: Mapping[str, Any],
              schema: Mapping[str, HandoffKey]) -> set[str]:
    """The base keys of ``values`` that ``prov`` (a run of ``method``) gave."""
    mine = {_base_key(k) for k in values
            if schema.get(_base_key(k), HandoffKey(k, '', '')).method == method}
    return mine if prov.keys is None else mine & set(prov.keys)


def _lead(key: str, schema: Mapping[str, HandoffKey]) -> str:
    spec = schema.get(key)
    return spec.follows if spec is not None and spec.follows else key


def _with_std(value: Any, std: Any) -> str:
    if isinstance(value, dict):
        return '(a mapping)'
    return f'{value!r}' + (f' ± {std:.3g}' if std is not None else '')


def _merge_method(method: str, prov: Provenance, new_values: Mapping[str, Any],
                  older: Calibration, values: dict[str, Any], schema: Mapping[str, HandoffKey],
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
        if old_runs[i].same_run(prov) and key not in new_keys:
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


def _merge_group(lead: str, members: list[str], new_has: bool, prov: Provenance,
                 new_values: Mapping[str, Any], older: Calibration, values: dict[str, Any],
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
            why = SAME_RUN[1:-2] if prov.same_run(old_run) else 'replace asked'
        elif u_new is not None and u_old is not None and _numbers(v_new, v_old):
            spread = math.hypot(u_new, u_old)
            z = abs(v_new - v_old) / spread if spread > 0 else (
                0.0 if v_new == v_old else math.inf)
            if z > MAX_DISAGREEMENT_SIGMA and comparable:
                raise HandoffError(
                    f'{lead}: this run gives {_with_std(v_new, u_new)} ({prov.source}), the '
                    f'file holds {_with_std(v_old, u_old)} ({old_run.source}): they differ '
                    f'by {z:.1f} combined standard uncertainties (a changed gyro, another '
                    f'gyro, or a wrong bench setting?); nothing written. Check, then give '
                    f'--replace to take this run\'s values, or use another --out.')
            take_new = u_new <= u_old
            why = ('more precise' if u_new < u_old else 'as precise, newer') if take_new \
                else f'this run\'s {_with_std(v_new, u_new)} is less precise (--replace ' \
                'takes it)'
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


def _numbers(*values: Any) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


SCALE_FACTOR_CONDITIONS: dict[str, tuple[tuple[str, ...], int, str]] = {
    'scale_factor_rad_per_pulse': (('scale_factor_rad_per_pulse', 'k_tilde_rad_per_pulse'), 1,
                                   'rad/pulse'),
    'fog_scale_factor_counts_per_rad': (('fog_scale_factor_counts_per_rad',), -1, 'counts/rad'),
}
"""A run condition naming the scale factor its values rest on → (the file's keys holding that
scale factor, the first present being the file's; the power p of the scale factor in those
values: v ∝ Kᵖ, rad = K·pulses, rad = counts/SF; its unit)."""

SCALE_FACTOR_FROM = 'scale_factor_from'
"""The run condition saying where the run's scale factor came from (a flag, a file, stored
bench settings)."""

MAX_SCALE_FACTOR_SHIFT = 0.2
"""A run's values may rest on a scale factor other than the file's only while the difference
moves none of them by more than this fraction of its standard uncertainty."""

SCALE_FACTOR_NOTE = 'scale factor: '
"""How a merge-report line about a run resting on another scale factor begins."""

MAX_MODEL_SCALE_FACTOR_PPM = 100.0
"""A model fitted with a scale factor (thermal) may differ from the file's by this much, ppm."""


@dataclass(frozen=True, slots=True)
class ScaleFactorFindings:
    """What :func:`scale_factor_findings` found: the refusal ('' if none) and merge notes."""

    problem: str = ''
    notes: tuple[str, ...] = ()
    stale: tuple[str, Provenance, str] | None = None
    """A refusal because this merge brings a new scale factor: (method, the file's run that
    rests on the old one, why) — ``replace`` drops that run's values instead."""


def _file_scale_factor(calibration: Calibration, keys: tuple[str, ...],
                       ) -> tuple[str, float] | None:
    for key in keys:
        if key in calibration.values and _numbers(calibration.values[key]):
            return key, float(calibration.values[key])
    return None


def _own_keys(run: Provenance, latest: Provenance, method: str, values: Mapping[str, Any],
              schema: Mapping[str, HandoffKey]) -> set[str]:
    """The base keys of ``values`` that ``run`` (``latest`` or one of its earlier runs) gave."""
    keys = _run_keys(run, method, values, schema)
    if run.keys is None and run is latest:
        keys -= {k for e in latest.earlier if e.keys for k in e.keys}
    return keys


def scale_factor_findings(calibration: Calibration,
                          schema: Mapping[str, HandoffKey] | None = None, *,
                          new_methods: Iterable[str] = ()) -> ScaleFactorFindings:
    """Whether the values of ``calibration`` rest on the file's scale factor.

    Two rules, against the file's scale factor (``scale_factor_rad_per_pulse``, else
    ``k_tilde_rad_per_pulse``; a FOG's ``fog_scale_factor_counts_per_rad``):

    * a value that is a model fitted with a scale factor (a mapping stating
      ``…scale_factor_rad_per_pulse``, the thermal model) differing from the file's by more
      than :data:`MAX_MODEL_SCALE_FACTOR_PPM`: refused (the model's bias belongs to its K);
    * a run whose conditions name the scale factor its values rest on
      (:data:`SCALE_FACTOR_CONDITIONS`: dither's θ_d and angles, noise terms in rad) beside
      another in the file: with v ∝ Kᵖ, each value of the run that scales with it
      (:attr:`HandoffKey.scales_with_scale_factor`) would move by |(K_file/K_run)ᵖ − 1|·|v|;
      more than :data:`MAX_SCALE_FACTOR_SHIFT` of its standard uncertainty for any of them
      is refused, else the difference is noted (a merge-report line).

    Args:
        calibration: the file's content (after a merge).
        schema: the known keys.
        new_methods: the methods of the run being merged (their latest runs are this run),
            so the refusal says which side is new and notes name only what this merge brings.
    """
    sch = _schema(schema)
    new = set(new_methods)
    file_k = _file_scale_factor(calibration, SCALE_FACTOR_CONDITIONS[
        'scale_factor_rad_per_pulse'][0])
    if file_k is not None:
        for key, value in calibration.values.items():
            if not isinstance(value, dict):
                continue
            for inner, k in value.items():
                if str(inner).endswith('scale_factor_rad_per_pulse') and _numbers(k) and k > 0 \
                        and abs(file_k[1] / k - 1.0) > MAX_MODEL_SCALE_FACTOR_PPM * 1e-6:
                    run = calibration.source_of(key, sch)
                    other = calibration.source_of(file_k[0], sch)
                    return ScaleFactorFindings(
                        f'the file\'s {file_k[0]} = {file_k[1]!r} rad/pulse '
                        f'({other.source if other else "?"}) differs from the K = {k!r} '
                        f'rad/pulse its {key} was fitted with ({run.source if run else "?"}) '
                        f'by {abs(file_k[1] / k - 1.0) * 1e6:.0f} ppm (more than 100), and the '
                        f'model\'s bias belongs to its K: refit it with this K (--calibration '
                        f'FILE) or use another --out. Nothing written.')
    notes: list[str] = []
    for condition, (file_keys, power, unit) in SCALE_FACTOR_CONDITIONS.items():
        held = _file_scale_factor(calibration, file_keys)
        if held is None:
            continue
        file_key, k_file = held
        k_owner = calibration.source_of(file_key, sch)
        k_is_new = sch[file_key].method in new and k_owner is calibration.methods.get(
            sch[file_key].method)
        for method, latest in calibration.methods.items():
            for run in (latest, *latest.earlier):
                stated = run.conditions.get(condition)
                if not isinstance(stated, (int, float)) or isinstance(stated, bool) \
                        or not stated > 0 or stated == k_file:
                    continue
                k_run = float(stated)
                shift = abs((k_file / k_run) ** power - 1.0)
                worst: tuple[float, str] = (0.0, '')
                for key in sorted(_own_keys(run, latest, method, calibration.values, sch)):
                    v, u = calibration.values.get(key), calibration.values.get(key + '_std')
                    if not (sch[key].scales_with_scale_factor and _numbers(v, u)):
                        continue
                    assert v is not None and u is not None  # numbers, checked above
                    moved = shift * abs(v)
                    sigmas = moved / u if u > 0 else (math.inf if moved > 0 else 0.0)
                    if sigmas >= worst[0]:
                        worst = (sigmas, key)
                if not worst[1]:
                    continue
                run_is_new = method in new and run is latest
                ppm = abs(k_file / k_run - 1.0) * 1e6
                where = run.conditions.get(SCALE_FACTOR_FROM, 'source not stated')
                whose = 'this run\'s' if k_is_new and not run_is_new else 'the file\'s'
                rests = (f'the {method} run {run.source} rests on {condition} = {k_run!r} '
                         f'{unit} ({where}); {whose} {file_key} = {k_file!r} {unit} '
                         f'({k_owner.source if k_owner else "?"}) differs from it by '
                         f'{_figure(ppm)} ppm')
                if worst[0] > MAX_SCALE_FACTOR_SHIFT:
                    moves = (f'{rests}, which would move its {worst[1]} by '
                             f'{_figure(worst[0])} standard uncertainties (more than '
                             f'{MAX_SCALE_FACTOR_SHIFT:g})')
                    if k_is_new and not run_is_new:
                        return ScaleFactorFindings(
                            f'{moves}: not merging values that rest on another scale factor; '
                            f'write this run to another --out, then re-run {method} on '
                            f'{run.source} with --calibration on that file, or give --replace '
                            f'to drop the {method} run\'s values (then re-run {method} with '
                            '--calibration FILE). Nothing written.',
                            stale=(method, run, f'rested on {condition} = {k_run!r} {unit} '
                                   f'({where}), {_figure(ppm)} ppm from the file\'s {file_key} '
                                   f'= {k_file!r} {unit} ({k_owner.source if k_owner else "?"})'))
                    return ScaleFactorFindings(
                        f'{moves}: not merging values that rest on another scale factor; '
                        f're-run {method} with the file\'s scale factor (--calibration FILE), '
                        'or use another --out (--replace does not take values resting on '
                        'another scale factor). Nothing written.')
                if run_is_new or k_is_new or not new:
                    notes.append(f'{SCALE_FACTOR_NOTE}{rests}, which moves its values by at most '
                                 f'{worst[0]:.2g} of their standard uncertainty ({worst[1]}); '
                                 'merged.')
    return ScaleFactorFindings('', tuple(notes))


def _figure(x: float) -> str:
    """3 significant figures, without an exponent up to 10⁹ (ppm, multiples of σ)."""
    return f'{x:.3g}' if x < 1000 or not math.isfinite(x) or x >= 1e9 else f'{x:.0f}'


def scale_factor_inconsistency(calibration: Calibration,
                               schema: Mapping[str, HandoffKey] | None = None) -> str:
    """Why the file is inconsistent ('' if not): :func:`scale_factor_findings`' refusal."""
    return scale_factor_findings(calibration, schema).problem


TWIN_SUFFIXES = ('_std', '_dof')
"""The keys that go with an uncertain value ``<key>``: its standard uncertainty and its
degrees of freedom (optional)."""


def _base_key(key: str) -> str:
    return key[:-4] if key.endswith(TWIN_SUFFIXES) else key


def _pop_twins(values: dict[str, Any], key: str) -> None:
    """Remove ``key``'s ``_std`` and ``_dof`` from ``values`` (changed in place)."""
    for suffix in TWIN_SUFFIXES:
        values.pop(key + suffix, None)


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


# ---------------------------------------------------------------------------------------
# On-disk shape


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


class CalibrationYaml(TypedDict):
    """On-disk shape of the whole hand-off file, format 3 or 4 (see the module docstring)."""

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
                    'missing', 'conditions', 'keys', 'earlier_runs', 'deviations')

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
                      _deviations(entry.get('deviations', {}) or {}, where))


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


# ---------------------------------------------------------------------------------------
# Files


def write_calibration(path: str | Path, calibration: Calibration,
                      schema: Mapping[str, HandoffKey] | None = None) -> Path:
    """Write ``calibration`` to ``path`` atomically: the old file or the new, never a mix.

    A temporary file in the same directory is written, flushed and fsynced, renamed onto
    the target by ``os.replace`` (:func:`gyro_calib.outputs.write_text_atomically`, the one
    output writer) and the directory is fsynced. The file keeps the mode of
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
            + yaml.dump(dict(calibration_to_yaml_dict(calibration, schema)), Dumper=_Dumper,
                        sort_keys=False, allow_unicode=True, width=100))
    try:
        write_text_atomically(target, text)
    except OSError as exc:
        raise HandoffError(f'cannot write calibration file {target}: '
                           f'{exc.strerror or exc}.') from None
    try:
        _fsync_directory(target.parent)
    except OSError as exc:
        raise HandoffError(f'calibration file {target} was written but its directory could '
                           f'not be synced, so it may not survive a power loss: '
                           f'{exc.strerror or exc}.') from None
    return target


class _Dumper(yaml.SafeDumper):
    """The safe dumper, with a list of numbers on one line (a deviation table per τ)."""


def _represent_list(dumper: yaml.SafeDumper, data: list[Any]) -> yaml.Node:
    flow = bool(data) and all(v is None or (_numbers(v) and not isinstance(v, bool))
                              for v in data)
    return dumper.represent_sequence('tag:yaml.org,2002:seq', data, flow_style=flow)


_Dumper.add_representer(list, _represent_list)


def update_calibration(path: str | Path, calibration: Calibration,
                       schema: Mapping[str, HandoffKey] | None = None, *,
                       replace: bool = False, report: list[str] | None = None) -> Path:
    """Merge one run's calibration into the gyro's file.

    Merge ``calibration`` (one run) into the gyro's file at ``path`` (created if absent),
    atomically, key by key (:meth:`Calibration.merged_into`): nothing measured is lost
    without a line in ``report`` saying so.

    Raises:
        HandoffError: the existing file is unreadable or invalid (it is left untouched: fix or
            move it), it belongs to another gyro, a value disagrees with the file's (without
            ``replace``), the result would be inconsistent, or the write fails.
    """
    sch = _schema(schema)
    target = Path(path)
    lines: list[str] = []
    if target.exists():
        calibration = calibration.merged_into(load_calibration(target, sch), sch,
                                              replace=replace, report=lines)
    else:
        findings = scale_factor_findings(calibration, sch, new_methods=calibration.methods)
        if findings.problem:
            raise HandoffError(findings.problem)
        lines += [f'added: {k} = {_with_std(v, calibration.values.get(k + "_std"))}.'
                  for k, v in calibration.values.items() if not k.endswith(TWIN_SUFFIXES)]
        if calibration.imu is not None:
            _merged_imu(calibration, Calibration({}, {}), lines)
        lines += findings.notes
    written = write_calibration(target, calibration, sch)
    if report is not None:
        report.extend(lines)
    return written


SAME_RUN = '(same run, updated).'
"""How a merge line ends when a live node rewrote the values of its own run."""


def merge_lines(report: Iterable[str]) -> list[str]:
    """The lines of a merge report worth telling (a node's rewrites of its own run left out)."""
    return [line for line in report if not line.endswith(SAME_RUN)]


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
