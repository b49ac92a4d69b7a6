"""`hand-tracker track`: a synthetic bag in, an estimates bag out; clear errors on bad input."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.bags.convert import hand_state_from_msg
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.cli.main import main
from hand_tracker_ros.pipeline.track_bag import JOINTS_TOPIC, STATE_TOPIC


@pytest.fixture(scope='module')
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('track') / 'seq'
    assert main(['synth', '--out', str(out), '--motion', 'pinch', '--frames', '6',
                 '--cameras', '3', '--seed', '1']) == 0
    return out


def test_track_writes_estimates_close_to_ground_truth(synthetic: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / 'estimates'
    assert main(['track', str(synthetic / 'bag'), '--out', str(out),
                 '--init', 'ground-truth']) == 0
    printed = capsys.readouterr().out
    assert 'tracked 6/6' in printed
    error = float(printed.split('ground truth: ')[1].split(' mm')[0])
    assert error < 6.0
    with BagReader(out) as bag:
        assert bag.topics[JOINTS_TOPIC].count == 6
        states = [hand_state_from_msg(m) for *_, m in bag.decoded(topics=[STATE_TOPIC])]
    assert [s.status for s in states] == [1] * 6
    assert states[0].keypoints_m.shape == (21, 3) and np.isfinite(states[0].joint_positions).all()


def test_missing_rig_is_a_clear_error(synthetic: Path, tmp_path: Path,
                                      capsys: pytest.CaptureFixture) -> None:
    bag_only = tmp_path / 'lonely'
    shutil.copytree(synthetic / 'bag', bag_only / 'bag')
    assert main(['track', str(bag_only / 'bag'), '--out', str(tmp_path / 'o')]) == 2
    assert 'no rig calibration' in capsys.readouterr().err


def test_corrupt_bag_is_a_clear_error(synthetic: Path, tmp_path: Path,
                                      capsys: pytest.CaptureFixture) -> None:
    broken = tmp_path / 'broken'
    shutil.copytree(synthetic, broken)
    [mcap] = (broken / 'bag').glob('*.mcap')
    mcap.write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    assert main(['track', str(broken / 'bag'), '--out', str(tmp_path / 'o')]) == 2
    assert 'truncated' in capsys.readouterr().err
