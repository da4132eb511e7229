"""Named errors of gyro_calib; every message is a whole sentence naming the value and limit."""

from __future__ import annotations


class GyroCalibError(Exception):
    """Base class of every error gyro_calib raises on purpose."""


class ConfigError(GyroCalibError):
    """A configuration value (parameter, YAML field) is missing or out of range."""


class InsufficientDataError(GyroCalibError):
    """Too few accepted windows (or samples) to form the requested estimate."""


class WindowError(GyroCalibError):
    """A whole-revolution window (or its end point) cannot be measured reliably."""


class StreamError(GyroCalibError):
    """A sample stream is malformed (non-finite values, mismatched lengths...)."""
