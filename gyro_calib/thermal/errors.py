"""Named errors of the thermal method (each message a whole sentence naming value and limit)."""

from __future__ import annotations

from gyro_calib.errors import GyroCalibError, InsufficientDataError


class ExtrapolationError(GyroCalibError):
    """A temperature (or its rate) lies outside the model's calibrated range plus margin."""


class ModelMismatchError(GyroCalibError):
    """A thermal model is applied to a gyro, site or sensor set it was not made for."""


class ModelFileError(GyroCalibError):
    """A thermal model dict (hand-off content) lacks a key or holds an invalid value."""


class TemperatureDataError(InsufficientDataError):
    """The temperature stream cannot support the fit (missing, stuck, too few points)."""


class SensorSamplingError(TemperatureDataError):
    """A temperature sensor is read too sparsely to interpolate.

    A temperature sensor is read so sparsely that it cannot be interpolated onto the
    averaging intervals (bad input: the offline front door refuses the run, exit 2).
    """
