from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.errors import ImageFormatError, ShapeError
from hand_tracker_ros.vision.edges import (
    EdgeConfig,
    compute_edges,
    nearest_edges,
    orientation_compatibility,
)
from hand_tracker_ros.vision.image import to_gray


def _brute_force(edges: np.ndarray, uv: np.ndarray) -> np.ndarray:
    rows, cols = np.nonzero(edges)
    d = np.hypot(uv[:, None, 0] - cols[None, :], uv[:, None, 1] - rows[None, :])
    return d.min(axis=1)


def test_nearest_edges_matches_brute_force(scene, rng):
    image, _ = scene((70, 55))
    edge_map = compute_edges(to_gray(image), EdgeConfig())
    assert 50 < edge_map.edges.sum() < edge_map.edges.size // 2
    h, w = edge_map.shape
    uv = np.column_stack([rng.integers(0, w, 2000), rng.integers(0, h, 2000)]).astype(float)
    edge_uv, dist, theta = nearest_edges(edge_map, uv)
    # The returned pixel is an edge pixel, the distance is to it, and it is (nearly) nearest:
    # the 5x5 chamfer label propagation is within 0.5 px + 4% of the exact nearest distance.
    assert np.all(edge_map.edges[edge_uv[:, 1].astype(int), edge_uv[:, 0].astype(int)])
    np.testing.assert_allclose(dist, np.hypot(*(uv - edge_uv).T))
    true = _brute_force(edge_map.edges, uv)
    excess = dist - true
    assert excess.min() >= -1e-9
    assert np.all(excess <= 0.5 + 0.04 * true)
    assert np.mean(excess < 1e-9) > 0.8
    np.testing.assert_allclose(edge_map.distance_px[uv[:, 1].astype(int), uv[:, 0].astype(int)],
                               true, rtol=0.04, atol=0.5)
    np.testing.assert_array_equal(
        theta, edge_map.orientation_rad[edge_uv[:, 1].astype(int), edge_uv[:, 0].astype(int)])


def test_subpixel_and_out_of_image_queries():
    gray = np.zeros((40, 50), dtype=np.uint8)
    gray[:, 25:] = 200  # vertical step edge between columns 24 and 25
    edge_map = compute_edges(gray, EdgeConfig(blur_sigma_px=0.0))
    cols = np.unique(np.nonzero(edge_map.edges)[1])
    assert set(cols) <= {24, 25}
    uv = np.array([[10.4, 20.0], [-30.0, 20.0], [40.0, 100.0]])
    edge_uv, dist, theta = nearest_edges(edge_map, uv)
    assert edge_uv[0, 0] == cols.min() and edge_uv[0, 1] == 20.0
    assert dist[0] == pytest.approx(cols.min() - 10.4)
    # Clamped lookup, true distance from the unclamped query.
    assert edge_uv[1, 1] == 20.0 and dist[1] == pytest.approx(cols.min() + 30.0)
    assert edge_uv[2, 1] == 39.0 and dist[2] == pytest.approx(np.hypot(40 - edge_uv[2, 0], 61))
    # Dark-to-bright along +u: the gradient (normal) points along +u, angle 0 (mod 2 pi).
    assert np.all(np.minimum(theta, 2 * np.pi - theta) < 1e-3)


def test_edge_free_image_returns_nan_and_inf():
    edge_map = compute_edges(np.full((10, 12), 80, np.uint8), EdgeConfig())
    assert edge_map.edge_uv_px.shape == (0, 2)
    edge_uv, dist, theta = nearest_edges(edge_map, np.array([[1.0, 2.0]]))
    assert np.all(np.isnan(edge_uv)) and np.isinf(dist[0]) and np.isnan(theta[0])


def test_compute_edges_is_deterministic_and_typed(scene):
    gray = to_gray(scene()[0])
    a, b = compute_edges(gray, EdgeConfig()), compute_edges(gray, EdgeConfig())
    for name in ('edges', 'orientation_rad', 'distance_px', 'labels', 'edge_uv_px'):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.edges.dtype == bool and a.orientation_rad.dtype == np.float32
    assert a.distance_px.dtype == np.float32 and a.edge_uv_px.dtype == np.int32
    assert a.orientation_rad.min() >= 0.0 and a.orientation_rad.max() < 2 * np.pi + 1e-6


def test_boundary_errors(scene):
    with pytest.raises(ImageFormatError, match=r'gray: expected an \(H, W\) uint8'):
        compute_edges(scene()[0], EdgeConfig())
    edge_map = compute_edges(to_gray(scene()[0]), EdgeConfig())
    with pytest.raises(ShapeError, match=r'`uv_px` must be \(\*, 2\), got \(3, 3\)'):
        nearest_edges(edge_map, np.zeros((3, 3)))
    with pytest.raises(ShapeError, match=r'`uv_px` holds 1 non-finite'):
        nearest_edges(edge_map, np.array([[1.0, np.nan]]))


def test_orientation_compatibility():
    a = np.array([0.0, 0.0, 0.0, 1.0])
    b = np.array([0.0, np.pi, np.pi / 2, 1.0 + np.pi / 3])
    np.testing.assert_allclose(orientation_compatibility(a, b), [1.0, 1.0, 0.0, 0.5],
                               atol=1e-12)
