"""Named errors of the bag layer: every message names the path and the problem."""

from __future__ import annotations

from gyro_calib.errors import GyroCalibError


class BagError(GyroCalibError):
    """A bag cannot be read or written as asked; the message names the path and the problem."""


class BagNotFoundError(BagError):
    """The path does not exist."""


class NotABagError(BagError):
    """The path exists but is not a rosbag2 bag (no metadata.yaml / storage file)."""


class CorruptBagError(BagError):
    """The bag's files are truncated or damaged."""


class MissingTopicError(BagError):
    """A topic the calibration needs is not in the bag."""


class WrongMessageTypeError(BagError):
    """A contract topic is recorded with another message type."""


class EmptyBagError(BagError):
    """The bag holds no message (on the topics asked for)."""


# ---------------------------------------------------------------------------------------
# The columnar decoder (gyro_calib.bagio.columns and the modules it reads with)


class ColumnDecodeError(BagError):
    """The columnar decoder cannot read the bag as asked; the message names path and place."""


class UnsupportedMessageTypeError(ColumnDecodeError):
    """A topic was asked for with a message type the columnar decoder has no columns for."""


class UnindexedChunksError(ColumnDecodeError):
    """The file's chunks have no Message Index records.

    The file's chunks have no Message Index records (valid MCAP, but rosbags' reader
    returns no message from them and the columnar decoder needs them).
    """


class DamagedChunkError(ColumnDecodeError, CorruptBagError):
    """A chunk is truncated, fails to decompress or fails its checksum."""


class IndexMismatchError(ColumnDecodeError, CorruptBagError):
    """A chunk's index disagrees with its records (offsets, channels, log times, lengths)."""


class CountMismatchError(ColumnDecodeError, CorruptBagError):
    """The chunk indexes list another number of messages on a channel than the statistics."""


class MessageDecodeError(ColumnDecodeError, CorruptBagError):
    """rosbags' CDR deserialiser rejected a message the columnar path handed to it."""

