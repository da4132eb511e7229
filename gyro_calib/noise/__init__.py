"""Noise characterisation of any gyro or IMU: Allan deviation and IEEE Std 952 terms.

Pure core (NumPy/SciPy, no ROS). Entry points:

- :class:`~gyro_calib.noise.calibrator.NoiseCalibrator` / :func:`calibrate_noise`: streams
  ``/gyro/pulses``, ``/fog/output`` or an Imu topic into per-axis Allan deviations (memory
  bounded independently of the record length) and jointly fitted noise terms; built from
  :mod:`~gyro_calib.noise.intake` (streams ordered, gated by the tables' motion, fed to
  channels), :mod:`~gyro_calib.noise.table_report` (the tables' motion in words),
  :mod:`~gyro_calib.noise.axis` (one axis from curve to terms) and
  :mod:`~gyro_calib.noise.results` (results, missing terms, table, ``--json``);
  :mod:`~gyro_calib.noise.topics` names the topics read.
- :class:`~gyro_calib.noise.settings.NoiseSettings`: the settings.
- :func:`~gyro_calib.noise.allan.overlapping_allan_deviation`,
  :func:`~gyro_calib.noise.allan.total_deviation`: batch statistics on arrays.
- :func:`~gyro_calib.noise.fit.fit_noise_terms`: the joint fit of one curve.
- :func:`~gyro_calib.noise.kalibr.write_kalibr_imu_yaml`: Kalibr ``imu.yaml``.
- :func:`~gyro_calib.noise.plots.plot_noise` (imported on use: matplotlib).
- :class:`~gyro_calib.noise.session.NoiseSession`: the method behind the front door
  (registry, ``gyro-calib calibrate --method noise``, ``gyro-calib noise``
  (:mod:`gyro_calib.cli.noise`), ``noise_node``); :mod:`gyro_calib.noise.outputs` writes
  its files; :mod:`gyro_calib.noise.keys` holds the hand-off keys (per axis for an IMU).
"""

from __future__ import annotations

from gyro_calib.noise.allan import overlapping_allan_deviation, total_deviation
from gyro_calib.noise.calibrator import AxisResult, NoiseCalibrator, calibrate_noise
from gyro_calib.noise.fit import NoiseFit, fit_noise_terms
from gyro_calib.noise.kalibr import KalibrExportError, kalibr_imu_yaml, write_kalibr_imu_yaml
from gyro_calib.noise.settings import NoiseSettings
from gyro_calib.noise.terms import ACCEL_UNITS, GYRO_UNITS

__all__ = ['ACCEL_UNITS', 'AxisResult', 'GYRO_UNITS', 'KalibrExportError', 'NoiseCalibrator',
           'NoiseFit', 'NoiseSettings', 'calibrate_noise', 'fit_noise_terms',
           'kalibr_imu_yaml', 'overlapping_allan_deviation', 'total_deviation',
           'write_kalibr_imu_yaml']
