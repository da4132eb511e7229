"""bag_player: play a rosbag2 MCAP bag back over DDS, like ``ros2 bag play``.

Messages go out unchanged (the recorded CDR bytes, so header stamps are the original
ones), in log-time order, paced at ``rate`` × the recorded timing, or as fast as the
readers acknowledge (``rate`` 0). With ``clock`` true it also publishes /clock
(rosgraph_msgs/Clock) from the log times, as ``ros2 bag play --clock`` does.

Parameters: ``bag`` (path, required), ``rate`` (1.0), ``clock`` (false),
``clock_period_s`` (0.01), ``topics`` (default: every topic in the bag),
``wait_for_subscribers`` (true: start once every topic has a reader, so nothing is
lost at the start).
Topics are published relative to the node's namespace: under ``__ns:=/bench2`` a bag of
one bench plays as the bench in /bench2 (/clock stays global).

    bag_player --ros-args -p bag:=bags/k_tilde_bench -p rate:=5.0
"""

from __future__ import annotations

import functools
import importlib
import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from gyro_calib.bagio import bag_info, iter_raw_messages
from gyro_calib.errors import GyroCalibError
from gyro_calib.nodes.ros_distribution import ros_context
from gyro_calib.nodes.ros_io import (
    SENSOR_QOS,
    ProgressLog,
    described_parameter,
    ns_to_stamp,
    publish_paced,
    refuse_misspelt_parameters,
    report_unused_parameters,
)
from gyro_calib.topics import relative

if TYPE_CHECKING:
    from rclpy.publisher import Publisher


def message_class(msgtype: str) -> type:
    """'sensor_msgs/msg/JointState' → the rclpy message class."""
    package, _, name = msgtype.split('/')
    cls: type = getattr(importlib.import_module(f'{package}.msg'), name)
    return cls


class BagPlayer(Node):
    """Publishes one bag's messages with their recorded timing."""

    def __init__(self) -> None:
        """Declare parameters, open the bag, create one publisher per topic."""
        super().__init__('bag_player')
        param = functools.partial(described_parameter, self)

        self.path = Path(param('bag', '', 'Bag directory to play (required).'))
        self.rate = float(param('rate', 1.0, 'Multiple of the recorded timing '
                                '(0 = as fast as the readers acknowledge).'))
        self.clock = bool(param('clock', False, 'Publish /clock from the log times.'))
        self.clock_period_ns = int(float(param('clock_period_s', 0.01,
                                               'Log-time period of /clock messages, s.')) * 1e9)
        wanted = list(param('topics', [''], 'Topics to play (default: all).'))
        self.wait = bool(param('wait_for_subscribers', True, 'Start once every played topic '
                               'has a reader.'))
        self.start_offset_s = float(param('start_offset_s', 0.0, 'Skip the first seconds of '
                                          'the bag (log time from its start), s.'))
        refuse_misspelt_parameters(self)  # named before what the typo may have caused
        if not math.isfinite(self.start_offset_s) or self.start_offset_s < 0:
            raise GyroCalibError(f'start_offset_s must be a finite number ≥ 0, got '
                                 f'{self.start_offset_s}.')
        if self.rate < 0:
            raise GyroCalibError(f'rate must be ≥ 0, got {self.rate}.')
        self.info = bag_info(self.path)
        if self.start_offset_s >= self.info.duration_s > 0:
            raise GyroCalibError(f'start_offset_s {self.start_offset_s:g} s is past the end of '
                                 f'{self.path} ({self.info.duration_s:g} s long).')
        names = [t for t in wanted if t] or list(self.info.topics)
        unknown = sorted(set(names) - set(self.info.topics))
        if unknown:
            raise GyroCalibError(f'{self.path}: no topic(s) {", ".join(unknown)} in the bag.')
        self.publishers_by_topic: dict[str, Publisher[Any]] = {
            name: self.create_publisher(message_class(self.info.topics[name].msgtype),
                                        relative(name), SENSOR_QOS)
            for name in names}
        self.clock_pub = None
        if self.clock:
            from rosgraph_msgs.msg import Clock
            self.clock_pub = self.create_publisher(Clock, '/clock', SENSOR_QOS)
        self.published = 0

    def wait_for_readers(self, timeout_s: float = 60.0) -> bool:
        """Block until every played topic has a reader.

        Block until every played topic has a reader (or ``timeout_s``), saying which
        topics it waits for whenever that changes.
        """
        deadline = time.monotonic() + timeout_s
        waiting: set[str] | None = None
        while time.monotonic() < deadline:
            lacking = {t for t, p in self.publishers_by_topic.items()
                       if not p.get_subscription_count()}
            if lacking != waiting and lacking:
                self.get_logger().info(f'waiting for a reader of {", ".join(sorted(lacking))}')
            waiting = lacking
            if not lacking:
                time.sleep(1.0)  # let the readers' side of discovery finish too
                return True
            time.sleep(0.05)
        return False

    def play(self) -> None:
        """Publish every message, paced; return when the bag is done."""
        from rosgraph_msgs.msg import Clock

        first_log: int | None = None
        wall_start = time.monotonic()
        next_clock = None
        progress = ProgressLog(self.get_logger(), 'played', self.info.duration_s)
        skip_before_ns = self.info.start_ns + round(self.start_offset_s * 1e9)
        for topic, _, log_ns, raw in iter_raw_messages(self.path):
            if not rclpy.ok():
                return
            pub = self.publishers_by_topic.get(topic)
            if pub is None or log_ns < skip_before_ns:
                continue
            if first_log is None:
                first_log, wall_start = log_ns, time.monotonic()
            if self.rate > 0:
                due = wall_start + (log_ns - first_log) / 1e9 / self.rate
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            if self.clock_pub is not None and (next_clock is None or log_ns >= next_clock):
                publish_paced(self.clock_pub, Clock(clock=ns_to_stamp(log_ns, Clock().clock)),
                              graph=self)
                next_clock = log_ns + self.clock_period_ns
            publish_paced(pub, raw, graph=self)
            self.published += 1
            progress.update((log_ns - self.info.start_ns) / 1e9)

    def wait_for_acknowledgements(self, timeout_s: float = 60.0) -> None:
        """Let lagging readers take the tail before the process exits."""
        for pub in self.publishers_by_topic.values():
            if not self.context.ok():  # Ctrl-C: rclpy shut the context down; nothing to wait for
                return
            try:
                acked = pub.wait_for_all_acked(rclpy.duration.Duration(seconds=timeout_s))
            except Exception:  # rclpy's RCLError once a Ctrl-C shut the context down meanwhile
                if self.context.ok():
                    raise
                return
            if not acked:
                self.get_logger().warning(f'{pub.topic_name}: readers did not acknowledge '
                                          f'the last messages within {timeout_s:g} s.')


def main(args: list[str] | None = None) -> None:
    """Play the bag given by the ``bag`` parameter, then exit."""
    try:
        with ros_context(args):
            try:
                player = BagPlayer()
                report_unused_parameters(player)
            except GyroCalibError as exc:
                print(f'bag_player: error: {exc}', file=sys.stderr)  # bad input
                raise SystemExit(2) from None
            log = player.get_logger()
            if player.wait and not player.wait_for_readers():
                log.warning('not every topic has a reader after 60 s; playing anyway.')
            log.info(f'playing {player.path} ({player.info.message_count} messages, '
                     f'{player.info.duration_s:.3f} s) at '
                     + (f'{player.rate:g}× the recorded rate' if player.rate
                        else 'the readers\' pace'))
            start = time.monotonic()
            player.play()
            player.wait_for_acknowledgements()
            if not player.context.ok():  # a Ctrl-C shut rclpy down: stopped, not played
                return
            wall = time.monotonic() - start
            log.info(f'played {player.published} messages in {wall:.3f} s '
                     f'({player.info.duration_s / max(wall, 1e-9):.2f}× real time)')
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
