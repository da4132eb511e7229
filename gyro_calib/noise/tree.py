"""Streaming Allan-variance sums with memory bounded independently of the record length.

:class:`AllanTree` is a decimation tree over the phase x (the integrated signal). Level 0
holds the samples themselves and computes every small averaging factor with full overlap.
Level j ≥ 1 holds x subsampled by 2^j — exact for phase data, no averaging needed — and
computes τ = m·2^j·τ0 for m in [min_m, 2·min_m) with stride 2^j (partial overlap: at
least min_m overlapping terms within every span of m·2^j samples). Each level keeps only
its last 2·max(m) samples and one block of pending samples, so memory is
O(levels × (block + 4·min_m)) = O(log N). The partial-overlap estimate at level j is
exactly the full-overlap estimate of the subsampled series, so its equivalent degrees
of freedom follow from that series' length (see :mod:`gyro_calib.noise.edf`).

How close partial overlap stays to full overlap (``benchmarks/noise_allan.py`` (c)): the
difference is statistical, not a bias, and scales as 1/min_m. With min_m = 512 (the
default) the largest seen at τ ≤ T/4 over white, flicker and random-walk FM and a gyro
mix was 0.37 %. White PM (quantisation) alone is the exception: its second differences
are nearly independent, so a stride-2^j estimate uses 1/2^j of the information and can
differ by several per cent at long τ. In a gyro, white PM (ADEV ∝ 1/τ) dominates only at
short τ, where the tree runs at full overlap.

Samples are processed in fixed blocks of absolute sample index, so the float sums are
bit-identical however the input was chunked. :meth:`AllanTree.sums` reports without
disturbing the stream (it flushes a copy).

:class:`FullOverlapStore` keeps every phase point (memory O(N)) and gives the
full-overlap sums at every grid factor: the reference mode, equal to allantools.oadev.

:class:`PhaseReservoir` keeps at most ``2·capacity`` phase points, subsampled by a power
of two that doubles whenever it fills — the decimated record the total deviation is
computed from at long τ.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.noise.allan import AllanSums, AveragingGrid, second_difference_sums

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]

TREE_BLOCK = 16384
"""Samples per processing block at every level."""


@dataclass(slots=True)
class _Level:
    ms: npt.NDArray[np.int64]
    block: int
    tail: FloatArray = field(default_factory=lambda: np.zeros(0))
    pending: FloatArray = field(init=False)
    n_pending: int = 0
    n_done: int = 0
    sum_sq: FloatArray = field(init=False)
    terms: npt.NDArray[np.int64] = field(init=False)

    def __post_init__(self) -> None:
        self.pending = np.empty(self.block)
        self.sum_sq = np.zeros(len(self.ms))
        self.terms = np.zeros(len(self.ms), dtype=np.int64)

    @property
    def n_samples(self) -> int:
        return self.n_done + self.n_pending


class AllanTree:
    """Decimation tree of partial-overlap Allan sums (see module docstring)."""

    def __init__(self, grid: AveragingGrid, block: int = TREE_BLOCK) -> None:
        """Create level 0 for ``grid``; higher levels appear as samples reach them."""
        self.grid = grid
        self.block = block
        self._levels: list[_Level] = [_Level(np.asarray(grid.level0, dtype=np.int64), block)]
        self._tail_len = [2 * max(grid.level0), 2 * max(grid.level)]

    @property
    def n_samples(self) -> int:
        """Phase points pushed so far."""
        return self._levels[0].n_samples

    def push(self, x: npt.ArrayLike) -> None:
        """Append level-0 phase points (in order)."""
        self._push(0, np.asarray(x, dtype=np.float64))

    def _push(self, j: int, x: FloatArray) -> None:
        lv = self._levels[j]
        i, n = 0, len(x)
        if lv.n_pending:
            take = min(self.block - lv.n_pending, n)
            lv.pending[lv.n_pending:lv.n_pending + take] = x[:take]
            lv.n_pending += take
            i = take
            if lv.n_pending == self.block:
                lv.n_pending = 0
                self._process(j, lv.pending.copy())
        while n - i >= self.block:
            self._process(j, x[i:i + self.block])
            i += self.block
        if i < n:
            rest = n - i
            lv.pending[lv.n_pending:lv.n_pending + rest] = x[i:]
            lv.n_pending += rest

    def _process(self, j: int, blk: FloatArray, flushing: bool = False) -> None:
        lv = self._levels[j]
        buf = np.concatenate((lv.tail, blk)) if len(lv.tail) else np.asarray(blk)
        g0 = lv.n_done - len(lv.tail)
        end = lv.n_done + len(blk)
        for k, m in enumerate(lv.ms):
            m = int(m)
            lo = max(0, lv.n_done - 2 * m)
            hi = end - 2 * m
            if hi > lo:
                lv.sum_sq[k] += second_difference_sums(buf, m, lo - g0, hi - g0)
                lv.terms[k] += hi - lo
        decimated = blk[lv.n_done % 2::2]
        lv.n_done = end
        keep = self._tail_len[min(j, 1)]
        lv.tail = buf[-keep:].copy() if len(buf) > keep else buf.copy()
        if len(decimated):
            if len(self._levels) == j + 1:
                if flushing and len(decimated) <= 2 * self.grid.level[0]:
                    return  # a new level this short would compute nothing (snapshot only)
                self._levels.append(_Level(np.asarray(self.grid.level, dtype=np.int64),
                                           self.block))
            self._push(j + 1, decimated)

    def _flush(self) -> None:
        j = 0
        while j < len(self._levels):
            lv = self._levels[j]
            if lv.n_pending:
                blk = lv.pending[:lv.n_pending].copy()
                lv.n_pending = 0
                self._process(j, blk, flushing=True)
            j += 1

    def sums(self) -> AllanSums:
        """Sums for every grid factor with at least one term so far (stream undisturbed)."""
        snap = copy.deepcopy(self)
        snap._flush()
        ms, sums, terms, strides = [], [], [], []
        for j, lv in enumerate(snap._levels):
            for k, m in enumerate(lv.ms):
                if lv.terms[k]:
                    ms.append(int(m) << j)
                    sums.append(lv.sum_sq[k])
                    terms.append(int(lv.terms[k]))
                    strides.append(1 << j)
        order = np.argsort(ms, kind='stable')
        return AllanSums(np.asarray(ms, dtype=np.int64)[order],
                         np.asarray(sums, dtype=np.float64)[order],
                         np.asarray(terms, dtype=np.int64)[order],
                         np.asarray(strides, dtype=np.int64)[order], self.n_samples)

    def level_lengths(self) -> list[int]:
        """Samples held (pushed) at each level so far."""
        return [lv.n_samples for lv in self._levels]

    def nbytes(self) -> int:
        """Bytes of sample storage held (bounded: O(levels × block))."""
        return sum(lv.pending.nbytes + lv.tail.nbytes for lv in self._levels)


class FullOverlapStore:
    """Every phase point, for full-overlap sums at every grid factor (memory O(N))."""

    def __init__(self, grid: AveragingGrid) -> None:
        """Start empty."""
        self.grid = grid
        self._chunks: list[FloatArray] = []
        self._n = 0

    @property
    def n_samples(self) -> int:
        """Phase points pushed so far."""
        return self._n

    def push(self, x: npt.ArrayLike) -> None:
        """Append phase points (in order)."""
        a = np.array(x, dtype=np.float64)
        if len(a):
            self._chunks.append(a)
            self._n += len(a)

    def phase(self) -> FloatArray:
        """All phase points so far."""
        if len(self._chunks) > 1:
            self._chunks = [np.concatenate(self._chunks)]
        return self._chunks[0] if self._chunks else np.zeros(0)

    def sums(self) -> AllanSums:
        """Full-overlap sums at every grid factor m with 2m < N."""
        x = self.phase()
        ms = self.grid.factors_up_to(max((len(x) - 1) // 2, 0))
        sums = np.array([second_difference_sums(x, int(m), 0, len(x) - 2 * int(m)) for m in ms])
        return AllanSums(ms, sums.astype(np.float64), len(x) - 2 * ms, np.ones_like(ms), len(x))

    def nbytes(self) -> int:
        """Bytes of sample storage held (grows with the record)."""
        return sum(c.nbytes for c in self._chunks)


class PhaseReservoir:
    """Phase points subsampled by a power-of-two stride, at most 2·capacity of them."""

    def __init__(self, capacity: int) -> None:
        """``capacity``: the stride doubles once 2·capacity + 1 points would be held."""
        self.capacity = capacity
        self.stride = 1
        self._x = np.empty(2 * capacity + 1)
        self._n_held = 0
        self._n_seen = 0

    def push(self, x: npt.ArrayLike) -> None:
        """Offer consecutive level-0 phase points."""
        a = np.asarray(x, dtype=np.float64)
        while len(a):
            first = (-self._n_seen) % self.stride
            room = len(self._x) - self._n_held
            take_n = min(room * self.stride, len(a))
            picked = a[first:take_n:self.stride]
            self._x[self._n_held:self._n_held + len(picked)] = picked
            self._n_held += len(picked)
            self._n_seen += take_n
            a = a[take_n:]
            if self._n_held == len(self._x):
                kept = self._x[:self._n_held:2].copy()
                self._x[:len(kept)] = kept
                self._n_held = len(kept)
                self.stride *= 2

    def nbytes(self) -> int:
        """Bytes of storage (fixed: 2·capacity + 1 points)."""
        return int(self._x.nbytes)

    def phase(self) -> FloatArray:
        """The held points x_0, x_s, x_2s, ... (s = :attr:`stride`)."""
        return self._x[:self._n_held].copy()
