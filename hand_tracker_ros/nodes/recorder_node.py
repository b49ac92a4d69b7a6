"""The `recorder` node: Records topics to a rosbag2 mcap through raw subscriptions."""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node

from hand_tracker_ros.node_config import RecorderNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config

DESCRIPTION = 'Records topics to a rosbag2 mcap through raw subscriptions.'


class RecorderNode(Node):
    """Records topics to a rosbag2 mcap through raw subscriptions."""

    def __init__(self) -> None:
        super().__init__('recorder')
        bridge_core_logging(self)
        self.config = declare_config(self, RecorderNodeConfig)
        self.get_logger().info('ready')


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros recorder`)."""
    return run_node('recorder', DESCRIPTION, RecorderNodeConfig, RecorderNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
