"""The `features` node: edges, foreground mask and optical flow per camera.

Standalone (the distributed graph) it subscribes, for every camera ``<cam>`` of the
``cameras`` parameter (sensor-data QoS), to ``<cam>/image_raw`` (or, with
``image_transport:=compressed``, the jpeg/png stream ``<cam>/image_raw/compressed``) and
``<cam>/camera_info`` and publishes, reliably and with the input's header: ``<cam>/edges``
(mono8, 255 on edges), ``<cam>/edge_orientation`` (32FC1, edge-normal direction in rad, what
the tracker's orientation check needs), ``<cam>/mask`` (mono8, 255 on the hand) and
``<cam>/flow`` (32FC2, px from the previous frame; not published on a camera's first frame),
at the working resolution (images wider than ``working_width_px`` scaled down to it, as the
tracker's cameras are).
It serves whole sets: the cameras' images are grouped by stamp (``sync_slop_ms``) and the
newest complete set is processed on a worker thread, so a node that falls behind drops whole
sets and its outputs still make sets at the tracker
(:class:`~hand_tracker_ros.ros_io.image_inputs.ImageInputs`). With ``follow_plan`` it follows
the tracker's plans on ``hand/observation_plan``: one set per plan, in the plan's regions of
interest (:mod:`hand_tracker_ros.ros_io.plans`). A set with a bad image gets one throttled
error and is dropped; the node keeps running.

In the composed tracker process (``in_process=True``) it subscribes to nothing: the tracker
hands it each synchronized image set it is about to track (:meth:`FeaturesNode.process_set`)
and takes the features in memory. The same topics are then published only while someone
subscribes to them (to look at the features), so nothing is serialized otherwise.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import Image
from std_msgs.msg import Header

from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.bags.convert import stamp_ns_of
from hand_tracker_ros.node_config import FeaturesNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.image_inputs import ImageInputs, ImageSet
from hand_tracker_ros.ros_io.images import image_msg
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.ros_io.plans import follow_plans, plan_summary, planned_set
from hand_tracker_ros.vision.features import CameraFeatures, MultiCameraFeatures
from hand_tracker_ros.vision.visualize import edge_image, flow_image, mask_image, paste_roi

DESCRIPTION = 'Per-camera image features: edges, foreground mask and optical flow.'
OUTPUTS = ('edges', 'edge_orientation', 'mask', 'flow')
THROTTLE_S = 5.0


class FeaturesNode(Node):
    """Per-camera feature extraction (module docstring)."""

    def __init__(self, *, in_process: bool = False, cameras: Sequence[str] = ()) -> None:
        # In process the tracker's cameras override the parameter (one list for the graph).
        super().__init__('features', parameter_overrides=[
            Parameter('cameras', Parameter.Type.STRING_ARRAY, list(cameras))] if cameras else [])
        if not in_process:          # in process the core's records go to the tracker's log
            bridge_core_logging(self)
        self.config = declare_config(self, FeaturesNodeConfig)
        self._in_process = in_process
        self._features = MultiCameraFeatures(self.config.cameras, self.config.features)
        self._pubs = {c: {o: self.create_publisher(Image, f'{c}/{o}', 10) for o in OUTPUTS}
                      for c in self.config.cameras}
        self._plans = (follow_plans(self, self.config.cameras, THROTTLE_S)
                       if self.config.follow_plan and not in_process else None)
        if not in_process:
            self._inputs = ImageInputs(self, self.config.cameras, self.config.image_topic,
                                       self.config.image_transport, self.config.queue_depth,
                                       self._on_set, THROTTLE_S, self.config.sync_slop_ms)
        where = 'in the tracker process' if in_process else 'from the image topics'
        self.get_logger().info(f'features for cameras {list(self.config.cameras)} {where}')

    def process_set(self, images_rgb: Sequence[UInt8Array], headers: Sequence[Header],
                    rois_px: Sequence[tuple[int, int, int, int] | None] | None = None
                    ) -> tuple[CameraFeatures, ...]:
        """Features of one synchronized set, cameras in ``cameras`` order, each in its region
        of interest ``(u0, v0, u1, v1)`` (None: the whole image); published at the images'
        size (in process: the tracker's working resolution, and only while someone
        subscribes)."""
        stamps = [stamp_ns_of(h) for h in headers]
        features = self._features.process(images_rgb, stamps, rois_px=rois_px)
        for camera, feat, header in zip(self.config.cameras, features, headers):
            self._publish(camera, feat, header)
        return features

    def _on_set(self, image_set: ImageSet) -> None:
        """(Standalone, the inputs' worker thread.) Features of one synchronized set, in
        the tracker's plan (skipped when its plan was served)."""
        planned = planned_set(self._plans, image_set, self.config.working_width_px)
        if planned is not None:
            images, plan = planned
            self.process_set(images, image_set.headers, plan.rois_px)

    def _publish(self, camera: str, features: CameraFeatures, header: Header) -> None:
        """Publish one camera's features (in process: only the topics someone reads)."""
        flow = features.flow
        images = {'edges': lambda: edge_image(features.edges),
                  'edge_orientation': lambda: features.edges.orientation_rad,
                  'mask': lambda: mask_image(features.mask),
                  'flow': (lambda: flow_image(flow)) if flow is not None else None}
        fill = {'flow': np.nan}     # no flow outside a region of interest
        for output, pub in self._pubs[camera].items():
            pixels = images[output]
            if pixels is None or (self._in_process and pub.get_subscription_count() == 0):
                continue
            full = paste_roi(pixels(), features.roi_px, features.image_size_px,
                             fill=fill.get(output, 0))
            pub.publish(image_msg(full, header))

    def destroy_node(self) -> None:
        """Stop the input and feature threads (logging where the input sets went), then the
        node."""
        if not self._in_process:
            self._inputs.close()
            self.get_logger().info(self._inputs.summary() + plan_summary(self._plans))
        self._features.close()
        super().destroy_node()


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros features`)."""
    return run_node('features', DESCRIPTION, FeaturesNodeConfig, FeaturesNode, args)


if __name__ == '__main__':
    raise SystemExit(main())
