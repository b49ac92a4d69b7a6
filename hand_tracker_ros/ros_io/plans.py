"""The tracker's observation plan across processes: the distributed graph's attention.

In the composed graph the tracker plans each set's observation itself
(:mod:`hand_tracker_ros.tracking.attention`): features in a region of interest around a
tracked hand, fingertips in every few sets, and only for the sets it tracks. Distributed, the
features and salient_points processes would otherwise observe every image of every set at
full size, and on one machine take the cores from the tracker's fit. So the tracker publishes
its plan (``hand_tracker_msgs/ObservationPlan`` on ``hand/observation_plan``) when it starts
to fit a set, planned from the estimate before that fit, as in process; each of the two
nodes then observes one set per plan, the first complete set it gets after the plan, in the
plan's regions and with its detection flag (:class:`PlanGate`). The fit in progress and the
observation of the next set overlap, as in the composed live loop.

A planned set can be lost on its way (a dropped message, a set the tracker refused): no fit
starts, so no new plan comes. The gate then lets one more set through with the latest plan
once ``REPEAT_S`` has passed since it served one, so such a loss costs a few sets, not the
timeout. Without a plan for ``PLAN_TIMEOUT_S`` (no tracker yet, a tracker that stopped, or a
user who only looks at the features) the nodes observe every set whole, as before plans
existed, so nothing waits for a tracker that is not there.

The two nodes may observe different sets for one plan: each takes the first complete set it
is free for after the plan, and a node still busy with its previous set when the plan comes
takes the set that waited meanwhile. The tracker then gets that set's features without
fingertips after its ``optional_wait_ms`` (the salient term tolerates a set without them).
Detection is usually the faster of the two, which keeps this rare; choosing the set by stamp
would remove it.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Sequence

from hand_tracker_msgs.msg import ObservationPlan as PlanMsg
from rclpy.node import Node
from rclpy.qos import QoSProfile
from sensor_msgs.msg import RegionOfInterest
from std_msgs.msg import Header

from hand_tracker_ros import topics
from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.errors import HandTrackerError, ShapeError
from hand_tracker_ros.ros_io.image_inputs import ImageSet
from hand_tracker_ros.tracking.attention import ObservationPlan
from hand_tracker_ros.vision.image import Box
from hand_tracker_ros.vision.resolution import to_width

# Longer than a live search's fit (about 250 ms), which plans one set like any other fit.
PLAN_TIMEOUT_S = 1.0
# Longer than a tracking fit (40-120 ms live), shorter than the timeout.
REPEAT_S = 0.3


def plan_msg(plan: ObservationPlan, header: Header, cameras: Sequence[str]) -> PlanMsg:
    """The message of ``plan`` for ``cameras`` (in the plan's camera order); a camera
    observed whole has a zero-size region."""
    rois = plan.rois_px if plan.rois_px is not None else [None] * len(cameras)
    return PlanMsg(header=header, camera_names=list(cameras), detect=bool(plan.detect),
                   rois=[RegionOfInterest() if box is None else RegionOfInterest(
                       x_offset=box[0], y_offset=box[1], width=box[2] - box[0],
                       height=box[3] - box[1]) for box in rois])


def plan_from_msg(msg: PlanMsg, cameras: Sequence[str]) -> ObservationPlan:
    """The plan of a message for ``cameras`` (this node's order); a camera the message does
    not name, or names with a zero-size region, is observed whole.

    Raises
    ------
    ShapeError
        When the message has another number of regions than of camera names.
    """
    if len(msg.camera_names) != len(msg.rois):
        text = (f'observation plan: {len(msg.camera_names)} camera names but '
                f'{len(msg.rois)} regions')
        raise ShapeError(text)
    boxes: dict[str, Box] = {
        name: (r.x_offset, r.y_offset, r.x_offset + r.width, r.y_offset + r.height)
        for name, r in zip(msg.camera_names, msg.rois) if r.width > 0 and r.height > 0}
    rois = [boxes.get(c) for c in cameras]
    return ObservationPlan(rois if any(r is not None for r in rois) else None, msg.detect)


class PlanGate:
    """One observed set per received plan (module docstring); thread-safe.

    :meth:`offer` runs in the plan subscription's callback, :meth:`take` on the node's
    worker thread before it observes a set. Times are ``time.monotonic`` seconds.
    """

    def __init__(self, timeout_s: float = PLAN_TIMEOUT_S) -> None:
        self._timeout_s = timeout_s
        self._lock = threading.Lock()
        self._plan: ObservationPlan | None = None
        self._received_s = float('-inf')
        self._served_s: float | None = None    # when the latest plan was last served
        self.skipped = 0       # sets not observed: the latest plan was already served

    def offer(self, plan: ObservationPlan, now_s: float) -> None:
        """A new plan: the next set is observed with it."""
        with self._lock:
            self._plan, self._received_s, self._served_s = plan, now_s, None

    def take(self, now_s: float) -> ObservationPlan | None:
        """The plan of the set about to be observed; everything (whole images, detection)
        without a plan in the last ``timeout_s``; None: skip the set, the latest plan was
        served less than ``REPEAT_S`` ago."""
        with self._lock:
            if self._plan is None or now_s - self._received_s > self._timeout_s:
                return ObservationPlan.everything()
            if self._served_s is not None and now_s - self._served_s < REPEAT_S:
                self.skipped += 1
                return None
            self._served_s = now_s
            return self._plan

    def release(self, plan: ObservationPlan) -> None:
        """``plan`` (from :meth:`take`) was not used (its set could not be decoded): the next
        set takes it, unless a newer plan came meanwhile."""
        with self._lock:
            if plan is self._plan:
                self._served_s = None


def follow_plans(node: Node, cameras: Sequence[str], throttle_s: float) -> PlanGate:
    """A gate fed by ``node``'s subscription to the tracker's plans (reliable, depth 1: only
    the latest plan counts), for ``cameras`` in this node's order; a malformed plan is
    logged (throttled) and ignored."""
    gate = PlanGate()

    def on_plan(msg: PlanMsg) -> None:
        try:
            plan = plan_from_msg(msg, cameras)
        except HandTrackerError as err:
            node.get_logger().error(f'ignoring a plan: {err}', throttle_duration_sec=throttle_s)
            return
        gate.offer(plan, time.monotonic())

    node.create_subscription(PlanMsg, topics.OBSERVATION_PLAN.name, on_plan, QoSProfile(depth=1))
    return gate


def plan_summary(gate: PlanGate | None) -> str:
    """The shutdown log's words on the sets a gate skipped ('' without a gate)."""
    return '' if gate is None else f", {gate.skipped} skipped between the tracker's plans"


def planned_set(gate: PlanGate | None, image_set: ImageSet, working_width_px: int
                ) -> tuple[list[UInt8Array], ObservationPlan] | None:
    """What an upstream node observes of ``image_set``: its images at the working width with
    the gate's plan (everything without a gate), or None when the gate skips the set.

    Raises
    ------
    HandTrackerError
        An image of the set cannot be decoded; the gate's plan goes to the next set.
    """
    plan = ObservationPlan.everything() if gate is None else gate.take(time.monotonic())
    if plan is None:
        return None
    try:
        images = image_set.images_rgb
    except HandTrackerError:
        if gate is not None:        # a corrupt set does not use up the plan
            gate.release(plan)
        raise
    return [to_width(image, working_width_px) for image in images], plan
