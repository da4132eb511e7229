"""Least squares of the output on the known regressors, reduced block by block (METHODS §C).

Model of the cumulative count over one block (pulses), table along case axis n:

    N(τ) = c₀ + c₁·τ + Σ_h [table line h·Ω_z] + [dither line Ω_d]
           + β_in·G_in(τ) + β_quad·G_quad(τ) + noise

    G_in(τ)   = ∫ω_T(τ)·φ_p(τ) dτ          (φ_p the fitted dither line, pulses)
    G_quad(τ) = ∫ω_T(τ)·φ̇_p(τ)/Ω_d dτ      (the same line advanced by 90°)

with ω_T the fitted table rate. The small-angle physics of METHODS §C gives
β_in = +a·sin ψ₀/cos a along Z and −a·cos ψ₀/cos a along Y (kinematics sign convention in
``sim_nodes.dither.kinematics``); transverse rocking in phase with the dither adds to β_in,
rocking in quadrature appears in β_quad. G_in and G_quad are computed in closed form (the
product of two sums of sinusoids integrates term by term), so no numerical integration of
a 400 Hz product sampled at 2 kHz is involved.

The per-block nuisance terms (offset, slope, table lines, dither line) are projected out of
both the count and the two regressors (QR); only the 2×2 reduced normal matrix, the reduced
right-hand side and the residual sum of squares are kept. Summing them over blocks is
exactly the least squares of the whole record with per-block nuisance parameters, so memory
stays bounded however long the record is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.dither.lines import DitherLineFit, TableFit

    FloatArray = npt.NDArray[np.float64]


class _Exponentials:
    """e^{iωτ} for the frequencies the regressors need, each computed once per block."""

    def __init__(self, tau_s: FloatArray) -> None:
        self.tau_s = tau_s
        self._cache: dict[float, npt.NDArray[np.complex128]] = {}

    def __call__(self, w: float) -> npt.NDArray[np.complex128]:
        """e^{i·w·τ}."""
        if w not in self._cache:
            self._cache[w] = np.exp(1j * w * self.tau_s)
        return self._cache[w]


def _integrated_products(exps: _Exponentials, nu: FloatArray, w_h: npt.NDArray[np.complex128],
                         p: complex, wd: float, drift_rad_s: float) -> FloatArray:
    """∫ Re(Σ W_h·e^{iν_hτ} + c₁)·Re(P·e^{iΩ_dτ}) dτ in closed form (no constant term).

    Re(W·e^{iντ})·Re(P·e^{iΩτ}) = ½·Re(W·P·e^{i(ν+Ω)τ} + W·P̄·e^{i(ν−Ω)τ}), term by term.
    """
    e_d = exps(wd)
    g = drift_rad_s * p / (1j * wd) * e_d
    for nu_h, w in zip(nu, w_h):
        e_h = exps(float(nu_h))
        up, down = nu_h + wd, nu_h - wd
        g = g + (0.5 * w * p / (1j * up)) * (e_h * e_d)
        if abs(down) > 1e-12:
            g = g + (0.5 * w * np.conj(p) / (1j * down)) * (e_h * np.conj(e_d))
    return g.real


def sideband_regressors(tau_s: FloatArray, dither: DitherLineFit,
                        table: TableFit) -> tuple[FloatArray, FloatArray]:
    """(G_in, G_quad) at ``tau_s`` in closed form, pulses·rad (module docstring).

    The fitted table rate (all harmonics and the drift c₁) times the fitted dither line,
    integrated term by term; G_quad uses the dither line advanced by 90° (phasor i·P).
    """
    wd = dither.angular_frequency_rad_s
    nu, w_h = table.rate_phasors_rad_s()
    p = dither.phasor_pulses
    exps = _Exponentials(tau_s)
    return (_integrated_products(exps, nu, w_h, p, wd, table.drift_rad_s),
            _integrated_products(exps, nu, w_h, 1j * p, wd, table.drift_rad_s))


def null_sideband_regressors(tau_s: FloatArray, dither: DitherLineFit, table: TableFit,
                             multiples: tuple[int, ...]) -> FloatArray:
    """Null regressors: the sideband regressors with the table fundamental moved to h·Ω_z.

    No physics puts a line at Ω_d ± h·Ω_z for h beyond the table harmonics carried, but
    noise that is not white there — pulse quantisation locked to the dither, the table and
    the sample clock — piles up on these frequencies as on Ω_d ± Ω_z. Their coefficients,
    normalised by their white-noise σ, have unit variance only if the white model holds
    (the null-sideband test in :meth:`ReducedNormalEquations.solve`). Returns n × 2·len(multiples)
    columns (in-phase, quadrature for each h).
    """
    wd = dither.angular_frequency_rad_s
    nu, w_h = table.rate_phasors_rad_s()
    exps = _Exponentials(tau_s)
    cols = []
    for h in multiples:
        nu_h, w = np.array([h * nu[0]]), np.array([w_h[0]])
        for p in (dither.phasor_pulses, 1j * dither.phasor_pulses):
            cols.append(_integrated_products(exps, nu_h, w, p, wd, 0.0))
    return np.column_stack(cols) if cols else np.zeros((len(tau_s), 0))


def choose_null_multiples(dither_hz: float, table_hz: float, sample_rate_hz: float, *,
                          harmonics: int, separation_hz: float, count: int = 8) -> tuple[int, ...]:
    """Up to ``count`` multiples h > H whose Ω_d ± h·Ω_z lie clear of every modelled line.

    Clear means: inside (separation, Nyquist − separation) and at least ``separation`` from
    zero, the dither line and its harmonic, the table lines and the true sidebands Ω_d ± h'·Ω_z
    (h' ≤ H).
    """
    lines = [0.0, dither_hz, 2 * dither_hz]
    lines += [h * table_hz for h in range(1, harmonics + 1)]
    lines += [dither_hz + s * h * table_hz for h in range(1, harmonics + 1) for s in (-1, 1)]
    nyquist = sample_rate_hz / 2
    out: list[int] = []
    h = harmonics + 1
    while len(out) < count and h <= harmonics + 4 * count:
        freqs = (dither_hz - h * table_hz, dither_hz + h * table_hz)
        ok = all(separation_hz < f < nyquist - separation_hz for f in freqs)
        ok = ok and all(abs(f - line) >= separation_hz for f in freqs for line in lines)
        if ok:
            out.append(h)
        h += 1
    return tuple(out)


@dataclass(frozen=True, slots=True)
class BlockReduction:
    """One block's contribution to the reduced normal equations.

    Attributes:
        normal: Xᵀ(I − P_Z)X for X = [G_in, G_quad, null regressors…] (k × k).
        rhs: Xᵀ(I − P_Z)y (k).
        rss_nuisance: yᵀ(I − P_Z)y, the residual after the nuisance terms alone.
        n_samples: samples in the block.
        n_nuisance: nuisance parameters fitted in the block.
    """

    normal: FloatArray
    rhs: FloatArray
    rss_nuisance: float
    n_samples: int
    n_nuisance: int

    def solve(self) -> FloatArray:
        """This block's own β (β_in, β_quad, then any null coefficients)."""
        return np.asarray(np.linalg.solve(self.normal, self.rhs), dtype=np.float64)


def reduce_block(counts: FloatArray, nuisance: FloatArray, regressors: FloatArray) -> tuple[
        BlockReduction, FloatArray]:
    """Project the nuisance columns out of count and regressors; return the reduction.

    Schur complement of the scaled Gram matrix of [nuisance | regressors | count]: the same
    numbers as a QR projection for these well-conditioned columns, at a fraction of the
    cost. Pass as ``counts`` the residual of the dither-line fit (already free of the
    nuisance terms) so that no large line cancels in the sums.

    Also returns the residual of the count after nuisance *and* regressors with this block's
    own β (for plots); the whole-record β differs from it only by noise.
    """
    a = np.column_stack((nuisance, regressors, counts))
    # einsum, not BLAS: a 4000 × 30 Gram is too small for threads, which only contend
    # on a busy machine (measured 0.6 ms idle, up to 100 ms under load, against 2.5 ms)
    gram = np.einsum('ij,ik->jk', a, a)
    p = nuisance.shape[1]
    gzz, gzr = gram[:p, :p], gram[:p, p:]
    zs = np.sqrt(np.diag(gzz))
    solved = np.linalg.solve(gzz / np.outer(zs, zs), gzr / zs[:, None]) / zs[:, None]
    reduced = gram[p:, p:] - gzr.T @ solved
    k = regressors.shape[1]
    normal, rhs, rss = reduced[:k, :k], reduced[:k, k], float(reduced[k, k])
    beta = np.linalg.solve(normal, rhs)
    coef_z = solved[:, k] - solved[:, :k] @ beta
    residual = counts - nuisance @ coef_z - regressors @ beta
    return BlockReduction(normal, rhs, rss, len(counts), p), residual


@dataclass(slots=True)
class ReducedNormalEquations:
    """Sum of block reductions: the whole-record least squares in O(1) memory."""

    normal: FloatArray | None = None
    rhs: FloatArray | None = None
    rss_nuisance: float = 0.0
    n_samples: int = 0
    n_parameters: int = 0
    n_blocks: int = 0
    block_chi2_terms: float = 0.0

    def add(self, block: BlockReduction) -> None:
        """Accumulate one block (all blocks must carry the same regressors)."""
        if self.normal is None or self.rhs is None:
            self.normal, self.rhs = block.normal.copy(), block.rhs.copy()
        else:
            self.normal = self.normal + block.normal
            self.rhs = self.rhs + block.rhs
        self.rss_nuisance += block.rss_nuisance
        self.n_samples += block.n_samples
        self.n_parameters += block.n_nuisance
        self.n_blocks += 1
        self.block_chi2_terms += float(block.rhs @ np.linalg.solve(block.normal, block.rhs))

    def solve(self) -> SidebandSolution:
        """β = N⁻¹·b with covariance σ̂²·N⁻¹ from the residuals (σ̂² = RSS/dof).

        Two checks of the white-noise model widen the covariance when it fails, by
        max(1, R_B², F²):

        * R_B², the Birge ratio: scatter of the per-block β about the common β against their
          own covariance (noise that varies from block to block);
        * F², the null-sideband ratio: mean of β_null²/var(β_null) over the null regressors
          (:func:`null_sideband_regressors`) — noise that is coherent over the whole record
          at the sideband frequencies, which no block scatter can show.
        """
        if self.normal is None or self.rhs is None:
            raise ValueError('no block accumulated')
        k = len(self.rhs)
        beta = np.asarray(np.linalg.solve(self.normal, self.rhs), dtype=np.float64)
        rss = max(self.rss_nuisance - float(self.rhs @ beta), 0.0)
        dof = self.n_samples - self.n_parameters - k
        sigma2 = rss / dof if dof > 0 else math.nan
        inv = np.linalg.inv(self.normal)
        # Σ_b β_bᵀN_bβ_b − βᵀNβ: χ² of the block estimates about the common β (in σ² units)
        chi2 = max(self.block_chi2_terms - float(self.rhs @ beta), 0.0)
        dof_blocks = k * (self.n_blocks - 1)
        birge2 = chi2 / sigma2 / dof_blocks if dof_blocks > 0 and sigma2 > 0 else math.nan
        n_null = k - 2
        if n_null > 0 and sigma2 > 0:
            null2 = float(np.mean(beta[2:] ** 2 / (sigma2 * np.diag(inv)[2:])))
        else:
            null2 = math.nan
        inflate = max([1.0] + [x for x in (birge2, null2) if math.isfinite(x)])
        cov = np.asarray(sigma2 * inflate * inv[:2, :2], dtype=np.float64)
        return SidebandSolution(beta[:2], cov, sigma2, dof, birge2, self.n_blocks,
                                self.n_samples, null2, n_null, inflate)


@dataclass(frozen=True, slots=True)
class SidebandSolution:
    """Whole-record (β_in, β_quad) of one orientation.

    Attributes:
        beta: (β_in, β_quad), rad.
        covariance: their covariance, rad².
        residual_variance_pulses2: σ̂², pulses².
        dof: residual degrees of freedom.
        birge_ratio_squared: block scatter / white-noise prediction (≈ 1 when the white
            model holds; NaN with one block).
        n_blocks: blocks used.
        n_samples: samples used.
        null_ratio_squared: F², mean squared normalised null-sideband coefficient (≈ 1 when
            the noise at the sidebands is white; NaN without null regressors).
        n_null: number of null regressors.
        inflation: the factor max(1, R_B², F²) the white-noise covariance was widened by.
    """

    beta: FloatArray
    covariance: FloatArray
    residual_variance_pulses2: float
    dof: int
    birge_ratio_squared: float
    n_blocks: int
    n_samples: int
    null_ratio_squared: float = math.nan
    n_null: int = 0
    inflation: float = 1.0
