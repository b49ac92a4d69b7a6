"""The `salient_points` node: trained fingertip detection per camera.

Standalone (the distributed graph), for every camera ``<cam>`` of ``cameras`` it subscribes
(sensor-data QoS) to ``<cam>/image_raw`` (or, with ``image_transport:=compressed``, the
jpeg/png stream ``<cam>/image_raw/compressed``) and ``<cam>/camera_info`` and publishes
``<cam>/salient_points`` (hand_tracker_msgs/SalientPoints, reliable, the input's header):
unlabelled candidates (u, v in px of the image at the working resolution,
``working_width_px``, score in 0..1); the tracker assigns them to fingers. Like
the features node it serves whole sets, the newest first (``sync_slop_ms``,
:class:`~hand_tracker_ros.ros_io.image_inputs.ImageInputs`), and with ``follow_plan`` it
follows the tracker's plans on ``hand/observation_plan``: one set per plan, detected in the
plan's regions of interest when the plan asks for detection, otherwise published without
candidates, so that the set is complete at the tracker (:mod:`hand_tracker_ros.ros_io.plans`).
A set with a bad image gets one throttled error and is dropped; the node keeps running.

In the composed tracker process (``in_process=True``) it subscribes to nothing: the tracker
asks it for the detections of the sets it tracks (:meth:`SalientPointsNode.detect_set`), and
``<cam>/salient_points`` is published only while someone subscribes to it.
"""
from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

from hand_tracker_msgs.msg import SalientPoints
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Header

from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.node_config import SalientPointsNodeConfig
from hand_tracker_ros.nodes._runner import run_node
from hand_tracker_ros.ros_io.image_inputs import ImageInputs, ImageSet
from hand_tracker_ros.ros_io.images import salient_points_msg
from hand_tracker_ros.ros_io.logging_bridge import bridge_core_logging
from hand_tracker_ros.ros_io.params import declare_config
from hand_tracker_ros.ros_io.plans import follow_plans, plan_summary, planned_set
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.detector.detector import FingertipDetector
from hand_tracker_ros.vision.image import Box

DESCRIPTION = 'Per-camera fingertip (salient point) detection with the trained detector.'
THROTTLE_S = 5.0


class SalientPointsNode(Node):
    """Per-camera fingertip detection (module docstring)."""

    def __init__(self, *, in_process: bool = False, cameras: Sequence[str] = ()) -> None:
        # In process the tracker's cameras override the parameter (one list for the graph).
        super().__init__('salient_points', parameter_overrides=[
            Parameter('cameras', Parameter.Type.STRING_ARRAY, list(cameras))] if cameras else [])
        if not in_process:          # in process the core's records go to the tracker's log
            bridge_core_logging(self)
        self.config = declare_config(self, SalientPointsNodeConfig)
        self._in_process = in_process
        self._detector = FingertipDetector.load(config=self.config.detector)
        self._pubs = {c: self.create_publisher(SalientPoints, f'{c}/salient_points', 10)
                      for c in self.config.cameras}
        # ONNX Runtime releases the GIL: two images at a time use both cores.
        self._pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix='detector')
        self._plans = (follow_plans(self, self.config.cameras, THROTTLE_S)
                       if self.config.follow_plan and not in_process else None)
        if not in_process:
            self._inputs = ImageInputs(self, self.config.cameras, self.config.image_topic,
                                       self.config.image_transport, self.config.queue_depth,
                                       self._on_set, THROTTLE_S, self.config.sync_slop_ms)
        where = 'in the tracker process' if in_process else 'from the image topics'
        self.get_logger().info(f'fingertip detection for cameras {list(self.config.cameras)} '
                               f'{where}')

    def detect_set(self, images_rgb: Sequence[UInt8Array], headers: Sequence[Header],
                   rois_px: Sequence[Box | None] | None = None, *, detect: bool = True
                   ) -> list[SalientDetections]:
        """Detections of one synchronized set, cameras in ``cameras`` order, each in its
        region of interest (None: the whole image), or none without ``detect``; published
        (in process: only while someone subscribes)."""
        rois = list(rois_px) if rois_px is not None else [None] * len(images_rgb)
        tips = (list(self._pool.map(self._detector.detect, images_rgb, rois)) if detect
                else [SalientDetections.empty()] * len(images_rgb))
        for camera, found, rgb, header in zip(self.config.cameras, tips, images_rgb, headers):
            pub = self._pubs[camera]
            if not self._in_process or pub.get_subscription_count() > 0:
                pub.publish(salient_points_msg(found, header, camera, rgb.shape[1],
                                               rgb.shape[0]))
        return tips

    def _on_set(self, image_set: ImageSet) -> None:
        """(Standalone, the inputs' worker thread.) Detections of one synchronized set, in
        the tracker's plan (skipped when its plan was served)."""
        planned = planned_set(self._plans, image_set, self.config.working_width_px)
        if planned is not None:
            images, plan = planned
            self.detect_set(images, image_set.headers, plan.rois_px, detect=plan.detect)

    def destroy_node(self) -> None:
        """Stop the input and detection threads (logging where the input sets went), then
        the node."""
        if not self._in_process:
            self._inputs.close()
            self.get_logger().info(self._inputs.summary() + plan_summary(self._plans))
        self._pool.shutdown(wait=True)
        super().destroy_node()


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point (`ros2 run hand_tracker_ros salient_points`)."""
    return run_node('salient_points', DESCRIPTION, SalientPointsNodeConfig, SalientPointsNode,
                    args)


if __name__ == '__main__':
    raise SystemExit(main())
