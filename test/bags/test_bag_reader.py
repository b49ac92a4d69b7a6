from __future__ import annotations

import logging
import sqlite3

import numpy as np
import pytest
import yaml

from hand_tracker_ros.bags import convert
from hand_tracker_ros.bags.image_codec import image_from_msg
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.errors import BagFormatError

STORAGES = ['mcap', 'sqlite3']


def _check_frame(samples, i, decoded):
    """Compare the decoded messages of frame ``i`` (topic -> msg) with the written values."""
    stamp = samples.T0_NS + i * samples.PERIOD_NS
    image = decoded['/cam0/image_raw']
    np.testing.assert_array_equal(image_from_msg(image, source='/cam0/image_raw'),
                                  samples.image(i))
    assert convert.stamp_ns_of(image.header) == stamp
    info = convert.camera_info_from_msg(decoded['/cam0/camera_info'])
    np.testing.assert_array_equal(info.K, samples.camera_info(stamp).K)
    np.testing.assert_array_equal(info.D, samples.camera_info(stamp).D)
    _, names, positions = convert.joint_state_from_msg(decoded['/hand/joint_states'])
    assert names == samples.joints(i)[0]
    np.testing.assert_array_equal(positions, samples.joints(i)[1])
    state = convert.hand_state_from_msg(decoded['/hand/state'])
    np.testing.assert_array_equal(state.keypoints_m, samples.hand_state(stamp, i).keypoints_m)
    assert state.iterations == 7 + i and state.keypoint_names[20] == 'kp20'
    points = convert.salient_points_from_msg(decoded['/cam0/salient_points'])
    np.testing.assert_array_equal(points.uv_px, samples.salient(stamp, i).uv_px)
    np.testing.assert_array_equal(points.label, [-1, 1, 4])


@pytest.mark.parametrize('storage', STORAGES)
def test_round_trip_through_bag_reader(make_bag, samples, storage):
    path = make_bag(storage)
    with BagReader(path) as bag:
        topics = bag.topics
        rows = list(bag.decoded())
        assert bag.start_ns == samples.T0_NS
    assert {t: (s.msgtype, s.count) for t, s in topics.items()} == {
        t: (msgtype, samples.N_FRAMES) for t, (msgtype, _) in samples.TOPICS.items()}
    assert topics['/cam0/image_raw'].best_effort and not topics['/hand/state'].best_effort
    stamps = [stamp for _, _, stamp, _ in rows]
    assert stamps == sorted(stamps) and len(rows) == samples.N_FRAMES * len(samples.TOPICS)
    for i in range(samples.N_FRAMES):
        frame = {t: m for t, _, s, m in rows if s == samples.T0_NS + i * samples.PERIOD_NS}
        _check_frame(samples, i, frame)


@pytest.mark.parametrize('storage', STORAGES)
def test_topic_and_time_filters(make_bag, samples, storage):
    path = make_bag(storage)
    start = samples.T0_NS + samples.PERIOD_NS
    with BagReader(path) as bag:
        rows = list(bag.messages(topics=['/hand/state'], start_ns=start))
    assert [(t, s) for t, _, s, _ in rows] == [
        ('/hand/state', start + k * samples.PERIOD_NS) for k in range(samples.N_FRAMES - 1)]
    assert all(isinstance(raw, bytes) for *_, raw in rows)


def test_independent_mcap_reader_decodes_every_type(make_bag, samples):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    path = make_bag('mcap')
    with (path / f'{path.name}.mcap').open('rb') as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        rows = [(channel.topic, msg.log_time, ros)
                for _, channel, msg, ros in reader.iter_decoded_messages()]
    assert len(rows) == samples.N_FRAMES * len(samples.TOPICS)
    for i in range(samples.N_FRAMES):
        frame = {t: m for t, s, m in rows if s == samples.T0_NS + i * samples.PERIOD_NS}
        image = frame['/cam0/image_raw']
        pixels = np.frombuffer(image.data, np.uint8).reshape(image.height, image.width, 3)
        np.testing.assert_array_equal(pixels, samples.image(i))
        _check_frame(samples, i, {**frame, '/cam0/image_raw': image})


@pytest.mark.parametrize('storage', STORAGES)
def test_empty_topic_filter_yields_nothing(make_bag, storage):
    with BagReader(make_bag(storage)) as bag:
        assert list(bag.messages(topics=[])) == []
        assert list(bag.decoded(topics=[])) == []


def test_unknown_topic_filter_lists_the_bag_topics(make_bag):
    with BagReader(make_bag('mcap')) as bag, pytest.raises(
            BagFormatError, match=r'topics not in the bag: /nope .*/hand/state'):
        list(bag.messages(topics=['/nope']))


def test_missing_path(tmp_path):
    with pytest.raises(BagFormatError, match='bag not found'):
        BagReader(tmp_path / 'absent').__enter__()


def test_directory_without_metadata_is_not_a_bag(tmp_path):
    (tmp_path / 'notes.txt').write_text('hello')
    with pytest.raises(BagFormatError, match='no metadata.yaml'):
        BagReader(tmp_path).__enter__()


def test_other_file_is_not_a_bag(tmp_path):
    path = tmp_path / 'data.bin'
    path.write_bytes(b'123')
    with pytest.raises(BagFormatError, match=r'data.bin: not a rosbag2 bag'):
        BagReader(path).__enter__()


@pytest.mark.parametrize('bare_file', [False, True])
def test_truncated_mcap_is_refused_with_its_name(make_bag, bare_file):
    path = make_bag('mcap')
    mcap = path / f'{path.name}.mcap'
    data = mcap.read_bytes()
    mcap.write_bytes(data[:len(data) * 2 // 3])
    target = mcap if bare_file else path
    with pytest.raises(BagFormatError, match=r'bag_mcap.mcap is truncated'):
        BagReader(target).__enter__()


def test_corrupt_sqlite3_is_refused(make_bag):
    path = make_bag('sqlite3')
    db = path / f'{path.name}.db3'
    data = bytearray(db.read_bytes())
    data[100:4000] = np.random.default_rng(0).integers(0, 256, 3900, np.uint8).tobytes()
    db.write_bytes(bytes(data))
    with pytest.raises(BagFormatError, match=r'bag_sqlite3: cannot open bag.*malformed'):
        BagReader(path).__enter__()


def test_metadata_listing_a_missing_file_is_refused(make_bag):
    path = make_bag('mcap')
    (path / f'{path.name}.mcap').unlink()
    with pytest.raises(BagFormatError, match=r'bag_mcap: cannot open bag.*missing'):
        BagReader(path).__enter__()


def _rename_type(path, old, new):
    """Give ``old`` the unknown name ``new`` in a sqlite3 bag and drop stored definitions."""
    with sqlite3.connect(path / f'{path.name}.db3') as db:
        db.execute('UPDATE topics SET type = ?, type_description_hash = ? WHERE type = ?',
                   (new, '', old))
        db.execute('DELETE FROM message_definitions')
    meta_path = path / 'metadata.yaml'
    meta = yaml.safe_load(meta_path.read_text())
    for topic in meta['rosbag2_bagfile_information']['topics_with_message_count']:
        if topic['topic_metadata']['type'] == old:
            topic['topic_metadata'].update(type=new, type_description_hash='')
    meta_path.write_text(yaml.safe_dump(meta))


def test_unknown_message_type_is_named(make_bag):
    path = make_bag('sqlite3')
    _rename_type(path, 'sensor_msgs/msg/JointState', 'foo_msgs/msg/Unknown')
    with BagReader(path) as bag:
        assert bag.topics['/hand/joint_states'].msgtype == 'foo_msgs/msg/Unknown'
        assert len(list(bag.messages(topics=['/hand/joint_states']))) == 3
        with pytest.raises(BagFormatError,
                           match=r"unknown message type 'foo_msgs/msg/Unknown'.*joint_states"):
            list(bag.decoded(topics=['/hand/joint_states']))


def test_reading_a_closed_reader_is_an_error(make_bag):
    bag = BagReader(make_bag('mcap'))
    with pytest.raises(BagFormatError, match='not open'):
        _ = bag.topics


def test_writer_refuses_existing_path(tmp_path):
    with pytest.raises(BagFormatError, match='refusing to overwrite'):
        BagWriter(tmp_path)


def test_writer_refuses_unknown_type_and_unadded_topic(tmp_path):
    with BagWriter(tmp_path / 'b') as bag:
        with pytest.raises(BagFormatError, match=r"unknown message type 'foo/msg/Bar'"):
            bag.add_topic('/x', 'foo/msg/Bar')
        with pytest.raises(BagFormatError, match=r"topic '/y' was not added"):
            bag.write('/y', 1, None)
        bag.add_topic('/j', 'sensor_msgs/msg/JointState')
        with pytest.raises(BagFormatError, match='already added'):
            bag.add_topic('/j', 'sensor_msgs/msg/JointState')


def test_writer_refuses_wrong_message_object(tmp_path):
    with BagWriter(tmp_path / 'b') as bag:
        bag.add_topic('/j', 'sensor_msgs/msg/JointState')
        image = convert.image_msg(np.zeros((1, 1, 3), np.uint8), 1, 'c')
        with pytest.raises(BagFormatError, match=r"cannot serialize .*JointState on '/j'"):
            bag.write('/j', 1, image)


def test_write_raw_round_trips_bytes(tmp_path, samples):
    msg = samples.frame_messages(0)['/hand/joint_states']
    from hand_tracker_ros.bags.typestore import typestore
    raw = bytes(typestore().serialize_cdr(msg, 'sensor_msgs/msg/JointState'))
    with BagWriter(tmp_path / 'b', storage='sqlite3') as bag:
        bag.add_topic('/j', 'sensor_msgs/msg/JointState')
        bag.write_raw('/j', 5, raw)
    with BagReader(tmp_path / 'b') as bag:
        assert list(bag.messages()) == [('/j', 'sensor_msgs/msg/JointState', 5, raw)]



def test_damage_inside_a_chunk_raises_while_iterating(make_bag, samples):
    path = make_bag('mcap')
    mcap = path / f'{path.name}.mcap'
    data = bytearray(mcap.read_bytes())
    # mcap Message record: opcode 0x05, u64 length, u16 channel, u32 sequence, u64 log time,
    # u64 publish time, payload. Give the last frame's first record an absurd length.
    stamp = (samples.T0_NS + 2 * samples.PERIOD_NS).to_bytes(8, 'little')
    start = data.index(stamp + stamp) - 1 - 8 - 2 - 4
    assert data[start] == 0x05
    data[start + 1:start + 9] = (2**62).to_bytes(8, 'little')
    mcap.write_bytes(bytes(data))
    with BagReader(path) as bag, pytest.raises(BagFormatError, match='damaged after'):
        list(bag.messages())


def test_intact_messages_stop_at_the_damage_with_a_warning(make_bag, samples, caplog):
    path = make_bag('mcap')
    mcap = path / f'{path.name}.mcap'
    data = bytearray(mcap.read_bytes())
    stamp = (samples.T0_NS + 2 * samples.PERIOD_NS).to_bytes(8, 'little')
    start = data.index(stamp + stamp) - 1 - 8 - 2 - 4   # as in the test above
    data[start + 1:start + 9] = (2**62).to_bytes(8, 'little')
    mcap.write_bytes(bytes(data))
    with caplog.at_level(logging.WARNING), BagReader(path) as bag:
        stamps = [stamp_ns for _, _, stamp_ns, _ in bag.intact_messages()]
    assert max(stamps, default=samples.T0_NS) < samples.T0_NS + 2 * samples.PERIOD_NS
    assert 'damaged after the messages read so far' in caplog.text
    assert 'using the messages before the damage' in caplog.text
