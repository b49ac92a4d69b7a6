"""`hand-tracker launch --bag`: the five-node graph plays a bag, tracks, records, and stops."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
import yaml

from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence

pytestmark = [pytest.mark.ros, pytest.mark.slow]
# Enough sets to see each output recorded once per set; every set costs 1.7 s of playback.
N_FRAMES = 6


def test_launch_plays_tracks_records_and_stops_at_the_end_of_the_bag(tmp_path: Path,
                                                                    hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=N_FRAMES, n_cameras=3),
                                 hand_model)
    bag = write_sequence(sequence, tmp_path / 'synthetic')
    params = tmp_path / 'params.yaml'
    params.write_text(yaml.safe_dump({
        'tracker': {'ros__parameters': {
            'initialization': 'initial_pose',
            'initial_pose': [float(v) for v in sequence.thetas[0]]}}}))
    record = tmp_path / 'tracked'
    result = subprocess.run(['hand-tracker', 'launch', '--bag', str(bag), '--rate', '0.02',
                             '--params', str(params), '--record', str(record)],
                            capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stdout[-3000:]
    assert 'player exited; stopping the graph' in result.stdout
    with BagReader(record) as reader:
        counts = {t: s.count for t, s in reader.topics.items()}
    # The player starts once the graph is connected and the graph drains after the bag, so
    # every set is tracked (the bag plays at 0.6 sets/s: a set needs ~0.1 s, but one the
    # session doubts is refitted from its recovery hypotheses, ~1 s on a loaded machine).
    # On a failure, the tracker's shutdown line in the output says where the sets went.
    assert counts.get('/hand/state') == N_FRAMES, (counts, result.stdout[-3000:])
    assert counts.get('/hand/joint_states') == N_FRAMES, counts
    assert counts.get('/tf') == N_FRAMES and counts.get('/hand/markers') == N_FRAMES, counts
    assert counts.get('/hand/robot_description') == 1, counts      # latched, recorded once
