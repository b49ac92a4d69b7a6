"""The `salient_points` node: trained fingertip detection per camera.

For every camera ``<cam>`` of ``cameras`` it subscribes (sensor-data QoS) to
``<cam>/image_raw`` (or, with ``image_transport:=compressed``, the jpeg/png stream
``<cam>/image_raw/compressed``) and ``<cam>/camera_info`` and publishes ``<cam>/salient_points``
(hand_tracker_msgs/SalientPoints, reliable, the input's header): unlabelled candidates
(u, v in px, score in 0..1); the tracker assigns them to fingers. A bad image gets one throttled
error and is dropped; the node keeps running.
"""
from __future__ import annotations

from collections.abc import Sequence

from hand_tracker_msgs.msg import SalientPoints
from rclpy.node import Node
from sensor_msgs.msg import CompressedImage, Image

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.node_config import SalientPointsNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.images import ImageInputs, salient_points_msg
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
        self._inputs = ImageInputs(self, self.config.cameras, self.config.image_topic,
                                   self.config.image_transport, self.config.queue_depth,
                                   self._on_image, THROTTLE_S)
        self._pubs = {c: self.create_publisher(SalientPoints, f'{c}/salient_points', 10)
                      for c in self.config.cameras}
        self.get_logger().info(f'fingertip detection for cameras {list(self.config.cameras)}')

    def _on_image(self, camera: str, msg: Image | CompressedImage) -> None:
        try:
            rgb = self._inputs.decode(camera, msg)
            tips = self._detector.detect(rgb)
        except HandTrackerError as err:
            self.get_logger().error(f'dropping a frame: {err}', throttle_duration_sec=THROTTLE_S)
            return
        height, width = rgb.shape[:2]
        self._pubs[camera].publish(salient_points_msg(tips, msg.header, camera, width, height))


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros salient_points`)."""
    return run_node('salient_points', DESCRIPTION, SalientPointsNodeConfig, SalientPointsNode,
                    args)


if __name__ == '__main__':
    raise SystemExit(main())
