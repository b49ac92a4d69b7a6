"""Synthetic sequences: determinism, and ground truth that reprojects onto the rendered hand."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.bags.convert import (
    camera_info_from_msg,
    hand_state_from_msg,
    joint_state_from_msg,
)
from hand_tracker_ros.bags.image_codec import image_from_msg
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.cli.main import main
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import GT_JOINTS_TOPIC, GT_STATE_TOPIC

SMALL = SynthConfig(motion='pinch', n_frames=4, n_cameras=2, seed=5)


def test_same_seed_gives_byte_identical_images(hand_model) -> None:
    a = SyntheticSequence(SMALL, hand_model).frame(2)
    b = SyntheticSequence(SMALL, hand_model).frame(2)
    for x, y in zip(a.images, b.images):
        assert x.tobytes() == y.tobytes()
    other = SyntheticSequence(SynthConfig(motion='pinch', n_frames=4, n_cameras=2, seed=6),
                              hand_model).frame(2)
    assert a.images[0].tobytes() != other.images[0].tobytes()


@pytest.fixture(scope='module')
def written(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('synth') / 'seq'
    assert main(['synth', '--out', str(out), '--motion', 'grasp', '--cameras', '3',
                 '--frames', '5', '--seed', '2']) == 0
    return out


def test_bag_has_the_documented_topics_and_counts(written: Path) -> None:
    with BagReader(written / 'bag') as bag:
        topics = bag.topics
    expected = {f'/cam{c}/{t}' for c in range(3) for t in ('image_raw', 'camera_info')}
    assert set(topics) == expected | {GT_JOINTS_TOPIC, GT_STATE_TOPIC}
    assert all(summary.count == 5 for summary in topics.values())
    assert topics['/cam0/image_raw'].best_effort


def test_ground_truth_reprojects_onto_the_rendered_hand(written: Path) -> None:
    """Every GT keypoint projects onto pixels where the image differs from the background."""
    rig = CameraRig.from_yaml(written / 'rig.yaml')
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=5, n_cameras=3, seed=2))
    images, infos, states, joints = {}, {}, [], []
    with BagReader(written / 'bag') as bag:
        for topic, _, stamp, msg in bag.decoded():
            if topic.endswith('image_raw'):
                images[(topic.split('/')[1], stamp)] = image_from_msg(msg, source=topic)
            elif topic.endswith('camera_info'):
                infos[topic.split('/')[1]] = camera_info_from_msg(msg)
            elif topic == GT_STATE_TOPIC:
                states.append(hand_state_from_msg(msg))
            else:
                joints.append(joint_state_from_msg(msg))
    assert len(states) == 5 and joints[0][1] == PARAM_NAMES
    for camera, background in zip(rig.cameras, sequence.backgrounds):
        np.testing.assert_allclose(infos[camera.name].K, camera.K)
        for state in states:
            image = images[(camera.name, state.stamp_ns)].astype(int)
            hand = np.abs(image - background).sum(axis=2) > 40
            uv, depth = camera.project(state.keypoints_m)
            assert np.all(depth > 0)
            px = np.rint(uv).astype(int)
            inside = (px[:, 0] >= 0) & (px[:, 0] < camera.width) & (px[:, 1] >= 0) & \
                (px[:, 1] < camera.height)
            assert inside.all()
            # joint centres lie inside the hand volume, so they project inside its silhouette
            near = [hand[max(v - 1, 0):v + 2, max(u - 1, 0):u + 2].any() for u, v in px]
            assert np.mean(near) == 1.0, (camera.name, state.stamp_ns)


def test_refuses_a_non_empty_output_directory(written: Path) -> None:
    assert main(['synth', '--out', str(written), '--frames', '1']) == 2


def test_independent_mcap_reader_opens_the_bag(written: Path) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    [mcap_file] = (written / 'bag').glob('*.mcap')
    with mcap_file.open('rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        seen = {}
        for _, channel, _, msg in reader.iter_decoded_messages():
            seen[channel.topic] = msg
    assert len(seen[GT_STATE_TOPIC].keypoints) == 21
    assert seen['/cam1/image_raw'].encoding == 'rgb8'
