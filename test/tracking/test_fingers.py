"""Finger-wise search: the states of one finger, the search bringing a finger back, and the
one-shot search ending with it."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.model.layout import FINGERS, FLEXIONS, Layout
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking import fingers as fingers_module
from hand_tracker_ros.tracking import initialize as initialize_module
from hand_tracker_ros.tracking.evidence import EvidenceConfig, confidence, measure
from hand_tracker_ros.tracking.fingers import (
    FINGER_STATES,
    finger_states,
    pinned_fingers,
    search_fingers,
    short_fit,
    unpinning_starts,
)
from hand_tracker_ros.tracking.initialize import InitConfig

THUMB_JOINTS = Layout.names[Layout.thumb]


def test_a_finger_state_sets_that_finger_and_nothing_else(hand_model) -> None:
    theta = hand_model.neutral_theta((0.01, -0.05, 0.02))
    theta[Layout.index('middle_mcp_abd')] = 0.1
    for finger in FINGERS:
        states = finger_states(theta, finger, hand_model)
        assert set(states) == {f'{finger}_{name}' for name in ('extended', 'curled', 'closed')}
        own = np.zeros(Layout.P, bool)
        own[Layout.per_finger[finger]] = True
        for name, start in states.items():
            np.testing.assert_array_equal(start[~own], theta[~own])
            degrees = FINGER_STATES[name.removeprefix(f'{finger}_')]
            mcp, pip, dip = (np.deg2rad(degrees.get(f'{finger}_{j}', 0.0)) for j in FLEXIONS)
            np.testing.assert_allclose(start[own], [mcp, 0.0, pip, dip])   # Layout order


def test_a_thumb_state_sets_the_thumbs_four_dof_and_nothing_else(hand_model) -> None:
    theta = hand_model.neutral_theta((0.01, -0.05, 0.02))
    states = finger_states(theta, 'thumb', hand_model)
    assert set(states) == {f'thumb_{name}' for name in FINGER_STATES}
    own = np.zeros(Layout.P, bool)
    own[Layout.thumb] = True
    for name, start in states.items():
        np.testing.assert_array_equal(start[~own], theta[~own])
        degrees = FINGER_STATES[name.removeprefix('thumb_')]
        expected = np.clip(np.deg2rad([degrees.get(joint, 0.0) for joint in THUMB_JOINTS]),
                           hand_model.lower[own], hand_model.upper[own])
        np.testing.assert_allclose(start[own], expected)
    assert not np.allclose(states['thumb_extended'][own], states['thumb_curled'][own])


def test_a_finger_is_pinned_at_mcp_hyperextension_or_full_pip_or_dip_flexion(hand_model
                                                                              ) -> None:
    theta = hand_model.neutral_theta((0.0, 0.0, 0.0))
    margin = np.deg2rad(2.0)
    lower, upper = hand_model.lower, hand_model.upper
    assert pinned_fingers(theta, hand_model, margin) == []
    straight = theta.copy()                 # PIP and DIP at their extension limits: no pin
    for finger in FINGERS:
        straight[Layout.index(f'{finger}_pip_flex')] = lower[Layout.index(f'{finger}_pip_flex')]
        straight[Layout.index(f'{finger}_dip_flex')] = lower[Layout.index(f'{finger}_dip_flex')]
    assert pinned_fingers(straight, hand_model, margin) == []
    for joint, limit, finger in (('mcp_flex', lower, 'ring'), ('pip_flex', upper, 'index'),
                                 ('dip_flex', upper, 'pinky')):
        k = Layout.index(f'{finger}_{joint}')
        for offset_deg, pinned in ((1.9, True), (2.1, False)):
            at = theta.copy()
            at[k] = limit[k] + np.deg2rad(offset_deg) * (1.0 if limit is lower else -1.0)
            assert pinned_fingers(at, hand_model, margin) == ([finger] if pinned else [])
    both = theta.copy()
    both[Layout.index('middle_dip_flex')] = upper[Layout.index('middle_dip_flex')]
    both[Layout.index('index_mcp_flex')] = lower[Layout.index('index_mcp_flex')]
    assert pinned_fingers(both, hand_model, margin) == ['index', 'middle']


def test_the_thumb_is_pinned_at_any_of_its_limits_and_comes_last(hand_model) -> None:
    theta = hand_model.neutral_theta((0.0, 0.0, 0.0))
    margin = np.deg2rad(2.0)
    lower, upper = hand_model.lower, hand_model.upper
    for joint in THUMB_JOINTS:
        k = Layout.index(joint)
        for limit, sign in ((lower, 1.0), (upper, -1.0)):
            for offset_deg, pinned in ((1.9, True), (2.1, False)):
                at = theta.copy()
                at[k] = limit[k] + sign * np.deg2rad(offset_deg)
                assert pinned_fingers(at, hand_model, margin) == (['thumb'] if pinned else [])
    both = theta.copy()
    both[Layout.index('thumb_ip_flex')] = upper[Layout.index('thumb_ip_flex')]
    both[Layout.index('ring_pip_flex')] = upper[Layout.index('ring_pip_flex')]
    assert pinned_fingers(both, hand_model, margin) == ['ring', 'thumb']


def test_unpinning_starts_move_only_the_pinned_fingers(hand_model) -> None:
    theta = hand_model.neutral_theta((0.01, -0.05, 0.02))
    trusted = theta + 0.05
    starts = unpinning_starts(theta, ['ring'], hand_model, trusted)
    assert set(starts) == {'ring_extended', 'ring_curled', 'ring_closed', 'ring_trusted'}
    own = np.zeros(Layout.P, bool)
    own[Layout.per_finger['ring']] = True
    for start in starts.values():
        np.testing.assert_array_equal(start[~own], theta[~own])
    np.testing.assert_array_equal(starts['ring_trusted'][own], trusted[own])
    assert set(unpinning_starts(theta, ['index', 'ring'], hand_model, None)) == {
        f'{f}_{s}' for f in ('index', 'ring') for s in FINGER_STATES}
    thumb = unpinning_starts(theta, ['thumb'], hand_model, trusted)
    np.testing.assert_array_equal(thumb['thumb_trusted'][Layout.thumb], trusted[Layout.thumb])
    np.testing.assert_array_equal(thumb['thumb_trusted'][Layout.fingers],
                                  theta[Layout.fingers])


def test_the_finger_search_leaves_the_thumb_as_it_is(hand_model, monkeypatch) -> None:
    start = hand_model.neutral_theta((0.01, -0.05, 0.02))
    tried = []

    def record(tracker, observations, theta):
        tried.append(np.array(theta))
        return SimpleNamespace(theta=np.array(theta))

    monkeypatch.setattr(fingers_module, 'short_fit', record)
    search_fingers(SimpleNamespace(model=hand_model), None, (0.5, start), lambda fit: 0.0)
    assert len(tried) == len(FINGERS) * len(FINGER_STATES)
    for theta in tried:
        np.testing.assert_array_equal(theta[Layout.thumb], start[Layout.thumb])


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

    alone = short_fit(pipeline.tracker, observations, start)
    assert min(error_mm(start), error_mm(alone.theta)) > 12.0
    best_score, best = search_fingers(pipeline.tracker, observations,
                                      (score(alone), alone.theta), score)
    assert error_mm(best) < 7.0 and best_score > max(0.9, score(alone))


@pytest.mark.slow
@pytest.mark.parametrize('finger_search', [True, False])
def test_the_one_shot_search_ends_with_the_finger_search_when_configured(
        hand_model, monkeypatch, finger_search) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='random', n_frames=1, seed=2), hand_model)
    frame = sequence.frame(0)
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    observations, _ = pipeline.observe(FrameSet(frame.stamp_ns, frame.images))
    pipeline.close()
    calls = []
    found = frame.theta + 0.01

    def spy(tracker, observations, start, score):
        calls.append(start)
        return 2.0, found

    monkeypatch.setattr(initialize_module, 'search_fingers', spy)
    theta = initialize_module.initialize(pipeline.tracker, observations,
                                         InitConfig(finger_search=finger_search))
    assert len(calls) == int(finger_search)
    if finger_search:           # it starts from the search's best, and its result is kept
        assert 0.0 <= calls[0][0] <= 1.0 and calls[0][1].shape == theta.shape
        np.testing.assert_array_equal(theta, found)
    else:
        assert not np.array_equal(theta, found)
