"""Bags given together that hold the same data: refused before any work.

The same recording under two paths (a bag copied elsewhere, ``gyro-calib repair``'s whole
copy beside the damaged original) would have its messages counted twice: twice the
stations, a standard uncertainty √2 too small, degrees of freedom doubled. Two checks, each
cheap where the bags differ:

* identical content (:func:`content_digest`): the bags' file sizes first, then SHA-256 only
  for bags whose sizes match;
* overlapping messages (:func:`shared_message`): two bags holding a topic over overlapping
  log-time spans are read at one instant of the overlap (through the chunk index, one chunk
  each): a message with the same topic, log time and bytes (its header stamp included) in
  both is one recording's message twice. Different runs of one bench (stamps restarted at
  the same instants) differ in their bytes (the noise), so they are not refused.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from gyro_calib.bagio.records import BagInfo
from gyro_calib.bagio.storage import open_reader
from gyro_calib.errors import ConfigError


def bag_files(path: Path) -> list[Path]:
    """The files of a bag: every file of a bag directory, or the one file."""
    path = Path(path)
    if path.is_dir():
        return sorted(p for p in path.rglob('*') if p.is_file())
    return [path] if path.is_file() else []


def size_signature(path: Path) -> tuple[int, ...]:
    """The sorted sizes of the bag's files, bytes: bags differing here differ in content."""
    return tuple(sorted(f.stat().st_size for f in bag_files(path)))


def content_digest(path: Path) -> tuple[str, ...]:
    """Sorted SHA-256 hex digests of the bag's files (their names and places left out)."""
    out = []
    for f in bag_files(path):
        digest = hashlib.sha256()
        with f.open('rb') as stream:
            for block in iter(lambda: stream.read(1 << 20), b''):
                digest.update(block)
        out.append(digest.hexdigest())
    return tuple(sorted(out))


def same_content_pairs(paths: Sequence[Path]) -> list[tuple[Path, Path]]:
    """Pairs (earlier, later) of ``paths`` naming the same file(s) or identical content.

    The same path spelled twice (relative and absolute, through a link) is found by
    resolving; other bags are compared by file sizes, and hashed only when these match.
    """
    pairs: list[tuple[Path, Path]] = []
    by_place: dict[Path, Path] = {}
    rest: list[Path] = []
    for p in map(Path, paths):
        key = p.resolve()
        if key in by_place:
            pairs.append((by_place[key], p))
        else:
            by_place[key] = p
            rest.append(p)
    by_size: dict[tuple[int, ...], list[Path]] = {}
    for p in rest:
        sig = size_signature(p)
        if sig:
            by_size.setdefault(sig, []).append(p)
    for group in by_size.values():
        if len(group) < 2:
            continue
        by_digest: dict[tuple[str, ...], Path] = {}
        for p in group:
            key2 = content_digest(p)
            if key2 in by_digest:
                pairs.append((by_digest[key2], p))
            else:
                by_digest[key2] = p
    return pairs


COMPARED_MESSAGES = 32
"""Messages of each shared topic compared at the start of two bags' overlap: all equal
(topic, log time, bytes) on every shared topic is one recording twice. A message alone can
be equal in two runs (a table at rest at t = 0); 32 of the gyro's, noise included, are not."""


class _Messages:
    """A bag's messages looked up by topic and log time.

    Through rosbags' chunk index, or for a damaged bag (``BagInfo.damage``) through its
    intact chunks (:func:`gyro_calib.bagio.recovery.intact_messages`).
    """

    def __init__(self, info: BagInfo) -> None:
        self.info = info
        self.reader: Any = None
        self.survey: Any = None
        if info.damage is not None:
            from gyro_calib.bagio.recovery import survey

            self.survey = survey(info.damage.mcap_path)
        else:
            self.reader = open_reader(Path(info.path))

    def window(self, topic: str, start_ns: int, stop_ns: int,
               limit: int | None = None) -> list[tuple[int, bytes]]:
        """(log time ns, bytes) of ``topic``'s first ``limit`` messages in [start_ns, stop_ns).

        In log-time order; all of them for ``limit`` None.
        """
        out: list[tuple[int, bytes]] = []
        if self.survey is not None:
            from gyro_calib.bagio.recovery import intact_messages

            ids = {cid for cid, ch in self.survey.channels.items() if ch[0] == topic}
            chunks = tuple(c for c in self.survey.chunks  # only those of the window read
                           if c.first_ns < stop_ns and c.last_ns >= start_ns
                           and any(cid in ids for cid in c.counts))
            window = dataclasses.replace(self.survey, chunks=chunks)
            out = sorted((int(log_ns), bytes(raw)) for cid, log_ns, raw
                         in intact_messages(window)
                         if cid in ids and start_ns <= log_ns < stop_ns)
            return out[:limit]
        cons = [c for c in self.reader.connections if c.topic == topic]
        if cons:
            for _, log_ns, raw in self.reader.messages(connections=cons, start=start_ns,
                                                       stop=stop_ns):
                out.append((int(log_ns), bytes(raw)))
                if limit is not None and len(out) >= limit:
                    break
        return out

    def close(self) -> None:
        """Close the reader (if one was opened)."""
        if self.reader is not None:
            self.reader.close()


def shared_message(a: BagInfo, b: BagInfo) -> str | None:
    """A topic on which bags ``a`` and ``b`` hold one same message, or None.

    For each topic both hold (same type, messages in each) over overlapping log-time spans,
    the first :data:`COMPARED_MESSAGES` messages of each bag inside the overlap are looked up
    at their log times in the other bag: found there, byte for byte, on every shared topic
    (the first topic named), the bags hold one recording's messages twice; one topic
    differing (a rerun of the bench, its noise another) clears them. A bag that cannot be
    read this way is not refused here: its reading says what is wrong with it.
    """
    lo, hi = max(a.start_ns, b.start_ns), min(a.end_ns, b.end_ns)
    if lo > hi:
        return None
    shared = sorted(t for t, ta in a.topics.items() if ta.count and t in b.topics
                    and b.topics[t].count and b.topics[t].msgtype == ta.msgtype)
    if not shared:
        return None
    opened: list[_Messages] = []
    try:
        ma = _Messages(a)
        opened.append(ma)
        mb = _Messages(b)
        opened.append(mb)
        same: list[str] = []
        for topic in shared:
            for first, other in ((ma, mb), (mb, ma)):
                mine = first.window(topic, lo, hi + 1, COMPARED_MESSAGES)
                if not mine:
                    continue
                theirs = set(other.window(topic, mine[0][0], mine[-1][0] + 1))
                if not all(m in theirs for m in mine):
                    return None  # one topic differs: two recordings, not one twice
                same.append(topic)
        return same[0] if same else None
    except Exception:  # noqa: BLE001 -- an unreadable bag: its own reading refuses or notes it
        return None
    finally:
        for m in opened:
            m.close()
    return None


def refuse_repeated_bags(infos: Sequence[BagInfo]) -> None:
    """One line refusing bags given together that hold the same data (before any work).

    Raises:
        ConfigError: two paths naming the same bag or identical copies, or two bags
            holding the same messages (a repaired copy beside its original).
    """
    paths = [Path(i.path) for i in infos]
    for first, second in same_content_pairs(paths):
        how = ('is given twice (as' if first.resolve() == second.resolve()
               else 'holds the same content as (a copy of')
        raise ConfigError(f'bag {second} {how} {first}): its data would be counted twice '
                          '(twice the samples, a smaller uncertainty than measured); give '
                          'one of them.')
    for i, a in enumerate(infos):
        for b in infos[i + 1:]:
            topic = shared_message(a, b)
            if topic is not None:
                raise ConfigError(
                    f'bags {a.path} and {b.path} hold the same {topic} messages (same stamps, '
                    'same bytes: one a copy of the other, e.g. a repaired copy beside its '
                    'original): they would be counted twice; give one of them.')
