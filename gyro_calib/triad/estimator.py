"""K_i, sense axes s_i, M = R⁻¹ and biases of a gyro triad from window pairs (METHODS §F.3–F.5).

Every forward/reverse pair k turns the body by ±φ_k about a known direction u_k (body frame);
channel i counts, after the pair difference (eq. 5),

    ΔN_ki = 2·φ_k·(u_k·r_i) + ε_ki,   r_i = s_i/K_i  (pulses/rad)                    eq. (7)

The rows r_i are solved jointly by generalised least squares (eq. 8; per pair the channels
share the swept-angle error, so the weight is a 3×3 block), together with any bench parameter
declared ``fitted`` (the tilt α, with its stated uncertainty as a prior). A channel whose
accepted directions do not span 3-D (eq. 9's rank test) is not measurable. Then

    K_i = 1/|r_i|,   s_i = K_i·r_i,   M = R⁻¹ (rad/pulse), ω_B = M·ṅ − b        eqs. (10)–(11)

with the covariance propagated to first order and split by source (eq. 12), and the bias from
the pair sums with the Earth rate along u removed (eq. 14).

What goes in and comes out (:class:`TriadPair`, :class:`TriadResult` …) is
:mod:`~gyro_calib.triad.records`, the biases :mod:`~gyro_calib.triad.bias`; this module
re-exports their names.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.errors import InsufficientDataError
from gyro_calib.estimate import Estimate, Rejection, student_t_factor
from gyro_calib.triad.bias import biases
from gyro_calib.triad.records import (
    BenchParameter,
    BudgetLine,
    ChannelResult,
    TriadPair,
    TriadResult,
)

if TYPE_CHECKING:
    import numpy.typing as npt

    Array = npt.NDArray[np.float64]

__all__ = ['BIRGE_PROBABILITY', 'COUNTS', 'RANK_THRESHOLD', 'SWEPT_ANGLE', 'BenchParameter',
           'BudgetLine', 'ChannelResult', 'TriadPair', 'TriadResult', 'triad_calibration']

RANK_THRESHOLD = 0.05
"""Smallest singular value of the √d-normalised matrix of a channel's d distinct directions
below which they count as not spanning 3-D (three orthogonal directions give 1/√3 = 0.577;
e_z and four stations at α = 45°, 90° apart, give 0.447)."""

BIRGE_PROBABILITY = 0.99
"""A complete prediction is widened by the Birge ratio only when the scatter exceeds it at
this probability (χ²_ν/ν above its 99 % point): the prediction then misses a source."""


COUNTS, SWEPT_ANGLE = 'counts', 'swept angle'
"""Budget sources: per-channel count noise of the pairs; the swept angle (encoder, index)."""


def _student_t(dof: int) -> float:
    """Student t with P(T_ν < t) = 0.8413 (docs/methods.md conventions; as §A eq. (3d))."""
    return student_t_factor(dof)



def _span_problem(name: str, directions: list[Array], threshold: float) -> str:
    """Why ``directions`` do not span 3-D (eq. 9), or ''.

    The test is on the distinct directions (equal to 1e-9), so that many pairs about one
    axis (hundreds of K̃ pairs) do not hide the stations in the √n normalisation.
    """
    n = len(directions)
    distinct = np.unique(np.round(np.array(directions).reshape(-1, 3), 9), axis=0)
    d = len(distinct)
    if d < 3:
        return (f'channel {name}: {n} accepted pair(s) about {d} distinct direction(s); its '
                'row needs pairs about at least 3 independent directions (K̃ pairs and 2 '
                'stations, or 3 stations).')
    sv = np.linalg.svd(distinct / math.sqrt(d), compute_uv=False)
    if sv[-1] < threshold:
        return (f'channel {name}: the {d} distinct rotation directions of its {n} accepted pairs '
                f'do not span 3-D (smallest singular value {sv[-1]:.3g} of the normalised '
                f'direction matrix < {threshold}); add pairs about a direction out of their '
                'plane (another station, K̃ pairs on the inner axis, or another remount axis).')
    return ''


def triad_calibration(
    pairs: Sequence[TriadPair], *,
    channels: tuple[str, str, str] = ('x', 'y', 'z'),
    parameters: Sequence[BenchParameter] = (),
    prediction_complete: bool = True,
    rank_threshold: float = RANK_THRESHOLD,
    count_noise_dof: Sequence[int] | None = None,
) -> TriadResult:
    """Rows, K_i, s_i, M with covariance and budget, and biases (METHODS §F eqs. 7–14).

    Args:
        pairs: forward/reverse pairs about known directions.
        channels: the three channel names.
        parameters: bench parameters, one per column of each pair's ``direction_sensitivity``.
        prediction_complete: True when ``count_difference_std`` and ``swept_angle_std_rad``
            hold every random source; otherwise the scatter (Birge ratio) is widened by its
            Student-t factor and used whenever larger (as §A eq. (18a)).
        rank_threshold: eq. (9)'s limit on the smallest normalised singular value.
        count_noise_dof: per channel, the degrees of freedom its count uncertainty rests on
            where that was measured (the count random walk from the residuals, eq. (6c)); K_i
            and s_i then state it (0 or None: the row's residual dof n_i − 3).

    Raises:
        InsufficientDataError: no pairs.
        ValueError: malformed pairs (shapes, non-unit u, non-positive std).
    """
    if not pairs:
        raise InsufficientDataError('no window pairs: the triad needs pairs about at least '
                                    '3 independent directions.')
    q = len(parameters)
    for p in pairs:
        if p.direction.shape != (3,) or abs(float(np.linalg.norm(p.direction)) - 1.0) > 1e-6:
            raise ValueError('a pair direction must be a unit 3-vector (body frame).')
        if p.count_difference.shape != (3,) or p.count_difference_std.shape != (3,):
            raise ValueError('count_difference and count_difference_std need one value per '
                             'channel (3).')
        if q and (p.direction_sensitivity is None or p.direction_sensitivity.shape != (3, q)):
            raise ValueError(f'with {q} bench parameter(s) every pair needs a (3, {q}) '
                             'direction_sensitivity.')
    # which pairs each channel uses, and which channels are measurable (eq. 9)
    used: list[list[int]] = [[], [], []]
    rejected: list[list[Rejection]] = [[], [], []]
    for k, p in enumerate(pairs):
        for c in range(3):
            why = p.rejected[c]
            if not why and not (math.isfinite(p.count_difference[c])
                                and p.count_difference_std[c] > 0):
                why = 'count difference not finite or its uncertainty not positive'
            if why:
                rejected[c].append(Rejection(p.stamp_ns, f'channel {channels[c]}: {why}'))
            else:
                used[c].append(k)
    problems = [_span_problem(channels[c], [pairs[k].direction for k in used[c]],
                              rank_threshold) for c in range(3)]
    solved = [c for c in range(3) if not problems[c]]
    fit_idx = [j for j, p in enumerate(parameters) if p.fitted and p.std_rad > 0]
    if not solved:
        return _unsolved(channels, problems, rejected)
    return _Solver(pairs, channels, parameters, used, solved, fit_idx, problems, rejected,
                   prediction_complete, count_noise_dof).result()


def _unsolved(channels: tuple[str, str, str], problems: list[str],
              rejected: list[list[Rejection]]) -> TriadResult:
    chans = tuple(ChannelResult(channels[c], None, None, None, None, None, problems[c],
                                'the row is not measurable', tuple(rejected[c]))
                  for c in range(3))
    return TriadResult(chans, None, None, None, not_measurable='; '.join(problems),
                       bias_missing='no channel is measurable')


class _Solver:
    """The joint generalised least squares of eq. (8) and its propagation (eqs. 10–12)."""

    def __init__(self, pairs: Sequence[TriadPair], channels: tuple[str, str, str],
                 parameters: Sequence[BenchParameter], used: list[list[int]],
                 solved: list[int], fit_idx: list[int], problems: list[str],
                 rejected: list[list[Rejection]], prediction_complete: bool,
                 count_noise_dof: Sequence[int] | None = None) -> None:
        self.pairs, self.channels, self.parameters = pairs, channels, parameters
        self.modelled = [p.as_modelled() for p in pairs]
        self.solved, self.fit_idx, self.problems = solved, fit_idx, problems
        self.rejected, self.complete = rejected, prediction_complete
        self.count_noise_dof = tuple(count_noise_dof) if count_noise_dof is not None \
            else (0, 0, 0)
        self.col = {c: 3 * j for j, c in enumerate(solved)}
        self.n_unknown = 3 * len(solved) + len(fit_idx)
        # observations grouped by pair: (pair index, [channels])
        sets = [set(u) for u in used]
        self.groups = [(k, [c for c in solved if k in sets[c]]) for k in range(len(pairs))]
        self.groups = [(k, cs) for k, cs in self.groups if cs]
        self.n_used = {c: len(used[c]) for c in range(3)}

    def _directions(self, delta: Array) -> list[Array]:
        out = []
        for p in self.pairs:
            u = p.direction
            if self.fit_idx and p.direction_sensitivity is not None:
                u = u + p.direction_sensitivity[:, self.fit_idx] @ delta
                u = u / np.linalg.norm(u)
            out.append(u)
        return out

    def _system(self, x: Array) -> tuple[Array, Array, list[Array]]:
        """Whitened Jacobian and residual (observations, then prior rows), and the L⁻¹."""
        nf = len(self.fit_idx)
        delta = x[3 * len(self.solved):]
        us = self._directions(delta)
        rows, res, whiten = [], [], []
        for k, cs in self.groups:
            p = self.pairs[k]
            jac = np.zeros((len(cs), self.n_unknown))
            r = np.empty(len(cs))
            for a, c in enumerate(cs):
                rc = x[self.col[c]:self.col[c] + 3]
                jac[a, self.col[c]:self.col[c] + 3] = 2 * p.swept_angle_rad * us[k]
                if nf and p.direction_sensitivity is not None:
                    jac[a, 3 * len(self.solved):] = (2 * p.swept_angle_rad * rc
                                                     @ p.direction_sensitivity[:, self.fit_idx])
                r[a] = p.count_difference[c] - 2 * p.swept_angle_rad * float(us[k] @ rc)
            li = np.linalg.inv(np.linalg.cholesky(self._pair_cov(k, cs)))
            whiten.append(li)
            rows.append(li @ jac)
            res.append(li @ r)
        for j, i in enumerate(self.fit_idx):
            prior = np.zeros((1, self.n_unknown))
            prior[0, 3 * len(self.solved) + j] = 1.0 / self.parameters[i].std_rad
            rows.append(prior)
            res.append(np.array([-delta[j] / self.parameters[i].std_rad]))
        return np.vstack(rows), np.concatenate(res), whiten

    def _pair_cov(self, k: int, cs: list[int], parts: str = 'all',
                  modelled: bool = False) -> Array:
        """Covariance of one pair's ΔN over channels ``cs``: counts + common swept angle.

        ``modelled``: the counts' uncertainty from the error model (eq. (6a)), else the
        weights' (:attr:`TriadPair.model_difference_std`).
        """
        p = self.modelled[k] if modelled else self.pairs[k]
        g = np.array([p.count_difference[c] for c in cs]) / p.swept_angle_rad
        counts = np.diag([p.count_difference_std[c] ** 2 for c in cs])
        angle = np.outer(g, g) * p.swept_angle_std_rad**2
        return {'all': counts + angle, COUNTS: counts, SWEPT_ANGLE: angle}[parts]

    def _solve(self) -> tuple[Array, Array, Array, list[Array]]:
        x = np.zeros(self.n_unknown)
        for _ in range(20):
            jac, res, whiten = self._system(x)
            step, *_ = np.linalg.lstsq(jac, res, rcond=None)
            x = x + step
            if np.all(np.abs(step) <= 1e-12 * np.abs(x) + 1e-15):
                break
        jac, res, whiten = self._system(x)
        return x, jac, res, whiten

    def result(self) -> TriadResult:
        x, jac, res, whiten = self._solve()
        n_obs = sum(len(cs) for _, cs in self.groups)
        dof = n_obs - 3 * len(self.solved)
        cov_pred = np.linalg.inv(jac.T @ jac)
        gain = cov_pred @ jac.T  # whitened observations → unknowns
        birge2 = float(res @ res) / self._expected_chi2(jac, gain, whiten) if dof > 0 \
            else math.nan
        scale, basis = 1.0, f'predicted from the counts and angles of {len(self.groups)} pairs'
        if dof > 0:
            from scipy.stats import chi2

            if self.complete:
                if birge2 > chi2.ppf(BIRGE_PROBABILITY, dof) / dof:
                    scale = birge2
                    basis = (f'scatter of {len(self.groups)} pairs (Birge ratio '
                             f'{math.sqrt(birge2):.2f}, above the prediction at 99 %)')
            else:
                t = _student_t(dof)
                if t * t * birge2 > 1.0:
                    scale = t * t * birge2
                    basis = (f'scatter of {len(self.groups)} pairs (Birge ratio '
                             f'{math.sqrt(birge2):.2f}) × Student t {t:.3f} ({dof} dof)')
        sources = self._source_covariances(x, gain, whiten, scale)
        cov = sum(sources.values(), np.zeros((self.n_unknown, self.n_unknown)))
        return self._report(x, cov, sources, dof, birge2, basis)

    def _expected_chi2(self, jac: Array, gain: Array, whiten: list[Array]) -> float:
        """E[χ²] of the weighted residuals under the modelled covariance (sandwich).

        The residuals are (I − P)·ỹ, P = J·G in the whitened rows; with the model's covariance
        S of ỹ, E[χ²] = trace((I − P)·S·(I − P)ᵀ): the dof when the weights are the model.
        """
        n_obs = sum(len(cs) for _, cs in self.groups)
        blocks = [li @ self._pair_cov(k, cs, modelled=True) @ li.T
                  for (k, cs), li in zip(self.groups, whiten, strict=True)]
        s = np.eye(jac.shape[0])
        s[:n_obs, :n_obs] = _block_diag(blocks, n_obs) + self._shared_ends(whiten, n_obs)
        resid = np.eye(jac.shape[0]) - jac @ gain
        return float(np.trace(resid @ s @ resid.T))

    def _shared_ends(self, whiten: list[Array], n_obs: int) -> Array:
        """Whitened covariance between pairs whose windows share an end (eq. (6a)).

        Back-to-back windows share the count fitted at their common zero-index event: pairs
        k ≠ k' holding it carry, on channel c, ∂ΔN_k/∂n·∂ΔN_k'/∂n·u²_end,c (``end_terms``).
        """
        at: dict[tuple[str, int], list[tuple[int, float, Array]]] = {}
        offset, row = 0, []
        for k, cs in self.groups:
            row.append(offset)
            offset += len(cs)
            for stamp, coef, var in self.pairs[k].end_terms:
                at.setdefault(stamp, []).append((len(row) - 1, coef, var))
        raw = np.zeros((n_obs, n_obs))
        shared = False
        for terms in at.values():
            for a, (g, coef_g, var_g) in enumerate(terms):
                for h, coef_h, _ in terms[a + 1:]:
                    if g == h:
                        continue
                    cs_g, cs_h = self.groups[g][1], self.groups[h][1]
                    for c in set(cs_g) & set(cs_h):
                        i, j = row[g] + cs_g.index(c), row[h] + cs_h.index(c)
                        raw[i, j] += coef_g * coef_h * float(var_g[c])
                        raw[j, i] = raw[i, j]
                        shared = True
        if not shared:
            return raw
        lw = _block_diag(whiten, n_obs)
        return np.asarray(lw @ raw @ lw.T, dtype=np.float64)

    def _source_covariances(self, x: Array, gain: Array, whiten: list[Array],
                            scale: float) -> dict[str, Array]:
        """Covariance of the unknowns split by source (eq. 12).

        G·S·Gᵀ with the whitened gain G of the weights and the modelled covariance S of each
        source (a sandwich: the weights need not be the model, the covariance is).
        """
        n_obs_rows = sum(len(cs) for _, cs in self.groups)
        out: dict[str, Array] = {}
        for part in (COUNTS, SWEPT_ANGLE):
            blocks = [li @ self._pair_cov(k, cs, part, modelled=True) @ li.T
                      for (k, cs), li in zip(self.groups, whiten, strict=True)]
            s = _block_diag(blocks, n_obs_rows)
            if part == COUNTS:
                s = s + self._shared_ends(whiten, n_obs_rows)
            g = gain[:, :n_obs_rows]
            out[part] = scale * g @ s @ g.T
        for j, i in enumerate(self.fit_idx):
            g = gain[:, n_obs_rows + j]
            out[self.parameters[i].name] = np.outer(g, g)
        for i, par in enumerate(self.parameters):
            if i in self.fit_idx or par.std_rad <= 0:
                continue
            a = []
            for (k, cs), li in zip(self.groups, whiten, strict=True):
                p = self.pairs[k]
                d = p.direction_sensitivity[:, i] if p.direction_sensitivity is not None \
                    else np.zeros(3)
                v = np.array([2 * p.swept_angle_rad * float(x[self.col[c]:self.col[c] + 3] @ d)
                              for c in cs])
                a.append(li @ v)
            da = gain[:, :n_obs_rows] @ np.concatenate(a)
            out[par.name] = np.outer(da, da) * par.std_rad**2
        return out

    def _report(self, x: Array, cov: Array, sources: dict[str, Array], dof: int,
                birge2: float, basis: str) -> TriadResult:
        ns = len(self.solved)
        n_all = sum(self.n_used[c] for c in self.solved)
        chans: list[ChannelResult] = []
        budget_k = {s: np.full(3, np.nan) for s in sources}
        budget_s = {s: np.full(3, np.nan) for s in sources}
        k_values = np.full(3, np.nan)
        for c in range(3):
            rej = tuple(self.rejected[c])
            if c not in self.col:
                chans.append(ChannelResult(self.channels[c], None, None, None, None, None,
                                           self.problems[c], 'the row is not measurable', rej))
                continue
            sl = slice(self.col[c], self.col[c] + 3)
            r = x[sl]
            c_r = cov[sl, sl]
            n, d = self.n_used[c], self.n_used[c] - 3
            if self.count_noise_dof[c] > 0:  # measured walk: its ν (eq. (6c)), one per quantity
                d = self.count_noise_dof[c]
            norm = float(np.linalg.norm(r))
            k = 1.0 / norm
            k_values[c] = k
            s = r * k
            j_k = -r / norm**3
            j_s = (np.eye(3) - np.outer(s, s)) / norm
            c_s = j_s @ c_r @ j_s.T
            for name, src in sources.items():
                budget_k[name][c] = math.sqrt(max(float(j_k @ src[sl, sl] @ j_k), 0.0)) / k
                budget_s[name][c] = math.sqrt(max(float(np.trace(j_s @ src[sl, sl] @ j_s.T)),
                                                  0.0))
            r_std = np.sqrt(np.maximum(np.diag(c_r), 0.0))
            s_std = np.sqrt(np.maximum(np.diag(c_s), 0.0))
            row = (Estimate(float(r[0]), float(r_std[0]), n, d, rej, basis),
                   Estimate(float(r[1]), float(r_std[1]), n, d, rej, basis),
                   Estimate(float(r[2]), float(r_std[2]), n, d, rej, basis))
            axis = (Estimate(float(s[0]), float(s_std[0]), n, d, rej, basis),
                    Estimate(float(s[1]), float(s_std[1]), n, d, rej, basis),
                    Estimate(float(s[2]), float(s_std[2]), n, d, rej, basis))
            k_est = Estimate(k, math.sqrt(float(j_k @ c_r @ j_k)), n, d, rej, basis)
            chans.append(ChannelResult(self.channels[c], row, k_est, axis, c_s, None, '', '',
                                       rej))
        params = {}
        for j, i in enumerate(self.fit_idx):
            m = 3 * ns + j
            params[self.parameters[i].name] = Estimate(float(x[m]), math.sqrt(cov[m, m]), n_all,
                                                       dof, (), basis)
        m_est = m_cov = None
        budget_m = {s: np.full((3, 3), np.nan) for s in sources}
        not_measurable = '; '.join(p for p in self.problems if p)
        if ns == 3:
            rmat = x[:9].reshape(3, 3)
            mmat = np.linalg.inv(rmat)
            j_m = -np.kron(mmat, mmat.T)  # vec_row(dM) = −(M ⊗ Mᵀ)·vec_row(dR), eq. (11)
            m_cov = j_m @ cov[:9, :9] @ j_m.T
            for name, src in sources.items():
                budget_m[name] = np.sqrt(np.maximum(np.diag(j_m @ src[:9, :9] @ j_m.T), 0.0)
                                         ).reshape(3, 3)
            m_std = np.sqrt(np.diag(m_cov)).reshape(3, 3)
            m_est = tuple(tuple(Estimate(float(mmat[i, j]), float(m_std[i, j]), n_all, dof, (),
                                         basis) for j in range(3)) for i in range(3))
        budget = tuple(BudgetLine(s, budget_k[s], budget_s[s], budget_m[s]) for s in sources)
        chans, bias_body, bias_missing = biases(self.modelled, chans, self.col, x, m_est,
                                                 k_values)
        return TriadResult(tuple(chans), m_est, m_cov, bias_body, params, budget,
                           math.sqrt(birge2) if dof > 0 else math.nan, basis, not_measurable,
                           bias_missing)


def _block_diag(blocks: list[Array], n: int) -> Array:
    out = np.zeros((n, n))
    i = 0
    for b in blocks:
        m = b.shape[0]
        out[i:i + m, i:i + m] = b
        i += m
    return out
