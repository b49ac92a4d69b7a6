"""The `tracker` node: synchronized multi-camera hand tracking."""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node

from hand_tracker_ros.node_config import TrackerNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config

DESCRIPTION = 'Synchronized multi-camera hand tracking (collision-aware Levenberg-Marquardt).'


class TrackerNode(Node):
    """Synchronized multi-camera hand tracking (collision-aware Levenberg-Marquardt)."""

    def __init__(self) -> None:
        super().__init__('tracker')
        bridge_core_logging(self)
        self.config = declare_config(self, TrackerNodeConfig)
        self.get_logger().info('ready')


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros tracker`)."""
    return run_node('tracker', DESCRIPTION, TrackerNodeConfig, TrackerNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
