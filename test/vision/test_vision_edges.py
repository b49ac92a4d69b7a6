from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.errors import ImageFormatError, ShapeError
from hand_tracker_ros.vision.edges import (
    EdgeConfig,
    EdgeMap,
    compute_edges,
    edges_within,
    orientation_compatibility,
)
from hand_tracker_ros.vision.image import to_gray


def _brute_force(edges: np.ndarray, uv: np.ndarray, offset=(0, 0)) -> np.ndarray:
    """(N,) float64 exact distance from each query to the nearest edge pixel centre."""
    rows, cols = np.nonzero(edges)
    d = np.hypot(uv[:, None, 0] - cols[None, :] - offset[0],
                 uv[:, None, 1] - rows[None, :] - offset[1])
    return d.min(axis=1) if d.shape[1] else np.full(len(uv), np.inf)


@pytest.mark.parametrize('radius', [0.0, 1.0, 2.0, 3.5])
def test_edges_within_matches_brute_force(scene, rng, radius):
    image, _ = scene((70, 55))
    edge_map = compute_edges(to_gray(image), EdgeConfig())
    assert 50 < edge_map.edges.sum() < edge_map.edges.size // 2
    h, w = edge_map.shape
    # Sub-pixel queries, some outside the map, and some on edge pixel centres.
    uv = np.column_stack([rng.uniform(-5, w + 5, 3000), rng.uniform(-5, h + 5, 3000)])
    rows, cols = np.nonzero(edge_map.edges)
    uv[:200] = np.column_stack([cols[:200], rows[:200]])
    near = edges_within(edge_map, uv, radius)
    np.testing.assert_array_equal(near, _brute_force(edge_map.edges, uv) <= radius)
    assert 0.05 < near.mean() < 0.95 or radius == 0.0


def test_edges_within_a_region_of_interest_uses_full_image_coordinates():
    edges = np.zeros((10, 20), bool)
    edges[4, 7] = True
    roi_map = EdgeMap(edges, np.zeros(edges.shape, np.float32), offset_uv_px=(30, 50))
    uv = np.array([[37.0, 54.0], [39.0, 54.0], [37.5, 55.5], [7.0, 4.0], [36.0, 56.5]])
    np.testing.assert_array_equal(edges_within(roi_map, uv, 2.0),
                                  [True, True, True, False, False])
    np.testing.assert_array_equal(edges_within(roi_map, uv, 2.0),
                                  _brute_force(edges, uv, (30, 50)) <= 2.0)


def test_subpixel_step_edge_and_its_orientation():
    gray = np.zeros((40, 50), dtype=np.uint8)
    gray[:, 25:] = 200  # vertical step edge between columns 24 and 25
    edge_map = compute_edges(gray, EdgeConfig(blur_sigma_px=0.0))
    cols = np.unique(np.nonzero(edge_map.edges)[1])
    assert set(cols) <= {24, 25}
    near = cols.min() - 2.0
    np.testing.assert_array_equal(
        edges_within(edge_map, np.array([[near, 20.0], [near - 0.01, 20.0]]), 2.0),
        [True, False])
    # Dark-to-bright along +u: the gradient (normal) points along +u, angle 0 (mod 2 pi).
    theta = edge_map.orientation_rad[edge_map.edges]
    assert np.all(np.minimum(theta, 2 * np.pi - theta) < 1e-3)


def test_edge_free_image_has_no_edge_near_anything():
    edge_map = compute_edges(np.full((10, 12), 80, np.uint8), EdgeConfig())
    assert not edge_map.edges.any()
    assert not edges_within(edge_map, np.array([[1.0, 2.0]]), 5.0).any()


def test_compute_edges_is_deterministic_and_typed(scene):
    gray = to_gray(scene()[0])
    a, b = compute_edges(gray, EdgeConfig()), compute_edges(gray, EdgeConfig())
    for name in ('edges', 'orientation_rad'):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.edges.dtype == bool and a.orientation_rad.dtype == np.float32
    assert a.orientation_rad.min() >= 0.0 and a.orientation_rad.max() < 2 * np.pi + 1e-6


def test_boundary_errors(scene):
    with pytest.raises(ImageFormatError, match=r'gray: expected an \(H, W\) uint8'):
        compute_edges(scene()[0], EdgeConfig())
    edge_map = compute_edges(to_gray(scene()[0]), EdgeConfig())
    with pytest.raises(ShapeError, match=r'`uv_px` must be \(\*, 2\), got \(3, 3\)'):
        edges_within(edge_map, np.zeros((3, 3)), 2.0)
    with pytest.raises(ShapeError, match=r'`uv_px` holds 1 non-finite'):
        edges_within(edge_map, np.array([[1.0, np.nan]]), 2.0)


def test_orientation_compatibility():
    a = np.array([0.0, 0.0, 0.0, 1.0])
    b = np.array([0.0, np.pi, np.pi / 2, 1.0 + np.pi / 3])
    np.testing.assert_allclose(orientation_compatibility(a, b), [1.0, 1.0, 0.0, 0.5],
                               atol=1e-12)
