"""Read the live ROS graph: which nodes are up, which topics have subscribers (used by the
demo, `hand-tracker launch`, the bag replay and the tests)."""
from __future__ import annotations

import time
from collections.abc import Callable, Iterable

import rclpy
from rclpy.node import Node

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.ros_io.observations import PARTS


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
