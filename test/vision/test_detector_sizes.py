"""The hand-size classes of the detector's training crops (augment.py, step 7)."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.vision.detector.augment import AugmentationConfig, hand_size_px, size_labels

# training.py imports PyTorch only inside train(): these run without it.
from hand_tracker_ros.vision.detector.training import TrainingConfig, augment


def test_hand_size_is_the_longer_side_of_the_mask_box():
    mask = np.zeros((40, 60), bool)
    assert hand_size_px(mask) == 0.0
    mask[5:15, 20:45] = True
    assert hand_size_px(mask) == 25.0


def test_small_hands_are_negatives_and_mid_sized_ones_ignored():
    uv = np.tile(np.arange(10.0).reshape(1, 5, 2), (3, 1, 1))
    visible = np.array([[True, True, False, True, True]] * 3)
    hand_px = np.array([30.0, 50.0, 80.0])
    out_uv, out_visible = size_labels(uv, visible, hand_px, (40.0, 55.0))
    assert np.isnan(out_uv[0]).all() and not out_visible[0].any()     # negatives
    np.testing.assert_array_equal(out_uv[1], uv[1])                    # kept, so ignored
    assert not out_visible[1].any()
    np.testing.assert_array_equal(out_uv[2], uv[2])
    np.testing.assert_array_equal(out_visible[2], visible[2])          # positives
    same_uv, same_visible = size_labels(uv, visible, hand_px, (0.0, 0.0))
    np.testing.assert_array_equal(same_uv, uv)
    np.testing.assert_array_equal(same_visible, visible)


def test_augmented_crops_report_the_hand_size_at_their_scale():
    rng = np.random.default_rng(5)
    images = np.full((4, 60, 80, 3), 90, np.uint8)
    masks = np.zeros((4, 60, 80), bool)
    masks[:, 20:32, 30:50] = True                     # a 20 px wide "hand"
    uv = np.tile(np.array([[35.0, 22.0]] * 5), (4, 1, 1))
    for scale in (0.5, 2.0):
        aug = AugmentationConfig(scale_range=(scale, scale), skin_probability=0.0,
                                 plain_background_probability=0.0, photometric=False)
        cfg = TrainingConfig(crop_height=40, crop_width=48, augmentation=aug)
        _, _, hand_px = augment(images, masks, uv, cfg, rng)
        np.testing.assert_allclose(hand_px, 20.0 * scale)
