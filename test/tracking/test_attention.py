"""The attention policy: whole images until the hand is tracked, then a region of interest
and a fingertip detection every few sets; the offline pipeline observes what it plans."""
from __future__ import annotations

from collections import Counter

from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.attention import Attention, AttentionConfig, ObservationPlan
from hand_tracker_ros.tracking.roi import hand_rois
from hand_tracker_ros.vision.detections import SalientDetections


class _Session:
    """The two things the policy reads of a tracking session."""

    def __init__(self, posed, status) -> None:
        self.status = status
        self.tracker = type('Tracker', (), {'last_posed': posed})()


def test_untracked_sets_observe_everything_tracked_ones_a_box_and_every_nth_detection(
        hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=2), hand_model)
    posed = hand_model.pose(sequence.thetas[0], jacobian=False)
    cameras = sequence.rig.cameras
    attention = Attention(AttentionConfig(detect_every=3), cameras)
    assert attention.plan(_Session(None, None)) == ObservationPlan.everything()
    assert attention.plan(_Session(posed, TrackStatus.LOST)) == ObservationPlan.everything()
    tracked = [attention.plan(_Session(posed, TrackStatus.TRACKING)) for _ in range(6)]
    assert [p.detect for p in tracked] == [False, False, True, False, False, True]
    assert all(p.rois_px == hand_rois(posed, cameras) for p in tracked)
    # A lost set restarts the count: the next tracked set detects only after three more.
    assert attention.plan(_Session(posed, TrackStatus.LOST)).detect
    assert not attention.plan(_Session(posed, TrackStatus.TRACKING)).detect
    whole = Attention(AttentionConfig(use_roi=False), cameras)
    assert whole.plan(_Session(posed, TrackStatus.TRACKING)).rois_px is None


def test_the_kind_of_the_next_plan_is_known_before_planning(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=2), hand_model)
    posed = hand_model.pose(sequence.thetas[0], jacobian=False)
    attention = Attention(AttentionConfig(detect_every=2), sequence.rig.cameras)
    statuses = [None, TrackStatus.TRACKING, TrackStatus.TRACKING, TrackStatus.TRACKING,
                TrackStatus.LOST, TrackStatus.TRACKING, TrackStatus.TRACKING]
    told, planned = [], []
    for status in statuses:
        session = _Session(None if status is None else posed, status)
        told.append(attention.next_kind(session))
        assert attention.next_kind(session) == told[-1]      # asking plans nothing
        plan = attention.plan(session)
        planned.append((plan.rois_px is not None, plan.detect))
    assert told == planned == [(False, True), (True, False), (True, True), (True, False),
                               (False, True), (True, False), (True, True)]


def test_offline_pipeline_observes_what_the_plan_of_a_tracked_hand_says(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=3), hand_model)
    pipe = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    try:
        pipe.session.reset(sequence.thetas[0])
        shots = [sequence.frame(k) for k in range(3)]
        assert pipe.step(FrameSet(shots[1].stamp_ns, shots[1].images)).status == \
            TrackStatus.TRACKING
        plan = Attention(AttentionConfig(), sequence.rig.cameras).plan(pipe.session)
        assert plan.rois_px is not None and not plan.detect
        observed, _ = pipe.observe(FrameSet(shots[2].stamp_ns, shots[2].images), plan)
        for camera, box in zip(observed.cameras, plan.rois_px):
            assert camera.features.roi_px == box
            assert len(camera.tips.uv_px) == 0
        everything, _ = pipe.observe(FrameSet(shots[2].stamp_ns, shots[2].images))
        assert all(len(c.tips.uv_px) > 0 for c in everything.cameras)
    finally:
        pipe.close()


def test_a_tracked_hand_is_detected_in_the_plans_region_of_interest(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=2), hand_model)
    shot = sequence.frame(1)
    asked = []

    def detector(image, roi_px):
        asked.append(roi_px)
        return SalientDetections.empty()

    pipe = OfflinePipeline(hand_model, sequence.rig, PipelineConfig(), detector=detector)
    try:
        posed = hand_model.pose(sequence.thetas[0], jacobian=False)
        boxes = hand_rois(posed, sequence.rig.cameras)
        pipe.observe(FrameSet(shot.stamp_ns, shot.images), ObservationPlan(boxes, True))
        pipe.observe(FrameSet(shot.stamp_ns, shot.images))
    finally:
        pipe.close()
    # Two detection threads: the calls' order is not the cameras'.
    assert Counter(asked) == Counter([*boxes, *[None] * len(boxes)])
