"""The angle random walk in each window's count, per gyro (METHODS §F.2 eq. (6b)).

A gyro of angle random walk N (rad/√s) and scale factor K adds a random walk to its count of
density a = N²/K² (pulses²/s): a window of T seconds carries a·T on top of its end fits and
quantisation, so the pair difference carries a·4·(w⁺²·T⁺ + w⁻²·T⁻) (``walk_weight_s``) and the
pair sum's rate a/(T⁺ + T⁻). The long inner windows carry more of it than the short station
windows, so one factor for the whole fit cannot stand in for it.

a comes, per gyro, from the stated ARW (:func:`stated_walk`, with K̂ from a first solve) or is
measured from the record (:func:`measured_walk`): the value at which the gyro's own pair
residuals of the joint fit scatter as their prediction says (χ² = its degrees of freedom,
REML-like, eq. (6c)).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    from gyro_calib.triad.records import TriadPair, TriadResult

    Array = npt.NDArray[np.float64]

STATED, MEASURED = 'stated', 'measured from the pair residuals'


@dataclass(frozen=True, slots=True)
class CountWalk:
    """The count random walk of each gyro and where it comes from.

    Attributes:
        density_pulses2_per_s: a_i = N_i²/K_i² per channel (3,), pulses²/s (NaN: unknown).
        arw_rad_sqrt_s: N_i = K_i·√a_i per channel (3,), rad/√s.
        origin: :data:`STATED` or :data:`MEASURED`.
        dof: per channel, the degrees of freedom the measured a rests on (0 when stated).
    """

    density_pulses2_per_s: Array
    arw_rad_sqrt_s: Array
    origin: str
    dof: tuple[int, int, int] = (0, 0, 0)


def with_count_walk(pair: TriadPair, density_pulses2_per_s: Array,
                    model_density_pulses2_per_s: Array | None = None) -> TriadPair:
    """``pair`` with each channel's count random walk a_i added (eq. (6b)).

    u²(ΔN_i) += a_i·walk_weight_s, u²(Σ_i) += a_i/(T⁺ + T⁻): to the weights' with
    ``density_pulses2_per_s``, to the model's with ``model_density_pulses2_per_s`` (default
    the same).
    """
    a = np.where(np.isfinite(density_pulses2_per_s), density_pulses2_per_s, 0.0)
    am = a if model_density_pulses2_per_s is None else np.where(
        np.isfinite(model_density_pulses2_per_s), model_density_pulses2_per_s, 0.0)
    diff_std = np.sqrt(pair.count_difference_std ** 2 + a * pair.walk_weight_s)
    sum_std = pair.sum_rate_std
    if sum_std is not None and pair.duration_s > 0:
        sum_std = np.sqrt(sum_std ** 2 + a / pair.duration_s)
    model_diff, model_sum = pair.model_difference_std, pair.model_sum_rate_std
    if model_diff is not None:
        model_diff = np.sqrt(model_diff ** 2 + am * pair.walk_weight_s)
    if model_sum is not None and pair.duration_s > 0:
        model_sum = np.sqrt(model_sum ** 2 + am / pair.duration_s)
    return dataclasses.replace(pair, count_difference_std=diff_std, sum_rate_std=sum_std,
                               model_difference_std=model_diff, model_sum_rate_std=model_sum)


def stated_walk(arw_rad_sqrt_s: Array, scale_factor_rad_per_pulse: Array) -> CountWalk:
    """a_i = (N_i/K_i)² from the stated ARW and the scale factors (eq. (6b))."""
    n = np.asarray(arw_rad_sqrt_s, dtype=np.float64)
    k = np.asarray(scale_factor_rad_per_pulse, dtype=np.float64)
    return CountWalk(np.asarray((n / k) ** 2, dtype=np.float64), n, STATED)


def channel_residuals(pairs: Sequence[TriadPair], result: TriadResult, c: int,
                      fitted: Sequence[int] = ()) -> tuple[Array, Array, Array]:
    """Channel c's pair residuals e_k = ΔN_kc − 2·φ_k·(u_k·r̂_c) and their parts of variance.

    Returns (e, V0, A): V0 the prediction without the walk (counts and the swept angle), A
    the walk weight, over the pairs the channel uses.
    """
    ch = result.channels[c]
    assert ch.row_pulse_per_rad is not None
    r = np.array([e.value for e in ch.row_pulse_per_rad])
    delta = np.array([e.value for e in result.parameters.values()])
    e, v0, w = [], [], []
    for p in pairs:
        if p.rejected[c] or not (math.isfinite(p.count_difference[c])
                                 and p.count_difference_std[c] > 0):
            continue
        u = p.direction
        if len(delta) and p.direction_sensitivity is not None and fitted:
            u = u + p.direction_sensitivity[:, list(fitted)] @ delta
            u = u / np.linalg.norm(u)
        e.append(float(p.count_difference[c]) - 2 * p.swept_angle_rad * float(u @ r))
        g = float(p.count_difference[c]) / p.swept_angle_rad
        v0.append(float(p.count_difference_std[c]) ** 2 + g * g * p.swept_angle_std_rad ** 2)
        w.append(p.walk_weight_s)
    return np.array(e), np.array(v0), np.array(w)


def sum_residuals(pairs: Sequence[TriadPair], result: TriadResult, c: int
                  ) -> tuple[Array, Array, Array]:
    """Channel c's pair-sum rates about their mean (eq. (6), (14)), and their variance parts.

    y_k = Σ_k − (r̂_c·u_k)·(excess + Ω_u) scatters about β_c by the windows' count noise:
    V0 = u²(Σ_k) without the walk, A = 1/(T⁺ + T⁻). Empty without the Earth rate along u.
    """
    ch = result.channels[c]
    assert ch.row_pulse_per_rad is not None
    r = np.array([e.value for e in ch.row_pulse_per_rad])
    y, v0, w = [], [], []
    for p in pairs:
        if p.rejected[c] or p.sum_rate is None or p.sum_rate_std is None \
                or p.duration_s <= 0 or not math.isfinite(p.earth_rate_along_u_rad_s):
            continue
        y.append(float(p.sum_rate[c]) - float(r @ p.direction)
                 * (p.excess_rate_rad_s + p.earth_rate_along_u_rad_s))
        v0.append(float(p.sum_rate_std[c]) ** 2)
        w.append(1.0 / p.duration_s)
    arr = np.array(y)
    return (arr - arr.mean() if len(arr) else arr), np.array(v0), np.array(w)


def walk_from_residuals(e: Array, v0: Array, weight: Array, dof: float) -> float:
    """The a ≥ 0 at which Σ e_k²/(V0_k + a·A_k) = ν (eq. (6c)); 0 if already below at a = 0."""
    if dof <= 0 or len(e) == 0 or not np.any(weight > 0):
        return 0.0

    def chi2(a: float) -> float:
        return float(np.sum(e * e / (v0 + a * weight)))

    if chi2(0.0) <= dof:
        return 0.0
    hi = max(float(np.max(e * e / np.maximum(weight, 1e-300))), 1e-300)
    lo = 0.0
    while chi2(hi) > dof:
        hi *= 4.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if chi2(mid) > dof:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * hi:
            break
    return 0.5 * (lo + hi)


def measured_walk(pairs: Sequence[TriadPair], result: TriadResult,
                  fitted: Sequence[int] = (), *, dof_at_most_pairs: bool = True) -> CountWalk:
    """a_i measured from gyro i's own pair residuals of the joint fit (eq. (6c)).

    The pair differences' residuals (ν = n_i − 3 − q/3: its pairs, its row, its share of the
    q fitted bench parameters) and the pair sums' scatter about their mean (ν = n_i − 1, when
    the Earth rate along u is known) together: a solves Σ e²/(V0 + a·A) = ν. Estimated from
    ν degrees of freedom (stated as at most n_i − 1, the pairs it rests on), a is used × t_ν²
    (Student t, §A eq. (3d)), so the share of the uncertainty it carries covers as a known one
    would; K_i and s_i state the same ν (:attr:`CountWalk.dof`). ``dof_at_most_pairs``
    False: ν uncapped (the solve's weights, kept as they were so the estimates do not move).
    The residuals must come from a fit weighted with the same a (iterate: solve, measure).
    """
    from gyro_calib.estimate import student_t_factor

    dens = np.full(3, math.nan)
    arw = np.full(3, math.nan)
    dofs = [0, 0, 0]
    for c, ch in enumerate(result.channels):
        if ch.row_pulse_per_rad is None or ch.scale_factor_rad_per_pulse is None:
            continue
        e, v0, w = channel_residuals(pairs, result, c, fitted)
        es, v0s, ws = sum_residuals(pairs, result, c)
        dof = len(e) - 3 - len(fitted) / 3.0 + max(len(es) - 1, 0)
        # at most n_i − 1, as any statement resting on n_i pairs (Estimate.supported_dof): the
        # same ν the channel's K_i and s_i then state (summary and hand-off)
        dofs[c] = max(min(int(round(dof)), len(e) - 1) if dof_at_most_pairs
                      else int(round(dof)), 0)
        a = walk_from_residuals(np.concatenate((e, es)), np.concatenate((v0, v0s)),
                                np.concatenate((w, ws)), dof)
        arw[c] = math.sqrt(a) * ch.scale_factor_rad_per_pulse.value
        dens[c] = a * (student_t_factor(dofs[c]) ** 2 if dofs[c] >= 1 else 1.0)
    return CountWalk(dens, arw, MEASURED, (dofs[0], dofs[1], dofs[2]))
