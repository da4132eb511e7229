"""The biases of the triad from the pair sums, with the Earth rate along u removed (METHODS §F.5).

Per channel β_i is the mean over its pairs of the count-rate sum less what the rotation and
the Earth rate along u explain; b_i = K_i·β_i along s_i and b = M·β in the body frame
(eq. (14)); the mean's uncertainty is the scatter × Student t or the prediction, whichever is
larger (as §A eq. (3d)).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.estimate import Estimate, student_t_factor
from gyro_calib.triad.records import ChannelResult

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy.typing as npt

    from gyro_calib.triad.records import TriadPair

    Array = npt.NDArray[np.float64]


def pair_mean(values: list[float], stds: list[float]) -> tuple[float, float, str]:
    """Mean and its standard uncertainty: scatter × Student t, or the prediction (§A (3d))."""
    n = len(values)
    arr = np.asarray(values)
    mean = float(arr.mean())
    predicted = math.sqrt(float(np.mean(np.square(stds)))) / math.sqrt(n)
    if n < 2:
        return mean, predicted, 'predicted from the counts of 1 pair'
    t = student_t_factor(n - 1)
    scatter = t * float(arr.std(ddof=1)) / math.sqrt(n)
    if scatter >= predicted:
        return mean, scatter, f'scatter of {n} pairs × Student t {t:.3f} ({n - 1} dof)'
    return mean, predicted, f'predicted from the counts of {n} pairs'


def biases(pairs: Sequence[TriadPair], chans: list[ChannelResult], col: dict[int, int],
           x: Array, m_est: tuple[tuple[Estimate, ...], ...] | None, k_values: Array,
           ) -> tuple[list[ChannelResult], tuple[Estimate, Estimate, Estimate] | None, str]:
    """β_i = mean over pairs of Σ − (r_i·u)(excess + Ω_u); b_i = K_i·β_i; b = M·β (eq. 14)."""
    out: list[ChannelResult] = []
    beta = np.full(3, np.nan)
    beta_var = np.full(3, np.nan)
    missing = ''
    for c, ch in enumerate(chans):
        if c not in col:
            out.append(ch)
            continue
        r = x[col[c]:col[c] + 3]
        vals, stds = [], []
        why = ''
        for p in pairs:
            if p.rejected[c] or p.sum_rate is None:
                continue
            if not math.isfinite(p.earth_rate_along_u_rad_s):
                why = ('the bias needs the site latitude (and heading) to remove the Earth rate '
                       'along each rotation direction.')
                break
            vals.append(float(p.sum_rate[c]) - float(r @ p.direction)
                        * (p.excess_rate_rad_s + p.earth_rate_along_u_rad_s))
            stds.append(float(p.sum_rate_std[c]) if p.sum_rate_std is not None else 0.0)
        if not why and not vals:
            why = 'no pair carries the count sums (N⁺ + N⁻) the bias needs.'
        if why:
            missing = missing or why
            out.append(replace_bias(ch, None, why))
            continue
        mean, std, basis = pair_mean(vals, stds)
        beta[c], beta_var[c] = mean, std * std
        k = float(k_values[c])
        out.append(replace_bias(ch, Estimate(k * mean, k * std, len(vals), len(vals) - 1, (),
                                              basis), ''))
    if m_est is None or not np.all(np.isfinite(beta)):
        return out, None, missing or 'b = M·β needs all three rows and biases.'
    mmat = np.array([[e.value for e in row] for row in m_est])
    b = mmat @ beta
    b_std = np.sqrt(np.diag(mmat @ np.diag(beta_var) @ mmat.T))
    n = min(e.n_used for ch in out if ch.bias_rad_s is not None for e in (ch.bias_rad_s,))
    return out, (Estimate(float(b[0]), float(b_std[0]), n, n - 1),
                 Estimate(float(b[1]), float(b_std[1]), n, n - 1),
                 Estimate(float(b[2]), float(b_std[2]), n, n - 1)), ''


def replace_bias(ch: ChannelResult, bias: Estimate | None, why: str) -> ChannelResult:
    """``ch`` with its bias (or None) and why it is missing."""
    return ChannelResult(ch.name, ch.row_pulse_per_rad, ch.scale_factor_rad_per_pulse,
                         ch.sense_axis, ch.sense_axis_covariance, bias, ch.not_measurable, why,
                         ch.rejected)
