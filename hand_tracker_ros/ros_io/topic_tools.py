"""Live graph tools behind `hand-tracker topics`: list, echo and hz.

The ``ros2 topic`` command (ros2cli) is not on PyPI, so these are its three most used verbs
written on rclpy alone. Each call creates a short-lived node in its own context, so callers
need no rclpy setup. Messages are printed as YAML documents separated by ``---`` as
``ros2 topic echo`` does; fields come from the generated classes'
``get_fields_and_field_types()`` (``rosidl_runtime_py.message_to_yaml`` is not on PyPI either).
``hz`` takes raw (serialized) messages, so it measures the rate without the cost of
deserializing large images.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TextIO

import numpy as np
import rclpy
import yaml
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.ros_io.message_kit import message_class
from hand_tracker_ros.ros_io.raw import matching_qos

_SPIN_S = 0.1


@contextmanager
def _graph_node(name: str) -> Iterator[tuple[Node, SingleThreadedExecutor]]:
    """A node in a fresh context with its executor; shut down on exit."""
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = Node(name, context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        yield node, executor
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def _spin_until(node: Node, executor: SingleThreadedExecutor, done: Callable[[], bool],
                timeout_s: float | None) -> None:
    """Spin until ``done()``, the timeout (None: none) or a shutdown (Ctrl-C)."""
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    try:
        while node.context.ok() and not done() and (
                deadline is None or time.monotonic() < deadline):
            executor.spin_once(timeout_sec=_SPIN_S)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


def _topic_type(node: Node, executor: SingleThreadedExecutor, topic: str,
                wait_s: float) -> str:
    """The type of ``topic`` once discovered (within ``wait_s``); raises if it never is."""
    topic = absolute(topic)
    found: dict[str, list[str]] = {}

    def discovered() -> bool:
        found.update(node.get_topic_names_and_types())
        return topic in found

    _spin_until(node, executor, discovered, wait_s)
    if topic not in found:
        msg = (f'topic {topic} not found in the graph within {wait_s:g} s (topics seen: '
               f'{", ".join(sorted(found)) or "none"})')
        raise HandTrackerError(msg)
    return found[topic][0]


def absolute(topic: str) -> str:
    """``topic`` with a leading slash (this tool's node lives in the root namespace)."""
    return topic if topic.startswith('/') else f'/{topic}'


def list_topics(*, wait_s: float, verbose: bool) -> list[str]:
    """``topic [type]`` per topic seen after ``wait_s`` of discovery (with ``verbose``, also
    the number of publishers and subscribers), sorted by name."""
    with _graph_node('hand_tracker_topics_list') as (node, executor):
        _spin_until(node, executor, lambda: False, wait_s)
        lines = []
        for topic, types in sorted(node.get_topic_names_and_types()):
            line = f'{topic} [{", ".join(types)}]'
            if verbose:
                line += (f'  publishers: {node.count_publishers(topic)}'
                         f'  subscribers: {node.count_subscribers(topic)}')
            lines.append(line)
        return lines


def message_to_plain(msg: Any, max_items: int) -> Any:
    """A message as dicts, lists and scalars; arrays longer than ``max_items`` are cut, with
    a note of how many items were left out."""
    if hasattr(msg, 'get_fields_and_field_types'):
        return {name: message_to_plain(getattr(msg, name), max_items)
                for name in msg.get_fields_and_field_types()}
    if isinstance(msg, (list, tuple)) or hasattr(msg, 'tolist') or hasattr(msg, 'typecode'):
        items = list(msg.tolist() if hasattr(msg, 'tolist') else msg)
        shown = [message_to_plain(v, max_items) for v in items[:max_items]]
        if len(items) > max_items:
            shown.append(f'... {len(items) - max_items} more')
        return shown
    if isinstance(msg, np.generic):
        return msg.item()
    return msg


def echo(topic: str, out: TextIO, *, count: int | None, wait_s: float,
         max_items: int) -> int:
    """Print messages of ``topic`` as YAML until ``count`` (None: until Ctrl-C); return how
    many were printed."""
    printed = 0
    with _graph_node('hand_tracker_topics_echo') as (node, executor):
        cls = message_class(_topic_type(node, executor, topic, wait_s))

        def show(msg: Any) -> None:
            nonlocal printed
            if count is None or printed < count:
                out.write(yaml.safe_dump(message_to_plain(msg, max_items), sort_keys=False))
                out.write('---\n')
                out.flush()
                printed += 1

        qos = matching_qos(node.get_publishers_info_by_topic(absolute(topic)), 10)
        node.create_subscription(cls, absolute(topic), show, qos)
        _spin_until(node, executor, lambda: count is not None and printed >= count, None)
    return printed


def hz(topic: str, out: TextIO, *, duration_s: float | None, wait_s: float,
       window: int, period_s: float = 1.0) -> int:
    """Print the receive rate of ``topic`` every ``period_s`` over the last ``window``
    messages (mean rate in Hz, min/max/std of the period in s) until ``duration_s`` (None:
    until Ctrl-C); return the number of messages received."""
    stamps: list[float] = []
    with _graph_node('hand_tracker_topics_hz') as (node, executor):
        cls = message_class(_topic_type(node, executor, topic, wait_s))
        qos = matching_qos(node.get_publishers_info_by_topic(absolute(topic)), 100)
        node.create_subscription(cls, absolute(topic),
                                 lambda _: stamps.append(time.monotonic()), qos, raw=True)
        end = None if duration_s is None else time.monotonic() + duration_s
        while node.context.ok() and (end is None or time.monotonic() < end):
            _spin_until(node, executor, lambda: False, period_s)
            out.write(_rate_line(stamps[-window - 1:]))
            out.flush()
    return len(stamps)


def _rate_line(stamps: list[float]) -> str:
    """The ``hz`` report of receive times ``stamps`` (s, increasing)."""
    if len(stamps) < 2:
        return 'no new messages\n'
    periods = np.diff(stamps)
    return (f'average rate: {1.0 / periods.mean():.3f}\n'
            f'\tmin: {periods.min():.3f}s max: {periods.max():.3f}s '
            f'std dev: {periods.std():.5f}s window: {periods.size + 1}\n')
