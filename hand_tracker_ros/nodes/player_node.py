"""The `player` node: Replays a rosbag2 (sqlite3 or mcap) on its original topics."""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node

from hand_tracker_ros.node_config import PlayerNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config

DESCRIPTION = 'Replays a rosbag2 (sqlite3 or mcap) on its original topics.'


class PlayerNode(Node):
    """Replays a rosbag2 (sqlite3 or mcap) on its original topics."""

    def __init__(self) -> None:
        super().__init__('player')
        bridge_core_logging(self)
        self.config = declare_config(self, PlayerNodeConfig)
        self.get_logger().info('ready')


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros player`)."""
    return run_node('player', DESCRIPTION, PlayerNodeConfig, PlayerNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
