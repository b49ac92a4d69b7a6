from __future__ import annotations

import cv2
import numpy as np
import pytest

from hand_tracker_ros.config import validate
from hand_tracker_ros.errors import ConfigError, ImageFormatError, ShapeError
from hand_tracker_ros.vision.mask import ForegroundMasker, MaskConfig, skin_lut


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sum(a & b) / np.sum(a | b))


def test_default_skin_model_segments_the_blob(scene):
    image, truth = scene()
    mask = ForegroundMasker(MaskConfig(method='skin')).compute(image)
    assert mask.dtype == bool and mask.shape == truth.shape
    assert _iou(mask, truth) > 0.9


def test_fitted_skin_model_finds_a_colour_the_default_misses(scene, rng):
    glove = (90, 170, 90)  # a green glove: chroma far from the default skin cluster
    image = scene.background.copy()
    cv2.circle(image, (50, 40), 20, glove, -1)
    truth = np.zeros(image.shape[:2], np.uint8)
    cv2.circle(truth, (50, 40), 20, 255, -1)
    masker = ForegroundMasker(MaskConfig(method='skin'))
    assert _iou(masker.compute(image), truth > 0) < 0.5
    samples = np.clip(np.array(glove) + rng.normal(0, 3, (200, 3)), 0, 255).astype(np.uint8)
    masker.fit_skin(samples)
    assert _iou(masker.compute(image), truth > 0) > 0.9


def test_background_difference_with_learning(scene):
    masker = ForegroundMasker(MaskConfig(method='background', learn_frames=3))
    for _ in range(3):
        assert not masker.compute(scene.background).any()  # learning: no foreground known
    np.testing.assert_array_equal(masker.background, scene.background)
    image, truth = scene((100, 70))
    assert _iou(masker.compute(image), truth) > 0.95
    masker.reset()
    assert masker.background is None


def test_background_set_explicitly_and_size_change(scene):
    masker = ForegroundMasker(MaskConfig(method='background', learn_frames=0))
    with pytest.raises(ConfigError, match='no background frame was set and learn_frames is 0'):
        masker.compute(scene.background)
    masker.set_background(scene.background)
    image, truth = scene()
    assert _iou(masker.compute(image), truth) > 0.95
    with pytest.raises(ConfigError, match='learn_frames is 0'):
        masker.compute(image[:60])  # a new size invalidates the background


def test_provided_mask(scene):
    image, truth = scene()
    masker = ForegroundMasker(MaskConfig(method='provided'))
    np.testing.assert_array_equal(masker.compute(image, truth.astype(np.uint8) * 7), truth)
    with pytest.raises(ImageFormatError, match='no mask image was given'):
        masker.compute(image)
    with pytest.raises(ImageFormatError, match=r'shape \(10, 10\) but the image is'):
        masker.compute(image, np.zeros((10, 10), bool))


def test_skin_model_errors():
    with pytest.raises(ConfigError, match='positive definite'):
        skin_lut(np.array([150.0, 110.0]), np.zeros((2, 2)), 2.0)
    with pytest.raises(ShapeError, match='at least 3 samples'):
        ForegroundMasker(MaskConfig()).fit_skin(np.zeros((2, 3), np.uint8))
    with pytest.raises(ConfigError, match=r'`method` must be one of'):
        validate(MaskConfig(method='magic'))
