"""Input subscriptions that take the reliability their publishers offer, as ``ros2 bag record``.

Most sensor drivers publish with the sensor-data QoS (best effort); a reliable reader never
matches them. An :class:`AdaptiveSubscription` reads reliable while every publisher of its
topic offers reliable (backpressure then keeps the no-loss guarantee), best effort as soon as
one offers best effort, and adapts again when publishers come and go (:meth:`adapt`, polled
by the node). The choice and the publishers it rests on are logged. A best-effort reader may
lose samples; the calibrators detect such drops from the stamps and report them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from gyro_calib.nodes.ros_io import SENSOR_QOS

if TYPE_CHECKING:
    from rclpy.node import Node
    from rclpy.subscription import Subscription

BEST_EFFORT_QOS = QoSProfile(depth=1000, history=HistoryPolicy.KEEP_LAST,
                             reliability=ReliabilityPolicy.BEST_EFFORT)
"""Input from best-effort publishers (the sensor-data QoS): a deep queue, so a burst waits
for the callbacks rather than being dropped by the reader."""

RELIABLE, BEST_EFFORT = ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT


def reliability_for(offered: list[ReliabilityPolicy]) -> ReliabilityPolicy | None:
    """The reader's reliability for publishers offering ``offered``.

    The reader's reliability for publishers offering ``offered``: best effort when any
    offers best effort, reliable when all offer reliable, None (keep) when there is none.
    """
    if not offered:
        return None
    return BEST_EFFORT if BEST_EFFORT in offered else RELIABLE


class AdaptiveSubscription:
    """One input topic, re-subscribed with the reliability its publishers offer.

    Args:
        node: the node owning the subscription.
        msg_class: the message class.
        topic: the topic name (relative names resolve in the node's namespace).
        callback: called with each message.
        reliable_qos: the profile while reading reliable (its reliability is RELIABLE).
        forced_best_effort: always best effort, whatever the publishers offer (noise_node's
            ``best_effort`` parameter).
    """

    def __init__(self, node: Node, msg_class: type, topic: str, callback: Callable[[Any], None],
                 reliable_qos: QoSProfile = SENSOR_QOS, *,
                 forced_best_effort: bool = False) -> None:
        """Subscribe (best effort if forced, else reliable until publishers say otherwise)."""
        self.node, self.msg_class, self.callback = node, msg_class, callback
        self.reliable_qos = reliable_qos
        self.forced = forced_best_effort
        self.reliability = BEST_EFFORT if forced_best_effort else RELIABLE
        self.switches = 0
        self._told = ''
        self.subscription: Subscription[Any] = self._subscribe(topic)
        self.topic = self.subscription.topic_name  # resolved: /bench2/gyro/pulses
        if forced_best_effort:
            node.get_logger().info(f'{self.topic}: reading best effort (forced by parameter)')

    def _subscribe(self, topic: str) -> Subscription[Any]:
        qos = BEST_EFFORT_QOS if self.reliability == BEST_EFFORT else self.reliable_qos
        # no QoS event handlers: rclpy's default one warns that nothing can arrive, which
        # adapt() makes untrue, and a handler's pending event outlives the subscription a
        # switch destroys (the EventsExecutor then fails on the destroyed handle: seen here)
        events = SubscriptionEventCallbacks(use_default_callbacks=False)
        return self.node.create_subscription(self.msg_class, topic, self.callback, qos,
                                             event_callbacks=events)

    def offered(self) -> list[ReliabilityPolicy]:
        """The reliability each current publisher of the topic offers."""
        return [i.qos_profile.reliability
                for i in self.node.get_publishers_info_by_topic(self.topic)]

    def adapt(self) -> bool:
        """Follow the publishers: re-subscribe when the reliability they need changed.

        A switch replaces the reader: samples still queued in the old one are lost, and the
        calibrators report that gap from the stamps as any other. Returns True on a switch.
        """
        if self.forced:
            return False
        offered = self.offered()
        wanted = reliability_for(offered)
        if wanted is None:
            return False
        n_best = sum(r == BEST_EFFORT for r in offered)
        switch = wanted != self.reliability
        if switch:
            self.node.destroy_subscription(self.subscription)
            self.reliability = wanted
            self.subscription = self._subscribe(self.topic)
            self.switches += 1
        told = (f'{self.topic}: reading {"reliable" if wanted == RELIABLE else "best effort"} '
                + (f'({n_best} of {len(offered)} publisher(s) offer best effort; samples lost '
                   'on the way show as gaps in the stamps)' if n_best else
                   f'(its {len(offered)} publisher(s) offer reliable)'))
        if told != self._told:
            self._told = told
            self.node.get_logger().info(told)
        return switch

    def destroy(self) -> None:
        """Remove the subscription from the node."""
        self.node.destroy_subscription(self.subscription)
