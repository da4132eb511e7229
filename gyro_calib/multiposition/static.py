"""Static intervals found from the recording's own noise (docs/methods.md §G.1).

Each sample gets the variance of each of the six axes (three accelerometer, three gyro) over
a centred window of ``window_s``. The recording's noise floor σ²_j of axis j is a low
quantile q of those variances divided by the same quantile of σ²·χ²_{w−1}/(w−1), the law of
a window variance of white noise (so it assumes at least a fraction q of windows at rest):

    σ²_j = Q_q(v_j) · (w − 1) / χ²_{w−1}(q)                                          (2)

A sample is at rest when every axis' window variance is below ``threshold_ratio`` · σ²_j:
the threshold is a property of the recording, not a setting to tune. Runs of resting samples
form intervals; one shorter than ``min_static_s`` is rejected with that reason, and so is
one whose mean gyro rate stands out from the other intervals' by more than its noise allows
(a slow steady turn keeps the variance low but moves the pose).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import stats
from scipy.ndimage import uniform_filter1d

Array = npt.NDArray[np.float64]

NOISE_QUANTILE = 0.10
"""q of eq. (2): the quantile of the window variances taken as the noise floor."""
THRESHOLD_RATIO = 6.0
"""A window whose variance exceeds this many noise floors on any axis is moving."""


@dataclass(frozen=True, slots=True)
class StaticInterval:
    """A run of samples at rest.

    Attributes:
        start: index of its first sample.
        stop: one past its last sample.
        t_start_s: stamp of its first sample, s.
        t_stop_s: stamp of its last sample, s.
    """

    start: int
    stop: int
    t_start_s: float
    t_stop_s: float

    @property
    def n(self) -> int:
        """Its number of samples."""
        return self.stop - self.start

    @property
    def duration_s(self) -> float:
        """Its length, s."""
        return self.t_stop_s - self.t_start_s


@dataclass(frozen=True, slots=True)
class RejectedInterval:
    """A run at rest that is not used, and why (one sentence)."""

    interval: StaticInterval
    reason: str


@dataclass(frozen=True, slots=True)
class Detection:
    """The static intervals of a recording and how they were found.

    Attributes:
        intervals: the intervals used, in time order.
        rejected: the runs at rest left out, each with its reason.
        noise_var_acc: σ²_j of eq. (2) of the accelerometer axes, raw unit².
        noise_var_gyro: the same of the gyro axes.
        window: the window, samples.
        threshold_ratio: the threshold, in noise floors.
    """

    intervals: tuple[StaticInterval, ...]
    rejected: tuple[RejectedInterval, ...]
    noise_var_acc: Array
    noise_var_gyro: Array
    window: int
    threshold_ratio: float


def moving_variance(x: Array, window: int) -> Array:
    """Per-column variance over a centred window of ``window`` samples (edges: nearest)."""
    mean = uniform_filter1d(x, window, axis=0, mode='nearest')
    mean_sq = uniform_filter1d(x * x, window, axis=0, mode='nearest')
    return np.maximum(mean_sq - mean * mean, 0.0)


def noise_floor(variance: Array, window: int, quantile: float = NOISE_QUANTILE) -> Array:
    """σ²_j of eq. (2) from the window variances ``variance`` (N×k)."""
    dof = window - 1
    factor = dof / float(stats.chi2.ppf(quantile, dof))
    floor = np.quantile(variance, quantile, axis=0) * factor
    return np.maximum(floor, np.finfo(float).tiny)


def _runs(mask: npt.NDArray[np.bool_]) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))


def _not_turning(gyro: Array, still: npt.NDArray[np.bool_], short: int
                 ) -> npt.NDArray[np.bool_]:
    """Samples whose short-window mean rate lies within 5 robust σ of the resting rate (2a).

    The start and end of a smooth hand turn (rate rising from 0) hide below the variance
    test; their rate does not. The resting rate and its spread are the median and the MAD of
    the ``short``-sample means over the samples passing the variance test (noise,
    quantisation and bias wander of this recording in one).
    """
    if np.count_nonzero(still) < 2 * short:
        return still
    mean = uniform_filter1d(gyro, short, axis=0, mode='nearest')
    rest = np.median(mean[still], axis=0)
    spread = 1.4826 * np.median(np.abs(mean[still] - rest), axis=0)
    spread = np.maximum(spread, np.finfo(float).tiny)
    return np.asarray(np.all(np.abs(mean - rest) < 5.0 * spread, axis=1))


def detect_static(t_s: Array, acc: Array, gyro: Array, *, window_s: float = 1.0,
                  min_static_s: float = 1.0,
                  threshold_ratio: float = THRESHOLD_RATIO) -> Detection:
    """The static intervals of a recording (§G.1 eq. (2)).

    Args:
        t_s: sample stamps, s (increasing).
        acc: accelerometer samples (N×3), any unit.
        gyro: gyro samples (N×3), any unit.
        window_s: the variance window, s.
        min_static_s: shortest interval used, s.
        threshold_ratio: see :data:`THRESHOLD_RATIO`.
    """
    n = len(t_s)
    dt = float(np.median(np.diff(t_s))) if n > 1 else 1.0
    window = max(5, int(round(window_s / dt)) | 1)
    va, vg = moving_variance(acc, window), moving_variance(gyro, window)
    fa, fg = noise_floor(va, window), noise_floor(vg, window)
    still = np.all(va < threshold_ratio * fa, axis=1) & np.all(vg < threshold_ratio * fg, axis=1)
    still &= _not_turning(gyro, still, max(3, window // 4))
    candidates = [StaticInterval(a, b, float(t_s[a]), float(t_s[b - 1]))
                  for a, b in _runs(still)]
    used: list[StaticInterval] = []
    rejected: list[RejectedInterval] = []
    for iv in candidates:
        if iv.duration_s < min_static_s:
            rejected.append(RejectedInterval(iv, f'at rest {iv.duration_s:.2f} s from '
                                             f't = {iv.t_start_s:.2f} s: shorter than '
                                             f'{min_static_s:g} s'))
        else:
            used.append(iv)
    used, turning = _steady_turns(used, gyro, fg)
    return Detection(tuple(used), tuple(rejected + turning), fa, fg, window, threshold_ratio)


def _steady_turns(intervals: list[StaticInterval], gyro: Array,
                  floor: Array) -> tuple[list[StaticInterval], list[RejectedInterval]]:
    """Intervals whose mean gyro rate is off the median of the others by > 6 σ per axis.

    σ² = the interval means' robust scatter (MAD) plus the noise floor over the interval.
    """
    if len(intervals) < 4:
        return intervals, []
    means = np.array([gyro[iv.start:iv.stop].mean(axis=0) for iv in intervals])
    median = np.median(means, axis=0)
    mad = 1.4826 * np.median(np.abs(means - median), axis=0)
    kept, out = [], []
    for iv, m in zip(intervals, means, strict=True):
        sigma = np.sqrt(mad ** 2 + floor / iv.n)
        z = np.abs(m - median) / sigma
        if np.any(z > 6.0):
            axis = 'xyz'[int(np.argmax(z))]
            out.append(RejectedInterval(iv, f'at rest by its variance from t = '
                                        f'{iv.t_start_s:.2f} s but its mean gyro {axis} rate '
                                        f'is {float(np.max(z)):.1f} σ off the other intervals\''
                                        ': a slow steady turn'))
        else:
            kept.append(iv)
    return kept, out
