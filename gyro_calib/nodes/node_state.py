"""A calibration node's state directory in ROS terms: resume after a crash, clear when done.

The record itself (:class:`gyro_calib.state_record.StateRecord`) is pure core; this module
wires it to a node: it opens the record at start-up (moving another gyro's, method's or
parameter set's record aside in one line), and at the first live batch judges whether the
new data continue the record (:func:`gyro_calib.state_record.why_not_continued`: stamps
that follow it within ``resume_max_gap_s``, counts and angles that move no faster than the
bench can move them: ``bench_max_rate_deg_s``, the commanded procedure, or the fastest the
record shows). Only then is the record replayed into the node's session, before that batch;
anything else is a new run: the record is moved aside with one warning naming why and
where it went. Every batch is appended before the session sees it, and the record is
removed once the calibration is complete (unless ``keep_state``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gyro_calib.bagio import SampleBatch
from gyro_calib.nodes.ros_io import refuse_misspelt_parameters
from gyro_calib.state_record import (
    RESUME_MAX_GAP_S,
    StateLock,
    StateRecord,
    StateRecordError,
    set_aside,
    why_not_continued,
)
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
                          'use_sim_time', 'resume', 'resume_max_gap_s',
                          'bench_max_rate_deg_s'})
"""Parameters that do not change what the session computes from the data."""


RESUME_DESCRIPTION = (
    'Resume a record found in the state directory when the new data continue it (stamps '
    'that follow it within resume_max_gap_s, counts and angles that move no faster than the '
    'bench can move them: bench_max_rate_deg_s); false = always start a new run (the '
    'record is moved aside, never deleted).')
BENCH_MAX_RATE_DESCRIPTION = (
    'The fastest any table of the bench turns, °/s: while the node is down a table may start, '
    'stop or reverse at up to this rate, and a resumed record is judged by it (NaN = the '
    "commanded procedure's fastest rate a simulator publishes on /sim/scenario, else the "
    'fastest any table turned in the record).')
RESUME_MAX_GAP_DESCRIPTION = (
    'Longest stamp gap from the end of a state record to the first new sample that still '
    "continues it, s (a longer gap is a new run); NaN = the method's own: max_pair_gap_s "
    '(rbrlg), max_temperature_gap_s (thermal), else 60 s.')


def resume_max_gap_s(given: float, settings: Mapping[str, Any]) -> float:
    """``resume_max_gap_s`` as given, or (NaN) the longest gap the method bridges anyway, s.

    ``max_pair_gap_s`` (rbrlg: no window pair spans more), ``max_temperature_gap_s``
    (thermal: the model bridges that), else :data:`RESUME_MAX_GAP_S`.
    """
    if math.isfinite(given):
        return given
    for key in ('max_pair_gap_s', 'max_temperature_gap_s'):
        if key in settings:
            return float(settings[key])
    return RESUME_MAX_GAP_S


def commanded_max_rate_deg_s(scenario: Mapping[str, Any]) -> float:
    """The fastest table rate of a simulator's commanded procedure (/sim/scenario), °/s.

    The rate table's ``table.rate_deg_s`` and, on a two-axis bench (``theta``, ``full``),
    the position table's ``procedure.position_table_rate_deg_s``; NaN when it names neither.
    """
    rates: list[float] = []
    for part, key in (('table', 'rate_deg_s'), ('procedure', 'position_table_rate_deg_s')):
        section = scenario.get(part)
        value = section.get(key) if isinstance(section, Mapping) else None
        if isinstance(value, (int, float)) and not isinstance(value, bool) \
                and math.isfinite(value) and value > 0:
            rates.append(float(value))
    return max(rates) if rates else math.nan


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
        parameters: the node's parameters; a record made with other values is moved aside
            (those in :data:`NOT_IDENTITY` do not change the results and may differ).
        resume: False = never resume: a record found at start-up is moved aside (the
            ``resume`` parameter).
        max_gap_s: the longest stamp gap from the record's end to new data that still
            continues it (``resume_max_gap_s``), s.
        bench_max_rate_deg_s: the fastest any table of the bench turns, °/s
            (``bench_max_rate_deg_s``; NaN: the commanded procedure's, set later through
            :meth:`commanded`, else the fastest the record shows).
    """

    def __init__(self, node: Node, method: str, gyro_id: str, directory: Path | None,
                 keep: bool, parameters: Mapping[str, Any] | None = None, *,
                 resume: bool = True, max_gap_s: float = RESUME_MAX_GAP_S,
                 bench_max_rate_deg_s: float = math.nan) -> None:
        """Open (or start) the record for this gyro, method and parameters.

        A misspelt parameter stops the node here, before the lock or the record is made
        (:func:`~gyro_calib.nodes.ros_io.refuse_misspelt_parameters`).
        """
        refuse_misspelt_parameters(node)
        self.node, self.keep = node, keep
        self.directory = directory
        self.max_gap_s = max_gap_s
        self.stated_max_rate_deg_s = bench_max_rate_deg_s
        self.commanded_max_rate_deg_s = math.nan
        identity = {'method': method, 'gyro_id': gyro_id}
        identity.update({f'parameter {k}': repr(v) for k, v in sorted(
            (parameters or {}).items()) if k not in NOT_IDENTITY})
        self.lock = None if directory is None else StateLock(directory)
        if self.lock is not None:  # one writer: a second node on this directory stops here
            self.lock.acquire()
        self.record = None if directory is None else self._open(directory, identity)
        self._resumed = False
        self._replay_into: tuple[Callable[[SampleBatch], None],
                                 Callable[[], list[str]]] | None = None
        held = self.record is not None and self.record.summary().messages > 0
        if held and not resume:
            self._set_aside('parameter resume is false')
        self._pending = held and resume
        if self.record is not None:
            node.get_logger().info(
                f'state directory: {directory} (the data consumed are recorded there and '
                'replayed after a crash)' + (
                    '; it holds a record, resumed only if the first new data continue it'
                    if self._pending else ''))

    def _open(self, directory: Path, identity: dict[str, str]) -> StateRecord:
        """The record in ``directory``, or a new one.

        The record in ``directory``; one of another gyro, method or parameter set is
        moved aside (never deleted, never mixed in) and a new one started, with a warning.
        """
        try:
            return StateRecord(directory, identity)
        except StateRecordError as exc:
            aside = set_aside(directory)
            self.node.get_logger().warning(
                f'{" ".join(str(exc).split())} It was moved to {aside} (nothing of it is '
                'used); this run starts a new record.')
            return StateRecord(directory, identity)

    def _set_aside(self, why: str) -> None:
        assert self.record is not None
        summary = self.record.summary()
        aside = self.record.set_aside()
        self.node.get_logger().warning(
            f'state directory {self.directory} not resumed: {why}. This is a new run: the '
            f'record ({summary.messages} messages) was moved to {aside} (nothing of it is '
            'used) and a new one is started.')

    def commanded(self, scenario: Mapping[str, Any]) -> None:
        """A simulator published its procedure: its fastest table rate bounds a resume."""
        rate = commanded_max_rate_deg_s(scenario)
        if math.isfinite(rate):
            self.commanded_max_rate_deg_s = max(rate, self.commanded_max_rate_deg_s) \
                if math.isfinite(self.commanded_max_rate_deg_s) else rate

    def bench_max_rate_rad_s(self) -> float:
        """The bench's fastest table rate stated (or commanded), rad/s; NaN: neither."""
        for rate in (self.stated_max_rate_deg_s, self.commanded_max_rate_deg_s):
            if math.isfinite(rate) and rate > 0:
                return math.radians(rate)
        return math.nan

    def resume_once(self, feed: Callable[[SampleBatch], None],
                    process: Callable[[], list[str]]) -> None:
        """Say where a resumed record is to be replayed (at the first live batch)."""
        if self._replay_into is None:
            self._replay_into = (feed, process)

    def _resume_or_start_anew(self, columns: Mapping[str, TopicColumns]) -> None:
        """At the first live batch: replay the record if the batch continues it, else set aside."""
        self._pending = False
        if self.record is None or self._resumed:
            return
        why = why_not_continued(self.record.tails(), columns, self.max_gap_s,
                                self.bench_max_rate_rad_s())
        if why is not None:
            self._set_aside(why)
            return
        if self._replay_into is None:
            raise RuntimeError('NodeState.resume_once was not called before the first batch')
        feed, process = self._replay_into
        self._resumed = True
        summary = self.record.summary()
        log = self.node.get_logger()
        log.info(f'resuming from {self.directory}: the new data continue its record; replaying '
                 f'{summary.messages} messages (the lines up to "resumed from" are the replay)')
        for recorded in self.record.replay():
            feed_columns(feed, recorded)
            for line in process():
                log.info(line)
        cut = (f'; {summary.dropped_bytes} bytes of a record cut by the crash dropped'
               if summary.dropped_bytes else '')
        last = format_stamp(summary.last_stamp_ns) if summary.last_stamp_ns is not None else '-'
        log.info(f'resumed from {self.directory}: {summary.messages} messages in '
                 f'{summary.batches} batches, up to stamp {last}{cut}; data that arrived while '
                 'no node ran are a gap')

    def record_batch(self, columns: Mapping[str, TopicColumns]) -> None:
        """Append a live batch before the session sees it.

        The first live batch first decides the record found at start-up: replayed into the
        session (given by :meth:`resume_once`) when the batch continues it, else moved aside.
        """
        if self._pending and any(len(c) for c in columns.values()):
            self._resume_or_start_anew(columns)
        if self.record is not None:
            self.record.append(columns)

    def reset(self) -> None:
        """Start over: an empty record (``~/reset``)."""
        self._resumed = True
        self._pending = False
        if self.record is not None:
            self.record.clear()

    def _release(self, *, remove: bool = False) -> None:
        """Let the directory go; the lock file is removed too if this process made it."""
        if self.lock is not None:
            self.lock.release(remove=remove)

    def finish(self, *, complete: bool, not_written: str = '') -> None:
        """End of the run: remove the record when complete (unless ``keep``), else keep it.

        ``not_written``: why the hand-off file was not written (''= it was, or none is
        kept); then the record is kept whatever else holds, with an error line naming it
        and what to do. A record that never got data leaves no directory, and says so.
        """
        log = self.node.get_logger()
        if self.record is None:
            if not_written:
                log.error(f'{not_written}; no state directory keeps the data (state_dir and '
                          'output_file not given): they are lost.')
            return
        if not_written:
            self.record.close()
            self._release()
            if self.directory is not None and self.directory.exists():
                log.error(f'{not_written}: the data consumed are kept in {self.directory} '
                          '(not removed). Move the file away (or free the disk), then start '
                          'the node again with the same parameters while the bench runs: it '
                          'resumes the record and writes the file.')
            else:
                log.error(f'{not_written}; no data were recorded, so no state directory '
                          'was kept.')
            return
        if self._pending:
            self.record.close()
            self._release()
            log.info(f'state directory {self.directory} kept as it was, not resumed: no new '
                     'data came to continue it')
            return
        if complete and not self.keep:
            self.record.remove()
            self._release(remove=True)
            log.info(f'calibration complete: state directory {self.directory} removed')
            return
        self.record.close()
        self._release()
        if self.directory is None or not self.directory.exists():
            log.info(f'no data recorded: no state directory {self.directory} left behind')
            return
        log.info(f'state kept in {self.directory} '
                 + ('(keep_state)' if complete else '(calibration not complete: a restart '
                    'with the same parameters resumes it)'))
