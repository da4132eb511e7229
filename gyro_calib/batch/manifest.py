"""The batch manifest: each gyro's id, bags, methods and settings.

Three forms:

* YAML — a list (or ``gyros:`` list) of mappings ``{id, bags: [...], methods: [...],
  settings: {latitude_deg: 28.2, ...}, customer: ...}``;
* CSV — columns ``gyro_id``, ``bags`` (``;``-separated), optional ``methods``
  (``;``-separated), optional ``customer`` and one column per setting (empty cell: not
  given);
* a directory with one folder per gyro (the folder name is the id) holding its bags and,
  optionally, ``settings.yaml`` (the settings mapping, ``methods`` and ``customer`` allowed
  in it).

``customer`` is the customer the gyro's certificate names (ISO/IEC 17025 7.8.2.1 e).

Relative paths are relative to the manifest (or the directory). Settings are the
``gyro-calib calibrate`` flags without ``--`` and with ``_`` (``latitude_deg``,
``scale_factor_rad_per_pulse``, ``config`` …).
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from gyro_calib.errors import ConfigError
from gyro_calib.file_lock import BATCH_LOCK
from gyro_calib.registry import METHODS

SETTINGS: dict[str, type] = {
    'latitude_deg': float, 'heading_deg': float, 'position_table_revolutions': int,
    'scale_factor_rad_per_pulse': float, 'scale_factor_counts_per_rad': float,
    'sense_axis_elevation_deg': float, 'sense_axis_azimuth_deg': float,
    'config': Path, 'calibration': Path,
}
"""Per-gyro settings (as the ``calibrate`` flags) and their types."""

FLEET_NAMES = ('fleet.csv', 'fleet.parquet', 'fleet.jsonl', 'fleet.html', BATCH_LOCK)
"""The names the fleet files and the lock take in the output directory (no gyro's stem)."""


def gyro_stem(gyro_id: str) -> str:
    """The gyro's folder and file stem (characters other than letters, digits, ._- → _)."""
    return re.sub(r'[^A-Za-z0-9._-]', '_', gyro_id).strip('.') or 'gyro'


def check_stems(jobs: list[GyroJob], where: str) -> None:
    """Refuse gyros whose files would land on one another's.

    Two ids with one stem (``A/1`` and ``A_1``), or stems equal but for case (``A-1`` and
    ``a-1``: one folder on a case-insensitive file system), would overwrite each other's
    hand-off file and certificate; a stem equal to a fleet file's name would replace it.

    Raises:
        ConfigError: naming both gyros (or the gyro and the fleet file) and what to do.
    """
    taken: dict[str, str] = {}
    reserved = {name.casefold() for name in FLEET_NAMES}
    for job in jobs:
        stem = gyro_stem(job.gyro_id)
        if stem.casefold() in reserved:
            raise ConfigError(f'{where}: gyro {job.gyro_id!r} would be stored as {stem!r}, '
                              'the name of a fleet file: rename the gyro.')
        other = taken.setdefault(stem.casefold(), job.gyro_id)
        if other != job.gyro_id:
            raise ConfigError(
                f'{where}: gyros {other!r} and {job.gyro_id!r} would share the folder and '
                f'files {gyro_stem(other)!r}/{stem!r} (characters other than letters, digits, '
                '._- become _, and file systems may ignore case): give them ids that differ '
                'in letters or digits.')


@dataclass(frozen=True, slots=True)
class GyroJob:
    """One gyro of the fleet.

    Attributes:
        gyro_id: its serial or name.
        bags: its bag paths (absolute).
        methods: the methods to run (empty: every method the bags reveal).
        settings: setting name → value (see :data:`SETTINGS`).
        customer: the customer its certificate names ('' not given).
    """

    gyro_id: str
    bags: tuple[str, ...]
    methods: tuple[str, ...] = ()
    settings: dict[str, Any] = field(default_factory=dict)
    customer: str = ''

    def options(self) -> Any:
        """The :class:`~gyro_calib.session.CalibrationOptions` of this gyro."""
        from gyro_calib.session import CalibrationOptions

        s = self.settings

        def path(value: Any) -> Path | None:
            return None if value is None else Path(value)

        return CalibrationOptions(
            latitude_deg=s.get('latitude_deg'), heading_deg=s.get('heading_deg'),
            position_table_revolutions=s.get('position_table_revolutions'),
            scale_factor_rad_per_pulse=s.get('scale_factor_rad_per_pulse'),
            scale_factor_counts_per_rad=s.get('scale_factor_counts_per_rad'),
            sense_axis_elevation_deg=s.get('sense_axis_elevation_deg'),
            sense_axis_azimuth_deg=s.get('sense_axis_azimuth_deg'),
            config_file=path(s.get('config')), calibration_file=path(s.get('calibration')),
            gyro_id=self.gyro_id, given_by='manifest')


def load_manifest(path: Path) -> list[GyroJob]:
    """The gyros of a manifest file or directory.

    Raises:
        ConfigError: unreadable, empty, a gyro without id or bags, a duplicate id, an unknown
            method or setting, a setting of the wrong type, two gyros whose files would
            collide (see :func:`check_stems`) — one line naming where.
    """
    path = Path(path)
    if path.is_dir():
        jobs = _from_directory(path)
    elif not path.exists():
        raise ConfigError(f'manifest {path}: no such file or directory.')
    elif path.suffix.lower() == '.csv':
        jobs = _from_csv(path)
    else:
        jobs = _from_yaml(path)
    if not jobs:
        raise ConfigError(f'manifest {path} lists no gyro.')
    seen: set[str] = set()
    for job in jobs:
        try:
            job.options()  # every setting range-checked before any work
        except ConfigError as exc:
            raise ConfigError(f'manifest {path}, gyro {job.gyro_id}: {exc}') from None
        if job.gyro_id in seen:
            raise ConfigError(f'manifest {path}: gyro {job.gyro_id!r} is listed twice.')
        seen.add(job.gyro_id)
    check_stems(jobs, f'manifest {path}')
    return jobs


def check_local_bags(jobs: Sequence[GyroJob], manifest: Path) -> None:
    """Every bag path of the manifest exists here (a local cluster reads them from here).

    Checked before any work: a typo in a bag path is one line, not a failed gyro after the
    output directory and fleet files were made. (Under ``--scheduler`` the workers may be
    other machines, whose paths this process cannot see: each worker checks them there.)

    Raises:
        ConfigError: naming the gyro, the path and the nearest existing name beside it.
    """
    for job in jobs:
        for bag in job.bags:
            path = Path(bag)
            if path.exists():
                continue
            try:
                beside = sorted(p.name for p in path.parent.iterdir())
            except OSError:
                beside = []
            hint = _nearest(path.name, beside)
            raise ConfigError(f'{manifest}: gyro {job.gyro_id}: bag {bag} does not exist'
                              f'{hint}: correct its path in the manifest.')


CSV_FIELDS = ('gyro_id', 'bags', 'methods', 'customer')
"""The columns of a CSV manifest besides the settings."""

YAML_FIELDS = ('id', 'gyro_id', 'bags', 'methods', 'settings', 'customer')
"""The fields of a YAML manifest entry."""


def _nearest(name: str, known: Sequence[str]) -> str:
    """' (did you mean 'X'?)' for the known name nearest ``name``, or ''."""
    import difflib

    near = difflib.get_close_matches(str(name), list(known), n=1, cutoff=0.6)
    return f' (did you mean {near[0]!r}?)' if near else ''


def _job(where: str, base: Path, gyro_id: Any, bags: Any, methods: Any,
         settings: Any, customer: Any = None) -> GyroJob:
    if not isinstance(gyro_id, (str, int)) or not str(gyro_id).strip():
        raise ConfigError(f'{where}: every gyro needs an id.')
    gid = str(gyro_id).strip()
    if isinstance(bags, str):
        bags = [bags]
    if not isinstance(bags, list) or not bags or not all(isinstance(b, str) for b in bags):
        raise ConfigError(f'{where}: gyro {gid} needs a list of bag paths.')
    methods = [] if methods in (None, '') else methods
    if isinstance(methods, str):
        methods = [m.strip() for m in methods.split(';') if m.strip()]
    if not isinstance(methods, list) or any(m not in METHODS for m in methods):
        raise ConfigError(f'{where}: gyro {gid}: methods {methods!r} must name methods of '
                          f'{", ".join(METHODS)}.')
    if not isinstance(settings, dict):
        raise ConfigError(f'{where}: gyro {gid}: settings must be a mapping.')
    if customer is not None and not isinstance(customer, (str, int)):
        raise ConfigError(f'{where}: gyro {gid}: customer must be a text (name and contact).')
    checked: dict[str, Any] = {}
    for name, value in settings.items():
        if value is None or value == '':
            continue
        if name not in SETTINGS:
            raise ConfigError(f'{where}: gyro {gid}: unknown setting {name!r}'
                              f'{_nearest(name, list(SETTINGS))}; the settings are '
                              f'{", ".join(SETTINGS)}.')
        kind = SETTINGS[name]
        try:
            if kind is Path:
                checked[name] = str((base / str(value)).absolute())
            elif kind is int:
                if isinstance(value, float) and not value.is_integer():
                    raise ValueError
                checked[name] = int(value)
            else:
                number = float(value)
                if not math.isfinite(number):
                    raise ValueError
                checked[name] = number
        except (TypeError, ValueError):
            raise ConfigError(f'{where}: gyro {gid}: {name} = {value!r} is not '
                              f'{"an integer" if kind is int else "a finite number"}.') from None
    return GyroJob(gid, tuple(str((base / b).absolute()) for b in bags), tuple(methods),
                   checked, ' '.join(str(customer or '').split()))


def _from_yaml(path: Path) -> list[GyroJob]:
    try:
        data = yaml.safe_load(path.read_text(encoding='utf-8'))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ConfigError(f'manifest {path} cannot be read as YAML: '
                          f'{" ".join(str(exc).split())}.') from None
    if isinstance(data, dict) and 'gyros' in data:
        data = data['gyros']
    if not isinstance(data, list):
        raise ConfigError(f'manifest {path} must be a list of gyros (or a mapping with '
                          '"gyros:"), each {id, bags, methods, settings}.')
    jobs = []
    for i, entry in enumerate(data):
        where = f'manifest {path}, entry {i + 1}'
        if not isinstance(entry, dict):
            raise ConfigError(f'{where} must be a mapping {{id, bags, methods, settings}}.')
        unknown = sorted(set(map(str, entry)) - set(YAML_FIELDS))
        if unknown:
            raise ConfigError(f'{where}: unknown field {unknown[0]!r}'
                              f'{_nearest(unknown[0], YAML_FIELDS + tuple(SETTINGS))}; the '
                              f'fields are {", ".join(YAML_FIELDS)} (settings go under '
                              '"settings:").')
        jobs.append(_job(where, path.parent, entry.get('id', entry.get('gyro_id')),
                         entry.get('bags'), entry.get('methods'), entry.get('settings') or {},
                         entry.get('customer')))
    return jobs


def _from_csv(path: Path) -> list[GyroJob]:
    try:
        with path.open(newline='', encoding='utf-8') as stream:
            reader = csv.DictReader(stream)
            rows = list(reader)
            header = [str(c).strip() for c in reader.fieldnames or []]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ConfigError(f'manifest {path} cannot be read as CSV: {exc}.') from None
    columns = CSV_FIELDS + tuple(SETTINGS)
    for column in header:  # a misspelt column is named before it makes a row look empty
        if column and column not in columns:
            raise ConfigError(f'manifest {path}: unknown column {column!r}'
                              f'{_nearest(column, columns)}; the columns are '
                              f'{", ".join(CSV_FIELDS)} and the settings '
                              f'{", ".join(SETTINGS)}.')
    jobs = []
    for i, row in enumerate(rows):
        where = f'manifest {path}, line {i + 2}'
        if None in row:
            raise ConfigError(f'{where} has more cells than the header.')
        bags = [b.strip() for b in (row.get('bags') or '').split(';') if b.strip()]
        settings = {k: (v or '').strip() for k, v in row.items()
                    if k not in ('gyro_id', 'bags', 'methods', 'customer')}
        jobs.append(_job(where, path.parent, row.get('gyro_id', ''), bags,
                         row.get('methods'), settings, row.get('customer')))
    return jobs


def _is_bag(path: Path) -> bool:
    return (path.is_dir() and ((path / 'metadata.yaml').exists() or any(path.glob('*.mcap')))
            ) or (path.is_file() and path.suffix == '.mcap')


def _from_directory(path: Path) -> list[GyroJob]:
    jobs = []
    for folder in sorted(p for p in path.iterdir() if p.is_dir()):
        bags = sorted(str(p.relative_to(folder)) for p in folder.iterdir() if _is_bag(p))
        settings: Any = {}
        settings_file = folder / 'settings.yaml'
        if settings_file.exists():
            try:
                settings = yaml.safe_load(settings_file.read_text(encoding='utf-8')) or {}
            except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
                raise ConfigError(f'{settings_file} cannot be read as YAML: '
                                  f'{" ".join(str(exc).split())}.') from None
        if not isinstance(settings, dict):
            raise ConfigError(f'{settings_file} must hold a mapping of settings.')
        settings = dict(settings)
        methods = settings.pop('methods', None)
        customer = settings.pop('customer', None)
        where = f'manifest directory {path}, folder {folder.name}'
        if not bags:
            raise ConfigError(f'{where} holds no bag.')
        jobs.append(_job(where, folder, folder.name, bags, methods, settings, customer))
    return jobs


def check_repeated_bags(jobs: Sequence[GyroJob]) -> None:
    """One line refusing a fleet where the same data is listed twice (before any work).

    A bag listed for two gyros, or listed twice for one gyro under two paths (a copy, the
    same directory spelled otherwise), would be calibrated twice: the same values under two
    ids, or one gyro's data counted twice. Found by resolving the paths, then comparing file
    sizes, and hashing only bags whose sizes match
    (:func:`gyro_calib.bagio.duplicates.same_content_pairs`). One gyro's bags holding the
    same messages (a repaired copy beside its original) are that gyro's failed row
    (:func:`gyro_calib.batch.tasks.plan_gyro`). Missing paths are left to the gyro's row.

    Raises:
        ConfigError: naming both gyros (or the gyro) and both paths.
    """
    from gyro_calib.bagio.duplicates import same_content_pairs

    owner: dict[Path, str] = {}
    paths: list[Path] = []
    for job in jobs:
        for bag in job.bags:
            path = Path(bag)
            if path.exists() and path not in owner:
                owner[path] = job.gyro_id
                paths.append(path)
            elif path in owner:
                whose = (f'for gyro {job.gyro_id}' if owner[path] == job.gyro_id else
                         f'(gyro {owner[path]} and gyro {job.gyro_id})')
                raise ConfigError(f'manifest: bag {path} is listed twice {whose}: its data '
                                  'would be calibrated twice; list each bag once.')
    for first, second in same_content_pairs(paths):
        same = 'is' if first.resolve() == second.resolve() else 'holds the same content as'
        raise ConfigError(f'manifest: bag {second} (gyro {owner[second]}) {same} {first} '
                          f'(gyro {owner[first]}): its data would be calibrated twice; list '
                          'it once.')
