"""Static records kept as tables (CSV or whitespace text), read as if they were bags.

Users of allan_variance_ros and MATLAB often keep a static record as a table: one row per
sample, a stamp column and rate (or pulse count) columns. ``gyro-calib`` reads such a file
wherever it takes a BAG: :func:`gyro_calib.bagio.bag_info` and
:func:`gyro_calib.bagio.iter_sample_batches` hand it here, so the noise analysis (and
``info``) see the same columns a bag would give.

Layout: a header row names the columns (comma, semicolon, tab or blank separated; lines
starting with ``#`` are comments). Recognised names (case-insensitive):

- the stamp: ``stamp_ns`` (integer ns) or one of ``stamp_s``, ``time_s``, ``t``, ``time``,
  ``timestamp`` (seconds);
- an IMU: ``gyro_x gyro_y gyro_z`` in rad/s, optionally ``accel_x accel_y accel_z`` in m/s²
  (absent axes are NaN, reported as not measured) → ``/imu/data`` (sensor_msgs/Imu);
- a pulse gyro: ``count`` or ``pulses`` (the cumulative pulse count) → ``/gyro/pulses``;
- a FOG: ``fog_counts`` (the accumulated output counts) → ``/fog/output``.

Any other column is refused with the names known, in one line.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np

from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.bagio.messages import IMU, JOINT_STATE
from gyro_calib.bagio.records import BagInfo, SampleBatch, TopicInfo
from gyro_calib.errors import ConfigError

TABLE_SUFFIXES = frozenset({'.csv', '.tsv', '.txt', '.dat'})
"""File suffixes read as tables."""

IMU_TOPIC = '/imu/data'
STAMP_NS = ('stamp_ns',)
STAMP_S = ('stamp_s', 'time_s', 't', 'time', 'timestamp')
GYRO = ('gyro_x', 'gyro_y', 'gyro_z')
ACCEL = ('accel_x', 'accel_y', 'accel_z')
PULSES = ('count', 'pulses')
FOG = ('fog_counts',)
KNOWN = (*STAMP_NS, *STAMP_S, *GYRO, *ACCEL, *PULSES, *FOG)


def is_table(path: str | Path) -> bool:
    """True for a file whose suffix marks a table (:data:`TABLE_SUFFIXES`)."""
    p = Path(path)
    return p.suffix.lower() in TABLE_SUFFIXES and p.is_file()


def _split(line: str) -> list[str]:
    return [c for c in re.split(r'[,;\t ]+', line.strip()) if c]


def read_table(path: str | Path) -> tuple[str, str, np.ndarray, dict[str, np.ndarray]]:
    """(topic, message type, stamps ns, columns by value name) of the table at ``path``.

    Raises:
        ConfigError: no header, an unknown or missing column, a value that is not a number,
            stamps that are not finite.
    """
    p = Path(path)
    try:
        lines = [ln for ln in p.read_text(encoding='utf-8').splitlines()
                 if ln.strip() and not ln.lstrip().startswith('#')]
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f'{p}: cannot be read as a text table ({exc}).') from None
    if not lines:
        raise ConfigError(f'{p}: an empty table (a header row and one row per sample '
                          'expected).')
    names = [n.lower() for n in _split(lines[0])]
    unknown = [n for n in names if n not in KNOWN]
    if unknown:
        raise ConfigError(f'{p}: unknown column(s) {", ".join(unknown)} in the header row; '
                          f'a table names a stamp ({", ".join(STAMP_NS + STAMP_S)}) and '
                          f'gyro_x gyro_y gyro_z [accel_x accel_y accel_z] (rad/s, m/s²), '
                          f'or count (pulses), or fog_counts.')
    stamp = next((n for n in names if n in STAMP_NS + STAMP_S), None)
    if stamp is None:
        raise ConfigError(f'{p}: no stamp column; name one {", ".join(STAMP_NS + STAMP_S)}.')
    rows = [_split(ln) for ln in lines[1:]]
    bad = next((i for i, r in enumerate(rows) if len(r) != len(names)), None)
    if bad is not None:
        raise ConfigError(f'{p}: row {bad + 2} has {len(rows[bad])} values, the header names '
                          f'{len(names)} columns.')
    if not rows:
        raise ConfigError(f'{p}: the table has a header but no sample row.')
    try:
        cols = {n: np.array([r[i] for r in rows], dtype=np.float64)
                for i, n in enumerate(names) if n != 'stamp_ns'}
        if stamp == 'stamp_ns':
            stamps = np.array([int(r[names.index('stamp_ns')]) for r in rows], dtype=np.int64)
        else:
            t = cols.pop(stamp)
            if not np.all(np.isfinite(t)):
                raise ConfigError(f'{p}: column {stamp} holds a value that is not finite.')
            stamps = np.round(t * 1e9).astype(np.int64)
    except ValueError as exc:
        raise ConfigError(f'{p}: a value is not a number ({exc}).') from None
    if all(g in cols for g in GYRO):
        n = len(stamps)
        accel = np.column_stack([cols.get(a, np.full(n, np.nan)) for a in ACCEL])
        values = {'angular_velocity_rad_s': np.column_stack([cols[g] for g in GYRO]),
                  'linear_acceleration_m_s2': accel,
                  'orientation_covariance_0_rad2': np.full(n, -1.0),
                  'angular_velocity_covariance_0_rad2_s2': np.zeros(n),
                  'linear_acceleration_covariance_0_m2_s4': np.zeros(n)}
        return IMU_TOPIC, IMU, stamps, values
    for group, topic in ((PULSES, '/gyro/pulses'), (FOG, '/fog/output')):
        col = next((c for c in group if c in cols), None)
        if col is not None:
            return topic, JOINT_STATE, stamps, {'position': cols[col],
                                                'velocity': np.full(len(stamps), np.nan)}
    raise ConfigError(f'{p}: no rate or count columns; name gyro_x gyro_y gyro_z, or count, '
                      'or fog_counts.')


def table_info(path: str | Path) -> BagInfo:
    """The :class:`gyro_calib.bagio.records.BagInfo` of a table (one topic)."""
    topic, msgtype, stamps, _ = read_table(path)
    return BagInfo(Path(path), {topic: TopicInfo(topic, msgtype, len(stamps))},
                   int(stamps.min()), int(stamps.max()), len(stamps), {})


def iter_table_batches(path: str | Path, topic_types: Mapping[str, str] | None,
                       batch_messages: int = 50_000) -> Iterator[SampleBatch]:
    """The table as :class:`gyro_calib.bagio.records.SampleBatch` es (log time = stamp)."""
    topic, msgtype, stamps, values = read_table(path)
    if topic_types is not None and topic_types.get(topic) != msgtype:
        return
    for start in range(0, len(stamps), batch_messages):
        sl = slice(start, start + batch_messages)
        n = len(stamps[sl])
        cols = TopicColumns(topic, msgtype, stamps[sl].copy(), stamps[sl].copy(),
                            FrameIds(np.zeros(n, dtype=np.int32), ('table',)),
                            {k: v[sl] for k, v in values.items()})
        yield SampleBatch({topic: cols}, n, int(stamps[sl].max()))
