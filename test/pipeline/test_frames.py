"""Which bag topic holds each camera's images (pipeline/frames.py)."""
from __future__ import annotations

import pytest

from hand_tracker_ros.errors import CalibrationError
from hand_tracker_ros.pipeline.frames import camera_image_topics


def test_each_camera_gets_its_raw_or_else_its_compressed_topic() -> None:
    topics = {'/cam0/image_raw', '/cam0/image_raw/compressed', '/cam1/image_raw/compressed',
              '/cam0/camera_info'}
    assert camera_image_topics(topics, ['cam0', 'cam1'], 'bag') == {
        '/cam0/image_raw': 'cam0', '/cam1/image_raw/compressed': 'cam1'}


def test_a_camera_without_images_is_a_clear_error() -> None:
    with pytest.raises(CalibrationError, match=r"bag: no image topic for camera\(s\) \['cam1'\] "
                       r"\(looked for /cam1/image_raw and /cam1/image_raw/compressed\)"):
        camera_image_topics({'/cam0/image_raw', '/cam1/camera_info'}, ['cam0', 'cam1'], 'bag')
