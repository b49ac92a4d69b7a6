"""Finger-wise search: the states of one finger, and the search bringing a finger back."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.model.layout import FINGERS, Layout
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.evidence import EvidenceConfig, confidence, measure
from hand_tracker_ros.tracking.fingers import (
    FINGER_STATES,
    finger_states,
    search_fingers,
    short_fit,
)


def test_a_finger_state_sets_that_finger_and_nothing_else(hand_model) -> None:
    theta = hand_model.neutral_theta((0.01, -0.05, 0.02))
    theta[Layout.index('middle_mcp_abd')] = 0.1
    for finger in FINGERS:
        states = finger_states(theta, finger, hand_model)
        assert set(states) == {f'{finger}_{name}' for name in FINGER_STATES}
        own = np.zeros(Layout.P, bool)
        own[Layout.per_finger[finger]] = True
        for name, start in states.items():
            np.testing.assert_array_equal(start[~own], theta[~own])
            expected = np.deg2rad(FINGER_STATES[name.removeprefix(f'{finger}_')])
            # MCP flexion, abduction 0, PIP, DIP
            np.testing.assert_allclose(start[own], [expected[0], 0.0, *expected[1:]])


@pytest.mark.slow
def test_the_search_brings_a_finger_in_a_wrong_state_back(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='random', n_frames=2, seed=2), hand_model)
    frame = sequence.frame(1)
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    observations, _ = pipeline.observe(FrameSet(frame.stamp_ns, frame.images))
    pipeline.close()
    # The middle finger, flexed 74 / 46 / 16 deg here, straightened: a short fit from there
    # stays about 14 mm off.
    start = finger_states(frame.theta, 'middle', hand_model)['middle_extended']
    config = EvidenceConfig()

    def score(fit) -> float:
        return confidence(measure(fit.views, observations, fit.posed.fingertips_m, config),
                          config)

    def error_mm(theta) -> float:
        keypoints = hand_model.pose(theta, jacobian=False).keypoints_m
        return 1e3 * float(np.linalg.norm(keypoints - frame.keypoints_m, axis=1).mean())

    best_score, best = search_fingers(pipeline.tracker, observations, start, score)
    alone = short_fit(pipeline.tracker, observations, start)
    assert min(error_mm(start), error_mm(alone.theta)) > 12.0
    assert error_mm(best) < 7.0 and best_score > max(0.9, score(alone))
