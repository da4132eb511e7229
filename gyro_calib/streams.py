"""Stamped sample streams: ordering, duplicates, non-finite values, restarts, bounded memory.

Calibration pairs streams by header stamp, never by arrival order. A
:class:`StampedBuffer` accepts samples one at a time (live node) or as arrays
(bag, offline), keeps them sorted by stamp, drops what cannot be trusted with a
count per cause, and tells the caller when the source restarted (its stamps
jumped back by more than a threshold).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.typing import ArrayLike


@dataclass(slots=True)
class StreamStats:
    """Counts of samples a stream dropped, by cause."""

    non_finite: int = 0
    duplicate: int = 0
    late: int = 0
    restarts: int = 0
    out_of_order: int = 0

    def summary(self) -> str:
        """One line: what was dropped and why (empty when nothing was)."""
        parts = [
            f'{n} {what}'
            for n, what in (
                (self.non_finite, 'non-finite'),
                (self.duplicate, 'duplicate-stamp'),
                (self.late, 'too-late'),
            )
            if n
        ]
        if self.out_of_order:
            parts.append(f'{self.out_of_order} re-sorted out-of-order')
        if self.restarts:
            parts.append(f'{self.restarts} restart(s)')
        return ', '.join(parts)


@dataclass(slots=True)
class StampedBuffer:
    """A bounded, stamp-sorted buffer of (t_ns, value...) samples.

    Attributes:
        n_values: number of float values per sample.
        restart_backstep_ns: a stamp this far (or more) before the newest one means
            the source restarted rather than delivered one sample out of order.
    """

    n_values: int
    restart_backstep_ns: int
    stats: StreamStats = field(default_factory=StreamStats)
    _t: npt.NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    _v: npt.NDArray[np.float64] = field(init=False)
    _pending_t: list[int] = field(default_factory=list)
    _pending_v: list[tuple[float, ...]] = field(default_factory=list)
    _newest_ns: int | None = None
    _floor_ns: int | None = None

    def __post_init__(self) -> None:
        """Allocate the empty value array."""
        self._v = np.zeros((0, self.n_values))

    @property
    def newest_ns(self) -> int | None:
        """Newest stamp accepted since the last restart (None when empty)."""
        return self._newest_ns

    def append(self, t_ns: int, *values: float) -> bool:
        """Add one sample; return True if it marks a restart of the source (buffer cleared)."""
        if self._newest_ns is not None and t_ns <= self._newest_ns - self.restart_backstep_ns:
            self.clear()
            self.stats.restarts += 1
            restarted = True
        else:
            restarted = False
        if not all(np.isfinite(values)):
            self.stats.non_finite += 1
            return restarted
        if self._floor_ns is not None and t_ns < self._floor_ns:
            self.stats.late += 1
            return restarted
        self._pending_t.append(int(t_ns))
        self._pending_v.append(tuple(float(v) for v in values))
        if self._newest_ns is None or t_ns > self._newest_ns:
            self._newest_ns = int(t_ns)
        return restarted

    def extend(self, t_ns: ArrayLike, *values: ArrayLike) -> bool:
        """Add many samples at once (bag replay); return True if the source restarted.

        A restart inside the batch keeps only the samples from the last restart on.
        """
        t = np.asarray(t_ns, dtype=np.int64)
        if len(t) == 0:
            return False
        v = np.column_stack([np.asarray(x, dtype=np.float64) for x in values])
        starts = timeline_starts(t, self.restart_backstep_ns, self._newest_ns)
        restarted = bool(starts)
        if restarted:
            self.clear()
            self.stats.restarts += len(starts)
            t, v = t[starts[-1]:], v[starts[-1]:]
        finite = np.all(np.isfinite(v), axis=1)
        self.stats.non_finite += int(np.count_nonzero(~finite))
        t, v = t[finite], v[finite]
        if self._floor_ns is not None:
            late = t < self._floor_ns
            self.stats.late += int(np.count_nonzero(late))
            t, v = t[~late], v[~late]
        if len(t):
            self._consolidate()
            in_order = bool(np.all(t[1:] > t[:-1])) and (len(self._t) == 0
                                                        or int(t[0]) > int(self._t[-1]))
            self._t = np.concatenate((self._t, t))
            self._v = np.concatenate((self._v, v))
            newest = int(t.max())
            self._newest_ns = newest if self._newest_ns is None else max(self._newest_ns, newest)
            if not in_order:  # the common case (strictly after what is held) needs no sort
                self._sort_and_dedupe()
        return restarted

    def clear(self) -> None:
        """Forget every sample and the stamp history (after a restart of the source)."""
        self._t = np.zeros(0, np.int64)
        self._v = np.zeros((0, self.n_values))
        self._pending_t.clear()
        self._pending_v.clear()
        self._newest_ns = None
        self._floor_ns = None

    def _consolidate(self) -> None:
        if not self._pending_t:
            return
        t = np.asarray(self._pending_t, dtype=np.int64)
        v = np.asarray(self._pending_v, dtype=np.float64).reshape(-1, self.n_values)
        self._pending_t.clear()
        self._pending_v.clear()
        self._t = np.concatenate((self._t, t))
        self._v = np.concatenate((self._v, v))
        self._sort_and_dedupe()

    def _sort_and_dedupe(self) -> None:
        t = self._t
        if len(t) > 1 and np.any(t[1:] < t[:-1]):
            self.stats.out_of_order += int(np.count_nonzero(t[1:] < t[:-1]))
            order = np.argsort(t, kind='stable')
            self._t, self._v = t[order], self._v[order]
        if len(self._t) > 1:
            keep = np.concatenate(([True], self._t[1:] != self._t[:-1]))
            n_dup = len(keep) - int(np.count_nonzero(keep))
            if n_dup:
                self.stats.duplicate += n_dup
                self._t, self._v = self._t[keep], self._v[keep]

    def arrays(self) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """Sorted, de-duplicated stamps (int ns) and values (n × n_values)."""
        self._consolidate()
        return self._t, self._v

    def discard_before(self, t_ns: int) -> None:
        """Forget samples older than ``t_ns``; later arrivals older than it count as late."""
        self._consolidate()
        cut = int(np.searchsorted(self._t, t_ns, side='left'))
        if cut:
            self._t, self._v = self._t[cut:], self._v[cut:]
        self._floor_ns = t_ns if self._floor_ns is None else max(self._floor_ns, t_ns)

    def span_ns(self) -> int:
        """Newest minus oldest stamp held (0 when empty), without consolidating."""
        if self._newest_ns is None:
            return 0
        oldest = int(self._t[0]) if len(self._t) else min(self._pending_t, default=self._newest_ns)
        return self._newest_ns - oldest

    def __len__(self) -> int:
        """Number of samples held."""
        return len(self._t) + len(self._pending_t)


def timeline_starts(t_ns: npt.NDArray[np.int64], backstep_ns: int,
                    newest_before_ns: int | None = None) -> list[int]:
    """Indices where a stamp falls ``backstep_ns`` or more behind the newest stamp before it.

    Each marks a restart of the source: a new timeline begins there. ``newest_before_ns``
    is the newest stamp seen before ``t_ns[0]`` (None if none).
    """
    out: list[int] = []
    start, newest = 0, newest_before_ns
    if len(t_ns) and (newest is None or int(t_ns[0]) > newest - backstep_ns) and bool(
            np.all(t_ns[1:] >= t_ns[:-1])):
        return out  # in order (the usual case): nothing falls behind, one pass
    while start < len(t_ns):
        running = np.maximum.accumulate(t_ns[start:])
        if newest is not None:
            running = np.maximum(running, newest)
        before = np.concatenate(([newest if newest is not None else t_ns[start]], running[:-1]))
        back = np.nonzero(t_ns[start:] <= before - backstep_ns)[0]
        if len(back) == 0:
            break
        start += int(back[0])
        out.append(start)
        newest = None
    return out


def feed_by_timeline(streams: Sequence[tuple[Callable[..., object], npt.NDArray[np.int64],
                                             tuple[npt.ArrayLike, ...]]],
                     backstep_ns: int, process: Callable[[], object]) -> None:
    """Feed whole recorded streams to a streaming calibrator one timeline at a time.

    ``streams`` holds, per input, ``(extend, t_ns, values)``: the calibrator's method that
    takes a batch ``extend(t_ns, *values)``, the stamps, and the value columns. A source
    restart (stamps jumping back by ``backstep_ns``, :func:`timeline_starts`) splits each
    stream; the k-th timeline of every stream is fed, then ``process()`` runs, then the
    next — as a live node would see a restarted bench.
    """
    cuts = [[0, *timeline_starts(t, backstep_ns), len(t)] for _, t, _ in streams]
    for k in range(max(len(c) - 1 for c in cuts)):
        for (extend, t, values), c in zip(streams, cuts):
            if k + 1 < len(c):
                part = slice(c[k], c[k + 1])
                extend(t[part], *(np.asarray(v)[part] for v in values))
        process()
