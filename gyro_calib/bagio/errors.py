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
