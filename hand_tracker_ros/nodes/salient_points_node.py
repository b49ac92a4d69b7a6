"""The `salient_points` node: Per-camera fingertip (salient point) detection."""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node

from hand_tracker_ros.node_config import SalientPointsNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config

DESCRIPTION = 'Per-camera fingertip (salient point) detection.'


class SalientPointsNode(Node):
    """Per-camera fingertip (salient point) detection."""

    def __init__(self) -> None:
        super().__init__('salient_points')
        bridge_core_logging(self)
        self.config = declare_config(self, SalientPointsNodeConfig)
        self.get_logger().info('ready')


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros salient_points`)."""
    return run_node('salient_points', DESCRIPTION, SalientPointsNodeConfig, SalientPointsNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
