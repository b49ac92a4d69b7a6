"""The `player` node: replays a rosbag2 (sqlite3 or mcap) on its original topics.

Each message's raw CDR bytes are published unchanged (``publish(bytes)``, no decoding) on
its bag topic, or the remapped one, at the bag's timing scaled by ``playback.rate``
(:class:`hand_tracker_ros.bags.playback.PlaybackSchedule`). With ``publish_clock`` a
``rosgraph_msgs/Clock`` holding the message's bag time is published on ``/clock`` right before
each message with a new bag time (``ros2 bag play --clock-topics-all``, once per time: the
messages of one frame set share it), so nodes with ``use_sim_time`` follow the bag. Every
``/clock`` message is handled by every sim-time node: before each of the 10 messages of a
synthetic frame, they cost the composed tracker process (three nodes) about 900 callbacks
per second at 30 Hz.

Start and pause. Playback starts once every topic of ``wait_topics`` has
``wait_subscriber_count`` subscribers (or after ``wait_for_subscribers_s``), so the first
messages of a short bag are not published before anyone listens. ``std_srvs`` is not on
PyPI, so pausing is a topic instead of the rosbag2 ``~/pause``/``~/resume`` services:
``std_msgs/Bool`` on ``~/pause`` pauses (``true``) or resumes (``false``); with
``start_paused`` playback waits for the first ``false``. Time spent paused shifts the rest of
the schedule.

End. Without ``playback.loop`` the node waits (up to ``ack_timeout_s``) until reliable
subscribers acknowledged everything, then shuts its context down, so ``spin`` returns and the
process exits with code 0. A bag that fails while playing makes it exit with code 1.

Publishing runs in its own thread (wall-clock sleeps; the executor stays free for ``~/pause``).
"""
from __future__ import annotations

import os
import threading
import time
from collections.abc import Mapping, Sequence
from typing import Any

import rclpy.logging
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.publisher import Publisher
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Bool

from hand_tracker_ros.bags.playback import NS_PER_S, PlaybackSchedule
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.errors import BagFormatError, HandTrackerError
from hand_tracker_ros.node_config import PlayerNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.message_kit import message_class
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.ros_io.raw import clock_msg, keep_last_qos, parameter_list

DESCRIPTION = 'Replays a rosbag2 (sqlite3 or mcap) on its original topics.'
CLOCK_TOPIC = '/clock'
# Longest sleep between checks of the pause and stop flags, s.
_POLL_S = 0.05


class PlayerNode(Node):
    """Replays a rosbag2 (behaviour: module docstring).

    Parameters
    ----------
    overrides : mapping of str to value, optional
        Parameter values (dotted names, e.g. ``'playback.rate'``) that take precedence over
        the defaults; ``--ros-args -p`` still applies to the others.

    Attributes
    ----------
    error : HandTrackerError or None
        Why playback stopped early, if it did.

    Raises
    ------
    BagFormatError
        If the bag is missing or corrupt, or none of its selected topics can be published.
    ConfigError
        For invalid parameters.
    """

    def __init__(self, overrides: Mapping[str, Any] | None = None) -> None:
        # Set first: the context destroys the node if the constructor fails.
        self.error: HandTrackerError | None = None
        self._stop = threading.Event()
        self._resumed = threading.Event()
        self._thread: threading.Thread | None = None
        self._destroyed = False
        super().__init__('player', parameter_overrides=parameter_list(overrides or {}))
        bridge_core_logging(self)
        self.config = declare_config(self, PlayerNodeConfig)
        if not self.config.bag:
            self.get_logger().info('no `bag` parameter: idle')
            return
        self._bag = BagReader(self.config.bag).__enter__()
        try:
            self._schedule = PlaybackSchedule(self.config.playback, self._bag.start_ns,
                                              self._bag.end_ns)
            self._outputs = self._create_publishers()
        except BaseException:
            self._bag.__exit__(None, None, None)
            raise
        self._clock_pub = self.create_publisher(Clock, CLOCK_TOPIC, 10)
        self._clock_ns: int | None = None     # the bag time last published on /clock
        self.create_subscription(Bool, '~/pause', self._on_pause, 10)
        # The context must be shut down from the executor's thread: shutting it down destroys
        # the node, which joins the playback thread.
        self._finished = self.create_guard_condition(self.context.try_shutdown)
        if not self.config.start_paused:
            self._resumed.set()
        self._thread = threading.Thread(target=self._play, name='player', daemon=True)
        self._thread.start()

    def _create_publishers(self) -> dict[str, Publisher]:
        """One raw publisher per played bag topic, keyed by bag topic; skips unpublishable."""
        topics = self._bag.topics
        played = self._schedule.select_topics(topics)
        if self.config.publish_clock and CLOCK_TOPIC in played:
            played.remove(CLOCK_TOPIC)
        publishers: dict[str, Publisher[Any]] = {}
        for topic in played:
            summary = topics[topic]
            try:
                cls = message_class(summary.msgtype)
            except BagFormatError as err:
                self.get_logger().error(f'{self._bag.path}: skipping topic {topic!r}: {err}')
                continue
            best_effort = (summary.best_effort if self.config.qos_reliability == 'bag'
                           else self.config.qos_reliability == 'best_effort')
            qos = keep_last_qos(self.config.qos_depth, best_effort=best_effort)
            publishers[topic] = self.create_publisher(
                cls, self._schedule.output_topic(topic), qos)
        if not publishers:
            msg = (f'{self._bag.path}: no topic to play (selected: {", ".join(played) or "none"}'
                   f'; the bag has {", ".join(sorted(topics))})')
            raise BagFormatError(msg)
        transport = (os.environ.get('FASTDDS_DEFAULT_PROFILES_FILE')
                     or os.environ.get('FASTDDS_BUILTIN_TRANSPORTS')
                     or 'Fast DDS defaults: large images may be dropped, see '
                        'config/fastdds_large_data.xml')
        self.get_logger().info(f'DDS transport: {transport}')
        self.get_logger().info(
            f'playing {self._bag.path}: ' + ', '.join(
                f'{t} -> {p.topic_name} ({topics[t].count})' for t, p in publishers.items()))
        return publishers

    def _on_pause(self, msg: Bool) -> None:
        if msg.data and self._resumed.is_set():
            self._resumed.clear()
            self.get_logger().info('paused')
        elif not msg.data and not self._resumed.is_set():
            self._resumed.set()
            self.get_logger().info('resumed')

    def _wait_for_subscribers(self) -> None:
        timeout_s = self.config.wait_for_subscribers_s
        if timeout_s <= 0:
            return
        wanted = set(self.config.wait_topics or [p.topic_name for p in
                                                 self._outputs.values()])
        by_name = {p.topic_name: p for p in self._outputs.values()}
        if unknown := sorted(wanted - set(by_name)):
            self.get_logger().warning(f'`wait_topics` not played: {", ".join(unknown)}')
        count = self.config.wait_subscriber_count
        deadline = time.monotonic() + timeout_s
        while not self._stop.is_set():
            missing = sorted(t for t in wanted & set(by_name)
                             if by_name[t].get_subscription_count() < count)
            if not missing:
                return
            if time.monotonic() >= deadline:
                self.get_logger().warning(
                    f'fewer than {count} subscribers after {timeout_s} s on: '
                    f'{", ".join(missing)}; playing anyway')
                return
            self._stop.wait(_POLL_S)

    def _wait_until(self, target_ns: int, paused_ns: int) -> int:
        """Sleep until monotonic ``target_ns + paused_ns``; return the updated pause total.

        Returns -1 if the node is stopping.
        """
        while not self._stop.is_set():
            if not self._resumed.is_set():
                start = time.monotonic_ns()
                while not self._resumed.wait(_POLL_S):
                    if self._stop.is_set():
                        return -1
                paused_ns += time.monotonic_ns() - start
                continue
            remaining_s = (target_ns + paused_ns - time.monotonic_ns()) / NS_PER_S
            if remaining_s <= 0:
                return paused_ns
            self._stop.wait(min(remaining_s, _POLL_S))
        return -1

    def _play_pass(self, loop: int, origin_ns: int, paused_ns: int) -> int:
        """Publish one pass over the playback window; return the pause total (-1: stopping)."""
        start_ns, stop_ns = self._schedule.window_ns
        for topic, _, stamp_ns, raw in self._bag.messages(list(self._outputs), start_ns,
                                                          stop_ns):
            paused_ns = self._wait_until(origin_ns + self._schedule.delay_ns(stamp_ns, loop),
                                         paused_ns)
            if paused_ns < 0:
                return -1
            if self.config.publish_clock and stamp_ns != self._clock_ns:
                self._clock_ns = stamp_ns
                self._clock_pub.publish(clock_msg(stamp_ns))
            self._outputs[topic].publish(raw)
        return paused_ns

    def _play(self) -> None:
        """Playback thread: wait for subscribers and the start, play, then end the node."""
        try:
            self._wait_for_subscribers()
            if self._wait_until(time.monotonic_ns(), 0) < 0:
                return
            origin_ns, paused_ns, loop = time.monotonic_ns(), 0, 0
            self.get_logger().info('playback started')
            while paused_ns >= 0:
                paused_ns = self._play_pass(loop, origin_ns, paused_ns)
                loop += 1
                if not self.config.playback.loop:
                    break
            if paused_ns >= 0:
                self._await_acks()
                self.get_logger().info('end of bag')
        except HandTrackerError as err:
            self.error = err
            self.get_logger().error(str(err))
        except Exception:
            # A publish racing the context shutdown of Ctrl-C fails (rclpy raises RCLError or
            # InvalidHandle); that is the expected end of playback, anything else is a bug.
            if self.context.ok() and not self._stop.is_set():
                raise
        finally:
            if not self._stop.is_set():
                self._finished.trigger()

    def _await_acks(self) -> None:
        deadline_ns = time.monotonic_ns() + round(self.config.ack_timeout_s * NS_PER_S)
        for publisher in self._outputs.values():
            timeout = Duration(nanoseconds=max(deadline_ns - time.monotonic_ns(), 0))
            if not publisher.wait_for_all_acked(timeout):
                self.get_logger().warning(
                    f'{publisher.topic_name}: not every message was acknowledged within '
                    f'{self.config.ack_timeout_s} s')

    def destroy_node(self) -> None:
        """Stop the playback thread, close the bag, then destroy the node."""
        self._stop.set()
        self._resumed.set()
        if self._destroyed:
            return
        self._destroyed = True
        if self._thread is not None:
            self._thread.join()
            self._bag.__exit__(None, None, None)
        super().destroy_node()


def run_player(overrides: Mapping[str, Any] | None = None,
               args: Sequence[str] | None = None) -> int:
    """Run a player until the bag ends or the process is interrupted; return 0.

    Parameters
    ----------
    overrides : mapping of str to value, optional
        Parameter values (see :class:`PlayerNode`).
    args : sequence of str, optional
        Command line (``sys.argv`` by default), may hold ``--ros-args``.

    Raises
    ------
    HandTrackerError
        If the bag cannot be opened or played, or a parameter is invalid.
    """
    nodes: list[PlayerNode] = []

    def factory() -> PlayerNode:
        nodes.append(PlayerNode(overrides))
        return nodes[-1]

    code = run_node('player', DESCRIPTION, PlayerNodeConfig, factory, args)
    if nodes and nodes[0].error is not None:
        raise nodes[0].error
    return code


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros player`); 1 on an error of ours."""
    try:
        return run_player(None, args)
    except HandTrackerError as err:
        rclpy.logging.get_logger('player').fatal(str(err))
        return 1


if __name__ == '__main__':
    raise SystemExit(main())
