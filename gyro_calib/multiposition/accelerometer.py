"""The accelerometer from gravity at the static poses (docs/methods.md §G.2).

At rest the calibrated specific force has the magnitude of local gravity g:

    r_k = ‖T·diag(s)·(ū_k − b)‖ − g,   k = 1 … K poses                               (4)

with ū_k the raw mean of pose k, T upper unitriangular (three angles, the accelerometer
frame's definition: x along the x axis, y in the x–y plane), s the scales and b the biases:
nine parameters, K ≥ 12 poses. The start is the ellipsoid through the means by linear least
squares; the fit is Gauss–Newton (scipy least_squares), its covariance eq. (7) with u(g)
propagated (eq. (8)).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from gyro_calib.multiposition.records import ACC_NAMES, TriadFit, misalignment_matrix
from gyro_calib.multiposition.uncertainty import (
    Input,
    condition_number,
    fit_covariance,
    weakest,
)

Array = npt.NDArray[np.float64]

MIN_POSES = 12
"""Fewest static poses the accelerometer fit takes (9 parameters, ν ≥ 3)."""


def calibrated(p: Array, raw: Array) -> Array:
    """T·diag(s)·(raw − b) of eq. (4) for raw samples (…×3)."""
    m = misalignment_matrix('accelerometer', p) @ np.diag(p[3:6])
    return np.asarray((raw - p[6:9]) @ m.T)


def start(means: Array, g: float) -> Array:
    """The axis-aligned ellipsoid through the means: Σ A_i u_i² + B_i u_i + C = 0."""
    centre = means.mean(axis=0)
    spread = np.maximum(means.std(axis=0), np.finfo(float).tiny)
    x = (means - centre) / spread  # conditioned: raw counts squared would swamp the rest
    design = np.column_stack((x ** 2, x, np.ones(len(x))))
    coef = np.linalg.svd(design)[2][-1]  # the null direction: Σ A_i x_i² + B_i x_i + C = 0
    coef = coef if np.sum(coef[:3]) > 0 else -coef
    a, b_lin, c = coef[:3], coef[3:6], coef[6]
    a = np.where(a > 0, a, np.abs(a) + 1e-12)
    bias = -b_lin / (2 * a)
    kappa = -c + float(np.sum(b_lin ** 2 / (4 * a)))
    scale = g * np.sqrt(a / max(kappa, 1e-300))
    return np.concatenate((np.zeros(3), scale / spread, centre + bias * spread))


def fit_accelerometer(means: Array, g: float, u_g: float, *, raw_unit: str = '') -> TriadFit:
    """Scale, misalignment and bias from the static poses' raw means (§G.2 eq. (4)).

    Raises:
        ValueError: fewer than :data:`MIN_POSES` poses.
    """
    k = len(means)
    if k < MIN_POSES:
        raise ValueError(f'{k} static poses; the accelerometer needs at least {MIN_POSES}.')

    def residual(p: Array) -> Array:
        return np.asarray(np.linalg.norm(calibrated(p, means), axis=1) - g)

    sol = least_squares(residual, start(means, g), x_scale='jac', method='lm',
                        xtol=1e-15, ftol=1e-15, gtol=1e-15)
    p = sol.x
    jac = np.asarray(sol.jac, dtype=np.float64)
    res = residual(p)
    dof = k - len(p)
    cov, nu, basis = fit_covariance(jac, res, dof, (
        Input('u(g)', -np.ones((k, 1)), np.array([[u_g ** 2]]), np.inf),))
    std = np.sqrt(np.diag(cov))
    return TriadFit('accelerometer', ACC_NAMES, p, cov, nu, k,
                    float(np.sqrt(np.mean(res ** 2))), np.abs(res), basis,
                    weakest(ACC_NAMES, jac, std), raw_unit,
                    condition=condition_number(jac)[0])
