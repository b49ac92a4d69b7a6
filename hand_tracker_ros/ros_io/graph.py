"""Read the live ROS graph: which nodes are up, which topics have subscribers (used by the
demo, the bag replay and the tests)."""
from __future__ import annotations

import time
from collections.abc import Iterable

import rclpy
from rclpy.node import Node


def wait_for_subscriptions(topics: Iterable[str], *, timeout_s: float = 60.0) -> set[str]:
    """Wait until every topic in ``topics`` has a subscription; return those that have one.

    Like :func:`wait_for_nodes` (own observer node and context); a partial set means the
    timeout expired first.
    """
    wanted = set(topics)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        observer = Node('hand_tracker_graph_observer', context=context)
        ready: set[str] = set()
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and ready != wanted:
            ready = {t for t in wanted if observer.count_subscribers(t) > 0}
            time.sleep(0.2)
        observer.destroy_node()
        return ready
    finally:
        rclpy.try_shutdown(context=context)


def wait_for_nodes(names: Iterable[str], *, timeout_s: float = 30.0,
                   namespace: str = '/') -> set[str]:
    """Wait until every node in ``names`` is discovered; return the set of those seen.

    Creates a short-lived observer node in its own context; the caller checks the returned
    set against ``names`` (a partial set means the timeout expired first).
    """
    wanted = set(names)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        observer = Node('hand_tracker_graph_observer', context=context)
        seen: set[str] = set()
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and not wanted <= seen:
            seen = {n for n, ns in observer.get_node_names_and_namespaces()
                    if ns == namespace} & wanted
            time.sleep(0.2)
        observer.destroy_node()
        return seen
    finally:
        rclpy.try_shutdown(context=context)
