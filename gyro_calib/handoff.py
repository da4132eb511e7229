"""The INS hand-off calibration file: what gyro_calib measured, for the navigation system.

One YAML file per gyro holds the calibrated values, each with its standard (k = 1)
uncertainty beside it as ``<name>_std``, under a top-level ``gyro:`` mapping, and the
metadata (what data, when, by which version) at top level. All units are SI and in the
key names. A value that was not measured is an *absent key* — never a placeholder number.

Example (``format_version: 1``)::

    # gyro_calib INS hand-off calibration; layout: gyro_calib/handoff.py
    format_version: 1
    gyro_calib_version: 0.1.0
    created_utc: '2026-11-23T09:30:00+00:00'
    source: bags/bench_2026-11-23.mcap     # or 'live'
    data_start_stamp_ns: 1795426200000000000
    data_end_stamp_ns: 1795426500000000000
    gyro:
      k_tilde_rad_per_pulse: 4.0860157e-06           # K̃ (METHODS §A.2, eq. 3)
      k_tilde_rad_per_pulse_std: 4.8e-14
      scale_factor_rad_per_pulse: 4.0859955e-06      # K = K̃·cos θ (eq. 4)
      scale_factor_rad_per_pulse_std: 5.1e-14
      fix_error_angle_rad: 0.0031355                  # θ (METHODS §A.3)
      fix_error_angle_rad_std: 2.0e-06
      bias_rad_s: 1.2e-08                             # along the gyro's sense axis
      bias_rad_s_std: 3.0e-09
      angle_random_walk_rad_per_sqrt_s: 2.9e-07
      angle_random_walk_rad_per_sqrt_s_std: 1.5e-08
      window_pairs: 3
      stations: 4

Required in ``gyro``: ``k_tilde_rad_per_pulse``, ``bias_rad_s`` (each with ``_std``),
``window_pairs`` and ``stations`` (0 when θ was not measured). Optional, each with its
``_std``: ``fix_error_angle_rad`` together with ``scale_factor_rad_per_pulse`` (K is only
known once θ is: both present or both absent), and ``angle_random_walk_rad_per_sqrt_s``.
All top-level keys shown are required. Unknown keys are refused (a misspelt optional key
would otherwise be silently dropped). Floats need a dot in the mantissa (YAML 1.1:
``4.0e-6``, not ``4e-6``, which reads as a string).

:func:`write_calibration` replaces the file atomically (temporary file in the same
directory, fsync, rename, fsync of the directory), so a reader such as
``imu_corrector`` sees the old file or the new one, never half of one.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypedDict

import yaml

from gyro_calib import __version__
from gyro_calib.errors import GyroCalibError

FORMAT_VERSION = 1
"""The layout version this module writes and reads."""


class HandoffError(GyroCalibError):
    """The hand-off calibration file cannot be written, read, or holds invalid content."""


class _GyroSectionRequired(TypedDict):
    k_tilde_rad_per_pulse: float
    k_tilde_rad_per_pulse_std: float
    bias_rad_s: float
    bias_rad_s_std: float
    window_pairs: int
    stations: int


class GyroSectionYaml(_GyroSectionRequired, total=False):
    """On-disk ``gyro:`` mapping; the optional keys are absent when not measured."""

    scale_factor_rad_per_pulse: float
    scale_factor_rad_per_pulse_std: float
    fix_error_angle_rad: float
    fix_error_angle_rad_std: float
    angle_random_walk_rad_per_sqrt_s: float
    angle_random_walk_rad_per_sqrt_s_std: float


class CalibrationYaml(TypedDict):
    """On-disk shape of the whole hand-off file (see the module docstring)."""

    format_version: int
    gyro_calib_version: str
    created_utc: str
    source: str
    data_start_stamp_ns: int
    data_end_stamp_ns: int
    gyro: GyroSectionYaml


def _utc_now_iso() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')


@dataclass(frozen=True, slots=True)
class GyroCalibration:
    """Calibrated values of one gyro along its sense axis, with standard uncertainties (k = 1).

    ``None`` means "not measured" (written as absent keys). Values are checked on
    construction; an invalid one raises :class:`HandoffError` naming the field.
    """

    k_tilde_rad_per_pulse: float
    """K̃, rad/pulse (METHODS §A.2, eq. 3)."""
    k_tilde_rad_per_pulse_std: float
    """Standard uncertainty of K̃, rad/pulse."""
    bias_rad_s: float
    """Gyro bias along its sense axis, rad/s (subtracted from the measured rate)."""
    bias_rad_s_std: float
    """Standard uncertainty of the bias, rad/s."""
    window_pairs: int
    """Forward/reverse window pairs K̃ rests on."""
    stations: int
    """Position-table stations θ rests on (0 when θ was not measured)."""
    data_start_stamp_ns: int
    """Header stamp of the first sample the values rest on, int ns."""
    data_end_stamp_ns: int
    """Header stamp of the last sample the values rest on, int ns."""
    source: str
    """Where the data came from: 'live' or a bag path."""
    scale_factor_rad_per_pulse: float | None = None
    """K = K̃·cos θ, rad/pulse (eq. 4); None when θ was not measured."""
    scale_factor_rad_per_pulse_std: float | None = None
    """Standard uncertainty of K, rad/pulse."""
    fix_error_angle_rad: float | None = None
    """θ, rad (METHODS §A.3); None when not measured."""
    fix_error_angle_rad_std: float | None = None
    """Standard uncertainty of θ, rad."""
    angle_random_walk_rad_per_sqrt_s: float | None = None
    """Measured angle random walk, rad/√s; None when not measured."""
    angle_random_walk_rad_per_sqrt_s_std: float | None = None
    """Standard uncertainty of the angle random walk, rad/√s."""
    created_utc: str = field(default_factory=_utc_now_iso)
    """When the values were produced, ISO-8601 UTC (metadata only)."""
    gyro_calib_version: str = __version__
    """Version of gyro_calib that produced them."""

    def __post_init__(self) -> None:
        """Check types, finiteness, signs and which optional values go together."""
        for f in dataclasses.fields(self):
            value, kind = getattr(self, f.name), str(f.type)  # annotations are strings here
            if value is None and 'None' in kind:
                continue
            if kind == 'int':
                if isinstance(value, bool) or not isinstance(value, int):
                    raise HandoffError(f'{f.name} = {value!r} is invalid: it must be an integer.')
            elif kind.startswith('float'):
                if (isinstance(value, bool) or not isinstance(value, (int, float))
                        or not math.isfinite(value)):
                    raise HandoffError(f'{f.name} = {value!r} is invalid: it must be a finite '
                                       'number.')
                object.__setattr__(self, f.name, float(value))
            elif not isinstance(value, str):
                raise HandoffError(f'{f.name} = {value!r} is invalid: it must be a string.')
        try:
            datetime.datetime.fromisoformat(self.created_utc)
        except ValueError:
            raise HandoffError(f'created_utc = {self.created_utc!r} is invalid: it must be an '
                               'ISO-8601 date and time.') from None
        for a, b in _PAIRS:
            if (getattr(self, a) is None) != (getattr(self, b) is None):
                raise HandoffError(f'{a} and {b} must be given together or both left out.')
        checks = [
            ('k_tilde_rad_per_pulse', self.k_tilde_rad_per_pulse > 0, 'positive'),
            ('scale_factor_rad_per_pulse', (self.scale_factor_rad_per_pulse or 1.0) > 0,
             'positive'),
            ('angle_random_walk_rad_per_sqrt_s',
             (self.angle_random_walk_rad_per_sqrt_s or 0.0) >= 0, 'non-negative'),
            ('window_pairs', self.window_pairs >= 0, 'non-negative'),
            ('stations', self.stations >= 0, 'non-negative'),
            ('data_end_stamp_ns', self.data_end_stamp_ns >= self.data_start_stamp_ns,
             f'at least data_start_stamp_ns = {self.data_start_stamp_ns}'),
        ] + [(name + '_std', (getattr(self, name + '_std') or 0.0) >= 0, 'non-negative')
             for name in _UNCERTAIN]
        for name, ok, expected in checks:
            if not ok:
                raise HandoffError(f'{name} = {getattr(self, name)!r} is invalid: it must be '
                                   f'{expected}.')


_UNCERTAIN = ('k_tilde_rad_per_pulse', 'bias_rad_s', 'scale_factor_rad_per_pulse',
              'fix_error_angle_rad', 'angle_random_walk_rad_per_sqrt_s')
"""Fields with a ``_std`` twin."""
_PAIRS = [(name, name + '_std') for name in _UNCERTAIN] + [
    ('fix_error_angle_rad', 'scale_factor_rad_per_pulse')]
"""Fields that are present together or absent together."""
_TOP_LEVEL = ('format_version', 'gyro_calib_version', 'created_utc', 'source',
              'data_start_stamp_ns', 'data_end_stamp_ns', 'gyro')
_GYRO_KEYS = ('k_tilde_rad_per_pulse', 'k_tilde_rad_per_pulse_std',
              'scale_factor_rad_per_pulse', 'scale_factor_rad_per_pulse_std',
              'fix_error_angle_rad', 'fix_error_angle_rad_std', 'bias_rad_s', 'bias_rad_s_std',
              'angle_random_walk_rad_per_sqrt_s', 'angle_random_walk_rad_per_sqrt_s_std',
              'window_pairs', 'stations')
_GYRO_REQUIRED = tuple(k for k in _GYRO_KEYS if k in GyroSectionYaml.__required_keys__)


def calibration_to_yaml_dict(calibration: GyroCalibration) -> CalibrationYaml:
    """The on-disk mapping of ``calibration``; values that are None are left out."""
    c = calibration
    gyro: dict[str, Any] = {}
    for key in _GYRO_KEYS:
        value = getattr(c, key)
        if value is not None:
            gyro[key] = value
    return CalibrationYaml(
        format_version=FORMAT_VERSION, gyro_calib_version=c.gyro_calib_version,
        created_utc=c.created_utc, source=c.source, data_start_stamp_ns=c.data_start_stamp_ns,
        data_end_stamp_ns=c.data_end_stamp_ns, gyro=gyro)  # type: ignore[typeddict-item]


def calibration_from_yaml_dict(data: Any, *, source: str = 'mapping') -> GyroCalibration:
    """Validate an on-disk mapping and build the :class:`GyroCalibration` it describes.

    Args:
        data: the parsed YAML document.
        source: what to name in messages (the file path).

    Raises:
        HandoffError: naming ``source`` and the key, for a document that is not a mapping,
            an unknown ``format_version``, missing or unknown keys, wrong types or values.
    """
    if not isinstance(data, dict):
        raise HandoffError(f'{source} must hold a mapping, got {type(data).__name__}.')
    version = data.get('format_version')
    if 'format_version' in data and version != FORMAT_VERSION:
        raise HandoffError(f'{source} has format_version {version!r}; this gyro_calib '
                           f'({__version__}) reads format_version {FORMAT_VERSION} only.')
    gyro = data.get('gyro')
    if 'gyro' in data and not isinstance(gyro, dict):
        raise HandoffError(f'field gyro in {source} must be a mapping of values.')
    gyro = gyro or {}
    missing = [k for k in _TOP_LEVEL if k not in data] + [
        f'gyro.{k}' for k in _GYRO_REQUIRED if 'gyro' in data and k not in gyro]
    if missing:
        raise HandoffError(f'field(s) {", ".join(missing)} missing in {source}.')
    unknown = sorted(set(data) - set(_TOP_LEVEL)) + sorted(
        f'gyro.{k}' for k in set(gyro) - set(_GYRO_KEYS))
    if unknown:
        raise HandoffError(f'unknown field(s) {", ".join(unknown)} in {source}.')
    values: dict[str, Any] = {k: v for k, v in data.items() if k not in ('gyro', 'format_version')}
    values.update(gyro)
    if isinstance(values['created_utc'], datetime.datetime):  # YAML read an unquoted timestamp
        values['created_utc'] = values['created_utc'].isoformat()
    for key, value in values.items():
        if isinstance(value, str) and key not in ('source', 'created_utc', 'gyro_calib_version'):
            raise HandoffError(f'field {key} in {source} must be a number, got the string '
                               f'{value!r} (YAML 1.1 floats need a dot: 4.0e-6, not 4e-6).')
    try:
        return GyroCalibration(**values)
    except HandoffError as exc:
        raise HandoffError(f'{str(exc).rstrip(".")} in {source}.') from None


def write_calibration(path: str | Path, calibration: GyroCalibration) -> Path:
    """Write ``calibration`` to ``path`` atomically: the old file or the new, never a mix.

    A temporary file in the same directory is written, flushed and fsynced, renamed onto
    the target by ``os.replace`` and the directory is fsynced. The file keeps the mode of
    the file it replaces (new files: 0644). Symbolic links are followed: the link's
    target is replaced.

    Returns:
        The absolute path written.

    Raises:
        HandoffError: naming the path and the OS reason, if any step fails; no temporary
            file is left behind and an existing file is untouched (unless only the final
            directory fsync failed, as the message then says).
    """
    target = Path(path).resolve()
    text = ('# gyro_calib INS hand-off calibration; layout: gyro_calib/handoff.py\n'
            + yaml.safe_dump(dict(calibration_to_yaml_dict(calibration)), sort_keys=False,
                             allow_unicode=True))
    tmp: str | None = None
    try:
        try:
            mode = os.stat(target).st_mode & 0o7777
        except FileNotFoundError:
            mode = 0o644
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


def _fsync_directory(directory: Path) -> None:
    fd = os.open(directory, os.O_RDONLY | getattr(os, 'O_DIRECTORY', 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def load_calibration(path: str | Path) -> GyroCalibration:
    """Read and validate a hand-off calibration file.

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
    return calibration_from_yaml_dict(data, source=f'calibration file {path}')
