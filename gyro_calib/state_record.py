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

import atexit
import json
import math
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
from gyro_calib.file_lock import FileLock, LockHeldError
from gyro_calib.outputs import write_text_atomically
from gyro_calib.units import NS_PER_S, format_stamp

FORMAT = 1
STATE_FILE = 'state.yaml'
RESUME_MAX_GAP_S = 60.0
"""Default longest stamp gap between a record's end and new data that still continues it, s.

As long as the longest time between paired windows (``max_pair_gap_s``, §A): no method
bridges a longer gap, so data after it are a new run whatever they are."""
RATE_MARGIN = 1.25
"""Factor on the bench's fastest rate when judging how far a count or angle may move over a
gap."""


class StateRecordError(GyroCalibError):
    """A state directory that cannot be used (another gyro or method, unreadable)."""


class StateDirectoryInUseError(GyroCalibError):
    """A state directory another running process writes, or that cannot be written."""


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


@dataclass(frozen=True, slots=True)
class TopicTail:
    """How one topic's record ends: what new data must continue (see :func:`why_not_continued`).

    Attributes:
        topic: the topic.
        msgtype: its message type.
        samples: samples recorded.
        last_stamp_ns: the latest header stamp recorded.
        last: value of each continuous column at that stamp.
        max_rate: fastest |change| per second of each continuous column between consecutive
            samples of the record (inf where fewer than two samples tell it).
        max_step: largest |change| between consecutive samples (the quantisation and noise
            allowance).
        last_frame_id: the header.frame_id of the last sample (the sensor's name).
    """

    topic: str
    msgtype: str
    samples: int
    last_stamp_ns: int
    last: dict[str, float]
    max_rate: dict[str, float]
    max_step: dict[str, float]
    last_frame_id: str = ''


def continuous_columns(topic: str, msgtype: str) -> dict[str, bool]:
    """The columns of a topic that move continuously, each with True where it is an angle.

    A JointState's ``position`` is a cumulative count (``/gyro/pulses``, ``/fog/output``) or
    a table's encoder angle (``…/joint_states``, judged modulo 2π since an encoder may wrap).
    Rates, temperatures and events carry no such constraint: only their stamps are judged.
    """
    if msgtype.endswith('JointState'):
        return {'position': topic.rstrip('/').endswith('joint_states')}
    return {}


def bench_rate_limit_rad_s(tails: Mapping[str, TopicTail],
                           stated_rad_s: float = math.nan) -> float:
    """The fastest any table of the bench can turn, rad/s (NaN: unknown).

    The larger of the stated limit (``bench_max_rate_deg_s``, or the commanded procedure's
    fastest rate) and the fastest any table turned in the record: a table at rest in the
    record (the position table during the K̃ phase) may turn at the bench's rate while the
    node is down. NaN when nothing is stated and no table has moved yet.
    """
    recorded = [rate for tail in tails.values() if tail.samples
                for name, is_angle in continuous_columns(tail.topic, tail.msgtype).items()
                if is_angle for rate in (tail.max_rate.get(name, math.nan),)
                if math.isfinite(rate) and rate > 0]
    limits = [*recorded, *([stated_rad_s] if math.isfinite(stated_rad_s)
                           and stated_rad_s > 0 else [])]
    return max(limits) if limits else math.nan


def _allowed_rates(tails: Mapping[str, TopicTail], limit_rad_s: float
                   ) -> dict[tuple[str, str], float]:
    """How fast each continuous column may move while no node runs, its unit per s.

    A table angle: the bench's limit (:func:`bench_rate_limit_rad_s`; inf when unknown). A
    cumulative count: its own fastest recorded rate, or, on a bench with tables, the count
    the gyro gives when every table turns at the limit (counts per rad from the record:
    the count's fastest rate over the fastest table's) — inf when that is unknown.
    """
    angles = {(t.topic, n): t for t in tails.values() if t.samples
              for n, a in continuous_columns(t.topic, t.msgtype).items() if a}
    fastest_table = max((t.max_rate.get(n, 0.0) for (_, n), t in angles.items()
                         if math.isfinite(t.max_rate.get(n, math.inf))), default=0.0)
    table_limit = limit_rad_s if math.isfinite(limit_rad_s) else math.inf
    out: dict[tuple[str, str], float] = {}
    for tail in tails.values():
        for name, is_angle in continuous_columns(tail.topic, tail.msgtype).items():
            own = tail.max_rate.get(name, math.inf)
            if is_angle:
                out[tail.topic, name] = table_limit
            elif not angles:  # no table: the count's own recorded rate
                out[tail.topic, name] = own
            elif fastest_table > 0 and math.isfinite(own) and math.isfinite(table_limit):
                counts_per_rad = own / fastest_table
                out[tail.topic, name] = max(own, counts_per_rad * len(angles) * table_limit)
            else:  # no table has moved and no limit is stated: any count
                out[tail.topic, name] = math.inf
    return out


def why_not_continued(tails: Mapping[str, TopicTail], live: Mapping[str, TopicColumns],
                      max_gap_s: float = RESUME_MAX_GAP_S,
                      bench_max_rate_rad_s: float = math.nan) -> str | None:
    """Why new data do not continue a record, or None when they do.

    New data continue a record when, for every topic, the first new sample comes after the
    topic's last recorded one (a topic the record lacks: after the earliest end of the
    recorded topics), the gap from the record's end to the first new sample is at most
    ``max_gap_s``, the sensor (frame_id) is the record's, and every cumulative count or
    encoder angle has moved from its recorded value by no more than the *bench* can move it
    over that gap (× 1.25, plus two of the record's largest sample-to-sample steps): a
    table may start, stop or reverse while the node is down, at up to the bench's fastest
    rate (:func:`bench_rate_limit_rad_s`: ``bench_max_rate_rad_s`` stated or commanded, or
    the fastest any table turned in the record), and the gyro on it counts accordingly.
    Stamps that go back, a count that jumps beyond that, another frame_id and a gap no
    window could bridge mean another run (another gyro, bench or recording).
    """
    ends = [t.last_stamp_ns for t in tails.values() if t.samples]
    firsts = {topic: int(np.min(c.stamp_ns)) for topic, c in live.items() if len(c)}
    if not ends or not firsts:
        return None
    record_end, earliest_end = max(ends), min(ends)
    for topic, first in sorted(firsts.items()):
        tail = tails.get(topic)
        end = tail.last_stamp_ns if tail is not None and tail.samples else earliest_end
        if first <= end:
            return (f'{topic}: the stamps go back (the first new sample at '
                    f'{format_stamp(first)}, the record ends at {format_stamp(end)})')
    gap_ns = min(firsts.values()) - record_end
    if gap_ns > max_gap_s * NS_PER_S:
        return (f'a gap of {gap_ns / NS_PER_S:.6g} s from the end of the record '
                f'({format_stamp(record_end)}) to the first new sample, longer than '
                f'resume_max_gap_s = {max_gap_s:g} s')
    limit = bench_rate_limit_rad_s(tails, bench_max_rate_rad_s)
    rates = _allowed_rates(tails, limit)
    for topic, cols in sorted(live.items()):
        tail = tails.get(topic)
        if tail is None or not tail.samples or not len(cols):
            continue
        i = int(np.argmin(cols.stamp_ns))
        frame = cols.frame_id.names[int(cols.frame_id.codes[i])]
        if frame != tail.last_frame_id:
            return (f'{topic}: another sensor (frame_id {frame!r}; the record ends with '
                    f'{tail.last_frame_id!r})')
        dt_s = (int(cols.stamp_ns[i]) - tail.last_stamp_ns) / NS_PER_S
        for name, is_angle in continuous_columns(topic, tail.msgtype).items():
            if name not in cols.values or name not in tail.last:
                continue
            value, last = float(np.asarray(cols.values[name])[i]), tail.last[name]
            if not (math.isfinite(value) and math.isfinite(last)):
                continue
            moved = value - last
            if is_angle:
                moved = math.remainder(moved, 2 * math.pi)
            rate = rates.get((topic, name), math.inf)
            allowed = RATE_MARGIN * rate * dt_s + 2 * tail.max_step[name]
            if abs(moved) > allowed:
                what = 'angle' if is_angle else 'count'
                bench = (f'the bench\'s fastest table rate ({math.degrees(limit):.6g} °/s) '
                         if math.isfinite(limit) and tails_have_tables(tails) else
                         'the recorded rate ')
                return (f'{topic}: the {what} ({name}) jumps by {moved:.10g} in {dt_s:.6g} s '
                        f'after the record (from {last:.10g} to {value:.10g}); {bench}'
                        f'allows at most {allowed:.6g}')
    return None


def tails_have_tables(tails: Mapping[str, TopicTail]) -> bool:
    """Whether the record holds a table's encoder angle (a ``…/joint_states`` topic)."""
    return any(a for t in tails.values()
               for a in continuous_columns(t.topic, t.msgtype).values())


def set_aside(directory: Path) -> Path:
    """Rename a state directory to ``<directory>.superseded-<UTC time>[-n]``; the new path.

    Never overwrites: a second move in the same second gets ``-2``, ``-3`` ….
    """
    stamp = time.strftime('%Y%m%dT%H%M%S', time.gmtime())
    aside = directory.with_name(f'{directory.name}.superseded-{stamp}')
    n = 1
    while aside.exists():
        n += 1
        aside = directory.with_name(f'{directory.name}.superseded-{stamp}-{n}')
    if directory.exists():
        directory.rename(aside)
    return aside


class StateLock:
    """One writer per state directory: an advisory ``flock`` on ``<directory>.lock``.

    The kernel releases the lock when the process ends however it ends, so a killed node
    leaves no stale lock behind; the file names the holder's pid and start time for the
    message another writer gets. A lock file this process created is removed when it lets
    the lock go, and at the latest when the process exits (a killed one leaves it).
    """

    def __init__(self, directory: Path) -> None:
        """A lock for the state directory ``directory`` (not yet taken)."""
        self.directory = directory
        self.path = directory.with_name(directory.name + '.lock')
        self._lock = FileLock(self.path)
        self.created = False
        """Whether this process created the lock file (then it removes it)."""

    def acquire(self) -> None:
        """Take the directory for this process.

        Raises:
            StateDirectoryInUseError: another live process holds it, or the place cannot be
                written.
        """
        started = time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())
        if self._lock.held:
            return
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            existed = self.path.exists()
            self._lock.acquire(f'pid {os.getpid()} (started {started})')
            self.created = not existed
            atexit.register(self.release)  # a node that ends another way removes it too
        except LockHeldError as exc:
            raise StateDirectoryInUseError(
                f'state directory {self.directory} is being written by {exc.holder}: give '
                'this node its own output_file or state_dir, or stop the other one.') from None
        except OSError as exc:
            raise StateDirectoryInUseError(
                f'state directory {self.directory} cannot be written ({exc.strerror}): give '
                'state_dir (or output_file) a writable place.') from exc

    def release(self, *, remove: bool = False) -> None:
        """Let another process take the directory; ``remove`` the lock file too.

        The lock file is removed as well when this process created it (while the lock is
        still held: no other process holds it then).
        """
        self._lock.release(remove=remove or self.created)


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
        write_text_atomically(self.directory / STATE_FILE,  # the one output writer
                              yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))

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
        self._close_files()

    def clear(self) -> None:
        """Remove the record (``reset``); the next sample recorded starts a new one."""
        self.remove()
        self._forget()

    def set_aside(self) -> Path:
        """Move the record to ``<directory>.superseded-<UTC time>`` and start an empty one.

        Nothing of it is deleted or used; a second move in the same second gets ``-2``,
        ``-3`` … so no record ever overwrites another.
        """
        self._close_files()
        aside = set_aside(self.directory)
        self._forget()
        return aside

    def remove(self) -> None:
        """Close the files and remove the state directory (a completed calibration)."""
        self._close_files()
        shutil.rmtree(self.directory, ignore_errors=True)

    def _close_files(self) -> None:
        for f in self._files.values():
            f.close()
        self._files.clear()

    def _forget(self) -> None:
        """Start an empty record: no topic, no frame name, no batch recorded yet."""
        self._layouts.clear()
        self._index.clear()
        self._frames.clear()
        self._batch = 0

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

    def tails(self) -> dict[str, TopicTail]:
        """How each topic's record ends (what new data must continue to resume it)."""
        out: dict[str, TopicTail] = {}
        for topic, layout in self._layouts.items():
            rec, _ = self._read_topic(topic)
            if not len(rec):
                continue
            order = np.argsort(rec['stamp_ns'], kind='stable')
            stamps = rec['stamp_ns'][order]
            last: dict[str, float] = {}
            max_rate: dict[str, float] = {}
            max_step: dict[str, float] = {}
            columns = self._columns(topic, rec[order]).values
            for name in continuous_columns(topic, layout.msgtype):
                v = np.asarray(columns.get(name, np.zeros(0)), dtype=np.float64)
                if v.ndim != 1 or not len(v):
                    continue
                ok = np.isfinite(v)
                last[name] = float(v[-1])
                step = np.abs(np.diff(v[ok]))
                dt = np.diff(stamps[ok]) / NS_PER_S
                moving = dt > 0
                max_step[name] = float(step.max()) if len(step) else math.inf
                max_rate[name] = (float(np.max(step[moving] / dt[moving])) if moving.any()
                                  else math.inf)
            names = sorted(self._frames[topic], key=self._frames[topic].__getitem__)
            frame = names[int(rec['frame'][order[-1]])] if names else ''
            out[topic] = TopicTail(topic, layout.msgtype, len(rec), int(stamps[-1]), last,
                                   max_rate, max_step, frame)
        return out

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
