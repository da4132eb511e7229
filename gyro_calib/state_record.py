"""The durable record of what a live calibration node has consumed (its state directory).

A node that crashes (SIGKILL, power loss, OOM) must not lose hours of data. Every batch of
samples a node hands to its session is first appended here, so a restarted node replays the
record into a fresh session and goes on: the calibrators give the same numbers however the
data are chunked, so the resumed session equals the uninterrupted one bit for bit.

Layout of a state directory (format 1)::

    state.yaml            identity: format, method, gyro id, topics and their columns
    <n>.frames.jsonl      topic n's header.frame_id strings, one JSON line per new code
    <n>.rec               topic n's samples: fixed-size little-endian records
                          (int64 batch number, int64 header stamp ns, int32 frame code,
                          int32 pad, float64 × the topic's value columns)

Records are only appended, with ``write`` per batch (in the kernel's page cache at once,
so a killed process loses nothing it wrote) and ``fsync`` at most every
``fsync_period_s`` (what a power loss may cost). A record cut by a crash ends in a partial
record (or a partial frame line), which the reader drops: it reads up to the last complete
sample. A frame name is written before the first sample that uses it.

Pure core: no ROS import.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from gyro_calib.bagio.columns import FrameIds, TopicColumns
from gyro_calib.errors import GyroCalibError

FORMAT = 1
STATE_FILE = 'state.yaml'


class StateRecordError(GyroCalibError):
    """A state directory that cannot be used (another gyro or method, unreadable)."""


@dataclass(frozen=True, slots=True)
class _TopicLayout:
    """How one topic's samples are stored: its value columns and their widths."""

    topic: str
    msgtype: str
    columns: tuple[tuple[str, int], ...]
    """(value name, width): width 0 is a 1-D column, w ≥ 1 an N × w matrix."""

    @property
    def n_floats(self) -> int:
        return sum(max(w, 1) for _, w in self.columns)

    def dtype(self) -> np.dtype[Any]:
        return np.dtype([('batch', '<i8'), ('stamp_ns', '<i8'), ('frame', '<i4'),
                         ('pad', '<i4'), ('values', '<f8', (self.n_floats,))])

    def as_yaml(self) -> dict[str, Any]:
        return {'topic': self.topic, 'msgtype': self.msgtype,
                'columns': [[name, width] for name, width in self.columns]}

    @staticmethod
    def of(columns: TopicColumns) -> _TopicLayout:
        cols = tuple((name, 0 if v.ndim == 1 else int(v.shape[1]))
                     for name, v in sorted(columns.values.items()))
        return _TopicLayout(columns.topic, columns.msgtype, cols)


@dataclass(frozen=True, slots=True)
class ResumeSummary:
    """What a state directory held when it was opened.

    Attributes:
        messages: samples recorded, all topics.
        batches: batches recorded.
        last_stamp_ns: the latest header stamp recorded (None when empty).
        dropped_bytes: bytes of a record cut by a crash that were dropped.
        last_stamp_ns_by_topic: each topic's latest header stamp.
    """

    messages: int
    batches: int
    last_stamp_ns: int | None
    dropped_bytes: int
    last_stamp_ns_by_topic: dict[str, int]


class StateRecord:
    """Append-only record of a node's input, and its replay.

    Args:
        directory: the state directory (created with the first sample recorded, so a node
            that stops before any data leaves nothing behind).
        identity: what the record belongs to (``method``, ``gyro_id`` …); an existing
            record with another identity is refused rather than mixed in.
        fsync_period_s: the longest time between ``fsync`` calls (power-loss exposure).

    Raises:
        StateRecordError: the directory holds another gyro's or method's record, or a
            state file of another format.
    """

    def __init__(self, directory: str | Path, identity: Mapping[str, str], *,
                 fsync_period_s: float = 5.0) -> None:
        """Open (or start) the record in ``directory`` for ``identity``."""
        self.directory = Path(directory)
        self.identity = dict(identity)
        self.fsync_period_s = fsync_period_s
        self._layouts: dict[str, _TopicLayout] = {}
        self._index: dict[str, int] = {}
        self._frames: dict[str, dict[str, int]] = {}
        self._files: dict[str, Any] = {}
        self._last_fsync = time.monotonic()
        self._batch = 0
        state = self.directory / STATE_FILE
        if state.exists():  # else the directory is made with the first sample recorded
            self._load_state(state)

    # -- identity and layouts -------------------------------------------------------------

    def _load_state(self, path: Path) -> None:
        try:
            doc = yaml.safe_load(path.read_text(encoding='utf-8')) or {}
        except (OSError, yaml.YAMLError) as exc:
            raise StateRecordError(f'state directory {self.directory}: {STATE_FILE} cannot be '
                                   f'read ({exc}); remove the directory to start over.') from exc
        if doc.get('format') != FORMAT:
            raise StateRecordError(f'state directory {self.directory} has format '
                                   f'{doc.get("format")!r}, this version reads {FORMAT}; '
                                   'remove it to start over.')
        held = {k: str(v) for k, v in (doc.get('identity') or {}).items()}
        for key, value in self.identity.items():
            if held.get(key, value) != value:
                raise StateRecordError(
                    f'state directory {self.directory} holds the record of {key} '
                    f'{held[key]!r}, not {value!r}: give this run its own state_dir, or '
                    'remove the directory to start over.')
        for i, entry in enumerate(doc.get('topics') or []):
            layout = _TopicLayout(str(entry['topic']), str(entry['msgtype']),
                                  tuple((str(n), int(w)) for n, w in entry['columns']))
            self._layouts[layout.topic] = layout
            self._index[layout.topic] = i
            self._frames[layout.topic] = {name: code for code, name in
                                          enumerate(self._read_frames(i))}

    def _write_state(self) -> None:
        doc = {'format': FORMAT, 'identity': self.identity,
               'topics': [self._layouts[t].as_yaml() for t in
                          sorted(self._index, key=self._index.__getitem__)]}
        self.directory.mkdir(parents=True, exist_ok=True)
        tmp = self.directory / (STATE_FILE + '.tmp')
        with open(tmp, 'w', encoding='utf-8') as f:
            yaml.safe_dump(doc, f, sort_keys=False, allow_unicode=True)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.directory / STATE_FILE)

    def _read_frames(self, index: int) -> list[str]:
        path = self.directory / f'{index}.frames.jsonl'
        if not path.exists():
            return []
        names: list[str] = []
        for line in path.read_bytes().split(b'\n'):
            try:
                names.append(str(json.loads(line)))
            except ValueError:
                break  # a line cut by a crash (or the empty tail)
        return names

    # -- writing --------------------------------------------------------------------------

    def append(self, columns: Mapping[str, TopicColumns]) -> None:
        """Append one batch (topic → its columns) before it is handed to the session."""
        wrote = False
        for topic, cols in columns.items():
            if len(cols) == 0:
                continue
            layout = self._layouts.get(topic)
            if layout is None:
                layout = self._layouts[topic] = _TopicLayout.of(cols)
                self._index[topic] = len(self._index)
                self._frames[topic] = {}
                self._write_state()
            i = self._index[topic]
            codes = self._frame_codes(topic, i, cols.frame_id)
            rec = np.zeros(len(cols), dtype=layout.dtype())
            rec['batch'] = self._batch
            rec['stamp_ns'] = cols.stamp_ns
            rec['frame'] = codes
            at = 0
            for name, width in layout.columns:
                v = np.asarray(cols.values[name], dtype=np.float64)
                w = max(width, 1)
                rec['values'][:, at:at + w] = v.reshape(len(cols), w)
                at += w
            self._file(f'{i}.rec').write(rec.tobytes())
            wrote = True
        if wrote:
            self._batch += 1
            for f in self._files.values():
                f.flush()
            if time.monotonic() - self._last_fsync >= self.fsync_period_s:
                self.sync()

    def _frame_codes(self, topic: str, index: int, frames: FrameIds) -> npt.NDArray[np.int32]:
        known = self._frames[topic]
        table = np.empty(len(frames.names), dtype=np.int32)
        for code, name in enumerate(frames.names):
            if name not in known:
                known[name] = len(known)
                f = self._file(f'{index}.frames.jsonl')
                f.write(json.dumps(name).encode() + b'\n')
                f.flush()
            table[code] = known[name]
        return table[np.asarray(frames.codes, dtype=np.intp)]

    def _file(self, name: str) -> Any:
        f = self._files.get(name)
        if f is None:
            path = self.directory / name
            f = self._files[name] = open(path, 'ab')  # noqa: SIM115 (kept open)
        return f

    def sync(self) -> None:
        """Flush and fsync every file of the record."""
        for f in self._files.values():
            f.flush()
            os.fsync(f.fileno())
        self._last_fsync = time.monotonic()

    def close(self) -> None:
        """Sync and close the files (the record stays for a later resume)."""
        self.sync()
        for f in self._files.values():
            f.close()
        self._files.clear()

    def clear(self) -> None:
        """Remove the record (``reset``); the next sample recorded starts a new one."""
        self.remove()
        self._layouts.clear()
        self._index.clear()
        self._frames.clear()
        self._batch = 0

    def remove(self) -> None:
        """Close the files and remove the state directory (a completed calibration)."""
        for f in self._files.values():
            f.close()
        self._files.clear()
        shutil.rmtree(self.directory, ignore_errors=True)

    # -- reading --------------------------------------------------------------------------

    def _read_topic(self, topic: str) -> tuple[npt.NDArray[Any], int]:
        layout = self._layouts[topic]
        path = self.directory / f'{self._index[topic]}.rec'
        if not path.exists():
            return np.zeros(0, dtype=layout.dtype()), 0
        raw = path.read_bytes()
        size = layout.dtype().itemsize
        whole = len(raw) // size * size
        rec = np.frombuffer(raw[:whole], dtype=layout.dtype())
        unknown = np.flatnonzero(rec['frame'] >= len(self._frames[topic]))
        ok = int(unknown[0]) if len(unknown) else len(rec)  # a name line cut by a crash
        dropped = len(raw) - whole + (len(rec) - ok) * size
        return rec[:ok], dropped

    def summary(self) -> ResumeSummary:
        """What the record holds now."""
        messages, batches, dropped = 0, 0, 0
        by_topic: dict[str, int] = {}
        for topic in self._layouts:
            rec, cut = self._read_topic(topic)
            messages += len(rec)
            dropped += cut
            if len(rec):
                batches = max(batches, int(rec['batch'].max()) + 1)
                by_topic[topic] = int(rec['stamp_ns'].max())
        last = max(by_topic.values(), default=None)
        return ResumeSummary(messages, batches, last, dropped, by_topic)

    def replay(self, *, batch_messages: int = 50_000) -> Iterator[dict[str, TopicColumns]]:
        """The recorded batches in their recorded order.

        The recorded batches in their recorded order, consecutive ones merged up to
        ``batch_messages`` samples, as topic → columns (the record's cut tail dropped).

        Appending goes on after the replay: the next batch number follows the last read.
        """
        recs = {t: self._read_topic(t)[0] for t in self._layouts}
        n_batches = max((int(r['batch'].max()) + 1 for r in recs.values() if len(r)),
                        default=0)
        self._batch = max(self._batch, n_batches)
        if n_batches == 0:
            return
        # batch k's rows of each topic: records are in batch order, so searchsorted cuts
        bounds = {t: np.searchsorted(r['batch'], np.arange(n_batches + 1)) for t, r in
                  recs.items()}
        sizes = np.asarray(sum(np.diff(b) for b in bounds.values()))
        start = 0
        while start < n_batches:
            end, total = start, 0
            while end < n_batches and (end == start or total + sizes[end] <= batch_messages):
                total += int(sizes[end])
                end += 1
            out: dict[str, TopicColumns] = {}
            for topic, rec in recs.items():
                part = rec[bounds[topic][start]:bounds[topic][end]]
                if len(part):
                    out[topic] = self._columns(topic, part)
            if out:
                yield out
            start = end

    def _columns(self, topic: str, rec: npt.NDArray[Any]) -> TopicColumns:
        layout = self._layouts[topic]
        values: dict[str, npt.NDArray[np.float64]] = {}
        at = 0
        for name, width in layout.columns:
            w = max(width, 1)
            block = np.ascontiguousarray(rec['values'][:, at:at + w])
            values[name] = block[:, 0].copy() if width == 0 else block
            at += w
        stamps = np.ascontiguousarray(rec['stamp_ns'])
        names = tuple(sorted(self._frames[topic], key=self._frames[topic].__getitem__))
        frames = FrameIds(np.ascontiguousarray(rec['frame']).astype(np.int32), names)
        return TopicColumns(topic, layout.msgtype, stamps.copy(), stamps, frames, values)
