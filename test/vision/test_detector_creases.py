"""Skin creases of the detector's training renders."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.model.layout import P
from hand_tracker_ros.vision.detector.creases import crease_weights
from hand_tracker_ros.vision.detector.data import scene_views


@pytest.fixture(scope='module')
def weights(hand_model):
    return crease_weights(hand_model)


def test_creases_lie_across_every_finger_on_its_palmar_side(hand_model, weights):
    assert weights.shape == (len(hand_model.rest_vertices_m),)
    assert np.all((weights >= 0.0) & (weights <= 1.0))
    creased = weights > 0.5
    for i in range(5):
        bones = [1 + 3 * i, 2 + 3 * i, 3 + 3 * i]
        assert np.any(creased & np.isin(hand_model.vertex_part, bones))
    assert not np.any(creased[hand_model.fingertip_vertex_ids])
    assert creased.mean() < 0.1
    # The palm faces +z in the rest pose (flexing a finger moves its tip towards +z): the
    # creases of the four fingers face +z, and none of their vertices facing -z (the back)
    # has one.
    normals = hand_model.pose(np.zeros(P), jacobian=False).vertex_normals
    fingers = hand_model.vertex_part >= 4
    assert np.all(normals[creased & fingers, 2] > 0.0)
    assert np.all(weights[fingers & (normals[:, 2] < -0.3)] == 0.0)


def test_crease_depth_darkens_only_the_hand(hand_model):
    plain = scene_views(hand_model, 3, 0, cameras_per_scene=2)
    creased = scene_views(hand_model, 3, 0, cameras_per_scene=2, crease_depth=(0.4, 0.5))
    for a, b in zip(plain, creased):
        np.testing.assert_array_equal(a.tips_uv, b.tips_uv)
        np.testing.assert_array_equal(a.hand_mask, b.hand_mask)
        np.testing.assert_array_equal(a.image[~a.hand_mask], b.image[~b.hand_mask])
        hand = a.hand_mask
        diff = a.image[hand].astype(int) - b.image[hand].astype(int)
        assert np.all(diff.sum(axis=1) >= -6)          # never brighter (but the noise)
        assert np.any(diff.sum(axis=1) > 60) or not hand.any()
