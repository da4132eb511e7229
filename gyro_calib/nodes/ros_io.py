"""Helpers shared by every node: stamps, QoS profiles, parameters from dataclasses."""

from __future__ import annotations

import dataclasses
import math
import signal
import sys
import threading
import time
from collections.abc import Callable, Collection, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from gyro_calib.config import field_descriptions

if TYPE_CHECKING:
    from builtin_interfaces.msg import Time
    from rclpy.context import Context
    from rclpy.executors import Executor
    from rclpy.node import Node
    from rclpy.publisher import Publisher

NodeT = TypeVar('NodeT', bound='Node')
"""The node class a front door runs (its on_stop and done callbacks take that class)."""

SENSOR_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
"""Live sensor streams: reliable, keep all. A KEEP_LAST reader drops silently when its
callbacks lag (measured here); with KEEP_ALL the backlog waits in the reader's queue and a
full writer history makes the publisher wait (see :func:`publish_paced`)."""

EVENT_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
"""Sparse events (zero-index): reliable."""

RESULT_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""Results: the latest value reaches late subscribers."""

SCENARIO_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""/sim/scenario writers: each simulator's description reaches late recorders."""

SCENARIO_READER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=16, reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""/sim/scenario readers: several simulators publish on it and a depth of 1 would keep only
the last to arrive before the callback ran (seen: the table's part lost)."""


def stamp_to_ns(stamp: Time) -> int:
    """builtin_interfaces/Time → int nanoseconds."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_stamp(t_ns: int, stamp: Time) -> Time:
    """Fill ``stamp`` from int nanoseconds (non-negative) and return it."""
    stamp.sec, stamp.nanosec = divmod(int(t_ns), 1_000_000_000)
    return stamp


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _takes(default: Any) -> tuple[str, str]:
    """(what a parameter with ``default`` takes, in words; an example value as typed)."""
    if isinstance(default, bool):
        return 'a boolean', 'true'
    if isinstance(default, int):
        return 'an integer', str(default)
    if isinstance(default, float):
        return 'a number', '1.0' if math.isnan(default) else repr(default)
    if isinstance(default, str):
        return 'a string', "\"'text'\""
    if default and all(isinstance(v, str) for v in default):
        return 'a list of strings', "\"['a', 'b']\""
    if default and all(isinstance(v, int) for v in default):
        return 'a list of integers', '[1, 2]'
    return 'a list of numbers', '[1.0, 2.0]'


def _coerced(name: str, default: Any, given: Any) -> Any:
    """``given`` as the type of ``default``.

    ``given`` as the type of ``default``: an integer (or a list of integers) where a float
    (a list of numbers) is declared becomes a float; anything else is refused.

    Raises:
        ConfigError: naming the parameter, the type it takes and what to pass.
    """
    from gyro_calib.errors import ConfigError

    takes, example = _takes(default)
    if isinstance(default, float) and _is_number(given):
        return float(given)
    if takes == 'a list of numbers' and isinstance(given, list) and all(
            _is_number(v) for v in given):
        return [float(v) for v in given]
    shown = f"'{given}'" if isinstance(given, str) else str(given)
    if isinstance(default, str) and not isinstance(given, (list, dict)):
        example = f'"\'{given}\'"'  # quoted, rcl reads it as a string
    raise ConfigError(f'parameter {name} := {shown} ({type(given).__name__}) is invalid: it '
                      f'takes {takes}; pass e.g. -p {name}:={example}.')


def declare_parameter_value(node: Node, name: str, default: Any,
                            descriptor: ParameterDescriptor) -> Any:
    """Declare one parameter, typed by ``default``, and return its value.

    Every node declares its parameters through here. ROS types ``-p duration_s:=30`` as an
    integer; where a float is declared it is taken as 30.0 (and ``[1, 2]`` as ``[1.0, 2.0]``
    where a list of floats is), and the parameter stays a float. Any other type is refused.

    Raises:
        ConfigError: one line naming the parameter, the type it takes and what to pass
            (:func:`run_node` logs it and exits with status 2).
    """
    from rclpy.exceptions import (
        InvalidParameterTypeException,
        InvalidParameterValueException,
    )

    from gyro_calib.errors import ConfigError

    def given() -> Any:  # the value the user passed (-p name:=...), as rcl typed it
        probe = node.declare_parameter(name, None, ParameterDescriptor(dynamic_typing=True))
        node.undeclare_parameter(name)
        return probe.value

    try:
        try:
            value = node.declare_parameter(name, default, descriptor).value
        except InvalidParameterTypeException:
            value = node.declare_parameter(name, _coerced(name, default, given()), descriptor,
                                           ignore_override=True).value
    except InvalidParameterValueException:  # outside the descriptor's range
        ranges = [f'{r.from_value:g} to {r.to_value:g}'
                  for r in (*descriptor.floating_point_range, *descriptor.integer_range)]
        raise ConfigError(f'parameter {name} := {given()} is out of range: it must lie in '
                          f'{" or ".join(ranges) or "its declared range"}; pass e.g. -p '
                          f'{name}:={_takes(default)[1]}.') from None
    if isinstance(default, list) and value is None:
        value = []
    return value


def number_list_parameter(node: Node, name: str, default: tuple[float, ...] | list[float],
                          description: str) -> list[float]:
    """Declare a list-of-numbers parameter that also takes [] and lists of integers; return it.

    Dynamically typed (a typed array refuses ``[]`` and integer lists where floats are
    declared), then checked here.

    Raises:
        ConfigError: naming the parameter when it is not a list of numbers.
    """
    value: Any = node.declare_parameter(name, list(default), ParameterDescriptor(
        description=description, dynamic_typing=True)).value
    if value is None:  # '-p name:=[]' arrives as NOT_SET
        return []
    if not isinstance(value, list) or not all(_is_number(v) for v in value):
        _coerced(name, [1.0], value)  # raises, naming the parameter
    return [float(v) for v in value]


def described_parameter(node: Node, name: str, default: Any, description: str) -> Any:
    """Declare one parameter with its description; return its value."""
    return declare_parameter_value(node, name, default,
                                   ParameterDescriptor(description=description))


def declare_dataclass_parameters(node: Node, cls: type, prefix: str = '', *,
                                 skip: Collection[str] = (),
                                 number_lists: bool = False) -> dict[str, Any]:
    """Declare one described parameter per field of ``cls``; return the values read.

    Ranges are checked by the dataclass itself (one validation for node, CLI and tests).
    Fields named in ``skip`` are not declared (the node declares or sets them otherwise).
    With ``number_lists``, tuple fields are list-of-number parameters
    (:func:`number_list_parameter`: ``[]`` and integer lists taken), each number made the
    field's element type (int for ``tuple[int, ...]``, else float).
    """
    descriptions = field_descriptions(cls)
    defaults = cls()
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        default = getattr(defaults, f.name)
        text = descriptions.get(f.name, '')
        if number_lists and isinstance(default, tuple):
            kind = int if str(f.type).startswith('tuple[int') else float
            values[f.name] = tuple(kind(v) for v in number_list_parameter(
                node, prefix + f.name, default, text))
            continue
        if isinstance(default, tuple):  # ROS arrays are lists
            default = list(default)
        value = declare_parameter_value(node, prefix + f.name, default,
                                        ParameterDescriptor(description=text))
        values[f.name] = tuple(value) if isinstance(default, list) else value
    return values


def unused_parameters(node: Node) -> list[str]:
    """Parameters given to ``node`` (``-p``, ``--params-file``) that it does not declare."""
    given = set(getattr(node, '_parameter_overrides', {}) or {})
    return sorted(given - set(getattr(node, '_parameters', {}) or {}))


_COMMAND_LINE: list[str] | None = None
"""The command line :func:`run_node` was given, while it runs (None: ``sys.argv``)."""


def note_command_line(args: list[str] | None) -> None:
    """Remember the command line the node was started with (for :func:`misspelt_parameters`)."""
    global _COMMAND_LINE  # noqa: PLW0603 - one node per process, set before it is made
    _COMMAND_LINE = None if args is None else list(args)


def _ros_args(args: list[str]) -> list[str]:
    """The tokens inside ``--ros-args`` … (``--`` or the end) sections."""
    out: list[str] = []
    inside = False
    for token in args:
        if token == '--ros-args':
            inside = True
        elif token == '--':
            inside = False
        elif inside:
            out.append(token)
    return out


def addressed_parameters(args: list[str], node_names: Collection[str]) -> set[str]:
    """Parameters ``args`` give to this node by name, not to every node.

    ``-p name:=value`` (``--param``), and the entries of a ``--params-file`` under the node's
    own name (``/ns/node``, ``node``); a wildcard section (``/**``) is meant for many nodes,
    and what a node lacks there is not a misspelling.
    """
    import yaml

    tokens = _ros_args(args)
    names: set[str] = set()
    own = {n.lstrip('/') for n in node_names}
    for flag, value in zip(tokens, tokens[1:], strict=False):
        if flag in ('-p', '--param') and ':=' in value:
            name = value.split(':=', 1)[0]
            node, _, name = name.rpartition(':')  # 'node:name' addresses one node
            if not node or node.lstrip('/') in own:
                names.add(name)
        elif flag == '--params-file':
            try:
                loaded = yaml.safe_load(Path(value).read_text(encoding='utf-8'))
            except (OSError, UnicodeDecodeError, yaml.YAMLError):
                continue  # rcl says what is wrong with the file
            for key, section in (loaded.items() if isinstance(loaded, dict) else ()):
                if (isinstance(key, str) and key.lstrip('/') in own
                        and isinstance(section, dict)
                        and isinstance(section.get('ros__parameters'), dict)):
                    names.update(_flattened(section['ros__parameters']))
    return names


def _flattened(mapping: dict[Any, Any], prefix: str = '') -> set[str]:
    """Dotted parameter names of a ``ros__parameters`` mapping."""
    out: set[str] = set()
    for key, value in mapping.items():
        if isinstance(value, dict):
            out |= _flattened(value, f'{prefix}{key}.')
        else:
            out.add(f'{prefix}{key}')
    return out


def misspelt_parameters(node: Node) -> list[tuple[str, str]]:
    """(given, the declared parameter it nearly spells) for each misspelt parameter.

    A parameter given to this node by name (:func:`addressed_parameters`) that it does not
    declare, within a difflib ratio of 0.8 of one it does: a typo that ROS would ignore,
    running on the default.
    """
    import difflib

    unused = unused_parameters(node)
    if not unused:
        return []
    args = list(sys.argv) if _COMMAND_LINE is None else _COMMAND_LINE
    mine = addressed_parameters(args, (node.get_name(), node.get_fully_qualified_name()))
    declared = sorted(getattr(node, '_parameters', {}) or {})
    out = []
    for name in unused:
        close = difflib.get_close_matches(name, declared, n=1, cutoff=0.8)
        if name in mine and close:
            out.append((name, close[0]))
    return out


def refuse_misspelt_parameters(node: Node) -> None:
    """Stop before any work on a misspelt parameter (bad input, exit 2 via :func:`run_node`).

    Raises:
        ConfigError: one line naming each misspelt parameter and the one it nearly spells.
    """
    from gyro_calib.errors import ConfigError

    wrong = misspelt_parameters(node)
    if wrong:
        said = '; '.join(f'{given!r} (did you mean {close!r}?)' for given, close in wrong)
        raise ConfigError(
            f'parameter(s) {said} given to {node.get_name()}, which has no such parameter: '
            'a misspelt parameter would be ignored and its default used. Nothing was started; '
            'correct the name (the node\'s parameters: docs/reference (node parameters)).')


def report_unused_parameters(node: Node) -> None:
    """One warning naming the given parameters the node lacks.

    One warning naming the parameters given that the node does not have (a misspelt or
    stale ``-p name:=...`` is otherwise silently ignored by ROS); a misspelt one given to
    this node by name stops it first (:func:`refuse_misspelt_parameters`).
    """
    refuse_misspelt_parameters(node)
    unused = unused_parameters(node)
    if unused:
        node.get_logger().warning(
            f'parameter(s) {", ".join(unused)} given but not declared by {node.get_name()}: '
            'ignored (its parameters: ros2 param list, or docs/reference (node parameters)).')


EXIT_READERS_STALLED = 3
"""Exit status of a simulator stopped because its readers stopped acknowledging
(:class:`ReadersStalled`): the run was not delivered whole (bad input exits 2, a stop by
signal or a finished run 0)."""

EXIT_HANDOFF_NOT_WRITTEN = 1
"""Exit status of a calibration node whose last write of its hand-off file failed (the file
replaced by something else during the run, the disk full): its state directory is kept."""


def run_node(node_name: str, make_node: Callable[[], NodeT], args: list[str] | None = None,
             *, on_stop: Callable[[NodeT, Executor], None] | None = None,
             done: Callable[[NodeT], bool] | None = None) -> None:
    """Run ``make_node()`` until SIGINT/SIGTERM (or ``done(node)``), then stop it cleanly.

    The node owns SIGINT and SIGTERM: they only set a flag. The spin loop ends,
    ``on_stop(node, executor)`` runs (flush, final results, hand-off) while the
    context is still up, then executor and node are torn down *before* the context
    shuts down. With rclpy's own handler the context was shut down under a waiting
    EventsExecutor, and the teardown afterwards crashed with SIGSEGV once in CI.
    A :class:`~gyro_calib.errors.GyroCalibError` or ``ValueError`` from ``make_node``
    (bad parameters) is logged as fatal in one line and exits with status 2 (bad input, as
    the command line); a stop by signal exits 0. A simulator whose readers stopped
    acknowledging (:class:`ReadersStalled` from :func:`publish_paced`) logs one line saying
    so and exits with :data:`EXIT_READERS_STALLED`, without a traceback. A node whose
    ``exit_status`` attribute is not 0 once stopped exits with it (a calibration node whose
    hand-off file could not be written: :data:`EXIT_HANDOFF_NOT_WRITTEN`).
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException

    from gyro_calib.errors import GyroCalibError
    from gyro_calib.nodes.ros_distribution import ros_context
    from gyro_calib.startup_interrupt import end_of_starting

    end_of_starting()  # loaded: from here Ctrl-C stops the node cleanly (not restored after)
    stop = threading.Event()
    stalled = False
    status = 0
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        with ros_context(args, own_signals=True):
            note_command_line(args)
            try:
                node = make_node()
            except (GyroCalibError, ValueError) as exc:
                rclpy.logging.get_logger(node_name).fatal(' '.join(str(exc).split()))
                raise SystemExit(2) from None
            try:
                report_unused_parameters(node)
            except GyroCalibError as exc:  # a node that makes no state checks here
                rclpy.logging.get_logger(node_name).fatal(' '.join(str(exc).split()))
                node.destroy_node()
                raise SystemExit(2) from None
            executor = make_executor()
            executor.add_node(node)
            reason = ''  # why a simulator stopped before the end of its run
            try:
                while not stop.is_set() and rclpy.ok() and not (done and done(node)):
                    executor.spin_once(timeout_sec=0.1)
                if on_stop is not None:
                    on_stop(node, executor)
            except ExternalShutdownException:
                pass
            except ReadersStalled as exc:  # a callback not guarded by stops_on_stalled_readers
                reason = str(exc)
            finally:
                reason = reason or str(getattr(node, 'stalled', '') or '')
                if reason:  # one line, no traceback, no wait for that reader
                    stalled = True
                    node.get_logger().error(f'{reason}; stopping before the end of the run.')
                status = int(getattr(node, 'exit_status', 0) or 0)
                executor.remove_node(node)
                executor.shutdown()
                node.destroy_node()
                del executor
    finally:
        note_command_line(None)  # a later node in this process reads its own command line
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if stalled:
        raise SystemExit(EXIT_READERS_STALLED)
    if status:
        raise SystemExit(status)


DRAIN_QUIET_S = 2.0
"""How long no message may arrive before a node's readers count as drained, s: on a loaded
machine a node can go half a second without the CPU while its readers still hold
acknowledged messages (a bag of a two-bench run lost its last window pair with 0.5 s while
two test runs shared 2 cores)."""


INPUT_HOLD_S = 5.0
"""How long an input topic may deliver nothing before it stops holding the others, s
(:class:`~gyro_calib.streams.WatermarkMerge`; also the others' stamps must have run twice
its largest stamp gap past its newest). While every topic delivers, live input is
ordered by stamps alone; a sparse topic (zero-index, injection) whose next message lags the
dense ones by less than this changes nothing, by more, the window that needed it is rejected
with a line. It sets when results appear, never what they are. Measured: an unpaced replay
into a FOG node on 2 shared cores delivered one topic up to 2.0 s behind another."""


def spin_until_quiet(executor: Any, received: Callable[[], int], *,
                     quiet_s: float = DRAIN_QUIET_S, limit_s: float = 60.0) -> None:
    """Spin until ``received()`` has not changed for ``quiet_s`` (at most ``limit_s``).

    A reliable writer counts a sample delivered once our DDS reader holds it, before our
    callback ran: at the end of a recording the node takes that backlog in before it
    closes its files.
    """
    deadline = time.monotonic() + limit_s
    seen, quiet_since = received(), time.monotonic()
    while time.monotonic() - quiet_since < quiet_s and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
        now = received()
        if now != seen:
            seen, quiet_since = now, time.monotonic()


class StartGate:
    """When a simulator may start publishing: once every sensor topic has its readers.

    A simulator whose first samples nobody reads would be integrated from the wrong instant
    by the gyro simulator and missed by the calibrator. After every publisher has
    ``min_readers`` readers, ``settle_s`` more let the readers' side of discovery finish.
    With ``wait`` off the gate opens at once. :attr:`opened_at` is the monotonic wall time
    it opened (the simulators pace from it). With a ``logger`` it says what it waits for
    ("waiting for a reader of /rate_table/zero_index"), again whenever that changes, and
    when it opens.
    """

    def __init__(self, wait: bool, *, min_readers: int = 1, settle_s: float = 1.0,
                 logger: Any = None) -> None:
        """A gate, open at once unless ``wait``."""
        self.wait, self.min_readers, self.settle_s = wait, min_readers, settle_s
        self.opened_at: float | None = None
        self._readers_since: float | None = None
        self._logger = logger
        self._waiting_for: tuple[str, ...] | None = None

    def open(self, publishers: list[Publisher[Any]],
             internal: Sequence[Publisher[Any]] = ()) -> bool:
        """True once the gate is open (it stays open).

        Args:
            publishers: the sensor topics; each needs ``min_readers`` readers.
            internal: simulator-internal topics (the true motion a gyro simulator reads,
                which no recorder or calibrator does); each needs one reader.
        """
        if self.opened_at is not None:
            return True
        if self.wait:
            lacking = tuple(sorted({p.topic_name for p in publishers
                                    if p.get_subscription_count() < self.min_readers}
                                   | {p.topic_name for p in internal
                                      if p.get_subscription_count() < 1}))
            if lacking != self._waiting_for:
                self._waiting_for = lacking
                if self._logger is not None and lacking:
                    what = 'a reader' if self.min_readers == 1 else f'{self.min_readers} readers'
                    self._logger.info(f'waiting for {what} of {", ".join(lacking)}')
                elif self._logger is not None:
                    self._logger.info(f'every topic has its readers; starting in '
                                      f'{self.settle_s:g} s')
            if lacking:
                self._readers_since = None
                return False
            if self._readers_since is None:
                self._readers_since = time.monotonic()
            if time.monotonic() - self._readers_since < self.settle_s:
                return False
        self.opened_at = time.monotonic()
        return True


class ProgressLog:
    """Progress lines of a long run, rate-limited.

    Progress lines of a long run, at most one per ``period_s`` of wall time:
    "<what>: 120 of 600 s simulated (20 %), 4.9× real time".
    """

    def __init__(self, logger: Any, what: str, total_s: float, *,
                 period_s: float = 10.0) -> None:
        """Log ``what`` every ``period_s`` of wall time out of ``total_s``."""
        self._logger, self.what, self.total_s, self.period_s = logger, what, total_s, period_s
        self._started = time.monotonic()
        self._last = self._started

    def update(self, done_s: float) -> None:
        """Log the progress if ``period_s`` has passed since the last line."""
        now = time.monotonic()
        if now - self._last < self.period_s:
            return
        self._last = now
        self._logger.info(progress_line(self.what, done_s, self.total_s, now - self._started))


def progress_line(what: str, done_s: float, total_s: float, wall_s: float) -> str:
    """'<what>: D of T s (P %), F× real time' (T unknown: 'D s so far')."""
    speed = f', {done_s / wall_s:.1f}× real time' if wall_s > 0 else ''
    if total_s > 0 and math.isfinite(total_s):
        return (f'{what}: {done_s:.0f} of {total_s:.0f} s ({100 * done_s / total_s:.0f} %)'
                f'{speed}')
    return f'{what}: {done_s:.0f} s so far{speed}'


def changes_line(before: Any, after: Any) -> str | None:
    """What changed between two sets of keys still missing, in one line; None if nothing.

    A node that repeated its whole missing list on every update says instead which keys
    are now measured and which are now missing (a key a bench turns out to be able to give,
    e.g. the self-calibration keys once injection starts, was never measured: it is not
    'no longer measured'; the first call, ``before`` None, lists all).
    """
    after = set(after)
    if before is None:
        return f'still missing: {", ".join(sorted(after))}' if after else 'complete'
    before = set(before)
    if before == after:
        return None
    parts = []
    if before - after:
        parts.append(f'now measured: {", ".join(sorted(before - after))}')
    if after - before:
        parts.append(f'now missing: {", ".join(sorted(after - before))}')
    parts.append(f'{len(after)} still missing' if after else 'complete')
    return '; '.join(parts)


def simulation_done(node: Any) -> bool:
    """True when a simulator node's run is over.

    A simulator node has published its whole run and is asked to exit then, or its
    readers stalled (``node.stalled``: :func:`stops_on_stalled_readers`).
    """
    return bool(getattr(node, 'stalled', '')) or bool(node.done and node.exit_when_done)


def acknowledge_tail(node: Any, _executor: Executor | None = None, *,
                     patience_s: float = 60.0) -> None:
    """Before a finished simulator exits, let lagging readers acknowledge its last samples."""
    from rclpy.duration import Duration

    if not node.done:
        return
    for pub in node.all_publishers:
        if not pub.wait_for_all_acked(Duration(seconds=patience_s)):
            node.get_logger().warning(f'{pub.topic_name}: readers did not acknowledge the last '
                                      f'samples within {patience_s:g} s; exiting anyway.')


def spin(node: Node) -> None:
    """Spin ``node`` in :func:`make_executor`'s executor until shutdown (tests, tools)."""
    import rclpy

    executor = make_executor()
    executor.add_node(node)
    while rclpy.ok():  # EventsExecutor.spin() does not return on shutdown here
        executor.spin_once(timeout_sec=0.1)


def make_executor(context: Context | None = None) -> Executor:
    """The executor every gyro_calib node spins in.

    rclpy's EventsExecutor takes > 10 000 JointState messages/s on this class of
    machine where the default SingleThreadedExecutor falls behind at a few thousand
    (measured; see docs/development/performance.md), so 1 kHz streams replay well above real time.
    """
    from rclpy.experimental.events_executor import EventsExecutor

    return EventsExecutor(context=context)


class ReadersStalled(Exception):
    """The readers of a reliable topic stalled.

    The readers of a reliable topic acknowledged nothing for the publisher's patience: a
    reader stopped reading (hung, paused, or still shutting down) while it is still
    connected. :func:`run_node` ends the node on it with one line saying so, no traceback.
    """


def stops_on_stalled_readers(callback: Callable[..., None]) -> Callable[..., None]:
    """Decorate a simulator's publishing callback against stalled readers.

    Decorate a simulator's publishing callback: :class:`ReadersStalled` from it records
    the reason on the node (``node.stalled``) instead of escaping into the executor (which
    logs it as a fatal exception with a stack); :func:`simulation_done` then ends the spin
    and :func:`run_node` says why in one line.
    """
    import functools

    @functools.wraps(callback)
    def guarded(node: Any, *args: Any, **kwargs: Any) -> None:
        if getattr(node, 'stalled', ''):
            return
        try:
            callback(node, *args, **kwargs)
        except ReadersStalled as exc:
            node.stalled = str(exc)
    return guarded


def reader_nodes(graph: Node, topic: str) -> list[str]:
    """The nodes reading ``topic`` as ``graph`` sees them (``/ns/name``, one per reader)."""
    return [f"{info.node_namespace.rstrip('/')}/{info.node_name}"
            for info in graph.get_subscriptions_info_by_topic(topic)]


def publish_paced(publisher: Publisher[Any], msg: object, *, patience_s: float = 30.0,
                  graph: Node | None = None) -> None:
    """Publish on a reliable topic; if the reader lags so far that DDS refuses, wait and retry.

    A reliable writer whose history is full of unacknowledged samples fails with
    "cannot publish data" (measured here). A simulator must not crash nor drop then:
    it waits for the readers' acknowledgements and tries again, which slows the
    whole simulated bench to the pace of its slowest reader.

    ``graph``: the publishing node, if given, names the readers (their nodes) in the error,
    and a publish refused because a Ctrl-C shut its context down just returns.

    Raises:
        ReadersStalled: if the readers acknowledge nothing for ``patience_s`` (naming the
            topic and its readers).
    """
    from rclpy._rclpy_pybind11 import RCLError  # the error rclpy's publish() raises
    from rclpy.duration import Duration

    deadline = time.monotonic() + patience_s
    while True:
        try:
            publisher.publish(msg)
            return
        except RCLError:
            if graph is not None and not graph.context.ok():
                return  # a Ctrl-C shut rclpy down: nothing more goes out, no traceback
            if time.monotonic() > deadline:
                readers = f'{publisher.get_subscription_count()} connected'
                names = [] if graph is None else reader_nodes(graph, publisher.topic_name)
                if names:
                    readers += ': ' + ', '.join(sorted(names))
                raise ReadersStalled(
                    f'the reader(s) of {publisher.topic_name} ({readers}) '
                    f'acknowledged nothing for {patience_s:g} s: a reader stopped reading '
                    'while still connected (hung, paused or ending), so the rest of the run '
                    'cannot be delivered') from None
            try:
                publisher.wait_for_all_acked(Duration(seconds=1.0))
            except RCLError:
                if graph is not None and not graph.context.ok():
                    return
                raise
