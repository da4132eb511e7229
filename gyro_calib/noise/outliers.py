"""Spikes in a noise record: found by median ± k·1.4826·MAD, reported, removed on request.

METHODS §E.6. Each channel's samples are screened segment by segment in fixed blocks of
``outlier_block_samples`` samples (counted from the segment's first sample, so the result
does not depend on how the record was chunked): within a block the statistic d — the rate
sample of an Imu axis, the per-sample increment of a pulse or FOG count — is a spike when

    |d − median(d)| > k · 1.4826 · median(|d − median(d)|)        (E.6-1)

(Stable32's outlier recognition, k = ``outlier_sigma``). A short last block (fewer samples
than a block) takes its median and MAD from the last ``outlier_block_samples`` samples of
the segment, itself included. When the MAD is 0 (most samples of a quantised output equal)
the scale is 1.2533 · mean|d − median| (the same σ for Gaussian data), and at least the
data's step (an LSB, one pulse: the smallest non-zero |d − median| held by 0.1 % of the
block's samples).

A rate spike is replaced by the median of the non-spike samples among its 8 nearest
neighbours in the block (the block median when all are spikes): (E.6-2). A count's spike
increments are repaired run by run (E.6-3): a transient (the run's sum is ordinary: a
count read wrong and then right again) is interpolated across, a jump is replaced as
(E.6-2) and so taken out of the count after it. The estimator takes a replaced sample
exactly: the record stays evenly sampled and no segment is cut (a gap would end the
segment and lose the longest averaging times).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]
    BoolArray = npt.NDArray[np.bool_]

MAD_TO_SIGMA = 1.4826
"""σ of a Gaussian per MAD (1/Φ⁻¹(3/4))."""
MEAN_ABS_TO_SIGMA = 1.2533
"""σ of a Gaussian per mean absolute deviation (√(π/2)): the scale when the MAD is 0."""
NEIGHBOURS = 4
"""A spike is replaced by the median of the non-spike samples within this many each side."""
STEP_SHARE = 1e-3
"""A non-zero |d − median| held by at least this share of a block's samples is the data's
step (when the MAD is 0), not a spike."""
FIRST_STAMPS = 5
"""Stamps of the first spikes kept for the report."""
OUTLIER_MODES = ('keep', 'remove')
"""``outliers``: keep the data as recorded (default) or replace the spikes."""


SELECT_MIN = 4096
"""Blocks at least this long take their medians by selection within a bracket (below)."""
SELECT_STRIDE = 32
"""Every this many-th sample of a block is sorted to bracket its median."""


def _middle(d: FloatArray, flags: BoolArray | None = None) -> float:
    """``np.median(d)`` exactly (the same float), at a fraction of its cost on long blocks.

    The median is selected among the samples within a bracket read from a sorted strided
    sample (about 1/8 of the block), not from the whole block; when the bracket misses the
    middle ranks (an ordered or periodic block can fool the sample) or the block holds a
    NaN, ``np.median`` decides. Either way the value is the k-th order statistic (the mean
    of the two middle ones for an even length), so it is the same float; only the sign of
    a zero median can differ (equal values in another order), which no result sees.
    ``flags``: a 2 × len(d) boolean work array (None: fresh ones; a fresh array of a block's
    size costs page faults, more than the selection itself).
    """
    n = len(d)
    if n < SELECT_MIN:
        return float(np.median(d))
    k_hi = n // 2
    k_lo = k_hi - 1 if n % 2 == 0 else k_hi
    sample = np.sort(d[::SELECT_STRIDE])
    s = len(sample)
    reach = 3 * math.isqrt(s) + 2  # ±6 σ of the sample rank of the median
    lo = sample[max(s // 2 - reach, 0)]
    hi = sample[min(s // 2 + reach, s - 1)]
    if flags is None:
        flags = np.empty((2, n), dtype=bool)
    low = np.less(d, lo, out=flags[0, :n])
    high = np.greater(d, hi, out=flags[1, :n])
    below = int(np.count_nonzero(low))
    above = int(np.count_nonzero(high))
    if below > k_lo or n - above <= k_hi:
        return float(np.median(d))
    np.logical_or(low, high, out=low)
    inside = np.compress(np.logical_not(low, out=low), d)  # lo ≤ d ≤ hi, and any NaN
    if np.isnan(inside).any():
        return float(np.median(d))
    r = k_lo - below
    if k_hi == k_lo:
        return float(np.partition(inside, r)[r])
    part = np.partition(inside, (r, r + 1))
    return float((part[r] + part[r + 1]) / 2.0)


_WORK: dict[tuple[int, int], tuple[FloatArray, BoolArray]] = {}


def _block_work(block: int) -> tuple[FloatArray, BoolArray]:
    """This thread's work arrays for a block: |d − median| and the selection's flags.

    Shared by every screen of the thread (each uses them only while it decides a block):
    an IMU's six axes hold one set, not six.
    """
    key = (threading.get_ident(), block)
    work = _WORK.get(key)
    if work is None:
        work = _WORK[key] = (np.empty(block), np.empty((2, block), dtype=bool))
    return work


def _robust(d: FloatArray, work: tuple[FloatArray, BoolArray] | None = None
            ) -> tuple[float, float, bool, FloatArray]:
    """(median, robust σ, MAD was 0, |d − median|) of ``d``: (E.6-1).

    ``work``: a float array and a 2-row boolean array at least len(d) long for |d − median|
    and the selection (None: fresh ones).
    """
    if not len(d):
        return math.nan, 0.0, False, np.zeros(0)
    flags = work[1] if work is not None else None
    med = _middle(d, flags)
    dev = np.subtract(d, med, out=work[0][:len(d)] if work is not None else None)
    np.abs(dev, out=dev)
    scale = MAD_TO_SIGMA * _middle(dev, flags)
    if scale > 0.0:
        return med, scale, False, dev
    scale = MEAN_ABS_TO_SIGMA * float(np.mean(dev))
    # the data's step (an LSB, one pulse) is the least scale: noise below one step shows as
    # ±1-step values, not as spikes; the step is the smallest non-zero |d − median| that
    # is common (at least STEP_SHARE of the samples: a spike is not a step)
    values, counts = np.unique(dev[dev > 0.0], return_counts=True)
    common = values[counts >= max(2.0, STEP_SHARE * len(d))]
    if len(common):
        scale = max(scale, float(common[0]))
    return med, scale, True, dev


def robust_center_scale(d: FloatArray) -> tuple[float, float, bool]:
    """Median and robust σ of ``d``: (E.6-1); scale 0 when all are equal.

    Returns:
        (median, 1.4826·MAD — when the MAD is 0, 1.2533·mean|d − median| and at least the
        data's step —, whether the MAD was 0).
    """
    med, scale, mad_zero, _ = _robust(d)
    return med, scale, mad_zero


def replace_spikes(d: FloatArray, spikes: BoolArray, center: float) -> FloatArray:
    """``d`` with each spike replaced by the median of its non-spike neighbours: (E.6-2)."""
    out = d.copy()
    idx = np.flatnonzero(spikes)
    if not len(idx):
        return out
    offsets = np.concatenate((np.arange(-NEIGHBOURS, 0), np.arange(1, NEIGHBOURS + 1)))
    near = idx[:, None] + offsets[None, :]
    inside = (near >= 0) & (near < len(d))
    near_c = np.clip(near, 0, len(d) - 1)
    usable = inside & ~spikes[near_c]
    vals = np.where(usable, d[near_c], np.nan)
    has = usable.any(axis=1)
    repl = np.full(len(idx), center)
    if has.any():
        repl[has] = np.nanmedian(vals[has], axis=1)
    out[idx] = repl
    return out


def repair_increments(d: FloatArray, spikes: BoolArray, center: float, scale: float,
                      k: float) -> FloatArray:
    """Increments of a count with its spikes repaired: (E.6-3).

    A run of L consecutive spike increments whose sum lies within k·scale·√L of L·median
    is a transient (a count read wrong, then right again: a glitch): the count across it is
    interpolated linearly (each increment becomes the run's mean), so the count after it
    is unchanged. Otherwise the run is a jump (pulses gained or lost): each increment is
    replaced as (E.6-2), which takes the jump out of the count after it.
    """
    out = replace_spikes(d, spikes, center)
    idx = np.flatnonzero(spikes)
    if not len(idx):
        return out
    starts = np.concatenate(([0], np.flatnonzero(np.diff(idx) != 1) + 1))
    length = np.diff(np.concatenate((starts, [len(idx)])))
    total = np.add.reduceat(d[idx], starts)
    glitch = np.abs(total - length * center) <= k * scale * np.sqrt(length)
    mean = np.repeat(np.where(glitch, total / length, np.nan), length)
    use = np.repeat(glitch, length)
    out[idx[use]] = mean[use]
    return out


@dataclass(slots=True)
class OutlierTally:
    """What the screen found on one channel (the report's numbers).

    Attributes:
        screened: samples screened (with a statistic: the first count of a segment has none).
        spikes: samples beyond k robust σ.
        largest_sigma: the largest |d − median| in robust σ of any sample (spike or not).
        largest_ns: its stamp.
        first: (stamp, robust σ) of the first :data:`FIRST_STAMPS` spikes.
        blocks: blocks screened.
        mad_zero_blocks: blocks whose MAD was 0 (scale from the mean absolute deviation).
        first_scale: robust σ of the first block.
    """

    screened: int = 0
    spikes: int = 0
    largest_sigma: float = 0.0
    largest_ns: int = -1
    first: list[tuple[int, float]] = field(default_factory=list)
    blocks: int = 0
    mad_zero_blocks: int = 0
    first_scale: float = math.nan


@dataclass(slots=True)
class OutlierScreen:
    """Holds one segment's samples in blocks and screens each block: METHODS §E.6.

    Attributes:
        kind: 'rate' (the samples are the statistic) or 'phase' (their increments are).
        sigma: k of (E.6-1).
        block: samples per block.
    """

    kind: str
    sigma: float
    block: int
    tally: OutlierTally = field(default_factory=OutlierTally)
    _t: list[IntArray] = field(default_factory=list)
    _v: list[FloatArray] = field(default_factory=list)
    _held: int = 0
    _prev: float = math.nan
    _offset: float = 0.0
    _tail: FloatArray | None = None
    _stat: FloatArray | None = None
    """The statistic of the last full block (its tail is :attr:`_tail`), reused block by block."""

    @property
    def held(self) -> int:
        """Samples waiting for their block to fill."""
        return self._held

    def nbytes(self) -> int:
        """Bytes held: the open block's stamps and values, the last block's statistic.

        (Not counted: two work arrays of a block, |d − median| and the selection's flags.)
        """
        tail = self._stat.nbytes if self._stat is not None else 0
        if self._tail is not None and (self._stat is None or self._tail.base is not self._stat):
            tail = max(tail, self._tail.nbytes)
        return sum(a.nbytes for a in (*self._t, *self._v)) + tail

    def push(self, t: IntArray, v: FloatArray) -> list[tuple[IntArray, FloatArray, FloatArray]]:
        """Samples of the open segment, in order; returns the blocks decided (see decide)."""
        self._t.append(t)
        self._v.append(v)
        self._held += len(t)
        out = []
        while self._held >= self.block:
            out.append(self._decide(self.block))
        return out

    def end_segment(self) -> list[tuple[IntArray, FloatArray, FloatArray]]:
        """The segment ends: decide what is held (a short last block); start afresh."""
        out = [self._decide(self._held)] if self._held else []
        self._prev, self._offset, self._tail = math.nan, 0.0, None
        return out

    def _take(self, n: int) -> tuple[IntArray, FloatArray]:
        """The next n held samples: views of the pushed arrays, copied only across two."""
        t0, v0 = self._t[0], self._v[0]
        self._held -= n
        if len(t0) >= n:
            if len(t0) > n:
                self._t[0], self._v[0] = t0[n:], v0[n:]
            else:
                del self._t[0], self._v[0]
            return t0[:n], v0[:n]
        ts, vs, got = [], [], 0
        while got < n:
            ta, va = self._t[0], self._v[0]
            need = n - got
            if len(ta) > need:
                ts.append(ta[:need])
                vs.append(va[:need])
                self._t[0], self._v[0] = ta[need:], va[need:]
                got = n
            else:
                ts.append(ta)
                vs.append(va)
                del self._t[0], self._v[0]
                got += len(ta)
        return np.concatenate(ts), np.concatenate(vs)

    def _decide(self, n: int) -> tuple[IntArray, FloatArray, FloatArray]:
        """Screen the next n held samples: (stamps, values as recorded, values cleaned)."""
        t, v = self._take(n)
        full = n == self.block
        if full and self._stat is None:
            self._stat = np.empty(self.block)
        has: BoolArray | None = None
        if self.kind == 'rate':
            d = dv = v
            t_v = t
        else:
            # a full block's increments go to the reused array (the next full block is the
            # first to overwrite them, and replaces the tail they hold); a short one's are new
            d = self._stat if full and self._stat is not None else np.empty(n)
            d[0] = v[0] - self._prev
            np.subtract(v[1:], v[:-1], out=d[1:])
            has = np.isfinite(d)
            if has[1:].all():  # the usual case: only a segment's first increment is missing
                dv, t_v = (d, t) if has[0] else (d[1:], t[1:])
            else:
                dv, t_v = d[has], t[has]
            self._prev = float(v[-1])
        ref = dv
        if n < self.block and self._tail is not None:  # a short last block: the last W samples
            ref = np.concatenate((self._tail[len(self._tail) - (self.block - len(dv)):], dv))
        center, scale, mad_zero, dev = _robust(ref, _block_work(self.block))
        tail = ref[-self.block:] if len(ref) >= self.block else ref
        if has is None and full and self._stat is not None:  # rate samples are the caller's
            self._tail = self._stat[:len(tail)]
            np.copyto(self._tail, tail)
        else:
            self._tail = tail if has is not None else tail.copy()
        if ref is not dv:
            dev = np.abs(dv - center)
        threshold = self.sigma * scale
        top = int(np.argmax(dev)) if len(dev) and scale > 0.0 else -1
        if top >= 0 and not dev[top] <= threshold:
            spikes_v = dev > threshold
        else:  # no sample beyond the threshold (the usual case): no mask needed
            spikes_v = None
        self._count(t_v, dev, scale, spikes_v, mad_zero, top)
        if spikes_v is None or not spikes_v.any():
            offset = self._offset
            if self.kind == 'phase' and (offset != 0.0 or math.copysign(1.0, offset) < 0):
                return t, v, v - offset
            return t, v, v  # v − (+0.0) is v, bit for bit: nothing to copy or compare
        if has is None:
            return t, v, replace_spikes(dv, spikes_v, center)
        d_clean = d.copy()
        d_clean[has] = repair_increments(dv, spikes_v, center, scale, self.sigma)
        change = np.where(has, d - d_clean, 0.0)
        shift = self._offset + np.cumsum(change)
        self._offset = float(shift[-1])
        return t, v, v - shift

    def _count(self, t: IntArray, dev: FloatArray, scale: float, spikes: BoolArray | None,
               mad_zero: bool, top: int) -> None:
        """Tally one block; ``top`` is the index of the largest ``dev`` (−1: none or scale 0)."""
        tl = self.tally
        if tl.blocks == 0:
            tl.first_scale = scale
        tl.blocks += 1
        tl.screened += len(dev)
        tl.mad_zero_blocks += int(mad_zero)
        if top >= 0:
            z = float(dev[top]) / scale
            if z > tl.largest_sigma:
                tl.largest_sigma, tl.largest_ns = z, int(t[top])
        if spikes is None:
            return
        n = int(np.count_nonzero(spikes))
        tl.spikes += n
        if n and len(tl.first) < FIRST_STAMPS:
            for i in np.flatnonzero(spikes)[:FIRST_STAMPS - len(tl.first)]:
                tl.first.append((int(t[i]), float(dev[i]) / scale))


def adev_at(tau_s: FloatArray, adev: FloatArray, at_s: float = 1.0) -> float:
    """ADEV at ``at_s`` by log-log interpolation of the curve (NaN outside it)."""
    ok = np.isfinite(adev) & (adev > 0)
    tau, dev = tau_s[ok], adev[ok]
    if not len(tau) or not tau[0] <= at_s <= tau[-1]:
        return math.nan
    return float(np.exp(np.interp(math.log(at_s), np.log(tau), np.log(dev))))


def _change(kept: float, removed: float) -> float | None:
    if not (math.isfinite(kept) and math.isfinite(removed)) or kept == 0:
        return None
    return removed / kept - 1.0


@dataclass(frozen=True, slots=True)
class OutlierReport:
    """The spikes of one axis and what removing them changes (METHODS §E.6).

    Attributes:
        axis: the axis.
        mode: the ``outliers`` setting used ('keep' or 'remove').
        sigma: k.
        block: samples per block.
        statistic: 'rate' or 'increment' (of a pulse or FOG count).
        tally: the counts, the largest, the first stamps.
        adev_1s: (ADEV at τ = 1 s as recorded, with the spikes removed), rate unit; NaN
            when the curve does not reach 1 s or has no spike.
        terms: term key → (value as recorded, with the spikes removed); NaN where the fit
            did not resolve the term.
        symbols: term key → its symbol (N, B …) for the line.
    """

    axis: str
    mode: str
    sigma: float
    block: int
    statistic: str
    tally: OutlierTally
    adev_1s: tuple[float, float] = (math.nan, math.nan)
    terms: dict[str, tuple[float, float]] = field(default_factory=dict)
    symbols: dict[str, str] = field(default_factory=dict)

    def record(self) -> dict[str, object]:
        """The ``--json`` record (``axes.AXIS.outliers``): stamps in s, changes as fractions."""
        tl = self.tally

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        out: dict[str, object] = {
            'mode': self.mode, 'sigma': self.sigma, 'block_samples': self.block,
            'statistic': self.statistic, 'screened': tl.screened, 'found': tl.spikes,
            'fraction': tl.spikes / tl.screened if tl.screened else 0.0,
            'largest_sigma': tl.largest_sigma,
            'largest_stamp_s': tl.largest_ns / 1e9 if tl.largest_ns >= 0 else None,
            'first_stamps_s': [ns / 1e9 for ns, _ in tl.first],
            'first_sigma': [z for _, z in tl.first],
            'mad_zero_blocks': tl.mad_zero_blocks,
        }
        if tl.spikes:
            k, r = self.adev_1s
            out['adev_1s'] = {'recorded': num(k), 'removed': num(r), 'change': _change(k, r)}
            out['terms'] = {key: {'recorded': num(k), 'removed': num(r),
                                  'change': _change(k, r)}
                            for key, (k, r) in self.terms.items()}
        return out

    def changes_words(self, other: str = 'without them') -> str:
        """'ADEV(1 s) −16 %, N −17 %, B −3.1 %' (what removing the spikes changes)."""
        parts = []
        c = _change(*self.adev_1s)
        if c is not None:
            parts.append(f'ADEV(1 s) {100 * c:+.3g} %')
        for key, (k, r) in self.terms.items():
            c = _change(k, r)
            sym = self.symbols.get(key, key)
            if c is not None:
                parts.append(f'{sym} {100 * c:+.3g} %')
            elif math.isfinite(k) != math.isfinite(r):
                gone = (f'resolved only {other}' if math.isfinite(r)
                        else f'not resolved {other}')
                parts.append(f'{sym} {gone}')
        return ', '.join(parts) or 'nothing measurable'

    def rule(self) -> str:
        """'beyond 8 robust σ (|d − median| > 8·1.4826·MAD, d = the rate, per block …)'."""
        what = ('the rate' if self.statistic == 'rate'
                else "the count's per-sample increment")
        return (f'beyond {self.sigma:g} robust σ (|d − median| > {self.sigma:g}·1.4826·MAD, '
                f'd = {what}, per block of {self.block} samples)')

    def line(self) -> str:
        """The summary line: always, spikes or none."""
        tl = self.tally
        rule = self.rule()
        if not tl.spikes:
            largest = f'; the largest {tl.largest_sigma:.3g} σ' if tl.screened else ''
            return f'{self.axis}: spikes: none of {tl.screened} samples {rule}{largest}.'
        pct = 100.0 * tl.spikes / tl.screened
        firsts = ', '.join(f'{ns // 1_000_000_000}.{ns % 1_000_000_000:09d} s ({z:.3g} σ)'
                           for ns, z in tl.first)
        if self.mode == 'remove':
            how = ('each was replaced by the median of its neighbours' if self.statistic == 'rate'
                   else 'the count was interpolated across each glitch and each jump taken out')
            tail = f'outliers = remove: {how}; keeping them would change {self.reverse_words()}'

        else:
            tail = ('outliers = keep: the terms above are of the record as recorded; '
                    f'removing them would change {self.changes_words()}')
        return (f'{self.axis}: spikes: {tl.spikes} of {tl.screened} samples ({pct:.3g} %) '
                f'{rule}; the largest {tl.largest_sigma:.4g} σ at '
                f'{tl.largest_ns // 1_000_000_000}.{tl.largest_ns % 1_000_000_000:09d} s; '
                f'the first at {firsts}; {tail}.')

    @staticmethod
    def lines(reports: list[OutlierReport]) -> list[str]:
        """The summary lines of several axes: one per axis with spikes, one for all without."""
        out = [r.line() for r in reports if r.tally.spikes]
        clean = [r for r in reports if not r.tally.spikes]
        if len(clean) == 1:
            out.append(clean[0].line())
        elif clean:
            largest = ', '.join(f'{r.axis} {r.tally.largest_sigma:.3g} σ' for r in clean)
            out.append(f'{", ".join(r.axis for r in clean)}: spikes: none '
                       f'{clean[0].rule()}; the largest: {largest}.')
        return out

    def reverse_words(self) -> str:
        """What keeping the spikes changes against the record with them removed."""
        flipped = OutlierReport(self.axis, self.mode, self.sigma, self.block, self.statistic,
                                self.tally, (self.adev_1s[1], self.adev_1s[0]),
                                {k: (r, v) for k, (v, r) in self.terms.items()}, self.symbols)
        return flipped.changes_words('with them')


__all__ = ['FIRST_STAMPS', 'MAD_TO_SIGMA', 'OUTLIER_MODES', 'OutlierReport', 'OutlierScreen',
           'OutlierTally', 'adev_at', 'repair_increments', 'replace_spikes',
           'robust_center_scale']
