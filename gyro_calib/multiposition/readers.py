"""The plain formats of the turntable-free recordings (docs/multiposition.md).

=================  ===========================================================================
format             layout
=================  ===========================================================================
``imu_tk``         two ASCII files (IMU-TK's ``importAsciiData``): ``t x y z`` per line, s and
                   raw counts, one accelerometer, one gyro, the same stamps
``imucal``         CSV with a header naming ``acc_x … gyr_z`` (imucal's sessions: m/s² and
                   deg/s, or raw a.u. with a ``part`` column); the sampling rate is given
``xyz6``           ``ax ay az wx wy wz`` per line, m/s² and rad/s, no stamps; the rate is given
=================  ===========================================================================
"""

from __future__ import annotations

import csv
import gzip
import io
import lzma
import math
import warnings
from pathlib import Path
from typing import IO

import numpy as np

from gyro_calib.multiposition.recording import Array, Recording

FORMATS = ('imu_tk', 'imucal', 'xyz6')
"""The plain formats read (each file may also be ``.xz`` or ``.gz`` compressed)."""


def open_text(path: Path) -> IO[str]:
    """A text file, decompressed when its name ends in ``.xz`` or ``.gz``."""
    if path.suffix == '.xz':
        return io.TextIOWrapper(lzma.open(path), encoding='utf-8', newline='')
    if path.suffix == '.gz':
        return io.TextIOWrapper(gzip.open(path), encoding='utf-8', newline='')
    return path.open(encoding='utf-8', newline='')


class RecordingFormatError(ValueError):
    """A plain recording cannot be read (one sentence naming the file and what to do)."""


def _table(path: Path, columns: int) -> Array:
    try:
        with open_text(path) as f, warnings.catch_warnings():
            warnings.simplefilter('ignore', UserWarning)  # empty: said below, in one line
            data = np.loadtxt(f, ndmin=2)
    except (OSError, ValueError, EOFError, lzma.LZMAError) as exc:
        raise RecordingFormatError(f'{path}: not a table of numbers ({exc}).') from None
    if data.size == 0:
        raise RecordingFormatError(f'{path}: empty.')
    if data.shape[1] != columns:
        raise RecordingFormatError(f'{path}: {data.shape[1]} columns per line; this format has '
                                   f'{columns}.')
    return data


def read_imu_tk(acc_path: Path, gyro_path: Path) -> Recording:
    """IMU-TK's two ASCII files (``t x y z``, counts); stamps must agree.

    Raises:
        RecordingFormatError: unreadable, or the two files' stamps differ.
    """
    a, g = _table(acc_path, 4), _table(gyro_path, 4)
    if a.shape != g.shape or not np.allclose(a[:, 0], g[:, 0], rtol=0, atol=1e-6):
        raise RecordingFormatError(f'{acc_path} and {gyro_path}: the stamps differ; give the '
                                   'accelerometer and gyro files of one recording.')
    return Recording(a[:, 0], a[:, 1:], g[:, 1:], 'count', 'count',
                     f'{acc_path} + {gyro_path}')


def read_imucal(path: Path, rate_hz: float, *, gyro_unit: str = 'deg/s',
                acc_unit: str = 'm/s²') -> Recording:
    """An imucal session CSV (columns ``acc_x … gyr_z``; stamps from the sample index).

    Raises:
        RecordingFormatError: unreadable, or a column is missing.
    """
    try:
        with open_text(path) as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            header = list(reader.fieldnames or [])
    except (OSError, UnicodeDecodeError, EOFError, lzma.LZMAError) as exc:
        raise RecordingFormatError(f'{path}: cannot be read ({exc}).') from None
    wanted = ('acc_x', 'acc_y', 'acc_z', 'gyr_x', 'gyr_y', 'gyr_z')
    gone = [c for c in wanted if c not in header]
    if gone:
        raise RecordingFormatError(f'{path}: no column {gone[0]} (an imucal session names '
                                   f'{", ".join(wanted)}).')
    if not rows:
        raise RecordingFormatError(f'{path}: no samples.')
    try:
        data = np.array([[float(r[c]) for c in wanted] for r in rows])
    except (TypeError, ValueError):
        raise RecordingFormatError(f'{path}: a sample is not a number.') from None
    scale = math.pi / 180 if gyro_unit == 'deg/s' else 1.0
    return Recording(np.arange(len(data)) / rate_hz, data[:, :3], data[:, 3:], acc_unit,
                     gyro_unit, str(path), nominal_gyro_scale=scale)


def read_xyz6(path: Path, rate_hz: float) -> Recording:
    """``ax ay az wx wy wz`` per line (m/s², rad/s), stamps from the line number at rate_hz."""
    d = _table(path, 6)
    return Recording(np.arange(len(d)) / rate_hz, d[:, :3], d[:, 3:], 'm/s²', 'rad/s',
                     str(path))
