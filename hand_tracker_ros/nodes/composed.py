"""The composed graph: tracker, features and salient_points in one process.

``ros2 run hand_tracker_ros tracker`` with ``inputs:=images`` (the default) builds the three
nodes here, spun by one executor, like an rclcpp component container: each keeps its name,
parameters and output topics, but the image sets travel in memory. The tracker synchronizes
the raw images; for each set it tracks, :class:`InProcessObserver` decodes the images once
(:mod:`hand_tracker_ros.bags.image_codec`, the one decoder), scales them to the working
resolution (the tracker's ``working_width_px``, :mod:`hand_tracker_ros.vision.resolution`),
asks the features node for edges, mask and flow and the salient_points node for fingertips,
and builds the tracker's observations, without serializing anything. Features and
detections are computed only for the sets that are tracked, so optical flow always spans the
tracker's own step.
"""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node

from hand_tracker_ros.bags.image_codec import image_from_msg
from hand_tracker_ros.core.observations import CameraObservation, FrameObservations
from hand_tracker_ros.nodes.features_node import FeaturesNode
from hand_tracker_ros.nodes.salient_points_node import SalientPointsNode
from hand_tracker_ros.nodes.tracker import TrackerNode
from hand_tracker_ros.sync.approximate import SyncedSet
from hand_tracker_ros.tracking.attention import Attention
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.resolution import to_working


class InProcessObserver:
    """A synchronized set of image messages -> the tracker's observations, in memory.

    What each set observes (a region of interest around a tracked hand, fingertips in every
    few sets) is the session's attention policy (:mod:`hand_tracker_ros.tracking.attention`,
    the ``attention.*`` parameters), as offline. Measured without ROS on random motion played
    at 30 Hz: at 4 x 640x480 the sets tracked went from 11 to 20 of 89 with the regions of
    interest and to 33 with detection in every second set; at 4 x 320x240 neither changed
    the sets tracked or the error.
    """

    def __init__(self, tracker: TrackerNode, features: FeaturesNode,
                 salient: SalientPointsNode) -> None:
        self._tracker, self._features, self._salient = tracker, features, salient
        self._attention = Attention(tracker.config.attention, tracker.working_cameras)

    def next_kind(self) -> tuple[bool, bool]:
        """The kind of the next set's plan (tracked, detects): the live loop predicts its
        observation's duration by it."""
        return self._attention.next_kind(self._tracker.session)

    def __call__(self, synced: SyncedSet) -> FrameObservations:
        cameras = self._tracker.working_cameras
        msgs = [synced.items[c.name] for c in cameras]
        images = [to_working(image_from_msg(m, source=c.name,
                                            expected_size_px=(c.width, c.height)), w)
                  for c, w, m in zip(self._tracker.cameras, cameras, msgs)]
        headers = [m.header for m in msgs]
        plan = self._attention.plan(self._tracker.session)
        features = self._features.process_set(images, headers, plan.rois_px)
        if plan.detect:
            tips = self._salient.detect_set(images, headers, plan.rois_px)
        else:
            tips = [SalientDetections.empty()] * len(cameras)
        return FrameObservations(synced.stamp_ns, tuple(
            CameraObservation(cam, feat, tip) for cam, feat, tip in zip(cameras, features, tips)))


def compose() -> Sequence[Node]:
    """The tracker node and, with ``inputs:=images``, its features and salient_points nodes
    (same cameras), linked in memory; the tracker warms up, then subscribes."""
    tracker = TrackerNode()
    if tracker.config.inputs != 'images':
        return [tracker]
    cameras = tracker.config.cameras
    features = FeaturesNode(in_process=True, cameras=cameras)
    salient = SalientPointsNode(in_process=True, cameras=cameras)
    observer = InProcessObserver(tracker, features, salient)
    tracker.start(observer, observe_kind=observer.next_kind)
    # run_node destroys the nodes in reverse: the tracker, whose pipeline threads call the
    # other two, stops first.
    return [features, salient, tracker]
