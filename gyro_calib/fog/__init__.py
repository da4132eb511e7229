"""FOG scale-factor calibration: turntable (IEEE Std 952) and ladder-wave self-calibration.

METHODS §B (seed 001). Pure core, no ROS import. Entry points:
:class:`~gyro_calib.fog.calibrator.FogCalibrator` (streaming) and
:func:`~gyro_calib.fog.calibrator.calibrate_fog` (batch); settings in
:class:`~gyro_calib.fog.settings.FogSettings`; topic names in :mod:`gyro_calib.fog.topics`;
plots in :mod:`gyro_calib.fog.plots`.
"""

from __future__ import annotations

from gyro_calib.fog.calibrator import FogCalibrator, calibrate_fog
from gyro_calib.fog.settings import FogSettings

__all__ = ['FogCalibrator', 'FogSettings', 'calibrate_fog']
