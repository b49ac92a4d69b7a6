"""The `features` node: edges, foreground mask and optical flow per camera.

For every camera ``<cam>`` of the ``cameras`` parameter it subscribes (sensor-data QoS) to
``<cam>/image_raw`` (or, with ``image_transport:=compressed``, the jpeg/png stream
``<cam>/image_raw/compressed``) and ``<cam>/camera_info`` and publishes, reliably and with the input's
header: ``<cam>/edges`` (mono8, 255 on edges), ``<cam>/edge_orientation`` (32FC1, edge-normal
direction in rad, what the tracker's orientation check needs), ``<cam>/mask`` (mono8, 255 on the
hand) and ``<cam>/flow`` (32FC2, px from the previous frame; not published on a camera's first
frame). A bad image gets one throttled error and is dropped; the node keeps running.
"""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node
from sensor_msgs.msg import CompressedImage, Image

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.node_config import FeaturesNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.images import ImageInputs, image_msg
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.vision.features import FeatureExtractor
from hand_tracker_ros.vision.visualize import edge_image, flow_image, mask_image

DESCRIPTION = 'Per-camera image features: edges, foreground mask and optical flow.'
OUTPUTS = ('edges', 'edge_orientation', 'mask', 'flow')
THROTTLE_S = 5.0


class FeaturesNode(Node):
    """Per-camera feature extraction."""

    def __init__(self) -> None:
        super().__init__('features')
        bridge_core_logging(self)
        self.config = declare_config(self, FeaturesNodeConfig)
        self._extractors = {c: FeatureExtractor(c, self.config.features)
                            for c in self.config.cameras}
        self._inputs = ImageInputs(self, self.config.cameras, self.config.image_topic,
                                   self.config.image_transport, self.config.queue_depth,
                                   self._on_image, THROTTLE_S)
        self._pubs = {c: {o: self.create_publisher(Image, f'{c}/{o}', 10) for o in OUTPUTS}
                      for c in self.config.cameras}
        self.get_logger().info(f'features for cameras {list(self.config.cameras)}')

    def _on_image(self, camera: str, msg: Image | CompressedImage) -> None:
        try:
            rgb = self._inputs.decode(camera, msg)
            stamp_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            features = self._extractors[camera].process(rgb, stamp_ns)
        except HandTrackerError as err:
            self.get_logger().error(f'dropping a frame: {err}', throttle_duration_sec=THROTTLE_S)
            return
        pubs = self._pubs[camera]
        pubs['edges'].publish(image_msg(edge_image(features.edges), msg.header))
        pubs['edge_orientation'].publish(image_msg(features.edges.orientation_rad, msg.header))
        pubs['mask'].publish(image_msg(mask_image(features.mask), msg.header))
        if features.flow is not None:
            pubs['flow'].publish(image_msg(flow_image(features.flow), msg.header))


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros features`)."""
    return run_node('features', DESCRIPTION, FeaturesNodeConfig, FeaturesNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
