"""The term fit's θ ≥ 0 least squares is scipy's lsq_linear(method='bvls'), float for float.

:mod:`gyro_calib.noise.bvls` keeps ``scipy.optimize`` out of ``gyro-calib noise`` (issue 40);
the committed bags' numbers stay bit for bit only if it returns lsq_linear's very floats, on
the problems the fit poses (a few columns of the IEEE 952 basis, scaled to unit norm) and
on random ones that put variables on the bound in every order.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from gyro_calib.noise.bvls import nonnegative_least_squares
from gyro_calib.noise.terms import avar_basis


def scipy_bvls(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.asarray(lsq_linear(a, b, bounds=(0.0, np.inf), method='bvls').x)


@pytest.mark.parametrize('seed', range(300))
def test_random_problems_give_lsq_linears_floats(seed: int) -> None:
    rng = np.random.default_rng(seed)
    rows, cols = int(rng.integers(2, 40)), int(rng.integers(1, 6))
    a = rng.standard_normal((rows, cols)) * np.exp(rng.uniform(-5, 5, cols))
    b = rng.standard_normal(rows) * 10.0 ** rng.uniform(-3, 3)
    ours = nonnegative_least_squares(a, b)
    assert np.array_equal(ours, scipy_bvls(a, b)), (ours, scipy_bvls(a, b))


@pytest.mark.parametrize('seed', range(100))
def test_ieee952_fits_give_lsq_linears_floats(seed: int) -> None:
    rng = np.random.default_rng(1000 + seed)
    tau = np.geomspace(1e-3, 1e4, int(rng.integers(6, 40)))
    basis = avar_basis(tau)
    theta = np.where(rng.random(5) < 0.4, 0.0, 10.0 ** rng.uniform(-14, -4, 5))
    y = basis @ theta * (1.0 + 0.3 * rng.standard_normal(len(tau)))
    active = sorted(rng.choice(5, size=int(rng.integers(1, 6)), replace=False))
    sd = np.abs(y) * 0.2 + 1e-30
    aw = basis[:, active] / sd[:, None]
    col = np.linalg.norm(aw, axis=0)
    col = np.where(col > 0, col, 1.0)
    ours = nonnegative_least_squares(aw / col, y / sd)
    assert np.array_equal(ours, scipy_bvls(aw / col, y / sd))
