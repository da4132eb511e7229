"""An input propagated into a least-squares fit is counted once (§G eqs. (7a), (8)).

A linear fit whose residuals hold the effect of an input x taken as known (covariance C_x),
partly absorbed by the parameters: the input's term G·C_x·Gᵀ is its whole share, so the
residual scatter must not add that part of x again (eq. (7a) takes its expected share out of
the RSS). With white noise on top (x 42–68 % of the residual sum), over 2000 draws the stated
variance matches the scatter of the estimates (0.95–1.07); the whole RSS as s² gave 1.2–2.7.
"""

from __future__ import annotations

import numpy as np
import pytest

from gyro_calib.multiposition.uncertainty import Input, fit_covariance


@pytest.mark.parametrize('noise', [0.02, 0.05])
def test_stated_variance_matches_the_scatter_with_a_propagated_input(noise: float) -> None:
    rng = np.random.default_rng(5)
    n, p, m = 40, 9, 9  # as the gyro fit: 9 parameters, the accelerometer's 9 as input
    jac = rng.normal(size=(n, p))
    sens = rng.normal(size=(n, m))  # ∂r/∂x: only partly in the span of jac
    c_x = np.eye(m) * 0.01 ** 2
    estimates, stated, twice = [], [], []
    jtj_inv = np.linalg.inv(jac.T @ jac)
    for _ in range(2000):
        x = rng.multivariate_normal(np.zeros(m), c_x)
        y = sens @ x + rng.normal(0, noise, n)  # the data the fit sees (truth θ = 0)
        theta = np.linalg.lstsq(jac, y, rcond=None)[0]
        cov, _, _ = fit_covariance(jac, jac @ theta - y, n - p,
                                   (Input('x', sens, c_x, np.inf),))
        estimates.append(theta)
        stated.append(np.diag(cov))
        res = jac @ theta - y  # the old s²: the whole residual sum, x's share included
        g = -jtj_inv @ jac.T @ sens
        twice.append(np.diag(g @ c_x @ g.T + res @ res / (n - p) * jtj_inv))
    truth = np.var(estimates, axis=0)
    np.testing.assert_allclose(np.mean(stated, axis=0) / truth, 1.0, atol=0.1)
    assert np.max(np.mean(twice, axis=0) / truth) > 1.3  # x counted twice: overstated


def test_a_propagated_share_above_the_residual_sum_is_said_not_hidden() -> None:
    """Eq. (7a) truncated at 0: the basis says the residual term is 0, not a bare s = 0."""
    rng = np.random.default_rng(1)
    jac = rng.normal(size=(20, 2))
    residuals = 1e-3 * rng.normal(size=20)
    big = Input('g', rng.normal(size=(20, 1)), np.array([[1.0]]), np.inf)
    _, _, basis = fit_covariance(jac, residuals, 18, (big,))
    assert 'exceeds it: the residual term is 0 and u rests on the propagated inputs alone' \
        in basis
    small = Input('g', rng.normal(size=(20, 1)), np.array([[1e-12]]), np.inf)
    _, _, basis = fit_covariance(jac, residuals, 18, (small,))
    assert 'exceeds' not in basis and 'taken out' in basis
