from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.checks import check_rgb
from hand_tracker_ros.errors import ImageFormatError
from hand_tracker_ros.vision.image import clip_roi, to_gray


def _rgb(rng: np.random.Generator, h: int = 5, w: int = 7) -> np.ndarray:
    return rng.integers(0, 256, (h, w, 3), dtype=np.uint8)


def test_check_rgb_and_to_gray(rng):
    rgb = _rgb(rng)
    check_rgb('cam0', rgb, size_px=(7, 5))
    with pytest.raises(ImageFormatError, match=r'cam0: expected an \(H, W, 3\) uint8 RGB'):
        check_rgb('cam0', rgb.astype(np.float32))
    with pytest.raises(ImageFormatError, match=r'cam0: image is 7x5 but camera_info says 8x5'):
        check_rgb('cam0', rgb, size_px=(8, 5))
    gray = to_gray(rgb)
    expected = rgb.astype(np.float64) @ np.array([0.299, 0.587, 0.114])
    assert gray.shape == (5, 7)
    assert np.max(np.abs(gray - expected)) <= 1.0


def test_clip_roi():
    assert clip_roi('cam0', None, 320, 240) == (0, 0, 320, 240)
    assert clip_roi('cam0', (-10, 5, 100, 300), 320, 240) == (0, 5, 100, 240)
    with pytest.raises(ImageFormatError, match=r'cam0: roi_px must be \(u0, v0, u1, v1\)'):
        clip_roi('cam0', (1, 2, 3), 320, 240)
    with pytest.raises(ImageFormatError, match=r'roi_px \(5, 5, 5, 9\) does not overlap'):
        clip_roi('cam0', (5, 5, 5, 9), 320, 240)
