"""The fine texture of the detector's training views (augment.py, step 3)."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.vision.detector.augment import fine_texture, textured


def test_fine_texture_is_standardised_and_varies_over_a_few_pixels():
    rng = np.random.default_rng(11)
    for _ in range(20):
        texture = fine_texture((120, 160), rng)
        assert texture.shape == (120, 160) and texture.dtype == np.float32
        assert abs(float(texture.mean())) < 1e-4 and abs(float(texture.std()) - 1.0) < 1e-4
        # Grain of 1-6 px (12 px for the coarser octave): neighbours 16 px apart are
        # nearly independent along at least one axis, 1 px apart they are not.
        near = min(np.corrcoef(texture[:, :-1].ravel(), texture[:, 1:].ravel())[0, 1],
                   np.corrcoef(texture[:-1].ravel(), texture[1:].ravel())[0, 1])
        far = min(np.corrcoef(texture[:, :-16].ravel(), texture[:, 16:].ravel())[0, 1],
                  np.corrcoef(texture[:-16].ravel(), texture[16:].ravel())[0, 1])
        assert far < 0.35 and near > far


def test_texture_is_added_to_the_background_and_weakly_multiplies_the_skin():
    rng = np.random.default_rng(12)
    image = np.full((60, 80, 3), 120, np.uint8)
    image[..., 2] = 100
    mask = np.zeros((60, 80), bool)
    mask[20:40, 30:50] = True
    for _ in range(20):
        out = textured(image, mask, rng).astype(np.float64)
        change = out - image
        # The background: one gray-level texture (the same in every channel), 5-35 levels.
        unclipped = ~mask & (out > 0).all(axis=2) & (out < 255).all(axis=2)
        np.testing.assert_allclose(change[unclipped][:, 0], change[unclipped][:, 2], atol=1.0)
        assert 4.0 < np.median(np.abs(change[~mask][:, 0])) / 0.6745 < 70.0
        # The skin: a relative change of at most 8 % of a unit texture, so per channel alike.
        ratio = out[mask] / image[mask]
        assert np.abs(ratio[:, 0] - ratio[:, 2]).max() < 0.02
        assert np.std(ratio[:, 0]) < 0.09
