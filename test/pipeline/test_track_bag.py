"""`hand-tracker track`: a synthetic bag in, an estimates bag out; clear errors on bad input."""
from __future__ import annotations

import contextlib
import io
import shutil
from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.bags.convert import hand_state_from_msg
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.cli.main import main
from hand_tracker_ros.pipeline.track_bag import JOINTS_TOPIC, STATE_TOPIC


SYNTH = ['--motion', 'pinch', '--frames', '6', '--cameras', '3', '--seed', '1']


def _synth(out: Path, *args: str) -> Path:
    assert main(['synth', '--out', str(out), *SYNTH, *args]) == 0
    return out


def _track(bag: Path, out: Path, *args: str) -> tuple[float, list]:
    """Track ``bag`` from the ground truth; (printed mean joint error in mm, HandStates)."""
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(['track', str(bag), '--out', str(out), '--init', 'ground-truth',
                     *args]) == 0
    assert 'tracked 6/6' in printed.getvalue()
    with BagReader(out) as estimates:
        assert estimates.topics[JOINTS_TOPIC].count == 6
        states = [hand_state_from_msg(m) for *_, m in estimates.decoded(topics=[STATE_TOPIC])]
    return float(printed.getvalue().split('ground truth: ')[1].split(' mm')[0]), states


@pytest.fixture(scope='module')
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _synth(tmp_path_factory.mktemp('track') / 'seq')


@pytest.fixture(scope='module')
def raw_estimates(synthetic: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple:
    return _track(synthetic / 'bag', tmp_path_factory.mktemp('raw') / 'estimates')


def test_track_writes_estimates_close_to_ground_truth(raw_estimates: tuple) -> None:
    error, states = raw_estimates
    assert error < 6.0
    assert [s.status for s in states] == [1] * 6
    assert states[0].keypoints_m.shape == (21, 3) and np.isfinite(states[0].joint_positions).all()


@pytest.mark.parametrize('image_format', ['png', 'jpeg'])
def test_compressed_bag_tracks_like_raw(raw_estimates: tuple, tmp_path: Path,
                                        image_format: str) -> None:
    seq = _synth(tmp_path / 'seq', '--image-format', image_format)
    with BagReader(seq / 'bag') as bag:
        assert bag.topics['/cam0/image_raw/compressed'].msgtype == \
            'sensor_msgs/msg/CompressedImage'
        assert '/cam0/image_raw' not in bag.topics
    error, states = _track(seq / 'bag', tmp_path / 'estimates')
    raw_error, raw_states = raw_estimates
    if image_format == 'png':   # lossless: the tracker sees the same pixels
        for state, raw in zip(states, raw_states, strict=True):
            np.testing.assert_array_equal(state.joint_positions, raw.joint_positions)
    assert abs(error - raw_error) < 1.0, (error, raw_error)


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
