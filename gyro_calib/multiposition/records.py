"""What the multiposition estimators give: a fitted triad with its covariance (§G.4)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from gyro_calib.estimate import Estimate

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class TriadFit:
    """One sensor triad's parameters, covariance and the data they rest on.

    Model (§G eq. (3)): y = T·diag(s)·(r − b), r the raw sample (raw unit), y the calibrated
    one (m/s² or rad/s).

    Attributes:
        sensor: 'accelerometer' or 'gyro'.
        names: parameter names, in the order of ``values``.
        values: the parameters (misalignments rad, scales SI unit per raw unit, biases raw).
        covariance: their covariance (k = 1).
        dof: ν of each parameter's standard uncertainty (Welch–Satterthwaite; inf = Type B
            only).
        n_used: poses (accelerometer) or motions between poses (gyro) the fit rests on.
        residual_rms: RMS of the residuals (m/s² accelerometer, unit vector gyro).
        residuals: per pose or motion, the residual norm (same unit).
        basis: what the uncertainty rests on, one line.
        weak: the conditioning statement: which parameter the poses leave weak, one line.
        raw_unit: the raw samples' unit as read.
        condition: cond(JᵀJ) of the fit's column-normalised Jacobian (§G.5; NaN: none).
    """

    sensor: str
    names: tuple[str, ...]
    values: Array
    covariance: Array
    dof: Array
    n_used: int
    residual_rms: float
    residuals: Array
    basis: str
    weak: str = ''
    raw_unit: str = ''
    notes: tuple[str, ...] = field(default=())
    condition: float = math.nan

    @property
    def std(self) -> Array:
        """Standard uncertainty of each parameter."""
        return np.sqrt(np.maximum(np.diag(self.covariance), 0.0))

    def value(self, name: str) -> float:
        """One parameter's value."""
        return float(self.values[self.names.index(name)])

    def estimate(self, name: str) -> Estimate:
        """One parameter as an :class:`~gyro_calib.estimate.Estimate`."""
        i = self.names.index(name)
        nu = float(self.dof[i])
        return Estimate(float(self.values[i]), float(self.std[i]), self.n_used,
                        int(nu) if math.isfinite(nu) else 10 ** 9, basis=self.basis)

    @property
    def misalignment(self) -> Array:
        """T of eq. (3)."""
        return misalignment_matrix(self.sensor, self.values)

    @property
    def scale(self) -> Array:
        """diag(s), SI unit per raw unit."""
        return np.diag(self.values[-6:-3] if self.sensor == 'accelerometer'
                       else self.values[6:9])

    @property
    def bias_raw(self) -> Array:
        """b, raw unit (the gyro's from the static intervals)."""
        return np.asarray(self.values[-3:]) if self.sensor == 'accelerometer' \
            else np.asarray(self.values[9:12])

    @property
    def matrix(self) -> Array:
        """T·diag(s): raw → calibrated."""
        return self.misalignment @ self.scale


ACC_NAMES = ('misalignment_yz_rad', 'misalignment_zy_rad', 'misalignment_zx_rad',
             'scale_x', 'scale_y', 'scale_z', 'bias_x_raw', 'bias_y_raw', 'bias_z_raw')
"""The accelerometer's parameters (IMU-TK's layout: T upper triangular, 3 angles)."""
GYRO_NAMES = ('misalignment_yz_rad', 'misalignment_zy_rad', 'misalignment_zx_rad',
              'misalignment_xz_rad', 'misalignment_xy_rad', 'misalignment_yx_rad',
              'scale_x', 'scale_y', 'scale_z', 'bias_x_raw', 'bias_y_raw', 'bias_z_raw')
"""The gyro's (T with six angles: its axes against the accelerometer's frame)."""


def misalignment_matrix(sensor: str, p: Array) -> Array:
    """T of eq. (3) from the parameter vector (accelerometer: 3 angles, gyro: 6)."""
    if sensor == 'accelerometer':
        yz, zy, zx = p[0], p[1], p[2]
        xz = xy = yx = 0.0
    else:
        yz, zy, zx, xz, xy, yx = p[0], p[1], p[2], p[3], p[4], p[5]
    return np.array([[1.0, -yz, zy], [xz, 1.0, -zx], [-xy, yx, 1.0]])
