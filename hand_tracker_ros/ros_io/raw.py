"""Raw (serialized CDR) publish/subscribe helpers for the bag player and recorder.

Also :func:`parameter_list`, with which the ``hand-tracker play``/``record`` verbs start these
nodes in-process with their options as parameter overrides.

Message classes come from the ROS 2 type name (``pkg/msg/Name``) through
:func:`hand_tracker_ros.ros_io.message_kit.message_class`: the generated ``pkg.msg`` module is
all rclpy needs to create a raw publisher or subscription.

QoS. A player offers what the recorded publishers offered (best effort for camera topics,
reliable otherwise). A recorder matches the live publishers: a reliable subscription does not
match a best-effort publisher, so any best-effort publisher makes the subscription best
effort; otherwise it is reliable, so nothing a reliable publisher sends is lost. Durability is
transient-local only if every publisher offers it (latched topics such as ``/tf_static``).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from builtin_interfaces.msg import Time
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from rclpy.topic_endpoint_info import TopicEndpointInfo
from rosgraph_msgs.msg import Clock

NS_PER_S = 1_000_000_000


def parameter_list(overrides: Mapping[str, Any]) -> list[Parameter]:
    """ROS parameters from ``{dotted name: value}`` (tuples become lists)."""
    return [Parameter(name, value=list(v) if isinstance(v, tuple) else v)
            for name, v in overrides.items()]


def keep_last_qos(depth: int, *, best_effort: bool, transient_local: bool = False
                  ) -> QoSProfile:
    """A keep-last profile of ``depth`` with the given reliability and durability."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if transient_local
                    else DurabilityPolicy.VOLATILE))


def matching_qos(publishers: Sequence[TopicEndpointInfo], depth: int) -> QoSProfile:
    """The subscription profile that matches every publisher of a topic (module docstring).

    Parameters
    ----------
    publishers : sequence of TopicEndpointInfo
        ``Node.get_publishers_info_by_topic(topic)``; may be empty (reliable, volatile).
    depth : int
        Queue depth of the subscription.
    """
    profiles = [p.qos_profile for p in publishers]
    best_effort = any(q.reliability == ReliabilityPolicy.BEST_EFFORT for q in profiles)
    latched = bool(profiles) and all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL
                                     for q in profiles)
    return keep_last_qos(depth, best_effort=best_effort, transient_local=latched)


def clock_msg(stamp_ns: int) -> Clock:
    """A ``rosgraph_msgs/Clock`` holding ``stamp_ns`` (int ns)."""
    sec, nanosec = divmod(int(stamp_ns), NS_PER_S)
    return Clock(clock=Time(sec=sec, nanosec=nanosec))


def drain(subscription: Subscription[Any], callback: Callable[[Any], None]) -> int:
    """Take every message still queued in a raw subscription and pass it to ``callback``.

    Used at shutdown: the executor stops as soon as the context is shut down, while DDS may
    still hold received samples. rclpy has no public "take" call, so this uses the same
    handle method its executor uses. Returns the number of messages taken.
    """
    taken = 0
    with subscription.handle:
        while (info := subscription.handle.take_message(subscription.msg_type,
                                                        subscription.raw)) is not None:
            callback(info[0])
            taken += 1
    return taken
