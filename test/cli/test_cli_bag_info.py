"""`hand-tracker bag-info`: storage, counts, types, duration; clear error for a non-bag."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.bags import convert
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.cli.main import main

T0_NS = 1_700_000_000_000_000_007


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_bag_info_reports_topics_counts_and_duration(tmp_path: Path, storage: str,
                                                     capsys) -> None:
    with BagWriter(tmp_path / 'bag', storage=storage) as bag:
        bag.add_topic('/cam0/image_raw', 'sensor_msgs/msg/Image', qos='sensor_data')
        bag.add_topic('/hand/joint_states', 'sensor_msgs/msg/JointState')
        for i in range(5):
            stamp = T0_NS + i * 250_000_000
            bag.write('/cam0/image_raw', stamp,
                      convert.image_msg(np.zeros((2, 2, 3), np.uint8), stamp, 'cam0'))
            if i < 3:
                bag.write('/hand/joint_states', stamp,
                          convert.joint_state_msg(stamp, ('a',), np.zeros(1)))
    assert main(['bag-info', str(tmp_path / 'bag')]) == 0
    lines = capsys.readouterr().out.splitlines()
    fields = dict(line.split(':', 1) for line in lines if not line.startswith('  '))
    assert fields['storage'].strip() == storage
    assert fields['messages'].strip() == '8'
    assert fields['duration'].strip() == '1.000 s'
    assert fields['start'].strip() == '1700000000.000000007 s (bag time)'
    assert fields['topics'].strip() == '2'
    rows = {line.split()[0]: line.split()[1:] for line in lines if line.startswith('  ')}
    assert rows['/cam0/image_raw'] == ['sensor_msgs/msg/Image', '5', 'msgs', 'best', 'effort']
    assert rows['/hand/joint_states'] == ['sensor_msgs/msg/JointState', '3', 'msgs',
                                          'reliable']


def test_bag_info_of_a_missing_path_is_a_clear_error(tmp_path: Path, capsys) -> None:
    assert main(['bag-info', str(tmp_path / 'nope')]) == 2
    assert 'nope: bag not found' in capsys.readouterr().err
