"""Projected-vertex residual rows: values, Jacobian vs central differences, empty blocks."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from hand_tracker_ros.energies._projection import ImageTargets, image_linearize, image_residuals
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


@pytest.mark.parametrize('line', [False, True])
def test_fused_rows_match_camera_jacobian_chain_rule(line: bool) -> None:
    """The numba rows equal the reference: project_jacobian, then (normal and) pose chain rule."""
    stub, camera = _Stub(6), _camera()
    posed = stub.pose(np.array([0.1, 0.2, 0.3, 0.4]))
    block = _blocks(camera, line)[0]
    uv, _, duv_dX = camera.project_jacobian(posed.vertices_m[block.vertex_ids])
    duv = np.einsum('nij,njp->nip', duv_dX, posed.vertices_jac[block.vertex_ids])
    s = block.sqrt_weights
    if line:
        n = block.normals_px
        r_ref = s * np.sum(n * (uv - block.targets_px), axis=1)
        J_ref = s[:, None] * np.einsum('ni,nip->np', n, duv)
    else:
        r_ref = (s[:, None] * (uv - block.targets_px)).ravel()
        J_ref = (s[:, None, None] * duv).reshape(-1, _P)
    r, J = image_linearize(posed, [block])
    np.testing.assert_allclose(r, r_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(J, J_ref, rtol=1e-12, atol=1e-12 * np.abs(J_ref).max())


def test_points_behind_the_camera_give_nan_rows() -> None:
    stub, camera = _Stub(6), _camera()
    posed = stub.pose(np.zeros(_P))
    behind = 2.0 * camera.center_world - posed.vertices_m[3]
    posed.vertices_m[3] = behind
    r, J = image_linearize(posed, _blocks(camera, True))
    assert np.isnan(r[1:3]).all() and np.isfinite(r[[0, 3]]).all()
    assert np.isnan(J[1:3]).all()


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


class _OtherModel:
    """A camera that is not a PinholeCamera (the Camera protocol only): the generic path."""

    def __init__(self, camera: PinholeCamera) -> None:
        self._camera = camera

    def __getattr__(self, name: str):
        return getattr(self._camera, name)


@pytest.mark.parametrize('line', [False, True])
def test_any_camera_model_gives_the_pinhole_rows(line: bool) -> None:
    """The rows through ``Camera.project_jacobian`` equal the fused pinhole kernel's."""
    stub, camera = _Stub(6), _camera()
    posed = stub.pose(np.array([0.1, 0.2, 0.3, 0.4]))
    fused = _blocks(camera, line)
    generic = [ImageTargets(_OtherModel(b.camera), b.vertex_ids, b.targets_px, b.sqrt_weights,
                            b.normals_px) for b in fused]
    r, J = image_linearize(posed, fused)
    r_any, J_any = image_linearize(posed, generic)
    np.testing.assert_allclose(r_any, r, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(J_any, J, rtol=1e-10, atol=1e-10 * np.abs(J).max())
    np.testing.assert_allclose(image_residuals(posed, generic), r, rtol=1e-12, atol=1e-12)
