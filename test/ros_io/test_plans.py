"""The tracker's observation plan across processes (ros_io.plans): the message round trip and
the gate that lets one set through per plan."""
from __future__ import annotations

import pytest

from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.tracking.attention import ObservationPlan

pytestmark = pytest.mark.ros


def test_plan_survives_the_message_in_another_camera_order() -> None:
    from hand_tracker_ros.ros_io.outputs import header_at
    from hand_tracker_ros.ros_io.plans import plan_from_msg, plan_msg

    plan = ObservationPlan([(10, 20, 110, 140), None, (0, 0, 320, 240)], detect=False)
    msg = plan_msg(plan, header_at(5, ''), ('cam0', 'cam1', 'cam2'))
    assert [r.width for r in msg.rois] == [100, 0, 320]
    back = plan_from_msg(msg, ('cam2', 'cam0', 'cam1', 'cam3'))
    assert back.rois_px == [(0, 0, 320, 240), (10, 20, 110, 140), None, None]
    assert back.detect is False
    whole = plan_from_msg(plan_msg(ObservationPlan.everything(), header_at(5, ''),
                                   ('cam0', 'cam1')), ('cam0', 'cam1'))
    assert whole == ObservationPlan.everything()
    msg.rois.pop()
    with pytest.raises(ShapeError, match='3 camera names but 2 regions'):
        plan_from_msg(msg, ('cam0',))


def test_gate_lets_one_set_through_per_plan_and_everything_without_plans() -> None:
    from hand_tracker_ros.ros_io.plans import REPEAT_S, PlanGate

    gate = PlanGate(timeout_s=1.0)
    assert gate.take(0.0) == ObservationPlan.everything()     # no tracker yet: every set
    assert gate.take(0.1) == ObservationPlan.everything()
    plan = ObservationPlan([(1, 2, 3, 4)], detect=False)
    gate.offer(plan, 1.0)
    assert gate.take(1.01) is plan
    assert gate.take(1.04) is None and gate.take(1.07) is None   # served: wait for the next
    assert gate.skipped == 2
    newer = ObservationPlan(None, detect=True)
    gate.offer(newer, 1.2)
    assert gate.take(1.21) is newer
    # The served set was lost on its way (no fit, so no plan): one more after REPEAT_S.
    assert gate.take(1.21 + REPEAT_S / 2) is None
    assert gate.take(1.22 + REPEAT_S) is newer
    assert gate.take(2.3) == ObservationPlan.everything()     # the tracker went quiet
    assert gate.skipped == 3


def test_a_skipped_set_is_never_decoded_and_a_corrupt_one_leaves_the_plan() -> None:
    import time

    import numpy as np

    from hand_tracker_ros.errors import HandTrackerError
    from hand_tracker_ros.ros_io.image_inputs import ImageSet
    from hand_tracker_ros.ros_io.images import image_msg
    from hand_tracker_ros.ros_io.outputs import header_at
    from hand_tracker_ros.ros_io.plans import PlanGate, planned_set

    def image_set(truncate: bool) -> ImageSet:
        msgs = [image_msg(np.full((24, 32, 3), 7, np.uint8), header_at(5, cam))
                for cam in ('cam0', 'cam1')]
        if truncate:
            msgs[1].data = bytes(msgs[1].data)[:-3]
        return ImageSet(('cam0', 'cam1'), msgs, {'cam0': (32, 24), 'cam1': (32, 24)})

    gate = PlanGate()
    plan = ObservationPlan([(0, 0, 8, 8), None], detect=False)
    gate.offer(plan, time.monotonic())
    with pytest.raises(HandTrackerError, match='cam1'):  # a corrupt set leaves the plan
        planned_set(gate, image_set(truncate=True), 16)
    served = planned_set(gate, image_set(truncate=False), 16)
    assert served is not None and served[1] is plan
    assert [im.shape for im in served[0]] == [(12, 16, 3)] * 2
    corrupt = image_set(truncate=True)
    assert planned_set(gate, corrupt, 16) is None        # the plan was served: skipped
    with pytest.raises(HandTrackerError, match='cam1'):  # its decode had not run
        _ = corrupt.images_rgb
