"""The offline pipeline at a working resolution: a 640x480 rig tracked from 320x240."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.config import from_mapping
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence


def test_a_640_rig_is_observed_and_fitted_at_the_working_width(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=6, width=640, height=480,
                                             seed=4), hand_model)
    frames = [sequence.frame(k) for k in range(6)]
    pipeline = OfflinePipeline(hand_model, sequence.rig,
                               from_mapping(PipelineConfig, {'working_width_px': 320}))
    assert [(c.width, c.height) for c in pipeline.cameras] == [(320, 240)] * 4
    assert [c.width for c in sequence.rig.cameras] == [640] * 4
    pipeline.session.reset(frames[0].theta)
    errors_mm = []
    for frame in frames[1:]:
        result = pipeline.step(FrameSet(frame.stamp_ns, frame.images))
        errors_mm.append(1e3 * np.linalg.norm(result.posed.keypoints_m - frame.keypoints_m,
                                              axis=1).mean())
    observed, _ = pipeline.observe(FrameSet(frames[-1].stamp_ns, frames[-1].images))
    pipeline.close()
    assert {o.features.image_size_px for o in observed.cameras} == {(320, 240)}
    assert max(errors_mm) < 4.0, errors_mm
