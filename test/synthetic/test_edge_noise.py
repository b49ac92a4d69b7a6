"""Structured edge noise adds clutter with orientations and removes true edges."""
from __future__ import annotations

import cv2
import numpy as np

from hand_tracker_ros.synthetic.edge_noise import EdgeNoiseConfig, add_edge_noise

ON = EdgeNoiseConfig(enabled=True)


def _circle_edges() -> tuple[np.ndarray, np.ndarray]:
    img = np.zeros((240, 320), np.uint8)
    cv2.circle(img, (160, 120), 60, 1, 1)
    vv, uu = np.mgrid[:240, :320]
    return img > 0, (np.arctan2(vv - 120, uu - 160) % (2 * np.pi)).astype(np.float32)


def test_noise_adds_and_removes_and_is_deterministic() -> None:
    edges, angle = _circle_edges()
    noisy, noisy_angle = add_edge_noise(edges, angle, np.random.default_rng(4), ON)
    again, _ = add_edge_noise(edges, angle, np.random.default_rng(4), ON)
    np.testing.assert_array_equal(noisy, again)
    removed = edges & ~noisy
    added = noisy & ~edges
    assert 0.05 < removed.sum() / edges.sum() < 0.5
    assert added.sum() > 100
    # kept true edges keep their orientation
    np.testing.assert_array_equal(noisy_angle[edges & noisy], angle[edges & noisy])


def test_stroke_orientation_is_the_curve_normal() -> None:
    edges = np.zeros((200, 200), bool)
    angle = np.zeros((200, 200), np.float32)
    cfg = EdgeNoiseConfig(enabled=True, strokes_per_10k_px=3.0, blobs_per_10k_px=0.0,
                          gap_fraction=0.0)
    noisy, noisy_angle = add_edge_noise(edges, angle, np.random.default_rng(1), cfg)
    # Oracle: the structure tensor of the drawn strokes; its dominant direction is the normal.
    img = noisy.astype(np.float32)
    gy, gx = np.gradient(cv2.GaussianBlur(img, (0, 0), 1.0))
    jxx, jyy, jxy = (cv2.GaussianBlur(a, (0, 0), 2.0) for a in (gx * gx, gy * gy, gx * gy))
    normal = 0.5 * np.arctan2(2.0 * jxy, jxx - jyy)
    vv, uu = np.nonzero(noisy)
    cos = np.abs(np.cos(normal[vv, uu] - noisy_angle[vv, uu]))
    assert np.median(cos) > 0.8


def test_disabled_noise_is_identity() -> None:
    edges, angle = _circle_edges()
    out, out_angle = add_edge_noise(edges, angle, np.random.default_rng(0),
                                    EdgeNoiseConfig(enabled=False))
    assert out is edges and out_angle is angle
