"""The FOG output stream reduced on the fly to least-squares sums per short cell.

Hours of 1 kHz cumulative counts are not kept: every ``cell_s`` of samples becomes seven
numbers (count, Σt, Σt², Σc, Σt·c, Σc² about the cell's own origin, and its reference
count), from which a line can be fitted over any run of whole cells. Two uses:

- the count at an instant (:meth:`CountCells.count_at`): a local line fit over the cells
  within ±h of it, which averages the ±½-count quantisation of the integer output down
  (its standard error from the fit residuals);
- the output rate of each cell (:meth:`CountCells.cell_rates`), to see where a plateau
  has settled.

A cell is reduced once every sample in it can have arrived (the output stream has run
``reorder_margin`` past its end), in one piece, so the sums never depend on how the
stream was chunked.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

_COLUMNS = 7  # n, St, Stt, Sc, Stc, Scc, c_ref


@dataclass(frozen=True, slots=True)
class LocalCount:
    """Cumulative count at an instant from a local line fit.

    Attributes:
        value: count at the instant, counts.
        std_uncertainty: standard error of ``value`` from the fit residuals, counts.
        n_used: output samples in the fit.
        rms_residual: rms residual of the fit, counts.
        rate_counts_s: slope of the fit, counts/s.
        window_s: width of the samples fitted, √(12·var(t)) (2 × the half-width when the
            samples fill the window evenly), s.
    """

    value: float
    std_uncertainty: float
    n_used: int
    rms_residual: float
    rate_counts_s: float
    window_s: float = 0.0


def random_walk_increment_s(interval_s: float, window_s: float) -> float:
    """Effective length T_eff of an increment between local-fit counts.

    Effective length T_eff of an increment between two local-fit counts ``interval_s``
    apart, each the mean over a window of ``window_s``: an angle random walk N² gives the
    increment the variance N²·T_eff, with T_eff = T − a/3 for T ≥ a and (T²/a)(1 − T/(3a))
    for overlapping windows (a = window_s; the variance of the difference of two boxcar
    means of a Wiener process). Block scatter divided by T itself would read N² low by
    up to a third.
    """
    t, a = interval_s, window_s
    if a <= 0.0:
        return t
    return t - a / 3.0 if t >= a else t * t / a * (1.0 - t / (3.0 * a))


class CountCells:
    """Least-squares sums of the output counts per cell of ``cell_ns``."""

    def __init__(self, cell_ns: int) -> None:
        """Create an empty store of cells ``cell_ns`` long (aligned to multiples of it)."""
        self.cell_ns = int(cell_ns)
        self._index = np.zeros(0, dtype=np.int64)
        self._sums = np.zeros((0, _COLUMNS))
        self._parts_index: list[npt.NDArray[np.int64]] = []
        self._parts_sums: list[npt.NDArray[np.float64]] = []
        self.reduced_until_ns: int | None = None
        """All samples before this stamp are in cells (None before the first)."""

    def add_samples(self, t_ns: npt.NDArray[np.int64], counts: npt.NDArray[np.float64],
                    until_ns: int) -> None:
        """Reduce sorted samples that make whole cells ending at or before ``until_ns``.

        ``until_ns`` must be a cell boundary; the caller passes exactly the samples of the
        cells in [reduced_until_ns, until_ns).
        """
        self.reduced_until_ns = until_ns
        if len(t_ns) == 0:
            return
        cell = t_ns // self.cell_ns
        starts = np.concatenate(([0], np.nonzero(np.diff(cell))[0] + 1))
        index = cell[starts]
        origin = index * self.cell_ns
        reps = np.diff(np.concatenate((starts, [len(t_ns)])))
        dt = (t_ns - np.repeat(origin, reps)) / 1e9
        c_ref = counts[starts]
        dc = counts - np.repeat(c_ref, reps)
        sums = np.empty((len(starts), _COLUMNS))
        sums[:, 0] = reps
        sums[:, 1] = np.add.reduceat(dt, starts)
        sums[:, 2] = np.add.reduceat(dt * dt, starts)
        sums[:, 3] = np.add.reduceat(dc, starts)
        sums[:, 4] = np.add.reduceat(dt * dc, starts)
        sums[:, 5] = np.add.reduceat(dc * dc, starts)
        sums[:, 6] = c_ref
        self._parts_index.append(index)
        self._parts_sums.append(sums)

    def _consolidate(self) -> None:
        if self._parts_index:
            self._index = np.concatenate([self._index, *self._parts_index])
            self._sums = np.concatenate([self._sums, *self._parts_sums])
            self._parts_index.clear()
            self._parts_sums.clear()

    def discard_before(self, t_ns: int) -> None:
        """Forget cells that end before ``t_ns``."""
        self._consolidate()
        cut = int(np.searchsorted(self._index, t_ns // self.cell_ns, side='left'))
        if cut:
            self._index, self._sums = self._index[cut:], self._sums[cut:]

    def clear(self) -> None:
        """Forget every cell (a source restart)."""
        self._index = np.zeros(0, dtype=np.int64)
        self._sums = np.zeros((0, _COLUMNS))
        self._parts_index.clear()
        self._parts_sums.clear()
        self.reduced_until_ns = None

    def __len__(self) -> int:
        """Number of cells held."""
        return len(self._index) + sum(len(p) for p in self._parts_index)

    def _cells_within(self, lo_ns: int, hi_ns: int) -> slice:
        """Cells lying entirely inside [lo, hi]."""
        self._consolidate()
        first = -(-lo_ns // self.cell_ns)  # ceil
        last = hi_ns // self.cell_ns - 1
        i0 = int(np.searchsorted(self._index, first, side='left'))
        i1 = int(np.searchsorted(self._index, last, side='right'))
        return slice(i0, max(i0, i1))

    def count_at(self, t_ns: int, half_width_ns: int, lo_ns: int, hi_ns: int,
                 min_samples: int, *, min_transitions: float = 0.0,
                 max_half_width_ns: int = 0) -> LocalCount | None:
        """Count at ``t_ns`` from a line through the cells within ±half-width inside [lo, hi].

        A slow output (fewer than ``min_transitions`` count transitions in the window) gets
        a wider window, up to ±``max_half_width_ns``, so that its quantisation averages down;
        so does a low sample rate (fewer than ``min_samples`` samples in the window).
        Returns None when the cells within ±``max_half_width_ns`` hold fewer than
        ``min_samples`` samples (a gap), or none on one side of the instant.
        """
        fit = self._fit_at(t_ns, half_width_ns, lo_ns, hi_ns, min_samples)
        if max_half_width_ns <= half_width_ns:
            return fit
        if fit is None:  # a slow sample rate (or a gap): the widest window decides
            return self._fit_at(t_ns, max_half_width_ns, lo_ns, hi_ns, min_samples)
        transitions = abs(fit.rate_counts_s) * 2.0 * half_width_ns / 1e9
        if transitions >= min_transitions:
            return fit
        wider = int(min(max_half_width_ns,
                        half_width_ns * min_transitions / max(transitions, 1.0)))
        return self._fit_at(t_ns, wider, lo_ns, hi_ns, min_samples) or fit

    def _fit_at(self, t_ns: int, half_width_ns: int, lo_ns: int, hi_ns: int,
                min_samples: int) -> LocalCount | None:
        part = self._cells_within(max(lo_ns, t_ns - half_width_ns),
                                  min(hi_ns, t_ns + half_width_ns))
        index, sums = self._index[part], self._sums[part]
        if len(index) == 0:
            return None
        mid = (index * self.cell_ns + self.cell_ns // 2)
        if not (np.any(mid < t_ns) and np.any(mid > t_ns)):
            return None
        a = (index * self.cell_ns - t_ns) / 1e9
        b = sums[:, 6] - sums[0, 6]
        n, st, stt, sc, stc, scc = (sums[:, k] for k in range(6))
        n_tot = float(np.sum(n))
        if n_tot < min_samples:
            return None
        s_t = float(np.sum(st + n * a))
        s_tt = float(np.sum(stt + 2.0 * a * st + n * a * a))
        s_c = float(np.sum(sc + n * b))
        s_tc = float(np.sum(stc + b * st + a * sc + n * a * b))
        s_cc = float(np.sum(scc + 2.0 * b * sc + n * b * b))
        t_mean, c_mean = s_t / n_tot, s_c / n_tot
        sxx = s_tt - n_tot * t_mean * t_mean
        sxy = s_tc - n_tot * t_mean * c_mean
        syy = s_cc - n_tot * c_mean * c_mean
        if sxx <= 0.0:
            return None
        slope = sxy / sxx
        intercept = c_mean - slope * t_mean
        rss = max(syy - slope * sxy, 0.0)
        s2 = rss / (n_tot - 2.0) if n_tot > 2 else 0.0
        se2 = s2 * (1.0 / n_tot + t_mean * t_mean / sxx)
        # integer counts: each count transition in the window is one independent look at the
        # ±½-count quantisation; with few transitions the residuals cannot show it
        span_s = float(np.sqrt(12.0 * sxx / n_tot))
        looks = min(n_tot, 1.0 + abs(slope) * span_s)
        se = float(np.sqrt(max(se2, 1.0 / (12.0 * looks))))
        return LocalCount(float(sums[0, 6]) + intercept, se, int(n_tot), float(np.sqrt(s2)),
                          slope, span_s)

    def cell_sizes(self, lo_ns: int, hi_ns: int) -> npt.NDArray[np.float64]:
        """Samples in each cell lying entirely inside [lo, hi]."""
        return self._sums[self._cells_within(lo_ns, hi_ns), 0]

    def cell_rates(self, lo_ns: int, hi_ns: int) -> tuple[npt.NDArray[np.int64],
                                                         npt.NDArray[np.float64]]:
        """Start stamps (ns) and least-squares output rates (counts/s) of the cells in [lo, hi].

        Cells with fewer than three samples are left out.
        """
        part = self._cells_within(lo_ns, hi_ns)
        index, sums = self._index[part], self._sums[part]
        n, st, stt, sc, stc = (sums[:, k] for k in range(5))
        ok = n >= 3
        with np.errstate(invalid='ignore', divide='ignore'):
            sxx = stt - st * st / n
            rate = (stc - st * sc / n) / sxx
        ok &= sxx > 0
        return index[ok] * self.cell_ns, rate[ok]
