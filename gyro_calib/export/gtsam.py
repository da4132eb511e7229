"""GTSAM IMU preintegration parameters (``PreintegrationParams``/``…CombinedParams``).

GTSAM has no file format: this YAML names each setter's matrix, continuous-time as GTSAM
takes them (its ``ImuFactor`` discretises with Δt itself; METHODS §E):

- ``gyroscope_covariance`` = diag(N_x², N_y², N_z²), rad²/s (``setGyroscopeCovariance``);
- ``bias_omega_covariance`` = diag(K²), rad²/s³ (``setBiasOmegaCovariance``, combined);
- ``accelerometer_covariance`` = diag(N_a²), m²/s³; ``bias_acc_covariance`` = diag(K_a²),
  m²/s⁵ (only when the accelerometers were measured; a gyro-only hand-off gives the gyro
  keys, enough for ``PreintegratedAhrsMeasurements``);
- ``integration_covariance``: not a sensor term (position-from-velocity integration error);
  the 1e-8·I of GTSAM's own examples, m²/s.

Per axis: each axis's own value (no largest-of). :func:`gtsam_matrices` reads the file back.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from gyro_calib.export.common import ExportOptions, axis_terms, check_stream, header, number
from gyro_calib.export.source import AXES, UNITS, ExportSource

FORMAT = 'gtsam'
INTEGRATION_COVARIANCE = 1e-8
GYRO_KEYS = ('gyroscope_covariance', 'bias_omega_covariance')
ACCEL_KEYS = ('accelerometer_covariance', 'bias_acc_covariance', 'integration_covariance')


def _matrix(key: str, unit: str, setter: str, entries: list[tuple[float, str]]) -> list[str]:
    lines = [f'{key}:  # {unit}; {setter}; diagonal, continuous (density squared)']
    for i, (value, why) in enumerate(entries):
        row = ['0.0'] * 3
        row[i] = number(value)
        lines.append(f'  - [{", ".join(row)}]  # {AXES[i]}: {why}')
    return lines


def gtsam_text(src: ExportSource, options: ExportOptions) -> str:
    """The GTSAM parameter YAML (see the module docstring)."""
    check_stream(src, FORMAT, options)
    n = axis_terms(src, FORMAT, 'gyro', 'N', 'gyroscope_covariance')
    k = axis_terms(src, FORMAT, 'gyro', 'K', 'bias_omega_covariance')
    body = _matrix('gyroscope_covariance', 'rad^2/s', 'setGyroscopeCovariance',
                   [(t.value ** 2, t.text(UNITS[('gyro', 'N')]) + ', squared') for t in n])
    body += _matrix('bias_omega_covariance', 'rad^2/s^3', 'setBiasOmegaCovariance',
                    [(t.value ** 2, t.text(UNITS[('gyro', 'K')]) + ', squared') for t in k])
    notes = []
    if any(src.accel[a] for a in AXES):
        na = axis_terms(src, FORMAT, 'accel', 'N', 'accelerometer_covariance')
        ka = axis_terms(src, FORMAT, 'accel', 'K', 'bias_acc_covariance')
        body += _matrix('accelerometer_covariance', 'm^2/s^3', 'setAccelerometerCovariance',
                        [(t.value ** 2, t.text(UNITS[('accel', 'N')]) + ', squared')
                         for t in na])
        body += _matrix('bias_acc_covariance', 'm^2/s^5', 'setBiasAccCovariance',
                        [(t.value ** 2, t.text(UNITS[('accel', 'K')]) + ', squared')
                         for t in ka])
        body += _matrix('integration_covariance', 'm^2/s', 'setIntegrationCovariance',
                        [(INTEGRATION_COVARIANCE, 'not a sensor term: GTSAM examples\' '
                          'integration error')] * 3)
    else:
        notes.append('No accelerometer term in the hand-off: gyro keys only (enough for '
                     'PreintegratedAhrsMeasurements / PreintegratedRotationParams); no '
                     'accelerometer covariance is invented.')
    return '\n'.join(header(src, FORMAT, options, notes) + body) + '\n'


def gtsam_matrices(text: str) -> dict[str, npt.NDArray[np.float64]]:
    """The 3×3 matrices of a GTSAM parameter file, by key (for the setters)."""
    data: Any = yaml.safe_load(text)
    out = {}
    for key in GYRO_KEYS + ACCEL_KEYS:
        if key in data:
            m = np.asarray(data[key], dtype=float)
            if m.shape != (3, 3):
                raise ValueError(f'{key} must be 3×3; it is {m.shape}')
            out[key] = m
    return out
