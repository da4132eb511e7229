"""What a bag holds and the samples read from it.

What a bag holds (:class:`BagInfo`) and the decoded samples read from it
(:class:`SampleBatch`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from gyro_calib import topics
from gyro_calib.bagio.messages import JOINT_STATE
from gyro_calib.units import format_stamp


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """One topic of a bag: name, message type, message count."""

    name: str
    msgtype: str
    count: int


@dataclass(frozen=True, slots=True)
class SkippedChunk:
    """A damaged chunk between intact ones, never used (docs/recovery.md).

    Attributes:
        offset, end: its bytes in the .mcap file, [offset, end).
        start_ns, end_ns: the log times its header (or chunk index) gives, or those of the
            intact chunks around it when its header is damaged too.
        reason: what is wrong with it.
    """

    offset: int
    end: int
    start_ns: int
    end_ns: int
    reason: str

    def line(self, bag: Path | str) -> str:
        """The one line saying it was skipped, naming its stamps."""
        return (f'{bag}: a damaged chunk at bytes {self.offset}–{self.end} '
                f'({format_stamp(self.start_ns)} → {format_stamp(self.end_ns)}, log times) '
                f'was skipped ({self.reason}); windows spanning it are rejected by the '
                f'methods\' gap rules, never bridged.')


@dataclass(frozen=True, slots=True)
class Damage:
    """What of a bag's .mcap file could not be read, and where its readable data ends.

    A bag read record by record (:mod:`gyro_calib.bagio.recovery`): its summary or footer is
    missing, its tail cut, or chunks damaged.

    Attributes:
        mcap_path: the file.
        file_bytes: its size.
        readable_end: the byte where its readable data ends (end of the last intact chunk).
        tail_from: where the unreadable tail begins (None: the file is whole to its footer).
        tail_reason: what is wrong there.
        tail_where: where the tail begins: 'inside a chunk', 'after its last intact chunk'
            or 'in its summary section' (then no message is lost).
        skipped: damaged chunks between intact ones.
        last_stamps_ns: topic → header stamp (log time for types without one) of its last
            intact message.
        lost_messages: topic → messages lost, when ``metadata.yaml`` counts them (else None).
        span_ns: first and last log time of the intact messages.
    """

    mcap_path: Path
    file_bytes: int
    readable_end: int
    tail_from: int | None
    tail_reason: str
    tail_where: str
    skipped: tuple[SkippedChunk, ...] = ()
    last_stamps_ns: dict[str, int] = field(default_factory=dict)
    lost_messages: dict[str, int] | None = None
    span_ns: tuple[int, int] = (0, 0)

    def line(self, bag: Path | str) -> str:
        """One line: where readable data ends, how much is lost, what the results rest on."""
        parts = []
        if self.tail_from is not None:
            tail = self.file_bytes - self.tail_from
            parts.append(f'the last {tail} bytes of the file '
                         f'({100 * tail / max(self.file_bytes, 1):.1f} %)')
        if self.skipped:
            parts.append(f'{sum(s.end - s.offset for s in self.skipped)} bytes in '
                         f'{len(self.skipped)} damaged chunk(s)')
        if self.lost_messages is not None:
            n = sum(self.lost_messages.values())
            per = ', '.join(f'{t} {k}' for t, k in sorted(self.lost_messages.items()) if k)
            parts.append(f'{n} messages ({per})' if n else 'no message')
        else:
            parts.append('an unknown number of messages (no metadata.yaml counts them)')
        stamps = ', '.join(f'{t} {format_stamp(s)}'
                           for t, s in sorted(self.last_stamps_ns.items())) or 'none'
        rests = (f'the results rest on the part before it ({format_stamp(self.span_ns[0])} → '
                 f'{format_stamp(self.span_ns[1])}, log times)')
        if self.tail_from is None:
            head = (f'{bag}: read record by record ({self.tail_reason}); its chunks end at '
                    f'byte {self.readable_end} of {self.file_bytes}')
        else:
            head = (f'{bag}: the recording is cut off or damaged from byte {self.tail_from}, '
                    f'{self.tail_where} ({self.tail_reason}): readable data ends at byte '
                    f'{self.readable_end} of {self.file_bytes}')
        return f'{head}; last stamps: {stamps}; lost: {", ".join(parts)}; {rests}.'

    def lines(self, bag: Path | str) -> list[str]:
        """The line above, then one per skipped chunk."""
        return [self.line(bag), *(s.line(bag) for s in self.skipped)]


@dataclass(frozen=True, slots=True)
class BagInfo:
    """What a bag holds, from its metadata (nothing decoded).

    Attributes:
        path: the bag directory.
        topics: topic name → :class:`TopicInfo`.
        start_ns, end_ns: first and last log time, ns.
        message_count: messages in all topics.
        scenario: the scenario YAML stored by the writer (parameters, seed, truth), or {}.
        namespace: the namespace the bag is seen from ('' = the root; see
            :meth:`in_namespace`): its topics are named as in the contract.
        namespace_scenarios: namespace → the scenario stored for the bench there.
        damage: what could not be read (None: the bag is whole); counts, span and scenario
            are then those of the intact part.
    """

    path: Path
    topics: dict[str, TopicInfo]
    start_ns: int
    end_ns: int
    message_count: int
    scenario: dict[str, Any] = field(default_factory=dict)
    namespace: str = ''
    namespace_scenarios: dict[str, dict[str, Any]] = field(default_factory=dict)
    damage: Damage | None = None

    @property
    def duration_s(self) -> float:
        """Log-time span, s."""
        return (self.end_ns - self.start_ns) / 1e9 if self.message_count else 0.0

    def in_namespace(self, namespace: str) -> BagInfo:
        """The bag as the bench in ``namespace`` sees it.

        The bag as the bench in ``namespace`` sees it: the topics under it, named without
        the namespace ('/bench2/gyro/pulses' → '/gyro/pulses'), the others left out, and that
        bench's scenario. The root namespace ('' or '/') gives the bag as it is.
        """
        ns = topics.normalized_namespace(namespace)
        if not ns:
            return self
        inside = {name[len(ns):]: TopicInfo(name[len(ns):], t.msgtype, t.count)
                  for name, t in self.topics.items() if name.startswith(ns + '/')}
        return dataclasses.replace(self, topics=inside, namespace=ns,
                                   message_count=sum(t.count for t in inside.values()),
                                   scenario=self.namespace_scenarios.get(ns, {}))


@dataclass(slots=True)
class SampleBatch:
    """Decoded samples of a stretch of the bag(s), per topic, in log-time order per topic.

    Attributes:
        columns: topic → its columns (:class:`gyro_calib.bagio.columns.TopicColumns`: header
            stamps, frame_ids, the message type's values).
        messages: how many messages this batch decoded.
        last_log_time_ns: log time of the batch's last message.
        notes: lines about the stretch read (a damaged chunk skipped before it).
    """

    columns: dict[str, Any]
    messages: int
    last_log_time_ns: int
    notes: tuple[str, ...] = ()

    def joint_state(self, topic: str) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64],
                                               npt.NDArray[np.float64]] | None:
        """(header stamp ns, position, velocity) of a JointState topic.

        (header stamp ns, position, velocity) of a JointState topic; NaN where a message
        had no position (or velocity), which the calibrators drop and count.
        """
        c = self.columns.get(topic)
        if c is None or c.msgtype != JOINT_STATE:
            return None
        return c.stamp_ns, c.values['position'], c.values['velocity']

    def stamps(self, topic: str) -> npt.NDArray[np.int64] | None:
        """Header stamps (ns) of a topic's messages (zero-index events)."""
        c = self.columns.get(topic)
        return None if c is None else c.stamp_ns
