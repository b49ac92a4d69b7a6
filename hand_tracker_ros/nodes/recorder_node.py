"""The `recorder` node: records topics to a rosbag2 (mcap) through raw subscriptions.

Discovery. Every ``discovery_period_s`` of wall time (also while a sim-time clock stands
still) the node polls the graph (``get_topic_names_and_types``) for the topics it should
record (``topics``, or every topic with ``all_topics``, minus ``exclude_regex``) that are not
recorded yet. A topic is subscribed
once it has a publisher: its type comes from the graph, its QoS matches the publishers
(:func:`hand_tracker_ros.ros_io.raw.matching_qos`: reliable with a ``queue_depth`` deep
queue for reliable publishers, best effort if any publisher is best effort). A topic whose type
has no importable message module, or is unknown to the bag type store, is skipped with one
error line.

Writing. The raw CDR bytes are written unchanged in the subscription callback
(:meth:`BagWriter.write_raw`, about as cheap as a memory copy), stamped with the receive time
``get_clock().now()`` in ns, as ``ros2 bag record`` does: with ``use_sim_time`` that is the
``/clock`` time. The bag's offered QoS per topic is ``reliable`` or ``sensor_data`` (best
effort), after the subscription's reliability.

Stop. On SIGINT/SIGTERM the executor stops; :meth:`RecorderNode.destroy_node` then takes the
messages DDS still holds for each subscription, writes them, and closes the bag (writing the
mcap summary and ``metadata.yaml``), so the bag is complete and readable.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import partial
from pathlib import Path
from typing import Any, Literal, cast

import rclpy.logging
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription

from hand_tracker_ros.bags.playback import compile_exclude
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.errors import BagFormatError, HandTrackerError
from hand_tracker_ros.node_config import RecorderNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.message_kit import message_class
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.ros_io.raw import drain, matching_qos, parameter_list

DESCRIPTION = 'Records topics to a rosbag2 (mcap) through raw subscriptions.'


class RecorderNode(Node):
    """Records topics into a new bag (behaviour: module docstring).

    Parameters
    ----------
    overrides : mapping of str to value, optional
        Parameter values that take precedence over the defaults.

    Attributes
    ----------
    counts : dict of str to int
        Messages written per topic.

    Raises
    ------
    BagFormatError
        If the output path exists.
    """

    def __init__(self, overrides: Mapping[str, Any] | None = None) -> None:
        # Set first: the context destroys the node if the constructor fails.
        self.counts: dict[str, int] = {}
        self._writer: BagWriter | None = None
        self._subscriptions_by_topic: dict[str, Subscription[Any]] = {}
        self._skipped: set[str] = set()
        super().__init__('recorder', parameter_overrides=parameter_list(overrides or {}))
        bridge_core_logging(self)
        self.config = declare_config(self, RecorderNodeConfig)
        if not self.config.output:
            self.get_logger().info('no `output` parameter: idle')
            return
        self._exclude = compile_exclude(self.config.exclude_regex)
        self._wanted = {self.resolve_topic_name(t) for t in self.config.topics}
        storage = cast(Literal['mcap', 'sqlite3'], self.config.storage)   # the param's choices
        self._writer = BagWriter(Path(self.config.output), storage=storage)
        self._writer.__enter__()
        self.get_logger().info(f'recording to {self._writer.path} ({self.config.storage})')
        # A wall-clock timer: with use_sim_time the ROS clock stands still until a player
        # publishes /clock, and the topics must be subscribed before that.
        self.create_timer(self.config.discovery_period_s, self._discover,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._discover()

    def _wants(self, topic: str) -> bool:
        if topic in self._subscriptions_by_topic or topic in self._skipped:
            return False
        if self._exclude is not None and self._exclude.fullmatch(topic):
            return False
        return self.config.all_topics or topic in self._wanted

    def _discover(self) -> None:
        """Subscribe to every wanted topic that now has a publisher."""
        for topic, types in self.get_topic_names_and_types():
            if not self._wants(topic):
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if not publishers:
                continue
            if len(types) > 1:
                self.get_logger().warning(f'{topic} has several types {types}; recording '
                                          f'{types[0]}')
            self._subscribe(topic, types[0], matching_qos(publishers, self.config.queue_depth))

    def _subscribe(self, topic: str, msgtype: str, qos: QoSProfile) -> None:
        assert self._writer is not None
        best_effort = qos.reliability == ReliabilityPolicy.BEST_EFFORT
        latched = qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
        try:
            cls = message_class(msgtype)
            self._writer.add_topic(topic, msgtype, qos='sensor_data' if best_effort else
                                   'latched' if latched else 'reliable')
        except BagFormatError as err:
            self._skipped.add(topic)
            self.get_logger().error(f'not recording {topic}: {err}')
            return
        self.counts[topic] = 0
        self._subscriptions_by_topic[topic] = self.create_subscription(
            cls, topic, lambda raw, t=topic: self._write(t, raw), qos, raw=True)
        self.get_logger().info(f'recording {topic} ({msgtype}, '
                               f'{"best effort" if best_effort else "reliable"})')

    def _write(self, topic: str, raw: bytes) -> None:
        assert self._writer is not None
        self._writer.write_raw(topic, self.get_clock().now().nanoseconds, raw)
        self.counts[topic] += 1

    def destroy_node(self) -> None:
        """Write what DDS still holds, close the bag, then destroy the node."""
        if self._writer is not None:
            taken = sum(drain(sub, partial(self._write, topic))
                        for topic, sub in self._subscriptions_by_topic.items())
            writer, self._writer = self._writer, None
            writer.close()
            counts = ', '.join(f'{t} {n}' for t, n in sorted(self.counts.items()))
            self.get_logger().info(f'closed {writer.path}: {counts or "no topic"} '
                                   f'({taken} taken at shutdown)')
        super().destroy_node()


def run_recorder(overrides: Mapping[str, Any] | None = None,
                 args: Sequence[str] | None = None) -> int:
    """Record until SIGINT/SIGTERM; return 0.

    Raises
    ------
    HandTrackerError
        If the output exists or a parameter is invalid.
    """
    return run_node('recorder', DESCRIPTION, RecorderNodeConfig,
                    lambda: RecorderNode(overrides), args)


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros recorder`); 1 on an error of ours."""
    try:
        return run_recorder(None, args)
    except HandTrackerError as err:
        rclpy.logging.get_logger('recorder').fatal(str(err))
        return 1


if __name__ == '__main__':
    raise SystemExit(main())
