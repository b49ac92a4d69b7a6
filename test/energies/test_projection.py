"""Projected-vertex residual rows: values, Jacobian vs central differences, empty blocks."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from hand_tracker_ros.energies._projection import (ImageTargets, image_linearize,
                                                   image_residuals, project_vertices)
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.geometry.transforms import look_at

_P = 4
_RNG_SEED = 7


def _camera() -> PinholeCamera:
    K = np.array([[300.0, 0.0, 160.0], [0.0, 310.0, 120.0], [0.0, 0.0, 1.0]])
    dist = np.array([-0.1, 0.02, 0.001, -0.002, 0.0])
    return PinholeCamera('cam', 320, 240, K, dist, look_at(np.array([0.1, -0.4, 0.2]),
                                                           np.zeros(3)))


class _Stub:
    """Smooth vertices X_i(theta) = B_i + 0.05 sin(A_i theta) with their analytic Jacobian."""

    def __init__(self, n_vertices: int) -> None:
        rng = np.random.default_rng(_RNG_SEED)
        self.base = rng.uniform(-0.05, 0.05, (n_vertices, 3))
        self.A = rng.normal(0.0, 1.0, (n_vertices, 3, _P))

    def pose(self, theta: np.ndarray) -> SimpleNamespace:
        arg = np.einsum('vip,p->vi', self.A, theta)
        return SimpleNamespace(theta=theta, vertices_m=self.base + 0.05 * np.sin(arg),
                               vertices_jac=0.05 * np.cos(arg)[..., None] * self.A)


def _blocks(camera: PinholeCamera, line: bool) -> list[ImageTargets]:
    rng = np.random.default_rng(_RNG_SEED)
    ids = np.array([0, 3, 3, 5])
    normals = rng.normal(size=(4, 2))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return [ImageTargets(camera, ids, rng.uniform(100, 200, (4, 2)), rng.uniform(0.5, 2, 4),
                         normals if line else None)]


@pytest.mark.parametrize('line', [False, True])
def test_jacobian_matches_central_differences(line: bool) -> None:
    stub, camera = _Stub(6), _camera()
    blocks = _blocks(camera, line)
    theta = np.array([0.3, -0.2, 0.5, 0.1])
    r, J = image_linearize(stub.pose(theta), blocks)
    assert r.shape == (4 if line else 8,) and J.shape == (r.size, _P)
    np.testing.assert_allclose(r, image_residuals(stub.pose(theta), blocks))
    h = 1e-6
    numeric = np.column_stack([
        (image_residuals(stub.pose(theta + h * e), blocks)
         - image_residuals(stub.pose(theta - h * e), blocks)) / (2 * h) for e in np.eye(_P)])
    np.testing.assert_allclose(J, numeric, rtol=1e-5, atol=1e-6 * np.abs(J).max())


def test_row_values_are_weighted_point_and_line_offsets() -> None:
    stub, camera = _Stub(6), _camera()
    posed = stub.pose(np.zeros(_P))
    point, line = _blocks(camera, False)[0], _blocks(camera, True)[0]
    uv, _ = camera.project(posed.vertices_m[point.vertex_ids])
    diff = uv - point.targets_px
    np.testing.assert_allclose(image_residuals(posed, [point]),
                               (point.sqrt_weights[:, None] * diff).ravel())
    np.testing.assert_allclose(image_residuals(posed, [line]),
                               line.sqrt_weights * np.sum(line.normals_px * diff, axis=1))


def test_project_vertices_chains_camera_and_pose_jacobians() -> None:
    stub, camera = _Stub(3), _camera()
    posed = stub.pose(np.array([0.1, 0.2, 0.3, 0.4]))
    uv, duv = project_vertices(camera, posed, np.array([2, 0]))
    _, _, duv_dX = camera.project_jacobian(posed.vertices_m[[2, 0]])
    np.testing.assert_allclose(duv[1], duv_dX[1] @ posed.vertices_jac[0])
    uv_only, none = project_vertices(camera, posed, np.array([2, 0]), jacobian=False)
    assert none is None
    np.testing.assert_allclose(uv_only, uv)


def test_empty_blocks_give_empty_rows() -> None:
    stub, camera = _Stub(2), _camera()
    posed = stub.pose(np.zeros(_P))
    empty = ImageTargets(camera, np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0),
                         np.zeros((0, 2)))
    for blocks in ([], [empty]):
        r, J = image_linearize(posed, blocks)
        assert r.shape == (0,) and J.shape == (0, _P)
        assert image_residuals(posed, blocks).shape == (0,)


def test_targets_reject_inconsistent_shapes() -> None:
    camera = _camera()
    with pytest.raises(ShapeError, match='targets_px'):
        ImageTargets(camera, np.zeros(3, np.int64), np.zeros((2, 2)), np.ones(3))
    with pytest.raises(ShapeError, match='normals_px'):
        ImageTargets(camera, np.zeros(2, np.int64), np.zeros((2, 2)), np.ones(2),
                     np.zeros((3, 2)))
    with pytest.raises(ShapeError, match='sqrt_weights'):
        ImageTargets(camera, np.zeros(2, np.int64), np.zeros((2, 2)), np.array([1.0, np.nan]))
