"""Stamped sample streams: ordering, duplicates, non-finite values, restarts, bounded memory.

Calibration pairs streams by header stamp, never by arrival order. A
:class:`StampedBuffer` accepts samples one at a time (live node) or as arrays
(bag, offline), keeps them sorted by stamp, drops what cannot be trusted with a
count per cause, and tells the caller when the source restarted (its stamps
jumped back by more than a threshold).
"""

from __future__ import annotations

import math
from bisect import bisect_right
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
    _store_t: npt.NDArray[np.int64] | None = None
    _store_v: npt.NDArray[np.float64] | None = None
    _store_end: int = 0
    """Room behind the samples held: ``_t``/``_v`` end at row ``_store_end`` of these, and a
    batch in stamp order is written after it (no copy of what is held per batch)."""

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
        n_bad = len(t) - int(np.count_nonzero(finite))
        if n_bad:  # (the usual case, all finite, copies nothing)
            self.stats.non_finite += n_bad
            t, v = t[finite], v[finite]
        if self._floor_ns is not None and len(t) and int(t.min()) < self._floor_ns:
            late = t < self._floor_ns
            self.stats.late += int(np.count_nonzero(late))
            t, v = t[~late], v[~late]
        if len(t):
            self._consolidate()
            in_order = bool(np.all(t[1:] > t[:-1])) and (len(self._t) == 0
                                                        or int(t[0]) > int(self._t[-1]))
            self._append(t, v)
            newest = int(t.max())
            self._newest_ns = newest if self._newest_ns is None else max(self._newest_ns, newest)
            if not in_order:  # the common case (strictly after what is held) needs no sort
                self._sort_and_dedupe()
        return restarted

    def _append(self, t: npt.NDArray[np.int64], v: npt.NDArray[np.float64]) -> None:
        """Hold ``t``/``v`` after ``_t``/``_v``.

        Written into the room behind them when they end where it does, else both copied
        into new room of twice their length.
        """
        held, k = len(self._t), len(t)
        st, sv, end = self._store_t, self._store_v, self._store_end
        if st is not None and sv is not None and end + k <= len(st) and end >= held:
            start = end - held
            views = self._t.base is st and self._v.base is sv  # (a bool: no narrowing)
            if (views and self._t.ctypes.data == st.ctypes.data + start * st.strides[0]
                    and self._v.ctypes.data == sv.ctypes.data + start * sv.strides[0]):
                st[end:end + k] = t
                sv[end:end + k] = v
                self._t, self._v, self._store_end = st[start:end + k], sv[start:end + k], end + k
                return
        room = max(2 * (held + k), 1024)
        st = np.empty(room, dtype=np.int64)
        sv = np.empty((room, self.n_values))
        st[:held], st[held:held + k] = self._t, t
        sv[:held], sv[held:held + k] = self._v, v
        self._store_t, self._store_v, self._store_end = st, sv, held + k
        self._t, self._v = st[:held + k], sv[:held + k]

    def clear(self) -> None:
        """Forget every sample and the stamp history (after a restart of the source)."""
        self._t = np.zeros(0, np.int64)
        self._v = np.zeros((0, self.n_values))
        self._pending_t.clear()
        self._pending_v.clear()
        self._newest_ns = None
        self._floor_ns = None
        self._store_t = self._store_v = None
        self._store_end = 0

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


@dataclass(slots=True)
class _Held:
    """Samples of one topic waiting for the watermark, in arrival order."""

    stamps: list[int] = field(default_factory=list)
    arrived_s: list[float] = field(default_factory=list)
    payloads: list[object] = field(default_factory=list)


@dataclass(slots=True)
class WatermarkMerge:
    """Order live input by stamp across topics: release only what no topic can still precede.

    Several topics reach a live node by separate DDS readers, each in its writer's order but
    with no order between them: under load one reader can run seconds behind the others,
    and an unpaced replay turns those seconds into minutes of stamps. The merge holds every
    sample and releases, in stamp order, those stamped at or before the **watermark**

        W = min over topics of (newest stamp − ``reorder_ns``) − 1 ns,

    so the session sees the samples in the order of a recording, cut at W (docs/methods.md,
    "Live input in stamp order"; the 1 ns holds back what shares the newest stamp: another
    sensor on the same topic may read at that stamp too). While every topic delivers, W is
    pure stamps: once every
    topic has delivered a sample newer than t, nothing older than t is still on its way
    (each reader is in order), however far one reader lags another. A topic that has
    delivered nothing for ``hold_s`` of wall time while the others' stamps ran on by more
    than ``gap_factor`` times its own largest stamp gap (a zero-index stream while the table
    stands, a bench without injection; a temperature read every minute among 1 kHz pulses
    is not silent between two readings), or every topic has paused that long (the end of a
    recording), stops holding the others, and W is then the newest
    stamp among the samples held ``hold_s`` or longer (and still no newer than what the
    flowing topics delivered): a silent topic's next sample was waited for as long as a
    reader may lag, so the wall clock decides when a result appears, not what it is.

    A sample that arrives stamped at or before what was already released is **late** (a
    silent topic's reader lagged more than ``hold_s``): it is released at once (the session
    treats it as out-of-order data) and listed in :meth:`take_late`, so the window that
    needs it can be rejected with a line instead of computed without it.

    A stamp ``restart_ns`` or more before its topic's newest one is a restarted source (a
    bag played again, a bench restarted): everything held is released, and the new
    timeline is merged afresh (the session reports the restart itself).

    The clock is the caller's (``now_s`` arguments, e.g. ``time.monotonic()``): the merge
    itself reads none, so it is tested with any arrival timing.

    Attributes:
        topics: the topics merged; each holds the watermark while it delivers.
        hold_s: wall time a topic may deliver nothing before it stops holding the others
            (and a sample waits at most for it), s.
        gap_factor: ...and only once the other topics' stamps have run this many times the
            topic's largest gap between two of its own stamps past its newest.
        reorder_ns: stamps a topic may deliver out of order by (kept back from W), ns.
        restart_ns: a stamp this far behind its topic's newest starts a new timeline, ns.
    """

    topics: tuple[str, ...]
    hold_s: float = 5.0
    gap_factor: float = 2.0
    reorder_ns: int = 0
    restart_ns: int = 1_000_000_000
    released_ns: int | None = None
    """Every sample stamped at or before this was released (None: nothing yet)."""
    _held: dict[str, _Held] = field(default_factory=dict)
    _newest: dict[str, int] = field(default_factory=dict)
    _last_arrival: dict[str, float] = field(default_factory=dict)
    _max_gap: dict[str, int] = field(default_factory=dict)
    _ready: list[list[tuple[int, int, str, object]]] = field(default_factory=lambda: [[]])
    _late: list[tuple[str, int]] = field(default_factory=list)

    def __post_init__(self) -> None:
        """One hold list per topic."""
        self._held = {t: _Held() for t in self.topics}

    def add(self, topic: str, t_ns: int, payload: object, now_s: float) -> None:
        """One sample of ``topic`` stamped ``t_ns`` arrived at wall time ``now_s``."""
        t_ns = int(t_ns)
        newest = self._newest.get(topic)
        if newest is not None and t_ns <= newest - self.restart_ns:
            self._ready[-1].extend(self._take(None))  # the old timeline goes out whole
            self._ready.append([])  # the new one after it, sorted apart
            self._newest.clear()
            self.released_ns = None
        if self.released_ns is not None and t_ns <= self.released_ns:
            self._late.append((topic, t_ns))
            self._ready[-1].append((t_ns, self.topics.index(topic), topic, payload))
        else:
            held = self._held[topic]
            held.stamps.append(t_ns)
            held.arrived_s.append(float(now_s))
            held.payloads.append(payload)
        if newest is not None and t_ns > newest:
            self._max_gap[topic] = max(self._max_gap.get(topic, 0), t_ns - newest)
        if newest is None or t_ns > newest:
            self._newest[topic] = t_ns
        self._last_arrival[topic] = float(now_s)

    def watermark(self, now_s: float) -> int | None:
        """W: the newest stamp that may be released at wall time ``now_s`` (None: none)."""
        waited = now_s - self.hold_s
        ahead = max(self._newest.values(), default=0)
        paused = all(self._last_arrival.get(t, -math.inf) <= waited for t in self.topics)
        live = [newest for t in self.topics if (newest := self._newest.get(t)) is not None
                and not paused and (self._last_arrival[t] > waited or ahead - newest
                                    <= self.gap_factor * self._max_gap.get(t, 0))]
        marks: list[int] = []  # less 1 ns: more samples may share the stamp (other sensors)
        if len(live) == len(self.topics):
            marks.append(min(live) - self.reorder_ns - 1)
        else:  # a topic silent (or all paused) for hold_s: what waited that long, and no
            # topic still flowing
            waited_for = [max(h.stamps[:k]) for h in self._held.values()
                          if (k := bisect_right(h.arrived_s, waited))]
            if waited_for:
                marks.append(min([max(waited_for),
                                  *(t - self.reorder_ns - 1 for t in live)]))
        if self.released_ns is not None:
            marks.append(self.released_ns)
        return max(marks) if marks else None

    def release(self, now_s: float, *, flush: bool = False) -> list[tuple[str, int, object]]:
        """(topic, stamp, payload) of every sample the watermark passed, in stamp order.

        With ``flush`` (the input ended) everything held is released.
        """
        mark = None if flush else self.watermark(now_s)
        if flush or mark is not None:
            out = self._take(mark)
            if mark is not None:
                self.released_ns = mark
            elif out:
                newest = max(t for t, *_ in out)
                self.released_ns = (newest if self.released_ns is None
                                    else max(self.released_ns, newest))
            self._ready[-1].extend(out)
        ready, self._ready = self._ready, [[]]
        return [(topic, t, payload) for timeline in ready
                for t, _, topic, payload in sorted(timeline, key=lambda r: (r[0], r[1]))]

    def take_late(self) -> list[tuple[str, int]]:
        """(topic, stamp) of the samples that arrived late since the last call."""
        late, self._late = self._late, []
        return late

    def held(self) -> int:
        """Samples waiting for the watermark (or to be returned by :meth:`release`)."""
        return (sum(len(h.stamps) for h in self._held.values())
                + sum(len(r) for r in self._ready))

    def clear(self) -> None:
        """Forget everything held and every stamp seen (a new session)."""
        self._held = {t: _Held() for t in self.topics}
        self._newest.clear()
        self._last_arrival.clear()
        self._max_gap.clear()
        self._ready = [[]]
        self._late.clear()
        self.released_ns = None

    def _take(self, mark: int | None) -> list[tuple[int, int, str, object]]:
        """Remove and return the held samples stamped at or before ``mark`` (None: all)."""
        out: list[tuple[int, int, str, object]] = []
        for i, (topic, held) in enumerate(self._held.items()):
            if mark is None:
                keep = [False] * len(held.stamps)
            else:
                keep = [t > mark for t in held.stamps]
            if all(keep):
                continue
            out.extend((t, i, topic, p) for t, p, k in zip(held.stamps, held.payloads, keep)
                       if not k)
            self._held[topic] = _Held(
                [t for t, k in zip(held.stamps, keep) if k],
                [a for a, k in zip(held.arrived_s, keep) if k],
                [p for p, k in zip(held.payloads, keep) if k])
        return out


def late_summary(late: Sequence[tuple[str, int]]) -> str:
    """'3 /fog/output samples stamped t=… to t=…, 1 /rate_table/zero_index sample …'."""
    by_topic: dict[str, list[int]] = {}
    for topic, t in late:
        by_topic.setdefault(topic, []).append(int(t))
    parts = []
    for topic, stamps in by_topic.items():
        lo, hi = min(stamps), max(stamps)
        when = (f'stamped t={lo / 1e9:.6f} s' if lo == hi
                else f'stamped t={lo / 1e9:.6f} s to t={hi / 1e9:.6f} s')
        parts.append(f'{len(stamps)} {topic} sample{"s" if len(stamps) > 1 else ""} {when}')
    return ', '.join(parts)
