from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.vision.resolution import to_working, working_camera


def test_a_wider_camera_is_scaled_and_projects_where_the_resized_image_shows_the_point():
    camera = CameraRig.ring(4, 640, 480).cameras[1]
    small = working_camera(camera, 320)
    assert (small.width, small.height) == (320, 240)
    points = np.random.default_rng(3).normal([0.0, 0.0, 0.0], 0.05, (50, 3))
    uv, depth = camera.project(points)
    uv_small, depth_small = small.project(points)
    # Pixel edges stay fixed: u' + 0.5 = (u + 0.5) / 2.
    np.testing.assert_allclose(uv_small + 0.5, (uv + 0.5) / 2.0, atol=1e-9)
    np.testing.assert_allclose(depth_small, depth)


def test_a_camera_at_or_below_the_working_width_or_a_zero_width_is_kept():
    camera = CameraRig.ring(4, 320, 240).cameras[0]
    assert working_camera(camera, 320) is camera
    assert working_camera(camera, 640) is camera
    assert working_camera(CameraRig.ring(4, 640, 480).cameras[0], 0).width == 640


def test_images_are_area_resized_to_the_working_camera_or_kept():
    native = CameraRig.ring(4, 640, 480).cameras[0]
    small = working_camera(native, 320)
    image = np.zeros((480, 640, 3), np.uint8)
    image[100:102, 200:202] = 255           # a 2x2 block becomes one full pixel
    resized = to_working(image, small)
    assert resized.shape == (240, 320, 3)
    assert resized[50, 100].tolist() == [255, 255, 255]
    assert resized.sum() == 255 * 3
    assert to_working(resized, small) is resized
    with pytest.raises(ShapeError, match='cannot be scaled down'):
        to_working(np.zeros((100, 100, 3), np.uint8), small)


def test_a_node_without_the_rig_scales_images_to_the_size_of_the_working_camera():
    from hand_tracker_ros.vision.resolution import to_width

    for width, height in ((640, 480), (1280, 720), (330, 250), (320, 240), (200, 150)):
        camera = CameraRig.ring(4, width, height).cameras[0]
        image = np.random.default_rng(width).integers(0, 256, (height, width, 3), np.uint8)
        scaled = to_width(image, 320)
        expected = working_camera(camera, 320)
        assert scaled.shape == (expected.height, expected.width, 3)
        np.testing.assert_array_equal(scaled, to_working(image, expected))
    image = np.zeros((480, 640), np.uint8)
    assert to_width(image, 0) is image
