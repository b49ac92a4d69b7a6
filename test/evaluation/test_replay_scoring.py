"""Scoring a recorded replay: estimates are matched to ground truth by their header stamp."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.bags.convert import hand_state_msg
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.evaluation.replay import live_summary, score_recording
from hand_tracker_ros.pipeline.frames import ground_truth, load_rig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence
from hand_tracker_ros.topics import GT_STATE, STATE


@pytest.fixture(scope='module')
def synthetic_bag(tmp_path_factory: pytest.TempPathFactory, hand_model) -> Path:
    config = SynthConfig(motion='pinch', n_frames=6, n_cameras=2, width=64, height=48)
    return write_sequence(SyntheticSequence(config, hand_model),
                          tmp_path_factory.mktemp('replay') / 'synthetic')


def test_estimates_received_a_frame_late_are_scored_against_their_own_frame(
        synthetic_bag: Path, tmp_path: Path) -> None:
    """An estimate received after the next set was played is scored by its header stamp, and
    its latency runs from the receipt of its own set's ground truth (wall clock)."""
    truth = ground_truth(synthetic_bag)
    stamps = sorted(truth)
    period_ns = stamps[1] - stamps[0]
    wall_ns = 5_000_000_000_000     # the recorder's clock: unrelated to the stamps
    recorded = tmp_path / 'recorded'
    with BagWriter(recorded) as writer:
        writer.add_topic(STATE.absolute, STATE.msgtype)
        writer.add_topic(GT_STATE.absolute, GT_STATE.msgtype)
        for k, stamp in enumerate(stamps):
            played_ns = wall_ns + 2 * k * period_ns          # played at half speed
            writer.write(GT_STATE.absolute, played_ns, hand_state_msg(truth[stamp]))
            exact = dataclasses.replace(truth[stamp], status=1)
            writer.write(STATE.absolute, played_ns + 3 * period_ns // 2, hand_state_msg(exact))

    outcome = score_recording(recorded, truth, load_rig(synthetic_bag), rate=0.5)

    assert sorted(outcome.states) == stamps
    assert outcome.scores is not None
    assert outcome.errors_mm.shape == (len(stamps) - 1,)   # the first frame is not scored
    np.testing.assert_allclose(outcome.errors_mm, 0.0, atol=1e-9)
    assert outcome.scores.failures == 0
    np.testing.assert_allclose(outcome.latencies_ms, 1.5 * period_ns / 1e6)
    # One estimate per set, a set per period of the bag, played at half speed.
    np.testing.assert_allclose(outcome.estimates_per_s, 0.5 / (period_ns / 1e9))
    assert outcome.joint_states == 0 and outcome.tracked_share == 0.0   # no /hand/joint_states
    assert f'{len(stamps)} of {len(stamps)} input sets estimated (100 %)' in \
        live_summary(outcome)
