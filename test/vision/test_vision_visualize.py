from __future__ import annotations

import numpy as np

from hand_tracker_ros.vision.edges import EdgeConfig, compute_edges
from hand_tracker_ros.vision.flow import DenseFlow, SparseFlow
from hand_tracker_ros.vision.visualize import (
    edge_image,
    flow_image,
    flow_to_rgb,
    mask_image,
    paste_roi,
)


def test_edge_and_mask_images():
    gray = np.zeros((20, 30), np.uint8)
    gray[:, 15:] = 255
    edges = compute_edges(gray, EdgeConfig())
    img = edge_image(edges)
    assert img.dtype == np.uint8 and set(np.unique(img)) == {0, 255}
    np.testing.assert_array_equal(img > 0, edges.edges)
    mask = np.eye(4, dtype=bool)
    np.testing.assert_array_equal(mask_image(mask), mask * 255)


def test_flow_image_dense_and_sparse():
    dense = np.zeros((4, 5, 2), np.float32)
    assert flow_image(DenseFlow(dense)) is dense
    prev = np.array([[1.2, 2.9]], np.float32)
    sparse = flow_image(SparseFlow((4, 5), prev, prev + [[0.5, -1.0]], 3.0))
    assert sparse.shape == (4, 5, 2) and sparse.dtype == np.float32
    np.testing.assert_allclose(sparse[3, 1], [0.5, -1.0])
    assert np.isnan(sparse).sum() == 2 * (4 * 5 - 1)
    # Tracks of a ROI flow are in full-image coordinates: drawn relative to its offset.
    roi = flow_image(SparseFlow((4, 5), prev + [[10.0, 20.0]], prev + [[10.5, 19.0]], 3.0,
                                offset_uv_px=(10, 20)))
    np.testing.assert_allclose(roi[3, 1], [0.5, -1.0])
    full = paste_roi(roi, (10, 20, 15, 24), (30, 40), fill=np.nan)
    assert full.shape == (40, 30, 2) and full.dtype == np.float32
    np.testing.assert_allclose(full[23, 11], [0.5, -1.0])
    assert np.isnan(full).sum() == 2 * (30 * 40 - 1)
    # A box that is the whole image needs no copy.
    assert paste_roi(full, (0, 0, 30, 40), (30, 40), fill=np.nan) is full


def test_flow_colour_wheel():
    flow = np.array([[[1.0, 0.0], [0.0, 1.0], [-2.0, 0.0], [np.nan, 0.0]]], np.float32)
    rgb = flow_to_rgb(flow, max_flow_px=2.0)
    assert rgb.shape == (1, 4, 3) and rgb.dtype == np.uint8
    assert rgb[0, 0, 0] > 100 and rgb[0, 0, 1] < 5 and rgb[0, 0, 2] < 5  # +u: red, half value
    assert rgb[0, 2, 0] < 5 and rgb[0, 2, 1] == 255 and rgb[0, 2, 2] == 255  # -u: cyan, full
    assert rgb[0, 1, 0] > rgb[0, 1, 2]  # +v (90 deg): yellow-green-ish, not blue
    np.testing.assert_array_equal(rgb[0, 3], [0, 0, 0])
