"""The result in the hand-off's ``imu:`` section (format 4; docs/multiposition.md).

The gyro part in the triad's layout (:mod:`gyro_calib.imu_calibration`): ω_B = M·r − b with
M = T_g·diag(s_g) (rad/s per raw unit: a "pulse" is one raw unit·s), the sense axes s_i the
unit rows of M⁻¹, K_i = 1/‖row i of M⁻¹‖, b = M·b_raw in the body frame. The body frame is
the accelerometer's (§G.2). The accelerometer part, ``imu.accelerometer``:
a_B = raw_to_body·r − bias_m_s2. Every uncertainty is propagated from the fit's covariance
(numerical Jacobian, first order).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from gyro_calib.imu_calibration import ImuCalibration
from gyro_calib.multiposition.recording import Array
from gyro_calib.multiposition.records import TriadFit, misalignment_matrix


def _propagate(f: Callable[[Array], Array], p: Array, cov: Array) -> tuple[Array, Array]:
    """f(p) and its covariance J·C·Jᵀ (central differences)."""
    y = f(p)
    jac = np.empty((y.size, p.size))
    for j in range(p.size):
        h = 1e-6 * max(abs(float(p[j])), 1e-6)
        dp = np.zeros(p.size)
        dp[j] = h
        jac[:, j] = (f(p + dp) - f(p - dp)).ravel() / (2 * h)
    c = jac @ cov @ jac.T
    return y, 0.5 * (c + c.T)


def _gyro_matrix(p: Array) -> Array:
    return misalignment_matrix('gyro', p) @ np.diag(p[6:9])


def _k_axes(p: Array) -> Array:
    r = np.linalg.inv(_gyro_matrix(p))
    norms = np.linalg.norm(r, axis=1)
    return np.concatenate((1 / norms, (r / norms[:, None]).ravel()))


def _acc_matrix(p: Array) -> Array:
    return misalignment_matrix('accelerometer', p) @ np.diag(p[3:6])


def accelerometer_section(fit: TriadFit, gravity: float, gravity_std: float) -> dict[str, Any]:
    """``imu.accelerometer``: raw_to_body, bias (body, m/s²), scales, angles, each with u."""
    p, cov = fit.values, fit.covariance
    a, a_cov = _propagate(lambda q: _acc_matrix(q).ravel(), p, cov)
    b, b_cov = _propagate(lambda q: _acc_matrix(q) @ q[6:9], p, cov)
    std = fit.std
    return {
        'raw_unit': fit.raw_unit,
        'raw_to_body': a.reshape(3, 3).tolist(),
        'raw_to_body_covariance': a_cov.tolist(),
        'bias_m_s2': b.tolist(), 'bias_m_s2_std': np.sqrt(np.diag(b_cov)).tolist(),
        'scale': p[3:6].tolist(), 'scale_std': std[3:6].tolist(),
        'scale_dof': [float(v) for v in fit.dof[3:6]],
        'misalignment_rad': {n.split('_')[1]: float(p[i]) for i, n in enumerate(fit.names[:3])},
        'misalignment_rad_std': {n.split('_')[1]: float(std[i])
                                 for i, n in enumerate(fit.names[:3])},
        'bias_raw': p[6:9].tolist(), 'bias_raw_std': std[6:9].tolist(),
        'gravity_m_s2': gravity, 'gravity_m_s2_std': gravity_std,
        'poses': fit.n_used,
    }


def imu_section(gyro: TriadFit | None, accelerometer: dict[str, Any] | None,
                missing: dict[str, str]) -> ImuCalibration:
    """The ``imu:`` section: the gyro in the triad's layout, the accelerometer beside it."""
    channels = ('x', 'y', 'z')
    if gyro is None:
        return ImuCalibration(channels, accelerometer=accelerometer or {}, missing=dict(missing))
    p, cov = gyro.values[:9], gyro.covariance[:9, :9]
    m, m_cov = _propagate(lambda q: _gyro_matrix(q).ravel(), p, cov)
    ka, ka_cov = _propagate(_k_axes, p, cov)
    axes_std = np.array([np.sqrt(max(float(np.trace(ka_cov[3 + 3 * i:6 + 3 * i,
                                                           3 + 3 * i:6 + 3 * i])), 0.0))
                         for i in range(3)])

    def body_bias(q: Array) -> Array:
        return _gyro_matrix(q[:9]) @ q[9:12]

    b, b_cov = _propagate(body_bias, gyro.values, gyro.covariance)
    dof = np.minimum(gyro.dof[6:9], 1e12)
    return ImuCalibration(
        channels, np.eye(3), ka[:3], np.sqrt(np.diag(ka_cov)[:3]), dof,
        ka[3:].reshape(3, 3), axes_std, m.reshape(3, 3), m_cov, b, np.sqrt(np.diag(b_cov)),
        accelerometer=accelerometer or {}, missing=dict(missing))


def _unflatten(y: Array) -> dict[str, Array]:
    """The Ferraris outputs from their flat vector (§G.6: K_a, R_a, b_a, K_g, R_g, K_ga, b_g)."""
    k_a, r_a, b_a = y[0:3], y[3:12].reshape(3, 3), y[12:15]
    k_g, r_g, k_ga, b_g = y[15:18], y[18:27].reshape(3, 3), y[27:36].reshape(3, 3), y[36:39]
    return {'K_a': k_a, 'R_a': r_a, 'b_a': b_a, 'K_g': k_g, 'R_g': r_g, 'K_ga': k_ga,
            'b_g': b_g}


def ferraris_section(y: Array, cov: Array, *, gyro_si_per_raw: float, acc_unit: str,
                     gravity: float) -> ImuCalibration:
    """The ``imu:`` section of a Ferraris result (flat outputs ``y``, covariance ``cov``).

    Gyro: M = (K_g·R_g)⁻¹·(SI per raw unit), b = M·b_g (rad/s); the g-sensitivity K_ga has no
    place in the triad's layout and is named under ``missing`` (the summary and --json hold
    it). Accelerometer: A = (K_a·R_a)⁻¹, bias A·b_a.
    """
    def gyro_m(q: Array) -> Array:
        v = _unflatten(q)
        return np.asarray(np.linalg.inv(np.diag(v['K_g']) @ v['R_g']) * gyro_si_per_raw,
                          dtype=np.float64)

    def k_axes(q: Array) -> Array:
        r = np.linalg.inv(gyro_m(q))
        norms = np.linalg.norm(r, axis=1)
        return np.concatenate((1 / norms, (r / norms[:, None]).ravel()))

    def acc_a(q: Array) -> Array:
        v = _unflatten(q)
        return np.asarray(np.linalg.inv(np.diag(v['K_a']) @ v['R_a']), dtype=np.float64)

    m, m_cov = _propagate(lambda q: gyro_m(q).ravel(), y, cov)
    ka, ka_cov = _propagate(k_axes, y, cov)
    b, b_cov = _propagate(lambda q: gyro_m(q) @ _unflatten(q)['b_g'], y, cov)
    a, a_cov = _propagate(lambda q: acc_a(q).ravel(), y, cov)
    ab, ab_cov = _propagate(lambda q: acc_a(q) @ _unflatten(q)['b_a'], y, cov)
    axes_std = np.array([np.sqrt(max(float(np.trace(ka_cov[3 + 3 * i:6 + 3 * i,
                                                           3 + 3 * i:6 + 3 * i])), 0.0))
                         for i in range(3)])
    accelerometer = {'raw_unit': acc_unit, 'raw_to_body': a.reshape(3, 3).tolist(),
                     'raw_to_body_covariance': a_cov.tolist(), 'bias_m_s2': ab.tolist(),
                     'bias_m_s2_std': np.sqrt(np.diag(ab_cov)).tolist(),
                     'gravity_m_s2': gravity, 'poses': 6}
    return ImuCalibration(
        ('x', 'y', 'z'), np.eye(3), ka[:3], np.sqrt(np.diag(ka_cov)[:3]), None,
        ka[3:].reshape(3, 3), axes_std, m.reshape(3, 3), m_cov, b, np.sqrt(np.diag(b_cov)),
        accelerometer=accelerometer,
        missing={'gyro_g_sensitivity': 'the Ferraris K_ga (gyro reading per m/s²) has no place '
                 'in this layout: see the summary or --json (imu.ferraris.K_ga_*)'})
