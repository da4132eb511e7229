"""A calibration node's state directory in ROS terms: resume after a crash, clear when done.

The record itself (:class:`gyro_calib.state_record.StateRecord`) is pure core; this module
wires it to a node: it opens the record at start-up (refusing another gyro's or method's
record in one line), replays it into the node's session before the first live batch, logs
what it resumed, appends every batch before the session sees it, and removes the record
once the calibration is complete (unless ``keep_state``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gyro_calib.bagio import SampleBatch
from gyro_calib.state_record import StateRecord, StateRecordError
from gyro_calib.units import format_stamp

if TYPE_CHECKING:
    from rclpy.node import Node

    from gyro_calib.bagio.columns import TopicColumns


def calibration_complete(missing: Mapping[str, str], not_measurable: Mapping[str, str]) -> bool:
    """True when nothing the bench could give is missing: the hand-off file's ``complete``.

    A key no run on such a bench could give (``not_measurable``, e.g. θ on a plain rate
    table, the full-scale FOG nonlinearity of a mapping-only table) does not keep a run open.
    """
    return not set(missing) - set(not_measurable)


NOT_IDENTITY = frozenset({'output_file', 'state_dir', 'keep_state', 'process_period_s',
                          'results_period_s', 'kalibr_file', 'plot_file', 'best_effort',
                          'use_sim_time'})
"""Parameters that do not change what the session computes from the data."""


def state_directory(state_dir: str, output_file: str) -> Path | None:
    """The node's state directory, or None.

    ``state_dir`` as given, else ``<output_file>.state`` beside the hand-off file, else
    None (a node that writes no file keeps no record unless asked to).
    """
    if state_dir:
        return Path(state_dir)
    if output_file:
        return Path(output_file + '.state')
    return None


def feed_columns(feed: Callable[[SampleBatch], None],
                 columns: Mapping[str, TopicColumns]) -> int:
    """Hand topic → columns to a session's ``feed`` as one batch; the samples handed."""
    n = sum(len(c) for c in columns.values())
    if n:
        last = max(int(c.stamp_ns.max()) for c in columns.values() if len(c))
        feed(SampleBatch(dict(columns), n, last))
    return n


class NodeState:
    """The state directory of one calibration node.

    Args:
        node: the node (for its logger).
        method: the method's registry name (part of the record's identity).
        gyro_id: the gyro's id (part of the record's identity).
        directory: where the record lives; None = no record.
        keep: keep the record after a completed calibration.
        parameters: the node's parameters; a record made with other values is refused
            (those in :data:`NOT_IDENTITY` do not change the results and may differ).

    Raises:
        StateRecordError: the directory holds another gyro's or method's record.
    """

    def __init__(self, node: Node, method: str, gyro_id: str, directory: Path | None,
                 keep: bool, parameters: Mapping[str, Any] | None = None) -> None:
        """Open (or start) the record for this gyro, method and parameters."""
        self.node, self.keep = node, keep
        self.directory = directory
        identity = {'method': method, 'gyro_id': gyro_id}
        identity.update({f'parameter {k}': repr(v) for k, v in sorted(
            (parameters or {}).items()) if k not in NOT_IDENTITY})
        self.record = None if directory is None else self._open(directory, identity)
        self._resumed = False
        if self.record is not None:
            node.get_logger().info(f'state directory: {directory} (the data consumed are '
                                   'recorded there and replayed after a crash)')

    def _open(self, directory: Path, identity: dict[str, str]) -> StateRecord:
        """The record in ``directory``, or a new one.

        The record in ``directory``; one of another gyro, method or parameter set is
        moved aside (never deleted, never mixed in) and a new one started, with a warning.
        """
        try:
            return StateRecord(directory, identity)
        except StateRecordError as exc:
            stamp = time.strftime('%Y%m%dT%H%M%S', time.gmtime())
            aside = directory.with_name(f'{directory.name}.superseded-{stamp}')
            directory.rename(aside)
            self.node.get_logger().warning(
                f'{" ".join(str(exc).split())} It was moved to {aside} (nothing of it is '
                'used); this run starts a new record.')
            return StateRecord(directory, identity)

    def resume_once(self, feed: Callable[[SampleBatch], None],
                    process: Callable[[], list[str]]) -> None:
        """Before the first live batch: replay what the record holds into the session."""
        if self._resumed:
            return
        self._resumed = True
        if self.record is None:
            return
        summary = self.record.summary()
        if summary.messages == 0:
            return
        log = self.node.get_logger()
        for columns in self.record.replay():
            feed_columns(feed, columns)
            for line in process():
                log.info(line)
        cut = (f'; {summary.dropped_bytes} bytes of a record cut by the crash dropped'
               if summary.dropped_bytes else '')
        last = format_stamp(summary.last_stamp_ns) if summary.last_stamp_ns is not None else '-'
        log.info(f'resumed from {self.directory}: {summary.messages} messages in '
                 f'{summary.batches} batches, up to stamp {last}{cut}; data that arrived while '
                 'no node ran are a gap')

    def record_batch(self, columns: Mapping[str, TopicColumns]) -> None:
        """Append a batch before the session sees it."""
        if self.record is not None:
            self.record.append(columns)

    def reset(self) -> None:
        """Start over: an empty record (``~/reset``)."""
        self._resumed = True
        if self.record is not None:
            self.record.clear()

    def finish(self, *, complete: bool) -> None:
        """End of the run: remove the record when complete (unless ``keep``), else keep it."""
        if self.record is None:
            return
        log = self.node.get_logger()
        if complete and not self.keep:
            self.record.remove()
            log.info(f'calibration complete: state directory {self.directory} removed')
        else:
            self.record.close()
            log.info(f'state kept in {self.directory} '
                     + ('(keep_state)' if complete else '(calibration not complete: a restart '
                        'with the same parameters resumes it)'))
