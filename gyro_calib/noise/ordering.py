"""Stamp ordering for a noise stream: sort, drop duplicates and late samples, see restarts.

Bags need no "cooking": samples may arrive out of stamp order. A :class:`ReorderBuffer`
holds the newest ``reorder_window`` of samples; everything older than the newest stamp
minus the window is *final* — no sample accepted later can precede it — and is released in
stamp order. The rules depend only on the arrival sequence, never on how it was cut into
chunks or when the caller processed, so the released sequence is chunking-invariant:

- a sample is *late* (dropped, counted) when its stamp is more than the window behind
  the newest stamp that arrived before it;
- a sample behind the newest stamp but within the window is re-sorted (counted);
- a sample whose stamp equals one already held is a duplicate (dropped, counted; the
  first arrival is kept);
- a stamp ``restart_backstep`` or more behind the newest one starts a new timeline (the
  source restarted): everything held is released, then a restart is signalled.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gyro_calib.streams import timeline_starts

if TYPE_CHECKING:
    import numpy.typing as npt

    FloatArray = npt.NDArray[np.float64]
    IntArray = npt.NDArray[np.int64]


@dataclass(slots=True)
class OrderingStats:
    """Samples the ordering stage dropped or re-sorted, by cause."""

    received: int = 0
    late: int = 0
    duplicate: int = 0
    out_of_order: int = 0
    restarts: int = 0

    def summary(self) -> str:
        """One line: what was dropped or re-sorted (empty when nothing was)."""
        parts = [f'{n} {what}' for n, what in (
            (self.out_of_order, 're-sorted out-of-order'), (self.duplicate, 'duplicate-stamp'),
            (self.late, 'too-late (dropped)'), (self.restarts, 'restart(s)')) if n]
        return ', '.join(parts)


class ReorderBuffer:
    """Releases (t_ns, values) in stamp order once final (see module docstring)."""

    def __init__(self, n_values: int, reorder_window_ns: int, restart_backstep_ns: int) -> None:
        """``n_values`` float columns per sample; windows in integer ns."""
        self.n_values = n_values
        self.window_ns = reorder_window_ns
        self.backstep_ns = restart_backstep_ns
        self.stats = OrderingStats()
        self._t = np.zeros(0, dtype=np.int64)
        self._v = np.zeros((0, n_values))
        self._newest: int | None = None

    def extend(self, t_ns: npt.ArrayLike, values: npt.ArrayLike
               ) -> list[tuple[IntArray, FloatArray] | None]:
        """Add samples in arrival order; return released batches, ``None`` marking a restart.

        Args:
            t_ns: stamps, int ns (shape n).
            values: n × n_values floats (non-finite values pass through: the channels
                decide what to drop).
        """
        t = np.asarray(t_ns, dtype=np.int64).ravel()
        v = np.asarray(values, dtype=np.float64).reshape(len(t), self.n_values)
        self.stats.received += len(t)
        out: list[tuple[IntArray, FloatArray] | None] = []
        if not len(t):
            return out
        starts = timeline_starts(t, self.backstep_ns, self._newest)
        bounds = [0, *starts, len(t)]
        for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
            if k > 0:
                out.extend(self.flush())
                out.append(None)
                self._newest = None
                self.stats.restarts += 1
            released = self._add(t[a:b], v[a:b])
            if released is not None:
                out.append(released)
        return out

    def _add(self, t: IntArray, v: FloatArray) -> tuple[IntArray, FloatArray] | None:
        if not len(t):
            return None
        if ((self._newest is None or t[0] > self._newest)
                and (len(t) == 1 or bool(np.all(t[1:] > t[:-1])))):
            return self._add_in_order(t, v)
        first = t[0] if self._newest is None else self._newest
        before = np.maximum.accumulate(np.concatenate(([first], t[:-1])))
        if self._newest is not None:
            before = np.maximum(before, self._newest)
        late = t < before - self.window_ns
        behind = (t < before) & ~late
        self.stats.late += int(np.count_nonzero(late))
        self.stats.out_of_order += int(np.count_nonzero(behind))
        t, v = t[~late], v[~late]
        if not len(t):
            return None
        newest = int(t.max())
        self._newest = newest if self._newest is None else max(self._newest, newest)
        all_t = np.concatenate((self._t, t))
        all_v = np.concatenate((self._v, v))
        if len(all_t) > 1 and np.any(all_t[1:] < all_t[:-1]):
            order = np.argsort(all_t, kind='stable')
            all_t, all_v = all_t[order], all_v[order]
        if len(all_t) > 1:
            keep = np.concatenate(([True], all_t[1:] != all_t[:-1]))
            n_dup = len(all_t) - int(np.count_nonzero(keep))
            if n_dup:
                self.stats.duplicate += n_dup
                all_t, all_v = all_t[keep], all_v[keep]
        cut = int(np.searchsorted(all_t, self._newest - self.window_ns, side='left'))
        self._t, self._v = all_t[cut:], all_v[cut:]
        if cut == 0:
            return None
        return all_t[:cut], all_v[:cut]

    def _add_in_order(self, t: IntArray, v: FloatArray) -> tuple[IntArray, FloatArray] | None:
        """Fast path: strictly increasing stamps, all after every held one."""
        self._newest = int(t[-1])
        cut_t = self._newest - self.window_ns
        k = int(np.searchsorted(t, cut_t, side='left'))
        if len(self._t):
            j = int(np.searchsorted(self._t, cut_t, side='left'))
            if j < len(self._t) or k == 0:
                all_t = np.concatenate((self._t, t))
                all_v = np.concatenate((self._v, v))
                cut = j + k if j == len(self._t) else j
                self._t, self._v = all_t[cut:], all_v[cut:]
                return (all_t[:cut], all_v[:cut]) if cut else None
            released = (np.concatenate((self._t, t[:k])), np.concatenate((self._v, v[:k])))
        else:
            released = (t[:k], v[:k])
        self._t, self._v = t[k:].copy(), v[k:].copy()
        return released if len(released[0]) else None

    def flush(self) -> list[tuple[IntArray, FloatArray]]:
        """Release everything held (end of the recording, or a restart)."""
        if not len(self._t):
            return []
        out = [(self._t, self._v)]
        self._t = np.zeros(0, dtype=np.int64)
        self._v = np.zeros((0, self.n_values))
        return out

    def __len__(self) -> int:
        """Samples held (not yet final)."""
        return len(self._t)
