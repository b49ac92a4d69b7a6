"""The tracker node's session through the live graph: LOST when the hand jumps, then found."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.evaluation.replay import replay
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence

pytestmark = [pytest.mark.ros, pytest.mark.slow]
JUMP_AT, JUMP_M = 12, 0.09


def test_a_hand_that_jumps_is_reported_lost_then_found_again(tmp_path: Path,
                                                             hand_model) -> None:
    # 30 frames (1 s of pinching, 0.83 s of wall time each at 0.04x): the session finds the
    # hand within a few sets after the jump, which leaves more than a pinch cycle to follow.
    sequence = SyntheticSequence(SynthConfig(motion='pinch', n_frames=30, n_cameras=3, seed=6),
                                 hand_model)
    # From frame JUMP_AT on the hand is 9 cm further along world x: no tracker can follow
    # that from one frame to the next, the session must say LOST and search again.
    sequence.thetas[JUMP_AT:, Layout.translation.start] += JUMP_M
    bag = write_sequence(sequence, tmp_path / 'synthetic')
    outcome = replay(bag, tmp_path / 'replay', rate=0.04, init_from_ground_truth=False)
    jump_ns = sequence.stamp_ns(JUMP_AT)
    after = [s for stamp, s in sorted(outcome.states.items()) if stamp >= jump_ns]
    statuses = [TrackStatus(s.status).name for s in after]
    assert TrackStatus.LOST in [s.status for s in after], statuses
    first_lost = next(i for i, s in enumerate(after) if s.status == TrackStatus.LOST)
    recovered = [s for s in after[first_lost:] if s.status == TrackStatus.TRACKING]
    assert recovered, statuses
    last = after[-1]
    truth = hand_model.pose(sequence.thetas[-1], jacobian=False).keypoints_m
    error_mm = 1e3 * np.linalg.norm(last.keypoints_m - truth, axis=1).mean()
    assert last.status == TrackStatus.TRACKING and error_mm < 15.0, (statuses, error_mm)
    assert all(s.confidence < 0.5 for s in after if s.status == TrackStatus.LOST)
