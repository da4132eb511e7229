"""Linear fits with honest covariance, and stepwise term selection by F-test (METHODS §D.3).

Three covariance treatments, chosen by the data:

- ``allan``: ordinary least squares on consecutive block means (continuous recordings),
  covariance LRV·(XᵀX)⁻¹ with the residuals' long-run variance LRV read from their
  Allan variance: LRV = the largest m·σ²_A(m) over the top three octaves m ≤
  ``lrv_max_rows``, where σ²_A(m) is the overlapping Allan variance of the residuals at m
  rows (for white noise m·σ²_A(m) is the variance at every m; for correlated noise it
  rises to the long-run variance once m exceeds the correlation time; for quantisation
  noise it falls towards its zero long-run variance). The residuals of a thermal model are
  autocorrelated (bias instability, quantisation, misfit, wavelet smoothing), so the
  naive OLS standard errors are 2–4× too small. A lag-window (Newey–West/HAC) estimate
  was tried first and rejected: with slowly varying regressors (powers of H over an
  8-hour run) the residuals lack exactly the low-frequency variance it must see, and in
  simulation its standard uncertainties at the ends of the temperature range came out
  30–80 % too small even for white noise; the Allan variance is a difference statistic,
  barely touched by that projection (``benchmarks/thermal_coverage.py`` measures the
  coverage). LRV·(XᵀX)⁻¹ assumes the regressors vary slowly against the noise's
  correlation time, true for H and, within tens of percent, for Ḣ. p-values come from
  statsmodels OLS with this fixed scale (t with n − p degrees of freedom);
- ``wls``: weighted least squares on soak points with known standard uncertainties
  σ_i: covariance (XᵀWX)⁻¹ scaled by the Birge ratio² χ²/(n − p) when that exceeds 1
  (scatter beyond the stated σ_i is taken as real, never the other way round);
- ``ols``: plain OLS with the residual variance (points without uncertainties, such as
  the paper's published bias table).

Stepwise regression (as MATLAB ``stepwisefit``, which the paper used): repeatedly add
the candidate with the smallest p-value if it is below ``p_enter``, otherwise remove the
model term with the largest p-value if it is above ``p_remove``; stop when neither
applies. For a single term the partial F-test and the t-test give the same p-value
(F = t²). Starting from the full model (``start='full'``) lets terms that only matter
together (a cubic's H and H³ for a non-monotonic curve) survive, which forward entry
from a constant cannot find. Terms that would make the design rank-deficient (exact
collinearity) are never entered. With ``keep_while`` (term → the terms it needs), a term
is not removed while a model term needs it (the marginality principle on main effects: H
stays while H³ or H·Ḣ does; a higher power alone describes a curve pinned flat at the
centre, which no physics asks for). p-values after selection are optimistic (the usual
post-selection caveat); the held-out check and the model error term in the calibrator
(METHODS §D.3, eq. (17g)) account for it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import statsmodels.api as sm

from gyro_calib.errors import ConfigError, InsufficientDataError
from gyro_calib.thermal.allan import allan_long_run_variance

if TYPE_CHECKING:
    import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class LinearFit:
    """A fitted linear model y = b₀ + Σ b_j x_j.

    Attributes:
        terms: names of the x_j (the intercept is not listed).
        coefficients: b₀, b₁, … (intercept first), unit of y per unit of x_j.
        covariance: their covariance matrix (see the module docstring).
        p_values: p-value of each term (same order as ``terms``).
        residuals: y − fit.
        n: rows used. dof: n − number of coefficients.
        covariance_kind: ``allan``, ``wls`` or ``ols``.
        lrv_rows: for ``allan``, the averaging length m (rows) where the long-run
            variance was read (0 otherwise); dof is then about n/m − p.
        birge_ratio: √(χ²/dof) for ``wls`` (1 otherwise).
    """

    terms: tuple[str, ...]
    coefficients: npt.NDArray[np.float64]
    covariance: npt.NDArray[np.float64]
    p_values: npt.NDArray[np.float64]
    residuals: npt.NDArray[np.float64]
    n: int
    dof: int
    covariance_kind: str
    lrv_rows: int = 0
    birge_ratio: float = 1.0

    @property
    def std_uncertainties(self) -> npt.NDArray[np.float64]:
        """Standard uncertainty of each coefficient (intercept first)."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def residual_std(self) -> float:
        """Standard deviation of the residuals (ddof = number of coefficients).

        Over the n rows, not over ``dof``: for the ``allan`` covariance ``dof`` is the
        effective n/m − p of autocorrelated rows, and dividing by it inflated the residual
        std by √(m) (0.34 instead of 0.026 °/h on the paper-like run).
        """
        p = len(self.coefficients)
        return float(math.sqrt(np.sum(self.residuals**2) / max(self.n - p, 1)))


def _design(columns: dict[str, npt.NDArray[np.float64]], terms: Sequence[str],
            n: int) -> npt.NDArray[np.float64]:
    return np.column_stack([np.ones(n)] + [columns[t] for t in terms])


def full_rank(columns: dict[str, npt.NDArray[np.float64]], terms: Sequence[str],
              n: int) -> bool:
    """True if intercept + terms are linearly independent (numerically) on these rows.

    From the eigenvalues of the Gram matrix of the column-normalised design: the smallest
    must exceed 1e-14 of the largest (singular values 1e-7 apart).
    """
    x = _design(columns, terms, n)
    if x.shape[0] < x.shape[1]:
        return False
    x = x / np.maximum(np.sqrt(np.sum(x * x, axis=0)), 1e-300)
    ev = np.linalg.eigvalsh(x.T @ x)
    return bool(ev[0] > 1e-14 * ev[-1])


def fit_linear(y: npt.ArrayLike, columns: dict[str, npt.NDArray[np.float64]],
               terms: Sequence[str], *, sigma: npt.ArrayLike | None = None,
               lrv_max_rows: int = 0) -> LinearFit:
    """Fit intercept + ``terms`` to ``y``.

    Args:
        y: responses.
        columns: candidate columns by term name (same length as y).
        terms: the terms to fit.
        sigma: standard uncertainty of each y (→ ``wls``), or None.
        lrv_max_rows: > 0 → ``allan`` covariance reading the long-run variance up to this
            many rows (ignored when sigma is given); 0 → ``ols``.

    Raises:
        InsufficientDataError: with no degree of freedom left.
    """
    yv = np.asarray(y, np.float64)
    n = len(yv)
    terms = tuple(terms)
    x = _design(columns, terms, n)
    dof = n - x.shape[1]
    if dof < 1:
        raise InsufficientDataError(
            f'{n} point(s) cannot fit {x.shape[1]} coefficient(s) (intercept + '
            f'{", ".join(terms) or "nothing"}) with a degree of freedom to spare.')
    if not full_rank(columns, terms, n):
        raise InsufficientDataError(
            f'the terms {", ".join(terms)} are collinear on these {n} point(s): they cannot '
            'be told apart (too few distinct temperatures or rates).')
    if sigma is not None:
        s = np.asarray(sigma, np.float64)
        if not np.all(np.isfinite(s) & (s > 0)):
            raise InsufficientDataError('a point has no positive finite standard uncertainty.')
        res = sm.WLS(yv, x, weights=1.0 / s**2).fit(method='qr')
        chi2 = float(np.sum((res.resid / s) ** 2))
        birge2 = chi2 / dof
        cov = np.asarray(res.normalized_cov_params) * max(birge2, 1.0)
        return LinearFit(terms, np.asarray(res.params), cov, np.asarray(res.pvalues)[1:],
                         np.asarray(res.resid), n, dof, 'wls', 0, math.sqrt(birge2))
    if lrv_max_rows > 0:
        first = sm.OLS(yv, x).fit(method='qr')
        lrv, m_star = allan_long_run_variance(np.asarray(first.resid), lrv_max_rows)
        res = sm.OLS(yv, x).fit(method='qr', cov_type='fixed scale', cov_kwds={'scale': lrv},
                                use_t=True)
        return LinearFit(terms, np.asarray(res.params), np.asarray(res.cov_params()),
                         np.asarray(res.pvalues)[1:], np.asarray(res.resid), n,
                         max(1, n // m_star - x.shape[1]), 'allan', m_star)
    res = sm.OLS(yv, x).fit(method='qr')
    return LinearFit(terms, np.asarray(res.params), np.asarray(res.cov_params()),
                     np.asarray(res.pvalues)[1:], np.asarray(res.resid), n, dof, 'ols')


@dataclass(frozen=True, slots=True)
class StepwiseStep:
    """One step of the selection.

    Attributes:
        action: ``enter``, ``remove`` or ``skip`` (collinear, never entered).
        term: the term.
        p_value: its p-value at that step (NaN for ``skip``).
    """

    action: str
    term: str
    p_value: float


@dataclass(frozen=True, slots=True)
class StepwiseResult:
    """Terms chosen, the steps taken, and the final fit."""

    terms: tuple[str, ...]
    steps: tuple[StepwiseStep, ...]
    fit: LinearFit


def stepwise(y: npt.ArrayLike, columns: dict[str, npt.NDArray[np.float64]],
             candidates: Sequence[str], *, p_enter: float = 0.05, p_remove: float = 0.10,
             start: str = 'full', sigma: npt.ArrayLike | None = None,
             lrv_max_rows: int = 0, max_steps: int = 100,
             keep_while: Mapping[str, Sequence[str]] | None = None) -> StepwiseResult:
    """Stepwise multiple linear regression with F-test entry and removal.

    Args:
        y: as :func:`fit_linear`.
        columns: as :func:`fit_linear`.
        sigma: as :func:`fit_linear`.
        lrv_max_rows: as :func:`fit_linear`.
        candidates: candidate term names (keys of ``columns``).
        p_enter: a candidate enters if its p-value is below this.
        p_remove: a term leaves if its p-value is above this (must be ≥ p_enter).
        start: ``full`` (all candidates, collinear ones skipped) or ``constant``.
        max_steps: safety limit.
        keep_while: term → terms that are not removed while it is in the model (its main
            effects); the removal step then takes the largest p-value among the others.

    Raises:
        ConfigError: on p_enter > p_remove or an unknown start.
        InsufficientDataError: if not even the intercept can be fitted.
    """
    if not 0 < p_enter <= p_remove < 1:
        raise ConfigError(f'p_enter = {p_enter!r} and p_remove = {p_remove!r} must satisfy '
                          '0 < p_enter <= p_remove < 1 (else terms cycle in and out).')
    if start not in ('full', 'constant'):
        raise ConfigError(f"stepwise start {start!r} is unknown: use 'full' or 'constant'.")
    yv = np.asarray(y, np.float64)
    n = len(yv)
    steps: list[StepwiseStep] = []
    model: list[str] = []
    if start == 'full':
        for term in candidates:
            if full_rank(columns, [*model, term], n) and n - len(model) - 2 >= 1:
                model.append(term)
            else:
                steps.append(StepwiseStep('skip', term, math.nan))
    fit = fit_linear(yv, columns, model, sigma=sigma, lrv_max_rows=lrv_max_rows)
    seen = {frozenset(model)}
    for _ in range(max_steps):
        best: tuple[float, str, LinearFit] | None = None
        for term in candidates:
            if term in model or not full_rank(columns, [*model, term], n):
                continue
            if n - len(model) - 2 < 1:
                continue
            trial = fit_linear(yv, columns, [*model, term], sigma=sigma, lrv_max_rows=lrv_max_rows)
            p = float(trial.p_values[-1])
            if best is None or p < best[0]:
                best = (p, term, trial)
        if best is not None and best[0] < p_enter and frozenset([*model, best[1]]) not in seen:
            model.append(best[1])
            fit = best[2]
            steps.append(StepwiseStep('enter', best[1], best[0]))
            seen.add(frozenset(model))
            continue
        needed = {n for t in model for n in (keep_while or {}).get(t, ()) if n != t}
        removable = [j for j, t in enumerate(model) if t not in needed]
        if removable:
            i = max(removable, key=lambda j: float(fit.p_values[j]))
            p = float(fit.p_values[i])
            reduced = [t for t in model if t != model[i]]
            if p > p_remove and frozenset(reduced) not in seen:
                steps.append(StepwiseStep('remove', model[i], p))
                model = reduced
                fit = fit_linear(yv, columns, model, sigma=sigma, lrv_max_rows=lrv_max_rows)
                seen.add(frozenset(model))
                continue
        break
    return StepwiseResult(tuple(model), tuple(steps), fit)
