"""The `recorder` node loses no message published to it, closes a readable bag on SIGINT, and a
player -> recorder round trip of a synthetic bag keeps every message."""
from __future__ import annotations

import argparse

import numpy as np
import pytest

from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.cli import record
from hand_tracker_ros.errors import BagFormatError
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.synthetic.writer import write_sequence

pytestmark = pytest.mark.ros
N_MESSAGES = 300


def test_recorder_keeps_every_message_of_two_reliable_topics(node_process, ros, tmp_path):
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    node, spin_until = ros
    out = tmp_path / 'recorded'
    recorder = node_process('recorder', '-p', f'output:={out}',
                            '-p', 'topics:=[/rec/text,rec/joints]')
    # Keep-all-deep publisher queues: the publisher must not be the one dropping messages.
    text = node.create_publisher(String, '/rec/text', QoSProfile(depth=N_MESSAGES))
    joints = node.create_publisher(JointState, '/rec/joints', QoSProfile(depth=N_MESSAGES))
    assert spin_until(lambda: text.get_subscription_count() and
                      joints.get_subscription_count(), 30.0), recorder.output()
    for i in range(N_MESSAGES):
        text.publish(String(data=f'message {i}'))
        msg = JointState(name=['a', 'b'], position=[float(i), -0.5 * i])
        msg.header.stamp.sec = i
        joints.publish(msg)
    assert text.wait_for_all_acked() and joints.wait_for_all_acked()
    assert recorder.stop() == 0, recorder.output()
    with BagReader(out) as bag:
        assert {t: s.count for t, s in bag.topics.items()} == {
            '/rec/text': N_MESSAGES, '/rec/joints': N_MESSAGES}, recorder.output()
        assert not any(s.best_effort for s in bag.topics.values())
        texts = [m.data for _, _, _, m in bag.decoded(['/rec/text'])]
        states = [m for _, _, _, m in bag.decoded(['/rec/joints'])]
        stamps = [s for _, _, s, _ in bag.messages()]
    assert texts == [f'message {i}' for i in range(N_MESSAGES)]
    assert [m.header.stamp.sec for m in states] == list(range(N_MESSAGES))
    assert all(m.name == ['a', 'b'] for m in states)
    np.testing.assert_array_equal(np.array([m.position for m in states]),
                                  np.stack([np.arange(N_MESSAGES), -0.5 * np.arange(N_MESSAGES)],
                                           axis=1))
    assert stamps == sorted(stamps) and stamps[0] > 1_600_000_000 * 10**9  # receive times
    assert 'closed' in recorder.output()


def test_player_to_recorder_round_trip_keeps_the_counts(node_process, tmp_path, hand_model):
    config = SynthConfig(n_frames=8, n_cameras=2, fps=30.0, width=96, height=72, clutter=2)
    bag = write_sequence(SyntheticSequence(config, hand_model), tmp_path / 'synth',
                         storage='sqlite3')
    with BagReader(bag) as reader:
        counts = {t: s.count for t, s in reader.topics.items()}
        best_effort = {t for t, s in reader.topics.items() if s.best_effort}
    out = tmp_path / 'recorded'
    topics = ','.join(sorted(counts))
    recorder = node_process('recorder', '-p', f'output:={out}', '-p', f'topics:=[{topics}]')
    player = node_process('player', '-p', f'bag:={bag}', '-p', 'wait_for_subscribers_s:=30.0')
    assert player.proc.wait(timeout=60) == 0, player.output()
    assert recorder.stop() == 0, recorder.output()
    with BagReader(out) as recorded:
        assert {t: s.count for t, s in recorded.topics.items()} == counts
        assert {t for t, s in recorded.topics.items() if s.best_effort} == best_effort
        images = [m for _, _, _, m in recorded.decoded(['/cam0/image_raw'])]
    with BagReader(bag) as reader:
        originals = [m for _, _, _, m in reader.decoded(['/cam0/image_raw'])]
    for got, want in zip(images, originals, strict=True):
        np.testing.assert_array_equal(got.data, want.data)


def test_recorder_refuses_an_existing_output(tmp_path):
    parser = argparse.ArgumentParser()
    record.add_parser(parser.add_subparsers())
    args = parser.parse_args(['record', str(tmp_path), '--topics', '/a', '/b'])
    assert record.overrides(args) == {'output': str(tmp_path), 'all_topics': False,
                                      'exclude_regex': '', 'storage': 'mcap',
                                      'queue_depth': 1000, 'topics': ('/a', '/b')}
    with pytest.raises(BagFormatError, match='refusing to overwrite'):
        record.run(args)
