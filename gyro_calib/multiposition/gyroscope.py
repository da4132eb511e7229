"""The gyro from the rotations between static poses (docs/methods.md §G.3).

The gyro bias b is the mean of the static intervals' raw means (eq. (6)), its uncertainty
their scatter (Earth rate, bias instability and noise in one, ν = K − 1). Between pose k and
pose k + 1 the calibrated rate ω = T·diag(s)·(r − b) is integrated to the rotation R_k
(cubic mean rate per step, steps composed exactly, eq. (5)); the gravity direction u_k of
pose k, seen from pose k + 1, must be u_{k+1}:

    r_k = R_kᵀ(θ)·u_k − u_{k+1}   (3 components, 2 independent)                     (6)

T (six angles: the gyro axes against the accelerometer frame) and s (three scales) are fitted
to the K − 1 motions; ν = 2(K − 1) − 9. The bias and the accelerometer calibration (through
the u_k) are inputs propagated by eq. (8).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from gyro_calib.multiposition.records import GYRO_NAMES, TriadFit, misalignment_matrix
from gyro_calib.multiposition.rotation import body_rotations
from gyro_calib.multiposition.static import StaticInterval
from gyro_calib.multiposition.uncertainty import (
    Input,
    condition_number,
    fit_covariance,
    weakest,
)

Array = npt.NDArray[np.float64]

MIN_MOTIONS = 9
"""Fewest motions between poses the gyro fit takes (9 parameters, ν ≥ 9)."""


def static_bias(gyro: Array, intervals: tuple[StaticInterval, ...]) -> tuple[Array, Array, int]:
    """The bias b: mean of the intervals' raw means, its covariance, ν = K − 1 (§G.3 eq. (6))."""
    means = np.array([gyro[iv.start:iv.stop].mean(axis=0) for iv in intervals])
    k = len(means)
    cov = np.cov(means, rowvar=False) / k if k > 1 else np.full((3, 3), np.inf)
    return means.mean(axis=0), np.atleast_2d(cov), k - 1


def motion_steps(t_s: Array, gyro: Array,
                 intervals: tuple[StaticInterval, ...]) -> tuple[Array, Array]:
    """Each motion's mean raw rate per step and step lengths, padded (M×L×3, M×L; dt 0 pads).

    The mean rate over a step from samples i−1 … i+2 by the cubic through them,
    (−r_{i−1} + 13r_i + 13r_{i+1} − r_{i+2})/24 (eq. (5)): the trapezoid's error, a fraction
    of 10⁻³ of the angle at 50 Hz hand turns, biased the scales by more than their u.
    """
    spans = [(a.stop - 1, b.start) for a, b in zip(intervals[:-1], intervals[1:], strict=True)]
    length = max(e - s for s, e in spans)
    rates = np.zeros((len(spans), length, 3))
    dts = np.zeros((len(spans), length))
    for m, (s, e) in enumerate(spans):
        i = np.arange(s, e)
        last = len(gyro) - 1
        rates[m, :e - s] = (13.0 * (gyro[i] + gyro[i + 1]) - gyro[np.maximum(i - 1, 0)]
                            - gyro[np.minimum(i + 2, last)]) / 24.0
        dts[m, :e - s] = np.diff(t_s[s:e + 1])
    return rates, dts


def directions(means_cal: Array) -> Array:
    """Unit gravity directions (K×3) of calibrated accelerometer means."""
    return np.asarray(means_cal / np.linalg.norm(means_cal, axis=1, keepdims=True))


def rotations(p: Array, bias: Array, rates: Array, dts: Array) -> Array:
    """R_k of eq. (5) for the gyro parameters p (9: angles, scales) and bias (raw)."""
    m = misalignment_matrix('gyro', p) @ np.diag(p[6:9])
    steps = ((rates - bias) @ m.T) * dts[..., None]
    return body_rotations(steps)


def residuals_of(rot: Array, u: Array) -> Array:
    """Eq. (6): R_kᵀu_k − u_{k+1}, flattened."""
    return np.asarray((np.einsum('kji,kj->ki', rot, u[:-1]) - u[1:]).ravel())


def _start_scale(bias: Array, rates: Array, dts: Array, u: Array, nominal: float) -> float:
    """The common scale whose rotations best match the directions.

    On a log grid over 10⁻⁶ … 10² × nominal (raw counts too).
    """
    grid = nominal * np.logspace(-6, 2, 81)
    costs = [float(np.sum(residuals_of(rotations(
        np.concatenate((np.zeros(6), [s, s, s])), bias, rates, dts), u) ** 2)) for s in grid]
    return float(grid[int(np.argmin(costs))])


def fit_gyro(t_s: Array, gyro: Array, intervals: tuple[StaticInterval, ...], u: Array,
             u_sensitivity: Array, u_inputs_cov: Array, u_inputs_dof: float, *,
             nominal_scale: float = 1.0, raw_unit: str = '',
             bias: Array | None = None) -> TriadFit:
    """Scale and misalignment from the motions, bias from the static intervals (§G.3).

    Args:
        t_s: stamps, s.
        gyro: raw gyro samples (N×3).
        intervals: the static poses, in time order.
        u: their gravity directions (K×3, unit).
        u_sensitivity: ∂vec(u)/∂θ_a (3K × 9), θ_a the accelerometer parameters.
        u_inputs_cov: C(θ_a).
        u_inputs_dof: its ν.
        nominal_scale: where the start search is centred (SI unit per raw unit).
        raw_unit: the raw samples' unit.
        bias: a bias to use instead of the static intervals' (raw; taken as exact), e.g. a
            peer tool's, to compare residuals.

    Raises:
        ValueError: fewer than :data:`MIN_MOTIONS` motions.
    """
    k = len(intervals)
    if k - 1 < MIN_MOTIONS:
        raise ValueError(f'{k - 1} motions between static poses; the gyro needs at least '
                         f'{MIN_MOTIONS}.')
    if bias is None:
        bias, bias_cov, bias_dof = static_bias(gyro, intervals)
    else:
        bias, bias_cov, bias_dof = np.asarray(bias, dtype=float), np.zeros((3, 3)), 10 ** 9
    rates, dts = motion_steps(t_s, gyro, intervals)
    s0 = _start_scale(bias, rates, dts, u, nominal_scale)

    def residual(p: Array) -> Array:
        return residuals_of(rotations(p, bias, rates, dts), u)

    sol = least_squares(residual, np.concatenate((np.zeros(6), [s0, s0, s0])),
                        x_scale='jac', method='lm', xtol=1e-14, ftol=1e-14, gtol=1e-14)
    p = sol.x
    jac = np.asarray(sol.jac, dtype=np.float64)
    res = residual(p)
    rot = rotations(p, bias, rates, dts)
    d_bias = np.empty((len(res), 3))
    for j in range(3):
        h = max(1e-6 * abs(bias[j]), 1e-3 * float(np.sqrt(bias_cov[j, j])), 1e-9)
        db = np.zeros(3)
        db[j] = h
        d_bias[:, j] = (residuals_of(rotations(p, bias + db, rates, dts), u) - res) / h
    d_u = _residual_wrt_directions(rot) @ u_sensitivity
    dof = 2 * (k - 1) - len(p)
    cov, nu, basis = fit_covariance(jac, res, dof, (
        Input('gyro bias', d_bias, bias_cov, float(bias_dof)),
        Input('accelerometer calibration', d_u, u_inputs_cov, u_inputs_dof)))
    # the bias as three more parameters: its own covariance, independent of the fit's
    full = np.zeros((12, 12))
    full[:9, :9] = cov
    jtj_inv = np.linalg.pinv(jac.T @ jac)
    g_b = -jtj_inv @ jac.T @ d_bias
    full[:9, 9:] = g_b @ bias_cov
    full[9:, :9] = full[:9, 9:].T
    full[9:, 9:] = bias_cov
    std = np.sqrt(np.diag(full))
    values = np.concatenate((p, bias))
    per_motion = np.linalg.norm(res.reshape(-1, 3), axis=1)
    return TriadFit('gyro', GYRO_NAMES, values, full,
                    np.concatenate((nu, np.full(3, float(bias_dof)))), k - 1,
                    float(np.sqrt(np.mean(per_motion ** 2))), per_motion,
                    basis + f'; bias: scatter of {k} static means (ν = {bias_dof})',
                    weakest(GYRO_NAMES[:9], jac, std[:9]), raw_unit,
                    condition=condition_number(jac)[0])


def _residual_wrt_directions(rot: Array) -> Array:
    """∂r/∂vec(u) of eq. (6): R_kᵀ on u_k, −I on u_{k+1} ((3(K−1)) × 3K)."""
    m = len(rot)
    out = np.zeros((3 * m, 3 * (m + 1)))
    for i in range(m):
        out[3 * i:3 * i + 3, 3 * i:3 * i + 3] = rot[i].T
        out[3 * i:3 * i + 3, 3 * i + 3:3 * i + 6] = -np.eye(3)
    return out
