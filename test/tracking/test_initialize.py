"""Initialization from observations: ray triangulation and the hypothesis search."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.pipeline.frames import FrameSet
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.initialize import triangulate_mask_centroids


def test_triangulation_recovers_a_ball_centre() -> None:
    rig = CameraRig.ring(3, 160, 120)
    centre = np.array([0.02, -0.01, 0.03])
    masks = []
    for camera in rig.cameras:
        uv, _ = camera.project(centre[None])
        vv, uu = np.mgrid[:120, :160]
        masks.append((uu - uv[0, 0]) ** 2 + (vv - uv[0, 1]) ** 2 < 36)
    np.testing.assert_allclose(triangulate_mask_centroids(rig.cameras, masks, 10), centre,
                               atol=1e-3)
    with pytest.raises(HandTrackerError, match='only 1 camera'):
        triangulate_mask_centroids(rig.cameras, [masks[0], masks[1] & False, masks[2] & False],
                                   10)


@pytest.mark.slow
def test_pipeline_finds_the_hand_without_a_given_pose(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='wrist', n_frames=12), hand_model)
    frame = sequence.frame(10)
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    result = pipeline.step(FrameSet(frame.stamp_ns, frame.images))
    pipeline.close()
    error = 1e3 * np.linalg.norm(result.posed.keypoints_m - frame.keypoints_m, axis=1).mean()
    assert error < 10.0 and 'initialize' in result.timings_s
