"""Least-squares covariance with propagated inputs and Welch–Satterthwaite ν (§G.4).

A fit θ̂ = argmin ‖r(θ; x)‖² with residual-scaled covariance s²(JᵀJ)⁻¹ (s² = RSS/ν, ν
residual degrees of freedom, eq. (7)), plus each input x it took as known with covariance
C_x: first order, dθ = −(JᵀJ)⁻¹Jᵀ(∂r/∂x)dx, so C_θ += G·C_x·Gᵀ with G = −(JᵀJ)⁻¹Jᵀ∂r/∂x
(eq. (8)). An input's error also moves the residuals, by the part of ∂r/∂x·dx the fit
cannot absorb, (I − H)·∂r/∂x·dx (H = J(JᵀJ)⁻¹Jᵀ): that part is already in C_x's term, so its
expected share of the residual sum, tr((I − H)·∂r/∂x·C_x·∂r/∂xᵀ), is taken out of the RSS
before s² is formed (eq. (7a)); without it the inputs were counted twice (the gyro
misalignments about x covered 0.80 and 0.78 within ±1σ over 120 seeds). ν per parameter
from the parts by Welch–Satterthwaite (eq. (9)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Input:
    """An input taken as known by the fit.

    Attributes:
        name: what it is (for the basis line).
        sensitivity: ∂r/∂x (residuals × inputs).
        covariance: C_x.
        dof: ν of C_x (inf: Type B).
    """

    name: str
    sensitivity: Array
    covariance: Array
    dof: float


def fit_covariance(jac: Array, residuals: Array, dof: int,
                   inputs: tuple[Input, ...] = ()) -> tuple[Array, Array, str]:
    """(covariance, ν per parameter, basis) of a least-squares fit (§G eqs. (7)–(9)).

    s² = (RSS − Σ_x tr((I − H)·S_x·C_x·S_xᵀ))/ν, at least 0 (eq. (7a)): the residual scatter
    the propagated inputs do not already explain. When their expected share reaches the RSS the
    basis says so (the u then rests on the propagated inputs alone).
    """
    jtj_inv = np.linalg.pinv(jac.T @ jac)
    rss = float(residuals @ residuals)
    explained = 0.0
    input_parts = []
    for inp in inputs:
        g = -jtj_inv @ jac.T @ inp.sensitivity
        input_parts.append((g @ inp.covariance @ g.T, inp.dof))
        left = inp.sensitivity + jac @ g  # (I − H)·S_x
        explained += float(np.sum((left @ inp.covariance) * left))  # tr(left·C_x·leftᵀ)
    s2 = max(rss - explained, 0.0) / max(dof, 1)
    parts = [(s2 * jtj_inv, float(dof)), *input_parts]
    cov = sum((c for c, _ in parts), np.zeros_like(jtj_inv))
    var = np.diag(cov)
    denom = sum((np.diag(c) ** 2 / nu for c, nu in parts if math.isfinite(nu)),
                np.zeros(len(var)))
    with np.errstate(divide='ignore'):
        nu_eff = np.where(denom > 0, var ** 2 / np.where(denom > 0, denom, 1.0), np.inf)
    over = inputs and explained >= rss  # eq. (7a) leaves nothing: say so, never silently
    basis = (f'residual scatter s = {math.sqrt(s2):.3g} over ν = {dof}'
             + (f' (the propagated inputs\' expected share, {explained / rss:.0%} of the '
                'residual sum, exceeds it: the residual term is 0 and u rests on the '
                'propagated inputs alone)' if over and rss > 0 else
                ' (the residual sum is 0: the residual term is 0)' if over else
                f' ({explained / rss:.0%} of the residual sum, the propagated inputs\' '
                'expected share, taken out)' if inputs and rss > 0 else '')
             + ''.join(f'; {inp.name} propagated' for inp in inputs))
    return (np.asarray(0.5 * (cov + cov.T), dtype=np.float64),
            np.asarray(nu_eff, dtype=np.float64), basis)


def condition_number(jac: Array) -> tuple[float, Array]:
    """cond(JᵀJ) of the column-normalised Jacobian and its weakest eigenvector (§G.5)."""
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    jn = jac / norms
    w, v = np.linalg.eigh(jn.T @ jn)
    return float(w[-1] / max(w[0], 1e-300)), np.asarray(v[:, 0], dtype=np.float64)


def weakest(names: tuple[str, ...], jac: Array, std: Array) -> str:
    """The conditioning statement (§G.5).

    cond(JᵀJ) of the column-normalised Jacobian and the parameter the weakest direction
    loads on most.
    """
    cond, v = condition_number(jac)
    i = int(np.argmax(np.abs(v)))
    return (f'cond(JᵀJ) = {cond:.3g} (columns normalised); weakest direction mostly '
            f'{names[i]} (u = {std[i]:.3g})')
