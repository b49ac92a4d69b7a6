"""The `salient_points` node: trained fingertip detection per camera.

For every camera ``<cam>`` of ``cameras`` it subscribes (sensor-data QoS) to
``<cam>/image_raw`` and ``<cam>/camera_info`` and publishes ``<cam>/salient_points``
(hand_tracker_msgs/SalientPoints, reliable, the input's header): unlabelled candidates
(u, v in px, score in 0..1); the tracker assigns them to fingers. A bad image gets one throttled
error and is dropped; the node keeps running.
"""
from __future__ import annotations

from collections.abc import Sequence
from functools import partial

from hand_tracker_msgs.msg import SalientPoints
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.node_config import SalientPointsNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.images import (ImageSizes, rgb_from_msg, salient_points_msg,
                                            sensor_qos)
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.vision.detector.detector import FingertipDetector

DESCRIPTION = 'Per-camera fingertip (salient point) detection with the trained detector.'
THROTTLE_S = 5.0


class SalientPointsNode(Node):
    """Per-camera fingertip detection."""

    def __init__(self) -> None:
        super().__init__('salient_points')
        bridge_core_logging(self)
        self.config = declare_config(self, SalientPointsNodeConfig)
        self._detector = FingertipDetector.load(config=self.config.detector)
        sensor = sensor_qos(self.config.queue_depth)
        self._sizes = ImageSizes(self, THROTTLE_S)
        self._pubs = {c: self.create_publisher(SalientPoints, f'{c}/salient_points', 10)
                      for c in self.config.cameras}
        for cam in self.config.cameras:
            self.create_subscription(Image, f'{cam}/{self.config.image_topic}',
                                     partial(self._on_image, cam), sensor)
            self.create_subscription(CameraInfo, f'{cam}/camera_info',
                                     partial(self._sizes.on_info, cam), sensor)
        self.get_logger().info(f'fingertip detection for cameras {list(self.config.cameras)}')

    def _on_image(self, camera: str, msg: Image) -> None:
        try:
            rgb = rgb_from_msg(msg, camera, self._sizes.get(camera))
            tips = self._detector.detect(rgb)
        except HandTrackerError as err:
            self.get_logger().error(f'dropping a frame: {err}', throttle_duration_sec=THROTTLE_S)
            return
        self._pubs[camera].publish(salient_points_msg(tips, msg.header, camera, msg.width,
                                                      msg.height))


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros salient_points`)."""
    return run_node('salient_points', DESCRIPTION, SalientPointsNodeConfig, SalientPointsNode,
                    args)


if __name__ == '__main__':
    raise SystemExit(main())
