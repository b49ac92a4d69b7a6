from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

import pytest
import yaml
from rosbags.highlevel import AnyReader

from hand_tracker_ros.bags.typestore import MSG_NAMES, find_msg_dir, msg_dir_candidates, typestore
from hand_tracker_ros.errors import BagFormatError

HAND_STATE = 'hand_tracker_msgs/msg/HandState'
# Pinned on purpose: a change means the wire type changed, so recorded bags and running nodes
# built from the old .msg files no longer match. Update it only together with the .msg edit.
HAND_STATE_RIHS01 = 'RIHS01_269f70e01c144d5ab45ba0d3ce2b810ae9a1ce1029676e6c8f764c111f1b6988'
# ROS 2's tf2_msgs/msg/TFMessage (the type real /tf publishers and listeners use).
TF_MESSAGE_RIHS01 = 'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087'


def test_typestore_is_cached_and_has_our_types():
    store = typestore()
    assert store is typestore()
    for name in MSG_NAMES:
        assert f'hand_tracker_msgs/msg/{name}' in store.fielddefs
    assert store.types[HAND_STATE].STATUS_LOST == 2
    assert store.types['hand_tracker_msgs/msg/SalientPoint'].LABEL_UNASSIGNED == -1


def test_hand_state_hash_is_pinned():
    assert typestore().hash_rihs01(HAND_STATE) == HAND_STATE_RIHS01


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_hash_stored_in_bag_matches_and_is_recomputed_from_stored_definition(make_bag, storage):
    path = make_bag(storage)
    meta = yaml.safe_load((path / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    stored = {t['topic_metadata']['type']: t['topic_metadata']['type_description_hash']
              for t in meta['topics_with_message_count']}
    for msgtype, digest in stored.items():
        assert digest == typestore().hash_rihs01(msgtype), msgtype
    # AnyReader rebuilds the types from the definitions stored in the bag, without ours.
    with AnyReader([path]) as reader:
        assert reader.typestore.hash_rihs01(HAND_STATE) == HAND_STATE_RIHS01


@pytest.mark.parametrize('msgtype', ['sensor_msgs/msg/Image', 'sensor_msgs/msg/CameraInfo',
                                     'sensor_msgs/msg/JointState'])
def test_standard_hashes_match_installed_kilted_json(msgtype):
    pkg, _, name = msgtype.split('/')
    path = Path(sys.prefix) / 'share' / pkg / 'msg' / f'{name}.json'
    if not path.is_file():
        pytest.skip(f'no installed {path}')
    hashes = {h['type_name']: h['hash_string']
              for h in json.loads(path.read_text())['type_hashes']}
    assert hashes[msgtype] == typestore().hash_rihs01(msgtype)


def test_hash_matches_built_hand_tracker_msgs():
    pytest.importorskip('hand_tracker_msgs')
    prefixes = [*os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep), sys.prefix]
    paths = [Path(p) / 'share' / 'hand_tracker_msgs' / 'msg' / 'HandState.json'
             for p in prefixes if p]
    path = next((p for p in paths if p.is_file()), None)
    if path is None:
        pytest.skip('hand_tracker_msgs is importable but its HandState.json is not found')
    hashes = {h['type_name']: h['hash_string']
              for h in json.loads(path.read_text())['type_hashes']}
    assert hashes[HAND_STATE] == HAND_STATE_RIHS01


def test_candidates_follow_ament_prefix_path(tmp_path):
    env = os.pathsep.join([str(tmp_path / 'a'), '', str(tmp_path / 'b')])
    dirs = msg_dir_candidates(tmp_path / 'repo', env)
    assert dirs[:3] == [tmp_path / 'repo/msg_defs/hand_tracker_msgs/msg',
                        tmp_path / 'a/share/hand_tracker_msgs/msg',
                        tmp_path / 'b/share/hand_tracker_msgs/msg']
    assert tmp_path / 'a/share/hand_tracker_ros/msg_defs/hand_tracker_msgs/msg' in dirs


def test_find_msg_dir_skips_incomplete_directories(tmp_path):
    source = find_msg_dir()
    partial, full = tmp_path / 'partial', tmp_path / 'full'
    partial.mkdir()
    shutil.copy(source / 'HandState.msg', partial)
    shutil.copytree(source, full)
    assert find_msg_dir([tmp_path / 'absent', partial, full]) == full


def test_find_msg_dir_error_lists_searched_dirs(tmp_path):
    with pytest.raises(BagFormatError, match=r'cannot find the hand_tracker_msgs .*absent'):
        find_msg_dir([tmp_path / 'absent'])


def test_our_tf2_msgs_definition_is_the_real_tfmessage():
    """msg_defs/tf2_msgs (built where PyPI has no tf2_msgs) has the hash of ROS 2's TFMessage,
    so real /tf listeners and bag tools take it."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    text = (Path(__file__).resolve().parents[2] / 'msg_defs' / 'tf2_msgs' / 'msg' /
            'TFMessage.msg').read_text()
    kilted = get_typestore(Stores.ROS2_KILTED)
    store = get_typestore(Stores.EMPTY)
    store.register({k: v for k, v in kilted.fielddefs.items() if not k.startswith('tf2_msgs/')})
    store.register(get_types_from_msg(text, 'tf2_msgs/msg/TFMessage'))
    assert store.hash_rihs01('tf2_msgs/msg/TFMessage') == TF_MESSAGE_RIHS01
    assert typestore().hash_rihs01('tf2_msgs/msg/TFMessage') == TF_MESSAGE_RIHS01
