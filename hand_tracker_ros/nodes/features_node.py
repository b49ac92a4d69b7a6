"""The `features` node: Per-camera image features: edges, foreground mask and optical flow."""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node

from hand_tracker_ros.node_config import FeaturesNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config

DESCRIPTION = 'Per-camera image features: edges, foreground mask and optical flow.'


class FeaturesNode(Node):
    """Per-camera image features: edges, foreground mask and optical flow."""

    def __init__(self) -> None:
        super().__init__('features')
        bridge_core_logging(self)
        self.config = declare_config(self, FeaturesNodeConfig)
        self.get_logger().info('ready')


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros features`)."""
    return run_node('features', DESCRIPTION, FeaturesNodeConfig, FeaturesNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
