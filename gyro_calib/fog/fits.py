"""Least squares for scale-factor fits: line, two slopes, polynomial (IEEE Std 952 practice).

Every fit takes design weights w_i (fixed by the measurement design, e.g. the segment
length, so they carry no estimation noise) and per-point variances v_i measured from the
data, and returns the covariance by the sandwich rule cov = A·diag(v)·Aᵀ with
A = (XᵀWX)⁻¹XᵀW. With unbiased v_i this covariance is unbiased whatever the weights,
which keeps the stated uncertainties honest when the v_i are noisy estimates.

Nonlinearity (METHODS §E; IEEE Std 952): max |N_i − (K·ω_i + N₀)| over the full-scale
output max |N_i|; its standard uncertainty is that of the residual at the maximum.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class LinearFit:
    """Result of a weighted least-squares fit y = X·β.

    Attributes:
        beta: fitted coefficients.
        cov: their covariance (sandwich rule), same units squared.
        operator: A with β = A·y (rows: coefficients), for covariances with other fits.
        residuals: y − X·β.
        residual_cov: covariance of the residuals.
        n_points: points fitted.
    """

    beta: FloatArray
    cov: FloatArray
    operator: FloatArray
    residuals: FloatArray
    residual_cov: FloatArray
    n_points: int

    def std(self, k: int) -> float:
        """Standard uncertainty of coefficient k."""
        return float(np.sqrt(max(self.cov[k, k], 0.0)))


def weighted_least_squares(design: FloatArray, y: FloatArray, weights: FloatArray,
                           variances: FloatArray) -> LinearFit:
    """Solve y = X·β with design weights and sandwich covariance from per-point variances.

    Raises:
        np.linalg.LinAlgError: if the design is rank-deficient.
    """
    x = np.asarray(design, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    v = np.asarray(variances, dtype=np.float64)
    scale = np.max(np.abs(x), axis=0)
    scale[scale == 0] = 1.0
    xs = x / scale
    normal = xs.T @ (w[:, None] * xs)
    if np.linalg.matrix_rank(normal) < x.shape[1]:
        raise np.linalg.LinAlgError('rank-deficient design')
    operator = np.linalg.solve(normal, xs.T * w) / scale[:, None]
    beta = operator @ y
    cov = (operator * v) @ operator.T
    hat = x @ operator
    resid_op = np.eye(len(y)) - hat
    residuals = y - x @ beta
    return LinearFit(beta, cov, operator, residuals, (resid_op * v) @ resid_op.T, len(y))


@dataclass(frozen=True, slots=True)
class Nonlinearity:
    """IEEE Std 952 nonlinearity of a line fit.

    Attributes:
        ppm: max |residual| / full scale, ppm.
        std_ppm: standard uncertainty of that residual / full scale, ppm.
        full_scale: max |output| over the points, output units.
        at: index of the point with the largest |residual|.
    """

    ppm: float
    std_ppm: float
    full_scale: float
    at: int


def nonlinearity(fit: LinearFit, outputs: FloatArray) -> Nonlinearity:
    """Nonlinearity of ``fit`` over its points, with ``outputs`` giving the full scale."""
    full_scale = float(np.max(np.abs(outputs)))
    at = int(np.argmax(np.abs(fit.residuals)))
    if full_scale == 0.0:
        return Nonlinearity(0.0, 0.0, 0.0, at)
    std = float(np.sqrt(max(fit.residual_cov[at, at], 0.0)))
    return Nonlinearity(abs(float(fit.residuals[at])) / full_scale * 1e6,
                        std / full_scale * 1e6, full_scale, at)


def line_design(x: FloatArray) -> FloatArray:
    """Columns [x, 1] of y = K·x + b."""
    x = np.asarray(x, dtype=np.float64)
    return np.column_stack((x, np.ones_like(x)))


def two_slope_design(x: FloatArray) -> FloatArray:
    """Columns [max(x, 0), min(x, 0), 1] of y = K₊·x⁺ + K₋·x⁻ + b (asymmetry)."""
    x = np.asarray(x, dtype=np.float64)
    return np.column_stack((np.maximum(x, 0.0), np.minimum(x, 0.0), np.ones_like(x)))


def polynomial_design(x: FloatArray, order: int) -> FloatArray:
    """Columns [x, x², …, x^order, 1]."""
    x = np.asarray(x, dtype=np.float64)
    return np.column_stack([x**k for k in range(1, order + 1)] + [np.ones_like(x)])


def ratio_std(num: float, den: float, var_num: float, var_den: float, cov: float) -> float:
    """Standard uncertainty of num/den by first-order propagation."""
    r = num / den
    var = (var_num - 2.0 * r * cov + r * r * var_den) / (den * den)
    return float(np.sqrt(max(var, 0.0)))
