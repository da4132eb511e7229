"""Least squares with θ ≥ 0 by bounded-variable least squares (Stark & Parker 1995).

``scipy.optimize.lsq_linear(A, b, bounds=(0, inf), method='bvls')``, the same steps in the
same order (so the same floats: tested ``==`` against it in test/test_noise_bvls.py),
without importing ``scipy.optimize`` — about a fifth of ``gyro-calib noise``'s CPU time on a
short record, for the term fit's few unknowns (issue 40). Adapted from SciPy 1.17
``scipy/optimize/_lsq/lsq_linear.py`` and ``bvls.py`` (BSD-3-Clause, Copyright (c)
2001-2002 Enthought, Inc. 2003, SciPy Developers); the verbose output and the result
object left out, the upper bound fixed at +∞.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]

TOL = 1e-10
"""lsq_linear's default tolerance (relative cost change and first-order optimality)."""


def _kkt_optimality(g: FloatArray, on_bound: FloatArray) -> float:
    """The largest violation of the KKT conditions."""
    g_kkt = g * on_bound
    free_set = on_bound == 0
    g_kkt[free_set] = np.abs(g[free_set])
    return float(np.max(g_kkt))


def nonnegative_least_squares(a: FloatArray, b: FloatArray, tol: float = TOL) -> FloatArray:
    """The x ≥ 0 minimising ‖a·x − b‖: ``lsq_linear(a, b, (0, inf), method='bvls').x``."""
    n = a.shape[1]
    lb = np.zeros(n)
    ub = np.full(n, np.inf)
    x_lsq = np.asarray(np.linalg.lstsq(a, b, rcond=-1)[0], dtype=np.float64)
    if np.all((x_lsq >= lb) & (x_lsq <= ub)):
        return x_lsq
    return _bvls(a, b, x_lsq, lb, ub, tol)


def _bvls(a: FloatArray, b: FloatArray, x_lsq: FloatArray, lb: FloatArray, ub: FloatArray,
          tol: float) -> FloatArray:
    """Stark & Parker's BVLS from the unconstrained solution (SciPy's ``bvls``)."""
    n = a.shape[1]
    x = x_lsq.copy()
    on_bound = np.zeros(n)
    mask = x <= lb
    x[mask] = lb[mask]
    on_bound[mask] = -1
    mask = x >= ub
    x[mask] = ub[mask]
    on_bound[mask] = 1
    free = on_bound == 0
    active_set = ~free
    free_set = np.nonzero(free)[0]
    r = a.dot(x) - b
    cost = 0.5 * np.dot(r, r)
    g = a.T.dot(r)
    iteration = 0
    # initialisation: the least-squares solution on the free variables made feasible by
    # putting the violating ones on their bounds, until it is
    while free_set.size > 0:
        iteration += 1
        z = np.linalg.lstsq(a[:, free_set], b - a.dot(x * active_set), rcond=None)[0]
        lbv = z < lb[free_set]
        ubv = z > ub[free_set]
        v = lbv | ubv
        if np.any(lbv):
            ind = free_set[lbv]
            x[ind] = lb[ind]
            active_set[ind] = True
            on_bound[ind] = -1
        if np.any(ubv):
            ind = free_set[ubv]
            x[ind] = ub[ind]
            active_set[ind] = True
            on_bound[ind] = 1
        ind = free_set[~v]
        x[ind] = z[~v]
        r = a.dot(x) - b
        cost = 0.5 * np.dot(r, r)
        g = a.T.dot(r)
        if np.any(v):
            free_set = free_set[~v]
        else:
            break
    max_iter = n + iteration
    done = False
    optimality = _kkt_optimality(g, on_bound)
    for iteration in range(iteration, max_iter):  # BVLS loop A
        if optimality < tol:
            done = True
        if done:
            break
        move_to_free = np.argmax(g * on_bound)
        on_bound[move_to_free] = 0
        while True:  # BVLS loop B
            free = on_bound == 0
            active_set = ~free
            free_set = np.nonzero(free)[0]
            x_free = x[free_set]
            lb_free = lb[free_set]
            ub_free = ub[free_set]
            z = np.linalg.lstsq(a[:, free_set], b - a.dot(x * active_set), rcond=None)[0]
            lbv = np.nonzero(z < lb_free)[0]
            ubv = np.nonzero(z > ub_free)[0]
            v = np.hstack((lbv, ubv))
            if v.size > 0:
                alphas = np.hstack((lb_free[lbv] - x_free[lbv],
                                    ub_free[ubv] - x_free[ubv])) / (z[v] - x_free[v])
                i = np.argmin(alphas)
                i_free = v[i]
                alpha = alphas[i]
                x_free *= 1 - alpha
                x_free += alpha * z
                x[free_set] = x_free
                on_bound[free_set[i_free]] = -1 if i < lbv.size else 1
            else:
                x[free_set] = z
                break
        r = a.dot(x) - b
        cost_new = 0.5 * np.dot(r, r)
        if cost - cost_new < tol * cost:
            done = True
        cost = cost_new
        g = a.T.dot(r)
        optimality = _kkt_optimality(g, on_bound)
    return x
