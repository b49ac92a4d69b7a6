"""PinholeCamera implements the Camera protocol the core is typed against."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.geometry.rig import CameraRig


def test_pinhole_camera_is_a_camera() -> None:
    camera = PinholeCamera('cam0', 64, 48, np.array([[50.0, 0, 32], [0, 50.0, 24], [0, 0, 1]]),
                           np.zeros(5), np.eye(4))
    assert isinstance(camera, Camera)
    assert isinstance(camera.scaled(32, 24), Camera)


def test_rig_cameras_are_cameras() -> None:
    assert all(isinstance(camera, Camera) for camera in CameraRig.ring(2, 64, 48).cameras)
