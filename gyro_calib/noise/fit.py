"""Noise terms by a joint weighted least-squares fit to the Allan variance (IEEE 952 Annex C).

Model (IEEE Std 952-1997 Annex C, linear in θ = (Q², N², B², K², R²))::

    AVAR(τ) = 3Q²/τ² + N²/τ + (2 ln 2/π)·B² + K²τ/3 + R²τ²/2

Estimator:

1. Weighted least squares with θ ≥ 0 (``scipy.optimize.lsq_linear``, bounded), weights
   1/Var(AVAR̂_k) with Var = 2·noise_k²/EDF_k (+ a ramp–noise cross term) from the model's
   random part (Q, N, B, K) — the model, not the noisy estimate, so the weights do not
   bias the fit low; the deterministic ramp adds almost no variance (the noise mean
   telescopes). Iterated to a fixed point (IRLS). The EDF at each τ is that of the noise
   type the random part's local slope says dominates there (:mod:`gyro_calib.noise.edf`).
2. Uncertainty: the sandwich covariance (AᵀWA)⁻¹AᵀW·C·WA(AᵀWA)⁻¹, with C the full
   covariance of the AVAR estimates — EDF variances and the correlation between τ points
   from the fitted noise model (:mod:`gyro_calib.noise.covariance`). Correlated τ points
   are therefore not counted as independent evidence. If the residuals are grossly larger
   than that covariance predicts (weighted χ² above its expectation by more than three
   standard deviations: the model does not describe the curve), the covariance is scaled
   by the ratio.
3. Which terms: N, B and K always stay in the model, reported or not — dropping a real
   but unresolved term and refitting biases its neighbours (in a Monte Carlo, dropping an
   unresolved K read B 1.6σ high on average; keeping it gives 73 %/95 % coverage). The edge
   terms Q and R, whose usual value is none, are taken out of the model when below
   ``edge_significance`` (Q, 3σ) or ``ramp_significance`` (R, 5σ: see its argument) and
   the rest refitted. On a pulse count (``context='pulses'``) Q stays in the model and its
   covariance even at the bound 0: the whole-pulse rounding is there by construction, and
   dropping it gave N its share and halved u(N) (METHODS §E.3). A term is reported when
   θ_k ≥ ``min_significance``·σ(θ_k) (2σ; Q 3σ, R 5σ). Each unreported term is absent
   with a reason naming the slope it would show, its fitted θ ± σ and a 2σ upper bound.
   Terms reported near the threshold read high on average (selection: they are reported
   because they came out high).

Coefficients are √θ with standard uncertainty σ(θ)/(2√θ).

Reading single points instead (N = σ(1 s), B = min σ/0.664, K = σ(3 s)) is biased where
the terms overlap — min σ/0.664 includes the N and K contributions at the minimum and
reads B high (about 20 % when N and K cross near the plateau); ``test_noise_fit.py``
shows both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Estimate
from gyro_calib.noise.covariance import allan_correlation
from gyro_calib.noise.edf import alpha_from_slope
from gyro_calib.noise.terms import AVAR_EXPONENT, SYMBOLS, avar_basis

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.noise.curve import AllanCurve
    from gyro_calib.noise.terms import TermUnits

    FloatArray = npt.NDArray[np.float64]

MAX_ITERATIONS = 40
BAND_MARGIN_POINTS = 2
"""Points left out beyond where the band-limited misfit stops being significant."""
BAND_MIN_DEPARTURE = 2.0
"""Standard deviations the shortest τ must lie off the model for a band-limited range."""


@dataclass(frozen=True, slots=True)
class NoiseFit:
    """The joint fit of one axis's Allan variance.

    Attributes:
        estimates: term key → coefficient estimate (SI unit of the key), resolved terms only.
        missing: term key → why it is not reported (a whole sentence).
        theta: (Q², N², B², K², R²) of the final model (0 for removed terms).
        theta_cov: covariance of theta (5 × 5). Terms fitted at the bound 0 carry their
            unconstrained variance on the diagonal only; terms out of the model are 0.
        alpha: noise type used for the EDF at each curve point.
        edf: EDF at each curve point (for error bars).
        used: mask of curve points in the fit.
        chi2_ratio: weighted χ² of the residuals / its expectation under the model.
        covariance_scale: factor applied to the covariance for misfit (1 = none).
    """

    estimates: dict[str, Estimate]
    missing: dict[str, str]
    theta: FloatArray
    theta_cov: FloatArray
    alpha: npt.NDArray[np.int64]
    edf: FloatArray
    used: npt.NDArray[np.bool_]
    chi2_ratio: float = math.nan
    covariance_scale: float = 1.0
    symbols_resolved: tuple[str, ...] = field(default=())
    upper_bounds: dict[str, float] = field(default_factory=dict)
    """term key → 2σ upper bound √(θ + 2σ(θ)) of each term not reported (from the last fit
    it was in), SI unit of the key; the bound its reason quotes."""
    tau_ranges: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    """term key → (τ_min, τ_max, largest share) of the fitted τ where the reported term
    carries at least half of the model's AVAR (else at least a tenth; else the τ of its
    largest share): the τ range its value rests on, s."""
    notes: tuple[str, ...] = ()
    """What the fit left out and why (band-limited short τ, few clusters, misfit)."""
    band_limited_below_s: float = 0.0
    """Shortest τ kept when a short-τ range departing from the model was left out, s
    (0: nothing left out)."""

    def json_record(self, curve: AllanCurve) -> dict[str, object]:
        """The fit as JSON: fitted τ range, χ², scaling, each term's τ range, notes."""
        tau = curve.tau_s[self.used]
        return {
            'tau_min_s': float(tau[0]) if len(tau) else None,
            'tau_max_s': float(tau[-1]) if len(tau) else None,
            'points': int(np.count_nonzero(self.used)),
            'chi2_reduced': (float(self.chi2_ratio) if math.isfinite(self.chi2_ratio)
                             else None),
            'uncertainty_scale': float(math.sqrt(self.covariance_scale)),
            'band_limited_below_s': float(self.band_limited_below_s),
            'term_tau_ranges_s': {k: {'tau_min_s': v[0], 'tau_max_s': v[1],
                                      'largest_share': v[2]}
                                  for k, v in self.tau_ranges.items()},
            'notes': list(self.notes)}

    def model_avar(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Fitted AVAR at τ, rate unit²."""
        return avar_basis(np.atleast_1d(np.asarray(tau_s, dtype=np.float64))) @ self.theta

    def term_avar(self, tau_s: npt.ArrayLike) -> FloatArray:
        """Each term's AVAR at τ (len(τ) × 5)."""
        return avar_basis(np.atleast_1d(np.asarray(tau_s, dtype=np.float64))) * self.theta


def _model_slope(theta: FloatArray, tau: FloatArray) -> FloatArray:
    parts = avar_basis(tau) * theta
    total = parts.sum(axis=1)
    with np.errstate(invalid='ignore', divide='ignore'):
        mu = (parts * AVAR_EXPONENT).sum(axis=1) / total
    return np.where(total > 0, mu, -1.0)


@dataclass(slots=True)
class _Solution:
    theta: FloatArray
    cov: FloatArray
    alpha: npt.NDArray[np.int64]
    edf: FloatArray
    chi2_ratio: float
    scale: float
    z: FloatArray = field(default_factory=lambda: np.zeros(0))
    """standardised residuals (AVAR̂ − model)/sd at the fitted points."""
    misfit: bool = False
    """χ² above its expectation by more than three standard deviations."""
    cov_statistical: FloatArray = field(default_factory=lambda: np.zeros((5, 5)))
    """the covariance before the misfit scaling."""


def _solve(curve: AllanCurve, used: npt.NDArray[np.bool_], active: list[int],
           pinned: tuple[int, ...] = ()) -> _Solution:
    """IRLS fit (8) and sandwich covariance (9) of the terms ``active``.

    A term held at the bound 0 leaves the covariance of the others, unless it is ``pinned``
    (present by construction, §E.3: Q of a pulse count): then the others keep the
    uncertainty of the model that has it.
    """
    from scipy.optimize import lsq_linear  # imported on use: keeps the core import fast

    tau = curve.tau_s[used]
    y = curve.avar[used]
    basis = avar_basis(tau)
    a = basis[:, active]
    noise, ramp = y.copy(), np.zeros(len(tau))
    alpha = np.zeros(len(tau), dtype=np.int64)
    theta_a = np.zeros(len(active))
    lag_ratio = curve.m[used] / np.maximum(curve.span[used], 1.0)
    for _ in range(MAX_ITERATIONS):
        sd = _estimate_sd(noise, ramp, _edf_at(curve, used, alpha), lag_ratio)
        aw = a / sd[:, None]
        yw = y / sd
        col = np.linalg.norm(aw, axis=0)
        col = np.where(col > 0, col, 1.0)
        res = lsq_linear(aw / col, yw, bounds=(0.0, np.inf), method='bvls')
        new = res.x / col
        converged = np.all(np.abs(new - theta_a) <= 1e-9 * np.maximum(np.abs(new), 1e-300))
        theta_a = new
        full = np.zeros(5)
        full[active] = theta_a
        if np.all(basis @ full <= 0):
            break
        random_part = full.copy()
        random_part[4] = 0.0
        noise = basis @ random_part
        ramp = basis[:, 4] * full[4]
        alpha = alpha_from_slope(_model_slope(random_part, tau))
        if converged:
            break
    theta = np.zeros(5)
    theta[active] = theta_a
    edf = _edf_at(curve, used, alpha)
    sd = _estimate_sd(noise, ramp, edf, lag_ratio)
    aw = a / sd[:, None]
    free = (theta_a > 0) | np.isin(np.asarray(active), pinned)
    cov = np.zeros((5, 5))
    chi2_ratio, scale = math.nan, 1.0
    if np.any(free):
        af = aw[:, free]
        rho = allan_correlation(curve.m[used], curve.span[used], curve.tau0_s, theta[:4])
        try:
            bread = np.linalg.inv(af.T @ af)
        except np.linalg.LinAlgError:
            bread = np.linalg.pinv(af.T @ af)
        proj = bread @ af.T
        cov_f = proj @ rho @ proj.T
        resid = (y - basis @ theta) / sd
        hat = np.eye(len(tau)) - af @ proj
        prh = hat @ rho @ hat.T
        expected = float(np.trace(prh))
        spread = math.sqrt(2.0 * float(np.sum(prh * prh)))
        chi2 = float(resid @ resid)
        if expected > 0:
            chi2_ratio = chi2 / expected
            if chi2 > expected + 3.0 * spread:
                scale = chi2_ratio
        idx = np.asarray(active)[free]
        cov[np.ix_(idx, idx)] = cov_f * scale
    if not np.all(free):
        # terms held at the bound 0: their unconstrained variance (diagonal only), so a
        # reason and a Kalibr file can quote an upper bound
        bread_all = np.linalg.pinv(aw.T @ aw)
        if np.any(free):
            rho_all = rho
        else:
            rho_all = allan_correlation(curve.m[used], curve.span[used], curve.tau0_s,
                                        theta[:4])
        proj_all = bread_all @ aw.T
        var_all = np.diag(proj_all @ rho_all @ proj_all.T) * scale
        for j, k in enumerate(active):
            if not free[j]:
                cov[k, k] = max(float(var_all[j]), 0.0)
    cov_stat = cov / scale
    z = (y - basis @ theta) / sd
    return _Solution(theta, cov, alpha, edf, chi2_ratio, scale, z, scale > 1.0, cov_stat)


def _estimate_sd(noise: FloatArray, ramp: FloatArray, edf: FloatArray,
                 lag_ratio: FloatArray) -> FloatArray:
    """Standard deviation of each AVAR estimate: its random part and the ramp cross term.

    An estimate is the mean of (d + e_i)² with d the deterministic ramp's second difference
    and e_i the noise's: Var = 2·noise²/EDF + 4d²·Var(ē)/(2τ²)². The noise mean ē
    telescopes to the record's ends; for white FM that gives (8/3)·(m/L)²·ramp·noise
    (L = N − 2m), used for every noise type. A ramp alone (no noise) gets a tiny floor.
    """
    var = 2.0 * noise**2 / edf + (8.0 / 3.0) * lag_ratio**2 * ramp * np.maximum(noise, 0.0)
    total = noise + ramp
    return np.sqrt(np.maximum(var, (1e-9 * np.maximum(total, 1e-300)) ** 2))


def _edf_at(curve: AllanCurve, used: npt.NDArray[np.bool_],
            alpha: npt.NDArray[np.int64]) -> FloatArray:
    full_alpha = np.zeros(len(curve), dtype=np.int64)
    full_alpha[used] = alpha
    return curve.edf(full_alpha)[used]


def _fmt(v: float) -> str:
    return f'{v:.3g}'


def _upper_bound(theta: float, sigma: float) -> float:
    """2σ upper bound of a coefficient from its squared estimate θ ± σ: √(θ + 2σ)."""
    return math.sqrt(max(theta, 0.0) + 2.0 * sigma) if sigma > 0 else math.sqrt(max(theta, 0.0))


def _reason(symbol: str, units: TermUnits, theta: float, sigma: float, tau_max_s: float,
            tau_min_s: float, threshold: float, context: str) -> str:
    k = SYMBOLS.index(symbol)
    name, unit = units.names[k], units.si_units[k]
    upper = _upper_bound(theta, sigma)
    fitted = (f'the joint fit gives {symbol}² = {_fmt(theta)} ± {_fmt(sigma)} ({unit})², '
              f'less than {threshold:g} standard uncertainties from zero, so {symbol} < '
              f'{_fmt(upper)} {unit} (2σ upper bound)')
    where = {
        'Q': (f'no −1 slope at short τ (from {_fmt(tau_min_s)} s) is resolved'),
        'N': 'no −½ slope is resolved',
        'B': 'no flat region between the −½ and +½ slopes is resolved',
        'K': (f'no +½ slope is resolved within τ ≤ {_fmt(tau_max_s)} s; a longer record '
              f'would show it if it is there'),
        'R': (f'no +1 slope is resolved within τ ≤ {_fmt(tau_max_s)} s; a rate ramp needs '
              f'records long against the rate random walk'),
    }[symbol]
    text = f'{name} is not reported: {where}; {fitted}.'
    if symbol == 'Q' and context == 'pulses':
        text += (' An RLG shows quantisation only while its sub-pulse phase moves (rotation '
                 'or dither); a static, locked-in RLG shows no −1 slope, and none is fitted.')
    return text


def _more_taus(tau_list: tuple[float, ...] | None, min_points: int) -> str:
    """What gives more usable τ: a longer record, or (a fixed list) the setting ``taus``."""
    if tau_list is None:
        return 'a longer record gives more'
    listed = ', '.join(f'{t:g}' for t in tau_list)
    if len(tau_list) < min_points:
        return (f'the setting taus (--taus) lists only {len(tau_list)} averaging time(s) '
                f'({listed} s), so no record can give a term: list at least {min_points} τ '
                'within the record, or use a named grid (default)')
    return (f'the setting taus (--taus) lists {len(tau_list)} averaging times ({listed} s): '
            'list more within the record, use a named grid (default), or record longer')


def fit_noise_terms(curve: AllanCurve, units: TermUnits, *, min_significance: float = 2.0,
                    edge_significance: float = 3.0, ramp_significance: float = 5.0,
                    min_tau_s: float = 0.0,
                    max_tau_s: float = math.inf,
                    terms: tuple[str, ...] = SYMBOLS, context: str = '',
                    eliminate_edges: bool = True, min_clusters: float = 10.0,
                    exclude_band_limited: bool = True, min_points: int = 8,
                    tau_list: tuple[float, ...] | None = None) -> NoiseFit:
    """Fit the five IEEE 952 terms jointly to one axis's Allan variance (module docstring).

    Args:
        curve: the pooled Allan variance of the axis.
        units: keys and units of the axis (gyro or accelerometer).
        min_significance: θ/σ(θ) a term needs to be reported.
        edge_significance: θ/σ(θ) quantisation Q needs to stay in the model (below it Q is
            taken out and the rest refitted: its usual value is none).
        ramp_significance: the same for the rate ramp R. Its +1 slope rests on the last few
            points, whose estimates are χ²-skewed (few EDF), so a Gaussian 3σ is not 3σ
            there: at 3 a Monte Carlo of 1-hour IMU records without a ramp reported one in
            6 % of them.
        min_tau_s: leave out shorter τ (e.g. where a sensor's anti-alias filter bends the
            white-noise line), s.
        max_tau_s: leave out longer τ, s.
        terms: symbols of the terms to fit (others are absent with a reason).
        context: 'pulses' for an RLG pulse stream (adds the lock-in note to Q's reason).
        eliminate_edges: take Q and R out of the model when below their thresholds.
        min_clusters: leave out τ with fewer non-overlapping clusters T/τ than this (their
            estimates are few and χ²-skewed).
        min_points: fewest fitted τ points for any term (fewer: every term absent, with the
            reason): below it a band-limited or otherwise unmodelled curve cannot be told
            from the terms' slopes.
        tau_list: the τ list of the setting ``taus`` when the grid is a fixed list (None for
            a named grid): too few usable τ then name the setting, not the record length.
        exclude_band_limited: leave out the short-τ range where the curve departs from the
            model (a sensor's anti-alias/decimation filter bends the white-noise line):
            while the fit's χ² exceeds its expectation by 3 standard deviations, the
            shortest fitted τ is left out and the fit repeated, then two more points (at
            most half the points in all).

    Returns:
        The fit; ``estimates`` is empty (every key in ``missing``) when nothing resolves.
    """
    used = ((curve.tau_s >= min_tau_s) & (curve.tau_s <= max_tau_s)
            & np.isfinite(curve.avar) & (curve.avar > 0))
    notes: list[str] = []
    if curve.clusters is not None and min_clusters > 0:
        few = used & (curve.clusters < min_clusters)
        if np.any(few):
            notes.append(f'{int(np.count_nonzero(few))} τ point(s) from '
                         f'{_fmt(float(curve.tau_s[few][0]))} s have fewer than '
                         f'{min_clusters:g} clusters (T/τ) and are left out of the term fit '
                         f'(shown in the curve).')
            used &= ~few
    band_below, band_low = 0.0, False
    if exclude_band_limited:
        used, band_below, note = _exclude_band_limited(curve, used, terms)
        band_low = 'lies' in note and 'below it' in note
        if note:
            notes.append(note)
    keys = dict(zip(SYMBOLS, units.keys))
    missing: dict[str, str] = {}
    empty = NoiseFit({}, {}, np.zeros(5), np.zeros((5, 5)), np.zeros(len(curve), dtype=np.int64),
                     curve.edf(0), used)
    for s in SYMBOLS:
        if s not in terms:
            missing[keys[s]] = f'{units.names[SYMBOLS.index(s)]} was not asked for.'
    n_used = int(np.count_nonzero(used))
    if n_used < min_points:
        why = (f'the Allan variance has {n_used} usable averaging time(s) (with at least '
               f'{min_clusters:g} clusters, in the fitted τ range), fewer than the '
               f'{min_points} needed to fit noise terms and still check that the model '
               f'describes the curve; {_more_taus(tau_list, min_points)}.')
        for s in SYMBOLS:
            missing.setdefault(keys[s], f'{units.names[SYMBOLS.index(s)]} is not reported: {why}')
        return NoiseFit({}, missing, empty.theta, empty.theta_cov, empty.alpha, empty.edf, used,
                        notes=tuple(notes))
    tau_used = curve.tau_s[used]
    active = [SYMBOLS.index(s) for s in SYMBOLS if s in terms]
    pinned = (SYMBOLS.index('Q'),) if context == 'pulses' else ()
    # at most as many terms as points less two: two degrees of freedom left to see whether
    # the model describes the curve (the terms left out are named in a note)
    cut: list[str] = []
    model_var = np.zeros(5)
    size = max(n_used - 2, 1)
    if len(active) > size:
        # the terms kept are those that describe the curve best (smallest χ²), not a fixed
        # few: a strong random walk must not be read as bias instability
        import itertools

        best: tuple[float, list[int]] | None = None
        trials = []
        for combo in itertools.combinations(active, size):
            trial = _solve(curve, used, list(combo), pinned)
            chi2 = float(trial.z @ trial.z)
            trials.append(trial)
            if best is None or chi2 < best[0]:
                best = (chi2, list(combo))
                chosen = trial
        assert best is not None
        cut = [SYMBOLS[k] for k in active if k not in best[1]]
        active = best[1]
        # other term sets that describe the curve as well: the spread of each term over
        # them is model uncertainty, added to its variance (the curve cannot tell them
        # apart, so a term that only one of them needs is not claimed)
        for trial in trials:
            if not trial.misfit:
                model_var = np.maximum(model_var, (trial.theta - chosen.theta) ** 2)
    if cut:
        notes.append(f'only {n_used} τ point(s) to fit: {", ".join(cut)} left out of the model '
                     '(two degrees of freedom are kept to check it; the terms kept describe '
                     'the curve best).')
    last: dict[int, tuple[float, float]] = {}
    # a pulse count is whole pulses: its rounding (Q) is there by construction whenever the
    # phase moves, so Q stays in the model as N, B and K do (§E.3); dropping an unresolved
    # real Q gives N its share and halves u(N) (benchmarks/noise_pulse_coverage.py)
    edge_terms = ('R',) if context == 'pulses' else ('Q', 'R')
    edges = [k for k in (SYMBOLS.index(s) for s in edge_terms) if k in active]
    thresholds = [edge_significance, min_significance, min_significance, min_significance,
                  ramp_significance]
    if not eliminate_edges:
        thresholds = [min_significance] * 5
    sol = None
    for _ in range(2):
        sol = _solve(curve, used, active, pinned)
        if np.any(model_var > 0):
            sol.cov = sol.cov + np.diag(model_var)
            sol.cov_statistical = sol.cov_statistical + np.diag(model_var)
        # significance from the statistical covariance: a misfit widens the reported
        # uncertainty (by the χ² ratio), it does not make a term vanish
        sigma = np.sqrt(np.clip(np.diag(sol.cov_statistical), 0.0, None))
        z = {k: (sol.theta[k] / sigma[k] if sigma[k] > 0 else
                 (math.inf if sol.theta[k] > 0 else 0.0)) for k in active}
        sigma_scaled = np.sqrt(np.clip(np.diag(sol.cov), 0.0, None))
        for k in active:
            last[k] = (float(sol.theta[k]), float(sigma_scaled[k]))
        drop = [k for k in edges if z[k] < thresholds[k]]
        if not drop or not eliminate_edges:
            break
        reduced = [k for k in active if k not in drop]
        if not reduced:
            active = reduced
            break
        # an edge term leaves the model only if that does not move the others: dropping
        # a real but unresolved term would bias its neighbours (N takes Q's share)
        trial = _solve(curve, used, reduced, pinned)
        if any(abs(float(trial.theta[k] - sol.theta[k])) > sigma[k] for k in reduced):
            notes.append('the edge term(s) ' + ', '.join(SYMBOLS[k] for k in drop)
                         + ' stay in the model although not resolved: leaving them out '
                         'moves the other terms by more than their uncertainty.')
            break
        active = reduced
        edges = []
    theta_final = sol.theta if sol is not None and active else np.zeros(5)
    cov_final = sol.cov if sol is not None and active else np.zeros((5, 5))
    if band_below > 0 and theta_final[1] > 0:
        # the filter's departure decays as 1/τ: what it was at the longest τ left out,
        # scaled to the first τ kept, bounds its share in N² (a systematic allowance)
        before = np.nonzero(np.isfinite(curve.avar) & (curve.avar > 0)
                            & (curve.tau_s < band_below))[0]
        if len(before):
            i = int(before[-1])
            model = float((avar_basis(curve.tau_s[i:i + 1]) @ theta_final)[0])
            frac = abs(float(curve.avar[i]) / model - 1.0) * float(curve.tau_s[i]) / band_below
            cov_final = cov_final.copy()
            cov_final[1, 1] += (frac * float(theta_final[1])) ** 2
            notes.append(f'N² carries a band-limited allowance of ±{100 * frac:.2g} % (the '
                         f'departure at {_fmt(float(curve.tau_s[i]))} s, decaying as 1/τ, '
                         'at the first τ kept), added to its uncertainty.')
    in_model = len(active)
    reported = [k for k in active if theta_final[k] > 0 and z.get(k, 0.0) >= thresholds[k]]
    q_index = SYMBOLS.index('Q')
    if band_below > 0 and band_low and context != 'pulses' and q_index in reported:
        # a low-pass filter's tail is a 1/τ² term too (−1.5·N²·T_c/τ² for one pole): a
        # positive 1/τ² fitted just above the band-limited range cannot be told from it
        reported.remove(q_index)
        missing[units.keys[q_index]] = (
            f'{units.names[q_index]} is not reported: the short-τ range departs from the '
            f'model (band-limited below {_fmt(band_below)} s), and the filter tail left '
            f'above it is a 1/τ² slope as quantisation is; the joint fit gives Q² = '
            f'{_fmt(float(theta_final[q_index]))} ± '
            f'{_fmt(math.sqrt(max(float(cov_final[q_index, q_index]), 0.0)))} '
            f'({units.si_units[q_index]})², which cannot be told from the filter.')
    estimates: dict[str, Estimate] = {}
    for k in reported:
        theta, sig = float(theta_final[k]), math.sqrt(max(float(cov_final[k, k]), 0.0))
        value = math.sqrt(theta)
        estimates[units.keys[k]] = Estimate(value, sig / (2.0 * value), curve.n_rate_samples,
                                            n_used - in_model)
    bounds: dict[str, float] = {}
    for k, s in enumerate(SYMBOLS):
        if k not in reported and units.keys[k] not in missing:
            theta, sig = last.get(k, (0.0, 0.0))
            missing[units.keys[k]] = _reason(s, units, theta, sig, float(tau_used[-1]),
                                             float(tau_used[0]), thresholds[k], context)
            bounds[units.keys[k]] = _upper_bound(theta, sig)
    full_alpha = np.zeros(len(curve), dtype=np.int64)
    chi2, scale = math.nan, 1.0
    if sol is not None and active:
        full_alpha[used] = sol.alpha
        chi2, scale = sol.chi2_ratio, sol.scale
    edf = curve.edf(full_alpha)
    if scale > 1.0:
        notes.append(f'the model fits the Allan variance worse than its scatter allows '
                     f'(χ² ratio {chi2:.3g}); every uncertainty is scaled by '
                     f'√{scale:.3g} = {math.sqrt(scale):.3g}.')
    ranges = _term_ranges(theta_final, tau_used, [units.keys[k] for k in reported], reported)
    return NoiseFit(estimates, missing, theta_final, cov_final, full_alpha, edf, used,
                    chi2, scale, tuple(SYMBOLS[k] for k in reported), bounds, ranges,
                    tuple(notes), band_below)


def _term_ranges(theta: FloatArray, tau: FloatArray, keys: list[str],
                 idx: list[int]) -> dict[str, tuple[float, float, float]]:
    """τ range each reported term rests on (see :attr:`NoiseFit.tau_ranges`)."""
    parts = avar_basis(tau) * theta
    total = parts.sum(axis=1)
    out: dict[str, tuple[float, float, float]] = {}
    with np.errstate(invalid='ignore', divide='ignore'):
        share = np.where(total[:, None] > 0, parts / total[:, None], 0.0)
    for key, k in zip(keys, idx):
        sh = share[:, k]
        for level in (0.5, 0.1):
            sel = sh >= level
            if np.any(sel):
                break
        else:
            sel = sh == sh.max()
        out[key] = (float(tau[sel][0]), float(tau[sel][-1]), float(sh.max()))
    return out


def _exclude_band_limited(curve: AllanCurve, used: npt.NDArray[np.bool_],
                          terms: tuple[str, ...]) -> tuple[npt.NDArray[np.bool_], float, str]:
    """Leave out the short-τ range that departs from the model (see fit_noise_terms)."""
    active = [SYMBOLS.index(s) for s in SYMBOLS if s in terms]
    n0 = int(np.count_nonzero(used))
    if n0 < 6 or len(active) < 2:
        return used, 0.0, ''
    used = used.copy()
    dropped: list[float] = []
    z_first = 0.0
    while int(np.count_nonzero(used)) > max(n0 // 2, 5):
        sol = _solve(curve, used, active)
        if not sol.misfit or len(sol.z) == 0:
            break
        first = int(np.nonzero(used)[0][0])
        if not dropped:
            z_first = float(sol.z[0])
            if abs(z_first) < BAND_MIN_DEPARTURE:
                # the misfit lies elsewhere: a filter bends the shortest τ most, so this is
                # not a band-limited range (the misfit scaling widens the uncertainties)
                break
        dropped.append(float(curve.tau_s[first]))
        used[first] = False
    if not dropped:
        return used, 0.0, ''
    # the filter's effect decays as 1/τ: once the misfit is no longer significant it is
    # still there at the next points, so a margin of two more points is left out as well
    for _ in range(BAND_MARGIN_POINTS):
        if int(np.count_nonzero(used)) <= max(n0 // 2, 5):
            break
        first = int(np.nonzero(used)[0][0])
        dropped.append(float(curve.tau_s[first]))
        used[first] = False
    kept = float(curve.tau_s[np.nonzero(used)[0][0]])
    side = 'below' if z_first < 0 else 'above'
    return used, kept, (
        f'τ < {_fmt(kept)} s ({len(dropped)} point(s) from {_fmt(dropped[0])} s) left out of '
        f'the term fit: the curve departs from the IEEE 952 model there (the shortest τ '
        f'lies {abs(z_first):.3g} standard deviations {side} it; white noise through a '
        f"low-pass filter, e.g. the sensor's anti-alias or decimation filter, bends the "
        f'−½ line at short τ).')
