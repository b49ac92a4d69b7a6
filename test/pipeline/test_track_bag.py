"""`hand-tracker track`: a synthetic bag in, an estimates bag out; clear errors on bad input."""
from __future__ import annotations

import contextlib
import io
import logging
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hand_tracker_ros.bags.convert import hand_state_from_msg
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.cli.main import main
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.urdf import urdf_text
from hand_tracker_ros.topics import JOINT_STATES, MARKERS, ROBOT_DESCRIPTION, STATE, TF

JOINTS_TOPIC, STATE_TOPIC = JOINT_STATES.absolute, STATE.absolute

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
def raw_output(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where ``raw_estimates`` writes the estimates bag."""
    return tmp_path_factory.mktemp('raw') / 'estimates'


@pytest.fixture(scope='module')
def raw_estimates(synthetic: Path, raw_output: Path) -> tuple:
    return _track(synthetic / 'bag', raw_output)


def test_track_writes_estimates_close_to_ground_truth(raw_estimates: tuple) -> None:
    error, states = raw_estimates
    assert error < 6.0
    assert [s.status for s in states] == [1] * 6
    assert states[0].keypoints_m.shape == (21, 3) and np.isfinite(states[0].joint_positions).all()


def test_estimates_bag_reads_with_the_independent_mcap_readers(raw_estimates: tuple,
                                                                 raw_output: Path) -> None:
    """The ``mcap`` + ``mcap-ros2-support`` readers (not rosbags, which wrote the bag) decode
    every message, from the schemas stored in the file, to the values rosbags reads."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    _, states = raw_estimates
    [mcap] = raw_output.glob('*.mcap')
    with mcap.open('rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        rows = [(channel.topic, schema.name, msg.log_time, ros)
                for schema, channel, msg, ros in reader.iter_decoded_messages()]
    joints = [r for r in rows if r[0] == JOINTS_TOPIC]
    hand = [r for r in rows if r[0] == STATE_TOPIC]
    assert {r[1] for r in joints} == {'sensor_msgs/msg/JointState'}
    assert {r[1] for r in hand} == {'hand_tracker_msgs/msg/HandState'}
    assert len(joints) == len(hand) == len(states) == 6
    for (_, _, log_ns, joint), (_, _, _, state), expected in zip(joints, hand, states,
                                                                 strict=True):
        assert log_ns == expected.stamp_ns
        assert joint.header.stamp.sec * 10**9 + joint.header.stamp.nanosec == log_ns
        assert tuple(joint.name) == PARAM_NAMES
        np.testing.assert_array_equal(joint.position, expected.joint_positions)
        assert state.status == expected.status and state.iterations == expected.iterations
        np.testing.assert_array_equal(
            [(p.x, p.y, p.z) for p in state.keypoints], expected.keypoints_m)
        assert tuple(state.energy_names) == expected.energy_names


def test_estimates_bag_holds_the_live_graphs_tf_markers_and_description(
        raw_estimates: tuple, raw_output: Path, hand_model) -> None:
    """The same topics as the live tracker: /tf chains from the world frame to every link at
    the estimate, robot_description is the URDF (latched), one MarkerArray per set."""
    _, states = raw_estimates
    with BagReader(raw_output) as bag:
        assert bag.topics[TF.absolute].msgtype == 'tf2_msgs/msg/TFMessage'
        assert bag.topics[TF.absolute].count == bag.topics[MARKERS.absolute].count == 6
        assert bag.topics[ROBOT_DESCRIPTION.absolute].count == 1
        [(*_, description)] = bag.decoded(topics=[ROBOT_DESCRIPTION.absolute])
        tfs = [msg for *_, msg in bag.decoded(topics=[TF.absolute])]
    assert description.data == urdf_text(hand_model, root_link='world')
    for tf, state in zip(tfs, states, strict=True):
        poses = {'world': np.eye(4)}
        for t in tf.transforms:
            assert t.header.stamp.sec * 10**9 + t.header.stamp.nanosec == state.stamp_ns
            q, v = t.transform.rotation, t.transform.translation
            pose = np.eye(4)
            pose[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
            pose[:3, 3] = (v.x, v.y, v.z)
            poses[t.child_frame_id] = poses[t.header.frame_id] @ pose
        bones = hand_model.pose(state.joint_positions, jacobian=False).bone_transforms
        for b, name in enumerate(hand_model.part_names):
            np.testing.assert_allclose(poses[name], bones[b], atol=1e-12)


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


def _without_camera_info(bag: Path, out: Path) -> Path:
    """A copy of ``bag`` without its camera_info topics (raw records, same stamps)."""
    with BagReader(bag) as source, BagWriter(out) as target:
        kept = {t: s for t, s in source.topics.items() if not t.endswith('/camera_info')}
        for topic, summary in kept.items():
            target.add_topic(topic, summary.msgtype)
        for topic, _, stamp, raw in source.messages(topics=list(kept)):
            target.write_raw(topic, stamp, raw)
    return out


def test_bag_without_camera_info_tracks_with_a_rig(synthetic: Path, raw_estimates: tuple,
                                                   tmp_path: Path,
                                                   capsys: pytest.CaptureFixture) -> None:
    bag = _without_camera_info(synthetic / 'bag', tmp_path / 'no_info' / 'bag')
    error, _ = _track(bag, tmp_path / 'estimates', '--rig', str(synthetic / 'rig.yaml'))
    assert error == raw_estimates[0]
    assert main(['track', str(bag), '--out', str(tmp_path / 'o')]) == 2
    err = capsys.readouterr().err
    assert 'no rig calibration' in err and 'pass --rig' in err


def test_wrong_bag_path_says_so(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(['track', str(tmp_path / 'nowhere'), '--out', str(tmp_path / 'o')]) == 2
    err = capsys.readouterr().err
    assert 'nowhere: bag not found' in err and 'rig' not in err
    assert not (tmp_path / 'o').exists()


def _tracked_count(bag: Path, out: Path) -> int:
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(['track', str(bag), '--out', str(out), '--init', 'ground-truth']) == 0
    return int(printed.getvalue().split('tracked ')[1].split('/')[0])


def test_truncated_bag_is_tracked_up_to_the_damage(synthetic: Path, tmp_path: Path,
                                                   caplog: pytest.LogCaptureFixture) -> None:
    broken = tmp_path / 'broken'
    shutil.copytree(synthetic, broken)
    [mcap] = (broken / 'bag').glob('*.mcap')
    mcap.write_bytes(mcap.read_bytes()[: mcap.stat().st_size * 3 // 4])
    with caplog.at_level(logging.WARNING):
        tracked = _tracked_count(broken / 'bag', tmp_path / 'o')
    assert 0 < tracked < 6
    assert 'is truncated' in caplog.text and 'before the damage' in caplog.text


def test_bag_damaged_inside_is_tracked_up_to_the_damage(synthetic: Path, tmp_path: Path,
                                                        caplog: pytest.LogCaptureFixture
                                                        ) -> None:
    broken = tmp_path / 'broken'
    shutil.copytree(synthetic, broken)
    with BagReader(broken / 'bag') as bag:
        stamps = sorted({stamp for *_, stamp, _ in bag.messages(topics=['/cam0/image_raw'])})
    [mcap] = (broken / 'bag').glob('*.mcap')
    data = bytearray(mcap.read_bytes())
    # mcap Message record: opcode 0x05, u64 length, u16 channel, u32 sequence, u64 log time,
    # u64 publish time, payload. Give a late frame's first record an absurd length.
    stamp = stamps[4].to_bytes(8, 'little')
    start = data.index(stamp + stamp) - 1 - 8 - 2 - 4
    assert data[start] == 0x05
    data[start + 1:start + 9] = (2**62).to_bytes(8, 'little')
    mcap.write_bytes(bytes(data))
    with caplog.at_level(logging.WARNING):
        tracked = _tracked_count(broken / 'bag', tmp_path / 'o')
    assert 0 < tracked < 6
    assert 'damaged after the messages read so far' in caplog.text


def test_synth_and_track_follow_the_shape_file(tmp_path: Path) -> None:
    from hand_tracker_ros.model.shape import HandShape
    from hand_tracker_ros.model.shape_file import load_shape, save_shape
    from hand_tracker_ros.synthetic.writer import GT_STATE_TOPIC

    shape = HandShape(scale=1.1, index_m=(0.052, 0.029, 0.02))
    save_shape(shape, tmp_path / 'big.yaml')
    seq = _synth(tmp_path / 'seq', '--shape', str(tmp_path / 'big.yaml'))
    assert load_shape(seq / 'shape.yaml') == shape
    with BagReader(seq / 'bag') as bag:
        truth = [hand_state_from_msg(m) for *_, m in bag.decoded(topics=[GT_STATE_TOPIC])]
    np.testing.assert_array_equal(truth[0].shape_parameters, shape.to_vector())
    error, states = _track(seq / 'bag', tmp_path / 'est', '--shape', str(seq / 'shape.yaml'))
    assert error < 6.0
    assert all(np.array_equal(s.shape_parameters, shape.to_vector()) for s in states)


def test_the_scale_of_a_larger_hand_is_followed_unless_fixed(tmp_path: Path) -> None:
    """A 1.12x hand tracked with the default model: by default the estimates bag holds a new
    URDF at every scale move, each HandState the shape it was posed with, and the scale grows;
    with --fixed-scale one URDF and the default scale throughout."""
    from hand_tracker_ros.model.hand import HandModel
    from hand_tracker_ros.model.shape import HandShape
    from hand_tracker_ros.model.shape_file import save_shape

    save_shape(HandShape(scale=1.12), tmp_path / 'large.yaml')
    assert main(['synth', '--out', str(tmp_path / 'seq'), '--motion', 'grasp', '--frames', '12',
                 '--cameras', '3', '--seed', '1', '--shape', str(tmp_path / 'large.yaml')]) == 0
    runs = {}
    for name, args in (('followed', []), ('fixed', ['--fixed-scale'])):
        out = tmp_path / name
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(['track', str(tmp_path / 'seq' / 'bag'), '--out', str(out), '--init',
                         'ground-truth', *args]) == 0
        with BagReader(out) as bag:
            descriptions = [(stamp, msg.data) for _, _, stamp, msg in
                            bag.decoded(topics=[ROBOT_DESCRIPTION.absolute])]
            states = [hand_state_from_msg(m) for *_, m in bag.decoded(topics=[STATE_TOPIC])]
        runs[name] = descriptions, states
    descriptions, states = runs['followed']
    assert len(descriptions) > 1 and states[-1].shape.scale > 1.01
    for stamp, text in descriptions:
        state = next(s for s in states if s.stamp_ns == stamp)
        assert text == urdf_text(HandModel.build(state.shape), root_link='world')
    descriptions, states = runs['fixed']
    assert len(descriptions) == 1 and {s.shape.scale for s in states} == {1.0}
