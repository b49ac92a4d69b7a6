"""The region of interest holds the projected hand with its margin, inside the image."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.roi import RoiConfig, hand_rois


def test_roi_holds_the_hand_and_its_margin_clipped_to_the_image(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=2), hand_model)
    posed = hand_model.pose(sequence.thetas[0], jacobian=False)
    cameras = sequence.rig.cameras
    tight = hand_rois(posed, cameras, RoiConfig(margin_fraction=0.0, margin_px=0))
    grown = hand_rois(posed, cameras, RoiConfig(margin_fraction=0.25, margin_px=10))
    for camera, box, big in zip(cameras, tight, grown):
        uv, _ = camera.project(posed.vertices_m)
        u0, v0, u1, v1 = box
        assert u0 <= uv[:, 0].min() and uv[:, 0].max() < u1
        assert v0 <= uv[:, 1].min() and uv[:, 1].max() < v1
        assert big[0] <= u0 and big[1] <= v0 and big[2] >= u1 and big[3] >= v1
        assert 0 <= big[0] < big[2] <= camera.width and 0 <= big[1] < big[3] <= camera.height
        assert (big[2] - big[0]) > (u1 - u0)


def test_a_hand_behind_the_camera_gives_the_whole_image(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=2), hand_model)
    camera = sequence.rig.cameras[0]
    theta = np.array(sequence.thetas[0], float)
    # Move the hand 1 m behind the camera, along its optical axis.
    theta[:3] = camera.center_world - 1.0 * camera.R_cam_world[2]
    posed = hand_model.pose(theta, jacobian=False)
    assert hand_rois(posed, [camera]) == [None]
