"""Deprecated old import path of the columnar MCAP decoder, removed in the next release.

Kept one release for code written against it: it re-exports what it gave (the column
reader :mod:`gyro_calib.bagio.columns`, its read plan :mod:`gyro_calib.bagio.plan`, the
message codecs :mod:`gyro_calib.bagio.layouts`, the chunk and payload limits of
:mod:`gyro_calib.bagio.chunks` and :mod:`gyro_calib.bagio.payloads`, the errors of
:mod:`gyro_calib.bagio.errors`) and warns (DeprecationWarning) when imported.
"""

import warnings as _warnings

from gyro_calib.bagio.chunks import PREFETCH
from gyro_calib.bagio.columns import ColumnBatch, FrameIds, TopicColumns, iter_column_batches
from gyro_calib.bagio.errors import (
    BagError,
    ColumnDecodeError,
    CorruptBagError,
    CountMismatchError,
    DamagedChunkError,
    IndexMismatchError,
    MessageDecodeError,
    UnindexedChunksError,
    UnsupportedMessageTypeError,
)
from gyro_calib.bagio.layouts import CODECS, KNOWN_TYPES, codec_for
from gyro_calib.bagio.messages import (
    HEADER,
    IMU,
    JOINT_STATE,
    JOINT_WIDTHS,
    TEMPERATURE,
    typestore,
)
from gyro_calib.bagio.payloads import MAX_LAYOUTS
from gyro_calib.bagio.plan import MAX_CHUNK_BYTES, MAX_GROUP_CHUNKS, ChunkPlan, ReadPlan, plan_bag
from gyro_calib.errors import GyroCalibError

__all__ = [
    'CODECS', 'HEADER', 'IMU', 'JOINT_STATE', 'JOINT_WIDTHS', 'KNOWN_TYPES', 'MAX_CHUNK_BYTES',
    'MAX_GROUP_CHUNKS', 'MAX_LAYOUTS', 'PREFETCH', 'TEMPERATURE', 'BagError', 'ChunkPlan',
    'ColumnBatch', 'ColumnDecodeError', 'CorruptBagError', 'CountMismatchError',
    'DamagedChunkError', 'FrameIds', 'GyroCalibError', 'IndexMismatchError',
    'MessageDecodeError', 'ReadPlan', 'TopicColumns', 'UnindexedChunksError',
    'UnsupportedMessageTypeError', 'codec_for', 'iter_column_batches', 'plan_bag', 'typestore',
]

_warnings.warn('gyro_calib.mcap_columns is deprecated; import from gyro_calib.bagio.columns '
               '(the column reader; its errors from gyro_calib.bagio.errors); it will be '
               'removed in the next release', DeprecationWarning, stacklevel=2)
