"""Read the live ROS graph: which nodes are up, which topics have subscribers (used by the
demo, `hand-tracker launch`, the bag replay and the tests)."""
from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from types import TracebackType
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from hand_tracker_ros.bags.convert import stamp_ns_of
from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.ros_io.message_kit import message_class
from hand_tracker_ros.ros_io.observations import PARTS
from hand_tracker_ros.ros_io.raw import keep_last_qos


def _poll(wanted: set[str], probe: Callable[[Node], set[str]], timeout_s: float) -> set[str]:
    """Call ``probe(observer)`` every 0.2 s until it reports all of ``wanted`` or the time is
    up; return the part of ``wanted`` it reported last.

    The observer is a short-lived node in its own context, so callers need no rclpy setup.
    """
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        observer = Node('hand_tracker_graph_observer', context=context)
        found: set[str] = set()
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and found != wanted:
            found = probe(observer) & wanted
            time.sleep(0.2)
        observer.destroy_node()
        return found
    finally:
        rclpy.try_shutdown(context=context)


def wait_for_subscriptions(topics: Iterable[str], *, timeout_s: float = 60.0) -> set[str]:
    """Wait until every topic in ``topics`` has a subscription; return those that have one
    (a partial set means the timeout expired first)."""
    wanted = set(topics)
    return _poll(wanted, lambda node: {t for t in wanted if node.count_subscribers(t) > 0},
                 timeout_s)


def wait_for_nodes(names: Iterable[str], *, timeout_s: float = 30.0,
                   namespace: str = '/') -> set[str]:
    """Wait until every node in ``names`` is discovered; return the set of those seen (a
    partial set means the timeout expired first)."""
    return _poll(set(names), lambda node: {n for n, ns in node.get_node_names_and_namespaces()
                                           if ns == namespace}, timeout_s)


def wait_for_tracking_graph(cameras: Iterable[str], outputs: Iterable[str], *,
                            timeout_s: float, mode: str = 'composed') -> None:
    """Block until the tracker subscribes to its inputs of every camera (``mode``
    ``composed``: ``/<cam>/image_raw``; ``distributed``: the feature topics
    ``/<cam>/<part>``) and a recorder to every topic of ``outputs``.

    The tracker subscribes once it is warm (its JIT kernels loaded). Frames played before
    then are lost, and a loaded machine can need more than 8 s to start it. Raises
    :class:`HandTrackerError` naming the topics still unsubscribed after ``timeout_s``.
    """
    parts = PARTS if mode == 'distributed' else ('image_raw',)
    topics = {f'/{c}/{part}' for c in cameras for part in parts} | set(outputs)
    missing = topics - wait_for_subscriptions(topics, timeout_s=timeout_s)
    if missing:
        msg = f'the graph did not subscribe to {sorted(missing)} within {timeout_s:.0f} s'
        raise HandTrackerError(msg)


class StampWatch:
    """The header stamps of the messages on one topic, heard by a background node.

    Used as a context manager: on entry a short-lived node in its own context subscribes to
    ``topic`` (best effort, so publishers of any reliability match and none waits for this
    reader) and spins in a daemon thread; on exit it is shut down. A message the watch misses
    only makes :meth:`wait_for` wait its full timeout.

    Parameters
    ----------
    topic : str
        Absolute topic name, e.g. ``/hand/state``.
    msgtype : str
        ROS 2 type of ``topic`` (it must have a ``header``), e.g.
        ``hand_tracker_msgs/msg/HandState``.
    """

    def __init__(self, topic: str, msgtype: str) -> None:
        self._topic, self._msgtype = topic, msgtype
        self._stamps_ns: set[int] = set()
        self._heard = threading.Condition()
        self._context: Any = None
        self._thread: threading.Thread | None = None

    def __enter__(self) -> StampWatch:
        self._context = rclpy.Context()
        rclpy.init(context=self._context)
        node = Node('hand_tracker_stamp_watch', context=self._context)
        node.create_subscription(message_class(self._msgtype), self._topic, self._on_message,
                                 keep_last_qos(100, best_effort=True))
        executor = SingleThreadedExecutor(context=self._context)
        executor.add_node(node)

        def spin() -> None:
            try:
                executor.spin()
            except ExternalShutdownException:     # __exit__
                pass

        self._thread = threading.Thread(target=spin, name='stamp_watch', daemon=True)
        self._thread.start()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        rclpy.try_shutdown(context=self._context)
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    def _on_message(self, msg: Any) -> None:
        with self._heard:
            self._stamps_ns.add(stamp_ns_of(msg.header))
            self._heard.notify_all()

    def wait_for(self, stamp_ns: int, timeout_s: float) -> bool:
        """Block until a message stamped ``stamp_ns`` (ns) was heard, at most ``timeout_s``
        (s); return whether it was."""
        with self._heard:
            return self._heard.wait_for(lambda: stamp_ns in self._stamps_ns, timeout_s)
