"""Exact full-overlap deviations of a record of any length, with bounded memory.

:class:`ExactDeviations` computes, at every requested averaging factor m, the sums of

- the overlapping Allan variance (NIST SP 1065 eq. 11): Σ_{i<N−2m} u_i², with the second
  difference u_i = x_{i+2m} − 2x_{i+m} + x_i, equal to ``allantools.oadev``;
- the overlapping Hadamard variance (SP 1065 eq. 17): Σ_{j<N−3m} T_j², with the third
  difference T_j = x_{j+3m} − 3x_{j+2m} + 3x_{j+m} − x_j (``allantools.ohdev``);
- the modified Allan variance (SP 1065 eq. 14): v_0² + Σ_{j<N−3m} v_{j+1}², with
  v_0 = Σ_{i<m} u_i and v_{j+1} = v_j + T_j (the running sum of ``allantools.mdev``);
- the total variance (SP 1065 eq. 25): the Allan sum (its terms are TOTVAR's middle terms)
  plus the m − 1 terms at each end that reach into the record reflected about its end
  points (``allantools.totdev``).

Memory. The phase points are held in memory up to ``memory_points``; beyond that every
point goes to a scratch file (deleted when the store is closed or collected) and only
the most recent ``window`` points stay in memory. The sums are accumulated in fixed
blocks of term index (``block``): a block is computed once every point it needs has
arrived, reading the older points it needs from the file at offset cursors (one read per
lag and block). Memory is therefore O(window + block), however long the record; the file
holds 8 bytes per point. The float sums depend only on the sample sequence, not on how it
was chunked or when :meth:`ExactDeviations.sums` was asked (the open last block is summed
into a copy).

Time: one pass over the record per averaging factor and statistic (``benchmarks/
noise_allan.py``).
"""

from __future__ import annotations

import os
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]

EXACT_BLOCK = 1 << 15
"""Terms per block of every sum (256 KiB of phase: a block and its differences stay in the
L2 cache; 2¹⁵ was the fastest of 2¹³–2¹⁷ in ``benchmarks/noise_allan.py``)."""
ADVANCE_BLOCKS = 16
"""Blocks of new points gathered before the sums advance: every factor then sweeps them in
one go while they are in memory (fewer calls, less thread hand-over)."""
DOT_PIECE = 8192
"""Longest dot product handed to BLAS at once: OpenBLAS runs longer ones multi-threaded,
which on a loaded machine costs ~50× (measured: 45 ns/element at 65 536 vs 0.9 at 8192)."""
DEVIATIONS = ('adev', 'mdev', 'hdev', 'totdev')
"""The statistics :class:`ExactDeviations` can compute."""
THREADS = min(2, os.cpu_count() or 1)
"""Averaging factors summed in parallel when MDEV or HDEV is asked for (NumPy releases the
GIL in its loops; each factor's sums stay in one thread, in block order, so they are the
same however many threads). The ADEV alone runs in one thread: its three memory-bound passes
per block gain nothing from a second one and lose to the hand-over (1.03 s against 1.44 s
for 3·10⁷ points, 23 factors)."""

_POOL: ThreadPoolExecutor | None = None
_BUFFERS: dict[tuple[int, int], tuple[FloatArray, FloatArray]] = {}
_LOCK = threading.Lock()


def _pool() -> ThreadPoolExecutor:
    global _POOL
    with _LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(THREADS, thread_name_prefix='gyro_calib_allan')
        return _POOL


def _buffers(block: int) -> tuple[FloatArray, FloatArray]:
    """Work and read buffers of this thread for ``block``.

    Work and read buffers of this thread for ``block`` (reused: fresh large temporaries
    cost page faults).
    """
    key = (threading.get_ident(), block)
    bufs = _BUFFERS.get(key)
    if bufs is None:
        bufs = (np.empty((3, 2 * block)), np.empty((4, 3 * block)))
        with _LOCK:
            _BUFFERS[key] = bufs
    return bufs


def _sumsq(u: FloatArray) -> float:
    """Σu², in pieces of :data:`DOT_PIECE` (fixed boundaries: reproducible)."""
    total = 0.0
    for a in range(0, len(u), DOT_PIECE):
        p = u[a:a + DOT_PIECE]
        total += float(np.dot(p, p))
    return total


class ScratchPhase:
    """Phase points of one segment: in memory while few, then in a scratch file."""

    def __init__(self, memory_points: int, window: int, directory: str | None = None) -> None:
        """Hold up to ``memory_points`` in memory; beyond, keep the last ``window`` there."""
        self.memory_points = memory_points
        self.window = window
        self.directory = directory
        self._buf = np.empty(max(1024, min(memory_points, 1 << 16)))
        self._start = 0  # global index of _buf[0]
        self._len = 0  # points in _buf
        self._n = 0
        self._file: int | None = None
        self._frozen = False  # a snapshot's copy: the file is read-only, new points stay

    def __len__(self) -> int:
        """Points pushed so far."""
        return self._n

    def __deepcopy__(self, memo: dict[int, object]) -> ScratchPhase:
        """A copy that shares the scratch file read-only.

        A copy that shares the scratch file read-only (a duplicated descriptor, reads by
        offset) and keeps the points pushed to it afterwards in memory: snapshots of a live
        stream (copy, flush, fit) cost no copy of the file and leave it untouched.
        """
        new = ScratchPhase.__new__(ScratchPhase)
        new.memory_points, new.window, new.directory = (self.memory_points, self.window,
                                                        self.directory)
        new._buf = self._buf.copy()
        new._start, new._len, new._n = self._start, self._len, self._n
        new._file = os.dup(self._file) if self._file is not None else None
        new._frozen = self._file is not None
        return new

    def thaw(self) -> None:
        """Make a snapshot's copy a store of its own (a channel's shadow, METHODS §E.6).

        Its points go into a scratch file of its own (one copy); new points are written there.
        """
        if not self._frozen or self._file is None:
            return
        fd, name = tempfile.mkstemp(prefix='gyro_calib_phase_', suffix='.f64',
                                    dir=self.directory)
        os.unlink(name)
        old, self._file = self._file, fd
        step = 1 << 20
        for lo in range(0, self._start, step):
            hi = min(lo + step, self._start)
            chunk = np.empty(hi - lo)
            got = os.preadv(old, [chunk.data.cast('B')], 8 * lo)
            if got != 8 * (hi - lo):
                raise OSError(f'short read from the phase scratch file ({got} bytes)')
            self._write(chunk)
        self._write(self._buf[:self._len])
        os.close(old)
        self._frozen = False

    @property
    def spilled(self) -> bool:
        """The points are in a scratch file."""
        return self._file is not None

    def push(self, x: FloatArray) -> None:
        """Append points (in order)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        if not len(x):
            return
        if self._frozen:  # a snapshot: keep every new point in memory, write nothing
            self._append_in_memory(x)
            return
        if self._file is None and self._n + len(x) > self.memory_points:
            fd, name = tempfile.mkstemp(prefix='gyro_calib_phase_', suffix='.f64',
                                        dir=self.directory)
            os.unlink(name)  # the file lives as long as the descriptor
            self._file = fd
            self._write(self._buf[:self._len])
        if self._file is not None:
            self._write(x)
        need = self._len + len(x)
        cap = len(self._buf)
        if need > cap:
            if self._file is None:
                grow = np.empty(max(need, 2 * cap))
                grow[:self._len] = self._buf[:self._len]
                self._buf = grow
            else:
                keep = min(self._len, self.window)
                if keep + len(x) > cap:
                    grow = np.empty(max(keep + len(x), 2 * self.window))
                    grow[:keep] = self._buf[self._len - keep:self._len]
                    self._buf = grow
                else:
                    self._buf[:keep] = self._buf[self._len - keep:self._len]
                self._start += self._len - keep
                self._len = keep
        self._buf[self._len:self._len + len(x)] = x
        self._len += len(x)
        self._n += len(x)

    def _append_in_memory(self, x: FloatArray) -> None:
        need = self._len + len(x)
        if need > len(self._buf):
            grow = np.empty(max(need, 2 * len(self._buf)))
            grow[:self._len] = self._buf[:self._len]
            self._buf = grow
        self._buf[self._len:need] = x
        self._len = need
        self._n += len(x)

    def _write(self, x: FloatArray) -> None:
        assert self._file is not None
        data = np.ascontiguousarray(x).data.cast('B')
        done = 0
        while done < len(data):
            done += os.write(self._file, data[done:])

    def read(self, lo: int, hi: int, out: FloatArray | None = None) -> FloatArray:
        """Points lo ≤ i < hi, from memory or the file.

        Points lo ≤ i < hi: a view when in memory, else read from the file (into ``out``
        when given and long enough).
        """
        if lo >= self._start:
            return self._buf[lo - self._start:hi - self._start]
        assert self._file is not None
        dest = out[:hi - lo] if out is not None and len(out) >= hi - lo else np.empty(hi - lo)
        got = os.preadv(self._file, [dest.data.cast('B')], 8 * lo)
        if got != 8 * (hi - lo):
            raise OSError(f'short read from the phase scratch file ({got} bytes)')
        return dest

    def nbytes(self) -> int:
        """Bytes held in memory."""
        return int(self._buf.nbytes)

    def close(self) -> None:
        """Delete the scratch file and free the memory."""
        if self._file is not None:
            os.close(self._file)
            self._file = None
        self._buf = np.empty(0)
        self._len = 0

    def __del__(self) -> None:
        """The scratch file goes with the store."""
        if getattr(self, '_file', None) is not None:
            os.close(self._file)  # type: ignore[arg-type]


_Kept = dict[tuple[int, int], tuple['FloatArray', 'FloatArray']]
"""Slices read from the scratch file in one sweep, by (lo, hi): (the slice, its buffer)."""


@dataclass(slots=True)
class _Factor:
    """Committed sums of one averaging factor."""

    m: int
    adev_sum: float = 0.0
    adev_done: int = 0
    hdev_sum: float = 0.0
    mdev_sum: float = 0.0
    mdev_carry: float = 0.0
    third_done: int = 0
    mdev_started: bool = False
    left_edge: float | None = None


@dataclass(frozen=True, slots=True)
class DeviationSums:
    """Raw sums of one segment per averaging factor (phase unit²; NaN where no term).

    Attributes:
        m: averaging factors, samples.
        adev_sum, adev_terms: Σu² and N − 2m.
        mdev_sum, mdev_terms: v_0² + Σv² and N − 3m + 1.
        hdev_sum, hdev_terms: ΣT² and N − 3m.
        totdev_sum, totdev_terms: the reflected-record sum and N − 2.
        n_points: phase points N.
    """

    m: IntArray
    adev_sum: FloatArray
    adev_terms: IntArray
    mdev_sum: FloatArray
    mdev_terms: IntArray
    hdev_sum: FloatArray
    hdev_terms: IntArray
    totdev_sum: FloatArray
    totdev_terms: IntArray
    n_points: int


class ExactDeviations:
    """Streaming exact sums of ADEV, MDEV, HDEV and TOTDEV (see module docstring)."""

    def __init__(self, factors_up_to: Callable[[int], IntArray], max_fraction: float, *,
                 deviations: tuple[str, ...] = DEVIATIONS, block: int = EXACT_BLOCK,
                 memory_points: int = 1 << 20, scratch_dir: str | None = None) -> None:
        """Create an empty store.

        Args:
            factors_up_to: the averaging factors of the τ grid not above a bound, ascending.
            max_fraction: factors m ≤ max_fraction·(N − 1) are computed.
            deviations: which of :data:`DEVIATIONS` to compute ('adev' always is).
            block: terms per block.
            memory_points: phase points held in memory before the scratch file is used.
            scratch_dir: directory of the scratch file (None: the system's temporary one).
        """
        self.factors_up_to = factors_up_to
        self.max_fraction = max_fraction
        self.deviations = tuple(d for d in DEVIATIONS if d in deviations or d == 'adev')
        self._third = 'mdev' in self.deviations or 'hdev' in self.deviations
        self._threads = THREADS if self._third else 1
        self.block = block
        self.phase = ScratchPhase(memory_points, (ADVANCE_BLOCKS + 4) * block, scratch_dir)
        self._factors: dict[int, _Factor] = {}
        self._processed_to = 0
        self._reuse: tuple[_Kept, _Kept] | None = None
        self._spare: list[FloatArray] = []  # block buffers of reused slices

    @property
    def n_samples(self) -> int:
        """Phase points pushed so far."""
        return len(self.phase)

    def nbytes(self) -> int:
        """Bytes of sample storage in memory (bounded once the scratch file is in use)."""
        return (self.phase.nbytes() + (THREADS + 1) * 18 * 8 * self.block  # + work buffers
                + 8 * self.block * len(self._spare))  # + slices shared by factors m and 2m

    def close(self) -> None:
        """Free the scratch file (the sums already computed stay valid in copies)."""
        self.phase.close()

    def push(self, x: npt.ArrayLike) -> None:
        """Append phase points (in order).

        Append phase points (in order); complete blocks are summed as they fill (while
        the points they need are still in memory).
        """
        a = np.asarray(x, dtype=np.float64)
        for lo in range(0, len(a), self.block):
            self.phase.push(a[lo:lo + self.block])
            if len(self.phase) - self._processed_to >= ADVANCE_BLOCKS * self.block:
                self._advance()

    # -- block sums ------------------------------------------------------------------------
    def _active(self) -> list[_Factor]:
        n = len(self.phase)
        m_max = int(self.max_fraction * (n - 1))
        for m in self.factors_up_to(m_max):
            m = int(m)
            if m >= 1 and 2 * m < n and m not in self._factors:
                self._factors[m] = _Factor(m)
        return [f for f in self._factors.values() if 2 * f.m < n]

    def _advance(self) -> None:
        n = len(self.phase)
        facs = self._active()
        if self._threads > 1 and len(facs) > 1:
            list(_pool().map(lambda f: self._advance_factor(f, n), facs))
        else:
            # ascending m: the oldest slice x_{a..} a factor m reads from the scratch file is
            # the middle slice x_{a'+2m..} of factor 2m in the same sweep; it is read once
            self._reuse = ({}, {})
            for f in sorted(facs, key=lambda f: f.m):
                self._reuse = (self._reuse[1], {})
                self._advance_factor(f, n)
                self._spare += [buf for _, buf in self._reuse[0].values()]  # not asked for
            self._spare += [buf for _, buf in self._reuse[1].values()]
            self._reuse = None
        self._processed_to = n

    def _oldest_slice(self, lo: int, hi: int, out: FloatArray) -> FloatArray:
        """x[lo:hi], read from the file, kept for the next (doubled) factor of the sweep."""
        if self._reuse is None or not self.phase.spilled:
            return self.phase.read(lo, hi, out)
        if len(self._reuse[1]) >= ADVANCE_BLOCKS + 1:  # a new factor's backlog: read it
            return self.phase.read(lo, hi, out)  # plainly, kept nowhere (memory bounded)
        spare = self._spare.pop() if self._spare else np.empty(self.block)
        x = self.phase.read(lo, hi, spare)
        if x.base is spare:
            self._reuse[1][(lo, hi)] = (x, spare)
        else:  # it was in memory
            self._spare.append(spare)
        return x

    def _middle_slice(self, lo: int, hi: int,
                      out: FloatArray) -> tuple[FloatArray, FloatArray | None]:
        """x[lo:hi] (the previous factor's oldest slice when it read this one, else read).

        Returns:
            The slice, and the buffer to free once it is used (None: nothing to free).
        """
        if self._reuse is not None:
            kept = self._reuse[0].pop((lo, hi), None)
            if kept is not None:
                return kept
        return self.phase.read(lo, hi, out), None

    def _advance_factor(self, f: _Factor, n: int) -> None:
        """Commit every complete block of one factor (one thread per factor)."""
        b = self.block
        while f.adev_done + b + 2 * f.m <= n:
            f.adev_sum += self._adev(f.m, f.adev_done, f.adev_done + b)
            f.adev_done += b
        if self._third and 3 * f.m < n:
            if not f.mdev_started:
                f.mdev_carry = self._first_cluster(f.m)
                f.mdev_sum = f.mdev_carry * f.mdev_carry
                f.mdev_started = True
            while f.third_done + b + 3 * f.m <= n:
                h, s, c = self._third_block(f.m, f.third_done, f.third_done + b,
                                            f.mdev_carry)
                f.hdev_sum += h
                f.mdev_sum += s
                f.mdev_carry = c
                f.third_done += b

    def _slices(self, m: int, lo: int, hi: int, k: int) -> list[FloatArray]:
        """x[lo + q·m : hi + q·m] for q = 0..k (hi − lo ≤ block)."""
        reads = _buffers(self.block)[1]
        if k * m <= 2 * self.block:
            x = self.phase.read(lo, hi + k * m, reads[0])
            return [x[q * m:q * m + hi - lo] for q in range(k + 1)]
        return [self.phase.read(lo + q * m, hi + q * m, reads[q]) for q in range(k + 1)]

    def _adev(self, m: int, lo: int, hi: int) -> float:
        """Σ_{lo ≤ i < hi} u_i², u_i = (x_{i+2m} − x_{i+m}) − (x_{i+m} − x_i)."""
        total = 0.0
        work = _buffers(self.block)[0]
        for a in range(lo, hi, self.block):
            e = min(a + self.block, hi)
            if m <= self.block:  # D_j = x_{j+m} − x_j once, u_i = D_{i+m} − D_i: two passes
                x = self.phase.read(a, e + 2 * m, _buffers(self.block)[1][0])
                d = np.subtract(x[m:], x[:-m], out=work[0, :e - a + m])
                u = np.subtract(d[m:], d[:e - a], out=work[1, :e - a])
            else:
                reads = _buffers(self.block)[1]
                x2 = self.phase.read(a + 2 * m, e + 2 * m, reads[2])
                x1, used = self._middle_slice(a + m, e + m, reads[1])
                u = np.subtract(x2, x1, out=work[0, :e - a])
                x0 = self._oldest_slice(a, e, reads[0])
                u -= np.subtract(x1, x0, out=work[1, :e - a])
                if used is not None:
                    self._spare.append(used)
            total += _sumsq(u)
        return total

    def _first_cluster(self, m: int) -> float:
        """v_0 = Σ_{i<m} u_i (the first cluster of the modified Allan variance)."""
        total = 0.0
        for a in range(0, m, self.block):
            e = min(a + self.block, m)
            x0, x1, x2 = self._slices(m, a, e, 2)
            total += float(np.sum(x2 - 2.0 * x1 + x0))
        return total

    def _third_block(self, m: int, lo: int, hi: int, carry: float) -> tuple[float, float, float]:
        """ΣT_j², Σv_{j+1}² and the new carry over lo ≤ j < hi (see module docstring)."""
        hsum = msum = 0.0
        work = _buffers(self.block)[0]
        for a in range(lo, hi, self.block):
            e = min(a + self.block, hi)
            k = e - a
            if m <= self.block // 2:  # nested differences of one read: three passes
                x = self.phase.read(a, e + 3 * m, _buffers(self.block)[1][0])
                d = np.subtract(x[m:], x[:-m], out=work[0, :k + 2 * m])
                u = np.subtract(d[m:], d[:-m], out=work[1, :k + m])
                t = np.subtract(u[m:], u[:k], out=work[2, :k])
            else:
                x0, x1, x2, x3 = self._slices(m, a, e, 3)
                w = work[:, :k]
                t = np.multiply(x2, 3.0, out=w[0])  # x3 − 3x2 + 3x1 − x0
                np.subtract(x3, t, out=t)
                t += np.multiply(x1, 3.0, out=w[1])
                t -= x0
            hsum += _sumsq(t)
            if 'mdev' in self.deviations:
                v = np.cumsum(t, out=_buffers(self.block)[1][1, :k])
                v += carry
                msum += _sumsq(v)
                carry = float(v[-1])
        return hsum, msum, carry

    def _edges(self, f: _Factor) -> float:
        """TOTVAR terms centred at c = 1..m−1 and c = N−m..N−2 (reflected record)."""
        m, n = f.m, len(self.phase)
        if m < 2:
            return 0.0
        if f.left_edge is None:
            total = 0.0
            x0 = float(self.phase.read(0, 1)[0])
            for a in range(1, m, self.block):
                e = min(a + self.block, m)
                c = self.phase.read(a, e)
                right = self.phase.read(a + m, e + m)
                left = 2.0 * x0 - self.phase.read(m - e + 1, m - a + 1)[::-1]  # x*_{c−m}
                d = left - 2.0 * c + right
                total += _sumsq(d)
            f.left_edge = total
        total = f.left_edge
        xe = float(self.phase.read(n - 1, n)[0])
        for a in range(n - m, n - 1, self.block):
            e = min(a + self.block, n - 1)
            c = self.phase.read(a, e)
            left = self.phase.read(a - m, e - m)
            # x*_{c+m} = 2x_{N−1} − x_{2(N−1)−c−m}
            lo_i, hi_i = 2 * (n - 1) - (e - 1) - m, 2 * (n - 1) - a - m + 1
            right = 2.0 * xe - self.phase.read(lo_i, hi_i)[::-1]
            d = left - 2.0 * c + right
            total += _sumsq(d)
        return total

    # -- results ---------------------------------------------------------------------------
    def sums(self) -> DeviationSums:
        """Sums at every active factor so far (the stream is undisturbed)."""
        self._advance()
        n = len(self.phase)
        facs = sorted(self._active(), key=lambda f: f.m)
        k = len(facs)
        out = {name: np.full(k, np.nan) for name in ('a', 'm', 'h', 't')}
        terms = {name: np.zeros(k, dtype=np.int64) for name in ('a', 'm', 'h', 't')}
        def partial(f: _Factor) -> tuple[float, float, float, float]:
            m = f.m
            a_sum = f.adev_sum + self._adev(m, f.adev_done, n - 2 * m)
            h_sum = m_sum = t_sum = np.nan
            if self._third and 3 * m < n and f.mdev_started:
                h, s, _ = self._third_block(m, f.third_done, n - 3 * m, f.mdev_carry)
                h_sum, m_sum = f.hdev_sum + h, f.mdev_sum + s
            if 'totdev' in self.deviations and m <= n - 2:
                t_sum = a_sum + self._edges(f)
            return a_sum, m_sum, h_sum, t_sum

        if self._threads > 1 and k > 1:
            parts = list(_pool().map(partial, facs))
        else:
            parts = [partial(f) for f in facs]
        for i, (f, (a_sum, m_sum, h_sum, t_sum)) in enumerate(zip(facs, parts)):
            m = f.m
            out['a'][i] = a_sum
            terms['a'][i] = n - 2 * m
            if 'hdev' in self.deviations and np.isfinite(h_sum):
                out['h'][i] = h_sum
                terms['h'][i] = n - 3 * m
            if 'mdev' in self.deviations and np.isfinite(m_sum):
                out['m'][i] = m_sum
                terms['m'][i] = n - 3 * m + 1
            if np.isfinite(t_sum):
                out['t'][i] = t_sum
                terms['t'][i] = n - 2
        ms = np.array([f.m for f in facs], dtype=np.int64)
        return DeviationSums(ms, out['a'], terms['a'], out['m'], terms['m'], out['h'],
                             terms['h'], out['t'], terms['t'], n)
