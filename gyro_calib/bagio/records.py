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


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """One topic of a bag: name, message type, message count."""

    name: str
    msgtype: str
    count: int


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
    """

    path: Path
    topics: dict[str, TopicInfo]
    start_ns: int
    end_ns: int
    message_count: int
    scenario: dict[str, Any] = field(default_factory=dict)
    namespace: str = ''
    namespace_scenarios: dict[str, dict[str, Any]] = field(default_factory=dict)

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
    """

    columns: dict[str, Any]
    messages: int
    last_log_time_ns: int

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
