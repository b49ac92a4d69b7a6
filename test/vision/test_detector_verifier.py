from __future__ import annotations

import cv2
import numpy as np

from hand_tracker_ros.vision.detector.channels import SKIN_CHANNEL
from hand_tracker_ros.vision.detector.shape import N_SHAPE, shape_features
from hand_tracker_ros.vision.detector.verifier import N_ANGLES, N_CONTEXT, N_FEATURES, \
    RING_RADII_PX, context_features, peak_features

_RING = 10  # features per ring radius, after the 3 peak features


def _finger(angle_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Channels and gate mask of one skin bar (a finger 10 px wide) ending at (100, 100)."""
    skin = np.zeros((200, 200), np.uint8)
    d = np.array([np.cos(np.deg2rad(angle_deg)), np.sin(np.deg2rad(angle_deg))])
    end = np.array([100.0, 100.0])
    cv2.line(skin, tuple(int(c) for c in np.rint(end)),
             tuple(int(c) for c in np.rint(end - 90.0 * d)), 255, thickness=10)
    cv2.circle(skin, (100, 100), 5, 255, -1)
    channels = np.zeros((4, 200, 200), np.uint8)
    channels[0] = skin // 2 + 60
    channels[SKIN_CHANNEL] = skin
    return channels, skin > 127, d


def _ring(features: np.ndarray, r: int) -> np.ndarray:
    start = 3 + _RING * RING_RADII_PX.index(r)
    return features[:, start:start + _RING]


def test_feature_layout():
    channels, mask, _ = _finger(0.0)
    uv = np.array([[100.0, 100.0], [60.0, 100.0]])
    features = peak_features(uv, np.array([2.0, 1.0]), channels, mask, vote_norm=4.0)
    assert features.shape == (2, N_FEATURES) and features.dtype == np.float32
    np.testing.assert_allclose(features[:, :3], [[0.5, 1.0, 0.0], [0.25, 0.5, 1.0]])


def test_ring_profile_tells_a_tip_from_the_middle_of_a_finger():
    channels, mask, d = _finger(30.0)
    tip = np.array([100.0, 100.0])
    uv = np.stack([tip, tip - 40.0 * d])
    ring = _ring(peak_features(uv, np.ones(2), channels, mask, 1.0), 9)
    # mask transitions: the ring crosses the finger once at the tip, twice in the middle.
    assert ring[0, 7] == 2 and ring[1, 7] == 4
    # first mask harmonic: one skin arc (tip) is lopsided, two opposite arcs cancel.
    assert ring[0, 5] > 2.0 * ring[1, 5]


def test_ring_features_do_not_depend_on_finger_direction():
    rings = []
    for angle in (0.0, 90.0, 180.0, 270.0):
        channels, mask, _ = _finger(angle)
        rings.append(peak_features(np.array([[100.0, 100.0]]), np.ones(1), channels, mask,
                                   1.0)[0, 3:])
    # Quarter turns map the 16-angle ring samples onto themselves exactly.
    assert N_ANGLES % 4 == 0
    for ring in rings[1:]:
        np.testing.assert_allclose(ring, rings[0], atol=0.02)


def test_shape_features_measure_the_finger_width():
    channels, mask, d = _finger(30.0)
    tip = np.array([100.0, 100.0])
    uv = np.stack([tip, tip - 40.0 * d, tip + 30.0 * d])       # tip, mid-finger, background
    shape = shape_features(uv, channels, mask)
    assert shape.shape == (3, N_SHAPE) and shape.dtype == np.float32
    np.testing.assert_array_equal(shape, peak_features(uv, np.ones(3), channels, mask,
                                                       1.0)[:, N_FEATURES - N_SHAPE:])
    d_in, d_out, widest = shape[:, 0], shape[:, 1], shape[:, 2:5]
    assert d_in[1] >= 4.0 and d_out[1] == 0.0                   # inside a 10 px finger
    assert d_in[2] == 0.0 and d_out[2] >= 20.0                   # far outside it
    # the finger is ~10 px wide: its half-width bounds d_in anywhere near it.
    assert np.all(widest[:2] <= 7.0) and np.all(widest[:2] >= 4.0)


def test_no_peaks_give_an_empty_matrix():
    channels, mask, _ = _finger(0.0)
    features = peak_features(np.zeros((0, 2)), np.zeros(0), channels, mask, 1.0)
    assert features.shape == (0, N_FEATURES)


def test_context_features():
    uv = np.array([[0.0, 0.0], [6.0, 8.0], [100.0, 0.0]])
    score = np.array([0.5, 0.9, 0.2])
    context = context_features(uv, score)
    assert context.shape == (3, N_CONTEXT) and context.dtype == np.float32
    np.testing.assert_allclose(context[:, 0], score, rtol=1e-6)
    np.testing.assert_array_equal(context[:, 1], [1, 0, 2])                       # rank
    np.testing.assert_allclose(context[:, 2], score / 0.9, rtol=1e-6)
    np.testing.assert_allclose(context[:, 3], 1.6, rtol=1e-6)                    # top-5 sum
    np.testing.assert_allclose(context[:, 4], [10.0, 99.0, np.hypot(94.0, 8.0)], rtol=1e-6)
    # within 10 px: the first two see each other, the third is alone (no higher score).
    np.testing.assert_allclose(context[:, 5], [0.9, 0.5, 0.0], rtol=1e-6)
    np.testing.assert_array_equal(context[:, 6], [1, 1, 0])


def test_context_of_no_peaks_is_empty():
    assert context_features(np.zeros((0, 2)), np.zeros(0)).shape == (0, N_CONTEXT)
