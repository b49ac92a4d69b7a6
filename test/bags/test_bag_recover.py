"""A truncated mcap bag: its intact records are recovered, with a warning."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from hand_tracker_ros.bags import convert
from hand_tracker_ros.bags.reader import BagReader
from hand_tracker_ros.bags.recover import readable_bag
from hand_tracker_ros.bags.writer import BagWriter
from hand_tracker_ros.errors import BagFormatError

N_FRAMES = 12


def _large_bag(path: Path) -> Path:
    """12 frames of 320x240 noise: about 2.8 MB, several mcap chunks."""
    rng = np.random.default_rng(0)
    with BagWriter(path, storage='mcap') as bag:
        bag.add_topic('/cam0/image_raw', 'sensor_msgs/msg/Image', qos='sensor_data')
        for i in range(N_FRAMES):
            rgb = rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
            bag.write('/cam0/image_raw', 1000 + i, convert.image_msg(rgb, 1000 + i, 'cam0'))
    return path


def _messages(path: Path) -> list[tuple]:
    with BagReader(path) as bag:
        return list(bag.messages())


def _truncate(path: Path, fraction: float) -> None:
    [mcap] = path.glob('*.mcap')
    data = mcap.read_bytes()
    mcap.write_bytes(data[:int(len(data) * fraction)])


def test_intact_bag_is_read_in_place(tmp_path):
    bag = _large_bag(tmp_path / 'bag')
    with readable_bag(bag) as readable:
        assert readable == bag


@pytest.mark.parametrize('bare_file', [False, True])
def test_truncated_bag_gives_its_intact_prefix(tmp_path, caplog, bare_file):
    bag = _large_bag(tmp_path / 'bag')
    original = _messages(bag)
    _truncate(bag, 0.7)
    target = next(bag.glob('*.mcap')) if bare_file else bag
    with caplog.at_level(logging.WARNING), readable_bag(target) as readable:
        recovered = _messages(readable)
    assert 0 < len(recovered) < N_FRAMES
    assert recovered == original[:len(recovered)]
    assert 'bag.mcap is truncated' in caplog.text
    assert f'using the {len(recovered)} messages before the damage' in caplog.text
    assert not readable.exists()   # the temporary copy is removed


def test_truncated_before_the_first_chunk_is_an_error(tmp_path):
    bag = _large_bag(tmp_path / 'bag')
    _truncate(bag, 0.1)
    with pytest.raises(BagFormatError, match='truncated before its first complete chunk'), \
            readable_bag(bag):
        pass


def test_missing_path_is_named(tmp_path):
    with pytest.raises(BagFormatError, match='nothing: bag not found'), \
            readable_bag(tmp_path / 'nothing'):
        pass
